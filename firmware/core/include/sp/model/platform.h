/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/model/platform.h - the platform description the core computes with.
 *
 * One source of truth: config/platform_default.json. The build generates
 * sp_platform_default (sp_platform_default.c) from that file with
 * tools/dev/gen_platform.py, so the firmware and the host tools cannot
 * disagree. Frames and conventions follow the paper (docs/explanation/model.md, Frames and pose):
 * base frame at the base centroid o, z up; motion frame at the platform
 * centroid o'.
 */
#ifndef SP_PLATFORM_H
#define SP_PLATFORM_H

#include "sp/math/fixed.h"

#define SP_LEGS 6

/** Pose of the motion frame: position of o' in the base frame and the
 *  paper's roll, pitch, yaw (eq 2). pos in m, rpy in rad, both Q24. */
typedef struct {
    sp_q24_t pos[3]; /**< x, y, z of o' in the base frame, m, Q24 */
    sp_q24_t rpy[3]; /**< roll phi, pitch theta, yaw psi, rad, Q24 */
} sp_pose_t;

/** A pose with its first and second time derivatives (what the reference
 *  generator produces each tick). */
typedef struct {
    sp_pose_t pose;
    sp_q24_t vel[3];      /**< dx/dt, dy/dt, dz/dt, m/s, Q24 */
    sp_q24_t rpy_rate[3]; /**< d(roll, pitch, yaw)/dt, rad/s, Q24 */
    sp_q24_t acc[3];      /**< d2(x, y, z)/dt2, m/s^2, Q24 */
    sp_q24_t rpy_acc[3];  /**< d2(roll, pitch, yaw)/dt2, rad/s^2, Q24 */
} sp_motion_t;

/** The mass of one leg: the barrel, pivoting about the base joint, and the
 *  rod with its piston, sliding in it and pivoting with it
 *  (sp_inverse_dynamics). Each is a rigid body symmetric about the leg
 *  axis with its centre on the axis: its mass, its centre, and its moment
 *  of inertia about its centre across the leg (about any axis through the
 *  centre perpendicular to the leg; the moment about the leg axis itself
 *  is not modelled: the legs' spin about their axes is neglected).
 *  docs/explanation/model.md "Leg inertia". All zero: massless legs, as in
 *  the paper; inertias zero: point masses. Every field >= 0 (a negative
 *  one fails sp_inverse_dynamics with SP_E_ARG). */
typedef struct {
    sp_q16_t cylinder_mass;    /**< barrel, kg, Q16 */
    sp_q24_t cylinder_com;     /**< barrel's centre from the base joint along the leg, m, Q24 */
    sp_q16_t rod_mass;         /**< rod and piston, kg, Q16 */
    sp_q24_t rod_com;          /**< rod's centre from the platform joint towards the base, m, Q24 */
    sp_q16_t cylinder_inertia; /**< barrel's moment of inertia about its centre across the leg, kg m^2, Q16 */
    sp_q16_t rod_inertia;      /**< rod and piston's about their centre across the leg, kg m^2, Q16 */
} sp_leg_mass_t;

/** Geometry, inertia and limits of one 6-6 platform. */
typedef struct {
    sp_q24_t base_joint[SP_LEGS][3];     /**< B_i, base frame, m, Q24 */
    sp_q24_t platform_joint[SP_LEGS][3]; /**< A_im, motion frame, m, Q24 */
    sp_q16_t mass;                       /**< moving mass, kg, Q16 (< 32768 kg) */
    sp_q16_t inertia[3][3];              /**< about o' (not the centre of mass), motion frame, kg m^2, Q16 */
    sp_q24_t center_of_mass[3];          /**< centre of the moving mass, motion frame, m, Q24 */
    sp_q24_t gravity;                    /**< g along -z of the base frame, m/s^2, Q24 */
    sp_pose_t home;                      /**< neutral pose */
    sp_pose_t park;                      /**< parked pose */
    sp_q24_t leg_length_min;             /**< joint-to-joint length at the lower stop, m, Q24 */
    sp_q24_t leg_length_max;             /**< joint-to-joint length at the upper stop, m, Q24 */
    sp_q8_t force_max;                   /**< largest commanded |cylinder force|, N, Q8 */
    sp_q24_t leg_velocity_max;           /**< largest commanded |leg rate|, m/s, Q24 */
    sp_pose_t workspace_min;             /**< pose limits relative to home, m / rad, Q24 */
    sp_pose_t workspace_max;             /**< pose limits relative to home, m / rad, Q24 */
    sp_q30_t piston_area;                /**< cylinder piston-side area, m^2, Q30 (0: unknown) */
    sp_q30_t annulus_area;               /**< cylinder rod-side (annulus) area, m^2, Q30 */
    sp_leg_mass_t leg_mass;              /**< every leg's mass (all zero: massless legs) */
    sp_q8_t viscous_friction[SP_LEGS];   /**< cylinder i's viscous friction, N s/m, Q8 */
    sp_q8_t coulomb_friction[SP_LEGS];   /**< cylinder i's Coulomb friction level, N, Q8 */
    sp_q24_t coulomb_velocity;           /**< |leg rate| at which the Coulomb term is full, m/s, Q24 (> 0) */
    /* The seals' LuGre friction (the plant's model, docs/explanation/plant.md "Friction"),
     * for the friction observer (sp/estimation/friction.h). sigma_0 and sigma_1 are
     * derived by tools/stewart/config.py bristle_parameters, the same numbers
     * the plant simulates. */
    sp_q8_t breakaway_friction[SP_LEGS]; /**< cylinder i's static (break-away) level F_s >= F_c, N, Q8 */
    sp_q24_t stribeck_velocity;          /**< v_s, decay of the break-away excess, m/s, Q24 (> 0) */
    int32_t bristle_stiffness[SP_LEGS];  /**< sigma_0 = F_c / presliding displacement, N/m, Q0 (integer,
                                              < 2.1e9; 0: no bristles) */
    sp_q8_t bristle_damping[SP_LEGS];    /**< sigma_1, N s/m, Q8 (< 8.4e6) */
} sp_platform_t;

/** The legs' length sensors as calibrated (config "length_sensors", written by
 *  stewart calibrate): leg i reads leg_length_min + (1 + k_i) (l - leg_length_min)
 *  + zero_i at the joint-to-joint length l. All zero: the sensor reads l. Kept
 *  apart from sp_platform_t: only the drives' link maps through it
 *  (sp_length_from_sensor, sp_length_to_sensor). */
typedef struct {
    sp_q24_t zero[SP_LEGS];      /**< zero_i, m, Q24, |.| <= 0.05 m */
    sp_q30_t scale[SP_LEGS];     /**< k_i, Q30, |.| <= 0.01 */
    sp_q30_t scale_inv[SP_LEGS]; /**< 1 / (1 + k_i) - 1, Q30 (the generator computes it) */
} sp_length_sensors_t;

/** The default platform, generated at build time from
 *  config/platform_default.json. */
extern const sp_platform_t sp_platform_default;

/** The default platform's length sensors (its config's "length_sensors";
 *  all zero without the section). */
extern const sp_length_sensors_t sp_length_sensors_default;

#endif /* SP_PLATFORM_H */
