/*
 * socketcan.h - the host port's CAN: Linux SocketCAN raw sockets, CAN FD,
 * non-blocking, batched with sendmmsg/recvmmsg, one socket per bus.
 * Implements sp_can_port_t (sp/port.h).
 */
#ifndef SP_SOCKETCAN_H
#define SP_SOCKETCAN_H

#include "sp/port.h"

#define SP_SOCKETCAN_MAX_FILTERS 16u
#define SP_SOCKETCAN_BATCH 32u

typedef struct {
    const char *ifname;                         /**< e.g. "vcan1"; NULL: bus unused */
    uint32_t rx_ids[SP_SOCKETCAN_MAX_FILTERS];  /**< identifiers to receive (exact match) */
    uint32_t n_rx_ids;                          /**< 0: receive nothing but error frames */
} sp_socketcan_bus_cfg_t;

typedef struct {
    int fd[SP_CAN_BUSES];           /**< -1 when the bus is unused */
    sp_bus_status_t st[SP_CAN_BUSES];
    uint32_t last_drops[SP_CAN_BUSES];
    char error[128];                /**< the last error, for the operator */
} sp_socketcan_t;

/**
 * Opens one raw CAN FD socket per configured bus, bound to its interface,
 * non-blocking, with receive filters for rx_ids, all error frames enabled and
 * the kernel's drop counter (SO_RXQ_OVFL) on. On failure closes what it
 * opened, writes the reason to p->error and returns SP_E_IO (interface
 * missing, no CAN FD MTU) or SP_E_ARG (bad arguments).
 */
sp_status_t sp_socketcan_open(sp_socketcan_t *p, const sp_socketcan_bus_cfg_t cfg[SP_CAN_BUSES]);

/** Closes every socket; safe to call twice. */
void sp_socketcan_close(sp_socketcan_t *p);

/** The sp_can_port_t view of an open port (ctx = p). */
sp_can_port_t sp_socketcan_port(sp_socketcan_t *p);

/** File descriptor of a bus (for poll()), -1 if unused. */
int sp_socketcan_fd(const sp_socketcan_t *p, uint8_t bus);

#endif /* SP_SOCKETCAN_H */
