# SPDX-License-Identifier: Apache-2.0
"""The firmware's CANopen master against the ``canopen`` library's node (issue 18).

The master is the core's C code (``sp/canopen/canopen_master.h``, loaded from the
host-release shared library over ctypes); the drives are ``canopen.LocalNode``
objects built from our EDS, an implementation we did not write, on
python-can's ``virtual`` interface. A loop moves frames between the bus and
the master once per millisecond of wall time.

What the library leaves to its application is done by a small glue
(``LibDrive``): the boot-up after an NMT reset (LocalNode changes state but
sends nothing), and the device side of the PDOs (on SYNC: the status word
following the control word, and TPDO1). Everything the master configures
goes through the library's SDO server and is checked in its dictionary.

- Start-up: three drives configured (every final value of the plan is in
  the library's dictionary), operational (NMT start seen by the library,
  heartbeat from the library's producer), ready in DISABLED, then ACTIVE.
- An SDO abort raised by the library's write callback: a named fault with
  the object and the abort code; no drive is asked beyond DISABLED.
- An EMCY from the library's producer: a named fault with its code.
- The library's heartbeat stopped: HEARTBEAT_LOST.
"""

from __future__ import annotations

import ctypes as C
import itertools
import time
from pathlib import Path

import can
import canopen
import pytest

from stewart import core

REPO_ROOT = Path(__file__).resolve().parents[2]

EDS = REPO_ROOT / "config" / "eds" / "stewart_sim_drive.eds"
_channels = itertools.count()

MAX_NODES = 6
MAX_TX = 24
REQ_DISABLED, REQ_HOLD, REQ_ACTIVE = 0, 1, 2
PHASE_RUN, PHASE_FAILED = 6, 7
F_SDO_ABORT, F_HEARTBEAT_LOST, F_EMCY = 2, 7, 9


class Frame(C.Structure):
    _fields_ = [("id", C.c_uint32), ("bus", C.c_uint8), ("len", C.c_uint8), ("flags", C.c_uint8),
                ("data", C.c_uint8 * 64)]


class NodeCfg(C.Structure):
    _fields_ = [("node_id", C.c_uint8), ("bus", C.c_uint8), ("leg", C.c_uint8), ("control_mode", C.c_int8),
                ("write_prefix", C.c_uint8), ("unit_prefix", C.c_int8), ("force_ff", C.c_uint8),
                ("profile", C.c_uint8), ("disable_on_block", C.c_uint8)]


class Cfg(C.Structure):
    _fields_ = [("node", NodeCfg * MAX_NODES), ("n_nodes", C.c_uint8), ("sync_divider", C.c_uint8),
                ("pressure_feedback", C.c_uint8), ("heartbeat_ms", C.c_uint16),
                ("heartbeat_timeout_ms", C.c_uint16), ("setpoint_timeout_ms", C.c_uint16),
                ("boot_timeout_ms", C.c_uint16), ("sdo_timeout_ms", C.c_uint16),
                ("state_timeout_ms", C.c_uint16), ("pdo_timeout_ms", C.c_uint16),
                ("master_heartbeat_ms", C.c_uint16), ("master_node_id", C.c_uint8)]


class Input(C.Structure):
    _fields_ = [("now_ms", C.c_uint32), ("request", C.c_uint8), ("block", C.c_uint8), ("setpoint", C.c_int32 * MAX_NODES),
                ("force_ff", C.c_int16 * MAX_NODES)]


class Output(C.Structure):
    _fields_ = [("tx", Frame * MAX_TX), ("n_tx", C.c_uint8), ("sync", C.c_uint8), ("ready", C.c_uint8),
                ("all_running", C.c_uint8), ("fault_mask", C.c_uint8)]


class Fault(C.Structure):
    _fields_ = [("code", C.c_uint8), ("sub", C.c_uint8), ("index", C.c_uint16), ("detail", C.c_uint32),
                ("expect", C.c_uint32), ("time_ms", C.c_uint32)]


class WriteEntry(C.Structure):
    _fields_ = [("index", C.c_uint16), ("sub", C.c_uint8), ("size", C.c_uint8), ("value", C.c_uint32),
                ("final", C.c_uint8), ("optional", C.c_uint8)]


@pytest.fixture(scope="module")
def L():
    try:
        lib = core.lib()
    except core.CoreError as e:
        pytest.skip(str(e))
    P = C.POINTER
    lib.sp_co_master_cfg_default.argtypes = [P(Cfg), C.c_uint8]
    lib.sp_co_master_init.argtypes = [C.c_void_p]
    lib.sp_co_master_start.argtypes = [C.c_void_p, P(Cfg), C.c_uint32]
    lib.sp_co_master_receive.argtypes = [C.c_void_p, P(Cfg), P(Frame), C.c_uint32]
    lib.sp_co_master_step.argtypes = [C.c_void_p, P(Cfg), P(Input), P(Output)]
    lib.sp_co_master_node_state.argtypes = [C.c_void_p, C.c_uint8, P(C.c_uint8), P(Fault)]
    lib.sp_co_plan_build.argtypes = [P(Cfg), C.c_uint8, P(WriteEntry * 32), P(C.c_uint8)]
    lib.sp_co_fault_name.argtypes = [C.c_int]
    lib.sp_co_fault_name.restype = C.c_char_p
    lib.sp_co_sdo_abort_name.argtypes = [C.c_uint32]
    lib.sp_co_sdo_abort_name.restype = C.c_char_p
    lib.sp_co_emcy_class_name.argtypes = [C.c_uint16]
    lib.sp_co_emcy_class_name.restype = C.c_char_p
    return lib


class LibDrive:
    """canopen.LocalNode from our EDS plus the glue the library leaves to its application."""

    def __init__(self, net: canopen.Network, node_id: int):
        self.node = canopen.LocalNode(node_id, canopen.import_od(str(EDS), node_id))
        net.add_node(self.node)
        self.net = net
        self.id = node_id
        self.control = 0
        self.status = 0x0008  # INIT
        net.subscribe(0, self._nmt)
        net.subscribe(0x080, self._sync)
        net.subscribe(0x200 + node_id, self._rpdo)

    def _nmt(self, can_id, data, ts):
        if data[1] in (0, self.id) and data[0] in (0x81, 0x82):
            # the library only changes state; a real node boots: boot-up, then pre-operational
            self.node.nmt.send_command(0x82)
            self.node.nmt.send_command(0x80)

    def _rpdo(self, can_id, data, ts):
        self.control = int.from_bytes(data[0:2], "little")

    def _sync(self, can_id, data, ts):
        if self.node.nmt.state != "OPERATIONAL":
            return
        want = {0x1: 0x9, 0x3: 0xB, 0x7: 0xF}.get(self.control & 0x7, 0x8)
        self.status = want
        self.net.send_message(0x180 + self.id, self.status.to_bytes(2, "little") + (1234).to_bytes(4, "little"))

    def value(self, index: int, sub: int) -> int:
        return int.from_bytes(self.node.get_data(index, sub), "little")


class Rig:
    def __init__(self, L, node_ids=(1, 2, 3)):
        self.L = L
        self.channel = f"stewart-co-interop-{next(_channels)}"
        self.net = canopen.Network()
        self.net.connect(interface="virtual", channel=self.channel, receive_own_messages=False)
        self.drives = [LibDrive(self.net, i) for i in node_ids]
        self.bus = can.Bus(interface="virtual", channel=self.channel)  # the master's port
        self.cfg = Cfg()
        assert L.sp_co_master_cfg_default(C.byref(self.cfg), len(node_ids)) == 0
        for k, i in enumerate(node_ids):
            self.cfg.node[k].node_id = i
            self.cfg.node[k].bus = 1
        # wall-clock loop in Python: generous timeouts against scheduling jitter
        self.cfg.heartbeat_timeout_ms = 200
        self.cfg.pdo_timeout_ms = 200
        self.cfg.sdo_timeout_ms = 500
        self.cfg.boot_timeout_ms = 1000
        self.cfg.state_timeout_ms = 500
        self.m = C.create_string_buffer(8192)
        self.inp = Input()
        self.out = Output()
        self.t0 = time.monotonic()
        assert L.sp_co_master_init(self.m) == 0
        assert L.sp_co_master_start(self.m, C.byref(self.cfg), self.now()) == 0

    def now(self) -> int:
        return int((time.monotonic() - self.t0) * 1000) + 1

    def tick(self):
        now = self.now()
        while (msg := self.bus.recv(0)) is not None:
            f = Frame(id=msg.arbitration_id, bus=1, len=msg.dlc)
            for i, b in enumerate(msg.data):
                f.data[i] = b
            self.L.sp_co_master_receive(self.m, C.byref(self.cfg), C.byref(f), now)
        self.inp.now_ms = now
        assert self.L.sp_co_master_step(self.m, C.byref(self.cfg), C.byref(self.inp), C.byref(self.out)) == 0
        for f in self.out.tx[: self.out.n_tx]:
            self.bus.send(can.Message(arbitration_id=f.id, data=bytes(f.data[: f.len]), is_extended_id=False))
        time.sleep(0.001)

    def run_until(self, cond, seconds: float) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.tick()
            if cond():
                return True
        return False

    def node_state(self, k: int) -> tuple[int, Fault]:
        phase, fault = C.c_uint8(), Fault()
        assert self.L.sp_co_master_node_state(self.m, k, C.byref(phase), C.byref(fault)) == 0
        return phase.value, fault

    def close(self):
        for d in self.drives:
            d.node.nmt.stop_heartbeat()
        self.bus.shutdown()
        self.net.disconnect()


@pytest.fixture
def rig(L):
    r = Rig(L)
    yield r
    r.close()


def test_master_configures_and_starts_library_nodes(rig, L):
    assert rig.run_until(lambda: rig.out.ready, 5.0), [rig.node_state(k)[0] for k in range(3)]
    assert rig.out.fault_mask == 0
    for k, d in enumerate(rig.drives):
        assert d.node.nmt.state == "OPERATIONAL"
        plan, n = (WriteEntry * 32)(), C.c_uint8()
        assert L.sp_co_plan_build(C.byref(rig.cfg), k, C.byref(plan), C.byref(n)) == 0
        assert n.value == 29
        for w in plan[: n.value]:
            if w.final:
                assert d.value(w.index, w.sub) == w.value, f"node {d.id} 0x{w.index:04X}.{w.sub}"
        assert d.value(0x1400, 5) == rig.cfg.setpoint_timeout_ms
        assert d.status == 0x9  # DISABLED
    rig.inp.request = REQ_ACTIVE
    rig.tick()
    assert rig.run_until(lambda: rig.out.ready, 2.0)
    assert all(d.status == 0xF for d in rig.drives)


def test_sdo_abort_from_the_library_is_a_named_fault(rig, L):
    def refuse(index, subindex, od, data):
        if index == 0x6043:
            raise canopen.sdo.SdoAbortedError(0x06090030)

    rig.drives[1].node.add_write_callback(refuse)
    rig.inp.request = REQ_ACTIVE
    assert rig.run_until(lambda: rig.out.fault_mask != 0, 5.0)
    assert rig.out.fault_mask == 1 << 1
    phase, fault = rig.node_state(1)
    assert phase == PHASE_FAILED
    assert L.sp_co_fault_name(fault.code) == b"SDO abort"
    assert (fault.index, fault.sub, fault.detail) == (0x6043, 0, 0x06090030)
    assert L.sp_co_sdo_abort_name(fault.detail) == b"value range of parameter exceeded"
    rig.run_until(lambda: False, 0.3)
    assert not rig.out.ready
    assert all(d.control in (0, 0x1) for d in rig.drives)  # never more than DISABLED


def test_emcy_from_the_library_is_a_named_fault(rig, L):
    assert rig.run_until(lambda: rig.out.ready, 5.0)
    rig.drives[2].node.emcy.send(0x4210, 0x09)
    assert rig.run_until(lambda: rig.out.fault_mask != 0, 1.0)
    _, fault = rig.node_state(2)
    assert L.sp_co_fault_name(fault.code) == b"EMCY"
    assert fault.index == 0x4210 and fault.detail == 0x09
    assert L.sp_co_emcy_class_name(fault.index) == b"temperature"


def test_heartbeat_stopped_in_the_library_is_heartbeat_lost(rig, L):
    assert rig.run_until(lambda: rig.out.ready, 5.0)
    rig.drives[0].node.nmt.stop_heartbeat()
    t = time.monotonic()
    assert rig.run_until(lambda: rig.out.fault_mask != 0, 2.0)
    _, fault = rig.node_state(0)
    assert L.sp_co_fault_name(fault.code) == b"heartbeat lost"
    assert fault.expect == rig.cfg.heartbeat_timeout_ms
    # detected after the configured timeout (wall clock: the loop's jitter on top)
    assert 0.15 <= time.monotonic() - t < 1.0


@pytest.mark.parametrize("pressure,divider,timeout,mode,ff,protocol", [
    (True, 1, 3, 8, False, "cia408"), (False, 3, 9, 9, False, "cia408"), (True, 2, 6, 8, True, "cia408"),
    (True, 1, 3, 8, False, "cia402"), (False, 3, 9, 8, False, "cia402")])
def test_the_c_plan_is_the_pc_plan(L, pressure, divider, timeout, mode, ff, protocol):
    """sp_co_plan_build writes what tools/stewart/drives/plan.py (the PC's
    `stewart drives config`) writes, in the same order: one plan, two languages."""
    from stewart.drives import plan as pc_plan
    from stewart.drives.layout import Drive, Drives, Scaling

    drive = Drive(1, protocol, "can_a", node_id=21, scaling=Scaling(1e-6, 1.85), control_mode=mode,
                  force_feedforward=ff)
    drives = Drives((drive,), {"can_a": 1_000_000}, sync_divider=divider, setpoint_timeout_ms=timeout,
                    pressure_feedback=pressure)
    want = pc_plan.drive_writes(drive, drives)
    cfg = Cfg()
    assert L.sp_co_master_cfg_default(C.byref(cfg), 1) == 0
    cfg.node[0].node_id = 21
    cfg.node[0].control_mode = mode
    cfg.node[0].force_ff = int(ff)
    cfg.node[0].profile = 1 if protocol == "cia402" else 0
    cfg.pressure_feedback = int(pressure)
    cfg.sync_divider = divider
    cfg.setpoint_timeout_ms = timeout
    got, n = (WriteEntry * 32)(), C.c_uint8()
    assert L.sp_co_plan_build(C.byref(cfg), 0, C.byref(got), C.byref(n)) == 0
    assert n.value == len(want)
    for g, w in zip(got[: n.value], want):
        size = {1: 1, 2: 1, 3: 2, 4: 4, 5: 1, 6: 2, 7: 4}[w.datatype]
        assert (g.index, g.sub, g.size, g.value, bool(g.final), bool(g.optional)) == (
            w.index, w.subindex, size, w.value & ((1 << (8 * size)) - 1), w.final, w.optional), w.purpose
