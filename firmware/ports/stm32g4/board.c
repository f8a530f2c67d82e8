/* SPDX-License-Identifier: Apache-2.0 */
/*
 * board.c - LD2, the 1 kHz tick (SysTick) and the independent watchdog of
 * the NUCLEO-G474RE port.
 */
#include <stddef.h>

#include "g4_regs.h"
#include "sp_g4.h"

#define LED_PORT G4_GPIOA
#define LED_PIN 5u /* LD2, green, active high (NUCLEO-64 user manual: PA5) */

void sp_g4_led_init(void)
{
    RCC_AHB2ENR |= RCC_AHB2ENR_GPIOAEN;
    (void)RCC_AHB2ENR;
    GPIO_BSRR(LED_PORT) = 1u << (LED_PIN + 16u);
    GPIO_OTYPER(LED_PORT) &= ~(1u << LED_PIN);
    GPIO_MODER(LED_PORT) = (GPIO_MODER(LED_PORT) & ~(3u << (2u * LED_PIN))) | (1u << (2u * LED_PIN));
}

void sp_g4_led_set(int on)
{
    GPIO_BSRR(LED_PORT) = on ? (1u << LED_PIN) : (1u << (LED_PIN + 16u));
}

/* ---- RNG ----------------------------------------------------------------- */

sp_status_t sp_g4_random_u32(uint32_t *out)
{
    if (out == NULL) {
        return SP_E_ARG;
    }
    RCC_CRRCR |= RCC_CRRCR_HSI48ON;
    for (uint32_t i = 0; i < 100000u && (RCC_CRRCR & RCC_CRRCR_HSI48RDY) == 0u; i++) {
    }
    if ((RCC_CRRCR & RCC_CRRCR_HSI48RDY) == 0u) {
        return SP_E_IO;
    }
    RCC_CCIPR &= ~RCC_CCIPR_CLK48SEL_MASK; /* HSI48 */
    RCC_AHB2ENR |= RCC_AHB2ENR_RNGEN;
    (void)RCC_AHB2ENR;
    RNG_CR |= RNG_CR_RNGEN;
    for (uint32_t i = 0; i < 100000u; i++) {
        uint32_t sr = RNG_SR;
        if ((sr & (RNG_SR_CECS | RNG_SR_SECS)) != 0u) {
            return SP_E_IO;
        }
        if ((sr & RNG_SR_DRDY) != 0u) {
            *out = RNG_DR;
            return SP_OK;
        }
    }
    return SP_E_IO;
}

/* ---- tick ---------------------------------------------------------------- */

static volatile uint32_t g_ticks; /* incremented by SysTick only */
static uint32_t g_next;           /* the tick the caller waits for next */

void sp_g4_systick_handler(void); /* vector table (startup.c) */
void sp_g4_systick_handler(void)
{
    g_ticks = g_ticks + 1u;
}

void sp_g4_tick_init(void)
{
    DEMCR |= DEMCR_TRCENA;
    DWT_CYCCNT = 0u;
    DWT_CTRL |= DWT_CTRL_CYCCNTENA;

    SCB_SHPR3 = (SCB_SHPR3 & 0x00FFFFFFu) | (0x00u << 24); /* SysTick: highest configurable priority */
    SYST_RVR = SP_G4_SYSCLK_HZ / SP_G4_TICK_HZ - 1u;       /* 169,999: fits 24 bits */
    SYST_CVR = 0u;
    g_ticks = 0u;
    g_next = 1u;
    SYST_CSR = 7u; /* core clock, interrupt, enable */
}

uint32_t sp_g4_ticks(void)
{
    return g_ticks;
}

uint32_t sp_g4_cycles(void)
{
    return DWT_CYCCNT;
}

static sp_status_t tick_wait(void *ctx, uint32_t *missed)
{
    (void)ctx;
    if (missed == NULL) {
        return SP_E_ARG;
    }
    /* The tick we wait for (g_next) has already begun: the last cycle
     * overran. Its boundary and any later one that passed are counted as
     * missed, and we wait for the next boundary, so that cycles (and SYNC)
     * always start on a SysTick edge, never late. */
    uint32_t now = g_ticks;
    *missed = 0u;
    if ((int32_t)(now - g_next) >= 0) {
        *missed = now - g_next + 1u;
        g_next = now + 1u;
    }
    /* Sleep until g_ticks reaches g_next. Interrupts are masked around the
     * test and the WFI, so a SysTick between them still wakes the WFI (a
     * pending interrupt ends WFI even while PRIMASK is set) and cannot be
     * slept through; it runs at cpsie. Each pass is one wake-up. */
    for (uint32_t i = 0; i < (1u << 20); i++) {
        __asm__ volatile("cpsid i" ::: "memory");
        int32_t ahead = (int32_t)(g_next - g_ticks);
        if (ahead > 0) {
            __asm__ volatile("dsb\n\twfi" ::: "memory");
        }
        __asm__ volatile("cpsie i\n\tisb" ::: "memory");
        if (ahead <= 0) {
            g_next++;
            return SP_OK;
        }
    }
    return SP_E_IO;
}

sp_tick_port_t sp_g4_tick_port(void)
{
    sp_tick_port_t p;
    p.ctx = NULL;
    p.wait = tick_wait;
    return p;
}

/* ---- independent watchdog -------------------------------------------------- */

sp_status_t sp_g4_watchdog_start(void)
{
    DBGMCU_APB1FZR1 |= DBGMCU_APB1FZR1_IWDG_STOP;
    IWDG_KR = IWDG_KR_START;
    IWDG_KR = IWDG_KR_UNLOCK;
    IWDG_PR = 0u; /* LSI / 4: 8 kHz, 125 us per count */
    IWDG_RLR = SP_G4_IWDG_RELOAD;
    /* The new values reach the LSI domain after a few LSI cycles. */
    for (uint32_t i = 0; i < 1000000u; i++) {
        if ((IWDG_SR & 7u) == 0u) {
            IWDG_KR = IWDG_KR_REFRESH;
            return SP_OK;
        }
    }
    return SP_E_IO;
}

static sp_status_t watchdog_kick(void *ctx)
{
    (void)ctx;
    IWDG_KR = IWDG_KR_REFRESH;
    return SP_OK;
}

sp_watchdog_port_t sp_g4_watchdog_port(void)
{
    sp_watchdog_port_t p;
    p.ctx = NULL;
    p.kick = watchdog_kick;
    return p;
}
