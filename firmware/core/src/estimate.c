#include "sp/estimate.h"

#include "fixed_inline.h"

void sp_estimate_init(sp_estimate_t *e, const sp_pose_t *park)
{
    e->pose = *park;
    e->valid = 0u;
    e->cache_valid = 0u;
    e->ref_lu.valid = 0u;
}

/* Is every axis of a within SP_ESTIMATE_CHORD_NEAR of b? */
static int near_pose(const sp_pose_t *a, const sp_pose_t *b)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (spi_farther(a->pos[k], b->pos[k], SP_ESTIMATE_CHORD_NEAR) ||
            spi_farther(a->rpy[k], b->rpy[k], SP_ESTIMATE_CHORD_NEAR)) {
            return 0;
        }
    }
    return 1;
}

sp_status_t sp_estimate_step(const sp_platform_t *platform, sp_estimate_t *e, const sp_q24_t length[SP_LEGS],
                             const sp_pose_t *reference, uint32_t *iterations)
{
    sp_fk_options_t opt;
    sp_fk_info_t info;
    sp_pose_t est;
    sp_status_t st = SP_E_NO_CONVERGENCE;

    sp_fk_default_options(&opt);
    if (!e->valid) {
        /* cold start from the parked pose, no continuity to check */
        opt.max_iterations = SP_ESTIMATE_COLD_STEPS;
        opt.max_jump_pos = INT32_MAX;
        opt.max_jump_rot = INT32_MAX;
    }
    info.iterations = 0u;
    if (e->valid && e->cache_valid && e->ref_lu.valid && near_pose(&e->pose, reference)) {
        /* chord steps with last tick's factorisation of J^T, from the
         * estimate's cached lengths and sines */
        sp_fk_options_t copt = opt;
        copt.max_iterations = SP_ESTIMATE_CHORD_STEPS;
        st = sp_fk_chord(platform, length, &e->pose, &e->ref_lu, &copt, &e->cache, &est, &info);
    }
    if (st != SP_OK) {
        /* full Newton from the guess, refilling the cache */
        st = sp_fk_newton_cached(platform, length, e->valid ? &e->pose : &platform->park, &opt, &e->cache, &est, &info);
        e->cache_valid = (st == SP_OK) ? 1u : 0u;
    }
    *iterations = info.iterations;
    if (st == SP_OK) {
        e->pose = est;
        e->valid = 1u;
    } else {
        e->valid = 0u;
        e->cache_valid = 0u;
    }
    return st;
}
