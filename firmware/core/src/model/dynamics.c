/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/model/dynamics.h"
#include "model/model_internal.h"

#include "math/fixed_inline.h"

/* bit i for each leg i */
#define SP_ALL_LEG_BITS ((1u << SP_LEGS) - 1u)
/* id_lu_plan's stages besides 0 (factorise whole), 1 (begin) and 2
 * (finish): a waiting call (sp_leg_hold_t.lu_wait), and the middle step
 * of a factorisation staged over three calls */
#define ID_LU_WAIT 3u
#define ID_LU_STEP 4u

#if defined(__GNUC__)
#define SPI_COLD __attribute__((cold, noinline))
#else
#define SPI_COLD
#endif
/* SPI_LEG_TERMS_AT_REST 1: leg_terms takes the short path for a motion at
 * rest (leg_terms_at_rest); 0 (tests/unit/test_dynamics_rest.c's plain
 * reference): every motion through the general formulas. */
#ifndef SPI_LEG_TERMS_AT_REST
#define SPI_LEG_TERMS_AT_REST 1
#endif
/* SPI_ID_RANGE_FAST 1: inertia_times2 and id_finish skip their overflow
 * tests for inputs whose range rules overflow out; 0 (tests/unit/
 * test_dynamics_plain.c's plain reference): every input tested. */
#ifndef SPI_ID_RANGE_FAST
#define SPI_ID_RANGE_FAST 1
#endif

/* leg_terms is SPI_NOINLINE: inlined into id_solve, GCC spills the
 * caller's values around its loop (-Os: 51 instructions per tick more, and
 * a deeper stack: id_solve's frame grows by more than leg_terms' own). */

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

/* x in [-2^k, 2^k) (0 <= k <= 30): 1 when it is not. */
SPI_INLINE uint32_t out_of(int32_t x, unsigned k)
{
    return ((uint32_t)x + (UINT32_C(1) << k)) >> (k + 1u);
}

/* I w and I v for I in Q16 (kg m^2) and w, v in Q24, in one pass over I:
 * Q40 sums (each product at most 2^62; an overflowing sum sets *ovf)
 * narrowed to Q24: |out| < 3 2^46. Rates below 32 rad/s (and rad/s^2)
 * in each component, far beyond any motion base, keep each product below
 * 2^60 and the sums below 2^62: no overflow is possible, and none is
 * tested for (inertia_times2, the same bits); other rates take
 * inertia_times2_checked, every sum tested. */
SPI_COLD static void inertia_times2_checked(const sp_q16_t inertia[3][3], const sp_q24_t w[3], const sp_q24_t v[3],
                                            int64_t iw[3], int64_t iv[3], int *ovf)
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

SPI_INLINE void inertia_times2(const sp_q16_t inertia[3][3], const sp_q24_t w[3], const sp_q24_t v[3], int64_t iw[3],
                               int64_t iv[3], int *ovf)
{
    unsigned r;
    if (!SPI_ID_RANGE_FAST || (out_of(w[0], 29u) | out_of(w[1], 29u) | out_of(w[2], 29u) | out_of(v[0], 29u) |
                               out_of(v[1], 29u) | out_of(v[2], 29u)) != 0u) {
        inertia_times2_checked(inertia, w, v, iw, iv, ovf);
        return;
    }
    for (r = 0u; r < 3u; ++r) {
        int64_t a = (int64_t)inertia[r][0] * w[0] + (int64_t)inertia[r][1] * w[1] + (int64_t)inertia[r][2] * w[2];
        int64_t b = (int64_t)inertia[r][0] * v[0] + (int64_t)inertia[r][1] * v[1] + (int64_t)inertia[r][2] * v[2];
        iw[r] = spi_round_away(a, 16u);
        iv[r] = spi_round_away(b, 16u);
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

/* round(a b / 2^s) (ties up) narrowed to int32, saturating and flagging:
 * one SMULL, one add, the range test and a shift. */
SPI_INLINE int32_t qmul(int32_t a, int32_t b, unsigned s, sp_flags_t *flags)
{
    return spi_narrow_floor((int64_t)a * b + (INT64_C(1) << (s - 1u)), s, flags);
}

/* a x b >> 24 (Q24 x Qn -> Qn), narrowed (flags on saturation). */
static void cross24(const sp_q24_t a[3], const int32_t b[3], int32_t out[3], sp_flags_t *flags)
{
    out[0] = spi_narrow_floor((int64_t)a[1] * b[2] - (int64_t)a[2] * b[1] + (INT64_C(1) << 23), 24u, flags);
    out[1] = spi_narrow_floor((int64_t)a[2] * b[0] - (int64_t)a[0] * b[2] + (INT64_C(1) << 23), 24u, flags);
    out[2] = spi_narrow_floor((int64_t)a[0] * b[1] - (int64_t)a[1] * b[0] + (INT64_C(1) << 23), 24u, flags);
}

/* (R v)_k = sum_c T[c][k] v_c (motion frame -> base frame), Q30 x Qn -> Qn. */
static void to_base(const sp_rot_t *rot, const int32_t v[3], int32_t out[3], sp_flags_t *flags)
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        out[k] = spi_narrow_floor((int64_t)rot->t[0][k] * v[0] + (int64_t)rot->t[1][k] * v[1] +
                                      (int64_t)rot->t[2][k] * v[2] + (INT64_C(1) << 29),
                                  30u, flags);
    }
}

/* The centre of mass c off o' (motion frame). About o', the platform then
 * needs besides eqs (7) and (15) the force m R (w' x c + w x (w x c)) (base
 * frame) and the body-frame moment m c x T (a + g e_z): the inertia of the
 * offset mass as o' accelerates, and the moment of its weight. Adds the
 * force to b[0..2] (N, Q24) and the moment to torque_body (N m, Q24). */
static void com_terms(const sp_platform_t *p, const sp_ik_t *ik, const sp_motion_t *m, const sp_q24_t w[3],
                      const sp_q24_t wd[3], int64_t b[SP_LEGS], int64_t torque_body[3], sp_flags_t *flags)
{
    sp_q16_t mc[3]; /* first moment m c, kg m, Q16 */
    sp_q16_t wc[3]; /* w x m c, kg m/s, Q16 */
    sp_q16_t kb[3]; /* w' x m c + w x (w x m c), body frame, N, Q16 */
    sp_q16_t t[3];
    sp_q16_t kbase[3];
    sp_q24_t ab[3]; /* T (a + g e_z), body frame, m/s^2, Q24 */
    int64_t gz = (int64_t)m->acc[2] + p->gravity;
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        mc[k] = qmul(p->mass, p->center_of_mass[k], 24u, flags);
    }
    cross24(w, mc, wc, flags);
    cross24(wd, mc, kb, flags);
    cross24(w, wc, t, flags);
    for (k = 0u; k < 3u; ++k) {
        int64_t acc = (int64_t)ik->rot.t[k][0] * m->acc[0] + (int64_t)ik->rot.t[k][1] * m->acc[1];
        kb[k] = spi_sat((int64_t)kb[k] + t[k], flags);
        ab[k] = spi_narrow_floor(acc + (int64_t)ik->rot.t[k][2] * gz + (INT64_C(1) << 29), 30u, flags);
    }
    to_base(&ik->rot, kb, kbase, flags);
    for (k = 0u; k < 3u; ++k) {
        b[k] += (int64_t)kbase[k] * 256; /* Q16 -> Q24 */
    }
    /* m c x T (a + g e_z): Q16 x Q24 = Q40 -> Q24 */
    torque_body[0] += spi_round_up((int64_t)mc[1] * ab[2] - (int64_t)mc[2] * ab[1], 16u);
    torque_body[1] += spi_round_up((int64_t)mc[2] * ab[0] - (int64_t)mc[0] * ab[2], 16u);
    torque_body[2] += spi_round_up((int64_t)mc[0] * ab[1] - (int64_t)mc[1] * ab[0], 16u);
}

/* The legs' summed force (N, Q16) and moment (N m, Q40) into b's wrench
 * rows (Q24), and kept in hold for the next ticks (when hold != NULL). */
SPI_INLINE void legs_sums_done(const int64_t fsum[3], const int64_t msum[3], sp_leg_hold_t *hold, int64_t b[6])
{
    unsigned k;
    if (hold != NULL) {
        for (k = 0u; k < 3u; ++k) {
            hold->fsum[k] = fsum[k];
            hold->msum[k] = msum[k];
        }
    }
    for (k = 0u; k < 3u; ++k) {
        b[k] += fsum[k] * 256;                   /* Q16 -> Q24 */
        b[3u + k] += spi_round_up(msum[k], 16u); /* Q40 -> Q24 */
    }
}

/*
 * Leg masses (sp_leg_mass_t; docs/explanation/model.md "Leg masses"). Leg i, of unit
 * vector u, length L and rate L', with platform joint A (arm r from o',
 * velocity v_A, acceleration a_A), acts on the platform with its cylinder
 * force F_i u minus
 *   h_i = mu a_A + c1 v_A + (0, 0, k_g g) + s_i u,
 *   mu  = (J_c + m_r (L - d_r)^2) / L^2           (transverse inertia at A)
 *   k_g = (m_c d_c + m_r (L - d_r)) / L           (weight carried at A)
 *   c1  = -2 L' (J_c - m_r d_r (L - d_r)) / L^3
 *   s_i = m_r (u.a_A + g u_z + d_r |u'|^2) - mu u.a_A - k_g g u_z - c1 L',
 * with |u'|^2 = (|v_A|^2 - L'^2) / L^2 and J_c = m_c d_c^2 + I_c + I_r
 * (moment balance of the leg about its base joint, and the rod's balance
 * along its axis). The legs' moments of inertia across the leg, I_c and
 * I_r, turn with the leg's angular velocity u x u' and so add to the
 * barrel's m_c d_c^2 wherever it appears (docs/explanation/model.md
 * "Leg inertia"). The parts along u add
 * to F_i directly (s_i); the rest adds its wrench about o' to b. This
 * function adds sum_i (h_i - s_i u) and sum_i r_i x (h_i - s_i u) to b
 * (N, N m, Q24) and returns s_i in axial (N, Q16). w, wd: the body rates.
 * This is the path for inputs outside leg_terms' envelope: every step
 * rounded and saturated on its own (a saturation fails the call).
 */
SPI_COLD static void leg_terms_wide(const sp_platform_t *p, const sp_ik_t *ik, const sp_motion_t *m,
                                    const sp_q24_t w[3], const sp_q24_t wd[3], int64_t b[SP_LEGS],
                                    sp_q16_t axial[SP_LEGS], sp_flags_t *flags)
{
    const sp_leg_mass_t *lm = &p->leg_mass;
    sp_q24_t wb[3];              /* angular velocity, base frame, rad/s, Q24 */
    sp_q24_t ab[3];              /* angular acceleration, base frame, rad/s^2, Q24 */
    int64_t fsum[3] = {0, 0, 0}; /* N, Q16 */
    int64_t msum[3] = {0, 0, 0}; /* N m, Q40 */
    sp_q16_t mcdc = qmul(lm->cylinder_mass, lm->cylinder_com, 24u, flags); /* kg m */
    /* J_c = m_c d_c^2 + I_c + I_r, kg m^2 */
    sp_q16_t mcdc2 =
        spi_sat((int64_t)qmul(mcdc, lm->cylinder_com, 24u, flags) + lm->cylinder_inertia + lm->rod_inertia, flags);
    unsigned i;
    unsigned k;

    to_base(&ik->rot, w, wb, flags);
    to_base(&ik->rot, wd, ab, flags);
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        const sp_q30_t *u = ik->unit[i];
        sp_q24_t wr[3], va[3], aa[3], t[3];
        sp_q24_t ld, ua, vv, uzg, lr, acc_term;
        sp_q30_t inv, inv2;
        sp_q16_t mrlr, mu, kgm, c1, bq, hw[3];
        unsigned sh;

        /* 1/L in Q30 needs L > 0.5 m (a leg that short is flagged) */
        if (ik->length[i] <= (INT32_C(1) << 23)) {
            *flags |= SP_FLAG_OVERFLOW;
            return;
        }
        cross24(wb, r, wr, flags);
        cross24(ab, r, aa, flags);
        cross24(wb, wr, t, flags);
        for (k = 0u; k < 3u; ++k) {
            va[k] = spi_sat((int64_t)m->vel[k] + wr[k], flags);
            aa[k] = spi_sat((int64_t)m->acc[k] + aa[k] + t[k], flags);
        }
        ld = spi_narrow_floor(
            (int64_t)u[0] * va[0] + (int64_t)u[1] * va[1] + (int64_t)u[2] * va[2] + (INT64_C(1) << 29), 30u, flags);
        ua = spi_narrow_floor(
            (int64_t)u[0] * aa[0] + (int64_t)u[1] * aa[1] + (int64_t)u[2] * aa[2] + (INT64_C(1) << 29), 30u, flags);
        vv = spi_narrow_floor((int64_t)va[0] * va[0] + (int64_t)va[1] * va[1] + (int64_t)va[2] * va[2] -
                                  (int64_t)ld * ld + (INT64_C(1) << 23),
                              24u, flags);
        if (vv < 0) {
            vv = 0; /* |v_A|^2 >= L'^2 up to rounding */
        }
        inv = spi_recip((uint32_t)ik->length[i], &sh); /* 1/L = inv / 2^sh, sh in [54, 61] */
        inv >>= (sh - 54u);                            /* Q30 */
        inv2 = qmul(inv, inv, 30u, flags);
        uzg = qmul(p->gravity, u[2], 30u, flags);
        lr = spi_sat((int64_t)ik->length[i] - lm->rod_com, flags);
        mrlr = qmul(lm->rod_mass, lr, 24u, flags);
        mu = qmul(spi_sat((int64_t)mcdc2 + qmul(mrlr, lr, 24u, flags), flags), inv2, 30u, flags);
        kgm = qmul(spi_sat((int64_t)mcdc + mrlr, flags), inv, 30u, flags);
        bq = spi_sat((int64_t)mcdc2 - qmul(mrlr, lm->rod_com, 24u, flags), flags);
        c1 = -qmul(qmul(qmul(bq, inv2, 30u, flags), inv, 30u, flags), ld, 23u, flags); /* -2 (B / L^3) L' */
        acc_term = spi_sat((int64_t)ua + uzg + qmul(qmul(lm->rod_com, vv, 24u, flags), inv2, 30u, flags), flags);
        axial[i] = spi_narrow_floor((int64_t)lm->rod_mass * acc_term - (int64_t)mu * ua - (int64_t)kgm * uzg -
                                        (int64_t)c1 * ld + (INT64_C(1) << 23),
                                    24u, flags);
        for (k = 0u; k < 3u; ++k) {
            int64_t v = (int64_t)mu * aa[k] + (int64_t)c1 * va[k];
            if (k == 2u) {
                v += (int64_t)kgm * p->gravity;
            }
            hw[k] = spi_narrow_floor(v + (INT64_C(1) << 23), 24u, flags);
            fsum[k] += hw[k];
        }
        msum[0] += (int64_t)r[1] * hw[2] - (int64_t)r[2] * hw[1];
        msum[1] += (int64_t)r[2] * hw[0] - (int64_t)r[0] * hw[2];
        msum[2] += (int64_t)r[0] * hw[1] - (int64_t)r[1] * hw[0];
    }
    legs_sums_done(fsum, msum, NULL, b);
}

/* round(v / 2^s) (ties up) as int32, for a v whose bound (argued at each
 * use) keeps the result within int32: no test. */
SPI_INLINE int32_t fit(int64_t v, unsigned s)
{
    return (int32_t)((v + (INT64_C(1) << (s - 1u))) >> s);
}

/*
 * The leg terms of leg_terms_wide (same formulas, same outputs, rounded
 * differently) for inputs inside an envelope that bounds every
 * intermediate, so that only the outputs (the leg reactions hw and the
 * axial terms, N in Q16, as in leg_terms_wide) need a saturating
 * narrowing: every other product and sum is exact or rounded once, with no
 * test. Also returns the leg rates L' in rate (m/s, Q24), J_i . [v; w_b]
 * from the Jacobian's rows (legs_rates_jac; w_b as sp_leg_rates), for
 * every leg: only the legs computed need v_A. Returns 0 (b, axial and
 * rate untouched) when an input is
 * outside the envelope; the caller then runs leg_terms_wide. wd: the body
 * angular acceleration (Q24, sp_body_rates_sc).
 *
 * Envelope (far beyond any hydraulic hexapod):
 *   m_c + m_r + 4 (I_c + I_r) < 512 kg (I_c, I_r in kg m^2, with
 *   I_c + I_r < 128 kg m^2), d_c, d_r < 4 m, |g| < 16 m/s^2,
 *   |v_c| < 4 m/s, |a_c| < 64 m/s^2, |w_b,c| < 4 rad/s (base frame),
 *   |w'_c| < 64 rad/s^2 (body frame), c = each component,
 *   per leg computed (not kept): max(d_c, d_r, 0.5 m) < L < 8 m and
 *   |r_c| < 4 m (the rates need no per-leg bound: |J_i| entries < 8).
 * Then (|.| Euclidean) |w_b| < 6.93, |w_b'| < 111, |a| < 111, |v| < 6.93,
 * |r| < 6.93 and
 *   |w_b x r| < 48 m/s, |v_A| < 55 m/s, |L'| <= |v_A|, |v_A|^2 < 3025,
 *   |a_A| < 111 + 111 * 6.93 + 6.93 * 48 < 1213 m/s^2.
 * Coefficients. With q = 1/L and the per-call constants
 *   K1 = m_c d_c - m_r d_r,  N = m_r d_r,  K2 = m_c d_c^2 + m_r d_r^2 + I,
 *   I = I_c + I_r, t = K2 q (below m_c d_c + m_r d_r + 2 I
 *   < 4 (m_c + m_r) + 2 I < 2048 kg m as d < L and q < 2)
 * the formulas above leg_terms_wide read (e = d_c q, y = d_r q, z = 1 - y)
 *   k_g = m_c e + m_r z           = m_r + K1 q
 *   mu  = m_c e^2 + m_r z^2 + I q^2  = m_r + q (t - 2 N)
 *   c1  = -2 L' B / L^3           = -2 L' (C / L),  C / L = q^2 (t - N)
 *   s_i = (m_r - mu) u.a_A + (m_r - k_g) g u_z + (N q^2) (|v_A|^2 - L'^2)
 *         + 2 (C / L) L'^2
 * (C = B / L^2 = m_c e^2 - m_r y z + I q^2; I q^2 < 4 I). Each of mu, k_g
 * is in [0, 512) kg, C in (-128, 512) kg, so |C / L| < 1024 kg/m, N q^2 < 1024 kg/m and
 * |c1| < 2 * 55 * 1024 < 2^17 kg/s.
 * Formats: v_A Q24, a_A Q20, L' Q24, u.a_A Q20, |v_A|^2 - L'^2 and L'^2
 * Q16, q Q30, q^2 Q28, masses and coefficients Q16, c1 Q12; hw and s_i
 * are sums in Q36 (each below 2^60) narrowed once, saturating (a leg
 * reaction of 32768 N or more fails the call with SP_E_OVERFLOW, as in
 * leg_terms_wide). Each bound is noted where it is used.
 * Legs in `keep` (bit i: leg i; hold not NULL) take their reaction and
 * axial term from *hold instead (sp_inverse_dynamics_held); the others'
 * are written to *hold when it is not NULL.
 * id_solve gives a motion at rest to leg_terms_at_rest (the same bits).
 */
/* 1 when the motion is at rest (v, w, a and wd all zero). A moving
 * reference has a rate or an acceleration that is not zero, mostly the
 * first ones looked at: the test stops there. */
SPI_INLINE int at_rest(const sp_motion_t *m, const sp_q24_t wd[3])
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        if (m->vel[k] != 0 || m->rpy_rate[k] != 0) {
            return 0;
        }
    }
    for (k = 0u; k < 3u; ++k) {
        if (m->acc[k] != 0 || wd[k] != 0) {
            return 0;
        }
    }
    return 1;
}

/* leg_terms' envelope of the legs' masses and inertias (every field >= 0:
 * checked by the caller), 0 within it: I_c + I_r < 128 kg m^2 (2^23 in
 * Q16) and m_c + m_r + 4 (I_c + I_r) < 512 kg (2^25), which keeps mu, k_g
 * and C within the bounds leg_one argues. With no inertia, the masses'
 * test as before. */
SPI_INLINE uint32_t legs_mass_outside(const sp_leg_mass_t *lm)
{
    const uint32_t in = (uint32_t)lm->cylinder_inertia + (uint32_t)lm->rod_inertia; /* < 2^32: each < 2^31 */
    uint32_t out = ((uint32_t)lm->cylinder_mass + (uint32_t)lm->rod_mass) >> 25;
    if (in != 0u) {
        const uint64_t sum = ((uint64_t)lm->cylinder_mass + (uint64_t)lm->rod_mass) + ((uint64_t)in << 2);
        out = (in >> 23) | (uint32_t)(sum >> 25);
    }
    return out;
}

/*
 * leg_terms for a motion at rest (v, a, the angle rates and wd all zero:
 * the ENGAGE tick, READY, the first tick of a park; the caller checks
 * with at_rest), 0 outside leg_terms' envelope: w_b, v_A, a_A, L' and
 * u.a_A are then exactly 0 in leg_terms' formulas (wb: 2^29 >> 30, v_A:
 * 2^23 >> 24, a_A: 2^27 >> 28, L': 2^29 >> 30), and so is every term that
 * multiplies them. What is left per leg, with leg_terms' roundings:
 *   hw = (m_r + K1 q) g e_z,   s_i = -(K1 q) g u_z,
 * about 60 % of a leg's cost less (the ENGAGE tick computes all six).
 * The same bits as leg_terms' general formulas (tests/unit/
 * test_dynamics_rest.c builds them with SPI_LEG_TERMS_AT_REST 0).
 */
SPI_NOINLINE static int leg_terms_at_rest(const sp_platform_t *p, const sp_ik_t *ik, int64_t b[SP_LEGS],
                                          sp_q16_t axial[SP_LEGS], sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold,
                                          unsigned keep, sp_flags_t *flags)
{
    const sp_leg_mass_t *lm = &p->leg_mass;
    const int32_t mr = lm->rod_mass; /* Q16 */
    const int32_t dc = lm->cylinder_com;
    const int32_t dr = lm->rod_com;
    int64_t fsum[3] = {0, 0, 0}; /* N, Q16 */
    int64_t msum[3] = {0, 0, 0}; /* N m, Q40 */
    int32_t g20, k1, lmin;
    unsigned i;
    unsigned k;

    /* leg_terms' global envelope, its rates and accelerations 0 */
    if ((out_of(p->gravity, 28u) | out_of(dc, 26u) | out_of(dr, 26u) | legs_mass_outside(lm)) != 0u) {
        return 0;
    }
    lmin = (dc > dr) ? dc : dr;
    if (lmin < (INT32_C(1) << 23)) {
        lmin = INT32_C(1) << 23; /* 0.5 m */
    }
    g20 = fit(p->gravity, 4u);
    /* K1 = m_c d_c - m_r d_r, Q16, as leg_terms */
    k1 = fit((int64_t)lm->cylinder_mass * dc, 24u) - fit((int64_t)mr * dr, 24u);
    if (keep != 0u) {
        for (k = 0u; k < 3u; ++k) {
            fsum[k] = hold->fsum[k];
            msum[k] = hold->msum[k];
        }
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        const int32_t len = ik->length[i];
        int32_t q, kq, guz, hz;
        int64_t mo[3];
        unsigned sh;

        if (((keep >> i) & 1u) != 0u) {
            axial[i] = hold->axial[i];
            continue;
        }
        /* the envelope's per-leg part, for the legs to compute (as
         * leg_terms: when it fails here, it fails there) */
        if ((uint32_t)len - (uint32_t)lmin - 1u >= (UINT32_C(1) << 27) - (uint32_t)lmin - 1u ||
            (out_of(r[0], 26u) | out_of(r[1], 26u) | out_of(r[2], 26u)) != 0u) {
            return 0; /* L outside (lmin, 8 m) or |r_c| >= 4 m */
        }
        q = spi_recip((uint32_t)len, &sh); /* 1/L = q / 2^sh, sh in [54, 57] */
        q >>= (sh - 54u);
        kq = fit((int64_t)k1 * q, 30u);                /* k_g - m_r = K1 q */
        guz = fit((int64_t)g20 * ik->unit[i][2], 30u); /* g u_z, Q20 */
        /* hw = (0, 0, (m_r + K1 q) g), narrowed as in leg_terms (x and y:
         * 2^19 >> 20 = 0) */
        hz = spi_narrow_floor((int64_t)(mr + kq) * g20 + (INT64_C(1) << 19), 20u, flags);
        mo[0] = (int64_t)r[1] * hz;
        mo[1] = -(int64_t)r[0] * hz;
        mo[2] = 0;
        fsum[2] += hz;
        for (k = 0u; k < 3u; ++k) {
            msum[k] += mo[k];
            if (hold != NULL) {
                if (keep != 0u) {
                    fsum[k] -= hold->hw[i][k];
                    msum[k] -= hold->mo[i][k];
                }
                hold->hw[i][k] = (k == 2u) ? hz : 0;
                hold->mo[i][k] = mo[k];
            }
        }
        axial[i] = spi_narrow_floor(-(int64_t)kq * guz + (INT64_C(1) << 19), 20u, flags);
        if (hold != NULL) {
            hold->axial[i] = axial[i];
        }
    }
    legs_sums_done(fsum, msum, hold, b);
    for (i = 0u; i < SP_LEGS; ++i) {
        rate[i] = 0; /* L' at rest */
    }
    return 1;
}

/* The legs' rates L'_i = J_i . [v; w_b] (m/s, Q24) from the Jacobian's
 * rows (Q28) and v, w_b (Q24): six exact products (each below 2^57 in
 * leg_terms' envelope: |J_i| entries below 8, |v_c|, |w_b,c| below 4)
 * summed (|L'| < 55 m/s: below 2^58 in Q52) and rounded once, ties up.
 * Out of line: a plain loop, its x in registers. */
SPI_NOINLINE static void legs_rates_jac(const sp_jacobian_t *jac, const sp_q24_t v[3], const sp_q24_t wb[3],
                                        sp_q24_t rate[SP_LEGS])
{
    const int32_t x0 = v[0], x1 = v[1], x2 = v[2], x3 = wb[0], x4 = wb[1], x5 = wb[2];
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        const int32_t *ji = jac->j[i];
        rate[i] = fit((int64_t)ji[0] * x0 + (int64_t)ji[1] * x1 + (int64_t)ji[2] * x2 + (int64_t)ji[3] * x3 +
                          (int64_t)ji[4] * x4 + (int64_t)ji[5] * x5,
                      28u);
    }
}

/* leg_terms' envelope (masses and centres are >= 0: checked by the
 * caller), 0 within it: its global part, w_b,c in [-2^26, 2^26) when wa_c's
 * high word is in [-2^24, 2^24), m_c + m_r < 2^25 (512 kg in Q16); its
 * per-leg part for the legs in todo (a kept leg's terms were computed
 * within it), L in (lmin, 8 m) and |r_c| < 4 m. */
SPI_INLINE uint32_t legs_outside(const sp_platform_t *p, const sp_ik_t *ik, const sp_motion_t *m, const sp_q24_t wd[3],
                                 const int64_t wa[3], unsigned todo)
{
    const sp_leg_mass_t *lm = &p->leg_mass;
    const int32_t dc = lm->cylinder_com;
    const int32_t dr = lm->rod_com;
    int32_t lmin;
    unsigned i;
    uint32_t out = out_of((int32_t)(wa[0] >> 32), 24u) | out_of((int32_t)(wa[1] >> 32), 24u) |
                   out_of((int32_t)(wa[2] >> 32), 24u) | out_of(wd[0], 30u) | out_of(wd[1], 30u) | out_of(wd[2], 30u) |
                   out_of(m->vel[0], 26u) | out_of(m->vel[1], 26u) | out_of(m->vel[2], 26u) | out_of(m->acc[0], 30u) |
                   out_of(m->acc[1], 30u) | out_of(m->acc[2], 30u) | out_of(p->gravity, 28u) | out_of(dc, 26u) |
                   out_of(dr, 26u) | legs_mass_outside(lm);
    if (out != 0u) {
        return out;
    }
    lmin = (dc > dr) ? dc : dr;
    if (lmin < (INT32_C(1) << 23)) {
        lmin = INT32_C(1) << 23; /* 0.5 m */
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        if (((todo >> i) & 1u) != 0u) {
            out |=
                (uint32_t)((uint32_t)ik->length[i] - (uint32_t)lmin - 1u >= (UINT32_C(1) << 27) - (uint32_t)lmin - 1u) |
                out_of(r[0], 26u) | out_of(r[1], 26u) | out_of(r[2], 26u);
        }
    }
    return out;
}

/* What the legs leg_terms computes share: the motion's terms, the
 * angular acceleration in the base frame ab (Q24), v and a with their
 * roundings' halves vb and ac (Q48, as sp_leg_rates; a's half of Q20). */
SPI_INLINE void legs_motion(const sp_ik_t *ik, const sp_motion_t *m, const sp_q24_t wd[3], sp_q24_t ab[3],
                            int64_t vb[3], int64_t ac[3])
{
    unsigned k;
    for (k = 0u; k < 3u; ++k) {
        /* R w': rows of T (|T_rc| <= 2^30 + small) dotted with w':
         * |.| <= |w'| < 111 rad/s^2 */
        ab[k] =
            fit((int64_t)ik->rot.t[0][k] * wd[0] + (int64_t)ik->rot.t[1][k] * wd[1] + (int64_t)ik->rot.t[2][k] * wd[2],
                30u);
        vb[k] = (int64_t)m->vel[k] * (INT64_C(1) << 24) + (INT64_C(1) << 23);
        ac[k] = (int64_t)m->acc[k] * (INT64_C(1) << 24) + (INT64_C(1) << 27);
    }
}

/* The leg's moment r x hw (Q40, each below 2^57) into msum, and its
 * reaction and moment kept in *hold (not NULL), a kept sum dropping the
 * leg's earlier terms (exact). */
SPI_INLINE void leg_moment(const sp_q24_t r[3], const int32_t hw[3], unsigned leg, int64_t fsum[3], int64_t msum[3],
                           sp_leg_hold_t *hold, unsigned keep)
{
    int64_t mo[3];
    unsigned k;
    mo[0] = (int64_t)r[1] * hw[2] - (int64_t)r[2] * hw[1];
    mo[1] = (int64_t)r[2] * hw[0] - (int64_t)r[0] * hw[2];
    mo[2] = (int64_t)r[0] * hw[1] - (int64_t)r[1] * hw[0];
    for (k = 0u; k < 3u; ++k) {
        msum[k] += mo[k];
        if (hold != NULL) {
            if (keep != 0u) {
                fsum[k] -= hold->hw[leg][k];
                msum[k] -= hold->mo[leg][k];
            }
            hold->hw[leg][k] = hw[k];
            hold->mo[leg][k] = mo[k];
        }
    }
}

/* The per-call constants of leg_terms' legs, Q16 (m_c, m_r < 512 kg,
 * d < 4 m, I_c + I_r < 128 kg m^2), and g (Q20). */
typedef struct {
    int32_t mr;  /* m_r */
    int32_t g20; /* g, Q20 */
    int32_t nn;  /* N = m_r d_r < 2048 */
    int32_t k1;  /* K1 = m_c d_c - N */
    int32_t k2;  /* K2 = m_c d_c^2 + m_r d_r^2 + I_c + I_r < 8192 kg m^2 */
} legs_const_t;

SPI_INLINE void legs_constants(const sp_platform_t *p, legs_const_t *c)
{
    const sp_leg_mass_t *lm = &p->leg_mass;
    const int32_t dc = lm->cylinder_com;
    const int32_t dr = lm->rod_com;
    const int32_t mcdc = fit((int64_t)lm->cylinder_mass * dc, 24u); /* m_c d_c < 2048 */
    c->mr = lm->rod_mass;
    c->g20 = fit(p->gravity, 4u);
    c->nn = fit((int64_t)c->mr * dr, 24u);
    c->k1 = mcdc - c->nn;
    /* K2 < 16 (m_c + m_r) + I < 8192: m_c + m_r + 4 I < 512 */
    c->k2 = fit((int64_t)mcdc * dc + (int64_t)c->nn * dr, 24u) + lm->cylinder_inertia + lm->rod_inertia;
}

/* One leg's terms (leg_terms): its reaction into fsum and its moment into
 * msum (and *hold), its axial term; ld its rate L'. It reads v through m:
 * from a plain int32 pointer GCC would reload it after every store to
 * *hold and axial (65 instructions an inverse dynamics, QEMU icount). */
SPI_INLINE void leg_one(const legs_const_t *c, const sp_q24_t wb[3], const sp_q24_t ab[3], const int64_t vb[3],
                        const int64_t ac[3], const sp_ik_t *ik, const sp_motion_t *m, unsigned leg, int32_t ld,
                        int64_t fsum[3], int64_t msum[3], sp_q16_t axial[SP_LEGS], sp_leg_hold_t *hold, unsigned keep,
                        sp_flags_t *flags)
{
    const sp_q24_t *r = ik->arm[leg];
    const sp_q30_t *u = ik->unit[leg];
    int32_t va[3]; /* v_A, m/s, Q24 */
    int32_t aa[3]; /* a_A, m/s^2, Q20 */
    int32_t ua, ld2, vv, q, q2, tq, kq, dmu, mu, cq, c1, nq2, guz, hw[3];
    unsigned sh;
    unsigned k;

    /* v_A = v + w_b x r rounded once: products below 2^53, |v_A| <
     * 55 m/s */
    va[0] = (int32_t)((vb[0] + (int64_t)wb[1] * r[2] - (int64_t)wb[2] * r[1]) >> 24);
    va[1] = (int32_t)((vb[1] + (int64_t)wb[2] * r[0] - (int64_t)wb[0] * r[2]) >> 24);
    va[2] = (int32_t)((vb[2] + (int64_t)wb[0] * r[1] - (int64_t)wb[1] * r[0]) >> 24);
    /* a_A = a + w_b' x r + w_b x (v_A - v), one Q48 sum (below
     * 1213 2^48 < 2^59) rounded once to Q20 */
    {
        const int32_t t0 = va[0] - m->vel[0];
        const int32_t t1 = va[1] - m->vel[1];
        const int32_t t2 = va[2] - m->vel[2];
        aa[0] = (int32_t)((ac[0] + (int64_t)ab[1] * r[2] - (int64_t)ab[2] * r[1] + (int64_t)wb[1] * t2 -
                           (int64_t)wb[2] * t1) >>
                          28);
        aa[1] = (int32_t)((ac[1] + (int64_t)ab[2] * r[0] - (int64_t)ab[0] * r[2] + (int64_t)wb[2] * t0 -
                           (int64_t)wb[0] * t2) >>
                          28);
        aa[2] = (int32_t)((ac[2] + (int64_t)ab[0] * r[1] - (int64_t)ab[1] * r[0] + (int64_t)wb[0] * t1 -
                           (int64_t)wb[1] * t0) >>
                          28);
    }
    /* u.a_A (Q20, < 1213), L'^2 and |v_A|^2 - L'^2 (Q16, below
     * 3025): sums below 2^62 */
    ua = fit((int64_t)u[0] * aa[0] + (int64_t)u[1] * aa[1] + (int64_t)u[2] * aa[2], 30u);
    ld2 = fit((int64_t)ld * ld, 32u);
    vv = fit((int64_t)va[0] * va[0] + (int64_t)va[1] * va[1] + (int64_t)va[2] * va[2], 32u) - ld2;
    if (vv < 0) {
        vv = 0; /* |v_A|^2 >= L'^2 up to rounding */
    }
    /* the leg's coefficients from q = 1/L (Q30, in (1/8, 2)) */
    q = spi_recip((uint32_t)ik->length[leg], &sh); /* 1/L = q / 2^sh, sh in [54, 57] */
    q >>= (sh - 54u);
    q2 = fit((int64_t)q * q, 32u);                 /* q^2, Q28, < 4 */
    tq = fit((int64_t)c->k2 * q, 30u);             /* t = K2 q, Q16, < 2048 */
    kq = fit((int64_t)c->k1 * q, 30u);             /* k_g - m_r = K1 q, |.| < 4096 */
    dmu = fit((int64_t)q * (tq - 2 * c->nn), 30u); /* mu - m_r */
    mu = c->mr + dmu;
    cq = fit((int64_t)q2 * (tq - c->nn), 28u); /* C / L, kg/m, Q16 */
    nq2 = fit((int64_t)q2 * c->nn, 28u);       /* N q^2, kg/m, Q16 */
    c1 = -fit((int64_t)cq * ld, 27u);          /* -2 (C / L) L', Q16 x Q24 -> Q12 */
    guz = fit((int64_t)c->g20 * u[2], 30u);    /* g u_z, Q20 */
    /* hw = mu a_A + c1 v_A + k_g g e_z: Q16 x Q20, Q12 x Q24, Q16 x Q20,
     * each below 2^59 (512 1213, 2^17 55, 512 16 in N, times 2^36) */
    for (k = 0u; k < 3u; ++k) {
        int64_t v = (int64_t)mu * aa[k] + (int64_t)c1 * va[k];
        if (k == 2u) {
            v += (int64_t)(c->mr + kq) * c->g20;
        }
        hw[k] = spi_narrow_floor(v + (INT64_C(1) << 19), 20u, flags);
        fsum[k] += hw[k];
    }
    leg_moment(r, hw, leg, fsum, msum, hold, keep);
    /* s_i, Q36: (m_r - mu) u.a_A, (m_r - k_g) g u_z (each below
     * 512 1213 2^36, 4096 16 2^36) and (N q^2 vv + 2 (C / L) L'^2) 2^4
     * (below 3 1024 3025 2^36): below 2^60 */
    axial[leg] = spi_narrow_floor(((int64_t)nq2 * vv + (int64_t)cq * ld2 * 2) * 16 - (int64_t)dmu * ua -
                                      (int64_t)kq * guz + (INT64_C(1) << 19),
                                  20u, flags);
    if (hold != NULL) {
        hold->axial[leg] = axial[leg];
    }
}

SPI_NOINLINE static int leg_terms(const sp_platform_t *p, const sp_ik_t *ik, const sp_jacobian_t *jac,
                                  const sp_motion_t *m, const sp_q24_t wd[3], int64_t b[SP_LEGS],
                                  sp_q16_t axial[SP_LEGS], sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned keep,
                                  sp_flags_t *flags)
{
    int64_t wa[3];                           /* w_b 2^30, as sp_leg_rates */
    sp_q24_t wb[3];                          /* angular velocity, base frame, Q24 */
    sp_q24_t ab[3];                          /* angular acceleration, base frame, Q24 */
    int64_t vb[3];                           /* v 2^24 + 2^23 */
    int64_t ac[3];                           /* a 2^24 + 2^27 */
    legs_const_t c = {0, 0, 0, 0, 0};        /* set when a leg is to compute */
    int64_t sums[2][3];                      /* the sums when nothing is kept (hold NULL) */
    int64_t *fsum = sums[0];                 /* N, Q16 */
    int64_t *msum = sums[1];                 /* N m, Q40 */
    unsigned todo = SP_ALL_LEG_BITS & ~keep; /* bit i: leg i's terms still to compute */
    unsigned i;
    unsigned k;

    /* w_b = roll' (R e_x) + pitch' (Rz e_y) + yaw' e_z exactly as
     * sp_leg_rates (below 2^63) */
    wa[0] = (int64_t)m->rpy_rate[0] * ik->rot.t[0][0] - (int64_t)m->rpy_rate[1] * ik->sc[4] + (INT64_C(1) << 29);
    wa[1] = (int64_t)m->rpy_rate[0] * ik->rot.t[0][1] + (int64_t)m->rpy_rate[1] * ik->sc[5] + (INT64_C(1) << 29);
    wa[2] = (int64_t)m->rpy_rate[0] * ik->rot.t[0][2] + (int64_t)m->rpy_rate[2] * SP_Q30_ONE + (INT64_C(1) << 29);
    if (legs_outside(p, ik, m, wd, wa, todo) != 0u) {
        return 0;
    }
    for (k = 0u; k < 3u; ++k) {
        wb[k] = (int32_t)(wa[k] >> 30);
    }
    legs_rates_jac(jac, m->vel, wb, rate);
    if (hold != NULL) {
        /* the sums updated where they are kept */
        fsum = hold->fsum;
        msum = hold->msum;
    }
    if (keep != 0u) {
        /* the kept legs' axial terms (the others' are overwritten below) */
        for (i = 0u; i < SP_LEGS; ++i) {
            axial[i] = hold->axial[i];
        }
    } else {
        for (k = 0u; k < 3u; ++k) {
            fsum[k] = 0;
            msum[k] = 0;
        }
    }
    if (todo != 0u) {
        /* what the legs to compute share (none on a tick that keeps all) */
        legs_motion(ik, m, wd, ab, vb, ac);
        legs_constants(p, &c);
    }
    for (; todo != 0u; todo &= todo - 1u) {
        /* the legs not kept, lowest first */
        const unsigned leg = 31u - spi_clz32(todo & (0u - todo));
        leg_one(&c, wb, ab, vb, ac, ik, m, leg, rate[leg], fsum, msum, axial, hold, keep, flags);
    }
    legs_sums_done(fsum, msum, NULL, b); /* kept in *hold already */
    return 1;
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
    sp_jacobian_t jac;
    sp_status_t st = (ik != NULL) ? sp_jacobian(ik, &jac) : SP_E_ARG;
    if (st != SP_OK && force != NULL && lu != NULL) {
        unsigned k;
        lu->valid = 0u;
        for (k = 0u; k < SP_LEGS; ++k) {
            force[k] = 0;
        }
    }
    if (st != SP_OK) {
        return (force == NULL || lu == NULL) ? SP_E_ARG : st;
    }
    return sp_inverse_dynamics_jac(platform, motion, ik, &jac, ext_force, force, lu);
}

/* 1 when |x| >= 2^24, else 0: x is in (-2^24, 2^24) exactly when x +
 * 2^24 - 1 (modulo 2^32) is below 2^25 - 1. */
SPI_INLINE uint32_t beyond24(int32_t x)
{
    return (uint32_t)((uint32_t)x + UINT32_C(0xFFFFFF) >= UINT32_C(0x1FFFFFF));
}

/* The refinement's right-hand side (sp_inverse_dynamics_held): r = b -
 * J^T fq 2^16 in Q24, J^T fq summed exactly in Q36 (|J| < 2^31 Q28 and
 * |fq| < 2^24 Q8: each product below 2^55, six below 2^58) and rounded
 * once (ties up). Returns 0 (r unusable) when an fq is 2^24 or more in
 * magnitude. |b| < 2^56 (checked by the caller) keeps |r| below 2^57:
 * an r_k beyond sp_lu6_solve's range fails that solve (SP_E_OVERFLOW),
 * which the caller takes as it would a 0 here (it factorises).
 * Out of line, a column of J^T at a time with the six forces in
 * registers (inlined into id_solve, GCC reloaded them and the Jacobian's
 * address for most products: -Os, about 280 instructions against 150). */
SPI_NOINLINE static int id_residual(const sp_jacobian_t *jac, const int32_t fq[SP_LEGS], const int64_t b[SP_LEGS],
                                    int64_t r[SP_LEGS])
{
    const int32_t f0 = fq[0], f1 = fq[1], f2 = fq[2], f3 = fq[3], f4 = fq[4], f5 = fq[5];
    unsigned k;
    if ((beyond24(f0) | beyond24(f1) | beyond24(f2) | beyond24(f3) | beyond24(f4) | beyond24(f5)) != 0u) {
        return 0;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        int64_t acc = (int64_t)jac->j[0][k] * f0 + (int64_t)jac->j[1][k] * f1 + (int64_t)jac->j[2][k] * f2 +
                      (int64_t)jac->j[3][k] * f3 + (int64_t)jac->j[4][k] * f4 + (int64_t)jac->j[5][k] * f5;
        r[k] = b[k] - ((acc + (INT64_C(1) << 11)) >> 12);
    }
    return 1;
}

/* The forces F = f + axial (f in Q24, the axial terms in Q16) rounded to
 * Q8 (ties away from zero, saturating and flagging), and, when fq is not
 * NULL, f alone rounded to Q8 (ties up, held within int32: an |fq| of
 * 2^24 or more is never refined from) as the next refinement's start.
 * With every |f_k| below 2^45 (2 MN) neither can leave int32 (|f +
 * axial 2^8| < 2^45 + 2^39 rounds below 2^30): id_finish rounds them
 * without the tests, the same bits; larger ones take id_finish_checked. */
SPI_COLD static void id_finish_checked(const int64_t f[SP_LEGS], const sp_q16_t axial[SP_LEGS], sp_q8_t force[SP_LEGS],
                                       int32_t fq[SP_LEGS], sp_flags_t *flags)
{
    unsigned k;
    for (k = 0u; k < SP_LEGS; ++k) {
        if (fq != NULL) {
            int64_t q = (f[k] + (INT64_C(1) << 15)) >> 16;
            fq[k] = (q > INT32_MAX) ? INT32_MAX : ((q < INT32_MIN) ? INT32_MIN : (int32_t)q);
        }
        /* Q24 -> Q8, with the legs' axial terms (Q16; 0 for massless legs) */
        force[k] = spi_narrow_away(f[k] + (int64_t)axial[k] * 256, 16u, flags);
    }
}

SPI_INLINE void id_finish(const int64_t f[SP_LEGS], const sp_q16_t axial[SP_LEGS], sp_q8_t force[SP_LEGS],
                          int32_t fq[SP_LEGS], sp_flags_t *flags)
{
    uint32_t out = 0u;
    unsigned k;
    for (k = 0u; k < SP_LEGS; ++k) {
        out |= out_of((int32_t)(f[k] >> 32), 13u);
    }
    if (!SPI_ID_RANGE_FAST || out != 0u) {
        id_finish_checked(f, axial, force, fq, flags);
        return;
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        if (fq != NULL) {
            fq[k] = (int32_t)((f[k] + (INT64_C(1) << 15)) >> 16);
        }
        force[k] = (int32_t)spi_round_away(f[k] + (int64_t)axial[k] * 256, 16u);
    }
}

/* The plan for the factorisation kept in *kept_lu (lu_keep > 1) with
 * *lu the last call's: *refine 1 to refine from kept_lu->fq with *lu;
 * returns the stage, 1: then begin the staged factorisation, ID_LU_STEP:
 * then take its middle step, 2: finish it first, ID_LU_WAIT: none (a
 * waiting call: its age not counted). */
SPI_INLINE unsigned id_lu_plan(sp_leg_hold_t *kept_lu, const sp_lu6_t *lu, int *refine)
{
    unsigned stage = 0u;
    unsigned lead = SPI_LU_LEAD((unsigned)kept_lu->lu_staged);
    *refine = lu->valid && kept_lu->held == SP_ALL_LEG_BITS;
    if (kept_lu->lu_wait && *refine && !kept_lu->lu_waited &&
        (kept_lu->lu_next.begun || (kept_lu->lu_age < kept_lu->lu_keep))) {
        kept_lu->lu_waited = 1u;
        stage = ID_LU_WAIT;
    } else if (kept_lu->lu_next.begun) {
        /* begun by an earlier call: its middle step (three calls), else
         * finished, it serves this call */
        stage = (kept_lu->lu_staged >= 3u && kept_lu->lu_next.steps < SP_LU6_STAGE_STEPS) ? ID_LU_STEP : 2u;
    } else if (kept_lu->lu_age + lead >= kept_lu->lu_keep) {
        /* due: a staged factorisation begins after this call's
         * refinement, else one is made now */
        stage = (kept_lu->lu_staged >= 2u && kept_lu->lu_age + lead == kept_lu->lu_keep) ? 1u : 0u;
        *refine = *refine && stage != 0u;
    }
    if (!*refine) {
        kept_lu->lu_next.begun = 0u; /* not finished: factorised afresh */
    }
    return stage;
}

/* Translation (eq 7): sum F_i u_i = m a - L + m g e_z, N in Q24, into
 * b[0..2]. Each term is below 2^47 in magnitude (Q16 x Q24 >> 16, Q8 <<
 * 16): the sum cannot overflow. */
SPI_INLINE void id_translation(const sp_platform_t *platform, const sp_motion_t *motion, const sp_q8_t ext_force[3],
                               int64_t b[SP_LEGS])
{
    unsigned k;
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
}

/* One refinement step with the kept factorisation (still in *lu: only
 * its valid flag was cleared), finishing the staged one first (stage 2),
 * beginning the next (stage 1) or taking its middle step (ID_LU_STEP)
 * after: f = fq 2^16 + LU^-1 (b - J^T fq).
 * Returns 0 when it cannot (the caller factorises), *st the solve's. */
SPI_INLINE int id_refine(sp_leg_hold_t *kept_lu, sp_lu6_t *lu, const sp_jacobian_t *jac, unsigned stage,
                         const int64_t b[SP_LEGS], int64_t f[SP_LEGS], sp_status_t *st)
{
    int64_t r[SP_LEGS];
    int64_t df[SP_LEGS];
    int refine = 1;
    unsigned k;
    if (stage == 2u) {
        /* the factorisation of the J^T of the call that began it: one
         * call old (two after a waiting call) */
        refine = (sp_lu6_factor_end(&kept_lu->lu_next, lu) == SP_OK);
        kept_lu->lu_age = 0u;
        kept_lu->lu_waited = 0u;
    }
    if (!refine || !id_residual(jac, kept_lu->fq, b, r)) {
        return 0;
    }
    lu->valid = 1u;
    *st = sp_lu6_solve_grow(lu, r, df);
    if (*st != SP_OK) {
        return 0; /* factorise instead */
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        f[k] = (int64_t)kept_lu->fq[k] * 65536 + df[k]; /* below 2^41 + 2^56 */
    }
    if (stage != ID_LU_WAIT) {
        kept_lu->lu_age = (uint8_t)(kept_lu->lu_age + 1u);
    }
    if (stage == 1u) {
        /* this call's J^T, its first pivot step taken (the next calls
         * take the others); a failure leaves it to a whole one */
        (void)sp_lu6_factor_begin(jac, 1, &kept_lu->lu_next);
    }
    if (stage == ID_LU_STEP) {
        (void)sp_lu6_factor_step(&kept_lu->lu_next); /* likewise */
    }
    return 1;
}

/* The forces' solve J^T f = b (SP_E_OVERFLOW for a b beyond sp_solve6's
 * range): refined with the kept factorisation (refine), else factorised
 * afresh into *lu. */
SPI_INLINE sp_status_t id_forces(sp_leg_hold_t *kept_lu, sp_lu6_t *lu, const sp_jacobian_t *jac, int refine,
                                 unsigned stage, const int64_t b[SP_LEGS], int64_t f[SP_LEGS])
{
    sp_status_t st = SP_OK;
    unsigned k;
    for (k = 0u; k < SP_LEGS; ++k) {
        if (b[k] >= (INT64_C(1) << 56) || b[k] <= -(INT64_C(1) << 56)) {
            return SP_E_OVERFLOW; /* sp_solve6's range */
        }
    }
    if (refine && id_refine(kept_lu, lu, jac, stage, b, f, &st)) {
        return st;
    }
    st = sp_lu6_factor(jac, 1, lu);
    if (st == SP_OK) {
        st = sp_lu6_solve(lu, b, f); /* = sp_solve6(&jac, 1, b, f) */
    }
    if (kept_lu != NULL) {
        kept_lu->lu_age = 0u;
        kept_lu->lu_waited = 0u;
    }
    return st;
}

/* The legs' terms into b and axial: the fast ones (at rest or moving;
 * returns 1, with the legs' rates in rate when it is not NULL), else the
 * wide ones (returns 0; none kept: *hold set to NULL). */
SPI_INLINE int id_legs(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                       const sp_jacobian_t *jac, const sp_q24_t omega[3], const sp_q24_t omega_dot[3],
                       int64_t b[SP_LEGS], sp_q16_t axial[SP_LEGS], sp_q24_t rate[SP_LEGS], sp_leg_hold_t **hold,
                       unsigned keep, sp_flags_t *flags)
{
    sp_q24_t rt[SP_LEGS];
    sp_q24_t *lr = (rate != NULL) ? rate : rt;
    if ((SPI_LEG_TERMS_AT_REST && at_rest(motion, omega_dot) &&
         leg_terms_at_rest(platform, ik, b, axial, lr, *hold, keep, flags)) ||
        leg_terms(platform, ik, jac, motion, omega_dot, b, axial, lr, *hold, keep, flags)) {
        return 1;
    }
    leg_terms_wide(platform, ik, motion, omega, omega_dot, b, axial, flags);
    if (*hold != NULL) {
        (*hold)->fresh = (uint8_t)SP_ALL_LEG_BITS; /* every leg computed, none kept */
        *hold = NULL;
    }
    return 0;
}

SPI_INLINE void id_zero(sp_q8_t force[SP_LEGS])
{
    unsigned k;
    for (k = 0u; k < SP_LEGS; ++k) {
        force[k] = 0;
    }
}

/* 1 when a leg's moment of inertia across the leg is negative (a bad
 * platform: SP_E_ARG), else 0. */
SPI_INLINE int leg_inertia_negative(const sp_platform_t *p)
{
    return (p->leg_mass.cylinder_inertia < 0) || (p->leg_mass.rod_inertia < 0);
}

/* 1 when the legs have a moment of inertia across the leg (then they have
 * leg terms even without mass), else 0. */
SPI_INLINE int leg_inertia_on(const sp_platform_t *p)
{
    return (p->leg_mass.cylinder_inertia != 0) || (p->leg_mass.rod_inertia != 0);
}
/* The call's start: the factorisation's plan when *hold keeps it
 * (*kept_lu, *stage and *refine: id_lu_plan), the legs whose terms *hold
 * keeps (returned; none held again until the call succeeds), *lu invalid
 * and the forces zero until then. */
SPI_INLINE unsigned id_begin(sp_leg_hold_t *hold, sp_lu6_t *lu, unsigned refresh, sp_q8_t force[SP_LEGS],
                             sp_leg_hold_t **kept_lu, unsigned *stage, int *refine)
{
    unsigned keep = 0u;
    if (hold != NULL && hold->lu_keep > 1u) {
        *kept_lu = hold;
        *stage = id_lu_plan(hold, lu, refine);
    }
    if (hold != NULL) {
        /* nothing computed yet: kept again only on success */
        keep = (unsigned)hold->held & ~refresh & SP_ALL_LEG_BITS;
        hold->held = 0u;
        hold->fresh = (uint8_t)(SP_ALL_LEG_BITS & ~keep);
    }
    lu->valid = 0u;
    id_zero(force);
    return keep;
}

/* The forces F = f + axial into force (f's rounding kept in kept_lu->fq
 * when it is not NULL), then the leg rates into rate when it asks for them
 * and the legs' terms did not give them: SP_OK, else the error with the
 * forces zeroed. */
SPI_INLINE sp_status_t id_end(const int64_t f[SP_LEGS], const sp_q16_t axial[SP_LEGS], sp_q8_t force[SP_LEGS],
                              sp_leg_hold_t *kept_lu, sp_lu6_t *lu, const sp_ik_t *ik, const sp_motion_t *motion,
                              sp_q24_t rate[SP_LEGS], int have_rates)
{
    sp_flags_t flags = 0u;
    id_finish(f, axial, force, (kept_lu != NULL) ? kept_lu->fq : NULL, &flags);
    if (flags == 0u && rate != NULL && !have_rates) {
        sp_status_t st = sp_leg_rates(ik, motion->vel, motion->rpy_rate, rate);
        if (st != SP_OK) {
            lu->valid = 0u;
            id_zero(force);
            return st;
        }
    }
    if (flags != 0u) {
        id_zero(force);
        return sp_flags_status(flags);
    }
    return SP_OK;
}

/* sp_inverse_dynamics_jac, and the leg rates in rate when rate is not NULL
 * (sp_inverse_dynamics_rates); body: the body rates when the frames made
 * them (spi_inverse_dynamics_held_body), else NULL. Over 80 lines (a
 * hot path, tests/rules/long_functions.txt): the body rates' choice in a
 * helper of its own, inline or not, cost 26 instructions a tick on the
 * Cortex-M4 (-Os, RUNNING mean of every scenario, GCC 12). */
static sp_status_t id_solve(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                            const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS], sp_lu6_t *lu,
                            sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned refresh, const sp_q24_t body[6])
{
    int have_rates = 0;
    sp_flags_t flags = 0u;
    sp_q24_t omega[3];
    sp_q24_t omega_dot[3];
    int64_t b[SP_LEGS];
    int64_t f[SP_LEGS];
    sp_q16_t axial[SP_LEGS] = {0, 0, 0, 0, 0, 0};
    sp_status_t st;
    int64_t h[3];
    int64_t i_wdot[3];
    int64_t torque_body[3];
    unsigned k;
    int ovf = 0;
    int legs_on;
    unsigned keep;
    sp_leg_hold_t *kept_lu = NULL; /* where the factorisation's age and the forces are kept */
    int refine = 0;                /* 1: refine from hold->fq with the kept *lu */
    unsigned stage = 0u;           /* 1: then begin the staged factorisation; 2: finish it first */

    if (force == NULL || lu == NULL) {
        return SP_E_ARG;
    }
    keep = id_begin(hold, lu, refresh, force, &kept_lu, &stage, &refine);
    if (platform == NULL || motion == NULL || ik == NULL || jac == NULL) {
        return SP_E_ARG;
    }
    if (platform->leg_mass.cylinder_mass < 0 || platform->leg_mass.rod_mass < 0 ||
        platform->leg_mass.cylinder_com < 0 || platform->leg_mass.rod_com < 0 || leg_inertia_negative(platform)) {
        return SP_E_ARG;
    }
    legs_on = (platform->leg_mass.cylinder_mass != 0 || platform->leg_mass.rod_mass != 0 || leg_inertia_on(platform));
    if (hold != NULL && !legs_on) {
        hold->fresh = (uint8_t)SP_ALL_LEG_BITS; /* no leg terms to keep */
        hold = NULL;
        keep = 0u;
    }
    if (body != NULL) {
        /* made by the frames from the same sines and rates, bit for bit */
        for (unsigned c = 0u; c < 3u; ++c) {
            omega[c] = body[c];
            omega_dot[c] = body[c + 3u];
        }
    } else {
        st = sp_body_rates_sc(ik->sc, motion->rpy_rate, motion->rpy_acc, omega, omega_dot);
        if (st != SP_OK) {
            return st;
        }
    }
    id_translation(platform, motion, ext_force, b);
    /* Rotation (eq 8 with the full tensor): I dw/dt + w x (I w), motion
     * frame, N m in Q24, then into the base frame with R = T^T. h and
     * I dw/dt are below 3 2^46, each product term of w x h below 2^55,
     * torque_body below 2^57 and R tau below 3 2^57 (|T| entries <= 1):
     * exact int64 arithmetic, no saturation needed after inertia_times.
     * Here, not in a helper: out of id_solve it cost 8 instructions a call
     * (QEMU icount, GCC 12 -O3). */
    inertia_times2(platform->inertia, omega, omega_dot, h, i_wdot, &ovf);
    torque_body[0] = i_wdot[0] + (mul_split_up(h[2], omega[1], 24u) - mul_split_up(h[1], omega[2], 24u));
    torque_body[1] = i_wdot[1] + (mul_split_up(h[0], omega[2], 24u) - mul_split_up(h[2], omega[0], 24u));
    torque_body[2] = i_wdot[2] + (mul_split_up(h[1], omega[0], 24u) - mul_split_up(h[0], omega[1], 24u));
    if ((platform->center_of_mass[0] | platform->center_of_mass[1] | platform->center_of_mass[2]) != 0) {
        com_terms(platform, ik, motion, omega, omega_dot, b, torque_body, &flags);
    }
    for (k = 0u; k < 3u; ++k) {
        /* (R tau)_k = sum_c R[k][c] tau_c = sum_c T[c][k] tau_c */
        b[3u + k] = mul_split_up(torque_body[0], ik->rot.t[0][k], 30u) +
                    mul_split_up(torque_body[1], ik->rot.t[1][k], 30u) +
                    mul_split_up(torque_body[2], ik->rot.t[2][k], 30u);
    }
    if (legs_on) {
        have_rates = id_legs(platform, motion, ik, jac, omega, omega_dot, b, axial, rate, &hold, keep, &flags);
    }
    if (ovf || flags != 0u) {
        return SP_E_OVERFLOW;
    }
    st = id_forces(kept_lu, lu, jac, refine, stage, b, f);
    if (st != SP_OK) {
        return st;
    }
    st = id_end(f, axial, force, kept_lu, lu, ik, motion, rate, have_rates);
    if (st == SP_OK && hold != NULL) {
        hold->held = (uint8_t)SP_ALL_LEG_BITS; /* kept and computed legs alike */
    }
    return st;
}

sp_status_t sp_inverse_dynamics_jac(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                    const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                    sp_lu6_t *lu)
{
    return id_solve(platform, motion, ik, jac, ext_force, force, lu, NULL, NULL, SP_ALL_LEG_BITS, NULL);
}

sp_status_t sp_inverse_dynamics_rates(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                      const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                      sp_lu6_t *lu, sp_q24_t rate[SP_LEGS])
{
    if (rate == NULL) {
        if (force != NULL) {
            unsigned k;
            for (k = 0u; k < SP_LEGS; ++k) {
                force[k] = 0;
            }
        }
        if (lu != NULL) {
            lu->valid = 0u;
        }
        return SP_E_ARG;
    }
    return id_solve(platform, motion, ik, jac, ext_force, force, lu, rate, NULL, SP_ALL_LEG_BITS, NULL);
}

sp_status_t sp_inverse_dynamics_held(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                     const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                     sp_lu6_t *lu, sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned refresh)
{
    if (hold == NULL) {
        return sp_inverse_dynamics_rates(platform, motion, ik, jac, ext_force, force, lu, rate);
    }
    if (rate == NULL) {
        hold->held = 0u;
        hold->fresh = (uint8_t)SP_ALL_LEG_BITS;
        return sp_inverse_dynamics_rates(platform, motion, ik, jac, ext_force, force, lu, rate); /* SP_E_ARG */
    }
    return id_solve(platform, motion, ik, jac, ext_force, force, lu, rate, hold, refresh, NULL);
}

sp_status_t spi_inverse_dynamics_held_body(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                           const sp_jacobian_t *jac, sp_q8_t force[SP_LEGS], sp_lu6_t *lu,
                                           sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned refresh,
                                           const sp_q24_t body[6])
{
    sp_status_t st;
    if ((hold == NULL) || (rate == NULL) || (body == NULL)) {
        st = sp_inverse_dynamics_held(platform, motion, ik, jac, NULL, force, lu, rate, hold, refresh);
    } else {
        st = id_solve(platform, motion, ik, jac, NULL, force, lu, rate, hold, refresh, body);
    }
    return st;
}
