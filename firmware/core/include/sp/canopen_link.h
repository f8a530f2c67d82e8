/*
 * sp/canopen_link.h - the controller's drives over CANopen: between the
 * controller's step (sp/controller.h) and the CANopen master
 * (sp/canopen_master.h), the CiA 408 counterpart of what node.c does with
 * the native AXIS_SETPOINTS / AXIS_FEEDBACK frames (docs/canopen.md).
 *
 * Per tick, in this order:
 *  1. sp_co_master_receive() for the frames received since the last tick
 *     (the TPDOs answering the last SYNC);
 *  2. sp_co_link_feedback(): the controller's drive feedback from them;
 *  3. sp_ctrl_step();
 *  4. sp_co_link_input(): the master's request and setpoints from the
 *     controller's output;
 *  5. sp_co_master_step(): RPDO1 + SYNC on SYNC ticks.
 *
 * CiA 408's axis position setpoint carries the position only: the drive
 * derives the velocity from consecutive setpoints, and the force
 * feed-forward goes only to drives configured with the vendor object
 * 0x2120 in RPDO1 (force_ff; docs/canopen.md says why). With a SYNC divider d the feedback arrives every d ticks:
 * the controller's feedback_timeout_ticks must exceed d.
 */
#ifndef SP_CANOPEN_LINK_H
#define SP_CANOPEN_LINK_H

#include "sp/canopen_master.h"
#include "sp/controller.h"

/** Which drive moves which leg, and in what units. */
typedef struct {
    sp_co_master_cfg_t master;        /**< the drives (node k moves leg master.node[k].leg) */
    sp_co_scaling_t scaling[SP_LEGS]; /**< per leg (index leg - 1) */
    const sp_platform_t *platform;    /**< cylinder areas for the force from the pressures */
} sp_co_link_cfg_t;

/** The bit of sp_drive_feedback_t.faults that says the CANopen master has a
 *  latched fault on the leg's drive (the native protocol's FAULT-state bit). */
#define SP_CO_LINK_FAULT 0x0080u

/**
 * A link for the default master configuration of six drives
 * (sp_co_master_cfg_default) with every leg at 1 um per count, count 0 at
 * the platform's park length of that leg (zero_q24 given per leg), direction
 * +1. SP_E_ARG for NULL arguments.
 */
sp_status_t sp_co_link_cfg_default(sp_co_link_cfg_t *cfg, const sp_platform_t *platform,
                                   const sp_q24_t zero_q24[SP_LEGS]);

/** SP_OK when every leg 1..6 has exactly one drive, the scalings are valid
 *  (sp_co_length_to_count's rules) and the master's config passes
 *  sp_co_master_cfg_check; SP_E_ARG otherwise. */
sp_status_t sp_co_link_cfg_check(const sp_co_link_cfg_t *cfg);

/**
 * The controller's drive feedback from the master's nodes: fresh when the
 * node's TPDO1 arrived since the master's last step, the length from its
 * actual position (scaling), the force from its TPDO2 pressures (the last
 * ones; 0 N before any), and SP_CO_LINK_FAULT in faults while the master
 * has a fault latched on the node. Legs are untouched when not fresh except
 * for their fresh flag (cleared). SP_E_ARG for NULL; SP_E_OVERFLOW when a
 * length saturated (the length is then the Q24 range's end).
 */
sp_status_t sp_co_link_feedback(const sp_co_master_t *m, const sp_co_link_cfg_t *cfg, sp_drive_feedback_t fb[SP_LEGS]);

/**
 * The master's input from the controller's output: request ACTIVE while the
 * controller's drive mode is ACTIVE, else HOLD; each node's setpoint the
 * count of its leg's setpoint length, and its force feed-forward in daN
 * along the count (the setpoint's force x direction / 10 N, rounded,
 * saturated to INT16; sent only to drives with force_ff). now_ms is copied. SP_E_ARG for NULL;
 * SP_E_OVERFLOW when a count saturated.
 */
sp_status_t sp_co_link_input(const sp_co_link_cfg_t *cfg, const sp_ctrl_output_t *out, uint32_t now_ms,
                             sp_co_master_input_t *in);

#endif /* SP_CANOPEN_LINK_H */
