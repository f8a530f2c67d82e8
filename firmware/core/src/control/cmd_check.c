/* SPDX-License-Identifier: Apache-2.0 */
/*
 * cmd_check.c - an operator command's parameters checked before it is
 * taken (docs/reference/commands.md): against what the tick can compute
 * without saturating and what the limits allow. Runs on a command's tick
 * only; the prepared capacities are made once by sp_ctrl_init.
 */
#include "control/control_internal.h"

#include "math/fixed_inline.h"

#define TWO_PI_Q28 INT32_C(1686629713) /* 2 pi in Q28 */
#define US_PER_S INT64_C(1000000)

/* Cylinder forces a command's accelerations may use: half of force_max,
 * the other half left to gravity, the poses away from home and the
 * feed-forward's other terms. */
#define FORCE_SHARE_SHIFT 1u

/* A command's pose (the tool frame in the work frame) as the platform's
 * pose; 0 when the transform fails. The poses one check transforms share
 * their orientation in *keep (valid 0 at first): a trig's two ends on a
 * translation axis, a straight move that does not turn, cost one
 * orientation. */
static int to_platform(const sp_ctrl_t *ctrl, sp_frames_keep_t *keep, const sp_pose_t *pose, sp_pose_t *platform)
{
    if (ctrl->frames.identity) {
        *platform = *pose;
        return 1;
    }
    return sp_frames_to_platform_kept(&ctrl->frames, keep, pose, platform) == SP_OK;
}

void spi_cmd_prepare(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg)
{
    const sp_platform_t *p = cfg->platform;
    sp_ik_t ik;
    sp_motion_t m;
    sp_q8_t f0[SP_LEGS];
    sp_q8_t f1[SP_LEGS];
    unsigned k;
    unsigned i;
    int64_t budget = (int64_t)p->force_max >> FORCE_SHARE_SHIFT;
    sp_motion_at_rest(&m, &p->home);
    ctrl->prep.arm_max = 0;
    for (i = 0u; i < SP_LEGS; ++i) { /* |a_i| (Q48 sum of squares of Q24 below 2^62: joints within 128 m) */
        uint64_t s2 = 0u;
        for (k = 0u; k < 3u; ++k) {
            s2 += (uint64_t)((int64_t)p->platform_joint[i][k] * p->platform_joint[i][k]);
        }
        k = sp_isqrt64(s2);
        ctrl->prep.arm_max = ((sp_q24_t)k > ctrl->prep.arm_max) ? (sp_q24_t)k : ctrl->prep.arm_max;
    }
    for (k = 0u; k < 6u; ++k) {
        ctrl->prep.acc_cap[k] = 0; /* no force model at home: every motion refused */
    }
    if (sp_inverse_kinematics(p, &p->home, &ik) != SP_OK || sp_inverse_dynamics(p, &m, &ik, NULL, f0) != SP_OK) {
        return;
    }
    for (k = 0u; k < 6u; ++k) {
        int64_t cap = INT64_C(1) << 30; /* 64 m/s^2: the trig generator's own bound (SP_TRIG_ACC_MAX) */
        sp_motion_at_rest(&m, &p->home);
        if (k < 3u) {
            m.acc[k] = SP_Q24_ONE;
        } else {
            m.rpy_acc[k - 3u] = SP_Q24_ONE;
        }
        if (sp_inverse_dynamics(p, &m, &ik, NULL, f1) != SP_OK) {
            continue;
        }
        for (i = 0u; i < SP_LEGS; ++i) {
            int64_t per = spi_abs64((int64_t)f1[i] - f0[i]); /* N per m/s^2, Q8 */
            int64_t room = budget - spi_abs64(f0[i]);
            int64_t c = (room <= 0) ? 0 : ((per == 0) ? cap : (room << 24) / per);
            cap = (c < cap) ? c : cap;
        }
        ctrl->prep.acc_cap[k] = (sp_q24_t)cap;
    }
}

/* Both ends of a trig about home reachable (as command_run_trig checks
 * them: from the last reference, no IK near it). */
static uint8_t trig_ends(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    const sp_q24_t *known = (ctrl->est.ref_lu.valid && ctrl->have_setpoint) ? ctrl->model.ref.length : NULL;
    unsigned a = (unsigned)cmd->axis;
    int s;
    sp_frames_keep_t keep;
    keep.valid = 0u;
    for (s = -1; s <= 1; s += 2) {
        sp_pose_t end = ctrl->frames.identity ? cfg->platform->home : ctrl->tool_home; /* about the pivot */
        sp_pose_t pp;
        sp_q24_t *e = (a < 3u) ? &end.pos[a] : &end.rpy[a - 3u];
        *e = sp_add(*e, (s < 0) ? -cmd->amplitude : cmd->amplitude, NULL); /* |A| <= 1: no saturation */
        if (!to_platform(ctrl, &keep, &end, &pp) ||
            !sp_limits_pose_reachable_from(&ctrl->prep.limits, cfg->platform, &ctrl->model_pose, known, &pp)) {
            return (uint8_t)SP_REFUSE_REACH;
        }
    }
    return (uint8_t)SP_REFUSE_NONE;
}

/* RUN_TRIG's parameters (READY; else the state machine refuses it). */
static uint8_t check_trig(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    unsigned a = (unsigned)cmd->axis;
    uint32_t fade = cmd->fade_ticks ? cmd->fade_ticks : cfg->fade_ticks;
    uint64_t fade_us = (uint64_t)fade * cfg->tick_us;
    int64_t amp = spi_abs64(cmd->amplitude);
    int64_t w;
    int64_t r;
    int64_t reach;
    int64_t speed;
    if (a >= SP_AXIS_COUNT || cmd->frequency <= 0 || cmd->frequency > 10 * SP_Q24_ONE || amp > SP_Q24_ONE ||
        fade_us < 100000u || fade_us > 60000000u || (int64_t)cmd->frequency * cfg->tick_us * 2 >= (US_PER_S << 24)) {
        return (uint8_t)SP_REFUSE_RANGE;
    }
    w = ((int64_t)cmd->frequency * TWO_PI_Q28) >> 28;                    /* rad/s, Q24, < 2^31 */
    r = (int64_t)(((UINT64_C(1) << 24) * (uint64_t)US_PER_S) / fade_us); /* 1/s, Q24, <= 10 */
    /* the peak speed: |A| |w cos(wt) e + sin(wt) e'| <= |A| sqrt(w^2 + (1.875 r)^2) (Cauchy-Schwarz,
     * the envelope e <= 1 and its slope e' <= 1.875 r; Q48 sum below 2^62), and a leg's rate per unit
     * of it: at most 1 on x, y, z (a unit vector's component), on an angle the largest |a_i| (one
     * Euler rate turns the platform about one unit axis: |w x R a_i| <= |w| |a_i|) */
    reach = (a < 3u) ? SP_Q24_ONE : (int64_t)ctrl->prep.arm_max;
    speed = (int64_t)sp_isqrt64((uint64_t)(w * w) + (uint64_t)((15 * r / 8) * (15 * r / 8))); /* Q24 */
    if ((((amp * speed) >> 24) * reach >> 24) > ctrl->prep.limits.rate_max) {
        return (uint8_t)SP_REFUSE_RATE;
    }
    /* the peak acceleration |A| (w^2 + 4 w r + 6 r^2) (sp_trig_start's bound) within the axis's
     * capacity: below 2^37 times |A| <= 2^24 */
    if (((amp * (((w * w) >> 24) + 4 * ((w * r) >> 24) + 6 * ((r * r) >> 24))) >> 24) > ctrl->prep.acc_cap[a]) {
        return (uint8_t)SP_REFUSE_FORCE;
    }
    return trig_ends(cfg, ctrl, cmd);
}

/* MOVE_TO: the target and the straight path's points at 1/4, 1/2 and 3/4
 * reachable (a leg's length along a straight path may dip below its
 * stroke between two reachable ends), each by sp_limits_pose_reachable_from
 * the last reference (as the state machine's check: no IK for a point
 * near it). */
static uint8_t check_move(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    sp_pose_t start = ctrl->pos_ref.pose;
    const sp_pose_t *from = &start;
    const sp_q24_t *known = (ctrl->est.ref_lu.valid && ctrl->have_setpoint) ? ctrl->model.ref.length : NULL;
    unsigned q;
    unsigned k;
    sp_frames_keep_t keep;
    keep.valid = 0u;
    if (!ctrl->frames.identity && spi_ready_tool_pose(ctrl, &start) != SP_OK) {
        return (uint8_t)SP_REFUSE_REACH; /* with frames the tool point moves on a straight line in W */
    }
    for (q = 1u; q <= 4u; ++q) {
        sp_pose_t mid;
        sp_pose_t pp;
        for (k = 0u; k < 3u; ++k) {
            mid.pos[k] = (sp_q24_t)(from->pos[k] + ((((int64_t)cmd->target.pos[k] - from->pos[k]) * q) >> 2));
            mid.rpy[k] = (sp_q24_t)(from->rpy[k] + ((((int64_t)cmd->target.rpy[k] - from->rpy[k]) * q) >> 2));
        }
        if (!to_platform(ctrl, &keep, &mid, &pp) ||
            !sp_limits_pose_reachable_from(&ctrl->prep.limits, cfg->platform, &ctrl->model_pose, known, &pp)) {
            return (uint8_t)SP_REFUSE_REACH;
        }
    }
    return (uint8_t)SP_REFUSE_NONE;
}

uint8_t spi_cmd_check(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    if (ctrl->state != SP_STATE_READY || ctrl->force.mode != SP_FORCE_OFF) {
        return (uint8_t)SP_REFUSE_NONE; /* the state machine's refusal (SP_REFUSE_STATE) */
    }
    if (cmd->type == SP_CMD_RUN_TRIG) {
        return check_trig(cfg, ctrl, cmd);
    }
    if (cmd->type == SP_CMD_MOVE_TO) {
        return check_move(cfg, ctrl, cmd);
    }
    return (uint8_t)SP_REFUSE_NONE;
}
