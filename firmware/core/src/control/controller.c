/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/control/controller.h"

#include "control/control_internal.h"
#include "estimation/estimation_internal.h"
#include "model/model_internal.h"
#include "math/fixed_inline.h"

/* The ticks the factorisation of J^T is staged over (sp_leg_hold_t.
 * lu_staged, sp/control/controller.h SP_CTRL_LU_KEEP): three from
 * SP_CTRL_LEG_GROUPS + 3 on, two at + 2, else none. */
#define CTRL_LU_STAGED                                                                                                 \
    ((SP_CTRL_LU_KEEP > SP_CTRL_LEG_GROUPS + 2u) ? 3u : ((SP_CTRL_LU_KEEP > SP_CTRL_LEG_GROUPS + 1u) ? 2u : 0u))

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
    case SP_STATE_STOPPING:
        return "stopping";
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
        cfg->move.vel_max[a] = SP_Q24_MILLI(250);
        cfg->move.acc_max[a] = SP_Q24_ONE;
        cfg->move.jerk_max[a] = 5 * SP_Q24_ONE;
    }
    cfg->fade_ticks = 2000u; /* 2 s */
    cfg->feedback_timeout_ticks = 2u;
    cfg->divergence_pos = SP_Q24_MILLI(25); /* 25 mm */
    cfg->divergence_rot = SP_Q24_MILLI(25); /* 25 mrad */
    cfg->stroke_margin = SP_Q24_MILLI(10);  /* 10 mm */
    cfg->stream_omega = 10 * SP_Q24_ONE;
    cfg->force_feedforward = 1u;
    cfg->friction_compensation = 1u;
    cfg->wrench_cutoff_hz = 80 * SP_Q24_ONE;
    cfg->wrench_smooth_hz = 15 * SP_Q24_ONE;
    cfg->wrench_jump[0] = 80 << 8; /* 80 N */
    cfg->wrench_jump[1] = 60 << 8; /* 60 N m */
    cfg->wrench_jump_persist = 4u;
    cfg->wrench_jump_hold = 20u;
    cfg->friction_observer = 1u;
    (void)sp_force_default_config(&cfg->force, SP_Q30_ONE, cfg->tick_us); /* gain and tick: set by init */
    cfg->wrench_source = SP_WRENCH_CYLINDERS;
    for (a = 0u; a < 3u; ++a) {
        unsigned b;
        cfg->ft_mount.pos[a] = 0;
        for (b = 0u; b < 3u; ++b) {
            cfg->ft_mount.axes.t[a][b] = (a == b) ? SP_Q30_ONE : 0;
        }
    }
    cfg->ft_timeout_ticks = 5u;
    cfg->ft_tare_samples = 500u;
    cfg->operator_timeout_ticks = 200u;
    cfg->drive_reset_ticks = 20u;
    cfg->operator_park = 0u;
    cfg->feedback_divider = 1u;
    for (a = 0u; a < SP_FRAME_SLOTS; ++a) {
        unsigned k;
        for (k = 0u; k < 3u; ++k) {
            cfg->frames.tool[a].pos[k] = 0;
            cfg->frames.tool[a].rpy[k] = 0;
            cfg->frames.work[a].pos[k] = 0;
            cfg->frames.work[a].rpy[k] = 0;
        }
    }
    cfg->frames.tool_used = 1u;
    cfg->frames.work_used = 1u;
    cfg->frames.tool_active = 0u;
    cfg->frames.work_active = 0u;
    cfg->estop.category = 1u;
    cfg->estop.limits.decel[0] = 4 * SP_Q24_ONE; /* 4 m/s^2 */
    cfg->estop.limits.decel[1] = 4 * SP_Q24_ONE; /* 4 rad/s^2 */
    cfg->estop.limits.jerk[0] = 25 * SP_Q24_ONE; /* 25 m/s^3 */
    cfg->estop.limits.jerk[1] = 25 * SP_Q24_ONE; /* 25 rad/s^3 */
    cfg->estop.settle_ticks = 30u;
    return SP_OK;
}

sp_status_t sp_ctrl_set_wrench_source(sp_ctrl_config_t *cfg, uint8_t source, const sp_ft_mount_t *mount)
{
    if (cfg == NULL || (source != SP_WRENCH_CYLINDERS && source != SP_WRENCH_SENSOR)) {
        return SP_E_ARG;
    }
    cfg->wrench_source = source;
    if (mount != NULL) {
        cfg->ft_mount = *mount;
    }
    if (source == SP_WRENCH_CYLINDERS) {
        cfg->force.contact.made = SP_CONTACT_MADE_CYLINDERS_Q8;
        cfg->force.contact.lost_ratio = SP_CONTACT_LOST_CYLINDERS_Q30;
        cfg->force.admit.crossover = SP_CROSSOVER_CYLINDERS_Q16;
        cfg->force.contact.made_slow = SP_CONTACT_MADE_SLOW_CYLINDERS_Q8;
        cfg->force.contact.slow_shift = SP_CONTACT_SLOW_SHIFT_CYLINDERS;
        cfg->force.admit.secant_margin = SP_SECANT_MARGIN_CYLINDERS_Q8;
        cfg->force.admit.boost = SP_BOOST_CYLINDERS;
        cfg->force.admit.boost_band = SP_BOOST_BAND_CYLINDERS_Q8;
        cfg->force.contact_ff = 1u;
    } else {
        sp_force_config_t d;
        (void)sp_force_default_config(&d, SP_Q30_ONE, cfg->tick_us);
        cfg->force.contact.made = d.contact.made;
        cfg->force.contact.lost_ratio = d.contact.lost_ratio;
        cfg->force.admit.crossover = d.admit.crossover;
        cfg->force.contact.made_slow = d.contact.made_slow;
        cfg->force.contact.slow_shift = d.contact.slow_shift;
        cfg->force.admit.secant_margin = d.admit.secant_margin;
        cfg->force.admit.boost = d.admit.boost;
        cfg->force.admit.boost_band = d.admit.boost_band;
        cfg->force.contact_ff = d.contact_ff;
    }
    return SP_OK;
}

/* The wrench filters' coefficients and the smoother's jump thresholds and
 * counts, for a feedback period of div ticks. */
static sp_status_t prepare_wrench(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg, uint32_t div)
{
    sp_status_t st = sp_wrench_alpha(cfg->wrench_cutoff_hz, cfg->tick_us, &ctrl->prep.wrench_alpha);
    unsigned i;
    if (st == SP_OK) {
        st = sp_wrench_alpha(cfg->wrench_cutoff_hz, ctrl->prep.feedback_us, &ctrl->prep.cyl_alpha);
    }
    if (st == SP_OK) {
        st = sp_wrench_alpha(cfg->wrench_smooth_hz, ctrl->prep.feedback_us, &ctrl->prep.wrench_smooth.alpha);
    }
    if (st == SP_OK && (cfg->wrench_jump[0] < 1 || cfg->wrench_jump[1] < 1 || cfg->wrench_jump_persist < 1u ||
                        cfg->wrench_jump_hold < 1u)) {
        st = SP_E_ARG;
    }
    if (st == SP_OK) {
        /* the thresholds at the same multiple of the filter's noise: one
         * sample per period of div ticks leaves about sqrt(div) times the
         * native noise (sqrt(div) in Q8; jump <= 2^30: the product < 2^42,
         * held at 2^30) */
        int64_t root_q8 = (int64_t)sp_isqrt64((uint64_t)div << 16);
        for (i = 0u; i < 2u; ++i) {
            int64_t j = ((int64_t)cfg->wrench_jump[i] * root_q8 + 128) >> 8;
            ctrl->prep.wrench_smooth.jump[i] = (int32_t)(j > (INT64_C(1) << 30) ? (INT64_C(1) << 30) : j);
        }
        /* counts of ticks, in the smoother's steps (one per feedback period), rounded up */
        ctrl->prep.wrench_smooth.persist = (uint8_t)((cfg->wrench_jump_persist + div - 1u) / div);
        ctrl->prep.wrench_smooth.hold = (uint8_t)((cfg->wrench_jump_hold + div - 1u) / div);
    }
    return st;
}

/* What sp_ctrl_init computes once from the configuration (ctrl->prep and
 * the friction table), checking it: SP_OK or why not. */
static sp_status_t prepare(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg)
{
    const sp_platform_t *p = cfg->platform;
    sp_status_t st;
    /* the cylinders' estimate steps once per feedback period (below 1: every tick) */
    uint32_t div = (cfg->feedback_divider > 1u) ? cfg->feedback_divider : 1u;
    ctrl->prep.feedback_us = cfg->tick_us * div;
    st = sp_friction_prepare(p, &ctrl->prep.friction);
    /* the observer's parameters, once: a platform it cannot run with
     * leaves the estimate on the feed-forward's friction, as before */
    ctrl->prep.fric_obs_ok = (sp_fric_obs_check(p) == SP_OK) ? 1u : 0u;
    /* its slow legs' exps, once (SP_E_ARG: an empty table, not used) */
    (void)sp_fric_table_prepare(p, ctrl->prep.feedback_us, &ctrl->fric_table);
    if (st == SP_OK) {
        st = prepare_wrench(ctrl, cfg, div);
    }
    if (st == SP_OK) {
        st = sp_motion_error_init(&ctrl->motion_error, ctrl->prep.feedback_us);
    }
    if (st == SP_OK) {
        ctrl->prep.force = cfg->force;
        ctrl->prep.force.admit.filter_alpha = ctrl->prep.wrench_alpha;
        ctrl->prep.force.admit.tick_us = cfg->tick_us;
        st = sp_force_init(&ctrl->prep.force, &ctrl->force);
    }
    if (st == SP_OK && ((cfg->wrench_source != SP_WRENCH_CYLINDERS && cfg->wrench_source != SP_WRENCH_SENSOR) ||
                        cfg->ft_tare_samples < 1u || cfg->ft_tare_samples > 65536u || cfg->ft_timeout_ticks < 1u)) {
        st = SP_E_ARG;
    }
    if (st == SP_OK) {
        st = spi_estop_config_check(&cfg->estop);
    }
    if (st == SP_OK) {
        spi_cmd_prepare(ctrl, cfg); /* needs nothing of the above */
    }
    return st;
}

/* The estimate, the wrench, the models and the supervision at park, before
 * the first tick. */
static void reset_estimate(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg)
{
    const sp_platform_t *p = cfg->platform;
    unsigned i;
    ctrl->park_after_release = 0u;
    ctrl->contact_ff_cols = 0u;
    sp_motion_at_rest(&ctrl->pos_ref, &p->park);
    sp_ft_tare_reset(&ctrl->ft_tare);
    sp_ft_tare_reset(&ctrl->cyl_tare);
    for (i = 0u; i < 6u; ++i) {
        ctrl->cyl_wrench[i] = 0;
    }
    ctrl->ft_missed = UINT32_MAX;
    ctrl->ft_valid = 0u;
    ctrl->ft_frame_valid = 0u;
    /* SP_E_RANGE (legs outside its envelope) leaves the rigid body */
    {
        sp_me_body_t body;
        (void)sp_motion_error_body(p, &body);
        (void)sp_motion_error_m6(&body, &ctrl->prep.motion_body); /* cannot fail: no NULL */
    }
    (void)sp_limits_prepare(&ctrl->prep.limits, p, cfg->stroke_margin); /* cannot fail: no NULL */
    (void)sp_stream_gains(&ctrl->prep.stream, cfg->tick_us, cfg->stream_omega);
    sp_wrench_reset(&ctrl->wrench);
    sp_fric_obs_reset(&ctrl->fric_obs);
    ctrl->state = SP_STATE_IDLE;
    ctrl->faults = 0u;
    ctrl->tick = 0u;
    ctrl->sup.seen_mask = 0u;
    ctrl->sup.no_force_mask = 0u;
    sp_estimate_init(&ctrl->est, &p->park);
    ctrl->est_ref = p->park;
    ctrl->est_ref_valid = 0u;
    ctrl->mode = SP_MODE_TRIG;
    ctrl->park_after = 0u;
    ctrl->have_setpoint = 0u;
    ctrl->setpoint_ff = 0u;
    ctrl->model_pose = p->park;
    ctrl->model_current = 1u;
    ctrl->setpoints_deferred = 0u;
    ctrl->busy = 0u;
    ctrl->legs.held = 0u; /* no leg terms kept: the first setpoints compute every leg */
    ctrl->legs.fresh = 0u;
    /* the forces' factorisation made every SP_CTRL_LU_KEEP ticks, the
     * ticks between refining from the last forces (sp_inverse_dynamics_held;
     * only with the leg terms kept: SP_CTRL_LEG_GROUPS > 1) */
    ctrl->legs.lu_keep = (uint8_t)SP_CTRL_LU_KEEP;
    ctrl->legs.lu_staged = (uint8_t)CTRL_LU_STAGED;
    ctrl->legs.lu_age = 0u;
    ctrl->legs.lu_next.begun = 0u; /* no factorisation staged */
    ctrl->legs_exact = 0u;
    ctrl->leg_group = 0u;
    ctrl->ref_orient.valid = 0u;
    {
        /* the reference's orientation kept from the park pose (where the
         * platform starts and the estimate's cold start begins): the
         * platform's bounds, park's sines and T, and (its second call, the
         * orientation held) its arms. The ENGAGE tick's reference, at rest
         * at the estimate, then pays for these only where its angles
         * differ from park's; the IK is the same bit for bit either way. */
        sp_ik_t park_ik;
        (void)sp_inverse_kinematics_kept(p, &p->park, &ctrl->ref_orient, &park_ik);
        (void)sp_inverse_kinematics_kept(p, &p->park, &ctrl->ref_orient, &park_ik);
    }
}

/* The setpoints, the motion generators and the link's and drives' state
 * before the first tick: no motion, nothing pending. */
static void reset_motion(sp_ctrl_t *ctrl, const sp_platform_t *p)
{
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        ctrl->sup.missed[i] = 0u;
        ctrl->sup.last_length[i] = 0;
        ctrl->sup.last_force[i] = 0;
        ctrl->sup.last_faults[i] = 0u;
        ctrl->setpoint[i].length = 0;
        ctrl->setpoint[i].velocity = 0;
        ctrl->setpoint[i].force = 0;
    }
    ctrl->trig.centre = p->home;
    ctrl->trig.axis = SP_AXIS_X;
    ctrl->trig.amplitude = 0;
    ctrl->trig.omega = 0;
    ctrl->trig.phase_step = 0u;
    ctrl->trig.phase = 0u;
    ctrl->trig.fade_ticks = 1u;
    ctrl->trig.tick = 0u;
    ctrl->trig.stop_tick = UINT32_MAX;
    ctrl->trig.finished = 1;
    ctrl->trig.fade_tick_us = 0u;
    ctrl->move.duration_ticks = 0u;
    ctrl->move.tick = 0u;
    ctrl->move.from = p->park;
    ctrl->move.to = p->park;
    ctrl->move.rate_tick_us = 0u;
    ctrl->move.rate = 0;
    ctrl->stream.stopping = 0u;
    ctrl->stream.anchor_valid = 0u;
    ctrl->link.silent = 0u;
    ctrl->link.armed = 0u;
    ctrl->drive_reset.left = 0u;
    ctrl->drive_reset.edge = 0u;
    ctrl->drive_reset.refused_legs = 0u;
    ctrl->drive_reset.refused_cause = 0u;
    ctrl->fault_hold_ticks = 0u;
    spi_estop_clear(ctrl);
}

/* ---- frames -------------------------------------------------------------- */

/* The frames of the active slots into ctrl->frames, their checksum and
 * home's tool pose. SP_E_RANGE (ctrl->frames then identity) for a slot
 * outside sp_frames_prepare's bounds or an active slot not defined. */
static sp_status_t activate_frames(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    const sp_frame_slots_t *sl = &ctrl->slots;
    sp_status_t st = SP_E_RANGE;
    if (sl->tool_active < SP_FRAME_SLOTS && sl->work_active < SP_FRAME_SLOTS &&
        (sl->tool_used & (1u << sl->tool_active)) != 0u && (sl->work_used & (1u << sl->work_active)) != 0u) {
        st = sp_frames_prepare(&sl->tool[sl->tool_active], &sl->work[sl->work_active], &ctrl->frames);
    } else {
        (void)sp_frames_prepare(NULL, NULL, &ctrl->frames);
    }
    ctrl->frames_crc = sp_frames_checksum(&ctrl->frames);
    spi_rate_prepare(ctrl);
    ctrl->ref_keep.valid = 0u; /* the kept orientations belong to the old frames */
    ctrl->target_keep.valid = 0u;
    ctrl->ready_valid = 0u;
    if (sp_frames_from_platform(&ctrl->frames, &cfg->platform->home, &ctrl->tool_home) != SP_OK) {
        st = SP_E_RANGE; /* home's tool pose out of range */
    }
    return st;
}

static int angles_held(const sp_q24_t a[3], const sp_q24_t b[3])
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

static int pose_held(const sp_pose_t *a, const sp_pose_t *b)
{
    return angles_held(a->pos, b->pos) && angles_held(a->rpy, b->rpy);
}

sp_status_t spi_ready_tool_pose(const sp_ctrl_t *ctrl, sp_pose_t *tool_pose)
{
    if (ctrl->ready_valid && pose_held(&ctrl->ready_platform, &ctrl->pos_ref.pose)) {
        *tool_pose = ctrl->ready_tool;
        return SP_OK;
    }
    return sp_frames_from_platform(&ctrl->frames, &ctrl->pos_ref.pose, tool_pose);
}

/* spi_ready_tool_pose, kept in ctrl->ready_tool for the ticks the
 * reference's pose holds (at rest). */
static sp_status_t ready_tool_keep(sp_ctrl_t *ctrl, sp_pose_t *tool_pose)
{
    sp_status_t st = SP_OK;
    if (!ctrl->ready_valid || !pose_held(&ctrl->ready_platform, &ctrl->pos_ref.pose)) {
        st = sp_frames_from_platform(&ctrl->frames, &ctrl->pos_ref.pose, &ctrl->ready_tool);
        ctrl->ready_platform = ctrl->pos_ref.pose;
        ctrl->ready_valid = (uint8_t)(st == SP_OK);
    }
    *tool_pose = ctrl->ready_tool;
    return st;
}

/* The slots from the config, the active frames, no refusals. */
static sp_status_t reset_frames(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    unsigned k;
    ctrl->slots = cfg->frames;
    for (k = 0u; k < SP_REFUSE_COUNT; ++k) {
        ctrl->refusals[k] = 0u;
    }
    ctrl->last_refusal = (uint8_t)SP_REFUSE_NONE;
    ctrl->refusing = (uint8_t)SP_REFUSE_NONE;
    sp_motion_at_rest(&ctrl->tool_ref, &cfg->platform->park);
    ctrl->stream_platform = cfg->platform->home;
    return activate_frames(cfg, ctrl);
}

void sp_ctrl_count_refusal(sp_ctrl_t *ctrl, uint8_t why)
{
    unsigned w = (unsigned)why;
    if (ctrl == NULL || w >= SP_REFUSE_COUNT || w == 0u) {
        return;
    }
    if (ctrl->refusals[w] < UINT16_MAX) {
        ++ctrl->refusals[w];
    }
    ctrl->last_refusal = (uint8_t)w;
}

sp_status_t sp_ctrl_tool_pose(const sp_ctrl_t *ctrl, const sp_pose_t *platform, sp_pose_t *tool_pose)
{
    if (ctrl == NULL) {
        return SP_E_ARG;
    }
    return sp_frames_from_platform(&ctrl->frames, platform, tool_pose);
}

sp_status_t sp_ctrl_init(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg)
{
    sp_status_t st;
    if (ctrl == NULL || cfg == NULL || cfg->platform == NULL || cfg->feedback_divider > 255u ||
        cfg->tick_us > UINT32_MAX / 255u) {
        return SP_E_ARG;
    }
    st = prepare(ctrl, cfg);
    if (st != SP_OK) {
        return st;
    }
    reset_estimate(ctrl, cfg);
    reset_motion(ctrl, cfg->platform);
    return (reset_frames(cfg, ctrl) == SP_OK) ? SP_OK : SP_E_ARG;
}

/* ---- faults ------------------------------------------------------------ */

/* The reaction to a fault: park when only the reference was at fault (the
 * feedback and the drives are trustworthy), otherwise hold. */
static void raise_fault(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, uint32_t fault)
{
    uint32_t before = ctrl->faults;
    ctrl->faults |= fault;
    if (ctrl->state == SP_STATE_STOPPING) {
        spi_estop_fault(ctrl, fault); /* the controlled stop cannot go on: category 0 */
        return;
    }
    if (ctrl->state == SP_STATE_ESTOP || (before != 0u && ctrl->state == SP_STATE_FAULT && ctrl->faults == before)) {
        return;
    }
    ctrl->state = (fault == SP_FAULT_ESTOP) ? SP_STATE_ESTOP : SP_STATE_FAULT;
    ctrl->move.duration_ticks = 0u;
    ctrl->move.tick = 0u;
    if (ctrl->faults == SP_FAULT_REFERENCE && ctrl->est.valid) {
        /* controlled park from where the platform is commanded to be */
        ctrl->busy = 1u;
        if (spi_move_plan_legs(cfg, ctrl, &ctrl->reference.pose, &cfg->platform->park) != SP_OK) {
            ctrl->move.duration_ticks = 0u;
        }
    }
}

static int park_reaction_active(const sp_ctrl_t *ctrl)
{
    return ctrl->state == SP_STATE_FAULT && ctrl->faults == SP_FAULT_REFERENCE && ctrl->move.duration_ticks > 0u;
}

/* Are the drives following the setpoints (ACTIVE)? */
static int drives_active(const sp_ctrl_t *ctrl)
{
    return ctrl->state == SP_STATE_ENGAGING || ctrl->state == SP_STATE_READY || ctrl->state == SP_STATE_RUNNING ||
           ctrl->state == SP_STATE_PARKING || ctrl->state == SP_STATE_STOPPING || park_reaction_active(ctrl);
}

/* ---- 1. feedback supervision --------------------------------------------- */

/* Takes the drives' feedback: per leg the ticks since its last frame and its
 * last length; a silent or faulty drive is a fault while the drives are
 * active (`active`, the drive state at the start of the tick). Returns
 * whether every drive is heard from (comms ok); *leg_out becomes 1 when a
 * last measured length lies outside its stroke, *heard 1 when any drive's
 * feedback is fresh this tick. */
static int supervise(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in, int active, int *leg_out,
                     int *heard)
{
    sp_supervision_t *sup = &ctrl->sup;
    const sp_limits_t *lim = &ctrl->prep.limits;
    uint32_t seen = sup->seen_mask;
    uint32_t no_force = sup->no_force_mask;
    uint32_t timeout = cfg->feedback_timeout_ticks;
    int comms_ok = 1;
    int drive_fault = 0;
    int out = 0;
    int fresh = 0;
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_drive_feedback_t *fb = &in->drive[i];
        uint32_t missed = sup->missed[i];
        if (fb->fresh) {
            fresh = 1;
            missed = 0u;
            seen |= UINT32_C(1) << i;
            sup->last_length[i] = fb->length;
            sup->last_force[i] = fb->force;
            no_force = (no_force & ~(UINT32_C(1) << i)) | ((uint32_t)(fb->no_force & 1u) << i);
            sup->last_faults[i] = fb->faults;
            drive_fault |= (fb->faults != 0u) ? 1 : 0;
        } else if (missed < UINT32_MAX) {
            ++missed;
        }
        sup->missed[i] = missed;
        comms_ok &= (missed < timeout) ? 1 : 0;
        out |= sp_limits_measured_out(lim, sup->last_length[i]);
    }
    sup->seen_mask = seen;
    sup->no_force_mask = no_force;
    if (seen != SP_ALL_LEGS) {
        comms_ok = 0; /* a drive never heard from */
    }
    if (active && !comms_ok) {
        raise_fault(cfg, ctrl, SP_FAULT_FEEDBACK_TIMEOUT);
    }
    if (active && drive_fault) {
        raise_fault(cfg, ctrl, SP_FAULT_DRIVE);
    }
    *leg_out = out;
    *heard = fresh;
    return comms_ok;
}

/* ---- 2. pose estimate ---------------------------------------------------- */

/* The estimate from the measured lengths, once every drive has been heard
 * from; a failed estimate or a leg outside its stroke is a fault while the
 * drives are active (`active` as in supervise). A tick without any fresh
 * length (`heard` 0: drives that answer once per SYNC period of a CANopen
 * layout, between their answers) takes no step: a valid estimate moves by
 * the reference's change since it was made (est_ref), so that the last
 * measured tracking error is kept until the next answer. A step from the
 * moved reference to the old lengths would find the old pose again, and
 * the estimate would stand still between answers and jump at each: a
 * tracking error growing and collapsing every SYNC period, whose second
 * difference the wrench estimate's motion correction takes as
 * acceleration. The angles add as numbers (no wrap: the platform's are
 * far from +-pi). Returns the FK's steps (0 on such a tick). */
/* Out of line, as the wrench job: off sp_ctrl_step's frame. */
/* The estimate moved by the reference's change since est_ref (saturating:
 * the poses are within their Q24 range, the sums of valid poses' small
 * differences stay there), and est_ref to the reference. */
static void follow_reference(sp_ctrl_t *ctrl)
{
    sp_flags_t flags = 0u; /* a saturated sum is held: the next answer replaces it */
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        ctrl->est.pose.pos[k] = spi_add(ctrl->est.pose.pos[k],
                                        spi_sub_sat(ctrl->reference.pose.pos[k], ctrl->est_ref.pos[k], &flags), &flags);
        ctrl->est.pose.rpy[k] = spi_add(ctrl->est.pose.rpy[k],
                                        spi_sub_sat(ctrl->reference.pose.rpy[k], ctrl->est_ref.rpy[k], &flags), &flags);
    }
    ctrl->est_ref = ctrl->reference.pose;
}

SPI_NOINLINE static uint32_t estimate(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, int active, int leg_out, int heard)
{
    uint32_t iterations = 0u;
    if (ctrl->sup.seen_mask != SP_ALL_LEGS) {
        return 0u;
    }
    if (!heard && ctrl->est.valid) {
        if (ctrl->est_ref_valid && ctrl->have_setpoint) {
            follow_reference(ctrl);
        }
    } else {
        /* ctrl->model.ref is the IK of ctrl->model_pose while est.ref_lu
         * is valid (both written by the last successful sp_setpoints_of) */
        if (sp_estimate_step(cfg->platform, &ctrl->est, ctrl->sup.last_length, &ctrl->model_pose, &ctrl->model.ref,
                             &iterations) != SP_OK &&
            active) {
            raise_fault(cfg, ctrl, SP_FAULT_FK);
        }
        ctrl->est_ref = ctrl->reference.pose;
        ctrl->est_ref_valid = ctrl->have_setpoint;
    }
    if (active && leg_out) {
        raise_fault(cfg, ctrl, SP_FAULT_LEG_LIMIT);
    }
    return iterations;
}

/* ---- 3. the operator's command -------------------------------------------- */

static int start_move(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *from, const sp_pose_t *to)
{
    ctrl->busy = 1u; /* the plan's cost: this tick's model work waits */
    return spi_move_plan_legs(cfg, ctrl, from, to) == SP_OK;
}

/* ENGAGE and RESET move to home from where the platform stands. A platform
 * resting just outside the workspace box (parked on its boundary and
 * sagging under a load the config does not know, a few tens of um) starts
 * from the nearest pose of the box: on each axis outside the box by at most
 * SP_CTRL_ENGAGE_TOL the start is the box's bound, a setpoint step of at
 * most that much. Farther out the start stays the estimate, and the move's
 * first reference leaves the limits (SP_FAULT_REFERENCE) as it always did:
 * no jump of millimetres at engage. */
#define SP_CTRL_ENGAGE_TOL 8389 /* Q24: 0.5 mm, 0.5 mrad */

static sp_q24_t into_box(sp_q24_t v, sp_q24_t lo, sp_q24_t hi)
{
    if (v < lo && (int64_t)lo - v <= SP_CTRL_ENGAGE_TOL) {
        return lo;
    }
    if (v > hi && (int64_t)v - hi <= SP_CTRL_ENGAGE_TOL) {
        return hi;
    }
    return v;
}

static int start_engage(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    const sp_limits_t *lim = &ctrl->prep.limits;
    sp_pose_t from = ctrl->est.pose;
    unsigned a;
    for (a = 0u; a < 3u; ++a) {
        from.pos[a] = into_box(from.pos[a], lim->ws_lo[a], lim->ws_hi[a]);
        from.rpy[a] = into_box(from.rpy[a], lim->ws_lo[3u + a], lim->ws_hi[3u + a]);
    }
    return start_move(cfg, ctrl, &from, &cfg->platform->home);
}

static void start_running(sp_ctrl_t *ctrl, sp_motion_mode_t mode)
{
    ctrl->mode = mode;
    ctrl->park_after = 0u;
    ctrl->state = SP_STATE_RUNNING;
}

/* Is a motion's end reachable (sp_limits_pose_reachable's verdict)? From
 * the model's reference (model_pose), whose IK lengths ctrl->model.ref
 * keeps while its factorisation is valid: an end near it needs no IK. */
static int end_reachable(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_pose_t *end)
{
    int known = ctrl->est.ref_lu.valid && ctrl->have_setpoint;
    return sp_limits_pose_reachable_from(&ctrl->prep.limits, cfg->platform, &ctrl->model_pose,
                                         known ? ctrl->model.ref.length : NULL, end);
}

/* The one reachability check of a tool pose (T in W) that MOVE_TO,
 * RUN_TRIG and the reach query share: *pp becomes the platform's pose for
 * it, and the verdict is sp_limits_pose_reachable's (end_reachable: the
 * same bit for bit). 1 reachable, 0 not, -1 when the transform failed. */
static int tool_reachable(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_pose_t *tool, sp_pose_t *pp)
{
    if (sp_frames_to_platform(&ctrl->frames, tool, pp, NULL) != SP_OK) {
        return -1;
    }
    return end_reachable(cfg, ctrl, pp);
}

/* The first limit the platform pose r->platform breaks (the workspace box
 * in axis order, then the legs in order), and the forces at rest there. */
static void reach_detail(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, sp_reach_t *r)
{
    const sp_limits_t *lim = &ctrl->prep.limits;
    const sp_pose_t *p = &r->platform;
    static const sp_q8_t no_ext[3] = {0, 0, 0};
    sp_ik_t ik;
    sp_motion_t rest;
    sp_flags_t flags = 0u;
    unsigned a;
    for (a = 0u; a < 6u && r->verdict == (uint8_t)SP_REACH_OK; ++a) {
        int32_t v = (a < 3u) ? p->pos[a] : p->rpy[a - 3u];
        if (v < lim->ws_lo[a] || v > lim->ws_hi[a]) {
            r->verdict = (uint8_t)SP_REACH_WORKSPACE;
            r->which = (uint8_t)a;
            r->excess = spi_sat((v < lim->ws_lo[a]) ? (int64_t)lim->ws_lo[a] - v : (int64_t)v - lim->ws_hi[a], &flags);
        }
    }
    if (sp_inverse_kinematics(cfg->platform, p, &ik) != SP_OK) {
        r->verdict = (uint8_t)((r->verdict == (uint8_t)SP_REACH_OK) ? SP_REACH_COMPUTE : r->verdict);
        return;
    }
    for (a = 0u; a < SP_LEGS && r->verdict == (uint8_t)SP_REACH_OK; ++a) {
        if (ik.length[a] < lim->length_min || ik.length[a] > lim->length_max) {
            int shortl = ik.length[a] < lim->length_min;
            r->verdict = (uint8_t)(shortl ? SP_REACH_LEG_SHORT : SP_REACH_LEG_LONG);
            r->which = (uint8_t)a;
            r->excess = spi_sat(
                shortl ? (int64_t)lim->length_min - ik.length[a] : (int64_t)ik.length[a] - lim->length_max, &flags);
        }
    }
    sp_motion_at_rest(&rest, p);
    if (sp_inverse_dynamics(cfg->platform, &rest, &ik, no_ext, r->force) != SP_OK) {
        for (a = 0u; a < SP_LEGS; ++a) {
            r->force[a] = 0;
        }
    }
}

/* MOVE_TO's path check (spi_cmd_check) for the reach query; out of line, so
 * that its command does not add to the stack of the query's dynamics. */
SPI_NOINLINE static int path_reachable(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_pose_t *tool_pose)
{
    sp_ctrl_cmd_t move;
    memset(&move, 0, sizeof move);
    move.type = SP_CMD_MOVE_TO;
    move.target = *tool_pose;
    return spi_cmd_check(cfg, ctrl, &move) == (uint8_t)SP_REFUSE_NONE;
}

sp_status_t sp_ctrl_reach(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_pose_t *tool_pose,
                          sp_reach_t *reach)
{
    unsigned a;
    int ok;
    if (cfg == NULL || ctrl == NULL || tool_pose == NULL || reach == NULL || cfg->platform == NULL) {
        return SP_E_ARG;
    }
    sp_reach_verdict_t none = SP_REACH_OK;
    reach->verdict = (uint8_t)none;
    reach->which = 0u;
    reach->excess = 0;
    for (a = 0u; a < SP_LEGS; ++a) {
        reach->force[a] = 0;
    }
    ok = tool_reachable(cfg, ctrl, tool_pose, &reach->platform);
    if (ok < 0) {
        reach->verdict = (uint8_t)SP_REACH_COMPUTE;
        reach->platform = *tool_pose;
        return SP_OK;
    }
    reach_detail(cfg, ctrl, reach);
    if (ok) {
        /* the shared checks decide: the end's, then the path's (spi_cmd_check, READY only) */
        reach->verdict = (uint8_t)(path_reachable(cfg, ctrl, tool_pose) ? SP_REACH_OK : SP_REACH_PATH);
        reach->which = 0u;
        reach->excess = 0;
    } else if (reach->verdict == (uint8_t)SP_REACH_OK) {
        reach->verdict = (uint8_t)SP_REACH_COMPUTE;
    }
    return SP_OK;
}

/* A refusal's reason for this tick's count (sp_ctrl_step); returns 0. */
static int refuse(sp_ctrl_t *ctrl, uint8_t why)
{
    ctrl->refusing = why;
    return 0;
}

/* MOVE_TO from READY: to a reachable tool pose, in the tool's space when
 * frames are set (the tool point moves on a straight line in W). */
SPI_NOINLINE static int command_move(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    sp_pose_t pp;
    sp_pose_t from;
    if (ctrl->state != SP_STATE_READY) {
        return 0;
    }
    if (ctrl->frames.identity) {
        if (!end_reachable(cfg, ctrl, &cmd->target)) {
            return refuse(ctrl, (uint8_t)SP_REFUSE_REACH);
        }
        from = ctrl->pos_ref.pose;
    } else {
        /* force control off: spi_cmd_check has checked the end (and the
         * path) on this tick already, the same check */
        if (ctrl->force.mode != SP_FORCE_OFF && tool_reachable(cfg, ctrl, &cmd->target, &pp) != 1) {
            return refuse(ctrl, (uint8_t)SP_REFUSE_REACH);
        }
        if (ready_tool_keep(ctrl, &from) != SP_OK) {
            return 0;
        }
    }
    if (!start_move(cfg, ctrl, &from, &cmd->target)) {
        return 0;
    }
    start_running(ctrl, SP_MODE_MOVE);
    return 1;
}

/* RUN_TRIG from READY: both ends of the motion must be reachable. */
/* The trig motion runs about home and its first sample is home at rest:
 * from a reference elsewhere (READY after a MOVE_TO) it would be a step
 * of the setpoints. RUN_TRIG needs the last reference within
 * SP_CTRL_TRIG_HOME_TOL of home on every axis (refused otherwise: move
 * home first). */
#define SP_CTRL_TRIG_HOME_TOL 168 /* Q24: 10 um, 10 urad */

static int at_home(const sp_pose_t *pose, const sp_pose_t *home)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (spi_farther(pose->pos[k], home->pos[k], SP_CTRL_TRIG_HOME_TOL) ||
            spi_farther(pose->rpy[k], home->rpy[k], SP_CTRL_TRIG_HOME_TOL)) {
            return 0;
        }
    }
    return 1;
}

SPI_NOINLINE static int command_run_trig(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    const sp_platform_t *p = cfg->platform;
    /* about home's tool pose: about the pivot when a tool frame is set */
    const sp_pose_t *centre = ctrl->frames.identity ? &p->home : &ctrl->tool_home;
    sp_pose_t lo = *centre;
    sp_pose_t hi = *centre;
    sp_pose_t pp;
    unsigned a = (unsigned)cmd->axis;
    sp_q24_t *l;
    sp_q24_t *h;
    if (ctrl->state != SP_STATE_READY || a >= SP_AXIS_COUNT || !at_home(&ctrl->reference.pose, &p->home)) {
        return 0;
    }
    l = (a < 3u) ? &lo.pos[a] : &lo.rpy[a - 3u];
    h = (a < 3u) ? &hi.pos[a] : &hi.rpy[a - 3u];
    *l = sp_sub(*l, cmd->amplitude, NULL);
    *h = sp_add(*h, cmd->amplitude, NULL);
    /* both ends: spi_cmd_check's trig_ends checked them on this tick (READY,
     * force control off: RUN_TRIG's only case), the same check; identity
     * frames check them here again as ever (bit for bit the same tick) */
    if (ctrl->frames.identity &&
        (tool_reachable(cfg, ctrl, &lo, &pp) != 1 || tool_reachable(cfg, ctrl, &hi, &pp) != 1)) {
        return refuse(ctrl, (uint8_t)SP_REFUSE_REACH);
    }
    if (sp_trig_start(&ctrl->trig, centre, cmd->axis, cmd->amplitude, cmd->frequency, cfg->tick_us,
                      cmd->fade_ticks ? cmd->fade_ticks : cfg->fade_ticks) != SP_OK) {
        return 0;
    }
    start_running(ctrl, SP_MODE_TRIG);
    return 1;
}

/* STOP and PARK: a running motion ends smoothly (and then parks on PARK);
 * from READY or ENGAGING, PARK parks. */
static int command_stop(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_cmd_type_t type)
{
    const sp_platform_t *p = cfg->platform;
    if (ctrl->state == SP_STATE_RUNNING) {
        ctrl->park_after = (type == SP_CMD_PARK) ? 1u : ctrl->park_after;
        if (ctrl->mode == SP_MODE_TRIG) {
            sp_trig_stop(&ctrl->trig);
        } else if (ctrl->mode == SP_MODE_STREAM) {
            /* settle back to home (its tool pose with frames), then end */
            sp_stream_stop(&ctrl->stream, ctrl->frames.identity ? &p->home : &ctrl->tool_home);
        }
        return 1;
    }
    if (type == SP_CMD_PARK && (ctrl->state == SP_STATE_READY || ctrl->state == SP_STATE_ENGAGING) &&
        start_move(cfg, ctrl, &ctrl->pos_ref.pose, &p->park)) {
        ctrl->state = SP_STATE_PARKING;
        return 1;
    }
    return 0;
}

/* The wrench force control would use this tick, NULL when its source is
 * not valid: the cylinders' estimate (less its bias at rest once tared:
 * before, the bias is 0 and the estimate is read as it is), or the tared
 * sensor's. */
static const int32_t *force_wrench(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl)
{
    if (cfg->wrench_source == SP_WRENCH_SENSOR) {
        return ctrl->ft_valid ? ctrl->ft_section[SP_WRENCH_SECTIONS - 1u] : NULL;
    }
    if (!ctrl->wrench.valid) {
        return NULL;
    }
    return ctrl->cyl_tare.tared ? ctrl->cyl_wrench : ctrl->wrench.wrench;
}

/* The cylinders' estimate less its bias (wrench_source CYLINDERS): a TARE
 * averages ft_tare_samples ticks of the estimate at rest into the bias, as
 * it does the sensor's readings. Until a tare has completed the bias is 0
 * (sp_ft_tare_reset; sp_ft_tare_start keeps it) and force_wrench reads the
 * estimate itself: no difference to take. After, outside a tare, the
 * difference is taken here, without sp_ft_tare_step's saturation, which
 * cannot act: the estimate lies within [-2^30, 2^30 - 1] (the wrench
 * filter's range, sp/estimation/wrench.h) and so does the bias (a rounded mean of
 * estimates), so their difference lies within +-(2^31 - 1), an int32 (the
 * same value, bit for bit; test_controller's tare test compares the
 * two). */
static void cylinder_wrench(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    unsigned k;
    if (cfg->wrench_source == SP_WRENCH_SENSOR || !ctrl->wrench.valid) {
        return;
    }
    if (ctrl->cyl_tare.needed != 0u) {
        (void)sp_ft_tare_step(&ctrl->cyl_tare, ctrl->wrench.wrench,
                              ctrl->cyl_wrench); /* its sums, its bias when done */
        return;
    }
    if (ctrl->cyl_tare.tared) {
        for (k = 0u; k < 6u; ++k) {
            ctrl->cyl_wrench[k] = ctrl->wrench.wrench[k] - ctrl->cyl_tare.bias[k];
        }
    }
}

/* FORCE, GUIDE (READY or RUNNING, with a valid wrench and pose; the
 * sensor tared), POSITION (leaves force control; nothing to leave is no
 * error) and TARE (READY in position control: the sensor's bias, or the
 * cylinders' estimate's bias at rest). */
static int command_force(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    int engaged = ctrl->state == SP_STATE_READY || ctrl->state == SP_STATE_RUNNING;
    switch (cmd->type) {
    case SP_CMD_FORCE:
    case SP_CMD_GUIDE:
        if (!engaged || !ctrl->est.valid || force_wrench(cfg, ctrl) == NULL ||
            (cfg->wrench_source == SP_WRENCH_SENSOR && !ctrl->ft_tare.tared)) {
            return 0;
        }
        return sp_force_start(&ctrl->prep.force, &ctrl->force,
                              (cmd->type == SP_CMD_FORCE) ? SP_FORCE_FORCE : SP_FORCE_GUIDE, cmd->force_mask,
                              cmd->force_target) == SP_OK;
    case SP_CMD_POSITION:
        return sp_force_release(&ctrl->force) == SP_OK;
    default: /* SP_CMD_TARE */
        if (ctrl->state != SP_STATE_READY || ctrl->force.mode != SP_FORCE_OFF) {
            return 0;
        }
        if (cfg->wrench_source != SP_WRENCH_SENSOR) {
            return ctrl->wrench.valid && sp_ft_tare_start(&ctrl->cyl_tare, cfg->ft_tare_samples) == SP_OK;
        }
        if (ctrl->ft_missed >= cfg->ft_timeout_ticks) {
            return 0;
        }
        return sp_ft_tare_start(&ctrl->ft_tare, cfg->ft_tare_samples) == SP_OK;
    }
}

/* The OR of the drives' last reported fault bits (low 8: the DBC's Faults);
 * *legs (if not NULL) gets the drives reporting any (bit i: leg i). */
static uint32_t drive_faults(const sp_ctrl_t *ctrl, uint32_t *legs)
{
    uint32_t bits = 0u;
    uint32_t mask = 0u;
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        if (ctrl->sup.last_faults[i] != 0u) {
            bits |= ctrl->sup.last_faults[i];
            mask |= UINT32_C(1) << i;
        }
    }
    if (legs != NULL) {
        *legs = mask;
    }
    return bits;
}

/* RESET's end: faults cleared, the engage move to home from the estimate.
 * Returns 0 (nothing changed) without every drive heard or an estimate. */
static int finish_reset(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, int comms_ok)
{
    if (!comms_ok || !ctrl->est.valid || !start_engage(cfg, ctrl)) {
        return 0;
    }
    ctrl->faults = 0u;
    spi_estop_clear(ctrl);
    ctrl->state = SP_STATE_ENGAGING;
    return 1;
}

/* A RESET waiting for the drives: done once none reports a fault (then the
 * controller's faults clear as RESET does), refused once drive_reset_ticks
 * have passed (the legs and their bits kept for the status). */
static void drive_reset_job(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, int comms_ok)
{
    sp_drive_reset_t *r = &ctrl->drive_reset;
    uint32_t legs = 0u;
    uint32_t bits;
    r->edge = 0u;
    if (r->left == 0u) {
        return;
    }
    if (ctrl->state != SP_STATE_FAULT && ctrl->state != SP_STATE_ESTOP) {
        r->left = 0u;
        return;
    }
    bits = drive_faults(ctrl, &legs);
    if (bits == 0u && finish_reset(cfg, ctrl, comms_ok)) {
        r->left = 0u;
        return;
    }
    --r->left;
    if (r->left == 0u) {
        r->refused_legs = (uint8_t)legs;
        r->refused_cause = (uint8_t)(bits & 0xFFu);
    }
}

/* FRAME: select a defined slot, or set one (and make it active), at rest
 * only (IDLE, or READY in position control): nothing moves, the reference
 * stays the platform's; from then on commands speak of the new frames. */
SPI_NOINLINE static int command_frame(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd)
{
    sp_frame_slots_t *sl = &ctrl->slots;
    sp_frame_slots_t before = *sl;
    unsigned i = cmd->frame_index;
    int tool = cmd->frame_kind == SP_FRAME_TOOL;
    sp_frames_t probe;
    if ((ctrl->state != SP_STATE_IDLE && ctrl->state != SP_STATE_READY) || ctrl->force.mode != SP_FORCE_OFF) {
        return refuse(ctrl, (uint8_t)SP_REFUSE_STATE);
    }
    if (i >= SP_FRAME_SLOTS || (cmd->frame_kind != SP_FRAME_TOOL && cmd->frame_kind != SP_FRAME_WORK) ||
        (cmd->frame_op != SP_FRAME_SELECT && cmd->frame_op != SP_FRAME_SET)) {
        return refuse(ctrl, (uint8_t)SP_REFUSE_EMPTY_SLOT);
    }
    if (cmd->frame_op == SP_FRAME_SELECT) {
        if (((tool ? sl->tool_used : sl->work_used) & (1u << i)) == 0u) {
            return refuse(ctrl, (uint8_t)SP_REFUSE_EMPTY_SLOT);
        }
    } else {
        if (sp_frames_prepare(tool ? &cmd->frame_value : NULL, tool ? NULL : &cmd->frame_value, &probe) != SP_OK) {
            return refuse(ctrl, (uint8_t)SP_REFUSE_BAD_FRAME);
        }
        if (tool) {
            sl->tool[i] = cmd->frame_value;
            sl->tool_used = (uint8_t)(sl->tool_used | (1u << i));
        } else {
            sl->work[i] = cmd->frame_value;
            sl->work_used = (uint8_t)(sl->work_used | (1u << i));
        }
    }
    if (tool) {
        sl->tool_active = (uint8_t)i;
    } else {
        sl->work_active = (uint8_t)i;
    }
    if (activate_frames(cfg, ctrl) != SP_OK) {
        *sl = before; /* home's tool pose out of range with them: the old frames stay */
        (void)activate_frames(cfg, ctrl);
        return refuse(ctrl, (uint8_t)SP_REFUSE_BAD_FRAME);
    }
    return 1;
}

/* Carries out the operator's command when the state allows it; returns 0
 * when it is refused (the state unchanged). */
SPI_NOINLINE static int command(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd, int comms_ok)
{
    switch (cmd->type) {
    case SP_CMD_NONE:
        return 1;
    case SP_CMD_ESTOP:
        spi_estop_take(cfg, ctrl, drives_active(ctrl), comms_ok); /* controlled or immediate (estop.c) */
        return 1;
    case SP_CMD_ENGAGE:
        if (ctrl->state != SP_STATE_IDLE || !comms_ok || !ctrl->est.valid || !start_engage(cfg, ctrl)) {
            return 0;
        }
        ctrl->state = SP_STATE_ENGAGING;
        return 1;
    case SP_CMD_RUN_TRIG:
        return ctrl->force.mode == SP_FORCE_OFF && command_run_trig(cfg, ctrl, cmd);
    case SP_CMD_MOVE_TO:
        return command_move(cfg, ctrl, cmd);
    case SP_CMD_STREAM:
        if (ctrl->state != SP_STATE_READY) {
            return 0;
        }
        if (ctrl->frames.identity) {
            sp_stream_start(&ctrl->stream, &ctrl->pos_ref);
        } else {
            sp_motion_t from;
            if (sp_frames_from_platform(&ctrl->frames, &ctrl->pos_ref.pose, &from.pose) != SP_OK) {
                return 0;
            }
            sp_motion_at_rest(&from, &from.pose);
            sp_stream_start(&ctrl->stream, &from);
            ctrl->stream_platform = ctrl->pos_ref.pose;
        }
        start_running(ctrl, SP_MODE_STREAM);
        return 1;
    case SP_CMD_FRAME:
        return command_frame(cfg, ctrl, cmd);
    case SP_CMD_STOP:
        return command_stop(cfg, ctrl, cmd->type);
    case SP_CMD_PARK:
        if (ctrl->force.mode != SP_FORCE_OFF) {
            /* leave force control first, then park (never refused) */
            (void)sp_force_release(&ctrl->force);
            ctrl->park_after_release = 1u;
            return 1;
        }
        return command_stop(cfg, ctrl, cmd->type);
    case SP_CMD_FORCE:
    case SP_CMD_GUIDE:
    case SP_CMD_POSITION:
    case SP_CMD_TARE:
        return command_force(cfg, ctrl, cmd);
    case SP_CMD_FORCE_PARAMS:
        /* position control only (sp_force_set_params refuses otherwise) */
        return sp_force_set_params(&ctrl->prep.force, &ctrl->force, (sp_force_mode_t)cmd->force_params_mode,
                                   cmd->force_mask, cmd->force_params_mass, cmd->force_params_damping,
                                   cmd->force_params_stiffness) == SP_OK;
    case SP_CMD_RESET:
        if (ctrl->state != SP_STATE_FAULT && ctrl->state != SP_STATE_ESTOP) {
            return 0;
        }
        ctrl->drive_reset.refused_legs = 0u;
        ctrl->drive_reset.refused_cause = 0u;
        if (drive_faults(ctrl, NULL) != 0u) {
            /* the drives first: the fault-reset edge, then wait for them */
            ctrl->drive_reset.edge = 1u;
            ctrl->drive_reset.left = (cfg->drive_reset_ticks > 0u) ? cfg->drive_reset_ticks : 1u;
            return 1;
        }
        return finish_reset(cfg, ctrl, comms_ok);
    default:
        return 0;
    }
}

/* A streamed tool target (frames set): its platform pose is offered to
 * the filter's check (sp_stream_offer, with the platform pose of the
 * target in force as the filter's target meanwhile), and on success the
 * tool pose becomes the filter's target. */
static int take_tool_target(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *target, int known)
{
    sp_pose_t pp;
    sp_pose_t tool_target = ctrl->stream.target;
    if (ctrl->stream.stopping || sp_frames_to_platform_kept(&ctrl->frames, &ctrl->target_keep, target, &pp) != SP_OK) {
        return refuse(ctrl, (uint8_t)SP_REFUSE_REACH);
    }
    ctrl->stream.target = ctrl->stream_platform;
    if (!sp_stream_offer(&ctrl->stream, &ctrl->prep.limits, cfg->platform, &pp, &ctrl->model_pose,
                         known ? ctrl->model.ref.length : NULL)) {
        ctrl->stream.target = tool_target;
        return refuse(ctrl, (uint8_t)SP_REFUSE_REACH);
    }
    ctrl->stream_platform = pp;
    ctrl->stream.target = *target;
    return 1;
}

/* A streamed target while streaming: taken when reachable (sp_stream_offer,
 * with the last reference's leg lengths, its IK as the setpoint path kept
 * it in ctrl->model.ref, known while its factorisation is valid). Returns
 * 0 when it is refused. */
static int take_stream_target(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *target)
{
    int known = ctrl->est.ref_lu.valid && ctrl->have_setpoint;
    if (ctrl->frames.identity) {
        return sp_stream_offer(&ctrl->stream, &ctrl->prep.limits, cfg->platform, target, &ctrl->model_pose,
                               known ? ctrl->model.ref.length : NULL)
                   ? 1
                   : refuse(ctrl, (uint8_t)SP_REFUSE_REACH);
    }
    return take_tool_target(cfg, ctrl, target, known);
}

/* ---- 4. the reference of this tick ---------------------------------------- */

/* A move step into *ref; returns 1 when the move has ended. */
static int move_step(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref, sp_flags_t *flags)
{
    int done = 0;
    *flags |= (sp_move_step(&ctrl->move, cfg->tick_us, ref, &done) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
    return done;
}

/* RUNNING with frames: the motion's next sample as a tool motion
 * (ctrl->tool_ref), turned into the platform's motion *ref; the motion's
 * end returns to READY (a stream's at home, at rest). */
SPI_NOINLINE static void tool_reference(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref,
                                        sp_flags_t *flags)
{
    sp_motion_t *x = &ctrl->tool_ref;
    int done = 0;
    if (ctrl->mode == SP_MODE_TRIG) {
        *flags |= (sp_trig_step(&ctrl->trig, cfg->tick_us, x) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
        done = ctrl->trig.finished;
    } else if (ctrl->mode == SP_MODE_MOVE) {
        done = move_step(cfg, ctrl, x, flags);
    } else {
        spi_stream_limits(cfg, ctrl);
        sp_stream_step(&ctrl->stream, &ctrl->prep.stream, &ctrl->stream_lim, x, flags);
        if (ctrl->stream.stopping && sp_stream_settled(x, &ctrl->tool_home)) {
            sp_motion_at_rest(x, &ctrl->tool_home);
            sp_motion_at_rest(ref, &cfg->platform->home);
            ctrl->state = SP_STATE_READY;
            return;
        }
    }
    *flags |= (sp_frames_motion_to_platform_shared(&ctrl->frames, &ctrl->ref_keep, &ctrl->ref_orient, x, ref) == SP_OK)
                  ? 0u
                  : SP_FLAG_OVERFLOW;
    if (done) {
        ctrl->state = SP_STATE_READY;
    }
}

/* RUNNING: the motion's next sample; the motion's end returns to READY, or
 * starts parking after PARK. */
static void running_reference(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref, sp_flags_t *flags)
{
    const sp_platform_t *p = cfg->platform;
    if (!ctrl->frames.identity) {
        tool_reference(cfg, ctrl, ref, flags); /* out of line: identity frames pay one test */
    } else if (ctrl->mode == SP_MODE_TRIG) {
        *flags |= (sp_trig_step(&ctrl->trig, cfg->tick_us, ref) == SP_OK) ? 0u : SP_FLAG_OVERFLOW;
        if (ctrl->trig.finished) {
            ctrl->state = SP_STATE_READY;
        }
    } else if (ctrl->mode == SP_MODE_MOVE) {
        if (move_step(cfg, ctrl, ref, flags)) {
            ctrl->state = SP_STATE_READY;
        }
    } else {
        spi_stream_limits(cfg, ctrl);
        sp_stream_step(&ctrl->stream, &ctrl->prep.stream, &ctrl->stream_lim, ref, flags);
        if (ctrl->stream.stopping && sp_stream_settled(ref, &p->home)) {
            sp_motion_at_rest(ref, &p->home);
            ctrl->state = SP_STATE_READY;
        }
    }
    if (ctrl->state == SP_STATE_READY && ctrl->park_after) {
        ctrl->park_after = 0u;
        if (start_move(cfg, ctrl, &ref->pose, &p->park)) {
            ctrl->state = SP_STATE_PARKING;
        }
    }
}

/* The position reference of this tick, by state, written in place into
 * ctrl->pos_ref (no copy of the motion a tick). Returns 1 when the drives
 * hold (no motion: IDLE, ESTOP, FAULT without the park reaction). */
static int reference(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_flags_t *flags)
{
    sp_motion_t *ref = &ctrl->pos_ref;
    unsigned k;
    switch (ctrl->state) {
    case SP_STATE_ENGAGING:
    case SP_STATE_PARKING:
        if (move_step(cfg, ctrl, ref, flags)) {
            ctrl->state = (ctrl->state == SP_STATE_ENGAGING) ? SP_STATE_READY : SP_STATE_IDLE;
        }
        return 0;
    case SP_STATE_RUNNING:
        running_reference(cfg, ctrl, ref, flags);
        return 0;
    case SP_STATE_READY:
        /* at rest where the last position reference was (its pose kept) */
        for (k = 0u; k < 3u; ++k) {
            ref->vel[k] = 0;
            ref->rpy_rate[k] = 0;
            ref->acc[k] = 0;
            ref->rpy_acc[k] = 0;
        }
        return 0;
    case SP_STATE_FAULT:
        if (park_reaction_active(ctrl)) {
            if (move_step(cfg, ctrl, ref, flags)) {
                ctrl->move.duration_ticks = 0u; /* parked: hold there, still latched */
            }
            return 0;
        }
        sp_motion_at_rest(ref, &ctrl->reference.pose);
        return 1;
    case SP_STATE_ESTOP:
        sp_motion_at_rest(ref, &ctrl->reference.pose);
        return 1;
    case SP_STATE_STOPPING:
        return spi_estop_reference(cfg, ctrl, ref);
    case SP_STATE_IDLE:
    default:
        sp_motion_at_rest(ref, ctrl->est.valid ? &ctrl->est.pose : &cfg->platform->park);
        return 1;
    }
}

/* ---- 5. setpoints, every limit checked ---------------------------------------------- */

/* *dst = *src (distinct motions), member by member: each member (24 or
 * 12 bytes) is copied in registers, where the whole-struct assignment (72
 * bytes) is a call to memcpy on the M4 (56 instructions of its word loop),
 * twice a tick (the accepted reference, and the output's): 24 a copy.
 * Out of line: inlined into sp_ctrl_step, its registers took 8 bytes more
 * of that frame, on the tick's deepest call chain, and it ran slower. */
SPI_NOINLINE static void copy_motion(sp_motion_t *dst, const sp_motion_t *src)
{
    /* written out: as a loop, GCC makes it a call to memmove again */
    dst->pose = src->pose;
    dst->vel[0] = src->vel[0], dst->vel[1] = src->vel[1], dst->vel[2] = src->vel[2];
    dst->rpy_rate[0] = src->rpy_rate[0], dst->rpy_rate[1] = src->rpy_rate[1], dst->rpy_rate[2] = src->rpy_rate[2];
    dst->acc[0] = src->acc[0], dst->acc[1] = src->acc[1], dst->acc[2] = src->acc[2];
    dst->rpy_acc[0] = src->rpy_acc[0], dst->rpy_acc[1] = src->rpy_acc[1], dst->rpy_acc[2] = src->rpy_acc[2];
}

/* Holding: the drives keep their lengths at rest (IDLE: where they are). */
static void hold_setpoints(sp_ctrl_t *ctrl, const sp_motion_t *ref)
{
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        if (ctrl->state == SP_STATE_IDLE || !ctrl->have_setpoint) {
            ctrl->setpoint[i].length = ctrl->sup.last_length[i];
            ctrl->setpoint[i].force = 0;
        }
        ctrl->setpoint[i].velocity = 0;
    }
    copy_motion(&ctrl->reference, ref);
    ctrl->model_pose = ref->pose;
    ctrl->model_current = 1u;
    ctrl->est.ref_lu.valid = 0u; /* no factorisation at this reference */
}

/* Is motion a the same as motion b, every field? Stops at the first
 * difference, the pose first: a moving reference costs a compare or two. */
static int same_motion(const sp_motion_t *a, const sp_motion_t *b)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (a->pose.pos[k] != b->pose.pos[k] || a->pose.rpy[k] != b->pose.rpy[k]) {
            return 0;
        }
    }
    for (k = 0u; k < 3u; ++k) {
        if (a->vel[k] != b->vel[k] || a->rpy_rate[k] != b->rpy_rate[k] || a->acc[k] != b->acc[k] ||
            a->rpy_acc[k] != b->rpy_acc[k]) {
            return 0;
        }
    }
    return 1;
}

/* Moving: the setpoints of the reference when every limit holds; a reference
 * that fails is never passed on (fault, the last valid lengths held at rest).
 * Returns 1 when ctrl->model is this tick's.
 * sp_setpoints_of is a pure function of the reference, the platform, the
 * prepared limits and friction and ff: a reference equal to the last
 * accepted one, whose setpoints, model and factorisation are still in
 * ctrl (est.ref_lu valid: hold_setpoints and a failed reference clear it),
 * made with the same ff, has them already. READY holds one such reference
 * for as long as it lasts (its first SP_CTRL_LEG_GROUPS ticks complete the
 * legs' terms), and the RUN_TRIG tick starts from it (the trig generator's
 * first sample is the centre at rest). */
static int motion_setpoints(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_motion_t *ref, sp_flags_t flags)
{
    sp_status_t st = SP_E_OVERFLOW;
    unsigned ff = (cfg->force_feedforward ? SP_FF_DYNAMICS : 0u) | (cfg->friction_compensation ? SP_FF_FRICTION : 0u);
    unsigned i;
    int same = ctrl->have_setpoint && ctrl->model_current && same_motion(ref, &ctrl->reference);
    if (flags == 0u && same && ctrl->est.ref_lu.valid && ctrl->setpoint_ff == ff && ctrl->legs_exact == SP_ALL_LEGS &&
        ctrl->legs.lu_age == 0u) {
        return 1;
    }
    if (flags == 0u) {
        /* this tick's group: SP_LEGS / SP_CTRL_LEG_GROUPS consecutive legs
         * (one group: every leg, nothing kept); none on a tick that
         * factorises J^T (due by its age, staged: the two ticks that begin
         * and finish it; or a repeated reference's, below), so that the
         * factorisation and a leg's terms never share a tick: the turn's
         * other SP_CTRL_LU_KEEP - 1 (staged: - 2) ticks refresh the groups */
        unsigned per = SP_LEGS / SP_CTRL_LEG_GROUPS;
        unsigned refresh = 0u;
        /* a tick busy with an operator command or a move's plan (up to
         * ~900 instructions) waits: no group, no factorisation step;
         * once a factorisation at most (sp_leg_hold_t.lu_wait) */
        int wait = ctrl->busy && SP_CTRL_LEG_GROUPS > 1u && !ctrl->legs.lu_waited;
        ctrl->legs.lu_wait = (uint8_t)wait;
        if (same && (ctrl->legs_exact & SP_ALL_LEGS) == SP_ALL_LEGS) {
            /* a repeated reference whose legs the ticks before completed:
             * factorised afresh, refreshing no leg, so that its forces
             * become sp_setpoints_of's (the ticks before refine, as a
             * moving reference's do: one factorisation, not one a tick) */
            ctrl->legs.lu_age = ctrl->legs.lu_keep;
            ctrl->legs.lu_next.begun = 0u;
        }
        if (!wait &&
            (SP_CTRL_LEG_GROUPS == 1u || SP_CTRL_LU_KEEP <= SP_CTRL_LEG_GROUPS || ctrl->legs.held != SP_ALL_LEGS ||
             ctrl->legs.lu_age + SPI_LU_LEAD(CTRL_LU_STAGED) < ctrl->legs.lu_keep)) {
            refresh = ((1u << per) - 1u) << (ctrl->leg_group * per);
            ctrl->leg_group = (uint8_t)((ctrl->leg_group + 1u < SP_CTRL_LEG_GROUPS) ? ctrl->leg_group + 1u : 0u);
        }
        st = sp_setpoints_held(cfg->platform, &ctrl->prep.limits, &ctrl->prep.friction, ref, ff, ctrl->setpoint,
                               &ctrl->est.ref_lu, &ctrl->model, (SP_CTRL_LEG_GROUPS > 1u) ? &ctrl->legs : NULL, refresh,
                               &ctrl->ref_orient);
    }
    if (st == SP_OK) {
        /* the legs whose terms are this reference's: those just computed,
         * and those kept from the same reference */
        unsigned fresh = (SP_CTRL_LEG_GROUPS > 1u) ? ctrl->legs.fresh : SP_ALL_LEGS;
        ctrl->legs_exact = (uint8_t)((same ? ctrl->legs_exact : 0u) | fresh);
        ctrl->have_setpoint = 1u;
        ctrl->setpoint_ff = (uint8_t)ff;
        copy_motion(&ctrl->reference, ref);
        ctrl->model_pose = ref->pose;
        ctrl->model_current = 1u;
        return 1;
    }
    ctrl->est.ref_lu.valid = 0u; /* the reference stays the previous one */
    ctrl->legs.held = 0u;        /* kept terms of a refused reference: none */
    ctrl->legs_exact = 0u;
    raise_fault(cfg, ctrl, (st == SP_E_RANGE) ? SP_FAULT_REFERENCE : SP_FAULT_COMPUTE);
    for (i = 0u; i < SP_LEGS; ++i) {
        ctrl->setpoint[i].velocity = 0;
    }
    sp_motion_at_rest(&ctrl->reference, &ctrl->reference.pose);
    ctrl->model_pose = ctrl->reference.pose;
    ctrl->model_current = 1u;
    return 0;
}

/* A tick whose setpoints nobody sends (setpoints_idle: CANopen drives
 * between SYNCs): the reference advances (the estimate follows it, the
 * divergence check and the report use it), the setpoints and the model
 * stay those of model_pose; the next tick that sends computes them for
 * its own reference. Returns whether the kept model is valid (the wrench
 * estimate's, on a tick with fresh feedback). */
static int idle_setpoints(sp_ctrl_t *ctrl, const sp_motion_t *ref)
{
    if (ctrl->model_current && !same_motion(ref, &ctrl->reference)) {
        ctrl->model_current = 0u;
    }
    copy_motion(&ctrl->reference, ref);
    return (ctrl->have_setpoint && ctrl->est.ref_lu.valid) ? 1 : 0;
}

/* The setpoints of a tick with divided feedback (feedback_divider > 1:
 * CANopen drives that take setpoints and answer once per SYNC period).
 * A tick that sends none keeps them (idle_setpoints), except that the
 * first setpoints after a hold (no factorisation at the reference: every
 * term and the whole factorisation to make, ENGAGE's or RESET's first) are
 * made on a tick that neither sends nor receives; a tick that sends them
 * while they are still to be made holds once (the reference's first
 * sample is at rest where the platform stands: the held lengths) and
 * leaves them to such a tick, so that the costliest setpoints never share
 * a tick with the SYNC's frames or the answers' estimate. A second sending
 * tick in a row makes them. A divider of 2 has no quiet tick: there the
 * first sending tick makes them, while the reference is still at rest
 * (the legs' terms at rest cost a third of a moving reference's, which a
 * held tick would leave to the next sending tick). Returns whether a
 * model of the tick's or a kept reference is valid. */
static int divided_setpoints(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_motion_t *ref, int idle, int heard)
{
    int fresh = ctrl->est.ref_lu.valid;
    if (idle) {
        return (!fresh && !heard) ? motion_setpoints(cfg, ctrl, ref, 0u) : idle_setpoints(ctrl, ref);
    }
    if (!fresh && !ctrl->setpoints_deferred && cfg->feedback_divider > 2u) {
        ctrl->setpoints_deferred = 1u;
        hold_setpoints(ctrl, ref);
        return 0;
    }
    ctrl->setpoints_deferred = 0u;
    return motion_setpoints(cfg, ctrl, ref, 0u);
}

/* ---- 6. the external wrench ------------------------------------------------ */

/* The estimate follows the measurements on ticks with a model of this
 * tick's reference, every drive heard from and every drive measuring its
 * force (a drive without, e.g. CiA 402, gives no cylinder force: the
 * estimate would be the model's forces against zeros); otherwise it is
 * invalid.
 * Out of line: its arrays stay off sp_ctrl_step's frame, which is on the
 * tick's deepest call chain (setpoints -> inverse dynamics). */
SPI_NOINLINE static void wrench(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, int have_model)
{
    int ok = have_model && ctrl->sup.seen_mask == SP_ALL_LEGS && ctrl->sup.no_force_mask == 0u;
    const sp_q8_t *friction = NULL;
    const sp_q8_t *correction = NULL;
    sp_q8_t observed[SP_LEGS];
    sp_q8_t dw[6];
    if (cfg->friction_observer && ctrl->sup.seen_mask == SP_ALL_LEGS) {
        /* the observer follows every measured length, engaged or not; a
         * failure (bad parameters) leaves the feed-forward's friction */
        sp_status_t st = ctrl->prep.fric_obs_ok
                             ? spi_fric_obs_step_checked(cfg->platform, &ctrl->fric_obs, &ctrl->fric_table,
                                                         ctrl->sup.last_length, ctrl->prep.feedback_us, observed)
                             : SP_E_ARG;
        friction = (st == SP_OK || st == SP_E_OVERFLOW) ? observed : NULL;
    }
    if (friction == NULL && cfg->friction_observer) {
        ok = 0; /* the kept model forces exclude friction: no estimate this tick */
    }
    /* the motion-error correction: the rigid body's M6 with the legs'
     * inertia at home (at the reference's sines: est and ref differ by mm,
     * mrad) times the acceleration of
     * estimate - reference, into the filter with the force path's wrench */
    if (ok && ctrl->est.valid) {
        sp_q24_t da[6];
        if (sp_motion_error_step(&ctrl->motion_error, &ctrl->est.pose, &ctrl->model_pose, da) != SP_E_BUSY &&
            sp_motion_error_wrench_m6(&ctrl->prep.motion_body, &ctrl->model.rot, ctrl->model.ref.sc, da, dw) !=
                SP_E_ARG) {
            correction = dw;
        }
    } else {
        sp_motion_error_reset(&ctrl->motion_error);
    }
    sp_wrench_step(&ctrl->wrench, ok ? &ctrl->model : NULL, friction, ctrl->sup.last_force, correction,
                   ctrl->prep.cyl_alpha);
    sp_wrench_smooth(&ctrl->wrench, &ctrl->prep.wrench_smooth);
}

/* ---- force control ----------------------------------------------------------- */

/* The force/torque sensor (wrench_source SENSOR): each reading less the
 * tare's bias, turned into the base frame at the platform's orientation
 * (the reference's, within mrad of the estimate's; the estimate's before
 * a reference exists), through the wrench filter's sections so that force
 * control sees it as it sees the cylinders' estimate. A sensor silent for
 * ft_timeout_ticks is invalid, and a fault while force control uses it. */
SPI_NOINLINE static void ft_sensor(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in)
{
    sp_q8_t tared[6];
    sp_q8_t base[6];
    sp_rot_t rot;
    sp_q30_t sc_est[6];
    const sp_q30_t *sc;
    int same = 1;
    unsigned k;
    unsigned n;
    if (cfg->wrench_source != SP_WRENCH_SENSOR) {
        return;
    }
    if (!in->ft_fresh) {
        if (ctrl->ft_missed < UINT32_MAX) {
            ++ctrl->ft_missed;
        }
        if (ctrl->ft_missed >= cfg->ft_timeout_ticks) {
            ctrl->ft_valid = 0u;
            if (ctrl->force.mode != SP_FORCE_OFF) {
                raise_fault(cfg, ctrl, SP_FAULT_FT_SENSOR);
            }
        }
        return;
    }
    ctrl->ft_missed = 0u;
    if (ctrl->ft_tare.needed != 0u) {
        (void)sp_ft_tare_step(&ctrl->ft_tare, in->ft_reading, tared); /* its sums, and its bias when done */
    }
    /* the sensor's frame (S = T^T R_m, r = T^T pos) changes only when the
     * platform turns: made again only for new sines (sp_ft_to_base's
     * result, bit for bit) */
    if (ctrl->est.ref_lu.valid && ctrl->have_setpoint) {
        sc = ctrl->model.ref.sc;
    } else if (ctrl->ref_orient.valid && ctrl->ref_orient.rpy[0] == ctrl->est.pose.rpy[0] &&
               ctrl->ref_orient.rpy[1] == ctrl->est.pose.rpy[1] && ctrl->ref_orient.rpy[2] == ctrl->est.pose.rpy[2]) {
        sc = ctrl->ref_orient.sc; /* the estimate's sines (before a reference exists), kept for its angles */
    } else {
        for (k = 0u; k < 3u; ++k) { /* the estimate's sines (before a reference exists): T is made below */
            sp_sincos_q24(ctrl->est.pose.rpy[k], &sc_est[2u * k], &sc_est[2u * k + 1u]);
        }
        sc = sc_est;
    }
    for (k = 0u; k < 6u; ++k) {
        same &= (sc[k] == ctrl->ft_frame_sc[k]) ? 1 : 0;
    }
    if (!same || !ctrl->ft_frame_valid) {
        spi_rot_from_sincos(sc, &rot);
        (void)sp_ft_frame(&cfg->ft_mount, &rot, &ctrl->ft_frame); /* saturates, never wraps */
        for (k = 0u; k < 6u; ++k) {
            ctrl->ft_frame_sc[k] = sc[k];
        }
        ctrl->ft_frame_valid = 1u;
    }
    /* the reading less the bias (sp_ft_tare_step's output), turned */
    (void)sp_ft_apply_tared(&ctrl->ft_frame, in->ft_reading, ctrl->ft_tare.bias, base); /* saturates, never wraps */
    for (k = 0u; k < 6u; ++k) {
        /* held within [-2^30, 2^30 - 1] Q8 (4.19 MN, MN m), as the cylinders'
         * estimate: each section's step is then one 32 x 32-bit product */
        int32_t x = (base[k] > SPI_SECTION_HI) ? SPI_SECTION_HI
                                               : ((base[k] < -SPI_SECTION_HI - 1) ? -SPI_SECTION_HI - 1 : base[k]);
        for (n = 0u; n < SP_WRENCH_SECTIONS; ++n) {
            if (ctrl->ft_valid) {
                x = spi_lowpass_section30(ctrl->ft_section[n][k], x, ctrl->prep.wrench_alpha);
            }
            ctrl->ft_section[n][k] = x;
        }
    }
    ctrl->ft_valid = 1u;
}

/* Force control with frames: in the tool's space. The position reference
 * as a tool motion (the generator's while RUNNING one, else the tool pose
 * of the platform's reference, at rest), the wrench at the tool point in
 * W's axes, the estimate's tool pose, and the workspace box moved by the
 * difference between the two poses (exact for frames that do not turn);
 * force control's result becomes the platform's motion *ref, whose limits
 * the setpoints check as always. */
SPI_NOINLINE static void force_step_tool(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref,
                                         uint32_t *events)
{
    const int32_t *w = force_wrench(cfg, ctrl);
    int32_t wt[6];
    sp_motion_t xref;
    sp_motion_t xout;
    sp_pose_t xest;
    sp_limits_t lim = ctrl->prep.limits;
    sp_rot_t rot;
    sp_flags_t flags = 0u;
    unsigned k;
    if (ctrl->state == SP_STATE_RUNNING) {
        xref = ctrl->tool_ref;
    } else {
        (void)ready_tool_keep(ctrl, &xref.pose); /* at rest the reference holds: its tool pose made once */
        sp_motion_at_rest(&xref, &xref.pose);
    }
    for (k = 0u; k < 6u; ++k) {
        int32_t d = (k < 3u) ? spi_sub_sat(xref.pose.pos[k], ctrl->pos_ref.pose.pos[k], &flags)
                             : spi_sub_sat(xref.pose.rpy[k - 3u], ctrl->pos_ref.pose.rpy[k - 3u], &flags);
        lim.ws_lo[k] = spi_add(lim.ws_lo[k], d, &flags);
        lim.ws_hi[k] = spi_add(lim.ws_hi[k], d, &flags);
    }
    if (ctrl->ref_orient.valid && angles_held(ctrl->ref_orient.rpy, ctrl->pos_ref.pose.rpy)) {
        rot = ctrl->ref_orient.rot; /* the IK's T of these angles: sp_orientation's, bit for bit */
    } else {
        (void)sp_orientation(ctrl->pos_ref.pose.rpy, &rot);
    }
    if (w != NULL && sp_frames_wrench_to_tool(&ctrl->frames, &rot, w, wt) == SP_OK) {
        w = wt;
    }
    if (ctrl->est.valid && sp_frames_from_platform(&ctrl->frames, &ctrl->est.pose, &xest) != SP_OK) {
        xest = xref.pose;
    }
    (void)sp_force_step(&ctrl->prep.force, &ctrl->force, &lim, &xref, w, ctrl->est.valid ? &xest : NULL, &xout, events);
    if (sp_frames_motion_to_platform_shared(&ctrl->frames, &ctrl->ref_keep, &ctrl->ref_orient, &xout, ref) != SP_OK) {
        copy_motion(ref, &ctrl->pos_ref); /* the position reference stands */
    }
}

/* Force control over this tick's position reference ctrl->pos_ref (READY,
 * RUNNING): *ref becomes the position reference plus force control's
 * offset, and 1 is returned; 0 when force control made no reference (the
 * position reference stands). A lost contact and a retract after an
 * excessive force latch their faults; a PARK that waited for the release
 * starts the park. */
SPI_NOINLINE static int force_control(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref)
{
    uint32_t events = 0u;
    int made = 0;
    if (ctrl->state != SP_STATE_READY && ctrl->state != SP_STATE_RUNNING) {
        (void)sp_force_reset(&ctrl->force); /* no computation: coefficients kept */
        ctrl->park_after_release = 0u;
        return 0;
    }
    if (ctrl->force.mode != SP_FORCE_OFF && !ctrl->frames.identity) {
        force_step_tool(cfg, ctrl, ref, &events);
        made = 1;
    } else if (ctrl->force.mode != SP_FORCE_OFF) {
        (void)sp_force_step(&ctrl->prep.force, &ctrl->force, &ctrl->prep.limits, &ctrl->pos_ref,
                            force_wrench(cfg, ctrl), ctrl->est.valid ? &ctrl->est.pose : NULL, ref, &events);
        made = 1; /* sp_force_step writes *ref whatever its status */
    }
    if ((events & SP_CONTACT_LOST) != 0u) {
        raise_fault(cfg, ctrl, SP_FAULT_CONTACT_LOST);
    }
    if ((events & SP_FORCE_RETRACTED) != 0u) {
        raise_fault(cfg, ctrl, SP_FAULT_EXCESS_FORCE);
    }
    if (ctrl->park_after_release && ctrl->force.mode == SP_FORCE_OFF) {
        ctrl->park_after_release = 0u;
        (void)command_stop(cfg, ctrl, SP_CMD_PARK);
    }
    return made;
}

/* ---- 7. divergence, 8. outputs -------------------------------------------- */

/* While engaged, an estimate farther from the reference than the config
 * allows on any axis is a fault (a saturated or blocked actuator). */
static void check_divergence(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    const sp_pose_t *e = &ctrl->est.pose;
    const sp_pose_t *r = &ctrl->reference.pose;
    unsigned i;
    if ((ctrl->state != SP_STATE_ENGAGING && ctrl->state != SP_STATE_READY && ctrl->state != SP_STATE_RUNNING &&
         ctrl->state != SP_STATE_PARKING && ctrl->state != SP_STATE_STOPPING) ||
        !ctrl->est.valid) {
        return;
    }
    for (i = 0u; i < 3u; ++i) {
        if (spi_farther(e->pos[i], r->pos[i], cfg->divergence_pos) ||
            spi_farther(e->rpy[i], r->rpy[i], cfg->divergence_rot)) {
            raise_fault(cfg, ctrl, SP_FAULT_DIVERGENCE);
            return;
        }
    }
}

/* In contact under force control the legs carry the push too: with the
 * force feed-forward on, each leg's force setpoint gets its share of the
 * wrench force control holds against on its force-controlled axes (the
 * columns of J^-T, made once per contact from the reference's
 * factorisation, one axis a tick, then six products a tick per axis), so
 * the drives do not have to build the contact force from a position
 * error: on a stiff surface they lagged the reference by tens of um,
 * hundreds of N, for a second. */
SPI_NOINLINE static void contact_ff_prepare(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl)
{
    unsigned k;
    int64_t b[SP_LEGS] = {0, 0, 0, 0, 0, 0}, f[SP_LEGS];
    uint8_t todo = (uint8_t)(ctrl->force.mask & (uint8_t)~ctrl->contact_ff_cols);
    if (!cfg->force_feedforward || !ctrl->prep.force.contact_ff || ctrl->force.mode != SP_FORCE_FORCE ||
        !ctrl->force.contact.made || !ctrl->frames.identity) {
        ctrl->contact_ff_cols = 0u;
        return;
    }
    if (todo == 0u || !ctrl->est.ref_lu.valid) {
        return;
    }
    k = 0u;
    while ((todo & (1u << k)) == 0u) { /* todo != 0: ends below 6 */
        ++k;
    }
    b[k] = INT64_C(1) << 24; /* a unit wrench, Q24 */
    if (sp_lu6_solve(&ctrl->est.ref_lu, b, f) != SP_OK) {
        return;
    }
    for (unsigned i = 0u; i < SP_LEGS; ++i) {
        ctrl->contact_ff[k][i] = (int32_t)((f[i] > INT32_MAX) ? INT32_MAX : ((f[i] < INT32_MIN) ? INT32_MIN : f[i]));
    }
    ctrl->contact_ff_cols = (uint8_t)(ctrl->contact_ff_cols | (1u << k));
}

SPI_NOINLINE static void contact_feedforward(const sp_ctrl_t *ctrl, const int32_t *w, sp_ctrl_output_t *out)
{
    int64_t f[SP_LEGS] = {0, 0, 0, 0, 0, 0};
    unsigned i, k;
    uint8_t mask = ctrl->force.mask;
    if (w == NULL || ctrl->contact_ff_cols == 0u || ctrl->contact_ff_cols != mask ||
        ctrl->force.mode != SP_FORCE_FORCE) {
        return;
    }
    for (k = 0u; k < 6u; ++k) {
        if ((mask & (1u << k)) != 0u) {
            /* the legs push against the world's wrench: -w, held within
             * 2^28 Q8 (1 MN), times a column: 32 x 32-bit products, six
             * of them below 2^62 */
            int32_t wk = (w[k] > (1 << 28)) ? -(1 << 28) : ((w[k] < -(1 << 28)) ? (1 << 28) : -w[k]);
            for (i = 0u; i < SP_LEGS; ++i) {
                f[i] += (int64_t)ctrl->contact_ff[k][i] * wk;
            }
        }
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        int64_t v = (int64_t)out->setpoint[i].force + spi_round_away(f[i], 24u); /* Q24 x Q8 -> Q8 */
        out->setpoint[i].force = (sp_q8_t)((v > INT32_MAX) ? INT32_MAX : ((v < INT32_MIN) ? INT32_MIN : v));
    }
}

sp_status_t sp_ctrl_wrench_at_tool(const sp_ctrl_t *ctrl, const int32_t w[6], int32_t w_tool[6])
{
    int32_t t[6] = {0, 0, 0, 0, 0, 0};
    sp_q24_t r[3];
    sp_status_t st = SP_E_ARG;
    unsigned k;
    if ((ctrl != NULL) && (w != NULL) && (w_tool != NULL)) {
        st = SP_OK;
        if (!ctrl->frames.identity) {
            /* the lever of the reference's orientation (the tick's model) */
            st = sp_frames_lever(&ctrl->frames, &ctrl->model.rot, r);
            if (st == SP_OK) {
                st = sp_frames_wrench_to_tool_at(&ctrl->frames, r, w, t);
            }
        }
        for (k = 0u; k < 6u; ++k) {
            /* identity frames, or a moved component that saturated: unmoved */
            w_tool[k] = (ctrl->frames.identity || (st != SP_OK)) ? w[k] : t[k];
        }
    }
    return st;
}

static void write_output(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, uint32_t fk_iterations, int rejected,
                         sp_ctrl_output_t *out)
{
    const int32_t *w = force_wrench(cfg, ctrl);
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        out->setpoint[i] = ctrl->setpoint[i];
    }
    if (ctrl->contact_ff_cols != 0u) {
        contact_feedforward(ctrl, w, out);
    }
    out->drive_mode = (ctrl->state == SP_STATE_IDLE || ctrl->state == SP_STATE_ESTOP ||
                       (ctrl->state == SP_STATE_FAULT && !park_reaction_active(ctrl)))
                          ? SP_DRIVE_HOLD
                          : SP_DRIVE_ACTIVE;
    /* load holding: valves at null, blocking valves closed in ESTOP and in a
     * FAULT that has held for SP_CTRL_FAULT_BLOCK_TICKS; open again only once
     * RESET re-engages */
    out->drive_block = (ctrl->state == SP_STATE_ESTOP || ctrl->fault_hold_ticks > SP_CTRL_FAULT_BLOCK_TICKS) ? 1u : 0u;
    out->state = ctrl->state;
    out->faults = ctrl->faults;
    out->tick = ctrl->tick;
    out->estimate = ctrl->est.pose;
    out->estimate_valid = ctrl->est.valid;
    copy_motion(&out->reference, &ctrl->reference);
    out->fk_iterations = fk_iterations;
    out->cmd_rejected = rejected ? 1u : 0u;
    for (i = 0u; i < 6u; ++i) {
        out->wrench[i] = ctrl->wrench.smooth[i];
    }
    out->wrench_valid = ctrl->wrench.valid;
    out->drive_fault_reset = ctrl->drive_reset.edge;
    out->stop_reaction = ctrl->estop.reaction;
    out->stop_cause = ctrl->estop.cause;
    out->reset_refused_legs = ctrl->drive_reset.refused_legs;
    out->reset_refused_cause = ctrl->drive_reset.refused_cause;
    out->force_unmeasured = (uint8_t)ctrl->sup.no_force_mask;
    out->force_mode = (uint8_t)ctrl->force.mode;
    out->contact = ctrl->force.contact.made;
    for (i = 0u; i < 6u; ++i) {
        out->force_target[i] = ctrl->force.target[i];
        out->force_wrench[i] = (w != NULL) ? w[i] : 0;
    }
}

/* ---- the tick -------------------------------------------------------------- */

/* A refused command or target: counted by its reason, the one this tick
 * reports (sp_ctrl_output_t.refuse_reason). */
SPI_NOINLINE static void count_refusal(sp_ctrl_t *ctrl, uint8_t reason)
{
    ctrl->refusing = (uint8_t)SP_REFUSE_NONE;
    sp_ctrl_count_refusal(ctrl, reason);
}

sp_status_t sp_ctrl_step(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in, sp_ctrl_output_t *out)
{
    sp_flags_t flags = 0u;
    sp_motion_t forced; /* the reference under force control */
    const sp_motion_t *ref = &ctrl->pos_ref;
    uint32_t fk_iterations;
    int active;
    int comms_ok;
    int leg_out;
    int heard;
    int rejected;
    int dropped;
    uint8_t reason = (uint8_t)SP_REFUSE_NONE;
    int have_model = 0;
    const sp_ctrl_cmd_t *cmd;

    if (cfg == NULL || ctrl == NULL || in == NULL || out == NULL || cfg->platform == NULL) {
        return SP_E_ARG;
    }
    ctrl->tick += 1u; /* a sequence number: wraps modulo 2^32, as the DBC's Tick (sp_ctrl_t.tick) */
    active = drives_active(ctrl);

    comms_ok = supervise(cfg, ctrl, in, active, &leg_out, &heard);
    fk_iterations = estimate(cfg, ctrl, active, leg_out, heard);
    ft_sensor(cfg, ctrl, in);
    drive_reset_job(cfg, ctrl, comms_ok);
    cmd = sp_ctrl_operator_link(cfg, ctrl, in, &dropped);
    ctrl->busy = 0u;
    if (dropped) {
        reason = (uint8_t)SP_REFUSE_LINK;
    } else if (cmd->type != SP_CMD_NONE) { /* checked before it is taken: no cost on ticks without a command */
        ctrl->busy = 1u;
        reason = spi_cmd_check(cfg, ctrl, cmd);
    }
    rejected = reason != (uint8_t)SP_REFUSE_NONE || !command(cfg, ctrl, cmd, comms_ok) || dropped;
    if (rejected && reason == (uint8_t)SP_REFUSE_NONE) {
        /* the path that refused it named its reason, else the state's */
        reason = (ctrl->refusing != (uint8_t)SP_REFUSE_NONE) ? ctrl->refusing : (uint8_t)SP_REFUSE_STATE;
    }
    if (ctrl->state == SP_STATE_RUNNING && ctrl->mode == SP_MODE_STREAM && in->stream_fresh &&
        !take_stream_target(cfg, ctrl, &in->stream_target)) {
        rejected = 1;
        reason = (reason != (uint8_t)SP_REFUSE_NONE) ? reason : (uint8_t)SP_REFUSE_REACH;
    }
    if (rejected) {
        count_refusal(ctrl, reason);
    }
    if (reference(cfg, ctrl, &flags)) {
        hold_setpoints(ctrl, ref);
        if (ctrl->force.mode != SP_FORCE_OFF || ctrl->park_after_release) {
            (void)sp_force_reset(&ctrl->force); /* no computation: coefficients kept */
            ctrl->park_after_release = 0u;
        }
    } else {
        if ((ctrl->force.mode != SP_FORCE_OFF || ctrl->park_after_release) && force_control(cfg, ctrl, &forced)) {
            ref = &forced;
        }
        if (flags == 0u && cfg->feedback_divider > 1u) {
            have_model = divided_setpoints(cfg, ctrl, ref, in->setpoints_idle, heard);
        } else {
            have_model = (in->setpoints_idle && flags == 0u) ? idle_setpoints(ctrl, ref)
                                                             : motion_setpoints(cfg, ctrl, ref, flags);
        }
    }
    if ((ctrl->prep.force.contact_ff && ctrl->force.mode == SP_FORCE_FORCE) || ctrl->contact_ff_cols != 0u) {
        contact_ff_prepare(cfg, ctrl); /* out of line: position control pays one test */
    }
    if (cfg->feedback_divider <= 1u || heard) {
        wrench(cfg, ctrl, have_model); /* a divided feedback: once per answer, at the model it was measured at */
    }
    cylinder_wrench(cfg, ctrl);
    check_divergence(cfg, ctrl);
    if (ctrl->state == SP_STATE_FAULT && !park_reaction_active(ctrl)) {
        ctrl->fault_hold_ticks += (ctrl->fault_hold_ticks < UINT32_MAX) ? 1u : 0u;
    } else {
        ctrl->fault_hold_ticks = 0u;
    }
    write_output(cfg, ctrl, fk_iterations, rejected, out);
    out->refuse_reason = reason;
    return SP_OK;
}
