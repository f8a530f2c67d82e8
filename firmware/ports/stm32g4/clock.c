/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clock.c - 170 MHz from the NUCLEO-G474RE's 24 MHz crystal (RM0440
 * chapter 7, RCC; chapter 6, PWR; chapter 3, flash access control).
 *
 *   HSE 24 MHz / M 6 = 4 MHz PLL input (allowed 2.66..16 MHz; 8 MHz / 2 with
 *     the SP_G4_HSE_MCO_8MHZ option)
 *   x N 85 = 340 MHz VCO (allowed 96..344 MHz)
 *   / R 2 = 170 MHz SYSCLK = HCLK = PCLK1 = PCLK2
 *   / Q 2 = 170 MHz FDCAN kernel clock
 *
 * Above 150 MHz the regulator must be in range 1 boost mode (PWR_CR5.R1MODE
 * = 0) and the flash needs 4 wait states (range 1 boost: 0 WS up to 34 MHz,
 * one more per 34 MHz, so 4 WS from 136 to 170 MHz; 4 WS are set before
 * the switch, so they are enough at every step). The manual's order for entering
 * boost mode: divide HCLK by 2 first, clear R1MODE, set the wait states,
 * switch to the new SYSCLK, wait at least 1 us, then restore the AHB
 * prescaler to 1.
 */
#include "g4_regs.h"
#include "sp_g4.h"

/* Board option: -DSP_G4_HSE_MCO_8MHZ for a NUCLEO modified to take the
 * ST-LINK's 8 MHz MCO on PF0 (HSE bypass) instead of the 24 MHz crystal;
 * M becomes 2 so that the PLL input stays 4 MHz and nothing else changes. */
#if defined(SP_G4_HSE_MCO_8MHZ)
#define HSE_BYPASS RCC_CR_HSEBYP
#define PLLM_DIV 2u
#else
#define HSE_BYPASS 0u
#define PLLM_DIV 6u
#endif

/* Spin bounds: at most 16 MHz (HSI16, reset clock) or 170 MHz, a few cycles
 * per iteration. HSE start-up is a few ms on this board; the bound is about
 * 100 ms at 16 MHz. */
#define SPIN_HSE 400000u
#define SPIN_SHORT 100000u

static int wait_set(volatile uint32_t *reg, uint32_t mask, uint32_t value, uint32_t bound)
{
    for (uint32_t i = 0; i < bound; i++) {
        if ((*reg & mask) == value) {
            return 1;
        }
    }
    return 0;
}

static void delay_loops(uint32_t n)
{
    for (volatile uint32_t i = 0; i < n; i++) {
    }
}

sp_status_t sp_g4_clock_init(void)
{
    RCC_APB1ENR1 |= RCC_APB1ENR1_PWREN;
    (void)RCC_APB1ENR1; /* read back: the enable takes effect before PWR is touched */

    /* Crystal (not bypass) by default: the NUCLEO-G474RE has X3 = 24 MHz
     * (see docs/reference/stm32g4.md). HSEBYP may only change while the HSE is off. */
    RCC_CR = (RCC_CR & ~(RCC_CR_HSEBYP | RCC_CR_HSEON)) | HSE_BYPASS;
    RCC_CR |= RCC_CR_HSEON;
    if (!wait_set(&RCC_CR, RCC_CR_HSERDY, RCC_CR_HSERDY, SPIN_HSE)) {
        RCC_CR &= ~RCC_CR_HSEON;
        return SP_E_IO;
    }

    /* Range 1 (the reset value; made explicit), wait for the regulator. */
    PWR_CR1 = (PWR_CR1 & ~PWR_CR1_VOS_MASK) | PWR_CR1_VOS_RANGE1;
    if (!wait_set(&PWR_SR2, PWR_SR2_VOSF, 0u, SPIN_SHORT)) {
        return SP_E_IO;
    }

    /* Boost mode: HCLK / 2 first, then R1MODE = 0, then wait states. */
    RCC_CFGR = (RCC_CFGR & ~RCC_CFGR_HPRE_MASK) | RCC_CFGR_HPRE_DIV2;
    PWR_CR5 &= ~PWR_CR5_R1MODE;
    FLASH_ACR = (FLASH_ACR & ~FLASH_ACR_LATENCY_MASK) | 4u | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
    if (!wait_set(&FLASH_ACR, FLASH_ACR_LATENCY_MASK, 4u, SPIN_SHORT)) {
        return SP_E_IO;
    }

    /* PLL (off after reset): HSE / 6 * 85, R / 2 and Q / 2 enabled. */
    RCC_CR &= ~RCC_CR_PLLON;
    if (!wait_set(&RCC_CR, RCC_CR_PLLRDY, 0u, SPIN_SHORT)) {
        return SP_E_IO;
    }
    RCC_PLLCFGR = RCC_PLLCFGR_PLLSRC_HSE | ((PLLM_DIV - 1u) << RCC_PLLCFGR_PLLM_SHIFT) |
                  (85u << RCC_PLLCFGR_PLLN_SHIFT) | RCC_PLLCFGR_PLLREN | (0u << RCC_PLLCFGR_PLLR_SHIFT) |
                  RCC_PLLCFGR_PLLQEN | (0u << RCC_PLLCFGR_PLLQ_SHIFT);
    RCC_CR |= RCC_CR_PLLON;
    if (!wait_set(&RCC_CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY, SPIN_SHORT)) {
        return SP_E_IO;
    }

    /* Switch SYSCLK to the PLL (HCLK still 85 MHz), APB1 and APB2 / 1. */
    RCC_CFGR = (RCC_CFGR & ~(RCC_CFGR_SW_MASK | RCC_CFGR_PPRE1_MASK | RCC_CFGR_PPRE2_MASK)) | RCC_CFGR_SW_PLL;
    if (!wait_set(&RCC_CFGR, RCC_CFGR_SW_MASK << RCC_CFGR_SWS_SHIFT, RCC_CFGR_SW_PLL << RCC_CFGR_SWS_SHIFT,
                  SPIN_SHORT)) {
        return SP_E_IO;
    }
    delay_loops(200u);               /* >= 1 us at 85 MHz (each iteration is several cycles) */
    RCC_CFGR &= ~RCC_CFGR_HPRE_MASK; /* HCLK = SYSCLK = 170 MHz */

    /* Clock security system: an HSE failure switches SYSCLK to HSI16 and
     * raises an NMI (the port's NMI handler enters the safe state, since the
     * CAN bit timing is then wrong). */
    RCC_CR |= RCC_CR_CSSON;

    /* FDCAN kernel clock = PLL "Q" = 170 MHz, no further division. */
    RCC_CCIPR = (RCC_CCIPR & ~RCC_CCIPR_FDCANSEL_MASK) | RCC_CCIPR_FDCANSEL_PLLQ;
    return SP_OK;
}
