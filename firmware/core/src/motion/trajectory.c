/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/motion/trajectory.h"

#include "math/fixed_inline.h"

#define TWO_PI_Q24 INT64_C(105414357)  /* 2 pi in Q24 */
#define TWO_PI_Q28 INT32_C(1686629713) /* 2 pi in Q28 */
#define US_PER_S INT64_C(1000000)
#define MOVE_MAX_MS UINT64_C(600000) /* 10 minutes */

sp_q24_t sp_pose_axis(const sp_pose_t *pose, sp_axis_t axis)
{
    unsigned a = (unsigned)axis;
    if (pose == NULL || a >= 6u) {
        return 0;
    }
    return (a < 3u) ? pose->pos[a] : pose->rpy[a - 3u];
}

static sp_q24_t *axis_ref(sp_pose_t *pose, unsigned a)
{
    return (a < 3u) ? &pose->pos[a] : &pose->rpy[a - 3u];
}

static sp_q24_t *vec_ref(sp_motion_t *m, unsigned a, int order)
{
    if (order == 1) {
        return (a < 3u) ? &m->vel[a] : &m->rpy_rate[a - 3u];
    }
    return (a < 3u) ? &m->acc[a] : &m->rpy_acc[a - 3u];
}

void sp_motion_at_rest(sp_motion_t *m, const sp_pose_t *pose)
{
    unsigned k;
    m->pose = *pose;
    for (k = 0u; k < 3u; ++k) {
        m->vel[k] = 0;
        m->rpy_rate[k] = 0;
        m->acc[k] = 0;
        m->rpy_acc[k] = 0;
    }
}

/* floor(n / d) for d != 0 without a 64-bit library division when the
 * quotient fits 32 bits (the tick's cases); exactly n / d in every case. */
static uint64_t udiv64(uint64_t n, uint32_t d)
{
    if ((n >> 32) < d) {
        return spi_udiv64_32(n, d, NULL);
    }
    return n / d;
}

/* Quintic smoothstep at u (Q30, 0..1): E in Q30, E' = dE/du and
 * E'' = d2E/du2 in Q24 (their peaks, 1.875 and 5.77, exceed Q30's range). */
static void smoothstep(int32_t u, int32_t *e, int32_t *de, int32_t *dde)
{
    int64_t one = INT64_C(1) << 30;
    int64_t uu = u;
    int64_t v = one - uu;                      /* 1 - u */
    int64_t u2 = spi_round_away(uu * uu, 30u); /* u^2 */
    int64_t u3 = spi_round_away(u2 * uu, 30u); /* u^3 */
    int64_t v2 = spi_round_away(v * v, 30u);   /* (1-u)^2 */
    /* E = u^3 (10 - 15u + 6u^2) */
    int64_t poly = 10 * one - 15 * uu + 6 * u2;
    *e = (int32_t)spi_round_away(u3 * poly, 30u);
    /* E' = 30 u^2 (1-u)^2 */
    *de = (int32_t)spi_round_away(30 * spi_round_away(u2 * v2, 30u), 6u);
    /* E'' = 60 u (1-u) (1-2u) */
    *dde = (int32_t)spi_round_away(60 * spi_round_away(spi_round_away(uu * v, 30u) * (one - 2 * uu), 30u), 6u);
}

sp_status_t sp_trig_start(sp_trig_t *g, const sp_pose_t *centre, sp_axis_t axis, sp_q24_t amplitude,
                          sp_q24_t frequency_hz, uint32_t tick_us, uint32_t fade_ticks)
{
    int64_t step;
    int64_t rate; /* the fade's rate, 1/s, Q24 */
    int64_t peak; /* w^2 + 4 w r + 6 r^2, Q24 */
    sp_q24_t omega;

    if (g == NULL) {
        return SP_E_ARG;
    }
    g->finished = 1;
    g->tick = 0u;
    g->phase = 0u;
    g->stop_tick = UINT32_MAX;
    g->fade_tick_us = 0u;
    if (centre == NULL) {
        return SP_E_ARG;
    }
    g->centre = *centre;
    if ((unsigned)axis >= 6u || tick_us < 1u || tick_us > 100000u || (uint64_t)fade_ticks * tick_us < 100000u ||
        (uint64_t)fade_ticks * tick_us > 60000000u || frequency_hz <= 0 || frequency_hz > 10 * SP_Q24_ONE ||
        amplitude > SP_Q24_ONE || amplitude < -SP_Q24_ONE) {
        return SP_E_ARG;
    }
    /* turns per tick = f * tick_us / 1e6, in 2^-32 turn; below half a turn */
    step = ((int64_t)frequency_hz * tick_us * 256 + US_PER_S / 2) / US_PER_S;
    if (step <= 0 || step >= (INT64_C(1) << 31)) {
        return SP_E_ARG;
    }
    omega = sp_mul(frequency_hz, TWO_PI_Q28, 28u, NULL);
    /* the acceleration's peak, |A| (w^2 + 4 w r + 6 r^2) with r the fade's
     * rate (w^2 s E, 2 w c E' r and s E'' r^2 at their peaks 1, 1.875 and
     * 5.77), below SP_TRIG_ACC_MAX: every sample then fits Q24. w < 2^30
     * and r <= 10 / s (a fade of 0.1 s at least): the sum is below 2^37
     * and its product by |A| <= 2^24 below 2^61. */
    rate = (int64_t)(((UINT64_C(1) << 24) * (uint64_t)US_PER_S) / ((uint64_t)fade_ticks * tick_us));
    peak = (((int64_t)omega * omega) >> 24) + 4 * (((int64_t)omega * rate) >> 24) + 6 * ((rate * rate) >> 24);
    if (((peak * (amplitude < 0 ? -(int64_t)amplitude : (int64_t)amplitude)) >> 24) >= SP_TRIG_ACC_MAX) {
        return SP_E_RANGE;
    }
    g->axis = axis;
    g->amplitude = amplitude;
    g->omega = omega;
    g->omega2 = spi_round_away((int64_t)omega * omega, 24u);
    /* narrow: every term of the acceleration within int32 (its bound
     * below 128 / s^2 in Q24: below 1.8 Hz and with fades of 0.22 s and
     * longer at least), computed as first written */
    g->wide = (peak >= (INT64_C(1) << 31)) ? 1u : 0u;
    g->phase_step = (uint32_t)step;
    g->fade_ticks = fade_ticks;
    g->finished = 0;
    return SP_OK;
}

void sp_trig_stop(sp_trig_t *g)
{
    if (g != NULL && g->stop_tick == UINT32_MAX) {
        /* a stop during the fade-in waits for it to end, so the envelope's
         * rate never reverses abruptly */
        g->stop_tick = (g->tick > g->fade_ticks) ? g->tick : g->fade_ticks;
    }
}

/* 1 / duration in 1/s, Q24, for a duration of dt_us >= 1 us (floor;
 * saturated, and flagged, above 128/s: durations below 7.8 ms). The
 * quotient is below 2^45; the 32-bit division whenever dt_us fits 32 bits. */
static int32_t inv_duration_q24(uint64_t dt_us, sp_flags_t *flags)
{
    uint64_t n = (UINT64_C(1) << 24) * (uint64_t)US_PER_S;
    return spi_sat((int64_t)((dt_us <= UINT32_MAX) ? udiv64(n, (uint32_t)dt_us) : n / dt_us), flags);
}

/* The envelope's rate during a fade, 1/s in Q24: fade_ticks * tick_us is in
 * [1e5, 6e7] (sp_trig_start). Made once per motion (and whenever the tick
 * length changes) and kept with its flags: the same value and flags every
 * fade tick. */
static int32_t fade_rate(sp_trig_t *g, uint32_t tick_us, sp_flags_t *flags)
{
    if (g->fade_tick_us != tick_us) {
        g->fade_flags = 0u;
        g->fade_rate = inv_duration_q24((uint64_t)g->fade_ticks * tick_us, &g->fade_flags);
        g->fade_tick_us = tick_us;
    }
    *flags |= g->fade_flags;
    return g->fade_rate;
}

/* The generator's first step (the command's tick; its sample, the centre
 * at rest, is already in *out): u = 0 and the phase 0, so E = E' = E'' = 0
 * and sin(theta) = 0, and every product of sp_trig_step's general path
 * has a zero factor. Of its flags only the fade rate's can be raised: the
 * same here. */
static sp_status_t trig_first(sp_trig_t *g, uint32_t tick_us)
{
    sp_flags_t flags = 0u;
    (void)fade_rate(g, tick_us, &flags);
    g->phase += g->phase_step;
    ++g->tick; /* in the fade-in: fade_ticks >= 1 (sp_trig_start) */
    return sp_flags_status(flags);
}

/* x f for x in Q24 (|x| < 2^38) and f in Q30 (|f| <= 2^30), Q24: the
 * 32-bit product, rounded away from zero, when x fits int32, else in two
 * parts, x = xh 2^16 + xl (xl in [0, 2^16)): xh f (below 2^52) plus xl f
 * / 2^16 (floor), rounded from Q30 + 14: within one step of x f, and x
 * itself for f = 2^30. */
static int64_t trig_mul_q30(int64_t x, int32_t f, sp_flags_t *flags)
{
    if (x >= INT32_MIN && x <= INT32_MAX) {
        return spi_mul_away((int32_t)x, f, 30u, flags);
    }
    return spi_round_away((x >> 16) * f + (((x & 0xFFFF) * f) >> 16), 14u);
}

/* The acceleration of a wide motion (sp_trig_t.wide), -w^2 s e + 2 w c e'
 * + s e'' (Q24, below 2^38), in 64 bits: w^2 below 2^37 (10 Hz), w c e'
 * below 2^35 (63 rad/s x 18.75 / s), e'' = E'' (du/dt)^2 below 2^34 (5.77
 * x 10^2 / s^2, a fade of 0.1 s) from dde_r = E'' du/dt (Q24). */
static int64_t trig_acc_wide(const sp_trig_t *g, sp_q30_t s, int32_t e, int32_t wc, int32_t de, int32_t dde_r,
                             int32_t rate, sp_flags_t *flags)
{
    int64_t dde_rr = spi_round_away((int64_t)dde_r * rate, 24u);
    return -trig_mul_q30(trig_mul_q30(g->omega2, s, flags), e, flags) + 2 * spi_round_away((int64_t)wc * de, 24u) +
           trig_mul_q30(dde_rr, s, flags);
}

/* The motion's offset, velocity and acceleration per unit amplitude at
 * sin and cos of the phase s, c (Q30) under the envelope e (Q30) with
 * e' = de, E'' du/dt = dde (Q24) and du/dt = rate (0: full amplitude):
 * offset = s e; velocity = w c e + s e'; acceleration = -w^2 s e + 2 w c
 * e' + s e''. Sums in Q24 (out[0..2]); each term of a narrow motion's
 * within int32 (sp_trig_start). */
SPI_INLINE void trig_terms(const sp_trig_t *g, sp_q30_t s, sp_q30_t c, int32_t e, int32_t de, int32_t dde, int32_t rate,
                           int64_t out[3], sp_flags_t *flags)
{
    int32_t wc = spi_mul_away(g->omega, c, 30u, flags); /* omega cos(theta), rad/s, Q24 */
    if (rate == 0) {
        /* at full amplitude, e = 1 (2^30) and e' = e'' = 0: a product by
         * e is its other factor exactly (round(x 2^30 / 2^30) = x, no
         * saturation), those by e' and e'' are 0: the same values */
        out[0] = spi_round_away(s, 6u);
        out[1] = wc;
        out[2] =
            g->wide ? -trig_mul_q30(g->omega2, s, flags) : -(int64_t)spi_mul_away((int32_t)g->omega2, s, 30u, flags);
    } else {
        out[0] = spi_round_away((int64_t)spi_mul_away(s, e, 30u, flags), 6u); /* s e, Q24 */
        out[1] = (int64_t)spi_mul_away(wc, e, 30u, flags) + spi_mul_away(de, s, 30u, flags);
        out[2] = g->wide ? trig_acc_wide(g, s, e, wc, de, dde, rate, flags)
                         : -(int64_t)spi_mul_away(spi_mul_away((int32_t)g->omega2, s, 30u, flags), e, 30u, flags) +
                               2 * (int64_t)spi_mul_away(wc, de, 24u, flags) +
                               spi_mul_away(spi_mul_away(dde, rate, 24u, flags), s, 30u, flags);
    }
}

sp_status_t sp_trig_step(sp_trig_t *g, uint32_t tick_us, sp_motion_t *out)
{
    sp_flags_t flags = 0u;
    int32_t u;
    int32_t e;
    int32_t de;
    int32_t dde;
    int32_t rate;  /* du/dt, 1/s, Q24 */
    int32_t theta; /* phase, rad, Q24 */
    sp_q30_t s;
    sp_q30_t c;
    int64_t m[3]; /* offset, velocity, acceleration per unit amplitude, Q24 */
    unsigned a;

    if (g == NULL || out == NULL || tick_us < 1u) {
        return SP_E_ARG;
    }
    sp_motion_at_rest(out, &g->centre);
    if (g->finished) {
        return SP_OK;
    }
    /* envelope position u (Q30), its rate du/dt and the smoothstep of u;
     * at full amplitude (u = 1) E = 1 and E' = E'' = 0 exactly */
    if (g->stop_tick != UINT32_MAX && g->tick >= g->stop_tick) {
        uint32_t k = g->tick - g->stop_tick;
        if (k >= g->fade_ticks) {
            g->finished = 1;
            return SP_OK;
        }
        u = (int32_t)udiv64((uint64_t)(g->fade_ticks - k) << 30, g->fade_ticks);
        rate = -fade_rate(g, tick_us, &flags);
    } else if (g->tick < g->fade_ticks) {
        if (g->tick == 0u) {
            return trig_first(g, tick_us);
        }
        u = (int32_t)udiv64((uint64_t)g->tick << 30, g->fade_ticks);
        rate = fade_rate(g, tick_us, &flags);
    } else {
        u = SP_Q30_ONE;
        rate = 0;
    }
    if (rate == 0) {
        e = SP_Q30_ONE;
        de = 0;
        dde = 0;
    } else {
        smoothstep(u, &e, &de, &dde);
        /* e' = E'(u) du/dt, Q24; E'' du/dt (below 5.77 x 10 / s, Q24) */
        de = spi_mul_away(de, rate, 24u, &flags);
        dde = spi_mul_away(dde, rate, 24u, &flags);
    }

    theta = (int32_t)spi_round_away((int64_t)(int32_t)g->phase * TWO_PI_Q24, 32u);
    sp_sincos_q24(theta, &s, &c);
    trig_terms(g, s, c, e, de, dde, rate, m, &flags);

    /* times the amplitude A */
    a = (unsigned)g->axis;
    *axis_ref(&out->pose, a) =
        spi_add(*axis_ref(&out->pose, a), spi_mul_away(g->amplitude, spi_sat(m[0], &flags), 24u, &flags), &flags);
    *vec_ref(out, a, 1) = spi_mul_away(g->amplitude, spi_sat(m[1], &flags), 24u, &flags);
    /* a wide motion: |A| <= 2^24 and |acc| < 2^38, the product fits; the
     * result below SP_TRIG_ACC_MAX (sp_trig_start) */
    *vec_ref(out, a, 2) = g->wide ? spi_sat(spi_round_away((int64_t)g->amplitude * m[2], 24u), &flags)
                                  : spi_mul_away(g->amplitude, spi_sat(m[2], &flags), 24u, &flags);

    g->phase += g->phase_step; /* modulo one turn by design */
    /* counts the fade-in and the fade-out only: a tick counting the whole
     * motion would saturate after 49.7 days at the stop sentinel and the
     * motion could not be stopped any more */
    if (g->tick < g->fade_ticks || g->stop_tick != UINT32_MAX) {
        ++g->tick;
    }
    return sp_flags_status(flags);
}

/* The value of axis a (0..5: x, y, z, roll, pitch, yaw) of a pose. */
static sp_q24_t axis_of(const sp_pose_t *pose, unsigned a)
{
    return (a < 3u) ? pose->pos[a] : pose->rpy[a - 3u];
}

/* ceil(n / d) for d >= 1 and n < 2^64 - 2^32 (the plan's bounds: n <
 * 2^32 * 6e10): the 32-bit division whenever the quotient fits. */
static uint64_t ceil_div(uint64_t n, uint32_t d)
{
    return udiv64(n + d - 1u, d);
}

/* Smallest r with r^3 >= v (v < 2^63); bounded bisection. */
static uint64_t icbrt_ceil(uint64_t v)
{
    uint64_t lo = 0u;
    uint64_t hi = 2097152u; /* 2^21: hi^3 = 2^63 */
    while (lo < hi) {       /* at most 22 steps */
        uint64_t mid = (lo + hi) / 2u;
        if (mid * mid * mid >= v) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

/* Smallest r with r^2 >= v (v < 2^63). */
static uint64_t isqrt_ceil(uint64_t v)
{
    uint64_t r = sp_isqrt64(v);
    return r + ((r * r < v) ? 1u : 0u);
}

sp_status_t sp_move_plan(sp_move_t *mv, const sp_pose_t *from, const sp_pose_t *to, const sp_move_limits_t *lim,
                         uint32_t tick_us)
{
    uint64_t t_ms = 0u;
    uint64_t t_acc[6];  /* T^2 of the acceleration bound per axis, ms^2 (0: at rest) */
    uint64_t t_jerk[6]; /* T^3 of the jerk bound per axis, ms^3 */
    unsigned a;

    if (mv == NULL || from == NULL || to == NULL || lim == NULL || tick_us < 1u || tick_us > 100000u) {
        return SP_E_ARG;
    }
    mv->from = *from;
    mv->to = *from;
    mv->duration_ticks = 0u;
    mv->tick = 0u;
    mv->rate_tick_us = 0u;
    mv->rate = 0;
    for (a = 0u; a < 6u; ++a) {
        int64_t d = (int64_t)axis_of(to, a) - axis_of(from, a);
        uint64_t dm = (uint64_t)(d < 0 ? -d : d); /* Q24, < 2^32 */
        uint64_t t;
        t_acc[a] = 0u;
        t_jerk[a] = 0u;
        if (lim->vel_max[a] <= 0 || lim->acc_max[a] <= 0 || lim->jerk_max[a] <= 0) {
            return SP_E_ARG;
        }
        if (dm == 0u) {
            continue;
        }
        /* velocity: T = 1.875 D / v, ms */
        t = ceil_div(dm * 1875u, (uint32_t)lim->vel_max[a]);
        t_ms = t > t_ms ? t : t_ms;
        /* acceleration: T^2 = 5.7735 D / a; in ms^2: 5773503 D / a */
        t = ceil_div(dm * 5773503u, (uint32_t)lim->acc_max[a]);
        if (t > MOVE_MAX_MS * MOVE_MAX_MS) {
            return SP_E_RANGE;
        }
        t_acc[a] = t;
        /* jerk: T^3 = 60 D / j; in ms^3: 6e10 D / j. D < 16 m keeps the
         * product below 2^64. */
        if (dm >= (UINT64_C(1) << 28)) {
            return SP_E_RANGE;
        }
        t = ceil_div(dm * UINT64_C(60000000000), (uint32_t)lim->jerk_max[a]);
        if (t > MOVE_MAX_MS * MOVE_MAX_MS * MOVE_MAX_MS) {
            return SP_E_RANGE;
        }
        t_jerk[a] = t;
    }
    /* T = the largest bound of all axes. A root needs computing only
     * where its power exceeds the largest T so far: its root is then
     * larger (otherwise it is not, and the maximum is the same). An axis
     * at rest has no bounds (0) */
    for (a = 0u; a < 6u; ++a) {
        if (t_ms > MOVE_MAX_MS) {
            return SP_E_RANGE;
        }
        if (t_acc[a] == 0u) {
            continue;
        }
        if (t_acc[a] > t_ms * t_ms) {
            t_ms = isqrt_ceil(t_acc[a]);
        }
        if (t_jerk[a] > t_ms * t_ms * t_ms) {
            t_ms = icbrt_ceil(t_jerk[a]);
        }
    }
    if (t_ms > MOVE_MAX_MS) {
        return SP_E_RANGE;
    }
    mv->to = *to;
    /* t_ms <= 6e5 and tick_us <= 1e5: the sum is below 2^32 */
    mv->duration_ticks = ((uint32_t)t_ms * 1000u + tick_us - 1u) / tick_us;
    return SP_OK;
}

sp_status_t sp_move_step(sp_move_t *mv, uint32_t tick_us, sp_motion_t *out, int *done)
{
    sp_flags_t flags = 0u;
    int32_t u;
    int32_t e;
    int32_t de;
    int32_t dde;
    int32_t rate;
    unsigned a;

    if (mv == NULL || out == NULL || done == NULL || tick_us < 1u) {
        return SP_E_ARG;
    }
    if (mv->tick >= mv->duration_ticks) {
        sp_motion_at_rest(out, &mv->to);
        *done = 1;
        return SP_OK;
    }
    *done = 0;
    sp_motion_at_rest(out, &mv->from);
    if (mv->tick == 0u || mv->rate_tick_us != tick_us) {
        /* once per move (and whenever the tick length changes) */
        mv->rate = inv_duration_q24((uint64_t)mv->duration_ticks * tick_us, &flags);
        mv->rate_tick_us = (flags == 0u) ? tick_us : 0u; /* a saturated rate is not kept */
    }
    if (mv->tick == 0u) {
        /* the first sample, u = 0: E = E' = E'' = 0, so every product
         * below is 0 and the sample is `from` at rest, as set above (the
         * move's command tick: no smoothstep, no division) */
        ++mv->tick;
        return sp_flags_status(flags);
    }
    u = (int32_t)udiv64((uint64_t)mv->tick << 30, mv->duration_ticks);
    rate = mv->rate;
    smoothstep(u, &e, &de, &dde);
    for (a = 0u; a < 6u; ++a) {
        int32_t from = (a < 3u) ? mv->from.pos[a] : mv->from.rpy[a - 3u];
        int32_t to = (a < 3u) ? mv->to.pos[a] : mv->to.rpy[a - 3u];
        int64_t d = (int64_t)to - from;
        int32_t dv;
        int32_t da;
        int64_t dp;
        if (d == 0) {
            continue; /* an axis that does not move: at rest at `from`, as set above */
        }
        if (d >= INT32_MIN && d <= INT32_MAX) {
            /* the common case, |d| < 128 m or rad: 32x32 products, the
             * same values as below */
            int32_t d32 = (int32_t)d;
            dv = spi_sat(spi_round_away((int64_t)d32 * de, 24u), &flags);
            da = spi_sat(spi_round_away((int64_t)d32 * dde, 24u), &flags);
            dp = spi_round_away((int64_t)d32 * e, 30u);
        } else {
            /* D E'(u) first, then the time scale: a short move has a large
             * rate but a small distance, and neither product saturates.
             * |d| < 2^33 and the factors are int32: products below
             * 2^63 - 2^32 */
            dv = spi_narrow_away(d * de, 24u, &flags);
            da = spi_narrow_away(d * dde, 24u, &flags);
            dp = spi_round_away64(d * e, 30u);
        }
        {
            sp_q24_t *p = axis_ref(&out->pose, a);
            *p = spi_sat(*p + dp, &flags);
        }
        *vec_ref(out, a, 1) = spi_sat(spi_round_away((int64_t)dv * rate, 24u), &flags);
        *vec_ref(out, a, 2) = spi_sat(
            spi_round_away((int64_t)spi_sat(spi_round_away((int64_t)da * rate, 24u), &flags) * rate, 24u), &flags);
    }
    ++mv->tick;
    return sp_flags_status(flags);
}
