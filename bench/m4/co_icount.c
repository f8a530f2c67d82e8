/* SPDX-License-Identifier: Apache-2.0 */
/*
 * co_icount.c - instructions per tick of the CANopen master and its link
 * (sp/canopen/canopen_master.h, sp/canopen/canopen_link.h) on a Cortex-M4 (QEMU mps2-an386,
 * -icount shift=7,sleep=off; m4_count.h), issue 18: six CiA 408 drives
 * running, SYNC every tick, RPDO1 with the force feed-forward object (the
 * 8-byte worst case), 2,000 ticks in steady state. Ends with the budget
 * line: the CANopen side of a tick, mean and max, against 10,000.
 *
 * The master is brought to its running state directly (every node's phase
 * RUN, as after a start-up): the start-up's SDO traffic happens before the
 * control loop and is not in the tick. Per tick the drives' frames of the
 * last SYNC are received (six TPDO1, six TPDO2, and every 20 ms six
 * heartbeats), then the link's feedback, the link's input and the master's
 * step (six RPDO1, two SYNC) are measured, each and together.
 *
 * Then the same with six CiA 402 drives (cyclic synchronous position,
 * operation enabled): TPDO1 only (no pressures), RPDO1 of 6 bytes, the
 * controlword from the state machine and the target position.
 *
 * Run: qemu-system-arm -M mps2-an386 -display none -monitor none -serial
 * none -icount shift=7,sleep=off -semihosting-config enable=on,target=native
 * -kernel build/m4-core/bench/m4/sp_m4_co_icount.elf
 */
#include "m4_count.h"
#include "m4_io.h"
#include "sp_mps2.h"

#include "sp/canopen/canopen_link.h"
#include "sp/model/kinematics.h"

#define TICKS 2000u

static sp_co_link_cfg_t cfg;
static sp_co_master_t m;
static sp_co_master_input_t min;
static sp_co_master_output_t mout;
static sp_ctrl_output_t out;
static sp_drive_feedback_t fb[SP_LEGS];
static sp_can_frame_t rx[3u * SP_LEGS];

__attribute__((noipa)) static void run_receive(uint32_t n, uint32_t now)
{
    uint32_t i;
    for (i = 0u; i < n; i++) {
        (void)sp_co_master_receive(&m, &cfg.master, &rx[i], now);
    }
}

__attribute__((noipa)) static void run_feedback(void)
{
    (void)sp_co_link_feedback(&m, &cfg, fb);
}

__attribute__((noipa)) static void run_input(uint32_t now)
{
    (void)sp_co_link_input(&cfg, &out, now, &min);
}

__attribute__((noipa)) static void run_step(void)
{
    (void)sp_co_master_step(&m, &cfg.master, &min, &mout);
}

/* 2,000 ticks of six running drives of one profile (402 != 0: CiA 402). */
static void bench(int cia402, m4_stat_t s[5])
{
    sp_ik_t ik;
    uint32_t t, k, net;
    (void)sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik);
    (void)sp_co_link_cfg_default(&cfg, &sp_platform_default, ik.length);
    for (k = 0u; k < SP_LEGS; k++) {
        cfg.master.node[k].profile = cia402 ? (uint8_t)SP_CO_PROFILE_402 : (uint8_t)SP_CO_PROFILE_408;
    }
    cfg.master.pressure_feedback = (uint8_t)(cia402 ? 0u : 1u);
    (void)sp_co_master_init(&m);
    (void)sp_co_master_start(&m, &cfg.master, 0u);
    for (k = 0u; k < SP_LEGS; k++) { /* as after the start-up */
        cfg.master.node[k].force_ff = (uint8_t)(cia402 ? 0u : 1u);
        out.setpoint[k].force = (sp_q8_t)(-(int32_t)(k * 100000u)); /* up to -1,953 N */
        m.node[k].phase = SP_CO_PHASE_RUN;
        m.node[k].nmt_pending = 0u;
        out.setpoint[k].length = ik.length[k] + (sp_q24_t)(k * 1000u);
    }
    out.drive_mode = SP_DRIVE_ACTIVE;
    for (k = 0u; k < 5u; k++) {
        m4_stat_reset(&s[k]);
    }
    for (t = 1u; t <= TICKS; t++) {
        uint32_t n = 0u, total = 0u;
        for (k = 0u; k < SP_LEGS; k++) {
            const sp_co_node_cfg_t *nc = &cfg.master.node[k];
            (void)sp_co_tpdo1_frame(&rx[n++], nc->bus, nc->node_id, cia402 ? 0x0237u : 0x000Fu,
                                    (int32_t)(k * 1000u + t));
            if (!cia402) {
                (void)sp_co_tpdo2_frame(&rx[n++], nc->bus, nc->node_id, 20000u, 5000u);
            }
            if (t % 20u == 0u) {
                (void)sp_co_heartbeat_frame(&rx[n++], nc->bus, nc->node_id, SP_CO_NMT_STATE_OPERATIONAL);
            }
        }
        M4_MEASURE(net, run_receive(n, t));
        m4_stat_add(&s[0], net);
        total += net;
        M4_MEASURE(net, run_feedback());
        m4_stat_add(&s[1], net);
        total += net;
        M4_MEASURE(net, run_input(t));
        m4_stat_add(&s[2], net);
        total += net;
        M4_MEASURE(net, run_step());
        m4_stat_add(&s[3], net);
        total += net;
        m4_stat_add(&s[4], total);
        out.setpoint[0].length += 17;
    }
}

static void budget(const char *what, const m4_stat_t *s)
{
    m4_out_str(what);
    m4_out_str(": the CANopen side of a tick mean ");
    m4_out_u32((uint32_t)(m4_stat_mean16(s) / 16u));
    m4_out_str(" max ");
    m4_out_u32(s->max16 / 16u);
    m4_out_str(" of 10000 instructions: ");
    m4_out_str(m4_stat_mean16(s) <= 160000u && s->max16 <= 160000u ? "within budget" : "OVER BUDGET");
    m4_out_nl();
}

int main(void)
{
    m4_stat_t s[5];
    m4_out_str("== Cortex-M4 instruction counts, CANopen master + link, six CiA 408 drives, SYNC every tick "
               "(compiled for " M4_OPTIMISATION ")");
    m4_out_nl();
    if (m4_count_init() != 0) {
        (void)m4_out_flush();
        return 3;
    }
    bench(0, s);
    m4_stat_header();
    m4_stat_print("co_receive", "sp_co_master_receive x 12-18 frames (TPDO1, TPDO2, heartbeats)", &s[0]);
    m4_stat_print("co_feedback", "sp_co_link_feedback (6 legs)", &s[1]);
    m4_stat_print("co_input", "sp_co_link_input (6 setpoints)", &s[2]);
    m4_stat_print("co_step", "sp_co_master_step (6 RPDO1 + 2 SYNC)", &s[3]);
    m4_stat_print("co_tick", "the CANopen side of one tick (the four above)", &s[4]);
    budget("co budget", &s[4]);
    m4_out_str("co_icount: master ready ");
    m4_out_u32(mout.ready);
    m4_out_str(", fault mask ");
    m4_out_u32(mout.fault_mask);
    m4_out_str(", frames per tick ");
    m4_out_u32(mout.n_tx);
    m4_out_nl();
    m4_out_str("== the same, six CiA 402 drives (cyclic synchronous position, operation enabled)");
    m4_out_nl();
    bench(1, s);
    m4_stat_header();
    m4_stat_print("402_receive", "sp_co_master_receive x 6-12 frames (TPDO1, heartbeats)", &s[0]);
    m4_stat_print("402_feedback", "sp_co_link_feedback (6 legs)", &s[1]);
    m4_stat_print("402_input", "sp_co_link_input (6 setpoints)", &s[2]);
    m4_stat_print("402_step", "sp_co_master_step (6 RPDO1 + 2 SYNC)", &s[3]);
    m4_stat_print("402_tick", "the CANopen side of one tick (the four above)", &s[4]);
    budget("co402 budget", &s[4]);
    m4_out_str("co_icount: master ready ");
    m4_out_u32(mout.ready);
    m4_out_str(", fault mask ");
    m4_out_u32(mout.fault_mask);
    m4_out_str(", frames per tick ");
    m4_out_u32(mout.n_tx);
    m4_out_nl();
    return m4_out_flush() == 0 ? 0 : 2;
}
