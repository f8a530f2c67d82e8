/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/estimation/estimate.h - the pose estimate: forward kinematics of the measured leg
 * lengths once per tick.
 *
 * The usual tick is one chord step from the previous tick's reference
 * (sp_fk_chord_step), with no IK, Jacobian or factorisation at all: the
 * reference's leg lengths and sines come from the setpoints (its IK), the
 * factorisation of its J^T from the inverse dynamics (sp_setpoints_of), so
 *   x = x_ref + J_ref^-1 (L_meas - L_ref).
 * The error of that step is second order in |x - x_ref|. Over the default
 * platform's workspace and tracking errors of every direction, the step is
 * within 1 um and 1 urad (every axis) of the true forward kinematics while
 * |L_meas - L_ref|_inf <= 0.62 mm (float64, tools/dev/estimate_bound.py,
 * a random search refined towards its worst cases); SP_ESTIMATE_STEP_MAX
 * takes 0.4 mm, where the second-order error is below 0.45 um, and leaves
 * the rest to the fixed point's rounding (tests/unit/test_ctrl_jobs.c
 * checks the step against full Newton within 1 um / 1 urad).
 * Beyond that bound, chord steps from the reference (sp_fk_chord, the same
 * convergence test as Newton), and full Newton (sp_forward_kinematics)
 * when they fail, when the reference has no factorisation, or on a cold
 * start. Every warm result is checked for continuity against the previous
 * estimate (sp_fk_default_options: 50 mm, 50 mrad).
 * The controller keeps the factorisation over up to SP_CTRL_LU_KEEP
 * ticks (sp_leg_hold_t.lu_keep, staged over two ticks): ref_lu is then
 * J^T's at a reference up to eight ticks older, which adds up to
 * |I - J_old^-1 J_ref| |x - x_ref| to the step (the first factor grows
 * with the age). At 0.4 mm, eight ticks (float64, docs/explanation/model.md, "The
 * factorisation kept over ticks"): within 1.24 um / 0.67 urad at the
 * surge's 0.28 m/s, up to 2.44 um / 2.83 urad at 0.5 m/s and 0.5 rad/s;
 * the 1 um bound above is for a fresh factorisation (SP_CTRL_LU_KEEP 1).
 */
#ifndef SP_ESTIMATE_H
#define SP_ESTIMATE_H

#include "sp/model/kinematics.h"

/** The single step is taken while every |L_meas - L_ref| is at most this:
 *  0.4 mm, Q24 (see the file comment for the bound it keeps to). */
#define SP_ESTIMATE_STEP_MAX ((sp_q24_t)6711)
/** Chord steps allowed (from the reference, beyond SP_ESTIMATE_STEP_MAX)
 *  before falling back to full Newton. */
#define SP_ESTIMATE_CHORD_STEPS 4u
/** Newton steps allowed for a cold start (no previous estimate). */
#define SP_ESTIMATE_COLD_STEPS 20u

/** The estimate and the reference factorisation the next tick reuses. */
typedef struct {
    sp_pose_t pose;  /**< the estimate (the last valid one, or the park pose before the first) */
    uint8_t valid;   /**< 1 while pose is the forward kinematics of the last measured lengths */
    sp_lu6_t ref_lu; /**< factorisation of J^T at the reference of the last tick, or (kept by the
                          controller) of one up to eight ticks older (valid flag inside): written
                          by the inverse dynamics of the setpoints (sp_setpoints_held),
                          invalidated by the controller whenever the reference has none */
} sp_estimate_t;

/** No estimate yet: pose = *park, nothing valid. */
void sp_estimate_init(sp_estimate_t *e, const sp_pose_t *park);

/**
 * One tick's estimate from the measured leg lengths `length` (m, Q24).
 * `reference` is the pose e->ref_lu was factorised at and `ref` its leg
 * lengths (m, Q24) and sines (Q30) as its IK computed them (sp_model_t.ref;
 * may be NULL: unknown). With a valid estimate, a valid ref_lu and ref not
 * NULL:
 *   - every |length - ref->length| <= SP_ESTIMATE_STEP_MAX: one chord step
 *     from the reference (sp_fk_chord_step, no IK);
 *   - otherwise up to SP_ESTIMATE_CHORD_STEPS chord steps from the
 *     reference (sp_fk_chord, each with an IK, converged as Newton).
 * Both results must lie within the default jumps (50 mm, 50 mrad) of the
 * previous estimate. Failing that, or without ref_lu or ref, full Newton
 * from the previous estimate with the default options (its jump check
 * against the previous estimate); with no valid estimate, a cold start
 * from platform->park with up to SP_ESTIMATE_COLD_STEPS steps and no
 * continuity check. *iterations (not NULL) gets the linear solves of
 * every method tried: 1 for the single step (or a one-step chord), the
 * chord steps, plus the Newton steps when Newton ran (0 when the guess
 * already fitted the lengths). On SP_OK e->pose is the new estimate; on an error (those of
 * sp_forward_kinematics) the estimate is invalid and e->pose keeps the
 * last estimate. Bounded: at most one step, 4 chord steps and 20 Newton
 * steps.
 */
sp_status_t sp_estimate_step(const sp_platform_t *platform, sp_estimate_t *e, const sp_q24_t length[SP_LEGS],
                             const sp_pose_t *reference, const sp_fk_cache_t *ref, uint32_t *iterations);

#endif /* SP_ESTIMATE_H */
