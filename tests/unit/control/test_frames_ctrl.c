/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The controller with tool and work frames (sp/model/frames.h): rotations
 * about the pivot keep the tool point still, streamed tool targets, the
 * FRAME command's refusals, and the reach query against MOVE_TO's own
 * refusal on 10,000 random tool poses (one shared check).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "sp/control/controller.h"

static double f24(int32_t v)
{
    return (double)v / 16777216.0;
}
static int32_t q24(double v)
{
    return (int32_t)llround(v * 16777216.0);
}

typedef struct {
    sp_ctrl_config_t cfg;
    sp_ctrl_t ctrl;
    sp_ctrl_input_t in;
    sp_ctrl_output_t out;
    sp_q24_t plant_length[SP_LEGS];
} rig_t;

static void rig_init(rig_t *r)
{
    sp_ik_t ik;
    memset(r, 0, sizeof *r);
    assert_int_equal(sp_ctrl_default_config(&r->cfg, &sp_platform_default), SP_OK);
    assert_int_equal(sp_ctrl_init(&r->ctrl, &r->cfg), SP_OK);
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik), SP_OK);
    memcpy(r->plant_length, ik.length, sizeof r->plant_length);
}

static void rig_step(rig_t *r)
{
    for (int i = 0; i < SP_LEGS; ++i) {
        r->in.drive[i].fresh = 1u;
        r->in.drive[i].length = r->plant_length[i];
        r->in.drive[i].force = 0;
    }
    assert_int_equal(sp_ctrl_step(&r->cfg, &r->ctrl, &r->in, &r->out), SP_OK);
    r->in.cmd.type = SP_CMD_NONE;
    r->in.stream_fresh = 0u;
    if (r->out.drive_mode == SP_DRIVE_ACTIVE) {
        for (int i = 0; i < SP_LEGS; ++i) {
            r->plant_length[i] = r->out.setpoint[i].length;
        }
    }
}

static void rig_tick(rig_t *r, sp_cmd_type_t cmd)
{
    r->in.cmd.type = cmd;
    rig_step(r);
}

static void run_until(rig_t *r, sp_state_t state, int max_ticks)
{
    for (int n = 0; n < max_ticks && r->out.state != state; ++n) {
        rig_tick(r, SP_CMD_NONE);
    }
    assert_int_equal(r->out.state, state);
}

static void engage(rig_t *r)
{
    rig_tick(r, SP_CMD_NONE);
    rig_tick(r, SP_CMD_ENGAGE);
    run_until(r, SP_STATE_READY, 20000);
}

static void frame_cmd(rig_t *r, uint8_t op, uint8_t kind, uint8_t index, const double v[6])
{
    r->in.cmd.type = SP_CMD_FRAME;
    r->in.cmd.frame_op = op;
    r->in.cmd.frame_kind = kind;
    r->in.cmd.frame_index = index;
    for (int k = 0; k < 3; ++k) {
        r->in.cmd.frame_value.pos[k] = v ? q24(v[k]) : 0;
        r->in.cmd.frame_value.rpy[k] = v ? q24(v[3 + k]) : 0;
    }
    rig_step(r);
}

/* The tool point of a platform pose, base frame, m. */
static void tip_of(const sp_pose_t *p, const double t[3], double tip[3])
{
    sp_rot_t rot;
    assert_int_equal(sp_orientation(p->rpy, &rot), SP_OK);
    for (int c = 0; c < 3; ++c) {
        tip[c] = f24(p->pos[c]);
        for (int k = 0; k < 3; ++k) {
            tip[c] += (double)rot.t[k][c] / 1073741824.0 * t[k];
        }
    }
}

/* The paper's motion about a tool tip 0.35 m above o' and 0.15 m off its
 * axis: +-0.08 rad at 0.5 Hz in roll, pitch and yaw. The tip of every
 * reference stays within 1 um of where it started (about o' the same
 * rotation moves it by about +-28 mm). */
static void test_rotation_about_the_pivot(void **state)
{
    static const double tool[6] = {0.15, 0.0, 0.35, 0.0, 0.0, 0.0};
    static const double t[3] = {0.15, 0.0, 0.35};
    rig_t *r = malloc(sizeof *r);
    (void)state;
    assert_non_null(r);
    rig_init(r);
    engage(r);
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, tool);
    assert_int_equal(r->out.cmd_rejected, 0);
    assert_int_equal(r->ctrl.slots.tool_active, 1);
    for (sp_axis_t axis = SP_AXIS_ROLL; axis <= SP_AXIS_YAW; ++axis) {
        double tip0[3], tip[3], worst = 0.0;
        tip_of(&r->out.reference.pose, t, tip0);
        r->in.cmd.axis = axis;
        r->in.cmd.amplitude = SP_Q24_MILLI(80);
        r->in.cmd.frequency = SP_Q24_ONE / 2;
        r->in.cmd.fade_ticks = 500u;
        rig_tick(r, SP_CMD_RUN_TRIG);
        assert_int_equal(r->out.cmd_rejected, 0);
        for (int n = 0; n < 2500; ++n) {
            rig_tick(r, SP_CMD_NONE);
            assert_int_equal(r->out.faults, 0);
            tip_of(&r->out.reference.pose, t, tip);
            for (int c = 0; c < 3; ++c) {
                worst = fmax(worst, fabs(tip[c] - tip0[c]));
            }
        }
        rig_tick(r, SP_CMD_STOP);
        run_until(r, SP_STATE_READY, 5000);
        printf("pivot axis %d: tip within %.3f um\n", (int)axis, worst * 1e6);
        assert_true(worst < 1e-6);
    }
    free(r);
}

/* Streamed tool targets: the platform settles at the pose that puts the
 * tool at the target (sp_frames_to_platform's). */
static void test_stream_in_tool_frame(void **state)
{
    static const double tool[6] = {0.0, 0.1, 0.3, 0.0, 0.0, 0.1};
    static const double work[6] = {0.5, -0.2, 0.1, 0.0, 0.2, 0.0};
    rig_t *r = malloc(sizeof *r);
    sp_pose_t target, want;
    (void)state;
    assert_non_null(r);
    rig_init(r);
    engage(r);
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_TOOL, 2u, tool);
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_WORK, 1u, work);
    assert_int_equal(r->out.cmd_rejected, 0);
    target = r->ctrl.tool_home;
    target.pos[0] += SP_Q24_MILLI(40);
    target.rpy[2] += SP_Q24_MILLI(30);
    assert_int_equal(sp_frames_to_platform(&r->ctrl.frames, &target, &want, NULL), SP_OK);
    rig_tick(r, SP_CMD_STREAM);
    assert_int_equal(r->out.cmd_rejected, 0);
    for (int n = 0; n < 3000; ++n) {
        r->in.stream_fresh = 1u;
        r->in.stream_target = target;
        rig_tick(r, SP_CMD_NONE);
        assert_int_equal(r->out.cmd_rejected, 0);
    }
    for (int k = 0; k < 3; ++k) {
        assert_true(abs(r->out.reference.pose.pos[k] - want.pos[k]) <= 2);
        assert_true(abs(r->out.reference.pose.rpy[k] - want.rpy[k]) <= 2);
    }
    rig_tick(r, SP_CMD_STOP);
    run_until(r, SP_STATE_READY, 10000);
    free(r);
}

/* Bad frames: each refused with its reason counted, nothing moves. */
static void test_frame_refusals(void **state)
{
    static const double far[6] = {3.0, 3.0, 3.0, 0.0, 0.0, 0.0}; /* 5.2 m */
    static const double tool[6] = {0.0, 0.0, 0.3, 0.0, 0.0, 0.0};
    rig_t *r = malloc(sizeof *r);
    sp_pose_t before;
    (void)state;
    assert_non_null(r);
    rig_init(r);
    engage(r);
    before = r->out.reference.pose;
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, far);
    assert_int_equal(r->out.cmd_rejected, 1);
    assert_int_equal(r->ctrl.refusals[SP_REFUSE_BAD_FRAME], 1);
    assert_int_equal(r->out.refuse_reason, SP_REFUSE_BAD_FRAME); /* one list: CTRL_REFUSAL says the same */
    frame_cmd(r, SP_FRAME_SELECT, SP_FRAME_WORK, 3u, NULL);
    assert_int_equal(r->out.cmd_rejected, 1);
    assert_int_equal(r->ctrl.refusals[SP_REFUSE_EMPTY_SLOT], 1);
    assert_int_equal(r->out.refuse_reason, SP_REFUSE_EMPTY_SLOT);
    frame_cmd(r, SP_FRAME_SELECT, SP_FRAME_TOOL, 9u, NULL);
    assert_int_equal(r->ctrl.refusals[SP_REFUSE_EMPTY_SLOT], 2);
    assert_int_equal(r->ctrl.frames.identity, 1);
    assert_memory_equal(&before, &r->out.reference.pose, sizeof before);
    /* while moving */
    r->in.cmd.axis = SP_AXIS_Z;
    r->in.cmd.amplitude = SP_Q24_MILLI(20);
    r->in.cmd.frequency = SP_Q24_ONE;
    rig_tick(r, SP_CMD_RUN_TRIG);
    assert_int_equal(r->out.state, SP_STATE_RUNNING);
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, tool);
    assert_int_equal(r->out.cmd_rejected, 1);
    assert_int_equal(r->ctrl.refusals[SP_REFUSE_STATE], 1);
    assert_int_equal(r->ctrl.frames.identity, 1);
    assert_int_equal(r->ctrl.last_refusal, SP_REFUSE_STATE);
    assert_int_equal(r->out.refuse_reason, SP_REFUSE_STATE);
    rig_tick(r, SP_CMD_STOP);
    run_until(r, SP_STATE_READY, 10000);
    /* at rest it is taken, and a select of slot 0 returns to identity */
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, tool);
    assert_int_equal(r->out.cmd_rejected, 0);
    assert_int_equal(r->ctrl.frames.identity, 0);
    assert_int_not_equal(r->ctrl.frames_crc, 0u);
    frame_cmd(r, SP_FRAME_SELECT, SP_FRAME_TOOL, 0u, NULL);
    assert_int_equal(r->out.cmd_rejected, 0);
    assert_int_equal(r->ctrl.frames.identity, 1);
    free(r);
}

/* The reach query's verdict against MOVE_TO's own acceptance of the same
 * tool pose from READY, on 10,000 random poses (about half of them
 * unreachable), with a tool and a work frame that turn: never a pose judged
 * reachable and refused, never one judged unreachable and accepted. */
static void test_reach_agrees_with_refusal(void **state)
{
    static const double tool[6] = {0.12, -0.05, 0.35, 0.05, -0.1, 0.2};
    static const double work[6] = {0.2, 0.1, 0.0, 0.0, 0.349, 0.0};
    rig_t *r = malloc(sizeof *r);
    rig_t *snap = malloc(sizeof *snap);
    unsigned reachable = 0u, legs = 0u, box = 0u;
    (void)state;
    assert_non_null(r);
    assert_non_null(snap);
    rig_init(r);
    engage(r);
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_TOOL, 1u, tool);
    frame_cmd(r, SP_FRAME_SET, SP_FRAME_WORK, 1u, work);
    assert_int_equal(r->out.cmd_rejected, 0);
    *snap = *r;
    srand(31);
    for (int n = 0; n < 10000; ++n) {
        sp_reach_t reach;
        sp_pose_t x = snap->ctrl.tool_home;
        for (int k = 0; k < 3; ++k) {
            x.pos[k] += q24(((double)rand() / RAND_MAX - 0.5) * 1.0);
            x.rpy[k] += q24(((double)rand() / RAND_MAX - 0.5) * 0.7);
        }
        *r = *snap;
        assert_int_equal(sp_ctrl_reach(&r->cfg, &r->ctrl, &x, &reach), SP_OK);
        r->in.cmd.target = x;
        rig_tick(r, SP_CMD_MOVE_TO);
        assert_int_equal(r->out.cmd_rejected, reach.verdict == SP_REACH_OK ? 0 : 1);
        if (reach.verdict == SP_REACH_OK) {
            ++reachable;
            assert_int_equal(r->out.state, SP_STATE_RUNNING);
            for (int i = 0; i < SP_LEGS; ++i) {
                assert_true(reach.force[i] != 0); /* the legs carry the platform */
            }
        } else {
            assert_int_equal(r->ctrl.refusals[SP_REFUSE_REACH], 1);
            assert_true(reach.excess > 0 || reach.verdict == SP_REACH_COMPUTE);
            legs += (reach.verdict == SP_REACH_LEG_SHORT || reach.verdict == SP_REACH_LEG_LONG) ? 1u : 0u;
            box += (reach.verdict == SP_REACH_WORKSPACE) ? 1u : 0u;
        }
    }
    printf("reach: %u of 10000 reachable, %u beyond the workspace, %u beyond a stroke\n", reachable, box, legs);
    assert_true(reachable > 1000u && reachable < 9000u);
    assert_true(box > 100u);
    free(snap);
    free(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frame_refusals),
        cmocka_unit_test(test_rotation_about_the_pivot),
        cmocka_unit_test(test_stream_in_tool_frame),
        cmocka_unit_test(test_reach_agrees_with_refusal),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
