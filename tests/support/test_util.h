/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_util.h - shared helpers of the C tests and benchmarks: a seeded,
 * portable random generator (so every run checks the same inputs and a
 * failure can be replayed) and TU_LDEXP for long double references.
 */
#ifndef TEST_UTIL_H
#define TEST_UTIL_H

#include <stdint.h>

/* splitmix64: a small, well-mixed 64-bit generator. */
static inline uint64_t tu_next(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* Uniform int32 over the whole range. */
static inline int32_t tu_i32(uint64_t *state)
{
    return (int32_t)(uint32_t)(tu_next(state) >> 32);
}

/* Uniform real in [lo, hi). */
static inline double tu_uniform(uint64_t *state, double lo, double hi)
{
    return lo + (hi - lo) * ((double)(tu_next(state) >> 11) * (1.0 / 9007199254740992.0));
}

/* An int32 whose magnitude is spread over all bit widths (log-uniform), so
 * that small values are tested as often as large ones. */
static inline int32_t tu_i32_logscale(uint64_t *state)
{
    uint64_t r = tu_next(state);
    unsigned bits = (unsigned)(r % 32u);
    int32_t v = (int32_t)((r >> 8) & ((UINT64_C(1) << bits) - 1u));
    return ((r >> 63) != 0u) ? -v : v;
}

#define TU_LDEXP(x, e) ((long double)(x)*powl(2.0L, (long double)(e)))

#endif
