# SPDX-License-Identifier: Apache-2.0
"""The operator node: interface-agnostic (any python-can bus).

One receive thread reads the controller's frames (CTRL_STATUS and
CTRL_AUTH; CTRL_MONITOR and CTRL_WRENCH too for a node that shows them,
``monitor``), checks their CRC and alive counter and keeps the latest of
each; one thread sends OP_HEARTBEAT every 20 ms (the
controller's operator-link supervision, docs/guides/operator.md). Commands wait
for the controller's answer: the state it should reach, or a refusal
(CTRL_STATUS's CmdRejected, or its count of refusals moved), with the
reason the tool can tell from the state.

A new process's first frame of a message may meet the controller's E2E
check with its counter out of sequence (the controller remembers the last
counter of the previous process) and be dropped: the check resynchronises
on it and takes the next frame. So a command is preceded by an OP_COMMAND
NONE (does nothing), and a MOVE_TO target is sent twice; ESTOP is sent
twice back to back (a second ESTOP is harmless).

Command authentication (docs/explanation/security.md): with the machine key
(``key``), the frames that start or change motion (OP_COMMAND but NONE,
STOP, PARK, ESTOP and IDENTIFY; OP_TARGET_POSE; OP_FORCE; OP_FORCE_PARAMS) are signed with the
controller's session and a counter that continues from the last one the
controller accepted, both read from its CTRL_AUTH (every 10 ms); without a
key such a frame is not sent (OpError). A command the controller rejects
for its code is reported as refused, with the reason CTRL_AUTH tells.

``identify`` asks the controller what it is (OP_COMMAND IDENTIFY, unsigned,
taken in any state): one CTRL_IDENTITY answers each request.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

from .. import auth as au
from .. import e2e
from .. import protocol as pr

HEARTBEAT_PERIOD_S = 0.020
COMMAND_QUEUE = 4  # the controller's command queue (SP_NODE_CMD_QUEUE): one command executed per tick
STATES = pr.value_names("CTRL_STATUS", "State")
COMMANDS = pr.value_names("OP_COMMAND", "Command")

#: Where each command is accepted (the controller's state machine,
#: firmware/core/src/control/controller.c and node.c).
ACCEPTED_IN = {
    "ENGAGE": ("IDLE",),
    "RUN_TRIG": ("READY",),
    "MOVE_TO": ("READY",),
    "STREAM": ("READY",),
    "STOP": ("RUNNING",),
    "PARK": ("READY", "ENGAGING", "RUNNING"),
    "ESTOP": STATES,
    "RESET": ("FAULT", "ESTOP"),  # not STOPPING: RESET waits for the controlled stop's end
    "SET_FEEDFORWARD": ("IDLE", "READY"),
    "FORCE": ("READY", "RUNNING"),
    "GUIDE": ("READY", "RUNNING"),
    "POSITION": STATES,
    "TARE": ("READY",),
    "IDENTIFY": STATES,
    "NONE": STATES,
}
MOTION = ("ENGAGE", "RUN_TRIG", "MOVE_TO", "STREAM", "FORCE", "GUIDE")
FORCE_MODES = pr.value_names("CTRL_STATUS", "ForceMode")


#: CTRL_FRAMES' refusal counts (Refused<Name>), one per reason of the one
#: list of refusal reasons (CTRL_REFUSAL Reason, CTRL_FRAMES LastRefusal)
#: but NONE and LINK, and what each means.
FRAME_REFUSALS = ("State", "Range", "Reach", "Rate", "Force", "EmptySlot", "BadFrame", "NotFinite")
FRAME_REFUSAL_TEXT = {
    "State": "the controller's state does not allow it (frames change only at rest: IDLE, or READY in position "
             "control)",
    "Range": "a parameter is outside its range",
    "Reach": "the pose is beyond the workspace or a stroke",
    "Rate": "the motion would drive a leg beyond its rate limit",
    "Force": "the motion would need more than the cylinders' force budget",
    "EmptySlot": "no frame is defined in that slot (0..3)",
    "BadFrame": "the frame is out of bounds: tool point beyond 5 m, work origin beyond 16 m, angle beyond pi",
    "NotFinite": "a value is not a finite number",
}
#: The wire's "not a finite number" in OP_FRAME and OP_REACH (raw -2^23).
NOT_FINITE_WIRE = -8.388608


class OpError(Exception):
    """A failed operator action; ``code`` is the exit status."""

    code = 2


class Refused(OpError):
    code = 1


class NoAnswer(OpError):
    code = 3


class _Field:
    """One little-endian signal of a DBC message, read from the payload as an
    integer (the DBC's start bit, length, sign and scale)."""

    __slots__ = ("start", "mask", "signed", "scale", "sign_bit")

    def __init__(self, signal):
        self.start = signal.start
        self.mask = (1 << signal.length) - 1
        self.signed = signal.is_signed
        self.sign_bit = 1 << (signal.length - 1)
        self.scale = float(signal.scale)

    def raw(self, word: int) -> int:
        v = (word >> self.start) & self.mask
        if self.signed and v & self.sign_bit:
            v -= self.mask + 1
        return v

    def value(self, word: int) -> float:
        return self.raw(word) * self.scale


class _Reader:
    """Fast reader of a message's signals (the DBC's layout, no cantools call
    per frame: the status arrives every millisecond)."""

    def __init__(self, proto: pr.Protocol, name: str):
        m = proto.message(name)
        self.name = name
        self.frame_id = m.frame_id
        self.length = m.length
        self.fields = {s.name: _Field(s) for s in m.signals}

    def word(self, data: bytes) -> int:
        return int.from_bytes(data, "little")


@dataclass
class Status:
    """One CTRL_STATUS."""

    tick: int
    state: str
    faults: list[str]
    fault_bits: int
    cmd_rejected: bool
    drive_mode: str
    feedforward: bool
    estimate_valid: bool
    pose: list[float]
    force_mode: str = "OFF"  # force control: OFF, FORCE, GUIDE, RELEASE, HOLD
    contact: bool = False
    drives_starting: bool = False  # the CANopen master is still starting the drives (ENGAGE refused)
    force_unmeasured: list[int] = field(default_factory=list)  # legs (1-6) whose drive measures no force
    refusals: int = 0     # commands the controller refused since it started, modulo 8 (CTRL_STATUS Refusals)
    seq: int = 0          # how many statuses this node had received
    t: float = 0.0        # receive time (time.monotonic)
    stamp: float = 0.0    # the interface's receive timestamp (time.time() base)
    auth_last: int = -1   # CTRL_AUTH's LastCounter when this status came (-1: none heard yet)

    def line(self) -> str:
        faults = ",".join(self.faults) if self.faults else "none"
        pose = " ".join(f"{v:+.6f}" for v in self.pose)
        return (f"state {self.state}, faults {faults}, drives {self.drive_mode}, "
                f"feed-forward {'on' if self.feedforward else 'off'}, tick {self.tick}, "
                f"pose [{pose}]" + ("" if self.estimate_valid else " (no estimate)")
                + ("" if self.force_mode == "OFF" else
                   f", force control {self.force_mode}{' in contact' if self.contact else ''}")
                + (", drives starting (CANopen start-up)" if self.drives_starting else "")
                + (f", no cylinder force from leg(s) {','.join(map(str, self.force_unmeasured))}"
                   if self.force_unmeasured else ""))


@dataclass
class Counters:
    frames: dict[str, int] = field(default_factory=dict)
    lost: int = 0                 # controller frames missed (alive counters)
    bad: dict[str, int] = field(default_factory=dict)   # rejected frames by reason
    error_frames: int = 0
    heartbeats: int = 0
    sent: int = 0
    send_errors: int = 0


@dataclass
class Answer:
    """The controller's answer to a command."""

    command: str
    status: Status
    ticks: int | None            # status frames from the send to the first change
    seconds: float


def refusal_reason(command: str, before: Status | None, at: Status | None) -> str:
    """Why the controller refused, as far as its state tells."""
    st = at or before
    if st is None:
        return "no status from the controller"
    if "operator_silent" in st.faults and command in MOTION:
        return ("the operator-silent fault is latched (the link was silent while the platform ran): "
                "`stewart op reset` clears it")
    allowed = ACCEPTED_IN.get(command, ())
    state = st.state  # the refusing tick's (before's may be stale: sent before the queue emptied)
    if state not in allowed:
        return f"{command} is accepted in {'/'.join(allowed)} only; the controller was {state}"
    if command == "ENGAGE":
        if st.drives_starting:
            return ("the CANopen master is still starting the drives (configuring them by SDO, or a drive "
                    "not yet operational): wait for the start-up to end, then ENGAGE again")
        return "no pose estimate yet, or a drive not heard from"
    if command == "RUN_TRIG":
        return ("an end of the motion is outside the workspace or a leg's stroke, the frequency is outside "
                "(0, 10] Hz, its acceleration bound |A| (w^2 + 4 w / fade + 6 / fade^2) reaches 64 m/s^2 (rad/s^2), "
                "or the platform is not at home (the motion runs about home: `stewart op move 0 0 0 0 0 0 "
                "--relative` first)")
    if command == "MOVE_TO":
        return "the target is outside the workspace or a leg's stroke"
    if command == "RESET":
        return "a fault's cause is still present (a drive silent, or no pose estimate)"
    if command == "STREAM":
        return "a streamed target is outside the workspace or a leg's stroke"
    if command in ("FORCE", "GUIDE"):
        if st.force_mode in ("RELEASE", "HOLD"):
            return f"force control is {st.force_mode} (wait for it to end, or reset the fault)"
        why = ("a target beyond the controller's limits (8 kN, 1 kN m), an empty mask, or no valid wrench "
               "(the force/torque sensor not tared, or silent"
               + (f"; or, on the cylinders' estimate: the drive(s) of leg(s) "
                  f"{','.join(map(str, st.force_unmeasured))} measure no cylinder force" if st.force_unmeasured
                  else "") + ")")
        if st.force_mode != "OFF":
            why += f", or other axes than those of the {st.force_mode} in force"
        return why
    if command == "TARE":
        return "the sensor is tared in READY under position control, with the sensor as the wrench source"
    return "refused by the controller"


def _legs(mask: int) -> list[int]:
    """The legs (1-6) of a 6-bit leg mask."""
    return [i + 1 for i in range(6) if mask >> i & 1]


def _name(names, raw: int) -> str:
    return names[raw] if raw < len(names) else str(raw)


@dataclass
class _Progress:
    """What :meth:`OperatorNode.wait_for` has seen of the statuses since a
    command was sent."""

    command: str
    before: Status | None
    sent_wall: float
    sent_after: float            #: statuses stamped at or after this count as after the send
    signed: int | None           #: the signed command's counter (None: not signed)
    refusals: int | None         #: the count of refusals before the send
    prev_tick: int | None        #: Tick of the last status seen (gaps: statuses the queue dropped)
    first_change: int | None = None
    k: int = 0                   #: statuses stamped after the send
    k_after: int = 0
    taken_k: int | None = None   #: the first status at which the controller had the frame
    carried_out: bool = False    #: the command queue's depth of statuses after taken_k
    missed: int = 0

    def advance(self, st: Status, reject_window: int) -> bool:
        """Counts status ``st``; False if it was stamped before the send.
        Raises Refused when it tells of a refusal."""
        if self.prev_tick is not None and st.tick > self.prev_tick + 1:
            self.missed += st.tick - self.prev_tick - 1
        self.prev_tick = st.tick
        if st.stamp < self.sent_wall:
            self.refusals = st.refusals  # sent before the command was: its count cannot hold the refusal
            return False
        self.k += 1
        self.k_after += st.stamp >= self.sent_after
        command, before = self.command, self.before
        if st.cmd_rejected and not self.carried_out and self.k <= reject_window:
            raise Refused(f"{command} refused: {refusal_reason(command, before, st)}")
        if not self.carried_out and self.refusals is not None and st.refusals != self.refusals:
            raise Refused(f"{command} refused: {refusal_reason(command, before, st)} (CTRL_STATUS "
                          f"Refusals went from {self.refusals} to {st.refusals}; the status that said "
                          f"CmdRejected was not heard: {self.missed} status(es) missed since the send)")
        if self.first_change is None and before is not None and st.state != before.state:
            self.first_change = self.k
        if self.taken_k is None and self.k_after > 0 and (self.signed is None or st.auth_last >= self.signed):
            self.taken_k = self.k
        if self.taken_k is not None and self.k >= self.taken_k + COMMAND_QUEUE:
            self.carried_out = True
        return True


class OperatorNode:
    """The operator node on an open python-can bus."""

    def __init__(self, bus, proto: pr.Protocol | None = None, heartbeat: bool = True,
                 on_frame: Callable | None = None, key: bytes | None = None, monitor: bool = True,
                 rx_batch_s: float = 0.0):
        import can

        self._can = can
        self.bus = bus
        self.proto = proto or pr.Protocol()
        self.heartbeat_enabled = heartbeat
        self.on_frame = on_frame
        # > 0: the receive thread sleeps this long after each frame and then
        # takes what queued meanwhile in one go. A thread woken for every
        # frame of a 1 kHz bus spends most of its CPU time being woken; a
        # display (the console) does not need the frames sooner than this.
        self.rx_batch_s = float(rx_batch_s)
        self._status_r = _Reader(self.proto, "CTRL_STATUS")
        self._monitor_r = _Reader(self.proto, "CTRL_MONITOR")
        self._wrench_r = _Reader(self.proto, "CTRL_WRENCH")
        self._auth_r = _Reader(self.proto, "CTRL_AUTH")
        self._identity_r = _Reader(self.proto, "CTRL_IDENTITY")
        self._reach_r = _Reader(self.proto, "CTRL_REACH")
        self._frames_r = _Reader(self.proto, "CTRL_FRAMES")
        # CTRL_MONITOR (1 kHz) and CTRL_WRENCH (500 Hz) only for a node that
        # shows them (`monitor`): without, the receive queue carries ~1,100
        # frames a second instead of ~2,600, and a loaded machine's reader
        # keeps up with CTRL_STATUS, which every command's answer is read from
        wanted = (self._status_r, self._auth_r, self._identity_r, self._reach_r, self._frames_r) + (
            (self._monitor_r, self._wrench_r) if monitor else ())
        self._readers = {r.frame_id: r for r in wanted}
        self.signer = au.Signer(self.proto.db, key) if key is not None else None
        self._unsigned = au.Signer(self.proto.db, bytes(au.KEY_BYTES))  # which frames need a code
        self.auth: dict | None = None          # the last CTRL_AUTH
        self._auth_at_send: dict | None = None
        self._auth_stamp = 0.0                 # when the last CTRL_AUTH was received (time.time())
        self._signed_counter: int | None = None  # the counter of the last signed frame
        self._rx = {fid: e2e.E2EReceiver() for fid in self._readers}
        self._tx: dict[str, int] = {}
        self._cond = threading.Condition()
        self._send_lock = threading.Lock()
        self.status: Status | None = None
        self.statuses: list[Status] = []      # since the last mark (bounded)
        self._keep_statuses = False
        self.monitor: dict | None = None
        self.wrench: dict | None = None
        self.identity: dict | None = None      # the last CTRL_IDENTITY
        self._identity_seq = 0                 # CTRL_IDENTITY frames received
        self.frames: dict | None = None        # the last CTRL_FRAMES
        self._frames_seq = 0                   # CTRL_FRAMES frames received
        self._frames_stamp = 0.0               # when the last one reached the socket (time.time())
        self.reach_answers: dict[int, dict] = {}  # CTRL_REACH by Sequence
        self._reach_next = 0
        self.counters = Counters()
        self._seq = 0
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self.rx_error: str | None = None
        self._sent_mono = 0.0
        self._sent_after = 0.0
        self._mark_tick: int | None = None     # the newest status's Tick when the record began

    # -- life cycle --------------------------------------------------------
    def start(self) -> "OperatorNode":
        # only the controller's frames (kernel filters where the interface has them)
        try:
            self.bus.set_filters([{"can_id": fid, "can_mask": 0x7FF, "extended": False}
                                  for fid in self._readers])
        except (NotImplementedError, self._can.CanError, OSError):
            pass
        sock = getattr(self.bus, "socket", None)
        if sock is not None:  # SocketCAN: room for a slow start (2 MB, capped by net.core.rmem_max)
            # not beyond rmem_max (SO_RCVBUFFORCE): a reader that cannot
            # keep up with the controller's ~2,600 frames a second (Python
            # inside user-mode Linux on a loaded machine) would fall seconds
            # behind instead of losing old frames, and answer from stale ones
            import socket

            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
            except OSError:
                pass
        if self.heartbeat_enabled:
            self.send_heartbeat()
        t = threading.Thread(target=self._receive_loop, name="op-rx", daemon=True)
        t.start()
        self._threads.append(t)
        if self.heartbeat_enabled:
            h = threading.Thread(target=self._heartbeat_loop, name="op-heartbeat", daemon=True)
            h.start()
            self._threads.append(h)
        return self

    def close(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(timeout=1.0)
        try:
            self.bus.shutdown()
        except Exception:  # noqa: BLE001 - closing: nothing left to report
            pass

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    # -- sending -----------------------------------------------------------
    def _send(self, name: str, signals: dict) -> float:
        """Sends one frame; returns the time.time() just before the send."""
        counter = self._tx.get(name, 0)
        data = self.proto.encode(name, signals, counter)
        info = self.proto.infos[name]
        if self._unsigned.needs(info.frame_id, data):
            data = self._sign(name, info.frame_id, data)
        self._tx[name] = e2e.next_counter(counter)
        msg = self._can.Message(arbitration_id=info.frame_id, data=data, is_extended_id=False,
                                is_fd=True, bitrate_switch=True)
        with self._send_lock:
            wall = time.time()
            try:
                self.bus.send(msg, timeout=0.1)
            except (self._can.CanError, OSError) as e:
                self.counters.send_errors += 1
                raise OpError(f"cannot send {name}: {e}") from None
            self.counters.sent += 1
            self._sent_after = time.time()  # the frame is on the bus from here on
        return wall

    def _sign(self, name: str, frame_id: int, data: bytes) -> bytes:
        if self.signer is None:
            raise OpError(f"{name}: commands that start or change motion need the machine key "
                          f"(--key FILE or {au.KEY_ENV}); STOP, PARK and ESTOP do not")
        end = time.monotonic() + 1.0
        with self._cond:
            while self.signer.session is None:
                left = end - time.monotonic()
                if left <= 0:
                    raise NoAnswer(f"{name}: no CTRL_AUTH from the controller within 1 s "
                                   "(its session is needed to sign)")
                self._cond.wait(left)
            self._auth_at_send = dict(self.auth) if self.auth else None
            try:
                signed = self.signer.sign(frame_id, data)
                self._signed_counter = self.signer.counter
                return signed
            except au.AuthError as e:
                raise OpError(f"{name}: {e}") from None

    def auth_reason(self) -> str | None:
        """Why the controller rejected the last signed frame, as CTRL_AUTH
        tells (its counts rose since the send, or it has no key), or None."""
        a, b = self.auth, self._auth_at_send
        if a is None:
            return None
        if not a["key_set"]:
            return ("the controller has no machine key: it refuses every command that starts or changes "
                    "motion (sp_controller --key FILE)")
        if b is None:
            return None
        if a["bad_tag"] > b["bad_tag"]:
            return ("its authentication code did not check: this key is not the controller's "
                    "(or the frame was corrupted)")
        if a["replayed"] > b["replayed"]:
            return "it was taken for a replay (another operator process used the same counter): send it again"
        return None

    def send_heartbeat(self) -> None:
        self._send("OP_HEARTBEAT", {})
        self.counters.heartbeats += 1

    def _heartbeat_loop(self) -> None:
        nxt = time.monotonic()
        while not self._stop.is_set():
            nxt += HEARTBEAT_PERIOD_S
            try:
                self.send_heartbeat()
            except OpError:
                pass  # counted; the controller's supervision will tell
            delay = nxt - time.monotonic()
            if delay < -1.0:
                nxt = time.monotonic()
            self._stop.wait(max(0.0, delay))

    def send_command(self, command: str, *, axis: str | int = 0, amplitude: float = 0.0,
                     frequency: float = 0.0, fade_time: float = 0.0, option: int = 0) -> float:
        return self._send("OP_COMMAND", pr.command_signals(command, axis, amplitude, frequency,
                                                            fade_time, option))

    def send_target(self, pose) -> float:
        return self._send("OP_TARGET_POSE", pr.pose_to_signals(pose))

    def send_force(self, mask: int, target) -> float:
        """OP_FORCE: the mask and target of the next FORCE or GUIDE (in
        FORCE, a target update)."""
        return self._send("OP_FORCE", pr.force_signals(mask, target))

    def send_force_params(self, mask: int, mode: str, mass: float, damping: float, stiffness: float) -> float:
        """OP_FORCE_PARAMS: the admittance's parameters for the masked axes
        (taken by the controller in position control only)."""
        return self._send("OP_FORCE_PARAMS", pr.force_params_signals(mask, mode, mass, damping, stiffness))

    # -- receiving ---------------------------------------------------------
    def _bad(self, reason: str) -> None:
        self.counters.bad[reason] = self.counters.bad.get(reason, 0) + 1

    def _receive_loop(self) -> None:
        timeout = 0.05
        while not self._stop.is_set():
            try:
                msg = self.bus.recv(timeout=timeout)
            except (self._can.CanError, OSError, ValueError) as e:
                self.rx_error = str(e)
                with self._cond:
                    self._cond.notify_all()
                self._stop.wait(0.1)
                continue
            if msg is None:
                if timeout == 0.0:  # took all that had queued: let the next ones queue
                    timeout = 0.05
                    self._stop.wait(self.rx_batch_s)
                continue
            if self.on_frame is not None:
                self.on_frame(msg)
            self.handle(msg)
            if self.rx_batch_s > 0.0:
                timeout = 0.0

    def handle(self, msg) -> None:
        """Takes one received frame (the receive thread calls it)."""
        if msg.is_error_frame:
            self.counters.error_frames += 1
            return
        r = self._readers.get(msg.arbitration_id)
        if r is None:
            return
        data = bytes(msg.data)
        if len(data) != r.length:
            self._bad(pr.BAD_LENGTH)
            return
        if not e2e.crc_ok(r.frame_id, data):
            self._bad(pr.BAD_CRC)
            return
        w = r.word(data)
        f = r.fields
        # the alive counter is diagnostics here: a frame with a good CRC but
        # out of sequence (this process fell behind) is still the newest
        # word of the controller, so it is counted and used
        check = self._rx[r.frame_id].check(f["Counter"].raw(w))
        if not check.accepted:
            self._bad(check.status)
            if check.status == e2e.REPEATED:
                return
        self.counters.lost += check.lost
        self.counters.frames[r.name] = self.counters.frames.get(r.name, 0) + 1
        if r is self._status_r:
            bits = f["Faults"].raw(w)
            state = f["State"].raw(w)
            st = Status(
                tick=f["Tick"].raw(w), state=STATES[state] if state < len(STATES) else str(state),
                faults=pr.fault_names(bits, pr.CONTROLLER_FAULTS), fault_bits=bits,
                cmd_rejected=bool(f["CmdRejected"].raw(w)),
                drive_mode="ACTIVE" if f["DriveMode"].raw(w) else "HOLD",
                feedforward=bool(f["FeedForward"].raw(w)),
                estimate_valid=bool(f["EstimateValid"].raw(w)),
                pose=[f[n].value(w) for n in pr.POSE_SIGNALS],
                force_mode=_name(FORCE_MODES, f["ForceMode"].raw(w)), contact=bool(f["Contact"].raw(w)),
                drives_starting=bool(f["DrivesStarting"].raw(w)),
                force_unmeasured=_legs(f["ForceUnmeasured"].raw(w)), refusals=f["Refusals"].raw(w),
                auth_last=self.auth["last_counter"] if self.auth else -1, t=time.monotonic(),
                stamp=float(msg.timestamp) if msg.timestamp else time.time())
            with self._cond:
                self._seq += 1
                st.seq = self._seq
                self.status = st
                if self._keep_statuses and len(self.statuses) < 200_000:
                    self.statuses.append(st)
                self._cond.notify_all()
        elif r is self._monitor_r:
            self.monitor = {
                "tick": f["Tick"].raw(w),
                "reference": [f["Ref" + n].value(w) for n in pr.POSE_SIGNALS],
                "length_sp": [f[f"LengthSp_{i}"].value(w) for i in range(1, 7)],
                "force_ff": [f[f"ForceFf_{i}"].value(w) for i in range(1, 7)],
            }
        elif r is self._auth_r:
            a = {"session": f["Session"].raw(w), "last_counter": f["LastCounter"].raw(w),
                 "bad_tag": f["BadTag"].raw(w), "replayed": f["Replayed"].raw(w),
                 "key_set": bool(f["KeySet"].raw(w))}
            with self._cond:
                self.auth = a
                self._auth_stamp = float(msg.timestamp) if msg.timestamp else time.time()
                if self.signer is not None:
                    self.signer.follow(a["session"], a["last_counter"])
                self._cond.notify_all()
        elif r is self._identity_r:
            self._take_identity(f, w)
        elif r is self._reach_r:
            self._take_reach(f, w)
        elif r is self._frames_r:
            self._take_frames(f, w, float(msg.timestamp) if msg.timestamp else time.time())
        else:
            self.wrench = {"tick": f["Tick"].raw(w), "valid": bool(f["Valid"].raw(w)),
                           "wrench": [f[n].value(w) for n in pr.WRENCH_SIGNALS]}

    def _take_identity(self, f: dict, w: int) -> None:
        port = pr.value_names("CTRL_IDENTITY", "Port")
        p = f["Port"].raw(w)
        ident = {"version": f"{f['VersionMajor'].raw(w)}.{f['VersionMinor'].raw(w)}.{f['VersionPatch'].raw(w)}",
                 "port": port[p] if p < len(port) else str(p), "protocol_hash": f["ProtocolHash"].raw(w)}
        with self._cond:
            self.identity = ident
            self._identity_seq += 1
            self._cond.notify_all()

    def _take_reach(self, f: dict, w: int) -> None:
        verdicts = pr.value_names("CTRL_REACH", "Verdict")
        v = f["Verdict"].raw(w)
        a = {"sequence": f["Sequence"].raw(w), "verdict": verdicts[v] if v < len(verdicts) else str(v),
             "which": f["Which"].raw(w), "excess": f["Excess"].value(w),
             "force": [f[f"Force_{i}"].value(w) for i in range(1, 7)], "t": time.monotonic()}
        with self._cond:
            self.reach_answers[a["sequence"]] = a
            self._cond.notify_all()

    def _take_frames(self, f: dict, w: int, stamp: float) -> None:
        reasons = pr.value_names("CTRL_FRAMES", "LastRefusal")
        lr = f["LastRefusal"].raw(w)
        fr = {"tool": f["ToolIndex"].raw(w), "work": f["WorkIndex"].raw(w), "identity": bool(f["Identity"].raw(w)),
              "checksum": f["Checksum"].raw(w), "last_refusal": reasons[lr] if lr < len(reasons) else str(lr),
              "refused": {n: f[f"Refused{n}"].raw(w) for n in FRAME_REFUSALS}}
        with self._cond:
            self.frames = fr
            self._frames_seq += 1
            self._frames_stamp = stamp
            self._cond.notify_all()

    def wait_frames(self, timeout: float = 2.0, after: int | None = None) -> dict:
        """The first CTRL_FRAMES that reached the socket after the call (its
        kernel time stamp: a reader behind on a loaded machine still holds
        older ones in its queue, which are passed over), or the first after
        count ``after``."""
        now, end = time.time(), time.monotonic() + timeout
        with self._cond:
            seen = self._frames_seq if after is None else after
            while self._frames_seq <= seen or (after is None and self._frames_stamp < now):
                left = end - time.monotonic()
                if left <= 0 or self.rx_error:
                    raise NoAnswer(f"no CTRL_FRAMES from the controller within {timeout:g} s "
                                   "(does its firmware know frames?)")
                self._cond.wait(left)
            return dict(self.frames)

    def send_frame(self, op: str, kind: str, index: int, values=None) -> float:
        """OP_FRAME: SELECT slot ``index`` of ``kind`` ("TOOL" or "WORK"), or
        SET it to ``values`` [x, y, z, roll, pitch, yaw] (non-finite values go
        as the wire's not-a-number, which the controller refuses)."""
        sig = {"Op": op, "Kind": kind, "Index": int(index)}
        if values is not None:
            sig.update(pr.pose_to_signals([v if math.isfinite(v) else NOT_FINITE_WIRE for v in values]))
        return self._send("OP_FRAME", sig)

    def frame(self, op: str, kind: str, index: int, values=None, timeout: float = 10.0) -> dict:
        """Sends OP_FRAME and returns the CTRL_FRAMES that shows it taken
        (CTRL_FRAMES comes every 100 ticks); Refused (naming the reason) when
        a refusal count rose instead, or when nothing changed within
        ``timeout`` s."""
        before = self.wait_frames(timeout=timeout)
        if self.signer is not None:
            self.fresh_auth()
        if not self._tx.get("OP_FRAME"):
            # this sender's first OP_FRAME: the controller's alive-counter
            # check may drop it, so a NONE goes first
            self.send_frame("NONE", kind, 0)
            self.wait_status(timeout=2.0, after=self.status.seq if self.status else 0)
            if self.signer is not None:
                self.fresh_auth()
        key = "tool" if kind == "TOOL" else "work"
        with self._cond:
            seen = self._frames_seq
        self.send_frame(op, kind, index, values)
        end = time.monotonic() + timeout
        # this reader may lag (CTRL_FRAMES queued before the send read after
        # it): a change of the index is proof, an index that was already
        # right needs three CTRL_FRAMES (300 ticks) without a refusal
        need = 3 if before[key] == index else 1
        heard = 0
        while True:
            try:
                fr = self.wait_frames(timeout=max(0.05, end - time.monotonic()), after=seen)
            except NoAnswer:
                why = self.auth_reason()
                raise Refused(f"FRAME {op} {kind} {index}: not taken within {timeout:g} s"
                              + (f" ({why})" if why else "")) from None
            seen = self._frames_seq
            heard += 1
            rose = [n for n in FRAME_REFUSALS if fr["refused"][n] > before["refused"][n]]
            if rose:
                raise Refused(f"FRAME {op} {kind} {index} refused: {', '.join(rose)} "
                              f"({FRAME_REFUSAL_TEXT.get(rose[0], '')})")
            if fr[key] == index and heard >= need:
                return fr

    def reach(self, pose, timeout: float = 2.0, resend: float = 0.25) -> dict:
        """The reach query (OP_REACH) for a tool pose in the work frame; the
        controller's answer (CTRL_REACH): verdict, which, excess, force."""
        seq = self._reach_next
        self._reach_next = (seq + 1) % 256
        sig = {"Sequence": seq, **pr.pose_to_signals([v if math.isfinite(v) else NOT_FINITE_WIRE for v in pose])}
        end = time.monotonic() + timeout
        with self._cond:
            self.reach_answers.pop(seq, None)
        while True:
            sent = time.monotonic()
            self._send("OP_REACH", sig)
            until = min(end, sent + resend)
            with self._cond:
                while seq not in self.reach_answers:
                    left = until - time.monotonic()
                    if left <= 0 or self.rx_error:
                        break
                    self._cond.wait(left)
                if seq in self.reach_answers:
                    a = dict(self.reach_answers.pop(seq))
                    a["latency"] = a["t"] - sent
                    return a
            if time.monotonic() >= end:
                raise NoAnswer(f"REACH: no CTRL_REACH within {timeout:g} s")

    def identify(self, timeout: float = 2.0, resend: float = 0.25) -> dict:
        """Asks the controller what it is (OP_COMMAND IDENTIFY) and returns its
        answer, CTRL_IDENTITY's values: ``version`` "MAJOR.MINOR.PATCH",
        ``port`` and ``protocol_hash``. The request is sent again every
        ``resend`` s until an answer comes (a frame lost on the bus);
        NoAnswer after ``timeout`` s."""
        end = time.monotonic() + timeout
        with self._cond:
            seen = self._identity_seq
        while True:
            self.send_command("IDENTIFY")
            until = min(end, time.monotonic() + resend)
            with self._cond:
                while self._identity_seq == seen:
                    if self.rx_error:
                        raise OpError(f"receiving: {self.rx_error}")
                    left = until - time.monotonic()
                    if left <= 0:
                        break
                    self._cond.wait(left)
                if self._identity_seq != seen:
                    return dict(self.identity)
            if time.monotonic() >= end:
                raise NoAnswer(f"IDENTIFY: no CTRL_IDENTITY from the controller within {timeout:g} s "
                               "(is it running, is this the ops bus, and does its firmware know IDENTIFY?)")

    # -- waiting -----------------------------------------------------------
    def wait_status(self, timeout: float = 2.0, after: int = 0) -> Status:
        """The first status with seq > after."""
        end = time.monotonic() + timeout
        with self._cond:
            while self.status is None or self.status.seq <= after:
                if self.rx_error:
                    raise OpError(f"receiving: {self.rx_error}")
                left = end - time.monotonic()
                if left <= 0:
                    raise NoAnswer(f"no CTRL_STATUS from the controller within {timeout:g} s "
                                   "(is it running, and is this the ops bus?)")
                self._cond.wait(left)
            return self.status

    def fresh_auth(self, timeout: float = 5.0) -> None:
        """Waits for a CTRL_AUTH received after this call (every 10 ms), so
        that the counter of the next signed frame continues from the
        controller's newest LastCounter: another operator process may have
        signed frames since this one last heard (on a loaded machine its
        receive queue may hold older ones), and a counter at or below
        LastCounter is refused as a replay."""
        now, end = time.time(), time.monotonic() + timeout
        with self._cond:
            while self._auth_stamp < now:
                left = end - time.monotonic()
                if left <= 0:
                    return  # signed with the newest heard; a replay would be reported with its reason
                self._cond.wait(left)

    def _mark(self) -> int:
        with self._cond:
            self._mark_tick = self.status.tick if self.status is not None else None
            self.statuses = []
            self._keep_statuses = True
            return self._seq

    def wait_for(self, command: str, done: Callable[[Status], bool], timeout: float,
                 mark: int, before: Status | None, sent_wall: float,
                 reject_window: int = 50, settle: int = 5, taken_window: int = 1000) -> Answer:
        """Waits until `done(status)` holds once the controller has carried
        the command out, or a refusal.

        A refusal is told by CTRL_STATUS in two ways: CmdRejected on the one
        status of the tick that refused it, and Refusals, the controller's
        count of refused commands (modulo 8), kept on every later status.
        This node may miss the first (a reader that falls behind the
        controller's ~2,600 frames a second finds its receive queue full,
        and the kernel drops what comes next); the second cannot be missed:
        the command was refused when the count moved past the one of the
        last status received before the send.

        The command was carried out once the controller had it and the
        command queue's depth of statuses more came (one command executed
        per tick): had it is, for a signed command, CTRL_AUTH showing its
        counter accepted; for another, a status stamped after the send
        returned (the frame was on the bus by then; this process may be held
        up between its clock read and the send on a loaded machine). `done`
        is believed from then on, and not before `settle` statuses, so a
        command whose answer the state already showed (a second ENGAGE in
        READY) is never taken for done before its refusal could count. Only
        statuses the interface stamped after the send count, so a backlog
        of older frames in the receive queue cannot answer for it."""
        end = time.monotonic() + timeout
        signed = self._signed_counter if command not in au.Signer.EXEMPT_COMMANDS else None
        p = _Progress(command, before, sent_wall, max(self._sent_after, sent_wall), signed,
                      before.refusals if before is not None else None, self._mark_tick)
        idx = 0
        while True:
            batch, idx = self._statuses_from(idx, end, command, timeout, p.missed)
            for st in batch:
                if not p.advance(st, reject_window):
                    continue
                if p.first_change is None and signed is not None and p.k_after >= reject_window and (
                        p.taken_k is None or p.k_after == reject_window):
                    self._check_taken(p, st, done, final=p.k_after >= taken_window)
                if done(st) and p.carried_out and p.k >= settle:
                    self._keep_statuses = False
                    return Answer(command, st, p.first_change if p.first_change is not None else p.k,
                                  st.t - self._sent_mono)

    def _statuses_from(self, idx: int, end: float, command: str, timeout: float,
                       missed: int) -> tuple[list[Status], int]:
        """(the statuses kept from index ``idx`` on, the index after them),
        waiting for one until ``end`` (monotonic); raises NoAnswer then."""
        with self._cond:
            while idx >= len(self.statuses):
                if self.rx_error:
                    raise OpError(f"receiving: {self.rx_error}")
                left = end - time.monotonic()
                if left <= 0:
                    st = self.status
                    raise NoAnswer(f"{command}: no answer within {timeout:g} s"
                                   + (f" (state {st.state}; {missed} status(es) missed since the send)"
                                      if st else " (no status received)"))
                self._cond.wait(left)
            return self.statuses[idx:], len(self.statuses)

    def _check_taken(self, p: _Progress, st: Status, done: Callable[[Status], bool], final: bool) -> None:
        """With the state unchanged, from the end of the refusal window on: a
        signed command whose code CTRL_AUTH counted as bad or replayed, or
        one whose counter another process's went past, was rejected. At the
        end of the (longer) taken window: a signed command the controller
        never showed taken was lost. The two differ because a bridged bus
        (`stewart sim` through socketcand, a loaded machine) can take longer
        than the refusal window for the frame to reach the controller and
        its status to come back; only a reason CTRL_AUTH gives ends the wait
        early."""
        command = p.command
        if p.taken_k is None:
            why = self.auth_reason()
            if why is None and final:
                why = "the controller did not take it (CTRL_AUTH never showed its counter)"
            if why is not None:
                raise Refused(f"{command} rejected: {why}")
            return
        if not done(st):
            why = self.auth_reason()  # another process's counters went past this one's
            if why is not None:
                raise Refused(f"{command} rejected: {why}")

    def command(self, command: str, done: Callable[[Status], bool], timeout: float = 10.0,
                sync: bool = True, **signals) -> Answer:
        """Sends a command and waits for the answer (see :meth:`wait_for`)."""
        before = self.wait_status(timeout=2.0)
        if sync:
            self.send_command("NONE")
            self.wait_status(timeout=2.0, after=before.seq)
            before = self.status
        if self.signer is not None and command not in au.Signer.EXEMPT_COMMANDS:
            self.fresh_auth()
        mark = self._mark()
        sent_wall = self.send_command(command, **signals)
        self._sent_mono = time.monotonic()
        if command == "ESTOP":
            self.send_command("ESTOP")
        return self.wait_for(command, done, timeout, mark, before, sent_wall)
