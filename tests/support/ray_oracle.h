/* Test oracle for ray casting: the first root of g(t) = f(o + t d) along a ray,
 * for polynomial tapes, in MPFR at 192 bits.  Shared by tests/test_ray_roots.c
 * and the stability suite (tests/test_stab_rays.c).
 *
 * Along a ray (o and d exactly the doubles given), g is a polynomial in t; its
 * coefficients are computed by running the tape with polynomial arithmetic
 * (only + - * ^n and constants; with one end of each interval constant, as
 * chosen).  Real roots in [t0, t1] are isolated through the critical points:
 * the roots of p' (found the same way, recursively) cut [t0, t1] into pieces
 * where p is monotone, and a piece holds a root exactly when p changes sign
 * over it; that root is refined by safeguarded Newton to ~2^-90.
 *
 * A ray is *ambiguous* when the answer of a double-precision renderer may
 * legitimately differ from the exact one:
 *  - near a double root: a critical point c before the second root (or t1)
 *    with |p(c)| <= 1e-9 L ell, L = max |p'| on [t0, t1] (the ray comes within
 *    about 1e-9 ell of touching the surface: a silhouette, a whisker, a
 *    singular point) -- near_double;
 *  - near the box: |p(t0)| or |p(t1)| <= 1e-9 L ell (the surface within about
 *    1e-9 ell of where the ray enters or leaves the box) -- near_box;
 * where ell is the scene's length scale (ro_ctx_t.length, 1 unless set: the
 * thresholds are relative to the scene, so that a scene scaled by 1e-8 is not
 * all ambiguous). */
#ifndef IVOCT_TEST_RAY_ORACLE_H
#define IVOCT_TEST_RAY_ORACLE_H

#include <mpfr.h>

#include "../../expr/tape.h"

#define RO_PREC 192
#define RO_DMAX 16

typedef enum { RO_CONST_LO, RO_CONST_HI } ro_const_t;

typedef struct ro_poly {
    int deg; /* -1 for the zero polynomial */
    mpfr_t c[RO_DMAX + 1];
} ro_poly_t;

typedef struct ro_roots {
    int n;
    mpfr_t r[RO_DMAX + 2];
} ro_roots_t;

/* Per-thread scratch. */
typedef struct ro_ctx {
    const tape_t *tape;
    double length; /* the scene's length scale for the ambiguity thresholds; 1 */
    ro_poly_t *slot;
    ro_poly_t p, dp, ddp;
    mpfr_t tmp, a, b, x, y;
    ro_roots_t R, C, C2;
} ro_ctx_t;

typedef struct ro_answer {
    int hit;       /* p has a real root in [t0, t1] */
    double r;      /* the smallest one (rounded to nearest) */
    double dp_r;   /* |p'(r)| */
    double gmin;   /* min |p| over the critical points in [t0, t1] and the ends (on a miss:
                    * how close the ray comes to the surface, in units of f) */
    double t_gmin; /* where (rounded to nearest) */
    int near_double, near_box;
    int ambiguous; /* near_double || near_box */
} ro_answer_t;

/* Is the tape a polynomial the oracle can expand (ops, degree <= RO_DMAX)?
 * exact_consts: also require every constant to be a double (lo == hi). */
int ro_tape_is_polynomial(const tape_t *t, int exact_consts);

void ro_init(ro_ctx_t *c, const tape_t *tape);
void ro_clear(ro_ctx_t *c);

/* The oracle's answer for the ray o + t d over [t0, t1], the tape's constants
 * taken at the chosen end. */
void ro_ray(ro_ctx_t *c, ro_const_t which, const double o[3], const double d[3], double t0,
            double t1, ro_answer_t *out);

/* The exact value of g(t) = f(o + t d) (t a double), to double precision. */
double ro_eval(ro_ctx_t *c, double t);

#endif
