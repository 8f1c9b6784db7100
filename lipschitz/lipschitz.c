/* ivoct — Lipschitz bounds and the Kalra–Barr tests (see lipschitz.h).
 *
 * Each quantity is an interval operation of expr/interval.h, whose results
 * enclose the exact ones; the upper bound of an enclosure is then a bound
 * rounded up.  Comparisons are written so that NaN makes them false. */
#include "lipschitz.h"

/* fmax (the other operand when one is NaN) without libm's call */
static inline double max_num(double a, double b) { return a > b || b != b ? a : b; }

static inline double magnitude(iv_t a) { return max_num(fabs(a.lo), fabs(a.hi)); }

double lip_magnitude(iv_t a) { return magnitude(a); }

/* The upper ends of iv_sqrt(0 + a^2 + b^2 + c^2) (iv_add, iv_sqr of points) and
 * of iv_mul(iv_point(a), iv_point(b)) for a, b, c >= 0 (or NaN), bit for bit,
 * with only the upper ends computed: the cell test runs on
 * every open cell of a build with the Lipschitz test, and the lower ends (and
 * iv_sqrt's call) were most of its time.  For magnitudes the intervals are
 * points or hold only non-negative numbers, which leaves of each operation
 * the branch written out here (interval.h, interval.c); the tests compare
 * these with the interval operations (tests/test_lipschitz_mpfi.c). */
static inline double norm3_up(double a, double b, double c)
{
    double s = iv_add_up(iv_add_up(iv_sqr_hi(a), iv_sqr_hi(b)), iv_sqr_hi(c));
    return s != s ? s : s > 0 ? iv_up(sqrt(s)) : 0.0;
}

static inline double mul_up(double a, double b)
{
    if (a != a || b != b)
        return NAN;
    return a == 0 || b == 0 ? 0.0 : iv_up(a * b);
}

static inline double gradient_bound(iv_grad_t G)
{
    return norm3_up(magnitude(G.dx), magnitude(G.dy), magnitude(G.dz));
}

double lip_gradient_bound(iv_grad_t G) { return gradient_bound(G); }

int lip_cell_excludes(const iv_box_t *box, const double c[3], iv_t fc, iv_grad_t G)
{
    double mig = fc.lo > 0 ? fc.lo : fc.hi < 0 ? -fc.hi : 0.0;
    if (!(mig > 0))
        return 0;
    /* r: from c to the farthest corner, each leg rounded up */
    const iv_t *ax[3] = {&box->x, &box->y, &box->z};
    double leg[3];
    for (int k = 0; k < 3; k++)
        leg[k] = iv_up(max_num(c[k] - ax[k]->lo, ax[k]->hi - c[k]));
    double bound = mul_up(gradient_bound(G), norm3_up(leg[0], leg[1], leg[2]));
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
