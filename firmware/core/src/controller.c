#include "sp/controller.h"

#include "core_internal.h"
#include "fixed_inline.h"

#define MODE_TRIG 0u
#define MODE_MOVE 1u
#define MODE_STREAM 2u
#define LEG_LIMIT_TOLERANCE INT32_C(83886) /* 5 mm beyond a stroke end, Q24 */

const char *sp_state_name(sp_state_t state)
{
    switch (state) {
    case SP_STATE_IDLE:
        return "idle";
    case SP_STATE_ENGAGING:
        return "engaging";
    case SP_STATE_READY:
        return "ready";
    case SP_STATE_RUNNING:
        return "running";
    case SP_STATE_PARKING:
        return "parking";
    case SP_STATE_FAULT:
        return "fault";
    case SP_STATE_ESTOP:
        return "estop";
    default:
        return "unknown";
    }
}

sp_status_t sp_ctrl_default_config(sp_ctrl_config_t *cfg, const sp_platform_t *platform)
{
    unsigned a;
    if (cfg == NULL || platform == NULL) {
        return SP_E_ARG;
    }
    cfg->platform = platform;
    cfg->tick_us = 1000u;
    for (a = 0u; a < SP_AXIS_COUNT; ++a) {
        cfg->move.vel_max[a] = SP_Q24_ONE / 4;
        cfg->move.acc_max[a] = SP_Q24_ONE;
        cfg->move.jerk_max[a] = 5 * SP_Q24_ONE;
    }
    cfg->fade_ticks = 2000u;
    cfg->feedback_timeout_ticks = 2u;
    cfg->divergence_pos = 419430; /* 25 mm */
    cfg->divergence_rot = 419430; /* 25 mrad */
    cfg->stroke_margin = 167772;  /* 10 mm */
    cfg->stream_omega = 10 * SP_Q24_ONE;
    cfg->force_feedforward = 1u;
    return SP_OK;
}

/* The int32 interval [*lo, *hi] of the poses whose axis value v has
 * wmin <= v - home <= wmax (exactly; lo > hi when there is none). */
static void ws_bounds(sp_q24_t home, sp_q24_t wmin, sp_q24_t wmax, sp_q24_t *lo, sp_q24_t *hi)
{
    int64_t l = (int64_t)home + wmin;
    int64_t h = (int64_t)home + wmax;
    if (l > h || l > INT32_MAX || h < INT32_MIN) {
        *lo = INT32_MAX;
        *hi = INT32_MIN;
        return;
    }
    *lo = (l < INT32_MIN) ? INT32_MIN : (sp_q24_t)l;
    *hi = (h > INT32_MAX) ? INT32_MAX : (sp_q24_t)h;
}

sp_status_t sp_ctrl_init(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg)
{
    unsigned i;
    if (ctrl == NULL || cfg == NULL || cfg->platform == NULL) {
        return SP_E_ARG;
    }
    ctrl->state = SP_STATE_IDLE;
    ctrl->faults = 0u;
    ctrl->tick = 0u;
    ctrl->seen_mask = 0u;
    ctrl->estimate = cfg->platform->park;
    ctrl->estimate_valid = 0u;
    ctrl->mode = MODE_TRIG;
    ctrl->park_after = 0u;
    ctrl->stream_stopping = 0u;
    ctrl->have_setpoint = 0u;
    ctrl->fk_cache_valid = 0u;
    ctrl->ref_lu.valid = 0u;
    for (i = 0u; i < SP_LEGS; ++i) {
        ctrl->missed[i] = 0u;
        ctrl->last_length[i] = 0;
        ctrl->setpoint[i].length = 0;
        ctrl->setpoint[i].velocity = 0;
        ctrl->setpoint[i].force = 0;
    }
    ctrl->trig.centre = cfg->platform->home;
    ctrl->trig.axis = SP_AXIS_X;
    ctrl->trig.amplitude = 0;
    ctrl->trig.omega = 0;
    ctrl->trig.phase_step = 0u;
    ctrl->trig.phase = 0u;
    ctrl->trig.fade_ticks = 1u;
    ctrl->trig.tick = 0u;
    ctrl->trig.stop_tick = UINT32_MAX;
    ctrl->trig.finished = 1;
    ctrl->move.duration_ticks = 0u;
    ctrl->move.tick = 0u;
    ctrl->move.from = cfg->platform->park;
    ctrl->move.to = cfg->platform->park;
    ctrl->move.rate_tick_us = 0u;
    ctrl->move.rate = 0;
    ctrl->stream_anchor_valid = 0u;
    for (i = 0u; i < 3u; ++i) {
        const sp_platform_t *p = cfg->platform;
        ws_bounds(p->home.pos[i], p->workspace_min.pos[i], p->workspace_max.pos[i], &ctrl->ws_lo[i], &ctrl->ws_hi[i]);
        ws_bounds(p->home.rpy[i], p->workspace_min.rpy[i], p->workspace_max.rpy[i], &ctrl->ws_lo[3u + i],
                  &ctrl->ws_hi[3u + i]);
    }
    ctrl->joint_reach = 0u;
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *a = cfg->platform->platform_joint[i];
        uint64_t l1 = (uint64_t)spi_dist32(a[0], 0) + spi_dist32(a[1], 0) + spi_dist32(a[2], 0);
        ctrl->joint_reach =
            (l1 >= UINT32_MAX) ? UINT32_MAX : (l1 > ctrl->joint_reach ? (uint32_t)l1 : ctrl->joint_reach);
    }
    return SP_OK;
}

static void motion_at_rest(sp_motion_t *m, const sp_pose_t *pose)
{
    unsigned k;
    m->pose = *pose;
    for (k = 0u; k < 3u; ++k) {
        m->vel[k] = 0;
        m->rpy_rate[k] = 0;
        m->acc[k] = 0;
        m->rpy_acc[k] = 0;
    }
}

/* Is |a - b| above the limit (a negative limit: always)? The distance is
 * exact in uint32 for any two int32. */
SPI_INLINE int farther(int32_t a, int32_t b, int32_t limit)
{
    return limit < 0 || spi_dist32(a, b) > (uint32_t)limit;
}

/* Chord FK: at most this many steps with the stale factorisation, which
 * must have been taken within CHORD_NEAR (10 mm, 10 mrad, Q24) of the
 * guess; otherwise full Newton. */
#define CHORD_MAX_STEPS 4u
#define CHORD_NEAR INT32_C(167772)

static int near_pose(const sp_pose_t *a, const sp_pose_t *b)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (farther(a->pos[k], b->pos[k], CHORD_NEAR) || farther(a->rpy[k], b->rpy[k], CHORD_NEAR)) {
            return 0;
        }
    }
    return 1;
}

/* Is the pose inside the workspace box (relative to home)? The box in
 * absolute coordinates comes from sp_ctrl_init (ws_lo, ws_hi, ws_bounds). */
static int in_workspace(const sp_ctrl_t *ctrl, const sp_pose_t *pose)
{
    unsigned a;
    for (a = 0u; a < 3u; ++a) {
        if (pose->pos[a] < ctrl->ws_lo[a] || pose->pos[a] > ctrl->ws_hi[a] || pose->rpy[a] < ctrl->ws_lo[3u + a] ||
            pose->rpy[a] > ctrl->ws_hi[3u + a]) {
            return 0;
        }
    }
    return 1;
}

/* Is the pose reachable: in the workspace and every leg inside its stroke
 * less the margin? The leg lengths go to `length` when it is not NULL. */
static int pose_reachable(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_pose_t *pose,
                          sp_q24_t length[SP_LEGS])
{
    const sp_platform_t *p = cfg->platform;
    sp_ik_t ik;
    unsigned i;
    if (!in_workspace(ctrl, pose)) {
        return 0;
    }
    spi_orientation_sc(pose->rpy, &ik.rot, ik.sc);
    if (spi_ik_lengths(p, pose, &ik) != SP_OK) { /* the lengths only: no unit vectors needed */
        return 0;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        if (ik.length[i] < p->leg_length_min + cfg->stroke_margin ||
            ik.length[i] > p->leg_length_max - cfg->stroke_margin) {
            return 0;
        }
        if (length != NULL) {
            length[i] = ik.length[i];
        }
    }
    return 1;
}

/* A sufficient test that a pose in the workspace is reachable, without its
 * IK: the legs of a base pose (`base_length`, its IK lengths) are far
 * enough inside the strokes that no leg can reach the margin on the way to
 * `pose`. A leg's length changes by at most the distance its platform joint
 * moves, |dp| + |a_i| |dR|, where |dR| <= |droll| + |dpitch| + |dyaw| (R is
 * a product of three elementary rotations, each moving a vector by at most
 * its angle times its length), |dp| <= |dx| + |dy| + |dz| and |a_i| <=
 * |a_ix| + |a_iy| + |a_iz| <= arm (sp_ctrl_t.joint_reach). Both IKs round each length within 1 LSB (+1e-9
 * of the radius): 4 LSB of margin. Returns 0 when the test is not
 * conclusive (the caller then computes the IK). */
static int reachable_near(const sp_ctrl_config_t *cfg, uint32_t arm, const sp_pose_t *base,
                          const sp_q24_t base_length[SP_LEGS], const sp_pose_t *pose)
{
    const sp_platform_t *p = cfg->platform;
    uint64_t dpos = 0u;
    uint64_t drot = 0u;
    uint64_t delta;
    int64_t lmin = (int64_t)p->leg_length_min + cfg->stroke_margin;
    int64_t lmax = (int64_t)p->leg_length_max - cfg->stroke_margin;
    unsigned k;

    for (k = 0u; k < 3u; ++k) {
        dpos += spi_dist32(pose->pos[k], base->pos[k]);
        drot += spi_dist32(pose->rpy[k], base->rpy[k]);
    }
    if (drot >= (UINT64_C(1) << 31) || arm == UINT32_MAX) {
        return 0; /* more than 128 rad or a 256 m platform: not worth bounding */
    }
    delta = dpos + (((uint64_t)arm * drot) >> 24) + 5u; /* Q24 x Q24 -> Q24, truncated: +1 */
    if (delta >= (UINT64_C(1) << 31)) {
        return 0;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        int64_t l = base_length[k];
        if (l - (int64_t)delta < lmin || l + (int64_t)delta > lmax) {
            return 0;
        }
    }
    return 1;
}

/* Is a streamed target reachable? The target in force again is; else
 * decided by the bound around the last reference (its setpoint lengths are its IK while ref_lu is valid), or
 * around the last target whose IK was computed, or else by the target's
 * IK, which then becomes that anchor. */
static int stream_target_reachable(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *t)
{
    sp_q24_t length[SP_LEGS];
    unsigned i;
    int same = 1;
    for (i = 0u; i < 3u; ++i) {
        same &= (t->pos[i] == ctrl->stream_target.pos[i]) & (t->rpy[i] == ctrl->stream_target.rpy[i]);
    }
    if (same) {
        return 1; /* the target in force (checked when it was taken, or the reference STREAM began at) */
    }
    if (!in_workspace(ctrl, t)) {
        return 0;
    }
    if (ctrl->ref_lu.valid && ctrl->have_setpoint) {
        for (i = 0u; i < SP_LEGS; ++i) {
            length[i] = ctrl->setpoint[i].length;
        }
        if (reachable_near(cfg, ctrl->joint_reach, &ctrl->reference.pose, length, t)) {
            return 1;
        }
    }
    if (ctrl->stream_anchor_valid &&
        reachable_near(cfg, ctrl->joint_reach, &ctrl->stream_anchor, ctrl->stream_anchor_length, t)) {
        return 1;
    }
    if (!pose_reachable(cfg, ctrl, t, length)) {
        return 0;
    }
    ctrl->stream_anchor = *t;
    for (i = 0u; i < SP_LEGS; ++i) {
        ctrl->stream_anchor_length[i] = length[i];
    }
    ctrl->stream_anchor_valid = 1u;
    return 1;
}

/* Setpoints of a reference motion, with every limit checked. Returns
 * SP_E_RANGE for a reference outside the limits, another error for a
 * computation failure; the setpoints are written only on SP_OK. */
static sp_status_t setpoints_for(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_motion_t *ref,
                                 sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu)
{
    const sp_platform_t *p = cfg->platform;
    sp_ik_t ik;
    sp_q24_t rate[SP_LEGS];
    sp_q8_t force[SP_LEGS];
    sp_status_t st;
    unsigned i;

    if (!in_workspace(ctrl, &ref->pose)) {
        return SP_E_RANGE;
    }
    st = sp_inverse_kinematics(p, &ref->pose, &ik);
    if (st == SP_OK) {
        st = sp_leg_rates(&ik, ref->vel, ref->rpy_rate, rate);
    }
    if (st == SP_OK) {
        st = sp_inverse_dynamics_lu(p, ref, &ik, NULL, force, lu);
    }
    if (st != SP_OK) {
        return st;
    }
    /* the limits of sp_check_legs, with the stroke margin on the lengths */
    {
        const sp_q24_t lmin = p->leg_length_min + cfg->stroke_margin;
        const sp_q24_t lmax = p->leg_length_max - cfg->stroke_margin;
        const sp_q24_t vmax = p->leg_velocity_max;
        const sp_q8_t fmax = p->force_max;
        const int ff = cfg->force_feedforward != 0;
        for (i = 0u; i < SP_LEGS; ++i) {
            if (ik.length[i] < lmin || ik.length[i] > lmax || rate[i] > vmax || rate[i] < -vmax || force[i] > fmax ||
                force[i] < -fmax) {
                return SP_E_RANGE;
            }
        }
        for (i = 0u; i < SP_LEGS; ++i) {
            sp[i].length = ik.length[i];
            sp[i].velocity = rate[i];
            sp[i].force = ff ? force[i] : 0;
        }
    }
    return SP_OK;
}

/* The reaction to a fault: park when only the reference was at fault (the
 * feedback and the drives are trustworthy), otherwise hold. */
static void raise_fault(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, uint32_t fault)
{
    uint32_t before = ctrl->faults;
    ctrl->faults |= fault;
    if (ctrl->state == SP_STATE_ESTOP || (before != 0u && ctrl->state == SP_STATE_FAULT && ctrl->faults == before)) {
        return;
    }
    ctrl->state = (fault == SP_FAULT_ESTOP) ? SP_STATE_ESTOP : SP_STATE_FAULT;
    ctrl->move.duration_ticks = 0u;
    ctrl->move.tick = 0u;
    if (ctrl->faults == SP_FAULT_REFERENCE && ctrl->estimate_valid) {
        /* controlled park from where the platform is commanded to be */
        if (sp_move_plan(&ctrl->move, &ctrl->reference.pose, &cfg->platform->park, &cfg->move, cfg->tick_us) != SP_OK) {
            ctrl->move.duration_ticks = 0u;
        }
    }
}

static int park_reaction_active(const sp_ctrl_t *ctrl)
{
    return ctrl->state == SP_STATE_FAULT && ctrl->faults == SP_FAULT_REFERENCE && ctrl->move.duration_ticks > 0u;
}

static int start_move(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *from, const sp_pose_t *to)
{
    return sp_move_plan(&ctrl->move, from, to, &cfg->move, cfg->tick_us) == SP_OK;
}

/* Stream filter: per axis a critically damped second-order follower of the
 * target, a = w^2 (target - x) - 2 w v, with the move limits on velocity and
 * acceleration. Position and velocity integrate in Q48 so that the slow
 * final approach is not lost to rounding. */
/* One axis of the stream filter: target (Q24), state x48, v48 (Q48),
 * outputs x, v, acc (Q24). */
SPI_INLINE void stream_axis(sp_q24_t target, int64_t *x48p, int64_t *v48p, int32_t vel_max, int32_t amax, int32_t w2,
                            int32_t w2x, int32_t dt, sp_q24_t *x, sp_q24_t *v, sp_q24_t *acc, sp_flags_t *flags)
{
    int64_t target48 = (int64_t)target * (INT64_C(1) << 24);
    int64_t vmax = (int64_t)vel_max * (INT64_C(1) << 24);
    int64_t x48 = *x48p;
    int64_t v48 = *v48p;
    int32_t err;
    int32_t acmd;
    if (x48 == target48 && v48 == 0) {
        /* at rest on the target: every term below is 0 */
        *acc = 0;
        *v = 0;
        *x = target;
        return;
    }
    /* |v48| <= vmax < 2^55 (clamped below, and 0 at the start), so its Q24
     * value fits int32 and v48 + acmd dt (< 2^52) cannot overflow */
    err = spi_narrow(spi_add64(target48, -x48, flags), 24u, flags);
    acmd = spi_sub(spi_mul(w2, err, 24u, flags), spi_mul(w2x, (int32_t)spi_rsr(v48, 24u), 24u, flags), flags);
    acmd = acmd > amax ? amax : (acmd < -amax ? -amax : acmd);
    v48 += (int64_t)acmd * dt; /* Q48 */
    v48 = v48 > vmax ? vmax : (v48 < -vmax ? -vmax : v48);
    x48 = spi_add64(x48, spi_mul64_rs(v48, dt, 24u, flags), flags);
    *v48p = v48;
    *x48p = x48;
    *acc = acmd;
    *v = (sp_q24_t)spi_rsr(v48, 24u);
    *x = spi_narrow(x48, 24u, flags);
}

static void stream_step(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_flags_t *flags)
{
    /* dt in s, Q24: tick_us 2^24 / 10^6 fits 32 bits for any tick_us */
    int32_t dt = (int32_t)spi_udiv64_32((uint64_t)cfg->tick_us << 24, 1000000u, NULL);
    int32_t w = cfg->stream_omega;
    int32_t w2 = spi_mul(w, w, 24u, flags);
    int32_t w2x = spi_add(w, w, flags);
    sp_motion_t *m = &ctrl->stream;
    unsigned a;
    for (a = 0u; a < 3u; ++a) {
        stream_axis(ctrl->stream_target.pos[a], &ctrl->stream_x[a], &ctrl->stream_v[a], cfg->move.vel_max[a],
                    cfg->move.acc_max[a], w2, w2x, dt, &m->pose.pos[a], &m->vel[a], &m->acc[a], flags);
        stream_axis(ctrl->stream_target.rpy[a], &ctrl->stream_x[3u + a], &ctrl->stream_v[3u + a],
                    cfg->move.vel_max[3u + a], cfg->move.acc_max[3u + a], w2, w2x, dt, &m->pose.rpy[a], &m->rpy_rate[a],
                    &m->rpy_acc[a], flags);
    }
}

/* Within 1 um (1 urad) of the pose and slower than 1 um/s on every axis. */
static int stream_settled(const sp_motion_t *m, const sp_pose_t *pose)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (farther(m->pose.pos[k], pose->pos[k], 16) || farther(m->pose.rpy[k], pose->rpy[k], 16) ||
            farther(m->vel[k], 0, 16) || farther(m->rpy_rate[k], 0, 16)) {
            return 0;
        }
    }
    return 1;
}

static void handle_command(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in, int comms_ok,
                           uint8_t *rejected)
{
    const sp_platform_t *p = cfg->platform;
    const sp_ctrl_cmd_t *cmd = &in->cmd;
    int ok = 1;
    unsigned i;

    switch (cmd->type) {
    case SP_CMD_NONE:
        return;
    case SP_CMD_ESTOP:
        raise_fault(cfg, ctrl, SP_FAULT_ESTOP);
        return;
    case SP_CMD_ENGAGE:
        ok = ctrl->state == SP_STATE_IDLE && comms_ok && ctrl->estimate_valid &&
             start_move(cfg, ctrl, &ctrl->estimate, &p->home);
        if (ok) {
            ctrl->state = SP_STATE_ENGAGING;
        }
        break;
    case SP_CMD_RUN_TRIG:
        ok = ctrl->state == SP_STATE_READY;
        if (ok) {
            sp_pose_t lo = p->home;
            sp_pose_t hi = p->home;
            unsigned a = (unsigned)cmd->axis;
            ok = a < 6u;
            if (ok) {
                sp_q24_t *l = (a < 3u) ? &lo.pos[a] : &lo.rpy[a - 3u];
                sp_q24_t *h = (a < 3u) ? &hi.pos[a] : &hi.rpy[a - 3u];
                *l = sp_sub(*l, cmd->amplitude, NULL);
                *h = sp_add(*h, cmd->amplitude, NULL);
                ok = pose_reachable(cfg, ctrl, &lo, NULL) && pose_reachable(cfg, ctrl, &hi, NULL) &&
                     sp_trig_start(&ctrl->trig, &p->home, cmd->axis, cmd->amplitude, cmd->frequency, cfg->tick_us,
                                   cmd->fade_ticks ? cmd->fade_ticks : cfg->fade_ticks) == SP_OK;
            }
        }
        if (ok) {
            ctrl->mode = MODE_TRIG;
            ctrl->park_after = 0u;
            ctrl->state = SP_STATE_RUNNING;
        }
        break;
    case SP_CMD_MOVE_TO:
        ok = ctrl->state == SP_STATE_READY && pose_reachable(cfg, ctrl, &cmd->target, NULL) &&
             start_move(cfg, ctrl, &ctrl->reference.pose, &cmd->target);
        if (ok) {
            ctrl->mode = MODE_MOVE;
            ctrl->park_after = 0u;
            ctrl->state = SP_STATE_RUNNING;
        }
        break;
    case SP_CMD_STREAM:
        ok = ctrl->state == SP_STATE_READY;
        if (ok) {
            ctrl->mode = MODE_STREAM;
            ctrl->park_after = 0u;
            ctrl->stream = ctrl->reference;
            ctrl->stream_target = ctrl->reference.pose;
            ctrl->stream_stopping = 0u;
            ctrl->stream_anchor_valid = 0u;
            for (i = 0u; i < 6u; ++i) {
                ctrl->stream_x[i] = (int64_t)sp_pose_axis(&ctrl->reference.pose, (sp_axis_t)i) << 24;
                ctrl->stream_v[i] = 0;
            }
            ctrl->state = SP_STATE_RUNNING;
        }
        break;
    case SP_CMD_STOP:
    case SP_CMD_PARK:
        if (ctrl->state == SP_STATE_RUNNING) {
            ctrl->park_after = (cmd->type == SP_CMD_PARK) ? 1u : ctrl->park_after;
            if (ctrl->mode == MODE_TRIG) {
                sp_trig_stop(&ctrl->trig);
            } else if (ctrl->mode == MODE_STREAM) {
                ctrl->stream_target = p->home; /* settle back to home, then end */
                ctrl->stream_stopping = 1u;
            }
        } else if (cmd->type == SP_CMD_PARK && (ctrl->state == SP_STATE_READY || ctrl->state == SP_STATE_ENGAGING)) {
            ok = start_move(cfg, ctrl, &ctrl->reference.pose, &p->park);
            if (ok) {
                ctrl->state = SP_STATE_PARKING;
            }
        } else {
            ok = 0;
        }
        break;
    case SP_CMD_RESET:
        ok = (ctrl->state == SP_STATE_FAULT || ctrl->state == SP_STATE_ESTOP) && comms_ok && ctrl->estimate_valid;
        if (ok) {
            ok = start_move(cfg, ctrl, &ctrl->estimate, &p->home);
        }
        if (ok) {
            ctrl->faults = 0u;
            ctrl->state = SP_STATE_ENGAGING;
        }
        break;
    default:
        ok = 0;
        break;
    }
    if (!ok) {
        *rejected = 1u;
    }
}

sp_status_t sp_ctrl_step(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in, sp_ctrl_output_t *out)
{
    const sp_platform_t *p;
    sp_flags_t flags = 0u;
    sp_motion_t ref;
    uint32_t all = (UINT32_C(1) << SP_LEGS) - 1u;
    int comms_ok = 1;
    int drive_fault = 0;
    int leg_out = 0; /* a measured length beyond a stroke end by more than the tolerance */
    int active;
    int hold = 0;
    uint8_t rejected = 0u;
    uint32_t fk_iterations = 0u;
    unsigned i;

    if (cfg == NULL || ctrl == NULL || in == NULL || out == NULL || cfg->platform == NULL) {
        return SP_E_ARG;
    }
    p = cfg->platform;
    if (ctrl->tick < UINT32_MAX) {
        ++ctrl->tick;
    }
    active = ctrl->state == SP_STATE_ENGAGING || ctrl->state == SP_STATE_READY || ctrl->state == SP_STATE_RUNNING ||
             ctrl->state == SP_STATE_PARKING || park_reaction_active(ctrl);

    /* 1. Feedback supervision. */
    {
        uint32_t seen = ctrl->seen_mask;
        uint32_t timeout = cfg->feedback_timeout_ticks;
        /* the stroke ends widened by the tolerance, clamped to int32 (exact:
         * no int32 length lies beyond a clamped end) */
        int64_t lo64 = (int64_t)p->leg_length_min - LEG_LIMIT_TOLERANCE;
        int64_t hi64 = (int64_t)p->leg_length_max + LEG_LIMIT_TOLERANCE;
        int32_t lo = (lo64 < INT32_MIN) ? INT32_MIN : (int32_t)lo64;
        int32_t hi = (hi64 > INT32_MAX) ? INT32_MAX : (int32_t)hi64;
        for (i = 0u; i < SP_LEGS; ++i) {
            const sp_drive_feedback_t *fb = &in->drive[i];
            uint32_t missed = ctrl->missed[i];
            if (fb->fresh) {
                missed = 0u;
                seen |= UINT32_C(1) << i;
                ctrl->last_length[i] = fb->length;
                drive_fault |= (fb->faults != 0u) ? 1 : 0;
            } else if (missed < UINT32_MAX) {
                ++missed;
            }
            ctrl->missed[i] = missed;
            comms_ok &= (missed < timeout) ? 1 : 0;
            leg_out |= (ctrl->last_length[i] < lo || ctrl->last_length[i] > hi) ? 1 : 0; /* the last measured length */
        }
        ctrl->seen_mask = seen;
        if (seen != all) {
            comms_ok = 0; /* a drive never heard from */
        }
    }
    if (active && !comms_ok) {
        raise_fault(cfg, ctrl, SP_FAULT_FEEDBACK_TIMEOUT);
    }
    if (active && drive_fault) {
        raise_fault(cfg, ctrl, SP_FAULT_DRIVE);
    }

    /* 2. Pose estimate from the measured lengths, warm-started. */
    if (ctrl->seen_mask == all) {
        sp_fk_options_t opt;
        sp_fk_info_t info;
        sp_pose_t est;
        sp_status_t st;
        sp_fk_default_options(&opt);
        if (!ctrl->estimate_valid) {
            /* cold start from the parked pose, no continuity to check */
            opt.max_iterations = 20u;
            opt.max_jump_pos = INT32_MAX;
            opt.max_jump_rot = INT32_MAX;
        }
        st = SP_E_NO_CONVERGENCE;
        info.iterations = 0u;
        if (ctrl->estimate_valid && ctrl->fk_cache_valid && ctrl->ref_lu.valid &&
            near_pose(&ctrl->estimate, &ctrl->reference.pose)) {
            /* chord steps with last tick's factorisation of J^T (at last
             * tick's reference, within CHORD_NEAR of the guess), from the
             * estimate's cached lengths: no Jacobian, no factorisation, and
             * no IK at the guess */
            sp_fk_options_t copt = opt;
            copt.max_iterations = CHORD_MAX_STEPS;
            st = sp_fk_chord(p, ctrl->last_length, &ctrl->estimate, &ctrl->ref_lu, &copt, &ctrl->fk_cache, &est, &info);
        }
        if (st != SP_OK) {
            /* full Newton from the guess; the cache of the result from the
             * IK of its last pass (lengths and sines, exactly what
             * sp_fk_cache_of computes) */
            sp_ik_t fik;
            st = sp_forward_kinematics(p, ctrl->last_length, ctrl->estimate_valid ? &ctrl->estimate : &p->park, &opt,
                                       &est, &fik, &info);
            if (st == SP_OK) {
                for (i = 0u; i < SP_LEGS; ++i) {
                    ctrl->fk_cache.length[i] = fik.length[i];
                    ctrl->fk_cache.sc[i] = fik.sc[i];
                }
            }
            ctrl->fk_cache_valid = (st == SP_OK) ? 1u : 0u;
        }
        fk_iterations = info.iterations;
        if (st == SP_OK) {
            ctrl->estimate = est;
            ctrl->estimate_valid = 1u;
        } else {
            ctrl->estimate_valid = 0u;
            ctrl->fk_cache_valid = 0u;
            if (active) {
                raise_fault(cfg, ctrl, SP_FAULT_FK);
            }
        }
        if (active && leg_out) {
            raise_fault(cfg, ctrl, SP_FAULT_LEG_LIMIT);
        }
    }

    /* 3. The operator's command. */
    handle_command(cfg, ctrl, in, comms_ok, &rejected);
    if (ctrl->state == SP_STATE_RUNNING && ctrl->mode == MODE_STREAM && in->stream_fresh) {
        const sp_pose_t *t = &in->stream_target;
        if (ctrl->stream_stopping) {
            rejected = 1u; /* after STOP or PARK the target stays home, whatever is still streamed */
        } else if (stream_target_reachable(cfg, ctrl, t)) {
            ctrl->stream_target = *t;
        } else {
            rejected = 1u; /* never passed on: the previous target stays */
        }
    }

    /* 4. The reference of this tick. */
    switch (ctrl->state) {
    case SP_STATE_ENGAGING:
    case SP_STATE_PARKING: {
        int done = 0;
        flags |= (sp_move_step(&ctrl->move, cfg->tick_us, &ref, &done) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
        if (done) {
            ctrl->state = (ctrl->state == SP_STATE_ENGAGING) ? SP_STATE_READY : SP_STATE_IDLE;
        }
        break;
    }
    case SP_STATE_RUNNING:
        if (ctrl->mode == MODE_TRIG) {
            flags |= (sp_trig_step(&ctrl->trig, cfg->tick_us, &ref) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
            if (ctrl->trig.finished) {
                ctrl->state = SP_STATE_READY;
            }
        } else if (ctrl->mode == MODE_MOVE) {
            int done = 0;
            flags |= (sp_move_step(&ctrl->move, cfg->tick_us, &ref, &done) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
            if (done) {
                ctrl->state = SP_STATE_READY;
            }
        } else {
            stream_step(cfg, ctrl, &flags);
            ref = ctrl->stream;
            if (ctrl->stream_stopping && stream_settled(&ref, &p->home)) {
                motion_at_rest(&ref, &p->home);
                ctrl->state = SP_STATE_READY;
            }
        }
        if (ctrl->state == SP_STATE_READY && ctrl->park_after) {
            ctrl->park_after = 0u;
            if (start_move(cfg, ctrl, &ref.pose, &p->park)) {
                ctrl->state = SP_STATE_PARKING;
            }
        }
        break;
    case SP_STATE_READY:
        motion_at_rest(&ref, &ctrl->reference.pose);
        break;
    case SP_STATE_FAULT:
        if (park_reaction_active(ctrl)) {
            int done = 0;
            flags |= (sp_move_step(&ctrl->move, cfg->tick_us, &ref, &done) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
            if (done) {
                ctrl->move.duration_ticks = 0u; /* parked: hold there, still latched */
            }
        } else {
            hold = 1;
            motion_at_rest(&ref, &ctrl->reference.pose);
        }
        break;
    case SP_STATE_ESTOP:
        hold = 1;
        motion_at_rest(&ref, &ctrl->reference.pose);
        break;
    case SP_STATE_IDLE:
    default:
        hold = 1;
        motion_at_rest(&ref, ctrl->estimate_valid ? &ctrl->estimate : &p->park);
        break;
    }

    /* 5. Setpoints: every reference is checked against the limits; one that
     * fails is never passed on. */
    if (hold) {
        for (i = 0u; i < SP_LEGS; ++i) {
            if (ctrl->state == SP_STATE_IDLE || !ctrl->have_setpoint) {
                ctrl->setpoint[i].length = ctrl->last_length[i];
                ctrl->setpoint[i].force = 0;
            }
            ctrl->setpoint[i].velocity = 0;
        }
        ctrl->reference = ref;
        ctrl->ref_lu.valid = 0u; /* no factorisation at this reference */
    } else {
        /* written only when every limit holds */
        sp_status_t st = (flags == 0u) ? setpoints_for(cfg, ctrl, &ref, ctrl->setpoint, &ctrl->ref_lu) : SP_E_OVERFLOW;
        if (st == SP_OK) {
            ctrl->have_setpoint = 1u;
            ctrl->reference = ref;
        } else {
            ctrl->ref_lu.valid = 0u; /* the reference stays the previous one */
            raise_fault(cfg, ctrl, (st == SP_E_RANGE) ? SP_FAULT_REFERENCE : SP_FAULT_COMPUTE);
            for (i = 0u; i < SP_LEGS; ++i) {
                ctrl->setpoint[i].velocity = 0; /* hold the last valid lengths */
            }
            motion_at_rest(&ctrl->reference, &ctrl->reference.pose);
        }
    }

    /* 6. Divergence of the estimate from the reference. */
    if ((ctrl->state == SP_STATE_ENGAGING || ctrl->state == SP_STATE_READY || ctrl->state == SP_STATE_RUNNING ||
         ctrl->state == SP_STATE_PARKING) &&
        ctrl->estimate_valid) {
        for (i = 0u; i < 3u; ++i) {
            if (farther(ctrl->estimate.pos[i], ctrl->reference.pose.pos[i], cfg->divergence_pos) ||
                farther(ctrl->estimate.rpy[i], ctrl->reference.pose.rpy[i], cfg->divergence_rot)) {
                raise_fault(cfg, ctrl, SP_FAULT_DIVERGENCE);
                break;
            }
        }
    }

    /* 7. Outputs. */
    for (i = 0u; i < SP_LEGS; ++i) {
        out->setpoint[i] = ctrl->setpoint[i];
    }
    out->drive_mode = (ctrl->state == SP_STATE_IDLE || ctrl->state == SP_STATE_ESTOP ||
                       (ctrl->state == SP_STATE_FAULT && !park_reaction_active(ctrl)))
                          ? SP_DRIVE_HOLD
                          : SP_DRIVE_ACTIVE;
    out->state = ctrl->state;
    out->faults = ctrl->faults;
    out->tick = ctrl->tick;
    out->estimate = ctrl->estimate;
    out->estimate_valid = ctrl->estimate_valid;
    out->reference = ctrl->reference;
    out->fk_iterations = fk_iterations;
    out->cmd_rejected = rejected;
    return SP_OK;
}
