/* SPDX-License-Identifier: Apache-2.0 */
/* The rule under test: a double anywhere in the core must not compile. */
int32_t rules_bad(void);
int32_t rules_bad(void)
{
    double x = 1.0;
    return (int32_t)x;
}
