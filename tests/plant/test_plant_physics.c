/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Plant physics against the firmware core (issue 5, checks 1 and 2).
 *
 * 1. Ideal force sources driven by the core's inverse dynamics. Each 1 ms
 *    cycle the test evaluates the reference motion at the middle of the
 *    cycle (the zero-order hold of a force is second-order accurate about
 *    that instant), converts it to the core's Q formats, runs
 *    sp_inverse_kinematics + sp_inverse_dynamics with sp_platform_default
 *    (generated from the same config as hs_params_default), and applies the
 *    six forces to the plant in HS_ACT_IDEAL mode. The plant starts at the
 *    motion's own pose and velocity. Motions: the paper's surge (90 mm,
 *    0.5 Hz) and yaw (0.09 rad, 0.5 Hz), and a motion of all six axes at
 *    once with different frequencies and phases.
 *    a) Open loop, 2 s: a platform on six constant-force legs is unstable
 *       (like an inverted pendulum, e-folding in about 0.5 s), so any force
 *       error grows; the bound is 0.1 mm and 0.1 mrad. A plant whose
 *       dynamics differed from the core's (a sign in the gyroscopic term, a
 *       missing product of inertia) misses it by orders of magnitude.
 *    b) 10 s with a weak stabilising correction added to the core's forces:
 *       per leg 2e4 N/m x (length error) + 2e3 N s/m x (rate error), a
 *       thousandth of the oil column's stiffness. Bounds: 0.1 mm, 0.1 mrad,
 *       and the correction never exceeds 5 N (the core's forces reach
 *       about 7 kN): the core's forces alone carry the motion.
 * 2. Energy and rest.
 *    a) Hydraulic mode with the valves closed (drives in INIT), no leakage,
 *       no friction: after a kick the platform rings on its oil columns for
 *       10 s; kinetic + gravity + oil energy stays constant within 1e-6 of
 *       the kick's kinetic energy (RK4 at 10 kHz).
 *    b) Ideal mode with the static forces of hs_static_forces: the platform
 *       stays within 5 um and 5 urad of its start for 10 s (the equilibrium
 *       on constant forces is unstable: rounding errors of 1e-16 grow by
 *       e^20 in 10 s to about 1 um); with the core's static forces (Q8,
 *       4 mN steps) within 10 um and 10 urad for 1 s.
 *    c) Hydraulic mode, drives holding (HOLD requests), full model with
 *       leakage, friction and sensor noise: within 5 um for 10 s (the
 *       leakage needs a steady valve opening, which the proportional loop
 *       gets from about 2 um of error).
 * Also the rigid body's own conservation laws (free tumbling body: angular
 * momentum and energy; constant wrench: momentum = F t, angular momentum =
 * M t) and the contact (resting on a plane; energy with a point spring).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hs/kin.h"
#include "hs/plant.h"
#include "assert_near.h"
#include "plant_test_util.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"

#define DT 1e-3

static hs_plant_t plant;

typedef struct {
    double pos;  /* largest position error, m */
    double rot;  /* largest orientation error, rad */
    double corr; /* largest |correction force|, N */
    double fmax; /* largest |core force|, N */
} track_t;

/* Runs the ideal-force plant along a motion for `seconds`; k, c: correction
 * gains (0: open loop). */
static void run_ideal(const pt_sines_t *m, double seconds, double k, double c, track_t *out)
{
    hs_params_t p;
    double pose[6], vel[6], acc[6], omega[3];
    long n_cycles = lround(seconds / DT);
    memset(out, 0, sizeof *out);
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_motion(p.home, m, 0.0, pose, vel, acc);
    assert_int_equal(hs_plant_init(&plant, &p, pose), HS_OK);
    hs_body_rates(&pose[3], &vel[3], omega);
    assert_int_equal(hs_plant_set_twist(&plant, vel, omega), HS_OK);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);

    for (long n = 0; n < n_cycles; ++n) {
        sp_motion_t mo;
        sp_ik_t ik;
        sp_q8_t fq[SP_LEGS];
        double force[HS_LEGS], now_pose[6];
        pt_motion(p.home, m, ((double)n + 0.5) * DT, pose, vel, acc);
        pt_to_sp_motion(pose, vel, acc, &mo);
        assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &mo.pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_dynamics(&sp_platform_default, &mo, &ik, NULL, fq), SP_OK);
        for (int i = 0; i < HS_LEGS; ++i) {
            force[i] = ref_f8(fq[i]);
            if (fabs(force[i]) > out->fmax) {
                out->fmax = fabs(force[i]);
            }
        }
        if (k > 0.0 || c > 0.0) {
            /* weak correction on the leg lengths and rates at the cycle start */
            hs_state_t st;
            double lp[HS_LEGS], lm[HS_LEGS], ld[HS_LEGS], t0 = (double)n * DT, h = 1e-6;
            assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
            pt_motion(p.home, m, t0, pose, vel, acc);
            hs_leg_lengths(&p, pose, ld);
            pt_motion(p.home, m, t0 + h, pose, vel, acc);
            hs_leg_lengths(&p, pose, lp);
            pt_motion(p.home, m, t0 - h, pose, vel, acc);
            hs_leg_lengths(&p, pose, lm);
            for (int i = 0; i < HS_LEGS; ++i) {
                double corr = k * (ld[i] - st.length[i]) + c * ((lp[i] - lm[i]) / (2.0 * h) - st.rate[i]);
                force[i] += corr;
                if (fabs(corr) > out->corr) {
                    out->corr = fabs(corr);
                }
            }
        }
        assert_int_equal(hs_plant_set_forces(&plant, force), HS_OK);
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        pt_motion(p.home, m, (double)(n + 1) * DT, pose, vel, acc);
        assert_int_equal(hs_plant_pose(&plant, now_pose), HS_OK);
        double ep = pt_pos_error(pose, now_pose);
        double er = pt_rot_error(&pose[3], &now_pose[3]);
        out->pos = (ep > out->pos) ? ep : out->pos;
        out->rot = (er > out->rot) ? er : out->rot;
    }
}

static const pt_sines_t surge = {{0.09, 0, 0, 0, 0, 0}, {0.5, 0.5, 0.5, 0.5, 0.5, 0.5}, {0}};
static const pt_sines_t yaw = {{0, 0, 0, 0, 0, 0.09}, {0.5, 0.5, 0.5, 0.5, 0.5, 0.5}, {0}};
static const pt_sines_t six_axes = {
    {0.06, 0.05, 0.04, 0.05, 0.04, 0.06}, {0.5, 0.4, 0.7, 0.6, 0.45, 0.55}, {0.0, 0.5, 1.0, 1.5, 2.0, 2.5}};

static void check_open_loop(const char *name, const pt_sines_t *m)
{
    track_t t;
    run_ideal(m, 2.0, 0.0, 0.0, &t);
    printf("  %-9s open loop 2 s: position %.2f um, orientation %.2f urad (forces up to %.0f N)\n", name, t.pos * 1e6,
           t.rot * 1e6, t.fmax);
    assert_true(t.pos < 1e-4);
    assert_true(t.rot < 1e-4);
}

static void check_corrected(const char *name, const pt_sines_t *m)
{
    track_t t;
    run_ideal(m, 10.0, 2e4, 2e3, &t);
    printf("  %-9s corrected 10 s: position %.2f um, orientation %.2f urad, correction <= %.3f N of %.0f N\n", name,
           t.pos * 1e6, t.rot * 1e6, t.corr, t.fmax);
    assert_true(t.pos < 1e-5);
    assert_true(t.rot < 1e-5);
    assert_true(t.corr < 0.1);
}

static void test_ideal_open_loop_surge(void **state)
{
    (void)state;
    check_open_loop("surge", &surge);
}

static void test_ideal_open_loop_yaw(void **state)
{
    (void)state;
    check_open_loop("yaw", &yaw);
}

static void test_ideal_open_loop_six_axes(void **state)
{
    (void)state;
    check_open_loop("six axes", &six_axes);
}

static void test_ideal_corrected_surge(void **state)
{
    (void)state;
    check_corrected("surge", &surge);
}

static void test_ideal_corrected_yaw(void **state)
{
    (void)state;
    check_corrected("yaw", &yaw);
}

static void test_ideal_corrected_six_axes(void **state)
{
    (void)state;
    check_corrected("six axes", &six_axes);
}

/* A plant whose physics differ from the core's must fail the open-loop
 * bound: the same run with the product of inertia I_xz flipped. This keeps
 * the bounds above honest (they are not so loose that anything passes). */
static void test_open_loop_detects_wrong_inertia(void **state)
{
    hs_params_t p;
    double pose[6], vel[6], acc[6], omega[3], now_pose[6], err = 0.0;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    p.inertia[0][2] = -p.inertia[0][2];
    p.inertia[2][0] = -p.inertia[2][0];
    pt_motion(p.home, &six_axes, 0.0, pose, vel, acc);
    assert_int_equal(hs_plant_init(&plant, &p, pose), HS_OK);
    hs_body_rates(&pose[3], &vel[3], omega);
    hs_plant_set_twist(&plant, vel, omega);
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    for (int n = 0; n < 2000; ++n) {
        sp_motion_t mo;
        sp_ik_t ik;
        sp_q8_t fq[SP_LEGS];
        double force[HS_LEGS];
        pt_motion(p.home, &six_axes, ((double)n + 0.5) * DT, pose, vel, acc);
        pt_to_sp_motion(pose, vel, acc, &mo);
        assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &mo.pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_dynamics(&sp_platform_default, &mo, &ik, NULL, fq), SP_OK);
        for (int i = 0; i < HS_LEGS; ++i) {
            force[i] = ref_f8(fq[i]);
        }
        hs_plant_set_forces(&plant, force);
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    pt_motion(p.home, &six_axes, 2.0, pose, vel, acc);
    hs_plant_pose(&plant, now_pose);
    err = pt_rot_error(&pose[3], &now_pose[3]);
    printf("  six axes, I_xz flipped: orientation error %.1f urad after 2 s\n", err * 1e6);
    assert_true(err > 1e-3);
}

static void test_energy_conserved_closed_valves(void **state)
{
    hs_params_t p;
    hs_energy_t e0, e;
    double vel[3] = {0.02, -0.01, 0.03}, omega[3] = {0.01, 0.02, -0.015};
    double drift = 0.0, kin_min = 1e30;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        p.cyl[i].leakage = 0.0;
    }
    pt_no_friction(&p);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_twist(&plant, vel, omega), HS_OK);
    assert_int_equal(hs_plant_energy(&plant, &e0), HS_OK);
    for (int n = 0; n < 10000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        assert_int_equal(hs_plant_energy(&plant, &e), HS_OK);
        drift = fmax(drift, fabs(e.total - e0.total));
        kin_min = fmin(kin_min, e.kinetic);
    }
    printf("  closed valves, 10 s: energy %.3f J (kick %.4f J, kinetic down to %.2e J), largest drift %.3e J\n",
           e0.total, e0.kinetic, kin_min, drift);
    /* the platform really rang: its kinetic energy went (almost) all into the oil at times */
    assert_true(kin_min < 0.1 * e0.kinetic);
    assert_true(drift < 1e-6 * e0.kinetic);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_int_equal(plant.drive[i].state, HS_DRIVE_INIT);
    }
}

static void test_rest_ideal_static_forces(void **state)
{
    hs_params_t p;
    double f[HS_LEGS], pose[6];
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        f[i] = plant.ideal_force[i]; /* the static forces, legs' weight included */
    }
    assert_int_equal(hs_plant_set_forces(&plant, f), HS_OK);
    for (int n = 0; n < 10000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_pose(&plant, pose);
    printf("  ideal, static forces, 10 s: moved %.3e m, %.3e rad\n", pt_pos_error(pose, p.home),
           pt_rot_error(&pose[3], &p.home[3]));
    assert_true(pt_pos_error(pose, p.home) < 5e-6);
    assert_true(pt_rot_error(&pose[3], &p.home[3]) < 5e-6);

    /* the core's static forces (Q8 quantised) for 1 s */
    {
        sp_motion_t mo;
        sp_ik_t ik;
        sp_q8_t fq[SP_LEGS];
        double zero[6] = {0, 0, 0, 0, 0, 0};
        pt_to_sp_motion(p.home, zero, zero, &mo);
        assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &mo.pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_dynamics(&sp_platform_default, &mo, &ik, NULL, fq), SP_OK);
        for (int i = 0; i < HS_LEGS; ++i) {
            f[i] = ref_f8(fq[i]);
        }
    }
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    hs_plant_set_forces(&plant, f);
    for (int n = 0; n < 1000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_pose(&plant, pose);
    printf("  ideal, core's static forces, 1 s: moved %.3e m, %.3e rad\n", pt_pos_error(pose, p.home),
           pt_rot_error(&pose[3], &p.home[3]));
    assert_true(pt_pos_error(pose, p.home) < 1e-5);
    assert_true(pt_rot_error(&pose[3], &p.home[3]) < 1e-5);
}

static void test_rest_hydraulic_hold(void **state)
{
    hs_params_t p;
    double pose[6], worst = 0.0;
    hs_feedback_t fb;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    for (int n = 0; n < 10000; ++n) {
        for (int i = 0; i < HS_LEGS; ++i) {
            assert_int_equal(hs_plant_set_setpoint(&plant, i, 0.0, 0.0, 0.0, HS_REQ_HOLD), HS_OK);
        }
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        hs_plant_pose(&plant, pose);
        worst = fmax(worst, pt_pos_error(pose, p.home));
    }
    printf("  hydraulic, drives holding, 10 s: largest excursion %.3f um\n", worst * 1e6);
    assert_true(worst < 5e-6);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_int_equal(hs_plant_feedback(&plant, i, &fb), HS_OK);
        assert_int_equal(fb.state, HS_DRIVE_HOLD);
        assert_int_equal(fb.faults, 0u);
    }
}

/* Angular momentum about o' in the base frame: R I w. */
static void angular_momentum(const hs_plant_t *pl, const hs_params_t *p, double h[3])
{
    hs_state_t st;
    double r[3][3], iw[3];
    hs_plant_state(pl, &st);
    hs_rot_from_quat(st.quat, r);
    for (int k = 0; k < 3; ++k) {
        iw[k] = p->inertia[k][0] * st.omega_body[0] + p->inertia[k][1] * st.omega_body[1] +
                p->inertia[k][2] * st.omega_body[2];
    }
    for (int k = 0; k < 3; ++k) {
        h[k] = r[k][0] * iw[0] + r[k][1] * iw[1] + r[k][2] * iw[2];
    }
}

/* Rigid body alone (ideal mode, zero leg forces, no gravity): a body
 * spinning about no principal axis tumbles (gyroscopic term, full inertia
 * with a product of inertia); its angular momentum in the base frame and its
 * kinetic energy stay constant within 1e-9 relative over 10 s, and its
 * quaternion stays unit. Then a constant external wrench: linear momentum
 * grows as F t and angular momentum as M t (exact laws, within 1e-9). */
static void test_rigid_body_laws(void **state)
{
    hs_params_t p;
    double zero[HS_LEGS] = {0, 0, 0, 0, 0, 0};
    double v0[3] = {0.0, 0.0, 0.0}, w0[3] = {0.5, -0.3, 0.8};
    double h0[3], h[3], dh = 0.0, de = 0.0, hn;
    hs_energy_t e0, e;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p); /* the rigid body alone */
    p.gravity = 0.0;
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);
    assert_int_equal(hs_plant_set_forces(&plant, zero), HS_OK);
    assert_int_equal(hs_plant_set_twist(&plant, v0, w0), HS_OK);
    angular_momentum(&plant, &p, h0);
    hs_plant_energy(&plant, &e0);
    hn = sqrt(h0[0] * h0[0] + h0[1] * h0[1] + h0[2] * h0[2]);
    for (int n = 0; n < 10000; ++n) {
        hs_state_t st;
        double qn;
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        angular_momentum(&plant, &p, h);
        hs_plant_energy(&plant, &e);
        for (int k = 0; k < 3; ++k) {
            dh = fmax(dh, fabs(h[k] - h0[k]));
        }
        de = fmax(de, fabs(e.kinetic - e0.kinetic));
        hs_plant_state(&plant, &st);
        qn = st.quat[0] * st.quat[0] + st.quat[1] * st.quat[1] + st.quat[2] * st.quat[2] + st.quat[3] * st.quat[3];
        assert_near(qn, 1.0, 1e-12, "step %d: |q|^2", n);
    }
    printf("  free tumbling body, 10 s: angular momentum drift %.2e of %.1f N m s, energy drift %.2e of %.3f J\n", dh,
           hn, de, e0.kinetic);
    assert_true(dh < 1e-9 * hn);
    assert_true(de < 1e-9 * e0.kinetic);
    {
        /* the body really tumbled: body rates changed (not a principal axis) */
        hs_state_t st;
        hs_plant_state(&plant, &st);
        assert_true(fabs(st.omega_body[0] - w0[0]) > 1e-3);
    }

    /* constant external wrench from rest */
    {
        double f[3] = {120.0, -80.0, 40.0}, m[3] = {30.0, 50.0, -70.0}, w00[3] = {0, 0, 0};
        double t = 2.0, pose0[6], pose1[6];
        assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
        hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
        hs_plant_set_forces(&plant, zero);
        hs_plant_set_twist(&plant, v0, w00);
        assert_int_equal(hs_plant_set_wrench(&plant, f, m), HS_OK);
        hs_plant_pose(&plant, pose0);
        for (int n = 0; n < 2000; ++n) {
            assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        }
        hs_plant_pose(&plant, pose1);
        angular_momentum(&plant, &p, h);
        for (int k = 0; k < 3; ++k) {
            hs_state_t st;
            hs_plant_state(&plant, &st);
            assert_near(p.mass * st.vel[k], f[k] * t, 1e-9 * fabs(f[k] * t), "momentum %d (N s)", k);
            assert_near(pose1[k] - pose0[k], 0.5 * f[k] / p.mass * t * t, 1e-12, "displacement %d (m)", k);
            assert_near(h[k], m[k] * t, 1e-9 * 100.0, "angular momentum %d (N m s)", k);
        }
    }
}

/* Contact. A plane under a point below o' (platform in ideal mode with no
 * leg forces): the platform falls on it and comes to rest where the spring
 * carries the weight: contact force m g within 0.1 %, penetration m g / k.
 * A bilateral point spring without damping: kinetic + gravity + spring
 * energy conserved within 1e-9 relative over 5 s. */
static void test_contact(void **state)
{
    hs_params_t p;
    hs_contact_t ct;
    hs_state_t st;
    double zero[HS_LEGS] = {0, 0, 0, 0, 0, 0}, pose[6];
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p); /* the rigid body alone */
    memset(&ct, 0, sizeof ct);
    ct.kind = HS_CONTACT_PLANE;
    ct.point[2] = -0.3;
    ct.normal[2] = 2.0;                  /* normalised by the plant */
    ct.offset = p.home[2] - 0.3 - 0.001; /* 1 mm below the point */
    ct.stiffness = 5e6;
    ct.damping = 2e5;
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    hs_plant_set_forces(&plant, zero);
    assert_int_equal(hs_plant_set_contact(&plant, &ct), HS_OK);
    for (int n = 0; n < 3000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_state(&plant, &st);
    hs_plant_pose(&plant, pose);
    printf("  resting on a plane: contact force %.2f N (weight %.2f N), sunk %.4f mm into it\n", st.contact_force[2],
           p.mass * p.gravity, (ct.offset - (pose[2] - 0.3)) * 1e3);
    assert_near(st.contact_force[2] / (p.mass * p.gravity), 1.0, 1e-3, "contact force / weight");
    assert_near(st.contact_force[0], 0.0, 1e-6, "contact force x (N)");
    assert_near(st.contact_force[1], 0.0, 1e-6, "contact force y (N)");
    assert_near(ct.offset - (pose[2] - 0.3), p.mass * p.gravity / ct.stiffness, 1e-6, "sunk into the plane (m)");

    /* Hydraulic mode (valves at null, no leakage) at that pose with the
     * contact carrying the weight: after hs_plant_rebalance the cylinders
     * carry nothing and the platform stays within 1 um; without it the
     * cylinders hold the weight too and the platform jumps up. */
    for (int rebalance = 1; rebalance >= 0; --rebalance) {
        double before[6], after[6], moved = 0.0;
        hs_params_t q = p;
        for (int i = 0; i < HS_LEGS; ++i) {
            q.cyl[i].leakage = 0.0;
        }
        assert_int_equal(hs_plant_init(&plant, &q, pose), HS_OK);
        assert_int_equal(hs_plant_set_contact(&plant, &ct), HS_OK);
        if (rebalance) {
            assert_int_equal(hs_plant_rebalance(&plant), HS_OK);
        }
        hs_plant_pose(&plant, before);
        for (int n = 0; n < 500; ++n) {
            assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
            hs_plant_pose(&plant, after);
            moved = fmax(moved, pt_pos_error(before, after));
        }
        printf("  hydraulic on the plane, %s: moved up to %.3f um\n", rebalance ? "rebalanced" : "not rebalanced",
               moved * 1e6);
        assert_true(rebalance ? moved < 1e-6 : moved > 1e-4);
    }

    /* bilateral point spring, no damping: energy conserved */
    {
        hs_energy_t e0, e;
        double v[3] = {0.05, -0.02, 0.01}, w[3] = {0.02, 0.0, -0.03}, drift = 0.0;
        memset(&ct, 0, sizeof ct);
        ct.kind = HS_CONTACT_POINT;
        ct.point[0] = 0.8;
        ct.anchor[0] = 0.8;
        ct.anchor[2] = p.home[2];
        ct.stiffness = 1e5;
        p.gravity = 0.0;
        assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
        hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
        hs_plant_set_forces(&plant, zero);
        assert_int_equal(hs_plant_set_contact(&plant, &ct), HS_OK);
        hs_plant_set_twist(&plant, v, w);
        hs_plant_energy(&plant, &e0);
        for (int n = 0; n < 5000; ++n) {
            assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
            hs_plant_energy(&plant, &e);
            drift = fmax(drift, fabs(e.total - e0.total));
        }
        printf("  point spring, 5 s: energy %.4f J, drift %.2e J\n", e0.total, drift);
        assert_true(e.springs > 0.0);
        assert_true(drift < 1e-9 * e0.total);
    }
}

/* A tilted surface (the scenario's `contact surface`: 20 degrees about x,
 * free side up, 1 mm from o' along its normal), touched at o' (no moment),
 * no gravity, rigid body alone. Pushed into it by F (-F n, at o'): the
 * platform comes to rest sunk F / k along n, the contact force F n (within
 * 0.1 %, its part along the surface within 1e-6 of F). Pushed also by f_t
 * along the surface: the model has no friction, so it slides at f_t / m
 * along the surface, the normal force unchanged, and no force acts along
 * the surface (within 1e-6 of F). */
static void test_contact_tilted(void **state)
{
    const double tilt = 20.0 * 3.14159265358979323846 / 180.0, big_f = 2000.0, f_t = 50.0;
    const double n[3] = {0.0, -sin(tilt), cos(tilt)}, t[3] = {0.0, cos(tilt), sin(tilt)};
    hs_params_t p;
    hs_contact_t ct;
    hs_state_t st;
    double zero[HS_LEGS] = {0, 0, 0, 0, 0, 0}, pose0[6], pose[6], m0[3] = {0, 0, 0};
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    p.gravity = 0.0;
    memset(&ct, 0, sizeof ct);
    ct.kind = HS_CONTACT_PLANE;
    memcpy(ct.normal, n, sizeof n);
    ct.offset = n[0] * p.home[0] + n[1] * p.home[1] + n[2] * p.home[2] - 0.001; /* 1 mm from o' */
    ct.stiffness = 1e6;
    ct.damping = 2e4;
    for (int slide = 0; slide <= 1; ++slide) {
        double push[3], fn = 0.0, ft = 0.0, dn = 0.0, dt = 0.0, expect_dt;
        const double secs = 3.0;
        for (int k = 0; k < 3; ++k) {
            push[k] = -big_f * n[k] + (slide ? f_t * t[k] : 0.0);
        }
        assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
        hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
        hs_plant_set_forces(&plant, zero);
        assert_int_equal(hs_plant_set_contact(&plant, &ct), HS_OK);
        assert_int_equal(hs_plant_set_wrench(&plant, push, m0), HS_OK);
        hs_plant_pose(&plant, pose0);
        for (int i = 0; i < (int)(secs / DT); ++i) {
            assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        }
        hs_plant_state(&plant, &st);
        hs_plant_pose(&plant, pose);
        for (int k = 0; k < 3; ++k) {
            fn += st.contact_force[k] * n[k];
            ft += st.contact_force[k] * t[k];
            dn += (pose[k] - pose0[k]) * n[k];
            dt += (pose[k] - pose0[k]) * t[k];
        }
        expect_dt = slide ? 0.5 * f_t / p.mass * secs * secs : 0.0;
        printf("  tilted surface (20 deg)%s: normal force %.2f N, along it %.2e N, sunk %.4f mm, slid %.2f mm "
               "(frictionless: %.2f)\n",
               slide ? ", pushed along it" : "", fn, ft, (-dn - 0.001) * 1e3, dt * 1e3, expect_dt * 1e3);
        assert_near(fn / big_f, 1.0, 1e-3, "normal force / push");
        assert_near(ft, 0.0, 1e-6 * big_f, "contact force along the surface (N)");
        assert_near(st.contact_force[0], 0.0, 1e-6 * big_f, "contact force x (N)");
        assert_near(-dn, big_f / ct.stiffness + 0.001, 1e-6, "moved along the normal (m)");
        assert_near(dt, expect_dt, 1e-3 * fmax(expect_dt, 1e-6), "slide along the surface (m)");
        assert_near(st.wrench[3], 0.0, 1e-6, "moment about o' (N m)");
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ideal_open_loop_surge),
        cmocka_unit_test(test_ideal_open_loop_yaw),
        cmocka_unit_test(test_ideal_open_loop_six_axes),
        cmocka_unit_test(test_ideal_corrected_surge),
        cmocka_unit_test(test_ideal_corrected_yaw),
        cmocka_unit_test(test_ideal_corrected_six_axes),
        cmocka_unit_test(test_open_loop_detects_wrong_inertia),
        cmocka_unit_test(test_energy_conserved_closed_valves),
        cmocka_unit_test(test_rest_ideal_static_forces),
        cmocka_unit_test(test_rest_hydraulic_hold),
        cmocka_unit_test(test_rigid_body_laws),
        cmocka_unit_test(test_contact),
        cmocka_unit_test(test_contact_tilted),
    };
    return cmocka_run_group_tests_name("plant_physics", tests, NULL, NULL);
}
