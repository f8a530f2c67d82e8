/* SPDX-License-Identifier: Apache-2.0 */
/*
 * model_internal.h - the model layer's functions that other source files of
 * the core share (kinematics.c, lu6.c, fk.c and, above, limits.c,
 * setpoint.c, estimate.c, motion_error.c, controller.c) and that are not
 * part of the public API.
 */
#ifndef SP_MODEL_INTERNAL_H
#define SP_MODEL_INTERNAL_H

#include "sp/model/kinematics.h"
#include "sp/model/dynamics.h"

/* T of the angles (rad, Q24), keeping their sines and cosines in sc =
 * {sin, cos} of roll, pitch, yaw (Q30). Cannot fail. */
void spi_orientation_sc(const sp_q24_t rpy[3], sp_rot_t *rot, sp_q30_t sc[6]);

/* T from the sines and cosines sc = {sin, cos} of roll, pitch, yaw (Q30, as
 * sp_sincos_q24 gives them); two-term entries rounded once. */
void spi_rot_from_sincos(const sp_q30_t sc[6], sp_rot_t *rot);

/* keep brought to the angles rpy (rad, Q24): each angle that changed gets
 * its sine and cosine (sp_sincos_q24), T is made again when one did (its
 * roll and pitch products only when roll or pitch did), as
 * spi_rot_from_sincos makes it, bit for bit; valid is set and the kept
 * arms are dropped when it changed. Returns 1 when
 * an angle changed (or keep was not valid), 0 otherwise; *flat is 1 when
 * the angles changed to roll = pitch = 0. Cannot fail. */
int spi_orient_update(sp_orient_keep_t *keep, const sp_q24_t rpy[3], int *flat);

/* Inverse kinematics of a pose whose orientation ik->rot is already set:
 * arms, legs and lengths (not the unit vectors). SP_E_RANGE for a leg
 * component of 64 m or more or a leg shorter than 1 mm, SP_E_OVERFLOW if an
 * arm saturated. */
sp_status_t spi_ik_lengths(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik);

/* The unit vectors of a successful spi_ik_lengths (Q30, within 3 LSB).
 * Cannot fail. */
void spi_ik_units(sp_ik_t *ik);

/* 1 when every platform joint of `platform` is in [-2 m, 2 m) (Q24:
 * [-2^25, 2^25)) in each axis, else 0. The arms A_im T of such a platform
 * are below sqrt(3) 2 m (1 + 2^-28) + 1 LSB < 4 m (2^26), so its IK's
 * Jacobian cannot saturate: spi_jacobian_near applies. */
int spi_joints_near(const sp_platform_t *platform);

/* 1 when `platform` has spi_joints_near and every base joint is in
 * [-8 m, 8 m) (Q24: [-2^27, 2^27)) in each axis, else 0. Every leg vector
 * arm + pos - base of such a platform at a position within 16 m
 * ([-2^28, 2^28) in each axis) is below 2^26 + 2^28 + 2^27 < 2^29 in each
 * component: its IK cannot overflow or leave the 64 m range
 * (sp_inverse_kinematics_kept then skips those tests). */
int spi_legs_fit(const sp_platform_t *platform);

/* sp_fk_chord_step's step in place, without its argument checks (lu_t
 * valid, nothing NULL): *q (from on entry, its sines sc) moved by
 * J^-1 b, b the leg-length increments (m, Q24, widened); b all zero leaves
 * *q as it is. The same errors; on an error *q is partly updated (the
 * caller drops it). */
sp_status_t spi_fk_chord_step_in(const sp_lu6_t *lu_t, const sp_q30_t sc[6], const int64_t b[SP_LEGS], sp_pose_t *q);

/* sp_fk_default_options' values (fk.c), for a copy without a call. */
extern const sp_fk_options_t spi_fk_defaults;

/* sp_jacobian for an ik of a platform with spi_joints_near (arms below
 * 2^26) whose unit vectors the IK made (|u_c| <= 2^30): the same
 * entries, without the saturation tests no entry can fail and with each
 * Q30 -> Q28 rounding in one addition (tests/unit/test_kinematics.c
 * proves them equal). Cannot fail. */
void spi_jacobian_near(const sp_ik_t *ik, sp_jacobian_t *jac);

/* sp_lu6_solve_transposed in 32-bit intermediates, block-scaled (lu6.c):
 * returns 1 and x on success, 0 (x untouched) when an intermediate would
 * leave the 32-bit range or b is 0 or out of range: the caller then uses
 * the int64 solve. */
int spi_lu6_solve_t32(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS]);

/* sp_inverse_dynamics_held (no external force) with the body rates given:
 * body = omega, omega_dot (Q24) as sp_body_rates_sc makes them from
 * ik->sc and motion's Euler rates (the frames' shared path keeps them in
 * the IK's sp_orient_keep_t), so that they are not made twice; the same
 * result bit for bit. NULL hold, rate or body: sp_inverse_dynamics_held. */
sp_status_t spi_inverse_dynamics_held_body(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                           const sp_jacobian_t *jac, sp_q8_t force[SP_LEGS], sp_lu6_t *lu,
                                           sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned refresh,
                                           const sp_q24_t body[6]);

/* The calls a factorisation staged over `staged` calls (sp_leg_hold_t.
 * lu_staged) begins before its due age: 2 over three calls, else 1 (over
 * two, or unstaged: the due call makes it whole). The controller's turn
 * refreshes no leg from that age on (motion_setpoints). */
#define SPI_LU_LEAD(staged) (((staged) >= 3u) ? 2u : 1u)

#endif /* SP_MODEL_INTERNAL_H */
