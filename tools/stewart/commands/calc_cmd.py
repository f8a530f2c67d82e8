# SPDX-License-Identifier: Apache-2.0
"""``stewart calc`` and ``stewart fk``: run the fixed-point firmware core
over a CSV file.

calc: poses and motions in, leg lengths, stretch and cylinder forces out.
fk:   six leg lengths in, the pose out (forward kinematics).

A bad row gets a status in its own output row; the rest of the file is still
processed. The exit status is 0 when every row is ok, 1 when some row is not,
2 when the files or the config cannot be used at all.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys

from .. import config as cfg
from .. import resources
from ..core import Core, CoreError

CALC_INPUT = [
    "t", "x", "y", "z", "roll", "pitch", "yaw",
    "vx", "vy", "vz", "roll_rate", "pitch_rate", "yaw_rate",
    "ax", "ay", "az", "roll_acc", "pitch_acc", "yaw_acc",
    "Lx", "Ly", "Lz",
]
LEGS = range(1, 7)
CALC_OUTPUT = ([f"l{i}" for i in LEGS] + [f"stretch{i}" for i in LEGS] + [f"F{i}" for i in LEGS]
               + ["status"])
POSE = ["x", "y", "z", "roll", "pitch", "yaw"]
FK_OUTPUT = POSE + ["iterations", "status"]


def _number(row: dict, name: str) -> float:
    text = (row.get(name) or "").strip()
    if text == "":
        return 0.0
    v = float(text)
    if not math.isfinite(v):
        raise ValueError(f"{name} is not finite")
    return v


def _fmt(v: float) -> str:
    return f"{v:.9f}"


def _open_csv(path: str):
    f = sys.stdin if path == "-" else open(path, newline="")
    reader = csv.DictReader(f)
    if reader.fieldnames is None:
        raise ValueError(f"{path}: empty file (a header row is required)")
    return f, reader


def calc_rows(core: Core, rows):
    """Yields (input row, output dict) for each input row."""
    for row in rows:
        out = {}
        try:
            v = {name: _number(row, name) for name in CALC_INPUT}
        except ValueError as e:
            out["status"] = f"bad-input: {e}"
            yield row, out
            continue
        r = core.calc(
            [v["x"], v["y"], v["z"], v["roll"], v["pitch"], v["yaw"]],
            vel=[v["vx"], v["vy"], v["vz"]],
            rpy_rate=[v["roll_rate"], v["pitch_rate"], v["yaw_rate"]],
            acc=[v["ax"], v["ay"], v["az"]],
            rpy_acc=[v["roll_acc"], v["pitch_acc"], v["yaw_acc"]],
            ext_force=[v["Lx"], v["Ly"], v["Lz"]],
        )
        out["status"] = r.status
        if r.length is not None:
            for i in range(6):
                out[f"l{i + 1}"] = _fmt(r.length[i])
                out[f"stretch{i + 1}"] = _fmt(r.stretch[i])
                out[f"F{i + 1}"] = f"{r.force[i]:.4f}"
        yield row, out


def run_calc(args: argparse.Namespace) -> int:
    try:
        platform = cfg.load(args.config)
        core = Core(platform)
        f, reader = _open_csv(args.input)
    except (cfg.ConfigError, CoreError, OSError, ValueError) as e:
        print(f"stewart calc: {e}", file=sys.stderr)
        return 2
    bad = 0
    n = 0
    with f, open(args.output, "w", newline="") as out_f:
        in_cols = list(reader.fieldnames)
        cols = in_cols + [c for c in CALC_INPUT if c not in in_cols] + CALC_OUTPUT
        writer = csv.DictWriter(out_f, fieldnames=cols, extrasaction="ignore")
        writer.writeheader()
        for row, out in calc_rows(core, reader):
            n += 1
            if out["status"] not in ("ok",):
                bad += 1
            merged = {c: row.get(c, "") for c in in_cols}
            for c in CALC_INPUT:
                merged.setdefault(c, row.get(c) or "0")
            merged.update(out)
            writer.writerow(merged)
    print(f"stewart calc: {n} rows, {bad} not ok -> {args.output}")
    return 1 if bad else 0


def run_fk(args: argparse.Namespace) -> int:
    try:
        platform = cfg.load(args.config)
        core = Core(platform)
        f, reader = _open_csv(args.input)
    except (cfg.ConfigError, CoreError, OSError, ValueError) as e:
        print(f"stewart fk: {e}", file=sys.stderr)
        return 2
    bad = 0
    n = 0
    prev = None  # the previous row's pose: the warm start, as in the firmware
    with f, open(args.output, "w", newline="") as out_f:
        in_cols = list(reader.fieldnames)
        writer = csv.DictWriter(out_f, fieldnames=in_cols + [c for c in FK_OUTPUT if c not in in_cols])
        writer.writeheader()
        for row in reader:
            n += 1
            out = {c: row.get(c, "") for c in in_cols}
            try:
                lengths = [float(row[f"l{i}"]) for i in LEGS]
                if not all(math.isfinite(v) for v in lengths):
                    raise ValueError("a length is not finite")
                start = None
                if all((row.get(c) or "").strip() for c in POSE):
                    start = [float(row[c]) for c in POSE]
            except (KeyError, TypeError, ValueError) as e:
                out.update({c: "" for c in POSE}, iterations="", status=f"bad-input: {e}")
                writer.writerow(out)
                bad += 1
                continue
            guess = start if start is not None else (prev if not args.cold else None)
            kw = {}
            if args.cold or guess is None:
                kw = {"max_iterations": 20, "max_jump_pos": 100.0, "max_jump_rot": 100.0}
            status, pose, iterations = core.forward_kinematics(lengths, guess, **kw)
            out["iterations"] = iterations
            out["status"] = status
            if pose is not None:
                for c, v in zip(POSE, pose):
                    out[c] = _fmt(v)
                prev = pose
            else:
                for c in POSE:
                    out[c] = ""
                bad += 1
            writer.writerow(out)
    print(f"stewart fk: {n} rows, {bad} not ok -> {args.output}")
    return 1 if bad else 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calc", help="leg lengths, stretch and cylinder forces of poses (fixed-point core)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=str(resources.default_platform()),
                   help="platform config JSON (default: the default platform)")
    p.add_argument("--input", required=True, help="CSV with a header row; columns: " + ",".join(CALC_INPUT))
    p.add_argument("--output", required=True, help="CSV to write")
    p.set_defaults(func=run_calc)

    p = sub.add_parser("fk", help="poses from six leg lengths (fixed-point forward kinematics)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=str(resources.default_platform()),
                   help="platform config JSON (default: the default platform)")
    p.add_argument("--input", required=True,
                   help="CSV with l1..l6 (m) and optionally a starting pose x,y,z,roll,pitch,yaw")
    p.add_argument("--output", required=True, help="CSV to write")
    p.add_argument("--cold", action="store_true",
                   help="start every row from home (or its own starting pose) instead of the previous "
                        "row's result, with no continuity limit")
    p.set_defaults(func=run_fk)
