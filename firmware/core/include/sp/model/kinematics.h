/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/model/kinematics.h - the paper's leg kinematics (eqs 1, 2, 10), the leg
 * Jacobian, and forward kinematics, in fixed point.
 *
 * Conventions (docs/explanation/model.md, Frames and pose). The paper writes vectors as rows: a point
 * with motion-frame coordinates a sits at a T + R in the base frame, so the
 * rows of T are the platform axes in base coordinates, and T^T is the usual
 * column-vector rotation Rz(yaw) Ry(pitch) Rx(roll) from the motion frame to
 * the base frame.
 *
 * All functions are pure: inputs -> outputs, no hidden state, no allocation.
 */
#ifndef SP_KINEMATICS_H
#define SP_KINEMATICS_H

#include "sp/math/fixed.h"
#include "sp/model/lu6.h"
#include "sp/model/platform.h"

/** The paper's orientation matrix T (eq 2), Q30. T[r][c]: row r is the
 *  motion frame's axis r (i, j, k) in base coordinates. */
typedef struct {
    sp_q30_t t[3][3];
} sp_rot_t;

/** Inverse kinematics of one pose. */
typedef struct {
    sp_rot_t rot;              /**< T of the pose */
    sp_q30_t sc[6];            /**< sin, cos of roll, pitch, yaw, Q30 (what T is built from) */
    sp_q24_t arm[SP_LEGS][3];  /**< A_im T: platform joint relative to o', base frame, m, Q24 */
    sp_q24_t leg[SP_LEGS][3];  /**< l_i = A_im T + R - B_i (eq 1), base frame, m, Q24 */
    sp_q24_t length[SP_LEGS];  /**< |l_i|, m, Q24 */
    sp_q30_t unit[SP_LEGS][3]; /**< l_i / |l_i|, base frame, Q30 */
} sp_ik_t;

/**
 * T from roll, pitch, yaw (rad, Q24, any value in the Q24 range) (eq 2).
 * Entries: the worst error seen against the exact T of the Q24 angles is
 * 3.1 LSB of Q30 (2e6 random angles in +-3.2 rad; 3.5 before the two-term
 * entries were rounded once). To first order the bound is 6 LSB: each
 * entry is at most two products of sines and cosines (each within 1.05
 * LSB, sp_sincos_q24) with one rounded product inside and one final
 * rounding.
 * Returns SP_E_ARG on NULL pointers, else SP_OK (cannot overflow: every
 * entry is a product of sines and cosines).
 */
sp_status_t sp_orientation(const sp_q24_t rpy[3], sp_rot_t *rot);

/**
 * Inverse kinematics (eq 1) of a pose: leg vectors, lengths, unit vectors.
 * Lengths are within 1 LSB of Q24 (60 nm) plus 1e-9 of the platform radius
 * of the exact value. Returns SP_E_ARG on NULL pointers, SP_E_RANGE if a leg
 * vector component reaches 64 m or a leg is shorter than 1 mm (no direction),
 * SP_E_OVERFLOW if an intermediate saturated. Stroke limits are not checked
 * here (see sp_check_legs).
 */
sp_status_t sp_inverse_kinematics(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik);

/** The orientation of the last pose given to sp_inverse_kinematics_kept:
 *  its angles, their sines and cosines and T, kept so that an angle that
 *  repeats costs no sine; and once an orientation repeats (a translation,
 *  e.g. the surge), the legs' arms A_im T, so that it costs no arm. Set
 *  valid to 0 before the first call. */
typedef struct {
    sp_q24_t rpy[3];               /**< the angles sc and rot are of, rad, Q24 */
    sp_q30_t sc[6];                /**< sin, cos of rpy (sp_sincos_q24), Q30 */
    sp_rot_t rot;                  /**< T of rpy */
    sp_q30_t tilt[2];              /**< sin pitch sin roll, sin pitch cos roll (rounded, Q30): T's products of
                                        roll and pitch that its yaw entries take, kept while those hold */
    sp_q24_t arm[SP_LEGS][3];      /**< the arms A_im T of `platform` at rot, m, Q24 */
    sp_flags_t arm_flags;          /**< SP_FLAG_OVERFLOW when an arm saturated */
    const sp_platform_t *platform; /**< the platform the arms are of */
    const sp_platform_t *near_of;  /**< the platform `near` is of */
    uint8_t near;                  /**< 1 when every platform joint of near_of is within 2 m in each axis
                                        (its Jacobian cannot saturate: sp_setpoints_held skips those tests) */
    uint8_t fit;                   /**< 1 when near_of also has its base joints within 8 m in each axis: the
                                        legs of a pose within 16 m cannot overflow (the IK skips those tests) */
    uint8_t arms_valid;            /**< 1 when arm, arm_flags and platform belong to rot */
    uint8_t valid;                 /**< 1 when rpy, sc and rot belong together */
    uint8_t fresh;                 /**< 1 when another user of the keep (sp_frames_motion_to_platform_shared)
                                        changed the orientation since the IK's last call: the IK takes it as
                                        changed (a turning reference keeps no arms) */
    uint8_t rates_valid;           /**< 1 when body is sp_body_rates_sc(sc, rates_of): set by
                                        sp_frames_motion_to_platform_shared, cleared when an angle changes */
    sp_q24_t rates_of[6];          /**< the Euler rates (rad/s) and accelerations (rad/s^2) body is of, Q24 */
    sp_q24_t body[6];              /**< their body rates omega (rad/s) and omega_dot (rad/s^2), Q24: the inverse
                                        dynamics of the same motion takes them instead of making them again */
} sp_orient_keep_t;

/**
 * sp_inverse_kinematics with the orientation kept from the last call in
 * *keep: each angle equal to the kept one takes its kept sine and cosine,
 * and T is rebuilt only when an angle changed (only its yaw entries when
 * roll and pitch hold); the legs' arms are made
 * once an orientation repeats and kept while it holds (made again for
 * another platform pointer); a turn about the vertical alone (roll =
 * pitch = 0) takes T's yaw entries as yaw's sine and cosine (each
 * product with cos 0 rounds to its factor) and makes its arms with two
 * products a component instead of three (the third is exactly 0); a
 * platform with spi_legs_fit's bounds (joints within 2 m, base joints
 * within 8 m) at a position within 16 m skips the legs' overflow tests,
 * which cannot fail, and makes each leg's unit vector in the same pass.
 * The sines are a pure function of the angle,
 * the arms of T and the platform, so the result is sp_inverse_kinematics'
 * bit for bit (tests/unit/test_kinematics.c); a platform changed in place
 * under the same pointer needs valid set to 0. keep NULL:
 * sp_inverse_kinematics.
 * *keep is updated to this pose's orientation whatever the status (the
 * orientation cannot fail). Errors as sp_inverse_kinematics.
 */
sp_status_t sp_inverse_kinematics_kept(const sp_platform_t *platform, const sp_pose_t *pose, sp_orient_keep_t *keep,
                                       sp_ik_t *ik);

/**
 * Stretch of each leg from its length at the home pose: length - home length
 * (m, Q24). home_ik is the inverse kinematics of platform->home.
 * Saturates (SP_E_OVERFLOW) only for lengths beyond +-128 m.
 */
sp_status_t sp_leg_stretch(const sp_ik_t *ik, const sp_ik_t *home_ik, sp_q24_t stretch[SP_LEGS]);

/**
 * Body angular velocity omega (eq 10) and its exact time derivative, in the
 * motion frame (rad/s and rad/s^2, Q24), from the Euler angles (rad), their
 * rates (rad/s) and accelerations (rad/s^2), all Q24. The derivative keeps
 * the angle-rate product terms. Saturates (SP_E_OVERFLOW) beyond +-128.
 */
sp_status_t sp_body_rates(const sp_q24_t rpy[3], const sp_q24_t rpy_rate[3], const sp_q24_t rpy_acc[3],
                          sp_q24_t omega[3], sp_q24_t omega_dot[3]);

/**
 * sp_body_rates from the sines and cosines sc = {sin, cos} of roll, pitch,
 * yaw (Q30, as in sp_ik_t.sc) instead of the angles: no sine is computed.
 * Bit-identical to sp_body_rates for the sines of the same angles (yaw's
 * are not used). Same units, ranges and errors. Work that cannot change
 * the result is skipped: no turning gives 0, and a turn in yaw alone at
 * roll = pitch = 0 (sin 0 = 0, cos 0 = 2^30) gives the yaw rate and
 * acceleration about e_z exactly, with no product.
 */
sp_status_t sp_body_rates_sc(const sp_q30_t sc[6], const sp_q24_t rpy_rate[3], const sp_q24_t rpy_acc[3],
                             sp_q24_t omega[3], sp_q24_t omega_dot[3]);

/**
 * Leg extension rates d|l_i|/dt (m/s, Q24) = u_i . (v + w x (A_im T)), with
 * w the angular velocity in the base frame, from the pose's inverse
 * kinematics (sp_inverse_kinematics or sp_forward_kinematics: its T, arms,
 * unit vectors and the yaw's sine and cosine in sc), the linear velocity of
 * o' (m/s, Q24) and the Euler angle rates (rad/s, Q24). Saturates
 * (SP_E_OVERFLOW) beyond +-128 m/s.
 */
sp_status_t sp_leg_rates(const sp_ik_t *ik, const sp_q24_t vel[3], const sp_q24_t rpy_rate[3], sp_q24_t rate[SP_LEGS]);

/**
 * Builds the leg Jacobian of a pose from its inverse kinematics: row i =
 * [u_i, (A_im T) x u_i], base frame, Q28 (sp_jacobian_t, sp/model/lu6.h).
 * d|l_i| = row_i . [dR ; dw] for a small translation dR (m) and a small
 * rotation dw (rad, base frame). Its transpose maps the six cylinder forces
 * to the wrench on the platform about o'. Entries must stay below 8 in
 * magnitude (platform joints closer than ~8 m to o'); else SP_E_OVERFLOW.
 */
sp_status_t sp_jacobian(const sp_ik_t *ik, sp_jacobian_t *jac);

/** Options of the forward kinematics. */
typedef struct {
    uint32_t max_iterations; /**< Newton steps allowed (1..20) */
    sp_q24_t tolerance;      /**< converged when every |length residual| <= this, m, Q24 */
    sp_q24_t max_jump_pos;   /**< largest accepted distance of the result from the guess, m, Q24 */
    sp_q24_t max_jump_rot;   /**< largest accepted angle change from the guess, rad, Q24 */
} sp_fk_options_t;

/** Defaults: 8 iterations, 0.25 um tolerance, 50 mm and 50 mrad jumps. */
void sp_fk_default_options(sp_fk_options_t *opt);

/** What the forward kinematics did. */
typedef struct {
    uint32_t iterations; /**< Newton steps taken (Jacobian solves) */
    sp_q24_t residual;   /**< largest |length residual| at the result, m, Q24 */
} sp_fk_info_t;

/**
 * Forward kinematics: the pose whose legs have the given lengths (m, Q24),
 * by Newton-Raphson from `guess` (the previous tick's pose), with the exact
 * Jacobian. On SP_OK, *pose is the solution and, when ik is not NULL, *ik
 * its inverse kinematics (pass NULL when only the pose is wanted: the unit
 * vectors of the final pose are then not computed).
 * Errors (pose is then set to the guess, never to a half-converged value):
 *   SP_E_NO_CONVERGENCE  residual above tolerance after max_iterations, or
 *                        the iteration diverged until a value saturated;
 *   SP_E_SINGULAR        the Jacobian is singular on the way;
 *   SP_E_DISCONTINUITY   converged, but farther from the guess than allowed
 *                        (another assembly mode or a lost tick);
 *   SP_E_ARG / SP_E_RANGE / SP_E_OVERFLOW from the steps.
 * info (may be NULL) reports iterations and the final residual in all cases.
 * Bounded: at most max_iterations (<= 20) IK + solve steps.
 */
sp_status_t sp_forward_kinematics(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                                  const sp_fk_options_t *opt, sp_pose_t *pose, sp_ik_t *ik, sp_fk_info_t *info);

/** What the chord forward kinematics keeps of a pose between calls: its
 *  leg lengths (m, Q24) and the sines and cosines of roll, pitch, yaw
 *  (Q30), exactly as the IK of that pose computes them. */
typedef struct {
    sp_q24_t length[SP_LEGS];
    sp_q30_t sc[6];
} sp_fk_cache_t;

/**
 * Fills *cache for `pose` (one orientation and one IK of the lengths).
 * Errors: SP_E_ARG (NULL), SP_E_RANGE (a leg out of range: lengths zeroed).
 */
sp_status_t sp_fk_cache_of(const sp_platform_t *platform, const sp_pose_t *pose, sp_fk_cache_t *cache);

/**
 * sp_forward_kinematics (the same pose, bit for bit, the same errors and
 * info) that also fills *cache with the solution's leg lengths and sines,
 * exactly as sp_fk_cache_of(solution) would, for the next call of
 * sp_fk_chord; on error *cache is untouched. SP_E_ARG also for a NULL
 * cache.
 */
sp_status_t sp_fk_newton_cached(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                                const sp_fk_options_t *opt, sp_fk_cache_t *cache, sp_pose_t *pose, sp_fk_info_t *info);

/**
 * Forward kinematics by chord (quasi-Newton) steps: like
 * sp_forward_kinematics, but every step solves with one fixed
 * factorisation lu_t of J^T (sp_lu6_factor(jac, 1, ..)) taken at a pose
 * near the solution (at 1 kHz, the previous tick's reference) instead of
 * building and factorising the Jacobian at each iterate, and the first pass
 * takes the guess's lengths and sines from *cache (sp_fk_cache_of(guess) or
 * the previous successful call) instead of an IK. The convergence test is
 * the same (every |length residual| <= opt->tolerance), so the accuracy is
 * the same; only the number of steps can grow with the distance between
 * the factorisation's pose and the solution (linear instead of quadratic
 * convergence). On SP_OK, *pose is the solution and *cache is updated to
 * it; on error *pose is the guess and *cache is unchanged. Errors as
 * sp_forward_kinematics (SP_E_ARG also for an invalid lu_t). Bounded: at
 * most max_iterations (<= 20) solves and IKs.
 */
sp_status_t sp_fk_chord(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                        const sp_lu6_t *lu_t, const sp_fk_options_t *opt, sp_fk_cache_t *cache, sp_pose_t *pose,
                        sp_fk_info_t *info);

/**
 * One chord step of the forward kinematics, with no IK: the pose
 * from + J^-1 d_length, J the leg Jacobian at `from` given as the
 * factorisation lu_t of J^T (sp_lu6_factor(jac, 1, ..), as sp_fk_chord),
 * sc the sines and cosines of from's roll, pitch, yaw (Q30, sp_ik_t.sc or
 * sp_fk_cache_t.sc of from) and d_length the leg-length increments (m,
 * Q24). The solve gives a translation dR (m) and a small rotation dw (rad,
 * base frame); dw becomes Euler increments with from's own sines, exactly
 * as in the Newton and chord updates: d_roll = (cy wx + sy wy) / cp,
 * d_pitch = -sy wx + cy wy, d_yaw = wz + sp d_roll. d_length all zero
 * gives *pose = *from with no solve. The result is the forward kinematics
 * of from's lengths + d_length to first order: the error is second order
 * in |d_length| (sp/estimation/estimate.h gives the bound for the default platform).
 * Errors, *pose untouched: SP_E_ARG (NULL or lu_t not valid),
 * SP_E_SINGULAR (|cos pitch| < 0.01), SP_E_OVERFLOW (the solve saturated),
 * SP_E_NO_CONVERGENCE (a pose value would saturate: a step of 128 m or
 * 128 rad). Bounded: one transposed solve, no loop beyond the six legs.
 */
sp_status_t sp_fk_chord_step(const sp_lu6_t *lu_t, const sp_pose_t *from, const sp_q30_t sc[6],
                             const sp_q24_t d_length[SP_LEGS], sp_pose_t *pose);

/**
 * The sensors a drive link maps through: `sensors` when one of its legs has
 * a zero or a gain, NULL when all are zero (or `sensors` is NULL). The maps
 * below give the same lengths bit for bit either way; with NULL a tick pays
 * a copy instead of twelve 64-bit maps (a link's configuration calls this
 * once). Never fails.
 */
const sp_length_sensors_t *sp_length_sensors_in_use(const sp_length_sensors_t *sensors);

/**
 * A leg's joint-to-joint length (m, Q24) from its sensor's reading (m, Q24):
 * l = lmin + (r - zero - lmin) (1 + scale_inv), lmin the platform's
 * leg_length_min, zero and scale_inv the sensors' of leg `leg` (0..5). With
 * both zero, or `sensors` NULL, the length is the reading, bit for bit.
 * Saturates at the Q24 range (SP_E_OVERFLOW, *length saturated); SP_E_ARG
 * (*length untouched) for a NULL platform or length, or leg > 5.
 */
sp_status_t sp_length_from_sensor(const sp_platform_t *platform, const sp_length_sensors_t *sensors, unsigned leg,
                                  sp_q24_t reading, sp_q24_t *length);

/**
 * The sensor reading (m, Q24) at a leg's joint-to-joint length (m, Q24): the
 * inverse of sp_length_from_sensor (to 1 LSB), r = lmin + (l - lmin) (1 +
 * scale) + zero, for the drives' setpoints. With both zero, or `sensors`
 * NULL, the reading is the length, bit for bit. Saturates at the Q24 range
 * (SP_E_OVERFLOW); SP_E_ARG (*reading untouched) for a NULL platform or
 * reading, or leg > 5.
 */
sp_status_t sp_length_to_sensor(const sp_platform_t *platform, const sp_length_sensors_t *sensors, unsigned leg,
                                sp_q24_t length, sp_q24_t *reading);

#endif /* SP_KINEMATICS_H */
