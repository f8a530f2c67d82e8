/* SPDX-License-Identifier: Apache-2.0 */
/* status.c - names of the host_sim status codes. */
#include "hs/status.h"

const char *hs_status_name(hs_status_t status)
{
    switch (status) {
    case HS_OK:
        return "ok";
    case HS_E_ARG:
        return "arg";
    case HS_E_SINGULAR:
        return "singular";
    case HS_E_NUMERIC:
        return "numeric";
    case HS_E_RANGE:
        return "range";
    case HS_E_SYNTAX:
        return "syntax";
    case HS_E_IO:
        return "io";
    default:
        return "unknown";
    }
}
