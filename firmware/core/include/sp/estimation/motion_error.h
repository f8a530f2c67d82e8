/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/estimation/motion_error.h - the acceleration of the tracking error and the
 * wrench it takes, for the external wrench estimate (sp/estimation/wrench.h).
 *
 * The wrench estimate compares the measured cylinder forces with the
 * inverse dynamics of the reference motion. When the platform's true
 * motion differs from the reference (a load step, friction at reversals),
 * the inertial forces differ too, and the estimate carries that
 * difference as a false external wrench. To first order the missing part
 * is the rigid body's mass matrix times the acceleration difference,
 *   dW = M6(x) (a_actual - a_ref),
 * which is to be added to W_raw = J^T (F_model - F) before the wrench
 * filter: J^T F_model is the platform's rigid-body wrench for the
 * reference, J^T F_rigid(actual) = J^T F_model + dW, and
 * W_ext = J^T F_rigid(actual) - J^T F (the unit test
 * test_motion_error_wrench_vs_dynamics proves the sign and the frames
 * against sp_inverse_dynamics).
 *
 * Two pure parts (the controller's wrench job wires them in: sp/control/controller.h):
 *
 * 1. sp_motion_error_step: the raw acceleration da of the tracking error
 *    e = estimate - reference (six axes: x, y, z in m, roll, pitch, yaw in
 *    rad, angles wrapped to [-pi, pi)): the double difference
 *    e[n] - 2 e[n-1] + e[n-2] divided by dt^2, centred on n-1 (one tick of
 *    delay). It is not filtered here: its wrench dW joins J^T (F_model - F)
 *    before the wrench filter (sp/estimation/wrench.h), so that both pass one filter.
 *    Noise: white noise of standard deviation s on every sample of e gives
 *    da a standard deviation of sqrt(6) s / dt^2 before the filter (1 um
 *    quantisation, s = 0.29 um: 0.71 m/s^2 at 1 kHz); the wrench filter's
 *    three sections bring it down (sp/estimation/wrench.h gives the figure).
 *
 * 2. sp_motion_error_wrench: dW = M6 da of the rigid platform (mass,
 *    inertia about o' and centre of mass of sp_platform_t), base frame,
 *    moment about o'. The legs' masses are left out: on the default
 *    platform (legs ~ 8 % of the moving mass) dW then misses 5.9 % (RMS)
 *    of the inverse dynamics' difference for a translational da and
 *    5.6 % for a rotational one (test_motion_error_wrench_vs_dynamics;
 *    docs/explanation/model.md, "The motion-error correction").
 *    sp_motion_error_body folds the legs' inertia at the home pose into
 *    the rigid body's parameters once (the controller does it at init),
 *    and sp_motion_error_wrench_body_sc computes dW with them at the cost
 *    of the rigid body's: the miss falls to the legs' anisotropy and
 *    their change with the pose (measured in the test above).
 */
#ifndef SP_MOTION_ERROR_H
#define SP_MOTION_ERROR_H

#include "sp/model/kinematics.h"

/** The history of the tracking error, for its double difference. */
typedef struct {
    sp_q24_t e1[6]; /**< e of the previous tick: m (x, y, z), rad (rpy), Q24 */
    sp_q24_t e2[6]; /**< e two ticks back, Q24 */
    int32_t k;      /**< 1 / dt^2, s^-2 (integer, rounded: 10^6 at 1 kHz) */
    int32_t lim;    /**< the largest |d| whose d k is within the held range: (2^30 - 1) / k */
    uint8_t count;  /**< errors held in e1, e2: 0, 1 or 2 */
    uint8_t small;  /**< bit 0: e1, bit 1: e2 within |e| < 2^29 on every axis (their double
                         difference with a small e is then an int32: 32-bit arithmetic) */
} sp_motion_error_t;

/**
 * Sets the tick (us, 100..1,000,000) and resets the history
 * (sp_motion_error_reset). 1/dt^2 is kept as the integer
 * round(10^12 / tick_us^2): exact for 1 ms (10^6) and every tick that
 * divides 10^6 us into a power-of-two-and-five count (0.1, 0.125, 0.2,
 * 0.25, 0.5, 2, 4, 5, 8, 10 ms), else within 0.5 / k relative; with it
 * lim = (2^30 - 1) / k, below which a double difference's product stays
 * in 32 bits (sp_motion_error_step).
 * SP_E_ARG (nothing changed) on NULL or a tick out of range.
 */
sp_status_t sp_motion_error_init(sp_motion_error_t *me, uint32_t tick_us);

/** Forgets the history; keeps the tick. No-op on NULL. */
void sp_motion_error_reset(sp_motion_error_t *me);

/**
 * One tick: e = est - ref (positions m, angles rad, Q24; the angle
 * differences wrapped into [-pi, pi) so that a yaw crossing +-pi in both
 * poses is no step), and, with the errors of the two previous ticks,
 * the raw acceleration da = (e - 2 e1 + e2) / dt^2 (exact integer
 * arithmetic; m/s^2 for x, y, z; rad/s^2 of the roll, pitch, yaw angles,
 * not body rates; Q24), held within [-64, 64).
 * Returns
 *   SP_OK          da is this tick's acceleration;
 *   SP_E_BUSY      fewer than three consecutive poses since the reset (or
 *                  est or ref NULL: a tick without a pose, which resets
 *                  the history): da is zeroed;
 *   SP_E_OVERFLOW  a value saturated this tick (a position difference
 *                  beyond +-128 m, an acceleration beyond [-64, 64) m/s^2
 *                  or rad/s^2, where it is held): da holds the held values;
 *   SP_E_ARG       me or da NULL: nothing changed.
 * Nothing wraps.
 */
sp_status_t sp_motion_error_step(sp_motion_error_t *me, const sp_pose_t *est, const sp_pose_t *ref, sp_q24_t da[6]);

/**
 * The rigid platform's wrench of an acceleration difference da
 * (m/s^2 of o' in the base frame, and rad/s^2 of the roll, pitch, yaw
 * angles; Q24), at the pose whose inverse kinematics is *ik (its T and its
 * sines and cosines sc are used): with the angle accelerations turned into
 * the body angular acceleration dw' = E(angles) d(rpy)'' by
 * the rows of sp_body_rates_sc for zero rates (the first-order part in
 * da; written out here, bit-identical), R = T^T and
 * r_c = R c (c = platform->center_of_mass),
 *   force  = m da_lin + (R dw') x (m r_c)             (N, base frame, Q8)
 *   moment = R (I dw') + (m r_c) x da_lin             (N m, about o', base frame, Q8)
 * I = platform->inertia (about o', motion frame), m = platform->mass. This
 * is J^T dF for dF the difference of the inverse dynamics (massless legs)
 * of the motion with acceleration a + da and with a. Leg masses are not
 * included here (see the file comment and sp_motion_error_body).
 * Error: within 0.01 N, N m plus 1e-7 relative of the exact value of
 * the Q24 / Q30 inputs (the default platform with its centre of mass
 * moved off o', |da| < 64, 20,000 random cases against a double
 * reference: worst 0.85 of that bound).
 * Returns SP_E_ARG (dw zeroed) on NULL; SP_E_OVERFLOW when a value
 * saturated (m r_c beyond 32768 kg m in Q16, a component of dw beyond
 * +-8.4 MN or MN m, held at the Q8 extremes; dw' saturating beyond
 * 128 rad/s^2); else SP_OK.
 */
sp_status_t sp_motion_error_wrench(const sp_platform_t *platform, const sp_ik_t *ik, const sp_q24_t da[6],
                                   sp_q8_t dw[6]);

/**
 * sp_motion_error_wrench at the pose whose roll, pitch, yaw have the sines
 * and cosines sc = {sin, cos} x (roll, pitch, yaw) (Q30, as in sp_ik_t.sc
 * and sp_fk_cache_t.sc; the controller keeps the reference's in
 * sp_model_t.ref.sc): T is rebuilt from sc exactly as the IK builds it, so
 * for the sines of an IK the result is bit-identical to
 * sp_motion_error_wrench with that IK. Same units, errors and returns.
 */
sp_status_t sp_motion_error_wrench_sc(const sp_platform_t *platform, const sp_q30_t sc[6], const sp_q24_t da[6],
                                      sp_q8_t dw[6]);

/** The rigid-body parameters dW is computed with. */
typedef struct {
    sp_q16_t mass;              /**< kg, Q16 */
    sp_q16_t inertia[3][3];     /**< about o', motion frame, kg m^2, Q16 */
    sp_q24_t center_of_mass[3]; /**< motion frame, m, Q24 */
} sp_me_body_t;

/**
 * The platform's rigid body with its legs' inertia at the home pose folded
 * in, for sp_motion_error_wrench_body_sc. Each leg (barrel m_c with its
 * centre d_c from the base joint, rod m_r with its centre d_r from the
 * platform joint, length L, unit u, arm r from o' at home) answers an
 * acceleration a_A of its platform joint with the force K a_A,
 * K = mu 1 + (m_r - mu) u u^T, mu = (m_c d_c^2 + m_r (L - d_r)^2) / L^2
 * (the rod follows the joint along the leg; across it both parts pivot
 * about the base joint): the wrench [K; [r]x K] (da + dw' x r). Summed
 * over the legs, its blocks join the rigid body's: the mean of the
 * translational block's diagonal to the mass, the skew part of the
 * coupling sum K [r]x to the first moment m c, and sum [r]x K [r]x^T to
 * the inertia (both turned into the motion frame with the home's T).
 * The default platform: +157 kg (the block's diagonal is 137, 137,
 * 196 kg), first moment (0, 0, -33) kg m, inertia +126, +126, +174 kg m^2.
 * Massless legs: the rigid body unchanged. Computed in int64 with one
 * rounding per product; the envelope (leg masses below 512 kg, centres
 * below 8 m and shorter than every leg at home, arms below 4 m) bounds
 * every product.
 * Returns SP_E_ARG on NULL (body unchanged); SP_E_RANGE outside the
 * envelope, when the home's IK fails or the inertia added exceeds
 * 32768 kg m^2 (body then holds the rigid body); SP_E_OVERFLOW when a
 * result saturated to int32; else SP_OK.
 */
sp_status_t sp_motion_error_body(const sp_platform_t *platform, sp_me_body_t *body);

/**
 * sp_motion_error_wrench_sc with the body's mass, inertia and centre of
 * mass in place of the platform's: the same arithmetic, units, errors and
 * returns (bit-identical when body holds the platform's values).
 */
sp_status_t sp_motion_error_wrench_body_sc(const sp_me_body_t *body, const sp_q30_t sc[6], const sp_q24_t da[6],
                                           sp_q8_t dw[6]);

/**
 * sp_motion_error_wrench_body_sc with T given: `rot` must be the T of the
 * sines `sc` (an IK's sp_ik_t.rot and .sc, or sp_model_t.rot and .ref.sc),
 * which saves rebuilding it (nine products). Bit-identical to
 * sp_motion_error_wrench_body_sc(body, sc, da, dw) then; same units,
 * errors and returns (SP_E_ARG on NULL).
 */
sp_status_t sp_motion_error_wrench_body_t(const sp_me_body_t *body, const sp_rot_t *rot, const sp_q30_t sc[6],
                                          const sp_q24_t da[6], sp_q8_t dw[6]);

/** The body for sp_motion_error_wrench_m6: its parts that do not change
 *  with the pose, prepared once (sp_motion_error_m6). */
typedef struct {
    sp_me_body_t body; /**< mass, inertia and centre of mass */
    sp_q16_t first[3]; /**< m c, motion frame, kg m, Q16 (0 when frame is 0) */
    uint8_t frame;     /**< 1: mass, m c and inertia below 2^29 in Q16 (8192 kg, kg m, kg m^2):
                             the motion-frame form; 0: the plain computation */
} sp_me_m6_t;

/**
 * Prepares *m6 from *body (sp_motion_error_body's, or any): keeps the body
 * and its first moment m c (Q16, rounded once). SP_E_ARG on NULL (m6
 * unchanged), else SP_OK.
 */
sp_status_t sp_motion_error_m6(const sp_me_body_t *body, sp_me_m6_t *m6);

/**
 * sp_motion_error_wrench_body_t's dW computed in the motion frame, where
 * the body's mass, first moment and inertia are constants: the linear
 * acceleration turned in (T da), the body-frame wrench
 *   f_b = m T da + dw' x (m c),   m_b = I dw' + (m c) x (T da)
 * (N, N m, Q8, each sum of Q16 x Q24 products rounded once) and both
 * turned out by R = T^T: the same law (R f_b = m da + (R dw') x (m R c),
 * R m_b = R I dw' + (m R c) x da) in 51 products with 18 roundings, where
 * the base-frame form takes 54 with 48 (m R c formed each tick). Not bit
 * for bit the same: within 0.01 N, N m plus 1e-7 relative of the exact
 * value of its inputs, as sp_motion_error_wrench (the test measures both
 * against a double reference and against each other). A body outside
 * the envelope (m6->frame 0) takes the plain computation,
 * sp_motion_error_wrench_body_t's. `rot` must be the T of the sines `sc`.
 * Same units and returns: SP_E_ARG (dw zeroed) on NULL; SP_E_OVERFLOW when
 * a value saturated (T da beyond +-128 m/s^2, dw' beyond 128 rad/s^2, a
 * component of dw beyond +-8.4 MN or MN m, held at the Q8 extremes); else
 * SP_OK.
 */
sp_status_t sp_motion_error_wrench_m6(const sp_me_m6_t *m6, const sp_rot_t *rot, const sp_q30_t sc[6],
                                      const sp_q24_t da[6], sp_q8_t dw[6]);

#endif /* SP_MOTION_ERROR_H */
