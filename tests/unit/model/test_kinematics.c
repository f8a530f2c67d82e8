/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of the fixed-point kinematics and dynamics (sp/model/kinematics.h,
 * sp/model/dynamics.h) on random 6-6 geometries and random poses, against the
 * double-precision reference model (tests/support/ref_model.h), and of the
 * rate functions' fast paths against plain references over their inputs'
 * whole range. (The independent float64 model in tools/stewart/model.py is
 * compared with the core in tests/python as well, on 10,000 poses; the 6x6
 * solves are tested in test_lu6.c.)
 *
 * Tolerances:
 *   T entries                       4e-9 (4 LSB of Q30), orthonormal to 8e-9
 *   leg lengths                     0.2 um
 *   unit vectors                    5e-8 (the leg vector is Q24: 60 nm)
 *   leg rates                       1e-6 m/s against the model (which is
 *                                   checked against finite differences);
 *                                   the rounding bound of each step against
 *                                   the plain reference (test_leg_rates_reference)
 *   body rates and derivatives      1e-6 rad/s, rad/s^2 against the model;
 *                                   0.53 and 3.3 LSB against the plain
 *                                   reference (test_body_rates_reference)
 *   forward kinematics              1 um, 5 urad; <= 3 iterations warm-started
 *                                   from a 1 kHz neighbour, <= 8 cold from home
 *   inverse dynamics                0.05 N: the forces reproduce the wrench
 *                                   the motion needs (checked in double)
 *   length sensors                  1 LSB of Q24 against the double model,
 *                                   bit for bit without calibration, the
 *                                   round trip within 2 LSB
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

#include "model/model_internal.h"
#include "math/fixed_inline.h"
#include "assert_near.h"
#include "ref_model.h"
#include "sp/model/dynamics.h"
#include "sp/model/frames.h"
#include "sp/model/kinematics.h"
#include "sp/motion/limits.h"
#include "test_util.h"

#define N_POSES 3000
#define DEG (3.14159265358979323846 / 180.0)

/* A random, plausible 6-6 geometry: joint pairs on two circles, legs reaching
 * to the neighbouring pair, platform joints below the centroid. */
static void random_platform(uint64_t *rng, sp_platform_t *p, double *home_z)
{
    double rb = tu_uniform(rng, 1.2, 2.0);
    double rp = tu_uniform(rng, 0.6, 1.3);
    double hb = tu_uniform(rng, 6.0, 15.0) * DEG;
    double hp = tu_uniform(rng, 5.0, 12.0) * DEG;
    double zoff = tu_uniform(rng, -0.4, 0.1);
    memset(p, 0, sizeof *p);
    for (int k = 0; k < 3; ++k) {
        double cb = (120.0 * k - 90.0) * DEG;
        double cp = (120.0 * k - 30.0) * DEG;
        for (int s = 0; s < 2; ++s) {
            int i = 2 * k + s;
            double ab = cb + (s ? hb : -hb);
            /* leg 2k reaches back to the previous platform pair, leg 2k+1 forward */
            double ap = s ? cp - hp : cp - 120.0 * DEG + hp;
            p->base_joint[i][0] = ref_q24(rb * cos(ab));
            p->base_joint[i][1] = ref_q24(rb * sin(ab));
            p->base_joint[i][2] = 0;
            p->platform_joint[i][0] = ref_q24(rp * cos(ap));
            p->platform_joint[i][1] = ref_q24(rp * sin(ap));
            p->platform_joint[i][2] = ref_q24(zoff);
        }
    }
    p->mass = ref_q16(tu_uniform(rng, 500.0, 6000.0));
    {
        double ixx = tu_uniform(rng, 300.0, 4000.0);
        double iyy = tu_uniform(rng, 300.0, 4000.0);
        double izz = ixx + iyy - tu_uniform(rng, 0.0, 200.0);
        double ixz = tu_uniform(rng, -80.0, 80.0);
        double ixy = tu_uniform(rng, -50.0, 50.0);
        p->inertia[0][0] = ref_q16(ixx);
        p->inertia[1][1] = ref_q16(iyy);
        p->inertia[2][2] = ref_q16(izz);
        p->inertia[0][2] = p->inertia[2][0] = ref_q16(ixz);
        p->inertia[0][1] = p->inertia[1][0] = ref_q16(ixy);
    }
    p->gravity = ref_q24(9.80665);
    *home_z = tu_uniform(rng, 1.8, 2.6);
    p->home.pos[2] = ref_q24(*home_z);
    p->leg_length_min = ref_q24(0.5);
    p->leg_length_max = ref_q24(5.0);
    p->force_max = (int32_t)(500000 * 256);
    p->leg_velocity_max = ref_q24(2.0);
}

static void random_pose(uint64_t *rng, double home_z, sp_pose_t *pose, double q[6])
{
    q[0] = tu_uniform(rng, -0.2, 0.2);
    q[1] = tu_uniform(rng, -0.2, 0.2);
    q[2] = home_z + tu_uniform(rng, -0.15, 0.15);
    for (int k = 3; k < 6; ++k) {
        q[k] = tu_uniform(rng, -15.0, 15.0) * DEG;
    }
    for (int k = 0; k < 3; ++k) {
        pose->pos[k] = ref_q24(q[k]);
        pose->rpy[k] = ref_q24(q[3 + k]);
        q[k] = ref_f24(pose->pos[k]); /* the exact value the core sees */
        q[3 + k] = ref_f24(pose->rpy[k]);
    }
}

static void test_orientation(void **state)
{
    uint64_t rng = 11;
    (void)state;
    assert_int_equal(sp_orientation(NULL, NULL), SP_E_ARG);
    for (int n = 0; n < N_POSES; ++n) {
        sp_q24_t rpy[3];
        double a[3];
        double r[3][3];
        sp_rot_t t;
        for (int k = 0; k < 3; ++k) {
            rpy[k] = ref_q24(tu_uniform(&rng, -3.2, 3.2));
            a[k] = ref_f24(rpy[k]);
        }
        assert_int_equal(sp_orientation(rpy, &t), SP_OK);
        ref_rot(a, r);
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                double dot = 0;
                /* the paper's T is the transpose of R */
                assert_near(ref_f30(t.t[i][j]), r[j][i], 4e-9, "T[%d][%d] of (%d, %d, %d)", i, j, rpy[0], rpy[1],
                            rpy[2]);
                for (int k = 0; k < 3; ++k) {
                    dot += ref_f30(t.t[i][k]) * ref_f30(t.t[j][k]);
                }
                assert_near(dot, i == j ? 1.0 : 0.0, 8e-9, "row %d . row %d of T", i, j);
            }
        }
    }
}

static void test_inverse_kinematics(void **state)
{
    uint64_t rng = 12;
    double worst_len = 0;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t pose;
        double q[6];
        sp_ik_t ik;
        double len[6], unit[6][3], arm[6][3];
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &pose, q);
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        ref_ik(&p, q, len, unit, arm);
        for (int i = 0; i < 6; ++i) {
            double e = fabs(ref_f24(ik.length[i]) - len[i]);
            worst_len = e > worst_len ? e : worst_len;
            assert_near(ref_f24(ik.length[i]), len[i], 0.2e-6, "pose %d: leg %d length", n, i);
            for (int c = 0; c < 3; ++c) {
                assert_near(ref_f30(ik.unit[i][c]), unit[i][c], 5e-8, "pose %d: leg %d unit[%d]", n, i, c);
            }
        }
    }
    print_message("IK worst length error %.3g m\n", worst_len);
}

static void test_ik_rejects_bad_input(void **state)
{
    sp_platform_t p;
    sp_pose_t pose;
    sp_ik_t ik;
    uint64_t rng = 13;
    double hz;
    (void)state;
    random_platform(&rng, &p, &hz);
    memset(&pose, 0, sizeof pose);
    assert_int_equal(sp_inverse_kinematics(NULL, &pose, &ik), SP_E_ARG);
    assert_int_equal(sp_inverse_kinematics(&p, NULL, &ik), SP_E_ARG);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, NULL), SP_E_ARG);
    pose.pos[0] = INT32_MAX; /* 128 m away: leg vector beyond 64 m */
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_RANGE);
    /* a platform joint exactly on its base joint: zero-length leg */
    pose.pos[0] = 0;
    for (int c = 0; c < 3; ++c) {
        p.platform_joint[0][c] = p.base_joint[0][c];
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_RANGE);
}

/* The IK's paths off the common one: legs shorter than 2^16 LSB (3.9 mm,
 * the square root's small-argument path) down to the 1 mm minimum; leg
 * components whose int32 intermediate pos - b overflows although the leg is
 * in range (the int64 path); an arm that saturates (SP_E_OVERFLOW). */
static void test_ik_edge_paths(void **state)
{
    sp_platform_t p;
    sp_pose_t pose;
    sp_ik_t ik;
    (void)state;
    memset(&p, 0, sizeof p);
    memset(&pose, 0, sizeof pose);
    /* every leg along x, 2 mm (small-argument root), 1.5 mm, 0.9 mm */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.platform_joint[i][1] = ref_q24(0.1 * i);
        p.base_joint[i][1] = ref_q24(0.1 * i);
        p.base_joint[i][0] = -ref_q24(0.002);
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(ik.length[i], ref_q24(0.002));
        assert_true(ik.unit[i][0] <= (INT32_C(1) << 30) && ik.unit[i][0] >= (INT32_C(1) << 30) - 3); /* 3 LSB */
        assert_int_equal(ik.unit[i][1], 0);
    }
    p.base_joint[3][0] = -ref_q24(0.0015);
    p.base_joint[3][2] = ref_q24(0.0002);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    assert_near(ref_f24(ik.length[3]), sqrt(0.0015 * 0.0015 + 0.0002 * 0.0002), 0.5 / 16777216.0 + 1e-12,
                "1.5 mm leg length");
    p.base_joint[3][0] = -ref_q24(0.0009);
    p.base_joint[3][2] = 0;
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_RANGE);

    /* x: pos - b = 2^31 - 1 + 2^30 - 10 leaves int32, arm -2^31 brings the
     * leg back to 2^30 - 11 (just under 64 m); then the mirror image */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.platform_joint[i][0] = INT32_MIN;
        p.base_joint[i][0] = -(INT32_C(1) << 30) + 10;
    }
    pose.pos[0] = INT32_MAX;
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(ik.arm[i][0], INT32_MIN);
        assert_int_equal(ik.leg[i][0], (INT32_C(1) << 30) - 11);
        assert_int_equal(ik.length[i], (INT32_C(1) << 30) - 11);
    }
    p.base_joint[0][0] -= 12; /* leg 0 reaches 64 m: out of range */
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_RANGE);
    for (int i = 0; i < SP_LEGS; ++i) {
        p.platform_joint[i][0] = INT32_MAX;
        p.base_joint[i][0] = (INT32_C(1) << 30) - 10;
    }
    pose.pos[0] = INT32_MIN;
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    assert_int_equal(ik.leg[0][0], -(INT32_C(1) << 30) + 9);

    /* the 64 m limit exactly, on the int32 path, in each component and
     * either sign: +-(2^30 - 1) is accepted, +-2^30 is not */
    memset(&pose, 0, sizeof pose);
    for (int c = 0; c < 3; ++c) {
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            for (int i = 0; i < SP_LEGS; ++i) {
                for (int k = 0; k < 3; ++k) {
                    p.platform_joint[i][k] = 0;
                    p.base_joint[i][k] = 0;
                }
                p.base_joint[i][c] = -sgn * ((INT32_C(1) << 30) - 1);
            }
            assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
            assert_int_equal(ik.leg[5][c], sgn * ((INT32_C(1) << 30) - 1));
            assert_int_equal(ik.length[5], (INT32_C(1) << 30) - 1);
            p.base_joint[4][c] = -sgn * (INT32_C(1) << 30);
            assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_RANGE);
        }
    }

    /* an arm of 128 m * sqrt(2) at yaw 45 degrees saturates; its leg stays
     * in range, so the IK completes with SP_E_OVERFLOW */
    memset(&pose, 0, sizeof pose);
    for (int i = 0; i < SP_LEGS; ++i) {
        p.platform_joint[i][0] = INT32_MAX;
        p.platform_joint[i][1] = INT32_MAX;
        p.platform_joint[i][2] = 0;
        p.base_joint[i][0] = 0;
        p.base_joint[i][1] = INT32_MAX - ref_q24(1.0);
        p.base_joint[i][2] = 0;
    }
    pose.rpy[2] = ref_q24(45.0 * DEG);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_OVERFLOW);
    assert_near(ik.arm[0][0], 0, 255, "arm x (LSB), 128 m (cos 45 - sin 45)");
    assert_int_equal(ik.arm[0][1], INT32_MAX);
    assert_near(ik.length[0], ref_q24(1.0), 255, "length (LSB) beside a saturated arm");
    pose.rpy[2] = -ref_q24(45.0 * DEG); /* the x component saturates */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.base_joint[i][0] = INT32_MAX - ref_q24(1.0);
        p.base_joint[i][1] = 0;
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_OVERFLOW);
    assert_int_equal(ik.arm[0][0], INT32_MAX);
    /* and negative: a joint at (-128 m, -128 m), base at (-127 m, 0) */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.platform_joint[i][0] = INT32_MIN;
        p.platform_joint[i][1] = INT32_MIN;
        p.base_joint[i][0] = INT32_MIN + ref_q24(1.0);
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_OVERFLOW);
    assert_int_equal(ik.arm[0][0], INT32_MIN);
    assert_near(ik.length[0], ref_q24(1.0), 255, "length (LSB) beside a saturated arm");
}

/* The leg rates against the reference model: the core's rates on the
 * core's IK against ref_leg_rates of the model's w = R w_body (the
 * orientation's and rates' rounding: 1e-6 m/s), and the model against a
 * central difference of the model's IK along the motion (1e-6 m/s). The
 * stretch is the length minus the home length, exactly. */
static void test_leg_rates_and_stretch(void **state)
{
    uint64_t rng = 14;
    (void)state;
    for (int n = 0; n < 500; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t pose;
        sp_pose_t pose2;
        double q[6];
        double qd[6];
        sp_q24_t vel[3];
        sp_q24_t rate[3];
        sp_q24_t legrate[6];
        sp_q24_t stretch[6];
        sp_ik_t ik;
        sp_ik_t home_ik;
        double dt = 1e-5;
        double len1[6], len2[6], unit[6][3], arm[6][3], r[3][3];
        double w_body[3], w[3], unused[3], want[6];
        double q1[6], q2[6];
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &pose, q);
        for (int k = 0; k < 3; ++k) {
            vel[k] = ref_q24(tu_uniform(&rng, -1.0, 1.0));
            rate[k] = ref_q24(tu_uniform(&rng, -1.0, 1.0));
            qd[k] = ref_f24(vel[k]);
            qd[3 + k] = ref_f24(rate[k]);
        }
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        assert_int_equal(sp_leg_rates(&ik, vel, rate, legrate), SP_OK);
        ref_ik(&p, q, NULL, unit, arm);
        ref_rot(&q[3], r);
        ref_body_rates(&q[3], &qd[3], &qd[3], w_body, unused);
        for (int c = 0; c < 3; ++c) {
            w[c] = r[c][0] * w_body[0] + r[c][1] * w_body[1] + r[c][2] * w_body[2];
        }
        ref_leg_rates(unit, arm, qd, w, want);
        /* the model's rates: a central difference of its IK */
        for (int k = 0; k < 6; ++k) {
            q1[k] = q[k] - qd[k] * dt;
            q2[k] = q[k] + qd[k] * dt;
        }
        ref_ik(&p, q1, len1, NULL, NULL);
        ref_ik(&p, q2, len2, NULL, NULL);
        for (int i = 0; i < 6; ++i) {
            assert_near(ref_f24(legrate[i]), want[i], 1e-6, "motion %d: leg %d rate", n, i);
            assert_near(want[i], (len2[i] - len1[i]) / (2 * dt), 1e-6, "motion %d: leg %d model rate vs difference", n,
                        i);
        }
        pose2 = p.home;
        assert_int_equal(sp_inverse_kinematics(&p, &pose2, &home_ik), SP_OK);
        assert_int_equal(sp_leg_stretch(&ik, &home_ik, stretch), SP_OK);
        for (int i = 0; i < 6; ++i) {
            assert_int_equal(stretch[i], ik.length[i] - home_ik.length[i]);
        }
    }
}

/* A value in [-max, max]: uniform, or (half the time) with a magnitude
 * log-uniform in [1e-4, max], so that small values come up as well. */
static double random_rate(uint64_t *rng, double max)
{
    uint64_t r = tu_next(rng);
    double m = (r & 1u) ? tu_uniform(rng, 0.0, max) : max * exp(tu_uniform(rng, log(1e-4 / max), 0.0));
    return (r & 2u) ? m : -m;
}

/* The plain reference of sp_leg_rates: the header's formula in double on
 * the IK's own values, w = roll_rate (row 0 of T) + pitch_rate (-sin yaw,
 * cos yaw, 0) + yaw_rate e_z (base frame), rate_i = u_i . (vel + w x
 * arm_i). For the saturation test: the largest |w_c| goes to *w_max, the
 * largest joint velocity component or rate to *v_max, the largest
 * component of a w x arm_i to *c_max. */
static void plain_leg_rates(const sp_ik_t *ik, const sp_q24_t vel[3], const sp_q24_t rpy_rate[3], double rate[SP_LEGS],
                            double *w_max, double *v_max, double *c_max)
{
    double dr = ref_f24(rpy_rate[0]), dp = ref_f24(rpy_rate[1]), dy = ref_f24(rpy_rate[2]);
    double w[3], v[3], unit[SP_LEGS][3], arm[SP_LEGS][3];
    w[0] = dr * ref_f30(ik->rot.t[0][0]) - dp * ref_f30(ik->sc[4]);
    w[1] = dr * ref_f30(ik->rot.t[0][1]) + dp * ref_f30(ik->sc[5]);
    w[2] = dr * ref_f30(ik->rot.t[0][2]) + dy;
    *w_max = *v_max = *c_max = 0;
    for (int c = 0; c < 3; ++c) {
        v[c] = ref_f24(vel[c]);
        *w_max = fmax(*w_max, fabs(w[c]));
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        for (int c = 0; c < 3; ++c) {
            unit[i][c] = ref_f30(ik->unit[i][c]);
            arm[i][c] = ref_f24(ik->arm[i][c]);
        }
        for (int c = 0; c < 3; ++c) {
            const double *a = arm[i];
            double cross = w[(c + 1) % 3] * a[(c + 2) % 3] - w[(c + 2) % 3] * a[(c + 1) % 3];
            *c_max = fmax(*c_max, fabs(cross));
            *v_max = fmax(*v_max, fabs(v[c] + cross));
        }
    }
    ref_leg_rates(unit, arm, v, w, rate);
    for (int i = 0; i < SP_LEGS; ++i) {
        *v_max = fmax(*v_max, fabs(rate[i]));
    }
}

/* sp_leg_rates, both paths (|w_c| below 64 rad/s, and the wide one), on
 * 6000 random IKs and rates up to 100 rad/s and 60 m/s, against
 * plain_leg_rates. The core rounds w (0.5 LSB of Q24 each), each joint
 * velocity component and the rate (0.5 LSB each), so when nothing
 * saturates |error| <= 0.5 + sum_c |u_c| (0.5 + (|r_c+1| + |r_c+2|) / 2)
 * LSB, r in m. When w, a joint velocity or a rate passes 128 (by 0.1),
 * or on the wide path a component of w x arm_i (each step saturates on its
 * own there), the result is SP_E_OVERFLOW. */
static void test_leg_rates_reference(void **state)
{
    uint64_t rng = 43;
    int wide = 0;
    int saturated = 0;
    double worst = 0;
    (void)state;
    for (int n = 0; n < 6000; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t pose;
        double q[6];
        sp_ik_t ik;
        sp_q24_t vel[3], rr[3], rate[SP_LEGS];
        double want[SP_LEGS], w_max, v_max, c_max, lo, hi;
        sp_status_t st;
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &pose, q);
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        for (int k = 0; k < 3; ++k) {
            vel[k] = ref_q24(random_rate(&rng, 60.0));
            rr[k] = ref_q24(random_rate(&rng, 100.0));
        }
        st = sp_leg_rates(&ik, vel, rr, rate);
        plain_leg_rates(&ik, vel, rr, want, &w_max, &v_max, &c_max);
        /* what must stay below 128: w, the joint velocities and rates,
         * and on the wide path (|w_c| >= 64) each w x arm_i on its own;
         * lo and hi bound it (the path is open within 0.1 of 64) */
        lo = hi = fmax(w_max, v_max);
        if (w_max >= 63.9) {
            hi = fmax(hi, c_max);
        }
        if (w_max > 64.1) {
            lo = hi;
        }
        if (lo > 128.1) {
            assert_int_equal(st, SP_E_OVERFLOW);
            ++saturated;
            continue;
        }
        if (hi > 127.9) {
            continue; /* at the limit: either */
        }
        assert_int_equal(st, SP_OK);
        wide += w_max > 64.1;
        for (int i = 0; i < SP_LEGS; ++i) {
            double tol = 0.5;
            for (int c = 0; c < 3; ++c) {
                double r1 = ref_f24(ik.arm[i][(c + 1) % 3]), r2 = ref_f24(ik.arm[i][(c + 2) % 3]);
                tol += fabs(ref_f30(ik.unit[i][c])) * (0.5 + (fabs(r1) + fabs(r2)) / 2);
            }
            worst = fmax(worst, fabs(rate[i] - want[i] * 16777216.0) / tol);
            assert_near(rate[i], want[i] * 16777216.0, tol, "case %d: leg %d rate (LSB), |w| %.1f rad/s", n, i, w_max);
        }
    }
    print_message("leg rates: %d of 6000 checked on the wide path, %d saturated; worst error %.2f of the bound\n", wide,
                  saturated, worst);
    assert_true(wide >= 1000 && saturated >= 100);
}

/* The plain reference of sp_body_rates_sc, ref_body_rates_sc, on the Q30
 * sines and cosines as given. */
static void plain_body_rates(const sp_q30_t sc[6], const sp_q24_t d[3], const sp_q24_t dd[3], double w[3], double wd[3])
{
    const double s[4] = {ref_f30(sc[0]), ref_f30(sc[1]), ref_f30(sc[2]), ref_f30(sc[3])};
    const double dv[3] = {ref_f24(d[0]), ref_f24(d[1]), ref_f24(d[2])};
    const double ddv[3] = {ref_f24(dd[0]), ref_f24(dd[1]), ref_f24(dd[2])};
    ref_body_rates_sc(s, dv, ddv, w, wd);
}

/* floor((v + 2^(s-1)) / 2^s): the core's rounding of a row (ties up). */
static int64_t round_up_shift(int64_t v, unsigned s)
{
    return (v + (INT64_C(1) << (s - 1u))) >> s;
}

/* sp_body_rates_sc's rows on the unit circle as first written: every term,
 * each row's exact int64 sum rounded once (ties up); for results in range. */
static void int_body_rates(const sp_q30_t sc[6], const sp_q24_t d[3], const sp_q24_t dd[3], sp_q24_t w[3],
                           sp_q24_t wd[3])
{
    const int64_t one = INT64_C(1) << 30;
    int64_t sr = sc[0], cr = sc[1], sp = sc[2], cp = sc[3];
    int64_t cpsr = round_up_shift(cp * sr, 30u), cpcr = round_up_shift(cp * cr, 30u);
    int64_t spsr = round_up_shift(sp * sr, 30u), spcr = round_up_shift(sp * cr, 30u);
    int64_t dr = d[0], dp = d[1], dy = d[2];
    int64_t dp_dr = round_up_shift(dp * dr, 24u), dy_dp = round_up_shift(dy * dp, 24u);
    int64_t dy_dr = round_up_shift(dy * dr, 24u);
    w[0] = (sp_q24_t)round_up_shift(dr * one - dy * sp, 30u);
    w[1] = (sp_q24_t)round_up_shift(dp * cr + dy * cpsr, 30u);
    w[2] = (sp_q24_t)round_up_shift(dy * cpcr - dp * sr, 30u);
    wd[0] = (sp_q24_t)round_up_shift(dd[0] * one - dd[2] * sp - dy_dp * cp, 30u);
    wd[1] = (sp_q24_t)round_up_shift(dd[1] * cr - dp_dr * sr + dd[2] * cpsr - dy_dp * spsr + dy_dr * cpcr, 30u);
    wd[2] = (sp_q24_t)round_up_shift(dd[2] * cpcr - dd[1] * sr - dp_dr * cr - dy_dp * spcr - dy_dr * cpsr, 30u);
}

/* sp_body_rates_sc, both paths (sines and cosines on the unit circle, and
 * off it: the saturating path), on 6000 random inputs (rates up to 4 rad/s,
 * accelerations up to 32 rad/s^2, |sin|, |cos| up to 1.25), against
 * plain_body_rates; on the circle, every path (yaw alone, level or not,
 * among them) equals the rows as first written (int_body_rates) bit for
 * bit, and sp_body_rates is sp_body_rates_sc of sp_sincos_q24's values. The core rounds the products of two
 * sines or cosines (0.5 LSB of Q30: 2^-7 LSB of Q24 per rad/s they
 * multiply), the products of two rates (0.5 LSB) and each result (0.5 LSB):
 * within these ranges |error| <= 0.5 + 4 / 128 LSB for w, and 0.5 + 0.5
 * (1.25 + 2 * 1.25^2) + (32 + 2 * 16) / 128 LSB (3.3) for its derivative.
 * A result past 128 (by 0.1) is SP_E_OVERFLOW. */
static void test_body_rates_reference(void **state)
{
    const double tol_w = 0.5 + 4.0 / 128.0;
    const double tol_wd = 0.5 + 0.5 * (1.25 + 2.0 * 1.25 * 1.25) + (32.0 + 2.0 * 16.0) / 128.0;
    uint64_t rng = 47;
    int off_circle = 0;
    double worst_w = 0, worst_wd = 0;
    (void)state;
    for (int n = 0; n < 6000; ++n) {
        sp_q24_t a[3], d[3], dd[3], w[3], wd[3], w2[3], wd2[3];
        sp_q30_t sc[6];
        double want_w[3], want_wd[3], biggest = 0;
        sp_status_t st;
        for (int k = 0; k < 3; ++k) {
            a[k] = ref_q24(tu_uniform(&rng, -3.2, 3.2));
            d[k] = ref_q24(random_rate(&rng, 4.0));
            dd[k] = ref_q24(random_rate(&rng, 32.0));
            if (n % 10 == 5 && k < 2) {
                /* yaw alone about the vertical (roll = pitch = 0: the
                 * level path), on and off the circle */
                a[k] = 0;
                d[k] = 0;
                dd[k] = 0;
            }
            sp_sincos_q24(a[k], &sc[2 * k], &sc[2 * k + 1]);
            if (n % 10 == 7 || (n % 10 == 3 && k < 2)) {
                /* no turning (the zero path) or yaw alone, on and off the circle */
                d[k] = 0;
                dd[k] = 0;
            }
        }
        if (n % 3 == 2) { /* off the unit circle: up to 1.25 in magnitude */
            for (int k = 0; k < 4; ++k) {
                sc[k] = (int32_t)llround(tu_uniform(&rng, -1.25, 1.25) * 1073741824.0);
            }
            ++off_circle;
        } else {
            /* sp_body_rates: the same bits from the angles */
            assert_int_equal(sp_body_rates(a, d, dd, w2, wd2), SP_OK);
        }
        st = sp_body_rates_sc(sc, d, dd, w, wd);
        plain_body_rates(sc, d, dd, want_w, want_wd);
        for (int k = 0; k < 3; ++k) {
            biggest = fmax(biggest, fmax(fabs(want_w[k]), fabs(want_wd[k])));
        }
        if (biggest > 128.1) {
            assert_int_equal(st, SP_E_OVERFLOW);
            continue;
        }
        if (biggest > 127.9) {
            continue;
        }
        assert_int_equal(st, SP_OK);
        if (n % 10 == 7) {
            for (int k = 0; k < 3; ++k) {
                assert_int_equal(w[k], 0);
                assert_int_equal(wd[k], 0);
            }
        }
        if (n % 3 != 2) {
            sp_q24_t wi[3], wdi[3];
            int_body_rates(sc, d, dd, wi, wdi); /* every path equals the rows as first written */
            assert_memory_equal(w, wi, sizeof w);
            assert_memory_equal(wd, wdi, sizeof wd);
            assert_memory_equal(w, w2, sizeof w);
            assert_memory_equal(wd, wd2, sizeof wd);
        }
        for (int k = 0; k < 3; ++k) {
            worst_w = fmax(worst_w, fabs(w[k] - want_w[k] * 16777216.0));
            worst_wd = fmax(worst_wd, fabs(wd[k] - want_wd[k] * 16777216.0));
            assert_near(w[k], want_w[k] * 16777216.0, tol_w, "case %d: w[%d] (LSB)", n, k);
            assert_near(wd[k], want_wd[k] * 16777216.0, tol_wd, "case %d: wd[%d] (LSB)", n, k);
        }
    }
    print_message("body rates: %d of 6000 off the unit circle; worst error %.2f LSB (w), %.2f LSB (derivative)\n",
                  off_circle, worst_w, worst_wd);
}

/* The model: the core's body rates of the angles against ref_body_rates
 * (the sines' error included: 1e-6), and the reference's derivative
 * against a central difference of its w along the motion (1e-5). */
static void test_body_rates(void **state)
{
    uint64_t rng = 15;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_q24_t a[3], d[3], dd[3], w[3], wd[3];
        double ad[3], dv[3], ddv[3], wr[3], wdr[3], w1[3], w2[3], unused[3];
        double a1[3], a2[3], d1[3], d2[3];
        double h = 1e-6;
        for (int k = 0; k < 3; ++k) {
            a[k] = ref_q24(tu_uniform(&rng, -0.3, 0.3));
            d[k] = ref_q24(tu_uniform(&rng, -1.0, 1.0));
            dd[k] = ref_q24(tu_uniform(&rng, -10.0, 10.0));
            ad[k] = ref_f24(a[k]);
            dv[k] = ref_f24(d[k]);
            ddv[k] = ref_f24(dd[k]);
        }
        assert_int_equal(sp_body_rates(a, d, dd, w, wd), SP_OK);
        ref_body_rates(ad, dv, ddv, wr, wdr);
        for (int k = 0; k < 3; ++k) {
            a1[k] = ad[k] - dv[k] * h;
            a2[k] = ad[k] + dv[k] * h;
            d1[k] = dv[k] - ddv[k] * h;
            d2[k] = dv[k] + ddv[k] * h;
        }
        ref_body_rates(a1, d1, ddv, w1, unused);
        ref_body_rates(a2, d2, ddv, w2, unused);
        for (int k = 0; k < 3; ++k) {
            assert_near(ref_f24(w[k]), wr[k], 1e-6, "motion %d: w[%d]", n, k);
            assert_near(ref_f24(wd[k]), wdr[k], 1e-6, "motion %d: wd[%d]", n, k);
            assert_near(wdr[k], (w2[k] - w1[k]) / (2 * h), 1e-5, "motion %d: model wd[%d] vs difference", n, k);
        }
    }
}

/* The saturations at the limits, on either path of the rate functions
 * (their values are checked against the plain references above):
 * sp_leg_rates at 120 rad/s, in range, and past 128 m/s on the wide and on
 * the common path; sp_body_rates_sc past 128 on and off the unit circle,
 * and with every input at its limit; sp_jacobian beyond 8. */
static void test_rates_wide_paths(void **state)
{
    sp_platform_t p;
    sp_pose_t pose;
    sp_ik_t ik;
    sp_q24_t vel[3] = {0, 0, 0};
    sp_q24_t rr[3] = {0, 0, 0};
    sp_q24_t rate[SP_LEGS];
    sp_jacobian_t jac;
    (void)state;
    memset(&p, 0, sizeof p);
    memset(&pose, 0, sizeof pose);
    for (int i = 0; i < SP_LEGS; ++i) {
        double b = (60.0 * i + 10.0) * DEG;
        double a = (60.0 * i - 10.0) * DEG;
        p.base_joint[i][0] = ref_q24(1.0 * cos(b));
        p.base_joint[i][1] = ref_q24(1.0 * sin(b));
        p.platform_joint[i][0] = ref_q24(0.6 * cos(a));
        p.platform_joint[i][1] = ref_q24(0.6 * sin(a));
    }
    pose.pos[2] = ref_q24(1.0);
    pose.rpy[0] = ref_q24(0.1);
    pose.rpy[1] = ref_q24(-0.05);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    vel[0] = ref_q24(0.5);
    vel[2] = -ref_q24(0.25);
    rr[0] = ref_q24(0.3);
    rr[2] = ref_q24(120.0); /* 72 m/s at the joints: still in range */
    assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_OK);
    vel[1] = ref_q24(100.0); /* 172 m/s: saturates on the wide path */
    assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_E_OVERFLOW);
    rr[2] = ref_q24(60.0); /* 136 m/s: saturates on the common path */
    assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_E_OVERFLOW);

    /* body rates: roll 0 and pitch 0.2, with cos(roll) 8 LSB above 1 (the
     * saturating path) and exact; saturation on both paths */
    {
        sp_q30_t sc[6];
        sp_q24_t d[3] = {ref_q24(100.0), ref_q24(100.0), ref_q24(100.0)};
        sp_q24_t dd[3] = {ref_q24(5.0), ref_q24(-3.0), ref_q24(9.0)};
        sp_q24_t w1[3], wd1[3], w2[3], wd2[3];
        sc[0] = 0;
        sc[1] = (INT32_C(1) << 30) + 8;
        sp_sincos_q24(ref_q24(0.2), &sc[2], &sc[3]);
        sc[4] = 0;
        sc[5] = INT32_C(1) << 30;
        assert_int_equal(sp_body_rates_sc(sc, d, dd, w2, wd2), SP_E_OVERFLOW);
        sc[1] -= 8;
        assert_int_equal(sp_body_rates_sc(sc, d, dd, w1, wd1), SP_E_OVERFLOW);
        /* and far off the circle, every input at its limit */
        for (int k = 0; k < 6; ++k) {
            sc[k] = INT32_MAX;
        }
        d[0] = d[1] = d[2] = INT32_MIN;
        dd[0] = dd[1] = dd[2] = INT32_MIN;
        assert_int_equal(sp_body_rates_sc(sc, d, dd, w2, wd2), SP_E_OVERFLOW);
    }

    /* a joint 10 m from o': the Jacobian's r x u reaches 10, beyond 8 */
    assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
    ik.arm[2][0] = ref_q24(10.0);
    ik.arm[2][1] = 0;
    ik.arm[2][2] = 0;
    ik.unit[2][0] = 0;
    ik.unit[2][1] = INT32_C(1) << 30;
    ik.unit[2][2] = 0;
    assert_int_equal(sp_jacobian(&ik, &jac), SP_E_OVERFLOW);
    assert_int_equal(jac.j[2][5], INT32_MAX);
    ik.unit[2][1] = -(INT32_C(1) << 30);
    assert_int_equal(sp_jacobian(&ik, &jac), SP_E_OVERFLOW);
    assert_int_equal(jac.j[2][5], INT32_MIN);
    assert_int_equal(jac.j[2][1], -(INT32_C(1) << 28));
}

/* A forward-kinematics case: a random platform and pose (truth; q, the
 * exact values in double) and the legs' lengths from the reference IK,
 * rounded to the sensor's Q24. */
static void random_fk_case(uint64_t *rng, sp_platform_t *p, double *hz, sp_pose_t *truth, double q[6], sp_q24_t l[6])
{
    double len[6];
    random_platform(rng, p, hz);
    random_pose(rng, *hz, truth, q);
    ref_ik(p, q, len, NULL, NULL);
    for (int i = 0; i < 6; ++i) {
        l[i] = ref_q24(len[i]);
    }
}

/* The pose moved by up to +-d per axis (m, rad): a warm-start guess one
 * 1 kHz tick away at 1 m/s and 1 rad/s for d = 1e-3. */
static sp_pose_t nudged(uint64_t *rng, const sp_pose_t *pose, double d)
{
    sp_pose_t out = *pose;
    for (int k = 0; k < 3; ++k) {
        out.pos[k] += ref_q24(tu_uniform(rng, -d, d));
        out.rpy[k] += ref_q24(tu_uniform(rng, -d, d));
    }
    return out;
}

/* An FK result against the true pose q: within 1 um and 5 urad; worst[0]
 * and worst[1] keep the largest position and angle errors. */
static void check_fk_pose(const sp_pose_t *out, const double q[6], double worst[2], const char *what, int n)
{
    for (int k = 0; k < 3; ++k) {
        worst[0] = fmax(worst[0], fabs(ref_f24(out->pos[k]) - q[k]));
        worst[1] = fmax(worst[1], fabs(ref_f24(out->rpy[k]) - q[3 + k]));
        assert_near(ref_f24(out->pos[k]), q[k], 1e-6, "pose %d: %s position %d", n, what, k);
        assert_near(ref_f24(out->rpy[k]), q[3 + k], 5e-6, "pose %d: %s angle %d", n, what, k);
    }
}

static void test_forward_kinematics(void **state)
{
    uint64_t rng = 17;
    sp_fk_options_t opt;
    uint32_t worst_warm = 0;
    uint32_t worst_cold = 0;
    double worst[2] = {0, 0};
    (void)state;
    sp_fk_default_options(&opt);
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t truth;
        sp_pose_t guess;
        sp_pose_t out;
        sp_ik_t ik_out;
        sp_fk_info_t info;
        double q[6];
        sp_q24_t l[6];
        random_fk_case(&rng, &p, &hz, &truth, q, l);
        guess = nudged(&rng, &truth, 1e-3);
        assert_int_equal(sp_forward_kinematics(&p, l, &guess, &opt, &out, &ik_out, &info), SP_OK);
        assert_true(info.iterations <= 3u);
        worst_warm = info.iterations > worst_warm ? info.iterations : worst_warm;
        {
            /* the pose alone (ik NULL): the same pose, iterations and
             * residual; the caller's ik is the pose's full IK */
            sp_pose_t out2;
            sp_fk_info_t info2;
            sp_ik_t ik_check;
            assert_int_equal(sp_forward_kinematics(&p, l, &guess, &opt, &out2, NULL, &info2), SP_OK);
            assert_memory_equal(&out2, &out, sizeof out);
            assert_int_equal(info2.iterations, info.iterations);
            assert_int_equal(info2.residual, info.residual);
            assert_int_equal(sp_inverse_kinematics(&p, &out, &ik_check), SP_OK);
            assert_memory_equal(&ik_check, &ik_out, sizeof ik_check);
        }
        check_fk_pose(&out, q, worst, "warm FK", n);
        /* cold start from home (large jumps allowed) */
        {
            sp_fk_options_t cold = opt;
            cold.max_jump_pos = ref_q24(1.0);
            cold.max_jump_rot = ref_q24(1.0);
            guess = p.home;
            assert_int_equal(sp_forward_kinematics(&p, l, &guess, &cold, &out, &ik_out, &info), SP_OK);
            worst_cold = info.iterations > worst_cold ? info.iterations : worst_cold;
            check_fk_pose(&out, q, worst, "cold FK", n);
            /* the same with the default jump limits: a discontinuity, and
             * the output stays at the guess */
            if (fabs(q[0]) > 0.06 || fabs(q[1]) > 0.06 || fabs(q[2] - hz) > 0.06) {
                assert_int_equal(sp_forward_kinematics(&p, l, &guess, &opt, &out, &ik_out, &info), SP_E_DISCONTINUITY);
                assert_memory_equal(&out, &guess, sizeof out);
            }
        }
    }
    print_message("FK: worst warm iterations %u, cold %u; worst error %.3g m, %.3g rad\n", worst_warm, worst_cold,
                  worst[0], worst[1]);
}

/* Chord forward kinematics as the controller uses it: the factorisation of
 * J^T at another pose up to 1 mm / 1 mrad away (last tick's reference), the
 * guess up to 1 mm / 1 mrad away with its cached lengths and sines. Same
 * accuracy bounds as sp_forward_kinematics, at most 3 steps. */
static void test_fk_chord(void **state)
{
    uint64_t rng = 29;
    sp_fk_options_t opt;
    uint32_t worst_it = 0;
    double worst[2] = {0, 0};
    (void)state;
    sp_fk_default_options(&opt);
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t truth;
        sp_pose_t guess;
        sp_pose_t near;
        sp_pose_t out;
        sp_pose_t out_newton;
        sp_ik_t ik;
        sp_jacobian_t jac;
        sp_lu6_t lu;
        sp_fk_cache_t cache;
        sp_fk_cache_t check;
        sp_fk_info_t info;
        double q[6];
        sp_q24_t l[6];
        random_fk_case(&rng, &p, &hz, &truth, q, l);
        guess = nudged(&rng, &truth, 1e-3);
        near = nudged(&rng, &truth, 1e-3);
        assert_int_equal(sp_inverse_kinematics(&p, &near, &ik), SP_OK);
        assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
        assert_int_equal(sp_lu6_factor(&jac, 1, &lu), SP_OK);
        assert_int_equal(sp_fk_cache_of(&p, &guess, &cache), SP_OK);
        assert_int_equal(sp_fk_chord(&p, l, &guess, &lu, &opt, &cache, &out, &info), SP_OK);
        assert_true(info.iterations <= 3u);
        assert_true(info.residual <= opt.tolerance);
        worst_it = info.iterations > worst_it ? info.iterations : worst_it;
        /* the cache now belongs to the result */
        assert_int_equal(sp_fk_cache_of(&p, &out, &check), SP_OK);
        assert_memory_equal(&check, &cache, sizeof check);
        assert_int_equal(sp_forward_kinematics(&p, l, &guess, &opt, &out_newton, NULL, NULL), SP_OK);
        check_fk_pose(&out, q, worst, "chord FK", n);
        /* far from the truth with a tight step limit: no convergence, the
         * guess returned and the cache untouched */
        if (n == 0) {
            sp_fk_options_t one = opt;
            sp_fk_cache_t before;
            sp_pose_t far = truth;
            far.pos[0] += ref_q24(0.02);
            assert_int_equal(sp_fk_cache_of(&p, &far, &cache), SP_OK);
            before = cache;
            one.max_iterations = 1u;
            assert_int_equal(sp_fk_chord(&p, l, &far, &lu, &one, &cache, &out, &info), SP_E_NO_CONVERGENCE);
            assert_memory_equal(&out, &far, sizeof out);
            assert_memory_equal(&cache, &before, sizeof cache);
            lu.valid = 0u;
            assert_int_equal(sp_fk_chord(&p, l, &far, &lu, &opt, &cache, &out, &info), SP_E_ARG);
            assert_int_equal(sp_fk_chord(&p, l, &far, NULL, &opt, &cache, &out, &info), SP_E_ARG);
        }
    }
    print_message("FK chord: worst iterations %u; worst error %.3g m, %.3g rad\n", worst_it, worst[0], worst[1]);
}

/* The chord step's Euler update as it was written before its d_roll
 * product took one 32 x 32-bit multiply for a small step: the plain
 * reference (every product through spi_mul64_up, every sum saturated). */
static sp_status_t fk_update_plain(sp_pose_t *q, const int64_t delta[SP_LEGS], const sp_q30_t sc[6])
{
    sp_flags_t flags = 0u;
    int32_t d[SP_LEGS];
    int32_t d_roll;
    unsigned sh;
    int32_t inv;
    for (int i = 0; i < SP_LEGS; ++i) {
        d[i] = spi_sat(delta[i], &flags);
    }
    for (int i = 0; i < 3; ++i) {
        q->pos[i] = spi_add(q->pos[i], d[i], &flags);
    }
    if (sc[3] < SP_Q30_MILLI(10)) {
        return SP_E_SINGULAR;
    }
    inv = spi_recip((uint32_t)sc[3], &sh);
    d_roll =
        spi_sat(spi_mul64_up(spi_round_away((int64_t)d[3] * sc[5] + (int64_t)d[4] * sc[4], 30u), inv, sh - 30u, &flags),
                &flags);
    q->rpy[0] = spi_add(q->rpy[0], d_roll, &flags);
    q->rpy[1] =
        spi_add(q->rpy[1], spi_sat(spi_round_away((int64_t)d[4] * sc[5] - (int64_t)d[3] * sc[4], 30u), &flags), &flags);
    q->rpy[2] = spi_add(q->rpy[2], spi_add(d[5], spi_mul_away(d_roll, sc[2], 30u, &flags), &flags), &flags);
    return (flags != 0u) ? SP_E_NO_CONVERGENCE : SP_OK;
}

/* sp_fk_chord_step against the plain reference (the same solves, then
 * fk_update_plain) on random poses and increments from 1 um to 10 cm, bit
 * for bit, status and pose; and the d_roll product's identity on its own:
 * round(x inv / 2^s) of an int32 x in one 32 x 32-bit product equals
 * spi_mul64_up for every reciprocal of a cosine the update accepts. */
static void test_fk_chord_step_plain(void **state)
{
    uint64_t rng = 0xC40D5u;
    int steps = 0;
    (void)state;
    for (int n = 0; n < 200000; ++n) {
        int32_t x = (int32_t)(uint32_t)tu_next(&rng);
        int32_t cp = SP_Q30_MILLI(10) + (int32_t)(tu_next(&rng) % (uint64_t)(SP_Q30_ONE - SP_Q30_MILLI(10) + 2));
        unsigned sh;
        sp_flags_t f = 0u;
        int32_t inv = spi_recip((uint32_t)cp, &sh);
        if (n % 4 == 0) {
            x = (int32_t)(tu_next(&rng) % 2001u) - 1000; /* the common, small case */
        }
        assert_true(spi_round_up((int64_t)x * inv, sh - 30u) == spi_mul64_up(x, inv, sh - 30u, &f));
        assert_int_equal(f, 0u);
    }
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t truth;
        sp_ik_t ik;
        sp_jacobian_t jac;
        sp_lu6_t lu;
        double q[6];
        sp_q24_t l[6];
        random_fk_case(&rng, &p, &hz, &truth, q, l);
        assert_int_equal(sp_inverse_kinematics(&p, &truth, &ik), SP_OK);
        assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
        assert_int_equal(sp_lu6_factor(&jac, 1, &lu), SP_OK);
        for (int m = 0; m < 8; ++m) {
            double scale = pow(10.0, -6.0 + 5.0 * (double)m / 7.0); /* 1 um .. 10 cm */
            sp_q24_t d[SP_LEGS];
            int64_t b[SP_LEGS];
            int64_t delta[SP_LEGS];
            sp_pose_t out = truth;
            sp_pose_t want = truth;
            sp_status_t st_want = SP_OK;
            for (int i = 0; i < SP_LEGS; ++i) {
                d[i] = ref_q24(tu_uniform(&rng, -scale, scale));
                b[i] = d[i];
            }
            if (m == 0 && n % 8 == 0) {
                memset(d, 0, sizeof d);
                memset(b, 0, sizeof b);
            }
            if (b[0] | b[1] | b[2] | b[3] | b[4] | b[5]) {
                if (!spi_lu6_solve_t32(&lu, b, delta)) {
                    st_want = sp_lu6_solve_transposed(&lu, b, delta);
                }
                if (st_want == SP_OK) {
                    st_want = fk_update_plain(&want, delta, ik.sc);
                }
            }
            sp_status_t st = sp_fk_chord_step(&lu, &truth, ik.sc, d, &out);
            assert_int_equal(st, st_want);
            if (st == SP_OK) {
                assert_memory_equal(&out, &want, sizeof out);
                ++steps;
            }
        }
    }
    print_message("chord step vs plain reference: %d steps bit for bit\n", steps);
    assert_true(steps > N_POSES * 6);
}

static void test_forward_kinematics_failures(void **state)
{
    uint64_t rng = 18;
    sp_platform_t p;
    double hz;
    sp_fk_options_t opt;
    sp_pose_t out;
    sp_ik_t ik;
    sp_fk_info_t info;
    sp_q24_t l[6];
    (void)state;
    random_platform(&rng, &p, &hz);
    sp_fk_default_options(&opt);
    /* lengths no pose can have: one leg far longer than the others */
    assert_int_equal(sp_inverse_kinematics(&p, &p.home, &ik), SP_OK);
    memcpy(l, ik.length, sizeof l);
    l[0] += ref_q24(3.0);
    {
        sp_status_t st = sp_forward_kinematics(&p, l, &p.home, &opt, &out, &ik, &info);
        print_message("FK on impossible lengths: %s after %u iterations\n", sp_status_name(st), info.iterations);
        /* any failure status will do (Newton diverges: it may saturate), but
         * it must be a failure, and the output must stay at the guess */
        assert_true(st != SP_OK);
        assert_memory_equal(&out, &p.home, sizeof out);
    }
    opt.max_iterations = 0u;
    assert_int_equal(sp_forward_kinematics(&p, l, &p.home, &opt, &out, &ik, &info), SP_E_ARG);
}

/* The wrench that the forces produce (ref_wrench_of_forces) against the
 * wrench the motion needs (ref_wrench_needed: Newton-Euler in the base
 * frame). */
static void test_inverse_dynamics(void **state)
{
    uint64_t rng = 19;
    double worst = 0;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_motion_t m;
        double q[6], qd[6], qdd[6];
        sp_ik_t ik;
        sp_q8_t f[6];
        sp_q8_t ext[3];
        double unit[6][3], arm[6][3];
        double fd[6], extd[3], need[6], got[6];
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &m.pose, q);
        for (int k = 0; k < 3; ++k) {
            m.vel[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.rpy_rate[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
            m.rpy_acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
            ext[k] = ref_q8(tu_uniform(&rng, -2000, 2000));
            qd[k] = ref_f24(m.vel[k]);
            qd[3 + k] = ref_f24(m.rpy_rate[k]);
            qdd[k] = ref_f24(m.acc[k]);
            qdd[3 + k] = ref_f24(m.rpy_acc[k]);
            extd[k] = ref_f8(ext[k]);
        }
        assert_int_equal(sp_inverse_kinematics(&p, &m.pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_dynamics(&p, &m, &ik, ext, f), SP_OK);
        {
            /* the variant that keeps the factorisation: the same forces */
            sp_lu6_t lu;
            sp_q8_t f2[6];
            assert_int_equal(sp_inverse_dynamics_lu(&p, &m, &ik, ext, f2, &lu), SP_OK);
            assert_memory_equal(f2, f, sizeof f2);
            assert_int_equal(lu.valid, 1);
            assert_int_equal(sp_inverse_dynamics_lu(&p, &m, &ik, ext, f2, NULL), SP_E_ARG);
        }
        ref_ik(&p, q, NULL, unit, arm);
        ref_wrench_needed(&p, q, qd, qdd, extd, need);
        for (int i = 0; i < 6; ++i) {
            fd[i] = ref_f8(f[i]);
        }
        ref_wrench_of_forces(fd, unit, arm, got);
        for (int k = 0; k < 6; ++k) {
            worst = fmax(worst, fabs(got[k] - need[k]));
            /* 0.05 N (N m) on the wrench: six forces each rounded to Q8 */
            assert_near(got[k], need[k], 0.05, "motion %d: wrench %d of the forces", n, k);
        }
    }
    print_message("ID worst wrench error %.4g N\n", worst);
}

/* Energy of the platform and its legs (J) at pose q with pose rates qd:
 * kinetic (about o': m |v|^2 / 2 + m v . (w x R c) + w.I w / 2, with the
 * legs' point masses and their moments of inertia across the leg, which
 * turn at |u'|: (I_c + I_r) |u'|^2 / 2) plus potential (every mass at its
 * height). Written from the kinematics alone, independently of the
 * dynamics. */
static double platform_energy(const sp_platform_t *p, const double q[6], const double qd[6])
{
    double r[3][3], len[6], unit[6][3], arm[6][3], w[3], wd[3], wb[3], rc[3], wxc[3];
    double zero[3] = {0, 0, 0};
    double m = ref_f16(p->mass), g = ref_f24(p->gravity);
    double mc = ref_f16(p->leg_mass.cylinder_mass), dc = ref_f24(p->leg_mass.cylinder_com);
    double mr = ref_f16(p->leg_mass.rod_mass), dr = ref_f24(p->leg_mass.rod_com);
    double il = ref_f16(p->leg_mass.cylinder_inertia) + ref_f16(p->leg_mass.rod_inertia);
    double e = 0.0;
    ref_rot(&q[3], r);
    ref_ik(p, q, len, unit, arm);
    ref_body_rates(&q[3], &qd[3], zero, w, wd);
    for (int k = 0; k < 3; ++k) {
        wb[k] = r[k][0] * w[0] + r[k][1] * w[1] + r[k][2] * w[2];
        rc[k] = 0.0;
        for (int c = 0; c < 3; ++c) {
            rc[k] += r[k][c] * ref_f24(p->center_of_mass[c]);
        }
    }
    wxc[0] = wb[1] * rc[2] - wb[2] * rc[1];
    wxc[1] = wb[2] * rc[0] - wb[0] * rc[2];
    wxc[2] = wb[0] * rc[1] - wb[1] * rc[0];
    for (int k = 0; k < 3; ++k) {
        e += 0.5 * m * qd[k] * qd[k] + m * qd[k] * wxc[k];
        for (int c = 0; c < 3; ++c) {
            e += 0.5 * w[k] * ref_f16(p->inertia[k][c]) * w[c];
        }
    }
    e += m * g * (q[2] + rc[2]);
    for (int i = 0; i < 6; ++i) {
        double va[3], ud[3], ld = 0.0, vc2 = 0.0, vr2 = 0.0, ud2 = 0.0;
        va[0] = qd[0] + wb[1] * arm[i][2] - wb[2] * arm[i][1];
        va[1] = qd[1] + wb[2] * arm[i][0] - wb[0] * arm[i][2];
        va[2] = qd[2] + wb[0] * arm[i][1] - wb[1] * arm[i][0];
        for (int k = 0; k < 3; ++k) {
            ld += unit[i][k] * va[k];
        }
        for (int k = 0; k < 3; ++k) {
            ud[k] = (va[k] - ld * unit[i][k]) / len[i];
            vc2 += (dc * ud[k]) * (dc * ud[k]);
            vr2 += (va[k] - dr * ud[k]) * (va[k] - dr * ud[k]);
            ud2 += ud[k] * ud[k];
        }
        e += 0.5 * mc * vc2 + 0.5 * mr * vr2 + 0.5 * il * ud2;
        e += g * (mc * (ref_f24(p->base_joint[i][2]) + dc * unit[i][2]) + mr * (q[2] + arm[i][2] - dr * unit[i][2]));
    }
    return e;
}

/* Leg masses (every other motion with the legs' moments of inertia across
 * the leg) and a centre of mass off o': the power of the cylinder forces,
 * sum F_i L'_i, equals the rate of change of the energy of the platform and
 * its legs (platform_energy, differentiated numerically along the motion
 * q(t) = q + qd t + qdd t^2 / 2). With massless legs and c = 0 the forces
 * are the paper's, bit for bit (test_inverse_dynamics covers those). */
static void test_inverse_dynamics_legs_power(void **state)
{
    uint64_t rng = 23;
    double worst = 0.0;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz, q[6], qd[6], qdd[6], len[6], unit[6][3], arm[6][3], w[3], wd[3], wb[3], r[3][3];
        double rate[6], power = 0.0, de;
        sp_motion_t m;
        sp_ik_t ik;
        sp_q8_t f[6];
        const double h = 1e-4;
        random_platform(&rng, &p, &hz);
        p.leg_mass.cylinder_mass = ref_q16(tu_uniform(&rng, 0.0, 120.0));
        p.leg_mass.cylinder_com = ref_q24(tu_uniform(&rng, 0.1, 1.0));
        p.leg_mass.rod_mass = ref_q16(tu_uniform(&rng, 0.0, 60.0));
        p.leg_mass.rod_com = ref_q24(tu_uniform(&rng, 0.1, 1.0));
        if (n % 2 == 1) {
            /* every other motion with the legs' moments of inertia */
            p.leg_mass.cylinder_inertia = ref_q16(tu_uniform(&rng, 0.0, 30.0));
            p.leg_mass.rod_inertia = ref_q16(tu_uniform(&rng, 0.0, 20.0));
        }
        for (int k = 0; k < 3; ++k) {
            p.center_of_mass[k] = ref_q24(tu_uniform(&rng, -0.2, 0.2));
        }
        random_pose(&rng, hz, &m.pose, q);
        for (int k = 0; k < 3; ++k) {
            m.vel[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.rpy_rate[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
            m.rpy_acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
            qd[k] = ref_f24(m.vel[k]);
            qd[3 + k] = ref_f24(m.rpy_rate[k]);
            qdd[k] = ref_f24(m.acc[k]);
            qdd[3 + k] = ref_f24(m.rpy_acc[k]);
        }
        assert_int_equal(sp_inverse_kinematics(&p, &m.pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_dynamics(&p, &m, &ik, NULL, f), SP_OK);
        ref_ik(&p, q, len, unit, arm);
        ref_rot(&q[3], r);
        ref_body_rates(&q[3], &qd[3], &qdd[3], w, wd);
        for (int k = 0; k < 3; ++k) {
            wb[k] = r[k][0] * w[0] + r[k][1] * w[1] + r[k][2] * w[2];
        }
        ref_leg_rates(unit, arm, qd, wb, rate);
        for (int i = 0; i < 6; ++i) {
            power += ref_f8(f[i]) * rate[i];
        }
        {
            double qa[6], qb[6], qda[6], qdb[6];
            for (int k = 0; k < 6; ++k) {
                qa[k] = q[k] + qd[k] * h + 0.5 * qdd[k] * h * h;
                qb[k] = q[k] - qd[k] * h + 0.5 * qdd[k] * h * h;
                qda[k] = qd[k] + qdd[k] * h;
                qdb[k] = qd[k] - qdd[k] * h;
            }
            de = (platform_energy(&p, qa, qda) - platform_energy(&p, qb, qdb)) / (2.0 * h);
        }
        worst = fmax(worst, fabs(power - de));
        /* the forces' rounding (0.004 N each, at |L'| < 3 m/s) and the
         * difference quotient's error (h^2 terms, rounding of E ~ 1e5 J)
         * stay below 0.3 W; a leg term wrong by 1 N shows as ~1 W */
        assert_near(power, de, 0.3, "motion %d: power of the forces against dE/dt", n);
    }
    print_message("ID with legs and centre of mass: worst power error %.4g W\n", worst);
}

/* sp_inverse_dynamics_held (the controller keeps legs in turn): with nothing
 * kept, or every kept leg's terms from the same motion, the forces and
 * rates are sp_inverse_dynamics_rates' bit for bit; with half the legs'
 * terms kept from the motion 1 ms before (pose, rates moved on along the
 * acceleration), the rates are still bit for bit and the forces within
 * 8 N of the fresh ones over random platforms with up to 180 kg legs,
 * 1 m/s, 1 rad/s, 10 m/s^2 and 10 rad/s^2 (measured: 4.8 N; the
 * controller's surge, 0.08 N: test_controller). With the factorisation
 * kept (hold.lu_keep), every leg computed: a factorisation made at a
 * motion and refined from the last forces 1 to 5 ms on gives forces
 * within 1.5 N of the fresh solve over the same motions (measured
 * 0.88 N; 1.41 N with every other motion staged as the controller does,
 * refined up to 8 ms on), and a call that factorises gives the plain
 * forces bit for bit. */
/* spi_jacobian_near against sp_jacobian, bit for bit: random platforms
 * and poses, and a platform whose joints sit at the bound (-2 m or 2 m -
 * 1 LSB in every axis, the longest arms spi_joints_near admits) turned
 * every way;
 * spi_joints_near at and beside its bound. */
static void test_jacobian_near(void **state)
{
    uint64_t rng = 77;
    sp_platform_t p;
    double hz, q[6];
    sp_pose_t pose;
    sp_ik_t ik;
    sp_jacobian_t jac, jac_near;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        if (n % 100 == 0) {
            random_platform(&rng, &p, &hz);
            assert_true(spi_joints_near(&p));
        }
        random_pose(&rng, hz, &pose, q);
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        memset(&jac_near, 0xA5, sizeof jac_near);
        assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
        spi_jacobian_near(&ik, &jac_near);
        assert_memory_equal(&jac_near, &jac, sizeof jac);
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        for (int c = 0; c < 3; ++c) {
            p.platform_joint[i][c] = ((i + c) % 2) ? (INT32_C(1) << 25) - 1 : -(INT32_C(1) << 25);
        }
        p.base_joint[i][2] = -(INT32_C(8) << 24); /* far below: every leg longer than the arms */
    }
    assert_true(spi_joints_near(&p));
    for (int n = 0; n < N_POSES; ++n) {
        for (int k = 0; k < 3; ++k) {
            pose.rpy[k] = (int32_t)tu_uniform(&rng, -3.2 * 16777216.0, 3.2 * 16777216.0);
            pose.pos[k] = (int32_t)tu_uniform(&rng, -2.0 * 16777216.0, 2.0 * 16777216.0);
        }
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
        spi_jacobian_near(&ik, &jac_near);
        assert_memory_equal(&jac_near, &jac, sizeof jac);
    }
    p.platform_joint[4][1] = INT32_C(1) << 25;
    assert_false(spi_joints_near(&p));
    p.platform_joint[4][1] = -(INT32_C(1) << 25) - 1;
    assert_false(spi_joints_near(&p));
    p.platform_joint[4][1] = INT32_MIN;
    assert_false(spi_joints_near(&p));
    p.platform_joint[4][1] = -(INT32_C(1) << 25);
    assert_true(spi_joints_near(&p));
}

/* sp_inverse_kinematics_kept against the plain sp_inverse_kinematics, bit
 * for bit, over a sequence of poses where each angle repeats the last
 * one's with probability 1/2 (the controller's references: surge keeps
 * all three, yaw two), from an invalid keep, and with keep NULL; an
 * out-of-range pose fails as the plain IK does and the next call is
 * still exact; the same over turns about the vertical alone. */
static void test_inverse_kinematics_kept(void **state)
{
    uint64_t rng = 31;
    sp_platform_t p;
    double hz, q[6];
    sp_orient_keep_t keep;
    sp_pose_t pose;
    sp_ik_t ik, ikk;
    int reused = 0;
    (void)state;
    random_platform(&rng, &p, &hz);
    memset(&keep, 0x5A, sizeof keep);
    keep.valid = 0u;
    random_pose(&rng, hz, &pose, q);
    for (int n = 0; n < N_POSES; ++n) {
        sp_pose_t next;
        random_pose(&rng, hz, &next, q);
        for (int k = 0; k < 3; ++k) {
            if (tu_uniform(&rng, 0.0, 1.0) < 0.5) {
                next.rpy[k] = pose.rpy[k];
                ++reused;
            }
        }
        pose = next;
        memset(&ik, 0, sizeof ik);
        memset(&ikk, 0xA5, sizeof ikk);
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, &ikk), SP_OK);
        assert_memory_equal(&ikk, &ik, sizeof ik);
        assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, NULL, &ikk), SP_OK);
        assert_memory_equal(&ikk, &ik, sizeof ik);
    }
    assert_true(reused > N_POSES);
    /* a pose 100 m away: SP_E_RANGE as the plain IK; then exact again */
    pose.pos[0] = INT32_C(100) << 24;
    assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, &ikk), sp_inverse_kinematics(&p, &pose, &ik));
    pose.pos[0] = 0;
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, &ikk), SP_OK);
    assert_memory_equal(&ikk, &ik, sizeof ik);
    /* translations only (the surge: the arms kept), then the same keep
     * for another platform: its arms made afresh (keep.platform) */
    for (int n = 0; n < 64; ++n) {
        pose.pos[n % 3] += (int32_t)tu_uniform(&rng, -2e5, 2e5);
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, &ikk), SP_OK);
        assert_memory_equal(&ikk, &ik, sizeof ik);
    }
    /* turning about the vertical alone (roll = pitch = 0, yaw and the
     * position moving every call: the arms' shorter sums, arms_about_z),
     * a pose 100 m away among them, then a platform joint of 128 m whose
     * turned arm saturates: the plain IK's error */
    pose.rpy[0] = 0;
    pose.rpy[1] = 0;
    for (int n = 0; n < N_POSES; ++n) {
        pose.rpy[2] = (int32_t)tu_uniform(&rng, -3.3 * 16777216.0, 3.3 * 16777216.0);
        pose.pos[n % 3] += (int32_t)tu_uniform(&rng, -2e5, 2e5);
        pose.pos[0] = (n == N_POSES / 2) ? INT32_C(100) << 24 : pose.pos[0];
        memset(&ik, 0, sizeof ik);
        memset(&ikk, 0xA5, sizeof ikk);
        assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, &ikk), sp_inverse_kinematics(&p, &pose, &ik));
        if (n == N_POSES / 2) {
            assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_RANGE);
            pose.pos[0] = 0;
            continue;
        }
        assert_memory_equal(&ikk, &ik, sizeof ik);
    }
    {
        sp_platform_t pw = p;
        pw.platform_joint[3][0] = INT32_MAX - 5; /* 128 m: the turned arm leaves int32 */
        pw.platform_joint[3][1] = INT32_MAX - 5;
        pose.rpy[2] = 13176795; /* pi/4 */
        pose.pos[0] = 0;
        assert_int_equal(sp_inverse_kinematics_kept(&pw, &pose, &keep, &ikk), sp_inverse_kinematics(&pw, &pose, &ik));
        assert_int_not_equal(sp_inverse_kinematics(&pw, &pose, &ik), SP_OK);
    }
    {
        sp_platform_t p2;
        double hz2;
        random_platform(&rng, &p2, &hz2);
        pose.pos[2] = (int32_t)(hz2 * 16777216.0);
        assert_int_equal(sp_inverse_kinematics(&p2, &pose, &ik), SP_OK);
        assert_int_equal(sp_inverse_kinematics_kept(&p2, &pose, &keep, &ikk), SP_OK);
        assert_memory_equal(&ikk, &ik, sizeof ik);
        assert_ptr_equal(keep.platform, &p2);
    }
    assert_int_equal(sp_inverse_kinematics_kept(NULL, &pose, &keep, &ikk), SP_E_ARG);
    assert_int_equal(sp_inverse_kinematics_kept(&p, NULL, &keep, &ikk), SP_E_ARG);
    assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, NULL), SP_E_ARG);
}

/* sp_inverse_kinematics_kept's legs without the overflow tests
 * (spi_legs_fit, leg_fit) against the plain IK, bit for bit and status for
 * status, at the bounds they rest on: platform joints at -2 m or 2 m -
 * 1 LSB, base joints at -8 m or 8 m - 1 LSB, positions at -16 m or
 * 16 m - 1 LSB in each axis (the longest legs leg_fit takes), turned every
 * way and about the vertical alone, turning and held; positions one LSB
 * beyond (the tested legs); spi_legs_fit at and beside its bound. */
static void test_legs_fit(void **state)
{
    uint64_t rng = 5;
    sp_platform_t p;
    double hz;
    sp_orient_keep_t keep;
    sp_pose_t pose;
    sp_ik_t ik, ikk;
    const int32_t pos_lo = -(INT32_C(1) << 28);
    const int32_t pos_hi = (INT32_C(1) << 28) - 1;
    (void)state;
    random_platform(&rng, &p, &hz);
    assert_true(spi_legs_fit(&p));
    for (int i = 0; i < SP_LEGS; ++i) {
        for (int c = 0; c < 3; ++c) {
            p.platform_joint[i][c] = ((i + c) % 2) ? (INT32_C(1) << 25) - 1 : -(INT32_C(1) << 25);
            p.base_joint[i][c] = ((i + c) % 3) ? (INT32_C(1) << 27) - 1 : -(INT32_C(1) << 27);
        }
    }
    assert_true(spi_legs_fit(&p));
    memset(&keep, 0x5A, sizeof keep);
    keep.valid = 0u;
    for (int n = 0; n < N_POSES; ++n) {
        int beyond = (n % 7 == 3);
        for (int k = 0; k < 3; ++k) {
            if (n % 3 != 2) { /* every third pose keeps the orientation */
                pose.rpy[k] = (int32_t)tu_uniform(&rng, -3.2 * 16777216.0, 3.2 * 16777216.0);
            }
            pose.pos[k] = tu_uniform(&rng, 0.0, 1.0) < 0.5 ? pos_lo : pos_hi;
        }
        if (n % 5 == 0) {
            pose.rpy[0] = 0; /* about the vertical alone */
            pose.rpy[1] = 0;
        }
        if (beyond) {
            pose.pos[n % 3] = (pose.pos[n % 3] < 0) ? pos_lo - 1 : pos_hi + 1;
        }
        memset(&ik, 0, sizeof ik);
        memset(&ikk, 0xA5, sizeof ikk);
        assert_int_equal(sp_inverse_kinematics_kept(&p, &pose, &keep, &ikk), sp_inverse_kinematics(&p, &pose, &ik));
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        assert_memory_equal(&ikk, &ik, sizeof ik);
    }
    p.base_joint[2][1] = INT32_C(1) << 27;
    assert_false(spi_legs_fit(&p));
    p.base_joint[2][1] = -(INT32_C(1) << 27) - 1;
    assert_false(spi_legs_fit(&p));
    p.base_joint[2][1] = INT32_MIN;
    assert_false(spi_legs_fit(&p));
    p.base_joint[2][1] = -(INT32_C(1) << 27);
    assert_true(spi_legs_fit(&p));
    p.platform_joint[1][0] = INT32_C(1) << 25; /* joints no longer near */
    assert_false(spi_legs_fit(&p));
}

/* The leg rates of the inverse dynamics with leg masses (leg_terms: L'_i
 * = J_i . [v; w_b], the Jacobian's rows in Q28 and w_b rounded to Q24)
 * against plain_leg_rates (double, from the IK's own values), over random
 * platforms with legs and motions up to 1 m/s, 1 rad/s, 10 m/s^2 and
 * 10 rad/s^2: |error| <= 0.5 (the rounding of the sum) + 0.5 sum_c
 * |J_i,3+c| (w_b's) + (sum_c |v_c| + |w_b,c|) / 2^5 (each J entry
 * within 2^-29) LSB of Q24, and within 2 LSB of sp_leg_rates (measured:
 * printed). */
static void test_inverse_dynamics_rates_reference(void **state)
{
    uint64_t rng = 47;
    double worst = 0.0;
    int worst_lsb = 0;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz, q[6], want[SP_LEGS], w_max, v_max, c_max, w[3];
        sp_motion_t m;
        sp_ik_t ik;
        sp_jacobian_t jac;
        sp_lu6_t lu;
        sp_q8_t f[SP_LEGS];
        sp_q24_t rt[SP_LEGS], rl[SP_LEGS];
        random_platform(&rng, &p, &hz);
        p.leg_mass.cylinder_mass = ref_q16(tu_uniform(&rng, 0.0, 120.0));
        p.leg_mass.cylinder_com = ref_q24(tu_uniform(&rng, 0.1, 1.0));
        p.leg_mass.rod_mass = ref_q16(tu_uniform(&rng, 1.0, 60.0));
        p.leg_mass.rod_com = ref_q24(tu_uniform(&rng, 0.1, 1.0));
        random_pose(&rng, hz, &m.pose, q);
        for (int k = 0; k < 3; ++k) {
            m.vel[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.rpy_rate[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
            m.rpy_acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
        }
        assert_int_equal(sp_inverse_kinematics(&p, &m.pose, &ik), SP_OK);
        assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
        assert_int_equal(sp_inverse_dynamics_rates(&p, &m, &ik, &jac, NULL, f, &lu, rt), SP_OK);
        assert_int_equal(sp_leg_rates(&ik, m.vel, m.rpy_rate, rl), SP_OK);
        plain_leg_rates(&ik, m.vel, m.rpy_rate, want, &w_max, &v_max, &c_max);
        w[0] = ref_f24(m.rpy_rate[0]) * ref_f30(ik.rot.t[0][0]) - ref_f24(m.rpy_rate[1]) * ref_f30(ik.sc[4]);
        w[1] = ref_f24(m.rpy_rate[0]) * ref_f30(ik.rot.t[0][1]) + ref_f24(m.rpy_rate[1]) * ref_f30(ik.sc[5]);
        w[2] = ref_f24(m.rpy_rate[0]) * ref_f30(ik.rot.t[0][2]) + ref_f24(m.rpy_rate[2]);
        for (int i = 0; i < SP_LEGS; ++i) {
            double tol = 0.5;
            double err = fabs(ref_f24(rt[i]) - want[i]) * 16777216.0;
            for (int c = 0; c < 3; ++c) {
                tol += 0.5 * fabs(ldexp((double)jac.j[i][3 + c], -28)) + (fabs(ref_f24(m.vel[c])) + fabs(w[c])) / 32.0;
            }
            worst = fmax(worst, err / tol);
            assert_true(err <= tol);
            worst_lsb = (abs(rt[i] - rl[i]) > worst_lsb) ? abs(rt[i] - rl[i]) : worst_lsb;
            assert_true(abs(rt[i] - rl[i]) <= 2);
        }
    }
    print_message("ID leg rates from the Jacobian: worst error %.3f of its bound, %d LSB from sp_leg_rates\n", worst,
                  worst_lsb);
}

/* A tool tip (no frame turned) shares its orientation with the IK's keep,
 * and the frames keep there the body rates they made of the tool motion
 * (sp_setpoints_held hands them to the inverse dynamics instead of making
 * them again): whenever rates_valid, they are sp_body_rates_sc of the
 * keep's sines and the platform's Euler rates bit for bit, and an angle
 * the IK alone changes clears them. */
static void test_frames_keep_body_rates(void **state)
{
    (void)state;
    uint64_t rng = 0x5eed0b0d7ea7e5ULL;
    sp_pose_t tool = {{ref_q24(0.15), 0, ref_q24(0.35)}, {0, 0, 0}};
    sp_pose_t work = {{0, 0, 0}, {0, 0, 0}};
    sp_frames_t f;
    sp_frames_keep_t fk;
    sp_orient_keep_t keep;
    unsigned kept = 0u;
    assert_int_equal(sp_frames_prepare(&tool, &work, &f), SP_OK);
    memset(&fk, 0, sizeof fk);
    memset(&keep, 0, sizeof keep);
    for (int n = 0; n < 4000; ++n) {
        sp_motion_t m;
        sp_motion_t plat;
        sp_q24_t w[3];
        sp_q24_t dw[3];
        memset(&m, 0, sizeof m);
        for (int k = 0; k < 3; ++k) {
            m.pose.pos[k] = ref_q24(tu_uniform(&rng, -0.1, 0.1));
            m.pose.rpy[k] = (n % 3 == 1) ? keep.rpy[k] : ref_q24(tu_uniform(&rng, -0.3, 0.3));
            m.rpy_rate[k] = (n % 5 == 0) ? 0 : ref_q24(tu_uniform(&rng, -1.0, 1.0));
            m.rpy_acc[k] = (n % 5 == 0) ? 0 : ref_q24(tu_uniform(&rng, -5.0, 5.0));
        }
        if (n % 7 == 3) {
            m.rpy_rate[0] = 0; /* a turn about z alone */
            m.rpy_rate[1] = 0;
            m.rpy_acc[0] = 0;
            m.rpy_acc[1] = 0;
        }
        assert_int_equal(sp_frames_motion_to_platform_shared(&f, &fk, &keep, &m, &plat), SP_OK);
        if (keep.rates_valid) {
            /* the body rates of the rates they are of, at the keep's sines
             * (the consumer takes them only for equal rates) */
            int same = 1;
            assert_int_equal(sp_body_rates_sc(keep.sc, &keep.rates_of[0], &keep.rates_of[3], w, dw), SP_OK);
            for (int k = 0; k < 3; ++k) {
                assert_int_equal(keep.body[k], w[k]);
                assert_int_equal(keep.body[k + 3], dw[k]);
                same = same && keep.rates_of[k] == plat.rpy_rate[k] && keep.rates_of[k + 3] == plat.rpy_acc[k];
            }
            kept += (unsigned)same;
        }
        if (n % 11 == 5) {
            /* the IK alone at other angles: the kept body rates go */
            sp_ik_t ik;
            sp_pose_t other = plat.pose;
            other.rpy[2] = sp_add(other.rpy[2], 1, NULL);
            (void)sp_inverse_kinematics_kept(&sp_platform_default, &other, &keep, &ik);
            assert_int_equal(keep.rates_valid, 0u);
        }
    }
    assert_true(kept > 2000u); /* this motion's rates were kept: the check ran */
}

/* A call that waits (sp_leg_hold_t.lu_wait, a controller tick busy with
 * a command): it only refines, taking no step of the staged
 * factorisation and leaving its age, once per factorisation; the step it
 * put off is the next call's, and a factorisation overdue (age lu_keep,
 * no stage begun) is made whatever lu_wait says. The forces at one
 * motion stay those of a fresh solve within 0.05 N throughout. */
static void held_call(const sp_motion_t *m, const sp_ik_t *ik, const sp_jacobian_t *jac, sp_lu6_t *luk,
                      sp_leg_hold_t *hk, unsigned wait, const sp_q8_t f[6])
{
    sp_q8_t fh[6];
    sp_q24_t rt[6];
    hk->lu_wait = (uint8_t)wait;
    assert_int_equal(sp_inverse_dynamics_held(&sp_platform_default, m, ik, jac, NULL, fh, luk, rt, hk, 0x3Fu), SP_OK);
    for (int i = 0; i < 6; ++i) {
        assert_near(ref_f8(fh[i]), ref_f8(f[i]), 0.05, "leg %d", i);
    }
}

static void test_inverse_dynamics_held_waits(void **state)
{
    const sp_platform_t *p = &sp_platform_default;
    sp_motion_t m;
    sp_ik_t ik;
    sp_jacobian_t jac;
    sp_lu6_t lu;
    sp_q8_t f[6];
    sp_q24_t rt[6];
    (void)state;
    memset(&m, 0, sizeof m);
    m.pose = p->home;
    m.vel[0] = ref_q24(0.2);
    m.rpy_rate[2] = ref_q24(0.1);
    m.acc[2] = ref_q24(1.0);
    assert_int_equal(sp_inverse_kinematics(p, &m.pose, &ik), SP_OK);
    assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
    assert_int_equal(sp_inverse_dynamics_rates(p, &m, &ik, &jac, NULL, f, &lu, rt), SP_OK);
    for (int calls = 2; calls <= 3; ++calls) {
        /* staged over two calls (lu_keep 8) and over three (9, as the
         * controller): begun at age lu_keep - lead */
        sp_lu6_t luk;
        sp_leg_hold_t hk;
        int lead = calls - 1;
        int due;
        memset(&hk, 0, sizeof hk);
        memset(&luk, 0, sizeof luk);
        hk.lu_keep = (uint8_t)(6 + calls);
        hk.lu_staged = (uint8_t)calls;
        due = hk.lu_keep - lead;
        held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* nothing to refine from: factorised */
        assert_int_equal(hk.lu_age, 0);
        assert_int_equal(hk.lu_waited, 0);
        for (int j = 1; j <= due; ++j) {
            held_call(&m, &ik, &jac, &luk, &hk, 0u, f);
            assert_int_equal(hk.lu_age, j);
        }
        held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* due to begin: waits */
        assert_int_equal(hk.lu_next.begun, 0);
        assert_int_equal(hk.lu_age, due);
        assert_int_equal(hk.lu_waited, 1);
        held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* a second wait on one factorisation: begins */
        assert_int_equal(hk.lu_next.begun, 1);
        assert_int_equal(hk.lu_next.steps, 1);
        assert_int_equal(hk.lu_age, due + 1);
        if (calls == 3) {
            held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* its middle step */
            assert_int_equal(hk.lu_next.begun, 1);
            assert_int_equal(hk.lu_next.steps, 2);
            assert_int_equal(hk.lu_age, due + 2);
        }
        held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* finishes: the next factorisation */
        assert_int_equal(hk.lu_next.begun, 0);
        assert_int_equal(hk.lu_age, 1);
        assert_int_equal(hk.lu_waited, 0);
        for (int j = 2; j <= due + 1; ++j) {
            held_call(&m, &ik, &jac, &luk, &hk, 0u, f); /* the last begins */
        }
        assert_int_equal(hk.lu_next.begun, 1);
        assert_int_equal(hk.lu_age, due + 1);
        held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* due to step or finish: waits, the stage kept */
        assert_int_equal(hk.lu_next.begun, 1);
        assert_int_equal(hk.lu_next.steps, 1);
        assert_int_equal(hk.lu_age, due + 1);
        assert_int_equal(hk.lu_waited, 1);
        for (int j = 1; j < calls; ++j) {
            held_call(&m, &ik, &jac, &luk, &hk, 1u, f); /* the wait used up: steps, finishes */
        }
        assert_int_equal(hk.lu_next.begun, 0);
        assert_int_equal(hk.lu_age, 1);
        /* overdue (the controller's repeated reference): factorised, no wait */
        hk.lu_age = hk.lu_keep;
        held_call(&m, &ik, &jac, &luk, &hk, 1u, f);
        assert_int_equal(hk.lu_age, 0);
        assert_int_equal(hk.lu_waited, 0);
    }
}

static void test_inverse_dynamics_held(void **state)
{
    uint64_t rng = 29;
    double worst = 0.0;
    double worst_lu = 0.0;
    int refined = 0;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz, q[6];
        sp_motion_t m, m2;
        sp_ik_t ik, ik2;
        sp_jacobian_t jac, jac2;
        sp_lu6_t lu;
        sp_leg_hold_t hold;
        sp_q8_t f[6], fh[6];
        sp_q24_t rt[6], rth[6];
        random_platform(&rng, &p, &hz);
        p.leg_mass.cylinder_mass = ref_q16(tu_uniform(&rng, 0.0, 120.0));
        p.leg_mass.cylinder_com = ref_q24(tu_uniform(&rng, 0.1, 1.0));
        p.leg_mass.rod_mass = ref_q16(tu_uniform(&rng, 1.0, 60.0));
        p.leg_mass.rod_com = ref_q24(tu_uniform(&rng, 0.1, 1.0));
        random_pose(&rng, hz, &m.pose, q);
        for (int k = 0; k < 3; ++k) {
            m.vel[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.rpy_rate[k] = ref_q24(tu_uniform(&rng, -1, 1));
            m.acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
            m.rpy_acc[k] = ref_q24(tu_uniform(&rng, -10, 10));
        }
        /* 1 ms on, at constant acceleration */
        m2 = m;
        for (int k = 0; k < 3; ++k) {
            m2.pose.pos[k] += ref_q24(1e-3 * ref_f24(m.vel[k]) + 0.5e-6 * ref_f24(m.acc[k]));
            m2.pose.rpy[k] += ref_q24(1e-3 * ref_f24(m.rpy_rate[k]) + 0.5e-6 * ref_f24(m.rpy_acc[k]));
            m2.vel[k] += ref_q24(1e-3 * ref_f24(m.acc[k]));
            m2.rpy_rate[k] += ref_q24(1e-3 * ref_f24(m.rpy_acc[k]));
        }
        assert_int_equal(sp_inverse_kinematics(&p, &m.pose, &ik), SP_OK);
        assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
        assert_int_equal(sp_inverse_kinematics(&p, &m2.pose, &ik2), SP_OK);
        assert_int_equal(sp_jacobian(&ik2, &jac2), SP_OK);
        assert_int_equal(sp_inverse_dynamics_rates(&p, &m, &ik, &jac, NULL, f, &lu, rt), SP_OK);
        /* nothing kept: every leg computed */
        memset(&hold, 0, sizeof hold);
        assert_int_equal(sp_inverse_dynamics_held(&p, &m, &ik, &jac, NULL, fh, &lu, rth, &hold, 0x07u), SP_OK);
        assert_memory_equal(fh, f, sizeof f);
        assert_memory_equal(rth, rt, sizeof rt);
        assert_int_equal(hold.fresh, 0x3F);
        assert_int_equal(hold.held, 0x3F);
        /* the same motion, half kept: the same forces */
        assert_int_equal(sp_inverse_dynamics_held(&p, &m, &ik, &jac, NULL, fh, &lu, rth, &hold, 0x38u), SP_OK);
        assert_int_equal(hold.fresh, 0x38);
        assert_memory_equal(fh, f, sizeof f);
        assert_memory_equal(rth, rt, sizeof rt);
        /* hold NULL: sp_inverse_dynamics_rates */
        assert_int_equal(sp_inverse_dynamics_held(&p, &m, &ik, &jac, NULL, fh, &lu, rth, NULL, 0u), SP_OK);
        assert_memory_equal(fh, f, sizeof f);
        /* 1 ms later with legs 1-3 kept */
        assert_int_equal(sp_inverse_dynamics_rates(&p, &m2, &ik2, &jac2, NULL, f, &lu, rt), SP_OK);
        assert_int_equal(sp_inverse_dynamics_held(&p, &m2, &ik2, &jac2, NULL, fh, &lu, rth, &hold, 0x38u), SP_OK);
        assert_memory_equal(rth, rt, sizeof rt);
        for (int i = 0; i < 6; ++i) {
            worst = fmax(worst, fabs(ref_f8(fh[i]) - ref_f8(f[i])));
            assert_near(ref_f8(fh[i]), ref_f8(f[i]), 8.0, "motion %d leg %d: kept terms 1 ms old", n, i);
        }
        {
            /* the factorisation kept (hold.lu_keep 6): made at m, then five
             * refinements 1, 2, ... 5 ms on (constant acceleration), each
             * from the forces before, every leg's terms computed: against
             * the fresh solve at each motion; every other motion staged
             * as the controller does it (lu_keep 8): refinements 1 to 8 ms
             * on, the last beginning the next factorisation, then one
             * with it finished (its motion's 8 ms, 1 ms old) */
            sp_leg_hold_t hk;
            sp_lu6_t luk;
            sp_motion_t mj;
            int staged = n % 2;
            int unbroken = 1;
            memset(&hk, 0, sizeof hk);
            memset(&luk, 0, sizeof luk);
            hk.lu_keep = staged ? 8u : 6u;
            hk.lu_staged = (uint8_t)(staged ? 2 : 0);
            for (int j = 0; j <= (staged ? 9 : 5); ++j) {
                sp_ik_t ikj;
                sp_jacobian_t jacj;
                double t = 1e-3 * j;
                mj = m;
                for (int k = 0; k < 3; ++k) {
                    mj.pose.pos[k] += ref_q24(t * ref_f24(m.vel[k]) + 0.5 * t * t * ref_f24(m.acc[k]));
                    mj.pose.rpy[k] += ref_q24(t * ref_f24(m.rpy_rate[k]) + 0.5 * t * t * ref_f24(m.rpy_acc[k]));
                    mj.vel[k] += ref_q24(t * ref_f24(m.acc[k]));
                    mj.rpy_rate[k] += ref_q24(t * ref_f24(m.rpy_acc[k]));
                }
                assert_int_equal(sp_inverse_kinematics(&p, &mj.pose, &ikj), SP_OK);
                assert_int_equal(sp_jacobian(&ikj, &jacj), SP_OK);
                assert_int_equal(sp_inverse_dynamics_rates(&p, &mj, &ikj, &jacj, NULL, f, &lu, rt), SP_OK);
                assert_int_equal(sp_inverse_dynamics_held(&p, &mj, &ikj, &jacj, NULL, fh, &luk, rth, &hk, 0x3Fu),
                                 SP_OK);
                assert_memory_equal(rth, rt, sizeof rt);
                if (hk.lu_age == 0u) {
                    /* factorised (j = 0, and after a call outside the leg
                     * terms' fast envelope, which keeps nothing): the plain
                     * solve, bit for bit */
                    assert_memory_equal(fh, f, sizeof f);
                } else {
                    ++refined;
                    assert_true(j > 0 && hk.lu_age <= (uint8_t)j);
                }
                for (int i = 0; i < 6; ++i) {
                    worst_lu = fmax(worst_lu, fabs(ref_f8(fh[i]) - ref_f8(f[i])));
                    assert_near(ref_f8(fh[i]), ref_f8(f[i]), 1.5, "motion %d leg %d: factorisation %d ms old", n, i, j);
                }
                if (hk.lu_age == 0u && j > 0) {
                    unbroken = 0; /* factorised again: the ages start over */
                }
                if (staged && unbroken) {
                    /* the staged factorisation's two calls */
                    assert_int_equal(hk.lu_next.begun, j == 8);
                    assert_int_equal(hk.lu_age, (j == 9) ? 1 : j);
                }
            }
            /* the sixth call factorises again (staged: refines with the
             * factorisation finished by the last) */
            assert_int_equal(sp_inverse_dynamics_held(&p, &m2, &ik2, &jac2, NULL, fh, &luk, rth, &hk, 0x3Fu), SP_OK);
            if (!staged || unbroken) {
                assert_int_equal(hk.lu_age, staged ? 2u : 0u);
            }
        }
        /* massless legs: nothing to keep */
        memset(&p.leg_mass, 0, sizeof p.leg_mass);
        assert_int_equal(sp_inverse_dynamics_rates(&p, &m, &ik, &jac, NULL, f, &lu, rt), SP_OK);
        assert_int_equal(sp_inverse_dynamics_held(&p, &m, &ik, &jac, NULL, fh, &lu, rth, &hold, 0u), SP_OK);
        assert_memory_equal(fh, f, sizeof f);
        assert_int_equal(hold.fresh, 0x3F);
        assert_int_equal(hold.held, 0);
    }
    print_message("ID with half the leg terms kept from 1 ms before: worst force difference %.4f N\n", worst);
    print_message(
        "ID refined with a factorisation up to 5 ms old (8 staged): worst force difference %.4f N over %d refined "
        "calls\n",
        worst_lu, refined);
    assert_true(refined > N_POSES); /* most motions refine (five calls each) */
}

static void test_check_legs(void **state)
{
    uint64_t rng = 20;
    sp_platform_t p;
    double hz;
    sp_leg_limits_t rep;
    sp_q24_t l[6], v[6];
    sp_q8_t f[6];
    (void)state;
    random_platform(&rng, &p, &hz);
    for (int i = 0; i < 6; ++i) {
        l[i] = ref_q24(2.0);
        v[i] = 0;
        f[i] = 0;
    }
    assert_int_equal(sp_check_legs(&p, l, v, f, &rep), SP_OK);
    l[1] = p.leg_length_min - 1;
    l[4] = p.leg_length_max + 1;
    v[2] = -p.leg_velocity_max - 1;
    f[5] = p.force_max + 1;
    assert_int_equal(sp_check_legs(&p, l, v, f, &rep), SP_E_RANGE);
    assert_int_equal(rep.too_short, 1u << 1);
    assert_int_equal(rep.too_long, 1u << 4);
    assert_int_equal(rep.too_fast, 1u << 2);
    assert_int_equal(rep.over_force, 1u << 5);
    assert_int_equal(sp_check_legs(&p, l, NULL, NULL, &rep), SP_E_RANGE);
    assert_int_equal(rep.too_fast | rep.over_force, 0u);
    assert_int_equal(sp_check_legs(NULL, l, NULL, NULL, &rep), SP_E_ARG);
}

/* sp_length_from_sensor / sp_length_to_sensor against the double model on
 * random zeros, scales and lengths; identity (bit for bit) with zeros and NULL. */
static void test_length_sensors(void **state)
{
    (void)state;
    uint64_t rng = 0x5EED5u;
    sp_platform_t p = sp_platform_default;
    sp_length_sensors_t ls;
    const double q24 = 16777216.0, q30 = 1073741824.0;
    double lmin = (double)p.leg_length_min / q24;
    memset(&ls, 0, sizeof ls);
    for (int n = 0; n < 2000; ++n) {
        sp_q24_t l = (sp_q24_t)llround(tu_uniform(&rng, 1.5, 3.5) * q24), r, back;
        unsigned leg = (unsigned)(n % SP_LEGS);
        assert_int_equal(sp_length_to_sensor(&p, &ls, leg, l, &r), SP_OK);
        assert_int_equal(r, l);
        assert_int_equal(sp_length_from_sensor(&p, NULL, leg, l, &r), SP_OK);
        assert_int_equal(r, l);
        double zero = tu_uniform(&rng, -0.05, 0.05), k = tu_uniform(&rng, -0.01, 0.01);
        ls.zero[leg] = (sp_q24_t)llround(zero * q24);
        ls.scale[leg] = (sp_q30_t)llround(k * q30);
        ls.scale_inv[leg] = (sp_q30_t)llround((1.0 / (1.0 + k) - 1.0) * q30);
        double ld = (double)l / q24;
        double want = lmin + (1.0 + (double)ls.scale[leg] / q30) * (ld - lmin) + (double)ls.zero[leg] / q24;
        assert_int_equal(sp_length_to_sensor(&p, &ls, leg, l, &r), SP_OK);
        assert_true(fabs((double)r / q24 - want) <= 1.0 / q24);
        assert_int_equal(sp_length_from_sensor(&p, &ls, leg, r, &back), SP_OK);
        assert_true(llabs((long long)back - (long long)l) <= 2);
        ls.zero[leg] = 0;
        ls.scale[leg] = 0;
        ls.scale_inv[leg] = 0;
    }
    /* saturation and bad arguments */
    ls.zero[0] = (sp_q24_t)(0.05 * q24);
    sp_q24_t r = 7;
    assert_int_equal(sp_length_to_sensor(&p, &ls, 0, INT32_MAX, &r), SP_E_OVERFLOW);
    assert_int_equal(r, INT32_MAX);
    r = 7;
    assert_int_equal(sp_length_to_sensor(&p, &ls, 6, 0, &r), SP_E_ARG);
    assert_int_equal(sp_length_from_sensor(NULL, &ls, 0, 0, &r), SP_E_ARG);
    assert_int_equal(sp_length_from_sensor(&p, &ls, 0, 0, NULL), SP_E_ARG);
    assert_int_equal(r, 7);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orientation),
        cmocka_unit_test(test_inverse_kinematics),
        cmocka_unit_test(test_ik_rejects_bad_input),
        cmocka_unit_test(test_ik_edge_paths),
        cmocka_unit_test(test_leg_rates_and_stretch),
        cmocka_unit_test(test_leg_rates_reference),
        cmocka_unit_test(test_body_rates),
        cmocka_unit_test(test_body_rates_reference),
        cmocka_unit_test(test_rates_wide_paths),
        cmocka_unit_test(test_forward_kinematics),
        cmocka_unit_test(test_fk_chord),
        cmocka_unit_test(test_fk_chord_step_plain),
        cmocka_unit_test(test_forward_kinematics_failures),
        cmocka_unit_test(test_inverse_dynamics),
        cmocka_unit_test(test_inverse_dynamics_legs_power),
        cmocka_unit_test(test_jacobian_near),
        cmocka_unit_test(test_inverse_kinematics_kept),
        cmocka_unit_test(test_legs_fit),
        cmocka_unit_test(test_inverse_dynamics_rates_reference),
        cmocka_unit_test(test_inverse_dynamics_held),
        cmocka_unit_test(test_frames_keep_body_rates),
        cmocka_unit_test(test_inverse_dynamics_held_waits),
        cmocka_unit_test(test_check_legs),
        cmocka_unit_test(test_length_sensors),
    };
    return cmocka_run_group_tests_name("kinematics", tests, NULL, NULL);
}
