/* SPDX-License-Identifier: Apache-2.0 */
/*
 * EVA harness of the operator link's protection (firmware/core/src/link/
 * e2e.c, auth.c): every function of sp/link/e2e.h and sp/link/auth.h on a
 * frame, a receiver state, a key and a tag of arbitrary bytes, every
 * payload length up to the buffer's size (SP_AUTH_PAYLOAD_MAX) and 8 bytes
 * beyond it (refused), any tag length. EVA reports any out-of-bounds
 * access, read of an uninitialised byte, signed overflow or invalid shift
 * it cannot rule out.
 */
#include "__fc_builtin.h"
#include "sp/link/auth.h"
#include "sp/link/e2e.h"

/* Every byte of p[0..n) any value. */
static void unknown(void *p, size_t n)
{
    uint8_t *b = p;
    size_t i;
    /*@ loop unroll 128; */
    for (i = 0u; i < n; ++i) {
        b[i] = Frama_C_unsigned_char_interval(0u, 255u);
    }
}

static uint32_t any32(void)
{
    return Frama_C_unsigned_int_interval(0u, UINT32_MAX);
}

int main(void)
{
    sp_can_frame_t frame;
    sp_e2e_rx_t e2e_rx;
    sp_auth_rx_t auth_rx;
    sp_auth_key_t key;
    uint8_t payload[SP_AUTH_PAYLOAD_MAX];
    uint8_t tag[SP_AUTH_TAG_MAX_BYTES];
    uint32_t tag_bytes = Frama_C_unsigned_int_interval(0u, 16u);
    uint32_t n;
    uint64_t out;
    volatile int sink;

    unknown(&frame, sizeof frame);
    unknown(&e2e_rx, sizeof e2e_rx);
    unknown(&auth_rx, sizeof auth_rx);
    unknown(&key, sizeof key);
    unknown(payload, sizeof payload);
    unknown(tag, sizeof tag);

    sink = sp_crc8_j1850(payload, Frama_C_unsigned_int_interval(0u, SP_AUTH_PAYLOAD_MAX));
    sink = sp_crc16_ccitt(payload, Frama_C_unsigned_int_interval(0u, SP_AUTH_PAYLOAD_MAX));
    sink = sp_e2e_crc(&frame);
    sink = sp_e2e_check_crc(&frame);
    sink = sp_e2e_seal(&frame);
    sink = sp_e2e_accepted(sp_e2e_rx_check(&e2e_rx, Frama_C_unsigned_char_interval(0u, 255u)));
    sink = sp_auth_rx_start(&auth_rx, any32());
    sink = (int)sp_auth_counter(&auth_rx, Frama_C_unsigned_short_interval(0u, UINT16_MAX));

    /* each length on its own: the hash's tail loop depends on it */
    /*@ loop unroll SP_AUTH_PAYLOAD_MAX + 9; */
    for (n = 0u; n <= SP_AUTH_PAYLOAD_MAX + 8u; ++n) {
        sink = sp_siphash24(&key, payload, (n <= SP_AUTH_PAYLOAD_MAX) ? n : SP_AUTH_PAYLOAD_MAX, &out);
        sink = sp_auth_tag(&key, any32(), any32(), any32(), payload, n, &out);
        unknown(&auth_rx, sizeof auth_rx);
        sink = sp_auth_check(&auth_rx, &key, any32(), Frama_C_unsigned_short_interval(0u, UINT16_MAX), payload, n, tag,
                             tag_bytes);
        sink = (sp_auth_result_name(sp_auth_check(&auth_rx, &key, 0u, 0u, payload, n, tag, tag_bytes)) != NULL);
    }
    return 0;
}
