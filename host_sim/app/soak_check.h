/* SPDX-License-Identifier: Apache-2.0 */
/*
 * soak_check.h - the invariants hs_soak checks on every tick of its
 * randomised run (docs/explanation/testing.md, "The soak"), apart from the
 * run so that a test can feed them a violation (tests/plant/test_soak_check.c).
 *
 * One tick is described by a snapshot (soak_snap_t: the controller's
 * output and what it took this tick, the plant's truth, the frame
 * counters); soak_check says whether every invariant holds:
 *   workspace   the reference pose inside the workspace box while the
 *               drives follow it (drive mode ACTIVE);
 *   stroke      every leg setpoint inside the stroke less the margin while
 *               ACTIVE, and every true leg length inside the stroke within
 *               SP_LEG_LIMIT_TOLERANCE (5 mm: the end stops' cushions);
 *   force       every force feed-forward within the platform's force_max
 *               while ACTIVE, and every true cylinder force within the
 *               plant's bound (soak_limits_t.plant_force_max) while no
 *               fault is injected;
 *   transition  the state change of the tick is in the legal table
 *               (soak_transition_legal, derived from controller.c);
 *   frames      every frame sent is accounted for: taken or counted as
 *               refused by its receiver, or dropped, cut by a bus-off or
 *               held by the injector (in + duplicated = receivers' counts
 *               + dropped + busoff + pending, modulo 2^32);
 *   overflow    no value clipped on sending (sp_node_stats_t.saturated)
 *               and no REFERENCE or COMPUTE fault (what the tick makes of
 *               an overflow flag) while no fault is injected: an accepted
 *               command never leads to one;
 *   finite      the plant's state stays finite.
 */
#ifndef SOAK_CHECK_H
#define SOAK_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "sp/control/controller.h"

#define SOAK_INVARIANTS 7 /**< invariants checked per tick (workspace .. finite) */

typedef enum {
    SOAK_OK = 0,
    SOAK_V_WORKSPACE,
    SOAK_V_STROKE,
    SOAK_V_FORCE,
    SOAK_V_TRANSITION,
    SOAK_V_FRAMES,
    SOAK_V_OVERFLOW,
    SOAK_V_FINITE
} soak_violation_t;

/** What the invariants compare against. */
typedef struct {
    sp_limits_t lim;        /**< the controller's prepared limits (workspace, strokes less the margin, force_max) */
    double length_lo;       /**< the plant's stroke: shortest true leg, m (less the tolerance) */
    double length_hi;       /**< longest true leg, m (plus the tolerance) */
    double plant_force_max; /**< largest |true cylinder force| while no fault is injected, N */
} soak_limits_t;

/** One tick as the checker sees it. */
typedef struct {
    uint64_t tick;
    int prev_state;       /**< sp_state_t before the tick */
    int state;            /**< after it */
    int cmd;              /**< the command the controller took this tick (SP_CMD_*, 0 none) */
    int reset_pending;    /**< a RESET was waiting for the drives before the tick */
    int active;           /**< drive mode ACTIVE after the tick */
    uint32_t prev_faults; /**< latched faults before the tick */
    uint32_t faults;      /**< after it */
    int injected;         /**< a fault is injected, or was since the controller last left FAULT/ESTOP */
    sp_pose_t reference;  /**< the controller's reference pose */
    sp_setpoint_t sp[SP_LEGS];
    double length[SP_LEGS]; /**< the plant's true leg lengths, m */
    double force[SP_LEGS];  /**< the plant's true cylinder forces, N */
    int finite;             /**< 1: the plant's pose, lengths and forces are finite */
    uint32_t unaccounted;   /**< frames sent less frames accounted for, modulo 2^32 (0: all) */
    uint32_t saturated;     /**< values clipped on sending this tick */
} soak_snap_t;

/** 1 if the controller may go from `from` to `to` in one tick having taken
 *  command `cmd` (reset_pending: a RESET waiting for the drives), else 0.
 *  The table and its derivation: soak_check.c. */
int soak_transition_legal(int from, int to, int cmd, int reset_pending);

/** Checks every invariant on one tick. Returns the first violated (SOAK_OK:
 *  none) and writes what was wrong to why[0..n) (NUL-terminated; n may be 0). */
soak_violation_t soak_check(const soak_limits_t *lim, const soak_snap_t *s, char *why, size_t n);

/** The invariant's name ("workspace", "stroke", ...; "ok"). */
const char *soak_violation_name(soak_violation_t v);

#endif /* SOAK_CHECK_H */
