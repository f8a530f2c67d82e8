/* SPDX-License-Identifier: Apache-2.0 */
/* io_host.c - m4_io_write on the host: standard output. */
#include <stdio.h>

#include "m4_io.h"

int m4_io_write(const char *buf, size_t len)
{
    return (fwrite(buf, 1u, len, stdout) == len && fflush(stdout) == 0) ? 0 : -1;
}
