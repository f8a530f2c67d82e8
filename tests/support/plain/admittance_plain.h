/* SPDX-License-Identifier: Apache-2.0 */
/*
 * admittance_plain.h - the admittance step and contact supervision as first
 * written (before the force-control tick's budget work of issue 15): every
 * coefficient and the tick's constants computed where they are used, every
 * axis stepped and filtered each tick. Kept as the plain reference that
 * test_admittance proves the prepared, skipping sp_admit_step equal to.
 */
#ifndef ADMITTANCE_PLAIN_H
#define ADMITTANCE_PLAIN_H

#include "sp/force/admittance.h"

typedef struct {
    sp_q24_t d;
    sp_q24_t v;
    sp_q24_t a;
    sp_admit_coef_t coef;
    sp_admit_coef_t rel;
    int32_t x_f[4];
    sp_q24_t x_contact;
    sp_q8_t w_contact;
    int32_t k_hat;
    uint8_t in_contact;
} plain_axis_state_t;

typedef struct {
    plain_axis_state_t axis[SP_AXES];
    uint8_t primed;
} plain_admit_t;

sp_status_t plain_admit_configure(const sp_admit_config_t *cfg, plain_admit_t *st);
sp_status_t plain_admit_step(const sp_admit_config_t *cfg, plain_admit_t *st, sp_admit_mode_t mode, uint8_t mask,
                             const sp_q8_t w_ext[SP_AXES], const sp_q8_t w_target[SP_AXES],
                             const sp_q24_t x_meas[SP_AXES], uint8_t contact, const sp_q24_t lo[SP_AXES],
                             const sp_q24_t hi[SP_AXES], sp_admit_report_t *report);
uint32_t plain_contact_step(const sp_contact_config_t *cfg, sp_contact_t *st, const sp_q8_t w_ext[SP_AXES],
                            const sp_q8_t w_target[SP_AXES]);

#endif /* ADMITTANCE_PLAIN_H */
