/* SPDX-License-Identifier: Apache-2.0 */
/* sensor.c - quantisation and the seeded noise generator (hs/sensor.h). */
#include "hs/sensor.h"

#include <math.h>

void hs_rng_seed(hs_rng_t *r, uint64_t seed)
{
    r->s = seed;
}

uint64_t hs_rng_next(hs_rng_t *r)
{
    /* splitmix64 */
    uint64_t z;
    r->s += UINT64_C(0x9E3779B97F4A7C15);
    z = r->s;
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

double hs_rng_gauss(hs_rng_t *r)
{
    /* Four uniform integers 0..65535: the sum has mean 131070 and variance
     * 4 (65536^2 - 1) / 12 = 1431655765 exactly. */
    static const double inv_sd = 2.6428997921303014e-05; /* 1 / sqrt(1431655765) */
    uint64_t z = hs_rng_next(r);
    uint64_t sum = (z & 0xFFFFu) + ((z >> 16) & 0xFFFFu) + ((z >> 32) & 0xFFFFu) + (z >> 48);
    return ((double)sum - 131070.0) * inv_sd;
}

int64_t hs_quantize(double value, double resolution)
{
    const double lim = 9007199254740992.0; /* 2^53 */
    double q;
    if (!(resolution > 0.0) || value != value) {
        return 0;
    }
    q = value / resolution;
    if (q >= lim) {
        return (int64_t)lim;
    }
    if (q <= -lim) {
        return -(int64_t)lim;
    }
    /* |q| < 2^53: truncation of q +- 0.5 rounds ties away from zero, except
     * where q + 0.5 itself rounds (|q| >= 2^52, where q is already integral) */
    if (q >= 4503599627370496.0 || q <= -4503599627370496.0) {
        return (int64_t)q;
    }
    return (int64_t)((q >= 0.0) ? q + 0.5 : q - 0.5);
}
