# SPDX-License-Identifier: Apache-2.0
"""``stewart cueing --in TELEMETRY.csv --out POSES.csv [--plot PNG]``: vehicle
telemetry to platform poses through the classical washout filter
(stewart.cueing, docs/explanation/cueing.md).

TELEMETRY.csv: a header line naming the columns ``t,fx,fy,fz,wx,wy,wz`` (any
order, other columns ignored), then one row per sample: t in s (strictly
increasing, any rate; resampled linearly to the filter's period), the
specific force in m/s^2 (acceleration minus gravity, vehicle frame x forward,
y left, z up: 9.81 on fz at rest) and the angular rate in rad/s.
``--synthetic`` writes the built-in deterministic drive to TELEMETRY.csv
first (accelerate, brake, corners, bumps).

POSES.csv: ``t,x,y,z,roll,pitch,yaw`` (s from the first sample; absolute
pose, m and rad) every period: the format of hs_sim's ``play`` action and
of streamed targets. Prints the figures (share of the specific force
reproduced below 1 Hz, workspace and stroke use, clipped samples).

Exit status: 0 written; 1 some poses had to be clipped to the workspace;
2 bad input (the message names the file and line).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .. import resources


def _fmt(v) -> str:
    return "n/a" if v is None else f"{100 * v:.1f} %"


def run(args: argparse.Namespace) -> int:
    from .. import config as cfg
    from .. import cueing as cu

    try:
        platform = cfg.load(args.platform)
        params = cu.WashoutParams()
        if args.params:
            over = json.loads(Path(args.params).read_text())
            if not isinstance(over, dict):
                raise ValueError(f"{args.params}: expected a JSON object of parameters")
            unknown = sorted(set(over) - set(params.as_dict()))
            if unknown:
                raise ValueError(f"{args.params}: unknown parameter(s) {', '.join(unknown)}")
            over = {k: tuple(v) if isinstance(v, list) else v for k, v in over.items()}
            params = cu.with_params(**over)
        washout = cu.Washout(params, dt=args.dt, platform=platform)
        if args.synthetic:
            t, f, w = cu.synthetic_drive(args.duration, args.dt, args.severity, washout.gravity)
            cu.write_telemetry(args.inp, t, f, w)
        t, f, w = cu.read_telemetry(args.inp)
        t, f, w = cu.resample(t, f, w, args.dt)
        poses = washout.run(t, f, w)
        cu.write_poses(args.out, t, poses)
        fig = cu.figures(washout, t, f, w, poses)
        if args.plot:
            cu.plot(args.plot, t, f, poses, washout, title=f"classical washout: {Path(args.inp).name}")
    except (cfg.ConfigError, ValueError, OSError, TypeError, json.JSONDecodeError) as exc:
        print(f"stewart cueing: {exc}", file=sys.stderr)
        return 2
    sh = fig["specific_force_share"]
    print(f"{len(t)} poses ({t[-1]:.3f} s at {1 / args.dt:.0f} Hz) -> {args.out}")
    print(f"specific force reproduced below {fig['cutoff_hz']:g} Hz: x {_fmt(sh['x'])}, "
          f"y {_fmt(sh['y'])}, x and y {_fmt(fig['specific_force_share_xy'])}")
    use = fig["workspace_use"]
    print("workspace use: " + ", ".join(f"{a} {100 * use[a]:.0f} %" for a in cu.AXES)
          + f"; leg stroke {100 * fig['leg_stroke_use']:.0f} %, leg speed max "
          f"{fig['leg_velocity_max']:.3f} m/s")
    clipped = {a: n for a, n in fig["clipped"].items() if n}
    print("clipped samples: " + (", ".join(f"{a} {n}" for a, n in clipped.items()) or "none"))
    if args.figures:
        Path(args.figures).write_text(json.dumps(fig, indent=1) + "\n")
    if args.plot:
        print(f"plot -> {args.plot}")
    return 1 if clipped else 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("cueing", help="vehicle telemetry -> platform poses (classical washout)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--in", dest="inp", required=True, metavar="TELEMETRY.csv",
                   help="telemetry CSV (t,fx,fy,fz,wx,wy,wz)")
    p.add_argument("--out", required=True, metavar="POSES.csv", help="pose CSV to write")
    p.add_argument("--plot", metavar="PNG", help="vehicle vs platform specific force")
    p.add_argument("--figures", metavar="JSON", help="write the figures as JSON")
    p.add_argument("--platform", default=str(resources.default_platform()),
                   help="platform config (home, gravity, workspace)")
    p.add_argument("--params", metavar="JSON", help="washout parameters to change (docs/explanation/cueing.md)")
    p.add_argument("--dt", type=float, default=0.001, help="output period, s (default 0.001)")
    p.add_argument("--synthetic", action="store_true",
                   help="first write the built-in synthetic drive to TELEMETRY.csv")
    p.add_argument("--duration", type=float, default=60.0, help="--synthetic: length, s")
    p.add_argument("--severity", type=float, default=1.0,
                   help="--synthetic: scale of the accelerations and rates (1.5 aggressive)")
    p.set_defaults(func=run)
