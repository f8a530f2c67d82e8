/* SPDX-License-Identifier: Apache-2.0 */
/* A math-layer file that includes the controller (ctest
 * rules_layers_reject_upward checks it as src/math/): the layer rule must
 * report the upward include, and only it. */
#include "math/fixed_inline.h"
#include "sp/control/controller.h"
#include "sp/math/status.h"
