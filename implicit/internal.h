/* ivoct — what the files of implicit/ share (not part of the interface).
 *
 * parse.c    the coordinate texts into exact rational functions of u, v
 * param.c    exact evaluation, interval bounds of a patch, the method names
 * resultant.c elimination by Sylvester resultants
 * groebner.c  elimination by a lex Gröbner basis (our Buchberger loop on
 *             Calcium's S-polynomial and reduction)
 * implicit.c  imp_implicitize: the factor that vanishes on the map, the
 *             budget, the result
 * text.c      polynomials as expression text (expanded and Horner) */
#ifndef IVOCT_IMPLICIT_INTERNAL_H
#define IVOCT_IMPLICIT_INTERNAL_H

#include <flint/fmpz_mpoly.h>

#include "implicit.h"

/* A parsed parametrization: coordinate i is num[i] / den[i] in Z[u, v]
 * (context ctx, lex u > v), reduced (gcd 1, integer content included) with
 * den[i] of positive leading coefficient; num[i] = 0 has den[i] = 1. */
struct imp_param {
    fmpz_mpoly_ctx_t ctx;
    fmpz_mpoly_struct num[3], den[3];
};

/* Variables of the elimination ring Z[w, u, v, x, y, z], lex w > u > v > x > y > z:
 * the order of FLINT's ORD_LEX is the order of the indices. */
enum { V_W, V_U, V_V, V_X, V_Y, V_Z, N_VARS };

/* One implicitization's limits and clock.  `what` names the method in messages
 * ("resultants", "Gröbner basis"). */
typedef struct imp_run {
    double t0;      /* monotonic start of the method's budget */
    double seconds; /* time allowed from t0 */
    size_t bytes;   /* memory allowed for intermediate polynomials */
    const char *what;
    ivoct_error_t *err;
} imp_run_t;

double imp_now(void);

/* IMP_EBUDGET with the message when past the time budget, else 0. */
int imp_run_time(const imp_run_t *run);
/* IMP_EBUDGET with the message when `live` bytes are past the memory budget,
 * else 0.  `detail` says what they are, with its verb: "the basis takes". */
int imp_run_bytes(const imp_run_t *run, double live, const char *detail);

/* The memory measure of the budget: terms x (coefficient limbs + exponent
 * words) x 8 bytes, the coefficient limbs of the largest coefficient. */
double imp_poly_bytes(const fmpz_mpoly_t a, const fmpz_mpoly_ctx_t ctx);

/* Copy a polynomial between contexts: variable i of `src` becomes variable
 * map[i] of `dst` (each variable of src that occurs must be mapped, >= 0). */
void imp_move_vars(fmpz_mpoly_t dst, const fmpz_mpoly_ctx_t dctx, const fmpz_mpoly_t src,
                   const fmpz_mpoly_ctx_t sctx, const int *map);

/* Numerators of d(n/d)/du and d(n/d)/dv: n_u d - n d_u and n_v d - n d_v (the
 * derivatives are these over d^2) (parse.c). */
void imp_partials(const fmpz_mpoly_t n, const fmpz_mpoly_t d, const fmpz_mpoly_ctx_t ctx,
                  fmpz_mpoly_t du, fmpz_mpoly_t dv);

/* The polynomials den_i * t_i - num_i, t = x, y, z, of the elimination ring. */
void imp_graph_polys(const imp_param_t *p, const fmpz_mpoly_ctx_t ctx6, fmpz_mpoly_struct P[3]);

/* Eliminate u and v: on success (IMP_OK) E holds a nonzero polynomial of
 * Z[x, y, z] (the ring ctx3, lex x > y > z) that vanishes on the image.
 * IMP_EINPUT when the method finds none (err says why), IMP_EBUDGET. */
int imp_eliminate_resultant(const imp_param_t *p, const imp_run_t *run, fmpz_mpoly_t E,
                            const fmpz_mpoly_ctx_t ctx3);
int imp_eliminate_groebner(const imp_param_t *p, const imp_run_t *run, fmpz_mpoly_t E,
                           const fmpz_mpoly_ctx_t ctx3);

/* Text (malloc'd, NULL when out of memory) of a polynomial of ctx3 with the
 * names x, y, z: expanded ("x^2 + y^2 + z^2 - 1"), and nested (Horner) in z,
 * then y, then x, for tape_compile.  The Horner text falls back to the
 * expanded one when its parentheses would nest deeper than IMP_TAPE_NESTING. */
char *imp_text_expanded(const fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx3);
char *imp_text_horner(const fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx3);
#define IMP_TAPE_NESTING 500

#endif
