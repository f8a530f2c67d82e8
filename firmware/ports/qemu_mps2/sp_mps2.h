/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_mps2.h - the port of the portable core to QEMU's `mps2-an386` board
 * (ARM MPS2 with the AN386 Cortex-M4 image), used to run the core on a real
 * Cortex-M4 instruction set: the bit-exactness check against the host build
 * and the instruction counts (docs/explanation/m4.md).
 *
 * Memory map (QEMU 7.2): code at 0x00000000 (4 MiB), RAM at 0x20000000
 * (4 MiB). The program talks to the host through ARM semihosting
 * (`-semihosting-config enable=on,target=native`): text to QEMU's standard
 * output, and the exit status. Nothing here is used by the firmware proper.
 *
 * Run:  qemu-system-arm -M mps2-an386 -nographic \
 *         -semihosting-config enable=on,target=native -kernel prog.elf
 * main()'s return value becomes QEMU's exit status; a fault handler exits
 * with status SP_MPS2_EXIT_FAULT after printing which fault it was.
 */
#ifndef SP_MPS2_H
#define SP_MPS2_H

#include <stddef.h>
#include <stdint.h>

/** Exit status of a program that took a CPU fault (HardFault, ...). */
#define SP_MPS2_EXIT_FAULT 125

/**
 * Writes len bytes of buf to QEMU's standard output (semihosting SYS_WRITE
 * on the ":tt" stream). Returns 0 when everything was written, -1 otherwise
 * (no semihosting host, stream closed). Blocking; not for a control loop.
 */
int sp_mps2_write(const char *buf, size_t len);

/**
 * Ends the program: QEMU exits with `status` (semihosting
 * SYS_EXIT_EXTENDED, ADP_Stopped_ApplicationExit). Never returns.
 */
void sp_mps2_exit(int status) __attribute__((noreturn));

/* ---- instruction counting (QEMU -icount shift=7,sleep=off) --------------
 *
 * QEMU models no cycles and its DWT cycle counter reads 0. With
 * `-icount shift=7,sleep=off` every instruction advances virtual time by
 * 2^7 ns exactly, and SysTick clocked from the core (25 MHz on this board,
 * 40 ns per count) then counts instructions deterministically:
 * instructions = SysTick counts x 40 / 128 = counts x 5 / 16.
 * Without -icount the counts are host-time noise.
 */

/** Starts SysTick as a free-running 24-bit down-counter on the core clock
 *  (CSR = 5, reload 0xFFFFFF, no interrupt) and waits until it runs. */
void sp_mps2_counter_start(void);

/** Current SysTick value (24 bits, counting down). */
uint32_t sp_mps2_counter_now(void);

/**
 * SysTick counts elapsed from `earlier` to `later` (both from
 * sp_mps2_counter_now), modulo 2^24: exact for intervals shorter than
 * 2^24 counts (5.2 million instructions under -icount shift=7).
 */
uint32_t sp_mps2_counter_elapsed(uint32_t earlier, uint32_t later);

/** SysTick counts to instructions x 16 (fixed point with 4 fractional
 *  bits: one count is 5/16 instruction). Exact, no rounding. */
static inline uint64_t sp_mps2_counts_to_instr16(uint64_t counts)
{
    return counts * 5u;
}

/* ---- stack high-water mark ---------------------------------------------- */

/**
 * Fills the unused part of the stack (from the bottom of the stack region
 * to 256 bytes below the caller's stack pointer) with a known pattern.
 */
void sp_mps2_stack_paint(void);

/**
 * Bytes of stack used below `top` since the last sp_mps2_stack_paint: the
 * distance from `top` (a stack address taken in the caller, e.g. with
 * sp_mps2_stack_pointer) down to the deepest word no longer holding the
 * pattern. 0 if nothing below `top` was touched.
 */
uint32_t sp_mps2_stack_used(uintptr_t top);

/** The current stack pointer. */
uintptr_t sp_mps2_stack_pointer(void);

#endif /* SP_MPS2_H */
