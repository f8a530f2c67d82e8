/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The soak's invariant checker (host_sim/app/soak_check.c): a tick that
 * keeps every invariant passes, and each invariant broken on its own is
 * caught and named; the legal transition table against the controller's
 * state machine as controller.c has it.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "soak_check.h"

static soak_limits_t lim;

static void good(soak_snap_t *s)
{
    memset(s, 0, sizeof *s);
    s->tick = 1000u;
    s->prev_state = s->state = SP_STATE_RUNNING;
    s->active = 1;
    s->reference = sp_platform_default.home;
    for (int i = 0; i < SP_LEGS; i++) {
        s->sp[i].length = (lim.lim.length_min + lim.lim.length_max) / 2;
        s->sp[i].force = 20000 * 256;
        s->length[i] = 2.5;
        s->force[i] = 20000.0;
    }
    s->finite = 1;
}

static int setup(void **state)
{
    (void)state;
    assert_int_equal(sp_limits_prepare(&lim.lim, &sp_platform_default, 167772), SP_OK); /* 10 mm */
    lim.length_lo = 1.85 - 0.005;
    lim.length_hi = 3.25 + 0.005;
    lim.plant_force_max = 120000.0;
    return 0;
}

static soak_violation_t check(const soak_snap_t *s)
{
    char why[256];
    soak_violation_t v = soak_check(&lim, s, why, sizeof why);
    assert_true((v == SOAK_OK) == (why[0] == '\0')); /* a violation always says what */
    return v;
}

static void test_a_good_tick_passes(void **state)
{
    (void)state;
    soak_snap_t s;
    good(&s);
    assert_int_equal(check(&s), SOAK_OK);
    s.active = 0;
    s.reference.pos[0] = lim.lim.ws_hi[0] + 1; /* holding: the reference is not passed on */
    assert_int_equal(check(&s), SOAK_OK);
}

static void test_each_invariant_is_caught(void **state)
{
    (void)state;
    soak_snap_t s;
    good(&s), s.reference.rpy[2] = lim.lim.ws_lo[5] - 1;
    assert_int_equal(check(&s), SOAK_V_WORKSPACE);
    good(&s), s.sp[3].length = lim.lim.length_max + 1;
    assert_int_equal(check(&s), SOAK_V_STROKE);
    good(&s), s.length[5] = lim.length_lo - 1e-6;
    assert_int_equal(check(&s), SOAK_V_STROKE);
    good(&s), s.sp[0].force = -lim.lim.force_max - 1;
    assert_int_equal(check(&s), SOAK_V_FORCE);
    good(&s), s.force[2] = 120001.0;
    assert_int_equal(check(&s), SOAK_V_FORCE);
    s.injected = 1; /* a fault injected: the true forces are the fault's */
    assert_int_equal(check(&s), SOAK_OK);
    good(&s), s.prev_state = SP_STATE_IDLE, s.state = SP_STATE_RUNNING;
    assert_int_equal(check(&s), SOAK_V_TRANSITION);
    good(&s), s.unaccounted = UINT32_MAX; /* one frame counted twice */
    assert_int_equal(check(&s), SOAK_V_FRAMES);
    good(&s), s.saturated = 1u;
    assert_int_equal(check(&s), SOAK_V_OVERFLOW);
    good(&s), s.state = SP_STATE_FAULT, s.faults = SP_FAULT_COMPUTE, s.active = 0;
    assert_int_equal(check(&s), SOAK_V_OVERFLOW);
    s.prev_faults = SP_FAULT_COMPUTE; /* latched before: not this tick's */
    assert_int_equal(check(&s), SOAK_OK);
    good(&s), s.state = SP_STATE_FAULT, s.faults = SP_FAULT_REFERENCE, s.active = 0, s.injected = 1;
    assert_int_equal(check(&s), SOAK_OK);
    good(&s), s.force[1] = NAN, s.finite = 0;
    assert_int_equal(check(&s), SOAK_V_FINITE);
    good(&s), s.length[1] = NAN; /* NaN fails the range check even if finite is not cleared */
    assert_int_equal(check(&s), SOAK_V_STROKE);
}

static void test_transition_table(void **state)
{
    (void)state;
    for (int a = 0; a <= SP_STATE_STOPPING; a++) {
        assert_true(soak_transition_legal(a, a, SP_CMD_NONE, 0));
        assert_true(soak_transition_legal(a, SP_STATE_ESTOP, SP_CMD_ESTOP, 0));
        assert_true(soak_transition_legal(a, SP_STATE_STOPPING, SP_CMD_ESTOP, 0));
        for (int b = 0; b <= SP_STATE_STOPPING; b++) {
            /* an ESTOP command is always taken: STOPPING (the controlled stop) or ESTOP */
            assert_false(soak_transition_legal(a, b, SP_CMD_ESTOP, 0) && b != SP_STATE_ESTOP && b != SP_STATE_STOPPING);
            assert_false(soak_transition_legal(a, SP_STATE_STOPPING, b, 1) && b != SP_CMD_ESTOP &&
                         a != SP_STATE_STOPPING);
            if (a != SP_STATE_ESTOP && a != SP_STATE_STOPPING) {
                assert_false(soak_transition_legal(a, SP_STATE_ESTOP, b, 1) && b != SP_CMD_ESTOP);
            }
        }
    }
    assert_true(soak_transition_legal(SP_STATE_STOPPING, SP_STATE_ESTOP, SP_CMD_NONE, 0)); /* the stop ended */
    assert_false(soak_transition_legal(SP_STATE_STOPPING, SP_STATE_READY, SP_CMD_NONE, 0));
    assert_false(soak_transition_legal(SP_STATE_STOPPING, SP_STATE_FAULT, SP_CMD_RESET, 0));
    assert_true(soak_transition_legal(SP_STATE_IDLE, SP_STATE_ENGAGING, SP_CMD_ENGAGE, 0));
    assert_false(soak_transition_legal(SP_STATE_IDLE, SP_STATE_ENGAGING, SP_CMD_NONE, 0));
    assert_false(soak_transition_legal(SP_STATE_IDLE, SP_STATE_READY, SP_CMD_ENGAGE, 0));
    assert_true(soak_transition_legal(SP_STATE_READY, SP_STATE_RUNNING, SP_CMD_STREAM, 0));
    assert_false(soak_transition_legal(SP_STATE_READY, SP_STATE_RUNNING, SP_CMD_PARK, 0));
    assert_true(soak_transition_legal(SP_STATE_RUNNING, SP_STATE_PARKING, SP_CMD_NONE, 0));
    assert_false(soak_transition_legal(SP_STATE_PARKING, SP_STATE_READY, SP_CMD_NONE, 0));
    assert_true(soak_transition_legal(SP_STATE_FAULT, SP_STATE_ENGAGING, SP_CMD_RESET, 0));
    assert_true(soak_transition_legal(SP_STATE_FAULT, SP_STATE_ENGAGING, SP_CMD_NONE, 1));
    assert_false(soak_transition_legal(SP_STATE_FAULT, SP_STATE_ENGAGING, SP_CMD_NONE, 0));
    assert_false(soak_transition_legal(SP_STATE_FAULT, SP_STATE_IDLE, SP_CMD_RESET, 0));
    assert_true(soak_transition_legal(SP_STATE_ESTOP, SP_STATE_FAULT, SP_CMD_RESET, 0));
    assert_false(soak_transition_legal(SP_STATE_ESTOP, SP_STATE_FAULT, SP_CMD_NONE, 0));
    assert_false(soak_transition_legal(SP_STATE_ESTOP, SP_STATE_READY, SP_CMD_RESET, 1));
    assert_false(soak_transition_legal(8, SP_STATE_IDLE, SP_CMD_NONE, 0)); /* an unknown state */
    assert_string_equal(soak_violation_name(SOAK_V_TRANSITION), "transition");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_a_good_tick_passes),
        cmocka_unit_test(test_each_invariant_is_caught),
        cmocka_unit_test(test_transition_table),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
