/* SPDX-License-Identifier: Apache-2.0 */
/* The rule under test: heap allocation in the core must not compile. */
void *malloc(size_t n);
int32_t *rules_bad(void);
int32_t *rules_bad(void)
{
    return (int32_t *)malloc(4u);
}
