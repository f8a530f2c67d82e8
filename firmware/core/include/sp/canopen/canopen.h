/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/canopen/canopen.h - CANopen (CiA 301) frames and the CiA 408 device state
 * machine, as pure functions over sp_can_frame_t (docs/reference/canopen.md).
 *
 * Classic CAN, 11-bit identifiers, the predefined connection set: COB-ID =
 * function base + node id (1..127). Multi-byte values are little-endian.
 * These functions build and parse single frames; the master that uses them
 * (start-up, heartbeat and EMCY consumers, PDO cycle) is sp/canopen/canopen_master.h.
 *
 * Every frame built here is classic (len <= 8, flags 0): its data[0..8) is
 * written, zero past len; data[8..64), which no classic frame carries and no
 * port sends, is left as it was (clearing it costs more than the rest of
 * the frame on the M4).
 *
 * Every builder returns SP_E_ARG for a NULL frame, a node id outside 1..127
 * or a bus index >= SP_CAN_BUSES, and leaves the frame untouched then. Every
 * parser returns SP_E_FRAME for a frame of the wrong identifier or length and
 * leaves its outputs untouched then. Nothing here saturates or wraps: all
 * values are carried bit for bit.
 */
#ifndef SP_CANOPEN_H
#define SP_CANOPEN_H

#include <stdint.h>

#include "sp/link/can.h"
#include "sp/math/status.h"

/* COB-ID function bases (CiA 301 predefined connection set). */
#define SP_CO_COB_NMT 0x000u       /**< NMT command, master -> all */
#define SP_CO_COB_SYNC 0x080u      /**< SYNC, no data */
#define SP_CO_COB_EMCY 0x080u      /**< + node id: emergency */
#define SP_CO_COB_TPDO1 0x180u     /**< + node id: status word, actual position */
#define SP_CO_COB_RPDO1 0x200u     /**< + node id: control word, position setpoint */
#define SP_CO_COB_TPDO2 0x280u     /**< + node id: chamber pressures A, B */
#define SP_CO_COB_SDO_TX 0x580u    /**< + node id: SDO server -> client (the drive answers) */
#define SP_CO_COB_SDO_RX 0x600u    /**< + node id: SDO client -> server (the master asks) */
#define SP_CO_COB_HEARTBEAT 0x700u /**< + node id: heartbeat and boot-up */

#define SP_CO_NODE_MIN 1u
#define SP_CO_NODE_MAX 127u

/** NMT commands (first byte of the NMT frame). */
typedef enum {
    SP_CO_NMT_START = 0x01,      /**< -> operational */
    SP_CO_NMT_STOP = 0x02,       /**< -> stopped */
    SP_CO_NMT_PREOP = 0x80,      /**< -> pre-operational */
    SP_CO_NMT_RESET_NODE = 0x81, /**< reset application (boots again) */
    SP_CO_NMT_RESET_COMM = 0x82  /**< reset communication (boots again) */
} sp_co_nmt_cmd_t;

/** NMT states as a heartbeat reports them (bit 7, the toggle, masked off). */
typedef enum {
    SP_CO_NMT_STATE_BOOTUP = 0x00,
    SP_CO_NMT_STATE_STOPPED = 0x04,
    SP_CO_NMT_STATE_OPERATIONAL = 0x05,
    SP_CO_NMT_STATE_PREOP = 0x7F
} sp_co_nmt_state_t;

/** NMT command frame to one node (node 1..127) on a bus. */
sp_status_t sp_co_nmt_frame(sp_can_frame_t *f, uint8_t bus, sp_co_nmt_cmd_t cmd, uint8_t node);

/** SYNC frame (COB-ID 0x080, no data, no counter) on a bus. */
sp_status_t sp_co_sync_frame(sp_can_frame_t *f, uint8_t bus);

/** Heartbeat (or boot-up, state 0) frame of a node: 0x700 + node, 1 byte. */
sp_status_t sp_co_heartbeat_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, sp_co_nmt_state_t state);

/** The node id (1..127) of a frame whose COB-ID is base + node id, or 0 when
 *  the identifier is not in base + 1..127. */
uint8_t sp_co_node_of(const sp_can_frame_t *f, uint32_t base);

/** A heartbeat or boot-up frame's NMT state (toggle bit masked off).
 *  SP_E_FRAME unless the identifier is 0x701..0x77F with 1 byte. */
sp_status_t sp_co_heartbeat_parse(const sp_can_frame_t *f, uint8_t *node, uint8_t *state);

/* ---- PDOs of the CiA 408 axis position layout (docs/reference/canopen.md) ---- */

/** RPDO1: control word (0x6040, u16) + axis position setpoint (0x6600.1, i32
 *  in the drive's counts); 6 bytes on 0x200 + node. */
sp_status_t sp_co_rpdo1_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t control, int32_t setpoint);

/** Parses RPDO1 (the drive's side). */
sp_status_t sp_co_rpdo1_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *control, int32_t *setpoint);

/** The simulated drive's vendor-specific force feed-forward (0x2120.0,
 *  INTEGER16, daN = 10 N, along the drive's position count), mapped as
 *  RPDO1's third entry where the config asks for it (docs/reference/canopen.md):
 *  CiA 408's axis position setpoint has no force. */
#define SP_CO_FORCE_FF_INDEX 0x2120u
#define SP_CO_FORCE_FF_MAPPING 0x21200010u

/** CiA 402's torque/force offset (0x60B2.0, INTEGER16, per mille of the
 *  drive's rated torque or force): the force feed-forward of cyclic
 *  synchronous position mode, RPDO1's third entry where the config asks
 *  for it (the bytes of sp_co_rpdo1_ff_frame). The rated force of the
 *  scaling (sp_co_scaling_t.rated_force_n) is bounded to
 *  SP_CO_RATED_FORCE_MIN_N..SP_CO_RATED_FORCE_MAX_N N. */
#define SP_CO402_FORCE_FF_INDEX 0x60B2u
#define SP_CO402_FORCE_FF_MAPPING 0x60B20010u
#define SP_CO_RATED_FORCE_MIN_N 100u
#define SP_CO_RATED_FORCE_MAX_N 10000000u

/** RPDO1 with the force feed-forward: control word, position setpoint and
 *  0x2120.0 (i16, daN); 8 bytes on 0x200 + node. */
sp_status_t sp_co_rpdo1_ff_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t control, int32_t setpoint,
                                 int16_t force_dan);

/** Parses the 8-byte RPDO1 with the force feed-forward (the drive's side). */
sp_status_t sp_co_rpdo1_ff_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *control, int32_t *setpoint,
                                 int16_t *force_dan);

/** TPDO1: status word (0x6041, u16) + axis position actual value (0x6601.1,
 *  i32 counts); 6 bytes on 0x180 + node. */
sp_status_t sp_co_tpdo1_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t status, int32_t actual);

/** Parses TPDO1. */
sp_status_t sp_co_tpdo1_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *status, int32_t *actual);

/** TPDO2: chamber pressures A and B (0x2110.1/.2, u16, kPa); 4 bytes on 0x280 + node. */
sp_status_t sp_co_tpdo2_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t pa_kpa, uint16_t pb_kpa);

/** Parses TPDO2. */
sp_status_t sp_co_tpdo2_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *pa_kpa, uint16_t *pb_kpa);

/* ---- EMCY ---- */

/** EMCY frame: 0x080 + node, 8 bytes: error code (u16), error register
 *  (0x1001), five manufacturer bytes (zero here). */
sp_status_t sp_co_emcy_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t code, uint8_t reg);

/** Parses an EMCY (0x081..0x0FF, at least 3 bytes: a shorter one is malformed). */
sp_status_t sp_co_emcy_parse(const sp_can_frame_t *f, uint8_t *node, uint16_t *code, uint8_t *reg);

/** The CiA 301 class of an EMCY error code, by name: "error reset",
 *  "generic", "current", "voltage", "temperature", "device hardware",
 *  "device software", "additional modules", "monitoring", "communication"
 *  (0x81xx), "protocol" (0x82xx, e.g. 0x8250 RPDO timeout), "external",
 *  "additional functions", "device specific". Never NULL. */
const char *sp_co_emcy_class_name(uint16_t code);

/* ---- SDO (expedited transfers; CiA 301 7.2.4) ---- */

#define SP_CO_SDO_ABORT_NO_OBJECT 0x06020000u   /**< object does not exist */
#define SP_CO_SDO_ABORT_NO_SUBINDEX 0x06090011u /**< sub-index does not exist */
#define SP_CO_SDO_ABORT_TIMEOUT 0x05040000u     /**< SDO protocol timed out */
#define SP_CO_SDO_ABORT_READ_ONLY 0x06010002u   /**< attempt to write a read-only object */
#define SP_CO_SDO_ABORT_RANGE 0x06090030u       /**< value range of parameter exceeded */
#define SP_CO_SDO_ABORT_CMD 0x05040001u         /**< command specifier not valid */

/** Expedited download request (write 1, 2 or 4 bytes of value to
 *  index.sub): 8 bytes on 0x600 + node. SP_E_ARG for another size. */
sp_status_t sp_co_sdo_download_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t index, uint8_t sub,
                                     uint8_t size, uint32_t value);

/** Upload request (read index.sub): 8 bytes on 0x600 + node. */
sp_status_t sp_co_sdo_upload_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t index, uint8_t sub);

/** What an SDO server answered. */
typedef enum {
    SP_CO_SDO_DOWNLOAD_OK = 0, /**< the write was acknowledged */
    SP_CO_SDO_UPLOAD_OK = 1,   /**< expedited read: value and size filled */
    SP_CO_SDO_ABORTED = 2,     /**< abort: value = abort code */
    SP_CO_SDO_UNSUPPORTED = 3  /**< a segmented or block answer (not needed by the master's objects) */
} sp_co_sdo_answer_t;

/**
 * Parses a server's answer (0x580 + node, 8 bytes) to a request on
 * index.sub. SP_E_FRAME for another identifier or length, an unknown command
 * specifier, or a multiplexer (index, sub) other than the one asked (an
 * answer to another request). On success *answer says which; *value is the
 * read value (zero-extended, size bytes) or the abort code; *size is 1..4
 * (0 for a download acknowledgement or abort; 4 when an expedited upload
 * does not state its size).
 */
sp_status_t sp_co_sdo_parse(const sp_can_frame_t *f, uint8_t node, uint16_t index, uint8_t sub,
                            sp_co_sdo_answer_t *answer, uint32_t *value, uint8_t *size);

/** The CiA 301 meaning of an abort code ("object does not exist", ...);
 *  "unknown abort code" for the others. Never NULL. */
const char *sp_co_sdo_abort_name(uint32_t code);

/* ---- CiA 408 device state machine ---- */

/** CiA 408 control word bits. */
#define SP_CO408_CW_D 0x0001u /**< disabled (1: leave INIT / DISABLED asked) */
#define SP_CO408_CW_H 0x0002u /**< hold */
#define SP_CO408_CW_M 0x0004u /**< device mode active */
#define SP_CO408_CW_R 0x0008u /**< reset fault, on its rising edge */

/** Device states, from status word bits 0..3 (R M H D). */
typedef enum {
    SP_CO408_NOT_READY = 0,      /**< 0000 at power-up; also FAULT_INIT */
    SP_CO408_INIT = 1,           /**< 1000 */
    SP_CO408_DISABLED = 2,       /**< 1001 */
    SP_CO408_HOLD = 3,           /**< 1011 */
    SP_CO408_ACTIVE = 4,         /**< 1111 */
    SP_CO408_FAULT_REACTION = 5, /**< 0111 */
    SP_CO408_FAULT_HOLD = 6,     /**< 0011 */
    SP_CO408_FAULT_DISABLED = 7, /**< 0001 */
    SP_CO408_UNKNOWN = 8         /**< any other bit pattern */
} sp_co408_state_t;

/** The device state a status word shows (bits 0..3; the others ignored). */
sp_co408_state_t sp_co408_state(uint16_t status);

/** 1 for the fault states (R bit clear, not NOT_READY's power-up). */
int sp_co408_is_fault(sp_co408_state_t s);

/** The status word bits 0..3 of a state (INIT..ACTIVE, the fault states). */
uint16_t sp_co408_status_bits(sp_co408_state_t s);

/** Short name of a state ("ACTIVE", ...). Never NULL. */
const char *sp_co408_state_name(sp_co408_state_t s);

/** What the master asks of a drive (driven from the controller's states). */
typedef enum {
    SP_CO_REQ_DISABLED = 0, /**< control word 0x0001 -> DISABLED */
    SP_CO_REQ_HOLD = 1,     /**< 0x0003 -> HOLD (the drive holds its own position) */
    SP_CO_REQ_ACTIVE = 2    /**< 0x0007 -> ACTIVE (the setpoint is followed) */
} sp_co_request_t;

/** The control word of a request; with reset != 0 the R bit is set too
 *  (sent for one SYNC period to make its rising edge). Unknown requests
 *  give DISABLED's word. */
uint16_t sp_co408_control_word(sp_co_request_t req, int reset);

/** The device state a request leads to (DISABLED, HOLD or ACTIVE). */
sp_co408_state_t sp_co408_target(sp_co_request_t req);

/**
 * The CiA 408 device state machine as a drive runs it: the next state from
 * the current one, the control word received and the previous control word
 * (for R's rising edge), and whether the drive has a fault pending
 * (fault != 0 moves any non-fault state to FAULT_REACTION, and
 * FAULT_REACTION on to FAULT_HOLD). Used by the simulated drive and by the
 * tests; the master only reads states.
 */
sp_co408_state_t sp_co408_next(sp_co408_state_t s, uint16_t control, uint16_t prev_control, int fault);

/* ---- CiA 402 device state machine (drives and motion control) ---- */

/** CiA 402 controlword commands (0x6040; bits 0..3 and 7). */
#define SP_CO402_CW_DISABLE_VOLTAGE 0x0000u /**< -> switch on disabled */
#define SP_CO402_CW_QUICK_STOP 0x0002u      /**< operation enabled -> quick stop active */
#define SP_CO402_CW_SHUTDOWN 0x0006u        /**< -> ready to switch on */
#define SP_CO402_CW_SWITCH_ON 0x0007u       /**< ready to switch on -> switched on (operation enabled -> switched on) */
#define SP_CO402_CW_ENABLE_OPERATION 0x000Fu /**< switched on -> operation enabled */
#define SP_CO402_CW_FAULT_RESET 0x0080u      /**< fault -> switch on disabled, on its rising edge */

#define SP_CO402_PROFILE 402u /**< 0x1000 bits 0..15 */
#define SP_CO402_MODE_CSP 8   /**< 0x6060 / 0x6061: cyclic synchronous position */

/** CiA 402 device states, from the statusword (mask, value: docs/reference/canopen.md). */
typedef enum {
    SP_CO402_NOT_READY = 0,          /**< not ready to switch on (0x4F, 0x00) */
    SP_CO402_SWITCH_ON_DISABLED = 1, /**< (0x4F, 0x40) */
    SP_CO402_READY = 2,              /**< ready to switch on (0x6F, 0x21) */
    SP_CO402_SWITCHED_ON = 3,        /**< (0x6F, 0x23) */
    SP_CO402_OPERATION_ENABLED = 4,  /**< (0x6F, 0x27) */
    SP_CO402_QUICK_STOP_ACTIVE = 5,  /**< (0x6F, 0x07) */
    SP_CO402_FAULT_REACTION = 6,     /**< fault reaction active (0x4F, 0x0F) */
    SP_CO402_FAULT = 7,              /**< (0x4F, 0x08) */
    SP_CO402_UNKNOWN = 8             /**< any other bit pattern */
} sp_co402_state_t;

/** The device state a statusword shows (bits 0..3, 5, 6; the others ignored). */
sp_co402_state_t sp_co402_state(uint16_t status);

/** 1 for FAULT_REACTION and FAULT. */
int sp_co402_is_fault(sp_co402_state_t s);

/** The statusword bits of a state (as the simulated drive sends them; 0 for UNKNOWN). */
uint16_t sp_co402_status_bits(sp_co402_state_t s);

/** Short name of a state ("OPERATION_ENABLED", ...). Never NULL. */
const char *sp_co402_state_name(sp_co402_state_t s);

/** The device state a request leads to: DISABLED -> READY (ready to switch
 *  on: shutdown), HOLD and ACTIVE -> OPERATION_ENABLED (HOLD: the master
 *  holds the target position, docs/reference/canopen.md). */
sp_co402_state_t sp_co402_target(sp_co_request_t req);

/**
 * The controlword the master sends to move a drive in state s one step
 * towards target: shutdown, switch on, enable operation, disable voltage
 * (out of quick stop, and from a fault state, so that a later fault reset
 * has its rising edge). reset != 0 gives the fault reset (0x0080, sent for
 * one SYNC period); quick_stop != 0 gives the quick stop command (0x0002)
 * whatever the state. Pure; never fails.
 */
uint16_t sp_co402_control_word(sp_co402_state_t s, sp_co402_state_t target, int reset, int quick_stop);

/**
 * The CiA 402 state machine as a drive runs it (the simulated drive and the
 * tests; one transition per call, at SYNC): NOT_READY -> SWITCH_ON_DISABLED
 * by itself; the controlword's commands (shutdown, switch on, enable
 * operation, disable voltage, quick stop; "switch on + enable operation"
 * from READY goes to SWITCHED_ON first); fault != 0 moves any other state
 * to FAULT_REACTION, FAULT_REACTION goes on to FAULT, and FAULT leaves to
 * SWITCH_ON_DISABLED on bit 7's rising edge when the fault is gone.
 */
sp_co402_state_t sp_co402_next(sp_co402_state_t s, uint16_t control, uint16_t prev_control, int fault);

#endif /* SP_CANOPEN_H */
