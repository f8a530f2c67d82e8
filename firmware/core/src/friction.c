/* friction.c - friction observer (sp/friction.h). */
#include "sp/friction.h"

#include <stddef.h>

/* ln 2 in Q24 and Q30, rounded to nearest */
#define FRIC_LN2_Q24 11629080
#define FRIC_LN2_Q30 INT64_C(744261118)
/* exp(-u) < 2^-31 (half an LSB of Q30) beyond 31 ln 2 */
#define FRIC_EXP_K_MAX 31
/* (-1)^k / k! in Q30, k = 0..7, rounded to nearest: on [0, ln 2) the
 * Taylor remainder is below (ln 2)^8 / 8! = 1.3e-6 */
#define FRIC_EXP_DEGREE 7
static const int32_t fric_exp_coef[FRIC_EXP_DEGREE + 1] = {1073741824, -1073741824, 536870912, -178956971,
                                                           44739243,   -8947849,    1491308,   -213044};
/* |v| / v_s at and beyond which exp(-(v/v_s)^2) is taken as 0 (exp(-64) = 1.6e-28) */
#define FRIC_STRIBECK_RATIO_MAX 8
/* sigma_0 |dx| / g at and beyond which exp(-a) is taken as 0 (exp(-32) = 1.3e-14) */
#define FRIC_BRISTLE_A_MAX 32
/* largest |bristle deflection step| carried into the damping term, Q36 m (64 m) */
#define FRIC_DZ_MAX_Q36 (INT64_C(1) << 42)

sp_q30_t sp_fric_exp_neg(sp_q24_t u)
{
    int32_t k;
    int64_t r, acc;
    if (u <= 0) {
        return SP_Q30_ONE;
    }
    k = u / FRIC_LN2_Q24;
    if (k >= FRIC_EXP_K_MAX) {
        return 0;
    }
    /* r = u - k ln2 in Q30: within a few LSB of [0, ln 2) (the two ln 2
     * roundings differ), where the polynomial is as good */
    r = (int64_t)u * 64 - (int64_t)k * FRIC_LN2_Q30;
    acc = fric_exp_coef[FRIC_EXP_DEGREE];
    for (int n = FRIC_EXP_DEGREE - 1; n >= 0; --n) {
        /* |acc| <= 2^30 + 2^29 and 0 <= r < 2^30: the product fits */
        acc = fric_exp_coef[n] + ((acc * r + (INT64_C(1) << 29)) >> 30);
    }
    /* acc is in (0, 1 + 2^-24]: the shift by k keeps it in Q30's range */
    acc = sp_rshift_round(acc, (unsigned)k);
    return (sp_q30_t)(acc > SP_Q30_ONE ? SP_Q30_ONE : acc);
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
        return sp_sat32(d * t->per_s, flags);
    }
    return sp_sat32(div_round(d * 1000000, (int64_t)t->tick_us), flags);
}

/* One leg: dx (m, Q24, |dx| < 2^31) over the tick; updates *phi, returns
 * the friction (N, Q8). slip: sigma_0 / F_c (1/m, Q8), cached by the
 * state. The common cases take no division: at rest (dx = 0: nothing but
 * the held phi) and sliding faster than 8 v_s (no Stribeck excess, g = F_c,
 * a = slip |dx|, no bristle damping); between them, the full law. */
static sp_q8_t leg_step(const sp_platform_t *p, int i, int32_t slip, sp_q8_t *phi, int64_t dx, const fric_tick_t *t,
                        sp_flags_t *flags)
{
    int32_t sigma0 = p->bristle_stiffness[i];
    sp_q24_t v;
    sp_q8_t viscous;
    int64_t adx, av, g, target, phi_new, dphi, damping = 0;
    sp_q30_t es = 0; /* Stribeck fade exp(-(v/v_s)^2), Q30 */
    sp_q30_t eb;     /* bristle relaxation exp(-sigma_0 |dx| / g), Q30 */
    if (dx == 0) {
        return (sigma0 == 0) ? 0 : *phi; /* at rest: the bristles hold, no viscous force */
    }
    v = per_second(t, dx, flags); /* m/s, Q24 */
    viscous = sp_mul(p->viscous_friction[i], v, 24u, flags);
    if (sigma0 == 0) {
        *phi = 0;
        return viscous;
    }
    adx = dx < 0 ? -dx : dx;
    av = v < 0 ? -(int64_t)v : (int64_t)v;
    if (av < (int64_t)FRIC_STRIBECK_RATIO_MAX * p->stribeck_velocity) {
        /* ratio < 8 fits Q24; its square < 64 too */
        sp_q24_t ratio = sp_div(av, p->stribeck_velocity, 24u, flags);
        es = sp_fric_exp_neg(sp_mul_q24(ratio, ratio, flags));
    }
    if (es == 0) {
        /* g = F_c: a = (sigma_0 / F_c) |dx| in Q24 (slip Q8 x |dx| Q24 >> 8) */
        int64_t a = (slip * adx) >> 8;
        g = p->coulomb_friction[i];
        eb = (a >= (int64_t)FRIC_BRISTLE_A_MAX << 24) ? 0 : sp_fric_exp_neg((sp_q24_t)a);
    } else {
        /* g = F_c + (F_s - F_c) e, N, Q8: in [F_c, F_s]; a = sigma_0 |dx| / g */
        int64_t load = (int64_t)sigma0 * adx; /* N, Q24 (< 2^62) */
        g = (int64_t)p->coulomb_friction[i] +
            sp_rshift_round(((int64_t)p->breakaway_friction[i] - p->coulomb_friction[i]) * es, 30u);
        eb = (load >= (int64_t)FRIC_BRISTLE_A_MAX * g * (INT64_C(1) << 16))
                 ? 0
                 : sp_fric_exp_neg(sp_div(load, (int32_t)g, 8u, flags));
    }
    target = dx > 0 ? g : -g;
    /* exact relaxation towards s g: a convex combination, |phi_new| <= max(|phi|, g) */
    phi_new = target + sp_rshift_round(((int64_t)*phi - target) * eb, 30u);
    dphi = phi_new - *phi;
    *phi = (sp_q8_t)phi_new;
    if (dphi != 0 && es != 0 && p->bristle_damping[i] != 0) {
        /* sigma_1 e dz/dt with dz = dphi / sigma_0: dz in Q36 m, dz/dt in Q24 m/s */
        sp_q8_t k = (sp_q8_t)sp_rshift_round((int64_t)p->bristle_damping[i] * es, 30u);
        int64_t dz = clamp64(div_round(dphi * (INT64_C(1) << 28), sigma0), FRIC_DZ_MAX_Q36, flags);
        /* dz / dt in Q36 (|dz| <= 2^42, x 10^6 < 2^62), then Q24 */
        int64_t zdot36 = (t->per_s != 0) ? dz * t->per_s : div_round(dz * 1000000, (int64_t)t->tick_us);
        sp_q24_t zdot = sp_sat32(sp_rshift_round(zdot36, 12u), flags);
        damping = sp_mul(k, zdot, 24u, flags);
    }
    return sp_sat32(phi_new + damping + viscous, flags);
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
    }
    o->valid = 0u;
}

sp_status_t sp_fric_obs_step(const sp_platform_t *p, sp_fric_obs_t *o, const sp_q24_t length[SP_LEGS], uint32_t tick_us,
                             sp_q8_t friction[SP_LEGS])
{
    sp_flags_t flags = 0u;
    if (p == NULL || o == NULL || length == NULL || friction == NULL || tick_us == 0u ||
        tick_us > SP_FRIC_TICK_MAX_US || !params_ok(p)) {
        return SP_E_ARG;
    }
    if (!o->valid) {
        for (int i = 0; i < SP_LEGS; ++i) {
            o->length[i] = length[i];
            friction[i] = 0;
            /* sigma_0 / F_c, 1/m, Q8 (sigma_0 Q0 x 2^16 / F_c Q8) */
            o->slip[i] = (p->bristle_stiffness[i] > 0)
                             ? sp_sat32(((int64_t)p->bristle_stiffness[i] << 16) / p->coulomb_friction[i], &flags)
                             : 0;
        }
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
            friction[i] = leg_step(p, i, o->slip[i], &o->phi[i], dx, &t, &flags);
        }
    }
    return sp_flags_status(flags);
}
