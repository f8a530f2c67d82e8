/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/co_node.h - a simulated drive presenting itself as a CiA 408 node
 * (docs/reference/canopen.md, config/eds/stewart_sim_drive.eds) or as a CiA 402 node
 * in cyclic synchronous position mode (config/eds/stewart_sim_drive_402.eds;
 * hs_co_node_init_profile): an object dictionary
 * with the objects the master uses, an expedited SDO server, NMT, a
 * heartbeat and EMCY producer, RPDO1 applied and TPDO1/TPDO2 sent on SYNC,
 * the RPDO event timer as the setpoint watchdog, and the CiA 408 device
 * state machine (sp_co408_next) or the CiA 402 one (sp_co402_next: the
 * setpoint is followed in OPERATION_ENABLED).
 *
 * The node knows nothing of hydraulics: the caller gives it the measured
 * position (drive counts) and pressures (kPa) before each SYNC and reads the
 * applied setpoint (counts) and device state after it, then drives its
 * hs_drive (ACTIVE: follow the setpoint; HOLD, DISABLED or a fault state:
 * hold). Integer-only on purpose: what goes over the bus is integers.
 *
 * Test knobs make it misbehave the ways the master must survive: never
 * boot, stop its heartbeat, abort an SDO transfer on one object, raise a
 * fault with an EMCY.
 */
#ifndef HS_CO_NODE_H
#define HS_CO_NODE_H

#include <stdint.h>

#include "hs/status.h"
#include "sp/canopen/canopen.h"

#define HS_CO_OD_MAX 96u /**< object dictionary entries */
#define HS_CO_MAX_TX 4u  /**< frames one call emits, at most */

#define HS_CO_RO 0u /**< read only */
#define HS_CO_RW 1u /**< read and write */

/** One object dictionary entry (value as its 1, 2 or 4 bytes). */
typedef struct {
    uint16_t index;
    uint8_t sub;
    uint8_t size;
    uint8_t access; /**< HS_CO_RO or HS_CO_RW */
    uint32_t value;
} hs_co_entry_t;

typedef struct {
    uint8_t node_id;
    uint8_t bus;
    hs_co_entry_t od[HS_CO_OD_MAX];
    uint8_t n_od;
    uint8_t nmt;             /**< sp_co_nmt_state_t; BOOTUP = powered off or resetting */
    uint8_t boot_pending;    /**< 1: send the boot-up on the next tick */
    sp_co408_state_t state;  /**< device state */
    uint16_t control;        /**< control word in force (applied at the last SYNC) */
    uint16_t rx_control;     /**< control word received, applied at the next SYNC */
    int32_t rx_setpoint;     /**< setpoint received, applied at the next SYNC (counts) */
    int32_t setpoint;        /**< setpoint in force (counts) */
    int16_t rx_force_ff;     /**< force feed-forward received (CiA 408: 0x2120, daN; CiA 402: 0x60B2, per
                                  mille of the rated force 0x6076; 0 without it in RPDO1) */
    int16_t force_ff;        /**< force feed-forward in force, the same unit (hs_co_node_force_n: in N) */
    uint8_t rpdo_seen;       /**< 1 once an RPDO1 arrived since operational */
    uint32_t rpdo_age_ms;    /**< ms since the last RPDO1 */
    uint32_t hb_elapsed_ms;  /**< ms since the last heartbeat */
    uint8_t fault;           /**< 1: a fault is pending (cleared by a fault reset) */
    uint16_t emcy_pending;   /**< an EMCY code to send on the next tick (0: none) */
    int32_t actual;          /**< measured position, counts (caller) */
    uint16_t pa_kpa, pb_kpa; /**< measured pressures, kPa (caller) */
    /* test knobs */
    uint8_t never_boot;   /**< 1: never sends a boot-up (nor anything else) */
    uint8_t silent;       /**< 1: sends no heartbeat */
    uint16_t abort_index; /**< SDO requests on this object are aborted (0: none) */
    uint8_t abort_sub;
    uint32_t abort_code;
    uint32_t sdo_count; /**< SDO requests served (figure) */
    /* CiA 402 (profile 1); at the end so that the CiA 408 fields keep their place */
    uint8_t profile;           /**< 0: CiA 408, 1: CiA 402 (sp_co_profile_t's values) */
    sp_co402_state_t state402; /**< CiA 402 device state */
    /* the heartbeat consumer (0x1016.1: node id << 16 | ms; 0 = off) */
    uint8_t hbc_seen;        /**< 1 once the watched node's heartbeat arrived (monitoring runs) */
    uint32_t hbc_elapsed_ms; /**< ms since the watched node's last heartbeat */
    /* test knob: a slow SDO server (a drive that takes its time over each
     * object, as one storing it does): each answer goes out sdo_delay_ms
     * after the request, from hs_co_node_tick (0: at once) */
    uint16_t sdo_delay_ms;
    uint8_t sdo_holding;     /**< 1: sdo_held waits for its time */
    uint16_t sdo_wait_ms;    /**< ms left before sdo_held goes out */
    sp_can_frame_t sdo_held; /**< the answer held back */
} hs_co_node_t;

/** Powers a node up with the EDS's defaults; it boots (sends its boot-up)
 *  on its first tick. HS_E_ARG for NULL, a node id outside 1..127 or a bus
 *  >= SP_CAN_BUSES. */
hs_status_t hs_co_node_init(hs_co_node_t *n, uint8_t node_id, uint8_t bus);

/** As hs_co_node_init, with the device profile: 0 = CiA 408 (the same as
 *  hs_co_node_init), 1 = CiA 402 (the 402 EDS's objects and defaults).
 *  HS_E_ARG also for another profile. */
hs_status_t hs_co_node_init_profile(hs_co_node_t *n, uint8_t node_id, uint8_t bus, uint8_t profile);

/** The entry index.sub, or NULL. */
hs_co_entry_t *hs_co_node_find(hs_co_node_t *n, uint16_t index, uint8_t sub);

/**
 * Takes one frame of its bus: NMT (to it or to all), SYNC, RPDO1, an SDO
 * request. Answers go to tx (at most HS_CO_MAX_TX), *n_tx is their count.
 * Frames for others are ignored. HS_E_ARG for NULL.
 */
hs_status_t hs_co_node_receive(hs_co_node_t *n, const sp_can_frame_t *f, sp_can_frame_t tx[HS_CO_MAX_TX],
                               uint8_t *n_tx);

/**
 * Advances the node's clocks by ms milliseconds (1..1000): the boot-up after
 * a reset, the heartbeat producer (0x1017), the RPDO event timer (0x1400.5:
 * in ACTIVE, no RPDO1 within it raises EMCY 0x8250 and a fault), the
 * heartbeat consumer (0x1016.1: once the watched node's heartbeat was seen,
 * silence beyond its time raises EMCY 0x8130 and a fault; CiA 301's
 * monitoring starts with the first heartbeat), a pending EMCY, and an SDO
 * answer held back by sdo_delay_ms once its time has come.
 * HS_E_ARG for NULL.
 */
hs_status_t hs_co_node_tick(hs_co_node_t *n, uint32_t ms, sp_can_frame_t tx[HS_CO_MAX_TX], uint8_t *n_tx);

/** Raises a drive fault: an EMCY with code (non-zero) on the next tick and
 *  the fault reaction at the next SYNC. */
hs_status_t hs_co_node_raise(hs_co_node_t *n, uint16_t code);

/** 1 when the setpoint is to be followed (operational and ACTIVE; CiA 402:
 *  operational and OPERATION_ENABLED). */
int hs_co_node_follows(const hs_co_node_t *n);

/** The force feed-forward in force (N along the count): CiA 408's daN
 *  times 10, CiA 402's per mille times the rated force 0x6076 (mN) / 10^6. */
double hs_co_node_force_n(const hs_co_node_t *n);

#endif /* HS_CO_NODE_H */
