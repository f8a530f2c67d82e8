# SPDX-License-Identifier: Apache-2.0
"""The PC side of commissioning: CANopen over python-can with the ``canopen``
library (any adapter python-can knows).

``scan`` finds the nodes on a bus and reads their device type and identity;
``configure`` writes a drive's configuration (:mod:`.plan`) by SDO, in NMT
pre-operational, and reads every final value back. Errors come out as
:class:`DriveError` with a message that names the node, the object and the
SDO abort code's meaning; nothing here lets a library exception through.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from . import objects as ob
from .plan import Write

#: Abort codes after which an optional write is skipped: the drive lacks the object.
ABSENT_CODES = (0x06020000, 0x06090011)
#: Abort code of a write to a read-only object: an optional one is then read and compared.
READ_ONLY_CODE = 0x06010002


class DriveError(Exception):
    """A commissioning step failed; the message says which and why."""


def open_network(opts):
    """A connected ``canopen.Network`` on the python-can bus of the bus
    options (:mod:`stewart.busopts`); DriveError when the adapter cannot be
    opened (unknown interface, missing channel, no driver)."""
    import can
    import canopen

    from .. import busopts

    try:
        kwargs = busopts.resolve(opts)
    except busopts.BusError as exc:
        raise DriveError(str(exc)) from None
    interface, channel = kwargs["interface"], kwargs.get("channel")
    net = canopen.Network()
    try:
        net.connect(**kwargs)
    except can.exceptions.CanInterfaceNotImplementedError as exc:
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        raise DriveError(f"cannot open CAN interface {interface!r}: {exc} (python-can interfaces: {known})") from None
    except (can.CanError, OSError, ValueError, ImportError, TypeError) as exc:
        raise DriveError(f"cannot open CAN interface {interface!r} channel {channel!r}: "
                         f"{type(exc).__name__}: {exc}") from None
    return net


def close_network(net) -> None:
    try:
        net.disconnect()
    except Exception:  # noqa: BLE001 - closing is best effort
        pass


def _abort_text(exc) -> str:
    code = getattr(exc, "code", None)
    if code is None:
        return str(exc)
    import canopen

    meaning = canopen.SdoAbortedError.CODES.get(code, "abort code not in CiA 301's table")
    return f"SDO abort 0x{code:08X} ({meaning})"


@dataclass
class NodeInfo:
    node_id: int
    device_type: int | None = None
    vendor_id: int | None = None
    product_code: int | None = None
    revision: int | None = None
    serial: int | None = None
    problems: list[str] = field(default_factory=list)

    @property
    def profile_text(self) -> str:
        if self.device_type is None:
            return "?"
        number = self.device_type & 0xFFFF
        known = {408: "CiA 408 fluid power", 402: "CiA 402 drive"}.get(number, f"profile {number}")
        return f"{known} (0x{self.device_type:08X})"


def _read_u32(node, index: int, sub: int) -> int:
    data = node.sdo.upload(index, sub)
    return int.from_bytes(data[:4].ljust(4, b"\0"), "little")


def scan(net, wait_s: float = 0.5, limit: int = 127) -> list[NodeInfo]:
    """The nodes that answer an SDO read of 0x1000 (or that sent anything a
    node sends) within ``wait_s``, with their identity."""
    import canopen

    net.scanner.reset()
    net.scanner.search(limit)
    time.sleep(wait_s)
    found = sorted(set(net.scanner.nodes))
    out = []
    for node_id in found:
        info = NodeInfo(node_id)
        node = canopen.RemoteNode(node_id, canopen.ObjectDictionary())
        net.add_node(node)
        try:
            for attr, index, sub in (("device_type", 0x1000, 0), ("vendor_id", 0x1018, 1),
                                     ("product_code", 0x1018, 2), ("revision", 0x1018, 3),
                                     ("serial", 0x1018, 4)):
                try:
                    setattr(info, attr, _read_u32(node, index, sub))
                except canopen.SdoAbortedError as exc:
                    info.problems.append(f"0x{index:04X}.{sub}: {_abort_text(exc)}")
                except canopen.SdoCommunicationError as exc:
                    info.problems.append(f"0x{index:04X}.{sub}: no SDO answer ({exc})")
                    break
        finally:
            del net[node_id]
        out.append(info)
    return out


def _encode(w: Write) -> bytes:
    nbytes = ob.TYPE_BITS[w.datatype] // 8
    return int(w.value).to_bytes(nbytes, "little", signed=w.datatype in ob.SIGNED_TYPES)


def _decode(w: Write, data: bytes) -> int:
    nbytes = ob.TYPE_BITS[w.datatype] // 8
    return int.from_bytes(data[:nbytes].ljust(nbytes, b"\0"), "little", signed=w.datatype in ob.SIGNED_TYPES)


def _read(node, node_id: int, w: Write) -> int:
    import canopen

    try:
        return _decode(w, node.sdo.upload(w.index, w.subindex))
    except canopen.SdoAbortedError as exc:
        raise DriveError(f"node {node_id}: reading back {w.key}: {_abort_text(exc)}") from None
    except canopen.SdoCommunicationError as exc:
        raise DriveError(f"node {node_id}: no SDO answer reading back {w.key}: {exc}") from None


#: CiA 402's motor rated torque (mN m) or, for a linear motor, force (mN).
RATED_TORQUE = (0x6076, 0)


def read_rated(net, node_id: int) -> int | None:
    """A CiA 402 drive's 0x6076 (UNSIGNED32): the torque or force that its
    0x60B2 torque/force offset counts in per mille of; None when the drive
    has no such object. Raises DriveError on another abort or no answer."""
    import canopen

    node = canopen.RemoteNode(node_id, canopen.ObjectDictionary())
    net.add_node(node)
    try:
        data = node.sdo.upload(*RATED_TORQUE)
    except canopen.SdoAbortedError as exc:
        if exc.code in ABSENT_CODES:
            return None
        raise DriveError(f"node {node_id}: reading 0x6076.0 (rated torque/force): {_abort_text(exc)}") from None
    except canopen.SdoCommunicationError as exc:
        raise DriveError(f"node {node_id}: no SDO answer reading 0x6076.0 (rated torque/force): {exc}") from None
    finally:
        del net[node_id]
    return int.from_bytes(data[:4].ljust(4, b"\0"), "little")


def rated_note(rated: int | None, rated_force_n: float) -> str:
    """What a commissioning engineer should compare: the drive's 0x6076
    against the config's scaling.rated_force (N along the leg at 0x60B2's
    1000 per mille). They agree to the letter for a linear motor on the leg
    (mN); for a rotary motor (mN m) only through the leg's screw."""
    config_mn = rated_force_n * 1000.0
    if rated is None:
        return ("the drive has no 0x6076 (rated torque/force): check scaling.rated_force "
                f"({rated_force_n:g} N along the leg at 1000 per mille of 0x60B2) against its manual")
    if rated == 0:
        return ("0x6076 = 0: the drive gives no rated torque/force, so what its 0x60B2 counts in is "
                "not known; check its manual")
    if abs(rated - config_mn) <= 0.5:
        return (f"0x6076 = {rated} equals scaling.rated_force ({rated_force_n:g} N along the leg) in mN: "
                "right for a linear motor on the leg")
    return (f"0x6076 = {rated} (the motor's rated torque in mN m, or force in mN for a linear motor) "
            f"is not scaling.rated_force ({rated_force_n:g} N along the leg = {config_mn:g} mN): right only "
            "if the leg's screw turns the one into the other; for a linear motor the force feed-forward "
            f"would be off by a factor {config_mn / rated:.4g}")


@dataclass
class ConfigResult:
    node_id: int
    written: list[Write] = field(default_factory=list)
    skipped: list[Write] = field(default_factory=list)     # optional, the drive has no such object
    fixed: list[Write] = field(default_factory=list)       # optional, read-only and already right
    readback: list[tuple[Write, int]] = field(default_factory=list)


def configure(net, node_id: int, writes: list[Write], nmt_pre_operational: bool = True) -> ConfigResult:
    """Writes ``writes`` to node ``node_id`` by SDO and reads the final values
    back. Raises DriveError naming the node and object on an abort, a silent
    node or a read-back that differs."""
    import canopen

    node = canopen.RemoteNode(node_id, canopen.ObjectDictionary())
    net.add_node(node)
    res = ConfigResult(node_id)
    try:
        if nmt_pre_operational:
            node.nmt.send_command(ob.NMT_PRE_OPERATIONAL)
        for w in writes:
            try:
                node.sdo.download(w.index, w.subindex, _encode(w))
                res.written.append(w)
            except canopen.SdoAbortedError as exc:
                if w.optional and exc.code in ABSENT_CODES:
                    res.skipped.append(w)
                    continue
                if w.optional and exc.code == READ_ONLY_CODE:
                    got = _read(node, node_id, w)
                    if got != w.value:
                        raise DriveError(f"node {node_id}: {w.key} is read-only and holds {got}; the config "
                                         f"needs {w.value_text()} ({w.purpose})") from None
                    res.fixed.append(w)
                    continue
                raise DriveError(f"node {node_id}: writing {w.key} = {w.value_text()} ({w.purpose}): "
                                 f"{_abort_text(exc)}") from None
            except canopen.SdoCommunicationError as exc:
                raise DriveError(f"node {node_id}: no SDO answer writing {w.key} ({w.purpose}): {exc}") from None
        finals: dict[tuple[int, int], Write] = {}
        for w in res.written:
            if w.final:
                finals[(w.index, w.subindex)] = w
        for w in finals.values():
            got = _read(node, node_id, w)
            res.readback.append((w, got))
            if got != w.value:
                raise DriveError(f"node {node_id}: read back {w.key} = {got}, wrote {w.value_text()} "
                                 f"({w.purpose})")
    finally:
        del net[node_id]
    return res
