/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/model/lu6.h - the 6x6 linear solver of the core: Gaussian elimination with
 * partial pivoting in fixed point, as a one-shot solve (sp_solve6) or as a
 * factorisation (sp_lu6_factor) that later solves reuse, also for the
 * transposed system. The inverse dynamics solve J^T F = wrench with it, and
 * the forward kinematics' Newton steps solve J d = residual.
 *
 * Pure functions, no allocation; every failure is a status and a zeroed
 * result, never a half-computed one.
 */
#ifndef SP_LU6_H
#define SP_LU6_H

#include "sp/math/fixed.h"
#include "sp/model/platform.h"

/** A 6x6 matrix in Q28, j[row][column]: the leg Jacobian of
 *  sp/model/kinematics.h (sp_jacobian) is the one the core solves with. */
typedef struct {
    int32_t j[SP_LEGS][6];
} sp_jacobian_t;

/**
 * Solves the 6x6 system M x = b (or M^T x = b when transpose != 0) by
 * Gaussian elimination with partial pivoting. M in Q28, b and x in the same
 * (any) Q format, int64, |b| < 2^56 (else SP_E_OVERFLOW). A pivot below
 * SP_PIVOT_MIN (1e-3 in Q28) means a singular or ill-conditioned matrix:
 * SP_E_SINGULAR and x is zeroed. Intermediates that saturate give
 * SP_E_OVERFLOW (x zeroed). One reciprocal per pivot (31 bits, relative
 * error below 2^-28) replaces the divisions. The solve (sp_lu6_solve)
 * runs in 32-bit intermediates scaled to max |b| (29 significant bits of
 * b, x keeps as many relative to max |b|), with the int64 solve as its
 * fallback when an intermediate would leave its range: x is within a few
 * parts in 10^8 of max |b| of the exact solution for a well-conditioned M
 * (tests/unit/test_lu6.c, test_solves_reference, against a plain long
 * double solve).
 */
#define SP_PIVOT_MIN ((int32_t)268435) /* 1e-3 in Q28 */
sp_status_t sp_solve6(const sp_jacobian_t *m, int transpose, const int64_t b[SP_LEGS], int64_t x[SP_LEGS]);

/** A pivoted LU factorisation of a 6x6 matrix A in Q28, as sp_solve6
 *  computes it: P A = L U, with (P A)_k = A_perm[k] (the k-th pivot row is
 *  row perm[k] of A). The rows are stored in pivot order, so that the
 *  solves read them at constant offsets: a[k] holds row k of U on and
 *  above the diagonal (Q28) and row k of L's multipliers below it (Q30,
 *  |l| <= 1, unit diagonal implied); inv and zk are each pivot's
 *  normalised reciprocal (see sp_solve6). valid is 1 only after a
 *  successful sp_lu6_factor. */
typedef struct {
    int32_t a[SP_LEGS][SP_LEGS];
    int32_t inv[SP_LEGS];
    uint8_t zk[SP_LEGS];
    uint8_t perm[SP_LEGS];
    uint8_t valid;
} sp_lu6_t;

/**
 * Factorises A = M (transpose == 0) or A = M^T (transpose != 0), M in Q28,
 * exactly as sp_solve6 does. Errors: SP_E_ARG (NULL), SP_E_SINGULAR (a
 * pivot below SP_PIVOT_MIN), SP_E_OVERFLOW (an eliminated entry saturated);
 * lu->valid is then 0. Each eliminated entry is a_ij - round(l a_kj / 2^30)
 * (ties up), exact apart from that rounding; a step whose entries are known
 * to stay below 2^31 (a running upper bound of their magnitudes: the
 * matrix's, plus each pivot row's) runs without saturation checks, with the
 * same bits.
 */
sp_status_t sp_lu6_factor(const sp_jacobian_t *m, int transpose, sp_lu6_t *lu);

/** The pivot steps a staged factorisation takes before its last call
 *  (sp_lu6_factor_end): columns 0 (sp_lu6_factor_begin) and 1
 *  (sp_lu6_factor_step, or the end itself); step k updates (5 - k)^2
 *  entries, so the first two are about half the work. */
#define SP_LU6_STAGE_STEPS 2u

/** A factorisation in progress (sp_lu6_factor_begin): the rows of A
 *  after the pivot steps taken so far, in place (not moved: row order[i]
 *  of a is the i-th in pivot order so far), and those steps' reciprocals.
 *  Not a factorisation: the solves do not take it. */
typedef struct {
    int32_t a[SP_LEGS][SP_LEGS];
    int32_t inv[SP_LU6_STAGE_STEPS];
    uint8_t zk[SP_LU6_STAGE_STEPS];
    uint8_t order[SP_LEGS];
    uint8_t steps; /**< pivot steps taken: 1 after sp_lu6_factor_begin, SP_LU6_STAGE_STEPS after sp_lu6_factor_step */
    uint8_t begun; /**< 1 after a successful sp_lu6_factor_begin, until sp_lu6_factor_end or a failed step */
} sp_lu6_stage_t;

/**
 * sp_lu6_factor in two or three calls (the controller spreads it over
 * three ticks): sp_lu6_factor_begin copies A (as sp_lu6_factor) into
 * *part and takes pivot step 0; sp_lu6_factor_step, when called, takes
 * step 1; sp_lu6_factor_end takes the others (step 1 too when no
 * sp_lu6_factor_step took it) on *part (used up: part->begun 0) and
 * writes the factorisation into *lu, bit-identical to sp_lu6_factor's of
 * the same A (tests/unit/test_lu6.c). Errors: SP_E_ARG (NULL, a step or
 * an end without a successful begin, a second step), SP_E_SINGULAR (a
 * pivot below SP_PIVOT_MIN, in any call), SP_E_OVERFLOW (an entry
 * saturated: reported by the call that saturated it, so that an earlier
 * call's SP_E_OVERFLOW may be a matrix that sp_lu6_factor finds
 * singular); part->begun or lu->valid is then 0.
 */
sp_status_t sp_lu6_factor_begin(const sp_jacobian_t *m, int transpose, sp_lu6_stage_t *part);
sp_status_t sp_lu6_factor_step(sp_lu6_stage_t *part);
sp_status_t sp_lu6_factor_end(sp_lu6_stage_t *part, sp_lu6_t *lu);

/**
 * Solves A x = b with a factorisation of A: bit-identical to sp_solve6 on
 * the same matrix and b (the accuracy stated there). b and x in the same
 * (any) Q format, int64, |b| < 2^56; b = 0 gives x = 0. Errors (x
 * zeroed): SP_E_ARG (NULL or lu not valid), SP_E_OVERFLOW (b out of range
 * or an intermediate of the int64 fallback saturated).
 */
sp_status_t sp_lu6_solve(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS]);

/**
 * sp_lu6_solve for a right-hand side whose solution may be many times
 * larger than it (a residual: sp_inverse_dynamics_held's refinement):
 * the 32-bit path scales max |b| into [2^24, 2^25) instead of [2^28,
 * 2^29), so it takes the int64 path only for a solution more than about
 * 16 times larger than sp_lu6_solve allows. Not bit-identical to
 * sp_lu6_solve: each step rounds within 2^-24 of max |b| (instead of
 * 2^-28), times the elimination's growth (tests/unit/test_lu6.c). Same
 * formats, ranges and errors.
 */
sp_status_t sp_lu6_solve_grow(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS]);

/**
 * Solves A^T x = b with a factorisation of A (U^T, then L^T, then the row
 * swaps undone): the transposed system at the cost of one solve, no new
 * factorisation. Same formats, ranges and errors as sp_lu6_solve. Not
 * bit-identical to sp_solve6 on A^T: int64 intermediates throughout
 * (no 32-bit path), within a few parts in 10^9 of |x| of the exact
 * solution for a well-conditioned A (tests/unit/test_lu6.c,
 * test_solves_reference).
 */
sp_status_t sp_lu6_solve_transposed(const sp_lu6_t *lu, const int64_t b[SP_LEGS], int64_t x[SP_LEGS]);

#endif /* SP_LU6_H */
