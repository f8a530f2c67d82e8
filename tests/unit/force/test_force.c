/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of force control over the position reference (sp/force/force.h):
 * the modes and their refusals, the bounds (deflection, workspace), and a
 * closed loop on an ideal servo with a surface under the tool: hold,
 * contact lost, excessive force and retract, hand guiding.
 *
 * Tolerances: OFF passes the reference bit for bit; a hold of 2 kN on
 * 1e6 N/m within 1 % after 1 s; contact loss reported within 10 ticks of
 * the surface's removal; the retract ends within 1 um of the position
 * reference; hand guiding at F / D within 2 %; no reference outside
 * the workspace box or the deflection limit.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "assert_near.h"
#include "sp/force/force.h"
#include "sp/motion/trajectory.h"
#include "sp/estimation/wrench.h"

#define Q24 16777216.0
#define Q8 256.0

typedef struct {
    sp_force_config_t cfg;
    sp_force_t f;
    sp_limits_t lim;
    sp_motion_t pos_ref;
} rig_t;

static void rig_init(rig_t *r)
{
    sp_q30_t alpha;
    assert_int_equal(sp_wrench_alpha(80 << 24, 1000u, &alpha), SP_OK);
    assert_int_equal(sp_force_default_config(&r->cfg, alpha, 1000u), SP_OK);
    assert_int_equal(sp_force_init(&r->cfg, &r->f), SP_OK);
    assert_int_equal(sp_limits_prepare(&r->lim, &sp_platform_default, SP_Q24_MILLI(10)), SP_OK);
    sp_motion_at_rest(&r->pos_ref, &sp_platform_default.home);
}

static void test_modes_and_refusals(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r);
    sp_q8_t t[SP_AXES] = {0, 0, -2000 * 256, 0, 0, 0};
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 0u, t), SP_E_ARG); /* empty mask */
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_RELEASE, 4u, t), SP_E_ARG);
    sp_q8_t big[SP_AXES] = {0, 0, -9000 * 256, 0, 0, 0};
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, big), SP_E_RANGE);
    sp_q8_t torque[SP_AXES] = {0, 0, 0, 1001 * 256, 0, 0};
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, torque), SP_E_RANGE);
    assert_int_equal(r.f.mode, SP_FORCE_OFF);
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, t), SP_OK);
    t[2] = -1500 * 256;
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, t), SP_OK); /* a target update */
    assert_int_equal(r.f.target[2], -1500 * 256);
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 5u, t), SP_E_ARG);    /* another mask */
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_GUIDE, 4u, NULL), SP_E_ARG); /* leave first */
    assert_int_equal(sp_force_release(&r.f), SP_OK);
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, t), SP_E_BUSY);
    /* OFF passes the reference as it is */
    rig_init(&r);
    r.pos_ref.vel[0] = 12345;
    sp_motion_t out;
    uint32_t ev;
    sp_q8_t w[SP_AXES] = {100, 200, 300, 4, 5, 6};
    assert_int_equal(sp_force_step(&r.cfg, &r.f, &r.lim, &r.pos_ref, w, NULL, &out, &ev), SP_OK);
    assert_memory_equal(&out, &r.pos_ref, sizeof out);
    assert_int_equal(ev, 0u);
}

/* An ideal servo (the pose is the reference of the last tick) on a surface
 * normal to z at z_s with stiffness k: the world pushes up when the tool
 * goes below it. The wrench passes the 80 Hz four-section filter. */
typedef struct {
    int32_t sec[SP_WRENCH_SECTIONS][SP_AXES];
    int primed;
} filt_t;

static void filt(filt_t *fl, sp_q30_t alpha, const double w[SP_AXES], sp_q8_t out[SP_AXES])
{
    for (unsigned k = 0; k < SP_AXES; ++k) {
        int32_t x = (int32_t)lround(w[k] * Q8);
        for (unsigned s = 0; s < SP_WRENCH_SECTIONS; ++s) {
            int32_t y = fl->sec[s][k];
            fl->sec[s][k] = fl->primed ? y + (int32_t)(((int64_t)alpha * (x - y) + (1 << 29)) >> 30) : x;
            x = fl->sec[s][k];
        }
        out[k] = x;
    }
    fl->primed = 1;
}

static void test_hold_lost_excess(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r);
    const double z0 = r.pos_ref.pose.pos[2] / Q24, z_s = z0 - 0.002, k = 1e6;
    sp_q8_t t[SP_AXES] = {0, 0, -2000 * 256, 0, 0, 0}; /* push down with 2 kN */
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, t), SP_OK);
    filt_t fl;
    memset(&fl, 0, sizeof fl);
    sp_motion_t out = r.pos_ref;
    double f_true = 0.0, extra = 0.0;
    int removed = 0, lost_at = -1, retracted_at = -1;
    for (int n = 0; n < 6000; ++n) {
        double z = out.pose.pos[2] / Q24;
        f_true = (!removed && z < z_s) ? k * (z_s - z) : 0.0;
        double w[SP_AXES] = {0, 0, f_true + extra, 0, 0, 0};
        sp_q8_t wf[SP_AXES];
        filt(&fl, r.cfg.admit.filter_alpha, w, wf);
        uint32_t ev;
        sp_pose_t meas = out.pose;
        assert_int_equal(sp_force_step(&r.cfg, &r.f, &r.lim, &r.pos_ref, wf, &meas, &out, &ev), SP_OK);
        assert_true(out.pose.pos[2] >= r.pos_ref.pose.pos[2] - r.cfg.deflection[2]);
        if (n == 3000) {
            assert_near(f_true, 2000.0, 20.0, "held force after 3 s");
            removed = 1;
        }
        if ((ev & SP_CONTACT_LOST) != 0u) {
            lost_at = n;
        }
        if ((ev & SP_FORCE_RETRACTED) != 0u) {
            retracted_at = n;
        }
        if (n == 3500) {
            /* lost -> HOLD: at rest where it stopped */
            assert_int_equal(r.f.mode, SP_FORCE_HOLD);
            assert_true(out.vel[2] == 0);
            /* restart force control from scratch with the surface back, then an excessive push */
            r.f.mode = SP_FORCE_RELEASE;
        }
        if (n == 4500) {
            assert_int_equal(r.f.mode, SP_FORCE_OFF);
            removed = 0;
            assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_FORCE, 4u, t), SP_OK);
        }
        if (n == 5500) {
            extra = 15000.0; /* something pushes up far beyond the excess limit */
        }
    }
    assert_true(lost_at > 3000 && lost_at - 3000 <= 10);
    assert_true(retracted_at > 5500);
    assert_int_equal(r.f.mode, SP_FORCE_OFF);
    assert_near(out.pose.pos[2] / Q24, z0, 1e-6, "retracted onto the position reference");
}

static void test_guide_and_workspace_bound(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r);
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x3Fu, NULL), SP_OK);
    /* the position reference 10 mm inside the workspace's +x edge */
    r.pos_ref.pose.pos[0] = r.lim.ws_hi[0] - SP_Q24_MILLI(10);
    sp_q8_t w[SP_AXES] = {50 * 256, 0, 0, 0, 0, 0}; /* 50 N: 0.02 m/s at D = 2500 N s/m */
    sp_motion_t out;
    uint32_t ev;
    double v_mid = 0.0;
    for (int n = 0; n < 2000; ++n) {
        assert_int_equal(sp_force_step(&r.cfg, &r.f, &r.lim, &r.pos_ref, w, NULL, &out, &ev), SP_OK);
        assert_true(out.pose.pos[0] <= r.lim.ws_hi[0]);
        if (n == 100) {
            v_mid = out.vel[0] / Q24;
        }
    }
    assert_near(v_mid, 0.02, 0.02 * 0.02, "guided speed (M / D = 8 ms: settled at 0.1 s)");
    assert_int_equal(out.pose.pos[0], r.lim.ws_hi[0] - SP_FORCE_BOUND_MARGIN); /* stopped inside, by the margin */
    assert_int_equal(out.vel[0], 0);
}

/* New admittance parameters: taken in OFF (GUIDE's damping on x: 50 N
 * then moves it at 50 / 1000 = 0.05 m/s), refused while force control
 * runs and for bad values, the config unchanged then. */
static void test_set_params(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r);
    const sp_force_config_t before = r.cfg;
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x01u, 0, 1000, 0), SP_E_ARG); /* mass 0 */
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x00u, 10 * SP_Q16_ONE, 1000, 0), SP_E_ARG);
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_HOLD, 0x01u, 10 * SP_Q16_ONE, 1000, 0), SP_E_ARG);
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x01u, 10 * SP_Q16_ONE, 0, 0), SP_E_ARG);
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x01u, 10 * SP_Q16_ONE, 1000, -1), SP_E_ARG);
    assert_memory_equal(&r.cfg, &before, sizeof before);
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x01u, 10 * SP_Q16_ONE, 1000, 0), SP_OK);
    assert_int_equal(r.cfg.guide_damping[0], 1000);
    assert_int_equal(r.cfg.admit.axis[0].mass, 10 * SP_Q16_ONE);
    assert_int_equal(r.cfg.guide_damping[1], before.guide_damping[1]);
    assert_int_equal(sp_force_start(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x01u, NULL), SP_OK);
    sp_q8_t w[SP_AXES] = {50 * 256, 0, 0, 0, 0, 0};
    sp_motion_t out;
    uint32_t ev;
    for (int n = 0; n <= 100; ++n) {
        assert_int_equal(sp_force_step(&r.cfg, &r.f, &r.lim, &r.pos_ref, w, NULL, &out, &ev), SP_OK);
    }
    assert_near(out.vel[0] / Q24, 0.05, 0.05 * 0.02, "guided speed with the new damping");
    const sp_force_config_t during = r.cfg;
    assert_int_equal(sp_force_set_params(&r.cfg, &r.f, SP_FORCE_GUIDE, 0x01u, 10 * SP_Q16_ONE, 5000, 0), SP_E_BUSY);
    assert_memory_equal(&r.cfg, &during, sizeof during);
    assert_int_equal(r.f.mode, SP_FORCE_GUIDE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_modes_and_refusals),
        cmocka_unit_test(test_hold_lost_excess),
        cmocka_unit_test(test_guide_and_workspace_bound),
        cmocka_unit_test(test_set_params),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
