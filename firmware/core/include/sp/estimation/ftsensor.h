/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/estimation/ftsensor.h - a six-axis force/torque sensor between the platform and
 * the tool, as the second source of the external wrench for force control
 * (the first is the cylinders' estimate, sp/estimation/wrench.h).
 *
 * The sensor reports the wrench that the world exerts on the tool, in its own
 * axes, the moment about its own origin. It is mounted at `pos` in the motion
 * frame with its axes turned by R_m (motion frame <- sensor axes). With the
 * platform's T (its rows are the platform's axes in base coordinates, so
 * R = T^T turns motion-frame vectors into base ones) the wrench on the
 * platform in the controller's convention (base frame, moment about o') is
 *     F = R R_m F_s,     M_o' = R R_m M_s + r x F,     r = R pos.
 * (The tool beyond the sensor is taken as massless, or its weight is in the
 * bias that the tare removes.)
 *
 * The tare: with the platform at rest and nothing touching the tool, the
 * mean of `samples` readings is the sensor's bias, subtracted from every
 * later reading until the next tare.
 */
#ifndef SP_FTSENSOR_H
#define SP_FTSENSOR_H

#include "sp/model/kinematics.h"

/** The sensor's mounting. */
typedef struct {
    sp_rot_t axes;   /**< R_m: columns are the sensor's axes in the motion frame, Q30 */
    sp_q24_t pos[3]; /**< the sensor's origin in the motion frame, m, Q24 */
} sp_ft_mount_t;

/** The config's force_sensor section (config/platform_default.json, generated
 *  with sp_platform_default by tools/dev/gen_platform.py): the mounting
 *  (mount_pos, mount_rpy) ... */
extern const sp_ft_mount_t sp_ft_mount_default;
/** ... and force control's wrench source (wrench_source: 0 cylinders, 1 sensor;
 *  SP_WRENCH_* of sp/control/controller.h). */
extern const uint8_t sp_wrench_source_default;

/**
 * The sensor's wrench (sensor axes, moment about its origin: N, N m, Q8) as
 * the wrench on the platform (base frame, moment about o', N, N m, Q8), for a
 * platform at orientation T. Inputs beyond +-2^30 Q8 (4.19 MN, MN m) are held
 * there; a result component beyond int32 saturates. Returns SP_E_ARG (out
 * untouched) on NULL, SP_E_OVERFLOW when something saturated, else SP_OK.
 * Error: within 2 LSB of Q8 plus 1e-8 relative of the exact transform of the
 * fixed-point inputs.
 */
sp_status_t sp_ft_to_base(const sp_ft_mount_t *mount, const sp_rot_t *T, const sp_q8_t reading[6], sp_q8_t out[6]);

/**
 * What sp_ft_to_base derives from the orientation and the mount alone, for a
 * caller that turns many readings at one orientation (the controller redoes
 * it only when the platform turns): S = T^T R_m (base <- sensor axes) and
 * r = T^T pos.
 */
typedef struct {
    int32_t s[3][3]; /**< T^T R_m, Q30 (entries within +-1 for rotations; held within int32) */
    int32_t r[3];    /**< T^T pos, the sensor's origin from o' in base axes, m, Q24 (held within +-128 m) */
} sp_ft_frame_t;

/**
 * The frame of a sensor mounted as `mount` on a platform at orientation T.
 * Entries beyond int32 (not for a rotation and a mount within +-128 m)
 * saturate. Returns SP_E_ARG (fr untouched) on NULL, SP_E_OVERFLOW when
 * something saturated, else SP_OK.
 */
sp_status_t sp_ft_frame(const sp_ft_mount_t *mount, const sp_rot_t *T, sp_ft_frame_t *fr);

/**
 * sp_ft_to_base with the frame prepared by sp_ft_frame: the same result,
 * bit for bit, for any frame whose entries did not saturate: 18 + 6 products
 * of 32 x 32 bits, where sp_ft_to_base also makes the frame (36 more). Inputs beyond +-2^30 Q8 are held there; a
 * result beyond int32 saturates. SP_E_ARG (out untouched) on NULL,
 * SP_E_OVERFLOW when something saturated, else SP_OK.
 */
sp_status_t sp_ft_apply(const sp_ft_frame_t *fr, const sp_q8_t reading[6], sp_q8_t out[6]);

/**
 * sp_ft_apply of the reading less a tare's bias (N, N m, Q8), the
 * difference taken in 64 bits: the same result and status, bit for bit,
 * as sp_ft_apply of sp_ft_tare_step's output (reading - bias saturated to
 * int32, which the input's hold at +-2^30 makes the same), in one pass
 * (what the controller does each tick once the tare is done).
 * SP_E_ARG (out untouched) on NULL, SP_E_OVERFLOW when something
 * saturated, else SP_OK.
 */
sp_status_t sp_ft_apply_tared(const sp_ft_frame_t *fr, const sp_q8_t reading[6], const sp_q8_t bias[6], sp_q8_t out[6]);

/** The tare's state. */
typedef struct {
    int64_t sum[6];  /**< readings summed so far, Q8 */
    uint32_t count;  /**< readings summed */
    uint32_t needed; /**< readings the tare takes (0: no tare running) */
    sp_q8_t bias[6]; /**< the bias in use, sensor axes, Q8 */
    uint8_t tared;   /**< 1 once a tare has completed */
} sp_ft_tare_t;

/** No bias, no tare. No-op on NULL. */
void sp_ft_tare_reset(sp_ft_tare_t *t);

/** Starts a tare of `samples` readings (1..65536); the bias in use stays
 *  until it completes. SP_E_ARG on NULL or a count out of range. */
sp_status_t sp_ft_tare_start(sp_ft_tare_t *t, uint32_t samples);

/**
 * One reading (sensor axes, Q8): adds it to a running tare (the mean, rounded,
 * becomes the bias when the last one arrives) and writes the reading less the
 * bias in use to out (saturating). Returns SP_E_BUSY while a tare is running
 * (out is still written), SP_E_ARG on NULL, SP_E_OVERFLOW if out saturated,
 * else SP_OK.
 */
sp_status_t sp_ft_tare_step(sp_ft_tare_t *t, const sp_q8_t reading[6], sp_q8_t out[6]);

#endif /* SP_FTSENSOR_H */
