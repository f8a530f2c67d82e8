# SPDX-License-Identifier: Apache-2.0
"""Which vcan back end ``stewart vcan`` picks, over recorded probe outcomes:
a UML kernel that panics on a CPU with AMX (bookworm's 6.1, log recorded on
such a host), one that boots (Debian sid's 7.2), one whose vcan module does
not load, a missing binary, a boot that times out. No UML is booted here:
the boots are replayed from tests/python/data/uml."""

import os
import sys
from pathlib import Path

import pytest

from stewart import uml, vcan

DATA = Path(__file__).parent / "data" / "uml"
PANIC = (DATA / "panic_amx_6.1.log").read_text()
BOOTS = (DATA / "boot_ok_7.2.log").read_text()
NO_VCAN = (DATA / "no_vcan_7.2.log").read_text()
NO_VCAN_STATE = (DATA / "no_vcan_7.2.status").read_text().split()


# ---------------------------------------------------------------- verdicts


def test_panic_on_amx_is_told_from_other_failures():
    verdict, reason = uml.classify([], PANIC, True, 134)
    assert verdict == uml.PANICS
    assert "ptrace set fp regs failed" in reason


def test_a_working_boot():
    assert uml.classify(["rc", "0"], BOOTS, True, 0) == (uml.OK, "boots and brings up vcan")


def test_missing_vcan_module():
    verdict, reason = uml.classify(NO_VCAN_STATE, NO_VCAN, True, 125)
    assert verdict == uml.NO_VCAN
    assert "vcan" in reason


def test_time_out_and_silent_death():
    assert uml.classify([], "", False, 124)[0] == uml.FAILED
    verdict, reason = uml.classify([], "some line\nlast words\n", True, 1)
    assert verdict == uml.FAILED and "last words" in reason and "exit status 1" in reason


def test_cpu_flags():
    info = "processor\t: 0\nvendor_id\t: GenuineIntel\nflags\t\t: fpu sse amx_bf16 amx_tile\n\n"
    assert uml.cpu_has_amx(info)
    assert not uml.cpu_has_amx(info.replace(" amx_tile", ""))
    assert uml.cpu_signature(info) != uml.cpu_signature(info.replace(" amx_tile", ""))
    # only the first CPU counts: the rest repeat it
    assert uml.cpu_signature(info) == uml.cpu_signature(info + "processor\t: 1\nflags\t: x\n")


# ------------------------------------------------------------- the choice


def fake_kernel(tmp_path: Path, kind: str, binary: bool = True, module: bool = True) -> uml.Kernel:
    root = tmp_path / kind
    modules = root / "modules"
    if module:
        (modules / "9.9.9" / "kernel" / "drivers/net/can").mkdir(parents=True)
        (modules / "9.9.9" / "kernel" / "drivers/net/can" / "vcan.ko").write_bytes(b"")
    exe = root / "linux.uml"
    if binary:
        exe.parent.mkdir(parents=True, exist_ok=True)
        exe.write_text("#!/bin/sh\nexit 1\n")
        exe.chmod(0o755)
    return uml.Kernel(kind, exe, modules, f"the {kind} kernel")


class Boots:
    """A stand-in for booting: replays a recorded outcome per kernel kind."""

    def __init__(self, outcomes: dict):
        self.outcomes = outcomes
        self.calls: list[str] = []

    def __call__(self, k: uml.Kernel) -> uml.Probe:
        self.calls.append(k.kind)
        state, log, ended = self.outcomes[k.kind]
        verdict, reason = uml.classify(state, log, ended, 0)
        return uml.Probe(verdict, reason, "7.2.7" if verdict == uml.OK else "", "", 1.0)


@pytest.fixture
def host(monkeypatch, tmp_path):
    """No host vcan, a private probe cache, and two fake kernels."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("STEWART_UML", raising=False)
    monkeypatch.setattr(vcan, "_host_problem", lambda count: "the host cannot create vcan")
    kernels = {"system": fake_kernel(tmp_path, "system"), "cache": fake_kernel(tmp_path, "cache")}
    monkeypatch.setattr(uml, "kernel", lambda kind: kernels[kind])
    return kernels


PANICS = ([], PANIC, True)
WORKS = (["rc", "0"], BOOTS, True)


def test_host_vcan_comes_first(host, monkeypatch):
    monkeypatch.setattr(vcan, "_host_problem", lambda count: None)
    boots = Boots({"system": PANICS, "cache": WORKS})
    assert vcan.choose(boot=boots).backend == "host"
    assert boots.calls == []


def test_amx_host_uses_the_cached_kernel(host):
    boots = Boots({"system": PANICS, "cache": WORKS})
    c = vcan.choose(boot=boots)
    assert (c.backend, c.kernel.kind, c.cached) == ("uml", "cache", False)
    assert boots.calls == ["system", "cache"]
    assert any("ptrace set fp regs failed" in t for t in c.tried)
    text = "\n".join(c.describe())
    assert "7.2.7" in text and "the cache kernel" in text and "why not" in text


def test_a_booting_system_kernel_is_kept(host):
    boots = Boots({"system": WORKS, "cache": PANICS})
    c = vcan.choose(boot=boots)
    assert c.kernel.kind == "system" and boots.calls == ["system"]


def test_forcing_the_cached_kernel(host, monkeypatch):
    boots = Boots({"system": WORKS, "cache": WORKS})
    monkeypatch.setenv("STEWART_UML", "cache")
    assert vcan.choose(boot=boots).kernel.kind == "cache"
    assert vcan.choose(boot=boots, uml_kernel="system").kernel.kind == "system"
    monkeypatch.setenv("STEWART_UML", "newest")
    with pytest.raises(vcan.VcanError, match="STEWART_UML"):
        vcan.choose(boot=boots)


def test_nothing_works_one_paragraph(host, tmp_path, monkeypatch):
    kernels = {"system": fake_kernel(tmp_path / "s", "system", module=False),
               "cache": fake_kernel(tmp_path / "c", "cache", binary=False)}
    monkeypatch.setattr(uml, "kernel", lambda kind: kernels[kind])
    with pytest.raises(vcan.VcanError) as e:
        vcan.choose(boot=Boots({}))
    text = str(e.value)
    lines = text.splitlines()
    assert lines[0].startswith("no virtual CAN bus can be set up")
    assert len(lines) == 5, text  # the headline, three things tried, what to do
    assert "host" in lines[1] and "no vcan module" in lines[2] and "not there" in lines[3]
    assert "scripts/setup.sh" in lines[4] and "modprobe vcan" in lines[4]


def test_panic_verdict_names_its_log_not_its_stack(host, monkeypatch):
    boots = Boots({"system": PANICS, "cache": (NO_VCAN_STATE, NO_VCAN, True)})
    with pytest.raises(vcan.VcanError) as e:
        vcan.choose(boot=boots)
    assert "Call Trace" not in str(e.value)
    assert "panics as init starts" in str(e.value) and "cannot load the CAN modules" in str(e.value)


# ---------------------------------------------------------- the probe cache


def test_verdicts_are_cached_and_invalidated(host, monkeypatch):
    boots = Boots({"system": PANICS, "cache": WORKS})
    assert vcan.choose(boot=boots).cached is False
    assert len(boots.calls) == 2
    c = vcan.choose(boot=boots)
    assert c.cached is True and len(boots.calls) == 2  # no boot at all
    # a new kernel binary (an upgrade): probed again
    exe = host["system"].binary
    st = exe.stat()
    os.utime(exe, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    vcan.choose(boot=boots)
    assert boots.calls[2:] == ["system"]
    # another CPU: probed again
    monkeypatch.setattr(uml, "cpu_signature", lambda cpuinfo=None: "another-cpu")
    vcan.choose(boot=boots)
    assert boots.calls[3:] == ["system", "cache"]


def test_a_time_out_is_not_cached(host):
    boots = Boots({"system": ([], "", False), "cache": WORKS})
    vcan.choose(boot=boots)
    vcan.choose(boot=boots)
    assert boots.calls == ["system", "cache", "system"]


# ---------------------------------------------------- a UML that dies mid-run


def test_a_dying_uml_is_one_line_and_a_log_file(tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    k = fake_kernel(tmp_path, "cache")
    k.binary.write_text("#!/bin/sh\ncat " + str(DATA / "panic_amx_6.1.log") + "\nexit 134\n")
    rc = vcan._run_uml(["true"], 1, True, 30.0, dict(os.environ), 256 << 20, False, k)
    assert rc == vcan.EXIT_SETUP
    err = capfd.readouterr().err
    assert err.count("\n") == 1, err
    assert "ptrace set fp regs failed" in err
    path = Path(err.rsplit("kernel log in ", 1)[1].strip())
    assert "Call Trace" in path.read_text()


def test_cli_check_names_back_end_kernel_and_origin():
    # the real choice on this host (booting a kernel at most once: cached)
    import subprocess
    r = subprocess.run([sys.executable, "-m", "stewart.cli", "vcan", "--check"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    first = r.stdout.splitlines()[0]
    assert first.startswith("back end: host") or first.startswith("back end: uml")
    assert "kernel: Linux " in r.stdout


# ---------------------------------------------------------------- one host CPU


def test_uml_is_held_to_a_core_another_uml_does_not_hold(monkeypatch):
    monkeypatch.delenv(vcan.PIN_ENV, raising=False)
    monkeypatch.setattr(vcan.os, "sched_getaffinity", lambda pid: {0, 1, 2, 3})
    monkeypatch.setattr(vcan, "_uml_cpus", lambda: [])
    assert vcan.pin_cpu() == 3  # the last allowed
    monkeypatch.setattr(vcan, "_uml_cpus", lambda: [3, 3, 3, 2])
    assert vcan.pin_cpu() == 1  # the bus tests' UML on 3, a sim's on 2
    monkeypatch.setattr(vcan, "_uml_cpus", lambda: [0, 1, 2, 3, 3])
    assert vcan.pin_cpu() == 2  # all taken: the least taken, the last first
    monkeypatch.setattr(vcan.os, "sched_getaffinity", lambda pid: {5})
    assert vcan.pin_cpu() is None  # one core: nothing to choose


def test_uml_core_from_the_environment(monkeypatch):
    monkeypatch.setattr(vcan.os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setenv(vcan.PIN_ENV, "none")
    assert vcan.pin_cpu() is None and vcan.pin_prefix() == []
    monkeypatch.setenv(vcan.PIN_ENV, "0")
    assert vcan.pin_cpu() == 0
    for bad in ("7", "first"):
        monkeypatch.setenv(vcan.PIN_ENV, bad)
        with pytest.raises(vcan.VcanError, match=vcan.PIN_ENV):
            vcan.pin_cpu()
