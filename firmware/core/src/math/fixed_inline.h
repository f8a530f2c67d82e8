/* SPDX-License-Identifier: Apache-2.0 */
/*
 * fixed_inline.h - private inline helpers of the fixed-point core (not part
 * of the public API; included by the core's own .c files only).
 *
 * They are the cheap building blocks on a Cortex-M4: a 32x32->64 multiply
 * (SMULL/UMULL), shifts, CLZ and the 32/32 hardware divide (UDIV). None of
 * them calls a 64-bit library division. Each states its input range; the
 * callers guarantee it.
 *
 * Rounding: each narrowing helper's name says its tie rule.
 *   *_away   round to nearest, ties away from zero: the public API's rule
 *            (sp/math/fixed.h), symmetric about zero;
 *   *_up     round to nearest, ties toward +infinity: one addition and a
 *            shift, used inside the kinematics, the LU solver and the
 *            dynamics, where an exact tie is rare and its direction does
 *            not bias a result (the tests bound those results against
 *            float64 references);
 *   *_floor  toward -infinity (a caller adds 2^(s-1) first for ties up).
 * Helpers that narrow to int32 saturate and flag; the others state the
 * input range their callers guarantee.
 *
 * Right shifts of negative int64 values: C99 leaves them
 * implementation-defined. GCC and Clang (the only compilers of this core,
 * host and arm-none-eabi) define them as arithmetic shifts, and the typedef
 * below makes the build fail on a compiler that does otherwise.
 */
#ifndef SP_FIXED_INLINE_H
#define SP_FIXED_INLINE_H

#include "sp/math/fixed.h"

/* Always inlined, also at -Os (where GCC would otherwise keep small
 * helpers out of line and pay a call for a two-instruction body). */
#if defined(__GNUC__)
#define SPI_INLINE static inline __attribute__((always_inline))
#else
#define SPI_INLINE static inline
#endif

/* Never inlined: a job whose locals must not join its caller's frame on the
 * tick's deepest call chain (the STM32 stack budget), or a loop GCC spills
 * around when inlined. */
#if defined(__GNUC__)
#define SPI_NOINLINE __attribute__((noinline))
#else
#define SPI_NOINLINE
#endif

/* 2 pi in Q24 (105414357.4 rounded). */
#define SPI_Q24_TWO_PI INT32_C(105414357)

typedef char spi_asr_is_arithmetic[((INT64_C(-5) >> 1) == INT64_C(-3)) ? 1 : -1];

/* One first-order low-pass section (backward Euler, as the wrench filter's):
 * y + round(alpha (x - y)), ties up, for alpha in [0, 2^30] (Q30). The
 * difference is taken in 64 bits, so any int32 y and x are fine, and the
 * result lies between y and x: it cannot overflow. */
SPI_INLINE int32_t spi_lowpass_section(int32_t y, int32_t x, sp_q30_t alpha)
{
    return (int32_t)(y + (((int64_t)alpha * ((int64_t)x - y) + (INT64_C(1) << 29)) >> 30));
}

/* The same section for y and x within [-2^30, 2^30 - 1] (SPI_SECTION_HI):
 * x - y then fits an int32 and the step is one 32 x 32-bit product; the
 * result, between y and x, stays in that range. Equal to
 * spi_lowpass_section there (test_fixed). */
#define SPI_SECTION_HI INT32_C(0x3FFFFFFF)
SPI_INLINE int32_t spi_lowpass_section30(int32_t y, int32_t x, sp_q30_t alpha)
{
    return y + (int32_t)(((int64_t)alpha * (x - y) + (INT64_C(1) << 29)) >> 30);
}

/* Number of leading zero bits of a non-zero 32-bit value (CLZ). */
SPI_INLINE unsigned spi_clz32(uint32_t v)
{
#if defined(__GNUC__)
    return (unsigned)__builtin_clz(v);
#else
    unsigned n = 0u;
    while ((v & 0x80000000u) == 0u) { /* at most 31 steps (v != 0) */
        v <<= 1;
        ++n;
    }
    return n;
#endif
}

/* Leading zeros of a non-zero 64-bit value. */
SPI_INLINE unsigned spi_clz64(uint64_t v)
{
    uint32_t hi = (uint32_t)(v >> 32);
    return (hi != 0u) ? spi_clz32(hi) : 32u + spi_clz32((uint32_t)v);
}

/* round(v / 2^s), ties away from zero, for 1 <= s <= 62 and
 * v < 2^63 - 2^(s-1) (every product of two int32 qualifies). WP proves the
 * contract one shift at a time (tests/static/proofs.py wp-round). */
/*@ requires 1 <= s <= 62;
  @ requires v <= INT64_MAX - (1 << (s - 1));
  @ assigns \nothing;
  @ ensures \result == SP_ROUND(v, 1 << s);
  @*/
SPI_INLINE int64_t spi_round_away(int64_t v, unsigned s)
{
    return (v + ((INT64_C(1) << (s - 1u)) - (v < 0 ? 1 : 0))) >> s;
}

/* Narrow to int32, saturating and flagging (flags must not be NULL). */
SPI_INLINE int32_t spi_sat(int64_t v, sp_flags_t *flags)
{
    /* v in [-2^31, 2^31) exactly when v + 2^31 (modulo 2^64) is below 2^32 */
    if ((uint64_t)v + UINT64_C(0x80000000) > UINT64_C(0xFFFFFFFF)) {
        *flags |= SP_FLAG_OVERFLOW;
        return (v > 0) ? INT32_MAX : INT32_MIN;
    }
    return (int32_t)v;
}

/* round(v / 2^s) with ties rounded up, for 1 <= s <= 62 and
 * v < 2^63 - 2^(s-1): cheaper than spi_round_away where the direction of exact
 * ties does not matter (inside the linear solve). */
SPI_INLINE int64_t spi_round_up(int64_t v, unsigned s)
{
    return (v + (INT64_C(1) << (s - 1u))) >> s;
}

/* sp_rshift_round for any int64 v and 1 <= s <= 62: inline unless v is
 * within 2^62 of INT64_MAX (then the exact library path). */
SPI_INLINE int64_t spi_round_away64(int64_t v, unsigned s)
{
    return (v > INT64_C(0x3FFFFFFFFFFFFFFF)) ? sp_rshift_round(v, s) : spi_round_away(v, s);
}

/* sp_narrow for any int64 v and 1 <= s <= 62: round(v / 2^s) saturated. */
SPI_INLINE int32_t spi_narrow_away(int64_t v, unsigned s, sp_flags_t *flags)
{
    return spi_sat(spi_round_away64(v, s), flags);
}

/* round(a * b / 2^s), saturated (1 <= s <= 62). */
SPI_INLINE int32_t spi_mul_away(int32_t a, int32_t b, unsigned s, sp_flags_t *flags)
{
    return spi_sat(spi_round_away((int64_t)a * b, s), flags);
}

/* round(a * b / 2^30) for |a|, |b| <= 2^30 + small (sines, cosines, rotation
 * entries and their products): the result cannot leave int32. */
SPI_INLINE int32_t spi_mul30_away(int32_t a, int32_t b)
{
    return (int32_t)spi_round_away((int64_t)a * b, 30u);
}

/* round(a b / 2^30) and round((a b + c d) / 2^30), ties up, for sines,
 * cosines and their rounded products (|a|, |b|, |c|, |d| <= 2^30 + 2): the
 * sums are below 2^62 and, for the entries of T, the results below 2^31
 * (each is a product or a dot product of unit vectors, to within a few
 * LSB). */
SPI_INLINE int32_t spi_mul30_up(int32_t a, int32_t b)
{
    return (int32_t)spi_round_up((int64_t)a * b, 30u);
}

SPI_INLINE int32_t spi_dot30_up(int32_t a, int32_t b, int32_t c, int32_t d)
{
    return (int32_t)spi_round_up((int64_t)a * b + (int64_t)c * d, 30u);
}

/* |a - b| for any two int32, exact in uint32. */
SPI_INLINE uint32_t spi_dist32(int32_t a, int32_t b)
{
    return (a > b) ? (uint32_t)a - (uint32_t)b : (uint32_t)b - (uint32_t)a;
}

/* Is |a - b| above the limit (a negative limit: always)? Exact for any
 * two int32. */
SPI_INLINE int spi_farther(int32_t a, int32_t b, int32_t limit)
{
    return limit < 0 || spi_dist32(a, b) > (uint32_t)limit;
}

/* a + b, saturated. */
SPI_INLINE int32_t spi_add(int32_t a, int32_t b, sp_flags_t *flags)
{
    return spi_sat((int64_t)a + b, flags);
}

/* a - b, saturated. */
SPI_INLINE int32_t spi_sub(int32_t a, int32_t b, sp_flags_t *flags)
{
    return spi_sat((int64_t)a - b, flags);
}

/* int64 a + b, saturated. */
SPI_INLINE int64_t spi_add64(int64_t a, int64_t b, sp_flags_t *flags)
{
    if (b > 0 && a > INT64_MAX - b) {
        *flags |= SP_FLAG_OVERFLOW;
        return INT64_MAX;
    }
    if (b < 0 && a < INT64_MIN - b) {
        *flags |= SP_FLAG_OVERFLOW;
        return INT64_MIN;
    }
    return a + b;
}

/* a - b saturated, setting *ovf on overflow: one SUBS and a branch on the
 * overflow flag where the compiler has the builtin. */
SPI_INLINE int32_t spi_sub_sat(int32_t a, int32_t b, sp_flags_t *flags)
{
#if defined(__GNUC__)
    int32_t r;
    if (__builtin_sub_overflow(a, b, &r)) {
        *flags |= SP_FLAG_OVERFLOW;
        r = (a < 0) ? INT32_MIN : INT32_MAX; /* the true result has a's sign */
    }
    return r;
#else
    return spi_sat((int64_t)a - b, flags);
#endif
}

/* round(x k / 2^30) for |x| < 2^61 and |k| <= 2^30, exact (ties up): the
 * result is at most |x|, no overflow. x = xh 2^32 + xl with xl unsigned:
 * x k = (xh k) 2^32 + xl k, and 2^32 is a multiple of 2^30. */
SPI_INLINE int64_t spi_mul64_q30_up(int64_t x, int32_t k)
{
    int64_t ph = (int64_t)(int32_t)(x >> 32) * k;         /* |ph| <= 2^59 */
    int64_t pl = (int64_t)(uint32_t)(x & 0xFFFFFFFF) * k; /* |pl| < 2^62 */
    return ph * 4 + ((pl + (INT64_C(1) << 29)) >> 30);
}

/* round(x k / 2^s) for int64 x, int32 k and 1 <= s <= 32 (ties up), or
 * sp_mul64's exact general path (ties away from zero, saturating) when the
 * result could come near 2^62. Two 32x32 products and a shift. */
SPI_INLINE int64_t spi_mul64_up(int64_t x, int32_t k, unsigned s, sp_flags_t *flags)
{
    int64_t ph = (int64_t)(int32_t)(x >> 32) * k;         /* |ph| <= 2^62 */
    int64_t pl = (int64_t)(uint32_t)(x & 0xFFFFFFFF) * k; /* |pl| < 2^63 */
    if ((uint64_t)ph + (UINT64_C(1) << (29u + s)) >= (UINT64_C(1) << (30u + s))) {
        return sp_mul64(x, k, s, flags); /* |ph 2^(32 - s)| could reach 2^61 */
    }
    return ph * (INT64_C(1) << (32u - s)) + ((pl + (INT64_C(1) << (s - 1u))) >> s);
}

/* One 16-bit quotient digit of Knuth's algorithm D: (n 2^16 + low) /
 * (d1 2^16 + d0) for a normalised divisor (d1 >= 2^15) and n below it, from
 * the trial n / d1 with at most two corrections (the test against the
 * two-digit divisor is exact, so no add-back is needed). */
SPI_INLINE uint32_t spi_udiv_digit(uint32_t n, uint32_t d1, uint32_t d0, uint32_t low)
{
    uint32_t q = n / d1; /* <= 2^16 + 2 */
    uint32_t r = n - q * d1;
    unsigned k;
    for (k = 0u; k < 2u; ++k) {
        if (q > 0xFFFFu || q * d0 > ((r << 16) | low)) {
            --q;
            r += d1;
            if (r > 0xFFFFu) {
                break;
            }
        } else {
            break;
        }
    }
    return q;
}

/*
 * floor(n / d) and n mod d for n < d * 2^32 (the quotient fits 32 bits),
 * d != 0: Knuth's algorithm D with 16-bit digits, two 32/32 hardware
 * divisions. With a two-digit divisor the trial-quotient test is exact, so
 * each digit needs at most two corrections and no add-back.
 */
SPI_INLINE uint32_t spi_udiv64_32(uint64_t n, uint32_t d, uint32_t *rem)
{
    unsigned s = spi_clz32(d);
    uint32_t dn = d << s;
    uint32_t d1 = dn >> 16;
    uint32_t d0 = dn & 0xFFFFu;
    uint64_t nn = n << s;                /* n < d 2^32, so n 2^s < dn 2^32 <= 2^64 */
    uint32_t n32 = (uint32_t)(nn >> 32); /* < dn */
    uint32_t n10 = (uint32_t)nn;
    uint32_t n1 = n10 >> 16;
    uint32_t n0 = n10 & 0xFFFFu;
    uint32_t q1;
    uint32_t q0;
    uint32_t n21;

    q1 = spi_udiv_digit(n32, d1, d0, n1);
    n21 = (n32 << 16) + n1 - q1 * dn; /* exact modulo 2^32: the true value is < dn */
    q0 = spi_udiv_digit(n21, d1, d0, n0);
    if (rem != NULL) {
        *rem = ((n21 << 16) + n0 - q0 * dn) >> s;
    }
    return (q1 << 16) | q0;
}

/*
 * Normalised reciprocal: for mn in [2^31, 2^32), returns Y ~= 2^62 / mn in
 * (2^30, 2^31], never above floor(2^62 / mn), relative error below 2^-28.
 * One 32/32 hardware division gives 2^48 / mn to 15 bits from below
 * (the divisor is rounded up); one Newton step y (2 - mn y) squares the
 * error and, being a maximum at the exact value, stays below it.
 */
SPI_INLINE uint32_t spi_recip_norm(uint32_t mn)
{
    uint32_t y0 = 0xFFFFFFFFu / ((mn >> 16) + 1u);        /* in [2^16 - 1, 2^17) */
    uint64_t e = (UINT64_C(1) << 48) - (uint64_t)mn * y0; /* in (0, 2^34) */
    return (y0 << 14) + (uint32_t)((e * y0) >> 34);
}

/*
 * Reciprocal of a magnitude 0 < m < 2^31: returns inv and *sh with
 * 1/m ~= inv / 2^sh, inv in (2^30, 2^31) never above the exact 2^sh / m
 * (relative error below 2^-28), sh = 62 - clz(m) in [31, 61]. Then
 * x 2^k / m ~= (x inv) / 2^(sh - k).
 */
SPI_INLINE int32_t spi_recip(uint32_t m, unsigned *sh)
{
    unsigned z = spi_clz32(m); /* >= 1 since m < 2^31 */
    uint32_t q = spi_recip_norm(m << z);
    if (q > 0x7FFFFFFFu) {
        q = 0x7FFFFFFFu; /* m a power of two: 2^31 - 1, error 2^-31 */
    }
    *sh = 62u - z; /* 1/m = 2^z / mn ~= q 2^z / 2^62 */
    return (int32_t)q;
}

/* The saturated value of spi_narrow_floor, out of line (fixed.c): sets
 * SP_FLAG_OVERFLOW, returns INT32_MIN for a negative acc, else INT32_MAX. */
int32_t spi_sat_slow(int64_t acc, sp_flags_t *flags)
#if defined(__GNUC__)
    __attribute__((cold, noinline))
#endif
    ;

/*
 * floor(acc / 2^s) narrowed to int32 for 1 <= s <= 31, saturating and
 * flagging (flags must not be NULL): the caller adds 2^(s-1) to acc first
 * for round to nearest (ties up). acc / 2^s fits int32 exactly when acc is
 * in [-2^(31+s), 2^(31+s)), i.e. when its high word is in
 * [-2^(s-1), 2^(s-1)): one addition and one comparison on that word, and
 * the rare saturation out of line.
 */
SPI_INLINE int32_t spi_narrow_floor(int64_t acc, unsigned s, sp_flags_t *flags)
{
    uint32_t hi = (uint32_t)((uint64_t)acc >> 32);
    /* the low word of acc >> s, as int32 (GCC and Clang convert modulo
     * 2^32); exact when in range, replaced when not */
    int32_t r = (int32_t)(acc >> s);
    if (((hi + (UINT32_C(1) << (s - 1u))) >> s) != 0u) {
        r = spi_sat_slow(acc, flags);
    }
    return r;
}

/* The square roots' seed table (fixed.c), see spi_sqrt_norm. */
extern const uint16_t spi_sqrt_seed[192];

/*
 * floor(sqrt(t 2^32 + lo)) for t in [2^30, 2^32), exact. One Newton step
 * s = (seed + t / s0) / 2 from the table gives floor(sqrt t) or one more
 * (at most 65536); t - s^2 modulo 2^32 then has its top bit set exactly
 * when s is one too many (the true difference is in (-2^31, 2^31)), and
 * rem = t - s^2 is in [0, 2s]. One division extends s by 16 bits
 * (Zimmermann's Karatsuba square root step): with
 * q = floor((rem 2^16 + lo / 2^16) / (2s)) <= 2^16, r = s 2^16 + q is
 * floor(sqrt) or one more (s >= 2^15 makes q^2 <= 2s 2^16), and one exact
 * comparison of r^2 fixes it. rem 2^15 + lo / 2^17 < 2^32 since rem <= 2s.
 * r = 2^32 (s = 65535, q = 2^16) wraps to 0: the floor is then 2^32 - 1.
 */
SPI_INLINE uint32_t spi_sqrt_norm(uint32_t t, uint32_t lo)
{
    uint32_t s = spi_sqrt_seed[(t >> 24) - 64u];
    uint32_t q;
    uint32_t r;

    s = (s + t / s) >> 1;
    if (((t - s * s) & 0x80000000u) != 0u) {
        --s;
    }
    q = (((t - s * s) << 15) + (lo >> 17)) / s;
    r = (s << 16) + q;
    if (r < q) {
        return 0xFFFFFFFFu;
    }
    if ((uint64_t)r * r > (((uint64_t)t << 32) | lo)) {
        --r;
    }
    return r;
}

/* int64 a - b, saturated (any b, INT64_MIN too). */
SPI_INLINE int64_t spi_sub64(int64_t a, int64_t b, sp_flags_t *flags)
{
    int64_t r;
    if ((b < 0) && (a > (INT64_MAX + b))) {
        *flags |= SP_FLAG_OVERFLOW;
        r = INT64_MAX;
    } else if ((b > 0) && (a < (INT64_MIN + b))) {
        *flags |= SP_FLAG_OVERFLOW;
        r = INT64_MIN;
    } else {
        r = a - b;
    }
    return r;
}

/* |v| for v > INT64_MIN (the core's 64-bit intermediates stay far inside). */
SPI_INLINE int64_t spi_abs64(int64_t v)
{
    return (v < 0) ? -v : v;
}

#endif /* SP_FIXED_INLINE_H */
