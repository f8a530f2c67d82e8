/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/rig.h - a single cylinder moving a mass along its own axis: the test
 * rig of one axis (hydraulic natural frequency, valve and drive tuning). It
 * uses the same cylinder model as the plant (hs_cyl_eval) and the same
 * integrator (RK4).
 *   m s'' = F_cyl(s, s', state, u) - m g_axis + F_ext
 */
#ifndef HS_RIG_H
#define HS_RIG_H

#include "hs/cylinder.h"

/* State vector layout. */
#define HS_RIG_STROKE 0  /**< s, m */
#define HS_RIG_RATE 1    /**< s', m/s */
#define HS_RIG_CYL 2     /**< p_A, p_B, spool, spool rate */
#define HS_RIG_BRISTLE 6 /**< LuGre bristle deflection z, m */
#define HS_RIG_NX 7

typedef struct {
    hs_cyl_params_t cyl;
    double mass;      /**< kg moved by the cylinder (load + piston) */
    double gravity;   /**< acceleration opposing extension, m/s^2 (g for a vertical cylinder, 0 lying) */
    double ext_force; /**< constant external force along the axis, N (positive pushes out) */
    double x[HS_RIG_NX];
    double time; /**< s */
} hs_rig_t;

/**
 * At rest at stroke s (m), chambers pre-pressurised to hold m g
 * (hs_cyl_holding_pressures), spool at null, bristles relaxed (z = 0), no
 * external force.
 * HS_E_ARG for NULL, mass <= 0, non-finite values or s outside [0, stroke].
 */
hs_status_t hs_rig_init(hs_rig_t *rig, const hs_cyl_params_t *cyl, double mass, double gravity, double stroke);

/** One RK4 step of h seconds (0 < h <= 0.01) with valve command u held.
 *  HS_E_ARG for bad arguments, HS_E_NUMERIC if the state became non-finite
 *  (the step is undone). Pressures are clamped to [0, pressure_max] after the step. */
hs_status_t hs_rig_step(hs_rig_t *rig, double u, double h);

/** Evaluates the cylinder at the rig's current state with command u. */
void hs_rig_eval(const hs_rig_t *rig, double u, hs_cyl_eval_t *out);

#endif /* HS_RIG_H */
