/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/motion/limits.h - the limits a pose, a reference and a setpoint must keep:
 * the workspace box, the legs' strokes less the controller's margin, the
 * leg rates and the cylinder forces, and a cheap sufficient test that a
 * pose near a checked one is reachable.
 *
 * The values the checks compare against are derived once from the platform
 * and the controller's margin by sp_limits_prepare (sp_ctrl_init calls it)
 * into an sp_limits_t; every check afterwards is a pure function of that
 * struct and its inputs. All lengths m, Q24; angles rad, Q24.
 */
#ifndef SP_LIMITS_H
#define SP_LIMITS_H

#include "sp/model/kinematics.h"

/** Measured lengths may lie this far beyond a stroke end before the
 *  controller calls them out of the stroke (sensor noise, end-stop
 *  cushions): 5 mm, Q24. */
#define SP_LEG_LIMIT_TOLERANCE ((sp_q24_t)83886)

/** The limits, prepared from the platform and the stroke margin. */
typedef struct {
    sp_q24_t ws_lo[6];     /**< workspace box in absolute pose coordinates (x, y, z, roll, pitch, yaw): */
    sp_q24_t ws_hi[6];     /**< home + workspace_min/max, clamped to int32; lo > hi: no pose */
    sp_q24_t length_min;   /**< shortest leg of a reference: the stroke's lower end + margin */
    sp_q24_t length_max;   /**< longest leg of a reference: the stroke's upper end - margin */
    sp_q24_t measured_min; /**< shortest measured leg inside the stroke: lower end - tolerance */
    sp_q24_t measured_max; /**< longest measured leg inside the stroke: upper end + tolerance */
    sp_q24_t rate_max;     /**< largest |leg rate|, m/s, Q24 (the platform's) */
    sp_q8_t force_max;     /**< largest |cylinder force|, N, Q8 (the platform's) */
    uint32_t joint_reach;  /**< max over the platform joints of |a_x| + |a_y| + |a_z|; UINT32_MAX: too
                                  large for sp_limits_reachable_near */
} sp_limits_t;

/**
 * Derives the limits of `platform` with `stroke_margin` (m, Q24, >= 0)
 * kept from both stroke ends. Every bound is computed in int64 and clamped
 * to int32, which is exact for every length, rate and force the core can
 * represent (a clamped bound rejects what the unclamped one rejects). An
 * empty range (the margin wider than half the stroke) rejects every leg.
 * Returns SP_E_ARG on NULL pointers, else SP_OK.
 */
sp_status_t sp_limits_prepare(sp_limits_t *lim, const sp_platform_t *platform, sp_q24_t stroke_margin);

/** 1 if the pose is inside the workspace box (bounds included), else 0.
 *  Inline: every reference and every streamed target is checked. */
static inline int sp_limits_in_workspace(const sp_limits_t *lim, const sp_pose_t *pose)
{
    unsigned a;
    for (a = 0u; a < 3u; ++a) {
        if (pose->pos[a] < lim->ws_lo[a] || pose->pos[a] > lim->ws_hi[a] || pose->rpy[a] < lim->ws_lo[3u + a] ||
            pose->rpy[a] > lim->ws_hi[3u + a]) {
            return 0;
        }
    }
    return 1;
}

/**
 * 1 if every leg length (m, Q24) is inside the stroke less the margin
 * (length_min <= l <= length_max), else 0.
 */
int sp_limits_lengths_ok(const sp_limits_t *lim, const sp_q24_t length[SP_LEGS]);

/**
 * 1 if every leg of the pose's inverse kinematics (lengths only:
 * sp_inverse_kinematics' lengths, bit for bit) is inside the stroke less
 * the margin; 0 otherwise, also when the IK fails. The workspace box is not
 * checked. The leg lengths go to `length` on 1 when it is not NULL.
 */
int sp_limits_legs_reachable(const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *pose,
                             sp_q24_t length[SP_LEGS]);

/** 1 if a pose is reachable: inside the workspace box and
 *  sp_limits_legs_reachable; else 0. `length` as there. */
int sp_limits_pose_reachable(const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *pose,
                             sp_q24_t length[SP_LEGS]);

/**
 * A sufficient test, without an IK, that `pose` is reachable from a base
 * pose whose IK lengths `base_length` are known: 1 when no leg can reach
 * the margin on the way. The caller checks the workspace box. A leg's
 * length changes by at most the distance its platform joint moves,
 * |dp| + |a_i| |dR|, where |dR| <= |droll| + |dpitch| + |dyaw| (R is a
 * product of three elementary rotations, each moving a vector by at most
 * its angle times its length), |dp| <= |dx| + |dy| + |dz| and |a_i| <=
 * joint_reach. The IKs of both poses round each length within 1 LSB (plus
 * 1e-9 of the radius): 5 LSB of margin cover them and the truncated
 * product. Returns 0 when the test is not conclusive (angles more than
 * 128 rad apart, a 256 m platform, or a leg too close to its margin): the
 * caller then computes the IK.
 */
int sp_limits_reachable_near(const sp_limits_t *lim, const sp_pose_t *base, const sp_q24_t base_length[SP_LEGS],
                             const sp_pose_t *pose);

/**
 * sp_limits_pose_reachable's verdict, bit for bit, from a base pose whose
 * IK lengths are known (`base_length`; NULL: none known): the workspace
 * box first, then sp_limits_reachable_near from the base, and the IK only
 * where that test is not conclusive. Near the base (a motion's ends around
 * the reference it starts from) it costs no IK. 1 if reachable, else 0.
 */
int sp_limits_pose_reachable_from(const sp_limits_t *lim, const sp_platform_t *platform, const sp_pose_t *base,
                                  const sp_q24_t base_length[SP_LEGS], const sp_pose_t *pose);

/**
 * 1 if the setpoints of a reference keep every limit: lengths inside the
 * stroke less the margin, |rate| <= rate_max (m/s, Q24) and |force| <=
 * force_max (N, Q8) on every leg; else 0.
 */
int sp_limits_setpoints_ok(const sp_limits_t *lim, const sp_q24_t length[SP_LEGS], const sp_q24_t rate[SP_LEGS],
                           const sp_q8_t force[SP_LEGS]);

/** 1 if a measured length (m, Q24) is outside the stroke by more than
 *  SP_LEG_LIMIT_TOLERANCE, else 0. */
static inline int sp_limits_measured_out(const sp_limits_t *lim, sp_q24_t length)
{
    return length < lim->measured_min || length > lim->measured_max;
}

/** Bits of a leg limit report: leg i sets bit i. */
typedef struct {
    uint32_t too_short;  /**< length < leg_length_min */
    uint32_t too_long;   /**< length > leg_length_max */
    uint32_t too_fast;   /**< |rate| > leg_velocity_max (only when rates given) */
    uint32_t over_force; /**< |force| > force_max (only when forces given) */
} sp_leg_limits_t;

/**
 * Checks leg lengths (m, Q24) and, when not NULL, leg rates (m/s, Q24) and
 * cylinder forces (N, Q8) against the platform's own limits (no margin),
 * with a report of which leg broke which limit. Returns SP_OK when all are
 * inside, SP_E_RANGE otherwise, SP_E_ARG on NULL platform, length or
 * report.
 */
sp_status_t sp_check_legs(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_q24_t rate[SP_LEGS],
                          const sp_q8_t force[SP_LEGS], sp_leg_limits_t *report);

#endif /* SP_LIMITS_H */
