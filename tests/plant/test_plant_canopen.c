/*
 * The firmware's CANopen master (sp/canopen_master.h) against the plant's
 * CiA 408 nodes (hs/co_node.h), frame by frame on a simulated bus, one call
 * of each per millisecond (issue 18):
 *
 * - Start-up of six drives: every node configured by SDO (plan written and
 *   read back), operational, DISABLED -> HOLD -> ACTIVE; the setpoint the
 *   master sends is the one each node applies at SYNC. Prints the time to
 *   ready and the SDO transfers made.
 * - The drive's dictionary after start-up holds every value of the plan.
 * - An optional object the drive lacks is skipped; the drive still runs.
 * - A drive that aborts an SDO write: SDO_ABORT naming the object and the
 *   abort code; nothing is asked beyond DISABLED, no drive is ACTIVE.
 * - A drive that never boots: NO_BOOT after boot_timeout_ms, not before;
 *   the others stay DISABLED.
 * - A drive of another profile (0x1000 = 402): WRONG_PROFILE.
 * - A read-back that differs: READBACK with the value read and written.
 * - EMCY while ACTIVE: EMCY latched in the tick of the frame, named by
 *   class; the others HOLD within 2 SYNC periods; reset -> ready again.
 * - Heartbeat lost while ACTIVE: HEARTBEAT_LOST within the configured
 *   timeout (+ 1 tick), not before it; the others HOLD. After the reset the
 *   drive is configured again while the others stay in HOLD; then ACTIVE.
 * - The drive's setpoint watchdog (RPDO event timer): when the master stops
 *   sending, the drive raises EMCY 0x8250 and leaves ACTIVE.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hs/co_node.h"
#include "sp/canopen_master.h"

#define N 6u
#define QMAX 128u

typedef struct {
    sp_co_master_t m;
    sp_co_master_cfg_t cfg;
    hs_co_node_t node[N];
    sp_co_master_input_t in;
    sp_co_master_output_t out;
    uint32_t now;
    uint8_t mute_master;   /* 1: the master's frames are not delivered */
    uint32_t emcy_seen_ms; /* when an EMCY frame reached the master (0: none) */
} rig_t;

static rig_t rig;

static void to_master(rig_t *r, const sp_can_frame_t *f)
{
    if (f->id > SP_CO_COB_EMCY && f->id < SP_CO_COB_TPDO1 && r->emcy_seen_ms == 0u) {
        r->emcy_seen_ms = r->now;
    }
    (void)sp_co_master_receive(&r->m, &r->cfg, f, r->now);
}

/* One millisecond: node clocks, then the master's step, its frames to
 * the nodes, their answers to the master. */
static void tick(rig_t *r)
{
    uint8_t k, i, j, n;
    sp_can_frame_t tx[HS_CO_MAX_TX];
    r->now++;
    for (k = 0u; k < N; k++) {
        assert_int_equal(hs_co_node_tick(&r->node[k], 1u, tx, &n), HS_OK);
        for (i = 0u; i < n; i++) {
            to_master(r, &tx[i]);
        }
    }
    r->in.now_ms = r->now;
    assert_int_equal(sp_co_master_step(&r->m, &r->cfg, &r->in, &r->out), SP_OK);
    if (r->mute_master) {
        return;
    }
    for (i = 0u; i < r->out.n_tx; i++) {
        for (k = 0u; k < N; k++) {
            assert_int_equal(hs_co_node_receive(&r->node[k], &r->out.tx[i], tx, &n), HS_OK);
            for (j = 0u; j < n; j++) {
                to_master(r, &tx[j]);
            }
        }
    }
}

static int setup(void **state)
{
    uint8_t k;
    (void)state;
    memset(&rig, 0, sizeof rig);
    assert_int_equal(sp_co_master_cfg_default(&rig.cfg, N), SP_OK);
    for (k = 0u; k < N; k++) {
        assert_int_equal(hs_co_node_init(&rig.node[k], rig.cfg.node[k].node_id, rig.cfg.node[k].bus), HS_OK);
        rig.node[k].actual = 1000 * (int32_t)k;
    }
    assert_int_equal(sp_co_master_init(&rig.m), SP_OK);
    assert_int_equal(sp_co_master_start(&rig.m, &rig.cfg, 0u), SP_OK);
    return 0;
}

/* Ticks until cond or limit ms; returns the ms taken. */
#define RUN_UNTIL(cond, limit)                                                                                         \
    do {                                                                                                               \
        uint32_t t0_ = rig.now;                                                                                        \
        while (!(cond) && rig.now - t0_ < (limit)) {                                                                   \
            tick(&rig);                                                                                                \
        }                                                                                                              \
    } while (0)

static uint32_t sdo_total(void)
{
    uint32_t s = 0u;
    uint8_t k;
    for (k = 0u; k < N; k++) {
        s += rig.node[k].sdo_count;
    }
    return s;
}

static void bring_up(uint8_t request)
{
    rig.in.request = SP_CO_REQ_DISABLED;
    RUN_UNTIL(rig.out.ready, 1000u);
    assert_true(rig.out.ready);
    rig.in.request = SP_CO_REQ_HOLD;
    tick(&rig);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    if (request == SP_CO_REQ_ACTIVE) {
        rig.in.request = SP_CO_REQ_ACTIVE;
        tick(&rig);
        RUN_UNTIL(rig.out.ready, 100u);
        assert_true(rig.out.ready);
    }
}

static void test_startup_six_drives(void **state)
{
    uint8_t k;
    uint32_t t_ready;
    (void)state;
    RUN_UNTIL(rig.out.ready, 1000u);
    assert_true(rig.out.ready);
    t_ready = rig.now;
    for (k = 0u; k < N; k++) {
        assert_int_equal(rig.m.node[k].phase, SP_CO_PHASE_RUN);
        assert_int_equal(rig.node[k].nmt, SP_CO_NMT_STATE_OPERATIONAL);
        assert_int_equal(rig.node[k].state, SP_CO408_DISABLED);
        assert_int_equal(rig.out.fault_mask, 0u);
    }
    /* 1 identity read + 28 writes + 22 read-backs per drive */
    assert_int_equal(sdo_total(), N * (1u + 28u + 22u));
    printf("canopen start-up: 6 drives ready (DISABLED) after %u ms, %u SDO transfers\n", (unsigned)t_ready,
           (unsigned)sdo_total());
    rig.in.request = SP_CO_REQ_ACTIVE;
    for (k = 0u; k < N; k++) {
        rig.in.setpoint[k] = -5000 + 77 * (int32_t)k;
    }
    tick(&rig);
    assert_false(rig.out.ready);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    printf("canopen DISABLED -> ACTIVE: %u ms\n", (unsigned)(rig.now - t_ready));
    for (k = 0u; k < N; k++) {
        assert_int_equal(rig.node[k].state, SP_CO408_ACTIVE);
        assert_true(hs_co_node_follows(&rig.node[k]));
        assert_int_equal(rig.node[k].setpoint, -5000 + 77 * (int32_t)k);
        assert_int_equal(rig.m.node[k].actual, 1000 * (int32_t)k);
        assert_int_equal(rig.m.node[k].status & 0xFu, 0xFu);
    }
}

static void test_plan_in_dictionary(void **state)
{
    sp_co_sdo_write_t plan[SP_CO_PLAN_MAX];
    uint8_t n, i, k;
    (void)state;
    RUN_UNTIL(rig.out.ready, 1000u);
    assert_true(rig.out.ready);
    for (k = 0u; k < N; k++) {
        assert_int_equal(sp_co_plan_build(&rig.cfg, k, plan, &n), SP_OK);
        for (i = 0u; i < n; i++) {
            const hs_co_entry_t *e;
            if (!plan[i].final) {
                continue;
            }
            e = hs_co_node_find(&rig.node[k], plan[i].index, plan[i].sub);
            assert_non_null(e);
            assert_int_equal(e->value, plan[i].value);
        }
        assert_int_equal(hs_co_node_find(&rig.node[k], 0x1400u, 5u)->value, rig.cfg.setpoint_timeout_ms);
    }
}

static void test_optional_object_skipped(void **state)
{
    (void)state;
    /* node 2 has no 0x1006: remove it from its dictionary */
    hs_co_entry_t *e = hs_co_node_find(&rig.node[1], 0x1006u, 0u);
    e->index = 0x5FFFu;
    RUN_UNTIL(rig.out.ready, 1000u);
    assert_true(rig.out.ready);
    assert_int_equal(rig.m.node[1].skipped, 1u << 5); /* the plan's 6th write is 0x1006 */
    assert_int_equal(rig.m.node[0].skipped, 0u);
}

static void assert_still(void)
{
    uint8_t k;
    for (k = 0u; k < N; k++) {
        assert_false(hs_co_node_follows(&rig.node[k]));
        assert_true(rig.node[k].state != SP_CO408_ACTIVE);
    }
}

static void test_sdo_abort(void **state)
{
    (void)state;
    rig.node[2].abort_index = 0x6043u;
    rig.node[2].abort_sub = 0u;
    rig.node[2].abort_code = SP_CO_SDO_ABORT_RANGE;
    rig.in.request = SP_CO_REQ_ACTIVE; /* the controller asks; the master must not */
    RUN_UNTIL(rig.out.fault_mask != 0u, 1000u);
    assert_int_equal(rig.out.fault_mask, 1u << 2);
    assert_int_equal(rig.m.node[2].fault.code, SP_CO_F_SDO_ABORT);
    assert_int_equal(rig.m.node[2].fault.index, 0x6043u);
    assert_int_equal(rig.m.node[2].fault.sub, 0u);
    assert_int_equal(rig.m.node[2].fault.detail, 0x06090030u);
    assert_string_equal(sp_co_fault_name(SP_CO_F_SDO_ABORT), "SDO abort");
    assert_string_equal(sp_co_sdo_abort_name(rig.m.node[2].fault.detail), "value range of parameter exceeded");
    assert_int_equal(rig.m.node[2].phase, SP_CO_PHASE_FAILED);
    RUN_UNTIL(0, 500u);
    assert_false(rig.out.ready);
    assert_still();
}

static void test_never_boots(void **state)
{
    (void)state;
    rig.node[4].never_boot = 1u;
    rig.in.request = SP_CO_REQ_ACTIVE;
    RUN_UNTIL(rig.out.fault_mask != 0u, 3000u);
    assert_int_equal(rig.out.fault_mask, 1u << 4);
    assert_int_equal(rig.m.node[4].fault.code, SP_CO_F_NO_BOOT);
    /* the reset goes out in the first step (t = 1 ms); the fault at boot_timeout_ms after it, not before */
    assert_in_range(rig.m.node[4].fault.time_ms, 1u + rig.cfg.boot_timeout_ms, 2u + rig.cfg.boot_timeout_ms);
    assert_string_equal(sp_co_fault_name(SP_CO_F_NO_BOOT), "no boot-up");
    RUN_UNTIL(0, 200u);
    assert_still();
    assert_int_equal(rig.node[0].state, SP_CO408_DISABLED);
}

static void test_wrong_profile(void **state)
{
    (void)state;
    hs_co_node_find(&rig.node[0], 0x1000u, 0u)->value = 0x00020192u; /* a CiA 402 drive */
    RUN_UNTIL(rig.out.fault_mask != 0u, 1000u);
    assert_int_equal(rig.m.node[0].fault.code, SP_CO_F_WRONG_PROFILE);
    assert_int_equal(rig.m.node[0].fault.detail, 0x00020192u);
    assert_int_equal(rig.m.node[0].fault.expect, 408u);
}

static void test_readback_differs(void **state)
{
    (void)state;
    /* let node 1 take its writes, then change 0x1017 behind the master's back */
    RUN_UNTIL(rig.m.node[0].phase == SP_CO_PHASE_READBACK, 1000u);
    assert_int_equal(rig.m.node[0].phase, SP_CO_PHASE_READBACK);
    hs_co_node_find(&rig.node[0], 0x1017u, 0u)->value = 100u;
    RUN_UNTIL(rig.out.fault_mask != 0u, 1000u);
    assert_int_equal(rig.m.node[0].fault.code, SP_CO_F_READBACK);
    assert_int_equal(rig.m.node[0].fault.index, 0x1017u);
    assert_int_equal(rig.m.node[0].fault.detail, 100u);
    assert_int_equal(rig.m.node[0].fault.expect, 20u);
}

static void test_emcy(void **state)
{
    uint8_t k;
    uint32_t t;
    (void)state;
    bring_up(SP_CO_REQ_ACTIVE);
    rig.emcy_seen_ms = 0u;
    assert_int_equal(hs_co_node_raise(&rig.node[1], 0x4210u), HS_OK); /* temperature */
    RUN_UNTIL(rig.out.fault_mask != 0u, 10u);
    assert_int_equal(rig.out.fault_mask, 1u << 1);
    assert_int_equal(rig.m.node[1].fault.code, SP_CO_F_EMCY);
    assert_int_equal(rig.m.node[1].fault.index, 0x4210u);
    assert_int_not_equal(rig.emcy_seen_ms, 0u);
    assert_int_equal(rig.m.node[1].fault.time_ms, rig.emcy_seen_ms); /* in the tick of its frame */
    assert_string_equal(sp_co_emcy_class_name(rig.m.node[1].fault.index), "temperature");
    t = rig.now;
    RUN_UNTIL(0, 3u);
    for (k = 0u; k < N; k++) {
        assert_false(hs_co_node_follows(&rig.node[k]));
    }
    assert_int_equal(rig.node[0].state, SP_CO408_HOLD);
    assert_true(sp_co408_is_fault(rig.node[1].state));
    printf("canopen EMCY: latched in the tick of its frame; all drives out of ACTIVE %u ms later\n",
           (unsigned)(rig.now - t));
    /* the operator's reset: R edge, the drive's fault cleared, HOLD again, then ACTIVE */
    rig.in.request = SP_CO_REQ_HOLD;
    assert_int_equal(sp_co_master_reset(&rig.m, &rig.cfg, rig.now), SP_OK);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    assert_int_equal(rig.node[1].state, SP_CO408_HOLD);
    rig.in.request = SP_CO_REQ_ACTIVE;
    tick(&rig);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    assert_true(hs_co_node_follows(&rig.node[1]));
}

static void test_heartbeat_lost(void **state)
{
    uint32_t t0;
    uint8_t k;
    (void)state;
    bring_up(SP_CO_REQ_ACTIVE);
    /* silence right after a heartbeat: the next would come in heartbeat_ms */
    RUN_UNTIL(rig.node[3].hb_elapsed_ms == 0u, 100u);
    rig.node[3].silent = 1u;
    t0 = rig.now;
    RUN_UNTIL(rig.out.fault_mask != 0u, 200u);
    assert_int_equal(rig.out.fault_mask, 1u << 3);
    assert_int_equal(rig.m.node[3].fault.code, SP_CO_F_HEARTBEAT_LOST);
    assert_int_equal(rig.now - t0, rig.cfg.heartbeat_timeout_ms); /* within the configured time, not before */
    printf("canopen heartbeat lost: detected %u ms after the last heartbeat (timeout %u ms)\n",
           (unsigned)(rig.now - t0), (unsigned)rig.cfg.heartbeat_timeout_ms);
    RUN_UNTIL(0, 3u);
    for (k = 0u; k < N; k++) {
        assert_false(hs_co_node_follows(&rig.node[k]));
        assert_int_equal(rig.node[k].state, SP_CO408_HOLD);
    }
    /* the drive speaks again; the operator's reset starts it again from NMT reset: the others
     * hold (never DISABLED: a disabled valve goes to its fail-safe position) until all run */
    rig.node[3].silent = 0u;
    rig.in.request = SP_CO_REQ_HOLD; /* the controller in FAULT, at rest */
    assert_int_equal(sp_co_master_reset(&rig.m, &rig.cfg, rig.now), SP_OK);
    t0 = rig.now;
    while (!rig.out.ready && rig.now - t0 < 1000u) {
        tick(&rig);
        for (k = 0u; k < N; k++) {
            if (k != 3u) {
                assert_int_equal(rig.node[k].state, SP_CO408_HOLD);
            }
        }
    }
    assert_true(rig.out.ready);
    assert_int_equal(rig.out.fault_mask, 0u);
    printf("canopen restart of one drive after the reset: ready again in %u ms, the others in HOLD throughout\n",
           (unsigned)(rig.now - t0));
    rig.in.request = SP_CO_REQ_ACTIVE; /* engaged again */
    tick(&rig);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    assert_true(hs_co_node_follows(&rig.node[3]));
}

static void test_drive_watchdog(void **state)
{
    (void)state;
    bring_up(SP_CO_REQ_ACTIVE);
    rig.mute_master = 1u;
    RUN_UNTIL(0, (uint32_t)rig.cfg.setpoint_timeout_ms + 2u);
    assert_int_equal(rig.node[0].fault, 1u);
    assert_int_equal(rig.node[0].emcy_pending, 0u); /* sent */
    assert_int_equal(rig.m.node[0].fault.code, SP_CO_F_EMCY);
    assert_int_equal(rig.m.node[0].fault.index, 0x8250u);
    assert_string_equal(sp_co_emcy_class_name(0x8250u), "protocol");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_startup_six_drives, setup),
        cmocka_unit_test_setup(test_plan_in_dictionary, setup),
        cmocka_unit_test_setup(test_optional_object_skipped, setup),
        cmocka_unit_test_setup(test_sdo_abort, setup),
        cmocka_unit_test_setup(test_never_boots, setup),
        cmocka_unit_test_setup(test_wrong_profile, setup),
        cmocka_unit_test_setup(test_readback_differs, setup),
        cmocka_unit_test_setup(test_emcy, setup),
        cmocka_unit_test_setup(test_heartbeat_lost, setup),
        cmocka_unit_test_setup(test_drive_watchdog, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
