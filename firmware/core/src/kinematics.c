#include "sp/kinematics.h"

#include "fixed_inline.h"

#define LEG_COMPONENT_MAX (INT32_C(1) << 30) /* 64 m in Q24 */
#define LEG_LENGTH_MIN INT32_C(16777)        /* 1 mm in Q24 */
#define COS_PITCH_MIN INT32_C(10737418)      /* 0.01 in Q30 */

/* T from the sines and cosines sc = {sin, cos} of roll, pitch, yaw. */
static void rot_from_sincos(const sp_q30_t sc[6], sp_rot_t *rot)
{
    sp_q30_t sr = sc[0];
    sp_q30_t cr = sc[1];
    sp_q30_t sp = sc[2];
    sp_q30_t cp = sc[3];
    sp_q30_t sy = sc[4];
    sp_q30_t cy = sc[5];
    sp_q30_t spsr = spi_mul30(sp, sr);
    sp_q30_t spcr = spi_mul30(sp, cr);

    /* T = (Rz(yaw) Ry(pitch) Rx(roll))^T: row r of T is column r of the
     * column-vector rotation. */
    rot->t[0][0] = spi_mul30(cy, cp);
    rot->t[0][1] = spi_mul30(sy, cp);
    rot->t[0][2] = -sp;
    rot->t[1][0] = spi_mul30(cy, spsr) - spi_mul30(sy, cr);
    rot->t[1][1] = spi_mul30(sy, spsr) + spi_mul30(cy, cr);
    rot->t[1][2] = spi_mul30(cp, sr);
    rot->t[2][0] = spi_mul30(cy, spcr) + spi_mul30(sy, sr);
    rot->t[2][1] = spi_mul30(sy, spcr) - spi_mul30(cy, sr);
    rot->t[2][2] = spi_mul30(cp, cr);
}

/* T of the angles, keeping their sines and cosines in sc. */
static void orientation_sc(const sp_q24_t rpy[3], sp_rot_t *rot, sp_q30_t sc[6])
{
    sp_sincos_q24(rpy[0], &sc[0], &sc[1]);
    sp_sincos_q24(rpy[1], &sc[2], &sc[3]);
    sp_sincos_q24(rpy[2], &sc[4], &sc[5]);
    rot_from_sincos(sc, rot);
}

sp_status_t sp_orientation(const sp_q24_t rpy[3], sp_rot_t *rot)
{
    sp_q30_t sc[6];

    if (rpy == NULL || rot == NULL) {
        return SP_E_ARG;
    }
    orientation_sc(rpy, rot, sc);
    return SP_OK;
}

/* Inverse kinematics of a pose whose orientation ik->rot is already set:
 * arms, legs and lengths. Every leg costs three 3-term dot products (exact
 * 64-bit sums) and one square root. */
static sp_status_t ik_lengths(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik)
{
    sp_flags_t flags = 0u;
    unsigned i;
    unsigned c;

    for (i = 0u; i < SP_LEGS; ++i) {
        const int32_t *a = platform->platform_joint[i];
        uint64_t len2 = 0u;
        for (c = 0u; c < 3u; ++c) {
            /* (A_im T)_c = sum_r a_r T[r][c]: Q24 x Q30, the exact sum of
             * three products below 3 (2^31 (2^30 + 3)) < 2^63, then >> 30.
             * T's columns are unit vectors: |arm| <= |a| (1 + 2^-28). */
            int64_t acc = (int64_t)a[0] * ik->rot.t[0][c] + (int64_t)a[1] * ik->rot.t[1][c] +
                          (int64_t)a[2] * ik->rot.t[2][c];
            int64_t leg;
            ik->arm[i][c] = spi_sat(spi_rsr(acc, 30u), &flags);
            leg = (int64_t)ik->arm[i][c] + pose->pos[c] - platform->base_joint[i][c];
            if (leg >= LEG_COMPONENT_MAX || leg <= -LEG_COMPONENT_MAX) {
                return SP_E_RANGE;
            }
            ik->leg[i][c] = (sp_q24_t)leg;
            len2 += (uint64_t)(leg * leg); /* < 3 * 2^60 */
        }
        ik->length[i] = (sp_q24_t)sp_isqrt64(len2); /* Q48 -> Q24, < 2^31 */
        if (ik->length[i] < LEG_LENGTH_MIN) {
            return SP_E_RANGE;
        }
    }
    return sp_flags_status(flags);
}

/* The unit vectors u = l / |l| (Q24 / Q24 -> Q30) of a successful
 * ik_lengths, with one reciprocal per leg: 1/|l| = inv / 2^sh, then
 * u_c = l_c inv / 2^(sh - 30). inv is never above the exact reciprocal and
 * has 31 significant bits (relative error below 2^-28): the error is at
 * most 3 LSB of Q30 and |u_c| <= 2^30. */
static void ik_units(sp_ik_t *ik)
{
    unsigned i;
    unsigned c;

    for (i = 0u; i < SP_LEGS; ++i) {
        unsigned sh;
        int32_t inv = spi_recip((uint32_t)ik->length[i], &sh); /* length in [2^14, 2^31) */
        for (c = 0u; c < 3u; ++c) {
            ik->unit[i][c] = (sp_q30_t)spi_rsr_up((int64_t)ik->leg[i][c] * inv, sh - 30u);
        }
    }
}

sp_status_t sp_inverse_kinematics(const sp_platform_t *platform, const sp_pose_t *pose, sp_ik_t *ik)
{
    sp_status_t st;

    if (platform == NULL || pose == NULL || ik == NULL) {
        return SP_E_ARG;
    }
    st = sp_orientation(pose->rpy, &ik->rot);
    if (st == SP_OK) {
        st = ik_lengths(platform, pose, ik);
    }
    if (st == SP_OK) {
        ik_units(ik);
    }
    return st;
}

sp_status_t sp_leg_stretch(const sp_ik_t *ik, const sp_ik_t *home_ik, sp_q24_t stretch[SP_LEGS])
{
    sp_flags_t flags = 0u;
    unsigned i;

    if (ik == NULL || home_ik == NULL || stretch == NULL) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        stretch[i] = sp_sub(ik->length[i], home_ik->length[i], &flags);
    }
    return sp_flags_status(flags);
}

/* Accumulates v (Q24) x c (Q30) into a Q54 int64 sum, saturating. */
SPI_INLINE void acc_term(int64_t *acc, int32_t v, int32_t c, sp_flags_t *flags)
{
    *acc = spi_add64(*acc, (int64_t)v * c, flags);
}

sp_status_t sp_body_rates(const sp_q24_t rpy[3], const sp_q24_t rpy_rate[3], const sp_q24_t rpy_acc[3],
                          sp_q24_t omega[3], sp_q24_t omega_dot[3])
{
    sp_flags_t flags = 0u;
    sp_q30_t sr;
    sp_q30_t cr;
    sp_q30_t sp;
    sp_q30_t cp;
    sp_q24_t dr;
    sp_q24_t dp;
    sp_q24_t dy;
    sp_q24_t dp_dr;
    sp_q24_t dy_dp;
    sp_q24_t dy_dr;
    int64_t a;

    if (rpy == NULL || rpy_rate == NULL || rpy_acc == NULL || omega == NULL || omega_dot == NULL) {
        return SP_E_ARG;
    }
    sp_sincos_q24(rpy[0], &sr, &cr);
    sp_sincos_q24(rpy[1], &sp, &cp);
    dr = rpy_rate[0];
    dp = rpy_rate[1];
    dy = rpy_rate[2];

    /* eq (10) */
    a = 0;
    acc_term(&a, dr, SP_Q30_ONE, &flags);
    acc_term(&a, dy, -sp, &flags);
    omega[0] = spi_narrow(a, 30u, &flags);
    a = 0;
    acc_term(&a, dp, cr, &flags);
    acc_term(&a, dy, spi_mul30(cp, sr), &flags);
    omega[1] = spi_narrow(a, 30u, &flags);
    a = 0;
    acc_term(&a, dp, -sr, &flags);
    acc_term(&a, dy, spi_mul30(cp, cr), &flags);
    omega[2] = spi_narrow(a, 30u, &flags);

    /* d/dt of eq (10): the angle accelerations plus the products of rates. */
    dp_dr = spi_mul(dp, dr, 24u, &flags);
    dy_dp = spi_mul(dy, dp, 24u, &flags);
    dy_dr = spi_mul(dy, dr, 24u, &flags);
    a = 0;
    acc_term(&a, rpy_acc[0], SP_Q30_ONE, &flags);
    acc_term(&a, rpy_acc[2], -sp, &flags);
    acc_term(&a, dy_dp, -cp, &flags);
    omega_dot[0] = spi_narrow(a, 30u, &flags);
    a = 0;
    acc_term(&a, rpy_acc[1], cr, &flags);
    acc_term(&a, dp_dr, -sr, &flags);
    acc_term(&a, rpy_acc[2], spi_mul30(cp, sr), &flags);
    acc_term(&a, dy_dp, -spi_mul30(sp, sr), &flags);
    acc_term(&a, dy_dr, spi_mul30(cp, cr), &flags);
    omega_dot[1] = spi_narrow(a, 30u, &flags);
    a = 0;
    acc_term(&a, rpy_acc[1], -sr, &flags);
    acc_term(&a, dp_dr, -cr, &flags);
    acc_term(&a, rpy_acc[2], spi_mul30(cp, cr), &flags);
    acc_term(&a, dy_dp, -spi_mul30(sp, cr), &flags);
    acc_term(&a, dy_dr, -spi_mul30(cp, sr), &flags);
    omega_dot[2] = spi_narrow(a, 30u, &flags);
    return sp_flags_status(flags);
}

sp_status_t sp_leg_rates(const sp_ik_t *ik, const sp_q24_t rpy[3], const sp_q24_t vel[3],
                         const sp_q24_t rpy_rate[3], sp_q24_t rate[SP_LEGS])
{
    sp_flags_t flags = 0u;
    sp_q30_t sy;
    sp_q30_t cy;
    sp_q24_t w[3];
    unsigned i;
    unsigned c;

    if (ik == NULL || rpy == NULL || vel == NULL || rpy_rate == NULL || rate == NULL) {
        return SP_E_ARG;
    }
    sp_sincos_q24(rpy[2], &sy, &cy);
    /* Angular velocity in the base frame for Z-Y-X angles:
     * w = roll_rate * (R e_x) + pitch_rate * (Rz e_y) + yaw_rate * e_z,
     * and R e_x is row 0 of T. */
    for (c = 0u; c < 3u; ++c) {
        int64_t a = (int64_t)rpy_rate[0] * ik->rot.t[0][c];
        if (c == 0u) {
            a += (int64_t)rpy_rate[1] * -sy;
        } else if (c == 1u) {
            a += (int64_t)rpy_rate[1] * cy;
        } else {
            a += (int64_t)rpy_rate[2] * SP_Q30_ONE;
        }
        w[c] = spi_sat(spi_rsr(a, 30u), &flags); /* two products: below 2^63 */
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        sp_q24_t v[3];
        /* joint velocity v + w x r, Q24 x Q24 -> Q24 */
        v[0] = spi_add(vel[0], spi_sat(spi_rsr((int64_t)w[1] * r[2] - (int64_t)w[2] * r[1], 24u), &flags), &flags);
        v[1] = spi_add(vel[1], spi_sat(spi_rsr((int64_t)w[2] * r[0] - (int64_t)w[0] * r[2], 24u), &flags), &flags);
        v[2] = spi_add(vel[2], spi_sat(spi_rsr((int64_t)w[0] * r[1] - (int64_t)w[1] * r[0], 24u), &flags), &flags);
        /* u . v with |u_c| <= 2^30: the exact sum is below 3 * 2^61 */
        rate[i] = spi_sat(spi_rsr((int64_t)ik->unit[i][0] * v[0] + (int64_t)ik->unit[i][1] * v[1] +
                                      (int64_t)ik->unit[i][2] * v[2],
                                  30u),
                          &flags);
    }
    return sp_flags_status(flags);
}

sp_status_t sp_jacobian(const sp_ik_t *ik, sp_jacobian_t *jac)
{
    sp_flags_t flags = 0u;
    unsigned i;

    if (ik == NULL || jac == NULL) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        const sp_q24_t *r = ik->arm[i];
        const sp_q30_t *u = ik->unit[i];
        jac->j[i][0] = (int32_t)spi_rsr(u[0], 2u); /* Q30 -> Q28 */
        jac->j[i][1] = (int32_t)spi_rsr(u[1], 2u);
        jac->j[i][2] = (int32_t)spi_rsr(u[2], 2u);
        /* r x u: Q24 x Q30 = Q54 -> Q28; each difference of two products
         * is below 2^63 */
        jac->j[i][3] = spi_sat(spi_rsr((int64_t)r[1] * u[2] - (int64_t)r[2] * u[1], 26u), &flags);
        jac->j[i][4] = spi_sat(spi_rsr((int64_t)r[2] * u[0] - (int64_t)r[0] * u[2], 26u), &flags);
        jac->j[i][5] = spi_sat(spi_rsr((int64_t)r[0] * u[1] - (int64_t)r[1] * u[0], 26u), &flags);
    }
    return sp_flags_status(flags);
}

/* |v| as an unsigned magnitude (|INT32_MIN| = 2^31 fits). */
SPI_INLINE uint32_t mag32(int32_t v)
{
    return (v < 0) ? (uint32_t)0 - (uint32_t)v : (uint32_t)v;
}

#define RHS_MAX (INT64_C(1) << 56) /* |b| below this: no overflow in the elimination */

sp_status_t sp_lu6_factor(const sp_jacobian_t *m, int transpose, sp_lu6_t *lu)
{
    sp_flags_t flags = 0u;
    unsigned i;
    unsigned j;
    unsigned k;

    if (m == NULL || lu == NULL) {
        return SP_E_ARG;
    }
    lu->valid = 0u;
    for (i = 0u; i < SP_LEGS; ++i) {
        for (j = 0u; j < SP_LEGS; ++j) {
            lu->a[i][j] = transpose ? m->j[j][i] : m->j[i][j];
        }
    }
    for (k = 0u; k < SP_LEGS; ++k) {
        int32_t *rowk = lu->a[k];
        unsigned p = k;
        uint32_t best = mag32(rowk[k]);
        for (i = k + 1u; i < SP_LEGS; ++i) {
            uint32_t v = mag32(lu->a[i][k]);
            if (v > best) {
                best = v;
                p = i;
            }
        }
        if (best < (uint32_t)SP_PIVOT_MIN) {
            return SP_E_SINGULAR;
        }
        lu->perm[k] = (uint8_t)p;
        if (p != k) {
            /* whole rows, the stored multipliers included: P A = L U */
            for (j = 0u; j < SP_LEGS; ++j) {
                int32_t t = rowk[j];
                rowk[j] = lu->a[p][j];
                lu->a[p][j] = t;
            }
        }
        /* One reciprocal per pivot. With z = clz(|a_kk|) - 1, the pivot
         * normalised to [2^30, 2^31) is |a_kk| 2^z and inv ~= 2^61 /
         * (|a_kk| 2^z) in (2^30, 2^31) (never above; 2^-28), the sign
         * folded in. best < 2^31 unless a saturated entry is the pivot;
         * that case is flagged. */
        if (best > 0x7FFFFFFFu) {
            flags |= SP_FLAG_OVERFLOW;
            best = 0x7FFFFFFFu;
        }
        {
            unsigned z = spi_clz32(best) - 1u; /* in [0, 12] for best >= 2^18 */
            uint32_t q = spi_recip_norm(best << (z + 1u)); /* 2^62 / (best 2^(z+1)) */
            if (q > 0x7FFFFFFFu) {
                q = 0x7FFFFFFFu; /* a power of two: error 2^-31 */
            }
            lu->zk[k] = (uint8_t)z;
            lu->inv[k] = (rowk[k] < 0) ? -(int32_t)q : (int32_t)q;
        }
        for (i = k + 1u; i < SP_LEGS; ++i) {
            int32_t *rowi = lu->a[i];
            /* multiplier l = a_ik / a_kk in Q30 = (a_ik 2^z) inv / 2^31:
             * |a_ik| <= |a_kk| keeps a_ik 2^z in int32, and inv rounds
             * toward zero, so |l| <= 2^30. Stored in place of a_ik. */
            int32_t l = (int32_t)spi_rsr_up((int64_t)(rowi[k] * (INT32_C(1) << lu->zk[k])) * lu->inv[k], 31u);
            rowi[k] = l;
            if (l == 0) {
                continue;
            }
            for (j = k + 1u; j < SP_LEGS; ++j) {
                /* |l a_kj| / 2^30 <= |a_kj|: the product fits int32 */
                rowi[j] = spi_sub_sat(rowi[j], (int32_t)spi_rsr_up((int64_t)l * rowk[j], 30u), &flags);
            }
        }
    }
    if (flags != 0u) {
        return sp_flags_status(flags);
    }
    lu->valid = 1u;
    return SP_OK;
}

/* x_k = s 2^28 / a_kk = s 2^28 2^z inv / 2^61 = s inv / 2^(33 - z),
 * 33 - z in [21, 33] */
SPI_INLINE int64_t lu_div_pivot(const sp_lu6_t *lu, unsigned k, int64_t s, sp_flags_t *flags)
{
    return (lu->zk[k] == 0u) ? sp_mul64(s, lu->inv[k], 33u, flags)
                             : spi_mul64_rs(s, lu->inv[k], 33u - lu->zk[k], flags);
}

static sp_status_t lu_check_rhs(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    sp_status_t st = SP_OK;
    unsigned i;

    if (lu == NULL || b == NULL || x == NULL) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        if (b[i] >= RHS_MAX || b[i] <= -RHS_MAX) {
            st = SP_E_OVERFLOW;
        }
    }
    if (!lu->valid) {
        st = SP_E_ARG;
    }
    if (st != SP_OK) {
        for (i = 0u; i < SP_LEGS; ++i) {
            x[i] = 0;
        }
    }
    return st;
}

sp_status_t sp_lu6_solve(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    int64_t r[SP_LEGS];
    sp_flags_t flags = 0u;
    unsigned i;
    unsigned j;
    unsigned k;
    sp_status_t st = lu_check_rhs(lu, b, x);

    if (st != SP_OK) {
        return st;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        r[i] = b[i];
        x[i] = 0;
    }
    for (k = 0u; k < SP_LEGS; ++k) { /* r = P b */
        unsigned p = lu->perm[k];
        int64_t tr = r[k];
        r[k] = r[p];
        r[p] = tr;
    }
    for (k = 0u; k < SP_LEGS; ++k) { /* L y = P b, y in r */
        for (i = k + 1u; i < SP_LEGS; ++i) {
            /* |r| < 2^56 at the start and at most doubles per column:
             * below 2^62 at the end, no overflow */
            if (lu->a[i][k] != 0) {
                r[i] -= spi_mul64_q30(r[k], lu->a[i][k]);
            }
        }
    }
    for (k = SP_LEGS; k-- > 0u;) {
        int64_t s = r[k];
        for (j = k + 1u; j < SP_LEGS; ++j) {
            s = spi_add64(s, -spi_mul64_rs(x[j], lu->a[k][j], 28u, &flags), &flags);
        }
        x[k] = lu_div_pivot(lu, k, s, &flags);
    }
    if (flags != 0u) {
        for (i = 0u; i < SP_LEGS; ++i) {
            x[i] = 0;
        }
        return sp_flags_status(flags);
    }
    return SP_OK;
}

#define LT_MAX (INT64_C(1) << 61) /* spi_mul64_q30's range */

sp_status_t sp_lu6_solve_transposed(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    int64_t y[SP_LEGS];
    sp_flags_t flags = 0u;
    unsigned i;
    unsigned j;
    unsigned k;
    sp_status_t st = lu_check_rhs(lu, b, x);

    if (st != SP_OK) {
        return st;
    }
    /* A = P^T L U, so A^T x = b is U^T (L^T P x) = b. U^T y = b, forward: */
    for (k = 0u; k < SP_LEGS; ++k) {
        int64_t s = b[k];
        for (j = 0u; j < k; ++j) {
            s = spi_add64(s, -spi_mul64_rs(y[j], lu->a[j][k], 28u, &flags), &flags);
        }
        y[k] = lu_div_pivot(lu, k, s, &flags);
    }
    /* L^T z = y, backward (unit diagonal, multipliers Q30, |l| <= 1): */
    for (k = SP_LEGS; k-- > 0u;) {
        int64_t s = y[k];
        for (i = k + 1u; i < SP_LEGS; ++i) {
            if (lu->a[i][k] != 0) {
                if (y[i] >= LT_MAX || y[i] <= -LT_MAX) {
                    flags |= SP_FLAG_OVERFLOW;
                } else {
                    s = spi_add64(s, -spi_mul64_q30(y[i], lu->a[i][k]), &flags);
                }
            }
        }
        y[k] = s;
    }
    /* x = P^T z: the row swaps undone in reverse order */
    for (k = SP_LEGS; k-- > 0u;) {
        unsigned p = lu->perm[k];
        if (p != k) {
            int64_t t = y[k];
            y[k] = y[p];
            y[p] = t;
        }
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        x[i] = (flags != 0u) ? 0 : y[i];
    }
    return sp_flags_status(flags);
}

#define S32_TOP 26u                 /* the scaled right-hand side: max |b| in [2^26, 2^27) */
#define S32_MAX (INT64_C(1) << 29)  /* every intermediate below this, else the int64 solve */

/* round(v / 2^s) narrowed to an intermediate of the 32-bit solve: 0 when it
 * is not below S32_MAX (the caller then falls back). */
SPI_INLINE int32_t s32_take(int64_t v, unsigned s, int *ok)
{
    int64_t r = spi_rsr(v, s);
    if (r >= S32_MAX || r <= -S32_MAX) {
        *ok = 0;
        return 0;
    }
    return (int32_t)r;
}

/* The block exponent e of the 32-bit solves: max |b| 2^e in [2^26, 2^27).
 * Returns 0 when b is 0 or out of sp_lu6_solve's range. */
static int s32_exponent(const int64_t b[SP_LEGS], int *e)
{
    uint64_t m = 0u;
    unsigned i;
    for (i = 0u; i < SP_LEGS; ++i) {
        uint64_t a = (b[i] < 0) ? (uint64_t)0 - (uint64_t)b[i] : (uint64_t)b[i];
        m = a > m ? a : m;
    }
    if (m == 0u || m >= (UINT64_C(1) << 56)) {
        return 0;
    }
    *e = (int)spi_clz64(m) - (int)(63u - S32_TOP);
    return 1;
}

/* b 2^e 2^f, rounded, as int64 (|.| < 2^(27 + f)). */
SPI_INLINE int64_t s32_scale_in(int64_t b, int e, unsigned f)
{
    return ((e >= 0) ? b * (INT64_C(1) << e) : spi_rsr(b, (unsigned)-e)) * (INT64_C(1) << f);
}

/* y 2^-e, rounded. */
SPI_INLINE int64_t s32_scale_out(int32_t y, int e)
{
    return (e > 0) ? spi_rsr(y, (unsigned)e) : (int64_t)y * (INT64_C(1) << -e);
}

/*
 * sp_lu6_solve_transposed in 32-bit intermediates, block-scaled: b is
 * scaled by 2^e so that max |b| is in [2^26, 2^27) (a few LSB of b lost
 * only when max |b| >= 2^27), every product is one 32x32->64 multiply
 * accumulated exactly in int64, and every intermediate must stay below
 * 2^29 (a growth of at least 4; sums of six products of int32 and 2^29 fit
 * int64). Returns 0, x untouched, when one does not (or b is 0): the caller
 * then uses the int64 solve. For the chord FK, whose right-hand side (a
 * length residual) is small: the steps keep 26 significant bits.
 */
static int lu_solve_t32(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    int32_t y[SP_LEGS];
    int ok = 1;
    int e;
    unsigned i;
    unsigned j;
    unsigned k;

    if (!s32_exponent(b, &e)) {
        return 0;
    }
    /* U^T y = b 2^e, forward: y_k = (b_k - sum_j U_jk y_j / 2^28) / U_kk */
    for (k = 0u; k < SP_LEGS; ++k) {
        int64_t acc = s32_scale_in(b[k], e, 28u);
        int32_t sk;
        for (j = 0u; j < k; ++j) {
            acc -= (int64_t)lu->a[j][k] * y[j]; /* |.| < 2^60 each, 6 of them fit */
        }
        sk = s32_take(acc, 28u, &ok);
        /* y_k = sk 2^28 / a_kk = sk inv / 2^(33 - z) */
        y[k] = s32_take((int64_t)sk * lu->inv[k], 33u - lu->zk[k], &ok);
    }
    /* L^T z = y, backward, multipliers Q30 */
    for (k = SP_LEGS; k-- > 0u;) {
        int64_t acc = (int64_t)y[k] * (INT64_C(1) << 30);
        for (i = k + 1u; i < SP_LEGS; ++i) {
            acc -= (int64_t)lu->a[i][k] * y[i];
        }
        y[k] = s32_take(acc, 30u, &ok);
    }
    if (!ok) {
        return 0;
    }
    for (k = SP_LEGS; k-- > 0u;) {
        unsigned p = lu->perm[k];
        int32_t t = y[k];
        y[k] = y[p];
        y[p] = t;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        x[i] = s32_scale_out(y[i], e);
    }
    return 1;
}

sp_status_t sp_solve6(const sp_jacobian_t *m, int transpose, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    sp_lu6_t lu;
    sp_status_t st;
    unsigned i;

    if (m == NULL || b == NULL || x == NULL) {
        return SP_E_ARG;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        x[i] = 0;
    }
    for (i = 0u; i < SP_LEGS; ++i) {
        if (b[i] >= RHS_MAX || b[i] <= -RHS_MAX) {
            return SP_E_OVERFLOW; /* x is zeroed */
        }
    }
    st = sp_lu6_factor(m, transpose, &lu);
    if (st != SP_OK) {
        return st;
    }
    return sp_lu6_solve(&lu, b, x);
}

void sp_fk_default_options(sp_fk_options_t *opt)
{
    if (opt == NULL) {
        return;
    }
    opt->max_iterations = 8u;
    opt->tolerance = 4;              /* 0.24 um */
    opt->max_jump_pos = 838861;      /* 50 mm */
    opt->max_jump_rot = 838861;      /* 50 mrad */
}

static int32_t max_abs_diff(int32_t a, int32_t b)
{
    int64_t d = (int64_t)a - b;
    d = d < 0 ? -d : d;
    return d > INT32_MAX ? INT32_MAX : (int32_t)d;
}

/* One Newton (or chord) update of q by delta = [dR (m); dw (rad, base
 * frame)], Q24, with sc the sines and cosines of q's own orientation.
 * SP_E_SINGULAR near pitch = +-90 degrees, SP_E_NO_CONVERGENCE when a value
 * saturated (the iteration diverged). */
static sp_status_t fk_update(sp_pose_t *q, const int64_t delta[SP_LEGS], const sp_q30_t sc[6])
{
    sp_flags_t flags = 0u;
    int32_t d[SP_LEGS];
    int32_t d_roll;
    unsigned sh;
    int32_t inv;
    unsigned i;

    /* a step of 128 m or 128 rad means the iteration diverged */
    for (i = 0u; i < SP_LEGS; ++i) {
        d[i] = spi_sat(delta[i], &flags);
    }
    for (i = 0u; i < 3u; ++i) {
        q->pos[i] = spi_add(q->pos[i], d[i], &flags);
    }
    /* Small rotation dw to Euler increments (inverse of the map used in
     * sp_leg_rates), with the sines of q's own orientation:
     * d_roll = (cy wx + sy wy) / cp, d_pitch = -sy wx + cy wy,
     * d_yaw = wz + sp d_roll. */
    if (sc[3] < COS_PITCH_MIN) {
        return SP_E_SINGULAR;
    }
    inv = spi_recip((uint32_t)sc[3], &sh); /* 1/cp = inv / 2^sh, sh in [54, 61] */
    d_roll = spi_sat(spi_mul64_rs(spi_rsr((int64_t)d[3] * sc[5] + (int64_t)d[4] * sc[4], 30u), inv, sh - 30u,
                                  &flags),
                     &flags);
    q->rpy[0] = spi_add(q->rpy[0], d_roll, &flags);
    q->rpy[1] = spi_add(q->rpy[1], spi_sat(spi_rsr((int64_t)d[4] * sc[5] - (int64_t)d[3] * sc[4], 30u), &flags),
                        &flags);
    q->rpy[2] = spi_add(q->rpy[2], spi_add(d[5], spi_mul(d_roll, sc[2], 30u, &flags), &flags), &flags);
    return (flags != 0u) ? SP_E_NO_CONVERGENCE : SP_OK;
}

/* Is every axis of q within the allowed jump of the guess? */
static sp_status_t fk_jump_check(const sp_pose_t *q, const sp_pose_t *guess, const sp_fk_options_t *opt)
{
    unsigned i;
    for (i = 0u; i < 3u; ++i) {
        if (max_abs_diff(q->pos[i], guess->pos[i]) > opt->max_jump_pos ||
            max_abs_diff(q->rpy[i], guess->rpy[i]) > opt->max_jump_rot) {
            return SP_E_DISCONTINUITY;
        }
    }
    return SP_OK;
}

sp_status_t sp_forward_kinematics(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS],
                                  const sp_pose_t *guess, const sp_fk_options_t *opt, sp_pose_t *pose,
                                  sp_ik_t *ik, sp_fk_info_t *info)
{
    sp_pose_t q;
    sp_jacobian_t jac;
    sp_fk_info_t local_info;
    sp_ik_t work;
    sp_ik_t *w = (ik != NULL) ? ik : &work;
    sp_status_t st = SP_OK;
    uint32_t it = 0u;
    unsigned i;

    if (info == NULL) {
        info = &local_info;
    }
    info->iterations = 0u;
    info->residual = INT32_MAX;
    if (platform == NULL || length == NULL || guess == NULL || opt == NULL || pose == NULL ||
        opt->max_iterations < 1u || opt->max_iterations > 20u || opt->tolerance < 0) {
        return SP_E_ARG;
    }
    q = *guess;
    for (;;) { /* bounded: at most max_iterations + 1 passes */
        int64_t neg_res[SP_LEGS];
        int64_t delta[SP_LEGS];
        sp_q30_t sc[6]; /* sin, cos of roll, pitch, yaw of q */
        sp_q24_t worst = 0;
        sp_flags_t flags = 0u;

        /* lengths only: the unit vectors are needed for a Jacobian or for
         * the caller's ik, not for the convergence test */
        orientation_sc(q.rpy, &w->rot, sc);
        st = ik_lengths(platform, &q, w);
        if (st != SP_OK) {
            break;
        }
        for (i = 0u; i < SP_LEGS; ++i) {
            sp_q24_t e = spi_sub(w->length[i], length[i], &flags);
            int32_t ae = max_abs_diff(e, 0);
            worst = ae > worst ? ae : worst;
            neg_res[i] = -(int64_t)e;
        }
        info->residual = worst;
        if (worst <= opt->tolerance) {
            if (ik != NULL) {
                ik_units(ik);
            }
            st = SP_OK;
            break;
        }
        if (it >= opt->max_iterations) {
            st = SP_E_NO_CONVERGENCE;
            break;
        }
        ik_units(w);
        st = sp_jacobian(w, &jac);
        if (st == SP_OK) {
            st = sp_solve6(&jac, 0, neg_res, delta);
        }
        if (st != SP_OK) {
            break;
        }
        ++it;
        st = fk_update(&q, delta, sc);
        if (st != SP_OK) {
            break;
        }
    }
    info->iterations = it;
    if (st == SP_OK) {
        st = fk_jump_check(&q, guess, opt);
    }
    *pose = (st == SP_OK) ? q : *guess;
    return st;
}

sp_status_t sp_fk_cache_of(const sp_platform_t *platform, const sp_pose_t *pose, sp_fk_cache_t *cache)
{
    sp_ik_t w;
    sp_status_t st;
    unsigned i;

    if (platform == NULL || pose == NULL || cache == NULL) {
        return SP_E_ARG;
    }
    orientation_sc(pose->rpy, &w.rot, cache->sc);
    st = ik_lengths(platform, pose, &w);
    for (i = 0u; i < SP_LEGS; ++i) {
        cache->length[i] = (st == SP_OK) ? w.length[i] : 0;
    }
    return st;
}

sp_status_t sp_fk_chord(const sp_platform_t *platform, const sp_q24_t length[SP_LEGS], const sp_pose_t *guess,
                        const sp_lu6_t *lu_t, const sp_fk_options_t *opt, sp_fk_cache_t *cache, sp_pose_t *pose,
                        sp_fk_info_t *info)
{
    sp_pose_t q;
    sp_fk_cache_t c;
    sp_fk_info_t local_info;
    sp_ik_t w;
    sp_status_t st = SP_OK;
    uint32_t it = 0u;
    unsigned i;

    if (info == NULL) {
        info = &local_info;
    }
    info->iterations = 0u;
    info->residual = INT32_MAX;
    if (platform == NULL || length == NULL || guess == NULL || lu_t == NULL || opt == NULL || cache == NULL ||
        pose == NULL || opt->max_iterations < 1u || opt->max_iterations > 20u || opt->tolerance < 0) {
        return SP_E_ARG;
    }
    q = *guess;
    c = *cache;
    for (;;) { /* bounded: at most max_iterations + 1 passes */
        int64_t neg_res[SP_LEGS];
        int64_t delta[SP_LEGS];
        sp_q24_t worst = 0;
        sp_flags_t flags = 0u;

        for (i = 0u; i < SP_LEGS; ++i) {
            sp_q24_t e = spi_sub(c.length[i], length[i], &flags);
            int32_t ae = max_abs_diff(e, 0);
            worst = ae > worst ? ae : worst;
            neg_res[i] = -(int64_t)e;
        }
        info->residual = worst;
        if (worst <= opt->tolerance) {
            st = SP_OK;
            break;
        }
        if (it >= opt->max_iterations) {
            st = SP_E_NO_CONVERGENCE;
            break;
        }
        /* J delta = -residual with J = (J^T)^T: the transposed solve of
         * the caller's factorisation of J^T */
        st = (lu_t->valid && lu_solve_t32(lu_t, neg_res, delta)) ? SP_OK
                                                                : sp_lu6_solve_transposed(lu_t, neg_res, delta);
        if (st != SP_OK) {
            break;
        }
        ++it;
        st = fk_update(&q, delta, c.sc);
        if (st != SP_OK) {
            break;
        }
        orientation_sc(q.rpy, &w.rot, c.sc);
        st = ik_lengths(platform, &q, &w);
        if (st != SP_OK) {
            break;
        }
        for (i = 0u; i < SP_LEGS; ++i) {
            c.length[i] = w.length[i];
        }
    }
    info->iterations = it;
    if (st == SP_OK) {
        st = fk_jump_check(&q, guess, opt);
    }
    if (st == SP_OK) {
        *pose = q;
        *cache = c;
    } else {
        *pose = *guess;
    }
    return st;
}
