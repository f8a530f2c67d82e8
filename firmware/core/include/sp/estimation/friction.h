/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/estimation/friction.h - friction observer: the cylinders' seal friction from the
 * measured leg lengths.
 *
 * The seals have LuGre friction with stiction (docs/explanation/plant.md "Friction"): a
 * bristle deflection z per seal, loaded by the stroke and relaxing towards
 * the Stribeck level g(v). At rest a seal holds up to the break-away force,
 * which the chamber pressures do not show. The observer runs the same
 * bristle dynamics, driven by the measured length increments: the 1 um
 * length sensor resolves the presliding deflection (sigma_0 = F_c / 0.1 mm,
 * about 4 N per um with the default seals).
 *
 * Discrete law, per leg and tick (docs/explanation/model.md "Friction observer"), with
 * the bristle force phi = sigma_0 z, dx = L - L_prev, v = dx / dt,
 * e = exp(-(v / v_s)^2), g = F_c + (F_s - F_c) e:
 *
 *   phi' = s g + (phi - s g) exp(-sigma_0 |dx| / g),   s = sign(dx)
 *   F    = phi' + sigma_1 e (phi' - phi) / (sigma_0 dt) + c_v v
 *
 * The phi update is the exact solution of the LuGre displacement law
 * dphi/dx = sigma_0 (1 - sign(dx) phi / g) over dx at a constant v, so it is
 * stable for any step (no explicit Euler: sigma_0 |v| dt / g reaches 5) and
 * |phi| never exceeds max(|phi|, g). F opposes the stroke (positive while the
 * leg lengthens), in the plant's convention F_net = p_A A_A - p_B A_B - F.
 *
 * Pure functions: the state is passed in; no allocation, no floating point.
 */
#ifndef SP_FRICTION_H
#define SP_FRICTION_H

#include <stdint.h>

#include "sp/math/fixed.h"
#include "sp/model/platform.h"
#include "sp/math/status.h"

/** Longest tick sp_fric_obs_step accepts, us. */
#define SP_FRIC_TICK_MAX_US 1000000u

/** The observer's state, all six legs. */
typedef struct {
    sp_q8_t phi[SP_LEGS];     /**< bristle force sigma_0 z per leg, N, Q8 (|phi| <= max(F_s)) */
    sp_q24_t length[SP_LEGS]; /**< last measured joint-to-joint length per leg, m, Q24 */
    int32_t slip[SP_LEGS];    /**< sigma_0 / F_c per leg, 1/m, Q8: taken from the platform at the first step */
    int32_t tau[SP_LEGS];     /**< sigma_1 / sigma_0 per leg, s, Q30: taken at the first step */
    int64_t inv_vs;           /**< 2^46 / v_s (v_s in Q24): taken at the first step */
    uint8_t valid;            /**< 0 after reset: the next step only records the lengths */
} sp_fric_obs_t;

/** Entries of the observer's Stribeck table (sp_fric_table_t): the
 *  length increments |dx| = 1..SP_FRIC_TABLE_LEN (Q24 LSB per tick). 336
 *  covers the default seals' region below 4 v_s at 1 ms (v_s = 5 mm/s:
 *  |dx| < 20 um = 335.5 LSB); 1,344 bytes an array. */
#define SP_FRIC_TABLE_LEN 336u

/**
 * What a slow leg's step needs, prepared per |dx| (sp_fric_table_prepare).
 * Below 4 v_s the Stribeck fade e = exp(-(v/v_s)^2) and the bristle
 * relaxation exp(-sigma_0 |dx| / g), g = F_c + (F_s - F_c) e, depend on
 * |dx| alone for a leg of given sigma_0, F_c and F_s at a given tick: the
 * slow leg's two exps and its reciprocal F_c / g become two loads.
 */
typedef struct {
    sp_q30_t relax[SP_FRIC_TABLE_LEN]; /**< exp(-sigma_0 |dx| / g) at |dx| = index + 1, Q30, of the table's
                                            legs */
    sp_q30_t fade[SP_FRIC_TABLE_LEN];  /**< the Stribeck fade exp(-(v/v_s)^2) at |dx| = index + 1, Q30 (the
                                           same for every leg) */
    int64_t inv_vs;                    /**< 2^46 / v_s, as the observer keeps it */
    uint32_t tick_us;                  /**< the tick it was prepared for, us */
    uint16_t count;                    /**< entries prepared: |dx| in 1..count is below 4 v_s */
    uint8_t legs;                      /**< bit i: leg i has the table's sigma_0, F_c and F_s */
} sp_fric_table_t;

/**
 * Reset the observer: bristles unloaded (phi = 0), no length recorded. The
 * next sp_fric_obs_step records the lengths only. A NULL o is ignored.
 */
void sp_fric_obs_reset(sp_fric_obs_t *o);

/**
 * One tick of the friction observer.
 *
 *   p        platform: viscous_friction (c_v), coulomb_friction (F_c),
 *            breakaway_friction (F_s >= F_c), stribeck_velocity (v_s > 0),
 *            bristle_stiffness (sigma_0, N/m Q0), bristle_damping (sigma_1)
 *   o        state, updated in place
 *   length   measured joint-to-joint leg lengths this tick, m, Q24
 *   tick_us  time since the previous call, us, 1..SP_FRIC_TICK_MAX_US
 *   friction out: each cylinder's seal friction, N, Q8; positive opposes
 *            lengthening (the plant's F_friction)
 *
 * The first call after sp_fric_obs_reset records the lengths and outputs 0
 * for every leg (no increment yet; the bristles start unloaded); it also
 * keeps sigma_0 / F_c per leg, so a platform whose friction changes needs a
 * reset. At rest (no length change) a leg costs nothing but its held phi;
 * sliding faster than 4 v_s takes no division (the Stribeck excess there,
 * exp(-16), is taken as 0) and, once its phi is within 1 LSB of F_c (as
 * a steady slide leaves it), no exp either. A leg with
 * sigma_0 = 0 has no bristles: its phi stays 0 and its friction is the
 * viscous part c_v v only.
 *
 * Returns SP_OK; SP_E_ARG (nothing written, state unchanged) on a NULL
 * pointer, tick_us outside 1..SP_FRIC_TICK_MAX_US or platform friction
 * parameters the law cannot run with (sigma_0 < 0, sigma_1 < 0, c_v < 0, or
 * sigma_0 > 0 with F_c <= 0, F_s < F_c or v_s <= 0); SP_E_OVERFLOW when an
 * intermediate or an output saturated (outputs and state are then the
 * saturated values; nothing wraps). A length jump of 128 m or more between
 * two calls is taken as 128 m (SP_E_OVERFLOW).
 */
sp_status_t sp_fric_obs_step(const sp_platform_t *p, sp_fric_obs_t *o, const sp_q24_t length[SP_LEGS], uint32_t tick_us,
                             sp_q8_t friction[SP_LEGS]);

/**
 * Prepares the Stribeck table of platform p at the tick tick_us (us,
 * 1..SP_FRIC_TICK_MAX_US) for sp_fric_obs_step_table: for |dx| = 1, 2, ...
 * while |v| = |dx| / dt stays below 4 v_s (at most SP_FRIC_TABLE_LEN
 * entries), the relaxation that sp_fric_obs_step computes for the first
 * leg with bristles; tab->legs marks that leg and every leg
 * with its sigma_0, F_c and F_s. The entries are computed by the step's
 * own code, so a step with the table is bit for bit the step without it.
 * About 200 Cortex-M4 instructions an entry (at init, not in a tick).
 * Returns SP_OK (no leg with bristles: an empty table); SP_E_ARG on NULL
 * p, a tick out of range or parameters sp_fric_obs_check refuses (tab,
 * when not NULL, is then empty: count 0).
 */
sp_status_t sp_fric_table_prepare(const sp_platform_t *p, uint32_t tick_us, sp_fric_table_t *tab);

/**
 * sp_fric_obs_step with a table prepared by sp_fric_table_prepare from
 * the same platform: a leg of tab->legs with |dx| <= tab->count takes its
 * relaxation and its Stribeck fade from the table instead of two exps and
 * a reciprocal. Same results, state and returns as sp_fric_obs_step, bit for bit (a
 * table of another tick or Stribeck velocity, or NULL, is not used).
 */
sp_status_t sp_fric_obs_step_table(const sp_platform_t *p, sp_fric_obs_t *o, const sp_fric_table_t *tab,
                                   const sp_q24_t length[SP_LEGS], uint32_t tick_us, sp_q8_t friction[SP_LEGS]);

/**
 * SP_OK when the platform's friction parameters are ones sp_fric_obs_step
 * runs with (see there), SP_E_ARG otherwise or on NULL. The controller
 * checks its platform once at init (sp_ctrl_init) and then steps the
 * observer without the per-tick check (about 120 Cortex-M4 instructions
 * of the tick).
 */
sp_status_t sp_fric_obs_check(const sp_platform_t *p);

/**
 * exp(-u) for u >= 0, u Q24, result Q30 in [0, 1]: range reduction
 * u = k ln 2 + r, exp(-r) on [0, ln 2) as exp(-j/32) from a 23-entry
 * table times exp(-d) for d = r - j/32 in [0, 1/32) by three Taylor
 * terms (remainder d^4 / 24 < 4.1e-8, 44 LSB), then the shift by k. Max
 * error against libm 64 LSB of Q30 (6e-8; tests/unit/test_friction.c
 * measures 42) plus the input's own quantisation (0.5 LSB of Q24 = 3e-8
 * relative): 0.0001 N on a 600 N seal. u <= 0 returns 1 (Q30);
 * u >= 31 ln 2 returns 0. Cannot fail.
 */
sp_q30_t sp_fric_exp_neg(sp_q24_t u);

#endif /* SP_FRICTION_H */
