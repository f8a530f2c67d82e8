/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Hydraulic cylinder, servo valve and axis drive models (issue 5, check 3,
 * and the behaviour the closed loop will rely on).
 *
 * 1. Natural frequency: one cylinder moving a mass on the single-axis rig
 *    (RK4 at 10 kHz, the plant's step), valve stepped to 2 % from rest. The acceleration rings at the damped
 *    frequency of the oil columns; the period between its upward zero
 *    crossings (first 6 cycles) matches the textbook
 *    w = sqrt(beta (A_A^2 / V_A + A_B^2 / V_B) / m), computed here from the
 *    config's bore, rod, dead volume, bulk modulus and stroke, within 10 %
 *    (measured: within 1 %), at three strokes and masses.
 * 2. Holding pressures give the force asked for; the velocity command gives
 *    the velocity asked for, under load, within 3 %.
 * 3. End stops: full valve into each end: the cylinder stops within 2 mm
 *    beyond it, pressures stay in [0, pressure_max], and reverses cleanly.
 * 4. Closed loop in the full plant: the six drives follow the paper's surge
 *    (90 mm, 0.5 Hz) for 4 s from setpoints made by the firmware core
 *    (lengths from sp_inverse_kinematics, rates from sp_leg_rates, forces
 *    from sp_inverse_dynamics), starting at the motion's own velocity;
 *    largest leg tracking error below 0.3 mm (the worst is just after each
 *    velocity reversal, where the Coulomb friction flips by 800 N that the
 *    force setpoint does not contain), RMS below 0.1 mm, drives ACTIVE,
 *    no fault bits.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hs/cylinder.h"
#include "hs/kin.h"
#include "hs/plant.h"
#include "hs/rig.h"
#include "assert_near.h"
#include "plant_test_util.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"

#define PI 3.14159265358979323846

static hs_plant_t plant;

/* The textbook formula, from the config values (not from the plant's own
 * helper), for a cylinder at stroke s moving mass m. */
static double textbook_w(double s, double m)
{
    const hs_hydraulic_config_t *h = &hs_config_default.hydraulic;
    double aa = 0.25 * PI * h->piston_diameter * h->piston_diameter;
    double ab = aa - 0.25 * PI * h->rod_diameter * h->rod_diameter;
    double stroke = hs_config_default.leg_length_max - hs_config_default.leg_length_min;
    double va = h->dead_volume + aa * s;
    double vb = h->dead_volume + ab * (stroke - s);
    return sqrt(h->bulk_modulus * (aa * aa / va + ab * ab / vb) / m);
}

static double measured_w(const hs_cyl_params_t *c, double s, double m)
{
    hs_rig_t rig;
    double h = 1e-4, prev = 0.0, t_first = -1.0, t_last = -1.0;
    int crossings = 0;
    assert_int_equal(hs_rig_init(&rig, c, m, 0.0, s), HS_OK);
    for (int k = 0; k < 20000 && crossings < 7; ++k) {
        double v0 = rig.x[HS_RIG_RATE], a;
        assert_int_equal(hs_rig_step(&rig, 0.02, h), HS_OK);
        a = (rig.x[HS_RIG_RATE] - v0) / h;
        if (k > 0 && prev < 0.0 && a >= 0.0) {
            /* linear interpolation of the crossing instant */
            double tc = rig.time - h * a / (a - prev);
            if (crossings == 0) {
                t_first = tc;
            }
            t_last = tc;
            crossings++;
        }
        prev = a;
    }
    assert_int_equal(crossings, 7);
    return 2.0 * PI * 6.0 / (t_last - t_first);
}

static void test_natural_frequency(void **state)
{
    hs_params_t p;
    const double strokes[3] = {0.7, 0.3, 1.1};
    const double masses[3] = {452.0, 1000.0, 250.0};
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    for (int n = 0; n < 3; ++n) {
        double wt = textbook_w(strokes[n], masses[n]);
        double wm = measured_w(&p.cyl[0], strokes[n], masses[n]);
        printf("  stroke %.1f m, mass %4.0f kg: textbook %.2f Hz, step response %.2f Hz (%+.2f %%)\n", strokes[n],
               masses[n], wt / (2 * PI), wm / (2 * PI), 100.0 * (wm / wt - 1.0));
        assert_near(wm / wt, 1.0, 0.10, "stroke %.1f m, mass %.0f kg: step response / textbook frequency", strokes[n],
                    masses[n]);
        assert_near(hs_cyl_natural_frequency(&p.cyl[0], strokes[n], masses[n]) / wt, 1.0, 1e-12,
                    "stroke %.1f m, mass %.0f kg: hs_cyl_natural_frequency / textbook", strokes[n], masses[n]);
    }
}

static void test_holding_pressures(void **state)
{
    hs_params_t p;
    const hs_cyl_params_t *c;
    const double forces[5] = {-60000.0, -1000.0, 0.0, 4500.0, 100000.0};
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    c = &p.cyl[0];
    for (int n = 0; n < 5; ++n) {
        double pa, pb;
        hs_cyl_holding_pressures(c, forces[n], &pa, &pb);
        assert_near(pa * c->area_a - pb * c->area_b, forces[n], 1e-6 * (1.0 + fabs(forces[n])), "holding force %d (N)",
                    n);
        assert_near(pa + pb, c->supply_pressure + c->tank_pressure, 1e-3, "holding force %d: p_A + p_B (Pa)", n);
        assert_true(pa >= c->tank_pressure && pa <= c->supply_pressure);
    }
    /* beyond what the supply can hold: clamped to the extreme pressures */
    {
        double pa, pb;
        hs_cyl_holding_pressures(c, 1e7, &pa, &pb);
        assert_true(pa == c->supply_pressure && pb == c->tank_pressure);
    }
}

static void test_velocity_command(void **state)
{
    hs_params_t p;
    const double speeds[4] = {0.2, -0.2, 0.45, -0.05};
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    for (int n = 0; n < 4; ++n) {
        const hs_cyl_params_t *c = &p.cyl[0];
        hs_rig_t rig;
        double m = 452.0, v = speeds[n];
        double load = m * 9.80665 + c->viscous_friction * v + (v > 0 ? 1.0 : -1.0) * c->coulomb_friction;
        double u = hs_cyl_velocity_command(c, v, load);
        assert_true(fabs(u) > 0.0 && fabs(u) < 1.0);
        assert_int_equal(hs_rig_init(&rig, c, m, 9.80665, 0.3 + (v < 0 ? 0.8 : 0.0)), HS_OK);
        for (int k = 0; k < 5000; ++k) {
            assert_int_equal(hs_rig_step(&rig, u, 1e-4), HS_OK);
        }
        printf("  velocity %+.2f m/s asked (command %+.4f): %+.4f m/s\n", v, u, rig.x[HS_RIG_RATE]);
        assert_near(rig.x[HS_RIG_RATE] / v, 1.0, 0.03, "velocity %+.2f m/s: reached / asked", v);
    }
    assert_true(hs_cyl_velocity_command(&p.cyl[0], 0.0, 1000.0) == 0.0);
    /* more force than the supply gives in that direction: saturated */
    assert_true(hs_cyl_velocity_command(&p.cyl[0], 0.1, 2e5) == 1.0);
    assert_true(hs_cyl_velocity_command(&p.cyl[0], -0.1, -2e5) == -1.0);
}

static void test_end_stops(void **state)
{
    hs_params_t p;
    hs_rig_t rig;
    double s_max = -1.0, s_min = 10.0;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    const hs_cyl_params_t *c = &p.cyl[0];
    assert_int_equal(hs_rig_init(&rig, c, 452.0, 9.80665, 0.7), HS_OK);
    for (int k = 0; k < 60000; ++k) {
        double u = (k < 30000) ? 1.0 : -1.0;
        assert_int_equal(hs_rig_step(&rig, u, 1e-4), HS_OK);
        s_max = fmax(s_max, rig.x[HS_RIG_STROKE]);
        s_min = fmin(s_min, rig.x[HS_RIG_STROKE]);
        for (int j = 0; j < 2; ++j) {
            double pr = rig.x[HS_RIG_CYL + j];
            assert_true(pr >= 0.0 && pr <= c->pressure_max);
        }
        if (k == 29999) {
            /* stalled at the top: full supply on A, tank on B */
            assert_near(rig.x[HS_RIG_RATE], 0.0, 1e-4, "stalled at the top: rate (m/s)");
            assert_near(rig.x[HS_RIG_CYL], c->supply_pressure, 0.01e6, "stalled at the top: p_A (Pa)");
            assert_near(rig.x[HS_RIG_CYL + 1], c->tank_pressure, 0.01e6, "stalled at the top: p_B (Pa)");
        }
    }
    printf("  full valve into the ends: stroke %.4f .. %.4f m (stroke %.2f m)\n", s_min, s_max, c->stroke);
    assert_true(s_max > c->stroke && s_max < c->stroke + 0.002);
    assert_true(s_min < 0.0 && s_min > -0.002);
    assert_near(rig.x[HS_RIG_RATE], 0.0, 1e-4, "stalled at the bottom: rate (m/s)");
}

static void test_closed_loop_surge(void **state)
{
    hs_params_t p;
    const pt_sines_t surge = {{0.09, 0, 0, 0, 0, 0}, {0.5, 0.5, 0.5, 0.5, 0.5, 0.5}, {0}};
    double pose[6], vel[6], acc[6], omega[3], err = 0.0, sq = 0.0;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_motion(p.home, &surge, 0.0, pose, vel, acc);
    assert_int_equal(hs_plant_init(&plant, &p, pose), HS_OK);
    hs_body_rates(&pose[3], &vel[3], omega);
    assert_int_equal(hs_plant_set_twist(&plant, vel, omega), HS_OK);
    for (int n = 0; n < 4000; ++n) {
        sp_motion_t mo;
        sp_ik_t ik;
        sp_q8_t fq[SP_LEGS];
        sp_q24_t rate[SP_LEGS];
        hs_state_t st;
        pt_motion(p.home, &surge, n * 1e-3, pose, vel, acc);
        pt_to_sp_motion(pose, vel, acc, &mo);
        assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &mo.pose, &ik), SP_OK);
        assert_int_equal(sp_leg_rates(&ik, mo.vel, mo.rpy_rate, rate), SP_OK);
        assert_int_equal(sp_inverse_dynamics(&sp_platform_default, &mo, &ik, NULL, fq), SP_OK);
        for (int i = 0; i < HS_LEGS; ++i) {
            assert_int_equal(hs_plant_set_setpoint(&plant, i, ik.length[i] / 16777216.0, rate[i] / 16777216.0,
                                                   ref_f8(fq[i]), HS_REQ_ACTIVE),
                             HS_OK);
        }
        assert_int_equal(hs_plant_step(&plant, 1e-3), HS_OK);
        /* compare with where the legs should be at the end of the cycle */
        pt_motion(p.home, &surge, (n + 1) * 1e-3, pose, vel, acc);
        {
            double want[HS_LEGS];
            hs_leg_lengths(&p, pose, want);
            hs_plant_state(&plant, &st);
            for (int i = 0; i < HS_LEGS; ++i) {
                err = fmax(err, fabs(st.length[i] - want[i]));
                sq += (st.length[i] - want[i]) * (st.length[i] - want[i]);
            }
        }
    }
    sq = sqrt(sq / (4000.0 * HS_LEGS));
    printf("  drives following the paper's surge for 4 s: leg error largest %.1f um, RMS %.1f um\n", err * 1e6,
           sq * 1e6);
    assert_true(err < 3e-4);
    assert_true(sq < 1e-4);
    for (int i = 0; i < HS_LEGS; ++i) {
        hs_feedback_t fb;
        hs_plant_feedback(&plant, i, &fb);
        assert_int_equal(fb.state, HS_DRIVE_ACTIVE);
        assert_int_equal(fb.faults, 0u);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_natural_frequency), cmocka_unit_test(test_holding_pressures),
        cmocka_unit_test(test_velocity_command),  cmocka_unit_test(test_end_stops),
        cmocka_unit_test(test_closed_loop_surge),
    };
    return cmocka_run_group_tests_name("plant_hydraulics", tests, NULL, NULL);
}
