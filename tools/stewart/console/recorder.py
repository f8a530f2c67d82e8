# SPDX-License-Identifier: Apache-2.0
"""The console's recordings: every frame the console receives, from the
start to the stop, in a candump ``-L`` log with the simulated set-up's
interface names (ops vcan0, axis_a vcan1, axis_b vcan2), then
``stewart analyze`` on it in the background: ``signals.csv``, the summary
and the plots of each segment, served by the API."""

from __future__ import annotations

import re
import threading
import time
from pathlib import Path

from .. import protocol as pr

NAME = re.compile(r"^rec-\d{8}-\d{6}(-\d+)?$")
FILES = {"log": "bus.log", "csv": "analysis/signals.csv", "summary": "analysis/summary.json"}


class Recorder:
    def __init__(self, root: Path, proto):
        self.root = root
        self.proto = proto
        self._lock = threading.Lock()
        self._file = None
        self.name: str | None = None
        self.frames = 0
        self.started = 0.0
        self.analysing: set[str] = set()
        self.errors: dict[str, str] = {}

    def start(self) -> dict:
        with self._lock:
            if self._file is not None:
                raise ValueError(f"recording {self.name} is already running: stop it first")
            name = time.strftime("rec-%Y%m%d-%H%M%S", time.gmtime())
            n = 1
            while (self.root / name).exists():
                n += 1
                name = time.strftime("rec-%Y%m%d-%H%M%S", time.gmtime()) + f"-{n}"
            d = self.root / name
            d.mkdir(parents=True)
            self._file = open(d / FILES["log"], "w", buffering=1 << 16)
            self.name, self.frames, self.started = name, 0, time.time()
            return self.info()

    def frame(self, msg, bus: str) -> None:
        """Called by the receive threads for every frame."""
        f = self._file
        if f is None or msg.is_error_frame:
            return
        data = bytes(msg.data).hex().upper()
        sep = "##" + str(1 if msg.bitrate_switch else 0) if msg.is_fd else "#"
        line = f"({msg.timestamp or time.time():.6f}) {pr.BUSES.get(bus, bus)} {msg.arbitration_id:03X}{sep}{data}\n"
        with self._lock:
            if self._file is not None:
                self._file.write(line)
                self.frames += 1

    def stop(self, analyse: bool = True) -> dict | None:
        with self._lock:
            if self._file is None:
                return None
            self._file.close()
            self._file = None
            name, self.name = self.name, None
        if analyse:
            self.analysing.add(name)
            threading.Thread(target=self._analyse, args=(name,), daemon=True).start()
        return {"name": name, "frames": self.frames, "seconds": time.time() - self.started}

    def _analyse(self, name: str) -> None:
        from ..analysis.run import analyze

        d = self.root / name
        try:
            analyze(d / FILES["log"], d / "analysis")
        except Exception as e:  # noqa: BLE001 - reported to the page, the recording stays
            self.errors[name] = f"{type(e).__name__}: {e}"
        finally:
            self.analysing.discard(name)

    def info(self) -> dict:
        return {"active": self._file is not None, "name": self.name, "frames": self.frames,
                "seconds": time.time() - self.started if self._file is not None else 0.0}

    def list(self) -> list[dict]:
        if not self.root.is_dir():
            return []
        out = []
        for d in sorted(self.root.iterdir(), reverse=True):
            if not (d.is_dir() and NAME.match(d.name)) or d.name == self.name:
                continue
            plots = sorted(p.name for p in (d / "analysis").glob("*.png")) if (d / "analysis").is_dir() else []
            out.append({"name": d.name, "log_bytes": (d / FILES["log"]).stat().st_size if (d / FILES["log"]).exists() else 0,
                        "csv": (d / FILES["csv"]).exists(), "plots": plots,
                        "analysing": d.name in self.analysing, "error": self.errors.get(d.name)})
        return out

    def path(self, name: str, what: str) -> Path | None:
        """The file of a finished recording, or None (names checked: no path escapes)."""
        if not NAME.match(name) or name == self.name:
            return None
        d = self.root / name
        if what in FILES:
            p = d / FILES[what]
        elif re.match(r"^seg\d+_(tracking|cylinders)\.png$", what):
            p = d / "analysis" / what
        else:
            return None
        return p if p.is_file() else None
