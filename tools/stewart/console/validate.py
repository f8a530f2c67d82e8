# SPDX-License-Identifier: Apache-2.0
"""Checks of the console API's command payloads, before anything is sent.

:func:`parse_command` turns a JSON object into a :class:`Request` or raises
:class:`BadRequest` (malformed: HTTP 400) or :class:`OutOfRange` (a pose or
a force target the platform cannot take: HTTP 422), with a message that
names the field and the allowed range. The controller checks again (its
workspace, leg strokes and force limits); these checks only make a clear
refusal come before the bus is touched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import model
from .. import protocol as pr

AXES = ("x", "y", "z", "roll", "pitch", "yaw")
#: The controller's force-control limits (refusal_reason in operator/node.py).
FORCE_LIMIT_N = 8000.0
MOMENT_LIMIT_NM = 1000.0
#: The paper's motion: the controller's frequency range, Hz
FREQ_MAX_HZ = 10.0
JOG_STEP_MAX = 0.05  # m or rad per jog step

COMMANDS = ("engage", "park", "stop", "estop", "reset", "move", "run", "jog", "force", "guide",
            "position", "tare", "feedforward")


class BadRequest(ValueError):
    """A malformed payload (HTTP 400)."""

    status = 400


class OutOfRange(ValueError):
    """A well-formed payload the platform cannot take (HTTP 422)."""

    status = 422


@dataclass
class Request:
    command: str
    pose: list[float] | None = None          # move: absolute pose (m, rad)
    axis: str | None = None                  # run, jog
    amplitude: float = 0.0
    frequency: float = 0.0
    fade: float = 0.0
    step: float = 0.0                        # jog: signed step, m or rad
    mask: int = 0                            # force, guide
    target: list[float] = field(default_factory=lambda: [0.0] * 6)
    params: tuple[float, float, float] | None = None  # mass, damping, stiffness
    on: bool = False                         # feedforward


def _number(d: dict, name: str, default: float | None = None) -> float:
    v = d.get(name, default)
    if v is None:
        raise BadRequest(f"{name}: missing (a number)")
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise BadRequest(f"{name}: expected a number, got {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise BadRequest(f"{name}: must be finite")
    return v


def _vector(d: dict, name: str, n: int = 6) -> list[float]:
    v = d.get(name)
    if not isinstance(v, list) or len(v) != n:
        raise BadRequest(f"{name}: expected a list of {n} numbers")
    return [_number({name: x}, name) for x in v]


def _axis(d: dict) -> str:
    a = d.get("axis")
    if a not in AXES:
        raise BadRequest(f"axis: one of {', '.join(AXES)}")
    return a


def check_pose(platform, pose: list[float]) -> None:
    """OutOfRange unless ``pose`` (absolute) is in the workspace about home
    and every leg within its stroke."""
    home = platform.home
    for i, name in enumerate(AXES):
        off = pose[i] - home[i]
        lo, hi = platform.workspace_min[i], platform.workspace_max[i]
        if not lo <= off <= hi:
            raise OutOfRange(f"pose {name} {off:+.4g} from home is outside the workspace [{lo:g}, {hi:g}]")
    lengths = model.inverse_kinematics(platform, np.asarray(pose)).lengths
    for i, ln in enumerate(lengths):
        if not platform.leg_length_min <= ln <= platform.leg_length_max:
            raise OutOfRange(f"leg {i + 1} would be {ln:.4f} m long, outside its stroke "
                             f"[{platform.leg_length_min:g}, {platform.leg_length_max:g}] m")


def _force_target(d: dict) -> list[float]:
    t = _vector(d, "target")
    for i, v in enumerate(t):
        lim = FORCE_LIMIT_N if i < 3 else MOMENT_LIMIT_NM
        if abs(v) > lim:
            unit = "N" if i < 3 else "N m"
            raise OutOfRange(f"target {AXES[i]} {v:g} {unit} exceeds the controller's limit {lim:g} {unit}")
    return t


def _force_params(d: dict) -> tuple[float, float, float] | None:
    p = d.get("params")
    if p is None:
        return None
    if not isinstance(p, dict):
        raise BadRequest("params: expected an object {mass, damping, stiffness}")
    v = (_number(p, "mass"), _number(p, "damping"), _number(p, "stiffness"))
    why = pr.force_params_check(*v)
    if why is not None:
        raise OutOfRange(f"params: {why}")
    return v


def _mask(d: dict) -> int:
    axes = d.get("axes")
    if not isinstance(axes, (str, int)) or isinstance(axes, bool):
        raise BadRequest("axes: axis names joined by commas (\"z\", \"x,y\") or a mask 0..63")
    try:
        mask = pr.force_mask(axes)
    except ValueError as e:
        raise BadRequest(f"axes: {e}") from None
    if mask == 0:
        raise BadRequest("axes: no axis in the mask")
    return mask


def parse_command(d: Any, platform, current_pose: list[float] | None = None) -> Request:
    """The request of a JSON payload; BadRequest / OutOfRange with the reason."""
    if not isinstance(d, dict):
        raise BadRequest("expected a JSON object {\"command\": ...}")
    name = d.get("command")
    if name not in COMMANDS:
        raise BadRequest(f"command: one of {', '.join(COMMANDS)}")
    r = Request(name)
    if name == "move":
        pose = _vector(d, "pose")
        if d.get("relative", False) is True:
            pose = [h + v for h, v in zip(platform.home, pose)]
        check_pose(platform, pose)
        r.pose = pose
    elif name == "run":
        _parse_run(d, r)
    elif name == "jog":
        _parse_jog(d, r, platform, current_pose)
    elif name in ("force", "guide"):
        r.mask = _mask(d)
        r.target = _force_target(d) if name == "force" else [0.0] * 6
        r.params = _force_params(d)
    elif name == "feedforward":
        on = d.get("on")
        if not isinstance(on, bool):
            raise BadRequest("on: expected true or false")
        r.on = on
    return r


def _parse_run(d: dict, r: Request) -> None:
    r.axis = _axis(d)
    r.amplitude = _number(d, "amplitude")
    r.frequency = _number(d, "frequency")
    r.fade = _number(d, "fade", 0.0)
    if not 0.0 < r.frequency <= FREQ_MAX_HZ:
        raise OutOfRange(f"frequency {r.frequency:g} Hz is outside (0, {FREQ_MAX_HZ:g}] Hz")
    if r.fade < 0.0 or r.fade > 60.0:
        raise OutOfRange(f"fade {r.fade:g} s is outside [0, 60] s")


def _parse_jog(d: dict, r: Request, platform, current_pose) -> None:
    r.axis = _axis(d)
    r.step = _number(d, "step")
    if not 0.0 < abs(r.step) <= JOG_STEP_MAX:
        raise OutOfRange(f"step {r.step:g} is outside 0 < |step| <= {JOG_STEP_MAX:g} (m or rad)")
    if current_pose is None:
        raise OutOfRange("no pose estimate to jog from")
    pose = list(current_pose)
    pose[AXES.index(r.axis)] += r.step
    check_pose(platform, pose)
    r.pose = pose
