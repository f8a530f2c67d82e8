/* SPDX-License-Identifier: Apache-2.0 */
/* drive.c - the axis drive of one cylinder (hs/drive.h). */
#include "hs/drive.h"

#include <math.h>
#include <string.h>

#include "cyl_model.h"
#include "hs/cylinder.h"

void hs_drive_init(hs_drive_t *d, double force0)
{
    memset(d, 0, sizeof *d);
    d->state = HS_DRIVE_INIT;
    d->request = HS_REQ_HOLD;
    d->meas_lp = force0;
    d->block = 1.0;
}

hs_status_t hs_drive_setpoint(hs_drive_t *d, double length, double velocity, double force, hs_drive_request_t mode)
{
    if (d == NULL || !isfinite(length) || !isfinite(velocity) || !isfinite(force) ||
        (mode != HS_REQ_HOLD && mode != HS_REQ_ACTIVE)) {
        return HS_E_ARG;
    }
    d->sp_length = length;
    d->sp_velocity = velocity;
    d->sp_force = force;
    d->sp_age = 0.0;
    d->request = mode;
    d->fresh = 1;
    d->ff_valid = 0;
    return HS_OK;
}

hs_status_t hs_drive_set_block(hs_drive_t *d, int closed)
{
    if (d == NULL) {
        return HS_E_ARG;
    }
    d->block_request = (closed != 0);
    return HS_OK;
}

static void enter_hold(hs_drive_t *d, double meas_length)
{
    d->state = HS_DRIVE_HOLD;
    d->hold_length = meas_length;
}

void hs_drive_cycle(hs_drive_t *d, const hs_drive_params_t *dp, double meas_length)
{
    if (d->fresh) {
        int released = d->blocked && !d->block_request;
        d->fresh = 0;
        d->missed = 0;
        d->blocked = d->block_request;
        if (d->state == HS_DRIVE_FAULT) {
            return;
        }
        if (d->request == HS_REQ_ACTIVE && !d->blocked && (d->faults & HS_FAULT_TIMEOUT) == 0u) {
            if (d->state != HS_DRIVE_ACTIVE) {
                d->state = HS_DRIVE_ACTIVE;
                d->ref_valid = 0;
            }
        } else if (d->state != HS_DRIVE_HOLD || released) {
            enter_hold(d, meas_length); /* released: hold where the blocking valves held it */
        }
        return;
    }
    if (d->state == HS_DRIVE_ACTIVE) {
        if (d->missed < UINT32_MAX) {
            d->missed++;
        }
        if (d->missed >= dp->timeout_cycles) {
            d->faults |= HS_FAULT_TIMEOUT;
            enter_hold(d, meas_length);
        }
    }
}

double hs_drive_update(hs_drive_t *d, const hs_drive_params_t *dp, const hs_cyl_params_t *c, double meas_length,
                       double meas_pa, double meas_pb, double h)
{
    double target, uff = 0.0, hp_ref = 0.0, hp_meas, u;
    double fm = meas_pa * c->area_a - meas_pb * c->area_b;
    double k = h * dp->force_highpass;
    k = (k < 1.0) ? k : 1.0;

    d->sp_age += h;
    hp_meas = fm - d->meas_lp;
    d->meas_lp += k * hp_meas;
    if (d->blocked) {
        d->command = 0.0;
        d->error = 0.0;
        return 0.0;
    }
    if (d->state == HS_DRIVE_HOLD) {
        target = d->hold_length;
    } else if (d->state == HS_DRIVE_ACTIVE) {
        double age = d->sp_age - h; /* the target of this substep's start */
        target = d->sp_length + d->sp_velocity * age;
        if (!d->ff_valid) {
            d->ff_command = hs_cyl_velocity_command(c, d->sp_velocity, d->sp_force);
            d->ff_valid = 1;
        }
        uff = dp->ff_gain * d->ff_command;
        if (!d->ref_valid) {
            d->ref_lp = d->sp_force;
            d->ref_valid = 1;
        }
        hp_ref = d->sp_force - d->ref_lp;
        d->ref_lp += k * hp_ref;
    } else {
        d->command = 0.0;
        d->error = 0.0;
        return 0.0;
    }
    d->error = target - meas_length;
    if (d->state == HS_DRIVE_ACTIVE && fabs(d->error) > dp->following_error_max) {
        hs_drive_raise(d, HS_FAULT_FOLLOWING);
        d->command = 0.0;
        return 0.0;
    }
    u = dp->kp * d->error + uff + dp->kf * (hp_ref - hp_meas);
    if (u != u) {
        u = 0.0; /* NaN: the plant flags it as an internal fault */
    } else if (u > 1.0) {
        u = 1.0;
    } else if (u < -1.0) {
        u = -1.0;
    }
    d->command = u;
    return u;
}

/* The spool model: x'' = w^2 (u - x) - 2 z w x', one RK4 step of h with u
 * held (as the plant integrates the spool). */
static void spool_model_step(hs_drive_t *d, const hs_cyl_params_t *c, double u, double h)
{
    double w2 = c->valve_omega * c->valve_omega, zw = 2.0 * c->valve_damping * c->valve_omega;
    double x = d->spool_model, v = d->spool_model_rate;
    double k1x = v, k1v = w2 * (u - x) - zw * v;
    double k2x = v + 0.5 * h * k1v, k2v = w2 * (u - (x + 0.5 * h * k1x)) - zw * k2x;
    double k3x = v + 0.5 * h * k2v, k3v = w2 * (u - (x + 0.5 * h * k2x)) - zw * k3x;
    double k4x = v + h * k3v, k4v = w2 * (u - (x + h * k3x)) - zw * k4x;
    d->spool_model = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    d->spool_model_rate = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
}

static void balance_restart(hs_drive_t *d, double meas_length, double meas_pa, double meas_pb, int valid)
{
    d->chk_length = meas_length;
    d->chk_pa = meas_pa;
    d->chk_pb = meas_pb;
    d->chk_qa = 0.0;
    d->chk_qb = 0.0;
    d->chk_travel = 0.0;
    d->chk_valid = valid;
}

/* The sensor plausibility (hs/drive.h): restart, or check the travel the
 * flows predict, then add this substep's flows. */
static void sensor_balance(hs_drive_t *d, const hs_drive_params_t *dp, const hs_cyl_params_t *c, double meas_length,
                           double meas_pa, double meas_pb, double meas_spool, double h)
{
    double lo = 0.01 * c->pressure_max, hi = 0.99 * c->pressure_max;
    double x, kx, qa, qb, ql;
    if (d->state == HS_DRIVE_FAULT || d->block < 1.0 || !(meas_pa > lo && meas_pa < hi) ||
        !(meas_pb > lo && meas_pb < hi) || !isfinite(meas_length) || !isfinite(meas_spool)) {
        balance_restart(d, meas_length, meas_pa, meas_pb, 0);
        return;
    }
    if (!d->chk_valid || meas_length != d->chk_length) {
        balance_restart(d, meas_length, meas_pa, meas_pb, 1);
    } else {
        double s = meas_length - c->length_min;
        double da = (d->chk_qa - hs__volume_a(c, s) / c->bulk_modulus * (meas_pa - d->chk_pa)) / c->area_a;
        double db = -(d->chk_qb - hs__volume_b(c, s) / c->bulk_modulus * (meas_pb - d->chk_pb)) / c->area_b;
        d->chk_travel = (da * db > 0.0) ? fmin(fabs(da), fabs(db)) : 0.0;
        d->chk_travel_peak = fmax(d->chk_travel_peak, d->chk_travel);
        if (d->chk_travel > dp->sensor_check_travel) {
            hs_drive_raise(d, HS_FAULT_SENSOR);
            return;
        }
    }
    x = hs__clamp(meas_spool, -1.0, 1.0);
    kx = c->valve_gain * x;
    if (x >= 0.0) {
        qa = kx * hs__orifice(c->supply_pressure - meas_pa, c->valve_transition);
        qb = -kx * hs__orifice(meas_pb - c->tank_pressure, c->valve_transition);
    } else {
        qa = kx * hs__orifice(meas_pa - c->tank_pressure, c->valve_transition);
        qb = -kx * hs__orifice(c->supply_pressure - meas_pb, c->valve_transition);
    }
    ql = c->leakage * (meas_pa - meas_pb);
    d->chk_qa += (qa - ql) * h;
    d->chk_qb += (qb + ql) * h;
}

void hs_drive_monitor(hs_drive_t *d, const hs_drive_params_t *dp, const hs_cyl_params_t *c, double meas_length,
                      double meas_pa, double meas_pb, double meas_spool, double h)
{
    double err = fabs(d->spool_model - meas_spool);
    d->spool_error = err;
    d->spool_error_peak = fmax(d->spool_error_peak, err);
    if (err > dp->spool_error_max) {
        d->spool_error_time += h;
        if (d->spool_error_time >= dp->spool_error_time - 0.5 * h) {
            hs_drive_raise(d, HS_FAULT_VALVE);
        }
    } else {
        d->spool_error_time = 0.0;
    }
    sensor_balance(d, dp, c, meas_length, meas_pa, meas_pb, meas_spool, h);
    spool_model_step(d, c, d->command, h);
    {
        double target = (d->state == HS_DRIVE_FAULT || d->blocked) ? 0.0 : 1.0;
        double step = (dp->block_time > 0.0) ? h / dp->block_time : 1.0;
        if (d->block < target) {
            d->block = fmin(d->block + step, target);
        } else if (d->block > target) {
            d->block = fmax(d->block - step, target);
        }
    }
}

void hs_drive_raise(hs_drive_t *d, uint32_t bits)
{
    d->faults |= (bits & 0xFFu);
    if ((bits & HS_FAULTS_SEVERE) != 0u) {
        d->state = HS_DRIVE_FAULT;
        d->command = 0.0;
    }
}

void hs_drive_fail(hs_drive_t *d, uint32_t bits)
{
    d->faults |= (bits & 0xFFu);
    d->state = HS_DRIVE_FAULT;
    d->command = 0.0;
}

void hs_drive_clear_faults(hs_drive_t *d)
{
    d->faults = 0u;
    d->missed = 0u;
    if (d->state == HS_DRIVE_FAULT) {
        d->state = HS_DRIVE_INIT;
    }
}
