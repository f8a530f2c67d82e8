/* SPDX-License-Identifier: Apache-2.0 */
#include "sp_abi.h"

#include <stddef.h>

#include "sp/link/can.h"
#include "sp/model/dynamics.h"
#include "sp/model/frames.h"
#include "sp/model/kinematics.h"
#include "sp/motion/limits.h"
#include "sp/model/platform.h"

/* The fields of the row of member m of struct type t (used inside braces). */
#define SP_ABI_ROW(t, m) #t, (uint32_t)sizeof(t), #m, (uint32_t)offsetof(t, m), (uint32_t)sizeof(((t *)0)->m)

static const sp_abi_member_t sp_abi_table[] = {
    {SP_ABI_ROW(sp_pose_t, pos)},
    {SP_ABI_ROW(sp_pose_t, rpy)},

    {SP_ABI_ROW(sp_motion_t, pose)},
    {SP_ABI_ROW(sp_motion_t, vel)},
    {SP_ABI_ROW(sp_motion_t, rpy_rate)},
    {SP_ABI_ROW(sp_motion_t, acc)},
    {SP_ABI_ROW(sp_motion_t, rpy_acc)},

    {SP_ABI_ROW(sp_platform_t, base_joint)},
    {SP_ABI_ROW(sp_platform_t, platform_joint)},
    {SP_ABI_ROW(sp_platform_t, mass)},
    {SP_ABI_ROW(sp_platform_t, inertia)},
    {SP_ABI_ROW(sp_platform_t, gravity)},
    {SP_ABI_ROW(sp_platform_t, home)},
    {SP_ABI_ROW(sp_platform_t, park)},
    {SP_ABI_ROW(sp_platform_t, leg_length_min)},
    {SP_ABI_ROW(sp_platform_t, leg_length_max)},
    {SP_ABI_ROW(sp_platform_t, force_max)},
    {SP_ABI_ROW(sp_platform_t, leg_velocity_max)},
    {SP_ABI_ROW(sp_platform_t, workspace_min)},
    {SP_ABI_ROW(sp_platform_t, workspace_max)},
    {SP_ABI_ROW(sp_platform_t, piston_area)},
    {SP_ABI_ROW(sp_platform_t, annulus_area)},
    {SP_ABI_ROW(sp_platform_t, center_of_mass)},
    {SP_ABI_ROW(sp_platform_t, leg_mass)},
    {SP_ABI_ROW(sp_platform_t, viscous_friction)},
    {SP_ABI_ROW(sp_platform_t, coulomb_friction)},
    {SP_ABI_ROW(sp_platform_t, coulomb_velocity)},
    {SP_ABI_ROW(sp_platform_t, breakaway_friction)},
    {SP_ABI_ROW(sp_platform_t, stribeck_velocity)},
    {SP_ABI_ROW(sp_platform_t, bristle_stiffness)},
    {SP_ABI_ROW(sp_platform_t, bristle_damping)},

    {SP_ABI_ROW(sp_rot_t, t)},

    {SP_ABI_ROW(sp_ik_t, rot)},
    {SP_ABI_ROW(sp_ik_t, sc)},
    {SP_ABI_ROW(sp_ik_t, arm)},
    {SP_ABI_ROW(sp_ik_t, leg)},
    {SP_ABI_ROW(sp_ik_t, length)},
    {SP_ABI_ROW(sp_ik_t, unit)},

    {SP_ABI_ROW(sp_fk_options_t, max_iterations)},
    {SP_ABI_ROW(sp_fk_options_t, tolerance)},
    {SP_ABI_ROW(sp_fk_options_t, max_jump_pos)},
    {SP_ABI_ROW(sp_fk_options_t, max_jump_rot)},

    {SP_ABI_ROW(sp_fk_info_t, iterations)},
    {SP_ABI_ROW(sp_fk_info_t, residual)},

    {SP_ABI_ROW(sp_leg_limits_t, too_short)},
    {SP_ABI_ROW(sp_leg_limits_t, too_long)},
    {SP_ABI_ROW(sp_leg_limits_t, too_fast)},
    {SP_ABI_ROW(sp_leg_limits_t, over_force)},

    {SP_ABI_ROW(sp_frames_t, tool)},
    {SP_ABI_ROW(sp_frames_t, work)},
    {SP_ABI_ROW(sp_frames_t, tool_rot)},
    {SP_ABI_ROW(sp_frames_t, work_rot)},
    {SP_ABI_ROW(sp_frames_t, identity)},
    {SP_ABI_ROW(sp_frames_t, tool_turned)},
    {SP_ABI_ROW(sp_frames_t, work_turned)},
    {SP_ABI_ROW(sp_frames_t, reserved)},

    {SP_ABI_ROW(sp_can_frame_t, id)},
    {SP_ABI_ROW(sp_can_frame_t, bus)},
    {SP_ABI_ROW(sp_can_frame_t, len)},
    {SP_ABI_ROW(sp_can_frame_t, flags)},
    {SP_ABI_ROW(sp_can_frame_t, data)},
};

const sp_abi_member_t *sp_abi_members(uint32_t *count, uint32_t *row_size)
{
    if (count != NULL) {
        *count = (uint32_t)(sizeof(sp_abi_table) / sizeof(sp_abi_table[0]));
    }
    if (row_size != NULL) {
        *row_size = (uint32_t)sizeof(sp_abi_member_t);
    }
    return sp_abi_table;
}
