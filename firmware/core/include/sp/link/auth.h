/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/link/auth.h - authentication of the operator's commands (docs/explanation/security.md).
 *
 * A command that starts or changes motion carries a message authentication
 * code: SipHash-2-4 (Aumasson and Bernstein, 2012; a 64-bit PRF with a
 * 128-bit key, made for short messages) over
 *
 *     data ID (the 11-bit CAN identifier, 2 bytes LE) | session (4 bytes LE)
 *     | counter (4 bytes LE) | the frame's payload before its tag
 *
 * truncated to the frame's tag field (the low `tag_bytes` bytes of the
 * 64-bit result, little-endian). Freshness comes from two numbers:
 *
 *  - the session: a value the controller draws at start-up and publishes;
 *    frames recorded in an earlier session fail the code;
 *  - the counter: 32 bits per session, strictly increasing; the frame
 *    carries its low 16 bits and the receiver rebuilds the rest from the
 *    last counter it accepted, so a frame at or below it (a replay) fails.
 *
 * The key is the machine's, provisioned at build or flash time and never in
 * the repository. Only a frame whose code checks advances the counter, so
 * nothing a stranger sends changes what the controller accepts next.
 */
#ifndef SP_AUTH_H
#define SP_AUTH_H

#include <stdint.h>

#include "sp/math/status.h"

#define SP_AUTH_KEY_BYTES 16u
#define SP_AUTH_TAG_MIN_BYTES 4u /**< shortest truncation the receiver takes (32 bits) */
#define SP_AUTH_TAG_MAX_BYTES 8u /**< the whole SipHash-2-4 output */
#define SP_AUTH_PAYLOAD_MAX 64u  /**< payload bytes covered (a CAN FD frame) */
#define SP_AUTH_HEADER_BYTES 10u /**< data ID, session, counter */

/** The machine's key. */
typedef struct {
    uint8_t k[SP_AUTH_KEY_BYTES];
} sp_auth_key_t;

/** SipHash-2-4 of msg[0..len) under `key`, as the 64-bit value of the
 *  reference (its output bytes read little-endian). len <= SP_AUTH_HEADER_BYTES
 *  + SP_AUTH_PAYLOAD_MAX. Returns SP_E_ARG for NULL arguments or a longer
 *  message (and leaves *out unchanged). No overflow: the arithmetic is
 *  modulo 2^64 by definition of the function. */
sp_status_t sp_siphash24(const sp_auth_key_t *key, const uint8_t *msg, uint32_t len, uint64_t *out);

/** The code of one frame: SipHash-2-4 of data ID | session | counter |
 *  payload[0..n), n <= SP_AUTH_PAYLOAD_MAX. SP_E_ARG for NULL arguments, an
 *  identifier above 0x7FF or a longer payload. */
sp_status_t sp_auth_tag(const sp_auth_key_t *key, uint32_t frame_id, uint32_t session, uint32_t counter,
                        const uint8_t *payload, uint32_t n, uint64_t *tag);

/** What sp_auth_check made of a frame. */
typedef enum {
    SP_AUTH_OK = 0,         /**< the code checks and the counter is new: accepted */
    SP_AUTH_BAD_TAG = 1,    /**< the code does not check (forged, corrupted, another session or key) */
    SP_AUTH_REPLAYED = 2,   /**< the code checks but the counter is not after the last accepted */
    SP_AUTH_NO_SESSION = 3, /**< the receiver has no session yet */
    SP_AUTH_BAD_ARG = 4     /**< NULL pointers, a tag length outside 4..8 bytes, too long a payload */
} sp_auth_result_t;

/** A receiver: the session and the last accepted counter, and counts. */
typedef struct {
    uint32_t session;  /**< this session's value (sp_auth_rx_start) */
    uint32_t last;     /**< the last accepted counter (0: none yet; the first valid counter is 1) */
    uint8_t started;   /**< 1 once a session is set */
    uint32_t accepted; /**< frames accepted (saturating) */
    uint32_t bad_tag;  /**< frames rejected for their code (saturating) */
    uint32_t replayed; /**< frames rejected as replays (saturating) */
} sp_auth_rx_t;

/** Starts a session: every earlier counter and frame is void. Counts are
 *  kept. SP_E_ARG for NULL. */
sp_status_t sp_auth_rx_start(sp_auth_rx_t *rx, uint32_t session);

/** The full counter a frame's low 16 bits stand for: the first value after
 *  rx->last with those low bits (1 to 65,536 ahead). 0 when that value
 *  would pass UINT32_MAX: the session is used up and must be restarted
 *  (counter 0 never checks). */
uint32_t sp_auth_counter(const sp_auth_rx_t *rx, uint16_t counter_low);

/** Checks one frame: `payload[0..n)` is what the code covers (the frame's
 *  bytes before the tag, the counter's low 16 bits among them), `tag` the
 *  frame's tag field, `tag_bytes` long (4..8), little-endian. Accepts when
 *  the code of the rebuilt counter (sp_auth_counter) checks; that counter
 *  becomes the last. A frame whose code checks with the counter 65,536
 *  lower (at or before the last: a frame of this session sent again, up to
 *  65,535 counters old) is REPLAYED, any other failure (older replays
 *  included) BAD_TAG. Rejections change only the counts. Codes
 *  are compared in a time that does not depend on where they differ. */
sp_auth_result_t sp_auth_check(sp_auth_rx_t *rx, const sp_auth_key_t *key, uint32_t frame_id, uint16_t counter_low,
                               const uint8_t *payload, uint32_t n, const uint8_t *tag, uint32_t tag_bytes);

/** Name of a result ("ok", "bad-tag", "replayed", "no-session",
 *  "bad-argument"; "unknown" otherwise). */
const char *sp_auth_result_name(sp_auth_result_t r);

#endif
