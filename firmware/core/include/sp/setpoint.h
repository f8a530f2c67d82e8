/*
 * sp/setpoint.h - what the controller sends each axis drive every tick: the
 * leg length to follow, its rate as velocity feed-forward, and the cylinder
 * force the motion requires (the paper's inverse dynamics) as force
 * feed-forward, computed from a reference motion with every limit checked.
 */
#ifndef SP_SETPOINT_H
#define SP_SETPOINT_H

#include "sp/dynamics.h"
#include "sp/limits.h"

/** One axis drive's setpoint. */
typedef struct {
    sp_q24_t length;   /**< length setpoint, m, Q24 */
    sp_q24_t velocity; /**< velocity feed-forward, m/s, Q24 */
    sp_q8_t force;     /**< force feed-forward, N, Q8 */
} sp_setpoint_t;

/**
 * The setpoints of a reference motion: the leg lengths of its pose (IK),
 * their rates (sp_leg_rates) and the cylinder forces of its motion
 * (sp_inverse_dynamics_lu, no external force), sent as 0 when
 * force_feedforward is 0. The factorisation of J^T at the pose goes to *lu
 * (valid only when the dynamics succeeded). Errors, with sp untouched:
 * SP_E_RANGE for a pose outside the workspace box or a length, rate or
 * force outside sp_limits_setpoints_ok; the IK's, the rates' or the
 * dynamics' error when one fails (SP_E_RANGE, SP_E_OVERFLOW,
 * SP_E_SINGULAR).
 */
sp_status_t sp_setpoints_of(const sp_platform_t *platform, const sp_limits_t *lim, const sp_motion_t *ref,
                            int force_feedforward, sp_setpoint_t sp[SP_LEGS], sp_lu6_t *lu);

#endif /* SP_SETPOINT_H */
