/* SPDX-License-Identifier: Apache-2.0 */
/* The rule under test: floating-point arithmetic without the keywords (a
 * literal) compiles, but leaves soft-float helper calls in the Cortex-M4
 * object, which the symbol check rejects. */
int32_t rules_bad(int32_t a);
int32_t rules_bad(int32_t a)
{
    return (int32_t)(a * 1.5);
}
