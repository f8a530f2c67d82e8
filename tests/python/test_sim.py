# SPDX-License-Identifier: Apache-2.0
"""`stewart sim` end to end, from the host: the simulated platform started
in real time (inside user-mode Linux where the host kernel has no CAN),
reached with python-can's socketcand interface through the bridge, driven
with `stewart op` (status, engage, a motion, stop), a fault injected with
`stewart sim inject` and seen on the bus, and stopped cleanly (the UML
halted, the final deadline figures printed, nothing left running).

The real-time pair misses deadlines on a loaded machine (the figure is
reported, not asserted here: docs/guides/simulator.md): the supervision is
relaxed (--relax) and the timeouts are generous. Where the host is so
loaded that the controller misses more than MAX_MISSES of its ticks in
the first seconds (on this project's shared machine, at a load average of
20-30 on 2 cores: 75-85 %), nothing runs in real time and the operator
session is skipped with the figure and the load; the bridge is tested
all the same. About 60 s.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from stewart import closedloop as cl
from stewart import protocol as pr
from stewart import vcan

REPO = Path(__file__).resolve().parents[2]
#: Deadline misses (per cent of the controller's ticks) above which the
#: host cannot run the session in real time (an idle machine: under 1 %).
MAX_MISSES = 20.0
STEWART = [sys.executable, "-m", "stewart.cli"]


def _usable() -> str | None:
    try:
        cl.Binaries.find()
    except FileNotFoundError as e:
        return str(e)
    try:
        vcan.backend_available()
    except vcan.VcanError as e:
        return f"no vcan back end: {e}"
    return None


pytestmark = pytest.mark.skipif(_usable() is not None, reason=str(_usable()))


def run(*args, timeout=120, check=None):
    r = subprocess.run([*STEWART, *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=REPO)
    print(f"$ stewart {' '.join(map(str, args))} -> {r.returncode}\n{r.stdout}{r.stderr}")
    assert "Traceback" not in r.stderr
    if check is not None:
        assert r.returncode == check, r.stderr
    return r


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("sim") / "run"
    out = open(run_dir.parent / "sim.out", "w+")
    proc = subprocess.Popen([*STEWART, "sim", "--run-dir", str(run_dir), "--port", "0", "--relax", "1000"],
                            stdout=out, stderr=subprocess.STDOUT, text=True, cwd=REPO, start_new_session=True)
    state = run_dir / "sim.json"
    end = time.monotonic() + 150
    while not state.exists():
        assert proc.poll() is None, f"stewart sim ended at start-up:\n{Path(out.name).read_text()}"
        assert time.monotonic() < end, "stewart sim did not start within 150 s"
        time.sleep(0.2)
    info = json.loads(state.read_text())
    yield proc, run_dir, info, Path(out.name)
    if proc.poll() is None:  # a test that failed half-way: stopped as a user would, killed if need be
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            for group in (proc.pid, info["pgid"]):
                try:
                    os.killpg(group, signal.SIGKILL)
                except (ProcessLookupError, PermissionError, TypeError):
                    pass
            proc.wait()
    out.close()


def op(info, *args, timeout=120, check=None):
    port = info["attach"]["socketcand"]["port"]
    return run("op", "-i", "socketcand", "--can-config", info["attach"]["socketcand"]["config"], *args,
               timeout=timeout, check=check) if port else None


def op_settled(info, *args, timeout=120):
    """`stewart op ARGS`, tried again (at most 3 times) when no status came
    within its 2 s (the relay into the user-mode Linux stalled: the host is
    loaded); any other failure is returned as it is."""
    for _ in range(3):
        r = op(info, *args, timeout=timeout)
        if r.returncode == 0 or "no CTRL_STATUS from the controller" not in r.stderr:
            return r
    return r


def _state(info) -> str:
    r = op_settled(info, "status")
    assert r.returncode == 0, r.stderr
    return r.stdout.split()[1].rstrip(",")


def _wait_state(info, want: str, timeout: float) -> str:
    end = time.monotonic() + timeout
    st = _state(info)
    while st != want and time.monotonic() < end:
        time.sleep(1.0)
        st = _state(info)
    return st


def test_python_can_hears_the_buses_through_the_bridge(sim):
    import can

    _, _, info, _ = sim
    s = info["attach"]["socketcand"]
    proto = pr.Protocol()
    seen: dict[int, int] = {}
    with can.Bus(interface="socketcand", host=s["host"], port=s["port"], channel="vcan0") as bus:
        end = time.monotonic() + 20
        while time.monotonic() < end and not (0x100 in seen and max(seen.values()) == 64):
            m = bus.recv(1.0)
            if m is not None:
                seen[m.arbitration_id] = max(seen.get(m.arbitration_id, 0), len(m.data))
                if m.arbitration_id == 0x100:
                    _, sig = proto.decode(0x100, bytes(m.data), check_counter=False)
                    assert pr.value_names("CTRL_STATUS", "State")[int(sig["State"])] == "IDLE"
    assert 0x100 in seen, f"no CTRL_STATUS through the bridge: {seen}"
    assert max(seen.values()) == 64, f"no 64-byte CAN FD frame through the bridge: {seen}"


def _require_real_time(run_dir) -> None:
    time.sleep(3.0)
    st = json.loads(run("sim", "status", "--run-dir", run_dir, "--json").stdout or "{}")
    miss = st.get("controller", {}).get("miss_percent")
    if miss is None or miss > MAX_MISSES:
        load = open("/proc/loadavg").read().split()[0]
        pytest.skip(f"the host cannot run the pair in real time now: {miss} % of the controller's ticks "
                    f"missed (load average {load}, {os.cpu_count()} cores)")


def test_operator_session_fault_and_clean_stop(sim):
    proc, run_dir, info, out = sim
    _require_real_time(run_dir)
    assert _state(info) == "IDLE"
    op_settled(info, "engage", timeout=150)
    assert _wait_state(info, "READY", 60) == "READY"
    motion = subprocess.Popen([*STEWART, "op", "-i", "socketcand", "--can-config", info["attach"]["socketcand"]["config"],
                               "run", "x", "0.02", "0.5"], cwd=REPO, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    try:
        assert _wait_state(info, "RUNNING", 60) == "RUNNING"
        op_settled(info, "stop", timeout=120)
        assert _wait_state(info, "READY", 60) == "READY"
    finally:
        motion.wait(timeout=60)
        print(motion.stdout.read())
    # a drive fault, injected while it runs, latches the controller's drive fault
    r = run("sim", "inject", "--run-dir", run_dir, "inject drive 2 fault 2", "not a scenario line")
    assert r.returncode == 1
    assert "accepted: inject drive 2 fault 2" in r.stdout
    assert "refused: control:1: unknown action 'not'" in r.stdout
    end = time.monotonic() + 60
    while time.monotonic() < end:
        st = op_settled(info, "status").stdout
        if st.startswith("state FAULT"):
            break
        time.sleep(1.0)
    assert st.startswith("state FAULT") and "drive" in st.split("faults ")[1].split(",")[0], st
    status = json.loads(run("sim", "status", "--run-dir", run_dir, "--json", check=0).stdout)
    assert status["running"] and status["controller"]["ticks"] > 0 and "plant" in status
    assert any("inject drive" in e for e in status["events"])
    pgid = status["pgid"]
    # the stop: the pair's summaries, the final figures, the UML halted, nothing left
    run("sim", "stop", "--run-dir", run_dir, check=0)
    assert proc.wait(timeout=60) == 0
    text = out.read_text()
    assert "stewart sim: controller:" in text and "deadline misses" in text, text
    assert not (run_dir / "control.sock").exists() and not (run_dir / "sim.json").exists()
    left = subprocess.run(["pgrep", "-g", str(pgid)], capture_output=True, text=True).stdout.split()
    assert left == [], f"processes of the simulation left: {left}"
    assert run("sim", "status", "--run-dir", run_dir).returncode == 3
