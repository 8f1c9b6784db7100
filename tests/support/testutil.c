#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <glob.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../../ray/ray.h"

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

double tu_lerp(double a, double b, double u)
{
    double v = a + (b - a) * u;
    return v < a ? a : v > b ? b : v;
}

iv_box_t tu_random_subbox(const double box[6], uint64_t *rng)
{
    iv_t r[3];
    double frac = exp2(-30.0 * tu_uniform(rng));
    int point = tu_next(rng) % 16 == 0;
    for (int k = 0; k < 3; k++) {
        double lo = box[2 * k], hi = box[2 * k + 1];
        double w = (hi - lo) * frac;
        double a = tu_lerp(lo, hi - w, tu_uniform(rng));
        double e = point ? a : fmin(a + w, hi);
        r[k] = iv_make(a, e < a ? a : e);
    }
    iv_box_t b = {r[0], r[1], r[2]};
    return b;
}

double tu_pick(iv_t r, uint64_t *rng)
{
    switch (tu_next(rng) % 4) {
    case 0: return r.lo;
    case 1: return r.hi;
    default: return tu_lerp(r.lo, r.hi, tu_uniform(rng));
    }
}

iv_t tu_box_side(const iv_box_t *b, int k) { return k == 0 ? b->x : k == 1 ? b->y : b->z; }

void tu_box_point(const iv_box_t *b, int j, uint64_t *rng, double p[3])
{
    for (int k = 0; k < 3; k++) {
        iv_t s = tu_box_side(b, k);
        if (j < 8)
            p[k] = (j >> k) & 1 ? s.hi : s.lo;
        else if (j == 8)
            p[k] = iv_mid(s);
        else
            p[k] = tu_lerp(s.lo, s.hi, tu_uniform(rng));
    }
    if (j > 8 && (j & 1)) {
        int k = (int)(tu_next(rng) % 3);
        iv_t s = tu_box_side(b, k);
        p[k] = tu_next(rng) & 1 ? s.hi : s.lo;
    }
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
        fail_msg("%s: no scene files", pattern);
    char **list = malloc(g.gl_pathc * sizeof *list);
    for (size_t i = 0; i < g.gl_pathc; i++)
        list[i] = strdup(g.gl_pathv[i]);
    int n = (int)g.gl_pathc;
    globfree(&g);
    *paths = list;
    if (n < TU_N_SCENE_FILES)
        fail_msg("%s: %d scene files, expected at least %d (one per surface of docs/surfaces.md, and the "
                 "parametric ones)",
                 pattern, n, TU_N_SCENE_FILES);
    return n;
}

const char *const tu_comparison_surfaces[TU_N_COMPARISON] = {
    "sphere", "drop", "chubs", "crosscap", "gumdrop", "horned-cube", "mcmullen-k3",
    "kusner-schmitt",
};

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

oct_tree_t *tu_scene_octree(const scene_t *s)
{
    oct_params_t p = s->octree;
    p.depth = tu_scale() < 1 && p.depth > 6 ? 6 : p.depth;
    p.threads = 2;
    oct_tree_t *t = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_build(s->tape, s->box, &p, &t, &err))
        fail_msg("%s: oct_build: %s", s->source.name, err.msg);
    return t;
}

int tu_image_size(int full)
{
    int n = (int)(full * sqrt(tu_scale()) + 0.5);
    return n < 16 ? 16 : n;
}

void tu_side_light(const ray_camera_t *cam, double light[3])
{
    double r = 0;
    for (int a = 0; a < 3; a++)
        r += (cam->eye[a] - cam->target[a]) * (cam->eye[a] - cam->target[a]);
    r = sqrt(r);
    for (int a = 0; a < 3; a++)
        light[a] = cam->target[a] + r * (0.8 * cam->right[a] + 0.6 * cam->vup[a]);
}

void tu_render_source(const scene_t *s, const ray_camera_t *cam, const ray_source_t *src,
                      ray_method_t m, int threads, ray_image_t *img, ray_stats_t *st)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (ray_image_alloc(img, cam->width, cam->height, &err))
        fail_msg("ray_image_alloc: %s", err.msg);
    ray_render_opts_t o;
    ray_render_opts_default(&o);
    o.method = m;
    o.threads = threads;
    double dx = s->box[1] - s->box[0], dy = s->box[3] - s->box[2], dz = s->box[5] - s->box[4];
    o.roots.sample_step = sqrt(dx * dx + dy * dy + dz * dz) / 1000;
    if (ray_render(s->tape, cam, src, &o, img, st, &err))
        fail_msg("render: %s", err.msg);
}

void tu_render(const scene_t *s, const ray_camera_t *cam, const oct_tree_t *tree,
               ray_method_t m, int threads, ray_image_t *img, ray_stats_t *st)
{
    ray_box_source_t bs;
    ray_octree_source_t os;
    ray_source_t src = tree ? ray_octree_source(&os, tree) : ray_box_source(&bs, s->box);
    tu_render_source(s, cam, &src, m, threads, img, st);
}

void tu_load_scene(const char *name, scene_t *s)
{
    char path[4096];
    if (strchr(name, '/'))
        snprintf(path, sizeof path, "%s", name);
    else
        snprintf(path, sizeof path, "%s/scenes/%s.ini", tu_source_dir(), name);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(path, s, &err)) {
        char buf[1024];
        fail_msg("cannot load %s: %s", path, ivoct_error_format(&err, buf, sizeof buf));
    }
}

unsigned char *tu_read_stream(FILE *f, size_t *n)
{
    size_t cap = 1 << 16, len = 0, got;
    unsigned char *p = malloc(cap);
    assert_non_null(p);
    while ((got = fread(p + len, 1, cap - len - 1, f)) > 0) {
        len += got;
        if (len + 1 == cap) {
            cap *= 2;
            p = realloc(p, cap);
            assert_non_null(p);
        }
    }
    if (ferror(f))
        fail_msg("read error");
    p[len] = '\0';
    if (n)
        *n = len;
    return p;
}

unsigned char *tu_read_file(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("cannot open %s", path);
    unsigned char *p = tu_read_stream(f, n);
    fclose(f);
    return p;
}

const char *const tu_op_exprs[] = {
    /* linear */
    "x + y", "x - y", "-x + 3*y - z/4", "0.1*x - y + 1e-3",
    /* products */
    "x*y", "x*y*z", "(x + y)*(x - y)", "(x + 0.1)*(y - 0.3)*(z + 0.7)", "x^2", "(x - y)^2",
    "(x*y - z)^2", "(x^2 + y^2 + z^2 - 1)^2",
    /* integer powers */
    "x^3", "x^4", "x^5", "(x - 0.5)^7", "(x*y)^6", "x^-1", "x^-2", "x^-3", "(x + y)^-4",
    /* real powers */
    "x^0.5", "x^1.5", "x^2.5", "x^-0.5", "x^0.3", "(x*x + y)^0.75", "(1 + x^2)^-1.5",
    /* division */
    "x/y", "1/x", "y/(x + 0.5)", "(x + y)/(1 + x^2 + y^2)", "x/(y*z)",
    /* sqrt exp log */
    "sqrt(x)", "sqrt(x^2 + y^2 + z^2)", "sqrt(x*y + z)", "exp(x)", "exp(x*y)",
    "exp(-(x^2 + y^2))", "log(x)", "log(x^2 + y*z)", "log(1 + x^2)",
    /* trigonometric */
    "sin(x)", "cos(x)", "tan(x)", "atan(x)", "sin(x*y)", "cos(3*x + y)", "tan(x*y - z)",
    "atan(x*y - z)", "atan(1/x)",
    /* abs min max */
    "abs(x)", "abs(x - y)", "abs(x*y) - z", "min(x, y)", "max(x, y)", "min(x*y, z)",
    "max(x^2, y) - z", "min(max(x, y), z)", "max(abs(x) - 1, y*z)",
    /* composites */
    "sin(3*x)*cos(2*y) + z", "exp(x*y) - log(1 + z^2)", "abs(x - y) - min(x*z, y)",
    "max(x, y*z)/(2 + sin(x))", "x^3 - 3*x*y^2 + z", "atan(x/y) + sqrt(abs(z))",
    "1/(x^2 + y^2 + 0.01) - exp(z)", "min(x^2 + y^2 - 1, (x - 1)^2 + z^2 - 0.5)",
    "log(exp(x) + exp(y))", "tan(atan(x) / 2)", "pi*x - e*y", "(x*y*z)^(1/3)", "2^x",
};

const size_t tu_n_op_exprs = sizeof tu_op_exprs / sizeof *tu_op_exprs;

const double tu_op_boxes[TU_N_OP_BOXES][6] = {
    {-2, 3, -1.5, 2.5, -3, 1},
    {-1e-3, 2e-3, -2e-3, 1e-3, -1e-3, 1e-3},
    {-1e3, 2e3, -3e3, 1e3, -1e3, 1e3},
};

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
