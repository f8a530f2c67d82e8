# SPDX-License-Identifier: Apache-2.0
"""The firmware's controller (sp_controller, host release build) on a real
SocketCAN bus, checked by python-can + cantools from the same DBC.

Runs inside ``stewart vcan --fd`` (vcan0..vcan2); skipped elsewhere.
"""

import re
import signal
import subprocess
import time
from pathlib import Path

import can
import pytest

from stewart import e2e
from stewart.protocol import Protocol, value_names

REPO_ROOT = Path(__file__).resolve().parents[2]

NET = Path("/sys/class/net")
pytestmark = pytest.mark.skipif(not (NET / "vcan0").exists(),
                                reason="vcan0 does not exist: run under `stewart vcan --fd`")
CONTROLLER = REPO_ROOT / "build" / "host-release" / "firmware" / "ports" / "host" / "sp_controller"


def summary_counts(text: str) -> dict[str, int]:
    line = next(l for l in text.splitlines() if l.startswith("sp_controller frames:"))
    return {k: int(v) for k, v in re.findall(r"([a-z-]+) (\d+)", line)}


def wait_ticks(proto: Protocol, n: int, timeout: float = 60.0) -> None:
    """Waits until the controller's CTRL_STATUS Tick has advanced by n from
    the first status sent after this call (a socket opened now hears only
    later frames)."""
    bus = can.Bus(interface="socketcan", channel="vcan0", fd=True,
                  can_filters=[{"can_id": 0x100, "can_mask": 0x7FF, "extended": False}])
    try:
        first = None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            m = bus.recv(timeout=0.5)
            if m is None or m.arbitration_id != 0x100:  # heard before the filter was set (busrig's doc)
                continue
            tick = proto.decode(0x100, bytes(m.data), check_counter=False)[1]["Tick"]
            first = tick if first is None else first
            if tick - first >= n:
                return
        pytest.fail(f"the controller's tick did not advance by {n} within {timeout} s")
    finally:
        bus.shutdown()


def test_controller_frames_decode_and_bad_frames_are_rejected():
    assert CONTROLLER.exists(), "build the host-release preset first"
    proto = Protocol()
    ops = can.Bus(interface="socketcan", channel="vcan0", fd=True)
    axis = can.Bus(interface="socketcan", channel="vcan1", fd=True)
    # stopped by SIGINT once it has taken the test's frames (a fixed 1.5 s
    # run could end before a loaded machine had sent them); 10 min at most
    proc = subprocess.Popen([str(CONTROLLER), "--ticks", "600000"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        received = {"ops": [], "axis_a": []}
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (len(received["ops"]) < 60 or len(received["axis_a"]) < 60):
            for name, bus in (("ops", ops), ("axis_a", axis)):
                msg = bus.recv(timeout=0.05)
                if msg is not None:
                    received[name].append(msg)
        # malformed frames into the controller's ops bus; the good one a
        # NONE (it needs no authentication code: docs/explanation/security.md)
        good = proto.encode("OP_COMMAND", {"Command": 0, "Axis": 0, "Amplitude": 0, "Frequency": 0,
                                           "FadeTime": 0, "Option": 0}, counter=3)
        unsigned = proto.encode("OP_COMMAND", {"Command": 1}, counter=4)  # ENGAGE without a code
        bad_crc = bytearray(good)
        bad_crc[1] ^= 0x40
        out_of_range = bytearray(proto.encode("OP_COMMAND", {"Command": 1}, counter=7))
        out_of_range[0] = 15  # beyond IDENTIFY (14), the last command
        out_of_range = e2e.seal(0x40, bytes(out_of_range))
        sends = [bytes(bad_crc), good[:8], good, good, unsigned]  # bad CRC, short, good, repeated, no code
        for data in sends:
            ops.send(can.Message(arbitration_id=0x40, data=data, is_fd=True, bitrate_switch=True,
                                 is_extended_id=False))
            time.sleep(0.01)
        ops.send(can.Message(arbitration_id=0x40, data=out_of_range, is_fd=True, bitrate_switch=True,
                             is_extended_id=False))
        wait_ticks(proto, 50)  # it reads its socket every tick: 50 ticks on, it has taken them all
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        ops.shutdown()
        axis.shutdown()
    assert proc.returncode == 0, err

    # every frame the C side sent decodes with the DBC, CRC and counters intact
    statuses = []
    for name, msgs in received.items():
        for m in msgs:
            r = proto.receive(m.arbitration_id, bytes(m.data), bus=name)
            assert r.ok, (name, hex(m.arbitration_id), r.error)
            assert m.is_fd and m.bitrate_switch
            if r.name == "CTRL_STATUS":
                statuses.append(r.signals)
    ticks = [s["Tick"] for s in statuses]
    assert len(ticks) >= 20 and all(b - a >= 1 for a, b in zip(ticks, ticks[1:]))
    states = value_names("CTRL_STATUS", "State")
    assert all(states[s["State"]] == "IDLE" for s in statuses)  # no drives on this bus
    sync = [proto.decode(m.arbitration_id, bytes(m.data), check_counter=False)[1]
            for m in received["axis_a"] if m.arbitration_id == 0x10]
    assert sync and all(s["Hold"] == 0 for s in sync)

    counts = summary_counts(out)
    assert counts["bad-crc"] == 1
    assert counts["bad-length"] == 1
    assert counts["repeated"] == 1
    assert counts["bad-tag"] == 1 and counts["replayed"] == 0 and counts["no-key"] == 0
    assert counts["accepted"] >= 1
    assert counts["out-of-range"] == 1
