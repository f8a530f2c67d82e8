/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/kin.h - rigid-body geometry in double precision for the plant: the
 * orientation in the three forms the plant uses (Euler angles of the paper,
 * rotation matrix, unit quaternion), body rates (eq 10), leg lengths (eq 1)
 * and a pivoted 6x6 solve.
 *
 * Conventions (docs/explanation/model.md, Frames and pose): pose = [x, y, z, roll, pitch, yaw] (m,
 * rad); R = Rz(yaw) Ry(pitch) Rx(roll) is the column rotation from the
 * motion frame to the base frame (R = T^T of the paper). The quaternion
 * q = [w, x, y, z] represents the same rotation: v_base = q v_motion q*.
 * All functions are pure and allocation-free.
 */
#ifndef HS_KIN_H
#define HS_KIN_H

#include "hs/params.h"

/** R = Rz(rpy[2]) Ry(rpy[1]) Rx(rpy[0]). No failure mode. */
void hs_rot_from_rpy(const double rpy[3], double r[3][3]);

/** Unit quaternion of the same rotation (w >= 0 not enforced). */
void hs_quat_from_rpy(const double rpy[3], double q[4]);

/** Rotation matrix of a quaternion; q need not be exactly unit (it is used
 *  as given: the plant renormalises after every step). */
void hs_rot_from_quat(const double q[4], double r[3][3]);

/** Roll, pitch, yaw of R (pitch in [-pi/2, pi/2], roll and yaw in
 *  (-pi, pi]). At |pitch| = pi/2 (gimbal lock of the angles, not of the
 *  plant) yaw is set to 0 and roll carries the rotation. r is not modified
 *  (not declared const: C99 would not convert double[3][3] to it). */
void hs_rpy_from_rot(double r[3][3], double rpy[3]);

/** Body angular velocity (motion frame, rad/s) from Euler angles and their
 *  rates (eq 10 of the paper for R = Rz Ry Rx). */
void hs_body_rates(const double rpy[3], const double rpy_rate[3], double omega[3]);

/** Euler angle rates from the body angular velocity (inverse of eq 10).
 *  HS_E_RANGE at |cos(pitch)| < 1e-9 (rates undefined), else HS_OK. */
hs_status_t hs_euler_rates(const double rpy[3], const double omega[3], double rpy_rate[3]);

/** Joint-to-joint leg lengths (m) at a pose, eq (1). HS_E_ARG on NULL. */
hs_status_t hs_leg_lengths(const hs_params_t *params, const double pose[6], double length[HS_LEGS]);

/**
 * Solves A x = b (6x6, row-major a[row][col]) by Gaussian elimination with
 * partial pivoting, on copies (a and b are not modified). A pivot below
 * 1e-12 times the largest |entry| gives HS_E_SINGULAR and x = 0.
 */
hs_status_t hs_solve6(double a[6][6], const double b[6], double x[6]);

/**
 * The six cylinder forces (N, positive pushes the platform away from the
 * base) that hold the platform at rest at `pose` against gravity (at the
 * centre of mass params->com) and an
 * external wrench (force at o' and moment about o', both base frame, N and
 * N m; either may be NULL for none). HS_E_SINGULAR near a singular pose.
 */
hs_status_t hs_static_forces(const hs_params_t *params, const double pose[6], const double ext_force[3],
                             const double ext_moment[3], double force[HS_LEGS]);

#endif /* HS_KIN_H */
