/* ivoct — Lipschitz bounds and the Kalra–Barr tests (see lipschitz.h).
 *
 * Each quantity is an interval operation of expr/interval.h, whose results
 * enclose the exact ones; the upper bound of an enclosure is then a bound
 * rounded up.  Comparisons are written so that NaN makes them false. */
#include "lipschitz.h"

double lip_magnitude(iv_t a) { return fmax(fabs(a.lo), fabs(a.hi)); }

/* sqrt(sum of squares) of three magnitudes, enclosed */
static iv_t norm3(double a, double b, double c)
{
    iv_t s = iv_add(iv_add(iv_add(iv_point(0), iv_sqr(iv_point(a))), iv_sqr(iv_point(b))),
                    iv_sqr(iv_point(c)));
    return iv_sqrt(s);
}

double lip_gradient_bound(iv_grad_t G)
{
    return norm3(lip_magnitude(G.dx), lip_magnitude(G.dy), lip_magnitude(G.dz)).hi;
}

int lip_cell_excludes(const iv_box_t *box, const double c[3], iv_t fc, iv_grad_t G)
{
    double mig = fc.lo > 0 ? fc.lo : fc.hi < 0 ? -fc.hi : 0.0;
    if (!(mig > 0))
        return 0;
    /* r: from c to the farthest corner, each leg rounded up */
    const iv_t *ax[3] = {&box->x, &box->y, &box->z};
    double leg[3];
    for (int k = 0; k < 3; k++)
        leg[k] = iv_up(fmax(c[k] - ax[k]->lo, ax[k]->hi - c[k]));
    double r = norm3(leg[0], leg[1], leg[2]).hi;
    double bound = iv_mul(iv_point(lip_gradient_bound(G)), iv_point(r)).hi;
    if (!(mig > bound))
        return 0;
    return fc.lo > 0 ? 1 : -1;
}

double lip_derivative_bound(iv_t dg) { return lip_magnitude(dg); }

int lip_segment_excludes(double a, double b, double m, iv_t gm, iv_t dg, double rnd)
{
    double mig = gm.lo > 0 ? gm.lo : gm.hi < 0 ? -gm.hi : 0.0;
    double G = lip_derivative_bound(dg);
    if (!(mig > 0) || !isfinite(G))
        return 0;
    double h = iv_up(fmax(m - a, b - m));
    double bound = iv_up(iv_up(G * h) + rnd);
    return mig > bound; /* false when bound is NaN */
}

int lip_normals_within_60_degrees(iv_grad_t G, const double a[3])
{
    iv_t A[3] = {iv_point(a[0]), iv_point(a[1]), iv_point(a[2])};
    iv_t dot = iv_add(iv_add(iv_mul(G.dx, A[0]), iv_mul(G.dy, A[1])), iv_mul(G.dz, A[2]));
    iv_t a2 = iv_add(iv_add(iv_add(iv_point(0), iv_sqr(A[0])), iv_sqr(A[1])), iv_sqr(A[2]));
    iv_t g_times_a = iv_mul(iv_point(lip_gradient_bound(G)), iv_sqrt(a2));
    double half = iv_mul(iv_point(0.5), g_times_a).hi;
    return dot.lo > half; /* false on NaN */
}
