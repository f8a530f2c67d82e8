# SPDX-License-Identifier: Apache-2.0
"""The command line is installed and dispatches to its sub-commands."""

import pkgutil
import subprocess
import sys
from pathlib import Path

from stewart import cli, commands

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_help_lists_commands(capsys):
    parser = cli.build_parser()
    parser.print_help()
    out = capsys.readouterr().out
    assert "info" in out


def test_command_modules_follow_the_cmd_naming():
    names = [m.name for m in pkgutil.iter_modules(commands.__path__)]
    assert "info_cmd" in names
    assert [n for n in names if not n.endswith("_cmd")] == []


def test_no_command_is_an_error():
    assert cli.main([]) == 2


def test_info_runs(capsys):
    assert cli.main(["info"]) == 0
    assert str(REPO_ROOT) in capsys.readouterr().out


def test_entry_point_installed():
    exe = REPO_ROOT / ".venv" / "bin" / "stewart"
    assert exe.exists(), "the set-up installs the stewart entry point into .venv"
    out = subprocess.run([str(exe), "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.startswith("stewart ")
    assert sys.version_info >= (3, 11)
