/* ivoct — what a parsed parametrization gives besides its implicit equation:
 * exact points (imp_param_eval), a rigorous box of a patch (imp_param_bounds),
 * and the method names. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../expr/interval.h"
#include "internal.h"

/* ---- exact points ------------------------------------------------------------------ */

/* r = a(u, v), term by term in exact rationals. */
static void eval_mpq(mpq_t r, const fmpz_mpoly_t a, const fmpz_mpoly_ctx_t ctx, const mpq_t u,
                     const mpq_t v)
{
    mpq_t t;
    mpz_t c, w;
    mpq_init(t);
    mpz_init(c);
    mpz_init(w);
    mpq_set_ui(r, 0, 1);
    for (slong i = 0; i < a->length; i++) {
        ulong e[2];
        fmpz_mpoly_get_term_exp_ui(e, a, i, ctx);
        fmpz_get_mpz(c, a->coeffs + i);
        /* c u^e0 v^e1 = c un^e0 vn^e1 / (ud^e0 vd^e1) */
        mpz_pow_ui(w, mpq_numref(u), e[0]);
        mpz_mul(c, c, w);
        mpz_pow_ui(w, mpq_numref(v), e[1]);
        mpz_mul(mpq_numref(t), c, w);
        mpz_pow_ui(w, mpq_denref(u), e[0]);
        mpz_pow_ui(mpq_denref(t), mpq_denref(v), e[1]);
        mpz_mul(mpq_denref(t), mpq_denref(t), w);
        mpq_canonicalize(t);
        mpq_add(r, r, t);
    }
    mpq_clear(t);
    mpz_clear(c);
    mpz_clear(w);
}

int imp_param_eval(const imp_param_t *p, const mpq_t u, const mpq_t v, mpq_t xyz[3])
{
    mpq_t n[3], d;
    int rc = 0;
    mpq_init(d);
    for (int i = 0; i < 3; i++) {
        mpq_init(n[i]);
        if (rc)
            continue;
        eval_mpq(d, p->den + i, p->ctx, u, v);
        if (mpq_sgn(d) == 0) {
            rc = -1;
            continue;
        }
        eval_mpq(n[i], p->num + i, p->ctx, u, v);
        mpq_div(n[i], n[i], d);
    }
    for (int i = 0; i < 3; i++) {
        if (rc == 0)
            mpq_set(xyz[i], n[i]);
        mpq_clear(n[i]);
    }
    mpq_clear(d);
    return rc;
}

/* ---- rigorous bounds of a patch ---------------------------------------------------- */

/* Sub-rectangles per side of the patch: the enclosure of each monomial sum
 * over a sub-rectangle overestimates by O(width), so 32 x 32 of them give a
 * box within a few percent of the hull for the usual patches, at 1024
 * evaluations of each coordinate. */
#define BOUNDS_GRID 32

/* An interval holding the integer c: exact below 2^53, otherwise the double
 * fmpz_get_d gives and its neighbour on the side where c lies (whatever the
 * rounding of fmpz_get_d, c is within one ulp of it). */
static iv_t fmpz_enclose(const fmpz_t c)
{
    if (fmpz_bits(c) <= 53)
        return iv_point(fmpz_get_d(c));
    if (fmpz_bits(c) > 1020)
        return fmpz_sgn(c) > 0 ? iv_make(DBL_MAX, INFINITY) : iv_make(-INFINITY, -DBL_MAX);
    double d = fmpz_get_d(c);
    fmpz_t t;
    fmpz_init(t);
    fmpz_set_d(t, d); /* d is an integer here: exact */
    int cmp = fmpz_cmp(t, c);
    fmpz_clear(t);
    if (cmp == 0)
        return iv_point(d);
    return cmp < 0 ? iv_make(d, nextafter(d, INFINITY)) : iv_make(nextafter(d, -INFINITY), d);
}

/* A polynomial ready for interval evaluation: coefficients enclosed. */
typedef struct ivpoly {
    slong n;
    iv_t *c;
    ulong *e; /* 2 per term: u, v */
} ivpoly_t;

static int ivpoly_make(ivpoly_t *q, const fmpz_mpoly_t a, const fmpz_mpoly_ctx_t ctx, ulong maxe[2])
{
    q->n = a->length;
    q->c = malloc(sizeof *q->c * (size_t)(q->n ? q->n : 1));
    q->e = malloc(sizeof *q->e * 2 * (size_t)(q->n ? q->n : 1));
    if (q->c == NULL || q->e == NULL)
        return -1;
    for (slong i = 0; i < q->n; i++) {
        q->c[i] = fmpz_enclose(a->coeffs + i);
        fmpz_mpoly_get_term_exp_ui(q->e + 2 * i, a, i, ctx);
        for (int k = 0; k < 2; k++)
            if (q->e[2 * i + k] > maxe[k])
                maxe[k] = q->e[2 * i + k];
    }
    return 0;
}

static iv_t ivpoly_eval(const ivpoly_t *q, const iv_t *up, const iv_t *vp)
{
    iv_t s = iv_point(0.0);
    for (slong i = 0; i < q->n; i++)
        s = iv_add(s, iv_mul(q->c[i], iv_mul(up[q->e[2 * i]], vp[q->e[2 * i + 1]])));
    return s;
}

/* Grid points t[0] = a < ... < t[n] = b, monotone (each step is a monotone
 * function of k, then clamped), finite whenever a and b are. */
static void grid(double a, double b, int n, double *t)
{
    double step = b / n - a / n;
    t[0] = a;
    for (int k = 1; k < n; k++) {
        double x = a + step * k;
        t[k] = x < t[k - 1] ? t[k - 1] : x > b ? b : x;
    }
    t[n] = b;
}

static void powers(iv_t *t, iv_t a, ulong n)
{
    for (ulong k = 0; k <= n; k++)
        t[k] = k == 0 ? iv_point(1.0) : iv_powi(a, (int)k);
}

static iv_t intersect(iv_t a, iv_t b)
{
    iv_t r = iv_make(a.lo > b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi);
    return r.lo <= r.hi ? r : a; /* both hold the range: never empty */
}

/* Per polynomial of a coordinate: 0 numerator, 1 denominator, 2 and 3 the
 * numerators of the partial derivatives in u and v. */
#define N_PARTS 4

int imp_param_bounds(const imp_param_t *p, const double u[2], const double v[2], double box[6],
                     ivoct_error_t *err)
{
    ivoct_error_clear(err);
    if (!(isfinite(u[0]) && isfinite(u[1]) && isfinite(v[0]) && isfinite(v[1]) && u[0] <= u[1] &&
          v[0] <= v[1])) {
        ivoct_error_at(err, 0, 0,
                       "invalid patch: u and v ranges must be finite with min <= max");
        return IMP_EINPUT;
    }
    const char *coord = "xyz";
    int nu = u[0] == u[1] ? 1 : BOUNDS_GRID, nv = v[0] == v[1] ? 1 : BOUNDS_GRID;
    double ut[BOUNDS_GRID + 1], vt[BOUNDS_GRID + 1];
    grid(u[0], u[1], nu, ut);
    grid(v[0], v[1], nv, vt);

    ivpoly_t q[3][N_PARTS];
    ulong maxe[2] = {0, 0};
    int rc = IMP_OK;
    memset(q, 0, sizeof q);
    fmpz_mpoly_t du, dv;
    fmpz_mpoly_init(du, p->ctx);
    fmpz_mpoly_init(dv, p->ctx);
    for (int i = 0; i < 3 && rc == IMP_OK; i++) {
        imp_partials(p->num + i, p->den + i, p->ctx, du, dv);
        if (ivpoly_make(&q[i][0], p->num + i, p->ctx, maxe) ||
            ivpoly_make(&q[i][1], p->den + i, p->ctx, maxe) ||
            ivpoly_make(&q[i][2], du, p->ctx, maxe) || ivpoly_make(&q[i][3], dv, p->ctx, maxe))
            rc = IMP_ENOMEM;
    }
    fmpz_mpoly_clear(du, p->ctx);
    fmpz_mpoly_clear(dv, p->ctx);
    size_t nuv = maxe[0] > maxe[1] ? maxe[0] + 1 : maxe[1] + 1;
    iv_t *up = malloc(sizeof *up * nuv), *vp = malloc(sizeof *vp * nuv);
    iv_t *cup = malloc(sizeof *up * nuv), *cvp = malloc(sizeof *vp * nuv);
    if (up == NULL || vp == NULL || cup == NULL || cvp == NULL)
        rc = IMP_ENOMEM;
    if (rc == IMP_ENOMEM)
        ivoct_error_set(err, "out of memory while bounding a patch");

    /* Over each sub-rectangle R = U x V with centre c, a coordinate n/d lies
     * in the natural enclosure N(R)/D(R) and in the mean-value form
     * X(c) + X_u(R) (U - c_u) + X_v(R) (V - c_v), X_u(R) = Nu(R) / D(R)^2:
     * the first is loose by O(width), the second by O(width^2); their
     * intersection holds the range and is tight. */
    iv_t hull[3] = {iv_empty(), iv_empty(), iv_empty()};
    for (int a = 0; a < nu && rc == IMP_OK; a++) {
        iv_t U = iv_make(ut[a], ut[a + 1]);
        double cu = fmin(fmax(iv_mid(U), U.lo), U.hi); /* in U, whatever the rounding */
        powers(up, U, maxe[0]);
        powers(cup, iv_point(cu), maxe[0]);
        for (int b = 0; b < nv && rc == IMP_OK; b++) {
            iv_t V = iv_make(vt[b], vt[b + 1]);
            double cv = fmin(fmax(iv_mid(V), V.lo), V.hi);
            powers(vp, V, maxe[1]);
            powers(cvp, iv_point(cv), maxe[1]);
            for (int i = 0; i < 3; i++) {
                iv_t num = ivpoly_eval(&q[i][0], up, vp), den = ivpoly_eval(&q[i][1], up, vp);
                if (den.lo <= 0.0 && den.hi >= 0.0) {
                    ivoct_error_at(err, 0, 0,
                                   "the denominator of %c may vanish on the patch, near u in [%.17g, "
                                   "%.17g], v in [%.17g, %.17g]: a pole (choose a patch that avoids it)",
                                   coord[i], U.lo, U.hi, V.lo, V.hi);
                    rc = IMP_EINPUT;
                    break;
                }
                iv_t r = iv_div(num, den);
                iv_t c = iv_div(ivpoly_eval(&q[i][0], cup, cvp), ivpoly_eval(&q[i][1], cup, cvp));
                iv_t d2 = iv_sqr(den);
                iv_t xu = iv_div(ivpoly_eval(&q[i][2], up, vp), d2);
                iv_t xv = iv_div(ivpoly_eval(&q[i][3], up, vp), d2);
                iv_t mv = iv_add(c, iv_add(iv_mul(xu, iv_sub(U, iv_point(cu))),
                                           iv_mul(xv, iv_sub(V, iv_point(cv)))));
                hull[i] = iv_hull(hull[i], intersect(r, mv));
            }
        }
    }
    if (rc == IMP_OK)
        for (int i = 0; i < 3; i++) {
            box[2 * i] = hull[i].lo;
            box[2 * i + 1] = hull[i].hi;
        }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < N_PARTS; k++) {
            free(q[i][k].c);
            free(q[i][k].e);
        }
    free(up);
    free(vp);
    free(cup);
    free(cvp);
    return rc;
}

/* ---- method names ------------------------------------------------------------------ */

static const char *const METHOD_NAMES[] = {"auto", "resultant", "groebner"};

const char *imp_method_name(imp_method_t m)
{
    return (unsigned)m < 3 ? METHOD_NAMES[m] : "unknown";
}

int imp_method_parse(const char *name, imp_method_t *m)
{
    for (int i = 0; name && i < 3; i++)
        if (strcmp(name, METHOD_NAMES[i]) == 0) {
            *m = (imp_method_t)i;
            return 0;
        }
    return -1;
}
