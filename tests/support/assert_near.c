/* SPDX-License-Identifier: Apache-2.0 */
/* assert_near.c - assert_near for the cmocka tests (assert_near.h). */
#include "assert_near.h"

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

void tu_assert_near(long double got, long double want, long double tol, const char *file, int line, const char *label,
                    ...)
{
    long double diff = got - want;
    char text[256];
    va_list ap;

    if (fabsl(diff) <= tol) {
        return;
    }
    va_start(ap, label);
    vsnprintf(text, sizeof text, label, ap);
    va_end(ap);
    print_error("%s: got %.17Lg, want %.17Lg, difference %.3Lg, tolerance %.3Lg\n", text, got, want, diff, tol);
    _fail(file, line);
}
