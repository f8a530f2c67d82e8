/*
 * sp/dynamics.h - the cylinder forces a motion requires (the paper's
 * translational and rotational dynamics, eqs 7 and 8/13-15, with the full
 * inertia tensor). The leg limit checks are in sp/limits.h.
 */
#ifndef SP_DYNAMICS_H
#define SP_DYNAMICS_H

#include "sp/kinematics.h"

/**
 * Inverse dynamics: the six cylinder forces F_i (N, Q8; positive pushes the
 * platform away from the base, along l_i) that produce the given motion of
 * the platform under gravity (0, 0, -m g) and an external force L at the
 * centroid o' (N, Q8, base frame; may be NULL for none). Solves
 *   sum F_i u_i                 = m a - L + (0, 0, m g)          (base frame)
 *   sum F_i (A_im T) x u_i      = R (I dw/dt + w x (I w))        (base frame)
 * where w, dw/dt are the body rates of eq (10) and R = T^T, by pivoted
 * Gaussian elimination in 64-bit intermediates (forces carried in Q24).
 * ik must be the inverse kinematics of motion->pose.
 * Errors: SP_E_ARG (NULL), SP_E_SINGULAR (pose at or near a singularity:
 * smallest pivot below 1e-3), SP_E_OVERFLOW (an intermediate or a force
 * saturated: |F| >= 8.4 MN). On error the forces are zeroed.
 */
sp_status_t sp_inverse_dynamics(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS]);

/**
 * sp_inverse_dynamics (same forces, bit for bit, same errors), also
 * returning the factorisation of J^T it solved with in *lu (lu->valid is 1
 * only on SP_OK; SP_E_ARG if lu is NULL). The transposed solve of *lu
 * (sp_lu6_solve_transposed) then solves J x = b at no new factorisation,
 * e.g. for the next tick's forward kinematics (sp_fk_chord).
 */
sp_status_t sp_inverse_dynamics_lu(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                   const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS], sp_lu6_t *lu);

#endif /* SP_DYNAMICS_H */
