/* SPDX-License-Identifier: Apache-2.0 */
/*
 * admittance_plain.c - the plain reference of sp/force/admittance.h (see
 * admittance_plain.h). The code of the first version, unchanged but for the
 * names.
 */
#include "admittance_plain.h"

#include <stddef.h>

/* y + round(alpha (x - y)), ties up (the wrench filter's section). */
static int32_t plain_section(int32_t y, int32_t x, sp_q30_t alpha)
{
    return (int32_t)(y + (((int64_t)alpha * ((int64_t)x - y) + (INT64_C(1) << 29)) >> 30));
}

#define WRENCH_MAX (INT64_C(1) << 30) /* the wrench sum is held within +-2^30 Q8 */
#define TICK_MAX_US 2000u             /* c_f (Q38) and dt (Q38) fit int32 up to here */

static int32_t clamp32(int64_t v, int32_t lo, int32_t hi)
{
    return (v < lo) ? lo : ((v > hi) ? hi : (int32_t)v);
}

static int64_t clamp64(int64_t v, int64_t lim)
{
    return (v < -lim) ? -lim : ((v > lim) ? lim : v);
}

/* The coefficients of the law for mass M (Q16), damping D and stiffness K
 * (N s/m, N/m) at tick dt_us. */
static sp_status_t coefficients(sp_q16_t mass, int32_t damping, int32_t stiffness, uint32_t tick_us, sp_admit_coef_t *c)
{
    sp_flags_t flags = 0u;
    /* den = M + dt D, kg, Q12 */
    int64_t den = (int64_t)(mass >> 4) + sp_div64((int64_t)damping * tick_us, 1000000, 12u, &flags);
    if (flags != 0u || den <= 0 || den > INT32_MAX) {
        return SP_E_OVERFLOW;
    }
    /* c_v = M / den, Q30 (Q16 / Q12 -> Q4, 26 more bits) */
    sp_q30_t c_v = sp_div((int64_t)mass, (int32_t)den, 26u, &flags);
    /* c_f = dt / den, Q38: dt_us 2^50 / (10^6 den_q12) */
    int32_t c_f = sp_div(sp_div64((int64_t)tick_us, 1000000, 50u, &flags), (int32_t)den, 0u, &flags);
    /* c_k = dt K / den, 1/s, Q16: dt_us K 2^28 / (10^6 den_q12) */
    int64_t k = sp_div64((int64_t)tick_us * stiffness, (int32_t)den, 28u, &flags);
    int32_t c_k = sp_sat32((k + 500000) / 1000000, &flags);
    if (flags != 0u) {
        return SP_E_OVERFLOW;
    }
    c->damping = damping;
    c->c_v = c_v;
    c->c_f = c_f;
    c->c_k = c_k;
    return SP_OK;
}

/* The critically damped return's damping, 2 sqrt(K M), N s/m. */
static int32_t release_damping(const sp_admit_axis_t *ax)
{
    uint64_t km = (uint64_t)(uint32_t)ax->release_stiffness * (uint32_t)ax->mass; /* Q16 */
    uint64_t d = ((uint64_t)sp_isqrt64(km) * 2u + 128u) >> 8;                     /* Q8 -> N s/m */
    return (d > INT32_MAX) ? INT32_MAX : ((d < 1u) ? 1 : (int32_t)d);
}

static int axis_ok(const sp_admit_axis_t *ax)
{
    return ax->mass >= SP_Q16_ONE && ax->damping >= 1 && ax->stiffness >= 0 && ax->release_stiffness >= 1 &&
           ax->v_max > 0 && ax->a_brake > 0;
}

sp_status_t plain_admit_configure(const sp_admit_config_t *cfg, plain_admit_t *st)
{
    if (cfg == NULL || st == NULL || cfg->crossover <= 0 || cfg->k_min < 1 || cfg->k_max < cfg->k_min ||
        cfg->secant_force <= 0 || cfg->secant_travel <= 0 || cfg->filter_alpha <= 0 || cfg->filter_alpha > SP_Q30_ONE ||
        cfg->tick_us < 100u || cfg->tick_us > TICK_MAX_US) {
        return SP_E_ARG;
    }
    plain_admit_t fresh;
    for (unsigned k = 0; k < SP_AXES; ++k) {
        const sp_admit_axis_t *ax = &cfg->axis[k];
        plain_axis_state_t *s = &fresh.axis[k];
        if (!axis_ok(ax)) {
            return SP_E_ARG;
        }
        sp_status_t a = coefficients(ax->mass, ax->damping, ax->stiffness, cfg->tick_us, &s->coef);
        sp_status_t b = coefficients(ax->mass, release_damping(ax), ax->release_stiffness, cfg->tick_us, &s->rel);
        if (a != SP_OK || b != SP_OK) {
            return SP_E_OVERFLOW;
        }
        s->d = 0;
        s->v = 0;
        s->a = 0;
        for (unsigned n = 0; n < 4u; ++n) {
            s->x_f[n] = 0;
        }
        s->x_contact = 0;
        s->w_contact = 0;
        s->k_hat = 0;
        s->in_contact = 0u;
    }
    fresh.primed = 0u;
    *st = fresh;
    return SP_OK;
}

/* The damping an axis in contact should use: the secant stiffness of the
 * filtered wrench against the filtered pose since contact, over w_c;
 * 0 while the secant is not yet trusted. */
static int32_t contact_damping(const sp_admit_config_t *cfg, plain_axis_state_t *s, sp_q8_t w)
{
    int64_t dx = (int64_t)s->x_f[3] - s->x_contact;
    int64_t dw = (int64_t)w - s->w_contact;
    int64_t adx = (dx < 0) ? -dx : dx;
    int64_t adw = (dw < 0) ? -dw : dw;
    /* the world pushes back: the wrench changes against the travel */
    if (adx < cfg->secant_travel || adw < cfg->secant_force || (dx > 0) == (dw > 0)) {
        return 0;
    }
    sp_flags_t flags = 0u;
    int32_t k = sp_div(adw, (int32_t)clamp64(adx, INT32_MAX), 16u, &flags); /* Q8 / Q24 -> N/m */
    k = (k < cfg->k_min) ? cfg->k_min : ((k > cfg->k_max) ? cfg->k_max : k);
    s->k_hat = k;
    int32_t d = sp_div((int64_t)k, cfg->crossover, 16u, &flags); /* (N/m) / (rad/s, Q16) */
    return (d < 1) ? 1 : d;
}

/* Holds v towards the bounds: v_max, then the braking speed sqrt(2 a dist). */
static int32_t limit_velocity(const sp_admit_axis_t *ax, int64_t v, sp_q24_t d, sp_q24_t lo, sp_q24_t hi,
                              uint32_t tick_us, int *limited)
{
    int64_t lim = ax->v_max;
    if (v > lim || v < -lim) {
        v = (v > 0) ? lim : -lim;
        *limited = 1;
    }
    int64_t dist = (v > 0) ? ((int64_t)hi - d) : ((int64_t)d - lo);
    if (v != 0) {
        if (dist <= 0) {
            *limited = 1;
            return 0;
        }
        uint64_t dist_c = (dist > INT32_MAX) ? (uint64_t)INT32_MAX : (uint64_t)dist;
        uint64_t brake2 = 2u * (uint64_t)(uint32_t)ax->a_brake * dist_c; /* Q48 (m/s)^2 */
        uint64_t av = (uint64_t)((v < 0) ? -v : v);
        if (av * av > brake2) {
            int64_t vb = (int64_t)sp_isqrt64(brake2); /* Q24 */
            v = (v > 0) ? vb : -vb;
            *limited = 1;
        }
        uint64_t vt = dist_c * SP_ADMIT_TAIL_RATE + 1000000u / tick_us;
        if ((uint64_t)((v < 0) ? -v : v) > vt) {
            v = (v > 0) ? (int64_t)vt : -(int64_t)vt;
            *limited = 1;
        }
    }
    return (int32_t)v;
}

sp_status_t plain_admit_step(const sp_admit_config_t *cfg, plain_admit_t *st, sp_admit_mode_t mode, uint8_t mask,
                             const sp_q8_t w_ext[SP_AXES], const sp_q8_t w_target[SP_AXES],
                             const sp_q24_t x_meas[SP_AXES], uint8_t contact, const sp_q24_t lo[SP_AXES],
                             const sp_q24_t hi[SP_AXES], sp_admit_report_t *report)
{
    if (cfg == NULL || st == NULL || w_ext == NULL || w_target == NULL || lo == NULL || hi == NULL ||
        (mode != SP_ADMIT_FORCE && mode != SP_ADMIT_RELEASE && mode != SP_ADMIT_HOLD)) {
        return SP_E_ARG;
    }
    sp_status_t status = SP_OK;
    sp_admit_report_t rep = {0u, 0u};
    const int64_t dt_q38 = ((int64_t)cfg->tick_us << 38) / 1000000;
    const int64_t rate_q16 = (INT64_C(1000000) << 16) / cfg->tick_us;
    for (unsigned k = 0; k < SP_AXES; ++k) {
        const sp_admit_axis_t *ax = &cfg->axis[k];
        plain_axis_state_t *s = &st->axis[k];
        const uint8_t bit = (uint8_t)(1u << k);
        const int forced = mode == SP_ADMIT_FORCE && (mask & bit) != 0u;

        if (x_meas != NULL) {
            for (unsigned n = 0; n < 4u; ++n) {
                int32_t in = (n == 0u) ? x_meas[k] : s->x_f[n - 1u];
                s->x_f[n] = st->primed ? plain_section(s->x_f[n], in, cfg->filter_alpha) : in;
            }
        }
        /* the damping this axis should use */
        int32_t damping = ax->damping;
        if (forced && (contact & bit) != 0u) {
            if (!s->in_contact) {
                s->in_contact = 1u;
                s->x_contact = s->x_f[3];
                s->w_contact = w_ext[k];
                s->k_hat = 0;
            }
            int32_t dc = (x_meas != NULL) ? contact_damping(cfg, s, w_ext[k]) : 0;
            damping = (dc > 0) ? dc : ((s->k_hat > 0) ? s->coef.damping : ax->damping);
        } else {
            s->in_contact = 0u;
            s->k_hat = 0;
        }
        if (forced) {
            int32_t diff = damping - s->coef.damping;
            int32_t tol = s->coef.damping / 16;
            if (diff > tol || diff < -tol || (damping == ax->damping && s->coef.damping != ax->damping)) {
                sp_admit_coef_t c;
                if (coefficients(ax->mass, damping, ax->stiffness, cfg->tick_us, &c) == SP_OK) {
                    s->coef = c;
                    rep.adapted |= bit;
                } else {
                    status = SP_E_OVERFLOW;
                }
            }
        }
        int64_t v;
        if (mode == SP_ADMIT_HOLD) {
            /* brake: |v| falls by a_brake dt each tick, never through zero */
            int64_t dv = ((int64_t)ax->a_brake * cfg->tick_us + 500000) / 1000000;
            v = (s->v > dv) ? s->v - dv : ((s->v < -dv) ? s->v + dv : 0);
        } else {
            const sp_admit_coef_t *c = forced ? &s->coef : &s->rel;
            int64_t f = forced ? clamp64((int64_t)w_ext[k] + w_target[k], WRENCH_MAX) : 0;
            v = (((int64_t)c->c_v * s->v + (INT64_C(1) << 29)) >> 30) +
                (((int64_t)c->c_f * f + (INT64_C(1) << 21)) >> 22) -
                (((int64_t)c->c_k * s->d + (INT64_C(1) << 15)) >> 16);
        }
        int limited = 0;
        if (forced) {
            /* the acceleration held to a_brake */
            int64_t dv = ((int64_t)ax->a_brake * cfg->tick_us + 500000) / 1000000;
            if (v > s->v + dv) {
                v = s->v + dv;
                limited = 1;
            } else if (v < s->v - dv) {
                v = s->v - dv;
                limited = 1;
            }
        }
        sp_q24_t lo_k = (lo[k] > 0) ? 0 : lo[k];
        sp_q24_t hi_k = (hi[k] < 0) ? 0 : hi[k];
        int32_t v_new = limit_velocity(ax, v, s->d, lo_k, hi_k, cfg->tick_us, &limited);
        int64_t d = (int64_t)s->d + (((int64_t)v_new * dt_q38 + (INT64_C(1) << 37)) >> 38);
        if (d > hi_k || d < lo_k) {
            d = (d > hi_k) ? hi_k : lo_k;
            limited = 1;
        }
        s->a = clamp32((((int64_t)v_new - s->v) * rate_q16 + (INT64_C(1) << 15)) >> 16, INT32_MIN, INT32_MAX);
        s->v = v_new;
        s->d = (int32_t)d;
        if (limited) {
            rep.limited |= bit;
        }
    }
    if (x_meas != NULL) {
        st->primed = 1u;
    }
    if (report != NULL) {
        *report = rep;
    }
    return status;
}

uint32_t plain_contact_step(const sp_contact_config_t *cfg, sp_contact_t *st, const sp_q8_t w_ext[SP_AXES],
                            const sp_q8_t w_target[SP_AXES])
{
    if (cfg == NULL || st == NULL || w_ext == NULL || w_target == NULL) {
        return 0u;
    }
    uint32_t events = 0u;
    int64_t dot = 0, t2 = 0, f2 = 0;
    for (unsigned k = 0; k < 3u; ++k) {
        int64_t f = clamp64(w_ext[k], WRENCH_MAX);
        int64_t t = clamp64(w_target[k], WRENCH_MAX);
        dot -= f * t; /* the push-back times |F_target|, Q16 */
        t2 += t * t;
        f2 += f * f;
    }
    int64_t excess = cfg->excess;
    if (f2 > excess * excess) {
        events |= SP_CONTACT_EXCESS;
    }
    if (t2 == 0) {
        st->made = 0u;
        st->armed = 0u;
        st->low = 0u;
        st->high = 0u;
        return events;
    }
    int64_t t_norm = (int64_t)sp_isqrt64((uint64_t)t2); /* |F_target|, Q8 */
    int64_t made = (cfg->made > (int32_t)WRENCH_MAX) ? WRENCH_MAX : cfg->made;
    if (!st->made) {
        if (dot >= made * t_norm) {
            st->made = 1u;
            st->armed = 0u;
            st->low = 0u;
            st->high = 0u;
            events |= SP_CONTACT_MADE;
        }
    } else {
        int64_t level = (int64_t)(cfg->lost_ratio >> 15) * (t2 >> 15); /* Q30 x Q16 -> Q16 */
        if (dot >= level) {
            st->high = (st->high < UINT8_MAX) ? (uint8_t)(st->high + 1u) : st->high;
            if (st->high >= cfg->arm_ticks) {
                st->armed = 1u;
            }
        } else {
            st->high = 0u;
        }
        int64_t floor_ = st->armed ? level : (made / 2) * t_norm;
        if (dot < floor_) {
            st->low = (st->low < UINT8_MAX) ? (uint8_t)(st->low + 1u) : st->low;
            if (st->low >= cfg->lost_ticks) {
                st->made = 0u;
                st->armed = 0u;
                st->low = 0u;
                st->high = 0u;
                events |= SP_CONTACT_LOST;
            }
        } else {
            st->low = 0u;
        }
    }
    return events;
}
