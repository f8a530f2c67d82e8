/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/motion/trajectory.h - reference motions, evaluated once per control tick.
 *
 * Every generator is a plain struct (its state) plus pure functions; time is
 * an integer tick count, never a clock. Outputs are complete motion samples
 * (pose, velocity, acceleration) so that the inverse dynamics can compute
 * the force feed-forward, and every output is continuous in position,
 * velocity and acceleration: nothing jumps.
 */
#ifndef SP_TRAJECTORY_H
#define SP_TRAJECTORY_H

#include "sp/model/platform.h"

/** Index of a pose axis: x, y, z (m) then roll, pitch, yaw (rad). */
typedef enum {
    SP_AXIS_X = 0,
    SP_AXIS_Y = 1,
    SP_AXIS_Z = 2,
    SP_AXIS_ROLL = 3,
    SP_AXIS_PITCH = 4,
    SP_AXIS_YAW = 5,
    SP_AXIS_COUNT = 6
} sp_axis_t;

/** One pose axis of a sp_pose_t: pos[0..2] then rpy[0..2]. */
sp_q24_t sp_pose_axis(const sp_pose_t *pose, sp_axis_t axis);

/** *m becomes the motion at rest at `pose` (zero velocities and
 *  accelerations). `pose` may be &m->pose. Cannot fail. */
void sp_motion_at_rest(sp_motion_t *m, const sp_pose_t *pose);

/* ---- the paper's trigonometric motion ---------------------------------- */

/**
 * A sinusoid on one axis about a centre pose, with smooth fade-in and
 * fade-out: offset(t) = A sin(2 pi f t) e(t), where the envelope e rises from
 * 0 to 1 (and later falls back) along the quintic smoothstep
 * 10u^3 - 15u^4 + 6u^5 over `fade_ticks`, so position, velocity and
 * acceleration all start and end at zero.
 * The phase is a 32-bit turn counter (2^32 = one cycle) advanced by a fixed
 * increment per tick: it wraps modulo one cycle by design, without drift.
 */
typedef struct {
    sp_pose_t centre;      /**< pose the motion is about */
    sp_axis_t axis;        /**< which axis moves */
    sp_q24_t amplitude;    /**< m or rad, Q24 */
    sp_q24_t omega;        /**< 2 pi f, rad/s, Q24 */
    int64_t omega2;        /**< omega^2 rounded to Q24, rad^2/s^2 (below 2^37: beyond int32 above 1.8 Hz) */
    uint8_t wide;          /**< 1: the acceleration's terms may leave int32 (above 1.8 Hz, or a fade below
                                0.22 s): summed in 64 bits */
    uint32_t phase_step;   /**< f * tick * 2^32 (turns per tick, 2^-32 units) */
    uint32_t phase;        /**< current phase, 2^-32 turn */
    uint32_t fade_ticks;   /**< fade-in and fade-out length, ticks */
    uint32_t tick;         /**< ticks since start while they matter: it stops at fade_ticks once the
                              fade-in is done and counts again from the stop, so a motion that runs
                              for any time (2^32 ticks are 49.7 days) can still be stopped; it never
                              reaches the stop_tick sentinel (at most 2 fade_ticks) */
    uint32_t stop_tick;    /**< tick at which the fade-out began (UINT32_MAX: none yet) */
    int finished;          /**< 1 once the fade-out has ended: output is the centre, at rest */
    uint32_t fade_tick_us; /**< the tick length fade_rate was computed for (0: none) */
    sp_q24_t fade_rate;    /**< the envelope's rate in a fade, 1 / (fade_ticks tick), 1/s, Q24 (kept by
                                 sp_trig_step: a division once per motion, not per fade tick) */
    sp_flags_t fade_flags; /**< its flags (SP_FLAG_OVERFLOW when it saturated), passed on each fade tick */
} sp_trig_t;

/** The highest peak acceleration a trigonometric motion may reach, m/s^2
 *  or rad/s^2, Q24 (64: beyond any hexapod; every sample then fits Q24). */
#define SP_TRIG_ACC_MAX (INT64_C(1) << 30)

/**
 * Starts a trigonometric motion. frequency in Hz (Q24, 0 < f <= 10, below
 * half the tick rate), tick length in us (1..100000), fade in ticks (0.1 s
 * to 60 s long). amplitude in m or rad (Q24,
 * |A| <= 1 m or 1 rad; sign allowed). Returns SP_E_ARG for NULL or values
 * outside these ranges, SP_E_RANGE for a motion whose acceleration bound
 * |A| (w^2 + 4 w r + 6 r^2) (w = 2 pi f, r = 1 / fade time) reaches
 * SP_TRIG_ACC_MAX (the generator is then left finished, at the centre).
 * An accepted motion's samples never saturate.
 */
sp_status_t sp_trig_start(sp_trig_t *g, const sp_pose_t *centre, sp_axis_t axis, sp_q24_t amplitude,
                          sp_q24_t frequency_hz, uint32_t tick_us, uint32_t fade_ticks);

/** Begins the fade-out (idempotent). The motion ends fade_ticks later. */
void sp_trig_stop(sp_trig_t *g);

/**
 * Motion sample for the current tick, then advances one tick. Position,
 * velocity and acceleration of the moving axis; the other axes stay at the
 * centre at rest. Saturates (SP_E_OVERFLOW) only for unreachable values.
 */
sp_status_t sp_trig_step(sp_trig_t *g, uint32_t tick_us, sp_motion_t *out);

/* ---- point-to-point moves -------------------------------------------- */

/** Per-axis limits of a point-to-point move (index sp_axis_t). */
typedef struct {
    sp_q24_t vel_max[SP_AXIS_COUNT];  /**< m/s or rad/s, > 0 */
    sp_q24_t acc_max[SP_AXIS_COUNT];  /**< m/s^2 or rad/s^2, > 0 */
    sp_q24_t jerk_max[SP_AXIS_COUNT]; /**< m/s^3 or rad/s^3, > 0 */
} sp_move_limits_t;

/**
 * A straight move in pose space from `from` to `to` along the minimum-jerk
 * (quintic) profile s(u) = 10u^3 - 15u^4 + 6u^5, lasting the shortest whole
 * number of ticks for which every axis stays within its velocity
 * (1.875 D/T), acceleration (5.774 D/T^2) and jerk (60 D/T^3) limits.
 */
typedef struct {
    sp_pose_t from;
    sp_pose_t to;
    uint32_t duration_ticks; /**< 0 for a null move */
    uint32_t tick;
    uint32_t rate_tick_us; /**< the tick length rate was computed for (0: none) */
    sp_q24_t rate;         /**< du/dt = 1 / duration, 1/s, Q24 (kept by sp_move_step) */
} sp_move_t;

/**
 * Plans a move. tick_us is the tick length (1..100000 us). Returns SP_E_ARG
 * for NULL or non-positive limits, SP_E_RANGE if the move would take longer
 * than 10 minutes.
 */
sp_status_t sp_move_plan(sp_move_t *mv, const sp_pose_t *from, const sp_pose_t *to, const sp_move_limits_t *lim,
                         uint32_t tick_us);

/** Motion sample of the current tick, then advances; *done = 1 once the
 *  target is reached (the sample is then the target at rest). */
sp_status_t sp_move_step(sp_move_t *mv, uint32_t tick_us, sp_motion_t *out, int *done);

#endif /* SP_TRAJECTORY_H */
