# SPDX-License-Identifier: Apache-2.0
"""Progress of the commands that take more than a moment, on stderr (the
results stay alone on stdout): a bar redrawn in place on a terminal, else
a line now and then; ``-q/--quiet`` (:func:`add_quiet`) silences it."""

from __future__ import annotations

import argparse
import sys
import time
from typing import TextIO


def add_quiet(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


class Progress:
    """``count`` of ``total`` steps of ``what`` done: shown at the start, then
    at most every ``every`` seconds (and at the end) on stderr."""

    def __init__(self, prog: str, what: str, total: int, quiet: bool = False, every: float = 1.0,
                 stream: TextIO | None = None):
        self.prog, self.what, self.total = prog, what, total
        self.quiet, self.every = quiet, every
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self.count = 0
        self.t0 = self._last = time.monotonic()
        self._show("")

    def advance(self, n: int = 1, note: str = "") -> None:
        self.count += n
        now = time.monotonic()
        if now - self._last >= self.every or self.count >= self.total:
            self._last = now
            self._show(note)

    def _show(self, note: str) -> None:
        if self.quiet:
            return
        elapsed = time.monotonic() - self.t0
        done = self.count / self.total if self.total else 1.0
        text = f"{self.prog}: {self.what} {self.count}/{self.total} ({elapsed:.0f} s)" + (f" {note}" if note else "")
        if self.tty:
            bar = "#" * round(20 * done) + "." * (20 - round(20 * done))
            end = "\n" if self.count >= self.total else ""
            self.stream.write(f"\r[{bar}] {text}\x1b[K{end}")
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

