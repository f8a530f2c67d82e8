/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/inject.h - the fault injector on the bus (docs/explanation/faults.md): frames
 * dropped, delayed, duplicated, reordered or corrupted per bus and per
 * message, at a rate or for the next N matching frames, and buses switched
 * off. hs_sim passes every frame it sends (direction HS_INJ_TO_CONTROLLER)
 * and every frame it receives from the controller (HS_INJ_TO_PLANT)
 * through hs_inject_filter; what comes out is what the other side gets.
 *
 * SYNC on the axis buses is never touched: in lockstep it is the plant's
 * clock for the controller (in the real machine the controller's own
 * timer), not a message between nodes that can be lost.
 *
 * Deterministic: the rate decisions and corrupted bits come from a seeded
 * generator (hs/sensor.h), one draw per candidate frame. No heap, no
 * globals; a plain struct.
 *
 * Accounting: every frame given to the filter is passed on, dropped,
 * dropped by a bus-off, or pending (held for a delay or a reorder, passed
 * on later); a duplicate adds one frame passed on:
 *   in + duplicated = out + dropped + busoff + pending.
 */
#ifndef HS_INJECT_H
#define HS_INJECT_H

#include <stdint.h>

#include "hs/sensor.h"
#include "hs/status.h"
#include "sp/link/can.h"

#define HS_INJ_RULES 16u /**< frame rules active at once */
#define HS_INJ_HELD 64u  /**< delayed frames held at once (more are dropped and counted) */
#define HS_INJ_ANY_BUS 0xFFu
#define HS_INJ_MAX_OUT 64u /**< frames one call may return: size the out array at least in n_in x 2 + HS_INJ_HELD */

typedef enum { HS_INJ_TO_CONTROLLER = 0, HS_INJ_TO_PLANT = 1 } hs_inj_dir_t;

typedef enum {
    HS_FRAME_DROP = 0,      /**< the frame is lost */
    HS_FRAME_DELAY = 1,     /**< delivered `delay` ticks later, before that tick's frames */
    HS_FRAME_DUPLICATE = 2, /**< delivered twice in a row */
    HS_FRAME_REORDER = 3,   /**< delivered after the next frame on its bus in its direction */
    HS_FRAME_CORRUPT = 4    /**< one payload bit flipped (the receiver's CRC check sees it) */
} hs_frame_fault_t;

/** One frame rule: which frames (bus, identifier range), what, how often. */
typedef struct {
    uint8_t bus;            /**< sp_bus_t, or HS_INJ_ANY_BUS */
    uint32_t id_lo, id_hi;  /**< identifiers id_lo..id_hi */
    hs_frame_fault_t fault; /**< what happens to a frame the rule fires on */
    double rate;            /**< probability per matching frame, 0..1 (0: only `count`) */
    uint32_t count;         /**< fires left (0 with rate > 0: no limit); the rule ends when it reaches 0 */
    uint32_t delay;         /**< HS_FRAME_DELAY: ticks, >= 1 */
} hs_frame_rule_t;

typedef struct {
    uint32_t in;         /**< frames given to the filter */
    uint32_t out;        /**< frames passed on */
    uint32_t dropped;    /**< dropped by a rule (or because the held queue was full) */
    uint32_t busoff;     /**< dropped by a bus-off */
    uint32_t delayed;    /**< held for a delay */
    uint32_t duplicated; /**< extra copies passed on */
    uint32_t reordered;  /**< held until the next frame on their bus */
    uint32_t corrupted;  /**< passed on with a bit flipped */
    uint32_t pending;    /**< held now (delayed or waiting to be reordered) */
} hs_inject_stats_t;

typedef struct {
    hs_frame_rule_t rule[HS_INJ_RULES];
    uint8_t active[HS_INJ_RULES];
    struct {
        sp_can_frame_t frame;
        uint64_t due;
        uint8_t dir;
    } held[HS_INJ_HELD];
    uint32_t n_held;
    sp_can_frame_t waiting[2][SP_CAN_BUSES]; /**< reordered frames, per direction and bus */
    uint8_t waiting_valid[2][SP_CAN_BUSES];
    uint64_t busoff_until[SP_CAN_BUSES]; /**< bus off while tick < this (UINT64_MAX: until cleared) */
    hs_rng_t rng;
    hs_inject_stats_t stats;
} hs_inject_t;

/** No rules, no bus off, nothing held; the generator seeded. HS_E_ARG on NULL. */
hs_status_t hs_inject_init(hs_inject_t *inj, uint64_t seed);

/** Adds a rule. HS_E_ARG for NULL, id_lo > id_hi, a rate outside 0..1, a
 *  rule that can never fire (rate 0 and count 0), a delay of 0 ticks for
 *  HS_FRAME_DELAY or an unknown fault; HS_E_RANGE when HS_INJ_RULES are active. */
hs_status_t hs_inject_add(hs_inject_t *inj, const hs_frame_rule_t *rule);

/** Removes every frame rule (frames held stay held and are delivered). */
void hs_inject_clear_rules(hs_inject_t *inj);

/** Bus `bus` off from now until tick `until` (exclusive; UINT64_MAX: until
 *  cleared; 0 clears it). HS_E_ARG for a bad bus. */
hs_status_t hs_inject_busoff(hs_inject_t *inj, uint8_t bus, uint64_t until);

/**
 * Passes frames in[0..n_in) sent in direction `dir` at `tick` through the
 * rules into out[0..*n_out) (at most max_out; frames beyond it are dropped
 * and counted). Held frames due at `tick` come first, then the frames in
 * order with the rules applied (the first active rule that matches a frame
 * decides). HS_E_ARG on NULL arguments or a bad direction.
 */
hs_status_t hs_inject_filter(hs_inject_t *inj, hs_inj_dir_t dir, uint64_t tick, const sp_can_frame_t *in, uint32_t n_in,
                             sp_can_frame_t *out, uint32_t max_out, uint32_t *n_out);

#endif /* HS_INJECT_H */
