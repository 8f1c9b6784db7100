/* The seven ray methods against each other on the eight comparison surfaces
 * (the scene files in scenes/, the scene's camera, a small image).
 *
 * Certified methods must agree pixel by pixel — the same hit/miss and the same
 * t — except on rays that pass within the double-root tolerance of a singular
 * point, a whisker or a silhouette, where one method may accept a tangent
 * segment the other excludes.  Those pixels are counted, printed and bounded
 * (< 1% of the pixels).  Sampling is not certified: it may miss thin parts
 * and double roots, so it is only held to the same bound, and to one rigorous
 * property: where it finds a sign change, every certified method hits no
 * later.  Image size: 64x64 (IVOCT_TEST_SCALE scales the pixel count). */
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

static const char *const SURFACES[] = {
    "sphere", "drop", "chubs", "crosscap", "gumdrop", "horned-cube", "mcmullen-k3",
    "kusner-schmitt",
};
#define NSURF (sizeof SURFACES / sizeof SURFACES[0])

static int image_size(void)
{
    int n = (int)(64 * sqrt(tu_scale()) + 0.5);
    return n < 16 ? 16 : n;
}

static void load(const char *name, scene_t *s)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/scenes/%s.ini", tu_source_dir(), name);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(path, s, &err)) {
        char buf[1024];
        fail_msg("%s", ivoct_error_format(&err, buf, sizeof buf));
    }
}

static void render(const scene_t *s, int size, ray_method_t m, ray_image_t *img,
                   ray_stats_t *st)
{
    ivoct_error_t err;
    ray_camera_t cam;
    assert_int_equal(ray_camera_init(&cam, s->camera.eye, s->camera.target, s->camera.up, s->camera.fov, size, size, &err),
                     0);
    assert_int_equal(ray_image_alloc(img, size, size, &err), 0);
    ray_box_source_t bs;
    ray_source_t src = ray_box_source(&bs, s->box);
    ray_render_opts_t o;
    ray_render_opts_default(&o);
    o.method = m;
    double dx = s->box[1] - s->box[0], dy = s->box[3] - s->box[2], dz = s->box[5] - s->box[4];
    o.roots.sample_step = sqrt(dx * dx + dy * dy + dz * dz) / 1000;
    if (ray_render(s->tape, &cam, &src, &o, img, st, &err))
        fail_msg("render: %s", err.msg);
}

/* Same answer: both miss, or both hit with t equal to 1e-10 relative (the
 * methods stop at the same band where the sign of f cannot be certified;
 * they differ by the band's width at most). */
static int agree(const ray_image_t *a, const ray_image_t *b, size_t i)
{
    if (a->hit[i] != b->hit[i])
        return 0;
    if (!a->hit[i])
        return 1;
    return fabs(a->t[i] - b->t[i]) <= 1e-10 * fmax(1.0, fabs(a->t[i]));
}

static void test_methods_agree(void **state)
{
    (void)state;
    const int size = image_size();
    const size_t npix = (size_t)size * size;
    const ray_method_t ref = RAY_NEWTON_AH;
    printf("%-15s %-13s %6s %6s %8s %10s %9s\n", "surface", "method", "hits", "tangent",
           "differ", "evals/ray", "time_s");
    for (size_t k = 0; k < NSURF; k++) {
        scene_t s;
        load(SURFACES[k], &s);
        ray_image_t img[RAY_METHOD_COUNT];
        ray_stats_t st[RAY_METHOD_COUNT];
        for (int m = 0; m < RAY_METHOD_COUNT; m++)
            render(&s, size, (ray_method_t)m, &img[m], &st[m]);
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            size_t differ = 0;
            for (size_t i = 0; i < npix; i++)
                differ += !agree(&img[ref], &img[m], i);
            printf("%-15s %-13s %6llu %6llu %8zu %10.1f %9.3f\n", SURFACES[k],
                   ray_method_name((ray_method_t)m), (unsigned long long)st[m].hits,
                   (unsigned long long)st[m].tangent_hits, differ,
                   (double)st[m].tape_evals / (double)npix, st[m].time_s);
            if (differ * 100 >= npix)
                fail_msg("%s: %s differs from %s on %zu of %zu pixels", SURFACES[k],
                         ray_method_name((ray_method_t)m), ray_method_name(ref), differ, npix);
            /* a sign change found by sampling is a root: no certified miss there */
            if (m == RAY_SAMPLING)
                for (int c = 0; c < RAY_METHOD_COUNT; c++) {
                    if (c == RAY_SAMPLING)
                        continue;
                    for (size_t i = 0; i < npix; i++)
                        if (img[m].hit[i] && (!img[c].hit[i] ||
                                              img[c].t[i] > img[m].t[i] * (1 + 1e-9)))
                            fail_msg("%s pixel %zu: sampling hits at t=%.17g, %s %s %.17g",
                                     SURFACES[k], i, img[m].t[i],
                                     ray_method_name((ray_method_t)c),
                                     img[c].hit[i] ? "only at" : "misses:", img[c].t[i]);
                }
        }
        /* shading never leaves NaN normals on a hit */
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            for (size_t i = 0; i < npix; i++)
                if (img[m].hit[i])
                    for (int j = 0; j < 3; j++)
                        assert_true(isfinite(img[m].normal[3 * i + j]) &&
                                    isfinite(img[m].point[3 * i + j]));
            ray_image_free(&img[m]);
        }
        scene_free(&s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_methods_agree),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
