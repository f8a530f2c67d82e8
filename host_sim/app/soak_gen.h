/* SPDX-License-Identifier: Apache-2.0 */
/*
 * soak_gen.h - the soak's random operator (hs_soak): each episode is a
 * short scenario text (hs/scenario.h) drawn from a seeded generator, chosen
 * by the controller's state: from READY a motion (RUN_TRIG, MOVE_TO,
 * STREAM), force control against a random surface, hand guiding with a
 * push, a load and an external wrench, commands the state or their
 * ranges refuse (forged, replayed and unsigned ones among them: `mark
 * soak:...` lines hs_soak carries out itself), an injected fault during a
 * motion (tools/stewart/faults.py's list and more), an ESTOP, a park and
 * re-engage, the operator's heartbeat paused during a motion; from the other states the way back to READY (RESET after a
 * fault, ENGAGE when parked), sometimes interrupted. Deterministic: the
 * same seed and states give the same texts.
 */
#ifndef SOAK_GEN_H
#define SOAK_GEN_H

#include <stddef.h>
#include <stdint.h>

#include "hs/sensor.h"

typedef struct {
    hs_rng_t rng;
    char text[16384]; /**< the episode's scenario (at most HS_SCENARIO_MAX_ACTIONS actions) */
    size_t len;
    uint64_t episodes;
    double load_kg;    /**< the random load the platform carries now, kg */
    double load_at[3]; /**< where, motion frame, m */
    int wide;          /**< 1: RUN_TRIG frequencies up to 3 Hz (beyond what the tick computes today) */
} soak_gen_t;

/** Seeds the generator; no load. */
void soak_gen_init(soak_gen_t *g, uint64_t seed);

/** The next episode for a controller in `state` (sp_state_t) with latched
 *  `faults` (SP_FAULT_*): a scenario text ending with `end`, valid until
 *  the next call. */
const char *soak_gen_episode(soak_gen_t *g, int state, uint32_t faults);

#endif /* SOAK_GEN_H */
