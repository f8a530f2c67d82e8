# SPDX-License-Identifier: Apache-2.0
"""The commands that run for more than 2 s show their progress on stderr
(results alone on stdout), and --quiet silences it."""

import io

from stewart import cli
from stewart.progress import Progress


def test_accuracy_shows_progress_unless_quiet(capsys):
    assert cli.main(["accuracy", "-n", "50"]) == 0
    out, err = capsys.readouterr()
    assert "random motions 0/50" in err and "random motions 50/50" in err
    assert "leg length" in out and "random motions" not in out
    assert cli.main(["accuracy", "-n", "50", "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert err == "" and "leg length" in out


def test_the_long_commands_take_quiet():
    commands = cli.build_parser()._subparsers._group_actions[0].choices
    for name in ("accuracy", "faults", "analyze", "demo", "paper", "identify"):
        assert "--quiet" in commands[name]._option_string_actions and "-q" in commands[name]._option_string_actions


def test_a_line_per_step_or_a_bar_on_a_terminal():
    lines = io.StringIO()
    p = Progress("stewart x", "runs", 3, every=0.0, stream=lines)
    for name in ("a", "b", "c"):
        p.advance(note=name)
    assert [line.split(" (")[0] for line in lines.getvalue().splitlines()] == [
        "stewart x: runs 0/3", "stewart x: runs 1/3", "stewart x: runs 2/3", "stewart x: runs 3/3"]

    class Tty(io.StringIO):
        def isatty(self):
            return True

    bar = Tty()
    p = Progress("stewart x", "runs", 2, every=0.0, stream=bar)
    p.advance()
    p.advance()
    text = bar.getvalue()
    assert text.count("\r") == 3 and text.endswith("\n") and "[####################] stewart x: runs 2/2" in text


def test_paper_figures_counted_on_stderr(tmp_path, capsys):
    assert cli.main(["paper", "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert "figures 0/2" in err and "figures 2/2" in err
    assert out.count("core vs float64") == 2 and "figures 2/2" not in out
