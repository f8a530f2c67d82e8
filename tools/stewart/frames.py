# SPDX-License-Identifier: Apache-2.0
"""The tool frame T and the work frame W in float64: the reference the
fixed-point core's transforms (firmware/core/src/model/frames.c) are
checked against (tests/python/test_frames.py).

T is fixed to the platform: its origin (the tool point, the pivot) at
``tool[:3]`` in motion-frame coordinates, its axes turned by ``tool[3:]``
(roll, pitch, yaw, the paper's convention: R = Rz Ry Rx). W is fixed to
the ground: origin ``work[:3]`` in base coordinates, axes turned by
``work[3:]``. A tool pose is T in W; a platform pose is o' in the base
frame (docs/reference/frames.md)::

    R_P = R_W R_X R_T^T        p = w + R_W x - R_P t
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from .config import ANGLE_MAX, SLOTS, TOOL_REACH_MAX, WORK_REACH_MAX, check_frame  # noqa: F401
from .model import body_rates, rotation

IDENTITY = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def angles(r: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw of a column rotation R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return np.array([
        math.atan2(r[2, 1], r[2, 2]),
        math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0])),
        math.atan2(r[1, 0], r[0, 0]),
    ])


@dataclass
class Frames:
    tool: tuple = IDENTITY
    work: tuple = IDENTITY
    rt: np.ndarray = field(init=False, repr=False)
    rw: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self.tool = tuple(float(x) for x in self.tool)
        self.work = tuple(float(x) for x in self.work)
        self.rt = rotation(self.tool[3:])
        self.rw = rotation(self.work[3:])

    @property
    def t(self) -> np.ndarray:
        return np.asarray(self.tool[:3])

    @property
    def w(self) -> np.ndarray:
        return np.asarray(self.work[:3])

    # ---- poses ----
    def to_platform(self, x6) -> np.ndarray:
        """Platform pose (o' in base) that puts T at x6 (T in W)."""
        x6 = np.asarray(x6, dtype=float)
        rp = self.rw @ rotation(x6[3:]) @ self.rt.T
        p = self.w + self.rw @ x6[:3] - rp @ self.t
        return np.concatenate([p, angles(rp)])

    def from_platform(self, p6) -> np.ndarray:
        """Tool pose (T in W) of a platform pose."""
        p6 = np.asarray(p6, dtype=float)
        rp = rotation(p6[3:])
        rx = self.rw.T @ rp @ self.rt
        x = self.rw.T @ (p6[:3] + rp @ self.t - self.w)
        return np.concatenate([x, angles(rx)])

    # ---- motions ----
    def motion_to_platform(self, x6, vel, rpy_rate, acc, rpy_acc):
        """(pose6, vel, rpy_rate, acc, rpy_acc) of the platform for a tool motion."""
        x6 = np.asarray(x6, dtype=float)
        p6 = self.to_platform(x6)
        wx, dwx = body_rates(x6[3:], rpy_rate, rpy_acc)
        w = self.rt @ wx  # body rates in the motion frame
        dw = self.rt @ dwx
        rp = rotation(p6[3:])
        wt = np.cross(w, self.t)
        v = self.rw @ np.asarray(vel, float) - rp @ wt
        a = self.rw @ np.asarray(acc, float) - rp @ (np.cross(dw, self.t) + np.cross(w, wt))
        rate, racc = euler_rates(p6[3:], w, dw)
        return p6, v, rate, a, racc

    # ---- wrenches ----
    def wrench_to_tool(self, platform_rpy, w6) -> np.ndarray:
        """Wrench about o' in base axes -> at the tool point in W's axes."""
        w6 = np.asarray(w6, dtype=float)
        r = rotation(platform_rpy) @ self.t
        f, m = w6[:3], w6[3:] - np.cross(r, w6[:3])
        return np.concatenate([self.rw.T @ f, self.rw.T @ m])

    def wrench_from_tool(self, platform_rpy, w6) -> np.ndarray:
        w6 = np.asarray(w6, dtype=float)
        r = rotation(platform_rpy) @ self.t
        f = self.rw @ w6[:3]
        m = self.rw @ w6[3:] + np.cross(r, f)
        return np.concatenate([f, m])

    def values_q24(self) -> list[int]:
        return [int(round(v * (1 << 24))) for v in (*self.tool, *self.work)]

    def checksum(self) -> int:
        """CRC-32 of the twelve Q24 values (sp_frames_checksum)."""
        return zlib.crc32(struct.pack("<12i", *self.values_q24())) & 0xFFFFFFFF

    @property
    def identity(self) -> bool:
        return not any(self.tool) and not any(self.work)


def euler_rates(rpy, w, dw):
    """Euler rates and accelerations from body rates w and their derivative dw."""
    phi, theta, _ = rpy
    sf, cf, st, ct = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
    e = np.array([[1.0, 0.0, -st], [0.0, cf, sf * ct], [0.0, -sf, cf * ct]])
    rate = np.linalg.solve(e, w)
    dphi, dtheta, dpsi = rate
    e_dot_rate = np.array([
        -dpsi * dtheta * ct,
        -dtheta * dphi * sf + dpsi * (dphi * cf * ct - dtheta * sf * st),
        -dtheta * dphi * cf - dpsi * (dphi * sf * ct + dtheta * cf * st),
    ])
    return rate, np.linalg.solve(e, np.asarray(dw) - e_dot_rate)
