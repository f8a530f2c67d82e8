/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_replay - the controller offline on a recorded lockstep CAN log: what
 * the plant sent (feedback, SYNC, operator commands) goes through the
 * portable node (sp/link/node.h) as sp_controller would have received it, and
 * the controller's external wrench estimate is printed for every tick at
 * full precision (Q8: 1/256 N, N m), where CTRL_WRENCH carries it on even
 * ticks in 0.25 N steps.
 *
 *   sp_replay LOG [--no-feedforward] > wrench.csv
 *
 * LOG is a candump -L log (stewart demo's main.log): vcan0 the ops bus,
 * vcan1 and vcan2 the axis buses. Output: one CSV row per tick, "tick,
 * state,valid,fx,fy,fz,mx,my,mz" (N, N m, base frame, moment about o').
 * The estimate does not act on the loop (it is an output only), so for the
 * log's controller build the replay reproduces the logged estimate exactly,
 * and a changed estimator can be judged on the same motion without the
 * closed loop (the wrench's `stewart` analysis takes the truth from the
 * run's --truth CSV). Exit status: 0 done, 1 I/O error, 2 usage.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sp/link/node.h"

static void usage(void)
{
    fprintf(stderr, "usage: sp_replay LOG [--no-feedforward] > wrench.csv\n");
}

static int hex_nibble(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

/* One candump -L line "(time) vcanN ID#DATA" or "(time) vcanN ID##FDATA"
 * into *f; 0 when it is not a frame on vcan0..2. */
static int parse_line(const char *line, sp_can_frame_t *f)
{
    const char *p = strchr(line, ')');
    char *end;
    unsigned long id;
    if (p == NULL) {
        return 0;
    }
    p++;
    while (*p == ' ') {
        p++;
    }
    if (strncmp(p, "vcan", 4) != 0 || p[4] < '0' || p[4] > '2' || p[5] != ' ') {
        return 0;
    }
    memset(f, 0, sizeof *f);
    f->bus = (uint8_t)(p[4] - '0');
    p += 6;
    id = strtoul(p, &end, 16);
    if (end == p || *end != '#' || id > 0x7FFu) {
        return 0;
    }
    f->id = (uint32_t)id;
    p = end + 1;
    if (*p == '#') {
        int fl = hex_nibble(p[1]);
        if (fl < 0) {
            return 0;
        }
        f->flags = (uint8_t)(SP_CAN_FLAG_FD | (((unsigned)fl & 1u) ? SP_CAN_FLAG_BRS : 0u));
        p += 2;
    }
    while (f->len < SP_CAN_MAX_DATA) {
        int hi = hex_nibble(p[0]);
        int lo = (hi < 0) ? -1 : hex_nibble(p[1]);
        if (hi < 0 || lo < 0) {
            break;
        }
        f->data[f->len++] = (uint8_t)(hi * 16 + lo);
        p += 2;
    }
    return 1;
}

/* What sp_controller (lockstep) listens to on each bus. */
static int addressed_to_controller(const sp_can_frame_t *f)
{
    if (f->bus == SP_BUS_OPS) {
        return f->id == SP_ID_OP_COMMAND || f->id == SP_ID_OP_TARGET_POSE;
    }
    return f->id == SP_ID_SYNC || f->id == 0x31u || f->id == 0x32u || f->id == 0x33u;
}

int main(int argc, char **argv)
{
    static sp_node_config_t cfg;
    static sp_node_t node;
    static char line[512];
    const char *path = NULL;
    int ff = 1;
    FILE *in;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--no-feedforward") == 0) {
            ff = 0;
        } else if (path == NULL && argv[i][0] != '-') {
            path = argv[i];
        } else {
            usage();
            return 2;
        }
    }
    if (path == NULL) {
        usage();
        return 2;
    }
    if ((in = fopen(path, "r")) == NULL) {
        perror(path);
        return 1;
    }
    if (sp_node_default_config(&cfg, &sp_platform_default) != SP_OK) {
        fprintf(stderr, "sp_replay: the default platform is not usable\n");
        fclose(in);
        return 1;
    }
    cfg.sync_master = 0u;
    cfg.ctrl.force_feedforward = (uint8_t)ff;
    cfg.ctrl.estop = sp_estop_default; /* as sp_controller */
    (void)sp_node_init(&node, &cfg);
    printf("tick,state,valid,fx,fy,fz,mx,my,mz\n");
    while (fgets(line, (int)sizeof line, in) != NULL) {
        sp_can_frame_t f;
        uint32_t t;
        if (!parse_line(line, &f) || !addressed_to_controller(&f)) {
            continue;
        }
        (void)sp_node_receive(&node, &f, NULL);
        if (sp_node_cycle_ready(&node, &t)) {
            sp_can_frame_t tx[SP_NODE_MAX_TX];
            uint32_t n = 0;
            (void)sp_node_tick(&cfg, &node, tx, &n);
            int32_t w[6];
            (void)sp_ctrl_wrench_at_tool(&node.ctrl, node.out.wrench, w); /* as CTRL_WRENCH reports it */
            printf("%lu,%s,%u", (unsigned long)t, sp_state_name(node.out.state), (unsigned)node.out.wrench_valid);
            for (int k = 0; k < 6; k++) {
                printf(",%.4f", (double)w[k] / 256.0);
            }
            printf("\n");
        }
    }
    if (ferror(in)) {
        perror(path);
        fclose(in);
        return 1;
    }
    fclose(in);
    return 0;
}
