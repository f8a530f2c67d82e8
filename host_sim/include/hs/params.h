/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/params.h - parameters of the plant simulator.
 *
 * Two layers:
 *  - hs_config_t mirrors config/platform_default.json key for key (SI units,
 *    radians). hs_config_default is generated from that file at build time by
 *    tools/dev/gen_plant.py (which validates it with stewart.config), so
 *    the plant, the firmware and the host tools read the same numbers.
 *  - hs_params_t is what the plant computes with: areas, volumes, valve
 *    coefficients and the drive gains derived from the config by
 *    hs_params_from_config(). Tests may build a config by hand, or edit any
 *    field of hs_params_t after deriving it (it is plain data, copied into the
 *    plant by hs_plant_init).
 *
 * Frames (docs/explanation/model.md, Frames and pose): base frame at the base centroid o, z up;
 * motion frame at the platform centroid o'; pose = [x, y, z, roll, pitch,
 * yaw] with the column rotation motion->base R = Rz(yaw) Ry(pitch) Rx(roll).
 */
#ifndef HS_PARAMS_H
#define HS_PARAMS_H

#include <stdint.h>

#include "hs/status.h"

#define HS_LEGS 6

/** config "hydraulic" section (see config/README.md), SI units. */
typedef struct {
    double piston_diameter;             /**< bore, m */
    double rod_diameter;                /**< m, < bore */
    double dead_volume;                 /**< oil volume of each chamber at its stroke end (lines, ports), m^3 */
    double piston_mass;                 /**< piston + rod, kg (sets the drive gains only; leg masses: rod_mass below) */
    double bulk_modulus;                /**< effective oil bulk modulus, Pa */
    double supply_pressure;             /**< Pa */
    double tank_pressure;               /**< Pa */
    double valve_rated_flow;            /**< flow per metering land at full opening and rated drop, m^3/s */
    double valve_rated_pressure_drop;   /**< drop per land at which the rated flow is given, Pa */
    double valve_natural_frequency;     /**< spool natural frequency, Hz */
    double valve_damping;               /**< spool damping ratio */
    double leakage_coefficient;         /**< internal (piston) leakage A<->B, m^3/(s Pa) */
    double viscous_friction[HS_LEGS];   /**< per cylinder (leg 1 first), N s/m */
    double coulomb_friction[HS_LEGS];   /**< per cylinder, N */
    double breakaway_friction[HS_LEGS]; /**< static (break-away) level per cylinder, N, >= coulomb (= it: no peak) */
    double coulomb_velocity;            /**< smoothing of the Coulomb term: full level from |v| = this, m/s */
    double stribeck_velocity;           /**< decay velocity of the break-away excess (Stribeck curve), m/s */
    double presliding_displacement;     /**< LuGre bristle deflection at the Coulomb level, F_c / sigma_0, m */
    double bristle_stiffness[HS_LEGS];  /**< LuGre sigma_0 per cylinder, N/m (0: memoryless); derived by the
                                             generator (tools/stewart/config.py bristle_parameters) */
    double bristle_damping[HS_LEGS];    /**< LuGre sigma_1 per cylinder, N s/m; derived there too */
    double end_cushion_length;          /**< length of the cushioned zone before each stroke end, m */
    double end_stop_stiffness;          /**< N/m, beyond the stroke ends */
    double end_stop_damping;            /**< N s/m, beyond the stroke ends (and reached at the end of the cushion) */
    /* Optional leg masses (config keys may be absent: 0 = off, the default;
     * docs/explanation/plant.md "Leg masses"). Each leg is two rigid bodies on its axis:
     * a mass at its centre and a moment of inertia across the leg. */
    double cylinder_mass;    /**< cylinder body (barrel), kg, >= 0 */
    double cylinder_com;     /**< its centre of mass from the base joint B_i along the leg, m, >= 0 */
    double rod_mass;         /**< rod + piston (sliding part), kg, >= 0 */
    double rod_com;          /**< its centre of mass from the platform joint towards the base, m, >= 0 */
    double cylinder_inertia; /**< barrel's moment of inertia about its centre across the leg, kg m^2, >= 0 */
    double rod_inertia;      /**< rod + piston's about their centre across the leg, kg m^2, >= 0 */
} hs_hydraulic_config_t;

/** config "sensors" section. */
typedef struct {
    double length_resolution;     /**< leg length quantum, m */
    double pressure_resolution;   /**< chamber pressure quantum, Pa */
    double pressure_noise;        /**< standard deviation of the pressure noise, Pa */
    uint64_t seed;                /**< seed of the noise generator */
    double length_zero[HS_LEGS];  /**< as built: reading beyond the true length at leg_length_min, m */
    double length_scale[HS_LEGS]; /**< as built: the reading's gain error over the stroke, - */
} hs_sensor_config_t;

/** config "force_sensor" section (the plant's sensor; its noise, bias and
 *  drift are hs_ft_default_params'). */
typedef struct {
    double mount_pos[3]; /**< sensor origin, motion frame, m */
    double mount_rpy[3]; /**< sensor axes from the motion frame's, rad (Z-Y-X) */
    double rate_hz;      /**< sample rate, Hz */
} hs_ft_config_t;

/** The platform config file, key for key. */
typedef struct {
    const char *name;
    double base_joints[HS_LEGS][3];     /**< B_i, base frame, m */
    double platform_joints[HS_LEGS][3]; /**< A_im, motion frame, m */
    double mass;                        /**< kg */
    double center_of_mass[3];           /**< centre of mass of the moving body, motion frame, m ([0,0,0] = o') */
    double inertia[3][3];               /**< about the centre of mass, axes of the motion frame, kg m^2 */
    double gravity;                     /**< m/s^2 along -z of the base frame */
    double home[6];                     /**< pose */
    double park[6];                     /**< pose */
    double leg_length_min;              /**< joint-to-joint length at the lower stop, m */
    double leg_length_max;              /**< joint-to-joint length at the upper stop, m */
    double force_max;                   /**< N */
    double leg_velocity_max;            /**< m/s */
    hs_hydraulic_config_t hydraulic;
    hs_sensor_config_t sensors;
    hs_ft_config_t force_sensor;
} hs_config_t;

/** The default config, generated at build time from config/platform_default.json. */
extern const hs_config_t hs_config_default;

/** One cylinder with its servo valve, derived (see hs_params_from_config). */
typedef struct {
    double area_a;             /**< piston-side area pi D^2/4, m^2 */
    double area_b;             /**< rod-side (annulus) area pi (D^2 - d^2)/4, m^2 */
    double length_min;         /**< joint-to-joint length at stroke 0, m */
    double stroke;             /**< usable stroke leg_length_max - leg_length_min, m */
    double dead_volume_a;      /**< chamber A volume at stroke 0, m^3 */
    double dead_volume_b;      /**< chamber B volume at full stroke, m^3 */
    double piston_mass;        /**< kg, drive gains only (not integrated; see rod_mass) */
    double bulk_modulus;       /**< Pa */
    double supply_pressure;    /**< Pa */
    double tank_pressure;      /**< Pa */
    double pressure_max;       /**< chamber pressures are clamped to [0, pressure_max], Pa */
    double valve_gain;         /**< K = rated flow / sqrt(rated drop), m^3/(s sqrt(Pa)) per land at full opening */
    double valve_transition;   /**< orifice laminar transition pressure p_t (hs/cylinder.h), Pa */
    double valve_omega;        /**< spool natural frequency, rad/s */
    double valve_damping;      /**< spool damping ratio */
    double leakage;            /**< m^3/(s Pa) */
    double viscous_friction;   /**< sigma_2, N s/m */
    double coulomb_friction;   /**< F_c, N */
    double breakaway_friction; /**< F_s >= F_c: the static (break-away) level, N */
    double coulomb_velocity;   /**< v_c: the memoryless Coulomb term's smoothing (hs/cylinder.h), m/s */
    double stribeck_velocity;  /**< v_s: decay of the break-away excess F_s - F_c, m/s */
    double bristle_stiffness;  /**< sigma_0 of the LuGre friction, N/m; 0: memoryless friction (no stiction) */
    double bristle_damping;    /**< sigma_1 of the LuGre friction (faded out above v_s), N s/m */
    double cushion_length;     /**< m */
    double stop_stiffness;     /**< N/m */
    double stop_damping;       /**< N s/m */
    /* Leg masses (docs/explanation/plant.md "Leg masses"): all 0 = neglected (default,
     * as the firmware's inverse dynamics). Point masses on the leg axis. */
    double cylinder_mass; /**< cylinder body, kg, >= 0 */
    double cylinder_com;  /**< its centre from the base joint along the leg, m, 0..length_min + stroke */
    double rod_mass;      /**< rod + piston, kg, >= 0 (independent of piston_mass, which only sets the drive gains) */
    double rod_com;       /**< its centre from the platform joint towards the base, m, 0..length_min + stroke */
    double cylinder_inertia; /**< barrel's moment of inertia about its centre across the leg, kg m^2, >= 0 */
    double rod_inertia;      /**< rod + piston's about their centre across the leg, kg m^2, >= 0 */
} hs_cyl_params_t;

/** Sensor model of every axis. */
typedef struct {
    double length_resolution;   /**< m, > 0 */
    double pressure_resolution; /**< Pa, > 0 */
    double pressure_noise;      /**< Pa (standard deviation), >= 0 */
    uint64_t seed;
    /* as built (config "as_built", tools/stewart/asbuilt.py): leg i reads
     * length_min + (1 + length_scale[i]) (l - length_min) + length_zero[i] at the
     * true joint-to-joint length l; all zero: the machine as drawn */
    double length_zero[HS_LEGS];  /**< m, |.| <= 0.05 */
    double length_scale[HS_LEGS]; /**< -, |.| <= 0.01 */
} hs_sensor_params_t;

/** Axis drive (position loop of each cylinder), see hs/drive.h. */
typedef struct {
    double kp;                  /**< valve command per metre of position error, 1/m */
    double kf;                  /**< valve command per newton of high-passed force error, 1/N */
    double force_highpass;      /**< corner of the high-pass on the force error, rad/s */
    double ff_gain;             /**< scale of the velocity feed-forward (1 = the valve/cylinder model inverse) */
    double following_error_max; /**< |position error| above which the drive faults, m */
    uint32_t timeout_cycles;    /**< cycles without a setpoint in ACTIVE before HOLD + timeout bit, >= 1 */
    double spool_error_max;     /**< valve monitor: |modelled - measured spool| (fraction of full opening) ... */
    double spool_error_time;    /**< ... above which for this long (s) is a valve fault; 0 < . */
    double sensor_check_travel; /**< sensor plausibility: travel the valve flow predicts while the length reading
                                     stays unchanged above which the sensor is faulty, m, > 0 */
    double block_time;          /**< the blocking valves' closing (and opening) time, s, >= 0 (0: at once) */
} hs_drive_params_t;

/** Everything the plant needs. */
typedef struct {
    double base_joint[HS_LEGS][3];     /**< B_i, base frame, m */
    double platform_joint[HS_LEGS][3]; /**< A_im, motion frame, m */
    double mass;                       /**< moving mass, kg, > 0 */
    double com[3];                     /**< its centre of mass c, motion frame, m (0: o', the old equations exactly) */
    double inertia[3][3];              /**< about o' (not c), motion frame, kg m^2, symmetric positive definite */
    double gravity;                    /**< m/s^2, >= 0 */
    double leg_length_min;             /**< m */
    double leg_length_max;             /**< m */
    double home[6];                    /**< neutral pose */
    hs_cyl_params_t cyl[HS_LEGS];
    hs_sensor_params_t sensors;
    hs_drive_params_t drive;
    uint32_t substeps; /**< RK4 steps per cycle, 1..1000 (default 10: 10 kHz at 1 ms) */
} hs_params_t;

/**
 * Derives the plant parameters from a config: areas from the diameters,
 * chamber dead volumes, valve coefficient K = Q_rated / sqrt(dp_rated),
 * spool frequency in rad/s, pressure clamp at 1.2 x supply, laminar
 * transition 1 bar, per-leg friction with the LuGre bristles (stiffness
 * F_c / 0.1 mm, damping critical for a sixth of the moving mass, bounded to
 * stay dissipative; none without a Coulomb level), the inertia moved from
 * the centre of mass to o' (parallel axes), and the drive gains from the
 * hydraulic natural frequency at mid stroke with a sixth of the moving mass
 * per cylinder (docs/explanation/plant.md: position loop gain w_h / 4, pressure
 * feedback for a damping ratio of about 0.5). 10 substeps per cycle.
 * Returns HS_E_ARG for NULL or a config that hs_params_check rejects.
 */
hs_status_t hs_params_from_config(const hs_config_t *config, hs_params_t *params);

/** hs_params_from_config(&hs_config_default, params). */
hs_status_t hs_params_default(hs_params_t *params);

/**
 * Checks that every value is finite and in its physical range (positive
 * masses, areas, volumes; a rigid body (hs_rigid_body_check); supply above
 * tank; stroke positive; substeps 1..1000; leg masses >= 0 with their
 * centres 0..leg length max from their joints; break-away friction >= Coulomb;
 * with bristles a Coulomb level > 0 and a dissipative bristle damping,
 * hs/cylinder.h; ...). HS_OK or HS_E_ARG.
 */
hs_status_t hs_params_check(const hs_params_t *params);

/**
 * Checks that mass (kg), centre of mass `com` (motion frame, m) and inertia
 * about o' (motion frame, kg m^2) describe a rigid body: mass > 0, all
 * finite, inertia symmetric, the inertia about the centre of mass (parallel
 * axes) positive definite and its principal moments within the triangle
 * inequality (tr(I_c)/2 - I_c positive semi-definite, tolerance 1e-9 of the
 * trace). `inertia_rows`: the 3x3 tensor row by row (&inertia[0][0]).
 * HS_OK or HS_E_ARG (also for NULL).
 */
hs_status_t hs_rigid_body_check(double mass, const double com[3], const double *inertia_rows);

/**
 * Adds a rigid point mass `mass` (kg; negative removes one) at `point`
 * (motion frame, m) to the moving body of `params`: mass, centre of mass
 * (mass-weighted) and inertia about o' (+ mass (|r|^2 1 - r r^T)). The
 * drive gains are not re-derived (a payload the drives were not tuned
 * for). HS_E_ARG on NULL or non-finite values; HS_E_RANGE, params
 * unchanged, if the result is not a rigid body (hs_rigid_body_check).
 */
hs_status_t hs_params_add_mass(hs_params_t *params, double mass, const double point[3]);

#endif /* HS_PARAMS_H */
