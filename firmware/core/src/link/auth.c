/* SPDX-License-Identifier: Apache-2.0 */
/*
 * auth.c - SipHash-2-4 and the freshness check of the operator's commands
 * (sp/link/auth.h, docs/explanation/security.md). Written from the algorithm's definition;
 * tests/unit/test_auth.c holds it to the reference's published values and
 * tests/python/test_auth.py to an implementation we did not write.
 */
#include "sp/link/auth.h"

#define ROTL64(x, b) (uint64_t)(((x) << (b)) | ((x) >> (64u - (b))))

static uint32_t load_le32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static uint64_t load_le64(const uint8_t *p)
{
    return (uint64_t)load_le32(p) | ((uint64_t)load_le32(p + 4) << 32);
}

/* One SipRound on the state (v0, v1, v2, v3): four scalars, so that the
 * compiler keeps them in registers (an array of them it keeps in memory). */
#define SIPROUND(v0, v1, v2, v3)                                                                                       \
    do {                                                                                                               \
        (v0) += (v1);                                                                                                  \
        (v1) = ROTL64((v1), 13u);                                                                                      \
        (v1) ^= (v0);                                                                                                  \
        (v0) = ROTL64((v0), 32u);                                                                                      \
        (v2) += (v3);                                                                                                  \
        (v3) = ROTL64((v3), 16u);                                                                                      \
        (v3) ^= (v2);                                                                                                  \
        (v0) += (v3);                                                                                                  \
        (v3) = ROTL64((v3), 21u);                                                                                      \
        (v3) ^= (v0);                                                                                                  \
        (v2) += (v1);                                                                                                  \
        (v1) = ROTL64((v1), 17u);                                                                                      \
        (v1) ^= (v2);                                                                                                  \
        (v2) = ROTL64((v2), 32u);                                                                                      \
    } while (0)

sp_status_t sp_siphash24(const sp_auth_key_t *key, const uint8_t *msg, uint32_t len, uint64_t *out)
{
    uint64_t v0;
    uint64_t v1;
    uint64_t v2;
    uint64_t v3;
    uint64_t k0;
    uint64_t k1;
    uint64_t m;
    uint32_t i;
    uint32_t words;
    if (key == NULL || out == NULL || (msg == NULL && len > 0u) || len > SP_AUTH_HEADER_BYTES + SP_AUTH_PAYLOAD_MAX) {
        return SP_E_ARG;
    }
    k0 = load_le64(&key->k[0]);
    k1 = load_le64(&key->k[8]);
    v0 = k0 ^ UINT64_C(0x736f6d6570736575);
    v1 = k1 ^ UINT64_C(0x646f72616e646f6d);
    v2 = k0 ^ UINT64_C(0x6c7967656e657261);
    v3 = k1 ^ UINT64_C(0x7465646279746573);
    words = len / 8u; /* at most 9 */
    for (i = 0u; i <= words; ++i) {
        if (i < words) {
            m = load_le64(&msg[8u * i]);
        } else { /* the last word: the tail bytes, the length's low byte on top */
            uint32_t j;
            m = (uint64_t)(len & 0xFFu) << 56;
            for (j = 0u; j < (len & 7u); ++j) {
                m |= (uint64_t)msg[8u * words + j] << (8u * j);
            }
        }
        v3 ^= m; /* c = 2 rounds per message word */
        SIPROUND(v0, v1, v2, v3);
        SIPROUND(v0, v1, v2, v3);
        v0 ^= m;
    }
    v2 ^= 0xFFu;
    for (i = 0u; i < 4u; ++i) { /* d = 4 finalisation rounds */
        SIPROUND(v0, v1, v2, v3);
    }
    *out = v0 ^ v1 ^ v2 ^ v3;
    return SP_OK;
}

static void put_le(uint8_t *p, uint32_t v, unsigned bytes)
{
    unsigned i;
    for (i = 0u; i < bytes; ++i) {
        p[i] = (uint8_t)(v >> (8u * i));
    }
}

sp_status_t sp_auth_tag(const sp_auth_key_t *key, uint32_t frame_id, uint32_t session, uint32_t counter,
                        const uint8_t *payload, uint32_t n, uint64_t *tag)
{
    uint8_t msg[SP_AUTH_HEADER_BYTES + SP_AUTH_PAYLOAD_MAX];
    uint32_t i;
    if (key == NULL || tag == NULL || frame_id > 0x7FFu || n > SP_AUTH_PAYLOAD_MAX || (payload == NULL && n > 0u)) {
        return SP_E_ARG;
    }
    put_le(&msg[0], frame_id, 2u);
    put_le(&msg[2], session, 4u);
    put_le(&msg[6], counter, 4u);
    for (i = 0u; i < n; ++i) {
        msg[SP_AUTH_HEADER_BYTES + i] = payload[i];
    }
    return sp_siphash24(key, msg, SP_AUTH_HEADER_BYTES + n, tag);
}

sp_status_t sp_auth_rx_start(sp_auth_rx_t *rx, uint32_t session)
{
    if (rx == NULL) {
        return SP_E_ARG;
    }
    rx->session = session;
    rx->last = 0u;
    rx->started = 1u;
    return SP_OK;
}

uint32_t sp_auth_counter(const sp_auth_rx_t *rx, uint16_t counter_low)
{
    uint64_t c;
    if (rx == NULL) {
        return 0u;
    }
    c = ((uint64_t)rx->last & ~UINT64_C(0xFFFF)) | counter_low;
    if (c <= rx->last) {
        c += 0x10000u;
    }
    return (c > UINT32_MAX) ? 0u : (uint32_t)c;
}

/* 1 when the low `bytes` bytes of `code` (little-endian) equal tag[0..bytes),
 * looking at every byte whatever the first difference. */
static int tag_equal(uint64_t code, const uint8_t *tag, uint32_t bytes)
{
    uint8_t diff = 0u;
    uint32_t i;
    for (i = 0u; i < bytes; ++i) {
        diff = (uint8_t)(diff | ((uint8_t)(code >> (8u * i)) ^ tag[i]));
    }
    return diff == 0u;
}

static void count(uint32_t *n)
{
    if (*n < UINT32_MAX) {
        ++*n;
    }
}

sp_auth_result_t sp_auth_check(sp_auth_rx_t *rx, const sp_auth_key_t *key, uint32_t frame_id, uint16_t counter_low,
                               const uint8_t *payload, uint32_t n, const uint8_t *tag, uint32_t tag_bytes)
{
    uint64_t code;
    uint32_t c;
    if (rx == NULL || key == NULL || tag == NULL || tag_bytes < SP_AUTH_TAG_MIN_BYTES ||
        tag_bytes > SP_AUTH_TAG_MAX_BYTES || n > SP_AUTH_PAYLOAD_MAX || (payload == NULL && n > 0u) ||
        frame_id > 0x7FFu) {
        return SP_AUTH_BAD_ARG;
    }
    if (!rx->started) {
        return SP_AUTH_NO_SESSION;
    }
    c = sp_auth_counter(rx, counter_low);
    if (c != 0u && sp_auth_tag(key, frame_id, rx->session, c, payload, n, &code) == SP_OK &&
        tag_equal(code, tag, tag_bytes)) {
        rx->last = c;
        count(&rx->accepted);
        return SP_AUTH_OK;
    }
    /* the same low bits one lap earlier: at or before the last accepted */
    if (c == 0u) { /* used up: the candidate within the last lap */
        c = (rx->last & ~UINT32_C(0xFFFF)) | counter_low;
    } else {
        c = (c > 0x10000u) ? c - 0x10000u : 0u;
    }
    if (c != 0u && c <= rx->last && sp_auth_tag(key, frame_id, rx->session, c, payload, n, &code) == SP_OK &&
        tag_equal(code, tag, tag_bytes)) {
        count(&rx->replayed);
        return SP_AUTH_REPLAYED;
    }
    count(&rx->bad_tag);
    return SP_AUTH_BAD_TAG;
}

const char *sp_auth_result_name(sp_auth_result_t r)
{
    switch (r) {
    case SP_AUTH_OK:
        return "ok";
    case SP_AUTH_BAD_TAG:
        return "bad-tag";
    case SP_AUTH_REPLAYED:
        return "replayed";
    case SP_AUTH_NO_SESSION:
        return "no-session";
    case SP_AUTH_BAD_ARG:
        return "bad-argument";
    default:
        return "unknown";
    }
}
