/* SPDX-License-Identifier: Apache-2.0 */
/* ref_model.c - the double-precision reference model of the C tests
 * (ref_model.h). */
#include "ref_model.h"

#include <stddef.h>

void ref_pose_from_sp(const sp_pose_t *pose, double q[6])
{
    for (int k = 0; k < 3; ++k) {
        q[k] = ref_f24(pose->pos[k]);
        q[3 + k] = ref_f24(pose->rpy[k]);
    }
}

void ref_rot(const double rpy[3], double r[3][3])
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

void ref_ik(const sp_platform_t *p, const double q[6], double len[SP_LEGS], double unit[SP_LEGS][3],
            double arm[SP_LEGS][3])
{
    double r[3][3];
    ref_rot(&q[3], r);
    for (int i = 0; i < SP_LEGS; ++i) {
        double a[3], l[3];
        double n = 0;
        for (int c = 0; c < 3; ++c) {
            a[c] = r[c][0] * ref_f24(p->platform_joint[i][0]) + r[c][1] * ref_f24(p->platform_joint[i][1]) +
                   r[c][2] * ref_f24(p->platform_joint[i][2]);
            l[c] = a[c] + q[c] - ref_f24(p->base_joint[i][c]);
            n += l[c] * l[c];
        }
        n = sqrt(n);
        for (int c = 0; c < 3; ++c) {
            if (arm != NULL) {
                arm[i][c] = a[c];
            }
            if (unit != NULL) {
                unit[i][c] = l[c] / n;
            }
        }
        if (len != NULL) {
            len[i] = n;
        }
    }
}

void ref_body_rates_sc(const double sc[4], const double rpy_rate[3], const double rpy_acc[3], double w[3], double wd[3])
{
    double sr = sc[0], cr = sc[1], sp = sc[2], cp = sc[3];
    double dr = rpy_rate[0], dp = rpy_rate[1], dy = rpy_rate[2];
    double ar = rpy_acc[0], ap = rpy_acc[1], ay = rpy_acc[2];
    /* eq (10) */
    w[0] = dr - dy * sp;
    w[1] = dp * cr + dy * cp * sr;
    w[2] = -dp * sr + dy * cp * cr;
    /* its derivative: d(sr)/dt = cr dr, d(cr)/dt = -sr dr, likewise pitch */
    wd[0] = ar - ay * sp - dy * dp * cp;
    wd[1] = ap * cr - dp * dr * sr + ay * cp * sr - dy * dp * sp * sr + dy * dr * cp * cr;
    wd[2] = -ap * sr - dp * dr * cr + ay * cp * cr - dy * dp * sp * cr - dy * dr * cp * sr;
}

void ref_body_rates(const double rpy[3], const double rpy_rate[3], const double rpy_acc[3], double w[3], double wd[3])
{
    const double sc[4] = {sin(rpy[0]), cos(rpy[0]), sin(rpy[1]), cos(rpy[1])};
    ref_body_rates_sc(sc, rpy_rate, rpy_acc, w, wd);
}

void ref_leg_rates(double unit[SP_LEGS][3], double arm[SP_LEGS][3], const double v[3], const double w[3],
                   double rate[SP_LEGS])
{
    for (int i = 0; i < SP_LEGS; ++i) {
        const double *r = arm[i];
        double joint[3] = {v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2],
                           v[2] + w[0] * r[1] - w[1] * r[0]};
        rate[i] = unit[i][0] * joint[0] + unit[i][1] * joint[1] + unit[i][2] * joint[2];
    }
}

void ref_wrench_needed(const sp_platform_t *p, const double q[6], const double qd[6], const double qdd[6],
                       const double ext[3], double wrench[6])
{
    double r[3][3], w[3], wd[3], iw[3], iwd[3], tb[3];
    double mass = ref_f16(p->mass);
    ref_rot(&q[3], r);
    ref_body_rates(&q[3], &qd[3], &qdd[3], w, wd);
    for (int k = 0; k < 3; ++k) {
        iw[k] = 0;
        iwd[k] = 0;
        for (int c = 0; c < 3; ++c) {
            iw[k] += ref_f16(p->inertia[k][c]) * w[c];
            iwd[k] += ref_f16(p->inertia[k][c]) * wd[c];
        }
    }
    /* Euler's equation in the motion frame, then to the base frame */
    tb[0] = iwd[0] + w[1] * iw[2] - w[2] * iw[1];
    tb[1] = iwd[1] + w[2] * iw[0] - w[0] * iw[2];
    tb[2] = iwd[2] + w[0] * iw[1] - w[1] * iw[0];
    for (int k = 0; k < 3; ++k) {
        wrench[k] = mass * qdd[k] - ext[k] + (k == 2 ? mass * ref_f24(p->gravity) : 0.0);
        wrench[3 + k] = r[k][0] * tb[0] + r[k][1] * tb[1] + r[k][2] * tb[2];
    }
}

void ref_wrench_of_forces(const double f[SP_LEGS], double unit[SP_LEGS][3], double arm[SP_LEGS][3], double wrench[6])
{
    for (int k = 0; k < 6; ++k) {
        wrench[k] = 0;
    }
    for (int i = 0; i < SP_LEGS; ++i) {
        const double *u = unit[i];
        const double *a = arm[i];
        wrench[0] += f[i] * u[0];
        wrench[1] += f[i] * u[1];
        wrench[2] += f[i] * u[2];
        wrench[3] += f[i] * (a[1] * u[2] - a[2] * u[1]);
        wrench[4] += f[i] * (a[2] * u[0] - a[0] * u[2]);
        wrench[5] += f[i] * (a[0] * u[1] - a[1] * u[0]);
    }
}
