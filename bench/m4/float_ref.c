/* SPDX-License-Identifier: Apache-2.0 */
/*
 * float_ref.c - single-precision float inverse kinematics and inverse
 * dynamics, step for step the algorithms of the fixed-point core
 * (float_ref.h). Bench code: float is its purpose.
 */
#include <math.h>
#include <stddef.h>

#include "float_ref.h"

#define Q24_TO_F (1.0f / 16777216.0f)
#define Q16_TO_F (1.0f / 65536.0f)

/* pi/2 split in two floats (Cody-Waite) and 2/pi. */
#define HALF_PI_HI 1.57079637050628662109375f
#define HALF_PI_LO (-4.37113900018624283e-8f)
#define TWO_OVER_PI 0.636619772367581343f

/* 1/k!, the core's Taylor coefficients. */
#define INV_FACT2 5.0e-1f
#define INV_FACT3 1.66666666666666667e-1f
#define INV_FACT4 4.16666666666666667e-2f
#define INV_FACT5 8.33333333333333333e-3f
#define INV_FACT6 1.38888888888888889e-3f
#define INV_FACT7 1.98412698412698413e-4f
#define INV_FACT8 2.48015873015873016e-5f
#define INV_FACT9 2.75573192239858907e-6f
#define INV_FACT10 2.75573192239858907e-7f
#define INV_FACT11 2.50521083854417188e-8f
#define INV_FACT12 2.08767569878680990e-9f

#define LEG_COMPONENT_MAX 64.0f
#define LEG_LENGTH_MIN 1.0e-3f
#define PIVOT_MIN 1.0e-3f

void m4f_platform_from_fixed(const sp_platform_t *platform, m4f_platform_t *out)
{
    unsigned i;
    unsigned c;
    for (i = 0u; i < SP_LEGS; ++i) {
        for (c = 0u; c < 3u; ++c) {
            out->base_joint[i][c] = (float)platform->base_joint[i][c] * Q24_TO_F;
            out->platform_joint[i][c] = (float)platform->platform_joint[i][c] * Q24_TO_F;
        }
    }
    out->mass = (float)platform->mass * Q16_TO_F;
    for (i = 0u; i < 3u; ++i) {
        for (c = 0u; c < 3u; ++c) {
            out->inertia[i][c] = (float)platform->inertia[i][c] * Q16_TO_F;
        }
    }
    for (c = 0u; c < 3u; ++c) {
        out->center_of_mass[c] = (float)platform->center_of_mass[c] * Q24_TO_F;
    }
    out->gravity = (float)platform->gravity * Q24_TO_F;
    out->cylinder_mass = (float)platform->leg_mass.cylinder_mass * Q16_TO_F;
    out->cylinder_com = (float)platform->leg_mass.cylinder_com * Q24_TO_F;
    out->rod_mass = (float)platform->leg_mass.rod_mass * Q16_TO_F;
    out->rod_com = (float)platform->leg_mass.rod_com * Q24_TO_F;
    out->leg_inertia = ((float)platform->leg_mass.cylinder_inertia + (float)platform->leg_mass.rod_inertia) * Q16_TO_F;
}

void m4f_motion_from_fixed(const sp_motion_t *motion, m4f_motion_t *out)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        out->pos[k] = (float)motion->pose.pos[k] * Q24_TO_F;
        out->rpy[k] = (float)motion->pose.rpy[k] * Q24_TO_F;
        out->vel[k] = (float)motion->vel[k] * Q24_TO_F;
        out->rpy_rate[k] = (float)motion->rpy_rate[k] * Q24_TO_F;
        out->acc[k] = (float)motion->acc[k] * Q24_TO_F;
        out->rpy_acc[k] = (float)motion->rpy_acc[k] * Q24_TO_F;
    }
}

void m4f_sincos(float x, float *s, float *c)
{
    float t = x * TWO_OVER_PI;
    int32_t n = (int32_t)(t >= 0.0f ? t + 0.5f : t - 0.5f);
    float fn = (float)n;
    float r = (x - fn * HALF_PI_HI) - fn * HALF_PI_LO;
    float r2 = r * r;
    float p;
    float sr;
    float cr;

    p = -INV_FACT11;
    p = INV_FACT9 + r2 * p;
    p = -INV_FACT7 + r2 * p;
    p = INV_FACT5 + r2 * p;
    p = -INV_FACT3 + r2 * p;
    p = 1.0f + r2 * p;
    sr = r * p;

    p = INV_FACT12;
    p = -INV_FACT10 + r2 * p;
    p = INV_FACT8 + r2 * p;
    p = -INV_FACT6 + r2 * p;
    p = INV_FACT4 + r2 * p;
    p = -INV_FACT2 + r2 * p;
    cr = 1.0f + r2 * p;

    switch (((n % 4) + 4) % 4) {
    case 1:
        p = sr;
        sr = cr;
        cr = -p;
        break;
    case 2:
        sr = -sr;
        cr = -cr;
        break;
    case 3:
        p = sr;
        sr = -cr;
        cr = p;
        break;
    default:
        break;
    }
    if (s != NULL) {
        *s = sr;
    }
    if (c != NULL) {
        *c = cr;
    }
}

static void orientation(const float rpy[3], float t[3][3])
{
    float sr;
    float cr;
    float sp;
    float cp;
    float sy;
    float cy;
    float spsr;
    float spcr;

    m4f_sincos(rpy[0], &sr, &cr);
    m4f_sincos(rpy[1], &sp, &cp);
    m4f_sincos(rpy[2], &sy, &cy);
    spsr = sp * sr;
    spcr = sp * cr;
    t[0][0] = cy * cp;
    t[0][1] = sy * cp;
    t[0][2] = -sp;
    t[1][0] = cy * spsr - sy * cr;
    t[1][1] = sy * spsr + cy * cr;
    t[1][2] = cp * sr;
    t[2][0] = cy * spcr + sy * sr;
    t[2][1] = sy * spcr - cy * sr;
    t[2][2] = cp * cr;
}

sp_status_t m4f_inverse_kinematics(const m4f_platform_t *platform, const float pos[3], const float rpy[3], m4f_ik_t *ik)
{
    unsigned i;
    unsigned c;

    if (platform == NULL || pos == NULL || rpy == NULL || ik == NULL) {
        return SP_E_ARG;
    }
    orientation(rpy, ik->rot);
    for (i = 0u; i < SP_LEGS; ++i) {
        const float *a = platform->platform_joint[i];
        float len2 = 0.0f;
        for (c = 0u; c < 3u; ++c) {
            ik->arm[i][c] = a[0] * ik->rot[0][c] + a[1] * ik->rot[1][c] + a[2] * ik->rot[2][c];
            ik->leg[i][c] = (ik->arm[i][c] + pos[c]) - platform->base_joint[i][c];
            if (ik->leg[i][c] >= LEG_COMPONENT_MAX || ik->leg[i][c] <= -LEG_COMPONENT_MAX) {
                return SP_E_RANGE;
            }
            len2 += ik->leg[i][c] * ik->leg[i][c];
        }
        ik->length[i] = sqrtf(len2);
        if (ik->length[i] < LEG_LENGTH_MIN) {
            return SP_E_RANGE;
        }
        for (c = 0u; c < 3u; ++c) {
            ik->unit[i][c] = ik->leg[i][c] / ik->length[i];
        }
    }
    return SP_OK;
}

sp_status_t m4f_body_rates(const float rpy[3], const float rpy_rate[3], const float rpy_acc[3], float omega[3],
                           float omega_dot[3])
{
    float sr;
    float cr;
    float sp;
    float cp;
    float dr;
    float dp;
    float dy;
    float dp_dr;
    float dy_dp;
    float dy_dr;

    if (rpy == NULL || rpy_rate == NULL || rpy_acc == NULL || omega == NULL || omega_dot == NULL) {
        return SP_E_ARG;
    }
    m4f_sincos(rpy[0], &sr, &cr);
    m4f_sincos(rpy[1], &sp, &cp);
    dr = rpy_rate[0];
    dp = rpy_rate[1];
    dy = rpy_rate[2];
    omega[0] = dr - dy * sp;
    omega[1] = dp * cr + dy * (cp * sr);
    omega[2] = -dp * sr + dy * (cp * cr);
    dp_dr = dp * dr;
    dy_dp = dy * dp;
    dy_dr = dy * dr;
    omega_dot[0] = rpy_acc[0] - rpy_acc[2] * sp - dy_dp * cp;
    omega_dot[1] = rpy_acc[1] * cr - dp_dr * sr + rpy_acc[2] * (cp * sr) - dy_dp * (sp * sr) + dy_dr * (cp * cr);
    omega_dot[2] = -rpy_acc[1] * sr - dp_dr * cr + rpy_acc[2] * (cp * cr) - dy_dp * (sp * cr) - dy_dr * (cp * sr);
    return SP_OK;
}

static void inertia_times(const float inertia[3][3], const float v[3], float out[3])
{
    unsigned r;
    for (r = 0u; r < 3u; ++r) {
        out[r] = inertia[r][0] * v[0] + inertia[r][1] * v[1] + inertia[r][2] * v[2];
    }
}

/* Solves J^T x = b for the 6x6 leg Jacobian J (rows [u_i, r_i x u_i]) by
 * Gaussian elimination with partial pivoting. */
static sp_status_t solve6_transposed(float jac[SP_LEGS][6], const float b[SP_LEGS], float x[SP_LEGS])
{
    float a[SP_LEGS][SP_LEGS];
    float r[SP_LEGS];
    unsigned i;
    unsigned j;
    unsigned k;

    for (i = 0u; i < SP_LEGS; ++i) {
        for (j = 0u; j < SP_LEGS; ++j) {
            a[i][j] = jac[j][i];
        }
        r[i] = b[i];
        x[i] = 0.0f;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        unsigned p = k;
        for (i = k + 1u; i < SP_LEGS; ++i) {
            if (fabsf(a[i][k]) > fabsf(a[p][k])) {
                p = i;
            }
        }
        if (fabsf(a[p][k]) < PIVOT_MIN) {
            return SP_E_SINGULAR;
        }
        if (p != k) {
            float tr = r[k];
            r[k] = r[p];
            r[p] = tr;
            for (j = 0u; j < SP_LEGS; ++j) {
                float t = a[k][j];
                a[k][j] = a[p][j];
                a[p][j] = t;
            }
        }
        for (i = k + 1u; i < SP_LEGS; ++i) {
            float l = a[i][k] / a[k][k];
            if (l == 0.0f) {
                continue;
            }
            for (j = k + 1u; j < SP_LEGS; ++j) {
                a[i][j] -= l * a[k][j];
            }
            a[i][k] = 0.0f;
            r[i] -= r[k] * l;
        }
    }
    for (k = SP_LEGS; k-- > 0u;) {
        float s = r[k];
        for (j = k + 1u; j < SP_LEGS; ++j) {
            s -= x[j] * a[k][j];
        }
        x[k] = s / a[k][k];
    }
    return SP_OK;
}

static void cross3(const float a[3], const float b[3], float out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* The legs' reactions at their platform joints (the core's leg_terms, in
 * float, the same formulas): with q = 1/L, e = d_c q, y = d_r q, z = 1 - y,
 *   h_i = mu a_A + c1 v_A + k_g g e_z  (wrench about o' added to b),
 *   s_i = (m_r - mu) u.a_A + (m_r - k_g) g u_z + m_r d_r q^2 (|v_A|^2 - L'^2)
 *         - c1 L'                      (added to F_i),
 *   mu = m_c e^2 + m_r z^2, k_g = m_c e + m_r z, c1 = -2 L' q (m_c e^2 - m_r y z),
 * v_A = v + w_b x r, a_A = a + w_b' x r + w_b x (w_b x r), L' = u.v_A. */
static void leg_terms(const m4f_platform_t *p, const m4f_motion_t *m, const m4f_ik_t *ik, const float w[3],
                      const float wd[3], float b[SP_LEGS], float axial[SP_LEGS])
{
    float wb[3], ab[3];
    unsigned i;
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        wb[k] = ik->rot[0][k] * w[0] + ik->rot[1][k] * w[1] + ik->rot[2][k] * w[2];
        ab[k] = ik->rot[0][k] * wd[0] + ik->rot[1][k] * wd[1] + ik->rot[2][k] * wd[2];
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        const float *r = ik->arm[i];
        const float *u = ik->unit[i];
        float wr[3], va[3], aa[3], t[3], hw[3], mom[3];
        float q = 1.0f / ik->length[i];
        float e = p->cylinder_com * q;
        float y = p->rod_com * q;
        float z = 1.0f - y;
        float iq2 = p->leg_inertia * q * q; /* the legs' inertia across the leg, I / L^2 */
        float mu = p->cylinder_mass * e * e + p->rod_mass * z * z + iq2;
        float kg = p->cylinder_mass * e + p->rod_mass * z;
        float cl = q * (p->cylinder_mass * e * e - p->rod_mass * y * z + iq2); /* C / L */
        float ld, ua, vv, c1, guz;
        cross3(wb, r, wr);
        cross3(ab, r, aa);
        cross3(wb, wr, t);
        for (k = 0u; k < 3u; ++k) {
            va[k] = m->vel[k] + wr[k];
            aa[k] += m->acc[k] + t[k];
        }
        ld = u[0] * va[0] + u[1] * va[1] + u[2] * va[2];
        ua = u[0] * aa[0] + u[1] * aa[1] + u[2] * aa[2];
        vv = va[0] * va[0] + va[1] * va[1] + va[2] * va[2] - ld * ld;
        c1 = -2.0f * cl * ld;
        guz = p->gravity * u[2];
        for (k = 0u; k < 3u; ++k) {
            hw[k] = mu * aa[k] + c1 * va[k];
        }
        hw[2] += kg * p->gravity;
        cross3(r, hw, mom);
        for (k = 0u; k < 3u; ++k) {
            b[k] += hw[k];
            b[3u + k] += mom[k];
        }
        axial[i] = (p->rod_mass - mu) * ua + (p->rod_mass - kg) * guz + p->rod_mass * y * q * vv - c1 * ld;
    }
}

sp_status_t m4f_inverse_dynamics(const m4f_platform_t *platform, const m4f_motion_t *motion, const m4f_ik_t *ik,
                                 float force[SP_LEGS])
{
    float omega[3];
    float omega_dot[3];
    float h[3];
    float i_wdot[3];
    float torque_body[3];
    float jac[SP_LEGS][6];
    float b[SP_LEGS];
    float axial[SP_LEGS] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    sp_status_t st;
    unsigned k;

    if (force == NULL) {
        return SP_E_ARG;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        force[k] = 0.0f;
    }
    if (platform == NULL || motion == NULL || ik == NULL) {
        return SP_E_ARG;
    }
    st = m4f_body_rates(motion->rpy, motion->rpy_rate, motion->rpy_acc, omega, omega_dot);
    if (st != SP_OK) {
        return st;
    }
    /* Translation (eq 7): sum F_i u_i = m a + m g e_z. */
    for (k = 0u; k < 3u; ++k) {
        b[k] = platform->mass * motion->acc[k];
    }
    b[2] += platform->mass * platform->gravity;
    /* Rotation: I dw/dt + w x (I w), motion frame, then R = T^T. */
    inertia_times(platform->inertia, omega, h);
    inertia_times(platform->inertia, omega_dot, i_wdot);
    torque_body[0] = i_wdot[0] + (h[2] * omega[1] - h[1] * omega[2]);
    torque_body[1] = i_wdot[1] + (h[0] * omega[2] - h[2] * omega[0]);
    torque_body[2] = i_wdot[2] + (h[1] * omega[0] - h[0] * omega[1]);
    {
        /* centre of mass c off o': m c x T (a + g e_z) to the body moment,
         * m R (w' x c + w x (w x c)) to the force */
        const float *cm = platform->center_of_mass;
        if (cm[0] != 0.0f || cm[1] != 0.0f || cm[2] != 0.0f) {
            float mc[3], wc[3], kb[3], ab[3];
            for (k = 0u; k < 3u; ++k) {
                mc[k] = platform->mass * cm[k];
            }
            cross3(omega, mc, wc);
            cross3(omega_dot, mc, kb);
            cross3(omega, wc, h);
            for (k = 0u; k < 3u; ++k) {
                kb[k] += h[k];
                ab[k] = ik->rot[k][0] * motion->acc[0] + ik->rot[k][1] * motion->acc[1] +
                        ik->rot[k][2] * (motion->acc[2] + platform->gravity);
            }
            for (k = 0u; k < 3u; ++k) {
                b[k] += ik->rot[0][k] * kb[0] + ik->rot[1][k] * kb[1] + ik->rot[2][k] * kb[2];
            }
            cross3(mc, ab, h);
            for (k = 0u; k < 3u; ++k) {
                torque_body[k] += h[k];
            }
        }
    }
    for (k = 0u; k < 3u; ++k) {
        b[3u + k] = torque_body[0] * ik->rot[0][k] + torque_body[1] * ik->rot[1][k] + torque_body[2] * ik->rot[2][k];
    }
    if (platform->cylinder_mass != 0.0f || platform->rod_mass != 0.0f || platform->leg_inertia != 0.0f) {
        leg_terms(platform, motion, ik, omega, omega_dot, b, axial);
    }
    /* The leg Jacobian, rows [u_i, (A_im T) x u_i]. */
    for (k = 0u; k < SP_LEGS; ++k) {
        const float *r = ik->arm[k];
        const float *u = ik->unit[k];
        jac[k][0] = u[0];
        jac[k][1] = u[1];
        jac[k][2] = u[2];
        jac[k][3] = r[1] * u[2] - r[2] * u[1];
        jac[k][4] = r[2] * u[0] - r[0] * u[2];
        jac[k][5] = r[0] * u[1] - r[1] * u[0];
    }
    st = solve6_transposed(jac, b, force);
    for (k = 0u; k < SP_LEGS; ++k) {
        force[k] += axial[k];
    }
    if (st != SP_OK) {
        for (k = 0u; k < SP_LEGS; ++k) {
            force[k] = 0.0f;
        }
    }
    return st;
}
