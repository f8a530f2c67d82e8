/* SPDX-License-Identifier: Apache-2.0 */
/*
 * scenario_plant.h - a scenario's actions on the plant that hs_sim and
 * hs_soak carry out alike (the scenario language knows no plant: this is
 * where the two meet).
 */
#ifndef HS_SCENARIO_PLANT_H
#define HS_SCENARIO_PLANT_H

#include "hs/plant.h"
#include "hs/scenario.h"

/**
 * Installs the contact as written (kind 0 removes it) with
 * hs_plant_set_contact. HS_E_RANGE when the plant refuses a surface that
 * would push with more than HS_CONTACT_START_FORCE_MAX the moment it is
 * placed: *start_force (N, if not NULL) is then that force. Other
 * statuses are the plant's.
 */
hs_status_t hs_scenario_set_contact(hs_plant_t *plant, const hs_scenario_contact_t *sc, double *start_force);

#endif /* HS_SCENARIO_PLANT_H */
