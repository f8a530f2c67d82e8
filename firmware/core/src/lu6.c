#include "sp/kinematics.h"

#include "core_internal.h"
#include "fixed_inline.h"

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
int spi_lu6_solve_t32(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
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
