/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_dynamics_rest.c - the leg terms' short path for a motion at rest
 * (dynamics.c, leg_terms_at_rest) against its plain reference: the same
 * dynamics.c compiled here with SPI_LEG_TERMS_AT_REST 0, so that every
 * motion goes through leg_terms' general formulas. Forces, leg rates, the
 * kept terms and the factorisation must be the same bits, for random leg
 * masses, centres and poses, with and without kept legs, and a motion that
 * is not at rest must not take the short path's result.
 */
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

/* the plain reference: dynamics.c without the short path
 * (plain_dynamics.h) */
#define SPI_LEG_TERMS_AT_REST 0
#include "plain/plain_dynamics.h"

#define N_CASES 4000

/* A random platform (leg masses and centres, centre of mass) and a pose
 * around home: +-0.2 m, +-0.15 m in z, +-15 degrees. */
static void random_case(uint64_t *rng, sp_platform_t *p, sp_motion_t *m)
{
    *p = sp_platform_default;
    p->leg_mass.cylinder_mass = ref_q16(tu_uniform(rng, 0.0, 120.0));
    p->leg_mass.cylinder_com = ref_q24(tu_uniform(rng, 0.1, 1.0));
    p->leg_mass.rod_mass = ref_q16(tu_uniform(rng, 0.0, 60.0));
    p->leg_mass.rod_com = ref_q24(tu_uniform(rng, 0.1, 1.0));
    /* the legs' moments of inertia across the leg: half the cases point
     * masses, half up to 30 + 20 kg m^2 (within the fast path's envelope) */
    {
        /* drawn from a stream of their own, so that the cases' other draws
         * (and what they cover) stay those of the point-mass legs */
        uint64_t irng = *rng ^ UINT64_C(0x9e3779b97f4a7c15);
        p->leg_mass.cylinder_inertia = (tu_uniform(&irng, 0.0, 1.0) < 0.5) ? 0 : ref_q16(tu_uniform(&irng, 0.0, 30.0));
        p->leg_mass.rod_inertia = (p->leg_mass.cylinder_inertia == 0) ? 0 : ref_q16(tu_uniform(&irng, 0.0, 20.0));
    }
    for (int k = 0; k < 3; ++k) {
        p->center_of_mass[k] = ref_q24(tu_uniform(rng, -0.2, 0.2));
    }
    memset(m, 0, sizeof *m);
    m->pose = p->home;
    for (int k = 0; k < 3; ++k) {
        m->pose.pos[k] += ref_q24(tu_uniform(rng, -0.2, 0.2) * (k == 2 ? 0.75 : 1.0));
        m->pose.rpy[k] += ref_q24(tu_uniform(rng, -0.26, 0.26));
    }
}

/* Both versions on the same inputs; returns 1 when the short path was
 * compared at all (the pose's IK succeeded). */
static int compare(const sp_platform_t *p, const sp_motion_t *m, uint64_t *rng)
{
    sp_ik_t ik;
    sp_jacobian_t jac;
    sp_q8_t f_new[SP_LEGS], f_ref[SP_LEGS];
    sp_q24_t r_new[SP_LEGS], r_ref[SP_LEGS];
    sp_lu6_t lu_new, lu_ref;
    sp_leg_hold_t h_new, h_ref;
    if (sp_inverse_kinematics(p, &m->pose, &ik) != SP_OK || sp_jacobian(&ik, &jac) != SP_OK) {
        return 0;
    }
    memset(&lu_new, 0, sizeof lu_new);
    memset(&lu_ref, 0, sizeof lu_ref);
    sp_status_t a = sp_inverse_dynamics_rates(p, m, &ik, &jac, NULL, f_new, &lu_new, r_new);
    sp_status_t b = plain_inverse_dynamics_rates(p, m, &ik, &jac, NULL, f_ref, &lu_ref, r_ref);
    assert_int_equal(a, b);
    assert_memory_equal(f_new, f_ref, sizeof f_new);
    assert_memory_equal(r_new, r_ref, sizeof r_new);
    assert_memory_equal(&lu_new, &lu_ref, sizeof lu_new);
    /* kept legs: the held terms of an earlier, moving motion, one random
     * group refreshed at this one */
    {
        sp_motion_t before = *m;
        unsigned refresh = 1u << (unsigned)tu_uniform(rng, 0.0, 5.99);
        sp_ik_t ik0;
        sp_jacobian_t jac0;
        for (int k = 0; k < 3; ++k) {
            before.vel[k] = ref_q24(tu_uniform(rng, -0.5, 0.5));
            before.acc[k] = ref_q24(tu_uniform(rng, -5.0, 5.0));
            before.rpy_rate[k] = ref_q24(tu_uniform(rng, -0.5, 0.5));
        }
        before.pose.pos[0] += ref_q24(0.001);
        assert_int_equal(sp_inverse_kinematics(p, &before.pose, &ik0), SP_OK);
        assert_int_equal(sp_jacobian(&ik0, &jac0), SP_OK);
        memset(&h_ref, 0, sizeof h_ref);
        h_ref.lu_keep = 6u;
        memset(&lu_ref, 0, sizeof lu_ref);
        (void)plain_inverse_dynamics_held(p, &before, &ik0, &jac0, NULL, f_ref, &lu_ref, r_ref, &h_ref, 0x3Fu);
        h_new = h_ref;
        lu_new = lu_ref;
        a = sp_inverse_dynamics_held(p, m, &ik, &jac, NULL, f_new, &lu_new, r_new, &h_new, refresh);
        b = plain_inverse_dynamics_held(p, m, &ik, &jac, NULL, f_ref, &lu_ref, r_ref, &h_ref, refresh);
        assert_int_equal(a, b);
        assert_memory_equal(f_new, f_ref, sizeof f_new);
        assert_memory_equal(r_new, r_ref, sizeof r_new);
        assert_memory_equal(&h_new, &h_ref, sizeof h_new);
        assert_memory_equal(&lu_new, &lu_ref, sizeof lu_new);
    }
    return 1;
}

static void test_rest_path_equals_general(void **state)
{
    uint64_t rng = 15u;
    int compared = 0;
    int legs_on = 0;
    (void)state;
    for (int n = 0; n < N_CASES; ++n) {
        sp_platform_t p;
        sp_motion_t m;
        random_case(&rng, &p, &m);
        if (n % 8 == 0) {
            p.leg_mass.cylinder_mass = 0; /* massless legs: no leg terms at all */
            p.leg_mass.rod_mass = 0;
            p.leg_mass.cylinder_inertia = 0;
            p.leg_mass.rod_inertia = 0;
        }
        legs_on += (p.leg_mass.cylinder_mass != 0 || p.leg_mass.rod_mass != 0);
        compared += compare(&p, &m, &rng);
    }
    print_message("at rest: %d of %d cases compared (%d with leg masses), every output the same bits\n", compared,
                  N_CASES, legs_on);
    assert_true(compared >= N_CASES * 9 / 10 && legs_on >= N_CASES * 8 / 10);
}

/* A motion with one rate or acceleration not zero is not at rest: the
 * short path must not be taken (its forces would miss that term). Checked
 * against the plain version for each of the twelve inputs on its own. */
static void test_not_at_rest(void **state)
{
    uint64_t rng = 16u;
    (void)state;
    for (int n = 0; n < 120; ++n) {
        sp_platform_t p;
        sp_motion_t m;
        random_case(&rng, &p, &m);
        int32_t *field[12] = {&m.vel[0], &m.vel[1], &m.vel[2], &m.rpy_rate[0], &m.rpy_rate[1], &m.rpy_rate[2],
                              &m.acc[0], &m.acc[1], &m.acc[2], &m.rpy_acc[0],  &m.rpy_acc[1],  &m.rpy_acc[2]};
        *field[n % 12] = ref_q24(tu_uniform(&rng, 0.05, 1.0));
        assert_true(compare(&p, &m, &rng));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rest_path_equals_general),
        cmocka_unit_test(test_not_at_rest),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
