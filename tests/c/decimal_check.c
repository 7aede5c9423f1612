/* decimal_check.c: dep_format_double against snprintf's "%.17g" (tests/c/test_decimal.py).
 *
 *   decimal_check N SEED    N doubles of each kind; prints "checked C differ D", then up to
 *                           ten that differ: the value's bits, ours, snprintf's
 *
 * Kinds: every bit pattern (uniform over all exponents, subnormals included), decimals with
 * few digits (k / 10^j: many near a tie or a power of ten), halves and sums of two powers of
 * two (exact ties at the 17th digit), and each power of ten and its neighbours.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "depsim.h"

static uint64_t state;

static uint64_t next(void) /* xorshift64* */
{
    state ^= state >> 12;
    state ^= state << 25;
    state ^= state >> 27;
    return state * 2685821657736338717ULL;
}

static long checked, differ;

static void check(double x)
{
    char ours[DEP_FORMAT_SIZE], theirs[64];
    int n = dep_format_double(x, ours);
    snprintf(theirs, sizeof theirs, "%.17g", x);
    checked++;
    if (strcmp(ours, theirs) != 0 || n != (int)strlen(theirs)) {
        uint64_t bits;
        memcpy(&bits, &x, sizeof bits);
        if (differ++ < 10) {
            printf("%016llx %s %s\n", (unsigned long long)bits, ours, theirs);
        }
    }
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: decimal_check N SEED\n");
        return 2;
    }
    long n = atol(argv[1]);
    state = strtoull(argv[2], NULL, 10) | 1;
    for (long i = 0; i < n; ++i) {
        uint64_t bits = next();
        double x;
        memcpy(&x, &bits, sizeof x);
        check(x);
        check(ldexp(1.0 + (double)(next() >> 11) * 0x1p-53, (int)(next() % 200) - 100));
        long digits = (long)(next() % 100000000);
        check((double)digits / pow(10.0, (double)(next() % 30)));
        check(ldexp((double)(next() >> 11) + 0.5, (int)(next() % 120) - 60)
              + ldexp(1.0, (int)(next() % 80) - 40));
    }
    for (int p = -330; p <= 310; ++p) {
        double x = pow(10.0, p);
        check(x);
        check(nextafter(x, 0.0));
        check(nextafter(x, INFINITY));
        check(-x);
    }
    double specials[] = {0.0, -0.0, INFINITY, -INFINITY, NAN, -NAN, 5e-324, 2.2250738585072009e-308,
                         2.2250738585072014e-308, 1.7976931348623157e308, 0.1, 0.5, 1.0, 1e16,
                         1e17, 9.9999999999999995e16, 123456789012345678.0, 1e-4, 9.99999e-5};
    for (size_t i = 0; i < sizeof specials / sizeof *specials; ++i) {
        check(specials[i]);
    }
    printf("checked %ld differ %ld\n", checked, differ);
    return 0;
}
