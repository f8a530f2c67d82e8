/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/motion/stop.h - the controlled stop of a moving reference: ESTOP's
 * stop category 1 (IEC 60204-1), docs/reference/safety.md.
 *
 * From the last reference (pose p0, velocity v0, acceleration a0 on each
 * of the six axes) the stop brings every axis to rest in the same time T,
 * along the path's second-order extension: each axis's velocity is the
 * quintic from (v0, a0, 0) at t = 0 to (0, 0, 0) at t = T,
 *   v(u) = v0 h(u) + a0 T g(u),  u = t / T,
 *   h = 1 - (10u^3 - 15u^4 + 6u^5),  g = u - 6u^3 + 8u^4 - 3u^5,
 * its position the integral (p0 + v0 T / 2 + a0 T^2 / 10 at the end) and
 * its acceleration the derivative: position, velocity and acceleration
 * continuous with the motion it stops, the acceleration smooth at the end
 * (no jerk step to set the oil columns ringing). A straight move (v0 and
 * a0 along the line) stops on its line; a single-axis motion on its axis.
 * T is the shortest whole number of ticks for which, on every axis, the
 * acceleration bound 1.875 |v0| / T + |a0| stays within the deceleration
 * limit (a motion already decelerating at more than 3/4 of it: within
 * |a0| + 1/4 of it) and the jerk bound 5.774 |v0| / T^2 + 3.95 |a0| / T
 * within the jerk limit (linear axes: the linear limits; angles: the
 * angular ones).
 *
 * Fixed point: poses, velocities, accelerations Q24; the time fraction u
 * Q30; every product in int64 and narrowed with saturation. A plan whose
 * coefficients would leave int32 is refused (SP_E_RANGE), so an accepted
 * stop's samples never saturate.
 */
#ifndef SP_STOP_H
#define SP_STOP_H

#include "sp/motion/trajectory.h"

/** The stop's limits: index 0 the linear axes (x, y, z), 1 the angles. */
typedef struct {
    sp_q24_t decel[2]; /**< deceleration, m/s^2 and rad/s^2, Q24, 0.1 .. 50 */
    sp_q24_t jerk[2];  /**< jerk, m/s^3 and rad/s^3, Q24, 1 .. 100 */
} sp_stop_limits_t;

/** The longest stop: 10 s. */
#define SP_STOP_MAX_US UINT32_C(10000000)

/** A planned stop (sp_stop_plan) and its progress. */
typedef struct {
    sp_pose_t from;     /**< p0 */
    sp_pose_t to;       /**< the pose it stops at (the curve at u = 1) */
    int32_t reach_v[6]; /**< v0 T, m or rad, Q24 (index sp_axis_t) */
    int32_t reach_a[6]; /**< a0 T^2, Q24 */
    int32_t v0[6];      /**< v0, Q24 */
    int32_t a0t[6];     /**< a0 T, Q24 */
    int32_t v0_t[6];    /**< v0 / T, Q24 */
    int32_t a0[6];      /**< a0, Q24 */
    uint32_t ticks;     /**< T in ticks (0: the motion was at rest: nothing to stop) */
    uint32_t tick;      /**< ticks sampled so far */
    int64_t step;       /**< 1 / ticks, Q46 (u = tick / ticks within 2^-33 at 10 s) */
} sp_stop_t;

/** SP_OK when every limit lies within its range (sp_stop_limits_t),
 *  SP_E_ARG otherwise or for NULL. */
sp_status_t sp_stop_limits_check(const sp_stop_limits_t *lim);

/**
 * Plans the stop of `from` (the last reference) within `lim` at a tick of
 * tick_us (1 .. 100000 us). SP_E_ARG for NULL, bad limits or tick;
 * SP_E_RANGE when no stop of at most SP_STOP_MAX_US keeps the limits or a
 * coefficient would leave int32 (the stop is then left with ticks 0 at
 * `from`'s pose). A motion at rest (every velocity and acceleration 0)
 * gives ticks 0: sp_stop_step then returns `from`'s pose at rest.
 */
sp_status_t sp_stop_plan(sp_stop_t *s, const sp_motion_t *from, const sp_stop_limits_t *lim, uint32_t tick_us);

/**
 * The sample of the next tick (the first call: one tick after `from`),
 * then advances; *done becomes 1 with the last sample (the end pose at
 * rest, also every call after). SP_E_ARG for NULL (nothing written), else
 * SP_OK: an accepted plan's samples never saturate.
 */
sp_status_t sp_stop_step(sp_stop_t *s, sp_motion_t *out, int *done);

#endif /* SP_STOP_H */
