# SPDX-License-Identifier: Apache-2.0
"""The fixed-point firmware core, called from Python through ctypes.

This is the same C code that runs on the controller (``firmware/core``),
built as a shared library: by the package's build into an installed
package, by the host-release preset in a checkout
(``build/host-release/firmware/libsp_core.so``; :mod:`stewart.resources`).
Values cross the boundary in the core's Q formats; this module converts
them to and from SI floats. Set ``STEWART_CORE_LIB`` to use another build
of the library.

The ctypes Structures below mirror the core's C structs (:data:`MIRRORS`).
The library exports the layout its compiler gave them (sizes, member
offsets and sizes; ``firmware/core/abi/sp_abi.c``), and :func:`lib`
compares every mirror with it when it loads the library: a mismatch is a
:class:`CoreError` naming the struct and the member, never silently wrong
numbers. Status names come from the core too (``sp_status_name``).
"""

from __future__ import annotations

import ctypes as C
import math
from dataclasses import dataclass
from pathlib import Path

from . import resources

LEGS = 6
Q24 = float(1 << 24)
Q30 = float(1 << 30)
Q16 = float(1 << 16)
Q8 = float(1 << 8)

I32 = C.c_int32
V3 = I32 * 3


class Pose(C.Structure):
    _fields_ = [("pos", V3), ("rpy", V3)]


class Motion(C.Structure):
    _fields_ = [
        ("pose", Pose),
        ("vel", V3),
        ("rpy_rate", V3),
        ("acc", V3),
        ("rpy_acc", V3),
    ]


class PlatformStruct(C.Structure):
    _fields_ = [
        ("base_joint", V3 * LEGS),
        ("platform_joint", V3 * LEGS),
        ("mass", I32),
        ("inertia", V3 * 3),
        ("center_of_mass", V3),
        ("gravity", I32),
        ("home", Pose),
        ("park", Pose),
        ("leg_length_min", I32),
        ("leg_length_max", I32),
        ("force_max", I32),
        ("leg_velocity_max", I32),
        ("workspace_min", Pose),
        ("workspace_max", Pose),
        ("piston_area", I32),
        ("annulus_area", I32),
        ("leg_mass", I32 * 6),
        ("viscous_friction", I32 * LEGS),
        ("coulomb_friction", I32 * LEGS),
        ("coulomb_velocity", I32),
        ("breakaway_friction", I32 * LEGS),
        ("stribeck_velocity", I32),
        ("bristle_stiffness", I32 * LEGS),
        ("bristle_damping", I32 * LEGS),
    ]


class Rot(C.Structure):
    _fields_ = [("t", V3 * 3)]


class IK(C.Structure):
    _fields_ = [
        ("rot", Rot),
        ("sc", I32 * 6),
        ("arm", V3 * LEGS),
        ("leg", V3 * LEGS),
        ("length", I32 * LEGS),
        ("unit", V3 * LEGS),
    ]


class FkOptions(C.Structure):
    _fields_ = [
        ("max_iterations", C.c_uint32),
        ("tolerance", I32),
        ("max_jump_pos", I32),
        ("max_jump_rot", I32),
    ]


class FkInfo(C.Structure):
    _fields_ = [("iterations", C.c_uint32), ("residual", I32)]


class LegLimits(C.Structure):
    _fields_ = [
        ("too_short", C.c_uint32),
        ("too_long", C.c_uint32),
        ("too_fast", C.c_uint32),
        ("over_force", C.c_uint32),
    ]


class CanFrame(C.Structure):
    _fields_ = [("id", C.c_uint32), ("bus", C.c_uint8), ("len", C.c_uint8), ("flags", C.c_uint8),
                ("data", C.c_uint8 * 64)]


#: Bytes enough for an sp_frames_keep_t (124 on the hosts built): the tests
#: pass a zeroed buffer of this size as the kept orientation.
FRAMES_KEEP_BYTES = 256

#: Bytes enough for an sp_orient_keep_t (the IK's kept orientation): a
#: zeroed buffer of this size is one with valid 0.
ORIENT_KEEP_BYTES = 512


#: Each ctypes mirror and the C struct it mirrors.
class FramesStruct(C.Structure):
    _fields_ = [("tool", Pose), ("work", Pose), ("tool_rot", Rot), ("work_rot", Rot), ("identity", C.c_uint8),
                ("tool_turned", C.c_uint8), ("work_turned", C.c_uint8), ("reserved", C.c_uint8)]


MIRRORS: dict[type, str] = {
    Pose: "sp_pose_t",
    Motion: "sp_motion_t",
    PlatformStruct: "sp_platform_t",
    Rot: "sp_rot_t",
    IK: "sp_ik_t",
    FkOptions: "sp_fk_options_t",
    FkInfo: "sp_fk_info_t",
    LegLimits: "sp_leg_limits_t",
    CanFrame: "sp_can_frame_t",
    FramesStruct: "sp_frames_t",
}


class AbiMember(C.Structure):
    """One row of the core's layout table (sp_abi_member_t, firmware/core/abi/sp_abi.h)."""

    _fields_ = [("type", C.c_char_p), ("type_size", C.c_uint32), ("member", C.c_char_p),
                ("offset", C.c_uint32), ("member_size", C.c_uint32)]


class CoreError(RuntimeError):
    """The shared library is missing or does not match this module."""


#: C struct name -> (sizeof, [(member, offsetof, sizeof member)]), as the core reports it.
Layout = dict[str, tuple[int, list[tuple[str, int, int]]]]


def core_layout(L: C.CDLL) -> Layout:
    """The layout table the library exports (sp_abi_members)."""
    try:
        fn = L.sp_abi_members
    except AttributeError:
        raise CoreError("the core library exports no struct layout (sp_abi_members): "
                        "rebuild it with `scripts/build.sh host-release`") from None
    fn.argtypes = [C.POINTER(C.c_uint32), C.POINTER(C.c_uint32)]
    fn.restype = C.POINTER(AbiMember)
    count, row_size = C.c_uint32(), C.c_uint32()
    rows = fn(C.byref(count), C.byref(row_size))
    if row_size.value != C.sizeof(AbiMember):
        raise CoreError(f"sp_abi_member_t is {row_size.value} bytes in the core library, "
                        f"{C.sizeof(AbiMember)} in Python (AbiMember)")
    out: Layout = {}
    for i in range(count.value):
        r = rows[i]
        entry = out.setdefault(r.type.decode(), (r.type_size, []))
        entry[1].append((r.member.decode(), r.offset, r.member_size))
    return out


def check_layout(layout: Layout, mirrors: dict[type, str] = MIRRORS) -> None:
    """Raises CoreError, naming the struct and members, unless every mirror
    has exactly the C struct's members, at its offsets and sizes, and its size."""
    problems = []
    for cls, c_name in mirrors.items():
        where = f"{cls.__name__} (mirror of {c_name})"
        if c_name not in layout:
            problems.append(f"{where}: the core library has no layout of {c_name}")
            continue
        size, members = layout[c_name]
        ours = {f[0]: getattr(cls, f[0]) for f in cls._fields_}
        theirs = {m: (off, sz) for m, off, sz in members}
        for m in [m for m in theirs if m not in ours]:
            problems.append(f"{where}: member {m} missing in Python")
        for m in [m for m in ours if m not in theirs]:
            problems.append(f"{where}: member {m} is not in the C struct")
        for m, (off, sz) in theirs.items():
            if m in ours and (ours[m].offset, ours[m].size) != (off, sz):
                problems.append(f"{where}: member {m} at offset {ours[m].offset}, {ours[m].size} bytes "
                                f"in Python; offset {off}, {sz} bytes in C")
        if C.sizeof(cls) != size:
            problems.append(f"{where}: {C.sizeof(cls)} bytes in Python, {size} in C")
    if problems:
        raise CoreError("ctypes mirrors disagree with the core library:\n  " + "\n  ".join(problems))


def library_path() -> Path:
    return resources.core_library()


_LIB = None


def lib() -> C.CDLL:
    """Loads the core library once (raises CoreError with the fix if absent)."""
    global _LIB
    if _LIB is not None:
        return _LIB
    path = library_path()
    if not path.exists():
        raise CoreError(
            f"{path} not found: build it with `scripts/build.sh host-release` "
            "(or run scripts/test.sh)"
        )
    L = C.CDLL(str(path))
    check_layout(core_layout(L))
    P = C.POINTER
    L.sp_status_name.argtypes = [C.c_int]
    L.sp_status_name.restype = C.c_char_p
    L.sp_inverse_kinematics.argtypes = [P(PlatformStruct), P(Pose), P(IK)]
    L.sp_inverse_dynamics.argtypes = [P(PlatformStruct), P(Motion), P(IK), P(V3), P(I32 * LEGS)]
    L.sp_leg_rates.argtypes = [P(IK), P(V3), P(V3), P(I32 * LEGS)]
    L.sp_leg_stretch.argtypes = [P(IK), P(IK), P(I32 * LEGS)]
    L.sp_body_rates.argtypes = [P(V3), P(V3), P(V3), P(V3), P(V3)]
    L.sp_forward_kinematics.argtypes = [
        P(PlatformStruct), P(I32 * LEGS), P(Pose), P(FkOptions), P(Pose), P(IK), P(FkInfo)
    ]
    L.sp_fk_default_options.argtypes = [P(FkOptions)]
    L.sp_fk_default_options.restype = None
    L.sp_check_legs.argtypes = [P(PlatformStruct), P(I32 * LEGS), P(I32 * LEGS), P(I32 * LEGS), P(LegLimits)]
    L.sp_orientation.argtypes = [P(V3), P(Rot)]
    L.sp_frames_prepare.argtypes = [P(Pose), P(Pose), P(FramesStruct)]
    L.sp_frames_to_platform.argtypes = [P(FramesStruct), P(Pose), P(Pose), P(Rot)]
    L.sp_frames_from_platform.argtypes = [P(FramesStruct), P(Pose), P(Pose)]
    L.sp_frames_motion_to_platform.argtypes = [P(FramesStruct), P(Motion), P(Motion)]
    L.sp_frames_wrench_to_tool.argtypes = [P(FramesStruct), P(Rot), P(I32 * 6), P(I32 * 6)]
    L.sp_frames_wrench_from_tool.argtypes = [P(FramesStruct), P(Rot), P(I32 * 6), P(I32 * 6)]
    # sp_frames_keep_t is opaque here: a zeroed buffer of FRAMES_KEEP_BYTES (valid 0)
    L.sp_frames_motion_to_platform_kept.argtypes = [P(FramesStruct), C.c_void_p, P(Motion), P(Motion)]
    L.sp_frames_to_platform_kept.argtypes = [P(FramesStruct), C.c_void_p, P(Pose), P(Pose)]
    # sp_orient_keep_t is opaque too: ORIENT_KEEP_BYTES zeroed
    L.sp_frames_motion_to_platform_shared.argtypes = [P(FramesStruct), C.c_void_p, C.c_void_p, P(Motion), P(Motion)]
    L.sp_inverse_kinematics_kept.argtypes = [P(PlatformStruct), P(Pose), C.c_void_p, P(IK)]
    L.sp_frames_lever.argtypes = [P(FramesStruct), P(Rot), P(V3)]
    L.sp_frames_wrench_to_tool_at.argtypes = [P(FramesStruct), P(V3), P(I32 * 6), P(I32 * 6)]
    L.sp_frames_checksum.argtypes = [P(FramesStruct)]
    L.sp_frames_checksum.restype = C.c_uint32
    L.sp_frames_atan2.argtypes = [I32, I32]
    L.sp_frames_atan2.restype = I32
    for name in ("sp_frames_prepare", "sp_frames_to_platform", "sp_frames_from_platform",
                 "sp_frames_motion_to_platform", "sp_frames_wrench_to_tool", "sp_frames_wrench_from_tool",
                 "sp_frames_motion_to_platform_kept", "sp_frames_to_platform_kept", "sp_frames_lever",
                 "sp_frames_wrench_to_tool_at", "sp_frames_motion_to_platform_shared",
                 "sp_inverse_kinematics_kept"):
        getattr(L, name).restype = C.c_int
    for name in ("sp_inverse_kinematics", "sp_inverse_dynamics", "sp_leg_rates", "sp_leg_stretch",
                 "sp_body_rates", "sp_forward_kinematics", "sp_check_legs", "sp_orientation"):
        getattr(L, name).restype = C.c_int
    _LIB = L
    return L


def status_name(code: int) -> str:
    """The core's name of a status code (sp_status_name: "ok", "singular",
    "out-of-range", ...); ``status-N`` for a code the core does not know."""
    name = lib().sp_status_name(code).decode()
    return f"status-{code}" if name == "unknown" else name


def _q(v: float, scale: float) -> int:
    """SI float -> Q integer, rounded to nearest, saturated to int32."""
    if not math.isfinite(v):
        raise ValueError(f"not a finite number: {v}")
    r = round(v * scale)
    return max(-(1 << 31), min((1 << 31) - 1, r))


def q24(v: float) -> int:
    return _q(v, Q24)


def pose_struct(pose6) -> Pose:
    p = Pose()
    for k in range(3):
        p.pos[k] = q24(pose6[k])
        p.rpy[k] = q24(pose6[3 + k])
    return p


def pose_tuple(p: Pose) -> tuple[float, ...]:
    return tuple([p.pos[k] / Q24 for k in range(3)] + [p.rpy[k] / Q24 for k in range(3)])


def platform_struct(platform) -> PlatformStruct:
    """The core's platform struct from a validated config (stewart.config),
    quantized exactly as the firmware's generated default is."""
    from . import fixedpoint

    ints = fixedpoint.quantize(platform)
    s = PlatformStruct()
    for i in range(LEGS):
        for c in range(3):
            s.base_joint[i][c] = ints["base_joint"][i][c]
            s.platform_joint[i][c] = ints["platform_joint"][i][c]
    s.mass = ints["mass"]
    for r in range(3):
        for c in range(3):
            s.inertia[r][c] = ints["inertia"][r][c]
    s.gravity = ints["gravity"]
    for name in ("home", "park", "workspace_min", "workspace_max"):
        dst = getattr(s, name)
        vals = ints[name]
        for k in range(3):
            dst.pos[k] = vals[k]
            dst.rpy[k] = vals[3 + k]
    s.leg_length_min = ints["leg_length_min"]
    s.leg_length_max = ints["leg_length_max"]
    s.force_max = ints["force_max"]
    s.leg_velocity_max = ints["leg_velocity_max"]
    s.piston_area = ints["piston_area"]
    s.annulus_area = ints["annulus_area"]
    for k in range(3):
        s.center_of_mass[k] = ints["center_of_mass"][k]
    for k, key in enumerate(("cylinder_mass", "cylinder_com", "rod_mass", "rod_com", "cylinder_inertia",
                              "rod_inertia")):
        s.leg_mass[k] = ints["leg_mass"][key]
    for i in range(LEGS):
        s.viscous_friction[i] = ints["viscous_friction"][i]
        s.coulomb_friction[i] = ints["coulomb_friction"][i]
    s.coulomb_velocity = ints["coulomb_velocity"]
    for i in range(LEGS):
        s.breakaway_friction[i] = ints["breakaway_friction"][i]
        s.bristle_stiffness[i] = ints["bristle_stiffness"][i]
        s.bristle_damping[i] = ints["bristle_damping"][i]
    s.stribeck_velocity = ints["stribeck_velocity"]
    return s


@dataclass
class CalcResult:
    status: str
    length: list[float] | None = None
    stretch: list[float] | None = None
    force: list[float] | None = None
    leg_rate: list[float] | None = None


class Core:
    """The firmware core bound to one platform."""

    def __init__(self, platform):
        self.L = lib()
        self.platform = platform
        self.ps = platform_struct(platform)
        self.home_ik = IK()
        st = self.L.sp_inverse_kinematics(C.byref(self.ps), C.byref(self.ps.home), C.byref(self.home_ik))
        if st != 0:
            raise CoreError(f"inverse kinematics of the home pose failed: {status_name(st)}")

    def inverse_kinematics(self, pose6):
        ik = IK()
        st = self.L.sp_inverse_kinematics(C.byref(self.ps), C.byref(pose_struct(pose6)), C.byref(ik))
        return st, ik

    def calc(self, pose6, vel=(0, 0, 0), rpy_rate=(0, 0, 0), acc=(0, 0, 0), rpy_acc=(0, 0, 0),
             ext_force=(0, 0, 0)) -> CalcResult:
        """Leg lengths, stretch, leg rates and cylinder forces of one motion
        sample, by the fixed-point core. status is the first problem found:
        a computation error leaves the numbers out; a limit violation
        (out-of-range) keeps them."""
        m = Motion()
        m.pose = pose_struct(pose6)
        for k in range(3):
            m.vel[k] = q24(vel[k])
            m.rpy_rate[k] = q24(rpy_rate[k])
            m.acc[k] = q24(acc[k])
            m.rpy_acc[k] = q24(rpy_acc[k])
        ext = V3(*[_q(f, Q8) for f in ext_force])
        ik = IK()
        st = self.L.sp_inverse_kinematics(C.byref(self.ps), C.byref(m.pose), C.byref(ik))
        if st != 0:
            return CalcResult(status_name(st))
        stretch = (I32 * LEGS)()
        st = self.L.sp_leg_stretch(C.byref(ik), C.byref(self.home_ik), C.byref(stretch))
        if st != 0:
            return CalcResult(status_name(st))
        rates = (I32 * LEGS)()
        st = self.L.sp_leg_rates(C.byref(ik), C.byref(m.vel), C.byref(m.rpy_rate),
                                 C.byref(rates))
        if st != 0:
            return CalcResult(status_name(st))
        forces = (I32 * LEGS)()
        st = self.L.sp_inverse_dynamics(C.byref(self.ps), C.byref(m), C.byref(ik), C.byref(ext), C.byref(forces))
        if st != 0:
            return CalcResult(status_name(st))
        limits = LegLimits()
        st = self.L.sp_check_legs(C.byref(self.ps), ik.length, rates, forces, C.byref(limits))
        return CalcResult(
            status_name(st),
            [ik.length[i] / Q24 for i in range(LEGS)],
            [stretch[i] / Q24 for i in range(LEGS)],
            [forces[i] / Q8 for i in range(LEGS)],
            [rates[i] / Q24 for i in range(LEGS)],
        )

    def forward_kinematics(self, lengths, guess6=None, max_iterations=None, max_jump_pos=None,
                           max_jump_rot=None):
        """Pose from six leg lengths (m) by the core's Newton-Raphson, from
        guess6 (default: home). Returns (status, pose6 or None, iterations)."""
        opt = FkOptions()
        self.L.sp_fk_default_options(C.byref(opt))
        if max_iterations is not None:
            opt.max_iterations = max_iterations
        if max_jump_pos is not None:
            opt.max_jump_pos = q24(max_jump_pos)
        if max_jump_rot is not None:
            opt.max_jump_rot = q24(max_jump_rot)
        ls = (I32 * LEGS)(*[q24(v) for v in lengths])
        guess = self.ps.home if guess6 is None else pose_struct(guess6)
        out = Pose()
        ik = IK()
        info = FkInfo()
        st = self.L.sp_forward_kinematics(C.byref(self.ps), C.byref(ls), C.byref(guess), C.byref(opt),
                                          C.byref(out), C.byref(ik), C.byref(info))
        return status_name(st), (pose_tuple(out) if st == 0 else None), info.iterations
