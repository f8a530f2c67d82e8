/* SPDX-License-Identifier: Apache-2.0 */
/*
 * soak_check.c - the soak's invariants (soak_check.h).
 *
 * The legal transitions, derived from firmware/core/src/control/controller.c
 * (every assignment to ctrl->state; one tick may chain two of them, listed
 * here as one): a fault may be raised in any state (raise_fault: FAULT,
 * ESTOP stays ESTOP), STOPPING only by the ESTOP command, ESTOP by the ESTOP
 * command or from STOPPING (the controlled stop ended, a fault or a second
 * ESTOP during it), and an ESTOP command always ends the tick in STOPPING
 * or ESTOP. The rest, by the state before the tick
 * (docs/explanation/testing.md has the table):
 *   IDLE      -> ENGAGING on ENGAGE
 *   ENGAGING  -> READY (the engage move ended), PARKING on PARK
 *   READY     -> RUNNING on RUN_TRIG, MOVE_TO or STREAM; PARKING (PARK, or
 *                a PARK given in force control once it has let go)
 *   RUNNING   -> READY (the motion ended: by itself, STOP, the operator
 *                link's stop), PARKING (ended after PARK)
 *   PARKING   -> IDLE (parked)
 *   FAULT     -> ENGAGING on RESET or while a RESET waits for the drives
 *   ESTOP     -> ENGAGING the same way; FAULT on such a tick (re-engaged,
 *                and a fault raised in the same tick)
 */
#include "soak_check.h"

#include <math.h>
#include <stdio.h>

#define BIT(s) (1u << (unsigned)(s))

/* The states each state may reach in one tick without a condition, besides itself. */
static const unsigned free_next[8] = {
    [SP_STATE_IDLE] = BIT(SP_STATE_FAULT),
    [SP_STATE_ENGAGING] = BIT(SP_STATE_READY) | BIT(SP_STATE_FAULT),
    [SP_STATE_READY] = BIT(SP_STATE_PARKING) | BIT(SP_STATE_FAULT),
    [SP_STATE_RUNNING] = BIT(SP_STATE_READY) | BIT(SP_STATE_PARKING) | BIT(SP_STATE_FAULT),
    [SP_STATE_PARKING] = BIT(SP_STATE_IDLE) | BIT(SP_STATE_FAULT),
    [SP_STATE_FAULT] = 0u,
    [SP_STATE_ESTOP] = 0u,
    [SP_STATE_STOPPING] = BIT(SP_STATE_ESTOP),
};

int soak_transition_legal(int from, int to, int cmd, int reset_pending)
{
    int resetting = (cmd == SP_CMD_RESET) || reset_pending;
    if (from < 0 || from > SP_STATE_STOPPING || to < 0 || to > SP_STATE_STOPPING) {
        return 0;
    }
    if (cmd == SP_CMD_ESTOP) {
        return to == SP_STATE_ESTOP || to == SP_STATE_STOPPING;
    }
    if (to == from) {
        return 1;
    }
    if (to == SP_STATE_STOPPING || (to == SP_STATE_ESTOP && from != SP_STATE_STOPPING)) {
        return 0; /* only by the ESTOP command, or the end of its controlled stop */
    }
    if ((free_next[from] & BIT(to)) != 0u) {
        return 1;
    }
    switch (from) {
    case SP_STATE_IDLE:
        return to == SP_STATE_ENGAGING && cmd == SP_CMD_ENGAGE;
    case SP_STATE_ENGAGING:
        return to == SP_STATE_PARKING && cmd == SP_CMD_PARK;
    case SP_STATE_READY:
        return to == SP_STATE_RUNNING && (cmd == SP_CMD_RUN_TRIG || cmd == SP_CMD_MOVE_TO || cmd == SP_CMD_STREAM);
    case SP_STATE_FAULT:
        return to == SP_STATE_ENGAGING && resetting;
    case SP_STATE_ESTOP:
        return (to == SP_STATE_ENGAGING || to == SP_STATE_FAULT) && resetting;
    default:
        return 0;
    }
}

const char *soak_violation_name(soak_violation_t v)
{
    static const char *const names[] = {"ok",         "workspace", "stroke",   "force",
                                        "transition", "frames",    "overflow", "finite"};
    return ((unsigned)v < sizeof names / sizeof names[0]) ? names[v] : "?";
}

static double q24(sp_q24_t v)
{
    return (double)v / 16777216.0;
}

static soak_violation_t check_commanded(const soak_limits_t *lim, const soak_snap_t *s, char *why, size_t n)
{
    if (!s->active) {
        return SOAK_OK;
    }
    if (!sp_limits_in_workspace(&lim->lim, &s->reference)) {
        snprintf(why, n, "reference %.4f %.4f %.4f m %.4f %.4f %.4f rad outside the workspace",
                 q24(s->reference.pos[0]), q24(s->reference.pos[1]), q24(s->reference.pos[2]), q24(s->reference.rpy[0]),
                 q24(s->reference.rpy[1]), q24(s->reference.rpy[2]));
        return SOAK_V_WORKSPACE;
    }
    for (unsigned i = 0; i < SP_LEGS; i++) {
        if (s->sp[i].length < lim->lim.length_min || s->sp[i].length > lim->lim.length_max) {
            snprintf(why, n, "leg %u setpoint %.4f m outside %.4f..%.4f m", i + 1u, q24(s->sp[i].length),
                     q24(lim->lim.length_min), q24(lim->lim.length_max));
            return SOAK_V_STROKE;
        }
        if (s->sp[i].force > lim->lim.force_max || s->sp[i].force < -lim->lim.force_max) {
            snprintf(why, n, "leg %u force feed-forward %.0f N beyond %.0f N", i + 1u, (double)s->sp[i].force / 256.0,
                     (double)lim->lim.force_max / 256.0);
            return SOAK_V_FORCE;
        }
    }
    return SOAK_OK;
}

static soak_violation_t check_plant(const soak_limits_t *lim, const soak_snap_t *s, char *why, size_t n)
{
    if (!s->finite) {
        snprintf(why, n, "the plant's state is not finite");
        return SOAK_V_FINITE;
    }
    for (unsigned i = 0; i < SP_LEGS; i++) {
        if (!(s->length[i] >= lim->length_lo && s->length[i] <= lim->length_hi)) {
            snprintf(why, n, "leg %u true length %.4f m outside %.4f..%.4f m", i + 1u, s->length[i], lim->length_lo,
                     lim->length_hi);
            return SOAK_V_STROKE;
        }
        if (!s->injected && !(fabs(s->force[i]) <= lim->plant_force_max)) {
            snprintf(why, n, "leg %u true force %.0f N beyond %.0f N with no fault injected", i + 1u, s->force[i],
                     lim->plant_force_max);
            return SOAK_V_FORCE;
        }
    }
    return SOAK_OK;
}

soak_violation_t soak_check(const soak_limits_t *lim, const soak_snap_t *s, char *why, size_t n)
{
    char none[1];
    soak_violation_t v;
    if (why == NULL || n == 0u) {
        why = none, n = sizeof none;
    }
    why[0] = '\0';
    if ((v = check_plant(lim, s, why, n)) != SOAK_OK || (v = check_commanded(lim, s, why, n)) != SOAK_OK) {
        return v;
    }
    if (!soak_transition_legal(s->prev_state, s->state, s->cmd, s->reset_pending)) {
        snprintf(why, n, "%s -> %s with command %d%s", sp_state_name((sp_state_t)s->prev_state),
                 sp_state_name((sp_state_t)s->state), s->cmd, s->reset_pending ? " (a reset waiting)" : "");
        return SOAK_V_TRANSITION;
    }
    if (s->unaccounted != 0u) {
        snprintf(why, n, "%d frames unaccounted for", (int32_t)s->unaccounted);
        return SOAK_V_FRAMES;
    }
    uint32_t fresh = s->faults & ~s->prev_faults & (SP_FAULT_REFERENCE | SP_FAULT_COMPUTE);
    if (s->saturated != 0u || (!s->injected && fresh != 0u)) {
        snprintf(why, n, "%s (faults 0x%04x, %u values clipped on sending)",
                 fresh ? "a reference or compute fault with no fault injected" : "a value clipped on sending",
                 (unsigned)s->faults, (unsigned)s->saturated);
        return SOAK_V_OVERFLOW;
    }
    return SOAK_OK;
}
