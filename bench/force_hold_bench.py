# SPDX-License-Identifier: Apache-2.0
"""Benchmark: the issue 15 hold figures per wrench source and stiffness.

    .venv/bin/python bench/force_hold_bench.py [--build build/host-release] [--out DIR]
        [--sources sensor,cylinders] [--stiffness 1e5,1e6,1e7] [--hold 2.0]

Runs `hs_sim --inproc` (the controller in the plant's process, the frames in
memory in the order one vcan socket delivers them: the same CAN log as the
lockstep run over vcan) on the scenario of tests/bus/test_force_loop.py's
cylinder run for each source and stiffness: engage, tare, a plane 2 mm above
the tool, FORCE on z with 2 kN held `--hold` s (plus the 1.5 s the approach
is allowed), the plane removed. Prints, per run, the figures of
stewart.forcecontrol.hold_figures and loss_figures.

"Contact", for the figures, is the plant's: the first tick the true normal
force (the truth's -Fz) reaches 100 N (forcecontrol.CONTACT_N), whatever
the controller's contact flag says; the RMS error is taken from 0.5 s after
it to the end of the hold, the overshoot from it, the peak-to-peak over the
last second of the hold. A figure printer, not a test.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from stewart import auth  # noqa: E402
from stewart import forcecontrol as fc  # noqa: E402
from stewart.analysis.truth import read_truth  # noqa: E402


def scenario(stiffness: float, hold: float) -> str:
    return ("cmd ENGAGE\n"
            "wait ready 20\n"
            "delay 0.3\n"
            + fc.tare()
            + fc.approach_and_hold(stiffness, 2000.0, hold=hold)
            + fc.remove_surface(0.5)
            + "end\n")


def run_one(hs_sim: Path, out: Path, source: str, stiffness: float, hold: float, seed: int | None = None) -> dict:
    key = auth.run_key(out).resolve()
    name = f"{source}_{stiffness:g}" + (f"_s{seed}" if seed is not None else "")
    scn = out / f"{name}.scenario"
    scn.write_text(scenario(stiffness, hold))
    log, truth = out / f"{name}.log", out / f"{name}.truth.csv"
    p = subprocess.run([str(hs_sim), "--inproc", "--wrench-source", source, "--scenario", str(scn),
                        "--log", str(log), "--truth", str(truth), "--key", str(key), "--session", "1"]
                       + (["--seed", str(seed)] if seed is not None else []),
                       capture_output=True, text=True, check=False)
    if p.returncode != 0:
        return {"error": f"hs_sim exited {p.returncode}: {p.stdout[-500:]}{p.stderr[-500:]}"}
    m = fc.marks(p.stdout)
    tr = read_truth(truth)
    status = fc.read_status(log)
    h = fc.hold_figures(tr, m["begin hold"], m["end hold"], 2000.0)
    loss = fc.loss_figures(tr, status, m["remove"])
    # the controller's contact flag (CTRL_STATUS) against the truth's contact
    on = status.tick[(status.tick >= m["begin hold"]) & (status.contact == 1)]
    h["flag_after_truth_ms"] = (int(on[0]) - h["contact_tick"]) if on.size and h.get("contact_tick") else None
    return {"hold": h, "loss": loss}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=str(ROOT / "build" / "host-release"))
    ap.add_argument("--out", default=None)
    ap.add_argument("--sources", default="sensor,cylinders")
    ap.add_argument("--stiffness", default="1e5,1e6,1e7")
    ap.add_argument("--hold", type=float, default=2.0)
    ap.add_argument("--seeds", default="", help="comma-separated hs_sim --seed values (default: hs_sim's)")
    a = ap.parse_args()
    hs_sim = Path(a.build) / "host_sim" / "hs_sim"
    out = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="force_hold_"))
    out.mkdir(parents=True, exist_ok=True)
    print(f"force hold bench: runs in {out}")
    print("| source | surface | RMS error | overshoot | p-p, last second | contact flag after true 100 N "
          "| removal: detected | travel after it |")
    print("|---|---|---|---|---|---|---|---|")
    seeds = [int(x) for x in a.seeds.split(",") if x] or [None]
    for source in a.sources.split(","):
        for k, seed in ((float(s), sd) for s in a.stiffness.split(",") for sd in seeds):
            r = run_one(hs_sim, out, source, k, a.hold, seed)
            if "error" in r:
                print(f"| {source} | {k:g} N/m | {r['error']} |")
                continue
            h, lo = r["hold"], r["loss"]
            if h.get("contact_tick") is None:
                print(f"| {source} | {k:g} N/m | no contact |")
                continue
            det = lo["detected_ticks"]
            label = f"{k:.0e} N/m" + (f" (seed {seed})" if seed is not None else "")
            print(f"| {source} | {label} | {h['rms_pct']:.2f} % | {h['overshoot_pct']:.2f} % | "
                  f"{h['pp_pct']:.2f} % | {h['flag_after_truth_ms']} ms | "
                  f"{det if det is not None else 'not'} ticks | {lo['travel_max_mm']:.2f} mm |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
