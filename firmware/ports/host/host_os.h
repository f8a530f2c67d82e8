/*
 * host_os.h - the little the host programs (sp_controller, hs_sim) need from
 * a POSIX (Linux) host besides CAN: a stop flag set by SIGINT/SIGTERM and a
 * monotonic clock. Host only: the portable core never includes this.
 */
#ifndef SP_HOST_OS_H
#define SP_HOST_OS_H

#include <stdint.h>

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

#endif /* SP_HOST_OS_H */
