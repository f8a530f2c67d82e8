/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs_soak - the soak: a randomised operation of the controller and the
 * simulated hexapod in one process, faster than real time, with every
 * invariant of soak_check.h checked on every tick
 * (docs/explanation/testing.md, "The soak").
 *
 *   hs_soak [--hours H | --seconds S | --ticks N] [--seed S] [--max-wall S]
 *           [--wide] [--strict] [--break INVARIANT@TICK] [--trace] [--quiet]
 *
 * The controller is the firmware's node (sp_node_*, configured as
 * sp_controller --lockstep, with a machine key drawn from the seed and
 * session 1), the plant hs_plant behind its bus binding hs_bus, in
 * lockstep as hs_sim --inproc runs them: each 1 ms cycle the operator's
 * frames, the force/torque sensor's and every drive's feedback and SYNC go
 * through the fault injector (hs/inject.h) into sp_node_receive, the
 * controller ticks, its frames go through the injector to the plant, and
 * the plant integrates 1 ms. The frames are the real ones, encoded and
 * decoded by the same codecs as on the bus. The operator is soak_gen.h:
 * random episodes in the scenario language, parsed and played by
 * hs/scenario.h and carried out here.
 *
 * --hours / --seconds / --ticks: simulated time (default 60 s); --max-wall
 * S stops earlier once S seconds of wall time have passed (the run still
 * passes; the summary says how far it got); --seed: the generator's seed
 * (default 1); the same seed gives the same run, tick for tick. --wide
 * draws RUN_TRIG frequencies up to 3 Hz (today's controller takes some it
 * cannot compute: issue 35). --strict (the test command's): a REFERENCE
 * fault while RUNNING an accepted motion is a violation (known_reference
 * below; without it such a fault is counted, not a violation). --break NAME@TICK (the checker's own test)
 * corrupts that tick's snapshot so that invariant NAME fails. --trace
 * prints every episode's text and every state change.
 *
 * A violation prints the invariant, the seed, the tick, what was wrong, the
 * episode's text, and the command that replays the run to that tick; exit
 * 1. Exit 0: no violation; 2: usage; 3: an episode the parser or the
 * plant refused (a defect of soak_gen.c); 5: the plant's step failed.
 */
#define _GNU_SOURCE
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hs/bus.h"
#include "hs/ftsensor.h"
#include "hs/inject.h"
#include "hs/kin.h"
#include "hs/scenario.h"
#include "sp/link/node.h"
#include "host_os.h"
#include "scenario_plant.h"
#include "soak_check.h"
#include "soak_gen.h"

#define MAX_FRAMES (4u * HS_INJ_MAX_OUT + 64u)
/* The states the figures count: IDLE .. STOPPING (sp_state_t, 0 .. 7) */
#define SOAK_STATES 8

typedef struct {
    uint64_t ticks, seed;
    double max_wall;
    int wide, trace, quiet, strict;
    int brk; /* soak_violation_t to provoke, 0 none */
    uint64_t brk_tick;
} opts_t;

typedef struct {
    opts_t o;
    hs_plant_t plant;
    hs_bus_t bus;
    hs_inject_t inj;
    hs_ft_t ft;
    hs_scenario_t scn;
    int have_episode;
    soak_gen_t gen;
    sp_node_config_t ncfg;
    sp_node_t node;
    sp_auth_key_t key;
    soak_limits_t lim;
    uint64_t tick;
    uint32_t auth_counter;
    uint8_t cmd_counter, target_counter, force_counter, ft_counter;
    int ft_silent;
    sp_can_frame_t last_signed; /* the last signed command (soak:replay sends it again) */
    int have_signed;
    int status_state;        /* CTRL_STATUS's state as the operator sees it, -1 none yet */
    uint32_t status_faults;  /* ... and its faults */
    uint8_t hb_counter;      /* OP_HEARTBEAT's alive counter */
    uint64_t hb_quiet_until; /* `mark soak:quiet`: no heartbeat before this tick */
    uint64_t ops_seen;       /* controller frames the plant side took (counted, decoded or not) */
    double wrench_from[6], wrench_to[6], push[6];
    uint64_t wrench_start, wrench_ticks, push_start, push_rise, push_hold, push_end;
    uint64_t latched_ticks; /* ticks the operator has seen FAULT or ESTOP in a row */
    int injected;           /* a fault injected since the controller last left FAULT/ESTOP */
    uint32_t saturated_last;
    /* figures */
    uint64_t checks, state_ticks[SOAK_STATES], transitions[SOAK_STATES][SOAK_STATES], commands, refused, forged,
        timeouts, injections, contacts_refused;
    uint64_t known, known_first; /* REFERENCE faults while RUNNING an accepted motion (known_reference) */
    double peak_force, peak_sp_force, min_margin_len;
    uint32_t in_last, dup_last, drop_last, busoff_last; /* the injector's counters at the last tick */
    uint64_t dropped_total;
} soak_t;

/* ---- frames ------------------------------------------------------------- */

/* The sum of every receiver's counts (modulo 2^32): the controller's
 * (taken, stale, refused by reason, queue full) and the plant side's. */
static uint32_t received(const soak_t *s)
{
    const sp_node_stats_t *ns = &s->node.stats;
    uint32_t n = ns->accepted + ns->stale + ns->cmd_overflow + s->bus.stats.accepted + s->bus.stats.ignored +
                 (uint32_t)s->ops_seen;
    for (int e = 0; e < SP_PROTO_ERRORS; e++) {
        n += ns->rejected[e] + s->bus.stats.rejected[e];
    }
    return n;
}

static uint32_t unaccounted(const soak_t *s)
{
    const hs_inject_stats_t *is = &s->inj.stats;
    return is->in + is->duplicated - is->dropped - is->busoff - is->pending - received(s);
}

/* Signs an operator frame that needs it with the next counter. */
static void sign(soak_t *s, sp_can_frame_t *f)
{
    if (sp_proto_frame_needs_auth(f) && sp_proto_sign(f, &s->key, 1u, s->auth_counter + 1u) == SP_OK) {
        s->auth_counter++;
        if (f->id == SP_ID_OP_COMMAND) {
            s->last_signed = *f, s->have_signed = 1;
        }
    }
}

/* Frames to the controller through the injector. */
static void to_controller(soak_t *s, sp_can_frame_t *in, uint32_t n_in)
{
    static sp_can_frame_t out[MAX_FRAMES];
    uint32_t n = 0;
    (void)hs_inject_filter(&s->inj, HS_INJ_TO_CONTROLLER, s->tick, in, n_in, out, MAX_FRAMES, &n);
    for (uint32_t i = 0; i < n; i++) {
        (void)sp_node_receive(&s->node, &out[i], NULL);
    }
}

/* One operator frame: encoded by the caller, signed here, sent. */
static void send_op(soak_t *s, sp_can_frame_t *f, int do_sign)
{
    if (do_sign) {
        sign(s, f);
    }
    s->commands += (f->id == SP_ID_OP_COMMAND);
    to_controller(s, f, 1u);
}

static void send_command(soak_t *s, const sp_msg_command_t *m, int do_sign)
{
    sp_can_frame_t f;
    (void)sp_proto_encode_command(m, s->cmd_counter, &f);
    s->cmd_counter = (uint8_t)((s->cmd_counter + 1u) & 0x0Fu);
    send_op(s, &f, do_sign);
}

/* The plant side's view of a controller frame on the ops bus: the operator
 * reads CTRL_STATUS's state (what the scenario's waits wait for). */
static void take_ops(soak_t *s, const sp_can_frame_t *f)
{
    s->ops_seen++;
    if (f->id == SP_ID_CTRL_STATUS) {
        sp_msg_status_t m;
        uint8_t ctr;
        sp_proto_error_t why;
        if (sp_proto_decode_status(f, &m, &ctr, &why) == SP_OK) {
            s->status_state = m.state;
            s->status_faults = m.faults;
        }
    }
}

/* ---- the operator's actions --------------------------------------------- */

/* The operator's heartbeat every 20 ms (the controller's operator link
 * supervises it from the first one on), unless `mark soak:quiet` paused it. */
static void heartbeat(soak_t *s)
{
    sp_can_frame_t f;
    if (s->tick % 20u == 0u && s->tick >= s->hb_quiet_until) {
        (void)sp_proto_encode_heartbeat(s->hb_counter, &f);
        s->hb_counter = (uint8_t)((s->hb_counter + 1u) & 0x0Fu);
        to_controller(s, &f, 1u);
    }
}

/* `mark soak:forge|replay|unsigned|quiet`: an ENGAGE signed with a wrong
 * key, the last signed command again, an unsigned RUN_TRIG; the operator's
 * heartbeat paused for 0.5 s (the operator link's timeout is 0.2 s). */
static void soak_mark(soak_t *s, const char *what)
{
    sp_msg_command_t m = {SP_CMD_ENGAGE, 0u, 0, 0, 0u, 0u};
    sp_can_frame_t f;
    if (strcmp(what, "soak:quiet") == 0) {
        s->hb_quiet_until = s->tick + 500u;
        return;
    }
    s->forged++;
    if (strcmp(what, "soak:replay") == 0 && s->have_signed) {
        f = s->last_signed;
        to_controller(s, &f, 1u);
    } else if (strcmp(what, "soak:forge") == 0) {
        sp_auth_key_t bad = s->key;
        bad.k[0] ^= 0x5Au;
        (void)sp_proto_encode_command(&m, s->cmd_counter, &f);
        s->cmd_counter = (uint8_t)((s->cmd_counter + 1u) & 0x0Fu);
        (void)sp_proto_sign(&f, &bad, 1u, s->auth_counter + 1u);
        to_controller(s, &f, 1u);
    } else {
        m.command = SP_CMD_RUN_TRIG, m.amplitude = 1 << 20, m.frequency = 1 << 23;
        send_command(s, &m, 0);
    }
}

static void wrench_now(soak_t *s)
{
    double w[6], f = 1.0, p = 0.0;
    if (s->wrench_ticks > 0u && s->tick < s->wrench_start + s->wrench_ticks) {
        f = (double)(s->tick - s->wrench_start) / (double)s->wrench_ticks;
    }
    if (s->push_end != 0u && s->tick >= s->push_start && s->tick < s->push_end) {
        uint64_t t = s->tick - s->push_start;
        p = (t < s->push_rise)                  ? (double)t / (double)s->push_rise
            : (t < s->push_rise + s->push_hold) ? 1.0
                                                : (double)(s->push_end - s->tick) / (double)s->push_rise;
    }
    for (int k = 0; k < 6; k++) {
        w[k] = s->wrench_from[k] + f * (s->wrench_to[k] - s->wrench_from[k]) + p * s->push[k];
    }
    (void)hs_plant_set_wrench(&s->plant, w, &w[3]);
}

static void act_wrench(soak_t *s, const hs_action_t *a)
{
    double f = (s->wrench_ticks > 0u && s->tick < s->wrench_start + s->wrench_ticks)
                   ? (double)(s->tick - s->wrench_start) / (double)s->wrench_ticks
                   : 1.0;
    for (int k = 0; k < 6; k++) {
        s->wrench_from[k] += f * (s->wrench_to[k] - s->wrench_from[k]);
        s->wrench_to[k] = a->wrench[k];
    }
    s->wrench_start = s->tick, s->wrench_ticks = a->ticks;
}

static void act_push(soak_t *s, const hs_action_t *a)
{
    memcpy(s->push, a->wrench, sizeof s->push);
    s->push_start = s->tick, s->push_rise = a->ticks, s->push_hold = a->hold;
    s->push_end = (a->ticks == 0u) ? 0u : s->tick + 2u * a->ticks + a->hold;
}

static int act_contact(soak_t *s, const hs_action_t *a)
{
    hs_status_t st = hs_scenario_set_contact(&s->plant, &a->contact, NULL);
    if (st == HS_E_RANGE) { /* placed through the platform (a motion before ended elsewhere): refused, as
                               hs_sim refuses it, and counted; the episode goes on without it */
        s->contacts_refused++;
        return 0;
    }
    return st == HS_OK ? 0 : -1;
}

static void clear_injections(soak_t *s)
{
    hs_inject_clear_rules(&s->inj);
    for (uint8_t b = 0; b < SP_CAN_BUSES; b++) {
        (void)hs_inject_busoff(&s->inj, b, 0u);
    }
    s->bus.frozen_mask = 0u, s->bus.stale_mask = 0u;
    for (int i = 0; i < HS_LEGS; i++) {
        (void)hs_plant_inject_drive(&s->plant, i, 0u);
        (void)hs_plant_inject_sensor(&s->plant, i, HS_SENSOR_OK, 0.0);
        (void)hs_plant_inject_valve(&s->plant, i, 0, 0.0);
    }
    (void)hs_plant_inject_supply(&s->plant, 0);
}

/* `inject` as hs_sim carries it out (hs_sim.c apply_inject). */
static int act_inject(soak_t *s, const hs_scenario_inject_t *in)
{
    hs_status_t st = HS_OK;
    uint8_t bit = (uint8_t)(1u << (in->leg & 7));
    s->injected |= (in->what != HS_INJECT_CLEAR && in->what != HS_INJECT_FRAMES_OFF);
    s->injections++;
    if (in->what == HS_INJECT_FRAMES) {
        hs_frame_rule_t r = {(uint8_t)in->bus, in->id_lo, in->id_hi, (hs_frame_fault_t)in->fault,
                             in->rate,         in->count, in->delay};
        st = hs_inject_add(&s->inj, &r);
    } else if (in->what == HS_INJECT_FRAMES_OFF) {
        hs_inject_clear_rules(&s->inj);
    } else if (in->what == HS_INJECT_BUSOFF) {
        st = hs_inject_busoff(&s->inj, (uint8_t)in->bus,
                              in->mode == 0 ? 0u : (in->ticks == 0u ? UINT64_MAX : s->tick + in->ticks));
    } else if (in->what == HS_INJECT_DRIVE) {
        if (in->mode == 0) {
            st = in->hold ? hs_plant_inject_drive(&s->plant, in->leg, in->bits)
                          : hs_plant_raise_faults(&s->plant, in->leg, in->bits);
        } else if (in->mode == 1) {
            s->bus.frozen_mask = (uint8_t)(s->bus.frozen_mask | bit);
        } else if (in->mode == 2) {
            s->bus.stale_mask = (uint8_t)(s->bus.stale_mask | bit), s->bus.stale_ticks = (uint16_t)in->ticks;
        }
    } else if (in->what == HS_INJECT_SENSOR) {
        st = hs_plant_inject_sensor(&s->plant, in->leg, (hs_sensor_fault_t)in->mode, in->value);
    } else if (in->what == HS_INJECT_VALVE || in->what == HS_INJECT_ENDSTOP) {
        st = hs_plant_inject_valve(&s->plant, in->leg, in->what == HS_INJECT_ENDSTOP ? 1 : in->mode, in->value);
    } else if (in->what == HS_INJECT_SUPPLY) {
        st = hs_plant_inject_supply(&s->plant, in->mode);
    } else if (in->what == HS_INJECT_FK) {
        for (int i = 0; i < HS_LEGS && st == HS_OK; i++) {
            st = hs_plant_inject_sensor(&s->plant, i, HS_SENSOR_JUMP, (i % 2 == 0) ? in->value : -in->value);
        }
    } else {
        clear_injections(s);
    }
    return st == HS_OK ? 0 : -1;
}

static void act_force(soak_t *s, const hs_action_t *a)
{
    sp_can_frame_t f;
    (void)sp_proto_encode_force(&a->force, s->force_counter, &f);
    s->force_counter = (uint8_t)((s->force_counter + 1u) & 0x0Fu);
    send_op(s, &f, 1);
    if (a->cmd.command != 0u) {
        send_command(s, &a->cmd, 1);
    }
}

static void act_leg(soak_t *s, const hs_action_t *a)
{
    if (a->kind == HS_ACTION_SILENCE) {
        s->bus.silent_mask = (uint8_t)(s->bus.silent_mask | (1u << a->leg));
        s->injected = 1;
    } else if (a->kind == HS_ACTION_UNSILENCE) {
        s->bus.silent_mask = (uint8_t)(s->bus.silent_mask & ~(1u << a->leg));
    } else {
        (void)hs_plant_raise_faults(&s->plant, a->leg, a->bits);
        s->injected = 1;
    }
}

/* One action; 0 done, -1 the plant refused it (a defect of soak_gen.c). */
static int act(soak_t *s, const hs_action_t *a)
{
    sp_can_frame_t f;
    switch (a->kind) {
    case HS_ACTION_CMD:
        send_command(s, &a->cmd, 1);
        return 0;
    case HS_ACTION_TARGET:
        (void)sp_proto_encode_target(&a->target, s->target_counter, &f);
        s->target_counter = (uint8_t)((s->target_counter + 1u) & 0x0Fu);
        send_op(s, &f, 1);
        return 0;
    case HS_ACTION_WRENCH:
        act_wrench(s, a);
        return 0;
    case HS_ACTION_CONTACT:
        return act_contact(s, a);
    case HS_ACTION_LOAD:
        return hs_plant_add_mass(&s->plant, a->mass, a->point) == HS_OK ? 0 : -1;
    case HS_ACTION_FORCE:
        act_force(s, a);
        return 0;
    case HS_ACTION_PUSH:
        act_push(s, a);
        return 0;
    case HS_ACTION_FTSENSOR:
        s->ft_silent = (a->bits == 0u);
        return 0;
    case HS_ACTION_SILENCE:
    case HS_ACTION_UNSILENCE:
    case HS_ACTION_FAULT:
        act_leg(s, a);
        return 0;
    case HS_ACTION_MARK:
        if (strncmp(a->text, "soak:", 5) == 0) {
            soak_mark(s, a->text);
        }
        return 0;
    case HS_ACTION_INJECT:
        return act_inject(s, &a->inject);
    default: /* DELAY, WAIT, END: the player's; PLAY: not generated */
        return 0;
    }
}

/* An episode waiting while the controller has been in FAULT or ESTOP for
 * 2 s is given up: the next one starts from that state (RESET). */
static void stuck(soak_t *s)
{
    int latched = s->status_state == SP_STATE_FAULT || s->status_state == SP_STATE_ESTOP;
    s->latched_ticks = latched ? s->latched_ticks + 1u : 0u;
    if (s->latched_ticks >= 2000u && s->scn.action[s->scn.pc].kind == HS_ACTION_WAIT &&
        s->scn.action[s->scn.pc].state != SP_STATE_ENGAGING) {
        s->have_episode = 0, s->latched_ticks = 0u;
    }
}

/* The episode's actions due now; a new episode when one ends. 0 ok, 3 a defect. */
static int operate(soak_t *s)
{
    for (int guard = 0; guard <= HS_SCENARIO_MAX_ACTIONS; guard++) {
        if (!s->have_episode) {
            hs_scenario_error_t err;
            const char *text =
                soak_gen_episode(&s->gen, s->status_state < 0 ? SP_STATE_IDLE : s->status_state, s->status_faults);
            if (hs_scenario_parse(&s->scn, text, "soak episode", &err) != HS_OK) {
                fprintf(stderr, "hs_soak: %s\n%s", err.message, text);
                return 3;
            }
            s->have_episode = 1;
            if (s->o.trace) {
                printf("hs_soak: tick %" PRIu64 " episode %" PRIu64 ":\n%s", s->tick, s->gen.episodes, text);
            }
        }
        const hs_action_t *a = NULL;
        hs_scenario_next_t next = hs_scenario_next(&s->scn, s->tick, s->status_state, &a);
        if (next == HS_SCENARIO_PENDING) {
            stuck(s);
            return 0;
        }
        if (next != HS_SCENARIO_DUE) {
            s->timeouts += (next == HS_SCENARIO_TIMEOUT);
            s->have_episode = 0; /* ended (or a wait timed out): the next one from the state now */
            continue;
        }
        if (act(s, a) != 0) {
            fprintf(stderr, "hs_soak: tick %" PRIu64 ": the plant refused line %d of:\n%s", s->tick, a->line,
                    s->gen.text);
            return 3;
        }
    }
    return 0;
}

/* ---- the cycle ------------------------------------------------------------ */

static void send_ft(soak_t *s)
{
    sp_msg_ft_t m;
    sp_can_frame_t f;
    if (s->ft_silent) {
        return;
    }
    for (int k = 0; k < 6; k++) {
        double q = s->ft.reading[k] * 256.0;
        m.wrench[k] = (sp_q8_t)llround(q > 2.0e9 ? 2.0e9 : (q < -2.0e9 ? -2.0e9 : q));
    }
    m.saturated = (uint8_t)(s->ft.saturated ? 1u : 0u);
    (void)sp_proto_encode_ft(&m, s->ft_counter, &f);
    s->ft_counter = (uint8_t)((s->ft_counter + 1u) & 0x0Fu);
    to_controller(s, &f, 1u);
}

/* The controller's tick and its frames through the injector to the plant. */
static void controller_cycle(soak_t *s)
{
    static sp_can_frame_t raw[SP_NODE_MAX_TX], out[MAX_FRAMES];
    uint32_t t = 0, n = 0, m = 0;
    if (sp_node_cycle_ready(&s->node, &t)) {
        (void)sp_node_tick(&s->ncfg, &s->node, raw, &n);
    }
    (void)hs_inject_filter(&s->inj, HS_INJ_TO_PLANT, s->tick, raw, n, out, MAX_FRAMES, &m);
    for (uint32_t k = 0; k < m; k++) {
        if (out[k].bus == SP_BUS_OPS) {
            take_ops(s, &out[k]);
        } else {
            (void)hs_bus_receive(&s->bus, &s->plant, &out[k]);
        }
    }
}

static void ft_advance(soak_t *s)
{
    hs_state_t st;
    double rot[3][3];
    (void)hs_plant_state(&s->plant, &st);
    hs_rot_from_quat(st.quat, rot);
    (void)hs_ft_advance(&s->ft, (double)s->tick * 1.0e-3, rot, st.wrench);
}

/* ---- the check ------------------------------------------------------------ */

static void snapshot(const soak_t *s, soak_snap_t *sn)
{
    hs_state_t st;
    const sp_ctrl_output_t *out = &s->node.out;
    (void)hs_plant_state(&s->plant, &st);
    sn->tick = s->tick;
    sn->state = out->state;
    sn->faults = out->faults;
    sn->active = out->drive_mode == SP_DRIVE_ACTIVE;
    sn->injected = s->injected;
    sn->reference = out->reference.pose;
    sn->finite = 1;
    for (int i = 0; i < SP_LEGS; i++) {
        sn->sp[i] = out->setpoint[i];
        sn->length[i] = st.length[i];
        sn->force[i] = st.force[i];
        sn->finite &= isfinite(st.length[i]) && isfinite(st.force[i]) && isfinite(st.pose[i]);
    }
    sn->unaccounted = unaccounted(s);
    sn->saturated = s->node.stats.saturated - s->saturated_last;
}

/* --break NAME@TICK: this tick's snapshot made to violate NAME. */
static void provoke(const soak_t *s, soak_snap_t *sn)
{
    switch ((soak_violation_t)s->o.brk) {
    case SOAK_V_WORKSPACE:
        sn->active = 1, sn->reference.pos[0] = s->lim.lim.ws_hi[0] + 1;
        break;
    case SOAK_V_STROKE:
        sn->length[2] = s->lim.length_hi + 0.001;
        break;
    case SOAK_V_FORCE:
        sn->injected = 0, sn->force[4] = -2.0 * s->lim.plant_force_max;
        break;
    case SOAK_V_TRANSITION:
        sn->prev_state = SP_STATE_IDLE, sn->state = SP_STATE_RUNNING, sn->cmd = SP_CMD_NONE;
        break;
    case SOAK_V_FRAMES:
        sn->unaccounted += 1u;
        break;
    case SOAK_V_OVERFLOW:
        sn->saturated += 1u;
        break;
    default:
        sn->finite = 0;
        break;
    }
}

static void report_violation(const soak_t *s, soak_violation_t v, const char *why)
{
    fprintf(stderr,
            "hs_soak: VIOLATION %s at tick %" PRIu64 " (%.3f s simulated), seed %" PRIu64 ": %s\n"
            "hs_soak: controller %s, faults 0x%04x; the episode (%" PRIu64 ") under way:\n%s"
            "hs_soak: replay: hs_soak --seed %" PRIu64 " --ticks %" PRIu64 "%s --trace\n",
            soak_violation_name(v), s->tick, (double)s->tick / 1000.0, s->o.seed, why, sp_state_name(s->node.out.state),
            (unsigned)s->node.out.faults, s->gen.episodes, s->gen.text, s->o.seed, s->tick + 1u,
            s->o.wide ? (s->o.strict ? " --wide --strict" : " --wide") : (s->o.strict ? " --strict" : ""));
}

static void tally(soak_t *s, const soak_snap_t *sn)
{
    s->checks += SOAK_INVARIANTS;
    s->state_ticks[sn->state & (SOAK_STATES - 1)]++;
    if (sn->prev_state != sn->state) {
        s->transitions[sn->prev_state & (SOAK_STATES - 1)][sn->state & (SOAK_STATES - 1)]++;
        if (s->o.trace) {
            printf("hs_soak: tick %" PRIu64 " %s -> %s faults 0x%04x\n", s->tick, sp_state_name(sn->prev_state),
                   sp_state_name(sn->state), (unsigned)sn->faults);
        }
    }
    s->refused += s->node.out.cmd_rejected;
    for (int i = 0; i < SP_LEGS; i++) {
        double f = fabs(sn->force[i]), spf = fabs((double)sn->sp[i].force / 256.0);
        double margin = fmin(sn->length[i] - s->lim.length_lo, s->lim.length_hi - sn->length[i]);
        s->peak_force = (!sn->injected && f > s->peak_force) ? f : s->peak_force;
        s->peak_sp_force = (sn->active && spf > s->peak_sp_force) ? spf : s->peak_sp_force;
        s->min_margin_len = (margin < s->min_margin_len) ? margin : s->min_margin_len;
    }
    if (sn->state != SP_STATE_FAULT && sn->state != SP_STATE_ESTOP &&
        (sn->prev_state == SP_STATE_FAULT || sn->prev_state == SP_STATE_ESTOP)) {
        s->injected = 0; /* left FAULT/ESTOP with the injections cleared: clean again */
    }
}

/* A REFERENCE fault while RUNNING an accepted motion (issue 35): once a
 * known defect (a stream's STOP or a six-axis MOVE_TO drove a leg beyond
 * its rate limit, each axis within its own), fixed in the controller
 * (spi_move_plan_legs, spi_stream_limits); --strict makes one a
 * violation. Without --strict such a fault is counted and reported. */
static void known_reference(soak_t *s, soak_snap_t *sn, int moving)
{
    if (!s->o.strict && moving && (sn->faults & ~sn->prev_faults) == SP_FAULT_REFERENCE) {
        if (s->known++ == 0u) {
            s->known_first = s->tick;
        }
        sn->prev_faults |= SP_FAULT_REFERENCE;
    }
}

/* One cycle: the operator, the frames to the controller, its tick, the
 * frames to the plant, the plant's 1 ms, the invariants. 0 ok, 1 a
 * violation, 3 a defect, 5 the plant's step failed. */
static int cycle(soak_t *s)
{
    sp_can_frame_t tx[HS_BUS_MAX_TX];
    uint32_t n = 0;
    soak_snap_t sn;
    char why[256];
    int r = operate(s);
    if (r != 0) {
        return r;
    }
    wrench_now(s);
    heartbeat(s);
    send_ft(s);
    (void)hs_bus_cycle_frames(&s->bus, &s->plant, (uint32_t)s->tick, 1u, tx, &n);
    to_controller(s, tx, n);
    memset(&sn, 0, sizeof sn);
    sn.prev_state = s->node.ctrl.state;
    sn.prev_faults = s->node.ctrl.faults;
    sn.reset_pending = s->node.ctrl.drive_reset.left > 0u;
    sn.cmd = (s->node.cmd_count > 0u) ? s->node.cmd_queue[s->node.cmd_head].command : SP_CMD_NONE;
    int moving = s->node.ctrl.state == SP_STATE_RUNNING;
    controller_cycle(s);
    if (hs_plant_step(&s->plant, 1.0e-3) != HS_OK) {
        fprintf(stderr, "hs_soak: the plant's step failed at tick %" PRIu64 " (seed %" PRIu64 ")\n", s->tick,
                s->o.seed);
        return 5;
    }
    snapshot(s, &sn);
    if (s->o.brk != 0 && s->tick == s->o.brk_tick) {
        provoke(s, &sn);
    }
    known_reference(s, &sn, moving);
    soak_violation_t v = soak_check(&s->lim, &sn, why, sizeof why);
    if (v != SOAK_OK) {
        report_violation(s, v, why);
        return 1;
    }
    tally(s, &sn);
    s->saturated_last = s->node.stats.saturated;
    s->tick++;
    ft_advance(s);
    return 0;
}

/* ---- set-up, summary, options --------------------------------------------- */

static int setup(soak_t *s)
{
    hs_params_t par;
    hs_rng_t r;
    if (hs_params_default(&par) != HS_OK || hs_plant_init(&s->plant, &par, hs_config_default.park) != HS_OK ||
        sp_node_default_config(&s->ncfg, &sp_platform_default) != SP_OK) {
        fprintf(stderr, "hs_soak: the default plant or platform is not usable\n");
        return 1;
    }
    par.sensors.seed = s->o.seed;
    (void)hs_plant_init(&s->plant, &par, hs_config_default.park);
    (void)hs_bus_init(&s->bus);
    (void)hs_inject_init(&s->inj, s->o.seed ^ UINT64_C(0x9E3779B97F4A7C15));
    hs_rng_seed(&r, s->o.seed ^ UINT64_C(0x6b6579)); /* the machine key of this run */
    for (unsigned k = 0; k < sizeof s->key.k; k++) {
        s->key.k[k] = (uint8_t)hs_rng_next(&r);
    }
    s->ncfg.sync_master = 0u;
    s->ncfg.auth_key = &s->key;
    s->ncfg.auth_session = 1u;
    (void)sp_ctrl_set_wrench_source(&s->ncfg.ctrl, sp_wrench_source_default, &sp_ft_mount_default);
    (void)sp_node_init(&s->node, &s->ncfg);
    hs_ft_params_t ftp = hs_ft_default_params();
    for (int k = 0; k < 3; k++) {
        ftp.mount_pos[k] = hs_config_default.force_sensor.mount_pos[k];
        ftp.mount_rpy[k] = hs_config_default.force_sensor.mount_rpy[k];
    }
    ftp.rate_hz = hs_config_default.force_sensor.rate_hz;
    (void)hs_ft_init(&s->ft, &ftp, s->o.seed + 0x5eed0f7u);
    ft_advance(s);
    soak_gen_init(&s->gen, s->o.seed);
    s->gen.wide = s->o.wide;
    s->status_state = -1;
    s->lim.lim = s->node.ctrl.prep.limits;
    s->lim.length_lo = s->plant.par.cyl[0].length_min - 0.005; /* SP_LEG_LIMIT_TOLERANCE */
    s->lim.length_hi = s->plant.par.cyl[0].length_min + s->plant.par.cyl[0].stroke + 0.005;
    s->lim.plant_force_max = (double)s->lim.lim.force_max / 256.0;
    s->min_margin_len = 1e9;
    return 0;
}

static void summary(const soak_t *s, double wall, int rc)
{
    const hs_inject_stats_t *is = &s->inj.stats;
    double sim = (double)s->tick / 1000.0;
    printf("hs_soak summary: seed %" PRIu64 ", simulated %.3f s (%.3f h), wall %.1f s, %.1fx real time, exit %d\n",
           s->o.seed, sim, sim / 3600.0, wall, wall > 0.0 ? sim / wall : 0.0, rc);
    printf("hs_soak checks: %" PRIu64 " ticks x %d invariants = %" PRIu64 " checks, violations %d\n", s->tick,
           SOAK_INVARIANTS, s->checks, rc == 1);
    printf("hs_soak operator: episodes %" PRIu64 ", commands %" PRIu64 ", refused %" PRIu64
           ", forged/replayed/unsigned %" PRIu64 ", injections %" PRIu64 ", waits timed out %" PRIu64
           ", contacts refused by the plant %" PRIu64 "\n",
           s->gen.episodes, s->commands, s->refused, s->forged, s->injections, s->timeouts, s->contacts_refused);
    uint32_t ctrl_refused = 0, plant_refused = 0;
    for (int e = 1; e < SP_PROTO_ERRORS; e++) {
        ctrl_refused += s->node.stats.rejected[e], plant_refused += s->bus.stats.rejected[e];
    }
    printf("hs_soak frames: in %u, dropped %u, bus-off %u, delayed %u, duplicated %u, reordered %u, corrupted %u, "
           "pending %u; refused by the controller %u (bad tag %u, replayed %u), by the drives %u (modulo 2^32)\n",
           is->in, is->dropped, is->busoff, is->delayed, is->duplicated, is->reordered, is->corrupted, is->pending,
           ctrl_refused, s->node.stats.rejected[SP_PROTO_AUTH_BAD_TAG], s->node.stats.rejected[SP_PROTO_AUTH_REPLAYED],
           plant_refused);
    printf("hs_soak known (issue 35, --strict makes them violations): %" PRIu64
           " REFERENCE faults while RUNNING an accepted motion, the first at tick %" PRIu64 "\n",
           s->known, s->known_first);
    printf("hs_soak peaks: true cylinder force %.0f N with no fault injected (bound %.0f N), force feed-forward "
           "%.0f N, closest true leg to its stroke end %.2f mm inside the tolerance\n",
           s->peak_force, s->lim.plant_force_max, s->peak_sp_force, s->min_margin_len * 1e3);
    printf("hs_soak states (s):");
    for (int k = 0; k < SOAK_STATES; k++) {
        printf(" %s %.1f", sp_state_name((sp_state_t)k), (double)s->state_ticks[k] / 1000.0);
    }
    printf("\nhs_soak transitions:");
    for (int a = 0; a < SOAK_STATES; a++) {
        for (int b = 0; b < SOAK_STATES; b++) {
            if (s->transitions[a][b] != 0u) {
                printf(" %s>%s %" PRIu64, sp_state_name((sp_state_t)a), sp_state_name((sp_state_t)b),
                       s->transitions[a][b]);
            }
        }
    }
    printf("\n");
}

static int parse_break(opts_t *o, const char *v)
{
    const char *at = strchr(v, '@');
    for (int k = 1; at != NULL && k <= SOAK_V_FINITE; k++) {
        const char *name = soak_violation_name((soak_violation_t)k);
        if (strlen(name) == (size_t)(at - v) && strncmp(v, name, strlen(name)) == 0) {
            o->brk = k;
            o->brk_tick = strtoull(at + 1, NULL, 10);
            return 0;
        }
    }
    return -1;
}

static int parse_options(opts_t *o, int argc, char **argv)
{
    o->ticks = 60000u, o->seed = 1u;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            printf("usage: hs_soak [--hours H | --seconds S | --ticks N] [--seed S] [--max-wall S] [--wide] "
                   "[--strict]\n               [--break INVARIANT@TICK] [--trace] [--quiet]\n"
                   "The randomised soak (docs/explanation/testing.md, \"The soak\"); the options: the head of "
                   "host_sim/app/hs_soak.c.\n");
            return -1;
        }
        int flag = strcmp(a, "--wide") == 0 || strcmp(a, "--trace") == 0 || strcmp(a, "--quiet") == 0 ||
                   strcmp(a, "--strict") == 0;
        if (flag) {
            o->strict |= strcmp(a, "--strict") == 0;
            o->wide |= strcmp(a, "--wide") == 0, o->trace |= strcmp(a, "--trace") == 0;
            o->quiet |= strcmp(a, "--quiet") == 0;
            continue;
        }
        if (v == NULL) {
            fprintf(stderr, "hs_soak: %s needs a value (--help: see the file's head)\n", a);
            return 2;
        }
        char *end = NULL;
        double d = strtod(v, &end);
        int ok = end != v && *end == '\0' && d >= 0.0 && d < 1e7;
        if (strcmp(a, "--hours") == 0 && ok) {
            o->ticks = (uint64_t)llround(d * 3.6e6);
        } else if (strcmp(a, "--seconds") == 0 && ok) {
            o->ticks = (uint64_t)llround(d * 1e3);
        } else if (strcmp(a, "--ticks") == 0 && ok) {
            o->ticks = (uint64_t)d;
        } else if (strcmp(a, "--seed") == 0 && end != v && *end == '\0') {
            o->seed = strtoull(v, NULL, 10);
        } else if (strcmp(a, "--max-wall") == 0 && ok) {
            o->max_wall = d;
        } else if (!(strcmp(a, "--break") == 0 && parse_break(o, v) == 0)) {
            fprintf(stderr, "hs_soak: bad option %s %s (usage: the head of host_sim/app/hs_soak.c)\n", a, v);
            return 2;
        }
        i++;
    }
    return 0;
}

int main(int argc, char **argv)
{
    static soak_t s;
    int rc = parse_options(&s.o, argc, argv);
    if (rc != 0 || (rc = setup(&s)) != 0) {
        return rc < 0 ? 0 : rc; /* -1: --help */
    }
    (void)sp_host_stop_on_signals(); /* SIGINT/SIGTERM: stop and print the summary */
    int64_t t0 = sp_host_now_ns();
    uint64_t next_note = 3600000u;
    while (rc == 0 && s.tick < s.o.ticks && !sp_host_stop_requested()) {
        rc = cycle(&s);
        if ((s.tick & 0x3FFu) == 0u && s.o.max_wall > 0.0 && (double)(sp_host_now_ns() - t0) * 1e-9 >= s.o.max_wall) {
            break;
        }
        if (s.tick >= next_note && !s.o.quiet) {
            next_note += 3600000u;
            fprintf(stderr, "hs_soak: %.0f h simulated in %.0f s, no violation\n", (double)s.tick / 3.6e6,
                    (double)(sp_host_now_ns() - t0) * 1e-9);
        }
    }
    summary(&s, (double)(sp_host_now_ns() - t0) * 1e-9, rc);
    return rc;
}
