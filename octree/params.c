/* ivoct — the octree's settings by name: defaults, the test lists that scene
 * files ([octree] tests) and the command line (--tests) give, and the checks
 * of what they set. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "octree.h"

/* The tests by bit, cheapest first: bit k is 1u << k. */
static const char *const TEST_NAMES[] = {"interval", "lipschitz", "ilie"};
#define N_TESTS (sizeof TEST_NAMES / sizeof TEST_NAMES[0])

_Static_assert(OCT_TEST_INTERVAL == 1u << 0 && OCT_TEST_LIPSCHITZ == 1u << 1 &&
                   OCT_TEST_ILIE == 1u << 2,
               "TEST_NAMES follows the OCT_TEST_* bits");

#define EXPECTED "interval, lipschitz or ilie"

void oct_params_default(oct_params_t *p)
{
    memset(p, 0, sizeof *p);
    p->depth = OCT_DEFAULT_DEPTH;
    p->tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ;
    p->refine = 0;
}

/* The blanks between names: those of the C locale's isspace. */
static int blank(int c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

/* Skip blanks from text[*i], counting lines. */
static void skip_blanks(const char *text, size_t *i, int *line, size_t *line_start)
{
    while (blank((unsigned char)text[*i])) {
        if (text[*i] == '\n') {
            (*line)++;
            *line_start = *i + 1;
        }
        (*i)++;
    }
}

int oct_tests_parse(const char *text, unsigned *tests, ivoct_error_t *err)
{
    unsigned mask = 0;
    int line = 1;
    size_t ls = 0, i = 0;
    if (!text)
        text = "";
    for (;;) {
        skip_blanks(text, &i, &line, &ls);
        size_t a = i;
        while (text[i] && text[i] != ',' && !blank((unsigned char)text[i]))
            i++;
        if (i == a) {
            ivoct_error_at(err, line, (int)(a - ls) + 1, "expected a test name: " EXPECTED);
            return -1;
        }
        size_t k = 0;
        while (k < N_TESTS &&
               !(strlen(TEST_NAMES[k]) == i - a && memcmp(TEST_NAMES[k], text + a, i - a) == 0))
            k++;
        if (k == N_TESTS) {
            ivoct_error_at(err, line, (int)(a - ls) + 1, "unknown test '%.*s'; expected " EXPECTED,
                           (int)(i - a < 40 ? i - a : 40), text + a);
            return -1;
        }
        mask |= 1u << k;
        skip_blanks(text, &i, &line, &ls);
        if (!text[i])
            break;
        if (text[i] != ',') {
            ivoct_error_at(err, line, (int)(i - ls) + 1, "expected ',' between test names");
            return -1;
        }
        i++;
    }
    *tests = mask;
    return 0;
}

char *oct_tests_format(unsigned tests, char *buf, size_t n)
{
    if (!buf || n == 0)
        return buf;
    buf[0] = '\0';
    size_t len = 0;
    for (size_t k = 0; k < N_TESTS; k++) {
        if (!(tests & (1u << k)))
            continue;
        int w = snprintf(buf + len, n - len, "%s%s", len ? ", " : "", TEST_NAMES[k]);
        if (w < 0 || (size_t)w >= n - len)
            break;
        len += (size_t)w;
    }
    return buf;
}

int oct_params_check(const oct_params_t *p, ivoct_error_t *err)
{
    if (p->depth < 0 || p->depth > OCT_MAX_DEPTH) {
        ivoct_error_set(err, "depth %d is out of range 0..%d", p->depth, OCT_MAX_DEPTH);
        return -1;
    }
    if (p->tests == 0 || (p->tests & ~(OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE))) {
        ivoct_error_set(err, "tests: expected one or more of " EXPECTED);
        return -1;
    }
    if (!(p->refine >= 0) || !isfinite(p->refine)) {
        ivoct_error_set(err, "refine %g: expected a length >= 0 (0 = off)", p->refine);
        return -1;
    }
    if (p->refine > 0 && !(p->tests & OCT_TEST_ILIE)) {
        ivoct_error_set(err, "refine %g needs the ilie test", p->refine);
        return -1;
    }
    return 0;
}
