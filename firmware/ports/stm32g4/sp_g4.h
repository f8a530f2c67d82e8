/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_g4.h - the NUCLEO-G474RE port (STM32G474RE, Cortex-M4, 170 MHz): the
 * implementations of sp/link/port.h (CAN on the three FDCAN controllers, the
 * 1 kHz tick, the independent watchdog) and the board's clocks, LED and
 * safe state. docs/reference/stm32g4.md describes the board, the pins and the
 * figures.
 *
 * Every function that can fail returns an sp_status_t; no function blocks
 * for longer than its stated bound. No heap, no floating point.
 */
#ifndef SP_G4_H
#define SP_G4_H

#include <stdint.h>

#include "sp/canopen/canopen_master.h"
#include "sp/link/port.h"

/* ---- clocks (clock.c) ---- */

#define SP_G4_HSE_HZ 24000000u     /**< NUCLEO-G474RE crystal X3 */
#define SP_G4_SYSCLK_HZ 170000000u /**< SYSCLK = HCLK = PCLK1 = PCLK2 */
#define SP_G4_FDCAN_HZ 170000000u  /**< FDCAN kernel clock (PLL "Q" output) */
#define SP_G4_TICK_HZ 1000u        /**< control tick */

/**
 * HSE 24 MHz crystal -> PLL (M = 6, N = 85: 340 MHz VCO) -> R / 2 = 170 MHz
 * SYSCLK, Q / 2 = 170 MHz FDCAN kernel clock; range 1 boost mode, 4 flash
 * wait states, prefetch and caches on; clock security system on (HSE loss
 * raises an NMI, which the port treats as a fault). Every wait is bounded:
 * SP_E_IO if the HSE or the PLL does not start (the clock is then left on
 * HSI16 and the caller must not start CAN).
 */
sp_status_t sp_g4_clock_init(void);

/* ---- board (board.c) ---- */

/** LD2 (PA5) as a push-pull output, off. */
void sp_g4_led_init(void);

/** A 32-bit value from the RNG peripheral (HSI48-clocked; the session value
 *  of command authentication, docs/explanation/security.md). Polls at most about 10^5
 *  times: SP_OK, or SP_E_IO when the RNG reports a clock or seed error or
 *  gives no value (the caller starts without authentication: motion refused). */
sp_status_t sp_g4_random_u32(uint32_t *out);
/** Sets LD2 on (on != 0) or off. */
void sp_g4_led_set(int on);

/** Starts SysTick at SP_G4_TICK_HZ from the 170 MHz core clock and the DWT
 *  cycle counter (cycles are read with sp_g4_cycles). */
void sp_g4_tick_init(void);
/** The tick port: wait() sleeps (WFI) until the next SysTick edge and
 *  returns right after it. If the tick it should have waited for had already
 *  begun (the caller's last cycle overran), that tick and any later one that
 *  passed are skipped and counted in *missed, and it waits for the next
 *  edge: cycles always start on an edge. SP_E_IO after 2^20 wake-ups
 *  without a tick (spurious wake-ups only: a stopped SysTick leaves WFI
 *  asleep, and the independent watchdog, no longer kicked, resets the chip). */
sp_tick_port_t sp_g4_tick_port(void);
/** Ticks since sp_g4_tick_init (wraps at 2^32, 49 days). */
uint32_t sp_g4_ticks(void);
/** The DWT cycle counter (170 MHz, wraps every 25 s). */
uint32_t sp_g4_cycles(void);

/**
 * Starts the independent watchdog: LSI (32 kHz nominal) / 4, reload
 * SP_G4_IWDG_RELOAD: a reset 10 ms (9.4 to 10.9 ms over the LSI's
 * tolerance) after the last kick. Once started it cannot be stopped. It is
 * frozen while a debugger halts the core. SP_E_IO if the prescaler or
 * reload update does not complete within its bound.
 */
#define SP_G4_IWDG_RELOAD 79u
sp_status_t sp_g4_watchdog_start(void);
/** The watchdog port: kick() refreshes the IWDG. */
sp_watchdog_port_t sp_g4_watchdog_port(void);

/* ---- CAN (fdcan.c) ---- */

/** FDCAN1 = ops (PA11 RX, PA12 TX, AF9), FDCAN2 = axis_a (PB12 RX, PB13 TX,
 *  AF9), FDCAN3 = axis_b (PA8 RX, PA15 TX, AF11). */
typedef struct {
    sp_bus_status_t status[SP_CAN_BUSES];
    uint32_t recover_wait[SP_CAN_BUSES]; /**< ticks until the next bus-off recovery attempt */
    uint32_t bus_off_recoveries[SP_CAN_BUSES];
    uint32_t tx_stale_cancelled[SP_CAN_BUSES]; /**< frames still pending a tick later, cancelled */
} sp_g4_can_t;

/**
 * Pins, kernel clock, bit timing (1 Mbit/s nominal, 5 Mbit/s data with bit
 * rate switch, transmitter delay compensation), receive filters (only what
 * the controller consumes: OP_COMMAND, OP_TARGET_POSE and OP_HEARTBEAT on ops, the three
 * AXIS_FEEDBACK identifiers on each axis bus; everything else is rejected
 * by the hardware), Tx FIFO mode (frames leave in the order they were
 * queued: setpoints before SYNC), then leaves initialisation mode on the
 * three controllers. SP_E_IO if a controller does not enter or leave
 * initialisation mode within its bound.
 */
sp_status_t sp_g4_can_init(sp_g4_can_t *can);

/**
 * As sp_g4_can_init, with the two drive buses as CANopen buses when co is
 * not NULL (the CiA 408 image, SP_DRIVE_PROTOCOL=cia408): classic CAN at
 * bitrate[bus] bit/s (170 tq per bit: 1 Mbit/s and its whole divisors;
 * NULL: 1 Mbit/s), and per configured node of the bus its TPDO1 and EMCY
 * (Rx FIFO 0), TPDO2 and heartbeat (FIFO 1) and SDO answer (FIFO 0). The ops
 * bus stays as sp_g4_can_init sets it. SP_E_ARG for a bit rate without a
 * whole prescaler (800 kbit/s), SP_E_IO as sp_g4_can_init.
 */
sp_status_t sp_g4_can_init_canopen(sp_g4_can_t *can, const sp_co_master_cfg_t *co, const uint32_t *bitrate);

/**
 * Interrupt handler of FDCAN2 and FDCAN3 line 0 (vector table), enabled
 * only on CANopen drive buses: moves the frames of both Rx FIFOs into the
 * bus's 16-frame receive queue, which the port's receive reads; a frame
 * that finds the queue full is counted in rx_overruns.
 */
void sp_g4_fdcan_drive_irq(void);

/** Free elements of the bus's Tx FIFO (0..3; 0 for a bad bus index). */
uint32_t sp_g4_can_tx_free(uint8_t bus);

/** The CAN port (send, receive, bus_status) over the three controllers. */
sp_can_port_t sp_g4_can_port(sp_g4_can_t *can);

/**
 * Once per tick, before new frames are queued: cancels transmissions still
 * pending from the previous tick (a setpoint is never sent a tick late;
 * counted in tx_dropped and tx_stale_cancelled), samples the error counters
 * (ECR.CEL into error_frames), error-passive and bus-off states, and
 * restarts a bus-off controller at most every 100 ticks.
 */
void sp_g4_can_service(sp_g4_can_t *can);

/** Safe state of the buses: cancels every pending transmission and puts
 *  the three controllers in initialisation mode (no frame, no ACK). Touches
 *  registers only (no RAM), so it can run from a fault handler. */
void sp_g4_can_silence(void);

/* ---- safe state and diagnostics (startup.c) ---- */

/** Why the port stopped (sp_g4_diag.reason). */
typedef enum {
    SP_G4_STOP_NONE = 0,
    SP_G4_STOP_FAULT = 1,      /**< HardFault / MemManage / BusFault / UsageFault */
    SP_G4_STOP_NMI = 2,        /**< NMI (HSE failure detected by the clock security system) */
    SP_G4_STOP_UNEXPECTED = 3, /**< an interrupt nobody enabled */
    SP_G4_STOP_INIT = 4        /**< clock or CAN start-up failed */
} sp_g4_stop_t;

/** Kept across a reset (not zeroed at start-up) for post-mortem reading with
 *  a debugger; valid when magic == SP_G4_DIAG_MAGIC. */
typedef struct {
    uint32_t magic;
    uint32_t reason; /**< sp_g4_stop_t */
    uint32_t cfsr, hfsr, bfar;
    uint32_t pc, lr; /**< stacked by the faulting context (0 if its stack was unusable) */
    uint32_t stops;  /**< stops since power-on */
} sp_g4_diag_t;
#define SP_G4_DIAG_MAGIC 0x53504734u
extern sp_g4_diag_t sp_g4_diag;

/** RCC_CSR reset flags at this start-up (bits 31:25: low-power, WWDG, IWDG,
 *  software, BOR, pin, option-byte reset), then cleared in RCC_CSR. */
extern uint32_t sp_g4_reset_flags;

/** Enters the safe state for good: interrupts off, CAN silent
 *  (sp_g4_can_silence), LD2 on, diagnostics recorded; waits for the
 *  independent watchdog's reset (forever if it was not started). */
__attribute__((noreturn)) void sp_g4_stop(sp_g4_stop_t reason);

/** Deepest main-stack use since start-up, bytes (from the painted stack). */
uint32_t sp_g4_stack_high_water(void);

#endif /* SP_G4_H */
