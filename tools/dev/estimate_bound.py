# SPDX-License-Identifier: Apache-2.0
"""The bound of the firmware's one-step pose estimate (float64, numpy).

The firmware's estimate (firmware/core/src/estimation/estimate.c) takes one chord step
from the reference x_ref of the previous tick, whose leg lengths L_ref and
factorisation of J^T are known:

    [dR; dw] = J_ref^-1 (L_meas - L_ref)

J's rows are [u_i, (A_i T) x u_i]: it maps a translation dR (m) and a small
rotation dw (rad, base frame) to leg-length increments. dw becomes Euler
increments with the reference's own sines, as fk_update in fk.c does:

    d_roll = (cy wx + sy wy) / cp, d_pitch = -sy wx + cy wy,
    d_yaw = wz + sp d_roll.

The result differs from the true forward kinematics by a second-order term
in |x - x_ref|. This script finds, over random references in the workspace
(reachable: every leg within its stroke) and random tracking errors of any
direction, the largest |L_meas - L_ref|_inf for which the step stays within
`tol_pos` of the true position and `tol_rot` of the true Euler angles on
every axis: for each (reference, direction) pair it bisects on the size of
the error, and the bound is the smallest size found. The true pose is known
exactly (the measured lengths are its IK), so no forward kinematics runs.

    .venv/bin/python tools/dev/estimate_bound.py [--samples N] [--seed S]
"""

from __future__ import annotations

import argparse

import numpy as np

from stewart import model, resources
from stewart import config as cfg


def euler_step(pose_ref: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """x_ref + the chord step delta = [dR; dw] (N x 6) with the rotation
    part turned into Euler increments at the reference's angles."""
    r, p, y = pose_ref[:, 3], pose_ref[:, 4], pose_ref[:, 5]
    sp, cp = np.sin(p), np.cos(p)
    sy, cy = np.sin(y), np.cos(y)
    wx, wy, wz = delta[:, 3], delta[:, 4], delta[:, 5]
    d_roll = (cy * wx + sy * wy) / cp
    d_pitch = -sy * wx + cy * wy
    d_yaw = wz + sp * d_roll
    out = pose_ref.copy()
    out[:, :3] += delta[:, :3]
    out[:, 3] = r + d_roll
    out[:, 4] = p + d_pitch
    out[:, 5] = y + d_yaw
    return out


def jacobians(platform, poses: np.ndarray) -> np.ndarray:
    """The leg Jacobian (rows [u_i, arm_i x u_i]) of each pose, N x 6 x 6."""
    return np.stack([model.force_matrix(platform, x).T for x in poses])


def sample_references(platform, rng, n: int) -> np.ndarray:
    """n poses uniform in the workspace box with every leg within its stroke."""
    home = np.asarray(platform.home, float)
    lo = home + np.asarray(platform.workspace_min, float)
    hi = home + np.asarray(platform.workspace_max, float)
    out = np.empty((0, 6))
    while len(out) < n:
        x = rng.uniform(lo, hi, size=(4 * n, 6))
        lengths = model.leg_lengths_many(platform, x)
        ok = np.all((lengths >= platform.leg_length_min) & (lengths <= platform.leg_length_max), axis=1)
        out = np.vstack([out, x[ok]])
    return out[:n]


def step_errors(platform, ref, jac, direction, scale):
    """|L_meas - L_ref|_inf and the step's largest position (m) and angle
    (rad) errors for the true poses ref + scale * direction."""
    truth = ref + scale[:, None] * direction
    l_ref = model.leg_lengths_many(platform, ref)
    d_l = model.leg_lengths_many(platform, truth) - l_ref
    delta = np.linalg.solve(jac, d_l[:, :, None])[:, :, 0]
    est = euler_step(ref, delta)
    err = est - truth
    return (np.max(np.abs(d_l), axis=1), np.max(np.abs(err[:, :3]), axis=1),
            np.max(np.abs(err[:, 3:]), axis=1))


def thresholds(platform, ref, jac, direction, tol_pos, tol_rot):
    """For each (reference, direction): |dL|_inf (m) at the largest size of
    the tracking error along `direction` whose step is within the
    tolerances (bisection; the error grows with the size)."""
    n = len(ref)
    lo = np.zeros(n)
    hi = np.full(n, 0.05)  # 50 mm / 50 mrad on the largest axis
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        _, ep, er = step_errors(platform, ref, jac, direction, mid)
        inside = (ep <= tol_pos) & (er <= tol_rot)
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    d_l, _, _ = step_errors(platform, ref, jac, direction, lo)
    return d_l


def bound(platform, samples=4000, seed=1, tol_pos=1e-6, tol_rot=1e-6, refine=64, rounds=30):
    """The largest |dL|_inf (m) below which every sampled step is within the
    tolerances, and the samples' thresholds (m) for the statistics. After
    the random samples, the `refine` worst (reference, direction) pairs are
    searched locally (random perturbations of both, kept when they lower
    the threshold) for `rounds` rounds, so the bound is the worst case found
    rather than a typical one."""
    rng = np.random.default_rng(seed)
    ref = sample_references(platform, rng, samples)
    jac = jacobians(platform, ref)
    # tracking errors of every direction: translations and rotations mixed
    # at random ratios (rotation in rad against translation in m, 1:1 at
    # this size of platform, where a joint sits ~1 m from o')
    direction = rng.normal(size=(samples, 6))
    direction *= rng.uniform(0.0, 1.0, size=(samples, 6)) ** 2
    direction /= np.max(np.abs(direction), axis=1)[:, None]
    thr = thresholds(platform, ref, jac, direction, tol_pos, tol_rot)
    worst = np.argsort(thr)[:refine]
    w_ref, w_dir, w_thr = ref[worst], direction[worst], thr[worst]
    home = np.asarray(platform.home, float)
    lo = home + np.asarray(platform.workspace_min, float)
    hi = home + np.asarray(platform.workspace_max, float)
    for k in range(rounds):
        step = 0.2 * 0.85**k
        c_ref = np.clip(w_ref + rng.normal(size=w_ref.shape) * step * (hi - lo) * 0.1, lo, hi)
        lengths = model.leg_lengths_many(platform, c_ref)
        reach = np.all((lengths >= platform.leg_length_min) & (lengths <= platform.leg_length_max), axis=1)
        c_dir = w_dir + rng.normal(size=w_dir.shape) * step
        c_dir /= np.max(np.abs(c_dir), axis=1)[:, None]
        c_thr = thresholds(platform, c_ref, jacobians(platform, c_ref), c_dir, tol_pos, tol_rot)
        better = reach & (c_thr < w_thr)
        w_ref[better], w_dir[better], w_thr[better] = c_ref[better], c_dir[better], c_thr[better]
    return float(min(np.min(thr), np.min(w_thr))), thr


def _at_limit(platform, limit, rng, samples):
    """Random references, their J, and tracking errors of random direction
    scaled so that |dL|_inf = `limit` (m) through that J (to first order,
    then one correction for the second-order part)."""
    ref = sample_references(platform, rng, samples)
    jac = jacobians(platform, ref)
    direction = rng.normal(size=(samples, 6))
    direction *= rng.uniform(0.0, 1.0, size=(samples, 6)) ** 2
    d_l, _, _ = step_errors(platform, ref, jac, direction, np.full(samples, 1e-4))
    scale = 1e-4 * limit / d_l
    d_l, _, _ = step_errors(platform, ref, jac, direction, scale)
    scale *= limit / d_l
    return ref, jac, direction, scale


def check(platform, limit, samples=4000, seed=2):
    """The step's worst position and angle errors (m, rad) over random
    references and directions with |dL|_inf exactly `limit` (m)."""
    ref, jac, direction, scale = _at_limit(platform, limit, np.random.default_rng(seed), samples)
    d_l, ep, er = step_errors(platform, ref, jac, direction, scale)
    return float(np.max(d_l)), float(np.max(ep)), float(np.max(er))


def aged_check(platform, limit, age_ticks, lin_speed, ang_speed, samples=4000, seed=2, tick_s=1e-3):
    """As `check`, with the step solved through the factorisation the
    controller keeps (SP_CTRL_LU_KEEP): J^T made `age_ticks` ticks earlier,
    at the reference moved back along a random velocity of `lin_speed`
    (m/s) and `ang_speed` (rad/s, Euler rates), the error still measured
    against the true pose ref + the tracking error, whose |dL|_inf is
    `limit` (m) through this tick's J. Returns the worst position (m) and
    angle (rad) errors. age_ticks 0 is `check`'s fresh factorisation."""
    rng = np.random.default_rng(seed)
    ref, _, direction, scale = _at_limit(platform, limit, rng, samples)
    vel = np.zeros((samples, 6))
    for part, speed in ((slice(0, 3), lin_speed), (slice(3, 6), ang_speed)):
        u = rng.normal(size=(samples, 3))
        vel[:, part] = speed * u / np.linalg.norm(u, axis=1)[:, None]
    old = ref - age_ticks * tick_s * vel
    _, ep, er = step_errors(platform, ref, jacobians(platform, old), direction, scale)
    return float(np.max(ep)), float(np.max(er))


#: the speeds of docs/explanation/model.md's table: (m/s, rad/s)
AGED_SPEEDS = ((0.28, 0.0), (0.0, 0.28), (0.3, 0.15), (0.5, 0.0), (0.0, 0.3), (0.5, 0.5))


def firmware_limit() -> float:
    """SP_ESTIMATE_STEP_MAX of sp/estimation/estimate.h, m."""
    text = resources.firmware_header("estimate.h").read_text()
    for line in text.splitlines():
        if line.startswith("#define SP_ESTIMATE_STEP_MAX"):
            return int(line.split("(sp_q24_t)")[1].rstrip(")").strip()) / 2.0**24
    raise LookupError("SP_ESTIMATE_STEP_MAX not found in sp/estimation/estimate.h")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--aged", type=int, nargs="+", metavar="TICKS",
                    help="instead: the step's worst error at SP_ESTIMATE_STEP_MAX through a factorisation "
                         "this many ticks old, at the speeds of docs/explanation/model.md's table (e.g. --aged 0 5 6)")
    args = ap.parse_args(argv)
    if args.aged:
        platform = cfg.load(resources.default_platform())
        fw = firmware_limit()
        print(f"|L_meas - L_ref|_inf = {fw * 1e3:.4f} mm (SP_ESTIMATE_STEP_MAX), {args.samples} samples a cell; "
              "worst step error (um, urad) by the factorisation's age")
        print("speed (m/s, rad/s) | " + " | ".join(f"{a} ticks" for a in args.aged))
        for lin, ang in AGED_SPEEDS:
            cells = []
            for age in args.aged:
                ep, er = aged_check(platform, fw, age, lin, ang, args.samples, args.seed + 1)
                cells.append(f"{ep * 1e6:.2f}, {er * 1e6:.2f}")
            print(f"{lin:.2f}, {ang:.2f} | " + " | ".join(cells))
        return 0
    platform = cfg.load(resources.default_platform())
    b, thr = bound(platform, args.samples, args.seed)
    print(f"1 um / 1 urad bound on |L_meas - L_ref|_inf: {b * 1e3:.4f} mm "
          f"(median threshold {np.median(thr) * 1e3:.3f} mm, {args.samples} samples)")
    b_half, _ = bound(platform, args.samples, args.seed, 0.5e-6, 0.5e-6)
    print(f"0.5 um / 0.5 urad bound: {b_half * 1e3:.4f} mm")
    fw = firmware_limit()
    d_l, ep, er = check(platform, fw, args.samples, args.seed + 1)
    print(f"firmware SP_ESTIMATE_STEP_MAX {fw * 1e3:.4f} mm: worst step error "
          f"{ep * 1e6:.3f} um, {er * 1e6:.3f} urad ({args.samples} samples at |dL|_inf = {d_l * 1e3:.4f} mm)")
    return 0 if fw <= b else 1


if __name__ == "__main__":
    raise SystemExit(main())
