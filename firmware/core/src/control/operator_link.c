/* SPDX-License-Identifier: Apache-2.0 */
/*
 * operator_link.c - the operator link's supervision (sp/control/controller.h,
 * sp_ctrl_operator_link): a silent operator ends a running motion, or
 * force control.
 */
#include "sp/control/controller.h"

static const sp_ctrl_cmd_t k_none = {.type = SP_CMD_NONE};
static const sp_ctrl_cmd_t k_stop = {.type = SP_CMD_STOP};
static const sp_ctrl_cmd_t k_park = {.type = SP_CMD_PARK};
static const sp_ctrl_cmd_t k_position = {.type = SP_CMD_POSITION};

/* With the operator-silent fault latched: what becomes of the command. */
static const sp_ctrl_cmd_t *latched(sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd, int *dropped)
{
    switch (cmd->type) {
    case SP_CMD_ENGAGE:
    case SP_CMD_RUN_TRIG:
    case SP_CMD_MOVE_TO:
    case SP_CMD_STREAM:
    case SP_CMD_FORCE:
    case SP_CMD_GUIDE:
        *dropped = 1;
        return &k_none;
    case SP_CMD_RESET:
        if (ctrl->state == SP_STATE_FAULT || ctrl->state == SP_STATE_ESTOP) {
            return cmd;
        }
        if (ctrl->state == SP_STATE_IDLE || ctrl->state == SP_STATE_READY) {
            ctrl->faults &= ~(uint32_t)SP_FAULT_OPERATOR_SILENT;
        } else {
            *dropped = 1;
        }
        return &k_none;
    default:
        return cmd;
    }
}

const sp_ctrl_cmd_t *sp_ctrl_operator_link(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in,
                                           int *dropped)
{
    sp_operator_link_t *link;
    int drop = 0;
    const sp_ctrl_cmd_t *cmd;
    if (dropped != NULL) {
        *dropped = 0;
    }
    if (cfg == NULL || ctrl == NULL || in == NULL || dropped == NULL) {
        return &k_none;
    }
    link = &ctrl->link;
    cmd = &in->cmd;
    if (in->operator_heartbeat) {
        link->armed = 1u;
        link->silent = 0u;
    } else if (link->silent < UINT32_MAX) {
        ++link->silent;
    }
    if (!link->armed || cfg->operator_timeout_ticks == 0u) {
        return cmd;
    }
    if ((ctrl->faults & SP_FAULT_OPERATOR_SILENT) == 0u) {
        int forcing = ctrl->force.mode == SP_FORCE_FORCE || ctrl->force.mode == SP_FORCE_GUIDE;
        if ((ctrl->state != SP_STATE_RUNNING && !forcing) || link->silent < cfg->operator_timeout_ticks) {
            return cmd;
        }
        ctrl->faults |= SP_FAULT_OPERATOR_SILENT;
        if (cmd->type == SP_CMD_ESTOP) {
            return cmd;
        }
        *dropped = (cmd->type != SP_CMD_NONE) ? 1 : 0;
        if (forcing) {
            return &k_position; /* force control first lets go, back onto the position reference */
        }
        return cfg->operator_park ? &k_park : &k_stop;
    }
    cmd = latched(ctrl, cmd, &drop);
    *dropped = drop;
    return cmd;
}
