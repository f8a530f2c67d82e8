# SPDX-License-Identifier: Apache-2.0
"""The duty file of ``stewart design``: what the platform must carry and do.

A JSON object (SI units, radians; docs/guides/designing.md walks through
one). Every key is checked; an unknown key, a missing one or an impossible
range raises DutyError naming it. Trajectory CSV files are read here too
(the columns of ``stewart calc``; rates and accelerations are taken from the
file when given, else differentiated from ``t``), so a bad row is named
before any analysis runs.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

AXES = ["x", "y", "z", "roll", "pitch", "yaw"]
RATES = ["vx", "vy", "vz", "roll_rate", "pitch_rate", "yaw_rate"]
ACCS = ["ax", "ay", "az", "roll_acc", "pitch_acc", "yaw_acc"]

TOP_KEYS = {"payload", "envelope", "external_wrench", "trajectories", "workspace", "sizing",
            "requirements"}
PAYLOAD_KEYS = {"mass_min", "mass_max", "center_of_mass", "inertia"}
ENVELOPE_KEYS = {"excursion_min", "excursion_max", "velocity", "acceleration", "combined"}
COMBINED_KEYS = {"linear_velocity", "angular_velocity", "linear_acceleration", "angular_acceleration"}
WRENCH_KEYS = {"force", "moment"}
WORKSPACE_KEYS = {"position_step", "angle_step", "orientations", "positions", "envelope_points"}
SIZING_KEYS = {"load_pressure_fraction", "loop_damping"}
REQUIREMENT_KEYS = {"bandwidth_hz", "force_margin", "condition_max"}


class DutyError(ValueError):
    """A duty that cannot be used; the message names the key or the row."""


@dataclass
class Trajectory:
    name: str
    t: np.ndarray      # (n,)
    pose: np.ndarray   # (n, 6) absolute poses
    vel: np.ndarray    # (n, 6) [v; Euler-angle rates]
    acc: np.ndarray    # (n, 6)


@dataclass
class Duty:
    mass_min: float = 0.0
    mass_max: float = 0.0
    payload_com: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    payload_inertia: list = field(default_factory=lambda: [[0.0] * 3 for _ in range(3)])
    excursion_min: list = field(default_factory=lambda: [0.0] * 6)
    excursion_max: list = field(default_factory=lambda: [0.0] * 6)
    velocity: list = field(default_factory=lambda: [0.0] * 6)
    acceleration: list = field(default_factory=lambda: [0.0] * 6)
    combined: dict = field(default_factory=dict)
    force: list = field(default_factory=lambda: [0.0] * 3)
    moment: list = field(default_factory=lambda: [0.0] * 3)
    trajectories: list = field(default_factory=list)
    position_step: float = 0.04
    angle_step: float = 0.04
    orientations: list = field(default_factory=lambda: [[0.0, 0.0, 0.0]])
    positions: list = field(default_factory=lambda: [[0.0, 0.0, 0.0]])
    envelope_points: int = 5
    load_pressure_fraction: float = 2.0 / 3.0
    loop_damping: float = 0.2
    requirements: dict = field(default_factory=dict)
    source: str = "<dict>"


def _keys(where: str, d, known: set) -> dict:
    if not isinstance(d, dict):
        raise DutyError(f"{where}: expected an object")
    for k in d:
        if k not in known:
            raise DutyError(f"{where}.{k}: unknown key (known: {', '.join(sorted(known))})".lstrip("."))
    return d


def _num(where: str, v, lo=None, hi=None) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise DutyError(f"{where}: expected a finite number, got {json.dumps(v)[:40]}")
    if lo is not None and v < lo:
        raise DutyError(f"{where}: {v:g} is below {lo:g}")
    if hi is not None and v > hi:
        raise DutyError(f"{where}: {v:g} is above {hi:g}")
    return float(v)


def _vec(where: str, v, n: int, lo=None, hi=None) -> list:
    if not isinstance(v, list) or len(v) != n:
        raise DutyError(f"{where}: expected a list of {n} numbers")
    return [_num(f"{where}[{i}]", x, lo, hi) for i, x in enumerate(v)]


def _payload(duty: Duty, p: dict) -> None:
    _keys("payload", p, PAYLOAD_KEYS)
    duty.mass_min = _num("payload.mass_min", p.get("mass_min", 0.0), 0.0, 32767.0)
    duty.mass_max = _num("payload.mass_max", p.get("mass_max", duty.mass_min), 0.0, 32767.0)
    if duty.mass_min > duty.mass_max:
        raise DutyError(f"payload.mass_min: {duty.mass_min:g} is above mass_max {duty.mass_max:g}")
    duty.payload_com = _vec("payload.center_of_mass", p.get("center_of_mass", [0.0] * 3), 3, -2.0, 2.0)
    rows = p.get("inertia", [[0.0] * 3 for _ in range(3)])
    if not isinstance(rows, list) or len(rows) != 3:
        raise DutyError("payload.inertia: expected 3 rows of 3 numbers")
    inertia = np.array([_vec(f"payload.inertia[{r}]", row, 3) for r, row in enumerate(rows)])
    if not np.allclose(inertia, inertia.T) or np.linalg.eigvalsh(inertia).min() < -1e-9:
        raise DutyError("payload.inertia: must be symmetric and positive semi-definite")
    duty.payload_inertia = inertia.tolist()


def _envelope(duty: Duty, e: dict) -> None:
    _keys("envelope", e, ENVELOPE_KEYS)
    duty.excursion_min = _vec("envelope.excursion_min", e.get("excursion_min", [0.0] * 6), 6, -2.0, 2.0)
    duty.excursion_max = _vec("envelope.excursion_max", e.get("excursion_max", [0.0] * 6), 6, -2.0, 2.0)
    for k in range(6):
        if duty.excursion_min[k] > duty.excursion_max[k]:
            raise DutyError(f"envelope.excursion_min[{k}]: {duty.excursion_min[k]:g} is above "
                            f"excursion_max[{k}] {duty.excursion_max[k]:g}")
    duty.velocity = _vec("envelope.velocity", e.get("velocity", [0.0] * 6), 6, 0.0, 10.0)
    duty.acceleration = _vec("envelope.acceleration", e.get("acceleration", [0.0] * 6), 6, 0.0, 100.0)
    comb = _keys("envelope.combined", e.get("combined", {}), COMBINED_KEYS)
    duty.combined = {k: _num(f"envelope.combined.{k}", v, 0.0, 100.0) for k, v in comb.items()}


def _workspace(duty: Duty, w: dict) -> None:
    _keys("workspace", w, WORKSPACE_KEYS)
    duty.position_step = _num("workspace.position_step", w.get("position_step", 0.04), 1e-3, 0.5)
    duty.angle_step = _num("workspace.angle_step", w.get("angle_step", 0.04), 1e-3, 0.5)
    for key in ("orientations", "positions"):
        v = w.get(key, [[0.0, 0.0, 0.0]])
        if not isinstance(v, list) or not v or len(v) > 8:
            raise DutyError(f"workspace.{key}: expected a list of 1 to 8 triples")
        setattr(duty, key, [_vec(f"workspace.{key}[{i}]", t, 3, -2.0, 2.0) for i, t in enumerate(v)])
    n = w.get("envelope_points", 5)
    if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= 9:
        raise DutyError("workspace.envelope_points: expected an integer 2..9")
    duty.envelope_points = n


def from_dict(d, source: str = "<dict>", base: Path | None = None) -> Duty:
    """Validates a parsed duty; raises DutyError naming the key."""
    try:
        _keys("", d, TOP_KEYS)
        duty = Duty(source=source)
        _payload(duty, d.get("payload", {}))
        _envelope(duty, d.get("envelope", {}))
        wr = _keys("external_wrench", d.get("external_wrench", {}), WRENCH_KEYS)
        duty.force = _vec("external_wrench.force", wr.get("force", [0.0] * 3), 3, -1e7, 1e7)
        duty.moment = _vec("external_wrench.moment", wr.get("moment", [0.0] * 3), 3, -1e7, 1e7)
        _workspace(duty, d.get("workspace", {}))
        s = _keys("sizing", d.get("sizing", {}), SIZING_KEYS)
        duty.load_pressure_fraction = _num("sizing.load_pressure_fraction",
                                           s.get("load_pressure_fraction", 2.0 / 3.0), 0.05, 1.0)
        duty.loop_damping = _num("sizing.loop_damping", s.get("loop_damping", 0.2), 0.01, 1.0)
        r = _keys("requirements", d.get("requirements", {}), REQUIREMENT_KEYS)
        duty.requirements = {k: _num(f"requirements.{k}", v, 0.0, 1e6) for k, v in r.items()}
        tr = d.get("trajectories", [])
        if not isinstance(tr, list) or not all(isinstance(x, str) for x in tr):
            raise DutyError("trajectories: expected a list of CSV file names")
        duty.trajectories = [read_trajectory((base or Path(".")) / x) for x in tr]
        return duty
    except DutyError as e:
        raise DutyError(f"{source}: {e}") from None


def load(path) -> Duty:
    path = Path(path)
    try:
        d = json.loads(path.read_text())
    except OSError as e:
        raise DutyError(f"{path}: cannot read: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise DutyError(f"{path}: not valid JSON: {e.msg} at line {e.lineno}") from None
    return from_dict(d, str(path), path.parent)


def _column(rows: list, name: str, path: Path) -> np.ndarray | None:
    if name not in rows[0]:
        return None
    out = np.empty(len(rows))
    for i, r in enumerate(rows):
        try:
            out[i] = float(r[name])
        except (TypeError, ValueError):
            out[i] = math.nan
        if not math.isfinite(out[i]):
            raise DutyError(f"trajectory {path}: row {i + 2}: {name} is not a finite number")
    return out


def read_trajectory(path: Path) -> Trajectory:
    """A CSV with t and the pose columns (absolute poses), optionally the
    rates and accelerations of ``stewart calc``'s input."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        raise DutyError(f"trajectory {path}: cannot read: {e.strerror}") from None
    if len(rows) < 3:
        raise DutyError(f"trajectory {path}: needs a header and at least 3 rows")
    cols = {}
    for name in ["t"] + AXES:
        c = _column(rows, name, path)
        if c is None:
            raise DutyError(f"trajectory {path}: column {name} missing")
        cols[name] = c
    t = cols["t"]
    if np.any(np.diff(t) <= 0.0):
        bad = int(np.argmax(np.diff(t) <= 0.0)) + 3
        raise DutyError(f"trajectory {path}: row {bad}: t does not increase")
    pose = np.stack([cols[a] for a in AXES], axis=1)
    vel = _derived(rows, RATES, path, pose, t)
    acc = _derived(rows, ACCS, path, vel, t)
    return Trajectory(str(path), t, pose, vel, acc)


def _derived(rows, names, path, of: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The given columns, or the time derivative of ``of``."""
    got = [_column(rows, n, path) for n in names]
    if all(g is not None for g in got):
        return np.stack(got, axis=1)
    return np.gradient(of, t, axis=0)
