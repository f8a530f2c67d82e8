# SPDX-License-Identifier: Apache-2.0
"""The plant's CiA 408 node (hs/co_node.h) driven from the ``canopen`` library (issue 18).

The node is the plant's C code (``libhs_co.so`` of the host-release build,
over ctypes), served by one thread that moves frames between python-can's
``virtual`` bus and the node and advances its clock every millisecond. The
other side is the ``canopen`` library, an implementation we did not write,
as NMT master and SDO client, and our PC tool ``stewart drives config``
built on it.

- The library sees the boot-up, reads the identity and device type by SDO,
  and gets the EDS's values.
- ``stewart drives config`` writes the controller's plan into the node and
  reads it back: all equal; the node's dictionary holds the values.
- An abort: a write to a read-only object, a missing object, each the CiA
  301 abort code through the library.
- NMT start, heartbeat from 0x1017 seen by the library's heartbeat
  consumer; PDOs: the library's RPDO (control word 0x0007 + setpoint) and
  SYNC walk the node DISABLED -> HOLD -> ACTIVE, its TPDO1 (read by the
  library from the node's own mapping) shows status 0x000F and the actual.
- EMCY on a raised fault, received by the library's EMCY consumer.

The same node as a CiA 402 drive (``hs_co_node_init_profile``, the EDS
config/eds/stewart_sim_drive_402.eds):

- the library reads the 402 objects by SDO (device type 402, modes of
  operation and its display, supported drive modes, interpolation period);
- ``stewart drives config`` writes the cia402 plan and reads it back;
- the library as master walks the node through shutdown, switch on,
  enable operation by its RPDO1 controlword and SYNC, and decodes each
  TPDO1 statusword with its own CiA 402 state table
  (``canopen.profiles.p402.State402``): READY TO SWITCH ON, SWITCHED ON,
  OPERATION ENABLED; the target position is applied; quick stop and fault
  reset likewise.
- every object of the 402 EDS is in the node with its default.
"""

from __future__ import annotations

import ctypes as C
import itertools
import threading
import time
from pathlib import Path

import can
import canopen
import pytest

from stewart import cli, core

REPO_ROOT = Path(__file__).resolve().parents[2]

EDS = REPO_ROOT / "config" / "eds" / "stewart_sim_drive.eds"
EDS402 = REPO_ROOT / "config" / "eds" / "stewart_sim_drive_402.eds"
DEFAULT = REPO_ROOT / "config" / "platform_default.json"
LIB = REPO_ROOT / "build" / "host-release" / "host_sim" / "libhs_co.so"
_channels = itertools.count()
NODE = 5
BUS = 1  # axis_a
MAX_TX = 4


class Frame(C.Structure):
    _fields_ = [("id", C.c_uint32), ("bus", C.c_uint8), ("len", C.c_uint8), ("flags", C.c_uint8),
                ("data", C.c_uint8 * 64)]


class Entry(C.Structure):
    _fields_ = [("index", C.c_uint16), ("sub", C.c_uint8), ("size", C.c_uint8), ("access", C.c_uint8),
                ("value", C.c_uint32)]


@pytest.fixture(scope="module")
def H():
    try:
        core.lib()  # the core library it links, with its layout check
    except core.CoreError as e:
        pytest.skip(str(e))
    if not LIB.exists():
        pytest.skip(f"{LIB} not found: build it with `scripts/build.sh host-release`")
    h = C.CDLL(str(LIB))
    P = C.POINTER
    h.hs_co_node_init.argtypes = [C.c_void_p, C.c_uint8, C.c_uint8]
    h.hs_co_node_init_profile.argtypes = [C.c_void_p, C.c_uint8, C.c_uint8, C.c_uint8]
    h.hs_co_node_receive.argtypes = [C.c_void_p, P(Frame), P(Frame * MAX_TX), P(C.c_uint8)]
    h.hs_co_node_tick.argtypes = [C.c_void_p, C.c_uint32, P(Frame * MAX_TX), P(C.c_uint8)]
    h.hs_co_node_raise.argtypes = [C.c_void_p, C.c_uint16]
    h.hs_co_node_find.argtypes = [C.c_void_p, C.c_uint16, C.c_uint8]
    h.hs_co_node_find.restype = P(Entry)
    h.hs_co_node_follows.argtypes = [C.c_void_p]
    return h


class PlantNode:
    """One hs_co_node on a virtual channel, served by one thread (the only caller of the node)."""

    def __init__(self, H, node_id=NODE, profile=0):
        self.H = H
        self.channel = f"stewart-co-plant-{next(_channels)}"
        self.node = C.create_string_buffer(16384)
        assert H.hs_co_node_init_profile(self.node, node_id, BUS, profile) == 0
        self.bus = can.Bus(interface="virtual", channel=self.channel)
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _send(self, tx, n):
        for f in tx[: n.value]:
            self.bus.send(can.Message(arbitration_id=f.id, data=bytes(f.data[: f.len]), is_extended_id=False))

    def _serve(self):
        tx, n = (Frame * MAX_TX)(), C.c_uint8()
        last = time.monotonic()
        while not self.stop.is_set():
            msg = self.bus.recv(0.0005)
            with self.lock:
                if msg is not None and not msg.is_remote_frame:
                    f = Frame(id=msg.arbitration_id, bus=BUS, len=msg.dlc)
                    for i, b in enumerate(msg.data):
                        f.data[i] = b
                    self.H.hs_co_node_receive(self.node, C.byref(f), C.byref(tx), C.byref(n))
                    self._send(tx, n)
                now = time.monotonic()
                ms = int((now - last) * 1000)
                if ms >= 1:
                    last += ms / 1000.0
                    self.H.hs_co_node_tick(self.node, min(ms, 1000), C.byref(tx), C.byref(n))
                    self._send(tx, n)

    def value(self, index, sub) -> int:
        with self.lock:
            e = self.H.hs_co_node_find(self.node, index, sub)
            return e.contents.value if e else None

    def raise_fault(self, code):
        with self.lock:
            assert self.H.hs_co_node_raise(self.node, code) == 0

    def close(self):
        self.stop.set()
        self.thread.join(2.0)
        self.bus.shutdown()


@pytest.fixture
def plant(H):
    p = PlantNode(H)
    yield p
    p.close()


@pytest.fixture
def net(plant):
    n = canopen.Network()
    n.connect(interface="virtual", channel=plant.channel)
    yield n
    n.disconnect()


@pytest.fixture
def plant402(H):
    p = PlantNode(H, profile=1)
    yield p
    p.close()


@pytest.fixture
def net402(plant402):
    n = canopen.Network()
    n.connect(interface="virtual", channel=plant402.channel)
    yield n
    n.disconnect()


def _remote(net):
    node = canopen.RemoteNode(NODE, canopen.import_od(str(EDS), NODE))
    net.add_node(node)
    return node


def test_library_reads_identity_and_device_type(net, plant):
    node = _remote(net)
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(2.0)
    assert node.sdo[0x1000].raw == 0x198
    assert node.sdo[0x1018][2].raw == 0x5348
    assert node.sdo[0x6043].raw == 8
    assert node.sdo[0x6601][3].raw == -6


def test_library_sees_the_named_abort_codes(net, plant):
    node = _remote(net)
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(2.0)
    with pytest.raises(canopen.SdoAbortedError) as e:
        node.sdo.download(0x1000, 0, b"\x00\x00\x00\x00")
    assert e.value.code == 0x06010002  # read only
    with pytest.raises(canopen.SdoAbortedError) as e:
        node.sdo.upload(0x3000, 0)
    assert e.value.code == 0x06020000  # no such object
    with pytest.raises(canopen.SdoAbortedError) as e:
        node.sdo.upload(0x1018, 9)
    assert e.value.code == 0x06090011  # no such sub-index
    with pytest.raises(canopen.SdoAbortedError) as e:
        node.sdo.download(0x1600, 1, b"\x10\x00\x40\x60")  # mapping while RPDO1 is valid
    assert e.value.code == 0x06010000


def test_stewart_drives_config_writes_the_plant_node(plant, tmp_path, capsys):
    import json

    from stewart import config
    from stewart.drives import plan

    d = json.loads(DEFAULT.read_text())
    legs = [{"protocol": "cia408", "bus": "can_a" if i < 3 else "can_b", "node_id": NODE + i % 3,
             "scaling": {"position_per_count": 1e-6, "length_at_zero": 1.85}} for i in range(6)]
    d["drives"] = {"buses": {"can_a": {"bitrate": 1000000}, "can_b": {"bitrate": 1000000}},
                   "sync_divider": 3, "legs": legs}
    path = tmp_path / "platform_cia408.json"
    path.write_text(json.dumps(d))
    time.sleep(0.05)  # the node's boot-up
    args = ["drives", "config", "--config", str(path), "--bus", "can_a", "--node", str(NODE),
            "--interface", "virtual", "--channel", plant.channel]
    assert cli.main(args) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    drives = config.load(path).drives
    writes = plan.drive_writes(drives.legs[0], drives)
    finals = [w for w in writes if w.final]
    assert f"wrote {len(writes)} objects, read back {len(finals)}: all equal" in out
    for w in finals:
        size = {1: 1, 2: 1, 3: 2, 4: 4, 5: 1, 6: 2, 7: 4}[w.datatype]
        assert plant.value(w.index, w.subindex) == w.value & ((1 << (8 * size)) - 1), w.purpose


def test_library_master_runs_the_node_to_active(net, plant, H):
    node = _remote(net)
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(2.0)
    node.sdo[0x1017].raw = 20
    node.tpdo.read()  # the node's own mapping, by SDO
    node.rpdo.read()
    assert node.tpdo[1].map[0].index == 0x6041 and node.tpdo[1].map[1].index == 0x6601
    node.nmt.state = "OPERATIONAL"
    node.nmt.wait_for_heartbeat(1.0)
    assert node.nmt.state == "OPERATIONAL"
    node.rpdo[1]["Device control word"].raw = 0x0007
    node.rpdo[1]["Axis position setpoint.Setpoint"].raw = 4321
    for _ in range(6):  # INIT -> DISABLED -> HOLD -> ACTIVE, one state per SYNC
        node.rpdo[1].transmit()
        net.sync.transmit()
        node.tpdo[1].wait_for_reception(1.0)
    assert node.tpdo[1]["Device status word"].raw & 0xF == 0xF
    assert node.sdo[0x6600][1].raw == 4321
    with plant.lock:
        assert H.hs_co_node_follows(plant.node) == 1


def test_library_receives_the_emcy(net, plant):
    node = _remote(net)
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(2.0)
    plant.raise_fault(0x4210)
    err = node.emcy.wait(0x4210, 1.0)
    assert err is not None and err.code == 0x4210
    assert node.sdo[0x1001].raw == 0x01


def _eds_variables(eds=EDS):
    import configparser
    import re

    c = configparser.ConfigParser(strict=False)
    c.optionxform = str
    c.read(eds)
    for name in c.sections():
        m = re.fullmatch(r"([0-9A-F]{4})(?:sub([0-9A-F]+))?", name)
        if not m or "DataType" not in c[name]:
            continue
        s = c[name]
        yield (int(m[1], 16), int(m[2] or "0", 16), int(s["DataType"], 16), s["AccessType"],
               s.get("DefaultValue", "0"))


@pytest.mark.parametrize("eds,profile", [(EDS, 0), (EDS402, 1)])
def test_the_plant_node_has_the_eds_dictionary(H, eds, profile):
    """Every object of the EDS (but the three strings) is in the node, with
    the EDS's size, access and default: the EDS describes this drive."""
    node = C.create_string_buffer(16384)
    assert H.hs_co_node_init_profile(node, NODE, BUS, profile) == 0
    sizes = {0x1: 1, 0x2: 1, 0x3: 2, 0x4: 4, 0x5: 1, 0x6: 2, 0x7: 4}
    checked = 0
    for index, sub, dtype, access, default in _eds_variables(eds):
        if dtype == 0x9:
            continue  # VISIBLE_STRING: 0x1008-0x100A
        e = H.hs_co_node_find(node, index, sub)
        assert e, f"0x{index:04X}.{sub} missing"
        size = sizes[dtype]
        # a number, or a sum such as "$NODEID+0x80"
        value = sum(int(t, 0) for t in default.replace("$NODEID", str(NODE)).split("+"))
        assert e.contents.size == size, f"0x{index:04X}.{sub}"
        assert e.contents.value == value & ((1 << (8 * size)) - 1), f"0x{index:04X}.{sub}"
        assert e.contents.access == (0 if access in ("ro", "const") else 1), f"0x{index:04X}.{sub}"
        checked += 1
    assert checked >= 70


# ---- CiA 402 ----

def _remote402(net):
    node = canopen.RemoteNode(NODE, canopen.import_od(str(EDS402), NODE))
    net.add_node(node)
    return node


def test_library_reads_the_402_objects(net402, plant402):
    node = _remote402(net402)
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(2.0)
    assert node.sdo[0x1000].raw & 0xFFFF == 402
    assert node.sdo[0x6502].raw & 0x80  # cyclic synchronous position supported
    assert node.sdo[0x6061].raw == 8
    node.sdo[0x6060].raw = 8
    assert node.sdo[0x6061].raw == 8
    assert (node.sdo[0x60C2][1].raw, node.sdo[0x60C2][2].raw) == (1, -3)
    with pytest.raises(canopen.SdoAbortedError) as e:
        node.sdo[0x6061].raw = 1
    assert e.value.code == 0x06010002  # the display is read only


def test_stewart_drives_config_writes_the_402_node(plant402, tmp_path, capsys):
    import json

    from stewart import config
    from stewart.drives import plan

    d = json.loads(DEFAULT.read_text())
    legs = [{"protocol": "cia402", "bus": "can_a" if i < 3 else "can_b", "node_id": NODE + i % 3,
             "scaling": {"position_per_count": 1e-6, "length_at_zero": 1.85}} for i in range(6)]
    d["drives"] = {"buses": {"can_a": {"bitrate": 1000000}, "can_b": {"bitrate": 1000000}},
                   "sync_divider": 2, "legs": legs}
    path = tmp_path / "platform_cia402.json"
    path.write_text(json.dumps(d))
    time.sleep(0.05)  # the node's boot-up
    args = ["drives", "config", "--config", str(path), "--bus", "can_a", "--node", str(NODE),
            "--interface", "virtual", "--channel", plant402.channel]
    assert cli.main(args) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    drives = config.load(path).drives
    writes = plan.drive_writes(drives.legs[0], drives)
    finals = [w for w in writes if w.final]
    assert f"wrote {len(writes)} objects, read back {len(finals)}: all equal" in out
    for w in finals:
        size = {1: 1, 2: 1, 3: 2, 4: 4, 5: 1, 6: 2, 7: 4}[w.datatype]
        assert plant402.value(w.index, w.subindex) == w.value & ((1 << (8 * size)) - 1), w.purpose
    assert plant402.value(0x60C2, 1) == 2


def _state402(word: int) -> str:
    """The CiA 402 state of a statusword by the library's own table."""
    from canopen.profiles.p402 import State402

    for name, (mask, value) in State402.SW_MASK.items():
        if word & mask == value:
            return name
    return "?"


def test_library_master_walks_the_402_state_machine(net402, plant402, H):
    node = _remote402(net402)
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(2.0)
    node.sdo[0x1017].raw = 20
    node.tpdo.read()
    node.rpdo.read()
    assert node.tpdo[1].map[0].index == 0x6041 and node.tpdo[1].map[1].index == 0x6064
    assert node.rpdo[1].map[1].index == 0x607A
    node.nmt.state = "OPERATIONAL"
    node.nmt.wait_for_heartbeat(1.0)

    def step(cw: int, target: int = 0) -> str:
        node.rpdo[1]["Controlword"].raw = cw
        node.rpdo[1]["Target position"].raw = target
        node.rpdo[1].transmit()
        net402.sync.transmit()
        node.tpdo[1].wait_for_reception(1.0)
        return _state402(node.tpdo[1]["Statusword"].raw)

    assert step(0x00) == "SWITCH ON DISABLED"
    assert step(0x06) == "READY TO SWITCH ON"
    assert step(0x07) == "SWITCHED ON"
    with plant402.lock:
        assert H.hs_co_node_follows(plant402.node) == 0
    assert step(0x0F, 4321) == "OPERATION ENABLED"
    assert node.sdo[0x607A].raw == 4321
    with plant402.lock:
        assert H.hs_co_node_follows(plant402.node) == 1
    assert step(0x02, 4321) == "QUICK STOP ACTIVE"
    assert step(0x00) == "SWITCH ON DISABLED"
    plant402.raise_fault(0x2310)
    err = node.emcy.wait(0x2310, 1.0)
    assert err is not None and err.code == 0x2310
    assert step(0x00) in ("FAULT REACTION ACTIVE", "FAULT")
    assert step(0x00) == "FAULT"
    assert node.sdo[0x603F].raw == 0x2310
    assert step(0x80) == "SWITCH ON DISABLED"  # fault reset: bit 7's rising edge
