/* drive.c - the axis drive of one cylinder (hs/drive.h). */
#include "hs/drive.h"

#include <math.h>
#include <string.h>

#include "hs/cylinder.h"

void hs_drive_init(hs_drive_t *d, double force0)
{
    memset(d, 0, sizeof *d);
    d->state = HS_DRIVE_INIT;
    d->request = HS_REQ_HOLD;
    d->meas_lp = force0;
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

static void enter_hold(hs_drive_t *d, double meas_length)
{
    d->state = HS_DRIVE_HOLD;
    d->hold_length = meas_length;
}

void hs_drive_cycle(hs_drive_t *d, const hs_drive_params_t *dp, double meas_length)
{
    if (d->fresh) {
        d->fresh = 0;
        d->missed = 0;
        if (d->state == HS_DRIVE_FAULT) {
            return;
        }
        if (d->request == HS_REQ_ACTIVE && (d->faults & HS_FAULT_TIMEOUT) == 0u) {
            if (d->state != HS_DRIVE_ACTIVE) {
                d->state = HS_DRIVE_ACTIVE;
                d->ref_valid = 0;
            }
        } else if (d->state != HS_DRIVE_HOLD) {
            enter_hold(d, meas_length);
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
