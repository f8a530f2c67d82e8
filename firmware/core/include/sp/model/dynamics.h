/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/model/dynamics.h - the cylinder forces a motion requires (the paper's
 * translational and rotational dynamics, eqs 7 and 8/13-15, with the full
 * inertia tensor). The leg limit checks are in sp/motion/limits.h.
 */
#ifndef SP_DYNAMICS_H
#define SP_DYNAMICS_H

#include "sp/model/kinematics.h"

/**
 * Inverse dynamics: the six cylinder forces F_i (N, Q8; positive pushes the
 * platform away from the base, along l_i; the force between barrel and rod,
 * friction excluded) that produce the given motion of the platform under
 * gravity (0, 0, -m g) and an external force L at o' (N, Q8, base frame;
 * may be NULL for none). With massless legs and the centre of mass at o'
 * (the paper's model) it solves
 *   sum F_i u_i                 = m a - L + (0, 0, m g)          (base frame)
 *   sum F_i (A_im T) x u_i      = R (I dw/dt + w x (I w))        (base frame)
 * where w, dw/dt are the body rates of eq (10) and R = T^T, by pivoted
 * Gaussian elimination in 64-bit intermediates (forces carried in Q24).
 * A centre of mass c off o' adds m R (dw/dt x c + w x (w x c)) to the force
 * and m c x T (a + g e_z) to the body moment; leg masses
 * (platform->leg_mass) add each leg's reaction at its platform joint: its
 * part along the leg goes to F_i, the rest to the wrench (docs/explanation/model.md,
 * "Leg masses"). platform->inertia is about o'.
 * ik must be the inverse kinematics of motion->pose.
 * Errors: SP_E_ARG (NULL), SP_E_SINGULAR (pose at or near a singularity:
 * smallest pivot below 1e-3), SP_E_OVERFLOW (an intermediate or a force
 * saturated: |F| >= 8.4 MN; a leg of 0.5 m or less with leg masses).
 * SP_E_ARG for a negative leg mass or centre. On error the forces are
 * zeroed.
 */
sp_status_t sp_inverse_dynamics(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS]);

/**
 * sp_inverse_dynamics (same forces, bit for bit, same errors), also
 * returning the factorisation of J^T it solved with in *lu (lu->valid is 1
 * only on SP_OK; SP_E_ARG if lu is NULL). The transposed solve of *lu
 * (sp_lu6_solve_transposed) then solves J x = b at no new factorisation,
 * e.g. for the next tick's forward kinematics (sp_fk_chord).
 */
sp_status_t sp_inverse_dynamics_lu(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                   const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS], sp_lu6_t *lu);

/**
 * sp_inverse_dynamics_lu (same forces, bit for bit, same errors) with the
 * Jacobian that the caller already built: jac must be sp_jacobian(ik).
 * SP_E_ARG if jac is NULL.
 */
sp_status_t sp_inverse_dynamics_jac(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                    const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                    sp_lu6_t *lu);

/**
 * sp_inverse_dynamics_jac (same forces, bit for bit, same errors) that
 * also returns the leg rates d|l_i|/dt of the motion in rate (m/s, Q24),
 * within 2 LSB of sp_leg_rates(ik, motion->vel, motion->rpy_rate, rate)
 * (measured 1; tests/unit/test_kinematics.c bounds both against float64):
 * with leg masses they are J_i . [v; w_b] from jac's rows, rounded once,
 * which costs less than the joint velocities of every leg, so a caller
 * that needs both (sp_setpoints_of) computes them once. Where the leg
 * terms do not run (massless legs, or inputs outside their envelope, see
 * dynamics.c) sp_leg_rates runs. rate is valid on SP_OK only; its errors
 * (SP_E_OVERFLOW beyond +-128 m/s) are returned like the forces'.
 * SP_E_ARG if rate is NULL.
 */
sp_status_t sp_inverse_dynamics_rates(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                      const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                      sp_lu6_t *lu, sp_q24_t rate[SP_LEGS]);

/**
 * The leg masses' terms kept from one call to the next
 * (sp_inverse_dynamics_held), so that a call need compute only some legs'
 * (docs/explanation/model.md, "Leg masses"; the controller refreshes one leg a
 * tick: sp/control/controller.h). Per leg: its reaction at the platform joint
 * without the part along the leg, h_i - s_i u_i = mu a_A + c1 v_A +
 * k_g g e_z (base frame, N, Q16), its moment about o' and the axial term
 * s_i (N, Q16); and the sums over the legs of the reactions and moments,
 * updated exactly (integers) as legs are refreshed, so that a kept leg
 * costs nothing but its rate. Zero it (or set held to 0) before the first
 * call.
 */
typedef struct {
    sp_q16_t hw[SP_LEGS][3]; /**< leg i's reaction h_i - s_i u_i, base frame, N, Q16 */
    int64_t mo[SP_LEGS][3];  /**< its moment about o', r_i x (h_i - s_i u_i), at its arm then, N m, Q40 */
    int64_t fsum[3];         /**< sum of hw over the legs, N, Q16 */
    int64_t msum[3];         /**< sum of mo over the legs, N m, Q40 */
    sp_q16_t axial[SP_LEGS]; /**< leg i's axial term s_i, N, Q16 */
    uint8_t held;            /**< bit i: leg i's terms are kept (computed by an earlier call) */
    uint8_t fresh;           /**< out: bit i: leg i's terms were computed by the last call (all when it kept none) */
    int32_t fq[SP_LEGS]; /**< the last call's solved forces without the axial terms, N, Q8 (the refinement's start) */
    uint8_t lu_keep;     /**< in: calls over which one factorisation may serve (0 or 1: a fresh one every call) */
    uint8_t lu_age;      /**< in/out: calls since *lu was factorised (0: by this call); lu_keep - 1 or more
                                  makes the next call factorise (staged: begin to) */
    uint8_t lu_staged;   /**< in: the calls a factorisation is staged over: 2 or 3 (below); 0 or 1: none */
    uint8_t lu_wait;     /**< in: 1: this call takes no step of the factorisation if it may refine (below) */
    uint8_t lu_waited;   /**< in/out: 1 once a call waited since *lu was factorised */
    sp_lu6_stage_t lu_next; /**< in/out: the last call's J^T, half factorised, while lu_next.begun is 1 */
} sp_leg_hold_t;

/**
 * sp_inverse_dynamics_rates, with the leg masses' terms of the legs not in
 * `refresh` (bit i: leg i) taken from *hold where it keeps them (bit i of
 * hold->held), the others computed and kept. A kept leg's reaction,
 * moment (at its arm then) and axial term are those of the motion it was
 * computed at (the caller bounds the difference: the controller refreshes
 * each leg every SP_CTRL_LEG_GROUPS ticks); the leg rates are always this
 * motion's. With refresh = 0x3F, or hold NULL, or every kept leg computed
 * at this same motion, the forces and rates are sp_inverse_dynamics_rates'
 * bit for bit (the sums are exact), provided the call factorised (below).
 * hold->fresh says which legs this call computed. For
 * inputs outside the leg terms' fast envelope (dynamics.c) every leg is
 * computed and none kept (hold->held = 0), as on any error. Errors as
 * sp_inverse_dynamics_rates.
 * The factorisation kept (hold->lu_keep > 1): when the last call
 * succeeded (hold->held all legs), *lu is still its factorisation
 * (lu->valid) and hold->lu_age + 1 < hold->lu_keep, the call does not
 * factorise this motion's J^T but takes one refinement step from the last
 * call's forces hold->fq with *lu: r = b - J^T fq (this J, exact in Q36,
 * rounded once to Q24), F = fq + LU^-1 r, and counts hold->lu_age up;
 * otherwise (also when |fq| >= 2^24 Q8 or r leaves the solve's range)
 * it factorises into *lu and sets hold->lu_age to 0.
 * Staged over two calls (hold->lu_staged 2): the call due to factorise
 * with hold->lu_age + 1 == hold->lu_keep refines once more with *lu (its
 * age becomes lu_keep) and begins the factorisation of its J^T in
 * hold->lu_next (sp_lu6_factor_begin); the next call, when it may refine
 * (as above, whatever the age), finishes it into *lu (sp_lu6_factor_end:
 * the exact factorisation of the last call's J^T) and refines with it,
 * hold->lu_age 1; a call that may not refine drops it and factorises
 * whole. Over three (hold->lu_staged 3): the call with hold->lu_age + 2
 * == hold->lu_keep begins it, the next refines with *lu and takes its
 * middle step (sp_lu6_factor_step), the one after finishes it (its J^T
 * two calls old) and refines with it. A hold->lu_age of lu_keep or more with no begun stage
 * (hold->lu_next.begun 0) makes the call factorise whole.
 * Waiting (hold->lu_wait 1, a call busy with other work): a call that may
 * refine, is not overdue (hold->lu_age below lu_keep, or a stage begun)
 * and whose *lu no call has waited on yet (hold->lu_waited 0) only
 * refines: it neither begins, finishes nor makes a factorisation,
 * leaves hold->lu_age as it was and sets hold->lu_waited, which the next
 * factorisation clears. So at most one call a factorisation waits, and
 * *lu serves at most lu_keep + 1 calls; a stage begun before the wait is
 * finished by the call after it (the J^T of the call that began it). The refined forces
 * differ from a fresh solve by at most |I - J_old^-T J^T| |F - fq| plus
 * the solve's rounding (docs/explanation/model.md, "The factorisation kept over
 * ticks"); *lu then stays the older motion's factorisation.
 */
sp_status_t sp_inverse_dynamics_held(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                     const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                     sp_lu6_t *lu, sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned refresh);

/** What the model says at the reference: sp_setpoints_of (sp/motion/setpoint.h)
 *  fills it, the wrench estimate (sp/estimation/wrench.h) reads it. */
typedef struct {
    sp_q8_t force[SP_LEGS]; /**< the cylinder forces the reference needs: inverse dynamics + friction, N, Q8 */
    sp_q8_t rigid[SP_LEGS]; /**< their inverse dynamics part alone (platform and legs, no friction), N, Q8 */
    sp_jacobian_t jac;      /**< the leg Jacobian at the reference pose (sp_jacobian) */
    sp_fk_cache_t ref;      /**< the reference pose's leg lengths (m, Q24) and sines (Q30), as its IK
                                 computed them: the pose estimate's next step starts there (sp/estimation/estimate.h) */
    sp_rot_t rot;           /**< T at the reference (its IK's, of ref.sc), for the wrench's motion correction */
} sp_model_t;

#endif /* SP_DYNAMICS_H */
