#include "sp/dynamics.h"

#include "fixed_inline.h"

/* a + b, setting *ovf when the sum leaves int64 (the value is then
 * meaningless and the caller fails): ADDS/ADCS and one branch. */
SPI_INLINE int64_t add_ck(int64_t a, int64_t b, int *ovf)
{
#if defined(__GNUC__)
    int64_t r;
    if (__builtin_add_overflow(a, b, &r)) {
        *ovf = 1;
    }
    return r;
#else
    sp_flags_t f = 0u;
    int64_t r = spi_add64(a, b, &f);
    *ovf |= (f != 0u);
    return r;
#endif
}

/* I w and I v for I in Q16 (kg m^2) and w, v in Q24, in one pass over I:
 * Q40 sums (each product at most 2^62; an overflowing sum sets *ovf)
 * narrowed to Q24: |out| < 3 2^46. */
static void inertia_times2(const sp_q16_t inertia[3][3], const sp_q24_t w[3], const sp_q24_t v[3], int64_t iw[3],
                           int64_t iv[3], int *ovf)
{
    unsigned r;
    for (r = 0u; r < 3u; ++r) {
        int32_t i0 = inertia[r][0];
        int32_t i1 = inertia[r][1];
        int32_t i2 = inertia[r][2];
        int64_t a = (int64_t)i0 * w[0];
        int64_t b = (int64_t)i0 * v[0];
        a = add_ck(a, (int64_t)i1 * w[1], ovf);
        b = add_ck(b, (int64_t)i1 * v[1], ovf);
        a = add_ck(a, (int64_t)i2 * w[2], ovf);
        b = add_ck(b, (int64_t)i2 * v[2], ovf);
        iw[r] = spi_round_away64(a, 16u);
        iv[r] = spi_round_away64(b, 16u);
    }
}

/* round(x w / 2^s), ties up, exactly, for 1 <= s <= 30, any int32 w and
 * |x| < 2^(31 + s): x = xh 2^s + xl with 0 <= xl < 2^s, so x w / 2^s =
 * xh w + xl w / 2^s and only the second part is rounded (as
 * spi_mul64_up(x, w, s) computes it, without its range test). |xh w| <
 * 2^62, the result too. */
SPI_INLINE int64_t mul_split_up(int64_t x, int32_t w, unsigned s)
{
    int32_t xh = (int32_t)(x >> s);
    int32_t xl = (int32_t)(x & ((INT64_C(1) << s) - 1));
    return (int64_t)xh * w + (((int64_t)xl * w + (INT64_C(1) << (s - 1u))) >> s);
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
    int ovf = 0;

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
    /* Translation (eq 7): sum F_i u_i = m a - L + m g e_z, N in Q24. Each
     * term is below 2^47 in magnitude (Q16 x Q24 >> 16, Q8 << 16): the sum
     * cannot overflow. */
    for (k = 0u; k < 3u; ++k) {
        int64_t v = spi_round_away((int64_t)platform->mass * motion->acc[k], 16u); /* Q40 -> Q24 */
        if (k == 2u) {
            v += spi_round_away((int64_t)platform->mass * platform->gravity, 16u);
        }
        if (ext_force != NULL) {
            v -= (int64_t)ext_force[k] * 65536; /* Q8 -> Q24 */
        }
        b[k] = v;
    }
    /* Rotation (eq 8 with the full tensor): I dw/dt + w x (I w), motion
     * frame, N m in Q24, then into the base frame with R = T^T. h and
     * I dw/dt are below 3 2^46, each product term of w x h below 2^55,
     * torque_body below 2^57 and R tau below 3 2^57 (|T| entries <= 1):
     * exact int64 arithmetic, no saturation needed after inertia_times. */
    inertia_times2(platform->inertia, omega, omega_dot, h, i_wdot, &ovf);
    torque_body[0] = i_wdot[0] + (mul_split_up(h[2], omega[1], 24u) - mul_split_up(h[1], omega[2], 24u));
    torque_body[1] = i_wdot[1] + (mul_split_up(h[0], omega[2], 24u) - mul_split_up(h[2], omega[0], 24u));
    torque_body[2] = i_wdot[2] + (mul_split_up(h[1], omega[0], 24u) - mul_split_up(h[0], omega[1], 24u));
    for (k = 0u; k < 3u; ++k) {
        /* (R tau)_k = sum_c R[k][c] tau_c = sum_c T[c][k] tau_c */
        b[3u + k] = mul_split_up(torque_body[0], ik->rot.t[0][k], 30u) +
                    mul_split_up(torque_body[1], ik->rot.t[1][k], 30u) +
                    mul_split_up(torque_body[2], ik->rot.t[2][k], 30u);
    }
    if (ovf) {
        return SP_E_OVERFLOW;
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
        force[k] = spi_narrow_away(f[k], 16u, &flags); /* Q24 -> Q8 */
    }
    if (flags != 0u) {
        for (k = 0u; k < SP_LEGS; ++k) {
            force[k] = 0;
        }
        return sp_flags_status(flags);
    }
    return SP_OK;
}
