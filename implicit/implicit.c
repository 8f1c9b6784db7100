/* ivoct — imp_implicitize: run a method, pick the factor of its eliminant
 * that vanishes on the parametrization (checked exactly), and write the
 * result; with the helpers the methods share (budget, rings). */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <flint/fmpz_mpoly_factor.h>
#include <flint/fmpz_vec.h>

#include "internal.h"

/* ---- budget -------------------------------------------------------------------------- */

double imp_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int imp_run_time(const imp_run_t *run)
{
    if (imp_now() - run->t0 <= run->seconds)
        return 0;
    ivoct_error_at(run->err, 0, 0, "implicitization by %s: past the time budget of %g s", run->what,
                   run->seconds);
    return IMP_EBUDGET;
}

int imp_run_bytes(const imp_run_t *run, double live, const char *detail)
{
    if (live <= (double)run->bytes)
        return 0;
    ivoct_error_at(run->err, 0, 0,
                   "implicitization by %s: %s %.3g bytes, past the memory budget of %zu bytes",
                   run->what, detail, live, run->bytes);
    return IMP_EBUDGET;
}

double imp_poly_bytes(const fmpz_mpoly_t a, const fmpz_mpoly_ctx_t ctx)
{
    slong bits = fmpz_mpoly_max_bits(a);
    bits = bits < 0 ? -bits : bits;
    double limbs = (double)((bits + FLINT_BITS - 1) / FLINT_BITS);
    if (limbs < 1)
        limbs = 1;
    double words = (double)mpoly_words_per_exp(a->bits, ctx->minfo);
    return (double)a->length * (limbs + words) * 8.0;
}

/* ---- rings --------------------------------------------------------------------------- */

void imp_move_vars(fmpz_mpoly_t dst, const fmpz_mpoly_ctx_t dctx, const fmpz_mpoly_t src,
                   const fmpz_mpoly_ctx_t sctx, const int *map)
{
    slong ns = sctx->minfo->nvars, nd = dctx->minfo->nvars;
    ulong es[N_VARS], ed[N_VARS];
    fmpz_mpoly_zero(dst, dctx);
    for (slong i = 0; i < src->length; i++) {
        fmpz_mpoly_get_term_exp_ui(es, src, i, sctx);
        memset(ed, 0, sizeof ed);
        for (slong k = 0; k < ns; k++)
            if (map[k] >= 0)
                ed[map[k]] = es[k];
        fmpz_mpoly_push_term_fmpz_ui(dst, src->coeffs + i, ed, dctx);
    }
    (void)nd;
    fmpz_mpoly_sort_terms(dst, dctx);
    fmpz_mpoly_combine_like_terms(dst, dctx);
}

void imp_graph_polys(const imp_param_t *p, const fmpz_mpoly_ctx_t ctx6, fmpz_mpoly_struct P[3])
{
    static const int uv[2] = {V_U, V_V};
    fmpz_mpoly_t n, t;
    fmpz_mpoly_init(n, ctx6);
    fmpz_mpoly_init(t, ctx6);
    for (int i = 0; i < 3; i++) {
        imp_move_vars(P + i, ctx6, p->den + i, p->ctx, uv);
        fmpz_mpoly_gen(t, V_X + i, ctx6);
        fmpz_mpoly_mul(P + i, P + i, t, ctx6);
        imp_move_vars(n, ctx6, p->num + i, p->ctx, uv);
        fmpz_mpoly_sub(P + i, P + i, n, ctx6);
    }
    fmpz_mpoly_clear(n, ctx6);
    fmpz_mpoly_clear(t, ctx6);
}

/* ---- does F vanish on the parametrization? ------------------------------------------- */

/* Sum over the terms c x^i y^j z^k of F of c * prod_t a_t^e_t b_t^(d_t - e_t),
 * with d the degrees of F in x, y, z: the value of F at (a0/b0, a1/b1, a2/b2)
 * times b0^d0 b1^d1 b2^d2.  Integers here. */
static void homog_eval(fmpz_t r, const fmpz_mpoly_t F, const fmpz_mpoly_ctx_t ctx3, const fmpz *a,
                       const fmpz *b, const slong d[3])
{
    fmpz_t t, w;
    fmpz_init(t);
    fmpz_init(w);
    fmpz_zero(r);
    for (slong i = 0; i < F->length; i++) {
        ulong e[3];
        fmpz_mpoly_get_term_exp_ui(e, F, i, ctx3);
        fmpz_set(t, F->coeffs + i);
        for (int k = 0; k < 3; k++) {
            fmpz_pow_ui(w, a + k, e[k]);
            fmpz_mul(t, t, w);
            fmpz_pow_ui(w, b + k, (ulong)d[k] - e[k]);
            fmpz_mul(t, t, w);
        }
        fmpz_add(r, r, t);
    }
    fmpz_clear(t);
    fmpz_clear(w);
}

/* Integer points (u, v) for the quick test: small, scattered, fixed. */
static const slong QUICK_POINTS[][2] = {{3, 7},  {-5, 2},  {11, -4}, {2, 13},  {-9, -6},
                                        {17, 5}, {-3, 19}, {8, -15}, {23, 12}, {-21, 9},
                                        {6, 29}, {31, -2}, {-14, -27}, {4, 37}, {41, 18}};
#define N_QUICK (sizeof QUICK_POINTS / sizeof QUICK_POINTS[0])

/* 0 when F(X, Y, Z) is certainly not 0: F is nonzero at an exact point of
 * the image.  1 when it vanishes at two such points (worth the exact check). */
static int vanishes_quick(const imp_param_t *p, const fmpz_mpoly_t F, const fmpz_mpoly_ctx_t ctx3,
                          const slong d[3])
{
    fmpz uv[2], a[3], b[3];
    fmpz *uvp[2] = {uv, uv + 1};
    fmpz_t r;
    fmpz_init(r);
    for (int k = 0; k < 3; k++) {
        fmpz_init(a + k);
        fmpz_init(b + k);
    }
    fmpz_init(uv);
    fmpz_init(uv + 1);
    int zeros = 0, result = 1;
    for (size_t q = 0; q < N_QUICK && zeros < 2; q++) {
        fmpz_set_si(uv, QUICK_POINTS[q][0]);
        fmpz_set_si(uv + 1, QUICK_POINTS[q][1]);
        int pole = 0;
        for (int k = 0; k < 3; k++) {
            fmpz_mpoly_evaluate_all_fmpz(a + k, p->num + k, uvp, p->ctx);
            fmpz_mpoly_evaluate_all_fmpz(b + k, p->den + k, uvp, p->ctx);
            pole |= fmpz_is_zero(b + k);
        }
        if (pole)
            continue;
        homog_eval(r, F, ctx3, a, b, d);
        if (!fmpz_is_zero(r)) {
            result = 0;
            break;
        }
        zeros++;
    }
    fmpz_clear(r);
    for (int k = 0; k < 3; k++) {
        fmpz_clear(a + k);
        fmpz_clear(b + k);
    }
    fmpz_clear(uv);
    fmpz_clear(uv + 1);
    return result;
}

/* The exact check: G(u, v) = F(Xn/Xd, Yn/Yd, Zn/Zd) Xd^dx Yd^dy Zd^dz is the
 * zero polynomial.  (The denominators are nonzero polynomials, so this is
 * F(X, Y, Z) = 0 as a rational function.)  Returns 1 or 0; 0 with *budget_rc
 * set (IMP_EBUDGET, IMP_ENOMEM) when it stopped: the budget is checked after
 * every power of the tables and every term of F, each of which can take
 * seconds on a large F. */
static int vanishes_exact(const imp_param_t *p, const fmpz_mpoly_t F, const fmpz_mpoly_ctx_t ctx3,
                          const slong d[3], const imp_run_t *run, int *budget_rc)
{
    const fmpz_mpoly_ctx_struct *ctx = p->ctx;
    fmpz_mpoly_struct *pw[3][2]; /* pw[k][0][e] = num_k^e, pw[k][1][e] = den_k^e */
    double bytes = 0;
    int ok = 1;
    *budget_rc = 0;
    memset(pw, 0, sizeof pw);
    for (int k = 0; k < 3 && ok; k++)
        for (int s = 0; s < 2 && ok; s++) {
            pw[k][s] = malloc(sizeof(fmpz_mpoly_struct) * (size_t)(d[k] + 1));
            if (pw[k][s] == NULL) {
                ivoct_error_at(run->err, 0, 0, "implicitization by %s: out of memory in the exact check",
                               run->what);
                *budget_rc = IMP_ENOMEM;
                ok = 0;
                break;
            }
            for (slong e = 0; e <= d[k]; e++)
                fmpz_mpoly_init(pw[k][s] + e, ctx);
            const fmpz_mpoly_struct *base = s ? p->den + k : p->num + k;
            fmpz_mpoly_one(pw[k][s], ctx);
            for (slong e = 1; e <= d[k] && ok; e++) {
                fmpz_mpoly_mul(pw[k][s] + e, pw[k][s] + e - 1, base, ctx);
                bytes += imp_poly_bytes(pw[k][s] + e, ctx);
                if ((*budget_rc = imp_run_time(run)) ||
                    (*budget_rc = imp_run_bytes(run, bytes, "the powers of the exact check take")))
                    ok = 0;
            }
        }
    int zero = 0;
    if (ok) {
        fmpz_mpoly_t g, t;
        fmpz_mpoly_init(g, ctx);
        fmpz_mpoly_init(t, ctx);
        for (slong i = 0; i < F->length; i++) {
            ulong e[3];
            fmpz_mpoly_get_term_exp_ui(e, F, i, ctx3);
            fmpz_mpoly_set_fmpz(t, F->coeffs + i, ctx);
            for (int k = 0; k < 3; k++) {
                fmpz_mpoly_mul(t, t, pw[k][0] + e[k], ctx);
                fmpz_mpoly_mul(t, t, pw[k][1] + (d[k] - (slong)e[k]), ctx);
            }
            fmpz_mpoly_add(g, g, t, ctx);
            if ((*budget_rc = imp_run_time(run)) ||
                (*budget_rc = imp_run_bytes(run, bytes + imp_poly_bytes(g, ctx) + imp_poly_bytes(t, ctx),
                                            "the exact check takes")))
                break;
        }
        zero = *budget_rc == 0 && fmpz_mpoly_is_zero(g, ctx);
        fmpz_mpoly_clear(g, ctx);
        fmpz_mpoly_clear(t, ctx);
    }
    for (int k = 0; k < 3; k++)
        for (int s = 0; s < 2; s++) {
            if (pw[k][s] == NULL)
                continue;
            for (slong e = 0; e <= d[k]; e++)
                fmpz_mpoly_clear(pw[k][s] + e, ctx);
            free(pw[k][s]);
        }
    return zero;
}

/* Make F primitive with a positive leading coefficient (lex x > y > z). */
static void normalise(fmpz_mpoly_t F, const fmpz_mpoly_ctx_t ctx3)
{
    if (F->length == 0)
        return;
    fmpz_t g;
    fmpz_init(g);
    _fmpz_vec_content(g, F->coeffs, F->length);
    if (fmpz_sgn(F->coeffs + 0) < 0)
        fmpz_neg(g, g);
    if (!fmpz_is_one(g))
        fmpz_mpoly_scalar_divexact_fmpz(F, F, g, ctx3);
    fmpz_clear(g);
}

/* "(x^2 + 1)^2", "x^3", "y - 1": a removed factor with its multiplicity. */
static char *factor_text(const fmpz_mpoly_t F, const fmpz_mpoly_ctx_t ctx3, const fmpz_t mult)
{
    char *s = imp_text_expanded(F, ctx3);
    if (s == NULL)
        return NULL;
    int paren = F->length > 1 && !fmpz_is_one(mult);
    char m[32] = "";
    if (!fmpz_is_one(mult))
        snprintf(m, sizeof m, "^%ld", fmpz_get_si(mult));
    size_t n = strlen(s) + strlen(m) + 3;
    char *r = malloc(n);
    if (r)
        snprintf(r, n, "%s%s%s%s", paren ? "(" : "", s, paren ? ")" : "", m);
    free(s);
    return r;
}

/* Factor the eliminant E and keep in f the irreducible factor that vanishes
 * on the parametrization; the others go to out->removed. */
static int pick_factor(const imp_param_t *p, const fmpz_mpoly_t E, const fmpz_mpoly_ctx_t ctx3,
                       const imp_run_t *run, fmpz_mpoly_t f, imp_result_t *out)
{
    int rc = imp_run_time(run);
    if (rc)
        return rc;
    fmpz_mpoly_factor_t fac;
    fmpz_mpoly_factor_init(fac, ctx3);
    if (!fmpz_mpoly_factor(fac, E, ctx3)) {
        fmpz_mpoly_factor_clear(fac, ctx3);
        ivoct_error_at(run->err, 0, 0, "implicitization by %s: the eliminant could not be factored",
                       run->what);
        return IMP_EINPUT;
    }
    if ((rc = imp_run_time(run))) {
        fmpz_mpoly_factor_clear(fac, ctx3);
        return rc;
    }
    slong found = -1;
    for (slong i = 0; i < fac->num && found < 0 && rc == 0; i++) {
        const fmpz_mpoly_struct *F = fac->poly + i;
        slong d[3];
        fmpz_mpoly_degrees_si(d, F, ctx3);
        for (int k = 0; k < 3; k++)
            d[k] = d[k] < 0 ? 0 : d[k];
        if (fmpz_mpoly_is_fmpz(F, ctx3) || !vanishes_quick(p, F, ctx3, d))
            continue;
        if (vanishes_exact(p, F, ctx3, d, run, &rc))
            found = i;
    }
    if (rc == 0 && found < 0) {
        ivoct_error_at(run->err, 0, 0,
                       "implicitization by %s: no factor of the eliminant vanishes on the "
                       "parametrization",
                       run->what);
        rc = IMP_EINPUT;
    }
    if (rc == 0) {
        fmpz_mpoly_set(f, fac->poly + found, ctx3);
        normalise(f, ctx3);
        size_t n = (size_t)fac->num - 1;
        out->removed = n ? calloc(n, sizeof *out->removed) : NULL;
        if (n && out->removed == NULL)
            rc = IMP_ENOMEM;
        for (slong i = 0; i < fac->num && rc == 0; i++) {
            if (i == found)
                continue;
            normalise(fac->poly + i, ctx3);
            if ((out->removed[out->n_removed] = factor_text(fac->poly + i, ctx3, fac->exp + i)) == NULL)
                rc = IMP_ENOMEM;
            else
                out->n_removed++;
        }
        if (rc == IMP_ENOMEM)
            ivoct_error_at(run->err, 0, 0, "out of memory while writing the implicit equation");
    }
    fmpz_mpoly_factor_clear(fac, ctx3);
    return rc;
}

/* ---- interface ----------------------------------------------------------------------- */

void imp_result_free(imp_result_t *r)
{
    if (r == NULL)
        return;
    free(r->f);
    free(r->f_tape);
    for (size_t i = 0; i < r->n_removed; i++)
        free(r->removed[i]);
    free(r->removed);
    memset(r, 0, sizeof *r);
}

static int run_method(const imp_param_t *p, imp_method_t m, const imp_run_t *run,
                      const fmpz_mpoly_ctx_t ctx3, fmpz_mpoly_t f, imp_result_t *out)
{
    fmpz_mpoly_t E;
    fmpz_mpoly_init(E, ctx3);
    int rc = m == IMP_GROEBNER ? imp_eliminate_groebner(p, run, E, ctx3)
                               : imp_eliminate_resultant(p, run, E, ctx3);
    if (rc == IMP_OK)
        rc = pick_factor(p, E, ctx3, run, f, out);
    fmpz_mpoly_clear(E, ctx3);
    return rc;
}

int imp_implicitize(const imp_param_t *p, imp_method_t m, const imp_budget_t *budget,
                    imp_result_t *out, ivoct_error_t *err)
{
    ivoct_error_clear(err);
    if (out == NULL) {
        ivoct_error_set(err, "imp_implicitize: no result");
        return IMP_EINPUT;
    }
    memset(out, 0, sizeof *out);
    if (p == NULL || (m != IMP_AUTO && m != IMP_RESULTANT && m != IMP_GROEBNER)) {
        ivoct_error_set(err, "imp_implicitize: no parametrization or an unknown method");
        return IMP_EINPUT;
    }
    double seconds = budget && budget->seconds != 0 ? budget->seconds : IMP_DEFAULT_SECONDS;
    size_t bytes = budget && budget->bytes ? budget->bytes : IMP_DEFAULT_BYTES;
    if (!(seconds > 0) || isinf(seconds)) {
        ivoct_error_set(err, "implicitization budget: seconds must be finite and > 0 (0: the default)");
        return IMP_EINPUT;
    }
    imp_run_t run = {.t0 = imp_now(), .seconds = seconds, .bytes = bytes, .err = err};

    fmpz_mpoly_ctx_t ctx3;
    fmpz_mpoly_ctx_init(ctx3, 3, ORD_LEX);
    fmpz_mpoly_t f;
    fmpz_mpoly_init(f, ctx3);

    imp_method_t tried[2] = {m, m};
    int n_tries = 1;
    if (m == IMP_AUTO) {
        tried[0] = IMP_RESULTANT;
        tried[1] = IMP_GROEBNER;
        n_tries = 2;
    }
    int rc = IMP_EINPUT;
    char first[sizeof err->msg] = "";
    for (int t = 0; t < n_tries; t++) {
        run.what = tried[t] == IMP_GROEBNER ? "Gröbner basis" : "resultants";
        rc = run_method(p, tried[t], &run, ctx3, f, out);
        if (rc == IMP_OK) {
            out->method = tried[t];
            break;
        }
        imp_result_free(out);
        if (rc == IMP_ENOMEM)
            break;
        if (t + 1 < n_tries && err)
            snprintf(first, sizeof first, "%s", err->msg);
    }
    if (rc != IMP_OK && first[0] && err) {
        /* AUTO: say why each method failed */
        char both[sizeof err->msg];
        size_t n = 0;
        const char *parts[3] = {first, "; then ", err->msg};
        for (int k = 0; k < 3; k++)
            for (const char *c = parts[k]; *c && n + 1 < sizeof both; c++)
                both[n++] = *c;
        both[n] = '\0';
        memcpy(err->msg, both, n + 1);
    }
    if (rc == IMP_OK) {
        out->degree = (int)fmpz_mpoly_total_degree_si(f, ctx3);
        out->terms = (long)f->length;
        out->f = imp_text_expanded(f, ctx3);
        out->f_tape = imp_text_horner(f, ctx3);
        if (out->f == NULL || out->f_tape == NULL) {
            ivoct_error_at(err, 0, 0, "out of memory while writing the implicit equation");
            rc = IMP_ENOMEM;
        }
    }
    if (rc == IMP_OK) {
        out->seconds = imp_now() - run.t0;
        ivoct_error_clear(err);
    } else {
        imp_result_free(out); /* zeroed */
    }
    fmpz_mpoly_clear(f, ctx3);
    fmpz_mpoly_ctx_clear(ctx3);
    return rc;
}
