# SPDX-License-Identifier: Apache-2.0
"""``stewart vcan``: a command runs with vcan buses up (here: inside a
user-mode Linux, as this machine's kernel has no CAN), gets its arguments,
environment and working directory intact, passes its output and exit status
through, and is killed at the time limit with nothing left running."""

import json
import os
import pty
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from stewart import vcan

CLI = [sys.executable, "-m", "stewart.cli", "vcan"]
#: Wall-clock bound for one run of a short command (s): a UML boots in ~2.5 s.
RUN_LIMIT = 120
PID_LINE = re.compile(r"stewart vcan: (?:uml: linux\.uml|host: command) pid (\d+)")


def stewart_vcan(*args, cwd=None, env=None, timeout=RUN_LIMIT):
    return subprocess.run([*CLI, *args], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=timeout, stdin=subprocess.DEVNULL)


def group_members(pgid: int) -> list[str]:
    """Processes (any state, zombies included) in process group ``pgid``."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        fields = text[text.rindex(")") + 2:].split()
        # fields: state, ppid, pgrp, session, ...
        if int(fields[2]) == pgid or int(stat.parent.name) == pgid:
            found.append(f"{stat.parent.name} {text[:text.rindex(')') + 1]} {fields[0]}")
    return found


def test_backend_is_available():
    assert vcan.backend_available() in ("host", "uml")


def test_exit_status_and_output_pass_through():
    r = stewart_vcan("--", "sh", "-c", "echo out-line; echo err-line >&2; printf tail; exit 7")
    assert r.returncode == 7, r.stderr
    assert r.stdout == "out-line\ntail"
    assert r.stderr == "err-line\n"


def test_arguments_environment_and_cwd_intact(tmp_path):
    odd = ["it's a \"test\"", "$HOME `id` $(id)", "", "*", "two\nlines", "-v", "--", "tab\there"]
    work = tmp_path / "dir with 'space'"
    work.mkdir()
    env = dict(os.environ, STEWART_PROBE="x 'y' \"z\" $w", PYTHONPATH="/nowhere/a b")
    script = ("import json, os, sys; print(json.dumps({'argv': sys.argv[1:], 'cwd': os.getcwd(), "
              "'probe': os.environ.get('STEWART_PROBE'), 'pp': os.environ.get('PYTHONPATH'), "
              "'home': os.environ.get('HOME'), 'path': os.environ.get('PATH'), "
              "'tty': sys.stdout.isatty()}))")
    r = stewart_vcan("--", sys.executable, "-c", script, *odd, cwd=work, env=env)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert got["argv"] == odd
    assert got["cwd"] == str(work)
    assert got["probe"] == env["STEWART_PROBE"]
    assert got["pp"] == env["PYTHONPATH"]
    assert got["home"] == os.environ.get("HOME")
    assert got["path"] == os.environ.get("PATH")
    # Our stdout is a pipe, so the command's is not a terminal either.
    assert got["tty"] is False


def test_stdout_is_a_terminal_when_ours_is():
    master, slave = pty.openpty()
    try:
        p = subprocess.Popen([*CLI, "--", "sh", "-c", "[ -t 1 ] && echo IS-TTY || echo NO-TTY"],
                             stdout=slave, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
        os.close(slave)
        out = b""
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # EIO: the last writer closed the terminal
                break
            if not chunk:
                break
            out += chunk
        assert p.wait(timeout=RUN_LIMIT) == 0, p.stderr.read()
        p.stderr.close()
    finally:
        os.close(master)
    assert b"IS-TTY" in out


def test_fd_buses_are_up_with_mtu_72():
    r = stewart_vcan("--fd", "--", "sh", "-c",
                     "ip -details link show vcan0; echo MTU $(cat /sys/class/net/vcan*/mtu); "
                     "echo LO $(cat /sys/class/net/lo/flags); "
                     "echo SHM $(awk '$2 == \"/dev/shm\" {print $3}' /proc/mounts); "
                     "echo NET $(ls /sys/class/net)")
    assert r.returncode == 0, r.stderr
    assert re.search(r"vcan0: <[^>]*\bUP\b[^>]*> mtu 72\b", r.stdout), r.stdout
    assert "link/can" in r.stdout
    assert "\nMTU 72 72 72\n" in r.stdout
    assert "\nLO 0x9\n" in r.stdout  # IFF_LOOPBACK | IFF_UP: the loopback is up
    assert "\nSHM tmpfs\n" in r.stdout or vcan.backend_available() == "host"
    assert r.stdout.endswith("\nNET lo vcan0 vcan1 vcan2\n")


def test_classic_buses_and_count():
    r = stewart_vcan("--count", "2", "--", "sh", "-c",
                     "cat /sys/class/net/vcan0/mtu /sys/class/net/vcan1/mtu; "
                     "test -e /sys/class/net/vcan2 && echo vcan2-exists; exit 0")
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["16", "16"]


def test_fd_frame_with_brs_seen_by_candump():
    data = "".join(f"{(7 * i + 3) & 0xFF:02X}" for i in range(64))
    script = (f"candump -x -n 1 vcan0 & pid=$!; i=0; "
              f"while kill -0 $pid 2>/dev/null && [ $i -lt 100 ]; do "
              f"cansend vcan0 123##1{data}; i=$((i+1)); sleep 0.2; done; wait $pid")
    r = stewart_vcan("--fd", "--", "sh", "-c", script)
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stdout.splitlines() if "vcan0" in ln]
    assert len(lines) == 1, r.stdout
    fields = lines[0].split()
    # vcan0 TX B - 123 [64] 03 0A ...: 'B' is the bit rate switch flag.
    assert fields[:6] == ["vcan0", "TX", "B", "-", "123", "[64]"], lines[0]
    assert "".join(fields[6:]) == data


def test_command_not_found_is_127():
    r = stewart_vcan("--", "no-such-command-xyz")
    assert r.returncode == 127
    assert "no-such-command-xyz" in r.stderr


def test_time_limit_kills_everything():
    t0 = time.monotonic()
    r = stewart_vcan("-v", "--timeout", "5", "--", "sleep", "100")
    elapsed = time.monotonic() - t0
    assert r.returncode == vcan.EXIT_TIMEOUT, r.stderr
    assert elapsed < 30, f"took {elapsed:.1f} s with a 5 s limit"
    assert "time limit" in r.stderr
    m = PID_LINE.search(r.stderr)
    assert m, r.stderr
    assert group_members(int(m.group(1))) == []


def test_sigterm_cleans_up():
    p = subprocess.Popen([*CLI, "-v", "--", "sleep", "100"], stdin=subprocess.DEVNULL,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        m = None
        for _ in range(20):  # -v first says which back end and kernel, then the pid
            m = PID_LINE.search(p.stderr.readline())
            if m:
                break
        assert m, "no pid line"
        pgid = int(m.group(1))
        time.sleep(3.0)  # let the UML boot and the command start
        assert group_members(pgid), "the UML (or the command) should be running"
        p.send_signal(signal.SIGTERM)
        assert p.wait(timeout=30) == 128 + signal.SIGTERM
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
        p.stderr.close()
    assert group_members(pgid) == []


def test_missing_uml_is_reported(tmp_path):
    # no linux.uml on this PATH, and only the system's kernel is asked for
    env = dict(os.environ, PATH=str(tmp_path), STEWART_UML="system")
    r = stewart_vcan("--uml", "--", "true", env=env)
    assert r.returncode == vcan.EXIT_SETUP
    assert "linux.uml is not installed" in r.stderr
    assert "user-mode-linux" in r.stderr


def test_host_backend_creates_and_deletes_interfaces(tmp_path):
    if Path("/sys/class/net/vcan0").exists():
        pytest.skip("this host has vcan0 already: the create/delete path is not taken")
    log = tmp_path / "ip.log"
    fake = tmp_path / "bin" / "ip"
    fake.parent.mkdir()
    fake.write_text(f'#!/bin/sh\necho "$*" >> {log}\nexit 0\n')
    fake.chmod(0o755)
    env = dict(os.environ, PATH=f"{fake.parent}:{os.environ['PATH']}")
    r = stewart_vcan("--host", "--fd", "--count", "2", "--", "sh", "-c",
                     'echo "backend=$STEWART_VCAN"; exit 3', env=env)
    assert r.returncode == 3, r.stderr
    assert r.stdout == "backend=host\n"
    calls = log.read_text().splitlines()
    assert calls == [
        "link add dev vcan0 type vcan", "link set dev vcan0 mtu 72", "link set dev vcan0 up",
        "link add dev vcan1 type vcan", "link set dev vcan1 mtu 72", "link set dev vcan1 up",
        "link del dev vcan0", "link del dev vcan1",
    ]


def test_host_backend_refused_without_vcan():
    if vcan.host_has_vcan():
        pytest.skip("this host kernel has vcan")
    r = stewart_vcan("--host", "--", "true")
    assert r.returncode == vcan.EXIT_SETUP
    assert "vcan0" in r.stderr


def test_bad_arguments():
    assert stewart_vcan("--").returncode == 2
    with pytest.raises(vcan.VcanError):
        vcan.run(["true"], count=0)
    with pytest.raises(vcan.VcanError):
        vcan.run(["true"], mem="lots")
    assert vcan.parse_mem("512M") == 512 << 20


def test_python_api_in_process(capsys):
    rc = vcan.run(["sh", "-c", "echo api $(cat /sys/class/net/vcan1/mtu); echo e >&2; exit 3"],
                  count=2, fd=True, timeout=RUN_LIMIT)
    assert rc == 3
    out, err = capsys.readouterr()
    assert out == "api 72\n"
    assert err == "e\n"
