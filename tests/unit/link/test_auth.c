/* SPDX-License-Identifier: Apache-2.0 */
/* Command authentication (sp/link/auth.h): SipHash-2-4 against the values the
 * algorithm's authors publish, and the receiver's freshness check through
 * every outcome: accepted, forged, corrupted, replayed (now and a lap of
 * the 16-bit counter later), another session, a lost stretch of frames,
 * the counter's 16-bit laps, the session's end, bad arguments. The full
 * comparison with an implementation we did not write is in
 * tests/python/test_auth.py (on many random keys and messages). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "sp/link/auth.h"

static sp_auth_key_t ref_key(void)
{
    sp_auth_key_t k;
    for (unsigned i = 0; i < SP_AUTH_KEY_BYTES; i++) {
        k.k[i] = (uint8_t)i;
    }
    return k;
}

static void test_siphash_published_values(void **state)
{
    (void)state;
    sp_auth_key_t k = ref_key();
    uint8_t msg[64];
    for (unsigned i = 0; i < sizeof msg; i++) {
        msg[i] = (uint8_t)i;
    }
    uint64_t h = 0;
    /* the paper's appendix: key 00..0f, message 00..0e */
    assert_int_equal(sp_siphash24(&k, msg, 15, &h), SP_OK);
    assert_true(h == UINT64_C(0xa129ca6149be45e5));
    /* the reference's first test vector: the empty message */
    assert_int_equal(sp_siphash24(&k, msg, 0, &h), SP_OK);
    assert_true(h == UINT64_C(0x726fdb47dd0e0e31));
    assert_int_equal(sp_siphash24(&k, NULL, 0, &h), SP_OK);
    assert_true(h == UINT64_C(0x726fdb47dd0e0e31));
    /* positive control: one bit of message or key changes the value */
    assert_int_equal(sp_siphash24(&k, msg + 1, 15, &h), SP_OK);
    assert_true(h != UINT64_C(0xa129ca6149be45e5));
    k.k[15] ^= 0x80u;
    assert_int_equal(sp_siphash24(&k, msg, 15, &h), SP_OK);
    assert_true(h != UINT64_C(0xa129ca6149be45e5));
}

static void test_siphash_bad_arguments(void **state)
{
    (void)state;
    sp_auth_key_t k = ref_key();
    uint8_t msg[SP_AUTH_HEADER_BYTES + SP_AUTH_PAYLOAD_MAX + 1] = {0};
    uint64_t h = 42;
    assert_int_equal(sp_siphash24(NULL, msg, 1, &h), SP_E_ARG);
    assert_int_equal(sp_siphash24(&k, NULL, 1, &h), SP_E_ARG);
    assert_int_equal(sp_siphash24(&k, msg, 1, NULL), SP_E_ARG);
    assert_int_equal(sp_siphash24(&k, msg, sizeof msg, &h), SP_E_ARG);
    assert_true(h == 42);
    assert_int_equal(sp_siphash24(&k, msg, sizeof msg - 1, &h), SP_OK);
    assert_int_equal(sp_auth_tag(&k, 0x800, 0, 1, msg, 1, &h), SP_E_ARG);
    assert_int_equal(sp_auth_tag(&k, 0x40, 0, 1, msg, SP_AUTH_PAYLOAD_MAX + 1, &h), SP_E_ARG);
}

/* A sender of frame 0x040: payload of 10 bytes whose first two are the
 * counter's low 16 bits, then an 8-byte tag. */
typedef struct {
    uint8_t payload[10];
    uint8_t tag[8];
    uint16_t low;
} frame_t;

static frame_t sign(const sp_auth_key_t *k, uint32_t session, uint32_t counter, uint8_t command)
{
    frame_t f;
    memset(&f, 0, sizeof f);
    f.low = (uint16_t)counter;
    f.payload[0] = (uint8_t)counter;
    f.payload[1] = (uint8_t)(counter >> 8);
    f.payload[2] = command;
    uint64_t t = 0;
    assert_int_equal(sp_auth_tag(k, 0x040, session, counter, f.payload, sizeof f.payload, &t), SP_OK);
    for (unsigned i = 0; i < 8; i++) {
        f.tag[i] = (uint8_t)(t >> (8u * i));
    }
    return f;
}

static sp_auth_result_t check(sp_auth_rx_t *rx, const sp_auth_key_t *k, const frame_t *f, uint32_t tag_bytes)
{
    return sp_auth_check(rx, k, 0x040, f->low, f->payload, sizeof f->payload, f->tag, tag_bytes);
}

static void test_accept_forge_corrupt_replay(void **state)
{
    (void)state;
    sp_auth_key_t k = ref_key();
    sp_auth_rx_t rx;
    memset(&rx, 0, sizeof rx);
    frame_t f1 = sign(&k, 0x1234u, 1, 7);
    assert_int_equal(check(&rx, &k, &f1, 8), SP_AUTH_NO_SESSION);
    assert_int_equal(sp_auth_rx_start(&rx, 0x1234u), SP_OK);
    assert_int_equal(check(&rx, &k, &f1, 8), SP_AUTH_OK);
    assert_int_equal(rx.last, 1);
    /* the same frame again: a replay */
    assert_int_equal(check(&rx, &k, &f1, 8), SP_AUTH_REPLAYED);
    /* a stranger's frame: right counter, a guessed tag */
    frame_t forged = sign(&k, 0x1234u, 2, 9);
    memset(forged.tag, 0xA5, sizeof forged.tag);
    assert_int_equal(check(&rx, &k, &forged, 8), SP_AUTH_BAD_TAG);
    /* the right tag on a changed command (one bit) */
    frame_t f2 = sign(&k, 0x1234u, 2, 9);
    f2.payload[2] ^= 1u;
    assert_int_equal(check(&rx, &k, &f2, 8), SP_AUTH_BAD_TAG);
    f2.payload[2] ^= 1u;
    /* another key, another session */
    sp_auth_key_t other = k;
    other.k[3] ^= 1u;
    frame_t f2k = sign(&other, 0x1234u, 2, 9);
    assert_int_equal(check(&rx, &k, &f2k, 8), SP_AUTH_BAD_TAG);
    frame_t f2s = sign(&k, 0x1235u, 2, 9);
    assert_int_equal(check(&rx, &k, &f2s, 8), SP_AUTH_BAD_TAG);
    assert_int_equal(rx.last, 1); /* nothing rejected moved the counter */
    assert_int_equal(check(&rx, &k, &f2, 8), SP_AUTH_OK);
    assert_int_equal(rx.last, 2);
    /* an older frame of this session */
    assert_int_equal(check(&rx, &k, &f1, 8), SP_AUTH_REPLAYED);
    assert_int_equal(rx.accepted, 2);
    assert_int_equal(rx.replayed, 2);
    assert_int_equal(rx.bad_tag, 4);
    /* a new session voids every earlier frame */
    assert_int_equal(sp_auth_rx_start(&rx, 0x9999u), SP_OK);
    assert_int_equal(check(&rx, &k, &f2, 8), SP_AUTH_BAD_TAG);
    assert_int_equal(rx.last, 0);
}

static void test_truncated_tags(void **state)
{
    (void)state;
    sp_auth_key_t k = ref_key();
    sp_auth_rx_t rx;
    memset(&rx, 0, sizeof rx);
    (void)sp_auth_rx_start(&rx, 5u);
    frame_t f = sign(&k, 5u, 1, 1);
    assert_int_equal(check(&rx, &k, &f, 3), SP_AUTH_BAD_ARG);
    assert_int_equal(check(&rx, &k, &f, 9), SP_AUTH_BAD_ARG);
    f.tag[7] ^= 0xFFu; /* outside a 4-byte tag: not looked at */
    assert_int_equal(check(&rx, &k, &f, 4), SP_AUTH_OK);
    frame_t g = sign(&k, 5u, 2, 1);
    g.tag[3] ^= 0x01u; /* inside it */
    assert_int_equal(check(&rx, &k, &g, 4), SP_AUTH_BAD_TAG);
    g.tag[3] ^= 0x01u;
    g.tag[7] ^= 0x01u; /* the 8-byte tag sees its last byte */
    assert_int_equal(check(&rx, &k, &g, 8), SP_AUTH_BAD_TAG);
    assert_int_equal(sp_auth_check(NULL, &k, 0x40, 1, f.payload, 10, f.tag, 8), SP_AUTH_BAD_ARG);
    assert_int_equal(sp_auth_check(&rx, NULL, 0x40, 1, f.payload, 10, f.tag, 8), SP_AUTH_BAD_ARG);
    assert_int_equal(sp_auth_check(&rx, &k, 0x40, 1, f.payload, 10, NULL, 8), SP_AUTH_BAD_ARG);
    assert_int_equal(sp_auth_check(&rx, &k, 0x40, 1, NULL, 10, f.tag, 8), SP_AUTH_BAD_ARG);
    assert_int_equal(sp_auth_check(&rx, &k, 0x800, 1, f.payload, 10, f.tag, 8), SP_AUTH_BAD_ARG);
    assert_string_equal(sp_auth_result_name(SP_AUTH_REPLAYED), "replayed");
    assert_string_equal(sp_auth_result_name((sp_auth_result_t)99), "unknown");
}

static void test_counter_laps_and_lost_frames(void **state)
{
    (void)state;
    sp_auth_key_t k = ref_key();
    sp_auth_rx_t rx;
    memset(&rx, 0, sizeof rx);
    (void)sp_auth_rx_start(&rx, 77u);
    /* across the 16-bit boundaries, with 1 to 65,536 frames lost between */
    static const uint32_t seq[] = {1, 2, 0xFFFF, 0x10000, 0x10001, 0x1FFFF, 0x2FFFF, 0x3FFFF, 0x40000};
    for (unsigned i = 0; i < sizeof seq / sizeof seq[0]; i++) {
        frame_t f = sign(&k, 77u, seq[i], (uint8_t)i);
        assert_int_equal(sp_auth_counter(&rx, f.low), seq[i]);
        assert_int_equal(check(&rx, &k, &f, 8), SP_AUTH_OK);
        assert_int_equal(rx.last, seq[i]);
    }
    /* more than a lap ahead is taken for the value within the lap: rejected */
    frame_t far = sign(&k, 77u, 0x40000u + 0x10001u, 1);
    assert_int_equal(check(&rx, &k, &far, 8), SP_AUTH_BAD_TAG);
    /* a replay 65,535 counters old is still named a replay; 65,536 old it
     * is rejected as a bad tag */
    frame_t old = sign(&k, 77u, 0x30001u, 1);
    assert_int_equal(check(&rx, &k, &old, 8), SP_AUTH_REPLAYED);
    frame_t older = sign(&k, 77u, 0x30000u, 1);
    assert_int_equal(check(&rx, &k, &older, 8), SP_AUTH_BAD_TAG);
    assert_int_equal(rx.last, 0x40000u);
    /* the session's end: no counter past UINT32_MAX */
    rx.last = UINT32_MAX - 1u;
    frame_t end = sign(&k, 77u, UINT32_MAX, 1);
    assert_int_equal(check(&rx, &k, &end, 8), SP_AUTH_OK);
    assert_int_equal(sp_auth_counter(&rx, 0x0000u), 0u);
    frame_t again = sign(&k, 77u, UINT32_MAX, 1);
    assert_int_equal(check(&rx, &k, &again, 8), SP_AUTH_REPLAYED);
    frame_t zero = sign(&k, 77u, 0u, 1);
    assert_int_equal(check(&rx, &k, &zero, 8), SP_AUTH_BAD_TAG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_siphash_published_values),     cmocka_unit_test(test_siphash_bad_arguments),
        cmocka_unit_test(test_accept_forge_corrupt_replay),  cmocka_unit_test(test_truncated_tags),
        cmocka_unit_test(test_counter_laps_and_lost_frames),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
