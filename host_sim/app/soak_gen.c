/* SPDX-License-Identifier: Apache-2.0 */
/*
 * soak_gen.c - the soak's operator: random episodes written in the
 * scenario language (hs/scenario.h), so that hs_soak plays them with the
 * same parser and player as hs_sim (soak_gen.h).
 */
#include "soak_gen.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "sp/control/controller.h"

/* The platform's home and workspace (config/platform_default.json): the
 * episodes' poses are drawn about home, mostly inside the box, some outside. */
static const double home_z = 2.55;
static const double box[6] = {0.45, 0.45, 0.5, 0.35, 0.35, 0.5};
static const char *const axis_name[6] = {"x", "y", "z", "roll", "pitch", "yaw"};

/* The faults of tools/stewart/faults.py (FAULTS) and a few more, as scenario lines. */
static const char *const fault_lines[] = {
    "inject frames axis_a feedback drop count=1",
    "inject frames axis_b feedback drop count=9",
    "inject frames axis_a setpoints drop count=4",
    "inject frames axis_a feedback delay delay=5 count=9",
    "inject frames axis_b feedback duplicate count=1",
    "inject frames axis_b setpoints duplicate count=1",
    "inject frames axis_a feedback reorder count=1",
    "inject frames axis_a setpoints reorder count=1",
    "inject frames axis_b feedback corrupt count=1",
    "inject frames axis_a setpoints corrupt count=1",
    "inject frames any any corrupt rate=0.001",
    "inject frames any any drop rate=0.0005",
    "inject frames ops command drop count=1",
    "inject frames ops target corrupt rate=0.05",
    "inject frames ops status drop rate=0.01",
    "inject busoff axis_a 0.5",
    "inject busoff axis_b 0.2",
    "inject busoff ops 0.5",
    "inject drive 2 fault 0x80",
    "inject drive 3 fault 0x04 hold",
    "inject drive 4 freeze",
    "inject drive 6 stale 2",
    "inject sensor 1 stick",
    "inject sensor 2 jump 0.03",
    "inject sensor 3 noise 0.01",
    "inject valve 5 stick 0",
    "inject supply loss",
    "inject endstop 3 up",
    "inject endstop 4 down",
    "inject fk 0.05",
    "silence 5",
    "fault 1 0x10",
};
#define N_FAULTS (sizeof fault_lines / sizeof fault_lines[0])

void soak_gen_init(soak_gen_t *g, uint64_t seed)
{
    memset(g, 0, sizeof *g);
    hs_rng_seed(&g->rng, seed);
}

static uint32_t below(soak_gen_t *g, uint32_t n)
{
    return (n == 0u) ? 0u : (uint32_t)(hs_rng_next(&g->rng) % n);
}

static double uniform(soak_gen_t *g, double lo, double hi)
{
    return lo + (hi - lo) * (double)(hs_rng_next(&g->rng) >> 11) * (1.0 / 9007199254740992.0);
}

static int chance(soak_gen_t *g, double p)
{
    return uniform(g, 0.0, 1.0) < p;
}

static void put(soak_gen_t *g, const char *fmt, ...)
{
    va_list ap;
    size_t room = sizeof g->text - g->len;
    va_start(ap, fmt);
    int w = vsnprintf(g->text + g->len, room, fmt, ap);
    va_end(ap);
    if (w > 0 && (size_t)w < room) {
        g->len += (size_t)w;
    }
}

/* A pose about home: `share` of the workspace box on each axis (above 1: outside). */
static void put_target(soak_gen_t *g, double share)
{
    double p[6];
    for (int k = 0; k < 6; k++) {
        p[k] = uniform(g, -share, share) * box[k];
    }
    put(g, "target %.5f %.5f %.5f %.5f %.5f %.5f\n", p[0], p[1], home_z + p[2], p[3], p[4], p[5]);
}

/* "wait ready" right after a command can pass on a status sent before the
 * controller took it: 50 ms later a taken MOVE_TO shows RUNNING, and the
 * wait lasts until the move's end. */
static void put_home_move(soak_gen_t *g)
{
    put(g, "target 0 0 %.5f 0 0 0\ncmd MOVE_TO\ndelay 0.05\nwait ready 60\n", home_z);
}

static void episode_trig(soak_gen_t *g)
{
    int a = (int)below(g, 6u);
    double amp = uniform(g, 0.002, (a < 3) ? 0.2 : 0.15) * (chance(g, 0.1) ? 3.0 : 1.0);
    double hz = uniform(g, 0.05, g->wide ? 3.0 : 1.5);
    put(g, "cmd RUN_TRIG axis=%s amplitude=%.5f frequency=%.4f fade=%.2f\n", axis_name[a], amp, hz,
        uniform(g, 0.0, 2.5));
    put(g, "delay %.3f\n", uniform(g, 0.5, 20.0));
    if (chance(g, 0.2)) {
        put(g, "cmd %s\n", chance(g, 0.5) ? "RUN_TRIG axis=x amplitude=0.01 frequency=0.5" : "ENGAGE");
    }
    put(g, "cmd STOP\nwait ready 30\n");
}

static void episode_move(soak_gen_t *g)
{
    int n = 1 + (int)below(g, 3u);
    for (int i = 0; i < n; i++) {
        put_target(g, chance(g, 0.2) ? 1.4 : 0.8);
        put(g, "cmd MOVE_TO\n");
        put(g, chance(g, 0.15) ? "delay %.3f\ncmd STOP\n" : "delay %.3f\n", uniform(g, 0.0, 0.5));
        put(g, "wait ready 60\n");
    }
    put_home_move(g);
}

static void episode_stream(soak_gen_t *g)
{
    double amp[6], hz[6];
    int n = 20 + (int)below(g, 100u);
    for (int k = 0; k < 6; k++) {
        amp[k] = uniform(g, 0.0, 0.3) * box[k];
        hz[k] = uniform(g, 0.05, 0.8);
    }
    put(g, "cmd STREAM\n");
    for (int i = 0; i < n; i++) {
        double t = 0.02 * i, p[6];
        for (int k = 0; k < 6; k++) {
            p[k] = amp[k] * (1.0 - cos(6.283185307179586 * hz[k] * t)); /* smooth, from home at rest */
        }
        if (chance(g, 0.02)) {
            p[(int)below(g, 6u)] = 2.0 * box[0]; /* unreachable: refused, the last target stays */
        }
        put(g, "target %.5f %.5f %.5f %.5f %.5f %.5f\ndelay 0.02\n", p[0], p[1], home_z + p[2], p[3], p[4], p[5]);
    }
    put(g, "cmd STOP\nwait ready 30\n");
}

static void episode_force(soak_gen_t *g)
{
    double gap = uniform(g, 0.001, 0.004), k = chance(g, 0.5) ? 1e6 : uniform(g, 1e5, 1e7);
    double f = chance(g, 0.1) ? 12000.0 : uniform(g, 300.0, 6000.0);
    /* the surface is placed a few mm from the tool point at home: be there (a motion before may have
     * ended anywhere; a surface through the platform is refused by the plant) */
    put_home_move(g);
    put(g, "tare\ndelay 0.8\n");
    put(g, "contact plane 0 0 -1 %.6f 0 0 0.05 stiffness=%.0f damping=1000\n", -(home_z + 0.05 + gap), k);
    put(g, "force z 0 0 %.1f 0 0 0\ndelay %.3f\n", f, uniform(g, 1.0, 5.0));
    if (chance(g, 0.3)) {
        put(g, "force_target z 0 0 %.1f 0 0 0\ndelay 1\n", uniform(g, 300.0, 6000.0));
    }
    if (chance(g, 0.3)) {
        put(g, "contact off\ndelay 1\n"); /* the surface removed: CONTACT_LOST */
    } else {
        put(g, "position\ndelay 1.5\ncontact off\n");
    }
    put(g, "wait ready 10\n");
    put_home_move(g);
}

static void episode_guide(soak_gen_t *g)
{
    int a = (int)below(g, 3u);
    double w[6] = {0, 0, 0, 0, 0, 0};
    w[a] = uniform(g, -300.0, 300.0);
    put(g, "tare\ndelay 0.8\nguide %s\n", axis_name[a]);
    put(g, "push %.1f %.1f %.1f 0 0 0 rise=0.02 hold=%.3f\n", w[0], w[1], w[2], uniform(g, 0.2, 1.0));
    put(g, "delay %.3f\nposition\ndelay 1.5\n", uniform(g, 1.5, 3.0));
    put_home_move(g);
}

/* Loads and wrenches the platform carries (kept within the rated payload). */
static void episode_load(soak_gen_t *g)
{
    if (g->load_kg > 0.0 && chance(g, 0.5)) {
        put(g, "load %.1f %.3f %.3f %.3f\n", -g->load_kg, g->load_at[0], g->load_at[1], g->load_at[2]);
        g->load_kg = 0.0;
    } else if (g->load_kg == 0.0) {
        g->load_kg = uniform(g, 50.0, 600.0);
        for (int k = 0; k < 3; k++) {
            g->load_at[k] = uniform(g, -0.4, 0.4);
        }
        g->load_at[2] = uniform(g, 0.0, 0.3);
        put(g, "load %.1f %.3f %.3f %.3f\n", g->load_kg, g->load_at[0], g->load_at[1], g->load_at[2]);
    }
    put(g, "wrench %.0f %.0f %.0f %.0f %.0f %.0f ramp=%.2f\n", uniform(g, -2000, 2000), uniform(g, -2000, 2000),
        uniform(g, -3000, 3000), uniform(g, -1000, 1000), uniform(g, -1000, 1000), uniform(g, -1000, 1000),
        uniform(g, 0.0, 2.0));
    episode_trig(g);
    put(g, "wrench off ramp=%.2f\ndelay 0.5\n", uniform(g, 0.0, 1.0));
}

/* Commands the state does not allow, out of range, forged or replayed. */
static void episode_invalid(soak_gen_t *g)
{
    static const char *const bad[] = {
        "cmd ENGAGE",
        "cmd RESET",
        "cmd RUN_TRIG axis=z amplitude=5 frequency=0.5",
        "cmd RUN_TRIG axis=x amplitude=0.05 frequency=0",
        "target 3 3 7 1 1 1\ncmd MOVE_TO",
        "target 0 0 2.55 0.6 0 0\ncmd MOVE_TO",
        "force z 0 0 0 0 0 0",
        "force 0 0 0 2000 0 0 0",
        "force_target z 0 0 1000 0 0 0",
        "guide 0",
        "position",
        "cmd SET_FEEDFORWARD option=0\ncmd SET_FEEDFORWARD option=1",
        "mark soak:forge",
        "mark soak:replay",
        "mark soak:unsigned",
        "target 0 0 2.6 0 0 0",
    };
    int n = 1 + (int)below(g, 6u);
    for (int i = 0; i < n; i++) {
        put(g, "%s\ndelay %.3f\n", bad[below(g, (uint32_t)(sizeof bad / sizeof bad[0]))], uniform(g, 0.0, 0.2));
    }
}

static void episode_fault(soak_gen_t *g)
{
    if (chance(g, 0.5)) {
        put(g, "cmd RUN_TRIG axis=%s amplitude=0.05 frequency=%.3f\n", axis_name[below(g, 6u)], uniform(g, 0.1, 1.0));
    } else {
        put_target(g, 0.5);
        put(g, "cmd MOVE_TO\n");
    }
    put(g, "delay %.3f\n%s\n", uniform(g, 0.2, 2.0), fault_lines[below(g, (uint32_t)N_FAULTS)]);
    put(g, "delay %.3f\ncmd STOP\ndelay 0.5\ncmd STOP\n", uniform(g, 0.5, 3.0));
    if (chance(g, 0.3)) {
        put(g, "cmd ESTOP\ndelay 0.3\ncmd ESTOP\n"); /* an ESTOP during the reaction, and a second */
    }
    put(g, "delay 2\ninject clear\nunsilence 5\nwait ready 3\n"); /* a latched fault: RESET next */
}

static void episode_estop(soak_gen_t *g)
{
    put(g, "cmd RUN_TRIG axis=%s amplitude=%.4f frequency=%.3f\n", axis_name[below(g, 6u)], uniform(g, 0.01, 0.1),
        uniform(g, 0.1, 1.2));
    put(g, "delay %.3f\ncmd ESTOP\ndelay %.3f\n", uniform(g, 0.0, 4.0), uniform(g, 0.2, 2.0));
    if (chance(g, 0.3)) {
        put(g, "cmd ENGAGE\ncmd RUN_TRIG axis=x amplitude=0.01 frequency=0.5\n"); /* refused in ESTOP */
    }
}

/* The operator falls silent during a motion: the operator link stops it
 * and latches OPERATOR_SILENT, which RESET clears in READY. */
static void episode_quiet(soak_gen_t *g)
{
    put(g, "cmd RUN_TRIG axis=%s amplitude=0.03 frequency=%.3f\n", axis_name[below(g, 6u)], uniform(g, 0.1, 1.0));
    put(g, "delay %.3f\nmark soak:quiet\ndelay 1\n", uniform(g, 0.2, 2.0));
    put(g, "cmd RUN_TRIG axis=x amplitude=0.01 frequency=0.5\nwait ready 20\n"); /* refused: latched */
}

static void episode_park(soak_gen_t *g)
{
    put(g, "cmd PARK\n");
    if (chance(g, 0.2)) {
        put(g, "delay %.3f\ncmd ESTOP\n", uniform(g, 0.0, 3.0));
        return;
    }
    put(g, "wait idle 60\ndelay %.3f\ncmd ENGAGE\nwait ready 60\n", uniform(g, 0.0, 1.0));
}

/* From a state other than READY: back to READY (or wherever the commands lead). */
static void episode_recover(soak_gen_t *g, int state)
{
    switch (state) {
    case SP_STATE_FAULT:
    case SP_STATE_ESTOP:
        put(g, "inject clear\nunsilence 5\nftsensor on\ncontact off\nwrench off\ndelay %.3f\ncmd RESET\n",
            uniform(g, 0.1, 1.0));
        put(g, "wait engaging 1\nwait ready 60\n");
        break;
    case SP_STATE_IDLE:
        if (chance(g, 0.2)) {
            episode_invalid(g);
        }
        put(g, "cmd ENGAGE\nwait ready 60\n");
        break;
    default: /* ENGAGING, RUNNING, PARKING: let it end, sometimes interrupt it */
        if (chance(g, 0.2)) {
            put(g, "cmd %s\n", chance(g, 0.5) ? "STOP" : "ESTOP");
        }
        put(g, "wait ready 60\n");
        break;
    }
}

const char *soak_gen_episode(soak_gen_t *g, int state, uint32_t faults)
{
    g->len = 0;
    g->text[0] = '\0';
    g->episodes++;
    if ((faults & SP_FAULT_OPERATOR_SILENT) != 0u && (state == SP_STATE_READY || state == SP_STATE_IDLE)) {
        put(g, "cmd RESET\ndelay 0.1\n"); /* clears the operator link's fault, nothing else */
    }
    if (state != SP_STATE_READY) {
        episode_recover(g, state);
    } else {
        static void (*const kinds[])(soak_gen_t *) = {
            episode_trig,    episode_trig,  episode_move,  episode_stream, episode_force, episode_guide, episode_load,
            episode_invalid, episode_fault, episode_fault, episode_estop,  episode_park,  episode_quiet,
        };
        kinds[below(g, (uint32_t)(sizeof kinds / sizeof kinds[0]))](g);
    }
    put(g, "end\n");
    return g->text;
}
