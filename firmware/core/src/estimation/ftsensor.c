/* SPDX-License-Identifier: Apache-2.0 */
/*
 * ftsensor.c - the force/torque sensor's wrench in the controller's frame,
 * and its tare (sp/estimation/ftsensor.h).
 */
#include "sp/estimation/ftsensor.h"

#include "math/fixed_inline.h"

#include <stddef.h>

#define IN_MAX (INT64_C(1) << 30)

static int64_t clamp_in(int64_t v, int *sat)
{
    if (v > IN_MAX || v < -IN_MAX) {
        *sat = 1;
        return (v > 0) ? IN_MAX : -IN_MAX;
    }
    return v;
}

static int64_t round_shift(int64_t v, unsigned s)
{
    return (v + (INT64_C(1) << (s - 1u))) >> s;
}

sp_status_t sp_ft_frame(const sp_ft_mount_t *mount, const sp_rot_t *T, sp_ft_frame_t *fr)
{
    if (mount == NULL || T == NULL || fr == NULL) {
        return SP_E_ARG;
    }
    sp_flags_t flags = 0u;
    /* S = T^T R_m (base <- sensor), Q30; r = T^T pos, Q24 */
    for (unsigned i = 0; i < 3u; ++i) {
        int64_t acc_r = 0;
        for (unsigned j = 0; j < 3u; ++j) {
            int64_t acc = 0;
            for (unsigned k = 0; k < 3u; ++k) {
                acc += (int64_t)T->t[k][i] * mount->axes.t[k][j];
            }
            fr->s[i][j] = sp_sat32(round_shift(acc, 30u), &flags);
            acc_r += (int64_t)T->t[j][i] * mount->pos[j];
        }
        fr->r[i] = sp_sat32(round_shift(acc_r, 30u), &flags);
    }
    return (flags != 0u) ? SP_E_OVERFLOW : SP_OK;
}

sp_status_t sp_ft_apply(const sp_ft_frame_t *fr, const sp_q8_t reading[6], sp_q8_t out[6])
{
    static const sp_q8_t no_bias[6] = {0, 0, 0, 0, 0, 0};
    return sp_ft_apply_tared(fr, reading, no_bias, out); /* reading - 0: the reading */
}

sp_status_t sp_ft_apply_tared(const sp_ft_frame_t *fr, const sp_q8_t reading[6], const sp_q8_t bias[6], sp_q8_t out[6])
{
    if (fr == NULL || reading == NULL || bias == NULL || out == NULL) {
        return SP_E_ARG;
    }
    int sat = 0;
    /* the reading less the bias held within +-2^30: each product with an
     * int32 entry of S below 2^61, three of them below 2^63 */
    int32_t f_s[3], m_s[3];
    for (unsigned k = 0; k < 3u; ++k) {
        f_s[k] = (int32_t)clamp_in((int64_t)reading[k] - bias[k], &sat);
        m_s[k] = (int32_t)clamp_in((int64_t)reading[3u + k] - bias[3u + k], &sat);
    }
    sp_flags_t flags = 0u;
    int64_t f[3], m[3];
    for (unsigned i = 0; i < 3u; ++i) {
        const int32_t *si = fr->s[i];
        f[i] = round_shift((int64_t)si[0] * f_s[0] + (int64_t)si[1] * f_s[1] + (int64_t)si[2] * f_s[2], 30u); /* Q8 */
        m[i] = (int64_t)si[0] * m_s[0] + (int64_t)si[1] * m_s[1] + (int64_t)si[2] * m_s[2];                   /* Q38 */
    }
    /* r x F: Q24 x Q8 = Q32; r within +-128 m and F within +-2^30: each product below 2^61 */
    int32_t fc[3];
    for (unsigned i = 0; i < 3u; ++i) {
        fc[i] = (int32_t)((f[i] > IN_MAX) ? IN_MAX : ((f[i] < -IN_MAX) ? -IN_MAX : f[i]));
    }
    const int32_t *r = fr->r;
    int64_t rx[3] = {(int64_t)r[1] * fc[2] - (int64_t)r[2] * fc[1], (int64_t)r[2] * fc[0] - (int64_t)r[0] * fc[2],
                     (int64_t)r[0] * fc[1] - (int64_t)r[1] * fc[0]};
    for (unsigned i = 0; i < 3u; ++i) {
        out[i] = spi_sat(f[i], &flags);
        out[3u + i] = spi_sat(round_shift(m[i], 30u) + round_shift(rx[i], 24u), &flags);
    }
    return (sat || flags != 0u) ? SP_E_OVERFLOW : SP_OK;
}

sp_status_t sp_ft_to_base(const sp_ft_mount_t *mount, const sp_rot_t *T, const sp_q8_t reading[6], sp_q8_t out[6])
{
    if (mount == NULL || T == NULL || reading == NULL || out == NULL) {
        return SP_E_ARG;
    }
    sp_ft_frame_t fr;
    sp_status_t a = sp_ft_frame(mount, T, &fr);
    sp_status_t b = sp_ft_apply(&fr, reading, out);
    return (a != SP_OK) ? a : b;
}

void sp_ft_tare_reset(sp_ft_tare_t *t)
{
    if (t == NULL) {
        return;
    }
    for (unsigned k = 0; k < 6u; ++k) {
        t->sum[k] = 0;
        t->bias[k] = 0;
    }
    t->count = 0u;
    t->needed = 0u;
    t->tared = 0u;
}

sp_status_t sp_ft_tare_start(sp_ft_tare_t *t, uint32_t samples)
{
    if (t == NULL || samples < 1u || samples > 65536u) {
        return SP_E_ARG;
    }
    for (unsigned k = 0; k < 6u; ++k) {
        t->sum[k] = 0;
    }
    t->count = 0u;
    t->needed = samples;
    return SP_OK;
}

sp_status_t sp_ft_tare_step(sp_ft_tare_t *t, const sp_q8_t reading[6], sp_q8_t out[6])
{
    if (t == NULL || reading == NULL || out == NULL) {
        return SP_E_ARG;
    }
    sp_status_t st = SP_OK;
    if (t->needed != 0u) {
        for (unsigned k = 0; k < 6u; ++k) {
            t->sum[k] += reading[k]; /* at most 65536 x 2^31: no overflow */
        }
        if (++t->count >= t->needed) {
            for (unsigned k = 0; k < 6u; ++k) {
                int64_t n = (int64_t)t->needed;
                int64_t q = (t->sum[k] >= 0) ? (t->sum[k] + n / 2) / n : -((-t->sum[k] + n / 2) / n);
                t->bias[k] = (sp_q8_t)q; /* a mean of int32 values fits */
            }
            t->needed = 0u;
            t->tared = 1u;
        } else {
            st = SP_E_BUSY;
        }
    }
    sp_flags_t flags = 0u;
    for (unsigned k = 0; k < 6u; ++k) {
        out[k] = spi_sat((int64_t)reading[k] - t->bias[k], &flags);
    }
    return (flags != 0u) ? SP_E_OVERFLOW : st;
}
