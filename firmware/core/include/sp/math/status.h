/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/math/status.h - status codes returned by every core function that can fail.
 */
#ifndef SP_STATUS_H
#define SP_STATUS_H

/** Result of a core function. SP_OK is zero; every error is non-zero. */
typedef enum {
    SP_OK = 0,
    SP_E_OVERFLOW = 1,       /**< an intermediate or result saturated */
    SP_E_DOMAIN = 2,         /**< undefined operation (x/0, sqrt of a negative) */
    SP_E_ARG = 3,            /**< NULL pointer or argument outside its documented range */
    SP_E_SINGULAR = 4,       /**< matrix singular or too ill-conditioned to trust */
    SP_E_RANGE = 5,          /**< result outside the physical limits (stroke, workspace, force) */
    SP_E_NO_CONVERGENCE = 6, /**< iteration did not converge within its bound */
    SP_E_DISCONTINUITY = 7,  /**< converged, but too far from the previous solution */
    SP_E_FRAME = 8,          /**< a received frame was malformed, corrupted, stale or out of range */
    SP_E_IO = 9,             /**< a port could not send or receive (bus off, socket error) */
    SP_E_BUSY = 10           /**< a queue was full or nothing was ready; retry later */
} sp_status_t;

/**
 * A short, constant, human-readable name of a status ("ok", "overflow", ...).
 * Unknown values return "unknown". Never NULL.
 */
const char *sp_status_name(sp_status_t status);

#endif /* SP_STATUS_H */
