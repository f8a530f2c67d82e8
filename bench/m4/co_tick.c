/* SPDX-License-Identifier: Apache-2.0 */
/*
 * co_tick.c - instructions of the whole tick the firmware runs with CiA 408
 * drives (issue 18: "the tick with the CANopen master within 10,000
 * instructions mean and max") on a Cortex-M4 (QEMU mps2-an386, -icount
 * shift=7,sleep=off; m4_count.h): the drives' frames received
 * (sp_co_master_receive), sp_co_link_feedback into the controller's drive
 * feedback, sp_ctrl_step, sp_co_link_input_due, sp_co_master_step, in the order
 * of firmware/ports/stm32g4/main.c and sp/canopen/canopen_link.h, measured as one.
 *
 * The scenarios of icount.c (surge, yaw, stream: m4_scenario.c) with six
 * CiA 408 drives behind the master (sp_co_link_cfg_default: three drives on
 * each of two buses, pressures in TPDO2, the force feed-forward 0x2120 in
 * RPDO1), SYNC every 3 ticks (the CiA 408 layout of docs/reference/canopen.md) and
 * every tick; and six CiA 402 drives (cyclic synchronous position, the
 * force feed-forward as 0x60B2, no pressures) with SYNC every 2 ticks, the
 * rate at which CiA 402 fits two classic 1 Mbit/s buses (`stewart busload
 * --builtin cia402 --sync-divider 2`: 38.3 %). The master is brought to its running state directly, as
 * co_icount.c does (the start-up's SDO traffic is before the control loop);
 * one unmeasured master step before the first tick sends the first SYNC.
 * After each tick that sent SYNC the drives answer, received at the start
 * of the next tick: TPDO1 with the status word of the state the master asks
 * and the count of the scenario's drive length (the scenario's plant: the
 * setpoint a tick late with a tracking error) through the link's scaling,
 * TPDO2 with pressures that give the scenario's drive force; every 20 ms
 * each drive's heartbeat. The link's feedback overwrites the scenario's
 * (fresh only for the legs that answered); the controller's
 * feedback_timeout_ticks is the divider + 2 (as the firmware and
 * tests/plant/test_plant_canopen_loop.c set it). Building the frames is not
 * measured.
 *
 * A second run of each scenario measures the five parts one by one (the
 * same ticks: the runs are deterministic), for where the instructions go.
 * Ends with a budget line per layout: the whole tick against 10,000.
 * Exit status: 0, 3 if the counter's calibration failed.
 *
 * Run: qemu-system-arm -M mps2-an386 -display none -monitor none -serial
 * none -icount shift=7,sleep=off -semihosting-config enable=on,target=native
 * -kernel build/m4-core/bench/m4/sp_m4_co_tick.elf
 */
#include "m4_count.h"
#include "m4_io.h"
#include "m4_vectors.h"
#include "sp_mps2.h"

#include "sp/canopen/canopen_link.h"
#include "sp/model/kinematics.h"

#define TICK_BUDGET 10000u
#define PB_KPA 5000u       /* the drives' rod-side pressure, 50 bar */
#define RATED_402_N 10000u /* the CiA 402 drives' rated force along the leg (0x60B2's 1000 per mille) */

/* A drive layout: the profile of all six drives and the SYNC divider. */
typedef struct {
    uint8_t cia402;
    uint8_t divider;
} layout_t;
#define LAYOUTS 3u

/* The tick's place in the SYNC period. */
#define KINDS 4u
#define KIND_SYNC 0u  /* the master sends RPDO1 + SYNC; no answers to receive */
#define KIND_AFTER 1u /* the answers to the last SYNC received; no SYNC sent */
#define KIND_OTHER 2u /* neither */
#define KIND_BOTH 3u  /* both (SYNC every tick) */
static const char *const kind_names[KINDS] = {
    "  SYNC ticks (RPDO1 + SYNC sent)",
    "  the tick after (answers received)",
    "  the other ticks",
    "  every tick (answers in, SYNC out)",
};

/* The parts of the tick (the second run). */
#define PARTS 5u
#define P_RECEIVE 0u
#define P_FEEDBACK 1u
#define P_CTRL 2u
#define P_INPUT 3u
#define P_STEP 4u

static m4_scenario_t sc;
static sp_co_link_cfg_t co_link;
static sp_co_master_t m;
static sp_co_master_input_t min;
static sp_co_master_output_t mout;
static sp_can_frame_t rx[3u * SP_LEGS];
static volatile int32_t sink;

/* The whole tick: the measured call (never inlined, never analysed across). */
__attribute__((noipa)) static sp_status_t run_whole(uint32_t n, uint32_t now)
{
    sp_status_t st;
    uint32_t i;
    for (i = 0u; i < n; i++) {
        (void)sp_co_master_receive(&m, &co_link.master, &rx[i], now);
    }
    (void)sp_co_link_feedback(&m, &co_link, sc.in.drive);
    sc.in.setpoints_idle = sp_co_link_setpoints_idle(&co_link, &m);
    st = sp_ctrl_step(&sc.cfg, &sc.ctrl, &sc.in, &sc.out);
    (void)sp_co_link_input_due(&co_link, &m, &sc.out, now, &min);
    (void)sp_co_master_step(&m, &co_link.master, &min, &mout);
    return st;
}

/* The same, part by part. */
__attribute__((noipa)) static void run_receive(uint32_t n, uint32_t now)
{
    uint32_t i;
    for (i = 0u; i < n; i++) {
        (void)sp_co_master_receive(&m, &co_link.master, &rx[i], now);
    }
}

__attribute__((noipa)) static void run_feedback(void)
{
    (void)sp_co_link_feedback(&m, &co_link, sc.in.drive);
    sc.in.setpoints_idle = sp_co_link_setpoints_idle(&co_link, &m);
}

__attribute__((noipa)) static sp_status_t run_ctrl(void)
{
    return sp_ctrl_step(&sc.cfg, &sc.ctrl, &sc.in, &sc.out);
}

__attribute__((noipa)) static void run_input(uint32_t now)
{
    (void)sp_co_link_input_due(&co_link, &m, &sc.out, now, &min);
}

__attribute__((noipa)) static void run_step(void)
{
    (void)sp_co_master_step(&m, &co_link.master, &min, &mout);
}

/* The counts of one scenario at one divider. */
typedef struct {
    m4_stat_t run;              /* the whole tick, RUNNING (the state it began in) */
    m4_stat_t all;              /* the whole tick, every state */
    m4_stat_t run_kind[KINDS];  /* RUNNING, by the tick's place in the SYNC period */
    m4_stat_t part[PARTS];      /* the second run: RUNNING, each part */
    m4_stat_t ctrl_kind[KINDS]; /* ... sp_ctrl_step by place */
    m4_stat_t co_kind[KINDS];   /* ... the four CANopen parts together, by place */
    m4_stat_t sum;              /* ... the five parts together, RUNNING */
    uint32_t fk[KINDS][4];      /* RUNNING ticks by place and FK steps: 0, 1, 2, 3 or more */
    uint32_t ctrl_worst_tick;   /* the second run: the highest sp_ctrl_step in RUNNING, its tick, */
    uint8_t ctrl_worst_kind;    /* place, */
    uint8_t ctrl_worst_fk;      /* FK steps */
    uint8_t ctrl_worst_cmd;     /* and command */
    uint32_t over;              /* ticks over the budget (every state) */
    uint32_t not_ok;            /* sp_ctrl_step not SP_OK */
    uint32_t worst_tick;        /* the highest whole tick: its index, */
    uint8_t worst_state;        /* the state it began in, */
    uint8_t worst_kind;         /* its place */
    uint8_t final_state;
    uint32_t faults;
    uint32_t ticks;
    uint8_t fault_mask; /* the master's, at the end */
    uint8_t ready;      /* the master's, at the end */
} counts_t;

/* The drives' answers to the SYNC just sent, from the scenario's plant:
 * positions `len` (Q24), forces `force` (Q8 N). Returns the frame count. */
static uint32_t answers(const sp_q24_t len[SP_LEGS], const sp_q8_t force[SP_LEGS], int sync, uint32_t now)
{
    const sp_co_request_t req = (sp_co_request_t)m.last_req;
    const int cia402 = co_link.master.node[0].profile == (uint8_t)SP_CO_PROFILE_402;
    uint16_t status = cia402 ? sp_co402_status_bits(sp_co402_target(req)) : sp_co408_status_bits(sp_co408_target(req));
    uint32_t n = 0u, k;
    for (k = 0u; k < co_link.master.n_nodes; k++) {
        const sp_co_node_cfg_t *nc = &co_link.master.node[k];
        uint32_t leg = (uint32_t)nc->leg - 1u;
        if (sync) {
            const sp_platform_t *p = co_link.platform;
            int32_t count = 0;
            int64_t pa;
            (void)sp_co_length_to_count(&co_link.scaling[leg], len[leg], &count);
            (void)sp_co_tpdo1_frame(&rx[n++], nc->bus, nc->node_id, status, count);
            if (!cia402) { /* CiA 402: position only, no pressures */
                /* pa A_piston - pb A_annulus = force: pa in kPa, rounded */
                pa = ((int64_t)force[leg] * (INT64_C(1) << 22) + (int64_t)PB_KPA * 1000 * p->annulus_area +
                      (int64_t)500 * p->piston_area) /
                     ((int64_t)1000 * p->piston_area);
                pa = pa < 0 ? 0 : (pa > 65535 ? 65535 : pa);
                (void)sp_co_tpdo2_frame(&rx[n++], nc->bus, nc->node_id, (uint16_t)pa, (uint16_t)PB_KPA);
            }
        }
        if (now % 20u == 0u) {
            (void)sp_co_heartbeat_frame(&rx[n++], nc->bus, nc->node_id, SP_CO_NMT_STATE_OPERATIONAL);
        }
    }
    return n;
}

static void run_scenario(uint8_t motion, layout_t lay, int parts, counts_t *r)
{
    const uint8_t divider = lay.divider;
    sp_ik_t ik;
    sp_drive_feedback_t seen[SP_LEGS]; /* the controller's feedback as the link left it */
    sp_q24_t plant_len[SP_LEGS];
    sp_q8_t plant_force[SP_LEGS];
    uint32_t n, now = 0u, k;

    if (!parts) {
        m4_stat_reset(&r->run);
        m4_stat_reset(&r->all);
        for (k = 0u; k < KINDS; ++k) {
            m4_stat_reset(&r->run_kind[k]);
        }
        r->over = 0u;
        r->not_ok = 0u;
        r->worst_tick = 0u;
        r->worst_state = 0u;
        r->worst_kind = 0u;
        for (k = 0u; k < KINDS * 4u; ++k) {
            r->fk[k / 4u][k % 4u] = 0u;
        }
    } else {
        r->ctrl_worst_tick = 0u;
        r->ctrl_worst_kind = 0u;
        r->ctrl_worst_fk = 0u;
        r->ctrl_worst_cmd = 0u;
        for (k = 0u; k < PARTS; ++k) {
            m4_stat_reset(&r->part[k]);
        }
        for (k = 0u; k < KINDS; ++k) {
            m4_stat_reset(&r->ctrl_kind[k]);
            m4_stat_reset(&r->co_kind[k]);
        }
        m4_stat_reset(&r->sum);
    }
    (void)m4_scenario_init(&sc, &sp_platform_default, motion);
    (void)sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik);
    (void)sp_co_link_cfg_default(&co_link, &sp_platform_default, ik.length);
    co_link.master.sync_divider = divider;
    co_link.master.pdo_timeout_ms = (uint16_t)(3u * divider + 5u);
    co_link.master.setpoint_timeout_ms = (uint16_t)(3u * divider);
    for (k = 0u; k < co_link.master.n_nodes; k++) {
        co_link.master.node[k].force_ff = 1u; /* 0x2120 (CiA 408), 0x60B2 (CiA 402) in RPDO1 */
        co_link.master.node[k].profile = lay.cia402 ? (uint8_t)SP_CO_PROFILE_402 : (uint8_t)SP_CO_PROFILE_408;
    }
    if (lay.cia402) {
        co_link.master.pressure_feedback = 0u;
        for (k = 0u; k < SP_LEGS; k++) {
            co_link.scaling[k].rated_force_n = RATED_402_N;
            (void)sp_co_scaling_prepare(&co_link.scaling[k]);
        }
    }
    /* feedback every `divider` ticks: the controller's timeout and feedback period */
    (void)sp_co_link_ctrl_config(&co_link, &sc.cfg);
    (void)sp_ctrl_init(&sc.ctrl, &sc.cfg);
    (void)sp_co_master_init(&m);
    (void)sp_co_master_start(&m, &co_link.master, 0u);
    for (k = 0u; k < co_link.master.n_nodes; k++) { /* as after the start-up */
        m.node[k].phase = SP_CO_PHASE_RUN;
        m.node[k].nmt_pending = 0u;
    }
    for (k = 0u; k < SP_LEGS; k++) {
        seen[k] = sc.in.drive[k];
        seen[k].fresh = 0u;
        plant_len[k] = sc.in.drive[k].length;
        plant_force[k] = sc.in.drive[k].force;
    }
    /* the first SYNC, before the control loop */
    (void)sp_co_link_input_due(&co_link, &m, &sc.out, now, &min);
    (void)sp_co_master_step(&m, &co_link.master, &min, &mout);
    n = answers(plant_len, plant_force, mout.sync, now);
    while (m4_scenario_prepare(&sc)) {
        sp_state_t before = sc.ctrl.state;
        int after = mout.sync != 0u; /* the answers to the last step's SYNC */
        int sync = m.ticks % divider == 0u;
        unsigned kind = sync ? (after ? KIND_BOTH : KIND_SYNC) : (after ? KIND_AFTER : KIND_OTHER);
        uint32_t tick = sc.ticks;
        uint32_t net;
        sp_status_t st;
        ++now;
        for (k = 0u; k < SP_LEGS; k++) { /* the link's view, not the scenario's plant */
            sc.in.drive[k] = seen[k];
        }
        if (!parts) {
            M4_MEASURE(net, st = run_whole(n, now));
            if (net > r->all.max16) {
                r->worst_tick = tick;
                r->worst_state = (uint8_t)before;
                r->worst_kind = (uint8_t)kind;
            }
            m4_stat_add(&r->all, net);
            if (before == SP_STATE_RUNNING) {
                m4_stat_add(&r->run, net);
                m4_stat_add(&r->run_kind[kind], net);
                r->fk[kind][sc.out.fk_iterations < 3u ? sc.out.fk_iterations : 3u]++;
            }
            r->over += (net > TICK_BUDGET * 16u) ? 1u : 0u;
            r->not_ok += (st != SP_OK) ? 1u : 0u;
        } else {
            uint32_t p[PARTS];
            M4_MEASURE(p[P_RECEIVE], run_receive(n, now));
            M4_MEASURE(p[P_FEEDBACK], run_feedback());
            M4_MEASURE(p[P_CTRL], sink = (int32_t)run_ctrl());
            M4_MEASURE(p[P_INPUT], run_input(now));
            M4_MEASURE(p[P_STEP], run_step());
            if (before == SP_STATE_RUNNING) {
                uint32_t co = p[P_RECEIVE] + p[P_FEEDBACK] + p[P_INPUT] + p[P_STEP];
                if (p[P_CTRL] > r->part[P_CTRL].max16) {
                    r->ctrl_worst_tick = tick;
                    r->ctrl_worst_kind = (uint8_t)kind;
                    r->ctrl_worst_fk = (uint8_t)sc.out.fk_iterations;
                    r->ctrl_worst_cmd = (uint8_t)sc.in.cmd.type;
                }
                for (k = 0u; k < PARTS; k++) {
                    m4_stat_add(&r->part[k], p[k]);
                }
                m4_stat_add(&r->ctrl_kind[kind], p[P_CTRL]);
                m4_stat_add(&r->co_kind[kind], co);
                m4_stat_add(&r->sum, co + p[P_CTRL]);
            }
        }
        for (k = 0u; k < SP_LEGS; k++) {
            seen[k] = sc.in.drive[k];
        }
        m4_scenario_finish(&sc); /* the plant: sc.in.drive */
        for (k = 0u; k < SP_LEGS; k++) {
            plant_len[k] = sc.in.drive[k].length;
            plant_force[k] = sc.in.drive[k].force;
        }
        n = answers(plant_len, plant_force, mout.sync, now);
    }
    r->final_state = (uint8_t)sc.out.state;
    r->faults = sc.out.faults;
    r->ticks = sc.ticks;
    r->fault_mask = mout.fault_mask;
    r->ready = mout.ready;
}

static const char *const motion_names[3] = {"surge", "yaw", "stream"};

/* A row's key: prefix, the scenario, _d and the divider (at most 13 characters). */
static void key(char *buf, const char *prefix, const char *name, uint8_t divider)
{
    uint32_t i = 0u;
    while (*prefix != '\0' && i < 4u) {
        buf[i++] = *prefix++;
    }
    while (*name != '\0' && i < 10u) {
        buf[i++] = *name++;
    }
    buf[i++] = '_';
    buf[i++] = 'd';
    buf[i++] = (char)('0' + divider);
    buf[i] = '\0';
}

static void print_counts(uint8_t motion, layout_t lay, const counts_t *r)
{
    const uint8_t divider = lay.divider;
    static const char *const part_names[PARTS] = {
        "  sp_co_master_receive (the frames)",
        "  sp_co_link_feedback",
        "  sp_ctrl_step",
        "  sp_co_link_input_due",
        "  sp_co_master_step",
    };
    static const char *const part_keys[PARTS] = {"p_recv", "p_fb", "p_ctrl", "p_input", "p_step"};
    char k[16];
    unsigned i;
    m4_out_str("-- ");
    m4_out_str(motion_names[motion]);
    m4_out_str(lay.cia402 ? ", CiA 402" : ", CiA 408");
    m4_out_str(", SYNC every ");
    m4_out_u32(divider);
    m4_out_str(divider == 1u ? " tick" : " ticks");
    m4_out_nl();
    key(k, "run_", motion_names[motion], divider);
    m4_stat_print(k, "whole tick in RUNNING", &r->run);
    for (i = 0u; i < KINDS; ++i) {
        if (r->run_kind[i].calls != 0u) {
            m4_stat_print("", kind_names[i], &r->run_kind[i]);
        }
    }
    key(k, "all_", motion_names[motion], divider);
    m4_stat_print(k, "whole tick, every state", &r->all);
    m4_out_str("parts, measured one by one (RUNNING):");
    m4_out_nl();
    for (i = 0u; i < PARTS; ++i) {
        m4_stat_print(part_keys[i], part_names[i], &r->part[i]);
    }
    m4_stat_print("p_sum", "  the five together", &r->sum);
    for (i = 0u; i < KINDS; ++i) {
        if (r->ctrl_kind[i].calls != 0u) {
            m4_stat_print("p_ctrl", kind_names[i], &r->ctrl_kind[i]);
            m4_stat_print("p_canopen", kind_names[i], &r->co_kind[i]);
        }
    }
    m4_out_str("FK steps in RUNNING ticks (0 / 1 / 2 / 3+):");
    for (i = 0u; i < KINDS; ++i) {
        if (r->run_kind[i].calls != 0u) {
            m4_out_str(kind_names[i] + 1);
            m4_out_str(" ");
            m4_out_u32(r->fk[i][0]);
            m4_out_str(" / ");
            m4_out_u32(r->fk[i][1]);
            m4_out_str(" / ");
            m4_out_u32(r->fk[i][2]);
            m4_out_str(" / ");
            m4_out_u32(r->fk[i][3]);
            m4_out_str(";");
        }
    }
    m4_out_nl();
    m4_out_str("highest sp_ctrl_step in RUNNING: tick ");
    m4_out_u32(r->ctrl_worst_tick);
    m4_out_str(",");
    m4_out_str(kind_names[r->ctrl_worst_kind] + 1);
    m4_out_str(", FK steps ");
    m4_out_u32(r->ctrl_worst_fk);
    m4_out_str(", command ");
    m4_out_u32(r->ctrl_worst_cmd);
    m4_out_nl();
    m4_out_str("highest tick: ");
    m4_out_u32(r->worst_tick);
    m4_out_str(", began in ");
    m4_out_str(sp_state_name((sp_state_t)r->worst_state));
    m4_out_str(",");
    m4_out_str(kind_names[r->worst_kind] + 1);
    m4_out_str("; ticks over ");
    m4_out_u32(TICK_BUDGET);
    m4_out_str(": ");
    m4_out_u32(r->over);
    m4_out_nl();
    m4_out_str("scenario: ");
    m4_out_u32(r->ticks);
    m4_out_str(" ticks, final state ");
    m4_out_str(sp_state_name((sp_state_t)r->final_state));
    m4_out_str(", faults");
    m4_out_hex(r->faults);
    m4_out_str("; sp_ctrl_step not SP_OK: ");
    m4_out_u32(r->not_ok);
    m4_out_str("; master ready ");
    m4_out_u32(r->ready);
    m4_out_str(", fault mask ");
    m4_out_u32(r->fault_mask);
    m4_out_nl();
}

static void budget(layout_t lay, const counts_t r[3])
{
    uint32_t over = 0u, max16 = 0u;
    unsigned i;
    int mean_ok = 1;
    for (i = 0u; i < 3u; ++i) {
        over += r[i].over;
        max16 = r[i].all.max16 > max16 ? r[i].all.max16 : max16;
        mean_ok = mean_ok && m4_stat_mean16(&r[i].run) <= TICK_BUDGET * 16u;
    }
    m4_out_str(lay.cia402 ? "budget: whole CANopen tick (CiA 402, SYNC every "
                          : "budget: whole CANopen tick (CiA 408, SYNC every ");
    m4_out_u32(lay.divider);
    m4_out_str(") <= ");
    m4_out_u32(TICK_BUDGET);
    m4_out_str(" instructions: RUNNING mean ");
    for (i = 0u; i < 3u; ++i) {
        m4_out_fix16(m4_stat_mean16(&r[i].run));
        m4_out_str(" (");
        m4_out_str(motion_names[i]);
        m4_out_str(i < 2u ? "), " : ")");
    }
    m4_out_str("; any tick of the three scenarios max ");
    m4_out_fix16(max16);
    m4_out_str(" -> ");
    if (over == 0u && mean_ok) {
        m4_out_str("within budget");
    } else {
        m4_out_str("OVER BUDGET");
        if (!mean_ok) {
            m4_out_str(" (mean)");
        }
        if (over != 0u) {
            m4_out_str(" in ");
            m4_out_u32(over);
            m4_out_str(" ticks");
        }
    }
    m4_out_nl();
}

int main(void)
{
    /* CiA 408 at the layout of two classic buses with pressures, CiA 402 at its own, CiA 408 every tick */
    static const layout_t layouts[LAYOUTS] = {{0u, 3u}, {1u, 2u}, {0u, 1u}};
    static counts_t r[LAYOUTS][3];
    unsigned d, s;
    m4_out_str("== Cortex-M4 instruction counts, the whole tick with six CANopen drives: frames received, "
               "link feedback, sp_ctrl_step, link input, master step (compiled for " M4_OPTIMISATION ")");
    m4_out_nl();
    if (m4_count_init() != 0) {
        (void)m4_out_flush();
        return 3;
    }
    for (d = 0u; d < LAYOUTS; ++d) {
        for (s = 0u; s < 3u; ++s) {
            run_scenario((uint8_t)s, layouts[d], 0, &r[d][s]);
            run_scenario((uint8_t)s, layouts[d], 1, &r[d][s]);
        }
    }
    m4_stat_header();
    for (d = 0u; d < LAYOUTS; ++d) {
        for (s = 0u; s < 3u; ++s) {
            print_counts((uint8_t)s, layouts[d], &r[d][s]);
        }
    }
    for (d = 0u; d < LAYOUTS; ++d) {
        budget(layouts[d], r[d]);
    }
    return m4_out_flush() == 0 ? 0 : 2;
}
