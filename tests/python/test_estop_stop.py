# SPDX-License-Identifier: Apache-2.0
"""ESTOP's stop categories in the lockstep closed loop (docs/reference/safety.md):
the controller and the simulated hexapod in one process (``hs_sim
--inproc``), engaged, the paper's surge (90 mm at 0.5 Hz, 0.5 s fades),
ESTOP one period in, where the platform moves at its peak 0.283 m/s.

Category 1 (the default, the config's estop section): the drives
decelerate the platform along the surge's path, hold it 30 ms, then
close the blocking valves. Asserted: STOPPING then ESTOP; at rest
(true speed below 1 % of the speed at the ESTOP, 2.8 mm/s and
2.8 mrad/s) within 0.3 s; after the valves closed, at most 1 mm peak to
peak on every axis over the 2 s observed (the pistons' leakage creep
included); every leg inside its stroke and every measured cylinder
force within force_max all along.
Measured (host-release): at rest 0.222 s after the ESTOP (below 1 mm/s
from 0.301 s), valves closed 0.305 s after, 0.19 mm peak to peak after
(0.03 mm in the first 250 ms), legs 2.05-2.58 m, forces up to 11 kN (42 kN
with category 0).

Category 0 (``--estop-category 0``): the valves close at once, as
before: 8.4 mm peak to peak, at rest 1.79 s after. Asserted as today's
figures (within 1 mm of 8.5 mm, closed within 25 ticks).
Two runs of 2.8 s simulated, about 4 s of wall time each. Needs the
host-release build."""

from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

from stewart import auth
from stewart import config as cfg
from stewart import resources
from stewart.closedloop import Binaries

SCENARIO = ("delay 0.2\ncmd ENGAGE\nwait ready 30\ndelay 0.1\n"
            "cmd RUN_TRIG axis=x amplitude=0.09 frequency=0.5 fade=0.5\n"
            "delay 2.0\nmark estop\ncmd ESTOP\ndelay 2.5\nend\n")
REST_S = 0.3
RINGING_MM = 1.0


def _bins() -> Binaries | None:
    try:
        return Binaries.find()
    except FileNotFoundError:
        return None


pytestmark = pytest.mark.skipif(_bins() is None, reason="needs build/host-release (scripts/build.sh host-release)")


def _run(tmp_path, category: int) -> tuple[dict, str]:
    scn = tmp_path / "estop.scenario"
    scn.write_text(SCENARIO)
    truth = tmp_path / f"truth{category}.csv"
    p = subprocess.run([str(_bins().plant), "--inproc", "--estop-category", str(category), "--scenario", str(scn),
                        "--truth", str(truth), "--key", str(auth.run_key(tmp_path))],
                       capture_output=True, text=True, timeout=300)
    print(p.stdout, p.stderr)
    assert p.returncode == 0, p.stderr
    est = int(re.search(r"hs_sim mark tick (\d+): estop", p.stdout).group(1))
    d = np.genfromtxt(truth, delimiter=",", names=True)
    t = d["tick"]
    pos = np.stack([d[k] for k in ("x", "y", "z")], axis=1)
    rot = np.stack([d[k] for k in ("roll", "pitch", "yaw")], axis=1)
    block = np.stack([d[f"block{i}"] for i in range(1, 7)], axis=1)
    speed = np.linalg.norm(np.gradient(pos, axis=0), axis=1) * 1000.0  # m/s (1 ms rows)
    spin = np.linalg.norm(np.gradient(rot, axis=0), axis=1) * 1000.0
    after = t >= est
    closed = t[np.argmax(after & (block.max(axis=1) == 0.0))]
    v0 = speed[np.searchsorted(t, est)]
    thr = 0.01 * v0
    moving = np.where(after & ((speed > thr) | (spin > thr)))[0]
    slow = np.where(after & ((speed > 1e-3) | (spin > 1e-3)))[0]
    c = t >= closed
    first = c & (t < closed + 250)
    lengths = np.stack([d[f"len{i}"] for i in range(1, 7)], axis=1)
    forces = np.stack([d[f"force{i}"] for i in range(1, 7)], axis=1)
    return {
        "v0": v0,
        "rest_s": (t[moving[-1]] - est + 1) / 1000.0,
        "below_1mm_s": (t[slow[-1]] - est + 1) / 1000.0,
        "closed_ticks": closed - est,
        "p2p_mm": max(np.ptp(pos[c, k]) for k in range(3)) * 1e3,
        "p2p_mrad": max(np.ptp(rot[c, k]) for k in range(3)) * 1e3,
        "p2p_first_mm": np.ptp(pos[first, 0]) * 1e3,
        "len": (lengths.min(), lengths.max()),
        "force": np.abs(forces).max(),
    }, p.stdout


def _limits(fig):
    p = cfg.load(resources.default_platform())
    assert p.leg_length_min <= fig["len"][0] and fig["len"][1] <= p.leg_length_max
    assert fig["force"] <= p.force_max


def test_category1_stops_along_the_path_then_blocks(tmp_path):
    fig, out = _run(tmp_path, 1)
    print("category 1:", fig)
    assert "hs_sim controller: last state estop, faults 0x0040" in out
    assert fig["v0"] > 0.27
    assert fig["rest_s"] <= REST_S
    assert 200 < fig["closed_ticks"] <= 350  # decelerated and held first, then closed
    assert fig["p2p_mm"] <= RINGING_MM and fig["p2p_mrad"] <= RINGING_MM
    _limits(fig)


def test_category0_blocks_at_once_as_before(tmp_path):
    fig, out = _run(tmp_path, 0)
    print("category 0:", fig)
    assert "hs_sim controller: last state estop, faults 0x0040" in out
    assert 0 < fig["closed_ticks"] <= 25
    assert 7.5 <= fig["p2p_first_mm"] <= 9.5  # the oil columns ring: 8.5 mm before this change
    assert fig["rest_s"] > 1.0
    _limits(fig)
