/* SPDX-License-Identifier: Apache-2.0 */
/*
 * plant_test_util.h - helpers shared by the plant tests: analytic
 * multi-sine motions about a pose (with exact velocities and
 * accelerations), motions in the firmware core's Q formats (the
 * conversions of tests/support/ref_model.h), and orientation errors.
 */
#ifndef PLANT_TEST_UTIL_H
#define PLANT_TEST_UTIL_H

#include <math.h>
#include <stdint.h>

#include "hs/kin.h"
#include "hs/params.h"
#include "ref_model.h"
#include "sp/model/platform.h"

#define PT_TWO_PI 6.283185307179586

/** offset_k(t) = amp_k sin(2 pi freq_k t + phase_k) on each pose axis k. */
typedef struct {
    double amp[6];   /**< m or rad */
    double freq[6];  /**< Hz */
    double phase[6]; /**< rad */
} pt_sines_t;

static inline void pt_motion(const double centre[6], const pt_sines_t *m, double t, double pose[6], double vel[6],
                             double acc[6])
{
    for (int k = 0; k < 6; ++k) {
        double w = PT_TWO_PI * m->freq[k];
        double a = w * t + m->phase[k];
        pose[k] = centre[k] + m->amp[k] * sin(a);
        vel[k] = m->amp[k] * w * cos(a);
        acc[k] = -m->amp[k] * w * w * sin(a);
    }
}

/** A motion sample in the firmware core's formats (sp_motion_t, Q24). */
static inline void pt_to_sp_motion(const double pose[6], const double vel[6], const double acc[6], sp_motion_t *out)
{
    for (int k = 0; k < 3; ++k) {
        out->pose.pos[k] = ref_q24(pose[k]);
        out->pose.rpy[k] = ref_q24(pose[3 + k]);
        out->vel[k] = ref_q24(vel[k]);
        out->rpy_rate[k] = ref_q24(vel[3 + k]);
        out->acc[k] = ref_q24(acc[k]);
        out->rpy_acc[k] = ref_q24(acc[3 + k]);
    }
}

/** Angle (rad) of the rotation between two orientations given as roll,
 *  pitch, yaw: atan2 of the sine and cosine parts of R_a^T R_b (accurate
 *  near zero, unlike acos of the trace). */
static inline double pt_rot_error(const double rpy_a[3], const double rpy_b[3])
{
    double ra[3][3], rb[3][3], m[3][3], s0, s1, s2;
    hs_rot_from_rpy(rpy_a, ra);
    hs_rot_from_rpy(rpy_b, rb);
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            m[i][j] = ra[0][i] * rb[0][j] + ra[1][i] * rb[1][j] + ra[2][i] * rb[2][j];
        }
    }
    s0 = m[2][1] - m[1][2];
    s1 = m[0][2] - m[2][0];
    s2 = m[1][0] - m[0][1];
    return atan2(0.5 * sqrt(s0 * s0 + s1 * s1 + s2 * s2), 0.5 * (m[0][0] + m[1][1] + m[2][2] - 1.0));
}

/** Largest distance between two positions (m). */
static inline double pt_pos_error(const double a[3], const double b[3])
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

/** Massless legs, as in the paper: the default config has leg masses, the
 *  rigid-body tests and the tests that add their own legs start without. */
static inline void pt_massless_legs(hs_params_t *p)
{
    for (int i = 0; i < HS_LEGS; ++i) {
        p->cyl[i].cylinder_mass = 0.0;
        p->cyl[i].rod_mass = 0.0;
        p->cyl[i].cylinder_inertia = 0.0;
        p->cyl[i].rod_inertia = 0.0;
    }
}

/** No friction at all in any cylinder (viscous, Coulomb, break-away, bristles). */
static inline void pt_no_friction(hs_params_t *p)
{
    for (int i = 0; i < HS_LEGS; ++i) {
        p->cyl[i].viscous_friction = 0.0;
        p->cyl[i].coulomb_friction = 0.0;
        p->cyl[i].breakaway_friction = 0.0;
        p->cyl[i].bristle_stiffness = 0.0;
        p->cyl[i].bristle_damping = 0.0;
    }
}

/** The friction of before issue 14: memoryless smoothed Coulomb (no bristles,
 *  no break-away excess), 1 mm/s smoothing. */
static inline void pt_memoryless_friction(hs_params_t *p)
{
    for (int i = 0; i < HS_LEGS; ++i) {
        p->cyl[i].breakaway_friction = p->cyl[i].coulomb_friction;
        p->cyl[i].bristle_stiffness = 0.0;
        p->cyl[i].bristle_damping = 0.0;
        p->cyl[i].coulomb_velocity = 1.0e-3;
    }
}

#endif /* PLANT_TEST_UTIL_H */
