/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/motion/setpoint.h - what the controller sends each axis drive every tick: the
 * leg length to follow, its rate as velocity feed-forward, and the cylinder
 * force the motion requires (the inverse dynamics, with the legs' masses)
 * plus the cylinders' friction as force feed-forward, computed from a
 * reference motion with every limit checked. The model forces and the
 * Jacobian they came from are kept for the wrench estimate (sp/estimation/wrench.h).
 */
#ifndef SP_SETPOINT_H
#define SP_SETPOINT_H

#include "sp/model/dynamics.h"
#include "sp/motion/limits.h"

/** One axis drive's setpoint. */
typedef struct {
    sp_q24_t length;   /**< length setpoint, m, Q24 */
    sp_q24_t velocity; /**< velocity feed-forward, m/s, Q24 */
    sp_q8_t force;     /**< force feed-forward, N, Q8 */
} sp_setpoint_t;

/** The cylinders' friction model, prepared once from the platform
 *  (sp_friction_prepare): F = c_v v + F_c s(v / v_c), s(x) = x for
 *  |x| <= 1, sign(x) beyond (a linear ramp through zero that saturates at
 *  the Coulomb level), v the leg rate. */
typedef struct {
    sp_q8_t viscous[SP_LEGS]; /**< c_v, N s/m, Q8 */
    sp_q8_t coulomb[SP_LEGS]; /**< F_c, N, Q8 */
    sp_q8_t ramp[SP_LEGS];    /**< F_c / v_c, N s/m, Q8 (saturated at INT32_MAX) */
    sp_q24_t velocity;        /**< v_c, m/s, Q24 (0: a step at v = 0) */
} sp_friction_t;

/** Prepares *fr from the platform's friction (viscous_friction,
 *  coulomb_friction, coulomb_velocity). SP_E_ARG on NULL or a negative
 *  value. */
sp_status_t sp_friction_prepare(const sp_platform_t *platform, sp_friction_t *fr);

/** Friction force of cylinder `leg` (0..5) at leg rate `rate` (m/s, Q24):
 *  N, Q8, opposing the motion as a cylinder force (positive for a
 *  extending leg). Saturates at the int32 range. */
sp_q8_t sp_friction_force(const sp_friction_t *fr, unsigned leg, sp_q24_t rate);

/** Feed-forward switches (sp_setpoints_of's ff). */
#define SP_FF_DYNAMICS 0x1u /**< send the inverse dynamics forces */
#define SP_FF_FRICTION 0x2u /**< add the friction compensation */

/**
 * The setpoints of a reference motion: the leg lengths of its pose (IK),
 * their rates (sp_inverse_dynamics_rates': within 2 LSB of sp_leg_rates)
 * and the force feed-forward: the cylinder
 * forces of its motion (sp_inverse_dynamics_jac, no external force) when
 * ff has SP_FF_DYNAMICS, plus the friction at the leg rates when ff has
 * SP_FF_FRICTION (0 when ff is 0). *model gets the full model forces
 * (dynamics + friction, whatever ff says), the Jacobian and the pose's
 * leg lengths and sines (model->ref); the
 * factorisation of J^T at the pose goes to *lu (valid only when the
 * dynamics succeeded). Errors, with sp untouched (and *model meaningless):
 * SP_E_RANGE for a pose outside the workspace box or a length, rate or
 * model force outside sp_limits_setpoints_ok (a motion that needs more
 * force than the limit is refused, feed-forward or not); the
 * IK's, the rates' or the dynamics' error when one fails (SP_E_RANGE,
 * SP_E_OVERFLOW, SP_E_SINGULAR).
 */
sp_status_t sp_setpoints_of(const sp_platform_t *platform, const sp_limits_t *lim, const sp_friction_t *fr,
                            const sp_motion_t *ref, unsigned ff, sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu,
                            sp_model_t *model);

/**
 * sp_setpoints_of with the leg masses' terms of the legs not in `refresh`
 * (bit i: leg i) kept from an earlier call in *hold
 * (sp_inverse_dynamics_held; the controller refreshes one leg a tick,
 * in turn), and the reference's IK by sp_inverse_kinematics_kept with
 * *orient (NULL: sp_inverse_kinematics; the same result either way). With
 * hold NULL or refresh 0x3F it is sp_setpoints_of bit for bit. On an
 * error before the dynamics ran, *hold is left as it was; the dynamics'
 * own errors leave it keeping nothing.
 */
sp_status_t sp_setpoints_held(const sp_platform_t *platform, const sp_limits_t *lim, const sp_friction_t *fr,
                              const sp_motion_t *ref, unsigned ff, sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu,
                              sp_model_t *model, sp_leg_hold_t *hold, unsigned refresh, sp_orient_keep_t *orient);

#endif /* SP_SETPOINT_H */
