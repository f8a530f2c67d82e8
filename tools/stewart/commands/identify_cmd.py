# SPDX-License-Identifier: Apache-2.0
"""``stewart identify``: the payload (mass, centre of mass, inertia) and the
cylinders' friction from a logged run, or the excitation run that makes
them observable (docs/explanation/identification.md).

    stewart identify --log LOG --config CFG --out NEW.json
        Reads the CAN log (candump -L, as ``stewart analyze``), uses the
        RUNNING ticks in which a leg moves faster than --min-leg-rate, fits
        the 22 parameters by least squares, prints each with its standard
        error and the condition number of the scaled regressor, and writes
        CFG with the identified values to NEW.json. The legs' moments of
        inertia are held at CFG's, or with --leg-inertia identified too
        (their sum, shared between barrel and rod as in CFG). Refuses (exit 1), naming
        the parameter and the reason, when the excitation leaves a parameter
        unobservable.

    stewart identify --scenario OUT.txt [--config CFG]
        Writes an excitation for hs_sim: the scenario OUT.txt (engage,
        STREAM, play the CSV, stop, park) and the CSV of target poses
        (t,x,y,z,roll,pitch,yaw; default OUT.csv), a multi-axis multi-sine
        checked against the config's limits and for observability.

Exit status: 0 done; 1 identification refused (no RUNNING ticks, too little
or unsuitable excitation, a physically impossible estimate) or an
excitation that cannot be planned; 2 usage error, unreadable log or bad
config.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .. import progress, resources

PROG = "stewart identify"


def _err(text: str, code: int) -> int:
    print(f"{PROG}: {text}", file=sys.stderr)
    return code


def _load_config(path):
    """(Platform, raw dict) or raises ConfigError."""
    from .. import config as cfg

    p = cfg.load(path)
    return p, json.loads(Path(path).read_text())


def _identify(args) -> int:
    from .. import config as cfg
    from .. import identify as idf
    from ..analysis.logfile import parse_bus_map

    if not args.out:
        return _err("--log needs --out NEW.json", 2)
    if not Path(args.log).is_file():
        return _err(f"no such file: {args.log}", 2)
    try:
        parse_bus_map(args.bus)
        platform, raw = _load_config(args.config)
    except (cfg.ConfigError, ValueError) as exc:
        return _err(str(exc), 2)
    if args.half_window < args.order or args.order < 2:
        return _err("--half-window must be >= --order >= 2", 2)
    if not args.quiet:
        print(f"{PROG}: decoding {args.log} and fitting the parameters", file=sys.stderr, flush=True)
    try:
        res = idf.identify_log(args.log, platform, buses=args.bus, min_rate=args.min_leg_rate,
                               half=args.half_window, order=args.order, leg_inertia=args.leg_inertia)
    except idf.IdentifyError as exc:
        return _err(f"{args.log}: refused: {exc}", 1)
    except OSError as exc:
        return _err(f"{args.log}: {exc}", 2)
    print(idf.format_result(res))
    new = idf.updated_config(raw, res)
    try:
        cfg.from_dict(new, args.out)
    except cfg.ConfigError as exc:
        return _err(f"refused: the identified config is not valid: {exc}", 1)
    try:
        Path(args.out).write_text(json.dumps(new, indent=2) + "\n")
    except OSError as exc:
        return _err(f"{args.out}: cannot write: {exc.strerror}", 2)
    print(f"wrote {args.out}")
    return 0


def _scenario(args) -> int:
    from .. import config as cfg
    from .. import identify as idf

    try:
        platform, _raw = _load_config(args.config)
    except cfg.ConfigError as exc:
        return _err(str(exc), 2)
    csv_path = Path(args.csv) if args.csv else Path(args.scenario).with_suffix(".csv")
    try:
        plan = idf.plan_excitation(platform, duration=args.duration, f_min=args.band[0], f_max=args.band[1],
                                   seed=args.seed)
    except idf.IdentifyError as exc:
        return _err(f"refused: {exc}", 1)
    try:
        idf.write_excitation(plan, args.scenario, csv_path, str(csv_path), csv_dt=args.csv_dt)
    except OSError as exc:
        return _err(f"cannot write: {exc}", 2)
    r = plan.report
    print(f"excitation: {plan.t[-1]:.1f} s, legs {r['leg_length_min']:.3f}..{r['leg_length_max']:.3f} m, "
          f"|leg rate| <= {r['leg_rate_max']:.3f} m/s, |force| <= {r['force_max'] / 1e3:.1f} kN, "
          f"condition number {r['condition']:.3g}")
    print("amplitudes (m, rad): " + ", ".join(f"{a:.4f}" for a in r["amplitude"]))
    print(f"wrote {args.scenario}, {csv_path}")
    return 0


def run(args: argparse.Namespace) -> int:
    if bool(args.log) == bool(args.scenario):
        return _err("give either --log LOG (identify) or --scenario OUT.txt (excitation)", 2)
    return _identify(args) if args.log else _scenario(args)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("identify", help="payload and friction from a logged run; or an excitation scenario",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--log", help="CAN log of a closed-loop run (candump -L)")
    progress.add_quiet(p)
    p.add_argument("--out", help="the identified config to write (JSON)")
    p.add_argument("--scenario", metavar="OUT.txt", help="write an excitation scenario (and its CSV)")
    p.add_argument("--config", default=str(resources.default_platform()),
                   help="platform config JSON (default: config/platform_default.json)")
    p.add_argument("--bus", help="interfaces of the buses, as for stewart analyze")
    p.add_argument("--min-leg-rate", type=float, default=None,
                   help="use a cylinder's force only when |leg rate| exceeds this, m/s (default: "
                   "max(0.01, 3 stribeck_velocity, 2 coulomb_velocity))")
    p.add_argument("--half-window", type=int, default=50,
                   help="Savitzky-Golay half window for the pose derivatives, ticks (default 50)")
    p.add_argument("--order", type=int, default=4, help="Savitzky-Golay polynomial order (default 4)")
    p.add_argument("--leg-inertia", action="store_true",
                   help="identify the legs' moments of inertia across the leg (their sum I_c + I_r, "
                        "a 23rd parameter; default: hold the config's cylinder_inertia and rod_inertia)")
    p.add_argument("--csv", help="with --scenario: the CSV to write and play (default OUT with .csv)")
    p.add_argument("--duration", type=float, default=60.0, help="with --scenario: length, s (default 60)")
    p.add_argument("--band", type=float, nargs=2, default=(0.1, 0.8), metavar=("FMIN", "FMAX"),
                   help="with --scenario: frequency band, Hz (default 0.1 0.8)")
    p.add_argument("--seed", type=int, default=1, help="with --scenario: phases' random seed")
    p.add_argument("--csv-dt", type=float, default=0.01,
                   help="with --scenario: CSV row spacing, s (play interpolates linearly; default 0.01)")
    p.set_defaults(func=run)
