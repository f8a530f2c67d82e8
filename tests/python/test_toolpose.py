# SPDX-License-Identifier: Apache-2.0
"""The tool pose in the work frame for the analysis (issue 31,
stewart.analysis.toolpose) and the demo's frames segments
(stewart.framesdemo), without a bus:

* ``tool_in_work`` / ``platform_of_tool`` (many poses at once) agree with
  the core's float64 reference ``stewart.frames.Frames`` on random frames
  and poses within 1e-12, and invert each other;
* signals.csv: with identity frames the same bytes as without frames
  (no tool columns); with frames, the tool columns, the fast writer equal
  to the row-by-row reference byte for byte;
* the pivot: the wanted platform path keeps the tip still (1e-12 m), the
  same rotation about o' moves it 28.0 / 30.5 / 12.0 mm (roll, pitch,
  yaw); the stream filter (sp/motion/stream.h's law, float64) fed the
  play file's targets gives the path back within 1e-9 (fed the path
  itself, its lag moves the tip 0.19 mm); the path stays
  within the controller's stream limits (1 m/s^2, 1 rad/s^2);
* the tilted surface: the target is 2 kN along -n, W's z is -n, the tool
  point at home 2 mm off the surface along it; the scenario line puts the
  plane where the work frame says.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from stewart import config as cfg
from stewart import framesdemo as fd
from stewart.analysis.csvout import write_signals_csv, write_signals_csv_reference
from stewart.analysis.decode import read_log
from stewart.analysis.run import DEFAULT_PLATFORM
from stewart.analysis.toolpose import attach_tool, platform_of_tool, tool_in_work, tool_tracking
from stewart.frames import Frames

DATA = Path(__file__).parent / "data"


def random_frames(rng, n):
    for _ in range(n):
        tool = tuple(rng.uniform(-1, 1, 3)) + tuple(rng.uniform(-3, 3, 3))
        work = tuple(rng.uniform(-2, 2, 3)) + tuple(rng.uniform(-3, 3, 3))
        yield tool, work


def test_tool_in_work_agrees_with_the_core_reference():
    rng = np.random.default_rng(31)
    for tool, work in random_frames(rng, 50):
        poses = np.column_stack([rng.uniform(-0.3, 0.3, (20, 2)), rng.uniform(1.8, 2.8, 20),
                                 rng.uniform(-0.5, 0.5, (20, 3))])
        fr = Frames(tool, work)
        got = tool_in_work(poses, tool, work)
        want = np.array([fr.from_platform(p) for p in poses])
        assert np.abs(got - want).max() < 1e-12
        back = platform_of_tool(got, tool, work)
        assert np.abs(back - poses).max() < 1e-12
        assert np.abs(back - np.array([fr.to_platform(x) for x in got])).max() < 1e-12


def test_bad_frames_are_refused_naming_them():
    with pytest.raises(ValueError, match="tool frame"):
        tool_in_work(np.zeros((1, 6)), (6.0, 0, 0, 0, 0, 0))
    with pytest.raises(ValueError, match="work frame"):
        tool_in_work(np.zeros((1, 6)), work=(0, 0, float("nan"), 0, 0, 0))


@pytest.fixture(scope="module")
def data():
    with gzip.open(DATA / "demo_excerpt.log.gz", "rt") as fh:
        lines = fh.read().splitlines()
    return read_log(lines, platform=cfg.load(DEFAULT_PLATFORM))


def test_signals_csv_tool_columns(data, tmp_path):
    a, b, c = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "c.csv"
    write_signals_csv(data, a)
    attach_tool(data)  # identity: nothing changes
    assert data.tool is None
    write_signals_csv(data, b)
    assert a.read_bytes() == b.read_bytes() and b"tool_" not in a.read_bytes().split(b"\r\n")[0]
    attach_tool(data, fd.TOOL_TIP + (0.0, 0.0, 0.0), (0.1, -0.2, 0.3, 0.0, 0.0, 0.5))
    try:
        write_signals_csv(data, b)
        write_signals_csv_reference(data, c)
        assert b.read_bytes() == c.read_bytes()
        head = b.read_bytes().split(b"\r\n")[0].decode().split(",")
        assert head[-12:] == [f"tool_{g}_{a}" for g in ("ref", "est")
                              for a in ("x", "y", "z", "roll", "pitch", "yaw")]
        # the old columns first, unchanged
        old = a.read_bytes().split(b"\r\n")
        new = b.read_bytes().split(b"\r\n")
        assert all(n.startswith(o) for o, n in zip(old[:50], new[:50]))
        tt = tool_tracking(data)
        assert tt is not None and "est" in tt
    finally:
        data.tool = None


def simulate_stream(targets, x0, omega=fd.STREAM_OMEGA, dt=fd.TICK):
    x, v, out = np.array(x0, dtype=float), np.zeros(len(x0)), []
    for t in targets:
        out.append(x.copy())
        a = omega * omega * (t - x) - 2.0 * omega * v
        v = v + a * dt
        x = x + v * dt
    return np.array(out)


def test_pivot_path_and_the_stream_inverse():
    t, tool = fd.pivot_tool_path()
    poses = fd.platform_of_tool(tool, fd.TOOL_TIP + (0.0, 0.0, 0.0))
    assert np.abs(fd.tip_deviation(poses)).max() < 1e-12
    for k, axis in enumerate(fd.PIVOT_AXES):
        assert np.abs(tool[:, 3 + k]).max() == pytest.approx(fd.PIVOT_AMPLITUDE, rel=1e-3)
    assert [round(fd.about_o_prime_mm(a), 1) for a in fd.PIVOT_AXES] == [28.0, 30.5, 12.0]
    targets = fd.stream_inverse(poses)
    out = simulate_stream(targets, poses[0])
    assert np.abs(out - poses).max() < 1e-9
    acc = np.abs(np.diff(poses, n=2, axis=0)).max(axis=0) / fd.TICK ** 2
    assert acc.max() < 0.9  # the controller's stream limit: 1 m/s^2, 1 rad/s^2 per axis
    # without the inverse the filter's lag alone (each axis late by its own amount) moves the tip 0.19 mm
    lagged = simulate_stream(poses, poses[0])
    assert 1000.0 * np.linalg.norm(fd.tip_deviation(lagged), axis=1).max() > 0.15
    text = fd.pivot_csv(2, ("roll",))
    rows = text.splitlines()
    assert rows[0] == "t,x,y,z,roll,pitch,yaw" and len(rows) == 1 + round((0.5 + 4.0 + 0.5) / fd.TICK) + 1


def test_tilted_surface_geometry():
    n = fd.surface_normal()
    fy, fz = fd.tilted_target()
    assert np.allclose([0.0, fy, fz], -fd.FORCE_N * n)
    w = fd.work_frame()
    home_tool = tool_in_work(np.array([fd.HOME]), fd.tool_frame(), w)[0]
    assert home_tool[:3] == pytest.approx([0.0, 0.0, -fd.GAP], abs=1e-12)
    # the scenario line: 'contact surface down P ROLL 0 T' is the plane {x: n.x = n.P} through W's origin
    words = fd.tilted_surface().split()
    assert words[:3] == ["contact", "surface", "down"]
    p = np.array([float(v) for v in words[3:6]])
    assert np.allclose(p, w[:3], atol=1e-6) and float(words[6]) == pytest.approx(fd.TILT, abs=1e-6)
