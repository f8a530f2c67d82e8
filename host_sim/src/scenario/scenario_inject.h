/* SPDX-License-Identifier: Apache-2.0 */
/* scenario_inject.h - the `inject` actions of the scenario language (internal to hs_scenario). */
#ifndef HS_SCENARIO_INJECT_H
#define HS_SCENARIO_INJECT_H

#include <stddef.h>

#include "hs/scenario.h"

/**
 * Parses the words w[0..nw) of an `inject` line (w[0] is "inject") into *a
 * (kind HS_ACTION_INJECT). Returns 1, or -1 with what is wrong in
 * why[0..why_len) (the words may be modified in place).
 */
int hs_scenario_parse_inject(char **w, int nw, hs_action_t *a, char *why, size_t why_len);

#endif /* HS_SCENARIO_INJECT_H */
