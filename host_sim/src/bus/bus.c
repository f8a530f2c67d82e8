/* SPDX-License-Identifier: Apache-2.0 */
/* bus.c - the drives' side of the CAN protocol for the plant (hs/bus.h). */
#include "hs/bus.h"

#include <math.h>
#include <string.h>

/* Q24 of a length given in tenths of a micrometre (AXIS_FEEDBACK's step):
 * exact to the Q24 step (60 nm, below half the step), so the encoder's
 * rounding back to 0.1 um returns the same count. */
static sp_q24_t q24_of_tenth_um(int64_t n)
{
    if (n < 0) {
        n = 0;
    }
    int64_t q = (n * (int64_t)SP_Q24_ONE + 5000000) / 10000000;
    return (q > INT32_MAX) ? INT32_MAX : (sp_q24_t)q;
}

/* Pa from pressure counts, rounded to the DBC's 1 kPa later by the encoder. */
static uint32_t pa_of(double pressure)
{
    if (!(pressure > 0.0)) {
        return 0u;
    }
    if (pressure > 4.0e9) {
        return 4000000000u;
    }
    return (uint32_t)llround(pressure);
}

/* Statistics saturate at UINT32_MAX, never wrap to 0. */
static void inc(uint32_t *c)
{
    if (*c < UINT32_MAX) {
        (*c)++;
    }
}

hs_status_t hs_bus_init(hs_bus_t *bus)
{
    if (bus == NULL) {
        return HS_E_ARG;
    }
    memset(bus, 0, sizeof *bus);
    return HS_OK;
}

hs_status_t hs_bus_cycle_frames(hs_bus_t *bus, const hs_plant_t *plant, uint32_t tick, uint8_t sync_master,
                                sp_can_frame_t out[HS_BUS_MAX_TX], uint32_t *n)
{
    if (bus == NULL || plant == NULL || out == NULL || n == NULL) {
        return HS_E_ARG;
    }
    *n = 0u;
    bus->tick = tick;
    bus->got_setpoints[0] = 0u;
    bus->got_setpoints[1] = 0u;
    for (int b = 0; b < 2; b++) {
        uint8_t sp_bus = (uint8_t)(SP_BUS_AXIS_A + b);
        for (int s = 0; s < 3; s++) {
            int leg = 3 * b + s;
            if (bus->silent_mask & (1u << leg)) {
                continue;
            }
            hs_feedback_t fb;
            (void)hs_plant_feedback(plant, leg, &fb);
            sp_msg_feedback_t m;
            m.length = q24_of_tenth_um((int64_t)llround(fb.length / 1.0e-7));
            m.pressure_a = pa_of(fb.pressure_a);
            m.pressure_b = pa_of(fb.pressure_b);
            m.state = (uint8_t)fb.state;
            m.faults = (uint8_t)(fb.faults & 0xFFu);
            m.tick_echo = (uint16_t)(tick & 0xFFFFu);
            if (bus->stale_mask & (1u << leg)) {
                m.tick_echo = (uint16_t)((tick - bus->stale_ticks) & 0xFFFFu);
            }
            (void)sp_proto_encode_feedback(&m, (uint8_t)(s + 1), bus->tx_counter_feedback[leg], sp_bus, &out[*n]);
            if ((bus->frozen_mask & (1u << leg)) == 0u) {
                bus->tx_counter_feedback[leg] = (uint8_t)((bus->tx_counter_feedback[leg] + 1u) & 0x0Fu);
            }
            (*n)++;
        }
        if (sync_master) {
            sp_msg_sync_t sy = {tick, 0u};
            (void)sp_proto_encode_sync(&sy, bus->tx_counter_sync[b], sp_bus, &out[*n]);
            bus->tx_counter_sync[b] = (uint8_t)((bus->tx_counter_sync[b] + 1u) & 0x0Fu);
            (*n)++;
        }
    }
    return HS_OK;
}

hs_status_t hs_bus_receive(hs_bus_t *bus, hs_plant_t *plant, const sp_can_frame_t *frame)
{
    if (bus == NULL || plant == NULL || frame == NULL) {
        return HS_E_ARG;
    }
    if (frame->id != SP_ID_AXIS_SETPOINTS) {
        inc(&bus->stats.ignored);
        return HS_E_RANGE;
    }
    if (frame->bus != SP_BUS_AXIS_A && frame->bus != SP_BUS_AXIS_B) {
        inc(&bus->stats.rejected[SP_PROTO_WRONG_BUS]);
        return HS_E_RANGE;
    }
    int b = (int)frame->bus - (int)SP_BUS_AXIS_A;
    sp_msg_setpoints_t m;
    uint8_t counter = 0u;
    sp_proto_error_t why = SP_PROTO_OK;
    if (sp_proto_decode_setpoints(frame, &m, &counter, &why) != SP_OK) {
        inc(&bus->stats.rejected[why < SP_PROTO_ERRORS ? why : SP_PROTO_UNKNOWN_ID]);
        for (int s = 0; s < 3; s++) {
            (void)hs_plant_raise_faults(plant, 3 * b + s, HS_FAULT_COMM);
        }
        return HS_E_RANGE;
    }
    sp_e2e_result_t r = sp_e2e_rx_check(&bus->rx_setpoints[b], counter);
    if (!sp_e2e_accepted(r)) {
        inc(&bus->stats.rejected[r == SP_E2E_REPEATED ? SP_PROTO_REPEATED : SP_PROTO_WRONG_SEQUENCE]);
        for (int s = 0; s < 3; s++) {
            (void)hs_plant_raise_faults(plant, 3 * b + s, HS_FAULT_COMM);
        }
        return HS_E_RANGE;
    }
    if (r == SP_E2E_OK_LOST) {
        inc(&bus->stats.lost);
    }
    if (m.fault_reset && !bus->last_reset[b]) {
        for (int s = 0; s < 3; s++) {
            uint32_t remaining = 0u;
            (void)hs_plant_fault_reset(plant, 3 * b + s, &remaining);
            if (remaining != 0u) {
                inc(&bus->stats.resets_refused);
            } else {
                inc(&bus->stats.resets);
            }
        }
    }
    bus->last_reset[b] = m.fault_reset ? 1u : 0u;
    hs_drive_request_t mode = (m.mode == SP_DRIVE_ACTIVE) ? HS_REQ_ACTIVE : HS_REQ_HOLD;
    for (int s = 0; s < 3; s++) {
        const sp_setpoint_t *sp = &m.setpoint[s];
        (void)hs_plant_set_setpoint(plant, 3 * b + s, (double)sp->length / (double)SP_Q24_ONE,
                                    (double)sp->velocity / (double)SP_Q24_ONE, (double)sp->force / (double)SP_Q8_ONE,
                                    mode);
        (void)hs_plant_set_block(plant, 3 * b + s, m.block);
    }
    if (m.tick == bus->tick) {
        bus->got_setpoints[b] = 1u;
    } else if (m.tick != bus->tick + 1u) { /* real time: setpoints come just before their SYNC */
        inc(&bus->stats.stale);
    }
    inc(&bus->stats.accepted);
    return HS_OK;
}

int hs_bus_cycle_complete(const hs_bus_t *bus)
{
    return bus != NULL && bus->got_setpoints[0] && bus->got_setpoints[1];
}
