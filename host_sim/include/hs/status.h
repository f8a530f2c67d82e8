/* SPDX-License-Identifier: Apache-2.0 */
/*
 * hs/status.h - status codes of the plant simulator (host_sim).
 */
#ifndef HS_STATUS_H
#define HS_STATUS_H

/** Result of a host_sim function. HS_OK is zero; every error is non-zero. */
typedef enum {
    HS_OK = 0,
    HS_E_ARG = 1,      /**< NULL pointer, index or value outside its documented range */
    HS_E_SINGULAR = 2, /**< pose at or near a singularity: static forces undefined */
    HS_E_NUMERIC = 3,  /**< the state became non-finite; the step was undone */
    HS_E_RANGE = 4,    /**< a pose puts a leg outside what the model can represent */
    HS_E_SYNTAX = 5,   /**< a scenario line that is not an action (hs/scenario.h) */
    HS_E_IO = 6        /**< a file could not be opened or read */
} hs_status_t;

/** Short constant name of a status ("ok", "arg", ...); "unknown" otherwise. Never NULL. */
const char *hs_status_name(hs_status_t status);

#endif /* HS_STATUS_H */
