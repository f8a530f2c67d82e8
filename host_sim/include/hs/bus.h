/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/bus.h - the drives' side of the CAN protocol (protocol/stewart.dbc) for
 * the simulated plant: plant feedback -> AXIS_FEEDBACK frames (+ SYNC when
 * the plant is the cycle master), AXIS_SETPOINTS frames -> drive setpoints.
 * Frames are packed and checked by the firmware core's protocol layer
 * (sp/link/protocol.h: the same DBC, the same E2E CRC and alive counters), so the
 * plant and the controller cannot disagree on the bit layout.
 *
 * Pure: no sockets, no clock. The executable (host_sim/app/hs_sim.c) moves
 * the frames between this and SocketCAN.
 *
 * Legs 0..5 of the plant are slots 1..3 of axis_a (legs 0..2) and of
 * axis_b (legs 3..5). Units: lengths are sent in tenths of a micrometre,
 * the default sensors' resolution (a coarser sensor's counts are sent
 * without loss); pressures are rounded from the sensors' counts to the
 * DBC's 1 kPa (the default sensor resolution: sent without loss).
 */
#ifndef HS_BUS_H
#define HS_BUS_H

#include <stdint.h>

#include "hs/plant.h"
#include "sp/link/protocol.h"

#define HS_BUS_MAX_TX 8u /**< frames hs_bus_cycle_frames emits at most: 6 feedback + 2 SYNC */

typedef struct {
    uint32_t accepted;                  /**< setpoint frames applied */
    uint32_t rejected[SP_PROTO_ERRORS]; /**< dropped frames by reason (sp_proto_error_t) */
    uint32_t lost;                      /**< setpoint frames missed according to the alive counters */
    uint32_t stale;                     /**< valid setpoints for another tick than the current cycle's */
    uint32_t ignored;                   /**< frames not addressed to the drives (other identifiers) */
    uint32_t resets;                    /**< drive fault resets carried out (per drive) */
    uint32_t resets_refused; /**< drive fault resets refused: a cause remained (per drive); every count saturates */
} hs_bus_stats_t;

typedef struct {
    uint8_t tx_counter_feedback[HS_LEGS];
    uint8_t tx_counter_sync[2];
    sp_e2e_rx_t rx_setpoints[2];
    uint32_t tick;            /**< the current cycle (SYNC tick) */
    uint8_t got_setpoints[2]; /**< setpoints for `tick` received on axis_a / axis_b */
    uint8_t silent_mask;      /**< bit i: drive of leg i sends no feedback (fault injection) */
    uint8_t frozen_mask;      /**< bit i: drive of leg i repeats its alive counter (fault injection) */
    uint8_t stale_mask;       /**< bit i: drive of leg i echoes an old SYNC tick (fault injection) */
    uint16_t stale_ticks;     /**< how old: TickEcho = tick - stale_ticks */
    uint8_t last_reset[2];    /**< FaultReset of the last accepted setpoints on axis_a / axis_b */
    hs_bus_stats_t stats;
} hs_bus_t;

/** Zeroes the binding: counters at 0, no setpoints, cycle tick 0. HS_E_ARG on NULL. */
hs_status_t hs_bus_init(hs_bus_t *bus);

/**
 * Starts cycle `tick`: the feedback of every drive that is not silenced, as
 * sampled by the plant at the end of its last cycle (TickEcho = tick mod
 * 2^16), then, if `sync_master`, SYNC(tick) on both axis buses after their
 * feedback. Writes up to HS_BUS_MAX_TX frames to out[0..*n). Resets the
 * "setpoints received" flags for the new tick. Values are saturated to the
 * DBC's ranges by the encoder (a pressure above 65.535 MPa is sent as the
 * maximum). HS_E_ARG on NULL.
 */
hs_status_t hs_bus_cycle_frames(hs_bus_t *bus, const hs_plant_t *plant, uint32_t tick, uint8_t sync_master,
                                sp_can_frame_t out[HS_BUS_MAX_TX], uint32_t *n);

/**
 * Takes one received frame. AXIS_SETPOINTS on an axis bus with a good CRC,
 * an accepted alive counter and in-range values is applied to the three
 * drives of that bus (hs_plant_set_setpoint: length m, velocity m/s, force N,
 * mode) whatever its tick, since a drive follows the newest setpoint; it is
 * counted as stale if its tick is neither the current cycle's nor the next
 * one's (in real time the controller sends setpoints just before their SYNC). A rejected frame
 * raises HS_FAULT_COMM on the drives of its bus (a warning bit; the drives'
 * setpoint watchdog does the rest) and is counted by reason. Frames with
 * other identifiers are counted as ignored. A rising edge of FaultReset
 * (0 in the last accepted setpoints of that bus, 1 in these) runs the fault
 * reset of its three drives (hs_plant_fault_reset), counted in
 * stats.resets / resets_refused, before their setpoints are stored. Returns HS_OK if the frame was
 * used, HS_E_RANGE if it was rejected or ignored, HS_E_ARG on NULL.
 */
hs_status_t hs_bus_receive(hs_bus_t *bus, hs_plant_t *plant, const sp_can_frame_t *frame);

/** 1 once setpoints for the current cycle's tick arrived on both axis buses. */
int hs_bus_cycle_complete(const hs_bus_t *bus);

#endif /* HS_BUS_H */
