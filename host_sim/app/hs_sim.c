/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs_sim - the simulated hydraulic hexapod on SocketCAN: the plant
 * (hs/plant.h) behind the drives' side of the protocol (hs/bus.h).
 *
 *   hs_sim [OPTION]...
 *
 * The options are the table cli_options below (one row each: name, value,
 * help line, setter); --help prints it.
 *
 * Command authentication (docs/explanation/security.md): the scenario's commands, MOVE_TO
 * and streamed targets and force targets are signed, as `stewart op` signs
 * them, with the machine key of --key FILE (else the file STEWART_KEY
 * names), the controller's session and the next counter. The session and the
 * last accepted counter come from the controller's CTRL_AUTH; --session N
 * gives the session from the start (a lockstep run's first cycles come
 * before the first CTRL_AUTH; sp_controller gets the same --session). The
 * counter starts after CTRL_AUTH's LastCounter and jumps there again when
 * another operator has gone past it. Without a key the frames go unsigned
 * (a controller with a key rejects them: the run shows what a stranger's
 * commands do). With --inproc the in-process controller gets the key and
 * the session (default 1).
 *
 * --canopen: the drives are CiA 408 nodes (hs/co_bus.h, docs/reference/canopen.md),
 * as the platform config's drives section says (then --canopen is the
 * default), else node ids 1-3 on axis_a and 4-6 on axis_b, configured and driven by a
 * CANopen master (NMT, SDO, RPDO1 + SYNC); the native drive frames are
 * neither sent nor read. The master's SYNC sets the pace: each SYNC (the
 * one on axis_b closes the cycle) is one plant cycle of 1 ms, whatever the
 * wall clock (log timestamps are simulated time); --timeout-ms of silence
 * ends the run (exit 3; the first cycle waits at least 10 s). With --lockstep the plant stays the time master
 * (deterministic, byte-identical logs): each cycle it sends only SYNC(t) on
 * both axis buses (the lockstep clock; no native feedback), the controller
 * ticks on it and its CANopen master sends NMT/SDO/RPDO1/SYNC, the nodes
 * answer at once (before the next SYNC(t)), then the plant integrates 1 ms.
 * Not with --inproc. --cia402 (implies --canopen) presents every drive as a
 * CiA 402 node in cyclic synchronous position mode instead (the profile per
 * leg comes from the config's drives section when it has one).
 * --sdo-delay-ms MS (0..1000, default 0; with --canopen) makes every node a
 * slow SDO server: each answer goes out MS ms of plant time after the
 * request (a drive storing each object), so that the master's start-up by
 * SDO lasts (tests/bus/test_canopen_engage_refused.py); keep MS below the
 * master's SDO timeout (100 ms).
 *
 * Lockstep (deterministic): the plant is the time master. Each cycle t it
 * runs the scenario's actions due at t (operator commands on the ops bus),
 * sends every drive's feedback and SYNC(t) on both axis buses, waits until
 * the controller has answered with AXIS_SETPOINTS(t) on both axis buses and
 * CTRL_STATUS(t) and CTRL_MONITOR(t) (and on even t CTRL_WRENCH(t)) on the
 * ops bus, then integrates 1 ms.
 * No wall clock enters the result: the same inputs give the same log, byte
 * for byte (log timestamps are simulated time).
 *
 * Real time: the plant integrates 1 ms per wall-clock millisecond (absolute
 * deadlines) and answers each SYNC from the controller (the cycle master)
 * at once with the latest sampled feedback. Log timestamps are wall time
 * since the start.
 *
 * Scenario file (--scenario): one operator action per line (cmd, target,
 * delay, wait, silence, unsilence, fault, mark, end, wrench, contact, load,
 * play, force, force_target, guide, position, tare, push, ftsensor); the language, its
 * parser and player are in hs/scenario.h (host_sim/src/scenario/scenario.c), what
 * each action does on the bus or to the plant is run_action below.
 * Commands are sent before the cycle's feedback and SYNC, so in lockstep the
 * controller always executes them at the same tick.
 *
 * --setpoint-timeout CYCLES: the drives' setpoint watchdog (default 3
 * cycles without setpoints in ACTIVE -> HOLD and the timeout fault); only
 * to relax it for hosts that cannot keep 1 ms deadlines (real time inside
 * user-mode Linux), as sp_controller's --feedback-timeout.
 * --inproc: lockstep with the controller (the firmware's node, configured as
 * sp_controller --lockstep) in this process instead of on SocketCAN: the
 * frames pass in memory in the order one vcan socket delivers them, so the
 * CAN log is the same byte for byte (docs/explanation/faults.md); prints the fault
 * report with every frame accounted on both sides.
 * --tick0 N (test only): the SYNC tick of cycle 0 (and with --inproc the
 * controller's own tick), to run through the 2^32 and TickEcho wraps.
 * --wrench-source cylinders|sensor (with --inproc): force control's wrench
 * source, as sp_controller's option (default: the platform config's).
 * --estop-category 0|1 (with --inproc): ESTOP's stop category, 1 the
 * controlled stop, 0 the immediate (default: the platform config's estop).
 * --load MASS,X,Y,Z: a point mass (kg, m in the motion frame) the config
 * does not know, part of the platform from the start (hs_params_add_mass).
 * --as-built FILE: the machine as built without a rebuild: the 48 offsets of
 * an as_built section (joints, sensor zeros and scales; as_built_params) on
 * the compiled-in config, added to its own (none in the default build).
 * The force/torque sensor (hs/ftsensor.h, mounted as the config's
 * force_sensor section) sends its newest sample as FT_SENSOR on axis_b each
 * cycle, before the cycle's SYNC.
 * --truth: per cycle pose, leg lengths, cylinder forces, drive states, the
 * outside world's wrench on the platform (external + contact, base frame,
 * moment about o'), each cylinder's friction and its blocking valves' opening
 * (0 closed .. 1 open, hs/drive.h; docs/explanation/closed_loop.md).
 *
 * --control FILE (real time): scenario lines while the run goes on, from
 * FILE (a FIFO that stewart sim writes; a regular file is read once): one
 * request a line, each parsed alone as a scenario of one action (the file
 * scenario's language) and played at once, in order; a `delay` or `wait`
 * holds the lines after it back. Each line is answered on stdout:
 * `hs_sim control: accepted: LINE`, `hs_sim control: refused: WHY` (a
 * parse error, a refused load or injection, a wait that timed out); the run
 * goes on either way (`end` only ends that request). The external wrench,
 * contacts, loads, pushes and faults are the plant's (docs/guides/simulator.md).
 * --stats S (real time): every S seconds of wall clock
 * `hs_sim stats: cycles N, deadline misses M (P %), worst late X ms` on
 * stderr, and once at the end. A deadline miss is a cycle that starts more
 * than one period (1 ms) after its own start time; the plant catches up
 * (it integrates 1 ms per cycle, the wall clock's time in all) while it is
 * at most 20 ms behind, and beyond skips ahead (each period skipped is a
 * miss too; the plant's time then falls behind the wall clock).
 *
 * Exit status: 0 the run ended (ticks done, scenario end, or SIGINT/SIGTERM), 1 I/O or set-up
 * error, 2 usage or scenario syntax error (or a load or play file refused
 * while running), 3 the controller stopped
 * answering (lockstep), 4 a scenario wait timed out, 5 the plant's state
 * became non-finite.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "hs/bus.h"
#include "hs/co_bus.h"
#include "hs/ftsensor.h"
#include "hs/inject.h"
#include "hs/kin.h"
#include "hs/scenario.h"
#include "sp/canopen/canopen_link.h"
#include "sp/link/node.h"
#include "host_os.h"
#include "socketcan.h"
#include "scenario_plant.h"

#define RX_BUF 64

/* The name of a state CTRL_STATUS reported (-1: none yet), or `none`. */
static const char *state_name(int state, const char *none)
{
    return (state >= 0) ? sp_state_name((sp_state_t)state) : none;
}

/* ---- run state ---------------------------------------------------------- */

typedef struct {
    sp_socketcan_t sc;
    sp_can_port_t port;
    const char *ifs[SP_CAN_BUSES];
    hs_plant_t plant;
    hs_bus_t bus;
    hs_scenario_t scn;
    int have_scenario;
    FILE *log;
    FILE *truth;
    uint8_t cmd_counter, target_counter;
    int status_state; /* last CTRL_STATUS state, -1 none */
    uint32_t status_faults;
    uint32_t status_tick, monitor_tick, wrench_tick;
    uint8_t status_seen, monitor_seen, wrench_seen;
    uint64_t ops_rejected;
    int lockstep;
    int progress;
    int64_t t0_ns;
    int64_t next_ns;   /* real time: the current cycle's deadline */
    uint32_t answered; /* real time: the last SYNC tick answered */
    int have_answered;
    double wrench_from[6], wrench_to[6]; /* the external wrench's ramp (scenario `wrench`) */
    uint64_t wrench_start, wrench_ticks;
    hs_play_t play; /* scenario `play` under way (file open) */
    uint64_t play_start;
    int canopen;                  /* --canopen: the drives are CiA 408 nodes (hs/co_bus.h), real time */
    int cia402;                   /* --cia402: ... CiA 402 nodes (cyclic synchronous position) */
    uint16_t sdo_delay_ms;        /* --sdo-delay-ms: each node answers an SDO request this late */
    hs_co_bus_t co;               /* their state */
    uint64_t co_sent;             /* frames the nodes sent */
    sp_can_frame_t co_rx[RX_BUF]; /* frames read, not yet handled (past the cycle's SYNC) */
    uint32_t co_rx_n, co_rx_i;
    uint64_t tick;      /* the current cycle */
    int wrench_source;  /* --wrench-source (--inproc): SP_WRENCH_*, -1 the config's */
    int estop_category; /* --estop-category (--inproc): 0 or 1, -1 the config's */
    uint32_t tick0;     /* --tick0: the SYNC tick of cycle 0 (test-only: the wrap tests) */
    hs_inject_t inj;    /* the fault injector on the bus (scenario `inject`) */
    /* --inproc: the controller (the firmware's node, as sp_controller --lockstep) in this process */
    int inproc;
    sp_node_config_t ncfg;
    sp_node_t node;
    uint64_t ctrl_delivered; /* frames handed to the controller */
    uint64_t ops_accepted;   /* controller frames the plant decoded */
    uint64_t ops_ignored;    /* other frames on the ops bus */
    uint8_t status_mode;     /* last CTRL_STATUS DriveMode */
    uint8_t refused_legs, refused_cause;
    double reference[6]; /* last CTRL_MONITOR reference */
    int have_reference;
    /* the fault report (first `inject` on) */
    int injected;
    uint64_t inject_tick, detect_tick;
    /* command authentication (--key, --session, CTRL_AUTH) */
    sp_auth_key_t key;
    int have_key;
    int session_known;
    uint32_t session;
    uint32_t auth_counter; /* the last counter used */
    uint64_t signed_frames, unsigned_frames;
    int detected;
    uint32_t detect_faults;
    int detect_state, detect_mode, reaction_state, reaction_mode;
    double safe_ref[6];
    double excursion_m, excursion_rad;
    int strokes_ok;
    hs_ft_t ft;                                          /* the force/torque sensor between platform and tool */
    uint8_t ft_counter;                                  /* FT_SENSOR's alive counter */
    int ft_silent;                                       /* scenario `ftsensor off`: the sensor sends nothing */
    uint8_t force_counter;                               /* OP_FORCE's alive counter */
    uint8_t frame_counter;                               /* OP_FRAME's alive counter */
    double push[6];                                      /* scenario `push`: its peak wrench */
    uint64_t push_start, push_rise, push_hold, push_end; /* ticks; push_end 0: none */
    /* --control: scenario lines at run time */
    int live_fd; /* -1: none */
    char live_buf[16384];
    size_t live_n;          /* bytes in live_buf, complete lines and a partial one */
    int live_busy;          /* live_scn holds a request being played */
    int live_overflow;      /* a line longer than the buffer is being skipped */
    hs_scenario_t live_scn; /* the request being played */
    char live_line[HS_SCENARIO_MAX_LINE + 2];
    /* --stats: the real-time loop's deadline misses */
    int64_t stats_every_ns, stats_due_ns;
    uint64_t rt_misses;
    uint64_t rt_skipped; /* periods skipped ahead (too far behind), missed too */
    int64_t rt_worst_late_ns;
} sim_t;

static void log_frame(sim_t *s, const sp_can_frame_t *f, uint64_t t_us)
{
    if (s->log == NULL || f->bus >= SP_CAN_BUSES) {
        return;
    }
    fprintf(s->log, "(%010" PRIu64 ".%06" PRIu64 ") %s %03X", t_us / 1000000u, t_us % 1000000u, s->ifs[f->bus],
            (unsigned)f->id);
    if (f->flags & SP_CAN_FLAG_FD) {
        fprintf(s->log, "##%X", (unsigned)((f->flags & SP_CAN_FLAG_BRS) ? 1u : 0u));
    } else {
        fputc('#', s->log);
    }
    for (unsigned i = 0; i < f->len; i++) {
        fprintf(s->log, "%02X", f->data[i]);
    }
    fputc('\n', s->log);
}

/* Does the controller (sp_controller's socket filters) receive frame f? */
static int controller_listens(const sp_can_frame_t *f)
{
    if (f->bus == SP_BUS_OPS) {
        return f->id == SP_ID_OP_COMMAND || f->id == SP_ID_OP_TARGET_POSE || f->id == SP_ID_OP_HEARTBEAT ||
               f->id == SP_ID_OP_FORCE || f->id == SP_ID_OP_FORCE_PARAMS || f->id == SP_ID_OP_FRAME ||
               f->id == SP_ID_OP_REACH;
    }
    if (f->bus == SP_BUS_AXIS_B && f->id == SP_ID_FT_SENSOR) {
        return 1;
    }
    return f->id == SP_ID_SYNC || (f->id >= SP_ID_AXIS_FEEDBACK_1 && f->id < SP_ID_AXIS_FEEDBACK_1 + SP_AXIS_SLOTS);
}

/* Signs the operator's authenticated frames among in[0..n)
 * (sp_proto_frame_needs_auth: OP_TARGET_POSE, OP_FORCE, OP_FORCE_PARAMS,
 * OP_COMMAND but NONE, STOP, PARK, ESTOP) with the next counter; without a
 * key or a session they go unsigned (counted). The scenario language sends
 * no OP_FORCE_PARAMS today (the controller's configured admittance serves
 * its runs); one it sent would be signed here like the others. */
static void sign_frames(sim_t *s, sp_can_frame_t *f, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++) {
        if (f[i].bus != SP_BUS_OPS || !sp_proto_frame_needs_auth(&f[i])) {
            continue;
        }
        if (s->have_key && s->session_known && s->auth_counter < UINT32_MAX &&
            sp_proto_sign(&f[i], &s->key, s->session, s->auth_counter + 1u) == SP_OK) {
            s->auth_counter++;
            s->signed_frames++;
        } else {
            if (s->unsigned_frames == 0u) {
                fprintf(stderr, "hs_sim: %s: operator frames go unsigned (a controller with a key refuses them)\n",
                        s->have_key ? "no session from the controller yet" : "no machine key (--key or STEWART_KEY)");
            }
            s->unsigned_frames++;
        }
    }
}

static int send_frames(sim_t *s, const sp_can_frame_t *in_const, uint32_t n_in, uint64_t t_us)
{
    static sp_can_frame_t f[4 * HS_INJ_MAX_OUT];
    static sp_can_frame_t in[4 * HS_INJ_MAX_OUT];
    uint32_t n = 0, sent = 0;
    if (n_in > 4 * HS_INJ_MAX_OUT) {
        return -1;
    }
    memcpy(in, in_const, n_in * sizeof in[0]);
    sign_frames(s, in, n_in);
    (void)hs_inject_filter(&s->inj, HS_INJ_TO_CONTROLLER, s->tick, in, n_in, f, 4 * HS_INJ_MAX_OUT, &n);
    sp_status_t st = SP_OK;
    if (s->inproc) {
        for (uint32_t i = 0; i < n; i++) {
            if (controller_listens(&f[i])) {
                s->ctrl_delivered++;
                (void)sp_node_receive(&s->node, &f[i], NULL);
            }
        }
        sent = n;
    } else if (n > 0u) {
        st = s->port.send(s->port.ctx, f, n, &sent);
    }
    for (uint32_t i = 0; i < sent; i++) {
        log_frame(s, &f[i], t_us);
    }
    if (st != SP_OK || sent != n) {
        fprintf(stderr, "hs_sim: send failed (%s): %u of %u frames\n", sp_status_name(st), sent, n);
        return -1;
    }
    return 0;
}

/* Handles a received frame (everything but the log). */
static void take_frame(sim_t *s, const sp_can_frame_t *f)
{
    if (f->bus == SP_BUS_OPS) {
        sp_proto_error_t why;
        uint8_t ctr;
        if (f->id == SP_ID_CTRL_STATUS) {
            sp_msg_status_t m;
            if (sp_proto_decode_status(f, &m, &ctr, &why) == SP_OK) {
                s->status_state = m.state;
                s->status_faults = m.faults;
                s->status_tick = m.tick;
                s->status_seen = 1;
                s->status_mode = m.drive_mode;
                s->refused_legs = m.reset_refused_legs;
                s->refused_cause = m.reset_refused_cause;
                s->ops_accepted++;
            } else {
                s->ops_rejected++;
            }
        } else if (f->id == SP_ID_CTRL_MONITOR) {
            sp_msg_monitor_t m;
            if (sp_proto_decode_monitor(f, &m, &ctr, &why) == SP_OK) {
                s->monitor_tick = m.tick;
                s->monitor_seen = 1;
                for (int k = 0; k < 3; k++) {
                    s->reference[k] = (double)m.reference.pos[k] / 16777216.0;
                    s->reference[3 + k] = (double)m.reference.rpy[k] / 16777216.0;
                }
                s->have_reference = 1;
                s->ops_accepted++;
            } else {
                s->ops_rejected++;
            }
        } else if (f->id == SP_ID_CTRL_WRENCH) {
            sp_msg_wrench_t m;
            if (sp_proto_decode_wrench(f, &m, &ctr, &why) == SP_OK) {
                s->wrench_tick = m.tick;
                s->wrench_seen = 1;
                s->ops_accepted++;
            } else {
                s->ops_rejected++;
            }
        } else if (f->id == SP_ID_CTRL_AUTH) {
            sp_msg_auth_t m;
            if (sp_proto_decode_auth(f, &m, &ctr, &why) == SP_OK) {
                if (!s->session_known || m.session != s->session) {
                    s->session = m.session; /* a new session: its counters start again */
                    s->auth_counter = m.last_counter;
                    s->session_known = 1;
                } else if (m.last_counter > s->auth_counter) {
                    s->auth_counter = m.last_counter; /* another operator went past us */
                }
                s->ops_accepted++;
            } else {
                s->ops_rejected++;
            }
        } else {
            s->ops_ignored++; /* another operator's command or target */
        }
        return;
    }
    (void)hs_bus_receive(&s->bus, &s->plant, f);
}

static sp_q24_t q24(double v)
{
    return (sp_q24_t)llround(v * 16777216.0);
}

static int send_target(sim_t *s, const sp_pose_t *pose, uint64_t t_us)
{
    sp_can_frame_t f;
    (void)sp_proto_encode_target(pose, s->target_counter, &f);
    s->target_counter = (uint8_t)((s->target_counter + 1u) & 0x0Fu);
    return send_frames(s, &f, 1u, t_us);
}

/* The force/torque sensor's newest sample as FT_SENSOR on axis_b (before
 * the cycle's SYNC, so that the controller uses it in the same tick). */
static int send_ft(sim_t *s, uint64_t t_us)
{
    if (s->ft_silent) {
        return 0;
    }
    sp_msg_ft_t m;
    sp_can_frame_t f;
    for (int k = 0; k < 6; k++) {
        double q = s->ft.reading[k] * 256.0;
        q = (q > 2.0e9) ? 2.0e9 : ((q < -2.0e9) ? -2.0e9 : q);
        m.wrench[k] = (sp_q8_t)llround(q);
    }
    m.saturated = (uint8_t)(s->ft.saturated ? 1u : 0u);
    (void)sp_proto_encode_ft(&m, s->ft_counter, &f); /* beyond the signal's range: saturated */
    s->ft_counter = (uint8_t)((s->ft_counter + 1u) & 0x0Fu);
    return send_frames(s, &f, 1u, t_us);
}

/* Advances the sensor to the end of the cycle just integrated. */
static void ft_advance(sim_t *s, uint64_t tick)
{
    hs_state_t st;
    double rot[3][3];
    (void)hs_plant_state(&s->plant, &st);
    hs_rot_from_quat(st.quat, rot);
    (void)hs_ft_advance(&s->ft, (double)tick * 1.0e-3, rot, st.wrench);
}

/* One tick of a `play` under way: the pose at this tick as OP_TARGET_POSE;
 * closes the file after the last row. 0 ok, 2 the file went bad, -1 I/O. */
static int play_tick(sim_t *s, uint64_t tick, uint64_t t_us)
{
    double pose[6];
    int done = 0;
    hs_scenario_error_t err;
    sp_pose_t p;
    if (s->play.file == NULL) {
        return 0;
    }
    if (hs_play_pose(&s->play, tick - s->play_start, pose, &done, &err) != HS_OK) {
        fprintf(stderr, "hs_sim: %s\n", err.message);
        hs_play_close(&s->play);
        return 2;
    }
    for (int k = 0; k < 3; k++) {
        p.pos[k] = q24(pose[k]);
        p.rpy[k] = q24(pose[3 + k]);
    }
    if (done) {
        hs_play_close(&s->play);
    }
    return send_target(s, &p, t_us) == 0 ? 0 : -1;
}

/* The share (0..1) of a push's peak at `tick`: a trapezoid. */
static double push_share(const sim_t *s, uint64_t tick)
{
    if (s->push_end == 0u || tick < s->push_start || tick >= s->push_end) {
        return 0.0;
    }
    uint64_t t = tick - s->push_start;
    if (t < s->push_rise) {
        return (double)t / (double)s->push_rise;
    }
    if (t < s->push_rise + s->push_hold) {
        return 1.0;
    }
    return (s->push_rise > 0u) ? (double)(s->push_end - tick) / (double)s->push_rise : 0.0;
}

/* The external wrench at `tick` on its ramp, plus a push under way. */
static void wrench_tick(sim_t *s, uint64_t tick)
{
    double w[6], f = 1.0;
    if (s->wrench_ticks > 0 && tick < s->wrench_start + s->wrench_ticks) {
        f = (double)(tick - s->wrench_start) / (double)s->wrench_ticks;
    }
    double p = push_share(s, tick);
    for (int k = 0; k < 6; k++) {
        w[k] = (f >= 1.0) ? s->wrench_to[k] : s->wrench_from[k] + f * (s->wrench_to[k] - s->wrench_from[k]);
        w[k] += p * s->push[k];
    }
    (void)hs_plant_set_wrench(&s->plant, w, &w[3]);
}

/* Removes every injected fault (frames, buses, drives, sensors, valves, supply). */
static void clear_injections(sim_t *s)
{
    hs_inject_clear_rules(&s->inj);
    for (uint8_t b = 0; b < SP_CAN_BUSES; b++) {
        (void)hs_inject_busoff(&s->inj, b, 0u);
    }
    s->bus.frozen_mask = 0u;
    s->bus.stale_mask = 0u;
    for (int i = 0; i < HS_LEGS; i++) {
        (void)hs_plant_inject_drive(&s->plant, i, 0u);
        (void)hs_plant_inject_sensor(&s->plant, i, HS_SENSOR_OK, 0.0);
        (void)hs_plant_inject_valve(&s->plant, i, 0, 0.0);
    }
    (void)hs_plant_inject_supply(&s->plant, 0);
}

/* A scenario `inject` (hs/scenario.h, "Fault injection"). 0 done, -1 refused. */
static int apply_inject(sim_t *s, const hs_scenario_inject_t *in, uint64_t tick)
{
    hs_status_t st = HS_OK;
    uint8_t bit = (uint8_t)(1u << (in->leg & 7));
    if (in->what != HS_INJECT_CLEAR && !s->injected) {
        s->injected = 1;
        s->inject_tick = tick;
    }
    switch (in->what) {
    case HS_INJECT_FRAMES: {
        hs_frame_rule_t r = {(uint8_t)in->bus, in->id_lo, in->id_hi, (hs_frame_fault_t)in->fault,
                             in->rate,         in->count, in->delay};
        st = hs_inject_add(&s->inj, &r);
        break;
    }
    case HS_INJECT_FRAMES_OFF:
        hs_inject_clear_rules(&s->inj);
        break;
    case HS_INJECT_BUSOFF:
        st = hs_inject_busoff(&s->inj, (uint8_t)in->bus,
                              in->mode == 0 ? 0u : (in->ticks == 0u ? UINT64_MAX : tick + in->ticks));
        break;
    case HS_INJECT_DRIVE:
        if (in->mode == 0) {
            st = in->hold ? hs_plant_inject_drive(&s->plant, in->leg, in->bits)
                          : hs_plant_raise_faults(&s->plant, in->leg, in->bits);
        } else if (in->mode == 1) {
            s->bus.frozen_mask = (uint8_t)(s->bus.frozen_mask | bit);
        } else if (in->mode == 2) {
            s->bus.stale_mask = (uint8_t)(s->bus.stale_mask | bit);
            s->bus.stale_ticks = (uint16_t)in->ticks;
        } else {
            s->bus.frozen_mask = (uint8_t)(s->bus.frozen_mask & ~bit);
            s->bus.stale_mask = (uint8_t)(s->bus.stale_mask & ~bit);
            st = hs_plant_inject_drive(&s->plant, in->leg, 0u);
        }
        break;
    case HS_INJECT_SENSOR:
        st = hs_plant_inject_sensor(&s->plant, in->leg, (hs_sensor_fault_t)in->mode, in->value);
        break;
    case HS_INJECT_VALVE:
        st = hs_plant_inject_valve(&s->plant, in->leg, in->mode, in->value);
        break;
    case HS_INJECT_SUPPLY:
        st = hs_plant_inject_supply(&s->plant, in->mode);
        break;
    case HS_INJECT_ENDSTOP:
        st = hs_plant_inject_valve(&s->plant, in->leg, 1, in->value);
        break;
    case HS_INJECT_FK:
        for (int i = 0; i < HS_LEGS && st == HS_OK; i++) {
            st = hs_plant_inject_sensor(&s->plant, i, HS_SENSOR_JUMP, (i % 2 == 0) ? in->value : -in->value);
        }
        break;
    case HS_INJECT_CLEAR:
    default:
        clear_injections(s);
        break;
    }
    static const char *const what[] = {"frames", "frames off", "busoff",  "drive", "sensor",
                                       "valve",  "supply",     "endstop", "fk",    "clear"};
    printf("hs_sim mark tick %" PRIu64 ": inject %s\n", tick,
           (in->what >= 0 && in->what <= HS_INJECT_CLEAR) ? what[in->what] : "?");
    return (st == HS_OK) ? 0 : -1;
}

/* Scenario `cmd`: OP_COMMAND. 0 sent, -1 error. */
static int action_cmd(sim_t *s, const hs_action_t *a, uint64_t tick, uint64_t t_us)
{
    sp_can_frame_t f;
    (void)sp_proto_encode_command(&a->cmd, s->cmd_counter, &f);
    s->cmd_counter = (uint8_t)((s->cmd_counter + 1u) & 0x0Fu);
    if (s->progress) {
        fprintf(stderr, "hs_sim: t=%8.3f s  command %s\n", (double)tick / 1000.0,
                hs_scenario_command_name(a->cmd.command));
    }
    return send_frames(s, &f, 1u, t_us);
}

/* Scenario `wrench`: a new ramp from the wrench acting now (a ramp under
 * way stops where it is) to the action's. */
static void action_wrench(sim_t *s, const hs_action_t *a, uint64_t tick)
{
    for (int k = 0; k < 6; k++) { /* the ramp's own value now (a push is not part of it) */
        double f = (s->wrench_ticks > 0 && tick < s->wrench_start + s->wrench_ticks)
                       ? (double)(tick - s->wrench_start) / (double)s->wrench_ticks
                       : 1.0;
        s->wrench_from[k] = s->wrench_from[k] + f * (s->wrench_to[k] - s->wrench_from[k]);
    }
    memcpy(s->wrench_to, a->wrench, sizeof s->wrench_to);
    s->wrench_start = tick;
    s->wrench_ticks = a->ticks;
    wrench_tick(s, tick);
    printf("hs_sim mark tick %" PRIu64 ": wrench %g %g %g %g %g %g ramp %.3f s\n", tick, a->wrench[0], a->wrench[1],
           a->wrench[2], a->wrench[3], a->wrench[4], a->wrench[5], (double)a->ticks / 1000.0);
}

/* Scenario `contact`. 0 done, 2 refused. */
static int action_contact(sim_t *s, const hs_action_t *a, uint64_t tick)
{
    double start_force = 0.0;
    hs_status_t st = hs_scenario_set_contact(&s->plant, &a->contact, &start_force);
    if (st == HS_E_RANGE) {
        fprintf(stderr,
                "hs_sim: scenario line %d: contact refused: it would push with %.0f kN the moment it is placed "
                "(at most %.0f kN): place the surface at the platform's point, not through it\n",
                a->line, start_force / 1000.0, HS_CONTACT_START_FORCE_MAX / 1000.0);
        return 2;
    }
    if (st != HS_OK) {
        fprintf(stderr, "hs_sim: scenario line %d: contact refused\n", a->line);
        return 2;
    }
    printf("hs_sim mark tick %" PRIu64 ": contact %s\n", tick,
           a->contact.kind == 1 ? "plane" : (a->contact.kind == 2 ? "point" : "off"));
    return 0;
}

/* Scenario `load`. 0 done, 2 refused (not a rigid body). */
static int action_load(sim_t *s, const hs_action_t *a, uint64_t tick)
{
    if (hs_plant_add_mass(&s->plant, a->mass, a->point) != HS_OK) {
        fprintf(stderr,
                "hs_sim: scenario line %d: load %g kg at (%g, %g, %g) m refused: the platform would not be a "
                "rigid body (mass %g kg now)\n",
                a->line, a->mass, a->point[0], a->point[1], a->point[2], s->plant.par.mass);
        return 2;
    }
    printf("hs_sim mark tick %" PRIu64 ": load %g kg at %g %g %g\n", tick, a->mass, a->point[0], a->point[1],
           a->point[2]);
    return 0;
}

/* Scenario `play`: opens the file and sends its first pose. 0 done, 2 the
 * file refused, -1 I/O. */
static int action_play(sim_t *s, const hs_action_t *a, uint64_t tick, uint64_t t_us)
{
    hs_scenario_error_t err;
    hs_play_close(&s->play);
    if (hs_play_open(&s->play, a->path, &err) != HS_OK) {
        fprintf(stderr, "hs_sim: scenario line %d: %s\n", a->line, err.message);
        return 2;
    }
    s->play_start = tick;
    printf("hs_sim mark tick %" PRIu64 ": play %s (%.3f s)\n", tick, a->path, (double)a->ticks / 1000.0);
    return play_tick(s, tick, t_us);
}

/* Scenario `force`, `force_target`, `guide`: OP_FORCE, then OP_COMMAND
 * unless the action has none. 0 sent, -1 error. */
static int action_force(sim_t *s, const hs_action_t *a, uint64_t tick, uint64_t t_us)
{
    sp_can_frame_t f[2];
    uint32_t n = 1u;
    (void)sp_proto_encode_force(&a->force, s->force_counter, &f[0]);
    s->force_counter = (uint8_t)((s->force_counter + 1u) & 0x0Fu);
    if (a->cmd.command != 0u) {
        (void)sp_proto_encode_command(&a->cmd, s->cmd_counter, &f[1]);
        s->cmd_counter = (uint8_t)((s->cmd_counter + 1u) & 0x0Fu);
        n = 2u;
    }
    printf("hs_sim mark tick %" PRIu64 ": %s mask 0x%02x target %g %g %g %g %g %g\n", tick,
           a->cmd.command != 0u ? hs_scenario_command_name(a->cmd.command) : "force_target", (unsigned)a->force.mask,
           a->force.target[0] / 256.0, a->force.target[1] / 256.0, a->force.target[2] / 256.0,
           a->force.target[3] / 256.0, a->force.target[4] / 256.0, a->force.target[5] / 256.0);
    return send_frames(s, f, n, t_us);
}

/* Scenario `frame`: OP_FRAME (issue 31), signed like every command that
 * changes motion. 0 sent, -1 error. */
static int action_frame(sim_t *s, const hs_action_t *a, uint64_t tick, uint64_t t_us)
{
    sp_msg_frame_t m;
    sp_can_frame_t f;
    const hs_scenario_frame_t *fr = &a->frame;
    memset(&m, 0, sizeof m);
    m.op = (uint8_t)fr->op;
    m.kind = (uint8_t)fr->kind;
    m.index = (uint8_t)fr->index;
    for (int k = 0; k < 3; ++k) { /* |v| <= 8 (the parser): within Q24 */
        m.value.pos[k] = (sp_q24_t)lround(fr->value[k] * 16777216.0);
        m.value.rpy[k] = (sp_q24_t)lround(fr->value[3 + k] * 16777216.0);
    }
    (void)sp_proto_encode_frame(&m, s->frame_counter, &f);
    s->frame_counter = (uint8_t)((s->frame_counter + 1u) & 0x0Fu);
    printf("hs_sim mark tick %" PRIu64 ": frame %s %s %d %g %g %g %g %g %g\n", tick, fr->kind ? "work" : "tool",
           fr->op ? "set" : "select", fr->index, fr->value[0], fr->value[1], fr->value[2], fr->value[3], fr->value[4],
           fr->value[5]);
    return send_frames(s, &f, 1u, t_us);
}

/* Scenario `push`: a trapezoid from this tick on (replaces one under way). */
static void action_push(sim_t *s, const hs_action_t *a, uint64_t tick)
{
    memcpy(s->push, a->wrench, sizeof s->push);
    s->push_start = tick;
    s->push_rise = a->ticks;
    s->push_hold = a->hold;
    s->push_end = tick + 2u * a->ticks + a->hold;
    if (s->push_end == tick) {
        s->push_end = 0u; /* rise and hold 0: nothing */
    }
    wrench_tick(s, tick);
    printf("hs_sim mark tick %" PRIu64 ": push %g %g %g %g %g %g rise %.3f s hold %.3f s\n", tick, a->wrench[0],
           a->wrench[1], a->wrench[2], a->wrench[3], a->wrench[4], a->wrench[5], (double)a->ticks / 1000.0,
           (double)a->hold / 1000.0);
}

/* Scenario `silence`, `unsilence`, `fault`: one leg's drive. */
static void action_leg(sim_t *s, const hs_action_t *a, uint64_t tick)
{
    const char *what = "fault";
    if (a->kind == HS_ACTION_SILENCE) {
        s->bus.silent_mask = (uint8_t)(s->bus.silent_mask | (1u << a->leg));
        what = "silence";
    } else if (a->kind == HS_ACTION_UNSILENCE) {
        s->bus.silent_mask = (uint8_t)(s->bus.silent_mask & ~(1u << a->leg));
        what = "unsilence";
    } else {
        (void)hs_plant_raise_faults(&s->plant, a->leg, a->bits);
    }
    printf("hs_sim mark tick %" PRIu64 ": %s leg %d\n", tick, what, a->leg + 1);
}

/* Carries out one action (what it does on the bus or to the plant).
 * Returns 0 done, 2 refused, -1 error. */
static int run_action(sim_t *s, const hs_action_t *a, uint64_t tick, uint64_t t_us)
{
    switch (a->kind) {
    case HS_ACTION_CMD:
        return action_cmd(s, a, tick, t_us);
    case HS_ACTION_TARGET:
        return send_target(s, &a->target, t_us);
    case HS_ACTION_WRENCH:
        action_wrench(s, a, tick);
        return 0;
    case HS_ACTION_CONTACT:
        return action_contact(s, a, tick);
    case HS_ACTION_LOAD:
        return action_load(s, a, tick);
    case HS_ACTION_PLAY:
        return action_play(s, a, tick, t_us);
    case HS_ACTION_FORCE:
        return action_force(s, a, tick, t_us);
    case HS_ACTION_PUSH:
        action_push(s, a, tick);
        return 0;
    case HS_ACTION_FRAME:
        return action_frame(s, a, tick, t_us);
    case HS_ACTION_FTSENSOR:
        s->ft_silent = (a->bits == 0u);
        printf("hs_sim mark tick %" PRIu64 ": ftsensor %s\n", tick, s->ft_silent ? "off" : "on");
        return 0;
    case HS_ACTION_WAIT:
        if (s->progress) {
            fprintf(stderr, "hs_sim: t=%8.3f s  state %s\n", (double)tick / 1000.0, sp_state_name(a->state));
        }
        return 0;
    case HS_ACTION_SILENCE:
    case HS_ACTION_UNSILENCE:
    case HS_ACTION_FAULT:
        action_leg(s, a, tick);
        return 0;
    case HS_ACTION_MARK:
        printf("hs_sim mark tick %" PRIu64 ": %s\n", tick, a->text);
        return 0;
    case HS_ACTION_INJECT:
        if (apply_inject(s, &a->inject, tick) != 0) {
            fprintf(stderr, "hs_sim: scenario line %d: injection refused\n", a->line);
            return 2;
        }
        return 0;
    case HS_ACTION_DELAY:
    case HS_ACTION_END:
        break;
    }
    return 0;
}

/* Carries out the scenario's actions due at `tick` (hs/scenario.h plays it).
 * Returns 0 go on, 1 end, 2 an action refused (load, contact), 4 wait timeout, -1 error. */
static int run_scenario(sim_t *s, hs_scenario_t *scn, uint64_t tick, uint64_t t_us)
{
    /* each round hands over one action: at most all of them, then the end */
    for (int guard = 0; guard <= HS_SCENARIO_MAX_ACTIONS; guard++) {
        const hs_action_t *a = NULL;
        hs_scenario_next_t next = hs_scenario_next(scn, tick, s->status_state, &a);
        if (next == HS_SCENARIO_PENDING) {
            return 0;
        }
        if (next == HS_SCENARIO_END) {
            return 1;
        }
        if (next == HS_SCENARIO_TIMEOUT) {
            fprintf(stderr, "hs_sim: scenario line %d: state %s not reached within %.3f s (now %s, faults 0x%04x)\n",
                    a->line, sp_state_name(a->state), (double)a->ticks / 1000.0, state_name(s->status_state, "unknown"),
                    (unsigned)s->status_faults);
            return 4;
        }
        int r = run_action(s, a, tick, t_us);
        if (r != 0) {
            return r;
        }
        fflush(stdout);
    }
    return 0;
}

/* ---- --control: scenario lines at run time ------------------------------ */

/* Opens the control file without blocking (a FIFO read-write, so that it
 * never reads as ended when a writer closes it). 0 ok, 1 error (said). */
static int live_open(sim_t *s, const char *path)
{
    struct stat st;
    int flags = O_NONBLOCK | O_CLOEXEC;
    flags |= (stat(path, &st) == 0 && S_ISFIFO(st.st_mode)) ? O_RDWR : O_RDONLY;
    s->live_fd = open(path, flags);
    if (s->live_fd < 0) {
        fprintf(stderr, "hs_sim: cannot open --control %s: %s\n", path, strerror(errno));
        return 1;
    }
    return 0;
}

/* Reads what has come, never blocking. A full buffer without a line end is
 * a line too long: it is dropped up to its end (answered when that comes). */
static void live_read(sim_t *s)
{
    for (int rounds = 0; rounds < 4; rounds++) {
        if (s->live_n == sizeof s->live_buf && memchr(s->live_buf, '\n', s->live_n) == NULL) {
            s->live_n = 0, s->live_overflow = 1;
        }
        size_t room = sizeof s->live_buf - s->live_n;
        if (room == 0) {
            return;
        }
        ssize_t r = read(s->live_fd, s->live_buf + s->live_n, room);
        if (r <= 0) {
            return;
        }
        s->live_n += (size_t)r;
    }
}

/* The next complete line into s->live_line, taken from the buffer.
 * Returns 1 a line, 0 none yet, 2 a line refused for its length (answered). */
static int live_next_line(sim_t *s)
{
    char *nl = memchr(s->live_buf, '\n', s->live_n);
    if (nl == NULL) {
        return 0;
    }
    size_t len = (size_t)(nl - s->live_buf);
    int too_long = s->live_overflow || len > HS_SCENARIO_MAX_LINE;
    if (!too_long) {
        memcpy(s->live_line, s->live_buf, len);
        s->live_line[len] = '\0';
    }
    memmove(s->live_buf, nl + 1, s->live_n - len - 1);
    s->live_n -= len + 1;
    s->live_overflow = 0;
    if (too_long) {
        printf("hs_sim control: refused: a line longer than %d characters\n", HS_SCENARIO_MAX_LINE);
        return 2;
    }
    return 1;
}

/* Parses the line taken and plays what is due of it now; answers it. */
static void live_start(sim_t *s, uint64_t tick, uint64_t t_us)
{
    hs_scenario_error_t err;
    if (hs_scenario_parse(&s->live_scn, s->live_line, "control", &err) != HS_OK) {
        printf("hs_sim control: refused: %s\n", err.message);
        return;
    }
    int r = run_scenario(s, &s->live_scn, tick, t_us);
    if (r == 0 || r == 1) {
        printf("hs_sim control: accepted: %s\n", s->live_line);
        s->live_busy = (r == 0);
    } else {
        printf("hs_sim control: refused: %s: %s\n", s->live_line,
               r == 4 ? "the state was not reached in time" : "the plant refused it (stderr says why)");
    }
}

/* --control at `tick`: new lines read, the request under way played, the
 * next ones started while nothing holds them back. */
static void live_tick(sim_t *s, uint64_t tick, uint64_t t_us)
{
    if (s->live_fd < 0) {
        return;
    }
    live_read(s);
    for (int guard = 0; guard < 64; guard++) {
        if (s->live_busy) {
            int r = run_scenario(s, &s->live_scn, tick, t_us);
            if (r == 0) {
                break;
            }
            s->live_busy = 0;
            if (r != 1) {
                printf("hs_sim control: failed: %s: %s\n", s->live_line,
                       r == 4 ? "the state was not reached in time" : "the plant refused it");
            }
        }
        int got = live_next_line(s);
        if (got == 0) {
            break;
        }
        if (got == 1) {
            live_start(s, tick, t_us);
        }
    }
    fflush(stdout);
}

/* --stats: the real-time loop's figures so far, on stderr. */
static void rt_print(const sim_t *s)
{
    uint64_t due = s->tick + s->rt_skipped; /* the periods that have passed */
    fprintf(stderr, "hs_sim stats: cycles %" PRIu64 ", deadline misses %" PRIu64 " (%.3f %%), worst late %.3f ms\n",
            s->tick, s->rt_misses, due ? 100.0 * (double)s->rt_misses / (double)due : 0.0,
            (double)s->rt_worst_late_ns * 1e-6);
}

/* Real time: the plant catches up (cycles back to back) while it is behind
 * by at most this much, ns; beyond, it skips ahead (a host that cannot keep
 * up: a plant that never sleeps would starve everything else there). */
#define RT_CATCH_UP_NS 20000000

/* Real time, at a cycle's start: a miss when it starts more than a period
 * after its own start time (and each period skipped ahead); the stats line
 * when due. */
static void rt_account(sim_t *s)
{
    int64_t now = sp_host_now_ns();
    int64_t late = now - s->next_ns;
    if (late > s->rt_worst_late_ns) {
        s->rt_worst_late_ns = late;
    }
    if (late > 1000000) {
        s->rt_misses++;
    }
    if (late > RT_CATCH_UP_NS) { /* too far behind to catch up: the cycles skipped are missed, time goes on */
        int64_t skip = late / 1000000;
        s->rt_misses += (uint64_t)skip;
        s->rt_skipped += (uint64_t)skip;
        s->next_ns += skip * 1000000;
    }
    if (s->stats_every_ns > 0 && now >= s->stats_due_ns) {
        rt_print(s);
        s->stats_due_ns = now + s->stats_every_ns;
    }
}

static void write_truth(sim_t *s, uint64_t tick)
{
    if (s->truth == NULL) {
        return;
    }
    hs_state_t st;
    (void)hs_plant_state(&s->plant, &st);
    fprintf(s->truth, "%" PRIu64, tick);
    for (int i = 0; i < 6; i++) {
        fprintf(s->truth, ",%.9f", st.pose[i]);
    }
    for (int i = 0; i < HS_LEGS; i++) {
        fprintf(s->truth, ",%.9f", st.length[i]);
    }
    for (int i = 0; i < HS_LEGS; i++) {
        fprintf(s->truth, ",%.3f", st.force[i]);
    }
    for (int i = 0; i < HS_LEGS; i++) {
        fprintf(s->truth, ",%d", (int)s->plant.drive[i].state);
    }
    for (int k = 0; k < 6; k++) {
        fprintf(s->truth, ",%.3f", st.wrench[k]);
    }
    for (int i = 0; i < HS_LEGS; i++) {
        fprintf(s->truth, ",%.3f", st.friction[i]);
    }
    for (int i = 0; i < HS_LEGS; i++) {
        fprintf(s->truth, ",%.3f", st.block[i]);
    }
    fputc('\n', s->truth);
}

static void progress_line(sim_t *s, uint64_t tick)
{
    double pose[6];
    (void)hs_plant_pose(&s->plant, pose);
    double wall = (double)(sp_host_now_ns() - s->t0_ns) * 1e-9;
    fprintf(stderr,
            "hs_sim: t=%8.3f s  controller %-8s  pose x %+7.4f y %+7.4f z %6.4f m  yaw %+7.4f rad  (%.1fx real time)\n",
            (double)tick / 1000.0, state_name(s->status_state, "-"), pose[0], pose[1], pose[2], pose[5],
            wall > 0.0 ? (double)tick / 1000.0 / wall : 0.0);
}

/* Is the controller's answer to cycle `tick` complete in raw[0..n) (as it
 * sent it, before the injector): AXIS_SETPOINTS(tick) on both axis buses,
 * CTRL_STATUS(tick), CTRL_MONITOR(tick), and on even ticks CTRL_WRENCH(tick)?
 * The frames a tick sends only when due (CTRL_REACH, CTRL_IDENTITY,
 * CTRL_REFUSAL) come before its CTRL_STATUS on the ops bus (sp/link/node.h),
 * so once it is here they are too: the log's order is the same every run. */
static int answer_complete(const sp_can_frame_t *raw, uint32_t n, uint32_t tick, int canopen)
{
    /* with CANopen drives the master's frames (no AXIS_SETPOINTS) come before the ops frames */
    int sp[2] = {canopen, canopen}, st = 0, mon = 0, wr = (tick % SP_PROTO_WRENCH_PERIOD != 0u);
    /* CTRL_FRAMES (every 100 ticks, after CTRL_MONITOR): waited for like CTRL_WRENCH (native drives: the
     * controller's tick is this SYNC tick) */
    int fr = canopen || (tick % SP_PROTO_FRAMES_PERIOD != SP_PROTO_FRAMES_PHASE);
    for (uint32_t k = 0; k < n; k++) {
        const sp_can_frame_t *f = &raw[k];
        uint8_t ctr;
        sp_proto_error_t why;
        if (f->id == SP_ID_AXIS_SETPOINTS && (f->bus == SP_BUS_AXIS_A || f->bus == SP_BUS_AXIS_B)) {
            sp_msg_setpoints_t m;
            if (sp_proto_decode_setpoints(f, &m, &ctr, &why) == SP_OK && m.tick == tick) {
                sp[f->bus - SP_BUS_AXIS_A] = 1;
            }
        } else if (f->bus == SP_BUS_OPS && f->id == SP_ID_CTRL_STATUS) {
            sp_msg_status_t m;
            st |= (sp_proto_decode_status(f, &m, &ctr, &why) == SP_OK && m.tick == tick);
        } else if (f->bus == SP_BUS_OPS && f->id == SP_ID_CTRL_MONITOR) {
            sp_msg_monitor_t m;
            mon |= (sp_proto_decode_monitor(f, &m, &ctr, &why) == SP_OK && m.tick == tick);
        } else if (f->bus == SP_BUS_OPS && f->id == SP_ID_CTRL_WRENCH) {
            sp_msg_wrench_t m;
            wr |= (sp_proto_decode_wrench(f, &m, &ctr, &why) == SP_OK && m.tick == tick);
        } else if (f->bus == SP_BUS_OPS && f->id == SP_ID_CTRL_FRAMES) {
            fr = 1;
        }
    }
    return sp[0] && sp[1] && st && mon && wr && fr;
}

/* The controller's frames of one cycle through the injector to the plant,
 * logged bus by bus (within a bus in the order they came): the same order
 * every run. */
static void deliver_answer(sim_t *s, const sp_can_frame_t *raw, uint32_t n_raw, uint64_t t_us)
{
    static sp_can_frame_t f[4 * HS_INJ_MAX_OUT + 4 * RX_BUF];
    uint32_t n = 0;
    (void)hs_inject_filter(&s->inj, HS_INJ_TO_PLANT, s->tick, raw, n_raw, f, 4 * HS_INJ_MAX_OUT + 4 * RX_BUF, &n);
    for (uint32_t k = 0; k < n; k++) {
        take_frame(s, &f[k]);
    }
    for (uint8_t b = 0; b < SP_CAN_BUSES; b++) {
        for (uint32_t k = 0; k < n; k++) {
            if (f[k].bus == b) {
                log_frame(s, &f[k], t_us);
            }
        }
    }
}

/* --inproc: the controller's tick when the cycle's SYNC reached it on both
 * axis buses (as sp_controller --lockstep); its frames into raw. */
static uint32_t inproc_answer(sim_t *s, sp_can_frame_t raw[SP_NODE_MAX_TX])
{
    uint32_t t = 0, n = 0;
    if (sp_node_cycle_ready(&s->node, &t)) {
        (void)sp_node_tick(&s->ncfg, &s->node, raw, &n);
    }
    return n;
}

/* The first cycle waits at least 10 s: a controller that has just opened
 * its sockets on a loaded machine may take seconds to its first tick (the
 * start-up, not a silence of the loop); later cycles wait timeout_ms. */
static long cycle_timeout_ms(uint64_t cycle, long timeout_ms)
{
    return (cycle == 0u && timeout_ms < 10000) ? 10000 : timeout_ms;
}

/* Lockstep: one cycle's wait for the controller's answer (raw frames into
 * keep[0..*nkeep)). 0 ok, 3 silent, WAIT_STOPPED on SIGINT/SIGTERM, -1 error. */
#define WAIT_STOPPED 6
static int lockstep_wait(sim_t *s, uint32_t tick, sp_can_frame_t *keep, uint32_t *nkeep_out, uint32_t max_keep,
                         long timeout_ms)
{
    struct pollfd pfd = {sp_socketcan_fd(&s->sc), POLLIN, 0}; /* one socket serves all buses */
    uint32_t nkeep = 0;
    long waited_ms = 0; /* no clock reads per cycle: each one is a system call in user-mode Linux */
    *nkeep_out = 0;
    for (;;) {
        /* the controller answers after our SYNC: wait first, then read */
        int r = poll(&pfd, 1, 100);
        if (r < 0 && errno != EINTR) {
            perror("hs_sim: poll");
            return -1;
        }
        if (r == 0) {
            waited_ms += 100;
            if (waited_ms >= timeout_ms) {
                return 3;
            }
        }
        if (sp_host_stop_requested()) {
            return WAIT_STOPPED; /* asked to stop: not a silent controller */
        }
        uint32_t got = 0;
        do {
            sp_can_frame_t rx[RX_BUF];
            got = 0;
            (void)s->port.receive(s->port.ctx, rx, RX_BUF, &got);
            for (uint32_t k = 0; k < got; k++) {
                if (nkeep < max_keep) {
                    keep[nkeep++] = rx[k];
                }
            }
        } while (got == RX_BUF);
        /* CTRL_WRENCH comes on even ticks only (500 Hz), after CTRL_MONITOR: waited for, so
         * that it is logged in its own cycle whatever the scheduling */
        if (answer_complete(keep, nkeep, tick, s->canopen)) {
            break;
        }
    }
    *nkeep_out = nkeep;
    return 0;
}

/* The fault report, each cycle after the controller's answer: detection
 * (the first CTRL_STATUS with faults after the first `inject`), the
 * reaction, the excursion of the true pose from the last safe reference
 * (the reference while no fault is detected, then the one before the
 * detection), the legs against their strokes. */
static void track_faults(sim_t *s, uint64_t tick)
{
    if (s->inproc) { /* the controller's own reference: known even while the ops bus carries nothing */
        for (int k = 0; k < 3; k++) {
            s->reference[k] = (double)s->node.out.reference.pose.pos[k] / 16777216.0;
            s->reference[3 + k] = (double)s->node.out.reference.pose.rpy[k] / 16777216.0;
        }
        s->have_reference = 1;
    }
    if (!s->detected && s->have_reference && s->status_faults == 0u) {
        memcpy(s->safe_ref, s->reference, sizeof s->safe_ref); /* the last reference without a fault */
    }
    if (!s->injected || tick < s->inject_tick) {
        return;
    }
    if (!s->detected &&
        (s->status_faults != 0u || s->status_state == SP_STATE_FAULT || s->status_state == SP_STATE_ESTOP)) {
        s->detected = 1;
        s->detect_tick = tick;
        s->detect_faults = s->status_faults;
        s->detect_state = s->status_state;
        s->detect_mode = s->status_mode;
        s->reaction_state = s->status_state;
        s->reaction_mode = s->status_mode;
    }
    if (s->detected && tick == s->detect_tick + 20u) { /* the reaction settled */
        s->reaction_state = s->status_state;
        s->reaction_mode = s->status_mode;
    }
    hs_state_t st;
    (void)hs_plant_state(&s->plant, &st);
    double dp = 0.0, dr = 0.0;
    for (int k = 0; k < 3; k++) {
        dp += (st.pose[k] - s->safe_ref[k]) * (st.pose[k] - s->safe_ref[k]);
        double a = fabs(st.pose[3 + k] - s->safe_ref[3 + k]);
        dr = (a > dr) ? a : dr;
    }
    dp = sqrt(dp);
    s->excursion_m = (dp > s->excursion_m) ? dp : s->excursion_m;
    s->excursion_rad = (dr > s->excursion_rad) ? dr : s->excursion_rad;
    for (int i = 0; i < HS_LEGS; i++) {
        const hs_cyl_params_t *c = &s->plant.par.cyl[i];
        double stroke = st.length[i] - c->length_min;
        if (stroke < 0.0 || stroke > c->stroke) {
            s->strokes_ok = 0;
        }
    }
}

/* The fault report's line (after the first `inject`). */
static void print_fault_report(sim_t *s)
{
    hs_state_t st;
    (void)hs_plant_state(&s->plant, &st);
    double v = sqrt(st.vel[0] * st.vel[0] + st.vel[1] * st.vel[1] + st.vel[2] * st.vel[2]);
    double w = sqrt(st.omega_base[0] * st.omega_base[0] + st.omega_base[1] * st.omega_base[1] +
                    st.omega_base[2] * st.omega_base[2]);
    int rest = v < 1e-3 && w < 1e-3;
    const hs_inject_stats_t *is = &s->inj.stats;
    printf("hs_sim injector: in %u out %u dropped %u busoff %u delayed %u duplicated %u reordered %u corrupted %u "
           "pending %u\n",
           is->in, is->out, is->dropped, is->busoff, is->delayed, is->duplicated, is->reordered, is->corrupted,
           is->pending);
    long long unaccounted = -1;
    if (s->inproc) {
        const sp_node_stats_t *ns = &s->node.stats;
        long long ctrl = (long long)ns->accepted + ns->stale;
        long long plant = (long long)s->bus.stats.accepted + s->bus.stats.ignored + (long long)s->ops_accepted +
                          (long long)s->ops_rejected + (long long)s->ops_ignored;
        for (int e = 0; e < SP_PROTO_ERRORS; e++) {
            ctrl += ns->rejected[e];
            plant += s->bus.stats.rejected[e];
        }
        /* everything sent: delivered and counted by its receiver, or counted by the injector */
        unaccounted = (long long)is->in + is->duplicated - is->dropped - is->busoff - is->pending - ctrl - plant;
        printf("hs_sim controller frames: delivered %" PRIu64 " accepted %u stale %u lost %u rejected",
               s->ctrl_delivered, ns->accepted, ns->stale, ns->lost);
        for (int e = 1; e < SP_PROTO_ERRORS; e++) {
            printf(" %s %u", sp_proto_error_name((sp_proto_error_t)e), ns->rejected[e]);
        }
        printf("\n");
    }
    printf("hs_sim fault-report: inject %" PRIu64 " detected %s after %lld ticks faults 0x%04x reaction %s/%s "
           "final %s/0x%04x rest %s excursion %.3f mm %.3f mrad strokes %s unaccounted %lld refused-legs 0x%02x "
           "refused-cause 0x%02x\n",
           s->inject_tick, s->detected ? "yes" : "no",
           s->detected ? (long long)(s->detect_tick - s->inject_tick) : -1LL, (unsigned)s->detect_faults,
           state_name(s->detected ? s->reaction_state : s->status_state, "none"),
           (s->detected ? s->reaction_mode : s->status_mode) ? "active" : "hold", state_name(s->status_state, "none"),
           (unsigned)s->status_faults, rest ? "yes" : "no", s->excursion_m * 1e3, s->excursion_rad * 1e3,
           s->strokes_ok ? "yes" : "no", unaccounted, (unsigned)s->refused_legs, (unsigned)s->refused_cause);
}

/* ---- command line ------------------------------------------------------- */

/* What the command line sets besides the run state's own fields (s). */
typedef struct {
    sim_t *s;
    const char *scenario, *log_path, *truth_path, *key_path, *control;
    unsigned long long max_ticks; /* 0: no limit */
    unsigned long long seed;
    int have_seed;
    uint32_t sp_timeout; /* the drives' setpoint watchdog in cycles, 0: the config's */
    long timeout_ms;
    double load[4];
    int have_load;
    const char *as_built; /* --as-built FILE: the machine as built, NULL: as the config's */
} cli_t;

static int parse_u64(const char *v, unsigned long long *out)
{
    char *end;
    errno = 0;
    *out = strtoull(v, &end, 0);
    return (errno == 0 && end != v && *end == '\0' && v[0] != '-') ? 0 : -1;
}

/* An unsigned number lo..hi. 0 ok, -1 not. */
static int parse_range(const char *v, unsigned long long lo, unsigned long long hi, unsigned long long *out)
{
    return (parse_u64(v, out) == 0 && *out >= lo && *out <= hi) ? 0 : -1;
}

/* "MASS,X,Y,Z": four finite numbers. 0 ok, -1 not. */
static int parse_load(const char *v, double out[4])
{
    const char *p = v;
    for (int k = 0; k < 4; k++) {
        char *end;
        errno = 0;
        out[k] = strtod(p, &end);
        if (errno != 0 || end == p || !isfinite(out[k]) || *end != (k < 3 ? ',' : '\0')) {
            return -1;
        }
        p = end + 1;
    }
    return 0;
}

/* One setter per option: takes the option's value (NULL for a flag) into
 * the run; 0 done, -1 the value is not what the option takes. */
static int set_ops(cli_t *c, const char *v)
{
    c->s->ifs[SP_BUS_OPS] = v;
    return 0;
}

static int set_axis_a(cli_t *c, const char *v)
{
    c->s->ifs[SP_BUS_AXIS_A] = v;
    return 0;
}

static int set_axis_b(cli_t *c, const char *v)
{
    c->s->ifs[SP_BUS_AXIS_B] = v;
    return 0;
}

static int set_lockstep(cli_t *c, const char *v)
{
    (void)v;
    c->s->lockstep = 1;
    return 0;
}

static int set_inproc(cli_t *c, const char *v)
{
    (void)v;
    c->s->inproc = 1;
    c->s->lockstep = 1;
    return 0;
}

static int set_ticks(cli_t *c, const char *v)
{
    return parse_u64(v, &c->max_ticks);
}

static int set_scenario(cli_t *c, const char *v)
{
    c->scenario = v;
    return 0;
}

static int set_log(cli_t *c, const char *v)
{
    c->log_path = v;
    return 0;
}

static int set_truth(cli_t *c, const char *v)
{
    c->truth_path = v;
    return 0;
}

static int set_seed(cli_t *c, const char *v)
{
    c->have_seed = (parse_u64(v, &c->seed) == 0);
    return c->have_seed ? 0 : -1;
}

static int set_timeout_ms(cli_t *c, const char *v)
{
    unsigned long long u;
    if (parse_range(v, 1u, 3599999u, &u) != 0) {
        return -1;
    }
    c->timeout_ms = (long)u;
    return 0;
}

static int set_progress(cli_t *c, const char *v)
{
    (void)v;
    c->s->progress = 1;
    return 0;
}

static int set_load(cli_t *c, const char *v)
{
    c->have_load = (parse_load(v, c->load) == 0);
    return c->have_load ? 0 : -1;
}

static int set_as_built(cli_t *c, const char *v)
{
    c->as_built = v;
    return 0;
}

static int set_setpoint_timeout(cli_t *c, const char *v)
{
    unsigned long long u;
    if (parse_range(v, 1u, 100000u, &u) != 0) {
        return -1;
    }
    c->sp_timeout = (uint32_t)u;
    return 0;
}

static int set_canopen(cli_t *c, const char *v)
{
    (void)v;
    c->s->canopen = 1;
    return 0;
}

static int set_cia402(cli_t *c, const char *v)
{
    (void)v;
    c->s->canopen = 1;
    c->s->cia402 = 1;
    return 0;
}

static int set_tick0(cli_t *c, const char *v)
{
    unsigned long long u;
    if (parse_range(v, 0u, UINT32_MAX, &u) != 0) {
        return -1;
    }
    c->s->tick0 = (uint32_t)u;
    return 0;
}

static int set_key(cli_t *c, const char *v)
{
    c->key_path = v;
    return 0;
}

static int set_session(cli_t *c, const char *v)
{
    unsigned long long u;
    if (parse_range(v, 0u, UINT32_MAX, &u) != 0) {
        return -1;
    }
    c->s->session = (uint32_t)u;
    c->s->session_known = 1;
    return 0;
}

static int set_wrench_source(cli_t *c, const char *v)
{
    if (strcmp(v, "cylinders") == 0) {
        c->s->wrench_source = (int)SP_WRENCH_CYLINDERS;
    } else if (strcmp(v, "sensor") == 0) {
        c->s->wrench_source = (int)SP_WRENCH_SENSOR;
    } else {
        return -1;
    }
    return 0;
}

static int set_estop_category(cli_t *c, const char *v)
{
    if (strcmp(v, "0") != 0 && strcmp(v, "1") != 0) {
        return -1;
    }
    c->s->estop_category = (v[0] == '1') ? 1 : 0;
    return 0;
}

static int set_sdo_delay_ms(cli_t *c, const char *v)
{
    unsigned long long u;
    if (parse_range(v, 0u, 1000u, &u) != 0) {
        return -1;
    }
    c->s->sdo_delay_ms = (uint16_t)u;
    return 0;
}

static int set_control(cli_t *c, const char *v)
{
    c->control = v;
    return 0;
}

static int set_stats(cli_t *c, const char *v)
{
    unsigned long long u;
    if (parse_range(v, 1u, 3600u, &u) != 0) {
        return -1;
    }
    c->s->stats_every_ns = (int64_t)u * 1000000000;
    return 0;
}

static int print_help(cli_t *c, const char *v);

/* The options: --NAME [ARG] (ARG NULL: a flag), the help line, the setter. */
typedef struct {
    const char *name;
    const char *arg;
    const char *help;
    int (*set)(cli_t *c, const char *v);
} cli_option_t;

static const cli_option_t cli_options[] = {
    {"ops", "IF", "the ops bus's CAN interface (default vcan0)", set_ops},
    {"axis-a", "IF", "axis_a's CAN interface (default vcan1)", set_axis_a},
    {"axis-b", "IF", "axis_b's CAN interface (default vcan2)", set_axis_b},
    {"lockstep", NULL, "the plant is the time master: deterministic, byte-identical logs", set_lockstep},
    {"inproc", NULL, "lockstep with the controller in this process, the frames in memory", set_inproc},
    {"ticks", "N", "end after N cycles of 1 ms (default 0: no limit)", set_ticks},
    {"scenario", "FILE", "the operator's actions to play (hs/scenario.h)", set_scenario},
    {"log", "FILE", "every frame on the buses, as a candump log", set_log},
    {"truth", "FILE", "the plant's true state each cycle (CSV)", set_truth},
    {"seed", "N", "the sensors' noise seed (default: the config's)", set_seed},
    {"timeout-ms", "MS", "controller silence that ends the run, 1..3599999 (default 2000)", set_timeout_ms},
    {"progress", NULL, "a status line each simulated second (stderr)", set_progress},
    {"load", "MASS,X,Y,Z", "a point mass (kg at m in the motion frame) on the platform", set_load},
    {"as-built", "FILE", "the machine as built: 48 offsets (joints, sensor zeros and scales) on the config's",
     set_as_built},
    {"setpoint-timeout", "CYCLES", "the drives' setpoint watchdog, 1..100000 (default: the config's)",
     set_setpoint_timeout},
    {"canopen", NULL, "the drives as CiA 408 nodes (the default with a drives section in the config)", set_canopen},
    {"cia402", NULL, "the drives as CiA 402 nodes (implies --canopen)", set_cia402},
    {"tick0", "N", "test only: the SYNC tick of cycle 0, 0..4294967295", set_tick0},
    {"key", "FILE", "the machine key (default: the file STEWART_KEY names)", set_key},
    {"session", "N", "the controller's session from the start, 0..4294967295", set_session},
    {"wrench-source", "cylinders|sensor", "force control's wrench source with --inproc (default: the config's)",
     set_wrench_source},
    {"estop-category", "0|1", "ESTOP's stop category with --inproc: 1 controlled, 0 immediate (default: the config's)",
     set_estop_category},
    {"sdo-delay-ms", "MS", "with --canopen: each node answers SDO requests MS ms late, 0..1000", set_sdo_delay_ms},
    {"control", "FILE", "scenario lines while running, one request a line (a FIFO)", set_control},
    {"stats", "S", "real time: deadline misses on stderr every S s, 1..3600", set_stats},
    {"help", NULL, "print this help and exit", print_help},
};

#define CLI_OPTIONS (sizeof cli_options / sizeof cli_options[0])
#define CLI_VAL0 0x100 /* getopt_long's value for cli_options[0]; row i gives CLI_VAL0 + i */

/* --help: the table cli_options, then the exit statuses; exits 0. */
static int print_help(cli_t *c, const char *v)
{
    (void)c, (void)v;
    int width = 0;
    for (size_t i = 0; i < CLI_OPTIONS; i++) {
        const cli_option_t *o = &cli_options[i];
        int w = (int)strlen(o->name) + (o->arg != NULL ? (int)strlen(o->arg) + 1 : 0);
        width = (w > width) ? w : width;
    }
    printf("usage: hs_sim [OPTION]...\n"
           "The simulated hydraulic hexapod on SocketCAN (docs/explanation/closed_loop.md).\n\n");
    for (size_t i = 0; i < CLI_OPTIONS; i++) {
        const cli_option_t *o = &cli_options[i];
        int w = (int)strlen(o->name) + (o->arg != NULL ? (int)strlen(o->arg) + 1 : 0);
        printf("  --%s%s%s%*s  %s\n", o->name, o->arg != NULL ? " " : "", o->arg != NULL ? o->arg : "", width - w, "",
               o->help);
    }
    printf("\nExit status: 0 the run ended, 1 I/O or set-up error, 2 usage or scenario error, 3 the controller\n"
           "stopped answering, 4 a scenario wait timed out, 5 the plant's state became non-finite.\n");
    exit(EXIT_SUCCESS);
}

/* What getopt_long refused (ret ':' or '?'), said on stderr. */
static void option_error(int ret, char **argv)
{
    if (ret == ':' && optopt >= CLI_VAL0) {
        const cli_option_t *o = &cli_options[optopt - CLI_VAL0];
        fprintf(stderr, "hs_sim: --%s needs a value: --%s %s: %s\n", o->name, o->name, o->arg, o->help);
    } else if (optopt >= CLI_VAL0) {
        fprintf(stderr, "hs_sim: --%s takes no value\n", cli_options[optopt - CLI_VAL0].name);
    } else if (optopt > 0) {
        fprintf(stderr, "hs_sim: unknown option -%c\n", optopt);
    } else {
        fprintf(stderr, "hs_sim: unknown or ambiguous option %s\n", argv[optind - 1]);
    }
}

/* The command line into c (and its run state). 0 ok, 2 a usage error (said on stderr). */
static int parse_command_line(cli_t *c, int argc, char **argv)
{
    struct option longopts[CLI_OPTIONS + 1];
    for (size_t i = 0; i < CLI_OPTIONS; i++) {
        longopts[i] = (struct option){cli_options[i].name, cli_options[i].arg != NULL ? required_argument : no_argument,
                                      NULL, CLI_VAL0 + (int)i};
    }
    longopts[CLI_OPTIONS] = (struct option){NULL, 0, NULL, 0};
    opterr = 0; /* the messages are ours */
    for (int ret; (ret = getopt_long(argc, argv, ":", longopts, NULL)) != -1;) {
        if (ret < CLI_VAL0) {
            option_error(ret, argv);
            fprintf(stderr, "hs_sim: see hs_sim --help\n");
            return 2;
        }
        const cli_option_t *o = &cli_options[ret - CLI_VAL0];
        if (o->set(c, optarg) != 0) {
            fprintf(stderr, "hs_sim: bad value '%s' for --%s %s: %s\n", optarg, o->name, o->arg, o->help);
            return 2;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "hs_sim: unexpected argument %s (see hs_sim --help)\n", argv[optind]);
        return 2;
    }
    return 0;
}

/* Real time: answers SYNC(t) from the controller with the feedback of that instant. */
static void realtime_frames(sim_t *s)
{
    sp_can_frame_t rx[RX_BUF];
    uint32_t got = 0;
    do {
        got = 0;
        (void)s->port.receive(s->port.ctx, rx, RX_BUF, &got);
        uint64_t t_us = (uint64_t)((sp_host_now_ns() - s->t0_ns) / 1000);
        for (uint32_t k = 0; k < got; k++) {
            log_frame(s, &rx[k], t_us);
            if (rx[k].id == SP_ID_SYNC && rx[k].bus != SP_BUS_OPS) {
                sp_msg_sync_t m;
                uint8_t ctr;
                sp_proto_error_t why;
                if (sp_proto_decode_sync(&rx[k], &m, &ctr, &why) == SP_OK &&
                    (!s->have_answered || m.tick != s->answered)) {
                    sp_can_frame_t tx[HS_BUS_MAX_TX];
                    uint32_t n = 0;
                    (void)hs_bus_cycle_frames(&s->bus, &s->plant, m.tick, 0u, tx, &n);
                    (void)send_ft(s, t_us);
                    (void)send_frames(s, tx, n, t_us);
                    s->answered = m.tick;
                    s->have_answered = 1;
                }
                continue;
            }
            take_frame(s, &rx[k]);
        }
    } while (got == RX_BUF);
}

/* --canopen: one frame the plant heard, logged: an ops frame as usual, an
 * axis bus's to the CANopen nodes, whose answers go out at once. */
static void canopen_take(sim_t *s, const sp_can_frame_t *f, uint64_t t_us)
{
    log_frame(s, f, t_us);
    if (f->bus == SP_BUS_OPS) {
        take_frame(s, f);
        return;
    }
    sp_can_frame_t tx[HS_CO_BUS_MAX_TX];
    uint8_t n = 0u;
    (void)hs_co_bus_receive(&s->co, f, tx, &n);
    if (n > 0u) {
        (void)send_frames(s, tx, n, t_us);
        s->co_sent += n;
    }
}

/* --canopen: the frames up to and including the next SYNC on axis_b (the
 * master sends the SYNCs after the RPDOs, axis_b's last: it closes the
 * cycle). Every frame of an axis bus goes to the CiA 408 nodes (NMT, SDO,
 * RPDO1, SYNC), their answers go out at once; ops frames as usual. Frames
 * read past that SYNC stay in s->co_rx for the next cycle. Returns 1 at the
 * SYNC, 0 when nothing more has arrived. */
static int canopen_frames(sim_t *s, uint64_t t_us)
{
    for (;;) {
        if (s->co_rx_i >= s->co_rx_n) {
            uint32_t got = 0;
            s->co_rx_i = s->co_rx_n = 0;
            (void)s->port.receive(s->port.ctx, s->co_rx, RX_BUF, &got);
            if (got == 0) {
                return 0;
            }
            s->co_rx_n = got;
        }
        const sp_can_frame_t *f = &s->co_rx[s->co_rx_i++];
        canopen_take(s, f, t_us);
        if (f->id == SP_CO_COB_SYNC && f->bus == SP_BUS_AXIS_B) {
            return 1;
        }
    }
}

/* --canopen --lockstep: the controller's answer to SYNC(t), in the order it
 * was sent: the master's frames (NMT, SDO, RPDO1, SYNC) to the CiA 408
 * nodes, whose answers (SDO, TPDOs) go out at once, before the next SYNC(t),
 * so the controller reads them in its next tick; ops frames as usual. */
static void canopen_answer(sim_t *s, const sp_can_frame_t *raw, uint32_t n_raw, uint64_t t_us)
{
    for (uint32_t k = 0; k < n_raw; k++) {
        canopen_take(s, &raw[k], t_us);
    }
}

/* --canopen: waits for the cycle's SYNC (see canopen_frames); 0, or 3 when
 * the master has been silent for timeout_ms. */
static int canopen_wait(sim_t *s, uint64_t t_us, long timeout_ms)
{
    long silent_ms = 0;
    while (!sp_host_stop_requested()) {
        if (canopen_frames(s, t_us)) {
            return 0;
        }
        struct pollfd pfd = {sp_socketcan_fd(&s->sc), POLLIN, 0};
        int r = poll(&pfd, 1, 100);
        if (r == 0 && (silent_ms += 100) >= timeout_ms) {
            return 3;
        }
    }
    return 0;
}

/* --canopen, after each plant step: positions and pressures into the
 * nodes, their clocks on by 1 ms (boot-up, heartbeat, EMCY). */
static void canopen_cycle(sim_t *s, uint64_t t_us)
{
    sp_can_frame_t tx[HS_CO_BUS_MAX_TX];
    uint8_t n = 0u;
    (void)hs_co_bus_sample(&s->co, &s->plant);
    (void)hs_co_bus_tick(&s->co, 1u, tx, &n);
    if (n > 0u) {
        (void)send_frames(s, tx, n, t_us);
        s->co_sent += n;
    }
}

/* --canopen: six nodes as the platform config's drives section says
 * (sp_co_layout_default: node ids, buses, count 0 at length_at_zero; one
 * resolution for all legs, direction +1), else the master's built-in
 * layout: legs 1-3 on axis_a and 4-6 on axis_b with node ids 1..6, 1 um per
 * count, count 0 at the park pose's leg lengths. */
static int canopen_init(sim_t *s, const hs_params_t *par)
{
    uint8_t ids[HS_LEGS], buses[HS_LEGS];
    double zero[HS_LEGS], m_per_count = 1e-6;
    if (hs_leg_lengths(par, hs_config_default.park, zero) != HS_OK) {
        return -1;
    }
    for (int i = 0; i < HS_LEGS; i++) {
        ids[i] = (uint8_t)(i + 1);
        buses[i] = (uint8_t)(i < 3 ? SP_BUS_AXIS_A : SP_BUS_AXIS_B);
    }
    if (sp_co_layout_default.present) {
        const sp_co_layout_t *l = &sp_co_layout_default;
        m_per_count = 1e-9 * (double)l->scaling[0].nm_per_count;
        for (uint32_t k = 0; k < l->master.n_nodes && k < HS_LEGS; k++) {
            uint32_t leg = (uint32_t)l->master.node[k].leg - 1u;
            if (leg >= HS_LEGS || l->scaling[leg].nm_per_count != l->scaling[0].nm_per_count ||
                l->scaling[leg].direction != 1) {
                fprintf(stderr, "hs_sim: the simulated drives need one resolution for all legs and direction +1\n");
                return -1;
            }
            ids[leg] = l->master.node[k].node_id;
            buses[leg] = l->master.node[k].bus;
            zero[leg] = (double)l->scaling[leg].zero_q24 / 16777216.0;
        }
    }
    if (hs_co_bus_init(&s->co, ids, buses, zero, m_per_count) != HS_OK ||
        (s->cia402 && hs_co_bus_set_profile(&s->co, 1u) != HS_OK)) {
        return -1;
    }
    if (sp_co_layout_default.present) { /* the profile of each leg's drive */
        const sp_co_layout_t *l = &sp_co_layout_default;
        for (uint32_t k = 0; k < l->master.n_nodes && k < HS_LEGS; k++) {
            uint32_t leg = (uint32_t)l->master.node[k].leg - 1u;
            if (l->master.node[k].profile != 0u &&
                hs_co_node_init_profile(&s->co.node[leg], ids[leg], buses[leg], l->master.node[k].profile) != HS_OK) {
                return -1;
            }
        }
    }
    return hs_co_bus_sample(&s->co, &s->plant) == HS_OK ? 0 : -1;
}

/* ---- set-up ------------------------------------------------------------- */

/* The defaults before the command line. */
static void set_defaults(sim_t *s, cli_t *c)
{
    memset(s, 0, sizeof *s);
    s->wrench_source = -1;
    s->estop_category = -1;
    s->ifs[0] = "vcan0", s->ifs[1] = "vcan1", s->ifs[2] = "vcan2";
    s->status_state = -1;
    s->live_fd = -1;
    s->canopen = sp_co_layout_default.present ? 1 : 0; /* the platform config's drives are CiA 408 */
    memset(c, 0, sizeof *c);
    c->s = s;
    c->timeout_ms = 2000;
}

/* The machine key (--key, else STEWART_KEY's file), the scenario, and the
 * options that do not go together. 0 ok, else the exit status. */
static int check_run(sim_t *s, const cli_t *c)
{
    const char *used = NULL;
    char err[256];
    s->have_key = sp_host_load_key(c->key_path, s->key.k, &used, err, sizeof err);
    if (s->have_key < 0) {
        fprintf(stderr, "hs_sim: %s\n", err);
        return 1;
    }
    if (s->inproc && !s->session_known) {
        s->session = 1u, s->session_known = 1;
    }
    if (c->scenario != NULL) {
        hs_scenario_error_t serr;
        if (hs_scenario_load(&s->scn, c->scenario, &serr) != HS_OK) {
            fprintf(stderr, "hs_sim: %s\n", serr.message);
            return 2;
        }
        s->have_scenario = 1;
    }
    if (s->canopen && s->inproc) {
        fprintf(stderr, "hs_sim: --canopen runs on SocketCAN (--lockstep or SYNC-driven), not --inproc\n");
        return 2;
    }
    if (c->scenario == NULL && c->max_ticks == 0 && s->lockstep) {
        fprintf(stderr, "hs_sim: lockstep needs --ticks or a --scenario that ends\n");
        return 2;
    }
    return 0;
}

/* --as-built FILE: HS_AS_BUILT_N numbers (whitespace or commas, '#' to the
 * end of a line a comment): base_joints 6 x 3 and platform_joints 6 x 3
 * (m, added to the config's), length_zero 6 (m), length_scale 6 (-), the
 * order and limits of the config's as_built section (tools/stewart/asbuilt.py;
 * `stewart calibrate as-built --plant-file` writes one). The plant's
 * parameters from the compiled-in config with them applied (*par).
 * 0 ok; else the message is printed and the exit status returned. */
#define HS_AS_BUILT_N 48
static int as_built_params(const char *path, hs_params_t *par)
{
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "hs_sim: --as-built %s: cannot open it\n", path);
        return 2;
    }
    double v[HS_AS_BUILT_N];
    int n = 0, bad = 0;
    char line[512];
    while (!bad && fgets(line, (int)sizeof line, f) != NULL) {
        char *hash = strchr(line, '#');
        if (hash != NULL) {
            *hash = '\0';
        }
        for (char *tok = strtok(line, " \t\r\n,"); tok != NULL && !bad; tok = strtok(NULL, " \t\r\n,")) {
            char *end;
            errno = 0;
            double x = strtod(tok, &end);
            double lim = (n >= 42) ? 0.01 : 0.05; /* scale 1 %, joints and zeros 5 cm */
            if (errno != 0 || *end != '\0' || !isfinite(x) || fabs(x) > lim || n >= HS_AS_BUILT_N) {
                fprintf(stderr, "hs_sim: --as-built %s: number %d (%s): %s\n", path, n + 1, tok,
                        n >= HS_AS_BUILT_N ? "more than 48 numbers" : "not a finite number within its limit");
                bad = 1;
            } else {
                v[n++] = x;
            }
        }
    }
    (void)fclose(f);
    if (bad) {
        return 2;
    }
    if (n != HS_AS_BUILT_N) {
        fprintf(stderr,
                "hs_sim: --as-built %s: %d numbers, expected 48 (base_joints 18, platform_joints 18, "
                "length_zero 6, length_scale 6)\n",
                path, n);
        return 2;
    }
    hs_config_t cfg = hs_config_default;
    for (int i = 0; i < HS_LEGS; i++) {
        for (int k = 0; k < 3; k++) {
            cfg.base_joints[i][k] += v[3 * i + k];
            cfg.platform_joints[i][k] += v[18 + 3 * i + k];
        }
        cfg.sensors.length_zero[i] += v[36 + i];
        cfg.sensors.length_scale[i] += v[42 + i];
    }
    if (hs_params_from_config(&cfg, par) != HS_OK) {
        fprintf(stderr, "hs_sim: --as-built %s: the machine as built is not a usable plant\n", path);
        return 1;
    }
    return 0;
}

/* The plant at the park pose with the options' parameters (*par), its bus
 * binding, the CANopen nodes, the fault injector. 0 ok, else the exit status. */
static int setup_plant(sim_t *s, const cli_t *c, hs_params_t *par)
{
    if (c->as_built != NULL) {
        int rc = as_built_params(c->as_built, par);
        if (rc != 0) {
            return rc;
        }
    } else if (hs_params_default(par) != HS_OK) {
        fprintf(stderr, "hs_sim: the default plant parameters are not usable\n");
        return 1;
    }
    if (c->have_seed) {
        par->sensors.seed = (uint64_t)c->seed;
    }
    if (c->sp_timeout > 0u) {
        par->drive.timeout_cycles = c->sp_timeout;
    }
    if (c->have_load && hs_params_add_mass(par, c->load[0], &c->load[1]) != HS_OK) {
        fprintf(stderr, "hs_sim: --load %g,%g,%g,%g: the platform would not be a rigid body\n", c->load[0], c->load[1],
                c->load[2], c->load[3]);
        return 2;
    }
    hs_status_t hst = hs_plant_init(&s->plant, par, hs_config_default.park);
    if (hst != HS_OK) {
        fprintf(stderr, "hs_sim: cannot start the plant at the park pose: %s\n", hs_status_name(hst));
        return 1;
    }
    (void)hs_bus_init(&s->bus);
    if (s->canopen && canopen_init(s, par) != 0) {
        fprintf(stderr, "hs_sim: cannot set up the CiA 408 nodes\n");
        return 1;
    }
    for (int i = 0; s->canopen && i < HS_LEGS; i++) {
        s->co.node[i].sdo_delay_ms = s->sdo_delay_ms;
    }
    (void)hs_inject_init(&s->inj, par->sensors.seed ^ UINT64_C(0x9E3779B97F4A7C15));
    s->strokes_ok = 1;
    return 0;
}

/* --inproc: the controller as sp_controller --lockstep runs it: the
 * defaults, the plant's SYNC. 0 ok, else the exit status. */
static int setup_inproc(sim_t *s)
{
    if (sp_node_default_config(&s->ncfg, &sp_platform_default) != SP_OK) {
        fprintf(stderr, "hs_sim: the default platform is not usable\n");
        return 1;
    }
    s->ncfg.sync_master = 0u;
    s->ncfg.ctrl.estop = sp_estop_default; /* as sp_controller */
    if (s->estop_category >= 0) {
        s->ncfg.ctrl.estop.category = (uint8_t)s->estop_category;
    }
    s->ncfg.auth_key = s->have_key ? &s->key : NULL;
    s->ncfg.auth_session = s->session;
    (void)sp_ctrl_set_wrench_source(&s->ncfg.ctrl,
                                    (s->wrench_source >= 0) ? (uint8_t)s->wrench_source : sp_wrench_source_default,
                                    &sp_ft_mount_default); /* as sp_controller */
    s->ncfg.ctrl.frames = sp_frame_slots_default;          /* the config's named frames */
    (void)sp_node_init(&s->node, &s->ncfg);
    s->node.ctrl.tick = s->tick0; /* its own tick through the wrap too (test-only) */
    return 0;
}

/* The force/torque sensor as the config's force_sensor section mounts it,
 * at cycle 0. 0 ok, else the exit status. */
static int setup_ft(sim_t *s, const hs_params_t *par)
{
    hs_ft_params_t ftp = hs_ft_default_params();
    for (int k = 0; k < 3; k++) {
        ftp.mount_pos[k] = hs_config_default.force_sensor.mount_pos[k];
        ftp.mount_rpy[k] = hs_config_default.force_sensor.mount_rpy[k];
    }
    ftp.rate_hz = hs_config_default.force_sensor.rate_hz;
    if (hs_ft_init(&s->ft, &ftp, par->sensors.seed + 0x5eed0f7u) != HS_OK) {
        fprintf(stderr, "hs_sim: the config's force_sensor section is not usable\n");
        return 1;
    }
    ft_advance(s, 0u);
    return 0;
}

/* The three buses on SocketCAN (not with --inproc), each with the receive
 * filters of what the plant listens to. 0 ok, else the exit status. */
static int open_buses(sim_t *s)
{
    sp_socketcan_bus_cfg_t bc[SP_CAN_BUSES];
    memset(bc, 0, sizeof bc);
    bc[SP_BUS_OPS] = (sp_socketcan_bus_cfg_t){
        s->ifs[0],
        {SP_ID_CTRL_STATUS, SP_ID_CTRL_MONITOR, SP_ID_CTRL_WRENCH, SP_ID_CTRL_AUTH, SP_ID_CTRL_IDENTITY,
         SP_ID_CTRL_REACH, SP_ID_CTRL_FRAMES, SP_ID_CTRL_REFUSAL, SP_ID_OP_COMMAND, SP_ID_OP_TARGET_POSE,
         SP_ID_OP_FORCE, SP_ID_OP_FORCE_PARAMS, SP_ID_OP_FRAME, SP_ID_OP_REACH},
        14u};
    for (int b = 1; b <= 2; b++) {
        bc[b] = (sp_socketcan_bus_cfg_t){s->ifs[b], {SP_ID_AXIS_SETPOINTS, SP_ID_SYNC}, s->lockstep ? 1u : 2u};
        if (s->canopen) { /* NMT, SYNC, and per node of the bus RPDO1 and SDO requests */
            bc[b] = (sp_socketcan_bus_cfg_t){s->ifs[b], {SP_CO_COB_NMT, SP_CO_COB_SYNC}, 2u};
            for (uint32_t k = 0u; k < HS_LEGS; k++) {
                if (s->co.node[k].bus == (uint8_t)b && bc[b].n_rx_ids + 2u <= SP_SOCKETCAN_MAX_FILTERS) {
                    bc[b].rx_ids[bc[b].n_rx_ids++] = SP_CO_COB_RPDO1 + s->co.node[k].node_id;
                    bc[b].rx_ids[bc[b].n_rx_ids++] = SP_CO_COB_SDO_RX + s->co.node[k].node_id;
                }
            }
        }
    }
    if (!s->inproc) {
        if (sp_socketcan_open(&s->sc, bc) != SP_OK) {
            fprintf(stderr, "hs_sim: %s\n", s->sc.error);
            return 1;
        }
        s->port = sp_socketcan_port(&s->sc);
    }
    return 0;
}

/* --log and --truth (the truth file's header line). 0 ok, else the exit status. */
static int open_outputs(sim_t *s, const cli_t *c)
{
    if (c->log_path != NULL && (s->log = fopen(c->log_path, "w")) == NULL) {
        fprintf(stderr, "hs_sim: cannot write %s: %s\n", c->log_path, strerror(errno));
        return 1;
    }
    static char log_buf[1 << 20], truth_buf[1 << 20]; /* few write calls: each is slow in user-mode Linux */
    if (s->log != NULL) {
        (void)setvbuf(s->log, log_buf, _IOFBF, sizeof log_buf);
    }
    if (c->truth_path != NULL) {
        if ((s->truth = fopen(c->truth_path, "w")) == NULL) {
            fprintf(stderr, "hs_sim: cannot write %s: %s\n", c->truth_path, strerror(errno));
            return 1;
        }
        (void)setvbuf(s->truth, truth_buf, _IOFBF, sizeof truth_buf);
        fprintf(s->truth, "tick,x,y,z,roll,pitch,yaw,len1,len2,len3,len4,len5,len6,"
                          "force1,force2,force3,force4,force5,force6,drive1,drive2,drive3,drive4,drive5,drive6,"
                          "wrench_fx,wrench_fy,wrench_fz,wrench_mx,wrench_my,wrench_mz,"
                          "friction1,friction2,friction3,friction4,friction5,friction6,"
                          "block1,block2,block3,block4,block5,block6\n");
    }
    return 0;
}

/* The run's mode and set-up, on stderr. */
static void print_banner(const sim_t *s, const cli_t *c, const hs_params_t *par)
{
    if (s->inproc) {
        fprintf(stderr,
                "hs_sim: lockstep mode in memory with the controller in-process, plant at the park pose, "
                "%u substeps per 1 ms\n",
                (unsigned)par->substeps);
    } else {
        fprintf(stderr, "hs_sim: %s mode on %s %s %s, plant at the park pose, %u substeps per 1 ms%s\n",
                s->lockstep ? "lockstep" : (s->canopen ? "SYNC-driven" : "real-time"), s->ifs[0], s->ifs[1], s->ifs[2],
                (unsigned)par->substeps,
                s->canopen ? (s->cia402 ? ", drives as CiA 402 nodes 1-3 (axis_a) and 4-6 (axis_b)"
                                        : ", drives as CiA 408 nodes 1-3 (axis_a) and 4-6 (axis_b)")
                           : "");
    }
    if (c->have_load) {
        fprintf(stderr, "hs_sim: load %g kg at (%g, %g, %g) m: moving mass %g kg, centre of mass (%g, %g, %g) m\n",
                c->load[0], c->load[1], c->load[2], c->load[3], par->mass, par->com[0], par->com[1], par->com[2]);
    }
}

/* Everything before the first cycle. 0 ok, else the exit status. */
static int setup(sim_t *s, const cli_t *c, hs_params_t *par)
{
    int rc = check_run(s, c);
    if (rc == 0) {
        rc = setup_plant(s, c, par);
    }
    if (rc == 0 && s->inproc) {
        rc = setup_inproc(s);
    }
    if (rc == 0) {
        rc = setup_ft(s, par);
    }
    if (rc == 0) {
        rc = open_buses(s);
    }
    if (rc == 0) {
        rc = open_outputs(s, c);
    }
    if (rc == 0 && c->control != NULL) {
        rc = live_open(s, c->control);
    }
    s->stats_due_ns = sp_host_now_ns() + s->stats_every_ns;
    return rc;
}

/* ---- the run ------------------------------------------------------------ */

/* Lockstep: cycle `tick`'s frames out (every drive's feedback and SYNC(t);
 * with CANopen drives SYNC(t) alone, the lockstep clock), then the
 * controller's answer in. 0 go on, WAIT_STOPPED on SIGINT/SIGTERM, else the
 * exit status. */
static int lockstep_cycle(sim_t *s, uint64_t tick, uint64_t t_us, long timeout_ms)
{
    sp_can_frame_t tx[HS_BUS_MAX_TX];
    uint32_t n = 0;
    uint32_t sync_tick = (uint32_t)(tick + s->tick0); /* modulo 2^32, as the DBC's Tick */
    (void)hs_bus_cycle_frames(&s->bus, &s->plant, sync_tick, 1u, tx, &n);
    if (s->canopen) { /* the drives answer by CANopen: only the cycle's SYNC(t), the lockstep clock */
        uint32_t k = 0;
        for (uint32_t i = 0; i < n; i++) {
            if (tx[i].id == SP_ID_SYNC) {
                tx[k++] = tx[i];
            }
        }
        n = k;
    }
    if (send_ft(s, t_us) != 0 || send_frames(s, tx, n, t_us) != 0) {
        return 1;
    }
    static sp_can_frame_t raw[4 * RX_BUF];
    uint32_t nraw = 0;
    int r = 0;
    if (s->inproc) {
        nraw = inproc_answer(s, raw);
    } else {
        r = lockstep_wait(s, sync_tick, raw, &nraw, 4 * RX_BUF, cycle_timeout_ms(tick, timeout_ms));
    }
    if (r == WAIT_STOPPED) {
        return WAIT_STOPPED;
    }
    if (r != 0) {
        if (r == 3) {
            fprintf(stderr, "hs_sim: the controller did not answer cycle %" PRIu64 " within %ld ms\n", tick,
                    cycle_timeout_ms(tick, timeout_ms));
        }
        return (r == 3) ? 3 : 1;
    }
    if (s->canopen) {
        canopen_answer(s, raw, nraw, t_us);
    } else {
        deliver_answer(s, raw, nraw, t_us);
    }
    track_faults(s, tick);
    return 0;
}

/* Real time: every SYNC answered at once until the cycle's 1 ms deadline. */
static void realtime_cycle(sim_t *s)
{
    rt_account(s);
    s->next_ns += 1000000;
    for (;;) {
        realtime_frames(s);
        int64_t left = s->next_ns - sp_host_now_ns();
        if (left <= 0 || sp_host_stop_requested()) {
            break;
        }
        struct pollfd pfd = {sp_socketcan_fd(&s->sc), POLLIN, 0};
        struct timespec ts = {(time_t)(left / 1000000000), (long)(left % 1000000000)};
        (void)ppoll(&pfd, 1, &ts, NULL);
    }
}

/* The frames of cycle `tick` with the controller, as the mode says. 0 go
 * on, WAIT_STOPPED on SIGINT/SIGTERM, else the exit status. */
static int exchange_frames(sim_t *s, uint64_t tick, uint64_t t_us, long timeout_ms)
{
    if (s->lockstep) {
        return lockstep_cycle(s, tick, t_us, timeout_ms);
    }
    if (s->canopen) {
        if (canopen_wait(s, t_us, timeout_ms) != 0) {
            fprintf(stderr, "hs_sim: no SYNC from the CANopen master for %ld ms at cycle %" PRIu64 "\n", timeout_ms,
                    tick);
            return 3;
        }
        return 0;
    }
    realtime_cycle(s);
    return 0;
}

/* The plant's 1 ms of cycle `tick`: the truth row, the CANopen nodes'
 * setpoints in, the step, the nodes' samples out. 0 ok, 5 the step failed. */
static int plant_cycle(sim_t *s, uint64_t tick, uint64_t t_us)
{
    write_truth(s, tick);
    if (s->canopen) {
        (void)hs_co_bus_apply(&s->co, &s->plant);
    }
    hs_status_t st = hs_plant_step(&s->plant, 1.0e-3);
    if (st != HS_OK) {
        fprintf(stderr, "hs_sim: plant step failed at cycle %" PRIu64 ": %s\n", tick, hs_status_name(st));
        return 5;
    }
    if (s->canopen) {
        canopen_cycle(s, t_us);
    }
    return 0;
}

/* The cycles until the end (--ticks, the scenario's end, a signal, an
 * error); *ticks the cycles done. Returns the exit status. */
static int run(sim_t *s, const cli_t *c, uint64_t *ticks)
{
    int rc = 0;
    uint64_t tick = 0;
    s->t0_ns = sp_host_now_ns();
    s->next_ns = s->t0_ns;
    while (!sp_host_stop_requested() && (c->max_ticks == 0 || tick < c->max_ticks)) {
        uint64_t t_us = (s->lockstep || s->canopen) ? tick * 1000u : (uint64_t)((sp_host_now_ns() - s->t0_ns) / 1000);
        s->tick = tick;
        if (s->have_scenario || s->live_fd >= 0) {
            int r = play_tick(s, tick, t_us); /* a play under way first: its last pose before what follows it */
            if (r == 0 && s->have_scenario) {
                r = run_scenario(s, &s->scn, tick, t_us);
            }
            if (r == 0) {
                live_tick(s, tick, t_us);
            }
            if (r != 0) {
                rc = (r == 1) ? 0 : ((r == 4 || r == 2) ? r : 1);
                break;
            }
            wrench_tick(s, tick);
        }
        int r = exchange_frames(s, tick, t_us, c->timeout_ms);
        if (r == WAIT_STOPPED) {
            break; /* SIGINT/SIGTERM: the run ends as asked (exit 0) */
        }
        if (r != 0 || (r = plant_cycle(s, tick, t_us)) != 0) {
            rc = r;
            break;
        }
        tick++;
        ft_advance(s, tick);
        if (s->progress && tick % 1000u == 0u) {
            progress_line(s, tick);
        }
    }
    *ticks = tick;
    return rc;
}

/* ---- the summary -------------------------------------------------------- */

/* The run, the final pose, authentication, the drives' states. */
static void print_summary(sim_t *s, uint64_t tick, int rc)
{
    double wall = (double)(sp_host_now_ns() - s->t0_ns) * 1e-9;
    double pose[6];
    (void)hs_plant_pose(&s->plant, pose);
    printf("hs_sim summary: %s, cycles %" PRIu64 ", simulated %.3f s, wall %.3f s, %.2fx real time, exit %d\n",
           s->lockstep ? "lockstep" : (s->canopen ? "SYNC-driven" : "real-time"), tick, (double)tick / 1000.0, wall,
           wall > 0.0 ? (double)tick / 1000.0 / wall : 0.0, rc);
    printf("hs_sim pose: x %.6f y %.6f z %.6f roll %.6f pitch %.6f yaw %.6f\n", pose[0], pose[1], pose[2], pose[3],
           pose[4], pose[5]);
    printf("hs_sim auth: signed %" PRIu64 ", unsigned %" PRIu64 ", session 0x%08x, last counter %u\n", s->signed_frames,
           s->unsigned_frames, (unsigned)s->session, (unsigned)s->auth_counter);
    printf("hs_sim drives:");
    for (int i = 0; i < HS_LEGS; i++) {
        hs_feedback_t fb;
        (void)hs_plant_feedback(&s->plant, i, &fb);
        printf(" %d:%s/0x%02x", i + 1,
               fb.state == HS_DRIVE_INIT     ? "init"
               : fb.state == HS_DRIVE_HOLD   ? "hold"
               : fb.state == HS_DRIVE_ACTIVE ? "active"
                                             : "fault",
               (unsigned)fb.faults);
    }
    printf("\n");
}

/* The frames the plant took, the CANopen nodes, the controller's last state. */
static void print_bus_summary(const sim_t *s)
{
    printf("hs_sim frames: setpoints accepted %u, lost %u, stale %u, ignored %u", s->bus.stats.accepted,
           s->bus.stats.lost, s->bus.stats.stale, s->bus.stats.ignored);
    for (int e = 1; e < SP_PROTO_ERRORS; e++) {
        printf(", %s %u", sp_proto_error_name((sp_proto_error_t)e), s->bus.stats.rejected[e]);
    }
    printf(", ops rejected %" PRIu64 "\n", s->ops_rejected);
    if (s->canopen) {
        uint32_t sdo = 0u;
        printf("hs_sim canopen:");
        for (int i = 0; i < HS_LEGS; i++) {
            const hs_co_node_t *nd = &s->co.node[i];
            sdo += nd->sdo_count;
            printf(" %u:nmt 0x%02x/%s", (unsigned)nd->node_id, (unsigned)nd->nmt, sp_co408_state_name(nd->state));
        }
        printf(", SDO requests %u, frames sent %" PRIu64 "\n", (unsigned)sdo, s->co_sent);
    }
    printf("hs_sim controller: last state %s, faults 0x%04x\n", state_name(s->status_state, "unknown"),
           (unsigned)s->status_faults);
}

/* The drives' safety monitors (hs/drive.h): their largest readings on the
 * drives they did not fault, against their thresholds (the false-alarm margin). */
static void print_monitors(const sim_t *s)
{
    double spool = 0.0, travel = 0.0;
    for (int i = 0; i < HS_LEGS; i++) {
        const hs_drive_t *d = &s->plant.drive[i];
        if ((d->faults & (HS_FAULT_VALVE | HS_FAULT_SENSOR)) == 0u) {
            spool = fmax(spool, d->spool_error_peak);
            travel = fmax(travel, d->chk_travel_peak);
        }
    }
    printf("hs_sim monitors: healthy drives' spool error peak %.1e (fault above %.2f), sensor balance peak "
           "%.4f mm (fault above %.2f mm)\n",
           spool, s->plant.par.drive.spool_error_max, travel * 1e3, s->plant.par.drive.sensor_check_travel * 1e3);
}

static void close_run(sim_t *s)
{
    if (s->log != NULL) {
        fclose(s->log);
    }
    if (s->truth != NULL) {
        fclose(s->truth);
    }
    hs_play_close(&s->play);
    if (s->live_fd >= 0) {
        close(s->live_fd);
    }
    if (!s->inproc) {
        sp_socketcan_close(&s->sc);
    }
}

int main(int argc, char **argv)
{
    static sim_t s;
    cli_t c;
    hs_params_t par;
    set_defaults(&s, &c);
    int rc = parse_command_line(&c, argc, argv);
    if (rc == 0) {
        rc = setup(&s, &c, &par);
    }
    if (rc != 0) {
        return rc;
    }
    if (sp_host_stop_on_signals() != 0) { /* then SIGINT/SIGTERM end the program at once, as by default */
        perror("hs_sim: cannot catch SIGINT/SIGTERM");
    }
    print_banner(&s, &c, &par);
    uint64_t ticks = 0;
    rc = run(&s, &c, &ticks);
    print_summary(&s, ticks, rc);
    if (!s.lockstep && !s.canopen && !s.inproc) {
        rt_print(&s);
    }
    print_bus_summary(&s);
    print_monitors(&s);
    if (s.injected) {
        print_fault_report(&s);
    }
    close_run(&s);
    return rc;
}
