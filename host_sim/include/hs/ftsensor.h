/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/ftsensor.h - a six-axis force/torque sensor between the platform and
 * the tool, as force-controlled machines carry one.
 *
 * Mounting: its origin at `mount_pos` in the motion frame, its axes turned by
 * `mount_rpy` (Z-Y-X, as the platform's angles) from the motion frame's.
 * Every external load acts through the tool beyond the sensor (a contact, a
 * person's push on the tool's handle, an applied wrench); the platform's own
 * payload (hs_plant_add_mass) is on the platform side and is not seen. With
 * the tool massless the reading is the wrench that the world exerts on the
 * tool, in sensor axes, the moment about the sensor's origin:
 *   F_s = (R R_m)^T F,   M_s = (R R_m)^T (M_o' - r x F),   r = R mount_pos
 * with F, M_o' the plant's external wrench (base frame, about o') and R the
 * platform's orientation.
 *
 * Imperfections, all seeded (hs/sensor.h), so a run repeats exactly:
 * - its own sample clock at `rate_hz`, not aligned with the 1 kHz cycle: a
 *   reading is the last sample taken, the truth interpolated linearly
 *   between the two cycle ends around the sample instant;
 * - a bias per axis, uniform within +-bias_*, drawn at init;
 * - a drift per axis, a linear rate uniform within +-drift_* per second
 *   (thermal drift), also drawn at init;
 * - noise per sample, standard deviation noise_*;
 * - quantisation to res_* and saturation at +-range_* (the reading is held
 *   there and `saturated` set).
 */
#ifndef HS_FTSENSOR_H
#define HS_FTSENSOR_H

#include <stdint.h>

#include "hs/sensor.h"
#include "hs/status.h"

/** Parameters (forces in N, moments in N m, rates in Hz, drifts per s). */
typedef struct {
    double mount_pos[3];              /**< sensor origin in the motion frame, m */
    double mount_rpy[3];              /**< sensor axes from the motion frame's, rad (Z-Y-X) */
    double rate_hz;                   /**< sample rate, > 0 */
    double noise_force, noise_moment; /**< standard deviation per sample, >= 0 */
    double bias_force, bias_moment;   /**< |initial bias| per axis at most, >= 0 */
    double drift_force, drift_moment; /**< |drift| per axis at most, per second, >= 0 */
    double res_force, res_moment;     /**< resolution, > 0 */
    double range_force, range_moment; /**< measuring range, > 0 */
} hs_ft_params_t;

/** State. Treat as opaque; use the functions. */
typedef struct {
    hs_ft_params_t par;
    double mount[3][3]; /**< R_m, motion frame <- sensor axes */
    hs_rng_t rng;
    double bias[6];  /**< at time 0 */
    double drift[6]; /**< per second */
    double t;        /**< time of the last advance, s */
    double t_next;   /**< next sample instant, s */
    double prev[6];  /**< the truth in sensor axes at time t, for the interpolation */
    int have_prev;
    double reading[6]; /**< the last sample: Fx, Fy, Fz (N), Mx, My, Mz (N m), quantised units times res */
    uint32_t samples;  /**< samples taken (wraps; a counter, not a clock) */
    int saturated;     /**< 1 when the last sample was held at its range */
} hs_ft_t;

/** The default parameters: a sensor for 10 kN / 1 kN m, 7 kHz, at o', axes
 *  along the motion frame's. */
hs_ft_params_t hs_ft_default_params(void);

/** Checks the parameters, draws bias and drift from the seed. HS_E_ARG on NULL
 *  or a parameter outside its range (nothing changed). */
hs_status_t hs_ft_init(hs_ft_t *ft, const hs_ft_params_t *par, uint64_t seed);

/** The truth in sensor axes for an external wrench (base frame, about o') with
 *  the platform at orientation rot (motion -> base): see the file comment. */
void hs_ft_truth(const hs_ft_t *ft, double rot[3][3], const double wrench[6], double out[6]);

/**
 * Advances the sensor to time t (s, not before the last call) with the
 * external wrench `wrench` (base frame, about o') and the orientation rot
 * at t: takes every sample whose instant falls in (t_last, t]. HS_E_ARG on
 * NULL or a time going back (nothing changed).
 */
hs_status_t hs_ft_advance(hs_ft_t *ft, double t, double rot[3][3], const double wrench[6]);

#endif /* HS_FTSENSOR_H */
