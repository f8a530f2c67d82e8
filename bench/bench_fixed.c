/* SPDX-License-Identifier: Apache-2.0 */
/*
 * bench_fixed - prints, for each arithmetic function of sp/math/fixed.h, the
 * maximum error measured against a long double reference over random inputs
 * and the host cost in nanoseconds per call. Not a test: it asserts nothing.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>

#include "sp/math/fixed.h"
#include "../tests/support/test_util.h"

#define N_ACC 1000000
#define N_TIME 20000000

static volatile int32_t sink;

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static int32_t inputs_a[1024];
static int32_t inputs_b[1024];

typedef int32_t (*fn2_t)(int32_t, int32_t);

static int32_t f_add(int32_t a, int32_t b)
{
    return sp_add(a, b, NULL);
}
static int32_t f_mul_q24(int32_t a, int32_t b)
{
    return sp_mul_q24(a, b, NULL);
}
static int32_t f_mul_q30(int32_t a, int32_t b)
{
    return sp_mul_q30(a, b, NULL);
}
static int32_t f_div_q24(int32_t a, int32_t b)
{
    return sp_div_q24(a, b | 1, NULL);
}
static int32_t f_sqrt_q24(int32_t a, int32_t b)
{
    (void)b;
    return sp_sqrt_q24(a & INT32_MAX, NULL);
}
static int32_t f_sincos(int32_t a, int32_t b)
{
    sp_q30_t s;
    sp_q30_t c;
    (void)b;
    sp_sincos_q24(a, &s, &c);
    return s ^ c;
}
static int32_t f_dot3(int32_t a, int32_t b)
{
    int32_t u[3] = {a, b, a ^ b};
    int32_t v[3] = {b, a, a};
    return sp_dot3(u, v, 30u, NULL);
}

static double time_fn(fn2_t fn)
{
    double t0 = now_ns();
    for (int i = 0; i < N_TIME; ++i) {
        sink = fn(inputs_a[i & 1023], inputs_b[i & 1023]);
    }
    return (now_ns() - t0) / N_TIME;
}

int main(void)
{
    uint64_t rng = 42;
    long double e_mul24 = 0;
    long double e_mul30 = 0;
    long double e_div = 0;
    long double e_sqrt = 0;
    long double e_sin = 0;
    long double e_dot = 0;

    for (int i = 0; i < 1024; ++i) {
        inputs_a[i] = tu_i32(&rng);
        inputs_b[i] = tu_i32_logscale(&rng);
    }
    for (int i = 0; i < N_ACC; ++i) {
        int32_t a = tu_i32_logscale(&rng);
        int32_t b = tu_i32_logscale(&rng);
        int32_t big = tu_i32(&rng);
        sp_q30_t s;
        sp_q30_t c;
        long double x;
        int32_t u[3] = {a, b, big};
        int32_t v[3] = {b, big, a};
        /* errors of results inside int32 (outside, the result saturates) */
        if (fabsl(TU_LDEXP((long double)a * b, -24)) < 2e9L) {
            e_mul24 = fmaxl(e_mul24, fabsl(sp_mul_q24(a, b, NULL) - TU_LDEXP((long double)a * b, -24)));
        }
        if (fabsl(TU_LDEXP((long double)a * b, -30)) < 2e9L) {
            e_mul30 = fmaxl(e_mul30, fabsl(sp_mul_q30(a, b, NULL) - TU_LDEXP((long double)a * b, -30)));
        }
        if (b != 0 && fabsl(TU_LDEXP(a, 24) / b) < 2e9L) {
            e_div = fmaxl(e_div, fabsl(sp_div_q24(a, b, NULL) - TU_LDEXP(a, 24) / b));
        }
        e_sqrt = fmaxl(e_sqrt, fabsl(sp_sqrt_q24(big & INT32_MAX, NULL) - sqrtl(TU_LDEXP(big & INT32_MAX, 24))));
        sp_sincos_q24(big, &s, &c);
        x = TU_LDEXP(big, -24);
        e_sin = fmaxl(e_sin, fmaxl(fabsl(s - TU_LDEXP(sinl(x), 30)), fabsl(c - TU_LDEXP(cosl(x), 30))));
        {
            long double exact = TU_LDEXP((long double)a * b + (long double)b * big + (long double)big * a, -40);
            if (fabsl(exact) < 2e9L) {
                e_dot = fmaxl(e_dot, fabsl(sp_dot3(u, v, 40u, NULL) - exact));
            }
        }
    }

    printf("fixed-point arithmetic: max error vs long double over %d random inputs, host cost\n", N_ACC);
    printf("%-14s %-24s %14s %12s\n", "function", "format", "max err [LSB]", "ns/call");
    printf("%-14s %-24s %14s %12.2f\n", "sp_add", "any", "exact", time_fn(f_add));
    printf("%-14s %-24s %14.3Lf %12.2f\n", "sp_mul_q24", "Q24*Q24->Q24", e_mul24, time_fn(f_mul_q24));
    printf("%-14s %-24s %14.3Lf %12.2f\n", "sp_mul_q30", "Q30*Q30->Q30", e_mul30, time_fn(f_mul_q30));
    printf("%-14s %-24s %14.3Lf %12.2f\n", "sp_div_q24", "Q24/Q24->Q24", e_div, time_fn(f_div_q24));
    printf("%-14s %-24s %14.3Lf %12.2f\n", "sp_sqrt_q24", "Q24->Q24", e_sqrt, time_fn(f_sqrt_q24));
    printf("%-14s %-24s %14.3Lf %12.2f\n", "sp_sincos_q24", "Q24 rad->Q30 (sin+cos)", e_sin, time_fn(f_sincos));
    printf("%-14s %-24s %14.3Lf %12.2f\n", "sp_dot3", "3x(int32*int32)>>s", e_dot, time_fn(f_dot3));
    return 0;
}
