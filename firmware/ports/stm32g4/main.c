/*
 * sp_stm32g4 - the controller on the NUCLEO-G474RE: the portable node
 * (sp/node.h) on the three FDCAN buses at 1 kHz, cycle master (it sends
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
 */
#include <stddef.h>

#include "sp/node.h"
#include "sp_g4.h"
#include "sp_machine_key.h" /* generated from the build's key file (tools/stewart/key_header.py) */

#define RX_BATCH 6u  /* frames per receive call */
#define RX_ROUNDS 4u /* 24 >= the 18 frames the 3 x 2 FIFOs of 3 can hold */

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

/* One control tick: the root of the tick path of the stack analysis
 * (tools/stewart/stack_usage.py). */
__attribute__((noinline)) void sp_g4_cycle(const sp_g4_ports_t *p)
{
    uint32_t t0 = sp_g4_cycles();
    sp_g4_can_service(&g_can);
    for (uint32_t round = 0; round < RX_ROUNDS; round++) {
        uint32_t got = 0;
        (void)p->can.receive(p->can.ctx, g_rx, RX_BATCH, &got);
        for (uint32_t k = 0; k < got && k < RX_BATCH; k++) {
            (void)sp_node_receive(&g_node, &g_rx[k], NULL);
        }
        if (got < RX_BATCH) {
            break;
        }
    }
    uint32_t n = 0, sent = 0;
    (void)sp_node_tick(&g_cfg, &g_node, g_tx, &n);
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
    g_cfg.sync_master = 1u; /* real time: we send SYNC */
    /* command authentication (docs/security.md): the machine key built in
     * (the build's key file), a session drawn from the RNG; without a
     * session the node starts without its key: motion commands refused */
    static const sp_auth_key_t key = {SP_MACHINE_KEY_BYTES};
    uint32_t session = 0u;
    if (sp_g4_random_u32(&session) == SP_OK) {
        g_cfg.auth_key = &key;
        g_cfg.auth_session = session;
    }
    if (sp_node_init(&g_node, &g_cfg) != SP_OK || sp_g4_can_init(&g_can) != SP_OK) {
        sp_g4_stop(SP_G4_STOP_INIT);
    }
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
