/* Rendered images against the MPFR first-root reference: see ray_check.h. */
#include "ray_check.h"

#include <math.h>
#include <omp.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include "testutil.h"

void rck_reference(const tape_t *t, const double box[6], const ray_camera_t *cam, rck_ref_t *R)
{
    if (!rref_supported(t))
        fail_msg("the reference needs a polynomial whose constants are doubles");
    double t_start = tu_now();
    const int w = cam->width, h = cam->height;
    R->width = w;
    R->height = h;
    R->npix = (size_t)w * (size_t)h;
    R->inbox = calloc(R->npix, 1);
    R->q = calloc(R->npix, sizeof *R->q);
    R->tol = calloc(R->npix, sizeof *R->tol);
    assert_true(R->inbox && R->q && R->tol);
    int failed = 0;
#pragma omp parallel num_threads(2)
    {
        rref_t *ref = rref_new(t);
        tape_ws_t *ws = tape_ws_new(t->n);
        if (!ref || !ws) {
#pragma omp atomic write
            failed = 1;
        }
#pragma omp for schedule(dynamic, 1)
        for (int row = 0; row < h; row++)
            for (int col = 0; col < w && ref && ws; col++) {
                size_t i = (size_t)row * (size_t)w + (size_t)col;
                double d[3];
                ray_camera_dir(cam, col, row, d);
                rref_result_t *q = &R->q[i];
                R->inbox[i] = (unsigned char)rref_ray_box(ref, box, cam->eye, d, q);
                if (!q->hit)
                    continue;
                /* the zero band: the enclosure of f at the rounded point of r */
                double p[3];
                iv_t v;
                ray_point(cam->eye, d, q->r, p);
                iv_box_t pb = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
                tape_eval_interval(t, ws, 1, &pb, &v);
                R->tol[i] = 1e-12 * fabs(q->r) + 4 * (v.hi - v.lo) / q->dp_r;
            }
        tape_ws_free(ws);
        rref_free(ref);
        rref_thread_cleanup();
    }
    assert_false(failed);
    R->n_in = R->n_hit = R->n_amb = 0;
    for (size_t i = 0; i < R->npix; i++) {
        R->n_in += R->inbox[i];
        R->n_hit += (size_t)R->q[i].hit;
        R->n_amb += R->inbox[i] && R->q[i].ambiguous;
    }
    R->time_s = tu_now() - t_start;
}

void rck_reference_free(rck_ref_t *R)
{
    free(R->inbox);
    free(R->q);
    free(R->tol);
}

size_t rck_judge(const rck_ref_t *R, const ray_image_t *img, const char *what, rck_tally_t *ty)
{
    assert_int_equal(img->width, R->width);
    assert_int_equal(img->height, R->height);
    size_t failures = 0;
    for (size_t i = 0; i < R->npix; i++) {
        const rref_result_t *q = &R->q[i];
        int hit = img->hit[i];
        double t = img->t[i];
        char msg[320] = "";
        if (!R->inbox[i]) {
            if (hit)
                snprintf(msg, sizeof msg, "a hit (t = %.17g) on a ray that misses the box", t);
        } else if (q->ambiguous) {
            ty->exempt++;
            if (hit != q->hit || (hit && !(fabs(t - q->r) <= R->tol[i])))
                ty->exempt_differ++;
            if (q->hit && !q->near_box && !hit)
                snprintf(msg, sizeof msg,
                         "ambiguous ray (near a double root) missed the root r = %.17g", q->r);
            else if (q->hit && !q->near_box && t > q->r + R->tol[i])
                snprintf(msg, sizeof msg,
                         "ambiguous ray hit at t = %.17g, after the first root r = %.17g "
                         "(tol %.3g)",
                         t, q->r, R->tol[i]);
        } else {
            ty->checked++;
            if (hit != q->hit) {
                snprintf(msg, sizeof msg, "renderer %s (t = %.17g), reference %s (r = %.17g)",
                         hit ? "hit" : "miss", t, q->hit ? "hit" : "miss", q->r);
            } else if (hit) {
                double e = fabs(t - q->r);
                if (e > 1e-12 * fabs(q->r)) {
                    ty->band_used++;
                    if (!(e <= R->tol[i]))
                        snprintf(msg, sizeof msg,
                                 "t = %.17g, reference r = %.17g: error %.3g (relative %.3g) > "
                                 "tol %.3g",
                                 t, q->r, e, e / fabs(q->r), R->tol[i]);
                } else if (e / fabs(q->r) > ty->max_rel) {
                    ty->max_rel = e / fabs(q->r);
                }
            }
        }
        if (msg[0]) {
            if (ty->failures + failures < 10)
                printf("%s pixel %zu (col %zu row %zu): %s\n", what, i, i % (size_t)R->width,
                       i / (size_t)R->width, msg);
            failures++;
        }
    }
    ty->failures += failures;
    return failures;
}
