/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Payload centre of mass and loads the config does not know (issue 14;
 * hs/plant.h, docs/explanation/plant.md "Centre of mass and loads").
 *
 * 1. Free fall (ideal mode, zero leg forces, gravity on) of a body whose
 *    centre of mass is 0.3 m off o', spinning: the centre of mass follows
 *    the parabola p_c0 + v_c0 t - g t^2 / 2 within 1e-9 m, total energy is
 *    constant within 1e-9 relative, the angular momentum about the centre
 *    of mass within 1e-9 relative, over 2 s.
 * 2. Energy, hydraulic mode, valves closed, no leakage or friction, centre
 *    of mass (0.2, -0.1, 0.15) m: after a kick kinetic + gravity + oil stays
 *    constant within 1e-6 of the kick over 5 s.
 * 3. Static forces vs hand computation: at home with the centre of mass at
 *    (d, 0, 0) the leg forces must carry m g vertically and the moment
 *    -m g d about y (computed here from the joints, not by the plant), to
 *    1e-6 N and 1e-6 N m, for d = 0.2 m and at a tilted pose for
 *    c = (0.1, 0.2, -0.1); in ideal mode these forces hold the platform
 *    within 5 um / 5 urad for 2 s, those of c = 0 let it tip by more than
 *    1 mrad in 1 s; hydraulic mode, drives holding: within 5 um for 5 s.
 * 4. hs_plant_add_mass: 300 kg at (0.2, 0, 0) gives the combined mass,
 *    centre and parallel-axes inertia exactly; a plant loaded so moves as a
 *    plant built with the combined body (2 s, 1e-12 m / rad); the result
 *    must be a rigid body (mass > 0, inertia about the centre valid), else
 *    HS_E_RANGE and nothing changes; removing the load again restores the
 *    original mass and inertia within 1e-12.
 * 5. Truth wrench: external wrench + contact force and moment about o'.
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

static hs_plant_t plant, plant2;

static void com_base(const hs_plant_t *pl, double pc[3])
{
    hs_state_t st;
    double r[3][3];
    hs_plant_state(pl, &st);
    hs_rot_from_quat(st.quat, r);
    for (int k = 0; k < 3; ++k) {
        pc[k] = st.pose[k] + r[k][0] * pl->par.com[0] + r[k][1] * pl->par.com[1] + r[k][2] * pl->par.com[2];
    }
}

/* Velocity of the centre of mass and angular momentum about it, base frame. */
static void com_motion(const hs_plant_t *pl, double vc[3], double hc[3])
{
    hs_state_t st;
    double r[3][3], rc[3], ic[3][3], iw[3], c2 = 0.0;
    const hs_params_t *p = &pl->par;
    hs_plant_state(pl, &st);
    hs_rot_from_quat(st.quat, r);
    for (int k = 0; k < 3; ++k) {
        rc[k] = r[k][0] * p->com[0] + r[k][1] * p->com[1] + r[k][2] * p->com[2];
        c2 += p->com[k] * p->com[k];
    }
    vc[0] = st.vel[0] + st.omega_base[1] * rc[2] - st.omega_base[2] * rc[1];
    vc[1] = st.vel[1] + st.omega_base[2] * rc[0] - st.omega_base[0] * rc[2];
    vc[2] = st.vel[2] + st.omega_base[0] * rc[1] - st.omega_base[1] * rc[0];
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            ic[j][k] = p->inertia[j][k] - p->mass * ((j == k ? c2 : 0.0) - p->com[j] * p->com[k]);
        }
    }
    for (int k = 0; k < 3; ++k) {
        iw[k] = ic[k][0] * st.omega_body[0] + ic[k][1] * st.omega_body[1] + ic[k][2] * st.omega_body[2];
    }
    for (int k = 0; k < 3; ++k) {
        hc[k] = r[k][0] * iw[0] + r[k][1] * iw[1] + r[k][2] * iw[2];
    }
}

static void set_com(hs_params_t *p, double cx, double cy, double cz)
{
    /* the config's inertia is about the centre of mass: move it to o' */
    double c[3] = {cx, cy, cz}, c2 = cx * cx + cy * cy + cz * cz;
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            p->inertia[j][k] += p->mass * ((j == k ? c2 : 0.0) - c[j] * c[k]);
        }
        p->com[j] = c[j];
    }
}

static void test_free_fall(void **state)
{
    hs_params_t p;
    double zero[HS_LEGS] = {0, 0, 0, 0, 0, 0};
    double v0[3] = {0.1, -0.05, 0.2}, w0[3] = {0.5, -0.3, 0.8};
    double pc0[3], vc0[3], hc0[3], pc[3], vc[3], hc[3], perr = 0.0, herr = 0.0, eerr = 0.0, hn;
    hs_energy_t e0, e;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    set_com(&p, 0.3, -0.1, 0.2);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(plant.com_on, 1);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);
    assert_int_equal(hs_plant_set_forces(&plant, zero), HS_OK);
    assert_int_equal(hs_plant_set_twist(&plant, v0, w0), HS_OK);
    com_base(&plant, pc0);
    com_motion(&plant, vc0, hc0);
    hn = sqrt(hc0[0] * hc0[0] + hc0[1] * hc0[1] + hc0[2] * hc0[2]);
    assert_int_equal(hs_plant_energy(&plant, &e0), HS_OK);
    for (int n = 1; n <= 2000; ++n) {
        double t = DT * n;
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        com_base(&plant, pc);
        com_motion(&plant, vc, hc);
        for (int k = 0; k < 3; ++k) {
            double want = pc0[k] + vc0[k] * t - (k == 2 ? 0.5 * p.gravity * t * t : 0.0);
            perr = fmax(perr, fabs(pc[k] - want));
            herr = fmax(herr, fabs(hc[k] - hc0[k]) / hn);
        }
        assert_int_equal(hs_plant_energy(&plant, &e), HS_OK);
        eerr = fmax(eerr, fabs(e.total - e0.total) / fabs(e0.total));
    }
    printf("  free fall, centre of mass 0.37 m off o', 2 s: parabola %.2e m, angular momentum %.2e, energy %.2e "
           "relative\n",
           perr, herr, eerr);
    assert_true(perr < 1e-9);
    assert_true(herr < 1e-9);
    assert_true(eerr < 1e-9);
}

static void test_energy_hydraulic(void **state)
{
    hs_params_t p;
    hs_energy_t e0, e;
    double vel[3] = {0.02, -0.01, 0.03}, omega[3] = {0.01, 0.02, -0.015}, drift = 0.0;
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    set_com(&p, 0.2, -0.1, 0.15);
    for (int i = 0; i < HS_LEGS; ++i) {
        p.cyl[i].leakage = 0.0;
    }
    pt_no_friction(&p);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_twist(&plant, vel, omega), HS_OK);
    assert_int_equal(hs_plant_energy(&plant, &e0), HS_OK);
    for (int n = 0; n < 5000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        assert_int_equal(hs_plant_energy(&plant, &e), HS_OK);
        drift = fmax(drift, fabs(e.total - e0.total));
    }
    printf("  centre of mass off o', valves closed, 5 s: drift %.2e J (kick %.3f J)\n", drift, e0.kinetic);
    assert_true(drift < 1e-6 * e0.kinetic);
}

/* Residual of the free-body equilibrium of the platform at `pose` with the
 * given leg forces: sum F_i u_i - (0,0,m g) and the moments about o' with
 * gravity at R c, computed here from the joints. */
static void residual(const hs_params_t *p, const double pose[6], const double f[HS_LEGS], double res[6])
{
    double r[3][3], rc[3], mg = p->mass * p->gravity;
    hs_rot_from_rpy(&pose[3], r);
    for (int k = 0; k < 3; ++k) {
        rc[k] = r[k][0] * p->com[0] + r[k][1] * p->com[1] + r[k][2] * p->com[2];
    }
    res[0] = res[1] = 0.0;
    res[2] = -mg;
    res[3] = -mg * rc[1]; /* (R c) x (0, 0, -m g) */
    res[4] = mg * rc[0];
    res[5] = 0.0;
    for (int i = 0; i < HS_LEGS; ++i) {
        double a[3], l[3], n = 0.0;
        for (int k = 0; k < 3; ++k) {
            a[k] = r[k][0] * p->platform_joint[i][0] + r[k][1] * p->platform_joint[i][1] +
                   r[k][2] * p->platform_joint[i][2];
            l[k] = pose[k] + a[k] - p->base_joint[i][k];
            n += l[k] * l[k];
        }
        n = sqrt(n);
        for (int k = 0; k < 3; ++k) {
            l[k] *= f[i] / n;
            res[k] += l[k];
        }
        res[3] += a[1] * l[2] - a[2] * l[1];
        res[4] += a[2] * l[0] - a[0] * l[2];
        res[5] += a[0] * l[1] - a[1] * l[0];
    }
}

static void test_static_forces(void **state)
{
    hs_params_t p, p0;
    double f[HS_LEGS], f0[HS_LEGS], res[6], my = 0.0, pose[6], tilt[6];
    (void)state;
    assert_int_equal(hs_params_default(&p0), HS_OK);
    pt_massless_legs(&p0);
    p = p0;
    set_com(&p, 0.2, 0.0, 0.0);
    assert_int_equal(hs_static_forces(&p, p.home, NULL, NULL, f), HS_OK);
    residual(&p, p.home, f, res);
    for (int k = 0; k < 6; ++k) {
        assert_near(res[k], 0.0, 1e-6, "equilibrium %d (N, N m)", k);
    }
    /* hand: gravity at (d, 0, 0) turns the platform about +y by m g d; the legs carry -m g d */
    {
        double r[6];
        double mg = p.mass * p.gravity;
        residual(&p0, p.home, f, r); /* same forces, but gravity at o': the residual is the moment they carry */
        my = r[4];
        printf("  centre of mass at x = 0.2 m: leg forces' moment about y %.6f N m (-m g d = %.6f)\n", my, -mg * 0.2);
        assert_near(my, -mg * 0.2, 1e-6, "-m g d (N m)");
    }
    /* ideal mode: these hold; those of c = 0 do not */
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);
    for (int n = 0; n < 2000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_pose(&plant, pose);
    printf("  ideal, centre of mass at x = 0.2 m, 2 s: moved %.2e m, %.2e rad\n", pt_pos_error(pose, p.home),
           pt_rot_error(&pose[3], &p.home[3]));
    assert_true(pt_pos_error(pose, p.home) < 5e-6 && pt_rot_error(&pose[3], &p.home[3]) < 5e-6);
    assert_int_equal(hs_static_forces(&p0, p.home, NULL, NULL, f0), HS_OK);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_actuation(&plant, HS_ACT_IDEAL), HS_OK);
    assert_int_equal(hs_plant_set_forces(&plant, f0), HS_OK);
    for (int n = 0; n < 1000; ++n) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    }
    hs_plant_pose(&plant, pose);
    printf("  ideal, forces for c = 0, 1 s: tipped %.2e rad\n", pt_rot_error(&pose[3], &p.home[3]));
    assert_true(pt_rot_error(&pose[3], &p.home[3]) > 1e-3);

    /* a tilted pose, a general centre */
    p = p0;
    set_com(&p, 0.1, 0.2, -0.1);
    memcpy(tilt, p.home, sizeof tilt);
    tilt[0] = 0.1;
    tilt[3] = 0.1;
    tilt[4] = -0.15;
    tilt[5] = 0.2;
    assert_int_equal(hs_static_forces(&p, tilt, NULL, NULL, f), HS_OK);
    residual(&p, tilt, f, res);
    for (int k = 0; k < 6; ++k) {
        assert_near(res[k], 0.0, 1e-6, "tilted equilibrium %d (N, N m)", k);
    }
    /* hydraulic, drives holding */
    {
        double worst = 0.0;
        assert_int_equal(hs_plant_init(&plant, &p, tilt), HS_OK);
        for (int n = 0; n < 5000; ++n) {
            for (int i = 0; i < HS_LEGS; ++i) {
                hs_plant_set_setpoint(&plant, i, 0.0, 0.0, 0.0, HS_REQ_HOLD);
            }
            assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
            hs_plant_pose(&plant, pose);
            worst = fmax(worst, pt_pos_error(pose, tilt));
        }
        printf("  hydraulic, tilted, centre (0.1, 0.2, -0.1), drives holding 5 s: %.3f um\n", worst * 1e6);
        assert_true(worst < 5e-6);
    }
}

static void test_add_mass(void **state)
{
    hs_params_t p, q;
    double pt[3] = {0.2, 0.0, 0.0}, far[3] = {10.0, 0.0, 0.0}, v0[3] = {0.05, 0.0, -0.02}, w0[3] = {0.1, 0.2, 0.0};
    double a[6], b[6], zero[HS_LEGS] = {0, 0, 0, 0, 0, 0};
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_add_mass(&plant, 300.0, pt), HS_OK);
    assert_near(plant.par.mass, 2800.0, 0.0, "mass (kg)");
    assert_near(plant.par.com[0], 60.0 / 2800.0, 1e-15, "centre x (m)");
    assert_near(plant.par.com[1], 0.0, 0.0, "centre y (m)");
    assert_near(plant.par.inertia[0][0], p.inertia[0][0], 0.0, "Ixx (kg m^2)");
    assert_near(plant.par.inertia[1][1], p.inertia[1][1] + 12.0, 1e-12, "Iyy (kg m^2)");
    assert_near(plant.par.inertia[2][2], p.inertia[2][2] + 12.0, 1e-12, "Izz (kg m^2)");
    assert_near(plant.par.inertia[0][2], p.inertia[0][2], 0.0, "Ixz (kg m^2)");
    assert_int_equal(plant.com_on, 1);
    /* invalid results: refused, nothing changes */
    q = plant.par;
    assert_int_equal(hs_plant_add_mass(&plant, -2800.0, pt), HS_E_RANGE);
    assert_int_equal(hs_plant_add_mass(&plant, -100.0, far), HS_E_RANGE);
    assert_int_equal(hs_plant_add_mass(&plant, NAN, pt), HS_E_ARG);
    assert_int_equal(hs_plant_add_mass(NULL, 1.0, pt), HS_E_ARG);
    assert_memory_equal(&q, &plant.par, sizeof q);
    /* off again */
    assert_int_equal(hs_plant_add_mass(&plant, -300.0, pt), HS_OK);
    assert_near(plant.par.mass, 2500.0, 0.0, "mass back (kg)");
    assert_near(plant.par.com[0], 0.0, 1e-15, "centre back (m)");
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            assert_near(plant.par.inertia[j][k], p.inertia[j][k], 1e-12, "inertia back (kg m^2)");
        }
    }
    /* a loaded plant moves as one built with the combined body */
    q = p;
    q.mass = 2800.0;
    q.com[0] = 60.0 / 2800.0;
    q.inertia[1][1] += 12.0;
    q.inertia[2][2] += 12.0;
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_add_mass(&plant, 300.0, pt), HS_OK);
    assert_int_equal(hs_plant_init(&plant2, &q, p.home), HS_OK);
    for (hs_plant_t *pl = &plant; pl != NULL; pl = (pl == &plant) ? &plant2 : NULL) {
        assert_int_equal(hs_plant_rebalance(pl), HS_OK);
        assert_int_equal(hs_plant_set_actuation(pl, HS_ACT_IDEAL), HS_OK);
        assert_int_equal(hs_plant_set_forces(pl, zero), HS_OK);
        assert_int_equal(hs_plant_set_twist(pl, v0, w0), HS_OK);
        for (int n = 0; n < 2000; ++n) {
            assert_int_equal(hs_plant_step(pl, DT), HS_OK);
        }
    }
    hs_plant_pose(&plant, a);
    hs_plant_pose(&plant2, b);
    printf("  300 kg at 0.2 m added vs built in, 2 s: %.2e m, %.2e rad\n", pt_pos_error(a, b),
           pt_rot_error(&a[3], &b[3]));
    assert_true(pt_pos_error(a, b) < 1e-12 && pt_rot_error(&a[3], &b[3]) < 1e-12);
}

static void test_truth_wrench(void **state)
{
    hs_params_t p;
    hs_contact_t ct;
    hs_state_t st;
    double fe[3] = {100.0, -200.0, 300.0}, me[3] = {10.0, 20.0, -30.0}, m[3];
    (void)state;
    assert_int_equal(hs_params_default(&p), HS_OK);
    pt_massless_legs(&p);
    assert_int_equal(hs_plant_init(&plant, &p, p.home), HS_OK);
    assert_int_equal(hs_plant_set_wrench(&plant, fe, me), HS_OK);
    memset(&ct, 0, sizeof ct);
    ct.kind = HS_CONTACT_POINT;
    ct.point[0] = 0.5;
    ct.point[2] = -0.1;
    ct.anchor[0] = 0.5;
    ct.anchor[1] = 0.01;
    ct.anchor[2] = p.home[2] - 0.1;
    ct.stiffness = 1e5;
    assert_int_equal(hs_plant_set_contact(&plant, &ct), HS_OK);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    /* contact force (0, 1000, 0) N at (0.5, 0, -0.1) from o' */
    m[0] = 0.0 * 0.0 - (-0.1) * 1000.0;
    m[1] = 0.0;
    m[2] = 0.5 * 1000.0;
    for (int k = 0; k < 3; ++k) {
        assert_near(st.wrench[k], fe[k] + (k == 1 ? 1000.0 : 0.0), 1e-9, "wrench force %d (N)", k);
        assert_near(st.wrench[3 + k], me[k] + m[k], 1e-9, "wrench moment %d (N m)", k);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_free_fall), cmocka_unit_test(test_energy_hydraulic), cmocka_unit_test(test_static_forces),
        cmocka_unit_test(test_add_mass),  cmocka_unit_test(test_truth_wrench),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
