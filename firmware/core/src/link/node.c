/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/link/node.h"

#include "link/link_internal.h"
#include "math/fixed_inline.h"
#include "sp/math/version.h"

/* Most frames of one tick: 2 AXIS_SETPOINTS + 2 SYNC + CTRL_AUTH + CTRL_STATUS + CTRL_MONITOR + CTRL_WRENCH;
 * CTRL_IDENTITY goes out on a tick without CTRL_AUTH only. */
typedef char sp_node_tx_fits[(8u <= SP_NODE_MAX_TX) ? 1 : -1];

static void inc(uint32_t *c)
{
    if (*c < UINT32_MAX) {
        (*c)++;
    }
}

sp_status_t sp_node_default_config(sp_node_config_t *cfg, const sp_platform_t *platform)
{
    if (cfg == NULL || platform == NULL) {
        return SP_E_ARG;
    }
    memset(cfg, 0, sizeof *cfg);
    cfg->sync_master = 1u;
    /* the built-in platform's sensors come with it; another platform's readings are lengths */
    cfg->length_sensors =
        (platform == &sp_platform_default) ? sp_length_sensors_in_use(&sp_length_sensors_default) : NULL;
    return sp_ctrl_default_config(&cfg->ctrl, platform);
}

sp_status_t sp_node_init(sp_node_t *node, const sp_node_config_t *cfg)
{
    if (node == NULL || cfg == NULL) {
        return SP_E_ARG;
    }
    memset(node, 0, sizeof *node);
    if (cfg->ctrl.platform == NULL) {
        return SP_E_ARG;
    }
    node->target = cfg->ctrl.platform->home;
    node->ctrl_platform = cfg->ctrl.platform;
    node->length_sensors = cfg->length_sensors;
    node->ctrl_sync_master = cfg->sync_master;
    if (cfg->auth_key != NULL) {
        node->key = *cfg->auth_key;
        node->key_set = 1u;
        (void)sp_auth_rx_start(&node->auth, cfg->auth_session);
    }
    return sp_ctrl_init(&node->ctrl, &cfg->ctrl);
}

static sp_status_t reject(sp_node_t *node, sp_proto_error_t e, sp_proto_error_t *why)
{
    if ((unsigned)e < SP_PROTO_ERRORS) {
        inc(&node->stats.rejected[e]);
    }
    if (why != NULL) {
        *why = e;
    }
    return SP_E_FRAME;
}

/* Alive-counter check; SP_PROTO_OK when the frame may be used. */
static sp_proto_error_t sequence(sp_node_t *node, sp_e2e_rx_t *rx, uint8_t counter)
{
    uint8_t before = rx->last;
    sp_e2e_result_t r = sp_e2e_rx_check(rx, counter);
    if (r == SP_E2E_REPEATED) {
        return SP_PROTO_REPEATED;
    }
    if (r == SP_E2E_WRONG_SEQ) {
        return SP_PROTO_WRONG_SEQUENCE;
    }
    if (r == SP_E2E_OK_LOST) {
        uint32_t lost = (uint32_t)((counter - before - 1u) & 0x0Fu);
        node->stats.lost = (node->stats.lost > UINT32_MAX - lost) ? UINT32_MAX : node->stats.lost + lost;
    }
    return SP_PROTO_OK;
}

static sp_status_t receive_axis(sp_node_t *node, const sp_can_frame_t *f, sp_proto_error_t *why)
{
    sp_proto_error_t e = SP_PROTO_OK;
    uint8_t counter = 0u;
    uint8_t b = (uint8_t)(f->bus - SP_BUS_AXIS_A);
    if (f->id == SP_ID_SYNC) {
        sp_msg_sync_t m;
        if (sp_proto_decode_sync(f, &m, &counter, &e) != SP_OK) {
            return reject(node, e, why);
        }
        e = sequence(node, &node->rx_sync[b], counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        if (!node->sync_valid || m.tick != node->sync_tick) {
            node->sync_seen[0] = 0u;
            node->sync_seen[1] = 0u;
        }
        node->sync_tick = m.tick;
        node->sync_valid = 1u;
        node->sync_seen[b] = 1u;
        /* lockstep: feedback sent just before this SYNC belongs to its cycle */
        for (uint32_t i = 0; i < SP_LEGS; i++) {
            if (node->early_valid[i] && node->early_echo[i] == (uint16_t)(m.tick & 0xFFFFu)) {
                node->in.drive[i] = node->early[i];
            }
            node->early_valid[i] = 0u;
        }
        inc(&node->stats.accepted);
        return SP_OK;
    }
    sp_msg_feedback_t m;
    uint8_t slot = 0u;
    if (sp_proto_decode_feedback(f, &m, &slot, &counter, &e) != SP_OK) {
        return reject(node, e, why);
    }
    uint32_t leg = (uint32_t)b * SP_AXIS_SLOTS + slot - 1u;
    e = sequence(node, &node->rx_feedback[leg], counter);
    if (e != SP_PROTO_OK) {
        return reject(node, e, why);
    }
    sp_drive_feedback_t d;
    d.fresh = 1u;
    d.length = m.length;
    /* the sensor's reading -> joint-to-joint length (calibrated zero and scale;
     * identity by default); saturated on overflow, which the limits then catch */
    (void)sp_length_from_sensor(node->ctrl_platform, node->length_sensors, leg, m.length, &d.length);
    d.force = spi_cylinder_force(node->ctrl_platform, m.pressure_a, m.pressure_b);
    d.no_force = 0u; /* the native feedback carries both chamber pressures */
    /* a drive in FAULT counts as faulty even without bits; bit 8, above the
     * DBC's eight, keeps the reported bits (a refused reset's cause) as sent */
    d.faults = (uint16_t)(m.faults | ((m.state == SP_DRIVE_STATE_FAULT) ? SP_DRIVE_FAULT_STATE : 0u));
    if (node->sync_valid && m.tick_echo == (uint16_t)(node->sync_tick & 0xFFFFu)) {
        node->in.drive[leg] = d;
    } else if (!node->ctrl_sync_master &&
               (!node->sync_valid || m.tick_echo == (uint16_t)((node->sync_tick + 1u) & 0xFFFFu))) {
        /* lockstep: the plant samples, sends the feedback, then SYNC closes the cycle */
        node->early[leg] = d;
        node->early_echo[leg] = m.tick_echo;
        node->early_valid[leg] = 1u;
    } else {
        inc(&node->stats.stale); /* valid, but it answers another cycle: not used */
        if (why != NULL) {
            *why = SP_PROTO_OK;
        }
        return SP_OK;
    }
    inc(&node->stats.accepted);
    return SP_OK;
}

/* The command authentication check of an authenticated frame (its CRC and
 * ranges checked): SP_PROTO_OK when its code checks (the counter becomes
 * the last accepted), else why it is rejected. Rejections change only the
 * counts (sp_auth_check). */
static sp_proto_error_t authenticate(sp_node_t *node, const sp_can_frame_t *f)
{
    if (!node->key_set) {
        return SP_PROTO_AUTH_NO_KEY;
    }
    switch (sp_proto_auth_check(&node->auth, &node->key, f)) {
    case SP_AUTH_OK:
        return SP_PROTO_OK;
    case SP_AUTH_REPLAYED:
        return SP_PROTO_AUTH_REPLAYED;
    case SP_AUTH_NO_SESSION:
        return SP_PROTO_AUTH_NO_KEY;
    default:
        return SP_PROTO_AUTH_BAD_TAG;
    }
}

/* The checks of a decoded operator frame (identifier, length, CRC and ranges
 * checked): its authentication code when it must carry one
 * (sp_proto_frame_needs_auth: the authenticated messages' table), then its
 * alive counter. A stranger's frames fail the first and so never touch the
 * genuine operator's E2E sequence. SP_PROTO_OK when the frame may be used. */
static sp_proto_error_t admit(sp_node_t *node, const sp_can_frame_t *f, sp_e2e_rx_t *rx, uint8_t counter)
{
    if (sp_proto_frame_needs_auth(f)) {
        sp_proto_error_t e = authenticate(node, f);
        if (e != SP_PROTO_OK) {
            return e;
        }
    }
    return sequence(node, rx, counter);
}

/* OP_COMMAND: decoded, admitted and queued. */
static sp_status_t receive_command(sp_node_t *node, const sp_can_frame_t *f, sp_proto_error_t *why)
{
    sp_proto_error_t e = SP_PROTO_OK;
    uint8_t counter = 0u;
    sp_msg_command_t m;
    if (sp_proto_decode_command(f, &m, &counter, &e) != SP_OK) {
        return reject(node, e, why);
    }
    e = admit(node, f, &node->rx_command, counter);
    /* ESTOP, STOP and PARK (a valid CRC) are taken even when their
     * alive counter repeats or jumps: a second operator process, a
     * resent emergency stop, any node on the bus (they carry no
     * authentication code either, so e can only be the counter's).
     * Refusing a stop is never the safe side. IDENTIFY, which only
     * reads, is taken so too: any tool may ask what it talks to. */
    if (e != SP_PROTO_OK && m.command != SP_CMD_ESTOP && m.command != SP_CMD_STOP && m.command != SP_CMD_PARK &&
        m.command != SP_CMD_IDENTIFY) {
        return reject(node, e, why);
    }
    if (m.command == SP_CMD_IDENTIFY) {
        node->identify_pending = 1u; /* answered by the node: no command slot, nothing for the controller */
        inc(&node->stats.accepted);
        return SP_OK;
    }
    if (node->cmd_count >= SP_NODE_CMD_QUEUE) {
        if (m.command != SP_CMD_ESTOP) {
            inc(&node->stats.cmd_overflow);
            return SP_E_BUSY;
        }
        /* an emergency stop replaces the newest waiting command */
        node->cmd_count--;
    }
    node->cmd_queue[(node->cmd_head + node->cmd_count) % SP_NODE_CMD_QUEUE] = m;
    node->cmd_count++;
    inc(&node->stats.accepted);
    return SP_OK;
}

/* OP_FRAME (authenticated: kept for the controller's next free command
 * slot) and OP_REACH (a query: answered by the node, the newest wins). */
static sp_status_t receive_frames(sp_node_t *node, const sp_can_frame_t *f, sp_proto_error_t *why)
{
    sp_proto_error_t e = SP_PROTO_OK;
    uint8_t counter = 0u;
    if (f->id == SP_ID_OP_FRAME) {
        sp_msg_frame_t m;
        if (sp_proto_decode_frame(f, &m, &counter, &e) != SP_OK) {
            return reject(node, e, why);
        }
        e = admit(node, f, &node->rx_frame, counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        if (m.op != SP_PROTO_FRAME_NONE) {
            node->frame = m;
            node->frame_fresh = 1u;
        }
        inc(&node->stats.accepted);
        return SP_OK;
    }
    if (f->id == SP_ID_OP_REACH) {
        sp_msg_reach_t m;
        if (sp_proto_decode_reach(f, &m, &counter, &e) != SP_OK) {
            return reject(node, e, why);
        }
        e = admit(node, f, &node->rx_reach, counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        node->reach = m;
        node->reach_pending = 1u;
        inc(&node->stats.accepted);
        return SP_OK;
    }
    return reject(node, SP_PROTO_UNKNOWN_ID, why);
}

/* 1 when a pose from OP_FRAME or OP_REACH holds the wire's "not a finite number". */
static int pose_not_finite(const sp_pose_t *p)
{
    for (uint32_t k = 0; k < 3u; k++) {
        if (p->pos[k] < -SP_PROTO_POSE_MAX_Q24 || p->rpy[k] < -SP_PROTO_POSE_MAX_Q24) {
            return 1;
        }
    }
    return 0;
}

static sp_status_t receive_ops(sp_node_t *node, const sp_can_frame_t *f, sp_proto_error_t *why)
{
    sp_proto_error_t e = SP_PROTO_OK;
    uint8_t counter = 0u;
    if (f->id == SP_ID_OP_COMMAND) {
        return receive_command(node, f, why);
    }
    if (f->id == SP_ID_OP_TARGET_POSE) {
        sp_pose_t pose;
        if (sp_proto_decode_target(f, &pose, &counter, &e) != SP_OK) {
            return reject(node, e, why);
        }
        e = admit(node, f, &node->rx_target, counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        node->target = pose;
        node->in.stream_target = pose;
        node->in.stream_fresh = 1u;
        inc(&node->stats.accepted);
        return SP_OK;
    }
    if (f->id == SP_ID_OP_HEARTBEAT) {
        if (sp_proto_decode_heartbeat(f, &counter, &e) != SP_OK) {
            return reject(node, e, why);
        }
        e = admit(node, f, &node->rx_heartbeat, counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        node->in.operator_heartbeat = 1u;
        inc(&node->stats.accepted);
        return SP_OK;
    }
    if (f->id == SP_ID_OP_FORCE) {
        sp_msg_force_t m;
        if (sp_proto_decode_force(f, &m, &counter, &e) != SP_OK) {
            return reject(node, e, why);
        }
        e = admit(node, f, &node->rx_force, counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        node->force = m;
        node->force_fresh = 1u;
        inc(&node->stats.accepted);
        return SP_OK;
    }
    if (f->id == SP_ID_OP_FORCE_PARAMS) {
        sp_msg_force_params_t m;
        if (sp_proto_decode_force_params(f, &m, &counter, &e) != SP_OK) {
            return reject(node, e, why); /* out-of-range parameters: counted by name */
        }
        e = admit(node, f, &node->rx_force_params, counter);
        if (e != SP_PROTO_OK) {
            return reject(node, e, why);
        }
        node->force_params = m;
        node->force_params_fresh = 1u;
        inc(&node->stats.accepted);
        return SP_OK;
    }
    return receive_frames(node, f, why);
}

/* FT_SENSOR (axis_b): the sensor's newest sample, this tick's reading. */
static sp_status_t receive_ft(sp_node_t *node, const sp_can_frame_t *f, sp_proto_error_t *why)
{
    sp_proto_error_t e = SP_PROTO_OK;
    uint8_t counter = 0u;
    sp_msg_ft_t m;
    if (f->bus != SP_BUS_AXIS_B) {
        return reject(node, SP_PROTO_WRONG_BUS, why);
    }
    if (sp_proto_decode_ft(f, &m, &counter, &e) != SP_OK) {
        return reject(node, e, why);
    }
    e = sequence(node, &node->rx_ft, counter);
    if (e != SP_PROTO_OK) {
        return reject(node, e, why);
    }
    for (uint32_t k = 0; k < 6u; k++) {
        node->in.ft_reading[k] = m.wrench[k];
    }
    node->in.ft_fresh = 1u;
    inc(&node->stats.ft_samples);
    inc(&node->stats.accepted);
    return SP_OK;
}

static int is_axis_id(uint32_t id)
{
    return id == SP_ID_SYNC || (id >= SP_ID_AXIS_FEEDBACK_1 && id < SP_ID_AXIS_FEEDBACK_1 + SP_AXIS_SLOTS);
}

sp_status_t sp_node_receive(sp_node_t *node, const sp_can_frame_t *frame, sp_proto_error_t *why)
{
    if (node == NULL || frame == NULL) {
        return SP_E_ARG;
    }
    if (why != NULL) {
        *why = SP_PROTO_OK;
    }
    if (frame->len > SP_CAN_MAX_DATA) {
        return reject(node, SP_PROTO_BAD_LENGTH, why);
    }
    if (is_axis_id(frame->id)) {
        if (frame->bus != SP_BUS_AXIS_A && frame->bus != SP_BUS_AXIS_B) {
            return reject(node, SP_PROTO_WRONG_BUS, why);
        }
        if (frame->id == SP_ID_SYNC && node->ctrl_sync_master) {
            return reject(node, SP_PROTO_UNKNOWN_ID, why); /* another cycle master on the bus */
        }
        return receive_axis(node, frame, why);
    }
    if (frame->id == SP_ID_FT_SENSOR) {
        return receive_ft(node, frame, why);
    }
    if (frame->id == SP_ID_OP_COMMAND || frame->id == SP_ID_OP_TARGET_POSE || frame->id == SP_ID_OP_HEARTBEAT ||
        frame->id == SP_ID_OP_FORCE || frame->id == SP_ID_OP_FORCE_PARAMS || frame->id == SP_ID_OP_FRAME ||
        frame->id == SP_ID_OP_REACH) {
        if (frame->bus != SP_BUS_OPS) {
            return reject(node, SP_PROTO_WRONG_BUS, why);
        }
        return receive_ops(node, frame, why);
    }
    return reject(node, SP_PROTO_UNKNOWN_ID, why);
}

int sp_node_cycle_ready(const sp_node_t *node, uint32_t *tick)
{
    if (node == NULL || !node->sync_valid || !node->sync_seen[0] || !node->sync_seen[1]) {
        return 0;
    }
    if (tick != NULL) {
        *tick = node->sync_tick;
    }
    return 1;
}

static void count_send(sp_node_t *node, sp_status_t st, uint32_t *n)
{
    if (st == SP_E_RANGE) {
        inc(&node->stats.saturated);
    }
    if (st == SP_OK || st == SP_E_RANGE) {
        (*n)++;
    }
}

/* The next queued operator command into node->in.cmd (none: SP_CMD_NONE).
 * SET_FEEDFORWARD is a tuning switch, applied here and only while no motion
 * is under way; ENGAGE is refused while drives_starting (the CANopen master
 * has not started every drive); returns 1 when a command is refused. FORCE and GUIDE take the mask
 * and target of the last OP_FORCE; with no command queued, a fresh OP_FORCE
 * while the controller is in FORCE becomes a FORCE command (the target
 * update; the controller refuses another mask). */
/* The node's jobs around the controller step stay out of line: their
 * locals must not join sp_node_tick's frame, which is on the tick's deepest
 * stack chain (through sp_ctrl_step). */
/* OP_FRAME into a FRAME command; one with a value that is not finite is
 * refused here (counted as NOT_FINITE): returns 1 then. */
static int take_frame(sp_node_t *node)
{
    node->frame_fresh = 0u;
    if (node->frame.op == SP_FRAME_SET && pose_not_finite(&node->frame.value)) {
        sp_ctrl_count_refusal(&node->ctrl, (uint8_t)SP_REFUSE_NOT_FINITE);
        return 1;
    }
    node->in.cmd.type = SP_CMD_FRAME;
    node->in.cmd.frame_op = node->frame.op;
    node->in.cmd.frame_kind = node->frame.kind;
    node->in.cmd.frame_index = node->frame.index;
    node->in.cmd.frame_value = node->frame.value;
    return 0;
}

SPI_NOINLINE static int take_command(sp_node_config_t *cfg, sp_node_t *node)
{
    int rejected = 0;
    memset(&node->in.cmd, 0, sizeof node->in.cmd);
    node->cmd_now = (uint8_t)SP_CMD_NONE;
    if (node->cmd_count > 0u) {
        const sp_msg_command_t *c = &node->cmd_queue[node->cmd_head];
        node->cmd_now = c->command;
        node->cmd_head = (uint8_t)((node->cmd_head + 1u) % SP_NODE_CMD_QUEUE);
        node->cmd_count--;
        if (c->command == SP_CMD_ENGAGE && node->drives_starting) {
            rejected = 1; /* the CANopen master has not started every drive: nothing may move yet */
        } else if (c->command == SP_CMD_SET_FEEDFORWARD) {
            if (node->ctrl.state == SP_STATE_IDLE || node->ctrl.state == SP_STATE_READY) {
                cfg->ctrl.force_feedforward = c->option;
            } else {
                rejected = 1;
            }
        } else {
            node->in.cmd.type = (sp_cmd_type_t)c->command;
            node->in.cmd.axis = (sp_axis_t)c->axis;
            node->in.cmd.amplitude = c->amplitude;
            node->in.cmd.frequency = c->frequency;
            node->in.cmd.fade_ticks =
                cfg->ctrl.tick_us ? (uint32_t)(((uint64_t)c->fade_ms * 1000u) / cfg->ctrl.tick_us) : 0u;
            node->in.cmd.target = node->target;
            if (c->command == SP_CMD_FORCE || c->command == SP_CMD_GUIDE) {
                node->force_fresh = 0u; /* this command carries the last OP_FORCE: no second update */
                node->in.cmd.force_mask = node->force.mask;
                for (uint32_t k = 0; k < 6u; k++) {
                    node->in.cmd.force_target[k] = node->force.target[k];
                }
            }
        }
    } else if (node->frame_fresh) {
        rejected = take_frame(node);
    } else if (node->force_params_fresh) {
        /* new admittance parameters: a command of their own (the controller
         * takes them in position control, refuses them otherwise) */
        const sp_msg_force_params_t *p = &node->force_params;
        node->cmd_now = (uint8_t)SP_REFUSED_FORCE_PARAMS;
        node->in.cmd.type = SP_CMD_FORCE_PARAMS;
        node->in.cmd.force_mask = p->mask;
        node->in.cmd.force_params_mode = p->mode;
        node->in.cmd.force_params_mass = p->mass;
        node->in.cmd.force_params_damping = p->damping;
        node->in.cmd.force_params_stiffness = p->stiffness;
        node->force_params_fresh = 0u;
    } else if (node->force_fresh && node->ctrl.force.mode == SP_FORCE_FORCE) {
        node->in.cmd.type = SP_CMD_FORCE;
        node->in.cmd.force_mask = node->force.mask;
        for (uint32_t k = 0; k < 6u; k++) {
            node->in.cmd.force_target[k] = node->force.target[k];
        }
        node->force_fresh = 0u;
    }
    if (node->ctrl.force.mode != SP_FORCE_FORCE) {
        node->force_fresh = 0u; /* kept for the next FORCE command; nothing to update */
    }
    return rejected;
}

/* The setpoints for the cycle that the next SYNC starts, one frame per axis
 * bus, then (as the SYNC master) the SYNC frames. */
SPI_NOINLINE static void send_axis_frames(const sp_node_config_t *cfg, sp_node_t *node, uint32_t tick,
                                          sp_can_frame_t out[], uint32_t *n)
{
    for (uint8_t b = 0; b < 2u; b++) {
        sp_msg_setpoints_t m;
        m.tick = tick;
        m.mode = (uint8_t)node->out.drive_mode;
        m.fault_reset = node->out.drive_fault_reset;
        m.block = node->out.drive_block;
        for (uint32_t s = 0; s < SP_AXIS_SLOTS; s++) {
            m.setpoint[s] = node->out.setpoint[b * SP_AXIS_SLOTS + s];
            /* joint-to-joint length -> what the drive's sensor is to read there */
            uint32_t leg = ((uint32_t)b * SP_AXIS_SLOTS) + s;
            (void)sp_length_to_sensor(node->ctrl_platform, node->length_sensors, leg, m.setpoint[s].length,
                                      &m.setpoint[s].length);
        }
        count_send(
            node,
            sp_proto_encode_setpoints(&m, node->tx_counter_setpoints[b]++, (uint8_t)(SP_BUS_AXIS_A + b), &out[*n]), n);
        node->tx_counter_setpoints[b] &= 0x0Fu;
    }
    if (cfg->sync_master) {
        for (uint8_t b = 0; b < 2u; b++) {
            sp_msg_sync_t m = {tick, node->out.state == SP_STATE_ESTOP ? 1u : 0u};
            count_send(node,
                       sp_proto_encode_sync(&m, node->tx_counter_sync[b]++, (uint8_t)(SP_BUS_AXIS_A + b), &out[*n]), n);
            node->tx_counter_sync[b] &= 0x0Fu;
        }
        node->sync_tick = tick;
        node->sync_valid = 1u;
    }
    node->sync_seen[0] = 0u;
    node->sync_seen[1] = 0u;
}

/* The controller's status and monitor frames to the operator bus, on even
 * ticks the wrench estimate (CTRL_WRENCH, 500 Hz), and every 10 ticks,
 * first, the command authentication's state (CTRL_AUTH, 100 Hz). */
SPI_NOINLINE static void send_ops_frames(const sp_node_config_t *cfg, sp_node_t *node, uint32_t tick,
                                         sp_can_frame_t out[], uint32_t *n)
{
    if (tick % SP_PROTO_AUTH_PERIOD == 0u) {
        sp_msg_auth_t a;
        a.session = node->auth.session;
        a.last_counter = node->auth.last;
        a.bad_tag = node->auth.bad_tag;
        a.replayed = node->auth.replayed;
        a.key_set = node->key_set;
        count_send(node, sp_proto_encode_auth(&a, node->tx_counter_auth++, &out[*n]), n);
        node->tx_counter_auth &= 0x0Fu;
    }
    sp_msg_status_t s;
    s.tick = tick;
    s.state = (uint8_t)node->out.state;
    s.faults = (uint16_t)(node->out.faults & 0xFFFFu);
    s.fk_iterations = (uint8_t)(node->out.fk_iterations > 15u ? 15u : node->out.fk_iterations);
    s.estimate_valid = node->out.estimate_valid;
    s.cmd_rejected = node->out.cmd_rejected;
    s.drive_mode = (uint8_t)node->out.drive_mode;
    s.feedforward = cfg->ctrl.force_feedforward;
    s.force_mode = (uint8_t)(node->out.force_mode > 4u ? 4u : node->out.force_mode);
    s.contact = node->out.contact;
    s.estimate = node->out.estimate;
    s.reset_refused_legs = node->out.reset_refused_legs;
    s.reset_refused_cause = node->out.reset_refused_cause;
    s.drives_starting = node->drives_starting;
    s.force_unmeasured = node->out.force_unmeasured;
    s.refusals = (uint8_t)(node->stats.cmd_refused & 0x07u);
    s.stop_reaction = (uint8_t)(node->out.stop_reaction > 2u ? 2u : node->out.stop_reaction);
    count_send(node, sp_proto_encode_status(&s, node->tx_counter_status++, &out[*n]), n);
    node->tx_counter_status &= 0x0Fu;

    sp_msg_monitor_t mon;
    mon.tick = tick;
    mon.reference = node->out.reference.pose;
    for (uint32_t i = 0; i < SP_LEGS; i++) {
        mon.length_sp[i] = node->out.setpoint[i].length;
        mon.force_ff[i] = node->out.setpoint[i].force;
    }
    count_send(node, sp_proto_encode_monitor(&mon, node->tx_counter_monitor++, &out[*n]), n);
    node->tx_counter_monitor &= 0x0Fu;

    if (tick % SP_PROTO_WRENCH_PERIOD == 0u) {
        sp_msg_wrench_t w;
        w.tick = tick;
        w.valid = node->out.wrench_valid;
        /* at the tool point with frames (on this tick only: not every tick) */
        (void)sp_ctrl_wrench_at_tool(&node->ctrl, node->out.wrench, w.wrench);
        count_send(node, sp_proto_encode_wrench(&w, node->tx_counter_wrench++, &out[*n]), n);
        node->tx_counter_wrench &= 0x0Fu;
    }
}

/* CTRL_REACH, the answer to the last OP_REACH: the controller's reach check
 * (sp_ctrl_reach, the check its MOVE_TO makes), or NOT_FINITE (counted). */
SPI_NOINLINE static void send_reach(const sp_node_config_t *cfg, sp_node_t *node, sp_can_frame_t out[], uint32_t *n)
{
    sp_msg_reach_answer_t a;
    sp_reach_t r;
    memset(&a, 0, sizeof a);
    a.sequence = node->reach.sequence;
    if (pose_not_finite(&node->reach.pose)) {
        a.verdict = SP_PROTO_REACH_NOT_FINITE;
        sp_ctrl_count_refusal(&node->ctrl, (uint8_t)SP_REFUSE_NOT_FINITE);
    } else if (sp_ctrl_reach(&cfg->ctrl, &node->ctrl, &node->reach.pose, &r) == SP_OK) {
        a.verdict = r.verdict;
        a.which = r.which;
        a.excess = r.excess;
        for (uint32_t i = 0; i < SP_LEGS; i++) {
            a.force[i] = r.force[i];
        }
    } else {
        a.verdict = (uint8_t)SP_REACH_COMPUTE;
    }
    count_send(node, sp_proto_encode_reach_answer(&a, node->tx_counter_reach++, &out[*n]), n);
    node->tx_counter_reach &= 0x0Fu;
    node->reach_pending = 0u;
}

/* CTRL_FRAMES: the active frames, their checksum and the refusals. */
SPI_NOINLINE static void send_frames(sp_node_t *node, sp_can_frame_t out[], uint32_t *n)
{
    sp_msg_frames_t m;
    const sp_ctrl_t *c = &node->ctrl;
    m.tool_index = c->slots.tool_active;
    m.work_index = c->slots.work_active;
    m.identity = c->frames.identity;
    m.last_refusal = c->last_refusal;
    m.checksum = c->frames_crc;
    /* every reason but LINK (CTRL_STATUS Refusals counts it with the others) */
    static const uint8_t sent[SP_PROTO_FRAMES_REFUSED] = {
        SP_REFUSE_STATE, SP_REFUSE_RANGE,      SP_REFUSE_REACH,     SP_REFUSE_RATE,
        SP_REFUSE_FORCE, SP_REFUSE_EMPTY_SLOT, SP_REFUSE_BAD_FRAME, SP_REFUSE_NOT_FINITE};
    for (uint32_t k = 0; k < SP_PROTO_FRAMES_REFUSED; k++) {
        m.refused[k] = c->refusals[sent[k]];
    }
    count_send(node, sp_proto_encode_frames(&m, node->tx_counter_frames++, &out[*n]), n);
    node->tx_counter_frames &= 0x0Fu;
}

/* CTRL_IDENTITY, the answer to IDENTIFY: the firmware's version, its port
 * and the DBC it was built from. */
SPI_NOINLINE static void send_identity(const sp_node_config_t *cfg, sp_node_t *node, sp_can_frame_t out[], uint32_t *n)
{
    sp_msg_identity_t id;
    id.major = SP_VERSION_MAJOR;
    id.minor = SP_VERSION_MINOR;
    id.patch = SP_VERSION_PATCH;
    id.port = cfg->port;
    id.protocol_hash = sp_proto_dbc_hash;
    count_send(node, sp_proto_encode_identity(&id, node->tx_counter_identity++, &out[*n]), n);
    node->tx_counter_identity &= 0x0Fu;
    node->identify_pending = 0u;
}

/* The refusal of this tick, kept for CTRL_REFUSAL: what (this tick's
 * command, else a streamed target) and why (the controller's reason; the
 * node's own refusals, ENGAGE while the drives start and SET_FEEDFORWARD
 * outside IDLE and READY, are of the state). */
static void note_refusal(sp_node_t *node, uint32_t tick)
{
    node->refusal.tick = tick;
    node->refusal.command = (node->cmd_now != (uint8_t)SP_CMD_NONE) ? node->cmd_now : (uint8_t)SP_REFUSED_TARGET;
    node->refusal.reason =
        (node->out.refuse_reason != (uint8_t)SP_REFUSE_NONE && node->out.refuse_reason < SP_REFUSE_COUNT)
            ? node->out.refuse_reason
            : (uint8_t)SP_REFUSE_STATE;
    node->refusal_pending = 1u;
}

/* CTRL_REFUSAL: on a tick without CTRL_AUTH or CTRL_IDENTITY, at most one
 * in 10 ticks (a refused stream may refuse a target every tick). */
static void send_refusal(sp_node_t *node, uint32_t tick, sp_can_frame_t out[], uint32_t *n)
{
    if (!node->refusal_pending || tick % SP_PROTO_AUTH_PERIOD == 0u ||
        (node->refusal_sent_valid && tick - node->refusal_sent < SP_PROTO_AUTH_PERIOD)) {
        return;
    }
    count_send(node, sp_proto_encode_refusal(&node->refusal, node->tx_counter_refusal++, &out[*n]), n);
    node->tx_counter_refusal &= 0x0Fu;
    node->refusal_pending = 0u;
    node->refusal_sent = tick;
    node->refusal_sent_valid = 1u;
}

sp_status_t sp_node_tick(sp_node_config_t *cfg, sp_node_t *node, sp_can_frame_t out[SP_NODE_MAX_TX], uint32_t *n)
{
    if (cfg == NULL || node == NULL || out == NULL || n == NULL || cfg->ctrl.platform == NULL) {
        return SP_E_ARG;
    }
    *n = 0u;
    node->ctrl_platform = cfg->ctrl.platform;
    node->length_sensors = cfg->length_sensors;
    node->ctrl_sync_master = cfg->sync_master;

    int ff_rejected = take_command(cfg, node);
    sp_status_t st = sp_ctrl_step(&cfg->ctrl, &node->ctrl, &node->in, &node->out);
    if (st != SP_OK) {
        return st;
    }
    if (ff_rejected) {
        node->out.cmd_rejected = 1u;
    }
    uint32_t tick = cfg->sync_master ? node->out.tick : node->sync_tick;
    if (node->out.cmd_rejected) {
        inc(&node->stats.cmd_refused);
        note_refusal(node, tick);
    }
    for (uint32_t i = 0; i < SP_LEGS; i++) {
        node->in.drive[i].fresh = 0u;
    }
    node->in.stream_fresh = 0u;
    node->in.operator_heartbeat = 0u;
    node->in.ft_fresh = 0u;

    send_axis_frames(cfg, node, tick, out, n);
    /* one answer a tick besides (never with CTRL_AUTH: SP_NODE_MAX_TX), the
     * reach query's first; ahead of CTRL_STATUS, so that a reader holding a
     * tick's CTRL_STATUS holds every optional frame of that tick (the
     * plant's lockstep logs the same order over vcan as in memory) */
    if (node->reach_pending && tick % SP_PROTO_AUTH_PERIOD != 0u) {
        send_reach(cfg, node, out, n);
    } else if (node->identify_pending && tick % SP_PROTO_AUTH_PERIOD != 0u) {
        send_identity(cfg, node, out, n);
    } else {
        send_refusal(node, tick, out, n);
    }
    send_ops_frames(cfg, node, tick, out, n);
    if (tick % SP_PROTO_FRAMES_PERIOD == SP_PROTO_FRAMES_PHASE) {
        send_frames(node, out, n);
    }
    return SP_OK;
}
