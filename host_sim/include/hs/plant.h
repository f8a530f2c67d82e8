/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/plant.h - the simulated hydraulic hexapod: a 6-DOF rigid body driven by
 * six cylinders (hs/cylinder.h) under their axis drives (hs/drive.h), with
 * gravity, an external constant wrench and a spring-damper contact, and the
 * drives' sensors (hs/sensor.h). Physics only: the bus binding calls this API.
 *
 * Rigid body (docs/explanation/plant.md): state p (o' in the base frame), v = p', unit
 * quaternion q (motion -> base), w (angular velocity in the motion frame).
 *   m (v' + R (w' x c + w x (w x c))) = F,   F = sum_i F_i u_i + (0, 0, -m g) + F_ext + F_contact
 *   I w' + w x (I w) + m c x (R^T v') = R^T M,
 *   M = sum_i (R a_i) x F_i u_i + (R c) x (0, 0, -m g) + M_ext + r_k x F_contact
 *   q'   = q (0, w) / 2,  p' = v
 * with u_i the unit vector of leg i (from base joint B_i to platform joint
 * p + R a_i), F_i the cylinder force along it (positive pushes out), c the
 * centre of mass (motion frame; gravity acts there), I the full inertia
 * tensor about o' in the motion frame (the config's, about c, moved by the
 * parallel axes), r_k = R k the contact point. With c = 0 the terms in c
 * vanish and the plant computes exactly as before they existed (a state
 * hash test); with c != 0 each evaluation solves the coupled 6 x 6 system
 * (as with leg masses). Leg masses are neglected
 * by default, as in the paper and in the firmware's inverse dynamics
 * (docs/explanation/plant.md says why); with cylinder_mass or rod_mass > 0 in the
 * cylinder params each leg adds two point masses on its axis, coupled to
 * the platform by virtual work (docs/explanation/plant.md "Leg masses"), and the static
 * forces of init and rebalance include the legs' weight. Integration:
 * classic RK4, `substeps` fixed steps per cycle (default 10: 10 kHz for
 * 1 ms cycles), quaternion renormalised after every step;
 * the drives run once per substep with their command held over the step.
 *
 * Actuation modes: HS_ACT_HYDRAULIC (default: valves, chambers, friction,
 * end stops; forces follow from the pressures) and HS_ACT_IDEAL (the six
 * forces set by hs_plant_set_forces act exactly; no friction, no end stops;
 * the hydraulic states are frozen and the drives do not run).
 *
 * Legs are indexed 0..5 here (legs 1..6 of the DBC). The plant is a plain
 * struct: no heap, no globals, no clock; the same calls give bit-identical
 * results.
 */
#ifndef HS_PLANT_H
#define HS_PLANT_H

#include <stdint.h>

#include "hs/cylinder.h"
#include "hs/drive.h"
#include "hs/params.h"
#include "hs/sensor.h"

/* Layout of the integrated state vector. */
#define HS_X_POS 0                            /**< p, m (3) */
#define HS_X_VEL 3                            /**< v, m/s (3) */
#define HS_X_QUAT 6                           /**< q = [w, x, y, z] (4) */
#define HS_X_OMEGA 10                         /**< w, body frame, rad/s (3) */
#define HS_X_CYL 13                           /**< per leg i: 13 + 4 i + {0: p_A, 1: p_B, 2: spool, 3: spool rate} */
#define HS_X_BRISTLE (HS_X_CYL + 4 * HS_LEGS) /**< per leg i: LuGre bristle deflection z, m (hs/cylinder.h) */
#define HS_NX (HS_X_BRISTLE + HS_LEGS)

typedef enum { HS_ACT_HYDRAULIC = 0, HS_ACT_IDEAL = 1 } hs_actuation_t;

typedef enum {
    HS_CONTACT_NONE = 0,
    HS_CONTACT_PLANE = 1, /**< unilateral: pushes the point out of the half space behind a plane */
    HS_CONTACT_POINT = 2  /**< bilateral: a spring-damper from the point to a fixed anchor */
} hs_contact_kind_t;

/** A spring-damper contact between a point of the platform and the world. */
typedef struct {
    hs_contact_kind_t kind;
    double point[3];  /**< the contact point on the platform, motion frame, m */
    double normal[3]; /**< PLANE: normal (base frame, normalised by the plant) pointing into free space */
    double offset;    /**< PLANE: the surface is {x : normal . x = offset}, m */
    double anchor[3]; /**< POINT: anchor of the spring, base frame, m */
    double stiffness; /**< N/m, >= 0 */
    double damping;   /**< N s/m, >= 0 (PLANE: the total normal force never pulls) */
} hs_contact_t;

/** What a drive sends after each cycle (quantised, with noise). */
typedef struct {
    double length;             /**< measured leg length = length_counts * resolution, m */
    int64_t length_counts;     /**< length in units of the length resolution */
    double pressure_a;         /**< measured chamber A pressure = counts * resolution, Pa (>= 0) */
    double pressure_b;         /**< measured chamber B pressure, Pa (>= 0) */
    int64_t pressure_a_counts; /**< pressure_a in units of the pressure resolution */
    int64_t pressure_b_counts;
    hs_drive_state_t state;
    uint32_t faults; /**< HS_FAULT_* bits */
    uint64_t cycle;  /**< cycles completed when sampled */
} hs_feedback_t;

/** The true state, for tests, logs and plots. */
typedef struct {
    double time;              /**< s since init */
    uint64_t cycle;           /**< cycles completed */
    double pose[6];           /**< x, y, z (m), roll, pitch, yaw (rad) */
    double quat[4];           /**< unit quaternion motion -> base, [w, x, y, z] */
    double vel[3];            /**< velocity of o', base frame, m/s */
    double omega_body[3];     /**< angular velocity, motion frame, rad/s */
    double omega_base[3];     /**< angular velocity, base frame, rad/s */
    double length[HS_LEGS];   /**< leg lengths, m */
    double rate[HS_LEGS];     /**< leg extension rates, m/s */
    double force[HS_LEGS];    /**< cylinder forces on the platform along the legs, N */
    double friction[HS_LEGS]; /**< cylinder friction forces (included in force with a minus sign; positive opposes
                                   extension), N; 0 in ideal mode */
    double pa[HS_LEGS];       /**< chamber pressures, Pa (frozen in ideal mode) */
    double pb[HS_LEGS];
    double spool[HS_LEGS];     /**< spool positions, -1..1 */
    double valve_cmd[HS_LEGS]; /**< drive outputs of the last substep */
    double block[HS_LEGS];     /**< blocking valves' opening, 0 (closed) .. 1 (open) (hs/drive.h) */
    double contact_force[3];   /**< force of the contact on the platform, base frame, N */
    double wrench[6];          /**< what the outside world exerts on the platform: external wrench + contact, force (N)
                           and moment about o' (N m), base frame; not gravity, legs or loads (hs_plant_add_mass) */
} hs_state_t;

/** Energies (J). total = kinetic + gravity + oil + springs. */
typedef struct {
    double kinetic; /**< m v^2 / 2 + w^T I w / 2 (+ the legs' kinetic energy, leg masses on) */
    double gravity; /**< m g z (+ the legs' m g z, leg masses on) */
    double oil;     /**< compressed oil (hs_cyl_oil_energy), hydraulic mode only */
    double springs; /**< end-stop springs and friction bristles sigma_0 z^2 / 2 (hydraulic mode), the contact spring */
    double total;
} hs_energy_t;

/** An injected length-sensor fault (hs_plant_inject_sensor). */
typedef enum {
    HS_SENSOR_OK = 0,    /**< the sensor reads the true length */
    HS_SENSOR_STICK = 1, /**< it reads `value` (m) whatever the length */
    HS_SENSOR_JUMP = 2,  /**< it reads the true length + `value` (m) */
    HS_SENSOR_NOISE = 3  /**< it reads the true length + `value` (m) x a unit noise sample (seeded) */
} hs_sensor_fault_t;

/** Faults injected into the plant (the fault injector, docs/explanation/faults.md):
 *  each stays until removed, and is the cause a drive's fault reset checks. */
typedef struct {
    hs_sensor_fault_t sensor[HS_LEGS]; /**< length sensor of each leg */
    double sensor_value[HS_LEGS];      /**< its value, m */
    int valve_stuck[HS_LEGS];          /**< 1: the spool follows valve_cmd below, not the drive */
    double valve_cmd[HS_LEGS];         /**< the stuck valve's command, -1..1 */
    uint32_t held[HS_LEGS];            /**< drive fault bits whose cause persists (fault ... hold) */
    int supply_lost;                   /**< 1: the supply pressure is at the tank's */
    double supply[HS_LEGS];            /**< the nominal supply pressures (at init), Pa: what the drives'
                                            supply monitor compares with, and what a return restores */
    hs_rng_t rng;                      /**< the injected noise's generator (the sensors' own stays untouched) */
} hs_plant_faults_t;

/** The plant. Treat as opaque; use the functions. */
typedef struct {
    hs_params_t par;
    hs_actuation_t act;
    double x[HS_NX];
    double ideal_force[HS_LEGS];
    double ext_force[3];
    double ext_moment[3];
    hs_contact_t contact;
    hs_drive_t drive[HS_LEGS];
    double valve_cmd[HS_LEGS];
    hs_rng_t rng;
    hs_feedback_t fb[HS_LEGS];
    double inertia_inv[3][3];
    double inv_mass;
    double time;
    uint64_t cycle;
    int legs_on;           /**< some leg mass > 0 (set by hs_plant_init from the params) */
    int com_on;            /**< centre of mass off o' (par.com != 0): the coupled equations */
    hs_plant_faults_t inj; /**< injected faults (none after init) */
} hs_plant_t;

/**
 * Starts the plant at rest at `pose` (x, y, z m; roll, pitch, yaw rad):
 * hydraulic mode, no external load, no contact, every drive in INIT, spools
 * at null, and the chambers pre-pressurised (hs_cyl_holding_pressures) with
 * the static forces that hold the pose against gravity, which are also the
 * initial ideal forces. Seeds the noise, samples the first feedback.
 * Errors: HS_E_ARG (NULL, bad params: hs_params_check), HS_E_RANGE (a leg
 * outside its stroke by more than the cushion length, or non-finite pose),
 * HS_E_SINGULAR (no static forces at that pose). The plant is unusable on error.
 */
hs_status_t hs_plant_init(hs_plant_t *plant, const hs_params_t *params, const double pose[6]);

/** Selects the actuation (HS_ACT_HYDRAULIC or HS_ACT_IDEAL). HS_E_ARG otherwise. */
hs_status_t hs_plant_set_actuation(hs_plant_t *plant, hs_actuation_t mode);

/** Sets the velocity of o' (base frame, m/s) and the body angular velocity
 *  (motion frame, rad/s). HS_E_ARG on NULL or non-finite values. */
hs_status_t hs_plant_set_twist(hs_plant_t *plant, const double vel[3], const double omega_body[3]);

/** Constant external force at o' (N) and moment about o' (N m), base frame;
 *  either may be NULL for zero. HS_E_ARG on non-finite values. */
hs_status_t hs_plant_set_wrench(hs_plant_t *plant, const double force[3], const double moment[3]);

/** The most elastic force a contact may exert the moment it is installed
 *  (N): a surface placed through the platform's path rather than at it
 *  (0.2 m deep at 9e6 N/m is 1.8 MN at once) is an impact, which this
 *  model is not made for: its state went non-finite within 10 ms. */
#define HS_CONTACT_START_FORCE_MAX 1.0e5

/** Installs a contact (NULL or kind NONE removes it). HS_E_ARG for a
 *  negative stiffness/damping, a zero normal or non-finite values;
 *  HS_E_RANGE when its elastic force at the present pose would exceed
 *  HS_CONTACT_START_FORCE_MAX (the contact is then not installed). */
hs_status_t hs_plant_set_contact(hs_plant_t *plant, const hs_contact_t *contact);

/** The magnitude of the elastic force (N) contact `c` would exert at the
 *  plant's present pose (a plane's normal taken at unit length); 0 for
 *  NULL or kind NONE. */
double hs_contact_start_force(const hs_plant_t *plant, const hs_contact_t *c);

/**
 * Re-computes the static forces at the current pose for gravity (at the
 * centre of mass), the external wrench, the contact's elastic force and the
 * legs' weight (leg masses on), and sets the ideal forces and (at rest,
 * valves at null, bristles relaxed) the chamber pressures to hold them.
 * HS_E_SINGULAR near a singular pose.
 */
hs_status_t hs_plant_rebalance(hs_plant_t *plant);

/**
 * Attaches a rigid point mass `mass` (kg; negative removes one) at `point`
 * (motion frame, m) to the platform from now on: the plant's mass, centre
 * of mass and inertia about o' become those of the combined body (parallel
 * axes). Nothing else changes at this instant (velocities, pressures,
 * forces): call hs_plant_rebalance to hold the new body at rest, or, to
 * start with it, add it to the params (hs_params_add_mass) before
 * hs_plant_init.
 * HS_E_ARG on NULL or non-finite values, HS_E_RANGE (plant unchanged) if
 * the result is not a rigid body (hs_rigid_body_check: mass <= 0, inertia
 * about the new centre of mass not positive definite or breaking the
 * triangle inequality).
 */
hs_status_t hs_plant_add_mass(hs_plant_t *plant, double mass, const double point[3]);

/**
 * Load holding of drive `leg` (0..5) from its next cycle (hs_drive_set_block:
 * closed != 0 puts its valve at null and closes its blocking valves; 0
 * opens them). HS_E_ARG for a bad leg.
 */
hs_status_t hs_plant_set_block(hs_plant_t *plant, int leg, int closed);

/**
 * Setpoint of drive `leg` (0..5) for the next cycle: length (m), velocity
 * (m/s), force feed-forward (N, positive pushes out), requested mode. Feeds
 * the watchdog. HS_E_ARG for a bad leg, non-finite values or an unknown mode.
 */
hs_status_t hs_plant_set_setpoint(hs_plant_t *plant, int leg, double length, double velocity, double force,
                                  hs_drive_request_t mode);

/** Ideal-mode cylinder forces (N, positive pushes out), held until changed.
 *  HS_E_ARG on NULL or non-finite values. */
hs_status_t hs_plant_set_forces(hs_plant_t *plant, const double force[HS_LEGS]);

/** Raises fault bits on a drive (HS_FAULT_COMM from the bus layer, or a
 *  fault injection); severe bits put it in FAULT. HS_E_ARG for a bad leg. */
hs_status_t hs_plant_raise_faults(hs_plant_t *plant, int leg, uint32_t bits);

/** Clears a drive's fault bits (FAULT -> INIT). HS_E_ARG for a bad leg. */
hs_status_t hs_plant_clear_faults(hs_plant_t *plant, int leg);

/**
 * Fault reset of drive `leg` (the rising edge of the setpoints' FaultReset):
 * clears its faults (FAULT -> INIT) only when no cause remains, else keeps
 * them, adds the remaining causes' bits and leaves the state as it is.
 * Causes: an injected sensor fault (HS_FAULT_SENSOR), a stuck valve
 * (HS_FAULT_VALVE), the supply lost (HS_FAULT_PRESSURE), the cylinder
 * beyond a stroke end (HS_FAULT_END_STOP), held injected bits, a non-finite
 * state (HS_FAULT_INTERNAL). *remaining (if not NULL) gets the remaining
 * causes' bits, 0 when the faults were cleared. HS_E_ARG for a bad leg.
 */
hs_status_t hs_plant_fault_reset(hs_plant_t *plant, int leg, uint32_t *remaining);

/** Injects a length-sensor fault on `leg` (HS_SENSOR_OK removes it; STICK
 *  with value <= 0 sticks at the last measured length). HS_E_ARG for a bad
 *  leg or mode, or a non-finite value. */
hs_status_t hs_plant_inject_sensor(hs_plant_t *plant, int leg, hs_sensor_fault_t mode, double value);

/** Sticks the valve of `leg` at command u (-1..1; 0 < stuck), or frees it
 *  (stuck 0). HS_E_ARG for a bad leg or |u| > 1. */
hs_status_t hs_plant_inject_valve(hs_plant_t *plant, int leg, int stuck, double u);

/** Supply pressure loss (lost 1: every cylinder's supply at the tank
 *  pressure) or its return (0). HS_E_ARG on NULL. Each drive monitors its
 *  supply (as a servo drive with a P-port pressure sensor does): below half
 *  its nominal pressure it raises HS_FAULT_PRESSURE and enters FAULT, its
 *  valve at null, so that the oil columns hold the platform instead of its
 *  position loop draining them (hs_drive_fail). */
hs_status_t hs_plant_inject_supply(hs_plant_t *plant, int lost);

/** Raises fault bits on drive `leg` whose cause persists (until bits 0 is
 *  given): a fault reset keeps them. HS_E_ARG for a bad leg. */
hs_status_t hs_plant_inject_drive(hs_plant_t *plant, int leg, uint32_t bits);

/**
 * Advances one cycle of dt seconds (0 < dt <= 0.1): drive cycle logic
 * (requests, watchdog), then `substeps` RK4 steps each preceded by the
 * drives' sensor sampling and control update, then the feedback sampling.
 * If the state becomes non-finite, the offending substep is undone, every
 * drive gets HS_FAULT_INTERNAL and HS_E_NUMERIC is returned.
 */
hs_status_t hs_plant_step(hs_plant_t *plant, double dt);

/** The feedback of drive `leg` sampled at the end of the last cycle (or at
 *  init). HS_E_ARG for NULL or a bad leg. */
hs_status_t hs_plant_feedback(const hs_plant_t *plant, int leg, hs_feedback_t *fb);

/** The true state (see hs_state_t). HS_E_ARG on NULL. */
hs_status_t hs_plant_state(const hs_plant_t *plant, hs_state_t *st);

/** The true pose [x, y, z, roll, pitch, yaw]. HS_E_ARG on NULL. */
hs_status_t hs_plant_pose(const hs_plant_t *plant, double pose[6]);

/** Energies of the current state. HS_E_ARG on NULL. */
hs_status_t hs_plant_energy(const hs_plant_t *plant, hs_energy_t *e);

#endif /* HS_PLANT_H */
