# SPDX-License-Identifier: Apache-2.0
"""``stewart calibrate check`` from external measurements alone: no truth.

A check run measures fresh validation poses (not used by ``solve``): the six
leg length readings at rest and the tracker's targets, as the calibration run
did (the same measurement CSV). At rest a controller holds the readings at
which its geometry's forward kinematics gives the commanded pose, so the pose
error a config makes at readings ``r`` is ``measured pose - fk_config(r)``:
each config's error is found at the measured readings, whichever config
drove the machine there (the nominal firmware can make the check run; the
calibrated config need not be built before it has passed).

The measured pose: the tracker's pose in the base frame from the check run's
own base fiducials (else the one ``solve`` found, the tracker not moved), the
targets into the base frame, and the rigid fit of the instrument's target
coordinates (motion frame) to them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kin import Geometry, fk, kabsch, poses_to_pr, rotation_angle, skew
from .solve import Data

OUTLIER_SIGMA = 6.0   # a pose whose targets fit this many sigma worse than the noise is refused


class CheckError(ValueError):
    """A check that cannot be made; the message names the row or pose."""


@dataclass
class Measured:
    p: np.ndarray           # (N, 3) o' in the base frame, m
    r: np.ndarray           # (N, 3, 3) motion -> base
    fit_rms: np.ndarray     # (N,) target residual RMS per coordinate of each pose's fit, m
    pos_floor: np.ndarray   # (N,) the instrument's own position uncertainty of o' (3-D RMS), m
    rot_floor: np.ndarray   # (N,) and of the orientation (3-D RMS), rad
    tracker: str            # where the tracker's pose came from


def tracker_pose(data: Data, record: dict | None):
    """(rot, pos, how): x_base = rot x_tracker + pos."""
    if data.fiducials is not None and len(data.fiducials) >= 3:
        rot, pos = kabsch(data.fiducials, data.fiducials_base)
        return rot, pos, f"from the check run's {len(data.fiducials)} base fiducial readings"
    if record and "tracker_rot" in record and "tracker_pos" in record:
        return (np.asarray(record["tracker_rot"], float), np.asarray(record["tracker_pos"], float),
                "as solve found it (no base fiducials in the check run: the tracker must not have moved)")
    raise CheckError("the check run has no base fiducial readings (F1..) and the calibrated config no "
                     "calibration.tracker_pos: the tracker's pose is unknown")


def measured_poses(data: Data, targets_motion, noise: float, record: dict | None = None) -> Measured:
    """The platform's pose at each check pose from the tracker alone."""
    c = np.asarray(targets_motion, float)
    rot, pos, how = tracker_pose(data, record)
    n = len(data.readings)
    p, r = np.zeros((n, 3)), np.zeros((n, 3, 3))
    fit, pfl, rfl = np.zeros(n), np.zeros(n), np.zeros(n)
    for i in range(n):
        seen = np.isfinite(data.targets[i]).all(-1)
        if seen.sum() < 3:
            where = f" (row {int(data.rows[i][seen][0])})" if data.rows is not None and seen.any() else ""
            raise CheckError(f"pose {i + 1}{where}: {int(seen.sum())} target(s) measured, the pose needs 3")
        world = data.targets[i][seen] @ rot.T + pos
        r[i], p[i] = kabsch(c[seen], world)
        res = c[seen] @ r[i].T + p[i] - world
        fit[i] = np.sqrt(np.mean(res ** 2))
        # the fit's covariance: rows [I, -[R c]x] per target, noise per coordinate
        jac = np.concatenate([np.hstack([np.eye(3), -skew(r[i] @ ck)]) for ck in c[seen]])
        cov = np.linalg.inv(jac.T @ jac) * noise ** 2
        pfl[i], rfl[i] = np.sqrt(np.trace(cov[:3, :3])), np.sqrt(np.trace(cov[3:, 3:]))
        dof = 3 * int(seen.sum()) - 6
        if dof > 0 and noise > 0:
            sigma_fit = np.sqrt(np.sum(res ** 2) / dof)
            if sigma_fit > OUTLIER_SIGMA * noise:
                rows = "" if data.rows is None else f" (rows {', '.join(str(int(x)) for x in data.rows[i][seen])})"
                raise CheckError(f"pose {i + 1}{rows}: the targets fit a rigid platform to {sigma_fit * 1e6:.0f} um, "
                                 f"{sigma_fit / noise:.0f}x the instrument's noise: an outlier reading or a "
                                 "target that moved; measure the pose again")
    return Measured(p, r, fit, pfl, rfl, how)


def config_errors(g: Geometry, data: Data, meas: Measured):
    """(position error (N,) m, orientation error (N,) rad) that a controller
    with geometry ``g`` makes at the measured readings."""
    p0, r0 = poses_to_pr(data.commanded)
    p, r = fk(g, g.length(data.readings), p0, r0)
    return np.linalg.norm(p - meas.p, axis=1), rotation_angle(r @ np.transpose(meas.r, (0, 2, 1)))


def summary(pos, rot) -> dict:
    return {"pos_rms": float(np.sqrt(np.mean(pos ** 2))), "pos_max": float(np.max(pos)),
            "rot_rms": float(np.sqrt(np.mean(rot ** 2))), "rot_max": float(np.max(rot))}
