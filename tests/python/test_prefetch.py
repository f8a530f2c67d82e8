# SPDX-License-Identifier: Apache-2.0
"""stewart.analysis.prefetch: a job run beside the caller gives the same
value, and raises the same error, as the job run inline (numpy arrays come
back whole through the pipe, a worker that dies is an error, not a hang);
and the analysis package stays light until a decoding name is used."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

from stewart.analysis import logfile, prefetch

LOG = (b"(1.000000) vcan1 010##0" + b"00" * 8 + b"\n"
       b"not a frame\n"
       b"(1.001000) vcan2 031#0102030405060708\n")


@pytest.mark.parametrize("cores", [1, 2])
def test_beside_returns_and_raises_like_inline(monkeypatch, cores):
    monkeypatch.setattr(prefetch.os, "cpu_count", lambda: cores)
    assert prefetch.beside(int, "42").result(timeout=60) == 42
    with pytest.raises(ValueError, match="invalid literal"):
        prefetch.beside(int, "forty-two").result(timeout=60)


@pytest.mark.parametrize("cores", [1, 2])
def test_frames_read_beside_equal_frames_read_inline(tmp_path, monkeypatch, cores):
    monkeypatch.setattr(prefetch.os, "cpu_count", lambda: cores)
    path = tmp_path / "run.log"
    path.write_bytes(LOG)
    a = logfile.read_frames(path)
    b = prefetch.read_frames_beside(path).result(timeout=60)
    assert len(a.line_no) == 2 and a.malformed and a.malformed == b.malformed
    for name in ("line_no", "time", "iface", "frame_id", "fd", "dlc", "data"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.ifaces == b.ifaces and a.lines == b.lines == 3


def test_a_missing_log_raises_through_the_future(tmp_path):
    with pytest.raises(OSError):
        prefetch.read_frames_beside(tmp_path / "missing.log").result(timeout=60)


def test_the_package_and_its_prefetch_do_not_load_the_protocol():
    code = ("import sys, stewart.analysis.prefetch, stewart.analysis.logfile; "
            "print('cantools' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_arrays_come_back_whole_and_a_dead_worker_is_an_error(monkeypatch):
    monkeypatch.setattr(prefetch.os, "cpu_count", lambda: 2)
    got = prefetch.beside(lambda: {"a": np.arange(3_000_000), "b": np.eye(3)[:, 1], "c": "text"}).result(timeout=60)
    np.testing.assert_array_equal(got["a"], np.arange(3_000_000))
    np.testing.assert_array_equal(got["b"], [0.0, 1.0, 0.0])   # not contiguous: pickled in band
    assert got["c"] == "text" and got["a"].flags.writeable
    with pytest.raises(OSError, match="ended without an answer"):
        prefetch.beside(os._exit, 3).result(timeout=60)
    with pytest.raises(TimeoutError):
        prefetch.beside(time.sleep, 2).result(timeout=0.1)
