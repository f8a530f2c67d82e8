/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/link/port.h - what a port (an OS or a chip) provides to run the controller:
 * CAN send and receive, a tick source and a watchdog. The host port
 * (firmware/ports/host, Linux SocketCAN) and the microcontroller port
 * (firmware/ports/stm32g4) implement it; the core never calls an OS.
 *
 * Every function returns SP_OK or an error status; none blocks unless said.
 */
#ifndef SP_PORT_H
#define SP_PORT_H

#include "sp/link/can.h"
#include "sp/math/status.h"

/** Health of one bus, as the port sees it. Counters saturate at UINT32_MAX. */
typedef struct {
    uint32_t tx_frames;    /**< frames handed to the bus */
    uint32_t rx_frames;    /**< frames received (before any protocol check) */
    uint32_t tx_dropped;   /**< frames the bus could not take (queue full) */
    uint32_t rx_overruns;  /**< frames lost before we read them */
    uint32_t error_frames; /**< error frames / protocol errors seen on the bus */
    uint8_t bus_off;       /**< 1 while the controller is bus-off */
    uint8_t error_passive; /**< 1 while error-passive */
} sp_bus_status_t;

typedef struct {
    void *ctx;
    /** Queues up to n frames (each names its bus); *sent says how many were
     *  taken. Never blocks. SP_E_BUSY if the queue is full (frames are not
     *  lost silently: tx_dropped counts them), SP_E_IO on a bus error. */
    sp_status_t (*send)(void *ctx, const sp_can_frame_t *frames, uint32_t n, uint32_t *sent);
    /** Moves up to max received frames into frames[]; *got says how many.
     *  Never blocks; SP_OK with *got == 0 when nothing is pending. */
    sp_status_t (*receive)(void *ctx, sp_can_frame_t *frames, uint32_t max, uint32_t *got);
    /** Health of one bus. */
    sp_status_t (*bus_status)(void *ctx, uint8_t bus, sp_bus_status_t *status);
} sp_can_port_t;

typedef struct {
    void *ctx;
    /** Blocks until the next tick deadline; *missed counts deadlines that
     *  passed while the caller was busy (0 when on time). */
    sp_status_t (*wait)(void *ctx, uint32_t *missed);
} sp_tick_port_t;

typedef struct {
    void *ctx;
    sp_status_t (*kick)(void *ctx); /**< refreshes the watchdog */
} sp_watchdog_port_t;

#endif /* SP_PORT_H */
