# SPDX-License-Identifier: Apache-2.0
"""The one list of what the controller's CANopen master needs from a drive.

Every object the master reads, writes at start-up or maps into a PDO, per
device profile (CiA 408 fluid power, axis position control; CiA 402 cyclic
synchronous position), with its data type, how it is used and why. The
commands ``stewart drives check`` (does an EDS offer them?) and ``stewart
drives config`` (what the master would write) read it from here, docs/reference/canopen.md
describes it, and the firmware's generator is to read it too: nothing else
may repeat these numbers.

Standard library only. Facts about the profiles that are uncertain (they vary
between vendors or could not be confirmed from public material) are marked
``uncertain`` in the entry's purpose and in docs/reference/canopen.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: Protocols a drive may speak (``drives.legs[i].protocol`` in the platform config).
PROTOCOLS = ("native", "cia408", "cia402")
CANOPEN_PROTOCOLS = ("cia408", "cia402")

# CiA 301 basic data types, by their EDS DataType codes.
BOOLEAN = 0x0001
INTEGER8 = 0x0002
INTEGER16 = 0x0003
INTEGER32 = 0x0004
UNSIGNED8 = 0x0005
UNSIGNED16 = 0x0006
UNSIGNED32 = 0x0007
VISIBLE_STRING = 0x0009

TYPE_NAMES = {
    BOOLEAN: "BOOLEAN", INTEGER8: "INTEGER8", INTEGER16: "INTEGER16", INTEGER32: "INTEGER32",
    UNSIGNED8: "UNSIGNED8", UNSIGNED16: "UNSIGNED16", UNSIGNED32: "UNSIGNED32",
    VISIBLE_STRING: "VISIBLE_STRING",
}
TYPE_BITS = {BOOLEAN: 1, INTEGER8: 8, INTEGER16: 16, INTEGER32: 32, UNSIGNED8: 8, UNSIGNED16: 16,
             UNSIGNED32: 32}
SIGNED_TYPES = (INTEGER8, INTEGER16, INTEGER32)

# How the master uses an entry.
READ = "read"      # read by SDO (identity, status, read-back)
WRITE = "write"    # written by SDO at start-up, then read back
RPDO = "rpdo"      # mapped into a receive PDO of the drive (master -> drive, every SYNC)
TPDO = "tpdo"      # mapped into a transmit PDO of the drive (drive -> master, every SYNC)

# COB-ID bases of the CiA 301 predefined connection set (+ node id).
COB_EMCY = 0x080
COB_TPDO1 = 0x180
COB_RPDO1 = 0x200
COB_TPDO2 = 0x280
COB_SDO_TX = 0x580
COB_SDO_RX = 0x600
COB_HEARTBEAT = 0x700
COB_SYNC = 0x080   # node id 0
COB_NMT = 0x000

#: PDO COB-ID sub-index 1 bit 31: the PDO does not exist (disabled, mapping may change).
PDO_COB_INVALID = 0x80000000
#: PDO transmission type 1: synchronous, every SYNC (RPDO: applied at the next SYNC).
TRANSMISSION_SYNC_EVERY = 1

# SI unit and prefix codes (CiA 303-2) of the profile's "unit" and "prefix"
# sub-indices: metre = 0x01, prefixes are the decimal exponents as INTEGER8.
UNIT_METRE = 0x01


@dataclass(frozen=True)
class Entry:
    """One object dictionary entry (index, sub-index) the master uses."""

    index: int
    subindex: int
    name: str
    datatype: int
    use: str
    required: bool
    purpose: str

    @property
    def key(self) -> str:
        return f"0x{self.index:04X}.{self.subindex}"

    @property
    def type_name(self) -> str:
        return TYPE_NAMES.get(self.datatype, f"0x{self.datatype:04X}")

    @property
    def bits(self) -> int:
        return TYPE_BITS[self.datatype]

    def mapping_value(self) -> int:
        """The PDO mapping entry (UNSIGNED32): index << 16 | subindex << 8 | bit length."""
        return (self.index << 16) | (self.subindex << 8) | self.bits


@dataclass(frozen=True)
class Pdo:
    """One PDO of the drive as the master configures it (number 1 = 0x1400/0x1600
    or 0x1800/0x1A00)."""

    name: str
    direction: str          # "rx" (the drive receives) or "tx" (the drive transmits)
    number: int             # 1-based
    cob_base: int           # COB-ID = cob_base + node id
    entries: tuple[Entry, ...]
    required: bool
    purpose: str

    @property
    def comm_index(self) -> int:
        return (0x1400 if self.direction == "rx" else 0x1800) + self.number - 1

    @property
    def map_index(self) -> int:
        return (0x1600 if self.direction == "rx" else 0x1A00) + self.number - 1

    @property
    def data_bytes(self) -> int:
        return sum(e.bits for e in self.entries) // 8

    def cob_id(self, node_id: int) -> int:
        return self.cob_base + node_id


@dataclass(frozen=True)
class Profile:
    """What the master needs of a drive speaking one device profile."""

    name: str               # "cia408" / "cia402"
    number: int             # the profile number in 0x1000 bits 0..15
    title: str
    entries: tuple[Entry, ...]
    pdos: tuple[Pdo, ...]
    #: writes of the device/operating mode (index, sub-index, value) at start-up
    mode_writes: tuple[tuple[int, int, int], ...] = field(default_factory=tuple)

    def pdo(self, name: str) -> Pdo:
        for p in self.pdos:
            if p.name == name:
                return p
        raise KeyError(name)


# ---- CiA 301 communication objects every drive needs ------------------------

DEVICE_TYPE = Entry(0x1000, 0, "Device type", UNSIGNED32, READ, True,
                    "bits 0..15 name the device profile (408 or 402); scan and check read it")
ERROR_REGISTER = Entry(0x1001, 0, "Error register", UNSIGNED8, READ, True,
                       "mandatory in every CiA 301 device; read when an EMCY names no cause")
PRODUCER_HEARTBEAT = Entry(0x1017, 0, "Producer heartbeat time", UNSIGNED16, WRITE, True,
                           "ms; the master watches each drive's heartbeat (a silent drive is a latched fault)")
IDENTITY_COUNT = Entry(0x1018, 0, "Identity: highest sub-index", UNSIGNED8, READ, True,
                       "how many identity entries the drive has")
VENDOR_ID = Entry(0x1018, 1, "Identity: vendor-ID", UNSIGNED32, READ, True,
                  "scan lists it; the config may pin it")
PRODUCT_CODE = Entry(0x1018, 2, "Identity: product code", UNSIGNED32, READ, False,
                     "scan lists it")
REVISION = Entry(0x1018, 3, "Identity: revision number", UNSIGNED32, READ, False,
                 "scan lists it")
SERIAL = Entry(0x1018, 4, "Identity: serial number", UNSIGNED32, READ, False,
               "scan lists it; tells two drives of one type apart")
CONSUMER_HEARTBEAT = Entry(0x1016, 1, "Consumer heartbeat time 1", UNSIGNED32, WRITE, False,
                           "bits 16..22 the master's node id, 0..15 ms: the drive watches the master's "
                           "heartbeat (written where present)")
SYNC_COB_ID = Entry(0x1005, 0, "COB-ID SYNC", UNSIGNED32, READ, False,
                    "the drive consumes SYNC on 0x080 (the master produces it)")
CYCLE_PERIOD = Entry(0x1006, 0, "Communication cycle period", UNSIGNED32, WRITE, False,
                     "us; written where the drive has it, so that it can watch the SYNC itself")
EMCY_COB_ID = Entry(0x1014, 0, "COB-ID EMCY", UNSIGNED32, READ, False,
                    "the master consumes EMCY on 0x080 + node id")

COMMUNICATION = (DEVICE_TYPE, ERROR_REGISTER, PRODUCER_HEARTBEAT, IDENTITY_COUNT, VENDOR_ID,
                 PRODUCT_CODE, REVISION, SERIAL, CONSUMER_HEARTBEAT, SYNC_COB_ID, CYCLE_PERIOD, EMCY_COB_ID)

#: The master's own heartbeat (it has no object dictionary on the bus): the
#: defaults of its node id and period (the config's drives.master_node_id and
#: master_heartbeat_ms set them; a drive's consumer allows three periods).
MASTER_NODE_ID = 127


def _firmware_master_heartbeat_ms() -> int:
    """The period the firmware defines (SP_CO_MASTER_HEARTBEAT_MS in
    sp/canopen/canopen_master.h): the one source, read from the header."""
    import re

    from .. import resources

    header = resources.firmware_header("canopen_master.h")
    m = re.search(r"^#define\s+SP_CO_MASTER_HEARTBEAT_MS\s+(\d+)u?\b", header.read_text(), re.M)
    if m is None:
        raise RuntimeError(f"{header}: no SP_CO_MASTER_HEARTBEAT_MS definition")
    return int(m[1])


MASTER_HEARTBEAT_MS = _firmware_master_heartbeat_ms()

# PDO communication parameter sub-indices the master writes (0x1400.. / 0x1800..).
PDO_COMM_COB_ID = 1
PDO_COMM_TRANSMISSION_TYPE = 2
PDO_COMM_EVENT_TIMER = 5

# ---- CiA 408 (fluid power), axis position control ---------------------------

CONTROL_WORD = Entry(0x6040, 0, "Device control word", UNSIGNED16, RPDO, True,
                     "CiA 408: bit 0 disabled, 1 hold, 2 device mode active, 3 reset fault")
STATUS_WORD = Entry(0x6041, 0, "Device status word", UNSIGNED16, TPDO, True,
                    "CiA 408: bits 0..3 D, H, M, R give the device state; checked every tick")
DEVICE_MODE = Entry(0x6042, 0, "Device mode", INTEGER8, WRITE, True,
                    "1 = setpoint input via the bus")
CONTROL_MODE = Entry(0x6043, 0, "Device control mode", INTEGER8, WRITE, True,
                     "axis position control: 8 in the vendor manual consulted (uncertain across "
                     "vendors; the config's control_mode overrides it)")
POS_SETPOINT = Entry(0x6600, 1, "Axis position setpoint", INTEGER32, RPDO, True,
                     "the leg's position setpoint in the drive's units, applied at the next SYNC")
POS_SETPOINT_UNIT = Entry(0x6600, 2, "Axis position setpoint: unit", UNSIGNED8, WRITE, False,
                          "SI unit code (metre = 0x01); written where writable, else read and compared")
POS_SETPOINT_PREFIX = Entry(0x6600, 3, "Axis position setpoint: prefix", INTEGER8, WRITE, False,
                            "decimal exponent of the unit (-6 = micrometre); from the config's scaling")
POS_ACTUAL = Entry(0x6601, 1, "Axis position actual value", INTEGER32, TPDO, True,
                   "the leg's measured position in the drive's units, sampled at SYNC")
POS_ACTUAL_UNIT = Entry(0x6601, 2, "Axis position actual value: unit", UNSIGNED8, READ, False,
                        "compared with the setpoint's unit")
POS_ACTUAL_PREFIX = Entry(0x6601, 3, "Axis position actual value: prefix", INTEGER8, READ, False,
                          "compared with the setpoint's prefix")
# Chamber pressures: the controller's force model and wrench estimate use
# p_A A_A - p_B A_B. CiA 408 has pressure actual values, but where a
# vendor puts the two chamber pressures of an axis differs; the simulated
# drive offers them at 0x2110 (manufacturer range). Optional: without them
# the controller runs position-only (no measured force).
PRESSURE_A = Entry(0x2110, 1, "Chamber pressure A", UNSIGNED16, TPDO, False,
                   "kPa; force feedback (manufacturer-specific index, see docs/reference/canopen.md)")
PRESSURE_B = Entry(0x2110, 2, "Chamber pressure B", UNSIGNED16, TPDO, False,
                   "kPa; force feedback (manufacturer-specific index, see docs/reference/canopen.md)")

# Force feed-forward: CiA 408's axis position setpoint carries the position
# only, and the native protocol's force feed-forward halves the tracking
# error (docs/reference/canopen.md). The simulated drive takes it in a manufacturer
# object, mapped as RPDO1's third entry only where the config asks for it
# (drives.legs[i].force_feedforward); real valves run without it.
FORCE_FF = Entry(0x2120, 0, "Force feed-forward", INTEGER16, RPDO, False,
                 "daN along the position count; the inverse dynamics force, where the config asks for it "
                 "(manufacturer-specific, see docs/reference/canopen.md)")

CIA408_DEVICE_MODE_BUS = 1
CIA408_CONTROL_MODE_AXIS_POSITION = 8

# Control word bits (CiA 408 device state machine).
CW408_DISABLED = 0x0001
CW408_HOLD = 0x0002
CW408_ACTIVE = 0x0004
CW408_RESET = 0x0008
#: The control word the master sends for each requested device state.
CW408 = {"DISABLED": CW408_DISABLED, "HOLD": CW408_DISABLED | CW408_HOLD,
         "ACTIVE": CW408_DISABLED | CW408_HOLD | CW408_ACTIVE}
#: Status word bits 0..3 (R M H D) of each device state.
SW408_MASK = 0x000F
SW408 = {
    "NOT_READY": 0b0000,       # also FAULT_INIT: same bits, told apart by the EMCY before it
    "INIT": 0b1000,
    "DISABLED": 0b1001,
    "HOLD": 0b1011,
    "ACTIVE": 0b1111,
    "FAULT_DISABLED": 0b0001,
    "FAULT_HOLD": 0b0011,
    "FAULT_REACTION": 0b0111,
}

RPDO_SETPOINT_408 = Pdo("setpoint", "rx", 1, COB_RPDO1, (CONTROL_WORD, POS_SETPOINT), True,
                        "control word + position setpoint, every SYNC; its event timer is the "
                        "drive's own setpoint watchdog")
#: RPDO1 with the force feed-forward (8 bytes), instead of RPDO_SETPOINT_408
#: on a drive whose config sets force_feedforward.
RPDO_SETPOINT_408_FF = Pdo("setpoint", "rx", 1, COB_RPDO1, (CONTROL_WORD, POS_SETPOINT, FORCE_FF), False,
                           "control word + position setpoint + force feed-forward (vendor object), every SYNC")
TPDO_ACTUAL_408 = Pdo("actual", "tx", 1, COB_TPDO1, (STATUS_WORD, POS_ACTUAL), True,
                      "status word + measured position, after every SYNC")
TPDO_PRESSURES = Pdo("pressures", "tx", 2, COB_TPDO2, (PRESSURE_A, PRESSURE_B), False,
                     "chamber pressures A and B, after every SYNC (force feedback)")

CIA408 = Profile(
    "cia408", 408, "CiA 408 fluid power, axis position control",
    COMMUNICATION + (CONTROL_WORD, STATUS_WORD, DEVICE_MODE, CONTROL_MODE, POS_SETPOINT,
                     POS_SETPOINT_UNIT, POS_SETPOINT_PREFIX, POS_ACTUAL, POS_ACTUAL_UNIT,
                     POS_ACTUAL_PREFIX, PRESSURE_A, PRESSURE_B, FORCE_FF),
    (RPDO_SETPOINT_408, TPDO_ACTUAL_408, TPDO_PRESSURES),
    ((0x6042, 0, CIA408_DEVICE_MODE_BUS), (0x6043, 0, CIA408_CONTROL_MODE_AXIS_POSITION)),
)

# ---- CiA 402 (electric drives), cyclic synchronous position -----------------

CONTROLWORD_402 = Entry(0x6040, 0, "Controlword", UNSIGNED16, RPDO, True,
                        "CiA 402 state machine commands (shutdown, switch on, enable operation, "
                        "fault reset on bit 7's rising edge)")
STATUSWORD_402 = Entry(0x6041, 0, "Statusword", UNSIGNED16, TPDO, True,
                       "CiA 402 state (bits 0..3, 5, 6); checked every tick")
MODES_OF_OPERATION = Entry(0x6060, 0, "Modes of operation", INTEGER8, WRITE, True,
                           "8 = cyclic synchronous position")
MODES_DISPLAY = Entry(0x6061, 0, "Modes of operation display", INTEGER8, READ, True,
                      "read back: must show 8 before operation is enabled")
TARGET_POSITION = Entry(0x607A, 0, "Target position", INTEGER32, RPDO, True,
                        "the leg's position setpoint in the drive's position units")
POSITION_ACTUAL = Entry(0x6064, 0, "Position actual value", INTEGER32, TPDO, True,
                        "the leg's measured position in the drive's position units")
INTERP_PERIOD_VALUE = Entry(0x60C2, 1, "Interpolation time period: value", UNSIGNED8, WRITE, False,
                            "the SYNC period in units of 10^index s (1 with index -3 = 1 ms)")
INTERP_PERIOD_INDEX = Entry(0x60C2, 2, "Interpolation time period: index", INTEGER8, WRITE, False,
                            "-3: the value is in ms")
# The force feed-forward of cyclic synchronous position mode: a standard
# object (unlike CiA 408's), in per mille of the drive's rated torque or
# force (0x6076); the config gives that force along the leg
# (drives.legs[i].scaling.rated_force), mapped only where the config asks.
TORQUE_OFFSET = Entry(0x60B2, 0, "Torque offset", INTEGER16, RPDO, False,
                      "per mille of the rated torque/force (scaling.rated_force along the leg); the inverse "
                      "dynamics force, where the config asks for it")

CIA402_CSP = 8
CW402 = {"SHUTDOWN": 0x0006, "SWITCH_ON": 0x0007, "ENABLE_OPERATION": 0x000F,
         "DISABLE_VOLTAGE": 0x0000, "QUICK_STOP": 0x0002, "FAULT_RESET": 0x0080}
#: (mask, value) of each CiA 402 state in the statusword.
SW402 = {
    "NOT_READY_TO_SWITCH_ON": (0x004F, 0x0000),
    "SWITCH_ON_DISABLED": (0x004F, 0x0040),
    "READY_TO_SWITCH_ON": (0x006F, 0x0021),
    "SWITCHED_ON": (0x006F, 0x0023),
    "OPERATION_ENABLED": (0x006F, 0x0027),
    "QUICK_STOP_ACTIVE": (0x006F, 0x0007),
    "FAULT_REACTION_ACTIVE": (0x004F, 0x000F),
    "FAULT": (0x004F, 0x0008),
}

RPDO_SETPOINT_402 = Pdo("setpoint", "rx", 1, COB_RPDO1, (CONTROLWORD_402, TARGET_POSITION), True,
                        "controlword + target position, every SYNC; its event timer is the "
                        "drive's own setpoint watchdog")
#: RPDO1 with the torque/force offset (8 bytes), instead of
#: RPDO_SETPOINT_402 on a drive whose config sets force_feedforward.
RPDO_SETPOINT_402_FF = Pdo("setpoint", "rx", 1, COB_RPDO1, (CONTROLWORD_402, TARGET_POSITION, TORQUE_OFFSET),
                           False, "controlword + target position + torque/force offset, every SYNC")
TPDO_ACTUAL_402 = Pdo("actual", "tx", 1, COB_TPDO1, (STATUSWORD_402, POSITION_ACTUAL), True,
                      "statusword + position actual value, after every SYNC")

CIA402 = Profile(
    "cia402", 402, "CiA 402 cyclic synchronous position",
    COMMUNICATION + (CONTROLWORD_402, STATUSWORD_402, MODES_OF_OPERATION, MODES_DISPLAY,
                     TARGET_POSITION, POSITION_ACTUAL, INTERP_PERIOD_VALUE, INTERP_PERIOD_INDEX, TORQUE_OFFSET),
    (RPDO_SETPOINT_402, TPDO_ACTUAL_402),
    ((0x6060, 0, CIA402_CSP),),
)

PROFILES = {"cia408": CIA408, "cia402": CIA402}

#: NMT commands (CiA 301), first byte of the frame on COB-ID 0.
NMT_START = 0x01
NMT_STOP = 0x02
NMT_PRE_OPERATIONAL = 0x80
NMT_RESET_NODE = 0x81
NMT_RESET_COMMUNICATION = 0x82


def profile(name: str) -> Profile:
    """The profile of a protocol name; KeyError for ``native`` or unknown names."""
    return PROFILES[name]


def pdos_used(prof: Profile, pressure_feedback: bool, force_feedforward: bool = False) -> tuple[Pdo, ...]:
    """The PDOs the master configures on a drive of this profile (RPDO1 with
    the force feed-forward on a drive that is configured for it: CiA 408's
    vendor object, CiA 402's torque/force offset)."""
    out = tuple(p for p in prof.pdos if p.required or (pressure_feedback and p is TPDO_PRESSURES))
    if force_feedforward:
        ff = {id(RPDO_SETPOINT_408): RPDO_SETPOINT_408_FF, id(RPDO_SETPOINT_402): RPDO_SETPOINT_402_FF}
        out = tuple(ff.get(id(p), p) for p in out)
    return out


def entries_needed(prof: Profile, pressure_feedback: bool, force_feedforward: bool = False) -> tuple[Entry, ...]:
    """The entries a drive must offer: the required ones, plus the pressures
    when force feedback is asked for, and the force feed-forward object when
    it is configured."""
    wanted = {id(e) for p in pdos_used(prof, pressure_feedback, force_feedforward) for e in p.entries}
    return tuple(e for e in prof.entries if e.required or id(e) in wanted)
