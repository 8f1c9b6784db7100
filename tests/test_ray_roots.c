/* Every certified ray method against an independent high-precision oracle, on
 * the eight comparison surfaces of docs/surfaces.md (all polynomials: degree 2 to
 * 8; each of them must be checked, none skipped), pixel by pixel at 64x64
 * with each scene's camera and the box source (--no-octree).
 *
 * The oracle (tests/support/ray_reference.c, shared with bench/ray_error.c):
 * along the ray of a pixel (eye o and unit direction d exactly as the renderer
 * has them, doubles), g(t) = f(o + t d) is a polynomial in t.  Its
 * coefficients are computed in MPFR at 192 bits by running the tape with
 * polynomial arithmetic in t (only + - * ^n and constants that are doubles).
 * Real roots in the box segment [t0, t1] (from ray_clip_box) are isolated
 * through the critical points: the roots of p' (found the same way,
 * recursively) cut [t0, t1] into pieces where p is monotone, and a piece holds
 * a root exactly when p changes sign over it; that root is refined by
 * safeguarded Newton to ~2^-90.
 *
 * What must hold, for each certified method (tests/support/ray_check.h):
 *  - hit/miss agrees with "p has a real root in [t0, t1]";
 *  - on a hit, t agrees with the smallest root r to 1e-12 relative, beyond the
 *    precision limit of double evaluation there: the renderer cannot locate r
 *    closer than the zero band where the double enclosure of f at the point
 *    holds 0, whose half-width is about w(F(p(r))) / |p'(r)|; that term is
 *    added (it is far below 1e-12 r except on grazing rays);
 *  - no hit on a ray that misses the box;
 * except on rays the oracle calls ambiguous, decided from the polynomial:
 *  - near a double root: a critical point c before the second root (or t1)
 *    with |p(c)| <= 1e-9 L, L = max |p'| on [t0, t1] (the ray comes within
 *    about 1e-9 of touching the surface: a silhouette, a whisker, a singular
 *    point), or
 *  - near the box: |p(t0)| or |p(t1)| <= 1e-9 L (the surface within about 1e-9
 *    of where the ray enters or leaves the box);
 * where hit/miss and t are free, save that a root away from the box is never
 * missed nor passed.  The ambiguous pixels are counted and printed; they must
 * be few (< 1%). */
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
#include "support/ray_check.h"
#include "support/ray_reference.h"
#include "support/testutil.h"

static void test_roots_against_oracle(void **state)
{
    (void)state;
    const int size = tu_image_size(64);
    const size_t npix = (size_t)size * size;
    printf("%-15s %7s %6s %9s %10s %12s\n", "surface", "in box", "hits", "ambiguous",
           "band-used", "max rel err");
    size_t checked_surfaces = 0, failures = 0;
    for (size_t si = 0; si < TU_N_COMPARISON; si++) {
        const char *name = tu_comparison_surfaces[si];
        scene_t s;
        tu_load_scene(name, &s);
        /* every comparison surface is a polynomial with double constants: none
         * may be skipped */
        if (!rref_supported(s.tape))
            fail_msg("%s: not a polynomial with double constants: the oracle cannot check it",
                     name);
        ivoct_error_t err;
        ivoct_error_clear(&err);
        ray_camera_t cam;
        assert_int_equal(
            ray_camera_init(&cam, s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, size, size, &err), 0);
        rck_ref_t R;
        rck_reference(s.tape, s.box, &cam, &R);
        if (R.n_amb * 100 >= npix)
            fail_msg("%s: %zu ambiguous pixels of %zu", name, R.n_amb, npix);
        /* not vacuous: the surface is in view */
        assert_true(R.n_hit > 0);

        /* each certified method */
        int methods = 0;
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            if (!ray_method_certified((ray_method_t)m))
                continue;
            methods++;
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
            char what[64];
            snprintf(what, sizeof what, "%s %s", name, ray_method_name((ray_method_t)m));
            rck_tally_t ty = {0};
            failures += rck_judge(&R, &img, what, &ty);
            printf("%-15s %7zu %6zu %9zu %10zu %12.3g  %s\n", name, R.n_in, R.n_hit, R.n_amb,
                   ty.band_used, ty.max_rel, ray_method_name((ray_method_t)m));
            ray_image_free(&img);
        }
        assert_int_equal(methods, RAY_METHOD_COUNT - 1); /* all but sampling */
        checked_surfaces++;
        rck_reference_free(&R);
        scene_free(&s);
    }
    if (failures)
        fail_msg("%zu pixels disagree with the oracle (the first ones above)", failures);
    /* every comparison surface was checked */
    assert_int_equal(checked_surfaces, TU_N_COMPARISON);
    assert_int_equal(TU_N_COMPARISON, 8);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roots_against_oracle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
