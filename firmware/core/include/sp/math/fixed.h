/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/math/fixed.h - fixed-point arithmetic of the portable core.
 *
 * Every quantity in the core is a two's-complement integer with an explicit
 * binary scaling, named in its type:
 *
 *   type        storage  format  unit / meaning                 range           resolution
 *   sp_q30_t    int32    Q1.30   dimensionless (unit vectors,   [-2, 2)         9.3e-10
 *                                rotation entries, sin, cos)
 *   sp_q24_t    int32    Q7.24   m, m/s, m/s^2, rad, rad/s,     [-128, 128)     6.0e-8
 *                                rad/s^2
 *   sp_q16_t    int32    Q15.16  kg, kg m^2, ratios > 128       [-32768, 32768) 1.5e-5
 *   sp_q8_t     int32    Q23.8   N, N m                         [-8.4e6, 8.4e6) 3.9e-3
 *
 * Wider intermediates are int64 with the sum of the operands' fractional
 * bits (e.g. a Q24 x Q24 product is Q48 in int64).
 *
 * Overflow policy: nothing wraps. A result that does not fit its type is
 * saturated to the type's extreme and SP_FLAG_OVERFLOW is OR-ed into the
 * caller's sticky flag word. A mathematically undefined operation (division
 * by zero, square root of a negative number) returns a documented safe value
 * and sets SP_FLAG_DOMAIN. The flag word is never cleared by these
 * functions: a caller runs a whole computation, then checks the word once and
 * turns it into an sp_status_t. A NULL flag pointer is allowed and ignored.
 *
 * Rounding: every narrowing shift rounds to nearest, ties away from zero, so
 * errors are symmetric about zero and do not drift with the sign.
 */
#ifndef SP_FIXED_H
#define SP_FIXED_H

#include <stdint.h>

#include "sp/math/status.h"

typedef int32_t sp_q30_t;
typedef int32_t sp_q24_t;
typedef int32_t sp_q16_t;
typedef int32_t sp_q8_t;

/** Sticky flag word; see SP_FLAG_*. */
typedef uint32_t sp_flags_t;

#define SP_FLAG_OVERFLOW 0x1u /**< a result saturated */
#define SP_FLAG_DOMAIN 0x2u   /**< undefined operation (x/0, sqrt(<0)) */

#define SP_Q30_ONE ((sp_q30_t)0x40000000)
#define SP_Q24_ONE ((sp_q24_t)0x01000000)
#define SP_Q16_ONE ((sp_q16_t)0x00010000)
#define SP_Q8_ONE ((sp_q8_t)0x00000100)

/** x thousandths (mm, mrad, mm/s, ...) in Q24, rounded to nearest (ties
 *  away from zero): an integer constant expression, for |x| < 128000. */
#define SP_Q24_MILLI(x) ((sp_q24_t)(((int64_t)(x)*SP_Q24_ONE + ((x) < 0 ? -500 : 500)) / 1000))

/** x thousandths in Q30, rounded as SP_Q24_MILLI, for |x| < 2000. */
#define SP_Q30_MILLI(x) ((sp_q30_t)(((int64_t)(x)*SP_Q30_ONE + ((x) < 0 ? -500 : 500)) / 1000))

/** pi/2 in Q24 (1.5707963 rad), rounded to nearest. */
#define SP_Q24_HALF_PI ((sp_q24_t)26353589)

/**
 * Status of a computation that ran with a flag word: SP_OK if no flag is set,
 * SP_E_DOMAIN if SP_FLAG_DOMAIN is set, else SP_E_OVERFLOW.
 */
sp_status_t sp_flags_status(sp_flags_t flags);

/*@ logic integer SP_SAT32(integer v) = (v > INT32_MAX ? INT32_MAX : (v < INT32_MIN ? INT32_MIN : v));
  @ // v / p rounded to nearest, ties away from zero (p > 0; ACSL's / truncates)
  @ logic integer SP_ROUND(integer v, integer p) = (v >= 0 ? (v + p / 2) / p : -((-v + p / 2) / p));
  @*/

/**
 * Narrow an int64 to int32. Values outside [INT32_MIN, INT32_MAX] saturate
 * to the nearer extreme and set SP_FLAG_OVERFLOW.
 */
/*@ requires flags == \null || \valid(flags);
  @ assigns *flags;
  @ ensures \result == SP_SAT32(v);
  @ ensures flags != \null && (v > INT32_MAX || v < INT32_MIN) ==> *flags == (\old(*flags) | SP_FLAG_OVERFLOW);
  @ ensures flags != \null && INT32_MIN <= v <= INT32_MAX ==> *flags == \old(*flags);
  @*/
int32_t sp_sat32(int64_t v, sp_flags_t *flags);

/** a + b, any common Q format. Saturates (SP_FLAG_OVERFLOW) on overflow. */
/*@ requires flags == \null || \valid(flags);
  @ assigns *flags;
  @ ensures \result == SP_SAT32(a + b);
  @*/
int32_t sp_add(int32_t a, int32_t b, sp_flags_t *flags);

/** a - b, any common Q format. Saturates (SP_FLAG_OVERFLOW) on overflow. */
/*@ requires flags == \null || \valid(flags);
  @ assigns *flags;
  @ ensures \result == SP_SAT32(a - b);
  @*/
int32_t sp_sub(int32_t a, int32_t b, sp_flags_t *flags);

/** -a. -INT32_MIN saturates to INT32_MAX (SP_FLAG_OVERFLOW). */
/*@ requires flags == \null || \valid(flags);
  @ assigns *flags;
  @ ensures \result == SP_SAT32(-a);
  @*/
int32_t sp_neg(int32_t a, sp_flags_t *flags);

/** |a|. |INT32_MIN| saturates to INT32_MAX (SP_FLAG_OVERFLOW). */
/*@ requires flags == \null || \valid(flags);
  @ assigns *flags;
  @ ensures \result == SP_SAT32(\abs(a));
  @*/
int32_t sp_abs(int32_t a, sp_flags_t *flags);

/**
 * v / 2^shift rounded to nearest (ties away from zero), 0 <= shift <= 62
 * (a larger shift is taken as 62). Exact for every int64 input; cannot
 * overflow. WP proves the contract one shift at a time (proofs.py wp-round).
 */
/*@ assigns \nothing;
  @ ensures \result == SP_ROUND(v, 1 << (shift > 62 ? 62 : shift));
  @*/
int64_t sp_rshift_round(int64_t v, unsigned shift);

/**
 * Product of Qa and Qb, returned in Q(a+b-shift): round(a * b / 2^shift).
 * The 64-bit product is exact; only the final narrowing can saturate
 * (SP_FLAG_OVERFLOW). shift must be <= 62 (a larger one is taken as 62).
 * Error: at most 0.5 LSB of the result (ties away from zero).
 */
/*@ requires flags == \null || \valid(flags);
  @ assigns *flags;
  @ ensures \result == SP_SAT32(SP_ROUND(a * b, 1 << (shift > 62 ? 62 : shift)));
  @*/
int32_t sp_mul(int32_t a, int32_t b, unsigned shift, sp_flags_t *flags);

/** Q30 x Q30 -> Q30. Saturates outside [-2, 2). Error <= 0.5 LSB. */
static inline sp_q30_t sp_mul_q30(sp_q30_t a, sp_q30_t b, sp_flags_t *flags)
{
    return sp_mul(a, b, 30u, flags);
}

/** Q24 x Q24 -> Q24. Saturates outside [-128, 128). Error <= 0.5 LSB. */
static inline sp_q24_t sp_mul_q24(sp_q24_t a, sp_q24_t b, sp_flags_t *flags)
{
    return sp_mul(a, b, 24u, flags);
}

/** Qn x Q30 -> Qn (scale any value by a dimensionless Q30 factor). */
static inline int32_t sp_scale_q30(int32_t a, sp_q30_t k, sp_flags_t *flags)
{
    return sp_mul(a, k, 30u, flags);
}

/**
 * Quotient num / den with the result carrying `shift` more fractional bits
 * than num has over den: round(num * 2^shift / den), 0 <= shift <= 62, num a
 * 64-bit value whose shifted magnitude must stay below 2^63 (the caller's
 * formats guarantee it; larger inputs saturate with SP_FLAG_OVERFLOW).
 * den == 0 returns 0 with SP_FLAG_DOMAIN (a safe value for a controller:
 * no output). A result outside int32 saturates (SP_FLAG_OVERFLOW).
 * Error: at most 0.5 LSB of the result.
 */
int32_t sp_div(int64_t num, int32_t den, unsigned shift, sp_flags_t *flags);

/** Q24 / Q24 -> Q24. See sp_div. */
static inline sp_q24_t sp_div_q24(sp_q24_t num, sp_q24_t den, sp_flags_t *flags)
{
    return sp_div(num, den, 24u, flags);
}

/**
 * Integer square root of an unsigned 64-bit value, rounded to nearest:
 * the r in [0, 2^32 - 1] closest to sqrt(v). Exact; cannot fail.
 * A Q2n input gives a Qn output (Q48 -> Q24, Q60 -> Q30).
 */
uint32_t sp_isqrt64(uint64_t v);

/**
 * Square root of a non-negative Q24 value, in Q24. Error <= 0.5 LSB.
 * A negative input returns 0 with SP_FLAG_DOMAIN.
 */
sp_q24_t sp_sqrt_q24(sp_q24_t a, sp_flags_t *flags);

/**
 * Sine and cosine of an angle in radians (Q24, the whole int32 range:
 * |angle| < 128 rad), in Q30. The quadrant comes from a multiplication by
 * 2/pi, the reduction by pi/2 is done in 52 fractional bits, then Taylor
 * polynomials on [-pi/4, pi/4] (to r^11 and r^12) by Horner steps of
 * rounded 32x32 high-word products. No division.
 * Error: at most 2 LSB of Q30 (1.9e-9) against the exact value of the Q24
 * input. Cannot fail; either output pointer may be NULL.
 */
void sp_sincos_q24(sp_q24_t angle, sp_q30_t *sin_out, sp_q30_t *cos_out);

/**
 * Dot product of two 3-vectors with an exact 64-bit accumulation:
 * round(sum a[k] * b[k] / 2^shift), narrowed with saturation
 * (SP_FLAG_OVERFLOW). The sum of three 62-bit products cannot overflow int64.
 */
int32_t sp_dot3(const int32_t a[3], const int32_t b[3], unsigned shift, sp_flags_t *flags);

/* ---- 64-bit intermediates (dynamics, linear solve) ----------------------- */

/** a + b in int64, saturating at INT64_MIN / INT64_MAX (SP_FLAG_OVERFLOW). */
int64_t sp_add64(int64_t a, int64_t b, sp_flags_t *flags);

/**
 * round(x * k / 2^shift) for a 64-bit x and a 32-bit k, 0 <= shift <= 62,
 * computed exactly through a 96-bit split product; the result saturates at
 * the int64 extremes (SP_FLAG_OVERFLOW). Error <= 0.5 LSB.
 * Typical use: scale an int64 Q24 force by a Q30 or Q28 coefficient.
 */
int64_t sp_mul64(int64_t x, int32_t k, unsigned shift, sp_flags_t *flags);

/**
 * round(num * 2^shift / den) for a 64-bit num and a 32-bit den,
 * 0 <= shift <= 62, exact long division; saturates at the int64 extremes
 * (SP_FLAG_OVERFLOW). den == 0 returns 0 with SP_FLAG_DOMAIN.
 * Error <= 0.5 LSB.
 */
int64_t sp_div64(int64_t num, int32_t den, unsigned shift, sp_flags_t *flags);

/**
 * A divisor prepared for sp_recip_div: d itself and r = floor(2^(24 + shift)
 * / d), shift the largest in [31, 39] that keeps r below 2^32. r is 0 when
 * no such shift exists (d at most about 2^23): sp_recip_div then divides.
 */
typedef struct {
    int64_t d;     /**< the divisor, > 0 */
    uint32_t r;    /**< floor(2^(24 + shift) / d); 0: sp_recip_div divides */
    uint8_t shift; /**< 31..39 */
} sp_recip_t;

/**
 * Prepares d (in (0, 2^62)) for sp_recip_div, with 64-bit divisions: for
 * a divisor that changes seldom and a quotient wanted often. SP_E_ARG for
 * d outside that range or rec NULL (rec, if given, then divides by 1).
 */
sp_status_t sp_recip_prepare(int64_t d, sp_recip_t *rec);

/**
 * floor(n 2^24 / d) for n in [0, 2^31) and rec prepared for d, exactly:
 * one 32 x 32 multiply, a shift and one correcting step instead of a
 * 64-bit division (a library call on a Cortex-M4). n 2^24 < 2^55 cannot
 * overflow; n at 2^31 or above is taken as 2^31 - 1. The Q format is n's
 * plus 24 less d's.
 */
int64_t sp_recip_div(uint32_t n, const sp_recip_t *rec);

/** Narrow an int64 to int32 after a rounding right shift (0..62), saturating
 *  (SP_FLAG_OVERFLOW): sp_sat32(sp_rshift_round(v, shift)). */
int32_t sp_narrow(int64_t v, unsigned shift, sp_flags_t *flags);

#endif /* SP_FIXED_H */
