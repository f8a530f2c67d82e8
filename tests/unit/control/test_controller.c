/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of the controller step (sp/control/controller.h) and the reference
 * generators (sp/motion/trajectory.h) on the default platform, closed around an
 * ideal plant in the test: each drive reaches its length setpoint by the
 * next tick (or, where a test says so, does not). The plant simulator and
 * the CAN bus are exercised by the integration tests; here the logic is.
 */
#include <math.h>

#define TEST_PI 3.14159265358979323846
#include <stdlib.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "assert_near.h"
#include "sp/control/controller.h"
#include "test_util.h"

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
    int silent[SP_LEGS];
    int frozen; /* 1: the plant ignores the setpoints */
} rig_t;

static void rig_init(rig_t *r)
{
    sp_ik_t ik;
    memset(r, 0, sizeof *r);
    assert_int_equal(sp_ctrl_default_config(&r->cfg, &sp_platform_default), SP_OK);
    assert_int_equal(sp_ctrl_init(&r->ctrl, &r->cfg), SP_OK);
    /* the plant starts parked */
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik), SP_OK);
    memcpy(r->plant_length, ik.length, sizeof r->plant_length);
}

/* One tick: feedback from the plant, the controller step, the plant moves. */
static void rig_tick(rig_t *r, sp_cmd_type_t cmd)
{
    for (int i = 0; i < SP_LEGS; ++i) {
        r->in.drive[i].fresh = (uint8_t)(r->silent[i] ? 0u : 1u);
        r->in.drive[i].length = r->plant_length[i];
        r->in.drive[i].force = 0;
    }
    r->in.cmd.type = cmd;
    assert_int_equal(sp_ctrl_step(&r->cfg, &r->ctrl, &r->in, &r->out), SP_OK);
    r->in.cmd.type = SP_CMD_NONE;
    r->in.stream_fresh = 0u;
    if (!r->frozen && r->out.drive_mode == SP_DRIVE_ACTIVE) {
        for (int i = 0; i < SP_LEGS; ++i) {
            r->plant_length[i] = r->out.setpoint[i].length;
        }
    }
}

static void run_until(rig_t *r, sp_state_t state, int max_ticks)
{
    for (int n = 0; n < max_ticks; ++n) {
        if (r->out.state == state) {
            return;
        }
        rig_tick(r, SP_CMD_NONE);
    }
    fail_msg("state %s not reached in %d ticks (now %s, faults 0x%x)", sp_state_name(state), max_ticks,
             sp_state_name(r->out.state), r->out.faults);
}

static void engage(rig_t *r)
{
    rig_tick(r, SP_CMD_NONE);
    assert_int_equal(r->out.state, SP_STATE_IDLE);
    assert_true(r->out.estimate_valid);
    rig_tick(r, SP_CMD_ENGAGE);
    assert_int_equal(r->out.cmd_rejected, 0);
    assert_int_equal(r->out.state, SP_STATE_ENGAGING);
    run_until(r, SP_STATE_READY, 20000);
}

/* A platform resting just below its park pose, which lies on the
 * workspace's floor (a payload the config does not know makes the legs
 * sag by tens of um): ENGAGE starts from the floor, 40 um above where it
 * stands, and reaches READY; 1 mm below, farther than SP_CTRL_ENGAGE_TOL
 * (0.5 mm), the move's first reference leaves the limits as before. */
static void test_engage_from_just_outside_the_workspace(void **state)
{
    static rig_t r;
    sp_ik_t ik;
    sp_pose_t sag = sp_platform_default.park;
    const sp_q24_t floor_z = sp_platform_default.home.pos[2] + sp_platform_default.workspace_min.pos[2];
    (void)state;
    assert_int_equal(sp_platform_default.park.pos[2], floor_z); /* the premise: park on the floor */
    rig_init(&r);
    sag.pos[2] -= q24(40e-6);
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sag, &ik), SP_OK);
    memcpy(r.plant_length, ik.length, sizeof r.plant_length);
    rig_tick(&r, SP_CMD_NONE);
    assert_true(r.out.estimate_valid);
    assert_true(r.out.estimate.pos[2] < floor_z - q24(35e-6));
    rig_tick(&r, SP_CMD_ENGAGE);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.faults, 0);
    assert_int_equal(r.out.state, SP_STATE_ENGAGING);
    assert_int_equal(r.out.reference.pose.pos[2], floor_z); /* the start: the floor */
    assert_near(f24(r.out.reference.pose.pos[0]), f24(r.out.estimate.pos[0]), 1e-9, "x kept");
    run_until(&r, SP_STATE_READY, 20000);
    /* 1 mm below: not within the tolerance */
    rig_init(&r);
    sag = sp_platform_default.park;
    sag.pos[2] -= q24(1e-3);
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sag, &ik), SP_OK);
    memcpy(r.plant_length, ik.length, sizeof r.plant_length);
    rig_tick(&r, SP_CMD_NONE);
    rig_tick(&r, SP_CMD_ENGAGE);
    run_until(&r, SP_STATE_FAULT, 10);
    assert_int_equal(r.out.faults, SP_FAULT_REFERENCE);
}

static void test_engage_run_park(void **state)
{
    static rig_t r;
    double peak = 0;
    double prev_acc = 0;
    double worst_jerk = 0;
    double worst_err = 0;
    int ticks = 0;
    (void)state;
    rig_init(&r);
    engage(&r);
    /* the estimate is home */
    for (int k = 0; k < 3; ++k) {
        assert_near(f24(r.out.estimate.pos[k]), f24(sp_platform_default.home.pos[k]), 1e-6, "estimate pos[%d]", k);
        assert_near(f24(r.out.estimate.rpy[k]), f24(sp_platform_default.home.rpy[k]), 5e-6, "estimate rpy[%d]", k);
    }
    /* the paper's surge: 90 mm, 0.5 Hz */
    r.in.cmd.axis = SP_AXIS_X;
    r.in.cmd.amplitude = q24(0.09);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    for (; ticks < 8000; ++ticks) {
        double x = f24(r.out.reference.pose.pos[0]);
        double acc = f24(r.out.reference.acc[0]);
        peak = fabs(x) > peak ? fabs(x) : peak;
        if (ticks > 0) {
            double jerk = fabs(acc - prev_acc) / 1e-3;
            worst_jerk = jerk > worst_jerk ? jerk : worst_jerk;
        }
        prev_acc = acc;
        /* the ideal plant is one tick behind the reference */
        {
            double e = fabs(f24(r.out.estimate.pos[0]) - x);
            worst_err = e > worst_err ? e : worst_err;
        }
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.faults, 0u);
    }
    assert_near(peak, 0.09, 1e-4, "peak of the surge (m)");
    /* smooth: the jerk of 0.09 sin(pi t) is 0.09 pi^3 = 2.8 m/s^3; the fades add a little */
    assert_true(worst_jerk < 6.0);
    assert_true(worst_err < 0.09 * 3.14159265358979 * 1e-3 * 1.05);
    rig_tick(&r, SP_CMD_STOP);
    run_until(&r, SP_STATE_READY, 3000);
    assert_near(f24(r.out.reference.pose.pos[0]), f24(sp_platform_default.home.pos[0]), 1e-6, "reference x after STOP");
    rig_tick(&r, SP_CMD_PARK);
    assert_int_equal(r.out.state, SP_STATE_PARKING);
    run_until(&r, SP_STATE_IDLE, 20000);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
    for (int k = 0; k < 3; ++k) {
        assert_near(f24(r.out.estimate.pos[k]), f24(sp_platform_default.park.pos[k]), 1e-6, "parked pos[%d]", k);
    }
    print_message("surge: peak %.6f m, worst jerk %.3f m/s^3, worst lag %.3g m\n", peak, worst_jerk, worst_err);
}

/* The controller reuses the last setpoints, model and factorisation when a
 * tick's reference equals the last accepted one (READY at rest, and the
 * RUN_TRIG tick). The plain reference: sp_setpoints_of on that reference,
 * computed afresh, must give the same setpoints, model and factorisation,
 * bit for bit, on every READY tick, on the RUN_TRIG tick, and after the
 * feed-forward switches change (which must not reuse). While moving, the
 * leg-mass terms of all legs but one group are kept from earlier ticks
 * (sp/control/controller.h, "The leg masses' terms"), and the forces' factorisation
 * is made every SP_CTRL_LU_KEEP ticks, the ticks between refining from
 * the last forces: lengths, rates and Jacobian are still the same bit for
 * bit, the factorisation too on the ticks that make it, the forces within
 * force_tol N (0: exact). Returns the largest force difference, N. */
static double check_fresh_setpoints(const rig_t *r, unsigned ff, double force_tol)
{
    double worst = 0.0;
    sp_setpoint_t sp[SP_LEGS];
    sp_lu6_t lu;
    sp_model_t model;
    memset(&lu, 0, sizeof lu);
    memset(&model, 0, sizeof model);
    assert_int_equal(sp_setpoints_of(&sp_platform_default, &r->ctrl.prep.limits, &r->ctrl.prep.friction,
                                     &r->ctrl.reference, ff, sp, &lu, &model),
                     SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(sp[i].length, r->out.setpoint[i].length);
        assert_int_equal(sp[i].velocity, r->out.setpoint[i].velocity);
        worst = fmax(worst, fabs((sp[i].force - r->out.setpoint[i].force) / 256.0));
        worst = fmax(worst, fabs((model.force[i] - r->ctrl.model.force[i]) / 256.0));
        assert_int_equal(model.ref.length[i], r->ctrl.model.ref.length[i]);
        assert_int_equal(model.ref.sc[i], r->ctrl.model.ref.sc[i]);
        if (r->ctrl.legs.lu_age == 0u) {
            /* factorised this tick: sp_setpoints_of's bit for bit (otherwise
             * an older reference's, the forces refined: within force_tol) */
            for (int k = 0; k < SP_LEGS; ++k) {
                assert_int_equal(lu.a[i][k], r->ctrl.est.ref_lu.a[i][k]);
            }
            assert_int_equal(lu.inv[i], r->ctrl.est.ref_lu.inv[i]);
            assert_int_equal(lu.perm[i], r->ctrl.est.ref_lu.perm[i]);
            assert_int_equal(lu.zk[i], r->ctrl.est.ref_lu.zk[i]);
        }
    }
    /* up to SP_CTRL_LU_KEEP - 1 ticks old, or SP_CTRL_LU_KEEP on the tick
     * that stages the next factorisation */
    assert_true(r->ctrl.legs.lu_age < (SP_CTRL_LEG_GROUPS > 1u ? SP_CTRL_LU_KEEP + r->ctrl.legs.lu_next.begun : 1u));
    assert_memory_equal(&model.jac, &r->ctrl.model.jac, sizeof model.jac);
    assert_int_equal(r->ctrl.est.ref_lu.valid, 1);
    assert_true(worst <= force_tol);
    return worst;
}

static void test_rest_reuses_setpoints(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    engage(&r);
    for (int n = 0; n < (int)SP_CTRL_LU_KEEP + 4; ++n) {
        /* READY's first ticks complete the legs' terms (the engage move's
         * last ones, at most 1 N off): SP_CTRL_LEG_GROUPS ticks that
         * refresh, the two of a staged factorisation among them at most
         * (SP_CTRL_LU_KEEP in all), then one that factorises (refreshing
         * no leg); bit for bit from there on */
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.state, SP_STATE_READY);
        check_fresh_setpoints(&r, SP_FF_DYNAMICS | SP_FF_FRICTION, (n < (int)SP_CTRL_LU_KEEP) ? 1.0 : 0.0);
    }
    r.cfg.friction_compensation = 0u;
    rig_tick(&r, SP_CMD_NONE);
    check_fresh_setpoints(&r, SP_FF_DYNAMICS, 0.0);
    r.cfg.force_feedforward = 0u;
    rig_tick(&r, SP_CMD_NONE);
    check_fresh_setpoints(&r, 0u, 0.0);
    r.cfg.force_feedforward = 1u;
    r.cfg.friction_compensation = 1u;
    r.in.cmd.axis = SP_AXIS_X;
    r.in.cmd.amplitude = q24(0.05);
    r.in.cmd.frequency = q24(0.5);
    r.in.cmd.fade_ticks = 0u;
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    check_fresh_setpoints(&r, SP_FF_DYNAMICS | SP_FF_FRICTION, 0.0);
    {
        /* moving, no fade: kept leg terms, within 1 N (measured below) */
        double worst = 0.0;
        for (int n = 0; n < 1000; ++n) {
            rig_tick(&r, SP_CMD_NONE);
            worst = fmax(worst, check_fresh_setpoints(&r, SP_FF_DYNAMICS | SP_FF_FRICTION, 1.0));
        }
        print_message("moving: forces within %.3f N of a fresh sp_setpoints_of\n", worst);
        /* kept terms differ; with one group nothing is kept: exact */
        assert_true((SP_CTRL_LEG_GROUPS > 1u) ? (worst > 0.0) : (worst == 0.0));
    }
}

static void test_silent_drive_faults_within_3_ticks(void **state)
{
    static rig_t r;
    sp_setpoint_t held[SP_LEGS];
    int n;
    (void)state;
    rig_init(&r);
    engage(&r);
    r.in.cmd.axis = SP_AXIS_YAW;
    r.in.cmd.amplitude = q24(0.09);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    for (n = 0; n < 2500; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    r.silent[3] = 1;
    for (n = 1; n <= 3; ++n) {
        rig_tick(&r, SP_CMD_NONE);
        if (r.out.state == SP_STATE_FAULT) {
            break;
        }
    }
    assert_true(n <= 3);
    print_message("silent drive: fault after %d tick(s)\n", n);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    assert_true((r.out.faults & SP_FAULT_FEEDBACK_TIMEOUT) != 0u);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
    memcpy(held, r.out.setpoint, sizeof held);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(held[i].velocity, 0);
    }
    /* latched: the fault stays even when the drive talks again, and the
     * setpoints stay frozen */
    r.silent[3] = 0;
    for (n = 0; n < 100; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    assert_memory_equal(held, r.out.setpoint, sizeof held);
    /* reset: re-engages to home from where the platform is */
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.faults, 0u);
    run_until(&r, SP_STATE_READY, 20000);
}

static void test_reset_refused_while_silent(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    engage(&r);
    r.silent[0] = 1;
    for (int n = 0; n < 5; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
}

/* RESET with a drive reporting faults: the fault-reset edge on one tick,
 * then the wait for the drive; cleared -> ENGAGING, a cause that stays ->
 * refused after drive_reset_ticks with the leg and its bits reported. */
static void test_reset_clears_drive_faults(void **state)
{
    static rig_t r;
    int n;
    (void)state;
    rig_init(&r);
    engage(&r);
    r.in.drive[4].faults = 0x10u | SP_DRIVE_FAULT_STATE; /* valve fault, drive in FAULT */
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    assert_true((r.out.faults & SP_FAULT_DRIVE) != 0u);
    assert_int_equal(r.out.drive_fault_reset, 0);
    /* the cause stays: refused after exactly drive_reset_ticks, the leg and its bits reported */
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.drive_fault_reset, 1);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    for (n = 1; n < (int)r.cfg.drive_reset_ticks; ++n) {
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.drive_fault_reset, 0);
        assert_int_equal(r.out.reset_refused_legs, 0);
    }
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    assert_int_equal(r.out.reset_refused_legs, 1u << 4);
    assert_int_equal(r.out.reset_refused_cause, 0x10u); /* the DBC's bits only */
    for (n = 0; n < 50; ++n) {                          /* reported until the next RESET */
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.reset_refused_legs, 1u << 4);
    /* the next RESET: the drive clears 3 ticks after the edge -> re-engage */
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.drive_fault_reset, 1);
    assert_int_equal(r.out.reset_refused_legs, 0);
    rig_tick(&r, SP_CMD_NONE);
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    r.in.drive[4].faults = 0u;
    rig_tick(&r, SP_CMD_NONE);
    /* re-engaged from home to home: the move may end in this very tick */
    assert_true(r.out.state == SP_STATE_ENGAGING || r.out.state == SP_STATE_READY);
    assert_int_equal(r.out.faults, 0u);
    run_until(&r, SP_STATE_READY, 20000);
    /* an ESTOP cancels a reset under way */
    r.in.drive[0].faults = 0x02u;
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    rig_tick(&r, SP_CMD_RESET);
    rig_tick(&r, SP_CMD_ESTOP);
    r.in.drive[0].faults = 0u;
    for (n = 0; n < 30; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    /* without drive faults RESET clears at once, as before */
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.drive_fault_reset, 0);
    assert_int_equal(r.out.faults, 0u);
    assert_true(r.out.state == SP_STATE_ENGAGING || r.out.state == SP_STATE_READY);
}

static void test_rejects_out_of_limit_commands(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    /* ENGAGE before any feedback: refused */
    r.silent[0] = 1;
    rig_tick(&r, SP_CMD_ENGAGE);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_IDLE);
    r.silent[0] = 0;
    engage(&r);
    /* 0.8 m of surge leaves the workspace: refused, nothing moves */
    r.in.cmd.axis = SP_AXIS_X;
    r.in.cmd.amplitude = q24(0.8);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_READY);
    /* a frequency of 0 Hz: refused */
    r.in.cmd.amplitude = q24(0.05);
    r.in.cmd.frequency = 0;
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.cmd_rejected, 1);
    /* a move target outside the workspace: refused */
    r.in.cmd.target = sp_platform_default.home;
    r.in.cmd.target.pos[2] += q24(2.0);
    rig_tick(&r, SP_CMD_MOVE_TO);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_READY);
    /* RUN while not READY: refused */
    rig_tick(&r, SP_CMD_PARK);
    r.in.cmd.amplitude = q24(0.05);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_PARKING);
}

static void test_move_and_stream(void **state)
{
    static rig_t r;
    sp_pose_t target;
    (void)state;
    rig_init(&r);
    engage(&r);
    target = sp_platform_default.home;
    target.pos[1] += q24(0.1);
    target.rpy[2] += q24(0.05);
    r.in.cmd.target = target;
    rig_tick(&r, SP_CMD_MOVE_TO);
    assert_int_equal(r.out.cmd_rejected, 0);
    run_until(&r, SP_STATE_READY, 20000);
    assert_memory_equal(&r.out.reference.pose, &target, sizeof target);
    /* RUN_TRIG runs about home from home at rest: READY 0.1 m away it
     * would be a step of the setpoints, so it is refused and nothing moves */
    r.in.cmd.axis = SP_AXIS_X;
    r.in.cmd.amplitude = q24(0.05);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_READY);
    assert_memory_equal(&r.out.reference.pose, &target, sizeof target);
    /* the move kept within its limits */
    /* stream: a reachable target is followed, an unreachable one refused */
    rig_tick(&r, SP_CMD_STREAM);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    r.in.stream_target = sp_platform_default.home;
    r.in.stream_target.pos[0] += q24(0.05);
    r.in.stream_fresh = 1u;
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (int n = 0; n < 3000; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_near(f24(r.out.reference.pose.pos[0]) - f24(sp_platform_default.home.pos[0]), 0.05, 1e-5,
                "reference x after the streamed target (from home)");
    r.in.stream_target.pos[0] += q24(3.0);
    r.in.stream_fresh = 1u;
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.cmd_rejected, 1);
    rig_tick(&r, SP_CMD_STOP);
    run_until(&r, SP_STATE_READY, 10000);
    assert_int_equal(r.out.faults, 0u);

    /* STOP while targets are still streamed, the first one in the same
     * tick: they are refused and the platform settles home (a target
     * taken after STOP used to replace home, and RUNNING never ended) */
    rig_tick(&r, SP_CMD_STREAM);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    r.in.stream_target = sp_platform_default.home;
    r.in.stream_target.pos[0] += q24(0.04);
    r.in.stream_fresh = 1u;
    rig_tick(&r, SP_CMD_NONE);
    for (int n = 0; n < 1000; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    r.in.stream_target.pos[1] += q24(0.04);
    r.in.stream_fresh = 1u;
    rig_tick(&r, SP_CMD_STOP);
    assert_int_equal(r.out.cmd_rejected, 1);
    for (int n = 0; n < 100; ++n) {
        r.in.stream_fresh = 1u;
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.cmd_rejected, 1);
    }
    run_until(&r, SP_STATE_READY, 10000);
    assert_int_equal(r.out.faults, 0u);
    for (int k = 0; k < 3; ++k) {
        assert_true(abs(r.out.reference.pose.pos[k] - sp_platform_default.home.pos[k]) <= 16); /* 1 um */
        assert_true(abs(r.out.reference.pose.rpy[k] - sp_platform_default.home.rpy[k]) <= 16);
    }
}

/* Is the pose reachable by the controller's rule: inside the workspace box
 * around home and every leg (its IK) inside the stroke less the margin?
 * The reference for the streamed targets below. */
static int expect_reachable(const sp_ctrl_config_t *cfg, const sp_pose_t *t)
{
    const sp_platform_t *p = cfg->platform;
    sp_ik_t ik;
    for (int k = 0; k < 3; ++k) {
        int64_t dp = (int64_t)t->pos[k] - p->home.pos[k];
        int64_t dr = (int64_t)t->rpy[k] - p->home.rpy[k];
        if (dp < p->workspace_min.pos[k] || dp > p->workspace_max.pos[k] || dr < p->workspace_min.rpy[k] ||
            dr > p->workspace_max.rpy[k]) {
            return 0;
        }
    }
    if (sp_inverse_kinematics(p, t, &ik) != SP_OK) {
        return 0;
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        if (ik.length[i] < p->leg_length_min + cfg->stroke_margin ||
            ik.length[i] > p->leg_length_max - cfg->stroke_margin) {
            return 0;
        }
    }
    return 1;
}

/* Streamed targets are accepted exactly when they are reachable, whether
 * the controller decides by its bound around the last reference (targets
 * near it) or by the target's IK: 4000 random targets around the moving
 * reference, at 1 um to 0.5 m (0.5 urad to 0.25 rad) from it, many of them
 * beyond the strokes or the workspace. */
static void test_stream_target_reachability(void **state)
{
    static rig_t r;
    static const double scale[4] = {1e-6, 1e-3, 0.05, 0.5};
    uint64_t rng = 12345u;
    int accepted = 0;
    int refused = 0;
    (void)state;
    rig_init(&r);
    engage(&r);
    rig_tick(&r, SP_CMD_STREAM);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    for (int n = 0; n < 4000 && r.out.state == SP_STATE_RUNNING; ++n) {
        sp_pose_t t = r.out.reference.pose;
        double sc = scale[n & 3];
        for (int k = 0; k < 3; ++k) {
            rng = rng * 6364136223846793005u + 1442695040888963407u;
            t.pos[k] += q24(sc * ((double)(rng >> 11) / 9007199254740992.0 * 2.0 - 1.0));
            rng = rng * 6364136223846793005u + 1442695040888963407u;
            t.rpy[k] += q24(0.5 * sc * ((double)(rng >> 11) / 9007199254740992.0 * 2.0 - 1.0));
        }
        r.in.stream_target = t;
        r.in.stream_fresh = 1u;
        rig_tick(&r, SP_CMD_NONE);
        if (expect_reachable(&r.cfg, &t)) {
            assert_int_equal(r.out.cmd_rejected, 0);
            ++accepted;
        } else {
            assert_int_equal(r.out.cmd_rejected, 1);
            ++refused;
        }
    }
    print_message("stream targets: %d accepted, %d refused, state %s\n", accepted, refused, sp_state_name(r.out.state));
    assert_true(accepted > 1000 && refused > 200);
}

/* The controller's estimate (chord FK with the last reference's
 * factorisation, from the cached lengths of the last estimate) against the
 * full Newton FK of the same lengths from the same guess, every tick of a
 * move in all six axes, with the ideal plant and with a lagging plant (it
 * covers a fifth of the way to each setpoint: the estimate trails the
 * factorisation's pose by up to a few mm). Both stop within the same
 * length tolerance (0.24 um), so they agree within a micrometre and a
 * microradian; the chord needs at most 3 steps. */
static void test_estimate_matches_full_fk(void **state)
{
    static rig_t r;
    (void)state;
    for (int lag = 0; lag < 2; ++lag) {
        sp_pose_t target;
        sp_fk_options_t opt;
        double worst_pos = 0;
        double worst_rot = 0;
        uint32_t worst_it = 0;
        int ticks = 0;
        rig_init(&r);
        engage(&r);
        sp_fk_default_options(&opt);
        target = sp_platform_default.home;
        target.pos[0] += q24(-0.08);
        target.pos[1] += q24(0.1);
        target.pos[2] += q24(0.05);
        target.rpy[0] += q24(0.1);
        target.rpy[1] += q24(-0.08);
        target.rpy[2] += q24(0.12);
        r.in.cmd.target = target;
        rig_tick(&r, SP_CMD_MOVE_TO);
        assert_int_equal(r.out.cmd_rejected, 0);
        r.frozen = lag;
        for (; ticks < 20000 && r.out.state == SP_STATE_RUNNING; ++ticks) {
            sp_pose_t guess = r.out.estimate;
            sp_pose_t full;
            sp_q24_t fed[SP_LEGS];
            memcpy(fed, r.plant_length, sizeof fed);
            rig_tick(&r, SP_CMD_NONE);
            if (lag) {
                for (int i = 0; i < SP_LEGS; ++i) {
                    r.plant_length[i] += (r.out.setpoint[i].length - r.plant_length[i]) / 5;
                }
            }
            assert_int_equal(r.out.faults, 0u);
            assert_true(r.out.estimate_valid);
            assert_int_equal(sp_forward_kinematics(&sp_platform_default, fed, &guess, &opt, &full, NULL, NULL), SP_OK);
            for (int k = 0; k < 3; ++k) {
                double ep = fabs(f24(r.out.estimate.pos[k]) - f24(full.pos[k]));
                double er = fabs(f24(r.out.estimate.rpy[k]) - f24(full.rpy[k]));
                worst_pos = ep > worst_pos ? ep : worst_pos;
                worst_rot = er > worst_rot ? er : worst_rot;
            }
            worst_it = r.out.fk_iterations > worst_it ? r.out.fk_iterations : worst_it;
        }
        assert_int_equal(r.out.state, SP_STATE_READY);
        assert_true(ticks > 1000);
        assert_true(worst_pos < 1e-6);
        assert_true(worst_rot < 1e-6);
        assert_true(worst_it <= 3u);
        print_message("estimate vs full FK (%s plant, %d ticks): %.3g m, %.3g rad, at most %u steps\n",
                      lag ? "lagging" : "ideal", ticks, worst_pos, worst_rot, (unsigned)worst_it);
    }
}

static void test_estop_and_divergence(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    engage(&r);
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
    assert_true((r.out.faults & SP_FAULT_ESTOP) != 0u);
    rig_tick(&r, SP_CMD_ENGAGE);
    assert_int_equal(r.out.cmd_rejected, 1);
    rig_tick(&r, SP_CMD_RESET);
    run_until(&r, SP_STATE_READY, 20000);

    /* a plant that stops following: the divergence fault latches */
    r.in.cmd.axis = SP_AXIS_Z;
    r.in.cmd.amplitude = q24(0.09);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    r.frozen = 1;
    run_until(&r, SP_STATE_FAULT, 3000);
    assert_true((r.out.faults & SP_FAULT_DIVERGENCE) != 0u);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
}

/* Load holding: the blocking valves closed (drive_block) from the ESTOP
 * tick and SP_CTRL_FAULT_BLOCK_TICKS into a FAULT that holds, through a
 * RESET still waiting for the drives, open again only on the re-engage;
 * open in IDLE and while moving. */
static void test_estop_closes_blocking_valves(void **state)
{
    static rig_t r;
    int n;
    (void)state;
    rig_init(&r);
    r.cfg.estop.category = 0u; /* the immediate stop (category 0) */
    assert_int_equal(sp_ctrl_init(&r.ctrl, &r.cfg), SP_OK);
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_IDLE);
    assert_int_equal(r.out.drive_block, 0);
    engage(&r);
    assert_int_equal(r.out.drive_block, 0);
    r.in.cmd.axis = SP_AXIS_X;
    r.in.cmd.amplitude = q24(0.05);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    for (n = 0; n < 500; ++n) {
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.drive_block, 0);
    }
    /* ESTOP: closed in that very tick, and latched */
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
    assert_int_equal(r.out.drive_block, 1);
    rig_tick(&r, SP_CMD_ENGAGE); /* refused: no way round RESET */
    assert_int_equal(r.out.cmd_rejected, 1);
    for (n = 0; n < 100; ++n) {
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.drive_block, 1);
    }
    /* a drive faulted meanwhile: RESET waits for it with the valves closed */
    r.in.drive[2].faults = 0x20u | SP_DRIVE_FAULT_STATE;
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.drive_fault_reset, 1);
    assert_int_equal(r.out.drive_block, 1);
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_block, 1);
    r.in.drive[2].faults = 0u;
    rig_tick(&r, SP_CMD_NONE);
    assert_true(r.out.state == SP_STATE_ENGAGING || r.out.state == SP_STATE_READY);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_ACTIVE);
    assert_int_equal(r.out.drive_block, 0);
    run_until(&r, SP_STATE_READY, 20000);
    assert_int_equal(r.out.drive_block, 0);
    /* a fault whose reaction is to hold (a silent drive): closed too, once
     * the position loops have held for SP_CTRL_FAULT_BLOCK_TICKS */
    r.silent[1] = 1;
    for (n = 0; n < 5 && r.out.state != SP_STATE_FAULT; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    r.silent[1] = 0;
    for (n = 0; r.out.drive_block == 0u && n < 1000; ++n) {
        assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(n, (int)SP_CTRL_FAULT_BLOCK_TICKS);
    for (n = 0; n < 10; ++n) {
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.drive_block, 1);
    }
    /* ESTOP in a holding fault: closed at once */
    rig_tick(&r, SP_CMD_RESET);
    run_until(&r, SP_STATE_READY, 20000);
    r.silent[1] = 1;
    for (n = 0; n < 5 && r.out.state != SP_STATE_FAULT; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    r.silent[1] = 0;
    assert_int_equal(r.out.drive_block, 0);
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_block, 1);
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.drive_block, 0);
    run_until(&r, SP_STATE_READY, 20000);
    /* parked again (PARK -> IDLE): a platform that has not failed, valves open */
    rig_tick(&r, SP_CMD_PARK);
    run_until(&r, SP_STATE_IDLE, 20000);
    assert_int_equal(r.out.drive_block, 0);
}

static void test_fk_failure_faults(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    engage(&r);
    /* one leg reads 0.3 m longer than possible with the others: no pose */
    r.frozen = 1;
    r.plant_length[2] += q24(0.3);
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.state, SP_STATE_FAULT);
    assert_true((r.out.faults & (SP_FAULT_FK | SP_FAULT_DIVERGENCE)) != 0u);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
}

/* The fade's rate kept in the generator (made once per motion and tick
 * length) against one made afresh every tick: the same motion and status,
 * through a fade-in and a fade-out with the tick length changing. */
static void test_trig_fade_rate_kept(void **state)
{
    sp_trig_t g;
    (void)state;
    assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_Z, q24(0.05), q24(1.0), 1000u, 400u), SP_OK);
    for (int n = 0; n < 1200; ++n) {
        static const uint32_t tick_us[3] = {1000u, 1000u, 250u};
        sp_trig_t fresh = g;
        sp_motion_t m, mf;
        fresh.fade_tick_us = 0u; /* nothing kept: made this tick */
        if (n == 600) {
            sp_trig_stop(&g);
            sp_trig_stop(&fresh);
        }
        assert_int_equal(sp_trig_step(&g, tick_us[n % 3], &m), sp_trig_step(&fresh, tick_us[n % 3], &mf));
        assert_memory_equal(&m, &mf, sizeof m);
        assert_int_equal(g.fade_rate, fresh.fade_rate);
    }
    assert_int_equal(g.finished, 1);
}

/* x f (Q24 x Q30 -> Q24) as the generator's acceleration makes it: the
 * 32-bit product where x fits int32, else x's high part (x / 2^16, floor)
 * times f plus its low part's product in Q30 + 14 (floor), rounded. */
static int64_t plain_mul_q30(int64_t x, int32_t f, sp_flags_t *flags)
{
    if (x >= INT32_MIN && x <= INT32_MAX) {
        return sp_mul((int32_t)x, f, 30u, flags);
    }
    int64_t high = (int64_t)floor((double)x / 65536.0);
    int64_t low = x - high * 65536;
    return sp_rshift_round(high * f + (int64_t)floor((double)(low * f) / 65536.0), 14u);
}

/* The peak-acceleration bound sp_trig_start refuses at (m/s^2 or rad/s^2),
 * in double: |A| (w^2 + 4 w r + 6 r^2), r the fade's rate. */
static double plain_trig_peak(sp_q24_t amp, sp_q24_t hz, uint32_t tick_us, uint32_t fade)
{
    double w = 2.0 * TEST_PI * f24(hz);
    double r = 1e6 / ((double)fade * tick_us);
    return fabs(f24(amp)) * (w * w + 4.0 * w * r + 6.0 * r * r);
}

/* The trig generator's motion at full amplitude as first written: every
 * product by the envelope e = 1 (Q30) and its derivatives 0, through the
 * public fixed-point functions (round to nearest, ties away; saturating). */
/* A trig sample from its envelope e (Q30), e' (Q24) and e'' (Q24, int64)
 * at the generator's phase, through the public fixed-point functions
 * (round to nearest, ties away; saturating): offset A s e, velocity
 * A (w c e + s e'), acceleration A (-w^2 s e + 2 w c e' + s e''). */
static sp_status_t plain_trig_sample(const sp_trig_t *g, int32_t e, int32_t de, int64_t dde_rr, sp_flags_t flags,
                                     sp_motion_t *out)
{
    sp_q30_t s, c;
    int32_t theta = (int32_t)sp_rshift_round((int64_t)(int32_t)g->phase * INT64_C(105414357), 32u);
    sp_sincos_q24(theta, &s, &c);
    int32_t wc = sp_mul(g->omega, c, 30u, &flags);
    int64_t pos = sp_rshift_round((int64_t)sp_mul(s, e, 30u, &flags), 6u);
    int64_t vel = (int64_t)sp_mul(wc, e, 30u, &flags) + sp_mul(de, s, 30u, &flags);
    int64_t w2 = sp_rshift_round((int64_t)g->omega * g->omega, 24u);
    int64_t acc = -plain_mul_q30(plain_mul_q30(w2, s, &flags), e, &flags) + 2 * sp_rshift_round((int64_t)wc * de, 24u) +
                  plain_mul_q30(dde_rr, s, &flags);
    unsigned a = (unsigned)g->axis;
    sp_motion_at_rest(out, &g->centre);
    sp_q24_t *p = (a < 3u) ? &out->pose.pos[a] : &out->pose.rpy[a - 3u];
    *p = sp_add(*p, sp_mul(g->amplitude, sp_sat32(pos, &flags), 24u, &flags), &flags);
    *((a < 3u) ? &out->vel[a] : &out->rpy_rate[a - 3u]) = sp_mul(g->amplitude, sp_sat32(vel, &flags), 24u, &flags);
    *((a < 3u) ? &out->acc[a] : &out->rpy_acc[a - 3u]) =
        sp_sat32(sp_rshift_round((int64_t)g->amplitude * acc, 24u), &flags);
    return sp_flags_status(flags);
}

static sp_status_t plain_trig_full(const sp_trig_t *g, sp_motion_t *out)
{
    return plain_trig_sample(g, INT32_C(1) << 30, 0, 0, 0u, out);
}

/* sp_trig_step at full amplitude (its short path: no products by the
 * envelope) against plain_trig_full, bit for bit with the status, on
 * every axis, frequencies up to 10 Hz (omega^2 beyond Q24's int32 above
 * 1.8 Hz) and amplitudes up to +-1 (down to 1 um at the highest
 * frequencies, so that both paths are accepted): an accepted motion
 * never saturates; sp_trig_start refuses exactly those above the bound. */
static void test_trig_full_amplitude(void **state)
{
    uint64_t rng = 71;
    int accepted = 0, refused = 0, narrow = 0;
    (void)state;
    for (int n = 0; n < 120; ++n) {
        sp_trig_t g;
        double scale = (n % 2 == 0) ? 1.0 : 0.001;
        sp_q24_t amp = (sp_q24_t)tu_uniform(&rng, -16777216.0 * scale, 16777216.0 * scale);
        sp_q24_t hz = (sp_q24_t)tu_uniform(&rng, 0.01 * 16777216.0, 10.0 * 16777216.0);
        uint32_t fade = (n % 3 == 0) ? 100u : 1000u; /* 0.1 s: every motion wide; 1 s: narrow below ~1.5 Hz */
        sp_status_t st0 = sp_trig_start(&g, &sp_platform_default.home, (sp_axis_t)(n % 6), amp, hz, 1000u, fade);
        double peak = plain_trig_peak(amp, hz, 1000u, fade);
        if (fabs(peak - 64.0) > 1e-3) { /* away from the bound's rounding */
            assert_int_equal(st0, (peak >= 64.0) ? SP_E_RANGE : SP_OK);
        }
        if (st0 != SP_OK) {
            assert_int_equal(g.finished, 1);
            ++refused;
            continue;
        }
        ++accepted;
        narrow += !g.wide;
        for (int t = 0; t < (int)fade + 300; ++t) {
            sp_motion_t m, want;
            sp_status_t st_want = plain_trig_full(&g, &want);
            sp_status_t st = sp_trig_step(&g, 1000u, &m);
            assert_int_equal(st, SP_OK);
            if (t > (int)fade) { /* past the fade-in: full amplitude */
                assert_int_equal(st_want, SP_OK);
                assert_memory_equal(&m, &want, sizeof m);
            }
        }
    }
    assert_true(accepted > 40 && refused > 20 && narrow > 5 && narrow < accepted);
}

/* Above 1.8 Hz (omega^2 beyond Q24's int32) the generator's motion against
 * the analytic sine: a 2, 5 and 10 Hz motion of 1 mm (a shaker test) runs
 * its fade-in and a second at full amplitude without a flag, position
 * within 0.1 um (Q24's step is 0.06 um), velocity within 1 um/s and acceleration within 0.1 % of the
 * peak of A w^2 sin, A w cos and -A w^2 sin. */
static void test_trig_high_frequency(void **state)
{
    static const double hzs[3] = {2.0, 5.0, 10.0};
    (void)state;
    for (int i = 0; i < 3; ++i) {
        sp_trig_t g;
        sp_motion_t m;
        double amp = 0.001;
        double w = 2.0 * TEST_PI * hzs[i];
        assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_Z, q24(amp), q24(hzs[i]), 1000u, 500u),
                         SP_OK);
        for (int t = 0; t < 1500; ++t) {
            double phase = 2.0 * TEST_PI * (double)g.phase / 4294967296.0;
            assert_int_equal(sp_trig_step(&g, 1000u, &m), SP_OK);
            if (t >= 500) {
                assert_near(f24(m.pose.pos[2] - sp_platform_default.home.pos[2]), amp * sin(phase), 1e-7,
                            "position (m)");
                assert_near(f24(m.vel[2]), amp * w * cos(phase), 1e-6, "velocity (m/s)");
                assert_near(f24(m.acc[2]), -amp * w * w * sin(phase), 1e-3 * amp * w * w, "acceleration (m/s^2)");
            }
        }
    }
    /* the paper's 90 mm at 10 Hz: 355 m/s^2, refused */
    sp_trig_t g;
    assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_X, q24(0.09), q24(10.0), 1000u, 1000u),
                     SP_E_RANGE);
}

/* The trig generator's first sample as its general path makes it: the
 * envelope at u = 0 (smoothstep's E, E', E'' through the public
 * fixed-point functions) at the fade rate 1 / (fade_ticks tick_us), the
 * phase 0, every product of the motion by them. */
static sp_status_t plain_trig_first(const sp_trig_t *g, uint32_t tick_us, sp_motion_t *out)
{
    sp_flags_t flags = 0u;
    const int64_t one = INT64_C(1) << 30;
    const int64_t u = 0;
    int64_t u2 = sp_rshift_round(u * u, 30u);
    int64_t u3 = sp_rshift_round(u2 * u, 30u);
    int64_t v2 = sp_rshift_round((one - u) * (one - u), 30u);
    int32_t e = (int32_t)sp_rshift_round(u3 * (10 * one - 15 * u + 6 * u2), 30u);
    int32_t de = (int32_t)sp_rshift_round(30 * sp_rshift_round(u2 * v2, 30u), 6u);
    int32_t dde =
        (int32_t)sp_rshift_round(60 * sp_rshift_round(sp_rshift_round(u * (one - u), 30u) * (one - 2 * u), 30u), 6u);
    uint64_t dt_us = (uint64_t)g->fade_ticks * tick_us;
    int32_t rate = sp_sat32((int64_t)(((UINT64_C(1) << 24) * UINT64_C(1000000)) / dt_us), &flags);
    de = sp_mul(de, rate, 24u, &flags);
    int64_t dde_rr = sp_rshift_round((int64_t)sp_mul(dde, rate, 24u, &flags) * rate, 24u);
    return plain_trig_sample(g, e, de, dde_rr, flags, out);
}

/* sp_trig_step's first sample (its short path: the centre at rest)
 * against plain_trig_first, bit for bit with the status, on every axis,
 * frequencies up to 10 Hz (omega^2 beyond Q24's int32 above 1.8 Hz),
 * amplitudes up to +-1 (down to 1 um, half of them), fades of 0.1 s to
 * 60 s, ticks of 250 us and 1 ms; the generator's phase and tick advanced
 * once, its fade rate made. Motions sp_trig_start refuses are skipped. */
static void test_trig_first_sample(void **state)
{
    uint64_t rng = 73;
    int accepted = 0;
    (void)state;
    for (int n = 0; n < 300; ++n) {
        sp_trig_t g;
        sp_motion_t m, want;
        double scale = (n % 2 == 0) ? 1.0 : 0.001;
        sp_q24_t amp = (sp_q24_t)tu_uniform(&rng, -16777216.0 * scale, 16777216.0 * scale);
        sp_q24_t hz = (sp_q24_t)tu_uniform(&rng, 0.01 * 16777216.0, 10.0 * 16777216.0);
        uint32_t tick_us = (n % 3 == 0) ? 250u : 1000u;
        uint32_t fade = (uint32_t)tu_uniform(&rng, 100000.0 / tick_us, 60000000.0 / tick_us);
        if (sp_trig_start(&g, &sp_platform_default.home, (sp_axis_t)(n % 6), amp, hz, tick_us, fade) != SP_OK) {
            continue;
        }
        ++accepted;
        sp_status_t st_want = plain_trig_first(&g, tick_us, &want);
        assert_int_equal(st_want, SP_OK);
        assert_int_equal(sp_trig_step(&g, tick_us, &m), st_want);
        assert_memory_equal(&m, &want, sizeof m);
        assert_int_equal(g.tick, 1u);
        assert_int_equal(g.phase, g.phase_step);
        assert_int_equal(g.fade_tick_us, tick_us);
    }
    assert_true(accepted > 100);
}

static void test_trig_generator(void **state)
{
    sp_trig_t g;
    sp_motion_t m;
    double prev_x = 0;
    double prev_v = 0;
    (void)state;
    assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_X, q24(0.09), q24(0.5), 1000u, 1000u), SP_OK);
    /* velocity and acceleration are the derivatives of position */
    for (int n = 0; n < 6000; ++n) {
        double x;
        double v;
        double a;
        if (n == 4000) {
            sp_trig_stop(&g);
        }
        assert_int_equal(sp_trig_step(&g, 1000u, &m), SP_OK);
        x = f24(m.pose.pos[0] - sp_platform_default.home.pos[0]);
        v = f24(m.vel[0]);
        a = f24(m.acc[0]);
        if (n > 0 && !g.finished) {
            assert_near((x - prev_x) / 1e-3, (v + prev_v) / 2, 2e-4, "tick %d: velocity vs position difference", n);
            (void)a;
        }
        prev_x = x;
        prev_v = v;
    }
    assert_true(g.finished);
    assert_int_equal(m.pose.pos[0], sp_platform_default.home.pos[0]);
    assert_int_equal(m.vel[0], 0);
    /* through the wraps: the tick stops at the fade once faded in, so a
     * motion of any length (the old tick saturated after 2^32 ticks at the
     * stop sentinel: unstoppable) still fades out in fade_ticks */
    assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_X, q24(0.09), q24(0.5), 1000u, 500u), SP_OK);
    for (int n = 0; n < 20000; ++n) {
        assert_int_equal(sp_trig_step(&g, 1000u, &m), SP_OK);
    }
    assert_int_equal(g.tick, 500u);
    g.phase = UINT32_MAX - g.phase_step / 2u; /* the phase wraps modulo one turn: no jump */
    assert_int_equal(sp_trig_step(&g, 1000u, &m), SP_OK);
    prev_x = f24(m.pose.pos[0] - sp_platform_default.home.pos[0]);
    assert_int_equal(sp_trig_step(&g, 1000u, &m), SP_OK);
    assert_near(f24(m.pose.pos[0] - sp_platform_default.home.pos[0]), prev_x, 0.09 * 6.3 * 0.5e-3 * 1.01,
                "position step across the phase wrap (m)");
    sp_trig_stop(&g);
    for (int n = 0; n <= 500 && !g.finished; ++n) {
        assert_int_equal(sp_trig_step(&g, 1000u, &m), SP_OK);
    }
    assert_true(g.finished);
    assert_int_equal(m.pose.pos[0], sp_platform_default.home.pos[0]);
    /* bad arguments */
    assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_X, q24(0.09), 0, 1000u, 1000u), SP_E_ARG);
    assert_int_equal(sp_trig_start(&g, &sp_platform_default.home, SP_AXIS_X, q24(2.0), q24(1), 1000u, 1000u), SP_E_ARG);
    assert_int_equal(sp_trig_start(&g, NULL, SP_AXIS_X, q24(0.09), q24(1), 1000u, 1000u), SP_E_ARG);
}

/* The wrench source and its contact threshold come together. */
static void test_set_wrench_source(void **state)
{
    (void)state;
    sp_ctrl_config_t cfg;
    assert_int_equal(sp_ctrl_default_config(&cfg, &sp_platform_default), SP_OK);
    sp_ft_mount_t mount = cfg.ft_mount;
    mount.pos[2] = 12345;
    assert_int_equal(sp_ctrl_set_wrench_source(&cfg, SP_WRENCH_CYLINDERS, &mount), SP_OK);
    assert_int_equal(cfg.wrench_source, SP_WRENCH_CYLINDERS);
    assert_int_equal(cfg.force.contact.made, 300 * SP_Q8_ONE);
    assert_int_equal(cfg.ft_mount.pos[2], 12345);
    assert_int_equal(sp_ctrl_set_wrench_source(&cfg, SP_WRENCH_SENSOR, NULL), SP_OK);
    assert_int_equal(cfg.force.contact.made, 100 * SP_Q8_ONE);
    assert_int_equal(cfg.ft_mount.pos[2], 12345);
    assert_int_equal(sp_ctrl_set_wrench_source(&cfg, 7u, NULL), SP_E_ARG);
    assert_int_equal(cfg.wrench_source, SP_WRENCH_SENSOR);
    assert_int_equal(sp_ctrl_set_wrench_source(NULL, SP_WRENCH_SENSOR, NULL), SP_E_ARG);
}

/* One tick of CANopen drives at SYNC every 3 (or 2) ticks (feedback_divider):
 * phase 0 sends setpoints (the drives take them), the others are
 * setpoints_idle; the drives' answers, fresh, arrive on phase 1. */
static void divided_tick(rig_t *r, sp_cmd_type_t cmd, unsigned phase)
{
    for (int i = 0; i < SP_LEGS; ++i) {
        r->in.drive[i].fresh = (uint8_t)(phase == 1u ? 1u : 0u);
        r->in.drive[i].length = r->plant_length[i];
        r->in.drive[i].force = 0;
    }
    r->in.setpoints_idle = (uint8_t)(phase != 0u ? 1u : 0u);
    r->in.cmd.type = cmd;
    assert_int_equal(sp_ctrl_step(&r->cfg, &r->ctrl, &r->in, &r->out), SP_OK);
    r->in.cmd.type = SP_CMD_NONE;
    if (phase == 0u && r->out.drive_mode == SP_DRIVE_ACTIVE) {
        for (int i = 0; i < SP_LEGS; ++i) {
            r->plant_length[i] = r->out.setpoint[i].length;
        }
    }
}

/* From ENGAGING at a divider's phase: on to READY, the surge started on a
 * sending tick, 3000 ticks of it: every sending tick carries its own
 * reference's setpoints (sp_setpoints_of's lengths and rates, forces
 * within 5 N: refined from a factorisation up to 8 sending ticks old), the
 * idle ticks keep them bit for bit while the reported reference moves
 * (on 9 in 10 at least), and the wrench estimate steps only on the
 * answers' ticks. Returns the worst force difference, N. */
static double divided_surge(rig_t *r, unsigned *t, unsigned divider)
{
    unsigned moved = 0u;
    unsigned idle = 0u;
    double worst = 0.0;
    for (int n = 0; n < 20000 && r->out.state != SP_STATE_READY; ++n) {
        divided_tick(r, SP_CMD_NONE, (*t)++ % divider);
    }
    assert_int_equal(r->out.state, SP_STATE_READY);
    while (*t % divider != 0u) {
        divided_tick(r, SP_CMD_NONE, (*t)++ % divider);
    }
    r->in.cmd.axis = SP_AXIS_X;
    r->in.cmd.amplitude = q24(0.05);
    r->in.cmd.frequency = q24(0.5);
    divided_tick(r, SP_CMD_RUN_TRIG, (*t)++ % divider);
    assert_int_equal(r->out.cmd_rejected, 0);
    assert_int_equal(r->out.state, SP_STATE_RUNNING);
    for (int n = 0; n < 3000; ++n) {
        unsigned phase = (*t)++ % divider;
        sp_setpoint_t before[SP_LEGS];
        sp_pose_t ref_before = r->out.reference.pose;
        sp_wrench_t w_before = r->ctrl.wrench;
        memcpy(before, r->out.setpoint, sizeof before);
        divided_tick(r, SP_CMD_NONE, phase);
        assert_int_equal(r->out.state, SP_STATE_RUNNING);
        if (phase == 0u) {
            worst = fmax(worst, check_fresh_setpoints(r, SP_FF_DYNAMICS | SP_FF_FRICTION, 5.0));
        } else {
            idle++;
            assert_memory_equal(before, r->out.setpoint, sizeof before);
            moved += (memcmp(&ref_before, &r->out.reference.pose, sizeof ref_before) != 0) ? 1u : 0u;
        }
        if (phase != 1u) {
            assert_memory_equal(&w_before, &r->ctrl.wrench, sizeof w_before);
        }
    }
    print_message("divided feedback by %u: sending ticks' forces within %.3f N of sp_setpoints_of; the reference "
                  "moved on %u of %u idle ticks\n",
                  divider, worst, moved, idle);
    assert_true(moved >= idle * 9u / 10u);
    assert_int_equal(r->out.faults, 0);
    return worst;
}

/* Divided feedback at `divider` (rig initialised, the divider's timeout
 * set): five ticks from the first answers (the estimate valid), then ENGAGE
 * on a sending tick, taken. Returns the next tick's number. */
static unsigned divided_engage(rig_t *r, unsigned divider)
{
    unsigned t = 1u;
    r->cfg.feedback_divider = divider;
    assert_int_equal(sp_ctrl_init(&r->ctrl, &r->cfg), SP_OK);
    for (; t < 6u; ++t) {
        divided_tick(r, SP_CMD_NONE, t % divider);
    }
    assert_int_equal(t % divider, 0u);
    assert_true(r->out.estimate_valid);
    divided_tick(r, SP_CMD_ENGAGE, t++ % divider);
    assert_int_equal(r->out.state, SP_STATE_ENGAGING);
    return t;
}

/* Divided feedback (setpoints and answers once per SYNC period of 3
 * ticks): ENGAGE taken on a sending tick holds there (the lengths where
 * the platform stands, no force), the answers' tick makes nothing, the
 * quiet tick after makes the setpoints; then the surge (divided_surge). A
 * divider above 255 is refused by sp_ctrl_init. */
static void test_divided_feedback(void **state)
{
    (void)state;
    static rig_t r;
    unsigned t;
    rig_init(&r);
    r.cfg.feedback_divider = 256u;
    assert_int_equal(sp_ctrl_init(&r.ctrl, &r.cfg), SP_E_ARG);
    r.cfg.feedback_timeout_ticks = 5u;
    t = divided_engage(&r, 3u);
    assert_int_equal(r.ctrl.setpoints_deferred, 1);
    assert_int_equal(r.ctrl.est.ref_lu.valid, 0);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(r.out.setpoint[i].length, r.in.drive[i].length);
        assert_int_equal(r.out.setpoint[i].force, 0);
    }
    divided_tick(&r, SP_CMD_NONE, t++ % 3u); /* the answers */
    assert_int_equal(r.ctrl.est.ref_lu.valid, 0);
    divided_tick(&r, SP_CMD_NONE, t++ % 3u); /* quiet: made here */
    assert_int_equal(r.ctrl.est.ref_lu.valid, 1);
    (void)divided_surge(&r, &t, 3u);
}

/* Divided feedback at SYNC every 2 ticks (CiA 402's layout on two classic
 * buses): no quiet tick, so ENGAGE taken on a sending tick makes the
 * setpoints there, at rest where the platform stands (the measured
 * lengths within 1 um, no velocity); then the surge as at 3. */
static void test_divided_feedback_by_two(void **state)
{
    (void)state;
    static rig_t r;
    unsigned t;
    rig_init(&r);
    r.cfg.feedback_timeout_ticks = 4u;
    t = divided_engage(&r, 2u);
    assert_int_equal(r.ctrl.setpoints_deferred, 0);
    assert_int_equal(r.ctrl.est.ref_lu.valid, 1);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_true(llabs((long long)r.out.setpoint[i].length - (long long)r.in.drive[i].length) <= q24(1e-6));
        assert_int_equal(r.out.setpoint[i].velocity, 0);
    }
    (void)divided_surge(&r, &t, 2u);
}

/* One tick with an operator heartbeat when `beat`. */
static void link_tick(rig_t *r, sp_cmd_type_t cmd, int beat)
{
    r->in.operator_heartbeat = (uint8_t)(beat ? 1u : 0u);
    rig_tick(r, cmd);
    r->in.operator_heartbeat = 0u;
}

static void start_surge(rig_t *r)
{
    r->in.cmd.axis = SP_AXIS_X;
    r->in.cmd.amplitude = q24(0.05);
    r->in.cmd.frequency = q24(0.5);
    link_tick(r, SP_CMD_RUN_TRIG, 1);
    assert_int_equal(r->out.cmd_rejected, 0);
    assert_int_equal(r->out.state, SP_STATE_RUNNING);
}

/* The surge (90 mm at 0.5 Hz, 0.5 s fade) until its reference moves at
 * its peak, +0.283 m/s (the zero crossing after one period). */
static void surge_at_peak(rig_t *r)
{
    engage(r);
    r->in.cmd.axis = SP_AXIS_X;
    r->in.cmd.amplitude = q24(0.09);
    r->in.cmd.frequency = q24(0.5);
    r->in.cmd.fade_ticks = 500u;
    rig_tick(r, SP_CMD_RUN_TRIG);
    assert_int_equal(r->out.state, SP_STATE_RUNNING);
    for (int n = 1; n < 2000; ++n) {
        rig_tick(r, SP_CMD_NONE);
    }
    assert_true(f24(r->out.reference.vel[0]) > 0.28);
}

/* ESTOP's controlled stop (category 1) in the surge at 0.283 m/s: STOPPING
 * with the drives ACTIVE and the valves open, the reference decelerating
 * monotonically within the configured 4 m/s^2 and 25 m/s^3 along x alone,
 * at rest within 0.3 s; then ESTOP: drives HOLD, valves blocked, the
 * setpoints where the stop ended. */
static void test_estop_controlled_stop(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    surge_at_peak(&r);
    double v = f24(r.out.reference.vel[0]), a = f24(r.out.reference.acc[0]), v0 = v;
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_STOPPING);
    assert_int_equal(r.out.stop_reaction, SP_STOP_CONTROLLED);
    assert_int_equal(r.out.stop_cause, SP_STOP_CAUSE_NONE);
    assert_int_equal(r.out.faults, SP_FAULT_ESTOP);
    int ticks = 1, rest = -1;
    double peak_dec = 0.0, peak_jerk = 0.0;
    while (r.out.state == SP_STATE_STOPPING && ticks < 1000) {
        double v1 = f24(r.out.reference.vel[0]), a1 = f24(r.out.reference.acc[0]);
        assert_int_equal(r.out.drive_mode, SP_DRIVE_ACTIVE);
        assert_int_equal(r.out.drive_block, 0);
        assert_true(v1 <= v0 + 1e-4 && v1 >= -1e-6); /* no faster, never back */
        assert_int_equal(r.out.reference.vel[1] | r.out.reference.vel[2] | r.out.reference.rpy_rate[2], 0);
        peak_dec = fmax(peak_dec, fabs(a1));
        peak_jerk = fmax(peak_jerk, fabs(a1 - a) * 1000.0);
        if (rest < 0 && r.out.reference.vel[0] == 0 && r.out.reference.acc[0] == 0) {
            rest = ticks;
        }
        v = v1, a = a1;
        rig_tick(&r, SP_CMD_NONE);
        ++ticks;
    }
    printf("controlled stop from 0.283 m/s: at rest after %d ticks, ESTOP after %d, peak %.2f m/s^2 %.1f m/s^3\n", rest,
           ticks, peak_dec, peak_jerk);
    assert_true(rest > 0 && rest <= 300);
    assert_int_equal(ticks, rest + (int)r.cfg.estop.settle_ticks);
    assert_true(peak_dec <= 4.0 + 1e-3 && peak_jerk <= 25.0 * 1.01 + 1.0);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
    assert_int_equal(r.out.drive_block, 1);
    assert_int_equal(r.out.stop_reaction, SP_STOP_CONTROLLED);
    sp_setpoint_t held[SP_LEGS];
    memcpy(held, r.out.setpoint, sizeof held);
    for (int n = 0; n < 50; ++n) {
        rig_tick(&r, SP_CMD_NONE);
        assert_memory_equal(held, r.out.setpoint, sizeof held);
    }
    rig_tick(&r, SP_CMD_RESET); /* RESET re-engages and forgets the reaction */
    assert_int_equal(r.out.state, SP_STATE_ENGAGING);
    assert_int_equal(r.out.stop_reaction, SP_STOP_NONE);
}

/* Category 0 wherever the controller cannot trust its loop, each with its
 * cause: the config's choice, the drives holding (IDLE), a second ESTOP
 * during the stop, a drive silent during the stop, a drive's fault at
 * the ESTOP; at rest (READY) the controlled stop has nothing to do and
 * blocks at once; RESET is refused while stopping. */
static void test_estop_immediate_causes(void **state)
{
    static rig_t r;
    (void)state;
    /* the config's choice */
    rig_init(&r);
    r.cfg.estop.category = 0u;
    assert_int_equal(sp_ctrl_init(&r.ctrl, &r.cfg), SP_OK);
    surge_at_peak(&r);
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_block, 1);
    assert_int_equal(r.out.stop_reaction, SP_STOP_IMMEDIATE);
    assert_int_equal(r.out.stop_cause, SP_STOP_CAUSE_CONFIG);
    /* IDLE: the drives hold already */
    rig_init(&r);
    rig_tick(&r, SP_CMD_NONE);
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.stop_cause, SP_STOP_CAUSE_HOLDING);
    /* READY at rest: controlled, nothing to decelerate, blocked at once */
    rig_init(&r);
    engage(&r);
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_block, 1);
    assert_int_equal(r.out.stop_reaction, SP_STOP_CONTROLLED);
    /* a second ESTOP during the stop; RESET refused before */
    rig_init(&r);
    surge_at_peak(&r);
    rig_tick(&r, SP_CMD_ESTOP);
    rig_tick(&r, SP_CMD_NONE);
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_STOPPING);
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.drive_block, 1);
    assert_int_equal(r.out.stop_reaction, SP_STOP_IMMEDIATE);
    assert_int_equal(r.out.stop_cause, SP_STOP_CAUSE_SECOND);
    /* a drive silent during the stop */
    rig_init(&r);
    surge_at_peak(&r);
    rig_tick(&r, SP_CMD_ESTOP);
    r.silent[3] = 1;
    for (int n = 0; n < 5; ++n) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.stop_cause, SP_STOP_CAUSE_COMMS);
    assert_int_equal(r.out.faults, SP_FAULT_ESTOP | SP_FAULT_FEEDBACK_TIMEOUT);
    /* a drive reporting a fault on the ESTOP's tick */
    rig_init(&r);
    surge_at_peak(&r);
    r.in.drive[1].faults = 0x10u;
    rig_tick(&r, SP_CMD_ESTOP);
    assert_int_equal(r.out.state, SP_STATE_ESTOP);
    assert_int_equal(r.out.stop_reaction, SP_STOP_IMMEDIATE);
}

/* Operator link supervision: never heard, no supervision; heard, a silence
 * of operator_timeout_ticks while RUNNING latches the fault on exactly that
 * tick and stops the motion smoothly; motion commands are refused until
 * RESET; READY is not supervised; ESTOP and STOP always pass. */
static void test_operator_link_stop(void **state)
{
    static rig_t r;
    uint32_t timeout;
    (void)state;
    rig_init(&r);
    timeout = r.cfg.operator_timeout_ticks;
    assert_int_equal(timeout, 200u);
    engage(&r);
    /* never armed: a long silent run is fine */
    r.in.cmd.axis = SP_AXIS_X;
    r.in.cmd.amplitude = q24(0.05);
    r.in.cmd.frequency = q24(0.5);
    rig_tick(&r, SP_CMD_RUN_TRIG);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    for (int k = 0; k < 1000; ++k) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.faults, 0u);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    rig_tick(&r, SP_CMD_STOP);
    run_until(&r, SP_STATE_READY, 5000);
    /* armed by one heartbeat; READY is not supervised */
    link_tick(&r, SP_CMD_NONE, 1);
    for (int k = 0; k < 1000; ++k) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.faults, 0u);
    /* RUNNING with a heartbeat every 20 ticks: no fault */
    start_surge(&r);
    for (int k = 1; k <= 2000; ++k) {
        link_tick(&r, SP_CMD_NONE, k % 20 == 0);
        assert_int_equal(r.out.faults, 0u);
    }
    /* silent: the fault on the timeout-th silent tick, not before */
    for (uint32_t k = 1; k < timeout; ++k) {
        rig_tick(&r, SP_CMD_NONE);
        assert_int_equal(r.out.faults, 0u);
    }
    rig_tick(&r, SP_CMD_NONE);
    assert_int_equal(r.out.faults, SP_FAULT_OPERATOR_SILENT);
    assert_int_equal(r.out.state, SP_STATE_RUNNING); /* fading out, not a jump */
    assert_int_equal(r.out.drive_mode, SP_DRIVE_ACTIVE);
    run_until(&r, SP_STATE_READY, 5000);
    assert_near(f24(r.out.reference.pose.pos[0]), f24(sp_platform_default.home.pos[0]), 1e-6, "x after the stop");
    assert_int_equal(r.out.faults, SP_FAULT_OPERATOR_SILENT);
    /* latched: motion refused, even with the operator back */
    r.in.cmd.axis = SP_AXIS_X;
    link_tick(&r, SP_CMD_RUN_TRIG, 1);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_READY);
    link_tick(&r, SP_CMD_STREAM, 1);
    assert_int_equal(r.out.cmd_rejected, 1);
    /* RESET in READY clears it and nothing else */
    link_tick(&r, SP_CMD_RESET, 1);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.faults, 0u);
    assert_int_equal(r.out.state, SP_STATE_READY);
    /* ESTOP passes while the fault is being raised on the same tick */
    start_surge(&r);
    for (uint32_t k = 1; k < timeout; ++k) {
        rig_tick(&r, SP_CMD_NONE);
    }
    rig_tick(&r, SP_CMD_ESTOP); /* the controlled stop, then ESTOP */
    assert_int_equal(r.out.state, SP_STATE_STOPPING);
    assert_int_equal(r.out.faults, SP_FAULT_OPERATOR_SILENT | SP_FAULT_ESTOP);
    run_until(&r, SP_STATE_ESTOP, 2000);
    link_tick(&r, SP_CMD_RESET, 1);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.state, SP_STATE_ENGAGING);
    assert_int_equal(r.out.faults, 0u);
    run_until(&r, SP_STATE_READY, 20000);
    /* STOP always passes, and a STOP while latched and stopping is not refused */
    start_surge(&r);
    for (uint32_t k = 0; k < timeout; ++k) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.faults, SP_FAULT_OPERATOR_SILENT);
    rig_tick(&r, SP_CMD_STOP);
    assert_int_equal(r.out.cmd_rejected, 0);
    /* RESET while still stopping is refused */
    rig_tick(&r, SP_CMD_RESET);
    assert_int_equal(r.out.cmd_rejected, 1);
    run_until(&r, SP_STATE_READY, 5000);
}

/* The park reaction, and the supervision off (timeout 0). */
static void test_operator_link_park(void **state)
{
    static rig_t r;
    (void)state;
    rig_init(&r);
    r.cfg.operator_park = 1u;
    engage(&r);
    start_surge(&r);
    for (uint32_t k = 0; k < r.cfg.operator_timeout_ticks; ++k) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.faults, SP_FAULT_OPERATOR_SILENT);
    run_until(&r, SP_STATE_PARKING, 5000);
    run_until(&r, SP_STATE_IDLE, 20000);
    for (int k = 0; k < 3; ++k) {
        assert_near(f24(r.out.estimate.pos[k]), f24(sp_platform_default.park.pos[k]), 1e-6, "parked pos[%d]", k);
    }
    link_tick(&r, SP_CMD_ENGAGE, 1);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.state, SP_STATE_IDLE);
    link_tick(&r, SP_CMD_RESET, 1);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.faults, 0u);
    link_tick(&r, SP_CMD_ENGAGE, 1);
    assert_int_equal(r.out.state, SP_STATE_ENGAGING);
    run_until(&r, SP_STATE_READY, 20000);
    /* supervision off */
    r.cfg.operator_timeout_ticks = 0u;
    start_surge(&r);
    for (int k = 0; k < 1000; ++k) {
        rig_tick(&r, SP_CMD_NONE);
    }
    assert_int_equal(r.out.faults, 0u);
    assert_int_equal(r.out.state, SP_STATE_RUNNING);
    /* NULL arguments: no command, nothing dropped */
    {
        int dropped = 1;
        assert_int_equal(sp_ctrl_operator_link(NULL, &r.ctrl, &r.in, &dropped)->type, SP_CMD_NONE);
        assert_int_equal(dropped, 0);
        assert_int_equal(sp_ctrl_operator_link(&r.cfg, &r.ctrl, &r.in, NULL)->type, SP_CMD_NONE);
    }
}

static void test_move_respects_limits(void **state)
{
    sp_move_t mv;
    sp_move_limits_t lim;
    sp_motion_t m;
    sp_pose_t to = sp_platform_default.home;
    double vmax = 0;
    double amax = 0;
    double jmax = 0;
    double prev_a = 0;
    int done = 0;
    int n = 0;
    (void)state;
    for (int a = 0; a < 6; ++a) {
        lim.vel_max[a] = q24(0.25);
        lim.acc_max[a] = q24(1.0);
        lim.jerk_max[a] = q24(5.0);
    }
    assert_int_equal(sp_move_plan(&mv, &sp_platform_default.park, &to, &lim, 1000u), SP_OK);
    while (!done) {
        double v;
        double a;
        assert_int_equal(sp_move_step(&mv, 1000u, &m, &done), SP_OK);
        v = fabs(f24(m.vel[2]));
        a = f24(m.acc[2]);
        vmax = v > vmax ? v : vmax;
        amax = fabs(a) > amax ? fabs(a) : amax;
        if (n > 0 && !done) {
            double j = fabs(a - prev_a) / 1e-3;
            jmax = j > jmax ? j : jmax;
        }
        prev_a = a;
        assert_true(++n < 100000);
    }
    assert_memory_equal(&m.pose, &to, sizeof to);
    assert_true(vmax <= 0.25 * 1.001);
    assert_true(amax <= 1.0 * 1.001);
    assert_true(jmax <= 5.0 * 1.01);
    lim.vel_max[0] = 0;
    assert_int_equal(sp_move_plan(&mv, &sp_platform_default.park, &to, &lim, 1000u), SP_E_ARG);
    print_message("engage move: %d ticks, peak %.3f m/s %.3f m/s^2 %.3f m/s^3\n", n, vmax, amax, jmax);
}

/* The plain reference of sp_move_plan's duration: every bound of every
 * axis computed, its root by a bisection over all of uint32, the largest
 * kept; the same range checks in the same order. */
static sp_status_t plain_move_ticks(const sp_pose_t *from, const sp_pose_t *to, const sp_move_limits_t *lim,
                                    uint32_t tick_us, uint32_t *ticks)
{
    const uint64_t max_ms = 600000u;
    uint64_t t_ms = 0u;
    for (int a = 0; a < 6; ++a) {
        int64_t d = (int64_t)sp_pose_axis(to, (sp_axis_t)a) - sp_pose_axis(from, (sp_axis_t)a);
        uint64_t dm = (uint64_t)(d < 0 ? -d : d);
        uint64_t t, lo, hi;
        if (lim->vel_max[a] <= 0 || lim->acc_max[a] <= 0 || lim->jerk_max[a] <= 0) {
            return SP_E_ARG;
        }
        if (dm == 0u) {
            continue;
        }
        t = (dm * 1875u + (uint64_t)lim->vel_max[a] - 1u) / (uint64_t)lim->vel_max[a];
        t_ms = t > t_ms ? t : t_ms;
        t = (dm * 5773503u + (uint64_t)lim->acc_max[a] - 1u) / (uint64_t)lim->acc_max[a];
        if (t > max_ms * max_ms) {
            return SP_E_RANGE;
        }
        for (lo = 0u, hi = UINT32_MAX; lo < hi;) { /* smallest r, r^2 >= t */
            uint64_t mid = (lo + hi) / 2u;
            if (mid * mid >= t) {
                hi = mid;
            } else {
                lo = mid + 1u;
            }
        }
        t_ms = lo > t_ms ? lo : t_ms;
        if (dm >= (UINT64_C(1) << 28)) {
            return SP_E_RANGE;
        }
        t = (dm * UINT64_C(60000000000) + (uint64_t)lim->jerk_max[a] - 1u) / (uint64_t)lim->jerk_max[a];
        if (t > max_ms * max_ms * max_ms) {
            return SP_E_RANGE;
        }
        for (lo = 0u, hi = 2097152u; lo < hi;) { /* smallest r, r^3 >= t */
            uint64_t mid = (lo + hi) / 2u;
            if (mid * mid * mid >= t) {
                hi = mid;
            } else {
                lo = mid + 1u;
            }
        }
        t_ms = lo > t_ms ? lo : t_ms;
    }
    if (t_ms > max_ms) {
        return SP_E_RANGE;
    }
    *ticks = (uint32_t)((t_ms * 1000u + tick_us - 1u) / tick_us);
    return SP_OK;
}

/* sp_move_plan computes a root only where it can be the largest bound:
 * the same duration and status as the plain reference over random moves
 * (any number of axes at rest) and limits where each bound dominates in
 * turn, including moves and limits beyond the range checks. */
static void test_move_plan_against_plain(void **state)
{
    uint64_t rng = 777u;
    int kinds[3] = {0, 0, 0};
    (void)state;
    for (int n = 0; n < 20000; ++n) {
        sp_pose_t from = sp_platform_default.home;
        sp_pose_t to = from;
        sp_move_limits_t lim;
        sp_move_t mv;
        uint32_t ticks = 0u;
        sp_status_t st, plain;
        for (int a = 0; a < 6; ++a) {
            double u[5];
            for (int k = 0; k < 5; ++k) {
                rng = rng * 6364136223846793005u + 1442695040888963407u;
                u[k] = (double)(rng >> 11) / 9007199254740992.0;
            }
            /* an axis at rest one time in three; up to 0.5 m or rad, or up
             * to 20 m (beyond the range checks) one time in 200 */
            double dist = (u[0] < 1.0 / 3.0) ? 0.0 : (u[1] - 0.5) * ((n % 200 == 0) ? 40.0 : 1.0);
            sp_q24_t *c = (a < 3) ? &to.pos[a] : &to.rpy[a - 3];
            *c += q24(dist);
            lim.vel_max[a] = q24(0.001 + 2.0 * u[2]);
            lim.acc_max[a] = q24(0.001 + 20.0 * u[3]);
            lim.jerk_max[a] = q24(0.001 + 100.0 * u[4]);
        }
        if (n % 997 == 0) {
            lim.jerk_max[n % 6] = 0;
        }
        plain = plain_move_ticks(&from, &to, &lim, 1000u, &ticks);
        st = sp_move_plan(&mv, &from, &to, &lim, 1000u);
        assert_int_equal(st, plain);
        if (st == SP_OK) {
            assert_int_equal(mv.duration_ticks, ticks);
            kinds[0]++;
        } else {
            kinds[st == SP_E_RANGE ? 1 : 2]++;
            assert_int_equal(mv.duration_ticks, 0u);
            assert_memory_equal(&mv.to, &from, sizeof from);
        }
    }
    print_message("move plans against the plain reference: %d planned, %d out of range, %d bad limits\n", kinds[0],
                  kinds[1], kinds[2]);
    assert_true(kinds[0] > 1000 && kinds[1] > 10 && kinds[2] > 5);
}

/* The first sample of a planned move as sp_move_step's general path
 * makes it: the smoothstep's E, E', E'' at u = 0 through the public
 * fixed-point functions, every moving axis's products by them and by the
 * rate 1/duration (its saturation flagged), the pose `from` plus D E. */
static sp_status_t plain_move_first(const sp_move_t *mv, uint32_t tick_us, sp_motion_t *out)
{
    sp_flags_t flags = 0u;
    const int64_t one = INT64_C(1) << 30;
    const int64_t u = 0;
    int64_t u2 = sp_rshift_round(u * u, 30u);
    int64_t u3 = sp_rshift_round(u2 * u, 30u);
    int64_t v2 = sp_rshift_round((one - u) * (one - u), 30u);
    int64_t e = sp_rshift_round(u3 * (10 * one - 15 * u + 6 * u2), 30u);
    int64_t de = sp_rshift_round(30 * sp_rshift_round(u2 * v2, 30u), 6u);
    int64_t dde = sp_rshift_round(60 * sp_rshift_round(sp_rshift_round(u * (one - u), 30u) * (one - 2 * u), 30u), 6u);
    uint64_t dt_us = (uint64_t)mv->duration_ticks * tick_us;
    int32_t rate = sp_sat32((int64_t)(((UINT64_C(1) << 24) * UINT64_C(1000000)) / dt_us), &flags);
    sp_motion_at_rest(out, &mv->from);
    for (int a = 0; a < 6; ++a) {
        int64_t d = (int64_t)sp_pose_axis(&mv->to, (sp_axis_t)a) - sp_pose_axis(&mv->from, (sp_axis_t)a);
        if (d == 0) {
            continue;
        }
        int32_t dv = sp_sat32(sp_rshift_round(d * de, 24u), &flags);
        int32_t da = sp_sat32(sp_rshift_round(d * dde, 24u), &flags);
        int64_t dp = sp_rshift_round(d * e, 30u);
        sp_q24_t *p = (a < 3) ? &out->pose.pos[a] : &out->pose.rpy[a - 3];
        *p = sp_sat32(*p + dp, &flags);
        *((a < 3) ? &out->vel[a] : &out->rpy_rate[a - 3]) = sp_sat32(sp_rshift_round((int64_t)dv * rate, 24u), &flags);
        *((a < 3) ? &out->acc[a] : &out->rpy_acc[a - 3]) = sp_sat32(
            sp_rshift_round((int64_t)sp_sat32(sp_rshift_round((int64_t)da * rate, 24u), &flags) * rate, 24u), &flags);
    }
    return sp_flags_status(flags);
}

/* sp_move_step's first sample (its short path: `from` at rest, no
 * smoothstep) against plain_move_first, bit for bit with the status, on
 * random moves from 0.1 um to 1 m or rad, some short enough for the rate
 * to saturate; the second sample then comes from the general path. */
static void test_move_first_sample(void **state)
{
    uint64_t rng = 4242u;
    int saturated = 0;
    int planned = 0;
    (void)state;
    for (int n = 0; n < 5000; ++n) {
        sp_pose_t to = sp_platform_default.home;
        sp_move_limits_t lim;
        sp_move_t mv;
        sp_motion_t m, want;
        int done = 1;
        for (int a = 0; a < 6; ++a) {
            rng = rng * 6364136223846793005u + 1442695040888963407u;
            double u = (double)(rng >> 11) / 9007199254740992.0;
            double dist = ((rng >> 3) % 3u == 0u) ? 0.0 : (u - 0.5) * 2.0 * pow(10.0, -7.0 + 7.0 * u);
            *((a < 3) ? &to.pos[a] : &to.rpy[a - 3]) += q24(dist);
            lim.vel_max[a] = q24(0.25);
            lim.acc_max[a] = q24(n % 2 ? 1.0 : 100.0);
            lim.jerk_max[a] = q24(n % 2 ? 5.0 : 120.0);
        }
        if (sp_move_plan(&mv, &sp_platform_default.home, &to, &lim, 1000u) != SP_OK || mv.duration_ticks == 0u) {
            continue;
        }
        ++planned;
        sp_status_t st_want = plain_move_first(&mv, 1000u, &want);
        saturated += st_want != SP_OK;
        assert_int_equal(sp_move_step(&mv, 1000u, &m, &done), st_want);
        assert_int_equal(done, 0);
        assert_memory_equal(&m, &want, sizeof m);
        assert_int_equal(mv.tick, 1u);
        (void)sp_move_step(&mv, 1000u, &m, &done);
        assert_int_equal(mv.tick, (mv.duration_ticks > 1u) ? 2u : 1u);
    }
    print_message("move first samples: %d moves, %d with a saturated rate\n", planned, saturated);
    assert_true(planned > 3000 && saturated > 5);
}

/* ---- force control on a force/torque sensor ---------------------------- */

/* A surface under the tool (the sensor at o', its axes the platform's) at
 * height z_s with stiffness k: the sensor reads the world pushing up on
 * the tool, plus a bias, from the plant's pose one tick late (the ideal
 * plant: the lengths of the last setpoints, i.e. the last reference). */
typedef struct {
    double z_s, k, bias;
    int on;
} surface_t;

static double surface_force(const surface_t *s, double z)
{
    return (s->on && z < s->z_s) ? s->k * (s->z_s - z) : 0.0;
}

static void force_tick(rig_t *r, const surface_t *s, sp_cmd_type_t cmd)
{
    double z = f24(r->out.reference.pose.pos[2]);
    memset(r->in.ft_reading, 0, sizeof r->in.ft_reading);
    r->in.ft_fresh = 1u;
    r->in.ft_reading[2] = (sp_q8_t)lround((surface_force(s, z) + s->bias) * 256.0);
    rig_tick(r, cmd);
}

static void force_rig(rig_t *r, surface_t *s)
{
    rig_init(r);
    r->cfg.wrench_source = SP_WRENCH_SENSOR;
    assert_int_equal(sp_ctrl_init(&r->ctrl, &r->cfg), SP_OK);
    s->bias = 15.0;
    s->k = 1e6;
    s->on = 0;
    for (int n = 0; n < 3; ++n) {
        force_tick(r, s, SP_CMD_NONE);
    }
    force_tick(r, s, SP_CMD_ENGAGE);
    for (int n = 0; n < 20000 && r->out.state != SP_STATE_READY; ++n) {
        force_tick(r, s, SP_CMD_NONE);
    }
    assert_int_equal(r->out.state, SP_STATE_READY);
    s->z_s = f24(r->out.reference.pose.pos[2]) - 0.002; /* 2 mm below the tool */
}

/* Before a reference exists the sensor's frame is made at the estimate's
 * angles: from the sines kept since init when the estimate is at park's
 * angles (sp_ctrl_init keeps park's orientation), else from its own; both
 * are sp_ft_frame of sp_orientation(estimate), bit for bit, and the
 * ENGAGE tick's setpoints are those of a controller without the kept
 * orientation (sp_setpoints_of). */
static void test_ft_frame_before_reference(void **state)
{
    static rig_t r;
    (void)state;
    for (int tilted = 0; tilted < 2; ++tilted) {
        sp_pose_t start = sp_platform_default.park;
        sp_ik_t ik;
        sp_rot_t rot;
        sp_ft_frame_t want;
        sp_setpoint_t sp[SP_LEGS];
        sp_lu6_t lu;
        sp_model_t model;
        sp_motion_t at;
        rig_init(&r);
        r.cfg.wrench_source = SP_WRENCH_SENSOR;
        assert_int_equal(sp_ctrl_init(&r.ctrl, &r.cfg), SP_OK);
        if (tilted) {
            start.pos[2] += q24(0.05);
            start.rpy[0] = q24(0.011);
            start.rpy[1] = q24(-0.007);
            start.rpy[2] = q24(0.013);
        }
        assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &start, &ik), SP_OK);
        memcpy(r.plant_length, ik.length, sizeof r.plant_length);
        r.in.ft_fresh = 1u;
        rig_tick(&r, SP_CMD_NONE);
        assert_true(r.out.estimate_valid);
        assert_int_equal(r.ctrl.ft_frame_valid, 1);
        assert_int_equal(sp_orientation(r.ctrl.est.pose.rpy, &rot), SP_OK);
        assert_int_equal(sp_ft_frame(&r.cfg.ft_mount, &rot, &want), SP_OK);
        assert_memory_equal(&r.ctrl.ft_frame, &want, sizeof want);
        rig_tick(&r, SP_CMD_ENGAGE);
        assert_int_equal(r.out.state, SP_STATE_ENGAGING);
        memcpy(&at, &r.ctrl.reference, sizeof at);
        assert_int_equal(sp_setpoints_of(&sp_platform_default, &r.ctrl.prep.limits, &r.ctrl.prep.friction, &at,
                                         r.ctrl.setpoint_ff, sp, &lu, &model),
                         SP_OK);
        for (int i = 0; i < SP_LEGS; ++i) {
            assert_int_equal(r.out.setpoint[i].length, sp[i].length);
            assert_int_equal(r.out.setpoint[i].velocity, sp[i].velocity);
            assert_int_equal(r.out.setpoint[i].force, sp[i].force);
        }
    }
}

/* TARE on the cylinders' estimate: refused outside READY; in READY it
 * averages ft_tare_samples ticks of the estimate into the bias, and force
 * control's wrench is then the estimate less that bias, exactly. */
static void test_cylinder_estimate_tare(void **state)
{
    static rig_t r;
    surface_t s = {0.0, 0.0, 0.0, 0};
    (void)state;
    rig_init(&r);
    r.cfg.wrench_source = SP_WRENCH_CYLINDERS;
    r.cfg.ft_tare_samples = 100u;
    assert_int_equal(sp_ctrl_init(&r.ctrl, &r.cfg), SP_OK);
    for (int n = 0; n < 3; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    force_tick(&r, &s, SP_CMD_TARE);
    assert_int_equal(r.out.cmd_rejected, 1); /* IDLE */
    force_tick(&r, &s, SP_CMD_ENGAGE);
    for (int n = 0; n < 20000 && r.out.state != SP_STATE_READY; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_int_equal(r.out.state, SP_STATE_READY);
    for (int n = 0; n < 200; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_int_equal(r.out.wrench_valid, 1);
    /* force control takes the 20 ms filter's estimate (no bias yet); the
     * reported one is its smoothed value, within the jump thresholds */
    assert_memory_equal(r.out.force_wrench, r.ctrl.wrench.wrench, sizeof r.out.force_wrench);
    for (int k = 0; k < 6; ++k) {
        assert_true(labs((long)r.out.wrench[k] - r.ctrl.wrench.wrench[k]) <= r.cfg.wrench_jump[k < 3 ? 0 : 1]);
    }
    force_tick(&r, &s, SP_CMD_TARE);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (int n = 0; n < 150; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_int_equal(r.ctrl.cyl_tare.tared, 1);
    double biggest = 0.0;
    for (int k = 0; k < 6; ++k) {
        assert_int_equal(r.out.force_wrench[k], r.ctrl.wrench.wrench[k] - r.ctrl.cyl_tare.bias[k]);
        biggest = fmax(biggest, fabs(r.ctrl.wrench.wrench[k] / 256.0));
        /* at rest the estimate is steady: less its mean, within 1 N */
        assert_true(fabs(r.out.force_wrench[k] / 256.0) <= 1.0);
    }
    assert_true(biggest > 10.0); /* the estimate itself is far from 0 here: the tare is what removed it */
    print_message("cylinders' estimate at rest: largest component %.1f N (N m), tared to within 1\n", biggest);
}

static void test_force_hold_and_contact_lost(void **state)
{
    static rig_t r;
    surface_t s;
    (void)state;
    force_rig(&r, &s);
    r.in.cmd.force_mask = 0x04u; /* z */
    r.in.cmd.force_target[2] = -2000 * 256;
    force_tick(&r, &s, SP_CMD_FORCE);
    assert_int_equal(r.out.cmd_rejected, 1); /* not tared yet */
    force_tick(&r, &s, SP_CMD_TARE);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (int n = 0; n < 600; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    r.in.cmd.force_target[2] = -9000 * 256; /* beyond the 8 kN the config allows */
    force_tick(&r, &s, SP_CMD_FORCE);
    assert_int_equal(r.out.cmd_rejected, 1);
    r.in.cmd.force_target[2] = -2000 * 256;
    s.on = 1;
    force_tick(&r, &s, SP_CMD_FORCE);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.force_mode, SP_FORCE_FORCE);
    double worst = 0.0;
    for (int n = 0; n < 4000; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
        assert_int_equal(r.out.faults, 0u);
        if (n >= 3000) {
            double e = fabs(surface_force(&s, f24(r.out.reference.pose.pos[2])) - 2000.0);
            worst = e > worst ? e : worst;
        }
    }
    print_message("force hold on the sensor, 1e6 N/m: worst |F - 2 kN| over the last second %.2f N\n", worst);
    assert_true(worst <= 20.0); /* 1 % */
    assert_int_equal(r.out.contact, 1u);
    /* the surface goes: a named fault within 10 ticks, then the drives hold */
    double z_lost = f24(r.out.reference.pose.pos[2]);
    s.on = 0;
    int ticks = 0;
    while (r.out.state != SP_STATE_FAULT && ticks < 50) {
        force_tick(&r, &s, SP_CMD_NONE);
        ++ticks;
    }
    print_message("surface removed: fault after %d ticks, faults 0x%x\n", ticks, r.out.faults);
    assert_true(ticks <= 10);
    assert_int_equal(r.out.faults, SP_FAULT_CONTACT_LOST);
    assert_int_equal(r.out.drive_mode, SP_DRIVE_HOLD);
    for (int n = 0; n < 100; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_true(fabs(f24(r.out.reference.pose.pos[2]) - z_lost) < 0.005);
    assert_int_equal(r.out.force_mode, SP_FORCE_OFF);
}

static void test_force_release_and_park(void **state)
{
    static rig_t r;
    surface_t s;
    (void)state;
    force_rig(&r, &s);
    double z_home = f24(r.out.reference.pose.pos[2]);
    force_tick(&r, &s, SP_CMD_TARE);
    for (int n = 0; n < 600; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    s.on = 1;
    r.in.cmd.force_mask = 0x04u;
    r.in.cmd.force_target[2] = -1000 * 256;
    force_tick(&r, &s, SP_CMD_FORCE);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (int n = 0; n < 2500; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_near(surface_force(&s, f24(r.out.reference.pose.pos[2])), 1000.0, 10.0, "held");
    force_tick(&r, &s, SP_CMD_POSITION);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (int n = 0; n < 2000 && r.out.force_mode != SP_FORCE_OFF; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_int_equal(r.out.force_mode, SP_FORCE_OFF);
    assert_near(f24(r.out.reference.pose.pos[2]), z_home, 1e-6, "back on the position reference");
    assert_int_equal(r.out.state, SP_STATE_READY);
    /* PARK during force control: released first, then parked */
    r.in.cmd.force_target[2] = -1000 * 256;
    force_tick(&r, &s, SP_CMD_FORCE);
    for (int n = 0; n < 2000; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    force_tick(&r, &s, SP_CMD_PARK);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (int n = 0; n < 30000 && r.out.state != SP_STATE_IDLE; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
        assert_int_equal(r.out.faults, 0u);
    }
    assert_int_equal(r.out.state, SP_STATE_IDLE);
}

/* A silent operator during force control in READY: the fault, and force
 * control lets go back onto the position reference; FORCE is then refused. */
static void test_operator_link_force(void **state)
{
    static rig_t r;
    surface_t s;
    (void)state;
    force_rig(&r, &s);
    double z_home = f24(r.out.reference.pose.pos[2]);
    r.in.operator_heartbeat = 1u;
    force_tick(&r, &s, SP_CMD_TARE);
    r.in.operator_heartbeat = 0u;
    for (int n = 0; n < 600; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    s.on = 1;
    r.in.cmd.force_mask = 0x04u;
    r.in.cmd.force_target[2] = -1000 * 256;
    r.in.operator_heartbeat = 1u;
    force_tick(&r, &s, SP_CMD_FORCE);
    r.in.operator_heartbeat = 0u;
    assert_int_equal(r.out.force_mode, SP_FORCE_FORCE);
    for (uint32_t n = 1; n < r.cfg.operator_timeout_ticks; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
        assert_int_equal(r.out.faults, 0u);
    }
    force_tick(&r, &s, SP_CMD_NONE);
    assert_int_equal(r.out.faults, SP_FAULT_OPERATOR_SILENT);
    assert_int_equal(r.out.force_mode, SP_FORCE_RELEASE);
    for (int n = 0; n < 2000 && r.out.force_mode != SP_FORCE_OFF; ++n) {
        force_tick(&r, &s, SP_CMD_NONE);
    }
    assert_near(f24(r.out.reference.pose.pos[2]), z_home, 1e-6, "let go onto the position reference");
    force_tick(&r, &s, SP_CMD_FORCE);
    assert_int_equal(r.out.cmd_rejected, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_trig_fade_rate_kept),
        cmocka_unit_test(test_trig_full_amplitude),
        cmocka_unit_test(test_trig_high_frequency),
        cmocka_unit_test(test_trig_generator),
        cmocka_unit_test(test_set_wrench_source),
        cmocka_unit_test(test_move_respects_limits),
        cmocka_unit_test(test_move_plan_against_plain),
        cmocka_unit_test(test_move_first_sample),
        cmocka_unit_test(test_trig_first_sample),
        cmocka_unit_test(test_engage_run_park),
        cmocka_unit_test(test_engage_from_just_outside_the_workspace),
        cmocka_unit_test(test_rest_reuses_setpoints),
        cmocka_unit_test(test_divided_feedback),
        cmocka_unit_test(test_divided_feedback_by_two),
        cmocka_unit_test(test_silent_drive_faults_within_3_ticks),
        cmocka_unit_test(test_reset_refused_while_silent),
        cmocka_unit_test(test_reset_clears_drive_faults),
        cmocka_unit_test(test_rejects_out_of_limit_commands),
        cmocka_unit_test(test_move_and_stream),
        cmocka_unit_test(test_stream_target_reachability),
        cmocka_unit_test(test_estimate_matches_full_fk),
        cmocka_unit_test(test_estop_and_divergence),
        cmocka_unit_test(test_estop_closes_blocking_valves),
        cmocka_unit_test(test_estop_controlled_stop),
        cmocka_unit_test(test_estop_immediate_causes),
        cmocka_unit_test(test_fk_failure_faults),
        cmocka_unit_test(test_ft_frame_before_reference),
        cmocka_unit_test(test_cylinder_estimate_tare),
        cmocka_unit_test(test_force_hold_and_contact_lost),
        cmocka_unit_test(test_force_release_and_park),
        cmocka_unit_test(test_operator_link_force),
        cmocka_unit_test(test_operator_link_stop),
        cmocka_unit_test(test_operator_link_park),
    };
    return cmocka_run_group_tests_name("controller", tests, NULL, NULL);
}
