/* SPDX-License-Identifier: Apache-2.0 */
#include "math/fixed_inline.h"

/* pi/2 2^31 = HALF_PI_HI + HALF_PI_LO / 2^24: the high part rounded to
 * nearest (32 bits, unsigned), the remainder 0.1305 in Q24, to nearest. */
#define HALF_PI_HI UINT32_C(3373259426)
#define HALF_PI_LO INT32_C(2189506)
/* 2/pi with 31 fractional bits, rounded to nearest. */
#define INV_HALF_PI_Q31 INT64_C(1367130551)

/* Taylor coefficients of (sin r - r) / r^3 = A0 + A1 r^2 + ... + A4 r^8 and
 * (cos r - 1) / r^2 = B0 + B1 r^2 + ... + B5 r^10, each rounded to nearest
 * in the Q format its Horner step needs (one bit more per level, because
 * every step multiplies by r^2 in Q31 and keeps the high word). */
#define SIN_A0 INT32_C(-1431655765) /* -1/3!  Q33 */
#define SIN_A1 INT32_C(143165577)   /*  1/5!  Q34 */
#define SIN_A2 INT32_C(-6817408)    /* -1/7!  Q35 */
#define SIN_A3 INT32_C(189372)      /*  1/9!  Q36 */
#define SIN_A4 INT32_C(-3443)       /* -1/11! Q37 */
#define COS_B0 INT32_MIN            /* -1/2!  Q32 */
#define COS_B1 INT32_C(357913941)   /*  1/4!  Q33 */
#define COS_B2 INT32_C(-23860929)   /* -1/6!  Q34 */
#define COS_B3 INT32_C(852176)      /*  1/8!  Q35 */
#define COS_B4 INT32_C(-18937)      /* -1/10! Q36 */
#define COS_B5 INT32_C(287)         /*  1/12! Q37 */

static void set_flag(sp_flags_t *flags, sp_flags_t f)
{
    if (flags != NULL) {
        *flags |= f;
    }
}

sp_status_t sp_flags_status(sp_flags_t flags)
{
    if ((flags & SP_FLAG_DOMAIN) != 0u) {
        return SP_E_DOMAIN;
    }
    if ((flags & SP_FLAG_OVERFLOW) != 0u) {
        return SP_E_OVERFLOW;
    }
    return SP_OK;
}

int32_t sp_sat32(int64_t v, sp_flags_t *flags)
{
    if (v > INT32_MAX) {
        set_flag(flags, SP_FLAG_OVERFLOW);
        return INT32_MAX;
    }
    if (v < INT32_MIN) {
        set_flag(flags, SP_FLAG_OVERFLOW);
        return INT32_MIN;
    }
    return (int32_t)v;
}

int32_t sp_add(int32_t a, int32_t b, sp_flags_t *flags)
{
    return sp_sat32((int64_t)a + (int64_t)b, flags);
}

int32_t sp_sub(int32_t a, int32_t b, sp_flags_t *flags)
{
    return sp_sat32((int64_t)a - (int64_t)b, flags);
}

int32_t sp_neg(int32_t a, sp_flags_t *flags)
{
    return sp_sat32(-(int64_t)a, flags);
}

int32_t sp_abs(int32_t a, sp_flags_t *flags)
{
    return sp_sat32(a < 0 ? -(int64_t)a : (int64_t)a, flags);
}

int64_t sp_rshift_round(int64_t v, unsigned shift)
{
    uint64_t mag;
    uint64_t half;

    if (shift == 0u) {
        return v;
    }
    if (shift > 62u) {
        shift = 62u;
    }
    if (v <= INT64_C(0x3FFFFFFFFFFFFFFF)) {
        /* |v + 2^(shift-1)| stays below 2^63: one add and a shift */
        return spi_round_away(v, shift);
    }
    mag = (uint64_t)v;
    half = (uint64_t)1 << (shift - 1u);
    mag = (mag >> shift) + (((mag & ((half << 1) - 1u)) >= half) ? 1u : 0u);
    return (int64_t)mag;
}

int32_t sp_mul(int32_t a, int32_t b, unsigned shift, sp_flags_t *flags)
{
    /* |a b| <= 2^62: spi_round_away's precondition holds for every shift */
    int64_t p = (int64_t)a * (int64_t)b;
    return sp_sat32((shift == 0u) ? p : spi_round_away(p, (shift > 62u) ? 62u : shift), flags);
}

/* The magnitudes and the sign of a quotient num / den (sp_div, sp_div64),
 * the shift capped at 62. Returns 0 (SP_FLAG_DOMAIN) when den is 0. */
SPI_INLINE int div_operands(int64_t num, int32_t den, unsigned *shift, uint64_t *n, uint32_t *d, int *neg,
                            sp_flags_t *flags)
{
    if (den == 0) {
        set_flag(flags, SP_FLAG_DOMAIN);
        return 0;
    }
    if (*shift > 62u) {
        *shift = 62u;
    }
    *neg = ((num < 0) != (den < 0)) ? 1 : 0;
    *n = (num < 0) ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    *d = (den < 0) ? (uint32_t)0 - (uint32_t)den : (uint32_t)den;
    return 1;
}

int32_t sp_div(int64_t num, int32_t den, unsigned shift, sp_flags_t *flags)
{
    uint64_t n;
    uint32_t d;
    uint32_t q;
    int neg;

    if (!div_operands(num, den, &shift, &n, &d, &neg, flags)) {
        return 0;
    }
    if (n > (UINT64_C(0x7FFFFFFFFFFFFFFF) >> shift)) {
        /* n * 2^shift >= 2^63 and d <= 2^31: |quotient| >= 2^32. */
        set_flag(flags, SP_FLAG_OVERFLOW);
        return neg ? INT32_MIN : INT32_MAX;
    }
    /* q = floor((n 2^shift + floor(d/2)) / d): nearest, ties away from zero.
     * The sum is below 2^63 + 2^31 and cannot wrap. */
    n = (n << shift) + (d >> 1);
    if ((n >> 32) >= d) {
        set_flag(flags, SP_FLAG_OVERFLOW); /* quotient >= 2^32 */
        return neg ? INT32_MIN : INT32_MAX;
    }
    q = spi_udiv64_32(n, d, NULL);
    return sp_sat32(neg ? -(int64_t)q : (int64_t)q, flags);
}

int32_t spi_sat_slow(int64_t acc, sp_flags_t *flags)
{
    *flags |= SP_FLAG_OVERFLOW;
    return (acc < 0) ? INT32_MIN : INT32_MAX;
}

/* Seeds of the square root of a 32-bit t in [2^30, 2^32):
 * spi_sqrt_seed[k - 64] is the square root of the geometric middle of
 * [k 2^24, (k + 1) 2^24), k = t >> 24 in [64, 256), to nearest. One Newton
 * step from it (spi_sqrt_norm) exceeds sqrt(t) by (seed - sqrt t)^2 /
 * (2 seed), largest at an interval's ends and at most 0.25 there, so it
 * lands on floor(sqrt t) or one above (test_fixed's test_isqrt64 checks
 * every interval's ends). */
const uint16_t spi_sqrt_seed[192] = {
    32895u, 33149u, 33401u, 33652u, 33900u, 34147u, 34391u, 34634u, 34876u, 35115u, 35354u, 35590u, 35825u, 36058u,
    36290u, 36521u, 36750u, 36977u, 37203u, 37428u, 37652u, 37874u, 38095u, 38314u, 38533u, 38750u, 38966u, 39180u,
    39394u, 39606u, 39817u, 40028u, 40237u, 40444u, 40651u, 40857u, 41062u, 41266u, 41469u, 41670u, 41871u, 42071u,
    42270u, 42468u, 42665u, 42861u, 43057u, 43251u, 43444u, 43637u, 43829u, 44020u, 44210u, 44399u, 44588u, 44776u,
    44963u, 45149u, 45334u, 45519u, 45703u, 45886u, 46068u, 46250u, 46431u, 46612u, 46791u, 46970u, 47148u, 47326u,
    47503u, 47679u, 47855u, 48030u, 48204u, 48378u, 48551u, 48723u, 48895u, 49066u, 49237u, 49407u, 49577u, 49746u,
    49914u, 50082u, 50249u, 50416u, 50582u, 50747u, 50912u, 51077u, 51241u, 51404u, 51567u, 51730u, 51892u, 52053u,
    52214u, 52374u, 52534u, 52694u, 52853u, 53011u, 53169u, 53327u, 53484u, 53640u, 53796u, 53952u, 54107u, 54262u,
    54417u, 54571u, 54724u, 54877u, 55030u, 55182u, 55334u, 55485u, 55636u, 55787u, 55937u, 56087u, 56236u, 56385u,
    56534u, 56682u, 56830u, 56977u, 57124u, 57271u, 57417u, 57563u, 57708u, 57854u, 57998u, 58143u, 58287u, 58431u,
    58574u, 58717u, 58860u, 59002u, 59144u, 59286u, 59427u, 59568u, 59709u, 59849u, 59989u, 60129u, 60268u, 60407u,
    60546u, 60684u, 60822u, 60960u, 61098u, 61235u, 61372u, 61508u, 61644u, 61780u, 61916u, 62051u, 62186u, 62321u,
    62456u, 62590u, 62724u, 62857u, 62990u, 63124u, 63256u, 63389u, 63521u, 63653u, 63785u, 63916u, 64047u, 64178u,
    64308u, 64439u, 64569u, 64699u, 64828u, 64957u, 65086u, 65215u, 65344u, 65472u,
};

uint32_t sp_isqrt64(uint64_t v)
{
    uint32_t hi = (uint32_t)(v >> 32);
    uint32_t lo = (uint32_t)v;
    uint32_t root;
    unsigned z;

    if (v == 0u) {
        return 0u;
    }
    /* vn = v 2^z with z even and vn's top word t in [2^30, 2^32) */
    if (hi != 0u) {
        z = spi_clz32(hi) & ~1u; /* 0..30 */
        hi = (hi << z) | ((lo >> 1) >> (31u - z));
        lo <<= z;
    } else {
        z = spi_clz32(lo) & ~1u;
        hi = lo << z;
        lo = 0u;
        z += 32u;
    }
    /* floor(sqrt(v)) = floor(floor(sqrt(vn)) / 2^(z/2)) */
    root = spi_sqrt_norm(hi, lo) >> (z >> 1);
    /* sqrt(v) >= root + 1/2 exactly when v > root^2 + root. */
    if (v - (uint64_t)root * root > root && root < UINT32_MAX) {
        root += 1u;
    }
    return root;
}

sp_q24_t sp_sqrt_q24(sp_q24_t a, sp_flags_t *flags)
{
    if (a < 0) {
        set_flag(flags, SP_FLAG_DOMAIN);
        return 0;
    }
    /* Q48 in, Q24 out; sqrt(2^55) < 2^31 so the result always fits. */
    return (sp_q24_t)sp_isqrt64((uint64_t)a << 24);
}

/* The int32 of a uint32 modulo 2^32, without an implementation-defined
 * conversion (the compiler emits nothing). */
SPI_INLINE int32_t u32_to_i32(uint32_t u)
{
    return (u <= 0x7FFFFFFFu) ? (int32_t)u : -(int32_t)(~u) - 1;
}

/* round(a b / 2^32), ties up: the high word of a 32x32 product, rounded.
 * Taken as the high word of the unsigned sum (the same bits): a value the
 * compiler sees as 32 bits wide, so that a product of it stays one 32x32
 * multiply (from spi_round_up's int64, GCC made the next mulhi a 64x64
 * one). */
SPI_INLINE int32_t mulhi(int32_t a, int32_t b)
{
    uint64_t v = (uint64_t)((int64_t)a * b) + (UINT64_C(1) << 31);
    return u32_to_i32((uint32_t)(v >> 32));
}

/* floor(a b / 2^32): the high word alone (one SMMUL instead of a rounding
 * SMLAL from 2^31), for the inner Horner steps. */
SPI_INLINE int32_t mulhi_floor(int32_t a, int32_t b)
{
    return (int32_t)(((int64_t)a * b) >> 32);
}

void sp_sincos_q24(sp_q24_t angle, sp_q30_t *sin_out, sp_q30_t *cos_out)
{
    int32_t n;
    int32_t r;
    int32_t r2;
    int32_t p;
    int32_t s;
    int32_t c;

    /* n = round(x / (pi/2)) by a multiplication with 2/pi (Q24 x Q31 =
     * Q55, rounded from the high word: floor((hi + 2^22) / 2^23) is
     * floor((x 2/pi 2^55 + 2^54) / 2^55), ties up); it may be off by one
     * where x / (pi/2) is within 2^-24 of a half-integer, which only moves
     * r a hair beyond pi/4, inside the polynomials' accuracy. |n| <= 82. */
    n = (int32_t)(((int64_t)angle * INV_HALF_PI_Q31 + (INT64_C(1) << 54)) >> 55);
    /* r = x - n pi/2 in Q31, |r| <= pi/4 (+ 1e-7) < 0.79 * 2^31, in 32-bit
     * arithmetic modulo 2^32 (exact, since the true value fits int32):
     * x 2^7 exactly, minus n HALF_PI_HI (pi/2 2^31 rounded, 32 bits),
     * minus n HALF_PI_LO (the remainder pi/2 2^31 - HALF_PI_HI, 0.1305, in
     * Q24) rounded. The only rounding is the last one's, 0.5 LSB of Q31;
     * the constants' own errors times |n| stay below 2^-20 LSB. */
    r = u32_to_i32(((uint32_t)angle << 7) - (uint32_t)n * HALF_PI_HI);
    r -= (n * HALF_PI_LO + (INT32_C(1) << 23)) >> 24;
    r2 = (int32_t)(((int64_t)r * r + (INT64_C(1) << 30)) >> 31); /* r^2, Q31, < 0.62 */

    /* sin r = r + r^3 (A0 + r^2 (A1 + ... )): Horner in r^2, each step
     * one high-word multiply, truncated (floor, bias below 1 LSB of its
     * level) inside the polynomial and rounded in the final products; then
     * from Q31 to Q30. A level's error enters the next level as half an
     * LSB times r^2 < 0.62, so the truncations add at most 1.45 LSB of Q33
     * (sine) or Q32 (cosine) at the last level, times r^3 < 0.49 or
     * r^2 < 0.62: below 0.1 and 0.23 LSB of Q30 (test_sincos: worst 1.03
     * LSB in all, 1.08 with every step rounded). */
    p = SIN_A4;
    p = SIN_A3 + mulhi_floor(r2, p);
    p = SIN_A2 + mulhi_floor(r2, p);
    p = SIN_A1 + mulhi_floor(r2, p);
    p = SIN_A0 + mulhi_floor(r2, p); /* Q33 */
    p = mulhi(r, mulhi(r2, p));      /* r^3 (...), Q31 */
    s = (r + p + 1) >> 1;            /* Q31 -> Q30; |r + p| <= |r| < 2^31 */

    /* cos r = 1 + r^2 (B0 + r^2 (B1 + ...)). */
    p = COS_B5;
    p = COS_B4 + mulhi_floor(r2, p);
    p = COS_B3 + mulhi_floor(r2, p);
    p = COS_B2 + mulhi_floor(r2, p);
    p = COS_B1 + mulhi_floor(r2, p);
    p = COS_B0 + mulhi_floor(r2, p);            /* Q32, in [-2^31, -0.47 * 2^32] */
    c = SP_Q30_ONE + ((mulhi(r2, p) + 1) >> 1); /* Q31 -> Q30; r^2 (...) in (-2^30, 0] */

    switch ((uint32_t)n & 3u) { /* n mod 4 for either sign */
    case 1u:                    /* x = r + pi/2 */
        p = s;
        s = c;
        c = -p;
        break;
    case 2u: /* x = r + pi */
        s = -s;
        c = -c;
        break;
    case 3u: /* x = r + 3pi/2 */
        p = s;
        s = -c;
        c = p;
        break;
    default:
        break;
    }
    if (sin_out != NULL) {
        *sin_out = s;
    }
    if (cos_out != NULL) {
        *cos_out = c;
    }
}

int32_t sp_dot3(const int32_t a[3], const int32_t b[3], unsigned shift, sp_flags_t *flags)
{
    /* Each product is within [-2^62, 2^62]; three of them can exceed int64.
     * Sum exact halves instead: p = 2h + r with r in {0, 1} (an arithmetic
     * shift is a floor division by 2). */
    int64_t p0 = (int64_t)a[0] * b[0];
    int64_t p1 = (int64_t)a[1] * b[1];
    int64_t p2 = (int64_t)a[2] * b[2];
    int64_t h = (p0 >> 1) + (p1 >> 1) + (p2 >> 1);
    int64_t r = (p0 & 1) + (p1 & 1) + (p2 & 1);
    int64_t hq;
    int64_t rem;
    int64_t half;

    /* total = 2h + r, |h| <= 3 * 2^61 + 1, r in [0, 3]. */
    h += r >> 1;
    r &= 1;
    if (shift == 0u) {
        if (h > INT32_MAX || h < INT32_MIN) {
            set_flag(flags, SP_FLAG_OVERFLOW);
            return (h > 0) ? INT32_MAX : INT32_MIN;
        }
        return sp_sat32(2 * h + r, flags);
    }
    if (shift > 62u) {
        shift = 62u;
    }
    /* total / 2^shift = hq + (2 hr + r) / 2^shift with 0 <= 2 hr + r < 2^shift. */
    hq = h >> (shift - 1u);
    rem = 2 * (h & ((INT64_C(1) << (shift - 1u)) - 1)) + r;
    half = INT64_C(1) << (shift - 1u);
    if (rem > half || (rem == half && hq >= 0)) {
        hq += 1; /* nearest, ties away from zero */
    }
    return sp_sat32(hq, flags);
}

int64_t sp_add64(int64_t a, int64_t b, sp_flags_t *flags)
{
    if (b > 0 && a > INT64_MAX - b) {
        set_flag(flags, SP_FLAG_OVERFLOW);
        return INT64_MAX;
    }
    if (b < 0 && a < INT64_MIN - b) {
        set_flag(flags, SP_FLAG_OVERFLOW);
        return INT64_MIN;
    }
    return a + b;
}

int32_t sp_narrow(int64_t v, unsigned shift, sp_flags_t *flags)
{
    return sp_sat32(sp_rshift_round(v, shift), flags);
}

/* A sign and a magnitude to int64, saturating: -2^63 is representable,
 * +2^63 is not. */
static int64_t sat_signed_mag(uint64_t mag, int neg, sp_flags_t *flags)
{
    if (neg) {
        if (mag > (UINT64_C(1) << 63)) {
            set_flag(flags, SP_FLAG_OVERFLOW);
            return INT64_MIN;
        }
        return (mag == (UINT64_C(1) << 63)) ? INT64_MIN : -(int64_t)mag;
    }
    if (mag > (uint64_t)INT64_MAX) {
        set_flag(flags, SP_FLAG_OVERFLOW);
        return INT64_MAX;
    }
    return (int64_t)mag;
}

/* round(x k / 2^shift) on the magnitudes, for any shift in [0, 62]
 * (the general case; sp_mul64 uses it for shifts above 32). */
static int64_t mul64_wide(int64_t x, int32_t k, unsigned shift, sp_flags_t *flags)
{
    uint64_t xm = (x < 0) ? (uint64_t)0 - (uint64_t)x : (uint64_t)x;
    uint64_t km = (k < 0) ? (uint64_t)0 - (uint64_t)(int64_t)k : (uint64_t)k; /* <= 2^31 */
    int neg = ((x < 0) != (k < 0)) ? 1 : 0;
    /* xm * km = (xh * 2^32 + xl) * km = ph * 2^32 + pl, all parts < 2^64 */
    uint64_t pl = (xm & 0xFFFFFFFFu) * km; /* < 2^63 */
    uint64_t ph = (xm >> 32) * km;         /* < 2^63 */
    uint64_t hi;                           /* product = hi * 2^32 + lo32 */
    uint64_t lo32;
    uint64_t q;
    uint64_t rem;
    uint64_t half;

    ph += pl >> 32;
    lo32 = pl & 0xFFFFFFFFu;
    hi = ph; /* product = hi * 2^32 + lo32, hi < 2^64 */
    if (shift > 62u) {
        shift = 62u;
    }
    /* q = floor(product / 2^shift), rem = product mod 2^shift. */
    if (shift >= 32u) {
        unsigned s2 = shift - 32u;
        q = (s2 == 0u) ? hi : (hi >> s2);
        rem = ((s2 == 0u) ? 0u : ((hi & ((UINT64_C(1) << s2) - 1u)) << 32)) | lo32;
    } else {
        if (shift > 0u && (hi >> (64u - 32u + shift)) != 0u) {
            q = UINT64_MAX; /* product / 2^shift >= 2^64 */
            rem = 0u;
        } else if (shift == 0u && (hi >> 32) != 0u) {
            q = UINT64_MAX;
            rem = 0u;
        } else {
            q = (hi << (32u - shift)) | (lo32 >> shift);
            rem = (shift == 0u) ? 0u : (lo32 & ((UINT64_C(1) << shift) - 1u));
        }
    }
    if (shift > 0u) {
        half = UINT64_C(1) << (shift - 1u);
        if (rem >= half && q != UINT64_MAX) {
            q += 1u; /* nearest, ties away from zero (on the magnitude) */
        }
    }
    return sat_signed_mag(q, neg, flags);
}

int64_t sp_mul64(int64_t x, int32_t k, unsigned shift, sp_flags_t *flags)
{
    /* x k = ph 2^32 + pl with ph = (x >> 32) k and pl = (x mod 2^32) k,
     * two 32x32 products. For shift <= 32, floor(x k / 2^shift) =
     * ph 2^(32 - shift) + floor(pl / 2^shift) exactly, and the bits of pl
     * below the shift decide the rounding. */
    int64_t ph;
    int64_t pl;
    int64_t q;
    int64_t rem;
    int64_t half;
    unsigned up;

    if (shift > 32u) {
        return mul64_wide(x, k, shift, flags);
    }
    ph = (int64_t)(int32_t)(x >> 32) * k;         /* |ph| <= 2^62 */
    pl = (int64_t)(uint32_t)(x & 0xFFFFFFFF) * k; /* |pl| < 2^63 */
    up = 32u - shift;
    if (ph > (INT64_MAX >> (up + 1u)) || ph < (INT64_MIN >> (up + 1u)) || shift == 0u) {
        /* the result may come near the int64 limits: exact general path */
        return mul64_wide(x, k, shift, flags);
    }
    /* |ph 2^up| < 2^62 and |pl / 2^shift| < 2^62: no overflow below */
    q = ph * ((int64_t)1 << up) + (pl >> shift);
    half = (int64_t)1 << (shift - 1u);
    rem = pl & ((half << 1) - 1);
    if (rem > half || (rem == half && q >= 0)) {
        q += 1; /* nearest, ties away from zero */
    }
    return q;
}

int64_t sp_div64(int64_t num, int32_t den, unsigned shift, sp_flags_t *flags)
{
    uint64_t n;
    uint32_t d;
    uint64_t q;
    uint32_t r;
    uint32_t nh;
    unsigned i;
    int neg;

    if (!div_operands(num, den, &shift, &n, &d, &neg, flags)) {
        return 0;
    }
    /* n / d in two 32-bit digits: the high digit by a 32/32 division, the
     * low one with the remainder in front (r < d: the quotient fits). */
    nh = (uint32_t)(n >> 32);
    q = (uint64_t)(nh / d) << 32;
    r = nh % d;
    q |= spi_udiv64_32(((uint64_t)r << 32) | (n & 0xFFFFFFFFu), d, &r);
    /* Append `shift` zero bits to the dividend, at most 31 at a time. */
    i = shift;
    while (i > 0u) { /* at most 3 rounds */
        unsigned s = (i > 31u) ? 31u : i;
        if (q > (UINT64_C(1) << (63u - s))) { /* q << s > 2^63: beyond int64 */
            set_flag(flags, SP_FLAG_OVERFLOW);
            return neg ? INT64_MIN : INT64_MAX;
        }
        q = (q << s) + spi_udiv64_32((uint64_t)r << s, d, &r);
        i -= s;
    }
    /* Round to nearest, ties away from zero: compare 2r with d. */
    if (2u * (uint64_t)r >= d) {
        q += 1u; /* q <= 2^63 + 2^31 here: cannot wrap */
    }
    return sat_signed_mag(q, neg, flags);
}

sp_status_t sp_recip_prepare(int64_t d, sp_recip_t *rec)
{
    sp_status_t st = SP_E_ARG;
    unsigned s;
    if (rec != NULL) {
        rec->d = 1;
        rec->r = 0u;
        rec->shift = 31u;
        if ((d > 0) && (d < (INT64_C(1) << 62))) {
            rec->d = d;
            for (s = 39u; s >= 31u; --s) { /* 2^(24 + s) <= 2^63: no overflow */
                uint64_t r = (UINT64_C(1) << (24u + s)) / (uint64_t)d;
                if (r <= (uint64_t)UINT32_MAX) {
                    rec->r = (uint32_t)r;
                    rec->shift = (uint8_t)s;
                    break;
                }
            }
            st = SP_OK;
        }
    }
    return st;
}

/* With N = n 2^24 and E = floor(N / d): r <= 2^(24+s) / d gives
 * q = floor(n r / 2^s) <= E, and r > 2^(24+s) / d - 1 gives n r / 2^s >
 * N / d - n / 2^s > N / d - 1 (n < 2^31 <= 2^s): q is E or E - 1, and
 * E exactly when (q + 1) d > N. (q + 1) d <= N + d < 2^55 + 2^62. */
int64_t sp_recip_div(uint32_t n, const sp_recip_t *rec)
{
    uint64_t nn = (n <= (uint32_t)INT32_MAX) ? (uint64_t)n : (uint64_t)INT32_MAX;
    uint64_t num = nn << 24;
    uint64_t d = (rec->d > 0) ? (uint64_t)rec->d : 1u; /* a structure never prepared: divide by 1 */
    uint64_t q;
    if (rec->r == 0u) {
        q = num / d;
    } else {
        q = (nn * rec->r) >> rec->shift;
        if (((q + 1u) * d) <= num) {
            q += 1u;
        }
    }
    return (int64_t)q;
}
