/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/model/frames.h - the tool frame T and the work frame W (docs/reference/frames.md).
 *
 * The tool frame T is fixed to the platform: its origin (the tool point,
 * the pivot) at `tool.pos` in the motion frame o' (motion-frame
 * coordinates), its axes turned from the motion frame's by `tool.rpy`.
 * The work frame W is fixed to the ground: its origin at `work.pos` in the
 * base frame, its axes turned from the base frame's by `work.rpy`. Angles
 * follow the paper's convention (sp/model/kinematics.h): roll, pitch, yaw
 * give the column-vector rotation R = Rz(yaw) Ry(pitch) Rx(roll), whose
 * transpose is the paper's T (sp_rot_t, rows = the turned frame's axes in
 * the outer frame's coordinates).
 *
 * A "tool pose" is the pose of T in W: the tool point's position in W's
 * coordinates (m) and T's orientation relative to W (roll, pitch, yaw).
 * With R_P, p the platform's pose (o' in the base frame) and R_T, t, R_W,
 * w the frames:
 *     R_X = R_W^T R_P R_T              x = R_W^T (p + R_P t - w)
 *     R_P = R_W R_X R_T^T              p = w + R_W x - R_P t
 * The pivot is T's origin: a tool pose that only turns keeps the tool point
 * where it is. With both frames identity every transform is the identity,
 * and sp_frames_t.identity lets a caller skip them.
 *
 * Q formats: positions and angles Q24 (m, rad), rotations Q30, wrenches Q8
 * (N, N m). Nothing wraps: a value that does not fit saturates and the
 * function returns SP_E_OVERFLOW. All functions are pure.
 *
 * Accuracy (tests/python/test_frames.py against tools/stewart/frames.py,
 * the float64 reference): positions within 4 LSB of Q24 (0.25 um) plus
 * 3e-9 of the lever |t|, angles within 8 LSB of Q24 (0.5 urad) for
 * |pitch| <= 1.4 rad, velocities and accelerations within 1e-7 of their
 * magnitude plus 8 LSB; wrenches within 2 LSB of Q8 plus 3e-9 of the
 * moment arm's contribution.
 */
#ifndef SP_FRAMES_H
#define SP_FRAMES_H

#include "sp/math/fixed.h"
#include "sp/model/kinematics.h"
#include "sp/model/platform.h"

/** Largest distance of the tool point from o', m, Q24 (5 m). */
#define SP_FRAME_TOOL_REACH_MAX (5 * SP_Q24_ONE)

/** Largest |component| of the work frame's origin, m, Q24 (16 m). */
#define SP_FRAME_WORK_REACH_MAX (16 * SP_Q24_ONE)

/** Largest |angle| of a frame's rotation, rad, Q24 (pi, rounded down). */
#define SP_FRAME_ANGLE_MAX ((sp_q24_t)52707178)

/** The two frames, prepared (sp_frames_prepare). */
typedef struct {
    sp_pose_t tool;      /**< T in o': tool point (motion-frame coordinates, m) and rotation (rad), Q24 */
    sp_pose_t work;      /**< W in the base frame: origin (base coordinates, m) and rotation (rad), Q24 */
    sp_rot_t tool_rot;   /**< the paper's T of tool.rpy (rows: T's axes in motion-frame coordinates), Q30 */
    sp_rot_t work_rot;   /**< the paper's T of work.rpy (rows: W's axes in base coordinates), Q30 */
    uint8_t identity;    /**< 1: both frames identity (every value 0): every transform is a copy */
    uint8_t tool_turned; /**< 1: tool.rpy is not all 0 */
    uint8_t work_turned; /**< 1: work.rpy is not all 0 */
    uint8_t reserved;    /**< 0 */
} sp_frames_t;

/**
 * Prepares *f from the tool frame (T in o') and the work frame (W in the
 * base frame). Either pointer NULL: that frame is identity.
 * Errors (f set to both identity): SP_E_ARG (f NULL); SP_E_RANGE for a
 * tool point farther than SP_FRAME_TOOL_REACH_MAX from o', a work origin
 * component beyond SP_FRAME_WORK_REACH_MAX, or an angle beyond
 * SP_FRAME_ANGLE_MAX.
 */
sp_status_t sp_frames_prepare(const sp_pose_t *tool, const sp_pose_t *work, sp_frames_t *f);

/**
 * The platform's pose (o' in the base frame) that puts the tool frame at
 * `tool_pose` (T in W). Angles: R_P = R_W R_X R_T^T, taken back to roll,
 * pitch, yaw with |roll|, |yaw| <= pi and |pitch| <= pi/2 (no turn:
 * R_X's own angles are copied, bit for bit). *rot (may be NULL) gets the
 * paper's T of the platform's orientation. identity: a copy.
 * Errors: SP_E_ARG (NULL), SP_E_OVERFLOW (a position saturated).
 */
sp_status_t sp_frames_to_platform(const sp_frames_t *f, const sp_pose_t *tool_pose, sp_pose_t *platform, sp_rot_t *rot);

/**
 * The tool pose (T in W) of a platform pose: the inverse of
 * sp_frames_to_platform. identity: a copy. Errors as sp_frames_to_platform.
 */
sp_status_t sp_frames_from_platform(const sp_frames_t *f, const sp_pose_t *platform, sp_pose_t *tool_pose);

/**
 * sp_frames_to_platform of a motion: the pose as there, the platform's
 * velocity and acceleration (of o', base frame: v_P = R_W v_X - w x r,
 * a_P = R_W a_X - dw x r - w x (w x r), r = R_P t, w the angular velocity)
 * and its Euler rates and accelerations (the same body rates: w_P,body =
 * R_T w_X,body). No frame turned: the angles and their rates are copied.
 * identity: a copy. The two motions must be distinct. A motion that does
 * not turn (Euler rates and accelerations 0) skips the body rates.
 * Errors: SP_E_ARG (NULL, or the same motion twice), SP_E_SINGULAR (the
 * platform's |cos pitch| below 0.01: its Euler rates are undefined;
 * *platform then partly written), SP_E_OVERFLOW (a value saturated).
 */
sp_status_t sp_frames_motion_to_platform(const sp_frames_t *f, const sp_motion_t *tool_motion, sp_motion_t *platform);

/**
 * What a tool motion's transform keeps between calls (set valid to 0
 * before the first call and whenever the frames change): the tool angles
 * of the last call, their sines, the platform's T (T_P = T_T^T T_X T_W),
 * its angles and (turned frames) their sines. A call whose tool angles
 * are those of the last one takes them as they are: no sine, no product
 * of rotations, no arc tangent; a call with other angles makes the sines
 * of the angles that changed only. Every kept value is a pure function of
 * the tool angles and the frames, so a kept call's result is the plain
 * call's bit for bit (tests/unit/test_frames.c).
 */
typedef struct {
    sp_q24_t tool_rpy[3]; /**< the tool angles the rest belongs to, rad, Q24 */
    sp_q30_t sc[6];       /**< sin, cos of tool_rpy, Q30 */
    sp_rot_t tp;          /**< the paper's T of the platform's orientation, Q30 */
    sp_q24_t rpy[3];      /**< the platform's angles, rad, Q24 */
    sp_q24_t prpy_of[3];  /**< the platform angles scp belongs to (turned frames), rad, Q24 */
    sp_q30_t scp[6];      /**< sin, cos of the platform's angles (turned frames only), Q30 */
    uint8_t valid;        /**< 1 when the values above belong together and to the frames */
    uint8_t reserved[3];  /**< 0 */
} sp_frames_keep_t;

/**
 * sp_frames_motion_to_platform with its orientation kept in *keep
 * (sp_frames_keep_t): the same result and errors, bit for bit, and work
 * only for the angles that changed since the last call. keep NULL: the
 * plain call. A platform pose's T is keep->tp after the call (f not
 * identity).
 */
sp_status_t sp_frames_motion_to_platform_kept(const sp_frames_t *f, sp_frames_keep_t *keep,
                                              const sp_motion_t *tool_motion, sp_motion_t *platform);

/**
 * sp_frames_motion_to_platform_kept whose orientation, when no frame is
 * turned (the platform's angles are the tool's), is kept in the IK's
 * *orient instead (sp_inverse_kinematics_kept's keep): one sine and one T
 * a tick for the frames and the IK of the platform motion that follows,
 * where each would make its own. The same result and errors, bit for bit;
 * *orient is left as sp_inverse_kinematics_kept would leave it for these
 * angles, with fresh set when they changed. orient NULL, or a frame
 * turned: sp_frames_motion_to_platform_kept. *keep is not used when
 * *orient is.
 */
sp_status_t sp_frames_motion_to_platform_shared(const sp_frames_t *f, sp_frames_keep_t *keep, sp_orient_keep_t *orient,
                                                const sp_motion_t *tool_motion, sp_motion_t *platform);

/**
 * sp_frames_to_platform (rot NULL) with its orientation kept in *keep:
 * the same pose and errors, bit for bit. keep NULL: the plain call.
 */
sp_status_t sp_frames_to_platform_kept(const sp_frames_t *f, sp_frames_keep_t *keep, const sp_pose_t *tool_pose,
                                       sp_pose_t *platform);

/**
 * The lever r = R_P t of the tool point at the platform orientation rot
 * (the paper's T), base coordinates, m, Q24 (|r| <= |t| (1 + 2^-27):
 * cannot overflow). Errors: SP_E_ARG (NULL).
 */
sp_status_t sp_frames_lever(const sp_frames_t *f, const sp_rot_t *rot, sp_q24_t r[3]);

/**
 * sp_frames_wrench_to_tool with its lever r given (sp_frames_lever of the
 * same orientation): the same result bit for bit; one lever serves every
 * wrench of a tick. Errors as sp_frames_wrench_to_tool.
 */
sp_status_t sp_frames_wrench_to_tool_at(const sp_frames_t *f, const sp_q24_t r[3], const int32_t wrench[6],
                                        int32_t tool_wrench[6]);

/**
 * A wrench about o' in base axes (the controller's convention: force N,
 * moment N m, Q8) at the platform's orientation `rot` (the paper's T of
 * the platform's pose) taken to the tool point, in W's axes:
 * F_W = R_W^T F, M_W = R_W^T (M - r x F), r = R_P t. identity: a copy.
 * Errors: SP_E_ARG (NULL), SP_E_OVERFLOW (saturated).
 */
sp_status_t sp_frames_wrench_to_tool(const sp_frames_t *f, const sp_rot_t *rot, const int32_t wrench[6],
                                     int32_t tool_wrench[6]);

/**
 * The inverse of sp_frames_wrench_to_tool: a wrench at the tool point in
 * W's axes to one about o' in base axes. identity: a copy. Errors as
 * sp_frames_wrench_to_tool.
 */
sp_status_t sp_frames_wrench_from_tool(const sp_frames_t *f, const sp_rot_t *rot, const int32_t tool_wrench[6],
                                       int32_t wrench[6]);

/**
 * Checksum of the two frames' twelve Q24 values (tool pos, tool rpy, work
 * pos, work rpy, each int32 little-endian): CRC-32 (IEEE 802.3, reflected,
 * initial and final XOR 0xFFFFFFFF), the value CTRL_FRAMES reports.
 * f NULL: 0.
 */
uint32_t sp_frames_checksum(const sp_frames_t *f);

/**
 * atan2(y, x) in rad, Q24, within [-pi, pi]: y and x any common scale
 * (e.g. Q30 entries of a rotation). (0, 0) gives 0. Error: at most 2 LSB
 * of Q24 for |(x, y)| >= 2^20. Cannot fail.
 */
sp_q24_t sp_frames_atan2(int32_t y, int32_t x);

#endif /* SP_FRAMES_H */
