/* SPDX-License-Identifier: Apache-2.0 */
/*
 * test_lu6.c - the 6x6 factorisation and solves, every fast routine against
 * one plain reference, on thousands of seeded random systems:
 *  - sp_lu6_factor against ref_factor, the elimination as written before
 *    the fast paths (row swaps, saturating subtraction on every entry, the
 *    same rounding): the same bits for matrices that take the unchecked 4a
 *    path (entries below 2), the unchecked 64-bit path (pivot rows up to
 *    3.9) and the checked path (entries near 8), and SP_E_OVERFLOW where
 *    an entry saturates;
 *  - the solves with a factorisation, sp_lu6_solve (32-bit, its int64
 *    fallback), sp_lu6_solve_transposed (int64) and the chord FK's 32-bit
 *    spi_lu6_solve_t32, against ref_solve: substitution with the same
 *    factors in long double, dividing by the pivots exactly (the bounds at
 *    test_solves_reference); sp_solve6 is sp_lu6_factor + sp_lu6_solve bit
 *    for bit; on well-conditioned matrices the solutions are within the
 *    header's bounds of the exact solution of the unfactored system;
 *  - the 32-bit solves (sp_lu6_solve's and sp_lu6_solve_grow's path,
 *    spi_lu6_solve_t32) bit for bit against their plain references
 *    (ref_solve32, ref_solve_t32: the algorithm as first written, with
 *    its roundings and refusals), test_solves32_bits;
 *  - the fallbacks (the int64 solve, the 32-bit transposed solve's
 *    refusal) on systems built to need them, and the errors.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "model/model_internal.h"
#include "assert_near.h"
#include "sp/model/kinematics.h"
#include "test_util.h"

#define Q28 268435456.0
#define Q24 16777216.0

/* The elimination as it was written before the fast paths: rows swapped,
 * every subtraction saturated and flagged (the pivot chosen as
 * sp_lu6_factor does). Uses the pivots' reciprocals
 * of lu (checked separately against 2^61 / (|a_kk| 2^z)). Returns the
 * rows in pivot order in a, the original index of pivot row k in perm. */
static int ref_factor(const sp_jacobian_t *m, int transpose, const sp_lu6_t *lu, int32_t a[6][6], int perm[6])
{
    int overflow = 0;
    for (int i = 0; i < 6; ++i) {
        perm[i] = i;
        for (int j = 0; j < 6; ++j) {
            a[i][j] = transpose ? m->j[j][i] : m->j[i][j];
        }
    }
    for (int k = 0; k < 6; ++k) {
        int p = k;
        int64_t key = llabs((long long)a[k][k]) - (a[k][k] < 0);
        int64_t best;
        for (int i = k + 1; i < 6; ++i) {
            /* the first largest |a_ik| - (a_ik < 0) */
            if (llabs((long long)a[i][k]) - (a[i][k] < 0) > key) {
                key = llabs((long long)a[i][k]) - (a[i][k] < 0);
                p = i;
            }
        }
        best = llabs((long long)a[p][k]);
        if (best < SP_PIVOT_MIN) {
            return -1;
        }
        if (p != k) {
            for (int j = 0; j < 6; ++j) {
                int32_t t = a[k][j];
                a[k][j] = a[p][j];
                a[p][j] = t;
            }
            int t = perm[k];
            perm[k] = perm[p];
            perm[p] = t;
        }
        if (best <= INT32_MAX) { /* (a saturated pivot is flagged) */
            /* the reciprocal: never above the exact value, within 2^-28 */
            int z = lu->zk[k];
            double exact = pow(2.0, 61) / ((double)best * pow(2.0, z));
            double inv = fabs((double)lu->inv[k]);
            assert_true((double)best * pow(2.0, z) >= pow(2.0, 30) && (double)best * pow(2.0, z) < pow(2.0, 31));
            assert_true(inv <= exact && inv >= exact * (1.0 - pow(2.0, -28)));
            assert_true((lu->inv[k] < 0) == (a[k][k] < 0));
        }
        for (int i = k + 1; i < 6; ++i) {
            int64_t l = ((int64_t)(a[i][k] * (1 << lu->zk[k])) * lu->inv[k] + ((int64_t)1 << 30)) >> 31;
            a[i][k] = (int32_t)l;
            for (int j = k + 1; j < 6; ++j) {
                int64_t v = (int64_t)a[i][j] - ((l * a[k][j] + ((int64_t)1 << 29)) >> 30);
                if (v > INT32_MAX || v < INT32_MIN) {
                    overflow = 1;
                    v = v > 0 ? INT32_MAX : INT32_MIN;
                }
                a[i][j] = (int32_t)v;
            }
        }
    }
    return overflow;
}

/* A row permutation of a diagonally dominant matrix with entries up to
 * scale (the diagonal 2 scale, the rest within +-0.3 scale). */
static void random_matrix(uint64_t *rng, double scale, int shift, sp_jacobian_t *m, double md[6][6])
{
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < 6; ++j) {
            double v = scale * (tu_uniform(rng, -0.3, 0.3) + (i == (j + shift) % 6 ? 2.0 : 0.0));
            m->j[i][j] = (int32_t)llround(v * Q28);
            md[i][j] = m->j[i][j] / Q28;
        }
    }
}

/* The staged factorisation against the whole one, in two calls
 * (sp_lu6_factor_begin, then _end) and in three (_begin, _step, _end):
 * the same bits and status; an error of an early call is one of the
 * whole factorisation's (a singular pivot, or a saturated entry where a
 * later pivot may yet be singular). */
static void check_staged_calls(const sp_jacobian_t *m, int transpose, const sp_lu6_t *lu, sp_status_t st, int calls)
{
    sp_lu6_stage_t part;
    sp_lu6_t staged;
    sp_status_t sb;
    memset(&staged, 0x5A, sizeof staged);
    sb = sp_lu6_factor_begin(m, transpose, &part);
    assert_int_equal(part.begun, sb == SP_OK);
    if (sb == SP_OK && calls == 3) {
        assert_int_equal(part.steps, 1);
        sb = sp_lu6_factor_step(&part);
        assert_int_equal(part.begun, sb == SP_OK);
        if (sb == SP_OK) {
            assert_int_equal(part.steps, SP_LU6_STAGE_STEPS);
            sp_lu6_stage_t twice = part;
            assert_int_equal(sp_lu6_factor_step(&twice), SP_E_ARG); /* a second step: refused */
        }
    }
    if (sb != SP_OK) {
        assert_int_not_equal(st, SP_OK);
        assert_true(sb == st || (sb == SP_E_OVERFLOW && st == SP_E_SINGULAR));
        assert_int_equal(sp_lu6_factor_end(&part, &staged), SP_E_ARG); /* nothing begun to end */
        assert_int_equal(staged.valid, 0);
        return;
    }
    assert_int_equal(sp_lu6_factor_end(&part, &staged), st);
    assert_int_equal(part.begun, 0);
    assert_int_equal(staged.valid, lu->valid);
    if (st == SP_OK) {
        assert_memory_equal(staged.a, lu->a, sizeof lu->a);
        assert_memory_equal(staged.inv, lu->inv, sizeof lu->inv);
        assert_memory_equal(staged.zk, lu->zk, sizeof lu->zk);
        assert_memory_equal(staged.perm, lu->perm, sizeof lu->perm);
    }
    assert_int_equal(sp_lu6_factor_step(&part), SP_E_ARG); /* used up */
}

static void check_staged(const sp_jacobian_t *m, int transpose, const sp_lu6_t *lu, sp_status_t st)
{
    check_staged_calls(m, transpose, lu, st, 2);
    check_staged_calls(m, transpose, lu, st, 3);
}

static void check_factor(const sp_jacobian_t *m, int transpose)
{
    sp_lu6_t lu;
    int32_t a[6][6];
    int perm[6];
    sp_status_t st = sp_lu6_factor(m, transpose, &lu);
    int ref = ref_factor(m, transpose, &lu, a, perm);
    check_staged(m, transpose, &lu, st);
    if (ref < 0) {
        assert_int_equal(st, SP_E_SINGULAR);
        return;
    }
    assert_int_equal(st, ref ? SP_E_OVERFLOW : SP_OK);
    assert_int_equal(lu.valid, ref ? 0 : 1);
    if (ref) {
        return;
    }
    for (int k = 0; k < 6; ++k) {
        assert_int_equal(lu.perm[k], perm[k]);
        assert_memory_equal(lu.a[k], a[k], sizeof a[k]);
    }
}

/* The factorisation's three elimination paths give the reference's bits. */
static void test_factor_paths(void **state)
{
    uint64_t rng = 31;
    sp_jacobian_t m;
    double md[6][6];
    (void)state;
    for (int n = 0; n < 3000; ++n) {
        /* n % 3 == 0: entries below 2 (the 4a path); 1: entries up to
         * 3.9 and no dominance, pivot rows above 2 (the 64-bit unchecked
         * path, then the checked one as the bound grows); 2: entries near
         * 8, the bound at 2^31 from the start (the checked path) */
        if (n % 3 == 1) {
            for (int i = 0; i < 6; ++i) {
                for (int j = 0; j < 6; ++j) {
                    m.j[i][j] = (int32_t)llround(tu_uniform(&rng, -3.9, 3.9) * Q28);
                }
            }
        } else {
            random_matrix(&rng, (n % 3 == 0) ? 1.0 : 3.4, n, &m, md);
        }
        check_factor(&m, n & 1);
    }
    /* an entry that saturates: SP_E_OVERFLOW, not valid */
    {
        sp_lu6_t lu;
        memset(&m, 0, sizeof m);
        for (int i = 0; i < 6; ++i) {
            m.j[i][i] = 1 << 28;
        }
        m.j[1][0] = -(1 << 28);    /* l = -1 for row 1 */
        m.j[0][1] = INT32_MAX - 5; /* row 0, the pivot row */
        m.j[1][1] = INT32_MAX - 5; /* + (INT32_MAX - 5) saturates */
        check_factor(&m, 0);
        assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_E_OVERFLOW);
        assert_int_equal(lu.valid, 0);
        /* the same matrix transposed does not (row 1 is not eliminated by 0) */
        check_factor(&m, 1);
    }
    /* singular */
    random_matrix(&rng, 1.0, 0, &m, md);
    for (int j = 0; j < 6; ++j) {
        m.j[5][j] = m.j[2][j];
    }
    check_factor(&m, 0);
}

/* The plain reference of the solves: A x = b (transpose == 0) or
 * A^T x = b (transpose != 0) for the factorised A = P^T L U of lu, by
 * substitution in long double with L (Q30) and U (Q28) as stored and an
 * exact division by each pivot: the exact solution of the system the
 * factors represent (to long double). b and x in the same Q format. */
static void ref_solve(const sp_lu6_t *lu, int transpose, const int64_t b[6], long double x[6])
{
    long double l[6][6], u[6][6], y[6];
    for (int k = 0; k < 6; ++k) { /* row k of L and U: pivot row k, lu->a[k] */
        for (int j = 0; j < 6; ++j) {
            int32_t v = lu->a[k][j];
            l[k][j] = (j < k) ? (long double)v / (1 << 30) : (j == k) ? 1.0L : 0.0L;
            u[k][j] = (j >= k) ? (long double)v / (1 << 28) : 0.0L;
        }
    }
    if (!transpose) {
        for (int k = 0; k < 6; ++k) { /* L y = P b */
            y[k] = (long double)b[lu->perm[k]];
            for (int j = 0; j < k; ++j) {
                y[k] -= l[k][j] * y[j];
            }
        }
        for (int k = 5; k >= 0; --k) { /* U x = y */
            x[k] = y[k];
            for (int j = k + 1; j < 6; ++j) {
                x[k] -= u[k][j] * x[j];
            }
            x[k] /= u[k][k];
        }
    } else {
        long double v[6];
        for (int k = 0; k < 6; ++k) { /* U^T y = b */
            y[k] = (long double)b[k];
            for (int j = 0; j < k; ++j) {
                y[k] -= u[j][k] * y[j];
            }
            y[k] /= u[k][k];
        }
        for (int k = 5; k >= 0; --k) { /* L^T v = y */
            v[k] = y[k];
            for (int i = k + 1; i < 6; ++i) {
                v[k] -= l[i][k] * v[i];
            }
        }
        for (int k = 0; k < 6; ++k) { /* x = P^T v */
            x[lu->perm[k]] = v[k];
        }
    }
}

static long double max_abs_ld(const long double v[6])
{
    long double m = 0;
    for (int i = 0; i < 6; ++i) {
        m = fabsl(v[i]) > m ? fabsl(v[i]) : m;
    }
    return m;
}

static int64_t max_abs_i64(const int64_t v[6])
{
    int64_t m = 0;
    for (int i = 0; i < 6; ++i) {
        m = llabs(v[i]) > m ? llabs(v[i]) : m;
    }
    return m;
}

/* A random, well-conditioned system: a row permutation of a diagonally
 * dominant matrix M (random_matrix at a scale s: a diagonal of 2 s, within
 * 0.3 s; five more entries per row and column, each within 0.3 s) of one of
 * three kinds (kind 0: s = 1; 1: s = 2.5, entries up to 5.75; 2: s = 0.25,
 * 0.1 or 0.05, so that |x| grows to 2 to 20 max |b|: the solves'
 * fallbacks), a solution xd of magnitude 1e-3 to 1e5, and, in Q24, b =
 * round(A xd) and bt = round(A^T xd) for A = M (transpose == 0) or M^T.
 * Returns a bound of ||A^-1|| and ||A^-T|| (infinity norm): 1 / (1.7 s -
 * 1.5 s), the margin of the dominance (Varah's bound). */
static double random_system(uint64_t *rng, int kind, int transpose, sp_jacobian_t *m, double xd[6], int64_t b[6],
                            int64_t bt[6])
{
    static const double small[3] = {0.25, 0.1, 0.05};
    double md[6][6];
    double mag = exp(tu_uniform(rng, log(1e-3), log(1e5)));
    double scale = (kind == 0) ? 1.0 : (kind == 1) ? 2.5 : small[tu_next(rng) % 3u];
    random_matrix(rng, scale, (int)(tu_next(rng) % 6u), m, md);
    for (int i = 0; i < 6; ++i) {
        xd[i] = tu_uniform(rng, -mag, mag);
    }
    for (int i = 0; i < 6; ++i) {
        long double s = 0, st = 0;
        for (int j = 0; j < 6; ++j) {
            s += (long double)(transpose ? md[j][i] : md[i][j]) * xd[j];
            st += (long double)(transpose ? md[i][j] : md[j][i]) * xd[j];
        }
        b[i] = llroundl(s * Q24);
        bt[i] = llroundl(st * Q24);
    }
    return 1.0 / (0.2 * scale);
}

/*
 * Every solve against ref_solve on 8000 random systems (random_system's
 * three kinds, either factorisation, |x| from 1e-3 to 1e5), in LSB of b's
 * Q format. The solves' errors are roundings of b and of the
 * intermediates, carried to x by A^-1 (at most g = ||A^-1|| times them),
 * and the reciprocals' 2^-28 per pivot, relative to x: with B = max |b|
 * 2^-28, X = max |x| 2^-28 (x the reference) and E = g (B + 1) + X:
 *  - sp_lu6_solve: within E (its 32-bit path rounds b and each
 *    intermediate to 29 significant bits of max |b|; the int64 fallback,
 *    taken when x passes 2^29 at b's scale, rounds each product);
 *  - sp_solve6 on the same matrix: sp_lu6_solve's bits;
 *  - sp_lu6_solve_grow (25 significant bits of max |b|): within 16 E;
 *  - sp_lu6_solve_transposed (int64 throughout): within 2 E;
 *  - spi_lu6_solve_t32, when it accepts (27 significant bits of max |b|):
 *    within 4 E; when it refuses, x untouched.
 * The measured worst cases are printed (about half the bound). On kind 0,
 * both solutions are also within the headers' bounds of the exact solution
 * xd of the unfactored systems: 3e-8 max |xd| + 1e-6 (sp_lu6_solve,
 * sp_solve6) and 1e-8 max |xd| + 1e-6 (sp_lu6_solve_transposed); b itself
 * is rounded to Q24 (6e-8).
 */
static void test_solves_reference(void **state)
{
    uint64_t rng = 41;
    double worst[4] = {0, 0, 0, 0}; /* error / bound: solve, transposed, t32, vs xd */
    double worst_grow = 0;
    int fallback64 = 0;
    int refused = 0;
    (void)state;
    for (int n = 0; n < 8000; ++n) {
        sp_jacobian_t m;
        sp_lu6_t lu;
        double xd[6];
        int64_t b[6], bt[6], x[6], x6[6], xt[6], x32[6];
        long double want[6], want_t[6];
        int kind = n % 3;
        int tr = (n / 3) & 1;
        long double err, err_t, tol;
        int e;
        double g = random_system(&rng, kind, tr, &m, xd, b, bt);
        assert_int_equal(sp_lu6_factor(&m, tr, &lu), SP_OK);
        ref_solve(&lu, 0, b, want);
        ref_solve(&lu, 1, bt, want_t);
        err = g * (ldexpl((long double)max_abs_i64(b), -28) + 1) + ldexpl(max_abs_ld(want), -28);
        err_t = g * (ldexpl((long double)max_abs_i64(bt), -28) + 1) + ldexpl(max_abs_ld(want_t), -28);
        /* the 32-bit solve's scale: max |b| 2^e in [2^28, 2^29) */
        e = 28 - (int)floorl(log2l((long double)max_abs_i64(b)));
        fallback64 += ldexpl(max_abs_ld(want), e) >= 0x1p29L;

        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
        assert_int_equal(sp_solve6(&m, tr, b, x6), SP_OK);
        assert_memory_equal(x6, x, sizeof x);
        /* sp_lu6_solve_grow: b rounded to 25 significant bits (16 times
         * sp_lu6_solve's 2^-29 of max |b|): within 16 E */
        assert_int_equal(sp_lu6_solve_grow(&lu, b, x6), SP_OK);
        for (int i = 0; i < 6; ++i) {
            worst_grow = fmax(worst_grow, (double)(fabsl(x6[i] - want[i]) / (16 * err)));
            assert_near(x6[i], want[i], 16 * err, "system %d (kind %d): grow x[%d]", n, kind, i);
        }
        assert_int_equal(sp_lu6_solve_transposed(&lu, bt, xt), SP_OK);
        for (int i = 0; i < 6; ++i) {
            x32[i] = INT64_C(0x7777777777777777);
        }
        if (spi_lu6_solve_t32(&lu, bt, x32)) {
            for (int i = 0; i < 6; ++i) {
                worst[2] = fmax(worst[2], (double)(fabsl(x32[i] - want_t[i]) / (4 * err_t)));
                assert_near(x32[i], want_t[i], 4 * err_t, "system %d (kind %d): t32 x[%d]", n, kind, i);
            }
        } else {
            ++refused;
            for (int i = 0; i < 6; ++i) {
                assert_true(x32[i] == INT64_C(0x7777777777777777));
            }
        }
        for (int i = 0; i < 6; ++i) {
            worst[0] = fmax(worst[0], (double)(fabsl(x[i] - want[i]) / err));
            assert_near(x[i], want[i], err, "system %d (kind %d): x[%d]", n, kind, i);
            worst[1] = fmax(worst[1], (double)(fabsl(xt[i] - want_t[i]) / (2 * err_t)));
            assert_near(xt[i], want_t[i], 2 * err_t, "system %d (kind %d): transposed x[%d]", n, kind, i);
        }
        if (kind == 0) {
            /* both against the exact solution xd of the unfactored systems */
            double big = 0;
            for (int i = 0; i < 6; ++i) {
                big = fmax(big, fabs(xd[i]));
            }
            for (int i = 0; i < 6; ++i) {
                tol = 3e-8 * big + 1e-6;
                worst[3] = fmax(worst[3], fabs((double)x[i] / Q24 - xd[i]) / (double)tol);
                assert_near((double)x[i] / Q24, xd[i], tol, "system %d: x[%d] vs the exact solution", n, i);
                tol = 1e-8 * big + 1e-6;
                worst[3] = fmax(worst[3], fabs((double)xt[i] / Q24 - xd[i]) / (double)tol);
                assert_near((double)xt[i] / Q24, xd[i], tol, "system %d: transposed x[%d] vs the exact solution", n, i);
            }
        }
    }
    print_message("solves vs ref_solve over 8000 systems, worst error / bound: solve %.2f, transposed %.2f, t32 %.2f; "
                  "vs the exact solution %.2f; int64 fallback %d, t32 refused %d\n",
                  worst[0], worst[1], worst[2], worst[3], fallback64, refused);
    assert_true(fallback64 > 200 && refused > 200);
    print_message("sp_lu6_solve_grow vs ref_solve, worst error / bound %.2f\n", worst_grow);
}

/*
 * The 32-bit solves as first written (sessions before 14), plainly: the
 * optimised ones must give their bits exactly, and refuse exactly where
 * they refuse. round(v / 2^s) ties up, accepted when it is in [-2^lim,
 * 2^lim) (else the solve refuses: returns 0).
 */
static int ref_narrow(int64_t v, int s, int lim, int32_t *r)
{
    int64_t q = (v + ((int64_t)1 << (s - 1))) >> s; /* v below 2^62 here */
    if (q < -((int64_t)1 << lim) || q >= ((int64_t)1 << lim)) {
        return 0;
    }
    *r = (int32_t)q;
    return 1;
}

/* max |b| 2^e in [2^top, 2^(top+1)) (0 < max |b| < 2^56) */
static int ref_exponent(const int64_t b[6], int top)
{
    uint64_t m = (uint64_t)max_abs_i64(b);
    int h = 0; /* the highest set bit of m */
    while ((m >> h) > 1u) {
        ++h;
    }
    return top - h;
}

/* b 2^e: exact for e >= 0, else rounded ties up */
static int32_t ref_scale_in(int64_t b, int e)
{
    return (int32_t)((e >= 0) ? b * ((int64_t)1 << e) : (b + ((int64_t)1 << (-e - 1))) >> -e);
}

/* w 2^-e: exact for e <= 0, else rounded ties up */
static int64_t ref_scale_out(int32_t w, int e)
{
    return (e > 0) ? ((int64_t)w + ((int64_t)1 << (e - 1))) >> e : (int64_t)w * ((int64_t)1 << -e);
}

/* y = s / a_kk as the 32-bit solves divide: round(s / 2^(30 - z)) in
 * [-2^30, 2^30), times inv, round(/ 2^31) in [-2^29, 2^29) */
static int ref_div_pivot(const sp_lu6_t *lu, int k, int64_t s, int32_t *y)
{
    int32_t sk;
    return ref_narrow(s, 30 - lu->zk[k], 30, &sk) && ref_narrow((int64_t)sk * lu->inv[k], 31, 29, y);
}

/* sp_lu6_solve's (top 28) and sp_lu6_solve_grow's (top 24) 32-bit path:
 * L y = P b', U x' = y */
static int ref_solve32(const sp_lu6_t *lu, const int64_t b[6], int top, int64_t x[6])
{
    int e = ref_exponent(b, top);
    int32_t y[6], w[6];
    for (int i = 0; i < 6; ++i) {
        int64_t acc = 0;
        for (int k = 0; k < i; ++k) {
            acc += (int64_t)lu->a[i][k] * y[k];
        }
        if (!ref_narrow((int64_t)ref_scale_in(b[lu->perm[i]], e) * ((int64_t)1 << 30) - acc, 30, 30, &y[i])) {
            return 0;
        }
    }
    for (int k = 5; k >= 0; --k) {
        int64_t acc = 0;
        for (int j = k + 1; j < 6; ++j) {
            acc += (int64_t)lu->a[k][j] * w[j];
        }
        if (!ref_div_pivot(lu, k, (int64_t)y[k] * ((int64_t)1 << 28) - acc, &w[k])) {
            return 0;
        }
    }
    for (int k = 0; k < 6; ++k) {
        x[k] = ref_scale_out(w[k], e);
    }
    return 1;
}

/* spi_lu6_solve_t32: U^T y = b', L^T v = y, x = P^T v */
static int ref_solve_t32(const sp_lu6_t *lu, const int64_t b[6], int64_t x[6])
{
    int32_t y[6];
    int64_t m = max_abs_i64(b);
    int e;
    if (m == 0 || m >= ((int64_t)1 << 56)) {
        return 0;
    }
    e = ref_exponent(b, 26);
    for (int k = 0; k < 6; ++k) {
        int64_t acc = 0;
        for (int j = 0; j < k; ++j) {
            acc += (int64_t)lu->a[j][k] * y[j];
        }
        if (!ref_div_pivot(lu, k, (int64_t)ref_scale_in(b[k], e) * ((int64_t)1 << 28) - acc, &y[k])) {
            return 0;
        }
    }
    for (int k = 5; k >= 0; --k) {
        int64_t acc = 0;
        for (int i = k + 1; i < 6; ++i) {
            acc += (int64_t)lu->a[i][k] * y[i];
        }
        if (!ref_narrow((int64_t)y[k] * ((int64_t)1 << 30) - acc, 30, 29, &y[k])) {
            return 0;
        }
    }
    for (int k = 0; k < 6; ++k) {
        x[lu->perm[k]] = ref_scale_out(y[k], e);
    }
    return 1;
}

/*
 * The 32-bit solves bit for bit against ref_solve32 / ref_solve_t32 on
 * 30000 random systems (random_system's three kinds, and one in five
 * with |A^-1| up to 250; either factorisation) and right-hand sides of every magnitude from 1 to 2^56
 * (b's signs and sizes mixed, powers of two among them: the scaling's
 * edges), including the many that need the int64 fallback (counted: the
 * test needs both outcomes).
 */
static void test_solves32_bits(void **state)
{
    uint64_t rng = 47;
    int taken[3] = {0, 0, 0};
    int refused[3] = {0, 0, 0};
    (void)state;
    for (int n = 0; n < 30000; ++n) {
        sp_jacobian_t m;
        sp_lu6_t lu;
        double xd[6];
        int64_t b[6], bt[6], x[6], want[6];
        int tr = n & 1;
        (void)random_system(&rng, n % 3, tr, &m, xd, b, bt);
        if (n % 5 == 4) { /* |A^-1| up to 250: the grow solve's refusals */
            double md[6][6];
            random_matrix(&rng, 0.005, n, &m, md);
        }
        assert_int_equal(sp_lu6_factor(&m, tr, &lu), SP_OK);
        if (n % 4 != 0) {                              /* a random b of random magnitude, not A xd */
            int bits = 1 + (int)(tu_next(&rng) % 56u); /* |b| below 2^56 */
            for (int i = 0; i < 6; ++i) {
                int bi = 1 + (int)(tu_next(&rng) % (uint64_t)bits);
                int64_t v = (int64_t)(tu_next(&rng) >> (64 - bi));
                if (tu_next(&rng) % 7u == 0u) {
                    v = (int64_t)1 << (bi - 1); /* a power of two */
                }
                b[i] = (tu_next(&rng) & 1u) ? -v : v;
            }
        }
        if (max_abs_i64(b) == 0) {
            continue;
        }
        for (int top = 24; top <= 28; top += 4) {
            int t = top == 28;
            if (ref_solve32(&lu, b, top, want)) {
                assert_int_equal(t ? sp_lu6_solve(&lu, b, x) : sp_lu6_solve_grow(&lu, b, x), SP_OK);
                assert_memory_equal(x, want, sizeof x);
                ++taken[t];
            } else {
                ++refused[t];
            }
        }
        for (int i = 0; i < 6; ++i) {
            x[i] = want[i] = 12345;
        }
        if (ref_solve_t32(&lu, b, want)) {
            assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 1);
            ++taken[2];
        } else {
            assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
            ++refused[2];
        }
        assert_memory_equal(x, want, sizeof x);
    }
    printf("32-bit solves: solve %d taken %d refused, grow %d / %d, t32 %d / %d\n", taken[1], refused[1], taken[0],
           refused[0], taken[2], refused[2]);
    for (int t = 0; t < 3; ++t) {
        assert_true(taken[t] > 1000 && refused[t] > 100);
    }
}

/* The fallbacks on systems built to need them: x_5 = 512 b_5 (x' = 512
 * max |b'| > 2^29: sp_lu6_solve's int64 solve, exact here; the 32-bit
 * transposed solve refuses, x untouched); growth in L (1 on the diagonal,
 * -1 below it: y_i = 2^i b for equal b, past 2^30 at b's 2^28: the int64
 * solve, within the reciprocals' 2^-28); b = 0 (x = 0; refused by the
 * 32-bit transposed solve) and |b| >= 2^56 (SP_E_OVERFLOW, x zeroed;
 * refused). */
static void test_solve_fallbacks(void **state)
{
    sp_jacobian_t m;
    sp_lu6_t lu;
    int64_t b[6] = {1000, -1000, 0, 0, 0, 1000000};
    int64_t x[6];
    (void)state;
    memset(&m, 0, sizeof m);
    for (int i = 0; i < 6; ++i) {
        m.j[i][i] = 1 << 28;
    }
    m.j[5][5] = 1 << 19; /* 2^-9 */
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
    assert_true(x[0] == 1000 && x[1] == -1000 && x[2] == 0 && x[5] == 512000000);
    for (int i = 0; i < 6; ++i) {
        x[i] = 7;
    }
    assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
    assert_true(x[0] == 7 && x[5] == 7);
    assert_int_equal(sp_lu6_solve_transposed(&lu, b, x), SP_OK);
    assert_true(x[5] == 512000000 && x[0] == 1000);
    assert_int_equal(sp_lu6_solve_grow(&lu, b, x), SP_OK); /* int64 here too: 512 > 16 */
    assert_true(x[0] == 1000 && x[1] == -1000 && x[2] == 0 && x[5] == 512000000);
    /* x_5 = 16 b_5: past sp_lu6_solve's 32-bit range, within the grow's */
    m.j[5][5] = 1 << 24;
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
    assert_int_equal(sp_lu6_solve_grow(&lu, b, x), SP_OK);
    assert_true(x[0] == 1000 && x[1] == -1000 && x[2] == 0 && x[5] == 16000000);
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
    assert_true(x[0] == 1000 && x[5] == 16000000);

    memset(&m, 0, sizeof m);
    for (int i = 0; i < 6; ++i) {
        m.j[i][i] = 1 << 28;
        for (int j = 0; j < i; ++j) {
            m.j[i][j] = -(1 << 28);
        }
        b[i] = (int64_t)1 << 40;
    }
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
    for (int i = 0; i < 6; ++i) {
        double want = ldexp(1.0, 40 + i);
        assert_near(x[i], want, 1e-8 * want, "L growth: x[%d]", i);
    }

    memset(b, 0, sizeof b);
    x[0] = 5;
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
    assert_true(x[0] == 0 && x[5] == 0);
    x[0] = 5;
    assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
    assert_true(x[0] == 5);
    b[3] = -((int64_t)1 << 56);
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_E_OVERFLOW);
    assert_true(x[0] == 0 && x[3] == 0);
    x[0] = 5;
    assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
    assert_true(x[0] == 5);
}

/* The errors: a singular matrix (two equal rows; all zero) gives
 * SP_E_SINGULAR and an invalid factorisation, which the solves refuse
 * (SP_E_ARG, x zeroed); |b| >= 2^56 gives SP_E_OVERFLOW with x zeroed;
 * NULL gives SP_E_ARG. */
static void test_solve_errors(void **state)
{
    uint64_t rng = 23;
    sp_jacobian_t m;
    sp_lu6_t lu;
    double md[6][6];
    int64_t b[6] = {1000, 1000, 1000, 1000, 1000, 1000};
    int64_t x[6];
    (void)state;
    random_matrix(&rng, 1.0, 0, &m, md);
    for (int j = 0; j < 6; ++j) {
        m.j[5][j] = m.j[4][j];
    }
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_E_SINGULAR);
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_E_SINGULAR);
    assert_int_equal(lu.valid, 0);
    assert_int_equal(sp_lu6_solve(&lu, b, x), SP_E_ARG);
    assert_int_equal(sp_lu6_solve_transposed(&lu, b, x), SP_E_ARG);
    assert_true(x[0] == 0 && x[5] == 0);
    memset(&m, 0, sizeof m);
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_E_SINGULAR);
    assert_int_equal(sp_solve6(NULL, 0, b, x), SP_E_ARG);
    assert_int_equal(sp_lu6_factor(NULL, 0, &lu), SP_E_ARG);
    {
        sp_lu6_stage_t part;
        memset(&part, 0, sizeof part);
        assert_int_equal(sp_lu6_factor_begin(NULL, 0, &part), SP_E_ARG);
        assert_int_equal(sp_lu6_factor_end(NULL, &lu), SP_E_ARG);
        assert_int_equal(sp_lu6_factor_end(&part, &lu), SP_E_ARG); /* not begun */
        assert_int_equal(lu.valid, 0);
    }
    assert_int_equal(sp_lu6_solve(NULL, b, x), SP_E_ARG);
    assert_int_equal(sp_lu6_solve_transposed(NULL, b, x), SP_E_ARG);

    for (int i = 0; i < 6; ++i) {
        m.j[i][i] = 1 << 28;
    }
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_OK);
    assert_true(x[0] == 1000 && x[5] == 1000);
    b[3] = -((int64_t)1 << 56);
    assert_int_equal(sp_solve6(&m, 0, b, x), SP_E_OVERFLOW);
    assert_true(x[0] == 0 && x[3] == 0 && x[5] == 0);
    assert_int_equal(sp_lu6_factor(&m, 1, &lu), SP_OK);
    b[3] = 1000;
    b[2] = (int64_t)1 << 56;
    x[0] = 5;
    assert_int_equal(sp_lu6_solve_transposed(&lu, b, x), SP_E_OVERFLOW);
    assert_true(x[0] == 0 && x[2] == 0);
}

/* A pivot row within the unchecked path's bound whose multiplier is just
 * above 1 (a_10 = -(a_00 + 1): the pivot search's tie, |l| = 2^30 (1 +
 * 1/a_00)): the eliminated a_11 = (2^30 - 1) + (2^30 - 2)(1 + 2^-18) is
 * beyond int32. Before the bound counted the multiplier's excess over 1
 * (lu_step), the unchecked path wrapped it (signed overflow, found by
 * Frama-C EVA, tests/static); now the checked path saturates it. */
static void test_factor_near_tie(void **state)
{
    sp_jacobian_t m;
    sp_lu6_t lu;
    sp_lu6_stage_t part;
    (void)state;
    memset(&m, 0, sizeof m);
    m.j[0][0] = 268436; /* SP_PIVOT_MIN + 1 */
    m.j[0][1] = (1 << 30) - 2;
    m.j[1][0] = -268437;
    m.j[1][1] = (1 << 30) - 1;
    for (int i = 2; i < 6; ++i) {
        m.j[i][i] = 1 << 28;
    }
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_E_OVERFLOW);
    assert_int_equal(lu.valid, 0);
    assert_int_equal(sp_lu6_factor_begin(&m, 0, &part), SP_E_OVERFLOW);
    assert_int_equal(part.begun, 0);
    /* 2^12 less in a_11 fits: factorised, a_11 as the exact rounding */
    m.j[1][1] = (1 << 30) - 1 - 8192;
    assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
    assert_true(lu.a[1][1] > 2147483647 - 8192 && lu.a[1][1] < 2147483647);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_factor_paths),  cmocka_unit_test(test_solves_reference),
        cmocka_unit_test(test_solves32_bits), cmocka_unit_test(test_solve_fallbacks),
        cmocka_unit_test(test_solve_errors),  cmocka_unit_test(test_factor_near_tie),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
