/* SPDX-License-Identifier: Apache-2.0 */
/* cylinder.c - hydraulic cylinder and servo valve model (hs/cylinder.h). */
#include "hs/cylinder.h"

#include <math.h>

#include "cyl_model.h"

double hs_cyl_volume_a(const hs_cyl_params_t *c, double stroke)
{
    return hs__volume_a(c, stroke);
}

double hs_cyl_volume_b(const hs_cyl_params_t *c, double stroke)
{
    return hs__volume_b(c, stroke);
}

void hs_cyl_eval(const hs_cyl_params_t *c, const hs_cyl_state_t *st, double stroke, double rate, double u,
                 hs_cyl_eval_t *out)
{
    hs__cyl_eval(c, st, stroke, rate, u, 1.0, out);
}

static double chamber_energy(double beta, double v, double p)
{
    double y;
    if (p <= 0.0) {
        return 0.0;
    }
    y = p / beta;
    return beta * v * (expm1(y) - y);
}

double hs_cyl_oil_energy(const hs_cyl_params_t *c, double stroke, double pa, double pb)
{
    return chamber_energy(c->bulk_modulus, hs_cyl_volume_a(c, stroke), pa) +
           chamber_energy(c->bulk_modulus, hs_cyl_volume_b(c, stroke), pb);
}

double hs_cyl_stop_energy(const hs_cyl_params_t *c, double stroke)
{
    double d = 0.0;
    if (stroke < 0.0) {
        d = -stroke;
    } else if (stroke > c->stroke) {
        d = stroke - c->stroke;
    }
    return 0.5 * c->stop_stiffness * d * d;
}

void hs_cyl_holding_pressures(const hs_cyl_params_t *c, double force, double *pa, double *pb)
{
    double ps = c->supply_pressure;
    double pt = c->tank_pressure;
    double a = (force + (ps + pt) * c->area_b) / (c->area_a + c->area_b);
    a = hs__clamp(a, pt, ps);
    *pa = a;
    *pb = ps + pt - a;
}

double hs_cyl_velocity_command(const hs_cyl_params_t *c, double velocity, double force)
{
    double ps = c->supply_pressure;
    double pt = c->tank_pressure;
    double aa = c->area_a;
    double ab = c->area_b;
    double r = (aa / ab) * (aa / ab);
    double den = r * aa + ab;
    double drop, q, u;
    if (velocity == 0.0) {
        return 0.0;
    }
    if (velocity > 0.0) {
        /* A fed from supply, B drains to tank; drop = p_B - p_T */
        drop = (ps * aa - pt * ab - force) / den;
    } else {
        /* B fed from supply, A drains to tank; drop = p_S - p_B */
        drop = (force - pt * aa + ps * ab) / den;
    }
    if (!(drop > 0.0)) {
        return (velocity > 0.0) ? 1.0 : -1.0;
    }
    q = c->valve_gain * hs__orifice(drop, c->valve_transition);
    u = ab * velocity / q;
    return hs__clamp(u, -1.0, 1.0);
}

double hs_cyl_natural_frequency(const hs_cyl_params_t *c, double stroke, double mass)
{
    double va, vb;
    if (!(mass > 0.0)) {
        return 0.0;
    }
    va = hs_cyl_volume_a(c, stroke);
    vb = hs_cyl_volume_b(c, stroke);
    return sqrt(c->bulk_modulus * (c->area_a * c->area_a / va + c->area_b * c->area_b / vb) / mass);
}
