/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target: random bytes as a scenario (host_sim/src/scenario/scenario.c),
 * through both readers: hs_scenario_parse on the text up to its first NUL,
 * and hs_scenario_load on all the bytes written to a file (NULs, overlong
 * lines and a last line without '\n' included).
 *
 * Whatever the text, nothing may crash, read out of bounds, overflow or
 * leak (ASan + UBSan + LeakSanitizer: a play file opened and not closed is
 * a leak), and each reader either accepts it (HS_OK: 1..MAX actions, each
 * with its fields in their documented ranges) or refuses it with
 * HS_E_SYNTAX, no actions, and a NUL-terminated message naming the text
 * and, when it is one line's fault, that line. Both readers must agree on
 * text without a NUL (status, line, number of actions). An accepted
 * scenario is then played to its end, handing every action over exactly
 * once and in order.
 * Build and run: scripts/fuzz.sh [SECONDS]
 */
#define _POSIX_C_SOURCE 200809L
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "hs/scenario.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define MAX_TEXT 65536u

static char dir[64];
static const char scn_file[] = "fuzz.scenario";

static void remove_dir(void)
{
    (void)unlink(scn_file);
    (void)rmdir(dir);
}

/* The file hs_scenario_load reads, in a directory of its own that is also
 * the working directory: a relative `play` file is then looked for in the
 * same place by both readers (the file's directory for hs_scenario_load,
 * the working directory for hs_scenario_parse), so they must agree. The
 * fuzzer is given absolute paths (scripts/fuzz.sh). */
static const char *file_name(void)
{
    if (dir[0] == '\0') {
        /* $TMPDIR, else /dev/shm (memory: a file on disk makes it 10 times slower), else /tmp */
        const char *tmp = getenv("TMPDIR");
        const char *where[3] = {(tmp != NULL && strlen(tmp) < 32) ? tmp : NULL, "/dev/shm", "/tmp"};
        int made = 0;
        for (int i = 0; i < 3 && !made; i++) {
            if (where[i] != NULL) {
                (void)snprintf(dir, sizeof dir, "%s/fuzz_scenario_XXXXXX", where[i]);
                made = mkdtemp(dir) != NULL;
            }
        }
        if (!made || chdir(dir) != 0) {
            __builtin_trap();
        }
        (void)atexit(remove_dir);
    }
    return scn_file;
}

/* The counted lines of `text` (as the parser counts them: a last line without '\n' counts). */
static int lines_of(const char *text)
{
    int n = 0;
    for (const char *p = text; *p != '\0'; p++) {
        if (*p == '\n' || p[1] == '\0') {
            n++;
        }
    }
    return n;
}

static void check_result(const hs_scenario_t *sc, hs_status_t st, const hs_scenario_error_t *err, const char *name,
                         int max_line)
{
    if (st == HS_OK) {
        if (sc->n < 1 || sc->n > HS_SCENARIO_MAX_ACTIONS || sc->pc != 0) {
            __builtin_trap();
        }
        for (int i = 0; i < sc->n; i++) {
            const hs_action_t *a = &sc->action[i];
            if ((int)a->kind < (int)HS_ACTION_CMD || (int)a->kind > (int)HS_ACTION_FTSENSOR || a->line < 1 ||
                a->line > max_line || (i > 0 && a->line <= sc->action[i - 1].line) ||
                memchr(a->text, '\0', sizeof a->text) == NULL || memchr(a->path, '\0', sizeof a->path) == NULL) {
                __builtin_trap();
            }
            if ((a->kind == HS_ACTION_SILENCE || a->kind == HS_ACTION_UNSILENCE || a->kind == HS_ACTION_FAULT) &&
                (a->leg < 0 || a->leg > 5)) {
                __builtin_trap();
            }
            if (a->kind == HS_ACTION_FAULT && (a->bits < 1u || a->bits > 0xFFu)) {
                __builtin_trap();
            }
            if (a->kind == HS_ACTION_FORCE &&
                (a->force.mask > 63u ||
                 (a->cmd.command != 0u && a->cmd.command != SP_CMD_FORCE && a->cmd.command != SP_CMD_GUIDE))) {
                __builtin_trap();
            }
            if (a->kind == HS_ACTION_FTSENSOR && a->bits > 1u) {
                __builtin_trap();
            }
            if (a->kind == HS_ACTION_INJECT) {
                const hs_scenario_inject_t *in = &a->inject;
                if (in->what < HS_INJECT_FRAMES || in->what > HS_INJECT_CLEAR || in->leg < 0 || in->leg > 5 ||
                    !(in->rate >= 0.0 && in->rate <= 1.0) || in->id_lo > in->id_hi || in->id_hi > 0x7FFu ||
                    in->bits > 0xFFu || (in->what == HS_INJECT_FRAMES && in->rate == 0.0 && in->count == 0u) ||
                    (in->what == HS_INJECT_FRAMES && in->fault == 1 && in->delay == 0u)) {
                    __builtin_trap();
                }
            }
        }
        return;
    }
    size_t len = strnlen(err->message, sizeof err->message);
    if (st != HS_E_SYNTAX || sc->n != 0 || len == 0u || len >= sizeof err->message || err->line < 0 ||
        err->line > max_line || strncmp(err->message, name, strlen(name)) != 0) {
        __builtin_trap();
    }
}

static void play(hs_scenario_t *sc)
{
    uint64_t tick = 0;
    int handed = 0;
    int state = -1;
    /* every round hands an action over or moves time to where one is due: at most 2 rounds an action */
    for (int round = 0; round < 2 * HS_SCENARIO_MAX_ACTIONS + 2; round++) {
        const hs_action_t *a = NULL;
        hs_scenario_next_t r = hs_scenario_next(sc, tick, state, &a);
        if (r == HS_SCENARIO_END) {
            if (a != NULL ? (a->kind != HS_ACTION_END || a != &sc->action[handed]) : handed != sc->n) {
                __builtin_trap();
            }
            return;
        }
        if (r == HS_SCENARIO_DUE) {
            if (a != &sc->action[handed]) {
                __builtin_trap();
            }
            handed++;
            continue;
        }
        if (r != HS_SCENARIO_PENDING || a != NULL) {
            __builtin_trap(); /* no TIMEOUT: every wait is given its state */
        }
        const hs_action_t *next = &sc->action[handed];
        state = (next->kind == HS_ACTION_WAIT) ? (int)next->state : -1;
        uint64_t to = sc->until > sc->busy ? sc->until : sc->busy;
        tick = to > tick ? to : tick;
    }
    __builtin_trap();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static hs_scenario_t sc, sc2;
    static char text[MAX_TEXT + 1];
    hs_scenario_error_t err, err2;
    if (size > MAX_TEXT) {
        return 0;
    }
    memcpy(text, data, size);
    text[size] = '\0';
    const char *name = file_name();

    /* the file first: a `play` of the scenario's own file then reads the same bytes in both */
    FILE *f = fopen(name, "wb");
    if (f == NULL || fwrite(data, 1, size, f) != size || fclose(f) != 0) {
        __builtin_trap();
    }
    memset(&err, 0x55, sizeof err); /* a message the parser forgets to write is caught */
    hs_status_t st = hs_scenario_parse(&sc, text, name, &err);
    check_result(&sc, st, &err, name, lines_of(text));

    memset(&err2, 0x55, sizeof err2);
    hs_status_t st2 = hs_scenario_load(&sc2, name, &err2);
    int lines = 1;
    for (size_t i = 0; i < size; i++) {
        lines += data[i] == '\n';
    }
    check_result(&sc2, st2, &err2, name, lines);

    if (memchr(data, '\0', size) == NULL && (st != st2 || sc.n != sc2.n || (st != HS_OK && err.line != err2.line))) {
        __builtin_trap();
    }
    if (st == HS_OK) {
        play(&sc);
    }
    return 0;
}
