# SPDX-License-Identifier: Apache-2.0
"""The two processes of the simulated platform in real time: the firmware's
controller (``sp_controller``, the cycle master) and the simulated hexapod
(``hs_sim``, following the wall clock), on vcan0..vcan2 where they run.

Their output is read line by line: the deadline figures (``--stats 1``: a
line each second from each), the controller's state and the plant's pose
(``hs_sim --progress``), the answers to scenario lines given at run time
(``hs_sim --control FIFO``, one request a line), marks. Kept in files
``controller.txt`` and ``plant.txt`` of the run directory.
"""

from __future__ import annotations

import collections
import os
import re
import signal
import subprocess
import tempfile
import threading
import time
from pathlib import Path

from .. import closedloop as cl

_CTL_STATS = re.compile(r"^sp_controller stats: ticks (\d+), deadline misses (\d+) \(([\d.]+) %\), "
                        r"worst late ([\d.-]+) ms")
_PLANT_STATS = re.compile(r"^hs_sim stats: cycles (\d+), deadline misses (\d+) \(([\d.]+) %\), "
                          r"worst late ([\d.-]+) ms")
_PROGRESS = re.compile(r"^hs_sim: t=\s*([\d.]+) s\s+controller (\S+)\s+pose x ([-+\d.]+) y ([-+\d.]+) "
                       r"z ([-+\d.]+) m\s+yaw ([-+\d.]+) rad")
_ANSWER = re.compile(r"^hs_sim control: (accepted|refused): (.*)$")
_EVENT = re.compile(r"^hs_sim (mark tick \d+: .*|control: failed: .*)$")

#: SCHED_FIFO priority of the pair (the agent's relay runs below it).
PRIORITY = 10
#: Seconds an injected line may wait for the plant's answer.
ANSWER_TIMEOUT = 10.0


class SimError(RuntimeError):
    """The simulation cannot start or do what was asked (message for the user)."""


def _stats(m: re.Match, unit: str) -> dict:
    return {unit: int(m.group(1)), "deadline_misses": int(m.group(2)), "miss_percent": float(m.group(3)),
            "worst_late_ms": float(m.group(4))}


class Plant:
    """sp_controller and hs_sim in real time. ``relax``: the controller's
    feedback supervision and the drives' setpoint watchdog in ticks (None:
    the config's; a host that misses 1 ms deadlines, as user-mode Linux,
    needs more). ``realtime``: both get SCHED_FIFO 10 once both have
    started (not before: a controller that cannot keep up would starve the
    plant's start)."""

    def __init__(self, out: Path, key: Path, build: str | None = None, relax: int | None = None,
                 realtime: bool = False, operator_timeout: int | None = None):
        self.out, self.key = Path(out), Path(key)
        self.bins = cl.Binaries.find(build)
        self.relax, self.realtime, self.operator_timeout = relax, realtime, operator_timeout
        self.prefix: list[str] = []
        self.procs: dict[str, subprocess.Popen] = {}
        self.tails = {name: collections.deque(maxlen=200) for name in ("controller", "plant")}
        self.stats: dict[str, dict] = {}
        self.progress: dict = {}
        self.events: collections.deque = collections.deque(maxlen=50)
        self._answers: collections.deque = collections.deque()
        self._cond = threading.Condition()
        self._inject_lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._fifo_dir = tempfile.mkdtemp(prefix="stewart-sim-", dir="/dev/shm" if os.path.isdir("/dev/shm") else None)
        self.fifo = Path(self._fifo_dir) / "control"
        os.mkfifo(self.fifo, 0o600)
        self._fifo_fd: int | None = None
        self.started = 0.0

    # ---------------------------------------------------------- start, stop

    def commands(self) -> tuple[list[str], list[str]]:
        ctl = [*self.prefix, str(self.bins.controller), "--key", str(self.key), "--stats", "1"]
        plant = [*self.prefix, str(self.bins.plant), "--key", str(self.key), "--stats", "1", "--progress",
                 "--control", str(self.fifo)]
        if self.relax:
            ctl += ["--feedback-timeout", str(min(self.relax, 1000))]
            plant += ["--setpoint-timeout", str(self.relax)]
        if self.operator_timeout is not None:
            ctl += ["--operator-timeout", str(self.operator_timeout)]
        return ctl, plant

    def start(self, timeout: float = 60.0) -> None:
        """Starts the controller, then (once its sockets are open) the plant."""
        ctl, plant = self.commands()
        self.out.mkdir(parents=True, exist_ok=True)
        self._spawn("controller", ctl)
        self._wait_line("controller", "mode on", timeout)
        self._spawn("plant", plant)
        self._wait_line("plant", "mode on", timeout)
        if self.realtime:
            for p in self.procs.values():
                os.sched_setscheduler(p.pid, os.SCHED_FIFO, os.sched_param(PRIORITY))
        # our own writer on the FIFO (hs_sim holds it read-write: never an end of file)
        self._fifo_fd = os.open(self.fifo, os.O_WRONLY | os.O_NONBLOCK)
        self.started = time.time()

    def _spawn(self, name: str, argv: list[str]) -> None:
        try:
            p = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True, errors="replace", bufsize=1)
        except OSError as e:
            raise SimError(f"cannot start {argv[len(self.prefix)]}: {e}") from None
        self.procs[name] = p
        t = threading.Thread(target=self._read, args=(name, p), daemon=True)
        t.start()
        self._threads.append(t)

    def _wait_line(self, name: str, text: str, timeout: float) -> None:
        end = time.monotonic() + timeout
        with self._cond:
            while not any(text in line for line in self.tails[name]):
                if self.procs[name].poll() is not None:
                    self._cond.wait(0.5)  # its last lines
                    self.stop()
                    tail = "\n".join(self.tails[name])
                    raise SimError(f"the {name} ended at start-up:\n{tail}")
                left = end - time.monotonic()
                if left <= 0:
                    self.stop()
                    raise SimError(f"the {name} did not start within {timeout:g} s")
                self._cond.wait(min(left, 0.1))

    def stop(self, timeout: float = 15.0) -> dict:
        """SIGINT to the plant and the controller (killed after ``timeout``);
        returns the final figures."""
        for name in ("plant", "controller"):
            p = self.procs.get(name)
            if p is not None and p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in self.procs.values():
            try:
                p.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for t in self._threads:
            t.join(timeout=5)
        if self._fifo_fd is not None:
            os.close(self._fifo_fd)
            self._fifo_fd = None
        try:
            self.fifo.unlink()
            os.rmdir(self._fifo_dir)
        except OSError:
            pass
        return self.status()

    def alive(self) -> bool:
        return bool(self.procs) and all(p.poll() is None for p in self.procs.values())

    # ------------------------------------------------------------- reading

    def _read(self, name: str, p: subprocess.Popen) -> None:
        assert p.stdout is not None
        with open(self.out / f"{name}.txt", "w") as log:
            for line in p.stdout:
                line = line.rstrip("\n")
                log.write(line + "\n")
                if "stats:" in line or "control:" in line or "mark" in line:
                    log.flush()
                self._take(name, line)
        with self._cond:
            self._cond.notify_all()

    def _take(self, name: str, line: str) -> None:
        with self._cond:
            self.tails[name].append(line)
            m = _CTL_STATS.match(line) or _PLANT_STATS.match(line)
            if m:
                self.stats[name] = _stats(m, "ticks" if name == "controller" else "cycles")
            elif (m := _PROGRESS.match(line)) is not None:
                self.progress = {"t": float(m.group(1)), "state": m.group(2),
                                 "pose": [float(m.group(k)) for k in (3, 4, 5)] + [float(m.group(6))]}
            elif (m := _ANSWER.match(line)) is not None:
                self._answers.append((m.group(1), m.group(2)))
            elif (m := _EVENT.match(line)) is not None:
                self.events.append(m.group(1))
            self._cond.notify_all()

    # ------------------------------------------------------------ requests

    def inject(self, line: str) -> dict:
        """Gives the plant one scenario line; returns {"ok", "answer"}."""
        if "\n" in line or "\r" in line or "\0" in line:
            return {"ok": False, "answer": "one scenario line, without line breaks"}
        if not line.strip():
            return {"ok": False, "answer": "an empty line"}
        with self._inject_lock:
            if self._fifo_fd is None or not self.alive():
                return {"ok": False, "answer": "the simulation is not running"}
            with self._cond:
                self._answers.clear()
            try:
                os.write(self._fifo_fd, (line + "\n").encode())
            except OSError as e:
                return {"ok": False, "answer": f"cannot reach the plant: {e}"}
            end = time.monotonic() + ANSWER_TIMEOUT
            with self._cond:
                while not self._answers:
                    left = end - time.monotonic()
                    if left <= 0 or not self.alive():
                        return {"ok": False, "answer": "the plant did not answer"}
                    self._cond.wait(min(left, 0.2))
                kind, text = self._answers.popleft()
            return {"ok": kind == "accepted", "answer": text}

    def status(self) -> dict:
        with self._cond:
            ctl = self.stats.get("controller", {})
            plant = self.stats.get("plant", {})
            return {"running": self.alive(), "uptime_s": round(time.time() - self.started, 1) if self.started else 0.0,
                    "controller": dict(ctl), "plant": dict(plant), "progress": dict(self.progress),
                    "events": list(self.events)[-10:],
                    "exit": {n: p.returncode for n, p in self.procs.items() if p.poll() is not None}}
