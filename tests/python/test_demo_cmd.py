# SPDX-License-Identifier: Apache-2.0
"""``stewart demo``'s runs per drive protocol (the runs themselves are the
demo's and the bus tests'): which lockstep runs each switch asks for."""

from __future__ import annotations

import argparse
from pathlib import Path
from types import SimpleNamespace

from stewart import closedloop as cl
from stewart.commands import demo_cmd


def _specs(monkeypatch, tmp_path, *flags):
    seen = []

    def fake_run(specs, out, **kw):
        seen.extend(specs)
        return [SimpleNamespace(spec=s, ok=True, plant_rc=0, log=Path(out) / "absent.log") for s in specs]

    monkeypatch.setattr(cl.Binaries, "find", classmethod(lambda cls, build=None: None))
    monkeypatch.setattr(cl, "run", fake_run)
    p = argparse.ArgumentParser()
    demo_cmd.register(p.add_subparsers(dest="cmd"))
    args = p.parse_args(["demo", "--out", str(tmp_path), *flags])
    rc = demo_cmd.run(args)
    return rc, {s.name: s for s in seen}


def test_cia402_demo_runs_cia402_drives_against_native(monkeypatch, tmp_path):
    rc, specs = _specs(monkeypatch, tmp_path, "--cia402")
    assert rc == 1  # the fake runs wrote no log
    assert sorted(specs) == ["main", "main_repeat", "native"]
    for name in ("main", "main_repeat"):
        assert specs[name].cia402 and specs[name].canopen_sync_divider == 2 and specs[name].canopen_force_ff  # 0x60B2, 41 %
        assert specs[name].scenario.startswith("delay 0.2\n")  # ENGAGE after the start-up by SDO
    native = specs["native"]
    assert not (native.cia402 or native.canopen) and native.feedforward
    assert native.scenario == specs["main"].scenario.removeprefix("delay 0.2\n")


def test_cia408_demo_unchanged(monkeypatch, tmp_path):
    rc, specs = _specs(monkeypatch, tmp_path, "--cia408")
    assert sorted(specs) == ["ff_off", "main", "main_repeat"]
    assert specs["main"].canopen and specs["main"].canopen_force_ff and not specs["main"].cia402
    assert specs["ff_off"].canopen and not specs["ff_off"].canopen_force_ff


def test_cia408_and_cia402_together_refused(monkeypatch, tmp_path, capsys):
    rc, specs = _specs(monkeypatch, tmp_path, "--cia408", "--cia402")
    assert rc == 2 and not specs
    assert "--cia408 or --cia402, not both" in capsys.readouterr().err
