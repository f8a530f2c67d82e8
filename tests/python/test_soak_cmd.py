# SPDX-License-Identifier: Apache-2.0
"""``stewart soak`` (tools/stewart/commands/soak_cmd.py) over ``hs_soak``:
the summary's figures parsed; a short run passes with its checks counted;
a run made to break an invariant (``--break``) fails with exit 1, the
invariant, the seed, the tick and the replay command; the replay command
stops at the same tick. Needs the host-release build (scripts/test.sh
builds it). About 3 s of CPU."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from stewart.commands import soak_cmd

SAMPLE = """hs_soak summary: seed 4, simulated 900.000 s (0.250 h), wall 178.9 s, 5.0x real time, exit 0
hs_soak checks: 900000 ticks x 7 invariants = 6300000 checks, violations 0
hs_soak operator: episodes 176, commands 401, refused 123, forged/replayed/unsigned 6, injections 78, waits timed out 0
hs_soak frames: in 12236584, dropped 2, bus-off 3600
hs_soak known (issue 35, --strict makes them violations): 13 REFERENCE faults while RUNNING an accepted motion
"""


def test_parse_summary():
    f = soak_cmd.parse_summary(SAMPLE)
    assert f["simulated_s"] == 900.0 and f["wall_s"] == 178.9 and f["speedup"] == 5.0 and f["exit"] == 0
    assert f["checks"] == 6300000 and f["violations"] == 0 and f["episodes"] == 176
    assert f["commands"] == 401 and f["refused"] == 123 and f["injections"] == 78
    assert f["frames"] == 12236584 and f["known"] == 13
    assert soak_cmd.parse_summary("nothing here") == {}


def _built() -> bool:
    try:
        soak_cmd.soak_binary(None)
    except FileNotFoundError:
        return False
    return True


needs_build = pytest.mark.skipif(not _built(), reason="needs build/host-release (scripts/build.sh host-release)")


def _stewart(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stewart.cli", "soak", "--quiet", *args], capture_output=True,
                          text=True, timeout=600)


@needs_build
def test_short_soak_passes(tmp_path):
    p = _stewart("--minutes", "0.1", "--seed", "5", "--json", str(tmp_path / "f.json"))
    assert p.returncode == 0, p.stdout + p.stderr
    f = json.loads((tmp_path / "f.json").read_text())
    assert f["simulated_s"] == pytest.approx(6.0) and f["violations"] == 0
    assert f["checks"] == 6000 * 7  # every tick, every invariant
    assert f["frames"] > 6000 * 10  # feedback, SYNC, sensor, setpoints, status ... every tick


@needs_build
def test_a_broken_invariant_fails_with_its_replay():
    p = _stewart("--minutes", "0.1", "--seed", "5", "--break", "frames@1234")
    assert p.returncode == 1, p.stdout + p.stderr
    assert "VIOLATION frames at tick 1234 (1.234 s simulated), seed 5: 1 frames unaccounted for" in p.stderr
    assert "replay: hs_soak --seed 5 --ticks 1235 --trace" in p.stderr
    assert "violations 1" in p.stdout
    # the replay (with the same break) stops at the same tick
    replay = [str(soak_cmd.soak_binary(None)), "--seed", "5", "--ticks", "1235", "--break", "frames@1234"]
    r = subprocess.run(replay, capture_output=True, text=True, timeout=600)
    assert r.returncode == 1 and "VIOLATION frames at tick 1234" in r.stderr
