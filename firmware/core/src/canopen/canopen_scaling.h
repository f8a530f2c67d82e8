/* SPDX-License-Identifier: Apache-2.0 */
/*
 * canopen_scaling.h - the per-tick arithmetic of sp_co_scaling_t (private
 * to the core: canopen_master.c's public sp_co_length_to_count and
 * sp_co_count_to_length, and canopen_link.c's loops over the legs, which
 * inline it). The rules are those of sp/canopen/canopen_master.h; the unit tests
 * compare both directions with a long double reference over the range.
 *
 * Magnitudes fit 32 bits (|length - zero| < 2^32, |count| <= 2^31), so
 * each conversion is one 32 x 32 (or 32 x 64) bit product, a rounding
 * shift and the sign put back: no division per value. Always inlined
 * (SPI_INLINE), also at -Os: the check alone costs less than the call.
 */
#ifndef SP_CANOPEN_SCALING_H
#define SP_CANOPEN_SCALING_H

#include "math/fixed_inline.h"
#include "sp/canopen/canopen_master.h"

/* 1 when s is usable: the fields in their ranges and the factors prepared. */
SPI_INLINE int spi_co_scaling_ok(const sp_co_scaling_t *s)
{
    return s != NULL && s->nm_per_count >= 1u && s->nm_per_count <= 1000000u &&
           (s->direction == 1 || s->direction == -1) && s->count_per_q24 != 0u && s->q24_per_count_q28 != 0u;
}

/* round(q / 2^shift) as an int32 with the sign neg, saturated (*st = SP_E_OVERFLOW). */
SPI_INLINE int32_t spi_co_signed_round(uint64_t q, unsigned shift, int neg, sp_status_t *st)
{
    uint64_t r = (q + ((uint64_t)1 << (shift - 1u))) >> shift;
    if (neg) {
        if (r > (uint64_t)INT32_MAX + 1u) {
            *st = SP_E_OVERFLOW;
            return INT32_MIN;
        }
        return r == (uint64_t)INT32_MAX + 1u ? INT32_MIN : -(int32_t)r;
    }
    if (r > (uint64_t)INT32_MAX) {
        *st = SP_E_OVERFLOW;
        return INT32_MAX;
    }
    return (int32_t)r;
}

/* sp_co_length_to_count of a checked scaling (spi_co_scaling_ok). */
SPI_INLINE sp_status_t spi_co_length_to_count(const sp_co_scaling_t *s, int32_t length_q24, int32_t *count)
{
    sp_status_t st = SP_OK;
    int below = length_q24 < s->zero_q24;
    uint32_t d = (uint32_t)length_q24 - (uint32_t)s->zero_q24; /* modulo 2^32: |length - zero| < 2^32 */
    uint32_t mag = below ? 0u - d : d;
    /* mag x count_per_q24 < 2^32 x 2^30 */
    *count = spi_co_signed_round((uint64_t)mag * s->count_per_q24, 24u, below != (s->direction < 0), &st);
    return st;
}

/* sp_co_count_to_length of a checked scaling (spi_co_scaling_ok). */
SPI_INLINE sp_status_t spi_co_count_to_length(const sp_co_scaling_t *s, int32_t count, int32_t *length_q24)
{
    sp_status_t st = SP_OK;
    int neg = (count < 0) != (s->direction < 0);
    uint32_t mag = count < 0 ? 0u - (uint32_t)count : (uint32_t)count; /* |count| <= 2^31 */
    uint64_t q24;
    int64_t len;
    if ((int64_t)mag > s->count_limit) {
        *length_q24 = !neg && mag != 0u ? INT32_MAX : INT32_MIN;
        return SP_E_OVERFLOW;
    }
    /* mag x nm < 2^37 nm-counts, x 2^52 / 1e9 < 2^60 */
    q24 = ((uint64_t)mag * s->q24_per_count_q28 + ((uint64_t)1 << 27)) >> 28;
    len = (int64_t)s->zero_q24 + (neg ? -(int64_t)q24 : (int64_t)q24);
    if (len > INT32_MAX) {
        *length_q24 = INT32_MAX;
        st = SP_E_OVERFLOW;
    } else if (len < INT32_MIN) {
        *length_q24 = INT32_MIN;
        st = SP_E_OVERFLOW;
    } else {
        *length_q24 = (int32_t)len;
    }
    return st;
}

/* sp_co_force_to_permille of a checked scaling with a rated force: force
 * (N Q8, |force| <= 2^31) x permille_per_n_q24 (< 2^28) < 2^59 is per mille
 * in Q32, rounded half away from zero, saturated to INT16. */
SPI_INLINE sp_status_t spi_co_force_to_permille(const sp_co_scaling_t *s, sp_q8_t force_q8, int16_t *permille)
{
    int neg = (force_q8 < 0) != (s->direction < 0);
    uint32_t mag = force_q8 < 0 ? 0u - (uint32_t)force_q8 : (uint32_t)force_q8;
    uint64_t r = ((uint64_t)mag * s->permille_per_n_q24 + ((uint64_t)1 << 31)) >> 32;
    if (r > (uint64_t)INT16_MAX) {
        *permille = neg ? (int16_t)INT16_MIN : (int16_t)INT16_MAX;
        return SP_E_OVERFLOW;
    }
    *permille = neg ? (int16_t) - (int32_t)r : (int16_t)r;
    return SP_OK;
}

#endif /* SP_CANOPEN_SCALING_H */
