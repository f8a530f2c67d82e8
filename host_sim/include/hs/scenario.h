/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/scenario.h - the operator scenario language of hs_sim: what the plant
 * plays at exact ticks in a closed-loop run (docs/explanation/closed_loop.md, "Scenario
 * files"). Parsing (from a string or a file) and playing (which action is
 * due at which tick) are here; what an action does on the bus or to the
 * plant is the program's part (host_sim/app/hs_sim.c).
 *
 * One action per line, '#' starts a comment (to the end of the line), words
 * are separated by spaces or tabs; keywords, command names, axes and states
 * are case-insensitive, the keys of `cmd` are lower case; legs are 1..6:
 *
 *   cmd NAME [axis=x|y|z|roll|pitch|yaw] [amplitude=A] [frequency=HZ] [fade=S] [option=0|1]
 *          OP_COMMAND; NAME: ENGAGE RUN_TRIG MOVE_TO STREAM STOP PARK ESTOP
 *          RESET SET_FEEDFORWARD FORCE GUIDE POSITION TARE. A: m or rad, |A| < 128; HZ: 0 <= HZ < 128;
 *          S: fade time 0..65 s (0: the controller's default); each key once
 *   target X Y Z ROLL PITCH YAW   OP_TARGET_POSE, m and rad, each |v| <= 8
 *   delay S                       wait S seconds of simulated time, 0..1e6
 *   wait STATE [S]                until CTRL_STATUS reports STATE (idle,
 *                                 engaging, ready, running, parking, fault,
 *                                 estop); times out after S s (0 < S <= 1e6,
 *                                 default 60)
 *   silence LEG / unsilence LEG   the drive of LEG stops / resumes sending feedback
 *   fault LEG BITS                raises drive fault bits 1..0xff (hs/drive.h)
 *   mark TEXT                     prints TEXT with the tick (for logs and tests)
 *   end                           ends the run
 *   wrench FX FY FZ MX MY MZ [ramp=S]
 *                                 the constant external wrench on the platform
 *                                 (base frame, force N at o', moment N m about
 *                                 o'), each |v| <= 1e6, reached linearly from
 *                                 the current one over S s (0..1e6, default 0:
 *                                 a step)
 *   wrench off [ramp=S]           the same towards zero
 *   contact plane NX NY NZ OFFSET PX PY PZ stiffness=K damping=D
 *                                 a unilateral plane {x : n . x = OFFSET}
 *                                 (base frame, n not zero, pointing into free
 *                                 space) touched by the platform point P
 *                                 (motion frame); |values| <= 100 m
 *   contact surface up|down PX PY PZ ROLL PITCH TX TY TZ stiffness=K damping=D
 *                                 the same plane placed by a point P on it
 *                                 (base frame, m) and its tilt: its free side
 *                                 +z (up) or -z (down), tilted by ROLL about
 *                                 x then PITCH about y (rad, |v| <= 1.5):
 *                                 n = Ry(PITCH) Rx(ROLL) (0, 0, +-1), offset
 *                                 n . P; touched by the platform point T
 *   contact point AX AY AZ PX PY PZ stiffness=K damping=D
 *                                 a spring-damper from the platform point P
 *                                 (motion frame) to the fixed anchor A (base
 *                                 frame); K 0..1e9 N/m, D 0..1e9 N s/m, both
 *                                 keys required, each once
 *   contact off                   removes the contact
 *   frame tool|work select N      OP_FRAME: makes slot N (0..15) the active
 *                                 tool or work frame (issue 31)
 *   frame tool|work set N X Y Z ROLL PITCH YAW
 *                                 OP_FRAME: sets slot N to the frame (m,
 *                                 rad, |v| <= 8; a tool frame is T in o', a
 *                                 work frame W in the base frame) and makes
 *                                 it active
 *   load MASS X Y Z               attaches a rigid point mass (kg, |MASS| <=
 *                                 1e5, negative removes) at (X, Y, Z) in the
 *                                 motion frame (|v| <= 100 m), from then on;
 *                                 the program refuses a result that is not a
 *                                 rigid body
 *   force AXES FX FY FZ MX MY MZ  OP_FORCE (the axes, the target wrench the
 *                                 platform is to exert: base frame, N and
 *                                 N m about o') then OP_COMMAND FORCE, as an
 *                                 operator enters force control. AXES: axis
 *                                 names joined by commas (z, x,z, ...) or the
 *                                 mask as a number 0..63; |v| <= 16383 (the
 *                                 frame's range; the controller's own limits
 *                                 refuse more)
 *   force_target AXES FX FY FZ MX MY MZ
 *                                 OP_FORCE alone: in FORCE, a target update
 *   guide AXES                    OP_FORCE (the axes, no target), then
 *                                 OP_COMMAND GUIDE: hand guiding
 *   position                      OP_COMMAND POSITION: leave force control
 *   tare                          OP_COMMAND TARE: zero the force/torque sensor
 *   push FX FY FZ MX MY MZ rise=S hold=S
 *                                 a person's push on the payload: a wrench
 *                                 (base frame, N and N m about o', |v| <=
 *                                 1e6) that rises linearly from 0 over S s,
 *                                 holds for S s and falls back over the rise
 *                                 time, on top of `wrench` (both keys
 *                                 required, 0..1e6 s; a new push replaces one
 *                                 under way)
 *   ftsensor off|on               the force/torque sensor stops / resumes
 *                                 sending FT_SENSOR
 *   play FILE                     streams target poses from a CSV file (header
 *                                 t,x,y,z,roll,pitch,yaw; t in s from the
 *                                 action, strictly increasing, >= 0, at most
 *                                 1e6; poses absolute, m and rad, |v| <= 8):
 *                                 one OP_TARGET_POSE per 1 ms tick, linearly
 *                                 interpolated (the first row held before its
 *                                 t), ending with the last row at its t; the
 *                                 actions after it wait until then. The file
 *                                 is checked when the scenario is parsed; a
 *                                 relative FILE is taken from the scenario
 *                                 file's directory (from the working
 *                                 directory for hs_scenario_parse).
 *
 * Fault injection (its own section; parsed in scenario_inject.c, carried
 * out by hs_sim through hs/inject.h and hs/plant.h; docs/explanation/faults.md):
 *
 *   inject frames BUS MSG FAULT [rate=P] [count=N] [delay=TICKS]
 *          BUS: ops, axis_a, axis_b, any; MSG: setpoints, feedback, command,
 *          target, heartbeat, status, monitor, wrench, any, or an
 *          identifier 0..0x7ff; FAULT: drop, delay, duplicate, reorder,
 *          corrupt. P: 0 < P <= 1 per matching frame; N: 1..1e6 fires (the
 *          default 1 without a rate; with a rate: no limit); delay 1..1e5
 *          ticks (default 5). SYNC is never touched (the lockstep clock).
 *   inject frames off             removes every frame rule
 *   inject busoff BUS [S | off]   the bus carries nothing for S s (0 < S <=
 *                                 1e6; default: until `inject busoff BUS off`)
 *   inject drive LEG fault BITS [hold]
 *                                 raises drive fault bits 1..0xff; with hold
 *                                 their cause stays (a fault reset is refused)
 *   inject drive LEG freeze | stale [TICKS] | ok
 *                                 the drive repeats its alive counter / echoes
 *                                 the SYNC tick TICKS (1..1000, default 2) old
 *                                 / is healthy again (held bits removed)
 *   inject sensor LEG stick [M] | jump M | noise M | ok
 *                                 the length sensor sticks (at M m, default
 *                                 where it is), jumps by M m, adds noise of M
 *                                 m (one sigma), or is healthy; |M| <= 10
 *   inject valve LEG stick [U] | ok   the spool sticks at command U (-1..1,
 *                                 default 0) / is free again
 *   inject supply loss | ok       the supply pressure falls to the tank's / returns
 *   inject endstop LEG [up|down]  the valve sticks fully open (up: extending,
 *                                 the default): the cylinder runs into its end stop
 *   inject fk [M]                 inconsistent leg lengths: the sensors of
 *                                 legs 1, 3, 5 read M m more, of 2, 4, 6 M m
 *                                 less (0 < M <= 1, default 0.05)
 *   inject clear                  removes every injected fault
 *
 * Actions run in order; there are no time stamps, only delays and waits, so
 * there is no tick order to get wrong. Seconds become 1 ms ticks, rounded to
 * the nearest tick; metres, radians and hertz become Q24 (rounded to
 * nearest, ties away from zero).
 *
 * No heap, no globals: a scenario is one plain struct. Not thread-safe per
 * struct.
 */
#ifndef HS_SCENARIO_H
#define HS_SCENARIO_H

#include <stdint.h>
#include <stdio.h>

#include "hs/status.h"
#include "sp/control/controller.h"
#include "sp/link/protocol.h"

#define HS_SCENARIO_MAX_ACTIONS 256           /**< actions in one scenario */
#define HS_SCENARIO_MAX_LINE 510              /**< characters in one line, without its '\n' */
#define HS_SCENARIO_MAX_WORDS 16              /**< words in one line (keyword included), comments excluded */
#define HS_SCENARIO_MAX_TEXT 95               /**< characters of a mark's text (its words joined by one space) */
#define HS_SCENARIO_ERROR_LEN 320             /**< size of hs_scenario_error_t.message, NUL included */
#define HS_SCENARIO_WAIT_DEFAULT_TICKS 60000u /**< a wait's timeout when none is given: 60 s */
#define HS_SCENARIO_MAX_PATH 255              /**< characters of a play file's path (after resolving) */

typedef enum {
    HS_ACTION_CMD = 0,   /**< send OP_COMMAND `cmd` */
    HS_ACTION_TARGET,    /**< send OP_TARGET_POSE `target` */
    HS_ACTION_DELAY,     /**< let `ticks` ticks pass */
    HS_ACTION_WAIT,      /**< until the controller reports `state`, at most `ticks` ticks */
    HS_ACTION_SILENCE,   /**< the drive of `leg` stops sending feedback */
    HS_ACTION_UNSILENCE, /**< the drive of `leg` sends feedback again */
    HS_ACTION_FAULT,     /**< raise drive fault `bits` on `leg` */
    HS_ACTION_MARK,      /**< print `text` with the tick */
    HS_ACTION_END,       /**< end the run */
    HS_ACTION_WRENCH,    /**< external wrench `wrench`, ramped over `ticks` */
    HS_ACTION_CONTACT,   /**< install `contact` (kind 0: remove) */
    HS_ACTION_LOAD,      /**< attach point mass `mass` at `point` */
    HS_ACTION_PLAY,      /**< stream the poses of `path` for `ticks` ticks */
    HS_ACTION_INJECT,    /**< inject the fault `inject` */
    HS_ACTION_FORCE,     /**< send OP_FORCE `force`, then OP_COMMAND `cmd` unless its command is 0 */
    HS_ACTION_PUSH,      /**< a push `wrench`: rise over `ticks`, hold for `hold` */
    HS_ACTION_FTSENSOR,  /**< the force/torque sensor sends (`bits` 1) or not (0) */
    HS_ACTION_FRAME      /**< send OP_FRAME `frame` */
} hs_action_kind_t;

/** What an `inject` action injects. */
typedef enum {
    HS_INJECT_FRAMES = 0,     /**< a frame rule: bus, id_lo..id_hi, fault, rate, count, delay */
    HS_INJECT_FRAMES_OFF = 1, /**< remove the frame rules */
    HS_INJECT_BUSOFF = 2,     /**< bus off for ticks (0: until cleared; mode 0: back on) */
    HS_INJECT_DRIVE = 3,      /**< mode: 0 fault bits (hold), 1 freeze, 2 stale (ticks), 3 ok */
    HS_INJECT_SENSOR = 4,     /**< mode: hs_sensor_fault_t values (0 ok, 1 stick, 2 jump, 3 noise); value */
    HS_INJECT_VALVE = 5,      /**< mode 1 stick at value, 0 free */
    HS_INJECT_SUPPLY = 6,     /**< mode 1 lost, 0 back */
    HS_INJECT_ENDSTOP = 7,    /**< value +1 (up) or -1 (down) */
    HS_INJECT_FK = 8,         /**< value: the sensors' offsets, m */
    HS_INJECT_CLEAR = 9       /**< remove everything injected */
} hs_inject_what_t;

/** An `inject` action as written (no dependency on hs/inject.h or the plant). */
typedef struct {
    int what;              /**< hs_inject_what_t */
    int bus;               /**< FRAMES, BUSOFF: 0 ops, 1 axis_a, 2 axis_b, 0xFF any (FRAMES only) */
    uint32_t id_lo, id_hi; /**< FRAMES: identifiers */
    int fault;             /**< FRAMES: 0 drop, 1 delay, 2 duplicate, 3 reorder, 4 corrupt (hs_frame_fault_t) */
    double rate;           /**< FRAMES: 0..1 (0: count only) */
    uint32_t count;        /**< FRAMES: fires (0 with a rate: no limit) */
    uint32_t delay;        /**< FRAMES delay: ticks */
    uint64_t ticks;        /**< BUSOFF: its length (0: until cleared); DRIVE stale: how old */
    int leg;               /**< DRIVE, SENSOR, VALVE, ENDSTOP: 0..5 */
    int mode;              /**< see hs_inject_what_t */
    uint32_t bits;         /**< DRIVE fault: bits */
    int hold;              /**< DRIVE fault: 1 the cause stays */
    double value;          /**< SENSOR: m; VALVE: command; ENDSTOP: +-1; FK: m */
} hs_scenario_inject_t;

/** A contact as written (hs/plant.h's hs_contact_t, without depending on the plant). */
typedef struct {
    int kind;         /**< 0 off, 1 plane, 2 point (the values of hs_contact_kind_t) */
    double normal[3]; /**< plane: normal, base frame (not normalised) */
    double offset;    /**< plane: offset, m */
    double anchor[3]; /**< point: anchor, base frame, m */
    double point[3];  /**< the platform point, motion frame, m */
    double stiffness; /**< N/m */
    double damping;   /**< N s/m */
} hs_scenario_contact_t;

/** A `frame` action as written: OP_FRAME's fields (issue 31). */
typedef struct {
    int op;          /**< 0 select, 1 set (SP_FRAME_SELECT, SP_FRAME_SET) */
    int kind;        /**< 0 tool, 1 work (SP_FRAME_TOOL, SP_FRAME_WORK) */
    int index;       /**< the slot, 0..15 (the controller refuses 4 and above) */
    double value[6]; /**< set: x y z (m) roll pitch yaw (rad), |v| <= 8 */
} hs_scenario_frame_t;

/** One parsed action. Only the fields of its kind are set; the others are 0. */
typedef struct {
    hs_action_kind_t kind;
    int line; /**< line of the scenario it came from, 1-based */
    /** CMD: command, axis (sp_axis_t), amplitude (Q24 m or rad), frequency (Q24 Hz), fade_ms (ms), option */
    sp_msg_command_t cmd;
    sp_pose_t target;                    /**< TARGET: pos (Q24 m), rpy (Q24 rad) */
    uint64_t ticks;                      /**< DELAY: its length; WAIT: its timeout; 1 ms ticks */
    sp_state_t state;                    /**< WAIT: the controller state awaited */
    int leg;                             /**< SILENCE, UNSILENCE, FAULT: leg index 0..5 (written 1..6) */
    uint32_t bits;                       /**< FAULT: drive fault bits, 0x01..0xff */
    char text[HS_SCENARIO_MAX_TEXT + 1]; /**< MARK: the text, NUL-terminated (may be empty) */
    double wrench[6];                    /**< WRENCH: force (N) and moment (N m), base frame; ticks: the ramp */
    hs_scenario_contact_t contact;       /**< CONTACT */
    double mass;                         /**< LOAD: kg */
    double point[3];                     /**< LOAD: motion frame, m */
    char path[HS_SCENARIO_MAX_PATH + 1]; /**< PLAY: the file (resolved); ticks: its duration (last row's t) */
    hs_scenario_inject_t inject;         /**< INJECT */
    sp_msg_force_t force;                /**< FORCE: OP_FORCE's mask and target (Q8) */
    uint64_t hold;                       /**< PUSH: the hold, ticks (the rise is `ticks`) */
    hs_scenario_frame_t frame;           /**< FRAME */
} hs_action_t;

/** A parsed scenario and where its player stands. */
typedef struct {
    hs_action_t action[HS_SCENARIO_MAX_ACTIONS];
    int n;          /**< actions parsed, 1..HS_SCENARIO_MAX_ACTIONS after a successful parse */
    int pc;         /**< the next action to play */
    uint64_t until; /**< the current delay's end tick, or the current wait's deadline */
    int armed;      /**< 1: the current delay or wait has set `until` */
    uint64_t busy;  /**< a play under way holds the next action back until this tick */
} hs_scenario_t;

/** Why a scenario was refused. */
typedef struct {
    int line;                            /**< the offending line, 1-based; 0: not one line's fault */
    char message[HS_SCENARIO_ERROR_LEN]; /**< "NAME:LINE: what is wrong" (or "NAME: ..." when line is 0) */
} hs_scenario_error_t;

/**
 * Parses a whole scenario from `text` (NUL-terminated; lines end with '\n',
 * a '\r' before it counts as a space) into *sc, rewound to its first action.
 * `name` names the text in error messages (a file name; NULL: "scenario").
 *
 * Returns HS_OK; HS_E_ARG if sc or text is NULL; HS_E_SYNTAX at the first
 * line that is wrong (unknown action, command, key, axis or state, a
 * missing or extra argument, a word that is not a number, a value out of
 * its range, a line longer than HS_SCENARIO_MAX_LINE characters or with
 * more than HS_SCENARIO_MAX_WORDS words, a mark text longer than
 * HS_SCENARIO_MAX_TEXT, an action beyond HS_SCENARIO_MAX_ACTIONS), or when
 * the text has no action at all (empty, or only comments and blank lines;
 * err->line 0). On an error *err (if not NULL) names the line and says
 * what is wrong, and *sc holds no actions (n = 0).
 */
hs_status_t hs_scenario_parse(hs_scenario_t *sc, const char *text, const char *name, hs_scenario_error_t *err);

/**
 * Reads and parses the scenario file `path`, as hs_scenario_parse with the
 * path as the name. Returns HS_OK; HS_E_ARG if sc or path is NULL; HS_E_IO
 * if the file cannot be opened or read (err->line 0, the message has the
 * system's reason); HS_E_SYNTAX as hs_scenario_parse (also for a NUL
 * character in a line).
 */
hs_status_t hs_scenario_load(hs_scenario_t *sc, const char *path, hs_scenario_error_t *err);

/** Puts the player back at the first action (no delay or wait under way). No-op on NULL. */
void hs_scenario_rewind(hs_scenario_t *sc);

/** What hs_scenario_next says. */
typedef enum {
    HS_SCENARIO_DUE = 0,     /**< *action is due at this tick: carry it out, then call again */
    HS_SCENARIO_PENDING = 1, /**< a delay or wait holds the rest back: call again next tick */
    HS_SCENARIO_END = 2,     /**< an `end` action or the end of the scenario was reached */
    HS_SCENARIO_TIMEOUT = 3  /**< *action, a wait, did not see its state within its timeout */
} hs_scenario_next_t;

/**
 * Plays the scenario at `tick` (1 ms ticks of simulated time, never going
 * back) given the controller state last reported (`state`: an sp_state_t
 * value, or -1 when none has been reported yet).
 *
 * Call it until it returns anything but HS_SCENARIO_DUE. Each DUE hands
 * over the next action in *action and moves past it, so every action is
 * handed over exactly once, at the tick it is due: CMD, TARGET, SILENCE,
 * UNSILENCE, FAULT and MARK at once; a DELAY of d ticks first seen at tick
 * t when tick >= t + d (at once for d = 0); a WAIT first seen at tick t as
 * soon as `state` equals its state, or HS_SCENARIO_TIMEOUT (and *action the
 * wait) at tick >= t + timeout if it still does not. A PLAY is handed over
 * at once (the program starts streaming) and holds the actions after it
 * back until tick >= t + its ticks (PENDING meanwhile). WRENCH, CONTACT,
 * LOAD, FORCE, PUSH and FTSENSOR are handed over at once. END and the end of
 * the scenario return HS_SCENARIO_END (with *action the `end` action, or
 * NULL), and keep returning it. The player does not move on after a
 * TIMEOUT. *action is NULL for PENDING. Returns HS_SCENARIO_END, with
 * *action NULL, on NULL arguments.
 */
hs_scenario_next_t hs_scenario_next(hs_scenario_t *sc, uint64_t tick, int state, const hs_action_t **action);

/** A play file being streamed (see `play`): the two rows around the time asked for. */
typedef struct {
    FILE *file;
    double row0[7], row1[7]; /**< t, x, y, z, roll, pitch, yaw; row1 unused when at_end */
    int at_end;              /**< row0 is the last row */
    long line;               /**< line of the file last read */
} hs_play_t;

/**
 * Opens a play file (as checked by the parser) and reads its first rows.
 * HS_OK; HS_E_ARG on NULL; HS_E_IO if it cannot be opened; HS_E_SYNTAX if it
 * is not as `play` wants (*err, if not NULL, names the file and line).
 */
hs_status_t hs_play_open(hs_play_t *play, const char *path, hs_scenario_error_t *err);

/**
 * The pose (x, y, z m; roll, pitch, yaw rad) at `ms` milliseconds after the
 * start: linear between the rows around t = ms / 1000 s, the first row
 * before it, the last after it. Times never go back. Returns HS_OK;
 * HS_E_ARG on NULL; HS_E_SYNTAX / HS_E_IO if the file changed under it
 * (*err says where). *done is 1 once t reached the last row's t.
 */
hs_status_t hs_play_pose(hs_play_t *play, uint64_t ms, double pose[6], int *done, hs_scenario_error_t *err);

/** Closes the file (no-op on NULL or a closed play). */
void hs_play_close(hs_play_t *play);

/** Name of an OP_COMMAND command as a scenario writes it ("ENGAGE", ..., "SET_FEEDFORWARD";
 *  "NONE" for 0); "unknown" otherwise. Never NULL. */
const char *hs_scenario_command_name(uint8_t command);

#endif /* HS_SCENARIO_H */
