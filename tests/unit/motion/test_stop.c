/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of the controlled stop (sp/motion/stop.h) against a float64
 * model of the same curve, on seeded random motions and limits: the
 * planned duration is the shortest whole number of ticks the model's
 * bounds allow, every sample lies within a few LSB of the model, the
 * samples' acceleration and jerk keep the limits, the stop ends exactly
 * at its end pose at rest, and continues the motion it stops.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "sp/motion/stop.h"
#include "test_util.h"

#define Q24 16777216.0
#define TICK_US 1000u

static double axis_v(const sp_motion_t *m, unsigned k, int order)
{
    int32_t v;
    if (order == 0) {
        v = (k < 3u) ? m->pose.pos[k] : m->pose.rpy[k - 3u];
    } else if (order == 1) {
        v = (k < 3u) ? m->vel[k] : m->rpy_rate[k - 3u];
    } else {
        v = (k < 3u) ? m->acc[k] : m->rpy_acc[k - 3u];
    }
    return (double)v / Q24;
}

static void set_axis(sp_motion_t *m, unsigned k, double p, double v, double a)
{
    int32_t pq = (int32_t)llround(p * Q24), vq = (int32_t)llround(v * Q24), aq = (int32_t)llround(a * Q24);
    if (k < 3u) {
        m->pose.pos[k] = pq, m->vel[k] = vq, m->acc[k] = aq;
    } else {
        m->pose.rpy[k - 3u] = pq, m->rpy_rate[k - 3u] = vq, m->rpy_acc[k - 3u] = aq;
    }
}

/* The model's T (ticks): the smallest n whose bounds hold on every axis. */
static uint32_t model_ticks(const sp_motion_t *m, const sp_stop_limits_t *lim)
{
    for (uint32_t n = 1u; n <= 10000u; ++n) {
        double t = n * 1e-3;
        int ok = 1;
        for (unsigned k = 0u; k < 6u && ok; ++k) {
            unsigned g = (k < 3u) ? 0u : 1u;
            double v = fabs(axis_v(m, k, 1)), a = fabs(axis_v(m, k, 2));
            double d = lim->decel[g] / Q24 - a, dl = lim->decel[g] / Q24 / 4.0, j = lim->jerk[g] / Q24;
            if (d < dl) {
                d = dl;
            }
            ok = (1.875 * v <= d * t) && (5913.0 / 1024.0 * v + 4.0 * a * t <= j * t * t);
        }
        if (ok) {
            return n;
        }
    }
    return 0u;
}

/* The model's sample of axis k at u: position, velocity, acceleration. */
static void model_sample(const sp_motion_t *m, unsigned k, double t, double u, double out[3])
{
    double p0 = axis_v(m, k, 0), v0 = axis_v(m, k, 1), a0 = axis_v(m, k, 2);
    double u2 = u * u, u3 = u2 * u, u4 = u3 * u, u5 = u4 * u, u6 = u5 * u;
    double ih = u - 2.5 * u4 + 3 * u5 - u6, ig = u2 / 2 - 1.5 * u4 + 1.6 * u5 - u6 / 2;
    double h = 1 - 10 * u3 + 15 * u4 - 6 * u5, g = u - 6 * u3 + 8 * u4 - 3 * u5;
    double dh = -30 * u2 + 60 * u3 - 30 * u4, dg = 1 - 18 * u2 + 32 * u3 - 15 * u4;
    out[0] = p0 + v0 * t * ih + a0 * t * t * ig;
    out[1] = v0 * h + a0 * t * g;
    out[2] = v0 / t * dh + a0 * dg;
}

static void random_motion(uint64_t *rng, sp_motion_t *m, sp_stop_limits_t *lim)
{
    memset(m, 0, sizeof *m);
    for (unsigned g = 0u; g < 2u; ++g) {
        lim->decel[g] = (int32_t)llround(tu_uniform(rng, 0.1, 50.0) * Q24);
        lim->jerk[g] = (int32_t)llround(tu_uniform(rng, 1.0, 100.0) * Q24);
    }
    for (unsigned k = 0u; k < 6u; ++k) {
        double scale = (tu_next(rng) % 4u == 0u) ? 0.0 : 1.0; /* some axes at rest */
        double p = (k == 2u) ? 2.55 + tu_uniform(rng, -0.5, 0.5) : tu_uniform(rng, -0.5, 0.5);
        set_axis(m, k, p, scale * tu_uniform(rng, -0.6, 0.6), scale * tu_uniform(rng, -5.0, 5.0));
    }
}

static void test_stop_against_the_model(void **state)
{
    (void)state;
    uint64_t rng = 35u;
    double worst[3] = {0, 0, 0};
    int planned = 0;
    for (int trial = 0; trial < 400; ++trial) {
        sp_motion_t from, s;
        sp_stop_limits_t lim;
        sp_stop_t st;
        random_motion(&rng, &from, &lim);
        uint32_t n = model_ticks(&from, &lim);
        sp_status_t r = sp_stop_plan(&st, &from, &lim, TICK_US);
        int too_far = 0; /* a reach beyond Q24's 128 m: refused */
        for (unsigned k = 0u; k < 6u && n > 0u; ++k) {
            double t = n * 1e-3;
            too_far |= fabs(axis_v(&from, k, 1) * t) > 127.9 || fabs(axis_v(&from, k, 2) * t * t) > 127.9;
        }
        if (n == 0u || too_far) {
            assert_int_equal(r, SP_E_RANGE);
            continue;
        }
        assert_int_equal(r, SP_OK);
        ++planned;
        /* the model's bounds in double against the firmware's in Q24: at most a tick apart */
        assert_true(st.ticks + 1u >= n && st.ticks <= n + 1u);
        double t = st.ticks * 1e-3, prev_acc[6] = {0}, dec_tol = 1e-3, jerk_tol = 1e-2;
        for (uint32_t i = 1u; i <= st.ticks; ++i) {
            int done = 0;
            assert_int_equal(sp_stop_step(&st, &s, &done), SP_OK);
            assert_int_equal(done, i == st.ticks);
            for (unsigned k = 0u; k < 6u; ++k) {
                unsigned g = (k < 3u) ? 0u : 1u;
                double ref[3];
                model_sample(&from, k, t, (double)i / st.ticks, ref);
                for (int o = 0; o < 3; ++o) {
                    double e = fabs(axis_v(&s, k, o) - ref[o]) * Q24;
                    worst[o] = fmax(worst[o], e);
                    assert_true(e <= ((o == 2) ? 32.0 : 16.0)); /* 1 um, 1 um/s, 2 um/s^2 */
                }
                double acc = axis_v(&s, k, 2), a0 = fabs(axis_v(&from, k, 2)), d = lim.decel[g] / Q24;
                /* within the deceleration, or within |a0| + d/4 for a motion already near it */
                assert_true(fabs(acc) <= ((a0 <= 0.75 * d) ? d : a0 + d / 4.0) + dec_tol);
                if (i > 1u) {
                    assert_true(fabs(acc - prev_acc[k]) / 1e-3 <= lim.jerk[g] / Q24 * (1.0 + jerk_tol) + 1.0);
                }
                prev_acc[k] = acc;
            }
        }
        /* the end: its pose, at rest, exactly, from then on */
        for (int again = 0; again < 2; ++again) {
            int done = 0;
            assert_int_equal(sp_stop_step(&st, &s, &done), SP_OK);
            assert_int_equal(done, 1);
            assert_memory_equal(&s.pose, &st.to, sizeof st.to);
            assert_int_equal(s.vel[0] | s.vel[1] | s.vel[2] | s.acc[0] | s.acc[1] | s.acc[2], 0);
            assert_int_equal(s.rpy_rate[0] | s.rpy_rate[1] | s.rpy_rate[2], 0);
        }
    }
    printf("stop against the float64 model: %d stops planned, worst %.1f / %.1f / %.1f LSB (pose, rate, acc)\n",
           planned, worst[0], worst[1], worst[2]);
    assert_true(planned > 300);
}

static void test_stop_at_rest_and_bad_arguments(void **state)
{
    (void)state;
    sp_motion_t m, s;
    sp_stop_t st;
    sp_stop_limits_t lim = {{4 * SP_Q24_ONE, 4 * SP_Q24_ONE}, {25 * SP_Q24_ONE, 25 * SP_Q24_ONE}};
    int done = 0;
    memset(&m, 0, sizeof m);
    m.pose.pos[2] = 2 * SP_Q24_ONE;
    assert_int_equal(sp_stop_plan(&st, &m, &lim, TICK_US), SP_OK);
    assert_int_equal(st.ticks, 0u); /* at rest: nothing to stop */
    assert_int_equal(sp_stop_step(&st, &s, &done), SP_OK);
    assert_int_equal(done, 1);
    assert_memory_equal(&s.pose, &m.pose, sizeof m.pose);
    /* the surge at 0.283 m/s, its zero crossing: 256 ticks, 28 mm farther */
    m.vel[0] = (int32_t)llround(0.2827 * Q24);
    assert_int_equal(sp_stop_plan(&st, &m, &lim, TICK_US), SP_OK);
    printf("surge at 0.283 m/s: stops in %u ticks, %.1f mm on\n", st.ticks, (st.to.pos[0] - m.pose.pos[0]) / Q24 * 1e3);
    assert_true(st.ticks > 200u && st.ticks < 280u);
    assert_int_equal(st.to.pos[1], 0);
    /* bad limits, tick, NULL */
    lim.decel[1] = SP_Q24_ONE / 20;
    assert_int_equal(sp_stop_plan(&st, &m, &lim, TICK_US), SP_E_ARG);
    lim.decel[1] = 4 * SP_Q24_ONE;
    lim.jerk[0] = 101 * SP_Q24_ONE;
    assert_int_equal(sp_stop_limits_check(&lim), SP_E_ARG);
    lim.jerk[0] = 25 * SP_Q24_ONE;
    assert_int_equal(sp_stop_plan(&st, &m, &lim, 0u), SP_E_ARG);
    assert_int_equal(sp_stop_plan(NULL, &m, &lim, TICK_US), SP_E_ARG);
    assert_int_equal(sp_stop_step(&st, NULL, &done), SP_E_ARG);
    /* a motion no stop of 10 s can bring to rest within 0.1 m/s^2 */
    lim.decel[0] = SP_Q24_ONE / 10;
    m.vel[0] = 2 * SP_Q24_ONE;
    assert_int_equal(sp_stop_plan(&st, &m, &lim, TICK_US), SP_E_RANGE);
    assert_int_equal(st.ticks, 0u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stop_against_the_model),
        cmocka_unit_test(test_stop_at_rest_and_bad_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
