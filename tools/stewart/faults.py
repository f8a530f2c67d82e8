# SPDX-License-Identifier: Apache-2.0
"""The fault-injection campaign (issue 17, docs/explanation/faults.md).

Every injectable fault in each of the states ENGAGING, RUNNING (the paper's
trigonometric motion, a point-to-point move, a stream of targets) and
PARKING, each run a lockstep closed loop of the firmware's controller and
the simulated hexapod (``hs_sim --inproc``: the controller's node in the
plant's process, the frames passed in memory in the order vcan carries
them; ``hs_sim`` prints the fault report). The runs are independent and go
in parallel over the machine's cores.

A row: the fault, the state, after how many ticks the controller reported
a fault (CTRL_STATUS), its reaction (state/drive mode 20 ticks later), the
final state, the platform at rest at the end (true velocity < 1 mm/s and
1 mrad/s), the largest excursion of the true pose from the last safe
reference (the reference while no fault was reported, then the one before
the report), the legs inside their strokes all along, and the frames
unaccounted for (sent, minus those the receivers accepted or counted as
rejected, minus those the injector dropped or still holds: must be 0).
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .closedloop import Binaries

HOME = (0.0, 0.0, 2.55, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Fault:
    """One injectable fault: its scenario lines and the detection it must
    meet (``bound`` ticks; None: tolerated, no fault need be reported)."""
    name: str
    inject: str
    bound: int | None
    what: str


#: Every injectable fault. Bounds: the controller's feedback timeout is 2
#: ticks (reported on the third), the drives' setpoint watchdog 3 cycles,
#: their following error 20 mm; a rejected setpoint frame raises the drives'
#: communication bit, which the controller reports as a drive fault. The
#: drives' safety functions (host_sim/include/hs/drive.h): a spool 0.2 off
#: its model for 2 ms is a valve fault (the spool reaches it within about
#: 1 ms of sticking open: 6 ticks with the report); a length reading that
#: stays put while the valve's flows predict 1 mm of travel is a sensor
#: fault (400 ticks: 1 mm at 2.5 mm/s, the slowest a leg creeps against a
#: stuck sensor in these runs, 4 mm/s, with margin).
FAULTS: tuple[Fault, ...] = (
    Fault("drop-feedback-1", "inject frames axis_a feedback drop count=1", None,
          "one feedback frame lost"),
    Fault("drop-feedback-3c", "inject frames axis_b feedback drop count=9", 4,
          "axis_b's feedback lost for 3 cycles"),
    Fault("drop-setpoints", "inject frames axis_a setpoints drop count=4", 8,
          "axis_a's setpoints lost for 4 cycles (drive watchdog)"),
    Fault("delay-feedback", "inject frames axis_a feedback delay delay=5 count=9", 4,
          "axis_a's feedback 5 ticks late for 3 cycles"),
    Fault("duplicate-feedback", "inject frames axis_b feedback duplicate count=1", None,
          "a feedback frame twice"),
    Fault("duplicate-setpoints", "inject frames axis_b setpoints duplicate count=1", 3,
          "a setpoints frame twice (the drives see a repeated counter)"),
    Fault("reorder-feedback", "inject frames axis_a feedback reorder count=1", None,
          "two feedback frames swapped"),
    Fault("reorder-setpoints", "inject frames axis_a setpoints reorder count=1", 3,
          "setpoints behind the next cycle's"),
    Fault("corrupt-feedback", "inject frames axis_b feedback corrupt count=1", None,
          "one feedback bit flipped (CRC)"),
    Fault("corrupt-setpoints", "inject frames axis_a setpoints corrupt count=1", 3,
          "one setpoints bit flipped (CRC)"),
    Fault("corrupt-rate", "inject frames any any corrupt rate=0.001", None,
          "every frame of every bus corrupted at 0.1 %"),
    Fault("drop-commands", "inject frames ops command drop count=1", None,
          "the next operator command lost (the operator repeats STOP)"),
    Fault("busoff-axis_a", "inject busoff axis_a 0.5", 4, "axis_a off for 0.5 s"),
    Fault("busoff-ops", "inject busoff ops 0.5", None, "the ops bus off for 0.5 s"),
    Fault("drive-fault", "inject drive 2 fault 0x80", 2, "drive 2 reports an internal fault"),
    Fault("drive-freeze", "inject drive 4 freeze", 4, "drive 4's alive counter frozen"),
    Fault("drive-stale", "inject drive 6 stale 2", 4, "drive 6 echoes a SYNC tick 2 old"),
    Fault("sensor-stick", "inject sensor 1 stick", 400,
          "leg 1's length sensor stuck (the drive's flow balance: 1 mm of travel unseen)"),
    Fault("sensor-jump", "inject sensor 2 jump 0.03", 3, "leg 2's sensor jumps 30 mm"),
    Fault("sensor-noise", "inject sensor 3 noise 0.01", 3, "leg 3's sensor noisy, 10 mm sigma"),
    Fault("valve-stick", "inject valve 5 stick 0", None, "leg 5's valve stuck at null"),
    Fault("supply-loss", "inject supply loss", 2, "the supply pressure lost (the drives' supply monitor)"),
    Fault("endstop", "inject endstop 3 up", 6,
          "leg 3's valve stuck open (the drive's valve monitor, its blocking valves close)"),
    Fault("fk-inconsistent", "inject fk 0.05", 3, "inconsistent leg lengths (+-50 mm)"),
)

STATES: tuple[str, ...] = ("ENGAGING", "RUNNING/trig", "RUNNING/p2p", "RUNNING/stream", "PARKING")

#: The representative subset of the test command: one of each family, in states that cover all five.
SUBSET: tuple[tuple[str, str], ...] = (
    ("drop-feedback-3c", "RUNNING/trig"),
    ("corrupt-setpoints", "PARKING"),
    ("busoff-axis_a", "RUNNING/stream"),
    ("drive-fault", "ENGAGING"),
    ("drive-freeze", "RUNNING/p2p"),
    ("sensor-jump", "RUNNING/trig"),
    ("duplicate-feedback", "RUNNING/p2p"),
    ("sensor-stick", "RUNNING/p2p"),
    ("endstop", "RUNNING/trig"),
)

_AFTER = 1.0  # s observed after the injection before the operator's STOP
_SETTLE = 3.0  # s after the STOP


def stream_csv(t0: float, t1: float) -> str:
    """Target poses from t0 to t1 s of a stream (surge 50 mm and yaw 40 mrad
    at 0.4 Hz about home), its time from 0 (a `play` file's)."""
    rows = ["t,x,y,z,roll,pitch,yaw"]
    for k in range(round(t0 * 1000), round(t1 * 1000) + 1, 10):
        t = k / 1000.0
        s = math.sin(2 * math.pi * 0.4 * t)
        rows.append(f"{t - t0:.3f},{0.05 * s:.6f},0,{HOME[2]:.6f},0,0,{0.04 * s:.6f}")
    return "\n".join(rows) + "\n"


def scenario(fault: Fault, state: str) -> str:
    """The scenario of one row: reach the state, inject, observe, stop, settle."""
    head = "delay 0.2\ncmd ENGAGE\n"
    stop = f"delay {_AFTER}\ncmd STOP\ndelay 0.5\ncmd STOP\ndelay {_SETTLE}\nend\n"
    if state == "ENGAGING":
        return head + f"delay 1.0\n{fault.inject}\ndelay {_AFTER + 0.5 + _SETTLE}\nend\n"
    head += "wait ready 30\ndelay 0.1\n"
    if state == "PARKING":
        return head + f"cmd PARK\ndelay 1.0\n{fault.inject}\ndelay {_AFTER + 0.5 + _SETTLE}\nend\n"
    if state == "RUNNING/trig":
        return head + "cmd RUN_TRIG axis=x amplitude=0.09 frequency=0.5 fade=0.5\ndelay 1.0\n" + fault.inject + "\n" + stop
    if state == "RUNNING/p2p":
        x, y, z, r, p, yaw = HOME
        return (head + f"target 0.12 0.05 {z + 0.05} 0.03 0 0.05\ncmd MOVE_TO fade=3\ndelay 1.0\n"
                + fault.inject + "\n" + stop)
    if state == "RUNNING/stream":
        # `play` holds the actions after it back until its file ends: the
        # stream in two files, the injection between them
        return (head + "cmd STREAM\nplay stream_a.csv\n" + fault.inject + "\nplay stream_b.csv\n"
                + stop.replace(f"delay {_AFTER}\n", "", 1))
    raise ValueError(f"unknown state {state!r} ({', '.join(STATES)})")


_REPORT = re.compile(
    r"hs_sim fault-report: inject (\d+) detected (yes|no) after (-?\d+) ticks faults 0x([0-9a-f]+) "
    r"reaction (\S+) final (\S+)/0x([0-9a-f]+) rest (yes|no) excursion ([\d.]+) mm ([\d.]+) mrad "
    r"strokes (yes|no) unaccounted (-?\d+)")
_FRAMES = re.compile(r"hs_sim injector: in (\d+)")


@dataclass
class Row:
    fault: str
    state: str
    bound: int | None
    rc: int = -1
    detected: bool = False
    ticks: int = -1
    faults: int = 0
    reaction: str = ""
    final: str = ""
    rest: bool = False
    excursion_mm: float = float("nan")
    excursion_mrad: float = float("nan")
    strokes: bool = False
    unaccounted: int = -1
    frames: int = 0
    wall_s: float = 0.0
    error: str = ""
    log: Path | None = field(default=None, repr=False)

    @property
    def within_bound(self) -> bool:
        return self.bound is None or (self.detected and 0 <= self.ticks <= self.bound)

    @property
    def safe(self) -> bool:
        return self.rc == 0 and self.rest and self.strokes and self.unaccounted == 0


def parse_report(text: str, row: Row) -> Row:
    m = _REPORT.search(text)
    if not m:
        row.error = "no fault report"
        return row
    row.detected = m.group(2) == "yes"
    row.ticks = int(m.group(3))
    row.faults = int(m.group(4), 16)
    row.reaction = m.group(5)
    row.final = m.group(6)
    row.rest = m.group(8) == "yes"
    row.excursion_mm = float(m.group(9))
    row.excursion_mrad = float(m.group(10))
    row.strokes = m.group(11) == "yes"
    row.unaccounted = int(m.group(12))
    f = _FRAMES.search(text)
    row.frames = int(f.group(1)) if f else 0
    return row


def run_row(fault: Fault, state: str, plant: Path, workdir: Path, seed: int = 1, log: bool = False) -> Row:
    """Runs one row in-process (``hs_sim --inproc``) and parses its report."""
    row = Row(fault.name, state, fault.bound)
    d = workdir / f"{fault.name}__{state.replace('/', '_')}"
    d.mkdir(parents=True, exist_ok=True)
    (d / "stream_a.csv").write_text(stream_csv(0.0, 1.5))
    (d / "stream_b.csv").write_text(stream_csv(1.5, 1.5 + _AFTER))
    scn = d / "run.scenario"
    scn.write_text(scenario(fault, state))
    from . import auth

    # the machine key: $STEWART_KEY's, else a throw-away one in the work directory
    argv = [str(plant), "--inproc", "--scenario", str(scn), "--seed", str(seed), "--key", str(auth.run_key(workdir))]
    if log:
        row.log = d / "run.log"
        argv += ["--log", str(row.log)]
    t0 = time.monotonic()
    p = subprocess.run(argv, capture_output=True, text=True, timeout=600)
    row.wall_s = time.monotonic() - t0
    row.rc = p.returncode
    (d / "plant.txt").write_text(p.stdout + p.stderr)
    parse_report(p.stdout, row)
    if p.returncode != 0 and not row.error:
        row.error = (p.stderr.strip().splitlines() or ["exit %d" % p.returncode])[-1]
    return row


def campaign(pairs: list[tuple[Fault, str]], jobs: int | None = None, build: str | Path | None = None,
             workdir: str | Path | None = None, log: bool = False,
             done: Callable[[Row], None] | None = None) -> list[Row]:
    """Runs the rows in parallel (``jobs`` workers, default the machine's cores);
    ``done`` is called with each row as it ends."""
    bins = Binaries.find(build)
    jobs = jobs or os.cpu_count() or 1
    tmp = None
    if workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="stewart-faults-")
        workdir = tmp.name
    wd = Path(workdir)
    from . import auth

    auth.run_key(wd)  # once, before the workers share it
    try:
        with ThreadPoolExecutor(max_workers=jobs) as ex:
            futs = [ex.submit(run_row, f, s, bins.plant, wd, 1, log) for f, s in pairs]
            for fut in as_completed(futs):
                if done is not None:
                    done(fut.result())
            return [f.result() for f in futs]
    finally:
        if tmp is not None and not log:
            tmp.cleanup()


def select(faults: list[str] | None = None, states: list[str] | None = None,
           subset: bool = False) -> list[tuple[Fault, str]]:
    by_name = {f.name: f for f in FAULTS}
    if subset:
        return [(by_name[f], s) for f, s in SUBSET]
    fs = [by_name[n] for n in faults] if faults else list(FAULTS)
    ss = states or list(STATES)
    for s in ss:
        if s not in STATES:
            raise ValueError(f"unknown state {s!r} ({', '.join(STATES)})")
    return [(f, s) for f in fs for s in ss]


def table(rows: list[Row]) -> str:
    """The campaign's table (Markdown)."""
    head = ("| fault | state | detected after (ticks) | bound | reaction | final | at rest | "
            "excursion (mm / mrad) | legs in strokes | frames | unaccounted |")
    out = [head, "|" + "---|" * 11]
    for r in rows:
        det = str(r.ticks) if r.detected else "-"
        bound = str(r.bound) if r.bound is not None else "tolerated"
        reaction = r.reaction if r.detected else "none"
        if r.error:
            reaction = f"ERROR: {r.error}"
        out.append(f"| {r.fault} | {r.state} | {det} | {bound} | {reaction} | {r.final} | "
                   f"{'yes' if r.rest else 'no'} | {r.excursion_mm:.1f} / {r.excursion_mrad:.1f} | "
                   f"{'yes' if r.strokes else 'no'} | {r.frames} | {r.unaccounted} |")
    return "\n".join(out)
