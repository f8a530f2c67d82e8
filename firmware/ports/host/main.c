/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_controller - the firmware's controller on a Linux host: the portable
 * node (sp/link/node.h) on SocketCAN, at 1 kHz.
 *
 *   sp_controller [--ops IF] [--axis-a IF] [--axis-b IF] [--lockstep]
 *                 [--ticks N] [--no-feedforward] [--timeout-ms MS] [--timing]
 *                 [--feedback-timeout TICKS] [--operator-timeout TICKS]
 *                 [--operator-reaction stop|park] [--wrench-source cylinders|sensor] [--canopen]
 *                 [--canopen-timeout-ms MS] [--canopen-force-ff] [--canopen-sync-divider N] [--cia402]
 *                 [--key FILE] [--session N] [--stats S]
 *
 * --key FILE (else the file the environment variable STEWART_KEY names):
 * the machine key of command authentication (docs/explanation/security.md; 32 hex
 * digits, mode 600). Without one the controller refuses every
 * authenticated command (reason no-key; STOP, PARK and ESTOP still work)
 * and says so at start. --session N sets the authentication session (for
 * deterministic lockstep runs); by default it is drawn from the kernel's
 * random source (getrandom) at start.
 *
 * --canopen: the drives are CiA 408 nodes configured and driven by the
 * CANopen master (sp/canopen/canopen_link.h, docs/reference/canopen.md) instead of the native
 * drive frames: as the platform config's drives section says (then
 * --canopen is the default), else the built-in layout: nodes 1-3 on axis_a
 * and 4-6 on axis_b, 1 um per count, count 0 at the park pose;
 * --canopen-force-ff (implies --canopen) maps the force feed-forward into
 * every drive's RPDO1: CiA 408's vendor object 0x2120 (the simulated drive
 * has it; real ones may not), CiA 402's torque/force offset 0x60B2 (per
 * mille of a rated force of HOST_402_RATED_FORCE_N, the simulated drive's
 * 0x6076); --canopen-sync-divider N (1..10, implies --canopen) sends SYNC
 * and the PDOs every N ticks (the layout of two classic buses at 1 Mbit/s
 * with pressures needs 3, docs/reference/canopen.md), the drives' watchdog 3N ms;
 * --cia402 (implies --canopen) drives every leg as a CiA 402 drive in cyclic
 * synchronous position mode (no pressure PDO); the config's drives
 * section may say so per leg.
 * --canopen-timeout-ms relaxes the drives' setpoint watchdog (RPDO event
 * timer, default 3 ms), the master's TPDO supervision (10 ms) and its
 * heartbeat consumer (50 ms) to MS, for hosts that miss 1 ms deadlines
 * (user-mode Linux in real time), as --feedback-timeout does. With
 * --lockstep the plant's SYNC(t) on the axis buses (the DBC's, 0x010) is the
 * clock and goes to the node; every other frame of those buses to the
 * master, which still produces the CANopen SYNC (0x080) for its drives.
 *
 * Real-time mode (default): the controller is the cycle master; an
 * absolute-deadline clock_nanosleep paces the ticks; deadline misses are
 * counted and reported. Lockstep mode: the plant sends SYNC and sets the
 * pace; each tick runs when SYNC has arrived on both axis buses, which makes
 * runs deterministic. Ends after N ticks (0: until SIGINT/SIGTERM) or when
 * the plant has been silent for --timeout-ms in lockstep (before its first
 * SYNC: at least FIRST_SYNC_TIMEOUT_MS, the plant's start-up on a loaded
 * machine); prints a summary.
 * --feedback-timeout relaxes the drive supervision (default 2 ticks: a
 * silent drive faults the controller on the third tick); only for hosts
 * that cannot keep 1 ms deadlines, such as user-mode Linux in real time.
 * --operator-timeout (default 200 ticks, 0: off) and --operator-reaction
 * (default stop) set the operator link's supervision: once an operator
 * heartbeat has been heard, a silent operator while RUNNING latches the
 * operator-silent fault and stops (or parks) the platform.
 * --wrench-source chooses force control's wrench (default: the platform
 * config's force_sensor.wrench_source): the cylinders' estimate or the
 * force/torque sensor's FT_SENSOR frames on axis_b (mounted as the config
 * says).
 * --stats S (1..3600, real-time mode): every S seconds of wall clock a line
 * `sp_controller stats: ticks N, deadline misses M, worst late X ms` on
 * stderr (stewart sim reports it while it runs). A deadline miss is a tick
 * that could not run in its 1 ms period (woken more than a period late:
 * each period passed is one miss, and the ticks resume from now).
 * The compute time of each tick is measured in real-time mode, and in
 * lockstep only with --timing (two clock reads per tick, which cost a system
 * call each inside user-mode Linux).
 * Exit status: 0 normal end, 1 I/O or set-up error, 2 usage.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "host_os.h"
#include "socketcan.h"
#include "sp/canopen/canopen_link.h"
#include "sp/model/kinematics.h"
#include "sp/link/node.h"

static void usage(void)
{
    fprintf(stderr, "usage: sp_controller [--ops IF] [--axis-a IF] [--axis-b IF] [--lockstep] [--ticks N]\n"
                    "                     [--no-feedforward] [--timeout-ms MS] [--timing] [--feedback-timeout TICKS]\n"
                    "                     [--operator-timeout TICKS] [--operator-reaction stop|park]\n"
                    "                     [--wrench-source cylinders|sensor] [--canopen] [--canopen-timeout-ms MS]\n"
                    "                     [--canopen-force-ff] [--canopen-sync-divider N] [--cia402]\n"
                    "                     [--key FILE] [--session N] [--stats S]\n");
}

typedef struct {
    uint64_t ticks;
    uint64_t misses;
    int64_t worst_late_ns; /* the latest wake-up after a tick's start, ns */
    int64_t worst_ns;
    int64_t sum_ns;
    uint64_t tx_busy;
    uint64_t timed;
} run_stats_t;

/* --canopen: the drives are CiA 408 nodes 1-3 (axis_a) and 4-6 (axis_b)
 * behind the CANopen master (sp/canopen/canopen_link.h); the node's own axis
 * frames are not sent. */
typedef struct {
    int on;
    sp_co_link_cfg_t link;
    sp_co_master_t m;
    sp_co_master_input_t in;
    sp_co_master_output_t out;
    uint32_t now_ms; /* control ticks run: the master's clock */
} co_t;

static co_t co;

/* Lockstep: the silence allowed before the plant's first SYNC, ms (the
 * plant starts after this process and may take seconds on a loaded machine). */
#define FIRST_SYNC_TIMEOUT_MS 10000L

/* The built-in CiA 402 layout's rated force along each leg, N (the
 * simulated CiA 402 drive's 0x6076, 10 kN as mN): 0x60B2's 1000 per mille. */
#define HOST_402_RATED_FORCE_N 10000u

static int co_setup(uint32_t timeout_ms, int force_ff, int divider, int cia402)
{
    sp_ik_t ik;
    if (sp_co_layout_default.present) { /* the platform config's drives section */
        if (sp_co_link_cfg_from_layout(&co.link, &sp_co_layout_default, &sp_platform_default) != SP_OK) {
            return -1;
        }
    } else if (sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik) != SP_OK ||
               sp_co_link_cfg_default(&co.link, &sp_platform_default, ik.length) != SP_OK) {
        return -1;
    } else { /* the built-in layout: the master's heartbeat period and node id from the config */
        co.link.master.master_heartbeat_ms = sp_co_layout_default.master.master_heartbeat_ms;
        co.link.master.master_node_id = sp_co_layout_default.master.master_node_id;
    }
    if (force_ff) {
        for (uint8_t k = 0; k < co.link.master.n_nodes; k++) {
            co.link.master.node[k].force_ff = 1u;
        }
    }
    if (cia402) { /* CiA 402 cyclic synchronous position: no chamber pressures; the force as 0x60B2 */
        for (uint8_t k = 0; k < co.link.master.n_nodes; k++) {
            co.link.master.node[k].profile = (uint8_t)SP_CO_PROFILE_402;
        }
        for (uint8_t i = 0; i < SP_LEGS; i++) {
            co.link.scaling[i].rated_force_n = HOST_402_RATED_FORCE_N;
            if (sp_co_scaling_prepare(&co.link.scaling[i]) != SP_OK) {
                return -1;
            }
        }
        co.link.master.pressure_feedback = 0u;
    }
    if (divider > 0) { /* SYNC every `divider` ticks: the drives' watchdog 3 periods, the TPDO supervision 3 + 5 ms */
        co.link.master.sync_divider = (uint8_t)divider;
        co.link.master.setpoint_timeout_ms = (uint16_t)(3 * divider);
        co.link.master.pdo_timeout_ms = (uint16_t)(3 * divider + 5);
    }
    if (timeout_ms > 0u) { /* relaxed supervision for hosts that miss 1 ms deadlines */
        co.link.master.setpoint_timeout_ms = (uint16_t)timeout_ms;
        co.link.master.pdo_timeout_ms = (uint16_t)timeout_ms;
        co.link.master.heartbeat_timeout_ms = (uint16_t)(timeout_ms > 50u ? timeout_ms : 50u);
    }
    if (sp_co_link_cfg_check(&co.link) != SP_OK || sp_co_master_init(&co.m) != SP_OK ||
        sp_co_master_start(&co.m, &co.link.master, 0u) != SP_OK) {
        return -1;
    }
    co.on = 1;
    return 0;
}

static void drain(sp_can_port_t *port, sp_node_t *node)
{
    sp_can_frame_t rx[32];
    for (int rounds = 0; rounds < 64; rounds++) {
        uint32_t got = 0;
        (void)port->receive(port->ctx, rx, 32u, &got);
        for (uint32_t k = 0; k < got; k++) {
            /* in lockstep the plant's SYNC(t) (the clock) goes to the node, and so does the force/torque
             * sensor's FT_SENSOR (axis_b); the rest of a drive bus to the master */
            if (co.on && rx[k].bus != SP_BUS_OPS && rx[k].id != SP_ID_SYNC && rx[k].id != SP_ID_FT_SENSOR) {
                (void)sp_co_master_receive(&co.m, &co.link.master, &rx[k], co.now_ms);
            } else {
                (void)sp_node_receive(node, &rx[k], NULL);
            }
        }
        if (got < 32u) {
            break;
        }
    }
}

static void tick(sp_can_port_t *port, sp_node_config_t *cfg, sp_node_t *node, run_stats_t *rs, int timing)
{
    sp_can_frame_t tx[SP_NODE_MAX_TX];
    uint32_t n = 0, sent = 0;
    int64_t t0 = timing ? sp_host_now_ns() : 0;
    if (co.on) {
        co.now_ms++;
        (void)sp_co_link_feedback(&co.m, &co.link, node->in.drive);
        node->in.setpoints_idle = sp_co_link_setpoints_idle(&co.link, &co.m); /* setpoints on SYNC ticks only */
        node->drives_starting =
            (uint8_t)(co.out.all_running ? 0u : 1u); /* the master's last step: ENGAGE refused until all run */
    }
    (void)sp_node_tick(cfg, node, tx, &n);
    if (co.on) {
        /* only the ops frames of the node; the drives get the master's */
        uint32_t k = 0;
        for (uint32_t i = 0; i < n; i++) {
            if (tx[i].bus == SP_BUS_OPS) {
                tx[k++] = tx[i];
            }
        }
        n = k;
        (void)sp_co_link_input_due(&co.link, &co.m, &node->out, co.now_ms, &co.in);
        (void)sp_co_master_step(&co.m, &co.link.master, &co.in, &co.out);
        uint32_t co_sent = 0;
        if (port->send(port->ctx, co.out.tx, co.out.n_tx, &co_sent) != SP_OK || co_sent != co.out.n_tx) {
            rs->tx_busy++;
        }
    }
    if (timing) {
        int64_t dt = sp_host_now_ns() - t0;
        rs->sum_ns += dt;
        rs->timed++;
        if (dt > rs->worst_ns) {
            rs->worst_ns = dt;
        }
    }
    if (port->send(port->ctx, tx, n, &sent) != SP_OK || sent != n) {
        rs->tx_busy++;
    }
    rs->ticks++;
}

/* The command line's options (the defaults in main). */
typedef struct {
    const char *ifs[SP_CAN_BUSES];
    int lockstep, ff, timing, canopen, co_force_ff, co_cia402;
    int co_divider;
    long co_sp_timeout;
    long fb_timeout;
    long op_timeout;
    int op_park;
    int wrench_source;
    unsigned long long max_ticks;
    long timeout_ms;
    const char *key_path;
    int session_given;
    uint32_t session;
    long stats_s; /* --stats: seconds between stats lines (0: none) */
} options_t;

/* An option without a value: 1 when a is one (set in *o), else 0. */
static int parse_flag(const char *a, options_t *o)
{
    if (strcmp(a, "--lockstep") == 0) {
        o->lockstep = 1;
    } else if (strcmp(a, "--timing") == 0) {
        o->timing = 1;
    } else if (strcmp(a, "--no-feedforward") == 0) {
        o->ff = 0;
    } else if (strcmp(a, "--canopen") == 0) {
        o->canopen = 1;
    } else if (strcmp(a, "--canopen-force-ff") == 0) {
        o->canopen = 1, o->co_force_ff = 1;
    } else if (strcmp(a, "--cia402") == 0) {
        o->canopen = 1, o->co_cia402 = 1;
    } else {
        return 0;
    }
    return 1;
}

/* v as a decimal long into *x: 0 when characters follow the number. */
static int parse_long(const char *v, long *x)
{
    char *end;
    *x = strtol(v, &end, 10);
    return *end == '\0';
}

/* An option a with its value v: 1 when a is one and v is valid for it
 * (set in *o), else 0. */
static int parse_value(const char *a, const char *v, options_t *o)
{
    char *end;
    long x;
    if (strcmp(a, "--canopen-sync-divider") == 0) {
        int ok = parse_long(v, &x);
        o->co_divider = (int)x, o->canopen = 1;
        return ok && o->co_divider >= 1 && o->co_divider <= 10;
    }
    if (strcmp(a, "--canopen-timeout-ms") == 0) {
        return parse_long(v, &o->co_sp_timeout) && o->co_sp_timeout >= 1 && o->co_sp_timeout <= 60000;
    }
    for (unsigned b = 0; b < SP_CAN_BUSES; b++) {
        static const char *const names[SP_CAN_BUSES] = {"--ops", "--axis-a", "--axis-b"};
        if (strcmp(a, names[b]) == 0) {
            o->ifs[b] = v;
            return 1;
        }
    }
    if (strcmp(a, "--ticks") == 0) {
        o->max_ticks = strtoull(v, &end, 10);
        return *end == '\0';
    }
    if (strcmp(a, "--feedback-timeout") == 0) {
        return parse_long(v, &o->fb_timeout) && o->fb_timeout >= 1 && o->fb_timeout <= 1000;
    }
    if (strcmp(a, "--operator-timeout") == 0) {
        return parse_long(v, &o->op_timeout) && o->op_timeout >= 0 && o->op_timeout <= 600000;
    }
    if (strcmp(a, "--operator-reaction") == 0) {
        o->op_park = (strcmp(v, "park") == 0);
        return o->op_park || strcmp(v, "stop") == 0;
    }
    if (strcmp(a, "--wrench-source") == 0) {
        o->wrench_source = (strcmp(v, "sensor") == 0) ? (int)SP_WRENCH_SENSOR : (int)SP_WRENCH_CYLINDERS;
        return strcmp(v, "sensor") == 0 || strcmp(v, "cylinders") == 0;
    }
    if (strcmp(a, "--key") == 0) {
        o->key_path = v;
        return 1;
    }
    if (strcmp(a, "--session") == 0) {
        unsigned long long s = strtoull(v, &end, 0);
        o->session = (uint32_t)s, o->session_given = 1;
        return *end == '\0' && s <= UINT32_MAX;
    }
    if (strcmp(a, "--timeout-ms") == 0) {
        return parse_long(v, &o->timeout_ms) && o->timeout_ms > 0;
    }
    if (strcmp(a, "--stats") == 0) {
        return parse_long(v, &o->stats_s) && o->stats_s >= 1 && o->stats_s <= 3600;
    }
    return 0;
}

/* The command line into *o: 0, or 2 (a usage error, usage printed). */
static int parse_args(int argc, char **argv, options_t *o)
{
    for (int i = 1; i < argc; i++) {
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        if (parse_flag(argv[i], o)) {
            continue;
        }
        if (v == NULL || !parse_value(argv[i], v, o)) {
            usage();
            return 2;
        }
        i++;
    }
    return 0;
}

/* The machine key (cfg->auth_key set when there is one) and the
 * authentication session: 0, or 1 (said why). */
static int setup_auth(const options_t *o, sp_node_config_t *cfg, sp_auth_key_t *key)
{
    const char *key_used = NULL;
    char key_err[256];
    uint32_t session = o->session;
    int have_key = sp_host_load_key(o->key_path, key->k, &key_used, key_err, sizeof key_err);
    if (have_key < 0) {
        fprintf(stderr, "sp_controller: %s\n", key_err);
        return 1;
    }
    if (!o->session_given && sp_host_random_u32(&session) != 0) {
        fprintf(stderr, "sp_controller: no random session value (getrandom: %s)\n", strerror(errno));
        return 1;
    }
    if (have_key) {
        cfg->auth_key = key;
        cfg->auth_session = session;
        printf("sp_controller: machine key from %s, session 0x%08x\n", key_used, (unsigned)session);
    } else {
        printf("sp_controller: no machine key (--key FILE or STEWART_KEY): motion commands will be refused "
               "(no-key); STOP, PARK and ESTOP work\n");
    }
    fflush(stdout);
    return 0;
}

/* The CANopen master (--canopen) and the node's configuration from the
 * options: 0, or 1 (said why). */
static int setup(const options_t *o, sp_node_config_t *cfg, sp_auth_key_t *key)
{
    if (o->canopen && co_setup((uint32_t)o->co_sp_timeout, o->co_force_ff, o->co_divider, o->co_cia402) != 0) {
        fprintf(stderr, "sp_controller: the CANopen master's configuration is not usable\n");
        return 1;
    }
    if (co.on && !sp_co_layout_default.present) {
        /* the built-in layout's bus load is not checked at build time as a config layout's is: say how */
        const unsigned div = co.link.master.sync_divider;
        fprintf(stderr,
                "sp_controller: CANopen built-in layout (the config has no drives section), SYNC every %u ms; "
                "its load on a real bus: stewart busload --builtin %s --sync-divider %u%s\n",
                div, o->co_cia402 ? "cia402" : "cia408", div, o->co_force_ff ? " --force-ff" : "");
    }
    if (sp_node_default_config(cfg, &sp_platform_default) != SP_OK) {
        fprintf(stderr, "sp_controller: the default platform is not usable\n");
        return 1;
    }
    cfg->sync_master = (uint8_t)(o->lockstep ? 0 : 1);
    cfg->port = SP_PORT_HOST;
    cfg->ctrl.force_feedforward = (uint8_t)o->ff;
    cfg->ctrl.estop = sp_estop_default; /* the config's ESTOP reaction */
    if (o->fb_timeout > 0) {
        cfg->ctrl.feedback_timeout_ticks = (uint32_t)o->fb_timeout;
    }
    if (co.on && sp_co_link_ctrl_config(&co.link, &cfg->ctrl) != SP_OK) {
        /* CANopen feedback comes every sync_divider ticks */
        fprintf(stderr, "sp_controller: the CANopen layout's SYNC divider is 0\n");
        return 1;
    }
    if (o->op_timeout >= 0) {
        cfg->ctrl.operator_timeout_ticks = (uint32_t)o->op_timeout;
    }
    cfg->ctrl.operator_park = (uint8_t)o->op_park;
    (void)sp_ctrl_set_wrench_source(&cfg->ctrl,
                                    (o->wrench_source >= 0) ? (uint8_t)o->wrench_source : sp_wrench_source_default,
                                    &sp_ft_mount_default); /* the config's source was validated when generated */
    cfg->ctrl.frames = sp_frame_slots_default;             /* the config's named frames */
    return setup_auth(o, cfg, key);
}

/* The frames the controller listens to on each bus. */
static void bus_filters(const options_t *o, sp_socketcan_bus_cfg_t bc[SP_CAN_BUSES])
{
    memset(bc, 0, SP_CAN_BUSES * sizeof bc[0]);
    bc[SP_BUS_OPS] = (sp_socketcan_bus_cfg_t){o->ifs[0],
                                              {SP_ID_OP_COMMAND, SP_ID_OP_TARGET_POSE, SP_ID_OP_HEARTBEAT,
                                               SP_ID_OP_FORCE, SP_ID_OP_FORCE_PARAMS, SP_ID_OP_FRAME, SP_ID_OP_REACH},
                                              7u};
    for (int b = 1; b <= 2; b++) {
        bc[b] = (sp_socketcan_bus_cfg_t){o->ifs[b], {SP_ID_SYNC, 0x31u, 0x32u, 0x33u}, o->lockstep ? 4u : 3u};
        if (!o->lockstep) { /* we are the cycle master: only feedback */
            bc[b].rx_ids[0] = 0x31u, bc[b].rx_ids[1] = 0x32u, bc[b].rx_ids[2] = 0x33u;
        }
        if (o->canopen) { /* per node: EMCY, TPDO1, TPDO2, SDO answers, heartbeat (15 of 16 filters) */
            static const uint32_t bases[] = {SP_CO_COB_EMCY, SP_CO_COB_TPDO1, SP_CO_COB_TPDO2, SP_CO_COB_SDO_TX,
                                             SP_CO_COB_HEARTBEAT};
            bc[b].n_rx_ids = 0u;
            if (o->lockstep) {
                bc[b].rx_ids[bc[b].n_rx_ids++] = SP_ID_SYNC; /* the plant's clock */
            }
            for (uint32_t k = 0; k < co.link.master.n_nodes; k++) {
                if (co.link.master.node[k].bus != (uint8_t)b) {
                    continue;
                }
                for (uint32_t j = 0; j < 5u && bc[b].n_rx_ids < SP_SOCKETCAN_MAX_FILTERS; j++) {
                    bc[b].rx_ids[bc[b].n_rx_ids++] = bases[j] + co.link.master.node[k].node_id;
                }
            }
        }
    }
    bc[SP_BUS_AXIS_B].rx_ids[bc[SP_BUS_AXIS_B].n_rx_ids++] = SP_ID_FT_SENSOR;
}

/* The real-time loop's figures so far, on stderr (--stats). */
static void print_stats(const run_stats_t *rs)
{
    uint64_t due = rs->ticks + rs->misses;
    (void)fprintf(stderr, "sp_controller stats: ticks %llu, deadline misses %llu (%.3f %%), worst late %.3f ms\n",
                  (unsigned long long)rs->ticks, (unsigned long long)rs->misses,
                  due ? 100.0 * (double)rs->misses / (double)due : 0.0, (double)rs->worst_late_ns * 1e-6);
}

/* Real-time mode: the controller is the cycle master, an absolute-deadline
 * clock_nanosleep paces the ticks. */
static void run_realtime(const options_t *o, sp_can_port_t *port, sp_node_config_t *cfg, sp_node_t *node,
                         run_stats_t *rs)
{
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    int64_t stats_due = (int64_t)next.tv_sec + o->stats_s;
    while (!sp_host_stop_requested() && (o->max_ticks == 0 || rs->ticks < o->max_ticks)) {
        next.tv_nsec += 1000000;
        if (next.tv_nsec >= 1000000000) {
            next.tv_nsec -= 1000000000;
            next.tv_sec++;
        }
        int r;
        do {
            r = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
        } while (r == EINTR && !sp_host_stop_requested());
        /* late by more than a tick: count the missed deadlines, skip ahead */
        struct timespec now;
        clock_gettime(CLOCK_MONOTONIC, &now);
        int64_t late = ((int64_t)now.tv_sec - next.tv_sec) * 1000000000 + (now.tv_nsec - next.tv_nsec);
        rs->worst_late_ns = (late > rs->worst_late_ns) ? late : rs->worst_late_ns;
        if (late > 1000000) {
            uint64_t missed = (uint64_t)(late / 1000000);
            rs->misses += missed;
            next = now;
        }
        drain(port, node);
        tick(port, cfg, node, rs, 1);
        if (o->stats_s > 0 && (int64_t)now.tv_sec >= stats_due) {
            print_stats(rs);
            stats_due = (int64_t)now.tv_sec + o->stats_s;
        }
    }
}

/* Lockstep mode: a tick when the plant's SYNC has arrived on both axis
 * buses. Returns 0, or 1 on an I/O error. */
static int run_lockstep(const options_t *o, int fd, sp_can_port_t *port, sp_node_config_t *cfg, sp_node_t *node,
                        run_stats_t *rs)
{
    struct pollfd pfd = {fd, POLLIN, 0}; /* one socket serves all buses */
    long silent_ms = 0;                  /* no clock reads per tick: inside user-mode Linux each one is a system call */
    while (!sp_host_stop_requested() && (o->max_ticks == 0 || rs->ticks < o->max_ticks)) {
        int r = poll(&pfd, 1, 100);
        if (r < 0 && errno != EINTR) {
            perror("sp_controller: poll");
            return 1;
        }
        if (r == 0) {
            silent_ms += 100;
        }
        drain(port, node);
        uint32_t t;
        if (sp_node_cycle_ready(node, &t)) {
            /* One socket serves all buses, so frames arrive in the order
             * they were sent: what the plant sent before this SYNC (an
             * operator command) has been read already, and a command
             * always lands in the same tick. */
            tick(port, cfg, node, rs, o->timing);
            silent_ms = 0;
        } else if (silent_ms >= o->timeout_ms && (rs->ticks > 0u || silent_ms >= FIRST_SYNC_TIMEOUT_MS)) {
            fprintf(stderr, "sp_controller: no SYNC from the plant for %ld ms, stopping\n", silent_ms);
            break;
        }
    }
    return 0;
}

/* The CANopen master's nodes at the end (--canopen). */
static void print_canopen(void)
{
    printf("sp_controller canopen: ready %u", (unsigned)co.out.ready);
    for (uint8_t k = 0; k < co.link.master.n_nodes; k++) {
        const sp_co_node_t *nd = &co.m.node[k];
        printf(", node %u phase %u status 0x%04x %s", (unsigned)co.link.master.node[k].node_id, (unsigned)nd->phase,
               (unsigned)nd->status, sp_co_fault_name((sp_co_fault_code_t)nd->fault.code));
        if (nd->fault.code == SP_CO_F_SDO_ABORT) {
            printf(" 0x%04X.%u %s", (unsigned)nd->fault.index, (unsigned)nd->fault.sub,
                   sp_co_sdo_abort_name(nd->fault.detail));
        } else if (nd->fault.code == SP_CO_F_EMCY) {
            printf(" 0x%04X (%s)", (unsigned)nd->fault.index, sp_co_emcy_class_name(nd->fault.index));
        }
    }
    printf("\n");
}

/* The run's summary: ticks and timing, frames, commands, the CANopen
 * nodes and the buses. */
static void print_summary(const options_t *o, sp_can_port_t *port, const sp_node_t *node, const run_stats_t *rs)
{
    printf("sp_controller summary: ticks %llu, state %s, faults 0x%04x, deadline misses %llu, "
           "tick compute mean %lld ns worst %lld ns (%llu ticks timed), tx busy %llu\n",
           (unsigned long long)rs->ticks, sp_state_name(node->out.state), (unsigned)node->out.faults,
           (unsigned long long)rs->misses, rs->timed ? (long long)(rs->sum_ns / (int64_t)rs->timed) : 0LL,
           (long long)rs->worst_ns, (unsigned long long)rs->timed, (unsigned long long)rs->tx_busy);
    printf("sp_controller frames: accepted %u, lost %u, stale %u, saturated %u, ft samples %u", node->stats.accepted,
           node->stats.lost, node->stats.stale, node->stats.saturated, node->stats.ft_samples);
    for (int e = 1; e < SP_PROTO_ERRORS; e++) {
        printf(", %s %u", sp_proto_error_name((sp_proto_error_t)e), node->stats.rejected[e]);
    }
    printf("\n");
    printf("sp_controller commands: refused %u, queue overflow %u\n", node->stats.cmd_refused,
           node->stats.cmd_overflow);
    if (co.on) {
        print_canopen();
    }
    for (uint8_t b = 0; b < SP_CAN_BUSES; b++) {
        sp_bus_status_t bs;
        (void)port->bus_status(port->ctx, b, &bs);
        printf("sp_controller bus %s: tx %u rx %u dropped %u overruns %u error frames %u bus-off %u\n", o->ifs[b],
               bs.tx_frames, bs.rx_frames, bs.tx_dropped, bs.rx_overruns, bs.error_frames, bs.bus_off);
    }
}

int main(int argc, char **argv)
{
    options_t o = {.ifs = {"vcan0", "vcan1", "vcan2"},
                   .ff = 1,
                   .canopen = sp_co_layout_default.present ? 1 : 0,
                   .op_timeout = -1,
                   .wrench_source = -1,
                   .timeout_ms = 5000};
    static sp_node_config_t cfg;
    static sp_node_t node;
    static sp_auth_key_t key;
    static sp_socketcan_t sc;
    sp_socketcan_bus_cfg_t bc[SP_CAN_BUSES];
    if (parse_args(argc, argv, &o) != 0) {
        return 2;
    }
    if (setup(&o, &cfg, &key) != 0) {
        return 1;
    }
    (void)sp_node_init(&node, &cfg);

    /* The controller listens to what is addressed to it. */
    bus_filters(&o, bc);
    if (sp_socketcan_open(&sc, bc) != SP_OK) {
        fprintf(stderr, "sp_controller: %s\n", sc.error);
        return 1;
    }
    sp_can_port_t port = sp_socketcan_port(&sc);
    if (sp_host_stop_on_signals() != 0) { /* then SIGINT/SIGTERM end the program at once, as by default */
        perror("sp_controller: cannot catch SIGINT/SIGTERM");
    }
    fprintf(stderr, "sp_controller: %s mode on %s %s %s, force feed-forward %s, wrench source %s%s\n",
            o.lockstep ? "lockstep" : "real-time", o.ifs[0], o.ifs[1], o.ifs[2], o.ff ? "on" : "off",
            cfg.ctrl.wrench_source == SP_WRENCH_SENSOR ? "sensor" : "cylinders",
            o.canopen ? (sp_co_layout_default.present
                             ? ", drives: CANopen as the platform config's drives section"
                             : (o.co_cia402 ? ", drives: CiA 402 nodes 1-3 (axis_a) and 4-6 (axis_b)"
                                            : ", drives: CiA 408 nodes 1-3 (axis_a) and 4-6 (axis_b)"))
                      : "");

    run_stats_t rs;
    memset(&rs, 0, sizeof rs);
    int rc = 0;
    if (!o.lockstep) {
        run_realtime(&o, &port, &cfg, &node, &rs);
    } else {
        rc = run_lockstep(&o, sp_socketcan_fd(&sc), &port, &cfg, &node, &rs);
    }
    print_summary(&o, &port, &node, &rs);
    if (!o.lockstep) {
        print_stats(&rs);
    }
    sp_socketcan_close(&sc);
    return rc;
}
