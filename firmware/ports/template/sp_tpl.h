/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_tpl.h - the blank port: what a new target provides so that main.c
 * runs the controller on it (docs/guides/porting.md). Each function is a stub in
 * port.c that fails; fill them in for the chip or OS, keep the contracts
 * written here, and rename the prefix (sp_tpl_) to the port's own
 * (sp_g4_, ...). sp/link/port.h defines the three port structs.
 *
 * None of these functions may allocate, use floating point in the tick
 * path, or block longer than its stated bound.
 */
#ifndef SP_TPL_H
#define SP_TPL_H

#include <stdint.h>

#include "sp/canopen/canopen_master.h"
#include "sp/link/auth.h"
#include "sp/link/port.h"

/** The port's rate: the controller is written for a 1 ms tick (its config,
 *  sp_ctrl_default_config, counts time in ticks of this length). */
#define SP_TPL_TICK_HZ 1000u

/* ---- CAN: three buses, index = sp_bus_t ---- */

/**
 * Brings up the three CAN controllers: ops, axis_a, axis_b (sp_bus_t),
 * 1 Mbit/s nominal; with the native drive protocol CAN FD at 5 Mbit/s
 * data rate (protocol/stewart.dbc), with co not NULL the two drive buses
 * as classic CANopen buses at bitrate[bus] bit/s (NULL: 1 Mbit/s).
 * Receive filters may drop what the controller never reads. Transmission
 * in queue order (setpoints before SYNC). SP_E_IO if a controller does not
 * start within its bound.
 */
sp_status_t sp_tpl_can_init(const sp_co_master_cfg_t *co, const uint32_t *bitrate);

/**
 * The CAN port (sp_can_port_t): send() queues frames in order without
 * blocking (SP_E_BUSY when the queue is full, counted in tx_dropped);
 * receive() moves pending frames without blocking, each with its bus and
 * its payload length (CAN FD lengths as received); bus_status() reports
 * the counters and the error-passive / bus-off state.
 */
sp_can_port_t sp_tpl_can_port(void);

/**
 * Once per tick, before the tick's frames are queued: drop frames still
 * pending from the last tick (a setpoint is never sent a tick late; count
 * them in tx_dropped), sample the bus error state, restart a bus-off
 * controller at a bounded rate.
 */
void sp_tpl_can_service(void);

/* ---- tick ---- */

/** Starts the tick source at SP_TPL_TICK_HZ (a timer interrupt, an OS
 *  periodic timer). */
sp_status_t sp_tpl_tick_start(void);

/**
 * The tick port (sp_tick_port_t): wait() returns right after the next tick
 * edge. If the edge it should have waited for has passed (the last cycle
 * overran), it skips it and every later one that passed, counts them in
 * *missed and waits for the next edge: a cycle always starts on an edge,
 * never late and never twice. An error if the tick source stopped.
 */
sp_tick_port_t sp_tpl_tick_port(void);

/** A free-running cycle counter for measuring the tick (docs/guides/porting.md,
 *  "Measuring the tick"); 0 when the target has none. */
uint32_t sp_tpl_cycles(void);

/* ---- watchdog ---- */

/** Starts a hardware watchdog that resets the target a few ticks (the
 *  STM32 port: 10 ms) after the last kick. Once started it cannot be
 *  stopped. */
sp_status_t sp_tpl_watchdog_start(void);

/** The watchdog port (sp_watchdog_port_t): kick() refreshes it, once per
 *  completed tick. */
sp_watchdog_port_t sp_tpl_watchdog_port(void);

/* ---- command authentication and the safe state ---- */

/**
 * The machine key and a fresh session value for command authentication
 * (docs/explanation/security.md): the key from storage outside the sources, the
 * session from a hardware random source, new at each start. An error when
 * either is missing: the node then starts without a key and refuses
 * motion commands (stops still work).
 */
sp_status_t sp_tpl_auth(const sp_auth_key_t **key, uint32_t *session);

/** The safe state for good: interrupts off, the CAN controllers silent (no
 *  frame, no acknowledge), a visible indication; waits for the watchdog's
 *  reset. */
__attribute__((noreturn)) void sp_tpl_stop(void);

#endif /* SP_TPL_H */
