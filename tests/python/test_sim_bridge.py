# SPDX-License-Identifier: Apache-2.0
"""The parts of `stewart sim` that need no bus: the link's lines, the raw
SocketCAN frame layout, and the socketcand server against python-can's own
socketcand client (64-byte frames both ways, whole blocks, the sender's
time stamps held back until its command is on the bus, bad input counted).
A few seconds (22 s at a load average of 20 on 2 cores)."""

from __future__ import annotations

import logging
import time

import can
import pytest

from stewart import busopts
from stewart.sim import bridge as br
from stewart.sim import wire


def test_frame_lines_round_trip_and_refuse_bad_ones():
    f = wire.Frame(1, 0x101, wire.FD | wire.BRS, bytes(range(64)), 12.5)
    words = wire.frame_line(f).split()[1:]
    assert wire.parse_frame(words) == f
    ext = wire.Frame(0, 0x1234567, wire.EXT, b"", 0.0)
    assert wire.parse_frame(wire.frame_line(ext, with_time=False).split()[1:]) == ext
    for bad in (["3", "101", "0", "-"], ["0", "800", "0", "-"], ["0", "101", "0", "zz"],
                ["0", "101", "0", "00" * 65], ["0", "101"]):
        with pytest.raises(wire.WireError):
            wire.parse_frame(bad)


def test_raw_frames_pack_and_unpack():
    f = wire.Frame(2, 0x123, wire.FD | wire.BRS, b"\x01" * 13)
    raw = wire.pack_raw(f)
    assert len(raw) == 72 and raw[4] == 16  # padded to the next CAN FD length
    back = wire.unpack_raw(2, raw, 1.0)
    assert back is not None and back.data == b"\x01" * 13 + b"\0" * 3 and back.flags == wire.FD | wire.BRS
    classic = wire.pack_raw(wire.Frame(0, 0x7FF, 0, b"\xaa\xbb"))
    assert len(classic) == 16
    assert wire.unpack_raw(0, classic, 0.0).data == b"\xaa\xbb"
    assert [wire.fd_length(n) for n in (0, 8, 9, 33, 64)] == [0, 8, 12, 48, 64]


def test_batch_reader_takes_many_datagrams_in_one_call():
    import socket

    a, b = socket.socketpair(socket.AF_UNIX, socket.SOCK_DGRAM)
    try:
        reader = wire.BatchReader(b, batch=4)
        assert reader.read() == []  # nothing waits: no block, no error
        sent = [bytes([i]) * (16 if i % 2 else 72) for i in range(6)]
        for d in sent:
            a.send(d)
        first, second = reader.read(), reader.read()
        assert [raw for raw, _ in first] == sent[:4]  # at most a batch, in order, each its own length
        assert [raw for raw, _ in second] == sent[4:]
        assert all(flags == 0 for _, flags in first + second)
        assert reader.read() == []
    finally:
        a.close()
        b.close()


def test_blocks_end_with_whole_messages():
    msgs = [br.format_frame(wire.Frame(0, 0x100 + i, wire.FD, bytes(64), 1.0)) for i in range(20)]
    out = br.blocks(msgs)
    assert len(out) % br.BLOCK == 0
    for k in range(0, len(out), br.BLOCK):
        block = out[k:k + br.BLOCK].decode()
        assert block.startswith("< frame") and block.endswith(">")
        assert block.count("<") == block.count(">")


class FakeSim:
    """The bridge's two hooks, recorded."""

    def __init__(self):
        self.sent: list[tuple[wire.Frame, object]] = []
        self.subs: list[tuple[int, bool]] = []

    def send(self, f, client):
        self.sent.append((f, client))

    def sub(self, bus, on):
        self.subs.append((bus, on))


@pytest.fixture
def server():
    sim = FakeSim()
    b = br.Bridge(sim.send, sim.sub, port=0)
    yield b, sim
    b.close()


def _client(b, channel="vcan0"):
    opts = busopts.BusOptions(interface="socketcand", channel=channel)
    kw = busopts.resolve(opts)
    assert kw["host"] == "127.0.0.1" and kw["port"] == br.DEFAULT_PORT and kw["fd"] is True
    return can.Bus(interface="socketcand", host="127.0.0.1", port=b.port, channel=channel)


def _wait(cond, timeout=5.0):
    end = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.01)


def test_python_can_gets_64_byte_frames_whole_and_sends_them(server, caplog):
    b, sim = server
    caplog.set_level(logging.WARNING)
    bus = _client(b)
    try:
        _wait(lambda: sim.subs == [(0, True)])
        frames = [wire.Frame(0, 0x101, wire.FD | wire.BRS, bytes([i]) * 64, 100.0 + i) for i in range(50)]
        b.deliver(frames)
        got = [bus.recv(2.0) for _ in frames]
        assert [bytes(m.data) for m in got] == [f.data for f in frames]
        assert [m.timestamp for m in got] == [f.time for f in frames]
        bus.send(can.Message(arbitration_id=0x40, data=bytes(range(20)), is_extended_id=False, is_fd=True))
        _wait(lambda: len(sim.sent) == 1)
        f, _ = sim.sent[0]
        assert (f.bus, f.can_id, f.data, f.flags) == (0, 0x40, bytes(range(20)), wire.FD | wire.BRS)
    finally:
        bus.shutdown()
    _wait(lambda: sim.subs[-1] == (0, False))
    assert not [r for r in caplog.records if r.name.startswith("can.interfaces.socketcand")], caplog.text


def test_a_senders_view_holds_back_what_preceded_its_frame(server):
    b, sim = server
    bus = _client(b)
    other = _client(b)
    try:
        _wait(lambda: len([c for c in b.clients if c.raw]) == 2)
        # a heartbeat is answered by nothing: no stamp is held back for it
        bus.send(can.Message(arbitration_id=0x60, data=b"\x01" * 4, is_extended_id=False))
        _wait(lambda: len(sim.sent) == 1)
        assert other.recv(2.0).arbitration_id == 0x60
        client = sim.sent[0][1]
        now = time.time()
        b.deliver([wire.Frame(0, 0x100, wire.FD, b"\x04" * 16, now)])  # before the heartbeat is on the bus
        assert bus.recv(2.0).timestamp == pytest.approx(now)
        assert other.recv(2.0).timestamp == pytest.approx(now)
        b.on_bus(client, now + 0.001)
        assert client.sends == [], "an acknowledged heartbeat is forgotten"
        # a command (OP_COMMAND, an event frame) is answered: what preceded it is held back
        before = time.time()
        bus.send(can.Message(arbitration_id=0x40, data=b"\x01" * 20, is_extended_id=False, is_fd=True))
        _wait(lambda: len(sim.sent) == 2)
        seen_by_other = other.recv(2.0)  # the other client hears the frame, not its sender
        assert seen_by_other.arbitration_id == 0x40
        now = time.time()
        b.deliver([wire.Frame(0, 0x100, wire.FD, b"\x02" * 16, now)])  # before the frame is on the bus
        early = bus.recv(2.0)
        assert early.timestamp < before, "a frame from before the send is stamped before it"
        assert other.recv(2.0).timestamp == pytest.approx(now)  # nothing held back for the other
        b.on_bus(client, now + 0.001)
        b.deliver([wire.Frame(0, 0x100, wire.FD, b"\x03" * 16, now + 0.01)])
        late = bus.recv(2.0)
        assert late.timestamp == pytest.approx(now + 0.01) and late.timestamp > before
    finally:
        bus.shutdown()
        other.shutdown()


def test_bad_channel_and_bad_sends(server):
    b, sim = server
    with pytest.raises(can.CanError, match="unknown channel"):
        can.Bus(interface="socketcand", host="127.0.0.1", port=b.port, channel="vcan7")
    bus = _client(b, channel="axis_a")
    try:
        _wait(lambda: (1, True) in sim.subs)
        bus._tcp_send("< send 101 3 1 2 >")  # announces 3 bytes, gives 2
        bus._tcp_send("< bogus >")
        bus.send(can.Message(arbitration_id=0x33, data=b"\x05", is_extended_id=False))
        _wait(lambda: len(sim.sent) == 1)
        assert sim.sent[0][0].bus == 1 and b.bad == 2
    finally:
        bus.shutdown()


def test_no_server_is_a_clear_error_at_once():
    t0 = time.monotonic()
    with pytest.raises(busopts.BusError, match="no socketcand server at 127.0.0.1:1 .*stewart sim"):
        busopts._check_socketcand({"host": "127.0.0.1", "port": 1})
    assert time.monotonic() - t0 < 3.0


def test_stewart_marks_socketcand_frames_fd(server):
    b, sim = server
    opts = busopts.BusOptions(interface="socketcand", channel="vcan0")
    import stewart.busopts as bo

    old = bo.SOCKETCAND_PORT
    bo.SOCKETCAND_PORT = b.port
    try:
        bus = bo.open_bus(opts)
    finally:
        bo.SOCKETCAND_PORT = old
    try:
        _wait(lambda: (0, True) in sim.subs)
        b.deliver([wire.Frame(0, 0x101, wire.FD | wire.BRS, bytes(64), 5.0)])
        m = bus.recv(2.0)
        assert m.is_fd and m.bitrate_switch and len(m.data) == 64
    finally:
        bus.shutdown()
