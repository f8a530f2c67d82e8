/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Unit tests of sp/math/fixed.h against long double references (64-bit mantissa:
 * exact for every 62-bit product), over random inputs spread across the
 * whole int32 range plus the edge values: zero, +-1, the extremes and the
 * points where saturation starts.
 *
 * Allowed errors, in LSB of the result (the reference is the exact real
 * result of the fixed-point inputs):
 *   add, sub, neg, abs, rshift_round, isqrt64   exact (0 LSB after rounding)
 *   mul, div, sqrt_q24, dot3                      0.5 LSB
 *   mul64, div64                                  exact rounding (vs 128-bit integers)
 *   sincos_q24                                    2 LSB of Q30 (1.9e-9)
 * Saturation: a flag is set exactly when the exact result leaves int32.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "math/fixed_inline.h"
#include "assert_near.h"
#include "sp/math/fixed.h"
#include "test_util.h"

#define N_RANDOM 200000
#define TOL_HALF_LSB (0.5L + 1e-9L)
#define TOL_SINCOS_LSB 2.0L

static const int32_t edges[] = {
    0,          1,           -1,         2,           -2,        255,       -256,          0x7FFF,        -0x8000,
    SP_Q24_ONE, -SP_Q24_ONE, SP_Q30_ONE, -SP_Q30_ONE, INT32_MAX, INT32_MIN, INT32_MAX - 1, INT32_MIN + 1, 0x40000001,
    -0x40000001};
#define N_EDGES (sizeof edges / sizeof edges[0])

/* Reference narrowing: clamps and tells whether it clamped. */
static long double clamp32(long double v, int *clamped)
{
    *clamped = 0;
    if (v > (long double)INT32_MAX) {
        *clamped = 1;
        return (long double)INT32_MAX;
    }
    if (v < (long double)INT32_MIN) {
        *clamped = 1;
        return (long double)INT32_MIN;
    }
    return v;
}

/* Nearest, ties away from zero: the rounding the library promises. */
static long double round_away(long double v)
{
    return (v < 0) ? -floorl(-v + 0.5L) : floorl(v + 0.5L);
}

static void check_exact_saturating(long double exact, int32_t got, sp_flags_t flags, const char *what, int32_t a,
                                   int32_t b)
{
    int clamped;
    long double want = clamp32(round_away(exact), &clamped);
    if ((long double)got != want || ((flags & SP_FLAG_OVERFLOW) != 0u) != (clamped != 0)) {
        fail_msg("%s(%ld, %ld): got %ld flags %u, want %.1Lf clamped %d", what, (long)a, (long)b, (long)got,
                 (unsigned)flags, want, clamped);
    }
}

static void test_add_sub_neg_abs(void **state)
{
    uint64_t rng = 1;
    (void)state;
    for (int i = 0; i < N_RANDOM + (int)(N_EDGES * N_EDGES); ++i) {
        int32_t a;
        int32_t b;
        sp_flags_t f;
        if (i < (int)(N_EDGES * N_EDGES)) {
            a = edges[(size_t)i % N_EDGES];
            b = edges[(size_t)i / N_EDGES];
        } else {
            a = (i & 1) ? tu_i32(&rng) : tu_i32_logscale(&rng);
            b = (i & 2) ? tu_i32(&rng) : tu_i32_logscale(&rng);
        }
        int32_t got;
        f = 0u;
        got = sp_add(a, b, &f);
        check_exact_saturating((long double)a + b, got, f, "add", a, b);
        f = 0u;
        got = sp_sub(a, b, &f);
        check_exact_saturating((long double)a - b, got, f, "sub", a, b);
        f = 0u;
        got = sp_neg(a, &f);
        check_exact_saturating(-(long double)a, got, f, "neg", a, 0);
        f = 0u;
        got = sp_abs(a, &f);
        check_exact_saturating(fabsl((long double)a), got, f, "abs", a, 0);
    }
}

static void test_rshift_round(void **state)
{
    uint64_t rng = 2;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int64_t v = (int64_t)tu_next(&rng);
        unsigned s = (unsigned)(tu_next(&rng) % 63u);
        long double want;
        if (i == 0) {
            v = INT64_MIN;
        } else if (i == 1) {
            v = INT64_MAX;
        } else if (i < 64) {
            v = ((i & 1) ? 3 : -3) * (INT64_C(1) << (s > 0 ? s - 1 : 0)); /* ties */
        }
        want = round_away(TU_LDEXP(v, -(int)s));
        assert_true((long double)sp_rshift_round(v, s) == want);
    }
    /* Ties go away from zero. */
    assert_int_equal(sp_rshift_round(3, 1), 2);
    assert_int_equal(sp_rshift_round(-3, 1), -2);
    assert_int_equal(sp_rshift_round(1, 1), 1);
    assert_int_equal(sp_rshift_round(-1, 1), -1);
    assert_int_equal(sp_rshift_round(-5, 2), -1);
}

static void test_mul(void **state)
{
    static const unsigned shifts[] = {0u, 8u, 16u, 24u, 30u, 31u, 40u, 62u};
    uint64_t rng = 3;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int32_t a = (i & 1) ? tu_i32(&rng) : tu_i32_logscale(&rng);
        int32_t b = (i & 2) ? tu_i32(&rng) : tu_i32_logscale(&rng);
        unsigned s = shifts[tu_next(&rng) % 8u];
        sp_flags_t f = 0u;
        int32_t got;
        int clamped;
        long double exact;
        if (i < (int)(N_EDGES * N_EDGES)) {
            a = edges[(size_t)i % N_EDGES];
            b = edges[(size_t)i / N_EDGES];
        }
        got = sp_mul(a, b, s, &f);
        exact = TU_LDEXP((long double)a * b, -(int)s);
        (void)clamp32(exact, &clamped);
        if (clamped) {
            assert_true((f & SP_FLAG_OVERFLOW) != 0u);
            assert_int_equal(got, exact > 0 ? INT32_MAX : INT32_MIN);
        } else {
            assert_near(got, exact, TOL_HALF_LSB, "mul(%ld, %ld, %u)", (long)a, (long)b, s);
        }
    }
    /* The Q wrappers keep their formats. */
    assert_int_equal(sp_mul_q30(SP_Q30_ONE, SP_Q30_ONE / 2, NULL), SP_Q30_ONE / 2);
    assert_int_equal(sp_mul_q24(3 * SP_Q24_ONE, -2 * SP_Q24_ONE, NULL), -6 * SP_Q24_ONE);
}

static void test_div(void **state)
{
    static const unsigned shifts[] = {0u, 8u, 16u, 24u, 30u, 31u, 40u};
    uint64_t rng = 4;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int64_t num = (int64_t)((i & 1) ? tu_i32(&rng) : tu_i32_logscale(&rng));
        int32_t den = (i & 2) ? tu_i32(&rng) : tu_i32_logscale(&rng);
        unsigned s = shifts[tu_next(&rng) % 7u];
        sp_flags_t f = 0u;
        int32_t got;
        long double exact;
        int clamped;
        if ((i % 5) == 0) {
            /* wide numerators, up to the largest that the shift allows */
            num = (int64_t)(tu_next(&rng) >> (1u + s + (unsigned)(tu_next(&rng) % (63u - s))));
        }
        if (den == 0) {
            got = sp_div(num, den, s, &f);
            assert_int_equal(got, 0);
            assert_true((f & SP_FLAG_DOMAIN) != 0u);
            continue;
        }
        got = sp_div(num, den, s, &f);
        exact = TU_LDEXP((long double)num, (int)s) / (long double)den;
        (void)clamp32(exact, &clamped);
        if (clamped) {
            assert_true((f & SP_FLAG_OVERFLOW) != 0u);
            assert_int_equal(got, exact > 0 ? INT32_MAX : INT32_MIN);
        } else {
            assert_true(f == 0u);
            assert_near(got, exact, TOL_HALF_LSB, "div(%lld, %ld, %u)", (long long)num, (long)den, s);
        }
    }
    /* Extremes: a 64-bit numerator far too large saturates, it never wraps. */
    {
        sp_flags_t f = 0u;
        assert_int_equal(sp_div(INT64_MAX, 1, 24u, &f), INT32_MAX);
        assert_true(f == SP_FLAG_OVERFLOW);
        f = 0u;
        assert_int_equal(sp_div(INT64_MIN, 1, 0u, &f), INT32_MIN);
        assert_true(f == SP_FLAG_OVERFLOW);
        f = 0u;
        assert_int_equal(sp_div(INT32_MIN, -1, 0u, &f), INT32_MAX);
        assert_true(f == SP_FLAG_OVERFLOW);
        f = 0u;
        assert_int_equal(sp_div_q24(SP_Q24_ONE, 3 * SP_Q24_ONE, &f), 5592405); /* 1/3 */
        assert_true(f == 0u);
    }
}

static void test_isqrt64(void **state)
{
    uint64_t rng = 5;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        uint64_t v = tu_next(&rng) >> (tu_next(&rng) % 64u);
        uint32_t r;
        if (i == 0) {
            v = 0u;
        } else if (i == 1) {
            v = UINT64_MAX;
        } else if (i < 1000) {
            uint64_t k = (uint64_t)i;
            v = k * k + (uint64_t)(i % 3) - 1u; /* around perfect squares */
        }
        r = sp_isqrt64(v);
        if (v >= UINT64_C(0xFFFFFFFF00000000)) {
            assert_int_equal(r, UINT32_MAX); /* sqrt rounds up to 2^32: saturated */
            continue;
        }
        /* Exact check in integers: (r - 1/2)^2 <= v <= (r + 1/2)^2, i.e.
         * r^2 - r < v + 1 and v <= r^2 + r (v, r integers). */
        {
            uint64_t rr = (uint64_t)r * r;
            assert_true(v <= rr + r);
            assert_true(r == 0u || rr - r <= v);
        }
    }
    /* The ends of every seed interval (top word t = k 2^24 and
     * (k + 1) 2^24 - 1, k = 64..255) with the low word 0 and all ones, at
     * every even normalising shift: the Newton step from each seed and the
     * 16-bit extension at their extremes, and exact squares around them. */
    for (uint64_t k = 64u; k < 256u; ++k) {
        uint64_t ends[4];
        ends[0] = (k << 56);
        ends[1] = (k << 56) | UINT64_C(0xFFFFFFFF);
        ends[2] = (((k + 1u) << 56) - 1u) & UINT64_C(0xFFFFFFFF00000000);
        ends[3] = ((k + 1u) << 56) - 1u;
        for (int e = 0; e < 4; ++e) {
            for (unsigned sh = 0u; sh < 64u; sh += 2u) {
                uint64_t v = ends[e] >> sh;
                uint32_t r = sp_isqrt64(v);
                uint64_t rr = (uint64_t)r * r;
                if (v >= UINT64_C(0xFFFFFFFF00000000)) {
                    assert_int_equal(r, UINT32_MAX);
                    continue;
                }
                assert_true(v <= rr + r);
                assert_true(r == 0u || rr - r <= v);
            }
        }
        {
            uint64_t s = (uint64_t)sp_isqrt64(k << 56); /* a root near the interval start */
            for (uint64_t d = s - 2u; d <= s + 2u && d < UINT64_C(0x100000000); ++d) {
                assert_int_equal(sp_isqrt64(d * d), (uint32_t)d);
                assert_int_equal(sp_isqrt64(d * d + d), (uint32_t)d);             /* below d + 1/2 */
                assert_int_equal(sp_isqrt64(d * d + d + 1u), (uint32_t)(d + 1u)); /* above */
            }
        }
    }
}

static void test_sqrt_q24(void **state)
{
    uint64_t rng = 6;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int32_t a = (i & 1) ? tu_i32(&rng) : tu_i32_logscale(&rng);
        sp_flags_t f = 0u;
        int32_t got = sp_sqrt_q24(a, &f);
        if (a < 0) {
            assert_int_equal(got, 0);
            assert_true(f == SP_FLAG_DOMAIN);
            continue;
        }
        assert_true(f == 0u);
        assert_near(got, sqrtl(TU_LDEXP(a, 24)), TOL_HALF_LSB, "sqrt_q24(%ld)", (long)a);
    }
}

static void test_sincos(void **state)
{
    uint64_t rng = 7;
    long double worst = 0;
    (void)state;
    for (int i = 0; i < N_RANDOM + (int)N_EDGES + 8; ++i) {
        int32_t a;
        sp_q30_t s;
        sp_q30_t c;
        long double x;
        long double es;
        long double ec;
        if (i < (int)N_EDGES) {
            a = edges[i];
        } else if (i < (int)N_EDGES + 8) {
            a = (i - (int)N_EDGES - 4) * SP_Q24_HALF_PI; /* multiples of pi/2 */
        } else if ((i & 3) == 0) {
            a = tu_i32(&rng); /* the whole range, +-128 rad */
        } else {
            a = (int32_t)tu_uniform(&rng, -7.0 * SP_Q24_ONE, 7.0 * SP_Q24_ONE);
        }
        sp_sincos_q24(a, &s, &c);
        x = TU_LDEXP(a, -24);
        es = fabsl((long double)s - TU_LDEXP(sinl(x), 30));
        ec = fabsl((long double)c - TU_LDEXP(cosl(x), 30));
        worst = (es > worst) ? es : worst;
        worst = (ec > worst) ? ec : worst;
        assert_near(s, TU_LDEXP(sinl(x), 30), TOL_SINCOS_LSB, "sin of %ld (LSB)", (long)a);
        assert_near(c, TU_LDEXP(cosl(x), 30), TOL_SINCOS_LSB, "cos of %ld (LSB)", (long)a);
    }
    /* Around every odd multiple of pi/4 in the Q24 range, where the
     * quadrant's rounding may go either way, and the range ends: the
     * reduction's 32-bit arithmetic modulo 2^32 at |n| up to 82. */
    for (int k = -163; k <= 163; k += 2) {
        long double m = (long double)k * 0.785398163397448309615660845819875721L * 16777216.0L;
        for (int d = -3; d <= 3; ++d) {
            long double al = roundl(m) + d;
            int32_t a;
            sp_q30_t s;
            sp_q30_t c;
            long double es;
            long double ec;
            if (al > (long double)INT32_MAX || al < (long double)INT32_MIN) {
                continue;
            }
            a = (int32_t)al;
            sp_sincos_q24(a, &s, &c);
            es = fabsl((long double)s - TU_LDEXP(sinl(TU_LDEXP(a, -24)), 30));
            ec = fabsl((long double)c - TU_LDEXP(cosl(TU_LDEXP(a, -24)), 30));
            worst = (es > worst) ? es : worst;
            worst = (ec > worst) ? ec : worst;
            assert_near(s, TU_LDEXP(sinl(TU_LDEXP(a, -24)), 30), TOL_SINCOS_LSB, "sin of %ld (LSB)", (long)a);
            assert_near(c, TU_LDEXP(cosl(TU_LDEXP(a, -24)), 30), TOL_SINCOS_LSB, "cos of %ld (LSB)", (long)a);
        }
    }
    /* Either output may be omitted. */
    sp_sincos_q24(SP_Q24_ONE, NULL, NULL);
    print_message("sincos worst error %.2Lf LSB Q30\n", worst);
}

static void test_dot3(void **state)
{
    uint64_t rng = 8;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int32_t a[3];
        int32_t b[3];
        unsigned s = (unsigned)(tu_next(&rng) % 63u);
        long double exact = 0;
        sp_flags_t f = 0u;
        int32_t got;
        int clamped;
        for (int k = 0; k < 3; ++k) {
            a[k] = (i < 16) ? ((i & 1) ? INT32_MIN : INT32_MAX) : tu_i32(&rng);
            b[k] = (i < 16) ? ((i & 2) ? INT32_MIN : INT32_MAX) : tu_i32_logscale(&rng);
            exact += (long double)a[k] * b[k];
        }
        exact = TU_LDEXP(exact, -(int)s);
        got = sp_dot3(a, b, s, &f);
        (void)clamp32(exact, &clamped);
        if (clamped) {
            assert_true((f & SP_FLAG_OVERFLOW) != 0u);
            assert_int_equal(got, exact > 0 ? INT32_MAX : INT32_MIN);
        } else {
            assert_near(got, exact, TOL_HALF_LSB, "dot3 shift %u", s);
        }
    }
}

static void test_flags_status(void **state)
{
    (void)state;
    assert_int_equal(sp_flags_status(0u), SP_OK);
    assert_int_equal(sp_flags_status(SP_FLAG_OVERFLOW), SP_E_OVERFLOW);
    assert_int_equal(sp_flags_status(SP_FLAG_DOMAIN | SP_FLAG_OVERFLOW), SP_E_DOMAIN);
    assert_string_equal(sp_status_name(SP_E_SINGULAR), "singular");
    assert_string_equal(sp_status_name((sp_status_t)99), "unknown");
    /* A NULL flag word is allowed. */
    assert_int_equal(sp_add(INT32_MAX, 1, NULL), INT32_MAX);
}

/* Exact 128-bit references for the 64-bit helpers (GCC/Clang on 64-bit hosts). */
__extension__ typedef __int128 i128;

static i128 ref_round_shift(i128 v, unsigned s)
{
    i128 mag = v < 0 ? -v : v;
    i128 q = (s == 0u) ? mag : ((mag + ((i128)1 << (s - 1u))) >> s);
    return v < 0 ? -q : q;
}

static int64_t ref_sat64(i128 v, int *clamped)
{
    *clamped = (v > (i128)INT64_MAX || v < (i128)INT64_MIN);
    if (v > (i128)INT64_MAX) {
        return INT64_MAX;
    }
    if (v < (i128)INT64_MIN) {
        return INT64_MIN;
    }
    return (int64_t)v;
}

static int64_t rand_i64_logscale(uint64_t *rng)
{
    uint64_t r = tu_next(rng);
    unsigned bits = (unsigned)(tu_next(rng) % 64u);
    int64_t v = (int64_t)(r >> (64u - (bits == 0u ? 1u : bits)) >> 1);
    return (tu_next(rng) & 1u) ? -v : v;
}

static void test_mul64(void **state)
{
    uint64_t rng = 9;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int64_t x = (i < 4) ? ((i & 1) ? INT64_MIN : INT64_MAX) : rand_i64_logscale(&rng);
        int32_t k = (i < 4) ? ((i & 2) ? INT32_MIN : INT32_MAX) : tu_i32_logscale(&rng);
        unsigned s = (unsigned)(tu_next(&rng) % 63u);
        sp_flags_t f = 0u;
        int clamped;
        int64_t got = sp_mul64(x, k, s, &f);
        int64_t want = ref_sat64(ref_round_shift((i128)x * k, s), &clamped);
        if (got != want || ((f & SP_FLAG_OVERFLOW) != 0u) != (clamped != 0)) {
            fail_msg("mul64(%lld, %ld, %u) = %lld, want %lld (clamped %d)", (long long)x, (long)k, s, (long long)got,
                     (long long)want, clamped);
        }
    }
}

static void test_div64(void **state)
{
    uint64_t rng = 10;
    (void)state;
    for (int i = 0; i < N_RANDOM; ++i) {
        int64_t n = (i < 4) ? ((i & 1) ? INT64_MIN : INT64_MAX) : rand_i64_logscale(&rng);
        int32_t d = (i < 4) ? ((i & 2) ? -1 : 1) : tu_i32_logscale(&rng);
        unsigned s = (unsigned)(tu_next(&rng) % 63u);
        sp_flags_t f = 0u;
        int64_t got = sp_div64(n, d, s, &f);
        i128 num;
        i128 mag;
        i128 dm;
        i128 q;
        int clamped;
        int64_t want;
        if (d == 0) {
            assert_true(got == 0 && f == SP_FLAG_DOMAIN);
            continue;
        }
        num = (i128)n * ((i128)1 << s);
        mag = num < 0 ? -num : num;
        dm = d < 0 ? -(i128)d : (i128)d;
        q = (mag + dm / 2) / dm; /* ties away from zero (d odd: no tie) */
        if ((dm % 2) == 0 && (mag % dm) * 2 == dm) {
            q = mag / dm + 1;
        }
        if ((n < 0) != (d < 0)) {
            q = -q;
        }
        want = ref_sat64(q, &clamped);
        if (got != want || ((f & SP_FLAG_OVERFLOW) != 0u) != (clamped != 0)) {
            fail_msg("div64(%lld, %ld, %u) = %lld, want %lld (clamped %d)", (long long)n, (long)d, s, (long long)got,
                     (long long)want, clamped);
        }
    }
}

static void test_add64_narrow(void **state)
{
    sp_flags_t f = 0u;
    (void)state;
    assert_true(sp_add64(INT64_MAX, 1, &f) == INT64_MAX && f == SP_FLAG_OVERFLOW);
    f = 0u;
    assert_true(sp_add64(INT64_MIN, -1, &f) == INT64_MIN && f == SP_FLAG_OVERFLOW);
    f = 0u;
    assert_true(sp_add64(-5, 7, &f) == 2 && f == 0u);
    assert_true(sp_narrow(INT64_C(3) << 40, 8u, &f) == INT32_MAX && f == SP_FLAG_OVERFLOW);
    f = 0u;
    assert_true(sp_narrow(-(INT64_C(5) << 7), 8u, &f) == -3 && f == 0u); /* -2.5 -> -3 */
}

/* The 32-bit low-pass section against the 64-bit one, on its whole input
 * range [-2^30, 2^30 - 1]: random values, the extremes, and every alpha
 * edge. */
static void test_lowpass_section30(void **state)
{
    (void)state;
    uint64_t rng = 0x5ec7104u;
    const int32_t lo = -SPI_SECTION_HI - 1, hi = SPI_SECTION_HI;
    const int32_t ends[6] = {lo, lo + 1, -1, 0, hi - 1, hi};
    const sp_q30_t alphas[4] = {0, 1, SP_Q30_ONE / 2, SP_Q30_ONE};
    for (int i = 0; i < 200000; ++i) {
        int32_t y = (i < 144) ? ends[i % 6] : (int32_t)(tu_i32(&rng) >> 1);
        int32_t x = (i < 144) ? ends[(i / 6) % 6] : (int32_t)(tu_i32(&rng) >> 1);
        sp_q30_t a = (i < 144) ? alphas[(i / 36) % 4] : (sp_q30_t)(tu_next(&rng) % ((uint64_t)SP_Q30_ONE + 1u));
        int32_t want = spi_lowpass_section(y, x, a);
        int32_t got = spi_lowpass_section30(y, x, a);
        if (got != want) {
            fail_msg("y %d x %d alpha %d: %d, the 64-bit section %d", y, x, a, got, want);
        }
        assert_true(got >= lo && got <= hi);
    }
}

/* sp_recip_div against the plain 64-bit division it replaces, bit for bit:
 * divisors from 1 to 2^62 (log-spread: those below about 2^23 take the
 * division path), numerators over [0, 2^31) and the edges, n at 2^31 and
 * above clamped; bad divisors refused. */
static void test_recip_div(void **state)
{
    static const int64_t edge_d[] = {1,
                                     3,
                                     (INT64_C(1) << 23) - 1,
                                     INT64_C(1) << 23,
                                     (INT64_C(1) << 23) + 1,
                                     6 * 9395240,
                                     INT64_C(1) << 40,
                                     (INT64_C(1) << 62) - 1};
    static const uint32_t edge_n[] = {0u, 1u, 6u, 0x7FFFFFFFu, 0x7FFFFFFEu, 0x80000000u, UINT32_MAX};
    uint64_t rng = 12;
    sp_recip_t rec;
    unsigned fast = 0u;
    (void)state;
    assert_int_equal(sp_recip_prepare(0, &rec), SP_E_ARG);
    assert_int_equal(sp_recip_div(5u, &rec), (int64_t)5 << 24); /* refused: divides by 1 */
    assert_int_equal(sp_recip_prepare(-5, &rec), SP_E_ARG);
    assert_int_equal(sp_recip_prepare(INT64_C(1) << 62, &rec), SP_E_ARG);
    assert_int_equal(sp_recip_prepare(7, NULL), SP_E_ARG);
    for (int i = 0; i < N_RANDOM; ++i) {
        int e = i % (int)(sizeof edge_d / sizeof edge_d[0]);
        int64_t d = (i < 64) ? edge_d[e] : (int64_t)(tu_next(&rng) >> (2u + (unsigned)(tu_next(&rng) % 62u)));
        uint32_t n = (i < 64) ? edge_n[i % (int)(sizeof edge_n / sizeof edge_n[0])]
                              : (uint32_t)(tu_next(&rng) >> (33u + (unsigned)(tu_next(&rng) % 31u)));
        uint64_t nn = (n < 0x80000000u) ? n : 0x7FFFFFFFu;
        if (d <= 0) {
            d = 1;
        }
        assert_int_equal(sp_recip_prepare(d, &rec), SP_OK);
        fast += (rec.r != 0u) ? 1u : 0u;
        int64_t want = (int64_t)((nn << 24) / (uint64_t)d);
        int64_t got = sp_recip_div(n, &rec);
        if (got != want) {
            fail_msg("recip_div(%lu, %lld) = %lld, want %lld (r %lu, shift %u)", (unsigned long)n, (long long)d,
                     (long long)got, (long long)want, (unsigned long)rec.r, (unsigned)rec.shift);
        }
    }
    assert_true(fast > (unsigned)N_RANDOM / 2u); /* most divisors above 2^23: the multiply path is what is tested */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_add_sub_neg_abs),
        cmocka_unit_test(test_lowpass_section30),
        cmocka_unit_test(test_rshift_round),
        cmocka_unit_test(test_mul),
        cmocka_unit_test(test_div),
        cmocka_unit_test(test_isqrt64),
        cmocka_unit_test(test_sqrt_q24),
        cmocka_unit_test(test_sincos),
        cmocka_unit_test(test_dot3),
        cmocka_unit_test(test_flags_status),
        cmocka_unit_test(test_mul64),
        cmocka_unit_test(test_div64),
        cmocka_unit_test(test_add64_narrow),
        cmocka_unit_test(test_recip_div),
    };
    return cmocka_run_group_tests_name("fixed", tests, NULL, NULL);
}
