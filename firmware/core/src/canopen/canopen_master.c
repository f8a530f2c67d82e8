/* SPDX-License-Identifier: Apache-2.0 */
/* canopen_master.c - the CANopen master of CiA 408 and CiA 402 drives (sp/canopen/canopen_master.h). */
#include "sp/canopen/canopen_master.h"

#include "canopen/canopen_scaling.h"
#include "math/fixed_inline.h"

/* What differs between the two profiles, as data: the device type, the
 * PDO mappings of RPDO1 (the force feed-forward third, CiA 408 only) and
 * TPDO1, and the object read back after the plan (0: none). */
typedef struct {
    uint16_t device_type; /* 0x1000 bits 0..15 */
    uint32_t rpdo1[3];    /* control word, position setpoint, force feed-forward */
    uint32_t tpdo1[2];    /* status word, position actual value */
    uint16_t check_index; /* read after the read-backs, must be check_value (1 byte) */
    uint8_t check_value;
} profile_t;

static const profile_t profiles[2] = {
    {SP_CO408_PROFILE, {0x60400010u, 0x66000120u, SP_CO_FORCE_FF_MAPPING}, {0x60410010u, 0x66010120u}, 0u, 0u},
    {SP_CO402_PROFILE,
     {0x60400010u, 0x607A0020u, SP_CO402_FORCE_FF_MAPPING},
     {0x60410010u, 0x60640020u},
     0x6061u,
     (uint8_t)SP_CO402_MODE_CSP},
};

static const profile_t *profile_of(const sp_co_node_cfg_t *nc)
{
    return &profiles[nc->profile == (uint8_t)SP_CO_PROFILE_402 ? 1 : 0];
}

/* A node's plan is a pure function of the config: it is rebuilt (on the
 * stack, 384 B) when a start-up step needs it rather than kept per node. */

static const char *const fault_names[] = {"none",
                                          "no boot-up",
                                          "SDO abort",
                                          "SDO timeout",
                                          "SDO answer not usable",
                                          "wrong device profile",
                                          "read-back differs",
                                          "heartbeat lost",
                                          "NMT state changed",
                                          "EMCY",
                                          "device fault",
                                          "device state not reached",
                                          "TPDO timeout"};

const char *sp_co_fault_name(sp_co_fault_code_t code)
{
    return (uint32_t)code < sizeof fault_names / sizeof fault_names[0] ? fault_names[code] : "unknown";
}

sp_status_t sp_co_master_cfg_default(sp_co_master_cfg_t *cfg, uint8_t n)
{
    uint8_t k;
    if (cfg == NULL || n == 0u || n > SP_CO_MAX_NODES) {
        return SP_E_ARG;
    }
    memset(cfg, 0, sizeof *cfg);
    for (k = 0u; k < n; k++) {
        cfg->node[k].node_id = (uint8_t)(k + 1u);
        cfg->node[k].bus = k < 3u ? (uint8_t)SP_BUS_AXIS_A : (uint8_t)SP_BUS_AXIS_B;
        cfg->node[k].leg = (uint8_t)(k + 1u);
        cfg->node[k].control_mode = SP_CO408_CONTROL_MODE_AXIS;
        cfg->node[k].write_prefix = 1u;
        cfg->node[k].unit_prefix = -6;
    }
    cfg->n_nodes = n;
    cfg->sync_divider = 1u;
    cfg->pressure_feedback = 1u;
    cfg->heartbeat_ms = 20u;
    cfg->heartbeat_timeout_ms = 50u;
    cfg->setpoint_timeout_ms = 3u;
    cfg->boot_timeout_ms = 2000u;
    cfg->sdo_timeout_ms = 100u;
    cfg->state_timeout_ms = 100u;
    cfg->pdo_timeout_ms = 10u;
    cfg->master_heartbeat_ms = SP_CO_MASTER_HEARTBEAT_MS;
    cfg->master_node_id = SP_CO_NODE_MAX;
    return SP_OK;
}

sp_status_t sp_co_master_cfg_check(const sp_co_master_cfg_t *cfg)
{
    uint8_t k, j;
    if (cfg == NULL || cfg->n_nodes == 0u || cfg->n_nodes > SP_CO_MAX_NODES || cfg->sync_divider == 0u ||
        cfg->heartbeat_ms == 0u || cfg->heartbeat_timeout_ms <= cfg->heartbeat_ms || cfg->boot_timeout_ms == 0u ||
        cfg->sdo_timeout_ms == 0u || cfg->state_timeout_ms == 0u || cfg->pdo_timeout_ms == 0u ||
        cfg->setpoint_timeout_ms == 0u ||
        (cfg->master_heartbeat_ms != 0u &&
         (cfg->master_node_id < SP_CO_NODE_MIN || cfg->master_node_id > SP_CO_NODE_MAX))) {
        return SP_E_ARG;
    }
    for (k = 0u; k < cfg->n_nodes; k++) {
        const sp_co_node_cfg_t *a = &cfg->node[k];
        if (a->node_id < SP_CO_NODE_MIN || a->node_id > SP_CO_NODE_MAX || a->bus >= SP_CAN_BUSES ||
            a->profile > (uint8_t)SP_CO_PROFILE_402 || a->force_ff > 1u) {
            return SP_E_ARG;
        }
        if (cfg->master_heartbeat_ms != 0u && a->node_id == cfg->master_node_id) {
            return SP_E_ARG;
        }
        for (j = 0u; j < k; j++) {
            if (cfg->node[j].bus == a->bus && cfg->node[j].node_id == a->node_id) {
                return SP_E_ARG;
            }
        }
    }
    return SP_OK;
}

/* ---- the plan ---- */

typedef struct {
    sp_co_sdo_write_t *out;
    uint8_t n;
} plan_t;

static void add(plan_t *p, uint16_t index, uint8_t sub, uint8_t size, uint32_t value, uint8_t final, uint8_t optional)
{
    if (p->n < SP_CO_PLAN_MAX) {
        sp_co_sdo_write_t *w = &p->out[p->n++];
        w->index = index;
        w->sub = sub;
        w->size = size;
        w->value = value;
        w->final = final;
        w->optional = optional;
    }
}

/* int8 as its one byte on the bus */
static uint32_t i8_bits(int8_t v)
{
    return (uint32_t)(uint8_t)(v < 0 ? (int)v + 256 : (int)v);
}

static void add_pdo(plan_t *p, uint16_t comm, uint16_t map, uint32_t cob, const uint32_t *entries, uint8_t n,
                    uint16_t event_timer)
{
    uint8_t i;
    add(p, comm, 1u, 4u, SP_CO_PDO_COB_INVALID | cob, 0u, 0u);
    add(p, map, 0u, 1u, 0u, 0u, 0u);
    for (i = 0u; i < n; i++) {
        add(p, map, (uint8_t)(i + 1u), 4u, entries[i], 1u, 0u);
    }
    add(p, map, 0u, 1u, n, 1u, 0u);
    add(p, comm, 2u, 1u, SP_CO_TRANSMISSION_SYNC, 1u, 0u);
    if (event_timer != 0u) {
        add(p, comm, 5u, 2u, event_timer, 1u, 0u);
    }
    add(p, comm, 1u, 4u, cob, 1u, 0u);
}

sp_status_t sp_co_plan_build(const sp_co_master_cfg_t *cfg, uint8_t k, sp_co_sdo_write_t out[SP_CO_PLAN_MAX],
                             uint8_t *n)
{
    static const uint32_t tpdo2[] = {0x21100110u, 0x21100210u};
    const profile_t *pr;
    int is402;
    plan_t p;
    uint8_t id;
    if (cfg == NULL || out == NULL || n == NULL || k >= cfg->n_nodes || k >= SP_CO_MAX_NODES) {
        return SP_E_ARG;
    }
    id = cfg->node[k].node_id;
    pr = profile_of(&cfg->node[k]);
    is402 = cfg->node[k].profile == (uint8_t)SP_CO_PROFILE_402;
    p.out = out;
    p.n = 0u;
    add(&p, 0x1017u, 0u, 2u, cfg->heartbeat_ms, 1u, 0u);
    if (cfg->master_heartbeat_ms != 0u) { /* the drive watches the master: three of its periods */
        uint32_t t = 3u * (uint32_t)cfg->master_heartbeat_ms;
        add(&p, 0x1016u, 1u, 4u, ((uint32_t)cfg->master_node_id << 16) | (t > 0xFFFFu ? 0xFFFFu : t), 1u, 1u);
    }
    if (is402) {
        add(&p, 0x6060u, 0u, 1u, (uint32_t)SP_CO402_MODE_CSP, 1u, 0u);
        add(&p, 0x60C2u, 1u, 1u, cfg->sync_divider, 1u, 1u);   /* the SYNC period, ms */
        add(&p, 0x60C2u, 2u, 1u, i8_bits((int8_t)-3), 1u, 1u); /* 10^-3 s */
    } else {
        add(&p, 0x6042u, 0u, 1u, 1u, 1u, 0u);
        add(&p, 0x6043u, 0u, 1u, i8_bits(cfg->node[k].control_mode), 1u, 0u);
        if (cfg->node[k].write_prefix) {
            add(&p, 0x6600u, 2u, 1u, SP_CO_UNIT_METRE, 1u, 1u);
            add(&p, 0x6600u, 3u, 1u, i8_bits(cfg->node[k].unit_prefix), 1u, 1u);
        }
    }
    add(&p, 0x1006u, 0u, 4u, (uint32_t)cfg->sync_divider * 1000u, 1u, 1u);
    add_pdo(&p, 0x1400u, 0x1600u, SP_CO_COB_RPDO1 + id, pr->rpdo1, cfg->node[k].force_ff ? 3u : 2u,
            cfg->setpoint_timeout_ms);
    add_pdo(&p, 0x1800u, 0x1A00u, SP_CO_COB_TPDO1 + id, pr->tpdo1, 2u, 0u);
    if (cfg->pressure_feedback && !is402) {
        add_pdo(&p, 0x1801u, 0x1A01u, SP_CO_COB_TPDO2 + id, tpdo2, 2u, 0u);
    }
    *n = p.n;
    return SP_OK;
}

/* ---- the master ---- */

sp_status_t sp_co_master_init(sp_co_master_t *m)
{
    if (m == NULL) {
        return SP_E_ARG;
    }
    memset(m, 0, sizeof *m);
    return SP_OK;
}

static void restart_node(sp_co_node_t *nd, uint32_t now_ms)
{
    sp_co_fault_t none;
    memset(&none, 0, sizeof none);
    nd->phase = SP_CO_PHASE_BOOT;
    nd->step = 0u;
    nd->sdo_busy = 0u;
    nd->skipped = 0u;
    nd->nmt_pending = SP_CO_NMT_RESET_COMM;
    nd->reset_edge = 0u;
    nd->resetting = 0u;
    nd->state_ok = 0u;
    nd->tpdo1_seen = 0u;
    nd->mode_checked = 0u;
    nd->holding = 0u;
    nd->phase_since = now_ms;
    nd->fault = none;
}

sp_status_t sp_co_master_start(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint32_t now_ms)
{
    uint8_t k;
    if (m == NULL || sp_co_master_cfg_check(cfg) != SP_OK) {
        return SP_E_ARG;
    }
    memset(m, 0, sizeof *m);
    for (k = 0u; k < cfg->n_nodes; k++) {
        sp_co_sdo_write_t plan[SP_CO_PLAN_MAX];
        restart_node(&m->node[k], now_ms);
        (void)sp_co_plan_build(cfg, k, plan, &m->node[k].plan_n);
    }
    for (k = 0u; k < cfg->n_nodes; k++) { /* checked above: bus < SP_CAN_BUSES, id <= 127 */
        m->node_of[cfg->node[k].bus][cfg->node[k].node_id] = (uint8_t)(k + 1u);
    }
    m->started = 1u;
    m->hb_sent = now_ms; /* the master's first heartbeat one period after the start */
    m->last_req = SP_CO_REQ_DISABLED;
    m->nodes_req = 0xFFu; /* no request yet: the first step sets every node's */
    m->nodes_block = 0u;
    return SP_OK;
}

static void latch(sp_co_node_t *nd, sp_co_fault_code_t code, uint16_t index, uint8_t sub, uint32_t detail,
                  uint32_t expect, uint32_t now_ms)
{
    if (nd->fault.code != (uint8_t)SP_CO_F_NONE) {
        return;
    }
    nd->fault.code = (uint8_t)code;
    nd->fault.index = index;
    nd->fault.sub = sub;
    nd->fault.detail = detail;
    nd->fault.expect = expect;
    nd->fault.time_ms = now_ms;
    nd->sdo_busy = 0u;
    if (nd->phase != SP_CO_PHASE_RUN) {
        nd->phase = SP_CO_PHASE_FAILED;
        nd->nmt_pending = 0u;
    }
}

sp_status_t sp_co_master_reset(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint32_t now_ms)
{
    uint8_t k;
    if (m == NULL || cfg == NULL || cfg->n_nodes > SP_CO_MAX_NODES) {
        return SP_E_ARG;
    }
    for (k = 0u; k < cfg->n_nodes; k++) {
        sp_co_node_t *nd = &m->node[k];
        uint8_t code = nd->fault.code;
        if (code == (uint8_t)SP_CO_F_NONE) {
            continue;
        }
        if (nd->phase == SP_CO_PHASE_RUN && (code == (uint8_t)SP_CO_F_EMCY || code == (uint8_t)SP_CO_F_DEVICE_FAULT ||
                                             code == (uint8_t)SP_CO_F_DEVICE_STATE)) {
            memset(&nd->fault, 0, sizeof nd->fault);
            nd->reset_edge = 1u; /* the R bit for one SYNC period */
            nd->resetting = 1u;  /* fault states allowed until the state is reached */
            nd->state_ok = 0u;
            nd->req_since = now_ms;
        } else {
            restart_node(nd, now_ms);
        }
    }
    return SP_OK;
}

/* The object of the node's outstanding or next SDO request; 0 = none left.
 * After the read-backs (step == plan_n), the profile's check object. */
static int current_object(const sp_co_node_t *nd, const profile_t *pr, const sp_co_sdo_write_t *plan, uint16_t *index,
                          uint8_t *sub)
{
    if (nd->phase == SP_CO_PHASE_IDENTITY) {
        *index = 0x1000u;
        *sub = 0u;
        return 1;
    }
    if (nd->phase == SP_CO_PHASE_READBACK && nd->step >= nd->plan_n && pr->check_index != 0u && !nd->mode_checked &&
        nd->nmt_pending == 0u) {
        *index = pr->check_index;
        *sub = 0u;
        return 1;
    }
    if ((nd->phase == SP_CO_PHASE_WRITE || nd->phase == SP_CO_PHASE_READBACK) && nd->step < nd->plan_n) {
        *index = plan[nd->step].index;
        *sub = plan[nd->step].sub;
        return 1;
    }
    return 0;
}

/* Next read-back at or after step: final and not skipped. */
static uint8_t next_readback(const sp_co_node_t *nd, const sp_co_sdo_write_t *plan, uint8_t step)
{
    uint8_t i;
    for (i = step; i < nd->plan_n; i++) {
        if (plan[i].final && (nd->skipped & (UINT32_C(1) << i)) == 0u) {
            return i;
        }
    }
    return nd->plan_n;
}

/* After a completed request: the next step, or the next phase. */
static void advance(sp_co_node_t *nd, const profile_t *pr, const sp_co_sdo_write_t *plan)
{
    if (nd->phase == SP_CO_PHASE_IDENTITY) {
        nd->phase = SP_CO_PHASE_WRITE;
        nd->step = 0u;
    } else if (nd->phase == SP_CO_PHASE_READBACK && nd->step >= nd->plan_n) {
        nd->mode_checked = 1u; /* the profile's check object answered as expected */
    } else {
        nd->step++;
    }
    if (nd->phase == SP_CO_PHASE_WRITE && nd->step >= nd->plan_n) {
        nd->phase = SP_CO_PHASE_READBACK;
        nd->step = 0u;
    }
    if (nd->phase == SP_CO_PHASE_READBACK) {
        nd->step = next_readback(nd, plan, nd->step);
        if (nd->step >= nd->plan_n && (pr->check_index == 0u || nd->mode_checked)) {
            nd->nmt_pending = SP_CO_NMT_START;
        }
    }
}

static uint32_t size_mask(uint8_t size)
{
    return size >= 4u ? 0xFFFFFFFFu : ((UINT32_C(1) << (8u * size)) - 1u);
}

static sp_status_t on_sdo(sp_co_node_t *nd, const sp_co_master_cfg_t *cfg, uint8_t k, const sp_can_frame_t *f,
                          uint32_t now_ms)
{
    sp_co_sdo_write_t plan[SP_CO_PLAN_MAX];
    uint8_t n, size;
    uint16_t index;
    uint8_t sub;
    uint32_t value;
    sp_co_sdo_answer_t ans;
    const profile_t *pr = profile_of(&cfg->node[k]);
    (void)sp_co_plan_build(cfg, k, plan, &n);
    if (!nd->sdo_busy || !current_object(nd, pr, plan, &index, &sub)) {
        return SP_OK; /* nothing asked: a stray answer */
    }
    if (sp_co_sdo_parse(f, cfg->node[k].node_id, index, sub, &ans, &value, &size) != SP_OK) {
        return SP_E_FRAME;
    }
    nd->sdo_busy = 0u;
    if (ans == SP_CO_SDO_ABORTED) {
        if (nd->phase == SP_CO_PHASE_WRITE && plan[nd->step].optional &&
            (value == SP_CO_SDO_ABORT_NO_OBJECT || value == SP_CO_SDO_ABORT_NO_SUBINDEX)) {
            nd->skipped |= UINT32_C(1) << nd->step;
            advance(nd, pr, plan);
            return SP_OK;
        }
        latch(nd, SP_CO_F_SDO_ABORT, index, sub, value, 0u, now_ms);
        return SP_OK;
    }
    if (ans == SP_CO_SDO_UNSUPPORTED || (nd->phase == SP_CO_PHASE_WRITE) != (ans == SP_CO_SDO_DOWNLOAD_OK)) {
        latch(nd, SP_CO_F_SDO_PROTOCOL, index, sub, f->data[0], 0u, now_ms);
        return SP_OK;
    }
    if (nd->phase == SP_CO_PHASE_IDENTITY && (value & 0xFFFFu) != pr->device_type) {
        latch(nd, SP_CO_F_WRONG_PROFILE, index, sub, value, pr->device_type, now_ms);
        return SP_OK;
    }
    if (nd->phase == SP_CO_PHASE_READBACK && nd->step >= nd->plan_n) {
        if ((value & 0xFFu) != pr->check_value) {
            latch(nd, SP_CO_F_READBACK, index, sub, value, pr->check_value, now_ms);
            return SP_OK;
        }
    } else if (nd->phase == SP_CO_PHASE_READBACK) {
        uint32_t mask = size_mask(plan[nd->step].size);
        if ((value & mask) != (plan[nd->step].value & mask)) {
            latch(nd, SP_CO_F_READBACK, index, sub, value, plan[nd->step].value, now_ms);
            return SP_OK;
        }
    }
    advance(nd, pr, plan);
    return SP_OK;
}

static int node_index(const sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint8_t bus, uint8_t id)
{
    uint8_t k;
    if (bus < SP_CAN_BUSES) { /* the table of the start; valid while the config still says so */
        k = m->node_of[bus][id];
        if (k != 0u && k <= cfg->n_nodes && k <= SP_CO_MAX_NODES && cfg->node[k - 1u].bus == bus &&
            cfg->node[k - 1u].node_id == id) {
            return (int)k - 1;
        }
    }
    for (k = 0u; k < cfg->n_nodes && k < SP_CO_MAX_NODES; k++) {
        if (cfg->node[k].bus == bus && cfg->node[k].node_id == id) {
            return (int)k;
        }
    }
    return -1;
}

/* Little-endian fields of a received PDO (as sp_co_tpdo1_parse and
 * sp_co_tpdo2_parse read them; the tests compare the two). */
static uint16_t le16(const uint8_t *p)
{
    return (uint16_t)((uint32_t)p[0] | ((uint32_t)p[1] << 8));
}

static int32_t le32_signed(const uint8_t *p)
{
    uint32_t v = (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
    return v <= (uint32_t)INT32_MAX ? (int32_t)v : (int32_t)(v - 0x80000000u) - INT32_MAX - 1;
}

static void on_heartbeat(sp_co_node_t *nd, uint8_t state, uint32_t now_ms)
{
    uint8_t ph = nd->phase;
    if (ph == SP_CO_PHASE_OFF || ph == SP_CO_PHASE_FAILED) {
        return;
    }
    if (state == (uint8_t)SP_CO_NMT_STATE_BOOTUP) {
        if (ph == SP_CO_PHASE_BOOT && nd->nmt_pending == 0u) {
            nd->phase = SP_CO_PHASE_IDENTITY;
            nd->phase_since = now_ms;
            nd->hb_last = now_ms;
        } else if (ph != SP_CO_PHASE_BOOT) {
            latch(nd, SP_CO_F_NMT_STATE, 0u, 0u, state, SP_CO_NMT_STATE_OPERATIONAL, now_ms);
        }
        return;
    }
    nd->hb_last = now_ms;
    if (ph == SP_CO_PHASE_START && state == (uint8_t)SP_CO_NMT_STATE_OPERATIONAL) {
        nd->phase = SP_CO_PHASE_RUN;
        nd->phase_since = now_ms;
        nd->tpdo1_last = now_ms;
        nd->req_since = now_ms;
        nd->state_ok = 0u;
    } else if (ph == SP_CO_PHASE_RUN && state != (uint8_t)SP_CO_NMT_STATE_OPERATIONAL) {
        latch(nd, SP_CO_F_NMT_STATE, 0u, 0u, state, SP_CO_NMT_STATE_OPERATIONAL, now_ms);
    }
}

sp_status_t sp_co_master_receive(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, const sp_can_frame_t *f,
                                 uint32_t now_ms)
{
    uint32_t base;
    uint8_t id;
    int k;
    sp_co_node_t *nd;
    if (m == NULL || cfg == NULL || f == NULL) {
        return SP_E_ARG;
    }
    if (!m->started || f->id == SP_CO_COB_SYNC) {
        return SP_OK;
    }
    base = f->id & 0x780u; /* function code: the identifier's top 4 bits */
    id = (uint8_t)(f->id & 0x7Fu);
    if (id == 0u) {
        return SP_OK;
    }
    k = node_index(m, cfg, f->bus, id);
    if (k < 0) {
        return SP_OK;
    }
    nd = &m->node[k];
    switch (base) {
    case SP_CO_COB_HEARTBEAT: /* as sp_co_heartbeat_parse reads it: 1 byte, the toggle bit masked off */
        if (f->len != 1u || f->id > 0x7FFu) {
            return SP_E_FRAME;
        }
        on_heartbeat(nd, (uint8_t)(f->data[0] & 0x7Fu), now_ms);
        return SP_OK;
    case SP_CO_COB_EMCY: {
        uint8_t node, reg;
        uint16_t code;
        if (sp_co_emcy_parse(f, &node, &code, &reg) != SP_OK) {
            return SP_E_FRAME;
        }
        if (code != 0u && nd->phase != SP_CO_PHASE_OFF) {
            latch(nd, SP_CO_F_EMCY, code, 0u, reg, 0u, now_ms);
        }
        return SP_OK;
    }
    case SP_CO_COB_TPDO1: /* the mapping is fixed by the plan: status word, then the position */
        if (f->len != 6u || f->id > 0x7FFu) {
            return SP_E_FRAME;
        }
        nd->status = le16(&f->data[0]);
        nd->actual = le32_signed(&f->data[2]);
        nd->tpdo1_last = now_ms;
        nd->tpdo1_seen = 1u;
        nd->tpdo1_fresh = 1u;
        return SP_OK;
    case SP_CO_COB_TPDO2: /* chamber pressures A, B */
        if (f->len != 4u || f->id > 0x7FFu) {
            return SP_E_FRAME;
        }
        nd->pa_kpa = le16(&f->data[0]);
        nd->pb_kpa = le16(&f->data[2]);
        nd->tpdo2_fresh = 1u;
        return SP_OK;
    case SP_CO_COB_SDO_TX:
        return on_sdo(nd, cfg, (uint8_t)k, f, now_ms);
    default:
        return SP_OK;
    }
}

/* A running node's timeouts: heartbeat, then TPDO1. */
SPI_INLINE void run_timeouts(sp_co_node_t *nd, const sp_co_master_cfg_t *cfg, uint32_t now)
{
    if (now - nd->hb_last >= cfg->heartbeat_timeout_ms) { /* silent for the whole timeout */
        latch(nd, SP_CO_F_HEARTBEAT_LOST, 0u, 0u, now - nd->hb_last, cfg->heartbeat_timeout_ms, now);
    } else if (now - nd->tpdo1_last > cfg->pdo_timeout_ms) {
        latch(nd, SP_CO_F_PDO_TIMEOUT, 0u, 0u, now - nd->tpdo1_last, cfg->pdo_timeout_ms, now);
    }
}

static void timeouts(sp_co_node_t *nd, const sp_co_master_cfg_t *cfg, const profile_t *pr,
                     const sp_co_sdo_write_t *plan, uint32_t now)
{
    uint16_t index = 0u;
    uint8_t sub = 0u;
    switch (nd->phase) {
    case SP_CO_PHASE_BOOT:
        if (nd->nmt_pending == 0u && now - nd->phase_since > cfg->boot_timeout_ms) {
            latch(nd, SP_CO_F_NO_BOOT, 0u, 0u, 0u, cfg->boot_timeout_ms, now);
        }
        break;
    case SP_CO_PHASE_IDENTITY:
    case SP_CO_PHASE_WRITE:
    case SP_CO_PHASE_READBACK:
        if (nd->sdo_busy && now - nd->sdo_since > cfg->sdo_timeout_ms) {
            (void)current_object(nd, pr, plan, &index, &sub);
            latch(nd, SP_CO_F_SDO_TIMEOUT, index, sub, cfg->sdo_timeout_ms, 0u, now);
        }
        break;
    case SP_CO_PHASE_START:
        if (nd->nmt_pending == 0u && now - nd->phase_since > cfg->heartbeat_timeout_ms) {
            latch(nd, SP_CO_F_HEARTBEAT_LOST, 0u, 0u, now - nd->hb_last, cfg->heartbeat_timeout_ms, now);
        }
        break;
    case SP_CO_PHASE_RUN:
        run_timeouts(nd, cfg, now);
        break;
    default:
        break;
    }
}

/* The profile's view of a status word: the status bits of the state a
 * request leads to, whether the word shows that state, and whether it shows
 * a fault state. */
static uint32_t wanted_bits(const sp_co_node_cfg_t *nc, sp_co_request_t eff)
{
    return nc->profile == (uint8_t)SP_CO_PROFILE_402 ? sp_co402_status_bits(sp_co402_target(eff))
                                                     : sp_co408_status_bits(sp_co408_target(eff));
}

/* The node's status word decoded by its profile (seen_state, seen_fault),
 * again only when the word (or the profile) changed since the last time:
 * the word arrives every SYNC and changes with the device state only. */
/* The node's profile as decode_status keeps it (seen_profile). */
SPI_INLINE uint8_t profile_index(const sp_co_node_cfg_t *nc)
{
    return nc->profile == (uint8_t)SP_CO_PROFILE_402 ? (uint8_t)SP_CO_PROFILE_402 : (uint8_t)SP_CO_PROFILE_408;
}

SPI_INLINE void decode_status(sp_co_node_t *nd, const sp_co_node_cfg_t *nc)
{
    uint8_t profile = profile_index(nc);
    if (nd->seen_valid && nd->seen_status == nd->status && nd->seen_profile == profile) {
        return;
    }
    if (profile == (uint8_t)SP_CO_PROFILE_402) {
        sp_co402_state_t st = sp_co402_state(nd->status);
        nd->seen_state = (uint8_t)st;
        nd->seen_fault = (uint8_t)(sp_co402_is_fault(st) != 0);
    } else {
        sp_co408_state_t st = sp_co408_state(nd->status);
        nd->seen_state = (uint8_t)st;
        nd->seen_fault = (uint8_t)(sp_co408_is_fault(st) != 0);
    }
    nd->seen_status = nd->status;
    nd->seen_profile = profile;
    nd->seen_valid = 1u;
}

/* The state a request leads to, per profile (index sp_co_profile_t). */
typedef struct {
    uint8_t state[2];
} targets_t;

static void node_targets(sp_co_request_t eff, targets_t *t);
static void node_requests(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, sp_co_request_t eff, uint8_t block,
                          uint32_t now);

SPI_INLINE int shows_target(const sp_co_node_t *nd, const targets_t *t)
{
    return nd->seen_state == t->state[nd->seen_profile == (uint8_t)SP_CO_PROFILE_402 ? 1 : 0];
}

/* The status word against the effective request, every tick (decoded:
 * decode_status): a fault state latches at once (except while a fault
 * reset is under way), leaving the requested state once reached latches
 * too; not reaching it is the caller's timeout. */
SPI_INLINE void check_state(sp_co_node_t *nd, const sp_co_node_cfg_t *nc, sp_co_request_t eff, const targets_t *t,
                            uint32_t now)
{
    if (nd->phase != SP_CO_PHASE_RUN || !nd->tpdo1_seen || nd->fault.code != (uint8_t)SP_CO_F_NONE) {
        return;
    }
    if (shows_target(nd, t)) {
        nd->state_ok = 1u;
        nd->resetting = 0u;
        return;
    }
    if (nd->seen_fault && !nd->resetting) {
        latch(nd, SP_CO_F_DEVICE_FAULT, 0u, 0u, nd->status, wanted_bits(nc, eff), now);
    } else if (nd->state_ok) {
        latch(nd, SP_CO_F_DEVICE_STATE, 0u, 0u, nd->status, wanted_bits(nc, eff), now);
    }
}

static int emit(sp_co_master_output_t *out)
{
    return out->n_tx < SP_CO_MAX_TX;
}

/* One node's RPDO1 of a SYNC tick under the effective request eff (t: its
 * target states; cw408: CiA 408's control word of eff without a fault or
 * reset, the common case, computed once per step). */
/* RPDO1 by the mapping the plan wrote (sp_co_plan_build): the control word,
 * the position setpoint and, with the force feed-forward, 0x2120 (i16,
 * daN); the bytes of sp_co_rpdo1_frame and sp_co_rpdo1_ff_frame (the tests
 * compare them), written once each without their argument checks (the
 * master's config was checked; a node id out of range leaves the frame as
 * the builders do). */
SPI_INLINE void put_rpdo1(sp_can_frame_t *f, const sp_co_node_cfg_t *nc, uint16_t cw, int32_t setpoint, int ff,
                          int16_t force)
{
    uint32_t v = (uint32_t)setpoint; /* two's complement, modulo 2^32 */
    uint32_t fv = (uint32_t)(uint16_t)force;
    if (nc->node_id < SP_CO_NODE_MIN || nc->node_id > SP_CO_NODE_MAX) {
        return;
    }
    f->id = SP_CO_COB_RPDO1 + nc->node_id;
    f->bus = nc->bus;
    f->len = ff ? 8u : 6u;
    f->flags = 0u;
    f->data[0] = (uint8_t)(cw & 0xFFu);
    f->data[1] = (uint8_t)(cw >> 8);
    f->data[2] = (uint8_t)(v & 0xFFu);
    f->data[3] = (uint8_t)((v >> 8) & 0xFFu);
    f->data[4] = (uint8_t)((v >> 16) & 0xFFu);
    f->data[5] = (uint8_t)(v >> 24);
    f->data[6] = ff ? (uint8_t)(fv & 0xFFu) : 0u;
    f->data[7] = ff ? (uint8_t)(fv >> 8) : 0u;
}

static void node_rpdo(sp_co_node_t *nd, const sp_co_node_cfg_t *nc, sp_co_request_t eff, const targets_t *t,
                      uint16_t cw408, int32_t setpoint, int16_t force, sp_can_frame_t *f)
{
    int faulted = nd->fault.code != (uint8_t)SP_CO_F_NONE;
    if (nc->profile == (uint8_t)SP_CO_PROFILE_402) {
        sp_co402_state_t s = (sp_co402_state_t)nd->seen_state; /* decode_status: this tick's word */
        uint16_t cw = sp_co402_control_word(s, (sp_co402_state_t)t->state[1], nd->reset_edge != 0u, faulted);
        int32_t target;
        int16_t offset = 0; /* the force only with the setpoint it belongs to */
        if (s != SP_CO402_OPERATION_ENABLED) {
            target = nd->actual; /* no jump when operation becomes enabled */
            nd->holding = 0u;
        } else if (eff == SP_CO_REQ_ACTIVE && !faulted) {
            target = setpoint;
            offset = force;
            nd->holding = 0u;
        } else {
            if (!nd->holding) {
                nd->hold_target = nd->last_target; /* the master holds where it last sent the drive */
                nd->holding = 1u;
            }
            target = nd->hold_target;
        }
        nd->last_target = target;
        put_rpdo1(f, nc, cw, target, nc->force_ff != 0u, offset);
    } else {
        uint16_t cw = cw408;
        if (faulted || nd->reset_edge != 0u) {
            sp_co_request_t r = faulted && eff == SP_CO_REQ_ACTIVE ? SP_CO_REQ_HOLD : eff;
            cw = sp_co408_control_word(r, nd->reset_edge != 0u);
        }
        put_rpdo1(f, nc, cw, setpoint, nc->force_ff != 0u, force);
    }
    if (nd->reset_edge > 0u) {
        nd->reset_edge--;
    }
}

/* A node that is not running (or has an NMT command pending): its
 * timeouts, then its NMT command or the next SDO request of its start-up. */
static void node_startup(sp_co_node_t *nd, const sp_co_master_cfg_t *cfg, uint8_t k, uint32_t now,
                         sp_co_master_output_t *out)
{
    const sp_co_node_cfg_t *nc = &cfg->node[k];
    const profile_t *pr = profile_of(nc);
    sp_co_sdo_write_t plan[SP_CO_PLAN_MAX];
    uint8_t n = 0u;
    uint16_t index;
    uint8_t sub;
    int sdo_phase = nd->phase >= SP_CO_PHASE_IDENTITY && nd->phase <= SP_CO_PHASE_READBACK;
    if (sdo_phase) {
        (void)sp_co_plan_build(cfg, k, plan, &n); /* only while starting up */
    }
    timeouts(nd, cfg, pr, plan, now);
    if (nd->nmt_pending != 0u && emit(out)) {
        (void)sp_co_nmt_frame(&out->tx[out->n_tx++], nc->bus, (sp_co_nmt_cmd_t)nd->nmt_pending, nc->node_id);
        nd->phase =
            nd->nmt_pending == (uint8_t)SP_CO_NMT_START ? (uint8_t)SP_CO_PHASE_START : (uint8_t)SP_CO_PHASE_BOOT;
        nd->phase_since = now;
        nd->nmt_pending = 0u;
    } else if (sdo_phase && !nd->sdo_busy && current_object(nd, pr, plan, &index, &sub) && emit(out)) {
        sp_can_frame_t *f = &out->tx[out->n_tx++];
        if (nd->phase == SP_CO_PHASE_WRITE) {
            (void)sp_co_sdo_download_frame(f, nc->bus, nc->node_id, index, sub, plan[nd->step].size,
                                           plan[nd->step].value);
        } else {
            (void)sp_co_sdo_upload_frame(f, nc->bus, nc->node_id, index, sub);
        }
        nd->sdo_busy = 1u;
        nd->sdo_since = now;
    }
}

/* Each node's timeouts and start-up (out->fault_mask: the nodes with a
 * fault latched; *any_fault set when one is). Returns 1 when all run. */
SPI_INLINE uint8_t step_nodes(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint32_t now,
                              sp_co_master_output_t *out, uint8_t *any_fault)
{
    uint8_t k, all_running = 1u;
    sp_co_node_t *nd = m->node;
    uint32_t bit = 1u, mask = 0u;
    for (k = 0u; k < cfg->n_nodes; k++, nd++, bit <<= 1) {
        if (nd->phase == SP_CO_PHASE_RUN && nd->nmt_pending == 0u) {
            run_timeouts(nd, cfg, now); /* running: nothing of the start-up to do */
        } else {
            node_startup(nd, cfg, k, now, out);
        }
        if (nd->phase != SP_CO_PHASE_RUN) {
            all_running = 0u;
        }
        if (nd->fault.code != (uint8_t)SP_CO_F_NONE) {
            *any_fault = 1u;
            mask |= bit;
        }
    }
    out->fault_mask = (uint8_t)mask;
    return all_running;
}

/* The request the drives get: the input's, lowered while drives start up
 * or are faulted. A change restarts every node's state timeout. */
SPI_INLINE sp_co_request_t effective_request(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint8_t request,
                                             uint8_t all_running, uint8_t any_fault, uint32_t now)
{
    uint8_t k;
    sp_co_request_t eff = (sp_co_request_t)request;
    if (eff > SP_CO_REQ_ACTIVE) {
        eff = SP_CO_REQ_DISABLED;
    }
    if (all_running) {
        m->was_running = 1u;
    }
    if (!all_running && !m->was_running) {
        eff = SP_CO_REQ_DISABLED; /* the first start-up: nothing beyond DISABLED */
    } else if ((!all_running || any_fault) && eff == SP_CO_REQ_ACTIVE) {
        eff = SP_CO_REQ_HOLD; /* a drive restarting or faulted: the others hold where they are */
    }
    if ((uint8_t)eff != m->last_req) {
        m->last_req = (uint8_t)eff;
        for (k = 0u; k < cfg->n_nodes; k++) {
            m->node[k].req_since = now;
            m->node[k].state_ok = 0u;
        }
    }
    return eff;
}

/* Each running node's status word against the request, latching the
 * faults (added to out->fault_mask; *any_fault set when one is). Returns 1
 * when every node shows the requested state. */
SPI_INLINE uint8_t check_nodes(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, sp_co_request_t eff,
                               const targets_t *targets, uint32_t now, sp_co_master_output_t *out, uint8_t *any_fault)
{
    uint8_t k, ready = 1u;
    sp_co_node_t *nd = m->node;
    const sp_co_node_cfg_t *nc = cfg->node;
    uint32_t bit = 1u, mask = out->fault_mask;
    for (k = 0u; k < cfg->n_nodes; k++, nd++, nc++, bit <<= 1) {
        if (nd->state_ok && nd->phase == SP_CO_PHASE_RUN && nd->fault.code == (uint8_t)SP_CO_F_NONE && nd->seen_valid &&
            nd->seen_status == nd->status && nd->seen_profile == profile_index(nc)) {
            /* settled: the requested state shown (state_ok; a new request clears it above) by the word
             * decoded and checked already; until the word changes there is nothing to check */
            nd->tpdo1_fresh = 0u;
            nd->tpdo2_fresh = 0u;
            continue;
        }
        decode_status(nd, nc);
        if (nd->phase == SP_CO_PHASE_RUN && nd->fault.code == (uint8_t)SP_CO_F_NONE) {
            sp_co_request_t e = (sp_co_request_t)nd->eff;
            const targets_t *t = targets;
            targets_t own;
            if ((uint8_t)e != (uint8_t)eff) {
                node_targets(e, &own);
                t = &own;
            }
            check_state(nd, nc, e, t, now);
            if (!nd->state_ok && nd->fault.code == (uint8_t)SP_CO_F_NONE &&
                now - nd->req_since > cfg->state_timeout_ms) {
                latch(nd, nd->seen_fault ? SP_CO_F_DEVICE_FAULT : SP_CO_F_DEVICE_STATE, 0u, 0u, nd->status,
                      wanted_bits(nc, e), now);
            }
        }
        if (nd->fault.code != (uint8_t)SP_CO_F_NONE) {
            mask |= bit;
            *any_fault = 1u;
        }
        ready = (uint8_t)(ready && nd->state_ok);
        nd->tpdo1_fresh = 0u;
        nd->tpdo2_fresh = 0u;
    }
    out->fault_mask = (uint8_t)mask;
    return ready;
}

/* The master's heartbeat on each bus with a node, when due. */
SPI_INLINE void send_heartbeats(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, uint32_t now,
                                sp_co_master_output_t *out)
{
    uint8_t k;
    if (cfg->master_heartbeat_ms == 0u || now - m->hb_sent < cfg->master_heartbeat_ms) {
        return;
    }
    uint8_t hb_bus[SP_CAN_BUSES] = {0u};
    m->hb_sent = now;
    for (k = 0u; k < cfg->n_nodes; k++) {
        if (cfg->node[k].bus < SP_CAN_BUSES) {
            hb_bus[cfg->node[k].bus] = 1u;
        }
    }
    for (k = 0u; k < SP_CAN_BUSES; k++) {
        if (hb_bus[k] && emit(out)) {
            (void)sp_co_heartbeat_frame(&out->tx[out->n_tx++], k, cfg->master_node_id,
                                        m->was_running ? SP_CO_NMT_STATE_OPERATIONAL : SP_CO_NMT_STATE_PREOP);
        }
    }
}

/* A SYNC tick: each running node's RPDO1, then SYNC on each bus with a node. */
SPI_INLINE void send_sync(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, const sp_co_master_input_t *in,
                          sp_co_request_t eff, const targets_t *targets, sp_co_master_output_t *out)
{
    uint8_t k;
    uint8_t bus_used[SP_CAN_BUSES] = {0u};
    uint16_t cw408 = sp_co408_control_word(eff, 0);
    sp_co_node_t *nd = m->node;
    const sp_co_node_cfg_t *nc = cfg->node;
    for (k = 0u; k < cfg->n_nodes; k++, nd++, nc++) {
        if (nc->bus >= SP_CAN_BUSES) {
            continue; /* the config changed after the check: never index past the array */
        }
        bus_used[nc->bus] = 1u;
        if (nd->phase == SP_CO_PHASE_RUN && emit(out)) {
            sp_co_request_t e = (sp_co_request_t)nd->eff;
            targets_t own;
            const targets_t *t = targets;
            uint16_t cw = cw408;
            if ((uint8_t)e != (uint8_t)eff) {
                node_targets(e, &own);
                t = &own;
                cw = sp_co408_control_word(e, 0);
            }
            node_rpdo(nd, nc, e, t, cw, in->setpoint[k], in->force_ff[k], &out->tx[out->n_tx++]);
        }
    }
    for (k = 0u; k < SP_CAN_BUSES; k++) {
        if (bus_used[k] && emit(out)) {
            (void)sp_co_sync_frame(&out->tx[out->n_tx++], k);
        }
    }
    out->sync = 1u;
}

sp_status_t sp_co_master_step(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, const sp_co_master_input_t *in,
                              sp_co_master_output_t *out)
{
    uint8_t all_running, any_fault = 0u, ready, sync_tick;
    uint32_t now;
    sp_co_request_t eff;
    targets_t targets;
    if (m == NULL || cfg == NULL || in == NULL || out == NULL || cfg->n_nodes > SP_CO_MAX_NODES ||
        cfg->sync_divider == 0u) {
        return SP_E_ARG;
    }
    /* the frames are written as they are emitted: no need to clear 1.7 KB */
    out->n_tx = 0u;
    out->sync = 0u;
    out->ready = 0u;
    out->all_running = 0u;
    out->fault_mask = 0u;
    if (!m->started) {
        return SP_OK;
    }
    now = in->now_ms;
    sync_tick = (uint8_t)(m->ticks % cfg->sync_divider == 0u);
    if (m->ticks < UINT32_MAX) {
        m->ticks++;
    }
    all_running = step_nodes(m, cfg, now, out, &any_fault);
    eff = effective_request(m, cfg, in->request, all_running, any_fault, now);
    node_requests(m, cfg, eff, in->block, now);
    node_targets(eff, &targets);
    ready = check_nodes(m, cfg, eff, &targets, now, out, &any_fault);
    send_heartbeats(m, cfg, now, out);
    if (sync_tick) {
        send_sync(m, cfg, in, eff, &targets, out);
    }
    out->all_running = all_running;
    out->ready = (uint8_t)(all_running && ready && !any_fault);
    return SP_OK;
}

int sp_co_master_sync_due(const sp_co_master_t *m, const sp_co_master_cfg_t *cfg)
{
    if (m == NULL || cfg == NULL || !m->started || cfg->sync_divider == 0u) {
        return 0;
    }
    return m->ticks % cfg->sync_divider == 0u; /* sp_co_master_step's test, before it counts the tick */
}

sp_status_t sp_co_master_node_state(const sp_co_master_t *m, uint8_t k, uint8_t *phase, sp_co_fault_t *fault)
{
    if (m == NULL || phase == NULL || fault == NULL || k >= SP_CO_MAX_NODES) {
        return SP_E_ARG;
    }
    *phase = m->node[k].phase;
    *fault = m->node[k].fault;
    return SP_OK;
}

/* ---- scaling ---- */

#define NM_PER_M 1000000000LL
#define Q24_RANGE_NM (((int64_t)1 << 31) * NM_PER_M >> 24) /* 128 m in nm */

static int scaling_fields_ok(const sp_co_scaling_t *s)
{
    return s != NULL && s->nm_per_count >= 1u && s->nm_per_count <= 1000000u &&
           (s->direction == 1 || s->direction == -1) &&
           (s->rated_force_n == 0u ||
            (s->rated_force_n >= SP_CO_RATED_FORCE_MIN_N && s->rated_force_n <= SP_CO_RATED_FORCE_MAX_N));
}

sp_status_t sp_co_scaling_prepare(sp_co_scaling_t *s)
{
    if (!scaling_fields_ok(s)) {
        return SP_E_ARG;
    }
    s->count_per_q24 = (uint32_t)((NM_PER_M + s->nm_per_count / 2u) / s->nm_per_count);
    {
        /* nm x 2^52 / 1e9 without overflow: (nm x 2^28) / 1e9 in whole and remainder, each times 2^24 */
        uint64_t a = (uint64_t)s->nm_per_count << 28; /* < 2^48 */
        uint64_t whole = a / (uint64_t)NM_PER_M, rest = a % (uint64_t)NM_PER_M;
        s->q24_per_count_q28 = (whole << 24) + ((rest << 24) + (uint64_t)NM_PER_M / 2u) / (uint64_t)NM_PER_M;
    }
    s->count_limit = Q24_RANGE_NM / (int64_t)s->nm_per_count + 1;
    /* 1000 x 2^24 / rated: below 2^28 for rated >= 100 N */
    s->permille_per_n_q24 =
        s->rated_force_n != 0u ? (uint32_t)((((uint64_t)1000u << 24) + s->rated_force_n / 2u) / s->rated_force_n) : 0u;
    return SP_OK;
}

sp_status_t sp_co_length_to_count(const sp_co_scaling_t *s, int32_t length_q24, int32_t *count)
{
    if (!spi_co_scaling_ok(s) || count == NULL) {
        return SP_E_ARG;
    }
    return spi_co_length_to_count(s, length_q24, count);
}

sp_status_t sp_co_count_to_length(const sp_co_scaling_t *s, int32_t count, int32_t *length_q24)
{
    if (!spi_co_scaling_ok(s) || length_q24 == NULL) {
        return SP_E_ARG;
    }
    return spi_co_count_to_length(s, count, length_q24);
}

sp_status_t sp_co_force_to_permille(const sp_co_scaling_t *s, sp_q8_t force_q8, int16_t *permille)
{
    if (!spi_co_scaling_ok(s) || s->permille_per_n_q24 == 0u || permille == NULL) {
        if (permille != NULL) {
            *permille = 0;
        }
        return SP_E_ARG;
    }
    return spi_co_force_to_permille(s, force_q8, permille);
}

/* ---- the request per node ---- */

/* The states request eff leads to, per profile. */
static void node_targets(sp_co_request_t eff, targets_t *t)
{
    t->state[0] = (uint8_t)sp_co408_target(eff);
    t->state[1] = (uint8_t)sp_co402_target(eff);
}

/* Each node's request of this step: the master's eff, or DISABLED instead
 * of HOLD while the controller blocks its drives (block) for a node whose
 * config says so (its valve's spool then takes its fail-safe position). A
 * node whose request changes starts its state timeout again. Nothing to do
 * (a test) while eff and block are the last step's. */
static void node_requests(sp_co_master_t *m, const sp_co_master_cfg_t *cfg, sp_co_request_t eff, uint8_t block,
                          uint32_t now)
{
    uint8_t k;
    if ((m->nodes_req != (uint8_t)eff) || (m->nodes_block != block)) { /* else every node's request stands */
        m->nodes_req = (uint8_t)eff;
        m->nodes_block = block;
        for (k = 0u; k < cfg->n_nodes; k++) {
            sp_co_request_t e = eff;
            if ((block != 0u) && (cfg->node[k].disable_on_block != 0u) && (eff == SP_CO_REQ_HOLD)) {
                e = SP_CO_REQ_DISABLED;
            }
            if (m->node[k].eff != (uint8_t)e) {
                m->node[k].eff = (uint8_t)e;
                m->node[k].req_since = now;
                m->node[k].state_ok = 0u;
            }
        }
    }
}
