# SPDX-License-Identifier: Apache-2.0
"""The tool's pose in the work frame (issue 31), float64, for the analysis.

A *tool frame* T is a fixed pose of the tool in the platform's frame o'
(offset in m, roll-pitch-yaw in rad, Z-Y-X as every pose of the project);
a *work frame* W a fixed pose in the base frame. A platform pose (o' in the
base frame: position p, rotation R) puts T at

    p_TW = R_W^T (p + R t - w),     R_TW = R_W^T R R_T

(t, R_T: the tool frame's offset and rotation; w, R_W: the work frame's).
With both frames identity, T in W is the platform pose itself. This is
stewart.frames (the core's float64 reference) for many poses at once;
tests/python/test_toolpose.py checks the two agree.

:func:`attach_tool` computes it for the reference, the controller's
estimate and the plant's truth of a decoded run (``LogData.tool``), which
signals.csv writes as ``tool_ref_*``, ``tool_est_*`` and ``tool_truth_*``
and :func:`tool_tracking` reduces to the tracking at the tool point.
"""

from __future__ import annotations

import numpy as np

from .. import frames
from ..model import rotation_many

IDENTITY = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def rpy_of(rot: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (Z-Y-X, R = Rz Ry Rx) of rotation matrices (..., 3, 3)."""
    rot = np.asarray(rot, dtype=float)
    roll = np.arctan2(rot[..., 2, 1], rot[..., 2, 2])
    pitch = np.arcsin(np.clip(-rot[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(rot[..., 1, 0], rot[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def check_frame(frame, name: str) -> tuple[float, ...]:
    """A frame as six finite floats within the core's bounds
    (stewart.frames.check_frame: ValueError naming it otherwise)."""
    return frames.check_frame(frame, f"{name} frame", name)


def tool_in_work(poses: np.ndarray, tool=IDENTITY, work=IDENTITY) -> np.ndarray:
    """Platform poses (N, 6) (o' in the base frame) -> the tool's poses in
    the work frame (N, 6); NaN rows stay NaN."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 6)
    tool, work = check_frame(tool, "tool"), check_frame(work, "work")
    r = rotation_many(poses[:, 3:])                         # (N, 3, 3)
    rt = rotation_many(np.asarray(tool[3:]))
    rw = rotation_many(np.asarray(work[3:]))
    tip = poses[:, :3] + r @ np.asarray(tool[:3])           # the tool point, base frame
    pos = (tip - np.asarray(work[:3])) @ rw                 # R_W^T (tip - w), row vectors
    rot = rw.T @ r @ rt
    return np.concatenate([pos, rpy_of(rot)], axis=1)


def platform_of_tool(tool_poses: np.ndarray, tool=IDENTITY, work=IDENTITY) -> np.ndarray:
    """The inverse of :func:`tool_in_work`: tool poses in W (N, 6) -> the
    platform poses (o' in the base frame) that put it there."""
    tool_poses = np.asarray(tool_poses, dtype=float).reshape(-1, 6)
    tool, work = check_frame(tool, "tool"), check_frame(work, "work")
    rtw = rotation_many(tool_poses[:, 3:])
    rt = rotation_many(np.asarray(tool[3:]))
    rw = rotation_many(np.asarray(work[3:]))
    r = rw @ rtw @ rt.T
    tip = np.asarray(work[:3]) + tool_poses[:, :3] @ rw.T
    pos = tip - r @ np.asarray(tool[:3])
    return np.concatenate([pos, rpy_of(r)], axis=1)


def is_identity(tool, work) -> bool:
    return check_frame(tool, "tool") == IDENTITY and check_frame(work, "work") == IDENTITY


def attach_tool(data, tool=IDENTITY, work=IDENTITY) -> None:
    """``data.tool``: {"frames": (tool, work), "ref", "est"[, "truth"]: (N, 6)}
    for a decoded run (and its attached truth); nothing with identity frames
    (signals.csv and the figures stay as they are)."""
    if is_identity(tool, work):
        data.tool = None
        return
    out = {"frames": (check_frame(tool, "tool"), check_frame(work, "work")),
           "ref": tool_in_work(data.reference, tool, work), "est": tool_in_work(data.estimate, tool, work)}
    if data.truth is not None:
        out["truth"] = tool_in_work(data.truth["pose"], tool, work)
    data.tool = out


def tool_tracking(data, delay_ticks: int = 0) -> dict | None:
    """The tracking at the tool point while the controller runs a motion
    (state RUNNING): the distance of the tool point from its reference
    (``delay_ticks`` older), estimate and truth, mm, RMS and max; and the
    tool's orientation error (rad). None without tool frames."""
    if getattr(data, "tool", None) is None:
        return None
    from .names import STATES

    running = np.asarray(data.state) == STATES.index("RUNNING")
    ref = data.tool["ref"]
    if delay_ticks:
        ref = np.concatenate([np.full((delay_ticks, 6), np.nan), ref[:-delay_ticks]])
    out = {"frames": {"tool": list(data.tool["frames"][0]), "work": list(data.tool["frames"][1])},
           "ticks": int(running.sum())}
    for key in ("est", "truth"):
        if key not in data.tool:
            continue
        d = data.tool[key] - ref
        ok = running & np.isfinite(d).all(axis=1)
        if not ok.any():
            continue
        dist = 1000.0 * np.linalg.norm(d[ok, :3], axis=1)
        ang = np.linalg.norm(d[ok, 3:], axis=1)
        out[key] = {"position_rms_mm": float(np.sqrt(np.mean(dist ** 2))), "position_max_mm": float(dist.max()),
                    "angle_rms_rad": float(np.sqrt(np.mean(ang ** 2))), "angle_max_rad": float(ang.max()),
                    "n": int(ok.sum())}
    return out
