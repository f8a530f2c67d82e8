/* SPDX-License-Identifier: Apache-2.0 */
/*
 * estimation_internal.h - the estimation layer's functions that the
 * controller (controller.c) shares and that are not part of the public API.
 */
#ifndef SP_ESTIMATION_INTERNAL_H
#define SP_ESTIMATION_INTERNAL_H

#include "sp/estimation/friction.h"

/* sp_fric_obs_step_table for a platform that passed sp_fric_obs_check
 * (the controller's, checked at init): the same step, results and
 * returns, without checking the friction parameters again. */
sp_status_t spi_fric_obs_step_checked(const sp_platform_t *p, sp_fric_obs_t *o, const sp_fric_table_t *tab,
                                      const sp_q24_t length[SP_LEGS], uint32_t tick_us, sp_q8_t friction[SP_LEGS]);

#endif /* SP_ESTIMATION_INTERNAL_H */
