/* Beams (ray/beam.c, ray/README.md "Beams"): a tile's rays walked through the
 * octree together decide, as misses, the rays of a beam that reaches no
 * surface leaf.  The promise: the images and every buffer are byte-identical
 * with and without beams, for every method and any thread count.
 *
 *  - the beam walk against the per-ray walk it stands for: random beams
 *    (random origins inside and outside the box, directions the hull of
 *    random rays around a random axis, some with a component that is 0 or
 *    changes sign, some exactly axis-parallel), every ray of the beam and the
 *    corners of its box walked alone by the octree source: when the beam
 *    reaches no surface leaf, no ray may get a single segment;
 *  - the packet walk against the per-ray walk: random packets of rays from one
 *    origin, through trees with and without slabs and leaf tapes, on every
 *    SIMD path; each ray's segments (bits, leaf, tape, order) as its own walk
 *    yields them, with t_max lowered and rays stopped along the way;
 *  - beams and --no-beams (ray_render_opts_t.no_beams) on the eight
 *    comparison surfaces and the 64-sphere CSG union, every method: every
 *    buffer identical (memcmp: t point normal dir hit kind shadow rgb), and
 *    every counter but the beams' own; the CSG union also with leaf tapes and
 *    a light, on 1 and 2 threads;
 *  - the stress cases of tests/test_stab_rays.c that go through ray_render
 *    (grazing rays at silhouettes, the singular Whitney umbrella, the thin
 *    shell, the tiny sphere, a depth-16 tree), every method, with a light;
 *  - images whose size is not a multiple of the tile, and parts of an image
 *    (the MPI split).
 * Sizes shrink in the sanitizer build (tu_image_size, tu_scene_octree). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../ray/beam_internal.h" /* the beam and packet walks themselves: the first tests */
#include "../ray/ray.h"
#include "support/testutil.h"

/* ---- the beam walk against the per-ray walk --------------------------------------- */

/* How many surface leaves the per-ray walk yields for o + t·d (t_max = inf). */
static uint64_t ray_leaves(const ray_source_t *src, void *state, const double o[3],
                           const double d[3])
{
    uint64_t leaves = 0;
    ray_segment_t seg = {.t_max = INFINITY};
    src->begin(src->ctx, state, o, d);
    while (src->next(src->ctx, state, &seg, &leaves))
        seg.t_max = INFINITY;
    return leaves;
}

/* The centre and the half widths of a box. */
static void centre_half(const double box[6], double c[3], double h[3])
{
    for (int a = 0; a < 3; a++) {
        c[a] = 0.5 * box[2 * a] + 0.5 * box[2 * a + 1];
        h[a] = 0.5 * (box[2 * a + 1] - box[2 * a]);
    }
}

static void unit(double d[3])
{
    double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; a++)
        d[a] /= n;
}

/* Random beams through the tree of a scene: whenever the beam walk says the
 * beam reaches no surface leaf, every ray of the beam (and the 8 corners of
 * its direction box, which are directions of the beam too) is walked alone
 * and must yield nothing.  Not vacuous: many beams are decided, many of them
 * through the tree's box, and some reached. */
static void test_beam_walk(void **state)
{
    (void)state;
    const char *names[] = {"gumdrop", "chubs", "whitney-umbrella"};
    uint64_t rng = tu_seed(0xbea1);
    const int n_beams = (int)(2000 * tu_scale()) + 50;
    long decided = 0, decided_through_box = 0, reached = 0;
    for (size_t k = 0; k < sizeof names / sizeof *names; k++) {
        scene_t s;
        tu_load_scene(names[k], &s);
        oct_tree_t *tree = tu_scene_octree(&s);
        ray_octree_source_t os;
        ray_source_t src = ray_octree_source(&os, tree);
        void *st = malloc(src.state_size);
        ray_beam_ws_t *bw = ray_beam_ws_new(tree);
        assert_non_null(st);
        assert_non_null(bw);
        double c[3], h[3];
        centre_half(s.box, c, h);
        for (int b = 0; b < n_beams; b++) {
            int kind = b % 4; /* 0, 1 outside, 2 inside the box, 3 axis-parallel */
            double o[3], axis[3], d[16][3];
            for (int a = 0; a < 3; a++) {
                double u = 2 * tu_uniform(&rng) - 1;
                o[a] = c[a] + h[a] * (kind == 2 ? u : 3 * u);
                /* towards a random point of the box */
                axis[a] = c[a] + h[a] * (2 * tu_uniform(&rng) - 1) - o[a];
            }
            if (kind == 3) {
                /* along an axis, the origin on a plane of the tree (a cell
                 * face at the deepest level) in the other two: rays in faces */
                int ax = (int)(tu_next(&rng) % 3);
                for (int a = 0; a < 3; a++) {
                    axis[a] = a == ax ? (tu_next(&rng) & 1 ? 1 : -1) : 0;
                    if (a != ax)
                        o[a] = oct_coord(s.box[2 * a], s.box[2 * a + 1],
                                         tu_next(&rng) % ((1u << tree->depth) + 1), tree->depth);
                    else
                        o[a] = c[a] - 3 * axis[a] * h[a];
                }
            }
            unit(axis);
            /* the beam's angular size: down to a pixel's, up to a wide tile */
            double spread = kind == 3 ? 0 : pow(2, -3 - 12 * tu_uniform(&rng));
            int n = 1 + (int)(tu_next(&rng) % 16);
            double dlo[3] = {INFINITY, INFINITY, INFINITY}, dhi[3] = {-INFINITY, -INFINITY, -INFINITY};
            for (int j = 0; j < n; j++) {
                for (int a = 0; a < 3; a++)
                    d[j][a] = axis[a] + spread * (2 * tu_uniform(&rng) - 1);
                if (kind != 3)
                    unit(d[j]);
                for (int a = 0; a < 3; a++) {
                    dlo[a] = fmin(dlo[a], d[j][a]);
                    dhi[a] = fmax(dhi[a], d[j][a]);
                }
            }
            if (ray_beam_reaches(tree, bw, o, dlo, dhi)) {
                reached++;
                continue;
            }
            decided++;
            int through = 0;
            for (int j = 0; j < n + 8; j++) {
                double dd[3], t0, t1;
                for (int a = 0; a < 3; a++)
                    dd[a] = j < n ? d[j][a] : ((j - n) >> a & 1) ? dhi[a] : dlo[a];
                if (ray_leaves(&src, st, o, dd) != 0)
                    fail_msg("%s beam %d: ray %d yields a leaf the beam does not reach", names[k],
                             b, j);
                through |= ray_clip_box(s.box, o, dd, &t0, &t1);
            }
            decided_through_box += through;
        }
        printf("%s: beams decided %ld (%ld through the box), reached %ld\n", names[k], decided,
               decided_through_box, reached);
        ray_beam_ws_free(bw);
        free(st);
        oct_free(tree);
        scene_free(&s);
    }
    assert_true(decided_through_box > 10 && reached > 10);
}

/* ---- the packet walk against the per-ray walk -------------------------------------- */

/* A consumer of one ray's segments, as the renderer is: after each segment it
 * may lower t_max (a hit: to a point of the segment) or stop the ray, decided
 * by the ray's own random stream, so the per-ray and the packet walks see the
 * same decisions at the same segments. */
typedef struct consumer {
    uint64_t rng;
    double t_max;
    int n, cap, stopped;
    ray_segment_t seg[256];
} consumer_t;

/* After a segment: 1 to go on, 0 when the ray stops. */
static int consume(consumer_t *c, const ray_segment_t *s)
{
    if (c->n >= c->cap)
        fail_msg("a ray got more than %d segments", c->cap);
    c->seg[c->n++] = *s;
    uint64_t u = tu_next(&c->rng) % 8;
    if (u == 0) {
        c->stopped = 1;
        return 0;
    }
    if (u <= 2) {
        double v = s->t_in + (s->t_out - s->t_in) * (u == 1 ? 0.25 : 1.0);
        if (v < c->t_max)
            c->t_max = v;
    }
    return 1;
}

typedef struct packet_check {
    consumer_t *c;
    double *t_max;
} packet_check_t;

static void packet_seg(void *ctx, int r, const ray_segment_t *seg)
{
    packet_check_t *pc = ctx;
    if (seg->t_max != pc->t_max[r])
        fail_msg("ray %d: the segment carries t_max %a, the walk was given %a", r, seg->t_max,
                 pc->t_max[r]);
    pc->t_max[r] = consume(&pc->c[r], seg) ? pc->c[r].t_max : -INFINITY;
}

static void same_segments(const consumer_t *a, const consumer_t *b, const char *what, int r)
{
    if (a->n != b->n)
        fail_msg("%s, ray %d: %d segments walked alone, %d in the packet", what, r, a->n, b->n);
    for (int k = 0; k < a->n; k++) {
        const ray_segment_t *x = &a->seg[k], *y = &b->seg[k];
        if (memcmp(&x->t_in, &y->t_in, sizeof x->t_in) ||
            memcmp(&x->t_out, &y->t_out, sizeof x->t_out) || x->leaf != y->leaf ||
            x->tape != y->tape)
            fail_msg("%s, ray %d, segment %d: [%a, %a] leaf %lld alone, [%a, %a] leaf %lld in "
                     "the packet", what, r, k, x->t_in, x->t_out, (long long)x->leaf, y->t_in,
                     y->t_out, (long long)y->leaf);
    }
}

/* Random packets (up to RAY_PACKET rays around a random axis, from a random
 * origin inside or outside the box, a pixel's to a tile's spread) through
 * trees with and without slabs and leaf tapes, on every SIMD path: each ray
 * must get from ray_packet_walk the very segments (bits, leaf, tape, order)
 * the per-ray walk yields, with t_max lowered and rays stopped along the way.
 * Rays that ray_packet_ray turns away, or of another sign, are left out of
 * the packet.  Not vacuous: most rays get segments, many several. */
static void test_packet_walk(void **state)
{
    (void)state;
    struct {
        const char *name;
        int slabs, tapes;
    } cases[] = {{"gumdrop", 0, 0}, {"chubs", 1, 0}, {"whitney-umbrella", 0, 0},
                 {"csg-64-spheres", 0, 1}};
    uint64_t rng = tu_seed(0x9acc);
    const int n_packets = (int)(300 * tu_scale()) + 30;
    static const char *const paths[] = {"portable", "avx2", "avx512"};
    long rays = 0, segments = 0, multi = 0;
    for (size_t k = 0; k < sizeof cases / sizeof *cases; k++) {
        scene_t s;
        tu_load_scene(cases[k].name, &s);
        if (cases[k].slabs)
            s.octree.tests |= OCT_TEST_ILIE;
        oct_tree_t *tree = tu_scene_octree(&s);
        oct_leaf_tapes_t *lt = NULL;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (cases[k].tapes)
            assert_int_equal(oct_leaf_tapes_build(tree, s.tape, 0x1p-30, 1.0, &lt, &err), 0);
        if (cases[k].slabs)
            assert_true(tree->slabs != NULL);
        ray_octree_source_t os;
        ray_source_t src = ray_octree_source(&os, tree);
        os.tapes = lt;
        void *st = malloc(src.state_size);
        ray_packet_ws_t *pw = ray_packet_ws_new(tree);
        assert_non_null(st);
        assert_non_null(pw);
        double c[3], h[3];
        centre_half(s.box, c, h);
        for (int b = 0; b < n_packets; b++) {
            double o[3], axis[3], d[RAY_PACKET][3];
            for (int a = 0; a < 3; a++) {
                double u = 2 * tu_uniform(&rng) - 1;
                o[a] = c[a] + h[a] * (b % 3 == 2 ? u : 3 * u);
                axis[a] = c[a] + h[a] * (2 * tu_uniform(&rng) - 1) - o[a];
            }
            unit(axis);
            double spread = pow(2, -3 - 12 * tu_uniform(&rng));
            int n = 0;
            unsigned mask0 = 0;
            for (int j = 0; j < RAY_PACKET; j++) {
                double dd[3];
                for (int a = 0; a < 3; a++)
                    dd[a] = axis[a] + spread * (2 * tu_uniform(&rng) - 1);
                unit(dd);
                unsigned m;
                if (!ray_packet_ray(o, dd, &m) || (n > 0 && m != mask0))
                    continue;
                mask0 = m;
                memcpy(d[n++], dd, sizeof dd);
            }
            if (n == 0)
                continue;
            uint64_t seed = tu_next(&rng);
            /* alone */
            consumer_t alone[RAY_PACKET];
            for (int r = 0; r < n; r++) {
                consumer_t *cr = &alone[r];
                *cr = (consumer_t){.rng = seed + (uint64_t)r, .t_max = INFINITY, .cap = 256};
                uint64_t leaves = 0;
                ray_segment_t seg;
                src.begin(src.ctx, st, o, d[r]);
                for (;;) {
                    seg.t_max = cr->t_max;
                    if (!src.next(src.ctx, st, &seg, &leaves) || !consume(cr, &seg))
                        break;
                }
                assert_int_equal(leaves, (uint64_t)cr->n);
                rays++;
                segments += cr->n;
                multi += cr->n > 1;
            }
            /* together, on every path */
            for (size_t q = 0; q < sizeof paths / sizeof *paths; q++) {
                const char *p = paths[q];
                if (!tape_simd_available(p))
                    continue;
                assert_int_equal(tape_simd_select(p, NULL), 0);
                consumer_t pk[RAY_PACKET];
                double t_max[RAY_PACKET];
                for (int r = 0; r < n; r++) {
                    pk[r] = (consumer_t){.rng = seed + (uint64_t)r, .t_max = INFINITY, .cap = 256};
                    t_max[r] = INFINITY;
                }
                packet_check_t pc = {pk, t_max};
                uint64_t leaves = 0;
                ray_packet_walk(&os, pw, o, n, (const double(*)[3])d, t_max, packet_seg, &pc,
                                &leaves);
                uint64_t total = 0;
                char what[128];
                snprintf(what, sizeof what, "%s, packet %d, path %s", cases[k].name, b, p);
                for (int r = 0; r < n; r++) {
                    same_segments(&alone[r], &pk[r], what, r);
                    total += (uint64_t)pk[r].n;
                }
                assert_int_equal(leaves, total);
            }
            tape_simd_select(NULL, NULL);
        }
        ray_packet_ws_free(pw);
        free(st);
        oct_leaf_tapes_free(lt);
        oct_free(tree);
        scene_free(&s);
    }
    printf("packets: %ld rays, %ld segments, %ld rays with more than one\n", rays, segments,
           multi);
    assert_true(rays > 100 && segments > rays && multi > 20);
}

/* ---- images -------------------------------------------------------------------------- */

#define NMETHODS RAY_METHOD_COUNT

typedef struct setup {
    const tape_t *tape;
    const ray_camera_t *cam;
    const double *box;
    const oct_tree_t *tree;
    const oct_leaf_tapes_t *tapes;
    const double *light; /* NULL: none */
    int part, parts;
} setup_t;

static void render(const setup_t *su, ray_method_t m, int threads, int no_beams,
                   ray_image_t *img, ray_stats_t *st)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(ray_image_alloc(img, su->cam->width, su->cam->height, &err), 0);
    /* the parts leave the rest of the buffers as they were: the same bytes */
    size_t n = (size_t)su->cam->width * su->cam->height;
    memset(img->t, 0, n * sizeof *img->t);
    memset(img->point, 0, 3 * n * sizeof *img->point);
    memset(img->normal, 0, 3 * n * sizeof *img->normal);
    memset(img->dir, 0, 3 * n * sizeof *img->dir);
    memset(img->hit, 0, n), memset(img->kind, 0, n), memset(img->rgb, 0, 3 * n);
    ray_box_source_t bs;
    ray_octree_source_t os;
    ray_source_t src = su->tree ? ray_octree_source(&os, su->tree) : ray_box_source(&bs, su->box);
    if (su->tree)
        os.tapes = su->tapes;
    ray_render_opts_t o;
    ray_render_opts_default(&o);
    o.method = m;
    o.threads = threads;
    o.no_beams = no_beams;
    o.part = su->part;
    o.parts = su->parts;
    double dx = su->box[1] - su->box[0], dy = su->box[3] - su->box[2], dz = su->box[5] - su->box[4];
    o.roots.sample_step = sqrt(dx * dx + dy * dy + dz * dz) / 1000;
    if (su->light) {
        o.light_on = 1;
        memcpy(o.light, su->light, sizeof o.light);
    }
    if (ray_render(su->tape, su->cam, &src, &o, img, st, &err))
        fail_msg("render: %s", err.msg);
}

/* Every buffer byte for byte, and every counter but the beams' own. */
static void assert_same(const ray_image_t *a, const ray_stats_t *sa, const ray_image_t *b,
                        const ray_stats_t *sb, const char *what)
{
    size_t n = (size_t)a->width * a->height;
    struct {
        const char *name;
        const void *x, *y;
        size_t bytes;
    } bufs[] = {
        {"t", a->t, b->t, n * sizeof(double)},
        {"point", a->point, b->point, 3 * n * sizeof(double)},
        {"normal", a->normal, b->normal, 3 * n * sizeof(double)},
        {"dir", a->dir, b->dir, 3 * n * sizeof(double)},
        {"hit", a->hit, b->hit, n},
        {"kind", a->kind, b->kind, n},
        {"shadow", a->shadow, b->shadow, n},
        {"rgb", a->rgb, b->rgb, 3 * n},
    };
    for (size_t k = 0; k < sizeof bufs / sizeof *bufs; k++)
        if (memcmp(bufs[k].x, bufs[k].y, bufs[k].bytes))
            fail_msg("%s: buffer %s differs", what, bufs[k].name);
    assert_int_equal(a->lit, b->lit);
    assert_true(sa->rays == sb->rays && sa->hits == sb->hits &&
                sa->tangent_hits == sb->tangent_hits && sa->tape_evals == sb->tape_evals &&
                sa->segments == sb->segments && sa->leaves == sb->leaves &&
                sa->shadow_rays == sb->shadow_rays && sa->shadowed == sb->shadowed &&
                sa->shadow_undecided == sb->shadow_undecided &&
                sa->shadow_evals == sb->shadow_evals);
}

/* Beams against none for every method (threads_b threads with beams, 1
 * without); returns the rays decided by beams over all methods, and checks
 * the beams' counters: none without beams, decided rays are misses. */
static uint64_t compare_methods(const setup_t *su, int threads_b, const char *name)
{
    uint64_t decided = 0;
    for (int m = 0; m < NMETHODS; m++) {
        ray_image_t a, b;
        ray_stats_t sa, sb;
        render(su, (ray_method_t)m, threads_b, 0, &a, &sa);
        render(su, (ray_method_t)m, 1, 1, &b, &sb);
        char what[160];
        snprintf(what, sizeof what, "%s, %s, %d thread(s)%s%s", name,
                 ray_method_name((ray_method_t)m), threads_b, su->tapes ? ", leaf tapes" : "",
                 su->light ? ", light" : "");
        assert_same(&a, &sa, &b, &sb, what);
        assert_true(sb.beams == 0 && sb.rays_decided_by_beam == 0);
        assert_true(sa.rays_decided_by_beam <= sa.rays - sa.hits);
        if (su->tree)
            assert_true(sa.beams > 0);
        else
            assert_true(sa.beams == 0); /* the box source has no beams */
        decided += sa.rays_decided_by_beam;
        if (m == 0)
            printf("%-48s rays %6llu  hits %6llu  beams %5llu  decided by a beam %6llu\n", what,
                   (unsigned long long)sa.rays, (unsigned long long)sa.hits,
                   (unsigned long long)sa.beams, (unsigned long long)sa.rays_decided_by_beam);
        ray_image_free(&a);
        ray_image_free(&b);
    }
    return decided;
}

static void camera_of(const scene_t *s, int w, int h, ray_camera_t *cam)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(ray_camera_init(cam, s->camera.eye, s->camera.target, s->camera.up,
                                     s->camera.fov, w, h, &err),
                     0);
}

/* An image side for the tests that count the rays a beam decides: scaled down
 * in the sanitizer build, but never below 32 pixels.  Beams stop at 8x8
 * (render.c); in an image of 16 whose view the surface fills, every such
 * beam reaches a leaf and none decides anything, which would leave the
 * decided rays' path untested. */
static int beam_image_size(int full)
{
    int n = tu_image_size(full);
    return n < 32 ? 32 : n;
}

/* The eight comparison surfaces at their scene's camera, every method; the
 * image 48x40 (three partial tiles a row and column); and the box source,
 * which has no beams. */
static void test_comparison_surfaces(void **state)
{
    (void)state;
    const int w = beam_image_size(48), h = beam_image_size(40);
    uint64_t decided = 0;
    for (size_t k = 0; k < TU_N_COMPARISON; k++) {
        scene_t s;
        tu_load_scene(tu_comparison_surfaces[k], &s);
        oct_tree_t *tree = tu_scene_octree(&s);
        ray_camera_t cam;
        camera_of(&s, w, h, &cam);
        setup_t su = {.tape = s.tape, .cam = &cam, .box = s.box, .tree = tree};
        decided += compare_methods(&su, 1, tu_comparison_surfaces[k]);
        if (k == 0) {
            setup_t box = su;
            box.tree = NULL;
            compare_methods(&box, 1, "sphere, box source");
        }
        oct_free(tree);
        scene_free(&s);
    }
    assert_true(decided > 0);
}

/* The 64-sphere union: the scene's tape, then leaf tapes with a light (their
 * margin covering the shadow rays), 1 and 2 threads; and the image in 3
 * parts, each part against the same part without beams. */
static void test_csg(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("csg-64-spheres", &s);
    oct_tree_t *tree = tu_scene_octree(&s);
    const int size = beam_image_size(40);
    ray_camera_t cam;
    camera_of(&s, size, size, &cam);
    double light[3];
    tu_side_light(&cam, light);
    setup_t su = {.tape = s.tape, .cam = &cam, .box = s.box, .tree = tree};
    assert_true(compare_methods(&su, 2, "csg-64-spheres") > 0);
    double margin = fmax(ray_tape_margin(&cam, s.box), ray_light_tape_margin(light, s.box));
    oct_leaf_tapes_t *lt = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(oct_leaf_tapes_build(tree, s.tape, margin, 1.0, &lt, &err), 0);
    su.tapes = lt;
    su.light = light;
    compare_methods(&su, 1, "csg-64-spheres");
    compare_methods(&su, 2, "csg-64-spheres");
    su.parts = 3;
    for (su.part = 0; su.part < su.parts; su.part++) {
        ray_image_t a, b;
        ray_stats_t sa, sb;
        render(&su, RAY_NEWTON_AH, 2, 0, &a, &sa);
        render(&su, RAY_NEWTON_AH, 1, 1, &b, &sb);
        assert_same(&a, &sa, &b, &sb, "csg-64-spheres, a part");
        ray_image_free(&a);
        ray_image_free(&b);
    }
    oct_leaf_tapes_free(lt);
    oct_free(tree);
    scene_free(&s);
}

/* The stress scenes of test_stab_rays.c that go through ray_render: the thin
 * shell (abs: leaf tapes too), the Whitney umbrella (a singular line, its
 * whisker on the z axis), the tiny sphere (a box of 4e-6), with the scene's
 * camera and with a camera close to the surface, so that a beam is narrower
 * than a leaf and many rays graze the silhouette; every method, with a
 * light (but the tiny sphere). */
static void test_stress_scenes(void **state)
{
    (void)state;
    const char *names[] = {"thin-shell", "whitney-umbrella", "tiny-sphere", "sphere"};
    const int size = tu_image_size(40);
    for (size_t k = 0; k < sizeof names / sizeof *names; k++) {
        scene_t s;
        tu_load_scene(names[k], &s);
        oct_tree_t *tree = tu_scene_octree(&s);
        for (int close = 0; close < 2; close++) {
            ray_camera_t cam;
            camera_of(&s, size, size, &cam);
            if (close) {
                /* a tenth of the way from the target to the eye, a narrow
                 * view towards the box's corner region */
                double eye[3], target[3];
                for (int a = 0; a < 3; a++) {
                    target[a] = s.camera.target[a];
                    eye[a] = target[a] + 0.3 * (s.camera.eye[a] - target[a]);
                }
                ivoct_error_t err;
                ivoct_error_clear(&err);
                assert_int_equal(ray_camera_init(&cam, eye, target, s.camera.up, 12, size, size,
                                                 &err),
                                 0);
            }
            double light[3];
            tu_side_light(&cam, light);
            oct_leaf_tapes_t *lt = NULL;
            if (tape_has_choices(s.tape)) {
                double margin =
                    fmax(ray_tape_margin(&cam, s.box), ray_light_tape_margin(light, s.box));
                ivoct_error_t err;
                ivoct_error_clear(&err);
                assert_int_equal(oct_leaf_tapes_build(tree, s.tape, margin, 1.0, &lt, &err), 0);
            }
            /* no light for the tiny sphere: sampling's shadow rays there step
             * at a thousandth of the box's diagonal over the whole way to
             * the light (a minute, with beams or without: beams do not touch
             * shadow rays) */
            setup_t su = {.tape = s.tape, .cam = &cam, .box = s.box, .tree = tree,
                          .tapes = lt, .light = strcmp(names[k], "tiny-sphere") ? light : NULL};
            char name[64];
            snprintf(name, sizeof name, "%s%s", names[k], close ? " (close)" : "");
            compare_methods(&su, 2, name);
            oct_leaf_tapes_free(lt);
        }
        oct_free(tree);
        scene_free(&s);
    }
}

/* A depth-16 tree around a sphere of radius 2.5e-4 (test_stab_rays.c's deep
 * case): the beams walk 16 levels, the camera close enough for the sphere to
 * fill part of the image. */
static void test_deep(void **state)
{
    (void)state;
    tape_t *t = tu_compile_uvw("u^2 + v^2 + w^2 - 6.25e-8", "x - 0.3", "y - 0.2", "z - 0.1");
    const double box[6] = {-1, 1, -1, 1, -1, 1};
    oct_params_t p;
    oct_params_default(&p);
    p.depth = tu_scale() < 1 ? 12 : 16;
    p.threads = 2;
    oct_tree_t *tree = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(oct_build(t, box, &p, &tree, &err), 0);
    const double eye[3] = {0.3 + 2e-3, 0.2 + 1.5e-3, 0.1 + 1e-3}, target[3] = {0.3, 0.2, 0.1},
                 up[3] = {0, 0, 1};
    ray_camera_t cam;
    const int size = tu_image_size(32);
    assert_int_equal(ray_camera_init(&cam, eye, target, up, 20, size, size, &err), 0);
    setup_t su = {.tape = t, .cam = &cam, .box = box, .tree = tree};
    compare_methods(&su, 2, "deep sphere, depth 16");
    oct_free(tree);
    tape_free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_beam_walk),     cmocka_unit_test(test_packet_walk),
        cmocka_unit_test(test_comparison_surfaces),
        cmocka_unit_test(test_csg),           cmocka_unit_test(test_stress_scenes),
        cmocka_unit_test(test_deep),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
