/* SPDX-License-Identifier: Apache-2.0 */
/* friction_plain.c - the friction observer as it was before its tick was
 * trimmed (issue 14: fewer Cortex-M4 instructions per tick): the plain
 * reference test_friction.c holds firmware/core/src/estimation/friction.c to, bit for
 * bit, on random platforms, states and length steps. Not built into the
 * firmware. */
#include <stddef.h>

#include "friction_plain.h"

#include "math/fixed_inline.h"

/* ln 2 in Q24 and Q30, rounded to nearest */
#define FRIC_LN2_Q24 11629080
#define FRIC_LN2_Q30 INT64_C(744261118)
/* exp(-u) < 2^-31 (half an LSB of Q30) beyond 31 ln 2 */
#define FRIC_EXP_K_MAX 31
/* exp(-j / 32) in Q30, j = 0..22, rounded to nearest: the steps of
 * [0, ln 2) by 1/32 (generated with Python's math.exp) */
#define FRIC_EXP_STEPS 23
static const int32_t fric_exp_table[FRIC_EXP_STEPS] = {
    1073741824, 1040706261, 1008687096, 977653056, 947573834, 918420052, 890163238, 862775794,
    836230973,  810502851,  785566300,  761396966, 737971244, 715266256, 693259826, 671930464,
    651257337,  631220255,  611799650,  592976553, 574732583, 557049920, 539911296};
/* |v| / v_s at and beyond which exp(-(v/v_s)^2) is taken as 0: exp(-16) =
 * 1.1e-7, 0.00002 N of a 200 N break-away excess; the bristle damping
 * sigma_1 e dz/dt (at most sigma_1 e |v|) below 0.01 N there */
#define FRIC_STRIBECK_RATIO_MAX 4
/* sigma_0 |dx| / g at and beyond which exp(-a) is taken as 0 (exp(-32) = 1.3e-14) */
#define FRIC_BRISTLE_A_MAX 32
/* largest |bristle deflection step| carried into the damping term, Q36 m (64 m) */
#define FRIC_DZ_MAX_Q36 (INT64_C(1) << 42)

sp_q30_t plain_fric_exp_neg(sp_q24_t u)
{
    uint32_t k;
    uint32_t j;
    int32_t r, d, d2, d3, poly, acc;
    if (u <= 0) {
        return SP_Q30_ONE;
    }
    k = (uint32_t)u / (uint32_t)FRIC_LN2_Q24;
    if (k >= (uint32_t)FRIC_EXP_K_MAX) {
        return 0;
    }
    /* r = u - k ln2 in Q30: within a few LSB of [0, ln 2) (the two ln 2
     * roundings differ; a negative r of a few LSB is clamped to 0) */
    r = (int32_t)((int64_t)u * 64 - (int64_t)k * FRIC_LN2_Q30);
    r = (r < 0) ? 0 : r;
    /* exp(-r) = exp(-j/32) exp(-d), d = r - j/32 in [0, 1/32): the table
     * and three Taylor terms, remainder d^4 / 24 below 4.1e-8 */
    j = (uint32_t)r >> 25;
    j = (j < (uint32_t)FRIC_EXP_STEPS) ? j : (uint32_t)FRIC_EXP_STEPS - 1u;
    d = r - (int32_t)(j << 25);
    d2 = (int32_t)(((int64_t)d * d + (INT64_C(1) << 29)) >> 30);
    d3 = (int32_t)(((int64_t)d2 * d + (INT64_C(1) << 29)) >> 30);
    poly = SP_Q30_ONE - d + (d2 >> 1) - (d3 / 6);
    acc = (int32_t)(((int64_t)fric_exp_table[j] * poly + (INT64_C(1) << 29)) >> 30);
    /* acc is in (0, 1]: the shift by k keeps it in Q30's range */
    if (k > 0u) {
        acc = (int32_t)(((int64_t)acc + (INT64_C(1) << (k - 1u))) >> k);
    }
    return (acc > SP_Q30_ONE) ? SP_Q30_ONE : acc;
}

/* round(num / den) for den > 0, ties away from zero; |num| < 2^62. */
static int64_t div_round(int64_t num, int64_t den)
{
    int64_t h = den / 2;
    return (num >= 0) ? (num + h) / den : -((-num + h) / den);
}

static int64_t clamp64(int64_t v, int64_t lim, sp_flags_t *flags)
{
    if (v > lim) {
        *flags |= SP_FLAG_OVERFLOW;
        return lim;
    }
    if (v < -lim) {
        *flags |= SP_FLAG_OVERFLOW;
        return -lim;
    }
    return v;
}

/* What one tick needs besides the platform: the tick and its rate
 * multiplier (1e6 / tick_us when that is a whole number, else 0: divide). */
typedef struct {
    uint32_t tick_us;
    int32_t per_s; /* ticks per second when exact, else 0 */
} fric_tick_t;

/* d / dt for d in Q24 (|d| < 2^32): Q24 per second, saturated. */
static sp_q24_t per_second(const fric_tick_t *t, int64_t d, sp_flags_t *flags)
{
    if (t->per_s != 0) {
        return spi_sat(d * t->per_s, flags);
    }
    return spi_sat(div_round(d * 1000000, (int64_t)t->tick_us), flags);
}

/* round(x / 2^30) of a product below 2^62 in magnitude */
#define FRIC_Q30(x) (((x) + (INT64_C(1) << 29)) >> 30)

/* The slow leg's terms of leg_step below: the Stribeck fade es (0 at
 * and beyond 4 v_s), the level g (N, Q8) and the relaxation eb = exp(-a)
 * of a leg with bristles, |dx| = adx (Q24) at the speed av = |v| (m/s Q24). */
static sp_q30_t slow_terms(const sp_platform_t *p, const sp_fric_obs_t *o, int i, int64_t adx, int64_t av,
                           sp_q30_t *es_out, int64_t *g_out)
{
    int32_t fc = p->coulomb_friction[i];
    int64_t a, g;
    sp_q30_t es = 0;
    if (av < (int64_t)FRIC_STRIBECK_RATIO_MAX * p->stribeck_velocity) {
        /* (v / v_s)^2 in Q24: av < 4 v_s < 2^31 and inv_vs < 2^46 / v_s
         * give a ratio below 8 (2^27 in Q24) and a square below 2^54 */
        int64_t ratio = (av * o->inv_vs) >> 22;
        es = plain_fric_exp_neg((sp_q24_t)((ratio * ratio + (INT64_C(1) << 23)) >> 24));
    }
    /* a at g = F_c: (sigma_0 / F_c) |dx|, Q24 (slip Q8 x |dx| Q24 >> 8) */
    a = ((int64_t)o->slip[i] * adx) >> 8;
    g = fc;
    if (es != 0) {
        /* g = F_c + (F_s - F_c) e in [F_c, F_s], N Q8; a scaled by F_c / g (Q30, in (0, 1]) */
        g += FRIC_Q30(((int64_t)p->breakaway_friction[i] - fc) * es);
        if (a < ((int64_t)FRIC_BRISTLE_A_MAX << 24)) {
            /* F_c / g = F_c inv / 2^sh (the normalised reciprocal: one
             * 32-bit division, relative error below 2^-28), Q30 */
            unsigned sh;
            int32_t inv = spi_recip((uint32_t)g, &sh);
            int64_t scale = ((int64_t)fc * inv) >> (sh - 30u);
            a = FRIC_Q30(a * scale);
        }
    }
    *es_out = es;
    *g_out = g;
    return (a >= ((int64_t)FRIC_BRISTLE_A_MAX << 24)) ? 0 : plain_fric_exp_neg((sp_q24_t)a);
}

void plain_fric_slow_terms(const sp_platform_t *p, const sp_fric_obs_t *o, int i, uint32_t tick_us, int32_t adx,
                           sp_q30_t *es, sp_q30_t *eb)
{
    fric_tick_t t;
    sp_flags_t flags = 0u;
    int64_t g;
    t.tick_us = tick_us;
    t.per_s = (1000000u % tick_us == 0u) ? (int32_t)(1000000u / tick_us) : 0;
    *eb = slow_terms(p, o, i, adx, per_second(&t, adx, &flags), es, &g);
}

/* One leg: dx (m, Q24, |dx| < 2^31) over the tick; updates *phi, returns
 * the friction (N, Q8). The leg's constants kept by the state at its first
 * step (slip = sigma_0 / F_c, 1/m Q8; tau = sigma_1 / sigma_0, s Q30;
 * inv_vs = 2^46 / v_s) turn the law's divisions into products: at rest
 * (dx = 0) a leg returns its held phi; faster than 4 v_s it needs one
 * exp; slower, two exps and one 32-bit division (F_c / g, spi_recip). */
static sp_q8_t leg_step(const sp_platform_t *p, const sp_fric_obs_t *o, int i, sp_q8_t *phi, int64_t dx,
                        const fric_tick_t *t, sp_flags_t *flags)
{
    int32_t sigma0 = p->bristle_stiffness[i];
    sp_q24_t v;
    sp_q8_t viscous;
    int64_t adx, av, g, target, phi_new, dphi, damping = 0;
    sp_q30_t es; /* Stribeck fade exp(-(v/v_s)^2), Q30 */
    sp_q30_t eb; /* bristle relaxation exp(-sigma_0 |dx| / g), Q30 */
    if (dx == 0) {
        return (sigma0 == 0) ? 0 : *phi; /* at rest: the bristles hold, no viscous force */
    }
    v = per_second(t, dx, flags); /* m/s, Q24 */
    viscous = spi_narrow_floor((int64_t)p->viscous_friction[i] * v + (INT64_C(1) << 23), 24u, flags);
    if (sigma0 == 0) {
        *phi = 0;
        return viscous;
    }
    adx = dx < 0 ? -dx : dx;
    av = v < 0 ? -(int64_t)v : (int64_t)v;
    eb = slow_terms(p, o, i, adx, av, &es, &g);
    target = dx > 0 ? g : -g;
    /* exact relaxation towards s g: a convex combination, |phi_new| <= max(|phi|, g) */
    phi_new = target + FRIC_Q30(((int64_t)*phi - target) * eb);
    dphi = phi_new - *phi;
    *phi = (sp_q8_t)phi_new;
    if (dphi != 0 && es != 0 && o->tau[i] != 0) {
        /* sigma_1 e dz/dt = e (dphi tau) / dt. dphi tau in N s, Q24 (|dphi|
         * held below 2^31, tau < 2^31: the product < 2^62, held below 2^40
         * after the shift), per second (x 10^6 at most: < 2^60), then Q8 */
        int64_t ns = clamp64((clamp64(dphi, INT32_MAX, flags) * o->tau[i]) >> 14, INT64_C(1) << 40, flags);
        int64_t per = (t->per_s != 0) ? ns * t->per_s : div_round(ns * 1000000, (int64_t)t->tick_us);
        damping = FRIC_Q30(clamp64(spi_round_away64(per, 16u), INT32_MAX, flags) * es);
    }
    return spi_sat(phi_new + damping + viscous, flags);
}

/* The step after the checks: p's parameters are those params_ok accepts. */
sp_status_t plain_fric_obs_run(const sp_platform_t *p, sp_fric_obs_t *o, const sp_q24_t length[SP_LEGS],
                               uint32_t tick_us, sp_q8_t friction[SP_LEGS])
{
    sp_flags_t flags = 0u;
    if (!o->valid) {
        for (int i = 0; i < SP_LEGS; ++i) {
            o->length[i] = length[i];
            friction[i] = 0;
            /* sigma_0 / F_c, 1/m, Q8 (sigma_0 Q0 x 2^16 / F_c Q8) */
            o->slip[i] = (p->bristle_stiffness[i] > 0)
                             ? sp_sat32(((int64_t)p->bristle_stiffness[i] << 16) / p->coulomb_friction[i], &flags)
                             : 0;
            /* sigma_1 / sigma_0, s, Q30: sigma_1 Q8 x 2^22 / sigma_0 Q0 */
            o->tau[i] = (p->bristle_stiffness[i] > 0)
                            ? sp_sat32(((int64_t)p->bristle_damping[i] << 22) / p->bristle_stiffness[i], &flags)
                            : 0;
        }
        /* 2^46 / v_s (v_s Q24 > 0 when any leg has bristles: params_ok) */
        o->inv_vs = (p->stribeck_velocity > 0) ? (INT64_C(1) << 46) / p->stribeck_velocity : 0;
        o->valid = 1u;
        return sp_flags_status(flags);
    }
    {
        fric_tick_t t;
        t.tick_us = tick_us;
        t.per_s = (1000000u % tick_us == 0u) ? (int32_t)(1000000u / tick_us) : 0;
        for (int i = 0; i < SP_LEGS; ++i) {
            int64_t dx = clamp64((int64_t)length[i] - o->length[i], INT32_MAX, &flags);
            o->length[i] = length[i];
            friction[i] = leg_step(p, o, i, &o->phi[i], dx, &t, &flags);
        }
    }
    return sp_flags_status(flags);
}
