/* SPDX-License-Identifier: Apache-2.0 */
/*
 * EVA harness of the operator link's protection (firmware/core/src/link/
 * e2e.c, auth.c): every function of sp/link/e2e.h and sp/link/auth.h on a
 * frame, a receiver state, a key and a tag of arbitrary bytes, any payload
 * length up to the buffer's size (SP_AUTH_PAYLOAD_MAX) and beyond it, any
 * tag length. EVA reports any out-of-bounds access, signed overflow or
 * invalid shift it cannot rule out.
 */
#include "__fc_builtin.h"
#include "sp/link/auth.h"
#include "sp/link/e2e.h"

static void unknown(void *p, size_t n)
{
    Frama_C_make_unknown((char *)p, n);
}

int main(void)
{
    sp_can_frame_t frame;
    sp_e2e_rx_t e2e_rx;
    sp_auth_rx_t auth_rx;
    sp_auth_key_t key;
    uint8_t payload[SP_AUTH_PAYLOAD_MAX];
    uint8_t tag[SP_AUTH_TAG_MAX_BYTES];
    uint32_t n = Frama_C_unsigned_int_interval(0u, SP_AUTH_PAYLOAD_MAX + 8u);
    uint32_t tag_bytes = Frama_C_unsigned_int_interval(0u, 16u);
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

    sink = sp_siphash24(&key, payload, Frama_C_unsigned_int_interval(0u, SP_AUTH_PAYLOAD_MAX), &out);
    sink =
        sp_auth_tag(&key, Frama_C_unsigned_int_interval(0u, UINT32_MAX), Frama_C_unsigned_int_interval(0u, UINT32_MAX),
                    Frama_C_unsigned_int_interval(0u, UINT32_MAX), payload, n, &out);
    sink = sp_auth_rx_start(&auth_rx, Frama_C_unsigned_int_interval(0u, UINT32_MAX));
    sink = (int)sp_auth_counter(&auth_rx, Frama_C_unsigned_short_interval(0u, UINT16_MAX));
    unknown(&auth_rx, sizeof auth_rx);
    sink = sp_auth_check(&auth_rx, &key, Frama_C_unsigned_int_interval(0u, UINT32_MAX),
                         Frama_C_unsigned_short_interval(0u, UINT16_MAX), payload, n, tag,
                         (tag_bytes <= SP_AUTH_TAG_MAX_BYTES) ? tag_bytes : SP_AUTH_TAG_MAX_BYTES);
    sink = (sp_auth_result_name(sp_auth_check(&auth_rx, &key, 0u, 0u, payload, n, tag, tag_bytes)) != NULL);
    return 0;
}
