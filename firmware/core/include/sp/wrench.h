/*
 * sp/wrench.h - the external wrench estimate: the force and moment that the
 * outside world exerts on the platform (base frame, moment about o'),
 * measured through the cylinders every tick.
 *
 * The model forces F_model (sp_model_t: the inverse dynamics of the
 * reference with the legs' masses, plus the seals' friction, observed by
 * sp/friction.h or modelled by the feed-forward) are what the cylinders
 * must push for the motion alone; the drives measure F (pressures times
 * areas). Whatever the cylinders push beyond the model balances an
 * external wrench W: J^T F + W = J^T F_model, so
 *   W_raw = J^T (F_model - F),
 * J the leg Jacobian at the reference (rows [u_i, r_i x u_i]). The model
 * of the previous tick is used: the feedback of this tick was sampled
 * after the drives applied the previous setpoints. W_raw is low-pass
 * filtered by two equal first-order backward-Euler sections
 * (y += alpha (x - y), alpha = w dt / (1 + w dt), w = 2 pi f_c), which set
 * the estimate's bandwidth and noise. They are the sections of the
 * motion-error filter (sp/motion_error.h), so that the correction
 * dW = M6 da of the platform's true acceleration (sp_wrench_correct) passes
 * the same filter as the force it corrects: added after the filter, it
 * equals the correction added to W_raw before it (the filter is linear
 * and M6 changes little over its ~10 ms memory). Measured in closed loop
 * (tests/bus/test_wrench_loop.py, docs/model.md "The motion-error
 * correction"), this beats a single first-order section with dW added
 * before it (da then filtered three times) or after it (da lagging the
 * force path by 5 ms).
 */
#ifndef SP_WRENCH_H
#define SP_WRENCH_H

#include "sp/setpoint.h"

/** The estimate and the model it compares the next measurement with. */
typedef struct {
    sp_q8_t model_force[SP_LEGS]; /**< the previous tick's model forces, N, Q8 */
    int32_t wrench[6];            /**< the estimate: filtered plus the motion-error correction, N, N m, Q8 */
    int32_t stage1[6];            /**< the low-pass filter's first section, N, N m, Q8 */
    int32_t filtered[6];          /**< its second section: J^T (F_model - F) filtered, N, N m, Q8 */
    uint8_t have_model;           /**< 1 when model_force holds the previous tick's model */
    uint8_t valid;                /**< 1 once the estimate follows the measurements */
} sp_wrench_t;

/** No model, no estimate (wrench zeroed). No-op on NULL. */
void sp_wrench_reset(sp_wrench_t *w);

/**
 * The filter gain alpha (Q30) of cut-off frequency `hz` (Hz, Q24, > 0)
 * at the tick `tick_us` (us): w dt / (1 + w dt). SP_E_ARG on NULL, a
 * cut-off <= 0 or a tick of 0; SP_E_RANGE when w dt exceeds 8.
 */
sp_status_t sp_wrench_alpha(sp_q24_t hz, uint32_t tick_us, sp_q30_t *alpha);

/**
 * One tick: with a model kept from the previous tick, `measured` the
 * cylinder forces of this tick's feedback (N, Q8) and model->jac the
 * Jacobian at this tick's reference, updates the estimate (the first one
 * is taken unfiltered by both sections; w->wrench = w->filtered, without a
 * correction until
 * sp_wrench_correct) and marks it valid; then keeps the model forces for
 * the next tick. `friction` (N, Q8, positive opposing lengthening) is the
 * seals' friction of this tick from the friction observer (sp/friction.h):
 * the estimate then compares F with the model's inverse dynamics part
 * (model->rigid) plus that friction; with friction NULL it compares F with
 * model->force, the inverse dynamics plus the feed-forward's friction model
 * (use one or the other consistently: the kept forces follow the choice).
 * model NULL (no model this tick): nothing kept, the estimate is invalid
 * until two ticks with a model. |F_model + F_friction - F| is clamped to
 * 2 MN per cylinder (2^29 in Q8); J^T (...) is exact (int64) and rounded
 * once to Q8, each component held within [-2^30, 2^30 - 1] of Q8 (4.19 MN,
 * 4.19 MN m: beyond any wrench the cylinders can balance), so the filter
 * step raw - W fits an int32 and the filtered value, between W and raw,
 * cannot overflow (both sections). alpha (Q30) is held within [0, 1]. Nothing wraps; no
 * status (nothing can fail).
 */
void sp_wrench_step(sp_wrench_t *w, const sp_model_t *model, const sp_q8_t friction[SP_LEGS],
                    const sp_q8_t measured[SP_LEGS], sp_q30_t alpha);

/**
 * Adds the motion-error correction dw (N, N m, Q8; sp/motion_error.h) to
 * this tick's estimate, after the filter: w->wrench = w->filtered + dw,
 * each component held within [-2^30, 2^30 - 1] of Q8 (the filter's range).
 * The filter's state is not touched, so the correction of one tick never
 * reaches the next: call it after sp_wrench_step on every tick that has
 * one. No-op on NULL or while the estimate is invalid.
 */
void sp_wrench_correct(sp_wrench_t *w, const sp_q8_t dw[6]);

#endif /* SP_WRENCH_H */
