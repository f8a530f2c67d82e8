/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/model/kinematics.h"

#include "model/model_internal.h"
#include "math/fixed_inline.h"

#define COS_PITCH_MIN SP_Q30_MILLI(10) /* 0.01 */

const sp_fk_options_t spi_fk_defaults = {
    8u,               /* max_iterations */
    4,                /* tolerance: 0.24 um */
    SP_Q24_MILLI(50), /* max_jump_pos: 50 mm */
    SP_Q24_MILLI(50), /* max_jump_rot: 50 mrad */
};

void sp_fk_default_options(sp_fk_options_t *opt)
{
    if (opt == NULL) {
        return;
    }
    *opt = spi_fk_defaults;
}

/* The length residuals l - length (Q24, saturated) into neg_res (negated,
 * int64) and the largest |residual| (saturated to INT32_MAX). */
static sp_q24_t fk_residuals(const sp_q24_t l[SP_LEGS], const sp_q24_t length[SP_LEGS], int64_t neg_res[SP_LEGS])
{
    sp_flags_t flags = 0u;
    uint32_t worst = 0u;
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        int32_t e = spi_sub_sat(l[i], length[i], &flags);
        uint32_t ae = spi_dist32(e, 0);
        worst = ae > worst ? ae : worst;
        neg_res[i] = -(int64_t)e;
    }
    return (worst > (uint32_t)INT32_MAX) ? INT32_MAX : (sp_q24_t)worst;
}

/* One Newton (or chord) update of q by delta = [dR (m); dw (rad, base
 * frame)], Q24, with sc the sines and cosines of q's own orientation.
 * SP_E_SINGULAR near pitch = +-90 degrees, SP_E_NO_CONVERGENCE when a value
 * saturated (the iteration diverged). */
static sp_status_t fk_update(sp_pose_t *q, const int64_t delta[SP_LEGS], const sp_q30_t sc[6])
{
    sp_flags_t flags = 0u;
    int32_t w[3]; /* the small rotation dw, rad, base frame, Q24 */
    int32_t d_roll;
    int64_t x;
    unsigned sh;
    int32_t inv;
    unsigned i;

    /* a step of 128 m or 128 rad means the iteration diverged; the
     * translation added as it is narrowed */
    for (i = 0u; i < 3u; ++i) {
        q->pos[i] = spi_add(q->pos[i], spi_sat(delta[i], &flags), &flags);
        w[i] = spi_sat(delta[3u + i], &flags);
    }
    /* Small rotation dw to Euler increments (inverse of the map used in
     * sp_leg_rates), with the sines of q's own orientation:
     * d_roll = (cy wx + sy wy) / cp, d_pitch = -sy wx + cy wy,
     * d_yaw = wz + sp d_roll. */
    if (sc[3] < COS_PITCH_MIN) {
        return SP_E_SINGULAR;
    }
    inv = spi_recip((uint32_t)sc[3], &sh); /* 1/cp = inv / 2^sh, sh in [54, 61] */
    /* cy wx + sy wy (Q24) times 1/cp; the common case, a small step, is
     * an int32 times inv: one 32 x 32-bit product, the value of
     * spi_mul64_up (rounded once, ties up, as it rounds) */
    x = spi_round_away((int64_t)w[0] * sc[5] + (int64_t)w[1] * sc[4], 30u);
    if ((uint64_t)x + UINT64_C(0x80000000) <= UINT64_C(0xFFFFFFFF)) {
        d_roll = spi_sat(spi_round_up((int64_t)(int32_t)x * inv, sh - 30u), &flags);
    } else {
        d_roll = spi_sat(spi_mul64_up(x, inv, sh - 30u, &flags), &flags);
    }
    q->rpy[0] = spi_add(q->rpy[0], d_roll, &flags);
    q->rpy[1] =
        spi_add(q->rpy[1], spi_sat(spi_round_away((int64_t)w[1] * sc[5] - (int64_t)w[0] * sc[4], 30u), &flags), &flags);
    q->rpy[2] = spi_add(q->rpy[2], spi_add(w[2], spi_mul_away(d_roll, sc[2], 30u, &flags), &flags), &flags);
    return (flags != 0u) ? SP_E_NO_CONVERGENCE : SP_OK;
}

/* Is every axis of q within the allowed jump of the guess? */
static sp_status_t fk_jump_check(const sp_pose_t *q, const sp_pose_t *guess, const sp_fk_options_t *opt)
{
    /* |a - b| exact in uint32; a negative limit rejects every pose, as the
     * signed comparison did */
    uint32_t jp = (opt->max_jump_pos < 0) ? 0u : (uint32_t)opt->max_jump_pos;
    uint32_t jr = (opt->max_jump_rot < 0) ? 0u : (uint32_t)opt->max_jump_rot;
    int neg = opt->max_jump_pos < 0 || opt->max_jump_rot < 0;
    unsigned i;
    for (i = 0u; i < 3u; ++i) {
        if (spi_dist32(q->pos[i], guess->pos[i]) > jp || spi_dist32(q->rpy[i], guess->rpy[i]) > jr) {
            return SP_E_DISCONTINUITY;
        }
    }
    return neg ? SP_E_DISCONTINUITY : SP_OK;
}

/* Newton-Raphson of sp_forward_kinematics into w (the IK of each iterate;
 * its unit vectors at the solution only when `units`), after the caller
 * checked the arguments and reset *info. */
static sp_status_t fk_newton(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                             const sp_fk_options_t *opt, sp_pose_t *pose, sp_ik_t *w, int units, sp_fk_info_t *info)
{
    sp_pose_t q = *guess;
    sp_jacobian_t jac;
    sp_status_t st = SP_OK;
    uint32_t it = 0u;

    for (;;) { /* bounded: at most max_iterations + 1 passes */
        int64_t neg_res[SP_LEGS];
        int64_t delta[SP_LEGS];
        sp_q24_t worst;

        /* lengths only: the unit vectors are needed for a Jacobian or for
         * the caller's ik, not for the convergence test */
        spi_orientation_sc(q.rpy, &w->rot, w->sc);
        st = spi_ik_lengths(platform, &q, w);
        if (st != SP_OK) {
            break;
        }
        worst = fk_residuals(w->length, length, neg_res);
        info->residual = worst;
        if (worst <= opt->tolerance) {
            if (units) {
                spi_ik_units(w);
            }
            st = SP_OK;
            break;
        }
        if (it >= opt->max_iterations) {
            st = SP_E_NO_CONVERGENCE;
            break;
        }
        spi_ik_units(w);
        st = sp_jacobian(w, &jac);
        if (st == SP_OK) {
            st = sp_solve6(&jac, 0, neg_res, delta);
        }
        if (st != SP_OK) {
            break;
        }
        ++it;
        st = fk_update(&q, delta, w->sc);
        if (st != SP_OK) {
            break;
        }
    }
    info->iterations = it;
    if (st == SP_OK) {
        st = fk_jump_check(&q, guess, opt);
    }
    *pose = (st == SP_OK) ? q : *guess;
    return st;
}

/* sp_forward_kinematics into w (units as fk_newton): info (may be NULL)
 * reset, the arguments checked (args_ok 0: the caller found a bad one of
 * its own), then Newton. */
static sp_status_t fk_run(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                          const sp_fk_options_t *opt, sp_pose_t *pose, sp_ik_t *w, int units, int args_ok,
                          sp_fk_info_t *info)
{
    sp_fk_info_t local_info;
    if (info == NULL) {
        info = &local_info;
    }
    info->iterations = 0u;
    info->residual = INT32_MAX;
    if (!args_ok || platform == NULL || length == NULL || guess == NULL || opt == NULL || pose == NULL ||
        opt->max_iterations < 1u || opt->max_iterations > 20u || opt->tolerance < 0) {
        return SP_E_ARG;
    }
    return fk_newton(platform, length, guess, opt, pose, w, units, info);
}

sp_status_t sp_forward_kinematics(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                                  const sp_fk_options_t *opt, sp_pose_t *pose, sp_ik_t *ik, sp_fk_info_t *info)
{
    sp_ik_t work;
    return fk_run(platform, length, guess, opt, pose, (ik != NULL) ? ik : &work, ik != NULL, 1, info);
}

sp_status_t sp_fk_newton_cached(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                                const sp_fk_options_t *opt, sp_fk_cache_t *cache, sp_pose_t *pose, sp_fk_info_t *info)
{
    sp_ik_t work;
    unsigned i;
    sp_status_t st = fk_run(platform, length, guess, opt, pose, &work, 0, cache != NULL, info);
    if (st == SP_OK) {
        for (i = 0u; i < SP_LEGS; ++i) {
            cache->length[i] = work.length[i];
        }
        for (i = 0u; i < 6u; ++i) {
            cache->sc[i] = work.sc[i];
        }
    }
    return st;
}

sp_status_t sp_fk_cache_of(const sp_platform_t *platform, const sp_pose_t *pose, sp_fk_cache_t *cache)
{
    sp_ik_t w;
    sp_status_t st;
    unsigned i;

    if (platform == NULL || pose == NULL || cache == NULL) {
        return SP_E_ARG;
    }
    spi_orientation_sc(pose->rpy, &w.rot, cache->sc);
    st = spi_ik_lengths(platform, pose, &w);
    for (i = 0u; i < SP_LEGS; ++i) {
        cache->length[i] = (st == SP_OK) ? w.length[i] : 0;
    }
    return st;
}

sp_status_t sp_fk_chord(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                        const sp_lu6_t *lu_t, const sp_fk_options_t *opt, sp_fk_cache_t *cache, sp_pose_t *pose,
                        sp_fk_info_t *info)
{
    sp_pose_t q;
    sp_fk_cache_t c;
    sp_fk_info_t local_info;
    sp_ik_t w;
    sp_status_t st = SP_OK;
    uint32_t it = 0u;
    unsigned i;

    if (info == NULL) {
        info = &local_info;
    }
    info->iterations = 0u;
    info->residual = INT32_MAX;
    if (platform == NULL || length == NULL || guess == NULL || lu_t == NULL || opt == NULL || cache == NULL ||
        pose == NULL || opt->max_iterations < 1u || opt->max_iterations > 20u || opt->tolerance < 0) {
        return SP_E_ARG;
    }
    q = *guess;
    c = *cache;
    for (;;) { /* bounded: at most max_iterations + 1 passes */
        int64_t neg_res[SP_LEGS];
        int64_t delta[SP_LEGS];
        sp_q24_t worst = fk_residuals(c.length, length, neg_res);

        info->residual = worst;
        if (worst <= opt->tolerance) {
            st = SP_OK;
            break;
        }
        if (it >= opt->max_iterations) {
            st = SP_E_NO_CONVERGENCE;
            break;
        }
        /* J delta = -residual with J = (J^T)^T: the transposed solve of
         * the caller's factorisation of J^T */
        st = (lu_t->valid && spi_lu6_solve_t32(lu_t, neg_res, delta)) ? SP_OK
                                                                      : sp_lu6_solve_transposed(lu_t, neg_res, delta);
        if (st != SP_OK) {
            break;
        }
        ++it;
        st = fk_update(&q, delta, c.sc);
        if (st != SP_OK) {
            break;
        }
        spi_orientation_sc(q.rpy, &w.rot, c.sc);
        st = spi_ik_lengths(platform, &q, &w);
        if (st != SP_OK) {
            break;
        }
        for (i = 0u; i < SP_LEGS; ++i) {
            c.length[i] = w.length[i];
        }
    }
    info->iterations = it;
    if (st == SP_OK) {
        st = fk_jump_check(&q, guess, opt);
    }
    if (st == SP_OK) {
        *pose = q;
        *cache = c;
    } else {
        *pose = *guess;
    }
    return st;
}

sp_status_t spi_fk_chord_step_in(const sp_lu6_t *lu_t, const sp_q30_t sc[6], const int64_t b[SP_LEGS], sp_pose_t *q)
{
    int64_t delta[SP_LEGS];
    uint64_t any = 0u;
    unsigned i;

    for (i = 0u; i < SP_LEGS; ++i) {
        any |= (uint64_t)b[i];
    }
    if (any == 0u) {
        return SP_OK; /* no increment: q as it is, no solve */
    }
    /* J delta = dL with J = (J^T)^T: the transposed solve of the
     * factorisation of J^T */
    if (!spi_lu6_solve_t32(lu_t, b, delta)) {
        sp_status_t st = sp_lu6_solve_transposed(lu_t, b, delta);
        if (st != SP_OK) {
            return st;
        }
    }
    return fk_update(q, delta, sc);
}

sp_status_t sp_fk_chord_step(const sp_lu6_t *lu_t, const sp_pose_t *from, const sp_q30_t sc[6],
                             const sp_q24_t d_length[SP_LEGS], sp_pose_t *pose)
{
    int64_t b[SP_LEGS];
    sp_pose_t q;
    sp_status_t st;
    unsigned i;

    if (lu_t == NULL || from == NULL || sc == NULL || d_length == NULL || pose == NULL || !lu_t->valid) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        b[i] = d_length[i];
    }
    q = *from;
    st = spi_fk_chord_step_in(lu_t, sc, b, &q);
    if (st == SP_OK) {
        *pose = q;
    }
    return st;
}
