/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/sensor.h - the sensor models: quantisation and a seeded, portable
 * noise generator (no rand(), no libm in the noise path, so a seed gives the
 * same sequence on every machine and compiler).
 */
#ifndef HS_SENSOR_H
#define HS_SENSOR_H

#include <stdint.h>

/** Generator state (splitmix64: a 64-bit counter stepped by the golden-ratio
 *  increment and mixed; period 2^64). */
typedef struct {
    uint64_t s;
} hs_rng_t;

/** Seeds the generator; any seed (0 included) is valid. */
void hs_rng_seed(hs_rng_t *r, uint64_t seed);

/** Next 64 uniformly distributed bits. */
uint64_t hs_rng_next(hs_rng_t *r);

/**
 * Gaussian-like sample with mean 0 and variance 1: the sum of four
 * independent uniform 16-bit integers, centred and scaled (Irwin-Hall,
 * n = 4), computed exactly in double. Bounded to +-3.47 (no outliers
 * beyond that, unlike a true Gaussian). One hs_rng_next per sample.
 */
double hs_rng_gauss(hs_rng_t *r);

/**
 * value / resolution rounded to the nearest integer, ties away from zero,
 * saturated to +-2^53 (and 0 for NaN). resolution must be > 0 (else 0).
 */
int64_t hs_quantize(double value, double resolution);

#endif /* HS_SENSOR_H */
