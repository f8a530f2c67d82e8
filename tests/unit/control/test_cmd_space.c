/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The command space, property-based with a seeded generator
 * (docs/reference/commands.md): random RUN_TRIG and MOVE_TO commands over
 * and beyond their whole ranges, each from READY at home, through the
 * controller with an ideal plant (the legs follow their setpoints).
 *  1. No accepted command makes a later tick fault: the motion runs to
 *     its peaks and back (STOP, the fade-out) with no fault bit (no limit,
 *     no saturated computation: SP_FAULT_REFERENCE and SP_FAULT_COMPUTE are
 *     how the tick reports either), every setpoint's rate and force inside
 *     the limits.
 *  2. No command inside the documented ranges is refused, none outside
 *     them is taken: the ranges evaluated here in float64, away from their
 *     boundaries by 0.1 % (the fixed point's rounding decides within).
 * Each refusal carries its reason (SP_REFUSE_*).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "sp/control/controller.h"
#include "test_util.h"

#define Q24 16777216.0
#define MARGIN 1e-3

typedef struct {
    sp_ctrl_config_t cfg;
    sp_ctrl_t ctrl;
    sp_ctrl_input_t in;
    sp_ctrl_output_t out;
    sp_q24_t plant[SP_LEGS];
} rig_t;

static const sp_platform_t *P = &sp_platform_default;
static rig_t ready; /* engaged at home, READY: every trial starts from a copy */
static rig_t r;
static uint64_t ticks_run;

/* One tick; 0 when the tick reported a fault or a setpoint beyond the limits. */
static int tick(rig_t *g, sp_cmd_type_t cmd)
{
    for (int i = 0; i < SP_LEGS; ++i) {
        g->in.drive[i].fresh = 1u;
        g->in.drive[i].length = g->plant[i];
    }
    g->in.cmd.type = cmd;
    assert_int_equal(sp_ctrl_step(&g->cfg, &g->ctrl, &g->in, &g->out), SP_OK);
    g->in.cmd.type = SP_CMD_NONE;
    ++ticks_run;
    int ok = g->out.faults == 0u;
    for (int i = 0; i < SP_LEGS; ++i) {
        if (g->out.drive_mode == SP_DRIVE_ACTIVE) {
            g->plant[i] = g->out.setpoint[i].length;
        }
        ok &= (g->out.setpoint[i].velocity <= g->ctrl.prep.limits.rate_max &&
               -g->out.setpoint[i].velocity <= g->ctrl.prep.limits.rate_max &&
               g->out.setpoint[i].force <= g->ctrl.prep.limits.force_max &&
               -g->out.setpoint[i].force <= g->ctrl.prep.limits.force_max)
                  ? 1
                  : 0;
    }
    return ok;
}

static int setup(void **state)
{
    (void)state;
    sp_ik_t ik;
    memset(&ready, 0, sizeof ready);
    assert_int_equal(sp_ctrl_default_config(&ready.cfg, P), SP_OK);
    assert_int_equal(sp_ctrl_init(&ready.ctrl, &ready.cfg), SP_OK);
    assert_int_equal(sp_inverse_kinematics(P, &P->park, &ik), SP_OK);
    memcpy(ready.plant, ik.length, sizeof ready.plant);
    tick(&ready, SP_CMD_NONE);
    tick(&ready, SP_CMD_ENGAGE);
    for (int n = 0; n < 20000 && ready.out.state != SP_STATE_READY; ++n) {
        tick(&ready, SP_CMD_NONE);
    }
    assert_int_equal(ready.out.state, SP_STATE_READY);
    printf("limits: leg rate %.3f m/s, joints' largest radius %.3f m; acceleration capacity %.1f %.1f %.1f m/s^2 %.1f "
           "%.1f "
           "%.1f rad/s^2\n",
           ready.ctrl.prep.limits.rate_max / Q24, ready.ctrl.prep.arm_max / Q24, ready.ctrl.prep.acc_cap[0] / Q24,
           ready.ctrl.prep.acc_cap[1] / Q24, ready.ctrl.prep.acc_cap[2] / Q24, ready.ctrl.prep.acc_cap[3] / Q24,
           ready.ctrl.prep.acc_cap[4] / Q24, ready.ctrl.prep.acc_cap[5] / Q24);
    for (int n = 0; n < 20; ++n) { /* the legs' terms at rest complete */
        tick(&ready, SP_CMD_NONE);
    }
    return 0;
}

static double log_uniform(uint64_t *rng, double lo, double hi)
{
    return exp(tu_uniform(rng, log(lo), log(hi)));
}

/* The documented RUN_TRIG ranges (docs/reference/commands.md) at a
 * relative margin m: 1 inside (every condition holds with m to spare),
 * -1 outside (one fails by m), 0 within m of a boundary. */
static int trig_in_range(const rig_t *g, unsigned axis, double amp, double f, double fade)
{
    const sp_limits_t *lim = &g->ctrl.prep.limits;
    double a = fabs(amp), w = 2.0 * 3.14159265358979323846 * f, rr = 1.0 / fade;
    double reach = (axis < 3u) ? 1.0 : g->ctrl.prep.arm_max / Q24;
    double q[6]; /* each condition as value / bound: <= 1 inside */
    int n = 0;
    if (axis >= 6u || f <= 0.0) {
        return -1;
    }
    q[n++] = f / 10.0;
    q[n++] = a / 1.0;
    q[n++] = 0.1 / fade;
    q[n++] = fade / 60.0;
    q[n++] = a * sqrt(w * w + pow(1.875 * rr, 2.0)) * reach / (lim->rate_max / Q24);
    q[n++] = a * (w * w + 4.0 * w * rr + 6.0 * rr * rr) / (g->ctrl.prep.acc_cap[axis] / Q24);
    int in = 1, out = 0;
    for (int k = 0; k < n; ++k) {
        in &= q[k] <= 1.0 - MARGIN;
        out |= q[k] >= 1.0 + MARGIN;
    }
    if (in) { /* and both ends reachable, with the margin */
        for (int s = -1; s <= 1; s += 2) {
            sp_pose_t end = P->home, far = P->home;
            double v = s * amp;
            int32_t *e = (axis < 3u) ? &end.pos[axis] : &end.rpy[axis - 3u];
            int32_t *x = (axis < 3u) ? &far.pos[axis] : &far.rpy[axis - 3u];
            *e += (int32_t)llround(v * Q24);
            *x += (int32_t)llround(v * (1.0 + MARGIN) * Q24 + (v > 0 ? 200.0 : -200.0));
            if (!sp_limits_pose_reachable(lim, P, &end, NULL)) {
                return -1;
            }
            in &= sp_limits_pose_reachable(lim, P, &far, NULL);
        }
    }
    return in ? 1 : (out ? -1 : 0);
}

static void test_trig_command_space(void **state)
{
    (void)state;
    uint64_t rng = 2026u;
    int accepted = 0, refused = 0, ran = 0, inside = 0, outside = 0;
    int reasons[8] = {0};
    for (int trial = 0; trial < 3000; ++trial) {
        unsigned axis = (unsigned)(tu_next(&rng) % 7u); /* 6: no axis */
        double amp = log_uniform(&rng, 1e-5, 1.5) * ((tu_next(&rng) & 1u) ? 1.0 : -1.0);
        double f = (tu_next(&rng) % 50u == 0u) ? -0.5 : log_uniform(&rng, 0.005, 15.0);
        double fade = (tu_next(&rng) % 40u == 0u) ? 0.0 : log_uniform(&rng, 0.02, 80.0);
        r = ready;
        r.in.cmd.axis = (sp_axis_t)axis;
        r.in.cmd.amplitude = (int32_t)llround(amp * Q24);
        r.in.cmd.frequency = (int32_t)llround(f * Q24);
        r.in.cmd.fade_ticks = (uint32_t)llround(fade * 1000.0);
        double fade_used = (r.in.cmd.fade_ticks == 0u) ? r.cfg.fade_ticks * 1e-3 : r.in.cmd.fade_ticks * 1e-3;
        int range = trig_in_range(&r, axis, r.in.cmd.amplitude / Q24, r.in.cmd.frequency / Q24, fade_used);
        assert_true(tick(&r, SP_CMD_RUN_TRIG));
        int took = r.out.state == SP_STATE_RUNNING;
        assert_int_equal(took, !r.out.cmd_rejected);
        assert_int_equal(r.out.refuse_reason == SP_REFUSE_NONE, took);
        reasons[r.out.refuse_reason & 7u]++;
        if (range == 1) {
            ++inside;
            if (!took) {
                fail_msg("refused inside the ranges: axis %u A %.6g f %.6g fade %.3g (reason %u)", axis, amp, f,
                         fade_used, r.out.refuse_reason);
            }
        } else if (range == -1) {
            ++outside;
            if (took) {
                fail_msg("taken outside the ranges: axis %u A %.6g f %.6g fade %.3g", axis, amp, f, fade_used);
            }
        }
        if (!took) {
            ++refused;
            continue;
        }
        ++accepted;
        /* run the accepted ones whose fades are short enough for the test's time: through the fade-in
         * and at least one period at full amplitude, STOP, the fade-out */
        if (fade_used > 1.5 || f < 0.5 || ran >= 150) {
            continue;
        }
        ++ran;
        int n = (int)(fade_used * 1000.0 + 1000.0 / f) + 10;
        for (int k = 0; k < n; ++k) {
            if (!tick(&r, SP_CMD_NONE)) {
                fail_msg("accepted RUN_TRIG axis %u A %.6g f %.6g fade %.3g faulted (0x%x) %d ticks in", axis, amp, f,
                         fade_used, r.out.faults, k + 1);
            }
        }
        assert_true(tick(&r, SP_CMD_STOP));
        for (int k = 0; k < 62000 && r.out.state != SP_STATE_READY; ++k) {
            if (!tick(&r, SP_CMD_NONE)) {
                fail_msg("accepted RUN_TRIG axis %u A %.6g f %.6g fade %.3g faulted (0x%x) in its fade-out", axis, amp,
                         f, fade_used, r.out.faults);
            }
        }
        assert_int_equal(r.out.state, SP_STATE_READY);
    }
    printf("RUN_TRIG space: %d accepted (%d run to the end), %d refused (range %d, reach %d, rate %d, force %d, "
           "state %d); %d inside the ranges, %d outside\n",
           accepted, ran, refused, reasons[SP_REFUSE_RANGE], reasons[SP_REFUSE_REACH], reasons[SP_REFUSE_RATE],
           reasons[SP_REFUSE_FORCE], reasons[SP_REFUSE_STATE], inside, outside);
    assert_true(ran >= 100 && inside >= 300 && outside >= 1000);
}

/* MOVE_TO: targets over the workspace box and 20 % beyond it on every
 * axis; the documented range: the target and the straight path's points
 * (checked here at 64 of them) inside the workspace and the strokes. */
static void test_move_command_space(void **state)
{
    (void)state;
    uint64_t rng = 60204u;
    int accepted = 0, refused = 0, inside = 0, outside = 0;
    const sp_limits_t *lim = &ready.ctrl.prep.limits;
    for (int trial = 0; trial < 40; ++trial) {
        sp_pose_t to;
        for (unsigned k = 0u; k < 6u; ++k) {
            double lo = lim->ws_lo[k] / Q24, hi = lim->ws_hi[k] / Q24, span = hi - lo;
            double v = tu_uniform(&rng, lo - 0.2 * span, hi + 0.2 * span);
            if (k < 3u) {
                to.pos[k] = (int32_t)llround(v * Q24);
            } else {
                to.rpy[k - 3u] = (int32_t)llround(v * Q24);
            }
        }
        int path_ok = 1;
        for (int s = 1; s <= 64 && path_ok; ++s) {
            sp_pose_t m;
            for (unsigned k = 0u; k < 3u; ++k) {
                m.pos[k] = P->home.pos[k] + (int32_t)(((int64_t)to.pos[k] - P->home.pos[k]) * s / 64);
                m.rpy[k] = P->home.rpy[k] + (int32_t)(((int64_t)to.rpy[k] - P->home.rpy[k]) * s / 64);
            }
            path_ok = sp_limits_pose_reachable(lim, P, &m, NULL);
        }
        r = ready;
        r.in.cmd.target = to;
        assert_true(tick(&r, SP_CMD_MOVE_TO));
        int took = r.out.state == SP_STATE_RUNNING;
        inside += path_ok;
        outside += !sp_limits_pose_reachable(lim, P, &to, NULL);
        if (path_ok && !took) {
            fail_msg("MOVE_TO inside the ranges refused (reason %u)", r.out.refuse_reason);
        }
        if (!took) {
            assert_true(r.out.refuse_reason == SP_REFUSE_REACH);
            ++refused;
            continue;
        }
        ++accepted;
        for (int k = 0; k < 20000 && r.out.state == SP_STATE_RUNNING; ++k) {
            if (!tick(&r, SP_CMD_NONE)) {
                fail_msg("accepted MOVE_TO faulted (0x%x) %d ticks in", r.out.faults, k + 1);
            }
        }
        assert_int_equal(r.out.state, SP_STATE_READY);
    }
    printf("MOVE_TO space: %d accepted and run, %d refused; %d inside the ranges, %d outside\n", accepted, refused,
           inside, outside);
    assert_true(accepted >= 5 && refused >= 5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_trig_command_space),
        cmocka_unit_test(test_move_command_space),
    };
    int rc = cmocka_run_group_tests(tests, setup, NULL);
    printf("command space: %llu ticks run\n", (unsigned long long)ticks_run);
    return rc;
}
