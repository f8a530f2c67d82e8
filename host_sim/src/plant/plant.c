/* SPDX-License-Identifier: Apache-2.0 */
/* plant.c - the simulated hydraulic hexapod (hs/plant.h). */
#include "hs/plant.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "cyl_model.h"

#include "hs/kin.h"

/* What one evaluation of the right-hand side computes besides dx. */
typedef struct {
    double length[HS_LEGS];
    double rate[HS_LEGS];
    double force[HS_LEGS];
    double friction[HS_LEGS];
    double contact[3];
    double contact_moment[3]; /* about o', base frame */
} aux_t;

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* m is a row-major 3x3 matrix (&a[0][0]). */
static void mat_vec(const double *m, const double v[3], double out[3])
{
    for (int r = 0; r < 3; ++r) {
        out[r] = m[3 * r] * v[0] + m[3 * r + 1] * v[1] + m[3 * r + 2] * v[2];
    }
}

static void mat_t_vec(const double *m, const double v[3], double out[3])
{
    for (int c = 0; c < 3; ++c) {
        out[c] = m[c] * v[0] + m[3 + c] * v[1] + m[6 + c] * v[2];
    }
}

static int invert3(double m[3][3], double out[3][3])
{
    double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    double c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    double c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if (!(fabs(det) > 0.0) || !isfinite(det)) {
        return 0;
    }
    out[0][0] = c00 / det;
    out[1][0] = c01 / det;
    out[2][0] = c02 / det;
    out[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
    out[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
    out[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
    out[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
    out[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
    out[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
    return 1;
}

/* Force of the contact on the platform (base frame) at contact point
 * position pc and velocity vc; elastic-only when vc is NULL. */
static void contact_force(const hs_contact_t *ct, const double pc[3], const double vc[3], double f[3])
{
    f[0] = f[1] = f[2] = 0.0;
    if (ct->kind == HS_CONTACT_PLANE) {
        double pen = ct->offset - (ct->normal[0] * pc[0] + ct->normal[1] * pc[1] + ct->normal[2] * pc[2]);
        if (pen > 0.0) {
            double vn = (vc != NULL) ? ct->normal[0] * vc[0] + ct->normal[1] * vc[1] + ct->normal[2] * vc[2] : 0.0;
            double fn = ct->stiffness * pen - ct->damping * vn;
            if (fn > 0.0) {
                for (int k = 0; k < 3; ++k) {
                    f[k] = fn * ct->normal[k];
                }
            }
        }
    } else if (ct->kind == HS_CONTACT_POINT) {
        for (int k = 0; k < 3; ++k) {
            f[k] = -ct->stiffness * (pc[k] - ct->anchor[k]) - ((vc != NULL) ? ct->damping * vc[k] : 0.0);
        }
    }
}

/* Leg masses (docs/explanation/plant.md "Leg masses"). Leg i is two rigid bodies on
 * its axis u = (A - B)/L: the cylinder body m_c at B + d_c u and the rod
 * m_r at A - d_r u, each with its moment of inertia across the leg about
 * its centre (I_c, I_r; symmetric about the axis, no spin about it), so its
 * configuration follows from the platform joint A alone. The bodies turn
 * with the leg's angular velocity u x u', whose rate is u x u''. By virtual
 * work the leg acts on the platform at A with
 *   F = -M a_A + b,   M = m_r u u^T + mu P,   mu = (J_c + m_r (L - d_r)^2) / L^2,
 *   b = -(1/L) P ((J_c) beta + m_c d_c g e_z) - m_r S (-d_r beta + g e_z),
 * J_c = m_c d_c^2 + I_c + I_r, P = I - u u^T, S = I - (d_r/L) P, and
 * beta = u'' - P a_A / L the velocity part of
 * u'' = (P a_A - 2 L' u' - (|v_A|^2 - L'^2)/L u) / L.
 * This function computes M and b from u, L and the joint velocity v_A
 * (base frame); va = NULL means at rest. */
static void leg_mass_terms(const hs_cyl_params_t *c, const double un[3], double len, const double *va, double g,
                           double mm[3][3], double b[3])
{
    double mc = c->cylinder_mass, dc = c->cylinder_com, mr = c->rod_mass, dr = c->rod_com;
    double jc = mc * dc * dc + c->cylinder_inertia + c->rod_inertia;
    double mu = (jc + mr * (len - dr) * (len - dr)) / (len * len);
    double beta[3] = {0.0, 0.0, 0.0}, y1[3], y2[3], py1[3], py2[3], d1, d2;
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) {
            mm[r][k] = (mr - mu) * un[r] * un[k] + ((r == k) ? mu : 0.0);
        }
    }
    if (va != NULL) {
        double ld = un[0] * va[0] + un[1] * va[1] + un[2] * va[2];
        double vn2 = va[0] * va[0] + va[1] * va[1] + va[2] * va[2] - ld * ld;
        for (int k = 0; k < 3; ++k) {
            double ud = (va[k] - ld * un[k]) / len;
            beta[k] = -(2.0 * ld * ud + vn2 / len * un[k]) / len;
        }
    }
    for (int k = 0; k < 3; ++k) {
        y1[k] = dc * beta[k];
        y2[k] = -dr * beta[k];
    }
    y1[2] += g;
    y2[2] += g;
    d1 = un[0] * y1[0] + un[1] * y1[1] + un[2] * y1[2];
    d2 = un[0] * y2[0] + un[1] * y2[1] + un[2] * y2[2];
    for (int k = 0; k < 3; ++k) {
        py1[k] = y1[k] - d1 * un[k];
        py2[k] = y2[k] - d2 * un[k];
        b[k] = -(dc / len) * mc * py1[k] - mr * (y2[k] - (dr / len) * py2[k]);
    }
    if (c->cylinder_inertia > 0.0 || c->rod_inertia > 0.0) {
        /* the inertias' part of J_c: -(I_c + I_r) / L P beta */
        double ib = (c->cylinder_inertia + c->rod_inertia) / len;
        double pb = un[0] * beta[0] + un[1] * beta[1] + un[2] * beta[2];
        for (int k = 0; k < 3; ++k) {
            b[k] -= ib * (beta[k] - pb * un[k]);
        }
    }
}

/* Geometry of leg i at state x: arm R a_i, unit vector, length and (if va
 * is not NULL) the platform joint's velocity, all base frame. */
static void leg_geometry(const hs_plant_t *pl, const double *x, double r[3][3], int i, double arm[3], double un[3],
                         double *len, double *va)
{
    const hs_params_t *p = &pl->par;
    double l[3];
    mat_vec(&r[0][0], p->platform_joint[i], arm);
    for (int k = 0; k < 3; ++k) {
        l[k] = x[HS_X_POS + k] + arm[k] - p->base_joint[i][k];
    }
    *len = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (int k = 0; k < 3; ++k) {
        un[k] = l[k] / *len;
    }
    if (va != NULL) {
        double wb[3], wxa[3];
        mat_vec(&r[0][0], &x[HS_X_OMEGA], wb);
        cross(wb, arm, wxa);
        for (int k = 0; k < 3; ++k) {
            va[k] = x[HS_X_VEL + k] + wxa[k];
        }
    }
}

/* I_base = R I R^T: the platform's inertia about o' in the base frame. */
static void inertia_base(const hs_params_t *p, double r[3][3], double ib[3][3])
{
    double ri[3][3];
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            ri[j][k] = r[j][0] * p->inertia[0][k] + r[j][1] * p->inertia[1][k] + r[j][2] * p->inertia[2][k];
        }
    }
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            ib[j][k] = ri[j][0] * r[k][0] + ri[j][1] * r[k][1] + ri[j][2] * r[k][2];
        }
    }
}

/* The centre of mass at R c from o' into the coupled equations a acc = rhs:
 * m (v' + w' x rc + w x (w x rc)) = f, I w' + w x (I w) + m rc x v' = tau
 * (about o', base frame). */
static void add_com_terms(const hs_params_t *p, double r[3][3], const double wb[3], double a[6][6], double rhs[6])
{
    double rc[3], wxr[3], cen[3], mm = p->mass;
    mat_vec(&r[0][0], p->com, rc);
    a[0][4] += mm * rc[2];
    a[0][5] -= mm * rc[1];
    a[1][3] -= mm * rc[2];
    a[1][5] += mm * rc[0];
    a[2][3] += mm * rc[1];
    a[2][4] -= mm * rc[0];
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            a[3 + k][j] = a[j][3 + k];
        }
    }
    cross(wb, rc, wxr);
    cross(wb, wxr, cen);
    for (int k = 0; k < 3; ++k) {
        rhs[k] -= mm * cen[k];
    }
}

/* Leg i's mass (leg_mass_terms) into the coupled equations a acc = rhs: it
 * acts at the platform joint (arm from o', base frame) with
 * a_A = v' + K w' + w x (w x arm), K = -[arm]x. */
static void add_leg_terms(const hs_plant_t *pl, int i, const double *x, const double wb[3], const double arm[3],
                          const double un[3], double len, double a[6][6], double rhs[6])
{
    double va[3], mm[3][3], b[3], kk[3][3], mk[3][3], wxa[3], cen[3], fb[3], m[3];
    cross(wb, arm, wxa);
    for (int k = 0; k < 3; ++k) {
        va[k] = x[HS_X_VEL + k] + wxa[k];
    }
    leg_mass_terms(&pl->par.cyl[i], un, len, va, pl->par.gravity, mm, b);
    kk[0][0] = 0.0;
    kk[0][1] = arm[2];
    kk[0][2] = -arm[1];
    kk[1][0] = -arm[2];
    kk[1][1] = 0.0;
    kk[1][2] = arm[0];
    kk[2][0] = arm[1];
    kk[2][1] = -arm[0];
    kk[2][2] = 0.0;
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            mk[j][k] = mm[j][0] * kk[0][k] + mm[j][1] * kk[1][k] + mm[j][2] * kk[2][k];
        }
    }
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
            a[j][k] += mm[j][k];
            a[j][3 + k] += mk[j][k];
            a[3 + k][j] += mk[j][k];
            a[3 + j][3 + k] += kk[0][j] * mk[0][k] + kk[1][j] * mk[1][k] + kk[2][j] * mk[2][k];
        }
    }
    cross(wb, wxa, cen);
    for (int k = 0; k < 3; ++k) {
        fb[k] = b[k] - (mm[k][0] * cen[0] + mm[k][1] * cen[1] + mm[k][2] * cen[2]);
    }
    cross(arm, fb, m);
    for (int k = 0; k < 3; ++k) {
        rhs[k] += fb[k];
        rhs[3 + k] += m[k];
    }
}

/* With leg masses or a centre of mass off o': solves the coupled platform
 * (+ legs) equations for v' and the base-frame angular acceleration
 * (docs/explanation/plant.md). f, tau: the wrench of everything else (base frame, at
 * o', gravity included). Returns 0 if singular. */
static int legs_accel(const hs_plant_t *pl, const double *x, double r[3][3], const double wb[3],
                      double arms[HS_LEGS][3], double uns[HS_LEGS][3], const double lens[HS_LEGS], const double f[3],
                      const double tau[3], double acc[6])
{
    const hs_params_t *p = &pl->par;
    double a[6][6], rhs[6], ib[3][3], ibw[3], gyro[3];
    inertia_base(p, r, ib);
    memset(a, 0, sizeof a);
    for (int j = 0; j < 3; ++j) {
        a[j][j] = p->mass;
        for (int k = 0; k < 3; ++k) {
            a[3 + j][3 + k] = ib[j][k];
        }
    }
    mat_vec(&ib[0][0], wb, ibw);
    cross(wb, ibw, gyro);
    for (int k = 0; k < 3; ++k) {
        rhs[k] = f[k];
        rhs[3 + k] = tau[k] - gyro[k];
    }
    if (pl->com_on) {
        add_com_terms(p, r, wb, a, rhs);
    }
    for (int i = 0; i < HS_LEGS && pl->legs_on; ++i) {
        add_leg_terms(pl, i, x, wb, arms[i], uns[i], lens[i], a, rhs);
    }
    return hs_solve6(a, rhs, acc) == HS_OK;
}

/* The wrench on the platform without the legs and the contact: the
 * external one and gravity (at the centre of mass R c); base frame, at o'. */
static void external_wrench(const hs_plant_t *pl, double r[3][3], double f[3], double tau[3])
{
    const hs_params_t *p = &pl->par;
    f[0] = pl->ext_force[0];
    f[1] = pl->ext_force[1];
    f[2] = pl->ext_force[2] - p->mass * p->gravity;
    tau[0] = pl->ext_moment[0];
    tau[1] = pl->ext_moment[1];
    tau[2] = pl->ext_moment[2];
    if (pl->com_on) {
        /* gravity acts at the centre of mass R c: moment (R c) x (0, 0, -m g) */
        double rc[3], mg = p->mass * p->gravity;
        mat_vec(&r[0][0], p->com, rc);
        tau[0] -= mg * rc[1];
        tau[1] += mg * rc[0];
    }
}

/* Each leg's arm R a_i, unit vector, length and extension rate at state x
 * (base frame). */
static void legs_kinematics(const hs_plant_t *pl, const double *x, double r[3][3], const double wb[3],
                            double arm[HS_LEGS][3], double un[HS_LEGS][3], double len[HS_LEGS], double ldot[HS_LEGS])
{
    const hs_params_t *p = &pl->par;
    const double *v = &x[HS_X_VEL];
    for (int i = 0; i < HS_LEGS; ++i) {
        double l[3], wxa[3], inv;
        mat_vec(&r[0][0], p->platform_joint[i], arm[i]);
        cross(wb, arm[i], wxa);
        for (int k = 0; k < 3; ++k) {
            l[k] = x[HS_X_POS + k] + arm[i][k] - p->base_joint[i][k];
        }
        len[i] = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
        inv = 1.0 / len[i];
        ldot[i] = 0.0;
        for (int k = 0; k < 3; ++k) {
            un[i][k] = l[k] * inv;
            ldot[i] += un[i][k] * (v[k] + wxa[k]);
        }
    }
}

/* Each cylinder's force fi and friction ffr and its states' derivatives
 * (hydraulic mode), or the ideal forces (the cylinder states stand still). */
static void cylinders(const hs_plant_t *pl, const double *x, const double u[HS_LEGS], const double len[HS_LEGS],
                      const double ldot[HS_LEGS], double *dx, double fi[HS_LEGS], double ffr[HS_LEGS])
{
    const hs_params_t *p = &pl->par;
    if (pl->act == HS_ACT_HYDRAULIC) {
        for (int i = 0; i < HS_LEGS; ++i) {
            const double *xc = &x[HS_X_CYL + 4 * i];
            double *dc = &dx[HS_X_CYL + 4 * i];
            hs_cyl_state_t st = {xc[0], xc[1], xc[2], xc[3], x[HS_X_BRISTLE + i]};
            hs_cyl_eval_t ev;
            hs__cyl_eval(&p->cyl[i], &st, len[i] - p->cyl[i].length_min, ldot[i], u[i], pl->drive[i].block, &ev);
            fi[i] = ev.force;
            ffr[i] = ev.friction;
            dc[0] = ev.dpa;
            dc[1] = ev.dpb;
            dc[2] = ev.dxv;
            dc[3] = ev.dxv_rate;
            dx[HS_X_BRISTLE + i] = ev.dz;
        }
    } else {
        for (int i = 0; i < HS_LEGS; ++i) {
            double *dc = &dx[HS_X_CYL + 4 * i];
            fi[i] = pl->ideal_force[i];
            ffr[i] = 0.0;
            dc[0] = dc[1] = dc[2] = dc[3] = 0.0;
            dx[HS_X_BRISTLE + i] = 0.0;
        }
    }
}

/* The contact's force and moment about o' added to (f, tau) (base frame);
 * into aux too if it is not NULL. */
static void add_contact(const hs_plant_t *pl, const double *x, double r[3][3], const double wb[3], double f[3],
                        double tau[3], aux_t *aux)
{
    if (pl->contact.kind != HS_CONTACT_NONE) {
        double ca[3], pc[3], vc[3], wxa[3], fc[3], m[3];
        mat_vec(&r[0][0], pl->contact.point, ca);
        cross(wb, ca, wxa);
        for (int k = 0; k < 3; ++k) {
            pc[k] = x[HS_X_POS + k] + ca[k];
            vc[k] = x[HS_X_VEL + k] + wxa[k];
        }
        contact_force(&pl->contact, pc, vc, fc);
        cross(ca, fc, m);
        for (int k = 0; k < 3; ++k) {
            f[k] += fc[k];
            tau[k] += m[k];
        }
        if (aux != NULL) {
            memcpy(aux->contact, fc, sizeof fc);
            memcpy(aux->contact_moment, m, sizeof m);
        }
    } else if (aux != NULL) {
        aux->contact[0] = aux->contact[1] = aux->contact[2] = 0.0;
        aux->contact_moment[0] = aux->contact_moment[1] = aux->contact_moment[2] = 0.0;
    }
}

/* The rigid body's derivatives (position, velocity, body rate) under the
 * wrench (f, tau): the coupled equations with leg masses or a centre of
 * mass off o', else Newton-Euler about the centre of mass at o'. */
static void platform_derivs(const hs_plant_t *pl, const double *x, double r[3][3], const double wb[3],
                            double arm[HS_LEGS][3], double un[HS_LEGS][3], const double len[HS_LEGS], const double f[3],
                            const double tau[3], double *dx)
{
    const double *v = &x[HS_X_VEL];
    const double *w = &x[HS_X_OMEGA];
    double dw[3];
    if (pl->legs_on || pl->com_on) {
        double acc[6];
        if (!legs_accel(pl, x, r, wb, arm, un, len, f, tau, acc)) {
            for (int k = 0; k < 6; ++k) {
                acc[k] = NAN; /* the step sees a non-finite state: HS_E_NUMERIC */
            }
        }
        for (int k = 0; k < 3; ++k) {
            dx[HS_X_POS + k] = v[k];
            dx[HS_X_VEL + k] = acc[k];
        }
        mat_t_vec(&r[0][0], &acc[3], dw);
    } else {
        double taub[3], iw[3], gyro[3], rhs[3];
        for (int k = 0; k < 3; ++k) {
            dx[HS_X_POS + k] = v[k];
            dx[HS_X_VEL + k] = f[k] * pl->inv_mass;
        }
        mat_t_vec(&r[0][0], tau, taub);
        mat_vec(&pl->par.inertia[0][0], w, iw);
        cross(w, iw, gyro);
        for (int k = 0; k < 3; ++k) {
            rhs[k] = taub[k] - gyro[k];
        }
        mat_vec(&pl->inertia_inv[0][0], rhs, dw);
    }
    for (int k = 0; k < 3; ++k) {
        dx[HS_X_OMEGA + k] = dw[k];
    }
}

/* Right-hand side: dx = f(x) with valve commands u (hydraulic mode). */
static void derivs(const hs_plant_t *pl, const double *x, const double u[HS_LEGS], double *dx, aux_t *aux)
{
    const double *q = &x[HS_X_QUAT];
    const double *w = &x[HS_X_OMEGA];
    double r[3][3], wb[3], f[3], tau[3];

    hs_rot_from_quat(q, r);
    mat_vec(&r[0][0], w, wb);
    external_wrench(pl, r, f, tau);

    /* Three passes over the legs (geometry, cylinders, wrench): the legs are
     * independent, so the square roots and divisions of different legs
     * overlap in the processor instead of forming one long chain. */
    double arm[HS_LEGS][3], un[HS_LEGS][3], len[HS_LEGS], ldot[HS_LEGS], fi[HS_LEGS], ffr[HS_LEGS];
    legs_kinematics(pl, x, r, wb, arm, un, len, ldot);
    cylinders(pl, x, u, len, ldot, dx, fi, ffr);
    for (int i = 0; i < HS_LEGS; ++i) {
        double fv[3], m[3];
        for (int k = 0; k < 3; ++k) {
            fv[k] = fi[i] * un[i][k];
            f[k] += fv[k];
        }
        cross(arm[i], fv, m);
        for (int k = 0; k < 3; ++k) {
            tau[k] += m[k];
        }
    }
    if (aux != NULL) {
        for (int i = 0; i < HS_LEGS; ++i) {
            aux->length[i] = len[i];
            aux->rate[i] = ldot[i];
            aux->force[i] = fi[i];
            aux->friction[i] = ffr[i];
        }
    }
    add_contact(pl, x, r, wb, f, tau, aux);
    platform_derivs(pl, x, r, wb, arm, un, len, f, tau, dx);
    dx[HS_X_QUAT + 0] = -0.5 * (q[1] * w[0] + q[2] * w[1] + q[3] * w[2]);
    dx[HS_X_QUAT + 1] = 0.5 * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1]);
    dx[HS_X_QUAT + 2] = 0.5 * (q[0] * w[1] + q[3] * w[0] - q[1] * w[2]);
    dx[HS_X_QUAT + 3] = 0.5 * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0]);
}

static const double zero_u[HS_LEGS] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};

static double measure_pressure(hs_plant_t *pl, double p)
{
    const hs_sensor_params_t *s = &pl->par.sensors;
    double m = p + s->pressure_noise * hs_rng_gauss(&pl->rng);
    return (m > 0.0) ? m : 0.0;
}

/* What the length sensor of leg i reads at the true length len: the sensor as
 * built (zero and scale, hs_sensor_params_t), then any injected fault. */
static double sensed_length(hs_plant_t *pl, int i, double true_len)
{
    const hs_sensor_params_t *s = &pl->par.sensors;
    double lmin = pl->par.cyl[i].length_min;
    double len = lmin + (1.0 + s->length_scale[i]) * (true_len - lmin) + s->length_zero[i];
    switch (pl->inj.sensor[i]) {
    case HS_SENSOR_STICK:
        return pl->inj.sensor_value[i];
    case HS_SENSOR_JUMP:
        return len + pl->inj.sensor_value[i];
    case HS_SENSOR_NOISE:
        return len + pl->inj.sensor_value[i] * hs_rng_gauss(&pl->inj.rng);
    case HS_SENSOR_OK:
    default:
        return len;
    }
}

static void sample_feedback(hs_plant_t *pl, const aux_t *aux)
{
    const hs_sensor_params_t *s = &pl->par.sensors;
    for (int i = 0; i < HS_LEGS; ++i) {
        hs_feedback_t *fb = &pl->fb[i];
        double pa, pb;
        if (pl->act == HS_ACT_HYDRAULIC) {
            pa = pl->x[HS_X_CYL + 4 * i];
            pb = pl->x[HS_X_CYL + 4 * i + 1];
        } else {
            hs_cyl_holding_pressures(&pl->par.cyl[i], pl->ideal_force[i], &pa, &pb);
        }
        fb->length_counts = hs_quantize(sensed_length(pl, i, aux->length[i]), s->length_resolution);
        fb->length = (double)fb->length_counts * s->length_resolution;
        fb->pressure_a_counts = hs_quantize(measure_pressure(pl, pa), s->pressure_resolution);
        fb->pressure_b_counts = hs_quantize(measure_pressure(pl, pb), s->pressure_resolution);
        fb->pressure_a = (double)fb->pressure_a_counts * s->pressure_resolution;
        fb->pressure_b = (double)fb->pressure_b_counts * s->pressure_resolution;
        fb->state = pl->drive[i].state;
        fb->faults = pl->drive[i].faults;
        fb->cycle = pl->cycle;
    }
}

static int state_finite(const double *x)
{
    for (int k = 0; k < HS_NX; ++k) {
        if (!isfinite(x[k])) {
            return 0;
        }
    }
    return 1;
}

static void clamp_state(hs_plant_t *pl)
{
    double *q = &pl->x[HS_X_QUAT];
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (n > 0.0) {
        for (int k = 0; k < 4; ++k) {
            q[k] /= n;
        }
    }
    for (int i = 0; i < HS_LEGS; ++i) {
        double pmax = pl->par.cyl[i].pressure_max;
        for (int k = 0; k < 2; ++k) {
            double *pp = &pl->x[HS_X_CYL + 4 * i + k];
            if (*pp < 0.0) {
                *pp = 0.0;
            } else if (*pp > pmax) {
                *pp = pmax;
            }
        }
    }
}

/* Adds the wrench of the legs' weight on the platform at rest (force at o'
 * and moment about o', base frame) at the current pose. */
static void add_leg_gravity(const hs_plant_t *pl, double fext[3], double mext[3])
{
    double r[3][3];
    hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
    for (int i = 0; i < HS_LEGS; ++i) {
        double arm[3], un[3], len, mm[3][3], b[3], m[3];
        leg_geometry(pl, pl->x, r, i, arm, un, &len, NULL);
        leg_mass_terms(&pl->par.cyl[i], un, len, NULL, pl->par.gravity, mm, b);
        cross(arm, b, m);
        for (int k = 0; k < 3; ++k) {
            fext[k] += b[k];
            mext[k] += m[k];
        }
    }
}

/* Static forces at the current pose for gravity, the external wrench, the
 * contact's elastic force and (if on) the legs' weight. */
static hs_status_t current_static_forces(const hs_plant_t *pl, double force[HS_LEGS])
{
    double pose[6], fext[3], mext[3];
    hs_plant_pose(pl, pose);
    memcpy(fext, pl->ext_force, sizeof fext);
    memcpy(mext, pl->ext_moment, sizeof mext);
    if (pl->legs_on) {
        add_leg_gravity(pl, fext, mext);
    }
    if (pl->contact.kind != HS_CONTACT_NONE) {
        double r[3][3], arm[3], pc[3], fc[3], m[3];
        hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
        mat_vec(&r[0][0], pl->contact.point, arm);
        for (int k = 0; k < 3; ++k) {
            pc[k] = pl->x[HS_X_POS + k] + arm[k];
        }
        contact_force(&pl->contact, pc, NULL, fc);
        cross(arm, fc, m);
        for (int k = 0; k < 3; ++k) {
            fext[k] += fc[k];
            mext[k] += m[k];
        }
    }
    return hs_static_forces(&pl->par, pose, fext, mext, force);
}

static void set_holding(hs_plant_t *pl, const double force[HS_LEGS])
{
    for (int i = 0; i < HS_LEGS; ++i) {
        double *xc = &pl->x[HS_X_CYL + 4 * i];
        pl->ideal_force[i] = force[i];
        hs_cyl_holding_pressures(&pl->par.cyl[i], force[i], &xc[0], &xc[1]);
        xc[2] = 0.0;
        xc[3] = 0.0;
        pl->x[HS_X_BRISTLE + i] = 0.0; /* the pressures hold it all */
        pl->valve_cmd[i] = 0.0;
        pl->drive[i].spool_model = 0.0; /* the drive's valve monitor sees the spool where it is */
        pl->drive[i].spool_model_rate = 0.0;
    }
}

hs_status_t hs_plant_init(hs_plant_t *pl, const hs_params_t *params, const double pose[6])
{
    double force[HS_LEGS], len[HS_LEGS];
    aux_t aux;
    double dx[HS_NX];
    hs_status_t st;
    if (pl == NULL || params == NULL || pose == NULL) {
        return HS_E_ARG;
    }
    if (hs_params_check(params) != HS_OK) {
        return HS_E_ARG;
    }
    for (int k = 0; k < 6; ++k) {
        if (!isfinite(pose[k])) {
            return HS_E_RANGE;
        }
    }
    memset(pl, 0, sizeof *pl);
    pl->par = *params;
    pl->act = HS_ACT_HYDRAULIC;
    if (!invert3(pl->par.inertia, pl->inertia_inv)) {
        return HS_E_ARG;
    }
    pl->inv_mass = 1.0 / pl->par.mass;
    pl->com_on = (pl->par.com[0] != 0.0 || pl->par.com[1] != 0.0 || pl->par.com[2] != 0.0);
    hs_leg_lengths(&pl->par, pose, len);
    for (int i = 0; i < HS_LEGS; ++i) {
        const hs_cyl_params_t *c = &pl->par.cyl[i];
        double s = len[i] - c->length_min;
        if (s < -c->cushion_length || s > c->stroke + c->cushion_length) {
            return HS_E_RANGE;
        }
    }
    for (int k = 0; k < 3; ++k) {
        pl->x[HS_X_POS + k] = pose[k];
    }
    hs_quat_from_rpy(&pose[3], &pl->x[HS_X_QUAT]);
    for (int i = 0; i < HS_LEGS; ++i) {
        if (pl->par.cyl[i].cylinder_mass > 0.0 || pl->par.cyl[i].rod_mass > 0.0 ||
            pl->par.cyl[i].cylinder_inertia > 0.0 || pl->par.cyl[i].rod_inertia > 0.0) {
            pl->legs_on = 1;
        }
    }
    if (pl->legs_on) {
        double fext[3] = {0.0, 0.0, 0.0}, mext[3] = {0.0, 0.0, 0.0};
        add_leg_gravity(pl, fext, mext);
        st = hs_static_forces(&pl->par, pose, fext, mext, force);
    } else {
        st = hs_static_forces(&pl->par, pose, NULL, NULL, force);
    }
    if (st != HS_OK) {
        return st;
    }
    set_holding(pl, force);
    for (int i = 0; i < HS_LEGS; ++i) {
        hs_drive_init(&pl->drive[i], force[i]);
    }
    hs_rng_seed(&pl->rng, pl->par.sensors.seed);
    hs_rng_seed(&pl->inj.rng, pl->par.sensors.seed ^ UINT64_C(0x5DEECE66D));
    for (int i = 0; i < HS_LEGS; ++i) {
        pl->inj.supply[i] = pl->par.cyl[i].supply_pressure;
    }
    derivs(pl, pl->x, zero_u, dx, &aux);
    sample_feedback(pl, &aux);
    return HS_OK;
}

hs_status_t hs_plant_set_actuation(hs_plant_t *pl, hs_actuation_t mode)
{
    if (pl == NULL || (mode != HS_ACT_HYDRAULIC && mode != HS_ACT_IDEAL)) {
        return HS_E_ARG;
    }
    pl->act = mode;
    return HS_OK;
}

static int finite3(const double *v)
{
    return v == NULL || (isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]));
}

hs_status_t hs_plant_set_twist(hs_plant_t *pl, const double vel[3], const double omega_body[3])
{
    if (pl == NULL || vel == NULL || omega_body == NULL || !finite3(vel) || !finite3(omega_body)) {
        return HS_E_ARG;
    }
    for (int k = 0; k < 3; ++k) {
        pl->x[HS_X_VEL + k] = vel[k];
        pl->x[HS_X_OMEGA + k] = omega_body[k];
    }
    return HS_OK;
}

hs_status_t hs_plant_set_wrench(hs_plant_t *pl, const double force[3], const double moment[3])
{
    if (pl == NULL || !finite3(force) || !finite3(moment)) {
        return HS_E_ARG;
    }
    for (int k = 0; k < 3; ++k) {
        pl->ext_force[k] = (force != NULL) ? force[k] : 0.0;
        pl->ext_moment[k] = (moment != NULL) ? moment[k] : 0.0;
    }
    return HS_OK;
}

hs_status_t hs_plant_set_contact(hs_plant_t *pl, const hs_contact_t *ct)
{
    hs_contact_t c;
    if (pl == NULL) {
        return HS_E_ARG;
    }
    if (ct == NULL || ct->kind == HS_CONTACT_NONE) {
        memset(&pl->contact, 0, sizeof pl->contact);
        return HS_OK;
    }
    c = *ct;
    if ((c.kind != HS_CONTACT_PLANE && c.kind != HS_CONTACT_POINT) || !finite3(c.point) || !finite3(c.normal) ||
        !finite3(c.anchor) || !isfinite(c.offset) || !(c.stiffness >= 0.0) || !(c.damping >= 0.0) ||
        !isfinite(c.stiffness) || !isfinite(c.damping)) {
        return HS_E_ARG;
    }
    if (c.kind == HS_CONTACT_PLANE) {
        double n = sqrt(c.normal[0] * c.normal[0] + c.normal[1] * c.normal[1] + c.normal[2] * c.normal[2]);
        if (!(n > 0.0)) {
            return HS_E_ARG;
        }
        for (int k = 0; k < 3; ++k) {
            c.normal[k] /= n;
        }
    }
    if (hs_contact_start_force(pl, &c) > HS_CONTACT_START_FORCE_MAX) {
        return HS_E_RANGE;
    }
    pl->contact = c;
    return HS_OK;
}

double hs_contact_start_force(const hs_plant_t *pl, const hs_contact_t *c)
{
    double r[3][3], arm[3], pc[3], fc[3], n;
    hs_contact_t u;
    if (pl == NULL || c == NULL || c->kind == HS_CONTACT_NONE) {
        return 0.0;
    }
    u = *c;
    n = sqrt(u.normal[0] * u.normal[0] + u.normal[1] * u.normal[1] + u.normal[2] * u.normal[2]);
    if (u.kind == HS_CONTACT_PLANE && n > 0.0) {
        for (int k = 0; k < 3; ++k) {
            u.normal[k] /= n;
        }
    }
    hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
    mat_vec(&r[0][0], u.point, arm);
    for (int k = 0; k < 3; ++k) {
        pc[k] = pl->x[HS_X_POS + k] + arm[k];
    }
    contact_force(&u, pc, NULL, fc);
    return sqrt(fc[0] * fc[0] + fc[1] * fc[1] + fc[2] * fc[2]);
}

hs_status_t hs_plant_rebalance(hs_plant_t *pl)
{
    double force[HS_LEGS];
    hs_status_t st;
    if (pl == NULL) {
        return HS_E_ARG;
    }
    st = current_static_forces(pl, force);
    if (st != HS_OK) {
        return st;
    }
    set_holding(pl, force);
    return HS_OK;
}

hs_status_t hs_plant_add_mass(hs_plant_t *pl, double mass, const double point[3])
{
    hs_params_t p;
    double inv[3][3];
    hs_status_t st;
    if (pl == NULL) {
        return HS_E_ARG;
    }
    p = pl->par;
    st = hs_params_add_mass(&p, mass, point);
    if (st != HS_OK) {
        return st;
    }
    if (!invert3(p.inertia, inv)) {
        return HS_E_RANGE;
    }
    pl->par = p;
    memcpy(pl->inertia_inv, inv, sizeof inv);
    pl->inv_mass = 1.0 / p.mass;
    pl->com_on = (p.com[0] != 0.0 || p.com[1] != 0.0 || p.com[2] != 0.0);
    return HS_OK;
}

static int bad_leg(const hs_plant_t *pl, int leg)
{
    return pl == NULL || leg < 0 || leg >= HS_LEGS;
}

hs_status_t hs_plant_set_setpoint(hs_plant_t *pl, int leg, double length, double velocity, double force,
                                  hs_drive_request_t mode)
{
    if (bad_leg(pl, leg)) {
        return HS_E_ARG;
    }
    return hs_drive_setpoint(&pl->drive[leg], length, velocity, force, mode);
}

hs_status_t hs_plant_set_block(hs_plant_t *pl, int leg, int closed)
{
    if (bad_leg(pl, leg)) {
        return HS_E_ARG;
    }
    return hs_drive_set_block(&pl->drive[leg], closed);
}

hs_status_t hs_plant_set_forces(hs_plant_t *pl, const double force[HS_LEGS])
{
    if (pl == NULL || force == NULL) {
        return HS_E_ARG;
    }
    for (int i = 0; i < HS_LEGS; ++i) {
        if (!isfinite(force[i])) {
            return HS_E_ARG;
        }
    }
    memcpy(pl->ideal_force, force, sizeof pl->ideal_force);
    return HS_OK;
}

hs_status_t hs_plant_raise_faults(hs_plant_t *pl, int leg, uint32_t bits)
{
    if (bad_leg(pl, leg)) {
        return HS_E_ARG;
    }
    hs_drive_raise(&pl->drive[leg], bits);
    pl->fb[leg].state = pl->drive[leg].state;
    pl->fb[leg].faults = pl->drive[leg].faults;
    return HS_OK;
}

hs_status_t hs_plant_clear_faults(hs_plant_t *pl, int leg)
{
    if (bad_leg(pl, leg)) {
        return HS_E_ARG;
    }
    hs_drive_clear_faults(&pl->drive[leg]);
    pl->fb[leg].state = pl->drive[leg].state;
    pl->fb[leg].faults = pl->drive[leg].faults;
    return HS_OK;
}

hs_status_t hs_plant_fault_reset(hs_plant_t *pl, int leg, uint32_t *remaining)
{
    if (bad_leg(pl, leg)) {
        return HS_E_ARG;
    }
    const hs_cyl_params_t *c = &pl->par.cyl[leg];
    double dx[HS_NX];
    aux_t aux;
    uint32_t cause = pl->inj.held[leg];
    derivs(pl, pl->x, pl->valve_cmd, dx, &aux);
    double s = aux.length[leg] - c->length_min;
    cause |= (pl->inj.sensor[leg] != HS_SENSOR_OK) ? HS_FAULT_SENSOR : 0u;
    cause |= pl->inj.valve_stuck[leg] ? HS_FAULT_VALVE : 0u;
    cause |= pl->inj.supply_lost ? HS_FAULT_PRESSURE : 0u;
    cause |= (s < 0.0 || s > c->stroke) ? HS_FAULT_END_STOP : 0u;
    cause |= state_finite(pl->x) ? 0u : HS_FAULT_INTERNAL;
    cause &= 0xFFu;
    if (cause != 0u) {
        pl->drive[leg].faults |= cause; /* the feedback says which cause remains */
    } else {
        hs_drive_clear_faults(&pl->drive[leg]);
    }
    pl->fb[leg].state = pl->drive[leg].state;
    pl->fb[leg].faults = pl->drive[leg].faults;
    if (remaining != NULL) {
        *remaining = cause;
    }
    return HS_OK;
}

hs_status_t hs_plant_inject_sensor(hs_plant_t *pl, int leg, hs_sensor_fault_t mode, double value)
{
    if (bad_leg(pl, leg) || !isfinite(value) ||
        (mode != HS_SENSOR_OK && mode != HS_SENSOR_STICK && mode != HS_SENSOR_JUMP && mode != HS_SENSOR_NOISE)) {
        return HS_E_ARG;
    }
    if (mode == HS_SENSOR_STICK && value <= 0.0) {
        value = pl->fb[leg].length;
    }
    pl->inj.sensor[leg] = mode;
    pl->inj.sensor_value[leg] = (mode == HS_SENSOR_OK) ? 0.0 : value;
    return HS_OK;
}

hs_status_t hs_plant_inject_valve(hs_plant_t *pl, int leg, int stuck, double u)
{
    if (bad_leg(pl, leg) || !(u >= -1.0 && u <= 1.0)) {
        return HS_E_ARG;
    }
    pl->inj.valve_stuck[leg] = stuck ? 1 : 0;
    pl->inj.valve_cmd[leg] = stuck ? u : 0.0;
    return HS_OK;
}

hs_status_t hs_plant_inject_supply(hs_plant_t *pl, int lost)
{
    if (pl == NULL) {
        return HS_E_ARG;
    }
    if (lost && !pl->inj.supply_lost) {
        for (int i = 0; i < HS_LEGS; ++i) {
            pl->par.cyl[i].supply_pressure = pl->par.cyl[i].tank_pressure;
        }
        pl->inj.supply_lost = 1;
    } else if (!lost && pl->inj.supply_lost) {
        for (int i = 0; i < HS_LEGS; ++i) {
            pl->par.cyl[i].supply_pressure = pl->inj.supply[i];
        }
        pl->inj.supply_lost = 0;
    }
    return HS_OK;
}

hs_status_t hs_plant_inject_drive(hs_plant_t *pl, int leg, uint32_t bits)
{
    if (bad_leg(pl, leg)) {
        return HS_E_ARG;
    }
    pl->inj.held[leg] = bits & 0xFFu;
    if (bits != 0u) {
        (void)hs_plant_raise_faults(pl, leg, bits);
    }
    return HS_OK;
}

/* Warnings and sensor plausibility after a substep (hydraulic mode). */
static void check_axes(hs_plant_t *pl, const aux_t *aux)
{
    for (int i = 0; i < HS_LEGS; ++i) {
        const hs_cyl_params_t *c = &pl->par.cyl[i];
        const double *xc = &pl->x[HS_X_CYL + 4 * i];
        double s = aux->length[i] - c->length_min;
        uint32_t bits = 0u;
        if (s < 0.0 || s > c->stroke) {
            bits |= HS_FAULT_END_STOP;
        }
        if (s < -0.1 || s > c->stroke + 0.1) {
            bits |= HS_FAULT_SENSOR; /* beyond any physical travel: the sensor reading cannot be right */
        }
        if (xc[0] <= 0.0 || xc[1] <= 0.0 || xc[0] >= c->pressure_max || xc[1] >= c->pressure_max) {
            bits |= HS_FAULT_PRESSURE;
        }
        if (bits != 0u) {
            hs_drive_raise(&pl->drive[i], bits);
        }
        if (c->supply_pressure < 0.5 * pl->inj.supply[i]) {
            hs_drive_fail(&pl->drive[i], HS_FAULT_PRESSURE); /* the supply monitor: valve at null */
            pl->valve_cmd[i] = pl->inj.valve_stuck[i] ? pl->inj.valve_cmd[i] : 0.0;
        }
    }
}

hs_status_t hs_plant_step(hs_plant_t *pl, double dt)
{
    double k1[HS_NX], k2[HS_NX], k3[HS_NX], k4[HS_NX], xt[HS_NX], x0[HS_NX];
    aux_t aux;
    double h;
    uint32_t n;
    if (pl == NULL || !(dt > 0.0) || !(dt <= 0.1)) {
        return HS_E_ARG;
    }
    n = pl->par.substeps;
    h = dt / (double)n;

    for (int i = 0; i < HS_LEGS; ++i) {
        hs_drive_cycle(&pl->drive[i], &pl->par.drive, pl->fb[i].length);
    }

    for (uint32_t s = 0; s < n; ++s) {
        memcpy(x0, pl->x, sizeof x0);
        derivs(pl, pl->x, zero_u, k1, &aux);
        if (pl->act == HS_ACT_HYDRAULIC) {
            const hs_sensor_params_t *sp = &pl->par.sensors;
            check_axes(pl, &aux);
            for (int i = 0; i < HS_LEGS; ++i) {
                const hs_cyl_params_t *c = &pl->par.cyl[i];
                double lm = (double)hs_quantize(sensed_length(pl, i, aux.length[i]), sp->length_resolution) *
                            sp->length_resolution;
                double pa =
                    (double)hs_quantize(measure_pressure(pl, pl->x[HS_X_CYL + 4 * i]), sp->pressure_resolution) *
                    sp->pressure_resolution;
                double pb =
                    (double)hs_quantize(measure_pressure(pl, pl->x[HS_X_CYL + 4 * i + 1]), sp->pressure_resolution) *
                    sp->pressure_resolution;
                double u;
                (void)hs_drive_update(&pl->drive[i], &pl->par.drive, c, lm, pa, pb, h);
                /* its safety functions: the valve monitor on the spool's LVDT, the sensor
                 * plausibility, the blocking valves (they may fault it: command 0) */
                hs_drive_monitor(&pl->drive[i], &pl->par.drive, c, lm, pa, pb, pl->x[HS_X_CYL + 4 * i + 2], h);
                u = pl->drive[i].command;
                if (pl->inj.valve_stuck[i]) {
                    u = pl->inj.valve_cmd[i]; /* the spool does not follow the drive */
                }
                pl->valve_cmd[i] = u;
                /* k1 was evaluated with u = 0; the spool equation is linear in u */
                k1[HS_X_CYL + 4 * i + 3] += c->valve_omega * c->valve_omega * u;
            }
        }
        for (int k = 0; k < HS_NX; ++k) {
            xt[k] = pl->x[k] + 0.5 * h * k1[k];
        }
        derivs(pl, xt, pl->valve_cmd, k2, NULL);
        for (int k = 0; k < HS_NX; ++k) {
            xt[k] = pl->x[k] + 0.5 * h * k2[k];
        }
        derivs(pl, xt, pl->valve_cmd, k3, NULL);
        for (int k = 0; k < HS_NX; ++k) {
            xt[k] = pl->x[k] + h * k3[k];
        }
        derivs(pl, xt, pl->valve_cmd, k4, NULL);
        for (int k = 0; k < HS_NX; ++k) {
            pl->x[k] += h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]);
        }
        if (!state_finite(pl->x)) {
            memcpy(pl->x, x0, sizeof x0);
            for (int i = 0; i < HS_LEGS; ++i) {
                hs_drive_raise(&pl->drive[i], HS_FAULT_INTERNAL);
                pl->fb[i].state = pl->drive[i].state;
                pl->fb[i].faults = pl->drive[i].faults;
            }
            return HS_E_NUMERIC;
        }
        clamp_state(pl);
        pl->time += h;
    }
    pl->cycle++;
    derivs(pl, pl->x, pl->valve_cmd, k1, &aux);
    if (pl->act == HS_ACT_HYDRAULIC) {
        check_axes(pl, &aux);
    }
    sample_feedback(pl, &aux);
    return HS_OK;
}

hs_status_t hs_plant_feedback(const hs_plant_t *pl, int leg, hs_feedback_t *fb)
{
    if (bad_leg(pl, leg) || fb == NULL) {
        return HS_E_ARG;
    }
    *fb = pl->fb[leg];
    return HS_OK;
}

hs_status_t hs_plant_pose(const hs_plant_t *pl, double pose[6])
{
    double r[3][3];
    if (pl == NULL || pose == NULL) {
        return HS_E_ARG;
    }
    hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
    for (int k = 0; k < 3; ++k) {
        pose[k] = pl->x[HS_X_POS + k];
    }
    hs_rpy_from_rot(r, &pose[3]);
    return HS_OK;
}

hs_status_t hs_plant_state(const hs_plant_t *pl, hs_state_t *st)
{
    double dx[HS_NX], r[3][3];
    aux_t aux;
    if (pl == NULL || st == NULL) {
        return HS_E_ARG;
    }
    derivs(pl, pl->x, pl->valve_cmd, dx, &aux);
    st->time = pl->time;
    st->cycle = pl->cycle;
    hs_plant_pose(pl, st->pose);
    for (int k = 0; k < 4; ++k) {
        st->quat[k] = pl->x[HS_X_QUAT + k];
    }
    hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
    for (int k = 0; k < 3; ++k) {
        st->vel[k] = pl->x[HS_X_VEL + k];
        st->omega_body[k] = pl->x[HS_X_OMEGA + k];
        st->contact_force[k] = aux.contact[k];
        st->wrench[k] = pl->ext_force[k] + aux.contact[k];
        st->wrench[3 + k] = pl->ext_moment[k] + aux.contact_moment[k];
    }
    mat_vec(&r[0][0], st->omega_body, st->omega_base);
    for (int i = 0; i < HS_LEGS; ++i) {
        st->length[i] = aux.length[i];
        st->rate[i] = aux.rate[i];
        st->force[i] = aux.force[i];
        st->friction[i] = aux.friction[i];
        st->pa[i] = pl->x[HS_X_CYL + 4 * i];
        st->pb[i] = pl->x[HS_X_CYL + 4 * i + 1];
        st->spool[i] = pl->x[HS_X_CYL + 4 * i + 2];
        st->valve_cmd[i] = pl->valve_cmd[i];
        st->block[i] = pl->drive[i].block;
    }
    return HS_OK;
}

hs_status_t hs_plant_energy(const hs_plant_t *pl, hs_energy_t *e)
{
    const hs_params_t *p;
    double dx[HS_NX], r[3][3], iw[3];
    aux_t aux;
    const double *v, *w;
    if (pl == NULL || e == NULL) {
        return HS_E_ARG;
    }
    p = &pl->par;
    v = &pl->x[HS_X_VEL];
    w = &pl->x[HS_X_OMEGA];
    mat_vec(&p->inertia[0][0], w, iw);
    e->kinetic =
        0.5 * p->mass * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + 0.5 * (w[0] * iw[0] + w[1] * iw[1] + w[2] * iw[2]);
    e->gravity = p->mass * p->gravity * pl->x[HS_X_POS + 2];
    if (pl->com_on) {
        /* about o': m v . (w_b x R c) more kinetic energy; the centre of mass's height */
        double rc[3], wb[3], wxr[3];
        hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
        mat_vec(&r[0][0], p->com, rc);
        mat_vec(&r[0][0], w, wb);
        cross(wb, rc, wxr);
        e->kinetic += p->mass * (v[0] * wxr[0] + v[1] * wxr[1] + v[2] * wxr[2]);
        e->gravity += p->mass * p->gravity * rc[2];
    }
    e->oil = 0.0;
    e->springs = 0.0;
    derivs(pl, pl->x, pl->valve_cmd, dx, &aux);
    if (pl->act == HS_ACT_HYDRAULIC) {
        for (int i = 0; i < HS_LEGS; ++i) {
            const hs_cyl_params_t *c = &p->cyl[i];
            double s = aux.length[i] - c->length_min;
            e->oil += hs_cyl_oil_energy(c, s, pl->x[HS_X_CYL + 4 * i], pl->x[HS_X_CYL + 4 * i + 1]);
            double z = pl->x[HS_X_BRISTLE + i];
            e->springs += hs_cyl_stop_energy(c, s) + 0.5 * c->bristle_stiffness * z * z;
        }
    }
    if (pl->contact.kind != HS_CONTACT_NONE) {
        const hs_contact_t *ct = &pl->contact;
        double arm[3], pc[3];
        hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
        mat_vec(&r[0][0], ct->point, arm);
        for (int k = 0; k < 3; ++k) {
            pc[k] = pl->x[HS_X_POS + k] + arm[k];
        }
        if (ct->kind == HS_CONTACT_PLANE) {
            double pen = ct->offset - (ct->normal[0] * pc[0] + ct->normal[1] * pc[1] + ct->normal[2] * pc[2]);
            if (pen > 0.0) {
                e->springs += 0.5 * ct->stiffness * pen * pen;
            }
        } else {
            double d2 = 0.0;
            for (int k = 0; k < 3; ++k) {
                d2 += (pc[k] - ct->anchor[k]) * (pc[k] - ct->anchor[k]);
            }
            e->springs += 0.5 * ct->stiffness * d2;
        }
    }
    if (pl->legs_on) {
        hs_rot_from_quat(&pl->x[HS_X_QUAT], r);
        for (int i = 0; i < HS_LEGS; ++i) {
            const hs_cyl_params_t *c = &p->cyl[i];
            double arm[3], un[3], len, va[3], mm[3][3], b[3], mv[3];
            leg_geometry(pl, pl->x, r, i, arm, un, &len, va);
            leg_mass_terms(c, un, len, NULL, 0.0, mm, b);
            mat_vec(&mm[0][0], va, mv);
            e->kinetic += 0.5 * (va[0] * mv[0] + va[1] * mv[1] + va[2] * mv[2]);
            e->gravity += p->gravity * (c->cylinder_mass * (p->base_joint[i][2] + c->cylinder_com * un[2]) +
                                        c->rod_mass * (pl->x[HS_X_POS + 2] + arm[2] - c->rod_com * un[2]));
        }
    }
    e->total = e->kinetic + e->gravity + e->oil + e->springs;
    return HS_OK;
}
