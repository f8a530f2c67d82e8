/* SPDX-License-Identifier: Apache-2.0 */
/*
 * ref_model.h - the double-precision reference model of the C tests: the
 * paper's equations written plainly in double, in the project's conventions
 * (docs/explanation/model.md), to check the fixed-point core against. One copy, used by
 * the unit tests (tests/unit), the plant tests and tests/m4.
 *
 * Conventions: a pose is q = (x, y, z, roll, pitch, yaw) (m, rad); the
 * rotation from the motion frame to the base frame (column vectors) is
 * R = Rz(yaw) Ry(pitch) Rx(roll), the paper's T is R^T. Rates and
 * accelerations are 6-vectors in the same order (m/s, rad/s; m/s^2,
 * rad/s^2).
 */
#ifndef REF_MODEL_H
#define REF_MODEL_H

#include <math.h>
#include <stdint.h>

#include "sp/model/platform.h"

/* (Two-dimensional inputs are not const: C99 does not convert double
 * (*)[3] to const double (*)[3].) */

/* ---- Q formats <-> double ------------------------------------------------ */

/** A Q24, Q30, Q16 or Q8 value as a double (exact). */
static inline double ref_f24(int32_t v)
{
    return (double)v / 16777216.0;
}
static inline double ref_f30(int32_t v)
{
    return (double)v / 1073741824.0;
}
static inline double ref_f16(int32_t v)
{
    return (double)v / 65536.0;
}
static inline double ref_f8(int32_t v)
{
    return (double)v / 256.0;
}

/** A double rounded to Q24, Q16 or Q8 (to nearest; the value must fit). */
static inline int32_t ref_q24(double x)
{
    return (int32_t)llround(x * 16777216.0);
}
static inline int32_t ref_q16(double x)
{
    return (int32_t)llround(x * 65536.0);
}
static inline int32_t ref_q8(double x)
{
    return (int32_t)llround(x * 256.0);
}

/** The pose's six coordinates in double (exact). */
void ref_pose_from_sp(const sp_pose_t *pose, double q[6]);

/* ---- the model ------------------------------------------------------------ */

/** R = Rz(yaw) Ry(pitch) Rx(roll) of rpy = (roll, pitch, yaw) (rad). */
void ref_rot(const double rpy[3], double r[3][3]);

/**
 * Inverse kinematics (eq 1) of pose q on the platform p (its joints, Q24,
 * taken exactly): per leg i the arm R A_i (base frame, m), the length |l_i|
 * of l_i = R A_i + pos - B_i (m) and the unit vector l_i / |l_i|. Any of
 * the outputs may be NULL.
 */
void ref_ik(const sp_platform_t *p, const double q[6], double len[SP_LEGS], double unit[SP_LEGS][3],
            double arm[SP_LEGS][3]);

/**
 * Body angular velocity w (eq 10) and its exact time derivative wd, motion
 * frame, from the sines and cosines sc = {sin roll, cos roll, sin pitch,
 * cos pitch} (used as given: they need not lie on the unit circle) and the
 * Euler angle rates and accelerations (rad/s, rad/s^2).
 */
void ref_body_rates_sc(const double sc[4], const double rpy_rate[3], const double rpy_acc[3], double w[3],
                       double wd[3]);

/** ref_body_rates_sc of the angles rpy (rad). */
void ref_body_rates(const double rpy[3], const double rpy_rate[3], const double rpy_acc[3], double w[3], double wd[3]);

/** Leg extension rates u_i . (v + w x arm_i) (m/s) for the linear velocity
 *  v (m/s) and the angular velocity w (rad/s), both in the base frame. */
void ref_leg_rates(double unit[SP_LEGS][3], double arm[SP_LEGS][3], const double v[3], const double w[3],
                   double rate[SP_LEGS]);

/**
 * The wrench (force, N; moment about o', N m; base frame) that the legs
 * must exert for the motion (pose q, rates qd, accelerations qdd) of the
 * rigid platform of p (mass, inertia about o' in the motion frame, gravity
 * along -z) with an external force ext (N) at o': Newton-Euler,
 * [m (a + g e_z) - ext ; R (I wd + w x I w)].
 */
void ref_wrench_needed(const sp_platform_t *p, const double q[6], const double qd[6], const double qdd[6],
                       const double ext[3], double wrench[6]);

/** The wrench of the leg forces f (N, along the unit vectors) about o':
 *  sum_i f_i [u_i ; arm_i x u_i] (J^T f). */
void ref_wrench_of_forces(const double f[SP_LEGS], double unit[SP_LEGS][3], double arm[SP_LEGS][3], double wrench[6]);

#endif /* REF_MODEL_H */
