/* decimal.c: a double as printf's "%.17g" writes it, character for character, without the C
 * library's multiple-precision arithmetic (which costs about as much as a step of INTELSAT V
 * for every five numbers of its CSV).
 *
 * x = m 2^e (m an integer below 2^53) to 17 significant digits is D = round(x 10^(16 - k)),
 * k = floor(log10 x). 10^p is held as a 128-bit fraction T_p 2^(b_p) truncated from the exact
 * value (decimal_powers.inc: a relative error below 2^-127), and m T_p is exact in 192 bits. So
 * x 10^(16 - k), below 2^57, is known to within 2^-69, and D is the correctly rounded value
 * unless its fraction lies within 2^-58 of one half: there, and for zeros, infinities and
 * NaNs, snprintf writes it. Compilers without a 128-bit integer type use snprintf throughout.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "base.h"

#define DIGITS 17

#if defined(__SIZEOF_INT128__)

__extension__ typedef unsigned __int128 wide;

typedef struct dep_power {
    uint64_t high, low; /* 10^p = (high 2^64 + low) 2^exponent */
    int exponent;
} dep_power;

#include "decimal_powers.inc"

static int bit_length(uint64_t v) /* v > 0 (GCC and Clang: the compilers with __int128) */
{
    return 64 - __builtin_clzll(v);
}

/* round(m 2^e 10^p) when that is unambiguous: 1 and *out; 0 when its fraction is within
   2^-58 of one half. Needs 2^46 < m 2^e 10^p < 2^64 (well inside: about 2^53 to 2^57). */
static int scaled(uint64_t m, int e, int p, uint64_t *out)
{
    const dep_power *t = &dep_powers[p - DEP_POWERS_LOWEST];
    wide low = (wide)m * t->low, high = (wide)m * t->high;
    wide middle = (high & UINT64_MAX) + (low >> 64);
    uint64_t a0 = (uint64_t)low, a1 = (uint64_t)middle;
    uint64_t a2 = (uint64_t)(high >> 64) + (uint64_t)(middle >> 64);
    int shift = -(e + t->exponent); /* the value is (a2 a1 a0) >> shift */
    uint64_t whole, fraction;       /* fraction: its top 64 bits */
    if (shift >= 128) {
        whole = a2 >> (shift - 128);
        fraction = shift == 128 ? a1 : (a2 << (192 - shift) | a1 >> (shift - 128));
    } else if (shift > 64) {
        whole = a2 << (128 - shift) | a1 >> (shift - 64);
        fraction = a1 << (128 - shift) | a0 >> (shift - 64);
    } else if (shift == 64) {
        whole = a1;
        fraction = a0;
    } else {
        return 0; /* not reached for doubles (shift is at least about 70) */
    }
    const uint64_t half = (uint64_t)1 << 63, margin = 64; /* 2^-58 of a unit */
    if (fraction > half - margin && fraction < half + margin) {
        return 0;
    }
    *out = whole + (fraction > half);
    return 1;
}

/* v < 10^8 as eight digits, two at a time (short 32-bit chains instead of 64-bit ones). */
static void eight_digits(uint32_t v, char *out)
{
    for (int i = 6; i >= 0; i -= 2) {
        uint32_t pair = v % 100;
        v /= 100;
        out[i] = (char)('0' + pair / 10);
        out[i + 1] = (char)('0' + pair % 10);
    }
}

/* The digits of D (10^16 <= D < 10^17) and its decimal exponent k as %.17g writes them. */
static int layout(int negative, uint64_t D, int k, char *out)
{
    char digits[DIGITS];
    int n = DIGITS, at = 0;
    uint32_t first = (uint32_t)(D / 10000000000000000ULL);
    D -= first * 10000000000000000ULL;
    digits[0] = (char)('0' + first);
    eight_digits((uint32_t)(D / 100000000), digits + 1);
    eight_digits((uint32_t)(D % 100000000), digits + 9);
    while (n > 1 && digits[n - 1] == '0') { /* %g drops trailing zeros */
        --n;
    }
    if (negative) {
        out[at++] = '-';
    }
    if (k < -4 || k >= DIGITS) { /* d.ddde+XX */
        out[at++] = digits[0];
        if (n > 1) {
            out[at++] = '.';
            memcpy(out + at, digits + 1, (size_t)(n - 1));
            at += n - 1;
        }
        at += snprintf(out + at, 8, "e%c%02d", k < 0 ? '-' : '+', k < 0 ? -k : k);
    } else if (k >= 0) { /* ddd.ddd */
        int whole = k + 1;
        for (int i = 0; i < whole; ++i) {
            out[at++] = i < n ? digits[i] : '0';
        }
        if (n > whole) {
            out[at++] = '.';
            memcpy(out + at, digits + whole, (size_t)(n - whole));
            at += n - whole;
        }
    } else { /* 0.000ddd */
        out[at++] = '0';
        out[at++] = '.';
        for (int i = 0; i < -k - 1; ++i) {
            out[at++] = '0';
        }
        memcpy(out + at, digits, (size_t)n);
        at += n;
    }
    out[at] = '\0';
    return at;
}

int dep_format_double(double x, char *out)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    int negative = (int)(bits >> 63), field = (int)(bits >> 52 & 0x7ff);
    uint64_t m = bits & (((uint64_t)1 << 52) - 1);
    if (field == 0x7ff || (field == 0 && m == 0)) { /* infinities, NaNs, zeros */
        return snprintf(out, DEP_FORMAT_SIZE, "%.17g", x);
    }
    int e = field ? field - 1075 : -1074;
    m = field ? m | (uint64_t)1 << 52 : m;
    /* k: floor(log10 x) from floor(log2 x) (it or one less), corrected by the digits found */
    int k = (int)floor((e + bit_length(m) - 1) * 0.30102999566398120);
    const uint64_t low = 10000000000000000ULL, high = 100000000000000000ULL;
    for (int tries = 0; tries < 3; ++tries) {
        uint64_t D;
        if (!scaled(m, e, DIGITS - 1 - k, &D)) {
            break;
        }
        if (D < low) {
            --k;
        } else if (D >= high) {
            if (D == high) { /* rounded up to the next power of ten */
                return layout(negative, low, k + 1, out);
            }
            ++k;
        } else {
            return layout(negative, D, k, out);
        }
    }
    return snprintf(out, DEP_FORMAT_SIZE, "%.17g", x);
}

#else

int dep_format_double(double x, char *out)
{
    return snprintf(out, DEP_FORMAT_SIZE, "%.17g", x);
}

#endif
