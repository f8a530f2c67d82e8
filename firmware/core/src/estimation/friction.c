/* SPDX-License-Identifier: Apache-2.0 */
/* friction.c - friction observer (sp/estimation/friction.h). */
#include "sp/estimation/friction.h"

#include "estimation/estimation_internal.h"
#include "math/fixed_inline.h"

#include <stddef.h>

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
/* |dphi| (N, Q8) below which the damping term's clamps cannot act: 2^23
 * (32,768 N) */
#define FRIC_DPHI_SMALL (INT64_C(1) << 23)

/* sp_fric_exp_neg's body, inline in the leg step (its two calls a leg
 * are most of a moving tick's exps: no call, no saved registers). */
SPI_INLINE sp_q30_t fric_exp_neg(sp_q24_t u)
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
    /* acc is in (0, 1]: the shift by k keeps it in Q30's range, and acc +
     * 2^(k-1) <= 2^30 + 2^29 + a few LSB fits 32 unsigned bits */
    if (k > 0u) {
        acc = (int32_t)(((uint32_t)acc + (1u << (k - 1u))) >> k);
    }
    return (acc > SP_Q30_ONE) ? SP_Q30_ONE : acc;
}

sp_q30_t sp_fric_exp_neg(sp_q24_t u)
{
    return fric_exp_neg(u);
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

static int params_ok(const sp_platform_t *p)
{
    for (int i = 0; i < SP_LEGS; ++i) {
        if (p->bristle_stiffness[i] < 0 || p->bristle_damping[i] < 0 || p->viscous_friction[i] < 0) {
            return 0;
        }
        if (p->bristle_stiffness[i] > 0 &&
            (p->coulomb_friction[i] <= 0 || p->breakaway_friction[i] < p->coulomb_friction[i] ||
             p->stribeck_velocity <= 0)) {
            return 0;
        }
    }
    return 1;
}

/* What one tick needs besides the platform, the same for every leg: the
 * tick and its rate multiplier (1e6 / tick_us when that is a whole number,
 * else 0: divide), once a tick rather than once a leg. */
typedef struct {
    uint32_t tick_us;
    int32_t per_s; /* ticks per second when exact, else 0 */
    int64_t fast;  /* 4 v_s, m/s Q24: from this speed on a leg slides at F_c */
    int32_t small; /* |dx| below which |v| < 2^24 (16 m/s) at an exact tick, else 0 */
} fric_tick_t;

static void fric_tick_init(fric_tick_t *t, const sp_platform_t *p, uint32_t tick_us)
{
    t->tick_us = tick_us;
    t->per_s = (1000000u % tick_us == 0u) ? (int32_t)(1000000u / tick_us) : 0;
    t->fast = (int64_t)FRIC_STRIBECK_RATIO_MAX * p->stribeck_velocity;
    t->small = (t->per_s != 0) ? (int32_t)((UINT32_C(1) << 24) / (uint32_t)t->per_s) : 0;
}

/* d / dt for d in Q24: Q24 per second, saturated. */
SPI_INLINE sp_q24_t per_second(const fric_tick_t *t, int32_t d, sp_flags_t *flags)
{
    if (t->per_s != 0) {
        return spi_sat((int64_t)d * t->per_s, flags);
    }
    return spi_sat(div_round((int64_t)d * 1000000, (int64_t)t->tick_us), flags);
}

/* round(x / 2^30) of a product below 2^62 in magnitude */
#define FRIC_Q30(x) (((x) + (INT64_C(1) << 29)) >> 30)

/* The Stribeck fade e = exp(-(v/v_s)^2), Q30, of a speed av = |v| below
 * 4 v_s (m/s, Q24) with inv_vs = 2^46 / v_s. (v / v_s)^2 in Q24: av <
 * 4 v_s < 2^31 and inv_vs < 2^46 / v_s give a ratio below 8 (2^27 in
 * Q24) and a square below 2^54; e is then above exp(-16), never 0. */
SPI_INLINE sp_q30_t fric_fade(int64_t av, int64_t inv_vs)
{
    int32_t ratio = (int32_t)((av * inv_vs) >> 22);
    return fric_exp_neg((sp_q24_t)(((int64_t)ratio * ratio + (INT64_C(1) << 23)) >> 24));
}

/* The Stribeck level g = F_c + (F_s - F_c) e in [F_c, F_s], N Q8
 * (0 <= F_s - F_c < 2^31). */
SPI_INLINE int64_t fric_level(int32_t fc, int32_t fs, sp_q30_t es)
{
    return fc + FRIC_Q30((int64_t)(fs - fc) * es);
}

/* The bristle relaxation exp(-sigma_0 |dx| / g), Q30, below 4 v_s: a =
 * (sigma_0 / F_c) |dx| (Q24, a at g = F_c) scaled by F_c / g. */
SPI_INLINE sp_q30_t fric_relax_slow(int64_t a, int32_t fc, int64_t g)
{
    if (a < ((int64_t)FRIC_BRISTLE_A_MAX << 24)) {
        /* F_c / g = F_c inv / 2^sh (the normalised reciprocal: one
         * 32-bit division, relative error below 2^-28), Q30. F_c <= g
         * normalised as g (shifted by clz(g) = 62 - sh) stays below
         * 2^32: the high word of its product with inv is exactly
         * (F_c inv) >> (sh - 30), at most 2^30 */
        unsigned sh;
        int32_t inv = spi_recip((uint32_t)g, &sh);
        uint32_t fc_norm = (uint32_t)fc << (62u - sh);
        int32_t scale = (int32_t)(((uint64_t)fc_norm * (uint32_t)inv) >> 32);
        /* a < 2^29 here: a 32 x 32-bit product */
        a = FRIC_Q30((int64_t)(int32_t)a * scale);
    }
    return (a >= ((int64_t)FRIC_BRISTLE_A_MAX << 24)) ? 0 : fric_exp_neg((sp_q24_t)a);
}

/* The bristle force phi relaxed towards target = s F_c by exp(-a), a =
 * (sigma_0 / F_c) |dx| (slip 1/m Q8, adx = |dx| m Q24; N Q8): a leg
 * sliding faster than 4 v_s. Once there, phi is at or within 1 LSB of
 * its level: at it, it stays (no a needed); next to it, round(d exp(-a))
 * for d = phi - target = +-1 is d while exp(-a) is above 1/2, that is
 * a < ln 2, and 0 beyond (fric_exp_neg is above 2^29 exactly on
 * [0, FRIC_LN2_Q24): tests/unit/test_friction.c checks every u below
 * 2 ln 2, and beyond that it is a quarter at most). Such a leg takes no
 * exp. */
SPI_INLINE int64_t fric_slide(int64_t phi, int64_t target, int32_t slip, int32_t adx)
{
    int64_t d = phi - target;
    int64_t a; /* (sigma_0 / F_c) |dx|, Q24 (slip Q8 x |dx| Q24 >> 8) */
    sp_q30_t eb;
    if (d == 0) {
        return phi;
    }
    a = ((int64_t)slip * adx) >> 8;
    if (d >= -1 && d <= 1) {
        return (a < FRIC_LN2_Q24) ? phi : target;
    }
    eb = (a >= ((int64_t)FRIC_BRISTLE_A_MAX << 24)) ? 0 : fric_exp_neg((sp_q24_t)a);
    return target + FRIC_Q30(d * eb);
}

/* One leg: dx (m, Q24, |dx| < 2^31) over the tick; updates *phi, returns
 * the friction (N, Q8). The leg's constants kept by the state at its first
 * step (slip = sigma_0 / F_c, 1/m Q8; tau = sigma_1 / sigma_0, s Q30;
 * inv_vs = 2^46 / v_s) turn the law's divisions into products: at rest
 * (dx = 0) a leg returns its held phi; faster than 4 v_s it needs one
 * exp, none once its phi is within 1 LSB of F_c (fric_slide); slower,
 * two exps and one 32-bit division (F_c / g, spi_recip), or, for a leg
 * of the table's (tab non-NULL: its tick and platform are this step's)
 * and |dx| within it, the table's fade and relaxation (no exp). Below
 * 16 m/s at a tick that divides a second (t->small) the speed and the
 * viscous force take no saturation. */
static sp_q8_t leg_step(const sp_platform_t *p, sp_fric_obs_t *o, const sp_fric_table_t *tab, int i, sp_q8_t *phi,
                        int32_t dx, const fric_tick_t *t, sp_flags_t *flags)
{
    int32_t sigma0 = p->bristle_stiffness[i];
    int32_t fc = p->coulomb_friction[i];
    sp_q24_t v;
    sp_q8_t viscous;
    int32_t adx; /* |dx| <= INT32_MAX (run clamps dx to +-INT32_MAX) */
    int64_t av, g, target, phi_new, dphi, damping = 0;
    sp_q30_t es = 0; /* Stribeck fade exp(-(v/v_s)^2), Q30 */
    sp_q30_t eb;     /* bristle relaxation exp(-sigma_0 |dx| / g), Q30 */
    if (dx == 0) {
        return (sigma0 == 0) ? 0 : *phi; /* at rest: the bristles hold, no viscous force */
    }
    adx = dx < 0 ? -dx : dx;
    if (adx < t->small) {
        /* the common case, in 32 bits: |v| < 2^24 needs no saturation,
         * nor does c_v v (c_v < 2^31: below 2^55) in Q8 */
        v = dx * t->per_s;
        viscous = (sp_q8_t)(((int64_t)p->viscous_friction[i] * v + (INT64_C(1) << 23)) >> 24);
    } else {
        v = per_second(t, dx, flags); /* m/s, Q24 */
        viscous = spi_narrow_floor((int64_t)p->viscous_friction[i] * v + (INT64_C(1) << 23), 24u, flags);
    }
    if (sigma0 == 0) {
        *phi = 0;
        return viscous;
    }
    av = v < 0 ? -(int64_t)v : (int64_t)v;
    if (tab != NULL && (uint32_t)adx <= tab->count && (((unsigned)tab->legs >> i) & 1u) != 0u) {
        /* below 4 v_s (the table's entries are): the lines below with
         * fric_fade's and fric_relax_slow's values prepared at init */
        es = tab->fade[adx - 1];
        g = fric_level(fc, p->breakaway_friction[i], es);
        eb = tab->relax[adx - 1];
    } else {
        if (av < t->fast) {
            es = fric_fade(av, o->inv_vs);
            g = fric_level(fc, p->breakaway_friction[i], es);
            /* a at g = F_c: (sigma_0 / F_c) |dx|, Q24 (slip Q8 x |dx| Q24 >> 8) */
            eb = fric_relax_slow(((int64_t)o->slip[i] * adx) >> 8, fc, g);
        } else {
            /* faster than 4 v_s: g = F_c, no damping (es = 0) */
            phi_new = fric_slide(*phi, dx > 0 ? fc : -fc, o->slip[i], adx);
            *phi = (sp_q8_t)phi_new;
            return spi_sat(phi_new + viscous, flags);
        }
    }
    target = dx > 0 ? g : -g;
    /* exact relaxation towards s g: a convex combination, |phi_new| <= max(|phi|, g) */
    phi_new = target + FRIC_Q30(((int64_t)*phi - target) * eb);
    dphi = phi_new - *phi;
    *phi = (sp_q8_t)phi_new;
    if (dphi != 0 && es != 0 && o->tau[i] != 0) {
        /* sigma_1 e dz/dt = e (dphi tau) / dt. dphi tau in N s, Q24 (|dphi|
         * held below 2^31, tau < 2^31: the product < 2^62, held below 2^40
         * after the shift), per second (x 10^6 at most: < 2^60), then Q8 */
        int64_t ns, per;
        if (dphi > -FRIC_DPHI_SMALL && dphi < FRIC_DPHI_SMALL) {
            /* the common case (|dphi| <= 2 F_s for a leg within the law's
             * bound): |dphi tau| < 2^54, so ns is within 2^40 without
             * the clamps (which would not act): one 32 x 32-bit product */
            ns = ((int64_t)(int32_t)dphi * o->tau[i]) >> 14;
        } else {
            ns = clamp64((clamp64(dphi, INT32_MAX, flags) * o->tau[i]) >> 14, INT64_C(1) << 40, flags);
        }
        per = (t->per_s != 0) ? ns * t->per_s : div_round(ns * 1000000, (int64_t)t->tick_us);
        damping = FRIC_Q30(clamp64(spi_round_away64(per, 16u), INT32_MAX, flags) * es);
    }
    return spi_sat(phi_new + damping + viscous, flags);
}

void sp_fric_obs_reset(sp_fric_obs_t *o)
{
    if (o == NULL) {
        return;
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        o->phi[i] = 0;
        o->length[i] = 0;
        o->slip[i] = 0;
        o->tau[i] = 0;
    }
    o->inv_vs = 0;
    o->valid = 0u;
}

/* The step after the checks: p's parameters are those params_ok accepts. */
static sp_status_t fric_obs_run(const sp_platform_t *p, sp_fric_obs_t *o, const sp_fric_table_t *tab,
                                const sp_q24_t length[SP_LEGS], uint32_t tick_us, sp_q8_t friction[SP_LEGS])
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
        fric_tick_init(&t, p, tick_us);
        if (tab != NULL && (tab->tick_us != tick_us || tab->inv_vs != o->inv_vs)) {
            tab = NULL; /* prepared for another tick or Stribeck velocity */
        }
        for (int i = 0; i < SP_LEGS; ++i) {
            int32_t dx = (int32_t)clamp64((int64_t)length[i] - o->length[i], INT32_MAX, &flags);
            o->length[i] = length[i];
            friction[i] = leg_step(p, o, tab, i, &o->phi[i], dx, &t, &flags);
        }
    }
    return sp_flags_status(flags);
}

sp_status_t sp_fric_obs_check(const sp_platform_t *p)
{
    return (p != NULL && params_ok(p)) ? SP_OK : SP_E_ARG;
}

sp_status_t sp_fric_obs_step(const sp_platform_t *p, sp_fric_obs_t *o, const sp_q24_t length[SP_LEGS], uint32_t tick_us,
                             sp_q8_t friction[SP_LEGS])
{
    if (p == NULL || o == NULL || length == NULL || friction == NULL || tick_us == 0u ||
        tick_us > SP_FRIC_TICK_MAX_US || !params_ok(p)) {
        return SP_E_ARG;
    }
    return fric_obs_run(p, o, NULL, length, tick_us, friction);
}

sp_status_t sp_fric_obs_step_table(const sp_platform_t *p, sp_fric_obs_t *o, const sp_fric_table_t *tab,
                                   const sp_q24_t length[SP_LEGS], uint32_t tick_us, sp_q8_t friction[SP_LEGS])
{
    if (p == NULL || o == NULL || length == NULL || friction == NULL || tick_us == 0u ||
        tick_us > SP_FRIC_TICK_MAX_US || !params_ok(p)) {
        return SP_E_ARG;
    }
    return fric_obs_run(p, o, tab, length, tick_us, friction);
}

sp_status_t spi_fric_obs_step_checked(const sp_platform_t *p, sp_fric_obs_t *o, const sp_fric_table_t *tab,
                                      const sp_q24_t length[SP_LEGS], uint32_t tick_us, sp_q8_t friction[SP_LEGS])
{
    if (p == NULL || o == NULL || length == NULL || friction == NULL || tick_us == 0u ||
        tick_us > SP_FRIC_TICK_MAX_US) {
        return SP_E_ARG;
    }
    return fric_obs_run(p, o, tab, length, tick_us, friction);
}

sp_status_t sp_fric_table_prepare(const sp_platform_t *p, uint32_t tick_us, sp_fric_table_t *tab)
{
    sp_flags_t flags = 0u;
    fric_tick_t t;
    int c = -1;
    int32_t sigma0, fc, fs, slip;
    uint32_t n;
    if (tab == NULL) {
        return SP_E_ARG;
    }
    tab->count = 0u;
    tab->legs = 0u;
    tab->tick_us = tick_us;
    tab->inv_vs = 0;
    if (p == NULL || tick_us == 0u || tick_us > SP_FRIC_TICK_MAX_US || !params_ok(p)) {
        return SP_E_ARG;
    }
    for (int i = SP_LEGS - 1; i >= 0; --i) {
        if (p->bristle_stiffness[i] > 0) {
            c = i; /* the first leg with bristles */
        }
    }
    if (c < 0) {
        return SP_OK; /* no bristles: nothing to tabulate */
    }
    sigma0 = p->bristle_stiffness[c];
    fc = p->coulomb_friction[c];
    fs = p->breakaway_friction[c];
    for (int i = 0; i < SP_LEGS; ++i) {
        if (p->bristle_stiffness[i] == sigma0 && p->coulomb_friction[i] == fc && p->breakaway_friction[i] == fs) {
            tab->legs = (uint8_t)(tab->legs | (1u << i));
        }
    }
    /* the constants as the observer's first step keeps them */
    slip = sp_sat32(((int64_t)sigma0 << 16) / fc, &flags);
    tab->inv_vs = (INT64_C(1) << 46) / p->stribeck_velocity;
    fric_tick_init(&t, p, tick_us);
    /* |v| grows with |dx|: the entries below 4 v_s are the first ones */
    for (n = 1u; n <= SP_FRIC_TABLE_LEN; ++n) {
        sp_q24_t v = per_second(&t, (int32_t)n, &flags); /* n x 10^6 < 2^31: exact */
        if ((int64_t)v >= t.fast) {
            break;
        }
        sp_q30_t es = fric_fade(v, tab->inv_vs);
        tab->fade[n - 1u] = es;
        tab->relax[n - 1u] = fric_relax_slow(((int64_t)slip * (int32_t)n) >> 8, fc, fric_level(fc, fs, es));
    }
    tab->count = (uint16_t)(n - 1u);
    return SP_OK;
}
