/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Tests of the six-axis force/torque sensor model (hs/ftsensor.h).
 *
 * Tolerances:
 *   truth in sensor axes         1e-9 against a force applied at a point,
 *                                computed from the point (not from o')
 *   noise-free reading           within half a resolution step of the truth
 *   noise                        sample standard deviation within 5 % of the
 *                                parameter over 20,000 samples
 *   bias and drift               within the drawn bounds; the mean moves by
 *                                drift x time within 3 noise standard errors
 *   sample clock                 samples in 1 s = rate +-1; a step in the
 *                                wrench shows only from the next sample instant
 *   the firmware's transform     sp_ft_to_base and sp_ft_frame + sp_ft_apply
 *                                equal the plain first version (below) bit
 *                                for bit, status included, on 5,000 random
 *                                poses and mounts with realistic and with
 *                                full-range (saturating) readings
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "assert_near.h"
#include "hs/ftsensor.h"
#include "hs/kin.h"
#include "sp/estimation/ftsensor.h"

/* The plain reference: sp_ft_to_base as first written (the frame made
 * for every reading, 64-bit products). */
static int64_t plain_round_shift(int64_t v, unsigned sh)
{
    return (v + (INT64_C(1) << (sh - 1u))) >> sh;
}

static int64_t plain_clamp_in(int32_t v, int *sat)
{
    const int64_t in_max = INT64_C(1) << 30;
    if (v > in_max || v < -in_max) {
        *sat = 1;
        return (v > 0) ? in_max : -in_max;
    }
    return v;
}

static int32_t plain_sat32(int64_t v, int *sat)
{
    if (v > INT32_MAX || v < INT32_MIN) {
        *sat = 1;
        return (v > 0) ? INT32_MAX : INT32_MIN;
    }
    return (int32_t)v;
}

static sp_status_t plain_ft_to_base(const sp_ft_mount_t *mount, const sp_rot_t *T, const sp_q8_t reading[6],
                                    sp_q8_t out[6])
{
    const int64_t in_max = INT64_C(1) << 30;
    int sat = 0;
    int64_t s[3][3], r[3];
    for (unsigned i = 0; i < 3u; ++i) {
        int64_t acc_r = 0;
        for (unsigned j = 0; j < 3u; ++j) {
            int64_t acc = 0;
            for (unsigned k = 0; k < 3u; ++k) {
                acc += (int64_t)T->t[k][i] * mount->axes.t[k][j];
            }
            s[i][j] = plain_round_shift(acc, 30u);
            acc_r += (int64_t)T->t[j][i] * mount->pos[j];
        }
        r[i] = plain_round_shift(acc_r, 30u);
    }
    int64_t f_s[3], m_s[3];
    for (unsigned k = 0; k < 3u; ++k) {
        f_s[k] = plain_clamp_in(reading[k], &sat);
        m_s[k] = plain_clamp_in(reading[3u + k], &sat);
    }
    int64_t f[3], m[3];
    for (unsigned i = 0; i < 3u; ++i) {
        f[i] = plain_round_shift(s[i][0] * f_s[0] + s[i][1] * f_s[1] + s[i][2] * f_s[2], 30u);
        m[i] = s[i][0] * m_s[0] + s[i][1] * m_s[1] + s[i][2] * m_s[2];
    }
    int64_t fc[3];
    for (unsigned i = 0; i < 3u; ++i) {
        fc[i] = (f[i] > in_max) ? in_max : ((f[i] < -in_max) ? -in_max : f[i]);
    }
    int64_t rx[3] = {r[1] * fc[2] - r[2] * fc[1], r[2] * fc[0] - r[0] * fc[2], r[0] * fc[1] - r[1] * fc[0]};
    for (unsigned i = 0; i < 3u; ++i) {
        out[i] = plain_sat32(f[i], &sat);
        out[3u + i] = plain_sat32(plain_round_shift(m[i], 30u) + plain_round_shift(rx[i], 24u), &sat);
    }
    return sat ? SP_E_OVERFLOW : SP_OK;
}

/* sp_ft_to_base and the prepared frame against the plain reference. */
static void expect_plain(const sp_ft_mount_t *mount, const sp_rot_t *T, const sp_q8_t reading[6], int c)
{
    sp_q8_t want[6], got[6], got2[6];
    sp_ft_frame_t fr;
    sp_status_t s0 = plain_ft_to_base(mount, T, reading, want);
    sp_status_t s1 = sp_ft_to_base(mount, T, reading, got);
    assert_int_equal(sp_ft_frame(mount, T, &fr), SP_OK);
    sp_status_t s2 = sp_ft_apply(&fr, reading, got2);
    assert_int_equal(s1, s0);
    assert_int_equal(s2, s0);
    for (int k = 0; k < 6; k++) {
        if (got[k] != want[k] || got2[k] != want[k]) {
            fail_msg("case %d component %d: plain %d, to_base %d, frame + apply %d", c, k, want[k], got[k], got2[k]);
        }
    }
    /* the reading less a tare's bias in one pass: the plain transform of
     * the tare's output (the difference saturated to int32); biases of
     * none, the reading's negative (the difference saturates at the
     * extremes) and of another component */
    sp_q8_t bias[6], tared[6];
    int sat = 0;
    for (int k = 0; k < 6; k++) {
        bias[k] =
            (c % 3 == 0) ? 0 : ((c % 3 == 1) ? (sp_q8_t)(-(int64_t)reading[k] / 2 * 2 - 1) : reading[(k + 1) % 6]);
        tared[k] = plain_sat32((int64_t)reading[k] - bias[k], &sat);
    }
    sp_status_t s3 = plain_ft_to_base(mount, T, tared, want);
    assert_int_equal(sp_ft_apply_tared(&fr, reading, bias, got), s3);
    for (int k = 0; k < 6; k++) {
        if (got[k] != want[k]) {
            fail_msg("case %d component %d: plain of the tared reading %d, apply_tared %d", c, k, want[k], got[k]);
        }
    }
    assert_int_equal(sp_ft_apply_tared(NULL, reading, bias, got), SP_E_ARG);
    assert_int_equal(sp_ft_apply_tared(&fr, reading, NULL, got), SP_E_ARG);
}

static hs_ft_params_t ideal(void)
{
    hs_ft_params_t p = hs_ft_default_params();
    p.noise_force = p.noise_moment = 0.0;
    p.bias_force = p.bias_moment = 0.0;
    p.drift_force = p.drift_moment = 0.0;
    p.res_force = p.res_moment = 1e-9;
    p.range_force = p.range_moment = 1e9;
    return p;
}

static void identity(double r[3][3])
{
    double rpy[3] = {0.0, 0.0, 0.0};
    hs_rot_from_rpy(rpy, r);
}

static void test_init_rejects(void **state)
{
    (void)state;
    hs_ft_t ft;
    hs_ft_params_t p = hs_ft_default_params();
    assert_int_equal(hs_ft_init(&ft, &p, 1u), HS_OK);
    assert_int_equal(hs_ft_init(NULL, &p, 1u), HS_E_ARG);
    assert_int_equal(hs_ft_init(&ft, NULL, 1u), HS_E_ARG);
    hs_ft_params_t b = p;
    b.rate_hz = 0.0;
    assert_int_equal(hs_ft_init(&ft, &b, 1u), HS_E_ARG);
    b = p;
    b.noise_force = -1.0;
    assert_int_equal(hs_ft_init(&ft, &b, 1u), HS_E_ARG);
    b = p;
    b.res_moment = 0.0;
    assert_int_equal(hs_ft_init(&ft, &b, 1u), HS_E_ARG);
    b = p;
    b.mount_pos[1] = NAN;
    assert_int_equal(hs_ft_init(&ft, &b, 1u), HS_E_ARG);
    double r[3][3], w[6] = {0};
    identity(r);
    assert_int_equal(hs_ft_advance(&ft, 0.01, r, w), HS_OK);
    assert_int_equal(hs_ft_advance(&ft, 0.005, r, w), HS_E_ARG); /* time going back */
}

/* A force F applied at point q (base frame): the wrench about o' is
 * (F, (q - o) x F); the sensor must read R_s^T F and R_s^T ((q - s) x F). */
static void test_truth_frames(void **state)
{
    (void)state;
    hs_ft_params_t p = ideal();
    p.mount_pos[0] = 0.05;
    p.mount_pos[1] = -0.02;
    p.mount_pos[2] = 0.15;
    p.mount_rpy[0] = 0.3;
    p.mount_rpy[1] = -0.2;
    p.mount_rpy[2] = 1.1;
    hs_ft_t ft;
    assert_int_equal(hs_ft_init(&ft, &p, 7u), HS_OK);
    const double o[3] = {0.01, -0.03, 1.2};
    const double rpy[3] = {0.1, 0.05, -0.2};
    double rot[3][3], mount[3][3];
    hs_rot_from_rpy(rpy, rot);
    hs_rot_from_rpy(p.mount_rpy, mount);
    for (int c = 0; c < 50; c++) {
        double F[3] = {100.0 * sin(c), 300.0 * cos(2.0 * c), -2000.0 + 10.0 * c};
        double q[3] = {o[0] + 0.1 * cos(c), o[1] + 0.2 * sin(3.0 * c), o[2] + 0.3};
        double ro[3] = {q[0] - o[0], q[1] - o[1], q[2] - o[2]};
        double w[6] = {
            F[0], F[1], F[2], ro[1] * F[2] - ro[2] * F[1], ro[2] * F[0] - ro[0] * F[2], ro[0] * F[1] - ro[1] * F[0]};
        double s[3], rs[3], sr[3][3];
        for (int i = 0; i < 3; i++) {
            s[i] = o[i];
            for (int j = 0; j < 3; j++) {
                s[i] += rot[i][j] * p.mount_pos[j];
                sr[i][j] = 0.0;
                for (int k = 0; k < 3; k++) {
                    sr[i][j] += rot[i][k] * mount[k][j];
                }
            }
        }
        for (int i = 0; i < 3; i++) {
            rs[i] = q[i] - s[i];
        }
        double m[3] = {rs[1] * F[2] - rs[2] * F[1], rs[2] * F[0] - rs[0] * F[2], rs[0] * F[1] - rs[1] * F[0]};
        double out[6];
        hs_ft_truth(&ft, rot, w, out);
        for (int j = 0; j < 3; j++) {
            double fs = sr[0][j] * F[0] + sr[1][j] * F[1] + sr[2][j] * F[2];
            double ms = sr[0][j] * m[0] + sr[1][j] * m[1] + sr[2][j] * m[2];
            assert_near(out[j], fs, 1e-9, "force %d, case %d", j, c);
            assert_near(out[3 + j], ms, 1e-9, "moment %d, case %d", j, c);
        }
    }
}

static void test_reading_and_clock(void **state)
{
    (void)state;
    hs_ft_params_t p = ideal();
    p.res_force = 0.01;
    p.res_moment = 0.001;
    p.rate_hz = 1300.0;
    hs_ft_t ft;
    assert_int_equal(hs_ft_init(&ft, &p, 3u), HS_OK);
    double r[3][3];
    identity(r);
    double w[6] = {123.456, -78.9, 2000.0, 12.3456, -1.2, 0.4};
    double t = 0.0;
    for (int n = 1; n <= 1000; n++) {
        t = n * 1e-3;
        assert_int_equal(hs_ft_advance(&ft, t, r, w), HS_OK);
        for (int k = 0; k < 6; k++) {
            assert_near(ft.reading[k], w[k], 0.5 * (k < 3 ? p.res_force : p.res_moment) + 1e-12, "axis %d", k);
        }
    }
    assert_true(ft.samples >= 1300u && ft.samples <= 1301u);
    /* a step: the reading keeps the old value until the next sample instant */
    hs_ft_params_t slow = ideal();
    slow.rate_hz = 400.0; /* a sample every 2.5 ms */
    assert_int_equal(hs_ft_init(&ft, &slow, 3u), HS_OK);
    double zero[6] = {0}, step[6] = {1000.0, 0, 0, 0, 0, 0};
    assert_int_equal(hs_ft_advance(&ft, 0.0, r, zero), HS_OK); /* sample at t = 0 */
    assert_int_equal(hs_ft_advance(&ft, 0.001, r, step), HS_OK);
    assert_near(ft.reading[0], 0.0, 1e-6, "no sample in (0, 1 ms]");
    assert_int_equal(hs_ft_advance(&ft, 0.002, r, step), HS_OK);
    assert_near(ft.reading[0], 0.0, 1e-6, "no sample in (1, 2 ms]");
    assert_int_equal(hs_ft_advance(&ft, 0.003, r, step), HS_OK);
    assert_near(ft.reading[0], 1000.0, 1e-6, "the sample at 2.5 ms");
}

static void test_noise_bias_drift(void **state)
{
    (void)state;
    hs_ft_params_t p = hs_ft_default_params();
    p.rate_hz = 1000.0;
    hs_ft_t ft;
    assert_int_equal(hs_ft_init(&ft, &p, 11u), HS_OK);
    for (int k = 0; k < 6; k++) {
        assert_true(fabs(ft.bias[k]) <= (k < 3 ? p.bias_force : p.bias_moment));
        assert_true(fabs(ft.drift[k]) <= (k < 3 ? p.drift_force : p.drift_moment));
    }
    double r[3][3];
    identity(r);
    double w[6] = {500.0, 0.0, -1500.0, 10.0, -20.0, 5.0};
    const int n = 20000;
    double sum[6] = {0}, sum2[6] = {0}, first[6] = {0}, last[6] = {0};
    for (int i = 1; i <= n; i++) {
        assert_int_equal(hs_ft_advance(&ft, i * 1e-3, r, w), HS_OK);
        for (int k = 0; k < 6; k++) {
            /* remove the known bias and drift: what is left is the noise */
            double e = ft.reading[k] - w[k] - ft.bias[k] - ft.drift[k] * (ft.samples - 1u) * 1e-3;
            sum[k] += e;
            sum2[k] += e * e;
            if (i <= 1000) {
                first[k] += ft.reading[k] / 1000.0;
            }
            if (i > n - 1000) {
                last[k] += ft.reading[k] / 1000.0;
            }
        }
    }
    for (int k = 0; k < 6; k++) {
        double sd = k < 3 ? p.noise_force : p.noise_moment;
        double mean = sum[k] / n, var = sum2[k] / n - mean * mean;
        assert_near(sqrt(var), sd, 0.05 * sd, "noise sd, axis %d", k);
        double moved = ft.drift[k] * (n - 1000) * 1e-3;
        assert_near(last[k] - first[k], moved, 3.0 * sd * sqrt(2.0 / 1000.0) + (k < 3 ? p.res_force : p.res_moment),
                    "drift, axis %d", k);
    }
    /* the same seed gives the same readings */
    hs_ft_t a, b;
    assert_int_equal(hs_ft_init(&a, &p, 99u), HS_OK);
    assert_int_equal(hs_ft_init(&b, &p, 99u), HS_OK);
    for (int i = 1; i <= 100; i++) {
        assert_int_equal(hs_ft_advance(&a, i * 1e-3, r, w), HS_OK);
        assert_int_equal(hs_ft_advance(&b, i * 1e-3, r, w), HS_OK);
        assert_memory_equal(a.reading, b.reading, sizeof a.reading);
    }
}

static void test_saturation(void **state)
{
    (void)state;
    hs_ft_params_t p = ideal();
    p.range_force = 1000.0;
    hs_ft_t ft;
    assert_int_equal(hs_ft_init(&ft, &p, 1u), HS_OK);
    double r[3][3];
    identity(r);
    double w[6] = {0.0, -5000.0, 0.0, 0.0, 0.0, 0.0};
    assert_int_equal(hs_ft_advance(&ft, 0.001, r, w), HS_OK);
    assert_near(ft.reading[1], -1000.0, 1e-6, "held at the range");
    assert_int_equal(ft.saturated, 1);
    w[1] = 10.0;
    assert_int_equal(hs_ft_advance(&ft, 0.002, r, w), HS_OK);
    assert_int_equal(ft.saturated, 0);
}

/* The firmware's sp_ft_to_base undoes the plant's hs_ft_truth: two
 * implementations, one each way, on random poses, mounts and wrenches
 * (within 0.01 N, N m + 1e-8 relative: the Q8 rounding of the reading). */
static void test_firmware_round_trip(void **state)
{
    (void)state;
    uint64_t rng = 0xf7f7u;
    hs_rng_t r;
    hs_rng_seed(&r, rng);
    for (int c = 0; c < 5000; c++) {
        hs_ft_params_t p = ideal();
        double u[12];
        for (int k = 0; k < 12; k++) {
            u[k] = 2.0 * ((double)(hs_rng_next(&r) >> 11) * (1.0 / 9007199254740992.0)) - 1.0;
        }
        for (int k = 0; k < 3; k++) {
            p.mount_pos[k] = 0.3 * u[k];
            p.mount_rpy[k] = 3.0 * u[3 + k];
        }
        hs_ft_t ft;
        assert_int_equal(hs_ft_init(&ft, &p, 1u), HS_OK);
        double rpy[3] = {0.3 * u[6], 0.3 * u[7], 3.0 * u[8]};
        double rot[3][3];
        hs_rot_from_rpy(rpy, rot);
        double w[6] = {5000.0 * u[9], -3000.0 * u[10], 20000.0 * u[11], 800.0 * u[0], -600.0 * u[4], 300.0 * u[8]};
        double s[6];
        hs_ft_truth(&ft, rot, w, s);
        sp_ft_mount_t mount;
        sp_rot_t T;
        for (int i = 0; i < 3; i++) {
            mount.pos[i] = (sp_q24_t)lround(p.mount_pos[i] * 16777216.0);
            for (int j = 0; j < 3; j++) {
                mount.axes.t[i][j] = (sp_q30_t)lround(ft.mount[i][j] * 1073741824.0);
                T.t[i][j] = (sp_q30_t)lround(rot[j][i] * 1073741824.0); /* rows of T: the platform's axes */
            }
        }
        sp_q8_t reading[6], out[6];
        for (int k = 0; k < 6; k++) {
            reading[k] = (sp_q8_t)lround(s[k] * 256.0);
        }
        assert_int_equal(sp_ft_to_base(&mount, &T, reading, out), SP_OK);
        for (int k = 0; k < 6; k++) {
            assert_near(out[k] / 256.0, w[k], 0.01 + 1e-8 * fabs(w[k]), "component %d, case %d", k, c);
        }
        expect_plain(&mount, &T, reading, c);
        for (int k = 0; k < 6; k++) { /* full range: the clamps and saturations */
            reading[k] = (sp_q8_t)(uint32_t)(hs_rng_next(&r) >> 32);
        }
        expect_plain(&mount, &T, reading, c);
    }
}

static void test_firmware_tare(void **state)
{
    (void)state;
    sp_ft_tare_t t;
    sp_ft_tare_reset(&t);
    sp_q8_t in[6] = {100 * 256, -50 * 256, 7, -7, 0, 3}, out[6];
    assert_int_equal(sp_ft_tare_step(&t, in, out), SP_OK);
    assert_memory_equal(in, out, sizeof in); /* no bias yet */
    assert_int_equal(sp_ft_tare_start(&t, 0u), SP_E_ARG);
    assert_int_equal(sp_ft_tare_start(&t, 4u), SP_OK);
    for (int n = 0; n < 3; n++) {
        assert_int_equal(sp_ft_tare_step(&t, in, out), SP_E_BUSY);
    }
    in[0] += 4; /* the mean of 100 x3 and 100 + 4/256: rounds to +1 LSB */
    assert_int_equal(sp_ft_tare_step(&t, in, out), SP_OK);
    assert_int_equal(t.tared, 1u);
    assert_int_equal(t.bias[0], 100 * 256 + 1);
    assert_int_equal(t.bias[1], -50 * 256);
    in[0] = INT32_MIN;
    assert_int_equal(sp_ft_tare_step(&t, in, out), SP_E_OVERFLOW);
    assert_int_equal(out[0], INT32_MIN);
    assert_int_equal(sp_ft_tare_step(NULL, in, out), SP_E_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init_rejects),      cmocka_unit_test(test_truth_frames),
        cmocka_unit_test(test_reading_and_clock), cmocka_unit_test(test_noise_bias_drift),
        cmocka_unit_test(test_saturation),        cmocka_unit_test(test_firmware_round_trip),
        cmocka_unit_test(test_firmware_tare),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
