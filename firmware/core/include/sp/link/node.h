/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/link/node.h - the controller as a CAN node: received frames in, frames to
 * send out, around one sp_ctrl_step per tick. Portable and pure: the port
 * moves frames between the buses and these functions.
 *
 * Cycle (CiA 408 spirit: setpoints take effect on the next SYNC):
 *  - sp_node_receive() for every received frame: decoded and checked
 *    (identifier, bus, length, CRC, ranges, alive counter per sender); a bad
 *    frame is counted by reason and dropped, never reaches the controller.
 *  - sp_node_tick() once per tick: runs the controller step on the feedback
 *    of the last SYNC, then emits AXIS_SETPOINTS on both axis buses, SYNC
 *    (only when the node is the cycle master: real-time mode), CTRL_STATUS
 *    and CTRL_MONITOR on the ops bus, and on even ticks (every
 *    SP_PROTO_WRENCH_PERIOD ticks: 500 Hz) CTRL_WRENCH, the external wrench
 *    estimate (at 1 kHz it would take the ops bus to 49.9 % of its 50 %
 *    budget).
 *  - OP_FORCE (mask, target) is kept for the next FORCE or GUIDE command
 *    (OP_COMMAND), as OP_TARGET_POSE is for MOVE_TO; while the controller
 *    is in FORCE a new OP_FORCE updates the target at once: the node hands
 *    the controller a FORCE command with it on the next tick that has no
 *    queued command. FT_SENSOR (axis_b) becomes the tick's sensor reading.
 *  - Feedback counts as fresh only if its TickEcho matches the last SYNC (sent
 *    by us, or, in lockstep, received from the plant). In lockstep the plant
 *    sends each cycle's feedback just before its SYNC, which closes the cycle:
 *    feedback for the next tick is held until that SYNC arrives.
 *  - Command authentication (sp/link/auth.h, docs/explanation/security.md): OP_TARGET_POSE,
 *    OP_FORCE, OP_FORCE_PARAMS and every OP_COMMAND but NONE, STOP, PARK,
 *    ESTOP and IDENTIFY (sp_proto_frame_needs_auth) must carry a code that checks under the machine key with this session and
 *    a counter after the last accepted; the check comes right after the
 *    CRC and ranges, before the alive counter, so that a stranger's frames
 *    change nothing but the counts. Rejected: SP_PROTO_AUTH_BAD_TAG,
 *    SP_PROTO_AUTH_REPLAYED, or SP_PROTO_AUTH_NO_KEY when the node has no
 *    key (then motion cannot be commanded; stops still work). Every
 *    SP_PROTO_AUTH_PERIOD ticks (10 ms) CTRL_AUTH publishes the session, the
 *    last accepted counter and the rejection counts, ahead of CTRL_STATUS.
 *  - CTRL_STATUS, CTRL_MONITOR and CTRL_WRENCH carry the tick of the setpoints they go
 *    with (the SYNC tick in lockstep), so that a log lines them up.
 *  - Order of a tick's frames: AXIS_SETPOINTS (and SYNC) on each axis bus;
 *    then on the ops bus the tick's one answer (CTRL_REACH, CTRL_IDENTITY
 *    or CTRL_REFUSAL) or CTRL_AUTH, CTRL_STATUS, CTRL_MONITOR, CTRL_WRENCH
 *    (even ticks), CTRL_FRAMES (every SP_PROTO_FRAMES_PERIOD ticks). Every
 *    frame a tick may or may not send comes before CTRL_STATUS or is on a
 *    fixed schedule, so a reader that waits for the scheduled frames holds
 *    the whole tick (the plant's lockstep relies on it).
 *  - OP_COMMAND IDENTIFY (any state, no authentication, taken like a stop
 *    whatever its alive counter) is answered by one CTRL_IDENTITY on the
 *    next tick, or the one after when the next sends CTRL_AUTH (so that no
 *    tick sends more than SP_NODE_MAX_TX frames); requests before the
 *    answer share it. It never reaches the controller: no command slot, no
 *    refusal. Without a request nothing is sent.
 */
#ifndef SP_NODE_H
#define SP_NODE_H

#include "sp/control/controller.h"
#include "sp/link/protocol.h"

#define SP_NODE_MAX_TX 8u    /**< frames sp_node_tick emits at most */
#define SP_NODE_CMD_QUEUE 4u /**< operator commands held (one is executed per tick) */

typedef struct {
    sp_ctrl_config_t ctrl;                     /**< controller tuning (force_feedforward may change by command) */
    uint8_t sync_master;                       /**< 1: we send SYNC (real time); 0: the plant does (lockstep) */
    const sp_auth_key_t *auth_key;             /**< the machine key (copied by sp_node_init); NULL: none, every
                                        authenticated command is refused (SP_PROTO_AUTH_NO_KEY) */
    uint32_t auth_session;                     /**< this session's value (drawn at start-up by the port) */
    uint8_t port;                              /**< sp_port_id_t: the target CTRL_IDENTITY names (set by the port) */
    const sp_length_sensors_t *length_sensors; /**< native drives' length sensors as calibrated
                                                    (sp_length_from_sensor); NULL: readings are lengths */
} sp_node_config_t;

typedef struct {
    uint32_t accepted;                  /**< frames used */
    uint32_t rejected[SP_PROTO_ERRORS]; /**< dropped frames by sp_proto_error_t */
    uint32_t lost;                      /**< frames missed according to alive counters */
    uint32_t stale;                     /**< valid feedback that answered an older SYNC */
    uint32_t saturated;                 /**< values clipped to a signal's range on send */
    uint32_t cmd_overflow;              /**< commands refused: queue full (an ESTOP never is) */
    uint32_t cmd_refused;               /**< commands the controller refused (ticks with cmd_rejected) */
    uint32_t ft_samples;                /**< FT_SENSOR frames used */
} sp_node_stats_t;

typedef struct {
    sp_ctrl_t ctrl;
    sp_ctrl_input_t in;   /**< gathered for the next tick */
    sp_ctrl_output_t out; /**< of the last tick */
    sp_e2e_rx_t rx_feedback[SP_LEGS];
    sp_e2e_rx_t rx_sync[2];
    sp_e2e_rx_t rx_command;
    sp_e2e_rx_t rx_target;
    sp_e2e_rx_t rx_heartbeat;
    sp_e2e_rx_t rx_force;
    sp_e2e_rx_t rx_force_params;
    sp_e2e_rx_t rx_ft;
    sp_e2e_rx_t rx_frame;
    sp_e2e_rx_t rx_reach;
    sp_auth_rx_t auth; /**< command authentication: session, last counter, counts */
    sp_auth_key_t key; /**< the machine key (when key_set) */
    uint8_t key_set;   /**< 1: a key was configured */
    uint8_t tx_counter_auth;
    uint8_t tx_counter_sync[2];
    uint8_t tx_counter_setpoints[2];
    uint8_t tx_counter_status;
    uint8_t tx_counter_monitor;
    uint8_t tx_counter_wrench;
    uint8_t tx_counter_identity;
    uint8_t identify_pending; /**< an IDENTIFY came: CTRL_IDENTITY goes out on the next tick that has room */
    uint8_t tx_counter_reach;
    uint8_t tx_counter_frames;
    uint8_t frame_fresh;   /**< an OP_FRAME arrived and is not yet handed to the controller */
    sp_msg_frame_t frame;  /**< that OP_FRAME */
    uint8_t reach_pending; /**< an OP_REACH waits for its CTRL_REACH (the newest query wins) */
    sp_msg_reach_t reach;  /**< that OP_REACH */
    uint8_t tx_counter_refusal;
    uint8_t cmd_now;                    /**< this tick's command as CTRL_REFUSAL names it (0: none) */
    uint8_t refusal_pending;            /**< a refusal to report: CTRL_REFUSAL on the next tick with room */
    sp_msg_refusal_t refusal;           /**< the last refusal (its tick, what, why) */
    uint32_t refusal_sent;              /**< the tick the last CTRL_REFUSAL went out (at most one in 10 ticks) */
    uint8_t refusal_sent_valid;         /**< 1 once one went out */
    uint32_t sync_tick;                 /**< tick of the last SYNC sent or received */
    uint8_t sync_seen[2];               /**< lockstep: SYNC(sync_tick) received on axis_a / axis_b */
    uint8_t sync_valid;                 /**< a SYNC has been sent or received */
    sp_drive_feedback_t early[SP_LEGS]; /**< lockstep: feedback waiting for the SYNC of its cycle */
    uint16_t early_echo[SP_LEGS];
    uint8_t early_valid[SP_LEGS];
    sp_msg_command_t cmd_queue[SP_NODE_CMD_QUEUE]; /**< commands waiting, one per tick */
    uint8_t cmd_head;
    uint8_t cmd_count;
    sp_pose_t target;     /**< last OP_TARGET_POSE */
    sp_msg_force_t force; /**< last OP_FORCE (mask 0 until one arrives: FORCE and GUIDE are refused) */
    uint8_t force_fresh;  /**< an OP_FORCE arrived since the last tick (a streamed target update in FORCE) */
    sp_msg_force_params_t force_params; /**< last OP_FORCE_PARAMS */
    uint8_t force_params_fresh;         /**< it arrived and is not yet handed to the controller */
    sp_node_stats_t stats;
    const sp_platform_t *ctrl_platform;        /**< from the config (cylinder areas) */
    const sp_length_sensors_t *length_sensors; /**< from the config (NULL: readings are lengths) */
    uint8_t ctrl_sync_master;                  /**< copy of cfg->sync_master */
    uint8_t drives_starting; /**< set by the port: 1 while the CANopen master is still starting the drives
                                  (not every drive operational); ENGAGE is then refused (cmd_rejected,
                                  stats.cmd_refused) and CTRL_STATUS DrivesStarting says why. 0 (native
                                  drives) after sp_node_init. */
} sp_node_t;

/** Defaults for a platform: sp_ctrl_default_config, sync_master = 1, no
 *  authentication key (auth_key NULL, auth_session 0), port
 *  SP_PORT_UNSPECIFIED. */
sp_status_t sp_node_default_config(sp_node_config_t *cfg, const sp_platform_t *platform);

/** Resets the node and its controller (IDLE, no faults, counters at 0);
 *  with cfg->auth_key, copies the key and starts the authentication
 *  session cfg->auth_session (sp_auth_rx_start). */
sp_status_t sp_node_init(sp_node_t *node, const sp_node_config_t *cfg);

/**
 * Takes one received frame. SP_OK if it was used; SP_E_FRAME if it was
 * rejected (counted in stats.rejected by reason; *why says which, if not
 * NULL); SP_E_ARG for NULL pointers. Frames the controller does not consume
 * (its own transmissions, other nodes' traffic) are SP_PROTO_UNKNOWN_ID.
 * Nothing in a rejected frame reaches the controller. One exception to the
 * alive-counter check: an OP_COMMAND ESTOP, STOP, PARK or IDENTIFY with a
 * valid CRC is used even when its counter repeats or jumps (a second operator
 * process, a resent emergency stop, another node: these carry no
 * authentication code either); refusing a stop is never the safe side.
 */
sp_status_t sp_node_receive(sp_node_t *node, const sp_can_frame_t *frame, sp_proto_error_t *why);

/** Lockstep: 1 when SYNC(tick) has arrived on both axis buses since the
 *  last tick and *tick tells which; 0 otherwise. */
int sp_node_cycle_ready(const sp_node_t *node, uint32_t *tick);

/**
 * One control tick: the controller step, then the frames to send
 * (out[0..*n)), at most SP_NODE_MAX_TX. cfg may be updated (SET_FEEDFORWARD).
 * Returns SP_OK, or SP_E_ARG for NULL pointers. Controller faults are in
 * node->out, not in the status.
 */
sp_status_t sp_node_tick(sp_node_config_t *cfg, sp_node_t *node, sp_can_frame_t out[SP_NODE_MAX_TX], uint32_t *n);

#endif /* SP_NODE_H */
