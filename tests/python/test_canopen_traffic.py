# SPDX-License-Identifier: Apache-2.0
"""CANopen frames of a CAN log decoded into signals (stewart/drives/traffic.py,
``stewart analyze``'s canopen.csv): every kind of the predefined connection
set the master and the CiA 408 drives use, by the master's PDO layout."""

from __future__ import annotations

from stewart.analysis.logfile import read_frames
from stewart.drives import traffic

LOG = """(0000000000.000000) vcan1 000#8201
(0000000000.001000) vcan1 601#4000100000000000
(0000000000.001000) vcan1 581#4300100098010000
(0000000000.002000) vcan1 601#2B17100014000000
(0000000000.002000) vcan1 581#6017100000000000
(0000000000.003000) vcan2 605#2F43600009000000
(0000000000.003000) vcan2 585#8043600030000906
(0000000000.004000) vcan1 701#05
(0000000000.005000) vcan1 201#0700FEFFFFFF
(0000000000.005000) vcan1 202#07001027000011FF
(0000000000.005000) vcan1 080#
(0000000000.005000) vcan1 181#0F0064000000
(0000000000.005000) vcan1 281#5A520A00
(0000000000.006000) vcan2 085#5082010000000000
(0000000000.006000) vcan0 100#0011223344556677
(0000000000.006000) vcan2 010##10000000000000062
"""


def test_every_kind_decoded():
    rows = traffic.decode(read_frames(LOG.splitlines()), {"vcan1": "axis_a", "vcan2": "axis_b"})
    by = [(r[3], r) for r in rows]
    kinds = [k for k, _ in by]
    # the ops frame and the FD lockstep clock are not CANopen traffic
    assert kinds == ["nmt", "sdo_request", "sdo_answer", "sdo_request", "sdo_answer", "sdo_request", "sdo_answer",
                     "heartbeat", "rpdo1", "rpdo1", "sync", "tpdo1", "tpdo2", "emcy"]
    r = dict(enumerate(rows))
    assert r[0][2] == 1 and r[0][11] == "reset communication"
    assert r[1][10] == "0x1000.0" and r[1][11] == "read" and r[2][11] == "value 0x198"
    assert r[3][11] == "write 0x14" and r[4][11] == "written"
    assert r[6][1:3] == ("axis_b", 5) and r[6][10] == "0x6043.0" and r[6][11] == "abort 0x06090030"
    assert r[7][11] == "operational"
    assert r[8][4:8] == ("0x0007", "", -2, "")                 # 6-byte RPDO1: position only
    assert r[9][4] == "0x0007" and r[9][6] == 10000 and r[9][7] == -239  # 8 bytes: + force 0x2120 (daN)
    assert r[11][4:7] == ("0x000F", "ACTIVE", 100)
    assert r[12][8:10] == (21082, 10)
    assert r[13][10] == "0x8250" and r[13][11].startswith("protocol; error register 0x01")
    s = traffic.summary(rows)
    assert s["frames"]["axis_a node 1"]["sdo_request"] == 2 and s["frames"]["axis_a"]["sync"] == 1
    assert s["sdo_aborts"][0]["object"] == "0x6043.0" and s["emcy"][0]["code"] == "0x8250"
    assert s["nmt_states"]["axis_a node 1"] == ["operational"]


# CiA 402 statuswords: 0x0237 is OPERATION_ENABLED (mask 0x6F -> 0x27); read
# as a CiA 408 status word its bits 0..3 (0b0111) would say FAULT_REACTION.
LOG_402 = """(0000000000.001000) vcan1 601#4000100000000000
(0000000000.001000) vcan1 581#4300100092010000
(0000000000.002000) vcan1 181#370264000000
(0000000000.002000) vcan1 182#370264000000
(0000000000.002000) vcan2 184#500200000000
(0000000000.002000) vcan2 185#0F0000000000
"""


def test_cia402_statusword_by_profile():
    frames = read_frames(LOG_402.splitlines())
    ifaces = {"vcan1": "axis_a", "vcan2": "axis_b"}
    rows = traffic.decode(frames, ifaces, {("axis_b", 4): "cia402", ("axis_b", 5): "cia408"})
    states = [(r[2], r[5]) for r in rows if r[3] == "tpdo1"]
    # node 1: 402 by its 0x1000 answer (0x192) in the log; node 2: no profile known, CiA 408;
    # node 4: 402 by the config (0x0250: SWITCH_ON_DISABLED); node 5: 408 by the config (0x000F: ACTIVE)
    assert states == [(1, "OPERATION_ENABLED"), (2, "FAULT_REACTION"), (4, "SWITCH_ON_DISABLED"), (5, "ACTIVE")]
    assert traffic.state_402(0x0008) == "FAULT" and traffic.state_402(0x0021) == "READY_TO_SWITCH_ON"
    assert traffic.state_402(0x0007) == "QUICK_STOP_ACTIVE" and traffic.state_408(0x0007) == "FAULT_REACTION"


def test_profiles_from_the_config_drives():
    from stewart.drives import layout as lo

    legs = tuple(lo.Drive(i + 1, "cia402" if i < 3 else "cia408", "can_0" if i < 3 else "can_1", node_id=i + 1)
                 for i in range(6))
    p = traffic.profiles_from_drives(lo.Drives(legs))
    assert p[("can_0", 1)] == p[("axis_a", 3)] == "cia402"
    assert p[("can_1", 4)] == p[("axis_b", 6)] == "cia408"
    assert traffic.profiles_from_drives(lo.native_default()) == {}
