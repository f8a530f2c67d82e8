/* SPDX-License-Identifier: Apache-2.0 */
/*
 * EVA harness of the 6x6 solver (firmware/core/src/model/lu6.c): the
 * factorisation (whole, in two calls and in three) and the three solves of
 * sp/model/lu6.h, on a Jacobian of arbitrary int32 entries (the header
 * bounds them only by int32: below 8 in Q28) and a right-hand side within
 * the documented |b| < 2^56 (larger is refused before any arithmetic),
 * either orientation. EVA
 * reports any signed overflow, invalid shift, division by zero or
 * out-of-bounds access it cannot rule out.
 */
#include "__fc_builtin.h"
#include "sp/model/lu6.h"

/* The documented range of b: |b| < 2^56 (sp/model/lu6.h). */
#define B_MAX ((INT64_C(1) << 56) - 1)

int main(void)
{
    sp_jacobian_t m;
    sp_lu6_t lu;
    sp_lu6_stage_t part;
    int64_t b[SP_LEGS];
    int64_t x[SP_LEGS];
    int transpose = Frama_C_nondet(0, 1);
    volatile int sink;
    unsigned i;
    unsigned j;

    for (i = 0u; i < SP_LEGS; ++i) {
        for (j = 0u; j < 6u; ++j) {
            m.j[i][j] = Frama_C_int_interval(INT32_MIN, INT32_MAX);
        }
        b[i] = Frama_C_long_long_interval(-B_MAX, B_MAX);
    }
    sink = sp_solve6(&m, transpose, b, x);
    if (sp_lu6_factor(&m, transpose, &lu) == SP_OK) {
        sink = sp_lu6_solve(&lu, b, x);
        sink = sp_lu6_solve_grow(&lu, b, x);
        sink = sp_lu6_solve_transposed(&lu, b, x);
    }
    if (sp_lu6_factor_begin(&m, transpose, &part) == SP_OK) {
        if (Frama_C_nondet(0, 1) != 0) {
            sink = sp_lu6_factor_step(&part); /* three calls (the end then finds it done or not begun) */
        }
        sink = sp_lu6_factor_end(&part, &lu);
    }
    return 0;
}
