/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of admittance control and contact supervision
 * (sp/force/admittance.h).
 *
 * Tolerances and figures:
 *   one step vs a double reference    d within 2 LSB + 1e-6 relative, v within
 *                                     4 LSB + 1e-6 relative, over 20,000
 *                                     random parameters and states (no limit
 *                                     active)
 *   force hold, 1-DOF closed loop     a servo with velocity feed-forward
 *                                     (K_v = 52.8 rad/s, as the plant's
 *                                     drives), a surface of 1e5, 1e6, 1e7 N/m,
 *                                     the wrench measured one tick late through
 *                                     the 80 Hz four-section filter with 14 N
 *                                     RMS noise, the pose quantised to 1 um:
 *                                     2 kN held within 1 % RMS from 0.5 s
 *                                     after contact (the true force at
 *                                     100 N), overshoot <= 10 %,
 *                                     peak-to-peak <= 2 % once settled;
 *                                     with 40 N RMS of noise and the
 *                                     cylinders' settings within 2 %, and
 *                                     the removal detected within 10 ticks
 *   hand guiding                      200 N moves the axis at 200 N / D within
 *                                     2 %; at a bound it stops on it, never past
 *   release                           d returns to 0 without overshoot (critical
 *                                     damping) within 5 time constants
 *   contact supervision               made, lost after lost_ticks, excess
 *   against the plain reference       the prepared, skipping step (coefficients
 *                                     made once, resting axes not computed,
 *                                     the pose filtered on forced axes only)
 *                                     and the prepared contact supervision
 *                                     equal the first version
 *                                     (admittance_plain.c) bit for bit: d, v,
 *                                     a, coefficients, stiffness estimate,
 *                                     events, status, every tick of 600
 *                                     random runs (FORCE, then RELEASE or
 *                                     HOLD, as sp/force/force.h runs it), and at
 *                                     the edges of the adaptation's 1/16
 *                                     window
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

#include "plain/admittance_plain.h"
#include "assert_near.h"
#include "sp/force/admittance.h"
#include "sp/estimation/wrench.h"
#include "test_util.h"

#define Q24 16777216.0
#define Q8 256.0
#define Q16 65536.0

static sp_q24_t q24(double v)
{
    return (sp_q24_t)lround(v * Q24);
}

static sp_q8_t q8(double v)
{
    return (sp_q8_t)lround(v * Q8);
}

/* A force-control set-up like the demo's: translation in m, rotation in rad. */
static sp_admit_config_t config(void)
{
    sp_admit_config_t c;
    memset(&c, 0, sizeof c);
    for (unsigned k = 0; k < SP_AXES; ++k) {
        sp_admit_axis_t *ax = &c.axis[k];
        ax->mass = (sp_q16_t)((k < 3u ? 20 : 5) * 65536);
        ax->damping = k < 3u ? 1000000 : 100000; /* approach: 2 kN at 2 mm/s */
        ax->stiffness = 0;
        ax->release_stiffness = k < 3u ? 20000 : 5000;
        ax->v_max = q24(k < 3u ? 0.1 : 0.1);
        ax->a_brake = q24(2.0);
    }
    c.crossover = (sp_q16_t)(20 * 65536);
    c.k_min = 10000;
    c.k_max = 100000000;
    c.secant_force = q8(30.0);
    c.secant_travel = q24(10e-6);
    c.tick_us = 1000u;
    assert_int_equal(sp_wrench_alpha(80 << 24, 1000u, &c.filter_alpha), SP_OK);
    return c;
}

static void wide_bounds(sp_q24_t lo[SP_AXES], sp_q24_t hi[SP_AXES])
{
    for (unsigned k = 0; k < SP_AXES; ++k) {
        lo[k] = q24(-1.0);
        hi[k] = q24(1.0);
    }
}

static void test_configure_rejects(void **state)
{
    (void)state;
    sp_admit_config_t c = config();
    sp_admit_t st;
    assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
    assert_int_equal(sp_admit_configure(NULL, &st), SP_E_ARG);
    assert_int_equal(sp_admit_configure(&c, NULL), SP_E_ARG);
    sp_admit_config_t bad = c;
    bad.axis[2].mass = SP_Q16_ONE / 2; /* below 1 kg */
    assert_int_equal(sp_admit_configure(&bad, &st), SP_E_ARG);
    bad = c;
    bad.axis[0].damping = 0;
    assert_int_equal(sp_admit_configure(&bad, &st), SP_E_ARG);
    bad = c;
    bad.tick_us = 5000u;
    assert_int_equal(sp_admit_configure(&bad, &st), SP_E_ARG);
    bad = c;
    bad.k_max = c.k_min - 1;
    assert_int_equal(sp_admit_configure(&bad, &st), SP_E_ARG);
    bad = c;
    bad.axis[1].v_max = 0;
    assert_int_equal(sp_admit_configure(&bad, &st), SP_E_ARG);
}

/* One step against the law in double, for random parameters and states. */
static void test_step_vs_double(void **state)
{
    (void)state;
    uint64_t rng = 0xad317ace5u;
    sp_q24_t lo[SP_AXES], hi[SP_AXES];
    wide_bounds(lo, hi);
    for (int i = 0; i < 20000; ++i) {
        sp_admit_config_t c = config();
        unsigned k = (unsigned)(tu_next(&rng) % SP_AXES);
        double m = tu_uniform(&rng, 1.0, 500.0);
        double dmp = exp(tu_uniform(&rng, log(1.0), log(5e6)));
        double kk = (tu_next(&rng) & 1u) ? 0.0 : exp(tu_uniform(&rng, log(1.0), log(1e6)));
        c.axis[k].mass = (sp_q16_t)lround(m * Q16);
        c.axis[k].damping = (int32_t)lround(dmp);
        c.axis[k].stiffness = (int32_t)lround(kk);
        c.axis[k].v_max = q24(100.0);
        c.axis[k].a_brake = q24(100.0);
        sp_admit_t st;
        assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
        double d0 = tu_uniform(&rng, -0.01, 0.01), v0 = tu_uniform(&rng, -0.1, 0.1);
        st.axis[k].d = q24(d0);
        st.axis[k].v = q24(v0);
        sp_q8_t w[SP_AXES] = {0}, t[SP_AXES] = {0};
        w[k] = q8(tu_uniform(&rng, -5000.0, 5000.0));
        t[k] = q8(tu_uniform(&rng, -5000.0, 5000.0));
        assert_int_equal(sp_admit_step(&c, &st, SP_ADMIT_FORCE, (uint8_t)(1u << k), w, t, NULL, 0u, lo, hi, NULL),
                         SP_OK);
        double mq = (double)c.axis[k].mass / Q16, dq = c.axis[k].damping, kq = c.axis[k].stiffness;
        double dt = 1e-3, d = st.axis[k].d / Q24, v = st.axis[k].v / Q24;
        double dd = (double)q24(d0) / Q24, vv = (double)q24(v0) / Q24;
        double f = (w[k] + t[k]) / Q8;
        double v_want = (mq * vv + dt * (f - kq * dd)) / (mq + dt * dq);
        if (fabs(v_want) > 50.0 || fabs(v_want - vv) > 0.099) {
            continue; /* the speed limit or the acceleration limit (a_brake dt = 0.1 m/s) would act */
        }
        double d_want = dd + dt * v_want;
        assert_near(v, v_want, 4.0 / Q24 + 2e-3 * fabs(v_want) + 1e-9, "v, case %d", i);
        assert_near(d, d_want, 4.0 / Q24 + 2e-3 * fabs(v_want) * dt + 1e-9, "d, case %d", i);
    }
}

/* The 1-DOF loop of a force hold: see the file comment. Returns the worst
 * figures after contact. */
typedef struct {
    double overshoot; /* max true force / target - 1 */
    double rms_rel;   /* RMS of (true - target) / target from 0.5 s after the true contact */
    double pp_rel;    /* peak-to-peak / target over the last second */
    double t_contact; /* contact made (the supervision's event), s */
    double t_true;    /* the true force first at 100 N (the contact), s */
    uint32_t lost_at; /* tick of CONTACT_LOST (0: none) */
    double x_lost;    /* position at surface removal, m */
    double x_end;     /* final position, m */
} hold_t;

/* The wrench sources of run_hold: the sensor's (14 N RMS before the
 * filter, the defaults of the unit tests), and a noisy estimate as the
 * cylinders' (noise_rms N RMS before the filter) with the cylinders'
 * settings (sp_ctrl_set_wrench_source: contact from 300 N or 120 N through
 * a 64 ms low-pass, lost below 80 %, crossover 6 rad/s, the secant with
 * 60 N of margin, the error beyond 100 N counted four times) or, with
 * `old_cyl`, those before them (300 N only, the plain secant, no boost). */
typedef struct {
    double noise_rms; /* N RMS before the filter */
    int cyl;          /* 1: the cylinders' settings, 2: the old ones */
} source_t;

static const source_t SENSOR = {14.0, 0};

static hold_t run_hold_src(double k_e, double seconds, double remove_at, int32_t k_clamp, source_t src)
{
    sp_admit_config_t c = config();
    if (k_clamp > 0) {
        c.k_min = k_clamp;
        c.k_max = k_clamp;
    }
    sp_contact_config_t cc = {q8(100.0), SP_Q30_ONE / 2, 2u, 1u, q8(20000.0), 0, 0u};
    if (src.cyl != 0) {
        c.crossover = (sp_q16_t)(6 * 65536);
        cc.made = q8(300.0);
        cc.lost_ratio = (sp_q30_t)(((int64_t)4 << 30) / 5);
        cc.arm_ticks = 100u;
        if (src.cyl == 1) {
            cc.made_slow = q8(120.0);
            cc.slow_shift = 6u;
            c.secant_margin = q8(60.0);
            c.boost = 4u;
            c.boost_band = q8(100.0);
        }
    }
    sp_admit_t st;
    assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
    sp_contact_t cs = {0u, 0u, 0u, 0u, 0};
    sp_wrench_t filt;
    sp_wrench_reset(&filt);
    int32_t sec[SP_WRENCH_SECTIONS] = {0};
    sp_q24_t lo[SP_AXES], hi[SP_AXES];
    wide_bounds(lo, hi);
    const double target = 2000.0, xs = 0.002, kv = 52.8;
    uint64_t rng = 0x5eed1234u ^ (uint64_t)k_e;
    double x = 0.0, x_r = 0.0, v_r = 0.0, w_true_prev = 0.0;
    sp_q24_t x_meas_prev = 0;
    int removed = 0;
    hold_t h = {0.0, 0.0, 0.0, -1.0, -1.0, 0u, 0.0, 0.0};
    double se = 0.0, f_lo = 1e9, f_hi = -1e9;
    int n_rms = 0;
    uint8_t contact = 0u;
    const int ticks = (int)(seconds * 1000.0);
    for (int n = 0; n < ticks; ++n) {
        double t = n * 1e-3;
        /* the measurement of the last cycle: the wrench through the filter, the pose */
        double noise = 0.0;
        for (int j = 0; j < 4; ++j) {
            noise += tu_uniform(&rng, -1.0, 1.0);
        }
        noise *= src.noise_rms * sqrt(3.0) / 2.0; /* sum of four U(-1,1): var 4/3 -> noise_rms */
        int32_t x_in = (int32_t)lround((w_true_prev + noise) * Q8);
        for (unsigned s = 0; s < SP_WRENCH_SECTIONS; ++s) {
            int32_t y = sec[s];
            sec[s] = (n == 0) ? x_in : y + (int32_t)(((int64_t)c.filter_alpha * (x_in - y) + (1 << 29)) >> 30);
            x_in = sec[s];
        }
        sp_q8_t w[SP_AXES] = {0}, tg[SP_AXES] = {0};
        sp_q24_t xm[SP_AXES] = {0};
        w[0] = sec[SP_WRENCH_SECTIONS - 1];
        tg[0] = q8(target);
        xm[0] = x_meas_prev;
        uint32_t ev = sp_contact_step(&cc, &cs, w, tg);
        if ((ev & SP_CONTACT_MADE) != 0u && h.t_contact < 0.0) {
            h.t_contact = t;
        }
        if ((ev & SP_CONTACT_LOST) != 0u && h.lost_at == 0u) {
            h.lost_at = (uint32_t)n;
        }
        contact = cs.made ? 1u : 0u;
        /* the controller's reaction to a lost contact: brake and hold */
        sp_admit_mode_t mode = (h.lost_at != 0u) ? SP_ADMIT_HOLD : SP_ADMIT_FORCE;
        assert_int_equal(sp_admit_step(&c, &st, mode, 1u, w, tg, xm, contact, lo, hi, NULL), SP_OK);
        /* the drive follows x_r with velocity feed-forward over the cycle (10 substeps) */
        double x_r_new = st.axis[0].d / Q24, v_r_new = st.axis[0].v / Q24;
        (void)x_r;
        (void)v_r;
        x_r = x_r_new;
        v_r = v_r_new;
        for (int s = 0; s < 10; ++s) {
            double age = (s + 0.5) * 1e-4;
            x += 1e-4 * (kv * (x_r + v_r * age - x) + v_r);
        }
        if (!removed && remove_at > 0.0 && t >= remove_at) {
            removed = 1;
            h.x_lost = x;
        }
        double f_true = (!removed && x > xs) ? k_e * (x - xs) : 0.0;
        w_true_prev = -f_true;
        x_meas_prev = (sp_q24_t)lround(floor(x * 1e6 + 0.5) * 1e-6 * Q24);
        if (h.t_true < 0.0 && f_true >= 100.0) {
            h.t_true = t;
        }
        if (h.t_true >= 0.0 && !removed) {
            double rel = f_true / target - 1.0;
            h.overshoot = fmax(h.overshoot, rel);
            if (t >= h.t_true + 0.5) {
                se += rel * rel;
                ++n_rms;
            }
            if (t >= seconds - 1.0) {
                f_lo = f_lo < f_true ? f_lo : f_true;
                f_hi = f_hi > f_true ? f_hi : f_true;
            }
        }
    }
    h.rms_rel = n_rms ? sqrt(se / n_rms) : 1.0;
    h.pp_rel = (f_hi - f_lo) / target;
    h.x_end = x;
    return h;
}

static hold_t run_hold(double k_e, double seconds, double remove_at, int32_t k_clamp)
{
    return run_hold_src(k_e, seconds, remove_at, k_clamp, SENSOR);
}

static void test_force_hold_each_stiffness(void **state)
{
    (void)state;
    const double ks[3] = {1e5, 1e6, 1e7};
    for (int i = 0; i < 3; ++i) {
        hold_t h = run_hold(ks[i], 6.0, 0.0, 0);
        print_message("k_e %.0e N/m: contact at %.3f s, overshoot %.2f %%, RMS %.3f %%, p-p %.3f %%\n", ks[i],
                      h.t_contact, 100.0 * h.overshoot, 100.0 * h.rms_rel, 100.0 * h.pp_rel);
        assert_true(h.t_contact > 0.0);
        assert_true(h.overshoot <= 0.10);
        assert_true(h.rms_rel <= 0.01);
        assert_true(h.pp_rel <= 0.02);
    }
}

/* The cylinders' estimate (40 N RMS of noise before the filter): 2 kN
 * held within 2 % RMS from 0.5 s after contact on each surface, overshoot
 * <= 10 %, p-p <= 2 % in the last second, and the surface's removal
 * detected within 10 ticks; the positive control: with the settings before
 * the slow contact level, the secant's margin and the boost, the soft
 * surface is not held within 2 % from 0.5 s after contact (contact counts
 * from 300 N, reached 1 s after 100 N at the approach's 2 mm/s). */
static void test_force_hold_cylinders_estimate(void **state)
{
    (void)state;
    const source_t cyl = {40.0, 1}, old = {40.0, 2};
    const double ks[3] = {1e5, 1e6, 1e7};
    for (int i = 0; i < 3; ++i) {
        hold_t h = run_hold_src(ks[i], 4.0, 0.0, 0, cyl);
        print_message("cylinders, k_e %.0e N/m: contact at %.3f s, overshoot %.2f %%, RMS %.3f %%, p-p %.3f %%\n",
                      ks[i], h.t_contact, 100.0 * h.overshoot, 100.0 * h.rms_rel, 100.0 * h.pp_rel);
        assert_true(h.t_contact > 0.0 && h.lost_at == 0u);
        assert_true(h.overshoot <= 0.10);
        assert_true(h.rms_rel <= 0.02);
        assert_true(h.pp_rel <= 0.02);
        hold_t r = run_hold_src(ks[i], 4.0, 3.0, 0, cyl);
        assert_true(r.lost_at > 3000u && r.lost_at - 3000u <= 10u);
    }
    hold_t h = run_hold_src(1e5, 4.0, 0.0, 0, old);
    print_message("cylinders, old settings, k_e 1e5 N/m: RMS %.2f %%\n", 100.0 * h.rms_rel);
    assert_true(h.rms_rel > 0.02);
}

/* The positive control: the damping held at what the soft surface needs
 * (the secant clamped to 1e5 N/m) drives the stiff one far past the
 * figures, which is why the damping adapts. */
static void test_fixed_damping_fails_on_stiff(void **state)
{
    (void)state;
    hold_t h = run_hold(1e7, 3.0, 0.0, 100000);
    print_message("k_e 1e7 with D for 1e5: overshoot %.1f %%, RMS %.1f %%\n", 100.0 * h.overshoot, 100.0 * h.rms_rel);
    assert_true(h.overshoot > 0.10 || h.rms_rel > 0.01 || h.pp_rel > 0.02);
}

static void test_contact_lost(void **state)
{
    (void)state;
    for (int i = 0; i < 3; ++i) {
        double k = (i == 0) ? 1e5 : ((i == 1) ? 1e6 : 1e7);
        hold_t h = run_hold(k, 5.0, 3.0, 0);
        assert_true(h.lost_at > 0u);
        uint32_t ticks = h.lost_at - 3000u;
        print_message("k_e %.0e: surface removed, lost after %u ticks, travel %.2f mm\n", k, ticks,
                      1e3 * (h.x_end - h.x_lost));
        assert_true(ticks <= 10u);
        assert_true(fabs(h.x_end - h.x_lost) <= 0.005);
    }
}

static void test_hand_guiding(void **state)
{
    (void)state;
    sp_admit_config_t c = config();
    c.axis[1].damping = 1000; /* 200 N -> 0.2 m/s */
    c.axis[1].v_max = q24(0.5);
    c.axis[1].a_brake = q24(1.0);
    sp_admit_t st;
    assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
    sp_q24_t lo[SP_AXES], hi[SP_AXES];
    wide_bounds(lo, hi);
    hi[1] = q24(0.15);
    sp_q8_t w[SP_AXES] = {0}, t[SP_AXES] = {0};
    w[1] = q8(200.0);
    double v_mid = 0.0, d_max = -1.0;
    for (int n = 0; n < 3000; ++n) {
        assert_int_equal(sp_admit_step(&c, &st, SP_ADMIT_FORCE, 0x3fu, w, t, NULL, 0u, lo, hi, NULL), SP_OK);
        if (n == 300) {
            v_mid = st.axis[1].v / Q24;
        }
        d_max = fmax(d_max, st.axis[1].d / Q24);
        assert_true(st.axis[1].d <= hi[1]);
    }
    assert_near(v_mid, 0.2, 0.2 * 0.02, "guided speed");
    assert_near(st.axis[1].d / Q24, 0.15, 1e-6, "stopped on the bound");
    assert_near(st.axis[1].v / Q24, 0.0, 1e-6, "at rest on the bound");
    assert_true(d_max <= 0.15 + 1e-9);
}

static void test_release_is_critically_damped(void **state)
{
    (void)state;
    sp_admit_config_t c = config();
    sp_admit_t st;
    assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
    sp_q24_t lo[SP_AXES], hi[SP_AXES];
    wide_bounds(lo, hi);
    st.axis[2].d = q24(-0.004);
    sp_q8_t w[SP_AXES] = {0}, t[SP_AXES] = {0};
    w[2] = q8(-3000.0); /* ignored in release */
    double tau = sqrt(20.0 / 20000.0);
    int n_end = (int)(10.0 * tau * 1000.0);
    for (int n = 0; n < n_end; ++n) {
        assert_int_equal(sp_admit_step(&c, &st, SP_ADMIT_RELEASE, 0x3fu, w, t, NULL, 0u, lo, hi, NULL), SP_OK);
        assert_true(st.axis[2].d <= 0); /* no overshoot past the position reference */
    }
    assert_true(fabs(st.axis[2].d / Q24) < 0.004 * 0.01);
}

static void test_contact_events(void **state)
{
    (void)state;
    sp_contact_config_t cc = {q8(100.0), SP_Q30_ONE / 4, 3u, 1u, q8(5000.0), 0, 0u};
    sp_contact_t cs = {0u, 0u, 0u, 0u, 0};
    sp_q8_t w[SP_AXES] = {0}, t[SP_AXES] = {0};
    t[2] = q8(-2000.0); /* push down */
    w[2] = q8(50.0);    /* the world pushes up, below the threshold */
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    w[2] = q8(150.0);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), SP_CONTACT_MADE);
    w[2] = q8(400.0); /* rising: below 25 % of 2 kN, but not yet armed */
    for (int n = 0; n < 10; ++n) {
        assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    }
    w[2] = q8(1990.0); /* held: armed */
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    assert_int_equal(cs.armed, 1u);
    w[2] = q8(400.0); /* falls away: lost after 3 ticks */
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), SP_CONTACT_LOST);
    assert_int_equal(cs.made, 0u);
    /* lost while still rising: below made / 2 */
    w[2] = q8(150.0);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), SP_CONTACT_MADE);
    w[2] = q8(30.0);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), SP_CONTACT_LOST);
    w[2] = q8(-150.0); /* pulling away is no contact */
    assert_int_equal(sp_contact_step(&cc, &cs, w, t), 0u);
    w[0] = q8(6000.0); /* excessive, any direction */
    assert_int_equal(sp_contact_step(&cc, &cs, w, t) & SP_CONTACT_EXCESS, SP_CONTACT_EXCESS);
    assert_int_equal(sp_contact_step(NULL, &cs, w, t), 0u);
    /* extreme inputs: no overflow */
    for (unsigned k = 0; k < SP_AXES; ++k) {
        w[k] = INT32_MIN;
        t[k] = INT32_MAX;
    }
    assert_int_equal(sp_contact_step(&cc, &cs, w, t) & SP_CONTACT_EXCESS, SP_CONTACT_EXCESS);
}

/* A random but valid config (issue 15's ranges and beyond). */
static sp_admit_config_t random_config(uint64_t *rng)
{
    sp_admit_config_t c = config();
    for (unsigned k = 0; k < SP_AXES; ++k) {
        sp_admit_axis_t *ax = &c.axis[k];
        ax->mass = (sp_q16_t)lround(tu_uniform(rng, 1.0, 200.0) * Q16);
        ax->damping = (int32_t)lround(exp(tu_uniform(rng, log(100.0), log(5e6))));
        ax->stiffness = (tu_next(rng) & 1u) ? 0 : (int32_t)lround(exp(tu_uniform(rng, 0.0, log(1e6))));
        ax->release_stiffness = (int32_t)lround(exp(tu_uniform(rng, log(100.0), log(1e6))));
        ax->v_max = q24(tu_uniform(rng, 0.01, 0.5));
        ax->a_brake = q24(tu_uniform(rng, 0.1, 10.0));
    }
    c.crossover = (sp_q16_t)lround(tu_uniform(rng, 5.0, 50.0) * Q16);
    c.k_min = (int32_t)lround(exp(tu_uniform(rng, log(1e3), log(1e5))));
    c.k_max = (int32_t)lround(exp(tu_uniform(rng, log(1e6), log(1e9))));
    c.secant_force = q8(tu_uniform(rng, 1.0, 50.0));
    c.secant_travel = q24(tu_uniform(rng, 1e-6, 2e-5));
    c.tick_us = (tu_next(rng) & 1u) ? 1000u : (uint32_t)(100u + tu_next(rng) % 1901u);
    return c;
}

static void expect_same_state(const sp_admit_t *st, const plain_admit_t *ps, int run, int tick)
{
    for (unsigned k = 0; k < SP_AXES; ++k) {
        const sp_admit_axis_state_t *a = &st->axis[k];
        const plain_axis_state_t *b = &ps->axis[k];
        if (a->d != b->d || a->v != b->v || a->a != b->a || a->coef.damping != b->coef.damping ||
            a->coef.c_v != b->coef.c_v || a->coef.c_f != b->coef.c_f || a->coef.c_k != b->coef.c_k ||
            a->rel.damping != b->rel.damping || a->rel.c_v != b->rel.c_v || a->rel.c_f != b->rel.c_f ||
            a->rel.c_k != b->rel.c_k || a->k_hat != b->k_hat || a->in_contact != b->in_contact) {
            fail_msg("run %d tick %d axis %u: d %d/%d v %d/%d a %d/%d D %d/%d k_hat %d/%d", run, tick, k, a->d, b->d,
                     a->v, b->v, a->a, b->a, a->coef.damping, b->coef.damping, a->k_hat, b->k_hat);
        }
    }
}

/* The prepared step against the plain one: random configs, a fixed mask,
 * FORCE (some runs as hand guiding: the guide damping's coefficients
 * prepared by sp_admit_coefficients, as sp_force_start does), then RELEASE
 * or HOLD; surfaces of random stiffness, noisy wrenches, random bounds. */
static void test_step_equals_plain(void **state)
{
    (void)state;
    uint64_t rng = 0x15b0d9e7u;
    int adapted = 0, limited = 0, rested = 0;
    for (int run = 0; run < 600; ++run) {
        sp_admit_config_t c = random_config(&rng);
        sp_admit_config_t cp = c; /* the plain step's config: the free-space damping in it */
        const int guide = (tu_next(&rng) % 4u) == 0u;
        sp_admit_t st;
        plain_admit_t ps;
        assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
        if (guide) {
            sp_admit_coef_t g[SP_AXES];
            for (unsigned k = 0; k < SP_AXES; ++k) {
                cp.axis[k].damping = (int32_t)(1 + tu_next(&rng) % 5000u);
                assert_int_equal(sp_admit_coefficients(&c, &st, k, cp.axis[k].damping, &g[k]), SP_OK);
            }
            assert_int_equal(sp_admit_restart(&st, g), SP_OK);
        }
        assert_int_equal(plain_admit_configure(&cp, &ps), SP_OK);
        expect_same_state(&st, &ps, run, -1);
        const uint8_t mask = (uint8_t)(1u + tu_next(&rng) % 63u);
        const int n_force = (int)(50u + tu_next(&rng) % 400u);
        const int n_total = n_force + (int)(tu_next(&rng) % 300u);
        const sp_admit_mode_t after = (tu_next(&rng) & 1u) ? SP_ADMIT_RELEASE : SP_ADMIT_HOLD;
        double ke[SP_AXES], x[SP_AXES], w[SP_AXES];
        sp_q8_t tg[SP_AXES];
        for (unsigned k = 0; k < SP_AXES; ++k) {
            ke[k] = exp(tu_uniform(&rng, log(1e4), log(1e8)));
            x[k] = tu_uniform(&rng, -0.01, 0.01);
            w[k] = tu_uniform(&rng, -100.0, 100.0);
            tg[k] = guide ? 0 : q8(tu_uniform(&rng, -3000.0, 3000.0));
        }
        for (int n = 0; n < n_total; ++n) {
            sp_admit_mode_t mode = (n < n_force) ? SP_ADMIT_FORCE : after;
            sp_q8_t we[SP_AXES];
            sp_q24_t xm[SP_AXES], lo[SP_AXES], hi[SP_AXES];
            for (unsigned k = 0; k < SP_AXES; ++k) {
                double dx = tu_uniform(&rng, -2e-5, 2e-5);
                x[k] += dx;
                w[k] += -ke[k] * dx * 1e-2 + tu_uniform(&rng, -5.0, 5.0); /* the surface pushes back */
                w[k] = fmax(-8000.0, fmin(8000.0, w[k]));
                we[k] = q8(w[k]);
                xm[k] = q24(x[k]);
                lo[k] = (tu_next(&rng) % 50u == 0u) ? 0 : q24(tu_uniform(&rng, -0.05, 0.0));
                hi[k] = (tu_next(&rng) % 50u == 0u) ? 0 : q24(tu_uniform(&rng, 0.0, 0.05));
                if (tu_next(&rng) % 100u == 0u) {
                    lo[k] = q24(0.001); /* a bound the reference has passed */
                }
            }
            const int meas = (tu_next(&rng) % 10u) != 0u;
            const uint8_t contact = (n > n_force / 4) ? (uint8_t)((mask & (uint8_t)tu_next(&rng)) | (mask & 0x5u)) : 0u;
            sp_admit_report_t r1, r2;
            sp_status_t s1 = sp_admit_step(&c, &st, mode, mask, we, tg, meas ? xm : NULL, contact, lo, hi, &r1);
            sp_status_t s2 = plain_admit_step(&cp, &ps, mode, mask, we, tg, meas ? xm : NULL, contact, lo, hi, &r2);
            assert_int_equal(s1, s2);
            assert_int_equal(r1.limited, r2.limited);
            assert_int_equal(r1.adapted, r2.adapted);
            expect_same_state(&st, &ps, run, n);
            adapted += (r1.adapted != 0u) ? 1 : 0;
            limited += (r1.limited != 0u) ? 1 : 0;
            for (unsigned k = 0; k < SP_AXES; ++k) {
                rested += (mode != SP_ADMIT_FORCE && st.axis[k].d == 0 && st.axis[k].v == 0) ? 1 : 0;
            }
        }
    }
    print_message("against the plain step: %d ticks adapted, %d limited, %d axis-ticks at rest in release/hold\n",
                  adapted, limited, rested);
    /* the runs reach what the preparation and the skipping change */
    assert_true(adapted > 1000);
    assert_true(limited > 1000);
    assert_true(rested > 1000);
}

/* A restart is a configure without computing: the same state. */
static void test_restart_is_configure(void **state)
{
    (void)state;
    uint64_t rng = 0x5eeda11u;
    for (int run = 0; run < 200; ++run) {
        sp_admit_config_t c = random_config(&rng);
        sp_admit_t st, fresh;
        assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
        sp_q24_t lo[SP_AXES], hi[SP_AXES], xm[SP_AXES];
        sp_q8_t w[SP_AXES], t[SP_AXES] = {0};
        wide_bounds(lo, hi);
        for (unsigned k = 0; k < SP_AXES; ++k) {
            w[k] = q8(tu_uniform(&rng, -500.0, 500.0));
            xm[k] = q24(tu_uniform(&rng, -0.01, 0.01));
        }
        for (int n = 0; n < 20; ++n) {
            (void)sp_admit_step(&c, &st, SP_ADMIT_FORCE, 0x3Fu, w, t, xm, 0x3Fu, lo, hi, NULL);
        }
        assert_int_equal(sp_admit_restart(&st, NULL), SP_OK);
        assert_int_equal(sp_admit_configure(&c, &fresh), SP_OK);
        assert_int_equal(st.primed, fresh.primed);
        assert_true(st.dt_q50 == fresh.dt_q50 && st.dt_q38 == fresh.dt_q38 && st.rate_q16 == fresh.rate_q16);
        for (unsigned k = 0; k < SP_AXES; ++k) {
            const sp_admit_axis_state_t *a = &st.axis[k], *b = &fresh.axis[k];
            assert_true(a->d == 0 && a->v == 0 && a->a == 0 && a->k_hat == 0 && a->in_contact == 0u);
            assert_memory_equal(&a->coef, &b->coef, sizeof a->coef);
            assert_memory_equal(&a->free_coef, &b->free_coef, sizeof a->free_coef);
            assert_memory_equal(&a->rel, &b->rel, sizeof a->rel);
            assert_memory_equal(a->x_f, b->x_f, sizeof a->x_f);
            assert_int_equal(a->dv_brake, b->dv_brake);
        }
    }
    sp_admit_config_t c = config();
    sp_admit_t st;
    sp_admit_coef_t cf;
    assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
    assert_int_equal(sp_admit_restart(NULL, NULL), SP_E_ARG);
    assert_int_equal(sp_admit_coefficients(NULL, &st, 0u, 10, &cf), SP_E_ARG);
    assert_int_equal(sp_admit_coefficients(&c, NULL, 0u, 10, &cf), SP_E_ARG);
    assert_int_equal(sp_admit_coefficients(&c, &st, SP_AXES, 10, &cf), SP_E_ARG);
    assert_int_equal(sp_admit_coefficients(&c, &st, 0u, 0, &cf), SP_E_ARG);
    assert_int_equal(sp_admit_coefficients(&c, &st, 0u, INT32_MAX, &cf), SP_E_OVERFLOW); /* M + dt D beyond 2^31 kg */
}

/* Contact supervision with the target prepared against the plain one. */
static void test_contact_equals_plain(void **state)
{
    (void)state;
    uint64_t rng = 0xc0a7ac7u;
    int events = 0;
    for (int run = 0; run < 300; ++run) {
        sp_contact_config_t cc = {q8(tu_uniform(&rng, 10.0, 300.0)),
                                  (sp_q30_t)(tu_next(&rng) % (uint64_t)SP_Q30_ONE),
                                  (uint8_t)(1u + tu_next(&rng) % 5u),
                                  (uint8_t)(tu_next(&rng) % 30u),
                                  q8(tu_uniform(&rng, 3000.0, 20000.0)),
                                  0,
                                  0u};
        sp_contact_t a = {0u, 0u, 0u, 0u, 0}, b = {0u, 0u, 0u, 0u, 0};
        sp_q8_t t[SP_AXES] = {0}, w[SP_AXES] = {0};
        for (unsigned k = 0; k < 3u; ++k) {
            t[k] = (tu_next(&rng) % 5u == 0u) ? 0 : q8(tu_uniform(&rng, -4000.0, 4000.0));
        }
        if (run % 50 == 0) {
            t[0] = INT32_MIN; /* extremes: held */
            t[1] = INT32_MAX;
        }
        sp_contact_target_t tp;
        sp_contact_target(t, &tp);
        for (int n = 0; n < 300; ++n) {
            for (unsigned k = 0; k < SP_AXES; ++k) {
                w[k] = (tu_next(&rng) % 200u == 0u) ? (sp_q8_t)tu_next(&rng) : q8(tu_uniform(&rng, -6000.0, 6000.0));
            }
            uint32_t e1 = sp_contact_step_to(&cc, &a, w, &tp);
            uint32_t e2 = plain_contact_step(&cc, &b, w, t);
            assert_int_equal(e1, e2);
            /* field by field: the struct has padding */
            assert_int_equal(a.made, b.made);
            assert_int_equal(a.armed, b.armed);
            assert_int_equal(a.low, b.low);
            assert_int_equal(a.high, b.high);
            assert_int_equal(a.slow, b.slow);
            events += (e1 != 0u) ? 1 : 0;
        }
    }
    assert_true(events > 1000);
    sp_contact_t cs = {0u, 0u, 0u, 0u, 0};
    sp_q8_t w0[SP_AXES] = {0};
    assert_int_equal(sp_contact_step_to(NULL, &cs, w0, NULL), 0u);
}

/* The adaptation at the edges of its 1/16 window: an axis set up in
 * contact with a secant of exactly k (travel 2^16 Q24, the wrench change
 * k Q8), the damping in use D, stepped by the prepared and the plain step,
 * for k where round(k / w_c) crosses D - D/16 or D + D/16, with the
 * free-space damping inside, outside and on the window. */
static void test_secant_window_edges(void **state)
{
    (void)state;
    uint64_t rng = 0xed9e5u;
    int acted = 0, quiet = 0;
    for (int run = 0; run < 3000; ++run) {
        sp_admit_config_t c = config();
        /* half the runs at an even number of rad/s: the edges then fall on
         * exact multiples (ties of the rounding) */
        c.crossover = (tu_next(&rng) & 1u) ? (sp_q16_t)(131072 * (int32_t)(1u + tu_next(&rng) % 50u))
                                           : (sp_q16_t)(1 + tu_next(&rng) % (uint64_t)(100 * 65536));
        c.k_min = 1;
        c.k_max = INT32_MAX;
        c.secant_force = 1;
        c.secant_travel = 1;
        const unsigned ax = (unsigned)(tu_next(&rng) % SP_AXES);
        const int32_t in_use = (int32_t)exp(tu_uniform(&rng, 0.0, log(2e7)));
        const int32_t tol = in_use / 16;
        int32_t free_d;
        switch (tu_next(&rng) % 4u) {
        case 0u:
            free_d = in_use; /* the free-space damping in use */
            break;
        case 1u:
            free_d = in_use + (int32_t)(tu_next(&rng) % (uint64_t)(2 * tol + 1)) - tol; /* inside the window */
            break;
        default:
            free_d = (int32_t)(1 + tu_next(&rng) % 5000000u); /* anywhere */
            break;
        }
        free_d = (free_d < 1) ? 1 : free_d;
        c.axis[ax].damping = free_d;
        sp_admit_t st;
        plain_admit_t ps;
        assert_int_equal(sp_admit_configure(&c, &st), SP_OK);
        assert_int_equal(plain_admit_configure(&c, &ps), SP_OK);
        sp_admit_coef_t use;
        if (sp_admit_coefficients(&c, &st, ax, in_use, &use) != SP_OK) {
            continue;
        }
        /* k around an edge: where round(k 2^16 / w_c) crosses D - tol or D + tol */
        const double edge = ((tu_next(&rng) & 1u) ? (double)(in_use - tol) - 0.5 : (double)(in_use + tol) + 0.5) *
                            (double)c.crossover / 65536.0;
        const int64_t k = (int64_t)edge + (int64_t)(tu_next(&rng) % 7u) - 3;
        if (k < 1 || k > (1 << 30)) {
            continue;
        }
        sp_admit_axis_state_t *a = &st.axis[ax];
        plain_axis_state_t *b = &ps.axis[ax];
        a->coef = use;
        b->coef = use;
        for (unsigned n = 0; n < 4u; ++n) {
            a->x_f[n] = -65536;
            b->x_f[n] = -65536;
        }
        st.primed = (uint8_t)(1u << ax);
        ps.primed = 1u;
        a->in_contact = b->in_contact = 1u;
        a->x_contact = b->x_contact = 0;
        a->w_contact = b->w_contact = 0;
        a->k_hat = b->k_hat = 1;
        sp_q8_t w[SP_AXES] = {0}, t[SP_AXES] = {0};
        sp_q24_t xm[SP_AXES] = {0}, lo[SP_AXES], hi[SP_AXES];
        wide_bounds(lo, hi);
        w[ax] = (sp_q8_t)k;
        xm[ax] = -65536;
        const uint8_t bit = (uint8_t)(1u << ax);
        sp_admit_report_t r1, r2;
        assert_int_equal(sp_admit_step(&c, &st, SP_ADMIT_FORCE, bit, w, t, xm, bit, lo, hi, &r1),
                         plain_admit_step(&c, &ps, SP_ADMIT_FORCE, bit, w, t, xm, bit, lo, hi, &r2));
        assert_int_equal(r1.adapted, r2.adapted);
        assert_int_equal(a->k_hat, (int32_t)k);
        expect_same_state(&st, &ps, run, 0);
        acted += (r1.adapted != 0u) ? 1 : 0;
        quiet += (r1.adapted == 0u) ? 1 : 0;
    }
    print_message("adaptation window edges: %d adapted, %d kept the damping\n", acted, quiet);
    assert_true(acted > 500 && quiet > 500);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_configure_rejects),
        cmocka_unit_test(test_step_vs_double),
        cmocka_unit_test(test_force_hold_each_stiffness),
        cmocka_unit_test(test_force_hold_cylinders_estimate),
        cmocka_unit_test(test_fixed_damping_fails_on_stiff),
        cmocka_unit_test(test_contact_lost),
        cmocka_unit_test(test_hand_guiding),
        cmocka_unit_test(test_release_is_critically_damped),
        cmocka_unit_test(test_contact_events),
        cmocka_unit_test(test_step_equals_plain),
        cmocka_unit_test(test_restart_is_configure),
        cmocka_unit_test(test_contact_equals_plain),
        cmocka_unit_test(test_secant_window_edges),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
