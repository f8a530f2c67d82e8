/* SPDX-License-Identifier: Apache-2.0 */
/*
 * force.c - force control modes over the position reference (sp/force/force.h).
 */
#include "sp/force/force.h"

#include "math/fixed_inline.h"

#include <stddef.h>

sp_status_t sp_force_default_config(sp_force_config_t *cfg, sp_q30_t filter_alpha, uint32_t tick_us)
{
    if (cfg == NULL) {
        return SP_E_ARG;
    }
    for (unsigned k = 0; k < SP_AXES; ++k) {
        int lin = k < 3u;
        sp_admit_axis_t *ax = &cfg->admit.axis[k];
        ax->mass = (lin ? 20 : 5) * SP_Q16_ONE;
        ax->damping = lin ? 1000000 : 100000;
        ax->stiffness = 0;
        ax->release_stiffness = lin ? 20000 : 5000;
        ax->v_max = SP_Q24_MILLI(100);
        ax->a_brake = 2 * SP_Q24_ONE;
        cfg->guide_damping[k] = lin ? 2500 : 500;
        cfg->deflection[k] = SP_Q24_MILLI(50);
    }
    cfg->admit.crossover = 30 * SP_Q16_ONE;
    cfg->admit.k_min = 10000;
    cfg->admit.k_max = 100000000;
    cfg->admit.secant_force = 30 * SP_Q8_ONE;
    cfg->admit.secant_travel = SP_Q24_ONE / 100000; /* 10 um */
    cfg->admit.filter_alpha = filter_alpha;
    cfg->admit.tick_us = tick_us;
    cfg->admit.secant_margin = 0;
    cfg->admit.boost = 0u;
    cfg->admit.boost_band = 0;
    cfg->contact.made = 100 * SP_Q8_ONE;
    cfg->contact.lost_ratio = SP_Q30_ONE / 2;
    cfg->contact.lost_ticks = 2u;
    cfg->contact.arm_ticks = 100u;
    cfg->contact.excess = 10000 * SP_Q8_ONE;
    cfg->contact.made_slow = 0;
    cfg->contact.slow_shift = 0u;
    cfg->target_max_force = 8000 * SP_Q8_ONE;
    cfg->target_max_moment = 1000 * SP_Q8_ONE;
    cfg->settled = SP_Q24_ONE / 1000000; /* 1 um */
    cfg->contact_ff = 0u;
    return SP_OK;
}

sp_status_t sp_force_reset(sp_force_t *f)
{
    if (f == NULL) {
        return SP_E_ARG;
    }
    (void)sp_admit_restart(&f->st, f->free_force);
    f->mode = SP_FORCE_OFF;
    f->mask = 0u;
    f->retract_fault = 0u;
    for (unsigned k = 0; k < SP_AXES; ++k) {
        f->target[k] = 0;
    }
    sp_contact_target(f->target, &f->push);
    f->contact.made = 0u;
    f->contact.armed = 0u;
    f->contact.low = 0u;
    f->contact.high = 0u;
    f->contact.slow = 0;
    return SP_OK;
}

sp_status_t sp_force_init(const sp_force_config_t *cfg, sp_force_t *f)
{
    if (cfg == NULL || f == NULL) {
        return SP_E_ARG;
    }
    for (unsigned k = 0; k < SP_AXES; ++k) {
        if (cfg->guide_damping[k] < 1 || cfg->deflection[k] <= 0) {
            return SP_E_ARG;
        }
    }
    /* on failure f is left unusable: init again with a good config */
    sp_status_t s = sp_admit_configure(&cfg->admit, &f->st);
    for (unsigned k = 0; k < SP_AXES && s == SP_OK; ++k) {
        f->free_force[k] = f->st.axis[k].free_coef;
        s = sp_admit_coefficients(&cfg->admit, &f->st, k, cfg->guide_damping[k], &f->free_guide[k]);
    }
    if (s != SP_OK) {
        return s;
    }
    return sp_force_reset(f);
}

/* |force part| <= max force (64-bit: no overflow), |moments| <= max moment. */
static int target_ok(const sp_force_config_t *cfg, const sp_q8_t t[SP_AXES])
{
    int64_t f2 = 0;
    for (unsigned k = 0; k < 3u; ++k) {
        f2 += (int64_t)t[k] * t[k] / 4; /* /4: three squares of up to 2^62 fit */
        if (t[3u + k] > cfg->target_max_moment || t[3u + k] < -cfg->target_max_moment) {
            return 0;
        }
    }
    int64_t m = cfg->target_max_force;
    return f2 <= m * m / 4;
}

sp_status_t sp_force_start(const sp_force_config_t *cfg, sp_force_t *f, sp_force_mode_t mode, uint8_t mask,
                           const sp_q8_t target[SP_AXES])
{
    if (cfg == NULL || f == NULL || (mask & 0x3Fu) == 0u || (mode != SP_FORCE_FORCE && mode != SP_FORCE_GUIDE) ||
        (mode == SP_FORCE_FORCE && target == NULL)) {
        return SP_E_ARG;
    }
    if (f->mode == SP_FORCE_RELEASE || f->mode == SP_FORCE_HOLD) {
        return SP_E_BUSY;
    }
    if (f->mode != SP_FORCE_OFF && (f->mode != mode || mode == SP_FORCE_GUIDE || mask != f->mask)) {
        return SP_E_ARG; /* leave first */
    }
    if (mode == SP_FORCE_FORCE && !target_ok(cfg, target)) {
        return SP_E_RANGE;
    }
    if (f->mode == SP_FORCE_OFF) {
        /* afresh, with the coefficients prepared at init */
        (void)sp_force_reset(f);
        if (mode == SP_FORCE_GUIDE) {
            (void)sp_admit_restart(&f->st, f->free_guide);
        }
    }
    if (f->mode == SP_FORCE_FORCE) {
        /* a new target: the lost level is its share, armed again once held */
        f->contact.armed = 0u;
        f->contact.high = 0u;
    }
    f->mode = mode;
    f->mask = (uint8_t)(mask & 0x3Fu);
    for (unsigned k = 0; k < SP_AXES; ++k) {
        f->target[k] = (mode == SP_FORCE_FORCE) ? target[k] : 0;
    }
    sp_contact_target(f->target, &f->push);
    return SP_OK;
}

sp_status_t sp_force_set_params(sp_force_config_t *cfg, sp_force_t *f, sp_force_mode_t mode, uint8_t mask,
                                sp_q16_t mass, int32_t damping, int32_t stiffness)
{
    if (cfg == NULL || f == NULL || mask == 0u || mask > 0x3Fu || (mode != SP_FORCE_FORCE && mode != SP_FORCE_GUIDE) ||
        mass < SP_Q16_ONE || damping < 1 || stiffness < 0) {
        return SP_E_ARG;
    }
    if (f->mode != SP_FORCE_OFF) {
        return SP_E_BUSY;
    }
    sp_force_config_t next = *cfg;
    for (unsigned k = 0; k < SP_AXES; ++k) {
        if ((mask & (1u << k)) == 0u) {
            continue;
        }
        next.admit.axis[k].mass = mass;
        next.admit.axis[k].stiffness = stiffness;
        if (mode == SP_FORCE_FORCE) {
            next.admit.axis[k].damping = damping;
        } else {
            next.guide_damping[k] = damping;
        }
    }
    sp_status_t s = sp_force_init(&next, f);
    if (s != SP_OK) {
        (void)sp_force_init(cfg, f); /* as before: it was initialised with cfg */
        return s;
    }
    *cfg = next;
    return SP_OK;
}

sp_status_t sp_force_release(sp_force_t *f)
{
    if (f == NULL) {
        return SP_E_ARG;
    }
    if (f->mode == SP_FORCE_FORCE || f->mode == SP_FORCE_GUIDE) {
        f->mode = SP_FORCE_RELEASE;
    }
    return SP_OK;
}

static sp_q24_t add_sat(sp_q24_t a, sp_q24_t b)
{
    sp_flags_t flags = 0u; /* saturation is the documented result */
    return spi_add(a, b, &flags);
}

/* The bounds of d on the axes in `moving`: the deflection limit and the
 * workspace box around the position reference, each less the margin
 * SP_FORCE_BOUND_MARGIN (0 when the reference is outside them). An axis outside `moving` (at rest on the position reference
 * and not forced: sp_admit_step leaves it there without reading its
 * bounds) gets [0, 0], which would hold it there as well. */
static void bounds(const sp_force_config_t *cfg, const sp_limits_t *lim, const sp_pose_t *p, uint8_t moving,
                   sp_q24_t lo[SP_AXES], sp_q24_t hi[SP_AXES])
{
    for (unsigned k = 0; k < SP_AXES; ++k) {
        lo[k] = 0;
        hi[k] = 0;
        if ((moving & (1u << k)) == 0u) {
            continue;
        }
        int64_t x = (k < 3u) ? p->pos[k] : p->rpy[k - 3u];
        int64_t l = (int64_t)lim->ws_lo[k] - x;
        int64_t h = (int64_t)lim->ws_hi[k] - x;
        int64_t defl = cfg->deflection[k];
        l = ((l < -defl) ? -defl : l) + SP_FORCE_BOUND_MARGIN;
        h = ((h > defl) ? defl : h) - SP_FORCE_BOUND_MARGIN;
        lo[k] = (sp_q24_t)((l > 0) ? 0 : l);
        hi[k] = (sp_q24_t)((h < 0) ? 0 : h);
    }
}

/* out (a copy of pos_ref): the position reference plus the admittance's
 * offsets on the axes that have one (adding zero would leave a field as it
 * is). */
SPI_INLINE void add_offsets(const sp_admit_t *st, const sp_motion_t *pos_ref, sp_motion_t *out)
{
    for (unsigned k = 0; k < 3u; ++k) {
        const sp_admit_axis_state_t *a = &st->axis[k];
        const sp_admit_axis_state_t *r = &st->axis[3u + k];
        if (a->d != 0 || a->v != 0 || a->a != 0) {
            out->pose.pos[k] = add_sat(pos_ref->pose.pos[k], a->d);
            out->vel[k] = add_sat(pos_ref->vel[k], a->v);
            out->acc[k] = add_sat(pos_ref->acc[k], a->a);
        }
        if (r->d != 0 || r->v != 0 || r->a != 0) {
            out->pose.rpy[k] = add_sat(pos_ref->pose.rpy[k], r->d);
            out->rpy_rate[k] = add_sat(pos_ref->rpy_rate[k], r->v);
            out->rpy_acc[k] = add_sat(pos_ref->rpy_acc[k], r->a);
        }
    }
}

sp_status_t sp_force_step(const sp_force_config_t *cfg, sp_force_t *f, const sp_limits_t *lim,
                          const sp_motion_t *pos_ref, const sp_q8_t w_ext[SP_AXES], const sp_pose_t *x_meas,
                          sp_motion_t *out, uint32_t *events)
{
    if (cfg == NULL || f == NULL || lim == NULL || pos_ref == NULL || out == NULL || events == NULL) {
        return SP_E_ARG;
    }
    *events = 0u;
    *out = *pos_ref; /* force control adds the offsets of the axes that have one */
    if (f->mode == SP_FORCE_OFF) {
        return SP_OK;
    }
    static const sp_q8_t zero[SP_AXES] = {0, 0, 0, 0, 0, 0};
    if (w_ext != NULL && (f->mode == SP_FORCE_FORCE || f->mode == SP_FORCE_GUIDE)) {
        *events = sp_contact_step_to(&cfg->contact, &f->contact, w_ext, &f->push);
        if ((*events & SP_CONTACT_EXCESS) != 0u) {
            f->mode = SP_FORCE_RELEASE;
            f->retract_fault = 1u;
        } else if ((*events & SP_CONTACT_LOST) != 0u) {
            f->mode = SP_FORCE_HOLD;
        }
    }
    sp_admit_mode_t am = SP_ADMIT_FORCE;
    if (f->mode == SP_FORCE_RELEASE) {
        am = SP_ADMIT_RELEASE;
    } else if (f->mode == SP_FORCE_HOLD || w_ext == NULL) {
        am = SP_ADMIT_HOLD;
    }
    sp_q24_t lo[SP_AXES], hi[SP_AXES], x[SP_AXES];
    uint8_t moving = (am == SP_ADMIT_FORCE) ? f->mask : 0u;
    for (unsigned k = 0; k < SP_AXES; ++k) {
        const sp_admit_axis_state_t *a = &f->st.axis[k];
        if (a->d != 0 || a->v != 0) {
            moving = (uint8_t)(moving | (1u << k));
        }
    }
    bounds(cfg, lim, &pos_ref->pose, moving, lo, hi);
    if (x_meas != NULL && cfg->contact_ff) {
        /* the measured pose less the position reference: what d would be
         * with the platform on the reference (the boost's lead; the
         * secant's changes as with the pose itself while the reference
         * holds still) */
        sp_flags_t flags = 0u; /* saturation is the documented result */
        for (unsigned k = 0; k < 3u; ++k) {
            x[k] = spi_sub(x_meas->pos[k], pos_ref->pose.pos[k], &flags);
            x[3u + k] = spi_sub(x_meas->rpy[k], pos_ref->pose.rpy[k], &flags);
        }
    } else if (x_meas != NULL) {
        for (unsigned k = 0; k < 3u; ++k) {
            x[k] = x_meas->pos[k];
            x[3u + k] = x_meas->rpy[k];
        }
    }
    uint8_t contact = f->contact.made ? f->mask : 0u;
    sp_status_t st = sp_admit_step(&cfg->admit, &f->st, am, f->mask, (w_ext != NULL) ? w_ext : zero, f->target,
                                   (x_meas != NULL) ? x : NULL, contact, lo, hi, NULL);
    add_offsets(&f->st, pos_ref, out);
    if (f->mode == SP_FORCE_RELEASE) {
        int done = 1;
        for (unsigned k = 0; k < SP_AXES; ++k) {
            sp_q24_t d = f->st.axis[k].d;
            done &= (d <= cfg->settled && d >= -cfg->settled) ? 1 : 0;
        }
        if (done) {
            *events |= f->retract_fault ? SP_FORCE_RETRACTED : SP_FORCE_RELEASED;
            f->mode = SP_FORCE_OFF;
            f->retract_fault = 0u;
            f->mask = 0u;
            f->contact.made = 0u;
        }
    }
    return st;
}
