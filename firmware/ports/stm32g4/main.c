/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_stm32g4 - the controller on the NUCLEO-G474RE: the portable node
 * (sp/link/node.h) on the three FDCAN buses at 1 kHz, cycle master (it sends
 * SYNC), as firmware/ports/host/main.c does in real-time mode.
 *
 * Each tick (sp_g4_cycle): cancel transmissions left from the last tick and
 * sample the bus health; move every received frame into sp_node_receive;
 * sp_node_tick; queue its frames (AXIS_SETPOINTS then SYNC on each axis
 * bus, CTRL_STATUS and CTRL_MONITOR on ops); kick the watchdog. The tick
 * comes from SysTick; a cycle always starts on a SysTick edge: when one
 * overruns its millisecond, the ticks it overlapped are skipped and counted
 * as missed (never run late, never run twice).
 *
 * LD2: blinks at 1 Hz while the controller has no fault, at 5 Hz with a
 * controller fault (node.out.faults); steady on in the safe state
 * (sp_g4_stop: CPU fault, clock failure, start-up failure).
 *
 * sp_g4_stats holds figures for a debugger (ticks, misses, cycles per tick,
 * stack high-water mark); nothing is printed.
 *
 * SP_DRIVE_CIA408 (CMake SP_DRIVE_PROTOCOL=cia408; docs/reference/canopen.md, one
 * drive protocol per image): the drives are CiA 408 nodes behind the
 * CANopen master (sp/canopen/canopen_link.h), laid out as the platform config's
 * drives section (sp_co_layout_default), else the built-in layout. Frames of
 * the drive buses go to the master; each tick the link fills the node's
 * drive feedback before sp_node_tick, the node's own axis frames are not
 * sent, and the master's RPDO1s and SYNCs are (before the ops frames). The
 * Tx FIFO holds 3 frames: a bus with three drives needs 4 per SYNC, so the
 * cycle waits for a free element, at most CO_TX_WAIT_US per tick.
 */
#include <stddef.h>

#include "sp/link/node.h"
#include "sp_g4.h"
#include "sp_machine_key.h" /* generated from the build's key file (tools/dev/key_header.py) */
#if SP_DRIVE_CIA408
#include "sp/canopen/canopen_link.h"
#include "sp/model/kinematics.h"
#define CO_TX_WAIT_US 400u /* > two classic 8-byte frames at 1 Mbit/s (135 us each) */
#endif

#define RX_BATCH 6u /* frames per receive call */
#if SP_DRIVE_CIA408
#define RX_ROUNDS 7u /* 42 >= 6 (ops FIFOs) + 2 x 16 (the drive buses' queues, fdcan.c) */
#else
#define RX_ROUNDS 4u /* 24 >= the 18 frames the 3 x 2 FIFOs of 3 can hold */
#endif

typedef struct {
    uint32_t ticks;       /**< cycles run */
    uint32_t misses;      /**< tick deadlines that passed while a cycle ran */
    uint32_t tx_busy;     /**< cycles whose frames were not all queued */
    uint32_t cycles_last; /**< core clock cycles of the last cycle (170 per us) */
    uint32_t cycles_max;  /**< worst cycle since start-up */
    uint32_t stack_max;   /**< main stack high-water mark, bytes (updated once a second) */
} sp_g4_stats_t;

sp_g4_stats_t sp_g4_stats;

typedef struct {
    sp_can_port_t can;
    sp_tick_port_t tick;
    sp_watchdog_port_t wdg;
} sp_g4_ports_t;

static sp_node_config_t g_cfg;
static sp_node_t g_node;
static sp_g4_can_t g_can;
static sp_can_frame_t g_rx[RX_BATCH];
static sp_can_frame_t g_tx[SP_NODE_MAX_TX];

void sp_g4_cycle(const sp_g4_ports_t *p);

#if SP_DRIVE_CIA408
static sp_co_link_cfg_t g_co;
static sp_co_master_t g_com;
static sp_co_master_input_t g_coin;
static sp_co_master_output_t g_coout;
static uint32_t g_co_now;

/* The master's frames, in order; waits (bounded) for a free Tx element. */
static void co_send(const sp_g4_ports_t *p)
{
    uint32_t t0 = sp_g4_cycles();
    for (uint32_t k = 0; k < g_coout.n_tx && k < SP_CO_MAX_TX; k++) {
        const sp_can_frame_t *f = &g_coout.tx[k];
        uint32_t sent = 0;
        while (sp_g4_can_tx_free(f->bus) == 0u && sp_g4_cycles() - t0 < CO_TX_WAIT_US * 170u) {
        }
        if (p->can.send(p->can.ctx, f, 1u, &sent) != SP_OK || sent != 1u) {
            sp_g4_stats.tx_busy++;
        }
    }
}

static sp_status_t co_init(void)
{
    sp_ik_t ik;
    if (sp_co_layout_default.present) {
        if (sp_co_link_cfg_from_layout(&g_co, &sp_co_layout_default, &sp_platform_default) != SP_OK) {
            return SP_E_ARG;
        }
    } else if (sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik) != SP_OK ||
               sp_co_link_cfg_default(&g_co, &sp_platform_default, ik.length) != SP_OK) {
        return SP_E_ARG;
    } else { /* the built-in layout: the master's heartbeat period and node id from the config */
        g_co.master.master_heartbeat_ms = sp_co_layout_default.master.master_heartbeat_ms;
        g_co.master.master_node_id = sp_co_layout_default.master.master_node_id;
    }
    if (sp_co_link_ctrl_config(&g_co, &g_cfg.ctrl) != SP_OK) { /* feedback every sync_divider ticks */
        return SP_E_ARG;
    }
    if (sp_co_master_init(&g_com) != SP_OK || sp_co_master_start(&g_com, &g_co.master, 0u) != SP_OK) {
        return SP_E_ARG;
    }
    return SP_OK;
}
#endif

/* One control tick: the root of the tick path of the stack analysis
 * (tools/dev/stack_usage.py). */
__attribute__((noinline)) void sp_g4_cycle(const sp_g4_ports_t *p)
{
    uint32_t t0 = sp_g4_cycles();
    sp_g4_can_service(&g_can);
    for (uint32_t round = 0; round < RX_ROUNDS; round++) {
        uint32_t got = 0;
        (void)p->can.receive(p->can.ctx, g_rx, RX_BATCH, &got);
        for (uint32_t k = 0; k < got && k < RX_BATCH; k++) {
#if SP_DRIVE_CIA408
            if (g_rx[k].bus != SP_BUS_OPS) {
                (void)sp_co_master_receive(&g_com, &g_co.master, &g_rx[k], g_co_now);
                continue;
            }
#endif
            (void)sp_node_receive(&g_node, &g_rx[k], NULL);
        }
        if (got < RX_BATCH) {
            break;
        }
    }
    uint32_t n = 0, sent = 0;
#if SP_DRIVE_CIA408
    g_co_now++;
    (void)sp_co_link_feedback(&g_com, &g_co, g_node.in.drive);
    g_node.in.setpoints_idle = sp_co_link_setpoints_idle(&g_co, &g_com); /* setpoints on SYNC ticks only */
    g_node.drives_starting =
        (uint8_t)(g_coout.all_running ? 0u : 1u); /* the master's last step: ENGAGE refused until all run */
#endif
    (void)sp_node_tick(&g_cfg, &g_node, g_tx, &n);
#if SP_DRIVE_CIA408
    {
        uint32_t m = 0; /* only the node's ops frames: the drives get the master's */
        for (uint32_t i = 0; i < n && i < SP_NODE_MAX_TX; i++) {
            if (g_tx[i].bus == SP_BUS_OPS) {
                g_tx[m++] = g_tx[i];
            }
        }
        n = m;
    }
    (void)sp_co_link_input_due(&g_co, &g_com, &g_node.out, g_co_now, &g_coin);
    (void)sp_co_master_step(&g_com, &g_co.master, &g_coin, &g_coout);
    co_send(p);
#endif
    if (p->can.send(p->can.ctx, g_tx, n, &sent) != SP_OK || sent != n) {
        sp_g4_stats.tx_busy++;
    }
    (void)p->wdg.kick(p->wdg.ctx);
    uint32_t dt = sp_g4_cycles() - t0;
    sp_g4_stats.cycles_last = dt;
    if (dt > sp_g4_stats.cycles_max) {
        sp_g4_stats.cycles_max = dt;
    }
    sp_g4_stats.ticks++;
}

int main(void)
{
    sp_g4_led_init();
    if (sp_g4_clock_init() != SP_OK) {
        sp_g4_stop(SP_G4_STOP_INIT);
    }
    if (sp_node_default_config(&g_cfg, &sp_platform_default) != SP_OK) {
        sp_g4_stop(SP_G4_STOP_INIT);
    }
    g_cfg.sync_master = 1u;              /* real time: we send SYNC */
    g_cfg.ctrl.estop = sp_estop_default; /* the config's ESTOP reaction */
    g_cfg.port = SP_PORT_STM32G474;
    g_cfg.ctrl.frames = sp_frame_slots_default; /* the config's named frames */
    /* command authentication (docs/explanation/security.md): the machine key built in
     * (the build's key file), a session drawn from the RNG; without a
     * session the node starts without its key: motion commands refused */
    static const sp_auth_key_t key = {SP_MACHINE_KEY_BYTES};
    uint32_t session = 0u;
    if (sp_g4_random_u32(&session) == SP_OK) {
        g_cfg.auth_key = &key;
        g_cfg.auth_session = session;
    }
#if SP_DRIVE_CIA408
    if (co_init() != SP_OK || sp_node_init(&g_node, &g_cfg) != SP_OK ||
        sp_g4_can_init_canopen(&g_can, &g_co.master,
                               sp_co_layout_default.present ? sp_co_layout_default.bitrate : NULL) != SP_OK) {
        sp_g4_stop(SP_G4_STOP_INIT);
    }
#else
    if (sp_node_init(&g_node, &g_cfg) != SP_OK || sp_g4_can_init(&g_can) != SP_OK) {
        sp_g4_stop(SP_G4_STOP_INIT);
    }
#endif
    static sp_g4_ports_t ports;
    ports.can = sp_g4_can_port(&g_can);
    ports.tick = sp_g4_tick_port();
    ports.wdg = sp_g4_watchdog_port();

    sp_g4_tick_init();
    if (sp_g4_watchdog_start() != SP_OK) {
        sp_g4_stop(SP_G4_STOP_INIT);
    }
    uint32_t led_count = 0;
    int led = 0;
    for (;;) { /* until reset */
        uint32_t missed = 0;
        if (ports.tick.wait(ports.tick.ctx, &missed) != SP_OK) {
            sp_g4_stop(SP_G4_STOP_INIT); /* SysTick stopped */
        }
        sp_g4_stats.misses = (sp_g4_stats.misses > UINT32_MAX - missed) ? UINT32_MAX : sp_g4_stats.misses + missed;
        sp_g4_cycle(&ports);

        uint32_t half_period = (g_node.out.faults != 0u) ? 100u : 500u;
        if (++led_count >= half_period) {
            led_count = 0;
            led = !led;
            sp_g4_led_set(led);
        }
        if (sp_g4_stats.ticks % 1000u == 0u) {
            sp_g4_stats.stack_max = sp_g4_stack_high_water();
        }
    }
}
