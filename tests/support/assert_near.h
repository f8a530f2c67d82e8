/* SPDX-License-Identifier: Apache-2.0 */
/*
 * assert_near.h - a cmocka assertion for numbers that must agree within a
 * tolerance:
 *
 *   assert_near(got, want, tol, "leg %d length", i);
 *
 * passes when |got - want| <= tol (compared in long double, so that exact
 * references keep their bits), and otherwise fails the test with the label,
 * both values, their difference and the tolerance. A NaN never passes. The
 * label is a printf format with its arguments; it is formatted only on
 * failure.
 */
#ifndef ASSERT_NEAR_H
#define ASSERT_NEAR_H

#if defined(__GNUC__)
#define TU_PRINTF_LIKE(f, a) __attribute__((format(printf, f, a)))
#else
#define TU_PRINTF_LIKE(f, a)
#endif

void tu_assert_near(long double got, long double want, long double tol, const char *file, int line, const char *label,
                    ...) TU_PRINTF_LIKE(6, 7);

#define assert_near(got, want, tol, ...)                                                                               \
    tu_assert_near((long double)(got), (long double)(want), (long double)(tol), __FILE__, __LINE__, __VA_ARGS__)

#endif /* ASSERT_NEAR_H */
