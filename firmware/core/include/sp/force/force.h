/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/force/force.h - force control as the controller runs it: the admittance
 * (sp/force/admittance.h) laid over the position reference in the axes a mask
 * names, contact supervision, and the modes an operator switches between.
 *
 * Modes:
 *   OFF      position control: the reference is the position reference.
 *   FORCE    the masked axes yield to W_ext + W_target (the target is the
 *            wrench the platform is to exert on the world); the others follow
 *            the position reference.
 *   GUIDE    hand guiding: every masked axis yields to the push of a person
 *            (W_target = 0) with the guide damping of the config; braking
 *            at the workspace and deflection bounds.
 *   RELEASE  leaving force control: every axis returns to the position
 *            reference (critically damped); then OFF, or RETRACTED after an
 *            excessive force (the controller then latches its fault).
 *   HOLD     after a lost contact: every axis brakes to rest where it is.
 * The offset d of each axis is bounded by the deflection limit of the config
 * and by the workspace box (sp_limits_t) around the position reference, each
 * less SP_FORCE_BOUND_MARGIN, so a
 * force-controlled reference never leaves the workspace; the controller
 * still passes every reference through all of its limits. The rotational
 * axes act on the roll, pitch, yaw angles of the pose (Z-Y-X), which are the
 * base frame's rotations about x, y, z to first order near a level platform.
 */
#ifndef SP_FORCE_H
#define SP_FORCE_H

#include "sp/force/admittance.h"
#include "sp/motion/limits.h"
#include "sp/model/platform.h"

/** The offset stops this far inside the deflection limit and the workspace
 *  (m or rad, Q24: 0.2 mm, 0.2 mrad): the platform lags the reference by
 *  tens of um (more on the cylinders' noisy estimate), so it stops inside
 *  the bound too. */
#define SP_FORCE_BOUND_MARGIN ((sp_q24_t)3355)

typedef enum {
    SP_FORCE_OFF = 0,
    SP_FORCE_FORCE = 1,
    SP_FORCE_GUIDE = 2,
    SP_FORCE_RELEASE = 3,
    SP_FORCE_HOLD = 4
} sp_force_mode_t;

/** Events of sp_force_step (besides SP_CONTACT_*: made, lost, excess). */
#define SP_FORCE_RELEASED 0x10u  /**< RELEASE has reached the position reference: OFF */
#define SP_FORCE_RETRACTED 0x20u /**< ... after an excessive force: OFF, the fault is the controller's */

/** Force-control configuration. */
typedef struct {
    sp_admit_config_t admit;        /**< FORCE: the law's parameters (free damping = approach) */
    sp_contact_config_t contact;    /**< contact supervision */
    int32_t guide_damping[SP_AXES]; /**< GUIDE: damping per axis, N s/m or N m s/rad, >= 1 */
    sp_q24_t deflection[SP_AXES];   /**< largest |d| per axis, m or rad, Q24, > 0 */
    sp_q8_t target_max_force;       /**< largest |force part| of a target, N, Q8 (below contact.excess) */
    sp_q8_t target_max_moment;      /**< largest |moment component| of a target, N m, Q8 */
    sp_q24_t settled;               /**< RELEASE ends when every |d| is below this (m or rad), Q24 */
    /** 1: in FORCE, in contact, the controller adds the contact wrench's
     *  share to the legs' force setpoints (with its force feed-forward on)
     *  and the admittance gets the measured pose less the position
     *  reference (the boost's lead); 0: neither (the sensor's default: its
     *  figures do not need it, and a Cortex-M4 force tick pays about 370
     *  instructions for it) */
    uint8_t contact_ff;
} sp_force_config_t;

/** Force-control state. */
typedef struct {
    sp_force_mode_t mode;
    uint8_t mask;                        /**< the force-controlled axes (bit k: axis k) */
    uint8_t retract_fault;               /**< RELEASE was started by an excessive force */
    sp_q8_t target[SP_AXES];             /**< W_target, N and N m, base frame, Q8 */
    sp_admit_t st;                       /**< the law's state (the config's admit) */
    sp_contact_t contact;                /**< contact supervision */
    sp_contact_target_t push;            /**< the target's force part, prepared for contact supervision */
    sp_admit_coef_t free_force[SP_AXES]; /**< FORCE: the approach damping's coefficients (prepared) */
    sp_admit_coef_t free_guide[SP_AXES]; /**< GUIDE: the guide damping's coefficients (prepared) */
} sp_force_t;

/**
 * Defaults for a hydraulic hexapod of a few tonnes: approach at 2 mm/s per
 * 2 kN (free damping 1e6 N s/m; 1e5 N m s/rad), M = 20 kg (5 kg m^2),
 * K = 0, release stiffness 2e4 N/m (5e3 N m/rad), speed limits 0.1 m/s
 * (0.1 rad/s), acceleration and braking 2 m/s^2 (2 rad/s^2); crossover
 * 30 rad/s; surfaces from 1e4 to 1e8 N/m; the secant after 30 N and 10 um;
 * contact made at 100 N, lost below half the target for 2 ticks once the
 * push-back held half of it for 100 ticks, excess above 10 kN; guide
 * damping 2500 N s/m (500 N m s/rad); deflection 50 mm (0.05 rad);
 * targets up to 8 kN and 1 kN m; released within 1 um. The filter of the
 * pose for the stiffness secant must be the wrench's: `filter_alpha` is
 * the caller's (sp_wrench_alpha). SP_E_ARG on NULL.
 */
sp_status_t sp_force_default_config(sp_force_config_t *cfg, sp_q30_t filter_alpha, uint32_t tick_us);

/**
 * Checks cfg and prepares every coefficient force control uses (the
 * approach, guide and release dampings of each axis: eighteen sets of
 * three divisions, sp_admit_configure), then OFF, no contact. For init or a
 * new config, not for a tick. SP_E_ARG on NULL or a bad config (f
 * unchanged), SP_E_OVERFLOW as sp_admit_configure (f then not usable until
 * an init succeeds).
 */
sp_status_t sp_force_init(const sp_force_config_t *cfg, sp_force_t *f);

/**
 * OFF, no contact, every axis at rest on the position reference, with the
 * coefficients sp_force_init prepared (nothing is computed: for a tick).
 * SP_E_ARG on NULL.
 */
sp_status_t sp_force_reset(sp_force_t *f);

/**
 * Enters FORCE (mask, target) or GUIDE (mask; the target is zero) from OFF,
 * or, in FORCE, changes mask-less the target (a new FORCE command with the
 * same mask is a target update). Uses the coefficients sp_force_init
 * prepared: no division, whatever the mask. Refused with SP_E_RANGE for a target
 * beyond the config's maxima, SP_E_ARG for an empty mask, a mode other
 * than FORCE or GUIDE, NULL, or a switch between FORCE and GUIDE (leave
 * first), SP_E_BUSY while RELEASE or HOLD runs. Nothing changes on refusal.
 */
sp_status_t sp_force_start(const sp_force_config_t *cfg, sp_force_t *f, sp_force_mode_t mode, uint8_t mask,
                           const sp_q8_t target[SP_AXES]);

/**
 * New admittance parameters for the axes in `mask` (1..63): the virtual
 * mass (Q16, kg or kg m^2, >= 1 kg), the stiffness of the spring to the
 * position reference (>= 0) and the free-space damping (>= 1) of FORCE
 * (mode SP_FORCE_FORCE: the approach) or of GUIDE (SP_FORCE_GUIDE: hand
 * guiding); then every coefficient is prepared again (sp_force_init: a
 * command's tick in position control pays eighteen coefficient sets).
 * Only in OFF: SP_E_BUSY in any other mode. SP_E_ARG on NULL, a bad mask
 * or mode, or a parameter out of its range; SP_E_OVERFLOW when a
 * coefficient does not fit (sp_admit_configure). On any refusal cfg and f
 * are as before.
 */
sp_status_t sp_force_set_params(sp_force_config_t *cfg, sp_force_t *f, sp_force_mode_t mode, uint8_t mask,
                                sp_q16_t mass, int32_t damping, int32_t stiffness);

/** FORCE or GUIDE -> RELEASE; no-op (SP_OK) in OFF, RELEASE and HOLD. SP_E_ARG on NULL. */
sp_status_t sp_force_release(sp_force_t *f);

/**
 * One tick: the reference `out` = the position reference `pos_ref` plus the
 * offsets (pose, rates and accelerations), with `w_ext` the filtered wrench
 * the world exerts on the platform (N, N m, base frame, Q8; NULL when no
 * estimate is valid this tick: the axes then brake as in HOLD without a
 * mode change) and `x_meas` the estimated pose (NULL: none). Returns the
 * events of this tick in *events (SP_CONTACT_* and SP_FORCE_*): a lost
 * contact puts the module in HOLD, an excessive force in RELEASE (then
 * SP_FORCE_RETRACTED). Sums saturate at the Q24 extremes (the controller's
 * limits then refuse the reference). Returns SP_E_ARG on NULL (besides
 * w_ext, x_meas), else the admittance step's status.
 */
sp_status_t sp_force_step(const sp_force_config_t *cfg, sp_force_t *f, const sp_limits_t *lim,
                          const sp_motion_t *pos_ref, const sp_q8_t w_ext[SP_AXES], const sp_pose_t *x_meas,
                          sp_motion_t *out, uint32_t *events);

#endif /* SP_FORCE_H */
