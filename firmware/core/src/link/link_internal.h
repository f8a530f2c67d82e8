/* SPDX-License-Identifier: Apache-2.0 */
/*
 * link_internal.h - the drive links' shared arithmetic, not part of the
 * public API.
 */
#ifndef SP_LINK_INTERNAL_H
#define SP_LINK_INTERNAL_H

#include "sp/model/platform.h"

/* Cylinder force from the chamber pressures (kPa, as the drives send them):
 * pA x A_piston - pB x A_annulus, N, Q8, rounded to nearest, saturated to
 * int32. Inline: the native link (node.c) and the CANopen link
 * (canopen_link.c) share it without a call. */
static inline sp_q8_t spi_cylinder_force(const sp_platform_t *p, uint32_t pa, uint32_t pb)
{
    int64_t f30 = (int64_t)pa * p->piston_area - (int64_t)pb * p->annulus_area; /* N, Q30 */
    int64_t f8 = (f30 >= 0) ? (f30 + (INT64_C(1) << 21)) >> 22 : -((-f30 + (INT64_C(1) << 21)) >> 22);
    if (f8 > INT32_MAX) {
        return INT32_MAX;
    }
    if (f8 < INT32_MIN) {
        return INT32_MIN;
    }
    return (sp_q8_t)f8;
}

#endif /* SP_LINK_INTERNAL_H */
