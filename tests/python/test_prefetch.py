"""stewart.analysis.prefetch: a job run beside the caller gives the same
value, and raises the same error, as the job run inline; and the analysis
package stays light until a decoding name is used."""

from __future__ import annotations

import subprocess
import sys

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
