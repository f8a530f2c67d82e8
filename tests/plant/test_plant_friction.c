/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Cylinder friction with stiction (issue 14; hs/cylinder.h, docs/explanation/plant.md
 * "Friction"): LuGre bristles with a Stribeck curve, default config
 * (F_c 400 N, F_s 600 N, v_s 5 mm/s, c_v 3000 N s/m, sigma_0 = F_c / 0.1 mm,
 * sigma_1 critical for a sixth of the moving mass).
 *
 * 1. Rest after motion (single-axis rig, the plant's RK4 at 10 kHz, no
 *    leakage): the valve drives the piston out at 20 mm/s for 0.1 s, then
 *    closes over 0.5 s (a drive coming to a stop). With the bristles the piston comes to rest (velocity below
 *    1 um/s, moved less than 0.01 um over the last second) while its
 *    pressures push with more than 100 N that no load balances: the seals
 *    hold it (friction = pressure force within 0.01 N). The memoryless
 *    friction of before, same run: the pressure force decays below 5 N.
 * 2. Break-away (rig with a soft oil column, 5 m^3 dead volume, so that the
 *    seals carry a load: oil stiffness 0.5 % of sigma_0): an
 *    external force ramped to 0.9 F_s and held 1 s is held with a bounded
 *    presliding displacement (above F / sigma_0, below 1.25 times LuGre's
 *    quasi-static -F_s/sigma_0 ln(1 - F/F_s), which the ramp's speed exceeds a
 *    little by lowering g(v); under 0.5 mm;
 *    velocity below 1 um/s, no motion over the last 0.5 s beyond 0.01 um)
 *    and the pressure force changes by less than 2 % of it; ramped on to
 *    1.1 F_s the cylinder slips (more than 1 mm, velocity above v_s).
 * 3. Steady sliding: the bristle equation integrated at a constant stroke
 *    rate (RK4, 10 kHz) settles to the Stribeck formula
 *    c_v v + sign(v) (F_c + (F_s - F_c) exp(-(v/v_s)^2)) within 1e-6 N at
 *    12 rates from 0.2 mm/s to 0.5 m/s, both directions; and the rig driven
 *    at a constant valve opening (about 20 mm/s) slides with the friction of
 *    the formula at its own speed within 0.5 N.
 * 4. Energy: hydraulic plant, valves closed, no leakage, stiction on, a
 *    kick: kinetic + gravity + oil + springs (bristles included) never
 *    rises by more than 1e-9 of the kick in a cycle and ends below a tenth
 *    of it (friction dissipates).
 * 5. Closed loop: the six drives hold the home pose and follow a slow 1 mm,
 *    0.2 Hz sine on every leg (stick-slip prone) for 10 s: state finite, leg
 *    error below 0.3 mm, no fault bits.
 * 6. hs_params_check: bristles need F_c > 0 and sigma_1 within the
 *    dissipation bound; F_s >= F_c.
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

#define H 1e-4 /* the plant's substep */
#define DT 1e-3

static hs_plant_t plant;

static double stribeck(const hs_cyl_params_t *c, double v)
{
    double r = v / c->stribeck_velocity;
    double g = c->coulomb_friction + (c->breakaway_friction - c->coulomb_friction) * exp(-r * r);
    return c->viscous_friction * v + (v > 0.0 ? g : -g);
}

static double pressure_force(const hs_rig_t *rig)
{
    return rig->x[HS_RIG_CYL] * rig->cyl.area_a - rig->x[HS_RIG_CYL + 1] * rig->cyl.area_b;
}

static void test_default_parameters(void **state)
{
    hs_params_t p;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        const hs_cyl_params_t *c = &p.cyl[i];
        assert_near(c->coulomb_friction, 400.0, 0.0, "F_c (N)");
        assert_near(c->breakaway_friction, 600.0, 0.0, "F_s (N)");
        assert_near(c->stribeck_velocity, 5e-3, 0.0, "v_s (m/s)");
        assert_near(c->bristle_stiffness, 4.0e6, 1e-6, "sigma_0 (N/m)");
        assert_true(c->bristle_damping > 0.0 && 0.42889 * c->bristle_damping * c->stribeck_velocity <= 1600.0);
        if (i == 0) {
            printf("  defaults: sigma_0 %.3g N/m, sigma_1 %.4g N s/m, F_c %.0f N, F_s %.0f N, v_s %.1f mm/s\n",
                   c->bristle_stiffness, c->bristle_damping, c->coulomb_friction, c->breakaway_friction,
                   c->stribeck_velocity * 1e3);
        }
    }
}

/* 1. */
static double rest_after_motion(const hs_cyl_params_t *c0, double *drift, double *speed, double *friction)
{
    hs_rig_t rig;
    hs_cyl_params_t c = *c0;
    hs_cyl_eval_t ev;
    double u, s_mark = 0.0;
    c.leakage = 0.0;
    assert_int_equal(hs_rig_init(&rig, &c, 452.0, 0.0, 0.7), HS_OK);
    u = hs_cyl_velocity_command(&c, 0.02, 0.0);
    for (int n = 0; n < 6000; ++n) { /* 0.1 s at 20 mm/s, then the valve closes over 0.5 s */
        assert_int_equal(hs_rig_step(&rig, u * fmin(1.0, (6000.0 - n) / 5000.0), H), HS_OK);
    }
    for (int n = 0; n < 40000; ++n) {
        assert_int_equal(hs_rig_step(&rig, 0.0, H), HS_OK);
        if (n == 30000) {
            s_mark = rig.x[HS_RIG_STROKE];
        }
    }
    hs_rig_eval(&rig, 0.0, &ev);
    *drift = fabs(rig.x[HS_RIG_STROKE] - s_mark);
    *speed = fabs(rig.x[HS_RIG_RATE]);
    *friction = ev.friction;
    return pressure_force(&rig);
}

static void test_rest_after_motion_hides_force(void **state)
{
    hs_params_t p;
    double drift, speed, fr, fp;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    fp = rest_after_motion(&p.cyl[0], &drift, &speed, &fr);
    printf("  stiction, at rest after 20 mm/s: pressure force %.2f N, friction %.2f N, speed %.2e m/s, "
           "moved %.2e m in the last 1 s\n",
           fp, fr, speed, drift);
    assert_true(fabs(fp) > 100.0);
    assert_true(fabs(fp) < p.cyl[0].breakaway_friction);
    assert_near(fr, fp, 0.01, "the seals hold what the pressures push (N)");
    assert_true(speed < 1e-6);
    assert_true(drift < 1e-8);

    pt_memoryless_friction(&p);
    fp = rest_after_motion(&p.cyl[0], &drift, &speed, &fr);
    printf("  memoryless friction, same run: pressure force %.2f N, speed %.2e m/s\n", fp, speed);
    assert_true(fabs(fp) < 5.0);
}

/* 2. */
static void test_break_away(void **state)
{
    hs_params_t p;
    hs_rig_t rig;
    hs_cyl_params_t c;
    hs_cyl_eval_t ev;
    double fs, s0, fp0, f, s_mark = 0.0, disp, want, worst_v = 0.0;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    c = p.cyl[0];
    c.leakage = 0.0;
    c.dead_volume_a = c.dead_volume_b = 5.0; /* a soft oil column: the seals carry the load */
    fs = c.breakaway_friction;
    assert_int_equal(hs_rig_init(&rig, &c, 452.0, 0.0, 0.7), HS_OK);
    s0 = rig.x[HS_RIG_STROKE];
    fp0 = pressure_force(&rig);
    /* ramp to 0.9 F_s in 0.5 s, hold 1 s */
    for (int n = 0; n < 15000; ++n) {
        rig.ext_force = 0.9 * fs * fmin(1.0, (double)n / 5000.0);
        assert_int_equal(hs_rig_step(&rig, 0.0, H), HS_OK);
        if (n == 10000) {
            s_mark = rig.x[HS_RIG_STROKE];
        }
    }
    f = rig.ext_force;
    disp = rig.x[HS_RIG_STROKE] - s0;
    hs_rig_eval(&rig, 0.0, &ev);
    printf("  0.9 F_s = %.0f N held: displacement %.2f um (-F_s/sigma_0 ln(1 - F/F_s) = %.2f um), speed %.2e m/s, last "
           "0.5 s %.2e m, "
           "pressure force changed %.2f N, friction %.2f N\n",
           f, disp * 1e6, -fs / c.bristle_stiffness * log(1.0 - f / fs) * 1e6, fabs(rig.x[HS_RIG_RATE]),
           fabs(rig.x[HS_RIG_STROKE] - s_mark), pressure_force(&rig) - fp0, ev.friction);
    /* LuGre's presliding under a slowly rising force: dz/dx = 1 - z / z_s with z_s = F_s / sigma_0 */
    want = -fs / c.bristle_stiffness * log(1.0 - f / fs);
    assert_true(disp > f / c.bristle_stiffness && disp < 1.25 * want);
    assert_true(disp < 0.5e-3);
    assert_true(fabs(rig.x[HS_RIG_RATE]) < 1e-6);
    assert_true(fabs(rig.x[HS_RIG_STROKE] - s_mark) < 1e-8);
    assert_true(fabs(pressure_force(&rig) - fp0) < 0.02 * f);
    /* on to 1.1 F_s in 0.2 s, hold 0.5 s: it slips */
    for (int n = 0; n < 7000; ++n) {
        rig.ext_force = fs * (0.9 + 0.2 * fmin(1.0, (double)n / 2000.0));
        assert_int_equal(hs_rig_step(&rig, 0.0, H), HS_OK);
        worst_v = fmax(worst_v, rig.x[HS_RIG_RATE]);
    }
    disp = rig.x[HS_RIG_STROKE] - s0;
    printf("  1.1 F_s = %.0f N: slipped %.3f mm, fastest %.1f mm/s\n", rig.ext_force, disp * 1e3, worst_v * 1e3);
    assert_true(disp > 1e-3);
    assert_true(worst_v > c.stribeck_velocity);
}

/* 3. */
static void test_steady_sliding(void **state)
{
    static const double speeds[12] = {2e-4, 5e-4, 1e-3, 2e-3, 3e-3, 5e-3, 7e-3, 1e-2, 2e-2, 5e-2, 0.2, 0.5};
    hs_params_t p;
    const hs_cyl_params_t *c;
    hs_cyl_state_t st;
    hs_cyl_eval_t ev;
    hs_rig_t rig;
    double worst = 0.0, u, v, fr;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    c = &p.cyl[0];
    memset(&st, 0, sizeof st);
    for (int k = 0; k < 24; ++k) {
        double rate = (k < 12) ? speeds[k] : -speeds[k - 12];
        /* 30 time constants F_s / (sigma_0 |v|) of the bristles' approach to their steady deflection */
        long steps = lround(30.0 * c->breakaway_friction / (c->bristle_stiffness * fabs(rate)) / H) + 100;
        st.z = 0.0;
        for (long n = 0; n < steps; ++n) {
            double k1, k2, k3, k4, z0 = st.z;
            hs_cyl_eval(c, &st, 0.7, rate, 0.0, &ev);
            k1 = ev.dz;
            st.z = z0 + 0.5 * H * k1;
            hs_cyl_eval(c, &st, 0.7, rate, 0.0, &ev);
            k2 = ev.dz;
            st.z = z0 + 0.5 * H * k2;
            hs_cyl_eval(c, &st, 0.7, rate, 0.0, &ev);
            k3 = ev.dz;
            st.z = z0 + H * k3;
            hs_cyl_eval(c, &st, 0.7, rate, 0.0, &ev);
            k4 = ev.dz;
            st.z = z0 + H / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        hs_cyl_eval(c, &st, 0.7, rate, 0.0, &ev);
        worst = fmax(worst, fabs(ev.friction - stribeck(c, rate)));
        assert_near(ev.friction, stribeck(c, rate), 1e-6, "steady friction at %g m/s (N)", rate);
    }
    printf("  steady sliding, 24 rates 0.2 mm/s .. 0.5 m/s: largest difference from the Stribeck formula %.2e N\n",
           worst);

    /* the rig at a constant valve opening: about 20 mm/s (in the Stribeck
     * region, below about 3 v_s, the falling friction makes it stick-slip) */
    assert_int_equal(hs_rig_init(&rig, c, 452.0, 0.0, 0.7), HS_OK);
    u = hs_cyl_velocity_command(c, 0.02, 0.0);
    for (int n = 0; n < 20000; ++n) {
        assert_int_equal(hs_rig_step(&rig, u, H), HS_OK);
    }
    v = rig.x[HS_RIG_RATE];
    hs_rig_eval(&rig, u, &ev);
    fr = ev.friction;
    printf("  rig sliding at %.3f mm/s: friction %.3f N, formula %.3f N\n", v * 1e3, fr, stribeck(c, v));
    assert_true(v > 0.01);
    assert_near(fr, stribeck(c, v), 0.5, "rig friction (N)");
}

/* 4. */
static void test_friction_dissipates(void **state)
{
    hs_params_t p;
    hs_energy_t e0, e, prev;
    double vel[3] = {0.02, -0.01, 0.03}, omega[3] = {0.01, 0.02, -0.015};
    double worst_rise = 0.0;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        p.cyl[i].leakage = 0.0;
    }
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_twist(&plant, vel, omega), HS_OK);
    assert_int_equal(hs_plant_energy(&plant, &e0), HS_OK);
    prev = e0;
    for (int n = 0; n < 3000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        assert_int_equal(hs_plant_energy(&plant, &e), HS_OK);
        worst_rise = fmax(worst_rise, e.total - prev.total);
        prev = e;
    }
    printf("  stiction, valves closed, 3 s: energy above rest %.4f J -> %.2e J, largest rise in a cycle %.2e J\n",
           e0.kinetic, e.total - (e0.total - e0.kinetic), worst_rise);
    assert_true(worst_rise <= 1e-9 * e0.kinetic);
    assert_true(e.total - (e0.total - e0.kinetic) < 0.1 * e0.kinetic);
}

/* 5. */
static void test_closed_loop_slow_sine(void **state)
{
    hs_params_t p;
    double len[HS_LEGS], worst = 0.0;
    hs_state_t st;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    hs_leg_lengths(&p, p.home, len);
    for (int n = 0; n < 10000; ++n) {
        double t = 1e-3 * n, w = 2.0 * 3.14159265358979323846 * 0.2;
        for (int i = 0; i < HS_LEGS; ++i) {
            assert_int_equal(hs_plant_set_setpoint(&plant, i, len[i] + 1e-3 * sin(w * t + i), 1e-3 * w * cos(w * t + i),
                                                   plant.ideal_force[i], HS_REQ_ACTIVE),
                             HS_OK);
        }
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
        if (n > 100) {
            for (int i = 0; i < HS_LEGS; ++i) {
                double t1 = 1e-3 * (n + 1);
                worst = fmax(worst, fabs(st.length[i] - (len[i] + 1e-3 * sin(w * t1 + i))));
            }
        }
    }
    printf("  drives, 1 mm 0.2 Hz sines with stiction, 10 s: leg error largest %.1f um\n", worst * 1e6);
    assert_true(worst < 3e-4);
    for (int i = 0; i < HS_LEGS; ++i) {
        hs_feedback_t fb;
        assert_int_equal(hs_plant_feedback(&plant, i, &fb), HS_OK);
        assert_int_equal(fb.state, HS_DRIVE_ACTIVE);
        assert_int_equal(fb.faults, 0u);
    }
}

/* 6. */
static void test_params_check(void **state)
{
    hs_params_t p, q;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    q = p;
    q.cyl[2].coulomb_friction = 0.0; /* bristles without a Coulomb level */
    assert_int_equal(hs_params_check(&q), HS_E_ARG);
    q.cyl[2].bristle_stiffness = 0.0; /* memoryless: fine */
    assert_int_equal(hs_params_check(&q), HS_OK);
    q = p;
    q.cyl[1].bristle_damping = 4.0 * q.cyl[1].coulomb_friction / (0.42 * q.cyl[1].stribeck_velocity);
    assert_int_equal(hs_params_check(&q), HS_E_ARG);
    q = p;
    q.cyl[0].breakaway_friction = q.cyl[0].coulomb_friction - 1.0;
    assert_int_equal(hs_params_check(&q), HS_E_ARG);
    q = p;
    q.cyl[5].stribeck_velocity = 0.0;
    assert_int_equal(hs_params_check(&q), HS_E_ARG);
    q = p;
    q.cyl[4].bristle_stiffness = NAN;
    assert_int_equal(hs_params_check(&q), HS_E_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_parameters),  cmocka_unit_test(test_rest_after_motion_hides_force),
        cmocka_unit_test(test_break_away),          cmocka_unit_test(test_steady_sliding),
        cmocka_unit_test(test_friction_dissipates), cmocka_unit_test(test_closed_loop_slow_sine),
        cmocka_unit_test(test_params_check),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
