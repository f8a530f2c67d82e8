/* SPDX-License-Identifier: Apache-2.0 */
/* params.c - plant parameters from the platform config (hs/params.h). */
#include "hs/params.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "hs/cylinder.h"

#define HS_PI 3.14159265358979323846
/* max over v of |v| exp(-(v/v_s)^2) / v_s = exp(-1/2) / sqrt(2), rounded up */
#define HS_FADE_PEAK 0.42889

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
        !finite_nonneg(c->rod_com) || !finite_nonneg(c->cylinder_inertia) || !finite_nonneg(c->rod_inertia) ||
        !(c->cylinder_com <= c->length_min + c->stroke) || !(c->rod_com <= c->length_min + c->stroke)) {
        return HS_E_ARG;
    }
    /* friction: F_s >= F_c; LuGre needs F_c > 0 (g(v) >= F_c keeps z' bounded)
     * and sigma_1 small enough to stay dissipative (hs/cylinder.h) */
    if (!isfinite(c->breakaway_friction) || !(c->breakaway_friction >= c->coulomb_friction) ||
        !finite_pos(c->stribeck_velocity) || !finite_nonneg(c->bristle_stiffness) ||
        !finite_nonneg(c->bristle_damping)) {
        return HS_E_ARG;
    }
    if (c->bristle_stiffness > 0.0 &&
        (!(c->coulomb_friction > 0.0) ||
         !(HS_FADE_PEAK * c->bristle_damping * c->stribeck_velocity <= 4.0 * c->coulomb_friction))) {
        return HS_E_ARG;
    }
    return HS_OK;
}

/* Leading principal minors of a symmetric 3x3 matrix: d1, d2, d3. */
static void minors(const double *m, double d[3])
{
    d[0] = m[0];
    d[1] = m[0] * m[4] - m[1] * m[3];
    d[2] = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
}

hs_status_t hs_rigid_body_check(double mass, const double com[3], const double *inertia_rows)
{
    double inertia[3][3];
    double ic[3][3], sm[3][3], d[3], c2, half_tr, tol;
    if (com == NULL || inertia_rows == NULL || !finite_pos(mass) || !isfinite(com[0]) || !isfinite(com[1]) ||
        !isfinite(com[2])) {
        return HS_E_ARG;
    }
    memcpy(inertia, inertia_rows, sizeof inertia);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            if (!isfinite(inertia[r][c]) || fabs(inertia[r][c] - inertia[c][r]) > 1e-9 * (1.0 + fabs(inertia[r][c]))) {
                return HS_E_ARG;
            }
        }
    }
    /* about the centre of mass (parallel axes), positive definite (Sylvester) */
    c2 = com[0] * com[0] + com[1] * com[1] + com[2] * com[2];
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            ic[r][c] = inertia[r][c] - mass * ((r == c ? c2 : 0.0) - com[r] * com[c]);
        }
    }
    minors(&ic[0][0], d);
    if (!(d[0] > 0.0 && d[1] > 0.0 && d[2] > 0.0)) {
        return HS_E_ARG;
    }
    /* the mass's second moment tr(I_c)/2 1 - I_c must be positive semi-definite
     * (the principal moments obey the triangle inequality): all principal minors >= 0 */
    half_tr = 0.5 * (ic[0][0] + ic[1][1] + ic[2][2]);
    tol = 1e-9 * half_tr;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            sm[r][c] = (r == c ? half_tr : 0.0) - ic[r][c];
        }
    }
    for (int k = 0; k < 3; ++k) {
        int a = (k + 1) % 3, b = (k + 2) % 3;
        if (sm[k][k] < -tol || sm[a][a] * sm[b][b] - sm[a][b] * sm[b][a] < -tol * half_tr) {
            return HS_E_ARG;
        }
    }
    minors(&sm[0][0], d);
    if (d[2] < -tol * half_tr * half_tr) {
        return HS_E_ARG;
    }
    return HS_OK;
}

hs_status_t hs_params_check(const hs_params_t *p)
{
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
    if (hs_rigid_body_check(p->mass, p->com, &p->inertia[0][0]) != HS_OK) {
        return HS_E_ARG;
    }
    if (!finite_pos(p->sensors.length_resolution) || !finite_pos(p->sensors.pressure_resolution) ||
        !finite_nonneg(p->sensors.pressure_noise)) {
        return HS_E_ARG;
    }
    for (int i = 0; i < HS_LEGS; ++i) {
        if (!isfinite(p->sensors.length_zero[i]) || !(fabs(p->sensors.length_zero[i]) <= 0.05) ||
            !isfinite(p->sensors.length_scale[i]) || !(fabs(p->sensors.length_scale[i]) <= 0.01)) {
            return HS_E_ARG;
        }
    }
    if (!finite_nonneg(p->drive.kp) || !finite_nonneg(p->drive.kf) || !finite_nonneg(p->drive.force_highpass) ||
        !finite_nonneg(p->drive.ff_gain) || !finite_pos(p->drive.following_error_max) || p->drive.timeout_cycles < 1u ||
        !finite_pos(p->drive.spool_error_max) || !finite_pos(p->drive.spool_error_time) ||
        !finite_pos(p->drive.sensor_check_travel) || !finite_nonneg(p->drive.block_time)) {
        return HS_E_ARG;
    }
    if (p->substeps < 1u || p->substeps > 1000u) {
        return HS_E_ARG;
    }
    return HS_OK;
}

/* The rigid body: joints, mass, inertia about o' (the config gives it about
 * the centre of mass), home pose, leg length range. */
static void body_from_config(const hs_config_t *cf, hs_params_t *p)
{
    memcpy(p->base_joint, cf->base_joints, sizeof p->base_joint);
    memcpy(p->platform_joint, cf->platform_joints, sizeof p->platform_joint);
    memcpy(p->inertia, cf->inertia, sizeof p->inertia);
    memcpy(p->com, cf->center_of_mass, sizeof p->com);
    if (cf->center_of_mass[0] != 0.0 || cf->center_of_mass[1] != 0.0 || cf->center_of_mass[2] != 0.0) {
        /* the config gives the inertia about c; the plant wants it about o' (parallel axes) */
        const double *cm = cf->center_of_mass;
        double c2 = cm[0] * cm[0] + cm[1] * cm[1] + cm[2] * cm[2];
        for (int r = 0; r < 3; ++r) {
            for (int k = 0; k < 3; ++k) {
                p->inertia[r][k] += cf->mass * ((r == k ? c2 : 0.0) - cm[r] * cm[k]);
            }
        }
    }
    memcpy(p->home, cf->home, sizeof p->home);
    p->mass = cf->mass;
    p->gravity = cf->gravity;
    p->leg_length_min = cf->leg_length_min;
    p->leg_length_max = cf->leg_length_max;
}

/* What all six cylinders share: geometry, oil, valve, end stops, masses. */
static void cylinder_from_config(const hs_config_t *cf, hs_cyl_params_t *c)
{
    const hs_hydraulic_config_t *h = &cf->hydraulic;
    memset(c, 0, sizeof *c);
    c->area_a = 0.25 * HS_PI * h->piston_diameter * h->piston_diameter;
    c->area_b = c->area_a - 0.25 * HS_PI * h->rod_diameter * h->rod_diameter;
    c->length_min = cf->leg_length_min;
    c->stroke = cf->leg_length_max - cf->leg_length_min;
    c->dead_volume_a = h->dead_volume;
    c->dead_volume_b = h->dead_volume;
    c->piston_mass = h->piston_mass;
    c->bulk_modulus = h->bulk_modulus;
    c->supply_pressure = h->supply_pressure;
    c->tank_pressure = h->tank_pressure;
    c->pressure_max = 1.2 * h->supply_pressure;
    c->valve_gain =
        (h->valve_rated_pressure_drop > 0.0) ? h->valve_rated_flow / sqrt(h->valve_rated_pressure_drop) : 0.0;
    c->valve_transition = 1.0e5;
    c->valve_omega = 2.0 * HS_PI * h->valve_natural_frequency;
    c->valve_damping = h->valve_damping;
    c->leakage = h->leakage_coefficient;
    c->coulomb_velocity = h->coulomb_velocity;
    c->stribeck_velocity = h->stribeck_velocity;
    c->cushion_length = h->end_cushion_length;
    c->stop_stiffness = h->end_stop_stiffness;
    c->stop_damping = h->end_stop_damping;
    c->cylinder_mass = h->cylinder_mass;
    c->cylinder_com = h->cylinder_com;
    c->rod_mass = h->rod_mass;
    c->rod_com = h->rod_com;
    c->cylinder_inertia = h->cylinder_inertia;
    c->rod_inertia = h->rod_inertia;
}

/* The drives' gains and safety functions, from the cylinder c (docs/explanation/plant.md). */
static void drive_from_config(const hs_config_t *cf, const hs_cyl_params_t *c, hs_drive_params_t *d)
{
    /* Drive gains from the oil-column resonance at mid stroke with a sixth
     * of the moving mass per cylinder (docs/explanation/plant.md): closed position loop
     * s^3 + c_f s^2 + w_h^2 s + w_h^2 K_v with pressure feedback c_f = w_h
     * (damping ratio 0.5) and loop gain K_v = w_h / 4. */
    double m_leg = cf->mass / HS_LEGS + cf->hydraulic.piston_mass;
    double mid = 0.5 * c->stroke;
    double w_h = hs_cyl_natural_frequency(c, mid, m_leg);
    double k_q = c->valve_gain * sqrt(0.5 * (c->supply_pressure - c->tank_pressure));
    double a_sum = c->bulk_modulus * (c->area_a / hs_cyl_volume_a(c, mid) + c->area_b / hs_cyl_volume_b(c, mid));
    d->kp = (k_q > 0.0) ? 0.25 * w_h * c->area_a / k_q : 0.0;
    d->kf = (k_q > 0.0 && a_sum > 0.0) ? w_h / (a_sum * k_q) : 0.0;
    d->force_highpass = 2.0 * HS_PI * 1.0;
    d->ff_gain = 1.0;
    d->following_error_max = 0.02;
    d->timeout_cycles = 3u;
    /* The safety functions below the position loop (hs/drive.h): a valve
     * fault when the spool is 0.2 off its model for 2 ms, a sensor fault
     * when the valve flow predicts 1 mm of travel the length reading does
     * not show, blocking valves closing in 20 ms. */
    d->spool_error_max = 0.2;
    d->spool_error_time = 0.002;
    d->sensor_check_travel = 0.001;
    d->block_time = 0.02;
}

hs_status_t hs_params_from_config(const hs_config_t *cf, hs_params_t *p)
{
    const hs_hydraulic_config_t *h;
    hs_cyl_params_t c;
    if (cf == NULL || p == NULL) {
        return HS_E_ARG;
    }
    h = &cf->hydraulic;
    memset(p, 0, sizeof *p);
    body_from_config(cf, p);
    cylinder_from_config(cf, &c);
    for (int i = 0; i < HS_LEGS; ++i) {
        hs_cyl_params_t *ci = &p->cyl[i];
        *ci = c;
        ci->viscous_friction = h->viscous_friction[i];
        ci->coulomb_friction = h->coulomb_friction[i];
        ci->breakaway_friction = h->breakaway_friction[i];
        /* LuGre (docs/explanation/plant.md "Friction"): sigma_0 and sigma_1 come with the config,
         * derived in one place for the plant and the firmware's friction observer
         * (tools/stewart/config.py bristle_parameters: sigma_0 = F_c / presliding
         * displacement, sigma_1 critical against a sixth of the moving mass, bounded
         * to stay dissipative; no Coulomb level: memoryless). hs_params_check
         * rejects a sigma_1 beyond the dissipativity bound. */
        ci->bristle_stiffness = h->bristle_stiffness[i];
        ci->bristle_damping = h->bristle_damping[i];
    }

    p->sensors.length_resolution = cf->sensors.length_resolution;
    p->sensors.pressure_resolution = cf->sensors.pressure_resolution;
    p->sensors.pressure_noise = cf->sensors.pressure_noise;
    p->sensors.seed = cf->sensors.seed;
    for (int i = 0; i < HS_LEGS; ++i) {
        p->sensors.length_zero[i] = cf->sensors.length_zero[i];
        p->sensors.length_scale[i] = cf->sensors.length_scale[i];
    }
    drive_from_config(cf, &c, &p->drive);
    p->substeps = 10u;
    return hs_params_check(p);
}

hs_status_t hs_params_default(hs_params_t *params)
{
    return hs_params_from_config(&hs_config_default, params);
}

hs_status_t hs_params_add_mass(hs_params_t *p, double mass, const double point[3])
{
    double m1, c1[3], in1[3][3], r2;
    if (p == NULL || point == NULL || !isfinite(mass) || !isfinite(point[0]) || !isfinite(point[1]) ||
        !isfinite(point[2])) {
        return HS_E_ARG;
    }
    m1 = p->mass + mass;
    if (!(m1 > 0.0)) {
        return HS_E_RANGE;
    }
    r2 = point[0] * point[0] + point[1] * point[1] + point[2] * point[2];
    for (int k = 0; k < 3; ++k) {
        c1[k] = (p->mass * p->com[k] + mass * point[k]) / m1;
    }
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            in1[j][k] = p->inertia[j][k] + mass * ((j == k ? r2 : 0.0) - point[j] * point[k]);
        }
    }
    if (hs_rigid_body_check(m1, c1, &in1[0][0]) != HS_OK) {
        return HS_E_RANGE;
    }
    p->mass = m1;
    for (int j = 0; j < 3; ++j) {
        p->com[j] = c1[j];
        for (int k = 0; k < 3; ++k) {
            p->inertia[j][k] = in1[j][k];
        }
    }
    return HS_OK;
}
