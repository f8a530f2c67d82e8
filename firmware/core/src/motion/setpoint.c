/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/motion/setpoint.h"

#include "model/model_internal.h"
#include "math/fixed_inline.h"

sp_status_t sp_friction_prepare(const sp_platform_t *platform, sp_friction_t *fr)
{
    unsigned i;
    if (platform == NULL || fr == NULL || platform->coulomb_velocity < 0) {
        return SP_E_ARG;
    }
    fr->velocity = platform->coulomb_velocity;
    for (i = 0u; i < SP_LEGS; ++i) {
        sp_flags_t flags = 0u;
        if (platform->viscous_friction[i] < 0 || platform->coulomb_friction[i] < 0) {
            return SP_E_ARG;
        }
        fr->viscous[i] = platform->viscous_friction[i];
        fr->coulomb[i] = platform->coulomb_friction[i];
        /* F_c / v_c: Q8 / Q24 -> Q8 (saturates for a tiny v_c: a step) */
        fr->ramp[i] = (fr->velocity > 0) ? sp_div(fr->coulomb[i], fr->velocity, 24u, &flags) : INT32_MAX;
    }
    return SP_OK;
}

SPI_INLINE sp_q8_t friction_of(const sp_friction_t *fr, unsigned leg, sp_q24_t rate)
{
    sp_flags_t flags = 0u;
    int64_t f = (int64_t)fr->viscous[leg] * rate; /* Q32 */
    if (rate >= fr->velocity && rate > 0) {
        f += (int64_t)fr->coulomb[leg] << 24;
    } else if (rate <= -fr->velocity && rate < 0) {
        f -= (int64_t)fr->coulomb[leg] << 24;
    } else {
        f += (int64_t)fr->ramp[leg] * rate; /* |rate| < v_c: below F_c */
    }
    return spi_narrow_floor(f + (INT64_C(1) << 23), 24u, &flags);
}

sp_q8_t sp_friction_force(const sp_friction_t *fr, unsigned leg, sp_q24_t rate)
{
    return friction_of(fr, leg, rate);
}

sp_status_t sp_setpoints_of(const sp_platform_t *platform, const sp_limits_t *lim, const sp_friction_t *fr,
                            const sp_motion_t *ref, unsigned ff, sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu,
                            sp_model_t *model)
{
    return sp_setpoints_held(platform, lim, fr, ref, ff, sp, lu, model, NULL, 0u, NULL);
}

/* The body rates of ref kept in orient by the frames (their Euler rates
 * equal ref's, their sines the IK's: an angle changed clears them), else
 * NULL. */
static const sp_q24_t *body_rates_kept(const sp_orient_keep_t *orient, const sp_motion_t *ref)
{
    const sp_q24_t *body = NULL;
    if ((orient != NULL) && (orient->rates_valid != 0u)) {
        unsigned k;
        body = orient->body;
        for (k = 0u; k < 3u; ++k) {
            if ((orient->rates_of[k] != ref->rpy_rate[k]) || (orient->rates_of[k + 3u] != ref->rpy_acc[k])) {
                body = NULL; /* of other rates */
            }
        }
    }
    return body;
}

sp_status_t sp_setpoints_held(const sp_platform_t *platform, const sp_limits_t *lim, const sp_friction_t *fr,
                              const sp_motion_t *ref, unsigned ff, sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu,
                              sp_model_t *model, sp_leg_hold_t *hold, unsigned refresh, sp_orient_keep_t *orient)
{
    sp_ik_t ik;
    sp_q24_t rate[SP_LEGS];
    sp_q8_t force[SP_LEGS];
    sp_status_t st;
    unsigned i;

    if (!sp_limits_in_workspace(lim, &ref->pose)) {
        return SP_E_RANGE;
    }
    st = sp_inverse_kinematics_kept(platform, &ref->pose, orient, &ik);
    if (st == SP_OK && orient != NULL && orient->near) {
        spi_jacobian_near(&ik, &model->jac); /* a platform whose Jacobian cannot saturate */
    } else if (st == SP_OK) {
        st = sp_jacobian(&ik, &model->jac);
    }
    if (st == SP_OK) {
        /* the forces and the leg rates (sp_leg_rates) in one pass */
        st = spi_inverse_dynamics_held_body(platform, ref, &ik, &model->jac, force, lu, rate, hold, refresh,
                                            body_rates_kept(orient, ref));
    }
    if (st != SP_OK) {
        return st;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        sp_q8_t fric = friction_of(fr, i, rate[i]);
        sp_flags_t flags = 0u;
        /* the model (like its Jacobian above) is written before the
         * limits are checked: a failed reference leaves it unusable (the
         * controller then marks the factorisation invalid) */
        model->rigid[i] = force[i];
        force[i] = spi_add(force[i], fric, &flags);
    }
    if (!sp_limits_setpoints_ok(lim, ik.length, rate, force)) {
        return SP_E_RANGE;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        sp[i].length = ik.length[i];
        sp[i].velocity = rate[i];
        sp_flags_t flags = 0u;
        sp_q8_t dyn = model->rigid[i];
        sp_q8_t fric = spi_sub(force[i], dyn, &flags); /* exact: force passed the limits */
        sp[i].force = ((ff & SP_FF_DYNAMICS) != 0u) ? (((ff & SP_FF_FRICTION) != 0u) ? force[i] : dyn)
                                                    : (((ff & SP_FF_FRICTION) != 0u) ? fric : 0);
        model->force[i] = force[i];
        model->ref.length[i] = ik.length[i];
        model->ref.sc[i] = ik.sc[i];
    }
    model->rot = ik.rot;
    return SP_OK;
}
