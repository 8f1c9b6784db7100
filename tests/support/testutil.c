#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <glob.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

uint64_t tu_seed(uint64_t fallback)
{
    const char *s = getenv("IVOCT_SEED");
    return s && *s ? strtoull(s, NULL, 0) : fallback;
}

int tu_sanitizer_build(void)
{
    const char *s = getenv("IVOCT_ASAN");
    return s && *s && strcmp(s, "0") != 0;
}

double tu_scale(void)
{
    const char *s = getenv("IVOCT_TEST_SCALE");
    if (s && *s) {
        double v = strtod(s, NULL);
        return v > 0 ? v : 1.0;
    }
    /* The sanitizer build looks for memory and undefined-behaviour errors,
     * which a tenth of the random cases exercise as well; the release build
     * runs the full counts. */
    return tu_sanitizer_build() ? 0.1 : 1.0;
}

const char *tu_source_dir(void)
{
    const char *s = getenv("IVOCT_SOURCE_DIR");
    return s && *s ? s : ".";
}

int tu_scene_files(char ***paths)
{
    char pattern[4096];
    snprintf(pattern, sizeof pattern, "%s/scenes/*.ini", tu_source_dir());
    glob_t g;
    *paths = NULL;
    if (glob(pattern, 0, NULL, &g) != 0)
        return 0;
    char **list = malloc(g.gl_pathc * sizeof *list);
    for (size_t i = 0; i < g.gl_pathc; i++)
        list[i] = strdup(g.gl_pathv[i]);
    int n = (int)g.gl_pathc;
    globfree(&g);
    *paths = list;
    return n;
}

void tu_free_list(char **list, int n)
{
    for (int i = 0; i < n; i++)
        free(list[i]);
    free(list);
}

double tu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void tu_result_row(const char *suite, const char *name, const char *outcome, double time_s,
                   double error)
{
    const char *path = getenv("IVOCT_STAB_CSV");
    if (!path || !*path)
        return;
    FILE *f = fopen(path, "a");
    if (!f)
        return;
    /* commas inside a field (names like "+1e3(1,1,1)") would split it: ';' instead */
    const char *field[3] = {suite, name, outcome};
    for (int k = 0; k < 3; k++) {
        for (const char *c = field[k]; *c; c++)
            fputc(*c == ',' ? ';' : *c, f);
        fputc(',', f);
    }
    fprintf(f, "%.3f,%.3g\n", time_s, error);
    fclose(f);
}

void tu_load_scene(const char *name, scene_t *s)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/scenes/%s.ini", tu_source_dir(), name);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(path, s, &err))
        fail_msg("%s: %s", path, err.msg);
}

tape_t *tu_compile_uvw(const char *f, const char *u, const char *v, const char *w)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    tape_compiler_t *tc = tape_compiler_new();
    assert_non_null(tc);
    tape_t *t = NULL;
    if (tape_compiler_define(tc, "u", u, &err) || tape_compiler_define(tc, "v", v, &err) ||
        tape_compiler_define(tc, "w", w, &err) || tape_compiler_compile(tc, f, &t, &err))
        fail_msg("%s with u = %s, v = %s, w = %s: %s", f, u, v, w, err.msg);
    tape_compiler_free(tc);
    return t;
}

tape_t *tu_compile(const char *f) { return tu_compile_uvw(f, "x", "y", "z"); }
