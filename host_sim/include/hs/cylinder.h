/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/cylinder.h - one double-acting hydraulic cylinder with its 4-way servo
 * valve: the right-hand side of its differential equations and the forces
 * it puts on the platform. Pure functions; the integration is done by the
 * plant (hs/plant.h) and the single-axis rig (hs/rig.h).
 *
 * Model (docs/explanation/plant.md). Stroke s = leg length - length_min (0 at the lower
 * stop, `stroke` at the upper), s' its rate. Chamber A (piston side) pushes
 * the leg out, chamber B (rod side) pulls it in.
 *   V_A = V_A0 + A_A s,  V_B = V_B0 + A_B (S - s)   (each >= V0 / 2)
 *   p_A' = beta / V_A (Q_A - A_A s' - Q_L),  p_B' = beta / V_B (Q_B + A_B s' + Q_L)
 *   Q_L = C_L (p_A - p_B)                        (internal leakage)
 *   spool x (-1..1): x'' = w_v^2 (u - x) - 2 z_v w_v x'   (u: valve command)
 *   critically centred 4-way valve, orifice g(dp) = sign(dp) sqrt|dp| for
 *   |dp| >= p_t, and below the laminar transition p_t the odd cubic
 *   g = dp / sqrt(p_t) (1.25 - 0.25 (dp / p_t)^2), same value and slope at p_t:
 *     x >= 0: Q_A = K x g(p_S - p_A),   Q_B = -K x g(p_B - p_T)
 *     x <  0: Q_A = K x g(p_A - p_T),   Q_B = -K x g(p_S - p_B)
 *     with x clamped to [-1, 1] in the flow (the spool's stops).
 *   Pressure rates are zeroed where they would push a pressure out of
 *   [0, pressure_max] (cavitation / relief); the integrator clamps too.
 *   Force on the platform along the leg:
 *     F = p_A A_A - p_B A_B - F_f + F_stop
 *   Friction F_f (opposes s'), with the Stribeck curve
 *     g(v) = F_c + (F_s - F_c) exp(-(v / v_s)^2)     (F_s: break-away level)
 *   - bristle_stiffness sigma_0 > 0 (the default): LuGre, one state z per
 *     cylinder (the mean bristle deflection, m):
 *       z' = s' - sigma_0 |s'| z / g(s')
 *       F_f = sigma_0 z + sigma_1 exp(-(s'/v_s)^2) z' + c_v s'
 *     At rest the bristles hold any force below F_s as a spring (presliding
 *     displacement z = F / sigma_0) that the pressures do not show; above it
 *     the cylinder slips; steady sliding gives c_v v + sign(v) g(v). The
 *     damping sigma_1 fades out above v_s, which keeps the friction
 *     dissipative (with the bristle energy sigma_0 z^2 / 2 counted) as long as
 *     0.429 sigma_1 v_s <= 4 F_c (hs_params_check).
 *   - sigma_0 = 0: memoryless, F_f = c_v s' + g(s') sat(s' / v_c), with
 *     sat(y) = y (3 - y^2) / 2 for |y| < 1 and sign(y) beyond (no stiction:
 *     it vanishes at rest; with F_s = F_c the friction of before issue 14,
 *     bit for bit).
 *   End stops: in the last `cushion_length` before each end, a cushion
 *   damping c_stop * depth / cushion_length acts while moving towards the
 *   end; beyond the end a spring-damper k_stop * d + c_stop * d' (never
 *   pulling) pushes back.
 */
#ifndef HS_CYLINDER_H
#define HS_CYLINDER_H

#include "hs/params.h"

/** The integrated state of one cylinder. */
typedef struct {
    double pa;      /**< chamber A pressure, Pa */
    double pb;      /**< chamber B pressure, Pa */
    double xv;      /**< spool position, fraction of full opening (-1..1 nominal) */
    double xv_rate; /**< spool velocity, 1/s */
    double z;       /**< LuGre bristle deflection, m (0 and unused with bristle_stiffness 0) */
} hs_cyl_state_t;

/** Result of one evaluation. */
typedef struct {
    double dpa, dpb;       /**< pressure rates, Pa/s */
    double dxv, dxv_rate;  /**< spool velocity (1/s) and acceleration (1/s^2) */
    double dz;             /**< bristle deflection rate, m/s (0 without bristles) */
    double force;          /**< total force on the platform along the leg, N (positive pushes out) */
    double pressure_force; /**< p_A A_A - p_B A_B, N */
    double friction;       /**< friction force (opposes s'), N: force includes -friction */
    double stop;           /**< end stop + cushion force, N (included in force) */
    double qa, qb;         /**< valve flows into chamber A and into chamber B, m^3/s */
} hs_cyl_eval_t;

/**
 * Evaluates the model at stroke s (m), stroke rate (m/s), state and valve
 * command u (clamped to [-1, 1] here). No failure mode for finite inputs;
 * non-finite inputs give non-finite outputs (the plant detects them).
 */
void hs_cyl_eval(const hs_cyl_params_t *c, const hs_cyl_state_t *st, double stroke, double rate, double u,
                 hs_cyl_eval_t *out);

/** Chamber volumes at stroke s (m^3), with the floor V0/2 the model uses. */
double hs_cyl_volume_a(const hs_cyl_params_t *c, double stroke);
double hs_cyl_volume_b(const hs_cyl_params_t *c, double stroke);

/**
 * Energy stored in the compressed oil of both chambers (J): for a constant
 * bulk modulus a sealed chamber keeps V exp(p / beta) constant and stores
 * U = beta V (exp(p / beta) - 1 - p / beta) relative to p = 0; its rate is
 * -p dV/dt exactly, so with closed valves, no leakage and no friction the
 * plant's total energy (hs_plant_energy) is conserved.
 */
double hs_cyl_oil_energy(const hs_cyl_params_t *c, double stroke, double pa, double pb);

/** Elastic energy of the end-stop spring at stroke s (J; 0 inside the stroke). */
double hs_cyl_stop_energy(const hs_cyl_params_t *c, double stroke);

/**
 * Chamber pressures (Pa) that produce `force` (N) at rest with the valve at
 * null and p_A + p_B = p_S + p_T (the steady state of a 4-way valve with
 * matched lands feeding only the leakage), clamped to [p_T, p_S]. This is
 * how the plant pre-pressurises the cylinders to hold a pose.
 */
void hs_cyl_holding_pressures(const hs_cyl_params_t *c, double force, double *pa, double *pb);

/**
 * Valve command that moves the cylinder at `velocity` (m/s) while it
 * delivers `force` (N), from the steady-state valve and cylinder equations
 * (flow continuity through both lands, load pressure from the force;
 * leakage neglected). Saturated to [-1, 1]; a force the supply cannot
 * deliver in that direction gives +-1. 0 for velocity 0.
 */
double hs_cyl_velocity_command(const hs_cyl_params_t *c, double velocity, double force);

/**
 * Hydraulic natural frequency (rad/s) of the cylinder at stroke s moving a
 * mass m (kg) with the valve closed: w = sqrt(beta (A_A^2/V_A + A_B^2/V_B) / m).
 * 0 for m <= 0.
 */
double hs_cyl_natural_frequency(const hs_cyl_params_t *c, double stroke, double mass);

#endif /* HS_CYLINDER_H */
