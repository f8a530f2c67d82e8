# SPDX-License-Identifier: Apache-2.0
"""``stewart calibrate``: the machine as built, found from external
measurements (docs/guides/commissioning.md, docs/reference/calibration.md).

    stewart calibrate as-built --seed N --joint-sigma 1mm --zero-sigma 0.5mm -o MACHINE.json
        CFG with an ``as_built`` section drawn from the seed and spreads:
        the plant's machine; the controller never reads the section.
    stewart calibrate plan [-n 60] [--seed S] -o PLAN.csv [--scenario OUT.txt]
        D-optimal static poses over the workspace: a list (for ``stewart op``)
        and an hs_sim scenario. ``--check POSES.csv`` checks a list instead.
    stewart calibrate run --plan PLAN.csv --machine MACHINE.json -o MEAS.csv
        Drives the poses on the float64 machine (the controller's config on
        the as-built geometry, drives at rest) and records the leg length
        readings with the tracker's readings (and --tracker-csv).
    stewart calibrate solve MEAS.csv -o CALIBRATED.json
        Least squares: joints, sensor zeros (--fit-scale: and scales), the
        tracker's pose; identifiability, standard deviations, outliers.
        Writes nothing unless the fit passes its checks.
    stewart calibrate plan --validation -n 50 --seed 1001 -o CHECKPLAN.csv
        Random fresh poses for a check run (``run`` measures them as above).
    stewart calibrate check --calibrated CALIBRATED.json --measurements CHECK.csv
                            [--machine MACHINE.json] [--plot OUT.png] [--accept OUT.json]
        Absolute pose error before and after on the check run's poses, from
        the measurements alone (the pose each config would hold at the
        measured readings against the tracker's); in simulation also
        against the plant's truth (--machine). --accept writes the config
        marked accepted, the only kind the firmware builds from.

Exit status: 0 done; 1 calibration refused (bad fit, outliers, not
identifiable, check failed); 2 usage error, bad file.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from .. import resources

PROG = "stewart calibrate"
# check's pass limits (the figures)
CHECK_RMS, CHECK_MAX, CHECK_ROT = 20e-6, 50e-6, 20e-6


def _err(text, code):
    print(f"{PROG}: {text}", file=sys.stderr)
    return code


def _load(path):
    from .. import config as cfg
    from ..calibrate.kin import Geometry
    p = cfg.load(path)
    raw = json.loads(Path(path).read_text())
    return p, raw, Geometry.of_platform(p)


def _as_built(args):
    from .. import asbuilt
    from ..calibrate.io import parse_length
    _, raw, _ = _load(args.config)
    raw["as_built"] = asbuilt.draw(args.seed, parse_length(args.joint_sigma), parse_length(args.zero_sigma),
                                   float(args.scale_sigma))
    asbuilt.parse(raw)
    Path(args.out).write_text(json.dumps(raw, indent=2) + "\n")
    print(f"{args.out}: as_built seed {args.seed}, joints {args.joint_sigma}, zeros {args.zero_sigma}")
    return 0


def _plan(args):
    from ..calibrate import io, plan
    from ..calibrate.kin import default_tracker
    p, _, _ = _load(args.config)
    if args.check:
        poses = io.read_plan(args.check)
        ok, msgs = plan.reachable(p, poses)
        for i in np.flatnonzero(~ok):
            print(f"{args.check}: pose {i + 1}: {msgs[i]}: the machine cannot reach it", file=sys.stderr)
        if not ok.all():
            return 1
        print(f"{args.check}: {len(poses)} poses, every one reachable")
        return 0
    if args.validation:
        poses = plan.candidates(p, args.poses, np.random.default_rng(args.seed), scale=0.9)
        io.write_plan(args.out, poses)
        if args.scenario:
            Path(args.scenario).write_text(io.scenario(poses, times=io.move_times(p, poses), home=p.home))
        print(f"{args.out}: {len(poses)} random validation poses (seed {args.seed}, 90 % of the workspace)")
        return 0
    inst = io.read_instrument(args.instrument)
    trk = default_tracker(0, inst["noise"], inst["targets"])
    poses, logdet = plan.make_plan(p, trk, args.poses, args.candidates, args.seed, args.fit_scale)
    io.write_plan(args.out, poses)
    if args.scenario:
        Path(args.scenario).write_text(io.scenario(poses, times=io.move_times(p, poses), home=p.home))
    print(f"{args.out}: {len(poses)} D-optimal poses of {args.candidates} candidates, log det {logdet:.1f}")
    return 0


def _run(args):
    from .. import asbuilt
    from ..calibrate import io, plan, sim
    from ..calibrate.kin import Geometry, default_tracker
    p, _, ctrl = _load(args.config)
    raw_m = json.loads(Path(args.machine).read_text())
    truth = Geometry.of_platform(p).as_built(asbuilt.parse(raw_m))
    poses = io.read_plan(args.plan)
    ok, msgs = plan.reachable(p, poses)
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        return _err(f"{args.plan}: pose {i + 1}: {msgs[i]}: the plan cannot be driven", 1)
    inst = io.read_instrument(args.instrument)
    seed = raw_m.get("as_built", {}).get("seed", 1) if args.tracker_seed is None else args.tracker_seed
    trk = default_tracker(int(seed), inst["noise"], inst["targets"])
    rng = np.random.default_rng(args.noise_seed)
    if args.build:
        from ..calibrate import loop
        work = Path(args.out).parent / (Path(args.out).stem + "_run")
        try:
            data = loop.measure(p, poses, args.build, work, trk, rng, inst["fiducials"],
                                plant_args=_plant_args(args, raw_m, work), inproc=args.inproc)
        except (RuntimeError, FileNotFoundError) as e:
            return _err(str(e), 1)
        plant = "the machine given to hs_sim --as-built" if args.as_built_plant else "its hs_sim is the machine"
        where = f"in closed loop ({args.build}: {plant}{', in one process' if args.inproc else ', over vcan'})"
    else:
        data = sim.measure(ctrl, truth, trk, poses, rng, inst["fiducials"])
        where = f"on the float64 machine ({args.machine})"
    io.write_measurements(args.out, data)
    if args.tracker_csv:
        io.write_tracker(args.tracker_csv, data)
    print(f"{args.out}: {len(poses)} poses measured {where}")
    return 0


def _plant_args(args, raw_m, work) -> tuple[str, ...]:
    """hs_sim's options for the as-built machine: ``--as-built FILE`` from
    the machine's section (--as-built-plant), else none (the build's hs_sim
    was made with -DHS_CONFIG=MACHINE.json)."""
    if not getattr(args, "as_built_plant", False):
        return ()
    from .. import asbuilt
    Path(work).mkdir(parents=True, exist_ok=True)
    f = Path(work).resolve() / "as_built.txt"
    f.write_text(asbuilt.plant_file(asbuilt.parse(raw_m)))
    return ("--as-built", str(f))


def _report(res, names_units=True):
    lines = [f"solved in {res.seconds:.2f} s CPU, {res.iterations} iterations; residual RMS "
             f"{res.rms * 1e6:.2f} um per coordinate (noise used {res.sigma * 1e6:.2f} um)",
             f"singular values (scaled): largest {res.singular[0]:.3g}, smallest {res.singular[-1]:.3g}, "
             f"condition {res.singular[0] / res.singular[-1]:.3g}"]
    for f in res.fixed:
        lines.append(f"not identifiable, held at nominal: {f}")
    for o in res.outliers:
        lines.append(o)
    lines.append(f"{'parameter':<24}{'change':>12}{'std':>10}")
    for n, v, s in zip(res.names, res.value, res.std):
        unit = 1e6 if "scale" not in n else 1e6
        lines.append(f"{n:<24}{v * unit:>10.1f}{' ppm' if 'scale' in n else (' ur' if 'rot' in n else ' um')}"
                     f"{s * unit:>8.1f}")
    return "\n".join(lines)


def _solve(args):
    from ..calibrate import io, solve
    p, raw, nominal = _load(args.config)
    inst = io.read_instrument(args.instrument)
    try:
        data = io.read_measurements(args.measurements, len(inst["targets"]), inst["fiducials"])
        res = solve.solve(nominal, inst["targets"], data, args.fit_scale, noise=inst["noise"])
    except (io.MeasurementError, solve.CalibrationError) as e:
        return _err(str(e), 1)
    print(_report(res))
    if len(res.fixed) > (0 if data.fiducials is not None else 1):
        return _err("the plan leaves the combinations above unidentifiable: nothing written "
                    "(plan more poses, larger rotations)", 1)
    if res.rms > 3.0 * inst["noise"]:
        return _err(f"residual RMS {res.rms * 1e6:.1f} um is beyond 3x the instrument's noise: nothing written", 1)
    worst = int(np.argmax(res.std[:36]))
    if res.std[worst] > 1e-4:
        return _err(f"{res.names[worst]}: standard deviation {res.std[worst] * 1e6:.0f} um is beyond 100 um: "
                    "nothing written", 1)
    from .. import config as cfg
    info = {"measurements": str(args.measurements), "measurements_sha256": _sha256(args.measurements),
            "poses": int(len(data.readings)), "residual_rms": res.rms, "tracker_pos": res.tracker.pos.tolist(),
            "tracker_rot": res.tracker.rot.tolist(), "status": cfg.CALIBRATION_SOLVED}
    Path(args.out).write_text(json.dumps(io.calibrated_config(raw, res.geometry, info), indent=2) + "\n")
    print(f"{args.out}: written, calibration.status \"{cfg.CALIBRATION_SOLVED}\": the firmware will not "
          f"build from it until `{PROG} check --measurements CHECK.csv --accept` passes")
    return 0


def _sha256(path) -> str:
    import hashlib
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _table(title, rows):
    print(title)
    print(f"{'':<26}{'pos RMS':>12}{'pos max':>12}{'rot RMS':>12}{'rot max':>12}")
    for label, f in rows:
        print(f"{label:<26}{f['pos_rms'] * 1e6:>9.1f} um{f['pos_max'] * 1e6:>9.1f} um"
              f"{f['rot_rms'] * 1e6:>8.1f} urad{f['rot_max'] * 1e6:>7.1f} urad")


def _passes(f) -> bool:
    return f["pos_rms"] <= CHECK_RMS and f["pos_max"] <= CHECK_MAX and f["rot_rms"] <= CHECK_ROT


def _plot(path, curves):
    """Position error per validation pose, one curve per (label, errors)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for label, ep in curves:
        ax.semilogy(np.arange(1, len(ep) + 1), ep * 1e6, "o-", ms=3, label=label)
    ax.axhline(CHECK_MAX * 1e6, color="k", lw=0.8, ls="--", label="50 um")
    ax.set_xlabel("validation pose")
    ax.set_ylabel("position error, um")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f"{path}: written")


def _check(args):
    """The calibrated config's accuracy on fresh poses: from a check run's
    measurements (``--measurements``: what a real machine has), and in
    simulation against the plant's truth (``--machine``); --accept writes
    the accepted config only if every figure given passes."""
    from .. import asbuilt
    from .. import config as cfg
    from ..calibrate import check, io, plan, sim
    if not args.measurements and not args.machine:
        return _err("check needs --measurements CHECK.csv (a check run's measurements) or, in simulation, "
                    "--machine MACHINE.json (the plant's truth)", 2)
    p, _, nominal = _load(args.config)
    _, raw_c, cal = _load(args.calibrated)
    record = raw_c.get("calibration") if isinstance(raw_c.get("calibration"), dict) else None
    if record is None:
        return _err(f"{args.calibrated}: calibration: no record (not a config `{PROG} solve` wrote)", 2)
    curves, ok, figures = [], True, {}
    val = None
    if args.measurements:
        inst = io.read_instrument(args.instrument)
        if record.get("measurements_sha256") == _sha256(args.measurements):
            return _err(f"{args.measurements}: the very measurements solve used: check on fresh poses", 1)
        try:
            data = io.read_measurements(args.measurements, len(inst["targets"]), inst["fiducials"])
            meas = check.measured_poses(data, inst["targets"], inst["noise"], record)
            rows = []
            for label, g in (("before (nominal config)", nominal), ("after (calibrated)", cal)):
                ep, er = check.config_errors(g, data, meas)
                rows.append((label, check.summary(ep, er)))
                curves.append((label + ", measured", ep))
        except (io.MeasurementError, check.CheckError, RuntimeError) as e:
            return _err(str(e), 1)
        _table(f"absolute pose error over {len(data.readings)} measured check poses ({args.measurements}; "
               f"tracker pose {meas.tracker}):", rows)
        print(f"the instrument's own share (the pose fit from {data.targets.shape[1]} targets): "
              f"{np.sqrt(np.mean(meas.pos_floor ** 2)) * 1e6:.1f} um RMS position, "
              f"{np.sqrt(np.mean(meas.rot_floor ** 2)) * 1e6:.1f} urad RMS orientation; "
              f"target fit residual {np.sqrt(np.mean(meas.fit_rms ** 2)) * 1e6:.1f} um RMS")
        figures["measured"] = {"poses": int(len(data.readings)), "file": str(args.measurements),
                               "sha256": _sha256(args.measurements), **rows[1][1]}
        ok = _passes(rows[1][1]) and ok
        val = data.commanded
    if args.machine:
        raw_m = json.loads(Path(args.machine).read_text())
        truth = nominal.as_built(asbuilt.parse(raw_m))
        if val is None:
            val = plan.candidates(p, args.poses, np.random.default_rng(args.seed), scale=0.9)
        rows = []
        for label, g in (("before (nominal config)", nominal), ("after (calibrated)", cal)):
            ep, er = sim.pose_errors(g, truth, nominal, val)
            rows.append((label, check.summary(ep, er)))
            curves.append((label + ", truth", ep))
        _table(f"simulation: against the plant's truth over {len(val)} validation poses ({args.machine}):", rows)
        figures["truth"] = {"poses": int(len(val)), **rows[1][1]}
        ok = _passes(rows[1][1]) and ok
    if args.plot:
        _plot(args.plot, curves)
    if args.closed_loop:
        if val is None:
            val = plan.candidates(p, args.poses, np.random.default_rng(args.seed), scale=0.9)
        ok = _check_loop(p, val[:args.loop_poses], args) and ok
    if not ok:
        return _err(f"check failed (limits: {CHECK_RMS * 1e6:.0f} um RMS, {CHECK_MAX * 1e6:.0f} um max, "
                    f"{CHECK_ROT * 1e6:.0f} urad RMS): the calibrated config is not accepted; nothing written", 1)
    if args.accept:
        record.update({"status": cfg.CALIBRATION_ACCEPTED, "check": figures})
        record["digest"] = cfg.calibration_digest(raw_c)
        Path(args.accept).write_text(json.dumps(raw_c, indent=2) + "\n")
        print(f"{args.accept}: written (calibration.status accepted: the firmware builds from it)")
    return 0


def _check_loop(p, val, args) -> bool:
    from ..calibrate import loop
    out = Path(args.plot or "calibrate_check").with_suffix("")
    res = {}
    for label, build in zip(("nominal on nominal", "before (nominal config)", "after (calibrated)"),
                            args.closed_loop):
        work = Path(str(out) + "_loop")
        plant = () if label.startswith("nominal on") or not args.machine else \
            _plant_args(args, json.loads(Path(args.machine).read_text()), work)
        res[label] = loop.validate(p, val, build, work, label.split()[0], plant_args=plant, inproc=args.inproc)
    print(f"closed loop over {len(val)} moves (absolute error at rest; surge 90 mm 0.5 Hz, truth - reference):")
    print(f"{'':<26}{'pos RMS':>12}{'pos max':>12}{'rot RMS':>12}{'surge RMS':>12}{'surge max':>12}")
    for label, r in res.items():
        print(f"{label:<26}{np.sqrt(np.mean(r['pos'] ** 2)) * 1e6:>9.1f} um{r['pos'].max() * 1e6:>9.1f} um"
              f"{np.sqrt(np.mean(r['rot'] ** 2)) * 1e6:>7.1f} urad{r['surge_rms'] * 1e3:>9.3f} mm"
              f"{r['surge_max'] * 1e3:>9.3f} mm")
    after, ref = res["after (calibrated)"], res["nominal on nominal"]
    ok = after["pos"].max() <= CHECK_MAX and after["surge_rms"] <= 1.1 * ref["surge_rms"]
    if not ok:
        print(f"{PROG}: closed loop: the calibrated config does not reach nominal-on-nominal", file=sys.stderr)
    return ok


def run(args) -> int:
    from .. import asbuilt
    try:
        return {"as-built": _as_built, "plan": _plan, "run": _run, "solve": _solve, "check": _check}[args.what](args)
    except (ValueError, OSError, asbuilt.AsBuiltError) as e:
        return _err(str(e), 2)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="geometric calibration: as-built machine, plan, run, solve, check",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    w = p.add_subparsers(dest="what", required=True)
    cfg = str(resources.default_platform())

    def common(q):
        q.add_argument("--config", default=cfg, help="the controller's platform config (default: the built-in)")
        q.add_argument("--instrument", help="instrument JSON: targets, fiducials, noise (default: built-in)")
        return q
    a = common(w.add_parser("as-built", help="write a config with a drawn as_built section"))
    a.add_argument("--seed", type=int, required=True)
    a.add_argument("--joint-sigma", default="1mm")
    a.add_argument("--zero-sigma", default="0.5mm")
    a.add_argument("--scale-sigma", default="0", help="sensor scale spread, dimensionless (default 0)")
    a.add_argument("-o", "--out", required=True)
    b = common(w.add_parser("plan", help="D-optimal calibration poses"))
    b.add_argument("-n", "--poses", type=int, default=60)
    b.add_argument("--candidates", type=int, default=400)
    b.add_argument("--seed", type=int, default=1)
    b.add_argument("--fit-scale", action="store_true")
    b.add_argument("--scenario", help="also write an hs_sim scenario")
    b.add_argument("--validation", action="store_true",
                   help="random poses over 90 %% of the workspace for a check run instead (use another --seed)")
    b.add_argument("--check", metavar="POSES.csv", help="check a list of poses for reachability instead")
    b.add_argument("-o", "--out", default="calibration_plan.csv")
    c = common(w.add_parser("run", help="measure the plan's poses on the float64 machine"))
    c.add_argument("--plan", required=True)
    c.add_argument("--machine", required=True, help="config with the as_built section (the plant)")
    c.add_argument("--tracker-seed", type=int, default=None, help="the tracker's pose (default: as_built seed)")
    c.add_argument("--noise-seed", type=int, default=1)
    c.add_argument("--tracker-csv", help="also write the tracker's own CSV")
    c.add_argument("--build", help="closed loop: the build dir whose sp_controller (the config) and hs_sim "
                   "(built with -DHS_CONFIG=MACHINE.json, or see --as-built-plant) drive the poses over vcan")
    c.add_argument("--as-built-plant", action="store_true",
                   help="with --build: hand hs_sim the machine's as_built section at run time (hs_sim --as-built), "
                   "so that any build's plant is the as-built machine")
    c.add_argument("--inproc", action="store_true",
                   help="with --build: the controller in hs_sim's process (hs_sim --inproc, no vcan; same frames)")
    c.add_argument("-o", "--out", required=True)
    d = common(w.add_parser("solve", help="least squares: joints, sensor zeros, tracker pose"))
    d.add_argument("measurements")
    d.add_argument("--fit-scale", action="store_true", help="also the sensors' scale")
    d.add_argument("-o", "--out", required=True)
    e = common(w.add_parser("check", help="accuracy before and after on fresh validation poses"))
    e.add_argument("--calibrated", required=True, help="the config solve wrote")
    e.add_argument("--measurements", metavar="CHECK.csv",
                   help="a check run's measurement CSV (fresh poses, not the solve's): the check without truth")
    e.add_argument("--machine", help="simulation: the config with the as_built section (the plant's truth)")
    e.add_argument("--poses", type=int, default=50, help="validation poses with --machine alone (default 50)")
    e.add_argument("--loop-poses", type=int, default=20, help="validation moves in closed loop (default 20)")
    e.add_argument("--seed", type=int, default=1001)
    e.add_argument("--plot")
    e.add_argument("--accept", metavar="OUT.json", help="write the checked config here if the check passes")
    e.add_argument("--closed-loop", nargs=3, metavar=("NOMINAL", "BEFORE", "AFTER"),
                   help="also in closed loop: build dirs of nominal-on-nominal, nominal config on the as-built "
                   "plant, calibrated config on it: absolute error after each move, the surge's tracking")
    e.add_argument("--as-built-plant", action="store_true",
                   help="with --closed-loop: BEFORE's and AFTER's hs_sim get --machine's as_built at run time")
    e.add_argument("--inproc", action="store_true", help="with --closed-loop: hs_sim --inproc, no vcan")
    p.set_defaults(func=run)
