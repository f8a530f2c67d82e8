# SPDX-License-Identifier: Apache-2.0
"""tools/dev/gen_proto_c.py: the protocol codec generated from the DBC.
Its frames and values are held to the hand-written codec it replaced by
the C test test_proto_codec; here: the mapping covers the DBC, the ranges
are the DBC's, and a DBC the mapping does not fit fails the build with a
message naming the signal."""

import re
from pathlib import Path

import pytest
from cantools.database.can.c_source import camel_to_snake_case

import gen_proto_c as gen
from stewart import protocol as pr

REPO_ROOT = Path(__file__).resolve().parents[2]

DBC = pr.DBC_PATH.read_text()


def test_names_are_cantools_names():
    for m in pr.Protocol().db.messages:
        assert gen.c_name(m.name) == camel_to_snake_case(m.name)
        for s in m.signals:
            assert gen.c_name(s.name) == camel_to_snake_case(s.name), (m.name, s.name)


def test_ranges_are_the_dbcs():
    msgs = gen.read_messages(DBC)
    db = pr.Protocol().db
    for m in db.messages:
        for s in m.signals:
            ours = msgs[m.name].signals[s.name]
            assert ours.lo == round(s.minimum / s.scale) and ours.hi == round(s.maximum / s.scale), (m.name, s.name)
            assert (ours.start, ours.length, ours.signed) == (s.start, s.length, s.is_signed)
        assert msgs[m.name].buses == [b for b in m.dbc.attributes["Bus"].value.split(",")]


def test_every_function_of_the_header_is_generated():
    header = (REPO_ROOT / "firmware/core/include/sp/link/protocol.h").read_text()
    declared = set(re.findall(r"\bsp_status_t (sp_proto_(?:en|de)code_\w+)\(", header))
    code = gen.generate(DBC, "stewart.dbc")
    defined = set(re.findall(r"^sp_status_t (sp_proto_(?:en|de)code_\w+)\(", code, flags=re.M))
    assert len(declared) == 38 and defined == declared
    # what only the DBC says reaches the code: OP_FORCE_PARAMS' mass range, the velocity's excluded -2^15
    code = " ".join(code.split())
    assert "s.mass < 10u || s.mass > 50000u" in code
    assert "s.velocity_1 < -32767" in code
    assert "m->mass < 65536 || m->mass > 327680000" in code


def test_the_dbc_hash_is_the_tools_one(tmp_path):
    """CTRL_IDENTITY's ProtocolHash as the firmware is built with it is the one
    `stewart op identify` compares with: the same bytes, the same hash; one
    byte more, another."""
    code = gen.generate(DBC, "stewart.dbc")
    assert f"const uint32_t sp_proto_dbc_hash = 0x{pr.dbc_hash():08X}u;" in code
    other = tmp_path / "other.dbc"
    other.write_bytes(pr.DBC_PATH.read_bytes() + b"\n")
    assert pr.dbc_hash(other) != pr.dbc_hash()
    assert f"0x{pr.dbc_hash(other):08X}u;" in gen.generate(other.read_text(), "other.dbc")


def test_the_generated_file_is_written(tmp_path):
    assert gen.main([str(pr.DBC_PATH), str(tmp_path)]) == 0
    text = (tmp_path / gen.OUT_NAME).read_text()
    assert text.startswith("/* SPDX-License-Identifier: Apache-2.0 */\n")
    assert "double" not in text and "float" not in text


def _tampered(old, new):
    assert old in DBC
    return DBC.replace(old, new, 1)


@pytest.mark.parametrize("old, new, expect", [
    ("SG_ Option : 72|8@1+", "SG_ Opt : 72|8@1+", "OP_COMMAND.Option: no such signal in the DBC"),
    ("BO_ 96 OP_HEARTBEAT:", "BO_ 96 OP_HEART:", "OP_HEARTBEAT: no such message in the DBC"),
    ("BO_ 96 OP_HEARTBEAT: 4 OPERATOR\n",
     "BO_ 97 OP_SPARE: 4 OPERATOR\n SG_ Counter : 0|4@1+ (1,0) [0|15] \"\" CONTROLLER\n\n"
     "BO_ 96 OP_HEARTBEAT: 4 OPERATOR\n",
     "OP_SPARE: a message gen_proto_c.MESSAGES does not map"),
    (" SG_ Counter : 120|4@1+ (1,0) [0|15] \"\" CONTROLLER\n",
     " SG_ Counter : 120|4@1+ (1,0) [0|15] \"\" CONTROLLER\n SG_ Spare : 125|3@1+ (1,0) [0|7] \"\" CONTROLLER\n",
     "FT_SENSOR.Spare: mapped 0 times"),
    ("SG_ Tick : 0|32@1+ (1,0) [0|4294967295] \"tick\" DRIVE_1,DRIVE_2,DRIVE_3\n SG_ Hold",
     "SG_ Tick : 0|32@1+ (1,0) [0|4294967294] \"tick\" DRIVE_1,DRIVE_2,DRIVE_3\n SG_ Hold",
     "SYNC.Tick: [min|max] narrower than its bits: rule copy"),
    ("SG_ Hold : 32|1@1+", "SG_ Hold : 32|2@1+", "SYNC.Hold: rule bool needs a one-bit unsigned signal"),
    ("SG_ LengthSp_6 : 416|24@1+ (0.000001,0) [0|16.777215]", "SG_ LengthSp_6 : 416|24@1+ (0.000001,0) [0|16]",
     "CTRL_MONITOR.LengthSp_6: rule, type or [min|max] differ from Length_1's of family LENGTH"),
    ("BO_ 51 AXIS_FEEDBACK_3: 16 DRIVE_3\n SG_ Length : 0|28@1+ (0.0000001,0) [0|26.8435455]",
     "BO_ 51 AXIS_FEEDBACK_3: 16 DRIVE_3\n SG_ Length : 0|28@1+ (0.0000001,0) [0|26.8435454]",
     "AXIS_FEEDBACK_3: its layout differs from AXIS_FEEDBACK_1's"),
    ("SG_ Amplitude : 16|24@1- (0.00001,0) [-83.88607|83.88607]",
     "SG_ Amplitude : 16|24@1- (0.00001,0) [-83.88607|83.88608]",
     "OP_COMMAND.Amplitude: [min|max] is not within its 24 bits"),
    ("SG_ Frequency : 40|16@1+ (0.001,0) [0|65.535]", "SG_ Frequency : 40|32@1+ (0.001,0) [0|4294967.295]",
     "FREQUENCY: a decoded value of Frequency's [min|max] leaves sp_q24_t"),
])
def test_a_dbc_the_mapping_does_not_fit_fails_the_build(tmp_path, capsys, old, new, expect):
    dbc = tmp_path / "bad.dbc"
    dbc.write_text(_tampered(old, new))
    with pytest.raises(gen.CodecError) as err:
        gen.generate(dbc.read_text(), "bad.dbc")
    assert expect in str(err.value)
    assert gen.main([str(dbc), str(tmp_path / "out")]) == 1
    assert expect in capsys.readouterr().err
