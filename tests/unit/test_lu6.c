/*
 * test_lu6.c - the 6x6 factorisation's and solves' fast paths against
 * their fallbacks and references:
 *  - sp_lu6_factor against a plain reference elimination (row swaps,
 *    saturating subtraction on every entry, the same rounding): the same
 *    bits for matrices that take the unchecked 4a path (entries below 2),
 *    the unchecked 64-bit path (pivot rows up to 3.9) and the checked path
 *    (entries near 8), and SP_E_OVERFLOW where an entry saturates;
 *  - sp_lu6_solve (32-bit path) against the exact solution, and its int64
 *    fallback where an intermediate leaves the 32-bit range;
 *  - the 32-bit transposed solve (spi_lu6_solve_t32) against the exact
 *    solution and sp_lu6_solve_transposed, and its refusal (the int64
 *    fallback) when an intermediate leaves its range.
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

#include "../../firmware/core/src/core_internal.h"
#include "sp/kinematics.h"
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

static void check_factor(const sp_jacobian_t *m, int transpose)
{
    sp_lu6_t lu;
    int32_t a[6][6];
    int perm[6];
    sp_status_t st = sp_lu6_factor(m, transpose, &lu);
    int ref = ref_factor(m, transpose, &lu, a, perm);
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
        assert_memory_equal(lu.a[lu.perm[k]], a[k], sizeof a[k]);
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

/* The 32-bit transposed solve: within the int64 solve's bound of the exact
 * solution on well-conditioned matrices (|x| up to 1e5 or small residuals),
 * and refused (the caller falls back) when an intermediate leaves 2^29. */
static void test_solve_t32(void **state)
{
    uint64_t rng = 37;
    sp_jacobian_t m;
    double md[6][6];
    sp_lu6_t lu;
    double worst = 0;
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double xd[6];
        int64_t b[6];
        int64_t x[6];
        int64_t x64[6];
        double mag = (n & 1) ? 1e5 : 1e-3; /* forces or FK steps */
        random_matrix(&rng, 1.0, n, &m, md);
        for (int i = 0; i < 6; ++i) {
            xd[i] = tu_uniform(&rng, -mag, mag);
        }
        for (int i = 0; i < 6; ++i) {
            double s = 0;
            for (int j = 0; j < 6; ++j) {
                s += md[j][i] * xd[j];
            }
            b[i] = llround(s * Q24);
        }
        assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
        assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 1);
        assert_int_equal(sp_lu6_solve_transposed(&lu, b, x64), SP_OK);
        for (int i = 0; i < 6; ++i) {
            /* 26 significant bits of max |b|, a few roundings */
            double e = fabs((double)x[i] / Q24 - xd[i]);
            double tol = 1e-7 * mag + 2e-7;
            worst = e / mag > worst ? e / mag : worst;
            if (e >= tol) {
                fail_msg("t32 n=%d x[%d]=%.9f want %.9f", n, i, (double)x[i] / Q24, xd[i]);
            }
            assert_true(fabs((double)(x[i] - x64[i]) / Q24) < tol);
        }
    }
    print_message("t32: worst error %.3g of max |x|\n", worst);
    /* growth: a small pivot makes y = 512 max |b| (> 2^29 at max |b| in
     * [2^26, 2^27)): refused, x untouched; the int64 solve is exact */
    {
        int64_t b[6] = {0, 0, 0, 0, 0, 1000000};
        int64_t x[6] = {7, 7, 7, 7, 7, 7};
        int64_t x64[6];
        memset(&m, 0, sizeof m);
        for (int i = 0; i < 6; ++i) {
            m.j[i][i] = 1 << 28;
        }
        m.j[5][5] = 1 << 19; /* 2^-9: x_5 = 512 b_5 */
        assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
        assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
        assert_true(x[0] == 7 && x[5] == 7);
        assert_int_equal(sp_lu6_solve_transposed(&lu, b, x64), SP_OK);
        assert_true(x64[5] == 512000000 && x64[0] == 0);
        /* b = 0 and |b| >= 2^56 are refused too */
        b[5] = 0;
        assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
        b[5] = (int64_t)1 << 56;
        assert_int_equal(spi_lu6_solve_t32(&lu, b, x), 0);
    }
}

/* sp_lu6_solve: the 32-bit path within 3e-8 of max |x| of the exact
 * solution (x ~ b / 2 here: |x| up to 1e5, and small x), and the int64
 * fallback (exact here) when x would pass 2^29 at b's scale. */
static void test_solve32(void **state)
{
    uint64_t rng = 41;
    sp_jacobian_t m;
    double md[6][6];
    sp_lu6_t lu;
    double worst = 0;
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double xd[6];
        int64_t b[6];
        int64_t x[6];
        double mag = (n & 1) ? 1e5 : 1.0;
        random_matrix(&rng, 1.0, n, &m, md);
        for (int i = 0; i < 6; ++i) {
            xd[i] = tu_uniform(&rng, -mag, mag);
        }
        for (int i = 0; i < 6; ++i) {
            double s = 0;
            for (int j = 0; j < 6; ++j) {
                s += md[i][j] * xd[j];
            }
            b[i] = llround(s * Q24);
        }
        assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
        for (int i = 0; i < 6; ++i) {
            double e = fabs((double)x[i] / Q24 - xd[i]);
            worst = e / mag > worst ? e / mag : worst;
            if (e >= 3e-8 * mag + 1e-7) {
                fail_msg("solve32 n=%d x[%d]=%.9f want %.9f", n, i, (double)x[i] / Q24, xd[i]);
            }
        }
    }
    print_message("solve: worst error %.3g of max |x|\n", worst);
    {
        /* x_5 = 512 b_5: x' = 512 max |b'| > 2^29, the int64 solve */
        int64_t b[6] = {1000, -1000, 0, 0, 0, 1000000};
        int64_t x[6];
        memset(&m, 0, sizeof m);
        for (int i = 0; i < 6; ++i) {
            m.j[i][i] = 1 << 28;
        }
        m.j[5][5] = 1 << 19;
        assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
        assert_true(x[0] == 1000 && x[1] == -1000 && x[2] == 0 && x[5] == 512000000);
        /* growth in L: 1 on the diagonal, -1 below it: y_i = b_i + the
         * y above, 2^i b for equal b: past 2^30 at b's 2^28 */
        memset(&m, 0, sizeof m);
        for (int i = 0; i < 6; ++i) {
            m.j[i][i] = 1 << 28;
            for (int j = 0; j < i; ++j) {
                m.j[i][j] = -(1 << 28);
            }
        }
        for (int i = 0; i < 6; ++i) {
            b[i] = (int64_t)1 << 40;
        }
        assert_int_equal(sp_lu6_factor(&m, 0, &lu), SP_OK);
        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
        for (int i = 0; i < 6; ++i) {
            /* the int64 solve: within 1e-8 (the reciprocals' 2^-28) */
            double want = ldexp(1.0, 40 + i);
            assert_true(fabs((double)x[i] - want) < 1e-8 * want);
        }
        /* b = 0: x = 0; |b| >= 2^56: SP_E_OVERFLOW, x zeroed */
        memset(b, 0, sizeof b);
        x[0] = 5;
        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_OK);
        assert_true(x[0] == 0 && x[5] == 0);
        b[3] = -((int64_t)1 << 56);
        x[0] = 5;
        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_E_OVERFLOW);
        assert_true(x[0] == 0 && x[3] == 0);
        lu.valid = 0;
        b[3] = 1;
        assert_int_equal(sp_lu6_solve(&lu, b, x), SP_E_ARG);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_factor_paths),
        cmocka_unit_test(test_solve32),
        cmocka_unit_test(test_solve_t32),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
