# SPDX-License-Identifier: Apache-2.0
"""tools/dev/gen_can_c.py: the scale ratios of the firmware's protocol
layer, generated from the DBC's factors (the C side's bit-exactness is
checked by test_protocol_c.py on the shared test vectors)."""

from fractions import Fraction

import pytest

import gen_can_c as gen
from stewart import protocol as pr

DBC = pr.DBC_PATH.read_text()


def test_signals_read_as_cantools_reads_them():
    ours = {(s.message, s.name): s for s in gen.read_signals(DBC)}
    db = pr.Protocol().db
    theirs = {(m.name, s.name): s for m in db.messages for s in m.signals}
    assert ours.keys() == theirs.keys()
    for key, s in ours.items():
        c = theirs[key]
        assert (float(s.factor), float(s.offset), s.length, s.unit) == (c.scale, c.offset, c.length, c.unit or ""), key


def test_ratios_are_the_core_lsb_over_the_factor():
    ratios = {name: r for name, r, _ in gen.scale_ratios(gen.read_signals(DBC))}
    assert set(ratios) == {f"SP_CAN_{stem}_RAW_PER_{unit}" for stem, unit, *_ in gen.SCALES}
    lsb = {f"SP_CAN_{stem}_RAW_PER_{unit}": q for stem, unit, q, *_ in gen.SCALES}
    scale = {"LENGTH": ("AXIS_SETPOINTS", "Length_1"), "FEEDBACK_LENGTH": ("AXIS_FEEDBACK_2", "Length"),
             "POSE": ("CTRL_STATUS", "Yaw"),
             "VELOCITY": ("AXIS_SETPOINTS", "Velocity_2"), "FORCE": ("CTRL_MONITOR", "ForceFf_6"),
             "PRESSURE": ("AXIS_FEEDBACK_3", "PressureB"), "AMPLITUDE": ("OP_COMMAND", "Amplitude"),
             "FREQUENCY": ("OP_COMMAND", "Frequency"), "FADE_TIME": ("OP_COMMAND", "FadeTime"),
             "WRENCH": ("CTRL_WRENCH", "Mz"), "FT_WRENCH": ("OP_FORCE", "Fz"),
             "MASS": ("OP_FORCE_PARAMS", "Mass"), "DAMPING": ("OP_FORCE_PARAMS", "Damping"),
             "STIFFNESS": ("OP_FORCE_PARAMS", "Stiffness"), "FRAME_POSE": ("OP_FRAME", "Yaw"),
             "EXCESS": ("CTRL_REACH", "Excess")}
    proto = pr.Protocol()
    for name, ratio in ratios.items():
        stem = name[len("SP_CAN_"):name.index("_RAW_PER_")]
        factor = proto.message(scale[stem][0]).get_signal_by_name(scale[stem][1]).scale
        assert float(ratio) == pytest.approx(float(lsb[name]) / factor, rel=1e-12), name
        assert ratio.numerator < 1 << 31 and ratio.denominator < 1 << 31
    assert ratios["SP_CAN_LENGTH_RAW_PER_Q24_M"] == Fraction(15625, 262144)  # 2^-24 m in um
    assert ratios["SP_CAN_FEEDBACK_LENGTH_RAW_PER_Q24_M"] == Fraction(78125, 131072)  # 2^-24 m in 0.1 um
    assert ratios["SP_CAN_PRESSURE_RAW_PER_PA"] == Fraction(1, 1000)  # 1 kPa steps
    assert ratios["SP_CAN_WRENCH_RAW_PER_Q8_N_NM"] == Fraction(1, 64)  # 0.25 N = 64 Q8 LSBs
    assert ratios["SP_CAN_FT_WRENCH_RAW_PER_Q8_N_NM"] == Fraction(1, 8)  # 1/32 N = 8 Q8 LSBs
    assert ratios["SP_CAN_MASS_RAW_PER_Q16_KG"] == Fraction(5, 32768)  # 0.1 kg = 6553.6 Q16 LSBs
    assert ratios["SP_CAN_DAMPING_RAW_PER_N_S_PER_M"] == Fraction(1, 10)  # 10 N s/m steps


def test_header_has_num_and_den_of_every_family():
    text = gen.scale_header(gen.read_signals(DBC))
    assert "#define SP_CAN_FORCE_RAW_PER_Q8_N_NUM 25\n#define SP_CAN_FORCE_RAW_PER_Q8_N_DEN 128\n" in text
    assert text.count("#define ") == 2 * len(gen.SCALES)


def _tampered(old, new):
    assert old in DBC
    return DBC.replace(old, new, 1)


@pytest.mark.parametrize("old, new, expect", [
    ("SG_ Length_2 : 104|24@1+ (0.000001,0)", "SG_ Length_2 : 104|24@1+ (0.000002,0)",
     "LENGTH: AXIS_SETPOINTS.Length_2: factor 0.000002 differs from AXIS_SETPOINTS.Length_1's 0.000001"),
    ("SG_ Frequency : 40|16@1+ (0.001,0)", "SG_ Frequency : 40|16@1+ (1e-20,0)",
     "FREQUENCY: factor 1e-20 gives raw = value x 95367431640625 / 16, too large for the 64-bit scaling"),
    ("SG_ Amplitude : 16|24@1- (0.00001,0)", "SG_ Amplitude : 16|24@1- (0.00001,0.5)",
     "AMPLITUDE: OP_COMMAND.Amplitude: offset 0.5 is not 0"),
    ("SG_ Amplitude : 16|24@1- (0.00001,0)", "SG_ Amplitude : 16|24@1- (-0.00001,0)",
     "AMPLITUDE: OP_COMMAND.Amplitude: factor -0.00001 is not positive"),
    ("SG_ Amplitude : 16|24@1- (0.00001,0)", "SG_ Amplitude : 16|24@1- (0x10,0)",
     "AMPLITUDE: OP_COMMAND.Amplitude: factor '0x10' is not a decimal number"),
    ('SG_ FadeTime : 56|16@1+ (0.001,0) [0|65.535] "s"', 'SG_ FadeTime : 56|16@1+ (0.001,0) [0|65.535] "ms"',
     "FADE_TIME: OP_COMMAND.FadeTime: unit 'ms', the core's value is in s"),
    ('SG_ My : 128|22@1- (0.25,0) [-524287.75|524287.75] "N m"',
     'SG_ My : 128|22@1- (0.25,0) [-524287.75|524287.75] "Nm"',
     "WRENCH: CTRL_WRENCH.My: unit 'Nm', the core's value is in N or N m"),
    ("SG_ Mz : 150|22@1- (0.25,0)", "SG_ Mz : 150|22@1- (0.5,0)",
     "WRENCH: CTRL_WRENCH.Mz: factor 0.5 differs from CTRL_WRENCH.Fx's 0.25"),
    ("SG_ Frequency : 40|16@1+", "SG_ Freq : 40|16@1+",
     "FREQUENCY: no signal OP_COMMAND.Frequency in the DBC"),
    ("SG_ Option : 72|8@1+ (1,0)", "SG_ Option m1 : 72|8@1+ (1,0)", "cannot read this signal's factor"),
])
def test_a_factor_it_cannot_represent_fails_the_build(tmp_path, capsys, old, new, expect):
    dbc = tmp_path / "bad.dbc"
    dbc.write_text(_tampered(old, new))
    with pytest.raises(gen.ScaleError) as err:
        gen.scale_ratios(gen.read_signals(dbc.read_text()))
    assert expect in str(err.value)
    # the build step stops before running cantools, with the reason on stderr
    assert gen.main(["/nonexistent/cantools", str(dbc), str(tmp_path / "out")]) == 1
    assert expect in capsys.readouterr().err
