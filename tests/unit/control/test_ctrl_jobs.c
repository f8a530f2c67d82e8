/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of the controller's jobs on their own, on the default
 * platform: the limits (sp/motion/limits.h), the stream filter (sp/motion/stream.h), the
 * pose estimate (sp/estimation/estimate.h) and the setpoints of a reference
 * (sp/motion/setpoint.h). test_controller.c tests them together through
 * sp_ctrl_step.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "assert_near.h"
#include "ref_model.h"
#include "sp/control/controller.h"
#include "test_util.h"

static const sp_platform_t *P = &sp_platform_default;

static int32_t q24(double v)
{
    return (int32_t)llround(v * 16777216.0);
}

static sp_limits_t default_limits(void)
{
    sp_limits_t lim;
    assert_int_equal(sp_limits_prepare(&lim, P, SP_Q24_MILLI(10)), SP_OK);
    return lim;
}

/* A pose around home: up to d (m) and r (rad) on every axis. */
static sp_pose_t random_pose(uint64_t *rng, double d, double r)
{
    sp_pose_t q = P->home;
    for (int k = 0; k < 3; ++k) {
        q.pos[k] += q24(tu_uniform(rng, -d, d));
        q.rpy[k] += q24(tu_uniform(rng, -r, r));
    }
    return q;
}

/* ---- limits --------------------------------------------------------------- */

static void test_limits_prepare(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    assert_int_equal(lim.length_min, P->leg_length_min + SP_Q24_MILLI(10));
    assert_int_equal(lim.length_max, P->leg_length_max - SP_Q24_MILLI(10));
    assert_int_equal(lim.measured_min, P->leg_length_min - SP_LEG_LIMIT_TOLERANCE);
    assert_int_equal(lim.measured_max, P->leg_length_max + SP_LEG_LIMIT_TOLERANCE);
    for (int a = 0; a < 3; ++a) {
        assert_int_equal(lim.ws_lo[a], P->home.pos[a] + P->workspace_min.pos[a]);
        assert_int_equal(lim.ws_hi[3 + a], P->home.rpy[a] + P->workspace_max.rpy[a]);
    }
    assert_true(lim.joint_reach > 0u && lim.joint_reach < UINT32_MAX);
    assert_int_equal(sp_limits_prepare(NULL, P, 0), SP_E_ARG);
    assert_int_equal(sp_limits_prepare(&lim, NULL, 0), SP_E_ARG);

    /* a box beyond int32 is clamped; an inverted one holds no pose */
    sp_platform_t p = *P;
    p.home.pos[0] = INT32_MAX - 10;
    p.workspace_max.pos[0] = 1000;
    p.workspace_min.rpy[2] = 5;
    p.workspace_max.rpy[2] = -5;
    assert_int_equal(sp_limits_prepare(&lim, &p, 0), SP_OK);
    assert_int_equal(lim.ws_hi[0], INT32_MAX);
    assert_true(lim.ws_lo[5] > lim.ws_hi[5]);
    assert_int_equal(sp_limits_in_workspace(&lim, &p.home), 0);

    /* a margin wider than half the stroke rejects every leg */
    assert_int_equal(sp_limits_prepare(&lim, P, (P->leg_length_max - P->leg_length_min) / 2 + 1), SP_OK);
    sp_q24_t mid[SP_LEGS];
    for (int i = 0; i < SP_LEGS; ++i) {
        mid[i] = P->leg_length_min + (P->leg_length_max - P->leg_length_min) / 2;
    }
    assert_int_equal(sp_limits_lengths_ok(&lim, mid), 0);
}

static void test_limits_workspace_edges(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    for (int a = 0; a < 6; ++a) {
        sp_pose_t q = P->home;
        sp_q24_t *v = (a < 3) ? &q.pos[a] : &q.rpy[a - 3];
        *v = lim.ws_hi[a];
        assert_int_equal(sp_limits_in_workspace(&lim, &q), 1);
        *v = lim.ws_hi[a] + 1;
        assert_int_equal(sp_limits_in_workspace(&lim, &q), 0);
        *v = lim.ws_lo[a];
        assert_int_equal(sp_limits_in_workspace(&lim, &q), 1);
        *v = lim.ws_lo[a] - 1;
        assert_int_equal(sp_limits_in_workspace(&lim, &q), 0);
    }
}

/* The bound never claims a pose reachable that the IK says is not, and
 * the reachability of a pose is exactly its IK's verdict. */
static void test_limits_reachable_near_is_sufficient(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    uint64_t rng = 0x5EEDu;
    int near = 0;
    int checked = 0;
    for (int n = 0; n < 4000; ++n) {
        sp_pose_t base = random_pose(&rng, 0.15, 0.2);
        sp_q24_t base_len[SP_LEGS];
        if (!sp_limits_pose_reachable(&lim, P, &base, base_len)) {
            continue;
        }
        double step = pow(10.0, tu_uniform(&rng, -6.0, -1.0)); /* 1 um .. 0.1 m */
        sp_pose_t q = base;
        for (int k = 0; k < 3; ++k) {
            q.pos[k] += q24(tu_uniform(&rng, -step, step));
            q.rpy[k] += q24(tu_uniform(&rng, -step, step));
        }
        sp_ik_t ik;
        int ik_ok = sp_inverse_kinematics(P, &q, &ik) == SP_OK && sp_limits_lengths_ok(&lim, ik.length);
        int reach = sp_limits_legs_reachable(&lim, P, &q, NULL);
        assert_int_equal(reach, ik_ok);
        if (sp_limits_reachable_near(&lim, &base, base_len, &q)) {
            assert_true(ik_ok);
            ++near;
        }
        ++checked;
    }
    assert_true(checked > 2000);
    assert_true(near > checked / 4); /* the bound decides most small steps */
}

/* sp_limits_reachable_near as first written: 64-bit sums and products,
 * each leg's two ends compared in int64. */
static int plain_reachable_near(const sp_limits_t *lim, const sp_pose_t *base, const sp_q24_t base_length[SP_LEGS],
                                const sp_pose_t *pose)
{
    uint64_t dpos = 0u, drot = 0u;
    for (int k = 0; k < 3; ++k) {
        dpos += (uint64_t)llabs((int64_t)pose->pos[k] - base->pos[k]);
        drot += (uint64_t)llabs((int64_t)pose->rpy[k] - base->rpy[k]);
    }
    if (drot >= (UINT64_C(1) << 31) || lim->joint_reach == UINT32_MAX) {
        return 0;
    }
    uint64_t delta = dpos + (((uint64_t)lim->joint_reach * drot) >> 24) + 5u;
    if (delta >= (UINT64_C(1) << 31)) {
        return 0;
    }
    for (int k = 0; k < SP_LEGS; ++k) {
        int64_t l = base_length[k];
        if (l - (int64_t)delta < lim->length_min || l + (int64_t)delta > lim->length_max) {
            return 0;
        }
    }
    return 1;
}

/* sp_limits_reachable_near against plain_reachable_near, verdict for
 * verdict: random bases and lengths (some at and beyond the margins),
 * steps from 0 to beyond 128 rad, margins from none to an empty stroke,
 * platforms too large to bound. */
static void test_limits_reachable_near_against_plain(void **state)
{
    (void)state;
    uint64_t rng = 0xBEEFu;
    int yes = 0;
    int no = 0;
    for (int n = 0; n < 20000; ++n) {
        sp_limits_t lim = default_limits();
        if (n % 50 == 0) {
            lim.joint_reach = UINT32_MAX;
        } else if (n % 50 == 1) {
            lim.length_min = lim.length_max + 1; /* an empty stroke */
        } else if (n % 50 == 2) {
            lim.length_min = INT32_MIN;
            lim.length_max = INT32_MAX;
        }
        sp_pose_t base = random_pose(&rng, 0.2, 0.3);
        sp_q24_t len[SP_LEGS];
        for (int i = 0; i < SP_LEGS; ++i) {
            double span = (double)lim.length_max - (double)lim.length_min;
            double f = tu_uniform(&rng, -0.05, 1.05);
            double l = (double)lim.length_min + f * (span > 0 ? span : 1e6);
            len[i] = (sp_q24_t)fmax(fmin(l, 2147483647.0), -2147483648.0);
            if (n % 7 == 3) {
                len[i] = (i % 2) ? lim.length_min : lim.length_max; /* at the margins */
            }
        }
        double step = (n % 97 == 0) ? 200.0 : pow(10.0, tu_uniform(&rng, -7.0, 0.5));
        sp_pose_t q = base;
        for (int k = 0; k < 3; ++k) {
            q.pos[k] = (sp_q24_t)fmax(fmin(q.pos[k] + tu_uniform(&rng, -step, step) * 16777216.0, 2147483647.0),
                                      -2147483648.0);
            q.rpy[k] = (sp_q24_t)fmax(fmin(q.rpy[k] + tu_uniform(&rng, -step, step) * 16777216.0, 2147483647.0),
                                      -2147483648.0);
        }
        if (n % 7 == 4 || n % 7 == 5) {
            /* every leg exactly at, or one LSB beyond, the bound's ends */
            uint64_t dpos = 0u, drot = 0u;
            for (int k = 0; k < 3; ++k) {
                dpos += (uint64_t)llabs((int64_t)q.pos[k] - base.pos[k]);
                drot += (uint64_t)llabs((int64_t)q.rpy[k] - base.rpy[k]);
            }
            int64_t delta = (int64_t)(dpos + (((uint64_t)lim.joint_reach * drot) >> 24) + 5u);
            int64_t out = (n % 7 == 5) ? 1 : 0;
            for (int i = 0; i < SP_LEGS; ++i) {
                int64_t l = (i == n % SP_LEGS) ? lim.length_min + delta - out : lim.length_max - delta + out;
                len[i] = (sp_q24_t)((l > INT32_MAX) ? INT32_MAX : ((l < INT32_MIN) ? INT32_MIN : l));
            }
        }
        int want = plain_reachable_near(&lim, &base, len, &q);
        assert_int_equal(sp_limits_reachable_near(&lim, &base, len, &q), want);
        yes += want;
        no += !want;
    }
    assert_true(yes > 2000 && no > 2000);
}

/* sp_limits_pose_reachable_from gives sp_limits_pose_reachable's verdict
 * (its plain reference) with and without the base's lengths, for ends
 * near and far from the base, inside and outside the workspace box and
 * the strokes; near ends are decided without the IK. */
static void test_limits_reachable_from_is_pose_reachable(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    uint64_t rng = 0xF00Du;
    int by_bound = 0;
    int refused_box = 0;
    int refused_legs = 0;
    int accepted = 0;
    for (int n = 0; n < 4000; ++n) {
        sp_pose_t base = random_pose(&rng, 0.1, 0.1);
        sp_q24_t base_len[SP_LEGS];
        if (!sp_limits_pose_reachable(&lim, P, &base, base_len)) {
            continue;
        }
        double step = pow(10.0, tu_uniform(&rng, -4.0, 0.0)); /* 0.1 mm .. 1 m, rad */
        sp_pose_t q = base;
        for (int k = 0; k < 3; ++k) {
            q.pos[k] += q24(tu_uniform(&rng, -step, step));
            q.rpy[k] += q24(tu_uniform(&rng, -step, step));
        }
        int want = sp_limits_pose_reachable(&lim, P, &q, NULL);
        assert_int_equal(sp_limits_pose_reachable_from(&lim, P, &base, base_len, &q), want);
        assert_int_equal(sp_limits_pose_reachable_from(&lim, P, &base, NULL, &q), want);
        accepted += want;
        if (!want) {
            refused_box += !sp_limits_in_workspace(&lim, &q);
            refused_legs += sp_limits_in_workspace(&lim, &q);
        }
        by_bound += sp_limits_in_workspace(&lim, &q) && sp_limits_reachable_near(&lim, &base, base_len, &q);
    }
    assert_true(accepted > 500);
    assert_true(by_bound > 500);
    assert_true(refused_box > 100);
    assert_true(refused_legs > 10);
}

/* sp_limits_setpoints_ok's plain reference: six signed comparisons a leg. */
static int plain_setpoints_ok(const sp_limits_t *lim, const sp_q24_t length[SP_LEGS], const sp_q24_t rate[SP_LEGS],
                              const sp_q8_t force[SP_LEGS])
{
    for (int i = 0; i < SP_LEGS; ++i) {
        if (length[i] < lim->length_min || length[i] > lim->length_max || (int64_t)rate[i] > lim->rate_max ||
            (int64_t)rate[i] < -(int64_t)lim->rate_max || (int64_t)force[i] > lim->force_max ||
            (int64_t)force[i] < -(int64_t)lim->force_max) {
            return 0;
        }
    }
    return 1;
}

/* A value near one of the bounds (or anywhere, or an int32 extreme). */
static int32_t near_bound(uint64_t *rng, int32_t lo, int32_t hi)
{
    double r = tu_uniform(rng, 0.0, 1.0);
    int64_t v;
    if (r < 0.1) {
        return (r < 0.05) ? INT32_MIN : INT32_MAX;
    }
    if (r < 0.3) {
        v = (int64_t)tu_uniform(rng, -2147483648.0, 2147483647.0);
    } else {
        v = ((r < 0.65) ? (int64_t)lo : (int64_t)hi) + (int64_t)tu_uniform(rng, -3.0, 3.99);
    }
    return (int32_t)((v > INT32_MAX) ? INT32_MAX : ((v < INT32_MIN) ? INT32_MIN : v));
}

/* sp_limits_setpoints_ok (one unsigned compare a bound pair) against the
 * plain reference on values at and around every bound and the int32
 * extremes, for limits from the platform's to empty and negative ones. */
static void test_limits_setpoints_reference(void **state)
{
    (void)state;
    uint64_t rng = 97;
    int ok = 0;
    for (int n = 0; n < 20000; ++n) {
        sp_limits_t lim = default_limits();
        sp_q24_t len[SP_LEGS], rate[SP_LEGS];
        sp_q8_t force[SP_LEGS];
        if (n % 5 == 1) { /* any limits: empty, negative, extreme */
            lim.length_min = near_bound(&rng, lim.length_min, lim.length_max);
            lim.length_max = near_bound(&rng, lim.length_min, lim.length_max);
            lim.rate_max = near_bound(&rng, -lim.rate_max, lim.rate_max);
            lim.force_max = near_bound(&rng, -lim.force_max, lim.force_max);
        }
        for (int i = 0; i < SP_LEGS; ++i) {
            /* mostly inside, so that later legs are reached too */
            int inside = tu_uniform(&rng, 0.0, 1.0) < 0.9;
            len[i] = inside ? lim.length_min : near_bound(&rng, lim.length_min, lim.length_max);
            rate[i] = inside ? 0 : near_bound(&rng, -(lim.rate_max | 1), lim.rate_max);
            force[i] = inside ? 0 : near_bound(&rng, -(lim.force_max | 1), lim.force_max);
        }
        int want = plain_setpoints_ok(&lim, len, rate, force);
        assert_int_equal(sp_limits_setpoints_ok(&lim, len, rate, force), want);
        ok += want;
    }
    assert_true(ok > 1000 && ok < 19000);
}

static void test_limits_setpoints_and_measured(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    sp_q24_t len[SP_LEGS];
    sp_q24_t rate[SP_LEGS] = {0};
    sp_q8_t force[SP_LEGS] = {0};
    for (int i = 0; i < SP_LEGS; ++i) {
        len[i] = lim.length_min;
    }
    assert_int_equal(sp_limits_setpoints_ok(&lim, len, rate, force), 1);
    len[3] = lim.length_min - 1;
    assert_int_equal(sp_limits_setpoints_ok(&lim, len, rate, force), 0);
    len[3] = lim.length_max;
    rate[2] = -lim.rate_max;
    force[5] = lim.force_max;
    assert_int_equal(sp_limits_setpoints_ok(&lim, len, rate, force), 1);
    rate[2] = -lim.rate_max - 1;
    assert_int_equal(sp_limits_setpoints_ok(&lim, len, rate, force), 0);
    rate[2] = 0;
    force[5] = lim.force_max + 1;
    assert_int_equal(sp_limits_setpoints_ok(&lim, len, rate, force), 0);

    assert_int_equal(sp_limits_measured_out(&lim, P->leg_length_max + SP_LEG_LIMIT_TOLERANCE), 0);
    assert_int_equal(sp_limits_measured_out(&lim, P->leg_length_max + SP_LEG_LIMIT_TOLERANCE + 1), 1);
    assert_int_equal(sp_limits_measured_out(&lim, P->leg_length_min - SP_LEG_LIMIT_TOLERANCE - 1), 1);
}

/* ---- stream filter ---------------------------------------------------------- */

static void test_stream_follows_within_limits(void **state)
{
    (void)state;
    sp_ctrl_config_t cfg;
    sp_stream_gains_t g;
    sp_stream_t s;
    sp_motion_t at_home;
    sp_limits_t lim = default_limits();
    assert_int_equal(sp_ctrl_default_config(&cfg, P), SP_OK);
    assert_int_equal(sp_stream_gains(&g, cfg.tick_us, cfg.stream_omega), SP_OK);
    assert_int_equal(g.flags, 0u);
    assert_int_equal(g.dt, 16777); /* 1 ms in Q24 */
    sp_motion_at_rest(&at_home, &P->home);
    sp_stream_start(&s, &at_home);
    sp_motion_t out = at_home;
    assert_int_equal(sp_stream_settled(&out, &P->home), 1);

    sp_pose_t target = P->home;
    target.pos[0] += SP_Q24_MILLI(40);
    target.rpy[2] += SP_Q24_MILLI(30);
    assert_int_equal(sp_stream_offer(&s, &lim, P, &target, &P->home, NULL), 1);
    sp_flags_t flags = 0u;
    double vmax = 0.0;
    double amax = 0.0;
    for (int t = 0; t < 3000; ++t) {
        sp_stream_step(&s, &g, &cfg.move, &out, &flags);
        vmax = fmax(vmax, fabs((double)out.vel[0]));
        amax = fmax(amax, fabs((double)out.acc[0]));
    }
    assert_int_equal(flags, 0u);
    assert_true(vmax <= (double)cfg.move.vel_max[0]);
    assert_true(amax <= (double)cfg.move.acc_max[0]);
    assert_true(vmax > 0.5 * (double)cfg.move.vel_max[0]); /* it did move */
    assert_int_equal(sp_stream_settled(&out, &target), 1);
    assert_int_equal(out.pose.pos[0], target.pos[0]);

    /* after stop: the target is home and nothing more is taken */
    sp_stream_stop(&s, &P->home);
    assert_int_equal(sp_stream_offer(&s, &lim, P, &target, &P->home, NULL), 0);
    assert_int_equal(s.target.pos[0], P->home.pos[0]);

    /* a bandwidth whose square leaves Q24 flags every step */
    assert_int_equal(sp_stream_gains(&g, 1000u, 100 * SP_Q24_ONE), SP_OK);
    assert_int_equal(g.flags, SP_FLAG_OVERFLOW);
    flags = 0u;
    sp_stream_step(&s, &g, &cfg.move, &out, &flags);
    assert_int_equal(flags, SP_FLAG_OVERFLOW);
    assert_int_equal(sp_stream_gains(NULL, 1000u, 0), SP_E_ARG);
    /* a tick of 128 s or more: dt saturates (flagged), never wraps */
    assert_int_equal(sp_stream_gains(&g, 127999999u, SP_Q24_ONE), SP_OK);
    assert_int_equal(g.flags, 0u);
    assert_int_equal(g.dt, 2147483631); /* floor(127999999 2^24 / 10^6) */
    assert_int_equal(sp_stream_gains(&g, 128000000u, SP_Q24_ONE), SP_OK);
    assert_int_equal(g.flags, SP_FLAG_OVERFLOW);
    assert_int_equal(g.dt, INT32_MAX);
    assert_int_equal(sp_stream_gains(&g, UINT32_MAX, SP_Q24_ONE), SP_OK);
    assert_int_equal(g.flags, SP_FLAG_OVERFLOW);
    assert_int_equal(g.dt, INT32_MAX);
}

/* The filter's step round(v dt / 2^24) (Q48 x Q24 -> Q48): sp_mul64's,
 * except that its ties are rounded up (not away from zero) while |v dt| <
 * 2^61 (the firmware's spi_mul64_up; it takes sp_mul64's path beyond):
 * they differ by 1 at a negative tie alone. */
static int64_t plain_step(int64_t v, int32_t dt, sp_flags_t *flags)
{
    int64_t r = sp_mul64(v, dt, 24u, flags);
    int64_t ph = (v >> 32) * dt; /* the high word's product, below 2^55 */
    int tie = (((uint64_t)(v & 0xFFFFFF) * (uint32_t)dt) & 0xFFFFFFu) == 0x800000u;
    if (tie && (v < 0) != (dt < 0) && ph >= -(INT64_C(1) << 53) && ph < (INT64_C(1) << 53)) {
        r += 1;
    }
    return r;
}

/* The stream filter's plain reference: its first version, every sum
 * saturating through the public fixed-point functions. */
static void plain_stream_step(int64_t x[6], int64_t v[6], const sp_pose_t *target, const sp_stream_gains_t *g,
                              const sp_move_limits_t *move, sp_motion_t *m, sp_flags_t *flags)
{
    *flags |= g->flags;
    for (unsigned a = 0u; a < 6u; ++a) {
        sp_q24_t t = (a < 3u) ? target->pos[a] : target->rpy[a - 3u];
        int64_t t48 = (int64_t)t * (INT64_C(1) << 24);
        int64_t vmax = (int64_t)move->vel_max[a] * (INT64_C(1) << 24);
        int32_t amax = move->acc_max[a];
        int32_t acmd = 0;
        sp_q24_t *px = (a < 3u) ? &m->pose.pos[a] : &m->pose.rpy[a - 3u];
        sp_q24_t *pv = (a < 3u) ? &m->vel[a] : &m->rpy_rate[a - 3u];
        sp_q24_t *pa = (a < 3u) ? &m->acc[a] : &m->rpy_acc[a - 3u];
        if (x[a] == t48 && v[a] == 0) {
            *px = t;
            *pv = 0;
            *pa = 0;
            continue;
        }
        int32_t err = sp_narrow(sp_add64(t48, -x[a], flags), 24u, flags);
        acmd = sp_sub(sp_mul(g->w2, err, 24u, flags), sp_mul(g->two_w, (int32_t)sp_rshift_round(v[a], 24u), 24u, flags),
                      flags);
        acmd = acmd > amax ? amax : (acmd < -amax ? -amax : acmd);
        v[a] += (int64_t)acmd * g->dt;
        v[a] = v[a] > vmax ? vmax : (v[a] < -vmax ? -vmax : v[a]);
        x[a] = sp_add64(x[a], plain_step(v[a], g->dt, flags), flags);
        *pa = acmd;
        *pv = (sp_q24_t)sp_rshift_round(v[a], 24u);
        *px = sp_narrow(x[a], 24u, flags);
    }
}

/* sp_stream_step (its common case in 32-bit steps, and the saturating
 * general one) against plain_stream_step bit for bit:
 * outputs, state and flags, over random targets near and far (up to the
 * Q24 range), bandwidths, limits and ticks up to 5 s. */
static void test_stream_step_reference(void **state)
{
    (void)state;
    uint64_t rng = 83;
    static const uint32_t ticks[4] = {1000u, 250u, 4000u, 5000000u};
    int far = 0;
    for (int n = 0; n < 400; ++n) {
        sp_stream_gains_t g;
        sp_move_limits_t move;
        sp_stream_t s;
        sp_motion_t from, out, want;
        int64_t x[6], v[6];
        double span = (n % 4 == 3) ? 2147483647.0 : 2e7;
        far += (n % 4 == 3) ? 1 : 0;
        assert_int_equal(sp_stream_gains(&g, ticks[n % 4], (int32_t)tu_uniform(&rng, 1.0, 60.0) * SP_Q24_ONE), SP_OK);
        for (int a = 0; a < 6; ++a) {
            move.vel_max[a] = (int32_t)tu_uniform(&rng, 1e5, 2.1e9);
            move.acc_max[a] = (int32_t)tu_uniform(&rng, 1e5, 2.1e9);
            move.jerk_max[a] = SP_Q24_ONE;
        }
        sp_motion_at_rest(&from, &P->home);
        sp_stream_start(&s, &from);
        for (int a = 0; a < 6; ++a) {
            x[a] = s.x[a];
            v[a] = s.v[a];
        }
        for (int t = 0; t < 300; ++t) {
            sp_flags_t f1 = 0u, f2 = 0u;
            if (t % 60 == 0) {
                for (int a = 0; a < 3; ++a) {
                    s.target.pos[a] = (int32_t)tu_uniform(&rng, -span, span);
                    s.target.rpy[a] = (int32_t)tu_uniform(&rng, -span, span);
                }
            }
            sp_stream_step(&s, &g, &move, &out, &f1);
            plain_stream_step(x, v, &s.target, &g, &move, &want, &f2);
            assert_memory_equal(&out, &want, sizeof out);
            assert_memory_equal(s.x, x, sizeof x);
            assert_memory_equal(s.v, v, sizeof v);
            for (int a = 0; a < 6; ++a) {
                assert_int_equal(s.vq[a], sp_rshift_round(v[a], 24u)); /* the kept damping velocity */
            }
            assert_int_equal(f1, f2);
        }
    }
    assert_int_equal(far, 100);
}

/* One of a few values at the edges of sp_stream_step's common case. */
static int32_t pick(uint64_t *rng, const int32_t *v, unsigned n)
{
    return v[tu_next(rng) % n];
}

/* sp_stream_step against plain_stream_step at the edges of its common
 * case (stream_axis_near): states on and next to the rounding ties of x,
 * v and err (a fraction of one half, one half +- 1 LSB of Q48), a tick of
 * 0.5 s for the step's own ties, errors at the 2^22 bound and velocities
 * at the 2^23 one,
 * limits at 2^30 and 0, velocities at and beyond the limit (the clamp),
 * positions at the 64 m bound: outputs, state and flags, three ticks from
 * each state. */
static void test_stream_step_edges(void **state)
{
    (void)state;
    uint64_t rng = 5;
    static const int32_t frac[] = {0, 1, 0x7FFFFF, 0x800000, 0x800001, 0xFFFFFF, 0x400000};
    static const int32_t near[] = {0,         1,         -1,       2,        -2,        0x3FFFFF, 0x400000,
                                   -0x400000, -0x400001, 0x7FFFFF, 0x800000, -0x800000, -0x800001};
    static const int32_t lims[] = {0, 1, 1 << 22, (1 << 30) - 1, 1 << 30, INT32_MAX, 16777216};
    static const int32_t xis[] = {0, -1, (1 << 30) - 1, -(1 << 30), 1 << 30, -(1 << 30) - 1, 12345678};
    static const uint32_t ticks[] = {1000u, 500000u, 999999u, 1000000u};
    for (int n = 0; n < 4000; ++n) {
        sp_stream_gains_t g;
        sp_move_limits_t move;
        sp_stream_t s;
        sp_motion_t from, out, want;
        int64_t x[6], v[6];
        int32_t omega = (int32_t)tu_uniform(&rng, 0.5, 11.3) * SP_Q24_ONE; /* w^2 up to 121, near 2^31 in Q24 */
        assert_int_equal(sp_stream_gains(&g, ticks[n % 4], (n % 6 == 5) ? -omega : omega), SP_OK);
        sp_motion_at_rest(&from, &P->home);
        sp_stream_start(&s, &from);
        for (int a = 0; a < 6; ++a) {
            int32_t xi = (n % 3 == 0) ? pick(&rng, xis, 7) : (int32_t)tu_uniform(&rng, -3e7, 3e7);
            int32_t vi = (n % 2 == 0) ? pick(&rng, near, 13) : (int32_t)tu_uniform(&rng, -1e7, 1e7);
            move.vel_max[a] = (n % 5 == 0) ? (int32_t)tu_uniform(&rng, 1e5, 5e6) : pick(&rng, lims, 7);
            move.acc_max[a] = (n % 7 == 0) ? pick(&rng, lims, 7) : (int32_t)tu_uniform(&rng, 1e5, 1e8);
            move.jerk_max[a] = SP_Q24_ONE;
            if (n % 11 == 0) {
                vi = move.vel_max[a] - (int32_t)(tu_next(&rng) % 3u); /* at the limit */
            }
            s.x[a] = (int64_t)xi * (INT64_C(1) << 24) + pick(&rng, frac, 7);
            s.v[a] = (int64_t)vi * (INT64_C(1) << 24) + pick(&rng, frac, 7);
            s.vq[a] = (int32_t)sp_rshift_round(s.v[a], 24u);
            int32_t t = (int32_t)((uint32_t)xi + (uint32_t)pick(&rng, near, 13));
            if (a < 3) {
                s.target.pos[a] = t;
            } else {
                s.target.rpy[a - 3] = t;
            }
            x[a] = s.x[a];
            v[a] = s.v[a];
        }
        for (int t = 0; t < 3; ++t) {
            sp_flags_t f1 = 0u, f2 = 0u;
            sp_stream_step(&s, &g, &move, &out, &f1);
            plain_stream_step(x, v, &s.target, &g, &move, &want, &f2);
            assert_memory_equal(&out, &want, sizeof out);
            assert_memory_equal(s.x, x, sizeof x);
            assert_memory_equal(s.v, v, sizeof v);
            for (int a = 0; a < 6; ++a) {
                assert_int_equal(s.vq[a], sp_rshift_round(v[a], 24u));
            }
            assert_int_equal(f1, f2);
        }
    }
}

/* sp_stream_offer (its anchor with the kept room, tested before the
 * reference) against the plain rule, sp_limits_reachable_near around the
 * reference or else the target's own IK, over random walks of targets that
 * wander to the stroke limits and back: the same answers, target by target. */
static void test_stream_offer_reference(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    uint64_t rng = 29;
    int taken = 0, refused = 0, by_ik = 0, out_box = 0;
    for (int n = 0; n < 40; ++n) {
        sp_stream_t s;
        sp_motion_t at_home;
        sp_pose_t ref = P->home;
        sp_q24_t ref_len[SP_LEGS];
        double step = (n % 2 == 0) ? 2e5 : 2e6; /* ~12 mm or ~120 mm a target */
        sp_motion_at_rest(&at_home, &P->home);
        sp_stream_start(&s, &at_home);
        assert_int_equal(sp_limits_pose_reachable(&lim, P, &ref, ref_len), 1);
        sp_pose_t t = P->home;
        for (int k = 0; k < 60; ++k) {
            sp_pose_t want_target = s.target;
            for (int a = 0; a < 3; ++a) {
                double dp = t.pos[a] - P->home.pos[a] + tu_uniform(&rng, -step, step);
                double dr = t.rpy[a] - P->home.rpy[a] + tu_uniform(&rng, -step, step) * 0.5;
                t.pos[a] = P->home.pos[a] + (int32_t)fmax(fmin(dp, 1e7), -1e7); /* within 0.6 m */
                t.rpy[a] = P->home.rpy[a] + (int32_t)fmax(fmin(dr, 1e7), -1e7); /* within 0.6 rad */
            }
            int plain = sp_limits_in_workspace(&lim, &t) && (sp_limits_reachable_near(&lim, &ref, ref_len, &t) ||
                                                             sp_limits_legs_reachable(&lim, P, &t, NULL));
            by_ik += plain && !sp_limits_reachable_near(&lim, &ref, ref_len, &t);
            out_box += !sp_limits_in_workspace(&lim, &t);
            int got = sp_stream_offer(&s, &lim, P, &t, &ref, (k % 5 == 4) ? NULL : ref_len);
            assert_int_equal(got, plain);
            if (got) {
                taken += 1;
                want_target = t;
                /* the reference follows the last target taken */
                ref = t;
                assert_int_equal(sp_limits_pose_reachable(&lim, P, &ref, ref_len), 1);
            } else {
                refused += 1;
                t = s.target;
            }
            assert_memory_equal(&s.target, &want_target, sizeof want_target);
        }
    }
    printf("offer: %d taken, %d refused, %d by IK, %d outside the box\n", taken, refused, by_ik, out_box);
    assert_true(taken > 1500 && refused > 100 && by_ik > 300 && out_box > 30);
}

static void test_stream_offer_rules(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    sp_stream_t s;
    sp_motion_t at_home;
    sp_q24_t home_len[SP_LEGS];
    sp_motion_at_rest(&at_home, &P->home);
    sp_stream_start(&s, &at_home);
    assert_int_equal(sp_limits_pose_reachable(&lim, P, &P->home, home_len), 1);

    /* near the reference: taken by the bound, the reference becomes the
     * anchor with its legs' least room to the stroke limits */
    sp_pose_t t = P->home;
    t.pos[2] += SP_Q24_MILLI(1);
    assert_int_equal(sp_stream_offer(&s, &lim, P, &t, &P->home, home_len), 1);
    assert_int_equal(s.anchor_valid, 1);
    assert_memory_equal(&s.anchor, &P->home, sizeof P->home);
    int64_t room = INT64_MAX;
    for (int i = 0; i < SP_LEGS; ++i) {
        int64_t lo = (int64_t)home_len[i] - lim.length_min;
        int64_t hi = (int64_t)lim.length_max - home_len[i];
        room = (lo < room) ? lo : room;
        room = (hi < room) ? hi : room;
    }
    assert_true(room > 0);
    assert_int_equal(s.anchor_room, room);
    /* and its least room to the workspace box, positions and angles apart */
    int64_t box[2] = {INT64_MAX, INT64_MAX};
    for (int a = 0; a < 6; ++a) {
        int64_t at = sp_pose_axis(&P->home, (sp_axis_t)a);
        int64_t lo = at - lim.ws_lo[a], hi = lim.ws_hi[a] - at;
        int64_t r = (lo < hi) ? lo : hi;
        box[a / 3] = (r < box[a / 3]) ? r : box[a / 3];
    }
    assert_true(box[0] > 0 && box[1] > 0);
    assert_int_equal(s.anchor_box[0], box[0]);
    assert_int_equal(s.anchor_box[1], box[1]);
    /* far (the bound is not conclusive) but reachable: its own IK decides
     * and it becomes the anchor */
    int found = 0;
    for (int mrad = 20; mrad <= 500 && !found; mrad += 20) {
        t = P->home;
        t.rpy[2] += SP_Q24_MILLI(mrad);
        found = !sp_limits_reachable_near(&lim, &P->home, home_len, &t) && sp_limits_pose_reachable(&lim, P, &t, NULL);
    }
    assert_true(found);
    assert_int_equal(sp_stream_offer(&s, &lim, P, &t, &P->home, home_len), 1);
    assert_int_equal(s.anchor_valid, 1);
    assert_memory_equal(&s.anchor, &t, sizeof t);
    /* outside the workspace: refused, the target in force stays */
    sp_pose_t out = P->home;
    out.pos[0] = lim.ws_hi[0] + 1;
    assert_int_equal(sp_stream_offer(&s, &lim, P, &out, &P->home, home_len), 0);
    assert_memory_equal(&s.target, &t, sizeof t);
    /* the target in force again is taken without any test */
    assert_int_equal(sp_stream_offer(&s, &lim, P, &t, &P->home, NULL), 1);
}

/* ---- estimate --------------------------------------------------------------- */

static void test_estimate_cold_warm_and_failure(void **state)
{
    (void)state;
    sp_estimate_t e;
    sp_ik_t ik;
    uint32_t it = 99u;
    uint64_t rng = 42u;
    sp_estimate_init(&e, &P->park);
    assert_int_equal(e.valid, 0);

    /* cold start far from the parked pose (the reference is unknown) */
    sp_pose_t truth = random_pose(&rng, 0.1, 0.1);
    assert_int_equal(sp_inverse_kinematics(P, &truth, &ik), SP_OK);
    assert_int_equal(sp_estimate_step(P, &e, ik.length, &P->home, NULL, &it), SP_OK);
    assert_int_equal(e.valid, 1);
    assert_true(it >= 2u && it <= SP_ESTIMATE_COLD_STEPS);
    for (int k = 0; k < 3; ++k) {
        assert_true(labs((long)e.pose.pos[k] - truth.pos[k]) <= 17); /* 1 um */
        assert_true(labs((long)e.pose.rpy[k] - truth.rpy[k]) <= 84); /* 5 urad */
    }

    /* lengths no pose has: the estimate is lost, the last pose kept */
    sp_pose_t last = e.pose;
    sp_q24_t bad[SP_LEGS];
    for (int i = 0; i < SP_LEGS; ++i) {
        bad[i] = (i < 3) ? P->leg_length_min / 4 : P->leg_length_max * 4;
    }
    assert_int_not_equal(sp_estimate_step(P, &e, bad, &P->home, NULL, &it), SP_OK);
    assert_int_equal(e.valid, 0);
    assert_memory_equal(&e.pose, &last, sizeof last);
}

/* An estimate as the controller leaves it after a tick at reference `ref`:
 * the last estimate at `last`, the factorisation of J^T at ref (the
 * inverse dynamics') and ref's lengths and sines (its IK) into *cache. */
static void estimate_at(sp_estimate_t *e, sp_fk_cache_t *cache, const sp_pose_t *ref, const sp_pose_t *last)
{
    sp_ik_t ik_ref;
    sp_q8_t force[SP_LEGS];
    sp_motion_t m;
    sp_motion_at_rest(&m, ref);
    sp_estimate_init(e, &P->park);
    e->pose = *last;
    e->valid = 1u;
    assert_int_equal(sp_inverse_kinematics(P, ref, &ik_ref), SP_OK);
    assert_int_equal(sp_inverse_dynamics_lu(P, &m, &ik_ref, NULL, force, &e->ref_lu), SP_OK);
    assert_int_equal(e->ref_lu.valid, 1);
    for (int i = 0; i < SP_LEGS; ++i) {
        cache->length[i] = ik_ref.length[i];
    }
    for (int k = 0; k < 6; ++k) {
        cache->sc[k] = ik_ref.sc[k];
    }
}

/* The largest |length - cache length|, Q24. */
static int32_t largest_dl(const sp_q24_t length[SP_LEGS], const sp_fk_cache_t *cache)
{
    int32_t w = 0;
    for (int i = 0; i < SP_LEGS; ++i) {
        int32_t d = abs(length[i] - cache->length[i]);
        w = d > w ? d : w;
    }
    return w;
}

/* The single step from the reference, within SP_ESTIMATE_STEP_MAX: 1 um
 * and 1 urad of full Newton on every axis, over random references in the
 * workspace and tracking errors of random size and direction. */
static void test_estimate_step_accuracy(void **state)
{
    (void)state;
    uint64_t rng = 7u;
    sp_fk_options_t opt;
    long worst_pos = 0;
    long worst_rot = 0;
    int steps = 0;
    int near_bound = 0;
    sp_fk_default_options(&opt);
    for (int n = 0; n < 4000; ++n) {
        sp_pose_t ref = random_pose(&rng, 0.3, 0.25);
        sp_pose_t truth = ref;
        double size = tu_uniform(&rng, 0.0, 0.0006); /* up to 0.6 mm / 0.6 mrad per axis */
        for (int k = 0; k < 3; ++k) {
            truth.pos[k] += q24(tu_uniform(&rng, -size, size));
            truth.rpy[k] += q24(tu_uniform(&rng, -size, size));
        }
        sp_ik_t ik_truth;
        if (sp_inverse_kinematics(P, &ref, &ik_truth) != SP_OK ||
            sp_inverse_kinematics(P, &truth, &ik_truth) != SP_OK) {
            continue;
        }
        sp_estimate_t e;
        sp_fk_cache_t cache;
        uint32_t it = 0u;
        estimate_at(&e, &cache, &ref, &ref);
        int32_t dl = largest_dl(ik_truth.length, &cache);
        if (dl > SP_ESTIMATE_STEP_MAX) {
            continue;
        }
        ++steps;
        near_bound += (dl > SP_ESTIMATE_STEP_MAX * 3 / 4) ? 1 : 0;
        assert_int_equal(sp_estimate_step(P, &e, ik_truth.length, &ref, &cache, &it), SP_OK);
        assert_int_equal(it, 1u);
        /* exactly the single step */
        sp_pose_t one;
        sp_q24_t d[SP_LEGS];
        for (int i = 0; i < SP_LEGS; ++i) {
            d[i] = ik_truth.length[i] - cache.length[i];
        }
        assert_int_equal(sp_fk_chord_step(&e.ref_lu, &ref, cache.sc, d, &one), SP_OK);
        assert_memory_equal(&one, &e.pose, sizeof one);
        /* against full Newton from the reference */
        sp_pose_t newton;
        assert_int_equal(sp_forward_kinematics(P, ik_truth.length, &ref, &opt, &newton, NULL, NULL), SP_OK);
        for (int k = 0; k < 3; ++k) {
            long ep = labs((long)e.pose.pos[k] - newton.pos[k]);
            long er = labs((long)e.pose.rpy[k] - newton.rpy[k]);
            worst_pos = ep > worst_pos ? ep : worst_pos;
            worst_rot = er > worst_rot ? er : worst_rot;
        }
    }
    printf("single step: %d poses (%d beyond 3/4 of the bound), worst %.3f um, %.3f urad from Newton\n", steps,
           near_bound, (double)worst_pos / 16.777216, (double)worst_rot / 16.777216);
    assert_true(steps > 1000 && near_bound > 100);
    assert_true(worst_pos <= 16); /* 16 LSB = 0.95 um */
    assert_true(worst_rot <= 16); /* 0.95 urad */
}

/* Beyond SP_ESTIMATE_STEP_MAX: chord steps from the reference, the same
 * pose as sp_fk_chord (and within Newton's tolerance of it); a missing
 * factorisation or reference: full Newton from the last estimate. */
static void test_estimate_fallbacks(void **state)
{
    (void)state;
    uint64_t rng = 11u;
    sp_fk_options_t opt;
    int beyond = 0;
    sp_fk_default_options(&opt);
    for (int n = 0; n < 300; ++n) {
        sp_pose_t ref = random_pose(&rng, 0.3, 0.25);
        sp_pose_t truth = ref;
        truth.pos[n % 3] += q24(tu_uniform(&rng, -0.003, 0.003));
        truth.rpy[(n + 1) % 3] += q24(tu_uniform(&rng, -0.003, 0.003));
        sp_ik_t ik_truth;
        if (sp_inverse_kinematics(P, &ref, &ik_truth) != SP_OK ||
            sp_inverse_kinematics(P, &truth, &ik_truth) != SP_OK) {
            continue;
        }
        sp_estimate_t e;
        sp_estimate_t keep;
        sp_fk_cache_t cache;
        uint32_t it = 0u;
        sp_pose_t want;
        sp_fk_info_t info;
        estimate_at(&e, &cache, &ref, &ref);
        keep = e;
        if (largest_dl(ik_truth.length, &cache) <= SP_ESTIMATE_STEP_MAX) {
            continue;
        }
        ++beyond;
        assert_int_equal(sp_estimate_step(P, &e, ik_truth.length, &ref, &cache, &it), SP_OK);
        sp_fk_cache_t c = cache;
        sp_fk_options_t copt = opt;
        copt.max_iterations = SP_ESTIMATE_CHORD_STEPS;
        assert_int_equal(sp_fk_chord(P, ik_truth.length, &ref, &keep.ref_lu, &copt, &c, &want, &info), SP_OK);
        assert_memory_equal(&want, &e.pose, sizeof want);
        assert_int_equal(it, info.iterations);
        assert_true(it >= 1u);

        /* no factorisation at the reference, or no reference lengths:
         * full Newton from the last estimate, bit for bit */
        assert_int_equal(sp_forward_kinematics(P, ik_truth.length, &ref, &opt, &want, NULL, &info), SP_OK);
        for (int variant = 0; variant < 2; ++variant) {
            sp_estimate_t f = keep;
            if (variant == 0) {
                f.ref_lu.valid = 0u;
            }
            assert_int_equal(sp_estimate_step(P, &f, ik_truth.length, &ref, variant == 0 ? &cache : NULL, &it), SP_OK);
            assert_memory_equal(&want, &f.pose, sizeof want);
            assert_int_equal(it, info.iterations);
        }
        /* a small step, but without a factorisation: Newton as well */
        sp_estimate_t f = keep;
        f.ref_lu.valid = 0u;
        assert_int_equal(sp_estimate_step(P, &f, cache.length, &ref, &cache, &it), SP_OK);
        assert_int_equal(sp_forward_kinematics(P, cache.length, &ref, &opt, &want, NULL, &info), SP_OK);
        assert_memory_equal(&want, &f.pose, sizeof want);
    }
    assert_true(beyond > 100);

    /* the reference's own lengths: the reference itself, one step */
    sp_estimate_t z;
    sp_fk_cache_t zc;
    uint32_t zit = 0u;
    estimate_at(&z, &zc, &P->home, &P->home);
    z.pose.pos[2] += 5; /* last estimate a little off */
    assert_int_equal(sp_estimate_step(P, &z, zc.length, &P->home, &zc, &zit), SP_OK);
    assert_int_equal(zit, 1u);
    assert_memory_equal(&z.pose, &P->home, sizeof z.pose);

    /* the step from the reference lands more than the allowed jump away
     * from the last estimate: Newton from the last estimate decides (and
     * reports the discontinuity) */
    sp_estimate_t e;
    sp_fk_cache_t cache;
    sp_pose_t far = P->home;
    uint32_t it = 0u;
    far.pos[0] += SP_Q24_MILLI(80);
    estimate_at(&e, &cache, &P->home, &far);
    assert_int_equal(sp_estimate_step(P, &e, cache.length, &P->home, &cache, &it), SP_E_DISCONTINUITY);
    assert_int_equal(e.valid, 0);
    assert_memory_equal(&e.pose, &far, sizeof far);
}

/* sp_fk_newton_cached is sp_forward_kinematics with the cache of the
 * result: the same pose and info, bit for bit, and sp_fk_cache_of's cache. */
static void test_fk_newton_cached(void **state)
{
    (void)state;
    uint64_t rng = 99u;
    sp_fk_options_t opt;
    sp_fk_default_options(&opt);
    for (int n = 0; n < 500; ++n) {
        sp_pose_t truth = random_pose(&rng, 0.15, 0.2);
        sp_pose_t guess = truth;
        guess.pos[n % 3] += q24(tu_uniform(&rng, -0.01, 0.01));
        sp_ik_t ik;
        if (sp_inverse_kinematics(P, &truth, &ik) != SP_OK) {
            continue;
        }
        sp_pose_t a;
        sp_pose_t b;
        sp_fk_info_t ia;
        sp_fk_info_t ib;
        sp_fk_cache_t cache;
        sp_fk_cache_t want;
        sp_status_t sa = sp_forward_kinematics(P, ik.length, &guess, &opt, &a, NULL, &ia);
        sp_status_t sb = sp_fk_newton_cached(P, ik.length, &guess, &opt, &cache, &b, &ib);
        assert_int_equal(sa, sb);
        assert_memory_equal(&a, &b, sizeof a);
        assert_int_equal(ia.iterations, ib.iterations);
        assert_int_equal(ia.residual, ib.residual);
        if (sa == SP_OK) {
            assert_int_equal(sp_fk_cache_of(P, &b, &want), SP_OK);
            assert_memory_equal(&cache, &want, sizeof want);
        }
    }
    sp_pose_t out;
    sp_ik_t home_ik;
    assert_int_equal(sp_inverse_kinematics(P, &P->home, &home_ik), SP_OK);
    assert_int_equal(sp_fk_newton_cached(P, home_ik.length, &P->home, &opt, NULL, &out, NULL), SP_E_ARG);
}

/* ---- setpoints --------------------------------------------------------------- */

static void test_setpoints_of(void **state)
{
    (void)state;
    sp_limits_t lim = default_limits();
    sp_setpoint_t sp[SP_LEGS];
    sp_setpoint_t before[SP_LEGS];
    sp_lu6_t lu;
    sp_motion_t m;
    sp_ik_t ik;
    sp_q24_t rate[SP_LEGS];
    sp_q8_t force[SP_LEGS];
    sp_friction_t fr;
    sp_model_t model;
    sp_jacobian_t jac;

    assert_int_equal(sp_friction_prepare(P, &fr), SP_OK);
    sp_motion_at_rest(&m, &P->home);
    m.vel[0] = SP_Q24_MILLI(100);
    m.rpy_acc[2] = SP_Q24_ONE / 2;
    assert_int_equal(sp_setpoints_of(P, &lim, &fr, &m, SP_FF_DYNAMICS, sp, &lu, &model), SP_OK);
    assert_int_equal(lu.valid, 1);
    assert_int_equal(sp_inverse_kinematics(P, &m.pose, &ik), SP_OK);
    assert_int_equal(sp_leg_rates(&ik, m.vel, m.rpy_rate, rate), SP_OK);
    assert_int_equal(sp_inverse_dynamics(P, &m, &ik, NULL, force), SP_OK);
    assert_int_equal(sp_jacobian(&ik, &jac), SP_OK);
    assert_memory_equal(&model.jac, &jac, sizeof jac);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(sp[i].length, ik.length[i]);
        assert_int_equal(sp[i].velocity, rate[i]);
        assert_int_equal(sp[i].force, force[i]);
        /* the model always carries the friction */
        assert_int_equal(model.force[i], force[i] + sp_friction_force(&fr, (unsigned)i, rate[i]));
    }
    assert_int_equal(sp_setpoints_of(P, &lim, &fr, &m, SP_FF_DYNAMICS | SP_FF_FRICTION, sp, &lu, &model), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(sp[i].force, model.force[i]);
    }
    assert_int_equal(sp_setpoints_of(P, &lim, &fr, &m, SP_FF_FRICTION, sp, &lu, &model), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(sp[i].force, sp_friction_force(&fr, (unsigned)i, rate[i]));
    }
    assert_int_equal(sp_setpoints_of(P, &lim, &fr, &m, 0u, sp, &lu, &model), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        assert_int_equal(sp[i].force, 0);
    }

    /* outside the workspace, or too fast: SP_E_RANGE, setpoints untouched */
    memcpy(before, sp, sizeof before);
    m.pose.pos[1] = lim.ws_hi[1] + 1;
    assert_int_equal(sp_setpoints_of(P, &lim, &fr, &m, SP_FF_DYNAMICS, sp, &lu, &model), SP_E_RANGE);
    m.pose = P->home;
    m.vel[2] = P->leg_velocity_max * 2;
    assert_int_equal(sp_setpoints_of(P, &lim, &fr, &m, SP_FF_DYNAMICS, sp, &lu, &model), SP_E_RANGE);
    assert_memory_equal(sp, before, sizeof before);
}

/* ---- friction and the wrench estimate ------------------------------------------ */

/* F = c_v v + F_c s(v / v_c): against the plain formula in double, over the
 * ramp, its ends and beyond, within one Q8 LSB. */
static void test_friction_force(void **state)
{
    (void)state;
    sp_friction_t fr;
    assert_int_equal(sp_friction_prepare(P, &fr), SP_OK);
    for (int n = -3000; n <= 3000; ++n) {
        sp_q24_t v = (sp_q24_t)(n * 1117); /* about +-0.2 m/s, through +-v_c */
        for (unsigned i = 0u; i < SP_LEGS; ++i) {
            double vd = ref_f24(v);
            double x = vd / ref_f24(fr.velocity);
            double want = ref_f8(fr.viscous[i]) * vd + ref_f8(fr.coulomb[i]) * (x > 1.0 ? 1.0 : (x < -1.0 ? -1.0 : x));
            assert_near(ref_f8(sp_friction_force(&fr, i, v)), want, 0.01, "v %d leg %u", v, i);
        }
    }
    {
        sp_platform_t bad = *P;
        bad.coulomb_friction[2] = -1;
        assert_int_equal(sp_friction_prepare(&bad, &fr), SP_E_ARG);
    }
}

/* The plain reference of sp_wrench_step's arithmetic (sp/estimation/wrench.h), one
 * component at a time, every step written out in int64: the raw input is
 * the kept force path of the previous tick plus the correction, held
 * within [-2^30, 2^30 - 1]; the sections with alpha held within [0, 1],
 * each section's last value in that range (the state cannot leave it:
 * test_wrench_state_stays_in_range); then this tick's force
 * path: d = F_model - F clamped to +-2^29, (J^T d)_k summed exactly and
 * rounded once to Q8, kept for the next tick. */
static void wrench_reference(const int32_t sec_in[SP_WRENCH_SECTIONS][6], int valid, const int64_t kept_in[6],
                             const sp_q8_t model_force[SP_LEGS], const sp_jacobian_t *jac,
                             const sp_q8_t measured[SP_LEGS], const sp_q8_t *correction, sp_q30_t alpha,
                             int32_t wrench_out[6], int64_t kept_out[6])
{
    const int64_t hi = (INT64_C(1) << 30) - 1;
    const int64_t lo = -(INT64_C(1) << 30);
    int64_t a = alpha < 0 ? 0 : (alpha > SP_Q30_ONE ? SP_Q30_ONE : alpha);
    for (int k = 0; k < 6; ++k) {
        int64_t raw = kept_in[k] + (correction != NULL ? correction[k] : 0);
        raw = raw > hi ? hi : (raw < lo ? lo : raw);
        if (valid) {
            for (unsigned n = 0u; n < SP_WRENCH_SECTIONS; ++n) {
                int64_t last = sec_in[n][k];
                assert_true(last >= lo && last <= hi); /* the state's range (test_wrench_state_stays_in_range) */
                raw = last + ((a * (raw - last) + (INT64_C(1) << 29)) >> 30);
                assert_true(raw >= lo && raw <= hi);
            }
        }
        wrench_out[k] = (int32_t)raw;
        int64_t acc = 0;
        for (int i = 0; i < SP_LEGS; ++i) {
            int64_t d = (int64_t)model_force[i] - measured[i];
            d = d > (INT64_C(1) << 29) ? (INT64_C(1) << 29) : (d < -(INT64_C(1) << 29) ? -(INT64_C(1) << 29) : d);
            acc += (int64_t)jac->j[i][k] * d;
        }
        kept_out[k] = (acc + (INT64_C(1) << 27)) >> 28;
    }
}

/* sp_wrench_step equals the plain reference bit for bit: random Jacobians
 * over the whole allowed range (|entry| < 8, Q28), forces of every size up
 * to the int32 range (the clamp on d), kept force paths up to the largest
 * J^T d (6 x 8 x 2^29 < 2^35), corrections of every size or none,
 * sections anywhere in their range [-2^30, 2^30 - 1], its ends included,
 * and gains outside [0, 1]. */
static void test_wrench_matches_reference(void **state)
{
    (void)state;
    uint64_t rng = 2024u;
    for (int n = 0; n < 20000; ++n) {
        sp_model_t model;
        sp_wrench_t w;
        sp_q8_t meas[SP_LEGS];
        sp_q8_t corr[6];
        int32_t want[6];
        int64_t kept[6];
        int64_t want_kept[6];
        int32_t sec[SP_WRENCH_SECTIONS][6];
        int big = (n % 4) == 0;
        for (int i = 0; i < SP_LEGS; ++i) {
            for (int k = 0; k < 6; ++k) {
                model.jac.j[i][k] = big ? tu_i32(&rng) : (int32_t)(tu_i32(&rng) >> 4);
            }
            model.force[i] = big ? tu_i32(&rng) : tu_i32_logscale(&rng);
            meas[i] = big ? tu_i32(&rng) : tu_i32_logscale(&rng);
        }
        sp_wrench_reset(&w);
        for (int k = 0; k < 6; ++k) {
            w.force_wrench[k] = big ? (int64_t)tu_i32(&rng) * 16 : (int64_t)tu_i32_logscale(&rng);
            corr[k] = (n % 5 == 2) ? tu_i32(&rng) : tu_i32_logscale(&rng);
            for (unsigned s = 0u; s < SP_WRENCH_SECTIONS; ++s) {
                int32_t v = tu_i32(&rng);
                w.section[s][k] = (n % 8) == (int)(1u + 2u * s) % 8 ? (v >> 1) : (v >> 3);
                if ((n % 11) == (int)s) {
                    w.section[s][k] = (v < 0) ? -(INT32_C(1) << 30) : (INT32_C(1) << 30) - 1; /* the ends */
                }
            }
        }
        memcpy(sec, w.section, sizeof sec);
        memcpy(kept, w.force_wrench, sizeof kept);
        w.have_force = 1u;
        w.valid = (uint8_t)(n % 3 != 0);
        sp_q30_t alpha = (n % 16) == 5 ? tu_i32(&rng) : (sp_q30_t)(tu_next(&rng) % ((uint64_t)SP_Q30_ONE + 1u));
        const sp_q8_t *c = (n % 7 == 4) ? NULL : corr;
        wrench_reference((const int32_t(*)[6])sec, w.valid, kept, model.force, &model.jac, meas, c, alpha, want,
                         want_kept);
        sp_wrench_step(&w, &model, NULL, meas, c, alpha);
        assert_memory_equal(w.wrench, want, sizeof want);
        assert_memory_equal(w.section[SP_WRENCH_SECTIONS - 1u], want, sizeof want);
        assert_int_equal(w.valid, 1);
        assert_memory_equal(w.force_wrench, want_kept, sizeof want_kept);
        assert_int_equal(w.have_force, 1);
    }
}

/* The plain reference of sp_wrench_smooth's arithmetic (sp/estimation/wrench.h), one
 * component, as it was written before session 15: the section's last
 * value held within [-2^30, 2^30 - 1] before each step, in int64. */
static void smooth_reference(sp_wrench_t *w, unsigned k, int64_t alpha, int64_t jump, unsigned persist, unsigned hold)
{
    const int64_t hi = (INT64_C(1) << 30) - 1;
    const int64_t lo = -(INT64_C(1) << 30);
    int64_t x = w->wrench[k];
    int64_t v;
    int64_t d;
    if (w->follow[k] > 0u) {
        w->follow[k]--;
        w->slow[k] = (int32_t)x;
        w->smooth[k] = (int32_t)x;
        return;
    }
    v = w->slow[k] > hi ? hi : (w->slow[k] < lo ? lo : w->slow[k]);
    v = v + ((alpha * (x - v) + (INT64_C(1) << 29)) >> 30);
    d = x - v;
    if (d > jump || d < -jump) {
        w->excess[k]++;
        if (w->excess[k] >= persist) {
            w->excess[k] = 0u;
            w->follow[k] = (uint8_t)(hold - 1u);
            v = x;
            w->smooth[k] = (int32_t)x;
        } else {
            w->smooth[k] = (int32_t)(d > 0 ? x - jump : x + jump);
        }
    } else {
        w->excess[k] = 0u;
        w->smooth[k] = (int32_t)v;
    }
    w->slow[k] = (int32_t)v;
}

/* The bound that lets sp_wrench_step and sp_wrench_smooth step their
 * sections without holding the last value in range first: from a reset,
 * over ticks of inputs of every size (forces, Jacobians, corrections up to
 * the int32 range, gains outside [0, 1], ticks without a model), every
 * section, the estimate, the smoother's section and the reported value
 * stay within [-2^30, 2^30 - 1]; and the smoother equals its plain
 * reference (which holds its section in range) bit for bit on the way. */
static void test_wrench_state_stays_in_range(void **state)
{
    (void)state;
    const int32_t hi = (INT32_C(1) << 30) - 1;
    const int32_t lo = -(INT32_C(1) << 30);
    uint64_t rng = 1515u;
    sp_wrench_t w;
    sp_wrench_t ref;
    sp_wrench_smooth_t p;
    sp_model_t model;
    sp_wrench_reset(&w);
    for (int n = 0; n < 40000; ++n) {
        sp_q8_t meas[SP_LEGS];
        sp_q8_t corr[6];
        int big = (n / 50) % 3 == 0; /* runs of extreme ticks */
        sp_q30_t alpha = (n % 13) == 7 ? tu_i32(&rng) : (sp_q30_t)(tu_next(&rng) % ((uint64_t)SP_Q30_ONE + 1u));
        for (int i = 0; i < SP_LEGS; ++i) {
            for (int k = 0; k < 6; ++k) {
                model.jac.j[i][k] = big ? tu_i32(&rng) : (int32_t)(tu_i32(&rng) >> 4);
            }
            model.force[i] = big ? tu_i32(&rng) : tu_i32_logscale(&rng);
            meas[i] = big ? tu_i32(&rng) : tu_i32_logscale(&rng);
        }
        for (int k = 0; k < 6; ++k) {
            corr[k] = big ? tu_i32(&rng) : tu_i32_logscale(&rng);
        }
        sp_wrench_step(&w, (n % 331) == 5 ? NULL : &model, NULL, meas, (n % 7) == 3 ? NULL : corr, alpha);
        p.alpha = (n % 17) == 2 ? tu_i32(&rng) : (sp_q30_t)(tu_next(&rng) % ((uint64_t)SP_Q30_ONE + 1u));
        p.jump[0] = (n % 5) == 1 ? tu_i32(&rng) : (int32_t)(tu_next(&rng) % (1u << 20)) + 1;
        p.jump[1] = (n % 5) == 2 ? tu_i32(&rng) : (int32_t)(tu_next(&rng) % (1u << 20)) + 1;
        p.persist = (uint8_t)(tu_next(&rng) % 6u);
        p.hold = (uint8_t)(tu_next(&rng) % 6u);
        ref = w;
        sp_wrench_smooth(&w, &p);
        if (ref.valid && ref.smooth_valid) {
            int64_t a = p.alpha < 0 ? 0 : (p.alpha > SP_Q30_ONE ? SP_Q30_ONE : p.alpha);
            unsigned persist = p.persist < 1u ? 1u : p.persist;
            unsigned hold = p.hold < 1u ? 1u : p.hold;
            for (unsigned k = 0u; k < 6u; ++k) {
                int64_t j = p.jump[k < 3u ? 0 : 1];
                j = j < 1 ? 1 : (j > (INT64_C(1) << 30) ? (INT64_C(1) << 30) : j);
                smooth_reference(&ref, k, a, j, persist, hold);
            }
            assert_memory_equal(w.smooth, ref.smooth, sizeof w.smooth);
            assert_memory_equal(w.slow, ref.slow, sizeof w.slow);
            assert_memory_equal(w.follow, ref.follow, sizeof w.follow);
            assert_memory_equal(w.excess, ref.excess, sizeof w.excess);
        }
        for (unsigned k = 0u; k < 6u; ++k) {
            for (unsigned s = 0u; s < SP_WRENCH_SECTIONS; ++s) {
                assert_true(w.section[s][k] >= lo && w.section[s][k] <= hi);
            }
            assert_true(w.wrench[k] >= lo && w.wrench[k] <= hi);
            assert_true(w.slow[k] >= lo && w.slow[k] <= hi);
            assert_true(w.smooth[k] >= lo && w.smooth[k] <= hi);
        }
    }
}

/* The step response of SP_WRENCH_SECTIONS equal sections, each
 * y += a (x - y), n ticks after a unit input fell to 0 from a settled 1. */
static double sections_decay(double a, int n)
{
    /* sum over k < SP_WRENCH_SECTIONS of C(n + k - 1, k) a^k (1 - a)^n:
     * the sections update in turn within a tick, each from the new value
     * of the one before */
    double sum = 0.0;
    double term = pow(1.0 - a, n); /* k = 0 */
    for (int k = 0; k < (int)SP_WRENCH_SECTIONS; ++k) {
        sum += term;
        term *= (double)(n + k) / (double)(k + 1) * a;
    }
    return sum;
}

/* A known wrench W on a platform at rest: measured forces F = F_model -
 * J^-T W. The estimate finds W (raw on the first tick, then through the
 * filter's sections: a step of W settles as 1 - sections_decay). */
static void test_wrench_estimate(void **state)
{
    (void)state;
    sp_ik_t ik;
    sp_model_t model;
    sp_wrench_t w;
    sp_q30_t alpha;
    sp_q8_t meas[SP_LEGS];
    const double want[6] = {1500.0, -800.0, -5000.0, 300.0, -1200.0, 450.0};
    int64_t rhs[6];
    int64_t f[6];
    sp_lu6_t lu;

    assert_int_equal(sp_wrench_alpha(80 * SP_Q24_ONE, 1000u, &alpha), SP_OK);
    /* alpha = w dt / (1 + w dt), w dt = 2 pi 80 / 1000 */
    assert_near(ref_f30(alpha), 0.5026548 / 1.5026548, 1e-6, "alpha");
    assert_int_equal(sp_wrench_alpha(0, 1000u, &alpha), SP_E_ARG);
    assert_int_equal(sp_inverse_kinematics(P, &P->home, &ik), SP_OK);
    assert_int_equal(sp_jacobian(&ik, &model.jac), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        model.force[i] = ref_q8(4000.0 + 100.0 * i);
    }
    /* J^T x = W for the forces the wrench takes off the cylinders */
    for (int k = 0; k < 6; ++k) {
        rhs[k] = (int64_t)llround(want[k] * 16777216.0);
    }
    assert_int_equal(sp_lu6_factor(&model.jac, 1, &lu), SP_OK);
    assert_int_equal(sp_lu6_solve(&lu, rhs, f), SP_OK);
    for (int i = 0; i < SP_LEGS; ++i) {
        meas[i] = (sp_q8_t)(model.force[i] - (int32_t)(f[i] / 65536));
    }
    sp_wrench_reset(&w);
    sp_wrench_step(&w, &model, NULL, meas, NULL, alpha); /* keeps this tick's force path only */
    assert_int_equal(w.valid, 0);
    sp_wrench_step(&w, &model, NULL, meas, NULL, alpha);
    assert_int_equal(w.valid, 1);
    for (int k = 0; k < 6; ++k) {
        assert_near(ref_f8(w.wrench[k]), want[k], 0.05, "first estimate, component %d", k);
    }
    /* the load goes away: the estimate describes the previous tick, so it
     * holds W for one more tick, then decays with the filter */
    for (int n = 1; n <= 20; ++n) {
        sp_wrench_step(&w, &model, NULL, model.force, NULL, alpha);
        for (int k = 0; k < 6; ++k) {
            double decay = sections_decay(ref_f30(alpha), n - 1);
            assert_near(ref_f8(w.wrench[k]), want[k] * decay, 0.05 + 1e-6 * fabs(want[k]), "tick %d component %d", n,
                        k);
        }
    }
    /* no model: invalid at once */
    sp_wrench_step(&w, NULL, NULL, meas, NULL, alpha);
    assert_int_equal(w.valid, 0);

    /* With observed friction the estimate compares the measured forces with
     * the inverse dynamics part (model.rigid) plus that friction: a model
     * whose feed-forward friction is wrong by 700 N per leg changes
     * nothing, and the observed friction acts like force the cylinders
     * spend on the seals. */
    {
        sp_q8_t friction[SP_LEGS];
        for (int i = 0; i < SP_LEGS; ++i) {
            friction[i] = ref_q8(300.0 - 50.0 * i);
            model.rigid[i] = model.force[i];
            model.force[i] = model.rigid[i] + ref_q8(700.0);
            meas[i] = (sp_q8_t)(model.rigid[i] + friction[i] - (int32_t)(f[i] / 65536));
        }
        sp_wrench_reset(&w);
        sp_wrench_step(&w, &model, friction, meas, NULL, alpha);
        sp_wrench_step(&w, &model, friction, meas, NULL, alpha);
        assert_int_equal(w.valid, 1);
        for (int k = 0; k < 6; ++k) {
            assert_near(ref_f8(w.wrench[k]), want[k], 0.05, "with observed friction, component %d", k);
        }
    }
}

/* The reported estimate's smoother (sp_wrench_smooth) with the
 * controller's defaults: it averages noise while the wrench holds still,
 * follows a step as soon as the jump persists, and never leaves the
 * filtered estimate by more than the jump. */
static void test_wrench_smooth(void **state)
{
    (void)state;
    sp_ctrl_config_t cfg;
    sp_wrench_smooth_t p;
    sp_wrench_t w;
    uint64_t rng = 77u;
    assert_int_equal(sp_ctrl_default_config(&cfg, P), SP_OK);
    assert_int_equal(sp_wrench_alpha(cfg.wrench_smooth_hz, cfg.tick_us, &p.alpha), SP_OK);
    p.jump[0] = cfg.wrench_jump[0];
    p.jump[1] = cfg.wrench_jump[1];
    p.persist = cfg.wrench_jump_persist;
    p.hold = cfg.wrench_jump_hold;
    assert_true(p.persist >= 2u && p.hold >= 2u);
    const double a = ref_f30(p.alpha);

    /* noise about a constant: uniform +-50 N, +-40 N m (below the jumps)
     * leaves sqrt(a / (2 - a)) of its RMS (0.21 at 15 Hz) */
    sp_wrench_reset(&w);
    w.valid = 1u;
    double in2[6] = {0}, out2[6] = {0};
    int n2 = 0;
    for (int n = 0; n < 20000; ++n) {
        for (int k = 0; k < 6; ++k) {
            double amp = (k < 3) ? 50.0 : 40.0;
            double noise = amp * (2.0 * (double)(tu_next(&rng) >> 11) / 9007199254740992.0 - 1.0);
            w.wrench[k] = ref_q8(1000.0 * (k + 1) + noise);
        }
        sp_wrench_smooth(&w, &p);
        if (n >= 200) {
            for (int k = 0; k < 6; ++k) {
                double e_in = ref_f8(w.wrench[k]) - 1000.0 * (k + 1);
                double e_out = ref_f8(w.smooth[k]) - 1000.0 * (k + 1);
                in2[k] += e_in * e_in;
                out2[k] += e_out * e_out;
            }
            ++n2;
        }
    }
    for (int k = 0; k < 6; ++k) {
        double ratio = sqrt(out2[k] / in2[k]);
        assert_true(ratio < 0.28);
        assert_near(ratio, sqrt(a / (2.0 - a)), 0.04, "noise ratio, component %d", k);
    }
    (void)n2;

    /* a step of 1000 N, 500 N m: held at the jump from it until the jump
     * has persisted, then equal to it for hold ticks and after */
    sp_wrench_reset(&w);
    w.valid = 1u;
    sp_wrench_smooth(&w, &p); /* first tick: smooth = wrench = 0 */
    for (int n = 0; n < 40; ++n) {
        for (int k = 0; k < 6; ++k) {
            w.wrench[k] = ref_q8(k < 3 ? 1000.0 : 500.0);
        }
        sp_wrench_smooth(&w, &p);
        for (int k = 0; k < 6; ++k) {
            int32_t jump = p.jump[k < 3 ? 0 : 1];
            int32_t want = (n + 1 < (int)p.persist) ? w.wrench[k] - jump : w.wrench[k];
            assert_int_equal(w.smooth[k], want);
        }
    }

    /* a step below the jump: the section alone, (1 - a)^n of it left */
    sp_wrench_reset(&w);
    w.valid = 1u;
    sp_wrench_smooth(&w, &p);
    for (int n = 1; n <= 60; ++n) {
        for (int k = 0; k < 6; ++k) {
            w.wrench[k] = ref_q8(-40.0);
        }
        sp_wrench_smooth(&w, &p);
        for (int k = 0; k < 6; ++k) {
            assert_near(ref_f8(w.smooth[k]), -40.0 * (1.0 - pow(1.0 - a, n)), 0.02, "tick %d component %d", n, k);
        }
    }

    /* random walks, steps and noise of every size: never beyond the jump
     * from the filtered estimate; an invalid tick resets to it */
    sp_wrench_reset(&w);
    for (int n = 0; n < 50000; ++n) {
        w.valid = (uint8_t)((n % 997) != 0);
        for (int k = 0; k < 6; ++k) {
            int32_t step = (tu_next(&rng) % 50u == 0u) ? (tu_i32(&rng) >> 4) : (tu_i32(&rng) >> 18);
            int64_t v = (int64_t)w.wrench[k] + step;
            w.wrench[k] = (int32_t)(v > 0x3FFFFFFF ? 0x3FFFFFFF : (v < -0x40000000 ? -0x40000000 : v));
        }
        sp_wrench_smooth(&w, &p);
        for (int k = 0; k < 6; ++k) {
            int64_t d = (int64_t)w.smooth[k] - w.wrench[k];
            assert_true(d <= p.jump[k < 3 ? 0 : 1] && d >= -p.jump[k < 3 ? 0 : 1]);
            if (!w.valid) {
                assert_int_equal(w.smooth[k], w.wrench[k]);
            }
        }
    }
    sp_wrench_smooth(NULL, &p);
    sp_wrench_smooth(&w, NULL);
}

/* The motion-error correction as the controller's wrench job applies it:
 * an estimate that accelerates at 0.5 m/s^2 in x away from a reference at
 * rest, with no force error, gives a wrench that is exactly the filtered
 * dW = sp_motion_error_wrench_sc(da) (the same sections run in double on
 * the same dW, within the sections' roundings), and dW is m da to 1 %. */
static void test_wrench_motion_error_correction(void **state)
{
    (void)state;
    sp_model_t model;
    sp_wrench_t w;
    sp_motion_error_t me;
    sp_ik_t ik;
    sp_q30_t alpha;
    sp_q24_t da[6] = {0};
    sp_q8_t dw[6] = {0};
    double y[SP_WRENCH_SECTIONS][6] = {{0}};
    sp_pose_t ref = P->home;
    int corrected = 0;
    assert_int_equal(sp_wrench_alpha(80 * SP_Q24_ONE, 1000u, &alpha), SP_OK);
    assert_int_equal(sp_motion_error_init(&me, 1000u), SP_OK);
    assert_int_equal(sp_inverse_kinematics(P, &ref, &ik), SP_OK);
    assert_int_equal(sp_jacobian(&ik, &model.jac), SP_OK);
    for (int k = 0; k < 6; ++k) {
        model.ref.sc[k] = ik.sc[k];
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        model.force[i] = ref_q8(4000.0);
    }
    sp_wrench_reset(&w);
    for (int n = 0; n < 80; ++n) {
        double t = n * 1e-3;
        sp_pose_t est = ref;
        const sp_q8_t *c = NULL;
        est.pos[0] += (sp_q24_t)llround(0.5 * 0.5 * t * t * 16777216.0);
        sp_status_t st = sp_motion_error_step(&me, &est, &ref, da);
        if (st != SP_E_BUSY) {
            assert_int_equal(st, SP_OK);
            assert_int_equal(sp_motion_error_wrench_sc(P, model.ref.sc, da, dw), SP_OK);
            c = dw;
        }
        int was_valid = w.valid;
        sp_wrench_step(&w, &model, NULL, model.force, c, alpha);
        if (!w.valid) {
            continue;
        }
        for (int k = 0; k < 6; ++k) {
            double x = (c != NULL) ? dw[k] : 0.0;
            for (unsigned s = 0u; s < SP_WRENCH_SECTIONS; ++s) {
                y[s][k] = was_valid ? y[s][k] + ref_f30(alpha) * (x - y[s][k]) : x;
                x = y[s][k];
            }
            assert_near(w.wrench[k], x, 2.0, "tick %d component %d (Q8 LSB)", n, k);
        }
        corrected += (c != NULL);
    }
    assert_true(corrected > 70);
    /* no force error: the wrench is the filtered dW, and dW = m da, raw
     * within e's Q24 rounding (4 LSB of e in the double difference: 0.24
     * m/s^2), filtered within 1 % */
    assert_near(ref_f8(dw[0]), P->mass / 65536.0 * 0.5, P->mass / 65536.0 * 0.24, "m da");
    assert_near(ref_f8(w.wrench[0]), P->mass / 65536.0 * 0.5, 0.01 * P->mass / 65536.0 * 0.5, "filtered m da");
    /* an invalid estimate takes no correction */
    sp_wrench_step(&w, NULL, NULL, model.force, dw, alpha);
    assert_int_equal(w.valid, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_friction_force),
        cmocka_unit_test(test_wrench_estimate),
        cmocka_unit_test(test_wrench_matches_reference),
        cmocka_unit_test(test_wrench_state_stays_in_range),
        cmocka_unit_test(test_wrench_smooth),
        cmocka_unit_test(test_wrench_motion_error_correction),
        cmocka_unit_test(test_limits_prepare),
        cmocka_unit_test(test_limits_workspace_edges),
        cmocka_unit_test(test_limits_reachable_near_is_sufficient),
        cmocka_unit_test(test_limits_reachable_near_against_plain),
        cmocka_unit_test(test_limits_reachable_from_is_pose_reachable),
        cmocka_unit_test(test_stream_offer_reference),
        cmocka_unit_test(test_limits_setpoints_reference),
        cmocka_unit_test(test_limits_setpoints_and_measured),
        cmocka_unit_test(test_stream_follows_within_limits),
        cmocka_unit_test(test_stream_step_reference),
        cmocka_unit_test(test_stream_step_edges),
        cmocka_unit_test(test_stream_offer_rules),
        cmocka_unit_test(test_estimate_cold_warm_and_failure),
        cmocka_unit_test(test_estimate_step_accuracy),
        cmocka_unit_test(test_estimate_fallbacks),
        cmocka_unit_test(test_fk_newton_cached),
        cmocka_unit_test(test_setpoints_of),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
