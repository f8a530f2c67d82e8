# SPDX-License-Identifier: Apache-2.0
"""The files of a calibration (docs/reference/calibration.md): the
measurement CSV, the tracker's CSV, the instrument JSON, the plan CSV; and
the calibrated config."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np

from .. import asbuilt
from .kin import DEFAULT_TARGETS, Geometry
from .sim import DEFAULT_FIDUCIALS
from .solve import Data

AXES6 = ["x", "y", "z", "roll", "pitch", "yaw"]
LEN_COLS = [f"len{i}" for i in range(1, 7)]
CMD_COLS = [f"cmd_{a}" for a in AXES6]
MEAS_COLS = ["pose", "tick", "target", "x", "y", "z"] + LEN_COLS + CMD_COLS
TRACKER_COLS = ["tick", "target", "x", "y", "z"]
_TARGET = re.compile(r"^([TF])([1-9][0-9]?)$")


class MeasurementError(ValueError):
    """A measurement file that cannot be used; the message names the row and column."""


def _rows(path):
    """(line number, dict) of the CSV's data rows; '#' lines are comments."""
    try:
        text = Path(path).read_text()
    except OSError as e:
        raise MeasurementError(f"{path}: cannot read: {e.strerror}") from None
    lines = [(n + 1, ln) for n, ln in enumerate(text.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise MeasurementError(f"{path}: no header line")
    header = [c.strip() for c in next(csv.reader([lines[0][1]]))]
    return header, [(n, [c.strip() for c in rec]) for (n, _), rec in
                    zip(lines[1:], csv.reader([ln for _, ln in lines[1:]]))]


def _num(path, line, col, text, finite=True):
    if text == "":
        raise MeasurementError(f"{path}: row {line}: column {col} is missing")
    try:
        v = float(text)
    except ValueError:
        raise MeasurementError(f"{path}: row {line}: column {col}: {text[:20]!r} is not a number") from None
    if finite and not math.isfinite(v):
        raise MeasurementError(f"{path}: row {line}: column {col}: {text!r} is not finite")
    return v


def _int(path, line, col, text, lo=0):
    v = _num(path, line, col, text)
    if v != int(v) or v < lo:
        raise MeasurementError(f"{path}: row {line}: column {col}: {text!r} is not an integer >= {lo}")
    return int(v)


def read_measurements(path, n_targets: int, fiducials_base=None) -> Data:
    """The measurement CSV (``MEAS_COLS``), checked row by row: every value
    present and finite, ticks never decreasing, poses numbered 1, 2, ... in
    order, no reading repeated, one set of leg lengths per pose."""
    header, rows = _rows(path)
    missing = [c for c in MEAS_COLS if c not in header]
    if missing:
        raise MeasurementError(f"{path}: header lacks column(s) {', '.join(missing)}")
    idx = {c: header.index(c) for c in MEAS_COLS}
    poses: dict[int, dict] = {}
    fid_rows: list[tuple[int, int, list[float]]] = []
    seen: dict[tuple, int] = {}
    last_tick, last_line, last_pose = -1, 0, 0
    for line, rec in rows:
        if len(rec) < len(header):
            raise MeasurementError(f"{path}: row {line}: {len(rec)} fields, the header has {len(header)}")
        val = {c: rec[i] for c, i in idx.items()}
        tick = _int(path, line, "tick", val["tick"])
        if tick < last_tick:
            raise MeasurementError(f"{path}: row {line}: tick {tick} is before row {last_line}'s tick "
                                   f"{last_tick} (rows out of order)")
        m = _TARGET.match(val["target"])
        if not m:
            raise MeasurementError(f"{path}: row {line}: target {val['target']!r} is neither T1..T{n_targets} "
                                   "(platform) nor F1.. (base fiducial)")
        kind, k = m.group(1), int(m.group(2))
        xyz = [_num(path, line, c, val[c]) for c in ("x", "y", "z")]
        key = (kind, k, tick) if kind == "F" else (kind, k, _int(path, line, "pose", val["pose"], 1))
        if key in seen:
            raise MeasurementError(f"{path}: row {line}: repeats row {seen[key]} "
                                   f"({'tick' if kind == 'F' else 'pose'} {key[2]}, target {val['target']})")
        seen[key] = line
        last_tick, last_line = tick, line
        if kind == "F":
            if fiducials_base is None or k > len(fiducials_base):
                raise MeasurementError(f"{path}: row {line}: fiducial F{k} is not in the instrument file")
            fid_rows.append((line, k - 1, xyz))
            continue
        if k > n_targets:
            raise MeasurementError(f"{path}: row {line}: target T{k}: the instrument has {n_targets} targets")
        pose = key[2]
        if pose < last_pose:
            raise MeasurementError(f"{path}: row {line}: pose {pose} after pose {last_pose} (rows out of order)")
        if pose > last_pose + 1 and pose not in poses:
            raise MeasurementError(f"{path}: row {line}: pose {pose} follows pose {last_pose}: "
                                   f"pose(s) {last_pose + 1}..{pose - 1} are missing")
        last_pose = pose
        lens = [_num(path, line, c, val[c]) for c in LEN_COLS]
        cmd = [_num(path, line, c, val[c]) for c in CMD_COLS]
        if pose not in poses:
            poses[pose] = {"len": lens, "cmd": cmd, "line": line, "tick": tick, "t": {}}
        elif poses[pose]["len"] != lens or poses[pose]["cmd"] != cmd:
            raise MeasurementError(f"{path}: row {line}: pose {pose}'s leg lengths or commanded pose differ "
                                   f"from row {poses[pose]['line']}'s")
        poses[pose]["t"][k - 1] = (xyz, line)
    if not poses:
        raise MeasurementError(f"{path}: no target readings")
    n = len(poses)
    targets = np.full((n, n_targets, 3), np.nan)
    lines = np.zeros((n, n_targets), int)
    for i, pose in enumerate(sorted(poses)):
        for k, (xyz, line) in poses[pose]["t"].items():
            targets[i, k], lines[i, k] = xyz, line
    data = Data(np.array([poses[q]["len"] for q in sorted(poses)]), targets,
                np.array([poses[q]["cmd"] for q in sorted(poses)]), lines,
                np.array([poses[q]["tick"] for q in sorted(poses)]))
    if fid_rows:
        data.fiducials = np.array([r[2] for r in fid_rows])
        data.fiducials_base = np.asarray(fiducials_base, float)[[r[1] for r in fid_rows]]
    return data


def write_measurements(path, data: Data, tick0=1000, dt=3000):
    """Writes ``data`` as a measurement CSV (ticks: tick0 + dt per pose)."""
    with open(path, "w", newline="") as f:
        f.write("# stewart calibrate measurements: tracker frame (m), leg length readings (m), "
                "commanded pose (m, rad); docs/reference/calibration.md\n")
        w = csv.writer(f)
        w.writerow(MEAS_COLS)
        if data.fiducials is not None:
            for j, (xyz, base) in enumerate(zip(data.fiducials, data.fiducials_base)):
                w.writerow(["", tick0 - 500 + j, f"F{_fid_index(data, base)}"] + [repr(float(v)) for v in xyz]
                           + [""] * 12)
        for i in range(len(data.readings)):
            tick = int(data.ticks[i]) if data.ticks is not None else tick0 + dt * i
            for k in range(data.targets.shape[1]):
                if np.isfinite(data.targets[i, k]).all():
                    w.writerow([i + 1, tick, f"T{k + 1}"] + [repr(float(v)) for v in data.targets[i, k]]
                               + [repr(float(v)) for v in data.readings[i]]
                               + [repr(float(v)) for v in data.commanded[i]])


def _fid_index(data, base):
    order = []
    for b in data.fiducials_base:
        if not any((b == o).all() for o in order):
            order.append(b)
    return 1 + next(j for j, o in enumerate(order) if (o == base).all())


def write_tracker(path, data: Data, tick0=1000, dt=3000):
    """The tracker's own CSV: tick, target, x, y, z (tracker frame, m)."""
    with open(path, "w", newline="") as f:
        f.write("# laser tracker readings, tracker frame, m; docs/reference/calibration.md\n")
        w = csv.writer(f)
        w.writerow(TRACKER_COLS)
        for i in range(len(data.readings)):
            tick = int(data.ticks[i]) if data.ticks is not None else tick0 + dt * i
            for k in range(data.targets.shape[1]):
                w.writerow([tick, f"T{k + 1}"] + [repr(float(v)) for v in data.targets[i, k]])


def read_instrument(path=None) -> dict:
    """{"targets": (K, 3) motion frame, "fiducials": (F, 3) base frame or None, "noise": m}."""
    d = {"targets": DEFAULT_TARGETS.tolist(), "fiducials": DEFAULT_FIDUCIALS.tolist(), "noise": 10e-6}
    if path:
        try:
            d.update(json.loads(Path(path).read_text()))
        except (OSError, json.JSONDecodeError) as e:
            raise MeasurementError(f"{path}: cannot read the instrument file: {e}") from None
    t = np.asarray(d["targets"], float)
    if t.ndim != 2 or t.shape[1] != 3 or not 3 <= len(t) <= 9 or not np.isfinite(t).all():
        raise MeasurementError(f"{path}: targets: expected 3 to 9 finite [x, y, z] in the motion frame")
    f = d.get("fiducials")
    f = None if f is None else np.asarray(f, float)
    if f is not None and (f.ndim != 2 or f.shape[1] != 3 or len(f) < 3 or not np.isfinite(f).all()):
        raise MeasurementError(f"{path}: fiducials: expected at least 3 finite [x, y, z] in the base frame")
    return {"targets": t, "fiducials": f, "noise": float(d["noise"])}


def write_plan(path, poses):
    with open(path, "w", newline="") as f:
        f.write("# stewart calibrate plan: one static pose per row (m, rad, base frame)\n")
        w = csv.writer(f)
        w.writerow(["pose"] + AXES6)
        for i, q in enumerate(poses):
            w.writerow([i + 1] + [f"{v:.6f}" for v in q])


def read_plan(path) -> np.ndarray:
    header, rows = _rows(path)
    if header[:7] != ["pose"] + AXES6:
        raise MeasurementError(f"{path}: header must be pose,{','.join(AXES6)}")
    return np.array([[_num(path, line, c, rec[j + 1]) for j, c in enumerate(AXES6)] for line, rec in rows])


def move_times(platform, poses, fade=2.0):
    """Seconds each move needs: the fade, or longer where a leg travels far
    (the controller stretches a MOVE_TO to keep every leg below
    leg_velocity_max; measured on the default platform: up to about 3.5
    times the travel over leg_velocity_max)."""
    from .kin import Geometry, ik, poses_to_pr
    g = Geometry.of_platform(platform)
    lengths = ik(g, *poses_to_pr(np.vstack([platform.home, poses])))
    travel = np.max(np.abs(np.diff(lengths, axis=0)), axis=1)
    return np.maximum(fade, 4.0 * travel / platform.leg_velocity_max)


def scenario(poses, settle=2.0, fade=3.0, times=None, home=None) -> str:
    """hs_sim scenario: engage, each pose by MOVE_TO (from READY), the move's
    time (``times``, default ``fade``) and ``settle`` at rest, a mark per
    pose, STOP (back to READY, holding the pose); back to ``home`` when
    given (PARK's straight path from a pose at the workspace's corner can
    leave the limits: the controller faults), park."""
    out = ["# stewart calibrate plan: static poses, a mark at rest on each", "cmd ENGAGE", "wait ready 60"]
    for i, q in enumerate(poses):
        t = fade if times is None else float(times[i])
        out += [f"target {' '.join(f'{v:.6f}' for v in q)}", f"cmd MOVE_TO fade={fade:g}",
                f"delay {t + settle:.2f}", f"mark calibrate pose {i + 1}", "cmd STOP", "wait ready 10"]
    if home is not None:
        t = fade if times is None else float(np.max(times))
        out += [f"target {' '.join(f'{v:.6f}' for v in home)}", f"cmd MOVE_TO fade={fade:g}",
                f"delay {t + settle:.2f}", "cmd STOP", "wait ready 10"]
    out += ["cmd PARK", "wait idle 60", "end"]
    return "\n".join(out) + "\n"


def calibrated_config(raw: dict, geometry: Geometry, result_info: dict) -> dict:
    """The controller's config with the calibrated joints and sensor zeros
    (``length_sensors``) and a ``calibration`` record; no ``as_built``."""
    out = {k: v for k, v in raw.items() if k not in ("as_built",)}
    out["base_joints"] = [[round(float(v), 9) for v in row] for row in geometry.base]
    out["platform_joints"] = [[round(float(v), 9) for v in row] for row in geometry.plat]
    out["length_sensors"] = {"zero": [round(float(v), 9) for v in geometry.zero],
                             "scale": [round(float(v), 12) for v in geometry.scale]}
    out["calibration"] = result_info
    return out


def parse_length(text: str) -> float:
    """'1mm', '0.5 mm', '10um', '1e-3' (m) -> metres."""
    m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*(m|mm|um|µm)?\s*", str(text))
    if not m:
        raise ValueError(f"{text!r}: expected a length such as 1mm, 10um or 0.001")
    return float(m.group(1)) * {"m": 1.0, None: 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6}[m.group(2)]


def as_built_section(seed, joint_sigma, zero_sigma, scale_sigma=0.0) -> dict:
    return asbuilt.draw(seed, joint_sigma, zero_sigma, scale_sigma)
