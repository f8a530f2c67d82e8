# SPDX-License-Identifier: Apache-2.0
"""Kinematics of a calibration: a geometry (joints, sensor zeros and
scales), inverse and forward kinematics over many poses at once, the laser
tracker's measurement model (float64, numpy).

Poses are (p, R): position of o' in the base frame (N, 3) and the column
rotation motion -> base (N, 3, 3); small rotations are vectors in the base
frame (R -> (I + [w]x) R)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import asbuilt
from ..model import rotation_many

LEGS = 6


@dataclass
class Geometry:
    """What a calibration finds: the joints, each sensor's zero and scale
    (``stewart.asbuilt.reading``)."""
    base: np.ndarray          # (6, 3) base frame, m
    plat: np.ndarray          # (6, 3) motion frame, m
    lmin: float
    zero: np.ndarray = field(default_factory=lambda: np.zeros(LEGS))
    scale: np.ndarray = field(default_factory=lambda: np.zeros(LEGS))

    @classmethod
    def of_platform(cls, p) -> "Geometry":
        ls = p.length_sensors
        return cls(np.array(p.base_joints, float), np.array(p.platform_joints, float), float(p.leg_length_min),
                   np.array(ls["zero"], float), np.array(ls["scale"], float))

    def as_built(self, section: dict) -> "Geometry":
        """This geometry with a (parsed) ``as_built`` section applied."""
        return replace(self, base=self.base + np.array(section["base_joints"]),
                       plat=self.plat + np.array(section["platform_joints"]),
                       zero=self.zero + np.array(section["length_zero"]),
                       scale=self.scale + np.array(section["length_scale"]))

    def reading(self, lengths):
        return self.lmin + (1.0 + self.scale) * (np.asarray(lengths) - self.lmin) + self.zero

    def length(self, readings):
        return self.lmin + (np.asarray(readings) - self.zero - self.lmin) / (1.0 + self.scale)


def poses_to_pr(poses):
    poses = np.atleast_2d(np.asarray(poses, float))
    return poses[:, :3].copy(), rotation_many(poses[:, 3:])


def pr_to_poses(p, r):
    """[x, y, z, roll, pitch, yaw] from (p, R = Rz Ry Rx)."""
    pitch = np.arcsin(np.clip(-r[:, 2, 0], -1.0, 1.0))
    roll = np.arctan2(r[:, 2, 1], r[:, 2, 2])
    yaw = np.arctan2(r[:, 1, 0], r[:, 0, 0])
    return np.column_stack([p, roll, pitch, yaw])


def skew(w):
    w = np.asarray(w, float)
    z = np.zeros(w.shape[:-1])
    return np.stack([np.stack([z, -w[..., 2], w[..., 1]], -1), np.stack([w[..., 2], z, -w[..., 0]], -1),
                     np.stack([-w[..., 1], w[..., 0], z], -1)], -2)


def rodrigues(w):
    """exp([w]x) for (..., 3) rotation vectors."""
    w = np.asarray(w, float)
    th = np.linalg.norm(w, axis=-1)[..., None, None]
    k = skew(w)
    small = th < 1e-12
    ths = np.where(small, 1.0, th)
    a = np.where(small, 1.0, np.sin(ths) / ths)
    b = np.where(small, 0.5, (1.0 - np.cos(ths)) / ths ** 2)
    return np.eye(3) + a * k + b * (k @ k)


def rotation_angle(r):
    """Angle of each rotation matrix, rad."""
    c = (np.trace(r, axis1=-2, axis2=-1) - 1.0) / 2.0
    s = np.linalg.norm(np.stack([r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0],
                                 r[..., 1, 0] - r[..., 0, 1]], -1), axis=-1) / 2.0
    return np.arctan2(s, c)


def legs(g: Geometry, p, r):
    """Leg vectors (N, 6, 3), arms R a (N, 6, 3)."""
    arms = np.einsum("nij,lj->nli", r, g.plat)
    return arms + p[:, None, :] - g.base[None], arms


def ik(g: Geometry, p, r):
    """Joint-to-joint lengths (N, 6)."""
    v, _ = legs(g, p, r)
    return np.linalg.norm(v, axis=-1)


def pose_jacobian(g: Geometry, p, r):
    """d lengths / d (dp, dw): (N, 6, 6); also the unit legs and arms."""
    v, arms = legs(g, p, r)
    u = v / np.linalg.norm(v, axis=-1)[..., None]
    return np.concatenate([u, np.cross(arms, u)], -1), u, arms


def fk(g: Geometry, lengths, p0, r0, tol=1e-13, iterations=30):
    """Poses whose joint-to-joint lengths are ``lengths`` (N, 6), Newton from
    (p0, r0). Raises RuntimeError naming the poses that do not converge."""
    p, r = np.array(p0, float), np.array(r0, float)
    lengths = np.asarray(lengths, float)
    for _ in range(iterations):
        jp, _, _ = pose_jacobian(g, p, r)
        err = ik(g, p, r) - lengths
        step = np.linalg.solve(jp, -err[..., None])[..., 0]
        p = p + step[:, :3]
        r = rodrigues(step[:, 3:]) @ r
        if np.max(np.abs(step)) < tol:
            return p, r
    bad = np.flatnonzero(np.max(np.abs(ik(g, p, r) - lengths), axis=1) > 1e-9)
    if len(bad):
        raise RuntimeError(f"forward kinematics does not converge for pose(s) {', '.join(str(i + 1) for i in bad[:8])}")
    return p, r


@dataclass
class Tracker:
    """A laser tracker: its frame in the base frame (x_base = rot x_trk + pos)
    and the targets it sees on the platform (motion frame, m)."""
    rot: np.ndarray
    pos: np.ndarray
    targets: np.ndarray
    noise: float = 10e-6

    def observe(self, p, r):
        """Target positions in the tracker's frame (N, K, 3), noise-free."""
        world = p[:, None, :] + np.einsum("nij,kj->nki", r, self.targets)
        return np.einsum("ji,nkj->nki", self.rot, world - self.pos)


#: Default targets: four retro-reflectors on the platform's top plate
#: (motion frame, m), not in one plane, so that three of them fix the pose.
DEFAULT_TARGETS = np.array([[0.9, 0.0, 0.02], [-0.45, 0.78, 0.02], [-0.45, -0.78, 0.02], [0.0, 0.0, 0.35]])


def default_tracker(seed: int, noise: float = 10e-6, targets=DEFAULT_TARGETS) -> Tracker:
    """A tracker 3-4 m from the base's centre, about 1.5 m up, looking at it,
    its pose drawn from ``seed`` (the calibration does not know it)."""
    rng = np.random.default_rng(seed + 7919)
    az = rng.uniform(-np.pi, np.pi)
    dist = rng.uniform(3.0, 4.0)
    pos = np.array([dist * np.cos(az), dist * np.sin(az), rng.uniform(1.0, 2.0)])
    rot = rodrigues(rng.normal(0.0, 1.0, 3) * 0.8) @ rodrigues(np.array([0.0, 0.0, az + np.pi]))
    return Tracker(rot, pos, np.array(targets, float), noise)


def base_frame_fit(true_base, nominal_base):
    """The rigid transform (R, t) taking the true base joints nearest to the
    drawn ones (least squares): the base frame a calibration defines."""
    ct, cn = true_base.mean(0), nominal_base.mean(0)
    h = (true_base - ct).T @ (nominal_base - cn)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return rot, cn - rot @ ct


def kabsch(src, dst):
    """(R, t) with dst ~ R src + t, least squares over (M, 3) points."""
    return base_frame_fit(np.asarray(src), np.asarray(dst))
