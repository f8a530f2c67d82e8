# SPDX-License-Identifier: Apache-2.0
"""The installable toolset: the wheel that ``pip`` builds from tools/ (its
own build makes the core library and copies the DBC and the default config
in), installed into a fresh venv, works outside the checkout: ``stewart
--version`` says tools/pyproject.toml's version, ``stewart calc`` on the
default config gives, byte for byte, what the checkout's tools give, and
the developer tools (tools/dev) are not in it. About 40 s (building the
wheel, then installing it and its pinned dependencies from pip's cache)."""

import csv
import subprocess
import sys
import tomllib
from pathlib import Path

from stewart import cli
from stewart import config as cfg

REPO_ROOT = Path(__file__).resolve().parents[2]


def _run(args, cwd, **kw):
    r = subprocess.run([str(a) for a in args], cwd=cwd, capture_output=True, text=True, **kw)
    assert r.returncode == 0, f"{args}: exit {r.returncode}\n{r.stdout}\n{r.stderr}"
    return r.stdout


def _poses(path: Path) -> None:
    home = cfg.load(REPO_ROOT / "config" / "platform_default.json").home
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "x", "y", "z", "roll", "pitch", "yaw", "vz", "az"])
        w.writerow([0.0, *home, 0.0, 0.0])
        w.writerow([0.5, home[0] + 0.05, home[1] - 0.03, home[2] + 0.02, 0.04, -0.03, 0.08, 0.1, 1.5])


def test_wheel_installs_and_runs_outside_the_checkout(tmp_path):
    wheels, outside = tmp_path / "wheels", tmp_path / "elsewhere"
    outside.mkdir()
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    _run(pip + ["wheel", "-q", "--no-deps", "-w", wheels, REPO_ROOT / "tools"], cwd=outside)
    (wheel,) = wheels.glob("stewart-*.whl")
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", venv], cwd=outside)
    _run([venv / "bin" / "pip", "install", "-q", "--disable-pip-version-check", wheel], cwd=outside)
    stewart = venv / "bin" / "stewart"

    version = tomllib.loads((REPO_ROOT / "tools" / "pyproject.toml").read_text())["project"]["version"]
    assert _run([stewart, "--version"], cwd=outside).strip() == f"stewart {version}"

    # the package's own files, no checkout
    where = _run([venv / "bin" / "python", "-c",
                  "import importlib.util as u, stewart.resources as r; "
                  "print(r.checkout(), r.core_library(), r.dbc_path(), r.default_platform(), sep='\\n'); "
                  "print(*(u.find_spec('stewart.' + m) for m in "
                  "('gen_platform', 'gen_can_c', 'testkey', 'analysis.decode_reference')))"],
                 cwd=outside).splitlines()
    site = str(venv / "lib")
    assert where[0] == "None"
    assert all(line.startswith(site) for line in where[1:4]), where
    assert where[4] == "None None None None"

    _poses(outside / "poses.csv")
    _run([stewart, "calc", "--input", "poses.csv", "--output", "installed.csv"], cwd=outside)
    assert cli.main(["calc", "--input", str(outside / "poses.csv"), "--output", str(outside / "checkout.csv")]) == 0
    installed = (outside / "installed.csv").read_text()
    assert installed == (outside / "checkout.csv").read_text()
    rows = list(csv.DictReader(installed.splitlines()))
    assert len(rows) == 2 and all(r["status"] == "ok" for r in rows), rows
