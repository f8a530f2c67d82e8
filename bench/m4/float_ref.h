/* SPDX-License-Identifier: Apache-2.0 */
/*
 * float_ref.h - a single-precision float implementation of the core's
 * inverse kinematics and inverse dynamics, written for the Cortex-M4
 * instruction-count comparison only (bench/m4/icount_float.c; docs/explanation/m4.md).
 * It follows the fixed-point core step for step (sp_orientation,
 * sp_inverse_kinematics, sp_body_rates, sp_jacobian, sp_solve6,
 * sp_inverse_dynamics): the same sine/cosine (reduction by pi/2, the same
 * Taylor polynomials), three divisions per unit vector, the same pivoted
 * elimination, so that the ratio of the two counts measures the number
 * format, not a different algorithm. Units: m, rad, s, kg, N (SI), float.
 * Not part of the firmware; tests/m4/test_m4_float_ref.c checks it against
 * the core.
 */
#ifndef M4_FLOAT_REF_H
#define M4_FLOAT_REF_H

#include "sp/model/platform.h"
#include "sp/math/status.h"

typedef struct {
    float base_joint[SP_LEGS][3];     /**< B_i, base frame, m */
    float platform_joint[SP_LEGS][3]; /**< A_im, motion frame, m */
    float mass;                       /**< kg */
    float inertia[3][3];              /**< about o', motion frame, kg m^2 */
    float center_of_mass[3];          /**< motion frame, m */
    float gravity;                    /**< m/s^2 */
    float cylinder_mass;              /**< each leg's barrel, kg */
    float cylinder_com;               /**< its centre from the base joint, m */
    float rod_mass;                   /**< each leg's rod and piston, kg */
    float rod_com;                    /**< its centre from the platform joint, m */
    float leg_inertia;                /**< barrel's + rod's moments of inertia across the leg, kg m^2 */
} m4f_platform_t;

typedef struct {
    float pos[3];      /**< m */
    float rpy[3];      /**< rad */
    float vel[3];      /**< m/s */
    float rpy_rate[3]; /**< rad/s */
    float acc[3];      /**< m/s^2 */
    float rpy_acc[3];  /**< rad/s^2 */
} m4f_motion_t;

typedef struct {
    float rot[3][3];        /**< T (eq 2) */
    float arm[SP_LEGS][3];  /**< A_im T, m */
    float leg[SP_LEGS][3];  /**< l_i (eq 1), m */
    float length[SP_LEGS];  /**< |l_i|, m */
    float unit[SP_LEGS][3]; /**< l_i / |l_i| */
} m4f_ik_t;

/** The fixed-point platform in float (SI units). */
void m4f_platform_from_fixed(const sp_platform_t *platform, m4f_platform_t *out);

/** A fixed-point motion in float (SI units). */
void m4f_motion_from_fixed(const sp_motion_t *motion, m4f_motion_t *out);

/** sin and cos of x (rad, |x| < 2^22): reduction by pi/2 (two-constant),
 *  Taylor polynomials to x^11 and x^12 on [-pi/4, pi/4]. */
void m4f_sincos(float x, float *s, float *c);

/** Inverse kinematics (eq 1). SP_E_ARG (NULL), SP_E_RANGE (a leg component
 *  beyond 64 m or a leg shorter than 1 mm), else SP_OK. */
sp_status_t m4f_inverse_kinematics(const m4f_platform_t *platform, const float pos[3], const float rpy[3],
                                   m4f_ik_t *ik);

/** Body angular velocity (eq 10) and its time derivative, motion frame. */
sp_status_t m4f_body_rates(const float rpy[3], const float rpy_rate[3], const float rpy_acc[3], float omega[3],
                           float omega_dot[3]);

/** Inverse dynamics: the six cylinder forces (N) for the motion, no
 *  external force, with the centre of mass off o' and the leg masses as
 *  the core has them (sp_inverse_dynamics, docs/explanation/model.md "Leg masses"). SP_E_ARG (NULL), SP_E_SINGULAR (pivot below 1e-3; forces
 *  zeroed), else SP_OK. ik must be the inverse kinematics of the pose. */
sp_status_t m4f_inverse_dynamics(const m4f_platform_t *platform, const m4f_motion_t *motion, const m4f_ik_t *ik,
                                 float force[SP_LEGS]);

#endif /* M4_FLOAT_REF_H */
