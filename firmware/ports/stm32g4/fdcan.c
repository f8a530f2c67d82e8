/* SPDX-License-Identifier: Apache-2.0 */
/*
 * fdcan.c - the three FDCAN controllers of the STM32G474 as the CAN port
 * (sp/link/port.h). Written from RM0440's FDCAN chapter (registers, message RAM,
 * operating modes). The native buses are polled once per tick, no
 * interrupts. A CANopen drive bus (the CiA 408 image) brings more frames
 * in a tick than its two 3-element Rx FIFOs hold (a SYNC's 3 TPDO1 and 3
 * TPDO2, and a heartbeat, EMCY or SDO answer at any time): its FIFOs'
 * new-message interrupt moves every frame into a 16-element queue per bus
 * (more than the ~9 classic frames 1 Mbit/s carries in a millisecond),
 * which the tick reads.
 *
 * Bus -> controller -> pins (NUCLEO-G474RE; docs/reference/stm32g4.md):
 *   ops    FDCAN1  PA11 RX, PA12 TX  AF9
 *   axis_a FDCAN2  PB12 RX, PB13 TX  AF9
 *   axis_b FDCAN3  PA8  RX, PA15 TX  AF11
 *
 * Bit timing from the 170 MHz kernel clock, prescaler 1 in both phases
 * (one time quantum = 1/170 MHz = 5.88 ns):
 *   nominal 1 Mbit/s: 170 tq = 1 sync + 135 (TSEG1) + 34 (TSEG2), sample
 *     point 136/170 = 80.0 %, SJW 34;
 *   data 5 Mbit/s: 34 tq = 1 + 26 + 7, sample point 27/34 = 79.4 %, SJW 7;
 *   transmitter delay compensation on, offset TDCO = 27 kernel clocks (the
 *     data-phase sample point), filter window off (TDCF = 0).
 *
 * Message RAM (fixed on the G4, 212 words per controller): 28 standard
 * filters, 8 extended, Rx FIFO 0 and 1 of 3 elements, Tx event FIFO of 3,
 * Tx FIFO of 3; every Rx/Tx element is 18 words (64 data bytes).
 * Receive filters (everything else is rejected by the hardware):
 *   ops:    OP_TARGET_POSE (0x050) -> FIFO 0, OP_COMMAND (0x040) and
 *           OP_HEARTBEAT (0x060) -> FIFO 1, OP_FORCE (0x048) and
 *           OP_FORCE_PARAMS (0x049) -> FIFO 0 (events: at most 3 a tick)
 *   axis_a: AXIS_FEEDBACK 0x031, 0x032 -> FIFO 0, 0x033 -> FIFO 1
 *   axis_b: the same, and FT_SENSOR (0x038) -> FIFO 1
 * so that no FIFO receives more than its 3 elements of the frames that
 * arrive in one tick. Transmit: Tx FIFO mode, frames leave in the order they were queued
 * (AXIS_SETPOINTS before SYNC; a Tx queue would send the lower identifier,
 * SYNC, first). sp_node_tick emits 2 frames per bus and tick; the FIFO holds 3.
 */
#include <string.h>

#include <stddef.h>

#include "g4_regs.h"
#include "sp/link/protocol.h" /* the identifiers the filters pass */
#include "sp_g4.h"

/* ---- bit timing ---------------------------------------------------------- */
#define NBRP 1u
#define NTSEG1 135u
#define NTSEG2 34u
#define NSJW 34u
#define DBRP 1u
#define DTSEG1 26u
#define DTSEG2 7u
#define DSJW 7u
#define TDCO (DBRP * (1u + DTSEG1)) /* data sample point, in kernel clocks */
#define TDCF 0u

/* Compile-time checks: exact bit rates, register field ranges. */
typedef char sp_g4_check_nominal_rate[(SP_G4_FDCAN_HZ / (NBRP * (1u + NTSEG1 + NTSEG2)) == 1000000u &&
                                       SP_G4_FDCAN_HZ % (NBRP * (1u + NTSEG1 + NTSEG2)) == 0u)
                                          ? 1
                                          : -1];
typedef char sp_g4_check_data_rate[(SP_G4_FDCAN_HZ / (DBRP * (1u + DTSEG1 + DTSEG2)) == 5000000u &&
                                    SP_G4_FDCAN_HZ % (DBRP * (1u + DTSEG1 + DTSEG2)) == 0u)
                                       ? 1
                                       : -1];
typedef char sp_g4_check_fields[(NBRP <= 512u && NTSEG1 >= 2u && NTSEG1 <= 256u && NTSEG2 >= 2u && NTSEG2 <= 128u &&
                                 NSJW <= NTSEG2 && DBRP <= 32u && DTSEG1 <= 32u && DTSEG2 <= 16u && DSJW <= DTSEG2 &&
                                 TDCO <= 127u)
                                    ? 1
                                    : -1];

#define NBTP_VALUE (((NSJW - 1u) << 25) | ((NBRP - 1u) << 16) | ((NTSEG1 - 1u) << 8) | (NTSEG2 - 1u))
#define DBTP_VALUE (FDCAN_DBTP_TDC | ((DBRP - 1u) << 16) | ((DTSEG1 - 1u) << 8) | ((DTSEG2 - 1u) << 4) | (DSJW - 1u))
#define TDCR_VALUE ((TDCO << 8) | TDCF)

/* ---- message RAM elements ------------------------------------------------- */
/* Standard filter element word (RM0440, FDCAN standard message ID filter element):
 * SFT[31:30] 01 = dual ID (SFID1 or SFID2), SFEC[29:27] 001 = store in Rx
 * FIFO 0, 010 = Rx FIFO 1, SFID1[26:16], SFID2[10:0]. */
#define SFT_DUAL (1u << 30)
#define SFEC_FIFO0 (1u << 27)
#define SFEC_FIFO1 (2u << 27)
#define STD_FILTER(sfec, id1, id2) (SFT_DUAL | (sfec) | ((uint32_t)(id1) << 16) | (uint32_t)(id2))
/* Rx/Tx element header: word 0 ESI 31, XTD 30, RTR 29, standard ID [28:18];
 * word 1 FDF 21, BRS 20, DLC [19:16] (Tx: EFC 23 = 0, no Tx event). */
#define ELEM_XTD (1u << 30)
#define ELEM_RTR (1u << 29)
#define ELEM_ID_SHIFT 18u
#define ELEM_FDF (1u << 21)
#define ELEM_BRS (1u << 20)
#define ELEM_DLC_SHIFT 16u

static const uint32_t k_base[SP_CAN_BUSES] = {G4_FDCAN1, G4_FDCAN2, G4_FDCAN3};

/* ---- receive queue of a CANopen drive bus ---------------------------------
 * Filled by sp_g4_fdcan_drive_irq (or by can_receive with interrupts
 * masked), emptied by can_receive with interrupts masked: every access runs
 * with the FDCAN interrupts unable to preempt it, so head, count and the
 * bus's receive counters need no other protection. Classic frames only
 * (CANopen: at most 8 bytes). */
#if SP_DRIVE_CIA408
#define RXQ_DEPTH 16u
#else
#define RXQ_DEPTH 1u /* no CANopen bus in the native image: never used */
#endif
typedef struct {
    uint16_t id;
    uint8_t len;
    uint8_t data[8];
} rxq_elem_t;
typedef struct {
    rxq_elem_t e[RXQ_DEPTH];
    uint32_t head;  /* oldest element */
    uint32_t count; /* 0..RXQ_DEPTH */
} rxq_t;
static rxq_t g_rxq[SP_CAN_BUSES];
static uint8_t g_queued[SP_CAN_BUSES]; /* 1: the bus's FIFOs are drained into g_rxq by the interrupt */
static sp_g4_can_t *g_rx_can;          /* the port whose counters the interrupt updates */

static uint32_t ram(uint8_t bus)
{
    return G4_SRAMCAN + (uint32_t)bus * G4_SRAMCAN_SIZE;
}

static const uint8_t k_dlc_len[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};

/* DLC of a payload length; 0xFF for a length CAN FD cannot carry. */
static uint8_t len_to_dlc(uint8_t len)
{
    for (uint8_t d = 0; d < 16u; d++) {
        if (k_dlc_len[d] == len) {
            return d;
        }
    }
    return 0xFFu;
}

static void inc(uint32_t *c, uint32_t by)
{
    *c = (*c > UINT32_MAX - by) ? UINT32_MAX : *c + by;
}

static int wait_cccr(uint32_t base, uint32_t mask, uint32_t value)
{
    for (uint32_t i = 0; i < 100000u; i++) {
        if ((FDCAN_CCCR(base) & mask) == value) {
            return 1;
        }
    }
    return 0;
}

/* Pin p of port to alternate function af, push-pull, no pull (the
 * transceiver drives RX), speed "high" (01 = medium would also carry
 * 5 Mbit/s edges; 10 = high keeps the TX edge sharp). */
static void pin_af(uint32_t port, uint32_t p, uint32_t af)
{
    /* Function, type, speed and pull first, the mode last: the pin never
     * drives a wrong function in between. */
    if (p < 8u) {
        GPIO_AFRL(port) = (GPIO_AFRL(port) & ~(0xFu << (4u * p))) | (af << (4u * p));
    } else {
        GPIO_AFRH(port) = (GPIO_AFRH(port) & ~(0xFu << (4u * (p - 8u)))) | (af << (4u * (p - 8u)));
    }
    GPIO_OTYPER(port) &= ~(1u << p);
    GPIO_OSPEEDR(port) = (GPIO_OSPEEDR(port) & ~(3u << (2u * p))) | (2u << (2u * p));
    GPIO_PUPDR(port) &= ~(3u << (2u * p));
    GPIO_MODER(port) = (GPIO_MODER(port) & ~(3u << (2u * p))) | (2u << (2u * p));
}

/* CANopen drive bus (co != NULL): per node of the bus three dual-ID filters,
 * TPDO1 + EMCY -> FIFO 0, TPDO2 + heartbeat -> FIFO 1, SDO answer -> FIFO 0;
 * returns the filters written (at most 28). */
static uint32_t canopen_filters(uint8_t bus, uint32_t r, const sp_co_master_cfg_t *co)
{
    uint32_t n = 0u;
    for (uint32_t k = 0u; k < co->n_nodes && k < SP_CO_MAX_NODES && n + 3u <= 28u; k++) {
        uint32_t id = co->node[k].node_id;
        if (co->node[k].bus != bus) {
            continue;
        }
        SP_REG(r + SRAMCAN_FLSSA + 4u * n++) = STD_FILTER(SFEC_FIFO0, SP_CO_COB_TPDO1 + id, SP_CO_COB_EMCY + id);
        SP_REG(r + SRAMCAN_FLSSA + 4u * n++) = STD_FILTER(SFEC_FIFO1, SP_CO_COB_TPDO2 + id, SP_CO_COB_HEARTBEAT + id);
        SP_REG(r + SRAMCAN_FLSSA + 4u * n++) = STD_FILTER(SFEC_FIFO0, SP_CO_COB_SDO_TX + id, SP_CO_COB_SDO_TX + id);
    }
    return n;
}

static sp_status_t init_one(uint8_t bus, const sp_co_master_cfg_t *co, uint32_t bitrate)
{
    uint32_t b = k_base[bus];
    uint32_t r = ram(bus);
    int canopen = co != NULL && bus != SP_BUS_OPS;
    /* CANopen buses: classic CAN, 170 tq per bit, the prescaler from the bit rate */
    uint32_t nbrp = canopen && bitrate > 0u ? 1000000u / bitrate : NBRP;
    uint32_t nfilters = 2u;
    if (canopen && (bitrate == 0u || 1000000u % bitrate != 0u || nbrp < 1u || nbrp > 512u)) {
        return SP_E_ARG; /* 800 kbit/s has no whole prescaler at 170 tq per bit */
    }

    /* Initialisation mode (INIT is 1 after reset), then configuration
     * change enable. */
    FDCAN_CCCR(b) |= FDCAN_CCCR_INIT;
    if (!wait_cccr(b, FDCAN_CCCR_INIT, FDCAN_CCCR_INIT)) {
        return SP_E_IO;
    }
    FDCAN_CCCR(b) |= FDCAN_CCCR_CCE;
    if (!wait_cccr(b, FDCAN_CCCR_CCE, FDCAN_CCCR_CCE)) {
        return SP_E_IO;
    }
    /* CAN FD with bit rate switch; automatic retransmission on (stale frames
     * are cancelled each tick instead); protocol exception handling default. */
    FDCAN_CCCR(b) = canopen ? (FDCAN_CCCR_INIT | FDCAN_CCCR_CCE)
                            : (FDCAN_CCCR_INIT | FDCAN_CCCR_CCE | FDCAN_CCCR_FDOE | FDCAN_CCCR_BRSE);
    if (bus == 0u) {
        /* The shared clock divider is writable while FDCAN1 has INIT and
         * CCE set: kernel clock / 1 (its reset value, made explicit). */
        FDCAN_CKDIV = 0u;
    }
    FDCAN_NBTP(b) =
        canopen ? (((NSJW - 1u) << 25) | ((nbrp - 1u) << 16) | ((NTSEG1 - 1u) << 8) | (NTSEG2 - 1u)) : NBTP_VALUE;
    FDCAN_DBTP(b) = DBTP_VALUE;
    FDCAN_TDCR(b) = TDCR_VALUE;

    /* The message RAM is undefined after power-on: clear this controller's
     * 212 words before writing filters. */
    for (uint32_t off = 0; off < G4_SRAMCAN_SIZE; off += 4u) {
        SP_REG(r + off) = 0u;
    }
    if (bus == SP_BUS_OPS) {
        SP_REG(r + SRAMCAN_FLSSA + 0u) = STD_FILTER(SFEC_FIFO0, SP_ID_OP_TARGET_POSE, SP_ID_OP_TARGET_POSE);
        SP_REG(r + SRAMCAN_FLSSA + 4u) = STD_FILTER(SFEC_FIFO1, SP_ID_OP_COMMAND, SP_ID_OP_HEARTBEAT);
        SP_REG(r + SRAMCAN_FLSSA + 8u) = STD_FILTER(SFEC_FIFO0, SP_ID_OP_FORCE, SP_ID_OP_FORCE_PARAMS);
        nfilters = 3u;
    } else if (canopen) {
        nfilters = canopen_filters(bus, r, co);
    } else {
        /* AXIS_FEEDBACK slots 1, 2; slot 3 (and on axis_b the force/torque sensor) */
        SP_REG(r + SRAMCAN_FLSSA + 0u) = STD_FILTER(SFEC_FIFO0, SP_ID_AXIS_FEEDBACK_1, SP_ID_AXIS_FEEDBACK_1 + 1u);
        SP_REG(r + SRAMCAN_FLSSA + 4u) =
            STD_FILTER(SFEC_FIFO1, SP_ID_AXIS_FEEDBACK_1 + 2u,
                       (bus == SP_BUS_AXIS_B) ? SP_ID_FT_SENSOR : SP_ID_AXIS_FEEDBACK_1 + 2u);
    }
    /* Standard filters as set above (three on ops, two on the native axis
     * buses, the CANopen layout's on CANopen ones), no extended; reject
     * non-matching and remote frames; both Rx FIFOs in blocking mode (a
     * full FIFO loses the new frame and sets RF0L / RF1L, counted as an
     * overrun). */
    FDCAN_RXGFC(b) = (nfilters << FDCAN_RXGFC_LSS_SHIFT) | (0u << FDCAN_RXGFC_LSE_SHIFT) | FDCAN_RXGFC_ANFS_REJECT |
                     FDCAN_RXGFC_ANFE_REJECT | FDCAN_RXGFC_RRFS | FDCAN_RXGFC_RRFE;
    FDCAN_TXBC(b) = 0u; /* TFQM = 0: Tx FIFO */
    /* Native buses polled: no interrupt. CANopen drive buses: Rx FIFO 0/1
     * new message on interrupt line 0 (the NVIC side: sp_g4_can_init_canopen). */
    FDCAN_IE(b) = canopen ? (FDCAN_IR_RF0N | FDCAN_IR_RF1N) : 0u;
    FDCAN_ILS(b) = 0u;
    FDCAN_ILE(b) = canopen ? FDCAN_ILE_EINT0 : 0u;
    FDCAN_IR(b) = 0xFFFFFFFFu; /* clear every flag (write 1 to clear) */
    g_queued[bus] = (uint8_t)(canopen ? 1u : 0u);
    g_rxq[bus].head = 0u;
    g_rxq[bus].count = 0u;

    /* Normal operation: clearing INIT also clears CCE; the controller joins
     * the bus after 11 recessive bits. */
    FDCAN_CCCR(b) &= ~(FDCAN_CCCR_INIT | FDCAN_CCCR_CCE);
    if (!wait_cccr(b, FDCAN_CCCR_INIT, 0u)) {
        return SP_E_IO;
    }
    return SP_OK;
}

sp_status_t sp_g4_can_init(sp_g4_can_t *can)
{
    return sp_g4_can_init_canopen(can, NULL, NULL);
}

sp_status_t sp_g4_can_init_canopen(sp_g4_can_t *can, const sp_co_master_cfg_t *co, const uint32_t *bitrate)
{
    if (can == NULL) {
        return SP_E_ARG;
    }
    memset(can, 0, sizeof *can);

    RCC_AHB2ENR |= RCC_AHB2ENR_GPIOAEN | RCC_AHB2ENR_GPIOBEN;
    RCC_APB1ENR1 |= RCC_APB1ENR1_FDCANEN;
    (void)RCC_APB1ENR1;
    RCC_APB1RSTR1 |= RCC_APB1RSTR1_FDCANRST; /* the three controllers to their reset state */
    RCC_APB1RSTR1 &= ~RCC_APB1RSTR1_FDCANRST;

    pin_af(G4_GPIOA, 11u, 9u);  /* FDCAN1_RX */
    pin_af(G4_GPIOA, 12u, 9u);  /* FDCAN1_TX */
    pin_af(G4_GPIOB, 12u, 9u);  /* FDCAN2_RX */
    pin_af(G4_GPIOB, 13u, 9u);  /* FDCAN2_TX */
    pin_af(G4_GPIOA, 8u, 11u);  /* FDCAN3_RX */
    pin_af(G4_GPIOA, 15u, 11u); /* FDCAN3_TX (PA15 leaves JTDI; SWD stays on PA13/PA14) */

    g_rx_can = can;
    for (uint8_t bus = 0; bus < SP_CAN_BUSES; bus++) {
        sp_status_t s = init_one(bus, co, bitrate != NULL ? bitrate[bus] : 1000000u);
        if (s != SP_OK) {
            return s;
        }
    }
    if (co != NULL) {
        /* Both drive buses' line 0 to one handler, priority below SysTick's
         * (0x00): the tick is never held up by a receive. */
        NVIC_IPR_BYTE(G4_IRQ_FDCAN2_IT0) = 0x80u;
        NVIC_IPR_BYTE(G4_IRQ_FDCAN3_IT0) = 0x80u;
        NVIC_ISER(G4_IRQ_FDCAN2_IT0) = 1u << (G4_IRQ_FDCAN2_IT0 % 32u);
        NVIC_ISER(G4_IRQ_FDCAN3_IT0) = 1u << (G4_IRQ_FDCAN3_IT0 % 32u);
    }
    return SP_OK;
}

uint32_t sp_g4_can_tx_free(uint8_t bus)
{
    return bus < SP_CAN_BUSES ? (FDCAN_TXFQS(k_base[bus]) & 0x7u) : 0u;
}

/* Copies one frame into the controller's Tx FIFO. SP_E_BUSY when full. */
static sp_status_t put(uint8_t bus, const sp_can_frame_t *f)
{
    uint32_t b = k_base[bus];
    uint8_t dlc = len_to_dlc(f->len);
    if (f->id > 0x7FFu || dlc == 0xFFu || (dlc > 8u && (f->flags & SP_CAN_FLAG_FD) == 0u)) {
        return SP_E_ARG;
    }
    uint32_t fqs = FDCAN_TXFQS(b);
    if ((fqs & FDCAN_TXFQS_TFQF) != 0u) {
        return SP_E_BUSY;
    }
    uint32_t pi = (fqs >> 16) & 3u;
    if (pi >= SRAMCAN_FIFO_DEPTH) {
        return SP_E_IO;
    }
    uint32_t e = ram(bus) + SRAMCAN_TFQSA + pi * SRAMCAN_ELEM;
    uint32_t w1 = (uint32_t)dlc << ELEM_DLC_SHIFT;
    if ((f->flags & SP_CAN_FLAG_FD) != 0u) {
        w1 |= ELEM_FDF;
        if ((f->flags & SP_CAN_FLAG_BRS) != 0u) {
            w1 |= ELEM_BRS;
        }
    }
    SP_REG(e) = f->id << ELEM_ID_SHIFT;
    SP_REG(e + 4u) = w1;
    uint32_t words = ((uint32_t)f->len + 3u) / 4u;
    for (uint32_t w = 0; w < words; w++) {
        const uint8_t *d = &f->data[4u * w];
        SP_REG(e + 8u + 4u * w) =
            (uint32_t)d[0] | ((uint32_t)d[1] << 8) | ((uint32_t)d[2] << 16) | ((uint32_t)d[3] << 24);
    }
    FDCAN_TXBAR(b) = 1u << pi;
    return SP_OK;
}

static sp_status_t can_send(void *ctx, const sp_can_frame_t *frames, uint32_t n, uint32_t *sent)
{
    sp_g4_can_t *can = (sp_g4_can_t *)ctx;
    if (can == NULL || sent == NULL || (frames == NULL && n > 0u)) {
        return SP_E_ARG;
    }
    *sent = 0;
    sp_status_t result = SP_OK;
    for (uint32_t k = 0; k < n; k++) {
        const sp_can_frame_t *f = &frames[k];
        if (f->bus >= SP_CAN_BUSES) {
            result = SP_E_ARG;
            continue;
        }
        sp_bus_status_t *st = &can->status[f->bus];
        sp_status_t s = (st->bus_off != 0u) ? SP_E_IO : put(f->bus, f);
        if (s == SP_OK) {
            inc(&st->tx_frames, 1u);
            (*sent)++;
        } else {
            inc(&st->tx_dropped, 1u);
            if (result == SP_OK || s == SP_E_IO) {
                result = s;
            }
        }
    }
    return result;
}

/* Moves one element of Rx FIFO `fifo` (0/1) of `bus` out of the FIFO: its
 * identifier, length and flags into *f and up to `cap` data bytes into
 * data (a longer frame's length is still reported). 0 if empty, 1 for a
 * frame, 2 for an extended or remote one (the filters reject them; dropped
 * as if it had never arrived). */
typedef struct {
    uint16_t id;
    uint8_t len;
    uint8_t flags;
} rx_head_t;
static int take(uint8_t bus, uint32_t fifo, rx_head_t *h, uint8_t *data, uint32_t cap)
{
    uint32_t b = k_base[bus];
    uint32_t st = (fifo == 0u) ? FDCAN_RXF0S(b) : FDCAN_RXF1S(b);
    if ((st & 0xFu) == 0u) {
        return 0;
    }
    uint32_t gi = (st >> 8) & 3u;
    if (gi >= SRAMCAN_FIFO_DEPTH) {
        return 0;
    }
    uint32_t e = ram(bus) + ((fifo == 0u) ? SRAMCAN_RF0SA : SRAMCAN_RF1SA) + gi * SRAMCAN_ELEM;
    uint32_t w0 = SP_REG(e);
    uint32_t w1 = SP_REG(e + 4u);
    h->id = (uint16_t)((w0 >> ELEM_ID_SHIFT) & 0x7FFu);
    h->len = k_dlc_len[(w1 >> ELEM_DLC_SHIFT) & 0xFu];
    h->flags = 0u;
    if ((w1 & ELEM_FDF) != 0u) {
        h->flags = (uint8_t)(SP_CAN_FLAG_FD | (((w1 & ELEM_BRS) != 0u) ? SP_CAN_FLAG_BRS : 0u));
    } else if (h->len > 8u) {
        h->len = 8u; /* classic CAN: DLC 9..15 still means 8 bytes */
    }
    uint32_t n = (h->len < cap) ? h->len : cap;
    uint32_t words = (n + 3u) / 4u;
    for (uint32_t w = 0; w < words; w++) {
        uint32_t v = SP_REG(e + 8u + 4u * w);
        for (uint32_t i = 0; i < 4u && 4u * w + i < n; i++) {
            data[4u * w + i] = (uint8_t)(v >> (8u * i));
        }
    }
    if (fifo == 0u) {
        FDCAN_RXF0A(b) = gi;
    } else {
        FDCAN_RXF1A(b) = gi;
    }
    return ((w0 & (ELEM_XTD | ELEM_RTR)) != 0u) ? 2 : 1;
}

/* take() into a frame of the port (every length up to 64 bytes). */
static int take_frame(uint8_t bus, uint32_t fifo, sp_can_frame_t *f)
{
    rx_head_t h;
    memset(f, 0, sizeof *f);
    int t = take(bus, fifo, &h, f->data, sizeof f->data);
    f->id = h.id;
    f->bus = bus;
    f->len = h.len;
    f->flags = h.flags;
    return t;
}

/* Counts the bus's lost-frame flags as overruns and clears them. */
static void count_lost(sp_g4_can_t *can, uint8_t bus)
{
    uint32_t b = k_base[bus];
    uint32_t ir = FDCAN_IR(b) & (FDCAN_IR_RF0L | FDCAN_IR_RF1L);
    if (ir != 0u) {
        FDCAN_IR(b) = ir;
        inc(&can->status[bus].rx_overruns,
            ((ir & FDCAN_IR_RF0L) != 0u ? 1u : 0u) + ((ir & FDCAN_IR_RF1L) != 0u ? 1u : 0u));
    }
}

/* Moves every frame of a queued bus's two FIFOs into its queue; a frame
 * that finds the queue full is lost and counted as an overrun. Runs in the
 * interrupt or with interrupts masked. At most 2 x 3 elements. */
static void drain(uint8_t bus)
{
    sp_g4_can_t *can = g_rx_can;
    if (can == NULL || g_queued[bus] == 0u) {
        return;
    }
    /* new-message flags cleared first: a frame arriving meanwhile raises
     * them again (and the interrupt with them) */
    FDCAN_IR(k_base[bus]) = FDCAN_IR_RF0N | FDCAN_IR_RF1N;
    count_lost(can, bus);
    rxq_t *q = &g_rxq[bus];
    for (uint32_t fifo = 0; fifo < 2u; fifo++) {
        for (uint32_t k = 0; k < SRAMCAN_FIFO_DEPTH; k++) {
            /* into the next free element, or a scratch one when the queue is full */
            static rxq_elem_t scratch;
            rxq_elem_t *e = (q->count < RXQ_DEPTH) ? &q->e[(q->head + q->count) % RXQ_DEPTH] : &scratch;
            rx_head_t h;
            int t = take(bus, fifo, &h, e->data, sizeof e->data);
            if (t == 0) {
                break;
            }
            inc(&can->status[bus].rx_frames, 1u);
            if (t != 1) {
                continue;
            }
            if (e == &scratch || h.len > sizeof e->data || h.flags != 0u) {
                inc(&can->status[bus].rx_overruns, 1u); /* queue full, or not a classic frame */
                continue;
            }
            e->id = h.id;
            e->len = h.len;
            q->count++;
        }
    }
}

void sp_g4_fdcan_drive_irq(void)
{
    drain(SP_BUS_AXIS_A);
    drain(SP_BUS_AXIS_B);
}

static uint32_t irq_mask(void)
{
    uint32_t primask;
    __asm__ volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask)::"memory");
    return primask;
}

static void irq_restore(uint32_t primask)
{
    __asm__ volatile("msr primask, %0" ::"r"(primask) : "memory");
}

/* Up to `max` frames of a queued bus, oldest first, into frames[]. */
static uint32_t take_queued(uint8_t bus, sp_can_frame_t *frames, uint32_t max)
{
    uint32_t n = 0u;
    uint32_t primask = irq_mask();
    drain(bus); /* what is in the FIFOs now, even if an interrupt is pending */
    rxq_t *q = &g_rxq[bus];
    while (n < max && q->count > 0u) {
        const rxq_elem_t *e = &q->e[q->head];
        sp_can_frame_t *f = &frames[n++];
        memset(f, 0, sizeof *f);
        f->id = e->id;
        f->bus = bus;
        f->len = e->len;
        memcpy(f->data, e->data, 8u);
        q->head = (q->head + 1u) % RXQ_DEPTH;
        q->count--;
    }
    irq_restore(primask);
    return n;
}

static sp_status_t can_receive(void *ctx, sp_can_frame_t *frames, uint32_t max, uint32_t *got)
{
    sp_g4_can_t *can = (sp_g4_can_t *)ctx;
    if (can == NULL || got == NULL || (frames == NULL && max > 0u)) {
        return SP_E_ARG;
    }
    *got = 0;
    /* Polled buses: at most 3 elements per FIFO, 2 FIFOs; queued buses: at
     * most RXQ_DEPTH. */
    for (uint8_t bus = 0; bus < SP_CAN_BUSES; bus++) {
        if (g_queued[bus] != 0u) {
            *got += take_queued(bus, &frames[*got], max - *got);
            continue;
        }
        count_lost(can, bus);
        for (uint32_t fifo = 0; fifo < 2u; fifo++) {
            for (uint32_t k = 0; k < SRAMCAN_FIFO_DEPTH && *got < max; k++) {
                int t = take_frame(bus, fifo, &frames[*got]);
                if (t == 0) {
                    break;
                }
                inc(&can->status[bus].rx_frames, 1u);
                if (t == 1) {
                    (*got)++;
                }
            }
        }
    }
    return SP_OK;
}

static sp_status_t can_bus_status(void *ctx, uint8_t bus, sp_bus_status_t *status)
{
    sp_g4_can_t *can = (sp_g4_can_t *)ctx;
    if (can == NULL || status == NULL || bus >= SP_CAN_BUSES) {
        return SP_E_ARG;
    }
    *status = can->status[bus];
    return SP_OK;
}

sp_can_port_t sp_g4_can_port(sp_g4_can_t *can)
{
    sp_can_port_t p;
    p.ctx = can;
    p.send = can_send;
    p.receive = can_receive;
    p.bus_status = can_bus_status;
    return p;
}

static uint32_t popcount3(uint32_t v)
{
    return (v & 1u) + ((v >> 1) & 1u) + ((v >> 2) & 1u);
}

void sp_g4_can_service(sp_g4_can_t *can)
{
    if (can == NULL) {
        return;
    }
    for (uint8_t bus = 0; bus < SP_CAN_BUSES; bus++) {
        uint32_t b = k_base[bus];
        sp_bus_status_t *st = &can->status[bus];

        uint32_t pending = FDCAN_TXBRP(b) & 7u;
        if (pending != 0u) {
            FDCAN_TXBCR(b) = pending; /* a frame in transmission completes or fails first */
            inc(&st->tx_dropped, popcount3(pending));
            inc(&can->tx_stale_cancelled[bus], popcount3(pending));
        }

        inc(&st->error_frames, (FDCAN_ECR(b) >> FDCAN_ECR_CEL_SHIFT) & 0xFFu); /* reading clears CEL */
        uint32_t psr = FDCAN_PSR(b); /* (reading also resets the last error codes) */
        st->error_passive = (uint8_t)((psr & FDCAN_PSR_EP) != 0u);
        st->bus_off = (uint8_t)((psr & FDCAN_PSR_BO) != 0u);

        /* Bus-off puts the controller in initialisation mode; leaving it
         * starts the recovery (128 x 11 recessive bits). */
        if (st->bus_off != 0u && (FDCAN_CCCR(b) & FDCAN_CCCR_INIT) != 0u) {
            if (can->recover_wait[bus] == 0u) {
                FDCAN_CCCR(b) &= ~FDCAN_CCCR_INIT;
                inc(&can->bus_off_recoveries[bus], 1u);
                can->recover_wait[bus] = 100u;
            } else {
                can->recover_wait[bus]--;
            }
        }
    }
}

void sp_g4_can_silence(void)
{
    for (uint32_t bus = 0; bus < SP_CAN_BUSES; bus++) {
        uint32_t b = (bus == 0u) ? G4_FDCAN1 : (bus == 1u) ? G4_FDCAN2 : G4_FDCAN3;
        FDCAN_TXBCR(b) = 7u;
        FDCAN_CCCR(b) |= FDCAN_CCCR_INIT;
    }
}
