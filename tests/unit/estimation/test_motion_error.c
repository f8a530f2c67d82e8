/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of the tracking error's acceleration and its wrench
 * (sp/estimation/motion_error.h), and of both through the wrench filter
 * (sp/estimation/wrench.h) as the controller chains them.
 *
 * Tolerances and figures (the filter: four sections at 80 Hz, 1 kHz):
 *   acceleration vs int64 reference exact (0 LSB): the double difference
 *                                   times 1/dt^2 is integer arithmetic
 *   2 Hz sine through the chain     5 N on m A w^2 = 1,980 N (the
 *                                   quantisation of e in Q24 through the
 *                                   filter: 0.9 N RMS) against the exact
 *                                   response of difference and sections
 *   quantisation noise              1 um on e through the chain: the
 *                                   force's standard deviation within 5 %
 *                                   of m sigma_e times the noise gain of
 *                                   the impulse response
 *   wrench vs double reference      0.01 N, N m + 1e-7 relative
 *   wrench vs inverse dynamics      0.05 N, N m + 2e-6 relative (massless
 *                                   legs; the ID is linear in the
 *                                   accelerations, so only rounding is left)
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

#include "assert_near.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"
#include "sp/estimation/motion_error.h"
#include "sp/estimation/wrench.h"
#include "test_util.h"

#define PI 3.14159265358979323846
#define Q24 16777216.0
#define Q30 1073741824.0

static int32_t q24(double x)
{
    return (int32_t)llround(x * Q24);
}

static sp_q30_t alpha_80hz(void)
{
    sp_q30_t a = 0;
    assert_int_equal(sp_wrench_alpha(80 * SP_Q24_ONE, 1000u, &a), SP_OK);
    return a;
}

/* The controller's chain at a fixed reference pose (its IK ik): e ->
 * sp_motion_error_step -> sp_motion_error_wrench -> sp_wrench_step with
 * no force error (the model forces measured). */
typedef struct {
    sp_motion_error_t me;
    sp_wrench_t w;
    sp_model_t model;
    sp_ik_t ik;
    sp_q30_t alpha;
} chain_t;

static void chain_init(chain_t *c, const sp_pose_t *ref)
{
    memset(c, 0, sizeof *c);
    c->alpha = alpha_80hz();
    assert_int_equal(sp_motion_error_init(&c->me, 1000u), SP_OK);
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, ref, &c->ik), SP_OK);
    assert_int_equal(sp_jacobian(&c->ik, &c->model.jac), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        c->model.force[i] = 4000 * 256;
    }
    sp_wrench_reset(&c->w);
}

/* One tick; returns 1 when c->w.wrench is valid. */
static int chain_step(chain_t *c, const sp_pose_t *est, const sp_pose_t *ref)
{
    sp_q24_t da[6];
    sp_q8_t dw[6];
    const sp_q8_t *corr = NULL;
    if (sp_motion_error_step(&c->me, est, ref, da) == SP_OK) {
        assert_int_equal(sp_motion_error_wrench(&sp_platform_default, &c->ik, da, dw), SP_OK);
        corr = dw;
    }
    sp_wrench_step(&c->w, &c->model, NULL, c->model.force, corr, c->alpha);
    return c->w.valid;
}

/* The exact response at angular frequency w (rad/tick) of the double
 * difference (2 cos w - 2, centred one tick back) and the filter's
 * sections alpha / (1 - b e^-jw) each: gain and phase lag (rad). */
static void chain_response(double alpha, double w, double *gain, double *lag)
{
    double b = 1.0 - alpha;
    double re = 1.0 - b * cos(w);
    double im = b * sin(w); /* 1 - b e^-jw */
    double mag = alpha / sqrt(re * re + im * im);
    double ph = -atan2(im, re); /* phase of 1 / (1 - b e^-jw) */
    *gain = (2.0 - 2.0 * cos(w)) * pow(mag, (double)SP_WRENCH_SECTIONS);
    *lag = w - (double)SP_WRENCH_SECTIONS * ph;
}

/* The noise gain: root sum of squares of the impulse response of the
 * double difference and the sections (per unit of e, times dt^2). */
static double chain_noise_gain(double alpha)
{
    double y[SP_WRENCH_SECTIONS] = {0};
    double s = 0.0;
    for (int n = 0; n < 4000; ++n) {
        double x = (n == 0) ? 1.0 : ((n == 1) ? -2.0 : ((n == 2) ? 1.0 : 0.0));
        for (unsigned k = 0u; k < SP_WRENCH_SECTIONS; ++k) {
            y[k] += alpha * (x - y[k]);
            x = y[k];
        }
        s += x * x;
    }
    return sqrt(s);
}

static void test_motion_error_api(void **state)
{
    sp_motion_error_t me;
    sp_pose_t a, b;
    sp_q24_t da[6];
    (void)state;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    assert_int_equal(sp_motion_error_init(NULL, 1000u), SP_E_ARG);
    assert_int_equal(sp_motion_error_init(&me, 99u), SP_E_ARG);
    assert_int_equal(sp_motion_error_init(&me, 1000001u), SP_E_ARG);
    assert_int_equal(sp_motion_error_init(&me, 3000u), SP_OK);
    assert_int_equal(me.k, 111111);
    assert_int_equal(sp_motion_error_init(&me, 1000u), SP_OK);
    assert_int_equal(me.k, 1000000);
    assert_int_equal(sp_motion_error_step(NULL, &a, &b, da), SP_E_ARG);
    assert_int_equal(sp_motion_error_step(&me, &a, &b, NULL), SP_E_ARG);
    /* warm-up: two poses, then the acceleration */
    a.pos[0] = 1000;
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_E_BUSY);
    assert_int_equal(da[0], 0);
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_E_BUSY);
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_OK);
    assert_int_equal(da[0], 0); /* constant error: no acceleration */
    /* a tick without a pose resets the history */
    assert_int_equal(sp_motion_error_step(&me, NULL, &b, da), SP_E_BUSY);
    assert_int_equal(me.count, 0);
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_E_BUSY);
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_E_BUSY);
    /* a jump of 1 mm is an acceleration of 1000 m/s^2: held at +64,
     * flagged, no wrap */
    a.pos[0] += q24(1e-3);
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_E_OVERFLOW);
    assert_int_equal(da[0], 0x3FFFFFFF);
    /* extreme positions: the difference saturates, the output is held */
    a.pos[1] = INT32_MAX;
    b.pos[1] = INT32_MIN;
    assert_int_equal(sp_motion_error_step(&me, &a, &b, da), SP_E_OVERFLOW);
    for (int n = 0; n < 200; ++n) {
        a.pos[1] = (n & 1) ? INT32_MAX : INT32_MIN;
        b.pos[1] = (n & 1) ? INT32_MIN : INT32_MAX;
        (void)sp_motion_error_step(&me, &a, &b, da);
        assert_true(da[1] >= -(1 << 30) && da[1] < (1 << 30));
    }
    /* yaw crossing +-pi in both poses: no step in e */
    sp_motion_error_reset(&me);
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    for (int n = 0; n < 40; ++n) {
        double yaw = 3.1 + 0.002 * n; /* crosses pi at n = 21 */
        double w = (yaw >= PI) ? yaw - 2.0 * PI : yaw;
        a.rpy[2] = q24(w + 1e-6);
        b.rpy[2] = q24((n >= 30) ? w : yaw); /* the reference wraps later */
        sp_status_t st = sp_motion_error_step(&me, &a, &b, da);
        assert_true(st == SP_OK || st == SP_E_BUSY);
        /* a wrap would be held at 64 rad/s^2; e's Q24 rounding alone
         * gives a few LSB of e: 1 rad/s^2 at most */
        assert_true(abs(da[5]) < q24(1.0));
    }
}

/* (a) the acceleration against a plain int64 reference on random errors:
 * random walks of the pose with random noise, angles near the wrap; every
 * value bit for bit. */
static void test_motion_error_vs_reference(void **state)
{
    uint64_t rng = 0x5EED0001u;
    sp_motion_error_t me;
    (void)state;
    for (int run = 0; run < 20; ++run) {
        double pos[6] = {0}, vel[6] = {0};
        int64_t e1[6] = {0}, e2[6] = {0};
        uint32_t tick = (run % 4 == 3) ? 500u : 1000u;
        assert_int_equal(sp_motion_error_init(&me, tick), SP_OK);
        for (int n = 0; n < 2000; ++n) {
            sp_pose_t est, ref;
            sp_q24_t da[6];
            int64_t e[6];
            for (int k = 0; k < 6; ++k) {
                /* a damped random walk: accelerations of a few m/s^2,
                 * rad/s^2, errors of millimetres and milliradians */
                vel[k] = 0.995 * vel[k] - 1e-4 * pos[k] + tu_uniform(&rng, -2e-6, 2e-6);
                pos[k] += vel[k];
            }
            for (int k = 0; k < 3; ++k) {
                double r = tu_uniform(&rng, -0.5, 0.5);
                ref.pos[k] = q24(r);
                est.pos[k] = q24(r + pos[k] * 1e-2 + tu_uniform(&rng, -3e-7, 3e-7));
                double ra = tu_uniform(&rng, -PI, PI);
                double ea = ra + pos[3 + k] + tu_uniform(&rng, -3e-7, 3e-7);
                ea = (ea >= PI) ? ea - 2 * PI : ((ea < -PI) ? ea + 2 * PI : ea);
                ref.rpy[k] = q24(ra);
                est.rpy[k] = q24(ea);
            }
            for (int k = 0; k < 3; ++k) {
                e[k] = (int64_t)est.pos[k] - ref.pos[k];
                int64_t d = (int64_t)est.rpy[k] - ref.rpy[k];
                /* the firmware wraps by its Q24 2 pi */
                while (d >= 52707179) {
                    d -= 105414357;
                }
                while (d < -52707179) {
                    d += 105414357;
                }
                e[3 + k] = d;
            }
            sp_status_t st = sp_motion_error_step(&me, &est, &ref, da);
            assert_int_equal(st, (n >= 2) ? SP_OK : SP_E_BUSY);
            for (int k = 0; k < 6; ++k) {
                int64_t want = (n >= 2) ? (e[k] - 2 * e1[k] + e2[k]) * me.k : 0;
                assert_true(want >= -(INT64_C(1) << 30) && want < (INT64_C(1) << 30));
                assert_int_equal(da[k], want);
                e2[k] = e1[k];
                e1[k] = e[k];
            }
        }
    }
}

/* sp_motion_error_step as it was written before its 32-bit double
 * difference: every difference in int64, saturated, held; the plain
 * reference of (a2). */
typedef struct {
    int32_t e1[6], e2[6];
    int count;
} me_plain_t;

static int32_t me_plain_sat(int64_t v, int *flag)
{
    if (v > INT32_MAX || v < INT32_MIN) {
        *flag = 1;
        return (v > 0) ? INT32_MAX : INT32_MIN;
    }
    return (int32_t)v;
}

static sp_status_t me_plain_step(me_plain_t *p, int32_t k_dt, const sp_pose_t *est, const sp_pose_t *ref,
                                 sp_q24_t da[6])
{
    int flag = 0;
    int32_t e[6];
    for (int k = 0; k < 3; ++k) {
        e[k] = me_plain_sat((int64_t)est->pos[k] - ref->pos[k], &flag);
        int64_t d = (int64_t)est->rpy[k] - ref->rpy[k];
        if (d < -52707179 || d >= 52707179) {
            int64_t r = (d + 52707179) % 105414357;
            d = ((r < 0) ? r + 105414357 : r) - 52707179;
        }
        e[3 + k] = (int32_t)d;
    }
    for (int k = 0; k < 6; ++k) {
        int unused = 0;
        int64_t d2 = (int64_t)e[k] - 2 * (int64_t)p->e1[k] + p->e2[k];
        int64_t v = (int64_t)me_plain_sat(d2, &unused) * k_dt; /* d2 held to int32, not flagged */
        if (p->count >= 2 && (v > 0x3FFFFFFF || v < -0x40000000)) {
            flag = 1;
            v = (v > 0) ? 0x3FFFFFFF : -0x40000000;
        }
        da[k] = (p->count < 2) ? 0 : (sp_q24_t)v;
        p->e2[k] = p->e1[k];
        p->e1[k] = e[k];
    }
    if (p->count < 2) {
        p->count += 1;
        return flag ? SP_E_OVERFLOW : SP_E_BUSY;
    }
    return flag ? SP_E_OVERFLOW : SP_OK;
}

/* (a2) against the plain reference on errors of every size: positions
 * from micrometres to the int32 extremes, so that the errors cross the
 * 2^29 bound of the 32-bit double difference in every order of the three
 * ticks it takes, and the saturated and held paths; every value, status
 * and tick bit for bit, with resets between runs. */
static void test_motion_error_vs_plain(void **state)
{
    uint64_t rng = 0x5EED0A2u;
    sp_motion_error_t me;
    int fast = 0, slow = 0;
    (void)state;
    for (int run = 0; run < 200; ++run) {
        me_plain_t plain;
        memset(&plain, 0, sizeof plain);
        assert_int_equal(sp_motion_error_init(&me, (run % 3 == 2) ? 250u : 1000u), SP_OK);
        for (int n = 0; n < 300; ++n) {
            sp_pose_t est, ref;
            sp_q24_t da[6], want[6];
            int big = 0;
            for (int k = 0; k < 3; ++k) {
                /* the size of this tick's error: mostly small, now and
                 * then beyond 2^29 or at the extremes */
                unsigned kind = (unsigned)(tu_next(&rng) % 16u);
                int32_t r = tu_i32(&rng);
                int32_t e;
                if (kind < 10u) {
                    e = (int32_t)(tu_next(&rng) % 2001u) - 1000;
                } else if (kind < 14u) {
                    e = (int32_t)(tu_next(&rng) % 0x40000003u) - 0x20000001; /* about the bound */
                } else {
                    e = tu_i32(&rng);
                }
                ref.pos[k] = (kind == 15u) ? INT32_MIN + (int32_t)(tu_next(&rng) % 8u) : r / 2;
                est.pos[k] = (int32_t)(((int64_t)ref.pos[k] + e > INT32_MAX)
                                           ? INT32_MAX
                                           : (((int64_t)ref.pos[k] + e < INT32_MIN) ? INT32_MIN : ref.pos[k] + e));
                if (kind == 15u) {
                    est.pos[k] = INT32_MAX - (int32_t)(tu_next(&rng) % 8u); /* the difference saturates */
                }
                int64_t dp = (int64_t)est.pos[k] - ref.pos[k];
                big |= (dp > 0x1FFFFFFF || dp < -0x1FFFFFFF);
                ref.rpy[k] = tu_i32(&rng) / 8;
                est.rpy[k] = (kind & 1u) ? tu_i32(&rng) : ref.rpy[k] + (int32_t)(tu_next(&rng) % 4001u) - 2000;
            }
            sp_status_t st_want = me_plain_step(&plain, me.k, &est, &ref, want);
            sp_status_t st = sp_motion_error_step(&me, &est, &ref, da);
            assert_int_equal(st, st_want);
            assert_memory_equal(da, want, sizeof da);
            assert_memory_equal(me.e1, plain.e1, sizeof me.e1);
            assert_memory_equal(me.e2, plain.e2, sizeof me.e2);
            if (n >= 2) {
                fast += big ? 0 : 1;
                slow += big ? 1 : 0;
            }
            if (tu_next(&rng) % 97u == 0u) {
                /* a tick without a pose: both histories start again */
                assert_int_equal(sp_motion_error_step(&me, NULL, &ref, da), SP_E_BUSY);
                memset(&plain, 0, sizeof plain);
            }
        }
    }
    print_message("motion error vs plain: %d ticks with small errors, %d with large\n", fast, slow);
    assert_true(fast > 10000 && slow > 10000);
}

/* (b) e = A sin(w t) at 2 Hz in x: the chain's force is m times the
 * filtered -A w^2 sin(w t), against the exact response. */
static void test_motion_error_sine_2hz(void **state)
{
    chain_t c;
    const double amp = 5e-3; /* 5 mm */
    const double w = 2.0 * PI * 2.0;
    const double dt = 1e-3;
    const double m = sp_platform_default.mass / 65536.0;
    const double peak = m * amp * w * w;
    double gain, lag, worst = 0.0;
    sp_pose_t ref = sp_platform_default.home;
    (void)state;
    chain_init(&c, &ref);
    chain_response(c.alpha / Q30, w * dt, &gain, &lag);
    gain /= dt * dt * w * w;
    for (int n = 0; n < 3000; ++n) {
        sp_pose_t est = ref;
        est.pos[0] += q24(amp * sin(w * n * dt));
        (void)chain_step(&c, &est, &ref);
        if (n < 1000) {
            continue; /* the start-up transient */
        }
        double want = -peak * gain * sin(w * n * dt - lag);
        double got = c.w.wrench[0] / 256.0;
        worst = fmax(worst, fabs(got - want));
        assert_near(got, want, 5.0, "tick %d", n);
    }
    printf("2 Hz sine, m A w^2 = %.0f N: gain %.5f, lag %.3f ticks; worst %.2f N\n", peak, gain, lag / (w * dt), worst);
}

/* (c) 1 um / 1 urad quantisation: e uniform in +-0.5 um (+-0.5 urad) per
 * sample, white, through the chain. */
static void test_motion_error_quantisation_noise(void **state)
{
    uint64_t rng = 0x5EED0003u;
    chain_t c;
    double f2[6] = {0};
    int count = 0;
    const double sigma = 1e-6 / sqrt(12.0);
    const double m = sp_platform_default.mass / 65536.0;
    sp_pose_t ref = sp_platform_default.home;
    (void)state;
    chain_init(&c, &ref);
    double g = chain_noise_gain(c.alpha / Q30);
    for (int n = 0; n < 60000; ++n) {
        sp_pose_t est = ref;
        for (int k = 0; k < 3; ++k) {
            est.pos[k] += q24(tu_uniform(&rng, -0.5e-6, 0.5e-6));
            est.rpy[k] += q24(tu_uniform(&rng, -0.5e-6, 0.5e-6));
        }
        (void)chain_step(&c, &est, &ref);
        if (n < 500) {
            continue;
        }
        for (int k = 0; k < 6; ++k) {
            f2[k] += (c.w.wrench[k] / 256.0) * (c.w.wrench[k] / 256.0);
        }
        ++count;
    }
    printf("noise gain %.5f / dt^2; sigma_e %.3f um -> predicted force noise %.1f N\n", g, sigma * 1e6,
           m * g * sigma * 1e6);
    for (int k = 0; k < 6; ++k) {
        double sf = sqrt(f2[k] / count);
        printf("  axis %d: wrench noise %.1f %s\n", k, sf, (k < 3) ? "N" : "N m");
        if (k < 3) {
            /* the default platform's centre of mass is o': dW = m da */
            assert_near(sf, m * g * sigma * 1e6, 0.05 * m * g * sigma * 1e6, "axis %d", k);
        }
    }
}

/* A random pose within +-50 % of the default workspace around home. */
static void random_pose(uint64_t *rng, sp_pose_t *pose)
{
    const sp_platform_t *p = &sp_platform_default;
    *pose = p->home;
    for (int k = 0; k < 3; ++k) {
        pose->pos[k] += q24(0.5 * tu_uniform(rng, p->workspace_min.pos[k] / Q24, p->workspace_max.pos[k] / Q24));
        pose->rpy[k] += q24(0.5 * tu_uniform(rng, p->workspace_min.rpy[k] / Q24, p->workspace_max.rpy[k] / Q24));
    }
}

/* The wrench in double from the same (quantised) inputs. */
static void ref_wrench(const sp_platform_t *p, const sp_ik_t *ik, const sp_q24_t da[6], double out[6])
{
    double sr = ik->sc[0] / Q30, cr = ik->sc[1] / Q30, sp = ik->sc[2] / Q30, cp = ik->sc[3] / Q30;
    double a[3], r3[3], wd[3], ab[3], rc[3], mc[3], iw[3], rw[3];
    double m = p->mass / 65536.0;
    double R[3][3]; /* R = T^T: R[k][r] = T[r][k] */
    for (int k = 0; k < 3; ++k) {
        a[k] = da[k] / Q24;
        r3[k] = da[3 + k] / Q24;
        for (int r = 0; r < 3; ++r) {
            R[k][r] = ik->rot.t[r][k] / Q30;
        }
    }
    /* eq (10) with zero rates, differentiated: the rpy accelerations only */
    wd[0] = r3[0] - sp * r3[2];
    wd[1] = cr * r3[1] + sr * cp * r3[2];
    wd[2] = -sr * r3[1] + cr * cp * r3[2];
    for (int k = 0; k < 3; ++k) {
        ab[k] = rc[k] = iw[k] = 0.0;
        for (int r = 0; r < 3; ++r) {
            ab[k] += R[k][r] * wd[r];
            rc[k] += R[k][r] * (p->center_of_mass[r] / Q24);
            iw[k] += (p->inertia[k][r] / 65536.0) * wd[r];
        }
    }
    for (int k = 0; k < 3; ++k) {
        mc[k] = m * rc[k];
        rw[k] = 0.0;
        for (int r = 0; r < 3; ++r) {
            rw[k] += R[k][r] * iw[r];
        }
    }
    out[0] = m * a[0] + ab[1] * mc[2] - ab[2] * mc[1];
    out[1] = m * a[1] + ab[2] * mc[0] - ab[0] * mc[2];
    out[2] = m * a[2] + ab[0] * mc[1] - ab[1] * mc[0];
    out[3] = rw[0] + mc[1] * a[2] - mc[2] * a[1];
    out[4] = rw[1] + mc[2] * a[0] - mc[0] * a[2];
    out[5] = rw[2] + mc[0] * a[1] - mc[1] * a[0];
}

/* The default platform, with a centre of mass off o' and massless legs
 * (legs = 1), or its own leg masses (legs = 0). */
static void test_platform(sp_platform_t *p, int massless_legs)
{
    *p = sp_platform_default;
    p->center_of_mass[0] = q24(0.06);
    p->center_of_mass[1] = q24(-0.04);
    p->center_of_mass[2] = q24(0.35);
    if (massless_legs) {
        memset(&p->leg_mass, 0, sizeof p->leg_mass);
    }
}

/* (a) the wrench against the double reference on random inputs. */
static void test_motion_error_wrench_vs_double(void **state)
{
    uint64_t rng = 0x5EED0002u;
    sp_platform_t p;
    double worst = 0.0;
    double worst6 = 0.0;
    sp_me_body_t body;
    sp_me_m6_t m6;
    (void)state;
    test_platform(&p, 1);
    /* massless legs: the platform's rigid body */
    assert_int_equal(sp_motion_error_body(&p, &body), SP_OK);
    assert_int_equal(sp_motion_error_m6(&body, &m6), SP_OK);
    assert_int_equal(m6.frame, 1);
    for (int n = 0; n < 20000; ++n) {
        sp_pose_t pose;
        sp_ik_t ik;
        sp_q24_t da[6];
        sp_q8_t dw[6], dw6[6];
        double want[6];
        random_pose(&rng, &pose);
        assert_int_equal(sp_inverse_kinematics(&p, &pose, &ik), SP_OK);
        for (int k = 0; k < 6; ++k) {
            /* up to the filter's +-64, log-spread */
            da[k] = tu_i32_logscale(&rng) >> 1;
        }
        assert_int_equal(sp_motion_error_wrench(&p, &ik, da, dw), SP_OK);
        assert_int_equal(sp_motion_error_wrench_m6(&m6, &ik.rot, ik.sc, da, dw6), SP_OK);
        ref_wrench(&p, &ik, da, want);
        for (int k = 0; k < 6; ++k) {
            double got = dw[k] / 256.0;
            double tol = 0.01 + 1e-7 * fabs(want[k]);
            worst = fmax(worst, fabs(got - want[k]) / tol);
            worst6 = fmax(worst6, fabs(dw6[k] / 256.0 - want[k]) / tol);
            assert_near(got, want[k], tol, "case %d component %d", n, k);
            assert_near(dw6[k] / 256.0, want[k], tol, "motion frame: case %d component %d", n, k);
        }
    }
    printf("wrench vs double: worst %.3f of the tolerance; in the motion frame (m6) %.3f\n", worst, worst6);
    /* NULL; a body outside the motion frame's envelope takes the plain
     * computation, bit for bit */
    {
        sp_ik_t ik;
        sp_q24_t da[6] = {q24(1.5), q24(-2.0), q24(0.3), q24(0.7), q24(-0.4), q24(2.5)};
        sp_q8_t dw[6] = {1, 1, 1, 1, 1, 1};
        sp_q8_t dw6[6];
        assert_int_equal(sp_motion_error_m6(NULL, &m6), SP_E_ARG);
        assert_int_equal(sp_motion_error_m6(&body, NULL), SP_E_ARG);
        assert_int_equal(sp_motion_error_wrench_m6(NULL, &ik.rot, ik.sc, da, dw), SP_E_ARG);
        assert_int_equal(dw[0], 0);
        assert_int_equal(sp_inverse_kinematics(&p, &p.home, &ik), SP_OK);
        assert_int_equal(sp_motion_error_wrench_m6(&m6, &ik.rot, NULL, da, dw), SP_E_ARG);
        body.mass = (sp_q16_t)(INT32_C(1) << 29); /* 8192 kg */
        assert_int_equal(sp_motion_error_m6(&body, &m6), SP_OK);
        assert_int_equal(m6.frame, 0);
        assert_int_equal(sp_motion_error_wrench_m6(&m6, &ik.rot, ik.sc, da, dw6), SP_OK);
        assert_int_equal(sp_motion_error_wrench_body_t(&body, &ik.rot, ik.sc, da, dw), SP_OK);
        assert_memory_equal(dw6, dw, sizeof dw);
        body.mass = p.mass;
        body.inertia[1][2] = -(sp_q16_t)(INT32_C(1) << 29);
        assert_int_equal(sp_motion_error_m6(&body, &m6), SP_OK);
        assert_int_equal(m6.frame, 0);
    }
    /* NULL and saturation */
    {
        sp_ik_t ik;
        sp_q24_t da[6] = {INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX};
        sp_q8_t dw[6] = {1, 1, 1, 1, 1, 1};
        assert_int_equal(sp_motion_error_wrench(NULL, &ik, da, dw), SP_E_ARG);
        assert_int_equal(dw[0], 0);
        assert_int_equal(sp_inverse_kinematics(&p, &p.home, &ik), SP_OK);
        /* 32768 kg, 128 m/s^2: 4.2 MN fits Q8 */
        p.mass = INT32_MAX;
        assert_int_equal(sp_motion_error_wrench(&p, &ik, da, dw), SP_OK);
        /* m c beyond 32768 kg m: held, flagged; the sums held in Q8 */
        p.center_of_mass[0] = p.center_of_mass[1] = p.center_of_mass[2] = q24(60.0);
        assert_int_equal(sp_motion_error_wrench(&p, &ik, da, dw), SP_E_OVERFLOW);
        for (int k = 0; k < 6; ++k) {
            assert_true(dw[k] > 0 || k >= 3);
        }
    }
}

/* J^T dF in double: N, N m from Q28 and Q8. */
static void jt_times(const sp_jacobian_t *jac, const sp_q8_t f1[SP_LEGS], const sp_q8_t f0[SP_LEGS], double out[6])
{
    for (int k = 0; k < 6; ++k) {
        out[k] = 0.0;
        for (int i = 0; i < SP_LEGS; ++i) {
            out[k] += (jac->j[i][k] / 268435456.0) * ((double)f1[i] - f0[i]) / 256.0;
        }
    }
}

/* (d) against the firmware's inverse dynamics: J^T (ID(a + d) - ID(a)) =
 * sp_motion_error_wrench(d). Massless legs: within the rounding. The
 * default platform's leg masses: the share the correction leaves out. */
static void test_motion_error_wrench_vs_dynamics(void **state)
{
    uint64_t rng = 0x5EED0004u;
    (void)state;
    for (int legs = 1; legs >= 0; --legs) {
        sp_platform_t p;
        double worst = 0.0, miss_lin = 0.0, miss_rot = 0.0;
        double n_lin = 0.0, n_rot = 0.0, d_lin = 0.0, d_rot = 0.0;
        sp_me_body_t body;
        test_platform(&p, legs);
        assert_int_equal(sp_motion_error_body(&p, &body), SP_OK);
        for (int n = 0; n < 3000; ++n) {
            sp_motion_t m0, m1;
            sp_ik_t ik;
            sp_jacobian_t jac;
            sp_q8_t f0[SP_LEGS], f1[SP_LEGS], dw[6];
            sp_q24_t d[6];
            double want[6];
            int kind = n % 3; /* 0 translation, 1 rotation, 2 both */
            memset(&m0, 0, sizeof m0);
            random_pose(&rng, &m0.pose);
            for (int k = 0; k < 3; ++k) {
                m0.vel[k] = q24(tu_uniform(&rng, -0.4, 0.4));
                m0.rpy_rate[k] = q24(tu_uniform(&rng, -0.4, 0.4));
                m0.acc[k] = q24(tu_uniform(&rng, -4.0, 4.0));
                m0.rpy_acc[k] = q24(tu_uniform(&rng, -4.0, 4.0));
                d[k] = (kind != 1) ? q24(tu_uniform(&rng, -1.0, 1.0)) : 0;
                d[3 + k] = (kind != 0) ? q24(tu_uniform(&rng, -1.0, 1.0)) : 0;
            }
            m1 = m0;
            for (int k = 0; k < 3; ++k) {
                m1.acc[k] += d[k];
                m1.rpy_acc[k] += d[3 + k];
            }
            assert_int_equal(sp_inverse_kinematics(&p, &m0.pose, &ik), SP_OK);
            assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
            assert_int_equal(sp_inverse_dynamics(&p, &m0, &ik, NULL, f0), SP_OK);
            assert_int_equal(sp_inverse_dynamics(&p, &m1, &ik, NULL, f1), SP_OK);
            jt_times(&jac, f1, f0, want);
            assert_int_equal(sp_motion_error_wrench(&p, &ik, d, dw), SP_OK);
            {
                sp_q8_t bw[6];
                assert_int_equal(sp_motion_error_wrench_body_sc(&body, ik.sc, d, bw), SP_OK);
                for (int k = 0; k < 6; ++k) {
                    double e = bw[k] / 256.0 - want[k];
                    if (legs) {
                        assert_int_equal(bw[k], dw[k]); /* massless legs: the rigid body, bit for bit */
                    } else if (kind == 0) {
                        d_lin += e * e;
                    } else if (kind == 1) {
                        d_rot += e * e;
                    }
                }
            }
            for (int k = 0; k < 6; ++k) {
                double got = dw[k] / 256.0;
                double err = fabs(got - want[k]);
                if (legs) {
                    double tol = 0.05 + 2e-6 * fabs(want[k]);
                    worst = fmax(worst, err / tol);
                    assert_near(got, want[k], tol, "case %d component %d", n, k);
                } else if (kind == 0) {
                    miss_lin += err * err;
                    n_lin += want[k] * want[k];
                } else if (kind == 1) {
                    miss_rot += err * err;
                    n_rot += want[k] * want[k];
                }
            }
        }
        if (legs) {
            printf("massless legs: worst %.3f of the tolerance (0.05 + 2e-6 |W|)\n", worst);
        } else {
            double rl = sqrt(miss_lin / n_lin), rr = sqrt(miss_rot / n_rot);
            double bl = sqrt(d_lin / n_lin), br = sqrt(d_rot / n_rot);
            printf("leg masses left out: RMS miss %.1f %% (translational da), %.1f %% (rotational da)\n", 100.0 * rl,
                   100.0 * rr);
            printf("legs' inertia at home folded in (sp_motion_error_body): %.1f %%, %.1f %%\n", 100.0 * bl,
                   100.0 * br);
            assert_true(rl < 0.2 && rr < 0.2);
            /* the body takes most of what the rigid body misses */
            assert_true(bl < 0.5 * rl && br < 0.5 * rr);
        }
    }
}

/* sp_motion_error_body against the same formulas in double on the home
 * pose's IK (mass within 0.01 kg, centre within 1 um, inertia within
 * 0.01 kg m^2), and against the legs' inertia of the float64 model
 * (tools/stewart/model.py: the inverse dynamics' mass matrix at home with
 * legs minus without, the default's leg inertias 11.25 + 7.5 kg m^2
 * included: diagonal 153.0, 153.0, 198.8 kg and 129.3, 129.3, 191.8 kg m^2,
 * coupling 37.2 kg m; point-mass legs gave 137.1, 137.1, 195.7, 126.2,
 * 126.2, 174.4 and 32.9) within 0.5; massless legs and the envelope. */
static void test_motion_error_body(void **state)
{
    const sp_platform_t *p = &sp_platform_default;
    const sp_leg_mass_t *lm = &p->leg_mass;
    sp_me_body_t body;
    sp_ik_t ik;
    double kt[3][3] = {{0}}, c[3][3] = {{0}}, b[3][3] = {{0}};
    (void)state;
    assert_int_equal(sp_motion_error_body(p, &body), SP_OK);
    assert_int_equal(sp_inverse_kinematics(p, &p->home, &ik), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        double u[3], r[3], kk[3][3], kr[3][3], rx[3][3];
        double len = ik.length[i] / Q24;
        double mc = lm->cylinder_mass / 65536.0, dc = lm->cylinder_com / Q24;
        double mr = lm->rod_mass / 65536.0, dr = lm->rod_com / Q24;
        double il = (lm->cylinder_inertia + lm->rod_inertia) / 65536.0; /* across the leg */
        double mu = (mc * dc * dc + il + mr * (len - dr) * (len - dr)) / (len * len);
        for (int k = 0; k < 3; ++k) {
            u[k] = ik.unit[i][k] / 1073741824.0;
            r[k] = ik.arm[i][k] / Q24;
        }
        rx[0][0] = 0.0, rx[0][1] = -r[2], rx[0][2] = r[1];
        rx[1][0] = r[2], rx[1][1] = 0.0, rx[1][2] = -r[0];
        rx[2][0] = -r[1], rx[2][1] = r[0], rx[2][2] = 0.0;
        for (int j = 0; j < 3; ++j) {
            for (int k = 0; k < 3; ++k) {
                kk[j][k] = (j == k ? mu : 0.0) + (mr - mu) * u[j] * u[k];
                kt[j][k] += kk[j][k];
            }
        }
        for (int j = 0; j < 3; ++j) {
            for (int k = 0; k < 3; ++k) {
                kr[j][k] = kk[j][0] * rx[0][k] + kk[j][1] * rx[1][k] + kk[j][2] * rx[2][k];
                c[j][k] += kr[j][k];
            }
        }
        for (int j = 0; j < 3; ++j) {
            for (int k = 0; k < 3; ++k) {
                b[j][k] -= rx[j][0] * kr[0][k] + rx[j][1] * kr[1][k] + rx[j][2] * kr[2][k];
            }
        }
    }
    {
        /* the home pose of the default platform has T = 1 */
        double s[3] = {0.5 * (c[2][1] - c[1][2]), 0.5 * (c[0][2] - c[2][0]), 0.5 * (c[1][0] - c[0][1])};
        double m = p->mass / 65536.0 + (kt[0][0] + kt[1][1] + kt[2][2]) / 3.0;
        assert_true(p->home.rpy[0] == 0 && p->home.rpy[1] == 0 && p->home.rpy[2] == 0);
        assert_near(body.mass / 65536.0, m, 0.01, "mass");
        for (int j = 0; j < 3; ++j) {
            double com = (p->mass / 65536.0 * p->center_of_mass[j] / Q24 + s[j]) / m;
            assert_near(body.center_of_mass[j] / Q24, com, 1e-6, "centre %d", j);
            for (int k = 0; k < 3; ++k) {
                assert_near(body.inertia[j][k] / 65536.0, p->inertia[j][k] / 65536.0 + b[j][k], 0.01, "inertia %d %d",
                            j, k);
            }
        }
        /* the float64 model's leg inertia at home */
        assert_near(kt[0][0], 153.0, 0.5, "K xx");
        assert_near(kt[1][1], 153.0, 0.5, "K yy");
        assert_near(kt[2][2], 198.8, 0.5, "K zz");
        assert_near(b[0][0], 129.3, 0.5, "B xx");
        assert_near(b[1][1], 129.3, 0.5, "B yy");
        assert_near(b[2][2], 191.8, 0.5, "B zz");
        assert_near(s[2], -37.2, 0.5, "first moment z");
        printf("legs at home: mass +%.1f kg, first moment (%.1f, %.1f, %.1f) kg m, inertia +%.1f +%.1f +%.1f kg m^2\n",
               m - p->mass / 65536.0, s[0], s[1], s[2], b[0][0], b[1][1], b[2][2]);
    }
    /* massless legs: the rigid body; outside the envelope: the rigid body
     * and SP_E_RANGE; NULL */
    {
        sp_platform_t q = *p;
        memset(&q.leg_mass, 0, sizeof q.leg_mass);
        assert_int_equal(sp_motion_error_body(&q, &body), SP_OK);
        assert_int_equal(body.mass, q.mass);
        assert_memory_equal(body.inertia, q.inertia, sizeof q.inertia);
        assert_memory_equal(body.center_of_mass, q.center_of_mass, sizeof q.center_of_mass);
        q = *p;
        q.leg_mass.rod_mass = 600 << 16;
        assert_int_equal(sp_motion_error_body(&q, &body), SP_E_RANGE);
        assert_int_equal(body.mass, q.mass);
        assert_memory_equal(body.inertia, q.inertia, sizeof q.inertia);
        q = *p;
        q.leg_mass.cylinder_com = 3 << 24; /* longer than the legs at home */
        assert_int_equal(sp_motion_error_body(&q, &body), SP_E_RANGE);
        q = *p;
        q.leg_mass.rod_inertia = 600 << 16; /* beyond 512 kg m^2 */
        assert_int_equal(sp_motion_error_body(&q, &body), SP_E_RANGE);
        q = *p;
        q.leg_mass.cylinder_inertia = -1; /* negative */
        assert_int_equal(sp_motion_error_body(&q, &body), SP_E_RANGE);
        assert_int_equal(sp_motion_error_body(NULL, &body), SP_E_ARG);
        assert_int_equal(sp_motion_error_body(p, NULL), SP_E_ARG);
        {
            sp_q24_t da[6] = {0};
            sp_q8_t dw[6] = {1, 1, 1, 1, 1, 1};
            assert_int_equal(sp_motion_error_wrench_body_sc(NULL, ik.sc, da, dw), SP_E_ARG);
            assert_int_equal(dw[0], 0);
        }
    }
}

/* The inline rows of dw' against the plain reference sp_body_rates_sc
 * (zero rates), and the sines-only entry point against the IK one: both
 * bit-identical (tolerance 0) for the sines of random angles and random
 * accelerations of any size (status too); the inline dw' rows against
 * sp_body_rates_sc's omega_dot through R I dw' within 0.01 N m plus 1e-7
 * relative (accelerations below 2^25 LSB, 2 rad/s^2: no saturation). */
static void test_motion_error_rows_vs_body_rates(void **state)
{
    (void)state;
    uint64_t rng = 1717u;
    const sp_q24_t zero[3] = {0, 0, 0};
    for (int n = 0; n < 20000; ++n) {
        sp_pose_t pose = sp_platform_default.home;
        sp_ik_t ik;
        sp_q24_t da[6];
        sp_q8_t a[6];
        sp_q8_t b[6];
        sp_q8_t c[6];
        sp_q24_t om[3];
        sp_q24_t wd[3];
        for (int k = 0; k < 3; ++k) {
            pose.rpy[k] = (sp_q24_t)(tu_i32(&rng) >> 6); /* +-2 rad */
        }
        for (int k = 0; k < 6; ++k) {
            da[k] = (n % 5 == 0) ? tu_i32(&rng) : (tu_i32(&rng) >> 6);
        }
        assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &pose, &ik), SP_OK);
        sp_status_t s1 = sp_motion_error_wrench(&sp_platform_default, &ik, da, a);
        sp_status_t s2 = sp_motion_error_wrench_sc(&sp_platform_default, ik.sc, da, b);
        assert_int_equal(s1, s2);
        assert_memory_equal(a, b, sizeof a);
        /* the plain reference: dw' from sp_body_rates_sc, then the wrench
         * of a pure body angular acceleration must equal that of da with
         * the same angle accelerations (linearity is not exact in fixed
         * point, so compare dw' through a zero-translation, zero-offset
         * platform: moment = R I dw') */
        if (n % 5 != 0 && sp_body_rates_sc(ik.sc, zero, &da[3], om, wd) == SP_OK) {
            sp_platform_t p = sp_platform_default;
            sp_q24_t rot_only[6] = {0, 0, 0, da[3], da[4], da[5]};
            for (int k = 0; k < 3; ++k) {
                p.center_of_mass[k] = 0;
            }
            assert_int_equal(sp_motion_error_wrench_sc(&p, ik.sc, rot_only, c), SP_OK);
            for (int k = 0; k < 3; ++k) {
                /* R I dw' in double from the reference's dw' */
                double iw[3];
                for (int r = 0; r < 3; ++r) {
                    iw[r] = 0.0;
                    for (int q = 0; q < 3; ++q) {
                        iw[r] += p.inertia[r][q] / 65536.0 * wd[q] / 16777216.0;
                    }
                }
                double want = 0.0;
                for (int r = 0; r < 3; ++r) {
                    want += ik.rot.t[r][k] / 1073741824.0 * iw[r];
                }
                assert_near(c[3 + k] / 256.0, want, 0.01 + 1e-7 * fabs(want), "case %d axis %d", n, k);
            }
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_motion_error_api),
        cmocka_unit_test(test_motion_error_vs_reference),
        cmocka_unit_test(test_motion_error_vs_plain),
        cmocka_unit_test(test_motion_error_sine_2hz),
        cmocka_unit_test(test_motion_error_quantisation_noise),
        cmocka_unit_test(test_motion_error_wrench_vs_double),
        cmocka_unit_test(test_motion_error_wrench_vs_dynamics),
        cmocka_unit_test(test_motion_error_body),
        cmocka_unit_test(test_motion_error_rows_vs_body_rates),
    };
    return cmocka_run_group_tests_name("motion_error", tests, NULL, NULL);
}
