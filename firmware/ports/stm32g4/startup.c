/* SPDX-License-Identifier: Apache-2.0 */
/*
 * startup.c - vector table, reset handler, fault handlers and the safe state
 * of the NUCLEO-G474RE port.
 *
 * Reset: copy .data from flash, zero .bss, paint the stack (for the
 * high-water mark), vector table base, divide-by-zero trap on, record and
 * clear the reset flags, main().
 *
 * Faults (HardFault; MemManage, BusFault and UsageFault are not enabled
 * separately, so they escalate to HardFault), NMI (the clock security
 * system's HSE failure) and any interrupt nobody enabled all end in
 * sp_g4_stop(): the fault entry first moves the stack pointer back to the
 * top of the stack, so the safe state is reached even after a stack
 * overflow; then no more frames are sent (pending transmissions cancelled,
 * the FDCAN controllers in initialisation mode), LD2 is lit, and the core
 * waits for the independent watchdog's reset. The drives keep their last
 * setpoint until their own setpoint timeout (the protocol's design, as
 * CiA 408's receive-PDO event timer), then take their fault reaction.
 * After the reset the controller starts in IDLE and needs a new ENGAGE.
 */
#include <stdint.h>

#include "g4_regs.h"
#include "sp_g4.h"

/* Linker script symbols (stm32g474re.ld). */
extern uint32_t sp_g4_data_load[];
extern uint32_t sp_g4_data_start[];
extern uint32_t sp_g4_data_end[];
extern uint32_t sp_g4_bss_start[];
extern uint32_t sp_g4_bss_end[];
extern uint32_t sp_g4_stack_bottom[];
extern uint32_t sp_g4_stack_top[];

int main(void);
void sp_g4_reset(void);
void sp_g4_fault_entry(void);
void sp_g4_fault_c(const uint32_t *frame);
void sp_g4_nmi(void);
void sp_g4_unexpected(void);
void sp_g4_systick_handler(void);

#define STACK_PAINT 0x5AA5C33Cu

__attribute__((section(".noinit"))) sp_g4_diag_t sp_g4_diag;
uint32_t sp_g4_reset_flags;

typedef void (*sp_g4_vector_t)(void);
#define SP_G4_IRQS 102u /* STM32G474 device interrupts, positions 0..101 (RM0440, NVIC: vector table) */

__attribute__((section(".vectors"), used)) static const sp_g4_vector_t sp_g4_vectors[16u + SP_G4_IRQS] = {
    [0] = (sp_g4_vector_t)(uintptr_t)sp_g4_stack_top, /* initial SP */
    [1] = sp_g4_reset,
    [2] = sp_g4_nmi,
    [3] = sp_g4_fault_entry, /* HardFault */
    [4] = sp_g4_fault_entry, /* MemManage */
    [5] = sp_g4_fault_entry, /* BusFault */
    [6] = sp_g4_fault_entry, /* UsageFault */
    [11] = sp_g4_unexpected, /* SVCall */
    [12] = sp_g4_unexpected, /* DebugMonitor */
    [14] = sp_g4_unexpected, /* PendSV */
    [15] = sp_g4_systick_handler,
/* clang-format off */
    /* device interrupts 0..101 (entries 16..117): only FDCAN2/3 line 0,
     * and only in the CANopen image (fdcan.c); the rest is never enabled */
#define V4(n) [(n)] = sp_g4_unexpected, [(n) + 1] = sp_g4_unexpected, [(n) + 2] = sp_g4_unexpected, [(n) + 3] = sp_g4_unexpected
    V4(16), V4(20), V4(24), V4(28), V4(32), V4(36), V4(40), V4(44), V4(48), V4(52), V4(56), V4(60), V4(64),
    V4(68), V4(72), V4(76), V4(80), V4(84), V4(88), V4(92), V4(96),
    [100] = sp_g4_unexpected, [101] = sp_g4_unexpected,
    [102] = sp_g4_fdcan_drive_irq, /* 16 + 86: FDCAN2_IT0 */
    [103] = sp_g4_unexpected,
    [104] = sp_g4_fdcan_drive_irq, /* 16 + 88: FDCAN3_IT0 */
    [105] = sp_g4_unexpected, [106] = sp_g4_unexpected, [107] = sp_g4_unexpected,
    V4(108), V4(112),
    [116] = sp_g4_unexpected, [117] = sp_g4_unexpected,
#undef V4
    /* clang-format on */
};

__attribute__((noreturn)) void sp_g4_reset(void)
{
    uint32_t *src = sp_g4_data_load;
    uint32_t *dst = sp_g4_data_start;
    while (dst < sp_g4_data_end) {
        *dst++ = *src++;
    }
    for (dst = sp_g4_bss_start; dst < sp_g4_bss_end; ++dst) {
        *dst = 0u;
    }
    /* Paint the stack below the current frame (64 bytes of margin). */
    uint32_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (dst = sp_g4_stack_bottom; (uintptr_t)dst < sp - 64u; ++dst) {
        *dst = STACK_PAINT;
    }
    if (sp_g4_diag.magic != SP_G4_DIAG_MAGIC) { /* power-on: the record is garbage */
        sp_g4_diag.magic = SP_G4_DIAG_MAGIC;
        sp_g4_diag.reason = SP_G4_STOP_NONE;
        sp_g4_diag.cfsr = sp_g4_diag.hfsr = sp_g4_diag.bfar = 0u;
        sp_g4_diag.pc = sp_g4_diag.lr = 0u;
        sp_g4_diag.stops = 0u;
    }
    SCB_VTOR = (uint32_t)(uintptr_t)sp_g4_vectors;
    SCB_CCR |= SCB_CCR_DIV_0_TRP;
    sp_g4_reset_flags = RCC_CSR & RCC_CSR_RESET_FLAGS;
    RCC_CSR |= RCC_CSR_RMVF;
#if defined(__ARM_FP)
    SCB_CPACR |= (0xFu << 20); /* hard-float builds: CP10/CP11 full access before any FP code */
#endif
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    (void)main();
    sp_g4_stop(SP_G4_STOP_INIT);
}

uint32_t sp_g4_stack_high_water(void)
{
    const uint32_t *p = sp_g4_stack_bottom;
    while (p < sp_g4_stack_top && *p == STACK_PAINT) {
        ++p;
    }
    return (uint32_t)((uintptr_t)sp_g4_stack_top - (uintptr_t)p);
}

__attribute__((noreturn)) void sp_g4_stop(sp_g4_stop_t reason)
{
    __asm__ volatile("cpsid i" ::: "memory");
    /* LD2 first (one store to a clocked GPIO), then the buses. */
    RCC_AHB2ENR |= RCC_AHB2ENR_GPIOAEN;
    GPIO_MODER(G4_GPIOA) = (GPIO_MODER(G4_GPIOA) & ~(3u << 10)) | (1u << 10);
    GPIO_BSRR(G4_GPIOA) = 1u << 5;
    sp_g4_can_silence();
    sp_g4_diag.magic = SP_G4_DIAG_MAGIC;
    sp_g4_diag.reason = (uint32_t)reason;
    sp_g4_diag.cfsr = SCB_CFSR;
    sp_g4_diag.hfsr = SCB_HFSR;
    sp_g4_diag.bfar = SCB_BFAR;
    sp_g4_diag.stops++;
    __asm__ volatile("dsb" ::: "memory");
    /* The one unbounded loop: the independent watchdog ends it (about 10 ms
     * after the last kick) with a reset. */
    for (;;) {
        __asm__ volatile("nop");
    }
}

/* Fault entry: r0 = the stack the fault frame was pushed on, MSP back to the
 * top of the stack (the handler never returns), then C. */
__attribute__((naked, noreturn)) void sp_g4_fault_entry(void)
{
    __asm__ volatile("tst lr, #4\n\t"
                     "ite eq\n\t"
                     "mrseq r0, msp\n\t"
                     "mrsne r0, psp\n\t"
                     "movw r1, #:lower16:sp_g4_stack_top\n\t"
                     "movt r1, #:upper16:sp_g4_stack_top\n\t"
                     "msr msp, r1\n\t"
                     "isb\n\t"
                     "b sp_g4_fault_c\n\t");
}

__attribute__((noreturn)) void sp_g4_fault_c(const uint32_t *frame)
{
    uintptr_t f = (uintptr_t)frame;
    /* The frame is r0-r3, r12, lr, pc, xpsr: read it only if it lies in the stack. */
    if (f >= (uintptr_t)sp_g4_stack_bottom && f + 32u <= (uintptr_t)sp_g4_stack_top && (f & 3u) == 0u) {
        sp_g4_diag.lr = frame[5];
        sp_g4_diag.pc = frame[6];
    } else {
        sp_g4_diag.lr = 0u;
        sp_g4_diag.pc = 0u;
    }
    sp_g4_stop(SP_G4_STOP_FAULT);
}

__attribute__((noreturn)) void sp_g4_nmi(void)
{
    RCC_CICR = RCC_CICR_CSSC;
    sp_g4_stop(SP_G4_STOP_NMI);
}

__attribute__((noreturn)) void sp_g4_unexpected(void)
{
    sp_g4_stop(SP_G4_STOP_UNEXPECTED);
}
