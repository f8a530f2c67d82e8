/* SPDX-License-Identifier: Apache-2.0 */
/*
 * g4_regs.h - the few STM32G474 and Cortex-M4 registers the port uses,
 * written from ST's reference manual RM0440 (STM32G4 series) and ARM's
 * ARMv7-M architecture reference manual. No vendor header is used: every
 * address and bit below names the manual section it comes from.
 *
 * Access: SP_REG(addr) is a volatile 32-bit register. All peripheral
 * registers (and the FDCAN message RAM) are accessed as 32-bit words.
 */
#ifndef SP_G4_REGS_H
#define SP_G4_REGS_H

#include <stdint.h>

#define SP_REG(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* ---- Memory map (RM0440, memory organisation: memory map) -------------------------------- */
#define G4_FLASH_BASE 0x08000000u /* main flash, 512 KiB on the G474RE */
#define G4_SRAM1_BASE 0x20000000u /* SRAM1 80 KiB, then SRAM2 16 KiB, then CCM alias */

/* ---- RCC, reset and clock control (RM0440 7.4), base 0x4002 1000 -------- */
#define G4_RCC 0x40021000u
#define RCC_CR SP_REG(G4_RCC + 0x00u)
#define RCC_CR_HSION (1u << 8)
#define RCC_CR_HSIRDY (1u << 10)
#define RCC_CR_HSEON (1u << 16)
#define RCC_CR_HSERDY (1u << 17)
#define RCC_CR_HSEBYP (1u << 18)
#define RCC_CR_CSSON (1u << 19)
#define RCC_CR_PLLON (1u << 24)
#define RCC_CR_PLLRDY (1u << 25)
#define RCC_CFGR SP_REG(G4_RCC + 0x08u)
#define RCC_CFGR_SW_MASK 3u /* SW[1:0] system clock switch */
#define RCC_CFGR_SW_HSI16 1u
#define RCC_CFGR_SW_PLL 3u
#define RCC_CFGR_SWS_SHIFT 2u  /* SWS[3:2] switch status, same coding */
#define RCC_CFGR_HPRE_SHIFT 4u /* HPRE[7:4]: 0xxx = /1, 1000 = /2 */
#define RCC_CFGR_HPRE_MASK (0xFu << 4)
#define RCC_CFGR_HPRE_DIV2 (0x8u << 4)
#define RCC_CFGR_PPRE1_MASK (7u << 8)  /* PPRE1[10:8]: 0xx = /1 */
#define RCC_CFGR_PPRE2_MASK (7u << 11) /* PPRE2[13:11]: 0xx = /1 */
#define RCC_PLLCFGR SP_REG(G4_RCC + 0x0Cu)
#define RCC_PLLCFGR_PLLSRC_HSE 3u /* PLLSRC[1:0] = 11: HSE */
#define RCC_PLLCFGR_PLLM_SHIFT 4u /* PLLM[7:4]: divide by PLLM + 1 */
#define RCC_PLLCFGR_PLLN_SHIFT 8u /* PLLN[14:8]: multiply by PLLN (8..127) */
#define RCC_PLLCFGR_PLLQEN (1u << 20)
#define RCC_PLLCFGR_PLLQ_SHIFT 21u /* PLLQ[22:21]: 00 = /2, 01 = /4, 10 = /6, 11 = /8 */
#define RCC_PLLCFGR_PLLREN (1u << 24)
#define RCC_PLLCFGR_PLLR_SHIFT 25u /* PLLR[26:25]: same coding as PLLQ */
#define RCC_CIFR SP_REG(G4_RCC + 0x1Cu)
#define RCC_CICR SP_REG(G4_RCC + 0x20u)
#define RCC_CICR_CSSC (1u << 8)
#define RCC_APB1RSTR1 SP_REG(G4_RCC + 0x38u)
#define RCC_AHB2ENR SP_REG(G4_RCC + 0x4Cu)
#define RCC_AHB2ENR_GPIOAEN (1u << 0)
#define RCC_AHB2ENR_GPIOBEN (1u << 1)
#define RCC_AHB2ENR_RNGEN (1u << 26)
#define RCC_CRRCR SP_REG(G4_RCC + 0x98u) /* clock recovery RC register: HSI48 */
#define RCC_CRRCR_HSI48ON (1u << 0)
#define RCC_CRRCR_HSI48RDY (1u << 1)
#define RCC_CCIPR_CLK48SEL_MASK (3u << 26) /* CLK48SEL[27:26]: 00 HSI48 (the RNG's clock) */

/* ---- RNG, the true random number generator (RM0440 26.7), base 0x5006 0800 */
#define G4_RNG 0x50060800u
#define RNG_CR SP_REG(G4_RNG + 0x00u)
#define RNG_CR_RNGEN (1u << 2)
#define RNG_SR SP_REG(G4_RNG + 0x04u)
#define RNG_SR_DRDY (1u << 0)
#define RNG_SR_CECS (1u << 1) /* clock error */
#define RNG_SR_SECS (1u << 2) /* seed error */
#define RNG_DR SP_REG(G4_RNG + 0x08u)
#define RCC_APB1ENR1 SP_REG(G4_RCC + 0x58u)
#define RCC_APB1ENR1_FDCANEN (1u << 25)
#define RCC_APB1ENR1_PWREN (1u << 28)
#define RCC_APB1RSTR1_FDCANRST (1u << 25)
#define RCC_CCIPR SP_REG(G4_RCC + 0x88u)
#define RCC_CCIPR_FDCANSEL_MASK (3u << 24) /* FDCANSEL[25:24]: 00 HSE, 01 PLL "Q", 10 PCLK1 */
#define RCC_CCIPR_FDCANSEL_PLLQ (1u << 24)
#define RCC_CSR SP_REG(G4_RCC + 0x94u)
#define RCC_CSR_RMVF (1u << 23)         /* write 1: clear the reset flags */
#define RCC_CSR_RESET_FLAGS 0xFE000000u /* OBL, PIN, BOR, SFT, IWDG, WWDG, LPWR reset flags [31:25] */
#define RCC_CSR_IWDGRSTF (1u << 29)

/* ---- PWR, power control (RM0440 6.4), base 0x4000 7000 ------------------ */
#define G4_PWR 0x40007000u
#define PWR_CR1 SP_REG(G4_PWR + 0x00u)
#define PWR_CR1_VOS_MASK (3u << 9) /* VOS[10:9]: 01 = range 1 (reset value) */
#define PWR_CR1_VOS_RANGE1 (1u << 9)
#define PWR_SR2 SP_REG(G4_PWR + 0x14u)
#define PWR_SR2_VOSF (1u << 10) /* 1 while the regulator changes voltage */
#define PWR_CR5 SP_REG(G4_PWR + 0x80u)
#define PWR_CR5_R1MODE (1u << 8) /* 1 = range 1 normal, 0 = range 1 boost (needed above 150 MHz) */

/* ---- Flash interface (RM0440 3.7.1 FLASH_ACR), base 0x4002 2000 ---------- */
#define G4_FLASH_R 0x40022000u
#define FLASH_ACR SP_REG(G4_FLASH_R + 0x00u)
#define FLASH_ACR_LATENCY_MASK 0xFu /* LATENCY[3:0]: wait states */
#define FLASH_ACR_PRFTEN (1u << 8)
#define FLASH_ACR_ICEN (1u << 9)
#define FLASH_ACR_DCEN (1u << 10)

/* ---- GPIO (RM0440 9.4) --------------------------------------------------- */
#define G4_GPIOA 0x48000000u
#define G4_GPIOB 0x48000400u
#define GPIO_MODER(p) SP_REG((p) + 0x00u)   /* 2 bits per pin: 00 in, 01 out, 10 AF, 11 analog */
#define GPIO_OTYPER(p) SP_REG((p) + 0x04u)  /* 0 push-pull */
#define GPIO_OSPEEDR(p) SP_REG((p) + 0x08u) /* 2 bits per pin: 00 low .. 11 very high */
#define GPIO_PUPDR(p) SP_REG((p) + 0x0Cu)   /* 2 bits per pin: 00 none, 01 up, 10 down */
#define GPIO_BSRR(p) SP_REG((p) + 0x18u)    /* [15:0] set, [31:16] reset */
#define GPIO_AFRL(p) SP_REG((p) + 0x20u)    /* 4 bits per pin 0..7 */
#define GPIO_AFRH(p) SP_REG((p) + 0x24u)    /* 4 bits per pin 8..15 */
#define GPIO_ODR(p) SP_REG((p) + 0x14u)

/* ---- IWDG, independent watchdog (RM0440, IWDG chapter: IWDG registers), base 0x4000 3000 ---------- */
#define G4_IWDG 0x40003000u
#define IWDG_KR SP_REG(G4_IWDG + 0x00u)
#define IWDG_KR_START 0xCCCCu  /* starts the watchdog (and the LSI) */
#define IWDG_KR_UNLOCK 0x5555u /* enables writes to PR and RLR */
#define IWDG_KR_REFRESH 0xAAAAu
#define IWDG_PR SP_REG(G4_IWDG + 0x04u)  /* PR[2:0]: LSI / 4 << PR */
#define IWDG_RLR SP_REG(G4_IWDG + 0x08u) /* RL[11:0] */
#define IWDG_SR SP_REG(G4_IWDG + 0x0Cu)  /* PVU bit 0, RVU bit 1, WVU bit 2: update in progress */

/* ---- FDCAN (RM0440, FDCAN chapter: FDCAN registers); instances at 0x4000 6400 / 6800 / 6C00 ---------- */
#define G4_FDCAN1 0x40006400u
#define G4_FDCAN2 0x40006800u
#define G4_FDCAN3 0x40006C00u
#define G4_FDCAN_CONFIG 0x40006500u                 /* FDCAN_CKDIV (shared by the three instances) */
#define FDCAN_CKDIV SP_REG(G4_FDCAN_CONFIG + 0x00u) /* PDIV[3:0]: 0000 = kernel clock / 1 */
#define FDCAN_DBTP(b) SP_REG((b) + 0x00Cu)
#define FDCAN_DBTP_TDC (1u << 23)
#define FDCAN_CCCR(b) SP_REG((b) + 0x018u)
#define FDCAN_CCCR_INIT (1u << 0)
#define FDCAN_CCCR_CCE (1u << 1)
#define FDCAN_CCCR_FDOE (1u << 8)
#define FDCAN_CCCR_BRSE (1u << 9)
#define FDCAN_NBTP(b) SP_REG((b) + 0x01Cu)
#define FDCAN_ECR(b) SP_REG((b) + 0x040u)
#define FDCAN_ECR_CEL_SHIFT 16u /* CEL[23:16]: error logging counter, cleared by reading ECR */
#define FDCAN_PSR(b) SP_REG((b) + 0x044u)
#define FDCAN_PSR_EP (1u << 5)
#define FDCAN_PSR_BO (1u << 7)
#define FDCAN_TDCR(b) SP_REG((b) + 0x048u) /* TDCF[6:0], TDCO[14:8] */
#define FDCAN_IR(b) SP_REG((b) + 0x050u)
#define FDCAN_IR_RF0N (1u << 0) /* Rx FIFO 0 new message (G4 bit layout; IE has the same) */
#define FDCAN_IR_RF0L (1u << 2) /* Rx FIFO 0 message lost (G4 bit layout) */
#define FDCAN_IR_RF1N (1u << 3) /* Rx FIFO 1 new message */
#define FDCAN_IR_RF1L (1u << 5) /* Rx FIFO 1 message lost */
#define FDCAN_IE(b) SP_REG((b) + 0x054u)
#define FDCAN_ILE(b) SP_REG((b) + 0x05Cu)
#define FDCAN_ILS(b) SP_REG((b) + 0x058u) /* 0: every interrupt group on line 0 (IT0) */
#define FDCAN_ILE_EINT0 (1u << 0)
#define FDCAN_RXGFC(b) SP_REG((b) + 0x080u)
#define FDCAN_RXGFC_RRFE (1u << 0)          /* reject remote frames, extended */
#define FDCAN_RXGFC_RRFS (1u << 1)          /* reject remote frames, standard */
#define FDCAN_RXGFC_ANFE_REJECT (2u << 2)   /* non-matching extended frames: reject */
#define FDCAN_RXGFC_ANFS_REJECT (2u << 4)   /* non-matching standard frames: reject */
#define FDCAN_RXGFC_LSS_SHIFT 16u           /* LSS[20:16]: standard filter elements in use (0..28) */
#define FDCAN_RXGFC_LSE_SHIFT 24u           /* LSE[27:24]: extended filter elements in use (0..8) */
#define FDCAN_RXF0S(b) SP_REG((b) + 0x090u) /* F0FL[3:0] fill level, F0GI[9:8] get index */
#define FDCAN_RXF0A(b) SP_REG((b) + 0x094u)
#define FDCAN_RXF1S(b) SP_REG((b) + 0x098u)
#define FDCAN_RXF1A(b) SP_REG((b) + 0x09Cu)
#define FDCAN_TXBC(b) SP_REG((b) + 0x0C0u)  /* TFQM bit 24: 0 = Tx FIFO (send in write order) */
#define FDCAN_TXFQS(b) SP_REG((b) + 0x0C4u) /* TFFL[2:0] free, TFQPI[17:16] put index, TFQF bit 21 full */
#define FDCAN_TXFQS_TFQF (1u << 21)
#define FDCAN_TXBRP(b) SP_REG((b) + 0x0C8u) /* TRP[2:0]: transmission request pending */
#define FDCAN_TXBAR(b) SP_REG((b) + 0x0CCu) /* AR[2:0]: add request */
#define FDCAN_TXBCR(b) SP_REG((b) + 0x0D0u) /* CR[2:0]: cancellation request */

/* FDCAN message RAM (RM0440, FDCAN chapter: message RAM): fixed layout, 212 words per instance,
 * instance n at 0x4000 A400 + n * 0x350. Offsets in bytes: */
#define G4_SRAMCAN 0x4000A400u
#define G4_SRAMCAN_SIZE 0x350u /* 212 words */
#define SRAMCAN_FLSSA 0x000u   /* 28 standard filters, 1 word each */
#define SRAMCAN_FLESA 0x070u   /* 8 extended filters, 2 words each */
#define SRAMCAN_RF0SA 0x0B0u   /* Rx FIFO 0: 3 elements */
#define SRAMCAN_RF1SA 0x188u   /* Rx FIFO 1: 3 elements */
#define SRAMCAN_TEFSA 0x260u   /* Tx event FIFO: 3 elements, 2 words each */
#define SRAMCAN_TFQSA 0x278u   /* Tx FIFO/queue: 3 elements */
#define SRAMCAN_ELEM 72u       /* Rx/Tx element: 2 header words + 64 data bytes = 18 words */
#define SRAMCAN_FIFO_DEPTH 3u

/* ---- Cortex-M4 system control space (ARMv7-M ARM B3.2, B3.3, C1.8) ------- */
/* NVIC: set-enable bit n % 32 of word n / 32; one priority byte per interrupt */
#define NVIC_ISER(n) SP_REG(0xE000E100u + 4u * ((n) / 32u))
#define NVIC_IPR_BYTE(n) (*(volatile uint8_t *)(uintptr_t)(0xE000E400u + (n)))
#define G4_IRQ_FDCAN2_IT0 86u /* RM0440 vector table: FDCAN2 interrupt 0 */
#define G4_IRQ_FDCAN3_IT0 88u /* FDCAN3 interrupt 0 */
#define SCB_VTOR SP_REG(0xE000ED08u)
#define SCB_CPACR SP_REG(0xE000ED88u)
#define SCB_CCR SP_REG(0xE000ED14u)
#define SCB_CCR_DIV_0_TRP (1u << 4)
#define SCB_SHPR3 SP_REG(0xE000ED20u) /* PRI_15 (SysTick) [31:24] */
#define SCB_CFSR SP_REG(0xE000ED28u)
#define SCB_HFSR SP_REG(0xE000ED2Cu)
#define SCB_BFAR SP_REG(0xE000ED38u)
#define SYST_CSR SP_REG(0xE000E010u) /* ENABLE bit 0, TICKINT bit 1, CLKSOURCE bit 2 (core clock) */
#define SYST_RVR SP_REG(0xE000E014u) /* 24-bit reload */
#define SYST_CVR SP_REG(0xE000E018u)
#define DEMCR SP_REG(0xE000EDFCu)
#define DEMCR_TRCENA (1u << 24)
#define DWT_CTRL SP_REG(0xE0001000u)
#define DWT_CTRL_CYCCNTENA (1u << 0)
#define DWT_CYCCNT SP_REG(0xE0001004u)

/* ---- DBGMCU (RM0440, debug chapter: DBGMCU_APB1FZR1): freeze the IWDG while the core is halted ---- */
#define DBGMCU_APB1FZR1 SP_REG(0xE0042008u)
#define DBGMCU_APB1FZR1_IWDG_STOP (1u << 12)

#endif /* SP_G4_REGS_H */
