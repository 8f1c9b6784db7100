/* ivoct fmt — numbers as text (fmt.h).
 *
 * %.17g of a double x = m 2^e (m an integer of 53 bits) is the integer N of
 * 17 digits nearest to x 10^q, for the q that puts it in [10^16, 10^17), and
 * the exponent k = 16 - q; printf then lays N out in fixed or exponential
 * notation.  Where 10^q fits in 128 bits and m 10^q 2^e needs no more than
 * 192, N and the rest of the division by 2^-e are exact integer arithmetic,
 * and so is the rounding, ties to even as glibc's printf rounds.  The other
 * magnitudes are rare in the outputs that need speed: printf does them. */
#include "fmt.h"

#include <locale.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

__extension__ typedef unsigned __int128 u128;

/* 10^q for q in [0, 38] (10^38 < 2^128 < 10^39), high and low 64 bits */
static const uint64_t POW10[39][2] = {
    {0x0000000000000000u, 0x0000000000000001u},
    {0x0000000000000000u, 0x000000000000000au},
    {0x0000000000000000u, 0x0000000000000064u},
    {0x0000000000000000u, 0x00000000000003e8u},
    {0x0000000000000000u, 0x0000000000002710u},
    {0x0000000000000000u, 0x00000000000186a0u},
    {0x0000000000000000u, 0x00000000000f4240u},
    {0x0000000000000000u, 0x0000000000989680u},
    {0x0000000000000000u, 0x0000000005f5e100u},
    {0x0000000000000000u, 0x000000003b9aca00u},
    {0x0000000000000000u, 0x00000002540be400u},
    {0x0000000000000000u, 0x000000174876e800u},
    {0x0000000000000000u, 0x000000e8d4a51000u},
    {0x0000000000000000u, 0x000009184e72a000u},
    {0x0000000000000000u, 0x00005af3107a4000u},
    {0x0000000000000000u, 0x00038d7ea4c68000u},
    {0x0000000000000000u, 0x002386f26fc10000u},
    {0x0000000000000000u, 0x016345785d8a0000u},
    {0x0000000000000000u, 0x0de0b6b3a7640000u},
    {0x0000000000000000u, 0x8ac7230489e80000u},
    {0x0000000000000005u, 0x6bc75e2d63100000u},
    {0x0000000000000036u, 0x35c9adc5dea00000u},
    {0x000000000000021eu, 0x19e0c9bab2400000u},
    {0x000000000000152du, 0x02c7e14af6800000u},
    {0x000000000000d3c2u, 0x1bcecceda1000000u},
    {0x0000000000084595u, 0x161401484a000000u},
    {0x000000000052b7d2u, 0xdcc80cd2e4000000u},
    {0x00000000033b2e3cu, 0x9fd0803ce8000000u},
    {0x00000000204fce5eu, 0x3e25026110000000u},
    {0x00000001431e0faeu, 0x6d7217caa0000000u},
    {0x0000000c9f2c9cd0u, 0x4674edea40000000u},
    {0x0000007e37be2022u, 0xc0914b2680000000u},
    {0x000004ee2d6d415bu, 0x85acef8100000000u},
    {0x0000314dc6448d93u, 0x38c15b0a00000000u},
    {0x0001ed09bead87c0u, 0x378d8e6400000000u},
    {0x0013426172c74d82u, 0x2b878fe800000000u},
    {0x00c097ce7bc90715u, 0xb34b9f1000000000u},
    {0x0785ee10d5da46d9u, 0x00f436a000000000u},
    {0x4b3b4ca85a86c47au, 0x098a224000000000u},
};

/* The exact range: 2^-73 <= |x| < 2^53, i.e. k in [-22, 15] and q in [1, 38]. */
#define FAST_E2_MIN (-73)
#define FAST_E2_MAX 52

static const uint64_t TEN17 = 100000000000000000u;

/* N = m 10^q 2^-s rounded to nearest, ties to even (s in [0, 127], the
 * product below 2^192). */
static uint64_t scaled_round(uint64_t m, int q, int s)
{
    const u128 t0 = (u128)m * POW10[q][1], t1 = (u128)m * POW10[q][0];
    const u128 mid = (t0 >> 64) + (uint64_t)t1;
    const uint64_t w0 = (uint64_t)t0;
    const u128 hi = ((u128)((uint64_t)(t1 >> 64) + (uint64_t)(mid >> 64)) << 64) | (uint64_t)mid;
    /* the product is hi 2^64 + w0; N its top part, the rest compared with 2^(s-1) */
    uint64_t n;
    int above, tie;
    if (s == 0)
        return w0;
    if (s < 64) {
        n = (uint64_t)(hi << (64 - s)) | w0 >> s;
        const uint64_t rest = w0 & (((uint64_t)1 << s) - 1), half = (uint64_t)1 << (s - 1);
        above = rest > half;
        tie = rest == half;
    } else if (s == 64) {
        n = (uint64_t)hi;
        above = w0 > (uint64_t)1 << 63;
        tie = w0 == (uint64_t)1 << 63;
    } else {
        n = (uint64_t)(hi >> (s - 64));
        const u128 rest = hi & (((u128)1 << (s - 64)) - 1), half = (u128)1 << (s - 65);
        above = rest > half || (rest == half && w0 != 0);
        tie = rest == half && w0 == 0;
    }
    return n + (uint64_t)(above || (tie && (n & 1)));
}

static const char DIGIT_PAIRS[] = "00010203040506070809101112131415161718192021222324252627282930313233"
                                  "34353637383940414243444546474849505152535455565758596061626364656667"
                                  "6869707172737475767778798081828384858687888990919293949596979899";

/* n < 10^8 as 8 digits: two independent halves of 4, each two pairs */
static void put8(char *d, uint32_t n)
{
    const uint32_t a = n / 10000, b = n % 10000;
    memcpy(d, DIGIT_PAIRS + 2 * (a / 100), 2);
    memcpy(d + 2, DIGIT_PAIRS + 2 * (a % 100), 2);
    memcpy(d + 4, DIGIT_PAIRS + 2 * (b / 100), 2);
    memcpy(d + 6, DIGIT_PAIRS + 2 * (b % 100), 2);
}

/* printf's own %.17g, with the C locale's decimal point whatever the
 * process's LC_NUMERIC (ivoct never sets one; a program linking libivoct may) */
static char *by_printf(char *p, double x)
{
    char text[64];
    const int len = snprintf(text, sizeof text, "%.17g", x);
    const char *point = localeconv()->decimal_point;
    const size_t np = point && strcmp(point, ".") != 0 ? strlen(point) : 0; /* 0: nothing to do */
    char *q = p;
    for (int i = 0; i < len; i++) {
        if (np && strncmp(text + i, point, np) == 0) {
            *q++ = '.';
            i += (int)np - 1;
        } else {
            *q++ = text[i];
        }
    }
    return q;
}

char *fmt_g17(char *p, double x)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    const int neg = (int)(bits >> 63), be = (int)(bits >> 52 & 0x7ff);
    const uint64_t frac = bits & (((uint64_t)1 << 52) - 1);
    const int e2 = be - 1023; /* 2^e2 <= |x| < 2^(e2 + 1) for a normal x */
    if (be == 0 && frac == 0) {
        if (neg)
            *p++ = '-';
        *p++ = '0';
        return p;
    }
    if (be == 0 || e2 < FAST_E2_MIN || e2 > FAST_E2_MAX)
        return by_printf(p, x);
    /* |x| = m 2^e exactly; k = floor(log10 |x|) is floor(e2 log10 2) or one more
       (78913 / 2^18: log10 2 to 1e-6, exact for |e2| < 1650) */
    const uint64_t m = frac | (uint64_t)1 << 52;
    const int e = e2 - 52;
    const int t = e2 * 78913;
    int k = t >= 0 ? t >> 18 : -((-t + (1 << 18) - 1) >> 18);
    uint64_t n;
    for (;;) {
        n = scaled_round(m, 16 - k, -e); /* e <= 0 here */
        if (n < TEN17)
            break;
        k++; /* x 10^(16 - k) was 10^17 or more, or rounded up to it */
    }
    /* the 17 digits (and 16 zeros after them, read by the fixed-size copies
       below), trailing zeros dropped: %g without '#' */
    char d[33];
    const uint64_t top = n / 100000000; /* 9 digits */
    d[0] = (char)('0' + top / 100000000);
    put8(d + 1, (uint32_t)(top % 100000000));
    put8(d + 9, (uint32_t)(n % 100000000));
    memset(d + 17, '0', 16);
    int nd = 17;
    while (nd > 1 && d[nd - 1] == '0')
        nd--;
    /* the layouts of %g for P = 17, by copies of fixed size (scratch past the
       end is FMT_G17_ROOM's) */
    if (neg)
        *p++ = '-';
    if (k < -4) { /* d.ddde-XX: k in [-22, -5] here */
        p[0] = d[0];
        p[1] = '.';
        memcpy(p + 2, d + 1, 16);
        p += nd > 1 ? nd + 1 : 1;
        memcpy(p, "e-", 2);
        memcpy(p + 2, DIGIT_PAIRS + 2 * -k, 2);
        return p + 4;
    }
    if (k < 0) { /* 0.ddd, 0.0ddd, 0.00ddd, 0.000ddd */
        memcpy(p, "0.000", 5);
        p += 1 - k;
        memcpy(p, d, 17);
        return p + nd;
    }
    /* k in [0, 15]: the integer part's k + 1 digits, then the rest if any */
    memcpy(p, d, 16);
    if (nd <= k + 1)
        return p + k + 1;
    p[k + 1] = '.';
    memcpy(p + k + 2, d + k + 1, 16);
    return p + nd + 1;
}
