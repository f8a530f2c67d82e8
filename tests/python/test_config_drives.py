# SPDX-License-Identifier: Apache-2.0
"""The platform config's ``drives`` section: validation names the bad key,
and a CANopen layout above 50 % bus load is refused with the ways out."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from stewart import cli, config
from stewart.canframe import classic_frame_bits
from stewart.drives import layout

REPO_ROOT = Path(__file__).resolve().parents[2]

DEFAULT = json.loads((REPO_ROOT / "config" / "platform_default.json").read_text())


def _with(drives):
    d = copy.deepcopy(DEFAULT)
    d["drives"] = drives
    return d


def _section(divider=3, pressure=True, per_bus=3, protocol="cia408"):
    legs = []
    for i in range(6):
        bus = f"can_{i // per_bus}"
        legs.append({"protocol": protocol, "bus": bus, "node_id": 10 + i % per_bus,
                     "scaling": {"position_per_count": 1e-6, "length_at_zero": 1.85}})
    buses = {f"can_{k}": {"bitrate": 1000000} for k in range(6 // per_bus)}
    return {"buses": buses, "sync_divider": divider, "pressure_feedback": pressure, "legs": legs}


def _error(d) -> str:
    with pytest.raises(config.ConfigError) as e:
        config.from_dict(d, "t.json")
    return str(e.value)


def test_default_config_is_all_native():
    p = config.load(REPO_ROOT / "config" / "platform_default.json")
    assert [d.protocol for d in p.drives.legs] == ["native"] * 6
    assert [d.bus for d in p.drives.legs] == ["axis_a"] * 3 + ["axis_b"] * 3
    assert p.drives.canopen == () and p.drives.buses() == []


def test_a_valid_cia408_layout():
    p = config.from_dict(_with(_section()))
    assert [d.on_block for d in p.drives.legs] == ["hold"] * 6   # the default
    s = _section()
    s["legs"][4]["on_block"] = "disabled"
    assert [d.on_block for d in config.from_dict(_with(s)).drives.legs] == ["hold"] * 4 + ["disabled", "hold"]
    assert [d.node_id for d in p.drives.legs] == [10, 11, 12, 10, 11, 12]
    assert p.drives.buses() == ["can_0", "can_1"]
    assert p.drives.setpoint_timeout_ms == 9 and p.drives.heartbeat_ms == 20
    assert p.drives.legs[0].scaling == layout.Scaling(1e-6, 1.85, 1)


@pytest.mark.parametrize("mutate, message", [
    (lambda s: s["legs"][4].update(node_id=10),
     "t.json: drives.legs[4].node_id: node 10 on bus can_1 is already leg 4's"),
    (lambda s: s["legs"][2].update(node_id=0), "t.json: drives.legs[2].node_id: 0 is outside 1..127"),
    (lambda s: s["legs"][2].update(node_id=128), "t.json: drives.legs[2].node_id: 128 is outside 1..127"),
    (lambda s: s["legs"][1].pop("node_id"), "t.json: drives.legs[1].node_id: missing"),
    (lambda s: s["legs"][5].pop("scaling"), "t.json: drives.legs[5].scaling: missing"),
    (lambda s: s["legs"][5]["scaling"].pop("position_per_count"),
     "t.json: drives.legs[5].scaling.position_per_count: missing"),
    (lambda s: s["legs"][0]["scaling"].update(position_per_count=1e-10),
     "drives.legs[0].scaling.position_per_count: 1e-10 is below the allowed minimum 1e-09"),
    (lambda s: s["legs"][0]["scaling"].update(direction=2), "drives.legs[0].scaling.direction: expected 1 or -1"),
    (lambda s: s["legs"][3].update(protocol="canopen"),
     "drives.legs[3].protocol: \"canopen\" is not one of native, cia408, cia402"),
    (lambda s: s["legs"][3].update(bus="can_9"), "drives.legs[3].bus: can_9 has no bit rate in drives.buses"),
    (lambda s: s["buses"]["can_0"].update(bitrate=900000),
     "drives.buses.can_0.bitrate: 900000 is not a classic CAN bit rate"),
    (lambda s: s.update(sync_divider=0), "drives.sync_divider: 0 is outside 1..10"),
    (lambda s: s.update(heartbeat_timeout_ms=20), "drives.heartbeat_timeout_ms: 20 must exceed heartbeat_ms 20"),
    (lambda s: s.update(setpoint_timeout_ms=5), "drives.setpoint_timeout_ms: 5 ms is below two SYNC periods"),
    (lambda s: s.update(syncdivider=2), "drives.syncdivider: unknown key"),
    (lambda s: s["legs"].pop(), "drives.legs: expected a list of 6 objects"),
    (lambda s: s["legs"][0]["scaling"].update(position_per_count=1e-9, length_at_zero=0.0),
     "drives.legs[0].scaling: leg length 3.25 m is 3.25e+09 counts from length_at_zero"),
    (lambda s: s["legs"][0].update(protocol="native", bus="can_0"),
     "drives.legs[0].bus: a native drive of leg 1 is on axis_a"),
    (lambda s: s["legs"][0].update(control_mode=9, protocol="cia402"),
     "drives.legs[0].control_mode: only for cia408 drives"),
    (lambda s: s["legs"][2].update(node_id=127),
     "drives.legs[2].node_id: 127 is the master's own heartbeat id"),
    (lambda s: s["legs"][4].update(protocol="cia402", force_feedforward=True),
     "drives.legs[4].force_feedforward: a cia402 drive takes the force as its torque/force offset 0x60B2, "
     "in per mille of its rated force: give scaling.rated_force"),
    (lambda s: s["legs"][4]["scaling"].update(rated_force=5000.0),
     "drives.legs[4].scaling.rated_force: only for cia402 drives"),
    (lambda s: (s["legs"][4].update(protocol="cia402"), s["legs"][4]["scaling"].update(rated_force=50.0)),
     "drives.legs[4].scaling.rated_force:"),
    (lambda s: s.update(master_heartbeat_ms=21846), "t.json: drives.master_heartbeat_ms: 21846 is outside 0..21845"),
    (lambda s: s.update(master_heartbeat_ms=-1), "t.json: drives.master_heartbeat_ms: -1 is outside 0..21845"),
    (lambda s: s.update(master_heartbeat_ms=50.5), "t.json: drives.master_heartbeat_ms: expected an integer"),
    (lambda s: s["legs"][3].update(on_block="open"),
     "t.json: drives.legs[3].on_block: \"open\" is not one of hold, disabled"),
    (lambda s: (s["legs"][3].update(protocol="native", bus="axis_b", on_block="hold"), s["legs"][3].pop("node_id"),
                s["legs"][3].pop("scaling")),
     "drives.legs[3].on_block: only for CANopen drives"),
    (lambda s: s.update(master_node_id=0), "t.json: drives.master_node_id: 0 is outside 1..127"),
    (lambda s: s.update(master_node_id=128), "t.json: drives.master_node_id: 128 is outside 1..127"),
    (lambda s: s.update(master_node_id=12),
     "t.json: drives.legs[2].node_id: 12 is the master's own heartbeat id (drives.master_node_id)"),
])
def test_validation_names_the_bad_key(mutate, message):
    s = _section()
    mutate(s)
    assert message in _error(_with(s))


def test_native_and_canopen_do_not_share_a_bus():
    s = _section()
    s["buses"] = {"axis_b": {"bitrate": 1000000}}
    for i in range(3):
        s["legs"][i] = {"protocol": "native"}
    for i in range(3, 6):
        s["legs"][i]["bus"] = "axis_b"
    p = config.from_dict(_with(s))   # legs 1-3 native on axis_a, 4-6 CiA 408 on axis_b
    assert [d.protocol for d in p.drives.legs] == ["native"] * 3 + ["cia408"] * 3
    s["legs"][2] = {"protocol": "native", "bus": "axis_a"}
    s["legs"][3] = {"protocol": "native", "node_id": 3}
    assert "drives.legs[3].node_id: only for CANopen drives" in _error(_with(s))


# Hand-computed with the classic frame length 47 + 8n + floor((34 + 8n - 1) / 4):
# SYNC 0 bytes 55 bits, PDO of 6 bytes 115, pressure PDO of 4 bytes 95, heartbeat 1 byte 65.
def test_frame_bits_by_hand():
    assert [classic_frame_bits(n) for n in (0, 1, 4, 6)] == [55, 65, 95, 115]


def test_six_drives_on_one_bus_at_1ms_is_143_percent_and_refused():
    # SYNC + 6 setpoint RPDOs + 6 actual TPDOs = 55 + 12 * 115 = 1435 us per 1 ms
    s = _section(divider=1, pressure=False, per_bus=6)
    p = config.from_dict(_with(s), check_bus_load=False)
    rows = layout.bus_rows(p.drives, "can_0")
    cyclic = sum(r.us_per_ms for r in rows if not r.name.startswith("heartbeat"))
    assert cyclic == pytest.approx(1435.0)
    # the heartbeats: six drives every 20 ms, the master (node 127) every 100 ms
    hb = 6 * 65 / 20 + 65 / 100
    assert layout.bus_load(p.drives, "can_0") == pytest.approx((1435 + hb) / 10)
    msg = _error(_with(s))
    assert "drives.legs: bus can_0: worst-case load 145.5 % is above 50 %" in msg
    # divider 3: (1435 / 3 + 20.15) / 10 = 49.8 % (50.1 % with the master's heartbeat counted every 20 ms)
    assert "drives.sync_divider = 3 (SYNC and PDOs every 3 ms" in msg and "49.8 %" in msg


@pytest.mark.parametrize("per_bus, divider, pressure, percent, fits", [
    # heartbeats: the drives' every 20 ms, the master's (node 127) every 100 ms
    (3, 1, True, (55 + 3 * (115 + 115 + 95) + 3 * 65 / 20 + 65 / 100) / 10, False),   # 104.0
    (3, 2, True, ((55 + 3 * 325) / 2 + 3 * 65 / 20 + 65 / 100) / 10, False),          # 52.5
    (3, 3, True, ((55 + 3 * 325) / 3 + 3 * 65 / 20 + 65 / 100) / 10, True),           # 35.4
    (3, 2, False, ((55 + 3 * 230) / 2 + 3 * 65 / 20 + 65 / 100) / 10, True),          # 38.3
    (2, 1, False, (55 + 2 * 230 + 2 * 65 / 20 + 65 / 100) / 10, False),               # 52.2
    (2, 2, True, ((55 + 2 * 325) / 2 + 2 * 65 / 20 + 65 / 100) / 10, True),           # 36.0
])
def test_layouts_by_hand(per_bus, divider, pressure, percent, fits):
    s = _section(divider, pressure, per_bus)
    p = config.from_dict(_with(s), check_bus_load=False)
    for bus in p.drives.buses():
        assert layout.bus_load(p.drives, bus) == pytest.approx(percent, abs=1e-9)
    if fits:
        config.from_dict(_with(s))
    else:
        assert "is above 50 %. Ways out:" in _error(_with(s))


def test_ways_out_are_named_and_each_fits():
    s = _section(divider=1)
    p = config.from_dict(_with(s), check_bus_load=False)
    ways = layout.ways_out(p.drives, "can_0")
    assert ways[0].startswith("a SYNC divider: drives.sync_divider = 3")
    assert ways[1].startswith("more buses: at most 1 drive per bus at this SYNC period (38.4 %), 6 CANopen buses")
    assert ways[2].startswith("no pressure TPDO") and ways[2].endswith("(still over)")


def test_busload_reports_the_canopen_buses(tmp_path, capsys):
    ok = tmp_path / "ok.json"
    ok.write_text(json.dumps(_with(_section(divider=3))))
    assert cli.main(["busload", "--config", str(ok)]) == 0
    out = capsys.readouterr().out
    assert "CANopen bus can_0: classic CAN 1 Mbit/s, SYNC every 3 ms" in out
    assert "**353.7 us = 35.4 %** (ok)" in out
    assert "| heartbeat (master, node 127) | 1 | 1 | 100 | 65 | 0.7 |" in out
    assert "bus axis_a" in out   # the DBC's buses stay: the config's CANopen buses are others
    over = tmp_path / "over.json"
    over.write_text(json.dumps(_with(_section(divider=1))))
    assert cli.main(["busload", "--config", str(over)]) == 1
    out = capsys.readouterr().out
    assert "104.0 %** (OVER LIMIT)" in out and "Ways out for can_0:" in out
    bad = tmp_path / "bad.json"
    s = _section()
    s["legs"][1]["node_id"] = 10
    bad.write_text(json.dumps(_with(s)))
    assert cli.main(["busload", "--config", str(bad)]) == 2
    assert "drives.legs[1].node_id: node 10 on bus can_0 is already leg 1's" in capsys.readouterr().err


def test_busload_drops_the_dbc_axis_frames_of_a_canopen_bus(tmp_path, capsys):
    s = _section(divider=3)
    s["buses"] = {"axis_a": {"bitrate": 1000000}, "axis_b": {"bitrate": 1000000}}
    for i, leg in enumerate(s["legs"]):
        leg["bus"] = "axis_a" if i < 3 else "axis_b"
    path = tmp_path / "axis.json"
    path.write_text(json.dumps(_with(s)))
    assert cli.main(["busload", "--config", str(path)]) == 0
    out = capsys.readouterr().out
    assert "bus axis_a\n" not in out and "AXIS_SETPOINTS" not in out
    assert "CANopen bus axis_a" in out and "bus ops" in out


# ---- the drives section into the firmware (gen_platform.py) -------------------

def test_force_feedforward_key():
    s = _section()
    s["legs"][2]["force_feedforward"] = True
    p = config.from_dict(_with(s))
    assert [d.force_feedforward for d in p.drives.legs] == [False, False, True, False, False, False]
    s["legs"][2]["force_feedforward"] = "yes"
    assert _error(_with(s)).endswith("drives.legs[2].force_feedforward: expected true or false")
    s = _section(protocol="cia402")
    s["legs"][0]["force_feedforward"] = True
    assert "drives.legs[0].force_feedforward: a cia402 drive takes the force" in _error(_with(s))
    s["legs"][0]["scaling"]["rated_force"] = 12000.0   # CiA 402: 0x60B2 in per mille of 12 kN
    p = config.from_dict(_with(s))
    assert p.drives.legs[0].force_feedforward and p.drives.legs[0].scaling.rated_force == 12000.0


def test_the_firmware_gets_the_config_layout():
    import gen_platform

    native = gen_platform.c_source(config.load(REPO_ROOT / "config" / "platform_default.json"))
    assert ".present = 0u," in native   # native drives: the master's keys only, for the built-in layout
    assert ".master = {.master_heartbeat_ms = 100u, .master_node_id = 127u}," in native
    s = _section(divider=3)
    s["legs"][4]["force_feedforward"] = True
    s["legs"][5]["scaling"] = {"position_per_count": 2e-6, "length_at_zero": 1.5, "direction": -1}
    s["legs"][1]["on_block"] = "disabled"
    text = gen_platform.c_source(config.from_dict(_with(s), "t.json"))
    assert ".present = 1u," in text and ".n_nodes = 6u," in text and ".sync_divider = 3u," in text
    assert "{10u, SP_BUS_AXIS_A, 1u, 8, 1u, -6, 0u, SP_CO_PROFILE_408, 0u}" in text   # can_0 -> axis_a
    assert "{11u, SP_BUS_AXIS_B, 5u, 8, 1u, -6, 1u, SP_CO_PROFILE_408, 0u}" in text   # can_1 -> axis_b, force ff
    assert ", SP_CO_PROFILE_408, 1u}" in text and text.count(", 1u}") == 1  # leg 2 disabled once blocked
    assert "{2000u, 25165824, -1, 0u, 0u, 0u, 0u, 0}" in text        # 2 um, 1.5 m in Q24, counting down
    assert ".setpoint_timeout_ms = 9u," in text and ".pdo_timeout_ms = 10u," in text
    assert "[SP_BUS_AXIS_A] = 1000000u, [SP_BUS_AXIS_B] = 1000000u" in text
    assert ".master_heartbeat_ms = 100u," in text and ".master_node_id = 127u," in text


def test_the_firmware_gets_a_cia402_layout():
    """CiA 402 drives: the profile per node, no unit prefix written (0x6600
    is CiA 408's), no pressure PDO; CiA 408 and 402 drives may share the master."""
    import gen_platform

    s = _section(divider=3)
    for leg in s["legs"]:
        leg["protocol"] = "cia402"
    text = gen_platform.c_source(config.from_dict(_with(s), "t.json"))
    assert "{10u, SP_BUS_AXIS_A, 1u, 8, 0u, 0, 0u, SP_CO_PROFILE_402, 0u}" in text
    assert ".pressure_feedback = 0u," in text
    s["legs"][1].update(force_feedforward=True)   # the torque/force offset 0x60B2, per mille of 8 kN
    s["legs"][1]["scaling"]["rated_force"] = 8000
    text = gen_platform.c_source(config.from_dict(_with(s), "t.json"))
    assert "SP_BUS_AXIS_A, 2u, 8, 0u, 0, 1u, SP_CO_PROFILE_402, 0u}" in text
    assert ", 8000u, 0u, 0u, 0u, 0}" in text
    s["legs"][1].update(force_feedforward=False)
    del s["legs"][1]["scaling"]["rated_force"]
    s["legs"][0]["protocol"] = "cia408"
    text = gen_platform.c_source(config.from_dict(_with(s), "t.json"))
    assert "{10u, SP_BUS_AXIS_A, 1u, 8, 1u, -6, 0u, SP_CO_PROFILE_408, 0u}" in text
    assert "SP_CO_PROFILE_402, 0u}" in text and ".pressure_feedback = 1u," in text


@pytest.mark.parametrize("mutate, message", [
    (lambda s: s["legs"][0].update(protocol="native", bus="axis_a", node_id=None, scaling=None),
     "drives.legs: the firmware drives every leg with one protocol (one per image); the config mixes cia408, native"),
    (lambda s: s["legs"][0]["scaling"].update(position_per_count=1.5e-9),
     "drives.legs[0].scaling.position_per_count: 1.5e-09 m is not a whole number of nm per count"),
])
def test_what_the_firmware_cannot_drive_fails_the_build(mutate, message):
    import gen_platform

    s = _section(divider=3)
    mutate(s)
    for leg in s["legs"]:
        for k in [k for k, v in leg.items() if v is None]:
            del leg[k]
    p = config.from_dict(_with(s), "t.json")
    with pytest.raises(config.ConfigError) as e:
        gen_platform.c_source(p)
    assert message in str(e.value)


def test_three_canopen_buses_fail_the_build():
    import gen_platform

    p = config.from_dict(_with(_section(divider=2, per_bus=2)), "t.json")
    with pytest.raises(config.ConfigError) as e:
        gen_platform.c_source(p)
    assert "drives.legs: 3 CANopen buses (can_0, can_1, can_2); the controller has 2 drive buses" in str(e.value)


def test_master_heartbeat_keys():
    """drives.master_heartbeat_ms and master_node_id: defaults 100 ms and 127
    (the firmware's SP_CO_MASTER_HEARTBEAT_MS); they reach the drives' plan
    (0x1016.1), the bus load, and the firmware's layout, CANopen or native."""
    import gen_platform
    from stewart.drives import plan

    p = config.from_dict(_with(_section()), "t.json")
    assert (p.drives.master_heartbeat_ms, p.drives.master_node_id) == (100, 127)
    s = _section()
    s.update(master_heartbeat_ms=250, master_node_id=100)
    p = config.from_dict(_with(s), "t.json")
    w = {(x.index, x.subindex): x.value for x in plan.drive_writes(p.drives.legs[0], p.drives)}
    assert w[(0x1016, 1)] == (100 << 16) | 750          # three periods, as the firmware writes it
    rows = layout.bus_rows(p.drives, "can_0")
    hb = [r for r in rows if r.name == "heartbeat (master, node 100)"]
    assert len(hb) == 1 and hb[0].period_ms == 250.0
    text = gen_platform.c_source(p)
    assert ".master_heartbeat_ms = 250u," in text and ".master_node_id = 100u," in text
    s["master_heartbeat_ms"] = 0                        # off: no consumer write, no row, node 127 free for a drive
    s["legs"][0]["node_id"] = 127
    p = config.from_dict(_with(s), "t.json")
    assert (0x1016, 1) not in {(x.index, x.subindex) for x in plan.drive_writes(p.drives.legs[0], p.drives)}
    assert not [r for r in layout.bus_rows(p.drives, "can_0") if "master" in r.name]
    # a native config may carry the master's keys alone (the ports' built-in CANopen layout takes them)
    p = config.from_dict(_with({"master_heartbeat_ms": 40, "master_node_id": 99}), "t.json")
    assert {d.protocol for d in p.drives.legs} == {"native"}
    assert ".master = {.master_heartbeat_ms = 40u, .master_node_id = 99u}," in gen_platform.c_source(p)
    assert "drives.legs: missing" in _error(_with({"master_node_id": 99, "sync_divider": 2}))
