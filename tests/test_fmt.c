/* fmt/ (fmt.h): fmt_g17 writes what glibc's printf("%.17g") writes, byte for
 * byte, for every class of double, and never past p + FMT_G17_ROOM.
 *
 * printf is the oracle (glibc formats from the exact binary value by
 * multi-precision arithmetic); fmt_g17 computes the digits by an exact integer
 * product over its range and hands the rest to snprintf, so the values below
 * aim at its range and at the edges of each of its steps: the exponent's
 * estimate (powers of ten and their neighbours, where the 17 digits round up
 * to the next power), the rounding (exact ties, m 2^-j with 18 digits ending
 * in 5), the layouts (%g's switch between fixed and exponential notation at
 * 1e-5 and 1e17, trailing zeros), and the edges of the range (2^-73, 2^53).
 * And printf's fallback keeps '.' as the decimal point under a locale with a
 * decimal comma (de_DE, built here by localedef from Debian's locales). */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, setenv */
#include <float.h>
#include <locale.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <cmocka.h>

#include "../fmt/fmt.h"

/* xorshift64: the same values on every run */
static uint64_t state = 0x9E3779B97F4A7C15u;
static uint64_t next(void)
{
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
}

static double uniform(void) { return (double)(next() >> 11) / 9007199254740992.0; }

static long checked, wrong;

/* fmt_g17(x) against snprintf, in a buffer whose bytes past the room must stay */
static void check(double x)
{
    char want[64], got[FMT_G17_ROOM + 8];
    snprintf(want, sizeof want, "%.17g", x);
    memset(got, '#', sizeof got);
    char *end = fmt_g17(got, x);
    checked++;
    const size_t n = (size_t)(end - got);
    int ok = n <= FMT_G17_MAX && n == strlen(want) && memcmp(got, want, n) == 0;
    for (size_t i = FMT_G17_ROOM; i < sizeof got; i++)
        ok = ok && got[i] == '#';
    if (!ok && wrong++ < 10)
        print_error("x = %a: printf \"%s\", fmt_g17 \"%.*s\"%s\n", x, want, (int)n, got,
                    n > FMT_G17_MAX ? " (too long)" : "");
}

static void check_both_signs(double x)
{
    check(x);
    check(-x);
}

static void expect_all_right(void)
{
    if (wrong)
        fail_msg("%ld of %ld values formatted differently from printf", wrong, checked);
    assert_true(checked > 0);
    checked = wrong = 0;
}

/* Every class of double: random bit patterns (zeros, subnormals, normals of
 * every exponent, infinities, NaNs: mostly outside the exact range, so this is
 * also the fallback's test), and the special values by name. */
static void test_bit_patterns(void **state_)
{
    (void)state_;
    for (long i = 0; i < 1000000; i++) {
        const uint64_t b = next();
        double x;
        memcpy(&x, &b, sizeof x);
        check(x);
    }
    const double special[] = {0.0, INFINITY, NAN, DBL_MIN, DBL_MAX, DBL_TRUE_MIN, DBL_EPSILON,
                              1.0, 0.5, 0.1, 1.0 / 3.0, 2.0 / 3.0, 123.0, 1e-4, 1e-5, 1e15,
                              1e16, 1e17};
    for (size_t i = 0; i < sizeof special / sizeof *special; i++)
        check_both_signs(special[i]);
    expect_all_right();
}

/* The leaves' f_lo and f_hi are floats: every float bit pattern class, and
 * floats of the magnitudes near a surface. */
static void test_floats(void **state_)
{
    (void)state_;
    for (long i = 0; i < 500000; i++) {
        const uint32_t b = (uint32_t)next();
        float f;
        memcpy(&f, &b, sizeof f);
        check(f);
        check((float)((uniform() - 0.5) * 3));
    }
    expect_all_right();
}

/* Magnitudes spread evenly in log scale over the exact range and beyond it
 * (1e-25 to 1e18), with every mantissa. */
static void test_magnitudes(void **state_)
{
    (void)state_;
    for (long i = 0; i < 1000000; i++)
        check_both_signs(pow(10.0, -25 + 43 * uniform()));
    expect_all_right();
}

/* 10^k and its 64 neighbours each way, -40 <= k <= 40: the exponent's
 * estimate is off by one there, and 17 nines round up to the next power. */
static void test_powers_of_ten(void **state_)
{
    (void)state_;
    for (int k = -40; k <= 40; k++) {
        const double p = pow(10.0, k);
        double down = p, up = p;
        for (int j = 0; j < 64; j++) {
            check_both_signs(down);
            check_both_signs(up);
            down = nextafter(down, 0);
            up = nextafter(up, INFINITY);
        }
    }
    /* the ends of the exact range, each side */
    const double edges[] = {ldexp(1, -73), ldexp(1, 53), ldexp(1, -74), ldexp(1, 52)};
    for (size_t i = 0; i < sizeof edges / sizeof *edges; i++)
        for (int j = -8; j <= 8; j++)
            check_both_signs(edges[i] * (1 + j * DBL_EPSILON));
    expect_all_right();
}

/* Exact ties: an odd m of 53 bits times 2^-j has j digits after the point,
 * the last a 5; where that makes 18 significant digits, the 17th is rounded
 * to even.  Ties are counted, so the test knows it reached them. */
static void test_ties(void **state_)
{
    (void)state_;
    long ties = 0;
    for (int j = 1; j <= 12; j++)
        for (long i = 0; i < 20000; i++) {
            const double x = ldexp((double)((next() >> 11) | 1), -j);
            char text[64];
            snprintf(text, sizeof text, "%.40g", x); /* exact: at most 16 + 12 digits */
            size_t digits = 0;
            for (const char *c = text; *c; c++)
                digits += *c >= '0' && *c <= '9';
            ties += digits == 18 && text[strlen(text) - 1] == '5';
            check_both_signs(x);
        }
    /* small integers and their halves (fixed notation, integers with zeros) */
    for (long i = 0; i < 100000; i++)
        check_both_signs((double)i / 2);
    expect_all_right();
    assert_true(ties > 1000);
}

/* Under LC_NUMERIC de_DE printf writes a decimal comma; fmt_g17 must not, on
 * its own path or on printf's (the values outside its exact range). */
static void test_decimal_comma_locale(void **state_)
{
    (void)state_;
    const double values[] = {0.5, -1.25e-3, 1e300, 5e-324, 1.0 / 3.0, 123456.789e20, 1e-30};
    const size_t n = sizeof values / sizeof *values;
    char want[sizeof values / sizeof *values][64];
    for (size_t i = 0; i < n; i++)
        snprintf(want[i], sizeof want[i], "%.17g", values[i]); /* the C locale's */

    char dir[] = "/tmp/ivoct-test-fmt-XXXXXX", cmd[256], path[128];
    assert_non_null(mkdtemp(dir));
    /* localedef warns (exit 1) about the charmap and still writes the locale */
    snprintf(cmd, sizeof cmd, "localedef -c -i de_DE -f UTF-8 %s/de_DE.UTF-8 >/dev/null 2>&1", dir);
    (void)system(cmd);
    snprintf(path, sizeof path, "%s/de_DE.UTF-8/LC_NUMERIC", dir);
    struct stat st;
    if (stat(path, &st) != 0)
        fail_msg("localedef made no de_DE locale in %s (is Debian's locales installed?)", dir);
    setenv("LOCPATH", dir, 1);
    assert_non_null(setlocale(LC_NUMERIC, "de_DE.UTF-8"));
    char probe[64];
    snprintf(probe, sizeof probe, "%.17g", 0.5);
    const int comma = strcmp(probe, "0,5") == 0;
    for (size_t i = 0; i < n; i++) {
        char got[FMT_G17_ROOM];
        char *end = fmt_g17(got, values[i]);
        if ((size_t)(end - got) != strlen(want[i]) || memcmp(got, want[i], strlen(want[i])))
            fail_msg("under de_DE, %a: fmt_g17 \"%.*s\", expected \"%s\"", values[i],
                     (int)(end - got), got, want[i]);
    }
    setlocale(LC_NUMERIC, "C");
    unsetenv("LOCPATH");
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    (void)system(cmd);
    assert_true(comma); /* printf itself wrote the comma: the locale was in force */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bit_patterns), cmocka_unit_test(test_floats),
        cmocka_unit_test(test_magnitudes),   cmocka_unit_test(test_powers_of_ten),
        cmocka_unit_test(test_ties),         cmocka_unit_test(test_decimal_comma_locale),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
