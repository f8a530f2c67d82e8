/* SPDX-License-Identifier: Apache-2.0 */
/*
 * CANopen frames, the CiA 408 state machine, the start-up plan and the
 * master's configuration and scaling (sp/canopen/canopen.h, sp/canopen/canopen_master.h;
 * issue 18). The master against simulated drives is tests/plant/
 * test_plant_canopen.c.
 *
 * - SDO frames byte for byte as CiA 301 lays them out (expedited download of
 *   1, 2 and 4 bytes, upload), answers parsed (ack, read of each size, abort,
 *   an answer to another object or a segmented one), abort codes by name.
 * - NMT, SYNC, heartbeat, PDO and EMCY frames round trip; wrong length or
 *   identifier is SP_E_FRAME; EMCY classes by name.
 * - CiA 408 status words decode to every state; the drive's state machine
 *   walks INIT -> ACTIVE one step per call, faults, and resets on R's edge.
 * - The plan: 29 writes of which 23 final with pressure feedback, 22/18
 *   without (docs/reference/canopen.md), 28/22 without the master's heartbeat (no
 *   0x1016.1), the RPDO event timer, the prefix's byte; CiA 402: 21/17
 *   (0x6060 = 8, 0x60C2, RPDO1 with 0x607A, TPDO1 with 0x6064, no TPDO2).
 * - CiA 402: the statusword table, the controlword towards each target,
 *   the drive's transitions, quick stop and fault reset.
 * - Config check names a bad node id, a duplicate, a zero divider.
 * - Scaling: the prepared factors against the exact quotients (a plain
 *   reference in long double) within 1 count and 1 Q24 step, for six
 *   resolutions from 1 nm to 1 mm; round trip; saturation.
 * - The master ignores frames of other nodes, rejects malformed ones.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "sp/canopen/canopen_link.h"
#include "sp/control/controller.h"
#include "sp/model/kinematics.h"
#include "sp/model/platform.h"

static void assert_bytes(const sp_can_frame_t *f, uint32_t id, const uint8_t *want, uint8_t len)
{
    assert_int_equal(f->id, id);
    assert_int_equal(f->len, len);
    assert_memory_equal(f->data, want, len);
}

static void test_sdo_frames(void **state)
{
    sp_can_frame_t f;
    static const uint8_t dl4[8] = {0x23, 0x00, 0x14, 0x01, 0x05, 0x02, 0x00, 0x80};
    static const uint8_t dl2[8] = {0x2B, 0x17, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00};
    static const uint8_t dl1[8] = {0x2F, 0x43, 0x60, 0x00, 0xFA, 0x00, 0x00, 0x00};
    static const uint8_t ul[8] = {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0};
    (void)state;
    assert_int_equal(sp_co_sdo_download_frame(&f, 1u, 5u, 0x1400u, 1u, 4u, 0x80000205u), SP_OK);
    assert_bytes(&f, 0x605u, dl4, 8u);
    assert_int_equal(sp_co_sdo_download_frame(&f, 1u, 5u, 0x1017u, 0u, 2u, 20u), SP_OK);
    assert_bytes(&f, 0x605u, dl2, 8u);
    assert_int_equal(sp_co_sdo_download_frame(&f, 1u, 5u, 0x6043u, 0u, 1u, 0xFFFFFFFAu), SP_OK);
    assert_bytes(&f, 0x605u, dl1, 8u); /* the value cut to its size */
    assert_int_equal(sp_co_sdo_upload_frame(&f, 2u, 5u, 0x1000u, 0u), SP_OK);
    assert_bytes(&f, 0x605u, ul, 8u);
    assert_int_equal(f.bus, 2u);
    assert_int_equal(sp_co_sdo_download_frame(&f, 1u, 5u, 0x1017u, 0u, 3u, 0u), SP_E_ARG);
    assert_int_equal(sp_co_sdo_download_frame(&f, 1u, 0u, 0x1017u, 0u, 2u, 0u), SP_E_ARG);
    assert_int_equal(sp_co_sdo_download_frame(&f, 1u, 128u, 0x1017u, 0u, 2u, 0u), SP_E_ARG);
    assert_int_equal(sp_co_sdo_download_frame(&f, 3u, 5u, 0x1017u, 0u, 2u, 0u), SP_E_ARG);
    assert_int_equal(sp_co_sdo_download_frame(NULL, 1u, 5u, 0x1017u, 0u, 2u, 0u), SP_E_ARG);
}

static sp_can_frame_t answer(uint8_t node, const uint8_t d[8])
{
    sp_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = 0x580u + node;
    f.len = 8u;
    memcpy(f.data, d, 8u);
    return f;
}

static void test_sdo_answers(void **state)
{
    sp_co_sdo_answer_t a;
    uint32_t v = 0xDEADu;
    uint8_t size = 9u;
    static const uint8_t ack[8] = {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0};
    static const uint8_t up4[8] = {0x43, 0x00, 0x10, 0x00, 0x98, 0x01, 0x00, 0x00};
    static const uint8_t up1[8] = {0x4F, 0x43, 0x60, 0x00, 0xFA, 0xEE, 0xEE, 0xEE};
    static const uint8_t up2[8] = {0x4B, 0x17, 0x10, 0x00, 0x14, 0x00, 0xEE, 0xEE};
    static const uint8_t abort[8] = {0x80, 0x43, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06};
    static const uint8_t seg[8] = {0x41, 0x08, 0x10, 0x00, 0x16, 0, 0, 0};
    static const uint8_t bad_cs[8] = {0xE0, 0x17, 0x10, 0x00, 0, 0, 0, 0};
    sp_can_frame_t f = answer(5u, ack);
    (void)state;
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1017u, 0u, &a, &v, &size), SP_OK);
    assert_int_equal(a, SP_CO_SDO_DOWNLOAD_OK);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1018u, 0u, &a, &v, &size), SP_E_FRAME); /* another object */
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1017u, 1u, &a, &v, &size), SP_E_FRAME);
    assert_int_equal(sp_co_sdo_parse(&f, 6u, 0x1017u, 0u, &a, &v, &size), SP_E_FRAME); /* another node */
    f = answer(5u, up4);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1000u, 0u, &a, &v, &size), SP_OK);
    assert_int_equal(a, SP_CO_SDO_UPLOAD_OK);
    assert_int_equal(v, 0x198u);
    assert_int_equal(size, 4u);
    f = answer(5u, up1);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x6043u, 0u, &a, &v, &size), SP_OK);
    assert_int_equal(v, 0xFAu);
    assert_int_equal(size, 1u);
    f = answer(5u, up2);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1017u, 0u, &a, &v, &size), SP_OK);
    assert_int_equal(v, 20u);
    assert_int_equal(size, 2u);
    f = answer(5u, abort);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x6043u, 0u, &a, &v, &size), SP_OK);
    assert_int_equal(a, SP_CO_SDO_ABORTED);
    assert_int_equal(v, 0x06090030u);
    assert_string_equal(sp_co_sdo_abort_name(v), "value range of parameter exceeded");
    assert_string_equal(sp_co_sdo_abort_name(0x06020000u), "object does not exist in the object dictionary");
    assert_string_equal(sp_co_sdo_abort_name(0x12345678u), "unknown abort code");
    f = answer(5u, seg);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1008u, 0u, &a, &v, &size), SP_OK);
    assert_int_equal(a, SP_CO_SDO_UNSUPPORTED);
    f = answer(5u, bad_cs);
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1017u, 0u, &a, &v, &size), SP_E_FRAME);
    f.len = 7u;
    assert_int_equal(sp_co_sdo_parse(&f, 5u, 0x1017u, 0u, &a, &v, &size), SP_E_FRAME);
}

static void test_nmt_sync_heartbeat(void **state)
{
    sp_can_frame_t f;
    uint8_t node, st;
    static const uint8_t start[2] = {0x01, 0x0C};
    static const uint8_t rc[2] = {0x82, 0x0C};
    (void)state;
    assert_int_equal(sp_co_nmt_frame(&f, 1u, SP_CO_NMT_START, 12u), SP_OK);
    assert_bytes(&f, 0x000u, start, 2u);
    assert_int_equal(sp_co_nmt_frame(&f, 1u, SP_CO_NMT_RESET_COMM, 12u), SP_OK);
    assert_bytes(&f, 0x000u, rc, 2u);
    assert_int_equal(sp_co_sync_frame(&f, 2u), SP_OK);
    assert_int_equal(f.id, 0x080u);
    assert_int_equal(f.len, 0u);
    assert_int_equal(sp_co_heartbeat_frame(&f, 1u, 12u, SP_CO_NMT_STATE_OPERATIONAL), SP_OK);
    assert_int_equal(f.id, 0x70Cu);
    f.data[0] = 0x85u; /* toggle bit set */
    assert_int_equal(sp_co_heartbeat_parse(&f, &node, &st), SP_OK);
    assert_int_equal(node, 12u);
    assert_int_equal(st, 0x05u);
    f.len = 2u;
    assert_int_equal(sp_co_heartbeat_parse(&f, &node, &st), SP_E_FRAME);
    f.len = 1u;
    f.id = 0x700u;
    assert_int_equal(sp_co_heartbeat_parse(&f, &node, &st), SP_E_FRAME);
}

static void test_pdo_emcy(void **state)
{
    sp_can_frame_t f;
    uint16_t w, a, b, code;
    int32_t v;
    uint8_t node, reg;
    static const uint8_t rpdo[6] = {0x07, 0x00, 0xFE, 0xFF, 0xFF, 0xFF};
    (void)state;
    assert_int_equal(sp_co_rpdo1_frame(&f, 1u, 3u, 0x0007u, -2), SP_OK);
    assert_bytes(&f, 0x203u, rpdo, 6u);
    assert_int_equal(sp_co_rpdo1_parse(&f, 3u, &w, &v), SP_OK);
    assert_int_equal(w, 7u);
    assert_int_equal(v, -2);
    {
        /* RPDO1 with the vendor force feed-forward 0x2120 (i16 daN) as its third entry */
        static const uint8_t rpdo_ff[8] = {0x07, 0x00, 0xFE, 0xFF, 0xFF, 0xFF, 0xCF, 0xFB};
        int16_t force = 0;
        assert_int_equal(sp_co_rpdo1_ff_frame(&f, 1u, 3u, 0x0007u, -2, -1073), SP_OK);
        assert_bytes(&f, 0x203u, rpdo_ff, 8u);
        assert_int_equal(sp_co_rpdo1_ff_parse(&f, 3u, &w, &v, &force), SP_OK);
        assert_int_equal(w, 7u);
        assert_int_equal(v, -2);
        assert_int_equal(force, -1073);
        assert_int_equal(sp_co_rpdo1_parse(&f, 3u, &w, &v), SP_E_FRAME); /* 8 bytes: not the 6-byte layout */
        assert_int_equal(sp_co_rpdo1_ff_frame(&f, 1u, 3u, 0u, 0, INT16_MIN), SP_OK);
        assert_int_equal(sp_co_rpdo1_ff_parse(&f, 3u, &w, &v, &force), SP_OK);
        assert_int_equal(force, INT16_MIN);
        assert_int_equal(sp_co_rpdo1_ff_parse(&f, 4u, &w, &v, &force), SP_E_FRAME);
        assert_int_equal(sp_co_rpdo1_ff_frame(&f, 1u, 0u, 0u, 0, 0), SP_E_ARG);
    }
    assert_int_equal(sp_co_tpdo1_frame(&f, 1u, 3u, 0x000Fu, INT32_MIN), SP_OK);
    assert_int_equal(f.id, 0x183u);
    assert_int_equal(sp_co_tpdo1_parse(&f, 3u, &w, &v), SP_OK);
    assert_int_equal(v, INT32_MIN);
    assert_int_equal(sp_co_tpdo1_parse(&f, 4u, &w, &v), SP_E_FRAME);
    f.len = 8u;
    assert_int_equal(sp_co_tpdo1_parse(&f, 3u, &w, &v), SP_E_FRAME);
    assert_int_equal(sp_co_tpdo2_frame(&f, 1u, 3u, 21000u, 65535u), SP_OK);
    assert_int_equal(f.id, 0x283u);
    assert_int_equal(sp_co_tpdo2_parse(&f, 3u, &a, &b), SP_OK);
    assert_int_equal(a, 21000u);
    assert_int_equal(b, 65535u);
    assert_int_equal(sp_co_emcy_frame(&f, 1u, 3u, 0x8250u, 0x11u), SP_OK);
    assert_int_equal(f.id, 0x083u);
    assert_int_equal(sp_co_emcy_parse(&f, &node, &code, &reg), SP_OK);
    assert_int_equal(node, 3u);
    assert_int_equal(code, 0x8250u);
    assert_int_equal(reg, 0x11u);
    f.len = 2u;
    assert_int_equal(sp_co_emcy_parse(&f, &node, &code, &reg), SP_E_FRAME);
    assert_string_equal(sp_co_emcy_class_name(0x0000u), "error reset");
    assert_string_equal(sp_co_emcy_class_name(0x2310u), "current");
    assert_string_equal(sp_co_emcy_class_name(0x3210u), "voltage");
    assert_string_equal(sp_co_emcy_class_name(0x4210u), "temperature");
    assert_string_equal(sp_co_emcy_class_name(0x5000u), "device hardware");
    assert_string_equal(sp_co_emcy_class_name(0x6100u), "device software");
    assert_string_equal(sp_co_emcy_class_name(0x8130u), "communication");
    assert_string_equal(sp_co_emcy_class_name(0x8250u), "protocol");
    assert_string_equal(sp_co_emcy_class_name(0x8611u), "monitoring");
    assert_string_equal(sp_co_emcy_class_name(0x9000u), "external");
    assert_string_equal(sp_co_emcy_class_name(0xF000u), "additional functions");
    assert_string_equal(sp_co_emcy_class_name(0xFF01u), "device specific");
}

static void test_cia408_states(void **state)
{
    sp_co408_state_t s = SP_CO408_NOT_READY;
    uint16_t cw = sp_co408_control_word(SP_CO_REQ_ACTIVE, 0);
    int i;
    (void)state;
    assert_int_equal(sp_co408_state(0x0008u), SP_CO408_INIT);
    assert_int_equal(sp_co408_state(0xFF09u), SP_CO408_DISABLED); /* high bits ignored */
    assert_int_equal(sp_co408_state(0x000Bu), SP_CO408_HOLD);
    assert_int_equal(sp_co408_state(0x000Fu), SP_CO408_ACTIVE);
    assert_int_equal(sp_co408_state(0x0007u), SP_CO408_FAULT_REACTION);
    assert_int_equal(sp_co408_state(0x0003u), SP_CO408_FAULT_HOLD);
    assert_int_equal(sp_co408_state(0x0001u), SP_CO408_FAULT_DISABLED);
    assert_int_equal(sp_co408_state(0x0005u), SP_CO408_UNKNOWN);
    for (i = 0; i <= (int)SP_CO408_FAULT_DISABLED; i++) {
        assert_int_equal(sp_co408_state(sp_co408_status_bits((sp_co408_state_t)i)), i);
    }
    assert_int_equal(sp_co408_control_word(SP_CO_REQ_DISABLED, 0), 0x0001u);
    assert_int_equal(sp_co408_control_word(SP_CO_REQ_HOLD, 0), 0x0003u);
    assert_int_equal(cw, 0x0007u);
    assert_int_equal(sp_co408_control_word(SP_CO_REQ_HOLD, 1), 0x000Bu);
    /* power-up -> INIT -> DISABLED -> HOLD -> ACTIVE, one step per call */
    for (i = 0; i < 4; i++) {
        s = sp_co408_next(s, cw, cw, 0);
        assert_int_equal(s, (sp_co408_state_t)(i + 1));
    }
    assert_int_equal(sp_co408_next(s, cw, cw, 0), SP_CO408_ACTIVE);
    s = sp_co408_next(s, cw, cw, 1);
    assert_int_equal(s, SP_CO408_FAULT_REACTION);
    s = sp_co408_next(s, cw, cw, 1);
    assert_int_equal(s, SP_CO408_FAULT_HOLD);
    /* no reset while the fault persists, nor without the edge */
    assert_int_equal(sp_co408_next(s, 0x000Bu, 0x0003u, 1), SP_CO408_FAULT_HOLD);
    assert_int_equal(sp_co408_next(s, 0x000Bu, 0x000Bu, 0), SP_CO408_FAULT_HOLD);
    assert_int_equal(sp_co408_next(s, 0x000Bu, 0x0003u, 0), SP_CO408_HOLD);
    assert_int_equal(sp_co408_next(s, 0x000Fu, 0x0007u, 0), SP_CO408_HOLD); /* never straight to ACTIVE */
    assert_true(sp_co408_is_fault(SP_CO408_FAULT_DISABLED));
    assert_false(sp_co408_is_fault(SP_CO408_NOT_READY));
    assert_string_equal(sp_co408_state_name(SP_CO408_FAULT_HOLD), "FAULT_HOLD");
}

static int finals(const sp_co_sdo_write_t *p, uint8_t n)
{
    int c = 0;
    uint8_t i;
    for (i = 0u; i < n; i++) {
        c += p[i].final;
    }
    return c;
}

static void test_plan(void **state)
{
    sp_co_master_cfg_t cfg;
    sp_co_sdo_write_t p[SP_CO_PLAN_MAX];
    uint8_t n, i, timer = 0u;
    (void)state;
    assert_int_equal(sp_co_master_cfg_default(&cfg, 6u), SP_OK);
    cfg.node[4].node_id = 21u;
    assert_int_equal(sp_co_plan_build(&cfg, 4u, p, &n), SP_OK);
    assert_int_equal(n, 29u);
    assert_int_equal(finals(p, n), 23);
    assert_int_equal(p[0].index, 0x1017u);
    assert_int_equal(p[0].value, 20u);
    assert_int_equal(p[1].index, 0x1016u); /* the master's heartbeat watched: node 127, 300 ms */
    assert_int_equal(p[1].value, (127u << 16) | 300u);
    assert_true(p[1].optional);
    assert_int_equal(p[3].index, 0x6043u);
    assert_int_equal(p[3].value, 8u);
    assert_int_equal(p[5].index, 0x6600u);
    assert_int_equal(p[5].sub, 3u);
    assert_int_equal(p[5].value, 0xFAu); /* -6 as its byte */
    assert_true(p[5].optional);
    for (i = 0u; i < n; i++) {
        if (p[i].index == 0x1400u && p[i].sub == 5u) {
            timer = 1u;
            assert_int_equal(p[i].value, cfg.setpoint_timeout_ms);
        }
    }
    assert_true(timer);
    assert_int_equal(p[7].value, 0x80000000u | (0x200u + 21u)); /* RPDO1 disabled while re-mapped */
    assert_int_equal(p[n - 1u].value, 0x280u + 21u);            /* TPDO2 enabled last */
    cfg.pressure_feedback = 0u;
    assert_int_equal(sp_co_plan_build(&cfg, 4u, p, &n), SP_OK);
    assert_int_equal(n, 22u);
    assert_int_equal(finals(p, n), 18);
    cfg.master_heartbeat_ms = 0u;
    assert_int_equal(sp_co_plan_build(&cfg, 4u, p, &n), SP_OK);
    assert_int_equal(n, 21u);
    assert_int_equal(finals(p, n), 17);
    cfg.master_heartbeat_ms = 100u;
    cfg.node[4].profile = SP_CO_PROFILE_402;
    cfg.pressure_feedback = 1u; /* CiA 408's pressures: not on a 402 drive */
    assert_int_equal(sp_co_plan_build(&cfg, 4u, p, &n), SP_OK);
    assert_int_equal(n, 21u);
    assert_int_equal(finals(p, n), 17);
    assert_int_equal(p[2].index, 0x6060u);
    assert_int_equal(p[2].value, 8u);
    assert_int_equal(p[3].index, 0x60C2u);
    assert_int_equal(p[4].value, 0xFDu); /* -3: ms */
    for (i = 0u; i < n; i++) {
        assert_true(p[i].index != 0x6042u && p[i].index != 0x6043u && p[i].index != 0x1801u);
        if (p[i].index == 0x1600u && p[i].sub == 2u) {
            assert_int_equal(p[i].value, 0x607A0020u);
        }
        if (p[i].index == 0x1A00u && p[i].sub == 2u) {
            assert_int_equal(p[i].value, 0x60640020u);
        }
    }
    cfg.node[4].force_ff = 1u; /* CiA 402's torque/force offset 0x60B2 as RPDO1's third entry */
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_OK);
    assert_int_equal(sp_co_plan_build(&cfg, 4u, p, &n), SP_OK);
    {
        int count = -1, third = -1;
        for (i = 0u; i < n; i++) {
            if (p[i].index == 0x1600u && p[i].sub == 0u && p[i].value != 0u) {
                count = (int)p[i].value;
            }
            if (p[i].index == 0x1600u && p[i].sub == 3u) {
                third = (int)(p[i].value == 0x60B20010u);
            }
        }
        assert_int_equal(count, 3);
        assert_int_equal(third, 1);
    }
    cfg.node[4].force_ff = 2u; /* a flag: 0 or 1 */
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_E_ARG);
    assert_int_equal(sp_co_plan_build(&cfg, 6u, p, &n), SP_E_ARG);
    assert_int_equal(sp_co_plan_build(NULL, 0u, p, &n), SP_E_ARG);
}

static void test_cfg_check(void **state)
{
    sp_co_master_cfg_t cfg;
    (void)state;
    assert_int_equal(sp_co_master_cfg_default(&cfg, 7u), SP_E_ARG);
    assert_int_equal(sp_co_master_cfg_default(&cfg, 6u), SP_OK);
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_OK);
    cfg.node[3].node_id = 1u; /* same id as leg 1 but on the other bus: fine */
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_OK);
    cfg.node[3].bus = cfg.node[0].bus; /* now a duplicate */
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_E_ARG);
    assert_int_equal(sp_co_master_cfg_default(&cfg, 6u), SP_OK);
    cfg.node[2].node_id = 128u;
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_E_ARG);
    assert_int_equal(sp_co_master_cfg_default(&cfg, 6u), SP_OK);
    cfg.sync_divider = 0u;
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_E_ARG);
    assert_int_equal(sp_co_master_cfg_default(&cfg, 6u), SP_OK);
    cfg.heartbeat_timeout_ms = cfg.heartbeat_ms;
    assert_int_equal(sp_co_master_cfg_check(&cfg), SP_E_ARG);
}

/* The plain references: the exact quotients in long double (tests may use
 * floating point), rounded half away from zero. */
static long double ref_count(const sp_co_scaling_t *s, int32_t length_q24)
{
    return (long double)s->direction * ((long double)length_q24 - (long double)s->zero_q24) / 16777216.0L * 1e9L /
           (long double)s->nm_per_count;
}

static long double ref_length(const sp_co_scaling_t *s, int32_t count)
{
    return (long double)s->zero_q24 +
           (long double)s->direction * (long double)count * (long double)s->nm_per_count * 16777216.0L / 1e9L;
}

static void test_scaling(void **state)
{
    static const uint32_t nms[] = {1u, 3u, 100u, 1000u, 7919u, 1000000u};
    sp_co_scaling_t s;
    int32_t c, len, i;
    uint32_t k, seed = 12345u;
    (void)state;
    memset(&s, 0, sizeof s);
    s.nm_per_count = 1000u;
    s.zero_q24 = 0x01000000; /* 1 m */
    s.direction = 1;
    assert_int_equal(sp_co_length_to_count(&s, 0, &c), SP_E_ARG); /* not prepared */
    assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
    assert_int_equal(sp_co_length_to_count(&s, 0x01000000 + 0x00100000 /* 1.0625 m */, &c), SP_OK);
    assert_int_equal(c, 62500); /* um */
    s.direction = -1;
    assert_int_equal(sp_co_length_to_count(&s, 0x01000000 + 0x00100000, &c), SP_OK);
    assert_int_equal(c, -62500);
    assert_int_equal(sp_co_count_to_length(&s, -62500, &len), SP_OK);
    assert_int_equal(len, 0x01100000);
    /* round trip over the stroke: 1 um = 16.8 Q24 steps, so exact */
    s.direction = 1;
    for (i = -400000; i <= 400000; i += 3331) {
        int32_t back;
        assert_int_equal(sp_co_count_to_length(&s, i, &len), SP_OK);
        assert_int_equal(sp_co_length_to_count(&s, len, &back), SP_OK);
        assert_int_equal(back, i);
    }
    /* the prepared factors against the exact quotients: within 1 count and 1 Q24 step (the
     * reference's own rounding included), for every resolution, both directions */
    for (k = 0u; k < sizeof nms / sizeof nms[0]; k++) {
        s.nm_per_count = nms[k];
        s.zero_q24 = 0x01D99999; /* 1.85 m */
        for (i = 0; i < 2000; i++) {
            long double r;
            int32_t count, length;
            seed = seed * 1664525u + 1013904223u;
            s.direction = (seed & 1u) ? 1 : -1;
            assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
            length = s.zero_q24 + (int32_t)(seed >> 8) - 0x00800000; /* +-0.5 m */
            assert_int_equal(sp_co_length_to_count(&s, length, &count), SP_OK);
            r = ref_count(&s, length);
            assert_true(fabsl((long double)count - r) <= 1.0L);
            count = (int32_t)(seed >> 12) - 0x00080000;
            if (sp_co_count_to_length(&s, count, &length) == SP_OK) {
                r = ref_length(&s, count);
                assert_true(fabsl((long double)length - r) <= 1.0L);
            }
        }
    }
    s.direction = 1;
    s.nm_per_count = 1u;
    assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
    assert_int_equal(sp_co_length_to_count(&s, INT32_MAX, &c), SP_E_OVERFLOW);
    assert_int_equal(c, INT32_MAX);
    s.nm_per_count = 1000000u;
    assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
    assert_int_equal(sp_co_count_to_length(&s, INT32_MIN, &len), SP_E_OVERFLOW);
    assert_int_equal(len, INT32_MIN);
    assert_int_equal(sp_co_count_to_length(&s, 130000, &len), SP_E_OVERFLOW); /* 130 m */
    assert_int_equal(len, INT32_MAX);
    s.nm_per_count = 0u;
    assert_int_equal(sp_co_scaling_prepare(&s), SP_E_ARG);
    s.nm_per_count = 1000u;
    s.direction = 0;
    assert_int_equal(sp_co_scaling_prepare(&s), SP_E_ARG);
}

/* CiA 402's torque/force offset (sp_co_force_to_permille, the link's
 * per-tick conversion) against the exact quotient in long double: within
 * 1 per mille over random forces of the whole Q8 range and rated forces
 * of the whole allowed range, both directions, saturated at INT16; the
 * bounds of rated_force_n in sp_co_scaling_prepare; a link config whose
 * CiA 402 drive has the feed-forward but no rated force is refused, and
 * sp_co_link_input sends each 402 node its per mille. */
static void test_force_permille(void **state)
{
    sp_co_scaling_t s;
    uint32_t seed = 9001u, t, exact_hits = 0u;
    int16_t pm;
    (void)state;
    memset(&s, 0, sizeof s);
    s.nm_per_count = 1000u;
    s.direction = 1;
    s.rated_force_n = 99u;
    assert_int_equal(sp_co_scaling_prepare(&s), SP_E_ARG);
    s.rated_force_n = 10000001u;
    assert_int_equal(sp_co_scaling_prepare(&s), SP_E_ARG);
    s.rated_force_n = 0u; /* none: the length scaling alone */
    assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
    assert_int_equal(sp_co_force_to_permille(&s, 256, &pm), SP_E_ARG);
    assert_int_equal(pm, 0);
    assert_int_equal(sp_co_force_to_permille(NULL, 256, &pm), SP_E_ARG);
    s.rated_force_n = 10000u; /* 10 N per mille */
    assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
    assert_int_equal(sp_co_force_to_permille(&s, 12345 * 256, &pm), SP_OK);
    assert_int_equal(pm, 1235); /* 1234.5 rounds away from zero */
    assert_int_equal(sp_co_force_to_permille(&s, -12345 * 256, &pm), SP_OK);
    assert_int_equal(pm, -1235);
    assert_int_equal(sp_co_force_to_permille(&s, 400000 * 256, &pm), SP_E_OVERFLOW);
    assert_int_equal(pm, INT16_MAX);
    s.direction = -1;
    assert_int_equal(sp_co_force_to_permille(&s, 400000 * 256, &pm), SP_E_OVERFLOW);
    assert_int_equal(pm, INT16_MIN);
    assert_int_equal(sp_co_force_to_permille(&s, 12345 * 256, &pm), SP_OK);
    assert_int_equal(pm, -1235); /* the count falls as the leg extends: the force too */
    for (t = 0u; t < 20000u; t++) {
        long double q, want;
        int32_t force;
        sp_status_t st;
        seed = seed * 1664525u + 1013904223u;
        s.rated_force_n = 100u + seed % 9999901u;
        s.direction = (seed & 0x80000000u) != 0u ? -1 : 1;
        assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
        seed = seed * 1664525u + 1013904223u;
        force = (int32_t)seed >> (seed % 24u); /* every magnitude, both signs */
        q = (long double)force / 256.0L * 1000.0L / (long double)s.rated_force_n * s.direction;
        want = q < 0 ? -floorl(-q + 0.5L) : floorl(q + 0.5L);
        st = sp_co_force_to_permille(&s, force, &pm);
        if (want > 32767.0L || want < -32768.0L) {
            assert_true(st == SP_E_OVERFLOW || fabsl(q) < 32768.5L);
            assert_true(pm == INT16_MAX || pm == INT16_MIN || fabsl((long double)pm - q) <= 1.0L);
            continue;
        }
        assert_true(fabsl((long double)pm - q) <= 1.0L);
        exact_hits += ((long double)pm == want) ? 1u : 0u;
    }
    assert_true(exact_hits > 19000u); /* off by one only next to a half */

    /* the link: a CiA 402 node with the feed-forward needs its leg's rated force */
    {
        sp_co_link_cfg_t cfg;
        sp_ctrl_output_t out;
        sp_co_master_input_t in;
        sp_q24_t zero[SP_LEGS] = {0, 0, 0, 0, 0, 0};
        uint32_t k;
        assert_int_equal(sp_co_link_cfg_default(&cfg, &sp_platform_default, zero), SP_OK);
        for (k = 0u; k < SP_LEGS; k++) {
            cfg.master.node[k].profile = (uint8_t)SP_CO_PROFILE_402;
        }
        cfg.master.pressure_feedback = 0u;
        assert_int_equal(sp_co_link_cfg_check(&cfg), SP_OK);
        cfg.master.node[0].force_ff = 1u;
        assert_int_equal(sp_co_link_cfg_check(&cfg), SP_E_ARG); /* no rated force for its leg */
        cfg.scaling[cfg.master.node[0].leg - 1u].rated_force_n = 5000u;
        assert_int_equal(sp_co_scaling_prepare(&cfg.scaling[cfg.master.node[0].leg - 1u]), SP_OK);
        assert_int_equal(sp_co_link_cfg_check(&cfg), SP_OK);
        memset(&out, 0, sizeof out);
        for (k = 0u; k < SP_LEGS; k++) {
            out.setpoint[k].force = 2500 * 256; /* 2.5 kN: half the rated force */
        }
        out.drive_mode = SP_DRIVE_ACTIVE;
        assert_int_equal(sp_co_link_input(&cfg, &out, 1u, &in), SP_OK);
        assert_int_equal(in.force_ff[0], 500);
        for (k = 1u; k < SP_LEGS; k++) {
            assert_int_equal(in.force_ff[k], 0); /* CiA 402 without the feed-forward: none */
        }
    }
}

/* The plain int64 conversions the 32-bit ones replaced (canopen_scaling.h):
 * the same factors, the sign carried through a 64-bit difference; the
 * values and statuses must be equal bit for bit (the bytes on the bus). */
static int32_t ref_sat32(int64_t v, sp_status_t *st)
{
    if (v > INT32_MAX || v < INT32_MIN) {
        *st = SP_E_OVERFLOW;
        return v > 0 ? INT32_MAX : INT32_MIN;
    }
    return (int32_t)v;
}

static int64_t ref_signed_round(int64_t sign, uint64_t mag, unsigned shift)
{
    int64_t q = (int64_t)((mag + ((uint64_t)1 << (shift - 1u))) >> shift);
    return sign < 0 ? -q : q;
}

static sp_status_t ref_to_count(const sp_co_scaling_t *s, int32_t length_q24, int32_t *count)
{
    sp_status_t st = SP_OK;
    int64_t diff = ((int64_t)length_q24 - (int64_t)s->zero_q24) * s->direction;
    *count = ref_sat32(ref_signed_round(diff, (uint64_t)(diff < 0 ? -diff : diff) * s->count_per_q24, 24u), &st);
    return st;
}

static sp_status_t ref_to_length(const sp_co_scaling_t *s, int32_t count, int32_t *length_q24)
{
    sp_status_t st = SP_OK;
    int64_t c = (int64_t)count * s->direction, q24;
    if (c > s->count_limit || c < -s->count_limit) {
        *length_q24 = c > 0 ? INT32_MAX : INT32_MIN;
        return SP_E_OVERFLOW;
    }
    q24 = ref_signed_round(c, (uint64_t)(c < 0 ? -c : c) * s->q24_per_count_q28, 28u);
    *length_q24 = ref_sat32((int64_t)s->zero_q24 + q24, &st);
    return st;
}

static void test_scaling_reference(void **state)
{
    static const uint32_t nms[] = {1u, 2u, 3u, 100u, 999u, 1000u, 7919u, 65536u, 999999u, 1000000u};
    static const int32_t zeros[] = {0, 0x01D99999, -0x01D99999, INT32_MAX, INT32_MIN};
    static const int32_t edges[] = {0, 1, -1, 2, -2, INT32_MAX, INT32_MIN, INT32_MAX - 1, INT32_MIN + 1, 0x01000000};
    sp_co_scaling_t s;
    uint32_t k, z, seed = 777u;
    int32_t i;
    (void)state;
    memset(&s, 0, sizeof s);
    for (k = 0u; k < sizeof nms / sizeof nms[0]; k++) {
        for (z = 0u; z < sizeof zeros / sizeof zeros[0]; z++) {
            int dir;
            for (dir = -1; dir <= 1; dir += 2) {
                s.nm_per_count = nms[k];
                s.zero_q24 = zeros[z];
                s.direction = (int8_t)dir;
                assert_int_equal(sp_co_scaling_prepare(&s), SP_OK);
                for (i = 0; i < 3000; i++) {
                    int32_t v, a = 0, b = 0;
                    seed = seed * 1664525u + 1013904223u;
                    if (i < (int32_t)(sizeof edges / sizeof edges[0])) {
                        v = edges[i];
                    } else if (i & 1) {
                        v = (int32_t)(seed >> 1); /* the whole int32 range */
                        v = (seed & 2u) != 0u ? -v - 1 : v;
                    } else {
                        v = zeros[z] / 2 + (int32_t)(seed >> 6) - 0x02000000; /* near the zero */
                    }
                    assert_int_equal(sp_co_length_to_count(&s, v, &a), ref_to_count(&s, v, &b));
                    assert_int_equal(a, b);
                    assert_int_equal(sp_co_count_to_length(&s, v, &a), ref_to_length(&s, v, &b));
                    assert_int_equal(a, b);
                }
            }
        }
    }
}

static void test_master_input_checks(void **state)
{
    sp_co_master_t m;
    sp_co_master_cfg_t cfg;
    sp_can_frame_t f;
    sp_co_master_input_t in;
    sp_co_master_output_t out;
    (void)state;
    memset(&in, 0, sizeof in);
    assert_int_equal(sp_co_master_cfg_default(&cfg, 2u), SP_OK);
    assert_int_equal(sp_co_master_init(&m), SP_OK);
    assert_int_equal(sp_co_master_step(&m, &cfg, &in, &out), SP_OK);
    assert_int_equal(out.n_tx, 0u); /* not started: silent */
    assert_int_equal(sp_co_master_start(&m, &cfg, 0u), SP_OK);
    in.now_ms = 1u;
    assert_int_equal(sp_co_master_step(&m, &cfg, &in, &out), SP_OK);
    assert_int_equal(out.n_tx, 2u + 1u); /* two NMT resets, one SYNC on axis_a */
    assert_int_equal(out.tx[0].data[0], SP_CO_NMT_RESET_COMM);
    /* a heartbeat of another node, one of a known node on another bus: ignored */
    assert_int_equal(sp_co_heartbeat_frame(&f, SP_BUS_AXIS_A, 9u, SP_CO_NMT_STATE_BOOTUP), SP_OK);
    assert_int_equal(sp_co_master_receive(&m, &cfg, &f, 2u), SP_OK);
    assert_int_equal(sp_co_heartbeat_frame(&f, SP_BUS_AXIS_B, 1u, SP_CO_NMT_STATE_BOOTUP), SP_OK);
    assert_int_equal(sp_co_master_receive(&m, &cfg, &f, 2u), SP_OK);
    assert_int_equal(m.node[0].phase, SP_CO_PHASE_BOOT);
    /* a malformed boot-up of node 1 (2 bytes): rejected, nothing changes */
    assert_int_equal(sp_co_heartbeat_frame(&f, SP_BUS_AXIS_A, 1u, SP_CO_NMT_STATE_BOOTUP), SP_OK);
    f.len = 2u;
    assert_int_equal(sp_co_master_receive(&m, &cfg, &f, 2u), SP_E_FRAME);
    assert_int_equal(m.node[0].phase, SP_CO_PHASE_BOOT);
    f.len = 1u;
    assert_int_equal(sp_co_master_receive(&m, &cfg, &f, 2u), SP_OK);
    assert_int_equal(m.node[0].phase, SP_CO_PHASE_IDENTITY);
    assert_int_equal(sp_co_master_receive(NULL, &cfg, &f, 2u), SP_E_ARG);
    assert_int_equal(sp_co_master_step(&m, &cfg, NULL, &out), SP_E_ARG);
    cfg.node[1].node_id = 0u;
    assert_int_equal(sp_co_master_start(&m, &cfg, 0u), SP_E_ARG);
}

/* The master's own PDO reading and writing (the node table, TPDOs unpacked
 * in place, RPDO1 packed by its fixed mapping, the status word decoded once
 * per change) against the frame functions of sp/canopen/canopen.h, the plain
 * reference: six running drives (408 with and without the force
 * feed-forward, 402), random values, a config changed after the start. */
static void test_master_pdo_reference(void **state)
{
    static sp_co_master_t m;
    static sp_co_master_output_t out;
    sp_co_master_cfg_t cfg;
    sp_co_master_input_t in;
    sp_can_frame_t f;
    uint32_t seed = 4242u, t, k;
    (void)state;
    memset(&in, 0, sizeof in);
    assert_int_equal(sp_co_master_cfg_default(&cfg, 6u), SP_OK);
    cfg.master_heartbeat_ms = 0u;
    for (k = 3u; k < 6u; k++) {
        cfg.node[k].profile = (uint8_t)SP_CO_PROFILE_402;
    }
    cfg.node[0].force_ff = 1u;
    cfg.node[1].force_ff = 1u;
    cfg.node[3].force_ff = 1u; /* CiA 402 with the torque/force offset */
    assert_int_equal(sp_co_master_init(&m), SP_OK);
    assert_int_equal(sp_co_master_start(&m, &cfg, 0u), SP_OK);
    for (k = 0u; k < 6u; k++) { /* as after the start-up */
        m.node[k].phase = SP_CO_PHASE_RUN;
        m.node[k].nmt_pending = 0u;
    }
    in.request = (uint8_t)SP_CO_REQ_ACTIVE;
    for (t = 1u; t <= 400u; t++) {
        if (t == 200u) { /* node ids swapped on axis_a after the start: found by the config, not the table */
            cfg.node[0].node_id = 2u;
            cfg.node[1].node_id = 1u;
        }
        for (k = 0u; k < 6u; k++) {
            const sp_co_node_cfg_t *nc = &cfg.node[k];
            uint16_t status, pa, pb;
            int32_t actual;
            seed = seed * 1664525u + 1013904223u;
            status = k < 3u ? (uint16_t)(0x000Fu | (seed & 0xFF00u)) : (uint16_t)(0x0027u | (seed & 0xFF00u));
            actual = (int32_t)(seed >> 1);
            actual = (seed & 1u) != 0u ? -actual - 1 : actual;
            assert_int_equal(sp_co_tpdo1_frame(&f, nc->bus, nc->node_id, status, actual), SP_OK);
            assert_int_equal(sp_co_master_receive(&m, &cfg, &f, t), SP_OK);
            assert_int_equal(sp_co_tpdo1_parse(&f, nc->node_id, &status, &actual), SP_OK);
            assert_int_equal(m.node[k].status, status);
            assert_int_equal(m.node[k].actual, actual);
            pa = (uint16_t)(seed >> 16);
            pb = (uint16_t)seed;
            assert_int_equal(sp_co_tpdo2_frame(&f, nc->bus, nc->node_id, pa, pb), SP_OK);
            assert_int_equal(sp_co_master_receive(&m, &cfg, &f, t), SP_OK);
            assert_int_equal(m.node[k].pa_kpa, pa);
            assert_int_equal(m.node[k].pb_kpa, pb);
            assert_int_equal(sp_co_heartbeat_frame(&f, nc->bus, nc->node_id, SP_CO_NMT_STATE_OPERATIONAL), SP_OK);
            assert_int_equal(sp_co_master_receive(&m, &cfg, &f, t), SP_OK);
            assert_int_equal(m.node[k].hb_last, t);
            assert_int_equal(sp_co_tpdo2_frame(&f, nc->bus, nc->node_id, pa, pb), SP_OK);
            f.len = 5u; /* malformed: rejected, nothing changes */
            assert_int_equal(sp_co_master_receive(&m, &cfg, &f, t), SP_E_FRAME);
            assert_int_equal(m.node[k].pa_kpa, pa);
            in.setpoint[k] = (int32_t)(seed ^ 0x5A5A5A5Au) / 3;
            in.force_ff[k] = (int16_t)((int32_t)(seed >> 16) - 32768);
        }
        in.now_ms = t;
        assert_int_equal(sp_co_master_step(&m, &cfg, &in, &out), SP_OK);
        assert_int_equal(out.fault_mask, 0u);
        assert_int_equal(out.n_tx, 6u + 2u); /* then a SYNC on each bus, axis_a and axis_b */
        for (k = 0u; k < 6u; k++) {
            const sp_can_frame_t *g = &out.tx[k];
            sp_can_frame_t ref;
            uint16_t cw;
            int32_t sp;
            int16_t ff = 0;
            memset(&ref, 0xA5, sizeof ref);
            if (cfg.node[k].force_ff) {
                assert_int_equal(sp_co_rpdo1_ff_parse(g, cfg.node[k].node_id, &cw, &sp, &ff), SP_OK);
                assert_int_equal(sp_co_rpdo1_ff_frame(&ref, cfg.node[k].bus, cfg.node[k].node_id, cw, sp, ff), SP_OK);
                assert_int_equal(ff, in.force_ff[k]);
            } else {
                assert_int_equal(sp_co_rpdo1_parse(g, cfg.node[k].node_id, &cw, &sp), SP_OK);
                assert_int_equal(sp_co_rpdo1_frame(&ref, cfg.node[k].bus, cfg.node[k].node_id, cw, sp), SP_OK);
            }
            assert_int_equal(g->id, ref.id);
            assert_int_equal(g->bus, ref.bus);
            assert_int_equal(g->len, ref.len);
            assert_int_equal(g->flags, ref.flags);
            assert_memory_equal(g->data, ref.data, 8u);
            assert_int_equal(sp, in.setpoint[k]); /* ACTIVE, operation enabled: the setpoint */
            assert_int_equal(
                cw, k < 3u ? sp_co408_control_word(SP_CO_REQ_ACTIVE, 0)
                           : sp_co402_control_word(SP_CO402_OPERATION_ENABLED, SP_CO402_OPERATION_ENABLED, 0, 0));
        }
        assert_int_equal(out.ready, 1u);
    }
    /* the status word decoded again when it changes: node 4 (CiA 402) shows FAULT */
    assert_int_equal(sp_co_tpdo1_frame(&f, cfg.node[4].bus, cfg.node[4].node_id, 0x0008u, 0), SP_OK);
    assert_int_equal(sp_co_master_receive(&m, &cfg, &f, 401u), SP_OK);
    in.now_ms = 401u;
    assert_int_equal(sp_co_master_step(&m, &cfg, &in, &out), SP_OK);
    assert_int_equal(out.fault_mask, 1u << 4);
    assert_int_equal(m.node[4].fault.code, SP_CO_F_DEVICE_FAULT);
    assert_int_equal(m.node[4].fault.detail, 0x0008u);
    /* and when the profile changes under the same word: node 0's 0x..0F is 402's FAULT_REACTION */
    cfg.node[0].profile = (uint8_t)SP_CO_PROFILE_402;
    cfg.node[0].force_ff = 0u;
    in.now_ms = 402u;
    assert_int_equal(sp_co_master_step(&m, &cfg, &in, &out), SP_OK);
    assert_int_equal(m.node[0].fault.code, SP_CO_F_DEVICE_FAULT);
}

/* The legs' calibrated length sensors (config "length_sensors") apply to
 * CANopen legs as to native ones: a drive's position (by its scaling) is the
 * sensor's reading; the feedback maps it to the joint-to-joint length and
 * the setpoint back, to one count. */
static void test_link_length_sensors(void **state)
{
    sp_co_link_cfg_t cfg;
    sp_co_master_t m;
    sp_co_master_input_t in;
    sp_ctrl_output_t out;
    sp_drive_feedback_t fb[SP_LEGS];
    sp_q24_t zero[SP_LEGS];
    sp_length_sensors_t sens;
    uint32_t i;
    (void)state;
    for (i = 0u; i < SP_LEGS; i++) {
        zero[i] = (sp_q24_t)(0x02000000 + (int32_t)i * 0x10000); /* 2 m + i/256 m */
    }
    assert_int_equal(sp_co_link_cfg_default(&cfg, &sp_platform_default, zero), SP_OK);
    /* the built-in platform's, or none when they are all zero (the maps are then identity, bit for bit) */
    assert_ptr_equal(cfg.length_sensors, sp_length_sensors_in_use(&sp_length_sensors_default));
    assert_null(sp_length_sensors_in_use(NULL));
    memset(&sens, 0, sizeof sens);
    assert_null(sp_length_sensors_in_use(&sens));
    sens.scale_inv[5] = 1;
    assert_ptr_equal(sp_length_sensors_in_use(&sens), &sens);
    memset(&sens, 0, sizeof sens);
    sens.zero[1] = 8389;         /* 0.5 mm */
    sens.scale[1] = 107374;      /* 100 ppm, Q30 */
    sens.scale_inv[1] = -107363; /* 1 / (1 + 1e-4) - 1, Q30 */
    cfg.length_sensors = &sens;
    memset(&m, 0, sizeof m);
    memset(fb, 0, sizeof fb);
    m.node[1].tpdo1_fresh = 1u; /* node 1 moves leg 2 */
    m.node[1].actual = 62500;   /* um: the sensor reads zero[1] + 62.5 mm */
    m.node[2].tpdo1_fresh = 1u; /* leg 3: its sensor as drawn */
    m.node[2].actual = 62500;
    assert_int_equal(sp_co_link_feedback(&m, &cfg, fb), SP_OK);
    int64_t r = (int64_t)zero[1] + 0x00100000;
    int64_t lmin = sp_platform_default.leg_length_min;
    /* l = lmin + (r - zero - lmin) / (1 + k): 0.5 mm and 100 ppm of the stroke shorter */
    int64_t want = r - 8389 - (((r - 8389 - lmin) * 107374) >> 30);
    assert_true(llabs((int64_t)fb[1].length - want) <= 2);
    assert_true(r - fb[1].length > 8389);                 /* the correction is there */
    assert_int_equal(fb[2].length, zero[2] + 0x00100000); /* identity where zero and scale are 0 */

    /* the setpoint at that length goes out as the count the drive reported */
    memset(&out, 0, sizeof out);
    for (i = 0u; i < SP_LEGS; i++) {
        out.setpoint[i].length = fb[i].length != 0 ? fb[i].length : zero[i];
    }
    out.drive_mode = SP_DRIVE_ACTIVE;
    assert_int_equal(sp_co_link_input(&cfg, &out, 5u, &in), SP_OK);
    assert_true(llabs((int64_t)in.setpoint[1] - 62500) <= 1);
    assert_int_equal(in.setpoint[2], 62500);
    /* without sensors the reading is the length: the setpoint 0.5 mm and 100 ppm off */
    cfg.length_sensors = NULL;
    assert_int_equal(sp_co_link_input(&cfg, &out, 5u, &in), SP_OK);
    assert_true(in.setpoint[1] < 62500 - 500);
    assert_int_equal(sp_co_link_feedback(&m, &cfg, fb), SP_OK);
    assert_int_equal(fb[1].length, (sp_q24_t)r);
}

static void test_link(void **state)
{
    sp_co_link_cfg_t cfg;
    sp_co_master_t m;
    sp_co_master_input_t in;
    sp_ctrl_output_t out;
    sp_drive_feedback_t fb[SP_LEGS];
    sp_q24_t zero[SP_LEGS];
    uint32_t i;
    (void)state;
    for (i = 0u; i < SP_LEGS; i++) {
        zero[i] = (sp_q24_t)(0x01000000 + (int32_t)i * 0x10000); /* 1 m + i/256 m */
    }
    assert_int_equal(sp_co_link_cfg_default(&cfg, &sp_platform_default, zero), SP_OK);
    assert_int_equal(sp_co_link_cfg_check(&cfg), SP_OK);
    /* legs swapped between nodes 0 and 1: still one drive per leg */
    cfg.master.node[0].leg = 2u;
    cfg.master.node[1].leg = 1u;
    assert_int_equal(sp_co_link_cfg_check(&cfg), SP_OK);
    cfg.master.node[1].leg = 2u; /* leg 2 twice, leg 1 none */
    assert_int_equal(sp_co_link_cfg_check(&cfg), SP_E_ARG);
    cfg.master.node[1].leg = 1u;
    cfg.scaling[3].direction = 0;
    assert_int_equal(sp_co_link_cfg_check(&cfg), SP_E_ARG);
    cfg.scaling[3].direction = 1;

    /* feedback: node 0 moves leg 2 */
    memset(&m, 0, sizeof m);
    memset(fb, 0, sizeof fb);
    fb[4].fresh = 1u;
    m.node[0].tpdo1_fresh = 1u;
    m.node[0].actual = 62500; /* um */
    m.node[0].pa_kpa = 10000u;
    m.node[0].pb_kpa = 0u;
    m.node[2].tpdo1_fresh = 1u;
    m.node[2].fault.code = SP_CO_F_EMCY;
    assert_int_equal(sp_co_link_feedback(&m, &cfg, fb), SP_OK);
    assert_int_equal(fb[1].fresh, 1u);
    assert_int_equal(fb[1].length, zero[1] + 0x00100000); /* + 62.5 mm */
    assert_int_equal(fb[1].faults, 0u);
    /* 100 bar on the piston side pushes out: 1e7 Pa x the piston area (the link passes Pa, as node.c does) */
    assert_true(llabs((int64_t)fb[1].force - (((int64_t)10000000 * sp_platform_default.piston_area) >> 22)) <= 1);
    assert_int_equal(fb[2].fresh, 1u);
    assert_int_equal(fb[2].faults, SP_CO_LINK_FAULT);
    assert_int_equal(fb[0].fresh, 0u);
    assert_int_equal(fb[4].fresh, 0u); /* cleared: no TPDO */
    assert_int_equal(fb[1].no_force, 0u);
    /* no pressures mapped (pressure_feedback off; CiA 402 likewise): no force measured, not 0 N */
    cfg.master.pressure_feedback = 0u;
    assert_int_equal(sp_co_link_feedback(&m, &cfg, fb), SP_OK);
    assert_int_equal(fb[1].no_force, 1u);
    assert_int_equal(fb[1].force, 0);
    cfg.master.pressure_feedback = 1u;
    cfg.master.node[0].profile = (uint8_t)SP_CO_PROFILE_402;
    assert_int_equal(sp_co_link_feedback(&m, &cfg, fb), SP_OK);
    assert_int_equal(fb[1].no_force, 1u);
    assert_int_equal(fb[2].no_force, 0u); /* node 2 stays CiA 408 */
    cfg.master.node[0].profile = (uint8_t)SP_CO_PROFILE_408;

    /* input: the request follows the drive mode, setpoints by scaling */
    memset(&out, 0, sizeof out);
    for (i = 0u; i < SP_LEGS; i++) {
        out.setpoint[i].length = zero[i] - 0x00100000;
    }
    out.drive_mode = SP_DRIVE_HOLD;
    assert_int_equal(sp_co_link_input(&cfg, &out, 77u, &in), SP_OK);
    assert_int_equal(in.request, SP_CO_REQ_HOLD);
    assert_int_equal(in.now_ms, 77u);
    assert_int_equal(in.setpoint[0], -62500);           /* node 0: leg 2's setpoint */
    out.setpoint[1].length = zero[1] - 0x00100000 + 17; /* 1 um = 16.8 Q24 steps: rounds to one count more */
    out.drive_mode = SP_DRIVE_ACTIVE;
    assert_int_equal(sp_co_link_input(&cfg, &out, 78u, &in), SP_OK);
    assert_int_equal(in.request, SP_CO_REQ_ACTIVE);
    assert_int_equal(in.setpoint[0], -62499);
    /* the force feed-forward in daN along the count: rounded half away from zero, saturated */
    out.setpoint[1].force = -12345 * 256; /* -1234.5 daN */
    out.setpoint[2].force = 400000 * 256; /* beyond INT16 daN */
    assert_int_equal(sp_co_link_input(&cfg, &out, 78u, &in), SP_OK);
    assert_int_equal(in.force_ff[0], -1235);
    assert_int_equal(in.force_ff[2], INT16_MAX); /* node 2: leg 3 */
    cfg.scaling[1].direction = -1;
    assert_int_equal(sp_co_link_input(&cfg, &out, 78u, &in), SP_OK);
    assert_int_equal(in.force_ff[0], 1235); /* the count falls as the leg extends: the force too */
    cfg.scaling[1].direction = 1;
    cfg.scaling[0].nm_per_count = 1u;
    assert_int_equal(sp_co_scaling_prepare(&cfg.scaling[0]), SP_OK);
    out.setpoint[0].length = INT32_MAX;
    assert_int_equal(sp_co_link_input(&cfg, &out, 79u, &in), SP_E_OVERFLOW);
    assert_int_equal(in.setpoint[1], INT32_MAX);
    assert_int_equal(sp_co_link_input(NULL, &out, 79u, &in), SP_E_ARG);

    /* from a layout (the config's drives section as generated): the scalings are prepared, the rest checked */
    {
        sp_co_layout_t lay;
        sp_co_link_cfg_t c2;
        memset(&lay, 0, sizeof lay);
        assert_int_equal(sp_co_link_cfg_from_layout(&c2, &lay, &sp_platform_default), SP_E_ARG); /* not present */
        lay.present = 1u;
        assert_int_equal(sp_co_master_cfg_default(&lay.master, (uint8_t)SP_LEGS), SP_OK);
        lay.master.node[3].force_ff = 1u;
        for (i = 0u; i < SP_LEGS; i++) {
            lay.scaling[i].nm_per_count = 2000u;
            lay.scaling[i].zero_q24 = zero[i];
            lay.scaling[i].direction = -1;
        }
        assert_int_equal(sp_co_link_cfg_from_layout(&c2, &lay, &sp_platform_default), SP_OK);
        assert_int_equal(c2.master.node[3].force_ff, 1u);
        assert_ptr_equal(c2.platform, &sp_platform_default);
        out.setpoint[0].length = zero[0] + 0x00100000; /* + 62.5 mm = 31250 counts of 2 um, counting down */
        assert_int_equal(sp_co_link_input(&c2, &out, 80u, &in), SP_OK);
        assert_int_equal(in.setpoint[0], -31250);
        lay.scaling[2].nm_per_count = 0u; /* not a scaling */
        assert_int_equal(sp_co_link_cfg_from_layout(&c2, &lay, &sp_platform_default), SP_E_ARG);
        lay.scaling[2].nm_per_count = 2000u;
        lay.master.node[4].node_id = lay.master.node[3].node_id; /* both on axis_b: a duplicate id */
        assert_int_equal(sp_co_link_cfg_from_layout(&c2, &lay, &sp_platform_default), SP_E_ARG);
        assert_int_equal(sp_co_link_cfg_from_layout(NULL, &lay, &sp_platform_default), SP_E_ARG);
    }
    assert_int_equal(sp_co_link_feedback(&m, &cfg, NULL), SP_E_ARG);
}

/* The controller closed over the link around an ideal plant: each drive
 * reaches its setpoint length by the next tick and pushes with the
 * setpoint's force, reported (CiA 408 with pressure feedback) as the
 * chamber pressure that gives it, in whole kPa. */
typedef struct {
    sp_co_link_cfg_t link;
    sp_co_master_t m;
    sp_ctrl_config_t cfg;
    sp_ctrl_t ctrl;
    sp_ctrl_input_t in;
    sp_ctrl_output_t out;
    sp_q24_t length[SP_LEGS];
    double force[SP_LEGS]; /* N */
} co_rig_t;

static void co_rig_init(co_rig_t *r, uint8_t source, uint8_t profile_402_mask)
{
    sp_ik_t ik;
    uint32_t k;
    memset(r, 0, sizeof *r);
    assert_int_equal(sp_inverse_kinematics(&sp_platform_default, &sp_platform_default.park, &ik), SP_OK);
    memcpy(r->length, ik.length, sizeof r->length);
    assert_int_equal(sp_co_link_cfg_default(&r->link, &sp_platform_default, ik.length), SP_OK);
    for (k = 0u; k < SP_LEGS; k++) {
        uint8_t leg = r->link.master.node[k].leg;
        if ((profile_402_mask & (1u << (leg - 1u))) != 0u) {
            r->link.master.node[k].profile = (uint8_t)SP_CO_PROFILE_402;
        }
    }
    assert_int_equal(sp_co_link_cfg_check(&r->link), SP_OK);
    assert_int_equal(sp_ctrl_default_config(&r->cfg, &sp_platform_default), SP_OK);
    assert_int_equal(sp_ctrl_set_wrench_source(&r->cfg, source, NULL), SP_OK);
    r->cfg.ft_tare_samples = 20u;
    r->cfg.friction_observer = 0u; /* the ideal plant has no seal friction: the model's forces hold it */
    assert_int_equal(sp_ctrl_init(&r->ctrl, &r->cfg), SP_OK);
}

static uint16_t kpa_of(double force_n, sp_q30_t area_q30)
{
    double kpa = force_n / ((double)area_q30 / 1073741824.0) / 1000.0;
    return kpa > 65535.0 ? (uint16_t)65535u : (uint16_t)lround(kpa);
}

static void co_rig_tick(co_rig_t *r, sp_cmd_type_t cmd)
{
    uint32_t k;
    for (k = 0u; k < SP_LEGS; k++) {
        sp_co_node_t *nd = &r->m.node[k];
        uint32_t leg = (uint32_t)r->link.master.node[k].leg - 1u;
        double f = r->force[leg];
        nd->tpdo1_fresh = 1u;
        assert_int_equal(sp_co_length_to_count(&r->link.scaling[leg], r->length[leg], &nd->actual), SP_OK);
        nd->pa_kpa = f > 0.0 ? kpa_of(f, sp_platform_default.piston_area) : 0u;
        nd->pb_kpa = f < 0.0 ? kpa_of(-f, sp_platform_default.annulus_area) : 0u;
    }
    assert_int_equal(sp_co_link_feedback(&r->m, &r->link, r->in.drive), SP_OK);
    r->in.cmd.type = cmd;
    r->in.ft_fresh = 1u; /* a sensor at rest (read only with the sensor as wrench source) */
    r->in.ft_reading[2] = 15 * 256;
    assert_int_equal(sp_ctrl_step(&r->cfg, &r->ctrl, &r->in, &r->out), SP_OK);
    r->in.cmd.type = SP_CMD_NONE;
    if (r->out.drive_mode == SP_DRIVE_ACTIVE) {
        for (k = 0u; k < SP_LEGS; k++) {
            r->length[k] = r->out.setpoint[k].length;
            r->force[k] = (double)r->out.setpoint[k].force / 256.0;
        }
    }
}

static void co_rig_ready(co_rig_t *r)
{
    int n;
    for (n = 0; n < 3; n++) {
        co_rig_tick(r, SP_CMD_NONE);
    }
    co_rig_tick(r, SP_CMD_ENGAGE);
    assert_int_equal(r->out.cmd_rejected, 0);
    for (n = 0; n < 20000 && r->out.state != SP_STATE_READY; n++) {
        co_rig_tick(r, SP_CMD_NONE);
    }
    assert_int_equal(r->out.state, SP_STATE_READY);
    for (n = 0; n < 200; n++) { /* at rest: the filters settle */
        co_rig_tick(r, SP_CMD_NONE);
    }
}

/* FORCE on z (1 kN down on the world) as the operator would send it. */
static void co_rig_force(co_rig_t *r)
{
    memset(r->in.cmd.force_target, 0, sizeof r->in.cmd.force_target);
    r->in.cmd.force_mask = 0x04u;
    r->in.cmd.force_target[2] = -1000 * 256;
    co_rig_tick(r, SP_CMD_FORCE);
}

/* sp_co_link_input_due against sp_co_link_input every tick: two masters at
 * SYNC divider 3 (CiA 408 with the force object, CiA 402 with 0x60B2),
 * the same setpoints moving every tick and the drive mode switching: the
 * same frames every tick, byte for byte; sp_co_master_sync_due says 1 on
 * exactly the steps that send SYNC. */
static void test_link_input_due(void **state)
{
    static sp_co_master_t ma, mb;
    static sp_co_master_output_t oa, ob;
    sp_co_link_cfg_t cfg;
    sp_ctrl_output_t out;
    sp_co_master_input_t ia, ib;
    sp_q24_t zero[SP_LEGS] = {0, 0, 0, 0, 0, 0};
    uint32_t t, k;
    (void)state;
    assert_int_equal(sp_co_link_cfg_default(&cfg, &sp_platform_default, zero), SP_OK);
    cfg.master.sync_divider = 3u;
    cfg.master.master_heartbeat_ms = 0u;
    for (k = 0u; k < SP_LEGS; k++) {
        cfg.master.node[k].force_ff = 1u;
        cfg.scaling[k].rated_force_n = 8000u;
        assert_int_equal(sp_co_scaling_prepare(&cfg.scaling[k]), SP_OK);
    }
    for (k = 3u; k < SP_LEGS; k++) {
        cfg.master.node[k].profile = (uint8_t)SP_CO_PROFILE_402;
    }
    cfg.master.pressure_feedback = 1u;
    assert_int_equal(sp_co_link_cfg_check(&cfg), SP_OK);
    assert_int_equal(sp_co_master_sync_due(&ma, &cfg.master), 0); /* not started */
    assert_int_equal(sp_co_link_setpoints_idle(&cfg, &ma), 1);
    assert_int_equal(sp_co_link_setpoints_idle(NULL, &ma), 1);
    assert_int_equal(sp_co_master_init(&ma), SP_OK);
    assert_int_equal(sp_co_master_init(&mb), SP_OK);
    assert_int_equal(sp_co_master_start(&ma, &cfg.master, 0u), SP_OK);
    assert_int_equal(sp_co_master_start(&mb, &cfg.master, 0u), SP_OK);
    for (k = 0u; k < SP_LEGS; k++) { /* as after the start-up */
        ma.node[k].phase = mb.node[k].phase = SP_CO_PHASE_RUN;
        ma.node[k].nmt_pending = mb.node[k].nmt_pending = 0u;
    }
    memset(&out, 0, sizeof out);
    memset(&ia, 0, sizeof ia);
    memset(&ib, 0, sizeof ib);
    for (t = 1u; t <= 300u; t++) {
        int due = sp_co_master_sync_due(&mb, &cfg.master);
        assert_int_equal(sp_co_link_setpoints_idle(&cfg, &mb), due ? 0 : 1);
        out.drive_mode = (t / 50u) % 2u == 0u ? SP_DRIVE_ACTIVE : SP_DRIVE_HOLD;
        for (k = 0u; k < SP_LEGS; k++) {
            out.setpoint[k].length = (sp_q24_t)(t * 977u + k * 100000u);
            out.setpoint[k].force = (sp_q8_t)((int32_t)(t * 1301u) - (int32_t)(k * 90000u));
        }
        (void)sp_co_link_input(&cfg, &out, t, &ia);
        (void)sp_co_link_input_due(&cfg, &mb, &out, t, &ib);
        assert_int_equal(ia.request, ib.request);
        assert_int_equal(sp_co_master_step(&ma, &cfg.master, &ia, &oa), SP_OK);
        assert_int_equal(sp_co_master_step(&mb, &cfg.master, &ib, &ob), SP_OK);
        assert_int_equal(ob.sync, (uint8_t)due);
        assert_int_equal(oa.n_tx, ob.n_tx);
        assert_int_equal(oa.sync, ob.sync);
        for (k = 0u; k < oa.n_tx; k++) {
            assert_int_equal(oa.tx[k].id, ob.tx[k].id);
            assert_int_equal(oa.tx[k].len, ob.tx[k].len);
            assert_memory_equal(oa.tx[k].data, ob.tx[k].data, oa.tx[k].len);
        }
    }
    assert_int_equal(sp_co_link_input_due(NULL, &mb, &out, 1u, &ib), SP_E_ARG);
    assert_int_equal(sp_co_link_input_due(&cfg, NULL, &out, 1u, &ib), SP_E_ARG);
}

/* The controller's config for a layout: the feedback period is the SYNC
 * divider, and a feedback timeout at or below it is raised above it (one
 * above is kept); a divider of 0 is refused. */
static void test_link_ctrl_config(void **state)
{
    sp_co_link_cfg_t cfg;
    sp_ctrl_config_t ctrl;
    sp_q24_t zero[SP_LEGS] = {0, 0, 0, 0, 0, 0};
    (void)state;
    assert_int_equal(sp_co_link_cfg_default(&cfg, &sp_platform_default, zero), SP_OK);
    assert_int_equal(sp_ctrl_default_config(&ctrl, &sp_platform_default), SP_OK);
    assert_int_equal(ctrl.feedback_divider, 1u);
    cfg.master.sync_divider = 3u;
    assert_int_equal(sp_co_link_ctrl_config(&cfg, &ctrl), SP_OK);
    assert_int_equal(ctrl.feedback_divider, 3u);
    assert_int_equal(ctrl.feedback_timeout_ticks, 5u);
    ctrl.feedback_timeout_ticks = 4u;
    assert_int_equal(sp_co_link_ctrl_config(&cfg, &ctrl), SP_OK);
    assert_int_equal(ctrl.feedback_timeout_ticks, 4u);
    cfg.master.sync_divider = 0u;
    assert_int_equal(sp_co_link_ctrl_config(&cfg, &ctrl), SP_E_ARG);
    assert_int_equal(sp_co_link_ctrl_config(NULL, &ctrl), SP_E_ARG);
}

/* The wrench estimate's validity follows the drives' force measurement:
 * CiA 408 with pressures gives a valid estimate near zero (nothing
 * outside pushes; the pressures' 1 kPa steps); a CiA 402 drive on any leg measures no force: the estimate is
 * invalid (not the model's forces against zeros, tens of kN), the leg
 * is named in force_unmeasured, and force control and TARE on the
 * cylinders are refused, while the force/torque sensor's still work. */
static void test_link_wrench_validity(void **state)
{
    static co_rig_t r;
    double biggest = 0.0;
    int k;
    (void)state;

    co_rig_init(&r, SP_WRENCH_CYLINDERS, 0u); /* CiA 408, pressure feedback on */
    co_rig_ready(&r);
    assert_int_equal(r.out.wrench_valid, 1);
    assert_int_equal(r.out.force_unmeasured, 0u);
    for (k = 0; k < 3; k++) {
        biggest = fmax(biggest, fabs((double)r.out.wrench[k] / 256.0));
    }
    print_message("CiA 408 with pressures at rest: |force estimate| <= %.1f N\n", biggest);
    assert_true(biggest < 20.0); /* 1 kPa steps: under 1 N per cylinder */
    co_rig_tick(&r, SP_CMD_TARE);
    assert_int_equal(r.out.cmd_rejected, 0);

    co_rig_init(&r, SP_WRENCH_CYLINDERS, 0x3Fu); /* every drive CiA 402 */
    co_rig_ready(&r);
    assert_int_equal(r.out.wrench_valid, 0);
    assert_int_equal(r.out.force_unmeasured, 0x3Fu);
    for (k = 0; k < SP_LEGS; k++) {
        assert_int_equal(r.in.drive[k].no_force, 1u);
        assert_int_equal(r.in.drive[k].force, 0);
    }
    co_rig_tick(&r, SP_CMD_TARE);
    assert_int_equal(r.out.cmd_rejected, 1);
    co_rig_force(&r);
    assert_int_equal(r.out.cmd_rejected, 1);
    assert_int_equal(r.out.force_mode, SP_FORCE_OFF);
    assert_int_equal(r.out.state, SP_STATE_READY); /* refused, not a fault */
    assert_int_equal(r.out.faults, 0u);

    co_rig_init(&r, SP_WRENCH_CYLINDERS, 0x10u); /* one CiA 402 drive, on leg 5 */
    co_rig_ready(&r);
    assert_int_equal(r.out.wrench_valid, 0);
    assert_int_equal(r.out.force_unmeasured, 0x10u);

    co_rig_init(&r, SP_WRENCH_SENSOR, 0x3Fu); /* CiA 402 with the force/torque sensor */
    co_rig_ready(&r);
    assert_int_equal(r.out.wrench_valid, 0);
    co_rig_tick(&r, SP_CMD_TARE);
    assert_int_equal(r.out.cmd_rejected, 0);
    for (k = 0; k < 40; k++) {
        co_rig_tick(&r, SP_CMD_NONE);
    }
    co_rig_force(&r);
    assert_int_equal(r.out.cmd_rejected, 0);
    assert_int_equal(r.out.force_mode, SP_FORCE_FORCE);
}

/* CiA 402: the statusword table (every state's bits decode to it, other
 * bits ignored), the controlword the master sends from each state towards
 * each target, and the drive's side: the master's words walk the drive's
 * state machine to the target in at most 3 SYNCs from switch on disabled. */
/* sp_co402_state's lookup against the plain search of the (mask, value)
 * rows of docs/reference/canopen.md, first match, for every statusword. */
static sp_co402_state_t ref_state402(uint16_t status)
{
    static const struct {
        uint16_t mask, value;
    } rows[] = {{0x4Fu, 0x00u}, {0x4Fu, 0x40u}, {0x6Fu, 0x21u}, {0x6Fu, 0x23u},
                {0x6Fu, 0x27u}, {0x6Fu, 0x07u}, {0x4Fu, 0x0Fu}, {0x4Fu, 0x08u}};
    uint32_t i;
    for (i = 0u; i < sizeof rows / sizeof rows[0]; i++) {
        if ((status & rows[i].mask) == rows[i].value) {
            return (sp_co402_state_t)i;
        }
    }
    return SP_CO402_UNKNOWN;
}

static void test_cia402_state_lookup(void **state)
{
    uint32_t w;
    (void)state;
    for (w = 0u; w <= 0xFFFFu; w++) {
        assert_int_equal(sp_co402_state((uint16_t)w), ref_state402((uint16_t)w));
    }
}

static void test_cia402_states(void **state)
{
    sp_co402_state_t s, t;
    (void)state;
    for (s = SP_CO402_NOT_READY; s < SP_CO402_UNKNOWN; s = (sp_co402_state_t)(s + 1)) {
        uint16_t bits = sp_co402_status_bits(s);
        assert_int_equal(sp_co402_state(bits), s);
        assert_int_equal(sp_co402_state((uint16_t)(bits | 0x0210u)), s); /* voltage enabled, remote */
        assert_int_equal(sp_co402_is_fault(s), s == SP_CO402_FAULT || s == SP_CO402_FAULT_REACTION);
    }
    assert_int_equal(sp_co402_state(0x0027u), SP_CO402_OPERATION_ENABLED);
    assert_int_equal(sp_co402_state(0x0007u), SP_CO402_QUICK_STOP_ACTIVE);
    assert_int_equal(sp_co402_state(0x0001u), SP_CO402_UNKNOWN);
    assert_string_equal(sp_co402_state_name(SP_CO402_OPERATION_ENABLED), "OPERATION_ENABLED");
    assert_string_equal(sp_co402_state_name((sp_co402_state_t)99), "UNKNOWN");
    assert_int_equal(sp_co402_target(SP_CO_REQ_DISABLED), SP_CO402_READY);
    assert_int_equal(sp_co402_target(SP_CO_REQ_HOLD), SP_CO402_OPERATION_ENABLED);
    assert_int_equal(sp_co402_target(SP_CO_REQ_ACTIVE), SP_CO402_OPERATION_ENABLED);
    /* the commands of the sequence */
    assert_int_equal(sp_co402_control_word(SP_CO402_SWITCH_ON_DISABLED, SP_CO402_OPERATION_ENABLED, 0, 0), 0x06u);
    assert_int_equal(sp_co402_control_word(SP_CO402_READY, SP_CO402_OPERATION_ENABLED, 0, 0), 0x07u);
    assert_int_equal(sp_co402_control_word(SP_CO402_SWITCHED_ON, SP_CO402_OPERATION_ENABLED, 0, 0), 0x0Fu);
    assert_int_equal(sp_co402_control_word(SP_CO402_OPERATION_ENABLED, SP_CO402_OPERATION_ENABLED, 0, 0), 0x0Fu);
    assert_int_equal(sp_co402_control_word(SP_CO402_OPERATION_ENABLED, SP_CO402_READY, 0, 0), 0x06u);
    assert_int_equal(sp_co402_control_word(SP_CO402_READY, SP_CO402_READY, 0, 0), 0x06u);
    assert_int_equal(sp_co402_control_word(SP_CO402_QUICK_STOP_ACTIVE, SP_CO402_OPERATION_ENABLED, 0, 0), 0x00u);
    assert_int_equal(sp_co402_control_word(SP_CO402_FAULT, SP_CO402_OPERATION_ENABLED, 0, 0), 0x00u);
    assert_int_equal(sp_co402_control_word(SP_CO402_FAULT, SP_CO402_OPERATION_ENABLED, 1, 0), 0x80u);
    assert_int_equal(sp_co402_control_word(SP_CO402_OPERATION_ENABLED, SP_CO402_OPERATION_ENABLED, 0, 1), 0x02u);
    /* the drive's transitions */
    assert_int_equal(sp_co402_next(SP_CO402_NOT_READY, 0u, 0u, 0), SP_CO402_SWITCH_ON_DISABLED);
    assert_int_equal(sp_co402_next(SP_CO402_SWITCH_ON_DISABLED, 0x0Fu, 0u, 0), SP_CO402_SWITCH_ON_DISABLED);
    assert_int_equal(sp_co402_next(SP_CO402_READY, 0x0Fu, 0x06u, 0), SP_CO402_SWITCHED_ON);
    assert_int_equal(sp_co402_next(SP_CO402_OPERATION_ENABLED, 0x07u, 0x0Fu, 0), SP_CO402_SWITCHED_ON);
    assert_int_equal(sp_co402_next(SP_CO402_OPERATION_ENABLED, 0x06u, 0x0Fu, 0), SP_CO402_READY);
    assert_int_equal(sp_co402_next(SP_CO402_OPERATION_ENABLED, 0x02u, 0x0Fu, 0), SP_CO402_QUICK_STOP_ACTIVE);
    assert_int_equal(sp_co402_next(SP_CO402_QUICK_STOP_ACTIVE, 0x0Fu, 0x02u, 0), SP_CO402_QUICK_STOP_ACTIVE);
    assert_int_equal(sp_co402_next(SP_CO402_QUICK_STOP_ACTIVE, 0x00u, 0x02u, 0), SP_CO402_SWITCH_ON_DISABLED);
    assert_int_equal(sp_co402_next(SP_CO402_SWITCHED_ON, 0x02u, 0x07u, 0), SP_CO402_SWITCH_ON_DISABLED);
    assert_int_equal(sp_co402_next(SP_CO402_OPERATION_ENABLED, 0x0Fu, 0x0Fu, 1), SP_CO402_FAULT_REACTION);
    assert_int_equal(sp_co402_next(SP_CO402_FAULT_REACTION, 0x0Fu, 0x0Fu, 1), SP_CO402_FAULT);
    assert_int_equal(sp_co402_next(SP_CO402_FAULT, 0x80u, 0x80u, 0), SP_CO402_FAULT); /* no edge */
    assert_int_equal(sp_co402_next(SP_CO402_FAULT, 0x80u, 0x00u, 1), SP_CO402_FAULT); /* the cause remains */
    assert_int_equal(sp_co402_next(SP_CO402_FAULT, 0x80u, 0x00u, 0), SP_CO402_SWITCH_ON_DISABLED);
    /* the master's words against the drive: from every non-fault state to each target */
    for (t = SP_CO402_READY; t <= SP_CO402_OPERATION_ENABLED; t = (sp_co402_state_t)(t + 2)) {
        for (s = SP_CO402_NOT_READY; s <= SP_CO402_QUICK_STOP_ACTIVE; s = (sp_co402_state_t)(s + 1)) {
            sp_co402_state_t d = s;
            uint16_t prev = 0u;
            int k;
            for (k = 0; k < 6 && d != t; k++) {
                uint16_t cw = sp_co402_control_word(d, t, 0, 0);
                d = sp_co402_next(d, cw, prev, 0);
                prev = cw;
            }
            assert_int_equal(d, t);
            assert_true(k <= 5);
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sdo_frames),
        cmocka_unit_test(test_sdo_answers),
        cmocka_unit_test(test_nmt_sync_heartbeat),
        cmocka_unit_test(test_pdo_emcy),
        cmocka_unit_test(test_cia408_states),
        cmocka_unit_test(test_cia402_states),
        cmocka_unit_test(test_cia402_state_lookup),
        cmocka_unit_test(test_plan),
        cmocka_unit_test(test_cfg_check),
        cmocka_unit_test(test_scaling),
        cmocka_unit_test(test_scaling_reference),
        cmocka_unit_test(test_force_permille),
        cmocka_unit_test(test_master_pdo_reference),
        cmocka_unit_test(test_master_input_checks),
        cmocka_unit_test(test_link),
        cmocka_unit_test(test_link_length_sensors),
        cmocka_unit_test(test_link_wrench_validity),
        cmocka_unit_test(test_link_input_due),
        cmocka_unit_test(test_link_ctrl_config),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
