/* ivoct — implicitization of parametric surfaces (prefix imp_).
 *
 * A parametrization x = X(u,v), y = Y(u,v), z = Z(u,v), each coordinate a
 * polynomial or a quotient of polynomials in u and v with exact rational
 * coefficients, is turned into the implicit equation f(x,y,z) = 0 of the
 * surface it traces: f has integer coefficients, is irreducible over Q and
 * vanishes identically on the parametrization (f(X(u,v), Y(u,v), Z(u,v)) = 0
 * as a rational function, checked exactly before it is returned).  The
 * arithmetic is FLINT's (fmpz_mpoly, exact; factoring and gcd too); the
 * resultants (subresultant sequence) and the Buchberger loop are this
 * module's, the latter on Calcium's S-polynomial and reduction primitives.
 * implicit/README.md explains the methods.
 *
 * Nothing here prints, exits or aborts; every failure is a status and an
 * ivoct_error_t.
 */
#ifndef IVOCT_IMPLICIT_H
#define IVOCT_IMPLICIT_H

#include <stddef.h>

#include <gmp.h>

#include "../expr/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Status codes. */
enum {
    IMP_OK = 0,
    IMP_EINPUT = 1,  /* the parametrization is not valid input: syntax, a transcendental
                        function, a map whose image is not a surface (constant, a curve),
                        a denominator that is identically 0 */
    IMP_EBUDGET = 2, /* the method exceeded its time or memory budget */
    IMP_ENOMEM = 3   /* out of memory */
};

/* ---- parametrizations ---------------------------------------------------------
 * Grammar of each coordinate text (a subset of the expression grammar of
 * docs/scene-format.md): numbers (decimal literals, read as exact rationals:
 * 0.1 = 1/10, 1e-3 = 1/1000), the variables u and v, + - * / (a quotient of
 * polynomials), ^ with an integer exponent (negative allowed on a nonzero
 * base), unary minus, parentheses.  Blanks and newlines are ignored.  A
 * function call (sin, sqrt, exp, ...), x, y, z, pi, e or any other name is an
 * error that says why (a parametrization is exact and rational). */
typedef struct imp_param imp_param_t;

/* Limits of a parametrization, each an IMP_EINPUT with a position past it:
 * a coordinate text of more than IMP_MAX_TEXT bytes, parentheses, signs and
 * '^' nested deeper than IMP_MAX_NESTING, and any numerator or denominator met
 * while parsing (the products and powers are predicted before they are
 * computed) of total degree above IMP_MAX_DEGREE or with coefficients of more
 * than IMP_MAX_BITS bits.  Implicitization is hopeless long before these. */
#define IMP_MAX_TEXT (1u << 20)
#define IMP_MAX_NESTING 1000
#define IMP_MAX_DEGREE 64
#define IMP_MAX_BITS 16384

/* Parse the three coordinate texts.  On error returns IMP_EINPUT (or
 * IMP_ENOMEM), sets *which to the coordinate (0, 1, 2) and err's line and
 * column inside that text (1-based; line 0 when the error has no position).
 * The map as a whole is checked here too, exactly (the rank of its Jacobian
 * matrix as rational functions): a constant map (image a point) and a map
 * whose image is a curve (X = u + v, Y = (u+v)^2, Z = (u+v)^3; or coordinates
 * that depend on u only) are IMP_EINPUT with line 0 and *which = 0.  So every
 * parsed parametrization traces a surface. */
int imp_param_parse(const char *const text[3], imp_param_t **out, int *which,
                    ivoct_error_t *err);
void imp_param_free(imp_param_t *p);

/* The exact point of parameters (u, v): xyz[i] = coordinate i.  Returns 0, or
 * -1 (xyz unchanged) when a denominator vanishes there. */
int imp_param_eval(const imp_param_t *p, const mpq_t u, const mpq_t v, mpq_t xyz[3]);

/* A box that holds every point of the patch u in [u0, u1], v in [v0, v1]
 * (rigorous: interval arithmetic over a subdivision of the patch, outward
 * rounded), xmin xmax ymin ymax zmin zmax.  Returns 0, or IMP_EINPUT with err
 * set when a denominator may vanish on the patch (a pole: give a box). */
int imp_param_bounds(const imp_param_t *p, const double u[2], const double v[2], double box[6],
                     ivoct_error_t *err);

/* ---- implicitization -------------------------------------------------------------- */

typedef enum imp_method {
    IMP_AUTO,      /* resultants, then the Gröbner basis if they fail */
    IMP_RESULTANT, /* eliminate u, then v, by Sylvester resultants */
    IMP_GROEBNER   /* lex Gröbner basis (w > u > v > x > y > z), the elements free of w, u, v */
} imp_method_t;

/* "auto", "resultant", "groebner"; imp_method_parse returns 0, or -1 for an
 * unknown name. */
const char *imp_method_name(imp_method_t m);
int imp_method_parse(const char *name, imp_method_t *m);

/* Limits of one implicitization.  Time is wall-clock, checked between the
 * steps of a method (inside a resultant after each elimination of a leading
 * term; one S-polynomial reduction; the factorization of the eliminant): a
 * step that has begun runs to its end.  Memory bounds the intermediate
 * polynomials (their terms times their coefficients' size, and a bound on a
 * resultant's terms before it is computed).  0: the default; seconds must
 * otherwise be finite and > 0 (else IMP_EINPUT). */
typedef struct imp_budget {
    double seconds; /* default IMP_DEFAULT_SECONDS */
    size_t bytes;   /* default IMP_DEFAULT_BYTES */
} imp_budget_t;
#define IMP_DEFAULT_SECONDS 60.0
#define IMP_DEFAULT_BYTES ((size_t)1 << 30)

typedef struct imp_result {
    imp_method_t method; /* the method that gave f (never IMP_AUTO) */
    double seconds;      /* wall-clock time of the implicitization */
    int degree;          /* total degree of f */
    long terms;          /* number of terms of f */
    char *f;             /* f expanded, integer coefficients, primitive, positive leading
                            coefficient: "x^2 + y^2 + z^2 - 1" (expression grammar) */
    char *f_tape;        /* the same polynomial as an expression for tape_compile, nested
                            (Horner) in z, then y, then x: fewer operations ("(y^2 +
                            x^2)*z - 2*x*y"); the expanded text when the nesting would
                            pass 500 parentheses */
    size_t n_removed;    /* factors of the eliminant that do not vanish on the
                            parametrization (base points, denominators), removed */
    char **removed;      /* each as text with its multiplicity: "(x^2 + 1)^2", "y^6",
                            "x - 1" (the Gröbner basis removes none) */
} imp_result_t;

/* Implicitize p with method m within budget (NULL: the defaults).  Returns
 * IMP_OK with *out filled (free with imp_result_free), or IMP_EINPUT (the image
 * is not a surface), IMP_EBUDGET or IMP_ENOMEM with err set and *out zeroed.
 * With IMP_AUTO a budget failure of the resultants falls back to the Gröbner
 * basis, within what remains of the same budget. */
int imp_implicitize(const imp_param_t *p, imp_method_t m, const imp_budget_t *budget,
                    imp_result_t *out, ivoct_error_t *err);
void imp_result_free(imp_result_t *r);

#ifdef __cplusplus
}
#endif
#endif
