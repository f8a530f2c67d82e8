#include "sp/dynamics.h"

#include "fixed_inline.h"

/* I v for I in Q16 (kg m^2) and v in Q24: Q40 sums narrowed to Q24, int64. */
static void inertia_times(const sp_q16_t inertia[3][3], const sp_q24_t v[3], int64_t out[3], sp_flags_t *flags)
{
    unsigned r;
    unsigned c;
    for (r = 0u; r < 3u; ++r) {
        int64_t a = 0;
        for (c = 0u; c < 3u; ++c) {
            a = spi_add64(a, (int64_t)inertia[r][c] * v[c], flags);
        }
        out[r] = spi_rshift(a, 16u);
    }
}

sp_status_t sp_inverse_dynamics(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS])
{
    sp_lu6_t lu;
    return sp_inverse_dynamics_lu(platform, motion, ik, ext_force, force, &lu);
}

sp_status_t sp_inverse_dynamics_lu(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                   const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS], sp_lu6_t *lu)
{
    sp_flags_t flags = 0u;
    sp_jacobian_t jac;
    sp_q24_t omega[3];
    sp_q24_t omega_dot[3];
    int64_t h[3];
    int64_t i_wdot[3];
    int64_t torque_body[3];
    int64_t b[SP_LEGS];
    int64_t f[SP_LEGS];
    sp_status_t st;
    unsigned k;
    unsigned c;

    if (force == NULL || lu == NULL) {
        return SP_E_ARG;
    }
    lu->valid = 0u;
    for (k = 0u; k < SP_LEGS; ++k) {
        force[k] = 0;
    }
    if (platform == NULL || motion == NULL || ik == NULL) {
        return SP_E_ARG;
    }
    st = sp_body_rates_sc(ik->sc, motion->rpy_rate, motion->rpy_acc, omega, omega_dot);
    if (st != SP_OK) {
        return st;
    }
    /* Translation (eq 7): sum F_i u_i = m a - L + m g e_z, N in Q24. */
    for (k = 0u; k < 3u; ++k) {
        int64_t v = spi_rsr((int64_t)platform->mass * motion->acc[k], 16u); /* Q40 -> Q24 */
        if (k == 2u) {
            v = spi_add64(v, spi_rsr((int64_t)platform->mass * platform->gravity, 16u), &flags);
        }
        if (ext_force != NULL) {
            v = spi_add64(v, -((int64_t)ext_force[k] * 65536), &flags); /* Q8 -> Q24 */
        }
        b[k] = v;
    }
    /* Rotation (eq 8 with the full tensor): I dw/dt + w x (I w), motion
     * frame, N m in Q24, then into the base frame with R = T^T. */
    inertia_times(platform->inertia, omega, h, &flags);
    inertia_times(platform->inertia, omega_dot, i_wdot, &flags);
    /* w x (I w): int64 (Q24) times Q24, two 32x32 products each */
    torque_body[0] = spi_add64(i_wdot[0],
                               spi_add64(spi_mul64_rs(h[2], omega[1], 24u, &flags),
                                         -spi_mul64_rs(h[1], omega[2], 24u, &flags), &flags),
                               &flags);
    torque_body[1] = spi_add64(i_wdot[1],
                               spi_add64(spi_mul64_rs(h[0], omega[2], 24u, &flags),
                                         -spi_mul64_rs(h[2], omega[0], 24u, &flags), &flags),
                               &flags);
    torque_body[2] = spi_add64(i_wdot[2],
                               spi_add64(spi_mul64_rs(h[1], omega[0], 24u, &flags),
                                         -spi_mul64_rs(h[0], omega[1], 24u, &flags), &flags),
                               &flags);
    for (k = 0u; k < 3u; ++k) {
        int64_t v = 0;
        for (c = 0u; c < 3u; ++c) {
            /* (R tau)_k = sum_c R[k][c] tau_c = sum_c T[c][k] tau_c */
            v = spi_add64(v, spi_mul64_rs(torque_body[c], ik->rot.t[c][k], 30u, &flags), &flags);
        }
        b[3u + k] = v;
    }
    if (flags != 0u) {
        return sp_flags_status(flags);
    }
    st = sp_jacobian(ik, &jac);
    if (st != SP_OK) {
        return st;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        if (b[k] >= (INT64_C(1) << 56) || b[k] <= -(INT64_C(1) << 56)) {
            return SP_E_OVERFLOW; /* sp_solve6's range */
        }
    }
    st = sp_lu6_factor(&jac, 1, lu);
    if (st == SP_OK) {
        st = sp_lu6_solve(lu, b, f); /* = sp_solve6(&jac, 1, b, f) */
    }
    if (st != SP_OK) {
        return st;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        force[k] = spi_narrow(f[k], 16u, &flags); /* Q24 -> Q8 */
    }
    if (flags != 0u) {
        for (k = 0u; k < SP_LEGS; ++k) {
            force[k] = 0;
        }
        return sp_flags_status(flags);
    }
    return SP_OK;
}

sp_status_t sp_check_legs(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS],
                          const sp_q24_t rate[SP_LEGS], const sp_q8_t force[SP_LEGS], sp_leg_limits_t *report)
{
    unsigned i;

    if (platform == NULL || length == NULL || report == NULL) {
        return SP_E_ARG;
    }
    report->too_short = 0u;
    report->too_long = 0u;
    report->too_fast = 0u;
    report->over_force = 0u;
    for (i = 0u; i < SP_LEGS; ++i) {
        uint32_t bit = UINT32_C(1) << i;
        if (length[i] < platform->leg_length_min) {
            report->too_short |= bit;
        }
        if (length[i] > platform->leg_length_max) {
            report->too_long |= bit;
        }
        if (rate != NULL && (rate[i] > platform->leg_velocity_max || rate[i] < -platform->leg_velocity_max)) {
            report->too_fast |= bit;
        }
        if (force != NULL && (force[i] > platform->force_max || force[i] < -platform->force_max)) {
            report->over_force |= bit;
        }
    }
    if ((report->too_short | report->too_long | report->too_fast | report->over_force) != 0u) {
        return SP_E_RANGE;
    }
    return SP_OK;
}
