/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_friction.c - the friction observer (sp/estimation/friction.h) against a double
 * precision reference of the same discrete law, and its exp(-u) against
 * libm; and bit for bit against its plain first version (friction_plain.c)
 * on random platforms, states and length steps. (Against the plant's
 * continuous LuGre friction: tests/plant/test_plant_fric_obs.c.)
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "assert_near.h"
#include "plain/friction_plain.h"
#include "sp/estimation/friction.h"
#include "test_util.h"

#define Q8 256.0
#define Q24 16777216.0
#define Q30 1073741824.0

/* exp(-u) over [0, 22] (every Q24 step near 0, then a dense random sweep)
 * against libm, the plain reference of the table and its three Taylor
 * terms: the header states 64 LSB of Q30. */
static void test_exp_neg(void **state)
{
    uint64_t rng = 11u;
    double worst = 0.0, worst_u = 0.0;
    (void)state;
    for (int32_t k = 0; k < 400000; ++k) {
        sp_q24_t u = (k < 100000) ? k : (sp_q24_t)tu_uniform(&rng, 0.0, 22.0 * Q24);
        double want = exp(-(double)u / Q24);
        double err = fabs((double)sp_fric_exp_neg(u) - want * Q30);
        if (err > worst) {
            worst = err;
            worst_u = u / Q24;
        }
    }
    printf("  exp(-u): max error %.2f LSB of Q30 (%.2g) at u = %.6f\n", worst, worst / Q30, worst_u);
    /* the remainder d^4 / 24 < 4.1e-8 (44 LSB) for d < 1/32, plus roundings */
    assert_true(worst <= 64.0);
    assert_int_equal(sp_fric_exp_neg(0), SP_Q30_ONE);
    assert_int_equal(sp_fric_exp_neg(-5), SP_Q30_ONE);
    assert_int_equal(sp_fric_exp_neg(INT32_MAX), 0);
    assert_int_equal(sp_fric_exp_neg((sp_q24_t)(31.0 * 0.6931471805599453 * Q24) + 1), 0);
}

/* The fast leg's shortcut (friction.c, fric_slide): exp(-u) is above 1/2
 * (2^29 in Q30) for every u below ln 2 (11629080 in Q24) and below 1/2
 * from there on: every u up to 2 ln 2, where exp(-u) is at most 1/4 +
 * 1 LSB, and spot checks beyond. */
static void test_exp_neg_half(void **state)
{
    const sp_q24_t ln2 = 11629080;
    (void)state;
    for (sp_q24_t u = 0; u < 2 * ln2; ++u) {
        sp_q30_t e = sp_fric_exp_neg(u);
        if (u < ln2 ? e <= (1 << 29) : e >= (1 << 29)) {
            fail_msg("exp(-%d / 2^24) = %d against 2^29", (int)u, (int)e);
        }
    }
    assert_true(sp_fric_exp_neg(2 * ln2) <= (1 << 28) + 1);
    for (sp_q24_t u = 2 * ln2; u < INT32_MAX - 999999; u += 999999) {
        assert_true(sp_fric_exp_neg(u) <= (1 << 28) + 1);
    }
}

/* The same discrete law in double (sp/estimation/friction.h), one leg. */
typedef struct {
    double s0, s1, cv, fc, fs, vs;
} ref_leg_t;

static ref_leg_t ref_leg(const sp_platform_t *p, int i)
{
    ref_leg_t r;
    r.s0 = p->bristle_stiffness[i];
    r.s1 = p->bristle_damping[i] / Q8;
    r.cv = p->viscous_friction[i] / Q8;
    r.fc = p->coulomb_friction[i] / Q8;
    r.fs = p->breakaway_friction[i] / Q8;
    r.vs = p->stribeck_velocity / Q24;
    return r;
}

static double ref_step(const ref_leg_t *r, double *phi, double dx, double dt)
{
    double v = dx / dt;
    double e = exp(-(v / r->vs) * (v / r->vs));
    double g = r->fc + (r->fs - r->fc) * e;
    double phin = *phi;
    double f;
    if (dx != 0.0) {
        double t = dx > 0.0 ? g : -g;
        phin = t + (*phi - t) * exp(-r->s0 * fabs(dx) / g);
    }
    f = phin + r->s1 * e * (phin - *phi) / (r->s0 * dt) + r->cv * v;
    *phi = phin;
    return f;
}

/* A random length history in whole um: rest, sliding at 0.1 um/tick to
 * 0.3 m/s, sinusoids (reversals), micro-motions of a few um. */
static double next_x(uint64_t *rng, int *seg, int *left, double *a, double *b, double *t, double x)
{
    if (*left <= 0) {
        *seg = (int)(tu_next(rng) % 4u);
        *left = (int)(10u + tu_next(rng) % 600u);
        *t = 0.0;
        if (*seg == 1) {
            *a = exp(tu_uniform(rng, log(0.1), log(300.0))) * ((tu_next(rng) & 1u) ? 1.0 : -1.0); /* um/tick */
        } else if (*seg == 2) {
            *a = exp(tu_uniform(rng, log(5.0), log(20000.0)));                    /* amplitude, um */
            *b = tu_uniform(rng, 0.2, 5.0) * 2.0 * 3.14159265358979323846 * 1e-3; /* rad/tick */
        }
    }
    --*left;
    *t += 1.0;
    switch (*seg) {
    case 1:
        return x + *a;
    case 2:
        return x + *a * (sin(*b * *t) - sin(*b * (*t - 1.0)));
    case 3:
        return x + tu_uniform(rng, -3.0, 3.0);
    default:
        return x;
    }
}

static void run_against_reference(uint32_t tick_us, int jitter, double *max_f, double *rms_f, double *max_phi)
{
    const sp_platform_t *p = &sp_platform_default;
    sp_fric_obs_t o;
    ref_leg_t r[SP_LEGS];
    double phi[SP_LEGS] = {0}, x[SP_LEGS] = {0}, a[SP_LEGS] = {0}, b[SP_LEGS] = {0}, t[SP_LEGS] = {0};
    int seg[SP_LEGS] = {0}, left[SP_LEGS] = {0};
    sp_q24_t len[SP_LEGS], prev[SP_LEGS];
    sp_q8_t f[SP_LEGS];
    uint64_t rng = 2024u + tick_us;
    double sum = 0.0;
    long n = 0;
    *max_f = *max_phi = 0.0;
    sp_fric_obs_reset(&o);
    for (int i = 0; i < SP_LEGS; ++i) {
        r[i] = ref_leg(p, i);
        len[i] = (sp_q24_t)llround((0.9 + 0.05 * i) * Q24);
    }
    assert_int_equal(sp_fric_obs_step(p, &o, len, tick_us, f), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(f[i], 0);
    }
    for (int k = 0; k < 40000; ++k) {
        uint32_t dt_us = tick_us + (jitter ? (uint32_t)(tu_next(&rng) % 101u) - 50u : 0u);
        memcpy(prev, len, sizeof len);
        for (int i = 0; i < SP_LEGS; ++i) {
            x[i] = next_x(&rng, &seg[i], &left[i], &a[i], &b[i], &t[i], x[i]);
            len[i] = (sp_q24_t)llround((0.9 + 0.05 * i + 1e-6 * round(x[i])) * Q24);
        }
        assert_int_equal(sp_fric_obs_step(p, &o, len, dt_us, f), SP_OK);
        for (int i = 0; i < SP_LEGS; ++i) {
            double want = ref_step(&r[i], &phi[i], (len[i] - prev[i]) / Q24, dt_us * 1e-6);
            double e = fabs(f[i] / Q8 - want);
            double ep = fabs(o.phi[i] / Q8 - phi[i]);
            sum += e * e;
            ++n;
            *max_f = fmax(*max_f, e);
            *max_phi = fmax(*max_phi, ep);
            if (e > 0.25) {
                fail_msg("tick %d leg %d: friction %.4f N, reference %.4f N", k, i, f[i] / Q8, want);
            }
        }
    }
    *rms_f = sqrt(sum / (double)n);
}

/* 40 000 ticks x 6 legs, at 1 kHz and at a 2 ms tick:
 * friction within 0.25 N of the double reference
 * (one Q8 LSB of phi is 0.004 N; the damping term sigma_1 e / (sigma_0 dt)
 * scales it by 21 at the default seals). */
static void test_against_double_reference(void **state)
{
    double mf, rf, mp;
    (void)state;
    run_against_reference(1000u, 0, &mf, &rf, &mp);
    printf("  vs double reference, 1 kHz: friction max %.4f N, RMS %.4f N; phi max %.4f N\n", mf, rf, mp);
    assert_true(mp <= 0.05);
    run_against_reference(1000u, 1, &mf, &rf, &mp);
    printf("  vs double reference, tick 950..1050 us: friction max %.4f N, RMS %.4f N; phi max %.4f N\n", mf, rf, mp);
    assert_true(mp <= 0.05);
    /* a longer step: twice the controller's tick */
    run_against_reference(2000u, 0, &mf, &rf, &mp);
    printf("  vs double reference, 2 ms tick: friction max %.4f N, RMS %.4f N; phi max %.4f N\n", mf, rf, mp);
    assert_true(mp <= 0.05);
}

/* Holding: after sliding the bristles hold the Coulomb level at rest; a
 * small reversal unloads them by sigma_0 per um; a 1 um step from rest
 * loads them by about 4 N. */
static void test_hold_and_reversal(void **state)
{
    const sp_platform_t *p = &sp_platform_default;
    sp_fric_obs_t o;
    sp_q24_t len[SP_LEGS];
    sp_q8_t f[SP_LEGS];
    const sp_q24_t um = 17; /* ~1 um in Q24 (1.0133 um) */
    (void)state;
    sp_fric_obs_reset(&o);
    for (int i = 0; i < SP_LEGS; ++i) {
        len[i] = SP_Q24_ONE;
    }
    assert_int_equal(sp_fric_obs_step(p, &o, len, 1000u, f), SP_OK);
    /* 1 um from rest: ~ sigma_0 1 um (4 N) + damping */
    len[0] += um;
    assert_int_equal(sp_fric_obs_step(p, &o, len, 1000u, f), SP_OK);
    assert_near(o.phi[0] / Q8, 4.0e6 * um / Q24, 0.1, "phi after 1 um");
    /* slide +50 mm/s for 0.2 s, then rest */
    for (int k = 0; k < 200; ++k) {
        len[0] += 50 * um;
        assert_int_equal(sp_fric_obs_step(p, &o, len, 1000u, f), SP_OK);
    }
    assert_near(f[0] / Q8, 400.0 + 3000.0 * 50 * um / Q24 * 1e3, 0.5, "sliding friction");
    for (int k = 0; k < 100; ++k) {
        assert_int_equal(sp_fric_obs_step(p, &o, len, 1000u, f), SP_OK);
        assert_near(f[0] / Q8, 400.0, 0.01, "held at rest");
    }
    /* reverse by 20 um at 1 mm/s: LuGre unloads at dphi/dx = sigma_0 (1 + phi / g),
     * 1.68 sigma_0 at first (g = 592 N): 400 -> -592 + 992 exp(-20.3 um sigma_0 / g) = 273 N */
    for (int k = 0; k < 20; ++k) {
        len[0] -= um;
        assert_int_equal(sp_fric_obs_step(p, &o, len, 1000u, f), SP_OK);
    }
    assert_int_equal(sp_fric_obs_step(p, &o, len, 1000u, f), SP_OK);
    printf("  held 400 N after sliding; after a 20 um reversal: %.2f N\n", f[0] / Q8);
    assert_near(f[0] / Q8, -592.1 + 992.1 * exp(-4.0e6 * 20.0 * um / Q24 / 592.1), 1.0, "after a reversal");
    for (int i = 1; i < SP_LEGS; ++i) {
        assert_int_equal(f[i], 0);
    }
}

static void test_errors_and_saturation(void **state)
{
    sp_platform_t p = sp_platform_default;
    sp_fric_obs_t o, keep;
    sp_q24_t len[SP_LEGS] = {0};
    sp_q8_t f[SP_LEGS];
    (void)state;
    sp_fric_obs_reset(&o);
    sp_fric_obs_reset(NULL);
    assert_int_equal(sp_fric_obs_step(NULL, &o, len, 1000u, f), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step(&p, NULL, len, 1000u, f), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step(&p, &o, NULL, 1000u, f), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, NULL), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 0u, f), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step(&p, &o, len, SP_FRIC_TICK_MAX_US + 1u, f), SP_E_ARG);
    assert_int_equal(o.valid, 0);
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, f), SP_OK);
    keep = o;
    p.stribeck_velocity = 0;
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, f), SP_E_ARG);
    assert_memory_equal(&o, &keep, sizeof o);
    p = sp_platform_default;
    p.breakaway_friction[3] = p.coulomb_friction[3] - 1;
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, f), SP_E_ARG);
    p = sp_platform_default;
    /* extreme jumps: INT32_MIN -> INT32_MAX lengths, 1 us ticks: saturate, never wrap */
    for (int i = 0; i < SP_LEGS; ++i) {
        len[i] = INT32_MIN;
    }
    sp_fric_obs_reset(&o);
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1u, f), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        len[i] = INT32_MAX;
    }
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1u, f), SP_E_OVERFLOW);
    for (int i = 0; i < SP_LEGS; ++i) {
        /* v saturates at 128 m/s: F_c + c_v 128 m/s */
        assert_near(f[i] / Q8, 400.0 + 3000.0 * 128.0, 0.01, "saturated rate");
        assert_int_equal(o.phi[i], p.coulomb_friction[i]);
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        len[i] = INT32_MIN;
    }
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1u, f), SP_E_OVERFLOW);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_near(f[i] / Q8, -400.0 - 3000.0 * 128.0, 0.01, "saturated rate");
        assert_int_equal(o.phi[i], -p.coulomb_friction[i]);
    }
    /* no bristles (sigma_0 = 0): viscous only */
    p.bristle_stiffness[2] = 0;
    sp_fric_obs_reset(&o);
    len[2] = 0;
    assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, f), SP_OK);
    len[2] = 10 * 16777; /* 10 mm in 1 ms: 10 m/s */
    (void)sp_fric_obs_step(&p, &o, len, 1000u, f);
    assert_near(f[2] / Q8, 3000.0 * 10.0 * 16777.0 / Q24 * 1e3, 0.1, "viscous only");
    assert_int_equal(o.phi[2], 0);
}

/* |v| of a log-scale int32, at least lo */
static int32_t mag(uint64_t *rng, int32_t lo)
{
    int32_t v = tu_i32_logscale(rng);
    v = (v < 0) ? -v : v;
    return (v < lo) ? lo : v;
}

/* A platform whose friction sp_fric_obs_check accepts: half of them the
 * default scaled by random factors, half with every magnitude log-uniform
 * over all widths; some legs without bristles or without damping. */
static void random_platform(uint64_t *rng, sp_platform_t *p)
{
    int wild = (int)(tu_next(rng) & 1u);
    *p = sp_platform_default;
    p->stribeck_velocity = wild ? mag(rng, 1) : (int32_t)(p->stribeck_velocity * tu_uniform(rng, 0.2, 5.0));
    for (int i = 0; i < SP_LEGS; ++i) {
        if (wild) {
            p->viscous_friction[i] = mag(rng, 0);
            p->coulomb_friction[i] = mag(rng, 1);
            p->breakaway_friction[i] =
                p->coulomb_friction[i] +
                (int32_t)((uint32_t)mag(rng, 0) % ((uint32_t)(INT32_MAX - p->coulomb_friction[i]) + 1u));
            p->bristle_stiffness[i] = mag(rng, 0);
            p->bristle_damping[i] = mag(rng, 0);
        } else {
            double k = tu_uniform(rng, 0.1, 10.0);
            p->coulomb_friction[i] = (int32_t)(p->coulomb_friction[i] * k);
            p->breakaway_friction[i] = (int32_t)(p->breakaway_friction[i] * k);
            p->bristle_stiffness[i] = (int32_t)(p->bristle_stiffness[i] * tu_uniform(rng, 0.1, 10.0));
        }
        switch (tu_next(rng) % 8u) {
        case 0:
            p->bristle_stiffness[i] = 0;
            break;
        case 1:
            p->bristle_damping[i] = 0;
            break;
        default:
            break;
        }
    }
    assert_int_equal(sp_fric_obs_check(p), SP_OK);
}

/* A length step: none, one near the Stribeck range (a few v_s ticks), one
 * of any width, or a jump across the whole int32 range. */
static int64_t random_step(uint64_t *rng, const sp_platform_t *p, uint32_t tick_us)
{
    switch (tu_next(rng) % 6u) {
    case 0:
        return 0;
    case 1:
    case 2: {
        double vs_tick = (double)p->stribeck_velocity * tick_us * 1e-6; /* Q24 per tick */
        double d = tu_uniform(rng, 0.0, 6.0) * vs_tick + tu_uniform(rng, -2.0, 2.0);
        return (int64_t)((tu_next(rng) & 1u) ? d : -d);
    }
    case 3:
        return (int64_t)tu_i32(rng) * 2;
    default:
        return tu_i32_logscale(rng);
    }
}

static sp_q8_t random_phi(uint64_t *rng, const sp_platform_t *p, int i)
{
    if (tu_next(rng) % 16u == 0u) {
        return tu_i32(rng); /* outside the law's bound |phi| <= F_s: still the same */
    }
    if (tu_next(rng) % 4u == 0u) {
        /* at or next to the Coulomb level, where a fast leg settles */
        int32_t near = p->coulomb_friction[i] + (int32_t)(tu_next(rng) % 5u) - 2;
        return (tu_next(rng) & 1u) ? near : -near;
    }
    return (sp_q8_t)tu_uniform(rng, -(double)p->breakaway_friction[i], (double)p->breakaway_friction[i]);
}

/* Every entry of a Stribeck table (its fade, when the build keeps the
 * fades, and its relaxation) is what the plain step computes for the
 * table's first leg at that increment: o is the observer after its first
 * step on p (its kept constants). */
static long check_table_entries(const sp_platform_t *p, const sp_fric_obs_t *o, const sp_fric_table_t *tab)
{
    int c = 0;
    if (tab->count == 0u) {
        return 0;
    }
    while (((tab->legs >> c) & 1u) == 0u) {
        ++c;
    }
    assert_true(tab->inv_vs == o->inv_vs);
    for (uint32_t n = 1u; n <= tab->count; ++n) {
        sp_q30_t es, eb;
        plain_fric_slow_terms(p, o, c, tab->tick_us, (int32_t)n, &es, &eb);
        assert_true(es > 0); /* below 4 v_s */
        if (tab->fade[n - 1u] != es) {
            fail_msg("fade at |dx| = %u: %d, plain %d", (unsigned)n, (int)tab->fade[n - 1u], (int)es);
        }
        if (tab->relax[n - 1u] != eb) {
            fail_msg("relaxation at |dx| = %u: %d, plain %d", (unsigned)n, (int)tab->relax[n - 1u], (int)eb);
        }
    }
    return (long)tab->count;
}

/* The observer's step, without and with its Stribeck table, equals its
 * plain first version bit for bit (outputs, state, status) over 3000
 * random platforms (half of them with the six legs' seals alike, as the
 * table's legs), 40 ticks each, random bristle states and steps of every
 * width, at ticks that divide a second and ones that do not; exp(-u)
 * likewise over random arguments and every k. */
static void test_equals_plain(void **state)
{
    static const uint32_t ticks[] = {1000u, 500u, 250u, 1u, 3u, 7u, 999u, SP_FRIC_TICK_MAX_US};
    uint64_t rng = UINT64_C(0x14F);
    static sp_fric_table_t table;
    long moving = 0;
    long tabled = 0;
    long entries = 0;
    (void)state;
    for (int n = 0; n < 2000000; ++n) {
        sp_q24_t u = (n % 2 == 0) ? tu_i32_logscale(&rng) : tu_i32(&rng);
        assert_int_equal(sp_fric_exp_neg(u), plain_fric_exp_neg(u));
    }
    for (int32_t k = 0; k <= 32; ++k) {
        for (int32_t e = -64; e <= 64; ++e) {
            sp_q24_t u = k * 11629080 + e;
            assert_int_equal(sp_fric_exp_neg(u), plain_fric_exp_neg(u));
        }
    }
    for (int n = 0; n < 3000; ++n) {
        sp_platform_t p;
        sp_fric_obs_t o, ot, ref;
        sp_q24_t len[SP_LEGS];
        sp_q8_t f[SP_LEGS], ft[SP_LEGS], f_ref[SP_LEGS];
        sp_status_t first;
        uint32_t tick_us = (n % 5 == 4) ? 1u + (uint32_t)(tu_next(&rng) % SP_FRIC_TICK_MAX_US) : ticks[n % 8];
        random_platform(&rng, &p);
        if (n % 2 == 0) {
            for (int i = 1; i < SP_LEGS; ++i) {
                p.bristle_stiffness[i] = p.bristle_stiffness[0];
                p.coulomb_friction[i] = p.coulomb_friction[0];
                p.breakaway_friction[i] = p.breakaway_friction[0];
            }
        }
        /* a table of another tick now and then: not used */
        assert_int_equal(sp_fric_table_prepare(&p, (n % 16 == 15) ? tick_us % 1000u + 1u : tick_us, &table), SP_OK);
        sp_fric_obs_reset(&o);
        for (int i = 0; i < SP_LEGS; ++i) {
            len[i] = tu_i32(&rng) / 4;
        }
        first = sp_fric_obs_step(&p, &o, len, tick_us, f); /* wild platforms saturate sigma_0 / F_c */
        assert_true(first == SP_OK || first == SP_E_OVERFLOW);
        entries += check_table_entries(&p, &o, &table);
        for (int i = 0; i < SP_LEGS; ++i) {
            o.phi[i] = random_phi(&rng, &p, i);
        }
        ref = o;
        ot = o;
        for (int t = 0; t < 40; ++t) {
            sp_status_t st, st_ref;
            if (tu_next(&rng) % 8u == 0u) {
                for (int i = 0; i < SP_LEGS; ++i) {
                    o.phi[i] = random_phi(&rng, &p, i);
                    ref.phi[i] = o.phi[i];
                    ot.phi[i] = o.phi[i];
                }
            }
            for (int i = 0; i < SP_LEGS; ++i) {
                int64_t l = (int64_t)len[i] + random_step(&rng, &p, tick_us);
                len[i] = (sp_q24_t)((l > INT32_MAX) ? INT32_MAX : (l < INT32_MIN) ? INT32_MIN : l);
                int64_t d = (int64_t)len[i] - o.length[i];
                moving += (len[i] != o.length[i]);
                tabled += (d != 0 && (((unsigned)table.legs >> i) & 1u) && (d < 0 ? -d : d) <= (int64_t)table.count);
            }
            st = sp_fric_obs_step(&p, &o, len, tick_us, f);
            st_ref = plain_fric_obs_run(&p, &ref, len, tick_us, f_ref);
            assert_int_equal(st, st_ref);
            assert_memory_equal(f, f_ref, sizeof f);
            assert_int_equal(sp_fric_obs_step_table(&p, &ot, &table, len, tick_us, ft), st_ref);
            assert_memory_equal(ft, f_ref, sizeof ft);
            assert_memory_equal(ot.phi, o.phi, sizeof o.phi);
            assert_memory_equal(ot.length, o.length, sizeof o.length);
            assert_true(ot.inv_vs == o.inv_vs && ot.valid == o.valid);
            assert_memory_equal(o.phi, ref.phi, sizeof o.phi);
            assert_memory_equal(o.length, ref.length, sizeof o.length);
            assert_memory_equal(o.slip, ref.slip, sizeof o.slip);
            assert_memory_equal(o.tau, ref.tau, sizeof o.tau);
            assert_true(o.inv_vs == ref.inv_vs && o.valid == ref.valid);
        }
    }
    assert_true(moving > 3000L * 40L * SP_LEGS / 2L);  /* most leg-ticks moved */
    assert_true(tabled > 3000L * 40L * SP_LEGS / 20L); /* and many took the table's entries */
    printf("  %ld table entries equal to the plain step's fade and relaxation\n", entries);
    assert_true(entries > 3000L * 10L);
}

/* The table's step takes each leg's Stribeck fade (a function of the
 * speed alone) from the table: legs creeping by the same few LSB tick
 * after tick, now and then another step, the table's last entry, a reset
 * or a tick the table was not made for, equal the plain first version
 * bit for bit (outputs, bristles, status), over 400 platforms of the
 * table's seals, 200 ticks each; at least a quarter of the leg-ticks on
 * the table. */
static void test_table_creep(void **state)
{
    static sp_fric_table_t table;
    uint64_t rng = UINT64_C(0xFADE);
    long tabled = 0;
    (void)state;
    for (int n = 0; n < 400; ++n) {
        sp_platform_t p;
        sp_fric_obs_t o, ref;
        sp_q24_t len[SP_LEGS];
        int32_t creep[SP_LEGS];
        sp_q8_t f[SP_LEGS], f_ref[SP_LEGS];
        const uint32_t tick_us = (n % 2 == 0) ? 1000u : 500u;
        random_platform(&rng, &p);
        for (int i = 1; i < SP_LEGS; ++i) {
            p.bristle_stiffness[i] = p.bristle_stiffness[0];
            p.coulomb_friction[i] = p.coulomb_friction[0];
            p.breakaway_friction[i] = p.breakaway_friction[0];
        }
        assert_int_equal(sp_fric_table_prepare(&p, tick_us, &table), SP_OK);
        sp_fric_obs_reset(&o);
        sp_fric_obs_reset(&ref);
        for (int i = 0; i < SP_LEGS; ++i) {
            len[i] = tu_i32(&rng) / 4;
            creep[i] = 1 + (int32_t)(tu_next(&rng) % 8u);
        }
        for (int t = 0; t < 200; ++t) {
            /* 1 tick in 50 at another tick (the table unused), 1 in 100 a reset */
            uint32_t tk = (t % 50 == 49) ? tick_us + 1u : tick_us;
            if (t % 100 == 99) {
                sp_fric_obs_reset(&o);
                sp_fric_obs_reset(&ref);
            }
            for (int i = 0; i < SP_LEGS; ++i) {
                uint32_t r = (uint32_t)(tu_next(&rng) % 16u);
                int32_t dx = (r == 0u) ? creep[i] + 1 : ((r == 1u) ? -creep[i] : creep[i]);
                if (r == 2u && table.count > 0u) {
                    dx = (int32_t)table.count; /* the table's last entry */
                }
                len[i] += dx;
                if (o.valid && tk == tick_us && table.count > 0u && (dx < 0 ? -dx : dx) <= (int32_t)table.count) {
                    ++tabled;
                }
            }
            sp_status_t st = sp_fric_obs_step_table(&p, &o, &table, len, tk, f);
            sp_status_t st_ref = plain_fric_obs_run(&p, &ref, len, tk, f_ref);
            assert_int_equal(st, st_ref);
            assert_memory_equal(f, f_ref, sizeof f);
            assert_memory_equal(o.phi, ref.phi, sizeof o.phi);
            assert_memory_equal(o.length, ref.length, sizeof o.length);
        }
    }
    assert_true(tabled > 400L * 200L * SP_LEGS / 4L);
}

/* A fast leg at or next to its Coulomb level (fric_slide's shortcut)
 * equals the plain step where exp(-a) crosses 1/2: seals whose
 * a = (sigma_0 / F_c) |dx| is ln 2 (11629080 in Q24) at |dx| = 8 LSB,
 * and 1 LSB of Q24 around it, all faster than 4 v_s at 1 ms. */
static void test_fast_leg_at_level(void **state)
{
    sp_platform_t p = sp_platform_default;
    (void)state;
    p.stribeck_velocity = 1000; /* 4 v_s = 4 LSB per tick */
    for (int i = 0; i < SP_LEGS; ++i) {
        p.coulomb_friction[i] = 65536;       /* 256 N */
        p.breakaway_friction[i] = 2 * 65536; /* 512 N */
        p.bristle_stiffness[i] = 372130560;  /* sigma_0 / F_c = 2^8 ln 2 / 8 LSB, Q8 */
    }
    for (int32_t adx = 7; adx <= 9; ++adx) {
        for (int32_t off = -2; off <= 2; ++off) {
            for (int sign = -1; sign <= 1; sign += 2) {
                sp_fric_obs_t o, ref;
                sp_q24_t len[SP_LEGS] = {0};
                sp_q8_t f[SP_LEGS], f_ref[SP_LEGS];
                sp_fric_obs_reset(&o);
                assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, f), SP_OK);
                assert_int_equal(o.slip[0], 372130560); /* a = slip |dx| / 2^8 */
                for (int i = 0; i < SP_LEGS; ++i) {
                    o.phi[i] = (i % 2 == 0 ? sign : -sign) * (65536 + off);
                    len[i] = (i < 3 ? sign : -sign) * adx;
                }
                ref = o;
                assert_int_equal(sp_fric_obs_step(&p, &o, len, 1000u, f), SP_OK);
                assert_int_equal(plain_fric_obs_run(&p, &ref, len, 1000u, f_ref), SP_OK);
                assert_memory_equal(f, f_ref, sizeof f);
                assert_memory_equal(o.phi, ref.phi, sizeof o.phi);
            }
        }
    }
}

/* The table of the default platform at 1 ms covers its whole region below
 * 4 v_s (|dx| < 20 um = 335.5 LSB of Q24) for all six legs; a leg with
 * other seals is left out; bad arguments leave it empty. */
static void test_table_prepare(void **state)
{
    sp_platform_t p = sp_platform_default;
    static sp_fric_table_t table;
    sp_fric_obs_t o;
    sp_q24_t len[SP_LEGS] = {0};
    sp_q8_t f[SP_LEGS];
    (void)state;
    assert_int_equal(sp_fric_table_prepare(&p, 1000u, &table), SP_OK);
    assert_int_equal(table.count, 335);
    assert_int_equal(table.legs, 0x3F);
    assert_int_equal(table.tick_us, 1000);
    /* the relaxation at 1 um/ms and 19.9 um/ms against the law in double
     * (sigma_0 / g within 2^-28 relative, two exps' errors of 64 LSB of
     * Q30, the inputs' rounding: 1e-7) */
    for (int n = 17; n <= 334; n += 317) {
        double v = n / 16777216.0 / 1e-3;
        double fc = p.coulomb_friction[0] / 256.0;
        double g = fc + (p.breakaway_friction[0] / 256.0 - fc) * exp(-pow(v / (p.stribeck_velocity / 16777216.0), 2));
        assert_true(fabs(table.relax[n - 1] / 1073741824.0 - exp(-p.bristle_stiffness[0] * (n / 16777216.0) / g)) <
                    1e-7);
    }
    /* 0.5 ms: half the increments reach 4 v_s */
    assert_int_equal(sp_fric_table_prepare(&p, 500u, &table), SP_OK);
    assert_int_equal(table.count, 167);
    p.coulomb_friction[3] += 1;
    assert_int_equal(sp_fric_table_prepare(&p, 1000u, &table), SP_OK);
    assert_int_equal(table.legs, 0x37);
    p.bristle_stiffness[0] = 0;
    assert_int_equal(sp_fric_table_prepare(&p, 1000u, &table), SP_OK);
    assert_int_equal(table.legs, 0x36); /* leg 1's seals: the first with bristles */
    assert_int_equal(sp_fric_table_prepare(&p, 0u, &table), SP_E_ARG);
    assert_int_equal(table.count, 0);
    assert_int_equal(sp_fric_table_prepare(NULL, 1000u, &table), SP_E_ARG);
    assert_int_equal(sp_fric_table_prepare(&p, 1000u, NULL), SP_E_ARG);
    p.bristle_stiffness[1] = -1;
    assert_int_equal(sp_fric_table_prepare(&p, 1000u, &table), SP_E_ARG);
    sp_fric_obs_reset(&o);
    assert_int_equal(sp_fric_obs_step_table(&p, &o, &table, len, 1000u, f), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step_table(&sp_platform_default, &o, NULL, len, 0u, f), SP_E_ARG);
    assert_int_equal(sp_fric_obs_step_table(&sp_platform_default, &o, NULL, len, 1000u, f), SP_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exp_neg),
        cmocka_unit_test(test_exp_neg_half),
        cmocka_unit_test(test_against_double_reference),
        cmocka_unit_test(test_hold_and_reversal),
        cmocka_unit_test(test_errors_and_saturation),
        cmocka_unit_test(test_equals_plain),
        cmocka_unit_test(test_table_creep),
        cmocka_unit_test(test_fast_leg_at_level),
        cmocka_unit_test(test_table_prepare),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
