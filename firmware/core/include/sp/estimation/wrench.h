/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/estimation/wrench.h - the external wrench estimate: the force and moment that the
 * outside world exerts on the platform (base frame, moment about o'),
 * measured through the cylinders every tick.
 *
 * The model forces F_model (sp_model_t: the inverse dynamics of the
 * reference with the legs' masses, plus the seals' friction, observed by
 * sp/estimation/friction.h or modelled by the feed-forward) are what the cylinders
 * must push for the motion alone; the drives measure F (pressures times
 * areas). Whatever the cylinders push beyond the model balances an
 * external wrench W: J^T F + W = J^T F_model, so
 *   W_raw = J^T (F_model - F),
 * J the leg Jacobian at the reference (rows [u_i, r_i x u_i]). The model,
 * friction, Jacobian and measured forces are all of one tick: the feedback
 * of tick n is the state sampled for SYNC n, which the reference of tick n
 * describes (docs/reference/analysis.md, "Tracking error and its delay"). When the
 * platform's motion differs from the reference, the correction
 * dW = M6 da of the tracking error's acceleration (sp/estimation/motion_error.h) is
 * added to W_raw. da is a backward double difference, centred on the
 * previous tick, so the force path is kept for one tick and added to the
 * correction of the next: all terms then describe the same instant, one
 * tick (1 ms) before the output. With the force path of tick n and the
 * correction centred on n - 1 (the estimator before issue 14's
 * alignment), a yaw reversal's break-away, where the true inertial
 * moment changes by some 100 N m per tick, left up to 176 N m.
 * The sum passes one low-pass filter of SP_WRENCH_SECTIONS equal
 * first-order backward-Euler sections (y += alpha (x - y),
 * alpha = w dt / (1 + w dt), w = 2 pi f_c), which sets the estimate's
 * bandwidth and noise. Four sections at 80 Hz, not two at 40 Hz: da is a
 * double difference of 1 um-quantised lengths, white noise rising with f^2
 * in acceleration, which two sections leave flat above f_c (33 N RMS on
 * the default platform) and four bring down with f^-2 (14 N), with the
 * same delay at low frequency (4 (1 - alpha) / alpha = 7.96 ms), a wider
 * band (-3 dB at 28.4 Hz against 23.0 Hz) and a faster step (2.6 %
 * against 5.7 % left after 20 ms; 3.4 % 20 ms after a change of the
 * true wrench, one tick of which is the alignment above). In closed loop
 * (the wrench bus test) the unloaded maximum fell from 201 N / 152 N m
 * to 148 N / 78 N m with the filter and to 107 N / 75 N m aligned.
 * Since session 10 the drives send lengths in 0.1 um (a tenth of that
 * quantisation noise), and the estimate that is reported (CTRL_WRENCH)
 * is w->smooth: the filter's value through sp_wrench_smooth, which
 * averages the pressure sensors' noise further while the wrench holds
 * still and follows a jump; force control keeps w->wrench.
 */
#ifndef SP_WRENCH_H
#define SP_WRENCH_H

#include "sp/model/dynamics.h"

/** Sections of the wrench filter. */
#define SP_WRENCH_SECTIONS 4u

/** The estimate and the model it compares the next measurement with. Its
 *  fields are sp_wrench_reset's, sp_wrench_step's and sp_wrench_smooth's
 *  alone: the sections, wrench and slow stay within [-2^30, 2^30 - 1] of Q8
 *  because nothing else writes them, and the steps rely on it (no
 *  re-clamp of the state each tick). */
typedef struct {
    int64_t force_wrench[6];                /**< the previous tick's J^T (F_model - F), N, N m, Q8 */
    int32_t wrench[6];                      /**< the estimate (the last section), N, N m, Q8 */
    int32_t section[SP_WRENCH_SECTIONS][6]; /**< the filter's sections, N, N m, Q8 */
    int32_t smooth[6];                      /**< the reported estimate (sp_wrench_smooth), N, N m, Q8 */
    int32_t slow[6];                        /**< the smoother's section, N, N m, Q8 */
    uint8_t follow[6];                      /**< ticks left in which smooth equals wrench */
    uint8_t excess[6];                      /**< consecutive ticks with |wrench - smooth| beyond the jump */
    uint8_t have_force;                     /**< 1 when force_wrench holds the previous tick's */
    uint8_t valid;                          /**< 1 once the estimate follows the measurements */
    uint8_t smooth_valid;                   /**< 1 once smooth follows wrench */
} sp_wrench_t;

/** The reported estimate's smoother (sp_wrench_smooth). */
typedef struct {
    sp_q30_t alpha;  /**< gain of its one section (sp_wrench_alpha), Q30, held within [0, 1] */
    int32_t jump[2]; /**< force (N) and moment (N m) thresholds, Q8, in [1, 2^30] */
    uint8_t persist; /**< ticks beyond the threshold that make a jump, >= 1 */
    uint8_t hold;    /**< ticks smooth then equals wrench, >= 1 */
} sp_wrench_smooth_t;

/** No model, no estimate (wrench zeroed). No-op on NULL. */
void sp_wrench_reset(sp_wrench_t *w);

/**
 * The filter gain alpha (Q30) of cut-off frequency `hz` (Hz, Q24, > 0)
 * at the tick `tick_us` (us): w dt / (1 + w dt). SP_E_ARG on NULL, a
 * cut-off <= 0 or a tick of 0; SP_E_RANGE when w dt exceeds 8.
 */
sp_status_t sp_wrench_alpha(sp_q24_t hz, uint32_t tick_us, sp_q30_t *alpha);

/**
 * One tick: with `model` this tick's (model->rigid and model->force for
 * this tick's reference, model->jac at it), `measured` the cylinder forces
 * of this tick's feedback (N, Q8) and `friction` the seals' friction of
 * this tick, computes this tick's force path J^T (F_model - F) and keeps
 * it (exact in int64, rounded once to Q8); with the previous tick's force
 * path kept, filters it plus `correction` (the motion-error wrench dW of
 * this tick, whose double difference is centred on the previous tick; N,
 * N m, Q8; NULL: none) into w->wrench and marks it valid (the first
 * estimate starts every section at its raw value). The output therefore
 * describes the previous tick. `friction` (N, Q8, positive opposing
 * lengthening) comes from the friction observer (sp/estimation/friction.h): the
 * estimate then compares F with the model's inverse dynamics part
 * (model->rigid) plus that friction; with friction NULL it compares F with
 * model->force, the inverse dynamics plus the feed-forward's friction model.
 * model NULL (no model this tick): nothing kept, the estimate is invalid
 * until two ticks with a model. |F_model + F_friction - F| is clamped to
 * 2 MN per cylinder (2^29 in Q8); with the correction added, each
 * component is held within [-2^30, 2^30 - 1] of Q8 (4.19 MN, 4.19 MN m:
 * beyond any wrench the cylinders can balance), so each section's step
 * x - y fits an int32 and its value, between its last value and x, cannot
 * overflow. alpha (Q30) is held within [0, 1]. Nothing wraps; no status
 * (nothing can fail).
 */
void sp_wrench_step(sp_wrench_t *w, const sp_model_t *model, const sp_q8_t friction[SP_LEGS],
                    const sp_q8_t measured[SP_LEGS], const sp_q8_t correction[6], sp_q30_t alpha);

/**
 * The reported estimate w->smooth (N, N m, Q8) from w->wrench, after each
 * sp_wrench_step. While the wrench holds still, smooth is w->wrench through
 * one more first-order section (p->alpha, its value w->slow): less of the
 * pressure sensors' noise, which the 20 ms filter of sp_wrench_step cannot
 * average much further (docs/explanation/model.md). A change of the wrench is a jump:
 * per component, when |wrench - slow| exceeds p->jump (force components
 * 0..2 jump[0], moments 3..5 jump[1]) for p->persist ticks in a row, slow
 * and smooth take wrench's value for p->hold ticks, so a step of the load
 * reaches smooth p->persist - 1 ticks after it reaches wrench by the jump;
 * in the ticks before, smooth is held at p->jump from wrench (a noise peak
 * of wrench shorter than p->persist ticks leaves slow alone). Hence
 * |smooth - wrench| <= jump at every tick. The first tick with w->valid
 * (and every tick without) sets smooth and slow to wrench. w->wrench must
 * lie within [-2^30, 2^30 - 1] (sp_wrench_step's range); values stay
 * within it; nothing wraps. No-op on NULL; p's fields
 * outside their ranges are used as their nearest valid value.
 */
void sp_wrench_smooth(sp_wrench_t *w, const sp_wrench_smooth_t *p);

#endif /* SP_WRENCH_H */
