/* ray/ piece by piece: method names, the camera, box clipping, the root
 * finders on hand-made cases (simple, multiple, double and undefined roots,
 * whiskers, segments starting on the surface, the budget), the interval
 * source seam, thread-count independence, and the PNG / .vti writers (the
 * .vti is parsed back and its base64 arrays decoded). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../ray/ray.h"
#include "../scene/scene.h"
#include "support/testutil.h"

static tape_t *compile(const char *text)
{
    tape_t *t = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (tape_compile(text, &t, &err) != 0)
        fail_msg("cannot compile '%s': %s", text, err.msg);
    return t;
}

/* ---- names ----------------------------------------------------------------------- */

static void test_method_names(void **state)
{
    (void)state;
    static const char *const names[] = {"mitchell",     "newton",    "newton-ah", "mrfro",
                                        "mrfro-newton", "lipschitz", "sampling"};
    assert_int_equal(RAY_METHOD_COUNT, 7);
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        ray_method_t p;
        assert_string_equal(ray_method_name((ray_method_t)m), names[m]);
        assert_int_equal(ray_method_parse(names[m], &p), 0);
        assert_int_equal(p, m);
        assert_int_equal(ray_method_certified((ray_method_t)m), m != RAY_SAMPLING);
    }
    ray_method_t p;
    assert_int_not_equal(ray_method_parse("Newton", &p), 0);
    assert_int_not_equal(ray_method_parse("newton-", &p), 0);
    assert_int_not_equal(ray_method_parse("", &p), 0);
    assert_null(ray_method_name(RAY_METHOD_COUNT));
}

/* ---- camera and clipping ------------------------------------------------------------ */

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* ray_octree_params: slabs from RAY_SLAB_RAYS rays on, and then the built
 * tree has a slab array; below (or NaN), the params are left as they were. */
static void test_octree_params(void **state)
{
    (void)state;
    oct_params_t base;
    oct_params_default(&base);
    base.tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ;
    base.slabs_unused = 1;
    base.depth = 4;
    const double few[] = {0, 300.0 * 300.0, RAY_SLAB_RAYS - 1, NAN};
    for (size_t k = 0; k < sizeof few / sizeof few[0]; k++) {
        oct_params_t p = base;
        ray_octree_params(&p, few[k]);
        assert_memory_equal(&p, &base, sizeof p);
    }
    oct_params_t p = base;
    ray_octree_params(&p, RAY_SLAB_RAYS);
    assert_int_equal(p.tests, base.tests | OCT_TEST_ILIE);
    assert_int_equal(p.slabs_unused, 0);
    tape_t *t = compile("x^2 + y^2 + z^2 - 1");
    const double box[6] = {-1.5, 1.5, -1.5, 1.5, -1.5, 1.5};
    oct_tree_t *tree = NULL;
    ivoct_error_t err;
    assert_int_equal(oct_build(t, box, &p, &tree, &err), 0);
    assert_non_null(tree->slabs);
    assert_true(tree->n_leaves > 0);
    oct_free(tree);
    tape_free(t);
}

static void test_camera(void **state)
{
    (void)state;
    ray_camera_t c;
    ivoct_error_t err;
    const double eye[3] = {5, 4, 3}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    assert_int_equal(ray_camera_init(&c, eye, target, up, 30, 5, 3, &err), 0);
    /* an orthonormal, right-handed frame: right x vup = fwd... vup has +z */
    assert_true(fabs(dot(c.fwd, c.fwd) - 1) < 1e-15 && fabs(dot(c.right, c.right) - 1) < 1e-15);
    assert_true(fabs(dot(c.fwd, c.right)) < 1e-15 && fabs(dot(c.fwd, c.vup)) < 1e-15 &&
                fabs(dot(c.right, c.vup)) < 1e-15);
    assert_true(c.vup[2] > 0);
    /* the centre pixel looks at the target; (0,0) is top left */
    double d[3];
    ray_camera_dir(&c, 2, 1, d);
    assert_true(fabs(dot(d, c.fwd) - 1) < 1e-15);
    ray_camera_dir(&c, 0, 0, d);
    assert_true(fabs(dot(d, d) - 1) < 1e-15);
    assert_true(dot(d, c.vup) > 0 && dot(d, c.right) < 0);
    /* vertical fov: the top edge of the image is 15 degrees above the axis */
    double top = (1.0 - 1.0 / 3) * tan(15 * 3.14159265358979323846 / 180);
    assert_true(fabs(dot(d, c.vup) / dot(d, c.fwd) - top) < 1e-14);
    /* a full turn comes back; a quarter turn about z keeps the height */
    ray_camera_t o;
    assert_int_equal(ray_camera_orbit(&c, 2 * 3.14159265358979323846, &o, &err), 0);
    for (int i = 0; i < 3; i++)
        assert_true(fabs(o.eye[i] - eye[i]) < 1e-13);
    assert_int_equal(ray_camera_orbit(&c, 3.14159265358979323846 / 2, &o, &err), 0);
    assert_true(fabs(o.eye[0] + 4) < 1e-13 && fabs(o.eye[1] - 5) < 1e-13 &&
                fabs(o.eye[2] - 3) < 1e-13);
    /* errors */
    const double par[3] = {5, 4, 3}, zero[3] = {0, 0, 0};
    assert_int_not_equal(ray_camera_init(&c, eye, target, par, 30, 5, 3, &err), 0);
    assert_non_null(strstr(err.msg, "parallel"));
    assert_int_not_equal(ray_camera_init(&c, eye, target, zero, 30, 5, 3, &err), 0);
    assert_int_not_equal(ray_camera_init(&c, eye, eye, up, 30, 5, 3, &err), 0);
    assert_int_not_equal(ray_camera_init(&c, eye, target, up, 0, 5, 3, &err), 0);
    assert_int_not_equal(ray_camera_init(&c, eye, target, up, 180, 5, 3, &err), 0);
    assert_int_not_equal(ray_camera_init(&c, eye, target, up, 30, 0, 3, &err), 0);
    assert_int_not_equal(ray_camera_init(&c, eye, target, up, 30, 5, RAY_MAX_SIZE + 1, &err),
                         0);
    const double nan3[3] = {NAN, 0, 0};
    assert_int_not_equal(ray_camera_init(&c, nan3, target, up, 30, 5, 3, &err), 0);
}

static void test_clip(void **state)
{
    (void)state;
    const double box[6] = {-1, 1, -2, 2, -3, 3};
    double t0, t1;
    const double o[3] = {-5, 0, 0}, dx[3] = {1, 0, 0};
    assert_int_equal(ray_clip_box(box, o, dx, &t0, &t1), 1);
    assert_true(t0 <= 4 && t0 > 4 - 1e-14 && t1 >= 6 && t1 < 6 + 1e-14);
    const double away[3] = {-1, 0, 0};
    assert_int_equal(ray_clip_box(box, o, away, &t0, &t1), 0);
    const double inside[3] = {0.5, 0.5, 0.5};
    assert_int_equal(ray_clip_box(box, inside, dx, &t0, &t1), 1);
    assert_true(t0 == 0 && t1 >= 0.5);
    /* parallel to a face, outside its slab */
    const double high[3] = {-5, 2.5, 0};
    assert_int_equal(ray_clip_box(box, high, dx, &t0, &t1), 0);
    /* the exact range is enclosed: a slanted ray through 0.1-ish faces */
    const double b2[6] = {0.1, 0.7, -1, 1, -1, 1}, o2[3] = {0, 0, 0}, d2[3] = {0.6, 0.8, 0};
    assert_int_equal(ray_clip_box(b2, o2, d2, &t0, &t1), 1);
    assert_true(t0 * 0.6 <= 0.1 && t1 * 0.6 >= 0.7 * (1 - 1e-15) && t1 * 0.8 <= 1 + 1e-15);
    const double dn[3] = {NAN, 0, 0};
    assert_int_equal(ray_clip_box(box, o, dn, &t0, &t1), 0);
}

/* ---- root finders ------------------------------------------------------------------------ */

typedef struct rcase {
    const char *f;
    double o[3], d[3], t0, t1;
    int hit;      /* expected for certified methods */
    double t;     /* expected first root (if hit) */
    double tol;   /* on t */
    int sampling; /* 1: sampling must agree; 0: not checked */
} rcase_t;

static const rcase_t CASES[] = {
    /* simple roots */
    {"x - 0.3", {0, 0, 0}, {1, 0, 0}, 0, 1, 1, 0.3, 4e-16, 1},
    {"x^2 + y^2 - 1", {-2, 0.5, 0}, {1, 0, 0}, 0, 4, 1, 2 - 0.86602540378443865, 1e-15, 1},
    {"(x-0.2)*(x-0.5)*(x-0.7)", {0, 0, 0}, {1, 0, 0}, 0, 1, 1, 0.2, 1e-15, 1},
    {"(x-0.2)*(x-0.5)*(x-0.7)", {0, 0, 0}, {1, 0, 0}, 0.3, 1, 1, 0.5, 1e-15, 1},
    {"(x-0.2)*(x-0.5)*(x-0.7)", {0, 0, 0}, {1, 0, 0}, 0.21, 0.49, 0, 0, 0, 1},
    /* two close roots, far from the step of sampling: certified methods see them */
    {"(x-0.5)^2 - 1e-10", {0, 0, 0}, {1, 0, 0}, 0, 1, 1, 0.5 - 1e-5, 1e-15, 0},
    /* a root at the very start of the segment, and one at its end */
    {"x", {0, 0, 0}, {1, 0, 0}, 0, 1, 1, 0, 1e-300, 1},
    {"x - 1", {0, 0, 0}, {1, 0, 0}, 0, 1, 1, 1, 4e-16, 1},
    /* a tangent (double root, no sign change) and a near miss; g = (t-2)^2 is
     * below the rounding of f (~1e-16) for |t - 2| < ~1e-8: that is the zero band */
    {"x^2 + y^2 - 1", {-2, 1, 0}, {1, 0, 0}, 0, 4, 1, 2, 1e-7, 0},
    {"x^2 + y^2 - 1", {-2, 1 + 1e-6, 0}, {1, 0, 0}, 0, 4, 0, 0, 0, 1},
    /* a whisker: f = 0 on the z axis only */
    {"x^2 + y^2", {-1, 0, 0.5}, {1, 0, 0}, 0, 2, 1, 1, 1e-7, 0},
    {"x^2 + y^2", {-1, 1e-3, 0.5}, {1, 0, 0}, 0, 2, 0, 0, 0, 1},
    /* f undefined on part of the ray (x < 0) */
    {"sqrt(x) - 0.5", {-3, 0, 0}, {1, 0, 0}, 0, 4, 1, 3.25, 1e-15, 1},
    {"sqrt(x) - 2", {-3, 0, 0}, {1, 0, 0}, 0, 4, 0, 0, 0, 1},
    {"log(x)", {-1, 0, 0}, {1, 0, 0}, 0, 3, 1, 2, 1e-15, 1},
    /* no root at all, and a constant */
    {"x^2 + 1", {-1, 0, 0}, {1, 0, 0}, 0, 2, 0, 0, 0, 1},
    {"2", {-1, 0, 0}, {1, 0, 0}, 0, 2, 0, 0, 0, 1},
    /* an oblique ray through a quartic (gumdrop) near its waist */
    {"4*(x^4 + (y^2+z^2)^2) + 17*x^2*(y^2+z^2) - 20*(x^2+y^2+z^2) + 17",
     {5, 0.3, 0.2}, {-1, 0, 0}, 0, 10, 1, 3.1625534008496970, 1e-14, 1},
};

static void test_root_cases(void **state)
{
    (void)state;
    ray_opts_t o;
    ray_opts_default(&o);
    for (size_t k = 0; k < sizeof CASES / sizeof CASES[0]; k++) {
        const rcase_t *c = &CASES[k];
        tape_t *t = compile(c->f);
        tape_ws_t *ws = tape_ws_new(t->n);
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            int cert = ray_method_certified((ray_method_t)m);
            if (!cert && !c->sampling)
                continue;
            ray_result_t r;
            ray_hit_kind_t kind =
                ray_find_root(t, ws, (ray_method_t)m, &o, c->o, c->d, c->t0, c->t1, &r);
            assert_int_equal(kind, r.kind);
            if ((kind != RAY_MISS) != c->hit)
                fail_msg("case %zu (%s) %s: expected %s, got kind %d t=%.17g", k, c->f,
                         ray_method_name((ray_method_t)m), c->hit ? "a hit" : "a miss", kind,
                         r.t);
            if (!c->hit) {
                assert_true(isnan(r.t));
                continue;
            }
            if (!(fabs(r.t - c->t) <= c->tol + 4 * 0x1p-52 * fabs(c->t)))
                fail_msg("case %zu (%s) %s: t = %.17g, expected %.17g", k, c->f,
                         ray_method_name((ray_method_t)m), r.t, c->t);
            assert_true(r.t_lo <= r.t && r.t <= r.t_hi);
            assert_true(r.evals > 0);
        }
        tape_ws_free(ws);
        tape_free(t);
    }
}

/* degenerate input, and the budget: never a crash, a miss or a conservative hit */
static void test_root_edges(void **state)
{
    (void)state;
    tape_t *t = compile("x^2 + y^2 - 1");
    tape_ws_t *ws = tape_ws_new(t->n);
    const double o[3] = {-2, 0, 0}, d[3] = {1, 0, 0};
    ray_result_t r;
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        assert_int_equal(ray_find_root(t, ws, (ray_method_t)m, NULL, o, d, 2, 1, &r), RAY_MISS);
        assert_int_equal(ray_find_root(t, ws, (ray_method_t)m, NULL, o, d, NAN, 1, &r),
                         RAY_MISS);
        assert_int_equal(ray_find_root(t, ws, (ray_method_t)m, NULL, o, d, 0, INFINITY, &r),
                         RAY_MISS);
        const double dn[3] = {NAN, 0, 0};
        assert_int_equal(ray_find_root(t, ws, (ray_method_t)m, NULL, o, dn, 0, 1, &r),
                         RAY_MISS);
        /* a degenerate segment on the surface */
        assert_int_not_equal(ray_find_root(t, ws, (ray_method_t)m, NULL, o, d, 1, 1, &r),
                             RAY_MISS);
        assert_true(r.t == 1);
    }
    assert_int_equal(ray_find_root(t, ws, RAY_METHOD_COUNT, NULL, o, d, 0, 4, &r), RAY_MISS);
    /* a budget of 2 segments on a tangent ray ends in a conservative hit */
    ray_opts_t opts;
    ray_opts_default(&opts);
    opts.max_nodes = 2;
    const double ot[3] = {-2, 1, 0};
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        if (!ray_method_certified((ray_method_t)m))
            continue;
        ray_hit_kind_t k = ray_find_root(t, ws, (ray_method_t)m, &opts, ot, d, 0, 4, &r);
        assert_int_equal(k, RAY_HIT_BUDGET);
        assert_true(r.t >= 0 && r.t <= 2);
    }
    tape_ws_free(ws);
    tape_free(t);
}

/* ---- scenes: sources, threads, writers ---------------------------------------------------- */

/* A source that cuts the box segment into k pieces (front to back), as an
 * octree traversal would hand over leaves. */
typedef struct split_ctx {
    double box[6];
    int k;
} split_ctx_t;

typedef struct split_state {
    double t0, t1;
    int i, k;
} split_state_t;

static void split_begin(const void *ctx, void *state, const double o[3], const double d[3])
{
    const split_ctx_t *c = ctx;
    split_state_t *s = state;
    s->k = ray_clip_box(c->box, o, d, &s->t0, &s->t1) ? c->k : 0;
    s->i = 0;
}

static int split_next(const void *ctx, void *state, ray_segment_t *seg, uint64_t *leaves)
{
    (void)ctx;
    split_state_t *s = state;
    if (s->i >= s->k)
        return 0;
    double w = s->t1 - s->t0;
    seg->t_in = s->i == 0 ? s->t0 : s->t0 + w * s->i / s->k;
    seg->t_out = s->i + 1 == s->k ? s->t1 : s->t0 + w * (s->i + 1) / s->k;
    seg->tape = NULL;
    s->i++;
    ++*leaves;
    return 1;
}

static void render(const scene_t *s, int w, int h, ray_method_t m, int threads,
                   const ray_source_t *src, ray_image_t *img, ray_stats_t *st)
{
    ivoct_error_t err;
    ray_camera_t cam;
    assert_int_equal(ray_camera_init(&cam, s->camera.eye, s->camera.target, s->camera.up, s->camera.fov, w, h, &err), 0);
    assert_int_equal(ray_image_alloc(img, w, h, &err), 0);
    ray_render_opts_t o;
    ray_render_opts_default(&o);
    o.method = m;
    o.threads = threads;
    if (ray_render(s->tape, &cam, src, &o, img, st, &err))
        fail_msg("render: %s", err.msg);
}

static void test_source_seam(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("gumdrop", &s);
    ray_box_source_t bs;
    ray_source_t one = ray_box_source(&bs, s.box);
    split_ctx_t sc;
    memcpy(sc.box, s.box, sizeof sc.box);
    sc.k = 7;
    ray_source_t seven = {&sc, sizeof(split_state_t), split_begin, split_next};
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        ray_image_t a, b;
        ray_stats_t sa, sb;
        render(&s, 24, 20, (ray_method_t)m, 0, &one, &a, &sa);
        render(&s, 24, 20, (ray_method_t)m, 0, &seven, &b, &sb);
        assert_true(sa.hits > 50);
        assert_int_equal(sa.leaves, 0);
        assert_true(sb.leaves > sa.segments && sb.segments > sa.segments);
        for (int i = 0; i < 24 * 20; i++) {
            assert_int_equal(a.hit[i], b.hit[i]);
            if (a.hit[i])
                assert_true(fabs(a.t[i] - b.t[i]) <= 1e-12 * a.t[i]);
        }
        ray_image_free(&a);
        ray_image_free(&b);
    }
    scene_free(&s);
}

/* Every buffer of a and b (of one size) the same, byte for byte. */
static void assert_same_buffers(const ray_image_t *a, const ray_image_t *b)
{
    assert_true(a->width == b->width && a->height == b->height);
    const size_t n = (size_t)a->width * a->height;
    assert_memory_equal(a->t, b->t, n * sizeof *a->t);
    assert_memory_equal(a->hit, b->hit, n);
    assert_memory_equal(a->kind, b->kind, n);
    assert_memory_equal(a->point, b->point, 3 * n * sizeof *a->point);
    assert_memory_equal(a->normal, b->normal, 3 * n * sizeof *a->normal);
    assert_memory_equal(a->dir, b->dir, 3 * n * sizeof *a->dir);
    assert_memory_equal(a->rgb, b->rgb, 3 * n);
}

static void test_threads_identical(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("chubs", &s);
    ray_box_source_t bs;
    ray_source_t src = ray_box_source(&bs, s.box);
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        ray_image_t a, b;
        ray_stats_t sa, sb;
        render(&s, 37, 29, (ray_method_t)m, 1, &src, &a, &sa);
        render(&s, 37, 29, (ray_method_t)m, 3, &src, &b, &sb);
        size_t n = 37 * 29;
        assert_int_equal(sa.threads, 1);
        assert_int_equal(sb.threads, 3);
        assert_same_buffers(&a, &b);
        assert_true(sa.hits == sb.hits && sa.tape_evals == sb.tape_evals &&
                    sa.segments == sb.segments && sa.tangent_hits == sb.tangent_hits);
        /* the buffers are consistent: point = ray_point(eye, dir, t), unit normals */
        for (size_t i = 0; i < n; i++) {
            if (!a.hit[i]) {
                assert_true(isnan(a.t[i]) && isnan(a.point[3 * i]) && isnan(a.normal[3 * i]));
                continue;
            }
            double p[3];
            ray_point(s.camera.eye, a.dir + 3 * i, a.t[i], p);
            assert_memory_equal(p, a.point + 3 * i, sizeof p);
            assert_true(fabs(dot(a.normal + 3 * i, a.normal + 3 * i) - 1) < 1e-12);
        }
        ray_image_free(&a);
        ray_image_free(&b);
    }
    scene_free(&s);
}

/* The image rendered in parts (ray_render_opts_t.part), each part packed and
 * unpacked into one image, is the image rendered whole, byte for byte (every
 * buffer, or the shaded image alone with RAY_PACK_RGB), and the
 * parts' counters add up to the whole's; a part leaves the rest of the buffers
 * as they were. */
static void test_parts(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("chubs", &s);
    ray_box_source_t bs;
    ray_source_t src = ray_box_source(&bs, s.box);
    const int W = 53, H = 41; /* 4 x 3 tiles, the last column and row partial */
    const size_t n = (size_t)W * H;
    ivoct_error_t err;
    ray_camera_t cam;
    assert_int_equal(ray_camera_init(&cam, s.camera.eye, s.camera.target, s.camera.up,
                                     s.camera.fov, W, H, &err), 0);
    ray_image_t whole, merged, shaded, piece;
    ray_stats_t sw;
    render(&s, W, H, RAY_NEWTON_AH, 2, &src, &whole, &sw);
    assert_true(sw.hits > 100 && sw.hits < n);
    assert_int_equal(ray_image_alloc(&merged, W, H, &err), 0);
    assert_int_equal(ray_image_alloc(&piece, W, H, &err), 0);
    assert_int_equal(ray_image_alloc(&shaded, W, H, &err), 0);
    assert_int_equal(ray_pack_bytes(RAY_PACK_ALL), RAY_PIXEL_BYTES);
    assert_int_equal(ray_pack_bytes(RAY_PACK_RGB), 3);
    const int counts[] = {1, 2, 3, 7}; /* 7: parts 6 is empty (tx + ty <= 5) */
    for (size_t c = 0; c < sizeof counts / sizeof *counts; c++) {
        const int parts = counts[c];
        ray_stats_t sum = {0};
        size_t pixels = 0;
        memset(merged.rgb, 0, 3 * n);
        memset(shaded.rgb, 0, 3 * n);
        for (int part = 0; part < parts; part++) {
            ray_render_opts_t o;
            ray_render_opts_default(&o);
            o.threads = 2;
            o.part = part;
            o.parts = parts;
            memset(piece.rgb, 0xAB, 3 * n);
            ray_stats_t st;
            assert_int_equal(ray_render(s.tape, &cam, &src, &o, &piece, &st, &err), 0);
            size_t np = ray_part_pixels(W, H, part, parts);
            assert_int_equal(st.rays, np);
            if (parts == 7 && part == 6)
                assert_int_equal(np, 0);
            /* the pixels outside the part were not touched: as many 0xAB
             * triples as pixels outside it at least (a shaded pixel is never
             * 0xAB 0xAB 0xAB) */
            size_t untouched = 0;
            for (size_t i = 0; i < n; i++)
                untouched += piece.rgb[3 * i] == 0xAB && piece.rgb[3 * i + 1] == 0xAB &&
                             piece.rgb[3 * i + 2] == 0xAB;
            assert_int_equal(untouched, n - np);
            unsigned char *buf = malloc(np * RAY_PIXEL_BYTES + 1);
            assert_non_null(buf);
            ray_image_pack(&piece, part, parts, RAY_PACK_ALL, buf);
            ray_image_unpack(&merged, part, parts, RAY_PACK_ALL, buf);
            ray_image_pack(&piece, part, parts, RAY_PACK_RGB, buf);
            ray_image_unpack(&shaded, part, parts, RAY_PACK_RGB, buf);
            free(buf);
            pixels += np;
            sum.rays += st.rays, sum.hits += st.hits, sum.tangent_hits += st.tangent_hits;
            sum.tape_evals += st.tape_evals, sum.segments += st.segments;
            sum.leaves += st.leaves;
        }
        assert_int_equal(pixels, n);
        assert_same_buffers(&whole, &merged);
        assert_memory_equal(whole.rgb, shaded.rgb, 3 * n);
        assert_true(sum.rays == sw.rays && sum.hits == sw.hits &&
                    sum.tangent_hits == sw.tangent_hits && sum.tape_evals == sw.tape_evals &&
                    sum.segments == sw.segments && sum.leaves == sw.leaves);
    }
    /* a part outside [0, parts) is refused */
    ray_render_opts_t o;
    ray_render_opts_default(&o);
    o.part = 3;
    o.parts = 3;
    assert_int_not_equal(ray_render(s.tape, &cam, &src, &o, &piece, NULL, &err), 0);
    assert_non_null(strstr(err.msg, "part 3 of 3"));
    ray_image_free(&whole);
    ray_image_free(&merged);
    ray_image_free(&shaded);
    ray_image_free(&piece);
    scene_free(&s);
}

/* a singular point: the normal falls back to -dir, never NaN */
static void test_singular_normal(void **state)
{
    (void)state;
    tape_t *t = compile("x^2 + y^2 - z^2"); /* a double cone, singular at 0 */
    ray_camera_t cam;
    ivoct_error_t err;
    const double eye[3] = {3, 0, 0}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    assert_int_equal(ray_camera_init(&cam, eye, target, up, 20, 3, 3, &err), 0);
    ray_image_t img;
    assert_int_equal(ray_image_alloc(&img, 3, 3, &err), 0);
    const double box[6] = {-1, 1, -1, 1, -1, 1};
    ray_box_source_t bs;
    ray_source_t src = ray_box_source(&bs, box);
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        ray_render_opts_t o;
        ray_render_opts_default(&o);
        o.method = (ray_method_t)m;
        assert_int_equal(ray_render(t, &cam, &src, &o, &img, NULL, &err), 0);
        /* the centre ray runs into the apex */
        if (ray_method_certified((ray_method_t)m)) {
            assert_int_equal(img.hit[4], 1);
            assert_true(fabs(img.t[4] - 3) < 1e-6);
        }
        for (int i = 0; i < 9; i++)
            if (img.hit[i])
                for (int k = 0; k < 3; k++)
                    assert_true(isfinite(img.normal[3 * i + k]));
    }
    ray_image_free(&img);
    tape_free(t);
}

/* ray_srgb8 against its formula, computed here with libm's pow: everywhere
 * at random, and at and around each of its 255 steps, where the table hands
 * over to the formula and where an off-by-one would show. */
static unsigned char srgb8_formula(double c)
{
    c = c < 0 ? 0 : c > 1 ? 1 : c;
    return (unsigned char)(255.0 * pow(c, 1.0 / 2.2) + 0.5);
}

static void test_srgb8(void **state)
{
    (void)state;
    static const double edges[] = {-INFINITY, -1e300, -2, -1, -0.5, -0.0, 0.0, 1e-300, 1,
                                   1.5, 2, 3, 1e300, INFINITY};
    for (size_t k = 0; k < sizeof edges / sizeof edges[0]; k++)
        assert_int_equal(ray_srgb8(edges[k]), srgb8_formula(edges[k]));
    assert_int_equal(ray_srgb8(NAN), 0);
    uint64_t x = 0x9e3779b97f4a7c15u;
    for (int k = 0; k < 1000000; k++) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        double c = (double)(x >> 11) * 0x1p-53 * 1.25 - 0.125;
        assert_int_equal(ray_srgb8(c), srgb8_formula(c));
    }
    for (int b = 1; b < 256; b++) {
        /* where the formula steps up to b (within the rounding of pow) */
        double step = pow((b - 0.5) / 255.0, 2.2);
        /* e ulps from it, and e * 2^-33 relative: out to 8 times the band
         * around each step (2^-30) where the table hands over */
        for (int e = -64; e <= 64; e++) {
            double c = step;
            for (int u = 0; u < abs(e); u++)
                c = nextafter(c, e < 0 ? 0 : 2);
            assert_int_equal(ray_srgb8(c), srgb8_formula(c));
            c = step * (1 + e * 0x1p-33);
            assert_int_equal(ray_srgb8(c), srgb8_formula(c));
        }
    }
}

/* ---- writers -------------------------------------------------------------------------------- */

static int b64val(int ch)
{
    const char *p = strchr("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/",
                           ch);
    return ch && p ? (int)(p - "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/")
                   : -1;
}

/* Decode the base64 text between the '>' after `Name="name"` and the next '<'. */
static unsigned char *array_bytes(const char *xml, const char *name, size_t *n)
{
    char key[64];
    snprintf(key, sizeof key, "Name=\"%s\"", name);
    const char *p = strstr(xml, key);
    assert_non_null(p);
    p = strchr(p, '>') + 1;
    const char *end = strchr(p, '<');
    unsigned char *out = malloc((size_t)(end - p));
    size_t k = 0, text = 0;
    unsigned acc = 0;
    int bits = 0;
    for (; p < end; p++) {
        if (*p == ' ' || *p == '\n')
            continue;
        text++;
        if (*p == '=')
            continue;
        int v = b64val(*p);
        assert_true(v >= 0);
        acc = acc << 6 | (unsigned)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out[k++] = (unsigned char)(acc >> bits & 0xff);
        }
    }
    /* whole groups of 4, the last padded with '=' */
    assert_int_equal(text, (k + 2) / 3 * 4);
    *n = k;
    return out;
}

/* The .vti and .png of a W x H render of the sphere, read back. */
static void check_writers(int W, int H)
{
    scene_t s;
    tu_load_scene("sphere", &s);
    ray_box_source_t bs;
    ray_source_t src = ray_box_source(&bs, s.box);
    ray_image_t img;
    ray_stats_t st;
    render(&s, W, H, RAY_NEWTON_AH, 0, &src, &img, &st);
    assert_true(st.hits > 0 && st.hits < (uint64_t)(W * H));
    ray_camera_t cam;
    ivoct_error_t err;
    assert_int_equal(ray_camera_init(&cam, s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, W, H, &err), 0);

    FILE *f = tmpfile();
    assert_non_null(f);
    assert_int_equal(ray_write_vti(f, &img, &cam, "newton-ah", &err), 0);
    rewind(f);
    char *xml = (char *)tu_read_stream(f, NULL);
    fclose(f);
    assert_non_null(strstr(xml, "<VTKFile type=\"ImageData\""));
    char extent[64];
    snprintf(extent, sizeof extent, "WholeExtent=\"0 %d 0 %d 0 0\"", W - 1, H - 1);
    assert_non_null(strstr(xml, extent));
    /* "newton-ah" as a String array: the characters as numbers, then 0 */
    assert_non_null(strstr(xml, ">110 101 119 116 111 110 45 97 104 0</Array>"));
    char eye[128];
    snprintf(eye, sizeof eye, "%.17g %.17g %.17g</DataArray>", s.camera.eye[0], s.camera.eye[1], s.camera.eye[2]);
    assert_non_null(strstr(xml, eye));
    static const struct {
        const char *name;
        int ncomp;
    } arrays[] = {{"t", 1}, {"hit", 1}, {"point", 3}, {"normal", 3}, {"dir", 3}};
    for (size_t a = 0; a < 5; a++) {
        size_t n;
        unsigned char *bytes = array_bytes(xml, arrays[a].name, &n);
        uint64_t count;
        memcpy(&count, bytes, 8);
        assert_int_equal(count, (uint64_t)W * H * arrays[a].ncomp * 8);
        assert_int_equal(n, 8 + count);
        /* VTK row vr is image row H-1-vr */
        for (int vr = 0; vr < H; vr++)
            for (int col = 0; col < W; col++)
                for (int k = 0; k < arrays[a].ncomp; k++) {
                    size_t i = (size_t)(H - 1 - vr) * W + col;
                    double got, want;
                    memcpy(&got, bytes + 8 + 8 * ((size_t)(vr * W + col) * arrays[a].ncomp + k),
                           8);
                    switch (a) {
                    case 0: want = img.t[i]; break;
                    case 1: want = img.hit[i]; break;
                    case 2: want = img.point[3 * i + k]; break;
                    case 3: want = img.normal[3 * i + k]; break;
                    default: want = img.dir[3 * i + k]; break;
                    }
                    assert_true(got == want || (isnan(got) && isnan(want)));
                }
        free(bytes);
    }
    free(xml);

    f = tmpfile();
    assert_non_null(f);
    assert_int_equal(ray_write_png(f, &img, &err), 0);
    rewind(f);
    char *png = (char *)tu_read_stream(f, NULL);
    fclose(f);
    assert_memory_equal(png, "\x89PNG\r\n\x1a\n", 8);
    assert_memory_equal(png + 12, "IHDR", 4);
    const unsigned char *u = (const unsigned char *)png;
    assert_int_equal(u[16] << 24 | u[17] << 16 | u[18] << 8 | u[19], W);
    assert_int_equal(u[20] << 24 | u[21] << 16 | u[22] << 8 | u[23], H);
    free(png);

    /* a write error is reported, not printed */
    f = fopen("/dev/full", "wb");
    if (f) {
        assert_int_not_equal(ray_write_png(f, &img, &err), 0);
        fclose(f);
        f = fopen("/dev/full", "wb");
        assert_int_not_equal(ray_write_vti(f, &img, &cam, "x", &err), 0);
        fclose(f);
    }
    ray_image_free(&img);
    scene_free(&s);
}

/* A small image, and one whose arrays span several of the encoder's blocks;
 * an array of k components holds 8 + 8 W H k bytes, which leaves 0 and 2
 * over 3 in the first (k = 1, 3) and 1 and 2 in the second: every padding. */
static void test_writers(void **state)
{
    (void)state;
    check_writers(7, 5);
    check_writers(131, 68);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_method_names),      cmocka_unit_test(test_camera),
        cmocka_unit_test(test_octree_params),
        cmocka_unit_test(test_clip),              cmocka_unit_test(test_root_cases),
        cmocka_unit_test(test_root_edges),        cmocka_unit_test(test_source_seam),
        cmocka_unit_test(test_threads_identical), cmocka_unit_test(test_singular_normal),
        cmocka_unit_test(test_parts),             cmocka_unit_test(test_writers),
        cmocka_unit_test(test_srgb8),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
