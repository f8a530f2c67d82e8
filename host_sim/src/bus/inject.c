/* SPDX-License-Identifier: Apache-2.0 */
/* inject.c - the fault injector on the bus (hs/inject.h). */
#include "hs/inject.h"

#include <string.h>

#include "sp/link/protocol.h"

hs_status_t hs_inject_init(hs_inject_t *inj, uint64_t seed)
{
    if (inj == NULL) {
        return HS_E_ARG;
    }
    memset(inj, 0, sizeof *inj);
    hs_rng_seed(&inj->rng, seed);
    return HS_OK;
}

hs_status_t hs_inject_add(hs_inject_t *inj, const hs_frame_rule_t *rule)
{
    if (inj == NULL || rule == NULL || rule->id_lo > rule->id_hi || !(rule->rate >= 0.0 && rule->rate <= 1.0) ||
        (rule->rate == 0.0 && rule->count == 0u) || (rule->fault == HS_FRAME_DELAY && rule->delay == 0u) ||
        rule->fault > HS_FRAME_CORRUPT) {
        return HS_E_ARG;
    }
    for (uint32_t k = 0; k < HS_INJ_RULES; k++) {
        if (!inj->active[k]) {
            inj->rule[k] = *rule;
            inj->active[k] = 1u;
            return HS_OK;
        }
    }
    return HS_E_RANGE;
}

void hs_inject_clear_rules(hs_inject_t *inj)
{
    if (inj != NULL) {
        memset(inj->active, 0, sizeof inj->active);
    }
}

hs_status_t hs_inject_busoff(hs_inject_t *inj, uint8_t bus, uint64_t until)
{
    if (inj == NULL || bus >= SP_CAN_BUSES) {
        return HS_E_ARG;
    }
    inj->busoff_until[bus] = until;
    return HS_OK;
}

/* A uniform number in [0, 1) from 53 random bits. */
static double uniform(hs_rng_t *r)
{
    return (double)(hs_rng_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

/* The rule that fires on f, or NULL. Uses up one fire of a counted rule. */
static const hs_frame_rule_t *fires(hs_inject_t *inj, const sp_can_frame_t *f)
{
    for (uint32_t k = 0; k < HS_INJ_RULES; k++) {
        hs_frame_rule_t *r = &inj->rule[k];
        if (!inj->active[k] || (r->bus != HS_INJ_ANY_BUS && r->bus != f->bus) || f->id < r->id_lo || f->id > r->id_hi) {
            continue;
        }
        int fire = (r->rate > 0.0) ? (uniform(&inj->rng) < r->rate) : 1;
        if (!fire) {
            return NULL; /* the first matching rule decides */
        }
        if (r->count > 0u) {
            r->count--;
            if (r->count == 0u) {
                inj->active[k] = 0u;
            }
        }
        return r;
    }
    return NULL;
}

typedef struct {
    sp_can_frame_t *out;
    uint32_t max, n;
} sink_t;

static void put(hs_inject_t *inj, sink_t *s, const sp_can_frame_t *f)
{
    if (s->n < s->max) {
        s->out[s->n++] = *f;
        inj->stats.out++;
    } else {
        inj->stats.dropped++;
    }
}

/* Passes f on, then a frame waiting to be reordered behind it on its bus. */
static void emit(hs_inject_t *inj, sink_t *s, hs_inj_dir_t dir, const sp_can_frame_t *f)
{
    put(inj, s, f);
    if (f->bus < SP_CAN_BUSES && inj->waiting_valid[dir][f->bus]) {
        inj->waiting_valid[dir][f->bus] = 0u;
        inj->stats.pending--;
        put(inj, s, &inj->waiting[dir][f->bus]);
    }
}

hs_status_t hs_inject_filter(hs_inject_t *inj, hs_inj_dir_t dir, uint64_t tick, const sp_can_frame_t *in, uint32_t n_in,
                             sp_can_frame_t *out, uint32_t max_out, uint32_t *n_out)
{
    if (inj == NULL || (in == NULL && n_in > 0u) || out == NULL || n_out == NULL ||
        (dir != HS_INJ_TO_CONTROLLER && dir != HS_INJ_TO_PLANT)) {
        return HS_E_ARG;
    }
    sink_t s = {out, max_out, 0u};
    /* held frames due now, in the order they were held */
    uint32_t keep = 0;
    for (uint32_t k = 0; k < inj->n_held; k++) {
        if (inj->held[k].dir == (uint8_t)dir && inj->held[k].due <= tick) {
            inj->stats.pending--;
            emit(inj, &s, dir, &inj->held[k].frame);
        } else {
            inj->held[keep++] = inj->held[k];
        }
    }
    inj->n_held = keep;
    for (uint32_t i = 0; i < n_in; i++) {
        sp_can_frame_t f = in[i];
        inj->stats.in++;
        if (f.id == SP_ID_SYNC && f.bus != SP_BUS_OPS) {
            emit(inj, &s, dir, &f); /* the lockstep clock */
            continue;
        }
        if (f.bus < SP_CAN_BUSES && tick < inj->busoff_until[f.bus]) {
            inj->stats.busoff++;
            continue;
        }
        const hs_frame_rule_t *r = fires(inj, &f);
        if (r == NULL) {
            emit(inj, &s, dir, &f);
            continue;
        }
        switch (r->fault) {
        case HS_FRAME_DROP:
            inj->stats.dropped++;
            break;
        case HS_FRAME_DUPLICATE:
            inj->stats.duplicated++;
            put(inj, &s, &f);
            emit(inj, &s, dir, &f);
            break;
        case HS_FRAME_CORRUPT:
            if (f.len > 0u) {
                uint64_t bit = hs_rng_next(&inj->rng) % (uint64_t)(8u * f.len);
                f.data[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
            }
            inj->stats.corrupted++;
            emit(inj, &s, dir, &f);
            break;
        case HS_FRAME_DELAY:
            if (inj->n_held < HS_INJ_HELD) {
                inj->held[inj->n_held].frame = f;
                inj->held[inj->n_held].due = tick + r->delay;
                inj->held[inj->n_held].dir = (uint8_t)dir;
                inj->n_held++;
                inj->stats.delayed++;
                inj->stats.pending++;
            } else {
                inj->stats.dropped++;
            }
            break;
        case HS_FRAME_REORDER:
        default:
            if (f.bus < SP_CAN_BUSES && !inj->waiting_valid[dir][f.bus]) {
                inj->waiting[dir][f.bus] = f;
                inj->waiting_valid[dir][f.bus] = 1u;
                inj->stats.reordered++;
                inj->stats.pending++;
            } else {
                emit(inj, &s, dir, &f);
            }
            break;
        }
    }
    *n_out = s.n;
    return HS_OK;
}
