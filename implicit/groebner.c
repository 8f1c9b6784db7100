/* ivoct — elimination by a lex Gröbner basis.
 *
 * The ideal of the graph: P_i = den_i t_i - num_i (t = x, y, z) and, when a
 * denominator is not constant, 1 - w s with s the squarefree part of the
 * product of the denominators.  The generator in w saturates the ideal by s:
 * it removes the components where a denominator vanishes (there the P_i say
 * nothing about x, y, z), so what is left is exactly the closure of the
 * graph, a prime ideal (its quotient ring is Q[u, v][1/s]).  Saturation by s
 * depends only on the zero set of s, so its squarefree part does as well as
 * the product itself, with smaller degrees.  In the lex order
 * w > u > v > x > y > z the elements of a Gröbner basis free of w, u and v
 * generate the elimination ideal, the ideal of the closure of the image: for
 * a surface, one principal ideal (f), so one element.
 *
 * The loop is Buchberger's algorithm, written here so that the budget is
 * checked between reductions (Calcium's fmpz_mpoly_buchberger_naive has
 * limits on lengths and bits, not on time): Calcium supplies the
 * S-polynomial and the reduction to a primitive remainder.  On top:
 *  - the pair criteria of Gebauer and Möller, which drop most pairs whose
 *    S-polynomial would reduce to 0 without reducing it;
 *  - the sugar strategy (the pair of least "sugar", the degree the
 *    S-polynomial would have with the inputs homogenised): lex orders are
 *    not degree compatible, and choosing by the lcm alone lets the degrees
 *    of the basis run away (the Roman surface: unfinished after 20 s instead
 *    of 3 ms);
 *  - reduction by every element found, redundant ones included: they keep
 *    the remainders short (the Roman surface again: unfinished after 20 s
 *    with the minimal basis alone).
 * The basis is then autoreduced (Calcium) and its elements in x, y, z read. */
#include <stdlib.h>
#include <string.h>

#include <calcium/utils_flint.h>
#include <flint/fmpz_mpoly_factor.h>

#include "internal.h"

typedef struct pair {
    slong a, b;
    ulong lcm[N_VARS];
    slong sugar, deg;
} gb_pair_t;

typedef struct basis {
    fmpz_mpoly_vec_t G;
    ulong (*lm)[N_VARS]; /* leading monomials */
    slong *sugar;
    char *redundant;     /* lm divisible by a later element's lm */
    slong cap;
    gb_pair_t *pairs;
    slong n_pairs, cap_pairs;
    double bytes;        /* sum of the memory measure over G */
} basis_t;

static slong lm_deg(const ulong *e)
{
    slong s = 0;
    for (int i = 0; i < N_VARS; i++)
        s += (slong)e[i];
    return s;
}

static int lm_divides(const ulong *a, const ulong *b)
{
    for (int i = 0; i < N_VARS; i++)
        if (a[i] > b[i])
            return 0;
    return 1;
}

static int lm_equal(const ulong *a, const ulong *b) { return memcmp(a, b, sizeof(ulong) * N_VARS) == 0; }

static int lm_coprime(const ulong *a, const ulong *b)
{
    for (int i = 0; i < N_VARS; i++)
        if (a[i] && b[i])
            return 0;
    return 1;
}

static void lm_lcm(ulong *r, const ulong *a, const ulong *b)
{
    for (int i = 0; i < N_VARS; i++)
        r[i] = a[i] > b[i] ? a[i] : b[i];
}

/* lex comparison of exponent vectors, w first */
static int lm_cmp(const ulong *a, const ulong *b)
{
    for (int i = 0; i < N_VARS; i++)
        if (a[i] != b[i])
            return a[i] < b[i] ? -1 : 1;
    return 0;
}

/* The pair to reduce next: least sugar, then least lcm. */
static slong select_pair(const basis_t *B)
{
    slong best = 0;
    for (slong k = 1; k < B->n_pairs; k++) {
        const gb_pair_t *x = B->pairs + k, *y = B->pairs + best;
        if (x->sugar < y->sugar || (x->sugar == y->sugar && lm_cmp(x->lcm, y->lcm) < 0))
            best = k;
    }
    return best;
}

static int grow(basis_t *B, const fmpz_mpoly_ctx_t ctx)
{
    (void)ctx;
    if (B->G->length < B->cap)
        return 0;
    slong cap = B->cap ? 2 * B->cap : 16;
    void *lm = realloc(B->lm, sizeof *B->lm * (size_t)cap);
    if (lm)
        B->lm = lm;
    void *sg = realloc(B->sugar, sizeof *B->sugar * (size_t)cap);
    if (sg)
        B->sugar = sg;
    void *rd = realloc(B->redundant, (size_t)cap);
    if (rd)
        B->redundant = rd;
    if (!lm || !sg || !rd)
        return -1;
    B->cap = cap;
    return 0;
}

static int push_pair(basis_t *B, const gb_pair_t *p)
{
    if (B->n_pairs == B->cap_pairs) {
        slong cap = B->cap_pairs ? 2 * B->cap_pairs : 64;
        gb_pair_t *t = realloc(B->pairs, sizeof *t * (size_t)cap);
        if (t == NULL)
            return -1;
        B->pairs = t;
        B->cap_pairs = cap;
    }
    B->pairs[B->n_pairs++] = *p;
    return 0;
}

/* Add h (nonzero, primitive) of sugar s to the basis and update the pairs
 * (Gebauer–Möller).  Returns 0 or -1 (out of memory). */
static int add_element(basis_t *B, const fmpz_mpoly_t h, slong s, const fmpz_mpoly_ctx_t ctx)
{
    if (grow(B, ctx))
        return -1;
    slong t = B->G->length;
    fmpz_mpoly_vec_append(B->G, h, ctx);
    B->bytes += imp_poly_bytes(h, ctx);
    ulong *H = B->lm[t];
    fmpz_mpoly_get_term_exp_ui(H, h, 0, ctx);
    B->sugar[t] = s;
    B->redundant[t] = 0;

    /* candidate pairs (i, t) */
    gb_pair_t *C = malloc(sizeof *C * (size_t)(t + 1));
    char *drop = calloc((size_t)t + 1, 1);
    if (C == NULL || drop == NULL) {
        free(C);
        free(drop);
        return -1;
    }
    slong nc = 0;
    for (slong i = 0; i < t; i++) {
        if (B->redundant[i])
            continue;
        gb_pair_t *c = C + nc++;
        c->a = i;
        c->b = t;
        lm_lcm(c->lcm, B->lm[i], H);
        c->deg = lm_deg(c->lcm);
        slong si = B->sugar[i] - lm_deg(B->lm[i]), st = s - lm_deg(H);
        c->sugar = (si > st ? si : st) + c->deg;
    }
    /* M: (i, t) goes when some lcm(j, t) properly divides lcm(i, t) */
    for (slong i = 0; i < nc; i++)
        for (slong j = 0; j < nc; j++)
            if (j != i && lm_divides(C[j].lcm, C[i].lcm) && !lm_equal(C[j].lcm, C[i].lcm)) {
                drop[i] = 1;
                break;
            }
    /* F and the product criterion: of the pairs with one lcm keep at most one,
     * none when one of them has coprime leading monomials (it reduces to 0,
     * and so do the others, by the chain through it) */
    for (slong i = 0; i < nc; i++) {
        if (drop[i])
            continue;
        int coprime = lm_coprime(B->lm[C[i].a], H);
        for (slong j = i + 1; j < nc; j++)
            if (!drop[j] && lm_equal(C[i].lcm, C[j].lcm)) {
                coprime |= lm_coprime(B->lm[C[j].a], H);
                drop[j] = 1;
            }
        if (coprime)
            drop[i] = 1;
    }
    /* B: an old pair (i, j) goes when lm(h) divides its lcm and lcm(i, t),
     * lcm(j, t) are both different from it */
    slong k2 = 0;
    for (slong k = 0; k < B->n_pairs; k++) {
        gb_pair_t *o = B->pairs + k;
        ulong li[N_VARS], lj[N_VARS];
        lm_lcm(li, B->lm[o->a], H);
        lm_lcm(lj, B->lm[o->b], H);
        if (lm_divides(H, o->lcm) && !lm_equal(li, o->lcm) && !lm_equal(lj, o->lcm))
            continue;
        B->pairs[k2++] = *o;
    }
    B->n_pairs = k2;
    int rc = 0;
    for (slong i = 0; i < nc && rc == 0; i++)
        if (!drop[i])
            rc = push_pair(B, C + i);
    free(C);
    free(drop);
    for (slong i = 0; i < t; i++)
        if (!B->redundant[i] && lm_divides(H, B->lm[i]))
            B->redundant[i] = 1;
    return rc;
}

/* The squarefree part of the product of the non-constant denominators, in
 * the elimination ring (1 when there is none). */
static void saturating_poly(const imp_param_t *p, const fmpz_mpoly_ctx_t ctx, fmpz_mpoly_t s)
{
    static const int uv[2] = {V_U, V_V};
    fmpz_mpoly_t d;
    fmpz_mpoly_init(d, p->ctx);
    fmpz_mpoly_one(d, p->ctx);
    for (int i = 0; i < 3; i++)
        if (!fmpz_mpoly_is_fmpz(p->den + i, p->ctx))
            fmpz_mpoly_mul(d, d, p->den + i, p->ctx);
    fmpz_mpoly_factor_t fac;
    fmpz_mpoly_factor_init(fac, p->ctx);
    fmpz_mpoly_t r;
    fmpz_mpoly_init(r, p->ctx);
    fmpz_mpoly_one(r, p->ctx);
    if (!fmpz_mpoly_is_fmpz(d, p->ctx) && fmpz_mpoly_factor_squarefree(fac, d, p->ctx))
        for (slong i = 0; i < fac->num; i++)
            fmpz_mpoly_mul(r, r, fac->poly + i, p->ctx);
    else
        fmpz_mpoly_set(r, d, p->ctx); /* constant, or (never seen) no squarefree split */
    if (fmpz_mpoly_is_fmpz(r, p->ctx))
        fmpz_mpoly_one(r, p->ctx);
    imp_move_vars(s, ctx, r, p->ctx, uv);
    fmpz_mpoly_clear(r, p->ctx);
    fmpz_mpoly_factor_clear(fac, p->ctx);
    fmpz_mpoly_clear(d, p->ctx);
}

int imp_eliminate_groebner(const imp_param_t *p, const imp_run_t *run, fmpz_mpoly_t E,
                           const fmpz_mpoly_ctx_t ctx3)
{
    static const int to_xyz[N_VARS] = {-1, -1, -1, 0, 1, 2};
    fmpz_mpoly_ctx_t ctx;
    fmpz_mpoly_ctx_init(ctx, N_VARS, ORD_LEX);
    basis_t B;
    memset(&B, 0, sizeof B);
    fmpz_mpoly_vec_init(B.G, 0, ctx);
    fmpz_mpoly_t h, s, gens[4];
    fmpz_mpoly_init(h, ctx);
    fmpz_mpoly_init(s, ctx);
    for (int i = 0; i < 4; i++)
        fmpz_mpoly_init(gens[i], ctx);
    fmpz_mpoly_struct P[3];
    for (int i = 0; i < 3; i++)
        fmpz_mpoly_init(P + i, ctx);
    imp_graph_polys(p, ctx, P);
    int ngens = 3;
    for (int i = 0; i < 3; i++)
        fmpz_mpoly_set(gens[i], P + i, ctx);
    saturating_poly(p, ctx, s);
    if (!fmpz_mpoly_is_one(s, ctx)) {
        fmpz_mpoly_gen(h, V_W, ctx); /* 1 - w s */
        fmpz_mpoly_mul(h, h, s, ctx);
        fmpz_mpoly_neg(h, h, ctx);
        fmpz_mpoly_add_ui(gens[3], h, 1, ctx);
        ngens = 4;
    }

    int rc = 0;
    for (int i = 0; i < ngens && rc == 0; i++) {
        fmpz_mpoly_primitive_part(h, gens[i], ctx);
        if (add_element(&B, h, fmpz_mpoly_total_degree_si(h, ctx), ctx))
            rc = IMP_ENOMEM;
    }
    fmpz_mpoly_t sp;
    fmpz_mpoly_init(sp, ctx);
    while (rc == 0 && B.n_pairs > 0) {
        if ((rc = imp_run_time(run)))
            break;
        slong k = select_pair(&B);
        gb_pair_t pr = B.pairs[k];
        B.pairs[k] = B.pairs[--B.n_pairs];
        fmpz_mpoly_spoly(sp, B.G->p + pr.a, B.G->p + pr.b, ctx);
        fmpz_mpoly_reduction_primitive_part(h, sp, B.G, ctx);
        if ((rc = imp_run_bytes(run, B.bytes + imp_poly_bytes(sp, ctx) + imp_poly_bytes(h, ctx),
                                "the basis and the S-polynomial take")))
            break;
        if (!fmpz_mpoly_is_zero(h, ctx) && add_element(&B, h, pr.sugar, ctx))
            rc = IMP_ENOMEM;
    }
    fmpz_mpoly_clear(sp, ctx);
    if (rc == IMP_ENOMEM)
        ivoct_error_at(run->err, 0, 0, "out of memory in the Gröbner basis");

    if (rc == 0 && !(rc = imp_run_time(run))) {
        /* the minimal basis, autoreduced */
        fmpz_mpoly_vec_t M, H;
        fmpz_mpoly_vec_init(M, 0, ctx);
        fmpz_mpoly_vec_init(H, 0, ctx);
        for (slong i = 0; i < B.G->length; i++)
            if (!B.redundant[i])
                fmpz_mpoly_vec_append(M, B.G->p + i, ctx);
        fmpz_mpoly_vec_autoreduction_groebner(H, M, ctx);
        slong found = -1, n_elim = 0;
        for (slong i = 0; i < H->length; i++) {
            const fmpz_mpoly_struct *g = H->p + i;
            if (fmpz_mpoly_degree_si(g, V_W, ctx) <= 0 && fmpz_mpoly_degree_si(g, V_U, ctx) <= 0 &&
                fmpz_mpoly_degree_si(g, V_V, ctx) <= 0 && !fmpz_mpoly_is_fmpz(g, ctx)) {
                found = i;
                n_elim++;
            }
        }
        if (n_elim == 1)
            imp_move_vars(E, ctx3, H->p + found, ctx, to_xyz);
        else {
            /* not for a parsed map (its image is a surface): kept as a check */
            ivoct_error_at(run->err, 0, 0,
                           n_elim ? "implicitization by Gröbner basis: %ld independent equations "
                                    "in x, y, z: the image is a curve, not a surface"
                                  : "implicitization by Gröbner basis: %ld equations in x, y, z: "
                                    "the image is not a surface",
                           (long)n_elim);
            rc = IMP_EINPUT;
        }
        if (rc == 0)
            rc = imp_run_time(run);
        fmpz_mpoly_vec_clear(M, ctx);
        fmpz_mpoly_vec_clear(H, ctx);
    }

    free(B.lm);
    free(B.sugar);
    free(B.redundant);
    free(B.pairs);
    fmpz_mpoly_vec_clear(B.G, ctx);
    for (int i = 0; i < 3; i++)
        fmpz_mpoly_clear(P + i, ctx);
    for (int i = 0; i < 4; i++)
        fmpz_mpoly_clear(gens[i], ctx);
    fmpz_mpoly_clear(h, ctx);
    fmpz_mpoly_clear(s, ctx);
    fmpz_mpoly_ctx_clear(ctx);
    return rc;
}
