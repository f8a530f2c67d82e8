/* SPDX-License-Identifier: Apache-2.0 */
#include "sp/math/status.h"

const char *sp_status_name(sp_status_t status)
{
    switch (status) {
    case SP_OK:
        return "ok";
    case SP_E_OVERFLOW:
        return "overflow";
    case SP_E_DOMAIN:
        return "domain";
    case SP_E_ARG:
        return "bad-argument";
    case SP_E_SINGULAR:
        return "singular";
    case SP_E_RANGE:
        return "out-of-range";
    case SP_E_NO_CONVERGENCE:
        return "no-convergence";
    case SP_E_DISCONTINUITY:
        return "discontinuity";
    case SP_E_FRAME:
        return "bad-frame";
    case SP_E_IO:
        return "io-error";
    case SP_E_BUSY:
        return "busy";
    default:
        return "unknown";
    }
}
