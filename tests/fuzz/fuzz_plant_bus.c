/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target: random bytes become a stream of CAN frames fed to the
 * plant's receive path (host_sim/src/bus/bus.c, hs_bus_receive), as the
 * simulated drives see the bus: any identifier, length (0..255, beyond the
 * 64-byte payload too), payload, flags and bus number. One header bit asks
 * the harness to seal the frame (a correct E2E CRC over whatever payload)
 * so that the fuzzer reaches the range checks, the alive counters and the
 * setpoint path, which a random CRC almost never passes. Every fourth frame
 * starts a cycle (hs_bus_cycle_frames, as the plant's SYNC master). The
 * plant is not stepped: that is the plant's own tests' business, and at
 * about 1,000 inputs/s it would leave the receive path little fuzzing.
 *
 * Whatever arrives, nothing may crash, read out of bounds or overflow
 * (ASan + UBSan), and the binding must keep its books: every frame
 * returns HS_OK (used) or HS_E_RANGE (rejected or ignored) and is counted
 * exactly once (accepted + rejected + ignored = frames), stale and lost
 * never exceed accepted, a cycle emits at most HS_BUS_MAX_TX frames, and
 * the drives' setpoints the binding wrote stay finite.
 * Build and run: scripts/fuzz.sh [SECONDS]
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "hs/bus.h"
#include "hs/params.h"
#include "hs/plant.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static hs_plant_t pristine;
static hs_plant_t plant;
static int ready;

static void check_stats(const hs_bus_t *bus, uint32_t frames)
{
    uint64_t sum = (uint64_t)bus->stats.accepted + bus->stats.ignored;
    for (uint32_t i = 0; i < SP_PROTO_ERRORS; i++) {
        sum += bus->stats.rejected[i];
    }
    if (sum != frames || bus->stats.stale > bus->stats.accepted || bus->stats.lost > bus->stats.accepted) {
        __builtin_trap();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static hs_bus_t bus;
    sp_can_frame_t out[HS_BUS_MAX_TX];
    if (!ready) {
        static hs_params_t par;
        if (hs_params_default(&par) != HS_OK || hs_plant_init(&pristine, &par, hs_config_default.park) != HS_OK) {
            __builtin_trap();
        }
        ready = 1;
    }
    memcpy(&plant, &pristine, sizeof plant);
    if (hs_bus_init(&bus) != HS_OK) {
        __builtin_trap();
    }
    size_t pos = 0;
    uint32_t frames = 0;
    uint32_t tick = 0;
    while (pos + 4u <= size) {
        sp_can_frame_t f;
        memset(&f, 0, sizeof f);
        /* header as fuzz_node's: id low, id high (3 bits) | seal (bit 5) | bus << 6, len, flags */
        f.id = (uint32_t)(data[pos] | ((data[pos + 1u] & 0x07u) << 8));
        f.bus = (uint8_t)(data[pos + 1u] >> 6);
        int seal = (data[pos + 1u] & 0x20u) != 0u;
        f.len = data[pos + 2u];
        f.flags = data[pos + 3u];
        pos += 4u;
        size_t take = f.len < SP_CAN_MAX_DATA ? f.len : SP_CAN_MAX_DATA;
        if (take > size - pos) {
            take = size - pos;
        }
        memcpy(f.data, data + pos, take);
        pos += take;
        if (seal) {
            (void)sp_e2e_seal(&f); /* SP_E_ARG for a length the CRC cannot cover: sent as it is */
        }
        hs_status_t st = hs_bus_receive(&bus, &plant, &f);
        if (st != HS_OK && st != HS_E_RANGE) {
            __builtin_trap();
        }
        frames++;
        check_stats(&bus, frames);
        if (st == HS_OK) {
            for (int leg = 0; leg < HS_LEGS; leg++) {
                const hs_drive_t *d = &plant.drive[leg];
                if (!isfinite(d->sp_length) || !isfinite(d->sp_velocity) || !isfinite(d->sp_force)) {
                    __builtin_trap();
                }
            }
        }
        if (frames % 4u == 0u) {
            uint32_t n = HS_BUS_MAX_TX + 1u;
            tick++;
            if (hs_bus_cycle_frames(&bus, &plant, tick, 1u, out, &n) != HS_OK || n > HS_BUS_MAX_TX) {
                __builtin_trap();
            }
        }
    }
    return 0;
}
