/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The firmware's CANopen master (sp/canopen/canopen_master.h) against the plant's
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
 * - The master's own heartbeat: every 100 ms on each bus, pre-operational
 *   until the drives run, then operational; the drives' consumer (0x1016.1,
 *   written at start-up) raises EMCY 0x8130 when it falls silent.
 *
 * CiA 402 (cyclic synchronous position), the same master with the profile
 * per node set to 402 against the plant's nodes presenting themselves as
 * CiA 402 drives:
 * - Start-up: plan, read-backs and 0x6061 = 8 read; DISABLED = ready to
 *   switch on; HOLD = operation enabled through shutdown, switch on, enable
 *   operation, the target held at the actual position (no jump); ACTIVE:
 *   the setpoints followed; back to HOLD: the target latched where it was.
 *   Prints the time to ready and the SDO transfers.
 * - 0x6061 not showing 8: READBACK naming 0x6061; a CiA 408 drive where
 *   a 402 one is configured: WRONG_PROFILE (402).
 * - EMCY while ACTIVE: latched, the faulted drive is sent quick stop, the
 *   others hold their latched target; the reset (fault reset, bit 7) brings
 *   it back to operation enabled, then ACTIVE.
 * - Heartbeat lost: the drive is quick-stopped, the others hold.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hs/co_node.h"
#include "sp/canopen/canopen_master.h"

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
    uint16_t emcy_code;    /* the code of the first one */
} rig_t;

static rig_t rig;

static void to_master(rig_t *r, const sp_can_frame_t *f)
{
    if (f->id > SP_CO_COB_EMCY && f->id < SP_CO_COB_TPDO1 && r->emcy_seen_ms == 0u) {
        r->emcy_seen_ms = r->now;
        r->emcy_code = (uint16_t)(f->data[0] | (f->data[1] << 8));
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

static int setup_profile(uint8_t profile)
{
    uint8_t k;
    memset(&rig, 0, sizeof rig);
    assert_int_equal(sp_co_master_cfg_default(&rig.cfg, N), SP_OK);
    for (k = 0u; k < N; k++) {
        rig.cfg.node[k].profile = profile;
        assert_int_equal(hs_co_node_init_profile(&rig.node[k], rig.cfg.node[k].node_id, rig.cfg.node[k].bus, profile),
                         HS_OK);
        rig.node[k].actual = 1000 * (int32_t)k;
    }
    if (profile == SP_CO_PROFILE_402) {
        rig.cfg.pressure_feedback = 0u;
    }
    assert_int_equal(sp_co_master_init(&rig.m), SP_OK);
    assert_int_equal(sp_co_master_start(&rig.m, &rig.cfg, 0u), SP_OK);
    return 0;
}

static int setup(void **state)
{
    (void)state;
    return setup_profile(SP_CO_PROFILE_408);
}

static int setup402(void **state)
{
    (void)state;
    return setup_profile(SP_CO_PROFILE_402);
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
    /* 1 identity read + 29 writes + 23 read-backs per drive */
    assert_int_equal(sdo_total(), N * (1u + 29u + 23u));
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
    assert_int_equal(rig.m.node[1].skipped, 1u << 6); /* the plan's 7th write is 0x1006 */
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

/* A slow SDO server (hs_sim --sdo-delay-ms; a drive storing each object):
 * every answer 20 ms late, within the master's SDO timeout. The start-up
 * takes the 53 transfers in a row of each drive (the drives in parallel),
 * at least 53 x 20 ms, and ends with every drive ready; the controller's
 * request does not hurry it. */
static void test_slow_sdo_server(void **state)
{
    uint8_t k;
    (void)state;
    for (k = 0u; k < N; k++) {
        rig.node[k].sdo_delay_ms = 20u;
    }
    rig.in.request = SP_CO_REQ_ACTIVE;
    RUN_UNTIL(rig.out.ready || rig.out.fault_mask != 0u, 53u * 20u);
    assert_false(rig.out.ready); /* still configuring after 53 x 20 ms */
    assert_int_equal(rig.out.fault_mask, 0u);
    RUN_UNTIL(rig.out.ready || rig.out.fault_mask != 0u, 3000u);
    assert_int_equal(rig.out.fault_mask, 0u);
    assert_true(rig.out.ready);
    assert_int_equal(sdo_total(), N * (1u + 29u + 23u));
    printf("canopen start-up with 20 ms SDO answers: ready after %u ms\n", (unsigned)rig.now);
    assert_in_range(rig.now, 53u * 20u, 53u * 24u + 100u);
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

static void test_master_heartbeat(void **state)
{
    uint32_t t0, seen[SP_CAN_BUSES] = {0u}, first = 0u;
    uint8_t i, last_state = 0xFFu;
    (void)state;
    t0 = rig.now;
    while (rig.now - t0 < 1000u) {
        tick(&rig);
        for (i = 0u; i < rig.out.n_tx; i++) {
            const sp_can_frame_t *f = &rig.out.tx[i];
            if (f->id == SP_CO_COB_HEARTBEAT + rig.cfg.master_node_id) {
                assert_int_equal(f->len, 1u);
                seen[f->bus]++;
                first = first == 0u ? rig.now : first;
                last_state = f->data[0];
            }
        }
    }
    assert_int_equal(rig.cfg.master_heartbeat_ms, 100u);
    assert_int_equal(seen[SP_BUS_AXIS_A], 10u);
    assert_int_equal(seen[SP_BUS_AXIS_B], 10u);
    assert_int_equal(first, 100u);                             /* one period after the start */
    assert_int_equal(last_state, SP_CO_NMT_STATE_OPERATIONAL); /* the drives run */
    /* the drives watch it (0x1016.1, three periods): the master falls silent -> EMCY 0x8130 */
    assert_int_equal(hs_co_node_find(&rig.node[0], 0x1016u, 1u)->value, (127u << 16) | 300u);
    assert_int_equal(rig.out.fault_mask, 0u);
    rig.mute_master = 1u; /* (the master sees the TPDOs stop; what matters here is the drives' side) */
    rig.emcy_seen_ms = 0u;
    t0 = rig.now;
    RUN_UNTIL(rig.emcy_seen_ms != 0u, 500u);
    assert_int_equal(rig.emcy_code, 0x8130u);
    assert_int_equal(rig.node[0].fault, 1u);
    assert_in_range(rig.now - t0, 200u, 301u); /* 300 ms after the last heartbeat, sent up to 100 ms before */
    printf("canopen master heartbeat: every %u ms on each bus; the drives' consumer raised EMCY 0x8130 %u ms "
           "after the master fell silent\n",
           (unsigned)rig.cfg.master_heartbeat_ms, (unsigned)(rig.now - t0));
    rig.mute_master = 0u;
    /* the master's id is refused for a drive */
    rig.cfg.node[0].node_id = rig.cfg.master_node_id;
    assert_int_equal(sp_co_master_cfg_check(&rig.cfg), SP_E_ARG);
    rig.cfg.master_heartbeat_ms = 0u;
    assert_int_equal(sp_co_master_cfg_check(&rig.cfg), SP_OK);
}

/* ---- CiA 402 ---- */

static void assert_402(uint8_t k, sp_co402_state_t s)
{
    assert_int_equal(rig.node[k].state402, s);
}

static void test_402_startup(void **state)
{
    uint8_t k;
    uint32_t t_ready, t_hold;
    (void)state;
    RUN_UNTIL(rig.out.ready, 1000u);
    assert_true(rig.out.ready);
    t_ready = rig.now;
    for (k = 0u; k < N; k++) {
        assert_int_equal(rig.m.node[k].phase, SP_CO_PHASE_RUN);
        assert_402(k, SP_CO402_READY);
        assert_int_equal(hs_co_node_find(&rig.node[k], 0x6061u, 0u)->value, 8u);
        assert_int_equal(hs_co_node_find(&rig.node[k], 0x60C2u, 1u)->value, 1u);
    }
    /* 1 identity read + 21 writes + 17 read-backs + the 0x6061 read per drive */
    assert_int_equal(sdo_total(), N * (1u + 21u + 17u + 1u));
    printf("canopen CiA 402 start-up: 6 drives ready (ready to switch on) after %u ms, %u SDO transfers\n",
           (unsigned)t_ready, (unsigned)sdo_total());
    /* HOLD: operation enabled, the target the actual position */
    rig.in.request = SP_CO_REQ_HOLD;
    for (k = 0u; k < N; k++) {
        rig.in.setpoint[k] = 99999; /* not followed in HOLD */
    }
    tick(&rig);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    t_hold = rig.now;
    printf("canopen CiA 402 ready to switch on -> operation enabled (HOLD): %u ms\n", (unsigned)(t_hold - t_ready));
    for (k = 0u; k < N; k++) {
        assert_402(k, SP_CO402_OPERATION_ENABLED);
        assert_true(hs_co_node_follows(&rig.node[k]));
        assert_int_equal(rig.node[k].setpoint, 1000 * (int32_t)k);
        assert_int_equal(rig.node[k].control, SP_CO402_CW_ENABLE_OPERATION);
    }
    /* ACTIVE: the setpoints followed */
    rig.in.request = SP_CO_REQ_ACTIVE;
    for (k = 0u; k < N; k++) {
        rig.in.setpoint[k] = -5000 + 77 * (int32_t)k;
    }
    RUN_UNTIL(0, 3u);
    assert_true(rig.out.ready);
    for (k = 0u; k < N; k++) {
        assert_int_equal(rig.node[k].setpoint, -5000 + 77 * (int32_t)k);
        assert_int_equal(rig.m.node[k].actual, 1000 * (int32_t)k);
    }
    /* HOLD again: the target stays at the last one sent */
    rig.in.request = SP_CO_REQ_HOLD;
    for (k = 0u; k < N; k++) {
        rig.in.setpoint[k] = 12345;
    }
    RUN_UNTIL(0, 10u);
    assert_true(rig.out.ready);
    for (k = 0u; k < N; k++) {
        assert_402(k, SP_CO402_OPERATION_ENABLED);
        assert_int_equal(rig.node[k].setpoint, -5000 + 77 * (int32_t)k);
    }
}

static void test_402_mode_not_shown(void **state)
{
    (void)state;
    RUN_UNTIL(rig.m.node[2].phase == SP_CO_PHASE_READBACK, 1000u);
    hs_co_node_find(&rig.node[2], 0x6061u, 0u)->value = 1u; /* profile position: the drive did not take 8 */
    RUN_UNTIL(rig.out.fault_mask != 0u, 1000u);
    assert_int_equal(rig.out.fault_mask, 1u << 2);
    assert_int_equal(rig.m.node[2].fault.code, SP_CO_F_READBACK);
    assert_int_equal(rig.m.node[2].fault.index, 0x6061u);
    assert_int_equal(rig.m.node[2].fault.detail, 1u);
    assert_int_equal(rig.m.node[2].fault.expect, 8u);
    RUN_UNTIL(0, 300u);
    assert_false(rig.out.ready);
    assert_402(0, SP_CO402_READY); /* the others: nothing beyond DISABLED */
}

static void test_402_wrong_profile(void **state)
{
    (void)state;
    hs_co_node_find(&rig.node[5], 0x1000u, 0u)->value = 0x00000198u; /* a CiA 408 valve */
    RUN_UNTIL(rig.out.fault_mask != 0u, 1000u);
    assert_int_equal(rig.m.node[5].fault.code, SP_CO_F_WRONG_PROFILE);
    assert_int_equal(rig.m.node[5].fault.expect, 402u);
}

static void bring_up_402_active(void)
{
    uint8_t k;
    bring_up(SP_CO_REQ_ACTIVE);
    for (k = 0u; k < N; k++) {
        rig.in.setpoint[k] = 2000 + (int32_t)k;
    }
    RUN_UNTIL(0, 3u);
    for (k = 0u; k < N; k++) {
        assert_int_equal(rig.node[k].setpoint, 2000 + (int32_t)k);
    }
}

/* What the controller asks after a fault: not followed (HOLD). */
static void ask_7000(void)
{
    uint8_t k;
    for (k = 0u; k < N; k++) {
        rig.in.setpoint[k] = 7000;
    }
}

static void test_402_emcy(void **state)
{
    uint8_t k;
    (void)state;
    bring_up_402_active();
    assert_int_equal(hs_co_node_raise(&rig.node[1], 0x2310u), HS_OK); /* current */
    RUN_UNTIL(rig.out.fault_mask != 0u, 10u);
    assert_int_equal(rig.m.node[1].fault.code, SP_CO_F_EMCY);
    assert_int_equal(rig.m.node[1].fault.index, 0x2310u);
    ask_7000();
    RUN_UNTIL(0, 5u);
    assert_402(1, SP_CO402_FAULT);
    assert_int_equal(rig.node[1].control, SP_CO402_CW_QUICK_STOP);
    for (k = 0u; k < N; k++) {
        if (k != 1u) {
            assert_402(k, SP_CO402_OPERATION_ENABLED);
            assert_int_equal(rig.node[k].setpoint, 2000 + (int32_t)k); /* held, 7000 not followed */
        }
    }
    rig.in.request = SP_CO_REQ_HOLD;
    assert_int_equal(sp_co_master_reset(&rig.m, &rig.cfg, rig.now), SP_OK);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    assert_402(1, SP_CO402_OPERATION_ENABLED);
    assert_int_equal(rig.node[1].fault, 0u);
    rig.in.request = SP_CO_REQ_ACTIVE;
    tick(&rig);
    RUN_UNTIL(rig.out.ready, 100u);
    assert_true(rig.out.ready);
    RUN_UNTIL(0, 2u);
    assert_int_equal(rig.node[1].setpoint, 7000);
}

static void test_402_heartbeat_lost(void **state)
{
    uint8_t k;
    (void)state;
    bring_up_402_active();
    rig.node[3].silent = 1u;
    RUN_UNTIL(rig.out.fault_mask != 0u, 200u);
    assert_int_equal(rig.m.node[3].fault.code, SP_CO_F_HEARTBEAT_LOST);
    ask_7000();
    RUN_UNTIL(0, 3u);
    assert_402(3, SP_CO402_QUICK_STOP_ACTIVE);
    assert_false(hs_co_node_follows(&rig.node[3]));
    for (k = 0u; k < N; k++) {
        if (k != 3u) {
            assert_402(k, SP_CO402_OPERATION_ENABLED);
            assert_int_equal(rig.node[k].setpoint, 2000 + (int32_t)k);
        }
    }
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
        cmocka_unit_test_setup(test_master_heartbeat, setup),
        cmocka_unit_test_setup(test_slow_sdo_server, setup),
        cmocka_unit_test_setup(test_402_startup, setup402),
        cmocka_unit_test_setup(test_402_mode_not_shown, setup402),
        cmocka_unit_test_setup(test_402_wrong_profile, setup402),
        cmocka_unit_test_setup(test_402_emcy, setup402),
        cmocka_unit_test_setup(test_402_heartbeat_lost, setup402),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
