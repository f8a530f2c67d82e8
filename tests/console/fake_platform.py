# SPDX-License-Identifier: Apache-2.0
"""A stand-in platform for the console's tests, until `stewart sim` serves
them: the controller's state machine in outline on any python-can bus
(the tests use ``udp_multicast``, which crosses processes), its ops-bus
frames (CTRL_STATUS and CTRL_MONITOR every 1 ms, CTRL_WRENCH every 2 ms,
CTRL_AUTH every 10 ms) with E2E counters and CRCs, the drives' feedback
and the force/torque sensor on the two drive buses (every 4 ms), the
authentication check of the signed commands with the suite's key, and the
operator supervision (no OP_HEARTBEAT for 200 ms while RUNNING or in
force control: OPERATOR_SILENT latched, the motion ended). Faults are
injected by lines on standard input (``fault drive``). Every ESTOP frame
received is printed with its receive time (``estop-rx T``), and so is
each operator-silent trip (``silent T last-heartbeat T``).

Run: ``python fake_platform.py --interface udp_multicast --ports P0,P1,P2``
(the three buses' ports) or ``--interface virtual --channels a,b,c``.
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time

import can
import numpy as np

from stewart import auth, config, model, resources
from stewart import protocol as pr

CMDS = pr.value_names("OP_COMMAND", "Command")
SESSION = 0x5EED0042
TIMEOUT_S = 0.200
BIT = {n: 1 << i for i, n in enumerate(pr.CONTROLLER_FAULTS)}


class Fake:
    def __init__(self, buses: dict, key: bytes):
        self.buses, self.key = buses, key
        self.proto = pr.Protocol()
        self.plat = config.load(resources.default_platform())
        self.home = np.array(self.plat.home)
        self.pose = np.array(self.plat.park)
        self.state, self.faults, self.ff, self.force_mode, self.contact = "IDLE", 0, 1, "OFF", 0
        self.motion = None  # callable t -> pose, with end time
        self.t_motion = 0.0
        self.refusals, self.tick, self.auth_last, self.bad_tag = 0, 0, 0, 0
        self.last_hb = None
        self.target = None
        self.checker = auth.Signer(self.proto.db, key)
        self.queue: list = []
        self.lock = threading.Lock()

    # -- receiving ---------------------------------------------------------
    def _authentic(self, fid: int, data: bytes) -> bool:
        c = self.checker
        if not c.needs(fid, data) or len(data) != self.proto.message(fid).length:
            return True
        cbyte, tbyte, tlen = c.layout[fid]
        low = int.from_bytes(data[cbyte:cbyte + 2], "little")
        full = self.auth_last + ((low - self.auth_last - 1) & 0xFFFF) + 1
        if data[tbyte:tbyte + tlen] != auth.tag_bytes(self.key, fid, SESSION, full, data[:tbyte], tlen):
            return False
        self.auth_last = full
        return True

    def _receive(self) -> None:
        bus = self.buses["ops"]
        while True:
            msg = bus.recv(timeout=0)
            if msg is None:
                return
            data = bytes(msg.data)
            if msg.arbitration_id == 0x040 and data and data[0] == CMDS.index("ESTOP"):
                print(f"estop-rx {time.time():.6f}", flush=True)
            if not self._authentic(msg.arbitration_id, data):
                self.bad_tag += 1
                continue
            r = self.proto.receive(msg.arbitration_id, data, bus="ops")
            if not r.ok:
                continue
            if r.name == "OP_HEARTBEAT":
                self.last_hb = time.monotonic()
            elif r.name == "OP_TARGET_POSE":
                self.target = np.array(pr.signals_to_pose(r.signals))
            elif r.name == "OP_COMMAND":
                self.queue.append(r.signals)

    # -- the state machine -------------------------------------------------
    def _ramp(self, to, seconds: float, then: str) -> None:
        start, to = self.pose.copy(), np.array(to)
        self.t_motion = time.monotonic()
        self.motion = (lambda t: start + (to - start) * min(1.0, t / seconds), seconds, then)

    def _command(self, name: str, s) -> bool:
        st = self.state
        if name in ("NONE", "IDENTIFY"):
            return True
        if name == "ESTOP":
            self.state, self.faults, self.motion, self.force_mode = "ESTOP", self.faults | BIT["estop"], None, "OFF"
            return True
        if name == "RESET" and st in ("FAULT", "ESTOP"):  # as the controller: RESET re-engages, home
            self.faults, self.state = 0, "ENGAGING"
            self._ramp(self.home, 0.4, "READY")
            return True
        if self.faults & BIT["operator_silent"] and name in ("ENGAGE", "RUN_TRIG", "MOVE_TO", "STREAM"):
            return False
        if name == "ENGAGE" and st == "IDLE":
            self.state = "ENGAGING"
            self._ramp(self.home, 0.4, "READY")
            return True
        if name == "PARK" and st in ("READY", "RUNNING"):
            self.state = "PARKING"
            self._ramp(self.plat.park, 0.4, "IDLE")
            return True
        if name == "MOVE_TO" and st == "READY" and self.target is not None:
            self.state = "RUNNING"
            self._ramp(self.target, 0.3, "READY")
            return True
        if name == "RUN_TRIG" and st == "READY":
            return self._run_trig(s)
        if name == "STOP" and st == "RUNNING":
            self._ramp(self.home, 0.2, "READY")
            return True
        return self._force_commands(name, st, s)

    def _run_trig(self, s) -> bool:
        axis, amp, freq = int(s["Axis"]), float(s["Amplitude"]), float(s["Frequency"])
        if not 0 < freq <= 10:
            return False
        self.state, self.t_motion = "RUNNING", time.monotonic()
        home = self.home.copy()

        def f(t):
            p = home.copy()
            p[axis] += amp * math.sin(2 * math.pi * freq * t) * min(1.0, t / 0.5)
            return p
        self.motion = (f, 1e9, "READY")
        return True

    def _force_commands(self, name: str, st: str, s) -> bool:
        if name == "SET_FEEDFORWARD" and st in ("IDLE", "READY"):
            self.ff = int(s["Option"])
            return True
        if name in ("FORCE", "GUIDE") and st in ("READY", "RUNNING"):
            self.force_mode, self.t_motion = name, time.monotonic()
            return True
        if name == "POSITION":
            self.force_mode, self.contact = "OFF", 0
            return True
        if name == "TARE" and st == "READY" and self.force_mode == "OFF":
            return True
        return False

    def inject(self, what: str) -> None:
        with self.lock:
            self.faults |= BIT.get(what, BIT["drive"])
            self.state, self.motion, self.force_mode = "FAULT", None, "OFF"

    def _supervise(self) -> None:
        active = self.state == "RUNNING" or self.force_mode != "OFF"
        if active and self.last_hb is not None and time.monotonic() - self.last_hb > TIMEOUT_S \
                and not self.faults & BIT["operator_silent"]:
            self.faults |= BIT["operator_silent"]
            print(f"silent {time.time():.6f} last-heartbeat-age {time.monotonic() - self.last_hb:.4f}", flush=True)
            self.force_mode, self.contact = "OFF", 0
            if self.state == "RUNNING":
                self._ramp(self.home, 0.2, "READY")

    def step(self) -> int:
        rejected = 0
        with self.lock:
            self._receive()
            if self.queue:
                s = self.queue.pop(0)
                rejected = 0 if self._command(CMDS[int(s["Command"])], s) else 1
                self.refusals = (self.refusals + rejected) % 8
            self._supervise()
            if self.motion is not None:
                f, end, then = self.motion
                t = time.monotonic() - self.t_motion
                self.pose = f(min(t, end))
                if t >= end:
                    self.motion, self.state = None, then
            if self.force_mode == "FORCE" and time.monotonic() - self.t_motion > 0.3:
                self.contact = 1
        return rejected

    # -- sending -----------------------------------------------------------
    def _send(self, bus: str, name: str, sig: dict, fd: bool = True) -> None:
        data = self.proto.encode(name, sig, bus=bus)
        fid = self.proto.message(name).frame_id
        self.buses[bus].send(can.Message(arbitration_id=fid, data=data, is_fd=fd, is_extended_id=False,
                                         bitrate_switch=fd))

    def publish(self, rejected: int) -> None:
        k = self.tick
        pose = [float(v) for v in self.pose]
        self._send("ops", "CTRL_STATUS", {
            "Tick": k, "State": self.state, "Faults": self.faults, "FkIterations": 1, "EstimateValid": 1,
            "CmdRejected": rejected, "Refusals": self.refusals, "DriveMode": 0 if self.state == "IDLE" else 1,
            "FeedForward": self.ff, "ForceMode": self.force_mode, "Contact": self.contact,
            **pr.pose_to_signals(pose)})
        lengths = model.inverse_kinematics(self.plat, self.pose).lengths
        if k % 2 == 0:
            mon = {"Tick": k, **pr.pose_to_signals(pose, "Ref")}
            for i in range(6):
                mon[f"LengthSp_{i + 1}"] = float(lengths[i])
                mon[f"ForceFf_{i + 1}"] = 4000.0 + 500.0 * math.sin(k / 300 + i)
            self._send("ops", "CTRL_MONITOR", mon)
        if k % 4 == 0:
            fz = -400.0 if self.contact else 0.0
            self._send("ops", "CTRL_WRENCH", {"Tick": k, "Valid": 1, "Fx": 0.0, "Fy": 0.0, "Fz": fz,
                                              "Mx": 0.0, "My": 0.0, "Mz": 0.0})
        if k % 10 == 0:
            self._send("ops", "CTRL_AUTH", {"Session": SESSION, "LastCounter": self.auth_last,
                                            "BadTag": self.bad_tag, "KeySet": 1})
        if k % 4 == 1:
            self._feedback(lengths)

    def _feedback(self, lengths) -> None:
        for leg in range(1, 7):
            bus, slot = pr.LEG_BUS[leg]
            self._send(bus, pr.feedback_name(slot), {
                "Length": float(lengths[leg - 1]), "State": 1 if self.state != "IDLE" else 0,
                "PressureA": 9.0e6 + 1e5 * leg, "PressureB": 5.0e6, "Faults": 0,
                "TickEcho": self.tick & 0xFFFF})
        self._send("axis_b", "FT_SENSOR", {"Fx": 0.0, "Fy": 0.0, "Fz": -400.0 if self.contact else 0.0,
                                           "Mx": 0.0, "My": 0.0, "Mz": 0.0, "Saturated": 0})

    def run(self, stop: threading.Event) -> None:
        nxt = time.monotonic()
        while not stop.is_set():
            self.tick += 1
            self.publish(self.step())
            nxt += 0.001
            d = nxt - time.monotonic()
            if d > 0:
                time.sleep(d)
            elif d < -0.05:
                nxt = time.monotonic()


def open_buses(interface: str, channels: list[str]) -> dict:
    names = ("ops", "axis_a", "axis_b")
    if interface == "udp_multicast":
        return {n: can.Bus(interface="udp_multicast", channel="239.74.163.2", port=int(p), fd=True,
                           receive_own_messages=False) for n, p in zip(names, channels)}
    return {n: can.Bus(interface=interface, channel=c, receive_own_messages=False) for n, c in zip(names, channels)}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--interface", default="udp_multicast")
    ap.add_argument("--channels", required=True, help="three, by commas: ops, axis_a, axis_b")
    args = ap.parse_args()
    buses = open_buses(args.interface, args.channels.split(","))
    fake = Fake(buses, auth.read_key(auth.key_file()))
    stop = threading.Event()
    t = threading.Thread(target=fake.run, args=(stop,), daemon=True)
    t.start()
    print("ready", flush=True)
    for line in sys.stdin:
        w = line.split()
        if w[:1] == ["fault"]:
            fake.inject(w[1] if len(w) > 1 else "drive")
        elif w[:1] == ["quit"]:
            break
    stop.set()
    t.join(1)
    for b in buses.values():
        b.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
