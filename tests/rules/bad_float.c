/* SPDX-License-Identifier: Apache-2.0 */
/* The rule under test: a float anywhere in the core must not compile. */
static const float gain = 0.5f;
int32_t rules_bad(int32_t a);
int32_t rules_bad(int32_t a)
{
    return (int32_t)((float)a * gain);
}
