/* SPDX-License-Identifier: Apache-2.0 */
/* co_node.c - a simulated drive as a CiA 408 or CiA 402 node (hs/co_node.h). */
#include "hs/co_node.h"

#include <string.h>

#define ABORT_UNSUPPORTED 0x06010000u
#define ABORT_WRITE_ONLY 0x06010001u
#define ABORT_READ_ONLY 0x06010002u
#define ABORT_NO_OBJECT 0x06020000u
#define ABORT_LENGTH 0x06070010u
#define ABORT_NO_SUB 0x06090011u
#define ABORT_CMD 0x05040001u
#define EMCY_RPDO_TIMEOUT 0x8250u
#define EMCY_HEARTBEAT 0x8130u /* life guard or heartbeat error */

static void od_add(hs_co_node_t *n, uint16_t index, uint8_t sub, uint8_t size, uint8_t access, uint32_t value)
{
    if (n->n_od < HS_CO_OD_MAX) {
        hs_co_entry_t *e = &n->od[n->n_od++];
        e->index = index;
        e->sub = sub;
        e->size = size;
        e->access = access;
        e->value = value;
    }
}

/* A PDO communication record (sub-indices 0, 1, 2, 3, 5) with the EDS's defaults. */
static void pdo_comm(hs_co_node_t *n, uint16_t index, uint32_t cob)
{
    od_add(n, index, 0u, 1u, HS_CO_RO, 5u);
    od_add(n, index, 1u, 4u, HS_CO_RW, cob);
    od_add(n, index, 2u, 1u, HS_CO_RW, 1u);
    od_add(n, index, 3u, 2u, HS_CO_RW, 0u);
    od_add(n, index, 5u, 2u, HS_CO_RW, 0u);
}

/* A PDO mapping record: count and four entries. */
static void pdo_map(hs_co_node_t *n, uint16_t index, uint32_t count, uint32_t e1, uint32_t e2)
{
    od_add(n, index, 0u, 1u, HS_CO_RW, count);
    od_add(n, index, 1u, 4u, HS_CO_RW, e1);
    od_add(n, index, 2u, 4u, HS_CO_RW, e2);
    od_add(n, index, 3u, 4u, HS_CO_RW, 0u);
    od_add(n, index, 4u, 4u, HS_CO_RW, 0u);
}

/* The communication objects both profiles share (the 408 EDS's 0x1001-0x1200). */
static void od_common(hs_co_node_t *n, uint32_t product)
{
    uint32_t id = n->node_id;
    od_add(n, 0x1001u, 0u, 1u, HS_CO_RO, 0u);
    od_add(n, 0x1003u, 0u, 1u, HS_CO_RW, 0u);
    od_add(n, 0x1003u, 1u, 4u, HS_CO_RO, 0u);
    od_add(n, 0x1005u, 0u, 4u, HS_CO_RW, 0x80u);
    od_add(n, 0x1006u, 0u, 4u, HS_CO_RW, 0u);
    od_add(n, 0x1014u, 0u, 4u, HS_CO_RO, 0x80u + id);
    od_add(n, 0x1016u, 0u, 1u, HS_CO_RO, 1u);
    od_add(n, 0x1016u, 1u, 4u, HS_CO_RW, 0u);
    od_add(n, 0x1017u, 0u, 2u, HS_CO_RW, 0u);
    od_add(n, 0x1018u, 0u, 1u, HS_CO_RO, 4u);
    od_add(n, 0x1018u, 1u, 4u, HS_CO_RO, 0u);
    od_add(n, 0x1018u, 2u, 4u, HS_CO_RO, product);
    od_add(n, 0x1018u, 3u, 4u, HS_CO_RO, 0x00010000u);
    od_add(n, 0x1018u, 4u, 4u, HS_CO_RO, 0u);
    od_add(n, 0x1200u, 0u, 1u, HS_CO_RO, 2u);
    od_add(n, 0x1200u, 1u, 4u, HS_CO_RO, 0x600u + id);
    od_add(n, 0x1200u, 2u, 4u, HS_CO_RO, 0x580u + id);
}

static void od_defaults_402(hs_co_node_t *n);

/* The EDS's objects (config/eds/stewart_sim_drive.eds) with its defaults,
 * except the three strings 0x1008-0x100A (they need a segmented transfer,
 * which this server does not offer); a Python test compares the two. */
static void od_defaults(hs_co_node_t *n)
{
    uint32_t id = n->node_id;
    n->n_od = 0u;
    if (n->profile == 1u) {
        od_defaults_402(n);
        return;
    }
    od_add(n, 0x1000u, 0u, 4u, HS_CO_RO, 0x00000198u);
    od_common(n, 0x5348u);
    pdo_comm(n, 0x1400u, 0x200u + id);
    pdo_comm(n, 0x1401u, 0x80000300u + id);
    pdo_map(n, 0x1600u, 2u, 0x60400010u, 0x66000120u);
    pdo_map(n, 0x1601u, 0u, 0u, 0u);
    pdo_comm(n, 0x1800u, 0x180u + id);
    pdo_comm(n, 0x1801u, 0x280u + id);
    pdo_map(n, 0x1A00u, 2u, 0x60410010u, 0x66010120u);
    pdo_map(n, 0x1A01u, 2u, 0x21100110u, 0x21100210u);
    od_add(n, 0x2100u, 0u, 1u, HS_CO_RO, 0u);
    od_add(n, 0x2110u, 0u, 1u, HS_CO_RO, 2u);
    od_add(n, 0x2110u, 1u, 2u, HS_CO_RO, 0u);
    od_add(n, 0x2110u, 2u, 2u, HS_CO_RO, 0u);
    od_add(n, 0x2120u, 0u, 2u, HS_CO_RW, 0u);
    od_add(n, 0x6040u, 0u, 2u, HS_CO_RW, 0u);
    od_add(n, 0x6041u, 0u, 2u, HS_CO_RO, 0u);
    od_add(n, 0x6042u, 0u, 1u, HS_CO_RW, 1u);
    od_add(n, 0x6043u, 0u, 1u, HS_CO_RW, 8u);
    od_add(n, 0x6600u, 0u, 1u, HS_CO_RO, 3u);
    od_add(n, 0x6600u, 1u, 4u, HS_CO_RW, 0u);
    od_add(n, 0x6600u, 2u, 1u, HS_CO_RW, 0x01u);
    od_add(n, 0x6600u, 3u, 1u, HS_CO_RW, 0xFAu); /* -6 */
    od_add(n, 0x6601u, 0u, 1u, HS_CO_RO, 3u);
    od_add(n, 0x6601u, 1u, 4u, HS_CO_RO, 0u);
    od_add(n, 0x6601u, 2u, 1u, HS_CO_RO, 0x01u);
    od_add(n, 0x6601u, 3u, 1u, HS_CO_RO, 0xFAu);
    od_add(n, 0x6614u, 0u, 1u, HS_CO_RO, 3u);
    od_add(n, 0x6614u, 1u, 4u, HS_CO_RW, 0u);
    od_add(n, 0x6614u, 2u, 1u, HS_CO_RO, 0x01u);
    od_add(n, 0x6614u, 3u, 1u, HS_CO_RO, 0xFAu);
}

/* config/eds/stewart_sim_drive_402.eds: a CiA 402 servo drive (0x1000 =
 * 0x00020192) in cyclic synchronous position mode by default. TPDO2 maps
 * the velocity actual value and is invalid by default. */
static void od_defaults_402(hs_co_node_t *n)
{
    uint32_t id = n->node_id;
    od_add(n, 0x1000u, 0u, 4u, HS_CO_RO, 0x00020192u);
    od_common(n, 0x5349u);
    pdo_comm(n, 0x1400u, 0x200u + id);
    pdo_comm(n, 0x1401u, 0x80000300u + id);
    pdo_map(n, 0x1600u, 2u, 0x60400010u, 0x607A0020u);
    pdo_map(n, 0x1601u, 0u, 0u, 0u);
    pdo_comm(n, 0x1800u, 0x180u + id);
    pdo_comm(n, 0x1801u, 0x80000280u + id);
    pdo_map(n, 0x1A00u, 2u, 0x60410010u, 0x60640020u);
    pdo_map(n, 0x1A01u, 1u, 0x606C0020u, 0u);
    od_add(n, 0x603Fu, 0u, 2u, HS_CO_RO, 0u);
    od_add(n, 0x6040u, 0u, 2u, HS_CO_RW, 0u);
    od_add(n, 0x6041u, 0u, 2u, HS_CO_RO, 0u);
    od_add(n, 0x6060u, 0u, 1u, HS_CO_RW, 8u);
    od_add(n, 0x6061u, 0u, 1u, HS_CO_RO, 8u);
    od_add(n, 0x6064u, 0u, 4u, HS_CO_RO, 0u);
    od_add(n, 0x606Cu, 0u, 4u, HS_CO_RO, 0u);
    od_add(n, 0x607Au, 0u, 4u, HS_CO_RW, 0u);
    od_add(n, 0x60C2u, 0u, 1u, HS_CO_RO, 2u);
    od_add(n, 0x60C2u, 1u, 1u, HS_CO_RW, 1u);
    od_add(n, 0x60C2u, 2u, 1u, HS_CO_RW, 0xFDu);       /* -3 */
    od_add(n, 0x6076u, 0u, 4u, HS_CO_RO, 10000000u);   /* rated force 10 kN, in mN (a linear axis) */
    od_add(n, 0x60B2u, 0u, 2u, HS_CO_RW, 0u);          /* torque/force offset, per mille of 0x6076 */
    od_add(n, 0x6502u, 0u, 4u, HS_CO_RO, 0x00000080u); /* bit 7: cyclic synchronous position */
}

/* The entry's index in n's dictionary, or n->n_od when it has none. */
static uint32_t od_slot(const hs_co_node_t *n, uint16_t index, uint8_t sub)
{
    uint32_t i;
    for (i = 0u; i < n->n_od; i++) {
        if (n->od[i].index == index && n->od[i].sub == sub) {
            break;
        }
    }
    return i;
}

hs_co_entry_t *hs_co_node_find(hs_co_node_t *n, uint16_t index, uint8_t sub)
{
    uint32_t i;
    if (n == NULL) {
        return NULL;
    }
    i = od_slot(n, index, sub);
    return i < n->n_od ? &n->od[i] : NULL;
}

static int index_exists(const hs_co_node_t *n, uint16_t index)
{
    uint32_t i;
    for (i = 0u; i < n->n_od; i++) {
        if (n->od[i].index == index) {
            return 1;
        }
    }
    return 0;
}

static uint32_t od_value(hs_co_node_t *n, uint16_t index, uint8_t sub)
{
    const hs_co_entry_t *e = hs_co_node_find(n, index, sub);
    return e != NULL ? e->value : 0u;
}

/* Power-on or NMT reset: the dictionary's defaults (reset node), or only
 * the writable communication area 0x1000-0x1FFF (reset communication). */
static void reset(hs_co_node_t *n, int whole)
{
    if (whole) {
        od_defaults(n);
        n->state = SP_CO408_NOT_READY;
        n->state402 = SP_CO402_NOT_READY;
        n->control = 0u;
        n->fault = 0u;
    } else {
        hs_co_node_t fresh;
        uint32_t i;
        fresh.node_id = n->node_id;
        fresh.profile = n->profile;
        fresh.n_od = 0u;
        od_defaults(&fresh);
        for (i = 0u; i < fresh.n_od; i++) {
            if (fresh.od[i].index < 0x2000u && fresh.od[i].access == HS_CO_RW) {
                hs_co_entry_t *e = hs_co_node_find(n, fresh.od[i].index, fresh.od[i].sub);
                if (e != NULL) {
                    e->value = fresh.od[i].value;
                }
            }
        }
    }
    n->nmt = SP_CO_NMT_STATE_BOOTUP;
    n->boot_pending = 1u;
    n->rpdo_seen = 0u;
    n->rpdo_age_ms = 0u;
    n->hb_elapsed_ms = 0u;
    n->hbc_seen = 0u;
    n->hbc_elapsed_ms = 0u;
}

hs_status_t hs_co_node_init_profile(hs_co_node_t *n, uint8_t node_id, uint8_t bus, uint8_t profile)
{
    if (n == NULL || node_id < SP_CO_NODE_MIN || node_id > SP_CO_NODE_MAX || bus >= SP_CAN_BUSES || profile > 1u) {
        return HS_E_ARG;
    }
    memset(n, 0, sizeof *n);
    n->node_id = node_id;
    n->bus = bus;
    n->profile = profile;
    reset(n, 1);
    return HS_OK;
}

hs_status_t hs_co_node_init(hs_co_node_t *n, uint8_t node_id, uint8_t bus)
{
    return hs_co_node_init_profile(n, node_id, bus, 0u);
}

static sp_can_frame_t *next_tx(sp_can_frame_t *tx, uint8_t *n_tx)
{
    return *n_tx < HS_CO_MAX_TX ? &tx[(*n_tx)++] : NULL;
}

static void sdo_answer(hs_co_node_t *n, sp_can_frame_t *f, uint8_t cmd, uint16_t index, uint8_t sub, uint32_t v)
{
    memset(f, 0, sizeof *f);
    f->id = SP_CO_COB_SDO_TX + n->node_id;
    f->bus = n->bus;
    f->len = 8u;
    f->data[0] = cmd;
    f->data[1] = (uint8_t)(index & 0xFFu);
    f->data[2] = (uint8_t)(index >> 8);
    f->data[3] = sub;
    f->data[4] = (uint8_t)(v & 0xFFu);
    f->data[5] = (uint8_t)((v >> 8) & 0xFFu);
    f->data[6] = (uint8_t)((v >> 16) & 0xFFu);
    f->data[7] = (uint8_t)(v >> 24);
}

/* A mapping (0x16xx / 0x1Axx) may change only while its PDO is invalid. */
static int mapping_locked(hs_co_node_t *n, uint16_t index)
{
    if ((index & 0xFE00u) == 0x1600u || (index & 0xFE00u) == 0x1A00u) {
        return (od_value(n, (uint16_t)(index - 0x200u), 1u) & 0x80000000u) == 0u;
    }
    return 0;
}

static void sdo_serve(hs_co_node_t *n, const sp_can_frame_t *f, sp_can_frame_t *out)
{
    uint8_t cmd = f->data[0];
    uint16_t index = (uint16_t)(f->data[1] | (f->data[2] << 8));
    uint8_t sub = f->data[3];
    uint32_t v = (uint32_t)f->data[4] | ((uint32_t)f->data[5] << 8) | ((uint32_t)f->data[6] << 16) |
                 ((uint32_t)f->data[7] << 24);
    hs_co_entry_t *e = hs_co_node_find(n, index, sub);
    uint32_t ccs = cmd >> 5;
    n->sdo_count++;
    if (ccs == 4u) {
        return; /* the client aborted: nothing to answer */
    }
    if (n->abort_index != 0u && index == n->abort_index && sub == n->abort_sub) {
        sdo_answer(n, out, 0x80u, index, sub, n->abort_code);
    } else if (ccs != 1u && ccs != 2u) {
        sdo_answer(n, out, 0x80u, index, sub, ABORT_CMD);
    } else if (e == NULL) {
        sdo_answer(n, out, 0x80u, index, sub, index_exists(n, index) ? ABORT_NO_SUB : ABORT_NO_OBJECT);
    } else if (ccs == 2u) { /* upload */
        sdo_answer(n, out, (uint8_t)(0x43u | ((4u - e->size) << 2)), index, sub, e->value);
    } else if ((cmd & 0x02u) == 0u) { /* a segmented download: not offered */
        sdo_answer(n, out, 0x80u, index, sub, ABORT_CMD);
    } else if (e->access != HS_CO_RW) {
        sdo_answer(n, out, 0x80u, index, sub, ABORT_READ_ONLY);
    } else if ((cmd & 0x01u) != 0u && 4u - ((cmd >> 2) & 3u) != e->size) {
        sdo_answer(n, out, 0x80u, index, sub, ABORT_LENGTH);
    } else if (mapping_locked(n, index)) {
        sdo_answer(n, out, 0x80u, index, sub, ABORT_UNSUPPORTED);
    } else {
        e->value = e->size == 4u ? v : (v & ((1u << (8u * e->size)) - 1u));
        if (n->profile == 1u && index == 0x6060u) {
            hs_co_node_find(n, 0x6061u, 0u)->value = e->value; /* the mode is taken at once */
        }
        sdo_answer(n, out, 0x60u, index, sub, 0u);
    }
}

/* RPDO1 is valid and mapped as the master's layout, with (3 entries) or
 * without (2) the force feed-forward: 3 or 2; 0 when not usable. */
static uint32_t rpdo1_layout(hs_co_node_t *n, uint32_t *cob)
{
    uint32_t c = od_value(n, 0x1400u, 1u);
    uint32_t count = od_value(n, 0x1600u, 0u);
    *cob = c & 0x7FFu;
    uint32_t target = n->profile == 1u ? 0x607A0020u : 0x66000120u;
    if ((c & 0x80000000u) != 0u || od_value(n, 0x1600u, 1u) != 0x60400010u || od_value(n, 0x1600u, 2u) != target) {
        return 0u;
    }
    if (count == 2u || (count == 3u && od_value(n, 0x1600u, 3u) ==
                                           (n->profile == 1u ? SP_CO402_FORCE_FF_MAPPING : SP_CO_FORCE_FF_MAPPING))) {
        return count;
    }
    return 0u;
}

/* The PDO is valid and mapped as the master's layout (comm index, map index). */
static int pdo_ok(hs_co_node_t *n, uint16_t comm, uint16_t map, uint32_t e1, uint32_t e2, uint32_t *cob)
{
    uint32_t c = od_value(n, comm, 1u);
    *cob = c & 0x7FFu;
    return (c & 0x80000000u) == 0u && od_value(n, map, 0u) == 2u && od_value(n, map, 1u) == e1 &&
           od_value(n, map, 2u) == e2;
}

/* CiA 402 at SYNC: the state machine, the objects, TPDO1 (statusword,
 * position actual value). */
static void on_sync_402(hs_co_node_t *n, uint16_t prev, sp_can_frame_t *tx, uint8_t *n_tx)
{
    uint32_t cob;
    sp_can_frame_t *f;
    uint16_t status;
    if ((n->control & SP_CO402_CW_FAULT_RESET) != 0u && (prev & SP_CO402_CW_FAULT_RESET) == 0u) {
        n->fault = 0u; /* the fault reset clears the cause first */
    }
    n->state402 = sp_co402_next(n->state402, n->control, prev, n->fault);
    status = (uint16_t)(sp_co402_status_bits(n->state402) | 0x0200u); /* bit 9: remote (the bus controls it) */
    hs_co_node_find(n, 0x6040u, 0u)->value = n->control;
    hs_co_node_find(n, 0x6041u, 0u)->value = status;
    hs_co_node_find(n, 0x607Au, 0u)->value = (uint32_t)n->setpoint;
    hs_co_node_find(n, 0x6064u, 0u)->value = (uint32_t)n->actual;
    if (pdo_ok(n, 0x1800u, 0x1A00u, 0x60410010u, 0x60640020u, &cob) && (f = next_tx(tx, n_tx)) != NULL) {
        (void)sp_co_tpdo1_frame(f, n->bus, n->node_id, status, n->actual);
        f->id = cob;
    }
}

static void on_sync(hs_co_node_t *n, sp_can_frame_t *tx, uint8_t *n_tx)
{
    uint32_t cob;
    uint16_t prev = n->control;
    sp_can_frame_t *f;
    if (n->nmt != SP_CO_NMT_STATE_OPERATIONAL) {
        return;
    }
    if (n->profile == 1u) {
        n->control = n->rx_control;
        n->setpoint = n->rx_setpoint;
        n->force_ff = n->rx_force_ff;
        hs_co_node_find(n, 0x60B2u, 0u)->value = (uint16_t)n->force_ff;
        on_sync_402(n, prev, tx, n_tx);
        return;
    }
    n->control = n->rx_control;
    n->setpoint = n->rx_setpoint;
    n->force_ff = n->rx_force_ff;
    if ((n->control & SP_CO408_CW_R) != 0u && (prev & SP_CO408_CW_R) == 0u) {
        n->fault = 0u; /* the fault reset clears the cause first */
    }
    n->state = sp_co408_next(n->state, n->control, prev, n->fault);
    hs_co_node_find(n, 0x6040u, 0u)->value = n->control;
    hs_co_node_find(n, 0x6041u, 0u)->value = sp_co408_status_bits(n->state);
    hs_co_node_find(n, 0x6600u, 1u)->value = (uint32_t)n->setpoint;
    hs_co_node_find(n, 0x2120u, 0u)->value = (uint16_t)n->force_ff;
    hs_co_node_find(n, 0x6601u, 1u)->value = (uint32_t)n->actual;
    if (pdo_ok(n, 0x1800u, 0x1A00u, 0x60410010u, 0x66010120u, &cob) && (f = next_tx(tx, n_tx)) != NULL) {
        (void)sp_co_tpdo1_frame(f, n->bus, n->node_id, sp_co408_status_bits(n->state), n->actual);
        f->id = cob;
    }
    if (pdo_ok(n, 0x1801u, 0x1A01u, 0x21100110u, 0x21100210u, &cob) && (f = next_tx(tx, n_tx)) != NULL) {
        (void)sp_co_tpdo2_frame(f, n->bus, n->node_id, n->pa_kpa, n->pb_kpa);
        f->id = cob;
    }
}

hs_status_t hs_co_node_receive(hs_co_node_t *n, const sp_can_frame_t *f, sp_can_frame_t tx[HS_CO_MAX_TX], uint8_t *n_tx)
{
    uint32_t cob, layout;
    if (n == NULL || f == NULL || tx == NULL || n_tx == NULL) {
        return HS_E_ARG;
    }
    *n_tx = 0u;
    if (f->bus != n->bus || n->never_boot || (n->nmt == SP_CO_NMT_STATE_BOOTUP && f->id != SP_CO_COB_NMT)) {
        return HS_OK;
    }
    if (f->id == SP_CO_COB_NMT) {
        if (f->len == 2u && (f->data[1] == 0u || f->data[1] == n->node_id)) {
            switch (f->data[0]) {
            case SP_CO_NMT_START:
                if (n->nmt != SP_CO_NMT_STATE_BOOTUP) {
                    n->nmt = SP_CO_NMT_STATE_OPERATIONAL;
                    n->rpdo_seen = 0u;
                }
                break;
            case SP_CO_NMT_STOP:
                n->nmt = SP_CO_NMT_STATE_STOPPED;
                break;
            case SP_CO_NMT_PREOP:
                n->nmt = SP_CO_NMT_STATE_PREOP;
                break;
            case SP_CO_NMT_RESET_NODE:
                reset(n, 1);
                break;
            case SP_CO_NMT_RESET_COMM:
                reset(n, 0);
                break;
            default:
                break;
            }
        }
        return HS_OK;
    }
    if (f->id == SP_CO_COB_SYNC) {
        on_sync(n, tx, n_tx);
        return HS_OK;
    }
    if (f->id > SP_CO_COB_HEARTBEAT && f->id <= SP_CO_COB_HEARTBEAT + SP_CO_NODE_MAX && f->len == 1u) {
        uint32_t c = od_value(n, 0x1016u, 1u);
        if ((c & 0xFFFFu) != 0u && ((c >> 16) & 0x7Fu) == f->id - SP_CO_COB_HEARTBEAT) {
            n->hbc_seen = 1u;
            n->hbc_elapsed_ms = 0u;
        }
        return HS_OK;
    }
    if (f->id == SP_CO_COB_SDO_RX + n->node_id && f->len == 8u &&
        (n->nmt == SP_CO_NMT_STATE_PREOP || n->nmt == SP_CO_NMT_STATE_OPERATIONAL)) {
        sp_can_frame_t *out = next_tx(tx, n_tx);
        sdo_serve(n, f, out);
        if (out->len == 0u) {
            *n_tx = 0u;
        } else if (n->sdo_delay_ms != 0u) { /* the slow server: the answer waits (a newer request replaces it) */
            n->sdo_held = *out;
            n->sdo_holding = 1u;
            n->sdo_wait_ms = n->sdo_delay_ms;
            *n_tx = 0u;
        }
        return HS_OK;
    }
    if (n->nmt == SP_CO_NMT_STATE_OPERATIONAL && (layout = rpdo1_layout(n, &cob)) != 0u && f->id == cob) {
        uint16_t cw;
        int32_t sp;
        int16_t force = 0;
        sp_can_frame_t g = *f;
        g.id = SP_CO_COB_RPDO1 + n->node_id; /* the parser checks the predefined id */
        if ((layout == 3u ? sp_co_rpdo1_ff_parse(&g, n->node_id, &cw, &sp, &force)
                          : sp_co_rpdo1_parse(&g, n->node_id, &cw, &sp)) == SP_OK) {
            n->rx_control = cw;
            n->rx_setpoint = sp;
            n->rx_force_ff = force;
            n->rpdo_seen = 1u;
            n->rpdo_age_ms = 0u;
        }
    }
    return HS_OK;
}

hs_status_t hs_co_node_tick(hs_co_node_t *n, uint32_t ms, sp_can_frame_t tx[HS_CO_MAX_TX], uint8_t *n_tx)
{
    uint32_t hb, timer;
    sp_can_frame_t *f;
    if (n == NULL || tx == NULL || n_tx == NULL || ms == 0u || ms > 1000u) {
        return HS_E_ARG;
    }
    *n_tx = 0u;
    if (n->never_boot) {
        return HS_OK;
    }
    if (n->boot_pending) {
        n->boot_pending = 0u;
        n->nmt = SP_CO_NMT_STATE_PREOP;
        if ((f = next_tx(tx, n_tx)) != NULL) {
            (void)sp_co_heartbeat_frame(f, n->bus, n->node_id, SP_CO_NMT_STATE_BOOTUP);
        }
        return HS_OK;
    }
    if (n->nmt == SP_CO_NMT_STATE_BOOTUP) {
        n->sdo_holding = 0u; /* a reset drops an answer held back */
        return HS_OK;
    }
    if (n->sdo_holding) {
        n->sdo_wait_ms = (uint16_t)(ms >= n->sdo_wait_ms ? 0u : n->sdo_wait_ms - ms);
        if (n->sdo_wait_ms == 0u && (f = next_tx(tx, n_tx)) != NULL) {
            *f = n->sdo_held;
            n->sdo_holding = 0u;
        }
    }
    hb = od_value(n, 0x1017u, 0u);
    n->hb_elapsed_ms += ms;
    if (hb != 0u && n->hb_elapsed_ms >= hb) {
        n->hb_elapsed_ms = 0u;
        if (!n->silent && (f = next_tx(tx, n_tx)) != NULL) {
            (void)sp_co_heartbeat_frame(f, n->bus, n->node_id, (sp_co_nmt_state_t)n->nmt);
        }
    }
    timer = od_value(n, 0x1400u, 5u);
    if (n->rpdo_age_ms < UINT32_MAX - ms) {
        n->rpdo_age_ms += ms;
    }
    if (timer != 0u && n->nmt == SP_CO_NMT_STATE_OPERATIONAL && n->rpdo_seen &&
        (n->profile == 1u ? n->state402 == SP_CO402_OPERATION_ENABLED : n->state == SP_CO408_ACTIVE) &&
        n->rpdo_age_ms > timer && !n->fault) {
        (void)hs_co_node_raise(n, EMCY_RPDO_TIMEOUT);
    }
    {
        uint32_t c = od_value(n, 0x1016u, 1u);
        if (n->hbc_seen && (c & 0xFFFFu) != 0u) {
            n->hbc_elapsed_ms += ms;
            if (n->hbc_elapsed_ms > (c & 0xFFFFu)) {
                n->hbc_seen = 0u; /* once per silence: monitoring starts again with the next heartbeat */
                if (!n->fault) {
                    (void)hs_co_node_raise(n, EMCY_HEARTBEAT);
                }
            }
        }
    }
    if (n->emcy_pending != 0u && (f = next_tx(tx, n_tx)) != NULL) {
        (void)sp_co_emcy_frame(f, n->bus, n->node_id, n->emcy_pending, 0x01u);
        n->emcy_pending = 0u;
    }
    return HS_OK;
}

hs_status_t hs_co_node_raise(hs_co_node_t *n, uint16_t code)
{
    if (n == NULL || code == 0u) {
        return HS_E_ARG;
    }
    n->fault = 1u;
    n->emcy_pending = code;
    hs_co_node_find(n, 0x1001u, 0u)->value = 0x01u;
    if (n->profile == 1u) {
        hs_co_node_find(n, 0x603Fu, 0u)->value = code;
    }
    return HS_OK;
}

int hs_co_node_follows(const hs_co_node_t *n)
{
    if (n == NULL || n->nmt != SP_CO_NMT_STATE_OPERATIONAL) {
        return 0;
    }
    return n->profile == 1u ? n->state402 == SP_CO402_OPERATION_ENABLED : n->state == SP_CO408_ACTIVE;
}

double hs_co_node_force_n(const hs_co_node_t *n)
{
    uint32_t i;
    if (n->profile != 1u) {
        return 10.0 * (double)n->force_ff;
    }
    i = od_slot(n, 0x6076u, 0u);
    return i < n->n_od ? (double)n->force_ff * (double)n->od[i].value * 1e-6 : 0.0;
}
