/* SPDX-License-Identifier: Apache-2.0 */
/*
 * admittance.c - admittance control and contact supervision (sp/force/admittance.h).
 */
#include "sp/force/admittance.h"

#include "math/fixed_inline.h"

#include <stddef.h>

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

/* dt in s, Q50 (dt_us 2^50 / 10^6): what coefficients() divides by den. */
static int64_t tick_q50(uint32_t tick_us, sp_flags_t *flags)
{
    return sp_div64((int64_t)tick_us, 1000000, 50u, flags);
}

/* The coefficients of the law for mass M (Q16), damping D and stiffness K
 * (N s/m, N/m) at tick dt_us, dt_q50 = tick_q50(dt_us) (prepared). Three
 * divisions, a fourth and fifth only for K != 0. */
static sp_status_t coefficients(sp_q16_t mass, int32_t damping, int32_t stiffness, uint32_t tick_us, int64_t dt_q50,
                                sp_admit_coef_t *c)
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
    int32_t c_f = sp_div(dt_q50, (int32_t)den, 0u, &flags);
    /* c_k = dt K / den, 1/s, Q16: dt_us K 2^28 / (10^6 den_q12); 0 for K = 0 */
    int32_t c_k = 0;
    if (stiffness != 0) {
        int64_t k = sp_div64((int64_t)tick_us * stiffness, (int32_t)den, 28u, &flags);
        c_k = sp_sat32((k + 500000) / 1000000, &flags);
    }
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

sp_status_t sp_admit_coefficients(const sp_admit_config_t *cfg, const sp_admit_t *st, unsigned axis, int32_t damping,
                                  sp_admit_coef_t *c)
{
    if (cfg == NULL || st == NULL || c == NULL || axis >= SP_AXES || damping < 1) {
        return SP_E_ARG;
    }
    const sp_admit_axis_t *ax = &cfg->axis[axis];
    return coefficients(ax->mass, damping, ax->stiffness, cfg->tick_us, st->dt_q50, c);
}

sp_status_t sp_admit_restart(sp_admit_t *st, const sp_admit_coef_t free_coef[SP_AXES])
{
    if (st == NULL) {
        return SP_E_ARG;
    }
    for (unsigned k = 0; k < SP_AXES; ++k) {
        sp_admit_axis_state_t *s = &st->axis[k];
        if (free_coef != NULL) {
            s->free_coef = free_coef[k];
        }
        s->coef = s->free_coef;
        s->d = 0;
        s->v = 0;
        s->a = 0;
        for (unsigned n = 0; n < 4u; ++n) {
            s->x_f[n] = 0;
        }
        s->x_contact = 0;
        s->w_contact = 0;
        s->k_hat = 0;
        s->window_w = 0; /* no windows made (a crossover is > 0) */
        s->in_contact = 0u;
    }
    st->primed = 0u;
    return SP_OK;
}

sp_status_t sp_admit_configure(const sp_admit_config_t *cfg, sp_admit_t *st)
{
    if (cfg == NULL || st == NULL || cfg->crossover <= 0 || cfg->k_min < 1 || cfg->k_max < cfg->k_min ||
        cfg->secant_force <= 0 || cfg->secant_travel <= 0 || cfg->filter_alpha <= 0 || cfg->filter_alpha > SP_Q30_ONE ||
        cfg->secant_margin < 0 || cfg->boost > 16u || cfg->boost_band < 0 || cfg->tick_us < 100u ||
        cfg->tick_us > TICK_MAX_US) {
        return SP_E_ARG;
    }
    sp_admit_t fresh;
    sp_flags_t flags = 0u;
    fresh.dt_q50 = tick_q50(cfg->tick_us, &flags); /* dt <= 2 ms: below 2^41 */
    if (flags != 0u) {
        return SP_E_OVERFLOW;
    }
    for (unsigned k = 0; k < SP_AXES; ++k) {
        const sp_admit_axis_t *ax = &cfg->axis[k];
        sp_admit_axis_state_t *s = &fresh.axis[k];
        if (!axis_ok(ax)) {
            return SP_E_ARG;
        }
        sp_status_t a = coefficients(ax->mass, ax->damping, ax->stiffness, cfg->tick_us, fresh.dt_q50, &s->free_coef);
        sp_status_t b =
            coefficients(ax->mass, release_damping(ax), ax->release_stiffness, cfg->tick_us, fresh.dt_q50, &s->rel);
        if (a != SP_OK || b != SP_OK) {
            return SP_E_OVERFLOW;
        }
        /* a_brake < 2^31 and dt <= 2 ms: below 2^22 */
        s->dv_brake = (sp_q24_t)(((int64_t)ax->a_brake * cfg->tick_us + 500000) / 1000000);
    }
    /* dt <= 2 ms: below 2^30 in Q38; dt >= 100 us: 1/dt below 2^30 in Q16 */
    fresh.dt_q38 = (int32_t)(((int64_t)cfg->tick_us << 38) / 1000000);
    fresh.rate_q16 = (int32_t)((INT64_C(1000000) << 16) / cfg->tick_us);
    (void)sp_admit_restart(&fresh, NULL);
    *st = fresh;
    return SP_OK;
}

/* The secant stiffness an axis in contact has: the filtered wrench against
 * the filtered pose since contact, N/m within [k_min, k_max] (kept as
 * k_hat); 0 while the secant is not yet trusted. */
static int32_t contact_stiffness(const sp_admit_config_t *cfg, sp_admit_axis_state_t *s, sp_q8_t w)
{
    int64_t dx = (int64_t)s->x_f[3] - s->x_contact;
    int64_t dw = (int64_t)w - s->w_contact;
    int64_t adx = (dx < 0) ? -dx : dx;
    int64_t adw = (dw < 0) ? -dw : dw;
    if (cfg->secant_margin > 0) {
        /* an upper bound: the change against the travel (none if the noise
         * shows it along the travel) plus the noise's bound */
        if (adx < cfg->secant_travel) {
            return 0;
        }
        adw = (((dx > 0) != (dw > 0)) ? adw : 0) + cfg->secant_margin;
    } else if (adx < cfg->secant_travel || adw < cfg->secant_force || (dx > 0) == (dw > 0)) {
        /* the world pushes back: the wrench changes against the travel */
        return 0;
    }
    sp_flags_t flags = 0u;
    int32_t k = sp_div(adw, (int32_t)clamp64(adx, INT32_MAX), 16u, &flags); /* Q8 / Q24 -> N/m */
    k = (k < cfg->k_min) ? cfg->k_min : ((k > cfg->k_max) ? cfg->k_max : k);
    s->k_hat = k;
    return k;
}

/* The contact damping of stiffness k at crossover w > 0: k / w_c, N s/m,
 * as sp_div rounds it (to nearest, ties away), at least 1. */
static int32_t damping_of(int32_t k, int32_t w)
{
    sp_flags_t flags = 0u;                          /* a pure function of k and w: flags unused */
    int32_t d = sp_div((int64_t)k, w, 16u, &flags); /* (N/m) / (rad/s, Q16) */
    return (d < 1) ? 1 : d;
}

/* The least stiffness k >= 0 whose damping_of(k, w) is at least x, held
 * within [0, 2^31] (2^31: none). damping_of is floor((k 2^16 +
 * floor(w / 2)) / w) held within [1, INT32_MAX], rising with k: for x >= 2
 * it is at least x exactly when k 2^16 >= x w - floor(w / 2). No division. */
static uint32_t least_k(int64_t x, int32_t w)
{
    if (x <= 1) {
        return 0u;
    }
    if (x > INT32_MAX) {
        return UINT32_C(1) << 31;
    }
    uint64_t need = (uint64_t)(uint32_t)x * (uint32_t)w - ((uint32_t)w >> 1); /* below 2^62 */
    uint64_t k = (need + 65535u) >> 16;
    return (k > (UINT64_C(1) << 31)) ? (UINT32_C(1) << 31) : (uint32_t)k;
}

/* The windows of k for the damping in use and the free-space one at
 * crossover w > 0 (made again when either damping or w changes: on a
 * tick that adapted, not on every tick the secant moves). */
static void make_windows(sp_admit_axis_state_t *s, int32_t w)
{
    int64_t c = s->coef.damping;
    int64_t tol = c / 16;
    int64_t f = s->free_coef.damping;
    s->keep_lo = least_k(c - tol, w);
    s->keep_hi = least_k(c + tol + 1, w);
    s->free_lo = least_k(f, w);
    s->free_hi = least_k(f + 1, w);
    s->window_w = w;
    s->window_c = s->coef.damping;
    s->window_f = s->free_coef.damping;
}

/* Holds v towards the bounds: v_max, then the braking speed sqrt(2 a dist),
 * then dist / tau plus one LSB a tick (so that d reaches the bound). */
static int32_t limit_velocity(const sp_admit_axis_t *ax, int64_t v, sp_q24_t d, sp_q24_t lo, sp_q24_t hi,
                              int32_t rate_q16, int *limited)
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
        /* a_brake, dist and |v| (held to v_max) below 2^31: 32 x 32-bit products */
        uint32_t dist_c = (dist > INT32_MAX) ? (uint32_t)INT32_MAX : (uint32_t)dist;
        uint64_t brake2 = 2u * ((uint64_t)(uint32_t)ax->a_brake * dist_c); /* Q48 (m/s)^2 */
        uint32_t av = (uint32_t)((v < 0) ? -v : v);
        if ((uint64_t)av * av > brake2) {
            int64_t vb = (int64_t)sp_isqrt64(brake2); /* Q24 */
            v = (v > 0) ? vb : -vb;
            av = (uint32_t)vb;
            *limited = 1;
        }
        /* the last stretch: dist / tau, so the reference comes to the
         * bound exponentially and the platform, which lags it, does not
         * pass it */
        uint64_t vt = (uint64_t)dist_c * SP_ADMIT_TAIL_RATE + (uint32_t)(rate_q16 >> 16); /* Q24 m/s; >= 1 LSB a tick */
        if ((uint64_t)av > vt) {
            v = (v > 0) ? (int64_t)vt : -(int64_t)vt;
            *limited = 1;
        }
    }
    return (int32_t)v;
}

/* The pose x (Q24) through the wrench filter's sections into s->x_f, for
 * the secant; primed with the measurement the first tick the axis (bit)
 * is forced. */
SPI_INLINE void filter_pose(const sp_admit_config_t *cfg, sp_admit_t *st, sp_admit_axis_state_t *s, uint8_t bit,
                            sp_q24_t x)
{
    const int primed = (st->primed & bit) != 0u;
    for (unsigned n = 0; n < 4u; ++n) {
        int32_t in = (n == 0u) ? x : s->x_f[n - 1u];
        s->x_f[n] = primed ? spi_lowpass_section(s->x_f[n], in, cfg->filter_alpha) : in;
    }
    st->primed |= bit;
}

/* The damping a forced axis should use: the free-space one off contact,
 * else from the contact's stiffness (have_x: a measured pose, so a secant). */
SPI_INLINE int32_t axis_damping(const sp_admit_config_t *cfg, sp_admit_axis_state_t *s, int in_contact, sp_q8_t w_ext,
                                int have_x)
{
    int32_t damping = s->free_coef.damping;
    if (in_contact) {
        if (!s->in_contact) {
            s->in_contact = 1u;
            s->x_contact = s->x_f[3];
            s->w_contact = w_ext;
            s->k_hat = 0;
        }
        int32_t kc = have_x ? contact_stiffness(cfg, s, w_ext) : 0;
        const int32_t w = cfg->crossover;
        if (kc > 0 && w > 0) {
            /* k / w_c: the windows of k tell whether it is the
             * free-space damping or within the tolerance of the
             * one in use; the quotient is taken only when neither
             * (the law's coefficients are then made from it) */
            if (w != s->window_w || s->coef.damping != s->window_c || s->free_coef.damping != s->window_f) {
                make_windows(s, w);
            }
            const uint32_t ku = (uint32_t)kc;
            damping = (ku >= s->free_lo && ku < s->free_hi)
                          ? s->free_coef.damping
                          : ((ku >= s->keep_lo && ku < s->keep_hi) ? s->coef.damping : damping_of(kc, w));
        } else {
            damping = (kc > 0) ? 1 : ((s->k_hat > 0) ? s->coef.damping : s->free_coef.damping);
        }
    } else {
        s->in_contact = 0u;
        s->k_hat = 0;
    }
    return damping;
}

/* The law's coefficients for the damping: kept within its tolerance of the
 * one in use, else made again. Returns 1 when they changed; *status
 * SP_E_OVERFLOW when they cannot be made (those in use kept). */
SPI_INLINE unsigned adapt(const sp_admit_config_t *cfg, const sp_admit_axis_t *ax, int64_t dt_q50,
                          sp_admit_axis_state_t *s, int32_t damping, sp_status_t *status)
{
    int32_t diff = damping - s->coef.damping;
    int32_t tol = s->coef.damping / 16;
    if (damping == s->free_coef.damping) {
        if (s->coef.damping != s->free_coef.damping) {
            s->coef = s->free_coef; /* prepared: what coefficients() would give */
            return 1u;
        }
    } else if (diff > tol || diff < -tol) {
        sp_admit_coef_t c;
        if (coefficients(ax->mass, damping, ax->stiffness, cfg->tick_us, dt_q50, &c) == SP_OK) {
            s->coef = c;
            return 1u;
        }
        *status = SP_E_OVERFLOW;
    }
    return 0u;
}

/* The wrench error f (Q8) with its excess over the boost band counted
 * boost times, while the force the reference will make once the platform
 * has caught up with it (k_hat times the reference's lead on the filtered
 * pose, Q24 x N/m -> Q8) is far from the target too: on a stiff surface
 * the drives lag and the boost would wind the reference up past the
 * target. */
SPI_INLINE int32_t boosted(const sp_admit_config_t *cfg, const sp_admit_axis_state_t *s, int32_t f)
{
    int64_t band = cfg->boost_band;
    int64_t lead = (int64_t)s->d - s->x_f[3];
    int64_t fp = clamp64(f - (((int64_t)s->k_hat * lead + (INT64_C(1) << 15)) >> 16), WRENCH_MAX);
    int64_t e1 = (f > band) ? f - band : ((f < -band) ? f + band : 0);
    int64_t e2 = (fp > band) ? fp - band : ((fp < -band) ? fp + band : 0);
    int64_t ex = (e1 > 0 && e2 > 0) ? ((e1 < e2) ? e1 : e2) : ((e1 < 0 && e2 < 0) ? ((e1 > e2) ? e1 : e2) : 0);
    return (int32_t)clamp64(f + (int64_t)(cfg->boost - 1u) * ex, WRENCH_MAX);
}

/* The reference's new speed from the law (forced: on the wrench error;
 * else the release back to d = 0), or braking under SP_ADMIT_HOLD. */
SPI_INLINE int64_t law_velocity(const sp_admit_config_t *cfg, const sp_admit_axis_state_t *s, sp_admit_mode_t mode,
                                int forced, int32_t w_ext, int32_t w_target, int have_x)
{
    if (mode == SP_ADMIT_HOLD) {
        /* brake: |v| falls by a_brake dt each tick, never through zero */
        const int32_t dv = s->dv_brake;
        return (s->v > dv) ? (int64_t)s->v - dv : ((s->v < -dv) ? (int64_t)s->v + dv : 0);
    }
    const sp_admit_coef_t *c = forced ? &s->coef : &s->rel;
    /* held within +-2^30: a 32 x 32-bit product */
    int32_t f = forced ? (int32_t)clamp64((int64_t)w_ext + w_target, WRENCH_MAX) : 0;
    if (forced && cfg->boost > 1u && s->k_hat > 0 && have_x) {
        f = boosted(cfg, s, f);
    }
    return (((int64_t)c->c_v * s->v + (INT64_C(1) << 29)) >> 30) + (((int64_t)c->c_f * f + (INT64_C(1) << 21)) >> 22) -
           (((int64_t)c->c_k * s->d + (INT64_C(1) << 15)) >> 16);
}

sp_status_t sp_admit_step(const sp_admit_config_t *cfg, sp_admit_t *st, sp_admit_mode_t mode, uint8_t mask,
                          const sp_q8_t w_ext[SP_AXES], const sp_q8_t w_target[SP_AXES], const sp_q24_t x_meas[SP_AXES],
                          uint8_t contact, const sp_q24_t lo[SP_AXES], const sp_q24_t hi[SP_AXES],
                          sp_admit_report_t *report)
{
    if (cfg == NULL || st == NULL || w_ext == NULL || w_target == NULL || lo == NULL || hi == NULL ||
        (mode != SP_ADMIT_FORCE && mode != SP_ADMIT_RELEASE && mode != SP_ADMIT_HOLD)) {
        return SP_E_ARG;
    }
    sp_status_t status = SP_OK;
    sp_admit_report_t rep = {0u, 0u};
    const int32_t dt_q38 = st->dt_q38;
    const int64_t rate_q16 = st->rate_q16;
    const int have_x = x_meas != NULL;
    /* the axes not forced: no contact, no secant, not primed; those at rest
     * on the position reference stay there (the return to d = 0 and the
     * brake both leave v = 0, d = 0, inside every bound), so the law runs on
     * the forced axes and the others still moving only */
    const uint8_t forced_mask = (mode == SP_ADMIT_FORCE) ? (uint8_t)(mask & 0x3Fu) : 0u;
    uint8_t work = forced_mask;
    st->primed &= forced_mask;
    for (unsigned k = 0; k < SP_AXES; ++k) {
        sp_admit_axis_state_t *s = &st->axis[k];
        if ((forced_mask & (1u << k)) == 0u) {
            s->in_contact = 0u;
            s->k_hat = 0;
            if (s->d == 0 && s->v == 0) {
                s->a = 0;
            } else {
                work = (uint8_t)(work | (1u << k));
            }
        }
    }
    for (unsigned k = 0; k < SP_AXES; ++k) {
        const sp_admit_axis_t *ax = &cfg->axis[k];
        sp_admit_axis_state_t *s = &st->axis[k];
        const uint8_t bit = (uint8_t)(1u << k);
        const int forced = (forced_mask & bit) != 0u;
        if ((work & bit) == 0u) {
            continue;
        }
        if (forced && have_x) {
            filter_pose(cfg, st, s, bit, x_meas[k]);
        }
        if (forced) {
            int32_t damping = axis_damping(cfg, s, (contact & bit) != 0u, w_ext[k], have_x);
            if (adapt(cfg, ax, st->dt_q50, s, damping, &status)) {
                rep.adapted |= bit;
            }
        }
        int64_t v = law_velocity(cfg, s, mode, forced, w_ext[k], w_target[k], have_x);
        int limited = 0;
        if (forced) {
            /* the reference's acceleration held to a_brake: a change of the
             * adapted damping or a step of the wrench then ramps the speed
             * instead of stepping it (the cylinders' estimate reads a step
             * of the reference's speed as a spike of wrench) */
            const int64_t dv = s->dv_brake;
            if (v > (int64_t)s->v + dv || v < (int64_t)s->v - dv) {
                v = (v > s->v) ? (int64_t)s->v + dv : (int64_t)s->v - dv;
                limited = 1;
            }
        }
        sp_q24_t lo_k = (lo[k] > 0) ? 0 : lo[k];
        sp_q24_t hi_k = (hi[k] < 0) ? 0 : hi[k];
        int32_t v_new = limit_velocity(ax, v, s->d, lo_k, hi_k, st->rate_q16, &limited);
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
    if (report != NULL) {
        *report = rep;
    }
    return status;
}

void sp_contact_target(const sp_q8_t w_target[SP_AXES], sp_contact_target_t *tp)
{
    if (w_target == NULL || tp == NULL) {
        return;
    }
    int64_t t2 = 0;
    for (unsigned k = 0; k < 3u; ++k) {
        int64_t t = clamp64(w_target[k], WRENCH_MAX);
        tp->t[k] = (int32_t)t;
        t2 += t * t;
    }
    tp->t2 = t2;
    tp->t_norm = (int64_t)sp_isqrt64((uint64_t)t2); /* |F_target|, Q8 */
}

uint32_t sp_contact_step(const sp_contact_config_t *cfg, sp_contact_t *st, const sp_q8_t w_ext[SP_AXES],
                         const sp_q8_t w_target[SP_AXES])
{
    if (w_target == NULL) {
        return 0u;
    }
    sp_contact_target_t tp;
    sp_contact_target(w_target, &tp);
    return sp_contact_step_to(cfg, st, w_ext, &tp);
}

uint32_t sp_contact_step_to(const sp_contact_config_t *cfg, sp_contact_t *st, const sp_q8_t w_ext[SP_AXES],
                            const sp_contact_target_t *tp)
{
    if (cfg == NULL || st == NULL || w_ext == NULL || tp == NULL) {
        return 0u;
    }
    uint32_t events = 0u;
    int64_t dot = 0, f2 = 0;
    for (unsigned k = 0; k < 3u; ++k) {
        /* held within +-2^30 (an int32 reading: 32-bit compares) */
        int64_t f = clamp32(w_ext[k], -(int32_t)WRENCH_MAX, (int32_t)WRENCH_MAX);
        dot -= f * tp->t[k]; /* the push-back times |F_target|, Q16 */
        f2 += f * f;
    }
    const int64_t t2 = tp->t2;
    int64_t excess = cfg->excess;
    if (f2 > excess * excess) {
        events |= SP_CONTACT_EXCESS;
    }
    if (t2 == 0) {
        st->made = 0u;
        st->armed = 0u;
        st->low = 0u;
        st->high = 0u;
        st->slow = 0;
        return events;
    }
    const int64_t t_norm = tp->t_norm;
    int64_t made = (cfg->made > (int32_t)WRENCH_MAX) ? WRENCH_MAX : cfg->made;
    int64_t made_slow = 0; /* made_slow |F_target|, Q16; 0: off */
    if (cfg->made_slow > 0 && cfg->slow_shift != 0u) {
        /* |dot| < 3 2^60 and |slow| <= 2^61 after the clamp: the difference
         * fits; the shift held to 15 */
        int64_t in = clamp64(dot, INT64_C(1) << 61);
        st->slow += (in - st->slow) / (INT64_C(1) << (cfg->slow_shift & 15u));
        made_slow = ((cfg->made_slow > (int32_t)WRENCH_MAX) ? WRENCH_MAX : cfg->made_slow) * t_norm;
    }
    if (!st->made) {
        if (dot >= made * t_norm || (made_slow > 0 && st->slow >= made_slow)) {
            st->made = 1u;
            st->armed = 0u;
            st->low = 0u;
            st->high = 0u;
            events |= SP_CONTACT_MADE;
        }
    } else {
        int64_t level = (int64_t)(cfg->lost_ratio >> 15) * (t2 >> 15); /* Q30 x Q16 -> Q16 */
        if (dot >= level) {
            /* armed once the push-back has held the level arm_ticks ticks
             * on end: a spike of the wrench does not arm it */
            st->high = (st->high < UINT8_MAX) ? (uint8_t)(st->high + 1u) : st->high;
            if (st->high >= cfg->arm_ticks) {
                st->armed = 1u;
            }
        } else {
            st->high = 0u;
        }
        /* below the level once armed; before, below made / 2 (with
         * made_slow, and the low-passed push-back below made_slow / 2:
         * contact made by either level is lost only when both fall) */
        int64_t floor_ = st->armed ? level : (made / 2) * t_norm;
        if (dot < floor_ && (st->armed || made_slow == 0 || st->slow < made_slow / 2)) {
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
