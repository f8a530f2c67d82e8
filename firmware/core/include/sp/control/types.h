/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/control/types.h - the controller's words that the links carry: the
 * operator's commands and the drives' mode. The CAN protocol
 * (sp/link/protocol.h) encodes them without the controller's header
 * (sp/control/controller.h), which includes this one.
 */
#ifndef SP_TYPES_H
#define SP_TYPES_H

/** Operator commands (one per tick; SP_CMD_NONE when none arrived). */
typedef enum {
    SP_CMD_NONE = 0,
    SP_CMD_ENGAGE = 1,
    SP_CMD_RUN_TRIG = 2, /**< the paper's trigonometric motion about home */
    SP_CMD_MOVE_TO = 3,  /**< point-to-point move to cmd.target */
    SP_CMD_STREAM = 4,   /**< follow streamed target poses */
    SP_CMD_STOP = 5,
    SP_CMD_PARK = 6,
    SP_CMD_ESTOP = 7,
    SP_CMD_RESET = 8,
    SP_CMD_FORCE = 10,        /**< enter force control (force_mask, force_target), or update its target */
    SP_CMD_GUIDE = 11,        /**< enter hand guiding (force_mask) */
    SP_CMD_POSITION = 12,     /**< leave force control smoothly (back onto the position reference) */
    SP_CMD_TARE = 13,         /**< zero the wrench source's bias: the force/torque sensor's, or the cylinders'
                               estimate's at rest (READY, position control) */
    SP_CMD_FORCE_PARAMS = 14, /**< the admittance's parameters for force_mask (force_params_*): only in position
                                  control (not on OP_COMMAND: the node makes it from OP_FORCE_PARAMS) */
    SP_CMD_FRAME = 15         /**< select or set a tool or work frame slot (frame_*): only at rest (IDLE or READY,
                                   force control off; not on OP_COMMAND: the node makes it from OP_FRAME) */
} sp_cmd_type_t;

/** Drive modes sent with the setpoints (in the spirit of CiA 408). */
typedef enum {
    SP_DRIVE_HOLD = 0,  /**< hold the current position; setpoints ignored */
    SP_DRIVE_ACTIVE = 1 /**< follow the setpoints */
} sp_drive_mode_t;

#endif /* SP_TYPES_H */
