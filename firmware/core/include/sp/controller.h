/*
 * sp/controller.h - the controller step, called once per control tick
 * (1 ms): feedback supervision, pose estimation by forward kinematics,
 * the operator state machine, reference generation, limit checks, and the
 * setpoints for the six axis drives (length, velocity feed-forward and the
 * paper's force feed-forward).
 *
 * Pure: sp_ctrl_step(config, state, input) -> output. It reads no clock,
 * allocates nothing and never blocks; the port calls it and moves the
 * inputs and outputs between the structs and the CAN bus.
 *
 * States (what an operator of a motion base expects):
 *   IDLE      parked; drives hold. ENGAGE starts the engage move.
 *   ENGAGING  smooth move from the estimated (parked) pose to home.
 *   READY     engaged at home, holding; accepts RUN_TRIG, MOVE_TO, STREAM, PARK.
 *   RUNNING   a motion is executing; STOP ends it smoothly (back to READY),
 *             PARK ends it and then parks.
 *   PARKING   smooth move to the park pose, then IDLE.
 *   FAULT     latched fault; the reaction is HOLD (setpoints frozen where
 *             the platform is told to be, at rest) or, when feedback and
 *             drives are trustworthy, a controlled PARK. RESET clears the
 *             faults once their causes are gone and re-engages to home.
 *   ESTOP     emergency stop: drives commanded to HOLD at once; latched until
 *             RESET.
 */
#ifndef SP_CONTROLLER_H
#define SP_CONTROLLER_H

#include "sp/dynamics.h"
#include "sp/kinematics.h"
#include "sp/trajectory.h"

typedef enum {
    SP_STATE_IDLE = 0,
    SP_STATE_ENGAGING = 1,
    SP_STATE_READY = 2,
    SP_STATE_RUNNING = 3,
    SP_STATE_PARKING = 4,
    SP_STATE_FAULT = 5,
    SP_STATE_ESTOP = 6
} sp_state_t;

/* Latched fault bits (sp_ctrl_t.faults). */
#define SP_FAULT_FEEDBACK_TIMEOUT 0x0001u /**< a drive went silent */
#define SP_FAULT_DRIVE 0x0002u            /**< a drive reported a fault */
#define SP_FAULT_FK 0x0004u               /**< forward kinematics failed */
#define SP_FAULT_DIVERGENCE 0x0008u       /**< commanded and estimated pose diverged */
#define SP_FAULT_REFERENCE 0x0010u        /**< the reference left the limits */
#define SP_FAULT_COMPUTE 0x0020u          /**< IK or inverse dynamics failed */
#define SP_FAULT_ESTOP 0x0040u            /**< emergency stop commanded */
#define SP_FAULT_LEG_LIMIT 0x0080u        /**< a measured leg is outside its stroke */

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
    SP_CMD_RESET = 8
} sp_cmd_type_t;

typedef struct {
    sp_cmd_type_t type;
    sp_axis_t axis;      /**< RUN_TRIG: axis */
    sp_q24_t amplitude;  /**< RUN_TRIG: m or rad, Q24 */
    sp_q24_t frequency;  /**< RUN_TRIG: Hz, Q24 */
    uint32_t fade_ticks; /**< RUN_TRIG: fade-in/out, ticks (0: the config's fade_ticks) */
    sp_pose_t target;    /**< MOVE_TO: absolute pose */
} sp_ctrl_cmd_t;

/** Drive modes sent with the setpoints (in the spirit of CiA 408). */
typedef enum {
    SP_DRIVE_HOLD = 0,  /**< hold the current position; setpoints ignored */
    SP_DRIVE_ACTIVE = 1 /**< follow the setpoints */
} sp_drive_mode_t;

/** Feedback of one axis drive for this tick. */
typedef struct {
    uint8_t fresh;   /**< 1 if a valid frame arrived since the last tick */
    sp_q24_t length; /**< measured joint-to-joint length, m, Q24 */
    sp_q8_t force;   /**< measured cylinder force, N, Q8 */
    uint16_t faults; /**< the drive's fault bits (0: none) */
} sp_drive_feedback_t;

typedef struct {
    sp_drive_feedback_t drive[SP_LEGS];
    sp_ctrl_cmd_t cmd;
    uint8_t stream_fresh;    /**< 1 if a streamed target arrived */
    sp_pose_t stream_target; /**< RUNNING in STREAM: taken when reachable (in the workspace, every leg inside
                                  its stroke less the margin), else refused (cmd_rejected, the previous target
                                  stays); refused too once STOP or PARK has sent the filter home */
} sp_ctrl_input_t;

typedef struct {
    sp_q24_t length;   /**< length setpoint, m, Q24 */
    sp_q24_t velocity; /**< velocity feed-forward, m/s, Q24 */
    sp_q8_t force;     /**< force feed-forward, N, Q8 */
} sp_setpoint_t;

typedef struct {
    sp_setpoint_t setpoint[SP_LEGS];
    sp_drive_mode_t drive_mode;
    sp_state_t state;
    uint32_t faults;        /**< latched SP_FAULT_* bits */
    uint32_t tick;          /**< ticks since init */
    sp_pose_t estimate;     /**< pose by forward kinematics */
    sp_motion_t reference;  /**< the reference of this tick */
    uint32_t fk_iterations; /**< this tick's Newton steps */
    uint8_t estimate_valid; /**< 1 once FK has a pose */
    uint8_t cmd_rejected;   /**< 1 if this tick's command was refused */
} sp_ctrl_output_t;

/** Tuning of the controller. sp_ctrl_default_config fills it from the platform. */
typedef struct {
    const sp_platform_t *platform;
    uint32_t tick_us;                /**< tick length, us (1000) */
    sp_move_limits_t move;           /**< engage, park and point-to-point limits */
    uint32_t fade_ticks;             /**< fade-in/out of trigonometric motions */
    uint32_t feedback_timeout_ticks; /**< ticks without feedback before the fault (2) */
    sp_q24_t divergence_pos;         /**< m, Q24 */
    sp_q24_t divergence_rot;         /**< rad, Q24 */
    sp_q24_t stroke_margin;          /**< references keep this far from the stroke ends, m, Q24 */
    sp_q24_t stream_omega;           /**< bandwidth of the stream filter, rad/s, Q24 */
    uint8_t force_feedforward;       /**< 1: send the inverse dynamics forces; 0: send 0 */
} sp_ctrl_config_t;

/** Controller state: everything the step remembers between ticks. */
typedef struct {
    sp_state_t state;
    uint32_t faults;
    uint32_t tick;
    uint32_t missed[SP_LEGS];
    uint32_t seen_mask; /**< drives heard from at least once */
    sp_q24_t last_length[SP_LEGS];
    sp_pose_t estimate;
    uint8_t estimate_valid;
    uint8_t mode;            /**< RUNNING: 0 trig, 1 move, 2 stream */
    uint8_t park_after;      /**< RUNNING: park once the motion ends */
    uint8_t stream_stopping; /**< RUNNING stream: settling back to home */
    sp_trig_t trig;
    sp_move_t move;
    sp_motion_t stream;  /**< stream filter output (pose, velocity, acceleration) */
    int64_t stream_x[6]; /**< stream filter position per axis, Q48 */
    int64_t stream_v[6]; /**< stream filter velocity per axis, Q48 */
    sp_pose_t stream_target;
    sp_pose_t stream_anchor;                /**< the last streamed target whose IK was computed (reachable) */
    sp_q24_t stream_anchor_length[SP_LEGS]; /**< its leg lengths, m, Q24 */
    uint8_t stream_anchor_valid;
    uint32_t joint_reach;  /**< max over the platform joints of |a_x| + |a_y| + |a_z|, m, Q24
                                    (set by sp_ctrl_init; UINT32_MAX: too large for the stream bound) */
    sp_q24_t ws_lo[6];     /**< workspace box in absolute pose coordinates (x, y, z, roll, pitch, yaw), */
    sp_q24_t ws_hi[6];     /**< home + workspace_min/max clamped to int32, set by sp_ctrl_init */
    sp_motion_t reference; /**< last accepted reference */
    sp_setpoint_t setpoint[SP_LEGS];
    uint8_t have_setpoint;
    uint8_t fk_cache_valid; /**< fk_cache holds the lengths and sines of `estimate` */
    sp_fk_cache_t fk_cache; /**< the estimate's lengths and sines, for the next tick's FK */
    sp_lu6_t ref_lu;        /**< factorisation of J^T at `reference.pose` (valid flag inside), from the
                                    inverse dynamics: the next tick's FK steps solve with it */
} sp_ctrl_t;

/**
 * Defaults for `platform`: 1 ms tick; engage/park limits 0.25 m/s,
 * 1 m/s^2, 5 m/s^3 (0.25 rad/s, 1 rad/s^2, 5 rad/s^3); 2 s fades; feedback
 * timeout 2 ticks; divergence 25 mm / 25 mrad; 10 mm stroke margin; stream
 * filter 10 rad/s; force feed-forward on. SP_E_ARG on NULL.
 */
sp_status_t sp_ctrl_default_config(sp_ctrl_config_t *cfg, const sp_platform_t *platform);

/** Resets the controller to IDLE with no faults and no estimate. */
sp_status_t sp_ctrl_init(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg);

/**
 * One control tick. Always fills *out (in a fault, with the hold setpoints).
 * Returns SP_OK, or SP_E_ARG for NULL pointers / a config without platform;
 * every other problem is a latched fault reported in out->faults, never a
 * return value the port could ignore.
 */
sp_status_t sp_ctrl_step(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in,
                         sp_ctrl_output_t *out);

/** Short constant name of a state ("idle", "engaging", ...). */
const char *sp_state_name(sp_state_t state);

#endif /* SP_CONTROLLER_H */
