/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/motion/stream.h - the stream filter: the reference that follows target poses
 * streamed by the operator (STREAM), and the test that decides whether a
 * streamed target is taken.
 *
 * Per axis the filter is a critically damped second-order follower of the
 * target, a = w^2 (target - x) - 2 w v, with the move limits on velocity and
 * acceleration. Position and velocity integrate in Q48 so that the slow
 * final approach is not lost to rounding; the output is Q24. Pure
 * functions over the state struct, no allocation.
 */
#ifndef SP_STREAM_H
#define SP_STREAM_H

#include "sp/motion/limits.h"
#include "sp/motion/trajectory.h"

/** The filter's constants, derived once from the tick and the bandwidth
 *  (sp_stream_gains). */
typedef struct {
    int32_t dt;       /**< the tick, s, Q24 */
    int32_t w2;       /**< omega^2, 1/s^2, Q24 */
    int32_t two_w;    /**< 2 omega, 1/s, Q24 */
    sp_flags_t flags; /**< SP_FLAG_OVERFLOW when omega^2 or 2 omega saturated: every step reports it */
} sp_stream_gains_t;

/** The filter's state. */
typedef struct {
    int64_t x[6];        /**< position per axis (x, y, z, roll, pitch, yaw), m or rad, Q48 */
    int64_t v[6];        /**< velocity per axis, m/s or rad/s, Q48 */
    int32_t vq[6];       /**< v rounded to Q24 (the last output velocity), m/s or rad/s: the next tick's damping term */
    sp_pose_t target;    /**< the target in force */
    sp_pose_t anchor;    /**< a pose whose leg lengths are known: the last reference that proved a target by
                              sp_limits_reachable_near, or the last streamed target whose IK was computed */
    int32_t anchor_room; /**< min over its legs of the room to the stroke limits (sp_limits_t), m, Q24,
                                saturated to int32 */
    int32_t anchor_box[2]; /**< its least room to the workspace box's faces (sp_limits_t), positions (m) and
                                angles (rad), Q24, saturated to int32; negative when it is outside */
    uint8_t anchor_valid;  /**< 1 once anchor holds a pose */
    uint8_t stopping;      /**< 1 after sp_stream_stop: settling on the home pose */
} sp_stream_t;

/**
 * The gains for a tick of tick_us microseconds (dt = tick_us 2^24 / 10^6,
 * truncated) and a bandwidth omega (rad/s, Q24). dt (from a tick of 128 s
 * on), omega^2 and 2 omega saturate at the Q24 range and set
 * SP_FLAG_OVERFLOW in g->flags, which every sp_stream_step then passes on.
 * SP_E_ARG on NULL, else SP_OK.
 */
sp_status_t sp_stream_gains(sp_stream_gains_t *g, uint32_t tick_us, sp_q24_t omega);

/** Starts the filter at `from` (the controller starts it from READY, at
 *  rest): the state from's pose with zero velocity, the target from's
 *  pose; no anchor, not stopping. */
void sp_stream_start(sp_stream_t *s, const sp_motion_t *from);

/** Sends the filter to `home` for good: the target becomes home, and no
 *  streamed target is taken any more (sp_stream_offer refuses). */
void sp_stream_stop(sp_stream_t *s, const sp_pose_t *home);

/**
 * Offers a streamed target: returns 1 and makes it the target in force when
 * it is reachable, else 0 (the previous target stays); always 0 after
 * sp_stream_stop. Reachable means: the target in force again; else inside
 * the workspace box and either within the bound of
 * sp_limits_reachable_near around the anchor or around the last reference
 * (`ref_pose` with its IK lengths `ref_length`, NULL when they are not
 * known), which then becomes the anchor, or else by the target's own IK
 * (sp_limits_pose_reachable), whose target then becomes the anchor. The
 * anchor keeps its legs' room and its room to the workspace box, so a
 * target near it costs neither a leg loop nor the box test; every bound is
 * sufficient, so the order of the tests does not change the answer.
 */
int sp_stream_offer(sp_stream_t *s, const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *target,
                    const sp_pose_t *ref_pose, const sp_q24_t ref_length[SP_LEGS]);

/**
 * One tick of the filter towards the target: *out (every field) becomes
 * the reference of this tick: pose, velocity, acceleration, Q24. The filter
 * keeps no copy of it (the controller has it written where it is used).
 * Axis a's velocity and acceleration are limited to move->vel_max[a] and
 * move->acc_max[a]. Per axis: err = round(target - x), acc =
 * clamp(round(w^2 err) - round(2 w vq)), v += acc dt (clamped), x +=
 * round(v dt) (Q48; ties up while |v dt| < 2^61, else away from zero),
 * outputs rounded to Q24, ties away from zero. Intermediates saturate and
 * set SP_FLAG_OVERFLOW in *flags (never NULL), as do the gains' flags. In
 * the common case (a tick below 1 s, positions below 64 m, error and
 * velocity below 0.5, limits below 2^30) the same values come from 32-bit
 * steps, none of which can saturate.
 */
void sp_stream_step(sp_stream_t *s, const sp_stream_gains_t *g, const sp_move_limits_t *move, sp_motion_t *out,
                    sp_flags_t *flags);

/** 1 when the filter's output m (sp_stream_step's) is within 1 um (1 urad)
 *  of `pose` and slower than 1 um/s (1 urad/s) on every axis, else 0. */
int sp_stream_settled(const sp_motion_t *m, const sp_pose_t *pose);

#endif /* SP_STREAM_H */
