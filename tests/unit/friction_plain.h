/* friction_plain.h - the plain reference of the friction observer's
 * step and exp (friction_plain.c) for test_friction.c. */
#ifndef FRICTION_PLAIN_H
#define FRICTION_PLAIN_H

#include "sp/friction.h"

/* sp_fric_exp_neg as first written. */
sp_q30_t plain_fric_exp_neg(sp_q24_t u);

/* sp_fric_obs_step after its argument checks, as first written: p's
 * parameters must pass sp_fric_obs_check, 1 <= tick_us <= SP_FRIC_TICK_MAX_US. */
sp_status_t plain_fric_obs_run(const sp_platform_t *p, sp_fric_obs_t *o, const sp_q24_t length[SP_LEGS],
                               uint32_t tick_us, sp_q8_t friction[SP_LEGS]);

#endif /* FRICTION_PLAIN_H */
