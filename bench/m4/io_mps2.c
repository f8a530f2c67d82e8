/* SPDX-License-Identifier: Apache-2.0 */
/* io_mps2.c - m4_io_write on QEMU's mps2-an386: semihosting to QEMU's
 * standard output. */
#include "m4_io.h"
#include "sp_mps2.h"

int m4_io_write(const char *buf, size_t len)
{
    return sp_mps2_write(buf, len);
}
