/*
 * Unit tests of the fixed-point kinematics and dynamics (sp/kinematics.h,
 * sp/dynamics.h) on random 6-6 geometries and random poses, against a small
 * double-precision evaluation of the same equations written in the test.
 * (The independent float64 model in tools/stewart/model.py is compared with
 * the core in tests/python as well, on 10,000 poses.)
 *
 * Tolerances:
 *   T entries                       4e-9 (4 LSB of Q30), orthonormal to 8e-9
 *   leg lengths                     0.2 um
 *   unit vectors                    5e-8 (the leg vector is Q24: 60 nm)
 *   leg rates (vs finite diff.)     1e-6 m/s
 *   body rates and derivatives      1e-6 rad/s, rad/s^2
 *   forward kinematics              1 um, 5 urad; <= 3 iterations warm-started
 *                                   from a 1 kHz neighbour, <= 8 cold from home
 *   inverse dynamics                0.05 N: the forces reproduce the wrench
 *                                   the motion needs (checked in double)
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

#include "sp/dynamics.h"
#include "sp/kinematics.h"
#include "sp/limits.h"
#include "test_util.h"

#define N_POSES 3000
#define DEG (3.14159265358979323846 / 180.0)

static int32_t q24(double v)
{
    return (int32_t)llround(v * 16777216.0);
}
static int32_t q16(double v)
{
    return (int32_t)llround(v * 65536.0);
}
static double f24(int32_t v)
{
    return (double)v / 16777216.0;
}
static double f30(int32_t v)
{
    return (double)v / 1073741824.0;
}
static double f8(int32_t v)
{
    return (double)v / 256.0;
}

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
            p->base_joint[i][0] = q24(rb * cos(ab));
            p->base_joint[i][1] = q24(rb * sin(ab));
            p->base_joint[i][2] = 0;
            p->platform_joint[i][0] = q24(rp * cos(ap));
            p->platform_joint[i][1] = q24(rp * sin(ap));
            p->platform_joint[i][2] = q24(zoff);
        }
    }
    p->mass = q16(tu_uniform(rng, 500.0, 6000.0));
    {
        double ixx = tu_uniform(rng, 300.0, 4000.0);
        double iyy = tu_uniform(rng, 300.0, 4000.0);
        double izz = ixx + iyy - tu_uniform(rng, 0.0, 200.0);
        double ixz = tu_uniform(rng, -80.0, 80.0);
        double ixy = tu_uniform(rng, -50.0, 50.0);
        p->inertia[0][0] = q16(ixx);
        p->inertia[1][1] = q16(iyy);
        p->inertia[2][2] = q16(izz);
        p->inertia[0][2] = p->inertia[2][0] = q16(ixz);
        p->inertia[0][1] = p->inertia[1][0] = q16(ixy);
    }
    p->gravity = q24(9.80665);
    *home_z = tu_uniform(rng, 1.8, 2.6);
    p->home.pos[2] = q24(*home_z);
    p->leg_length_min = q24(0.5);
    p->leg_length_max = q24(5.0);
    p->force_max = (int32_t)(500000 * 256);
    p->leg_velocity_max = q24(2.0);
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
        pose->pos[k] = q24(q[k]);
        pose->rpy[k] = q24(q[3 + k]);
        q[k] = f24(pose->pos[k]); /* the exact value the core sees */
        q[3 + k] = f24(pose->rpy[k]);
    }
}

/* Column-vector rotation motion -> base, R = Rz(yaw) Ry(pitch) Rx(roll). */
static void rot_d(const double rpy[3], double r[3][3])
{
    double cr = cos(rpy[0]), sr = sin(rpy[0]);
    double cp = cos(rpy[1]), sp = sin(rpy[1]);
    double cy = cos(rpy[2]), sy = sin(rpy[2]);
    r[0][0] = cy * cp;
    r[0][1] = cy * sp * sr - sy * cr;
    r[0][2] = cy * sp * cr + sy * sr;
    r[1][0] = sy * cp;
    r[1][1] = sy * sp * sr + cy * cr;
    r[1][2] = sy * sp * cr - cy * sr;
    r[2][0] = -sp;
    r[2][1] = cp * sr;
    r[2][2] = cp * cr;
}

static void ik_d(const sp_platform_t *p, const double q[6], double len[6], double unit[6][3], double arm[6][3])
{
    double r[3][3];
    rot_d(&q[3], r);
    for (int i = 0; i < 6; ++i) {
        double l[3];
        double n = 0;
        for (int c = 0; c < 3; ++c) {
            arm[i][c] = r[c][0] * f24(p->platform_joint[i][0]) + r[c][1] * f24(p->platform_joint[i][1]) +
                        r[c][2] * f24(p->platform_joint[i][2]);
            l[c] = arm[i][c] + q[c] - f24(p->base_joint[i][c]);
            n += l[c] * l[c];
        }
        len[i] = sqrt(n);
        for (int c = 0; c < 3; ++c) {
            unit[i][c] = l[c] / len[i];
        }
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
            rpy[k] = q24(tu_uniform(&rng, -3.2, 3.2));
            a[k] = f24(rpy[k]);
        }
        assert_int_equal(sp_orientation(rpy, &t), SP_OK);
        rot_d(a, r);
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                double dot = 0;
                /* the paper's T is the transpose of R */
                assert_true(fabs(f30(t.t[i][j]) - r[j][i]) < 4e-9);
                for (int k = 0; k < 3; ++k) {
                    dot += f30(t.t[i][k]) * f30(t.t[j][k]);
                }
                assert_true(fabs(dot - (i == j ? 1.0 : 0.0)) < 8e-9);
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
        ik_d(&p, q, len, unit, arm);
        for (int i = 0; i < 6; ++i) {
            double e = fabs(f24(ik.length[i]) - len[i]);
            worst_len = e > worst_len ? e : worst_len;
            assert_true(e < 0.2e-6);
            for (int c = 0; c < 3; ++c) {
                assert_true(fabs(f30(ik.unit[i][c]) - unit[i][c]) < 5e-8);
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
        p.platform_joint[i][1] = q24(0.1 * i);
        p.base_joint[i][1] = q24(0.1 * i);
        p.base_joint[i][0] = -q24(0.002);
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(ik.length[i], q24(0.002));
        assert_true(ik.unit[i][0] <= (INT32_C(1) << 30) && ik.unit[i][0] >= (INT32_C(1) << 30) - 3); /* 3 LSB */
        assert_int_equal(ik.unit[i][1], 0);
    }
    p.base_joint[3][0] = -q24(0.0015);
    p.base_joint[3][2] = q24(0.0002);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    assert_true(fabs(f24(ik.length[3]) - sqrt(0.0015 * 0.0015 + 0.0002 * 0.0002)) < 0.5 / 16777216.0 + 1e-12);
    p.base_joint[3][0] = -q24(0.0009);
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
        p.base_joint[i][1] = INT32_MAX - q24(1.0);
        p.base_joint[i][2] = 0;
    }
    pose.rpy[2] = q24(45.0 * DEG);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_OVERFLOW);
    assert_true(abs(ik.arm[0][0]) < 256); /* 128 m (cos 45 - sin 45) */
    assert_int_equal(ik.arm[0][1], INT32_MAX);
    assert_true(abs(ik.length[0] - q24(1.0)) < 256);
    pose.rpy[2] = -q24(45.0 * DEG); /* the x component saturates */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.base_joint[i][0] = INT32_MAX - q24(1.0);
        p.base_joint[i][1] = 0;
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_OVERFLOW);
    assert_int_equal(ik.arm[0][0], INT32_MAX);
    /* and negative: a joint at (-128 m, -128 m), base at (-127 m, 0) */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.platform_joint[i][0] = INT32_MIN;
        p.platform_joint[i][1] = INT32_MIN;
        p.base_joint[i][0] = INT32_MIN + q24(1.0);
    }
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_E_OVERFLOW);
    assert_int_equal(ik.arm[0][0], INT32_MIN);
    assert_true(abs(ik.length[0] - q24(1.0)) < 256);
}

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
        sp_q24_t vel[3];
        sp_q24_t rate[3];
        sp_q24_t legrate[6];
        sp_q24_t stretch[6];
        sp_ik_t ik;
        sp_ik_t home_ik;
        double dt = 1e-5;
        double len1[6], len2[6], unit[6][3], arm[6][3];
        double q2[6];
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &pose, q);
        for (int k = 0; k < 3; ++k) {
            vel[k] = q24(tu_uniform(&rng, -1.0, 1.0));
            rate[k] = q24(tu_uniform(&rng, -1.0, 1.0));
        }
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        assert_int_equal(sp_leg_rates(&ik, vel, rate, legrate), SP_OK);
        /* central difference of the double IK along the motion */
        for (int k = 0; k < 3; ++k) {
            q2[k] = q[k] + f24(vel[k]) * dt;
            q2[3 + k] = q[3 + k] + f24(rate[k]) * dt;
            q[k] -= f24(vel[k]) * dt;
            q[3 + k] -= f24(rate[k]) * dt;
        }
        ik_d(&p, q, len1, unit, arm);
        ik_d(&p, q2, len2, unit, arm);
        for (int i = 0; i < 6; ++i) {
            assert_true(fabs(f24(legrate[i]) - (len2[i] - len1[i]) / (2 * dt)) < 1e-6);
        }
        pose2 = p.home;
        assert_int_equal(sp_inverse_kinematics(&p, &pose2, &home_ik), SP_OK);
        assert_int_equal(sp_leg_stretch(&ik, &home_ik, stretch), SP_OK);
        for (int i = 0; i < 6; ++i) {
            assert_int_equal(stretch[i], ik.length[i] - home_ik.length[i]);
        }
    }
}

static void body_rates_d(const double a[3], const double d[3], const double dd[3], double w[3], double wd[3])
{
    double sr = sin(a[0]), cr = cos(a[0]), sp = sin(a[1]), cp = cos(a[1]);
    w[0] = d[0] - d[2] * sp;
    w[1] = d[1] * cr + d[2] * cp * sr;
    w[2] = -d[1] * sr + d[2] * cp * cr;
    (void)dd;
    (void)wd;
}

static void test_body_rates(void **state)
{
    uint64_t rng = 15;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_q24_t a[3], d[3], dd[3], w[3], wd[3];
        double ad[3], dv[3], ddv[3], wr[3], w1[3], w2[3], unused[3];
        double h = 1e-6;
        for (int k = 0; k < 3; ++k) {
            a[k] = q24(tu_uniform(&rng, -0.3, 0.3));
            d[k] = q24(tu_uniform(&rng, -1.0, 1.0));
            dd[k] = q24(tu_uniform(&rng, -10.0, 10.0));
            ad[k] = f24(a[k]);
            dv[k] = f24(d[k]);
            ddv[k] = f24(dd[k]);
        }
        assert_int_equal(sp_body_rates(a, d, dd, w, wd), SP_OK);
        body_rates_d(ad, dv, ddv, wr, unused);
        for (int k = 0; k < 3; ++k) {
            assert_true(fabs(f24(w[k]) - wr[k]) < 1e-6);
        }
        /* the derivative against a central difference along the motion */
        {
            double a1[3], a2[3], d1[3], d2[3];
            for (int k = 0; k < 3; ++k) {
                a1[k] = ad[k] - dv[k] * h;
                a2[k] = ad[k] + dv[k] * h;
                d1[k] = dv[k] - ddv[k] * h;
                d2[k] = dv[k] + ddv[k] * h;
            }
            body_rates_d(a1, d1, ddv, w1, unused);
            body_rates_d(a2, d2, ddv, w2, unused);
            for (int k = 0; k < 3; ++k) {
                assert_true(fabs(f24(wd[k]) - (w2[k] - w1[k]) / (2 * h)) < 1e-5);
            }
        }
    }
}

/* The rate functions' paths off the common one: sp_leg_rates with an
 * angular velocity of 64 rad/s or more (each step saturating on its own)
 * against the common path just below it, both against double; the
 * saturations of either path; sp_body_rates_sc with sines and cosines off
 * the unit circle (the saturating path); sp_jacobian beyond 8. */
static void test_rates_wide_paths(void **state)
{
    sp_platform_t p;
    sp_pose_t pose;
    sp_ik_t ik;
    sp_q24_t vel[3] = {0, 0, 0};
    sp_q24_t rr[3] = {0, 0, 0};
    sp_q24_t rate[SP_LEGS];
    sp_jacobian_t jac;
    const double yaw_rates[2] = {60.0, 100.0}; /* below, above 64 rad/s */
    (void)state;
    memset(&p, 0, sizeof p);
    memset(&pose, 0, sizeof pose);
    for (int i = 0; i < SP_LEGS; ++i) {
        double b = (60.0 * i + 10.0) * DEG;
        double a = (60.0 * i - 10.0) * DEG;
        p.base_joint[i][0] = q24(1.0 * cos(b));
        p.base_joint[i][1] = q24(1.0 * sin(b));
        p.platform_joint[i][0] = q24(0.6 * cos(a));
        p.platform_joint[i][1] = q24(0.6 * sin(a));
    }
    pose.pos[2] = q24(1.0);
    pose.rpy[0] = q24(0.1);
    pose.rpy[1] = q24(-0.05);
    assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
    for (int k = 0; k < 2; ++k) {
        double w[3];
        vel[0] = q24(0.5);
        vel[2] = -q24(0.25);
        rr[0] = q24(0.3);
        rr[2] = q24(yaw_rates[k]);
        assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_OK);
        /* w = roll_rate (row 0 of T) + yaw_rate e_z (pitch rate 0) */
        for (int c = 0; c < 3; ++c) {
            w[c] = f24(rr[0]) * f30(ik.rot.t[0][c]);
        }
        w[2] += f24(rr[2]);
        for (int i = 0; i < SP_LEGS; ++i) {
            double r[3], v[3], want = 0;
            for (int c = 0; c < 3; ++c) {
                r[c] = f24(ik.arm[i][c]);
            }
            v[0] = f24(vel[0]) + w[1] * r[2] - w[2] * r[1];
            v[1] = f24(vel[1]) + w[2] * r[0] - w[0] * r[2];
            v[2] = f24(vel[2]) + w[0] * r[1] - w[1] * r[0];
            for (int c = 0; c < 3; ++c) {
                want += f30(ik.unit[i][c]) * v[c];
            }
            assert_true(fabs(f24(rate[i]) - want) < 2e-7);
        }
    }
    rr[2] = q24(120.0); /* 72 m/s at the joints: still in range */
    assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_OK);
    vel[1] = q24(100.0); /* 172 m/s: saturates on the wide path */
    assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_E_OVERFLOW);
    rr[2] = q24(60.0); /* 136 m/s: saturates on the common path */
    assert_int_equal(sp_leg_rates(&ik, vel, rr, rate), SP_E_OVERFLOW);

    /* body rates: roll 0 and pitch 0.2; the same with cos(roll) 8 LSB
     * above 1 takes the saturating path and agrees to within 3 LSB */
    {
        sp_q30_t sc[6];
        sp_q24_t d[3] = {q24(0.7), q24(-1.1), q24(2.3)};
        sp_q24_t dd[3] = {q24(5.0), q24(-3.0), q24(9.0)};
        sp_q24_t w1[3], wd1[3], w2[3], wd2[3];
        sc[0] = 0;
        sc[1] = INT32_C(1) << 30;
        sp_sincos_q24(q24(0.2), &sc[2], &sc[3]);
        sc[4] = 0;
        sc[5] = INT32_C(1) << 30;
        assert_int_equal(sp_body_rates_sc(sc, d, dd, w1, wd1), SP_OK);
        sc[1] += 8;
        assert_int_equal(sp_body_rates_sc(sc, d, dd, w2, wd2), SP_OK);
        for (int k = 0; k < 3; ++k) {
            assert_true(abs(w1[k] - w2[k]) <= 3 && abs(wd1[k] - wd2[k]) <= 3);
        }
        /* saturation on both paths */
        d[0] = d[1] = d[2] = q24(100.0);
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
    ik.arm[2][0] = q24(10.0);
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

static void test_solve6(void **state)
{
    uint64_t rng = 16;
    sp_jacobian_t m;
    int64_t b[6];
    int64_t x[6];
    double worst = 0;
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double md[6][6];
        double xd[6];
        /* diagonally dominant random matrix: well conditioned */
        for (int i = 0; i < 6; ++i) {
            for (int j = 0; j < 6; ++j) {
                md[i][j] = tu_uniform(&rng, -0.5, 0.5) + (i == j ? 2.0 : 0.0);
                m.j[i][j] = (int32_t)llround(md[i][j] * 268435456.0);
                md[i][j] = m.j[i][j] / 268435456.0;
            }
            xd[i] = tu_uniform(&rng, -1e5, 1e5);
        }
        for (int tr = 0; tr < 2; ++tr) {
            for (int i = 0; i < 6; ++i) {
                double s = 0;
                for (int j = 0; j < 6; ++j) {
                    s += (tr ? md[j][i] : md[i][j]) * xd[j];
                }
                b[i] = llround(s * 16777216.0);
            }
            assert_int_equal(sp_solve6(&m, tr, b, x), SP_OK);
            for (int i = 0; i < 6; ++i) {
                /* relative 3e-8 of max |x| (1e5): the solve's 32-bit path
                 * rounds b to 29 and x to 27 to 28 significant bits
                 * (x ~ b / 2 here); the int64 path was within 1e-8 */
                double e = fabs((double)x[i] / 16777216.0 - xd[i]);
                worst = e > worst ? e : worst;
                if (e >= 3e-8 * 1e5 + 1e-6) {
                    fail_msg("solve6 n=%d tr=%d x[%d]=%.9f want %.9f", n, tr, i, (double)x[i] / 16777216.0, xd[i]);
                }
            }
        }
    }
    print_message("solve6: worst error %.3g (|x| up to 1e5)\n", worst);
    /* two equal rows: singular */
    for (int j = 0; j < 6; ++j) {
        m.j[5][j] = m.j[4][j];
    }
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_E_SINGULAR);
    memset(&m, 0, sizeof m);
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_E_SINGULAR);
    assert_int_equal(sp_solve6(NULL, 0, b, x), SP_E_ARG);
    /* a right-hand side of 2^56 or more is refused (x zeroed) */
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < 6; ++j) {
            m.j[i][j] = (i == j) ? (1 << 28) : 0;
        }
        b[i] = 1000;
    }
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_OK);
    assert_true(x[0] == 1000 && x[5] == 1000);
    b[3] = -((int64_t)1 << 56);
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_E_OVERFLOW);
    assert_true(x[0] == 0 && x[3] == 0 && x[5] == 0);
}

static void test_forward_kinematics(void **state)
{
    uint64_t rng = 17;
    sp_fk_options_t opt;
    uint32_t worst_warm = 0;
    uint32_t worst_cold = 0;
    double worst_pos = 0;
    double worst_rot = 0;
    (void)state;
    sp_fk_default_options(&opt);
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_pose_t truth;
        sp_pose_t guess;
        sp_pose_t out;
        sp_ik_t ik;
        sp_ik_t ik_out;
        sp_fk_info_t info;
        double q[6];
        double len[6], unit[6][3], arm[6][3];
        sp_q24_t l[6];
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &truth, q);
        /* lengths from the double IK, rounded to the sensor's Q24 */
        ik_d(&p, q, len, unit, arm);
        for (int i = 0; i < 6; ++i) {
            l[i] = q24(len[i]);
        }
        (void)ik;
        /* warm start: the previous 1 kHz tick at 1 m/s and 1 rad/s */
        guess = truth;
        for (int k = 0; k < 3; ++k) {
            guess.pos[k] += q24(tu_uniform(&rng, -1e-3, 1e-3));
            guess.rpy[k] += q24(tu_uniform(&rng, -1e-3, 1e-3));
        }
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
        for (int k = 0; k < 3; ++k) {
            double ep = fabs(f24(out.pos[k]) - q[k]);
            double er = fabs(f24(out.rpy[k]) - q[3 + k]);
            worst_pos = ep > worst_pos ? ep : worst_pos;
            worst_rot = er > worst_rot ? er : worst_rot;
            assert_true(ep < 1e-6);
            assert_true(er < 5e-6);
        }
        /* cold start from home (large jumps allowed) */
        {
            sp_fk_options_t cold = opt;
            cold.max_jump_pos = q24(1.0);
            cold.max_jump_rot = q24(1.0);
            guess = p.home;
            assert_int_equal(sp_forward_kinematics(&p, l, &guess, &cold, &out, &ik_out, &info), SP_OK);
            worst_cold = info.iterations > worst_cold ? info.iterations : worst_cold;
            for (int k = 0; k < 3; ++k) {
                assert_true(fabs(f24(out.pos[k]) - q[k]) < 1e-6);
                assert_true(fabs(f24(out.rpy[k]) - q[3 + k]) < 5e-6);
            }
            /* the same with the default jump limits: a discontinuity, and
             * the output stays at the guess */
            if (fabs(q[0]) > 0.06 || fabs(q[1]) > 0.06 || fabs(q[2] - hz) > 0.06) {
                assert_int_equal(sp_forward_kinematics(&p, l, &guess, &opt, &out, &ik_out, &info), SP_E_DISCONTINUITY);
                assert_memory_equal(&out, &guess, sizeof out);
            }
        }
    }
    print_message("FK: worst warm iterations %u, cold %u; worst error %.3g m, %.3g rad\n", worst_warm, worst_cold,
                  worst_pos, worst_rot);
}

/* The factorisation used twice per tick by the controller: sp_lu6_solve is
 * sp_solve6 bit for bit; sp_lu6_solve_transposed solves M^T x = b from M's
 * factors, against the exact solution (same bound as sp_solve6) and within
 * a few LSB of sp_solve6(M, transposed). */
static void test_lu6(void **state)
{
    uint64_t rng = 23;
    sp_jacobian_t m;
    sp_lu6_t lu;
    int64_t b[6];
    int64_t x[6];
    int64_t x2[6];
    int64_t worst_lsb = 0;
    double worst_err = 0;
    double worst_err2 = 0;
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double md[6][6];
        double xd[6];
        for (int i = 0; i < 6; ++i) {
            for (int j = 0; j < 6; ++j) {
                /* a row permutation of a diagonally dominant matrix:
                 * well conditioned, and the pivoting swaps rows */
                md[i][j] = tu_uniform(&rng, -0.3, 0.3) + (i == (j + n) % 6 ? 2.0 : 0.0);
                m.j[i][j] = (int32_t)llround(md[i][j] * 268435456.0);
                md[i][j] = m.j[i][j] / 268435456.0;
            }
            xd[i] = tu_uniform(&rng, -1e5, 1e5);
        }
        for (int tr = 0; tr < 2; ++tr) {
            for (int i = 0; i < 6; ++i) {
                double s = 0;
                for (int j = 0; j < 6; ++j) {
                    s += (tr ? md[j][i] : md[i][j]) * xd[j];
                }
                b[i] = llround(s * 16777216.0);
            }
            assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
            assert_int_equal(sp_solve6(&m, tr, b, x2), SP_OK);
            if (tr == 0) {
                assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
                assert_memory_equal(x, x2, sizeof x);
            } else {
                assert_int_equal(sp_lu6_solve_transposed(&lu, b, x), SP_OK);
                for (int i = 0; i < 6; ++i) {
                    int64_t d = x[i] - x2[i];
                    d = d < 0 ? -d : d;
                    worst_lsb = d > worst_lsb ? d : worst_lsb;
                    /* the bound of test_solve6 */
                    double e = fabs((double)x[i] / 16777216.0 - xd[i]);
                    double e2 = fabs((double)x2[i] / 16777216.0 - xd[i]);
                    worst_err = e > worst_err ? e : worst_err;
                    worst_err2 = e2 > worst_err2 ? e2 : worst_err2;
                    if (e >= 1e-8 * 1e5 + 1e-6) {
                        fail_msg("lu6 transposed n=%d x[%d]=%.9f want %.9f solve6 %.9f", n, i,
                                 (double)x[i] / 16777216.0, xd[i], (double)x2[i] / 16777216.0);
                    }
                }
            }
        }
    }
    print_message("lu6: transposed solve vs sp_solve6(M^T): worst %lld LSB of Q24 (|x| up to 1e5); worst error "
                  "%.3g (sp_solve6 %.3g)\n",
                  (long long)worst_lsb, worst_err, worst_err2);
    /* errors: singular, range, invalid factorisation */
    for (int j = 0; j < 6; ++j) {
        m.j[5][j] = m.j[4][j];
    }
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_E_SINGULAR);
    assert_int_equal(lu.valid, 0);
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_E_ARG);
    assert_int_equal(sp_lu6_solve_transposed(&lu, b, x), SP_E_ARG);
    assert_true(x[0] == 0 && x[5] == 0);
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < 6; ++j) {
            m.j[i][j] = (i == j) ? (1 << 28) : 0;
        }
        b[i] = 1000;
    }
    assert_int_equal(sp_lu6_factor(&m, 1, &lu), SP_OK);
    b[2] = (int64_t)1 << 56;
    assert_int_equal(sp_lu6_solve_transposed(&lu, b, x), SP_E_OVERFLOW);
    assert_true(x[0] == 0 && x[2] == 0);
    assert_int_equal(sp_lu6_factor(NULL, 0, &lu), SP_E_ARG);
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
    double worst_pos = 0;
    double worst_rot = 0;
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
        double len[6], unit[6][3], arm[6][3];
        sp_q24_t l[6];
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &truth, q);
        ik_d(&p, q, len, unit, arm);
        for (int i = 0; i < 6; ++i) {
            l[i] = q24(len[i]);
        }
        guess = truth;
        near = truth;
        for (int k = 0; k < 3; ++k) {
            guess.pos[k] += q24(tu_uniform(&rng, -1e-3, 1e-3));
            guess.rpy[k] += q24(tu_uniform(&rng, -1e-3, 1e-3));
            near.pos[k] += q24(tu_uniform(&rng, -1e-3, 1e-3));
            near.rpy[k] += q24(tu_uniform(&rng, -1e-3, 1e-3));
        }
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
        for (int k = 0; k < 3; ++k) {
            double ep = fabs(f24(out.pos[k]) - q[k]);
            double er = fabs(f24(out.rpy[k]) - q[3 + k]);
            worst_pos = ep > worst_pos ? ep : worst_pos;
            worst_rot = er > worst_rot ? er : worst_rot;
            assert_true(ep < 1e-6);
            assert_true(er < 5e-6);
        }
        /* far from the truth with a tight step limit: no convergence, the
         * guess returned and the cache untouched */
        if (n == 0) {
            sp_fk_options_t one = opt;
            sp_fk_cache_t before;
            sp_pose_t far = truth;
            far.pos[0] += q24(0.02);
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
    print_message("FK chord: worst iterations %u; worst error %.3g m, %.3g rad\n", worst_it, worst_pos, worst_rot);
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
    l[0] += q24(3.0);
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

/* The wrench that the forces produce, in double, against the wrench the
 * motion needs (Newton-Euler in the base frame, written independently). */
static void test_inverse_dynamics(void **state)
{
    uint64_t rng = 19;
    double worst = 0;
    (void)state;
    for (int n = 0; n < N_POSES; ++n) {
        sp_platform_t p;
        double hz;
        sp_motion_t m;
        double q[6];
        sp_ik_t ik;
        sp_q8_t f[6];
        sp_q8_t ext[3];
        double len[6], unit[6][3], arm[6][3];
        double r[3][3];
        double w[3], wd[3], need[6], got[6] = {0};
        double iw[3], iwd[3], tb[3];
        double mass;
        random_platform(&rng, &p, &hz);
        random_pose(&rng, hz, &m.pose, q);
        for (int k = 0; k < 3; ++k) {
            m.vel[k] = q24(tu_uniform(&rng, -1, 1));
            m.rpy_rate[k] = q24(tu_uniform(&rng, -1, 1));
            m.acc[k] = q24(tu_uniform(&rng, -10, 10));
            m.rpy_acc[k] = q24(tu_uniform(&rng, -10, 10));
            ext[k] = (int32_t)llround(tu_uniform(&rng, -2000, 2000) * 256.0);
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
        ik_d(&p, q, len, unit, arm);
        rot_d(&q[3], r);
        {
            double a[3] = {q[3], q[4], q[5]};
            double d[3] = {f24(m.rpy_rate[0]), f24(m.rpy_rate[1]), f24(m.rpy_rate[2])};
            double dd[3] = {f24(m.rpy_acc[0]), f24(m.rpy_acc[1]), f24(m.rpy_acc[2])};
            double sr = sin(a[0]), cr = cos(a[0]), sp = sin(a[1]), cp = cos(a[1]);
            w[0] = d[0] - d[2] * sp;
            w[1] = d[1] * cr + d[2] * cp * sr;
            w[2] = -d[1] * sr + d[2] * cp * cr;
            wd[0] = dd[0] - dd[2] * sp - d[2] * d[1] * cp;
            wd[1] = dd[1] * cr - d[1] * d[0] * sr + dd[2] * cp * sr - d[2] * d[1] * sp * sr + d[2] * d[0] * cp * cr;
            wd[2] = -dd[1] * sr - d[1] * d[0] * cr + dd[2] * cp * cr - d[2] * d[1] * sp * cr - d[2] * d[0] * cp * sr;
        }
        mass = p.mass / 65536.0;
        for (int k = 0; k < 3; ++k) {
            iw[k] = 0;
            iwd[k] = 0;
            for (int c = 0; c < 3; ++c) {
                iw[k] += p.inertia[k][c] / 65536.0 * w[c];
                iwd[k] += p.inertia[k][c] / 65536.0 * wd[c];
            }
        }
        tb[0] = iwd[0] + w[1] * iw[2] - w[2] * iw[1];
        tb[1] = iwd[1] + w[2] * iw[0] - w[0] * iw[2];
        tb[2] = iwd[2] + w[0] * iw[1] - w[1] * iw[0];
        for (int k = 0; k < 3; ++k) {
            need[k] = mass * f24(m.acc[k]) - f8(ext[k]) + (k == 2 ? mass * f24(p.gravity) : 0.0);
            need[3 + k] = r[k][0] * tb[0] + r[k][1] * tb[1] + r[k][2] * tb[2];
        }
        for (int i = 0; i < 6; ++i) {
            double fi = f8(f[i]);
            got[0] += fi * unit[i][0];
            got[1] += fi * unit[i][1];
            got[2] += fi * unit[i][2];
            got[3] += fi * (arm[i][1] * unit[i][2] - arm[i][2] * unit[i][1]);
            got[4] += fi * (arm[i][2] * unit[i][0] - arm[i][0] * unit[i][2]);
            got[5] += fi * (arm[i][0] * unit[i][1] - arm[i][1] * unit[i][0]);
        }
        for (int k = 0; k < 6; ++k) {
            double e = fabs(got[k] - need[k]);
            worst = e > worst ? e : worst;
            /* 0.05 N (N m) on the wrench: six forces each rounded to Q8 */
            if (e > 0.05) {
                fail_msg("pose %d: wrench %d got %.4f need %.4f", n, k, got[k], need[k]);
            }
        }
    }
    print_message("ID worst wrench error %.4g N\n", worst);
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
        l[i] = q24(2.0);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orientation),
        cmocka_unit_test(test_inverse_kinematics),
        cmocka_unit_test(test_ik_rejects_bad_input),
        cmocka_unit_test(test_ik_edge_paths),
        cmocka_unit_test(test_leg_rates_and_stretch),
        cmocka_unit_test(test_body_rates),
        cmocka_unit_test(test_rates_wide_paths),
        cmocka_unit_test(test_solve6),
        cmocka_unit_test(test_forward_kinematics),
        cmocka_unit_test(test_lu6),
        cmocka_unit_test(test_fk_chord),
        cmocka_unit_test(test_forward_kinematics_failures),
        cmocka_unit_test(test_inverse_dynamics),
        cmocka_unit_test(test_check_legs),
    };
    return cmocka_run_group_tests_name("kinematics", tests, NULL, NULL);
}
