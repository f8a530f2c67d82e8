# SPDX-License-Identifier: Apache-2.0
"""Bus smoke test: python-can over SocketCAN vcan with CAN FD frames.

Meant to run inside ``stewart vcan --fd`` (which brings up vcan0..vcan2):

    .venv/bin/stewart vcan --fd -- .venv/bin/pytest -q tests/bus

Outside it, where vcan0 does not exist, every test is skipped (marked, not
a module-level skip, so that pytest still collects them and exits with 0).
"""

from pathlib import Path

import can
import pytest

NET = Path("/sys/class/net")
pytestmark = pytest.mark.skipif(not (NET / "vcan0").exists(),
                                reason="vcan0 does not exist: run under `stewart vcan --fd`")

#: Time to wait for a frame that must arrive (s): generous for a loaded UML.
RX_TIMEOUT = 5.0
#: Time to wait for a frame that must not arrive (s).
QUIET = 0.3


def mtu(name: str) -> int:
    return int((NET / name / "mtu").read_text())


def fd_bus(channel: str) -> "can.BusABC":
    return can.Bus(interface="socketcan", channel=channel, fd=True)


@pytest.fixture
def pair():
    a, b = fd_bus("vcan0"), fd_bus("vcan0")
    yield a, b
    a.shutdown()
    b.shutdown()


def test_three_fd_buses_exist():
    for name in ("vcan0", "vcan1", "vcan2"):
        assert (NET / name).exists(), f"{name} missing: stewart vcan brings up three buses"
        assert mtu(name) == 72, f"{name} has MTU {mtu(name)}, not 72: run `stewart vcan --fd`"


def test_fd_frame_with_brs_round_trip(pair):
    tx, rx = pair
    payload = bytes((7 * i + 3) & 0xFF for i in range(64))
    msg = can.Message(arbitration_id=0x123, is_extended_id=False, is_fd=True,
                      bitrate_switch=True, data=payload)
    tx.send(msg, timeout=1.0)
    got = rx.recv(timeout=RX_TIMEOUT)
    assert got is not None, "the 64-byte FD frame did not arrive on the second bus object"
    assert got.arbitration_id == 0x123
    assert not got.is_extended_id
    assert got.is_fd
    assert got.bitrate_switch
    assert got.dlc == 64
    assert bytes(got.data) == payload
    # The sender does not get its own frame back (CAN_RAW_RECV_OWN_MSGS off).
    assert tx.recv(timeout=QUIET) is None


def test_buses_are_separate():
    b1, b2 = fd_bus("vcan1"), fd_bus("vcan2")
    try:
        b1.send(can.Message(arbitration_id=0x321, is_fd=True, data=bytes(12)))
        assert b2.recv(timeout=QUIET) is None, "a frame sent on vcan1 appeared on vcan2"
    finally:
        b1.shutdown()
        b2.shutdown()
