/* SPDX-License-Identifier: Apache-2.0 */
/* The protocol's hand-written part: the rejection reasons' names and
 * command authentication. The encoders and decoders are generated from the
 * DBC (tools/dev/gen_proto_c.py, stewart_proto.c in the build). */
#include "sp/link/protocol.h"

#include "stewart_can.h"

const char *sp_proto_error_name(sp_proto_error_t e)
{
    switch (e) {
    case SP_PROTO_OK:
        return "ok";
    case SP_PROTO_UNKNOWN_ID:
        return "unknown-id";
    case SP_PROTO_BAD_LENGTH:
        return "bad-length";
    case SP_PROTO_BAD_CRC:
        return "bad-crc";
    case SP_PROTO_OUT_OF_RANGE:
        return "out-of-range";
    case SP_PROTO_REPEATED:
        return "repeated";
    case SP_PROTO_WRONG_SEQUENCE:
        return "wrong-sequence";
    case SP_PROTO_WRONG_BUS:
        return "wrong-bus";
    case SP_PROTO_AUTH_BAD_TAG:
        return "bad-tag";
    case SP_PROTO_AUTH_REPLAYED:
        return "replayed";
    case SP_PROTO_AUTH_NO_KEY:
        return "no-key";
    default:
        return "unknown";
    }
}

/* ---- command authentication (docs/explanation/security.md) ---- */
/* The authenticated messages, one row each: their fields' offsets are
 * generated from the DBC (gen_can_c.py). A message the table lacks is not
 * authenticated: sp_proto_frame_needs_auth, the signer and the node's check
 * all read this table. */
static const struct {
    uint32_t id;
    sp_proto_auth_layout_t lay;
} auth_messages[] = {
    {SP_ID_OP_COMMAND,
     {STEWART_CAN_OP_COMMAND_LENGTH, SP_CAN_OP_COMMAND_AUTH_COUNTER_BYTE, SP_CAN_OP_COMMAND_AUTH_TAG_BYTE,
      SP_CAN_OP_COMMAND_AUTH_TAG_BYTES}},
    {SP_ID_OP_TARGET_POSE,
     {STEWART_CAN_OP_TARGET_POSE_LENGTH, SP_CAN_OP_TARGET_POSE_AUTH_COUNTER_BYTE, SP_CAN_OP_TARGET_POSE_AUTH_TAG_BYTE,
      SP_CAN_OP_TARGET_POSE_AUTH_TAG_BYTES}},
    {SP_ID_OP_FORCE,
     {STEWART_CAN_OP_FORCE_LENGTH, SP_CAN_OP_FORCE_AUTH_COUNTER_BYTE, SP_CAN_OP_FORCE_AUTH_TAG_BYTE,
      SP_CAN_OP_FORCE_AUTH_TAG_BYTES}},
    {SP_ID_OP_FORCE_PARAMS,
     {STEWART_CAN_OP_FORCE_PARAMS_LENGTH, SP_CAN_OP_FORCE_PARAMS_AUTH_COUNTER_BYTE,
      SP_CAN_OP_FORCE_PARAMS_AUTH_TAG_BYTE, SP_CAN_OP_FORCE_PARAMS_AUTH_TAG_BYTES}},
    {SP_ID_OP_FRAME,
     {STEWART_CAN_OP_FRAME_LENGTH, SP_CAN_OP_FRAME_AUTH_COUNTER_BYTE, SP_CAN_OP_FRAME_AUTH_TAG_BYTE,
      SP_CAN_OP_FRAME_AUTH_TAG_BYTES}},
};

sp_status_t sp_proto_auth_layout(uint32_t id, sp_proto_auth_layout_t *lay)
{
    if (lay == NULL) {
        return SP_E_ARG;
    }
    for (uint32_t i = 0; i < (uint32_t)(sizeof auth_messages / sizeof auth_messages[0]); i++) {
        if (auth_messages[i].id == id) {
            *lay = auth_messages[i].lay;
            return SP_OK;
        }
    }
    return SP_E_ARG;
}

int sp_proto_frame_needs_auth(const sp_can_frame_t *f)
{
    sp_proto_auth_layout_t lay;
    if (f == NULL || sp_proto_auth_layout(f->id, &lay) != SP_OK) {
        return 0;
    }
    /* OP_COMMAND's Command is its first byte (the DBC: bits 0-7) */
    return f->id != SP_ID_OP_COMMAND || (f->len > 0u && sp_proto_command_needs_auth(f->data[0]));
}

int sp_proto_command_needs_auth(uint8_t command)
{
    return command != (uint8_t)SP_CMD_NONE && command != (uint8_t)SP_CMD_STOP && command != (uint8_t)SP_CMD_PARK &&
           command != (uint8_t)SP_CMD_ESTOP && command != SP_CMD_IDENTIFY;
}

sp_status_t sp_proto_sign(sp_can_frame_t *f, const sp_auth_key_t *key, uint32_t session, uint32_t counter)
{
    sp_proto_auth_layout_t lay;
    uint64_t code = 0u;
    if (f == NULL || key == NULL || counter == 0u || sp_proto_auth_layout(f->id, &lay) != SP_OK ||
        f->len != lay.length) {
        return SP_E_ARG;
    }
    f->data[lay.counter_byte] = (uint8_t)(counter & 0xFFu);
    f->data[lay.counter_byte + 1u] = (uint8_t)((counter >> 8) & 0xFFu);
    if (sp_auth_tag(key, f->id, session, counter, f->data, lay.tag_byte, &code) != SP_OK) {
        return SP_E_ARG;
    }
    for (uint32_t i = 0; i < lay.tag_bytes; i++) {
        f->data[lay.tag_byte + i] = (uint8_t)((code >> (8u * i)) & 0xFFu);
    }
    return sp_e2e_seal(f) == SP_OK ? SP_OK : SP_E_ARG;
}

sp_auth_result_t sp_proto_auth_check(sp_auth_rx_t *rx, const sp_auth_key_t *key, const sp_can_frame_t *f)
{
    sp_proto_auth_layout_t lay;
    if (rx == NULL || key == NULL || f == NULL || sp_proto_auth_layout(f->id, &lay) != SP_OK || f->len != lay.length) {
        return SP_AUTH_BAD_ARG;
    }
    uint16_t low = (uint16_t)((uint32_t)f->data[lay.counter_byte] | ((uint32_t)f->data[lay.counter_byte + 1u] << 8));
    return sp_auth_check(rx, key, f->id, low, f->data, lay.tag_byte, &f->data[lay.tag_byte], lay.tag_bytes);
}
