# SPDX-License-Identifier: Apache-2.0
"""Workspaces on grids: the constant-orientation workspace (positions of
o' reachable at a fixed orientation), the orientation workspace (angles
reachable at a fixed position) and the duty's envelope.

The workspaces are the machine's geometric ones (strokes, joints,
clearance), not clipped to the config's ``workspace`` box (a limit the
firmware enforces). Grids are cell-centred over a box found by scanning
each axis from the centre and grown until no reachable cell touches its
faces, so a volume is the count of reachable cells times a cell's volume.
"""

from __future__ import annotations

import numpy as np

from . import limits


def axis_grid(lo: float, hi: float, step: float) -> tuple[np.ndarray, float]:
    """Cell centres covering [lo, hi] with cells of at most ``step``; the
    actual cell size."""
    n = max(1, int(np.ceil((hi - lo) / step - 1e-9)))
    h = (hi - lo) / n
    return lo + h * (np.arange(n) + 0.5), h


POSITION_REACH = 4.0   # m from the centre: farther is beyond any sensible platform
ANGLE_REACH = 1.2      # rad: the config's bound on angles (Euler angles near gimbal lock)


def _scan(platform, centre: np.ndarray, k: int, sign: float, reach: float) -> float:
    """How far along axis k from ``centre`` the poses stay reachable."""
    t = np.linspace(0.0, reach, 801)
    poses = np.tile(centre, (t.size, 1))
    poses[:, k] += sign * t
    ok = limits.inside(platform, poses)
    return float(t[np.argmin(ok)] if not ok.all() else reach)


def reach_box(platform, centre, axes: range, reach: float, step: float) -> list:
    """[lo, hi] per axis of a box holding every reachable pose of the
    ``axes`` around ``centre`` (the other coordinates fixed)."""
    centre = np.asarray(centre, dtype=float)
    box = [[centre[k] - 1.3 * _scan(platform, centre, k, -1.0, reach) - step,
            centre[k] + 1.3 * _scan(platform, centre, k, 1.0, reach) + step] for k in axes]
    return [[max(lo, centre[k] - reach), min(hi, centre[k] + reach)] for (lo, hi), k in zip(box, axes)]


def _grid(platform, centre, axes: range, reach: float, step: float):
    """Cell-centred grid over the reach box, grown until no reachable cell
    lies on a face that could grow: (axes' grids, cell size, mask)."""
    centre = np.asarray(centre, dtype=float)
    box = reach_box(platform, centre, axes, reach, step)
    for _ in range(6):
        grids = [axis_grid(lo, hi, step) for lo, hi in box]
        mesh = np.meshgrid(*[g for g, _ in grids], indexing="ij")
        poses = np.broadcast_to(centre, mesh[0].shape + (6,)).copy()
        for m, k in zip(mesh, axes):
            poses[..., k] = m
        mask = _inside(platform, poses.reshape(-1, 6)).reshape(mesh[0].shape)
        grown = False
        for d, k in enumerate(axes):
            for end, face in ((0, 0), (1, -1)):
                at_cap = abs(box[d][end] - centre[k]) >= reach - 1e-12
                if not at_cap and np.take(mask, face, axis=d).any():
                    box[d][end] = centre[k] + 1.5 * (box[d][end] - centre[k])
                    grown = True
        if not grown:
            return [g for g, _ in grids], float(np.prod([h for _, h in grids])), mask
    raise RuntimeError("the workspace grid did not close")


def constant_orientation(platform, rpy, step: float) -> dict:
    """Reachable positions at orientation ``rpy`` (absolute): the volume (m^3),
    the grid and the boolean mask (nx, ny, nz)."""
    centre = np.concatenate([np.asarray(platform.home[:3], float), np.asarray(rpy, dtype=float)])
    (gx, gy, gz), cell, mask = _grid(platform, centre, range(3), POSITION_REACH, step)
    return {"volume": float(mask.sum() * cell), "x": gx, "y": gy, "z": gz, "mask": mask, "cell": cell}


def orientation_workspace(platform, position, step: float) -> dict:
    """Reachable orientations at position ``position`` (absolute): the
    volume in rad^3, the largest roll, pitch and yaw reached alone, the mask."""
    home = np.asarray(platform.home, dtype=float)
    centre = np.concatenate([np.asarray(position, dtype=float), home[3:]])
    (gr, gp, gw), cell, mask = _grid(platform, centre, range(3, 6), ANGLE_REACH, step)
    alone = [[float(centre[k] - _scan(platform, centre, k, -1.0, ANGLE_REACH)),
              float(centre[k] + _scan(platform, centre, k, 1.0, ANGLE_REACH))] for k in range(3, 6)]
    return {"volume": float(mask.sum() * cell), "roll": gr, "pitch": gp, "yaw": gw, "mask": mask,
            "alone": alone}


def _inside(platform, poses: np.ndarray, chunk: int = 100000) -> np.ndarray:
    out = np.empty(poses.shape[0], dtype=bool)
    for s in range(0, poses.shape[0], chunk):
        out[s:s + chunk] = limits.inside(platform, poses[s:s + chunk])
    return out


def envelope_poses(platform, duty, points: int | None = None) -> np.ndarray:
    """The duty's excursion box (relative to home) as a grid of absolute
    poses, ``points`` per moving axis (its ends included)."""
    n = points or duty.envelope_points
    home = np.asarray(platform.home, dtype=float)
    axes = [np.linspace(lo, hi, n) if hi > lo else np.array([lo])
            for lo, hi in zip(duty.excursion_min, duty.excursion_max)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 6)
    return grid + home


def envelope_check(platform, duty, poses: np.ndarray) -> dict:
    """The tightest limit over the envelope's poses: the margin (m or rad),
    the pose and what sets it."""
    m = limits.margins(platform, poses)
    worst = np.minimum(np.minimum(m.stroke, m.clearance), np.minimum(m.base_cone, m.platform_cone))
    k = int(np.argmin(worst))
    margin, what = limits.limiter(platform, poses[k])
    cond, smin = limits.conditioning(platform, poses)
    return {"margin": margin, "pose": poses[k].tolist(), "limit": what,
            "inside_fraction": float(m.inside().mean()), "cond_max": float(cond.max()),
            "smin_min": float(smin.min())}


def conditioning_map(platform, rpy, step: float) -> dict:
    """Condition number and smallest singular value over the reachable
    x-y plane at home height and orientation ``rpy``."""
    centre = np.concatenate([platform.home[:3], rpy])
    box = reach_box(platform, centre, range(2), POSITION_REACH, step)
    gx, gy = (axis_grid(lo, hi, step)[0] for lo, hi in box)
    xx, yy = np.meshgrid(gx, gy, indexing="ij")
    poses = np.zeros(xx.shape + (6,))
    poses[..., 0], poses[..., 1] = xx, yy
    poses[..., 2] = platform.home[2]
    poses[..., 3:] = rpy
    ok = limits.margins(platform, poses).inside()
    cond, smin = limits.conditioning(platform, poses)
    return {"x": gx, "y": gy, "cond": np.where(ok, cond, np.nan), "smin": np.where(ok, smin, np.nan)}
