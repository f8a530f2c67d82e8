/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/estimation/estimate.h"

#include "model/model_internal.h"
#include "math/fixed_inline.h"

void sp_estimate_init(sp_estimate_t *e, const sp_pose_t *park)
{
    e->pose = *park;
    e->valid = 0u;
    e->ref_lu.valid = 0u;
}

/* Is every axis of a within the allowed jump of b (the FK's continuity
 * test, as fk_jump_check in fk.c)? */
static int within_jump(const sp_pose_t *a, const sp_pose_t *b, const sp_fk_options_t *opt)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (spi_farther(a->pos[k], b->pos[k], opt->max_jump_pos) ||
            spi_farther(a->rpy[k], b->rpy[k], opt->max_jump_rot)) {
            return 0;
        }
    }
    return 1;
}

/* The warm estimate from the reference into *est: the single step within
 * the bound, chord steps beyond it. SP_E_DISCONTINUITY when the result is
 * too far from the previous estimate. */
static sp_status_t from_reference(const sp_platform_t *platform, const sp_estimate_t *e, const sp_q24_t length[SP_LEGS],
                                  const sp_pose_t *reference, const sp_fk_cache_t *ref, const sp_fk_options_t *opt,
                                  sp_pose_t *est, uint32_t *iterations)
{
    sp_q24_t d[SP_LEGS];
    uint32_t beyond = 0u;
    sp_status_t st;
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        /* lengths are positive Q24 values: the difference cannot wrap */
        sp_flags_t flags = 0u;
        d[i] = spi_sub_sat(length[i], ref->length[i], &flags);
        /* |d| <= STEP_MAX exactly when d + STEP_MAX (modulo 2^32) is at
         * most 2 STEP_MAX: one addition and one comparison */
        beyond |= ((uint32_t)d[i] + (uint32_t)SP_ESTIMATE_STEP_MAX) > 2u * (uint32_t)SP_ESTIMATE_STEP_MAX ? 1u : 0u;
    }
    if (beyond == 0u) {
        /* the step in place on a copy of the reference (ref_lu valid,
         * nothing NULL: sp_fk_chord_step's checks hold) */
        int64_t b[SP_LEGS];
        for (i = 0u; i < SP_LEGS; ++i) {
            b[i] = d[i];
        }
        *est = *reference;
        st = spi_fk_chord_step_in(&e->ref_lu, ref->sc, b, est);
        *iterations = 1u;
    } else {
        sp_fk_options_t copt = *opt;
        sp_fk_cache_t c = *ref;
        sp_fk_info_t info;
        copt.max_iterations = SP_ESTIMATE_CHORD_STEPS;
        st = sp_fk_chord(platform, length, reference, &e->ref_lu, &copt, &c, est, &info);
        *iterations = info.iterations;
    }
    if (st == SP_OK && !within_jump(est, &e->pose, opt)) {
        st = SP_E_DISCONTINUITY;
    }
    return st;
}

sp_status_t sp_estimate_step(const sp_platform_t *platform, sp_estimate_t *e, const sp_q24_t length[SP_LEGS],
                             const sp_pose_t *reference, const sp_fk_cache_t *ref, uint32_t *iterations)
{
    sp_pose_t est;
    sp_status_t st = SP_E_NO_CONVERGENCE;

    *iterations = 0u;
    if (e->valid && e->ref_lu.valid && ref != NULL) {
        /* the default options read in place (sp_fk_default_options) */
        st = from_reference(platform, e, length, reference, ref, &spi_fk_defaults, &est, iterations);
    }
    if (st != SP_OK) {
        sp_fk_options_t opt = spi_fk_defaults;
        sp_fk_info_t info;
        if (!e->valid) {
            /* cold start from the parked pose, no continuity to check */
            opt.max_iterations = SP_ESTIMATE_COLD_STEPS;
            opt.max_jump_pos = INT32_MAX;
            opt.max_jump_rot = INT32_MAX;
        }
        /* full Newton from the last estimate (or the park pose) */
        st = sp_forward_kinematics(platform, length, e->valid ? &e->pose : &platform->park, &opt, &est, NULL, &info);
        *iterations += info.iterations; /* the solves of every method tried */
    }
    if (st == SP_OK) {
        e->pose = est;
        e->valid = 1u;
    } else {
        e->valid = 0u;
    }
    return st;
}
