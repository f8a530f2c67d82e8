/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/co_bus.h - the plant's six drives as CiA 408 nodes (hs/co_node.h) on
 * the CANopen buses: the CANopen counterpart of hs/bus.h.
 *
 * Per plant cycle (1 ms), in this order:
 *  - hs_co_bus_receive() for every frame of the master (NMT, SDO, RPDO1,
 *    SYNC); at SYNC each node applies its setpoint and answers with its
 *    TPDOs (the position and pressures sampled at the last hs_co_bus_sample);
 *  - hs_co_bus_apply(): each drive of the plant gets its node's setpoint
 *    (ACTIVE while the node follows, else HOLD); a CiA 408 node DISABLED
 *    while operational blocks its drive (valve at null, blocking valves
 *    closed: a valve's fail-safe spool position);
 *  - hs_plant_step();
 *  - hs_co_bus_sample(): each node's actual position (counts) and pressures
 *    (kPa) from the plant's feedback;
 *  - hs_co_bus_tick(): heartbeats, EMCY, the nodes' watchdogs.
 *
 * Scaling: position count = round((length - zero) / m_per_count). The
 * drive's own reference generator moves the setpoint on between SYNCs, as
 * a drive's interpolating demand value generator does: interpolate = 2
 * (the default) second order, the acceleration from the last three
 * setpoints and the velocity at the SYNC from the last two plus half a
 * period of that acceleration (position sp + v t + a t^2 / 2, velocity
 * v + a t); 1 first order (the velocity of the last two setpoints, the
 * acceleration 0); 0 steps from setpoint to setpoint.
 */
#ifndef HS_CO_BUS_H
#define HS_CO_BUS_H

#include <stdint.h>

#include "hs/co_node.h"
#include "hs/plant.h"

#define HS_CO_BUS_MAX_TX (HS_LEGS * HS_CO_MAX_TX) /**< frames one call emits, at most */

typedef struct {
    hs_co_node_t node[HS_LEGS]; /**< leg i's drive */
    double zero[HS_LEGS];       /**< leg length at count 0, m */
    double m_per_count;         /**< m per count (1e-6) */
    double sync_period;         /**< s between SYNCs, measured by the bus (for the interpolation) */
    uint8_t interpolate;        /**< 2: second order (default), 1: first order, 0: steps (above) */
    int32_t last_setpoint[HS_LEGS];
    int32_t prev_setpoint[HS_LEGS]; /**< the one before last_setpoint */
    double velocity[HS_LEGS];       /**< m/s from the setpoints */
    double accel[HS_LEGS];          /**< m/s^2 from three setpoints (interpolate = 2) */
    uint32_t ms_since_sync;         /**< ms since the last SYNC */
} hs_co_bus_t;

/** Six nodes (node ids and bus indices per leg), count 0 at zero[i] (m),
 *  m_per_count > 0. HS_E_ARG for NULL or a bad node id, bus or scale. */
hs_status_t hs_co_bus_init(hs_co_bus_t *b, const uint8_t node_id[HS_LEGS], const uint8_t bus[HS_LEGS],
                           const double zero[HS_LEGS], double m_per_count);

/** Presents every drive as a node of the device profile (0 = CiA 408, the
 *  default; 1 = CiA 402): the nodes are powered up again with that
 *  profile's defaults. HS_E_ARG for NULL or another profile. */
hs_status_t hs_co_bus_set_profile(hs_co_bus_t *b, uint8_t profile);

/** One frame from the master to every node of its bus; answers in tx
 *  (*n_tx of them, at most HS_CO_BUS_MAX_TX). HS_E_ARG for NULL. */
hs_status_t hs_co_bus_receive(hs_co_bus_t *b, const sp_can_frame_t *f, sp_can_frame_t tx[HS_CO_BUS_MAX_TX],
                              uint8_t *n_tx);

/** Each plant drive's setpoint from its node (HOLD unless the node follows).
 *  HS_E_ARG for NULL. */
hs_status_t hs_co_bus_apply(hs_co_bus_t *b, hs_plant_t *plant);

/** Each node's actual position and pressures from the plant's feedback
 *  (saturated to the object's range). HS_E_ARG for NULL. */
hs_status_t hs_co_bus_sample(hs_co_bus_t *b, const hs_plant_t *plant);

/** Advances the nodes' clocks by ms (1..1000); their frames in tx. */
hs_status_t hs_co_bus_tick(hs_co_bus_t *b, uint32_t ms, sp_can_frame_t tx[HS_CO_BUS_MAX_TX], uint8_t *n_tx);

#endif /* HS_CO_BUS_H */
