# SPDX-License-Identifier: Apache-2.0
"""`hs_sim --control FILE`: scenario lines given while the plant runs (what
`stewart sim inject` writes), one request a line, each answered on stdout.
Run with the controller in-process (--inproc: no bus needed, deterministic
ticks) from a regular file, read once. Well under a second."""

from __future__ import annotations

import re
import subprocess

import pytest

from stewart import closedloop as cl


@pytest.fixture(scope="module")
def plant():
    try:
        return cl.Binaries.find().plant
    except FileNotFoundError as e:
        pytest.skip(str(e))


def _run(plant, tmp_path, lines: list[str], ticks: int = 200):
    control = tmp_path / "control"
    control.write_text("".join(line + "\n" for line in lines))
    r = subprocess.run([str(plant), "--inproc", "--ticks", str(ticks), "--control", str(control)],
                       capture_output=True, text=True, timeout=60)
    answers = re.findall(r"^hs_sim control: (accepted|refused|failed): (.*)$", r.stdout, re.M)
    marks = dict((text, int(tick)) for tick, text in re.findall(r"^hs_sim mark tick (\d+): (.*)$", r.stdout, re.M))
    return r, answers, marks


def test_each_line_is_answered_in_order_and_played_when_due(plant, tmp_path):
    r, answers, marks = _run(plant, tmp_path, [
        "wrench 0 0 100 0 0 0", "bogus", "mark first", "delay 0.05", "mark later", "x" * 600,
        "inject drive 2 fault 2", "load 1e9 0 0 0", "", "# only a comment"])
    assert r.returncode == 0, r.stderr
    kinds = [k for k, _ in answers]
    assert kinds == ["accepted", "refused", "accepted", "accepted", "accepted", "refused", "accepted",
                     "refused", "refused", "refused"], answers
    assert answers[1][1].startswith("control:1: unknown action 'bogus'")
    assert answers[5][1] == "a line longer than 510 characters"
    assert "out of range" in answers[7][1]
    assert marks["first"] == 0 and marks["later"] == 50  # the delay held the next line back 50 ticks
    assert "2:fault/0x02" in r.stdout  # the injected drive fault reached the plant


def test_a_refused_action_leaves_the_run_going(plant, tmp_path):
    r, answers, marks = _run(plant, tmp_path, ["load -99999 0 0 0", "mark after"], ticks=20)
    assert r.returncode == 0
    assert answers[0] == ("refused", "load -99999 0 0 0: the plant refused it (stderr says why)")
    assert "rigid body" in r.stderr
    assert answers[1] == ("accepted", "mark after") and marks["after"] == 0


def test_a_missing_control_file_is_a_set_up_error(plant, tmp_path):
    r = subprocess.run([str(plant), "--inproc", "--ticks", "5", "--control", str(tmp_path / "none")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "cannot open --control" in r.stderr
