/* SPDX-License-Identifier: Apache-2.0 */
/* rig.c - one cylinder moving a mass along its axis (hs/rig.h). */
#include "hs/rig.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "cyl_model.h"

static void rig_derivs(const hs_rig_t *rig, const double *x, double u, double *dx)
{
    hs_cyl_state_t st = {x[HS_RIG_CYL], x[HS_RIG_CYL + 1], x[HS_RIG_CYL + 2], x[HS_RIG_CYL + 3], x[HS_RIG_BRISTLE]};
    hs_cyl_eval_t ev;
    hs__cyl_eval(&rig->cyl, &st, x[HS_RIG_STROKE], x[HS_RIG_RATE], u, 1.0, &ev);
    dx[HS_RIG_STROKE] = x[HS_RIG_RATE];
    dx[HS_RIG_RATE] = (ev.force + rig->ext_force) / rig->mass - rig->gravity;
    dx[HS_RIG_CYL] = ev.dpa;
    dx[HS_RIG_CYL + 1] = ev.dpb;
    dx[HS_RIG_CYL + 2] = ev.dxv;
    dx[HS_RIG_CYL + 3] = ev.dxv_rate;
    dx[HS_RIG_BRISTLE] = ev.dz;
}

hs_status_t hs_rig_init(hs_rig_t *rig, const hs_cyl_params_t *cyl, double mass, double gravity, double stroke)
{
    if (rig == NULL || cyl == NULL || !(mass > 0.0) || !isfinite(mass) || !isfinite(gravity) || !(stroke >= 0.0) ||
        !(stroke <= cyl->stroke)) {
        return HS_E_ARG;
    }
    memset(rig, 0, sizeof *rig);
    rig->cyl = *cyl;
    rig->mass = mass;
    rig->gravity = gravity;
    rig->x[HS_RIG_STROKE] = stroke;
    hs_cyl_holding_pressures(cyl, mass * gravity, &rig->x[HS_RIG_CYL], &rig->x[HS_RIG_CYL + 1]);
    return HS_OK;
}

hs_status_t hs_rig_step(hs_rig_t *rig, double u, double h)
{
    double k1[HS_RIG_NX], k2[HS_RIG_NX], k3[HS_RIG_NX], k4[HS_RIG_NX], xt[HS_RIG_NX], x0[HS_RIG_NX];
    if (rig == NULL || !(h > 0.0) || !(h <= 0.01) || !isfinite(u)) {
        return HS_E_ARG;
    }
    memcpy(x0, rig->x, sizeof x0);
    rig_derivs(rig, rig->x, u, k1);
    for (int k = 0; k < HS_RIG_NX; ++k) {
        xt[k] = rig->x[k] + 0.5 * h * k1[k];
    }
    rig_derivs(rig, xt, u, k2);
    for (int k = 0; k < HS_RIG_NX; ++k) {
        xt[k] = rig->x[k] + 0.5 * h * k2[k];
    }
    rig_derivs(rig, xt, u, k3);
    for (int k = 0; k < HS_RIG_NX; ++k) {
        xt[k] = rig->x[k] + h * k3[k];
    }
    rig_derivs(rig, xt, u, k4);
    for (int k = 0; k < HS_RIG_NX; ++k) {
        rig->x[k] += h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]);
        if (!isfinite(rig->x[k])) {
            memcpy(rig->x, x0, sizeof x0);
            return HS_E_NUMERIC;
        }
    }
    for (int k = HS_RIG_CYL; k < HS_RIG_CYL + 2; ++k) {
        if (rig->x[k] < 0.0) {
            rig->x[k] = 0.0;
        } else if (rig->x[k] > rig->cyl.pressure_max) {
            rig->x[k] = rig->cyl.pressure_max;
        }
    }
    rig->time += h;
    return HS_OK;
}

void hs_rig_eval(const hs_rig_t *rig, double u, hs_cyl_eval_t *out)
{
    hs_cyl_state_t st = {rig->x[HS_RIG_CYL], rig->x[HS_RIG_CYL + 1], rig->x[HS_RIG_CYL + 2], rig->x[HS_RIG_CYL + 3],
                         rig->x[HS_RIG_BRISTLE]};
    hs__cyl_eval(&rig->cyl, &st, rig->x[HS_RIG_STROKE], rig->x[HS_RIG_RATE], u, 1.0, out);
}
