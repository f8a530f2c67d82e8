/* SPDX-License-Identifier: Apache-2.0 */
/*
 * estop.c - ESTOP's reaction (docs/reference/safety.md): the controlled
 * stop of IEC 60204-1 category 1 (decelerate along the path by the
 * drives' position loops with the force feed-forward, then hold and close
 * the blocking valves) or the immediate category 0 (hold and block at
 * once) for a controller that cannot trust its loop.
 */
#include "control/control_internal.h"

#define SETTLE_TICKS_MAX 1000u

sp_status_t spi_estop_config_check(const sp_estop_config_t *cfg)
{
    if (cfg == NULL || cfg->category > 1u || cfg->settle_ticks > SETTLE_TICKS_MAX) {
        return SP_E_ARG;
    }
    /* the limits matter only for category 1 */
    return (cfg->category == 0u) ? SP_OK : sp_stop_limits_check(&cfg->limits);
}

void spi_estop_clear(sp_ctrl_t *ctrl)
{
    ctrl->estop.reaction = (uint8_t)SP_STOP_NONE;
    ctrl->estop.cause = (uint8_t)SP_STOP_CAUSE_NONE;
    ctrl->estop.settle = 0u;
    ctrl->estop.stop.ticks = 0u;
    ctrl->estop.stop.tick = 0u;
}

/* Category 0: the drives hold where they are told to be, at rest, and
 * their blocking valves close (write_output: ESTOP). */
static void immediate(sp_ctrl_t *ctrl, uint8_t cause)
{
    ctrl->faults |= SP_FAULT_ESTOP;
    ctrl->state = SP_STATE_ESTOP;
    ctrl->move.duration_ticks = 0u;
    ctrl->move.tick = 0u;
    ctrl->estop.reaction = (uint8_t)SP_STOP_IMMEDIATE;
    ctrl->estop.cause = cause;
}

static int any_drive_fault(const sp_ctrl_t *ctrl)
{
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        if (ctrl->sup.last_faults[i] != 0u) {
            return 1;
        }
    }
    return 0;
}

void spi_estop_take(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, int active, int comms_ok)
{
    uint8_t cause = (uint8_t)SP_STOP_CAUSE_NONE;
    ctrl->drive_reset.left = 0u; /* a reset under way does not re-engage after an ESTOP */
    ctrl->busy = 1u;             /* the stop's plan and its end's reach check: this tick's model work waits */
    if (ctrl->state == SP_STATE_ESTOP) {
        ctrl->faults |= SP_FAULT_ESTOP;
        return;
    }
    if (ctrl->state == SP_STATE_STOPPING) {
        cause = (uint8_t)SP_STOP_CAUSE_SECOND;
    } else if (cfg->estop.category == 0u) {
        cause = (uint8_t)SP_STOP_CAUSE_CONFIG;
    } else if (!active || !ctrl->have_setpoint) {
        cause = (uint8_t)SP_STOP_CAUSE_HOLDING;
    } else if (!comms_ok) {
        cause = (uint8_t)SP_STOP_CAUSE_COMMS;
    } else if (!ctrl->est.valid) {
        cause = (uint8_t)SP_STOP_CAUSE_ESTIMATE;
    } else if (any_drive_fault(ctrl)) {
        cause = (uint8_t)SP_STOP_CAUSE_DRIVE;
    } else if (sp_stop_plan(&ctrl->estop.stop, &ctrl->reference, &cfg->estop.limits, cfg->tick_us) != SP_OK ||
               !sp_limits_pose_reachable(&ctrl->prep.limits, cfg->platform, &ctrl->estop.stop.to, NULL)) {
        cause = (uint8_t)SP_STOP_CAUSE_PLAN;
    }
    if (cause != (uint8_t)SP_STOP_CAUSE_NONE) {
        immediate(ctrl, cause);
        return;
    }
    ctrl->faults |= SP_FAULT_ESTOP;
    ctrl->move.duration_ticks = 0u;
    ctrl->move.tick = 0u;
    ctrl->estop.reaction = (uint8_t)SP_STOP_CONTROLLED;
    ctrl->estop.cause = (uint8_t)SP_STOP_CAUSE_NONE;
    /* at rest already (READY, a finished move): nothing to decelerate or settle */
    ctrl->estop.settle = (ctrl->estop.stop.ticks > 0u) ? cfg->estop.settle_ticks : 0u;
    ctrl->state = (ctrl->estop.stop.ticks > 0u) ? SP_STATE_STOPPING : SP_STATE_ESTOP;
}

void spi_estop_fault(sp_ctrl_t *ctrl, uint32_t fault)
{
    uint8_t cause = (uint8_t)SP_STOP_CAUSE_FAULT;
    if ((fault & SP_FAULT_FEEDBACK_TIMEOUT) != 0u) {
        cause = (uint8_t)SP_STOP_CAUSE_COMMS;
    } else if ((fault & SP_FAULT_FK) != 0u) {
        cause = (uint8_t)SP_STOP_CAUSE_ESTIMATE;
    } else if ((fault & SP_FAULT_DRIVE) != 0u) {
        cause = (uint8_t)SP_STOP_CAUSE_DRIVE;
    }
    immediate(ctrl, cause);
}

int spi_estop_reference(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref)
{
    int done = 0;
    (void)cfg;
    (void)sp_stop_step(&ctrl->estop.stop, ref, &done); /* no NULL: SP_OK, never saturates */
    if (!done) {
        return 0;
    }
    if (ctrl->estop.settle > 0u) {
        --ctrl->estop.settle; /* at rest at the end, the position loops settling */
        return 0;
    }
    ctrl->state = SP_STATE_ESTOP;
    return 1;
}
