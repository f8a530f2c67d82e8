/* SPDX-License-Identifier: Apache-2.0 */
/* canopen_link.c - the controller's drives over CANopen (sp/canopen/canopen_link.h). */
#include "sp/canopen/canopen_link.h"

#include "canopen/canopen_scaling.h"
#include "link/link_internal.h"
#include "sp/model/kinematics.h"

/* The built-in platform's sensors come with it; another platform's readings
 * are lengths (as sp_node_default_config). */
static const sp_length_sensors_t *link_sensors(const sp_platform_t *platform)
{
    return (platform == &sp_platform_default) ? sp_length_sensors_in_use(&sp_length_sensors_default) : NULL;
}

sp_status_t sp_co_link_cfg_default(sp_co_link_cfg_t *cfg, const sp_platform_t *platform,
                                   const sp_q24_t zero_q24[SP_LEGS])
{
    uint32_t i;
    if (cfg == NULL || platform == NULL || zero_q24 == NULL) {
        return SP_E_ARG;
    }
    memset(cfg, 0, sizeof *cfg);
    if (sp_co_master_cfg_default(&cfg->master, (uint8_t)SP_LEGS) != SP_OK) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; i++) {
        cfg->scaling[i].nm_per_count = 1000u;
        cfg->scaling[i].zero_q24 = zero_q24[i];
        cfg->scaling[i].direction = 1;
        (void)sp_co_scaling_prepare(&cfg->scaling[i]);
    }
    cfg->platform = platform;
    cfg->length_sensors = link_sensors(platform);
    return SP_OK;
}

sp_status_t sp_co_link_cfg_from_layout(sp_co_link_cfg_t *cfg, const sp_co_layout_t *layout,
                                       const sp_platform_t *platform)
{
    uint32_t i;
    if (cfg == NULL || layout == NULL || platform == NULL || !layout->present) {
        return SP_E_ARG;
    }
    memset(cfg, 0, sizeof *cfg);
    cfg->master = layout->master;
    for (i = 0u; i < SP_LEGS; i++) {
        cfg->scaling[i] = layout->scaling[i];
        if (sp_co_scaling_prepare(&cfg->scaling[i]) != SP_OK) {
            return SP_E_ARG;
        }
    }
    cfg->platform = platform;
    cfg->length_sensors = link_sensors(platform);
    return sp_co_link_cfg_check(cfg);
}

sp_status_t sp_co_link_cfg_check(const sp_co_link_cfg_t *cfg)
{
    uint32_t seen = 0u, k;
    int32_t probe;
    if (cfg == NULL || cfg->platform == NULL || sp_co_master_cfg_check(&cfg->master) != SP_OK ||
        cfg->master.n_nodes != SP_LEGS) {
        return SP_E_ARG;
    }
    for (k = 0u; k < SP_LEGS; k++) {
        uint8_t leg = cfg->master.node[k].leg;
        if (leg < 1u || leg > SP_LEGS || (seen & (1u << (leg - 1u))) != 0u) {
            return SP_E_ARG;
        }
        seen |= 1u << (leg - 1u);
        if (sp_co_length_to_count(&cfg->scaling[leg - 1u], 0, &probe) == SP_E_ARG) {
            return SP_E_ARG;
        }
        if (cfg->master.node[k].profile == (uint8_t)SP_CO_PROFILE_402 && cfg->master.node[k].force_ff &&
            cfg->scaling[leg - 1u].permille_per_n_q24 == 0u) {
            return SP_E_ARG; /* 0x60B2 is per mille of a rated force the config did not give */
        }
    }
    return SP_OK;
}

sp_status_t sp_co_link_feedback(const sp_co_master_t *m, const sp_co_link_cfg_t *cfg, sp_drive_feedback_t fb[SP_LEGS])
{
    sp_status_t st = SP_OK;
    uint32_t k;
    if (m == NULL || cfg == NULL || fb == NULL || cfg->platform == NULL || cfg->master.n_nodes > SP_CO_MAX_NODES) {
        return SP_E_ARG;
    }
    for (k = 0u; k < SP_LEGS; k++) {
        fb[k].fresh = 0u;
    }
    for (k = 0u; k < cfg->master.n_nodes; k++) {
        const sp_co_node_t *nd = &m->node[k];
        uint32_t leg = (uint32_t)cfg->master.node[k].leg - 1u;
        sp_drive_feedback_t *d;
        if (leg >= SP_LEGS || !nd->tpdo1_fresh) {
            continue;
        }
        d = &fb[leg];
        /* the drive's position is the sensor's reading: -> joint-to-joint length
         * (calibrated zero and gain; identity by default), saturated on overflow */
        if (!spi_co_scaling_ok(&cfg->scaling[leg]) ||
            spi_co_count_to_length(&cfg->scaling[leg], nd->actual, &d->length) != SP_OK ||
            sp_length_from_sensor(cfg->platform, cfg->length_sensors, (unsigned)leg, d->length, &d->length) != SP_OK) {
            st = SP_E_OVERFLOW;
        }
        if (cfg->master.pressure_feedback && cfg->master.node[k].profile != (uint8_t)SP_CO_PROFILE_402) {
            /* the pressures in Pa, as the native feedback carries them (kPa x 1000 < 2^32) */
            d->force = spi_cylinder_force(cfg->platform, (uint32_t)nd->pa_kpa * 1000u, (uint32_t)nd->pb_kpa * 1000u);
            d->no_force = 0u;
        } else {
            d->force = 0; /* no pressures mapped (CiA 402, or no pressure feedback): no force measured */
            d->no_force = 1u;
        }
        d->faults = nd->fault.code != (uint8_t)SP_CO_F_NONE ? (uint16_t)SP_CO_LINK_FAULT : 0u;
        d->fresh = 1u;
    }
    return st;
}

/* Q8 N -> daN along the drive's count, rounded half away from zero, saturated to INT16. */
static int16_t force_dan(sp_q8_t force_q8, int8_t direction)
{
    int32_t f = direction < 0 ? -(force_q8 / 2) : force_q8 / 2; /* Q7, no overflow on negation */
    int32_t dan = (f >= 0 ? f + 640 : f - 640) / 1280;
    return (int16_t)(dan > INT16_MAX ? INT16_MAX : (dan < INT16_MIN ? INT16_MIN : dan));
}

/* The master's request (ACTIVE while the controller's drive mode is
 * ACTIVE, else HOLD), whether the controller blocks its drives, and the
 * time: every tick's part of the input. */
static void link_request(const sp_ctrl_output_t *out, uint32_t now_ms, sp_co_master_input_t *in)
{
    in->now_ms = now_ms;
    in->request = out->drive_mode == SP_DRIVE_ACTIVE ? (uint8_t)SP_CO_REQ_ACTIVE : (uint8_t)SP_CO_REQ_HOLD;
    in->block = (out->drive_block != 0u) ? 1u : 0u;
}

sp_status_t sp_co_link_input(const sp_co_link_cfg_t *cfg, const sp_ctrl_output_t *out, uint32_t now_ms,
                             sp_co_master_input_t *in)
{
    sp_status_t st = SP_OK;
    uint32_t k;
    sp_q24_t reading = 0;
    if (cfg == NULL || out == NULL || in == NULL || cfg->master.n_nodes > SP_CO_MAX_NODES) {
        return SP_E_ARG;
    }
    link_request(out, now_ms, in);
    for (k = 0u; k < cfg->master.n_nodes; k++) {
        uint32_t leg = (uint32_t)cfg->master.node[k].leg - 1u;
        in->setpoint[k] = 0;
        in->force_ff[k] = 0;
        if (leg < SP_LEGS && cfg->master.node[k].profile != (uint8_t)SP_CO_PROFILE_402) {
            in->force_ff[k] = force_dan(out->setpoint[leg].force, cfg->scaling[leg].direction);
        } else if (leg < SP_LEGS && cfg->master.node[k].force_ff && cfg->scaling[leg].permille_per_n_q24 != 0u) {
            /* saturated at INT16 (a force beyond 32.767 times the rated one): the setpoint still goes out */
            (void)spi_co_force_to_permille(&cfg->scaling[leg], out->setpoint[leg].force, &in->force_ff[k]);
        }
        /* joint-to-joint length -> what the leg's sensor reads there -> counts */
        if (leg < SP_LEGS && (!spi_co_scaling_ok(&cfg->scaling[leg]) ||
                              sp_length_to_sensor(cfg->platform, cfg->length_sensors, (unsigned)leg,
                                                  out->setpoint[leg].length, &reading) != SP_OK ||
                              spi_co_length_to_count(&cfg->scaling[leg], reading, &in->setpoint[k]) != SP_OK)) {
            st = SP_E_OVERFLOW;
        }
    }
    return st;
}

sp_status_t sp_co_link_input_due(const sp_co_link_cfg_t *cfg, const sp_co_master_t *m, const sp_ctrl_output_t *out,
                                 uint32_t now_ms, sp_co_master_input_t *in)
{
    if (cfg == NULL || m == NULL || out == NULL || in == NULL) {
        return SP_E_ARG;
    }
    if (sp_co_master_sync_due(m, &cfg->master)) {
        return sp_co_link_input(cfg, out, now_ms, in);
    }
    link_request(out, now_ms, in);
    return SP_OK;
}

sp_status_t sp_co_link_ctrl_config(const sp_co_link_cfg_t *cfg, sp_ctrl_config_t *ctrl)
{
    if (cfg == NULL || ctrl == NULL || cfg->master.sync_divider == 0u) {
        return SP_E_ARG;
    }
    ctrl->feedback_divider = cfg->master.sync_divider;
    if (ctrl->feedback_timeout_ticks <= cfg->master.sync_divider) {
        ctrl->feedback_timeout_ticks = (uint32_t)cfg->master.sync_divider + 2u;
    }
    return SP_OK;
}

uint8_t sp_co_link_setpoints_idle(const sp_co_link_cfg_t *cfg, const sp_co_master_t *m)
{
    if (cfg == NULL || m == NULL) {
        return 1u;
    }
    return (uint8_t)(sp_co_master_sync_due(m, &cfg->master) ? 0u : 1u);
}
