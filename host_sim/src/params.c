/* params.c - plant parameters from the platform config (hs/params.h). */
#include "hs/params.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "hs/cylinder.h"

#define HS_PI 3.14159265358979323846

static int finite_pos(double v)
{
    return isfinite(v) && v > 0.0;
}

static int finite_nonneg(double v)
{
    return isfinite(v) && v >= 0.0;
}

static hs_status_t check_cyl(const hs_cyl_params_t *c)
{
    if (!finite_pos(c->area_a) || !finite_pos(c->area_b) || !(c->area_b <= c->area_a) || !finite_pos(c->length_min) ||
        !finite_pos(c->stroke) || !finite_pos(c->dead_volume_a) || !finite_pos(c->dead_volume_b) ||
        !finite_nonneg(c->piston_mass) || !finite_pos(c->bulk_modulus) || !finite_pos(c->supply_pressure) ||
        !finite_nonneg(c->tank_pressure) || !(c->tank_pressure < c->supply_pressure) || !isfinite(c->pressure_max) ||
        !(c->pressure_max >= c->supply_pressure) || !finite_pos(c->valve_gain) || !finite_pos(c->valve_transition) ||
        !finite_pos(c->valve_omega) || !finite_pos(c->valve_damping) || !finite_nonneg(c->leakage) ||
        !finite_nonneg(c->viscous_friction) || !finite_nonneg(c->coulomb_friction) ||
        !finite_pos(c->coulomb_velocity) || !finite_nonneg(c->cushion_length) ||
        !(c->cushion_length < 0.5 * c->stroke) || !finite_pos(c->stop_stiffness) || !finite_nonneg(c->stop_damping) ||
        !finite_nonneg(c->cylinder_mass) || !finite_nonneg(c->cylinder_com) || !finite_nonneg(c->rod_mass) ||
        !finite_nonneg(c->rod_com) || !(c->cylinder_com <= c->length_min + c->stroke) ||
        !(c->rod_com <= c->length_min + c->stroke)) {
        return HS_E_ARG;
    }
    return HS_OK;
}

hs_status_t hs_params_check(const hs_params_t *p)
{
    const double *m;
    double d2, d3;
    if (p == NULL) {
        return HS_E_ARG;
    }
    for (int i = 0; i < HS_LEGS; ++i) {
        for (int k = 0; k < 3; ++k) {
            if (!isfinite(p->base_joint[i][k]) || !isfinite(p->platform_joint[i][k])) {
                return HS_E_ARG;
            }
        }
        if (check_cyl(&p->cyl[i]) != HS_OK) {
            return HS_E_ARG;
        }
    }
    for (int k = 0; k < 6; ++k) {
        if (!isfinite(p->home[k])) {
            return HS_E_ARG;
        }
    }
    if (!finite_pos(p->mass) || !finite_nonneg(p->gravity) || !finite_pos(p->leg_length_min) ||
        !isfinite(p->leg_length_max) || !(p->leg_length_max > p->leg_length_min)) {
        return HS_E_ARG;
    }
    /* inertia: finite, symmetric, positive definite (Sylvester) */
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            if (!isfinite(p->inertia[r][c]) ||
                fabs(p->inertia[r][c] - p->inertia[c][r]) > 1e-9 * (1.0 + fabs(p->inertia[r][c]))) {
                return HS_E_ARG;
            }
        }
    }
    m = &p->inertia[0][0];
    d2 = m[0] * m[4] - m[1] * m[3];
    d3 = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
    if (!(m[0] > 0.0 && d2 > 0.0 && d3 > 0.0)) {
        return HS_E_ARG;
    }
    if (!finite_pos(p->sensors.length_resolution) || !finite_pos(p->sensors.pressure_resolution) ||
        !finite_nonneg(p->sensors.pressure_noise)) {
        return HS_E_ARG;
    }
    if (!finite_nonneg(p->drive.kp) || !finite_nonneg(p->drive.kf) || !finite_nonneg(p->drive.force_highpass) ||
        !finite_nonneg(p->drive.ff_gain) || !finite_pos(p->drive.following_error_max) || p->drive.timeout_cycles < 1u) {
        return HS_E_ARG;
    }
    if (p->substeps < 1u || p->substeps > 1000u) {
        return HS_E_ARG;
    }
    return HS_OK;
}

hs_status_t hs_params_from_config(const hs_config_t *cf, hs_params_t *p)
{
    const hs_hydraulic_config_t *h;
    hs_cyl_params_t c;
    double m_leg, mid, w_h, k_q, a_sum;
    if (cf == NULL || p == NULL) {
        return HS_E_ARG;
    }
    h = &cf->hydraulic;
    memset(p, 0, sizeof *p);
    memcpy(p->base_joint, cf->base_joints, sizeof p->base_joint);
    memcpy(p->platform_joint, cf->platform_joints, sizeof p->platform_joint);
    memcpy(p->inertia, cf->inertia, sizeof p->inertia);
    memcpy(p->home, cf->home, sizeof p->home);
    p->mass = cf->mass;
    p->gravity = cf->gravity;
    p->leg_length_min = cf->leg_length_min;
    p->leg_length_max = cf->leg_length_max;

    memset(&c, 0, sizeof c);
    c.area_a = 0.25 * HS_PI * h->piston_diameter * h->piston_diameter;
    c.area_b = c.area_a - 0.25 * HS_PI * h->rod_diameter * h->rod_diameter;
    c.length_min = cf->leg_length_min;
    c.stroke = cf->leg_length_max - cf->leg_length_min;
    c.dead_volume_a = h->dead_volume;
    c.dead_volume_b = h->dead_volume;
    c.piston_mass = h->piston_mass;
    c.bulk_modulus = h->bulk_modulus;
    c.supply_pressure = h->supply_pressure;
    c.tank_pressure = h->tank_pressure;
    c.pressure_max = 1.2 * h->supply_pressure;
    c.valve_gain =
        (h->valve_rated_pressure_drop > 0.0) ? h->valve_rated_flow / sqrt(h->valve_rated_pressure_drop) : 0.0;
    c.valve_transition = 1.0e5;
    c.valve_omega = 2.0 * HS_PI * h->valve_natural_frequency;
    c.valve_damping = h->valve_damping;
    c.leakage = h->leakage_coefficient;
    c.viscous_friction = h->viscous_friction;
    c.coulomb_friction = h->coulomb_friction;
    c.coulomb_velocity = 1.0e-3;
    c.cushion_length = h->end_cushion_length;
    c.stop_stiffness = h->end_stop_stiffness;
    c.stop_damping = h->end_stop_damping;
    c.cylinder_mass = h->cylinder_mass;
    c.cylinder_com = h->cylinder_com;
    c.rod_mass = h->rod_mass;
    c.rod_com = h->rod_com;
    for (int i = 0; i < HS_LEGS; ++i) {
        p->cyl[i] = c;
    }

    p->sensors.length_resolution = cf->sensors.length_resolution;
    p->sensors.pressure_resolution = cf->sensors.pressure_resolution;
    p->sensors.pressure_noise = cf->sensors.pressure_noise;
    p->sensors.seed = cf->sensors.seed;

    /* Drive gains from the oil-column resonance at mid stroke with a sixth
     * of the moving mass per cylinder (docs/plant.md): closed position loop
     * s^3 + c_f s^2 + w_h^2 s + w_h^2 K_v with pressure feedback c_f = w_h
     * (damping ratio 0.5) and loop gain K_v = w_h / 4. */
    m_leg = cf->mass / HS_LEGS + h->piston_mass;
    mid = 0.5 * c.stroke;
    w_h = hs_cyl_natural_frequency(&c, mid, m_leg);
    k_q = c.valve_gain * sqrt(0.5 * (c.supply_pressure - c.tank_pressure));
    a_sum = c.bulk_modulus * (c.area_a / hs_cyl_volume_a(&c, mid) + c.area_b / hs_cyl_volume_b(&c, mid));
    p->drive.kp = (k_q > 0.0) ? 0.25 * w_h * c.area_a / k_q : 0.0;
    p->drive.kf = (k_q > 0.0 && a_sum > 0.0) ? w_h / (a_sum * k_q) : 0.0;
    p->drive.force_highpass = 2.0 * HS_PI * 1.0;
    p->drive.ff_gain = 1.0;
    p->drive.following_error_max = 0.02;
    p->drive.timeout_cycles = 3u;
    p->substeps = 10u;
    return hs_params_check(p);
}

hs_status_t hs_params_default(hs_params_t *params)
{
    return hs_params_from_config(&hs_config_default, params);
}
