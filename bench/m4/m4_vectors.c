/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_vectors.c - deterministic inputs of the bench/m4 programs
 * (m4_vectors.h). Integer arithmetic only.
 */
#include "m4_vectors.h"

void m4_rng_seed(m4_rng_t *rng, uint64_t seed)
{
    rng->state = seed;
}

uint32_t m4_rng_next(m4_rng_t *rng)
{
    uint64_t z = (rng->state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return (uint32_t)((z ^ (z >> 31)) >> 32);
}

int32_t m4_rng_range(m4_rng_t *rng, int32_t lim)
{
    /* multiply-shift: floor(r * (2 lim + 1) / 2^32) in [0, 2 lim] */
    uint64_t span = (uint64_t)(2 * (int64_t)lim + 1);
    return (int32_t)(((uint64_t)m4_rng_next(rng) * span) >> 32) - lim;
}

void m4_random_motion(m4_rng_t *rng, const sp_platform_t *platform, sp_motion_t *motion)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        motion->pose.pos[k] = platform->home.pos[k] + m4_rng_range(rng, (k == 2u) ? M4_BOX_Z : M4_BOX_XY);
        motion->pose.rpy[k] = platform->home.rpy[k] + m4_rng_range(rng, M4_BOX_ANGLE);
    }
    for (k = 0u; k < 3u; ++k) {
        motion->vel[k] = m4_rng_range(rng, M4_BOX_RATE);
        motion->rpy_rate[k] = m4_rng_range(rng, M4_BOX_RATE);
        motion->acc[k] = m4_rng_range(rng, M4_BOX_ACC);
        motion->rpy_acc[k] = m4_rng_range(rng, M4_BOX_ACC);
    }
}

void m4_nearby_pose(m4_rng_t *rng, const sp_pose_t *pose, sp_pose_t *guess)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        guess->pos[k] = pose->pos[k] + m4_rng_range(rng, M4_NEAR_POS);
        guess->rpy[k] = pose->rpy[k] + m4_rng_range(rng, M4_NEAR_ANGLE);
    }
}
