#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <glob.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

uint64_t tu_seed(uint64_t fallback)
{
    const char *s = getenv("IVOCT_SEED");
    return s && *s ? strtoull(s, NULL, 0) : fallback;
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
    const char *asan = getenv("IVOCT_ASAN");
    return asan && *asan && strcmp(asan, "0") ? 0.1 : 1.0;
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
