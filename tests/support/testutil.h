/* Helpers shared by the tests: a seeded PRNG, the scene directory, scene and
 * expression loading that fails the running cmocka test on error. */
#ifndef IVOCT_TEST_UTIL_H
#define IVOCT_TEST_UTIL_H

#include <stdint.h>

#include "../../expr/tape.h"
#include "../../scene/scene.h"

/* splitmix64: fast, fixed-seed, good enough for test inputs */
static inline uint64_t tu_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* uniform in [0, 1) */
static inline double tu_uniform(uint64_t *s)
{
    return (double)(tu_next(s) >> 11) * 0x1p-53;
}

/* The seed: IVOCT_SEED from the environment, else the given default. */
uint64_t tu_seed(uint64_t fallback);

/* Is this the sanitizer build (IVOCT_ASAN set and not "0")?  Tests shrink
 * their sizes there: the instrumented code runs ~10x slower. */
int tu_sanitizer_build(void);

/* Scale factor for iteration counts: IVOCT_TEST_SCALE, else 0.1 in the
 * sanitizer build (IVOCT_ASAN set), else 1. */
double tu_scale(void);

/* The source tree: IVOCT_SOURCE_DIR, else ".". */
const char *tu_source_dir(void);

/* Paths of the scene files (scenes/NAME.ini), sorted; returns the count, *paths malloc'd (free with tu_free_list). */
int tu_scene_files(char ***paths);
void tu_free_list(char **list, int n);

/* scenes/NAME.ini into *s (scene_free it); fails the current test on error. */
void tu_load_scene(const char *name, scene_t *s);

/* The tape of expression f, with u, v, w defined as the given expressions
 * (e.g. u = "x - 1e8" translates a scene written in u, v, w); tu_compile(f) is
 * f in x, y, z.  Fails the current test on error. */
tape_t *tu_compile_uvw(const char *f, const char *u, const char *v, const char *w);
tape_t *tu_compile(const char *f);

/* Wall-clock seconds (monotonic). */
double tu_now(void);

/* One result row for a benchmark table: when IVOCT_STAB_CSV names a file,
 * append "suite,case,outcome,time_s,error" to it (bench/stability.sh sets it;
 * the tests run without it).  Commas inside the fields are written as ';'. */
void tu_result_row(const char *suite, const char *name, const char *outcome, double time_s,
                   double error);

#endif
