/* SPDX-License-Identifier: Apache-2.0 */
/*
 * mps2.c - semihosting output and exit, SysTick instruction counter and
 * stack high-water mark of the mps2-an386 port (see sp_mps2.h).
 */
#include "sp_mps2.h"

#define SYS_OPEN 0x01
#define SYS_WRITE 0x05
#define SYS_EXIT_EXTENDED 0x20
#define ADP_STOPPED_APPLICATION_EXIT 0x20026

#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

#define STACK_PATTERN UINT32_C(0x5AA5C33C)

extern uint32_t sp_mps2_stack_bottom[];

/* One semihosting call: operation in r0, argument block address in r1,
 * result in r0. BKPT 0xAB is the M-profile semihosting trap. */
static int32_t semihost(int32_t op, const void *arg)
{
    register int32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

static int32_t stdout_handle = -1;

int sp_mps2_write(const char *buf, size_t len)
{
    uint32_t block[3];

    if (stdout_handle < 0) {
        static const char tt[] = ":tt";
        uint32_t open_block[3];
        open_block[0] = (uint32_t)(uintptr_t)tt;
        open_block[1] = 4u; /* mode "w": the console's output stream */
        open_block[2] = (uint32_t)(sizeof tt - 1u);
        stdout_handle = semihost(SYS_OPEN, open_block);
        if (stdout_handle < 0) {
            return -1;
        }
    }
    if (len == 0u) {
        return 0;
    }
    block[0] = (uint32_t)stdout_handle;
    block[1] = (uint32_t)(uintptr_t)buf;
    block[2] = (uint32_t)len;
    return (semihost(SYS_WRITE, block) == 0) ? 0 : -1; /* returns bytes NOT written */
}

void sp_mps2_exit(int status)
{
    uint32_t block[2];
    block[0] = ADP_STOPPED_APPLICATION_EXIT;
    block[1] = (uint32_t)status;
    for (;;) {
        (void)semihost(SYS_EXIT_EXTENDED, block);
    }
}

void sp_mps2_counter_start(void)
{
    SYST_CSR = 0u;
    SYST_RVR = 0x00FFFFFFu;
    SYST_CVR = 0u; /* any write clears the counter; it reloads on the next count */
    SYST_CSR = 5u; /* ENABLE | CLKSOURCE (core clock), no interrupt */
    while (SYST_CVR == 0u) {
    }
}

uint32_t sp_mps2_counter_now(void)
{
    return SYST_CVR;
}

uint32_t sp_mps2_counter_elapsed(uint32_t earlier, uint32_t later)
{
    return (earlier - later) & 0x00FFFFFFu;
}

uintptr_t sp_mps2_stack_pointer(void)
{
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    return sp;
}

__attribute__((noinline)) void sp_mps2_stack_paint(void)
{
    volatile uint32_t *p = sp_mps2_stack_bottom;
    uintptr_t limit = sp_mps2_stack_pointer() - 256u;
    while ((uintptr_t)p < limit) {
        *p++ = STACK_PATTERN;
    }
}

uint32_t sp_mps2_stack_used(uintptr_t top)
{
    const volatile uint32_t *p = sp_mps2_stack_bottom;
    while ((uintptr_t)p < top && *p == STACK_PATTERN) {
        ++p;
    }
    return (uint32_t)(top - (uintptr_t)p);
}
