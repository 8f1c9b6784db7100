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
 * in a): then the next choice is tried, v before u, and every pivot.  The
 * resultants are computed here, step by step, so the budget is checked within
 * them (below); before each one a bound on its number of terms is held against
 * the memory budget too (a degree guard). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

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

/* ---- the resultant, step by step ------------------------------------------------------
 * FLINT's fmpz_mpoly_resultant is one call that cannot be interrupted: on a
 * map of moderate degree (denominators of degree 8) a single one ran for
 * minutes.  So the resultant is computed here by the subresultant
 * pseudo-remainder sequence of Collins and Brown (Cohen, A Course in
 * Computational Algebraic Number Theory, algorithm 3.3.7), over Z[other
 * variables], with the budget checked after every elimination of a leading
 * term: a step is one pass of multiplications over one polynomial's
 * coefficients.  The divisions by g h^delta that keep the coefficients small
 * are exact by the theory of subresultants (checked: fmpz_mpoly_divides). */

/* a polynomial in var as a dense array of coefficients free of var; len 0 = 0 */
typedef struct upoly {
    fmpz_mpoly_struct *c;
    slong len;
} upoly_t;

static int upoly_from(upoly_t *u, const fmpz_mpoly_t a, int var, const fmpz_mpoly_ctx_t ctx)
{
    slong deg = fmpz_mpoly_degree_si(a, var, ctx);
    u->len = deg + 1; /* 0 for the zero polynomial (degree -1) */
    u->c = malloc(sizeof *u->c * (size_t)(u->len > 0 ? u->len : 1));
    if (u->c == NULL)
        return -1;
    for (slong i = 0; i < u->len; i++)
        fmpz_mpoly_init(u->c + i, ctx);
    if (u->len == 0)
        return 0;
    fmpz_mpoly_univar_t U;
    fmpz_mpoly_univar_init(U, ctx);
    fmpz_mpoly_to_univar(U, a, var, ctx);
    for (slong i = 0; i < fmpz_mpoly_univar_length(U, ctx); i++)
        fmpz_mpoly_univar_swap_term_coeff(u->c + fmpz_mpoly_univar_get_term_exp_si(U, i, ctx), U, i, ctx);
    fmpz_mpoly_univar_clear(U, ctx);
    return 0;
}

static void upoly_clear(upoly_t *u, const fmpz_mpoly_ctx_t ctx)
{
    for (slong i = 0; i < u->len; i++)
        fmpz_mpoly_clear(u->c + i, ctx);
    free(u->c);
    u->c = NULL;
    u->len = 0;
}

static void upoly_trim(upoly_t *u, const fmpz_mpoly_ctx_t ctx)
{
    while (u->len > 0 && fmpz_mpoly_is_zero(u->c + u->len - 1, ctx)) {
        fmpz_mpoly_clear(u->c + u->len - 1, ctx);
        u->len--;
    }
}

static double upoly_bytes(const upoly_t *u, const fmpz_mpoly_ctx_t ctx)
{
    double b = 0;
    for (slong i = 0; i < u->len; i++)
        b += imp_poly_bytes(u->c + i, ctx);
    return b;
}

/* The budget during a resultant: `live` bytes outside it plus its own. */
static int step_check(const imp_run_t *run, double live, const upoly_t *a, const upoly_t *b,
                      const upoly_t *r, const fmpz_mpoly_ctx_t ctx)
{
    int rc = imp_run_time(run);
    if (rc == 0)
        rc = imp_run_bytes(run, live + upoly_bytes(a, ctx) + upoly_bytes(b, ctx) + upoly_bytes(r, ctx),
                           "the intermediate polynomials take");
    return rc;
}

/* r = prem(a, b) = lc(b)^(deg a - deg b + 1) a mod b, deg a >= deg b >= 1. */
static int prem(upoly_t *r, const upoly_t *a, const upoly_t *b, double live, const fmpz_mpoly_ctx_t ctx,
                const imp_run_t *run)
{
    slong m = a->len - 1, n = b->len - 1;
    r->len = a->len;
    r->c = malloc(sizeof *r->c * (size_t)r->len);
    if (r->c == NULL) {
        r->len = 0;
        return IMP_ENOMEM;
    }
    for (slong i = 0; i <= m; i++) {
        fmpz_mpoly_init(r->c + i, ctx);
        fmpz_mpoly_set(r->c + i, a->c + i, ctx);
    }
    const fmpz_mpoly_struct *lb = b->c + n;
    fmpz_mpoly_t lead, t;
    fmpz_mpoly_init(lead, ctx);
    fmpz_mpoly_init(t, ctx);
    int rc = 0;
    for (slong k = m; k >= n && rc == 0; k--) {
        /* cancel the term of degree k: r = lc(b) r - r_k x^(k-n) b */
        fmpz_mpoly_swap(lead, r->c + k, ctx);
        fmpz_mpoly_zero(r->c + k, ctx);
        /* the clock after each coefficient: with large coefficients one
         * elimination is many products, seconds in all */
        for (slong i = 0; i < k && rc == 0; i++) {
            fmpz_mpoly_mul(r->c + i, r->c + i, lb, ctx);
            if (i >= k - n && !fmpz_mpoly_is_zero(lead, ctx)) {
                fmpz_mpoly_mul(t, lead, b->c + i - (k - n), ctx);
                fmpz_mpoly_sub(r->c + i, r->c + i, t, ctx);
            }
            rc = imp_run_time(run);
        }
        if (rc == 0)
            rc = step_check(run, live, a, b, r, ctx);
    }
    fmpz_mpoly_clear(lead, ctx);
    fmpz_mpoly_clear(t, ctx);
    upoly_trim(r, ctx);
    return rc;
}

/* q = a / b, exact; 0, or 1 when it is not (never, by the theory) */
static int divide(fmpz_mpoly_t q, const fmpz_mpoly_t a, const fmpz_mpoly_t b, const fmpz_mpoly_ctx_t ctx)
{
    if (fmpz_mpoly_is_one(b, ctx)) {
        fmpz_mpoly_set(q, a, ctx);
        return 0;
    }
    return fmpz_mpoly_divides(q, a, b, ctx) ? 0 : 1;
}

/* c = x^n / y^(n-1), n >= 1, by Lazard's steps c = c x / y (Ducos 2000, sec. 2):
 * in the subresultant sequence each x^k / y^(k-1), k <= n, is a principal
 * subresultant coefficient, so every division is exact and the intermediates
 * stay the size of such coefficients, where x^n and y^(n-1) first would be
 * about n times larger and their quotient one uninterruptible division of
 * seconds.  The budget is checked after each step.  0, 1 (a division not
 * exact: never, by the theory) or IMP_EBUDGET. */
static int pow_quotient(fmpz_mpoly_t c, const fmpz_mpoly_t x, const fmpz_mpoly_t y, slong n,
                        const fmpz_mpoly_ctx_t ctx, const imp_run_t *run)
{
    fmpz_mpoly_t t;
    fmpz_mpoly_init(t, ctx);
    fmpz_mpoly_set(t, x, ctx);
    int rc = 0;
    for (slong k = 1; k < n && rc == 0; k++) {
        fmpz_mpoly_mul(t, t, x, ctx);
        if ((rc = divide(t, t, y, ctx)) == 0)
            rc = imp_run_time(run);
    }
    fmpz_mpoly_swap(c, t, ctx);
    fmpz_mpoly_clear(t, ctx);
    return rc;
}

/* R = Res_var(A, B) up to sign (the sign does not matter here): 0, 1 (could
 * not be computed), IMP_EBUDGET or IMP_ENOMEM.  A and B nonzero. */
static int subresultant(fmpz_mpoly_t R, const fmpz_mpoly_t A0, const fmpz_mpoly_t B0, int var,
                        double live, const fmpz_mpoly_ctx_t ctx, const imp_run_t *run)
{
    upoly_t A = {0}, B = {0}, r = {0};
    int rc = 0;
    if (upoly_from(&A, A0, var, ctx) || upoly_from(&B, B0, var, ctx)) {
        upoly_clear(&A, ctx);
        upoly_clear(&B, ctx);
        return IMP_ENOMEM;
    }
    if (A.len < B.len) {
        upoly_t t = A;
        A = B;
        B = t;
    }
    fmpz_mpoly_t g, h, t;
    fmpz_mpoly_init(g, ctx);
    fmpz_mpoly_init(h, ctx);
    fmpz_mpoly_init(t, ctx);
    fmpz_mpoly_one(g, ctx);
    fmpz_mpoly_one(h, ctx);
    if (B.len == 1) { /* Res(A, b) = b^deg A */
        if (!fmpz_mpoly_pow_ui(R, B.c + 0, (ulong)(A.len - 1), ctx))
            rc = 1;
        goto done;
    }
    for (;;) {
        slong delta = A.len - B.len;
        if ((rc = prem(&r, &A, &B, live, ctx, run)))
            break;
        if (r.len == 0) { /* a common factor in var */
            fmpz_mpoly_zero(R, ctx);
            break;
        }
        /* A = B, B = r / (g h^delta) */
        upoly_clear(&A, ctx);
        A = B;
        B = r;
        r.c = NULL;
        r.len = 0;
        if (!fmpz_mpoly_pow_ui(t, h, (ulong)delta, ctx)) {
            rc = 1;
            break;
        }
        fmpz_mpoly_mul(t, t, g, ctx);
        for (slong i = 0; i < B.len && rc == 0; i++)
            if ((rc = divide(B.c + i, B.c + i, t, ctx)) == 0)
                rc = i % 8 == 7 ? step_check(run, live, &A, &B, &r, ctx) : imp_run_time(run);
        if (rc)
            break;
        /* g = lc(A), h = h^(1 - delta) g^delta */
        fmpz_mpoly_set(g, A.c + A.len - 1, ctx);
        if (delta == 1)
            fmpz_mpoly_set(h, g, ctx);
        else if (delta > 1) {
            if ((rc = pow_quotient(t, g, h, delta, ctx, run)))
                break;
            fmpz_mpoly_swap(h, t, ctx);
        }
        if ((rc = step_check(run, live, &A, &B, &r, ctx)))
            break;
        if (B.len == 1) { /* R = lc(B)^deg A / h^(deg A - 1) */
            rc = pow_quotient(R, B.c + 0, h, A.len - 1, ctx, run);
            break;
        }
    }
done:
    upoly_clear(&A, ctx);
    upoly_clear(&B, ctx);
    upoly_clear(&r, ctx);
    fmpz_mpoly_clear(g, ctx);
    fmpz_mpoly_clear(h, ctx);
    fmpz_mpoly_clear(t, ctx);
    return rc;
}

/* One resultant with the budget checked around and inside it.  Returns 0,
 * 1 (it could not be computed: give up this choice), IMP_EBUDGET or IMP_ENOMEM. */
static int resultant(fmpz_mpoly_t R, const fmpz_mpoly_t A, const fmpz_mpoly_t B, int var,
                     double live, const fmpz_mpoly_ctx_t ctx, const imp_run_t *run)
{
    int rc;
    if ((rc = imp_run_time(run)) || (rc = guard(A, B, var, live, ctx, run)))
        return rc;
    if ((rc = subresultant(R, A, B, var, live, ctx, run)))
        return rc;
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
    else if (rc == IMP_ENOMEM)
        ivoct_error_at(run->err, 0, 0, "implicitization by resultants: out of memory");
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
