/* SPDX-License-Identifier: Apache-2.0 */
/* co_bus.c - the plant's drives as CiA 408 nodes (hs/co_bus.h). */
#include "hs/co_bus.h"

#include <math.h>
#include <string.h>

hs_status_t hs_co_bus_init(hs_co_bus_t *b, const uint8_t node_id[HS_LEGS], const uint8_t bus[HS_LEGS],
                           const double zero[HS_LEGS], double m_per_count)
{
    int i;
    if (b == NULL || node_id == NULL || bus == NULL || zero == NULL || !(m_per_count > 0.0) || !isfinite(m_per_count)) {
        return HS_E_ARG;
    }
    memset(b, 0, sizeof *b);
    for (i = 0; i < HS_LEGS; i++) {
        if (hs_co_node_init(&b->node[i], node_id[i], bus[i]) != HS_OK || !isfinite(zero[i])) {
            return HS_E_ARG;
        }
        b->zero[i] = zero[i];
    }
    b->m_per_count = m_per_count;
    b->sync_period = 1e-3;
    b->interpolate = 2u;
    return HS_OK;
}

hs_status_t hs_co_bus_set_profile(hs_co_bus_t *b, uint8_t profile)
{
    int i;
    if (b == NULL || profile > 1u) {
        return HS_E_ARG;
    }
    for (i = 0; i < HS_LEGS; i++) {
        if (hs_co_node_init_profile(&b->node[i], b->node[i].node_id, b->node[i].bus, profile) != HS_OK) {
            return HS_E_ARG;
        }
    }
    return HS_OK;
}

hs_status_t hs_co_bus_receive(hs_co_bus_t *b, const sp_can_frame_t *f, sp_can_frame_t tx[HS_CO_BUS_MAX_TX],
                              uint8_t *n_tx)
{
    int i;
    if (b == NULL || f == NULL || tx == NULL || n_tx == NULL) {
        return HS_E_ARG;
    }
    *n_tx = 0u;
    if (f->id == SP_CO_COB_SYNC && f->bus == b->node[0].bus) {
        /* the SYNC period, from the bus of leg 1 (every bus has the same) */
        if (b->ms_since_sync > 0u) {
            b->sync_period = 1e-3 * (double)b->ms_since_sync;
        }
        b->ms_since_sync = 0u;
    }
    for (i = 0; i < HS_LEGS; i++) {
        uint8_t n = 0u;
        (void)hs_co_node_receive(&b->node[i], f, &tx[*n_tx], &n);
        *n_tx = (uint8_t)(*n_tx + n);
        if (f->id == SP_CO_COB_SYNC && f->bus == b->node[i].bus) {
            int32_t sp = b->node[i].setpoint;
            int on = b->interpolate && hs_co_node_follows(&b->node[i]);
            double T = b->sync_period;
            b->accel[i] = on && b->interpolate == 2u
                              ? (double)(sp - 2 * b->last_setpoint[i] + b->prev_setpoint[i]) * b->m_per_count / (T * T)
                              : 0.0;
            b->velocity[i] = on ? (double)(sp - b->last_setpoint[i]) * b->m_per_count / T + 0.5 * b->accel[i] * T : 0.0;
            b->prev_setpoint[i] = b->last_setpoint[i];
            b->last_setpoint[i] = sp;
        }
    }
    return HS_OK;
}

hs_status_t hs_co_bus_apply(hs_co_bus_t *b, hs_plant_t *plant)
{
    int i;
    if (b == NULL || plant == NULL) {
        return HS_E_ARG;
    }
    for (i = 0; i < HS_LEGS; i++) {
        const hs_co_node_t *n = &b->node[i];
        double length = b->zero[i] + (double)n->setpoint * b->m_per_count;
        int follows = hs_co_node_follows(n);
        /* the setpoint of this SYNC period, moved on by its velocity since the SYNC */
        double t = 1e-3 * (double)b->ms_since_sync;
        double a = follows ? b->accel[i] : 0.0;
        double v = follows ? b->velocity[i] : 0.0;
        double force = follows ? hs_co_node_force_n(n) : 0.0;
        (void)hs_plant_set_setpoint(plant, i, length + v * t + 0.5 * a * t * t, v + a * t, force,
                                    follows ? HS_REQ_ACTIVE : HS_REQ_HOLD);
        /* a CiA 408 valve disabled while operational: its spool at the fail-safe position, modelled as
         * the valve at null and the blocking valves closed (the native drive's Block) */
        (void)hs_plant_set_block(
            plant, i, n->profile != 1u && n->nmt == SP_CO_NMT_STATE_OPERATIONAL && n->state == SP_CO408_DISABLED);
    }
    return HS_OK;
}

static uint16_t kpa(double pa)
{
    double k = floor(pa / 1000.0 + 0.5);
    return k <= 0.0 ? 0u : (k >= 65535.0 ? 65535u : (uint16_t)k);
}

hs_status_t hs_co_bus_sample(hs_co_bus_t *b, const hs_plant_t *plant)
{
    int i;
    if (b == NULL || plant == NULL) {
        return HS_E_ARG;
    }
    for (i = 0; i < HS_LEGS; i++) {
        hs_feedback_t fb;
        double c;
        if (hs_plant_feedback(plant, i, &fb) != HS_OK) {
            return HS_E_ARG;
        }
        c = floor((fb.length - b->zero[i]) / b->m_per_count + 0.5);
        c = c > 2147483647.0 ? 2147483647.0 : (c < -2147483648.0 ? -2147483648.0 : c);
        b->node[i].actual = (int32_t)c;
        b->node[i].pa_kpa = kpa(fb.pressure_a);
        b->node[i].pb_kpa = kpa(fb.pressure_b);
    }
    return HS_OK;
}

hs_status_t hs_co_bus_tick(hs_co_bus_t *b, uint32_t ms, sp_can_frame_t tx[HS_CO_BUS_MAX_TX], uint8_t *n_tx)
{
    int i;
    if (b == NULL || tx == NULL || n_tx == NULL || ms == 0u || ms > 1000u) {
        return HS_E_ARG;
    }
    *n_tx = 0u;
    b->ms_since_sync += ms;
    for (i = 0; i < HS_LEGS; i++) {
        uint8_t n = 0u;
        (void)hs_co_node_tick(&b->node[i], ms, &tx[*n_tx], &n);
        *n_tx = (uint8_t)(*n_tx + n);
    }
    return HS_OK;
}
