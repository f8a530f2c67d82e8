# SPDX-License-Identifier: Apache-2.0
"""The console's bus side: one operator node for every client.

The :class:`Hub` owns the operator node on the ops bus
(:class:`stewart.operator.node.OperatorNode`: commands signed with the
machine key, which stays here), listeners on the drive buses (the legs'
lengths and pressures, the force/torque sensor), who commands, the
snapshots the page shows, the recordings and the UDP pose output.

Who commands: one client at a time (the commander); the others observe.
A client becomes commander by claiming while nobody commands, or by an
explicit takeover. The node's OP_HEARTBEAT, which the controller's
operator supervision watches while RUNNING and in force control, is sent
only while the commander is alive: its WebSocket open, or an HTTP request
from it within the lease (``lease_s``). Closing the commander's browser
or killing the server therefore stops the heartbeat, and the controller
stops the platform after its operator timeout (200 ms by default).
ESTOP is taken from every client, commander or not.
"""

from __future__ import annotations

import math
import secrets
import struct
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

from .. import protocol as pr
from ..operator.node import NoAnswer, OperatorNode, OpError, Refused, _Reader
from . import recorder
from .validate import Request

#: The receive threads wake at most every RX_BATCH_S and take the frames that
#: queued meanwhile (their bus timestamps are the interface's): woken for
#: each of ~4,000 frames a second, they cost more CPU than all else; every
#: 4 ms the server still took 23-26 % of a core on a lightly loaded machine
#: (the bound is 25 %), every 10 ms 15-18 % (docs/guides/console.md).
RX_BATCH_S = 0.010
STALE_S = 0.5          # no CTRL_STATUS for this long: the controller (or the bus) is gone
#: A command that finds the status stale waits this long for a fresh one
#: before it is refused: a relayed bus (``stewart sim`` through socketcand
#: into user-mode Linux) can pause for half a second on a busy machine (CI).
STALE_GRACE_S = 2.0
UDP_MAGIC = b"SPP1"
#: The UDP pose datagram (docs/reference/console-api.md): magic, sequence,
#: controller tick, bus time of the status (s, Unix), pose x y z (m) roll
#: pitch yaw (rad), state number, valid flag, two pad bytes.
UDP_FORMAT = "<4sIId6dBBxx"


class Forbidden(Exception):
    """Not the commander (HTTP 403)."""


class Conflict(Exception):
    """Someone else commands (HTTP 409)."""


class BusDown(Exception):
    """No bus, or no controller on it (HTTP 503)."""


class ConsoleNode(OperatorNode):
    """The operator node whose heartbeat goes out only while ``gate()``."""

    def __init__(self, *args, gate, **kw):
        super().__init__(*args, heartbeat=True, **kw)
        self._gate = gate

    def send_heartbeat(self) -> None:
        if self._gate():
            super().send_heartbeat()


@dataclass
class Client:
    id: str
    name: str
    sockets: int = 0
    last_seen: float = 0.0


class AxisListener:
    """The latest frame of each drive-bus message (decoded when shown)."""

    def __init__(self, bus, name: str, on_frame):
        self.bus, self.name, self.on_frame = bus, name, on_frame
        self.latest: dict[int, tuple[bytes, float]] = {}
        self.error: str | None = None
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._loop, name=f"console-{name}", daemon=True)

    def start(self):
        self.thread.start()
        return self

    def _loop(self) -> None:
        timeout = 0.05
        while not self._stop.is_set():
            try:
                msg = self.bus.recv(timeout=timeout)
            except Exception as e:  # noqa: BLE001 - any interface error is the bus going away
                self.error = str(e) or type(e).__name__
                self._stop.wait(0.2)
                continue
            if msg is None:
                if timeout == 0.0:  # took all that had queued (see RX_BATCH_S)
                    timeout = 0.05
                    self._stop.wait(RX_BATCH_S)
                continue
            timeout = 0.0
            if msg.is_error_frame:
                continue
            self.error = None
            self.latest[msg.arbitration_id] = (bytes(msg.data), float(msg.timestamp or time.time()))
            self.on_frame(msg, self.name)

    def close(self) -> None:
        self._stop.set()
        self.thread.join(1.0)
        try:
            self.bus.shutdown()
        except Exception:  # noqa: BLE001 - closing
            pass


class Hub:
    """Everything the server serves, independent of HTTP."""

    def __init__(self, ops_bus, platform, key: bytes | None, axis_buses: dict | None = None,
                 lease_s: float = 1.0, record_dir: str | Path = "out/console", proto=None,
                 stale_s: float = STALE_S):
        self.platform = platform
        self.stale_s = stale_s
        self.proto = proto or pr.Protocol()
        self.lease_s = lease_s
        self.clients: dict[str, Client] = {}
        self.commander: str | None = None
        self._lock = threading.RLock()
        self._cmd_lock = threading.Lock()
        self.events: deque = deque(maxlen=50)
        self._event_seq = 0
        self.recorder = recorder.Recorder(Path(record_dir), self.proto)
        self.node = ConsoleNode(ops_bus, proto=self.proto, key=key, monitor=True, gate=self.commander_alive,
                                rx_batch_s=RX_BATCH_S,
                                on_frame=lambda m: self.recorder.frame(m, "ops"))
        self.axes = {name: AxisListener(bus, name, self.recorder.frame) for name, bus in (axis_buses or {}).items()}
        self._fb = {s: _Reader(self.proto, pr.feedback_name(s)) for s in (1, 2, 3)}
        self._ft = _Reader(self.proto, "FT_SENSOR")
        self._prev_len: list[tuple[float, float, float | None] | None] = [None] * 6
        self._udp = None
        self.key_loaded = key is not None

    def start(self) -> "Hub":
        self.node.start()
        for a in self.axes.values():
            a.start()
        return self

    def close(self) -> None:
        if self._udp is not None:
            self._udp.close()
        self.recorder.stop()
        for a in self.axes.values():
            a.close()
        self.node.close()

    # -- clients and who commands ------------------------------------------
    def new_client(self, name: str = "") -> Client:
        c = Client(secrets.token_hex(8), str(name)[:40], last_seen=time.monotonic())
        with self._lock:
            self.clients[c.id] = c
            # forget clients long gone
            for cid in [k for k, v in self.clients.items()
                        if v.sockets == 0 and time.monotonic() - v.last_seen > 600 and k != self.commander]:
                del self.clients[cid]
        return c

    def touch(self, cid: str | None) -> Client | None:
        with self._lock:
            c = self.clients.get(cid or "")
            if c is not None:
                c.last_seen = time.monotonic()
            return c

    def socket_opened(self, cid: str) -> None:
        with self._lock:
            self.clients[cid].sockets += 1

    def socket_closed(self, cid: str) -> None:
        with self._lock:
            c = self.clients.get(cid)
            if c is not None:
                c.sockets -= 1
                c.last_seen = time.monotonic() - self.lease_s  # no lease left after the page is gone
                if c.sockets == 0 and self.commander == cid:
                    self.commander = None
                    self.event("control", f"the commander {c.name or cid} left: nobody commands "
                               "(the controller stops a running motion when the heartbeat stops)")

    def _alive(self, c: Client | None) -> bool:
        return c is not None and (c.sockets > 0 or time.monotonic() - c.last_seen < self.lease_s)

    def commander_alive(self) -> bool:
        with self._lock:
            return self.commander is not None and self._alive(self.clients.get(self.commander))

    def claim(self, cid: str, takeover: bool) -> dict:
        with self._lock:
            c = self.clients.get(cid)
            if c is None:
                raise Forbidden("unknown client: open a session first (POST /api/session or the WebSocket)")
            cur = self.commander
            if cur not in (None, cid) and self.commander_alive() and not takeover:
                other = self.clients[cur]
                raise Conflict(f"{other.name or cur} commands: take over explicitly (takeover: true)")
            if cur not in (None, cid):
                self.event("control", f"{c.name or cid} took over from {self.clients[cur].name or cur}")
            elif cur is None:
                self.event("control", f"{c.name or cid} commands")
            self.commander = cid
            return self.control()

    def release(self, cid: str) -> dict:
        with self._lock:
            if self.commander == cid:
                self.commander = None
                self.event("control", f"{self.clients[cid].name or cid} released command")
            return self.control()

    def control(self) -> dict:
        with self._lock:
            alive = self.commander_alive()
            c = self.clients.get(self.commander or "")
            return {"commander": self.commander if alive else None, "commander_name": c.name if c and alive else None,
                    "clients": sum(1 for v in self.clients.values() if self._alive(v))}

    def require_commander(self, cid: str | None) -> None:
        with self._lock:
            if cid is None or cid not in self.clients:
                raise Forbidden("unknown client: open a session first (POST /api/session or the WebSocket)")
            if self.commander != cid or not self.commander_alive():
                raise Forbidden("this client observes: claim command first (POST /api/control "
                                "{\"action\": \"claim\"}), or take over")

    # -- events ----------------------------------------------------------------
    def event(self, kind: str, text: str, ok: bool = True) -> dict:
        self._event_seq += 1
        e = {"seq": self._event_seq, "t": time.time(), "kind": kind, "text": text, "ok": ok}
        self.events.append(e)
        return e

    # -- health ------------------------------------------------------------------
    def bus_problem(self) -> str | None:
        """Why no command can go now (the bus gone, the controller silent), or None."""
        if self.node.rx_error:
            return f"the ops bus failed: {self.node.rx_error}"
        st = self.node.status
        if st is None:
            return "no CTRL_STATUS from the controller yet (is it running, is this the ops bus?)"
        if time.monotonic() - st.t > self.stale_s:
            return f"the controller has been silent for {time.monotonic() - st.t:.1f} s (bus or controller gone)"
        return None

    def _bus_problem_after_grace(self) -> str | None:
        """bus_problem(), but a status that is only late is waited for
        (STALE_GRACE_S) rather than refused at once."""
        why = self.bus_problem()
        st = self.node.status
        if why is None or st is None or self.node.rx_error:
            return why
        try:
            self.node.wait_status(timeout=STALE_GRACE_S, after=st.seq)
        except OpError:
            pass
        return self.bus_problem()

    # -- commands ----------------------------------------------------------------
    def estop(self, cid: str | None) -> dict:
        """ESTOP from any client: sent at once (twice, the E2E resync), then
        the answer awaited without the command lock."""
        who = self.clients.get(cid or "")
        t0 = time.time()
        try:
            self.node.send_command("ESTOP")
            self.node.send_command("ESTOP")
        except OpError as e:
            self.event("command", f"ESTOP could not be sent: {e}", ok=False)
            raise BusDown(f"ESTOP could not be sent: {e}") from None
        sent = time.time()
        st = self._wait_state(lambda s: s.state == "ESTOP", 2.0)
        self.event("command", f"ESTOP by {who.name if who and who.name else cid or 'anonymous'}: "
                   f"{st.state if st else 'no status'}", ok=bool(st and st.state == "ESTOP"))
        if st is None or st.state != "ESTOP":
            raise NoAnswer("ESTOP sent; the controller did not show ESTOP within 2 s")
        return {"ok": True, "command": "estop", "state": st.state, "sent": sent, "send_ms": (sent - t0) * 1e3}

    def _wait_state(self, done, timeout: float):
        end = time.monotonic() + timeout
        st = self.node.status
        seq = st.seq if st else 0
        while time.monotonic() < end:
            try:
                st = self.node.wait_status(timeout=max(0.01, end - time.monotonic()), after=seq)
            except OpError:
                return self.node.status
            seq = st.seq
            if done(st):
                return st
        return st

    def execute(self, cid: str, req: Request) -> dict:
        """Carries out a checked request for the commander (blocking: a
        worker thread calls it). Raises Forbidden, BusDown, Refused, NoAnswer."""
        self.require_commander(cid)
        why = self._bus_problem_after_grace()
        if why:
            raise BusDown(why)
        if not self._cmd_lock.acquire(timeout=0.5):
            raise Conflict("another command is still being carried out: wait for its answer")
        t0 = time.monotonic()
        try:
            text = _ACTIONS[req.command](self, req)
        except (Refused, NoAnswer, OpError) as e:
            self.event("command", f"{req.command}: {e}", ok=False)
            raise
        finally:
            self._cmd_lock.release()
        st = self.node.status
        self.event("command", f"{req.command}: {text}")
        return {"ok": True, "command": req.command, "state": st.state if st else None, "text": text,
                "ms": (time.monotonic() - t0) * 1e3}

    def _cmd(self, name: str, done, timeout: float, **signals) -> str:
        ans = self.node.command(name, done, timeout=timeout, **signals)
        return f"{ans.status.state} ({ans.seconds * 1e3:.0f} ms)"

    def _move(self, pose, wait_end: bool) -> str:
        node = self.node
        node.send_target(pose)
        node.wait_status(timeout=2.0, after=node.status.seq)
        node.send_target(pose)
        text = self._cmd("MOVE_TO", lambda s: s.state != "READY", 5.0)
        if wait_end:
            st = self._wait_state(lambda s: s.state != "RUNNING", 10.0)
            text = st.state if st else text
        return text

    def _force(self, req: Request, mode: str) -> str:
        from ..commands import op_cmd

        node = self.node
        if req.params is not None:
            args = SimpleNamespace(op=mode.lower(), timeout=None)
            if op_cmd._send_params(node, args, req.mask, req.params):
                raise Refused(f"{mode}: the admittance parameters were refused (position control only)")
        op_cmd._send_force_twice(node, req.mask, req.target)
        return self._cmd(mode, lambda s: s.force_mode == mode, 5.0)

    # -- the UDP pose output ---------------------------------------------------
    def start_udp(self, host: str, port: int, rate_hz: float) -> None:
        self._udp = UdpPose(self, host, port, rate_hz).start()

    # -- snapshot ------------------------------------------------------------------
    def snapshot(self) -> dict:
        """What the page shows, as JSON-ready values (SI units)."""
        st, mon, wr = self.node.status, self.node.monitor, self.node.wrench
        snap = {"type": "state", "t": time.time(), "bus_problem": self.bus_problem(),
                "control": self.control(), "recording": self.recorder.info(),
                "events_seq": self._event_seq, "key_loaded": self.key_loaded}
        if st is not None:
            snap.update(tick=st.tick, state=st.state, faults=st.faults, pose=st.pose,
                        estimate_valid=st.estimate_valid, feedforward=st.feedforward,
                        drive_mode=st.drive_mode, force_mode=st.force_mode, contact=st.contact,
                        refusals=st.refusals, bus_stamp=st.stamp, drives_starting=st.drives_starting)
        if mon is not None:
            snap["reference"] = mon["reference"]
            if st is not None:
                snap["tracking_error"] = [r - p for r, p in zip(mon["reference"], st.pose)]
        if wr is not None:
            snap["wrench"] = {"valid": wr["valid"], "values": wr["wrench"]}
        snap["legs"] = self._legs(mon)
        snap["ft"] = self._ft_values()
        c = self.node.counters
        snap["counters"] = {"frames": dict(c.frames), "lost": c.lost, "sent": c.sent, "heartbeats": c.heartbeats,
                            "send_errors": c.send_errors,
                            "axis_errors": {k: a.error for k, a in self.axes.items() if a.error}}
        return snap

    def _legs(self, mon) -> list[dict]:
        p = self.platform
        hyd = p.hydraulic
        area_a = math.pi / 4 * hyd.get("piston_diameter", 0.0) ** 2
        area_b = area_a - math.pi / 4 * hyd.get("rod_diameter", 0.0) ** 2
        states = pr.value_names("AXIS_FEEDBACK_1", "State")
        legs = []
        for leg in range(1, 7):
            bus, slot = pr.LEG_BUS[leg]
            d = {"leg": leg}
            if mon is not None:
                d["length_sp"] = mon["length_sp"][leg - 1]
                d["force_ff"] = mon["force_ff"][leg - 1]
            a = self.axes.get(bus)
            got = a.latest.get(self._fb[slot].frame_id) if a else None
            if got is not None:
                r = self._fb[slot]
                w, f = r.word(got[0]), r.fields
                ln, pa, pb = f["Length"].value(w), f["PressureA"].value(w), f["PressureB"].value(w)
                s = f["State"].raw(w)
                d.update(length=ln, pressure_a=pa, pressure_b=pb, force=pa * area_a - pb * area_b,
                         state=states[s] if s < len(states) else str(s),
                         faults=pr.fault_names(f["Faults"].raw(w), pr.DRIVE_FAULTS),
                         stroke=(ln - p.leg_length_min) / (p.leg_length_max - p.leg_length_min))
                d["speed"] = self._speed(leg, ln, got[1])
            elif "length_sp" in d:
                d["stroke"] = (d["length_sp"] - p.leg_length_min) / (p.leg_length_max - p.leg_length_min)
            legs.append(d)
        return legs

    def _speed(self, leg: int, length: float, stamp: float) -> float | None:
        """The leg's speed, m/s, from its lengths at least 20 ms apart (the
        last figure kept between)."""
        prev = self._prev_len[leg - 1]
        if prev is None or stamp - prev[1] >= 0.02:
            speed = (length - prev[0]) / (stamp - prev[1]) if prev is not None and stamp > prev[1] else None
            self._prev_len[leg - 1] = (length, stamp, speed)
            return speed
        return prev[2]

    def _ft_values(self) -> list[float] | None:
        a = self.axes.get("axis_b")
        got = a.latest.get(self._ft.frame_id) if a else None
        if got is None:
            return None
        w = self._ft.word(got[0])
        return [self._ft.fields[n].value(w) for n in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")]


class UdpPose:
    """The measured pose over UDP at ``rate_hz`` (format: :data:`UDP_FORMAT`)."""

    def __init__(self, hub: Hub, host: str, port: int, rate_hz: float):
        import socket

        self.hub, self.addr, self.period = hub, (host, port), 1.0 / rate_hz
        self.sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_DGRAM)
        self.sent = 0
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._loop, name="console-udp", daemon=True)

    def start(self):
        self.thread.start()
        return self

    def _loop(self) -> None:
        states = pr.value_names("CTRL_STATUS", "State")
        nxt = time.monotonic()
        while not self._stop.is_set():
            st = self.hub.node.status
            if st is not None:
                data = struct.pack(UDP_FORMAT, UDP_MAGIC, self.sent & 0xFFFFFFFF, st.tick & 0xFFFFFFFF, st.stamp,
                                   *st.pose, states.index(st.state) if st.state in states else 255,
                                   1 if st.estimate_valid and time.monotonic() - st.t < STALE_S else 0)
                try:
                    self.sock.sendto(data, self.addr)
                    self.sent += 1
                except OSError:
                    pass
            nxt += self.period
            delay = nxt - time.monotonic()
            if delay < -0.1:
                nxt = time.monotonic()
            self._stop.wait(max(0.0, delay))

    def close(self) -> None:
        self._stop.set()
        self.thread.join(1.0)
        self.sock.close()


def _reset_done(s) -> bool:
    return s.state in ("READY", "IDLE") and not s.faults


def _stop(h: Hub, r: Request) -> str:
    if h.node.status.state != "RUNNING":
        return f"nothing to stop (the controller is {h.node.status.state})"
    return h._cmd("STOP", lambda s: s.state != "RUNNING", 60.0)


def _jog(h: Hub, r: Request) -> str:
    return h._move(r.pose, wait_end=True)


_ACTIONS = {
    "engage": lambda h, r: h._cmd("ENGAGE", lambda s: s.state in ("ENGAGING", "READY"), 10.0),
    "park": lambda h, r: h._cmd("PARK", lambda s: s.state in ("PARKING", "IDLE"), 10.0),
    "stop": _stop,
    "reset": lambda h, r: h._cmd("RESET", _reset_done, 30.0),
    "move": lambda h, r: h._move(r.pose, wait_end=False),
    "jog": _jog,
    "run": lambda h, r: h._cmd("RUN_TRIG", lambda s: s.state == "RUNNING", 5.0, axis=r.axis,
                               amplitude=r.amplitude, frequency=r.frequency, fade_time=r.fade),
    "force": lambda h, r: h._force(r, "FORCE"),
    "guide": lambda h, r: h._force(r, "GUIDE"),
    "position": lambda h, r: h._cmd("POSITION", lambda s: s.force_mode == "OFF", 30.0),
    "tare": lambda h, r: h._cmd("TARE", lambda s: True, 5.0),
    "feedforward": lambda h, r: h._cmd("SET_FEEDFORWARD", lambda s, on=r.on: s.feedforward == on, 2.0,
                                       option=1 if r.on else 0),
}
