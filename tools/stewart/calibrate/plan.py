# SPDX-License-Identifier: Apache-2.0
"""Calibration poses chosen for identifiability: D-optimal (greedy, then
exchange) selection from random candidates over the whole workspace, on the
nominal geometry's Jacobian."""

from __future__ import annotations

import numpy as np

from .kin import Geometry, Tracker, ik, poses_to_pr
from .solve import Data, Problem, _basis

MARGIN = 0.03           # m kept from each stroke end
EXTREME = 0.6           # share of candidate coordinates drawn at a workspace limit


class PlanError(ValueError):
    """A plan that cannot be made or driven; the message names the pose."""


def reachable(platform, poses, margin=MARGIN):
    """(ok mask, message per pose) for poses (N, 6): inside the workspace and
    every leg inside its stroke with ``margin``."""
    poses = np.atleast_2d(np.asarray(poses, float))
    g = Geometry.of_platform(platform)
    p, r = poses_to_pr(poses)
    lengths = ik(g, p, r)
    rel = poses - np.asarray(platform.home)
    lo, hi = np.asarray(platform.workspace_min), np.asarray(platform.workspace_max)
    msgs = []
    for i in range(len(poses)):
        m = ""
        out = np.flatnonzero((rel[i] < lo - 1e-9) | (rel[i] > hi + 1e-9))
        if len(out):
            k = out[0]
            m = (f"axis {k} is {rel[i, k]:+.4f} from home, outside the workspace "
                 f"[{lo[k]:+.4f}, {hi[k]:+.4f}]")
        else:
            short = np.flatnonzero(lengths[i] < platform.leg_length_min + margin)
            long_ = np.flatnonzero(lengths[i] > platform.leg_length_max - margin)
            if len(short):
                m = (f"leg {short[0] + 1} would be {lengths[i, short[0]]:.4f} m, within {margin * 1e3:.0f} mm "
                     f"of leg_length_min {platform.leg_length_min:g}")
            elif len(long_):
                m = (f"leg {long_[0] + 1} would be {lengths[i, long_[0]]:.4f} m, within {margin * 1e3:.0f} mm "
                     f"of leg_length_max {platform.leg_length_max:g}")
        msgs.append(m)
    return np.array([not m for m in msgs]), msgs


def candidates(platform, n, rng, scale=1.0):
    """``n`` reachable random poses; each coordinate at a workspace limit
    with probability EXTREME, else uniform (identifiability lives at the edges)."""
    home = np.asarray(platform.home)
    lo, hi = np.asarray(platform.workspace_min) * scale, np.asarray(platform.workspace_max) * scale
    out = []
    for _ in range(200):
        u = rng.uniform(lo, hi, (4 * n, 6))
        edge = rng.random((4 * n, 6)) < EXTREME
        side = np.where(rng.random((4 * n, 6)) < 0.5, lo, hi)
        q = home + np.where(edge, side * rng.uniform(0.7, 1.0, (4 * n, 6)), u)
        ok, _ = reachable(platform, q)
        out.extend(q[ok])
        if len(out) >= n:
            return np.array(out[:n])
    raise PlanError("the workspace has too few reachable poses for a plan")


def pose_blocks(nominal: Geometry, tracker: Tracker, poses, fit_scale=False):
    """Per pose, the rows of the scaled, gauge-fixed Jacobian: (N, 3K, m)."""
    p, r = poses_to_pr(poses)
    data = Data(nominal.reading(ik(nominal, p, r)), tracker.observe(p, r), np.asarray(poses, float))
    prob = Problem(nominal, tracker.targets, data, fit_scale)
    _, jac = prob.residual_jacobian(np.zeros(prob.n), tracker.rot, tracker.pos)
    d, q = _basis(prob)
    return ((jac * d) @ q).reshape(len(poses), -1, q.shape[1])


def d_optimal(blocks, count, exchanges=1):
    """Indices of ``count`` poses maximising det(J^T J): greedy from a small
    ridge, then exchange passes."""
    n, rows, m = blocks.shape
    info = np.einsum("nri,nrj->nij", blocks, blocks)
    chosen: list[int] = []
    mat = 1e-6 * np.trace(info.sum(0)) / m / n * np.eye(m)
    for _ in range(count):
        inv = np.linalg.inv(mat)
        gain = np.linalg.slogdet(np.eye(rows) + np.einsum("nri,ij,nsj->nrs", blocks, inv, blocks))[1]
        gain[chosen] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        mat = mat + info[k]
    for _ in range(exchanges):
        improved = False
        for pos in range(count):
            base = sum(info[c] for j, c in enumerate(chosen) if j != pos)
            cur = np.linalg.slogdet(base + info[chosen[pos]])[1]
            inv = np.linalg.inv(base + 1e-12 * np.eye(m))
            gain = np.linalg.slogdet(np.eye(rows) + np.einsum("nri,ij,nsj->nrs", blocks, inv, blocks))[1]
            gain += np.linalg.slogdet(base)[1]
            gain[chosen] = -np.inf
            k = int(np.argmax(gain))
            if gain[k] > cur + 1e-6:
                chosen[pos] = k
                improved = True
        if not improved:
            break
    return chosen


def make_plan(platform, tracker: Tracker, count=60, n_candidates=400, seed=1, fit_scale=False):
    """``count`` D-optimal poses (N, 6) and log det of their information."""
    rng = np.random.default_rng(seed)
    nominal = Geometry.of_platform(platform)
    cand = candidates(platform, n_candidates, rng)
    blocks = pose_blocks(nominal, tracker, cand, fit_scale)
    idx = d_optimal(blocks, count)
    info = np.einsum("nri,nrj->ij", blocks[idx], blocks[idx])
    return cand[idx], float(np.linalg.slogdet(info)[1])
