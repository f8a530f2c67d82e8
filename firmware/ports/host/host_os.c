/* SPDX-License-Identifier: Apache-2.0 */
/* host_os.c - stop flag on SIGINT/SIGTERM, the monotonic clock, the machine
 * key file and a random session value (host_os.h). */
#define _GNU_SOURCE
#include "host_os.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/stat.h>
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

static int hex_digit(int c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

int sp_host_load_key(const char *path, uint8_t key[SP_HOST_KEY_BYTES], const char **used, char *err, size_t errlen)
{
    if (path == NULL || path[0] == '\0') {
        path = getenv(SP_HOST_KEY_ENV);
    }
    if (path == NULL || path[0] == '\0') {
        return 0;
    }
    if (used != NULL) {
        *used = path;
    }
    FILE *fp = fopen(path, "r");
    if (fp == NULL) {
        snprintf(err, errlen, "cannot read the key file %s: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fileno(fp), &st) != 0) {
        snprintf(err, errlen, "cannot stat the key file %s: %s", path, strerror(errno));
        (void)fclose(fp);
        return -1;
    }
    if ((st.st_mode & 0077u) != 0u) {
        snprintf(err, errlen, "%s: the key file may be read by others (mode %03o); chmod 600 it", path,
                 (unsigned)(st.st_mode & 0777u));
        (void)fclose(fp);
        return -1;
    }
    uint32_t digits = 0;
    int bad = 0;
    for (int c = fgetc(fp); c != EOF && digits <= 2u * SP_HOST_KEY_BYTES; c = fgetc(fp)) {
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
            continue;
        }
        int d = hex_digit(c);
        if (d < 0 || digits == 2u * SP_HOST_KEY_BYTES) {
            bad = 1;
            break;
        }
        if (digits % 2u == 0u) {
            key[digits / 2u] = (uint8_t)(d << 4);
        } else {
            key[digits / 2u] = (uint8_t)(key[digits / 2u] | d);
        }
        digits++;
    }
    (void)fclose(fp);
    if (bad || digits != 2u * SP_HOST_KEY_BYTES) {
        snprintf(err, errlen, "%s: a key file holds %u hexadecimal digits", path, 2u * SP_HOST_KEY_BYTES);
        return -1;
    }
    return 1;
}

int sp_host_random_u32(uint32_t *out)
{
    uint8_t b[4];
    if (getrandom(b, sizeof b, 0) != (ssize_t)sizeof b) {
        return -1;
    }
    *out = (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) | ((uint32_t)b[3] << 24);
    return 0;
}
