/* SPDX-License-Identifier: Apache-2.0 */
/* kin.c - rigid-body geometry in double precision (hs/kin.h). */
#include "hs/kin.h"

#include <math.h>
#include <stddef.h>

void hs_rot_from_rpy(const double rpy[3], double r[3][3])
{
    double cr = cos(rpy[0]), sr = sin(rpy[0]);
    double cp = cos(rpy[1]), sp = sin(rpy[1]);
    double cy = cos(rpy[2]), sy = sin(rpy[2]);
    r[0][0] = cy * cp;
    r[0][1] = cy * sp * sr - sy * cr;
    r[0][2] = cy * sp * cr + sy * sr;
    r[1][0] = sy * cp;
    r[1][1] = sy * sp * sr + cy * cr;
    r[1][2] = sy * sp * cr - cy * sr;
    r[2][0] = -sp;
    r[2][1] = cp * sr;
    r[2][2] = cp * cr;
}

void hs_quat_from_rpy(const double rpy[3], double q[4])
{
    /* q = qz(yaw) qy(pitch) qx(roll) */
    double cr = cos(0.5 * rpy[0]), sr = sin(0.5 * rpy[0]);
    double cp = cos(0.5 * rpy[1]), sp = sin(0.5 * rpy[1]);
    double cy = cos(0.5 * rpy[2]), sy = sin(0.5 * rpy[2]);
    q[0] = cr * cp * cy + sr * sp * sy;
    q[1] = sr * cp * cy - cr * sp * sy;
    q[2] = cr * sp * cy + sr * cp * sy;
    q[3] = cr * cp * sy - sr * sp * cy;
}

void hs_rot_from_quat(const double q[4], double r[3][3])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double n = w * w + x * x + y * y + z * z;
    double s = (n > 0.0) ? 2.0 / n : 0.0;
    r[0][0] = 1.0 - s * (y * y + z * z);
    r[0][1] = s * (x * y - w * z);
    r[0][2] = s * (x * z + w * y);
    r[1][0] = s * (x * y + w * z);
    r[1][1] = 1.0 - s * (x * x + z * z);
    r[1][2] = s * (y * z - w * x);
    r[2][0] = s * (x * z - w * y);
    r[2][1] = s * (y * z + w * x);
    r[2][2] = 1.0 - s * (x * x + y * y);
}

void hs_rpy_from_rot(double r[3][3], double rpy[3])
{
    double s = -r[2][0];
    if (s > 1.0) {
        s = 1.0;
    } else if (s < -1.0) {
        s = -1.0;
    }
    rpy[1] = asin(s);
    if (hypot(r[0][0], r[1][0]) < 1e-12) {
        rpy[2] = 0.0;
        rpy[0] = atan2(-r[1][2], r[1][1]);
    } else {
        rpy[0] = atan2(r[2][1], r[2][2]);
        rpy[2] = atan2(r[1][0], r[0][0]);
    }
}

void hs_body_rates(const double rpy[3], const double rpy_rate[3], double omega[3])
{
    double cr = cos(rpy[0]), sr = sin(rpy[0]);
    double cp = cos(rpy[1]), sp = sin(rpy[1]);
    omega[0] = rpy_rate[0] - rpy_rate[2] * sp;
    omega[1] = rpy_rate[1] * cr + rpy_rate[2] * sr * cp;
    omega[2] = -rpy_rate[1] * sr + rpy_rate[2] * cr * cp;
}

hs_status_t hs_euler_rates(const double rpy[3], const double omega[3], double rpy_rate[3])
{
    double cr = cos(rpy[0]), sr = sin(rpy[0]);
    double cp = cos(rpy[1]), sp = sin(rpy[1]);
    if (fabs(cp) < 1e-9) {
        return HS_E_RANGE;
    }
    rpy_rate[2] = (omega[1] * sr + omega[2] * cr) / cp;
    rpy_rate[1] = omega[1] * cr - omega[2] * sr;
    rpy_rate[0] = omega[0] + rpy_rate[2] * sp;
    return HS_OK;
}

hs_status_t hs_leg_lengths(const hs_params_t *params, const double pose[6], double length[HS_LEGS])
{
    double r[3][3];
    if (params == NULL || pose == NULL || length == NULL) {
        return HS_E_ARG;
    }
    hs_rot_from_rpy(&pose[3], r);
    for (int i = 0; i < HS_LEGS; ++i) {
        const double *a = params->platform_joint[i];
        double l2 = 0.0;
        for (int k = 0; k < 3; ++k) {
            double c = pose[k] + r[k][0] * a[0] + r[k][1] * a[1] + r[k][2] * a[2] - params->base_joint[i][k];
            l2 += c * c;
        }
        length[i] = sqrt(l2);
    }
    return HS_OK;
}

hs_status_t hs_solve6(double a_in[6][6], const double b_in[6], double x[6])
{
    double a[6][6];
    double b[6];
    double amax = 0.0;
    for (int r = 0; r < 6; ++r) {
        b[r] = b_in[r];
        x[r] = 0.0;
        for (int c = 0; c < 6; ++c) {
            a[r][c] = a_in[r][c];
            if (fabs(a[r][c]) > amax) {
                amax = fabs(a[r][c]);
            }
        }
    }
    if (!(amax > 0.0) || !isfinite(amax)) {
        return HS_E_SINGULAR;
    }
    for (int c = 0; c < 6; ++c) {
        int piv = c;
        for (int r = c + 1; r < 6; ++r) {
            if (fabs(a[r][c]) > fabs(a[piv][c])) {
                piv = r;
            }
        }
        if (!(fabs(a[piv][c]) > 1e-12 * amax)) {
            return HS_E_SINGULAR;
        }
        if (piv != c) {
            for (int k = 0; k < 6; ++k) {
                double t = a[c][k];
                a[c][k] = a[piv][k];
                a[piv][k] = t;
            }
            double t = b[c];
            b[c] = b[piv];
            b[piv] = t;
        }
        for (int r = c + 1; r < 6; ++r) {
            double f = a[r][c] / a[c][c];
            for (int k = c; k < 6; ++k) {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    for (int r = 5; r >= 0; --r) {
        double s = b[r];
        for (int k = r + 1; k < 6; ++k) {
            s -= a[r][k] * x[k];
        }
        x[r] = s / a[r][r];
    }
    return HS_OK;
}

hs_status_t hs_static_forces(const hs_params_t *params, const double pose[6], const double ext_force[3],
                             const double ext_moment[3], double force[HS_LEGS])
{
    double r[3][3];
    double a[6][6];
    double b[6];
    if (params == NULL || pose == NULL || force == NULL) {
        return HS_E_ARG;
    }
    hs_rot_from_rpy(&pose[3], r);
    for (int i = 0; i < HS_LEGS; ++i) {
        const double *pj = params->platform_joint[i];
        double arm[3], l[3], u[3];
        double len = 0.0;
        for (int k = 0; k < 3; ++k) {
            arm[k] = r[k][0] * pj[0] + r[k][1] * pj[1] + r[k][2] * pj[2];
            l[k] = pose[k] + arm[k] - params->base_joint[i][k];
            len += l[k] * l[k];
        }
        len = sqrt(len);
        if (!(len > 1e-6)) {
            return HS_E_RANGE;
        }
        for (int k = 0; k < 3; ++k) {
            u[k] = l[k] / len;
            a[k][i] = u[k];
        }
        a[3][i] = arm[1] * u[2] - arm[2] * u[1];
        a[4][i] = arm[2] * u[0] - arm[0] * u[2];
        a[5][i] = arm[0] * u[1] - arm[1] * u[0];
    }
    for (int k = 0; k < 3; ++k) {
        b[k] = (ext_force != NULL) ? -ext_force[k] : 0.0;
        b[3 + k] = (ext_moment != NULL) ? -ext_moment[k] : 0.0;
    }
    b[2] += params->mass * params->gravity;
    if (params->com[0] != 0.0 || params->com[1] != 0.0 || params->com[2] != 0.0) {
        /* gravity at the centre of mass R c: its moment (R c) x (0, 0, -m g) is held too */
        const double *c = params->com;
        double mg = params->mass * params->gravity;
        double rc0 = r[0][0] * c[0] + r[0][1] * c[1] + r[0][2] * c[2];
        double rc1 = r[1][0] * c[0] + r[1][1] * c[1] + r[1][2] * c[2];
        b[3] += mg * rc1;
        b[4] -= mg * rc0;
    }
    return hs_solve6(a, b, force);
}
