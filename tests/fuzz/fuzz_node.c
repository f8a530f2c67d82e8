/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target: random bytes become a stream of CAN frames fed to the
 * controller node's receive path, with a control tick every few frames.
 * Whatever arrives, nothing may crash, read out of bounds or overflow
 * (ASan + UBSan), and the controller must never leave its limits: every
 * setpoint it emits lies within the leg stroke. Each frame also goes
 * through the decoders of the frames the node does not consume itself
 * (AXIS_FEEDBACK as the plant sees it, CTRL_WRENCH as the operator does):
 * whatever one accepts must re-encode without saturation and decode to the
 * same values.
 * Build and run: scripts/fuzz.sh [SECONDS]
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "sp/link/node.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_decoders(const sp_can_frame_t *f)
{
    uint8_t counter = 0u;
    uint8_t slot = 0u;
    sp_proto_error_t e;
    sp_can_frame_t again;
    sp_msg_wrench_t w, w2;
    memset(&w, 0, sizeof w);
    memset(&w2, 0, sizeof w2);
    if (sp_proto_decode_wrench(f, &w, &counter, &e) == SP_OK) {
        if (sp_proto_encode_wrench(&w, counter, &again) != SP_OK ||
            sp_proto_decode_wrench(&again, &w2, &counter, &e) != SP_OK || memcmp(&w, &w2, sizeof w) != 0) {
            __builtin_trap();
        }
    }
    sp_msg_feedback_t fb, fb2;
    memset(&fb, 0, sizeof fb);
    memset(&fb2, 0, sizeof fb2);
    if (sp_proto_decode_feedback(f, &fb, &slot, &counter, &e) == SP_OK) {
        if (sp_proto_encode_feedback(&fb, slot, counter, f->bus, &again) != SP_OK ||
            sp_proto_decode_feedback(&again, &fb2, &slot, &counter, &e) != SP_OK || fb.pressure_a != fb2.pressure_a ||
            fb.pressure_b != fb2.pressure_b || fb.length != fb2.length || fb.state != fb2.state ||
            fb.faults != fb2.faults || fb.tick_echo != fb2.tick_echo) {
            __builtin_trap();
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static sp_node_config_t cfg;
    static sp_node_t node;
    sp_can_frame_t out[SP_NODE_MAX_TX];
    uint32_t n;
    if (sp_node_default_config(&cfg, &sp_platform_default) != SP_OK || sp_node_init(&node, &cfg) != SP_OK) {
        __builtin_trap();
    }
    size_t pos = 0;
    uint32_t frames = 0;
    while (pos + 4u <= size) {
        sp_can_frame_t f;
        memset(&f, 0, sizeof f);
        f.id = (uint32_t)(data[pos] | ((data[pos + 1u] & 0x07u) << 8));
        f.bus = (uint8_t)(data[pos + 1u] >> 6);
        f.len = data[pos + 2u];
        f.flags = data[pos + 3u];
        pos += 4u;
        size_t take = f.len < SP_CAN_MAX_DATA ? f.len : SP_CAN_MAX_DATA;
        if (take > size - pos) {
            take = size - pos;
        }
        memcpy(f.data, data + pos, take);
        pos += take;
        (void)sp_node_receive(&node, &f, NULL);
        check_decoders(&f);
        if (++frames % 4u == 0u) {
            if (sp_node_tick(&cfg, &node, out, &n) != SP_OK || n > SP_NODE_MAX_TX) {
                __builtin_trap();
            }
            for (uint32_t i = 0; i < SP_LEGS; i++) {
                const sp_setpoint_t *s = &node.out.setpoint[i];
                if (node.out.drive_mode == SP_DRIVE_ACTIVE && (s->length < sp_platform_default.leg_length_min ||
                                                               s->length > sp_platform_default.leg_length_max)) {
                    __builtin_trap();
                }
            }
        }
    }
    return 0;
}
