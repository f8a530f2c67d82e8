/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_count.h - instruction counting on QEMU's mps2-an386 for the bench/m4
 * programs (icount.c, icount_float.c): SysTick under
 * `-icount shift=7,sleep=off` (sp_mps2.h, docs/explanation/m4.md), with the
 * cost of the measurement itself calibrated and subtracted, and a
 * self-check on a block of exactly 1000 NOPs.
 *
 * Use:   M4_MEASURE(net16, result = measured_call(...));
 *        m4_stat_add(&stat, net16);
 * with measured_call an __attribute__((noipa)) function.
 * Counts are instructions executed, not cycles (docs/explanation/m4.md).
 */
#ifndef M4_COUNT_H
#define M4_COUNT_H

#include <stdint.h>

#include "sp_mps2.h"

/** The optimisation the program was compiled with, as text. */
#if defined(__OPTIMIZE_SIZE__)
#define M4_OPTIMISATION "size (-Os)"
#elif defined(__OPTIMIZE__)
#define M4_OPTIMISATION "speed (-O2)"
#else
#define M4_OPTIMISATION "no optimisation (-O0)"
#endif

/** Statistics of one measured function, instructions x 16. */
typedef struct {
    uint32_t calls;
    uint64_t total16;
    uint32_t min16;
    uint32_t max16;
} m4_stat_t;

/**
 * Starts the counter, measures the overhead of an empty measured call and
 * checks that a block of 1000 NOPs measures 1000 +- 1 instructions. Prints
 * the calibration line. Returns 0, or -1 if the check fails (QEMU was not
 * run with -icount shift=7: the counts would be meaningless).
 */
int m4_count_init(void);

/** Resets a statistic. */
void m4_stat_reset(m4_stat_t *s);

/** Instructions x 16 in `counts` SysTick counts, the calibrated overhead
 *  of a measurement subtracted (never below zero). */
uint32_t m4_count_net16(uint32_t counts);

/** Runs `call` (a statement) between two counter reads; net16 receives the
 *  instructions x 16 it executed. */
#define M4_MEASURE(net16, call)                                                                                        \
    do {                                                                                                               \
        uint32_t m4_t0_ = sp_mps2_counter_now();                                                                       \
        call;                                                                                                          \
        (net16) = m4_count_net16(sp_mps2_counter_elapsed(m4_t0_, sp_mps2_counter_now()));                              \
    } while (0)

/** Adds one measurement (instructions x 16). */
void m4_stat_add(m4_stat_t *s, uint32_t net16);

/** Mean of the measurements, instructions x 16 (0 when none). */
uint64_t m4_stat_mean16(const m4_stat_t *s);

/** Prints a row: key, description, calls, mean, min, max. */
void m4_stat_print(const char *key, const char *name, const m4_stat_t *s);

/** Prints the header of the rows. */
void m4_stat_header(void);

#endif /* M4_COUNT_H */
