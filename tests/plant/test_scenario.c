/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The scenario language of hs_sim (hs/scenario.h): parser, file reader and
 * player, without a bus.
 *
 * - Every action kind parses to its values: command numbers, axes, Q24
 *   amplitudes, frequencies and target poses (rounded to nearest, ties away
 *   from zero, up to INT32_MAX), fades in ms, delays and wait timeouts in
 *   1 ms ticks, states, legs 1..6 as 0..5, fault bits, mark texts; names are
 *   case-insensitive; comments, blank lines and "\r\n" endings are skipped
 *   and every action keeps its line number.
 * - Every malformed line is refused with HS_E_SYNTAX, names its line
 *   ("NAME:LINE: ") and says what is wrong: unknown action, command, key,
 *   axis or state; missing and extra arguments; words that are not numbers;
 *   values out of range; a repeated key; too many words; an overlong line;
 *   a mark text too long; more than 256 actions; an empty scenario or one
 *   of comments only (line 0). The scenario is empty after an error.
 *   Actions have no time stamps (only delays and waits), so there is no
 *   tick order to check.
 * - A file parses as the same text does; an overlong line or a NUL in a file
 *   names its line; a missing file is HS_E_IO.
 * - The player hands over each action once, at its tick: delays, waits
 *   (reached, or timed out), end, the end of the scenario, rewind.
 * - wrench (6 numbers or off, ramp=S), contact (plane, point, off; stiffness
 *   and damping required), load: values, ranges and every error message.
 * - play: the CSV is checked at parse time (header, 7 numbers a row, t >= 0
 *   increasing, pose ranges; errors name the file's line), a relative path
 *   is taken from the scenario file's directory, the player holds the next
 *   action until the last row's tick, and hs_play_pose holds the first
 *   row, interpolates linearly and ends exactly on the last row.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "hs/scenario.h"

static hs_scenario_t sc;
static hs_scenario_t sc2;
static hs_scenario_error_t err;

/* Parses text, which must hold exactly one action, and returns it. */
static const hs_action_t *one(const char *text)
{
    hs_status_t st = hs_scenario_parse(&sc, text, "t.scn", &err);
    if (st != HS_OK) {
        fail_msg("'%s' refused: %s", text, err.message);
    }
    assert_int_equal(sc.n, 1);
    return &sc.action[0];
}

/* text must be refused at `line` with a message "t.scn:LINE: ...WHAT...". */
static void refused(const char *text, int line, const char *what)
{
    char prefix[32];
    hs_status_t st = hs_scenario_parse(&sc, text, "t.scn", &err);
    if (st != HS_E_SYNTAX) {
        fail_msg("'%s' gave status %d, not HS_E_SYNTAX", text, (int)st);
    }
    assert_int_equal(err.line, line);
    if (line > 0) {
        (void)snprintf(prefix, sizeof prefix, "t.scn:%d: ", line);
    } else {
        (void)snprintf(prefix, sizeof prefix, "t.scn: ");
    }
    if (strncmp(err.message, prefix, strlen(prefix)) != 0 || strstr(err.message, what) == NULL) {
        fail_msg("'%s': message '%s', wanted '%s...%s'", text, err.message, prefix, what);
    }
    assert_int_equal(sc.n, 0);
}

static void test_cmd_names(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        uint8_t command;
    } cases[] = {
        {"cmd ENGAGE", SP_CMD_ENGAGE},
        {"cmd RUN_TRIG", SP_CMD_RUN_TRIG},
        {"cmd MOVE_TO", SP_CMD_MOVE_TO},
        {"cmd STREAM", SP_CMD_STREAM},
        {"cmd STOP", SP_CMD_STOP},
        {"cmd PARK", SP_CMD_PARK},
        {"cmd ESTOP", SP_CMD_ESTOP},
        {"cmd RESET", SP_CMD_RESET},
        {"cmd SET_FEEDFORWARD", 9u},
        {"CMD engage", 1u},
        {"Cmd Park", 6u},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const hs_action_t *a = one(cases[i].text);
        assert_int_equal(a->kind, HS_ACTION_CMD);
        assert_int_equal(a->line, 1);
        assert_int_equal(a->cmd.command, cases[i].command);
        /* no arguments: all zero (the controller's defaults) */
        assert_int_equal(a->cmd.axis, 0);
        assert_int_equal(a->cmd.amplitude, 0);
        assert_int_equal(a->cmd.frequency, 0);
        assert_int_equal(a->cmd.fade_ms, 0);
        assert_int_equal(a->cmd.option, 0);
    }
    assert_string_equal(hs_scenario_command_name(0), "NONE");
    assert_string_equal(hs_scenario_command_name(2), "RUN_TRIG");
    assert_string_equal(hs_scenario_command_name(9), "SET_FEEDFORWARD");
    assert_string_equal(hs_scenario_command_name(10), "FORCE");
    assert_string_equal(hs_scenario_command_name(13), "TARE");
    assert_string_equal(hs_scenario_command_name(14), "unknown");
}

/* Force control as an operator sends it: OP_FORCE (mask, target) with
 * OP_COMMAND FORCE or GUIDE, a target update alone, POSITION, TARE; a
 * person's push; the sensor switched off. */
static void test_force_actions(void **state)
{
    (void)state;
    const hs_action_t *a = one("force z 0 0 2000 0 0 -12.5");
    assert_int_equal(a->kind, HS_ACTION_FORCE);
    assert_int_equal(a->cmd.command, SP_CMD_FORCE);
    assert_int_equal(a->force.mask, 0x04);
    assert_int_equal(a->force.target[2], 2000 * 256);
    assert_int_equal(a->force.target[5], -3200);
    a = one("force x,Z,yaw 10 0 -5 0 0 1");
    assert_int_equal(a->force.mask, 0x25);
    a = one("force 0 0 0 1 0 0 0");
    assert_int_equal(a->force.mask, 0);
    a = one("force_target 4 0 0 2500 0 0 0");
    assert_int_equal(a->kind, HS_ACTION_FORCE);
    assert_int_equal(a->cmd.command, 0);
    assert_int_equal(a->force.target[2], 2500 * 256);
    a = one("guide x,y");
    assert_int_equal(a->cmd.command, SP_CMD_GUIDE);
    assert_int_equal(a->force.mask, 0x03);
    assert_int_equal(a->force.target[0], 0);
    a = one("position");
    assert_int_equal(a->kind, HS_ACTION_CMD);
    assert_int_equal(a->cmd.command, SP_CMD_POSITION);
    a = one("TARE");
    assert_int_equal(a->cmd.command, SP_CMD_TARE);
    a = one("cmd GUIDE");
    assert_int_equal(a->cmd.command, SP_CMD_GUIDE);
    a = one("push 200 0 0 0 0 0 rise=0.2 hold=1.5");
    assert_int_equal(a->kind, HS_ACTION_PUSH);
    assert_true(a->wrench[0] == 200.0);
    assert_int_equal(a->ticks, 200);
    assert_int_equal(a->hold, 1500);
    a = one("ftsensor off");
    assert_int_equal(a->kind, HS_ACTION_FTSENSOR);
    assert_int_equal(a->bits, 0);
    a = one("ftsensor ON");
    assert_int_equal(a->bits, 1);

    refused("force z 0 0 2000 0 0", 1, "force needs the axes and 6 numbers");
    refused("force q 0 0 2000 0 0 0", 1, "unknown axis 'q'");
    refused("force 64 0 0 2000 0 0 0", 1, "axes mask 64 is out of range");
    refused("force z 0 0 16384 0 0 0", 1, "force value 16384 is out of range");
    refused("guide", 1, "guide needs the axes");
    refused("position now", 1, "position takes no arguments");
    refused("push 200 0 0 0 0 0 rise=0.2", 1, "push needs 6 numbers");
    refused("push 200 0 0 0 0 0 rise=0.2 rise=0.3", 1, "push: argument 'rise' given twice");
    refused("push 200 0 0 0 0 0 rise=0.2 hold=-1", 1, "push: hold -1 is out of range");
    refused("ftsensor", 1, "ftsensor takes 'off' or 'on'");
}

static void test_cmd_arguments(void **state)
{
    (void)state;
    const hs_action_t *a = one("cmd RUN_TRIG axis=x amplitude=0.090000 frequency=0.5000 fade=1.000");
    assert_int_equal(a->cmd.command, SP_CMD_RUN_TRIG);
    assert_int_equal(a->cmd.axis, SP_AXIS_X);
    assert_int_equal(a->cmd.amplitude, 1509949); /* 0.09 * 2^24 = 1509949.44 */
    assert_int_equal(a->cmd.frequency, 8388608); /* 0.5 * 2^24 */
    assert_int_equal(a->cmd.fade_ms, 1000);
    assert_int_equal(a->cmd.option, 0);

    a = one("cmd RUN_TRIG amplitude=-0.09 axis=YAW frequency=0.75 fade=0.0006 option=1");
    assert_int_equal(a->cmd.axis, SP_AXIS_YAW);
    assert_int_equal(a->cmd.amplitude, -1509949);
    assert_int_equal(a->cmd.frequency, 12582912); /* 0.75 * 2^24 */
    assert_int_equal(a->cmd.fade_ms, 1);          /* 0.6 ms rounds to 1 */
    assert_int_equal(a->cmd.option, 1);

    /* Q24 rounding: half an LSB (2^-25) rounds away from zero; the largest value is INT32_MAX */
    a = one("cmd MOVE_TO amplitude=2.98023223876953125e-08 frequency=127.999999940395355224609375 fade=65");
    assert_int_equal(a->cmd.amplitude, 1);
    assert_int_equal(a->cmd.frequency, INT32_MAX);
    assert_int_equal(a->cmd.fade_ms, 65000);
    a = one("cmd MOVE_TO amplitude=-2.98023223876953125e-08 frequency=0");
    assert_int_equal(a->cmd.amplitude, -1);
    assert_int_equal(a->cmd.frequency, 0);
    a = one("cmd SET_FEEDFORWARD option=0");
    assert_int_equal(a->cmd.command, 9);
    assert_int_equal(a->cmd.option, 0);

    static const char *const axes[] = {"x", "y", "z", "roll", "pitch", "yaw"};
    for (int i = 0; i < 6; i++) {
        char text[64];
        (void)snprintf(text, sizeof text, "cmd RUN_TRIG axis=%s", axes[i]);
        assert_int_equal(one(text)->cmd.axis, i);
    }
    assert_int_equal(one("cmd RUN_TRIG axis=Pitch")->cmd.axis, SP_AXIS_PITCH);
}

static void test_target(void **state)
{
    (void)state;
    const hs_action_t *a = one("target 0.01 -0.02 2.56 0.01 -0.01 0.02");
    assert_int_equal(a->kind, HS_ACTION_TARGET);
    assert_int_equal(a->target.pos[0], 167772);   /* 167772.16 */
    assert_int_equal(a->target.pos[1], -335544);  /* -335544.32 */
    assert_int_equal(a->target.pos[2], 42949673); /* 42949672.96 */
    assert_int_equal(a->target.rpy[0], 167772);
    assert_int_equal(a->target.rpy[1], -167772);
    assert_int_equal(a->target.rpy[2], 335544);

    a = one("TARGET 8 -8 0 1e-3 -0 2.98023223876953125e-08");
    assert_int_equal(a->target.pos[0], 134217728);
    assert_int_equal(a->target.pos[1], -134217728);
    assert_int_equal(a->target.pos[2], 0);
    assert_int_equal(a->target.rpy[0], 16777); /* 16777.216 */
    assert_int_equal(a->target.rpy[1], 0);
    assert_int_equal(a->target.rpy[2], 1);
}

static void test_delay_and_wait(void **state)
{
    (void)state;
    const hs_action_t *a = one("delay 8.000");
    assert_int_equal(a->kind, HS_ACTION_DELAY);
    assert_int_equal(a->ticks, 8000);
    assert_int_equal(one("delay 0")->ticks, 0);
    assert_int_equal(one("delay 0.0004")->ticks, 0); /* nearest tick */
    assert_int_equal(one("delay 0.0006")->ticks, 1);
    assert_int_equal(one("delay 1e6")->ticks, 1000000000u);

    a = one("wait ready 20");
    assert_int_equal(a->kind, HS_ACTION_WAIT);
    assert_int_equal(a->state, SP_STATE_READY);
    assert_int_equal(a->ticks, 20000);
    a = one("wait idle");
    assert_int_equal(a->state, SP_STATE_IDLE);
    assert_int_equal(a->ticks, 60000); /* default 60 s */
    a = one("WAIT Estop 0.5");
    assert_int_equal(a->state, SP_STATE_ESTOP);
    assert_int_equal(a->ticks, 500);

    static const char *const states[] = {"idle",    "engaging", "ready", "running",
                                         "parking", "fault",    "estop", "stopping"};
    for (int i = 0; i < 8; i++) {
        char text[32];
        (void)snprintf(text, sizeof text, "wait %s 1", states[i]);
        assert_int_equal(one(text)->state, i);
    }
}

static void test_drive_actions(void **state)
{
    (void)state;
    const hs_action_t *a = one("silence 1");
    assert_int_equal(a->kind, HS_ACTION_SILENCE);
    assert_int_equal(a->leg, 0);
    a = one("unsilence 6");
    assert_int_equal(a->kind, HS_ACTION_UNSILENCE);
    assert_int_equal(a->leg, 5);
    a = one("fault 2 0x04");
    assert_int_equal(a->kind, HS_ACTION_FAULT);
    assert_int_equal(a->leg, 1);
    assert_int_equal(a->bits, 0x04);
    a = one("FAULT 3 255");
    assert_int_equal(a->leg, 2);
    assert_int_equal(a->bits, 0xFF);
    a = one("fault 4 0x1");
    assert_int_equal(a->bits, 1);
}

/* The fault injection section: every form, and what is refused. */
static void test_inject(void **state)
{
    (void)state;
    const hs_action_t *a = one("inject frames axis_a setpoints drop");
    assert_int_equal(a->kind, HS_ACTION_INJECT);
    assert_int_equal(a->inject.what, HS_INJECT_FRAMES);
    assert_int_equal(a->inject.bus, 1);
    assert_int_equal(a->inject.id_lo, 0x20);
    assert_int_equal(a->inject.id_hi, 0x20);
    assert_int_equal(a->inject.fault, 0);
    assert_int_equal(a->inject.count, 1u); /* no rate: the next frame */
    a = one("inject frames any feedback corrupt rate=0.25");
    assert_int_equal(a->inject.bus, 0xFF);
    assert_int_equal(a->inject.id_lo, 0x31);
    assert_int_equal(a->inject.id_hi, 0x33);
    assert_int_equal(a->inject.fault, 4);
    assert_true(a->inject.rate == 0.25);
    assert_int_equal(a->inject.count, 0u);
    a = one("INJECT frames ops 0x100 delay delay=7 count=3");
    assert_int_equal(a->inject.bus, 0);
    assert_int_equal(a->inject.id_lo, 0x100);
    assert_int_equal(a->inject.fault, 1);
    assert_int_equal(a->inject.delay, 7u);
    assert_int_equal(a->inject.count, 3u);
    a = one("inject frames off");
    assert_int_equal(a->inject.what, HS_INJECT_FRAMES_OFF);
    a = one("inject busoff axis_b 0.25");
    assert_int_equal(a->inject.what, HS_INJECT_BUSOFF);
    assert_int_equal(a->inject.bus, 2);
    assert_int_equal(a->inject.ticks, 250u);
    assert_int_equal(a->inject.mode, 1);
    a = one("inject busoff ops off");
    assert_int_equal(a->inject.mode, 0);
    a = one("inject drive 3 fault 0x10 hold");
    assert_int_equal(a->inject.what, HS_INJECT_DRIVE);
    assert_int_equal(a->inject.leg, 2);
    assert_int_equal(a->inject.bits, 0x10u);
    assert_int_equal(a->inject.hold, 1);
    a = one("inject drive 6 stale 9");
    assert_int_equal(a->inject.mode, 2);
    assert_int_equal(a->inject.ticks, 9u);
    a = one("inject drive 1 freeze");
    assert_int_equal(a->inject.mode, 1);
    a = one("inject sensor 2 noise 0.004");
    assert_int_equal(a->inject.what, HS_INJECT_SENSOR);
    assert_int_equal(a->inject.mode, 3);
    assert_true(a->inject.value == 0.004);
    a = one("inject sensor 2 stick");
    assert_int_equal(a->inject.mode, 1);
    a = one("inject valve 5 stick -0.5");
    assert_int_equal(a->inject.what, HS_INJECT_VALVE);
    assert_true(a->inject.value == -0.5);
    a = one("inject supply loss");
    assert_int_equal(a->inject.what, HS_INJECT_SUPPLY);
    assert_int_equal(a->inject.mode, 1);
    a = one("inject endstop 4 down");
    assert_int_equal(a->inject.what, HS_INJECT_ENDSTOP);
    assert_true(a->inject.value == -1.0);
    a = one("inject fk");
    assert_int_equal(a->inject.what, HS_INJECT_FK);
    assert_true(a->inject.value == 0.05);
    a = one("inject clear");
    assert_int_equal(a->inject.what, HS_INJECT_CLEAR);

    refused("inject", 1, "needs what to inject");
    refused("inject frames axis_c setpoints drop", 1, "unknown bus 'axis_c'");
    refused("inject frames ops frob drop", 1, "unknown message 'frob'");
    refused("inject frames ops 0x800 drop", 1, "unknown message '0x800'");
    refused("inject frames ops command smash", 1, "unknown frame fault 'smash'");
    refused("inject frames ops command drop rate=0", 1, "rate 0 is out of range");
    refused("inject frames ops command drop rate=0.5 rate=0.5", 1, "unknown or repeated argument");
    refused("inject frames ops command drop delay=3", 1, "delay= only goes with the delay fault");
    refused("inject frames ops command delay delay=0", 1, "is not 1..");
    refused("inject busoff any", 1, "unknown bus 'any'");
    refused("inject busoff ops -1", 1, "is not a time");
    refused("inject drive 7 freeze", 1, "needs a leg");
    refused("inject drive 1 fault 0x100", 1, "are not 1..0xff");
    refused("inject drive 1 fault 1 forever", 1, "is not 'hold'");
    refused("inject sensor 1 jump", 1, "needs M");
    refused("inject sensor 1 ok 3", 1, "takes no value");
    refused("inject sensor 1 jump 11", 1, "|M| <= 10");
    refused("inject valve 1 stick 2", 1, "is not -1..1");
    refused("inject supply gone", 1, "needs loss or ok");
    refused("inject endstop 1 sideways", 1, "is not up or down");
    refused("inject fk 2", 1, "0 < M <= 1");
    refused("inject clear now", 1, "takes no arguments");
    refused("inject frob", 1, "unknown injection 'frob'");
}

static void test_mark_and_end(void **state)
{
    (void)state;
    const hs_action_t *a = one("mark  engaged,\t now   move   # not this");
    assert_int_equal(a->kind, HS_ACTION_MARK);
    assert_string_equal(a->text, "engaged, now move");
    assert_string_equal(one("mark")->text, "");
    /* 95 characters fit */
    char text[128];
    (void)snprintf(text, sizeof text, "mark %095d", 7);
    assert_int_equal(strlen(one(text)->text), 95);
    a = one("end");
    assert_int_equal(a->kind, HS_ACTION_END);
    assert_int_equal(one("End # the end")->kind, HS_ACTION_END);
}

static void test_lines_and_comments(void **state)
{
    (void)state;
    const char *text = "# generated\n"
                       "\n"
                       "   \t \n"
                       "  cmd ENGAGE   # go\r\n"
                       "# wait ready\n"
                       "wait ready 20\r\n"
                       "\tdelay 0.5\n"
                       "mark last line without newline";
    assert_int_equal(hs_scenario_parse(&sc, text, "t.scn", &err), HS_OK);
    assert_int_equal(sc.n, 4);
    assert_int_equal(sc.action[0].kind, HS_ACTION_CMD);
    assert_int_equal(sc.action[0].line, 4);
    assert_int_equal(sc.action[1].kind, HS_ACTION_WAIT);
    assert_int_equal(sc.action[1].line, 6);
    assert_int_equal(sc.action[1].ticks, 20000);
    assert_int_equal(sc.action[2].kind, HS_ACTION_DELAY);
    assert_int_equal(sc.action[2].line, 7);
    assert_int_equal(sc.action[2].ticks, 500);
    assert_int_equal(sc.action[3].kind, HS_ACTION_MARK);
    assert_int_equal(sc.action[3].line, 8);
    assert_string_equal(sc.action[3].text, "last line without newline");
    assert_int_equal(sc.pc, 0);

    /* a comment line of exactly the longest length is fine */
    static char longest[HS_SCENARIO_MAX_LINE + 16];
    longest[0] = '#';
    memset(&longest[1], 'x', HS_SCENARIO_MAX_LINE - 1);
    (void)snprintf(&longest[HS_SCENARIO_MAX_LINE], 16, "\nend\n");
    assert_int_equal(hs_scenario_parse(&sc, longest, "t.scn", &err), HS_OK);
    assert_int_equal(sc.n, 1);
    assert_int_equal(sc.action[0].line, 2);
}

static void test_malformed_lines(void **state)
{
    (void)state;
    /* the line number is the line's, counting comments and blank lines */
    refused("cmd ENGAGE\n\n# comment\nfrob 1\nend\n", 4, "unknown action 'frob'");
    refused("delay 1\r\nwaitt ready\r\n", 2, "unknown action 'waitt'");

    refused("cmd", 1, "cmd needs a command name");
    refused("cmd FLY", 1, "unknown command 'FLY'");
    refused("cmd NONE", 1, "unknown command 'NONE'");
    refused("cmd RUN_TRIG axis", 1, "expected key=value after the command name, got 'axis'");
    refused("cmd RUN_TRIG speed=1", 1, "unknown argument 'speed'");
    refused("cmd RUN_TRIG Axis=x", 1, "unknown argument 'Axis'");
    refused("cmd RUN_TRIG axis=x axis=y", 1, "argument 'axis' given twice");
    refused("cmd RUN_TRIG axis=w", 1, "unknown axis 'w'");
    refused("cmd RUN_TRIG amplitude=abc", 1, "amplitude: 'abc' is not a number");
    refused("cmd RUN_TRIG amplitude=", 1, "amplitude: '' is not a number");
    refused("cmd RUN_TRIG amplitude=0.1m", 1, "amplitude: '0.1m' is not a number");
    refused("cmd RUN_TRIG amplitude=nan", 1, "is not a number");
    refused("cmd RUN_TRIG amplitude=inf", 1, "is not a number");
    refused("cmd RUN_TRIG amplitude=1e400", 1, "is not a number");
    refused("cmd RUN_TRIG amplitude=128", 1, "amplitude 128 is out of range");
    refused("cmd RUN_TRIG amplitude=-128", 1, "amplitude -128 is out of range");
    refused("cmd RUN_TRIG frequency=-0.5", 1, "frequency -0.5 is out of range");
    refused("cmd RUN_TRIG frequency=200", 1, "frequency 200 is out of range");
    refused("cmd RUN_TRIG fade=-1", 1, "fade -1 is out of range (0..65 s)");
    refused("cmd RUN_TRIG fade=65.001", 1, "fade 65.001 is out of range");
    refused("cmd SET_FEEDFORWARD option=2", 1, "option must be 0 or 1, got '2'");
    refused("cmd SET_FEEDFORWARD option=0.5", 1, "option must be 0 or 1");

    refused("target 0 0 2.5 0 0", 1, "target needs 6 numbers (x y z roll pitch yaw), got 5");
    refused("target 0 0 2.5 0 0 0 0", 1, "got 7");
    refused("target", 1, "got 0");
    refused("target 0 0 x 0 0 0", 1, "target value 'x' is not a number");
    refused("target 0 0 8.5 0 0 0", 1, "target value 8.5 is out of range");

    refused("delay", 1, "delay needs one number of seconds (0..1e6), got 0 arguments");
    refused("delay 1 2", 1, "got 2 arguments");
    refused("delay 1s", 1, "delay: '1s' is not a number");
    refused("delay -0.1", 1, "delay -0.1 is out of range");
    refused("delay 1e7", 1, "delay 1e7 is out of range");

    refused("wait", 1, "wait needs a state");
    refused("wait ready 1 2", 1, "got 3 arguments");
    refused("wait flying", 1,
            "unknown state 'flying' (idle, engaging, ready, running, parking, fault, estop, stopping)");
    refused("wait ready 0", 1, "wait timeout 0 is out of range");
    refused("wait ready -1", 1, "wait timeout -1 is out of range");
    refused("wait ready soon", 1, "wait timeout 'soon' is not a number");

    refused("silence", 1, "silence needs one leg (1..6), got 0 arguments");
    refused("silence 1 2", 1, "silence needs one leg (1..6), got 2 arguments");
    refused("unsilence", 1, "unsilence needs one leg");
    refused("silence 0", 1, "leg '0' is not one of 1..6");
    refused("silence 7", 1, "leg '7' is not one of 1..6");
    refused("unsilence 1.5", 1, "leg '1.5' is not one of 1..6");
    refused("silence x", 1, "leg 'x' is not one of 1..6");
    refused("fault 2", 1, "fault needs a leg (1..6) and fault bits (1..0xff), got 1 arguments");
    refused("fault 2 4 5", 1, "got 3 arguments");
    refused("fault 9 4", 1, "leg '9' is not one of 1..6");
    refused("fault 2 0", 1, "fault bits '0' are not 1..0xff");
    refused("fault 2 0x100", 1, "fault bits '0x100' are not 1..0xff");
    refused("fault 2 4x", 1, "fault bits '4x' are not 1..0xff");
    refused("fault 2 -1", 1, "fault bits '-1' are not 1..0xff");

    refused("end now", 1, "end takes no arguments, got 1");
    refused("mark 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16", 1, "more than 16 words");
    char text[160];
    (void)snprintf(text, sizeof text, "mark %096d", 7);
    refused(text, 1, "mark text longer than 95 characters");
}

static void test_overlong_and_empty(void **state)
{
    (void)state;
    static char text[HS_SCENARIO_MAX_LINE + 64];
    /* line 3 has 511 characters: refused, though it is a comment */
    size_t n = (size_t)snprintf(text, sizeof text, "cmd ENGAGE\ndelay 1\n#");
    memset(&text[n], 'x', HS_SCENARIO_MAX_LINE);
    (void)snprintf(&text[n + HS_SCENARIO_MAX_LINE], 32, "\nend\n");
    refused(text, 3, "line longer than 510 characters");

    refused("", 0, "no actions");
    refused("# only\n\n   # comments\n\t\n", 0, "no actions");

    /* NULL arguments; a NULL name is "scenario"; a NULL err is allowed */
    assert_int_equal(hs_scenario_parse(NULL, "end", "t", &err), HS_E_ARG);
    assert_int_equal(hs_scenario_parse(&sc, NULL, "t", &err), HS_E_ARG);
    assert_int_equal(hs_scenario_parse(&sc, "frob", NULL, &err), HS_E_SYNTAX);
    assert_string_equal(err.message,
                        "scenario:1: unknown action 'frob' "
                        "(cmd, target, delay, wait, silence, unsilence, fault, mark, end, wrench, contact, load, play, "
                        "force, force_target, guide, position, tare, push, ftsensor, inject, frame)");
    assert_int_equal(hs_scenario_parse(&sc, "frob", NULL, NULL), HS_E_SYNTAX);
    assert_int_equal(hs_scenario_parse(&sc, "end", NULL, NULL), HS_OK);
    assert_int_equal(hs_scenario_load(&sc, NULL, &err), HS_E_ARG);
}

static void test_action_limit(void **state)
{
    (void)state;
    static char text[HS_SCENARIO_MAX_ACTIONS * 16 + 64];
    size_t n = 0;
    for (int i = 0; i < HS_SCENARIO_MAX_ACTIONS; i++) {
        n += (size_t)snprintf(&text[n], sizeof text - n, "delay 0.%03d\n", i);
    }
    n += (size_t)snprintf(&text[n], sizeof text - n, "\n# blank lines and comments after the last action\n");
    assert_int_equal(hs_scenario_parse(&sc, text, "t.scn", &err), HS_OK);
    assert_int_equal(sc.n, HS_SCENARIO_MAX_ACTIONS);
    assert_int_equal(sc.action[255].ticks, 255);
    assert_int_equal(sc.action[255].line, 256);
    (void)snprintf(&text[n], sizeof text - n, "end\n");
    refused(text, HS_SCENARIO_MAX_ACTIONS + 3, "more than 256 actions");
}

static void same_action(const hs_action_t *a, const hs_action_t *b)
{
    assert_int_equal(a->kind, b->kind);
    assert_int_equal(a->line, b->line);
    assert_int_equal(a->cmd.command, b->cmd.command);
    assert_int_equal(a->cmd.axis, b->cmd.axis);
    assert_int_equal(a->cmd.amplitude, b->cmd.amplitude);
    assert_int_equal(a->cmd.frequency, b->cmd.frequency);
    assert_int_equal(a->cmd.fade_ms, b->cmd.fade_ms);
    assert_int_equal(a->cmd.option, b->cmd.option);
    for (int k = 0; k < 3; k++) {
        assert_int_equal(a->target.pos[k], b->target.pos[k]);
        assert_int_equal(a->target.rpy[k], b->target.rpy[k]);
    }
    assert_int_equal(a->ticks, b->ticks);
    assert_int_equal(a->state, b->state);
    assert_int_equal(a->leg, b->leg);
    assert_int_equal(a->bits, b->bits);
    assert_string_equal(a->text, b->text);
}

/* Writes `len` bytes to a new temporary file; its name in path (size 64). */
static void write_file(char *path, const char *data, size_t len)
{
    (void)snprintf(path, 64, "/tmp/hs_scenario_test_XXXXXX");
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, data, len), (ssize_t)len);
    assert_int_equal(close(fd), 0);
}

static void test_load_file(void **state)
{
    (void)state;
    const char *text = "# demo\ncmd ENGAGE\nwait ready 20\r\n"
                       "cmd RUN_TRIG axis=x amplitude=0.090000 frequency=0.5000 fade=1.000\n"
                       "delay 8.000\ntarget 0 0 2.55 0 0 0.01\nsilence 3\nfault 2 0x10\nmark done # x\nend";
    char path[64];
    write_file(path, text, strlen(text));
    assert_int_equal(hs_scenario_load(&sc, path, &err), HS_OK);
    assert_int_equal(hs_scenario_parse(&sc2, text, "t.scn", &err), HS_OK);
    assert_int_equal(sc.n, 9);
    assert_int_equal(sc.n, sc2.n);
    for (int i = 0; i < sc.n; i++) {
        same_action(&sc.action[i], &sc2.action[i]);
    }
    assert_int_equal(sc.action[8].line, 10);
    (void)unlink(path);

    /* an overlong line (line 2) and a NUL (line 3) are named by their line */
    static char data[HS_SCENARIO_MAX_LINE + 64];
    size_t n = (size_t)snprintf(data, sizeof data, "end\n");
    memset(&data[n], 'x', HS_SCENARIO_MAX_LINE + 1);
    n += HS_SCENARIO_MAX_LINE + 1;
    n += (size_t)snprintf(&data[n], sizeof data - n, "\nend\n");
    write_file(path, data, n);
    assert_int_equal(hs_scenario_load(&sc, path, &err), HS_E_SYNTAX);
    assert_int_equal(err.line, 2);
    assert_non_null(strstr(err.message, ":2: line longer than 510 characters"));
    assert_int_equal(strncmp(err.message, path, strlen(path)), 0);
    assert_int_equal(sc.n, 0);
    (void)unlink(path);

    /* exactly the longest line, without a newline at the end of the file */
    n = (size_t)snprintf(data, sizeof data, "end\n#");
    memset(&data[n], 'x', HS_SCENARIO_MAX_LINE - 1);
    n += HS_SCENARIO_MAX_LINE - 1;
    write_file(path, data, n);
    assert_int_equal(hs_scenario_load(&sc, path, &err), HS_OK);
    assert_int_equal(sc.n, 1);
    (void)unlink(path);

    static const char with_nul[] = "end\nend\nmark a\0b\n";
    write_file(path, with_nul, sizeof with_nul - 1);
    assert_int_equal(hs_scenario_load(&sc, path, &err), HS_E_SYNTAX);
    assert_int_equal(err.line, 3);
    assert_non_null(strstr(err.message, ":3: a NUL character in the line"));
    (void)unlink(path);

    write_file(path, "\n# nothing\n", 11);
    assert_int_equal(hs_scenario_load(&sc, path, &err), HS_E_SYNTAX);
    assert_int_equal(err.line, 0);
    assert_non_null(strstr(err.message, ": no actions"));
    (void)unlink(path);

    assert_int_equal(hs_scenario_load(&sc, "/nonexistent/dir/x.scenario", &err), HS_E_IO);
    assert_int_equal(err.line, 0);
    assert_string_equal(err.message,
                        "/nonexistent/dir/x.scenario: cannot open the scenario: No such file or directory");
}

static void expect_next(uint64_t tick, int ctrl_state, hs_scenario_next_t want, const hs_action_t *want_action);

/* `contact surface`: a plane placed by a point on it and its tilt. */
static void test_contact_surface(void **state)
{
    (void)state;
    const double s20 = sin(0.349066), c20 = cos(0.349066);
    /* untilted: today's ceiling (free side down) and a floor */
    const hs_action_t *a = one("contact surface down 0 0 2.6 0 0 0 0 0.05 stiffness=1e6 damping=1000");
    assert_int_equal(a->kind, HS_ACTION_CONTACT);
    assert_int_equal(a->contact.kind, 1);
    assert_true(a->contact.normal[0] == 0.0 && a->contact.normal[2] == -1.0 && a->contact.offset == -2.6);
    assert_true(a->contact.point[2] == 0.05 && a->contact.stiffness == 1e6 && a->contact.damping == 1000.0);
    a = one("contact surface UP 1 2 0.5 0 0 0 0 0 stiffness=1 damping=0");
    assert_true(a->contact.normal[2] == 1.0 && a->contact.offset == 0.5);
    /* 20 degrees about x: n = (0, sin, -cos), through (0.1, 0.2, 2.6) */
    a = one("contact surface down 0.1 0.2 2.6 0.349066 0 0 0 0.05 stiffness=1e6 damping=1000");
    assert_true(fabs(a->contact.normal[0]) < 1e-15 && fabs(a->contact.normal[1] - s20) < 1e-12 &&
                fabs(a->contact.normal[2] + c20) < 1e-12);
    assert_true(fabs(a->contact.offset - (0.2 * s20 - 2.6 * c20)) < 1e-12);
    /* and about y: n = (sin p, 0, cos p) for up; unit length with both */
    a = one("contact surface up 0 0 0 0 0.349066 0 0 0 stiffness=1 damping=1");
    assert_true(fabs(a->contact.normal[0] - s20) < 1e-12 && fabs(a->contact.normal[2] - c20) < 1e-12);
    a = one("contact surface up 0 0 0 0.3 -0.7 0 0 0 stiffness=1 damping=1");
    assert_true(fabs(a->contact.normal[0] * a->contact.normal[0] + a->contact.normal[1] * a->contact.normal[1] +
                     a->contact.normal[2] * a->contact.normal[2] - 1.0) < 1e-12);
    refused("contact surface 0 0 0 0 0 0 0 0 stiffness=1 damping=1", 1, "contact surface needs up or down");
    refused("contact surface up 0 0 0 0 0 0 0 stiffness=1 damping=1", 1, "contact surface needs 8 numbers");
    refused("contact surface up 0 0 0 1.6 0 0 0 0 stiffness=1 damping=1", 1,
            "contact surface tilt value 1.6 is out of range (|v| <= 1.5 rad)");
    refused("contact surface up 0 0 200 0 0 0 0 0 stiffness=1 damping=1", 1, "contact surface point value 200");
    refused("contact surface up 0 0 0 0 0 0 0 nan stiffness=1 damping=1", 1,
            "contact surface tool point value 'nan' is not a number");
    refused("contact surface up 0 0 0 0 0 0 0 0 stiffness=1", 1, "contact needs stiffness=K");
}

/* `frame`: OP_FRAME's select and set (issue 31). */
static void test_frame_action(void **state)
{
    (void)state;
    const hs_action_t *a = one("frame tool select 1");
    assert_int_equal(a->kind, HS_ACTION_FRAME);
    assert_true(a->frame.op == 0 && a->frame.kind == 0 && a->frame.index == 1);
    a = one("FRAME work set 3 0.1 -0.2 2.6 0.349066 0 -1.5");
    assert_true(a->frame.op == 1 && a->frame.kind == 1 && a->frame.index == 3);
    assert_true(a->frame.value[0] == 0.1 && a->frame.value[2] == 2.6 && a->frame.value[3] == 0.349066 &&
                a->frame.value[5] == -1.5);
    a = one("frame tool select 15"); /* the wire's range: the controller refuses it */
    assert_int_equal(a->frame.index, 15);
    refused("frame tool", 1, "frame needs tool or work, select or set, and a slot");
    refused("frame hand select 0", 1, "frame: unknown kind 'hand' (tool, work)");
    refused("frame tool pick 0", 1, "frame: unknown operation 'pick' (select, set)");
    refused("frame tool select 16", 1, "frame: slot '16' is not 0..15");
    refused("frame tool select 1.5", 1, "frame: slot '1.5' is not 0..15");
    refused("frame tool select 1 2", 1, "frame select takes a slot alone");
    refused("frame work set 1 0 0 0 0 0", 1, "frame set needs a slot and 6 numbers");
    refused("frame work set 1 0 0 9 0 0 0", 1, "frame value 9 is out of range (|v| <= 8 m or rad)");
    refused("frame work set 1 0 0 nan 0 0 0", 1, "frame value 'nan' is not a number");
}

static void test_wrench_contact_load(void **state)
{
    (void)state;
    const hs_action_t *a = one("wrench 100 -200 300.5 10 -20 30 ramp=0.25");
    assert_int_equal(a->kind, HS_ACTION_WRENCH);
    assert_true(a->wrench[0] == 100.0 && a->wrench[2] == 300.5 && a->wrench[5] == 30.0);
    assert_int_equal(a->ticks, 250);
    a = one("WRENCH off");
    assert_int_equal(a->kind, HS_ACTION_WRENCH);
    assert_true(a->wrench[0] == 0.0 && a->wrench[5] == 0.0);
    assert_int_equal(a->ticks, 0);
    a = one("wrench off ramp=2");
    assert_int_equal(a->ticks, 2000);
    refused("wrench 1 2 3", 1, "wrench needs 6 numbers (fx fy fz mx my mz) or 'off'");
    refused("wrench 1 2 3 4 5 6 7", 1, "wrench needs 6 numbers");
    refused("\nwrench 1 2 3 4 5 x", 2, "wrench value 'x' is not a number");
    refused("wrench 1 2 3 4 5 2e6", 1, "wrench value 2e6 is out of range (|v| <= 1e+06 N or N m)");
    refused("wrench 1 2 3 4 5 6 ramp=-1", 1, "wrench: ramp -1 is out of range (0..1e+06)");
    refused("wrench off ramp=1 ramp=2", 1, "wrench: argument 'ramp' given twice");
    refused("wrench off speed=1", 1, "wrench: unknown argument 'speed'");

    a = one("contact plane 0 0 1 1.9 0.3 0 -0.25 stiffness=1e7 damping=2e4");
    assert_int_equal(a->kind, HS_ACTION_CONTACT);
    assert_int_equal(a->contact.kind, 1);
    assert_true(a->contact.normal[2] == 1.0 && a->contact.offset == 1.9 && a->contact.point[0] == 0.3 &&
                a->contact.point[2] == -0.25);
    assert_true(a->contact.stiffness == 1e7 && a->contact.damping == 2e4);
    a = one("contact point 0.5 0 2.4 0.5 0 -0.1 damping=100 stiffness=1e5");
    assert_int_equal(a->contact.kind, 2);
    assert_true(a->contact.anchor[0] == 0.5 && a->contact.anchor[2] == 2.4 && a->contact.point[2] == -0.1);
    assert_true(a->contact.stiffness == 1e5 && a->contact.damping == 100.0);
    a = one("contact off");
    assert_int_equal(a->kind, HS_ACTION_CONTACT);
    assert_int_equal(a->contact.kind, 0);
    refused("contact", 1, "contact needs plane, surface, point or off");
    refused("contact wall 1 2 3", 1, "unknown contact 'wall' (plane, surface, point, off)");
    refused("contact off now", 1, "contact off takes no arguments");
    refused("contact plane 0 0 1 1.9 0 0 stiffness=1 damping=1", 1, "contact plane needs 7 numbers");
    refused("contact point 0 0 1 0 0 stiffness=1 damping=1", 1, "contact point needs 6 numbers");
    refused("contact plane 0 0 0 1 0 0 0 stiffness=1 damping=1", 1, "the normal is zero");
    refused("contact point 0 0 1 0 0 0 stiffness=2e9 damping=1", 1,
            "contact: stiffness 2e9 is out of range (0..1e+09)");
    refused("contact point 0 0 1 0 0 0 stiffness=1 damping=-1", 1, "contact: damping -1 is out of range");
    refused("contact point 0 0 1 0 0 0 stiffness=1", 1, "contact needs stiffness=K (N/m) and damping=D (N s/m)");
    refused("contact point 0 0 1 0 0 200 stiffness=1 damping=1", 1, "contact point value 200 is out of range");

    a = one("load 300 0.2 0 -0.1");
    assert_int_equal(a->kind, HS_ACTION_LOAD);
    assert_true(a->mass == 300.0 && a->point[0] == 0.2 && a->point[2] == -0.1);
    a = one("load -50 0 0 0");
    assert_true(a->mass == -50.0);
    refused("load 300 0.2 0", 1, "load needs a mass (kg) and a point x y z");
    refused("load 2e5 0 0 0", 1, "load mass value 2e5 is out of range (|v| <= 100000 kg)");
    refused("load 0 0 0 0", 1, "load mass is 0");
    refused("load 1 0 nan 0", 1, "load point value 'nan' is not a number");
}

static void write_named(const char *path, const char *data)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_int_equal(fputs(data, f) >= 0, 1);
    assert_int_equal(fclose(f), 0);
}

static void test_play(void **state)
{
    (void)state;
    char dir[] = "/tmp/hs_play_XXXXXX";
    char csv[96], scn[96], text[160], msg[200];
    assert_non_null(mkdtemp(dir));
    (void)snprintf(csv, sizeof csv, "%s/motion.csv", dir);
    (void)snprintf(scn, sizeof scn, "%s/run.scn", dir);
    write_named(csv, "t,x,y,z,roll,pitch,yaw\n0.001,0,0,2.5,0,0,0\n0.011,0.01,0,2.5,0,0,-0.02\n\n"
                     "0.0105e0,1,1,1,1,1,1\n");
    /* t does not increase at line 5 */
    (void)snprintf(text, sizeof text, "play %s\n", csv);
    refused(text, 1, "does not increase");
    (void)snprintf(msg, sizeof msg, "play %s: line 5: t 0.0105 s does not increase", csv);
    assert_non_null(strstr(err.message, msg));

    write_named(csv, "t,x,y,z,roll,pitch,yaw\r\n0.001,0,0,2.5,0,0,0\n0.011,0.01,0,2.5,0,0,-0.02\n"
                     "0.0205,0.01,0.001,2.5,0,0,-0.02\n");
    /* relative to the scenario file's directory */
    write_named(scn, "play motion.csv\nmark after\n");
    assert_int_equal(hs_scenario_load(&sc, scn, &err), HS_OK);
    assert_int_equal(sc.action[0].kind, HS_ACTION_PLAY);
    assert_string_equal(sc.action[0].path, csv);
    assert_int_equal(sc.action[0].ticks, 21); /* the last row at 20.5 ms: finished at the 21st tick */
    /* the player: the play at once, what follows when it is done */
    expect_next(100, -1, HS_SCENARIO_DUE, &sc.action[0]);
    expect_next(100, -1, HS_SCENARIO_PENDING, NULL);
    expect_next(120, -1, HS_SCENARIO_PENDING, NULL);
    expect_next(121, -1, HS_SCENARIO_DUE, &sc.action[1]);

    /* streaming: first row held, linear between rows, the last row at the end */
    hs_play_t pl;
    double pose[6];
    int done = -1;
    assert_int_equal(hs_play_open(&pl, csv, &err), HS_OK);
    assert_int_equal(hs_play_pose(&pl, 0, pose, &done, &err), HS_OK);
    assert_true(pose[0] == 0.0 && pose[2] == 2.5 && done == 0);
    assert_int_equal(hs_play_pose(&pl, 6, pose, &done, &err), HS_OK); /* halfway between 1 and 11 ms */
    assert_true(fabs(pose[0] - 0.005) < 1e-15 && fabs(pose[5] + 0.01) < 1e-15 && done == 0);
    assert_int_equal(hs_play_pose(&pl, 11, pose, &done, &err), HS_OK);
    assert_true(pose[0] == 0.01 && pose[1] == 0.0 && done == 0);
    assert_int_equal(hs_play_pose(&pl, 20, pose, &done, &err), HS_OK);
    assert_true(fabs(pose[1] - 0.001 * 9.0 / 9.5) < 1e-15 && done == 0);
    assert_int_equal(hs_play_pose(&pl, 21, pose, &done, &err), HS_OK);
    assert_true(pose[1] == 0.001 && done == 1);
    hs_play_close(&pl);
    hs_play_close(&pl);

    /* bad files */
    (void)snprintf(text, sizeof text, "mark x\nplay %s/none.csv\n", dir);
    refused(text, 2, "cannot open");
    write_named(csv, "t,x,y,z\n0,0,0,0\n");
    (void)snprintf(text, sizeof text, "play %s\n", csv);
    refused(text, 1, "line 1: the header must be t,x,y,z,roll,pitch,yaw");
    write_named(csv, "t,x,y,z,roll,pitch,yaw\n");
    refused(text, 1, "no rows after the header");
    write_named(csv, "t,x,y,z,roll,pitch,yaw\n0,0,0,2.5,0,0\n");
    refused(text, 1, "line 2: expected 7 numbers t,x,y,z,roll,pitch,yaw");
    write_named(csv, "t,x,y,z,roll,pitch,yaw\n-1,0,0,2.5,0,0,0\n");
    refused(text, 1, "line 2: t -1 is out of range");
    write_named(csv, "t,x,y,z,roll,pitch,yaw\n0,0,0,9,0,0,0\n");
    refused(text, 1, "line 2: pose value 9 is out of range");
    refused("play", 1, "play needs one file name");
    assert_int_equal(hs_play_open(&pl, "/nonexistent/x.csv", &err), HS_E_IO);
    (void)unlink(csv);
    (void)unlink(scn);
    (void)rmdir(dir);
}

static void expect_next(uint64_t tick, int ctrl_state, hs_scenario_next_t want, const hs_action_t *want_action)
{
    static const hs_action_t dummy;
    const hs_action_t *a = &dummy; /* must be overwritten */
    hs_scenario_next_t got = hs_scenario_next(&sc, tick, ctrl_state, &a);
    if (got != want || a != want_action) {
        fail_msg("tick %lu: got %d (action %p), wanted %d (action %p)", (unsigned long)tick, (int)got, (const void *)a,
                 (int)want, (const void *)want_action);
    }
}

static void test_player(void **state)
{
    (void)state;
    const hs_action_t *a = sc.action;
    assert_int_equal(hs_scenario_parse(&sc, "cmd ENGAGE\nwait ready 1\ndelay 0.002\ndelay 0\nmark x\nend\ncmd STOP\n",
                                       "t.scn", &err),
                     HS_OK);
    expect_next(0, -1, HS_SCENARIO_DUE, &a[0]);    /* cmd at once */
    expect_next(0, -1, HS_SCENARIO_PENDING, NULL); /* wait: no state yet */
    expect_next(1, SP_STATE_ENGAGING, HS_SCENARIO_PENDING, NULL);
    expect_next(5, SP_STATE_READY, HS_SCENARIO_DUE, &a[1]);    /* reached before its deadline (1000) */
    expect_next(5, SP_STATE_READY, HS_SCENARIO_PENDING, NULL); /* delay from tick 5: due at 7 */
    expect_next(6, SP_STATE_READY, HS_SCENARIO_PENDING, NULL);
    expect_next(7, SP_STATE_RUNNING, HS_SCENARIO_DUE, &a[2]);
    expect_next(7, SP_STATE_RUNNING, HS_SCENARIO_DUE, &a[3]); /* delay 0: at once */
    expect_next(7, SP_STATE_RUNNING, HS_SCENARIO_DUE, &a[4]);
    expect_next(7, SP_STATE_RUNNING, HS_SCENARIO_END, &a[5]); /* end, and it stays there */
    expect_next(8, SP_STATE_RUNNING, HS_SCENARIO_END, &a[5]);
    assert_int_equal(sc.pc, 5);

    /* a wait that times out: first seen at tick 10, deadline 13 */
    assert_int_equal(hs_scenario_parse(&sc, "wait ready 0.003\ncmd STOP\n", "t.scn", &err), HS_OK);
    expect_next(10, SP_STATE_ENGAGING, HS_SCENARIO_PENDING, NULL);
    expect_next(12, SP_STATE_ENGAGING, HS_SCENARIO_PENDING, NULL);
    expect_next(13, SP_STATE_ENGAGING, HS_SCENARIO_TIMEOUT, &a[0]);
    expect_next(14, SP_STATE_READY, HS_SCENARIO_DUE, &a[0]); /* the player stayed on the wait */

    /* the end of a scenario without `end`; rewind plays it again */
    assert_int_equal(hs_scenario_parse(&sc, "silence 2\nunsilence 2\n", "t.scn", &err), HS_OK);
    expect_next(0, -1, HS_SCENARIO_DUE, &a[0]);
    expect_next(0, -1, HS_SCENARIO_DUE, &a[1]);
    expect_next(0, -1, HS_SCENARIO_END, NULL);
    expect_next(1, -1, HS_SCENARIO_END, NULL);
    hs_scenario_rewind(&sc);
    expect_next(2, -1, HS_SCENARIO_DUE, &a[0]);

    /* a delay is armed when first seen, not when parsed */
    assert_int_equal(hs_scenario_parse(&sc, "delay 1\nend\n", "t.scn", &err), HS_OK);
    expect_next(5000, -1, HS_SCENARIO_PENDING, NULL);
    expect_next(5999, -1, HS_SCENARIO_PENDING, NULL);
    expect_next(6000, -1, HS_SCENARIO_DUE, &a[0]);
    expect_next(6000, -1, HS_SCENARIO_END, &a[1]);

    const hs_action_t *none = NULL;
    assert_int_equal(hs_scenario_next(NULL, 0, -1, &none), HS_SCENARIO_END);
    assert_null(none);
    assert_int_equal(hs_scenario_next(&sc, 0, -1, NULL), HS_SCENARIO_END);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cmd_names),
        cmocka_unit_test(test_force_actions),
        cmocka_unit_test(test_cmd_arguments),
        cmocka_unit_test(test_target),
        cmocka_unit_test(test_delay_and_wait),
        cmocka_unit_test(test_drive_actions),
        cmocka_unit_test(test_inject),
        cmocka_unit_test(test_mark_and_end),
        cmocka_unit_test(test_lines_and_comments),
        cmocka_unit_test(test_malformed_lines),
        cmocka_unit_test(test_overlong_and_empty),
        cmocka_unit_test(test_action_limit),
        cmocka_unit_test(test_load_file),
        cmocka_unit_test(test_player),
        cmocka_unit_test(test_contact_surface),
        cmocka_unit_test(test_frame_action),
        cmocka_unit_test(test_wrench_contact_load),
        cmocka_unit_test(test_play),
    };
    return cmocka_run_group_tests_name("scenario", tests, NULL, NULL);
}
