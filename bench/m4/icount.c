/* SPDX-License-Identifier: Apache-2.0 */
/*
 * icount.c - instructions executed by the fixed-point core on a Cortex-M4
 * (QEMU mps2-an386 under -icount shift=7,sleep=off; m4_count.h): inverse
 * kinematics, leg rates, inverse dynamics, forward kinematics warm-started
 * about one tick away, the fixed-point primitives they are made of, and the
 * whole controller tick over the golden scenario (ENGAGE, the paper's 90 mm
 * 0.5 Hz surge, PARK; a plant that follows with a tracking error), by state, against the budget of issue 7
 * (<= 10,000 instructions per tick). Also the stack the tick uses (measured
 * high-water mark) and the controller's RAM. The motions are the first
 * ones of golden.c (same generator, same seed). scripts/m4_bench.sh runs it next to icount_float.c.
 * Exit status: 0, or 3 if the counter's calibration failed.
 */
#include "m4_count.h"
#include "m4_io.h"
#include "m4_vectors.h"
#include "sp_mps2.h"

#include <string.h>

#include "sp/link/auth.h"
#include "sp/link/protocol.h"
#include "sp/control/controller.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"
#include "sp/estimation/motion_error.h"
#include "sp/estimation/wrench.h"

#define N_MOTIONS 2000u
#define N_PRIM 1000u
#define TICK_BUDGET 10000u
#define FK_IT_ROWS 4u /* 0, 1, 2, 3 or more Newton steps */

static sp_motion_t motions[N_MOTIONS];
static sp_pose_t guesses[N_MOTIONS];
static sp_ik_t ik;
static sp_ik_t fk_ik;
static volatile int32_t sink;

/* The measured calls: never inlined, never analysed across (docs/explanation/m4.md, Instruction counts). */
__attribute__((noipa)) static sp_status_t run_ik(const sp_pose_t *pose, sp_ik_t *out)
{
    return sp_inverse_kinematics(&sp_platform_default, pose, out);
}

__attribute__((noipa)) static sp_status_t run_rates(const sp_motion_t *m, const sp_ik_t *in, sp_q24_t *rate)
{
    return sp_leg_rates(in, m->vel, m->rpy_rate, rate);
}

__attribute__((noipa)) static sp_status_t run_id(const sp_motion_t *m, const sp_ik_t *in, sp_q8_t *force)
{
    return sp_inverse_dynamics(&sp_platform_default, m, in, NULL, force);
}

__attribute__((noipa)) static sp_status_t run_fk(const sp_q24_t *length, const sp_pose_t *guess,
                                                 const sp_fk_options_t *opt, sp_pose_t *pose, sp_fk_info_t *info)
{
    return sp_forward_kinematics(&sp_platform_default, length, guess, opt, pose, &fk_ik, info);
}

__attribute__((noipa)) static sp_status_t run_tick(m4_scenario_t *s)
{
    return sp_ctrl_step(&s->cfg, &s->ctrl, &s->in, &s->out);
}

__attribute__((noipa)) static sp_status_t run_wrench_at_tool(const sp_ctrl_t *c, const int32_t *w, int32_t *t)
{
    return sp_ctrl_wrench_at_tool(c, w, t);
}

__attribute__((noipa)) static sp_status_t run_force_step(sp_ctrl_t *c, sp_force_t *f, const sp_q8_t *w,
                                                         const sp_pose_t *x, sp_motion_t *out, uint32_t *events)
{
    return sp_force_step(&c->prep.force, f, &c->prep.limits, &c->pos_ref, w, x, out, events);
}

__attribute__((noipa)) static sp_status_t run_orientation(const sp_q24_t *rpy, sp_rot_t *rot)
{
    return sp_orientation(rpy, rot);
}

__attribute__((noipa)) static sp_status_t run_body_rates(const sp_motion_t *m, sp_q24_t *w, sp_q24_t *wd)
{
    return sp_body_rates(m->pose.rpy, m->rpy_rate, m->rpy_acc, w, wd);
}

__attribute__((noipa)) static sp_status_t run_jacobian(const sp_ik_t *in, sp_jacobian_t *jac)
{
    return sp_jacobian(in, jac);
}

__attribute__((noipa)) static sp_status_t run_solve6(const sp_jacobian_t *jac, int transpose, const int64_t *b,
                                                     int64_t *x)
{
    return sp_solve6(jac, transpose, b, x);
}

__attribute__((noipa)) static void run_sincos(sp_q24_t a, sp_q30_t *s, sp_q30_t *c)
{
    sp_sincos_q24(a, s, c);
}

__attribute__((noipa)) static int32_t run_div(int64_t n, int32_t d, sp_flags_t *fl)
{
    return sp_div(n, d, 30u, fl);
}

__attribute__((noipa)) static int64_t run_div64(int64_t n, int32_t d, sp_flags_t *fl)
{
    return sp_div64(n, d, 28u, fl);
}

__attribute__((noipa)) static int64_t run_mul64(int64_t x, int32_t k, sp_flags_t *fl)
{
    return sp_mul64(x, k, 30u, fl);
}

__attribute__((noipa)) static uint32_t run_isqrt(uint64_t v)
{
    return sp_isqrt64(v);
}

__attribute__((noipa)) static int32_t run_dot3(const int32_t *a, const int32_t *b, sp_flags_t *fl)
{
    return sp_dot3(a, b, 30u, fl);
}

static void primitives(m4_rng_t *rng)
{
    m4_stat_t s[6];
    sp_flags_t fl = 0u;
    uint32_t n;
    unsigned k;

    for (k = 0u; k < 6u; ++k) {
        m4_stat_reset(&s[k]);
    }
    /* Arguments of the sizes the kinematics uses: angles within +-pi,
     * a Q24 leg component over a Q24 length (unit vectors), Q24 forces over
     * Q28 pivots, squared lengths (Q48), Q30 x Q24 dot products. */
    for (n = 0u; n < N_PRIM; ++n) {
        sp_q30_t sn;
        sp_q30_t cs;
        int32_t a[3];
        int32_t b[3];
        int32_t len = 33554432 + m4_rng_range(rng, 16777216); /* 1..3 m */
        int32_t comp = m4_rng_range(rng, len);
        int64_t wide = (int64_t)m4_rng_range(rng, 1 << 30) * 4096; /* Q24 force up to ~5 MN */
        int32_t piv = 67108864 + m4_rng_range(rng, 67108864);      /* Q28 0..0.5 */
        uint32_t net;
        for (k = 0u; k < 3u; ++k) {
            a[k] = m4_rng_range(rng, 1 << 30);
            b[k] = m4_rng_range(rng, 1 << 26);
        }
        M4_MEASURE(net, run_sincos(m4_rng_range(rng, 52707178), &sn, &cs));
        m4_stat_add(&s[0], net);
        M4_MEASURE(net, sink = run_div(comp, len, &fl));
        m4_stat_add(&s[1], net);
        M4_MEASURE(net, sink = (int32_t)run_div64(wide, piv, &fl));
        m4_stat_add(&s[2], net);
        M4_MEASURE(net, sink = (int32_t)run_mul64(wide, a[0], &fl));
        m4_stat_add(&s[3], net);
        M4_MEASURE(net, sink = (int32_t)run_isqrt((uint64_t)len * (uint64_t)len));
        m4_stat_add(&s[4], net);
        M4_MEASURE(net, sink = run_dot3(a, b, &fl));
        m4_stat_add(&s[5], net);
        sink = sn + cs;
    }
    m4_stat_print("sincos", "sp_sincos_q24 (|angle| <= pi)", &s[0]);
    m4_stat_print("div", "sp_div (Q24 / Q24 -> Q30, unit vector)", &s[1]);
    m4_stat_print("div64", "sp_div64 (shift 28, back substitution)", &s[2]);
    m4_stat_print("mul64", "sp_mul64 (shift 30)", &s[3]);
    m4_stat_print("isqrt64", "sp_isqrt64 (a squared length, Q48)", &s[4]);
    m4_stat_print("dot3", "sp_dot3 (shift 30)", &s[5]);
}

/* The parts the kinematics are made of, on the same motions. */
__attribute__((noipa)) static sp_status_t run_me_step(sp_motion_error_t *me, const sp_pose_t *est, const sp_pose_t *ref,
                                                      sp_q24_t *da)
{
    return sp_motion_error_step(me, est, ref, da);
}

__attribute__((noipa)) static sp_status_t run_me_wrench(const sp_ik_t *in, const sp_q24_t *da, sp_q8_t *dw)
{
    return sp_motion_error_wrench(&sp_platform_default, in, da, dw);
}

static void parts(m4_rng_t *rng)
{
    m4_stat_t s[7];
    sp_motion_error_t me;
    uint32_t n;
    unsigned k;

    for (k = 0u; k < 7u; ++k) {
        m4_stat_reset(&s[k]);
    }
    /* 1 kHz; the estimate is the motion's nearby guess, so the double
     * difference sees errors of ~1 mm */
    (void)sp_motion_error_init(&me, 1000u);
    for (n = 0u; n < N_MOTIONS; ++n) {
        sp_q24_t da[6];
        sp_q8_t dw[6];
        sp_rot_t rot;
        sp_q24_t w[3];
        sp_q24_t wd[3];
        sp_jacobian_t jac;
        int64_t b[SP_LEGS];
        int64_t x[SP_LEGS];
        uint32_t net;
        (void)sp_inverse_kinematics(&sp_platform_default, &motions[n].pose, &ik);
        for (k = 0u; k < SP_LEGS; ++k) {
            /* a right-hand side of the inverse dynamics' size: up to 50 kN
             * or 50 kN m in Q24 */
            b[k] = (int64_t)m4_rng_range(rng, 1 << 30) * 800;
        }
        M4_MEASURE(net, sink = (int32_t)run_orientation(motions[n].pose.rpy, &rot));
        m4_stat_add(&s[0], net);
        M4_MEASURE(net, sink = (int32_t)run_body_rates(&motions[n], w, wd));
        m4_stat_add(&s[1], net);
        M4_MEASURE(net, sink = (int32_t)run_jacobian(&ik, &jac));
        m4_stat_add(&s[2], net);
        M4_MEASURE(net, sink = (int32_t)run_solve6(&jac, 1, b, x));
        m4_stat_add(&s[3], net);
        M4_MEASURE(net, sink = (int32_t)run_solve6(&jac, 0, b, x));
        m4_stat_add(&s[4], net);
        M4_MEASURE(net, sink = (int32_t)run_me_step(&me, &guesses[n], &motions[n].pose, da));
        if (n >= 2u) {
            m4_stat_add(&s[5], net); /* three poses in: the difference running */
        }
        M4_MEASURE(net, sink = (int32_t)run_me_wrench(&ik, da, dw));
        m4_stat_add(&s[6], net);
        sink = rot.t[0][0] + w[0] + wd[0] + (int32_t)x[0] + dw[0];
    }
    m4_stat_print("orientation", "sp_orientation (3 sincos, T)", &s[0]);
    m4_stat_print("body_rates", "sp_body_rates (2 sincos)", &s[1]);
    m4_stat_print("jacobian", "sp_jacobian", &s[2]);
    m4_stat_print("solve6_t", "sp_solve6, transposed (inverse dynamics)", &s[3]);
    m4_stat_print("solve6", "sp_solve6 (one FK Newton step)", &s[4]);
    m4_stat_print("me_step", "sp_motion_error_step (difference running)", &s[5]);
    m4_stat_print("me_wrench", "sp_motion_error_wrench (after IK)", &s[6]);
}

static void kinematics(void)
{
    m4_stat_t s_ik;
    m4_stat_t s_rates;
    m4_stat_t s_id;
    m4_stat_t s_fk;
    m4_stat_t s_fk_it[FK_IT_ROWS];
    sp_fk_options_t opt;
    uint32_t failures = 0u;
    uint32_t n;
    unsigned k;

    sp_fk_default_options(&opt);
    m4_stat_reset(&s_ik);
    m4_stat_reset(&s_rates);
    m4_stat_reset(&s_id);
    m4_stat_reset(&s_fk);
    for (k = 0u; k < FK_IT_ROWS; ++k) {
        m4_stat_reset(&s_fk_it[k]);
    }
    for (n = 0u; n < N_MOTIONS; ++n) {
        sp_q24_t rate[SP_LEGS];
        sp_q8_t force[SP_LEGS];
        sp_pose_t pose;
        sp_fk_info_t info;
        sp_status_t st[4];
        uint32_t net;

        M4_MEASURE(net, st[0] = run_ik(&motions[n].pose, &ik));
        m4_stat_add(&s_ik, net);
        M4_MEASURE(net, st[1] = run_rates(&motions[n], &ik, rate));
        m4_stat_add(&s_rates, net);
        M4_MEASURE(net, st[2] = run_id(&motions[n], &ik, force));
        m4_stat_add(&s_id, net);
        M4_MEASURE(net, st[3] = run_fk(ik.length, &guesses[n], &opt, &pose, &info));
        m4_stat_add(&s_fk, net);
        m4_stat_add(&s_fk_it[info.iterations < FK_IT_ROWS ? info.iterations : FK_IT_ROWS - 1u], net);
        for (k = 0u; k < 4u; ++k) {
            failures += (st[k] != SP_OK) ? 1u : 0u;
        }
        sink = rate[0] + force[0] + pose.pos[0];
    }
    m4_stat_print("ik", "sp_inverse_kinematics", &s_ik);
    m4_stat_print("rates", "sp_leg_rates (after IK)", &s_rates);
    m4_stat_print("id", "sp_inverse_dynamics (after IK)", &s_id);
    m4_stat_print("fk", "sp_forward_kinematics (warm, +-1 mm/mrad)", &s_fk);
    m4_stat_print("fk_1", "  of which 1 Newton step", &s_fk_it[1]);
    m4_stat_print("fk_2", "  of which 2 Newton steps", &s_fk_it[2]);
    m4_stat_print("fk_3", "  of which 3 or more Newton steps", &s_fk_it[3]);
    if (failures != 0u) {
        m4_out_str("warning: ");
        m4_out_u32(failures);
        m4_out_str(" of these calls did not return SP_OK");
        m4_out_nl();
    }
}

/* Signed statistics of a per-tick difference, instructions x 16. */
typedef struct {
    uint32_t n;
    int64_t sum;
    int32_t min;
    int32_t max;
} diff_stat_t;

static void diff_reset(diff_stat_t *d)
{
    d->n = 0u;
    d->sum = 0;
    d->min = INT32_MAX;
    d->max = INT32_MIN;
}

static void diff_add(diff_stat_t *d, int32_t v)
{
    ++d->n;
    d->sum += v;
    d->min = (v < d->min) ? v : d->min;
    d->max = (v > d->max) ? v : d->max;
}

static void out_signed16(int64_t v16)
{
    if (v16 < 0) {
        m4_out_str("-");
        v16 = -v16;
    }
    m4_out_fix16((uint64_t)v16);
}

static void diff_print(const char *what, const diff_stat_t *d)
{
    m4_out_str(what);
    m4_out_str(": ");
    m4_out_u32(d->n);
    m4_out_str(" ticks, mean ");
    out_signed16((d->n != 0u) ? d->sum / (int64_t)d->n : 0);
    m4_out_str(", min ");
    out_signed16((d->n != 0u) ? d->min : 0);
    m4_out_str(", max ");
    out_signed16((d->n != 0u) ? d->max : 0);
    m4_out_nl();
}

/* 1 if the n bytes at a and b are equal. */
static int m4_same_bytes(const void *a, const void *b, uint32_t n)
{
    const uint8_t *x = (const uint8_t *)a;
    const uint8_t *y = (const uint8_t *)b;
    uint32_t i;
    for (i = 0u; i < n; ++i) {
        if (x[i] != y[i]) {
            return 0;
        }
    }
    return 1;
}

/* The twin's tick costs by tick index (the force scenario in position
 * control), for the per-tick increment of force control. */
static uint32_t twin_net16[M4_MAX_TICKS + M4_TAIL_TICKS + 1u];

/* The tick kinds of the breakdown: a tick with a command; a moving tick
 * (ENGAGING, RUNNING, PARKING, READY under force control) that factorised
 * the forces' J^T (the factorisation's bytes changed, or its age restarted
 * at 0: a Jacobian unchanged since the last factorisation gives the same
 * bytes, as in the stream's settling tail), one that refined
 * them from the kept factorisation (its age counted up); every other tick
 * (at rest, holding: the setpoints kept). */
#define KINDS 4u
#define KIND_CMD 0u
#define KIND_LU 1u
#define KIND_REFINE 2u
#define KIND_REST 3u
static const char *const kind_keys[KINDS] = {"k_command", "k_factorise", "k_refine", "k_rest"};

/* The counts of one scenario run. */
typedef struct {
    m4_stat_t by_state[7];
    m4_stat_t all;
    uint32_t running_fk[4]; /* FK steps in RUNNING ticks: 0, 1, 2, 3 or more */
    uint32_t over;          /* ticks over the budget */
    uint32_t stack;         /* high-water mark of the stack, bytes */
    m4_stat_t force;        /* ticks that began in force control (FORCE) */
    m4_stat_t run;          /* the force-control run: the FORCE command's tick to the end of the release */
    m4_stat_t slide;        /* ticks of the slide (began in RUNNING, in phase 3 of the force scenario) */
    diff_stat_t incr;       /* the run's ticks less the twin's same ticks */
    diff_stat_t incr_slide; /* ... those of the slide */
    m4_stat_t own;          /* force control's own step (sp_force_step), again on a copy, in the run's ticks */
    uint32_t own_mismatch;  /* copies whose step did not reproduce the tick's (not counted in `own`) */
    m4_stat_t kind[KINDS];  /* ticks by kind (kind_names): which kind makes the maximum */
    m4_stat_t report;       /* with frames: the wrench report at the tool point (sp_ctrl_wrench_at_tool,
                               the node's on its CTRL_WRENCH ticks), RUNNING ticks */
    uint32_t worst_tick;    /* the highest tick: its index, */
    uint8_t worst_state;    /* the state it began in, */
    uint8_t worst_cmd;      /* its command (SP_CMD_NONE: none) */
    uint8_t worst_kind;     /* and its kind */
} scenario_counts_t;

static const char *const kind_names[KINDS] = {
    "  ticks with a command",
    "  moving ticks that factorise J^T",
    "  moving ticks that refine (kept LU)",
    "  other ticks (at rest, holding)",
};

static void run_scenario(m4_scenario_t *sc, uint8_t motion, scenario_counts_t *r)
{
    uintptr_t top;
    unsigned k;

    for (k = 0u; k < 7u; ++k) {
        m4_stat_reset(&r->by_state[k]);
    }
    m4_stat_reset(&r->all);
    for (k = 0u; k < 4u; ++k) {
        r->running_fk[k] = 0u;
    }
    r->over = 0u;
    m4_stat_reset(&r->force);
    m4_stat_reset(&r->run);
    m4_stat_reset(&r->slide);
    diff_reset(&r->incr);
    diff_reset(&r->incr_slide);
    m4_stat_reset(&r->own);
    r->own_mismatch = 0u;
    for (k = 0u; k < KINDS; ++k) {
        m4_stat_reset(&r->kind[k]);
    }
    m4_stat_reset(&r->report);
    r->worst_tick = 0u;
    r->worst_state = 0u;
    r->worst_cmd = 0u;
    r->worst_kind = 0u;
    (void)m4_scenario_init(sc, &sp_platform_default, motion);
    sp_mps2_stack_paint();
    top = sp_mps2_stack_pointer();
    while (m4_scenario_prepare(sc)) {
        sp_state_t before = sc->ctrl.state;
        int forcing = sc->ctrl.force.mode == SP_FORCE_FORCE;
        int in_run = sc->ctrl.force.mode != SP_FORCE_OFF || sc->in.cmd.type == SP_CMD_FORCE;
        /* force control's own step, again on a copy of its state from
         * before the tick (ticks without a command: the state the tick's
         * step began from), counted only where it reproduces the tick's */
        static sp_force_t shadow;
        int shadowed = motion == M4_MOTION_FORCE && sc->ctrl.force.mode != SP_FORCE_OFF &&
                       sc->in.cmd.type == SP_CMD_NONE && (before == SP_STATE_READY || before == SP_STATE_RUNNING);
        if (shadowed) {
            shadow = sc->ctrl.force;
        }
        int sliding = before == SP_STATE_RUNNING && sc->phase == 3u;
        uint32_t tick = sc->ticks;
        uint32_t net;
        unsigned kind;
        static sp_lu6_t lu_before;
        uint8_t cmd = (uint8_t)sc->in.cmd.type;
        uint8_t age_before = sc->ctrl.legs.lu_age;
        lu_before = sc->ctrl.est.ref_lu;
        M4_MEASURE(net, sink = (int32_t)run_tick(sc));
        if (cmd != (uint8_t)SP_CMD_NONE) {
            kind = KIND_CMD;
        } else if (sc->ctrl.est.ref_lu.valid && (!m4_same_bytes(&lu_before, &sc->ctrl.est.ref_lu, sizeof lu_before) ||
                                                 (sc->ctrl.legs.lu_age == 0u && age_before != 0u))) {
            kind = KIND_LU; /* bytes changed, or factorised again to the same bytes (its age restarted) */
        } else if (sc->ctrl.est.ref_lu.valid && sc->ctrl.legs.lu_age != age_before) {
            kind = KIND_REFINE;
        } else {
            kind = KIND_REST;
        }
        m4_stat_add(&r->kind[kind], net);
        if (m4_scenario_frames != 0u && before == SP_STATE_RUNNING) {
            static int32_t wt[6];
            uint32_t rep;
            M4_MEASURE(rep, sink = (int32_t)run_wrench_at_tool(&sc->ctrl, sc->out.wrench, wt));
            m4_stat_add(&r->report, rep);
        }
        if (net > r->all.max16) {
            r->worst_tick = tick;
            r->worst_state = (uint8_t)before;
            r->worst_cmd = cmd;
            r->worst_kind = (uint8_t)kind;
        }
        if ((unsigned)before < 7u) {
            m4_stat_add(&r->by_state[before], net);
        }
        m4_stat_add(&r->all, net);
        if (forcing) {
            m4_stat_add(&r->force, net);
        }
        if (shadowed && (sc->ctrl.state == SP_STATE_READY || sc->ctrl.state == SP_STATE_RUNNING)) {
            sp_motion_t out;
            uint32_t events;
            uint32_t own;
            const sp_q8_t *w = sc->ctrl.ft_valid ? sc->ctrl.ft_section[SP_WRENCH_SECTIONS - 1u] : NULL;
            M4_MEASURE(own, sink = (int32_t)run_force_step(
                                &sc->ctrl, &shadow, w, sc->ctrl.est.valid ? &sc->ctrl.est.pose : NULL, &out, &events));
            if (m4_same_bytes(&shadow, &sc->ctrl.force, sizeof shadow)) {
                m4_stat_add(&r->own, own);
            } else {
                ++r->own_mismatch;
            }
        }
        if (motion == M4_MOTION_FORCE_TWIN && tick < sizeof twin_net16 / sizeof twin_net16[0]) {
            twin_net16[tick] = net;
        }
        if (motion == M4_MOTION_FORCE && in_run) {
            m4_stat_add(&r->run, net);
            if (tick < sizeof twin_net16 / sizeof twin_net16[0]) {
                int32_t dv = (int32_t)net - (int32_t)twin_net16[tick];
                diff_add(&r->incr, dv);
                if (sliding) {
                    diff_add(&r->incr_slide, dv);
                }
            }
        }
        if (sliding && (motion == M4_MOTION_FORCE ? forcing : motion == M4_MOTION_FORCE_TWIN)) {
            m4_stat_add(&r->slide, net);
        }
        if (before == SP_STATE_RUNNING) {
            r->running_fk[sc->out.fk_iterations < 3u ? sc->out.fk_iterations : 3u]++;
        }
        r->over += (net > TICK_BUDGET * 16u) ? 1u : 0u;
        m4_scenario_finish(sc);
    }
    r->stack = sp_mps2_stack_used(top);
}

static void print_scenario_end(const m4_scenario_t *sc, const scenario_counts_t *r)
{
    unsigned k;
    for (k = 0u; k < KINDS; ++k) {
        if (r->kind[k].calls != 0u) {
            m4_stat_print(kind_keys[k], kind_names[k], &r->kind[k]);
        }
    }
    m4_out_str("highest tick: ");
    m4_out_u32(r->worst_tick);
    m4_out_str(", began in ");
    m4_out_str(sp_state_name((sp_state_t)r->worst_state));
    m4_out_str(", command ");
    m4_out_u32(r->worst_cmd);
    m4_out_str(",");
    m4_out_str(kind_names[r->worst_kind] + 1);
    m4_out_nl();
    m4_out_str("scenario: ");
    m4_out_u32(sc->ticks);
    m4_out_str(" ticks, final state ");
    m4_out_str(sp_state_name(sc->out.state));
    m4_out_str(", faults");
    m4_out_hex(sc->out.faults);
    m4_out_str("; FK steps in the RUNNING ticks: 0: ");
    m4_out_u32(r->running_fk[0]);
    m4_out_str(", 1: ");
    m4_out_u32(r->running_fk[1]);
    m4_out_str(", 2: ");
    m4_out_u32(r->running_fk[2]);
    m4_out_str(", 3 or more: ");
    m4_out_u32(r->running_fk[3]);
    m4_out_nl();
}

/* One line of the frames section: a scenario's RUNNING mean and max, the
 * mean's increase over the identity run, and the scenario's highest tick
 * in any state (the state it began in, its command). */
static void frames_line(const char *what, const m4_stat_t *with, const m4_stat_t *identity, const scenario_counts_t *r)
{
    m4_out_str(what);
    m4_out_str(" mean ");
    m4_out_fix16(m4_stat_mean16(with));
    m4_out_str(" (identity ");
    m4_out_fix16(m4_stat_mean16(identity));
    m4_out_str(", +");
    out_signed16((int64_t)m4_stat_mean16(with) - (int64_t)m4_stat_mean16(identity));
    m4_out_str("), max ");
    m4_out_fix16(with->max16);
    m4_out_str("; highest tick ");
    m4_out_fix16(r->all.max16);
    m4_out_str(" (");
    m4_out_str(sp_state_name((sp_state_t)r->worst_state));
    m4_out_str(", command ");
    m4_out_u32(r->worst_cmd);
    m4_out_str("); the node's wrench report ");
    m4_out_fix16(m4_stat_mean16(&r->report));
    m4_out_str(" every ");
    m4_out_u32(SP_PROTO_WRENCH_PERIOD);
    m4_out_str(" ticks");
    m4_out_nl();
}

/* Issue 31: the same scenarios with a tool frame (the pivot) and with
 * turned tool and work frames: what the transforms add to a tick. */
static void frames_section(m4_scenario_t *sc, const scenario_counts_t *surge, const scenario_counts_t other[2],
                           const scenario_counts_t *force)
{
    static scenario_counts_t r;
    uint32_t max16 = 0u;
    uint32_t fmax16 = 0u;
    for (uint8_t mode = 1u; mode <= 2u; ++mode) {
        m4_scenario_frames = mode;
        m4_out_str(mode == 1u ? "frames: a tool tip (0.15, 0, 0.35) m, RUNNING tick:"
                              : "frames: tool and work frames turned, RUNNING tick:");
        m4_out_nl();
        run_scenario(sc, M4_MOTION_SURGE, &r);
        frames_line("  surge about the pivot", &r.by_state[SP_STATE_RUNNING], &surge->by_state[SP_STATE_RUNNING], &r);
        max16 = r.all.max16 > max16 ? r.all.max16 : max16;
        run_scenario(sc, M4_MOTION_YAW, &r);
        frames_line("  yaw about the pivot  ", &r.by_state[SP_STATE_RUNNING], &other[0].by_state[SP_STATE_RUNNING], &r);
        max16 = r.all.max16 > max16 ? r.all.max16 : max16;
        run_scenario(sc, M4_MOTION_STREAM, &r);
        frames_line("  stream of tool poses ", &r.by_state[SP_STATE_RUNNING], &other[1].by_state[SP_STATE_RUNNING], &r);
        max16 = r.all.max16 > max16 ? r.all.max16 : max16;
        run_scenario(sc, M4_MOTION_FORCE, &r);
        frames_line("  force run at the tool", &r.run, &force->run, &r);
        fmax16 = r.run.max16 > fmax16 ? r.run.max16 : fmax16;
    }
    m4_scenario_frames = 0u;
    m4_out_str("frames budget: any tick of the position scenarios max ");
    m4_out_fix16(max16);
    m4_out_str(" (<= 11000), force run max ");
    m4_out_fix16(fmax16);
    m4_out_str(" (<= 12500) -> ");
    m4_out_str((max16 <= 11000u * 16u && fmax16 <= 12500u * 16u) ? "within budget" : "OVER BUDGET");
    m4_out_nl();
}

static void controller(void)
{
    static m4_scenario_t sc;
    static scenario_counts_t surge;
    static scenario_counts_t other[2];
    static scenario_counts_t force;
    static scenario_counts_t twin;
    uint32_t over;
    uint32_t max16;
    uint32_t stack;
    unsigned k;
    static const char *const names[7] = {
        "tick in IDLE",    "tick in ENGAGING", "tick in READY", "tick in RUNNING (the surge)",
        "tick in PARKING", "tick in FAULT",    "tick in ESTOP",
    };
    static const char *const keys[7] = {
        "tick_idle", "tick_engaging", "tick_ready", "tick_running", "tick_parking", "tick_fault", "tick_estop",
    };

    /* the golden scenario: the surge */
    run_scenario(&sc, M4_MOTION_SURGE, &surge);
    for (k = 0u; k < 7u; ++k) {
        if (surge.by_state[k].calls != 0u) {
            m4_stat_print(keys[k], names[k], &surge.by_state[k]);
        }
    }
    m4_stat_print("tick_all", "tick, every state", &surge.all);
    print_scenario_end(&sc, &surge);
    /* the same with a yaw motion and with streamed targets */
    run_scenario(&sc, M4_MOTION_YAW, &other[0]);
    m4_stat_print("tick_run_yaw", "tick in RUNNING (yaw 0.09 rad 0.5 Hz)", &other[0].by_state[SP_STATE_RUNNING]);
    m4_stat_print("tick_all_yaw", "tick, every state (yaw scenario)", &other[0].all);
    print_scenario_end(&sc, &other[0]);
    run_scenario(&sc, M4_MOTION_STREAM, &other[1]);
    m4_stat_print("tick_run_stream", "tick in RUNNING (STREAM, target every tick)",
                  &other[1].by_state[SP_STATE_RUNNING]);
    m4_stat_print("tick_all_stream", "tick, every state (stream scenario)", &other[1].all);
    print_scenario_end(&sc, &other[1]);

    over = surge.over + other[0].over + other[1].over;
    max16 = surge.all.max16;
    stack = surge.stack;
    for (k = 0u; k < 2u; ++k) {
        max16 = other[k].all.max16 > max16 ? other[k].all.max16 : max16;
        stack = other[k].stack > stack ? other[k].stack : stack;
    }
    m4_out_str("budget: whole tick <= ");
    m4_out_u32(TICK_BUDGET);
    m4_out_str(" instructions: RUNNING mean ");
    m4_out_fix16(m4_stat_mean16(&surge.by_state[SP_STATE_RUNNING]));
    m4_out_str(" (surge), ");
    m4_out_fix16(m4_stat_mean16(&other[0].by_state[SP_STATE_RUNNING]));
    m4_out_str(" (yaw), ");
    m4_out_fix16(m4_stat_mean16(&other[1].by_state[SP_STATE_RUNNING]));
    m4_out_str(" (stream); any tick of the three scenarios max ");
    m4_out_fix16(max16);
    m4_out_str(" -> ");
    m4_out_str(over == 0u ? "within budget" : "OVER BUDGET in ");
    if (over != 0u) {
        m4_out_u32(over);
        m4_out_str(" ticks");
    }
    m4_out_nl();
    /* force control (issue 15's figure: mean <= 10,000, max <= 12,000 for
     * every tick of a force-control run), and the same scenario in position
     * control (the twin) for what force control adds to each tick */
    run_scenario(&sc, M4_MOTION_FORCE_TWIN, &twin);
    m4_stat_print("tick_twin_slide", "position control: tick of the 50 mm slide", &twin.slide);
    m4_stat_print("tick_all_twin", "position control: tick, every state (twin)", &twin.all);
    run_scenario(&sc, M4_MOTION_FORCE, &force);
    m4_stat_print("tick_force", "tick in FORCE (2 kN on 1e6 N/m, a 50 mm slide)", &force.force);
    m4_stat_print("tick_force_run", "tick of the run (FORCE command to released)", &force.run);
    m4_stat_print("tick_force_slide", "tick in FORCE of the 50 mm slide", &force.slide);
    m4_stat_print("tick_all_force", "tick, every state (force scenario)", &force.all);
    print_scenario_end(&sc, &force);
    m4_stat_print("force_own", "force control's own step (sp_force_step)", &force.own);
    if (force.own_mismatch != 0u) {
        m4_out_str("warning: ");
        m4_out_u32(force.own_mismatch);
        m4_out_str(" steps on the copy differed from the tick's");
        m4_out_nl();
    }
    diff_print("force control adds per tick, the run (less the twin's same tick)", &force.incr);
    diff_print("force control adds per tick, the slide (both RUNNING, the same move)", &force.incr_slide);
    m4_out_str("force-control budget: tick of the run mean ");
    m4_out_fix16(m4_stat_mean16(&force.run));
    m4_out_str(" (<= 10000), max ");
    m4_out_fix16(force.run.max16);
    m4_out_str(" (<= 12000) -> ");
    m4_out_str((force.run.calls != 0u && m4_stat_mean16(&force.run) <= 10000u * 16u && force.run.max16 <= 12000u * 16u)
                   ? "within budget"
                   : "OVER BUDGET");
    m4_out_str("; force control adds mean ");
    out_signed16((force.incr_slide.n != 0u) ? force.incr_slide.sum / (int64_t)force.incr_slide.n : 0);
    m4_out_str(", max ");
    out_signed16((force.incr_slide.n != 0u) ? force.incr_slide.max : 0);
    m4_out_str(" to a RUNNING tick; its own step mean ");
    m4_out_fix16(m4_stat_mean16(&force.own));
    m4_out_str(", max ");
    m4_out_fix16(force.own.max16);
    m4_out_nl();
    stack = force.stack > stack ? force.stack : stack;
    stack = twin.stack > stack ? twin.stack : stack;
    m4_out_str("stack: sp_ctrl_step used at most ");
    m4_out_u32(stack);
    m4_out_str(" bytes (high-water mark over the five scenarios, call included)");
    m4_out_nl();
    frames_section(&sc, &surge, other, &force);
    m4_out_str("RAM of the controller: sp_ctrl_t ");
    m4_out_u32((uint32_t)sizeof(sp_ctrl_t));
    m4_out_str(" + sp_ctrl_config_t ");
    m4_out_u32((uint32_t)sizeof(sp_ctrl_config_t));
    m4_out_str(" + input ");
    m4_out_u32((uint32_t)sizeof(sp_ctrl_input_t));
    m4_out_str(" + output ");
    m4_out_u32((uint32_t)sizeof(sp_ctrl_output_t));
    m4_out_str(" bytes");
    m4_out_nl();
}

/* Command authentication (sp/link/auth.h): checking one authenticated frame, the
 * payload of OP_TARGET_POSE (24 bytes) and of a short command (12) with an
 * 8-byte tag: the code is computed once when it checks, twice when not. */
static void auth(m4_rng_t *rng)
{
    static const uint32_t sizes[2] = {24u, 12u};
    m4_stat_t s[3];
    sp_auth_key_t key;
    sp_auth_rx_t rx;
    uint8_t payload[SP_AUTH_PAYLOAD_MAX];
    uint8_t tag[8];
    uint32_t n;
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        m4_stat_reset(&s[k]);
    }
    for (k = 0u; k < SP_AUTH_KEY_BYTES; ++k) {
        key.k[k] = (uint8_t)m4_rng_next(rng);
    }
    (void)sp_auth_rx_start(&rx, m4_rng_next(rng));
    for (n = 1u; n <= 200u; ++n) {
        for (k = 0u; k < 2u; ++k) {
            uint64_t code = 0u;
            uint32_t net;
            uint32_t c = rx.last + 1u;
            unsigned i;
            for (i = 0u; i < sizes[k]; ++i) {
                payload[i] = (uint8_t)m4_rng_next(rng);
            }
            (void)sp_auth_tag(&key, 0x050u, rx.session, c, payload, sizes[k], &code);
            for (i = 0u; i < 8u; ++i) {
                tag[i] = (uint8_t)(code >> (8u * i));
            }
            M4_MEASURE(net, (void)sp_auth_check(&rx, &key, 0x050u, (uint16_t)c, payload, sizes[k], tag, 8u));
            m4_stat_add(&s[k], net);
            if (k == 0u) { /* the same frame again: rejected, two codes computed */
                M4_MEASURE(net, (void)sp_auth_check(&rx, &key, 0x050u, (uint16_t)c, payload, sizes[k], tag, 8u));
                m4_stat_add(&s[2], net);
            }
        }
    }
    m4_stat_print("auth_24", "sp_auth_check, 24-byte payload, accepted", &s[0]);
    m4_stat_print("auth_12", "sp_auth_check, 12-byte payload, accepted", &s[1]);
    m4_stat_print("auth_replay", "sp_auth_check, 24-byte payload, replayed (rejected)", &s[2]);
}

/* Command authentication on the frames the node checks (sp_proto_auth_check,
 * sp/link/protocol.h): a signed OP_TARGET_POSE (what streaming adds to a tick: at
 * most one such frame per tick), a signed OP_COMMAND, a forged
 * OP_TARGET_POSE (another key: one code, rejected), and the CTRL_AUTH frame
 * the node encodes every 10 ticks. */
static void auth_frames(m4_rng_t *rng)
{
    m4_stat_t s[4];
    sp_auth_key_t key;
    sp_auth_key_t other;
    sp_auth_rx_t rx;
    sp_can_frame_t f;
    sp_pose_t pose;
    sp_msg_command_t c;
    sp_msg_auth_t a;
    uint32_t n;
    uint32_t net;
    unsigned k;
    for (k = 0u; k < 4u; ++k) {
        m4_stat_reset(&s[k]);
    }
    for (k = 0u; k < SP_AUTH_KEY_BYTES; ++k) {
        key.k[k] = (uint8_t)m4_rng_next(rng);
        other.k[k] = (uint8_t)(key.k[k] ^ 0x01u);
    }
    (void)sp_auth_rx_start(&rx, m4_rng_next(rng));
    memset(&c, 0, sizeof c);
    c.command = 3u; /* MOVE_TO */
    for (n = 1u; n <= 200u; ++n) {
        for (k = 0u; k < 3u; ++k) {
            pose.pos[k] = (sp_q24_t)(m4_rng_next(rng) % 1000000u);
            pose.rpy[k] = (sp_q24_t)(m4_rng_next(rng) % 100000u);
        }
        (void)sp_proto_encode_target(&pose, (uint8_t)n, &f);
        (void)sp_proto_sign(&f, &key, rx.session, rx.last + 1u);
        M4_MEASURE(net, (void)sp_proto_auth_check(&rx, &key, &f));
        m4_stat_add(&s[0], net);
        c.fade_ms = n;
        (void)sp_proto_encode_command(&c, (uint8_t)n, &f);
        (void)sp_proto_sign(&f, &key, rx.session, rx.last + 1u);
        M4_MEASURE(net, (void)sp_proto_auth_check(&rx, &key, &f));
        m4_stat_add(&s[1], net);
        (void)sp_proto_encode_target(&pose, (uint8_t)n, &f);
        (void)sp_proto_sign(&f, &other, rx.session, rx.last + 1u);
        M4_MEASURE(net, (void)sp_proto_auth_check(&rx, &key, &f));
        m4_stat_add(&s[2], net);
        a.session = rx.session;
        a.last_counter = rx.last;
        a.bad_tag = rx.bad_tag;
        a.replayed = rx.replayed;
        a.key_set = 1u;
        M4_MEASURE(net, (void)sp_proto_encode_auth(&a, (uint8_t)n, &f));
        m4_stat_add(&s[3], net);
    }
    m4_stat_print("auth_pose", "sp_proto_auth_check, signed OP_TARGET_POSE (22 bytes covered), accepted", &s[0]);
    m4_stat_print("auth_cmd", "sp_proto_auth_check, signed OP_COMMAND (12 bytes covered), accepted", &s[1]);
    m4_stat_print("auth_forged", "sp_proto_auth_check, OP_TARGET_POSE under another key, rejected", &s[2]);
    m4_stat_print("auth_status", "sp_proto_encode_auth, CTRL_AUTH (every 10 ticks)", &s[3]);
}

/* The native node's protocol codec in a tick (sp/link/protocol.h): per tick
 * it encodes two SYNC and two AXIS_SETPOINTS (one per axis bus), CTRL_STATUS
 * and CTRL_MONITOR, and decodes six AXIS_FEEDBACK; setpoints and feedback
 * near their signals' limits, so that the saturation and range paths run. */
static void codec(m4_rng_t *rng)
{
    m4_stat_t s[5];
    sp_can_frame_t f;
    sp_can_frame_t fb[SP_LEGS];
    sp_msg_sync_t sync;
    sp_msg_setpoints_t sp;
    sp_msg_feedback_t m;
    sp_msg_status_t st;
    sp_msg_monitor_t mon;
    uint8_t slot;
    uint8_t counter;
    uint32_t n;
    uint32_t net;
    uint32_t sum;
    unsigned k;
    for (k = 0u; k < 5u; ++k) {
        m4_stat_reset(&s[k]);
    }
    memset(&st, 0, sizeof st);
    memset(&mon, 0, sizeof mon);
    for (n = 1u; n <= 200u; ++n) {
        sync.tick = n;
        sync.hold = 0u;
        sp.tick = n;
        sp.mode = 1u;
        sp.fault_reset = 0u;
        sp.block = 0u;
        for (k = 0u; k < SP_AXIS_SLOTS; ++k) {
            sp.setpoint[k].length = (sp_q24_t)(m4_rng_next(rng) % (300u << 24));
            sp.setpoint[k].velocity = (sp_q24_t)(m4_rng_next(rng) % (2u << 24)) - (1 << 24);
            sp.setpoint[k].force = (sp_q8_t)(m4_rng_next(rng) % (400000u << 8)) - (200000 << 8);
        }
        for (k = 0u; k < SP_LEGS; ++k) {
            m.length = (sp_q24_t)(m4_rng_next(rng) % (30u << 24));
            m.pressure_a = m4_rng_next(rng) % 70000000u;
            m.pressure_b = m4_rng_next(rng) % 70000000u;
            m.state = 2u;
            m.faults = 0u;
            m.tick_echo = (uint16_t)n;
            (void)sp_proto_encode_feedback(&m, (uint8_t)(k % 3u + 1u), (uint8_t)n, (uint8_t)(1u + k / 3u), &fb[k]);
            mon.length_sp[k] = sp.setpoint[k % 3u].length;
            mon.force_ff[k] = sp.setpoint[k % 3u].force;
        }
        for (k = 0u; k < 3u; ++k) {
            st.estimate.pos[k] = (sp_q24_t)(m4_rng_next(rng) % (2u << 24)) - (1 << 24);
            st.estimate.rpy[k] = (sp_q24_t)(m4_rng_next(rng) % (1u << 24)) - (1 << 23);
        }
        mon.reference = st.estimate;
        sum = 0u;
        for (k = 0u; k < 2u; ++k) {
            M4_MEASURE(net, (void)sp_proto_encode_sync(&sync, (uint8_t)n, (uint8_t)(1u + k), &f));
            sum += net;
            M4_MEASURE(net, (void)sp_proto_encode_setpoints(&sp, (uint8_t)n, (uint8_t)(1u + k), &f));
            m4_stat_add(&s[0], net);
            sum += net;
        }
        for (k = 0u; k < SP_LEGS; ++k) {
            M4_MEASURE(net, (void)sp_proto_decode_feedback(&fb[k], &m, &slot, &counter, NULL));
            m4_stat_add(&s[1], net);
            sum += net;
        }
        M4_MEASURE(net, (void)sp_proto_encode_status(&st, (uint8_t)n, &f));
        m4_stat_add(&s[2], net);
        sum += net;
        M4_MEASURE(net, (void)sp_proto_encode_monitor(&mon, (uint8_t)n, &f));
        m4_stat_add(&s[3], net);
        sum += net;
        m4_stat_add(&s[4], sum);
    }
    m4_stat_print("co_setpoints", "sp_proto_encode_setpoints, AXIS_SETPOINTS", &s[0]);
    m4_stat_print("co_feedback", "sp_proto_decode_feedback, AXIS_FEEDBACK", &s[1]);
    m4_stat_print("co_status", "sp_proto_encode_status, CTRL_STATUS", &s[2]);
    m4_stat_print("co_monitor", "sp_proto_encode_monitor, CTRL_MONITOR", &s[3]);
    m4_stat_print("co_tick", "the codec of a native tick (2 SYNC, 2 setpoints, 6 feedback, status, monitor)", &s[4]);
}

int main(void)
{
    m4_rng_t rng;
    uint32_t n;

    m4_out_str("== Cortex-M4 instruction counts, fixed point (QEMU mps2-an386, -icount shift=7,sleep=off; "
               "soft-float ABI; compiled for " M4_OPTIMISATION ")");
    m4_out_nl();
    if (m4_count_init() != 0) {
        (void)m4_out_flush();
        return 3;
    }
    m4_rng_seed(&rng, M4_SEED);
    for (n = 0u; n < N_MOTIONS; ++n) {
        m4_random_motion(&rng, &sp_platform_default, &motions[n]);
        m4_nearby_pose(&rng, &motions[n].pose, &guesses[n]);
    }
    m4_stat_header();
    kinematics();
    parts(&rng);
    primitives(&rng);
    auth(&rng);
    auth_frames(&rng);
    codec(&rng);
    controller();
    return m4_out_flush() == 0 ? 0 : 2;
}
