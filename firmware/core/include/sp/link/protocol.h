/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/link/protocol.h - the CAN protocol (protocol/stewart.dbc) in the core's
 * fixed-point units. Bit packing is generated from the DBC at build time by
 * cantools (integer signals only); so are the encoders and decoders below
 * (tools/dev/gen_proto_c.py): the unit conversions and the range checks
 * follow each signal's factor and [min|max] in the DBC, and they add the
 * E2E counter and CRC (sp/link/e2e.h).
 *
 * Encoders: message struct -> sealed frame (counter and CRC filled in).
 * They return SP_OK, or SP_E_RANGE when a value did not fit its signal and
 * was saturated to the signal's limit (the frame is still valid and sent).
 * Decoders: frame -> message struct, checking identifier, length, CRC and
 * every enumerated or bounded signal; SP_E_FRAME with *error saying why.
 * Decoders never touch *msg on error. The alive counter is returned for
 * the caller's per-sender sequence check (sp_e2e_rx_check).
 *
 * Units on the bus: measured leg lengths (AXIS_FEEDBACK) 0.1 um, length
 * setpoints and positions 1 um, angles 1 urad, velocities
 * 5e-5 m/s, forces 0.02 N, pressures 1 kPa, external wrench 0.25 N and
 * 0.25 N m, amplitude 1e-5 m or rad, frequency 1 mHz, times 1 ms.
 * Conversions round to nearest, ties away from zero.
 */
#ifndef SP_PROTOCOL_H
#define SP_PROTOCOL_H

#include "sp/link/auth.h"
#include "sp/link/can.h"
#include "sp/control/types.h"
#include "sp/link/e2e.h"
#include "sp/motion/setpoint.h"

#define SP_ID_SYNC 0x010u
#define SP_ID_AXIS_SETPOINTS 0x020u
#define SP_ID_AXIS_FEEDBACK_1 0x031u /* slots 1..3: 0x031..0x033 */
#define SP_ID_FT_SENSOR 0x038u       /* axis_b: the force/torque sensor */
#define SP_ID_OP_COMMAND 0x040u
#define SP_ID_OP_FORCE 0x048u
#define SP_ID_OP_FORCE_PARAMS 0x049u
#define SP_ID_OP_TARGET_POSE 0x050u
#define SP_ID_OP_HEARTBEAT 0x060u
#define SP_ID_CTRL_STATUS 0x100u
#define SP_ID_CTRL_MONITOR 0x101u
#define SP_ID_CTRL_WRENCH 0x102u
#define SP_ID_CTRL_AUTH 0x103u
#define SP_ID_CTRL_IDENTITY 0x104u
#define SP_ID_OP_FRAME 0x04Au
#define SP_ID_OP_REACH 0x04Bu
#define SP_ID_CTRL_REACH 0x105u
#define SP_ID_CTRL_FRAMES 0x106u
#define SP_ID_CTRL_REFUSAL 0x107u
#define SP_AXIS_SLOTS 3u

/** Why a frame was rejected. */
typedef enum {
    SP_PROTO_OK = 0,
    SP_PROTO_UNKNOWN_ID = 1,
    SP_PROTO_BAD_LENGTH = 2,
    SP_PROTO_BAD_CRC = 3,
    SP_PROTO_OUT_OF_RANGE = 4,
    SP_PROTO_REPEATED = 5,
    SP_PROTO_WRONG_SEQUENCE = 6,
    SP_PROTO_WRONG_BUS = 7,
    SP_PROTO_AUTH_BAD_TAG = 8, /**< an authenticated message whose code does not check (docs/explanation/security.md) */
    SP_PROTO_AUTH_REPLAYED = 9, /**< an authenticated message of this session sent again */
    SP_PROTO_AUTH_NO_KEY = 10,  /**< an authenticated message, and the controller has no key */
    SP_PROTO_ERRORS = 11
} sp_proto_error_t;

/** Short constant name of a rejection reason ("bad-crc", ...). */
const char *sp_proto_error_name(sp_proto_error_t e);

/** Drive states in AXIS_FEEDBACK (CiA 408 spirit). */
typedef enum {
    SP_DRIVE_STATE_INIT = 0,
    SP_DRIVE_STATE_HOLD = 1,
    SP_DRIVE_STATE_ACTIVE = 2,
    SP_DRIVE_STATE_FAULT = 3
} sp_drive_state_t;

typedef struct {
    uint32_t tick;
    uint8_t hold; /**< 1: every drive holds now */
} sp_msg_sync_t;

typedef struct {
    uint32_t tick;
    uint8_t mode;                          /**< sp_drive_mode_t */
    sp_setpoint_t setpoint[SP_AXIS_SLOTS]; /**< slots 1..3 of the bus */
    uint8_t fault_reset;                   /**< FaultReset: 1 asks the drives to clear their faults (on the
                                                rising edge); any non-zero is sent as 1 */
    uint8_t block;                         /**< Block: 1 = valves at null, blocking valves closed (load
                                                holding); any non-zero is sent as 1 */
} sp_msg_setpoints_t;

typedef struct {
    sp_q24_t length;     /**< m, Q24 */
    uint32_t pressure_a; /**< piston side, Pa (1 kPa on the bus, 0..65.535 MPa) */
    uint32_t pressure_b; /**< rod side, Pa (1 kPa on the bus, 0..65.535 MPa) */
    uint8_t state;       /**< sp_drive_state_t */
    uint8_t faults;      /**< drive fault bits */
    uint16_t tick_echo;  /**< low 16 bits of the SYNC tick sampled at */
} sp_msg_feedback_t;

typedef struct {
    uint8_t command;    /**< sp_cmd_type_t, or SET_FEEDFORWARD, IDENTIFY (0..SP_CMD_WIRE_MAX) */
    uint8_t axis;       /**< sp_axis_t */
    sp_q24_t amplitude; /**< m or rad, Q24 */
    sp_q24_t frequency; /**< Hz, Q24 */
    uint32_t fade_ms;   /**< fade time, ms (0: the controller's default) */
    uint8_t option;
} sp_msg_command_t;

#define SP_CMD_SET_FEEDFORWARD 9u
/** OP_COMMAND IDENTIFY: the node answers it with one CTRL_IDENTITY and hands
 *  the controller nothing (its value, 14, is no sp_cmd_type_t on the wire:
 *  SP_CMD_FORCE_PARAMS is the node's own). Needs no authentication. */
#define SP_CMD_IDENTIFY 14u
/** The largest Command value of OP_COMMAND (IDENTIFY, 14; FORCE..TARE are sp_cmd_type_t's 10..13). */
#define SP_CMD_WIRE_MAX 14u

/** OP_FORCE: force control's selection and target (the admittance parameters
 *  are the controller's configured ones). */
typedef struct {
    uint8_t mask;      /**< force-controlled axes, bit k: x, y, z, roll, pitch, yaw (0..63) */
    sp_q8_t target[6]; /**< the wrench the platform is to exert, N, N m, base frame, about o', Q8 */
} sp_msg_force_t;

/** OP_FORCE_PARAMS: the admittance's parameters for the masked axes (the
 *  ranges are the DBC's; sp_proto_decode_force_params rejects others). */
typedef struct {
    uint8_t mask; /**< the axes they are for, bit k: x, y, z, roll, pitch, yaw (1..63) */
    uint8_t mode; /**< which free damping `damping` sets: SP_FORCE_FORCE (1) or SP_FORCE_GUIDE (2) */
    sp_q16_t
        mass; /**< virtual mass, kg or kg m^2, Q16, [SP_PROTO_MASS_MIN_Q16, SP_PROTO_MASS_MAX_Q16] (0.1 kg steps on the bus) */
    int32_t damping;   /**< free-space damping, N s/m or N m s/rad, [100, 1e8] (10 per bit on the bus) */
    int32_t stiffness; /**< spring to the position reference, N/m or N m/rad, [0, 1e7] */
} sp_msg_force_params_t;

#define SP_PROTO_MASS_MIN_Q16 (1 * 65536)    /**< OP_FORCE_PARAMS Mass: 1 kg */
#define SP_PROTO_MASS_MAX_Q16 (5000 * 65536) /**< ... 5000 kg */
#define SP_PROTO_DAMPING_MIN 100             /**< OP_FORCE_PARAMS Damping: 100 N s/m */
#define SP_PROTO_DAMPING_MAX 100000000       /**< ... 1e8 N s/m */
#define SP_PROTO_STIFFNESS_MAX 10000000      /**< OP_FORCE_PARAMS Stiffness: 1e7 N/m */

/** FT_SENSOR: one sample of the force/torque sensor. */
typedef struct {
    sp_q8_t wrench[6]; /**< on the tool, sensor axes, moment about its origin, N, N m, Q8 */
    uint8_t saturated; /**< 1: a component was at the sensor's range */
} sp_msg_ft_t;

/** Largest |component| OP_FORCE and FT_SENSOR carry: 16383.96875 N or N m in Q8
 *  (raw +-(2^19 - 1) at 1/32). */
#define SP_PROTO_FT_MAX_Q8 (INT32_C(524287) * 8)

typedef struct {
    uint32_t tick;
    uint8_t state;
    uint16_t faults;
    uint8_t fk_iterations;
    uint8_t estimate_valid;
    uint8_t cmd_rejected;
    uint8_t drive_mode;
    uint8_t feedforward;
    uint8_t force_mode; /**< sp_force_mode_t, 0..4 */
    uint8_t contact;    /**< 1 while force control is in contact */
    sp_pose_t estimate;
    uint8_t reset_refused_legs;  /**< ResetRefusedLegs: bit i, leg i + 1 refused the last fault reset (6 bits;
                                      higher bits are not sent) */
    uint8_t reset_refused_cause; /**< ResetRefusedCause: the refusing drives' fault bits */
    uint8_t drives_starting;     /**< DrivesStarting: 1 while the CANopen master starts the drives (ENGAGE refused) */
    uint8_t force_unmeasured;    /**< ForceUnmeasured: bit i, leg i + 1's drive measures no cylinder force (6 bits;
                                      higher bits are not sent) */
    uint8_t refusals;            /**< Refusals: commands refused since start, modulo 8 (3 bits; higher bits are
                                      not sent), so that a reader missing the CmdRejected status still sees it */
    uint8_t stop_reaction;       /**< StopReaction: the last ESTOP's reaction, SP_STOP_NONE, _CONTROLLED,
                                      _IMMEDIATE (0..2) */
} sp_msg_status_t;

typedef struct {
    uint32_t tick;
    sp_pose_t reference;
    sp_q24_t length_sp[SP_LEGS];
    sp_q8_t force_ff[SP_LEGS];
} sp_msg_monitor_t;

/** CTRL_WRENCH: the controller's external wrench estimate (sp_ctrl_output_t.wrench). */
typedef struct {
    uint32_t tick;     /**< controller tick of the estimate */
    uint8_t valid;     /**< sp_ctrl_output_t.wrench_valid (any non-zero is sent as 1) */
    int32_t wrench[6]; /**< force x, y, z (N) and moment about o' x, y, z (N m), base frame, Q8 */
} sp_msg_wrench_t;

/** Largest |wrench| component CTRL_WRENCH carries: 524287.75 N or N m in Q8
 *  (raw +-(2^21 - 1) at 0.25). */
#define SP_PROTO_WRENCH_MAX_Q8 (INT32_C(2097151) * 64)
/** CTRL_WRENCH goes out on ticks that are multiples of this (the DBC's 2 ms
 *  cycle: at 1 kHz the ops bus would be at 49.9 %, at its 50 % budget). */
#define SP_PROTO_WRENCH_PERIOD 2u

/** CTRL_AUTH: the controller's command authentication (docs/explanation/security.md). */
typedef struct {
    uint32_t session;      /**< this session's value */
    uint32_t last_counter; /**< the last accepted authentication counter (0: none) */
    uint32_t bad_tag;      /**< frames rejected for their code (sent saturated at 65535) */
    uint32_t replayed;     /**< frames rejected as replays (sent saturated at 65535) */
    uint8_t key_set;       /**< 1: a machine key is configured (any non-zero is sent as 1) */
} sp_msg_auth_t;

/** CTRL_AUTH goes out on ticks that are multiples of this (the DBC's 10 ms cycle). */
#define SP_PROTO_AUTH_PERIOD 10u

/** CTRL_AUTH (ID 0x103, 16 bytes, ops bus, CRC-16). Counts above 65535
 *  are sent as 65535 (saturated, never wrapped; the call returns SP_OK: a
 *  count at its end is still the truth as far as it goes). SP_E_ARG on NULL. */
sp_status_t sp_proto_encode_auth(const sp_msg_auth_t *m, uint8_t counter, sp_can_frame_t *f);

/** CTRL_AUTH -> its values. Rejects (SP_E_FRAME, *error) a wrong identifier
 *  or length and a bad CRC; SP_E_ARG on NULL. */
sp_status_t sp_proto_decode_auth(const sp_can_frame_t *f, sp_msg_auth_t *m, uint8_t *counter, sp_proto_error_t *error);

/** OP_FRAME: select or set a tool or work frame slot (sp_ctrl_cmd_t's frame_*). */
typedef struct {
    uint8_t op;      /**< SP_FRAME_SELECT (0), SP_FRAME_SET (1) or SP_PROTO_FRAME_NONE (2: nothing) */
    uint8_t kind;    /**< SP_FRAME_TOOL (0) or SP_FRAME_WORK (1) */
    uint8_t index;   /**< the slot, 0..15 on the wire (the controller refuses 4 and above) */
    sp_pose_t value; /**< SET: the frame (m, rad, Q24); a component below -SP_PROTO_POSE_MAX_Q24 is the wire's
                          "not a finite number" (SP_PROTO_NOT_FINITE_Q24) */
} sp_msg_frame_t;

/** OP_FRAME Op NONE: a frame that does nothing (a new sender's first, which the alive-counter check may drop). */
#define SP_PROTO_FRAME_NONE 2u

/** OP_REACH: the reach query. */
typedef struct {
    uint8_t sequence; /**< echoed by CTRL_REACH */
    sp_pose_t pose;   /**< the tool frame's pose in the work frame (m, rad, Q24); not finite as in OP_FRAME */
} sp_msg_reach_t;

/** The largest |component| OP_FRAME and OP_REACH carry as a number: 8.388607 m or rad in Q24; the one raw
 *  value below (-8.388608, decoded as SP_PROTO_NOT_FINITE_Q24) stands for a value that is not finite. */
#define SP_PROTO_POSE_MAX_Q24 INT32_C(140737472)
#define SP_PROTO_NOT_FINITE_Q24 INT32_C(-140737488)

/** CTRL_REACH: the answer to one OP_REACH (sp_reach_t, or NOT_FINITE). */
typedef struct {
    uint8_t sequence;       /**< OP_REACH's */
    uint8_t verdict;        /**< sp_reach_verdict_t, or SP_PROTO_REACH_NOT_FINITE */
    uint8_t which;          /**< the workspace axis or the leg of the first limit broken */
    sp_q24_t excess;        /**< by how much, m or rad, Q24 */
    sp_q8_t force[SP_LEGS]; /**< the cylinder forces at rest there, N, Q8 */
} sp_msg_reach_answer_t;

/** CTRL_REACH Verdict of a query with a value that is not a finite number. */
#define SP_PROTO_REACH_NOT_FINITE 5u

/** CTRL_FRAMES's refusal counts: every reason of SP_REFUSE_* but NONE and LINK. */
#define SP_PROTO_FRAMES_REFUSED 8u

/** CTRL_FRAMES: the active frames and the refusals (every SP_PROTO_FRAMES_PERIOD ticks). */
typedef struct {
    uint8_t tool_index;   /**< the active tool slot */
    uint8_t work_index;   /**< the active work slot */
    uint8_t identity;     /**< 1: both active frames identity */
    uint8_t last_refusal; /**< the reason of the last refusal (SP_REFUSE_* of sp/control/controller.h) */
    uint32_t checksum;    /**< sp_frames_checksum of the active frames */
    uint32_t refused[SP_PROTO_FRAMES_REFUSED]; /**< refusals by reason, SP_REFUSE_STATE, RANGE, REACH, RATE, FORCE,
                                                    EMPTY_SLOT, BAD_FRAME, NOT_FINITE (every one but LINK), sent
                                                    saturated at 65535 */
} sp_msg_frames_t;

/** CTRL_FRAMES goes out on ticks t with t % SP_PROTO_FRAMES_PERIOD == SP_PROTO_FRAMES_PHASE (the DBC's
 *  100 ms; phase 5: never beside CTRL_AUTH, whose ticks are multiples of 10). */
#define SP_PROTO_FRAMES_PERIOD 100u
#define SP_PROTO_FRAMES_PHASE 5u

/** OP_FRAME (ID 0x04A, 32 bytes, ops bus, CRC-16, authenticated: sign it with sp_proto_sign). Components beyond
 *  the signal's range are saturated (SP_E_RANGE). SP_E_ARG on NULL, an op outside 0..2 or a kind outside 0..1. */
sp_status_t sp_proto_encode_frame(const sp_msg_frame_t *m, uint8_t counter, sp_can_frame_t *f);
/** OP_FRAME -> its values; rejects (SP_E_FRAME, *error) a wrong identifier or length, a bad CRC, an op
 *  outside 0..2 or a kind outside 0..1. SP_E_ARG on NULL. */
sp_status_t sp_proto_decode_frame(const sp_can_frame_t *f, sp_msg_frame_t *m, uint8_t *counter,
                                  sp_proto_error_t *error);
/** OP_REACH (ID 0x04B, 24 bytes, ops bus, CRC-16). As OP_FRAME's, without authentication. */
sp_status_t sp_proto_encode_reach(const sp_msg_reach_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t sp_proto_decode_reach(const sp_can_frame_t *f, sp_msg_reach_t *m, uint8_t *counter,
                                  sp_proto_error_t *error);
/** CTRL_REACH (ID 0x105, 32 bytes, ops bus, CRC-16). SP_E_ARG on NULL or a verdict or leg out of range;
 *  SP_E_RANGE when a value was saturated. */
sp_status_t sp_proto_encode_reach_answer(const sp_msg_reach_answer_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t sp_proto_decode_reach_answer(const sp_can_frame_t *f, sp_msg_reach_answer_t *m, uint8_t *counter,
                                         sp_proto_error_t *error);
/** CTRL_FRAMES (ID 0x106, 24 bytes, ops bus, CRC-16); counts saturate at 65535. SP_E_ARG on NULL or a
 *  refusal reason beyond 6. */
sp_status_t sp_proto_encode_frames(const sp_msg_frames_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t sp_proto_decode_frames(const sp_can_frame_t *f, sp_msg_frames_t *m, uint8_t *counter,
                                   sp_proto_error_t *error);

/** CTRL_IDENTITY Port: the target a port is built for (sp_node_config_t.port). */
typedef enum {
    SP_PORT_UNSPECIFIED = 0, /**< a port that does not say */
    SP_PORT_HOST = 1,        /**< the Linux SocketCAN port (sp_controller) */
    SP_PORT_STM32G474 = 2    /**< the NUCLEO-G474RE board port */
} sp_port_id_t;

/** CTRL_IDENTITY: what the controller is, sent once per OP_COMMAND IDENTIFY. */
typedef struct {
    uint8_t major;          /**< SP_VERSION_MAJOR (sp/math/version.h) */
    uint8_t minor;          /**< SP_VERSION_MINOR */
    uint8_t patch;          /**< SP_VERSION_PATCH */
    uint8_t port;           /**< sp_port_id_t */
    uint32_t protocol_hash; /**< sp_proto_dbc_hash of the firmware's DBC */
} sp_msg_identity_t;

/** The protocol the core was built from: the first 4 bytes, big-endian, of
 *  the SHA-256 of protocol/stewart.dbc (generated with the codec). */
extern const uint32_t sp_proto_dbc_hash;

/** CTRL_IDENTITY (ID 0x104, 12 bytes, ops bus, CRC-8). SP_E_ARG on NULL or
 *  a port outside sp_port_id_t. */
sp_status_t sp_proto_encode_identity(const sp_msg_identity_t *m, uint8_t counter, sp_can_frame_t *f);

/** CTRL_REFUSAL Command beyond OP_COMMAND's: what else the controller refuses. */
#define SP_REFUSED_FORCE_PARAMS 15u /**< an OP_FORCE_PARAMS (the node's SP_CMD_FORCE_PARAMS) */
#define SP_REFUSED_TARGET 16u       /**< a streamed OP_TARGET_POSE */

/** CTRL_REFUSAL: a refused command and why (docs/reference/commands.md). */
typedef struct {
    uint32_t tick;   /**< the tick that refused it */
    uint8_t command; /**< OP_COMMAND's value, SP_REFUSED_FORCE_PARAMS or SP_REFUSED_TARGET (0..16) */
    uint8_t reason;  /**< SP_REFUSE_* of sp/control/controller.h (1 .. SP_REFUSE_COUNT - 1) */
} sp_msg_refusal_t;

/** CTRL_REFUSAL (ID 0x107, 8 bytes, ops bus, CRC-8). SP_E_ARG on NULL or
 *  a command or reason outside its range. */
sp_status_t sp_proto_encode_refusal(const sp_msg_refusal_t *m, uint8_t counter, sp_can_frame_t *f);

/** CTRL_REFUSAL -> its values. Rejects (SP_E_FRAME, *error) a wrong
 *  identifier or length, a bad CRC and a value out of range; SP_E_ARG on NULL. */
sp_status_t sp_proto_decode_refusal(const sp_can_frame_t *f, sp_msg_refusal_t *m, uint8_t *counter,
                                    sp_proto_error_t *error);

/** CTRL_IDENTITY -> its values. Rejects (SP_E_FRAME, *error) a wrong
 *  identifier or length, a bad CRC and an unknown port; SP_E_ARG on NULL. */
sp_status_t sp_proto_decode_identity(const sp_can_frame_t *f, sp_msg_identity_t *m, uint8_t *counter,
                                     sp_proto_error_t *error);

/** Where an authenticated message (OP_COMMAND, OP_TARGET_POSE, OP_FORCE,
 *  OP_FORCE_PARAMS) keeps its authentication fields: byte offsets generated
 *  from the DBC. */
typedef struct {
    uint32_t length;       /**< the message's length, bytes */
    uint32_t counter_byte; /**< AuthCounter: the counter's low 16 bits, little-endian */
    uint32_t tag_byte;     /**< AuthTag: the code's low tag_bytes bytes; the code covers data[0..tag_byte) */
    uint32_t tag_bytes;    /**< 4..8 */
} sp_proto_auth_layout_t;

/** The layout of identifier `id`'s authentication fields: SP_OK, or
 *  SP_E_ARG for NULL or a message that has none. */
sp_status_t sp_proto_auth_layout(uint32_t id, sp_proto_auth_layout_t *lay);

/** 1 when OP_COMMAND's Command `command` must be authenticated: every
 *  command but NONE (does nothing), STOP, PARK and ESTOP (never refused for
 *  authentication: any node may stop the platform) and IDENTIFY (reads
 *  only); 0 otherwise. */
int sp_proto_command_needs_auth(uint8_t command);

/** 1 when frame `f` must carry a valid authentication code: its identifier
 *  is an authenticated message's (sp_proto_auth_layout) and, for
 *  OP_COMMAND, its Command needs it (sp_proto_command_needs_auth); 0
 *  otherwise and for NULL. Looks at the identifier and OP_COMMAND's first
 *  byte only: the frame's CRC and length are the decoder's to check. */
int sp_proto_frame_needs_auth(const sp_can_frame_t *f);

/**
 * Signs an encoded authenticated frame (OP_COMMAND, OP_TARGET_POSE,
 * OP_FORCE, OP_FORCE_PARAMS, as its encoder made it): writes the counter's low 16 bits and
 * the code (sp_auth_tag over the bytes before the tag, under `key`, with
 * `session` and the full `counter`), then seals the CRC again. SP_E_ARG for
 * NULL, another message or length, or counter 0 (never valid).
 */
sp_status_t sp_proto_sign(sp_can_frame_t *f, const sp_auth_key_t *key, uint32_t session, uint32_t counter);

/** Checks a received authenticated frame (its CRC already checked) against
 *  the receiver `rx` (sp_auth_check: counts and, when accepted, the last
 *  counter change). SP_AUTH_BAD_ARG for NULL or another message. */
sp_auth_result_t sp_proto_auth_check(sp_auth_rx_t *rx, const sp_auth_key_t *key, const sp_can_frame_t *f);

sp_status_t sp_proto_encode_sync(const sp_msg_sync_t *m, uint8_t counter, uint8_t bus, sp_can_frame_t *f);
sp_status_t sp_proto_encode_setpoints(const sp_msg_setpoints_t *m, uint8_t counter, uint8_t bus, sp_can_frame_t *f);
/** slot 1..3 selects the identifier 0x031..0x033. */
sp_status_t sp_proto_encode_feedback(const sp_msg_feedback_t *m, uint8_t slot, uint8_t counter, uint8_t bus,
                                     sp_can_frame_t *f);
sp_status_t sp_proto_encode_command(const sp_msg_command_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t sp_proto_encode_target(const sp_pose_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t sp_proto_encode_status(const sp_msg_status_t *m, uint8_t counter, sp_can_frame_t *f);
sp_status_t sp_proto_encode_monitor(const sp_msg_monitor_t *m, uint8_t counter, sp_can_frame_t *f);

/**
 * CTRL_WRENCH (ID 0x102, 24 bytes, ops bus, CRC-16): tick, valid, then each
 * wrench component rounded to the nearest 0.25 N or N m (Q8 / 64, ties away
 * from zero). A component beyond +-524287.75 (SP_PROTO_WRENCH_MAX_Q8) is
 * saturated to that limit, never wrapped, and the call returns SP_E_RANGE
 * (the frame is still complete and sealed). SP_E_ARG on NULL.
 */
sp_status_t sp_proto_encode_wrench(const sp_msg_wrench_t *m, uint8_t counter, sp_can_frame_t *f);

/**
 * OP_FORCE (ID 0x048, 32 bytes, ops bus, CRC-16; authenticated: the
 * encoder leaves AuthCounter and AuthTag 0, sp_proto_sign fills them): the mask, then each
 * target component rounded to the nearest 1/32 N or N m (Q8 / 8, ties away
 * from zero). A component beyond +-16383.97 (SP_PROTO_FT_MAX_Q8) is
 * saturated, never wrapped, and the call returns SP_E_RANGE (the frame is
 * still sealed). SP_E_ARG on NULL or a mask above 63.
 */
sp_status_t sp_proto_encode_force(const sp_msg_force_t *m, uint8_t counter, sp_can_frame_t *f);

/**
 * OP_FORCE -> mask and the Q8 target (raw x 8, exact). Rejects
 * (SP_E_FRAME, *error) a wrong identifier or length, a bad CRC and the
 * excluded raw value -2^19 (out-of-range). Whether the
 * target is within the controller's limits is the controller's check.
 */
sp_status_t sp_proto_decode_force(const sp_can_frame_t *f, sp_msg_force_t *m, uint8_t *counter,
                                  sp_proto_error_t *error);

/**
 * OP_FORCE_PARAMS (ID 0x049, 24 bytes, ops bus, CRC-16; authenticated as
 * OP_FORCE: sp_proto_sign fills AuthCounter and AuthTag): mask, mode, the
 * mass rounded to 0.1 kg, the damping to 10 N s/m (ties away from zero),
 * the stiffness in N/m. SP_E_ARG on NULL, a mask of 0 or above 63, a mode
 * other than 1 or 2, or a value outside the documented ranges (nothing is
 * saturated: a parameter is either sent as asked or not at all).
 */
sp_status_t sp_proto_encode_force_params(const sp_msg_force_params_t *m, uint8_t counter, sp_can_frame_t *f);

/**
 * OP_FORCE_PARAMS -> the parameters (mass Q16 = raw x 65536 / 10 rounded,
 * damping = raw x 10, stiffness = raw). Rejects (SP_E_FRAME, *error) a
 * wrong identifier or length, a bad CRC, and as out-of-range a mask of 0,
 * a mode other than 1 or 2, or a value outside the DBC's range; *m is
 * untouched then.
 */
sp_status_t sp_proto_decode_force_params(const sp_can_frame_t *f, sp_msg_force_params_t *m, uint8_t *counter,
                                         sp_proto_error_t *error);

/**
 * FT_SENSOR (ID 0x038, 20 bytes, axis_b, CRC-16): the wrench rounded to
 * 1/32 N or N m, saturated at +-16383.97 (SP_E_RANGE, frame still sealed).
 * SP_E_ARG on NULL.
 */
sp_status_t sp_proto_encode_ft(const sp_msg_ft_t *m, uint8_t counter, sp_can_frame_t *f);

/** FT_SENSOR -> Q8 wrench (exact). Rejects as sp_proto_decode_force; the
 *  bus is the caller's check. */
sp_status_t sp_proto_decode_ft(const sp_can_frame_t *f, sp_msg_ft_t *m, uint8_t *counter, sp_proto_error_t *error);

/**
 * OP_HEARTBEAT (ID 0x060, 4 bytes, ops bus, CRC-8): the operator node's sign
 * of life; no payload besides the alive counter. SP_E_ARG on NULL.
 */
sp_status_t sp_proto_encode_heartbeat(uint8_t counter, sp_can_frame_t *f);

/** OP_HEARTBEAT -> its alive counter. Rejects (SP_E_FRAME, *error) a wrong
 *  identifier or length and a bad CRC; SP_E_ARG on NULL. */
sp_status_t sp_proto_decode_heartbeat(const sp_can_frame_t *f, uint8_t *counter, sp_proto_error_t *error);

sp_status_t sp_proto_decode_sync(const sp_can_frame_t *f, sp_msg_sync_t *m, uint8_t *counter, sp_proto_error_t *error);
sp_status_t sp_proto_decode_setpoints(const sp_can_frame_t *f, sp_msg_setpoints_t *m, uint8_t *counter,
                                      sp_proto_error_t *error);
/** *slot gets 1..3 from the identifier. */
sp_status_t sp_proto_decode_feedback(const sp_can_frame_t *f, sp_msg_feedback_t *m, uint8_t *slot, uint8_t *counter,
                                     sp_proto_error_t *error);
sp_status_t sp_proto_decode_command(const sp_can_frame_t *f, sp_msg_command_t *m, uint8_t *counter,
                                    sp_proto_error_t *error);
sp_status_t sp_proto_decode_target(const sp_can_frame_t *f, sp_pose_t *m, uint8_t *counter, sp_proto_error_t *error);
sp_status_t sp_proto_decode_status(const sp_can_frame_t *f, sp_msg_status_t *m, uint8_t *counter,
                                   sp_proto_error_t *error);
sp_status_t sp_proto_decode_monitor(const sp_can_frame_t *f, sp_msg_monitor_t *m, uint8_t *counter,
                                    sp_proto_error_t *error);
/**
 * CTRL_WRENCH -> Q8 wrench (raw x 64, exact: |value| <= SP_PROTO_WRENCH_MAX_Q8).
 * Rejects (SP_E_FRAME, *error) a wrong identifier or length, a bad CRC, and
 * the excluded raw value -2^21 of any component (out-of-range).
 */
sp_status_t sp_proto_decode_wrench(const sp_can_frame_t *f, sp_msg_wrench_t *m, uint8_t *counter,
                                   sp_proto_error_t *error);

#endif /* SP_PROTOCOL_H */
