/* The high-precision reference for ray casting: the first root of a polynomial
 * surface along a ray, computed in MPFR.  Shared by tests/test_ray_roots.c (the
 * oracle every certified method must agree with), tests/test_stab_rays.c (the
 * stress cases) and bench/ray_error.c (the hit error of ivoct's methods and of
 * the OpenVDB level-set ray caster).
 *
 * Along a ray (origin o and direction d exactly as given, doubles),
 * g(t) = f(o + t d) is a polynomial in t.  Its coefficients are computed at
 * RREF_PREC bits by running the tape with polynomial arithmetic in t (only
 * + - * ^n and constants; rref_supported says whether a tape qualifies).  A
 * constant that is an interval (a decimal like 0.1, rounded outward) is taken
 * at one end, chosen by rref_set_end: a caller that must be right for any value
 * inside asks at both ends.  The real roots in [t0, t1] are isolated through the critical
 * points: the roots of g' (found the same way, recursively) cut [t0, t1] into
 * pieces where g is monotone, a piece holds a root exactly when g changes sign
 * over it, and that root is refined by safeguarded Newton to ~2^-90 relative.
 *
 * Ambiguous rays, where a double-precision renderer may rightly answer either
 * way: L = max |g'| on [t0, t1] and ell the scene's length scale (1 unless set
 * by rref_set_length, so that a scene scaled by 1e-8 is not all ambiguous);
 * the ray is
 *  - near_double when |g(c)| <= 1e-9 L ell at a critical point c before the
 *    second root (or t1): the ray comes within about 1e-9 ell of touching the
 *    surface (a silhouette, a whisker, a singular point);
 *  - near_box when |g(t0)| or |g(t1)| <= 1e-9 L ell: the surface within about
 *    1e-9 ell of where the ray enters or leaves the box.
 * `graze` is the smallest of those |g(.)| / L: a distance-like measure of how
 * close the ray is to being ambiguous, for coarser thresholds (e.g. a voxel).
 *
 * Not a library module: test and benchmark support (it allocates freely, and
 * one rref_t must not be used by two threads at once; use one per thread). */
#ifndef IVOCT_RAY_REFERENCE_H
#define IVOCT_RAY_REFERENCE_H

#include "../../expr/tape.h"

#define RREF_PREC 192      /* MPFR bits */
#define RREF_MAX_DEGREE 16 /* largest degree of g handled */

typedef struct rref rref_t;

/* Which end of each interval constant g is built with. */
typedef enum { RREF_CONST_LO, RREF_CONST_HI } rref_end_t;

typedef struct rref_result {
    int hit;          /* g has a real root in [t0, t1] */
    double r;         /* the smallest one (rounded to double); NaN on a miss */
    double dp_r;      /* |g'(r)|; NaN on a miss */
    int near_double;  /* see above */
    int near_box;
    int ambiguous;    /* near_double || near_box */
    double graze;     /* min |g(.)| / L at the points the ambiguity test looks at;
                       * INFINITY when there are none, NaN when L = 0 */
    double gmin;      /* min |g| over t0, t1 and every critical point in [t0, t1]
                       * (on a miss: how close the ray comes to the surface, in
                       * units of f); INFINITY on a ray that misses the box */
    double t_gmin;    /* where (rounded to double) */
} rref_result_t;

/* Is the tape a polynomial of degree <= RREF_MAX_DEGREE whose constants are
 * doubles (one answer, no end to choose)? */
int rref_supported(const tape_t *t);

/* The same with interval constants allowed (answers at one end of them). */
int rref_supported_at_ends(const tape_t *t);

/* A reference for tape t (borrowed: it must outlive the result), with the low
 * ends of interval constants and length scale 1.  NULL when the tape is not
 * rref_supported_at_ends or memory runs out. */
rref_t *rref_new(const tape_t *t);
void rref_free(rref_t *c);

/* Build g with the chosen end of every interval constant (from the next ray). */
void rref_set_end(rref_t *c, rref_end_t end);

/* The scene's length scale ell of the ambiguity thresholds (> 0). */
void rref_set_length(rref_t *c, double length);

/* The first root of f(o + t d) in [t0, t1]. */
void rref_ray(rref_t *c, const double o[3], const double d[3], double t0, double t1,
              rref_result_t *out);

/* The same over the ray clipped to box (ray_clip_box, as the renderer does).
 * Returns 0 (and a miss in *out) when the ray misses the box, else 1. */
int rref_ray_box(rref_t *c, const double box[6], const double o[3], const double d[3],
                 rref_result_t *out);

/* Free MPFR's per-thread caches (call once per thread that used a reference,
 * when done). */
void rref_thread_cleanup(void);

#endif
