/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/estimation/motion_error.h"

#include "model/model_internal.h"
#include "math/fixed_inline.h"

/* pi in Q24 (3.14159265 rad), rounded to nearest. */
#define ME_Q24_PI INT64_C(52707179)
/* The raw acceleration is held within [-2^30, 2^30) of Q24 (+-64 m/s^2,
 * rad/s^2). */
#define ME_HI INT32_C(0x3FFFFFFF)
#define ME_LO (-ME_HI - 1)
/* The errors held small, |e| < 2^29 (32 m, rad): the double difference of
 * three of them is below 4 x 2^29 = 2^31, an int32. */
#define ME_SMALL_MAX UINT32_C(0x1FFFFFFF)

sp_status_t sp_motion_error_init(sp_motion_error_t *me, uint32_t tick_us)
{
    uint64_t t2;
    if (me == NULL || tick_us < 100u || tick_us > 1000000u) {
        return SP_E_ARG;
    }
    t2 = (uint64_t)tick_us * tick_us; /* <= 10^12 */
    /* round(10^12 / t^2): in [1, 10^8] */
    me->k = (int32_t)((UINT64_C(1000000000000) + t2 / 2u) / t2);
    me->lim = ME_HI / me->k; /* in [10, 2^30 - 1] */
    sp_motion_error_reset(me);
    return SP_OK;
}

void sp_motion_error_reset(sp_motion_error_t *me)
{
    unsigned k;
    if (me == NULL) {
        return;
    }
    for (k = 0u; k < 6u; ++k) {
        me->e1[k] = 0;
        me->e2[k] = 0;
    }
    me->count = 0u;
    me->small = 0u;
}

/* v held within [ME_LO, ME_HI], flagging when it was not. */
SPI_INLINE int32_t me_hold(int64_t v, sp_flags_t *flags)
{
    if (v > ME_HI) {
        *flags |= SP_FLAG_OVERFLOW;
        return ME_HI;
    }
    if (v < ME_LO) {
        *flags |= SP_FLAG_OVERFLOW;
        return ME_LO;
    }
    return (int32_t)v;
}

/* An angle difference (|d| < 2^32) wrapped into [-pi, pi) (Q24 pi): the
 * division only when it is outside. */
static int32_t me_wrap(int64_t d)
{
    if (d < -ME_Q24_PI || d >= ME_Q24_PI) {
        int64_t r = (d + ME_Q24_PI) % SPI_Q24_TWO_PI;
        if (r < 0) {
            r += SPI_Q24_TWO_PI;
        }
        d = r - ME_Q24_PI;
    }
    return (int32_t)d;
}

/* e - 2 e1 + e2 narrowed to int32: in 32 bits when all three are small
 * (`small`, |.| <= ME_SMALL_MAX: the sum cannot leave int32), else exact in 64 bits
 * (|.| < 2^33) and held (beyond int32 the product with k >= 1 is held
 * anyway). */
SPI_INLINE int32_t me_d2(int32_t e, int32_t e1, int32_t e2, int small)
{
    int64_t d2;
    if (small) {
        return e - 2 * e1 + e2;
    }
    d2 = (int64_t)e - 2 * (int64_t)e1 + e2;
    return (d2 > INT32_MAX) ? INT32_MAX : ((d2 < INT32_MIN) ? INT32_MIN : (int32_t)d2);
}

sp_status_t sp_motion_error_step(sp_motion_error_t *me, const sp_pose_t *est, const sp_pose_t *ref, sp_q24_t da[6])
{
    sp_flags_t flags = 0u;
    sp_q24_t e[6];
    uint32_t big = 0u;
    unsigned small;
    int all_small;
    unsigned k;
    if (me == NULL || da == NULL) {
        return SP_E_ARG;
    }
    if (est == NULL || ref == NULL) {
        sp_motion_error_reset(me);
        for (k = 0u; k < 6u; ++k) {
            da[k] = 0;
        }
        return SP_E_BUSY;
    }
    for (k = 0u; k < 3u; ++k) {
        int64_t dp = (int64_t)est->pos[k] - ref->pos[k];
        if ((uint64_t)dp + ME_SMALL_MAX <= 2u * ME_SMALL_MAX) {
            e[k] = (int32_t)dp; /* small: no saturation to test */
        } else {
            e[k] = spi_sat(dp, &flags);
            big = 1u;
        }
        /* wrapped: |.| <= pi, small */
        e[3u + k] = me_wrap((int64_t)est->rpy[k] - ref->rpy[k]);
    }
    small = (big == 0u) ? 1u : 0u;
    /* this tick's, e1's and e2's errors small */
    all_small = small != 0u && me->small == 3u;
    me->small = (uint8_t)(((unsigned)me->small << 1u | small) & 3u);
    if (me->count < 2u) {
        for (k = 0u; k < 6u; ++k) {
            me->e2[k] = me->e1[k];
            me->e1[k] = e[k];
            da[k] = 0;
        }
        me->count = (uint8_t)(me->count + 1u);
        return (flags == 0u) ? SP_E_BUSY : SP_E_OVERFLOW;
    }
    for (k = 0u; k < 6u; ++k) {
        int32_t d = me_d2(e[k], me->e1[k], me->e2[k], all_small);
        /* m/s^2, Q24: |d| <= lim within the hold, a 32-bit product */
        da[k] = ((uint32_t)d + (uint32_t)me->lim <= 2u * (uint32_t)me->lim) ? d * me->k
                                                                            : me_hold((int64_t)d * me->k, &flags);
        me->e2[k] = me->e1[k];
        me->e1[k] = e[k];
    }
    return (flags == 0u) ? SP_OK : SP_E_OVERFLOW;
}

/* round(a b / 2^s) (ties up), for int32 a, b: below 2^(62-s) */
SPI_INLINE int64_t me_p(int32_t a, int32_t b, unsigned s)
{
    return ((int64_t)a * b + (INT64_C(1) << (s - 1u))) >> s;
}

/* The body angular acceleration dw' = E(angles) d(rpy)'' of zero angle
 * rates (eq 10's derivative without its rate products), from the sines
 * and cosines sc of roll and pitch (Q30), T = t of those sines (as the IK
 * builds it: its third column is -sin pitch, cos pitch sin roll, cos
 * pitch cos roll, the products E takes, read rather than formed again)
 * and the angle accelerations a (rad/s^2, Q24): the three rows of
 * sp_body_rates_sc written out, each sum of two Q24 x Q30 products
 * (|a| <= 2^31, coefficients within a few LSB of 2^30: below 2^62)
 * rounded once (ties up) and saturated beyond int32. Bit-identical to
 * sp_body_rates_sc's omega_dot for zero rates and sines and cosines of one
 * angle (test_motion_error_rows_vs_body_rates). */
SPI_INLINE void me_body_acc(const sp_q30_t sc[6], const sp_q30_t (*t)[3], const sp_q24_t a[3], sp_q24_t wd[3],
                            sp_flags_t *flags)
{
    const int64_t half = INT64_C(1) << 29;
    sp_q30_t sr = sc[0];
    sp_q30_t cr = sc[1];
    sp_q30_t sp = sc[2];
    sp_q30_t cpsr = t[1][2]; /* spi_mul30_up(cp, sr), rot_tilt's */
    sp_q30_t cpcr = t[2][2]; /* spi_mul30_up(cp, cr) */
    wd[0] = spi_narrow_floor((int64_t)a[0] * SP_Q30_ONE - (int64_t)a[2] * sp + half, 30u, flags);
    wd[1] = spi_narrow_floor((int64_t)a[1] * cr + (int64_t)a[2] * cpsr + half, 30u, flags);
    wd[2] = spi_narrow_floor((int64_t)a[2] * cpcr - (int64_t)a[1] * sr + half, 30u, flags);
}

/* dW = M6 da of the body (mass, inertia about o', centre: Q16, Q16, Q24)
 * with T = t (Q30) and the roll and pitch sines sc. */
static sp_status_t me_wrench(sp_q16_t mass, const sp_q16_t (*inertia)[3], const sp_q24_t com[3], const sp_q30_t (*t)[3],
                             const sp_q30_t sc[6], const sp_q24_t da[6], sp_q8_t dw[6])
{
    sp_flags_t flags = 0u;
    sp_q24_t wd[3]; /* body angular acceleration dw', rad/s^2, Q24 */
    sp_q24_t ab[3]; /* R dw', base frame, rad/s^2, Q24 */
    sp_q24_t rc[3]; /* R c, base frame, m, Q24 */
    sp_q16_t mc[3]; /* m R c, base frame, kg m, Q16 */
    sp_q8_t iw[3];  /* I dw', motion frame, N m, Q8 */
    unsigned k;

    me_body_acc(sc, t, &da[3], wd, &flags);
    for (k = 0u; k < 3u; ++k) {
        /* (R v)_k = sum_r T[r][k] v_r: Q30 x Q24 sums below 2^63 */
        ab[k] = spi_narrow_floor((int64_t)t[0][k] * wd[0] + (int64_t)t[1][k] * wd[1] + (int64_t)t[2][k] * wd[2] +
                                     (INT64_C(1) << 29),
                                 30u, &flags);
        rc[k] = spi_narrow_floor((int64_t)t[0][k] * com[0] + (int64_t)t[1][k] * com[1] + (int64_t)t[2][k] * com[2] +
                                     (INT64_C(1) << 29),
                                 30u, &flags);
    }
    for (k = 0u; k < 3u; ++k) {
        const sp_q16_t *row = inertia[k];
        /* Q16 x Q24 products rounded to Q32 (each below 2^54), summed,
         * then to Q8 */
        int64_t s = me_p(row[0], wd[0], 8u) + me_p(row[1], wd[1], 8u) + me_p(row[2], wd[2], 8u);
        iw[k] = spi_narrow_floor(s + (INT64_C(1) << 23), 24u, &flags);
        mc[k] = spi_narrow_floor((int64_t)mass * rc[k] + (INT64_C(1) << 23), 24u, &flags);
    }
    /* force = m da + (R dw') x (m R c); moment = R (I dw') + (m R c) x da,
     * all terms in Q32 (below 2^55 each), narrowed once to Q8 */
    {
        const sp_q24_t *a = da;
        int64_t f[3];
        int64_t m[3];
        f[0] = me_p(mass, a[0], 8u) + me_p(ab[1], mc[2], 8u) - me_p(ab[2], mc[1], 8u);
        f[1] = me_p(mass, a[1], 8u) + me_p(ab[2], mc[0], 8u) - me_p(ab[0], mc[2], 8u);
        f[2] = me_p(mass, a[2], 8u) + me_p(ab[0], mc[1], 8u) - me_p(ab[1], mc[0], 8u);
        m[0] = me_p(mc[1], a[2], 8u) - me_p(mc[2], a[1], 8u);
        m[1] = me_p(mc[2], a[0], 8u) - me_p(mc[0], a[2], 8u);
        m[2] = me_p(mc[0], a[1], 8u) - me_p(mc[1], a[0], 8u);
        for (k = 0u; k < 3u; ++k) {
            /* (R I dw')_k: Q30 x Q8 sums (below 2^63) rounded to Q32 */
            int64_t r =
                ((int64_t)t[0][k] * iw[0] + (int64_t)t[1][k] * iw[1] + (int64_t)t[2][k] * iw[2] + (INT64_C(1) << 5)) >>
                6;
            dw[k] = spi_narrow_floor(f[k] + (INT64_C(1) << 23), 24u, &flags);
            dw[3u + k] = spi_narrow_floor(m[k] + r + (INT64_C(1) << 23), 24u, &flags);
        }
    }
    return (flags == 0u) ? SP_OK : SP_E_OVERFLOW;
}

static sp_status_t me_bad_args(sp_q8_t dw[6])
{
    unsigned k;
    if (dw != NULL) {
        for (k = 0u; k < 6u; ++k) {
            dw[k] = 0;
        }
    }
    return SP_E_ARG;
}

sp_status_t sp_motion_error_wrench(const sp_platform_t *platform, const sp_ik_t *ik, const sp_q24_t da[6],
                                   sp_q8_t dw[6])
{
    if (platform == NULL || ik == NULL || da == NULL || dw == NULL) {
        return me_bad_args(dw);
    }
    return me_wrench(platform->mass, (const sp_q16_t(*)[3])platform->inertia, platform->center_of_mass,
                     (const sp_q30_t(*)[3])ik->rot.t, ik->sc, da, dw);
}

sp_status_t sp_motion_error_wrench_sc(const sp_platform_t *platform, const sp_q30_t sc[6], const sp_q24_t da[6],
                                      sp_q8_t dw[6])
{
    sp_rot_t rot;
    if (platform == NULL || sc == NULL || da == NULL || dw == NULL) {
        return me_bad_args(dw);
    }
    /* T from the sines, as the IK builds it */
    spi_rot_from_sincos(sc, &rot);
    return me_wrench(platform->mass, (const sp_q16_t(*)[3])platform->inertia, platform->center_of_mass,
                     (const sp_q30_t(*)[3])rot.t, sc, da, dw);
}

sp_status_t sp_motion_error_wrench_body_sc(const sp_me_body_t *body, const sp_q30_t sc[6], const sp_q24_t da[6],
                                           sp_q8_t dw[6])
{
    sp_rot_t rot;
    if (body == NULL || sc == NULL || da == NULL || dw == NULL) {
        return me_bad_args(dw);
    }
    spi_rot_from_sincos(sc, &rot);
    return me_wrench(body->mass, (const sp_q16_t(*)[3])body->inertia, body->center_of_mass, (const sp_q30_t(*)[3])rot.t,
                     sc, da, dw);
}

sp_status_t sp_motion_error_wrench_body_t(const sp_me_body_t *body, const sp_rot_t *rot, const sp_q30_t sc[6],
                                          const sp_q24_t da[6], sp_q8_t dw[6])
{
    if (body == NULL || rot == NULL || sc == NULL || da == NULL || dw == NULL) {
        return me_bad_args(dw);
    }
    return me_wrench(body->mass, (const sp_q16_t(*)[3])body->inertia, body->center_of_mass,
                     (const sp_q30_t(*)[3])rot->t, sc, da, dw);
}

/* round(s / 2^32) (ties up) as an int32, for s below 2^62: the high
 * word of s + 2^31, taken from its unsigned shift so that the compiler
 * keeps it a 32-bit value (an int64 >> 32 narrowed and widened again is
 * folded back to the int64, and each product with it then takes a
 * 64 x 64-bit multiply). GCC and Clang convert to int32 modulo 2^32. */
SPI_INLINE int32_t me_q32(int64_t s)
{
    return (int32_t)(uint32_t)((uint64_t)(s + (INT64_C(1) << 31)) >> 32);
}

/* dW = M6 da in the motion frame, where the body's mass, first moment m c
 * and inertia are constants: the linear acceleration turned in (T da),
 * the body-frame wrench
 *   f_b = m T da + dw' x (m c),   m_b = I dw' + (m c) x (T da),
 * and both turned out (R = T^T): the same law as me_wrench (R f_b = m da
 * + (R dw') x (m R c), R m_b = R I dw' + (m R c) x da), with m R c no
 * longer formed per tick and each sum rounded once. b within the
 * envelope of sp_motion_error_m6 (mass, m c, I below 2^29 in Q16). */
static sp_status_t me_wrench_frame(const sp_me_m6_t *b, const sp_q30_t (*t)[3], const sp_q30_t sc[6],
                                   const sp_q24_t da[6], sp_q8_t dw[6])
{
    sp_flags_t flags = 0u;
    const sp_q16_t *mc = b->first;
    const sp_q16_t(*in)[3] = (const sp_q16_t(*)[3])b->body.inertia;
    sp_q16_t m = b->body.mass;
    sp_q24_t wd[3]; /* body angular acceleration dw', rad/s^2, Q24 */
    sp_q24_t ab[3]; /* T da, motion frame, m/s^2, Q24 */
    int32_t fb[3];  /* f_b, N, Q8 */
    int32_t mb[3];  /* m_b, N m, Q8 */
    unsigned k;
    me_body_acc(sc, t, &da[3], wd, &flags);
    for (k = 0u; k < 3u; ++k) {
        /* (T v)_k = sum_r T[k][r] v_r: Q30 x Q24 sums below 2^63 */
        ab[k] = spi_narrow_floor((int64_t)t[k][0] * da[0] + (int64_t)t[k][1] * da[1] + (int64_t)t[k][2] * da[2] +
                                     (INT64_C(1) << 29),
                                 30u, &flags);
    }
    /* Q16 x Q24 products below 2^29 x 2^31 = 2^60: the sums of three
     * (f_b) and five (m_b) below 2^63, and in Q8 below 5 x 2^28 < 2^31 */
    fb[0] = me_q32((int64_t)m * ab[0] + (int64_t)wd[1] * mc[2] - (int64_t)wd[2] * mc[1]);
    fb[1] = me_q32((int64_t)m * ab[1] + (int64_t)wd[2] * mc[0] - (int64_t)wd[0] * mc[2]);
    fb[2] = me_q32((int64_t)m * ab[2] + (int64_t)wd[0] * mc[1] - (int64_t)wd[1] * mc[0]);
    mb[0] = me_q32((int64_t)in[0][0] * wd[0] + (int64_t)in[0][1] * wd[1] + (int64_t)in[0][2] * wd[2] +
                   (int64_t)mc[1] * ab[2] - (int64_t)mc[2] * ab[1]);
    mb[1] = me_q32((int64_t)in[1][0] * wd[0] + (int64_t)in[1][1] * wd[1] + (int64_t)in[1][2] * wd[2] +
                   (int64_t)mc[2] * ab[0] - (int64_t)mc[0] * ab[2]);
    mb[2] = me_q32((int64_t)in[2][0] * wd[0] + (int64_t)in[2][1] * wd[1] + (int64_t)in[2][2] * wd[2] +
                   (int64_t)mc[0] * ab[1] - (int64_t)mc[1] * ab[0]);
    for (k = 0u; k < 3u; ++k) {
        /* (R v)_k = sum_r T[r][k] v_r: Q30 x Q8 below 2^61 each */
        dw[k] = spi_narrow_floor((int64_t)t[0][k] * fb[0] + (int64_t)t[1][k] * fb[1] + (int64_t)t[2][k] * fb[2] +
                                     (INT64_C(1) << 29),
                                 30u, &flags);
        dw[3u + k] = spi_narrow_floor((int64_t)t[0][k] * mb[0] + (int64_t)t[1][k] * mb[1] + (int64_t)t[2][k] * mb[2] +
                                          (INT64_C(1) << 29),
                                      30u, &flags);
    }
    return (flags == 0u) ? SP_OK : SP_E_OVERFLOW;
}

/* The envelope of the body-frame form: |x| below 2^29 (Q16: 8192 kg,
 * kg m, kg m^2). */
#define ME_M6_MAX (INT64_C(1) << 29)

sp_status_t sp_motion_error_m6(const sp_me_body_t *body, sp_me_m6_t *m6)
{
    unsigned j, k;
    int ok;
    if (body == NULL || m6 == NULL) {
        return SP_E_ARG;
    }
    m6->body = *body;
    ok = body->mass > -ME_M6_MAX && body->mass < ME_M6_MAX;
    for (j = 0u; j < 3u; ++j) {
        /* m c: Q16 x Q24 (below 2^62), rounded to Q16 */
        int64_t first = ((int64_t)body->mass * body->center_of_mass[j] + (INT64_C(1) << 23)) >> 24;
        ok = ok && first > -ME_M6_MAX && first < ME_M6_MAX;
        m6->first[j] = ok ? (sp_q16_t)first : 0;
        for (k = 0u; k < 3u; ++k) {
            ok = ok && body->inertia[j][k] > -ME_M6_MAX && body->inertia[j][k] < ME_M6_MAX;
        }
    }
    m6->frame = ok ? 1u : 0u;
    return SP_OK;
}

sp_status_t sp_motion_error_wrench_m6(const sp_me_m6_t *m6, const sp_rot_t *rot, const sp_q30_t sc[6],
                                      const sp_q24_t da[6], sp_q8_t dw[6])
{
    if (m6 == NULL || rot == NULL || sc == NULL || da == NULL || dw == NULL) {
        return me_bad_args(dw);
    }
    if (!m6->frame) {
        return me_wrench(m6->body.mass, (const sp_q16_t(*)[3])m6->body.inertia, m6->body.center_of_mass,
                         (const sp_q30_t(*)[3])rot->t, sc, da, dw);
    }
    return me_wrench_frame(m6, (const sp_q30_t(*)[3])rot->t, sc, da, dw);
}

/* round(x / 2^s) (ties up) of an int64 below 2^62 in magnitude */
#define ME_SHR(x, s) (((x) + (INT64_C(1) << ((s)-1u))) >> (s))

/* The envelope that bounds every product of the legs' sums: leg masses
 * below 512 kg, their moments of inertia across the leg below 512 kg m^2,
 * centres below 8 m, arms below 4 m per component, every leg longer than
 * its centres, and than 0.5 m when an inertia is not 0 (mu then below
 * m_c + m_r + 4 (I_c + I_r) < 5120 kg). Returns 1 within it, with the IK
 * at home in *ik. */
/* me_envelope's bounds of the legs' moments of inertia across the leg,
 * 512 kg m^2 in Q16, and of the legs' length when they have one, 0.5 m in
 * Q24 (written out: MISRA 10.1, no shift of a signed constant) */
#define ME_LEG_INERTIA_MAX INT32_C(33554432)
#define ME_LEG_SPIN_MIN INT32_C(8388608)

static int me_envelope(const sp_platform_t *platform, const sp_leg_mass_t *lm, sp_ik_t *ik)
{
    unsigned i, k;
    if (lm->cylinder_mass < 0 || lm->rod_mass < 0 || lm->cylinder_mass >= (512 << 16) || lm->rod_mass >= (512 << 16) ||
        lm->cylinder_com < 0 || lm->rod_com < 0 || lm->cylinder_com >= (8 << 24) || lm->rod_com >= (8 << 24) ||
        ((lm->cylinder_inertia < 0) || (lm->rod_inertia < 0)) ||
        ((lm->cylinder_inertia >= ME_LEG_INERTIA_MAX) || (lm->rod_inertia >= ME_LEG_INERTIA_MAX)) ||
        sp_inverse_kinematics(platform, &platform->home, ik) != SP_OK) {
        return 0;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        if (ik->length[i] <= lm->cylinder_com || ik->length[i] <= lm->rod_com || ik->length[i] >= (8 << 24) ||
            ((ik->length[i] <= ME_LEG_SPIN_MIN) && ((lm->cylinder_inertia | lm->rod_inertia) != 0))) {
            return 0;
        }
        for (k = 0u; k < 3u; ++k) {
            if (ik->arm[i][k] <= -(4 << 24) || ik->arm[i][k] >= (4 << 24)) {
                return 0;
            }
        }
    }
    return 1;
}

/* Leg i's terms added to the sums: K_i to kt, K_i [r_i]x to c and
 * [r_i]x K_i [r_i]x^T to b (Q16), within me_envelope's bounds. */
static void me_leg_sums(const sp_leg_mass_t *lm, const sp_ik_t *ik, unsigned i, int64_t kt[3][3], int64_t c[3][3],
                        int64_t b[3][3])
{
    const sp_q30_t *u = ik->unit[i];
    const sp_q24_t *r = ik->arm[i];
    int64_t len = ik->length[i];
    int64_t dr = len - lm->rod_com;
    unsigned j, k, l;
    /* mu = (m_c d_c^2 + m_r (L - d_r)^2 + I_c + I_r) / L^2, kg, Q16 (the
     * moments of inertia across the leg, docs/explanation/model.md "Leg
     * inertia"): the squares in Q24 (lengths below 8 m: < 2^30), times the
     * masses (Q16, < 2^31): Q40 below 2^61 each, the inertias (Q16, < 2^25)
     * in Q40 below 2^49; L^2 > 0 (the IK's lengths are positive) */
    int64_t num = (int64_t)lm->cylinder_mass * ME_SHR((int64_t)lm->cylinder_com * lm->cylinder_com, 24u) +
                  (int64_t)lm->rod_mass * ME_SHR(dr * dr, 24u) +
                  ((int64_t)lm->cylinder_inertia + lm->rod_inertia) * (INT64_C(1) << 24);
    int64_t mu = num / ME_SHR(len * len, 24u);
    int64_t axial = (int64_t)lm->rod_mass - mu; /* m_r - mu, kg, Q16 */
    int64_t kk[3][3];                           /* K = mu 1 + (m_r - mu) u u^T, kg, Q16 */
    int64_t kr[3][3];                           /* K [r]x, kg m, Q16 */
    int64_t rx[3][3];                           /* [r]x, m, Q24 */
    rx[0][0] = 0, rx[0][1] = -r[2], rx[0][2] = r[1];
    rx[1][0] = r[2], rx[1][1] = 0, rx[1][2] = -r[0];
    rx[2][0] = -r[1], rx[2][1] = r[0], rx[2][2] = 0;
    for (j = 0u; j < 3u; ++j) {
        for (k = 0u; k < 3u; ++k) {
            int64_t uu = ME_SHR((int64_t)u[j] * u[k], 30u); /* Q30 */
            kk[j][k] = ((j == k) ? mu : 0) + ME_SHR(axial * uu, 30u);
            kt[j][k] += kk[j][k];
        }
    }
    for (j = 0u; j < 3u; ++j) {
        for (k = 0u; k < 3u; ++k) {
            int64_t acc = 0;
            for (l = 0u; l < 3u; ++l) {
                acc += kk[j][l] * rx[l][k]; /* Q16 x Q24, below 2^57 each */
            }
            kr[j][k] = ME_SHR(acc, 24u);
            c[j][k] += kr[j][k];
        }
    }
    /* [r]x K [r]x^T = -[r]x (K [r]x) */
    for (j = 0u; j < 3u; ++j) {
        for (k = 0u; k < 3u; ++k) {
            int64_t acc = 0;
            for (l = 0u; l < 3u; ++l) {
                acc -= rx[j][l] * kr[l][k]; /* Q24 x Q16 (< 2^35): below 2^61 */
            }
            b[j][k] += ME_SHR(acc, 24u);
        }
    }
}

/* The body's centre of mass and inertia with the legs' first moment s
 * (base frame, kg m, Q16) and inertia b (kg m^2, Q16) moved to the motion
 * frame: s_b = T s, I_b = T B T^T (T the home's, Q30); m_eff > 0. */
static void me_to_motion_frame(const sp_platform_t *platform, const sp_q30_t t[3][3], const int64_t s[3],
                               const int64_t b[3][3], int64_t m_eff, sp_me_body_t *body, sp_flags_t *flags)
{
    unsigned j, k, l;
    for (j = 0u; j < 3u; ++j) {
        int64_t sb = 0;
        int64_t first;
        for (l = 0u; l < 3u; ++l) {
            sb += (int64_t)t[j][l] * s[l]; /* Q30 x Q16 (< 2^40) */
        }
        sb = ME_SHR(sb, 30u);
        /* c_eff = (m c + s_b) / m_eff, m, Q24 */
        first = (int64_t)platform->mass * platform->center_of_mass[j] + sb * (INT64_C(1) << 24); /* Q40 */
        body->center_of_mass[j] = sp_sat32(first / m_eff, flags);
        for (k = 0u; k < 3u; ++k) {
            int64_t acc = 0;
            for (l = 0u; l < 3u; ++l) {
                /* (T B)_jl, Q16: each Q30 x Q16 product (< 2^61) rounded */
                int64_t tb = ME_SHR((int64_t)t[j][0] * b[0][l], 30u) + ME_SHR((int64_t)t[j][1] * b[1][l], 30u) +
                             ME_SHR((int64_t)t[j][2] * b[2][l], 30u);
                acc += ME_SHR(tb * t[k][l], 30u);
            }
            body->inertia[j][k] = sp_sat32((int64_t)platform->inertia[j][k] + acc, flags);
        }
    }
}

sp_status_t sp_motion_error_body(const sp_platform_t *platform, sp_me_body_t *body)
{
    sp_flags_t flags = 0u;
    sp_ik_t ik;
    int64_t kt[3][3] = {{0}}; /* sum of K_i, kg, Q16 */
    int64_t c[3][3] = {{0}};  /* sum of K_i [r_i]x, kg m, Q16 */
    int64_t b[3][3] = {{0}};  /* sum of [r_i]x K_i [r_i]x^T, kg m^2, Q16 */
    int64_t s[3];             /* the legs' first moment, base frame, kg m, Q16 */
    const sp_leg_mass_t *lm;
    int64_t m_eff;
    unsigned i, j, k;
    if (platform == NULL || body == NULL) {
        return SP_E_ARG;
    }
    body->mass = platform->mass;
    for (j = 0u; j < 3u; ++j) {
        body->center_of_mass[j] = platform->center_of_mass[j];
        for (k = 0u; k < 3u; ++k) {
            body->inertia[j][k] = platform->inertia[j][k];
        }
    }
    lm = &platform->leg_mass;
    if (lm->cylinder_mass == 0 && lm->rod_mass == 0 && lm->cylinder_inertia == 0 && lm->rod_inertia == 0) {
        return SP_OK; /* massless legs: the rigid body as it is */
    }
    if (!me_envelope(platform, lm, &ik)) {
        return SP_E_RANGE;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        me_leg_sums(lm, &ik, i, kt, c, b);
    }
    for (j = 0u; j < 3u; ++j) {
        for (k = 0u; k < 3u; ++k) {
            if (b[j][k] <= -(INT64_C(1) << 31) || b[j][k] >= (INT64_C(1) << 31)) {
                return SP_E_RANGE; /* beyond 32768 kg m^2 */
            }
        }
    }
    /* the rigid body's coupling is [m r_c]x: the skew part of C */
    s[0] = ME_SHR(c[2][1] - c[1][2], 1u);
    s[1] = ME_SHR(c[0][2] - c[2][0], 1u);
    s[2] = ME_SHR(c[1][0] - c[0][1], 1u);
    /* mass: the mean of the translational block's diagonal */
    m_eff = (int64_t)platform->mass + (kt[0][0] + kt[1][1] + kt[2][2]) / 3;
    body->mass = sp_sat32(m_eff, &flags);
    if (m_eff <= 0) {
        return SP_E_RANGE;
    }
    me_to_motion_frame(platform, (const sp_q30_t(*)[3])ik.rot.t, s, (const int64_t(*)[3])b, m_eff, body, &flags);
    return (flags == 0u) ? SP_OK : SP_E_OVERFLOW;
}
