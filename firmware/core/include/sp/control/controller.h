/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/control/controller.h - the controller step, called once per control tick
 * (1 ms): feedback supervision, pose estimation by forward kinematics,
 * the operator state machine, reference generation, limit checks, and the
 * setpoints for the six axis drives (length, velocity feed-forward and the
 * paper's force feed-forward).
 *
 * Pure: sp_ctrl_step(config, state, input) -> output. It reads no clock,
 * allocates nothing and never blocks; the port calls it and moves the
 * inputs and outputs between the structs and the CAN bus.
 *
 * The tick, in order (controller.c), each job with its own state in
 * sp_ctrl_t and its own module:
 *   1. supervise   the drives' feedback: timeouts, drive faults, legs
 *                  outside their stroke (sp_supervision_t);
 *   2. estimate    the pose by forward kinematics (sp/estimation/estimate.h);
 *   3. command     the operator's command and streamed target: the state
 *                  machine below, the motion generators (sp/motion/trajectory.h,
 *                  sp/motion/stream.h);
 *   4. reference   this tick's reference motion, by state;
 *      force       in READY and RUNNING with force control on, the offset of
 *                  sp/force/force.h added to the position reference (the wrench
 *                  from the cylinders' estimate or a force/torque sensor);
 *   5. setpoints   the drives' setpoints of the reference with every limit
 *                  checked (sp/motion/setpoint.h, sp/motion/limits.h); a reference
 *                  outside the limits is never passed on;
 *   6. wrench      the external wrench estimate from the measured cylinder
 *                  forces and the model's (sp/estimation/wrench.h);
 *   7. divergence  of the estimate from the reference;
 *   8. output.
 * The leg masses' terms (the force feed-forward's heaviest part) are
 * refreshed for SP_LEGS / SP_CTRL_LEG_GROUPS legs a tick, in turn
 * (sp_setpoints_held), the other legs' reactions, moments and axial terms
 * kept from the tick that last refreshed them; the rest of the inverse
 * dynamics and the leg rates are always this tick's. The forces' solve
 * factorises J^T once every SP_CTRL_LU_KEEP ticks, in three parts on
 * three ticks (hold.lu_staged): the first refines its forces with the old
 * factorisation and begins the new one of its own J^T, the second takes
 * its middle step, the third finishes it and refines with it, two ticks
 * old; the ticks between refine the last tick's forces with it too (sp_inverse_dynamics_held,
 * hold.lu_keep; docs/explanation/model.md, "The factorisation kept over ticks"), and
 * the estimate's chord step uses it too.
 * The three ticks that factorise refresh no leg (the factorisation and a
 * leg's terms are the two heaviest jobs of the feed-forward: never on the
 * same tick), so a turn is SP_CTRL_LU_KEEP = SP_CTRL_LEG_GROUPS + 3
 * ticks. A kept term is at most SP_CTRL_LU_KEEP - 1 ticks old (docs/explanation/model.md,
 * "Leg masses kept over ticks"). A tick with an operator command (its
 * check and plan) refreshes no leg and takes no step of the factorisation,
 * once a turn at most (sp_leg_hold_t.lu_wait): a command's cost never
 * meets the turn's heaviest work; that turn is a tick longer. A reference
 * repeated at rest is computed until every leg's terms are its own, then
 * factorised on the next tick (refreshing none), and only then reused. The default
 * is six groups (one leg a tick): the M4 tick is about 1,840 instructions
 * shorter than with one group (every leg every tick, nothing kept), and
 * the demo's figures stay within their bounds (docs/explanation/m4.md, "Why the leg
 * terms are kept").
 * Values derived once from the config (the limits in absolute coordinates,
 * the stream filter's gains) are prepared by sp_ctrl_init
 * (sp_ctrl_prepared_t), apart from the tick's state.
 *
 * States (what an operator of a motion base expects):
 *   IDLE      parked; drives hold. ENGAGE starts the engage move.
 *   ENGAGING  smooth move from the estimated (parked) pose to home (from
 *             the workspace's bound on an axis where the estimate lies
 *             outside it by at most 0.5 mm / 0.5 mrad: a platform parked
 *             on the boundary that sags under its load; farther out the
 *             move's first reference leaves the limits, SP_FAULT_REFERENCE).
 *   READY     engaged at home, holding; accepts RUN_TRIG, MOVE_TO, STREAM, PARK.
 *   RUNNING   a motion is executing; STOP ends it smoothly (back to READY),
 *             PARK ends it and then parks.
 *   PARKING   smooth move to the park pose, then IDLE.
 *   FAULT     latched fault; the reaction is HOLD (setpoints frozen where
 *             the platform is told to be, at rest) or, when feedback and
 *             drives are trustworthy, a controlled PARK. RESET clears the
 *             faults once their causes are gone and re-engages to home.
 *             When a drive reports faults, RESET first asks the drives to
 *             clear theirs (out->drive_fault_reset for one tick: the
 *             setpoints' FaultReset edge) and waits up to
 *             drive_reset_ticks for every drive to report none; then it
 *             clears and re-engages as above. A drive whose cause remains
 *             keeps its faults: the reset is refused, the controller stays
 *             in FAULT and reports the refusing legs and their fault bits
 *             (out->reset_refused_legs, reset_refused_cause) until the next
 *             RESET. ESTOP cancels a reset under way.
 *   STOPPING  ESTOP taken, its controlled stop (IEC 60204-1 category 1,
 *             control/estop.c, sp/motion/stop.h) under way: the drives
 *             ACTIVE decelerate along the path within cfg->estop's limits,
 *             settle at rest for estop.settle_ticks, then ESTOP. RESET is
 *             refused; a second ESTOP or any fault makes it immediate.
 *   ESTOP     emergency stop: drives commanded to HOLD; latched until RESET.
 *             Reached after STOPPING, or at once (category 0) when the
 *             config asks, the drives were holding, a drive is silent or
 *             faulted, or there is no estimate (out->stop_reaction,
 *             stop_cause; docs/reference/safety.md).
 * Commands are checked before they are taken (control/cmd_check.c,
 * docs/reference/commands.md): a refusal reports its reason in
 * out->refuse_reason.
 * Load holding: from the tick the state is ESTOP, and in FAULT once the
 * drives have held for SP_CTRL_FAULT_BLOCK_TICKS (every fault but the park
 * reaction under way), out->drive_block is 1: the drives put their servo
 * valves at null and close their blocking (load-holding) valves (the
 * setpoints' Block), so the legs hold the load by those valves even if a
 * servo valve leaks or sticks or the supply pressure drops. It returns to
 * 0 only when the drives are told to move again: the re-engage of a RESET
 * (ENGAGING). IDLE before the first ENGAGE keeps the valves
 * open (drives holding by their position loops), as a parked platform
 * that has not failed.
 *
 * Operator link (operator_link.c, sp_ctrl_operator_link): once an operator
 * heartbeat (OP_HEARTBEAT) has been heard, an operator silent for
 * operator_timeout_ticks while RUNNING latches SP_FAULT_OPERATOR_SILENT and
 * ends the motion as STOP (or PARK, operator_park) would; ESTOP and STOP are
 * always accepted.
 */
#ifndef SP_CONTROLLER_H
#define SP_CONTROLLER_H

#include "sp/model/dynamics.h"
#include "sp/model/frames.h"
#include "sp/estimation/estimate.h"
#include "sp/motion/limits.h"
#include "sp/motion/setpoint.h"
#include "sp/motion/stream.h"
#include "sp/motion/stop.h"
#include "sp/motion/trajectory.h"
#include "sp/force/force.h"
#include "sp/estimation/friction.h"
#include "sp/estimation/ftsensor.h"
#include "sp/estimation/motion_error.h"
#include "sp/estimation/wrench.h"
#include "sp/control/types.h"

typedef enum {
    SP_STATE_IDLE = 0,
    SP_STATE_ENGAGING = 1,
    SP_STATE_READY = 2,
    SP_STATE_RUNNING = 3,
    SP_STATE_PARKING = 4,
    SP_STATE_FAULT = 5,
    SP_STATE_ESTOP = 6,
    SP_STATE_STOPPING = 7 /**< ESTOP taken, its controlled stop (category 1) under way; then ESTOP */
} sp_state_t;

/** The reaction to the last ESTOP (sp_ctrl_output_t.stop_reaction;
 *  docs/reference/safety.md). */
#define SP_STOP_NONE 0u       /**< no ESTOP since init or the last RESET */
#define SP_STOP_CONTROLLED 1u /**< category 1: decelerated along the path by the drives, then blocked */
#define SP_STOP_IMMEDIATE 2u  /**< category 0: the drives hold and the blocking valves close at once */

/** Why a command was refused: the one list of refusal reasons
 *  (sp_ctrl_output_t.refuse_reason, sp_ctrl_t.refusals and last_refusal;
 *  docs/reference/commands.md). On the bus as CTRL_REFUSAL Reason and
 *  CTRL_FRAMES LastRefusal, whose value tables in protocol/stewart.dbc are
 *  this list (tests/python/test_refusal_reasons.py holds them equal). */
#define SP_REFUSE_NONE 0u /**< not refused */
#define SP_REFUSE_STATE                                                                                                \
    1u                          /**< not in this state or condition (the state machine above; a missing estimate,
                                wrench, heard drive, tare; a force-control mode; a frame change outside rest) */
#define SP_REFUSE_RANGE 2u      /**< a parameter outside its range (axis, amplitude, frequency, fade time) */
#define SP_REFUSE_REACH 3u      /**< a target, an end or a point of the path outside the workspace or the strokes */
#define SP_REFUSE_RATE 4u       /**< the motion's peak speed would drive a leg beyond leg_velocity_max */
#define SP_REFUSE_FORCE 5u      /**< its peak acceleration would need more than the cylinders' force budget */
#define SP_REFUSE_LINK 6u       /**< dropped by the operator link (a silent operator's fault latched) */
#define SP_REFUSE_EMPTY_SLOT 7u /**< a frame select of an undefined slot, or an index beyond the slots */
#define SP_REFUSE_BAD_FRAME 8u  /**< a frame outside sp_frames_prepare's bounds (tool point beyond 5 m, ...) */
#define SP_REFUSE_NOT_FINITE 9u /**< a reach query or frame with a value that is not a finite number (the node) */
#define SP_REFUSE_COUNT 10u     /**< the number of values, NONE included */

/** Why the last ESTOP was (or became) a category-0 stop (stop_cause). */
#define SP_STOP_CAUSE_NONE 0u     /**< none: a controlled stop, or no ESTOP */
#define SP_STOP_CAUSE_CONFIG 1u   /**< the config asks for category 0 (estop.category 0) */
#define SP_STOP_CAUSE_HOLDING 2u  /**< the drives were not following setpoints (IDLE, a holding FAULT) */
#define SP_STOP_CAUSE_ESTIMATE 3u /**< no pose estimate, or the forward kinematics failed during the stop */
#define SP_STOP_CAUSE_COMMS 4u    /**< a drive not heard (feedback timeout), at the ESTOP or during the stop */
#define SP_STOP_CAUSE_DRIVE 5u    /**< a drive reported a fault, at the ESTOP or during the stop */
#define SP_STOP_CAUSE_SECOND 6u   /**< a second ESTOP during the controlled stop */
#define SP_STOP_CAUSE_FAULT 7u    /**< another fault during the stop (reference, divergence, leg limit, ...) */
#define SP_STOP_CAUSE_PLAN 8u     /**< no stop within the limits and 10 s, or its end out of reach */

/* Latched fault bits (sp_ctrl_t.faults). */
#define SP_FAULT_FEEDBACK_TIMEOUT 0x0001u /**< a drive went silent */
#define SP_FAULT_DRIVE 0x0002u            /**< a drive reported a fault */
#define SP_FAULT_FK 0x0004u               /**< forward kinematics failed */
#define SP_FAULT_DIVERGENCE 0x0008u       /**< commanded and estimated pose diverged */
#define SP_FAULT_REFERENCE 0x0010u        /**< the reference left the limits */
#define SP_FAULT_COMPUTE 0x0020u          /**< IK or inverse dynamics failed */
#define SP_FAULT_ESTOP 0x0040u            /**< emergency stop commanded */
#define SP_FAULT_LEG_LIMIT 0x0080u        /**< a measured leg is outside its stroke */
#define SP_FAULT_OPERATOR_SILENT 0x0100u  /**< no operator heartbeat while RUNNING or in force control */
#define SP_FAULT_CONTACT_LOST 0x0200u     /**< force control: the contact fell away while a push was commanded */
#define SP_FAULT_EXCESS_FORCE 0x0400u     /**< force control: the wrench exceeded its limit (retracted first) */
#define SP_FAULT_FT_SENSOR 0x0800u        /**< force control on the force/torque sensor: the sensor went silent */

typedef struct {
    sp_cmd_type_t type;
    sp_axis_t axis;                 /**< RUN_TRIG: axis */
    sp_q24_t amplitude;             /**< RUN_TRIG: m or rad, Q24 */
    sp_q24_t frequency;             /**< RUN_TRIG: Hz, Q24 */
    uint32_t fade_ticks;            /**< RUN_TRIG: fade-in/out, ticks (0: the config's fade_ticks) */
    sp_pose_t target;               /**< MOVE_TO: the tool pose to go to (T in W; the platform's pose with the
                                         default identity frames) */
    uint8_t force_mask;             /**< FORCE, GUIDE: the force-controlled axes (bit k: x, y, z, roll, pitch, yaw) */
    sp_q8_t force_target[6];        /**< FORCE: the wrench the platform is to exert on the world, N, N m, base frame,
                                  about o', Q8 */
    uint8_t force_params_mode;      /**< FORCE_PARAMS: the damping set is FORCE's (SP_FORCE_FORCE) or GUIDE's */
    sp_q16_t force_params_mass;     /**< FORCE_PARAMS: virtual mass, kg or kg m^2, Q16 */
    int32_t force_params_damping;   /**< FORCE_PARAMS: free-space damping, N s/m or N m s/rad */
    int32_t force_params_stiffness; /**< FORCE_PARAMS: spring to the position reference, N/m or N m/rad */
    uint8_t frame_op;               /**< FRAME: SP_FRAME_SELECT or SP_FRAME_SET */
    uint8_t frame_kind;             /**< FRAME: SP_FRAME_TOOL or SP_FRAME_WORK */
    uint8_t frame_index;            /**< FRAME: the slot, 0 .. SP_FRAME_SLOTS - 1 */
    sp_pose_t frame_value;          /**< FRAME SET: the slot's new values (tool: T in o', work: W in the base
                                         frame; m, rad, Q24); the slot becomes the active one */
} sp_ctrl_cmd_t;

/** Slots of each kind of frame (tool, work). */
#define SP_FRAME_SLOTS 4u

/** sp_ctrl_cmd_t.frame_op */
#define SP_FRAME_SELECT 0u /**< make slot frame_index the active frame of its kind */
#define SP_FRAME_SET 1u    /**< set slot frame_index to frame_value and make it active */

/** sp_ctrl_cmd_t.frame_kind */
#define SP_FRAME_TOOL 0u
#define SP_FRAME_WORK 1u

/** The named frames of the platform config (config/platform_default.json
 *  "frames"), and which are active at init. Slot 0 of each kind is the
 *  identity unless the config says otherwise. */
typedef struct {
    sp_pose_t tool[SP_FRAME_SLOTS]; /**< T in o' (m, rad, Q24) */
    sp_pose_t work[SP_FRAME_SLOTS]; /**< W in the base frame (m, rad, Q24) */
    uint8_t tool_used;              /**< bit i: tool slot i is defined (a select of another is refused) */
    uint8_t work_used;              /**< bit i: work slot i is defined */
    uint8_t tool_active;            /**< the active tool slot */
    uint8_t work_active;            /**< the active work slot */
} sp_frame_slots_t;

/** The config's frames (config/platform_default.json "frames"), generated
 *  by tools/dev/gen_platform.py: ports copy them into sp_ctrl_config_t.frames. */
extern const sp_frame_slots_t sp_frame_slots_default;

/** The reach check's verdict (sp_ctrl_reach). */
typedef enum {
    SP_REACH_OK = 0,        /**< reachable: a MOVE_TO to it from READY passes the limits */
    SP_REACH_WORKSPACE = 1, /**< the platform's pose leaves the workspace box on axis `which` (0..5: x, y,
                                 z, roll, pitch, yaw) by `excess` (m or rad) */
    SP_REACH_LEG_SHORT = 2, /**< leg `which` (0..5) is shorter than its stroke less the margin by `excess` (m) */
    SP_REACH_LEG_LONG = 3,  /**< leg `which` is longer than its stroke less the margin by `excess` (m) */
    SP_REACH_COMPUTE = 4,   /**< the transform or the IK failed (a pose far out of range) */
    SP_REACH_PATH = 6       /**< the end is reachable but a point of MOVE_TO's straight path from the
                                 last reference is not (READY only; 5 is the protocol's NOT_FINITE) */
} sp_reach_verdict_t;

/** The answer to a reach query (sp_ctrl_reach). */
typedef struct {
    uint8_t verdict;        /**< sp_reach_verdict_t */
    uint8_t which;          /**< the axis or the leg of the first limit broken (0 when reachable) */
    sp_q24_t excess;        /**< by how much, m or rad, Q24, >= 0 (0 when reachable) */
    sp_pose_t platform;     /**< the platform's pose (o' in the base frame) for the tool pose */
    sp_q8_t force[SP_LEGS]; /**< the cylinder forces that hold the platform at rest there, N, Q8 (0 when
                                  the IK failed) */
} sp_reach_t;

/** Feedback of one axis drive for this tick. */
typedef struct {
    uint8_t fresh;   /**< 1 if a valid frame arrived since the last tick */
    sp_q24_t length; /**< measured joint-to-joint length, m, Q24 */
    sp_q8_t force;   /**< measured cylinder force, N, Q8 */
    uint16_t faults; /**< the drive's fault bits (0: none): the DBC's eight, and
                          SP_DRIVE_FAULT_STATE when the drive reports the FAULT state */
    /** 1 (bit 0; the others ignored): the drive measures no cylinder force
     *  (a CiA 402 drive, a CiA 408 drive without pressure feedback): `force`
     *  is no measurement and the cylinders' wrench estimate is invalid;
     *  0 (the native drives): measured */
    uint8_t no_force;
} sp_drive_feedback_t;

/** sp_drive_feedback_t.faults: the drive is in its FAULT state (above the DBC's 8 fault bits). */
#define SP_DRIVE_FAULT_STATE 0x100u

typedef struct {
    sp_drive_feedback_t drive[SP_LEGS];
    sp_ctrl_cmd_t cmd;
    uint8_t stream_fresh;       /**< 1 if a streamed target arrived */
    uint8_t operator_heartbeat; /**< 1 if an operator heartbeat (OP_HEARTBEAT) arrived since the last tick */
    sp_pose_t stream_target;    /**< RUNNING in STREAM: taken when reachable (in the workspace, every leg inside
                                  its stroke less the margin), else refused (cmd_rejected, the previous target
                                  stays); refused too once STOP or PARK has sent the filter home */
    uint8_t ft_fresh;           /**< 1 if a force/torque sensor reading arrived */
    sp_q8_t ft_reading[6];      /**< the sensor's wrench on the tool, its axes, about its origin, N, N m, Q8 */
    uint8_t setpoints_idle;     /**< 1: no setpoint leaves this tick (CANopen drives between SYNCs,
                                     sp_co_master_sync_due 0): the reference advances, but its setpoints
                                     and model are not computed (the last ones are kept); 0 (native
                                     drives, every tick): computed */
} sp_ctrl_input_t;

typedef struct {
    sp_setpoint_t setpoint[SP_LEGS];
    sp_drive_mode_t drive_mode;
    sp_state_t state;
    uint32_t faults;             /**< latched SP_FAULT_* bits */
    uint32_t tick;               /**< ticks since init, modulo 2^32 (sp_ctrl_t.tick) */
    sp_pose_t estimate;          /**< pose by forward kinematics */
    sp_motion_t reference;       /**< the reference of this tick */
    uint32_t fk_iterations;      /**< this tick's FK steps (linear solves, sp_estimate_step): 1 for the single step */
    int32_t wrench[6];           /**< external wrench estimate, as reported (sp_wrench_smooth): force N, moment about o'
                            N m, base frame, Q8 (with frames the node reports it at the tool point:
                            sp_ctrl_wrench_at_tool) */
    uint8_t estimate_valid;      /**< 1 once FK has a pose */
    uint8_t cmd_rejected;        /**< 1 if this tick's command was refused */
    uint8_t wrench_valid;        /**< 1 while the wrench estimate follows the measurements (engaged, every drive heard,
                                    every drive measuring its force: force_unmeasured 0) */
    uint8_t force_mode;          /**< sp_force_mode_t: OFF (position control), FORCE, GUIDE, RELEASE, HOLD */
    uint8_t contact;             /**< 1 while force control is in contact */
    sp_q8_t force_target[6];     /**< the commanded wrench (0 outside FORCE), N, N m, Q8 */
    int32_t force_wrench[6];     /**< the wrench force control uses (the source of the config), force N, moment
                                      about o' N m, base frame, Q8 (at the tool point: sp_ctrl_wrench_at_tool) */
    uint8_t drive_fault_reset;   /**< 1 on the tick RESET asks the drives to clear their faults (the
                                      setpoints' FaultReset), else 0 */
    uint8_t reset_refused_legs;  /**< bit i: leg i's drive refused the last fault reset (0: none refused) */
    uint8_t reset_refused_cause; /**< the fault bits the refusing drives still reported (their cause) */
    uint8_t force_unmeasured;    /**< bit i: leg i's drive measures no cylinder force (sp_drive_feedback_t.no_force):
                                      the wrench estimate is invalid, and FORCE, GUIDE and TARE with the
                                      cylinders as wrench source are refused for this reason */
    uint8_t drive_block;         /**< 1: the drives' servo valves at null, their blocking valves closed
                                      (ESTOP, FAULT holding; the setpoints' Block), else 0 */
    uint8_t stop_reaction;       /**< the last ESTOP's reaction: SP_STOP_NONE, _CONTROLLED, _IMMEDIATE */
    uint8_t stop_cause;          /**< why it is IMMEDIATE: SP_STOP_CAUSE_* (NONE for a controlled stop) */
    uint8_t refuse_reason;       /**< why this tick's command was refused: SP_REFUSE_* (NONE with cmd_rejected 0) */
} sp_ctrl_output_t;

/** ESTOP's reaction (docs/reference/safety.md). */
typedef struct {
    uint8_t category;        /**< 1 (default): the controlled stop of sp/motion/stop.h, then the drives hold
                                  and block; 0: hold and block at once. Else sp_ctrl_init SP_E_ARG */
    sp_stop_limits_t limits; /**< the stop's deceleration and jerk (sp_stop_limits_check) */
    uint32_t settle_ticks;   /**< ticks at rest, the position loops holding, between the stop's end and the
                                  blocking valves (0 .. 1000) */
} sp_estop_config_t;

/** The platform config's `estop` section (generated with sp_platform_default
 *  by tools/dev/gen_platform.py; validated there): the ports copy it into
 *  sp_ctrl_config_t.estop. Its settle time is in ticks of 1 ms. */
extern const sp_estop_config_t sp_estop_default;

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
    uint8_t friction_compensation;   /**< 1: add the cylinders' friction (sp_friction_t) to the force feed-forward */
    sp_q24_t wrench_cutoff_hz; /**< cut-off of each of the wrench filter's sections (sp/estimation/wrench.h), Hz, Q24 */
    sp_q24_t wrench_smooth_hz; /**< cut-off of the reported estimate's smoother (sp_wrench_smooth), Hz, Q24 */
    int32_t wrench_jump[2];    /**< the smoother's jump thresholds, force N and moment N m, Q8, > 0 */
    uint8_t wrench_jump_persist;     /**< ticks beyond a threshold that make a jump, >= 1 */
    uint8_t wrench_jump_hold;        /**< ticks the reported estimate then follows the filter's, >= 1 */
    uint8_t friction_observer;       /**< 1: the wrench estimate takes the seals' friction from the friction
                                          observer (sp/estimation/friction.h); 0: from the feed-forward's model */
    sp_force_config_t force;         /**< force control (sp/force/force.h); its filter gain and tick are the wrench
                                          filter's and the controller's (set by sp_ctrl_init) */
    uint8_t wrench_source;           /**< force control's wrench: SP_WRENCH_CYLINDERS or SP_WRENCH_SENSOR */
    sp_ft_mount_t ft_mount;          /**< the force/torque sensor's mounting (sp/estimation/ftsensor.h) */
    uint32_t ft_timeout_ticks;       /**< ticks without a sensor reading before it counts as silent */
    uint32_t ft_tare_samples;        /**< readings a tare averages */
    uint32_t operator_timeout_ticks; /**< ticks without an operator heartbeat while RUNNING before
                                          SP_FAULT_OPERATOR_SILENT (200); 0: no supervision */
    uint8_t operator_park;           /**< the silent operator's reaction: 0 STOP (back to READY), 1 PARK */
    uint32_t drive_reset_ticks;      /**< ticks RESET waits for the drives to clear their faults after the
                                          fault-reset edge before reporting the reset refused (20) */
    uint32_t feedback_divider;       /**< ticks between the drives' feedback: 1 (or 0) every tick (native);
                                          CANopen drives answer each SYNC, every sync_divider ticks. Above 1
                                          the cylinders' wrench estimate, its friction observer and motion
                                          correction step only on ticks with fresh feedback, their filters
                                          made for that period (the smoother's persist and hold counts
                                          divided by it, rounded up, its jump thresholds multiplied by its
                                          square root: one sample a period leaves about that much more
                                          noise); 1..255, else sp_ctrl_init SP_E_ARG */
    sp_frame_slots_t frames;         /**< the named tool and work frames and the active ones at init (default:
                                          slot 0 of each, identity, the only one defined) */
    sp_estop_config_t estop;         /**< ESTOP's stop category and its limits */
} sp_ctrl_config_t;

/** Force control's source of the external wrench. */
#define SP_WRENCH_CYLINDERS 0u /**< the estimate from the cylinders' pressures (sp/estimation/wrench.h) */
#define SP_WRENCH_SENSOR 1u /**< a six-axis force/torque sensor between platform and tool (sp/estimation/ftsensor.h) */

/** What RUNNING is executing. */
typedef enum {
    SP_MODE_TRIG = 0,  /**< the paper's trigonometric motion (RUN_TRIG), sp_ctrl_t.trig */
    SP_MODE_MOVE = 1,  /**< a point-to-point move (MOVE_TO), sp_ctrl_t.move */
    SP_MODE_STREAM = 2 /**< the stream filter (STREAM), sp_ctrl_t.stream */
} sp_motion_mode_t;

/** Values derived from the config by sp_ctrl_init, constant until the next
 *  init (call sp_ctrl_init again after changing the config). */
typedef struct {
    sp_limits_t limits;               /**< workspace box, stroke, rate and force limits, joint reach */
    sp_stream_gains_t stream;         /**< the stream filter's dt and gains */
    sp_friction_t friction;           /**< the cylinders' friction model */
    sp_q30_t wrench_alpha;            /**< the wrench filter's gain (sp_wrench_alpha) at the tick: the sensor's
                                           path and the admittance */
    sp_q30_t cyl_alpha;               /**< the cylinders' estimate's filter gain at the feedback period
                                           (wrench_alpha when feedback_divider is 1) */
    uint32_t feedback_us;             /**< the feedback period, us: tick_us * feedback_divider */
    sp_wrench_smooth_t wrench_smooth; /**< the reported estimate's smoother (sp_wrench_smooth) */
    uint8_t fric_obs_ok;              /**< 1: the platform's friction passed sp_fric_obs_check */
    sp_me_m6_t motion_body;           /**< the rigid body with the legs' inertia at home, for the wrench's
                                   motion correction (sp_motion_error_body, then sp_motion_error_m6; the
                                   rigid body alone when the legs are outside its envelope) */
    sp_force_config_t force;          /**< cfg->force with the wrench filter's gain and the tick */
    sp_q24_t arm_max;                 /**< the platform joints' largest distance from o', m, Q24 */
    sp_q24_t acc_cap[6];              /**< per axis, the largest acceleration a command may reach: its
                                           inverse-dynamics forces at home within half force_max (the other
                                           half for gravity, poses away from home, the other terms), at most
                                           64 m/s^2; m/s^2 or rad/s^2, Q24 (0: no motion) */
} sp_ctrl_prepared_t;

/** Ticks over which every leg's leg-mass terms are refreshed once
 *  ("The leg masses' terms" above; divides SP_LEGS): each tick refreshes
 *  SP_LEGS / SP_CTRL_LEG_GROUPS legs, in turn. 1: every leg every tick,
 *  the plain computation (sp_setpoints_of) that the tests compare with. */
#define SP_CTRL_LEG_GROUPS 6u

/** Ticks over which one factorisation of J^T serves the forces' solve
 *  (sp_leg_hold_t.lu_keep; "The forces' solve" above): the ticks between
 *  refine the last forces with it, and the estimate's chord step uses it.
 *  1: a fresh factorisation every tick (the plain computation). Above
 *  SP_CTRL_LEG_GROUPS (> 1), the tick that factorises refreshes no leg
 *  (motion_setpoints): SP_CTRL_LEG_GROUPS + 1 gives each of the turn's
 *  other ticks one group. Above that, the factorisation is staged over two
 *  ticks, neither refreshing a leg (sp_leg_hold_t.lu_staged 2):
 *  SP_CTRL_LEG_GROUPS + 2 gives each of the other ticks one group; from
 *  SP_CTRL_LEG_GROUPS + 3 (the default) over three (lu_staged 3: pivot
 *  step 0, step 1, the other four), so that no tick of the factorisation
 *  costs more than a leg's terms (Cortex-M4, -Os: the stream scenario's
 *  highest tick 10,085 -> 9,988 instructions, CHANGELOG.md); the forces
 *  of a kept leg are then up to 8 ticks old and the factorisation up to
 *  9 (docs/explanation/model.md). */
#define SP_CTRL_LU_KEEP 9u

/** Ticks a FAULT holds by the drives' position loops before the blocking
 *  valves close (out->drive_block): the loops first bring a moving
 *  platform to rest (closed at once, the platform rings on its oil columns
 *  with little damping: 8.5 mm, still 1.7 mm a second later, after a fault
 *  in the surge). ESTOP closes them at once. */
#define SP_CTRL_FAULT_BLOCK_TICKS 500u

/** sp_supervision_t.seen_mask once every drive has been heard from. */
#define SP_ALL_LEGS ((UINT32_C(1) << SP_LEGS) - 1u)

/** Feedback supervision: what the step remembers of the drives' frames. */
typedef struct {
    uint32_t missed[SP_LEGS];      /**< ticks since leg i's last fresh frame (saturates) */
    uint32_t seen_mask;            /**< drives heard from at least once (bit i: leg i) */
    sp_q24_t last_length[SP_LEGS]; /**< the last measured lengths, m, Q24 */
    sp_q8_t last_force[SP_LEGS];   /**< the last measured cylinder forces, N, Q8 */
    uint16_t last_faults[SP_LEGS]; /**< the fault bits of each drive's last frame (0: none) */
    uint32_t no_force_mask;        /**< drives whose last frame measured no force (bit i: leg i) */
} sp_supervision_t;

/** A RESET that waits for the drives to clear their faults (the fault
 *  reset over CAN, DBC AXIS_SETPOINTS FaultReset). */
typedef struct {
    uint32_t left;         /**< ticks left to wait (0: no reset under way) */
    uint8_t edge;          /**< 1: this tick's setpoints carry FaultReset */
    uint8_t refused_legs;  /**< the last refused reset's drives (bit i: leg i), 0 when none */
    uint8_t refused_cause; /**< their fault bits then */
} sp_drive_reset_t;

/** Operator link supervision (sp_ctrl_operator_link). */
typedef struct {
    uint32_t silent; /**< ticks since the last operator heartbeat (saturates) */
    uint8_t armed;   /**< 1 once a heartbeat has been heard (until sp_ctrl_init) */
} sp_operator_link_t;

/** ESTOP's controlled stop under way (STOPPING) and the last reaction. */
typedef struct {
    sp_stop_t stop;   /**< the stop (sp/motion/stop.h) */
    uint32_t settle;  /**< ticks at rest left before the blocking valves close */
    uint8_t reaction; /**< SP_STOP_NONE, _CONTROLLED, _IMMEDIATE */
    uint8_t cause;    /**< SP_STOP_CAUSE_* */
} sp_estop_state_t;

/** Controller state: everything the step remembers between ticks. */
typedef struct {
    sp_ctrl_prepared_t prep; /**< derived from the config at init */
    sp_state_t state;
    uint32_t faults; /**< latched SP_FAULT_* bits */
    uint32_t tick;   /**< ticks since init, modulo 2^32: a sequence number (the SYNC tick of a
                          cycle master), compared only for equality, so it wraps after 49.7
                          days like the DBC's Tick signal; saturating would freeze the SYNC
                          tick and with it the feedback's freshness check (TickEcho). A test
                          may start it anywhere after sp_ctrl_init (the wrap tests do) */
    sp_supervision_t sup;
    sp_estimate_t est;               /**< the pose estimate, its FK cache and the factorisation at the reference */
    sp_pose_t est_ref;               /**< the reference (pose) the estimate was last made or moved at: on a tick
                                          without fresh lengths the estimate moves by the reference's change
                                          since (the last measured tracking error is kept) */
    uint8_t est_ref_valid;           /**< 1 when est_ref was a reference (have_setpoint then), else the estimate
                                          stays as it is on such a tick */
    sp_motion_mode_t mode;           /**< RUNNING: the motion executing */
    uint8_t park_after;              /**< RUNNING: park once the motion ends */
    sp_trig_t trig;                  /**< RUN_TRIG's generator */
    sp_move_t move;                  /**< engage, park, MOVE_TO and the fault reaction's park move */
    sp_stream_t stream;              /**< STREAM's filter */
    sp_move_limits_t stream_lim;     /**< STREAM: this tick's limits of the filter (spi_stream_limits; kept here,
                                          not on the tick's stack) */
    sp_motion_t reference;           /**< the last accepted reference (advances on setpoints_idle ticks too) */
    sp_pose_t model_pose;            /**< the reference pose that model, est.ref_lu and the setpoints were made
                                          at: reference.pose but after setpoints_idle ticks */
    uint8_t model_current;           /**< 1: model is of reference (no setpoints_idle tick moved it since) */
    uint8_t setpoints_deferred;      /**< divided feedback: 1 when the last sending tick held, leaving the
                                          first setpoints after a hold to a quiet tick */
    uint8_t busy;                    /**< 1 on a tick that checked an operator command or planned a move:
                                          the model's work that may wait, waits (motion_setpoints) */
    sp_setpoint_t setpoint[SP_LEGS]; /**< the last setpoints sent */
    uint8_t have_setpoint;           /**< 1 once a reference passed every limit */
    uint8_t setpoint_ff;             /**< the feed-forward switches (SP_FF_*) the last setpoints were made with */
    sp_model_t model;                /**< the model forces and Jacobian of the last accepted reference */
    sp_wrench_t wrench;              /**< the external wrench estimate */
    sp_fric_obs_t fric_obs;          /**< the seals' friction observed from the measured lengths */
    sp_motion_error_t motion_error;  /**< the history of estimate - reference (wrench correction) */
    sp_leg_hold_t legs;              /**< the leg masses' terms kept for the legs not refreshed this tick */
    uint8_t legs_exact;              /**< bit i: leg i's kept terms are those of the last accepted reference */
    uint8_t leg_group;               /**< the group of legs whose terms the next tick refreshes */
    sp_orient_keep_t ref_orient;     /**< the last reference IK's angles, sines and T (an angle that repeats
                                          costs no sine) */
    sp_motion_t pos_ref;             /**< the position reference of the last tick (before force control's offset) */
    sp_force_t force;                /**< force control */
    /** the legs' forces per unit wrench on the force-controlled axes
     *  (columns of J^-T, Q24), made one column a tick once contact is made
     *  (the contact's force feed-forward, controller.c) */
    int32_t contact_ff[6][SP_LEGS];
    uint8_t contact_ff_cols;    /**< bit k: column k of contact_ff is this contact's */
    uint8_t park_after_release; /**< PARK during force control: park once released */
    sp_ft_tare_t ft_tare;       /**< the force/torque sensor's bias */
    sp_ft_tare_t cyl_tare;      /**< the cylinders' estimate's bias at rest (TARE on that source) */
    /** the cylinders' estimate less cyl_tare's bias, N, N m, Q8: kept once
     *  cyl_tare.tared and while a tare runs (before, force control reads
     *  wrench.wrench itself: the bias is 0) */
    int32_t cyl_wrench[6];
    int32_t ft_section[SP_WRENCH_SECTIONS][6]; /**< the sensor's wrench through the wrench filter's sections, Q8 */
    uint32_t ft_missed;                        /**< ticks since the last sensor reading (saturates) */
    uint8_t ft_valid;                          /**< 1 while ft_section follows the sensor */
    sp_ft_frame_t ft_frame;                    /**< the sensor's frame at the orientation of ft_frame_sc */
    sp_q30_t ft_frame_sc[6];                   /**< sin, cos of roll, pitch, yaw that ft_frame was made for */
    uint8_t ft_frame_valid;                    /**< 1 once ft_frame was made (0 at init: make it) */
    sp_operator_link_t link;                   /**< the operator's heartbeat supervision */
    sp_drive_reset_t drive_reset;              /**< RESET's fault reset of the drives */
    uint32_t fault_hold_ticks;                 /**< ticks of the current holding FAULT (saturates; 0 otherwise) */
    /** the frames (sp/model/frames.h): commands, streamed targets and force control speak of the tool
     *  frame in the work frame; identity (the default) skips every transform */
    sp_frames_t frames;
    sp_frame_slots_t slots;             /**< the slots (from cfg->frames at init, SET changes one) */
    uint32_t frames_crc;                /**< sp_frames_checksum(&frames), made when they change */
    int64_t rate_weight;                /**< the legs' rate bound's weight on the angle rates: prep.arm_max
                                             plus the tool point's distance from o' (rounded up), m, Q24,
                                             below 2^27; made when the frames change (spi_rate_prepare) */
    sp_recip_t rate_grow;               /**< 6 rate_weight prepared for sp_recip_div: the stream filter's
                                             growth of an angle rate, each STREAM tick without a division */
    sp_motion_t tool_ref;               /**< RUNNING with frames: the motion generator's reference, a tool motion */
    sp_pose_t tool_home;                /**< the tool pose of the platform's home (RUN_TRIG's centre, STREAM's end) */
    sp_pose_t stream_platform;          /**< STREAM with frames: the platform pose of the streamed target in force */
    sp_frames_keep_t ref_keep;          /**< the orientation of the last tool reference's transform (RUNNING,
                                            force control's result), made again when its angles change */
    sp_frames_keep_t target_keep;       /**< the same for the streamed tool targets */
    sp_pose_t ready_platform;           /**< force control at rest with frames: the platform pose ready_tool is of */
    sp_pose_t ready_tool;               /**< its tool pose (sp_frames_from_platform), kept while it holds */
    uint8_t ready_valid;                /**< 1 when ready_tool belongs to ready_platform and the frames */
    uint16_t refusals[SP_REFUSE_COUNT]; /**< refusals by reason (SP_REFUSE_*), saturating */
    uint8_t last_refusal;               /**< the reason of the last refusal (SP_REFUSE_*) */
    uint8_t
        refusing; /**< this tick's refused command's reason where the path that refused it named one (SP_REFUSE_*) */
    sp_estop_state_t estop; /**< ESTOP's controlled stop and its reaction */
    /** the friction observer's Stribeck table (sp_fric_table_prepare),
     *  made at init like prep; last, so that its 2,704 bytes leave the other members
     *  within a load's reach of the struct's start */
    sp_fric_table_t fric_table;
} sp_ctrl_t;

/**
 * Defaults for `platform`: 1 ms tick; engage/park limits 0.25 m/s,
 * 1 m/s^2, 5 m/s^3 (0.25 rad/s, 1 rad/s^2, 5 rad/s^3); 2 s fades; feedback
 * timeout 2 ticks; divergence 25 mm / 25 mrad; 10 mm stroke margin; stream
 * filter 10 rad/s; force feed-forward and friction compensation on; wrench
 * estimate filtered by four sections at 80 Hz (sp/estimation/wrench.h); a silent
 * operator stops the motion after 200 ticks (10 heartbeats of 20 ms);
 * a RESET waits 20 ticks for the drives to clear their faults.
 * SP_E_ARG on NULL.
 */
sp_status_t sp_ctrl_default_config(sp_ctrl_config_t *cfg, const sp_platform_t *platform);

/** Force control's contact threshold on the cylinders' estimate, N, Q8:
 *  the estimate carries about 30 N RMS of noise at rest (pressure sensors,
 *  1 um lengths), so contact counts from 300 N there, not from the
 *  sensor's 100 N (sp_force_default_config), or noise alone makes and
 *  loses it. */
#define SP_CONTACT_MADE_CYLINDERS_Q8 (300 * 256)

/** ... and contact counts as lost below 80 % of the target there (the
 *  sensor's 50 %): the estimate sees a removed surface only as the
 *  platform starts to move (the cylinders' forces change later), so it
 *  falls slower than the sensor's reading; 80 % keeps the detection within
 *  10 ticks. Q30. */
#define SP_CONTACT_LOST_CYLINDERS_Q30 ((sp_q30_t)(((int64_t)4 << 30) / 5))

/** ... and the force loop crosses over at 10 rad/s there (the sensor's
 *  20): the estimate's noise reaches the true force up to the crossover,
 *  so half of it halves the noise's band. Q16. */
#define SP_CROSSOVER_CYLINDERS_Q16 (6 * 65536)

/** ... and contact counts also from 120 N of the push-back through a
 *  64 ms low-pass (2^6 ticks at 1 ms; its peaks at rest and approaching
 *  stay within about 35 N), so a soft surface, whose force rises slowly,
 *  is in contact about 0.1 s after the true 100 N, not 0.75 s (1e5 N/m at
 *  2 mm/s). N, Q8; the shift in ticks. */
#define SP_CONTACT_MADE_SLOW_CYLINDERS_Q8 (120 * 256)
#define SP_CONTACT_SLOW_SHIFT_CYLINDERS 6u

/** ... and the surface's stiffness is bounded from above by the secant
 *  with 60 N of the estimate's noise added to the change of force (its
 *  peaks in free space, unfiltered by the low-pass above), trusted after
 *  10 um: the loop never crosses over above w_c, and on a soft surface
 *  the axis speeds up as soon as it has travelled, not once the force has
 *  risen by 30 N. N, Q8. */
#define SP_SECANT_MARGIN_CYLINDERS_Q8 (60 * 256)

/** ... and beyond 100 N from the target the force error counts four
 *  times (the loop crosses over at about 24 rad/s far from the target, at
 *  6 rad/s near it, where the estimate's noise matters), and the legs'
 *  force setpoints carry the contact wrench's share (force.contact_ff). */
#define SP_BOOST_CYLINDERS 4u
#define SP_BOOST_BAND_CYLINDERS_Q8 (100 * 256)

/** Chooses force control's wrench source (SP_WRENCH_CYLINDERS or
 *  SP_WRENCH_SENSOR), the sensor's mounting (NULL: keep cfg's) and the
 *  contact levels and loop crossover that suit the source
 *  (SP_CONTACT_MADE_CYLINDERS_Q8, SP_CONTACT_LOST_CYLINDERS_Q30,
 *  SP_CROSSOVER_CYLINDERS_Q16 on the cylinders; sp_force_default_config's
 *  on the sensor). For ports that take both from
 *  the platform config (sp_wrench_source_default, sp_ft_mount_default).
 *  SP_E_ARG for a NULL cfg or another source (cfg unchanged). */
sp_status_t sp_ctrl_set_wrench_source(sp_ctrl_config_t *cfg, uint8_t source, const sp_ft_mount_t *mount);

/** Resets the controller to IDLE with no faults and no estimate, and
 *  derives ctrl->prep from cfg. SP_E_ARG on NULL, a config without
 *  platform, negative friction or a wrench cut-off <= 0; SP_E_RANGE for a
 *  cut-off above 8 / (2 pi dt) (1.27 kHz at 1 ms). */
sp_status_t sp_ctrl_init(sp_ctrl_t *ctrl, const sp_ctrl_config_t *cfg);

/**
 * One control tick. Always fills *out (in a fault, with the hold setpoints).
 * Returns SP_OK, or SP_E_ARG for NULL pointers / a config without platform;
 * every other problem is a latched fault reported in out->faults, never a
 * return value the port could ignore.
 */
sp_status_t sp_ctrl_step(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in,
                         sp_ctrl_output_t *out);

/**
 * The operator link's job in the tick (operator_link.c), before the command
 * is carried out: counts the ticks since the last heartbeat
 * (in->operator_heartbeat), and returns the command this tick carries out
 * in place of in->cmd:
 *  - not armed (no heartbeat heard since init) or operator_timeout_ticks
 *    0: in->cmd unchanged;
 *  - RUNNING or in force control (FORCE, GUIDE), silent for
 *    operator_timeout_ticks or more, and SP_FAULT_OPERATOR_SILENT not yet
 *    latched: latches it and returns POSITION in force control (it lets go
 *    first), else STOP (PARK with operator_park), or in->cmd when that is
 *    an ESTOP; any other command of this tick is dropped;
 *  - SP_FAULT_OPERATOR_SILENT latched: ENGAGE, RUN_TRIG, MOVE_TO, STREAM,
 *    FORCE and GUIDE are dropped (refused); RESET in IDLE or READY clears the fault
 *    and nothing else (in FAULT and ESTOP the controller's RESET clears
 *    every fault); in other states RESET is dropped; ESTOP, STOP and PARK
 *    pass.
 * *dropped becomes 1 when in->cmd was dropped (to be reported as refused).
 * Never NULL: on NULL arguments, a command of SP_CMD_NONE (and *dropped 0
 * when dropped is not NULL). Saturating counter; no failure otherwise.
 */
const sp_ctrl_cmd_t *sp_ctrl_operator_link(const sp_ctrl_config_t *cfg, sp_ctrl_t *ctrl, const sp_ctrl_input_t *in,
                                           int *dropped);

/**
 * The reach query ("can it reach?"): the platform pose that puts the tool
 * frame at `tool_pose` (T in W, with the active frames), whether every
 * limit a MOVE_TO to it checks holds there (the workspace box and every
 * leg inside its stroke less the margin: the same check, so a MOVE_TO from
 * READY to a pose judged reachable is never refused for its limits, and
 * one to a pose judged unreachable always is), the first limit broken
 * (workspace axis or leg, and by how much) and the cylinder forces at rest
 * there (the inverse dynamics at zero velocity, no external wrench).
 * Pure: nothing moves, nothing changes. Errors: SP_E_ARG (NULL). A pose
 * that cannot be computed is SP_REACH_COMPUTE, not an error.
 */
sp_status_t sp_ctrl_reach(const sp_ctrl_config_t *cfg, const sp_ctrl_t *ctrl, const sp_pose_t *tool_pose,
                          sp_reach_t *reach);

/**
 * A wrench of this tick's output (out->wrench or out->force_wrench: force
 * N, moment about o' N m, base frame, Q8) at the tool point in W's axes, at
 * the orientation of the tick's reference (the active frames; identity
 * frames: w copied). Computed on demand, not every tick: the node moves the
 * wrench it reports on the ticks it reports it. Call it after the tick's
 * sp_ctrl_step, before the next. w_tool may be w. Errors: SP_E_ARG (NULL),
 * SP_E_OVERFLOW (a component saturated: w_tool is w, unmoved).
 */
sp_status_t sp_ctrl_wrench_at_tool(const sp_ctrl_t *ctrl, const int32_t w[6], int32_t w_tool[6]);

/** Counts a refusal (ctrl->refusals[why], saturating; ctrl->last_refusal):
 *  for the node's own refusals (a non-finite value). `why` is an
 *  SP_REFUSE_* value; ignores NULL, SP_REFUSE_NONE and values from
 *  SP_REFUSE_COUNT on. */
void sp_ctrl_count_refusal(sp_ctrl_t *ctrl, uint8_t why);

/** The tool pose (T in W, active frames) of a platform pose (o' in the
 *  base frame): sp_frames_from_platform. Errors as there. */
sp_status_t sp_ctrl_tool_pose(const sp_ctrl_t *ctrl, const sp_pose_t *platform, sp_pose_t *tool_pose);

/** Short constant name of a state ("idle", "engaging", ...). */
const char *sp_state_name(sp_state_t state);

#endif /* SP_CONTROLLER_H */
