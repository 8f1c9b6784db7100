/* Every certified ray method against an independent high-precision oracle, on
 * the polynomial comparison surfaces (the eight of surfaces.md are all
 * polynomials: degree 2 to 8), pixel by pixel at 64x64 with each scene's camera.
 *
 * The oracle (tests/support/ray_reference.c, shared with bench/ray_error.c):
 * along the ray of a pixel (eye o and unit direction d exactly as the renderer
 * has them, doubles), g(t) = f(o + t d) is a polynomial in t.  Its
 * coefficients are computed in MPFR at 192 bits by running the tape with
 * polynomial arithmetic in t (only + - * ^n and constants that are doubles,
 * else the scene is skipped).  Real roots in the box segment [t0, t1] (from
 * ray_clip_box) are isolated through the critical points: the roots of p'
 * (found the same way, recursively) cut [t0, t1] into pieces where p is
 * monotone, and a piece holds a root exactly when p changes sign over it;
 * that root is refined by safeguarded Newton to ~2^-90.
 *
 * What must hold, for each certified method:
 *  - hit/miss agrees with "p has a real root in [t0, t1]";
 *  - on a hit, t agrees with the smallest root r to 1e-12 relative, beyond the
 *    precision limit of double evaluation there: the renderer cannot locate r
 *    closer than the zero band where the double enclosure of f at the point
 *    holds 0, whose half-width is about w(F(p(r))) / |p'(r)|; that term is
 *    added (it is far below 1e-12 r except on grazing rays).
 * except on rays the test calls ambiguous, decided from the polynomial:
 *  - near a double root: a critical point c before the second root (or t1)
 *    with |p(c)| <= 1e-9 L, L = max |p'| on [t0, t1] (the ray comes within
 *    about 1e-9 of touching the surface: a silhouette, a whisker, a singular
 *    point), or
 *  - near the box: |p(t0)| or |p(t1)| <= 1e-9 L (the surface within about 1e-9
 *    of where the ray enters or leaves the box).
 * The ambiguous pixels are counted and printed; they must be few (< 1%). */
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
#include "support/ray_reference.h"
#include "support/testutil.h"

static const char *const SURFACES[] = {
    "sphere", "drop", "chubs", "crosscap", "gumdrop", "horned-cube", "mcmullen-k3",
    "kusner-schmitt",
};
#define NSURF (sizeof SURFACES / sizeof SURFACES[0])

/* ---- the test ------------------------------------------------------------------------------ */

static int image_size(void)
{
    int n = (int)(64 * sqrt(tu_scale()) + 0.5);
    return n < 16 ? 16 : n;
}

static void test_roots_against_oracle(void **state)
{
    (void)state;
    const int size = image_size();
    const size_t npix = (size_t)size * size;
    printf("%-15s %7s %6s %9s %10s %12s\n", "surface", "in box", "hits", "ambiguous",
           "band-used", "max rel err");
    for (size_t si = 0; si < NSURF; si++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/scenes/%s.ini", tu_source_dir(), SURFACES[si]);
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_load(path, &s, &err))
            fail_msg("%s: %s", path, err.msg);
        rref_t *ref = rref_supported(s.tape) ? rref_new(s.tape) : NULL;
        if (!ref) {
            printf("%-15s skipped: not a polynomial with double constants\n", SURFACES[si]);
            scene_free(&s);
            continue;
        }
        ray_camera_t cam;
        assert_int_equal(
            ray_camera_init(&cam, s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, size, size, &err), 0);
        tape_ws_t *ws = tape_ws_new(s.tape->n);

        /* the oracle for every pixel */
        rref_result_t *orc = calloc(npix, sizeof *orc);
        unsigned char *inbox = calloc(npix, 1);
        double *band = calloc(npix, sizeof *band);
        size_t n_in = 0, n_hit = 0, n_amb = 0;
        for (size_t i = 0; i < npix; i++) {
            double d[3], t0, t1;
            ray_camera_dir(&cam, (int)(i % size), (int)(i / size), d);
            if (!ray_clip_box(s.box, cam.eye, d, &t0, &t1))
                continue;
            inbox[i] = 1;
            n_in++;
            rref_ray(ref, cam.eye, d, t0, t1, &orc[i]);
            n_hit += orc[i].hit;
            n_amb += orc[i].ambiguous;
            if (orc[i].hit) {
                /* the zero band: the enclosure of f at the point of r */
                double p[3];
                iv_t v;
                ray_point(cam.eye, d, orc[i].r, p);
                iv_box_t pb = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
                tape_eval_interval(s.tape, ws, 1, &pb, &v);
                band[i] = 4 * (v.hi - v.lo) / orc[i].dp_r;
            }
        }
        if (n_amb * 100 >= npix)
            fail_msg("%s: %zu ambiguous pixels of %zu", SURFACES[si], n_amb, npix);

        /* each certified method */
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            if (!ray_method_certified((ray_method_t)m))
                continue;
            ray_image_t img;
            ray_stats_t st;
            ray_box_source_t bs;
            ray_source_t src = ray_box_source(&bs, s.box);
            ray_render_opts_t o;
            ray_render_opts_default(&o);
            o.method = (ray_method_t)m;
            assert_int_equal(ray_image_alloc(&img, size, size, &err), 0);
            if (ray_render(s.tape, &cam, &src, &o, &img, &st, &err))
                fail_msg("render: %s", err.msg);
            double max_rel = 0;
            size_t band_used = 0;
            for (size_t i = 0; i < npix; i++) {
                if (!inbox[i]) {
                    if (img.hit[i])
                        fail_msg("%s %s pixel %zu: a hit on a ray that misses the box",
                                 SURFACES[si], ray_method_name((ray_method_t)m), i);
                    continue;
                }
                const rref_result_t *q = &orc[i];
                if (q->ambiguous)
                    continue;
                if (img.hit[i] != q->hit)
                    fail_msg("%s %s pixel %zu (col %zu row %zu): renderer %s, oracle %s "
                             "(r = %.17g, t = %.17g)",
                             SURFACES[si], ray_method_name((ray_method_t)m), i, i % size,
                             i / size, img.hit[i] ? "hit" : "miss", q->hit ? "hit" : "miss",
                             q->r, img.t[i]);
                if (!q->hit)
                    continue;
                double e = fabs(img.t[i] - q->r);
                double rel = e / fabs(q->r);
                if (e > 1e-12 * fabs(q->r)) {
                    band_used++;
                    if (!(e <= 1e-12 * fabs(q->r) + band[i]))
                        fail_msg("%s %s pixel %zu: t = %.17g, oracle r = %.17g: error %.3g "
                                 "(relative %.3g, zero band %.3g)",
                                 SURFACES[si], ray_method_name((ray_method_t)m), i, img.t[i],
                                 q->r, e, rel, band[i]);
                } else if (rel > max_rel) {
                    max_rel = rel;
                }
            }
            printf("%-15s %7zu %6zu %9zu %10zu %12.3g  %s\n", SURFACES[si], n_in, n_hit, n_amb,
                   band_used, max_rel, ray_method_name((ray_method_t)m));
            ray_image_free(&img);
        }
        free(orc);
        free(inbox);
        free(band);
        tape_ws_free(ws);
        rref_free(ref);
        scene_free(&s);
    }
    rref_thread_cleanup();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roots_against_oracle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
