/*
 * hs_sim - the simulated hydraulic hexapod on SocketCAN: the plant
 * (hs/plant.h) behind the drives' side of the protocol (hs/bus.h).
 *
 *   hs_sim [--ops IF] [--axis-a IF] [--axis-b IF] [--lockstep] [--ticks N]
 *          [--scenario FILE] [--log FILE] [--truth FILE] [--seed N]
 *          [--timeout-ms MS] [--progress]
 *
 * Lockstep (deterministic): the plant is the time master. Each cycle t it
 * runs the scenario's actions due at t (operator commands on the ops bus),
 * sends every drive's feedback and SYNC(t) on both axis buses, waits until
 * the controller has answered with AXIS_SETPOINTS(t) on both axis buses and
 * CTRL_STATUS(t) and CTRL_MONITOR(t) on the ops bus, then integrates 1 ms.
 * No wall clock enters the result: the same inputs give the same log, byte
 * for byte (log timestamps are simulated time).
 *
 * Real time: the plant integrates 1 ms per wall-clock millisecond (absolute
 * deadlines) and answers each SYNC from the controller (the cycle master)
 * at once with the latest sampled feedback. Log timestamps are wall time
 * since the start.
 *
 * Scenario file (one action per line, '#' starts a comment; legs are 1..6):
 *   cmd NAME [axis=x|y|z|roll|pitch|yaw] [amplitude=A] [frequency=HZ] [fade=S] [option=0|1]
 *          NAME: ENGAGE RUN_TRIG MOVE_TO STREAM STOP PARK ESTOP RESET SET_FEEDFORWARD
 *   target X Y Z ROLL PITCH YAW    OP_TARGET_POSE (m, rad)
 *   delay S                        wait S seconds of simulated time
 *   wait STATE [S]                 until CTRL_STATUS reports STATE (idle, engaging,
 *                                  ready, running, parking, fault, estop); fails after S s (default 60)
 *   silence LEG                    the drive of LEG stops sending feedback
 *   unsilence LEG
 *   fault LEG BITS                 raises drive fault bits (hs/drive.h) on LEG
 *   mark TEXT                      prints TEXT with the tick (for logs and tests)
 *   end                            stops the run
 * Commands are sent before the cycle's feedback and SYNC, so in lockstep the
 * controller always executes them at the same tick.
 *
 * Exit status: 0 the run ended (ticks done or scenario end), 1 I/O or set-up
 * error, 2 usage or scenario syntax error, 3 the controller stopped
 * answering (lockstep), 4 a scenario wait timed out, 5 the plant's state
 * became non-finite.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "hs/bus.h"
#include "host_os.h"
#include "socketcan.h"

#define MAX_ACTIONS 256
#define RX_BUF 64

/* ---- scenario ---------------------------------------------------------- */

typedef enum { A_CMD, A_TARGET, A_DELAY, A_WAIT, A_SILENCE, A_UNSILENCE, A_FAULT, A_MARK, A_END } action_kind_t;

typedef struct {
    action_kind_t kind;
    int line;
    sp_msg_command_t cmd;
    double value[6];
    int state;
    int leg;
    uint32_t bits;
    char text[96];
} action_t;

typedef struct {
    action_t a[MAX_ACTIONS];
    int n;
    int pc;
    uint64_t until; /* delay/wait: tick it ends (wait: deadline) */
    int armed;      /* the current delay/wait has set `until` */
} scenario_t;

static const char *const k_states[] = {"idle", "engaging", "ready", "running", "parking", "fault", "estop"};
static const char *const k_cmds[] = {"NONE", "ENGAGE", "RUN_TRIG", "MOVE_TO", "STREAM",
                                     "STOP", "PARK",   "ESTOP",    "RESET",   "SET_FEEDFORWARD"};
static const char *const k_axes[] = {"x", "y", "z", "roll", "pitch", "yaw"};

static int lookup(const char *s, const char *const *names, int n)
{
    for (int i = 0; i < n; i++) {
        if (strcasecmp(s, names[i]) == 0) {
            return i;
        }
    }
    return -1;
}

static int parse_double(const char *s, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(s, &end);
    return (errno == 0 && end != s && *end == '\0' && isfinite(*v)) ? 0 : -1;
}

static sp_q24_t q24_of(double v)
{
    double q = v * 16777216.0;
    if (q > 2147483647.0) {
        return INT32_MAX;
    }
    if (q < -2147483647.0) {
        return -INT32_MAX;
    }
    return (sp_q24_t)llround(q);
}

static int parse_leg(const char *s, int *leg)
{
    double v;
    if (s == NULL || parse_double(s, &v) != 0 || v < 1.0 || v > 6.0 || v != floor(v)) {
        return -1;
    }
    *leg = (int)v - 1;
    return 0;
}

/* Parses one line into *a. Returns 0 ok, 1 blank, -1 error (message in err). */
static int parse_line(char *line, action_t *a, char *err, size_t errlen)
{
    char *hash = strchr(line, '#');
    if (hash != NULL) {
        *hash = '\0';
    }
    char *tok[10];
    int nt = 0;
    for (char *s = strtok(line, " \t\r\n"); s != NULL && nt < 10; s = strtok(NULL, " \t\r\n")) {
        tok[nt++] = s;
    }
    if (nt == 0) {
        return 1;
    }
    memset(a, 0, sizeof *a);
    const char *kw = tok[0];
    if (strcasecmp(kw, "cmd") == 0) {
        if (nt < 2 || (a->cmd.command = (uint8_t)lookup(tok[1], k_cmds, 10), lookup(tok[1], k_cmds, 10) <= 0)) {
            snprintf(err, errlen, "cmd needs a command name (ENGAGE, RUN_TRIG, ...)");
            return -1;
        }
        a->kind = A_CMD;
        for (int i = 2; i < nt; i++) {
            char *eq = strchr(tok[i], '=');
            double v = 0.0;
            if (eq == NULL) {
                snprintf(err, errlen, "expected key=value, got '%s'", tok[i]);
                return -1;
            }
            *eq = '\0';
            const char *key = tok[i], *val = eq + 1;
            if (strcmp(key, "axis") == 0) {
                int ax = lookup(val, k_axes, 6);
                if (ax < 0) {
                    snprintf(err, errlen, "unknown axis '%s'", val);
                    return -1;
                }
                a->cmd.axis = (uint8_t)ax;
            } else if (parse_double(val, &v) != 0) {
                snprintf(err, errlen, "'%s' is not a number", val);
                return -1;
            } else if (strcmp(key, "amplitude") == 0) {
                a->cmd.amplitude = q24_of(v);
            } else if (strcmp(key, "frequency") == 0 && v >= 0.0) {
                a->cmd.frequency = q24_of(v);
            } else if (strcmp(key, "fade") == 0 && v >= 0.0 && v <= 65.0) {
                a->cmd.fade_ms = (uint32_t)llround(v * 1000.0);
            } else if (strcmp(key, "option") == 0 && (v == 0.0 || v == 1.0)) {
                a->cmd.option = (uint8_t)v;
            } else {
                snprintf(err, errlen, "bad or out-of-range argument '%s'", key);
                return -1;
            }
        }
    } else if (strcasecmp(kw, "target") == 0) {
        if (nt != 7) {
            snprintf(err, errlen, "target needs 6 numbers: x y z roll pitch yaw");
            return -1;
        }
        a->kind = A_TARGET;
        for (int i = 0; i < 6; i++) {
            if (parse_double(tok[i + 1], &a->value[i]) != 0 || fabs(a->value[i]) > 8.0) {
                snprintf(err, errlen, "bad target value '%s'", tok[i + 1]);
                return -1;
            }
        }
    } else if (strcasecmp(kw, "delay") == 0) {
        if (nt != 2 || parse_double(tok[1], &a->value[0]) != 0 || a->value[0] < 0.0 || a->value[0] > 1.0e6) {
            snprintf(err, errlen, "delay needs seconds >= 0");
            return -1;
        }
        a->kind = A_DELAY;
    } else if (strcasecmp(kw, "wait") == 0) {
        a->kind = A_WAIT;
        a->value[0] = 60.0;
        if (nt < 2 || nt > 3 || (a->state = lookup(tok[1], k_states, 7)) < 0 ||
            (nt == 3 && (parse_double(tok[2], &a->value[0]) != 0 || a->value[0] <= 0.0 || a->value[0] > 1.0e6))) {
            snprintf(err, errlen,
                     "wait needs a state (idle, engaging, ready, running, parking, fault, estop) "
                     "and optionally a timeout in seconds");
            return -1;
        }
    } else if (strcasecmp(kw, "silence") == 0 || strcasecmp(kw, "unsilence") == 0) {
        a->kind = (strcasecmp(kw, "silence") == 0) ? A_SILENCE : A_UNSILENCE;
        if (nt != 2 || parse_leg(tok[1], &a->leg) != 0) {
            snprintf(err, errlen, "%s needs a leg 1..6", kw);
            return -1;
        }
    } else if (strcasecmp(kw, "fault") == 0) {
        char *end;
        a->kind = A_FAULT;
        if (nt != 3 || parse_leg(tok[1], &a->leg) != 0) {
            snprintf(err, errlen, "fault needs a leg 1..6 and fault bits");
            return -1;
        }
        unsigned long bits = strtoul(tok[2], &end, 0);
        if (*end != '\0' || bits == 0 || bits > 0xFFu) {
            snprintf(err, errlen, "fault bits must be 1..0xff");
            return -1;
        }
        a->bits = (uint32_t)bits;
    } else if (strcasecmp(kw, "mark") == 0) {
        a->kind = A_MARK;
        for (int i = 1; i < nt; i++) {
            if (i > 1) {
                strncat(a->text, " ", sizeof a->text - strlen(a->text) - 1);
            }
            strncat(a->text, tok[i], sizeof a->text - strlen(a->text) - 1);
        }
    } else if (strcasecmp(kw, "end") == 0) {
        a->kind = A_END;
    } else {
        snprintf(err, errlen, "unknown action '%s'", kw);
        return -1;
    }
    return 0;
}

static int load_scenario(const char *path, scenario_t *sc)
{
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "hs_sim: cannot open scenario %s: %s\n", path, strerror(errno));
        return -1;
    }
    char line[512], err[160];
    int ln = 0;
    while (fgets(line, sizeof line, f) != NULL) {
        ln++;
        if (sc->n >= MAX_ACTIONS) {
            fprintf(stderr, "hs_sim: %s:%d: more than %d actions\n", path, ln, MAX_ACTIONS);
            fclose(f);
            return -1;
        }
        int r = parse_line(line, &sc->a[sc->n], err, sizeof err);
        if (r < 0) {
            fprintf(stderr, "hs_sim: %s:%d: %s\n", path, ln, err);
            fclose(f);
            return -1;
        }
        if (r == 0) {
            sc->a[sc->n].line = ln;
            sc->n++;
        }
    }
    fclose(f);
    return 0;
}

/* ---- run state ---------------------------------------------------------- */

typedef struct {
    sp_socketcan_t sc;
    sp_can_port_t port;
    const char *ifs[SP_CAN_BUSES];
    hs_plant_t plant;
    hs_bus_t bus;
    scenario_t scn;
    int have_scenario;
    FILE *log;
    FILE *truth;
    uint8_t cmd_counter, target_counter;
    int status_state; /* last CTRL_STATUS state, -1 none */
    uint32_t status_faults;
    uint32_t status_tick, monitor_tick;
    uint8_t status_seen, monitor_seen;
    uint64_t ops_rejected;
    int lockstep;
    int progress;
    int64_t t0_ns;
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

static int send_frames(sim_t *s, const sp_can_frame_t *f, uint32_t n, uint64_t t_us)
{
    uint32_t sent = 0;
    sp_status_t st = s->port.send(s->port.ctx, f, n, &sent);
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
            } else {
                s->ops_rejected++;
            }
        } else if (f->id == SP_ID_CTRL_MONITOR) {
            sp_msg_monitor_t m;
            if (sp_proto_decode_monitor(f, &m, &ctr, &why) == SP_OK) {
                s->monitor_tick = m.tick;
                s->monitor_seen = 1;
            } else {
                s->ops_rejected++;
            }
        }
        return;
    }
    (void)hs_bus_receive(&s->bus, &s->plant, f);
}

/* Runs the scenario's actions due at `tick`. Returns 0 go on, 1 end, 4 wait timeout, -1 error. */
static int run_scenario(sim_t *s, uint64_t tick, uint64_t t_us)
{
    scenario_t *sc = &s->scn;
    for (int guard = 0; guard < MAX_ACTIONS + 1 && sc->pc < sc->n; guard++) {
        action_t *a = &sc->a[sc->pc];
        switch (a->kind) {
        case A_CMD: {
            sp_can_frame_t f;
            (void)sp_proto_encode_command(&a->cmd, s->cmd_counter, &f);
            s->cmd_counter = (uint8_t)((s->cmd_counter + 1u) & 0x0Fu);
            if (s->progress) {
                fprintf(stderr, "hs_sim: t=%8.3f s  command %s\n", (double)tick / 1000.0, k_cmds[a->cmd.command]);
            }
            if (send_frames(s, &f, 1u, t_us) != 0) {
                return -1;
            }
            break;
        }
        case A_TARGET: {
            sp_pose_t p;
            for (int i = 0; i < 3; i++) {
                p.pos[i] = q24_of(a->value[i]);
                p.rpy[i] = q24_of(a->value[3 + i]);
            }
            sp_can_frame_t f;
            (void)sp_proto_encode_target(&p, s->target_counter, &f);
            s->target_counter = (uint8_t)((s->target_counter + 1u) & 0x0Fu);
            if (send_frames(s, &f, 1u, t_us) != 0) {
                return -1;
            }
            break;
        }
        case A_DELAY:
            if (!sc->armed) {
                sc->until = tick + (uint64_t)llround(a->value[0] * 1000.0);
                sc->armed = 1;
            }
            if (tick < sc->until) {
                return 0;
            }
            sc->armed = 0;
            break;
        case A_WAIT:
            if (!sc->armed) {
                sc->until = tick + (uint64_t)llround(a->value[0] * 1000.0);
                sc->armed = 1;
            }
            if (s->status_state != a->state) {
                if (tick >= sc->until) {
                    fprintf(stderr,
                            "hs_sim: scenario line %d: state %s not reached within %.3f s (now %s, faults 0x%04x)\n",
                            a->line, k_states[a->state], a->value[0],
                            s->status_state >= 0 ? k_states[s->status_state] : "unknown", (unsigned)s->status_faults);
                    return 4;
                }
                return 0;
            }
            if (s->progress) {
                fprintf(stderr, "hs_sim: t=%8.3f s  state %s\n", (double)tick / 1000.0, k_states[a->state]);
            }
            sc->armed = 0;
            break;
        case A_SILENCE:
            s->bus.silent_mask = (uint8_t)(s->bus.silent_mask | (1u << a->leg));
            break;
        case A_UNSILENCE:
            s->bus.silent_mask = (uint8_t)(s->bus.silent_mask & ~(1u << a->leg));
            break;
        case A_FAULT:
            (void)hs_plant_raise_faults(&s->plant, a->leg, a->bits);
            break;
        case A_MARK:
            printf("hs_sim mark tick %" PRIu64 ": %s\n", tick, a->text);
            fflush(stdout);
            break;
        case A_END:
            return 1;
        }
        if (a->kind == A_SILENCE || a->kind == A_UNSILENCE || a->kind == A_FAULT) {
            printf("hs_sim mark tick %" PRIu64 ": %s leg %d\n", tick,
                   a->kind == A_SILENCE     ? "silence"
                   : a->kind == A_UNSILENCE ? "unsilence"
                                            : "fault",
                   a->leg + 1);
            fflush(stdout);
        }
        sc->pc++;
    }
    return sc->pc >= sc->n ? 1 : 0;
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
    fputc('\n', s->truth);
}

static void progress_line(sim_t *s, uint64_t tick)
{
    double pose[6];
    (void)hs_plant_pose(&s->plant, pose);
    double wall = (double)(sp_host_now_ns() - s->t0_ns) * 1e-9;
    fprintf(stderr,
            "hs_sim: t=%8.3f s  controller %-8s  pose x %+7.4f y %+7.4f z %6.4f m  yaw %+7.4f rad  (%.1fx real time)\n",
            (double)tick / 1000.0, s->status_state >= 0 ? k_states[s->status_state] : "-", pose[0], pose[1], pose[2],
            pose[5], wall > 0.0 ? (double)tick / 1000.0 / wall : 0.0);
}

/* Lockstep: one cycle's wait for the controller's answer. 0 ok, 3 silent, -1 error. */
static int lockstep_wait(sim_t *s, uint32_t tick, uint64_t t_us, long timeout_ms)
{
    struct pollfd pfd = {sp_socketcan_fd(&s->sc), POLLIN, 0}; /* one socket serves all buses */
    static sp_can_frame_t keep[4 * RX_BUF];
    uint32_t nkeep = 0;
    long waited_ms = 0; /* no clock reads per cycle: each one is a system call in user-mode Linux */
    s->status_seen = 0;
    s->monitor_seen = 0;
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
            return 3;
        }
        uint32_t got = 0;
        do {
            sp_can_frame_t rx[RX_BUF];
            got = 0;
            (void)s->port.receive(s->port.ctx, rx, RX_BUF, &got);
            for (uint32_t k = 0; k < got; k++) {
                take_frame(s, &rx[k]);
                if (nkeep < 4 * RX_BUF) {
                    keep[nkeep++] = rx[k];
                }
            }
        } while (got == RX_BUF);
        if (hs_bus_cycle_complete(&s->bus) && s->status_seen && s->status_tick == tick && s->monitor_seen &&
            s->monitor_tick == tick) {
            break;
        }
    }
    /* the same order every run: bus by bus, and within a bus as the controller sent them */
    for (uint8_t b = 0; b < SP_CAN_BUSES; b++) {
        for (uint32_t k = 0; k < nkeep; k++) {
            if (keep[k].bus == b) {
                log_frame(s, &keep[k], t_us);
            }
        }
    }
    return 0;
}

static void usage(void)
{
    fprintf(stderr, "usage: hs_sim [--ops IF] [--axis-a IF] [--axis-b IF] [--lockstep] [--ticks N]\n"
                    "              [--scenario FILE] [--log FILE] [--truth FILE] [--seed N] [--timeout-ms MS]\n"
                    "              [--progress]\n");
}

static int parse_u64(const char *v, unsigned long long *out)
{
    char *end;
    errno = 0;
    *out = strtoull(v, &end, 0);
    return (errno == 0 && end != v && *end == '\0' && v[0] != '-') ? 0 : -1;
}

/* Real time: answers SYNC(t) from the controller with the feedback of that instant. */
static void realtime_frames(sim_t *s, uint32_t *answered, int *have_answered)
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
                if (sp_proto_decode_sync(&rx[k], &m, &ctr, &why) == SP_OK && (!*have_answered || m.tick != *answered)) {
                    sp_can_frame_t tx[HS_BUS_MAX_TX];
                    uint32_t n = 0;
                    (void)hs_bus_cycle_frames(&s->bus, &s->plant, m.tick, 0u, tx, &n);
                    (void)send_frames(s, tx, n, t_us);
                    *answered = m.tick;
                    *have_answered = 1;
                }
                continue;
            }
            take_frame(s, &rx[k]);
        }
    } while (got == RX_BUF);
}

int main(int argc, char **argv)
{
    static sim_t s;
    memset(&s, 0, sizeof s);
    s.ifs[0] = "vcan0", s.ifs[1] = "vcan1", s.ifs[2] = "vcan2";
    s.status_state = -1;
    const char *scenario = NULL, *log_path = NULL, *truth_path = NULL;
    unsigned long long max_ticks = 0, seed = 0;
    int have_seed = 0;
    long timeout_ms = 2000;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        unsigned long long u;
        if (strcmp(a, "--lockstep") == 0) {
            s.lockstep = 1;
        } else if (strcmp(a, "--progress") == 0) {
            s.progress = 1;
        } else if (v == NULL) {
            usage();
            return 2;
        } else if (strcmp(a, "--ops") == 0) {
            s.ifs[0] = v, i++;
        } else if (strcmp(a, "--axis-a") == 0) {
            s.ifs[1] = v, i++;
        } else if (strcmp(a, "--axis-b") == 0) {
            s.ifs[2] = v, i++;
        } else if (strcmp(a, "--scenario") == 0) {
            scenario = v, i++;
        } else if (strcmp(a, "--log") == 0) {
            log_path = v, i++;
        } else if (strcmp(a, "--truth") == 0) {
            truth_path = v, i++;
        } else if (strcmp(a, "--ticks") == 0 && parse_u64(v, &u) == 0) {
            max_ticks = u, i++;
        } else if (strcmp(a, "--seed") == 0 && parse_u64(v, &u) == 0) {
            seed = u, have_seed = 1, i++;
        } else if (strcmp(a, "--timeout-ms") == 0 && parse_u64(v, &u) == 0 && u > 0 && u < 3600000) {
            timeout_ms = (long)u, i++;
        } else {
            usage();
            return 2;
        }
    }
    if (scenario != NULL) {
        if (load_scenario(scenario, &s.scn) != 0) {
            return 2;
        }
        s.have_scenario = 1;
    }
    if (scenario == NULL && max_ticks == 0 && s.lockstep) {
        fprintf(stderr, "hs_sim: lockstep needs --ticks or a --scenario that ends\n");
        return 2;
    }

    hs_params_t par;
    if (hs_params_default(&par) != HS_OK) {
        fprintf(stderr, "hs_sim: the default plant parameters are not usable\n");
        return 1;
    }
    if (have_seed) {
        par.sensors.seed = (uint64_t)seed;
    }
    hs_status_t hst = hs_plant_init(&s.plant, &par, hs_config_default.park);
    if (hst != HS_OK) {
        fprintf(stderr, "hs_sim: cannot start the plant at the park pose: %s\n", hs_status_name(hst));
        return 1;
    }
    (void)hs_bus_init(&s.bus);

    sp_socketcan_bus_cfg_t bc[SP_CAN_BUSES];
    memset(bc, 0, sizeof bc);
    bc[SP_BUS_OPS] = (sp_socketcan_bus_cfg_t){
        s.ifs[0], {SP_ID_CTRL_STATUS, SP_ID_CTRL_MONITOR, SP_ID_OP_COMMAND, SP_ID_OP_TARGET_POSE}, 4u};
    for (int b = 1; b <= 2; b++) {
        bc[b] = (sp_socketcan_bus_cfg_t){s.ifs[b], {SP_ID_AXIS_SETPOINTS, SP_ID_SYNC}, s.lockstep ? 1u : 2u};
    }
    if (sp_socketcan_open(&s.sc, bc) != SP_OK) {
        fprintf(stderr, "hs_sim: %s\n", s.sc.error);
        return 1;
    }
    s.port = sp_socketcan_port(&s.sc);
    if (log_path != NULL && (s.log = fopen(log_path, "w")) == NULL) {
        fprintf(stderr, "hs_sim: cannot write %s: %s\n", log_path, strerror(errno));
        return 1;
    }
    static char log_buf[1 << 20], truth_buf[1 << 20]; /* few write calls: each is slow in user-mode Linux */
    if (s.log != NULL) {
        (void)setvbuf(s.log, log_buf, _IOFBF, sizeof log_buf);
    }
    if (truth_path != NULL) {
        if ((s.truth = fopen(truth_path, "w")) == NULL) {
            fprintf(stderr, "hs_sim: cannot write %s: %s\n", truth_path, strerror(errno));
            return 1;
        }
        (void)setvbuf(s.truth, truth_buf, _IOFBF, sizeof truth_buf);
        fprintf(s.truth, "tick,x,y,z,roll,pitch,yaw,len1,len2,len3,len4,len5,len6,"
                         "force1,force2,force3,force4,force5,force6,drive1,drive2,drive3,drive4,drive5,drive6\n");
    }
    if (sp_host_stop_on_signals() != 0) { /* then SIGINT/SIGTERM end the program at once, as by default */
        perror("hs_sim: cannot catch SIGINT/SIGTERM");
    }
    fprintf(stderr, "hs_sim: %s mode on %s %s %s, plant at the park pose, %u substeps per 1 ms\n",
            s.lockstep ? "lockstep" : "real-time", s.ifs[0], s.ifs[1], s.ifs[2], (unsigned)par.substeps);

    int rc = 0;
    uint64_t tick = 0;
    s.t0_ns = sp_host_now_ns();
    int64_t next = s.t0_ns;
    uint32_t answered = 0;
    int have_answered = 0;
    while (!sp_host_stop_requested() && (max_ticks == 0 || tick < max_ticks)) {
        uint64_t t_us = s.lockstep ? tick * 1000u : (uint64_t)((sp_host_now_ns() - s.t0_ns) / 1000);
        if (s.have_scenario) {
            int r = run_scenario(&s, tick, t_us);
            if (r != 0) {
                rc = (r == 1) ? 0 : (r == 4 ? 4 : 1);
                break;
            }
        }
        if (s.lockstep) {
            sp_can_frame_t tx[HS_BUS_MAX_TX];
            uint32_t n = 0;
            (void)hs_bus_cycle_frames(&s.bus, &s.plant, (uint32_t)tick, 1u, tx, &n);
            if (send_frames(&s, tx, n, t_us) != 0) {
                rc = 1;
                break;
            }
            int r = lockstep_wait(&s, (uint32_t)tick, t_us, timeout_ms);
            if (r != 0) {
                if (r == 3) {
                    fprintf(stderr, "hs_sim: the controller did not answer cycle %" PRIu64 " within %ld ms\n", tick,
                            timeout_ms);
                }
                rc = (r == 3) ? 3 : 1;
                break;
            }
        } else {
            next += 1000000;
            for (;;) {
                realtime_frames(&s, &answered, &have_answered);
                int64_t left = next - sp_host_now_ns();
                if (left <= 0 || sp_host_stop_requested()) {
                    break;
                }
                struct pollfd pfd = {sp_socketcan_fd(&s.sc), POLLIN, 0};
                struct timespec ts = {(time_t)(left / 1000000000), (long)(left % 1000000000)};
                (void)ppoll(&pfd, 1, &ts, NULL);
            }
        }
        write_truth(&s, tick);
        hs_status_t st = hs_plant_step(&s.plant, 1.0e-3);
        if (st != HS_OK) {
            fprintf(stderr, "hs_sim: plant step failed at cycle %" PRIu64 ": %s\n", tick, hs_status_name(st));
            rc = 5;
            break;
        }
        tick++;
        if (s.progress && tick % 1000u == 0u) {
            progress_line(&s, tick);
        }
    }
    double wall = (double)(sp_host_now_ns() - s.t0_ns) * 1e-9;
    double pose[6];
    (void)hs_plant_pose(&s.plant, pose);
    printf("hs_sim summary: %s, cycles %" PRIu64 ", simulated %.3f s, wall %.3f s, %.2fx real time, exit %d\n",
           s.lockstep ? "lockstep" : "real-time", tick, (double)tick / 1000.0, wall,
           wall > 0.0 ? (double)tick / 1000.0 / wall : 0.0, rc);
    printf("hs_sim pose: x %.6f y %.6f z %.6f roll %.6f pitch %.6f yaw %.6f\n", pose[0], pose[1], pose[2], pose[3],
           pose[4], pose[5]);
    printf("hs_sim drives:");
    for (int i = 0; i < HS_LEGS; i++) {
        hs_feedback_t fb;
        (void)hs_plant_feedback(&s.plant, i, &fb);
        printf(" %d:%s/0x%02x", i + 1,
               fb.state == HS_DRIVE_INIT     ? "init"
               : fb.state == HS_DRIVE_HOLD   ? "hold"
               : fb.state == HS_DRIVE_ACTIVE ? "active"
                                             : "fault",
               (unsigned)fb.faults);
    }
    printf("\nhs_sim frames: setpoints accepted %u, lost %u, stale %u, ignored %u", s.bus.stats.accepted,
           s.bus.stats.lost, s.bus.stats.stale, s.bus.stats.ignored);
    for (int e = 1; e < SP_PROTO_ERRORS; e++) {
        printf(", %s %u", sp_proto_error_name((sp_proto_error_t)e), s.bus.stats.rejected[e]);
    }
    printf(", ops rejected %" PRIu64 "\n", s.ops_rejected);
    printf("hs_sim controller: last state %s, faults 0x%04x\n",
           s.status_state >= 0 ? k_states[s.status_state] : "unknown", (unsigned)s.status_faults);
    if (s.log != NULL) {
        fclose(s.log);
    }
    if (s.truth != NULL) {
        fclose(s.truth);
    }
    sp_socketcan_close(&s.sc);
    return rc;
}
