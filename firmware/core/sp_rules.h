/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_rules.h - force-included (-include) before every translation unit of the
 * firmware core. It makes the core's two hard rules compiler-enforced:
 *   - no floating point: the keywords float and double are poisoned;
 *   - no heap: the allocator's names are poisoned.
 * The only headers the core may use are included first, so that their
 * declarations are not themselves rejected.
 * (A float literal that sneaks into arithmetic is caught by the Cortex-M4
 * soft-float build, whose objects must not reference __aeabi_f / __aeabi_d
 * helpers; see cmake/check_symbols.cmake.)
 */
#ifndef SP_RULES_H
#define SP_RULES_H
#include <limits.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h> /* memcpy and memset, used by the generated CAN code */
#pragma GCC poison float double
#pragma GCC poison malloc calloc realloc free aligned_alloc
#endif
