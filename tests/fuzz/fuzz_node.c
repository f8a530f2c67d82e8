/*
 * libFuzzer target: random bytes become a stream of CAN frames fed to the
 * controller node's receive path, with a control tick every few frames.
 * Whatever arrives, nothing may crash, read out of bounds or overflow
 * (ASan + UBSan), and the controller must never leave its limits: every
 * setpoint it emits lies within the leg stroke.
 * Build and run: scripts/fuzz.sh [SECONDS]
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "sp/node.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

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
