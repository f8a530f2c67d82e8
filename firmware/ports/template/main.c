/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_port_template - the controller's main program for a new target
 * (docs/guides/porting.md). It needs only the functions of sp_tpl.h (port.c);
 * with them filled in it runs the portable node (sp/link/node.h) at
 * SP_TPL_TICK_HZ as cycle master (it sends SYNC), as the STM32 port
 * (firmware/ports/stm32g4/main.c) does. As shipped, every stub fails and
 * the program enters the safe state at once.
 *
 * Each tick (cycle): service the buses; move every received frame to the
 * node (or, with CANopen drives, the drive buses' frames to the master);
 * sp_node_tick; queue its frames (AXIS_SETPOINTS then SYNC on each axis
 * bus, CTRL_STATUS and CTRL_MONITOR on ops); kick the watchdog.
 * sp_tpl_stats keeps the tick's figures for a debugger; nothing is printed.
 *
 * SP_DRIVE_CIA408=1 (one drive protocol per image, docs/reference/canopen.md): the
 * drives are CiA 408 or CiA 402 nodes behind the CANopen master, laid out
 * as the platform config's drives section (sp_co_layout_default), else
 * the built-in layout. A tick then runs the five steps of
 * sp/canopen/canopen_link.h in this order:
 *   1. the drive buses' frames to sp_co_master_receive;
 *   2. sp_co_link_feedback and sp_co_link_setpoints_idle into the node's
 *      input (and ENGAGE refused until the master's last step had every
 *      drive running);
 *   3. sp_node_tick (the controller's step), keeping only its ops frames;
 *   4. sp_co_link_input_due: the master's request and setpoints;
 *   5. sp_co_master_step, and its frames (RPDOs, SYNC) sent before the
 *      node's ops frames.
 */
#include <stddef.h>

#include "sp/sp.h"
#include "sp_tpl.h"

#define RX_BATCH 8u  /* frames per receive call */
#define RX_ROUNDS 8u /* receive calls per tick at most: 64 frames, above what three buses bring in 1 ms */

/* Figures for a debugger (docs/guides/porting.md, "Measuring the tick"). */
typedef struct {
    uint32_t ticks;       /**< cycles run */
    uint32_t misses;      /**< tick edges that passed while a cycle ran */
    uint32_t tx_busy;     /**< cycles whose frames were not all queued */
    uint32_t cycles_last; /**< sp_tpl_cycles() of the last cycle */
    uint32_t cycles_max;  /**< the worst since start-up */
} sp_tpl_stats_t;

sp_tpl_stats_t sp_tpl_stats;

typedef struct {
    sp_can_port_t can;
    sp_tick_port_t tick;
    sp_watchdog_port_t wdg;
} tpl_ports_t;

static sp_node_config_t g_cfg;
static sp_node_t g_node;
static sp_can_frame_t g_rx[RX_BATCH];
static sp_can_frame_t g_tx[SP_NODE_MAX_TX];

#if SP_DRIVE_CIA408
static sp_co_link_cfg_t g_co;
static sp_co_master_t g_com;
static sp_co_master_input_t g_coin;
static sp_co_master_output_t g_coout;
static uint32_t g_co_now; /* ticks run: the master's clock, ms */

/* The drives from the config's drives section, else the built-in layout;
 * the controller's feedback timing fitted to the SYNC divider; the master
 * started (boot-up, SDO configuration, NMT start, then the cyclic PDOs). */
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
    if (sp_co_link_ctrl_config(&g_co, &g_cfg.ctrl) != SP_OK || sp_co_master_init(&g_com) != SP_OK ||
        sp_co_master_start(&g_com, &g_co.master, 0u) != SP_OK) {
        return SP_E_ARG;
    }
    return SP_OK;
}

/* A received frame's destination: with CANopen drives, a drive bus's
 * frames go to the master (step 1), but for the force/torque sensor's. */
static void route(const sp_can_frame_t *f)
{
    if (f->bus != SP_BUS_OPS && f->id != SP_ID_FT_SENSOR) {
        (void)sp_co_master_receive(&g_com, &g_co.master, f, g_co_now);
        return;
    }
    (void)sp_node_receive(&g_node, f, NULL);
}
#else
static void route(const sp_can_frame_t *f)
{
    (void)sp_node_receive(&g_node, f, NULL);
}
#endif

/* Every frame received since the last tick, in arrival order. */
static void receive_all(const sp_can_port_t *can)
{
    for (uint32_t round = 0; round < RX_ROUNDS; round++) {
        uint32_t got = 0;
        (void)can->receive(can->ctx, g_rx, RX_BATCH, &got);
        for (uint32_t k = 0; k < got && k < RX_BATCH; k++) {
            route(&g_rx[k]);
        }
        if (got < RX_BATCH) {
            break;
        }
    }
}

/* One control tick. */
static void cycle(const tpl_ports_t *p)
{
    uint32_t t0 = sp_tpl_cycles();
    uint32_t n = 0, sent = 0;
    sp_tpl_can_service();
    receive_all(&p->can);
#if SP_DRIVE_CIA408
    g_co_now++;
    (void)sp_co_link_feedback(&g_com, &g_co, g_node.in.drive);
    g_node.in.setpoints_idle = sp_co_link_setpoints_idle(&g_co, &g_com);
    g_node.drives_starting = (uint8_t)(g_coout.all_running ? 0u : 1u);
#endif
    (void)sp_node_tick(&g_cfg, &g_node, g_tx, &n);
#if SP_DRIVE_CIA408
    uint32_t m = 0;
    for (uint32_t i = 0; i < n && i < SP_NODE_MAX_TX; i++) {
        if (g_tx[i].bus == SP_BUS_OPS) {
            g_tx[m++] = g_tx[i];
        }
    }
    n = m;
    (void)sp_co_link_input_due(&g_co, &g_com, &g_node.out, g_co_now, &g_coin);
    (void)sp_co_master_step(&g_com, &g_co.master, &g_coin, &g_coout);
    if (p->can.send(p->can.ctx, g_coout.tx, g_coout.n_tx, &sent) != SP_OK || sent != g_coout.n_tx) {
        sp_tpl_stats.tx_busy++;
    }
#endif
    if (p->can.send(p->can.ctx, g_tx, n, &sent) != SP_OK || sent != n) {
        sp_tpl_stats.tx_busy++;
    }
    (void)p->wdg.kick(p->wdg.ctx);
    uint32_t dt = sp_tpl_cycles() - t0;
    sp_tpl_stats.cycles_last = dt;
    if (dt > sp_tpl_stats.cycles_max) {
        sp_tpl_stats.cycles_max = dt;
    }
    sp_tpl_stats.ticks++;
}

/* The node's configuration: the generated platform, cycle master, and the
 * machine key when the port has one. */
static sp_status_t node_config(void)
{
    const sp_auth_key_t *key = NULL;
    uint32_t session = 0u;
    if (sp_node_default_config(&g_cfg, &sp_platform_default) != SP_OK) {
        return SP_E_ARG;
    }
    g_cfg.sync_master = 1u;
    g_cfg.ctrl.frames = sp_frame_slots_default; /* the config's named frames */
    g_cfg.ctrl.estop = sp_estop_default;        /* the config's ESTOP reaction */
    if (sp_tpl_auth(&key, &session) == SP_OK) {
        g_cfg.auth_key = key;
        g_cfg.auth_session = session;
    }
    return SP_OK;
}

int main(void)
{
    static tpl_ports_t ports;
    sp_status_t st = node_config();
#if SP_DRIVE_CIA408
    if (st == SP_OK) {
        st = co_init();
    }
    const sp_co_master_cfg_t *co = &g_co.master;
    const uint32_t *bitrate = sp_co_layout_default.present ? sp_co_layout_default.bitrate : NULL;
#else
    const sp_co_master_cfg_t *co = NULL;
    const uint32_t *bitrate = NULL;
#endif
    if (st != SP_OK || sp_node_init(&g_node, &g_cfg) != SP_OK || sp_tpl_can_init(co, bitrate) != SP_OK) {
        sp_tpl_stop();
    }
    ports.can = sp_tpl_can_port();
    ports.tick = sp_tpl_tick_port();
    ports.wdg = sp_tpl_watchdog_port();
    if (sp_tpl_tick_start() != SP_OK || sp_tpl_watchdog_start() != SP_OK) {
        sp_tpl_stop();
    }
    for (;;) {
        uint32_t missed = 0;
        if (ports.tick.wait(ports.tick.ctx, &missed) != SP_OK) {
            sp_tpl_stop(); /* the tick source stopped */
        }
        sp_tpl_stats.misses = (sp_tpl_stats.misses > UINT32_MAX - missed) ? UINT32_MAX : sp_tpl_stats.misses + missed;
        cycle(&ports);
    }
}
