/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/force/admittance.h - admittance (hybrid force/position) control: how far
 * the reference pose yields to the wrench that the world exerts on the
 * platform, axis by axis, and the contact it is in.
 *
 * Per axis k of the base frame (x, y, z in m; roll, pitch, yaw in rad),
 * the offset d of the reference pose from the position reference obeys
 *
 *     M d'' + D d' + K d = W_ext + W_target
 *
 * with W_ext the wrench the world exerts on the platform (sp/estimation/wrench.h or a
 * force/torque sensor: N, N m, base frame, about o') and W_target the
 * wrench the platform is to exert on the world (the tool's push). At rest
 * in contact W_ext = -W_target - K d: with K = 0 the platform pushes
 * exactly W_target. Free of contact, a constant W_target moves the axis at
 * W_target / D (the approach speed); with W_target = 0 a push by a person
 * moves it at W_ext / D (hand guiding).
 *
 * Why the damping adapts: in contact with a surface of stiffness k_e, the
 * force loop (this law, the drives' position loop, the surface and the
 * wrench filter) is an integrator of gain k_e / D. One D cannot serve
 * surfaces from 1e5 to 1e7 N/m: the loop is either too slow on the soft
 * one or unstable on the stiff one. So each axis estimates k_e while it is
 * in contact, as the secant of the wrench against the measured pose since
 * contact was made, both through the same low-pass filter (the wrench
 * filter's delay would otherwise make the secant read low while the axis
 * moves), and then uses D = k_e / w_c: the loop's crossover sits at w_c,
 * whatever the surface (docs/explanation/force_control.md).
 *
 * Discretisation (tick dt): backward Euler in the velocity, unconditionally
 * stable for any M > 0, D >= 0:
 *     v[n+1] = (M v[n] + dt (F - K d[n])) / (M + dt D),  F = W_ext + W_target
 *     d[n+1] = d[n] + dt v[n+1]
 * The coefficients M / (M + dt D), dt / (M + dt D) and dt K / (M + dt D) are
 * computed only when the adapted D changes by more than 1/16 (three
 * divisions per change); those of the free-space damping and of the return
 * to d = 0 are prepared once (sp_admit_configure, sp_admit_coefficients).
 * Then, in this order: |v| <= v_max; towards a bound [lo, hi] of d (the
 * deflection limit and the workspace, given by the caller each tick) v is
 * held to the braking speed sqrt(2 a_brake (bound - d)) and, on the last
 * stretch, to (bound - d) / tau (SP_ADMIT_TAIL_RATE), so the axis comes to
 * the bound without passing it, and so does the platform that lags it; d
 * is held within [lo, hi].
 *
 * Axes outside the force mask, and every axis in release, return to d = 0
 * through a critically damped spring of the axis's release stiffness (no
 * wrench input), so leaving force control moves smoothly back onto the
 * position reference. In hold (the reaction to a lost contact or an
 * excessive force) every axis brakes at a_brake to rest and stays where it
 * stopped.
 */
#ifndef SP_ADMITTANCE_H
#define SP_ADMITTANCE_H

#include "sp/math/fixed.h"
#include "sp/math/status.h"

#define SP_AXES 6u

/** 1 / tau of the last stretch towards a bound, 1/s: |v| <= dist / tau
 *  there, so the reference reaches the bound exponentially (tau = 40 ms)
 *  and the platform, lagging it, does not pass it. */
#define SP_ADMIT_TAIL_RATE 25u

/** Parameters of one axis (units: m and N for x, y, z; rad and N m for roll, pitch, yaw). */
typedef struct {
    sp_q16_t mass;             /**< virtual mass M, kg or kg m^2, Q16, within [1, 32767] */
    int32_t damping;           /**< D in free space (approach, hand guiding), N s/m or N m s/rad, >= 1 */
    int32_t stiffness;         /**< K, spring to the position reference, N/m or N m/rad, >= 0 */
    int32_t release_stiffness; /**< spring of the return to d = 0, N/m or N m/rad, >= 1 */
    sp_q24_t v_max;            /**< speed limit of d, m/s or rad/s, Q24, > 0 */
    sp_q24_t
        a_brake; /**< largest |d''| of a forced axis, and the deceleration towards a bound and in hold, m/s^2 or rad/s^2, Q24, > 0 */
} sp_admit_axis_t;

/** Parameters of the admittance (sp_admit_configure checks them). */
typedef struct {
    sp_admit_axis_t axis[SP_AXES];
    sp_q16_t crossover;     /**< w_c of the force loop in contact, rad/s, Q16, > 0 */
    int32_t k_min;          /**< lowest surface stiffness believed, N/m (N m/rad), >= 1 */
    int32_t k_max;          /**< highest, N/m (N m/rad), >= k_min */
    sp_q8_t secant_force;   /**< |change of wrench| since contact before the secant is trusted, N (N m), Q8, > 0 */
    sp_q24_t secant_travel; /**< |travel| since contact before the secant is trusted, m (rad), Q24, > 0 */
    sp_q30_t filter_alpha;  /**< the wrench filter's section gain (sp_wrench_alpha), Q30, (0, 1] */
    uint32_t tick_us;       /**< dt, us, within [100, 100000] */
    /** the wrench's noise bound, N (N m), Q8, >= 0: the secant becomes
     *  (|change of wrench| + margin) / |travel|, an upper bound of k_e
     *  while the noise stays within it (the loop then crosses over at w_c
     *  or below), trusted once the travel reaches secant_travel; 0: the
     *  plain secant, trusted after secant_force too */
    sp_q8_t secant_margin;
    /** in contact, with the secant trusted, the part of the force error
     *  beyond boost_band counts `boost` times: the loop crosses over at
     *  about boost w_c while far from the target and at w_c near it; only
     *  the part that the force predicted at the reference shares (the
     *  wrench plus k_hat times d less the filtered x_meas, so x_meas must
     *  then be the pose less the position reference, as sp_force_step
     *  passes it with contact_ff); 0 or 1: off, at most 16 */
    uint8_t boost;
    sp_q8_t boost_band; /**< see boost, N (N m), Q8, >= 0 */
} sp_admit_config_t;

/** Coefficients of the discretised law for one damping. */
typedef struct {
    int32_t damping; /**< the D they were computed for, N s/m */
    sp_q30_t c_v;    /**< M / (M + dt D), Q30 */
    int32_t c_f;     /**< dt / (M + dt D), s/kg, Q40 (fits: M >= 1 kg) */
    int32_t c_k;     /**< dt K / (M + dt D), 1/s, Q30 */
} sp_admit_coef_t;

/** State of one axis. */
typedef struct {
    sp_q24_t d;                /**< offset from the position reference, m or rad, Q24 */
    sp_q24_t v;                /**< its rate, m/s or rad/s, Q24 */
    sp_q24_t a;                /**< its acceleration this tick, m/s^2 or rad/s^2, Q24 */
    sp_admit_coef_t coef;      /**< for the damping in use */
    sp_admit_coef_t free_coef; /**< for the free-space damping (approach or guiding), prepared */
    sp_admit_coef_t rel;       /**< for the return to d = 0 (critically damped), prepared */
    sp_q24_t dv_brake;         /**< a_brake dt: the speed hold takes off each tick, m/s or rad/s, Q24 */
    int32_t x_f[4];            /**< the measured pose through the wrench filter's sections, Q24 */
    sp_q24_t x_contact;        /**< x_f when contact was made, Q24 */
    sp_q8_t w_contact;         /**< the filtered wrench when contact was made, Q8 */
    int32_t k_hat;             /**< the surface stiffness estimate, N/m (0: none yet) */
    int32_t window_w;          /**< the crossover the windows below were made for, rad/s, Q16 (0: none) */
    int32_t window_c;          /**< ... the damping in use (coef.damping) */
    int32_t window_f;          /**< ... and the free-space damping (free_coef.damping), N s/m */
    uint32_t keep_lo;          /**< the stiffnesses k whose damping k / w_c is within coef.damping's
                                    tolerance: keep_lo <= k < keep_hi, N/m */
    uint32_t keep_hi;          /**< (see keep_lo) */
    uint32_t free_lo;          /**< ... and those whose damping is the free-space one: free_lo <= k < free_hi */
    uint32_t free_hi;          /**< (see free_lo) */
    uint8_t in_contact;        /**< 1 from contact made until it is lost or force control ends */
} sp_admit_axis_state_t;

/** State of the admittance. */
typedef struct {
    sp_admit_axis_state_t axis[SP_AXES];
    int64_t dt_q50;   /**< the tick, s, Q50 (prepared: the numerator of the coefficient c_f) */
    int32_t dt_q38;   /**< the tick, s, Q38 (prepared) */
    int32_t rate_q16; /**< 1 / tick, 1/s, Q16 (prepared) */
    uint8_t primed;   /**< bit k: x_f of axis k holds the measured pose (the axis is forced since) */
} sp_admit_t;

/** What the axes do in a step. */
typedef enum {
    SP_ADMIT_FORCE = 0,   /**< masked axes follow the law, the others return to d = 0 */
    SP_ADMIT_RELEASE = 1, /**< every axis returns to d = 0 (leaving force control) */
    SP_ADMIT_HOLD = 2     /**< every axis brakes to rest and holds its d */
} sp_admit_mode_t;

/** What one step reports, per axis bit (bit k = axis k). */
typedef struct {
    uint8_t limited; /**< the axis was held by v_max, a braking speed or a bound */
    uint8_t adapted; /**< the damping in use changed this tick */
} sp_admit_report_t;

/**
 * Checks cfg, prepares every coefficient the steps use (per axis: the
 * free-space damping's and the release's, three divisions each; the tick's
 * constants) and sets every axis to d = v = 0, no contact, the free-space
 * damping. Call it when the config changes (at init), not in a tick: it
 * costs twelve coefficient sets. SP_E_ARG (nothing changed) on NULL or a
 * parameter outside its documented range; SP_E_OVERFLOW when a coefficient
 * does not fit its format (M + dt D beyond 2^31 kg, i.e. D above about
 * 2e12 N s/m).
 */
sp_status_t sp_admit_configure(const sp_admit_config_t *cfg, sp_admit_t *st);

/**
 * The coefficients of axis `axis` of cfg (its mass and stiffness; the tick
 * as prepared in st, which sp_admit_configure made from cfg) for the
 * damping `damping` (N s/m or N m s/rad, >= 1): what sp_admit_configure and
 * a step's adaptation compute, for a caller that prepares the coefficients
 * of another free-space damping (hand guiding). SP_E_ARG on NULL, an axis
 * >= SP_AXES or a damping < 1; SP_E_OVERFLOW as sp_admit_configure (*c
 * unchanged on failure).
 */
sp_status_t sp_admit_coefficients(const sp_admit_config_t *cfg, const sp_admit_t *st, unsigned axis, int32_t damping,
                                  sp_admit_coef_t *c);

/**
 * Starts afresh without computing anything: every axis to d = v = a = 0, no
 * contact, no stiffness estimate, the filter of the pose unprimed, and the
 * damping in use the free-space one. With `free_coef` non-NULL, free_coef[k] becomes
 * axis k's free-space coefficients (prepared by sp_admit_coefficients for
 * this config); with NULL, each axis keeps the ones it has. The release
 * coefficients and the tick's constants are kept. SP_E_ARG on NULL st.
 */
sp_status_t sp_admit_restart(sp_admit_t *st, const sp_admit_coef_t free_coef[SP_AXES]);

/**
 * One tick, with cfg the config st was configured with (its prepared
 * coefficients are used as they are).
 *   mode     what the axes do (sp_admit_mode_t; another value: SP_E_ARG);
 *   mask     bit k: axis k is force-controlled in SP_ADMIT_FORCE;
 *   w_ext    the filtered wrench the world exerts on the platform, N / N m, Q8;
 *   w_target the wrench the platform is to exert, N / N m, Q8;
 *   x_meas   the measured (estimated) pose, m / rad, Q24 (or the pose
 *            less the position reference: the secant uses only its
 *            changes; the boost needs that one), used for the
 *            stiffness secant of the forced axes, whose filter it passes
 *            (primed the first tick an axis is forced; may be NULL: no
 *            adaptation this tick);
 *   contact  bit k: the axis is in contact (sp_contact_step decides);
 *   lo, hi   bounds of d this tick, Q24, lo <= 0 <= hi (a bound the
 *            position reference has already passed counts as 0).
 * Writes st (d, v, a per axis) and *report (may be NULL). Work per tick: an
 * axis at rest on the position reference (d = v = 0) that follows it stays
 * there without computing; a forced axis runs its filter and, in contact,
 * the secant (two divisions); a change of the adapted damping by more than
 * 1/16 costs three more.
 * Inputs are clamped: a wrench sum beyond +-2^30 Q8 (4.19 MN) is held there;
 * d, v, a saturate at the Q24 extremes. Nothing wraps.
 * Returns SP_E_ARG (nothing changed) on NULL (other than x_meas, report);
 * SP_E_OVERFLOW when a coefficient could not be recomputed (the old
 * damping is kept: safe); else SP_OK.
 */
sp_status_t sp_admit_step(const sp_admit_config_t *cfg, sp_admit_t *st, sp_admit_mode_t mode, uint8_t mask,
                          const sp_q8_t w_ext[SP_AXES], const sp_q8_t w_target[SP_AXES], const sp_q24_t x_meas[SP_AXES],
                          uint8_t contact, const sp_q24_t lo[SP_AXES], const sp_q24_t hi[SP_AXES],
                          sp_admit_report_t *report);

/** Contact supervision parameters. */
typedef struct {
    sp_q8_t made;        /**< contact made when the push-back reaches this, N, Q8, > 0 */
    sp_q30_t lost_ratio; /**< contact lost when the push-back falls below this share of the target, Q30, (0, 1) */
    uint8_t lost_ticks;  /**< ... for this many consecutive ticks, >= 1 */
    uint8_t arm_ticks;   /**< the lost level counts once the push-back held it this many ticks on end (0, 1: at once) */
    sp_q8_t excess;      /**< excessive force: |force part of W_ext| above this, N, Q8, > made */
    /** contact is made also when the push-back through a first-order
     *  low-pass of time constant 2^slow_shift ticks reaches made_slow (a
     *  lower level than made, for a noisy wrench: on a soft surface the
     *  force rises slowly and the filter's lag costs little), and, until
     *  armed, lost only when that filtered push-back is below made_slow / 2
     *  as well as the push-back below made / 2 (contact made by either
     *  level is lost when both fall). N, Q8; 0: off */
    sp_q8_t made_slow;
    uint8_t slow_shift; /**< see made_slow, 1..15 (0: off; above 15 the low 4 bits) */
} sp_contact_config_t;

/** Contact supervision state. */
typedef struct {
    uint8_t made;  /**< 1 while in contact */
    uint8_t armed; /**< 1 once the push-back held the lost level arm_ticks ticks in this contact */
    uint8_t low;   /**< consecutive ticks below the level that counts */
    uint8_t high;  /**< consecutive ticks at or above the lost level (until armed) */
    int64_t slow;  /**< the push-back times |F_target| through the made_slow low-pass, Q16 (0 with no target) */
} sp_contact_t;

/** Events of sp_contact_step. */
#define SP_CONTACT_MADE 0x1u   /**< the push-back reached `made` this tick */
#define SP_CONTACT_LOST 0x2u   /**< in contact, the push-back fell away while a push is commanded */
#define SP_CONTACT_EXCESS 0x4u /**< the force exceeded `excess` */

/**
 * One tick of contact supervision along the commanded push:
 * p = -(F_ext . F_target) / |F_target| (the world pushing back against the
 * tool, N; force parts only, the first three components). Contact is made
 * when p >= made; lost when, in contact, p stays for lost_ticks
 * consecutive ticks below lost_ratio |F_target| once it has reached that
 * level in this contact (armed), or below made / 2 before (the state then
 * leaves contact; with made_slow, also made when the low-passed p reaches
 * made_slow, and lost before armed only when it is below made_slow / 2
 * too, see sp_contact_config_t); excess
 * when |F_ext| > excess, in any state. With F_target = 0 (hand guiding)
 * only excess is checked. Returns the events (0 on NULL). |F| is computed
 * in 64 bits (no overflow for any Q8 input); the comparison of p with the
 * lost level is done without a division.
 */
uint32_t sp_contact_step(const sp_contact_config_t *cfg, sp_contact_t *st, const sp_q8_t w_ext[SP_AXES],
                         const sp_q8_t w_target[SP_AXES]);

/** A target's force part as sp_contact_step uses it, prepared once per target. */
typedef struct {
    int32_t t[3];   /**< the force part, each component held within +-2^30, N, Q8 */
    int64_t t2;     /**< |t|^2, Q16 */
    int64_t t_norm; /**< |t|, rounded, N, Q8 */
} sp_contact_target_t;

/** Prepares w_target (the first three components) for sp_contact_step_to. No-op on NULL. */
void sp_contact_target(const sp_q8_t w_target[SP_AXES], sp_contact_target_t *tp);

/**
 * sp_contact_step with the target prepared by sp_contact_target: the same
 * events and state, without the target's norm (a square root) each tick.
 * Returns 0 on NULL.
 */
uint32_t sp_contact_step_to(const sp_contact_config_t *cfg, sp_contact_t *st, const sp_q8_t w_ext[SP_AXES],
                            const sp_contact_target_t *tp);

#endif /* SP_ADMITTANCE_H */
