/* host_os.c - stop flag on SIGINT/SIGTERM and the monotonic clock (host_os.h). */
#define _POSIX_C_SOURCE 200809L
#include "host_os.h"

#include <signal.h>
#include <string.h>
#include <time.h>

static volatile sig_atomic_t g_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

int sp_host_stop_on_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sa.sa_flags = SA_RESTART; /* what glibc's signal() does */
    if (sigemptyset(&sa.sa_mask) != 0) {
        return -1;
    }
    if (sigaction(SIGINT, &sa, NULL) != 0 || sigaction(SIGTERM, &sa, NULL) != 0) {
        return -1;
    }
    return 0;
}

int sp_host_stop_requested(void)
{
    return g_stop != 0;
}

int64_t sp_host_now_ns(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}
