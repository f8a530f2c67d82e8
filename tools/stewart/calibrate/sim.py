# SPDX-License-Identifier: Apache-2.0
"""The float64 machine: what a controller with one geometry does on a
machine built to another, and what the tracker sees (no dynamics: the
drives hold each commanded reading exactly at rest)."""

from __future__ import annotations

import numpy as np

from .kin import Geometry, Tracker, base_frame_fit, fk, ik, poses_to_pr, rotation_angle
from .solve import Data


def reached(controller: Geometry, truth: Geometry, poses, quantum=1e-7):
    """Where the machine ``truth`` stands (p, R in its own base frame) when a
    controller with ``controller`` commands ``poses`` (N, 6), and the readings
    (quantized to the sensors' ``quantum``)."""
    p, r = poses_to_pr(poses)
    cmd = controller.reading(ik(controller, p, r))
    cmd = np.round(cmd / quantum) * quantum
    pt, rt = fk(truth, truth.length(cmd), p, r)
    return pt, rt, cmd


#: Default base fiducials: three reflector nests on the base's floor plate
#: (base frame, m); they define the base frame for the tracker.
DEFAULT_FIDUCIALS = np.array([[2.2, 0.0, 0.0], [-1.1, 1.9, 0.0], [-1.1, -1.9, 0.0], [0.0, 0.0, 0.6]])


def measure(controller: Geometry, truth: Geometry, tracker: Tracker, poses, rng,
            fiducials=DEFAULT_FIDUCIALS, fiducial_repeats=20) -> Data:
    """The measurements of a calibration run at ``poses`` (with the base
    fiducials measured ``fiducial_repeats`` times each, unless ``fiducials`` is None)."""
    pt, rt, cmd = reached(controller, truth, poses)
    obs = tracker.observe(pt, rt) + rng.normal(0.0, tracker.noise, (len(pt), len(tracker.targets), 3))
    data = Data(cmd, obs, np.asarray(poses, float))
    if fiducials is not None:
        f = np.tile(np.asarray(fiducials, float), (fiducial_repeats, 1))
        data.fiducials = (f - tracker.pos) @ tracker.rot + rng.normal(0.0, tracker.noise, f.shape)
        data.fiducials_base = f
    return data


def pose_errors(controller: Geometry, truth: Geometry, nominal: Geometry, poses, fiducials=True):
    """Absolute position error (m) and orientation error (rad) per pose: the
    commanded pose against where the machine stands, in the base frame the
    calibration defines: the fiducials' (the plant's own frame), or without
    fiducials the true base joints' best fit to the drawn ones."""
    pt, rt, _ = reached(controller, truth, poses)
    if fiducials:
        gr, gt = np.eye(3), np.zeros(3)
    else:
        gr, gt = base_frame_fit(truth.base, nominal.base)
    pt = pt @ gr.T + gt
    rt = gr @ rt
    p, r = poses_to_pr(poses)
    return np.linalg.norm(pt - p, axis=1), rotation_angle(rt @ np.transpose(r, (0, 2, 1)))
