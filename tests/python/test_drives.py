# SPDX-License-Identifier: Apache-2.0
"""``stewart drives`` against a drive played by the ``canopen`` library.

A canopen ``LocalNode`` built from our EDS (config/eds/stewart_sim_drive.eds)
answers SDO on python-can's ``virtual`` interface; the tools talk to it
through their own canopen ``Network`` on the same channel, as they would to
a real drive through any adapter.
"""

from __future__ import annotations

import configparser
import copy
import itertools
import json
import subprocess
from pathlib import Path

import canopen
import pytest

from stewart import cli, config
from stewart.drives import eds, objects as ob, plan

REPO_ROOT = Path(__file__).resolve().parents[2]

EDS = REPO_ROOT / "config" / "eds" / "stewart_sim_drive.eds"
DEFAULT = REPO_ROOT / "config" / "platform_default.json"
_channels = itertools.count()


def _drives_section(node_ids=(5, 6, 7), divider=3):
    legs = []
    for i in range(6):
        bus = "can_a" if i < 3 else "can_b"
        legs.append({"protocol": "cia408", "bus": bus, "node_id": node_ids[i % 3],
                     "scaling": {"position_per_count": 1e-6, "length_at_zero": 1.85}})
    return {"buses": {"can_a": {"bitrate": 1000000}, "can_b": {"bitrate": 1000000}},
            "sync_divider": divider, "legs": legs}


@pytest.fixture
def cia408_config(tmp_path):
    d = json.loads(DEFAULT.read_text())
    d["drives"] = _drives_section()
    path = tmp_path / "platform_cia408.json"
    path.write_text(json.dumps(d))
    return path


class SimDrive:
    """A CiA 408 drive played by canopen's LocalNode on a virtual bus."""

    def __init__(self, node_id: int, eds_path=EDS):
        self.channel = f"stewart-drives-{next(_channels)}"
        self.net = canopen.Network()
        self.net.connect(interface="virtual", channel=self.channel)
        self.node = canopen.LocalNode(node_id, canopen.import_od(str(eds_path), node_id))
        self.net.add_node(self.node)
        self.nmt_commands: list[int] = []
        self.net.subscribe(0, lambda can_id, data, ts: self.nmt_commands.append(data[0]))

    def value(self, index: int, sub: int, signed=False) -> int:
        return int.from_bytes(self.node.get_data(index, sub), "little", signed=signed)

    def close(self):
        self.node.nmt.stop_heartbeat()
        self.net.disconnect()


@pytest.fixture
def sim_drive():
    d = SimDrive(5)
    yield d
    d.close()


def _bus(d: SimDrive) -> list[str]:
    return ["--interface", "virtual", "--channel", d.channel]


# ---- scan --------------------------------------------------------------------

def test_scan_finds_the_drive_and_its_identity(sim_drive, capsys):
    assert cli.main(["drives", "scan", *_bus(sim_drive), "--wait", "0.3"]) == 0
    out = capsys.readouterr().out
    assert "| 5 | CiA 408 fluid power (0x00000198) | 0x00000000 | 0x00005348 | 0x00010000 | 0x00000000 |" in out
    assert len([l for l in out.splitlines() if l.startswith("| ") and "| node |" not in l]) == 1  # one node


def test_scan_of_an_empty_bus_says_so(capsys):
    d = SimDrive(5)
    d.node.remove_network()   # nothing answers on this channel
    try:
        assert cli.main(["drives", "scan", *_bus(d), "--wait", "0.2"]) == 1
    finally:
        d.net.disconnect()
    assert "no node answered" in capsys.readouterr().err


# ---- check -------------------------------------------------------------------

def test_check_passes_for_our_eds(capsys):
    assert cli.main(["drives", "check", "--eds", str(EDS)]) == 0
    out = capsys.readouterr().out
    assert "ok: every object and PDO mapping the controller needs is there" in out


def _stripped_eds(tmp_path):
    """Our EDS without the control mode, without the RPDO event timer, with
    the actual position not PDO-mappable and TPDO1's mapping fixed (ro) to
    something else."""
    cp = configparser.RawConfigParser()
    cp.optionxform = str
    cp.read(EDS)
    cp.remove_section("6043")
    opt = cp["OptionalObjects"]
    entries = [v for k, v in opt.items() if k != "SupportedObjects" and v != "0x6043"]
    for k in list(opt):
        del opt[k]
    opt["SupportedObjects"] = str(len(entries))
    for i, v in enumerate(entries, 1):
        opt[str(i)] = v
    cp.remove_section("1400sub5")
    cp["1400"]["SubNumber"] = str(int(cp["1400"]["SubNumber"]) - 1)
    cp["6601sub1"]["PDOMapping"] = "0"
    for s in ("1A00sub0", "1A00sub2"):
        cp[s]["AccessType"] = "ro"
    cp["1A00sub2"]["DefaultValue"] = "0x66010110"
    path = tmp_path / "stripped.eds"
    with path.open("w") as f:
        cp.write(f, space_around_delimiters=False)
    return path


def test_check_names_what_a_stripped_eds_lacks(tmp_path, capsys):
    path = _stripped_eds(tmp_path)
    assert cli.main(["drives", "check", "--eds", str(path)]) == 1
    out = capsys.readouterr().out
    assert "NOT usable: 4 problems" in out
    assert "missing: 0x6043.0 Device control mode" in out
    assert "missing: 0x1400.5 RPDO1 (setpoint) event timer (the setpoint watchdog)" in out
    assert "0x6601.1 Axis position actual value: not PDO-mappable" in out
    assert "0x1A00.2 TPDO1 (actual): fixed mapping 0x66010110, the master needs 0x66010120" in out


def test_check_against_the_other_profile_and_without_pressures(tmp_path, capsys):
    assert cli.main(["drives", "check", "--eds", str(EDS), "--profile", "cia402"]) == 1
    out = capsys.readouterr().out
    for key in ("0x6060.0", "0x6061.0", "0x607A.0", "0x6064.0"):
        assert f"missing: {key}" in out
    assert "names profile 408, not 402" in out
    # a position-only CiA 408 drive (no 0x2110) passes with --no-pressure only
    cp = configparser.RawConfigParser()
    cp.optionxform = str
    cp.read(EDS)
    for s in ("2110", "2110sub0", "2110sub1", "2110sub2"):
        cp.remove_section(s)
    man = cp["ManufacturerObjects"]
    man["SupportedObjects"] = "1"
    del man["2"]
    path = tmp_path / "no_pressure.eds"
    with path.open("w") as f:
        cp.write(f, space_around_delimiters=False)
    assert cli.main(["drives", "check", "--eds", str(path)]) == 1
    assert "missing: 0x2110.1 Chamber pressure A" in capsys.readouterr().out
    assert cli.main(["drives", "check", "--eds", str(path), "--no-pressure"]) == 0


def test_check_of_an_unreadable_eds_is_a_usage_error(tmp_path, capsys):
    assert cli.main(["drives", "check", "--eds", str(tmp_path / "none.eds")]) == 2
    assert "no such file" in capsys.readouterr().err
    bad = tmp_path / "bad.eds"
    bad.write_text("this is no EDS\n[1000\n")
    assert cli.main(["drives", "check", "--eds", str(bad)]) == 2
    assert "not a readable EDS" in capsys.readouterr().err


def test_the_eds_defaults_are_the_controllers_pdo_layout():
    """Out of the box the simulated drive already has the mapping the master
    writes (as a vendor's CiA 408 defaults would)."""
    od = canopen.import_od(str(EDS), 5)
    for pdo in ob.CIA408.pdos:
        assert od[pdo.map_index][0].default == len(pdo.entries)
        for i, e in enumerate(pdo.entries, 1):
            assert od[pdo.map_index][i].default == e.mapping_value(), (pdo.name, i)
        assert od[pdo.comm_index][1].default == pdo.cob_id(5)
    assert od[0x1000].default & 0xFFFF == 408


# ---- config ------------------------------------------------------------------

def test_config_writes_and_reads_back(sim_drive, cia408_config, capsys):
    args = ["drives", "config", "--config", str(cia408_config), "--bus", "can_a", "--node", "5", *_bus(sim_drive)]
    assert cli.main(args) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    writes = plan.drive_writes(config.load(cia408_config).drives.legs[0], config.load(cia408_config).drives)
    finals = {(w.index, w.subindex) for w in writes if w.final}
    assert f"wrote {len(writes)} objects, read back {len(finals)}: all equal" in out
    assert ob.NMT_PRE_OPERATIONAL in sim_drive.nmt_commands
    v = sim_drive.value
    assert v(0x1017, 0) == 20
    assert v(0x6042, 0, signed=True) == 1
    assert v(0x6043, 0, signed=True) == 8
    assert v(0x6600, 3, signed=True) == -6
    assert v(0x1006, 0) == 3000
    assert v(0x1600, 0) == 2 and v(0x1600, 1) == 0x60400010 and v(0x1600, 2) == 0x66000120
    assert v(0x1400, 1) == 0x205 and v(0x1400, 2) == 1 and v(0x1400, 5) == 9   # 3 SYNC periods of 3 ms
    assert v(0x1A00, 1) == 0x60410010 and v(0x1A00, 2) == 0x66010120 and v(0x1800, 1) == 0x185
    assert v(0x1A01, 1) == 0x21100110 and v(0x1801, 1) == 0x285


def test_config_sdo_abort_is_a_named_error(sim_drive, cia408_config, capsys):
    def refuse(index, subindex, od, data):
        if index == 0x6043:
            raise canopen.SdoAbortedError(0x06090030)

    sim_drive.node.add_write_callback(refuse)
    args = ["drives", "config", "--config", str(cia408_config), "--bus", "can_a", "--node", "5", *_bus(sim_drive)]
    assert cli.main(args) == 1
    err = capsys.readouterr().err
    assert ("stewart drives: leg 1: node 5: writing 0x6043.0 = 8 (Device control mode = 8): "
            "SDO abort 0x06090030 (Value range of parameter exceeded)") in err


def test_config_read_back_that_differs_is_an_error(sim_drive, cia408_config, capsys):
    def stale(index, subindex, od):
        if (index, subindex) == (0x1400, 5):
            return 0   # the drive keeps its own event timer
        return None

    sim_drive.node.add_read_callback(stale)
    args = ["drives", "config", "--config", str(cia408_config), "--bus", "can_a", "--node", "5", *_bus(sim_drive)]
    assert cli.main(args) == 1
    assert "node 5: read back 0x1400.5 = 0, wrote 9" in capsys.readouterr().err


def test_config_of_a_silent_node_is_an_error(sim_drive, cia408_config, capsys):
    args = ["drives", "config", "--config", str(cia408_config), "--bus", "can_a", "--node", "6", *_bus(sim_drive)]
    assert cli.main(args) == 1
    assert "leg 2: node 6: no SDO answer writing 0x1017.0" in capsys.readouterr().err


def _eds_without(tmp_path, eds_path, section: str):
    """A copy of an EDS without one object's section (a drive that lacks it)."""
    cp = configparser.RawConfigParser()
    cp.optionxform = str
    cp.read(eds_path)
    cp.remove_section(section)
    path = tmp_path / f"no_{section}.eds"
    with path.open("w") as f:
        cp.write(f, space_around_delimiters=False)
    return path


def test_config_skips_optional_objects_the_drive_lacks(tmp_path, cia408_config, capsys):
    d = SimDrive(5, _eds_without(tmp_path, EDS, "1006"))
    try:
        args = ["drives", "config", "--config", str(cia408_config), "--bus", "can_a", "--node", "5", *_bus(d)]
        assert cli.main(args) == 0
    finally:
        d.close()
    assert "skipped 1 optional (0x1006.0)" in capsys.readouterr().out


def test_config_compares_read_only_scaling(tmp_path, cia408_config, capsys):
    """A drive whose unit prefix is fixed: right -> accepted, wrong -> named error."""
    cp = configparser.RawConfigParser()
    cp.optionxform = str
    cp.read(EDS)
    cp["6600sub3"]["AccessType"] = "ro"
    path = tmp_path / "fixed_prefix.eds"
    with path.open("w") as f:
        cp.write(f, space_around_delimiters=False)
    args = ["drives", "config", "--config", str(cia408_config), "--bus", "can_a", "--node", "5"]
    d = SimDrive(5, path)
    try:
        assert cli.main([*args, *_bus(d)]) == 0
    finally:
        d.close()
    cp["6600sub3"]["DefaultValue"] = "-3"
    with path.open("w") as f:
        cp.write(f, space_around_delimiters=False)
    d = SimDrive(5, path)
    try:
        assert cli.main([*args, *_bus(d)]) == 1
    finally:
        d.close()
    assert "node 5: 0x6600.3 is read-only and holds -3; the config needs -6" in capsys.readouterr().err


def test_config_dry_run_prints_every_write(cia408_config, capsys):
    assert cli.main(["drives", "config", "--config", str(cia408_config), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert out.count("SDO writes") == 6
    assert "| 0x1400.5 | 9 | RPDO1 setpoint: event timer 9 ms = the drive's setpoint watchdog |" in out
    assert "| 0x1600.2 | 0x66000120 | RPDO1 setpoint: map 0x6600.1 Axis position setpoint |" in out


def test_config_usage_errors(cia408_config, capsys):
    assert cli.main(["drives", "config"]) == 2
    assert "every leg's drive is native" in capsys.readouterr().err
    assert cli.main(["drives", "config", "--config", str(cia408_config)]) == 2
    assert "name the adapter's bus with --bus" in capsys.readouterr().err
    assert cli.main(["drives", "config", "--config", str(cia408_config), "--bus", "axis_a"]) == 2
    assert "the config's CANopen buses are can_a, can_b" in capsys.readouterr().err


def test_unknown_interface_is_a_clear_message_without_traceback(cia408_config):
    exe = REPO_ROOT / ".venv" / "bin" / "stewart"
    for args in (["drives", "scan", "--interface", "no_such_adapter"],
                 ["drives", "config", "--config", str(cia408_config), "--bus", "can_a",
                  "--interface", "no_such_adapter"]):
        r = subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=60)
        assert r.returncode == 2
        assert "cannot open CAN interface 'no_such_adapter'" in r.stderr
        assert "virtual" in r.stderr and "socketcan" in r.stderr   # the interfaces python-can knows
        assert "Traceback" not in r.stderr + r.stdout


# ---- the plan (what the master writes) -----------------------------------------

def test_plan_for_a_cia402_drive(tmp_path):
    d = json.loads(DEFAULT.read_text())
    sec = _drives_section(divider=2)
    for leg in sec["legs"]:
        leg["protocol"] = "cia402"
    d["drives"] = sec
    drives = config.from_dict(d).drives
    writes = plan.drive_writes(drives.legs[3], drives)
    by_key = {w.key: w.value for w in writes if w.final}
    assert by_key["0x6060.0"] == 8
    assert by_key["0x60C2.1"] == 2 and by_key["0x60C2.2"] == -3
    assert by_key["0x1600.1"] == 0x60400010 and by_key["0x1600.2"] == 0x607A0020
    assert by_key["0x1A00.2"] == 0x60640020
    assert "0x1A01.1" not in by_key   # no pressure TPDO on an electric drive
    assert by_key["0x1400.5"] == 6


def test_scaling_round_trip():
    d = json.loads(DEFAULT.read_text())
    sec = _drives_section()
    sec["legs"][0]["scaling"]["direction"] = -1
    d["drives"] = sec
    drives = config.from_dict(d).drives
    leg1, leg2 = drives.legs[0], drives.legs[1]
    assert plan.length_to_position(leg2, 2.55) == 700000
    assert plan.length_to_position(leg1, 2.55) == -700000
    assert plan.position_to_length(leg1, -700000) == pytest.approx(2.55, abs=1e-12)
    assert plan.unit_prefix(1e-6) == -6 and plan.unit_prefix(2e-6) is None


def test_the_one_list_has_no_duplicates_and_fits_the_pdos():
    for prof in ob.PROFILES.values():
        keys = [(e.index, e.subindex) for e in prof.entries]
        assert len(keys) == len(set(keys)), prof.name
        for p in prof.pdos:
            assert p.data_bytes <= 8, (prof.name, p.name)   # classic CAN
            for e in p.entries:
                assert e in prof.entries
                assert e.use == (ob.RPDO if p.direction == "rx" else ob.TPDO)


def test_docs_tables_are_generated_from_the_one_list():
    from stewart.drives import doc

    page = REPO_ROOT / "docs" / "reference" / "canopen.md"
    assert doc.page_is_current(page), "run: .venv/bin/stewart drives doc --write"
    text = page.read_text()
    for prof in ob.PROFILES.values():
        for e in prof.entries:
            assert f"| {e.key} | {e.name} |" in text


def test_check_passes_for_a_cia402_eds(tmp_path, capsys):
    """Our EDS turned into a CiA 402 drive's: device type 402, the CSP objects,
    the PDO defaults on controlword/target and statusword/actual position."""
    cp = configparser.RawConfigParser()
    cp.optionxform = str
    cp.read(EDS)
    cp["1000"]["DefaultValue"] = "0x00020192"
    added = {"6060": ("Modes of operation", "0x0002", "rw", "0"),
             "6061": ("Modes of operation display", "0x0002", "ro", "0"),
             "607A": ("Target position", "0x0004", "rww", "1"),
             "6064": ("Position actual value", "0x0004", "ro", "1")}
    opt = cp["OptionalObjects"]
    n = int(opt["SupportedObjects"])
    for index, (name, dtype, access, pdo) in added.items():
        n += 1
        opt[str(n)] = f"0x{index}"
        cp[index] = {"ParameterName": name, "ObjectType": "0x7", "DataType": dtype, "AccessType": access,
                     "DefaultValue": "0", "PDOMapping": pdo}
    opt["SupportedObjects"] = str(n)
    cp["1600sub2"]["DefaultValue"] = "0x607A0020"
    cp["1A00sub2"]["DefaultValue"] = "0x60640020"
    path = tmp_path / "cia402.eds"
    with path.open("w") as f:
        cp.write(f, space_around_delimiters=False)
    assert cli.main(["drives", "check", "--eds", str(path), "--profile", "cia402"]) == 0
    out = capsys.readouterr().out
    assert "ok: every object and PDO mapping" in out
    assert "absent (optional): 0x60C2.1" in out


def test_check_passes_for_the_simulated_cia402_drive_eds(capsys):
    """config/eds/stewart_sim_drive_402.eds (the plant's CiA 402 node): every
    object and mapping of CiA 402 CSP there, optional ones too; checked as a
    CiA 408 drive it names the profile."""
    eds402 = REPO_ROOT / "config" / "eds" / "stewart_sim_drive_402.eds"
    assert cli.main(["drives", "check", "--eds", str(eds402), "--profile", "cia402"]) == 0
    out = capsys.readouterr().out
    assert "ok: every object and PDO mapping" in out and "absent" not in out
    assert cli.main(["drives", "check", "--eds", str(eds402), "--profile", "cia408"]) == 1
    assert "names profile 402, not 408" in capsys.readouterr().out


# ---- CiA 402: the rated torque/force behind 0x60B2 -----------------------------

EDS_402 = REPO_ROOT / "config" / "eds" / "stewart_sim_drive_402.eds"


def _cia402_ff_config(tmp_path, rated_force: float):
    d = json.loads(DEFAULT.read_text())
    sec = _drives_section(divider=2)
    for leg in sec["legs"]:
        leg["protocol"] = "cia402"
        leg["force_feedforward"] = True
        leg["scaling"]["rated_force"] = rated_force
    d["drives"] = sec
    path = tmp_path / f"platform_cia402_{rated_force:g}.json"
    path.write_text(json.dumps(d))
    return path


@pytest.mark.parametrize("rated_force, says", [
    (10000, "0x6076 = 10000000 equals scaling.rated_force (10000 N along the leg) in mN"),
    (5000, "0x6076 = 10000000 (the motor's rated torque in mN m, or force in mN for a linear motor) is not "
           "scaling.rated_force (5000 N along the leg = 5e+06 mN)"),
])
def test_config_of_a_cia402_drive_reads_its_rated_force(tmp_path, capsys, rated_force, says):
    """The simulated CiA 402 drive's 0x6076 is 10 kN (a linear axis, mN):
    `drives config` reads it after the writes and sets it beside the
    config's scaling.rated_force, which 0x60B2's per mille count in."""
    d = SimDrive(5, EDS_402)
    try:
        args = ["drives", "config", "--config", str(_cia402_ff_config(tmp_path, rated_force)), "--bus", "can_a",
                "--node", "5", *_bus(d)]
        assert cli.main(args) == 0, capsys.readouterr().err
    finally:
        d.close()
    out = capsys.readouterr().out
    assert f"leg 1: node 5: {says}" in out
    if rated_force != 10000:
        assert "off by a factor 0.5" in out


def test_config_of_a_cia402_drive_without_0x6076(tmp_path, capsys):
    d = SimDrive(5, _eds_without(tmp_path, EDS_402, "6076"))
    try:
        args = ["drives", "config", "--config", str(_cia402_ff_config(tmp_path, 10000)), "--bus", "can_a",
                "--node", "5", *_bus(d)]
        assert cli.main(args) == 0, capsys.readouterr().err
    finally:
        d.close()
    assert "leg 1: node 5: the drive has no 0x6076 (rated torque/force)" in capsys.readouterr().out
