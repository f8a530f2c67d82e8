/* SPDX-License-Identifier: Apache-2.0 */
/*
 * control_internal.h - the controller's jobs kept in their own files
 * (estop.c: ESTOP's reaction), called by the tick in controller.c.
 */
#ifndef SP_CONTROL_INTERNAL_H
#define SP_CONTROL_INTERNAL_H

#include "sp/control/controller.h"

/* ESTOP taken this tick (estop.c). `active`: the drives followed
 * setpoints at the start of the tick; comms_ok: every drive heard. A
 * controlled stop (STOPPING) when the config asks for category 1, the
 * drives follow setpoints, every drive is heard and reports no fault, the
 * estimate is valid and a stop within the limits exists; otherwise the
 * immediate stop (ESTOP), its cause recorded. A second ESTOP during the
 * stop makes it immediate; one in ESTOP changes nothing. */
void spi_estop_take(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, int active, int comms_ok);

/* A fault latched during the controlled stop: immediate (ESTOP), with the
 * cause of the fault bit. */
void spi_estop_fault(sp_ctrl_t *ctrl, uint32_t fault);

/* STOPPING's reference of this tick into *ref (the stop's sample, then at
 * rest at its end for estop.settle_ticks); returns 1 on the tick the
 * stop ends in ESTOP (the drives hold from then), else 0. */
int spi_estop_reference(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, sp_motion_t *ref);

/* No ESTOP reaction: init and RESET. */
void spi_estop_clear(sp_ctrl_t *ctrl);

/* The estop config's check for sp_ctrl_init: SP_OK or SP_E_ARG. */
sp_status_t spi_estop_config_check(const sp_estop_config_t *cfg);

/* The accelerations each axis may command at most (ctrl->prep.acc_cap),
 * from the inverse dynamics at home (cmd_check.c): made by sp_ctrl_init. */
void spi_cmd_prepare(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg);

/* An operator command's parameters, checked before it is taken (READY,
 * position control: RUN_TRIG and MOVE_TO; other commands and states are
 * the state machine's): SP_REFUSE_NONE, or why it is refused. */
uint8_t spi_cmd_check(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_ctrl_cmd_t *cmd);

/* A move from `from` to `to` planned into ctrl->move (sp_move_plan) with
 * the speed limits of cfg->move lowered where the axes' peak speeds
 * together could drive a leg beyond rate_max (less 1/64): the move takes
 * longer, never faster (cmd_check.c). Errors as sp_move_plan's. */
sp_status_t spi_move_plan_legs(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_pose_t *from,
                               const sp_pose_t *to);

/* STREAM: this tick's limits for sp_stream_step into ctrl->stream_lim, cfg->move's with each
 * axis's speed limit lowered to its velocity now plus its share of the
 * legs' rate budget left, so that the six axes together never drive a
 * leg beyond rate_max (less 1/64) (cmd_check.c). */
void spi_stream_limits(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl);

/* ctrl->rate_weight and ctrl->rate_grow for the active frames (after
 * spi_cmd_prepare, whenever the frames change). */
void spi_rate_prepare(sp_ctrl_t *ctrl);

/* The tool pose of the position reference's pose (frames not identity):
 * ctrl->ready_tool when it is kept for that pose, else
 * sp_frames_from_platform's (not kept: ctrl is const). Errors as there. */
sp_status_t spi_ready_tool_pose(const sp_ctrl_t *ctrl, sp_pose_t *tool_pose);

#endif /* SP_CONTROL_INTERNAL_H */
