/* SPDX-License-Identifier: Apache-2.0 */
/* canopen.c - CANopen frames and the CiA 408 device state machine (sp/canopen/canopen.h). */
#include "sp/canopen/canopen.h"

static int node_ok(uint8_t node)
{
    return node >= SP_CO_NODE_MIN && node <= SP_CO_NODE_MAX;
}

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
    p[2] = (uint8_t)((v >> 16) & 0xFFu);
    p[3] = (uint8_t)(v >> 24);
}

/* The header of a classic frame; the caller writes all of data[0..8). */
static sp_status_t frame_head(sp_can_frame_t *f, uint8_t bus, uint32_t id, uint8_t len)
{
    if (f == NULL || bus >= SP_CAN_BUSES) {
        return SP_E_ARG;
    }
    f->id = id;
    f->bus = bus;
    f->len = len;
    f->flags = 0u;
    return SP_OK;
}

static sp_status_t start_frame(sp_can_frame_t *f, uint8_t bus, uint32_t id, uint8_t len)
{
    if (frame_head(f, bus, id, len) != SP_OK) {
        return SP_E_ARG;
    }
    /* Classic frames: the 8 bytes a classic frame can carry are written (zero
     * past len); data[8..64) is left as it was (see sp/canopen/canopen.h). Clearing
     * the whole 64-byte buffer costs about 290 instructions per frame on the
     * M4 with newlib-nano's byte-wise memset. */
    put_u32(&f->data[0], 0u);
    put_u32(&f->data[4], 0u);
    return SP_OK;
}

static uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)((uint16_t)p[0] | (uint16_t)((uint16_t)p[1] << 8));
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* Two's complement reinterpretation without implementation-defined casts. */
static int32_t u32_to_i32(uint32_t v)
{
    if (v <= (uint32_t)INT32_MAX) {
        return (int32_t)v;
    }
    return (int32_t)(v - 0x80000000u) - INT32_MAX - 1;
}

static uint32_t i32_to_u32(int32_t v)
{
    if (v >= 0) {
        return (uint32_t)v;
    }
    return (uint32_t)(v + INT32_MAX + 1) + 0x80000000u;
}

sp_status_t sp_co_nmt_frame(sp_can_frame_t *f, uint8_t bus, sp_co_nmt_cmd_t cmd, uint8_t node)
{
    if (!node_ok(node) || start_frame(f, bus, SP_CO_COB_NMT, 2u) != SP_OK) {
        return SP_E_ARG;
    }
    f->data[0] = (uint8_t)cmd;
    f->data[1] = node;
    return SP_OK;
}

sp_status_t sp_co_sync_frame(sp_can_frame_t *f, uint8_t bus)
{
    return start_frame(f, bus, SP_CO_COB_SYNC, 0u);
}

sp_status_t sp_co_heartbeat_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, sp_co_nmt_state_t state)
{
    if (!node_ok(node) || start_frame(f, bus, SP_CO_COB_HEARTBEAT + node, 1u) != SP_OK) {
        return SP_E_ARG;
    }
    f->data[0] = (uint8_t)state;
    return SP_OK;
}

uint8_t sp_co_node_of(const sp_can_frame_t *f, uint32_t base)
{
    if (f == NULL || f->id <= base || f->id > base + SP_CO_NODE_MAX) {
        return 0u;
    }
    return (uint8_t)(f->id - base);
}

sp_status_t sp_co_heartbeat_parse(const sp_can_frame_t *f, uint8_t *node, uint8_t *state)
{
    uint8_t n = sp_co_node_of(f, SP_CO_COB_HEARTBEAT);
    if (n == 0u || f->len != 1u || node == NULL || state == NULL) {
        return SP_E_FRAME;
    }
    *node = n;
    *state = (uint8_t)(f->data[0] & 0x7Fu);
    return SP_OK;
}

/* The PDOs write each of their 8 bytes once: the fields, then zeros. */
static sp_status_t pdo6_frame(sp_can_frame_t *f, uint8_t bus, uint32_t base, uint8_t node, uint16_t word, int32_t v)
{
    if (!node_ok(node) || frame_head(f, bus, base + node, 6u) != SP_OK) {
        return SP_E_ARG;
    }
    put_u16(&f->data[0], word);
    put_u32(&f->data[2], i32_to_u32(v));
    f->data[6] = 0u;
    f->data[7] = 0u;
    return SP_OK;
}

static sp_status_t pdo6_parse(const sp_can_frame_t *f, uint32_t base, uint8_t node, uint16_t *word, int32_t *v)
{
    if (f == NULL || word == NULL || v == NULL || !node_ok(node) || f->id != base + node || f->len != 6u) {
        return SP_E_FRAME;
    }
    *word = get_u16(&f->data[0]);
    *v = u32_to_i32(get_u32(&f->data[2]));
    return SP_OK;
}

sp_status_t sp_co_rpdo1_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t control, int32_t setpoint)
{
    return pdo6_frame(f, bus, SP_CO_COB_RPDO1, node, control, setpoint);
}

sp_status_t sp_co_rpdo1_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *control, int32_t *setpoint)
{
    return pdo6_parse(f, SP_CO_COB_RPDO1, node, control, setpoint);
}

sp_status_t sp_co_rpdo1_ff_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t control, int32_t setpoint,
                                 int16_t force_dan)
{
    if (!node_ok(node) || frame_head(f, bus, SP_CO_COB_RPDO1 + node, 8u) != SP_OK) {
        return SP_E_ARG;
    }
    put_u16(&f->data[0], control);
    put_u32(&f->data[2], i32_to_u32(setpoint));
    put_u16(&f->data[6], (uint16_t)(force_dan < 0 ? (uint16_t)(65536 + (int32_t)force_dan) : (uint16_t)force_dan));
    return SP_OK;
}

sp_status_t sp_co_rpdo1_ff_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *control, int32_t *setpoint,
                                 int16_t *force_dan)
{
    uint16_t raw;
    if (f == NULL || control == NULL || setpoint == NULL || force_dan == NULL || !node_ok(node) ||
        f->id != SP_CO_COB_RPDO1 + node || f->len != 8u) {
        return SP_E_FRAME;
    }
    *control = get_u16(&f->data[0]);
    *setpoint = u32_to_i32(get_u32(&f->data[2]));
    raw = get_u16(&f->data[6]);
    *force_dan = raw >= 0x8000u ? (int16_t)((int32_t)raw - 65536) : (int16_t)raw;
    return SP_OK;
}

sp_status_t sp_co_tpdo1_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t status, int32_t actual)
{
    return pdo6_frame(f, bus, SP_CO_COB_TPDO1, node, status, actual);
}

sp_status_t sp_co_tpdo1_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *status, int32_t *actual)
{
    return pdo6_parse(f, SP_CO_COB_TPDO1, node, status, actual);
}

sp_status_t sp_co_tpdo2_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t pa_kpa, uint16_t pb_kpa)
{
    if (!node_ok(node) || frame_head(f, bus, SP_CO_COB_TPDO2 + node, 4u) != SP_OK) {
        return SP_E_ARG;
    }
    put_u16(&f->data[0], pa_kpa);
    put_u16(&f->data[2], pb_kpa);
    put_u32(&f->data[4], 0u);
    return SP_OK;
}

sp_status_t sp_co_tpdo2_parse(const sp_can_frame_t *f, uint8_t node, uint16_t *pa_kpa, uint16_t *pb_kpa)
{
    if (f == NULL || pa_kpa == NULL || pb_kpa == NULL || !node_ok(node) || f->id != SP_CO_COB_TPDO2 + node ||
        f->len != 4u) {
        return SP_E_FRAME;
    }
    *pa_kpa = get_u16(&f->data[0]);
    *pb_kpa = get_u16(&f->data[2]);
    return SP_OK;
}

sp_status_t sp_co_emcy_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t code, uint8_t reg)
{
    if (!node_ok(node) || start_frame(f, bus, SP_CO_COB_EMCY + node, 8u) != SP_OK) {
        return SP_E_ARG;
    }
    put_u16(&f->data[0], code);
    f->data[2] = reg;
    return SP_OK;
}

sp_status_t sp_co_emcy_parse(const sp_can_frame_t *f, uint8_t *node, uint16_t *code, uint8_t *reg)
{
    uint8_t n = sp_co_node_of(f, SP_CO_COB_EMCY);
    if (n == 0u || f->len < 3u || f->len > 8u || node == NULL || code == NULL || reg == NULL) {
        return SP_E_FRAME;
    }
    *node = n;
    *code = get_u16(&f->data[0]);
    *reg = f->data[2];
    return SP_OK;
}

const char *sp_co_emcy_class_name(uint16_t code)
{
    static const char *const by_nibble[16] = {"error reset", "generic",         "current",         "voltage",
                                              "temperature", "device hardware", "device software", "additional modules",
                                              "monitoring",  "external",        "external",        "external",
                                              "external",    "external",        "external",        "device specific"};
    uint32_t hi = (uint32_t)(code >> 12);
    if (code == 0u) {
        return "error reset";
    }
    if ((code & 0xFF00u) == 0x8100u) {
        return "communication";
    }
    if ((code & 0xFF00u) == 0x8200u) {
        return "protocol";
    }
    if ((code & 0xFF00u) == 0xF000u) {
        return "additional functions";
    }
    if (hi == 0u) {
        return "error reset or no error";
    }
    if (hi >= 0xAu && hi <= 0xEu) {
        return "reserved";
    }
    return by_nibble[hi];
}

/* ---- SDO ---- */

#define SDO_CCS_DOWNLOAD_INIT 0x20u /* client: initiate download (1 << 5) */
#define SDO_CCS_UPLOAD_INIT 0x40u   /* client: initiate upload (2 << 5) */
#define SDO_SCS_UPLOAD_INIT 0x40u   /* server: initiate upload response (2 << 5) */
#define SDO_SCS_DOWNLOAD_INIT 0x60u /* server: initiate download response (3 << 5) */
#define SDO_CS_ABORT 0x80u          /* either side: abort transfer (4 << 5) */
#define SDO_FLAG_E 0x02u            /* expedited */
#define SDO_FLAG_S 0x01u            /* size indicated */

static void put_mux(uint8_t *d, uint16_t index, uint8_t sub)
{
    put_u16(&d[1], index);
    d[3] = sub;
}

sp_status_t sp_co_sdo_download_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t index, uint8_t sub,
                                     uint8_t size, uint32_t value)
{
    if (!node_ok(node) || (size != 1u && size != 2u && size != 4u) ||
        start_frame(f, bus, SP_CO_COB_SDO_RX + node, 8u) != SP_OK) {
        return SP_E_ARG;
    }
    /* n = 4 - size unused bytes in bits 3..2 */
    f->data[0] = (uint8_t)(SDO_CCS_DOWNLOAD_INIT | ((uint32_t)(4u - size) << 2) | SDO_FLAG_E | SDO_FLAG_S);
    put_mux(f->data, index, sub);
    put_u32(&f->data[4], size == 4u ? value : (value & ((1u << (8u * size)) - 1u)));
    return SP_OK;
}

sp_status_t sp_co_sdo_upload_frame(sp_can_frame_t *f, uint8_t bus, uint8_t node, uint16_t index, uint8_t sub)
{
    if (!node_ok(node) || start_frame(f, bus, SP_CO_COB_SDO_RX + node, 8u) != SP_OK) {
        return SP_E_ARG;
    }
    f->data[0] = SDO_CCS_UPLOAD_INIT;
    put_mux(f->data, index, sub);
    return SP_OK;
}

sp_status_t sp_co_sdo_parse(const sp_can_frame_t *f, uint8_t node, uint16_t index, uint8_t sub,
                            sp_co_sdo_answer_t *answer, uint32_t *value, uint8_t *size)
{
    uint8_t cs;
    if (f == NULL || answer == NULL || value == NULL || size == NULL || !node_ok(node) ||
        f->id != SP_CO_COB_SDO_TX + node || f->len != 8u) {
        return SP_E_FRAME;
    }
    if (get_u16(&f->data[1]) != index || f->data[3] != sub) {
        return SP_E_FRAME;
    }
    cs = (uint8_t)(f->data[0] & 0xE0u);
    if (cs == SDO_CS_ABORT) {
        *answer = SP_CO_SDO_ABORTED;
        *value = get_u32(&f->data[4]);
        *size = 0u;
        return SP_OK;
    }
    if (cs == SDO_SCS_DOWNLOAD_INIT) {
        *answer = SP_CO_SDO_DOWNLOAD_OK;
        *value = 0u;
        *size = 0u;
        return SP_OK;
    }
    if (cs == SDO_SCS_UPLOAD_INIT) {
        uint8_t n;
        uint32_t v = get_u32(&f->data[4]);
        if ((f->data[0] & SDO_FLAG_E) == 0u) {
            *answer = SP_CO_SDO_UNSUPPORTED;
            *value = 0u;
            *size = 0u;
            return SP_OK;
        }
        n = (f->data[0] & SDO_FLAG_S) != 0u ? (uint8_t)(4u - ((uint32_t)(f->data[0] >> 2) & 3u)) : 4u;
        *answer = SP_CO_SDO_UPLOAD_OK;
        *value = n == 4u ? v : (v & ((1u << (8u * n)) - 1u));
        *size = n;
        return SP_OK;
    }
    return SP_E_FRAME;
}

const char *sp_co_sdo_abort_name(uint32_t code)
{
    static const struct {
        uint32_t code;
        const char *name;
    } table[] = {
        {0x05030000u, "toggle bit not alternated"},
        {0x05040000u, "SDO protocol timed out"},
        {0x05040001u, "command specifier not valid or unknown"},
        {0x05040005u, "out of memory"},
        {0x06010000u, "unsupported access to an object"},
        {0x06010001u, "attempt to read a write only object"},
        {0x06010002u, "attempt to write a read only object"},
        {0x06020000u, "object does not exist in the object dictionary"},
        {0x06040041u, "object cannot be mapped to the PDO"},
        {0x06040042u, "the number and length of the objects to be mapped would exceed the PDO length"},
        {0x06040043u, "general parameter incompatibility"},
        {0x06040047u, "general internal incompatibility in the device"},
        {0x06060000u, "access failed due to a hardware error"},
        {0x06070010u, "data type does not match, length of service parameter does not match"},
        {0x06070012u, "data type does not match, length of service parameter too high"},
        {0x06070013u, "data type does not match, length of service parameter too low"},
        {0x06090011u, "sub-index does not exist"},
        {0x06090030u, "value range of parameter exceeded"},
        {0x06090031u, "value of parameter written too high"},
        {0x06090032u, "value of parameter written too low"},
        {0x08000000u, "general error"},
        {0x08000020u, "data cannot be transferred or stored to the application"},
        {0x08000021u, "data cannot be transferred because of local control"},
        {0x08000022u, "data cannot be transferred because of the present device state"},
    };
    uint32_t i;
    for (i = 0u; i < sizeof table / sizeof table[0]; i++) {
        if (table[i].code == code) {
            return table[i].name;
        }
    }
    return "unknown abort code";
}

/* ---- CiA 408 ---- */

sp_co408_state_t sp_co408_state(uint16_t status)
{
    switch (status & 0x0Fu) {
    case 0x0u:
        return SP_CO408_NOT_READY;
    case 0x8u:
        return SP_CO408_INIT;
    case 0x9u:
        return SP_CO408_DISABLED;
    case 0xBu:
        return SP_CO408_HOLD;
    case 0xFu:
        return SP_CO408_ACTIVE;
    case 0x7u:
        return SP_CO408_FAULT_REACTION;
    case 0x3u:
        return SP_CO408_FAULT_HOLD;
    case 0x1u:
        return SP_CO408_FAULT_DISABLED;
    default:
        return SP_CO408_UNKNOWN;
    }
}

int sp_co408_is_fault(sp_co408_state_t s)
{
    return s == SP_CO408_FAULT_REACTION || s == SP_CO408_FAULT_HOLD || s == SP_CO408_FAULT_DISABLED;
}

uint16_t sp_co408_status_bits(sp_co408_state_t s)
{
    static const uint16_t bits[] = {0x0u, 0x8u, 0x9u, 0xBu, 0xFu, 0x7u, 0x3u, 0x1u};
    return (uint32_t)s < sizeof bits / sizeof bits[0] ? bits[s] : 0u;
}

const char *sp_co408_state_name(sp_co408_state_t s)
{
    static const char *const names[] = {"NOT_READY",      "INIT",       "DISABLED",       "HOLD",   "ACTIVE",
                                        "FAULT_REACTION", "FAULT_HOLD", "FAULT_DISABLED", "UNKNOWN"};
    return (uint32_t)s < sizeof names / sizeof names[0] ? names[s] : "UNKNOWN";
}

uint16_t sp_co408_control_word(sp_co_request_t req, int reset)
{
    uint16_t cw;
    switch (req) {
    case SP_CO_REQ_HOLD:
        cw = SP_CO408_CW_D | SP_CO408_CW_H;
        break;
    case SP_CO_REQ_ACTIVE:
        cw = SP_CO408_CW_D | SP_CO408_CW_H | SP_CO408_CW_M;
        break;
    case SP_CO_REQ_DISABLED:
    default:
        cw = SP_CO408_CW_D;
        break;
    }
    return reset ? (uint16_t)(cw | SP_CO408_CW_R) : cw;
}

sp_co408_state_t sp_co408_target(sp_co_request_t req)
{
    if (req == SP_CO_REQ_ACTIVE) {
        return SP_CO408_ACTIVE;
    }
    return req == SP_CO_REQ_HOLD ? SP_CO408_HOLD : SP_CO408_DISABLED;
}

/* The non-fault state a control word asks for. */
static sp_co408_state_t asked(uint16_t cw)
{
    if ((cw & SP_CO408_CW_D) == 0u) {
        return SP_CO408_INIT;
    }
    if ((cw & SP_CO408_CW_H) == 0u) {
        return SP_CO408_DISABLED;
    }
    return (cw & SP_CO408_CW_M) != 0u ? SP_CO408_ACTIVE : SP_CO408_HOLD;
}

sp_co408_state_t sp_co408_next(sp_co408_state_t s, uint16_t control, uint16_t prev_control, int fault)
{
    int r_edge = (control & SP_CO408_CW_R) != 0u && (prev_control & SP_CO408_CW_R) == 0u;
    sp_co408_state_t want = asked(control);
    switch (s) {
    case SP_CO408_FAULT_REACTION:
        return SP_CO408_FAULT_HOLD;
    case SP_CO408_FAULT_HOLD:
    case SP_CO408_FAULT_DISABLED:
        if (r_edge && !fault) {
            /* the reset leads to the state the control word asks, at most HOLD */
            return want == SP_CO408_ACTIVE ? SP_CO408_HOLD : want;
        }
        if (s == SP_CO408_FAULT_HOLD && want < SP_CO408_HOLD) {
            return SP_CO408_FAULT_DISABLED;
        }
        if (s == SP_CO408_FAULT_DISABLED && want == SP_CO408_INIT) {
            return SP_CO408_NOT_READY; /* FAULT_INIT shows 0000 */
        }
        return s;
    case SP_CO408_UNKNOWN:
        return SP_CO408_FAULT_REACTION;
    default:
        break;
    }
    if (fault) {
        return s == SP_CO408_NOT_READY || s == SP_CO408_INIT ? s : SP_CO408_FAULT_REACTION;
    }
    if (s == SP_CO408_NOT_READY) {
        return SP_CO408_INIT;
    }
    /* one step per call along INIT <-> DISABLED <-> HOLD <-> ACTIVE */
    if (want > s) {
        return (sp_co408_state_t)(s + 1);
    }
    if (want < s) {
        return (sp_co408_state_t)(s - 1);
    }
    return s;
}

/* ---- CiA 402 ---- */

/* The statusword's state by its six bits that matter (0..3, 5, 6: index
 * bits 0..3, then 4..5), looked up instead of searched: the rows of
 * docs/reference/canopen.md's (mask, value) table in order, the first that matches;
 * the unit test compares every word with that search. */
#define S_NR SP_CO402_NOT_READY
#define S_SD SP_CO402_SWITCH_ON_DISABLED
#define S_RD SP_CO402_READY
#define S_SO SP_CO402_SWITCHED_ON
#define S_OE SP_CO402_OPERATION_ENABLED
#define S_QS SP_CO402_QUICK_STOP_ACTIVE
#define S_FR SP_CO402_FAULT_REACTION
#define S_F SP_CO402_FAULT
#define S_U SP_CO402_UNKNOWN
static const uint8_t state402[64] = {
    S_NR, S_U,  S_U, S_U,  S_U, S_U, S_U, S_QS, S_F, S_U, S_U, S_U, S_U, S_U, S_U, S_FR, /* bit 6 = 0, bit 5 = 0 */
    S_NR, S_RD, S_U, S_SO, S_U, S_U, S_U, S_OE, S_F, S_U, S_U, S_U, S_U, S_U, S_U, S_FR, /* bit 6 = 0, bit 5 = 1 */
    S_SD, S_U,  S_U, S_U,  S_U, S_U, S_U, S_U,  S_U, S_U, S_U, S_U, S_U, S_U, S_U, S_U,  /* bit 6 = 1, bit 5 = 0 */
    S_SD, S_U,  S_U, S_U,  S_U, S_U, S_U, S_U,  S_U, S_U, S_U, S_U, S_U, S_U, S_U, S_U,  /* bit 6 = 1, bit 5 = 1 */
};
#undef S_NR
#undef S_SD
#undef S_RD
#undef S_SO
#undef S_OE
#undef S_QS
#undef S_FR
#undef S_F
#undef S_U

sp_co402_state_t sp_co402_state(uint16_t status)
{
    return (sp_co402_state_t)state402[(status & 0x0Fu) | ((uint32_t)(status >> 1) & 0x30u)];
}

int sp_co402_is_fault(sp_co402_state_t s)
{
    return s == SP_CO402_FAULT_REACTION || s == SP_CO402_FAULT;
}

uint16_t sp_co402_status_bits(sp_co402_state_t s)
{
    static const uint16_t bits[] = {0x00u, 0x40u, 0x21u, 0x23u, 0x27u, 0x07u, 0x0Fu, 0x08u};
    return (uint32_t)s < sizeof bits / sizeof bits[0] ? bits[s] : 0u;
}

const char *sp_co402_state_name(sp_co402_state_t s)
{
    static const char *const names[] = {"NOT_READY_TO_SWITCH_ON",
                                        "SWITCH_ON_DISABLED",
                                        "READY_TO_SWITCH_ON",
                                        "SWITCHED_ON",
                                        "OPERATION_ENABLED",
                                        "QUICK_STOP_ACTIVE",
                                        "FAULT_REACTION_ACTIVE",
                                        "FAULT",
                                        "UNKNOWN"};
    return (uint32_t)s < sizeof names / sizeof names[0] ? names[s] : "UNKNOWN";
}

sp_co402_state_t sp_co402_target(sp_co_request_t req)
{
    return req == SP_CO_REQ_HOLD || req == SP_CO_REQ_ACTIVE ? SP_CO402_OPERATION_ENABLED : SP_CO402_READY;
}

uint16_t sp_co402_control_word(sp_co402_state_t s, sp_co402_state_t target, int reset, int quick_stop)
{
    if (reset) {
        return SP_CO402_CW_FAULT_RESET;
    }
    if (quick_stop) {
        return SP_CO402_CW_QUICK_STOP;
    }
    switch (s) {
    case SP_CO402_SWITCH_ON_DISABLED:
        return target >= SP_CO402_READY && target <= SP_CO402_OPERATION_ENABLED ? SP_CO402_CW_SHUTDOWN
                                                                                : SP_CO402_CW_DISABLE_VOLTAGE;
    case SP_CO402_READY:
        return target == SP_CO402_SWITCHED_ON || target == SP_CO402_OPERATION_ENABLED ? SP_CO402_CW_SWITCH_ON
                                                                                      : SP_CO402_CW_SHUTDOWN;
    case SP_CO402_SWITCHED_ON:
        if (target == SP_CO402_OPERATION_ENABLED) {
            return SP_CO402_CW_ENABLE_OPERATION;
        }
        return target == SP_CO402_SWITCHED_ON ? SP_CO402_CW_SWITCH_ON : SP_CO402_CW_SHUTDOWN;
    case SP_CO402_OPERATION_ENABLED:
        if (target == SP_CO402_OPERATION_ENABLED) {
            return SP_CO402_CW_ENABLE_OPERATION;
        }
        return target == SP_CO402_SWITCHED_ON ? SP_CO402_CW_SWITCH_ON : SP_CO402_CW_SHUTDOWN;
    default: /* not ready (the drive moves on by itself), quick stop active, fault states */
        return SP_CO402_CW_DISABLE_VOLTAGE;
    }
}

/* The command of a controlword (bits 0..3): the state it leads to from s,
 * or s when the command does not apply there. */
static sp_co402_state_t command_402(sp_co402_state_t s, uint16_t cw)
{
    uint32_t c = cw & 0x0Fu;
    if ((c & 0x2u) == 0u) { /* disable voltage */
        return SP_CO402_SWITCH_ON_DISABLED;
    }
    if ((c & 0x4u) == 0u) { /* quick stop */
        return s == SP_CO402_OPERATION_ENABLED ? SP_CO402_QUICK_STOP_ACTIVE
                                               : (s == SP_CO402_QUICK_STOP_ACTIVE ? s : SP_CO402_SWITCH_ON_DISABLED);
    }
    if (s == SP_CO402_QUICK_STOP_ACTIVE) {
        return s; /* left by disable voltage only */
    }
    if ((c & 0x1u) == 0u) { /* shutdown */
        return SP_CO402_READY;
    }
    if (s == SP_CO402_READY) { /* switch on (with or without enable operation: one step per call) */
        return SP_CO402_SWITCHED_ON;
    }
    if ((c & 0x8u) == 0u) { /* switch on / disable operation */
        return s == SP_CO402_OPERATION_ENABLED ? SP_CO402_SWITCHED_ON : s;
    }
    return s == SP_CO402_SWITCHED_ON ? SP_CO402_OPERATION_ENABLED : s; /* enable operation */
}

sp_co402_state_t sp_co402_next(sp_co402_state_t s, uint16_t control, uint16_t prev_control, int fault)
{
    int reset_edge = (control & SP_CO402_CW_FAULT_RESET) != 0u && (prev_control & SP_CO402_CW_FAULT_RESET) == 0u;
    switch (s) {
    case SP_CO402_FAULT_REACTION:
        return SP_CO402_FAULT;
    case SP_CO402_FAULT:
        return reset_edge && !fault ? SP_CO402_SWITCH_ON_DISABLED : SP_CO402_FAULT;
    case SP_CO402_UNKNOWN:
        return SP_CO402_FAULT_REACTION;
    case SP_CO402_NOT_READY:
        return SP_CO402_SWITCH_ON_DISABLED;
    default:
        break;
    }
    if (fault) {
        return SP_CO402_FAULT_REACTION;
    }
    if (s == SP_CO402_SWITCH_ON_DISABLED) {
        /* only shutdown leaves it */
        return (control & 0x2u) != 0u && (control & 0x4u) != 0u && (control & 0x1u) == 0u ? SP_CO402_READY : s;
    }
    return command_402(s, control);
}
