/* test.h: the few checking macros our C tests share. A failed check prints the file, line,
 * expression and values, and the test exits nonzero at the end (test_summary). */
#ifndef HD_TEST_H
#define HD_TEST_H

#include <math.h>
#include <stdio.h>

static int test_failures;

#define CHECK(cond)                                                                   \
    do {                                                                              \
        if (!(cond)) {                                                                \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);  \
            test_failures++;                                                          \
        }                                                                             \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                               \
    do {                                                                                    \
        double check_a_ = (double)(a), check_b_ = (double)(b);                              \
        if (!(fabs(check_a_ - check_b_) <= (tol))) {                                        \
            fprintf(stderr, "%s:%d: %s = %.9g, expected %s = %.9g (tolerance %g)\n", __FILE__, \
                    __LINE__, #a, check_a_, #b, check_b_, (double)(tol));                   \
            test_failures++;                                                                \
        }                                                                                   \
    } while (0)

static inline int test_summary(const char *name)
{
    if (test_failures) {
        fprintf(stderr, "%s: %d check(s) failed\n", name, test_failures);
        return 1;
    }
    return 0;
}

#endif /* HD_TEST_H */
