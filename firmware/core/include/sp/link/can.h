/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/link/can.h - a CAN or CAN FD frame as the core and the ports exchange it.
 *
 * The core packs and unpacks these (sp/link/protocol.h); the ports move them to
 * and from a bus (sp/link/port.h). Nothing here knows about sockets or registers.
 */
#ifndef SP_CAN_H
#define SP_CAN_H

#include <stdint.h>

#define SP_CAN_MAX_DATA 64u /**< CAN FD payload limit, bytes */
#define SP_CAN_BUSES 3u     /**< buses of the protocol: ops, axis_a, axis_b */

/** Bus indices of the protocol (protocol/stewart.dbc). */
typedef enum {
    SP_BUS_OPS = 0,    /**< operator PC <-> controller */
    SP_BUS_AXIS_A = 1, /**< controller <-> drives of legs 1..3 */
    SP_BUS_AXIS_B = 2  /**< controller <-> drives of legs 4..6 */
} sp_bus_t;

#define SP_CAN_FLAG_FD 0x01u  /**< CAN FD frame (else classic CAN) */
#define SP_CAN_FLAG_BRS 0x02u /**< CAN FD bit-rate switch */

typedef struct {
    uint32_t id;                   /**< 11-bit identifier */
    uint8_t bus;                   /**< sp_bus_t */
    uint8_t len;                   /**< payload bytes: 0..8, 12, 16, 20, 24, 32, 48, 64 */
    uint8_t flags;                 /**< SP_CAN_FLAG_* */
    uint8_t data[SP_CAN_MAX_DATA]; /**< payload; bytes past len are zero */
} sp_can_frame_t;

#endif /* SP_CAN_H */
