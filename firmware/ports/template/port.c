/* SPDX-License-Identifier: Apache-2.0 */
/*
 * port.c - the blank port's target functions (sp_tpl.h): stubs that fail,
 * so that main.c, unchanged, goes straight to the safe state. Replace each
 * body with the target's code; firmware/ports/stm32g4 (registers) and
 * firmware/ports/host (Linux SocketCAN) are worked examples.
 */
#include <stddef.h>

#include "sp_tpl.h"

/* ---- CAN ---- */

sp_status_t sp_tpl_can_init(const sp_co_master_cfg_t *co, const uint32_t *bitrate)
{
    (void)co;
    (void)bitrate;
    return SP_E_IO; /* fill in: pins, clocks, bit timing, filters, start */
}

static sp_status_t can_send(void *ctx, const sp_can_frame_t *frames, uint32_t n, uint32_t *sent)
{
    (void)ctx;
    (void)frames;
    (void)n;
    *sent = 0u;
    return SP_E_IO; /* fill in: queue frames[0..n) on frames[k].bus, in order */
}

static sp_status_t can_receive(void *ctx, sp_can_frame_t *frames, uint32_t max, uint32_t *got)
{
    (void)ctx;
    (void)frames;
    (void)max;
    *got = 0u; /* fill in: move up to max pending frames, with bus and length */
    return SP_OK;
}

static sp_status_t can_bus_status(void *ctx, uint8_t bus, sp_bus_status_t *status)
{
    (void)ctx;
    if (bus >= SP_CAN_BUSES || status == NULL) {
        return SP_E_ARG;
    }
    *status = (sp_bus_status_t){0}; /* fill in: the bus's counters and state */
    return SP_OK;
}

sp_can_port_t sp_tpl_can_port(void)
{
    sp_can_port_t p = {.ctx = NULL, .send = can_send, .receive = can_receive, .bus_status = can_bus_status};
    return p;
}

void sp_tpl_can_service(void)
{
    /* fill in: cancel last tick's pending frames, sample the error state */
}

/* ---- tick ---- */

sp_status_t sp_tpl_tick_start(void)
{
    return SP_E_IO; /* fill in: a SP_TPL_TICK_HZ timer */
}

static sp_status_t tick_wait(void *ctx, uint32_t *missed)
{
    (void)ctx;
    *missed = 0u;
    return SP_E_IO; /* fill in: sleep until the next edge; count the edges that passed */
}

sp_tick_port_t sp_tpl_tick_port(void)
{
    sp_tick_port_t p = {.ctx = NULL, .wait = tick_wait};
    return p;
}

uint32_t sp_tpl_cycles(void)
{
    return 0u; /* fill in: a free-running cycle counter (Cortex-M: DWT CYCCNT) */
}

/* ---- watchdog ---- */

sp_status_t sp_tpl_watchdog_start(void)
{
    return SP_E_IO; /* fill in: a hardware watchdog of a few ticks */
}

static sp_status_t watchdog_kick(void *ctx)
{
    (void)ctx;
    return SP_E_IO; /* fill in: refresh the watchdog */
}

sp_watchdog_port_t sp_tpl_watchdog_port(void)
{
    sp_watchdog_port_t p = {.ctx = NULL, .kick = watchdog_kick};
    return p;
}

/* ---- command authentication and the safe state ---- */

sp_status_t sp_tpl_auth(const sp_auth_key_t **key, uint32_t *session)
{
    *key = NULL;
    *session = 0u;
    return SP_E_IO; /* fill in: the machine key from storage, a random session */
}

void sp_tpl_stop(void)
{
    /* fill in: interrupts off, CAN silent, an indication */
    for (;;) {
    }
}
