/* SPDX-License-Identifier: Apache-2.0 */
/*
 * EVA harness of the fixed-point primitives (firmware/core/src/math/fixed.c):
 * each public function once, on every input its header allows (the whole
 * range of each integer argument, any shift 0..62 and beyond, the flag
 * pointer NULL or not). EVA then reports any signed overflow, shift out of
 * range, division by zero or invalid access it cannot rule out.
 */
#include "__fc_builtin.h"
#include "sp/math/fixed.h"

static int32_t any32(void)
{
    return Frama_C_int_interval(INT32_MIN, INT32_MAX);
}

static int64_t any64(void)
{
    return Frama_C_long_long_interval(INT64_MIN, INT64_MAX);
}

int main(void)
{
    sp_flags_t word = 0u;
    sp_flags_t *flags = Frama_C_nondet(0, 1) ? &word : NULL;
    unsigned shift = Frama_C_unsigned_int_interval(0u, 70u);
    int32_t v3a[3] = {any32(), any32(), any32()};
    int32_t v3b[3] = {any32(), any32(), any32()};
    sp_q30_t s;
    sp_q30_t c;
    volatile int64_t sink;

    sink = sp_flags_status(word);
    sink = sp_sat32(any64(), flags);
    sink = sp_add(any32(), any32(), flags);
    sink = sp_sub(any32(), any32(), flags);
    sink = sp_neg(any32(), flags);
    sink = sp_abs(any32(), flags);
    sink = sp_rshift_round(any64(), shift);
    sink = sp_mul(any32(), any32(), shift, flags);
    sink = sp_mul_q30(any32(), any32(), flags);
    sink = sp_div(any64(), any32(), shift, flags);
    sink = sp_isqrt64(Frama_C_unsigned_long_long_interval(0u, UINT64_MAX));
    sink = sp_sqrt_q24(any32(), flags);
    sp_sincos_q24(any32(), &s, &c);
    sink = s;
    sink = c;
    sp_sincos_q24(any32(), NULL, NULL);
    sink = sp_dot3(v3a, v3b, shift, flags);
    sink = sp_add64(any64(), any64(), flags);
    sink = sp_mul64(any64(), any32(), shift, flags);
    sink = sp_div64(any64(), any32(), shift, flags);
    sink = sp_narrow(any64(), shift, flags);
    return 0;
}
