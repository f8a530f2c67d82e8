/* SPDX-License-Identifier: Apache-2.0 */
/* scenario_plant.c - see scenario_plant.h. */
#include "scenario_plant.h"

#include <string.h>

hs_status_t hs_scenario_set_contact(hs_plant_t *plant, const hs_scenario_contact_t *sc, double *start_force)
{
    hs_contact_t c;
    memset(&c, 0, sizeof c);
    c.kind = (sc->kind == 1) ? HS_CONTACT_PLANE : (sc->kind == 2) ? HS_CONTACT_POINT : HS_CONTACT_NONE;
    memcpy(c.point, sc->point, sizeof c.point);
    memcpy(c.normal, sc->normal, sizeof c.normal);
    memcpy(c.anchor, sc->anchor, sizeof c.anchor);
    c.offset = sc->offset;
    c.stiffness = sc->stiffness;
    c.damping = sc->damping;
    hs_status_t st = hs_plant_set_contact(plant, &c);
    if (st == HS_E_RANGE && start_force != NULL) {
        *start_force = hs_contact_start_force(plant, &c);
    }
    return st;
}
