/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_plant_faults.c - the drives' fault reset over CAN (the setpoints'
 * FaultReset edge, hs/bus.h) and the plant's injected faults (hs/plant.h):
 * a reset clears a drive's faults only when their cause is gone, and says
 * which cause remains otherwise.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hs/bus.h"
#include "hs/inject.h"
#include "hs/kin.h"
#include "hs/plant.h"
#include "assert_near.h"

#define DT 1e-3

static hs_plant_t plant;
static hs_params_t params;
static hs_bus_t bus;
static double hold_len[HS_LEGS];
static uint8_t counter[2];

static void start(void)
{
    assert_int_equal(hs_params_default(&params), HS_OK);
    assert_int_equal(hs_plant_init(&plant, &params, params.home), HS_OK);
    assert_int_equal(hs_bus_init(&bus), HS_OK);
    hs_leg_lengths(&params, params.home, hold_len);
    counter[0] = counter[1] = 0u;
}

/* The controller's AXIS_SETPOINTS for both buses (hold at home), FaultReset as given. */
static void send_setpoints(uint8_t mode, uint8_t fault_reset)
{
    for (uint8_t b = 0; b < 2u; b++) {
        sp_msg_setpoints_t m;
        sp_can_frame_t f;
        memset(&m, 0, sizeof m);
        m.tick = bus.tick;
        m.mode = mode;
        m.fault_reset = fault_reset;
        for (int s = 0; s < 3; s++) {
            m.setpoint[s].length = (sp_q24_t)llround(hold_len[3 * b + s] * 16777216.0);
        }
        assert_int_equal(sp_proto_encode_setpoints(&m, counter[b], (uint8_t)(SP_BUS_AXIS_A + b), &f), SP_OK);
        counter[b] = (uint8_t)((counter[b] + 1u) & 0x0Fu);
        assert_int_equal(hs_bus_receive(&bus, &plant, &f), HS_OK);
    }
}

static void cycle(uint8_t mode, uint8_t fault_reset)
{
    sp_can_frame_t out[HS_BUS_MAX_TX];
    uint32_t n = 0;
    assert_int_equal(hs_bus_cycle_frames(&bus, &plant, bus.tick + 1u, 1u, out, &n), HS_OK);
    send_setpoints(mode, fault_reset);
    assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
}

static hs_feedback_t feedback(int leg)
{
    hs_feedback_t fb;
    assert_int_equal(hs_plant_feedback(&plant, leg, &fb), HS_OK);
    return fb;
}

/* A one-shot severe fault (no cause left) clears on the edge, only on the edge. */
static void test_reset_clears_on_edge(void **state)
{
    (void)state;
    start();
    cycle(1u, 0u);
    assert_int_equal(hs_plant_raise_faults(&plant, 4, HS_FAULT_VALVE), HS_OK);
    cycle(0u, 0u);
    assert_int_equal(feedback(4).state, HS_DRIVE_FAULT);
    assert_int_equal(feedback(4).faults, HS_FAULT_VALVE);
    cycle(0u, 1u); /* the edge */
    assert_int_equal(bus.stats.resets, 6u);
    assert_int_equal(bus.stats.resets_refused, 0u);
    assert_int_equal(feedback(4).faults, 0u);
    assert_int_equal(feedback(4).state, HS_DRIVE_HOLD); /* INIT, then the HOLD request */
    /* a level held at 1 is no new edge: a new fault stays */
    assert_int_equal(hs_plant_raise_faults(&plant, 1, HS_FAULT_FOLLOWING), HS_OK);
    cycle(0u, 1u);
    assert_int_equal(feedback(1).state, HS_DRIVE_FAULT);
    assert_int_equal(bus.stats.resets, 6u);
    cycle(0u, 0u);
    cycle(0u, 1u);
    assert_int_equal(feedback(1).faults, 0u);
    assert_int_equal(bus.stats.resets, 12u);
}

/* Causes that remain: the reset is refused and the feedback says which. */
static void test_reset_refused_with_cause(void **state)
{
    (void)state;
    start();
    cycle(1u, 0u);
    assert_int_equal(hs_plant_inject_valve(&plant, 2, 1, 0.0), HS_OK);
    assert_int_equal(hs_plant_raise_faults(&plant, 2, HS_FAULT_VALVE), HS_OK);
    assert_int_equal(hs_plant_inject_sensor(&plant, 3, HS_SENSOR_STICK, 0.0), HS_OK);
    assert_int_equal(hs_plant_raise_faults(&plant, 3, HS_FAULT_SENSOR), HS_OK);
    assert_int_equal(hs_plant_inject_drive(&plant, 5, HS_FAULT_INTERNAL), HS_OK);
    cycle(0u, 0u);
    cycle(0u, 1u);
    assert_int_equal(bus.stats.resets_refused, 3u);
    assert_int_equal(feedback(2).state, HS_DRIVE_FAULT);
    assert_int_equal(feedback(2).faults, HS_FAULT_VALVE);
    assert_int_equal(feedback(3).faults, HS_FAULT_SENSOR);
    assert_int_equal(feedback(5).faults, HS_FAULT_INTERNAL);
    /* the supply lost: every drive refuses with the pressure bit */
    assert_int_equal(hs_plant_inject_supply(&plant, 1), HS_OK);
    cycle(0u, 0u);
    cycle(0u, 1u);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_true((feedback(i).faults & HS_FAULT_PRESSURE) != 0u);
    }
    /* causes removed: the next edge clears them all */
    assert_int_equal(hs_plant_inject_supply(&plant, 0), HS_OK);
    assert_near(plant.par.cyl[0].supply_pressure, params.cyl[0].supply_pressure, 0.0, "supply restored (Pa)");
    assert_int_equal(hs_plant_inject_valve(&plant, 2, 0, 0.0), HS_OK);
    assert_int_equal(hs_plant_inject_sensor(&plant, 3, HS_SENSOR_OK, 0.0), HS_OK);
    assert_int_equal(hs_plant_inject_drive(&plant, 5, 0u), HS_OK);
    cycle(0u, 0u);
    cycle(0u, 1u);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_int_equal(feedback(i).faults, 0u);
        assert_int_equal(feedback(i).state, HS_DRIVE_HOLD);
    }
}

/* Sensor faults: stick, jump and noise change what the drive reads, not the truth. */
static void test_sensor_faults(void **state)
{
    hs_state_t st;
    (void)state;
    start();
    cycle(1u, 0u);
    double l0 = feedback(0).length;
    assert_int_equal(hs_plant_inject_sensor(&plant, 0, HS_SENSOR_JUMP, 0.002), HS_OK);
    assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    assert_near(feedback(0).length, l0 + 0.002, 2e-6, "jumped reading (m)");
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    assert_near(st.length[0], l0, 5e-6, "true length unchanged (m)");
    assert_int_equal(hs_plant_inject_sensor(&plant, 0, HS_SENSOR_STICK, 1.0), HS_OK);
    assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
    assert_near(feedback(0).length, 1.0, 1e-6, "stuck reading (m)");
    assert_int_equal(hs_plant_inject_sensor(&plant, 0, HS_SENSOR_NOISE, 0.001), HS_OK);
    double lo = 1e9, hi = -1e9;
    for (int k = 0; k < 50; ++k) {
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        double d = feedback(0).length - l0;
        lo = (d < lo) ? d : lo;
        hi = (d > hi) ? d : hi;
    }
    assert_true(hi - lo > 0.001);   /* it is noisy */
    assert_true(fabs(lo) < 0.0045); /* bounded: 3.47 sigma plus the drive's motion */
    assert_int_equal(hs_plant_inject_sensor(&plant, 0, (hs_sensor_fault_t)7, 0.0), HS_E_ARG);
    assert_int_equal(hs_plant_inject_valve(&plant, 0, 1, 1.5), HS_E_ARG);
    assert_int_equal(hs_plant_inject_valve(&plant, 6, 1, 0.5), HS_E_ARG);
}

/* Runs a plant (no bus) for n cycles with every drive ACTIVE on its home
 * length, leg `leg` on a ramp at v m/s from t0 (s); returns the cycles run
 * until `leg` reported `bit` (n if never). */
static int run_ramp(int leg, double v, double t0, int n, uint32_t bit)
{
    for (int k = 0; k < n; ++k) {
        double t = (double)k * DT;
        for (int i = 0; i < HS_LEGS; ++i) {
            double l = hold_len[i], vi = 0.0;
            if (i == leg && t > t0) {
                l += v * (t - t0);
                vi = v;
            }
            assert_int_equal(hs_plant_set_setpoint(&plant, i, l, vi, 0.0, HS_REQ_ACTIVE), HS_OK);
        }
        assert_int_equal(hs_plant_step(&plant, DT), HS_OK);
        if ((feedback(leg).faults & bit) != 0u) {
            return k + 1;
        }
    }
    return n;
}

/* A valve stuck fully open: without the valve monitor (threshold out of
 * reach) only the following error (20 mm) finds it; with it the drive
 * faults within 4 ms, its blocking valves close in 20 ms and the leg stops
 * a few mm on (the campaign's endstop rows: without the blocking valves the
 * cylinder ran into its end stop whatever the drive commanded). */
static void test_stuck_open_valve_blocked(void **state)
{
    hs_state_t st0, st;
    (void)state;
    /* the runaway the blocking valves prevent */
    start();
    params.drive.spool_error_max = 1e9;
    assert_int_equal(hs_plant_init(&plant, &params, params.home), HS_OK);
    assert_int_equal(run_ramp(1, 0.0, 0.0, 20, 0u), 20);
    assert_int_equal(hs_plant_state(&plant, &st0), HS_OK);
    assert_int_equal(hs_plant_inject_valve(&plant, 1, 1, 1.0), HS_OK);
    (void)run_ramp(1, 0.0, 0.0, 200, 0u);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    print_message("stuck open, no monitor: leg 2 moved %.1f mm in 200 ms\n", (st.length[1] - st0.length[1]) * 1e3);
    assert_true(st.length[1] - st0.length[1] > 0.02);
    assert_true((feedback(1).faults & HS_FAULT_FOLLOWING) != 0u);
    /* the drive's valve monitor and blocking valves */
    start();
    assert_int_equal(run_ramp(1, 0.0, 0.0, 20, 0u), 20);
    assert_int_equal(hs_plant_state(&plant, &st0), HS_OK);
    assert_int_equal(hs_plant_inject_valve(&plant, 1, 1, 1.0), HS_OK);
    int k = run_ramp(1, 0.0, 0.0, 50, HS_FAULT_VALVE);
    print_message("stuck open: valve fault after %d cycles\n", k);
    assert_true(k <= 4);
    assert_int_equal(feedback(1).state, HS_DRIVE_FAULT);
    (void)run_ramp(1, 0.0, 0.0, 30, 0u);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    assert_true(st.block[1] == 0.0);
    assert_true(st.block[0] == 1.0); /* the other drives keep theirs open */
    double moved = st.length[1] - st0.length[1];
    (void)run_ramp(1, 0.0, 0.0, 500, 0u); /* the oil columns settle: the pressures the stuck valve left balance */
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    double settled = st.length[1] - st0.length[1];
    (void)run_ramp(1, 0.0, 0.0, 250, 0u);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    print_message("stuck open: leg 2 %.2f mm on when blocked, %.2f mm after 0.5 s, then %.4f mm in 0.25 s, "
                  "%.4f mm/s at the end\n",
                  moved * 1e3, settled * 1e3, (st.length[1] - st0.length[1] - settled) * 1e3, st.rate[1] * 1e3);
    assert_true(moved > 0.0 && moved < 0.01);
    assert_true(fabs(settled) < 0.01);
    assert_near(st.length[1] - st0.length[1], settled, 0.00005, "blocked: the leg stays (m)");
    assert_near(st.rate[1], 0.0, 0.001, "at rest (m/s)");
    assert_true(feedback(1).state == HS_DRIVE_FAULT && (feedback(1).faults & HS_FAULT_VALVE) != 0u);
    for (int i = 0; i < HS_LEGS; ++i) {
        if (i != 1) {
            assert_int_equal(feedback(i).faults & (HS_FAULT_VALVE | HS_FAULT_SENSOR), 0u);
        }
    }
}

/* A length sensor stuck while its leg moves at 20 mm/s: the drive's flow
 * balance finds it after 1 mm of unseen travel (30 ms: the position loop,
 * blind, speeds the leg up), its blocking valves
 * stop the leg; the same ramp with a healthy sensor raises nothing (the
 * balance's largest reading stated). */
static void test_stuck_sensor_found_by_flow_balance(void **state)
{
    hs_state_t st0, st;
    (void)state;
    start();
    assert_int_equal(run_ramp(0, 0.02, 0.05, 600, HS_FAULT_SENSOR), 600);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_int_equal(feedback(i).faults, 0u);
    }
    double peak = 0.0;
    for (int i = 0; i < HS_LEGS; ++i) {
        peak = fmax(peak, plant.drive[i].chk_travel_peak);
    }
    print_message("healthy ramp: flow balance peak %.4f mm (fault above 1 mm), spool error peak %.2e\n", peak * 1e3,
                  plant.drive[0].spool_error_peak);
    assert_true(peak < 0.1e-3);
    assert_true(plant.drive[0].spool_error_peak < 0.01);
    assert_near(st.length[0] - hold_len[0], 0.02 * 0.55, 0.002, "the ramp was followed (m)");

    start();
    assert_int_equal(run_ramp(0, 0.02, 0.05, 100, HS_FAULT_SENSOR), 100);
    assert_int_equal(hs_plant_state(&plant, &st0), HS_OK);
    assert_int_equal(hs_plant_inject_sensor(&plant, 0, HS_SENSOR_STICK, 0.0), HS_OK);
    int k = run_ramp(0, 0.02, -0.05, 500, HS_FAULT_SENSOR);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    print_message("stuck sensor at 20 mm/s: sensor fault after %d cycles, the leg %.2f mm on\n", k,
                  (st.length[0] - st0.length[0]) * 1e3);
    assert_true(k >= 20 && k <= 50);
    assert_int_equal(feedback(0).state, HS_DRIVE_FAULT);
    (void)run_ramp(0, 0.02, -0.05, 500, 0u);
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    print_message("stuck sensor: the leg %.2f mm on after 0.5 s, %.4f mm/s\n", (st.length[0] - st0.length[0]) * 1e3,
                  st.rate[0] * 1e3);
    assert_true(st.block[0] == 0.0);
    assert_true(fabs(st.length[0] - st0.length[0]) < 0.003);
    assert_near(st.rate[0], 0.0, 0.001, "at rest (m/s)");
}

/* n frames: id, bus, payload byte 0 = k (to follow them) */
static void frames(sp_can_frame_t *f, uint32_t n, uint32_t id, uint8_t on_bus)
{
    for (uint32_t k = 0; k < n; k++) {
        memset(&f[k], 0, sizeof f[k]);
        f[k].id = id;
        f[k].bus = on_bus;
        f[k].len = 12u;
        f[k].data[0] = (uint8_t)k;
    }
}

static void check_accounting(const hs_inject_t *inj)
{
    const hs_inject_stats_t *s = &inj->stats;
    assert_int_equal(s->in + s->duplicated, s->out + s->dropped + s->busoff + s->pending);
}

static void test_injector_frames(void **state)
{
    static hs_inject_t inj;
    sp_can_frame_t in[4], out[HS_INJ_MAX_OUT];
    uint32_t n = 0;
    (void)state;
    assert_int_equal(hs_inject_init(&inj, 1u), HS_OK);
    /* drop the next 2 feedback frames of axis_a; other buses and ids pass */
    hs_frame_rule_t r = {SP_BUS_AXIS_A, 0x31u, 0x33u, HS_FRAME_DROP, 0.0, 2u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_OK);
    frames(in, 3, 0x31u, SP_BUS_AXIS_A);
    in[1].bus = SP_BUS_AXIS_B;
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_CONTROLLER, 1u, in, 3, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 1u);
    assert_int_equal(out[0].bus, SP_BUS_AXIS_B);
    assert_int_equal(inj.stats.dropped, 2u);
    assert_int_equal(inj.active[0], 0); /* used up */
    /* duplicate, corrupt (one bit), reorder (behind the next frame of its bus) */
    r = (hs_frame_rule_t){SP_BUS_OPS, 0x100u, 0x100u, HS_FRAME_DUPLICATE, 0.0, 1u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_OK);
    frames(in, 2, 0x100u, SP_BUS_OPS);
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_PLANT, 2u, in, 2, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 3u);
    assert_int_equal(out[0].data[0], 0);
    assert_int_equal(out[1].data[0], 0);
    assert_int_equal(out[2].data[0], 1);
    r = (hs_frame_rule_t){SP_BUS_OPS, 0x100u, 0x100u, HS_FRAME_CORRUPT, 0.0, 1u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_OK);
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_PLANT, 3u, in, 1, out, HS_INJ_MAX_OUT, &n), HS_OK);
    int flipped = 0;
    for (unsigned b = 0; b < 12u; b++) {
        flipped += __builtin_popcount((unsigned)(out[0].data[b] ^ in[0].data[b]));
    }
    assert_int_equal(flipped, 1);
    r = (hs_frame_rule_t){SP_BUS_OPS, 0x100u, 0x100u, HS_FRAME_REORDER, 0.0, 1u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_OK);
    frames(in, 3, 0x100u, SP_BUS_OPS);
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_PLANT, 4u, in, 3, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 3u);
    assert_int_equal(out[0].data[0], 1);
    assert_int_equal(out[1].data[0], 0);
    assert_int_equal(out[2].data[0], 2);
    /* delay: held, then first of the tick it is due */
    r = (hs_frame_rule_t){SP_BUS_AXIS_B, 0x20u, 0x20u, HS_FRAME_DELAY, 0.0, 1u, 3u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_OK);
    frames(in, 1, 0x20u, SP_BUS_AXIS_B);
    in[0].data[0] = 42u;
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_PLANT, 10u, in, 1, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 0u);
    assert_int_equal(inj.stats.pending, 1u);
    check_accounting(&inj);
    frames(in, 1, 0x20u, SP_BUS_AXIS_B);
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_PLANT, 12u, in, 1, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 1u);
    assert_int_equal(out[0].data[0], 0);
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_CONTROLLER, 13u, NULL, 0, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 0u); /* the other direction's queue */
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_PLANT, 13u, NULL, 0, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 1u);
    assert_int_equal(out[0].data[0], 42);
    check_accounting(&inj);
    /* bus-off: nothing on the bus but the lockstep SYNC */
    assert_int_equal(hs_inject_busoff(&inj, SP_BUS_AXIS_A, 20u), HS_OK);
    frames(in, 2, 0x31u, SP_BUS_AXIS_A);
    in[1].id = SP_ID_SYNC;
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_CONTROLLER, 19u, in, 2, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 1u);
    assert_int_equal(out[0].id, SP_ID_SYNC);
    assert_int_equal(hs_inject_filter(&inj, HS_INJ_TO_CONTROLLER, 20u, in, 2, out, HS_INJ_MAX_OUT, &n), HS_OK);
    assert_int_equal(n, 2u);
    check_accounting(&inj);
    /* refused rules */
    r = (hs_frame_rule_t){SP_BUS_OPS, 5u, 4u, HS_FRAME_DROP, 0.0, 1u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_E_ARG);
    r = (hs_frame_rule_t){SP_BUS_OPS, 4u, 4u, HS_FRAME_DROP, 0.0, 0u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_E_ARG);
    r = (hs_frame_rule_t){SP_BUS_OPS, 4u, 4u, HS_FRAME_DELAY, 0.5, 0u, 0u};
    assert_int_equal(hs_inject_add(&inj, &r), HS_E_ARG);
}

/* A rate: about that share of the frames, the same ones for the same seed. */
static void test_injector_rate(void **state)
{
    static hs_inject_t a, b;
    sp_can_frame_t in[8], oa[HS_INJ_MAX_OUT], ob[HS_INJ_MAX_OUT];
    (void)state;
    hs_frame_rule_t r = {HS_INJ_ANY_BUS, 0u, 0x7FFu, HS_FRAME_DROP, 0.1, 0u, 0u};
    assert_int_equal(hs_inject_init(&a, 7u), HS_OK);
    assert_int_equal(hs_inject_init(&b, 7u), HS_OK);
    assert_int_equal(hs_inject_add(&a, &r), HS_OK);
    assert_int_equal(hs_inject_add(&b, &r), HS_OK);
    frames(in, 8, 0x40u, SP_BUS_OPS);
    for (uint64_t t = 0; t < 2500u; t++) {
        uint32_t na = 0, nb = 0;
        (void)hs_inject_filter(&a, HS_INJ_TO_CONTROLLER, t, in, 8, oa, HS_INJ_MAX_OUT, &na);
        (void)hs_inject_filter(&b, HS_INJ_TO_CONTROLLER, t, in, 8, ob, HS_INJ_MAX_OUT, &nb);
        assert_int_equal(na, nb);
        assert_memory_equal(oa, ob, na * sizeof oa[0]);
    }
    double share = (double)a.stats.dropped / (double)a.stats.in;
    print_message("rate 0.1: %u of %u frames dropped (%.4f)\n", a.stats.dropped, a.stats.in, share);
    assert_true(fabs(share - 0.1) < 0.01); /* 20000 draws: sigma 0.002 */
    check_accounting(&a);
}

/* The supply lost: every drive's monitor puts it in FAULT with its valve at
 * null, and the oil columns hold the platform (leakage only). */
static void test_supply_loss_holds(void **state)
{
    hs_state_t st0, st;
    (void)state;
    start();
    for (int k = 0; k < 20; ++k) {
        cycle(1u, 0u);
    }
    assert_int_equal(hs_plant_state(&plant, &st0), HS_OK);
    assert_int_equal(hs_plant_inject_supply(&plant, 1), HS_OK);
    cycle(1u, 0u);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_int_equal(feedback(i).state, HS_DRIVE_FAULT);
        assert_true((feedback(i).faults & HS_FAULT_PRESSURE) != 0u);
    }
    for (int k = 0; k < 500; ++k) {
        cycle(1u, 0u);
    }
    assert_int_equal(hs_plant_state(&plant, &st), HS_OK);
    for (int i = 0; i < HS_LEGS; ++i) {
        assert_true(st.valve_cmd[i] == 0.0);
    }
    print_message("supply lost: the platform moved %.3f mm in 0.5 s\n", fabs(st.pose[2] - st0.pose[2]) * 1e3);
    assert_near(st.pose[2], st0.pose[2], 0.002, "z held without supply (m)");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reset_clears_on_edge),
        cmocka_unit_test(test_reset_refused_with_cause),
        cmocka_unit_test(test_sensor_faults),
        cmocka_unit_test(test_stuck_open_valve_blocked),
        cmocka_unit_test(test_stuck_sensor_found_by_flow_balance),
        cmocka_unit_test(test_supply_loss_holds),
        cmocka_unit_test(test_injector_frames),
        cmocka_unit_test(test_injector_rate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
