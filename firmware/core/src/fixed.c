#include "sp/fixed.h"

/* pi/2 with 52 fractional bits, rounded to nearest (for angle reduction). */
#define HALF_PI_Q52 INT64_C(7074237752028440)

/* 1/k! in Q30, rounded to nearest (Taylor coefficients). */
#define INV_FACT2 INT32_C(536870912)
#define INV_FACT3 INT32_C(178956971)
#define INV_FACT4 INT32_C(44739243)
#define INV_FACT5 INT32_C(8947849)
#define INV_FACT6 INT32_C(1491308)
#define INV_FACT7 INT32_C(213044)
#define INV_FACT8 INT32_C(26631)
#define INV_FACT9 INT32_C(2959)
#define INV_FACT10 INT32_C(296)
#define INV_FACT11 INT32_C(27)
#define INV_FACT12 INT32_C(2)

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
    /* Work on the magnitude so that rounding is symmetric and no shift of a
     * negative value (implementation-defined in C99) is needed. */
    mag = (v < 0) ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    half = (uint64_t)1 << (shift - 1u);
    mag = (mag >> shift) + (((mag & ((half << 1) - 1u)) >= half) ? 1u : 0u);
    /* mag <= 2^63 >> 1 (+1): always fits in int64. */
    return (v < 0) ? -(int64_t)mag : (int64_t)mag;
}

int32_t sp_mul(int32_t a, int32_t b, unsigned shift, sp_flags_t *flags)
{
    return sp_sat32(sp_rshift_round((int64_t)a * (int64_t)b, shift), flags);
}

int32_t sp_div(int64_t num, int32_t den, unsigned shift, sp_flags_t *flags)
{
    uint64_t n;
    uint64_t d;
    uint64_t q;
    int neg;

    if (den == 0) {
        set_flag(flags, SP_FLAG_DOMAIN);
        return 0;
    }
    if (shift > 62u) {
        shift = 62u;
    }
    neg = ((num < 0) != (den < 0)) ? 1 : 0;
    n = (num < 0) ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    d = (den < 0) ? (uint64_t)0 - (uint64_t)(int64_t)den : (uint64_t)den;
    if (n > (UINT64_C(0x7FFFFFFFFFFFFFFF) >> shift)) {
        /* n * 2^shift >= 2^63 and d <= 2^31: |quotient| >= 2^32. */
        set_flag(flags, SP_FLAG_OVERFLOW);
        return neg ? INT32_MIN : INT32_MAX;
    }
    /* n << shift < 2^63 and d / 2 < 2^31: the sum cannot wrap. Adding d/2
     * rounds ties away from zero. */
    q = ((n << shift) + (d >> 1)) / d;
    return sp_sat32(neg ? -(int64_t)q : (int64_t)q, flags);
}

uint32_t sp_isqrt64(uint64_t v)
{
    uint64_t rem = v;
    uint64_t root = 0u;
    uint64_t bit = (uint64_t)1 << 62;

    while (bit > rem) { /* at most 32 steps */
        bit >>= 2;
    }
    while (bit != 0u) { /* at most 32 steps */
        if (rem >= root + bit) {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    /* root = floor(sqrt(v)), rem = v - root^2. sqrt(v) >= root + 1/2 exactly
     * when v > root^2 + root, i.e. rem > root. */
    if (rem > root && root < UINT32_MAX) {
        root += 1u;
    }
    return (uint32_t)root;
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

/* Q30 x Q30 -> Q30 without a flag word: only used inside the polynomial
 * evaluation, where every operand is bounded by 1 and cannot saturate. */
static int32_t mul30(int32_t a, int32_t b)
{
    return (int32_t)sp_rshift_round((int64_t)a * (int64_t)b, 30u);
}

void sp_sincos_q24(sp_q24_t angle, sp_q30_t *sin_out, sp_q30_t *cos_out)
{
    int64_t x52 = (int64_t)angle * (INT64_C(1) << 28); /* |x52| < 2^59 */
    int64_t n;
    int32_t r;
    int32_t r2;
    int32_t p;
    int32_t s;
    int32_t c;
    int32_t quadrant;

    /* n = round(x / (pi/2)); |n| <= 82, so n * HALF_PI_Q52 cannot overflow. */
    if (x52 >= 0) {
        n = (x52 + HALF_PI_Q52 / 2) / HALF_PI_Q52;
    } else {
        n = -((-x52 + HALF_PI_Q52 / 2) / HALF_PI_Q52);
    }
    /* r in [-pi/4, pi/4], from Q52 to Q30. */
    r = (int32_t)sp_rshift_round(x52 - n * HALF_PI_Q52, 22u);
    r2 = mul30(r, r);

    /* sin r = r (1 - r^2/3! + r^4/5! - ... - r^10/11!), Horner in r^2. */
    p = -INV_FACT11;
    p = INV_FACT9 + mul30(r2, p);
    p = -INV_FACT7 + mul30(r2, p);
    p = INV_FACT5 + mul30(r2, p);
    p = -INV_FACT3 + mul30(r2, p);
    p = SP_Q30_ONE + mul30(r2, p);
    s = mul30(r, p);

    /* cos r = 1 - r^2/2! + r^4/4! - ... + r^12/12!. */
    p = INV_FACT12;
    p = -INV_FACT10 + mul30(r2, p);
    p = INV_FACT8 + mul30(r2, p);
    p = -INV_FACT6 + mul30(r2, p);
    p = INV_FACT4 + mul30(r2, p);
    p = -INV_FACT2 + mul30(r2, p);
    c = SP_Q30_ONE + mul30(r2, p);

    quadrant = (int32_t)(((n % 4) + 4) % 4);
    switch (quadrant) {
    case 1: /* x = r + pi/2 */
        p = s;
        s = c;
        c = -p;
        break;
    case 2: /* x = r + pi */
        s = -s;
        c = -c;
        break;
    case 3: /* x = r + 3pi/2 */
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

/* Floor division by 2^t (0 <= t <= 62) with the remainder in [0, 2^t). */
static int64_t floor_div_pow2(int64_t v, unsigned t, int64_t *rem)
{
    int64_t d = INT64_C(1) << t;
    int64_t q = v / d;
    int64_t r = v - q * d;

    if (r < 0) {
        q -= 1;
        r += d;
    }
    *rem = r;
    return q;
}

int32_t sp_dot3(const int32_t a[3], const int32_t b[3], unsigned shift, sp_flags_t *flags)
{
    /* Each product is within [-2^62, 2^62]; three of them can exceed int64.
     * Sum exact halves instead: p = 2h + r with r in {0, 1}. */
    int64_t h = 0;
    int64_t r = 0;
    int64_t hq;
    int64_t hr;
    int64_t rem;
    int64_t half;
    unsigned k;

    for (k = 0u; k < 3u; ++k) {
        int64_t rk;
        h += floor_div_pow2((int64_t)a[k] * (int64_t)b[k], 1u, &rk);
        r += rk;
    }
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
    hq = floor_div_pow2(h, shift - 1u, &hr);
    rem = 2 * hr + r;
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

int64_t sp_mul64(int64_t x, int32_t k, unsigned shift, sp_flags_t *flags)
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

int64_t sp_div64(int64_t num, int32_t den, unsigned shift, sp_flags_t *flags)
{
    uint64_t n;
    uint64_t d;
    uint64_t q;
    uint64_t r;
    unsigned i;
    int neg;

    if (den == 0) {
        set_flag(flags, SP_FLAG_DOMAIN);
        return 0;
    }
    if (shift > 62u) {
        shift = 62u;
    }
    neg = ((num < 0) != (den < 0)) ? 1 : 0;
    n = (num < 0) ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    d = (den < 0) ? (uint64_t)0 - (uint64_t)(int64_t)den : (uint64_t)den;
    q = n / d;
    r = n % d; /* r < d <= 2^31 */
    /* Append `shift` zero bits to the dividend, a few at a time: each round
     * shifts by at most 31 bits so that r << s stays below 2^62. */
    i = shift;
    while (i > 0u) { /* at most 3 rounds */
        unsigned s = (i > 31u) ? 31u : i;
        uint64_t rs;
        if (q > (UINT64_C(1) << (63u - s))) { /* q << s > 2^63: beyond int64 */
            set_flag(flags, SP_FLAG_OVERFLOW);
            return neg ? INT64_MIN : INT64_MAX;
        }
        rs = r << s;
        q = (q << s) + rs / d;
        r = rs % d;
        i -= s;
    }
    /* Round to nearest, ties away from zero: compare 2r with d. */
    if (2u * r >= d) {
        q += 1u; /* q <= 2^63 + 2^31 here: cannot wrap */
    }
    return sat_signed_mag(q, neg, flags);
}
