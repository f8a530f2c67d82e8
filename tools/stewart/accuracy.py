# SPDX-License-Identifier: Apache-2.0
"""Accuracy of the fixed-point firmware core against the float64 model, on
random poses and motions around home (the issue's box: +-0.2 m in x and y,
+-0.15 m in z, +-15 deg about each axis, velocities to 1 m/s and 1 rad/s,
accelerations to 10 m/s^2 and 10 rad/s^2).

Used by ``stewart accuracy`` (prints the figures) and by the tests (assert
the bounds). Both sides see the same inputs: the poses are rounded to the
core's Q24 first, so the errors are the core's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import model
from .core import Core

Q24 = float(1 << 24)

# The bounds the issue sets (and the tests assert).
BOUND_LENGTH = 1e-6   # m
BOUND_FORCE = 0.05    # N
BOUND_FK_POS = 1e-6   # m
BOUND_FK_ROT = 5e-6   # rad
BOUND_FK_ITER = 3     # Newton steps, warm-started one 1 kHz tick away


@dataclass
class Report:
    n: int
    length: float = 0.0
    stretch: float = 0.0
    force: float = 0.0
    fk_pos: float = 0.0
    fk_rot: float = 0.0
    fk_iter_max: int = 0
    failures: int = 0

    def ok(self) -> bool:
        return (self.failures == 0 and self.length <= BOUND_LENGTH and self.force <= BOUND_FORCE
                and self.fk_pos <= BOUND_FK_POS and self.fk_rot <= BOUND_FK_ROT
                and self.fk_iter_max <= BOUND_FK_ITER)

    def lines(self) -> list[str]:
        return [
            f"fixed-point core vs float64 model, {self.n} random poses and motions around home",
            f"  leg length      max error {self.length * 1e6:9.4f} um   (bound {BOUND_LENGTH * 1e6:g} um)",
            f"  stretch         max error {self.stretch * 1e6:9.4f} um",
            f"  cylinder force  max error {self.force:9.4f} N    (bound {BOUND_FORCE:g} N)",
            f"  FK position     max error {self.fk_pos * 1e6:9.4f} um   (bound {BOUND_FK_POS * 1e6:g} um)",
            f"  FK orientation  max error {self.fk_rot * 1e6:9.4f} urad (bound {BOUND_FK_ROT * 1e6:g} urad)",
            f"  FK iterations   max {self.fk_iter_max} warm-started from the previous 1 kHz tick "
            f"(bound {BOUND_FK_ITER})",
            f"  failures        {self.failures}",
        ]


def _quantize(v):
    return np.round(np.asarray(v, dtype=float) * Q24) / Q24


def random_motions(platform, n: int, seed: int = 1):
    """n random (pose, vel, rpy_rate, acc, rpy_acc), each already on the Q24 grid."""
    rng = np.random.default_rng(seed)
    home = np.array(platform.home, dtype=float)
    lo = np.array([-0.2, -0.2, -0.15] + [-math.radians(15)] * 3)
    out = []
    for _ in range(n):
        pose = _quantize(home + rng.uniform(lo, -lo))
        vel = _quantize(rng.uniform(-1, 1, 3))
        rate = _quantize(rng.uniform(-1, 1, 3))
        acc = _quantize(rng.uniform(-10, 10, 3))
        racc = _quantize(rng.uniform(-10, 10, 3))
        out.append((pose, vel, rate, acc, racc))
    return out


def measure(platform, n: int = 10000, seed: int = 1, step: Callable[[], None] | None = None) -> Report:
    """The report over n random motions; ``step`` is called as each one starts."""
    core = Core(platform)
    rep = Report(n)
    home_len = np.asarray(model.inverse_kinematics(platform, np.array(platform.home, dtype=float)).lengths)
    rng = np.random.default_rng(seed + 1)
    for pose, vel, rate, acc, racc in random_motions(platform, n, seed):
        if step is not None:
            step()
        r = core.calc(pose, vel, rate, acc, racc)
        if r.length is None:
            rep.failures += 1
            continue
        ik = model.inverse_kinematics(platform, pose)
        lengths = np.asarray(ik.lengths)
        f_model = np.asarray(model.inverse_dynamics(platform, pose, vel, rate, acc, racc))
        rep.length = max(rep.length, float(np.max(np.abs(np.asarray(r.length) - lengths))))
        rep.stretch = max(rep.stretch, float(np.max(np.abs(np.asarray(r.stretch) - (lengths - home_len)))))
        rep.force = max(rep.force, float(np.max(np.abs(np.asarray(r.force) - f_model))))
        # FK: the true lengths (as a 1 um-class sensor would give them, on the
        # Q24 grid), warm-started from where the platform was one tick ago
        # when moving at up to 1 m/s and 1 rad/s.
        guess = pose - rng.uniform(-1e-3, 1e-3, 6)
        status, est, iterations = core.forward_kinematics(_quantize(lengths), guess)
        if est is None:
            rep.failures += 1
            continue
        est = np.asarray(est)
        rep.fk_pos = max(rep.fk_pos, float(np.max(np.abs(est[:3] - pose[:3]))))
        rep.fk_rot = max(rep.fk_rot, float(np.max(np.abs(est[3:] - pose[3:]))))
        rep.fk_iter_max = max(rep.fk_iter_max, iterations)
    return rep
