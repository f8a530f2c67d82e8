/*
 * The controller as a CAN node (sp/node.h) with the protocol layer
 * (sp/protocol.h): a drive-side rig in the test answers every SYNC with
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
#include "sp/node.h"
#include "test_util.h"

typedef struct {
    sp_node_config_t cfg;
    sp_node_t node;
    sp_q24_t length[SP_LEGS];
    uint8_t fb_counter[SP_LEGS];
    uint8_t op_counter;
    int silent[SP_LEGS];
    sp_can_frame_t sent[SP_NODE_MAX_TX];
    uint32_t n_sent;
} rig_t;

static void rig_init(rig_t *r)
{
    memset(r, 0, sizeof *r);
    assert_int_equal(sp_node_default_config(&r->cfg, &sp_platform_default), SP_OK);
    assert_int_equal(sp_node_init(&r->node, &r->cfg), SP_OK);
    sp_ik_t ik;
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik), SP_OK);
    memcpy(r->length, ik.length, sizeof r->length);
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
    assert_int_equal(sp_node_receive(&r->node, &f, NULL), SP_OK);
}

/* The drives: apply the setpoints that were sent, answer the SYNC. */
static void rig_tick(rig_t *r)
{
    assert_int_equal(sp_node_tick(&r->cfg, &r->node, r->sent, &r->n_sent), SP_OK);
    assert_int_equal(r->n_sent, 6u); /* setpoints x2, SYNC x2, status, monitor */
    uint32_t sync_tick = 0;
    int syncs = 0;
    for (uint32_t k = 0; k < r->n_sent; k++) {
        const sp_can_frame_t *f = &r->sent[k];
        uint8_t counter;
        sp_proto_error_t e;
        if (f->id == SP_ID_AXIS_SETPOINTS) {
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

static void run_until(rig_t *r, sp_state_t state, uint32_t max_ticks)
{
    for (uint32_t t = 0; t < max_ticks && r->node.out.state != state; t++) {
        rig_tick(r);
    }
    assert_int_equal(r->node.out.state, state);
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
    /* out of range: command 12 with a valid CRC */
    f = good;
    f.data[0] = 12;
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_OUT_OF_RANGE);
    /* none of that reached the controller */
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_IDLE);
    /* the good frame is taken once; its replay is refused */
    assert_int_equal(sp_node_receive(&r.node, &good, &why), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &good, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_REPEATED);
    /* a counter jump beyond the allowed gap */
    assert_int_equal(sp_proto_encode_command(&c, 12, &f), SP_OK);
    assert_int_equal(sp_node_receive(&r.node, &f, &why), SP_E_FRAME);
    assert_int_equal(why, SP_PROTO_WRONG_SEQUENCE);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_BAD_CRC], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_BAD_LENGTH], 2u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_UNKNOWN_ID], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_WRONG_BUS], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_OUT_OF_RANGE], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_REPEATED], 1u);
    assert_int_equal(r.node.stats.rejected[SP_PROTO_WRONG_SEQUENCE], 1u);
    rig_tick(&r);
    assert_int_equal(r.node.out.state, SP_STATE_ENGAGING); /* the one good command */
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
    const uint32_t ids[] = {
        SP_ID_SYNC,        SP_ID_AXIS_SETPOINTS, 0x31, 0x32, 0x33, SP_ID_OP_COMMAND, SP_ID_OP_TARGET_POSE,
        SP_ID_CTRL_STATUS, SP_ID_CTRL_MONITOR};
    uint32_t accepted = 0;
    for (int k = 0; k < 200000; k++) {
        sp_can_frame_t f;
        uint64_t x = tu_next(&seed);
        f.id = (x & 1u) ? ids[(x >> 1) % 9u] : (uint32_t)((x >> 8) & 0xFFFFu);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_engage_run_park_over_frames),
        cmocka_unit_test(test_malformed_frames_are_counted_and_dropped),
        cmocka_unit_test(test_stale_feedback_is_not_used),
        cmocka_unit_test(test_silent_drive_faults_within_3_ticks),
        cmocka_unit_test(test_drive_pressures_become_forces),
        cmocka_unit_test(test_fuzz_receive_path),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
