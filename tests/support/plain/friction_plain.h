/* SPDX-License-Identifier: Apache-2.0 */
/* friction_plain.h - the plain reference of the friction observer's
 * step and exp (friction_plain.c) for test_friction.c. */
#ifndef FRICTION_PLAIN_H
#define FRICTION_PLAIN_H

#include "sp/estimation/friction.h"

/* sp_fric_exp_neg as first written. */
sp_q30_t plain_fric_exp_neg(sp_q24_t u);

/* sp_fric_obs_step after its argument checks, as first written: p's
 * parameters must pass sp_fric_obs_check, 1 <= tick_us <= SP_FRIC_TICK_MAX_US. */
sp_status_t plain_fric_obs_run(const sp_platform_t *p, sp_fric_obs_t *o, const sp_q24_t length[SP_LEGS],
                               uint32_t tick_us, sp_q8_t friction[SP_LEGS]);

/* What the plain step computes for leg i (with bristles) of p at the
 * increment |dx| = adx (Q24 LSB) over tick_us, with the constants o keeps
 * (a valid o): the Stribeck fade *es (0 at and beyond 4 v_s) and the
 * bristle relaxation *eb, both Q30; what sp_fric_table_prepare tabulates. */
void plain_fric_slow_terms(const sp_platform_t *p, const sp_fric_obs_t *o, int i, uint32_t tick_us, int32_t adx,
                           sp_q30_t *es, sp_q30_t *eb);

#endif /* FRICTION_PLAIN_H */
