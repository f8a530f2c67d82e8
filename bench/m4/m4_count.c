/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_count.c - calibrated instruction counting on mps2-an386 (m4_count.h).
 */
#include "m4_count.h"

#include "m4_io.h"
#include "sp_mps2.h"

#define CALIBRATION_RUNS 64u

static uint32_t overhead16;

__attribute__((noipa)) static int32_t empty_call(int32_t v)
{
    return v;
}

__attribute__((noipa)) static int32_t nop_block(int32_t v)
{
    __asm__ volatile(".rept 999\n\tnop\n\t.endr" ::: "memory");
    return v; /* the return instruction is the 1000th, as in empty_call */
}

int m4_count_init(void)
{
    uint64_t empty16 = 0u;
    uint64_t nops16 = 0u;
    uint64_t net16;
    volatile int32_t sink = 0;
    unsigned i;

    sp_mps2_counter_start();
    for (i = 0u; i < CALIBRATION_RUNS; ++i) {
        uint32_t t0 = sp_mps2_counter_now();
        sink = empty_call(sink);
        empty16 += sp_mps2_counts_to_instr16(sp_mps2_counter_elapsed(t0, sp_mps2_counter_now()));
        t0 = sp_mps2_counter_now();
        sink = nop_block(sink);
        nops16 += sp_mps2_counts_to_instr16(sp_mps2_counter_elapsed(t0, sp_mps2_counter_now()));
    }
    overhead16 = (uint32_t)(empty16 / CALIBRATION_RUNS);
    net16 = (nops16 - empty16) / CALIBRATION_RUNS;
    m4_out_str("calibration: a block of 999 NOPs measures ");
    m4_out_fix16(net16);
    m4_out_str(" instructions beyond an empty call (expected 999.0); measurement overhead ");
    m4_out_fix16(overhead16);
    m4_out_str(" instructions, subtracted");
    m4_out_nl();
    if (net16 < 998u * 16u || net16 > 1000u * 16u) {
        m4_out_str("calibration FAILED: run QEMU with -icount shift=7,sleep=off");
        m4_out_nl();
        return -1;
    }
    return 0;
}

void m4_stat_reset(m4_stat_t *s)
{
    s->calls = 0u;
    s->total16 = 0u;
    s->min16 = UINT32_MAX;
    s->max16 = 0u;
}

uint32_t m4_count_net16(uint32_t counts)
{
    uint64_t v16 = sp_mps2_counts_to_instr16(counts);
    return (v16 > overhead16) ? (uint32_t)(v16 - overhead16) : 0u;
}

void m4_stat_add(m4_stat_t *s, uint32_t net)
{
    s->calls += 1u;
    s->total16 += net;
    s->min16 = (net < s->min16) ? net : s->min16;
    s->max16 = (net > s->max16) ? net : s->max16;
}

uint64_t m4_stat_mean16(const m4_stat_t *s)
{
    return (s->calls == 0u) ? 0u : s->total16 / s->calls;
}

void m4_stat_header(void)
{
    m4_out_str_w("key", 14u);
    m4_out_str_w("measured (instructions per call)", 44u);
    m4_out_str("calls       mean       min       max");
    m4_out_nl();
}

void m4_stat_print(const char *key, const char *name, const m4_stat_t *s)
{
    m4_out_str_w(key, 14u);
    m4_out_str_w(name, 44u);
    m4_out_u32_w(s->calls, 5u);
    m4_out_fix16_w(m4_stat_mean16(s), 11u);
    m4_out_fix16_w(s->calls == 0u ? 0u : s->min16, 10u);
    m4_out_fix16_w(s->max16, 10u);
    m4_out_nl();
}
