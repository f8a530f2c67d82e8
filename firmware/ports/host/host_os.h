/* SPDX-License-Identifier: Apache-2.0 */
/*
 * host_os.h - the little the host programs (sp_controller, hs_sim) need from
 * a POSIX (Linux) host besides CAN: a stop flag set by SIGINT/SIGTERM and a
 * monotonic clock. Host only: the portable core never includes this.
 */
#ifndef SP_HOST_OS_H
#define SP_HOST_OS_H

#include <stddef.h>
#include <stdint.h>

#define SP_HOST_KEY_BYTES 16u
/** The environment variable naming the machine key file when no --key is given. */
#define SP_HOST_KEY_ENV "STEWART_KEY"

/**
 * Installs the handler of SIGINT and SIGTERM: it only sets the stop flag
 * (sp_host_stop_requested), so the program's loop ends at its next check and
 * prints its summary. Interrupted system calls are restarted where the system
 * does that (SA_RESTART); poll() and clock_nanosleep() return EINTR, which the
 * loops treat as "look at the flag". Returns 0, or -1 if a handler could not
 * be installed (errno set).
 */
int sp_host_stop_on_signals(void);

/** 1 once SIGINT or SIGTERM has arrived after sp_host_stop_on_signals, else 0. */
int sp_host_stop_requested(void);

/** CLOCK_MONOTONIC in nanoseconds (an arbitrary origin; differences only). */
int64_t sp_host_now_ns(void);

/**
 * The machine key of command authentication (docs/explanation/security.md) from the file
 * `path`, or, when path is NULL or empty, from the file the environment
 * variable STEWART_KEY names. The file holds 32 hexadecimal digits
 * (whitespace allowed) and may be read by its owner only (mode 600, as an
 * ssh private key: group or others' permissions refuse it). Returns 1 with
 * key[0..16) filled and *used set to the file's name, 0 when neither names
 * a file (no key), -1 on an error with a one-line reason in err[0..errlen).
 */
int sp_host_load_key(const char *path, uint8_t key[SP_HOST_KEY_BYTES], const char **used, char *err, size_t errlen);

/** A random 32-bit value from the kernel (getrandom): 0, or -1 (errno set). */
int sp_host_random_u32(uint32_t *out);

#endif /* SP_HOST_OS_H */
