/* SPDX-License-Identifier: Apache-2.0 */
/*
 * ftsensor.c - the six-axis force/torque sensor (hs/ftsensor.h).
 */
#include "hs/ftsensor.h"

#include <math.h>
#include <stddef.h>

#include "hs/kin.h"

hs_ft_params_t hs_ft_default_params(void)
{
    hs_ft_params_t p = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 7000.0, 2.0, 0.2, 20.0, 2.0, 0.5, 0.05, 0.01,
                        0.001,           10000.0,         1000.0};
    return p;
}

static int finite_nonneg(double v)
{
    return isfinite(v) && v >= 0.0;
}

hs_status_t hs_ft_init(hs_ft_t *ft, const hs_ft_params_t *par, uint64_t seed)
{
    if (ft == NULL || par == NULL || !(par->rate_hz > 0.0) || !isfinite(par->rate_hz) ||
        !finite_nonneg(par->noise_force) || !finite_nonneg(par->noise_moment) || !finite_nonneg(par->bias_force) ||
        !finite_nonneg(par->bias_moment) || !finite_nonneg(par->drift_force) || !finite_nonneg(par->drift_moment) ||
        !(par->res_force > 0.0) || !(par->res_moment > 0.0) || !(par->range_force > 0.0) ||
        !(par->range_moment > 0.0) || !isfinite(par->range_force) || !isfinite(par->range_moment)) {
        return HS_E_ARG;
    }
    for (int k = 0; k < 3; k++) {
        if (!isfinite(par->mount_pos[k]) || !isfinite(par->mount_rpy[k])) {
            return HS_E_ARG;
        }
    }
    hs_ft_t f;
    f.par = *par;
    hs_rot_from_rpy(par->mount_rpy, f.mount);
    hs_rng_seed(&f.rng, seed);
    for (int k = 0; k < 6; k++) {
        double u = 2.0 * ((double)(hs_rng_next(&f.rng) >> 11) * (1.0 / 9007199254740992.0)) - 1.0;
        double w = 2.0 * ((double)(hs_rng_next(&f.rng) >> 11) * (1.0 / 9007199254740992.0)) - 1.0;
        f.bias[k] = u * (k < 3 ? par->bias_force : par->bias_moment);
        f.drift[k] = w * (k < 3 ? par->drift_force : par->drift_moment);
        f.prev[k] = 0.0;
        f.reading[k] = 0.0;
    }
    f.t = 0.0;
    f.t_next = 0.0;
    f.have_prev = 0;
    f.samples = 0u;
    f.saturated = 0;
    *ft = f;
    return HS_OK;
}

void hs_ft_truth(const hs_ft_t *ft, double rot[3][3], const double wrench[6], double out[6])
{
    /* S = R R_m: base <- sensor axes; r = R mount_pos */
    double s[3][3], r[3];
    for (int i = 0; i < 3; i++) {
        r[i] = 0.0;
        for (int j = 0; j < 3; j++) {
            s[i][j] = 0.0;
            for (int k = 0; k < 3; k++) {
                s[i][j] += rot[i][k] * ft->mount[k][j];
            }
            r[i] += rot[i][j] * ft->par.mount_pos[j];
        }
    }
    const double *f = wrench;
    double m[3] = {wrench[3] - (r[1] * f[2] - r[2] * f[1]), wrench[4] - (r[2] * f[0] - r[0] * f[2]),
                   wrench[5] - (r[0] * f[1] - r[1] * f[0])};
    for (int j = 0; j < 3; j++) {
        out[j] = s[0][j] * f[0] + s[1][j] * f[1] + s[2][j] * f[2];
        out[3 + j] = s[0][j] * m[0] + s[1][j] * m[1] + s[2][j] * m[2];
    }
}

/* One sample of the truth `w` (sensor axes) at time ts. */
static void sample(hs_ft_t *ft, double ts, const double w[6])
{
    int sat = 0;
    for (int k = 0; k < 6; k++) {
        int force = k < 3;
        double noise = (force ? ft->par.noise_force : ft->par.noise_moment) * hs_rng_gauss(&ft->rng);
        double v = w[k] + ft->bias[k] + ft->drift[k] * ts + noise;
        double range = force ? ft->par.range_force : ft->par.range_moment;
        if (v > range || v < -range) {
            v = (v > 0.0) ? range : -range;
            sat = 1;
        }
        double res = force ? ft->par.res_force : ft->par.res_moment;
        ft->reading[k] = (double)hs_quantize(v, res) * res;
    }
    ft->saturated = sat;
    ft->samples++;
}

hs_status_t hs_ft_advance(hs_ft_t *ft, double t, double rot[3][3], const double wrench[6])
{
    if (ft == NULL || rot == NULL || wrench == NULL || !isfinite(t) || t < ft->t) {
        return HS_E_ARG;
    }
    double now[6];
    hs_ft_truth(ft, rot, wrench, now);
    if (!ft->have_prev) {
        for (int k = 0; k < 6; k++) {
            ft->prev[k] = now[k];
        }
        ft->have_prev = 1;
    }
    const double period = 1.0 / ft->par.rate_hz;
    /* bounded: at most the samples of (t_last, t]; a long gap takes its last one only */
    double span = t - ft->t;
    if (ft->t_next <= t && (t - ft->t_next) > 4.0 * period) {
        ft->t_next = t - fmod(t - ft->t_next, period);
    }
    for (int n = 0; n < 64 && ft->t_next <= t; n++) {
        double a = (span > 0.0) ? (ft->t_next - ft->t) / span : 1.0;
        a = (a < 0.0) ? 0.0 : ((a > 1.0) ? 1.0 : a);
        double w[6];
        for (int k = 0; k < 6; k++) {
            w[k] = ft->prev[k] + a * (now[k] - ft->prev[k]);
        }
        sample(ft, ft->t_next, w);
        ft->t_next += period;
    }
    for (int k = 0; k < 6; k++) {
        ft->prev[k] = now[k];
    }
    ft->t = t;
    return HS_OK;
}
