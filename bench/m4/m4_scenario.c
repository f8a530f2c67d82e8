/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_scenario.c - the controller scenario of the bench/m4 programs
 * (m4_vectors.h): ENGAGE, the paper's surge, PARK, with an ideal plant.
 */
#include "m4_vectors.h"

#include "sp/model/kinematics.h"

uint8_t m4_scenario_frames;

/* The frames of m4_scenario_frames into the config: slot 1 of each kind, active. */
static void scenario_frames(sp_ctrl_config_t *cfg)
{
    sp_pose_t *t = &cfg->frames.tool[1];
    sp_pose_t *w = &cfg->frames.work[1];
    if (m4_scenario_frames == 0u) {
        return;
    }
    t->pos[0] = SP_Q24_MILLI(150);
    t->pos[2] = SP_Q24_MILLI(350);
    cfg->frames.tool_used = 3u;
    cfg->frames.tool_active = 1u;
    if (m4_scenario_frames == 2u) {
        t->rpy[0] = SP_Q24_MILLI(50);
        t->rpy[1] = -SP_Q24_MILLI(100);
        t->rpy[2] = SP_Q24_MILLI(200);
        w->pos[0] = SP_Q24_MILLI(200);
        w->pos[1] = SP_Q24_MILLI(100);
        w->rpy[1] = SP_Q24_MILLI(349);
        cfg->frames.work_used = 3u;
        cfg->frames.work_active = 1u;
    }
}

sp_status_t m4_scenario_init(m4_scenario_t *s, const sp_platform_t *platform, uint8_t motion)
{
    sp_ik_t park;
    sp_status_t st;
    unsigned i;
    uint8_t *bytes = (uint8_t *)s;

    for (i = 0u; i < sizeof *s; ++i) {
        bytes[i] = 0u; /* inputs, outputs, counters and padding all zero */
    }
    s->motion = motion;
    st = sp_ctrl_default_config(&s->cfg, platform);
    if (motion == M4_MOTION_FORCE || motion == M4_MOTION_FORCE_TWIN) {
        s->cfg.wrench_source = SP_WRENCH_SENSOR;
    }
    if (st == SP_OK) {
        scenario_frames(&s->cfg);
        st = sp_ctrl_init(&s->ctrl, &s->cfg);
    }
    if (st == SP_OK) {
        st = sp_inverse_kinematics(platform, &platform->park, &park);
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        s->in.drive[i].length = (st == SP_OK) ? park.length[i] : 0;
    }
    return st;
}

/* M4_MOTION_FORCE: the sensor reads the surface under the tool (from the
 * reference the ideal plant followed), and the operator's commands by phase.
 * M4_MOTION_FORCE_TWIN: the same without the FORCE command. */
static void force_scenario(m4_scenario_t *s)
{
    const sp_platform_t *p = s->cfg.platform;
    int64_t below = (int64_t)(p->home.pos[2] - SP_Q24_MILLI(2)) - s->out.reference.pose.pos[2];
    s->in.ft_fresh = 1u;
    s->in.ft_reading[2] = (below > 0) ? (sp_q8_t)((below * 1000000) >> 16) : 0; /* 1e6 N/m, Q24 m -> Q8 N */
    ++s->phase_ticks;
    if (s->phase == 0u && s->ticks > 1u && s->out.state == SP_STATE_READY) {
        s->in.cmd.type = SP_CMD_TARE;
        s->phase = 1u;
        s->phase_ticks = 0u;
    } else if (s->phase == 1u && s->phase_ticks > 600u) {
        s->in.cmd.type = (s->motion == M4_MOTION_FORCE) ? SP_CMD_FORCE : SP_CMD_NONE; /* the twin: none */
        s->in.cmd.force_mask = 0x04u;
        s->in.cmd.force_target[2] = -2000 * SP_Q8_ONE;
        s->run_sent = 1u;
        s->phase = 2u;
        s->phase_ticks = 0u;
    } else if (s->phase == 2u && s->phase_ticks > 2000u) {
        s->in.cmd.type = SP_CMD_MOVE_TO;
        s->in.cmd.target = s->ctrl.tool_home;
        s->in.cmd.target.pos[0] += SP_Q24_MILLI(50);
        s->phase = 3u;
        s->phase_ticks = 0u;
    } else if (s->phase == 3u && s->phase_ticks > 3000u && !s->park_sent && s->out.state == SP_STATE_READY) {
        s->in.cmd.type = SP_CMD_PARK;
        s->park_sent = 1u;
    }
}

int m4_scenario_prepare(m4_scenario_t *s)
{
    unsigned i;
    if (s->ticks >= M4_MAX_TICKS || s->tail >= M4_TAIL_TICKS) {
        return 0;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        s->in.drive[i].fresh = 1u;
    }
    s->in.cmd.type = SP_CMD_NONE;
    s->in.stream_fresh = 0u;
    if (s->motion == M4_MOTION_STREAM && s->run_sent && !s->park_sent) {
        /* a target every tick, one of four poses around home for 500 ticks
         * each, all six axes moving: 40 mm in x and y, 20 mm in z, 0.02 rad
         * in roll and pitch, 0.04 rad in yaw; x also creeps by 1 um a tick,
         * so no target repeats the one before */
        static const int32_t d40[4] = {671089, 0, -671089, 0};
        static const int32_t d20[4] = {0, 335544, 0, -335544};
        uint32_t q = (s->running_ticks / 500u) & 3u;
        s->in.stream_fresh = 1u;
        s->in.stream_target = s->ctrl.tool_home; /* home's tool pose (home itself with identity frames) */
        s->in.stream_target.pos[0] += d40[q] + (int32_t)(s->running_ticks % 500u) * 17; /* + 1 um a tick */
        s->in.stream_target.pos[1] += d40[(q + 1u) & 3u];
        s->in.stream_target.pos[2] += d20[q];
        s->in.stream_target.rpy[0] += d20[(q + 1u) & 3u];
        s->in.stream_target.rpy[1] += d20[q];
        s->in.stream_target.rpy[2] += d40[(q + 3u) & 3u];
    }
    if ((s->motion == M4_MOTION_FORCE || s->motion == M4_MOTION_FORCE_TWIN) && s->ticks != 1u) {
        force_scenario(s);
    } else if (s->ticks == 1u) {
        s->in.cmd.type = SP_CMD_ENGAGE;
    } else if (!s->run_sent && s->ticks > 1u && s->out.state == SP_STATE_READY) {
        s->in.cmd.type = (s->motion == M4_MOTION_STREAM) ? SP_CMD_STREAM : SP_CMD_RUN_TRIG;
        s->in.cmd.axis = (s->motion == M4_MOTION_YAW) ? SP_AXIS_YAW : SP_AXIS_X;
        s->in.cmd.amplitude = 1509949;        /* 90 mm or 0.09 rad */
        s->in.cmd.frequency = SP_Q24_ONE / 2; /* 0.5 Hz */
        s->run_sent = 1u;
    } else if (s->run_sent && !s->park_sent && s->running_ticks >= M4_RUN_TICKS) {
        s->in.cmd.type = SP_CMD_PARK;
        s->park_sent = 1u;
    }
    return 1;
}

void m4_scenario_finish(m4_scenario_t *s)
{
    unsigned i;
    ++s->ticks;
    if ((unsigned)s->out.state < 32u) {
        s->visited |= UINT32_C(1) << (unsigned)s->out.state;
    }
    if (s->out.state == SP_STATE_RUNNING) {
        ++s->running_ticks;
    }
    if (s->park_sent && s->out.state == SP_STATE_IDLE) {
        ++s->tail;
    }
    if (s->out.drive_mode == SP_DRIVE_ACTIVE) {
        for (i = 0u; i < SP_LEGS; ++i) {
            /* the drive follows its setpoint a tick late with a tracking
             * error: a triangle of +-42 um and 400 ticks, each leg's
             * phase its own, so that the estimate's chord step has a
             * difference to solve every tick, as on a machine (the demo's
             * tracking error is 0.08 mm RMS). A plant that returned the
             * setpoints exactly left the step nothing to do and hid ~850
             * instructions a tick. */
            uint32_t ph = (s->ticks + 67u * i) % 400u;
            int32_t tri = (int32_t)((ph < 200u) ? ph : 400u - ph) - 100;
            s->in.drive[i].length = s->out.setpoint[i].length + 7 * tri;
        }
    }
}
