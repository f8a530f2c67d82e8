# SPDX-License-Identifier: Apache-2.0
"""What bounds the workspace, pose by pose (vectorised over any number of
poses): the strokes, the passive joints' cone angles and the legs'
clearance from one another; and the distance to singularity (the force
transformation's condition number and smallest singular value).

Each limit is a margin, positive inside: metres for the strokes and the
clearance, radians for the joints. ``margins`` returns the margins and the
leg (or leg pair) that sets each, so a verdict can name what limits it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import model

PAIRS = [(i, j) for i in range(6) for j in range(i + 1, 6)]


class MissingKey(ValueError):
    """The config lacks a key an analysis needs; the message names it."""


def need(platform, *keys: str) -> None:
    """Raises MissingKey naming the first of ``keys`` (``section.key``) the config lacks."""
    for key in keys:
        section, _, name = key.partition(".")
        d = getattr(platform, section, None) or {}
        if name not in d:
            raise MissingKey(f"{platform.source}: {key}: missing (stewart design needs it; config/README.md)")


@dataclass
class Legs:
    """The legs at (..., 6) poses, base frame."""
    rot: np.ndarray     # (..., 3, 3)
    arms: np.ndarray    # (..., 6, 3) R a_i
    tops: np.ndarray    # (..., 6, 3) platform joints A_i
    lengths: np.ndarray  # (..., 6)
    units: np.ndarray   # (..., 6, 3)


def legs(platform, poses) -> Legs:
    poses = np.asarray(poses, dtype=float)
    rot = model.rotation_many(poses[..., 3:])
    arms = np.einsum("...jk,ik->...ij", rot, np.asarray(platform.platform_joints, dtype=float))
    tops = arms + poses[..., None, :3]
    vec = tops - np.asarray(platform.base_joints, dtype=float)
    lengths = np.linalg.norm(vec, axis=-1)
    return Legs(rot, arms, tops, lengths, vec / lengths[..., None])


def force_matrix(lg: Legs) -> np.ndarray:
    """(..., 6, 6): column i is [u_i ; (R a_i) x u_i] (``model.force_matrix``)."""
    return np.concatenate([np.swapaxes(lg.units, -1, -2),
                           np.swapaxes(np.cross(lg.arms, lg.units), -1, -2)], axis=-2)


def segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Shortest distance between segments p1-q1 and p2-q2 (arrays (..., 3))."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...k,...k->...", d1, d1)
    e = np.einsum("...k,...k->...", d2, d2)
    b = np.einsum("...k,...k->...", d1, d2)
    c = np.einsum("...k,...k->...", d1, r)
    f = np.einsum("...k,...k->...", d2, r)
    denom = a * e - b * b
    s = np.where(denom > 1e-12 * a * e, np.clip((b * f - c * e) / np.where(denom > 0, denom, 1.0), 0, 1), 0.0)
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    gap = p1 + s[..., None] * d1 - p2 - t[..., None] * d2
    return np.linalg.norm(gap, axis=-1)


@dataclass
class Margins:
    """Per pose: each limit's margin and the leg (pair index) that sets it."""
    stroke: np.ndarray
    stroke_leg: np.ndarray
    base_cone: np.ndarray
    base_leg: np.ndarray
    platform_cone: np.ndarray
    platform_leg: np.ndarray
    clearance: np.ndarray
    clearance_pair: np.ndarray

    def inside(self) -> np.ndarray:
        return ((self.stroke >= 0) & (self.base_cone >= 0) & (self.platform_cone >= 0)
                & (self.clearance >= 0))


def _cone_margins(platform, lg: Legs):
    """Angle between each leg and its direction at home, at the base (base
    frame) and at the platform (motion frame), against the cone limits."""
    home = legs(platform, np.asarray(platform.home, dtype=float))
    u0_base = home.units
    u0_plat = np.einsum("kj,ik->ij", home.rot, home.units)
    u_plat = np.einsum("...kj,...ik->...ij", lg.rot, lg.units)
    ang_b = np.arccos(np.clip(np.einsum("...ik,ik->...i", lg.units, u0_base), -1.0, 1.0))
    ang_p = np.arccos(np.clip(np.einsum("...ik,ik->...i", u_plat, u0_plat), -1.0, 1.0))
    joints = platform.joints or {}
    mb = joints.get("base_cone_max", np.inf) - ang_b
    mp = joints.get("platform_cone_max", np.inf) - ang_p
    return mb, mp


def margins(platform, poses) -> Margins:
    lg = legs(platform, poses)
    st = np.minimum(lg.lengths - platform.leg_length_min, platform.leg_length_max - lg.lengths)
    mb, mp = _cone_margins(platform, lg)
    base = np.broadcast_to(np.asarray(platform.base_joints, dtype=float), lg.tops.shape)
    od = (platform.hydraulic or {}).get("cylinder_outer_diameter")
    if od is None:
        clear = np.full(lg.lengths.shape[:-1] + (len(PAIRS),), np.inf)
    else:
        i = [p[0] for p in PAIRS]
        j = [p[1] for p in PAIRS]
        clear = segment_distance(base[..., i, :], lg.tops[..., i, :], base[..., j, :], lg.tops[..., j, :]) - od
    return Margins(st.min(axis=-1), st.argmin(axis=-1), mb.min(axis=-1), mb.argmin(axis=-1),
                   mp.min(axis=-1), mp.argmin(axis=-1), clear.min(axis=-1), clear.argmin(axis=-1))


def inside(platform, poses: np.ndarray) -> np.ndarray:
    """``margins(...).inside()`` for (n, 6) poses, cheaper: each limit is
    computed only where the ones before it hold (clearance last)."""
    lg = legs(platform, poses)
    ok = ((lg.lengths >= platform.leg_length_min) & (lg.lengths <= platform.leg_length_max)).all(axis=-1)
    idx = np.flatnonzero(ok)
    sub = Legs(lg.rot[idx], lg.arms[idx], lg.tops[idx], lg.lengths[idx], lg.units[idx])
    mb, mp = _cone_margins(platform, sub)
    keep = (mb.min(axis=-1) >= 0) & (mp.min(axis=-1) >= 0)
    idx, sub = idx[keep], Legs(sub.rot[keep], sub.arms[keep], sub.tops[keep], sub.lengths[keep], sub.units[keep])
    od = (platform.hydraulic or {}).get("cylinder_outer_diameter")
    if od is not None and idx.size:
        base = np.broadcast_to(np.asarray(platform.base_joints, dtype=float), sub.tops.shape)
        i = [p[0] for p in PAIRS]
        j = [p[1] for p in PAIRS]
        clear = segment_distance(base[:, i, :], sub.tops[:, i, :], base[:, j, :], sub.tops[:, j, :]).min(axis=-1)
        idx = idx[clear >= od]
    out = np.zeros(poses.shape[0], dtype=bool)
    out[idx] = True
    return out


def limiter(platform, pose) -> tuple[float, str]:
    """The tightest limit at one pose: (margin, what sets it), margins in m or rad."""
    m = margins(platform, np.asarray(pose, dtype=float)[None, :])
    lg = legs(platform, np.asarray(pose, dtype=float))
    cands = []
    k = int(m.stroke_leg[0])
    end = "leg_length_max" if lg.lengths[k] > 0.5 * (platform.leg_length_min + platform.leg_length_max) \
        else "leg_length_min"
    cands.append((float(m.stroke[0]), f"leg {k + 1} stroke ({end}, {lg.lengths[k]:.4f} m)"))
    if np.isfinite(m.base_cone[0]):
        cands.append((float(m.base_cone[0]), f"leg {int(m.base_leg[0]) + 1} base joint angle"))
    if np.isfinite(m.platform_cone[0]):
        cands.append((float(m.platform_cone[0]), f"leg {int(m.platform_leg[0]) + 1} platform joint angle"))
    if np.isfinite(m.clearance[0]):
        a, b = PAIRS[int(m.clearance_pair[0])]
        cands.append((float(m.clearance[0]), f"legs {a + 1} and {b + 1} clearance"))
    return min(cands, key=lambda c: c[0])


def conditioning(platform, poses) -> tuple[np.ndarray, np.ndarray]:
    """Condition number and smallest singular value of the force
    transformation at each pose (N and N m columns as in the model)."""
    sv = np.linalg.svd(force_matrix(legs(platform, poses)), compute_uv=False)
    return sv[..., 0] / sv[..., -1], sv[..., -1]
