/* SPDX-License-Identifier: Apache-2.0 */
/* E2E protection: CRC check values, sealing and checking frames, and the
 * counter state machine (every transition). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "sp/link/e2e.h"

static void test_crc_check_values(void **state)
{
    (void)state;
    const uint8_t s[] = "123456789";
    assert_int_equal(sp_crc8_j1850(s, 9), 0x4B);
    assert_int_equal(sp_crc16_ccitt(s, 9), 0x29B1);
    assert_int_equal(sp_crc8_j1850(NULL, 3), 0);
}

static sp_can_frame_t frame(uint32_t id, uint8_t len, uint8_t seed)
{
    sp_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.len = len;
    f.flags = SP_CAN_FLAG_FD | SP_CAN_FLAG_BRS;
    for (uint32_t i = 0; i < SP_CAN_MAX_DATA; i++) {
        f.data[i] = (i < len) ? (uint8_t)(seed * 31u + i * 7u) : 0u;
    }
    return f;
}

static void test_seal_and_check_every_length(void **state)
{
    (void)state;
    const uint8_t lens[] = {2, 8, 12, 16, 24, 32, 48, 64};
    for (size_t k = 0; k < sizeof lens; k++) {
        sp_can_frame_t f = frame(0x123, lens[k], (uint8_t)k);
        assert_int_equal(sp_e2e_seal(&f), SP_OK);
        assert_int_equal(sp_e2e_check_crc(&f), SP_OK);
        /* any single bit flip in the payload is detected */
        for (uint32_t bit = 0; bit < 8u * lens[k]; bit++) {
            sp_can_frame_t g = f;
            g.data[bit / 8u] = (uint8_t)(g.data[bit / 8u] ^ (1u << (bit % 8u)));
            assert_int_equal(sp_e2e_check_crc(&g), SP_E_FRAME);
        }
        /* the same bytes on another identifier fail (data ID) */
        sp_can_frame_t h = f;
        h.id = 0x124;
        assert_int_equal(sp_e2e_check_crc(&h), SP_E_FRAME);
    }
}

static void test_crc_size_follows_length(void **state)
{
    (void)state;
    sp_can_frame_t f = frame(0x31, 12, 1);
    assert_int_equal(sp_e2e_seal(&f), SP_OK);
    uint8_t before = f.data[10];
    f.data[10] = (uint8_t)(before ^ 0xFFu); /* byte 10 is payload for a CRC-8 frame */
    assert_int_equal(sp_e2e_check_crc(&f), SP_E_FRAME);
    sp_can_frame_t g = frame(0x20, 32, 2);
    assert_int_equal(sp_e2e_seal(&g), SP_OK);
    uint16_t crc = sp_e2e_crc(&g);
    assert_int_equal(g.data[30], crc & 0xFF);
    assert_int_equal(g.data[31], crc >> 8);
    sp_can_frame_t bad = frame(0x20, 1, 0);
    assert_int_equal(sp_e2e_seal(&bad), SP_E_ARG);
    assert_int_equal(sp_e2e_check_crc(&bad), SP_E_FRAME);
    assert_int_equal(sp_e2e_check_crc(NULL), SP_E_FRAME);
}

static void test_counter_state_machine(void **state)
{
    (void)state;
    sp_e2e_rx_t rx = {0, 0};
    assert_int_equal(sp_e2e_rx_check(&rx, 14), SP_E2E_INITIAL);
    assert_int_equal(sp_e2e_rx_check(&rx, 15), SP_E2E_OK);
    assert_int_equal(sp_e2e_rx_check(&rx, 0), SP_E2E_OK); /* wrap 15 -> 0 */
    assert_int_equal(sp_e2e_rx_check(&rx, 0), SP_E2E_REPEATED);
    assert_int_equal(sp_e2e_rx_check(&rx, 2), SP_E2E_OK_LOST); /* one lost */
    assert_int_equal(sp_e2e_rx_check(&rx, 5), SP_E2E_OK_LOST); /* two lost: delta 3 */
    assert_int_equal(sp_e2e_rx_check(&rx, 10), SP_E2E_WRONG_SEQ);
    assert_int_equal(sp_e2e_rx_check(&rx, 11), SP_E2E_INITIAL); /* resynchronised */
    assert_int_equal(sp_e2e_rx_check(&rx, 12), SP_E2E_OK);
    assert_int_equal(sp_e2e_rx_check(&rx, 0x1D), SP_E2E_OK); /* only 4 bits count */
    assert_true(sp_e2e_accepted(SP_E2E_OK) && sp_e2e_accepted(SP_E2E_OK_LOST) && sp_e2e_accepted(SP_E2E_INITIAL));
    assert_false(sp_e2e_accepted(SP_E2E_REPEATED) || sp_e2e_accepted(SP_E2E_WRONG_SEQ));
    assert_int_equal(sp_e2e_rx_check(NULL, 1), SP_E2E_WRONG_SEQ);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc_check_values),
        cmocka_unit_test(test_seal_and_check_every_length),
        cmocka_unit_test(test_crc_size_follows_length),
        cmocka_unit_test(test_counter_state_machine),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
