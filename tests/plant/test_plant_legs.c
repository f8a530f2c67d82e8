/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Optional leg masses of the plant (issue 5; docs/explanation/plant.md "Leg masses").
 *
 * Leg masses used here: cylinder body 60 kg at 0.8 m from the base joint,
 * rod + piston 35 kg at 1.0 m from the platform joint (about a default
 * leg's proportions at home, length 2.55 m).
 *
 * 1. Off by default, bit-identical: the default config has every leg mass
 *    at 0, and a fixed scenario (hydraulic mode, drives ACTIVE following
 *    sines, a kick, an external wrench, a point contact, rebalance, then
 *    ideal mode; 600 cycles) hashes (FNV-1a over the state after every
 *    cycle) to the value recorded with the plant before leg masses existed.
 * 2. Energy: hydraulic mode, valves closed, no leakage or friction, leg
 *    masses on, a kick; kinetic + gravity (platform and legs) + oil stays
 *    constant over 10 s within 1e-6 of the kick's kinetic energy.
 * 3. Rest: leg masses on, ideal mode, after hs_plant_rebalance the platform
 *    stays within 5 um and 5 urad for 10 s; with the forces that neglect
 *    the legs it falls away (more than 0.1 mm in 1 s). Hydraulic mode,
 *    drives holding, leg masses on: within 5 um for 10 s.
 * 4. Static forces against an independent free-body computation: for each
 *    leg, moments about the base joint give the transverse part of the joint
 *    force, the rod's axial balance its axial part; the plant's forces must
 *    put the platform in equilibrium with these joint forces (1e-6 N,
 *    1e-6 N m), and the vertical cylinder force sum exceeds the platform's
 *    weight by sum_i g (k_i (1 - u_iz^2) + m_r u_iz^2), k_i = (m_c d_c +
 *    m_r (L_i - d_r)) / L_i.
 * 5. Dynamics against a rigid body: rods with their centre at the platform
 *    joint (d_r = 0) and cylinders at the base joint (d_c = 0) are exactly a
 *    platform with 6 m_r more mass and the point masses' inertia (platform
 *    joints moved into the plane of o' so that o' stays the centre of
 *    mass); with the same forces and kick both move alike within
 *    1e-9 m / 1e-9 rad in 2 s.
 * 6. Newton-Euler cross-check of the leg dynamics (see the test).
 * 7. hs_params_check rejects negative or non-finite leg masses and centres
 *    beyond the longest leg, and negative or non-finite moments of inertia.
 *
 * Tests 2 and 6 run again with the legs' moments of inertia across the leg
 * (docs/explanation/model.md "Leg inertia"): 11.25 kg m^2 for the barrel
 * (60 kg, 1.5 m) and 7.5 kg m^2 for the rod (35 kg, 1.6 m). In 6 the
 * moment balance of each leg about its base joint then takes in the rate
 * of the leg's angular momentum, (I_c + I_r) u x u'', u'' by differences.
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

#define DT 1e-3
#define M_CYL 60.0
#define D_CYL 0.8
#define M_ROD 35.0
#define D_ROD 1.0
#define I_CYL 11.25
#define I_ROD 7.5

static hs_plant_t plant;
static hs_plant_t plant2;

static void with_legs(hs_params_t *p, double mc, double dc, double mr, double dr)
{
    for (int i = 0; i < HS_LEGS; ++i) {
        p->cyl[i].cylinder_mass = mc;
        p->cyl[i].cylinder_com = dc;
        p->cyl[i].rod_mass = mr;
        p->cyl[i].rod_com = dr;
    }
}

static uint64_t fnv(uint64_t h, const void *d, size_t n)
{
    const unsigned char *b = d;
    for (size_t k = 0; k < n; ++k) {
        h ^= b[k];
        h *= 1099511628211u;
    }
    return h;
}

static void test_default_off_bit_identical(void **state)
{
    hs_params_t p;
    double len[HS_LEGS];
    uint64_t h = 1469598103934665603u;
    double vel[3] = {0.01, -0.02, 0.015}, om[3] = {0.01, -0.01, 0.02};
    double fe[3] = {100.0, -50.0, 200.0}, me[3] = {30.0, 20.0, -10.0};
    hs_contact_t ct;
    (void)state;
    /* the default config has leg masses; switched off they leave no trace */
    assert_true(hs_config_default.hydraulic.cylinder_mass > 0.0);
    assert_true(hs_config_default.hydraulic.rod_mass > 0.0);
    memset(&ct, 0, sizeof ct);
    ct.kind = HS_CONTACT_POINT;
    ct.point[0] = 0.3;
    ct.anchor[0] = 0.3;
    ct.anchor[2] = 2.55;
    ct.stiffness = 1e4;
    ct.damping = 100.0;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    pt_memoryless_friction(&p);         /* the friction the hash was recorded with */
    p.sensors.length_resolution = 1e-6; /* and the length sensor (0.1 um since session 10) */
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(plant.legs_on, 0);
    hs_leg_lengths(&p, p.home, len);
    hs_plant_set_twist(&plant, vel, om);
    hs_plant_set_wrench(&plant, fe, me);
    hs_plant_set_contact(&plant, &ct);
    assert_int_equal(hs_plant_rebalance(&plant), HS_OK);
    for (int n = 0; n < 400; ++n) {
        for (int i = 0; i < HS_LEGS; ++i) {
            double t = 1e-3 * n;
            hs_plant_set_setpoint(&plant, i, len[i] + 0.005 * sin(6.0 * t + i), 0.03 * cos(6.0 * t + i),
                                  plant.ideal_force[i], HS_REQ_ACTIVE);
        }
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        h = fnv(h, plant.x, HS_X_BRISTLE * sizeof plant.x[0]); /* the state as it was then */
    }
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    for (int n = 0; n < 200; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        h = fnv(h, plant.x, HS_X_BRISTLE * sizeof plant.x[0]); /* the state as it was then */
    }
    printf("  leg masses off: state hash %016llx (recorded before leg masses: 689033ade62055a7)\n",
           (unsigned long long)h);
    assert_true(h == UINT64_C(0x689033ade62055a7));
}

static void with_inertia(hs_params_t *p, double ic, double ir)
{
    for (int i = 0; i < HS_LEGS; ++i) {
        p->cyl[i].cylinder_inertia = ic;
        p->cyl[i].rod_inertia = ir;
    }
}

static void energy_conserved(double ic, double ir)
{
    hs_params_t p;
    hs_energy_t e0, e;
    double vel[3] = {0.02, -0.01, 0.03}, omega[3] = {0.01, 0.02, -0.015};
    double drift = 0.0, kin_min = 1e30, leg_kin;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    with_legs(&p, M_CYL, D_CYL, M_ROD, D_ROD);
    with_inertia(&p, ic, ir);
    for (int i = 0; i < HS_LEGS; ++i) {
        p.cyl[i].leakage = 0.0;
    }
    pt_no_friction(&p);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(plant.legs_on, 1);
    assert_int_equal(hs_plant_set_twist(&plant, vel, omega), HS_OK);
    assert_int_equal(hs_plant_energy(&plant, &e0), HS_OK);
    /* the legs' share of the kick's kinetic energy: the platform alone has
     * m v^2/2 + w^T I w/2 */
    {
        double iw[3];
        for (int k = 0; k < 3; ++k) {
            iw[k] = p.inertia[k][0] * omega[0] + p.inertia[k][1] * omega[1] + p.inertia[k][2] * omega[2];
        }
        leg_kin = e0.kinetic - 0.5 * p.mass * (vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2]) -
                  0.5 * (omega[0] * iw[0] + omega[1] * iw[1] + omega[2] * iw[2]);
    }
    for (int n = 0; n < 10000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        assert_int_equal(hs_plant_energy(&plant, &e), HS_OK);
        drift = fmax(drift, fabs(e.total - e0.total));
        kin_min = fmin(kin_min, e.kinetic);
    }
    printf("  leg masses on (inertia %g + %g kg m^2), closed valves, 10 s: energy %.3f J (kick %.4f J of which legs "
           "%.4f J, kinetic down to %.2e J), largest drift %.3e J\n",
           ic, ir, e0.total, e0.kinetic, leg_kin, kin_min, drift);
    assert_true(leg_kin > 0.01 * e0.kinetic);
    assert_true(kin_min < 0.1 * e0.kinetic);
    assert_true(drift < 1e-6 * e0.kinetic);
}

static void test_energy_conserved_with_legs(void **state)
{
    (void)state;
    energy_conserved(0.0, 0.0);
    energy_conserved(I_CYL, I_ROD);
}

static void test_rest_with_legs(void **state)
{
    hs_params_t p;
    double pose[6], f[HS_LEGS], worst = 0.0;
    hs_feedback_t fb;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    with_legs(&p, M_CYL, D_CYL, M_ROD, D_ROD);

    /* ideal mode after rebalance, 10 s */
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);
    hs_plant_set_forces(&plant, (double[HS_LEGS]){0, 0, 0, 0, 0, 0});
    assert_int_equal(hs_plant_rebalance(&plant), HS_OK);
    for (int n = 0; n < 10000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_pose(&plant, pose);
    printf("  leg masses on, ideal, rebalanced, 10 s: moved %.3e m, %.3e rad\n", pt_pos_error(pose, p.home),
           pt_rot_error(&pose[3], &p.home[3]));
    assert_true(pt_pos_error(pose, p.home) < 5e-6);
    assert_true(pt_rot_error(&pose[3], &p.home[3]) < 5e-6);

    /* control: the static forces that neglect the legs do not hold it */
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    assert_int_equal(hs_static_forces(&p, p.home, NULL, NULL, f), HS_OK);
    hs_plant_set_forces(&plant, f);
    for (int n = 0; n < 1000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_pose(&plant, pose);
    printf("  leg masses on, ideal, forces without legs, 1 s: moved %.3e m\n", pt_pos_error(pose, p.home));
    assert_true(pt_pos_error(pose, p.home) > 1e-4);

    /* hydraulic, drives holding, 10 s (init includes the legs' weight) */
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    for (int n = 0; n < 10000; ++n) {
        for (int i = 0; i < HS_LEGS; ++i) {
            assert_int_equal(hs_plant_set_setpoint(&plant, i, 0.0, 0.0, 0.0, HS_REQ_HOLD), HS_OK);
        }
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        hs_plant_pose(&plant, pose);
        worst = fmax(worst, pt_pos_error(pose, p.home));
    }
    printf("  leg masses on, hydraulic, drives holding, 10 s: largest excursion %.3f um\n", worst * 1e6);
    assert_true(worst < 5e-6);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_int_equal(hs_plant_feedback(&plant, i, &fb), HS_OK);
        assert_int_equal(fb.faults, 0u);
    }
}

static void test_static_forces_free_body(void **state)
{
    static const double poses[3][6] = {
        {0.0, 0.0, 2.55, 0.0, 0.0, 0.0}, {0.2, -0.15, 2.4, 0.1, -0.08, 0.2}, {-0.3, 0.2, 2.8, -0.15, 0.12, -0.3}};
    hs_params_t p, p0;
    (void)state;
    assert_int_equal(hs_params_default(&p0), HS_OK);
    pt_massless_legs(&p0);
    p = p0;
    with_legs(&p, M_CYL, D_CYL, M_ROD, D_ROD);
    for (int n = 0; n < 3; ++n) {
        double r[3][3], fsum[3] = {0.0, 0.0, 0.0}, msum[3] = {0.0, 0.0, 0.0}, vert = 0.0, vert0 = 0.0, expect = 0.0;
        double g = p.gravity, f0[HS_LEGS], worst_f, worst_m;
        assert_int_equal(hs_plant_init(&plant, &p, poses[n]), HS_OK);
        assert_int_equal(hs_plant_rebalance(&plant), HS_OK);
        assert_int_equal(hs_static_forces(&p0, poses[n], NULL, NULL, f0), HS_OK);
        hs_rot_from_rpy(&poses[n][3], r);
        for (int i = 0; i < HS_LEGS; ++i) {
            double arm[3], l[3], u[3], len = 0.0, k, gperp[3], gax, gj[3], onp[3], m[3];
            double fi = plant.ideal_force[i];
            for (int j = 0; j < 3; ++j) {
                arm[j] = r[j][0] * p.platform_joint[i][0] + r[j][1] * p.platform_joint[i][1] +
                         r[j][2] * p.platform_joint[i][2];
                l[j] = poses[n][j] + arm[j] - p.base_joint[i][j];
                len += l[j] * l[j];
            }
            len = sqrt(len);
            for (int j = 0; j < 3; ++j) {
                u[j] = l[j] / len;
            }
            /* G: force of the platform on the leg at its joint. Moments of
             * the whole leg about B: L u x G = (m_c d_c + m_r (L - d_r)) g u x e_z,
             * so G's part across the leg is k g (e_z - u_z u). The rod along
             * the leg: G.u + F - m_r g u_z = 0. */
            k = (M_CYL * D_CYL + M_ROD * (len - D_ROD)) / len;
            gax = M_ROD * g * u[2] - fi;
            for (int j = 0; j < 3; ++j) {
                gperp[j] = k * g * ((j == 2 ? 1.0 : 0.0) - u[2] * u[j]);
                gj[j] = gperp[j] + gax * u[j];
                onp[j] = -gj[j];
                fsum[j] += onp[j];
            }
            m[0] = arm[1] * onp[2] - arm[2] * onp[1];
            m[1] = arm[2] * onp[0] - arm[0] * onp[2];
            m[2] = arm[0] * onp[1] - arm[1] * onp[0];
            for (int j = 0; j < 3; ++j) {
                msum[j] += m[j];
            }
            vert += fi * u[2];
            vert0 += f0[i] * u[2];
            expect += g * (k * (1.0 - u[2] * u[2]) + M_ROD * u[2] * u[2]);
        }
        fsum[2] -= p.mass * g;
        worst_f = fmax(fabs(fsum[0]), fmax(fabs(fsum[1]), fabs(fsum[2])));
        worst_m = fmax(fabs(msum[0]), fmax(fabs(msum[1]), fabs(msum[2])));
        printf("  pose %d: vertical cylinder force %.3f N (without legs %.3f N): +%.3f N, free body expects +%.3f N; "
               "residual %.2e N, %.2e N m\n",
               n, vert, vert0, vert - vert0, expect, worst_f, worst_m);
        assert_true(worst_f < 1e-6);
        assert_true(worst_m < 1e-6);
        assert_near(vert - vert0, expect, 1e-6, "pose %d: vertical force of the legs' mass (N)", n);
        assert_true(vert - vert0 > 0.5 * 6.0 * M_ROD * g); /* really changed */
    }
}

static void test_point_masses_at_joints_are_rigid(void **state)
{
    hs_params_t p, q;
    double f[HS_LEGS], vel[3] = {0.05, -0.03, 0.04}, om[3] = {0.03, -0.05, 0.06}, a[6], b[6];
    (void)state;
    double pose[6];
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    /* the rigid body's o' must stay its centre of mass: platform joints in
     * the plane z' = 0 (their x', y' centroid is 0), the pose 0.25 m lower
     * so that the legs keep their home lengths */
    for (int i = 0; i < HS_LEGS; ++i) {
        p.platform_joint[i][2] = 0.0;
    }
    memcpy(pose, p.home, sizeof pose);
    pose[2] -= 0.25;
    q = p;
    with_legs(&p, M_CYL, 0.0, M_ROD, 0.0);
    q.mass += 6.0 * M_ROD;
    for (int i = 0; i < HS_LEGS; ++i) {
        const double *ai = q.platform_joint[i];
        double a2 = ai[0] * ai[0] + ai[1] * ai[1] + ai[2] * ai[2];
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) {
                q.inertia[r][c] += M_ROD * ((r == c ? a2 : 0.0) - ai[r] * ai[c]);
            }
        }
    }
    assert_int_equal(hs_plant_init(&plant, &p, pose), HS_OK);
    assert_int_equal(hs_plant_init(&plant2, &q, pose), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_near(plant.ideal_force[i], plant2.ideal_force[i], 1e-7 * fabs(plant2.ideal_force[i]),
                    "leg %d: ideal force with rods vs rods in the platform (N)", i);
        f[i] = plant2.ideal_force[i] * (1.0 + 0.002 * (double)(i - 2));
    }
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    hs_plant_set_actuation(&plant2, HS_ACT_IDEAL);
    hs_plant_set_forces(&plant, f);
    hs_plant_set_forces(&plant2, f);
    hs_plant_set_twist(&plant, vel, om);
    hs_plant_set_twist(&plant2, vel, om);
    for (int n = 0; n < 2000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        assert_int_equal(hs_plant_step(&plant2, DT), HS_OK);
    }
    hs_plant_pose(&plant, a);
    hs_plant_pose(&plant2, b);
    printf("  masses at the joints vs rigid platform, 2 s: moved %.3f m; differ by %.2e m, %.2e rad\n",
           pt_pos_error(a, pose), pt_pos_error(a, b), pt_rot_error(&a[3], &b[3]));
    assert_true(pt_pos_error(a, pose) > 0.01);
    assert_true(pt_pos_error(a, b) < 1e-9);
    assert_true(pt_rot_error(&a[3], &b[3]) < 1e-9);
}

/* Leg geometry and the two point masses' positions at state x. */
static void masses_at(const hs_params_t *p, const double *x, int i, double arm[3], double l[3], double c1[3],
                      double c2[3])
{
    double r[3][3], len;
    hs_rot_from_quat(&x[HS_X_QUAT], r);
    for (int j = 0; j < 3; ++j) {
        arm[j] =
            r[j][0] * p->platform_joint[i][0] + r[j][1] * p->platform_joint[i][1] + r[j][2] * p->platform_joint[i][2];
        l[j] = x[HS_X_POS + j] + arm[j] - p->base_joint[i][j];
    }
    len = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (int j = 0; j < 3; ++j) {
        c1[j] = p->base_joint[i][j] + D_CYL * l[j] / len;
        c2[j] = p->base_joint[i][j] + l[j] - D_ROD * l[j] / len;
    }
}

/* Angular momentum about o', base frame: R I w. */
static void ang_mom(const hs_params_t *p, const double *x, double h[3])
{
    double r[3][3], iw[3];
    hs_rot_from_quat(&x[HS_X_QUAT], r);
    for (int j = 0; j < 3; ++j) {
        iw[j] = p->inertia[j][0] * x[HS_X_OMEGA] + p->inertia[j][1] * x[HS_X_OMEGA + 1] +
                p->inertia[j][2] * x[HS_X_OMEGA + 2];
    }
    for (int j = 0; j < 3; ++j) {
        h[j] = r[j][0] * iw[0] + r[j][1] * iw[1] + r[j][2] * iw[2];
    }
}

/* 6. Newton-Euler cross-check of the leg dynamics, independent of the
 *    plant's virtual-work formulas: along a fast motion with leg masses on,
 *    the point masses' accelerations are taken by central differences of
 *    their positions (h = 0.5 ms), each leg's moment balance about its base
 *    joint and its rod's axial balance give the joint force G_i, and the
 *    platform must satisfy m v' + m g e_z + sum G_i = 0 and
 *    d(R I w)/dt + sum arm_i x G_i = 0 (v', (R I w)' also by differences).
 *    Bound: 1e-4 of the legs' inertial forces sum |m_k c_k''| (measured
 *    about 1e-6: the differences' own error). */
static void newton_euler_cross_check(double ic, double ir)
{
    hs_params_t p;
    double f[HS_LEGS], vel[3] = {0.3, -0.2, 0.25}, om[3] = {0.3, -0.4, 0.5};
    double xs[3][HS_NX], fq[HS_LEGS], h = 5e-4, spin = 0.0;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    with_legs(&p, M_CYL, D_CYL, M_ROD, D_ROD);
    with_inertia(&p, ic, ir);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    hs_plant_set_actuation(&plant, HS_ACT_IDEAL);
    for (int i = 0; i < HS_LEGS; ++i) {
        f[i] = plant.ideal_force[i] * (1.0 + 0.05 * (double)(i - 2));
    }
    hs_plant_set_forces(&plant, f);
    hs_plant_set_twist(&plant, vel, om);
    for (int n = 0; n < 400; ++n) {
        assert_int_equal(hs_plant_step(&plant, h), HS_OK);
    }
    for (int n = 0; n < 3; ++n) {
        memcpy(xs[n], plant.x, sizeof xs[n]);
        assert_int_equal(hs_plant_step(&plant, h), HS_OK);
    }
    memcpy(fq, f, sizeof fq);
    {
        double res_f[3], res_m[3], h0[3], h2[3], scale = 0.0, rf, rm;
        ang_mom(&p, xs[0], h0);
        ang_mom(&p, xs[2], h2);
        for (int j = 0; j < 3; ++j) {
            res_f[j] = p.mass * (xs[2][HS_X_VEL + j] - xs[0][HS_X_VEL + j]) / (2.0 * h);
            res_m[j] = (h2[j] - h0[j]) / (2.0 * h);
        }
        res_f[2] += p.mass * p.gravity;
        for (int i = 0; i < HS_LEGS; ++i) {
            double arm[3], l[3], c1[3][3], c2[3][3], a1[3], a2[3], w1[3], w2[3], mb[3], gp[3], len2, len, u[3];
            double gax, g[3], m[3], t1[3], t2[3], un[3][3], udd[3], hd[3];
            for (int n = 0; n < 3; ++n) {
                double ln;
                masses_at(&p, xs[n], i, arm, l, c1[n], c2[n]);
                ln = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
                for (int j = 0; j < 3; ++j) {
                    un[n][j] = l[j] / ln;
                }
            }
            masses_at(&p, xs[1], i, arm, l, c1[1], c2[1]);
            len2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
            len = sqrt(len2);
            for (int j = 0; j < 3; ++j) {
                u[j] = l[j] / len;
                a1[j] = (c1[2][j] - 2.0 * c1[1][j] + c1[0][j]) / (h * h);
                a2[j] = (c2[2][j] - 2.0 * c2[1][j] + c2[0][j]) / (h * h);
                w1[j] = M_CYL * a1[j];
                w2[j] = M_ROD * a2[j];
            }
            scale += sqrt(w1[0] * w1[0] + w1[1] * w1[1] + w1[2] * w1[2]) +
                     sqrt(w2[0] * w2[0] + w2[1] * w2[1] + w2[2] * w2[2]);
            w1[2] += M_CYL * p.gravity;
            w2[2] += M_ROD * p.gravity;
            /* moments about B_i of the masses' m (c'' + g e_z) = l x G */
            for (int j = 0; j < 3; ++j) {
                t1[j] = c1[1][j] - p.base_joint[i][j];
                t2[j] = c2[1][j] - p.base_joint[i][j];
            }
            mb[0] = t1[1] * w1[2] - t1[2] * w1[1] + t2[1] * w2[2] - t2[2] * w2[1];
            mb[1] = t1[2] * w1[0] - t1[0] * w1[2] + t2[2] * w2[0] - t2[0] * w2[2];
            mb[2] = t1[0] * w1[1] - t1[1] * w1[0] + t2[0] * w2[1] - t2[1] * w2[0];
            /* and the rate of the bodies' own angular momentum (I_c + I_r) u x u'' */
            for (int j = 0; j < 3; ++j) {
                udd[j] = (un[2][j] - 2.0 * un[1][j] + un[0][j]) / (h * h);
            }
            hd[0] = (ic + ir) * (u[1] * udd[2] - u[2] * udd[1]);
            hd[1] = (ic + ir) * (u[2] * udd[0] - u[0] * udd[2]);
            hd[2] = (ic + ir) * (u[0] * udd[1] - u[1] * udd[0]);
            spin += sqrt(hd[0] * hd[0] + hd[1] * hd[1] + hd[2] * hd[2]) / len;
            for (int j = 0; j < 3; ++j) {
                mb[j] += hd[j];
            }
            gp[0] = (mb[1] * l[2] - mb[2] * l[1]) / len2;
            gp[1] = (mb[2] * l[0] - mb[0] * l[2]) / len2;
            gp[2] = (mb[0] * l[1] - mb[1] * l[0]) / len2;
            gax = u[0] * w2[0] + u[1] * w2[1] + u[2] * w2[2] - fq[i];
            for (int j = 0; j < 3; ++j) {
                g[j] = gp[j] + gax * u[j];
                res_f[j] += g[j];
            }
            m[0] = arm[1] * g[2] - arm[2] * g[1];
            m[1] = arm[2] * g[0] - arm[0] * g[2];
            m[2] = arm[0] * g[1] - arm[1] * g[0];
            for (int j = 0; j < 3; ++j) {
                res_m[j] += m[j];
            }
        }
        rf = sqrt(res_f[0] * res_f[0] + res_f[1] * res_f[1] + res_f[2] * res_f[2]);
        rm = sqrt(res_m[0] * res_m[0] + res_m[1] * res_m[1] + res_m[2] * res_m[2]);
        printf("  Newton-Euler with leg masses (inertia %g + %g kg m^2): legs' inertial forces %.2f N in all, their "
               "spin's %.2f N; residual %.3e N, %.3e N m\n",
               ic, ir, scale, spin, rf, rm);
        assert_true(scale > 10.0);
        assert_true(ic + ir == 0.0 || spin > 1e-3 * scale);
        assert_true(rf < 1e-4 * scale);
        assert_true(rm < 1e-4 * scale);
    }
}

static void test_newton_euler_cross_check(void **state)
{
    (void)state;
    newton_euler_cross_check(0.0, 0.0);
    newton_euler_cross_check(I_CYL, I_ROD);
}

static void test_params_check(void **state)
{
    hs_params_t p;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    with_legs(&p, M_CYL, D_CYL, M_ROD, D_ROD);
    assert_int_equal(hs_params_check(&p), HS_OK);
    p.cyl[3].rod_mass = -1.0;
    assert_int_equal(hs_params_check(&p), HS_E_ARG);
    p.cyl[3].rod_mass = M_ROD;
    p.cyl[2].cylinder_com = p.leg_length_max + 0.01;
    assert_int_equal(hs_params_check(&p), HS_E_ARG);
    p.cyl[2].cylinder_com = NAN;
    assert_int_equal(hs_params_check(&p), HS_E_ARG);
    p.cyl[2].cylinder_com = D_CYL;
    p.cyl[1].rod_com = -0.1;
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_E_ARG);
    p.cyl[1].rod_com = D_ROD;
    with_inertia(&p, I_CYL, I_ROD);
    assert_int_equal(hs_params_check(&p), HS_OK);
    p.cyl[4].cylinder_inertia = -1.0;
    assert_int_equal(hs_params_check(&p), HS_E_ARG);
    p.cyl[4].cylinder_inertia = I_CYL;
    p.cyl[0].rod_inertia = INFINITY;
    assert_int_equal(hs_params_check(&p), HS_E_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_off_bit_identical),
        cmocka_unit_test(test_energy_conserved_with_legs),
        cmocka_unit_test(test_rest_with_legs),
        cmocka_unit_test(test_static_forces_free_body),
        cmocka_unit_test(test_point_masses_at_joints_are_rigid),
        cmocka_unit_test(test_newton_euler_cross_check),
        cmocka_unit_test(test_params_check),
    };
    return cmocka_run_group_tests_name("plant_legs", tests, NULL, NULL);
}
