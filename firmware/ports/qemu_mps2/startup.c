/* SPDX-License-Identifier: Apache-2.0 */
/*
 * startup.c - vector table, reset handler and fault handlers of the
 * mps2-an386 port (Cortex-M4). After reset: copy .data from its load address
 * in code memory to RAM, zero .bss, enable the FPU when the program was
 * compiled for it (hard-float builds: CPACR grants CP10/CP11), call main()
 * and exit QEMU with its return value.
 */
#include <stdint.h>

#include "sp_mps2.h"

/* Symbols of the linker script (mps2_an386.ld). */
extern uint32_t sp_mps2_data_load[];
extern uint32_t sp_mps2_data_start[];
extern uint32_t sp_mps2_data_end[];
extern uint32_t sp_mps2_bss_start[];
extern uint32_t sp_mps2_bss_end[];
extern uint32_t sp_mps2_stack_top[];

int main(void);
void sp_mps2_reset(void);
void sp_mps2_fault(void);
void sp_mps2_unexpected(void);

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SCB_CFSR (*(volatile uint32_t *)0xE000ED28u)

__attribute__((noreturn)) void sp_mps2_reset(void)
{
    uint32_t *src = sp_mps2_data_load;
    uint32_t *dst = sp_mps2_data_start;

    while (dst < sp_mps2_data_end) {
        *dst++ = *src++;
    }
    for (dst = sp_mps2_bss_start; dst < sp_mps2_bss_end; ++dst) {
        *dst = 0u;
    }
#if defined(__ARM_FP)
    /* Full access to the FPU (coprocessors 10 and 11), before any FP code. */
    SCB_CPACR |= (UINT32_C(0xF) << 20);
    __asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
    sp_mps2_exit(main());
}

static void put_hex(char *out, uint32_t v)
{
    static const char digits[] = "0123456789abcdef";
    int i;
    for (i = 7; i >= 0; --i) {
        out[i] = digits[v & 0xFu];
        v >>= 4;
    }
}

/* HardFault, MemManage, BusFault, UsageFault: report and stop, so that a
 * crash ends the run with a non-zero status instead of hanging the test. */
__attribute__((noreturn)) void sp_mps2_fault(void)
{
    char msg[] = "\nfault: CPU fault, CFSR=00000000\n";
    put_hex(&msg[24], SCB_CFSR);
    (void)sp_mps2_write(msg, sizeof msg - 1u);
    sp_mps2_exit(SP_MPS2_EXIT_FAULT);
}

/* Any other exception or interrupt: none is enabled by these programs. */
__attribute__((noreturn)) void sp_mps2_unexpected(void)
{
    static const char msg[] = "\nfault: unexpected exception\n";
    (void)sp_mps2_write(msg, sizeof msg - 1u);
    sp_mps2_exit(SP_MPS2_EXIT_FAULT);
}

typedef void (*sp_mps2_vector_t)(void);

/* Cortex-M vector table: initial stack pointer, then the 15 system
 * exceptions. No device interrupt is used, so the table stops there. */
__attribute__((section(".vectors"), used)) static const sp_mps2_vector_t vectors[16] = {
    (sp_mps2_vector_t)(uintptr_t)sp_mps2_stack_top, /* initial SP */
    sp_mps2_reset,                                  /* Reset */
    sp_mps2_unexpected,                             /* NMI */
    sp_mps2_fault,                                  /* HardFault */
    sp_mps2_fault,                                  /* MemManage */
    sp_mps2_fault,                                  /* BusFault */
    sp_mps2_fault,                                  /* UsageFault */
    0,
    0,
    0,
    0,                  /* reserved */
    sp_mps2_unexpected, /* SVCall */
    sp_mps2_unexpected, /* DebugMonitor */
    0,                  /* reserved */
    sp_mps2_unexpected, /* PendSV */
    sp_mps2_unexpected, /* SysTick */
};
