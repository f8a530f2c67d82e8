/* SPDX-License-Identifier: Apache-2.0 */
/* plain_dynamics.h - a second copy of dynamics.c for a test's plain
 * reference: its public functions renamed plain_* (its statics are the
 * including file's own). Define the switch the test turns off
 * (SPI_ID_RANGE_FAST, SPI_LEG_TERMS_AT_REST) before including it, once. */
#define sp_inverse_dynamics plain_inverse_dynamics
#define sp_inverse_dynamics_lu plain_inverse_dynamics_lu
#define sp_inverse_dynamics_jac plain_inverse_dynamics_jac
#define sp_inverse_dynamics_rates plain_inverse_dynamics_rates
#define sp_inverse_dynamics_held plain_inverse_dynamics_held
#define spi_inverse_dynamics_held_body plain_inverse_dynamics_held_body
sp_status_t plain_inverse_dynamics(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                   const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS]);
sp_status_t plain_inverse_dynamics_lu(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                      const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS], sp_lu6_t *lu);
sp_status_t plain_inverse_dynamics_jac(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                       const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                       sp_lu6_t *lu);
sp_status_t plain_inverse_dynamics_rates(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                         const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                         sp_lu6_t *lu, sp_q24_t rate[SP_LEGS]);
sp_status_t plain_inverse_dynamics_held(const sp_platform_t *platform, const sp_motion_t *motion, const sp_ik_t *ik,
                                        const sp_jacobian_t *jac, const sp_q8_t ext_force[3], sp_q8_t force[SP_LEGS],
                                        sp_lu6_t *lu, sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold, unsigned refresh);
sp_status_t plain_inverse_dynamics_held_body(const sp_platform_t *platform, const sp_motion_t *motion,
                                             const sp_ik_t *ik, const sp_jacobian_t *jac, sp_q8_t force[SP_LEGS],
                                             sp_lu6_t *lu, sp_q24_t rate[SP_LEGS], sp_leg_hold_t *hold,
                                             unsigned refresh, const sp_q24_t body[6]);
#include "model/dynamics.c"
#undef sp_inverse_dynamics
#undef sp_inverse_dynamics_lu
#undef sp_inverse_dynamics_jac
#undef sp_inverse_dynamics_rates
#undef sp_inverse_dynamics_held
#undef spi_inverse_dynamics_held_body
