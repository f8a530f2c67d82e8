/* SPDX-License-Identifier: Apache-2.0 */
/*
 * cyl_model.h - private: the cylinder model's right-hand side as inline
 * functions, so that the plant's and the rig's inner loops can inline them
 * (hs_cyl_eval in cylinder.c is the public wrapper; hs/cylinder.h documents
 * the model).
 */
#ifndef HS_CYL_MODEL_H
#define HS_CYL_MODEL_H

#include <math.h>

#include "hs/cylinder.h"

static inline double hs__clamp(double v, double lo, double hi)
{
    return (v < lo) ? lo : ((v > hi) ? hi : v);
}

/* Smoothed sign for the Coulomb friction: y (3 - y^2) / 2 on |y| < 1 (value
 * and slope meet +-1 at the ends), +-1 beyond. No square root, no division. */
static inline double hs__smooth_sign(double y)
{
    if (y >= 1.0) {
        return 1.0;
    }
    if (y <= -1.0) {
        return -1.0;
    }
    return 0.5 * y * (3.0 - y * y);
}

/* Orifice law with a laminar transition at pt: sign(dp) sqrt|dp| for
 * |dp| >= pt; below, the odd cubic a dp + b dp^3 that meets the square root
 * with the same value and slope at +-pt (a = 1.25 / sqrt(pt),
 * b = -0.25 / pt^2.5). The finite slope at dp = 0 keeps the pressure
 * equations integrable with explicit steps. */
static inline double hs__orifice(double dp, double pt)
{
    double a = fabs(dp);
    if (a >= pt) {
        return (dp > 0.0) ? sqrt(a) : -sqrt(a);
    }
    {
        double r = dp / pt;
        return dp / sqrt(pt) * (1.25 - 0.25 * r * r);
    }
}

static inline double hs__volume_a(const hs_cyl_params_t *c, double stroke)
{
    double v = c->dead_volume_a + c->area_a * stroke;
    double vmin = 0.5 * c->dead_volume_a;
    return (v < vmin) ? vmin : v;
}

static inline double hs__volume_b(const hs_cyl_params_t *c, double stroke)
{
    double v = c->dead_volume_b + c->area_b * (c->stroke - stroke);
    double vmin = 0.5 * c->dead_volume_b;
    return (v < vmin) ? vmin : v;
}

/* End stops and cushions: force along the leg (positive pushes out). */
static inline double hs__stop_force(const hs_cyl_params_t *c, double s, double rate)
{
    double f = 0.0;
    double cl = c->cushion_length;
    double S = c->stroke;
    /* lower end: s = 0 */
    if (cl > 0.0 && s < cl && rate < 0.0) {
        double depth = hs__clamp(cl - s, 0.0, cl);
        f -= c->stop_damping * (depth / cl) * rate;
    }
    if (s < 0.0) {
        double fs = c->stop_stiffness * (-s) - c->stop_damping * rate;
        if (fs > 0.0) {
            f += fs;
        }
    }
    /* upper end: s = S */
    if (cl > 0.0 && s > S - cl && rate > 0.0) {
        double depth = hs__clamp(s - (S - cl), 0.0, cl);
        f -= c->stop_damping * (depth / cl) * rate;
    }
    if (s > S) {
        double fs = c->stop_stiffness * (s - S) + c->stop_damping * rate;
        if (fs > 0.0) {
            f -= fs;
        }
    }
    return f;
}

/* Friction force (opposes the stroke rate; hs/cylinder.h) and the bristle
 * deflection's rate dz. With sigma_0 = 0 the memoryless smoothed Coulomb
 * term of before, with the Stribeck excess when F_s > F_c (exactly the old
 * expression when F_s = F_c); with sigma_0 > 0 the LuGre model. */
static inline double hs__friction(const hs_cyl_params_t *c, double z, double rate, double *dz)
{
    double fc = c->coulomb_friction;
    double excess = c->breakaway_friction - fc;
    if (c->bristle_stiffness > 0.0) {
        double r = rate / c->stribeck_velocity;
        double e = exp(-r * r);
        double g = fc + excess * e; /* >= F_c > 0 (hs_params_check) */
        double zd = rate - c->bristle_stiffness * fabs(rate) * z / g;
        *dz = zd;
        return c->bristle_stiffness * z + c->bristle_damping * e * zd + c->viscous_friction * rate;
    }
    *dz = 0.0;
    if (excess > 0.0) {
        double r = rate / c->stribeck_velocity;
        fc += excess * exp(-r * r);
    }
    return c->viscous_friction * rate + fc * hs__smooth_sign(rate / c->coulomb_velocity);
}

/* open: the opening of the blocking valves between the servo valve and the
 * chambers (hs/drive.h), 0..1, scaling the valve flows (1: the model of
 * hs/cylinder.h exactly; 0: only the internal leakage moves oil). */
static inline void hs__cyl_eval(const hs_cyl_params_t *c, const hs_cyl_state_t *st, double stroke, double rate,
                                double u, double open, hs_cyl_eval_t *out)
{
    double x = hs__clamp(st->xv, -1.0, 1.0);
    double kx = c->valve_gain * x * open;
    double ps = c->supply_pressure;
    double pt = c->tank_pressure;
    double ptr = c->valve_transition;
    double pa = st->pa;
    double pb = st->pb;
    double qa, qb, ql, va, vb, dpa, dpb;
    double w = c->valve_omega;

    u = hs__clamp(u, -1.0, 1.0);
    if (x >= 0.0) {
        qa = kx * hs__orifice(ps - pa, ptr);
        qb = -kx * hs__orifice(pb - pt, ptr);
    } else {
        qa = kx * hs__orifice(pa - pt, ptr);
        qb = -kx * hs__orifice(ps - pb, ptr);
    }
    ql = c->leakage * (pa - pb);
    va = hs__volume_a(c, stroke);
    vb = hs__volume_b(c, stroke);
    {
        double k = c->bulk_modulus / (va * vb); /* one division for both chambers */
        dpa = k * vb * (qa - c->area_a * rate - ql);
        dpb = k * va * (qb + c->area_b * rate + ql);
    }
    if ((pa <= 0.0 && dpa < 0.0) || (pa >= c->pressure_max && dpa > 0.0)) {
        dpa = 0.0;
    }
    if ((pb <= 0.0 && dpb < 0.0) || (pb >= c->pressure_max && dpb > 0.0)) {
        dpb = 0.0;
    }
    out->dpa = dpa;
    out->dpb = dpb;
    out->dxv = st->xv_rate;
    out->dxv_rate = w * w * (u - st->xv) - 2.0 * c->valve_damping * w * st->xv_rate;
    out->qa = qa;
    out->qb = qb;
    out->pressure_force = pa * c->area_a - pb * c->area_b;
    out->friction = hs__friction(c, st->z, rate, &out->dz);
    out->stop = hs__stop_force(c, stroke, rate);
    out->force = out->pressure_force - out->friction + out->stop;
}

#endif /* HS_CYL_MODEL_H */
