/* SPDX-License-Identifier: Apache-2.0 */
/* scenario.c - the scenario language of hs_sim: parser, file reader, player (hs/scenario.h). */
#define _POSIX_C_SOURCE 200809L
#include "hs/scenario.h"
#include "scenario_inject.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define WHY_LEN 200        /* what is wrong with a line, without its name and number */
#define N_COMMANDS 14      /* OP_COMMAND values 0..13 (TARE): a scenario has no IDENTIFY (14) */
#define MAX_SECONDS 1.0e6  /* longest delay or wait timeout */
#define MAX_TARGET 8.0     /* largest |value| of a target pose, m or rad */
#define MAX_FADE_S 65.0    /* longest fade, s */
#define Q24_ONE 16777216.0 /* 1.0 in Q24 */
#define COMMAND_LIST                                                                                                   \
    "ENGAGE, RUN_TRIG, MOVE_TO, STREAM, STOP, PARK, ESTOP, RESET, SET_FEEDFORWARD, FORCE, GUIDE, POSITION, TARE"
#define ACTION_LIST                                                                                                    \
    "cmd, target, delay, wait, silence, unsilence, fault, mark, end, wrench, contact, load, play, force, "             \
    "force_target, guide, position, tare, push, ftsensor, inject, frame"
#define MAX_FT 16383.0     /* largest |value| of an OP_FORCE target, N or N m (the frame's range) */
#define MAX_WRENCH 1.0e6   /* largest |value| of a wrench, N or N m */
#define MAX_GEOMETRY 100.0 /* largest |value| of a contact or load position, m */
#define MAX_CONTACT 1.0e9  /* largest contact stiffness (N/m) and damping (N s/m) */
#define MAX_TILT 1.5       /* largest |tilt| of a contact surface about x or y, rad (below a right angle) */
#define MAX_LOAD 1.0e5     /* largest |mass| of a load, kg */
#define PLAY_HEADER "t,x,y,z,roll,pitch,yaw"
#define KEY_LIST "axis, amplitude, frequency, fade, option"
#define AXIS_LIST "x, y, z, roll, pitch, yaw"
#define STATE_LIST "idle, engaging, ready, running, parking, fault, estop, stopping"

/* Indexed by the OP_COMMAND value. The core names its states (sp_state_name)
 * but not its commands (sp_cmd_type_t, SP_CMD_SET_FEEDFORWARD), and the
 * header cantools generates from the DBC has only numeric choice macros, so
 * the names are spelt here, tied to the core's values. */
static const char *const k_commands[N_COMMANDS] = {
    [SP_CMD_NONE] = "NONE",         [SP_CMD_ENGAGE] = "ENGAGE",
    [SP_CMD_RUN_TRIG] = "RUN_TRIG", [SP_CMD_MOVE_TO] = "MOVE_TO",
    [SP_CMD_STREAM] = "STREAM",     [SP_CMD_STOP] = "STOP",
    [SP_CMD_PARK] = "PARK",         [SP_CMD_ESTOP] = "ESTOP",
    [SP_CMD_RESET] = "RESET",       [SP_CMD_SET_FEEDFORWARD] = "SET_FEEDFORWARD",
    [SP_CMD_FORCE] = "FORCE",       [SP_CMD_GUIDE] = "GUIDE",
    [SP_CMD_POSITION] = "POSITION", [SP_CMD_TARE] = "TARE"};

static const char *const k_axes[SP_AXIS_COUNT] = {
    [SP_AXIS_X] = "x",       [SP_AXIS_Y] = "y",         [SP_AXIS_Z] = "z",
    [SP_AXIS_ROLL] = "roll", [SP_AXIS_PITCH] = "pitch", [SP_AXIS_YAW] = "yaw"};

enum { KEY_AXIS, KEY_AMPLITUDE, KEY_FREQUENCY, KEY_FADE, KEY_OPTION, N_KEYS };
static const char *const k_keys[N_KEYS] = {"axis", "amplitude", "frequency", "fade", "option"};

#if defined(__GNUC__)
static int fail(char why[WHY_LEN], const char *fmt, ...) __attribute__((format(printf, 2, 3)));
#endif

/* Writes what is wrong into why; returns -1 (parse_line's error). */
static int fail(char why[WHY_LEN], const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(why, WHY_LEN, fmt, ap);
    va_end(ap);
    return -1;
}

/* Index of s in names[0..n) ignoring case, or -1. */
static int lookup(const char *s, const char *const *names, int n)
{
    for (int i = 0; i < n; i++) {
        if (strcasecmp(s, names[i]) == 0) {
            return i;
        }
    }
    return -1;
}

static int lookup_state(const char *s)
{
    for (int i = SP_STATE_IDLE; i <= SP_STATE_STOPPING; i++) {
        if (strcasecmp(s, sp_state_name((sp_state_t)i)) == 0) {
            return i;
        }
    }
    return -1;
}

/* A whole word that is a finite number. 0 ok, -1 not. */
static int parse_double(const char *s, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(s, &end);
    return (errno == 0 && end != s && *end == '\0' && isfinite(*v)) ? 0 : -1;
}

/* 1 if v converts to Q24 without saturating. */
static int fits_q24(double v)
{
    return fabs(v * Q24_ONE) <= 2147483647.0;
}

/* v in Q24, rounded to nearest (ties away from zero), saturated. */
static sp_q24_t q24_of(double v)
{
    double q = v * Q24_ONE;
    if (q > 2147483647.0) {
        return INT32_MAX;
    }
    if (q < -2147483647.0) {
        return -INT32_MAX;
    }
    return (sp_q24_t)llround(q);
}

/* Seconds (0..MAX_SECONDS) to 1 ms ticks, rounded to nearest. */
static uint64_t ticks_of(double seconds)
{
    return (uint64_t)llround(seconds * 1000.0);
}

/* A leg written 1..6 to its index 0..5. 0 ok, -1 not a leg. */
static int parse_leg(const char *s, int *leg)
{
    double v;
    if (parse_double(s, &v) != 0 || v < 1.0 || v > 6.0 || v != floor(v)) {
        return -1;
    }
    *leg = (int)v - 1;
    return 0;
}

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

/* Splits s in place into words. Returns their number, or -1 if there are more than max. */
static int split_words(char *s, char *word[], int max)
{
    size_t len = strlen(s);
    int n = 0, in_word = 0;
    for (size_t i = 0; i < len; i++) {
        if (is_space(s[i])) {
            s[i] = '\0';
            in_word = 0;
        } else if (!in_word) {
            if (n == max) {
                return -1;
            }
            word[n++] = &s[i];
            in_word = 1;
        }
    }
    return n;
}

static int parse_cmd(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw < 2) {
        return fail(why, "cmd needs a command name (" COMMAND_LIST ")");
    }
    int c = lookup(w[1], k_commands, N_COMMANDS);
    if (c <= 0) {
        return fail(why, "unknown command '%.40s' (" COMMAND_LIST ")", w[1]);
    }
    a->kind = HS_ACTION_CMD;
    a->cmd.command = (uint8_t)c;
    unsigned seen = 0u;
    for (int i = 2; i < nw; i++) {
        char *eq = strchr(w[i], '=');
        if (eq == NULL) {
            return fail(why, "expected key=value after the command name, got '%.40s'", w[i]);
        }
        *eq = '\0';
        const char *key = w[i], *val = eq + 1;
        int k = -1;
        for (int j = 0; j < N_KEYS; j++) {
            if (strcmp(key, k_keys[j]) == 0) {
                k = j;
            }
        }
        if (k < 0) {
            return fail(why, "unknown argument '%.40s' (" KEY_LIST ")", key);
        }
        if (seen & (1u << k)) {
            return fail(why, "argument '%s' given twice", key);
        }
        seen |= 1u << k;
        if (k == KEY_AXIS) {
            int ax = lookup(val, k_axes, SP_AXIS_COUNT);
            if (ax < 0) {
                return fail(why, "unknown axis '%.40s' (" AXIS_LIST ")", val);
            }
            a->cmd.axis = (uint8_t)ax;
            continue;
        }
        double v;
        if (parse_double(val, &v) != 0) {
            return fail(why, "%s: '%.40s' is not a number", key, val);
        }
        switch (k) {
        case KEY_AMPLITUDE:
            if (!fits_q24(v)) {
                return fail(why, "amplitude %.40s is out of range (|A| < 128 m or rad)", val);
            }
            a->cmd.amplitude = q24_of(v);
            break;
        case KEY_FREQUENCY:
            if (v < 0.0 || !fits_q24(v)) {
                return fail(why, "frequency %.40s is out of range (0 <= HZ < 128)", val);
            }
            a->cmd.frequency = q24_of(v);
            break;
        case KEY_FADE:
            if (v < 0.0 || v > MAX_FADE_S) {
                return fail(why, "fade %.40s is out of range (0..65 s)", val);
            }
            a->cmd.fade_ms = (uint32_t)llround(v * 1000.0);
            break;
        default: /* KEY_OPTION */
            if (v != 0.0 && v != 1.0) {
                return fail(why, "option must be 0 or 1, got '%.40s'", val);
            }
            a->cmd.option = (uint8_t)v;
            break;
        }
    }
    return 1;
}

static int parse_target(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw != 7) {
        return fail(why, "target needs 6 numbers (x y z roll pitch yaw), got %d", nw - 1);
    }
    a->kind = HS_ACTION_TARGET;
    for (int i = 0; i < 6; i++) {
        double v;
        if (parse_double(w[i + 1], &v) != 0) {
            return fail(why, "target value '%.40s' is not a number", w[i + 1]);
        }
        if (fabs(v) > MAX_TARGET) {
            return fail(why, "target value %.40s is out of range (|v| <= 8 m or rad)", w[i + 1]);
        }
        if (i < 3) {
            a->target.pos[i] = q24_of(v);
        } else {
            a->target.rpy[i - 3] = q24_of(v);
        }
    }
    return 1;
}

static int parse_delay(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    double v;
    if (nw != 2) {
        return fail(why, "delay needs one number of seconds (0..1e6), got %d arguments", nw - 1);
    }
    if (parse_double(w[1], &v) != 0) {
        return fail(why, "delay: '%.40s' is not a number", w[1]);
    }
    if (v < 0.0 || v > MAX_SECONDS) {
        return fail(why, "delay %.40s is out of range (0..1e6 s)", w[1]);
    }
    a->kind = HS_ACTION_DELAY;
    a->ticks = ticks_of(v);
    return 1;
}

static int parse_wait(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw < 2 || nw > 3) {
        return fail(why, "wait needs a state (" STATE_LIST ") and optionally a timeout in seconds, got %d arguments",
                    nw - 1);
    }
    int st = lookup_state(w[1]);
    if (st < 0) {
        return fail(why, "unknown state '%.40s' (" STATE_LIST ")", w[1]);
    }
    a->kind = HS_ACTION_WAIT;
    a->state = (sp_state_t)st;
    a->ticks = HS_SCENARIO_WAIT_DEFAULT_TICKS;
    if (nw == 3) {
        double v;
        if (parse_double(w[2], &v) != 0) {
            return fail(why, "wait timeout '%.40s' is not a number", w[2]);
        }
        if (v <= 0.0 || v > MAX_SECONDS) {
            return fail(why, "wait timeout %.40s is out of range (0 < S <= 1e6 s)", w[2]);
        }
        a->ticks = ticks_of(v);
    }
    return 1;
}

/* silence, unsilence, fault */
static int parse_drive(char **w, int nw, hs_action_kind_t kind, hs_action_t *a, char why[WHY_LEN])
{
    int want = (kind == HS_ACTION_FAULT) ? 3 : 2;
    if (nw != want) {
        return (kind == HS_ACTION_FAULT)
                   ? fail(why, "fault needs a leg (1..6) and fault bits (1..0xff), got %d arguments", nw - 1)
                   : fail(why, "%s needs one leg (1..6), got %d arguments", w[0], nw - 1);
    }
    a->kind = kind;
    if (parse_leg(w[1], &a->leg) != 0) {
        return fail(why, "leg '%.40s' is not one of 1..6", w[1]);
    }
    if (kind == HS_ACTION_FAULT) {
        char *end;
        errno = 0;
        unsigned long bits = strtoul(w[2], &end, 0);
        if (errno != 0 || end == w[2] || *end != '\0' || bits == 0u || bits > 0xFFu) {
            return fail(why, "fault bits '%.40s' are not 1..0xff", w[2]);
        }
        a->bits = (uint32_t)bits;
    }
    return 1;
}

static int parse_mark(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    size_t len = 0;
    a->kind = HS_ACTION_MARK;
    for (int i = 1; i < nw; i++) {
        size_t wl = strlen(w[i]);
        size_t need = wl + (i > 1 ? 1u : 0u);
        if (len + need > HS_SCENARIO_MAX_TEXT) {
            return fail(why, "mark text longer than %d characters", HS_SCENARIO_MAX_TEXT);
        }
        if (i > 1) {
            a->text[len++] = ' ';
        }
        memcpy(&a->text[len], w[i], wl);
        len += wl;
    }
    a->text[len] = '\0';
    return 1;
}

/* Numbers w[from..from+n) into v, each |v| <= max. 0 ok, -1 (why). */
static int parse_numbers(char **w, int from, int n, double max, const char *what, const char *unit, double *v,
                         char why[WHY_LEN])
{
    for (int i = 0; i < n; i++) {
        if (parse_double(w[from + i], &v[i]) != 0) {
            return fail(why, "%s value '%.40s' is not a number", what, w[from + i]);
        }
        if (fabs(v[i]) > max) {
            return fail(why, "%s value %.40s is out of range (|v| <= %g %s)", what, w[from + i], max, unit);
        }
    }
    return 0;
}

/* key=value words w[from..nw): each of keys[] at most once, value in [0, max[k]].
 * seen gets a bit per key found. 0 ok, -1 (why). */
static int parse_keys(char **w, int from, int nw, const char *what, const char *const *keys, const double *max,
                      int nkeys, double *vals, unsigned *seen, char why[WHY_LEN])
{
    *seen = 0u;
    for (int i = from; i < nw; i++) {
        char *eq = strchr(w[i], '=');
        int k = -1;
        double v;
        if (eq == NULL) {
            return fail(why, "%s: expected key=value, got '%.40s'", what, w[i]);
        }
        *eq = '\0';
        for (int j = 0; j < nkeys; j++) {
            if (strcmp(w[i], keys[j]) == 0) {
                k = j;
            }
        }
        if (k < 0) {
            return fail(why, "%s: unknown argument '%.40s'", what, w[i]);
        }
        if (*seen & (1u << k)) {
            return fail(why, "%s: argument '%s' given twice", what, keys[k]);
        }
        *seen |= 1u << k;
        if (parse_double(eq + 1, &v) != 0) {
            return fail(why, "%s: %s '%.40s' is not a number", what, keys[k], eq + 1);
        }
        if (v < 0.0 || v > max[k]) {
            return fail(why, "%s: %s %.40s is out of range (0..%g)", what, keys[k], eq + 1, max[k]);
        }
        vals[k] = v;
    }
    return 0;
}

static int parse_wrench(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    static const char *const keys[1] = {"ramp"};
    static const double max[1] = {MAX_SECONDS};
    double ramp = 0.0;
    unsigned seen;
    int first_key;
    a->kind = HS_ACTION_WRENCH;
    if (nw >= 2 && strcasecmp(w[1], "off") == 0) {
        first_key = 2;
    } else {
        int n = 0;
        while (1 + n < nw && strchr(w[1 + n], '=') == NULL) {
            n++;
        }
        if (n != 6) {
            return fail(why, "wrench needs 6 numbers (fx fy fz mx my mz) or 'off', then optionally ramp=S; got %d", n);
        }
        if (parse_numbers(w, 1, 6, MAX_WRENCH, "wrench", "N or N m", a->wrench, why) != 0) {
            return -1;
        }
        first_key = 7;
    }
    if (parse_keys(w, first_key, nw, "wrench", keys, max, 1, &ramp, &seen, why) != 0) {
        return -1;
    }
    a->ticks = ticks_of(ramp);
    return 1;
}

/* `contact surface up|down PX PY PZ ROLL PITCH TX TY TZ stiffness=K damping=D`:
 * the plane through P (base frame, m) whose free side is +z (up) or -z
 * (down) before it is tilted by ROLL about x, then PITCH about y (rad, each
 * within MAX_TILT): n = Ry(PITCH) Rx(ROLL) (0, 0, +-1), offset n . P; the
 * platform point T (motion frame) touches it. Stored as the plane it is. */
static int parse_surface(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    static const char *const keys[2] = {"stiffness", "damping"};
    static const double max[2] = {MAX_CONTACT, MAX_CONTACT};
    double v[8], kd[2] = {0.0, 0.0}, side;
    unsigned seen;
    hs_scenario_contact_t *c = &a->contact;
    if (nw < 3 || (strcasecmp(w[2], "up") != 0 && strcasecmp(w[2], "down") != 0)) {
        return fail(why, "contact surface needs up or down (its free side before the tilt), then 8 numbers");
    }
    side = (strcasecmp(w[2], "up") == 0) ? 1.0 : -1.0;
    for (int i = 0; i < 8; i++) {
        if (3 + i >= nw || strchr(w[3 + i], '=') != NULL) {
            return fail(why, "contact surface needs 8 numbers (px py pz roll pitch tx ty tz), got %d", i);
        }
    }
    if (parse_numbers(w, 3, 3, MAX_GEOMETRY, "contact surface point", "m", v, why) != 0 ||
        parse_numbers(w, 6, 2, MAX_TILT, "contact surface tilt", "rad", &v[3], why) != 0 ||
        parse_numbers(w, 8, 3, MAX_GEOMETRY, "contact surface tool point", "m", &v[5], why) != 0) {
        return -1;
    }
    if (parse_keys(w, 11, nw, "contact", keys, max, 2, kd, &seen, why) != 0) {
        return -1;
    }
    if (seen != 3u) {
        return fail(why, "contact needs stiffness=K (N/m) and damping=D (N s/m)");
    }
    c->kind = 1;
    c->normal[0] = side * sin(v[4]) * cos(v[3]);
    c->normal[1] = -side * sin(v[3]);
    c->normal[2] = side * cos(v[4]) * cos(v[3]);
    c->offset = c->normal[0] * v[0] + c->normal[1] * v[1] + c->normal[2] * v[2];
    memcpy(c->point, &v[5], sizeof c->point);
    c->stiffness = kd[0];
    c->damping = kd[1];
    return 1;
}

static int parse_contact(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    static const char *const keys[2] = {"stiffness", "damping"};
    static const double max[2] = {MAX_CONTACT, MAX_CONTACT};
    double v[7], kd[2] = {0.0, 0.0};
    unsigned seen;
    int plane, n;
    hs_scenario_contact_t *c = &a->contact;
    a->kind = HS_ACTION_CONTACT;
    if (nw < 2) {
        return fail(why, "contact needs plane, surface, point or off");
    }
    if (strcasecmp(w[1], "off") == 0) {
        if (nw != 2) {
            return fail(why, "contact off takes no arguments, got %d", nw - 2);
        }
        return 1;
    }
    if (strcasecmp(w[1], "surface") == 0) {
        return parse_surface(w, nw, a, why);
    }
    plane = strcasecmp(w[1], "plane") == 0;
    if (!plane && strcasecmp(w[1], "point") != 0) {
        return fail(why, "unknown contact '%.40s' (plane, surface, point, off)", w[1]);
    }
    n = plane ? 7 : 6;
    for (int i = 0; i < n; i++) {
        if (2 + i >= nw || strchr(w[2 + i], '=') != NULL) {
            return fail(why,
                        plane ? "contact plane needs 7 numbers (nx ny nz offset px py pz), got %d"
                              : "contact point needs 6 numbers (ax ay az px py pz), got %d",
                        i);
        }
    }
    if (parse_numbers(w, 2, n, MAX_GEOMETRY, plane ? "contact plane" : "contact point", "m", v, why) != 0) {
        return -1;
    }
    if (parse_keys(w, 2 + n, nw, "contact", keys, max, 2, kd, &seen, why) != 0) {
        return -1;
    }
    if (seen != 3u) {
        return fail(why, "contact needs stiffness=K (N/m) and damping=D (N s/m)");
    }
    if (plane) {
        c->kind = 1;
        memcpy(c->normal, v, sizeof c->normal);
        c->offset = v[3];
        memcpy(c->point, &v[4], sizeof c->point);
        if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) {
            return fail(why, "contact plane: the normal is zero");
        }
    } else {
        c->kind = 2;
        memcpy(c->anchor, v, sizeof c->anchor);
        memcpy(c->point, &v[3], sizeof c->point);
    }
    c->stiffness = kd[0];
    c->damping = kd[1];
    return 1;
}

static int parse_load(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw != 5) {
        return fail(why, "load needs a mass (kg) and a point x y z (m, motion frame), got %d arguments", nw - 1);
    }
    a->kind = HS_ACTION_LOAD;
    if (parse_numbers(w, 1, 1, MAX_LOAD, "load mass", "kg", &a->mass, why) != 0 ||
        parse_numbers(w, 2, 3, MAX_GEOMETRY, "load point", "m", a->point, why) != 0) {
        return -1;
    }
    if (a->mass == 0.0) {
        return fail(why, "load mass is 0");
    }
    return 1;
}

/* ---- play files ---------------------------------------------------------- */

/* Reads the next non-blank line of f into buf (newline and '\r' removed).
 * 1 a line, 0 end of file, -1 error (why). */
static int read_csv_line(FILE *f, char buf[HS_SCENARIO_MAX_LINE + 2], long *line, char why[WHY_LEN])
{
    for (;;) {
        size_t len;
        if (fgets(buf, HS_SCENARIO_MAX_LINE + 2, f) == NULL) {
            return ferror(f) ? fail(why, "cannot read: %s", strerror(errno)) : 0;
        }
        (*line)++;
        len = strlen(buf);
        if (len > 0 && buf[len - 1] == '\n') {
            buf[--len] = '\0';
        } else if (!feof(f)) {
            return fail(why, "line %ld longer than %d characters", *line, HS_SCENARIO_MAX_LINE);
        }
        while (len > 0 && is_space(buf[len - 1])) {
            buf[--len] = '\0';
        }
        if (len > 0) {
            return 1;
        }
    }
}

/* Next row of a play file: t (in ms) and the pose, checked against the
 * previous t (prev_ms < 0: none). 1 a row, 0 end, -1 error (why). */
static int read_play_row(FILE *f, long *line, double prev_ms, double row[7], char why[WHY_LEN])
{
    char buf[HS_SCENARIO_MAX_LINE + 2];
    char *p;
    int r = read_csv_line(f, buf, line, why);
    if (r <= 0) {
        return r;
    }
    p = buf;
    for (int k = 0; k < 7; k++) {
        char *end;
        errno = 0;
        row[k] = strtod(p, &end);
        while (is_space(*end)) {
            end++;
        }
        if (errno != 0 || end == p || !isfinite(row[k]) || *end != (k < 6 ? ',' : '\0')) {
            return fail(why, "line %ld: expected 7 numbers t,x,y,z,roll,pitch,yaw", *line);
        }
        p = end + 1;
    }
    if (row[0] < 0.0 || row[0] > MAX_SECONDS) {
        return fail(why, "line %ld: t %g is out of range (0..1e6 s)", *line, row[0]);
    }
    row[0] *= 1000.0;
    if (prev_ms >= 0.0 && !(row[0] > prev_ms)) {
        return fail(why, "line %ld: t %g s does not increase", *line, row[0] / 1000.0);
    }
    for (int k = 1; k < 7; k++) {
        if (fabs(row[k]) > MAX_TARGET) {
            return fail(why, "line %ld: pose value %g is out of range (|v| <= 8 m or rad)", *line, row[k]);
        }
    }
    return 1;
}

static int read_play_header(FILE *f, long *line, char why[WHY_LEN])
{
    char buf[HS_SCENARIO_MAX_LINE + 2];
    int r = read_csv_line(f, buf, line, why);
    if (r < 0) {
        return -1;
    }
    if (r == 0 || strcmp(buf, PLAY_HEADER) != 0) {
        return fail(why, "line %ld: the header must be " PLAY_HEADER, *line);
    }
    return 0;
}

/* Checks a whole play file; *ticks: its duration in 1 ms ticks. 0 ok, -1 (why). */
static int check_play_file(const char *path, uint64_t *ticks, char why[WHY_LEN])
{
    char inner[WHY_LEN];
    double row[7], prev = -1.0;
    long line = 0;
    int r, rows = 0;
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        return fail(why, "play: cannot open '%.100s': %s", path, strerror(errno));
    }
    if (read_play_header(f, &line, inner) != 0) {
        (void)fclose(f);
        return fail(why, "play %.100s: %s", path, inner);
    }
    while ((r = read_play_row(f, &line, prev, row, inner)) == 1) {
        prev = row[0];
        rows++;
    }
    (void)fclose(f);
    if (r < 0) {
        return fail(why, "play %.100s: %s", path, inner);
    }
    if (rows == 0) {
        return fail(why, "play %.100s: no rows after the header", path);
    }
    *ticks = (uint64_t)ceil(prev - 1e-6);
    return 0;
}

static int parse_play(char **w, int nw, const char *dir, hs_action_t *a, char why[WHY_LEN])
{
    int n;
    if (nw != 2) {
        return fail(why, "play needs one file name (no spaces), got %d arguments", nw - 1);
    }
    a->kind = HS_ACTION_PLAY;
    if (w[1][0] != '/' && dir != NULL && dir[0] != '\0') {
        n = snprintf(a->path, sizeof a->path, "%s/%s", dir, w[1]);
    } else {
        n = snprintf(a->path, sizeof a->path, "%s", w[1]);
    }
    if (n < 0 || (size_t)n >= sizeof a->path) {
        return fail(why, "play: the path is longer than %d characters", HS_SCENARIO_MAX_PATH);
    }
    if (check_play_file(a->path, &a->ticks, why) != 0) {
        return -1;
    }
    return 1;
}

/* Parses one line (modified in place). 1: an action in *a, 0: blank or comment, -1: error (why).
 * dir: where relative play files are (NULL: the working directory). */
/* AXES of force, force_target and guide: axis names joined by commas, or
 * the mask as a number 0..63. 0 ok (*mask), -1 (why). */
static int parse_axes(const char *s, uint8_t *mask, char why[WHY_LEN])
{
    double v;
    if (parse_double(s, &v) == 0) {
        if (v < 0.0 || v > 63.0 || v != floor(v)) {
            return fail(why, "axes mask %.40s is out of range (a whole number 0..63)", s);
        }
        *mask = (uint8_t)v;
        return 0;
    }
    char buf[64];
    if (strlen(s) >= sizeof buf) {
        return fail(why, "axes '%.40s...' too long (" AXIS_LIST ", joined by commas)", s);
    }
    strcpy(buf, s);
    unsigned m = 0u;
    for (char *tok = buf; tok != NULL;) {
        char *comma = strchr(tok, ',');
        if (comma != NULL) {
            *comma = '\0';
        }
        int ax = lookup(tok, k_axes, SP_AXIS_COUNT);
        if (ax < 0) {
            return fail(why, "unknown axis '%.40s' (" AXIS_LIST ", joined by commas, or a mask 0..63)", tok);
        }
        m |= 1u << ax;
        tok = (comma != NULL) ? comma + 1 : NULL;
    }
    *mask = (uint8_t)m;
    return 0;
}

/* force AXES F x6 (command FORCE), force_target AXES F x6 (none), guide AXES (GUIDE). */
static int parse_force(char **w, int nw, uint8_t command, hs_action_t *a, char why[WHY_LEN])
{
    const char *what = (command == SP_CMD_GUIDE) ? "guide" : ((command == 0u) ? "force_target" : "force");
    int want = (command == SP_CMD_GUIDE) ? 2 : 8;
    if (nw != want) {
        return fail(why, "%s needs %s, got %d word(s)", what,
                    (command == SP_CMD_GUIDE) ? "the axes" : "the axes and 6 numbers (fx fy fz mx my mz)", nw - 1);
    }
    a->kind = HS_ACTION_FORCE;
    a->cmd.command = command;
    if (parse_axes(w[1], &a->force.mask, why) != 0) {
        return -1;
    }
    if (command != SP_CMD_GUIDE) {
        double v[6];
        if (parse_numbers(w, 2, 6, MAX_FT, what, "N or N m", v, why) != 0) {
            return -1;
        }
        for (int k = 0; k < 6; k++) {
            a->force.target[k] = (sp_q8_t)llround(v[k] * 256.0);
        }
    }
    return 1;
}

static int parse_push(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    static const char *const keys[2] = {"rise", "hold"};
    static const double max[2] = {MAX_SECONDS, MAX_SECONDS};
    double v[2] = {0.0, 0.0};
    unsigned seen;
    if (nw != 9) {
        return fail(why, "push needs 6 numbers (fx fy fz mx my mz), rise=S and hold=S; got %d word(s)", nw - 1);
    }
    a->kind = HS_ACTION_PUSH;
    if (parse_numbers(w, 1, 6, MAX_WRENCH, "push", "N or N m", a->wrench, why) != 0 ||
        parse_keys(w, 7, nw, "push", keys, max, 2, v, &seen, why) != 0) {
        return -1;
    }
    if (seen != 3u) {
        return fail(why, "push needs both rise=S and hold=S");
    }
    a->ticks = ticks_of(v[0]);
    a->hold = ticks_of(v[1]);
    return 1;
}

/* position, tare: OP_COMMAND with no arguments. */
static int parse_bare_command(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw != 1) {
        return fail(why, "%s takes no arguments, got %d", w[0], nw - 1);
    }
    a->kind = HS_ACTION_CMD;
    a->cmd.command = (uint8_t)((strcasecmp(w[0], "tare") == 0) ? SP_CMD_TARE : SP_CMD_POSITION);
    return 1;
}

static int parse_ftsensor(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw != 2 || (strcasecmp(w[1], "off") != 0 && strcasecmp(w[1], "on") != 0)) {
        return fail(why, "ftsensor takes 'off' or 'on'");
    }
    a->kind = HS_ACTION_FTSENSOR;
    a->bits = (strcasecmp(w[1], "on") == 0) ? 1u : 0u;
    return 1;
}

/* `frame tool|work select N` or `frame tool|work set N X Y Z ROLL PITCH YAW`:
 * OP_FRAME (slot N 0..15 on the wire; values within MAX_TARGET). */
static int parse_frame(char **w, int nw, hs_action_t *a, char why[WHY_LEN])
{
    double slot;
    hs_scenario_frame_t *f = &a->frame;
    a->kind = HS_ACTION_FRAME;
    if (nw < 4) {
        return fail(why, "frame needs tool or work, select or set, and a slot");
    }
    if (strcasecmp(w[1], "tool") != 0 && strcasecmp(w[1], "work") != 0) {
        return fail(why, "frame: unknown kind '%.40s' (tool, work)", w[1]);
    }
    f->kind = (strcasecmp(w[1], "work") == 0) ? 1 : 0;
    if (strcasecmp(w[2], "select") != 0 && strcasecmp(w[2], "set") != 0) {
        return fail(why, "frame: unknown operation '%.40s' (select, set)", w[2]);
    }
    f->op = (strcasecmp(w[2], "set") == 0) ? 1 : 0;
    if (parse_double(w[3], &slot) != 0 || slot < 0.0 || slot > 15.0 || slot != floor(slot)) {
        return fail(why, "frame: slot '%.40s' is not 0..15", w[3]);
    }
    f->index = (int)slot;
    if (f->op == 0) {
        return (nw == 4) ? 1 : fail(why, "frame select takes a slot alone, got %d more words", nw - 4);
    }
    if (nw != 10) {
        return fail(why, "frame set needs a slot and 6 numbers (x y z roll pitch yaw), got %d", nw - 4);
    }
    return (parse_numbers(w, 4, 6, MAX_TARGET, "frame", "m or rad", f->value, why) != 0) ? -1 : 1;
}

static int parse_end(int nw, hs_action_t *a, char why[WHY_LEN])
{
    if (nw != 1) {
        return fail(why, "end takes no arguments, got %d", nw - 1);
    }
    a->kind = HS_ACTION_END;
    return 1;
}

/* One action's words (nw >= 1) by its keyword w[0]. */
static int parse_action(char **w, int nw, const char *dir, hs_action_t *a, char why[WHY_LEN])
{
    const char *kw = w[0];
    if (strcasecmp(kw, "cmd") == 0) {
        return parse_cmd(w, nw, a, why);
    }
    if (strcasecmp(kw, "target") == 0) {
        return parse_target(w, nw, a, why);
    }
    if (strcasecmp(kw, "delay") == 0) {
        return parse_delay(w, nw, a, why);
    }
    if (strcasecmp(kw, "wait") == 0) {
        return parse_wait(w, nw, a, why);
    }
    if (strcasecmp(kw, "silence") == 0) {
        return parse_drive(w, nw, HS_ACTION_SILENCE, a, why);
    }
    if (strcasecmp(kw, "unsilence") == 0) {
        return parse_drive(w, nw, HS_ACTION_UNSILENCE, a, why);
    }
    if (strcasecmp(kw, "fault") == 0) {
        return parse_drive(w, nw, HS_ACTION_FAULT, a, why);
    }
    if (strcasecmp(kw, "mark") == 0) {
        return parse_mark(w, nw, a, why);
    }
    if (strcasecmp(kw, "wrench") == 0) {
        return parse_wrench(w, nw, a, why);
    }
    if (strcasecmp(kw, "contact") == 0) {
        return parse_contact(w, nw, a, why);
    }
    if (strcasecmp(kw, "load") == 0) {
        return parse_load(w, nw, a, why);
    }
    if (strcasecmp(kw, "play") == 0) {
        return parse_play(w, nw, dir, a, why);
    }
    if (strcasecmp(kw, "inject") == 0) {
        return hs_scenario_parse_inject(w, nw, a, why, WHY_LEN);
    }
    if (strcasecmp(kw, "force") == 0) {
        return parse_force(w, nw, SP_CMD_FORCE, a, why);
    }
    if (strcasecmp(kw, "force_target") == 0) {
        return parse_force(w, nw, 0u, a, why);
    }
    if (strcasecmp(kw, "guide") == 0) {
        return parse_force(w, nw, SP_CMD_GUIDE, a, why);
    }
    if (strcasecmp(kw, "position") == 0 || strcasecmp(kw, "tare") == 0) {
        return parse_bare_command(w, nw, a, why);
    }
    if (strcasecmp(kw, "push") == 0) {
        return parse_push(w, nw, a, why);
    }
    if (strcasecmp(kw, "ftsensor") == 0) {
        return parse_ftsensor(w, nw, a, why);
    }
    if (strcasecmp(kw, "end") == 0) {
        return parse_end(nw, a, why);
    }
    if (strcasecmp(kw, "frame") == 0) {
        return parse_frame(w, nw, a, why);
    }
    return fail(why, "unknown action '%.40s' (" ACTION_LIST ")", kw);
}

static int parse_line(char *line, const char *dir, hs_action_t *a, char why[WHY_LEN])
{
    char *hash = strchr(line, '#');
    if (hash != NULL) {
        *hash = '\0';
    }
    char *w[HS_SCENARIO_MAX_WORDS];
    int nw = split_words(line, w, HS_SCENARIO_MAX_WORDS);
    if (nw < 0) {
        return fail(why, "more than %d words", HS_SCENARIO_MAX_WORDS);
    }
    if (nw == 0) {
        return 0;
    }
    memset(a, 0, sizeof *a);
    return parse_action(w, nw, dir, a, why);
}

/* Fills *err (if any) with "name:line: why" and empties the scenario. Returns status. */
static hs_status_t refuse(hs_scenario_t *sc, hs_status_t status, const char *name, int line, const char *why,
                          hs_scenario_error_t *err)
{
    sc->n = 0;
    hs_scenario_rewind(sc);
    if (err != NULL) {
        err->line = line;
        if (line > 0) {
            (void)snprintf(err->message, sizeof err->message, "%s:%d: %s", name, line, why);
        } else {
            (void)snprintf(err->message, sizeof err->message, "%s: %s", name, why);
        }
    }
    return status;
}

static void start(hs_scenario_t *sc, hs_scenario_error_t *err)
{
    sc->n = 0;
    hs_scenario_rewind(sc);
    if (err != NULL) {
        err->line = 0;
        err->message[0] = '\0';
    }
}

enum { LINE_WHOLE, LINE_TOO_LONG, LINE_NUL };

/* One line (NUL-terminated in buf, which it modifies; `shape` says whether it could be read
 * whole) appended to the scenario if it is an action. */
static hs_status_t take_line(hs_scenario_t *sc, char *buf, int shape, const char *name, const char *dir, int ln,
                             hs_scenario_error_t *err)
{
    char why[WHY_LEN];
    hs_action_t a;
    if (shape != LINE_WHOLE) {
        if (shape == LINE_TOO_LONG) {
            (void)snprintf(why, sizeof why, "line longer than %d characters", HS_SCENARIO_MAX_LINE);
        } else {
            (void)snprintf(why, sizeof why, "a NUL character in the line");
        }
        return refuse(sc, HS_E_SYNTAX, name, ln, why, err);
    }
    int r = parse_line(buf, dir, &a, why);
    if (r < 0) {
        return refuse(sc, HS_E_SYNTAX, name, ln, why, err);
    }
    if (r == 0) {
        return HS_OK;
    }
    if (sc->n >= HS_SCENARIO_MAX_ACTIONS) {
        (void)snprintf(why, sizeof why, "more than %d actions", HS_SCENARIO_MAX_ACTIONS);
        return refuse(sc, HS_E_SYNTAX, name, ln, why, err);
    }
    a.line = ln;
    sc->action[sc->n++] = a;
    return HS_OK;
}

static hs_status_t finish(hs_scenario_t *sc, const char *name, hs_scenario_error_t *err)
{
    if (sc->n == 0) {
        return refuse(sc, HS_E_SYNTAX, name, 0, "no actions (the scenario is empty or only comments)", err);
    }
    return HS_OK;
}

hs_status_t hs_scenario_parse(hs_scenario_t *sc, const char *text, const char *name, hs_scenario_error_t *err)
{
    if (sc == NULL || text == NULL) {
        return HS_E_ARG;
    }
    if (name == NULL) {
        name = "scenario";
    }
    start(sc, err);
    char buf[HS_SCENARIO_MAX_LINE + 1];
    const char *p = text;
    /* each round takes one line and moves p past it: at most strlen(text) rounds */
    for (int ln = 1; *p != '\0'; ln++) {
        const char *nl = strchr(p, '\n');
        size_t len = (nl != NULL) ? (size_t)(nl - p) : strlen(p);
        int shape = LINE_WHOLE;
        if (len > HS_SCENARIO_MAX_LINE) {
            shape = LINE_TOO_LONG;
            buf[0] = '\0';
        } else {
            memcpy(buf, p, len);
            buf[len] = '\0';
        }
        hs_status_t st = take_line(sc, buf, shape, name, NULL, ln, err);
        if (st != HS_OK) {
            return st;
        }
        p += len + ((nl != NULL) ? 1u : 0u);
    }
    return finish(sc, name, err);
}

hs_status_t hs_scenario_load(hs_scenario_t *sc, const char *path, hs_scenario_error_t *err)
{
    if (sc == NULL || path == NULL) {
        return HS_E_ARG;
    }
    start(sc, err);
    char why[WHY_LEN];
    /* the scenario's directory, for relative play files */
    char dir[HS_SCENARIO_MAX_PATH + 1] = "";
    const char *slash = strrchr(path, '/');
    if (slash != NULL) {
        size_t dl = (size_t)(slash - path);
        if (dl == 0) {
            dl = 1; /* "/x.scn": the root */
        }
        if (dl < sizeof dir) {
            memcpy(dir, path, dl);
            dir[dl] = '\0';
        }
    }
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        (void)snprintf(why, sizeof why, "cannot open the scenario: %s", strerror(errno));
        return refuse(sc, HS_E_IO, path, 0, why, err);
    }
    char buf[HS_SCENARIO_MAX_LINE + 1];
    size_t len = 0;
    int ln = 1, overlong = 0, nul = 0;
    hs_status_t st = HS_OK;
    /* one character a round: as many rounds as the file has characters, plus one */
    for (;;) {
        int c = getc(f);
        if (c == EOF && ferror(f)) {
            (void)snprintf(why, sizeof why, "cannot read the scenario: %s", strerror(errno));
            st = refuse(sc, HS_E_IO, path, 0, why, err);
            break;
        }
        if (c == EOF && len == 0 && !overlong && !nul) {
            break; /* no last line without '\n' */
        }
        if (c == EOF || c == '\n') {
            buf[len] = '\0';
            st = take_line(sc, buf, overlong ? LINE_TOO_LONG : (nul ? LINE_NUL : LINE_WHOLE), path, dir, ln, err);
            if (st != HS_OK || c == EOF) {
                break;
            }
            ln++;
            len = 0;
            overlong = 0;
            nul = 0;
        } else if (c == '\0') {
            nul = 1;
        } else if (len < HS_SCENARIO_MAX_LINE) {
            buf[len++] = (char)c;
        } else {
            overlong = 1;
        }
    }
    (void)fclose(f);
    return (st != HS_OK) ? st : finish(sc, path, err);
}

void hs_scenario_rewind(hs_scenario_t *sc)
{
    if (sc == NULL) {
        return;
    }
    sc->pc = 0;
    sc->until = 0;
    sc->armed = 0;
    sc->busy = 0;
}

hs_scenario_next_t hs_scenario_next(hs_scenario_t *sc, uint64_t tick, int state, const hs_action_t **action)
{
    if (action != NULL) {
        *action = NULL;
    }
    if (sc == NULL || action == NULL || sc->pc < 0 || sc->pc >= sc->n) {
        return HS_SCENARIO_END;
    }
    if (tick < sc->busy) {
        return HS_SCENARIO_PENDING; /* a play under way */
    }
    const hs_action_t *a = &sc->action[sc->pc];
    switch (a->kind) {
    case HS_ACTION_PLAY:
        sc->busy = tick + a->ticks;
        break;
    case HS_ACTION_DELAY:
        if (!sc->armed) {
            sc->until = tick + a->ticks;
            sc->armed = 1;
        }
        if (tick < sc->until) {
            return HS_SCENARIO_PENDING;
        }
        sc->armed = 0;
        break;
    case HS_ACTION_WAIT:
        if (!sc->armed) {
            sc->until = tick + a->ticks;
            sc->armed = 1;
        }
        if (state != (int)a->state) {
            if (tick >= sc->until) {
                *action = a;
                return HS_SCENARIO_TIMEOUT;
            }
            return HS_SCENARIO_PENDING;
        }
        sc->armed = 0;
        break;
    case HS_ACTION_END:
        *action = a;
        return HS_SCENARIO_END;
    default:
        break;
    }
    sc->pc++;
    *action = a;
    return HS_SCENARIO_DUE;
}

const char *hs_scenario_command_name(uint8_t command)
{
    return (command < N_COMMANDS) ? k_commands[command] : "unknown";
}

hs_status_t hs_play_open(hs_play_t *play, const char *path, hs_scenario_error_t *err)
{
    char why[WHY_LEN];
    int r;
    if (play == NULL || path == NULL) {
        return HS_E_ARG;
    }
    memset(play, 0, sizeof *play);
    play->file = fopen(path, "r");
    if (play->file == NULL) {
        (void)snprintf(why, sizeof why, "cannot open: %s", strerror(errno));
        if (err != NULL) {
            err->line = 0;
            (void)snprintf(err->message, sizeof err->message, "%s: %s", path, why);
        }
        return HS_E_IO;
    }
    if (read_play_header(play->file, &play->line, why) != 0 ||
        (r = read_play_row(play->file, &play->line, -1.0, play->row0, why)) <= 0 ||
        (r = read_play_row(play->file, &play->line, play->row0[0], play->row1, why)) < 0) {
        if (err != NULL) {
            err->line = (int)play->line;
            (void)snprintf(err->message, sizeof err->message, "%s: %s", path, why);
        }
        hs_play_close(play);
        return HS_E_SYNTAX;
    }
    play->at_end = (r == 0);
    return HS_OK;
}

hs_status_t hs_play_pose(hs_play_t *play, uint64_t ms, double pose[6], int *done, hs_scenario_error_t *err)
{
    char why[WHY_LEN];
    double t = (double)ms;
    if (play == NULL || pose == NULL || done == NULL || play->file == NULL) {
        return HS_E_ARG;
    }
    /* each round moves one row on: at most as many rounds as the file has rows */
    while (!play->at_end && play->row1[0] <= t + 1e-6) {
        double next[7];
        int r = read_play_row(play->file, &play->line, play->row1[0], next, why);
        if (r < 0) {
            if (err != NULL) {
                err->line = (int)play->line;
                (void)snprintf(err->message, sizeof err->message, "play: %s", why);
            }
            return HS_E_SYNTAX;
        }
        memcpy(play->row0, play->row1, sizeof play->row0);
        if (r == 0) {
            play->at_end = 1;
        } else {
            memcpy(play->row1, next, sizeof play->row1);
        }
    }
    if (play->at_end || t <= play->row0[0]) {
        memcpy(pose, &play->row0[1], 6 * sizeof pose[0]);
    } else {
        double f = (t - play->row0[0]) / (play->row1[0] - play->row0[0]);
        for (int k = 0; k < 6; k++) {
            pose[k] = play->row0[1 + k] + f * (play->row1[1 + k] - play->row0[1 + k]);
        }
    }
    *done = play->at_end && t >= play->row0[0] - 1e-6;
    return HS_OK;
}

void hs_play_close(hs_play_t *play)
{
    if (play != NULL && play->file != NULL) {
        (void)fclose(play->file);
        play->file = NULL;
    }
}
