/* SPDX-License-Identifier: Apache-2.0 */
/* scenario_inject.c - the `inject` actions of the scenario language
 * (hs/scenario.h, "Fault injection"; docs/explanation/faults.md). */
#define _POSIX_C_SOURCE 200809L
#include "scenario_inject.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "sp/link/protocol.h"

#define BUS_LIST "ops, axis_a, axis_b"
#define MSG_LIST "setpoints, feedback, command, target, heartbeat, status, monitor, wrench, any, or 0..0x7ff"
#define FAULT_LIST "drop, delay, duplicate, reorder, corrupt"
#define WHAT_LIST "frames, busoff, drive, sensor, valve, supply, endstop, fk, clear"
#define MAX_COUNT 1.0e6
#define MAX_DELAY 1.0e5
#define MAX_BUSOFF_S 1.0e6
#define MAX_SENSOR_M 10.0

#if defined(__GNUC__)
static int bad(char *why, size_t len, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
#endif

static int bad(char *why, size_t len, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(why, len, fmt, ap);
    va_end(ap);
    return -1;
}

static int number(const char *s, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(s, &end);
    return (errno == 0 && end != s && *end == '\0' && isfinite(*v)) ? 0 : -1;
}

static int leg_of(const char *s, int *leg)
{
    double v;
    if (number(s, &v) != 0 || v < 1.0 || v > 6.0 || v != floor(v)) {
        return -1;
    }
    *leg = (int)v - 1;
    return 0;
}

/* ops, axis_a, axis_b (any when allowed). -1 unknown. */
static int bus_of(const char *s, int allow_any)
{
    static const char *const names[3] = {"ops", "axis_a", "axis_b"};
    for (int b = 0; b < 3; b++) {
        if (strcasecmp(s, names[b]) == 0) {
            return b;
        }
    }
    return (allow_any && strcasecmp(s, "any") == 0) ? 0xFF : -1;
}

/* A message name or identifier into [lo, hi]. 0 ok, -1 unknown. */
static int msg_of(const char *s, uint32_t *lo, uint32_t *hi)
{
    static const struct {
        const char *name;
        uint32_t lo, hi;
    } msgs[] = {
        {"setpoints", SP_ID_AXIS_SETPOINTS, SP_ID_AXIS_SETPOINTS},
        {"feedback", SP_ID_AXIS_FEEDBACK_1, SP_ID_AXIS_FEEDBACK_1 + SP_AXIS_SLOTS - 1u},
        {"command", SP_ID_OP_COMMAND, SP_ID_OP_COMMAND},
        {"target", SP_ID_OP_TARGET_POSE, SP_ID_OP_TARGET_POSE},
        {"heartbeat", SP_ID_OP_HEARTBEAT, SP_ID_OP_HEARTBEAT},
        {"status", SP_ID_CTRL_STATUS, SP_ID_CTRL_STATUS},
        {"monitor", SP_ID_CTRL_MONITOR, SP_ID_CTRL_MONITOR},
        {"wrench", SP_ID_CTRL_WRENCH, SP_ID_CTRL_WRENCH},
        {"any", 0u, 0x7FFu},
    };
    for (size_t k = 0; k < sizeof msgs / sizeof msgs[0]; k++) {
        if (strcasecmp(s, msgs[k].name) == 0) {
            *lo = msgs[k].lo;
            *hi = msgs[k].hi;
            return 0;
        }
    }
    char *end;
    errno = 0;
    unsigned long id = strtoul(s, &end, 0);
    if (errno != 0 || end == s || *end != '\0' || s[0] == '-' || id > 0x7FFu) {
        return -1;
    }
    *lo = *hi = (uint32_t)id;
    return 0;
}

static int parse_frames(char **w, int nw, hs_scenario_inject_t *in, char *why, size_t len)
{
    static const char *const faults[5] = {"drop", "delay", "duplicate", "reorder", "corrupt"};
    if (nw == 3 && strcasecmp(w[2], "off") == 0) {
        in->what = HS_INJECT_FRAMES_OFF;
        return 1;
    }
    if (nw < 5) {
        return bad(why, len, "inject frames needs BUS MSG FAULT (or 'off'), got %d arguments", nw - 2);
    }
    in->what = HS_INJECT_FRAMES;
    if ((in->bus = bus_of(w[2], 1)) < 0) {
        return bad(why, len, "unknown bus '%.40s' (" BUS_LIST ", any)", w[2]);
    }
    if (msg_of(w[3], &in->id_lo, &in->id_hi) != 0) {
        return bad(why, len, "unknown message '%.40s' (" MSG_LIST ")", w[3]);
    }
    in->fault = -1;
    for (int k = 0; k < 5; k++) {
        if (strcasecmp(w[4], faults[k]) == 0) {
            in->fault = k;
        }
    }
    if (in->fault < 0) {
        return bad(why, len, "unknown frame fault '%.40s' (" FAULT_LIST ")", w[4]);
    }
    int have_rate = 0, have_count = 0, have_delay = 0;
    in->delay = 5u;
    for (int i = 5; i < nw; i++) {
        char *eq = strchr(w[i], '=');
        double v;
        if (eq == NULL) {
            return bad(why, len, "inject frames: expected key=value, got '%.40s'", w[i]);
        }
        *eq = '\0';
        if (number(eq + 1, &v) != 0) {
            return bad(why, len, "inject frames: %.20s '%.40s' is not a number", w[i], eq + 1);
        }
        if (strcmp(w[i], "rate") == 0 && !have_rate) {
            if (!(v > 0.0 && v <= 1.0)) {
                return bad(why, len, "inject frames: rate %.40s is out of range (0 < P <= 1)", eq + 1);
            }
            in->rate = v;
            have_rate = 1;
        } else if (strcmp(w[i], "count") == 0 && !have_count) {
            if (v < 1.0 || v > MAX_COUNT || v != floor(v)) {
                return bad(why, len, "inject frames: count %.40s is not 1..%g", eq + 1, MAX_COUNT);
            }
            in->count = (uint32_t)v;
            have_count = 1;
        } else if (strcmp(w[i], "delay") == 0 && !have_delay) {
            if (v < 1.0 || v > MAX_DELAY || v != floor(v)) {
                return bad(why, len, "inject frames: delay %.40s is not 1..%g ticks", eq + 1, MAX_DELAY);
            }
            in->delay = (uint32_t)v;
            have_delay = 1;
        } else {
            return bad(why, len, "inject frames: unknown or repeated argument '%.40s' (rate, count, delay)", w[i]);
        }
    }
    if (have_delay && in->fault != 1) {
        return bad(why, len, "inject frames: delay= only goes with the delay fault");
    }
    if (!have_rate && !have_count) {
        in->count = 1u;
    }
    return 1;
}

static int parse_busoff(char **w, int nw, hs_scenario_inject_t *in, char *why, size_t len)
{
    double s;
    if (nw < 3 || nw > 4) {
        return bad(why, len, "inject busoff needs BUS [S | off], got %d arguments", nw - 2);
    }
    in->what = HS_INJECT_BUSOFF;
    in->mode = 1;
    if ((in->bus = bus_of(w[2], 0)) < 0) {
        return bad(why, len, "unknown bus '%.40s' (" BUS_LIST ")", w[2]);
    }
    if (nw == 4) {
        if (strcasecmp(w[3], "off") == 0) {
            in->mode = 0;
        } else if (number(w[3], &s) != 0 || !(s > 0.0 && s <= MAX_BUSOFF_S)) {
            return bad(why, len, "inject busoff: '%.40s' is not a time in s (0 < S <= %g) or 'off'", w[3],
                       MAX_BUSOFF_S);
        } else {
            in->ticks = (uint64_t)llround(s * 1000.0);
            in->ticks = (in->ticks > 0u) ? in->ticks : 1u;
        }
    }
    return 1;
}

static int parse_drive(char **w, int nw, hs_scenario_inject_t *in, char *why, size_t len)
{
    if (nw < 4 || leg_of(w[2], &in->leg) != 0) {
        return bad(why, len, "inject drive needs a leg (1..6) and fault, freeze, stale or ok");
    }
    in->what = HS_INJECT_DRIVE;
    if (strcasecmp(w[3], "fault") == 0) {
        char *end;
        if (nw < 5 || nw > 6) {
            return bad(why, len, "inject drive LEG fault needs BITS [hold]");
        }
        errno = 0;
        unsigned long bits = strtoul(w[4], &end, 0);
        if (errno != 0 || end == w[4] || *end != '\0' || w[4][0] == '-' || bits == 0u || bits > 0xFFu) {
            return bad(why, len, "fault bits '%.40s' are not 1..0xff", w[4]);
        }
        if (nw == 6 && strcasecmp(w[5], "hold") != 0) {
            return bad(why, len, "inject drive LEG fault BITS: '%.40s' is not 'hold'", w[5]);
        }
        in->mode = 0;
        in->bits = (uint32_t)bits;
        in->hold = (nw == 6);
        return 1;
    }
    if (strcasecmp(w[3], "stale") == 0) {
        double v = 2.0;
        if (nw > 5 || (nw == 5 && (number(w[4], &v) != 0 || v < 1.0 || v > 1000.0 || v != floor(v)))) {
            return bad(why, len, "inject drive LEG stale [TICKS]: TICKS is 1..1000");
        }
        in->mode = 2;
        in->ticks = (uint64_t)v;
        return 1;
    }
    if (nw != 4) {
        return bad(why, len, "inject drive LEG %.20s takes no more arguments", w[3]);
    }
    if (strcasecmp(w[3], "freeze") == 0) {
        in->mode = 1;
    } else if (strcasecmp(w[3], "ok") == 0) {
        in->mode = 3;
    } else {
        return bad(why, len, "inject drive: unknown '%.40s' (fault, freeze, stale, ok)", w[3]);
    }
    return 1;
}

static int parse_sensor(char **w, int nw, hs_scenario_inject_t *in, char *why, size_t len)
{
    static const char *const modes[4] = {"ok", "stick", "jump", "noise"};
    if (nw < 4 || nw > 5 || leg_of(w[2], &in->leg) != 0) {
        return bad(why, len, "inject sensor needs a leg (1..6) and stick [M], jump M, noise M or ok");
    }
    in->what = HS_INJECT_SENSOR;
    in->mode = -1;
    for (int k = 0; k < 4; k++) {
        if (strcasecmp(w[3], modes[k]) == 0) {
            in->mode = k;
        }
    }
    if (in->mode < 0) {
        return bad(why, len, "inject sensor: unknown '%.40s' (stick, jump, noise, ok)", w[3]);
    }
    int need = (in->mode == 2 || in->mode == 3) ? 1 : 0;
    int may = (in->mode != 0) ? 1 : 0;
    if (nw - 4 < need || nw - 4 > may) {
        return bad(why, len, "inject sensor %s: %s", modes[in->mode],
                   need ? "needs M (m)" : (may ? "takes at most M (m)" : "takes no value"));
    }
    if (nw == 5 &&
        (number(w[4], &in->value) != 0 || fabs(in->value) > MAX_SENSOR_M || (in->mode == 1 && !(in->value > 0.0)))) {
        return bad(why, len, "inject sensor: '%.40s' is not a length in m (|M| <= %g; stick: > 0)", w[4], MAX_SENSOR_M);
    }
    return 1;
}

static int parse_valve(char **w, int nw, hs_scenario_inject_t *in, char *why, size_t len)
{
    if (nw < 4 || nw > 5 || leg_of(w[2], &in->leg) != 0) {
        return bad(why, len, "inject valve needs a leg (1..6) and stick [U] or ok");
    }
    in->what = HS_INJECT_VALVE;
    if (strcasecmp(w[3], "ok") == 0 && nw == 4) {
        in->mode = 0;
        return 1;
    }
    if (strcasecmp(w[3], "stick") != 0) {
        return bad(why, len, "inject valve: unknown '%.40s' (stick [U], ok)", w[3]);
    }
    in->mode = 1;
    if (nw == 5 && (number(w[4], &in->value) != 0 || !(in->value >= -1.0 && in->value <= 1.0))) {
        return bad(why, len, "inject valve stick: command '%.40s' is not -1..1", w[4]);
    }
    return 1;
}

int hs_scenario_parse_inject(char **w, int nw, hs_action_t *a, char *why, size_t len)
{
    hs_scenario_inject_t *in = &a->inject;
    a->kind = HS_ACTION_INJECT;
    memset(in, 0, sizeof *in);
    if (nw < 2) {
        return bad(why, len, "inject needs what to inject (" WHAT_LIST ")");
    }
    const char *what = w[1];
    if (strcasecmp(what, "frames") == 0) {
        return parse_frames(w, nw, in, why, len);
    }
    if (strcasecmp(what, "busoff") == 0) {
        return parse_busoff(w, nw, in, why, len);
    }
    if (strcasecmp(what, "drive") == 0) {
        return parse_drive(w, nw, in, why, len);
    }
    if (strcasecmp(what, "sensor") == 0) {
        return parse_sensor(w, nw, in, why, len);
    }
    if (strcasecmp(what, "valve") == 0) {
        return parse_valve(w, nw, in, why, len);
    }
    if (strcasecmp(what, "supply") == 0) {
        in->what = HS_INJECT_SUPPLY;
        if (nw == 3 && strcasecmp(w[2], "loss") == 0) {
            in->mode = 1;
            return 1;
        }
        if (nw == 3 && strcasecmp(w[2], "ok") == 0) {
            return 1;
        }
        return bad(why, len, "inject supply needs loss or ok");
    }
    if (strcasecmp(what, "endstop") == 0) {
        in->what = HS_INJECT_ENDSTOP;
        in->value = 1.0;
        if (nw < 3 || nw > 4 || leg_of(w[2], &in->leg) != 0) {
            return bad(why, len, "inject endstop needs a leg (1..6) and optionally up or down");
        }
        if (nw == 4) {
            if (strcasecmp(w[3], "down") == 0) {
                in->value = -1.0;
            } else if (strcasecmp(w[3], "up") != 0) {
                return bad(why, len, "inject endstop: '%.40s' is not up or down", w[3]);
            }
        }
        return 1;
    }
    if (strcasecmp(what, "fk") == 0) {
        in->what = HS_INJECT_FK;
        in->value = 0.05;
        if (nw > 3 || (nw == 3 && (number(w[2], &in->value) != 0 || !(in->value > 0.0 && in->value <= 1.0)))) {
            return bad(why, len, "inject fk takes at most M (0 < M <= 1 m)");
        }
        return 1;
    }
    if (strcasecmp(what, "clear") == 0) {
        in->what = HS_INJECT_CLEAR;
        if (nw != 2) {
            return bad(why, len, "inject clear takes no arguments");
        }
        return 1;
    }
    return bad(why, len, "unknown injection '%.40s' (" WHAT_LIST ")", what);
}
