/* Rendered images against the MPFR first-root reference (ray_reference.h),
 * pixel by pixel: shared by tests/test_ray_roots.c and tests/test_ray_methods.c.
 *
 * The reference of a pixel: its ray (cam->eye and ray_camera_dir, the doubles
 * the renderer uses) clipped to the box with ray_clip_box (as the box source
 * does), and the first root r of g(t) = f(o + t d) on [t0, t1] (rref_ray).  The
 * tape must be rref_supported (a polynomial whose constants are doubles), so
 * that g is f along the ray exactly and the reference is certain.
 *
 * The tolerance of a hit at r:
 *     tol = 1e-12 |r| + 4 w(F(p(r))) / |g'(r)|
 * 1e-12 |r| is the refinement of a certified root (a few ulps) with margin;
 * the second term is the zero band: the renderer cannot place a hit closer to
 * r than where the double enclosure of f at the rounded point p(r) =
 * ray_point(o, d, r) holds 0 (w(F) its width) allows, which is that width over
 * the slope; the factor 4 covers the band's two sides and the variation of
 * F's width across it.  It is far below 1e-12 |r| except on grazing rays.
 *
 * The judgement of one pixel of an image rendered by a certified method:
 *  - a ray that misses the box does not hit;
 *  - on a ray the reference does not call ambiguous: the same hit/miss as the
 *    reference, and on a hit |t - r| <= tol (the strict comparison);
 *  - on an ambiguous ray (ray_reference.h: the ray passes within ~1e-9 of
 *    touching the surface, or the surface is within ~1e-9 of the box face
 *    where the ray enters or leaves; a double-precision renderer may rightly
 *    answer either way there) hit/miss and t are exempt and counted, except
 *    what a certified method guarantees on every ray: where g has a root away
 *    from the box faces (not near_box) the method hits (its miss is a
 *    certified exclusion over boxes that hold the exact ray), and never after
 *    r + tol.  Near the box faces the first root may lie in the outward
 *    rounding of [t0, t1], outside the box an octree covers: not judged. */
#ifndef IVOCT_TEST_RAY_CHECK_H
#define IVOCT_TEST_RAY_CHECK_H

#include <stddef.h>

#include "../../expr/tape.h"
#include "../../ray/ray.h"
#include "ray_reference.h"

typedef struct rck_ref {
    int width, height;
    size_t npix;
    unsigned char *inbox; /* the pixel's ray meets the box */
    rref_result_t *q;     /* the reference of each pixel (a miss outside the box) */
    double *tol;          /* on a reference hit, tol above; else 0 */
    size_t n_in, n_hit, n_amb; /* rays in the box, reference hits, ambiguous rays */
    double time_s;
} rck_ref_t;

/* The reference of every pixel of cam for tape t in box (2 threads).  Fails
 * the current test when the tape is not rref_supported. */
void rck_reference(const tape_t *t, const double box[6], const ray_camera_t *cam, rck_ref_t *R);
void rck_reference_free(rck_ref_t *R);

typedef struct rck_tally {
    size_t checked;       /* pixels in the box held to the strict comparison */
    size_t exempt;        /* ambiguous pixels (in the box) */
    size_t exempt_differ; /* of those, where hit/miss differs or |t - r| > tol */
    size_t band_used;     /* strict hits with 1e-12 |r| < |t - r| <= tol */
    double max_rel;       /* max |t - r| / |r| over the strict hits within 1e-12 |r| */
    size_t failures;
} rck_tally_t;

/* Judge img (rendered with a certified method over R's camera) against R;
 * adds to *ty and returns the number of failing pixels of this image, the
 * first few printed with `what` naming the image. */
size_t rck_judge(const rck_ref_t *R, const ray_image_t *img, const char *what, rck_tally_t *ty);

#endif
