/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/estimation/wrench.h"

#include "math/fixed_inline.h"

void sp_wrench_reset(sp_wrench_t *w)
{
    unsigned k;
    unsigned n;
    if (w == NULL) {
        return;
    }
    for (k = 0u; k < 6u; ++k) {
        w->wrench[k] = 0;
        w->force_wrench[k] = 0;
        for (n = 0u; n < SP_WRENCH_SECTIONS; ++n) {
            w->section[n][k] = 0;
        }
        w->smooth[k] = 0;
        w->slow[k] = 0;
        w->follow[k] = 0u;
        w->excess[k] = 0u;
    }
    w->have_force = 0u;
    w->valid = 0u;
    w->smooth_valid = 0u;
}

sp_status_t sp_wrench_alpha(sp_q24_t hz, uint32_t tick_us, sp_q30_t *alpha)
{
    sp_flags_t flags = 0u;
    int64_t wdt; /* 2 pi f dt, Q24 */
    if (alpha == NULL || hz <= 0 || tick_us == 0u || tick_us > 1000000u) {
        return SP_E_ARG;
    }
    /* 2 pi (Q24) x f (Q24) >> 24 = w (Q24, < 2^34), x dt */
    wdt = (((int64_t)SPI_Q24_TWO_PI * hz) >> 24) * (int64_t)tick_us / 1000000;
    if (wdt > (INT64_C(8) << 24)) {
        return SP_E_RANGE;
    }
    *alpha = sp_div(wdt, (int32_t)(wdt + (INT64_C(1) << 24)), 30u, &flags);
    return (flags == 0u) ? SP_OK : SP_E_RANGE;
}

/* |F_model - F| is clamped to 2^29 (2 MN in Q8, beyond any cylinder), so
 * each product with a Jacobian entry (< 2^31) stays below 2^60 and the sum
 * of six below 2^63. */
#define WRENCH_D_MAX (INT64_C(1) << 29)
/* Each component is held within [-2^30, 2^30 - 1] (4.19 MN, 4.19 MN m in
 * Q8): the filter's step raw - W then fits an int32 (one 32 x 32 product),
 * and the filtered value, between W and raw, needs no saturation. */
#define WRENCH_HI INT64_C(0x3FFFFFFF)
#define WRENCH_LO (-WRENCH_HI - 1)

/* The clamped model error F_model + F_friction - F, N, Q8. */
SPI_INLINE int32_t wrench_d(int32_t model_force, int32_t friction, int32_t measured)
{
    int64_t v = (int64_t)model_force + friction - measured;
    return (int32_t)((v > WRENCH_D_MAX) ? WRENCH_D_MAX : ((v < -WRENCH_D_MAX) ? -WRENCH_D_MAX : v));
}

/* acc = J^T d (Q28 x Q8 = Q36, exact), three components at a time, leg by
 * leg (a column of J^T at a time), the legs written out: three
 * accumulators stay in registers, where six would not. */
#define WRENCH_LEG(i)                                                                                                  \
    do {                                                                                                               \
        const int32_t *row = &jac->j[(i)][k];                                                                          \
        int32_t di = d[(i)];                                                                                           \
        a0 += (int64_t)row[0] * di;                                                                                    \
        a1 += (int64_t)row[1] * di;                                                                                    \
        a2 += (int64_t)row[2] * di;                                                                                    \
    } while (0)

static void wrench_sums(const sp_jacobian_t *jac, const int32_t d[SP_LEGS], int64_t acc[6])
{
    unsigned k;
    for (k = 0u; k < 6u; k += 3u) {
        int64_t a0 = 0;
        int64_t a1 = 0;
        int64_t a2 = 0;
        WRENCH_LEG(0);
        WRENCH_LEG(1);
        WRENCH_LEG(2);
        WRENCH_LEG(3);
        WRENCH_LEG(4);
        WRENCH_LEG(5);
        acc[k] = a0;
        acc[k + 1u] = a1;
        acc[k + 2u] = a2;
    }
}

/* One component of the filter's input: the kept force path (Q8, J^T d
 * of the previous tick, |.| < 2^35) plus the correction (Q8), held within
 * [WRENCH_LO, WRENCH_HI]. */
SPI_INLINE int32_t wrench_raw(int64_t force_wrench, int32_t correction)
{
    int64_t x = force_wrench + correction;
    return (x > WRENCH_HI) ? (int32_t)WRENCH_HI : ((x < WRENCH_LO) ? (int32_t)WRENCH_LO : (int32_t)x);
}

/* One section: y + round(alpha (x - y)) (ties up) for x and y within
 * [WRENCH_LO, WRENCH_HI] and alpha in [0, 2^30]: x - y then fits an int32
 * and the result lies between y and x (0 <= alpha (x - y) / 2^30 <= x - y
 * for x >= y, rounding to an integer between the two, and the mirror for
 * x < y), so within the range again. The state y is not held in the range
 * here: it cannot leave it. Every section's value is 0 (sp_wrench_reset),
 * a raw input (wrench_raw: in the range) or this function's result (in the
 * range, by the above); the smoother's w->slow is w->wrench (a section's
 * value) or this function's result. By induction over the ticks each state
 * stays within [WRENCH_LO, WRENCH_HI] (test_wrench_state_stays_in_range
 * runs the step and the smoother over inputs of every size and checks it;
 * test_wrench_matches_reference compares with a plain reference that holds
 * y in the range, as this function did until session 15). */
SPI_INLINE int32_t wrench_section(int32_t y, int32_t x, sp_q30_t alpha)
{
    return y + (int32_t)(((int64_t)alpha * (x - y) + (INT64_C(1) << 29)) >> 30);
}

/* No correction: six zeros, read as a correction would be (a NULL test
 * in the loop had GCC -O3 make a copy of the loop per case: 1.1 KiB more
 * on the M4, and 23 instructions more a tick). */
static const sp_q8_t wrench_zero[6] = {0, 0, 0, 0, 0, 0};

void sp_wrench_step(sp_wrench_t *w, const sp_model_t *model, const sp_q8_t friction[SP_LEGS],
                    const sp_q8_t measured[SP_LEGS], const sp_q8_t correction[6], sp_q30_t alpha)
{
    unsigned i;
    unsigned k;
    int32_t d[SP_LEGS]; /* F_model + F_friction - F, N, Q8 */
    int64_t acc[6];     /* J^T d, Q36 */
    const sp_q8_t *c;
    if (model == NULL) {
        w->have_force = 0u;
        w->valid = 0u;
        return;
    }
    /* this tick's force path: model, friction, measurement and Jacobian
     * of one tick, rounded once to Q8 */
    for (i = 0u; i < SP_LEGS; ++i) {
        d[i] = wrench_d((friction != NULL) ? model->rigid[i] : model->force[i], (friction != NULL) ? friction[i] : 0,
                        measured[i]);
    }
    wrench_sums(&model->jac, d, acc);
    if (w->have_force) {
        /* alpha outside [0, 1] would leave the hull of last and raw */
        alpha = (alpha < 0) ? 0 : ((alpha > SP_Q30_ONE) ? SP_Q30_ONE : alpha);
        c = (correction != NULL) ? correction : wrench_zero;
        for (k = 0u; k < 6u; ++k) {
            /* the previous tick's force path with this tick's correction,
             * whose double difference is centred on the previous tick */
            int32_t x = wrench_raw(w->force_wrench[k], c[k]);
            unsigned n;
            if (w->valid) {
                for (n = 0u; n < SP_WRENCH_SECTIONS; ++n) {
                    x = wrench_section(w->section[n][k], x, alpha);
                    w->section[n][k] = x;
                }
            } else {
                /* the first estimate starts every section at its value */
                for (n = 0u; n < SP_WRENCH_SECTIONS; ++n) {
                    w->section[n][k] = x;
                }
            }
            w->wrench[k] = x;
        }
        w->valid = 1u;
    }
    for (k = 0u; k < 6u; ++k) {
        w->force_wrench[k] = (acc[k] + (INT64_C(1) << 27)) >> 28;
    }
    w->have_force = 1u;
}

/* One component of the smoother (sp_wrench_smooth): x the filtered
 * estimate and w->slow[k] within [WRENCH_LO, WRENCH_HI] (the section
 * holds them there), so x - v fits an int32; jump in [1, 2^30]. */
SPI_INLINE void wrench_smooth_one(sp_wrench_t *w, unsigned k, sp_q30_t alpha, int32_t jump, uint8_t persist,
                                  uint8_t hold)
{
    int32_t x = w->wrench[k];
    int32_t v;
    int32_t d;
    if (w->follow[k] > 0u) {
        w->follow[k] = (uint8_t)(w->follow[k] - 1u);
        w->slow[k] = x;
        w->smooth[k] = x;
        return;
    }
    v = wrench_section(w->slow[k], x, alpha); /* between the last value and x */
    d = x - v;
    /* |d| > jump, one unsigned comparison: d + jump wraps above 2 jump
     * (<= 2^31) for every d < -jump */
    if ((uint32_t)d + (uint32_t)jump > 2u * (uint32_t)jump) {
        w->excess[k] = (uint8_t)(w->excess[k] + 1u);
        if (w->excess[k] >= persist) {
            /* a jump: follow x from here */
            w->excess[k] = 0u;
            w->follow[k] = (uint8_t)(hold - 1u);
            v = x;
            w->smooth[k] = x;
        } else {
            /* jump < |d|: x -+ jump lies between v and x */
            w->smooth[k] = (d > 0) ? x - jump : x + jump;
        }
    } else {
        w->excess[k] = 0u;
        w->smooth[k] = v;
    }
    w->slow[k] = v;
}

/* A jump threshold held within [1, 2^30]. */
SPI_INLINE int32_t wrench_jump(int32_t j)
{
    return (j < 1) ? 1 : ((j > (INT32_C(1) << 30)) ? (INT32_C(1) << 30) : j);
}

void sp_wrench_smooth(sp_wrench_t *w, const sp_wrench_smooth_t *p)
{
    unsigned k;
    sp_q30_t alpha;
    int32_t jump;
    uint8_t persist;
    uint8_t hold;
    if (w == NULL || p == NULL) {
        return;
    }
    if (!w->valid || !w->smooth_valid) {
        for (k = 0u; k < 6u; ++k) {
            w->smooth[k] = w->wrench[k];
            w->slow[k] = w->wrench[k];
            w->follow[k] = 0u;
            w->excess[k] = 0u;
        }
        w->smooth_valid = w->valid;
        return;
    }
    alpha = (p->alpha < 0) ? 0 : ((p->alpha > SP_Q30_ONE) ? SP_Q30_ONE : p->alpha);
    persist = (p->persist < 1u) ? 1u : p->persist;
    hold = (p->hold < 1u) ? 1u : p->hold;
    jump = wrench_jump(p->jump[0]);
    for (k = 0u; k < 3u; ++k) {
        wrench_smooth_one(w, k, alpha, jump, persist, hold);
    }
    jump = wrench_jump(p->jump[1]);
    for (k = 3u; k < 6u; ++k) {
        wrench_smooth_one(w, k, alpha, jump, persist, hold);
    }
}
