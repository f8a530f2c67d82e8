/* SPDX-License-Identifier: Apache-2.0 */
/*
 * socketcan.h - the host port's CAN: Linux SocketCAN raw sockets, CAN FD,
 * non-blocking, batched with sendmmsg/recvmmsg, one socket per bus.
 * Implements sp_can_port_t (sp/link/port.h).
 *
 * One socket serves all three buses: it is bound to every CAN interface
 * (ifindex 0), each received frame names its interface, each sent frame is
 * addressed to its bus's interface. A whole tick's frames therefore go out
 * in one sendmmsg and come in with one recvmmsg, in the order they were
 * sent across buses; that halves the system calls per tick, which is what
 * limits the speed inside user-mode Linux.
 */
#ifndef SP_SOCKETCAN_H
#define SP_SOCKETCAN_H

#include "sp/link/port.h"

#define SP_SOCKETCAN_MAX_FILTERS 20u
#define SP_SOCKETCAN_BATCH 32u

typedef struct {
    const char *ifname;                        /**< e.g. "vcan1"; NULL: bus unused */
    uint32_t rx_ids[SP_SOCKETCAN_MAX_FILTERS]; /**< identifiers to receive (exact match) */
    uint32_t n_rx_ids;                         /**< 0: receive nothing but error frames */
} sp_socketcan_bus_cfg_t;

typedef struct {
    int fd;                    /**< the one raw socket, bound to every CAN interface; -1 when closed */
    int ifindex[SP_CAN_BUSES]; /**< interface of each bus; 0: bus unused */
    uint32_t rx_ids[SP_CAN_BUSES][SP_SOCKETCAN_MAX_FILTERS];
    uint32_t n_rx_ids[SP_CAN_BUSES];
    sp_bus_status_t st[SP_CAN_BUSES];
    uint32_t last_drops; /**< the kernel's drop counter of the socket */
    char error[128];     /**< the last error, for the operator */
} sp_socketcan_t;

/**
 * Opens the raw CAN FD socket for the configured buses (ifname NULL: unused),
 * non-blocking, with a receive filter on every bus's rx_ids (checked again per
 * bus on receipt), all error frames enabled and the kernel's drop counter
 * (SO_RXQ_OVFL) on. On failure closes the socket, writes the reason to
 * p->error and returns SP_E_IO (interface missing, no CAN FD MTU, two buses on
 * one interface) or SP_E_ARG (bad arguments).
 */
sp_status_t sp_socketcan_open(sp_socketcan_t *p, const sp_socketcan_bus_cfg_t cfg[SP_CAN_BUSES]);

/** Closes the socket; safe to call twice. */
void sp_socketcan_close(sp_socketcan_t *p);

/** The sp_can_port_t view of an open port (ctx = p). */
sp_can_port_t sp_socketcan_port(sp_socketcan_t *p);

/** The socket's file descriptor, to poll() for frames of any bus; -1 when closed. */
int sp_socketcan_fd(const sp_socketcan_t *p);

#endif /* SP_SOCKETCAN_H */
