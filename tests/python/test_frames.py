# SPDX-License-Identifier: Apache-2.0
"""The fixed-point tool and work frames (firmware/core/src/model/frames.c)
against the float64 reference (tools/stewart/frames.py), on random frames
and poses, and the reference against finite differences of itself."""

import ctypes as C
import math

import numpy as np
import pytest

from stewart import core
from stewart.frames import Frames, check_frame

Q24 = float(1 << 24)
Q8 = 256.0
RNG_SEED = 31
N = 2000

# Stated tolerances (sp/model/frames.h): positions 4 LSB of Q24 plus 3e-9 of
# the lever; angles 8 LSB; motion derivatives 1e-7 relative plus 8 LSB;
# wrenches 2 LSB of Q8 plus 3e-9 relative.
POS_TOL = 4 / Q24
ANG_TOL = 8 / Q24


@pytest.fixture(scope="module")
def L():
    try:
        return core.lib()
    except core.CoreError as e:
        pytest.skip(str(e))


def rand_frame(rng, turned=True):
    t = rng.uniform(-1.0, 1.0, 3)
    a = rng.uniform(-0.6, 0.6, 3) if turned else np.zeros(3)
    return tuple(np.concatenate([t, a]))


def rand_pose(rng):
    return tuple(np.concatenate([rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.4, 0.4, 3)]))


def prepared(L, tool, work):
    f = core.FramesStruct()
    # quantize as the controller does
    st = L.sp_frames_prepare(C.byref(core.pose_struct(tool)), C.byref(core.pose_struct(work)), C.byref(f))
    assert st == 0
    q_tool = core.pose_tuple(core.pose_struct(tool))
    q_work = core.pose_tuple(core.pose_struct(work))
    return f, Frames(q_tool, q_work)


def angle_diff(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + math.pi) % (2 * math.pi) - math.pi)


def test_pose_transforms_match_float64(L):
    rng = np.random.default_rng(RNG_SEED)
    worst_p = worst_a = worst_rp = worst_ra = 0.0
    for i in range(N):
        f, ref = prepared(L, rand_frame(rng, i % 4 != 0), rand_frame(rng, i % 3 != 0))
        x = core.pose_struct(rand_pose(rng))
        xq = np.array(core.pose_tuple(x))
        out = core.Pose()
        assert L.sp_frames_to_platform(C.byref(f), C.byref(x), C.byref(out), None) == 0
        want = ref.to_platform(xq)
        got = np.array(core.pose_tuple(out))
        lever = np.linalg.norm(ref.t)
        worst_p = max(worst_p, np.max(np.abs(got[:3] - want[:3])) - 3e-9 * lever)
        worst_a = max(worst_a, np.max(angle_diff(got[3:], want[3:])))
        back = core.Pose()
        assert L.sp_frames_from_platform(C.byref(f), C.byref(out), C.byref(back)) == 0
        want_back = ref.from_platform(got)
        got_back = np.array(core.pose_tuple(back))
        worst_rp = max(worst_rp, np.max(np.abs(got_back[:3] - want_back[:3])) - 3e-9 * lever)
        worst_ra = max(worst_ra, np.max(angle_diff(got_back[3:], want_back[3:])))
    print("worst LSB", worst_p * Q24, worst_a * Q24, worst_rp * Q24, worst_ra * Q24)
    assert worst_p <= POS_TOL, worst_p * Q24
    assert worst_a <= ANG_TOL, worst_a * Q24
    assert worst_rp <= POS_TOL, worst_rp * Q24
    assert worst_ra <= ANG_TOL, worst_ra * Q24


def test_identity_is_a_copy_and_pivot_stays(L):
    rng = np.random.default_rng(RNG_SEED + 1)
    f, _ = prepared(L, (0,) * 6, (0,) * 6)
    assert f.identity == 1
    for _ in range(200):
        x = core.pose_struct(rand_pose(rng))
        out = core.Pose()
        assert L.sp_frames_to_platform(C.byref(f), C.byref(x), C.byref(out), None) == 0
        assert list(out.pos) == list(x.pos) and list(out.rpy) == list(x.rpy)
    # a pivot 0.35 m above o', 0.15 m off its axis: turning T about it keeps the
    # tool point (by the platform's own forward map) within 4 LSB
    f, ref = prepared(L, (0.15, 0.0, 0.35, 0, 0, 0), (0, 0, 0, 0, 0, 0))
    for _ in range(200):
        x6 = np.concatenate([[0.1, -0.05, 2.2], rng.uniform(-0.08, 0.08, 3)])
        out = core.Pose()
        assert L.sp_frames_to_platform(C.byref(f), C.byref(core.pose_struct(x6)), C.byref(out), None) == 0
        p = np.array(core.pose_tuple(out))
        from stewart.model import rotation
        tip = p[:3] + rotation(p[3:]) @ np.array([0.15, 0.0, 0.35])
        assert np.max(np.abs(tip - np.array(core.pose_tuple(core.pose_struct(x6)))[:3])) < 6 / Q24


def motion_struct(x6, vel, rate, acc, racc):
    m = core.Motion()
    m.pose = core.pose_struct(x6)
    for k in range(3):
        m.vel[k] = core.q24(vel[k])
        m.rpy_rate[k] = core.q24(rate[k])
        m.acc[k] = core.q24(acc[k])
        m.rpy_acc[k] = core.q24(racc[k])
    return m


def test_motion_transform_matches_float64(L):
    rng = np.random.default_rng(RNG_SEED + 2)
    worst = np.zeros(4)
    for i in range(N // 2):
        f, ref = prepared(L, rand_frame(rng, i % 2 == 0), rand_frame(rng, i % 3 == 0))
        x6 = rand_pose(rng)
        vel, rate, acc, racc = (rng.uniform(-1, 1, 3) for _ in range(4))
        m = motion_struct(x6, vel, rate, acc, racc)
        q = lambda a: np.array([v / Q24 for v in a])  # noqa: E731
        want = ref.motion_to_platform(np.array(core.pose_tuple(m.pose)), q(m.vel), q(m.rpy_rate), q(m.acc),
                                      q(m.rpy_acc))
        out = core.Motion()
        assert L.sp_frames_motion_to_platform(C.byref(f), C.byref(m), C.byref(out)) == 0
        got = (q(out.vel), q(out.rpy_rate), q(out.acc), q(out.rpy_acc))
        for k, (g, w) in enumerate(zip(got, want[1:])):
            worst[k] = max(worst[k], np.max(np.abs(g - w) - 1e-7 * np.max(np.abs(w))))
    print("worst motion LSB", worst * Q24)
    assert np.all(worst <= 8 / Q24), worst * Q24


def test_float64_motion_is_the_derivative_of_the_pose():
    """The reference's derivatives against central differences of its poses."""
    rng = np.random.default_rng(RNG_SEED + 3)
    h = 1e-5
    for _ in range(100):
        ref = Frames(rand_frame(rng), rand_frame(rng))
        c = [rng.uniform(-0.3, 0.3, 6) for _ in range(3)]
        pose = lambda s: c[0] + c[1] * s + c[2] * s * s  # noqa: E731
        p0, v, rate, a, racc = ref.motion_to_platform(pose(0), c[1][:3], c[1][3:], 2 * c[2][:3], 2 * c[2][3:])
        pm, pp = ref.to_platform(pose(-h)), ref.to_platform(pose(h))
        assert np.allclose((pp - pm) / (2 * h), np.concatenate([v, rate]), atol=1e-6)
        assert np.allclose((pp - 2 * p0 + pm) / (h * h), np.concatenate([a, racc]), atol=2e-3)


def test_wrench_transforms_match_float64(L):
    rng = np.random.default_rng(RNG_SEED + 4)
    worst = 0.0
    for i in range(N):
        f, ref = prepared(L, rand_frame(rng, i % 2 == 0), rand_frame(rng, i % 3 == 0))
        prpy = rng.uniform(-0.4, 0.4, 3)
        rot = core.Rot()
        assert L.sp_orientation(C.byref(core.V3(*[core.q24(v) for v in prpy])), C.byref(rot)) == 0
        prpy_q = [core.q24(v) / Q24 for v in prpy]
        w = rng.uniform(-5000, 5000, 6)
        wi = (core.I32 * 6)(*[int(round(v * Q8)) for v in w])
        wq = np.array([v / Q8 for v in wi])
        out = (core.I32 * 6)()
        assert L.sp_frames_wrench_to_tool(C.byref(f), C.byref(rot), C.byref(wi), C.byref(out)) == 0
        want = ref.wrench_to_tool(prpy_q, wq)
        worst = max(worst, np.max(np.abs(np.array(out[:]) / Q8 - want) - 3e-9 * np.max(np.abs(want))))
        back = (core.I32 * 6)()
        assert L.sp_frames_wrench_from_tool(C.byref(f), C.byref(rot), C.byref(out), C.byref(back)) == 0
        want = ref.wrench_from_tool(prpy_q, np.array(out[:]) / Q8)
        worst = max(worst, np.max(np.abs(np.array(back[:]) / Q8 - want) - 3e-9 * np.max(np.abs(want))))
    assert worst <= 2 / Q8, worst * Q8


def test_atan2_and_checksum(L):
    rng = np.random.default_rng(RNG_SEED + 5)
    worst = 0
    for _ in range(20000):
        y, x = (int(v) for v in rng.integers(-(1 << 31), (1 << 31) - 1, 2))
        if math.hypot(x, y) < (1 << 20):
            continue
        got = L.sp_frames_atan2(y, x)
        worst = max(worst, abs(got - math.atan2(y, x) * Q24))
    assert worst <= 2.0, worst
    f, ref = prepared(L, (0.1, -0.2, 0.35, 0.01, -0.02, 0.3), (1.0, 2.0, -0.5, 0.3, 0.0, -0.1))
    assert L.sp_frames_checksum(C.byref(f)) == ref.checksum()


def test_prepare_refuses_bad_frames(L):
    f = core.FramesStruct()
    far = core.pose_struct((3.0, 3.0, 3.0, 0, 0, 0))  # 5.2 m
    assert L.sp_frames_prepare(C.byref(far), None, C.byref(f)) != 0
    assert f.identity == 1
    ok = core.pose_struct((3.0, 3.0, 2.0, 0, 0, 0))
    assert L.sp_frames_prepare(C.byref(ok), None, C.byref(f)) == 0
    turned = core.pose_struct((0, 0, 0, 3.2, 0, 0))
    assert L.sp_frames_prepare(None, C.byref(turned), C.byref(f)) != 0
    with pytest.raises(ValueError, match="tool"):
        check_frame((3, 3, 3, 0, 0, 0), "tool", "tool")
    with pytest.raises(ValueError, match="finite"):
        check_frame((0, 0, float("nan"), 0, 0, 0), "k")


def _config_with(frames):
    import json
    from pathlib import Path

    from stewart import config

    d = json.loads((Path(__file__).resolve().parents[2] / "config" / "platform_default.json").read_text())
    d["frames"] = frames
    return config.from_dict(d, check_bus_load=False)


def test_config_frames_default_and_bad_ones_refused_by_key():
    from stewart import config

    p = config.load(Path_default())
    fr = p.frames
    assert fr["tool"][fr["active_tool"]]["pose"] == [0.0] * 6
    assert fr["work"][fr["active_work"]]["pose"] == [0.0] * 6
    ok = {"tool": [{"name": "a", "pose": [0, 0, 0, 0, 0, 0]}, {"name": "tip", "pose": [0.1, 0, 0.3, 0, 0, 0]}],
          "active_tool": "tip"}
    assert _config_with(ok).frames["active_tool"] == 1
    bad = [
        ({"tool": [{"name": "far", "pose": [3, 3, 3, 0, 0, 0]}]}, r"frames\.tool\[0\]\.pose"),
        ({"tool": [{"name": f"t{i}", "pose": [0] * 6} for i in range(5)]}, r"frames\.tool"),
        ({"work": [{"name": "w", "pose": [0, 0, 0, 0, 3.3, 0]}]}, r"frames\.work\[0\]\.pose"),
        ({"work": [{"name": "w", "pose": [0, 0, 0]}]}, r"frames\.work\[0\]\.pose"),
        ({"tool": [{"name": "a", "pose": [0] * 6}], "active_tool": "b"}, r"frames\.active_tool"),
        ({"tool": [{"name": "a", "pose": [0] * 6}, {"name": "a", "pose": [0] * 6}]}, r"frames\.tool\[1\]\.name"),
        ({"tools": []}, r"frames\.tools"),
        ({"tool": [{"name": "n", "pose": [float("nan")] + [0] * 5}]}, r"frames\.tool\[0\]\.pose"),
    ]
    for frames, key in bad:
        with pytest.raises(config.ConfigError, match=key):
            _config_with(frames)


def Path_default():
    from pathlib import Path

    return Path(__file__).resolve().parents[2] / "config" / "platform_default.json"


def test_generated_frame_slots():
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "p.c"
        subprocess.run([sys.executable, str(root / "tools/dev/gen_platform.py"), str(Path_default()), str(out)],
                       check=True)
        text = out.read_text()
    assert "sp_frame_slots_default" in text
    assert text.count("3u, 3u, 0u, 0u}") == 1  # two of each defined, flange and base active


# ---- the kept transforms and the shared lever (the tick's optimised paths) ----

def motion_bytes(m):
    return bytes(memoryview(m))


def test_kept_transforms_equal_the_plain_ones(L):
    """sp_frames_motion_to_platform_kept and sp_frames_to_platform_kept, on
    sequences of tool motions whose angles repeat, change one at a time or
    all at once (as a tick's reference does), give the plain calls' results
    bit for bit; the plain calls are held to the float64 model above."""
    rng = np.random.default_rng(RNG_SEED + 10)
    for i in range(200):
        f, _ = prepared(L, rand_frame(rng, i % 2 == 0), rand_frame(rng, i % 3 == 0))
        keep = (C.c_uint8 * core.FRAMES_KEEP_BYTES)()
        pkeep = (C.c_uint8 * core.FRAMES_KEEP_BYTES)()
        x6 = np.array(rand_pose(rng))
        for n in range(20):
            step = n % 4
            if step == 1:  # one angle changes
                x6[3 + rng.integers(3)] += rng.uniform(-1e-3, 1e-3)
            elif step == 2:  # all change
                x6[3:] += rng.uniform(-1e-3, 1e-3, 3)
            x6[:3] += rng.uniform(-1e-3, 1e-3, 3)  # the position always moves; step 0, 3: angles repeat
            vel, rate, acc, racc = (rng.uniform(-1, 1, 3) * (n % 5 != 0) for _ in range(4))
            m = motion_struct(tuple(x6), vel, rate, acc, racc)
            plain, kept = core.Motion(), core.Motion()
            st_plain = L.sp_frames_motion_to_platform(C.byref(f), C.byref(m), C.byref(plain))
            st_kept = L.sp_frames_motion_to_platform_kept(C.byref(f), keep, C.byref(m), C.byref(kept))
            assert st_plain == st_kept
            assert motion_bytes(plain) == motion_bytes(kept), (i, n)
            pp, pk = core.Pose(), core.Pose()
            assert L.sp_frames_to_platform(C.byref(f), C.byref(m.pose), C.byref(pp), None) == \
                L.sp_frames_to_platform_kept(C.byref(f), pkeep, C.byref(m.pose), C.byref(pk))
            assert bytes(memoryview(pp)) == bytes(memoryview(pk)), (i, n)
    # NULL keep: the plain call
    m = motion_struct(rand_pose(rng), *(rng.uniform(-1, 1, 3) for _ in range(4)))
    a, b = core.Motion(), core.Motion()
    assert L.sp_frames_motion_to_platform(C.byref(f), C.byref(m), C.byref(a)) == 0
    assert L.sp_frames_motion_to_platform_kept(C.byref(f), None, C.byref(m), C.byref(b)) == 0
    assert motion_bytes(a) == motion_bytes(b)


def test_shared_orientation_equals_the_plain_transform_and_ik(L):
    """sp_frames_motion_to_platform_shared keeps a tool tip's orientation
    (no frame turned) in the IK's own sp_orient_keep_t: on sequences whose
    angles repeat, change one at a time or all at once, its platform
    motion is the plain call's bit for bit, and the IK that follows with
    the same keep gives the plain IK's legs, rotation and unit vectors bit
    for bit (a keep changed by the frames is taken as a turning reference).
    With a turned frame it is the kept call."""
    from stewart import config

    ps = core.platform_struct(config.load(Path_default()))
    rng = np.random.default_rng(RNG_SEED + 11)
    for i in range(120):
        turned = i % 4 == 3
        tool = rand_frame(rng, turned)
        f, _ = prepared(L, tool, rand_frame(rng, False) if i % 2 else (0.0,) * 6)
        keep = (C.c_uint8 * core.FRAMES_KEEP_BYTES)()
        orient = (C.c_uint8 * core.ORIENT_KEEP_BYTES)()
        x6 = np.array(rand_pose(rng)) * 0.3
        for n in range(16):
            step = n % 4
            if step == 1:
                x6[3 + rng.integers(3)] += rng.uniform(-1e-3, 1e-3)
            elif step == 2:
                x6[3:] += rng.uniform(-1e-3, 1e-3, 3)
            x6[:3] += rng.uniform(-1e-3, 1e-3, 3)
            vel, rate, acc, racc = (rng.uniform(-1, 1, 3) * (n % 5 != 0) for _ in range(4))
            m = motion_struct(tuple(x6), vel, rate, acc, racc)
            plain, shared = core.Motion(), core.Motion()
            st_plain = L.sp_frames_motion_to_platform(C.byref(f), C.byref(m), C.byref(plain))
            st_shared = L.sp_frames_motion_to_platform_shared(C.byref(f), keep, orient, C.byref(m), C.byref(shared))
            assert st_plain == st_shared, (i, n)
            assert motion_bytes(plain) == motion_bytes(shared), (i, n)
            if n % 3 == 2:
                continue  # the IK skips a tick (a CANopen tick that sends no setpoints)
            ik_plain, ik_kept = core.IK(), core.IK()
            st_a = L.sp_inverse_kinematics(C.byref(ps), C.byref(shared.pose), C.byref(ik_plain))
            st_b = L.sp_inverse_kinematics_kept(C.byref(ps), C.byref(shared.pose), orient, C.byref(ik_kept))
            assert st_a == st_b, (i, n)
            assert bytes(memoryview(ik_plain)) == bytes(memoryview(ik_kept)), (i, n)


def _round_away(v, s):
    return (v + (1 << (s - 1)) - (1 if v < 0 else 0)) >> s


_SATURATED = []


def _sat(v):
    if not -(1 << 31) <= v < (1 << 31):
        _SATURATED.append(v)
    return max(-(1 << 31), min((1 << 31) - 1, v))


def straightforward_wrench_to_tool(f, rot, w):
    """The wrench at the tool point in W's axes as the plain formulas say it,
    in exact integers with the core's roundings: r = R_P t (Q24), M - r x F,
    both turned by R_W^T (Q30 rounded once), saturated to int32."""
    t = [f.tool.pos[k] for k in range(3)]
    r = [_round_away(sum(rot.t[j][c] * t[j] for j in range(3)), 30) for c in range(3)]
    F, M = list(w[:3]), list(w[3:])
    c = [_round_away(r[1] * F[2] - r[2] * F[1], 24), _round_away(r[2] * F[0] - r[0] * F[2], 24),
         _round_away(r[0] * F[1] - r[1] * F[0], 24)]
    mo = [M[k] - c[k] for k in range(3)]
    if f.work_turned:
        W = f.work_rot.t
        n = [_sat(v) for v in mo]
        F = [_round_away(sum(W[i][j] * F[j] for j in range(3)), 30) for i in range(3)]
        mo = [_round_away(sum(W[i][j] * n[j] for j in range(3)), 30) for i in range(3)]
    return [_sat(v) for v in F + mo]


def test_wrench_lever_once_equals_straightforward(L):
    """sp_frames_lever + sp_frames_wrench_to_tool_at (the tick's two reported
    wrenches, one lever) and sp_frames_wrench_to_tool equal the straightforward
    integer formulas bit for bit, saturating wrenches included; the float64
    model holds them (test_wrench_transforms_match_float64)."""
    rng = np.random.default_rng(RNG_SEED + 11)
    saturated = 0
    for i in range(1000):
        f, _ = prepared(L, rand_frame(rng, i % 2 == 0), rand_frame(rng, i % 3 == 0))
        if f.identity:
            continue
        rot = core.Rot()
        assert L.sp_orientation(C.byref(core.V3(*[core.q24(v) for v in rng.uniform(-0.4, 0.4, 3)])),
                                C.byref(rot)) == 0
        scale = 5000 if i % 10 else 2e7  # the last: near the int32 range of Q8
        wi = (core.I32 * 6)(*[int(round(v * Q8)) for v in rng.uniform(-scale, scale, 6)])
        lever = core.V3()
        assert L.sp_frames_lever(C.byref(f), C.byref(rot), lever) == 0
        at, plain = (core.I32 * 6)(), (core.I32 * 6)()
        st_at = L.sp_frames_wrench_to_tool_at(C.byref(f), lever, C.byref(wi), C.byref(at))
        st_plain = L.sp_frames_wrench_to_tool(C.byref(f), C.byref(rot), C.byref(wi), C.byref(plain))
        assert st_at == st_plain
        _SATURATED.clear()
        want = straightforward_wrench_to_tool(f, rot, list(wi))
        assert list(at) == want and list(plain) == want, i
        assert (st_at == 0) == (not _SATURATED), (i, st_at)  # SP_E_OVERFLOW exactly when a value saturated
        saturated += bool(_SATURATED)
    assert saturated > 0  # the saturating case was met
