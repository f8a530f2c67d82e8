/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_dynamics_plain.c - the inverse dynamics' untested fast ranges
 * (dynamics.c: inertia_times2 without overflow tests for rates below
 * 32 rad/s, id_finish without range tests for forces below 2 MN) against
 * their plain reference: the same dynamics.c compiled here with
 * SPI_ID_RANGE_FAST 0, so that every input takes the tested path. Forces,
 * leg rates, kept terms and factorisation must be the same bits, for
 * random platforms and motions on both sides of both bounds, single calls
 * and runs of calls that keep legs and refine from a kept factorisation.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "ref_model.h"
#include "sp/model/dynamics.h"
#include "sp/model/kinematics.h"
#include "test_util.h"

/* the plain reference: dynamics.c with every range tested
 * (plain_dynamics.h) */
#define SPI_ID_RANGE_FAST 0
#include "plain/plain_dynamics.h"

#define N_CASES 3000
#define N_RUNS 300
#define RUN_CALLS 14

/* What the cases covered: each bound from both sides. */
typedef struct {
    int compared;   /* calls compared (the pose's IK succeeded) */
    int fast_rates; /* every body rate and acceleration component below 32 (rad/s, rad/s^2) */
    int wide_rates; /* one of them at 32 or more */
    int big_force;  /* a force of 2 MN or more (or SP_E_OVERFLOW) */
    int refined;    /* held calls that refined from a kept factorisation */
    int staged;     /* held calls that finished a staged factorisation and refined with it */
} coverage_t;

/* A random platform: mass up to 30 t, a full inertia tensor, leg masses,
 * centres and a centre of mass (none for one in four). */
static void random_platform(uint64_t *rng, sp_platform_t *p)
{
    *p = sp_platform_default;
    p->mass = ref_q16(tu_uniform(rng, 200.0, 30000.0));
    double ixx = tu_uniform(rng, 100.0, 30000.0);
    double iyy = tu_uniform(rng, 100.0, 30000.0);
    double izz = tu_uniform(rng, 100.0, 30000.0);
    double ixz = tu_uniform(rng, -0.1, 0.1) * ixx;
    p->inertia[0][0] = ref_q16(ixx);
    p->inertia[1][1] = ref_q16(iyy);
    p->inertia[2][2] = ref_q16(izz);
    p->inertia[0][2] = p->inertia[2][0] = ref_q16(ixz);
    p->leg_mass.cylinder_mass = ref_q16(tu_uniform(rng, 0.0, 120.0));
    p->leg_mass.cylinder_com = ref_q24(tu_uniform(rng, 0.1, 1.0));
    p->leg_mass.rod_mass = ref_q16(tu_uniform(rng, 0.0, 60.0));
    p->leg_mass.rod_com = ref_q24(tu_uniform(rng, 0.1, 1.0));
    /* half the cases with the legs' moments of inertia across the leg */
    {
        /* drawn from a stream of their own, so that the cases' other draws
         * (and what they cover) stay those of the point-mass legs */
        uint64_t irng = *rng ^ UINT64_C(0x9e3779b97f4a7c15);
        p->leg_mass.cylinder_inertia = (tu_uniform(&irng, 0.0, 1.0) < 0.5) ? 0 : ref_q16(tu_uniform(&irng, 0.0, 30.0));
        p->leg_mass.rod_inertia = (p->leg_mass.cylinder_inertia == 0) ? 0 : ref_q16(tu_uniform(&irng, 0.0, 20.0));
    }
    for (int k = 0; k < 3; ++k) {
        p->center_of_mass[k] = (tu_uniform(rng, 0.0, 1.0) < 0.25) ? 0 : ref_q24(tu_uniform(rng, -0.2, 0.2));
    }
}

/* A random motion around home: +-0.2 m, +-15 degrees; rates and
 * accelerations up to `scale` times a motion base's (0.5 m/s, 5 m/s^2,
 * 0.5 rad/s, 5 rad/s^2), within Q24's range. */
static void random_motion(uint64_t *rng, const sp_platform_t *p, double scale, sp_motion_t *m)
{
    memset(m, 0, sizeof *m);
    m->pose = p->home;
    for (int k = 0; k < 3; ++k) {
        m->pose.pos[k] += ref_q24(tu_uniform(rng, -0.2, 0.2) * (k == 2 ? 0.75 : 1.0));
        m->pose.rpy[k] += ref_q24(tu_uniform(rng, -0.26, 0.26));
        m->vel[k] = ref_q24(fmin(tu_uniform(rng, -0.5, 0.5) * scale, 100.0));
        m->acc[k] = ref_q24(fmax(fmin(tu_uniform(rng, -5.0, 5.0) * scale, 120.0), -120.0));
        m->rpy_rate[k] = ref_q24(fmax(fmin(tu_uniform(rng, -0.5, 0.5) * scale, 60.0), -60.0));
        m->rpy_acc[k] = ref_q24(fmax(fmin(tu_uniform(rng, -5.0, 5.0) * scale, 120.0), -120.0));
    }
}

static void note_coverage(const sp_motion_t *m, sp_status_t st, const sp_q8_t f[SP_LEGS], coverage_t *cov)
{
    int wide = 0;
    int big = (st == SP_E_OVERFLOW);
    for (int k = 0; k < 3; ++k) {
        /* |w| <= |roll'| + |pitch'| + |yaw'| bounds each body rate */
        wide |= fabs(ref_f24(m->rpy_rate[0])) + fabs(ref_f24(m->rpy_rate[1])) + fabs(ref_f24(m->rpy_rate[2])) >= 32.0;
        wide |= fabs(ref_f24(m->rpy_acc[k])) >= 32.0;
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        big |= (st == SP_OK && fabs(ref_f8(f[i])) >= 2.0e6);
    }
    cov->wide_rates += wide;
    cov->fast_rates += !wide;
    cov->big_force += big;
}

/* One call of each version on the same inputs (ik, jac of m's pose). */
static void compare_call(const sp_platform_t *p, const sp_motion_t *m, const sp_ik_t *ik, const sp_jacobian_t *jac,
                         coverage_t *cov)
{
    sp_q8_t f_new[SP_LEGS], f_ref[SP_LEGS];
    sp_q24_t r_new[SP_LEGS], r_ref[SP_LEGS];
    sp_lu6_t lu_new, lu_ref;
    memset(&lu_new, 0, sizeof lu_new);
    memset(&lu_ref, 0, sizeof lu_ref);
    sp_status_t a = sp_inverse_dynamics_rates(p, m, ik, jac, NULL, f_new, &lu_new, r_new);
    sp_status_t b = plain_inverse_dynamics_rates(p, m, ik, jac, NULL, f_ref, &lu_ref, r_ref);
    assert_int_equal(a, b);
    assert_memory_equal(f_new, f_ref, sizeof f_new);
    assert_memory_equal(&lu_new, &lu_ref, sizeof lu_new);
    if (a == SP_OK) {
        assert_memory_equal(r_new, r_ref, sizeof r_new);
    }
    note_coverage(m, a, f_new, cov);
    cov->compared++;
}

static void test_single_calls_equal_plain(void **state)
{
    uint64_t rng = 41u;
    coverage_t cov;
    (void)state;
    memset(&cov, 0, sizeof cov);
    for (int n = 0; n < N_CASES; ++n) {
        sp_platform_t p;
        sp_motion_t m;
        sp_ik_t ik;
        sp_jacobian_t jac;
        random_platform(&rng, &p);
        /* one in three at a motion base's rates, the others up to 200 times */
        random_motion(&rng, &p, (n % 3 == 0) ? 1.0 : tu_uniform(&rng, 1.0, 200.0), &m);
        if (sp_inverse_kinematics(&p, &m.pose, &ik) != SP_OK || sp_jacobian(&ik, &jac) != SP_OK) {
            continue;
        }
        compare_call(&p, &m, &ik, &jac, &cov);
    }
    print_message("single calls: %d compared (%d rates below 32, %d at or above, %d forces of 2 MN or more), "
                  "every output the same bits\n",
                  cov.compared, cov.fast_rates, cov.wide_rates, cov.big_force);
    assert_true(cov.compared >= N_CASES * 9 / 10);
    assert_true(cov.fast_rates >= N_CASES / 4 && cov.wide_rates >= N_CASES / 4 && cov.big_force >= N_CASES / 20);
}

/* Runs of held calls (one leg refreshed a call, the factorisation kept
 * over seven, or over four and staged over two calls or three, each in
 * one pair of runs of three): the kept terms, the refinement's start and the
 * factorisation must stay the same bits along the run; a finished staged
 * factorisation (two calls or three) is sp_lu6_factor's of the J^T of the
 * call that began it. */
static void test_held_runs_equal_plain(void **state)
{
    uint64_t rng = 42u;
    coverage_t cov;
    (void)state;
    memset(&cov, 0, sizeof cov);
    for (int n = 0; n < N_RUNS; ++n) {
        sp_platform_t p;
        sp_motion_t m;
        sp_leg_hold_t h_new, h_ref;
        sp_lu6_t lu_new, lu_ref;
        sp_jacobian_t jac_began;
        random_platform(&rng, &p);
        random_motion(&rng, &p, (n % 2 == 0) ? 1.0 : tu_uniform(&rng, 1.0, 100.0), &m);
        memset(&h_new, 0, sizeof h_new);
        memset(&lu_new, 0, sizeof lu_new);
        memset(&jac_began, 0, sizeof jac_began);
        h_new.lu_staged = (uint8_t)((n / 2) % 3 == 0 ? 0 : (n / 2) % 3 + 1); /* none, two calls, three */
        h_new.lu_keep = h_new.lu_staged ? 4u : 7u;                           /* staged: three in a run */
        h_ref = h_new;
        lu_ref = lu_new;
        for (int c = 0; c < RUN_CALLS; ++c) {
            sp_ik_t ik;
            sp_jacobian_t jac;
            sp_q8_t f_new[SP_LEGS], f_ref[SP_LEGS];
            sp_q24_t r_new[SP_LEGS], r_ref[SP_LEGS];
            unsigned refresh = (c == 0) ? 0x3Fu : (1u << (unsigned)(c % SP_LEGS));
            /* the motion moves on a little each call */
            for (int k = 0; k < 3; ++k) {
                m.pose.pos[k] += ref_q24(tu_uniform(&rng, -0.002, 0.002));
                m.pose.rpy[k] += ref_q24(tu_uniform(&rng, -0.002, 0.002));
                m.acc[k] += ref_q24(tu_uniform(&rng, -0.05, 0.05));
            }
            if (sp_inverse_kinematics(&p, &m.pose, &ik) != SP_OK || sp_jacobian(&ik, &jac) != SP_OK) {
                break;
            }
            uint8_t age = h_new.lu_age;
            int may_refine = lu_new.valid && h_new.held == 0x3Fu && age + 1u < h_new.lu_keep;
            int begun = h_new.lu_next.begun;
            sp_status_t a = sp_inverse_dynamics_held(&p, &m, &ik, &jac, NULL, f_new, &lu_new, r_new, &h_new, refresh);
            sp_status_t b =
                plain_inverse_dynamics_held(&p, &m, &ik, &jac, NULL, f_ref, &lu_ref, r_ref, &h_ref, refresh);
            assert_int_equal(a, b);
            assert_memory_equal(f_new, f_ref, sizeof f_new);
            assert_memory_equal(&h_new, &h_ref, sizeof h_new);
            assert_memory_equal(&lu_new, &lu_ref, sizeof lu_new);
            if (a == SP_OK) {
                assert_memory_equal(r_new, r_ref, sizeof r_new);
                cov.refined += (may_refine && h_new.lu_age == age + 1u);
                if (begun && h_new.lu_age == 1u) {
                    sp_lu6_t lu_last;
                    memset(&lu_last, 0, sizeof lu_last); /* its padding, as lu_new's */
                    assert_int_equal(sp_lu6_factor(&jac_began, 1, &lu_last), SP_OK);
                    assert_memory_equal(&lu_new, &lu_last, sizeof lu_new);
                    cov.staged++;
                }
            }
            if (!begun && h_new.lu_next.begun) {
                jac_began = jac; /* this call began a staged factorisation */
            }
            note_coverage(&m, a, f_new, &cov);
            cov.compared++;
        }
    }
    print_message("held runs: %d calls compared (%d refined, %d with a staged factorisation; %d rates below 32, %d "
                  "at or above, %d forces of 2 MN or more), every output and kept state the same bits\n",
                  cov.compared, cov.refined, cov.staged, cov.fast_rates, cov.wide_rates, cov.big_force);
    assert_true(cov.compared >= N_RUNS * RUN_CALLS * 8 / 10);
    assert_true(cov.staged >= cov.compared / 60);
    assert_true(cov.refined >= cov.compared / 10 && cov.fast_rates >= cov.compared / 4 &&
                cov.wide_rates >= cov.compared / 10);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_calls_equal_plain),
        cmocka_unit_test(test_held_runs_equal_plain),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
