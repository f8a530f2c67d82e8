/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_m4_float_ref - the single-precision float reference of the
 * Cortex-M4 instruction-count benchmark (bench/m4/float_ref.c) computes what
 * the fixed-point core computes, so that the measured ratio compares two
 * implementations of the same thing. Over the benchmark's 2000 motions
 * (bench/m4/m4_vectors.c, the box of issue 7 around home), against the core:
 *   sine, cosine                 |error| <= 1e-7
 *   leg lengths                  |error| <= 1e-6 m
 *   unit vectors                 |error| <= 5e-7
 *   cylinder forces              |error| <= 0.05 N + 1e-6 |F|
 * (single precision carries 24 bits, 6e-8 relative; measured: 3.3e-8,
 * 4.8e-7 m, 1.3e-7, 0.014 N with the default config's leg masses, which
 * both sides model), and the float sine and cosine against libm's
 * double ones within 1e-6 on [-10, 10] rad (measured 2.5e-7: the float
 * argument's own rounding). A positive control
 * checks that a wrong input (another pose) is caught by the same bounds.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "assert_near.h"
#include "float_ref.h"
#include "m4_vectors.h"
#include "ref_model.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"

#define N_MOTIONS 2000u
#define TOL_TRIG 1e-7
#define TOL_TRIG_WIDE 1e-6
#define TOL_LENGTH 1e-6
#define TOL_UNIT 5e-7
#define TOL_FORCE_ABS 0.05
#define TOL_FORCE_REL 1e-6

typedef struct {
    double trig;
    double length;
    double unit;
    double force_excess; /* max of |error| - (abs + rel |F|): <= 0 when inside */
    double force_abs;
} errors_t;

/* Compares the float reference on `fmotion` with the core on `motion`. */
static void compare(const m4f_platform_t *fp, const sp_motion_t *motion, const m4f_motion_t *fmotion, errors_t *e)
{
    const sp_platform_t *p = &sp_platform_default; /* leg masses on */
    sp_ik_t ik;
    m4f_ik_t fik;
    sp_q8_t force[SP_LEGS];
    float fforce[SP_LEGS];
    unsigned i;
    unsigned c;

    assert_int_equal(sp_inverse_kinematics(p, &motion->pose, &ik), SP_OK);
    assert_int_equal(m4f_inverse_kinematics(fp, fmotion->pos, fmotion->rpy, &fik), SP_OK);
    assert_int_equal(sp_inverse_dynamics(p, motion, &ik, NULL, force), SP_OK);
    assert_int_equal(m4f_inverse_dynamics(fp, fmotion, &fik, fforce), SP_OK);
    for (c = 0u; c < 3u; ++c) {
        sp_q30_t s;
        sp_q30_t co;
        float fs;
        float fc;
        sp_sincos_q24(motion->pose.rpy[c], &s, &co);
        m4f_sincos(fmotion->rpy[c], &fs, &fc);
        e->trig = fmax(e->trig, fabs((double)fs - ref_f30(s)));
        e->trig = fmax(e->trig, fabs((double)fc - ref_f30(co)));
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        double f = ref_f8(force[i]);
        double err = fabs((double)fforce[i] - f);
        e->length = fmax(e->length, fabs((double)fik.length[i] - ref_f24(ik.length[i])));
        for (c = 0u; c < 3u; ++c) {
            e->unit = fmax(e->unit, fabs((double)fik.unit[i][c] - ref_f30(ik.unit[i][c])));
        }
        e->force_abs = fmax(e->force_abs, err);
        e->force_excess = fmax(e->force_excess, err - (TOL_FORCE_ABS + TOL_FORCE_REL * fabs(f)));
    }
}

static void test_float_reference_matches_core(void **state)
{
    m4f_platform_t fp;
    m4_rng_t rng;
    errors_t e = {0.0, 0.0, 0.0, -1e30, 0.0};
    uint32_t n;
    (void)state;

    m4f_platform_from_fixed(&sp_platform_default, &fp);
    m4_rng_seed(&rng, M4_SEED);
    for (n = 0u; n < N_MOTIONS; ++n) {
        sp_motion_t m;
        sp_pose_t guess;
        m4f_motion_t fm;
        m4_random_motion(&rng, &sp_platform_default, &m);
        m4_nearby_pose(&rng, &m.pose, &guess);
        m4f_motion_from_fixed(&m, &fm);
        compare(&fp, &m, &fm, &e);
    }
    print_message("float reference vs core over %u motions: sin/cos %.2e, length %.2e m, unit %.2e, force %.3f N\n",
                  N_MOTIONS, e.trig, e.length, e.unit, e.force_abs);
    assert_near(e.trig, 0.0, TOL_TRIG, "worst sin/cos error");
    assert_near(e.length, 0.0, TOL_LENGTH, "worst length error (m)");
    assert_near(e.unit, 0.0, TOL_UNIT, "worst unit vector error");
    assert_true(e.force_excess <= 0.0);
}

/* Positive control: the float reference fed a pose 1 mm away in x (and an
 * acceleration 0.1 m/s^2 off) must fail the same bounds. */
static void test_bounds_catch_a_wrong_input(void **state)
{
    m4f_platform_t fp;
    m4_rng_t rng;
    errors_t e = {0.0, 0.0, 0.0, -1e30, 0.0};
    sp_motion_t m;
    sp_pose_t guess;
    m4f_motion_t fm;
    (void)state;

    m4f_platform_from_fixed(&sp_platform_default, &fp);
    m4_rng_seed(&rng, M4_SEED);
    m4_random_motion(&rng, &sp_platform_default, &m);
    m4_nearby_pose(&rng, &m.pose, &guess);
    m4f_motion_from_fixed(&m, &fm);
    fm.pos[0] += 1e-3f;
    fm.acc[0] += 0.1f;
    compare(&fp, &m, &fm, &e);
    assert_true(e.length > TOL_LENGTH);
    assert_true(e.force_excess > 0.0);
}

/* sincos over whole turns and beyond (the reduction's quadrants). */
static void test_sincos_all_quadrants(void **state)
{
    double worst = 0.0;
    int k;
    (void)state;
    for (k = -4000; k <= 4000; ++k) {
        float x = (float)k * 0.0025f; /* -10..10 rad */
        float s;
        float c;
        m4f_sincos(x, &s, &c);
        worst = fmax(worst, fabs((double)s - sin((double)x)));
        worst = fmax(worst, fabs((double)c - cos((double)x)));
    }
    print_message("float sincos on [-10, 10] rad: max error %.2e\n", worst);
    assert_near(worst, 0.0, TOL_TRIG_WIDE, "worst sin/cos error against libm");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_float_reference_matches_core),
        cmocka_unit_test(test_bounds_catch_a_wrong_input),
        cmocka_unit_test(test_sincos_all_quadrants),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
