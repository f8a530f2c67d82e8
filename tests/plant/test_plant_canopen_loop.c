/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Closed loop with CiA 408 drives, in process (issue 18): the firmware's
 * controller (sp_ctrl_step) and CANopen master with its link
 * (sp/canopen/canopen_link.h) command the hydraulic plant (hs_plant) through its
 * six CiA 408 nodes (hs/co_bus.h), frame by frame, 1 ms per tick. The same
 * motion on the native path (the controller's setpoints straight into the
 * plant's drives, feedback straight back: what the DBC frames carry) is the
 * reference.
 *
 * - Start-up by SDO, ENGAGE, the paper's surge (90 mm, 0.5 Hz) with SYNC
 *   every 1 and every 3 ms (the layout of two classic buses with pressures,
 *   docs/reference/canopen.md): the tracking error (reference vs the plant's true
 *   surge, RMS and max over two periods after the fade-in) is printed for
 *   each next to the native path's; CiA 408 at 1 ms is within 10 % of the
 *   native RMS + 0.02 mm (the position-only setpoint loses the force
 *   feed-forward).
 * - The same with CiA 402 drives (cyclic synchronous position: the master
 *   drives each one's state machine to operation enabled, the target
 *   position every SYNC; no pressures): position only at SYNC 1 ms, within
 *   10 % of the native path without its force feed-forward (the same
 *   setpoint as CiA 408's); with the force feed-forward as the torque/force
 *   offset 0x60B2 (per mille of the simulated drive's 10 kN rated force
 *   0x6076) at SYNC 2 ms (the rate at which CiA 402 fits two classic
 *   buses, with no quiet tick in the period) and 3 ms, within 10 % of the
 *   native path with it.
 * - A constant load applied and removed in READY: the wrench estimate's
 *   error against issue 14's bound, natively (within from 20 ms on) and
 *   with CiA 408 at SYNC every 3 ms (later and noisier: within 1.5 times
 *   from 40 ms on; test_wrench_load_native_vs_cia408 says why).
 * - ESTOP while RUNNING with two drives configured disable_on_block: they
 *   go DISABLED once the stop is done, the others HOLD; RESET re-engages.
 * - A drive's heartbeat lost while RUNNING: the master's fault reaches the
 *   controller as a drive fault in the next tick, every drive is asked HOLD
 *   and the platform stops: its speed below 5 mm/s for good within 300 ms.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hs/co_bus.h"
#include "hs/params.h"
#include "sp/canopen/canopen_link.h"
#include "sp/model/kinematics.h"
#include "sp/model/platform.h"

#define Q24 16777216.0

typedef struct {
    hs_params_t par;
    hs_plant_t plant;
    hs_co_bus_t bus;
    sp_ctrl_config_t cfg;
    sp_ctrl_t ctrl;
    sp_ctrl_input_t in;
    sp_ctrl_output_t out;
    sp_co_link_cfg_t link;
    sp_co_master_t m;
    sp_co_master_input_t min;
    sp_co_master_output_t mout;
    uint32_t now;
    int native;   /* 1: the native path instead of CANopen */
    int no_force; /* native: without the force feed-forward (what CiA 408's position setpoint cannot carry) */
} loop_t;

static loop_t L;
static sp_axis_t g_axis = SP_AXIS_X;          /* the motion of the next RUN_TRIG: the paper's surge or yaw */
static uint8_t g_profile = SP_CO_PROFILE_408; /* the drives' profile of the next init */

static void to_master(loop_t *r, const sp_can_frame_t *f, uint8_t n)
{
    uint8_t i;
    for (i = 0u; i < n; i++) {
        (void)sp_co_master_receive(&r->m, &r->link.master, &f[i], r->now);
    }
}

static void init_ff(loop_t *r, int native, uint8_t divider, uint8_t force_ff)
{
    sp_ik_t ik;
    sp_q24_t zero_q24[SP_LEGS];
    double zero[HS_LEGS];
    uint8_t ids[HS_LEGS], buses[HS_LEGS];
    int i;
    memset(r, 0, sizeof *r);
    r->native = native;
    assert_int_equal(hs_params_default(&r->par), HS_OK);
    assert_int_equal(hs_plant_init(&r->plant, &r->par, hs_config_default.park), HS_OK);
    assert_int_equal(sp_ctrl_default_config(&r->cfg, &sp_platform_default), SP_OK);
    r->cfg.feedback_timeout_ticks = (uint32_t)divider + 2u;
    r->cfg.feedback_divider = divider; /* as sp_co_link_ctrl_config sets it */
    assert_int_equal(sp_ctrl_init(&r->ctrl, &r->cfg), SP_OK);
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik), SP_OK);
    for (i = 0; i < SP_LEGS; i++) {
        zero_q24[i] = ik.length[i];
        zero[i] = (double)ik.length[i] / Q24;
    }
    assert_int_equal(sp_co_link_cfg_default(&r->link, &sp_platform_default, zero_q24), SP_OK);
    r->link.master.sync_divider = divider;
    r->link.master.pdo_timeout_ms = (uint16_t)(3u * divider + 5u);
    r->link.master.setpoint_timeout_ms = (uint16_t)(3u * divider);
    for (i = 0; i < HS_LEGS; i++) {
        r->link.master.node[i].force_ff = force_ff;
        r->link.master.node[i].profile = g_profile;
    }
    if (g_profile == SP_CO_PROFILE_402) {
        r->link.master.pressure_feedback = 0u; /* a CiA 402 drive has no chamber pressures */
        for (i = 0; i < SP_LEGS; i++) {
            r->link.scaling[i].rated_force_n = 10000u; /* the simulated drive's 0x6076: 10 kN */
            assert_int_equal(sp_co_scaling_prepare(&r->link.scaling[i]), SP_OK);
        }
    }
    assert_int_equal(sp_co_link_cfg_check(&r->link), SP_OK);
    for (i = 0; i < HS_LEGS; i++) {
        ids[i] = r->link.master.node[i].node_id;
        buses[i] = r->link.master.node[i].bus;
    }
    assert_int_equal(hs_co_bus_init(&r->bus, ids, buses, zero, 1e-6), HS_OK);
    assert_int_equal(hs_co_bus_set_profile(&r->bus, g_profile), HS_OK);
    assert_int_equal(hs_co_bus_sample(&r->bus, &r->plant), HS_OK);
    assert_int_equal(sp_co_master_init(&r->m), SP_OK);
    assert_int_equal(sp_co_master_start(&r->m, &r->link.master, 0u), SP_OK);
}

static void init(loop_t *r, int native, uint8_t divider)
{
    init_ff(r, native, divider, 0u);
}

static void native_tick(loop_t *r)
{
    int i;
    for (i = 0; i < SP_LEGS; i++) {
        hs_feedback_t fb;
        double f;
        assert_int_equal(hs_plant_feedback(&r->plant, i, &fb), HS_OK);
        f = fb.pressure_a * r->par.cyl[i].area_a - fb.pressure_b * r->par.cyl[i].area_b;
        r->in.drive[i].fresh = 1u;
        r->in.drive[i].length = (sp_q24_t)lround(fb.length * Q24);
        r->in.drive[i].force = (sp_q8_t)lround(f * 256.0);
        r->in.drive[i].faults = (uint16_t)fb.faults;
    }
    assert_int_equal(sp_ctrl_step(&r->cfg, &r->ctrl, &r->in, &r->out), SP_OK);
    for (i = 0; i < SP_LEGS; i++) {
        const sp_setpoint_t *s = &r->out.setpoint[i];
        assert_int_equal(hs_plant_set_setpoint(&r->plant, i, (double)s->length / Q24, (double)s->velocity / Q24,
                                               r->no_force ? 0.0 : (double)s->force / 256.0,
                                               r->out.drive_mode == SP_DRIVE_ACTIVE ? HS_REQ_ACTIVE : HS_REQ_HOLD),
                         HS_OK);
    }
    assert_int_equal(hs_plant_step(&r->plant, 1e-3), HS_OK);
}

static void canopen_tick(loop_t *r)
{
    sp_can_frame_t tx[HS_CO_BUS_MAX_TX];
    uint8_t n, i;
    (void)sp_co_link_feedback(&r->m, &r->link, r->in.drive);
    r->in.setpoints_idle = sp_co_link_setpoints_idle(&r->link, &r->m);
    assert_int_equal(sp_ctrl_step(&r->cfg, &r->ctrl, &r->in, &r->out), SP_OK);
    (void)sp_co_link_input_due(&r->link, &r->m, &r->out, r->now, &r->min);
    assert_int_equal(sp_co_master_step(&r->m, &r->link.master, &r->min, &r->mout), SP_OK);
    for (i = 0u; i < r->mout.n_tx; i++) {
        assert_int_equal(hs_co_bus_receive(&r->bus, &r->mout.tx[i], tx, &n), HS_OK);
        to_master(r, tx, n);
    }
    assert_int_equal(hs_co_bus_apply(&r->bus, &r->plant), HS_OK);
    assert_int_equal(hs_plant_step(&r->plant, 1e-3), HS_OK);
    assert_int_equal(hs_co_bus_sample(&r->bus, &r->plant), HS_OK);
    assert_int_equal(hs_co_bus_tick(&r->bus, 1u, tx, &n), HS_OK);
    to_master(r, tx, n);
}

static void tick(loop_t *r, sp_cmd_type_t cmd)
{
    r->now++;
    r->in.cmd.type = cmd;
    if (cmd == SP_CMD_RUN_TRIG) {
        r->in.cmd.axis = g_axis;
        r->in.cmd.amplitude = (sp_q24_t)lround(0.09 * Q24);
        r->in.cmd.frequency = (sp_q24_t)lround(0.5 * Q24);
        r->in.cmd.fade_ticks = 500u;
    }
    if (r->native) {
        native_tick(r);
    } else {
        canopen_tick(r);
    }
    memset(&r->in.cmd, 0, sizeof r->in.cmd);
}

static void run_until_state(loop_t *r, sp_state_t s, uint32_t max)
{
    uint32_t k;
    for (k = 0u; k < max && r->out.state != s; k++) {
        tick(r, SP_CMD_NONE);
    }
    assert_int_equal(r->out.state, s);
}

/* Start-up (CANopen: until the master is ready), ENGAGE, READY. */
static void bring_up(loop_t *r)
{
    uint32_t k;
    for (k = 0u; k < 2000u && !r->native && !r->mout.ready; k++) {
        tick(r, SP_CMD_NONE);
    }
    if (!r->native) {
        assert_true(r->mout.ready);
    }
    tick(r, SP_CMD_NONE);
    tick(r, SP_CMD_ENGAGE);
    assert_int_equal(r->out.state, SP_STATE_ENGAGING);
    run_until_state(r, SP_STATE_READY, 20000u);
}

typedef struct {
    double rms, max;
} track_t;

/* The surge (g_axis X, mm) or yaw (YAW, mrad): fade-in, then two periods
 * measured (reference vs true pose). */
static track_t surge(loop_t *r)
{
    track_t t = {0.0, 0.0};
    double sum = 0.0;
    uint32_t k, n = 0u;
    tick(r, SP_CMD_RUN_TRIG);
    assert_int_equal(r->out.state, SP_STATE_RUNNING);
    for (k = 0u; k < 1000u; k++) {
        tick(r, SP_CMD_NONE);
    }
    for (k = 0u; k < 4000u; k++) {
        double pose[6], e;
        tick(r, SP_CMD_NONE);
        assert_int_equal(r->out.state, SP_STATE_RUNNING);
        assert_int_equal(hs_plant_pose(&r->plant, pose), HS_OK);
        /* the reference of this tick is reached one tick later: compare with the pose after the step */
        e = g_axis == SP_AXIS_YAW ? (double)r->out.reference.pose.rpy[2] / Q24 - pose[5]
                                  : (double)r->out.reference.pose.pos[0] / Q24 - pose[0];
        sum += e * e;
        n++;
        t.max = fabs(e) > t.max ? fabs(e) : t.max;
    }
    t.rms = sqrt(sum / (double)n);
    return t;
}

/* One motion on the native path (with and without its force feed-forward)
 * and on CiA 408 (position only; with the vendor force feed-forward 0x2120
 * in RPDO1), SYNC every 1 and 3 ms. */
static void compare(sp_axis_t axis, const char *name, const char *unit)
{
    track_t nat, nat0, co1, co3, ff1, ff3;
    g_axis = axis;
    init(&L, 1, 1u);
    bring_up(&L);
    nat = surge(&L);
    init(&L, 1, 1u);
    L.no_force = 1;
    bring_up(&L);
    nat0 = surge(&L);
    init(&L, 0, 1u);
    bring_up(&L);
    printf("canopen loop: start-up to READY in %u ms (SDO configuration and ENGAGE)\n", (unsigned)L.now);
    co1 = surge(&L);
    assert_int_equal(L.out.faults, 0u);
    assert_int_equal(L.mout.fault_mask, 0u);
    init(&L, 0, 3u);
    bring_up(&L);
    co3 = surge(&L);
    assert_int_equal(L.out.faults, 0u);
    init_ff(&L, 0, 1u, 1u);
    bring_up(&L);
    ff1 = surge(&L);
    assert_int_equal(L.out.faults, 0u);
    assert_int_equal(L.mout.fault_mask, 0u);
    {
        /* the measured force reaches the controller from the TPDO2 pressures (kPa) */
        int i;
        for (i = 0; i < SP_LEGS; i++) {
            hs_feedback_t fb;
            double f;
            assert_int_equal(hs_plant_feedback(&L.plant, i, &fb), HS_OK);
            f = fb.pressure_a * L.par.cyl[i].area_a - fb.pressure_b * L.par.cyl[i].area_b;
            /* within the kPa resolution (1 kPa on 100 + 56 mm pistons: < 20 N) and the plant's change in one tick */
            assert_true(fabs((double)L.in.drive[i].force / 256.0 - f) < 0.02 * fabs(f) + 50.0);
        }
    }
    init_ff(&L, 0, 3u, 1u);
    bring_up(&L);
    ff3 = surge(&L);
    assert_int_equal(L.out.faults, 0u);
    printf("%s 0.5 Hz, tracking error RMS / max (%s): native %.3f / %.3f, native without force feed-forward "
           "%.3f / %.3f; CiA 408 position only SYNC 1 ms %.3f / %.3f, SYNC 3 ms %.3f / %.3f; CiA 408 with the "
           "force feed-forward 0x2120 SYNC 1 ms %.3f / %.3f, SYNC 3 ms %.3f / %.3f\n",
           name, unit, nat.rms * 1e3, nat.max * 1e3, nat0.rms * 1e3, nat0.max * 1e3, co1.rms * 1e3, co1.max * 1e3,
           co3.rms * 1e3, co3.max * 1e3, ff1.rms * 1e3, ff1.max * 1e3, ff3.rms * 1e3, ff3.max * 1e3);
    /* position only: CiA 408 tracks as the native path without its force feed-forward */
    assert_true(co1.rms <= 1.10 * nat0.rms);
    assert_true(co3.rms <= 1.10 * nat0.rms);
    /* with the force feed-forward object: within 10 % of the native path (the goal) */
    assert_true(ff1.rms <= 1.10 * nat.rms);
    assert_true(ff3.rms <= 1.10 * nat.rms);
    assert_true(ff1.max <= 1.10 * nat.max);
    {
        /* CiA 402 cyclic synchronous position: position only at SYNC 1 ms, with the
         * torque/force offset 0x60B2 at SYNC 2 and 3 ms */
        track_t p1, p2, p3;
        uint32_t t_ready;
        g_profile = SP_CO_PROFILE_402;
        init(&L, 0, 1u);
        bring_up(&L);
        t_ready = L.now;
        p1 = surge(&L);
        assert_int_equal(L.out.faults, 0u);
        assert_int_equal(L.mout.fault_mask, 0u);
        init_ff(&L, 0, 2u, 1u);
        bring_up(&L);
        p2 = surge(&L);
        assert_int_equal(L.out.faults, 0u);
        assert_int_equal(L.mout.fault_mask, 0u);
        init_ff(&L, 0, 3u, 1u);
        bring_up(&L);
        p3 = surge(&L);
        assert_int_equal(L.out.faults, 0u);
        assert_int_equal(L.mout.fault_mask, 0u);
        g_profile = SP_CO_PROFILE_408;
        printf("%s 0.5 Hz, CiA 402 CSP (start-up to READY %u ms): position only SYNC 1 ms %.3f / %.3f, with the "
               "torque/force offset 0x60B2 SYNC 2 ms %.3f / %.3f, SYNC 3 ms %.3f / %.3f (native %.3f / %.3f, native "
               "without force feed-forward %.3f RMS)\n",
               name, (unsigned)t_ready, p1.rms * 1e3, p1.max * 1e3, p2.rms * 1e3, p2.max * 1e3, p3.rms * 1e3,
               p3.max * 1e3, nat.rms * 1e3, nat.max * 1e3, nat0.rms * 1e3);
        assert_true(p1.rms <= 1.10 * nat0.rms);
        assert_true(p2.rms <= 1.10 * nat.rms);
        assert_true(p2.max <= 1.10 * nat.max);
        assert_true(p3.rms <= 1.10 * nat.rms);
        assert_true(p3.max <= 1.10 * nat.max);
    }
    g_axis = SP_AXIS_X;
}

static void test_surge_native_vs_cia408(void **state)
{
    (void)state;
    compare(SP_AXIS_X, "surge 90 mm", "mm");
}

static void test_yaw_native_vs_cia408(void **state)
{
    (void)state;
    compare(SP_AXIS_YAW, "yaw 0.09 rad", "mrad");
}

static void test_heartbeat_lost_stops_the_platform(void **state)
{
    uint32_t k, t0, fault_ms, still = 0u;
    double speed = 1.0;
    (void)state;
    init(&L, 0, 1u);
    bring_up(&L);
    tick(&L, SP_CMD_RUN_TRIG);
    for (k = 0u; k < 1500u; k++) {
        tick(&L, SP_CMD_NONE);
    }
    L.bus.node[2].silent = 1u;
    t0 = L.now;
    for (k = 0u; k < 200u && L.mout.fault_mask == 0u; k++) {
        tick(&L, SP_CMD_NONE);
    }
    assert_int_equal(L.mout.fault_mask, 1u << 2);
    assert_int_equal(L.m.node[2].fault.code, SP_CO_F_HEARTBEAT_LOST);
    fault_ms = L.now - t0;
    assert_true(L.now - t0 <= (uint32_t)L.link.master.heartbeat_timeout_ms + (uint32_t)L.link.master.heartbeat_ms + 1u);
    tick(&L, SP_CMD_NONE);
    assert_true((L.out.faults & SP_FAULT_DRIVE) != 0u);
    t0 = L.now;
    for (k = 0u; k < 1000u; k++) {
        hs_state_t st;
        tick(&L, SP_CMD_NONE);
        assert_int_equal(hs_plant_state(&L.plant, &st), HS_OK);
        speed = sqrt(st.vel[0] * st.vel[0] + st.vel[1] * st.vel[1] + st.vel[2] * st.vel[2]);
        if (speed >= 0.005) {
            still = 0u;
        } else if (still == 0u) {
            still = L.now;
        }
    }
    printf("canopen heartbeat lost in RUNNING: fault %u ms after it fell silent, controller %s; the platform "
           "below 5 mm/s for good %u ms after the fault, %.5f m/s after 1 s\n",
           (unsigned)fault_ms, sp_state_name(L.out.state), (unsigned)(still - t0), speed);
    assert_int_not_equal(still, 0u);
    assert_true(still - t0 <= 300u);
    for (k = 0u; k < SP_LEGS; k++) {
        assert_false(hs_co_node_follows(&L.bus.node[k]));
    }
}

/* The worst error of the controller's wrench estimate against the plant's
 * true external wrench, in units of issue 14's bound (2 % of the load +
 * 100 N, + 50 N m), over `ticks` ticks. */
static double wrench_error(loop_t *r, const double load[6], uint32_t ticks)
{
    double worst = 0.0;
    uint32_t k;
    int a;
    for (k = 0u; k < ticks; k++) {
        tick(r, SP_CMD_NONE);
        assert_true(r->out.wrench_valid);
        for (a = 0; a < 6; a++) {
            double bound = 0.02 * fabs(load[a]) + (a < 3 ? 100.0 : 50.0);
            double e = fabs((double)r->out.wrench[a] / 256.0 - load[a]) / bound;
            worst = e > worst ? e : worst;
        }
    }
    return worst;
}

/* A constant load of the demo's (3, -2, -4 kN; 1.5, -1, 0.8 kN m)
 * applied and removed at rest in READY, the wrench estimate's worst error
 * in units of issue 14's bound. Natively within it from 20 ms after each
 * change (the figure). With CiA 408 drives with pressures at SYNC
 * every 3 ms the estimate rises 3 to 4 ms later (lengths and pressures
 * sampled at SYNC, received on the next tick): above the bound between 20
 * and 40 ms, and noisier at rest (one sample of the pressures' noise per
 * 3 ms; the smoother's jump thresholds are sqrt(3) times the native ones
 * so that this noise does not pass for a jump: 1.31 / 2.23 times the
 * bound from 40 ms on with the native thresholds, 0.76 / 1.30 with them);
 * it must stay within 1.5 times the bound from 40 ms on. */
static void test_wrench_load_native_vs_cia408(void **state)
{
    static const double load[6] = {3000.0, -2000.0, -4000.0, 1500.0, -1000.0, 800.0};
    static const double none[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    double early[2][2], late[2][2];
    int native;
    (void)state;
    for (native = 1; native >= 0; native--) {
        if (native) {
            init(&L, 1, 1u);
        } else {
            init_ff(&L, 0, 3u, 1u);
        }
        bring_up(&L);
        (void)wrench_error(&L, none, 500u);
        assert_int_equal(hs_plant_set_wrench(&L.plant, &load[0], &load[3]), HS_OK);
        (void)wrench_error(&L, load, 20u);
        early[native][0] = wrench_error(&L, load, 20u);
        late[native][0] = wrench_error(&L, load, 960u);
        assert_int_equal(hs_plant_set_wrench(&L.plant, &none[0], &none[3]), HS_OK);
        (void)wrench_error(&L, none, 20u);
        early[native][1] = wrench_error(&L, none, 20u);
        late[native][1] = wrench_error(&L, none, 960u);
    }
    printf("wrench estimate against a constant load, worst error in units of the bound (2 %% + 100 N, + 50 N m), "
           "20-40 ms / 40-1000 ms after the change: native applied %.2f / %.2f, removed %.2f / %.2f; CiA 408 SYNC "
           "3 ms applied %.2f / %.2f, removed %.2f / %.2f\n",
           early[1][0], late[1][0], early[1][1], late[1][1], early[0][0], late[0][0], early[0][1], late[0][1]);
    assert_true(early[1][0] <= 1.0 && late[1][0] <= 1.0 && early[1][1] <= 1.0 && late[1][1] <= 1.0);
    assert_true(late[0][0] <= 1.5 && late[0][1] <= 1.5);
}

/* ESTOP while RUNNING with CiA 408 drives, two of them (legs 2 and 5)
 * configured to be disabled when the controller blocks its drives
 * (disable_on_block: a valve with a fail-safe spool position): the
 * category-1 stop decelerates by the drives' loops, then those two drives
 * go DISABLED (the plant's valve at its fail-safe position: blocking valves
 * closed) and the other four HOLD (open: they hold by their own loop), no
 * master fault, the platform at rest; RESET brings every drive back to
 * HOLD and the controller to READY. */
static void test_estop_disables_the_drives_the_config_names(void **state)
{
    static const int disabled[SP_LEGS] = {0, 1, 0, 0, 1, 0};
    uint32_t k, t_block;
    hs_state_t st;
    double speed;
    int i;
    (void)state;
    init(&L, 0, 1u);
    for (i = 0; i < SP_LEGS; i++) {
        L.link.master.node[i].disable_on_block = (uint8_t)disabled[i];
    }
    assert_int_equal(sp_co_link_cfg_check(&L.link), SP_OK);
    bring_up(&L);
    tick(&L, SP_CMD_RUN_TRIG);
    for (k = 0u; k < 1500u; k++) {
        tick(&L, SP_CMD_NONE);
    }
    tick(&L, SP_CMD_ESTOP);
    assert_int_equal(L.out.state, SP_STATE_STOPPING); /* category 1: the controlled stop first */
    for (k = 0u; k < 3000u && !L.out.drive_block; k++) {
        tick(&L, SP_CMD_NONE);
    }
    assert_true(L.out.drive_block);
    assert_int_equal(L.out.state, SP_STATE_ESTOP);
    t_block = k;
    for (k = 0u; k < 300u; k++) { /* the state changes at SYNC, the blocking valves in 20 ms */
        tick(&L, SP_CMD_NONE);
    }
    assert_int_equal(L.mout.fault_mask, 0u);
    assert_int_equal(L.out.faults, SP_FAULT_ESTOP); /* no drive fault beside it */
    for (i = 0; i < SP_LEGS; i++) {
        assert_int_equal(L.bus.node[i].state, disabled[i] ? SP_CO408_DISABLED : SP_CO408_HOLD);
        if (disabled[i]) {
            assert_true(L.plant.drive[i].block < 0.01);
        } else {
            assert_true(L.plant.drive[i].block > 0.99);
        }
    }
    assert_int_equal(hs_plant_state(&L.plant, &st), HS_OK);
    speed = sqrt(st.vel[0] * st.vel[0] + st.vel[1] * st.vel[1] + st.vel[2] * st.vel[2]);
    printf("canopen ESTOP while RUNNING: drives blocked %u ms after the ESTOP; legs 2 and 5 DISABLED (fail-safe "
           "spool: blocking valves closed), the others HOLD; %.5f m/s 300 ms later\n",
           (unsigned)t_block, speed);
    assert_true(speed < 0.005);
    tick(&L, SP_CMD_RESET);
    run_until_state(&L, SP_STATE_READY, 20000u);
    for (k = 0u; k < 50u; k++) {
        tick(&L, SP_CMD_NONE);
    }
    assert_int_equal(L.mout.fault_mask, 0u);
    for (i = 0; i < SP_LEGS; i++) {
        assert_int_equal(L.bus.node[i].state, SP_CO408_ACTIVE);
        assert_true(L.plant.drive[i].block > 0.99);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_surge_native_vs_cia408),
        cmocka_unit_test(test_yaw_native_vs_cia408),
        cmocka_unit_test(test_heartbeat_lost_stops_the_platform),
        cmocka_unit_test(test_wrench_load_native_vs_cia408),
        cmocka_unit_test(test_estop_disables_the_drives_the_config_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
