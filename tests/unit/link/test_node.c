/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The controller as a CAN node (sp/link/node.h) with the protocol layer
 * (sp/link/protocol.h): a drive-side rig in the test answers every SYNC with
 * feedback frames (an ideal plant: each leg sits at its last length
 * setpoint), the operator sends commands as frames. Checks the whole frame
 * path, the rejection of malformed frames, and a fuzz run of the receive
 * path.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "assert_near.h"
#include "sp/link/node.h"
#include "sp/math/version.h"
#include "test_util.h"

typedef struct {
    sp_node_config_t cfg;
    sp_node_t node;
    sp_q24_t length[SP_LEGS];
    uint8_t fb_counter[SP_LEGS];
    uint8_t op_counter;
    uint8_t params_counter; /* OP_FORCE_PARAMS's own alive counter */
    int silent[SP_LEGS];
    sp_can_frame_t sent[SP_NODE_MAX_TX];
    uint32_t n_sent;
    uint32_t wrench_frames;      /* CTRL_WRENCH frames seen */
    uint32_t wrench_valid;       /* of which Valid = 1 */
    uint8_t wrench_counter;      /* Counter of the last one */
    sp_auth_key_t key;           /* the test's throw-away machine key */
    uint32_t auth_counter;       /* the operator's authentication counter (last used) */
    uint32_t auth_frames;        /* CTRL_AUTH frames seen */
    sp_msg_auth_t auth;          /* the last one */
    int identify_asked;          /* an IDENTIFY was sent and not yet answered */
    uint32_t identity_frames;    /* CTRL_IDENTITY frames seen */
    sp_msg_identity_t identity;  /* the last one */
    uint8_t identity_counter;    /* its Counter */
    uint32_t reach_frames;       /* CTRL_REACH frames seen */
    sp_msg_reach_answer_t reach; /* the last one */
    uint32_t frames_frames;      /* CTRL_FRAMES frames seen */
    sp_msg_frames_t frames;      /* the last one */
    uint32_t refusal_frames;     /* CTRL_REFUSAL frames seen */
    sp_msg_refusal_t refusal;    /* the last one */
} rig_t;

#define RIG_SESSION 0x5EED1234u

static void rig_init(rig_t *r)
{
    memset(r, 0, sizeof *r);
    assert_int_equal(sp_node_default_config(&r->cfg, &sp_platform_default), SP_OK);
    for (uint32_t i = 0; i < SP_AUTH_KEY_BYTES; i++) {
        r->key.k[i] = (uint8_t)(0xA0u + 7u * i);
    }
    r->cfg.auth_key = &r->key;
    r->cfg.auth_session = RIG_SESSION;
    assert_int_equal(sp_node_init(&r->node, &r->cfg), SP_OK);
    sp_ik_t ik;
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik), SP_OK);
    memcpy(r->length, ik.length, sizeof r->length);
}

/* Signs an operator frame as `stewart op` does: the next counter. */
static void sign(rig_t *r, sp_can_frame_t *f)
{
    assert_int_equal(sp_proto_sign(f, &r->key, RIG_SESSION, ++r->auth_counter), SP_OK);
}

static void send_command(rig_t *r, uint8_t command)
{
    sp_msg_command_t c;
    memset(&c, 0, sizeof c);
    c.command = command;
    c.axis = SP_AXIS_X;
    c.amplitude = (sp_q24_t)(0.09 * 16777216.0);
    c.frequency = (sp_q24_t)(0.5 * 16777216.0);
    c.fade_ms = 500u;
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_command(&c, r->op_counter++, &f), SP_OK);
    sign(r, &f);
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* The drives: apply the setpoints that were sent, answer the SYNC. */
static void rig_tick(rig_t *r)
{
    assert_int_equal(sp_node_tick(&r->cfg, &r->node, r->sent, &r->n_sent), SP_OK);
    /* setpoints x2, SYNC x2, status, monitor; + CTRL_WRENCH on even ticks,
     * + CTRL_AUTH every 10, + CTRL_FRAMES every 100 (phase 5); + CTRL_REACH,
     * CTRL_IDENTITY or CTRL_REFUSAL when due, after the axis frames and ahead
     * of CTRL_STATUS */
    uint32_t even = (r->node.out.tick % 2u) == 0u ? 1u : 0u;
    uint32_t tenth = (r->node.out.tick % SP_PROTO_AUTH_PERIOD) == 0u ? 1u : 0u;
    uint32_t frames = (r->node.out.tick % SP_PROTO_FRAMES_PERIOD) == SP_PROTO_FRAMES_PHASE ? 1u : 0u;
    uint32_t identity = r->n_sent > 4u && (r->sent[4].id == SP_ID_CTRL_IDENTITY || r->sent[4].id == SP_ID_CTRL_REACH ||
                                           r->sent[4].id == SP_ID_CTRL_REFUSAL)
                            ? 1u
                            : 0u;
    assert_int_equal(r->n_sent, 6u + even + tenth + frames + identity);
    uint32_t sync_tick = 0;
    int syncs = 0;
    for (uint32_t k = 0; k < r->n_sent; k++) {
        const sp_can_frame_t *f = &r->sent[k];
        uint8_t counter;
        sp_proto_error_t e;
        if (f->id == SP_ID_CTRL_IDENTITY) {
            assert_true(r->identify_asked); /* never unasked */
            assert_int_equal(tenth, 0u);    /* never beside CTRL_AUTH: at most SP_NODE_MAX_TX frames */
            assert_int_equal(f->bus, SP_BUS_OPS);
            assert_int_equal(sp_proto_decode_identity(f, &r->identity, &counter, &e), SP_OK);
            r->identity_counter = counter;
            r->identity_frames++;
            r->identify_asked = 0;
        } else if (f->id == SP_ID_CTRL_REACH) {
            assert_int_equal(tenth, 0u);
            assert_int_equal(k, 4u); /* ahead of CTRL_STATUS */
            assert_int_equal(sp_proto_decode_reach_answer(f, &r->reach, &counter, &e), SP_OK);
            r->reach_frames++;
        } else if (f->id == SP_ID_CTRL_FRAMES) {
            assert_int_equal(sp_proto_decode_frames(f, &r->frames, &counter, &e), SP_OK);
            r->frames_frames++;
        } else if (f->id == SP_ID_CTRL_REFUSAL) {
            assert_int_equal(tenth, 0u); /* never beside CTRL_AUTH */
            assert_int_equal(f->bus, SP_BUS_OPS);
            assert_int_equal(sp_proto_decode_refusal(f, &r->refusal, &counter, &e), SP_OK);
            r->refusal_frames++;
        } else if (f->id == SP_ID_CTRL_AUTH) {
            assert_int_equal(f->bus, SP_BUS_OPS);
            assert_int_equal(k, 4u); /* ahead of CTRL_STATUS */
            assert_int_equal(sp_proto_decode_auth(f, &r->auth, &counter, &e), SP_OK);
            r->auth_frames++;
        } else if (f->id == SP_ID_CTRL_WRENCH) {
            sp_msg_wrench_t w;
            assert_int_equal(f->bus, SP_BUS_OPS);
            assert_int_equal(sp_proto_decode_wrench(f, &w, &counter, &e), SP_OK);
            assert_int_equal(w.tick, r->node.out.tick);
            assert_int_equal(w.valid, r->node.out.wrench_valid);
            int32_t at_tool[6]; /* with frames, at the tool point: what the frame carries */
            assert_int_equal(sp_ctrl_wrench_at_tool(&r->node.ctrl, r->node.out.wrench, at_tool), SP_OK);
            for (uint32_t c = 0; c < 6u; c++) {
                /* 0.25 N steps = 64 Q8 LSBs: within half a step */
                int64_t d = (int64_t)w.wrench[c] - at_tool[c];
                assert_true(d >= -32 && d <= 32);
            }
            if (r->wrench_frames > 0u) {
                assert_int_equal(counter, (r->wrench_counter + 1u) & 0x0Fu);
            }
            r->wrench_counter = counter;
            r->wrench_frames++;
            r->wrench_valid += w.valid;
        } else if (f->id == SP_ID_AXIS_SETPOINTS) {
            sp_msg_setpoints_t m;
            assert_int_equal(sp_proto_decode_setpoints(f, &m, &counter, &e), SP_OK);
            if (m.mode == SP_DRIVE_ACTIVE) {
                for (uint32_t s = 0; s < 3u; s++) {
                    r->length[(f->bus - 1u) * 3u + s] = m.setpoint[s].length;
                }
            }
        } else if (f->id == SP_ID_SYNC) {
            sp_msg_sync_t m;
            assert_int_equal(sp_proto_decode_sync(f, &m, &counter, &e), SP_OK);
            sync_tick = m.tick;
            syncs++;
        }
    }
    assert_int_equal(syncs, 2);
    for (uint32_t i = 0; i < SP_LEGS; i++) {
        if (r->silent[i]) {
            continue;
        }
        sp_msg_feedback_t fb = {r->length[i],          3000000u, 1000000u,
                                SP_DRIVE_STATE_ACTIVE, 0u,       (uint16_t)(sync_tick & 0xFFFFu)};
        sp_can_frame_t f;
        sp_status_t st = sp_proto_encode_feedback(&fb, (uint8_t)(i % 3u + 1u), r->fb_counter[i]++,
                                                  (uint8_t)(SP_BUS_AXIS_A + i / 3u), &f);
        assert_int_equal(st, SP_OK);
        assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
    }
}

static void send_force(rig_t *r, uint8_t mask, double fz)
{
    sp_msg_force_t m;
    memset(&m, 0, sizeof m);
    m.mask = mask;
    m.target[2] = (sp_q8_t)(fz * 256.0);
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_force(&m, r->op_counter++, &f), SP_OK);
    sign(r, &f);
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* One OP_FORCE_PARAMS frame (mode 1: FORCE's damping). */
static void send_force_params(rig_t *r, uint8_t mask, double mass, int32_t damping, int32_t stiffness)
{
    sp_msg_force_params_t m = {mask, 1u, (sp_q16_t)(mass * 65536.0), damping, stiffness};
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_force_params(&m, r->params_counter++, &f), SP_OK);
    sign(r, &f);
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* One FT_SENSOR frame on axis_b (the sensor at rest: fz N of bias). */
static void send_ft(rig_t *r, uint8_t counter, double fz)
{
    sp_msg_ft_t m;
    memset(&m, 0, sizeof m);
    m.wrench[2] = (sp_q8_t)(fz * 256.0);
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_ft(&m, counter, &f), SP_OK);
    assert_int_equal(f.bus, SP_BUS_AXIS_B);
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* CTRL_STATUS of the last tick. */
static sp_msg_status_t last_status(const rig_t *r)
{
    sp_msg_status_t s;
    memset(&s, 0, sizeof s);
    for (uint32_t k = 0; k < r->n_sent; k++) {
        if (r->sent[k].id == SP_ID_CTRL_STATUS) {
            uint8_t counter;
            sp_proto_error_t e;
            assert_int_equal(sp_proto_decode_status(&r->sent[k], &s, &counter, &e), SP_OK);
        }
    }
    return s;
}

/* OP_COMMAND IDENTIFY as any tool sends it: unsigned, with the given alive counter. */
static void send_identify(rig_t *r, uint8_t counter)
{
    sp_msg_command_t c;
    memset(&c, 0, sizeof c);
    c.command = SP_CMD_IDENTIFY;
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_command(&c, counter, &f), SP_OK);
    assert_false(sp_proto_frame_needs_auth(&f));
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
    r->identify_asked = 1;
}

/* Asks in the node's present state: one CTRL_IDENTITY on the next tick with
 * the build's version, the port and the DBC's hash; the state, the
 * command queue and the refusals untouched. */
static void identify_now(rig_t *r, uint8_t port)
{
    uint32_t frames = r->identity_frames;
    uint32_t refused = r->node.stats.cmd_refused;
    sp_state_t before = r->node.out.state;
    if ((r->node.out.tick + 1u) % SP_PROTO_AUTH_PERIOD == 0u) {
        rig_tick(r); /* the next tick sends CTRL_AUTH: ask on the one after */
    }
    send_identify(r, r->op_counter++);
    assert_int_equal(r->node.cmd_count, 0u); /* no command slot */
    rig_tick(r);
    assert_int_equal(r->identity_frames, frames + 1u);
    assert_int_equal(r->identity.major, SP_VERSION_MAJOR);
    assert_int_equal(r->identity.minor, SP_VERSION_MINOR);
    assert_int_equal(r->identity.patch, SP_VERSION_PATCH);
    assert_int_equal(r->identity.port, port);
    assert_int_equal(r->identity.protocol_hash, sp_proto_dbc_hash);
    assert_false(last_status(r).cmd_rejected);
    assert_int_equal(r->node.stats.cmd_refused, refused);
    if (before != SP_STATE_ENGAGING && before != SP_STATE_PARKING) {
        assert_int_equal(r->node.out.state, before);
    }
}

static void run_until(rig_t *r, sp_state_t state, uint32_t max_ticks)
{
    for (uint32_t t = 0; t < max_ticks && r->node.out.state != state; t++) {
        rig_tick(r);
    }
    assert_int_equal(r->node.out.state, state);
}

static void send_heartbeat(rig_t *r, uint8_t counter)
{
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_heartbeat(counter, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* Drives that measure no cylinder force (the CiA 402 / 408-without-
 * pressures link sets no_force in the node's drive input): CTRL_STATUS
 * names their legs in ForceUnmeasured while they say so, and the wrench
 * estimate is invalid; native feedback (both pressures) clears it. */
static void test_status_names_legs_without_force(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    for (uint32_t t = 0; t < 5u; t++) {
        rig_tick(&r);
    }
    assert_int_equal(last_status(&r).force_unmeasured, 0u);
    r.node.in.drive[1].no_force = 1u; /* as sp_co_link_feedback leaves it */
    r.node.in.drive[4].no_force = 1u;
    rig_tick(&r);
    assert_int_equal(last_status(&r).force_unmeasured, 0x12u);
    assert_int_equal(r.node.out.wrench_valid, 0u);
    rig_tick(&r); /* native feedback of the last tick: every leg measures */
    assert_int_equal(last_status(&r).force_unmeasured, 0u);
}

/* ENGAGE while the CANopen master is still starting the drives (the port
 * sets drives_starting): refused with the reason in CTRL_STATUS
 * (CmdRejected, DrivesStarting), counted, the controller stays IDLE; once
 * every drive runs the same ENGAGE is taken. */
static void test_engage_refused_while_drives_start(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    for (uint32_t t = 0; t < 5u; t++) {
        rig_tick(&r); /* every drive heard, an estimate */
    }
    assert_int_equal(r.node.out.estimate_valid, 1u);
    r.node.drives_starting = 1u;
    send_command(&r, SP_CMD_ENGAGE);
    rig_tick(&r);
    sp_msg_status_t s = last_status(&r);
    assert_int_equal(s.cmd_rejected, 1u);
    assert_int_equal(s.drives_starting, 1u);
    assert_int_equal(s.refusals, 1u);
    assert_int_equal(r.node.stats.cmd_refused, 1u);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_IDLE);
    s = last_status(&r); /* CmdRejected for one status; the count stays */
    assert_int_equal(s.cmd_rejected, 0u);
    assert_int_equal(s.refusals, 1u);
    r.node.drives_starting = 0u;
    send_command(&r, SP_CMD_ENGAGE);
    rig_tick(&r);
    s = last_status(&r);
    assert_int_equal(s.cmd_rejected, 0u);
    assert_int_equal(s.drives_starting, 0u);
    assert_int_equal(r.node.out.state, SP_STATE_ENGAGING);
    assert_int_equal(r.node.stats.cmd_refused, 1u);
    assert_int_equal(s.refusals, 1u);
}

/* CTRL_STATUS Refusals counts refused commands modulo 8 (3 bits): eight
 * more refusals (a second ENGAGE, not taken outside IDLE) bring it back to
 * where it was, one more moves it on; an accepted command leaves it. */
static void test_status_counts_refusals_modulo_8(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    for (uint32_t t = 0; t < 5u; t++) {
        rig_tick(&r);
    }
    send_command(&r, SP_CMD_ENGAGE);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_ENGAGING);
    assert_int_equal(last_status(&r).refusals, 0u);
    for (uint32_t k = 1u; k <= 9u; k++) {
        send_command(&r, SP_CMD_ENGAGE);
        rig_tick(&r);
        sp_msg_status_t s = last_status(&r);
        assert_int_equal(s.cmd_rejected, 1u);
        assert_int_equal(s.refusals, k % 8u);
        assert_int_equal(r.node.stats.cmd_refused, k);
    }
}

/* CTRL_REFUSAL: the refused command and its reason on the tick after the
 * refusal, its Tick the CTRL_STATUS tick that said CmdRejected; at most
 * one in 10 ticks, the latest refusal kept. */
static void test_refusal_frames(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    for (uint32_t t = 0; t < 5u; t++) {
        rig_tick(&r);
    }
    send_command(&r, SP_CMD_RUN_TRIG); /* IDLE: the state's */
    rig_tick(&r);
    uint32_t refused_at = last_status(&r).tick;
    assert_int_equal(last_status(&r).cmd_rejected, 1u);
    for (uint32_t t = 0; t < 3u; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.refusal_frames, 1u);
    assert_int_equal(r.refusal.command, SP_CMD_RUN_TRIG);
    assert_int_equal(r.refusal.reason, SP_REFUSE_STATE);
    assert_int_equal(r.refusal.tick, refused_at);
    send_command(&r, SP_CMD_ENGAGE);
    run_until(&r, SP_STATE_READY, 10000u);
    uint32_t before = r.refusal_frames;
    /* READY: 90 mm at 3 Hz drives a leg beyond 0.5 m/s: RATE; then STOP (not RUNNING: the state's) */
    sp_msg_command_t c;
    memset(&c, 0, sizeof c);
    c.command = SP_CMD_RUN_TRIG;
    c.axis = SP_AXIS_X;
    c.amplitude = (sp_q24_t)(0.09 * 16777216.0);
    c.frequency = 3 * SP_Q24_ONE;
    c.fade_ms = 500u;
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_command(&c, r.op_counter++, &f), SP_OK);
    sign(&r, &f);
    assert_int_equal(sp_node_receive(&r.node, &f, NULL), SP_OK);
    rig_tick(&r);
    assert_int_equal(r.node.out.refuse_reason, SP_REFUSE_RATE);
    send_command(&r, SP_CMD_STOP);
    rig_tick(&r);
    for (uint32_t t = 0; t < 25u; t++) {
        rig_tick(&r);
    }
    /* both within 10 ticks: the later one went out, once */
    assert_true(r.refusal_frames == before + 1u || r.refusal_frames == before + 2u);
    assert_int_equal(r.refusal.command, SP_CMD_STOP);
    assert_int_equal(r.refusal.reason, SP_REFUSE_STATE);
    assert_int_equal(r.node.ctrl.state, SP_STATE_READY);
}

/* OP_HEARTBEAT over frames: a heartbeat with a bad CRC is dropped and arms
 * nothing; a good one arms the supervision; silent for the timeout while
 * RUNNING, CTRL_STATUS reports the operator-silent fault (bit 8) and the
 * motion ends in READY. */
static void test_operator_heartbeat_over_frames(void **state)
{
    (void)state;
    static rig_t r;
    sp_can_frame_t f;
    sp_proto_error_t why;
    rig_init(&r);
    rig_tick(&r);
    rig_tick(&r);
    assert_int_equal(sp_proto_encode_heartbeat(0u, &f), SP_OK);
    f.data[3] ^= 1u;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_BAD_CRC);
    rig_tick(&r);
    assert_int_equal(r.node.ctrl.link.armed, 0u);
    send_heartbeat(&r, 0u);
    rig_tick(&r);
    assert_int_equal(r.node.ctrl.link.armed, 1u);
    assert_int_equal(r.node.ctrl.link.silent, 0u);
    send_command(&r, SP_CMD_ENGAGE);
    for (uint32_t t = 0; t < 10000u && r.node.out.state != SP_STATE_READY; t++) {
        if (t % 20u == 0u) {
            send_heartbeat(&r, (uint8_t)(t / 20u + 1u));
        }
        rig_tick(&r);
    }
    assert_int_equal(r.node.out.state, SP_STATE_READY);
    /* the last heartbeat with RUN_TRIG: the silence counts from this tick */
    send_command(&r, SP_CMD_RUN_TRIG);
    send_heartbeat(&r, (uint8_t)(r.node.rx_heartbeat.last + 1u));
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_RUNNING);
    for (uint32_t t = 1; t < r.cfg.ctrl.operator_timeout_ticks; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.node.out.faults, 0u);
    rig_tick(&r);
    assert_int_equal(r.node.out.faults, SP_FAULT_OPERATOR_SILENT);
    /* the status frame carries it */
    sp_msg_status_t s;
    uint8_t counter;
    int found = 0;
    for (uint32_t k = 0; k < r.n_sent; k++) {
        if (r.sent[k].id == SP_ID_CTRL_STATUS) {
            assert_int_equal(sp_proto_decode_status(&r.sent[k], &s, &counter, NULL), SP_OK);
            assert_int_equal(s.faults, 0x100u);
            assert_int_equal(s.state, SP_STATE_RUNNING);
            found = 1;
        }
    }
    assert_true(found);
    run_until(&r, SP_STATE_READY, 10000u);
    assert_int_equal(r.node.out.faults, SP_FAULT_OPERATOR_SILENT);
}

/* OP_COMMAND IDENTIFY: one CTRL_IDENTITY per request in every state,
 * unsigned, never without a request (rig_tick fails on an unasked one). */
static void test_identify_over_frames(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    assert_false(sp_proto_command_needs_auth(SP_CMD_IDENTIFY));
    for (int t = 0; t < 50; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.identity_frames, 0u);
    identify_now(&r, SP_PORT_UNSPECIFIED);
    uint8_t c0 = r.identity_counter;
    for (int t = 0; t < 50; t++) {
        rig_tick(&r); /* one answer per request */
    }
    assert_int_equal(r.identity_frames, 1u);

    r.cfg.port = SP_PORT_STM32G474;
    send_command(&r, SP_CMD_ENGAGE);
    rig_tick(&r);
    identify_now(&r, SP_PORT_STM32G474); /* ENGAGING */
    run_until(&r, SP_STATE_READY, 10000u);
    identify_now(&r, SP_PORT_STM32G474);
    send_command(&r, SP_CMD_RUN_TRIG);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_RUNNING);
    identify_now(&r, SP_PORT_STM32G474);
    assert_int_equal(r.identity_counter, (c0 + 3u) & 0x0Fu);

    /* asked just before a CTRL_AUTH tick: answered on the tick after it */
    while ((r.node.out.tick + 1u) % SP_PROTO_AUTH_PERIOD != 0u) {
        rig_tick(&r);
    }
    send_identify(&r, r.op_counter++);
    rig_tick(&r);
    assert_int_equal(r.identity_frames, 4u);
    rig_tick(&r);
    assert_int_equal(r.identity_frames, 5u);

    /* two requests before a tick share one answer; an alive counter out of
     * sequence (another tool) is no reason to refuse */
    send_identify(&r, r.op_counter);
    send_identify(&r, r.op_counter);
    r.op_counter = (uint8_t)(r.op_counter + 7u);
    send_identify(&r, r.op_counter++);
    if ((r.node.out.tick + 1u) % SP_PROTO_AUTH_PERIOD == 0u) {
        rig_tick(&r);
    }
    rig_tick(&r);
    rig_tick(&r);
    assert_int_equal(r.identity_frames, 6u);
    assert_int_equal(r.node.out.state, SP_STATE_RUNNING);

    send_command(&r, SP_CMD_ESTOP);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_STOPPING); /* the controlled stop */
    identify_now(&r, SP_PORT_STM32G474);
    assert_int_equal(r.identity_frames, 7u);
    run_until(&r, SP_STATE_ESTOP, 2000u);
}

static uint8_t frame_counter; /* OP_FRAME's alive counter */

static void send_frame(rig_t *r, uint8_t op, uint8_t kind, uint8_t index, const double v[6], int signed_ok,
                       sp_status_t want)
{
    sp_msg_frame_t m;
    sp_can_frame_t f;
    memset(&m, 0, sizeof m);
    m.op = op;
    m.kind = kind;
    m.index = index;
    for (int k = 0; k < 3; k++) {
        m.value.pos[k] = v ? (sp_q24_t)llround(v[k] * 16777216.0) : 0;
        m.value.rpy[k] = v ? (sp_q24_t)llround(v[3 + k] * 16777216.0) : 0;
    }
    (void)sp_proto_encode_frame(&m, frame_counter++, &f);
    frame_counter &= 0x0Fu;
    if (signed_ok) {
        sign(r, &f);
    }
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), want);
}

static void send_reach(rig_t *r, uint8_t seq, const sp_pose_t *p)
{
    sp_msg_reach_t m;
    sp_can_frame_t f;
    static uint8_t counter;
    m.sequence = seq;
    m.pose = *p;
    (void)sp_proto_encode_reach(&m, counter++, &f);
    counter &= 0x0Fu;
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* OP_FRAME (authenticated, at rest only), CTRL_FRAMES, and OP_REACH
 * answered within 2 ticks, agreeing with MOVE_TO's refusal. */
static void test_frames_and_reach_over_frames(void **state)
{
    static const double tip[6] = {0.15, 0.0, 0.35, 0.0, 0.0, 0.0};
    static const double far[6] = {3.0, 3.0, 3.0, 0.0, 0.0, 0.0};
    static rig_t r;
    (void)state;
    rig_init(&r);
    for (int t = 0; t < 5; t++) {
        rig_tick(&r);
    }
    send_command(&r, SP_CMD_ENGAGE);
    rig_tick(&r);
    run_until(&r, SP_STATE_READY, 10000u);
    send_frame(&r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, tip, 0, SP_E_FRAME); /* unsigned: refused, nothing changes */
    send_frame(&r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, tip, 1, SP_OK);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 0);
    {
        static const double tilted[6] = {0.2, 0.1, 0.0, 0.0, 0.349, 0.0};
        send_frame(&r, SP_FRAME_SET, SP_FRAME_WORK, 2u, tilted, 1, SP_OK);
        rig_tick(&r);
        assert_int_equal(r.node.out.cmd_rejected, 0);
        assert_int_equal(r.node.ctrl.slots.work_active, 2);
        send_frame(&r, SP_FRAME_SELECT, SP_FRAME_WORK, 0u, NULL, 1, SP_OK);
        rig_tick(&r);
        assert_int_equal(r.node.ctrl.slots.work_active, 0);
    }
    send_frame(&r, SP_FRAME_SET, SP_FRAME_TOOL, 2u, far, 1, SP_OK);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 1);
    send_frame(&r, SP_FRAME_SELECT, SP_FRAME_WORK, 3u, NULL, 1, SP_OK);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 1);
    {
        sp_msg_frame_t nan;
        sp_can_frame_t f;
        memset(&nan, 0, sizeof nan);
        nan.op = SP_FRAME_SET;
        nan.value.pos[2] = SP_PROTO_NOT_FINITE_Q24;
        assert_int_equal(sp_proto_encode_frame(&nan, frame_counter++, &f), SP_OK);
        frame_counter &= 0x0Fu;
        sign(&r, &f);
        assert_int_equal(sp_node_receive(&r.node, &f, NULL), SP_OK);
        rig_tick(&r);
        assert_int_equal(r.node.out.cmd_rejected, 1);
    }
    for (int t = 0; t < 100; t++) {
        rig_tick(&r);
    }
    assert_true(r.frames_frames >= 1u);
    assert_int_equal(r.frames.tool_index, 1);
    assert_int_equal(r.frames.work_index, 0);
    assert_int_equal(r.frames.identity, 0);
    assert_int_equal(r.frames.checksum, r.node.ctrl.frames_crc);
    assert_int_equal(r.frames.refused[6], 1u);
    assert_int_equal(r.frames.refused[5], 1u);
    assert_int_equal(r.frames.refused[7], 1u);
    /* reach queries: answered within 2 ticks, the same verdict as a MOVE_TO's */
    for (int q = 0; q < 40; q++) {
        sp_pose_t x = r.node.ctrl.tool_home;
        uint32_t before = r.reach_frames;
        x.pos[q % 3] += (sp_q24_t)((q % 2 ? 1 : -1) * (q * 0.02) * 16777216.0);
        x.rpy[(q + 1) % 3] += (sp_q24_t)(q * 0.01 * 16777216.0);
        send_reach(&r, (uint8_t)q, &x);
        rig_tick(&r);
        if (r.reach_frames == before) {
            rig_tick(&r);
        }
        assert_int_equal(r.reach_frames, before + 1u);
        assert_int_equal(r.reach.sequence, q);
        r.node.target = x;
        send_command(&r, SP_CMD_MOVE_TO);
        rig_tick(&r);
        assert_int_equal(r.node.out.cmd_rejected, r.reach.verdict == SP_REACH_OK ? 0 : 1);
        if (r.node.out.state == SP_STATE_RUNNING) {
            /* a frame change while moving is refused */
            send_frame(&r, SP_FRAME_SELECT, SP_FRAME_TOOL, 0u, NULL, 1, SP_OK);
            rig_tick(&r);
            assert_int_equal(r.node.out.cmd_rejected, 1);
            assert_int_equal(r.node.ctrl.last_refusal, SP_REFUSE_STATE);
            run_until(&r, SP_STATE_READY, 20000u);
            r.node.target = r.node.ctrl.tool_home;
            send_command(&r, SP_CMD_MOVE_TO);
            rig_tick(&r);
            run_until(&r, SP_STATE_READY, 20000u);
        }
    }
    {
        sp_pose_t x = r.node.ctrl.tool_home;
        uint32_t before = r.node.ctrl.refusals[SP_REFUSE_NOT_FINITE];
        x.rpy[1] = SP_PROTO_NOT_FINITE_Q24;
        send_reach(&r, 77u, &x);
        rig_tick(&r);
        rig_tick(&r);
        assert_int_equal(r.reach.sequence, 77);
        assert_int_equal(r.reach.verdict, SP_PROTO_REACH_NOT_FINITE);
        assert_int_equal(r.node.ctrl.refusals[SP_REFUSE_NOT_FINITE], before + 1u);
    }
}

static void test_engage_run_park_over_frames(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    rig_tick(&r);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_IDLE);
    assert_true(r.node.out.estimate_valid);
    send_command(&r, SP_CMD_ENGAGE);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_ENGAGING);
    run_until(&r, SP_STATE_READY, 10000u);
    send_command(&r, SP_CMD_RUN_TRIG);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_RUNNING);
    for (int t = 0; t < 1500; t++) {
        rig_tick(&r);
    }
    /* the estimate (from 1 um feedback) follows the reference */
    assert_near((double)r.node.out.estimate.pos[0] / 16777216.0, (double)r.node.out.reference.pose.pos[0] / 16777216.0,
                5e-3, "estimate x vs reference x (m)");
    /* CTRL_WRENCH every 2nd tick, valid while engaged */
    uint32_t frames0 = r.wrench_frames, valid0 = r.wrench_valid;
    for (int t = 0; t < 100; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.wrench_frames - frames0, 50u);
    assert_int_equal(r.wrench_valid - valid0, 50u);
    send_command(&r, SP_CMD_PARK);
    run_until(&r, SP_STATE_IDLE, 20000u);
    assert_int_equal(r.node.out.faults, 0u);
    for (int k = 0; k < SP_PROTO_ERRORS; k++) {
        assert_int_equal(r.node.stats.rejected[k], 0u);
    }
    /* the status frame says the same as the controller */
    sp_msg_status_t s;
    uint8_t counter;
    sp_proto_error_t e;
    int found = 0;
    for (uint32_t k = 0; k < r.n_sent; k++) {
        if (r.sent[k].id == SP_ID_CTRL_STATUS) {
            assert_int_equal(sp_proto_decode_status(&r.sent[k], &s, &counter, &e), SP_OK);
            assert_int_equal(s.state, SP_STATE_IDLE);
            assert_int_equal(s.tick, r.node.out.tick);
            found = 1;
        }
    }
    assert_true(found);
}

/* Through the wraps: a node started 1500 ticks before its 32-bit tick (and
 * the 16-bit TickEcho) wraps engages, runs and parks exactly as one started
 * at 0: the same setpoints, states and estimates every tick, no fault, the
 * SYNC and status ticks running through 0xFFFFFFFF -> 0 (the alive counters
 * wrap every 16 frames in both). */
static void test_tick_wrap_is_seamless(void **state)
{
    (void)state;
    static rig_t r0, r1;
    const uint32_t start = UINT32_MAX - 5000u; /* wraps while running the surge */
    rig_init(&r0);
    rig_init(&r1);
    r1.node.ctrl.tick = start; /* the test-only initial value */
    int wrapped = 0, ran = 0;
    for (uint32_t t = 0; t < 14000u; t++) {
        if (t == 2u) {
            send_command(&r0, SP_CMD_ENGAGE);
            send_command(&r1, SP_CMD_ENGAGE);
        }
        if (!ran && r0.node.out.state == SP_STATE_READY) {
            send_command(&r0, SP_CMD_RUN_TRIG);
            send_command(&r1, SP_CMD_RUN_TRIG);
            ran = 1;
        }
        if (t == 7000u) {
            send_command(&r0, SP_CMD_PARK);
            send_command(&r1, SP_CMD_PARK);
        }
        rig_tick(&r0);
        rig_tick(&r1);
        assert_int_equal(r1.node.out.tick, (uint32_t)(r0.node.out.tick + start));
        assert_int_equal(r1.node.out.state, r0.node.out.state);
        assert_memory_equal(r1.node.out.setpoint, r0.node.out.setpoint, sizeof r0.node.out.setpoint);
        assert_memory_equal(&r1.node.out.estimate, &r0.node.out.estimate, sizeof r0.node.out.estimate);
        assert_int_equal(r1.node.out.faults, 0u);
        if (r1.node.out.tick == 0u) {
            wrapped = 1;
            assert_int_equal(r1.node.out.state, SP_STATE_RUNNING);
        }
    }
    assert_true(wrapped);
    assert_int_equal(r1.node.out.state, SP_STATE_IDLE);
    assert_int_equal(r1.node.stats.stale, 0u);
    assert_int_equal(r1.node.stats.lost, 0u);
    assert_int_equal(r1.node.stats.accepted, r0.node.stats.accepted);
    print_message("tick wrap: %u frames accepted, state %s at tick %u\n", r1.node.stats.accepted,
                  sp_state_name(r1.node.out.state), r1.node.out.tick);
}

/* The node's statistics saturate at UINT32_MAX, never wrap to 0. */
static void test_stats_saturate(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    r.node.stats.accepted = UINT32_MAX - 2u;
    r.node.stats.rejected[SP_PROTO_BAD_CRC] = UINT32_MAX;
    for (int t = 0; t < 3; t++) {
        rig_tick(&r); /* 6 feedback frames a tick */
    }
    assert_int_equal(r.node.stats.accepted, UINT32_MAX);
    sp_can_frame_t f;
    sp_msg_feedback_t fb = {r.length[0], 3000000u, 1000000u, SP_DRIVE_STATE_ACTIVE, 0u, 0u};
    assert_int_equal(sp_proto_encode_feedback(&fb, 1u, 0u, SP_BUS_AXIS_A, &f), SP_OK);
    f.data[5] ^= 1u; /* a bad CRC */
    assert_int_equal(sp_node_receive(&r.node, &f, NULL), SP_E_FRAME);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_BAD_CRC], UINT32_MAX);
}

static void test_malformed_frames_are_counted_and_dropped(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    rig_tick(&r);
    sp_msg_command_t c;
    memset(&c, 0, sizeof c);
    c.command = SP_CMD_ENGAGE;
    sp_can_frame_t good;
    assert_int_equal(sp_proto_encode_command(&c, 5, &good), SP_OK);
    sign(&r, &good);
    sp_proto_error_t why;

    sp_can_frame_t f = good;
    f.data[2] ^= 0x10u;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_BAD_CRC);
    f = good;
    f.len = 8;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_BAD_LENGTH);
    f = good;
    f.id = 0x7FF;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_UNKNOWN_ID);
    f = good;
    f.bus = SP_BUS_AXIS_A;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_WRONG_BUS);
    f = good;
    f.len = 200;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_BAD_LENGTH);
    /* out of range: command 15 with a valid CRC (10..13 are force control's, 14 IDENTIFY) */
    f = good;
    f.data[0] = 15;
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_OUT_OF_RANGE);
    /* none of that reached the controller */
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_IDLE);
    /* the good frame is taken once; its replay is refused (by its code's
     * counter, before the alive counter is looked at) */
    assert_int_equal(sp_node_receive(&r.node, &good, &why), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &good, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_REPLAYED);
    /* the alive counter repeated on a fresh code */
    f = good;
    sign(&r, &f);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_REPEATED);
    /* a counter jump beyond the allowed gap */
    assert_int_equal(sp_proto_encode_command(&c, 12, &f), SP_OK);
    sign(&r, &f);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_WRONG_SEQUENCE);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_BAD_CRC], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_BAD_LENGTH], 2u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_UNKNOWN_ID], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_WRONG_BUS], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_OUT_OF_RANGE], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_REPEATED], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_AUTH_REPLAYED], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_WRONG_SEQUENCE], 1u);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_ENGAGING); /* the one good command */
    /* an ESTOP is taken whatever its alive counter: here a repeated one */
    c.command = SP_CMD_ESTOP;
    assert_int_equal(sp_proto_encode_command(&c, 12, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_OK);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_REPEATED], 1u);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_ESTOP);
}

static void test_stale_feedback_is_not_used(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    rig_tick(&r);
    rig_tick(&r);
    uint32_t before = r.node.stats.stale;
    sp_msg_feedback_t fb = {r.length[0],           0u, 0u,
                            SP_DRIVE_STATE_ACTIVE, 0u, (uint16_t)((r.node.sync_tick - 5u) & 0xFFFFu)};
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_feedback(&fb, 1, r.fb_counter[0]++, SP_BUS_AXIS_A, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, NULL), SP_OK);
    assert_int_equal(r.node.stats.stale, before + 1u);
}

static void test_silent_drive_faults_within_3_ticks(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    rig_tick(&r);
    send_command(&r, SP_CMD_ENGAGE);
    run_until(&r, SP_STATE_READY, 10000u);
    r.silent[4] = 1;
    int ticks = 0;
    while (r.node.out.state != SP_STATE_FAULT && ticks < 10) {
        rig_tick(&r);
        ticks++;
    }
    assert_int_equal(r.node.out.state, SP_STATE_FAULT);
    assert_true(ticks <= 3);
    assert_true(r.node.out.faults & SP_FAULT_FEEDBACK_TIMEOUT);
}

static void test_drive_pressures_become_forces(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    rig_tick(&r);
    /* 3 MPa on the piston, 1 MPa on the annulus (rig_tick sends these) */
    double a = 3.14159265358979 * 0.1 * 0.1 / 4.0;
    double an = a - 3.14159265358979 * 0.056 * 0.056 / 4.0;
    double expect = 3e6 * a - 1e6 * an;
    rig_tick(&r);
    assert_near((double)r.node.in.drive[2].force / 256.0, expect, 1.0, "drive 2 force (N)");
}

static void test_fuzz_receive_path(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    rig_tick(&r);
    uint64_t seed = 42;
    const uint32_t ids[] = {SP_ID_SYNC,
                            SP_ID_AXIS_SETPOINTS,
                            0x31,
                            0x32,
                            0x33,
                            SP_ID_OP_COMMAND,
                            SP_ID_OP_TARGET_POSE,
                            SP_ID_CTRL_STATUS,
                            SP_ID_CTRL_MONITOR,
                            SP_ID_CTRL_WRENCH};
    uint32_t accepted = 0;
    for (int k = 0; k < 200000; k++) {
        sp_can_frame_t f;
        uint64_t x = tu_next(&seed);
        f.id = (x & 1u) ? ids[(x >> 1) % (sizeof ids / sizeof ids[0])] : (uint32_t)((x >> 8) & 0xFFFFu);
        f.bus = (uint8_t)((x >> 24) % 4u);
        f.len = (uint8_t)((x >> 28) % 70u);
        f.flags = (uint8_t)(x >> 40);
        for (uint32_t i = 0; i < SP_CAN_MAX_DATA; i++) {
            f.data[i] = (uint8_t)(tu_next(&seed) >> 56);
        }
        if (sp_node_receive(&r.node, &f, NULL) == SP_OK) {
            accepted++;
        }
    }
    /* random bytes essentially never pass the CRC (p ~ 1/256 for the 8-bit
     * frames, and then the counter and ranges must fit as well) */
    assert_true(accepted < 200000u / 100u);
    assert_int_equal(sp_node_tick(&r.cfg, &r.node, r.sent, &r.n_sent), SP_OK);
}

static void test_wrench_frame_round_trip_and_saturation(void **state)
{
    (void)state;
    const int32_t lim = SP_PROTO_WRENCH_MAX_Q8; /* 524287.75 N in Q8 */
    sp_msg_wrench_t m = {123456u, 1u, {100 * 256, -(35 * 256 + 128), 32, -32, 31, lim}};
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_wrench(&m, 7u, &f), SP_OK);
    assert_int_equal(f.id, SP_ID_CTRL_WRENCH);
    assert_int_equal(f.len, 24u);
    assert_int_equal(f.bus, SP_BUS_OPS);
    sp_msg_wrench_t d;
    uint8_t counter = 0u;
    sp_proto_error_t e = SP_PROTO_OK;
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_OK);
    assert_int_equal(counter, 7u);
    assert_int_equal(d.tick, 123456u);
    assert_int_equal(d.valid, 1u);
    assert_int_equal(d.wrench[0], 100 * 256);
    assert_int_equal(d.wrench[1], -(35 * 256 + 128));
    assert_int_equal(d.wrench[2], 64); /* 0.125 N: a tie, away from zero */
    assert_int_equal(d.wrench[3], -64);
    assert_int_equal(d.wrench[4], 0);   /* below half a step */
    assert_int_equal(d.wrench[5], lim); /* the largest value is exact */

    /* beyond the signal: saturated (never wrapped), reported as SP_E_RANGE */
    sp_msg_wrench_t big = {1u, 2u, {lim + 32, -lim - 32, INT32_MAX, INT32_MIN, 0, 0}};
    assert_int_equal(sp_proto_encode_wrench(&big, 15u, &f), SP_E_RANGE);
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_OK);
    assert_int_equal(d.valid, 1u); /* any non-zero valid is 1 */
    assert_int_equal(d.wrench[0], lim);
    assert_int_equal(d.wrench[1], -lim);
    assert_int_equal(d.wrench[2], lim);
    assert_int_equal(d.wrench[3], -lim);
    assert_int_equal(d.wrench[4], 0);
    assert_int_equal(sp_proto_encode_wrench(NULL, 0u, &f), SP_E_ARG);
    assert_int_equal(sp_proto_encode_wrench(&m, 0u, NULL), SP_E_ARG);
    assert_int_equal(sp_proto_decode_wrench(&f, NULL, &counter, &e), SP_E_ARG);

    /* rejections as for the other frames, *d untouched */
    sp_can_frame_t good;
    assert_int_equal(sp_proto_encode_wrench(&m, 3u, &good), SP_OK);
    sp_msg_wrench_t keep;
    memset(&keep, 0x5A, sizeof keep);
    d = keep;
    f = good;
    f.data[10] ^= 0x04u;
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_E_FRAME);
    assert_int_equal(e, SP_PROTO_BAD_CRC);
    f = good;
    f.data[23] ^= 0x80u; /* a CRC bit */
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_E_FRAME);
    assert_int_equal(e, SP_PROTO_BAD_CRC);
    f = good;
    f.len = 32u;
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_E_FRAME);
    assert_int_equal(e, SP_PROTO_BAD_LENGTH);
    f = good;
    f.id = SP_ID_CTRL_MONITOR;
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_E_FRAME);
    assert_int_equal(e, SP_PROTO_UNKNOWN_ID);
    f = good; /* Mz raw -2^21 (bits 150..171 = 1 << 21), resealed: out of range */
    for (uint32_t b = 150u; b < 172u; b++) {
        uint8_t bit = (uint8_t)(1u << (b % 8u));
        f.data[b / 8u] = (uint8_t)((b == 171u) ? (f.data[b / 8u] | bit) : (f.data[b / 8u] & (uint8_t)~bit));
    }
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    assert_int_equal(sp_proto_decode_wrench(&f, &d, &counter, &e), SP_E_FRAME);
    assert_int_equal(e, SP_PROTO_OUT_OF_RANGE);
    assert_memory_equal(&d, &keep, sizeof d);
    /* the alive counter: a repeat and a jump are refused by the receiver */
    sp_e2e_rx_t rx;
    memset(&rx, 0, sizeof rx);
    assert_int_equal(sp_proto_decode_wrench(&good, &d, &counter, &e), SP_OK);
    assert_true(sp_e2e_accepted(sp_e2e_rx_check(&rx, counter)));
    assert_int_equal(sp_e2e_rx_check(&rx, counter), SP_E2E_REPEATED);
    assert_int_equal(sp_e2e_rx_check(&rx, (uint8_t)(counter + 8u)), SP_E2E_WRONG_SEQ);
    /* the controller does not consume it (its own frame): unknown to the node */
    static rig_t r;
    rig_init(&r);
    sp_proto_error_t why;
    assert_int_equal(sp_node_receive(&r.node, &good, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_UNKNOWN_ID);
}

static void test_feedback_pressures_at_1_kpa(void **state)
{
    (void)state;
    sp_msg_feedback_t m = {SP_Q24_ONE, 3000499u, 3000500u, SP_DRIVE_STATE_ACTIVE, 0u, 77u};
    sp_can_frame_t f;
    assert_int_equal(sp_proto_encode_feedback(&m, 2u, 1u, SP_BUS_AXIS_B, &f), SP_OK);
    assert_int_equal(f.len, 16u); /* 0.1 um lengths since issue 14's session 10 */
    sp_msg_feedback_t d;
    uint8_t slot = 0u, counter = 0u;
    sp_proto_error_t e;
    assert_int_equal(sp_proto_decode_feedback(&f, &d, &slot, &counter, &e), SP_OK);
    assert_int_equal(d.length, SP_Q24_ONE);   /* 1 m: raw 10,000,000 exactly */
    assert_int_equal(d.pressure_a, 3000000u); /* nearest 1 kPa */
    assert_int_equal(d.pressure_b, 3001000u);
    assert_int_equal(d.state, SP_DRIVE_STATE_ACTIVE);
    assert_int_equal(d.tick_echo, 77u);
    assert_int_equal(slot, 2u);
    /* bytes 0-3: Length raw 10,000,000 (28 bits) with State 2 in the top
     * nibble; bytes 4-5: PressureA raw 3000 little-endian */
    assert_int_equal(f.data[0], 10000000u & 0xFFu);
    assert_int_equal(f.data[3], ((10000000u >> 24) & 0x0Fu) | (SP_DRIVE_STATE_ACTIVE << 4));
    assert_int_equal(f.data[4], 3000u & 0xFFu);
    assert_int_equal(f.data[5], 3000u >> 8);
    /* a length 2 Q24 LSB (0.12 um) longer arrives as the next 0.1 um step:
     * raw 10,000,001, back to 1 m + 1.68 Q24 LSB, rounded to 2 */
    m.length = SP_Q24_ONE + 2;
    assert_int_equal(sp_proto_encode_feedback(&m, 2u, 2u, SP_BUS_AXIS_B, &f), SP_OK);
    assert_int_equal(sp_proto_decode_feedback(&f, &d, &slot, &counter, &e), SP_OK);
    assert_int_equal(d.length, SP_Q24_ONE + 2);
    assert_int_equal(f.data[0], 10000001u & 0xFFu);
    /* full scale 65.535 MPa; above it saturates */
    m.pressure_a = 65535000u;
    m.pressure_b = 70000000u;
    assert_int_equal(sp_proto_encode_feedback(&m, 1u, 2u, SP_BUS_AXIS_A, &f), SP_E_RANGE);
    assert_int_equal(sp_proto_decode_feedback(&f, &d, &slot, &counter, &e), SP_OK);
    assert_int_equal(d.pressure_a, 65535000u);
    assert_int_equal(d.pressure_b, 65535000u);
}

/* Force control over frames: FT_SENSOR (axis_b only) becomes the sensor
 * reading; TARE; FORCE without an OP_FORCE, with a target beyond the
 * limit and with another mask is refused (counted, reported in
 * CTRL_STATUS, nothing moves); OP_FORCE + FORCE enters force control; a
 * lone OP_FORCE updates the target; POSITION releases. */
static void test_force_commands_over_frames(void **state)
{
    (void)state;
    static rig_t r;
    sp_can_frame_t f;
    sp_proto_error_t why;
    rig_init(&r);
    r.cfg.ctrl.wrench_source = SP_WRENCH_SENSOR;
    r.cfg.ctrl.ft_tare_samples = 10u;
    assert_int_equal(sp_node_init(&r.node, &r.cfg), SP_OK);
    uint8_t ft = 0u;
    /* the sensor's frame on the wrong bus is refused */
    sp_msg_ft_t m;
    memset(&m, 0, sizeof m);
    assert_int_equal(sp_proto_encode_ft(&m, 0u, &f), SP_OK);
    f.bus = SP_BUS_AXIS_A;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_WRONG_BUS);
    rig_tick(&r);
    /* admittance parameters in position control: taken (z: 40 kg, approach
     * damping 5e5 N s/m, so 1 kN approaches at 2 mm/s, no spring) */
    send_force_params(&r, 0x04u, 40.0, 500000, 0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 0u);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].mass, 40 * 65536);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].damping, 500000);
    assert_int_equal(r.node.ctrl.force.free_force[2].damping, 500000);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[0].damping, 1000000); /* x: as configured */
    send_command(&r, SP_CMD_ENGAGE);
    for (uint32_t t = 0; t < 10000u && r.node.out.state != SP_STATE_READY; t++) {
        send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
        rig_tick(&r);
    }
    assert_int_equal(r.node.out.state, SP_STATE_READY);
    assert_int_equal(r.node.in.ft_fresh, 0u); /* consumed by the tick */
    /* FORCE before the tare: refused (the sensor's bias is unknown) */
    send_force(&r, 0x04u, 1000.0);
    send_command(&r, SP_CMD_FORCE);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 1u);
    assert_int_equal(r.node.stats.cmd_refused, 1u);
    send_command(&r, SP_CMD_TARE);
    for (uint32_t t = 0; t < 20u; t++) {
        send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
        rig_tick(&r);
    }
    assert_int_equal(r.node.ctrl.ft_tare.tared, 1u);
    assert_int_equal(r.node.ctrl.ft_tare.bias[2], 15 * 256);
    /* a target beyond the controller's 8 kN: refused, still position control */
    send_force(&r, 0x04u, 12000.0);
    send_command(&r, SP_CMD_FORCE);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 1u);
    assert_int_equal(last_status(&r).cmd_rejected, 1u);
    assert_int_equal(r.node.out.force_mode, SP_FORCE_OFF);
    assert_int_equal(r.node.stats.cmd_refused, 2u);
    assert_int_equal(r.node.out.faults, 0u);
    /* a good one: FORCE on z with 1 kN */
    send_force(&r, 0x04u, 1000.0);
    send_command(&r, SP_CMD_FORCE);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 0u);
    assert_int_equal(r.node.out.force_mode, SP_FORCE_FORCE);
    assert_int_equal(r.node.out.force_target[2], 1000 * 256);
    assert_int_equal(last_status(&r).force_mode, SP_FORCE_FORCE);
    /* a lone OP_FORCE with the same mask updates the target, once */
    send_force(&r, 0x04u, 1500.0);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 0u);
    assert_int_equal(r.node.out.force_target[2], 1500 * 256);
    assert_int_equal(r.node.force_fresh, 0u);
    /* another mask: the update is refused, the target stays */
    send_force(&r, 0x01u, 500.0);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 1u);
    assert_int_equal(r.node.out.force_target[2], 1500 * 256);
    assert_int_equal(r.node.stats.cmd_refused, 3u);
    /* POSITION lets go */
    send_command(&r, SP_CMD_POSITION);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.force_mode, SP_FORCE_RELEASE);
    assert_int_equal(r.node.out.faults, 0u);
    assert_true(r.node.stats.ft_samples > 30u);
    /* new parameters while force control runs: refused, the old ones kept */
    send_force_params(&r, 0x04u, 20.0, 2000000, 0);
    send_ft(&r, (uint8_t)(ft++ & 0x0Fu), 15.0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 1u);
    assert_int_equal(r.node.stats.cmd_refused, 4u);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].damping, 500000);
}

/* OP_FORCE_PARAMS: the round trip on its 0.1 kg and 10 N s/m steps; the
 * encoder refuses what the DBC's ranges exclude; a frame carrying such a
 * value is rejected as out-of-range (counted by that name), the
 * parameters unchanged. */
static void test_force_params_frames(void **state)
{
    (void)state;
    static rig_t r;
    rig_init(&r);
    sp_can_frame_t f;
    uint8_t counter;
    sp_proto_error_t why;
    sp_msg_force_params_t m = {0x07u, 2u, (sp_q16_t)(35.5 * 65536.0), 2500, 1000}, back;
    assert_int_equal(sp_proto_encode_force_params(&m, 3u, &f), SP_OK);
    assert_int_equal(f.id, SP_ID_OP_FORCE_PARAMS);
    assert_int_equal(f.len, 24u);
    assert_int_equal(sp_proto_decode_force_params(&f, &back, &counter, &why), SP_OK);
    assert_int_equal(counter, 3u);
    assert_int_equal(back.mask, m.mask);
    assert_int_equal(back.mode, m.mode);
    assert_int_equal(back.mass, m.mass);
    assert_int_equal(back.damping, m.damping);
    assert_int_equal(back.stiffness, m.stiffness);
    sp_msg_force_params_t bad = m;
    bad.mass = SP_Q16_ONE / 2; /* 0.5 kg */
    assert_int_equal(sp_proto_encode_force_params(&bad, 0u, &f), SP_E_ARG);
    bad = m;
    bad.damping = 50;
    assert_int_equal(sp_proto_encode_force_params(&bad, 0u, &f), SP_E_ARG);
    bad = m;
    bad.stiffness = 20000000;
    assert_int_equal(sp_proto_encode_force_params(&bad, 0u, &f), SP_E_ARG);
    bad = m;
    bad.mode = 3u;
    assert_int_equal(sp_proto_encode_force_params(&bad, 0u, &f), SP_E_ARG);
    bad = m;
    bad.mask = 0u;
    assert_int_equal(sp_proto_encode_force_params(&bad, 0u, &f), SP_E_ARG);
    /* on the wire: a damping of 50 N s/m (raw 5, bytes 4..6), sealed again */
    assert_int_equal(sp_proto_encode_force_params(&m, 0u, &f), SP_OK);
    f.data[4] = 5u;
    f.data[5] = 0u;
    f.data[6] = 0u;
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    uint32_t rejected = r.node.stats.rejected[SP_PROTO_OUT_OF_RANGE];
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_OUT_OF_RANGE);
    assert_string_equal(sp_proto_error_name(why), "out-of-range");
    assert_int_equal(r.node.stats.rejected[SP_PROTO_OUT_OF_RANGE], rejected + 1u);
    assert_int_equal(r.node.force_params_fresh, 0u);
    /* on another bus: wrong-bus */
    assert_int_equal(sp_proto_encode_force_params(&m, 1u, &f), SP_OK);
    f.bus = SP_BUS_AXIS_A;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_WRONG_BUS);
}

/* OP_FORCE_PARAMS is authenticated as OP_FORCE (docs/explanation/security.md): without
 * a code, under another key or another session it is a bad tag, a genuine
 * frame sent again is a replay, a keyless node says no-key; each is counted,
 * the admittance keeps its parameters and the genuine operator's next frame
 * (next counter, next alive counter) is taken and reaches the admittance. */
static void test_force_params_auth_over_frames(void **state)
{
    (void)state;
    static rig_t r;
    sp_can_frame_t f;
    sp_proto_error_t why;
    sp_auth_key_t other;
    rig_init(&r);
    for (uint32_t i = 0; i < SP_AUTH_KEY_BYTES; i++) {
        other.k[i] = (uint8_t)(r.key.k[i] ^ (i == 9u ? 0x80u : 0x00u)); /* one bit off */
    }
    rig_tick(&r);
    const int32_t damping0 = r.node.ctrl.prep.force.admit.axis[2].damping;
    sp_msg_force_params_t m = {0x04u, 1u, 40 * 65536, 500000, 0};
    assert_true(damping0 != m.damping);
    /* no code: the encoder's frame as it is */
    assert_int_equal(sp_proto_encode_force_params(&m, r.params_counter, &f), SP_OK);
    assert_int_equal(sp_proto_frame_needs_auth(&f), 1);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    /* another key; the right key and another session */
    assert_int_equal(sp_proto_sign(&f, &other, RIG_SESSION, 1u), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    assert_int_equal(sp_proto_sign(&f, &r.key, RIG_SESSION + 1u, 1u), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    /* a genuine code on a changed payload (the damping's bytes 4..6) */
    assert_int_equal(sp_proto_encode_force_params(&m, r.params_counter, &f), SP_OK);
    sign(&r, &f);
    f.data[4] ^= 0x01u;
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    rig_tick(&r);
    assert_int_equal(r.node.force_params_fresh, 0u);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].damping, damping0);
    assert_int_equal(r.node.auth.last, 0u);
    /* the genuine frame (the alive counter none of the refused ones used up): taken */
    assert_int_equal(sp_proto_encode_force_params(&m, r.params_counter++, &f), SP_OK);
    sign(&r, &f);
    const sp_can_frame_t recorded = f;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_OK);
    assert_int_equal(r.node.auth.last, r.auth_counter);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 0u);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].damping, 500000);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].mass, 40 * 65536);
    /* its replay: refused as such, even with another set's values re-sealed
     * (the code no longer checks then: a bad tag) */
    assert_int_equal(sp_node_receive(&r.node, &recorded, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_REPLAYED);
    f = recorded;
    f.data[4] = 0x10u;
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    rig_tick(&r);
    assert_int_equal(r.node.force_params_fresh, 0u);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].damping, 500000);
    /* 5 bad tags, 1 replay, counted and in CTRL_AUTH */
    assert_int_equal(r.node.stats.rejected[SP_PROTO_AUTH_BAD_TAG], 5u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_AUTH_REPLAYED], 1u);
    for (uint32_t t = 0; t < SP_PROTO_AUTH_PERIOD; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.auth.bad_tag, 5u);
    assert_int_equal(r.auth.replayed, 1u);
    /* the next genuine set is still taken */
    send_force_params(&r, 0x04u, 20.0, 2000000, 0);
    rig_tick(&r);
    assert_int_equal(r.node.out.cmd_rejected, 0u);
    assert_int_equal(r.node.ctrl.prep.force.admit.axis[2].damping, 2000000);

    /* a keyless node: no-key, counted, nothing taken */
    static rig_t n;
    rig_init(&n);
    n.cfg.auth_key = NULL;
    assert_int_equal(sp_node_init(&n.node, &n.cfg), SP_OK);
    rig_tick(&n);
    assert_int_equal(sp_proto_encode_force_params(&m, n.params_counter++, &f), SP_OK);
    sign(&n, &f);
    assert_int_equal(sp_node_receive(&n.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_NO_KEY);
    assert_int_equal(n.node.stats.rejected[SP_PROTO_AUTH_NO_KEY], 1u);
    rig_tick(&n);
    assert_int_equal(n.node.ctrl.prep.force.admit.axis[2].damping, damping0);
}

/* Command authentication over frames (docs/explanation/security.md): a stranger's
 * ENGAGE, MOVE_TO target, STREAM and OP_FORCE (another key, no code, a
 * replay of a genuine frame) are rejected and counted by reason, change
 * nothing the genuine operator sends next, and are reported in CTRL_AUTH;
 * the stranger's STOP, PARK and ESTOP are taken; a node without a key
 * refuses every authenticated command (no-key) and still stops. */
static void test_auth_over_frames(void **state)
{
    (void)state;
    static rig_t r;
    sp_can_frame_t f;
    sp_proto_error_t why;
    sp_auth_key_t other;
    rig_init(&r);
    for (uint32_t i = 0; i < SP_AUTH_KEY_BYTES; i++) {
        other.k[i] = (uint8_t)(r.key.k[i] ^ (i == 5u ? 0x01u : 0x00u)); /* one bit off */
    }
    rig_tick(&r);
    sp_msg_command_t c;
    memset(&c, 0, sizeof c);
    c.command = SP_CMD_ENGAGE;
    /* no code at all */
    assert_int_equal(sp_proto_encode_command(&c, r.op_counter++, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    /* another key, a counter well ahead */
    assert_int_equal(sp_proto_sign(&f, &other, RIG_SESSION, 1000u), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    /* the right key, another session (a frame recorded before a restart) */
    assert_int_equal(sp_proto_sign(&f, &r.key, RIG_SESSION + 1u, 1u), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    /* a target pose and a force target without the key */
    sp_pose_t p = sp_platform_default.home;
    assert_int_equal(sp_proto_encode_target(&p, 0u, &f), SP_OK);
    assert_int_equal(sp_proto_sign(&f, &other, RIG_SESSION, 1u), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    sp_msg_force_t fm;
    memset(&fm, 0, sizeof fm);
    fm.mask = 4u;
    assert_int_equal(sp_proto_encode_force(&fm, 0u, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    assert_int_equal(r.node.force.mask, 0u);
    for (uint32_t t = 0; t < 10u; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.node.out.state, SP_STATE_IDLE);
    assert_int_equal(r.node.auth.last, 0u);
    /* the genuine operator's ENGAGE (counter 1): taken */
    c.command = SP_CMD_ENGAGE;
    assert_int_equal(sp_proto_encode_command(&c, r.op_counter++, &f), SP_OK);
    sign(&r, &f);
    sp_can_frame_t recorded = f;
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_OK);
    run_until(&r, SP_STATE_READY, 10000u);
    /* its replay: rejected; the same frame re-signed by the stranger with
     * another key for the next counters: rejected */
    assert_int_equal(sp_node_receive(&r.node, &recorded, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_REPLAYED);
    for (uint32_t k = 2u; k < 12u; k++) {
        f = recorded;
        assert_int_equal(sp_proto_sign(&f, &other, RIG_SESSION, k), SP_OK);
        assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
        assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    }
    /* the stranger's STREAM and RUN_TRIG without a code: refused, READY stays */
    c.command = SP_CMD_STREAM;
    assert_int_equal(sp_proto_encode_command(&c, r.op_counter++, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_BAD_TAG);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_READY);
    /* counts: no-tag 1 + other key 1 + other session 1 + pose 1 + force 1
     * + re-signed 10 + stream 1 = 16 bad tags, 1 replay; in CTRL_AUTH */
    assert_int_equal(r.node.stats.rejected[SP_PROTO_AUTH_BAD_TAG], 16u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_AUTH_REPLAYED], 1u);
    for (uint32_t t = 0; t < SP_PROTO_AUTH_PERIOD; t++) {
        rig_tick(&r);
    }
    assert_int_equal(r.auth.session, RIG_SESSION);
    assert_int_equal(r.auth.last_counter, 1u);
    assert_int_equal(r.auth.bad_tag, 16u);
    assert_int_equal(r.auth.replayed, 1u);
    assert_int_equal(r.auth.key_set, 1u);
    /* the genuine operator's next counter is still good: RUN_TRIG runs */
    send_command(&r, SP_CMD_RUN_TRIG);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_RUNNING);
    /* the stranger's STOP (no code, any alive counter): taken */
    c.command = SP_CMD_STOP;
    assert_int_equal(sp_proto_encode_command(&c, 9u, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_OK);
    run_until(&r, SP_STATE_READY, 10000u);
    /* and its ESTOP with a forged code */
    c.command = SP_CMD_ESTOP;
    assert_int_equal(sp_proto_encode_command(&c, 3u, &f), SP_OK);
    assert_int_equal(sp_proto_sign(&f, &other, 7u, 7u), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_OK);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_ESTOP);

    /* no key: every authenticated command refused (no-key), STOP/PARK/ESTOP taken */
    static rig_t n;
    rig_init(&n);
    n.cfg.auth_key = NULL;
    assert_int_equal(sp_node_init(&n.node, &n.cfg), SP_OK);
    rig_tick(&n);
    c.command = SP_CMD_ENGAGE;
    assert_int_equal(sp_proto_encode_command(&c, n.op_counter++, &f), SP_OK);
    sign(&n, &f);
    assert_int_equal(sp_node_receive(&n.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_AUTH_NO_KEY);
    c.command = SP_CMD_PARK; /* another node's: its alive counter out of sequence */
    assert_int_equal(sp_proto_encode_command(&c, (uint8_t)(n.op_counter + 9u), &f), SP_OK);
    assert_int_equal(sp_node_receive(&n.node, &f, &why), SP_OK);
    c.command = SP_CMD_ESTOP;
    assert_int_equal(sp_proto_encode_command(&c, n.op_counter++, &f), SP_OK);
    assert_int_equal(sp_node_receive(&n.node, &f, &why), SP_OK);
    for (uint32_t t = 0; t < SP_PROTO_AUTH_PERIOD; t++) {
        rig_tick(&n);
    }
    assert_int_equal(n.node.out.state, SP_STATE_ESTOP);
    assert_int_equal(n.node.stats.rejected[SP_PROTO_AUTH_NO_KEY], 1u);
    assert_int_equal(n.auth.key_set, 0u);
    assert_string_equal(sp_proto_error_name(SP_PROTO_AUTH_NO_KEY), "no-key");
    assert_string_equal(sp_proto_error_name(SP_PROTO_AUTH_BAD_TAG), "bad-tag");
    assert_string_equal(sp_proto_error_name(SP_PROTO_AUTH_REPLAYED), "replayed");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frames_and_reach_over_frames),
        cmocka_unit_test(test_engage_run_park_over_frames),
        cmocka_unit_test(test_identify_over_frames),
        cmocka_unit_test(test_refusal_frames),
        cmocka_unit_test(test_tick_wrap_is_seamless),
        cmocka_unit_test(test_stats_saturate),
        cmocka_unit_test(test_malformed_frames_are_counted_and_dropped),
        cmocka_unit_test(test_stale_feedback_is_not_used),
        cmocka_unit_test(test_silent_drive_faults_within_3_ticks),
        cmocka_unit_test(test_drive_pressures_become_forces),
        cmocka_unit_test(test_fuzz_receive_path),
        cmocka_unit_test(test_wrench_frame_round_trip_and_saturation),
        cmocka_unit_test(test_feedback_pressures_at_1_kpa),
        cmocka_unit_test(test_force_params_frames),
        cmocka_unit_test(test_operator_heartbeat_over_frames),
        cmocka_unit_test(test_force_commands_over_frames),
        cmocka_unit_test(test_engage_refused_while_drives_start),
        cmocka_unit_test(test_status_counts_refusals_modulo_8),
        cmocka_unit_test(test_status_names_legs_without_force),
        cmocka_unit_test(test_auth_over_frames),
        cmocka_unit_test(test_force_params_auth_over_frames),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
