/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/model/lu6.h"

#include "model/model_internal.h"
#include "math/fixed_inline.h"

/* The loops below have constant bounds once lu_step is inlined for a
 * constant k: unrolled by hand through the pragma (GCC; -Os would keep the
 * loops). */
#if defined(__GNUC__) && !defined(__clang__)
#define LU_UNROLL _Pragma("GCC unroll 6")
#else
#define LU_UNROLL
#endif

/* The multiplier l = round(a_ik 2^z inv / 2^31) (ties up) in Q30, from
 * the product's two words: a 32-bit value the compiler multiplies with
 * one SMULL/SMLAL (computed as an int64 shift, it may keep the 64-bit
 * value and multiply 64x32). */
SPI_INLINE int32_t lu_multiplier(int32_t a, unsigned z, int32_t inv)
{
    int64_t p = (int64_t)(a * (INT32_C(1) << z)) * inv + (INT64_C(1) << 30);
    return (int32_t)(((uint32_t)p >> 31) | ((uint32_t)(p >> 32) << 1));
}

/* |v| as an unsigned magnitude (|INT32_MIN| = 2^31 fits). */
SPI_INLINE uint32_t mag32(int32_t v)
{
    return (v < 0) ? (uint32_t)0 - (uint32_t)v : (uint32_t)v;
}

/* max |b_i| as an unsigned magnitude. */
SPI_INLINE uint64_t max_abs64(const int64_t b[SP_LEGS])
{
    uint64_t m = 0u;
    unsigned i;
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        uint64_t a = (b[i] < 0) ? (uint64_t)0 - (uint64_t)b[i] : (uint64_t)b[i];
        m = (a > m) ? a : m;
    }
    return m;
}

#define RHS_MAX (INT64_C(1) << 56) /* |b| below this: no overflow in the elimination */

/* The pivot row of column k among the rows r[k..5]: the first largest of
 * v ^ (v >> 31) (|v|, less 1 when v is negative: one instruction), within
 * 1 of the largest |a_ik|. */
SPI_INLINE unsigned lu_pivot(int32_t *const r[SP_LEGS], unsigned k)
{
    unsigned p = k;
    unsigned i;
    uint32_t best = (uint32_t)(r[k][k] ^ (r[k][k] >> 31));
    LU_UNROLL
    for (i = k + 1u; i < SP_LEGS; ++i) {
        uint32_t v = (uint32_t)(r[i][k] ^ (r[i][k] >> 31));
        if (v > best) {
            best = v;
            p = i;
        }
    }
    return p;
}

/* One reciprocal per pivot a (|a| = best). With z = clz(|a|) - 1, the
 * pivot normalised to [2^30, 2^31) is |a| 2^z and inv ~= 2^61 / (|a|
 * 2^z) in (2^30, 2^31) (never above; 2^-28), the sign folded in. best <
 * 2^31 unless a saturated entry is the pivot; that case is flagged.
 * Returns inv, z into *z_out. */
SPI_INLINE int32_t lu_reciprocal(int32_t a, uint32_t best, unsigned *z_out, sp_flags_t *flags)
{
    unsigned z;
    uint32_t q;
    if (best > 0x7FFFFFFFu) {
        *flags |= SP_FLAG_OVERFLOW;
        best = 0x7FFFFFFFu;
    }
    z = spi_clz32(best) - 1u;             /* in [0, 12] for best >= 2^18 */
    q = spi_recip_norm(best << (z + 1u)); /* 2^62 / (best 2^(z+1)) */
    if (q > 0x7FFFFFFFu) {
        q = 0x7FFFFFFFu; /* a power of two: error 2^-31 */
    }
    *z_out = z;
    return (a < 0) ? -(int32_t)q : (int32_t)q;
}

/* The elimination below the pivot row rk when its entries right of the
 * pivot are in [-2^29, 2^29): the pivot row times 4 fits int32, and
 * round(l a_kj / 2^30) = round(l (4 a_kj) / 2^32) = hi + (bit 31 of lo),
 * the words of one 32x32->64 product (the same bits as lu_eliminate). */
SPI_INLINE void lu_eliminate_x4(int32_t *const r[SP_LEGS], const int32_t *rk, unsigned k, unsigned z, int32_t inv)
{
    int32_t a4[SP_LEGS];
    unsigned i;
    unsigned j;
    LU_UNROLL
    for (j = k + 1u; j < SP_LEGS; ++j) {
        a4[j] = (int32_t)((uint32_t)rk[j] << 2);
    }
    LU_UNROLL
    for (i = k + 1u; i < SP_LEGS; ++i) {
        int32_t *ri = r[i];
        int32_t l = lu_multiplier(ri[k], z, inv);
        ri[k] = l;
        LU_UNROLL
        for (j = k + 1u; j < SP_LEGS; ++j) {
            int64_t pr = (int64_t)l * a4[j];
            /* |hi| < inc - 1: no overflow, as below (lu_step) */
            ri[j] = ri[j] - (int32_t)(pr >> 32) - (int32_t)((uint32_t)pr >> 31);
        }
    }
}

/* The elimination below the pivot row rk when no subtraction can overflow
 * (the rows' bound plus the pivot row's below 2^31). */
SPI_INLINE void lu_eliminate(int32_t *const r[SP_LEGS], const int32_t *rk, unsigned k, unsigned z, int32_t inv)
{
    unsigned i;
    unsigned j;
    LU_UNROLL
    for (i = k + 1u; i < SP_LEGS; ++i) {
        int32_t *ri = r[i];
        /* multiplier l = a_ik / a_kk in Q30 = (a_ik 2^z) inv / 2^31:
         * |a_ik| <= |a_kk| keeps a_ik 2^z in int32, and inv rounds
         * toward zero, so |l| <= 2^30. Stored in place of a_ik. */
        int32_t l = lu_multiplier(ri[k], z, inv);
        ri[k] = l;
        LU_UNROLL
        for (j = k + 1u; j < SP_LEGS; ++j) {
            /* |round(l a_kj / 2^30)| < inc, |r_ij| <= the old bound:
             * the difference stays below 2^31 (lu_step) */
            ri[j] -= (int32_t)(((int64_t)l * rk[j] + (INT64_C(1) << 29)) >> 30);
        }
    }
}

/* The elimination below the pivot row rk when the rows' bound is not
 * known: each subtraction saturates and flags, with the same rounding. */
SPI_INLINE void lu_eliminate_sat(int32_t *const r[SP_LEGS], const int32_t *rk, unsigned k, unsigned z, int32_t inv,
                                 sp_flags_t *flags)
{
    unsigned i;
    unsigned j;
    for (i = k + 1u; i < SP_LEGS; ++i) {
        int32_t *ri = r[i];
        int32_t l = lu_multiplier(ri[k], z, inv);
        ri[k] = l;
        for (j = k + 1u; j < SP_LEGS; ++j) {
            /* |l a_kj| / 2^30 <= |a_kj|: the product fits int32 */
            ri[j] = spi_sub_sat(ri[j], (int32_t)spi_round_up((int64_t)l * rk[j], 30u), flags);
        }
    }
}

/*
 * Step k of the elimination on the rows r[k..5] (pointers to the rows, in
 * pivot order so far); the pivot's reciprocal and exponent into
 * inv_out[k] and zk_out[k]. Returns 0 for a pivot below SP_PIVOT_MIN.
 *
 * *bound is at least every |entry| of the rows r[k..5] in the columns
 * k..5 (0x80000000 once it is not known to be below 2^31). The pivot is
 * within 1 of the column's largest |a_ik| (lu_pivot), so |l| <= 2^30 (1 +
 * 1/|a_kk|) + 1/2 < 2^30 + 2^12 + 1 (Q30, |a_kk| >= SP_PIVOT_MIN > 2^18)
 * and the rounded product round(l a_kj / 2^30) is below |a_kj| (1 +
 * 2^-17) + 2 <= umax + 8 + umax / 2^16 - 1 = inc - 1, umax + 1 bounding
 * the pivot row right of the pivot, so every new entry (and the x4 path's
 * partial difference) is below *bound + inc: when that is at most 2^31 - 1
 * (Frama-C EVA found the overflow that umax + 1 in place of inc let
 * through, tests/unit/test_lu6.c test_factor_near_tie), no subtraction of this
 * step can overflow and the inner loop runs unchecked (32x32->64 product,
 * rounded shift, subtraction); else each subtraction saturates and flags,
 * with the same rounding (the same bits whenever nothing saturates).
 */
SPI_INLINE int lu_step(int32_t *inv_out, uint8_t *zk_out, int32_t *r[SP_LEGS], unsigned k, uint32_t *bound,
                       sp_flags_t *flags)
{
    unsigned p = lu_pivot(r, k);
    int32_t *rk = r[p];
    uint32_t best = mag32(rk[k]);
    uint32_t umax = 0u;
    uint32_t inc;
    int32_t inv;
    unsigned z;
    unsigned j;
    if (best < (uint32_t)SP_PIVOT_MIN) {
        return 0;
    }
    r[p] = r[k]; /* the rows' pointers swapped, not the rows */
    r[k] = rk;
    inv = lu_reciprocal(rk[k], best, &z, flags);
    zk_out[k] = (uint8_t)z;
    inv_out[k] = inv;
    if (k + 1u >= SP_LEGS) {
        return 1;
    }
    /* v ^ (v >> 31) is |v| for v >= 0 and |v| - 1 below: their OR bounds
     * the pivot row's entries (|a_kj| <= umax + 1), and it is below 2^29
     * exactly when every a_kj is in [-2^29, 2^29) */
    LU_UNROLL
    for (j = k + 1u; j < SP_LEGS; ++j) {
        umax |= (uint32_t)(rk[j] ^ (rk[j] >> 31));
    }
    inc = umax + 8u + (umax >> 16); /* |round(l a_kj / 2^30)| + 1 < inc */
    if (*bound < 0x7FFFFFFFu && inc <= 0x7FFFFFFFu - *bound) {
        *bound += inc;
        if (umax < (UINT32_C(1) << 29)) {
            lu_eliminate_x4(r, rk, k, z, inv);
        } else {
            lu_eliminate(r, rk, k, z, inv);
        }
    } else {
        *bound = 0x80000000u;
        lu_eliminate_sat(r, rk, k, z, inv, flags);
    }
    return 1;
}

/* The copy of A = M (transpose == 0) or M^T into w, and an upper bound
 * of its magnitudes: v ^ (v >> 31) is |v| for v >= 0 and |v| - 1 below,
 * so every |entry| <= (their OR) + 1 <= 2^31. */
SPI_INLINE uint32_t lu_copy_in(const sp_jacobian_t *m, int transpose, int32_t w[SP_LEGS][SP_LEGS])
{
    uint32_t any = 0u;
    unsigned i;
    unsigned j;
    if (transpose) { /* the controller's case: rows unrolled, constant offsets */
        for (i = 0u; i < SP_LEGS; ++i) {
            LU_UNROLL
            for (j = 0u; j < SP_LEGS; ++j) {
                int32_t v = m->j[j][i];
                w[i][j] = v;
                any |= (uint32_t)(v ^ (v >> 31));
            }
        }
    } else {
        const int32_t *src = &m->j[0][0];
        int32_t *dst = &w[0][0];
        for (i = 0u; i < SP_LEGS * SP_LEGS; ++i) {
            int32_t v = src[i];
            dst[i] = v;
            any |= (uint32_t)(v ^ (v >> 31));
        }
    }
    return any + 1u;
}

/* The row order of r (pointers to the rows of a 6x6 array at w0, its
 * first entry): r[i] is row order[i]. */
SPI_INLINE void lu_order(int32_t *const r[SP_LEGS], const int32_t *w0, uint8_t order[SP_LEGS])
{
    unsigned i;
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        order[i] = (uint8_t)((uintptr_t)((const char *)r[i] - (const char *)w0) / (SP_LEGS * sizeof *w0));
    }
}

/* The factorisation's pivot steps in two groups, the first
 * SP_LU6_STAGE_STEPS (0 and 1) and the others (2 to 5), out of line:
 * sp_lu6_factor and the staged factorisation's end share them. Each returns 0
 * at a pivot below SP_PIVOT_MIN. */
SPI_NOINLINE static int lu_steps_first(int32_t *inv, uint8_t *zk, int32_t *r[SP_LEGS], uint32_t *bound,
                                       sp_flags_t *flags)
{
    return lu_step(inv, zk, r, 0u, bound, flags) && lu_step(inv, zk, r, 1u, bound, flags);
}

SPI_NOINLINE static int lu_steps_rest(int32_t *inv, uint8_t *zk, int32_t *r[SP_LEGS], uint32_t *bound,
                                      sp_flags_t *flags)
{
    return lu_step(inv, zk, r, 2u, bound, flags) && lu_step(inv, zk, r, 3u, bound, flags) &&
           lu_step(inv, zk, r, 4u, bound, flags) && lu_step(inv, zk, r, 5u, bound, flags);
}

/* The rows r (pointers to the rows of a 6x6 array at w0) in pivot order
 * into lu->a, and their order into lu->perm (pivot row i is row perm[i]
 * of A). */
SPI_INLINE void lu_copy_out(int32_t *const r[SP_LEGS], const int32_t *w0, sp_lu6_t *lu)
{
    unsigned i;
    unsigned j;
    lu_order(r, w0, lu->perm);
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        LU_UNROLL
        for (j = 0u; j < SP_LEGS; ++j) {
            lu->a[i][j] = r[i][j];
        }
    }
}

sp_status_t sp_lu6_factor(const sp_jacobian_t *m, int transpose, sp_lu6_t *lu)
{
    int32_t w[SP_LEGS][SP_LEGS];
    int32_t *r[SP_LEGS];
    sp_flags_t flags = 0u;
    uint32_t bound;
    unsigned i;

    if (m == NULL || lu == NULL) {
        return SP_E_ARG;
    }
    lu->valid = 0u;
    bound = lu_copy_in(m, transpose, w);
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        r[i] = w[i];
    }
    if (!lu_steps_first(lu->inv, lu->zk, r, &bound, &flags) || !lu_steps_rest(lu->inv, lu->zk, r, &bound, &flags)) {
        return SP_E_SINGULAR;
    }
    /* the rows in pivot order (the solves then read them at constant
     * offsets) */
    lu_copy_out(r, &w[0][0], lu);
    if (flags != 0u) {
        return sp_flags_status(flags);
    }
    lu->valid = 1u;
    return SP_OK;
}

/* The rows of a staged factorisation, in pivot order so far. */
SPI_INLINE void lu_stage_rows(sp_lu6_stage_t *part, int32_t *r[SP_LEGS])
{
    unsigned i;
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        r[i] = part->a[part->order[i]];
    }
}

/* A bound of the entries left after `from` pivot steps (rows and columns
 * from..5 in pivot order), from the entries themselves: not the running
 * one sp_lu6_factor carries to that step, so a step may take the other
 * path, with the same bits, as neither saturates where that bound rules
 * it out. */
SPI_INLINE uint32_t lu_stage_bound(int32_t *const r[SP_LEGS], unsigned from)
{
    uint32_t bound = 0u;
    unsigned i;
    unsigned j;
    LU_UNROLL
    for (i = from; i < SP_LEGS; ++i) {
        LU_UNROLL
        for (j = from; j < SP_LEGS; ++j) {
            bound |= (uint32_t)(r[i][j] ^ (r[i][j] >> 31));
        }
    }
    return bound + 1u;
}

sp_status_t sp_lu6_factor_begin(const sp_jacobian_t *m, int transpose, sp_lu6_stage_t *part)
{
    int32_t *r[SP_LEGS];
    sp_flags_t flags = 0u;
    uint32_t bound;
    unsigned i;

    if (m == NULL || part == NULL) {
        return SP_E_ARG;
    }
    part->begun = 0u;
    part->steps = 0u;
    bound = lu_copy_in(m, transpose, part->a);
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        r[i] = part->a[i];
    }
    if (!lu_step(part->inv, part->zk, r, 0u, &bound, &flags)) {
        return SP_E_SINGULAR;
    }
    lu_order(r, &part->a[0][0], part->order); /* the rows themselves stay where they are */
    if (flags != 0u) {
        return sp_flags_status(flags);
    }
    part->steps = 1u;
    part->begun = 1u;
    return SP_OK;
}

sp_status_t sp_lu6_factor_step(sp_lu6_stage_t *part)
{
    int32_t *r[SP_LEGS];
    sp_flags_t flags = 0u;
    uint32_t bound;

    if (part == NULL || !part->begun || part->steps != 1u) {
        return SP_E_ARG;
    }
    part->begun = 0u; /* its rows are changed below: begun again once done */
    lu_stage_rows(part, r);
    bound = lu_stage_bound(r, 1u);
    if (!lu_step(part->inv, part->zk, r, 1u, &bound, &flags)) {
        return SP_E_SINGULAR;
    }
    lu_order(r, &part->a[0][0], part->order);
    if (flags != 0u) {
        return sp_flags_status(flags);
    }
    part->steps = SP_LU6_STAGE_STEPS;
    part->begun = 1u;
    return SP_OK;
}

sp_status_t sp_lu6_factor_end(sp_lu6_stage_t *part, sp_lu6_t *lu)
{
    int32_t *r[SP_LEGS];
    sp_flags_t flags = 0u;
    uint32_t bound;
    unsigned i;

    if (part == NULL || lu == NULL) {
        return SP_E_ARG;
    }
    lu->valid = 0u;
    if (part->begun && part->steps != SP_LU6_STAGE_STEPS) {
        sp_status_t st = sp_lu6_factor_step(part); /* two calls: the second step here */
        if (st != SP_OK) {
            return st;
        }
    }
    if (!part->begun) {
        return SP_E_ARG;
    }
    part->begun = 0u; /* its rows are changed below */
    lu_stage_rows(part, r);
    bound = lu_stage_bound(r, SP_LU6_STAGE_STEPS);
    if (!lu_steps_rest(lu->inv, lu->zk, r, &bound, &flags)) {
        return SP_E_SINGULAR;
    }
    LU_UNROLL
    for (i = 0u; i < SP_LU6_STAGE_STEPS; ++i) {
        lu->inv[i] = part->inv[i];
        lu->zk[i] = part->zk[i];
    }
    lu_copy_out(r, &part->a[0][0], lu);
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
                             : spi_mul64_up(s, lu->inv[k], 33u - lu->zk[k], flags);
}

/* The checks common to the solves: SP_OK, or the error with x zeroed. */
static sp_status_t lu_check_rhs(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    sp_status_t st = SP_OK;
    unsigned i;

    if (lu == NULL || b == NULL || x == NULL) {
        return SP_E_ARG;
    }
    if (max_abs64(b) >= (uint64_t)RHS_MAX) {
        st = SP_E_OVERFLOW;
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

/* sp_lu6_solve in int64 intermediates (checked): the fallback of the
 * 32-bit solve. lu and b already checked. */
static sp_status_t lu_solve64(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    int64_t r[SP_LEGS];
    sp_flags_t flags = 0u;
    unsigned i;
    unsigned j;
    unsigned k;

    for (k = 0u; k < SP_LEGS; ++k) { /* r = P b */
        r[k] = b[lu->perm[k]];
        x[k] = 0;
    }
    for (k = 0u; k < SP_LEGS; ++k) { /* L y = P b, y in r */
        for (i = k + 1u; i < SP_LEGS; ++i) {
            /* |r| < 2^56 at the start and at most doubles per column:
             * below 2^62 at the end, no overflow */
            int32_t l = lu->a[i][k];
            if (l != 0) {
                r[i] -= spi_mul64_q30_up(r[k], l);
            }
        }
    }
    for (k = SP_LEGS; k-- > 0u;) {
        const int32_t *uk = lu->a[k];
        int64_t s = r[k];
        for (j = k + 1u; j < SP_LEGS; ++j) {
            s = spi_sub64(s, spi_mul64_up(x[j], uk[j], 28u, &flags), &flags); /* INT64_MIN too */
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

/* round(v / 2^s) with ties up into *r when it is below 2^lim in magnitude
 * (v + 2^(s-1) + 2^(s+lim) must not overflow); returns 0 otherwise. A
 * branch per value instead of a flag word: the compiler then keeps no
 * word of a check alive to the end. */
SPI_INLINE int narrow_up_ok(int64_t v, unsigned s, unsigned lim, int32_t *r)
{
    uint64_t t = (uint64_t)v + ((UINT64_C(1) << (s - 1u)) + (UINT64_C(1) << (s + lim)));
    uint32_t lo = (uint32_t)(t >> s);
    if (((uint32_t)(t >> 32) >> s) != 0u || (lo >> (lim + 1u)) != 0u) {
        return 0;
    }
    *r = (int32_t)lo - (INT32_C(1) << lim);
    return 1;
}

/*
 * The 32-bit solves' sums start from c 2^s (+ a rounding bias below 2^s,
 * + hi_bias 2^32) and add the products with the unknowns found so far
 * NEGATED (each |t| < 2^30: -t fits): c 2^s - sum m t = c 2^s + sum m
 * (-t), one multiply-accumulate a product and no 64-bit shift or
 * subtraction, the same integers. The start's two words: c >> (32 - s)
 * (arithmetic) above, c << s | bias below.
 */
SPI_INLINE int64_t s32_start(int32_t c, unsigned s, uint32_t bias, uint32_t hi_bias)
{
    uint32_t hi = (uint32_t)(c >> (32u - s)) + hi_bias;
    return (int64_t)(((uint64_t)hi << 32) | (((uint32_t)c << s) | bias));
}

/* round(v / 2^30) (ties up) into *r when it is in [-2^lim, 2^lim), for t
 * = v + 2^29 + 2^(30 + lim) (the bias already in the sum, from
 * s32_start(c, 30, 2^29, 2^(lim - 2))): narrow_up_ok(v, 30, lim, r). */
SPI_INLINE int narrow30_biased_ok(int64_t t, unsigned lim, int32_t *r)
{
    uint32_t hi = (uint32_t)((uint64_t)t >> 32);
    uint32_t lo = (uint32_t)((uint64_t)t >> 30);
    if ((hi >> 30) != 0u || (lo >> (lim + 1u)) != 0u) {
        return 0;
    }
    *r = (int32_t)lo - (INT32_C(1) << lim);
    return 1;
}

/*
 * y = v / a_kk as the 32-bit solves divide (v int64, |v| below 2^62):
 * sk = round(v / 2^(30 - z)) (ties up) in [-2^30, 2^30), then y =
 * round(sk inv / 2^31) in [-2^29, 2^29); returns 0 when either is out of
 * its range. The first rounding as a multiply: v 2^(z + 2) + 2^31 + 2^62
 * (96 bits, from one unsigned and one signed multiply-accumulate of v's
 * words) has sk + 2^30 in its bits 32 and up, which must be in [0, 2^31):
 * the same bits and the same refusals as shifting v by the pivot's
 * variable 30 - z (tests/unit/test_lu6.c, test_solves32_bits).
 */
SPI_INLINE int div_pivot_ok(const sp_lu6_t *lu, unsigned k, int64_t v, int32_t *y)
{
    int32_t p = INT32_C(4) << lu->zk[k]; /* 2^(z + 2), z in [0, 12] */
    uint64_t lo = (uint64_t)(uint32_t)v * (uint32_t)p + ((UINT64_C(1) << 62) | (UINT64_C(1) << 31));
    int32_t vh = (int32_t)((uint64_t)v >> 32);
    int64_t hi = (int64_t)vh * p + (int64_t)(lo >> 32); /* bits 32..95 */
    if ((uint64_t)hi >= (UINT64_C(1) << 31)) {
        return 0;
    }
    /* narrow_up_ok(sk inv, 31, 29, y): t = sk inv + 2^30 + 2^60 (below
     * 2^62 in magnitude) must be in [0, 2^61), a test of its high word */
    {
        int64_t t =
            (int64_t)((int32_t)hi - (INT32_C(1) << 30)) * lu->inv[k] + ((INT64_C(1) << 60) | (INT64_C(1) << 30));
        if (((uint32_t)((uint64_t)t >> 32) >> 29) != 0u) {
            return 0;
        }
        *y = (int32_t)(uint32_t)((uint64_t)t >> 31) - (INT32_C(1) << 29);
    }
    return 1;
}

/* The block exponent e of the 32-bit solves for max |b| = m (0 < m <
 * 2^56): max |b| 2^e in [2^top, 2^(top+1)). */
SPI_INLINE int s32_exponent(uint64_t m, unsigned top)
{
    return (int)spi_clz64(m) - (int)(63u - top);
}

/* b[perm[k]] 2^e (b[k]'s when perm is NULL) as int32 into bs[k], for
 * max |b| 2^e below 2^(top+1): exact for e >= 0, else round(b / 2^-e)
 * with ties up (-e in [1, 31]). */
SPI_INLINE void s32_scale_in(const int64_t b[SP_LEGS], int e, const uint8_t *perm, int32_t bs[SP_LEGS])
{
    unsigned i;
    if (e >= 0) {
        LU_UNROLL
        for (i = 0u; i < SP_LEGS; ++i) {
            bs[i] = (int32_t)((uint32_t)b[perm != NULL ? perm[i] : i] << e);
        }
    } else {
        unsigned sh = (unsigned)-e;
        LU_UNROLL
        for (i = 0u; i < SP_LEGS; ++i) {
            uint64_t t = (uint64_t)b[perm != NULL ? perm[i] : i] + (UINT64_C(1) << (sh - 1u));
            bs[i] = (int32_t)(((uint32_t)t >> sh) | ((uint32_t)(t >> 32) << (32u - sh)));
        }
    }
}

/* x[perm[k]] (x[k] when perm is NULL) = w_k 2^-e: exact for e <= 0
 * (-e <= 29, |w| < 2^30: below 2^59), else round(w_k / 2^e), ties up
 * (e <= 28: no overflow). */
SPI_INLINE void s32_scale_out(const int32_t w[SP_LEGS], int e, const uint8_t *perm, int64_t x[SP_LEGS])
{
    unsigned k;
    if (e > 0) {
        LU_UNROLL
        for (k = 0u; k < SP_LEGS; ++k) {
            x[perm != NULL ? perm[k] : k] = (int64_t)((w[k] + (INT32_C(1) << (e - 1))) >> e);
        }
    } else {
        /* w 2^n, n = -e in [0, 31], from its two words: w << n below,
         * w >> (32 - n) (arithmetic, as (w >> 1) >> (31 - n)) above */
        unsigned n = (unsigned)-e;
        LU_UNROLL
        for (k = 0u; k < SP_LEGS; ++k) {
            uint32_t hi = (uint32_t)((w[k] >> 1) >> (31u - n));
            x[perm != NULL ? perm[k] : k] = (int64_t)(((uint64_t)hi << 32) | ((uint32_t)w[k] << n));
        }
    }
}

/*
 * sp_lu6_solve in 32-bit intermediates, block-scaled. b' = b 2^e with
 * max |b'| in [2^28, 2^29) (b rounded when max |b| >= 2^29), x' = x 2^e.
 * L y = P b', forward, every y below 2^30 in magnitude:
 * y_i 2^30 - sum_k l_ik y_k is exact in int64 (|l| <= 2^30: five products
 * up to 2^60, and 2^59). U x' = y, backward, every x' below 2^29:
 * s_k = y_k 2^28 - sum_j u_kj x'_j is exact (|u| <= 2^31: five products up
 * to 2^60, and 2^58), then x'_k = s_k / a_kk = round(s_k / 2^(30 - z))
 * inv / 2^31, the first factor below 2^30 (the pivot's exponent taken out
 * first, so that it keeps as many bits as x'). Each step rounds once
 * (within 2^-29 of max |b'|, the reciprocal within 2^-28): x is within a
 * few 2^-28 max |b| of the exact solution times the growth of the
 * elimination. For the inverse dynamics (J^T f = wrench) max |x| is
 * typically 1/4 to 2 max |b|. Returns 0 (x untouched) when an
 * intermediate leaves its range: the caller then solves in int64.
 */
static int lu_solve32(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int e, int64_t x[SP_LEGS])
{
    const int32_t(*u)[SP_LEGS] = lu->a; /* the rows of L and U in pivot order */
    int32_t bs[SP_LEGS];
    int32_t y[SP_LEGS];
    int32_t ny[SP_LEGS]; /* -y */
    int32_t w[SP_LEGS];
    int32_t nw[SP_LEGS]; /* -w */
    unsigned i;
    unsigned j;
    unsigned k;

    s32_scale_in(b, e, lu->perm, bs); /* P b' */
    LU_UNROLL
    for (i = 0u; i < SP_LEGS; ++i) {
        int64_t acc = s32_start(bs[i], 30u, UINT32_C(1) << 29, UINT32_C(1) << 28);
        LU_UNROLL
        for (k = 0u; k < i; ++k) {
            acc += (int64_t)u[i][k] * ny[k];
        }
        if (!narrow30_biased_ok(acc, 30u, &y[i])) {
            return 0;
        }
        ny[i] = -y[i];
    }
    LU_UNROLL
    for (k = SP_LEGS; k-- > 0u;) {
        int64_t acc = s32_start(y[k], 28u, 0u, 0u);
        LU_UNROLL
        for (j = k + 1u; j < SP_LEGS; ++j) {
            acc += (int64_t)u[k][j] * nw[j];
        }
        if (!div_pivot_ok(lu, k, acc, &w[k])) {
            return 0;
        }
        nw[k] = -w[k];
    }
    s32_scale_out(w, e, NULL, x);
    return 1;
}

sp_status_t sp_lu6_solve(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    uint64_t m;
    unsigned i;

    if (lu == NULL || b == NULL || x == NULL) {
        return SP_E_ARG;
    }
    m = max_abs64(b);
    if (m >= (uint64_t)RHS_MAX || !lu->valid || m == 0u) {
        for (i = 0u; i < SP_LEGS; ++i) {
            x[i] = 0;
        }
        return !lu->valid ? SP_E_ARG : (m != 0u) ? SP_E_OVERFLOW : SP_OK;
    }
    if (lu_solve32(lu, b, s32_exponent(m, 28u), x)) {
        return SP_OK;
    }
    return lu_solve64(lu, b, x);
}

sp_status_t sp_lu6_solve_grow(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    uint64_t m;
    unsigned i;

    if (lu == NULL || b == NULL || x == NULL) {
        return SP_E_ARG;
    }
    m = max_abs64(b);
    if (m >= (uint64_t)RHS_MAX || !lu->valid || m == 0u) {
        for (i = 0u; i < SP_LEGS; ++i) {
            x[i] = 0;
        }
        return !lu->valid ? SP_E_ARG : (m != 0u) ? SP_E_OVERFLOW : SP_OK;
    }
    /* b' in [2^24, 2^25): room for a solution 16 times max |b'| larger
     * than sp_lu6_solve's; e >= -31 as m < 2^56 */
    if (lu_solve32(lu, b, s32_exponent(m, 24u), x)) {
        return SP_OK;
    }
    return lu_solve64(lu, b, x);
}

#define LT_MAX (INT64_C(1) << 61) /* spi_mul64_q30_up's range */

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
            s = spi_sub64(s, spi_mul64_up(y[j], lu->a[j][k], 28u, &flags), &flags);
        }
        y[k] = lu_div_pivot(lu, k, s, &flags);
    }
    /* L^T z = y, backward (unit diagonal, multipliers Q30, |l| <= 1): */
    for (k = SP_LEGS; k-- > 0u;) {
        int64_t s = y[k];
        for (i = k + 1u; i < SP_LEGS; ++i) {
            int32_t l = lu->a[i][k];
            if (l != 0) {
                if (y[i] >= LT_MAX || y[i] <= -LT_MAX) {
                    flags |= SP_FLAG_OVERFLOW;
                } else {
                    s = spi_add64(s, -spi_mul64_q30_up(y[i], l), &flags);
                }
            }
        }
        y[k] = s;
    }
    /* x = P^T z: (P x)_k = x_perm[k] */
    for (k = 0u; k < SP_LEGS; ++k) {
        x[lu->perm[k]] = (flags != 0u) ? 0 : y[k];
    }
    return sp_flags_status(flags);
}

/*
 * sp_lu6_solve_transposed in 32-bit intermediates, block-scaled: b is
 * scaled by 2^e so that max |b| is in [2^26, 2^27) (rounded only when
 * max |b| >= 2^27), every product is one 32x32->64 multiply accumulated
 * exactly in int64, and every intermediate must stay below 2^29 (a growth
 * of at least 4). U^T y = b', forward: s_k = b'_k 2^28 - sum_j u_jk y_j
 * (five products up to 2^60, and 2^55), y_k = round(s_k / 2^(30 - z))
 * inv / 2^31 as in lu_solve32; L^T v = y, backward: v_k = y_k - sum_i
 * l_ik v_i / 2^30 (five products up to 2^59). Returns 0, x untouched,
 * when an intermediate does not fit (or b is 0): the caller then uses the
 * int64 solve. For the chord FK, whose right-hand side (a length
 * residual) is small: the steps keep 26 significant bits.
 */
int spi_lu6_solve_t32(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS])
{
    const int32_t(*u)[SP_LEGS] = lu->a; /* the rows of L and U in pivot order */
    int32_t bs[SP_LEGS];
    int32_t y[SP_LEGS];
    int32_t ny[SP_LEGS]; /* -y */
    uint64_t m = max_abs64(b);
    int e;
    unsigned i;
    unsigned j;
    unsigned k;

    if (m == 0u || m >= (uint64_t)RHS_MAX) {
        return 0;
    }
    e = s32_exponent(m, 26u);
    s32_scale_in(b, e, NULL, bs);
    LU_UNROLL
    for (k = 0u; k < SP_LEGS; ++k) {
        int64_t acc = s32_start(bs[k], 28u, 0u, 0u);
        LU_UNROLL
        for (j = 0u; j < k; ++j) {
            acc += (int64_t)u[j][k] * ny[j];
        }
        if (!div_pivot_ok(lu, k, acc, &y[k])) {
            return 0;
        }
        ny[k] = -y[k];
    }
    LU_UNROLL
    for (k = SP_LEGS; k-- > 0u;) {
        int64_t acc = s32_start(y[k], 30u, UINT32_C(1) << 29, UINT32_C(1) << 27);
        LU_UNROLL
        for (i = k + 1u; i < SP_LEGS; ++i) {
            acc += (int64_t)u[i][k] * ny[i]; /* ny[i] = -v_i here */
        }
        if (!narrow30_biased_ok(acc, 29u, &y[k])) {
            return 0;
        }
        ny[k] = -y[k];
    }
    s32_scale_out(y, e, lu->perm, x);
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
    if (max_abs64(b) >= (uint64_t)RHS_MAX) {
        return SP_E_OVERFLOW; /* x is zeroed */
    }
    st = sp_lu6_factor(m, transpose, &lu);
    if (st != SP_OK) {
        return st;
    }
    return sp_lu6_solve(&lu, b, x);
}
