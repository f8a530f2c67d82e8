/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/motion/stop.h"

#include "math/fixed_inline.h"

#define Q30_ONE (INT64_C(1) << 30)
#define US_PER_S INT64_C(1000000)
#define LIM_DECEL_MIN (SP_Q24_ONE / 10)
#define LIM_DECEL_MAX (50 * SP_Q24_ONE)
#define LIM_JERK_MIN SP_Q24_ONE
#define LIM_JERK_MAX (100 * SP_Q24_ONE)

sp_status_t sp_stop_limits_check(const sp_stop_limits_t *lim)
{
    unsigned g;
    if (lim == NULL) {
        return SP_E_ARG;
    }
    for (g = 0u; g < 2u; ++g) {
        if (lim->decel[g] < LIM_DECEL_MIN || lim->decel[g] > LIM_DECEL_MAX || lim->jerk[g] < LIM_JERK_MIN ||
            lim->jerk[g] > LIM_JERK_MAX) {
            return SP_E_ARG;
        }
    }
    return SP_OK;
}

/* The motion's value of axis k (0..5) of order 0 (pose), 1 (rate), 2 (acceleration). */
static int32_t motion_axis(const sp_motion_t *m, unsigned k, int order)
{
    if (order == 0) {
        return (k < 3u) ? m->pose.pos[k] : m->pose.rpy[k - 3u];
    }
    if (order == 1) {
        return (k < 3u) ? m->vel[k] : m->rpy_rate[k - 3u];
    }
    return (k < 3u) ? m->acc[k] : m->rpy_acc[k - 3u];
}

/* Does a stop of T (s, Q24, at most 10 s) keep every axis's limits? */
static int stop_fits(const sp_motion_t *from, const sp_stop_limits_t *lim, int64_t t_q24)
{
    unsigned k;
    for (k = 0u; k < 6u; ++k) {
        unsigned g = (k < 3u) ? 0u : 1u;
        int64_t v = spi_abs64(motion_axis(from, k, 1)); /* < 2^31 */
        int64_t a = spi_abs64(motion_axis(from, k, 2));
        int64_t d = (int64_t)lim->decel[g] - a;
        int64_t jt2;
        if (d < lim->decel[g] / 4) {
            d = lim->decel[g] / 4; /* already decelerating near the limit */
        }
        /* 1.875 v / T <= d: 15 v 2^24 <= 8 d T (both below 2^61) */
        if (15 * (v << 24) > 8 * d * t_q24) {
            return 0;
        }
        /* 5.7735 v + 3.95 a T <= J T^2, Q48 (5913 / 1024 and 4 from above): J T < 2^58, J T^2 < 2^62 */
        jt2 = ((int64_t)lim->jerk[g] * t_q24 >> 24) * t_q24;
        if (((v * 5913) << 14) + 4 * a * t_q24 > jt2) {
            return 0;
        }
    }
    return 1;
}

/* T in s, Q24, of n ticks of tick_us (n tick_us <= 10 s). */
static int64_t ticks_q24(uint32_t n, uint32_t tick_us)
{
    return (int64_t)(((uint64_t)n * tick_us << 24) / (uint64_t)US_PER_S);
}

/* The curve's polynomials at u (Q30), each Q30: the velocity's
 * h = 1 - (10u^3 - 15u^4 + 6u^5) and g = u - 6u^3 + 8u^4 - 3u^5, their
 * integrals (positions) and derivatives (accelerations). */
static void stop_basis(int64_t u, int64_t b[6])
{
    int64_t u2 = spi_round_away(u * u, 30u);
    int64_t u3 = spi_round_away(u2 * u, 30u);
    int64_t u4 = spi_round_away(u3 * u, 30u);
    int64_t u5 = spi_round_away(u4 * u, 30u);
    int64_t u6 = spi_round_away(u5 * u, 30u);
    b[0] = u - (5 * u4) / 2 + 3 * u5 - u6;                /* integral of h */
    b[1] = u2 / 2 - (3 * u4) / 2 + (8 * u5) / 5 - u6 / 2; /* integral of g */
    b[2] = Q30_ONE - 10 * u3 + 15 * u4 - 6 * u5;          /* h */
    b[3] = u - 6 * u3 + 8 * u4 - 3 * u5;                  /* g */
    b[4] = -30 * u2 + 60 * u3 - 30 * u4;                  /* h' */
    b[5] = Q30_ONE - 18 * u2 + 32 * u3 - 15 * u4;         /* g' */
}

/* The sample at u into *out (flags on saturation). */
static void stop_sample(const sp_stop_t *s, int64_t u, sp_motion_t *out, sp_flags_t *flags)
{
    int64_t b[6];
    unsigned k;
    stop_basis(u, b);
    for (k = 0u; k < 6u; ++k) {
        int64_t dp = spi_round_away(s->reach_v[k] * b[0] + s->reach_a[k] * b[1], 30u);
        int32_t p = spi_sat((int64_t)sp_pose_axis(&s->from, (sp_axis_t)k) + dp, flags);
        int32_t v = spi_sat(spi_round_away(s->v0[k] * b[2] + s->a0t[k] * b[3], 30u), flags);
        int32_t a = spi_sat(spi_round_away(s->v0_t[k] * b[4] + s->a0[k] * b[5], 30u), flags);
        if (k < 3u) {
            out->pose.pos[k] = p;
            out->vel[k] = v;
            out->acc[k] = a;
        } else {
            out->pose.rpy[k - 3u] = p;
            out->rpy_rate[k - 3u] = v;
            out->rpy_acc[k - 3u] = a;
        }
    }
}

/* The coefficients of a stop of n ticks; 0 when one leaves int32. */
static int stop_coefficients(sp_stop_t *s, const sp_motion_t *from, uint32_t n, uint32_t tick_us)
{
    sp_flags_t flags = 0u;
    int64_t t = ticks_q24(n, tick_us); /* > 0, < 2^28 */
    sp_motion_t end;
    unsigned k;
    for (k = 0u; k < 6u; ++k) {
        int64_t v = motion_axis(from, k, 1);
        int64_t a = motion_axis(from, k, 2);
        int64_t at = spi_round_away(a * t, 24u); /* < 2^35 */
        s->v0[k] = (int32_t)v;
        s->a0[k] = (int32_t)a;
        s->reach_v[k] = spi_sat(spi_round_away(v * t, 24u), &flags);
        s->a0t[k] = spi_sat(at, &flags);
        s->reach_a[k] = spi_sat(spi_round_away(s->a0t[k] * t, 24u), &flags);
        s->v0_t[k] = spi_sat((v * (INT64_C(1) << 24)) / t, &flags);
    }
    s->ticks = n;
    s->tick = 0u;
    s->step = ((INT64_C(1) << 46) + (int64_t)n / 2) / (int64_t)n;
    stop_sample(s, Q30_ONE, &end, &flags);
    s->to = end.pose;
    return flags == 0u;
}

sp_status_t sp_stop_plan(sp_stop_t *s, const sp_motion_t *from, const sp_stop_limits_t *lim, uint32_t tick_us)
{
    uint32_t lo = 1u;
    uint32_t hi;
    unsigned k;
    int moving = 0;
    if (s == NULL || from == NULL || tick_us < 1u || tick_us > 100000u || sp_stop_limits_check(lim) != SP_OK) {
        return SP_E_ARG;
    }
    s->from = from->pose;
    s->to = from->pose;
    s->ticks = 0u;
    s->tick = 0u;
    s->step = 0;
    for (k = 0u; k < 6u; ++k) {
        moving |= (motion_axis(from, k, 1) != 0 || motion_axis(from, k, 2) != 0) ? 1 : 0;
        s->reach_v[k] = 0;
        s->reach_a[k] = 0;
        s->v0[k] = 0;
        s->a0t[k] = 0;
        s->v0_t[k] = 0;
        s->a0[k] = 0;
    }
    if (!moving) {
        return SP_OK;
    }
    hi = SP_STOP_MAX_US / tick_us;
    if (!stop_fits(from, lim, ticks_q24(hi, tick_us))) {
        return SP_E_RANGE;
    }
    /* the shortest: the limits hold for every T above one that fits */
    while (lo < hi) { /* at most 24 halvings */
        uint32_t mid = lo + (hi - lo) / 2u;
        if (stop_fits(from, lim, ticks_q24(mid, tick_us))) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    if (!stop_coefficients(s, from, lo, tick_us)) {
        s->ticks = 0u;
        s->to = from->pose;
        return SP_E_RANGE;
    }
    return SP_OK;
}

sp_status_t sp_stop_step(sp_stop_t *s, sp_motion_t *out, int *done)
{
    sp_flags_t flags = 0u;
    if (s == NULL || out == NULL || done == NULL) {
        return SP_E_ARG;
    }
    if (s->tick < s->ticks) {
        s->tick += 1u;
    }
    if (s->tick >= s->ticks) {
        sp_motion_at_rest(out, &s->to);
        *done = 1;
        return SP_OK;
    }
    stop_sample(s, spi_round_away(s->step * (int64_t)s->tick, 16u), out, &flags); /* u within 2^-33 */
    *done = 0;
    return SP_OK;
}
