# SPDX-License-Identifier: Apache-2.0
"""The ctypes mirrors of the core's structs (stewart.core) against the layout
the shared library reports (firmware/core/abi/sp_abi.c), and the status
names, which come from the core (sp_status_name)."""

import ctypes as C

import pytest

from stewart import core


@pytest.fixture(scope="module")
def layout():
    return core.core_layout(core.lib())


def test_every_mirror_matches_the_core(layout):
    core.check_layout(layout)  # lib() did the same when it loaded the library
    assert set(core.MIRRORS.values()) == set(layout)
    size, members = layout["sp_pose_t"]
    assert size == C.sizeof(core.Pose) == 24
    assert members == [("pos", 0, 12), ("rpy", 12, 12)]


class WideFkInfo(C.Structure):
    _fields_ = [("iterations", C.c_uint64), ("residual", C.c_int32)]


class SwappedFkOptions(C.Structure):
    _fields_ = [("max_iterations", C.c_uint32), ("max_jump_pos", C.c_int32),
                ("tolerance", C.c_int32), ("max_jump_rot", C.c_int32)]


class ShortLegLimits(C.Structure):
    _fields_ = [("too_short", C.c_uint32), ("too_long", C.c_uint32), ("too_fast", C.c_uint32)]


class Unknown(C.Structure):
    _fields_ = [("x", C.c_int32)]


@pytest.mark.parametrize("mirror, c_name, expect", [
    (WideFkInfo, "sp_fk_info_t", r"WideFkInfo \(mirror of sp_fk_info_t\): member iterations at offset 0, "
                                 r"8 bytes in Python; offset 0, 4 bytes in C"),
    (WideFkInfo, "sp_fk_info_t", r"member residual at offset 8, 4 bytes in Python; offset 4"),
    (WideFkInfo, "sp_fk_info_t", r"16 bytes in Python, 8 in C"),
    (SwappedFkOptions, "sp_fk_options_t", r"member tolerance at offset 8, 4 bytes in Python; offset 4"),
    (ShortLegLimits, "sp_leg_limits_t", r"member over_force missing in Python"),
    (Unknown, "sp_unknown_t", r"the core library has no layout of sp_unknown_t"),
])
def test_a_wrong_mirror_is_refused_naming_struct_and_member(layout, mirror, c_name, expect):
    with pytest.raises(core.CoreError, match=expect):
        core.check_layout(layout, {mirror: c_name})


def test_a_member_the_c_struct_lacks_is_refused(layout):
    class ExtraPose(C.Structure):
        _fields_ = [("pos", C.c_int32 * 3), ("rpy", C.c_int32 * 3), ("spare", C.c_int32)]

    with pytest.raises(core.CoreError, match=r"ExtraPose .*member spare is not in the C struct"):
        core.check_layout(layout, {ExtraPose: "sp_pose_t"})


def test_lib_checks_the_mirrors_when_it_loads_the_library(monkeypatch):
    monkeypatch.setattr(core, "_LIB", None)
    monkeypatch.setitem(core.MIRRORS, WideFkInfo, "sp_fk_info_t")
    with pytest.raises(core.CoreError, match="WideFkInfo"):
        core.lib()


def test_status_names_come_from_the_core():
    names = [core.status_name(code) for code in range(11)]
    assert names == [core.lib().sp_status_name(code).decode() for code in range(11)]
    # the strings `stewart calc` and `stewart fk` print in their status column
    assert names[4:8] == ["singular", "out-of-range", "no-convergence", "discontinuity"]
    assert names[0] == "ok"
    assert core.status_name(99) == "status-99"
