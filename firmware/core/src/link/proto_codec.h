/* SPDX-License-Identifier: Apache-2.0 */
/*
 * proto_codec.h - the steps every encoder and decoder of the protocol
 * shares: the body of the codec that tools/dev/gen_proto_c.py generates
 * from the DBC (stewart_proto.c in the build's generated folder), which is
 * the one file that includes it. Static, so that the compiler sees them
 * where the generated code calls them, as in one hand-written file.
 */
#ifndef SP_PROTO_CODEC_H
#define SP_PROTO_CODEC_H

#include "sp/link/protocol.h"
#include "stewart_can.h"

/* round(v * num / den) to nearest, ties away from zero; |v * num| < 2^62
 * (gen_can_c.py checks the ratios against it). */
static int64_t muldiv(int64_t v, int64_t num, int64_t den)
{
    int64_t p = v * num;
    return p >= 0 ? (p + den / 2) / den : -((-p + den / 2) / den);
}

/* v within [lo, hi]; *sat = 1 when it was not. */
static int64_t clamp(int64_t v, int64_t lo, int64_t hi, int *sat)
{
    if (v < lo) {
        *sat = 1;
        return lo;
    }
    if (v > hi) {
        *sat = 1;
        return hi;
    }
    return v;
}

static void clear(sp_can_frame_t *f)
{
    for (uint32_t i = 0; i < SP_CAN_MAX_DATA; i++) {
        f->data[i] = 0u;
    }
}

/* An encoder's end: the packed frame's header and CRC; SP_E_RANGE when a
 * value was saturated (the frame is complete all the same). */
static sp_status_t finish(sp_can_frame_t *f, uint32_t id, uint8_t bus, int packed, uint8_t len, int sat)
{
    if (packed != (int)len) {
        return SP_E_ARG;
    }
    f->id = id;
    f->bus = bus;
    f->len = len;
    f->flags = SP_CAN_FLAG_FD | SP_CAN_FLAG_BRS;
    if (sp_e2e_seal(f) != SP_OK) {
        return SP_E_ARG;
    }
    return sat ? SP_E_RANGE : SP_OK;
}

/* Identifier, length and CRC: the checks every decoder starts with. */
static sp_status_t precheck(const sp_can_frame_t *f, uint32_t id, uint8_t len, sp_proto_error_t *error)
{
    sp_proto_error_t e = SP_PROTO_OK;
    if (f == NULL || f->id != id) {
        e = SP_PROTO_UNKNOWN_ID;
    } else if (f->len != len) {
        e = SP_PROTO_BAD_LENGTH;
    } else if (sp_e2e_check_crc(f) != SP_OK) {
        e = SP_PROTO_BAD_CRC;
    }
    if (error != NULL) {
        *error = e;
    }
    return e == SP_PROTO_OK ? SP_OK : SP_E_FRAME;
}

static sp_status_t reject(sp_proto_error_t *error, sp_proto_error_t why)
{
    if (error != NULL) {
        *error = why;
    }
    return SP_E_FRAME;
}

#endif /* SP_PROTO_CODEC_H */
