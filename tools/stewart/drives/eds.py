# SPDX-License-Identifier: Apache-2.0
"""Does a drive's EDS offer what the controller's CANopen master needs?

Reads the EDS with the ``canopen`` library and compares it with the one list
(:mod:`.objects`): every needed entry present with its data type, writable
where the master writes it, PDO-mappable where it goes into a PDO; the PDOs'
communication and mapping records present, with the RPDO event timer (the
setpoint watchdog) and room for the mapping entries; the device type naming
the profile. Each shortfall is one line naming the object.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from . import objects as ob


class EdsError(Exception):
    """The file cannot be read as an EDS."""


@dataclass
class CheckResult:
    profile: str
    device: str
    missing: list[str] = field(default_factory=list)    # the controller cannot work with the drive
    notes: list[str] = field(default_factory=list)      # optional features absent or to verify

    @property
    def ok(self) -> bool:
        return not self.missing


def load_od(path):
    """The object dictionary of an EDS file; EdsError with the reason."""
    import canopen

    try:
        return canopen.import_od(str(path))
    except FileNotFoundError:
        raise EdsError(f"{path}: no such file") from None
    except Exception as exc:  # noqa: BLE001 - the library raises many kinds for a bad file
        raise EdsError(f"{path}: not a readable EDS: {type(exc).__name__}: {exc}") from None


def _lookup(od, index: int, subindex: int):
    """The ODVariable at (index, subindex) or None."""
    import canopen.objectdictionary as odm

    if index not in od:
        return None
    obj = od[index]
    if isinstance(obj, odm.ODVariable):
        return obj if subindex == 0 else None
    if subindex in obj:
        return obj[subindex]
    return None


def _writable(var) -> bool:
    return var.access_type in ("rw", "wo", "rww", "rwr")


def check_od(od, profile_name: str, pressure_feedback: bool = True) -> CheckResult:
    prof = ob.profile(profile_name)
    info = od.device_information
    device = " / ".join(x for x in (info.vendor_name, info.product_name) if x) or "(no DeviceInfo)"
    res = CheckResult(profile_name, device)
    needed = ob.entries_needed(prof, pressure_feedback)
    for e in prof.entries:
        var = _lookup(od, e.index, e.subindex)
        wanted = e in needed
        label = f"{e.key} {e.name} ({e.type_name}; {e.purpose})"
        if var is None:
            (res.missing if wanted else res.notes).append(f"{'missing' if wanted else 'absent (optional)'}: {label}")
            continue
        problems = []
        if var.data_type != e.datatype:
            problems.append(f"data type 0x{var.data_type:04X}, the master needs {e.type_name}")
        if e.use == ob.WRITE and not _writable(var):
            problems.append(f"access {var.access_type}: the master writes it")
        if e.use in (ob.RPDO, ob.TPDO) and not var.pdo_mappable:
            problems.append(f"not PDO-mappable: the master maps it into a{'n R' if e.use == ob.RPDO else ' T'}PDO")
        if e.use == ob.RPDO and not _writable(var):
            problems.append(f"access {var.access_type}: an RPDO writes it")
        for p in problems:
            (res.missing if wanted else res.notes).append(f"{e.key} {e.name}: {p}")
    for pdo in ob.pdos_used(prof, pressure_feedback):
        what = f"{'R' if pdo.direction == 'rx' else 'T'}PDO{pdo.number} ({pdo.name})"
        subs = [ob.PDO_COMM_COB_ID, ob.PDO_COMM_TRANSMISSION_TYPE]
        if pdo.direction == "rx":
            subs.append(ob.PDO_COMM_EVENT_TIMER)
        for sub in subs:
            var = _lookup(od, pdo.comm_index, sub)
            name = {1: "COB-ID", 2: "transmission type", 5: "event timer (the setpoint watchdog)"}[sub]
            if var is None:
                res.missing.append(f"missing: 0x{pdo.comm_index:04X}.{sub} {what} {name}")
            elif not _writable(var):
                res.missing.append(f"0x{pdo.comm_index:04X}.{sub} {what} {name}: access {var.access_type}, "
                                   "the master writes it")
        count = _lookup(od, pdo.map_index, 0)
        if count is None:
            res.missing.append(f"missing: 0x{pdo.map_index:04X} {what} mapping record")
            continue
        for i in range(1, len(pdo.entries) + 1):
            var = _lookup(od, pdo.map_index, i)
            if var is None:
                res.missing.append(f"missing: 0x{pdo.map_index:04X}.{i} {what} mapping entry {i} "
                                   f"(the master maps {len(pdo.entries)} objects)")
            elif not _writable(var) or not _writable(count):
                default = var.default if isinstance(var.default, int) else None
                want = pdo.entries[i - 1].mapping_value()
                if default != want:
                    res.missing.append(f"0x{pdo.map_index:04X}.{i} {what}: fixed mapping 0x{default or 0:08X}, "
                                       f"the master needs 0x{want:08X}")
    dt = _lookup(od, ob.DEVICE_TYPE.index, 0)
    if dt is not None and isinstance(dt.default, int) and (dt.default & 0xFFFF) != prof.number:
        res.missing.append(f"0x1000 Device type: 0x{dt.default:08X} names profile {dt.default & 0xFFFF}, "
                           f"not {prof.number}")
    if profile_name == "cia408" and not pressure_feedback:
        res.notes.append("pressure feedback not asked for: the force model runs without measured force")
    return res


def check_file(path, profile_name: str, pressure_feedback: bool = True) -> CheckResult:
    return check_od(load_od(path), profile_name, pressure_feedback)


def format_result(path, res: CheckResult) -> str:
    lines = [f"{path}: {res.device}, checked for {ob.profile(res.profile).title}"]
    if res.ok:
        lines.append("ok: every object and PDO mapping the controller needs is there")
    else:
        lines.append(f"NOT usable: {len(res.missing)} problem{'s' if len(res.missing) != 1 else ''}")
        lines.extend(f"  - {m}" for m in res.missing)
    if res.notes:
        lines.append("notes:")
        lines.extend(f"  - {n}" for n in res.notes)
    return "\n".join(lines)
