/* SPDX-License-Identifier: Apache-2.0 */
/* Positive control: ordinary fixed-point code compiles under the core's rules. */
int32_t rules_good(int32_t a);
int32_t rules_good(int32_t a)
{
    return a / 2;
}
