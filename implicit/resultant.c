/* ivoct — elimination by Sylvester resultants.
 *
 * The graph of the map is the zero set of P_i = den_i t_i - num_i (t = x, y,
 * z) in Z[u, v, x, y, z], minus the zeros of the denominators.  A resultant
 * Res_a(A, B) lies in the ideal of A and B and is free of a, so eliminating
 * u from (P_k, P_i) and (P_k, P_j) with one pivot P_k, then v from the two
 * results, gives a polynomial of Z[x, y, z] that vanishes wherever all three
 * P vanish, which includes the image.  It may have other factors: the
 * resultant vanishes also where the two leading coefficients in a vanish
 * together (the denominators, points "at infinity" of the parametrization)
 * and where the P have common zeros for every (x, y, z) (base points).
 * implicit.c factors it and keeps the factor that vanishes on the map.
 *
 * A resultant can be identically 0 (the two polynomials have a common factor
 * in a): then the next choice is tried, v before u, and every pivot.  FLINT
 * computes each resultant in one call that cannot be interrupted, so the
 * budget is checked between them, and before each one a bound on its number
 * of terms is held against the memory budget (a degree guard). */
#include <math.h>
#include <stdio.h>

#include "internal.h"

static const char VNAME[N_VARS] = {'w', 'u', 'v', 'x', 'y', 'z'};

/* Remove the factors of A that are free of x, y and z (polynomials of the
 * parameter still present, and integer content): they vanish nowhere on the
 * image, only make the next resultant bigger. */
static void strip_parameter_content(fmpz_mpoly_t A, const fmpz_mpoly_ctx_t ctx)
{
    slong xyz[3] = {V_X, V_Y, V_Z}; /* FLINT's prototype takes it non-const */
    if (A->length == 0)
        return;
    fmpz_mpoly_t g;
    fmpz_mpoly_init(g, ctx);
    if (fmpz_mpoly_content_vars(g, A, xyz, 3, ctx) && !fmpz_mpoly_is_zero(g, ctx) &&
        !fmpz_mpoly_is_one(g, ctx))
        fmpz_mpoly_divexact(A, A, g, ctx);
    fmpz_mpoly_clear(g, ctx);
    if (fmpz_sgn(A->coeffs + 0) < 0)
        fmpz_mpoly_neg(A, A, ctx);
}

/* Before Res_var(A, B): a bound on its terms against the budget.  With m, n
 * the degrees in var, each term of the Sylvester determinant is a product of
 * n coefficients of A and m of B, so the degree of the resultant in another
 * variable t is at most n deg_t A + m deg_t B, and its total degree at most
 * n deg A + m deg B; the number of monomials under either bound bounds the
 * terms.  Coefficients are not counted (the check after the resultant does). */
static int guard(const fmpz_mpoly_t A, const fmpz_mpoly_t B, int var, double live,
                 const fmpz_mpoly_ctx_t ctx, const imp_run_t *run)
{
    slong m = fmpz_mpoly_degree_si(A, var, ctx), n = fmpz_mpoly_degree_si(B, var, ctx);
    slong dA[N_VARS], dB[N_VARS];
    fmpz_mpoly_degrees_si(dA, A, ctx);
    fmpz_mpoly_degrees_si(dB, B, ctx);
    double per_var = 1.0, binom = 1.0;
    double total = (double)n * (double)fmpz_mpoly_total_degree_si(A, ctx) +
                   (double)m * (double)fmpz_mpoly_total_degree_si(B, ctx);
    int k = 0;
    for (int t = 0; t < N_VARS; t++) {
        if (t == var || (dA[t] <= 0 && dB[t] <= 0))
            continue;
        double d = (double)n * (double)(dA[t] > 0 ? dA[t] : 0) + (double)m * (double)(dB[t] > 0 ? dB[t] : 0);
        per_var *= d + 1.0;
        k++;
        binom = binom * (total + k) / k; /* C(total + k, k) */
    }
    double terms = per_var < binom ? per_var : binom;
    char detail[128];
    snprintf(detail, sizeof detail, "the resultant in %c (up to %.3g terms) could take", VNAME[var], terms);
    /* at least one coefficient limb and one exponent word per term */
    return imp_run_bytes(run, live + terms * 16.0, detail);
}

/* One resultant with the budget checked around it.  Returns 0, 1 (FLINT
 * could not compute it: give up this choice) or IMP_EBUDGET. */
static int resultant(fmpz_mpoly_t R, const fmpz_mpoly_t A, const fmpz_mpoly_t B, int var,
                     double live, const fmpz_mpoly_ctx_t ctx, const imp_run_t *run)
{
    int rc;
    if ((rc = imp_run_time(run)) || (rc = guard(A, B, var, live, ctx, run)))
        return rc;
    if (!fmpz_mpoly_resultant(R, A, B, var, ctx))
        return 1;
    strip_parameter_content(R, ctx);
    if ((rc = imp_run_bytes(run, live + imp_poly_bytes(R, ctx), "the intermediate polynomials take")))
        return rc;
    return imp_run_time(run);
}

/* Eliminate a with pivot P[k], then b.  Returns 0 with R nonzero in Z[x, y, z],
 * 1 when this choice gives 0 (or cannot be computed), or IMP_EBUDGET. */
static int try_pivot(const fmpz_mpoly_struct P[3], int k, int a, int b, const fmpz_mpoly_ctx_t ctx,
                     const imp_run_t *run, fmpz_mpoly_t R)
{
    fmpz_mpoly_t Q[2];
    double live = 0;
    int rc = 0, nq = 0;
    for (int i = 0; i < 3; i++)
        live += imp_poly_bytes(P + i, ctx);
    fmpz_mpoly_init(Q[0], ctx);
    fmpz_mpoly_init(Q[1], ctx);
    for (int j = 0; j < 3 && rc == 0; j++) {
        if (j == k)
            continue;
        if (fmpz_mpoly_degree_si(P + j, a, ctx) <= 0)
            fmpz_mpoly_set(Q[nq], P + j, ctx); /* free of a already */
        else
            rc = resultant(Q[nq], P + k, P + j, a, live, ctx, run);
        if (rc == 0 && fmpz_mpoly_is_zero(Q[nq], ctx))
            rc = 1;
        if (rc == 0)
            live += imp_poly_bytes(Q[nq], ctx);
        nq++;
    }
    if (rc == 0) {
        int has0 = fmpz_mpoly_degree_si(Q[0], b, ctx) > 0, has1 = fmpz_mpoly_degree_si(Q[1], b, ctx) > 0;
        if (has0 && has1)
            rc = resultant(R, Q[0], Q[1], b, live, ctx, run);
        else if (!has0 && (has1 || fmpz_mpoly_total_degree_si(Q[0], ctx) <= fmpz_mpoly_total_degree_si(Q[1], ctx)))
            fmpz_mpoly_set(R, Q[0], ctx); /* already in Z[x, y, z] */
        else
            fmpz_mpoly_set(R, Q[1], ctx);
    }
    if (rc == 0 && (fmpz_mpoly_is_zero(R, ctx) || fmpz_mpoly_is_fmpz(R, ctx) ||
                    fmpz_mpoly_degree_si(R, a, ctx) > 0 || fmpz_mpoly_degree_si(R, b, ctx) > 0))
        rc = 1;
    fmpz_mpoly_clear(Q[0], ctx);
    fmpz_mpoly_clear(Q[1], ctx);
    return rc;
}

int imp_eliminate_resultant(const imp_param_t *p, const imp_run_t *run, fmpz_mpoly_t E,
                            const fmpz_mpoly_ctx_t ctx3)
{
    static const int orders[2][2] = {{V_U, V_V}, {V_V, V_U}};
    static const int to_xyz[N_VARS] = {-1, -1, -1, 0, 1, 2};
    fmpz_mpoly_ctx_t ctx;
    fmpz_mpoly_ctx_init(ctx, N_VARS, ORD_LEX);
    fmpz_mpoly_struct P[3];
    fmpz_mpoly_t R;
    fmpz_mpoly_init(R, ctx);
    for (int i = 0; i < 3; i++)
        fmpz_mpoly_init(P + i, ctx);
    imp_graph_polys(p, ctx, P);

    int rc = 1;
    for (int o = 0; o < 2 && rc == 1; o++) {
        int a = orders[o][0], b = orders[o][1];
        /* pivots by increasing positive degree in a */
        int piv[3], np = 0;
        for (slong d = 1; np < 3 && d <= IMP_MAX_DEGREE + 1; d++)
            for (int i = 0; i < 3; i++)
                if (fmpz_mpoly_degree_si(P + i, a, ctx) == d)
                    piv[np++] = i;
        for (int q = 0; q < np && rc == 1; q++)
            rc = try_pivot(P, piv[q], a, b, ctx, run, R);
    }
    if (rc == 0)
        imp_move_vars(E, ctx3, R, ctx, to_xyz);
    else if (rc == 1) {
        ivoct_error_at(run->err, 0, 0,
                       "implicitization by resultants: every eliminant is 0 (u then v and v then "
                       "u, with every pivot)");
        rc = IMP_EINPUT;
    }
    for (int i = 0; i < 3; i++)
        fmpz_mpoly_clear(P + i, ctx);
    fmpz_mpoly_clear(R, ctx);
    fmpz_mpoly_ctx_clear(ctx);
    return rc;
}
