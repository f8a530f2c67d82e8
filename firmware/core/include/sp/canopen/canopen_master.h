/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/canopen/canopen_master.h - the controller as CANopen master of up to six
 * drives (docs/reference/canopen.md), each of device profile CiA 408 (fluid power,
 * axis position control) or CiA 402 (cyclic synchronous position): NMT,
 * SYNC producer, RPDO1/TPDO1/TPDO2, a heartbeat and an EMCY consumer per
 * node, its own heartbeat producer, and an SDO client that configures each
 * drive at start-up and reads back what it wrote. The profile is a table
 * (objects, PDO mapping, mode writes) and the device state machine each
 * drive is driven through; everything else is shared.
 *
 * Pure and allocation-free: the state is a plain struct the caller owns,
 * time is an input (now_ms, the caller's millisecond count; the controller
 * ticks at 1 ms), and frames go in and out through the caller:
 *  - sp_co_master_receive() for every received frame of a CANopen bus: a
 *    boot-up, heartbeat, EMCY, SDO answer or TPDO updates the node at once
 *    (an EMCY is a latched fault within the tick of its frame);
 *  - sp_co_master_step() once per control tick: timeouts (boot-up, SDO,
 *    heartbeat, device state), the start-up's next SDO transfer per node,
 *    NMT commands, and on SYNC ticks the RPDO1 of every operational node
 *    followed by one SYNC per bus.
 *
 * Start-up, per node and in parallel across nodes (one SDO transfer
 * outstanding per node): NMT reset communication -> boot-up seen (else
 * NO_BOOT) -> read 0x1000 (the node's profile, 408 or 402, else
 * WRONG_PROFILE) -> the writes of the plan (sp_co_plan_build; optional
 * objects the drive lacks are skipped) -> read back every final value (a
 * difference is READBACK; CiA 402: then 0x6061 must show 8) -> NMT start ->
 * a heartbeat showing operational -> running. Nothing is asked beyond
 * DISABLED until every node runs; sp_co_master_output_t.ready says when
 * every node runs and shows the requested device state.
 *
 * Faults are latched per node with a name (sp_co_fault_name) and the
 * detail to report (object, abort code, EMCY code, values). While any node
 * has a fault, every other running node is asked HOLD (the platform stays
 * still) whatever the controller requests, until sp_co_master_reset().
 *
 * Build-time choice (docs/reference/stm32g4.md): an image carries either the native
 * drive protocol or this master, never both.
 */
#ifndef SP_CANOPEN_MASTER_H
#define SP_CANOPEN_MASTER_H

#include <stdint.h>

#include "sp/canopen/canopen.h"
#include "sp/math/fixed.h"

#define SP_CO_MAX_NODES 6u /**< drives one master handles (one per leg) */
#define SP_CO_PLAN_MAX 32u /**< SDO writes of one drive's plan, at most */
#define SP_CO_MAX_TX 24u   /**< frames one sp_co_master_step emits, at most */

/** Fixed CiA 408 objects the plan writes (docs/reference/canopen.md, objects.py). */
#define SP_CO408_PROFILE 408u        /**< 0x1000 bits 0..15 */
#define SP_CO408_CONTROL_MODE_AXIS 8 /**< 0x6043 axis position control (uncertain: config) */
#define SP_CO_UNIT_METRE 0x01u       /**< CiA 303-2 SI unit code of 0x6600.2 */
#define SP_CO_TRANSMISSION_SYNC 1u   /**< PDO transmission type: every SYNC */
#define SP_CO_PDO_COB_INVALID 0x80000000u
/** The master's own heartbeat period, ms (sp_co_master_cfg_default; the
 *  config's layout and `stewart busload` read this line: the one source). */
#define SP_CO_MASTER_HEARTBEAT_MS 100u

/** A drive's device profile (sp_co_node_cfg_t.profile). */
typedef enum {
    SP_CO_PROFILE_408 = 0, /**< CiA 408 fluid power, axis position control */
    SP_CO_PROFILE_402 = 1  /**< CiA 402 drives, cyclic synchronous position (mode 8) */
} sp_co_profile_t;

/** One drive on the master's buses. */
typedef struct {
    uint8_t node_id;          /**< 1..127, unique per bus */
    uint8_t bus;              /**< index of the frame's bus (< SP_CAN_BUSES) */
    uint8_t leg;              /**< 1..6: the leg it moves (names the fault) */
    int8_t control_mode;      /**< 0x6043 value of axis position control (default 8) */
    uint8_t write_prefix;     /**< 1: write unit metre and the prefix below to 0x6600.2/.3 */
    int8_t unit_prefix;       /**< decimal exponent of the drive's count (-6: 1 um) */
    uint8_t force_ff;         /**< 1: RPDO1 also maps a force feed-forward (8 bytes): CiA 408, the vendor object
                               0x2120.0 (daN); CiA 402, the torque/force offset 0x60B2.0 (per mille of the
                               rated force: the leg's sp_co_scaling_t.rated_force_n, which must be set) */
    uint8_t profile;          /**< sp_co_profile_t (0 = CiA 408) */
    uint8_t disable_on_block; /**< 1: asked DISABLED rather than HOLD while the controller blocks its drives
                                   (sp_co_master_input_t.block: a stop completed, a FAULT holding): a valve
                                   whose spool then takes its fail-safe position; 0: HOLD (the drive holds
                                   its position by its own loop) */
} sp_co_node_cfg_t;

/** The master's configuration (from the platform config's `drives`). */
typedef struct {
    sp_co_node_cfg_t node[SP_CO_MAX_NODES];
    uint8_t n_nodes;               /**< 1..SP_CO_MAX_NODES */
    uint8_t sync_divider;          /**< SYNC and PDOs every n control ticks, 1..255 */
    uint8_t pressure_feedback;     /**< 1: map TPDO2 (chamber pressures) */
    uint16_t heartbeat_ms;         /**< each drive's producer heartbeat (0x1017), 1..65535 */
    uint16_t heartbeat_timeout_ms; /**< consumer: silent longer than this = HEARTBEAT_LOST */
    uint16_t setpoint_timeout_ms;  /**< RPDO1 event timer (0x1400.5): the drive's watchdog */
    uint16_t boot_timeout_ms;      /**< no boot-up within this after the reset = NO_BOOT */
    uint16_t sdo_timeout_ms;       /**< no SDO answer within this = SDO_TIMEOUT */
    uint16_t state_timeout_ms;     /**< device state not reached within this = DEVICE_STATE */
    uint16_t pdo_timeout_ms;       /**< no TPDO1 within this while running = PDO_TIMEOUT */
    uint16_t master_heartbeat_ms;  /**< the master's own heartbeat (0x700 + master_node_id) every this many
                                        ms on each bus in use, so that drives can supervise it; 0 = none */
    uint8_t master_node_id;        /**< the master's node id for its heartbeat, 1..127, unique on its buses */
} sp_co_master_cfg_t;

/** The defaults of docs/reference/canopen.md for n nodes: heartbeat 20 ms, timeout 50
 *  ms, setpoint watchdog 3 ms, boot 2000 ms, SDO 100 ms, state 100 ms, PDO
 *  10 ms, divider 1, pressure feedback on, the master's heartbeat every 100
 *  ms as node 127; node i: CiA 408, id i+1 on bus SP_BUS_AXIS_A for legs
 *  1-3 and SP_BUS_AXIS_B for 4-6, control mode 8, prefix -6 written.
 *  SP_E_ARG for NULL or n outside 1..SP_CO_MAX_NODES. */
sp_status_t sp_co_master_cfg_default(sp_co_master_cfg_t *cfg, uint8_t n);

/** SP_OK if the configuration is usable; SP_E_ARG for a node id outside
 *  1..127, a duplicate id on a bus (the master's own id included when it
 *  sends a heartbeat), a bus index out of range, an unknown profile, the
 *  force feed-forward on a CiA 402 drive, a zero divider or timeout, or a
 *  heartbeat timeout not above the heartbeat. */
sp_status_t sp_co_master_cfg_check(const sp_co_master_cfg_t *cfg);

/** One SDO write of a drive's start-up plan. */
typedef struct {
    uint16_t index;
    uint8_t sub;
    uint8_t size;     /**< 1, 2 or 4 bytes */
    uint32_t value;   /**< the bytes written, little-endian in the frame (signed values two's complement) */
    uint8_t final;    /**< 1: read back after the writes and compared */
    uint8_t optional; /**< 1: skipped when the drive lacks it (abort 0x06020000 or 0x06090011) */
} sp_co_sdo_write_t;

/**
 * The SDO writes that configure node k (0-based) of cfg, in order; the same
 * list as tools/stewart/drives/plan.py (a Python test compares them): the
 * producer heartbeat, the consumer heartbeat 0x1016.1 watching the master's
 * (optional; master node id << 16 | 3 x master_heartbeat_ms, saturated to
 * 65535 ms; left out when the master sends none); CiA 408: the device mode (0x6042 = 1) and control
 * mode (0x6043), the unit and prefix (optional); CiA 402: the mode of
 * operation (0x6060 = 8) and the interpolation period 0x60C2.1/.2 (the
 * divider in ms, optional); the cycle period 0x1006 (optional, us), then
 * per PDO (RPDO1 with the force feed-forward as its third entry where
 * force_ff, TPDO1, TPDO2 with pressure feedback on CiA 408): COB-ID invalid,
 * mapping count 0, entries, count, transmission type 1, the RPDO's event
 * timer, COB-ID valid. *n gets the count. SP_E_ARG for NULL or k out of range.
 */
sp_status_t sp_co_plan_build(const sp_co_master_cfg_t *cfg, uint8_t k, sp_co_sdo_write_t out[SP_CO_PLAN_MAX],
                             uint8_t *n);

/** Named faults, latched per node. */
typedef enum {
    SP_CO_F_NONE = 0,
    SP_CO_F_NO_BOOT = 1,        /**< no boot-up within boot_timeout_ms */
    SP_CO_F_SDO_ABORT = 2,      /**< the drive aborted an SDO transfer (object, abort code) */
    SP_CO_F_SDO_TIMEOUT = 3,    /**< no SDO answer within sdo_timeout_ms (object) */
    SP_CO_F_SDO_PROTOCOL = 4,   /**< an SDO answer the master cannot use (segmented) */
    SP_CO_F_WRONG_PROFILE = 5,  /**< 0x1000 bits 0..15 are not the node's profile, 408 or 402 (value) */
    SP_CO_F_READBACK = 6,       /**< a value read back differs from the one written */
    SP_CO_F_HEARTBEAT_LOST = 7, /**< no heartbeat within heartbeat_timeout_ms */
    SP_CO_F_NMT_STATE = 8,      /**< a running node reported another NMT state or booted again */
    SP_CO_F_EMCY = 9,           /**< the drive sent an EMCY with a non-zero code (code) */
    SP_CO_F_DEVICE_FAULT = 10,  /**< the status word shows a fault state */
    SP_CO_F_DEVICE_STATE = 11,  /**< the requested device state was not reached in time, or left */
    SP_CO_F_PDO_TIMEOUT = 12    /**< no TPDO1 within pdo_timeout_ms while running */
} sp_co_fault_code_t;

/** Short name of a fault ("no boot-up", "SDO abort", ...). Never NULL. */
const char *sp_co_fault_name(sp_co_fault_code_t code);

/** A latched fault and what to report with it. */
typedef struct {
    uint8_t code;     /**< sp_co_fault_code_t */
    uint8_t sub;      /**< SDO faults: the object's sub-index */
    uint16_t index;   /**< SDO faults: the object's index; EMCY: the error code */
    uint32_t detail;  /**< abort code; value read; status word; NMT state; EMCY register */
    uint32_t expect;  /**< READBACK: the value written (0x6061: 8); WRONG_PROFILE: 408 or 402 */
    uint32_t time_ms; /**< now_ms when it latched */
} sp_co_fault_t;

/** Where a node is in its life. */
typedef enum {
    SP_CO_PHASE_OFF = 0,      /**< start-up not begun */
    SP_CO_PHASE_BOOT = 1,     /**< reset sent, waiting for the boot-up */
    SP_CO_PHASE_IDENTITY = 2, /**< reading 0x1000 */
    SP_CO_PHASE_WRITE = 3,    /**< the plan's writes */
    SP_CO_PHASE_READBACK = 4, /**< reading back the final values */
    SP_CO_PHASE_START = 5,    /**< NMT start sent, waiting for an operational heartbeat */
    SP_CO_PHASE_RUN = 6,      /**< operational: PDOs every SYNC */
    SP_CO_PHASE_FAILED = 7    /**< start-up failed (see the fault); waits for a reset */
} sp_co_phase_t;

/** Per node state (zero it through sp_co_master_init). */
typedef struct {
    uint8_t phase;        /**< sp_co_phase_t */
    uint8_t step;         /**< index into the plan (writes, then read-backs) */
    uint8_t plan_n;       /**< writes in the plan */
    uint8_t sdo_busy;     /**< 1: a request is outstanding */
    uint8_t nmt_pending;  /**< an NMT command to send this tick (sp_co_nmt_cmd_t), 0 = none */
    uint8_t reset_edge;   /**< SYNC periods left with the R bit set in the control word */
    uint8_t resetting;    /**< 1: a fault reset is under way (fault states tolerated until the state is reached) */
    uint8_t state_ok;     /**< 1 once the requested device state was seen */
    uint8_t tpdo1_seen;   /**< 1 once a TPDO1 arrived since the node runs */
    uint32_t skipped;     /**< bit i: plan write i was optional and the drive lacks it */
    uint32_t sdo_since;   /**< now_ms the outstanding request was sent */
    uint32_t phase_since; /**< now_ms the phase began */
    uint32_t hb_last;     /**< now_ms of the last heartbeat */
    uint32_t tpdo1_last;  /**< now_ms of the last TPDO1 */
    uint32_t req_since;   /**< now_ms the current request began */
    uint8_t eff;          /**< sp_co_request_t: the request this node got at the last step (the master's, or
                               DISABLED while blocked where the node's config says so) */
    uint16_t status;      /**< last status word (0x6041) */
    int32_t actual;       /**< last actual position, drive counts */
    uint16_t pa_kpa;      /**< last chamber pressure A, kPa */
    uint16_t pb_kpa;      /**< last chamber pressure B, kPa */
    uint8_t tpdo2_fresh;  /**< 1: TPDO2 arrived since the last step */
    uint8_t tpdo1_fresh;  /**< 1: TPDO1 arrived since the last step */
    uint8_t mode_checked; /**< CiA 402: 1 once 0x6061 was read back as 8 */
    uint8_t holding;      /**< CiA 402: 1 while the target is held at hold_target */
    int32_t hold_target;  /**< CiA 402: the target position held while HOLD is asked, counts */
    int32_t last_target;  /**< CiA 402: the target position of the last RPDO1, counts */
    sp_co_fault_t fault;  /**< the first fault latched (code NONE: none) */
    /* The status word decoded once per change (sp_co_master_step), not per
     * use: valid while seen_status == status and seen_profile == the node's
     * profile. Derived; zeroed state is simply "not decoded yet". */
    uint16_t seen_status; /**< the status word seen_state was decoded from */
    uint8_t seen_valid;   /**< 1: seen_state, seen_fault are those of seen_status */
    uint8_t seen_profile; /**< sp_co_profile_t seen_state is of */
    uint8_t seen_state;   /**< sp_co408_state_t or sp_co402_state_t of seen_status */
    uint8_t seen_fault;   /**< 1: seen_state is a fault state */
} sp_co_node_t;

typedef struct {
    sp_co_node_t node[SP_CO_MAX_NODES];
    uint8_t started; /**< 1 after sp_co_master_start */
    uint8_t
        was_running;   /**< 1 once every node has run (a later restart of one asks HOLD of the others, not DISABLED) */
    uint8_t last_req;  /**< the request of the last step */
    uint8_t nodes_req; /**< the request the nodes' own (sp_co_node_t.eff) were made from (0xFF: none yet) */
    uint8_t nodes_block; /**< the block they were made with */
    uint32_t ticks;      /**< steps since start (the SYNC divider counts these) */
    uint32_t hb_sent;    /**< now_ms of the master's last heartbeat */
    /** Derived at sp_co_master_start: 1 + the node k with (bus, node id),
     *  0 = none, so that a received frame finds its node without a search
     *  (checked against the config on use: a config changed since the start
     *  falls back to the search). */
    uint8_t node_of[SP_CAN_BUSES][SP_CO_NODE_MAX + 1u];
} sp_co_master_t;

/** Zeroes the state (every node OFF). SP_E_ARG for NULL. */
sp_status_t sp_co_master_init(sp_co_master_t *m);

/** Begins the start-up of every node at now_ms: each is sent NMT reset
 *  communication on the next step. SP_E_ARG for NULL or a bad cfg. */
sp_status_t sp_co_master_start(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint32_t now_ms);

/**
 * Clears every latched fault at now_ms: a node that failed its start-up
 * starts again from the reset; a running node gets the R bit of its control
 * word for one SYNC period (the drive's fault reset). SP_E_ARG for NULL.
 */
sp_status_t sp_co_master_reset(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint32_t now_ms);

/**
 * Takes one received frame of a CANopen bus. Frames of no configured node
 * (or of other identifiers) are ignored: SP_OK. A malformed frame of a
 * configured node's boot-up/heartbeat/EMCY/TPDO identifier returns
 * SP_E_FRAME and changes nothing; an SDO answer while no request is
 * outstanding is ignored. A fault latches here (EMCY, boot-up or heartbeat
 * state change while running, SDO abort, wrong profile, read-back).
 */
sp_status_t sp_co_master_receive(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, const sp_can_frame_t *f,
                                 uint32_t now_ms);

/** The controller's side of one tick. */
typedef struct {
    uint32_t now_ms;
    uint8_t request;                   /**< sp_co_request_t: what the controller's state asks of all drives */
    uint8_t block;                     /**< 1: the controller blocks its drives (sp_ctrl_output_t.drive_block):
                                            a HOLD becomes DISABLED for the nodes with disable_on_block */
    int32_t setpoint[SP_CO_MAX_NODES]; /**< drive counts, per node (see sp_co_length_to_count) */
    int16_t force_ff[SP_CO_MAX_NODES]; /**< force feed-forward in the drive's unit, per node (sent where
                                             force_ff): daN (CiA 408, 0x2120), per mille of the rated force
                                             (CiA 402, 0x60B2) */
} sp_co_master_input_t;

typedef struct {
    sp_can_frame_t tx[SP_CO_MAX_TX]; /**< tx[0..n_tx): frames to send, in this order (the rest is left as it was) */
    uint8_t n_tx;
    uint8_t sync;        /**< 1: this tick sent SYNC */
    uint8_t ready;       /**< 1: every node runs and shows the requested device state */
    uint8_t all_running; /**< 1: every node is operational (phase RUN) */
    uint8_t fault_mask;  /**< bit k: node k has a latched fault */
} sp_co_master_output_t;

/**
 * One control tick: checks the timeouts (a boot-up, SDO answer, heartbeat,
 * TPDO1 or device state overdue latches its fault), advances each node's
 * start-up by at most one SDO request, emits pending NMT commands, the
 * master's own heartbeat when due (operational once every node has run,
 * else pre-operational), and on SYNC ticks (every sync_divider steps) the
 * RPDO1 of each running node (control word of the effective request,
 * setpoint) and one SYNC per bus in use, after the RPDOs. The effective
 * request is DISABLED until every node has run for the first time; after
 * that at most HOLD while any node has a fault or is starting again; else
 * in->request. While in->block, a node with disable_on_block is asked
 * DISABLED where the others are asked HOLD (its state timeout restarts).
 *
 * CiA 408: the control word of the request (the drive holds by itself in
 * HOLD). CiA 402: the controlword moves the drive one step per SYNC towards
 * the request's state (sp_co402_control_word), a node with a latched fault
 * of its own gets the quick stop command, and the target position is the
 * drive's actual position until operation is enabled, in->setpoint while
 * ACTIVE, and the last target sent, latched, while HOLD (the master holds).
 * SP_E_ARG for NULL arguments (out is then untouched).
 */
sp_status_t sp_co_master_step(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, const sp_co_master_input_t *in,
                              sp_co_master_output_t *out);

/**
 * 1 when the next sp_co_master_step of a started master is a SYNC tick (it
 * sends the RPDO1s and SYNC: one step in sync_divider), else 0; 0 also for
 * NULL arguments, a master not started or a divider of 0. The step reads
 * in->setpoint and in->force_ff only on SYNC ticks: a caller may prepare
 * them only then (sp_co_link_input_due).
 */
int sp_co_master_sync_due(const sp_co_master_t *m, const sp_co_master_cfg_t *cfg);

/** Node k's phase (sp_co_phase_t) and latched fault, for callers that do
 *  not read the struct (the Python tools over ctypes). SP_E_ARG for NULL or
 *  k >= SP_CO_MAX_NODES. */
sp_status_t sp_co_master_node_state(const sp_co_master_t *m, uint8_t k, uint8_t *phase, sp_co_fault_t *fault);

/** Scaling of a leg length to a drive's position count, and of a force to
 *  a CiA 402 drive's torque/force offset. Set the first four fields, then
 *  sp_co_scaling_prepare() derives the rest (no division per tick). */
typedef struct {
    uint32_t nm_per_count;       /**< 1..1,000,000 (1 nm .. 1 mm per count) */
    int32_t zero_q24;            /**< leg length at count 0, m Q24 */
    int8_t direction;            /**< +1: the count grows as the leg extends; -1 */
    uint32_t rated_force_n;      /**< N along the leg at 1000 per mille of CiA 402's 0x60B2 (the drive's rated
                                     torque or force, 0x6076, through its gearing), 100..10,000,000; 0: none */
    uint32_t count_per_q24;      /**< derived: round(1e9 / nm_per_count), counts per Q24 step x 2^24 */
    uint32_t permille_per_n_q24; /**< derived: round(1000 x 2^24 / rated_force_n), 0 without a rated force */
    uint64_t q24_per_count_q28;  /**< derived: round(nm_per_count x 2^52 / 1e9), Q24 steps per count x 2^28 */
    int64_t count_limit;         /**< derived: counts beyond which a length leaves the Q24 range */
} sp_co_scaling_t;

/** Derives the per-tick factors. SP_E_ARG (nothing derived) for NULL,
 *  nm_per_count outside 1..1,000,000, a direction other than +-1 or a
 *  rated_force_n other than 0 or 100..10,000,000. */
sp_status_t sp_co_scaling_prepare(sp_co_scaling_t *s);

/** count = direction x round((length - zero) / nm_per_count), by the
 *  prepared factor (within 1 count of the exact quotient; equal in the
 *  tests' sweep), saturated to INT32 (SP_E_OVERFLOW then). length in m Q24.
 *  SP_E_ARG for an unprepared or bad scaling. */
sp_status_t sp_co_length_to_count(const sp_co_scaling_t *s, int32_t length_q24, int32_t *count);

/** length = zero + direction x count x nm_per_count, m Q24 rounded to
 *  nearest (within 1 LSB of the exact value), saturated (SP_E_OVERFLOW).
 *  SP_E_ARG for an unprepared or bad scaling. */
sp_status_t sp_co_count_to_length(const sp_co_scaling_t *s, int32_t count, int32_t *length_q24);

/** CiA 402's torque/force offset (0x60B2, per mille of rated_force_n) of
 *  a force along the leg (N Q8), signed by the direction, rounded to
 *  nearest (within 1 of the exact quotient), saturated to INT16
 *  (SP_E_OVERFLOW then). SP_E_ARG for an unprepared or bad scaling or one
 *  without a rated force. */
sp_status_t sp_co_force_to_permille(const sp_co_scaling_t *s, sp_q8_t force_q8, int16_t *permille);

#endif /* SP_CANOPEN_MASTER_H */
