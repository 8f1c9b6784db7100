/* ivoct — modal intervals, Kaucher arithmetic and the semantic extensions of a
 * tape (prefix mod_).  The theory is in modal/README.md; in short:
 *
 * A modal interval [a, b] is a pair of reals read with a quantifier: proper
 * (a <= b) is "some x in [a, b]" (existential), improper (a > b) is "every x
 * in [b, a]" (universal); a point [a, a] is both.  Its set Set([a, b]) is
 * [min(a, b), max(a, b)].  The modal inclusion A ⊆ B is B.lo <= A.lo and
 * A.hi <= B.hi (on proper intervals, the inclusion of sets).
 *
 * Conventions:
 *  - mod_t is {lo, hi}; lo > hi is improper, lo <= hi proper; bounds finite in
 *    operands (a result may have an infinite bound after an overflow, still
 *    rounded in the right direction);
 *  - an operation undefined on its operands (a division by an interval whose
 *    set holds 0, sqrt of an interval whose set holds a negative number, ...)
 *    returns {NaN, NaN}, and every operation maps a NaN operand to NaN;
 *  - the rounding of an operation is given by mod_round_t.  MOD_OUTER rounds
 *    each bound so that the result R~ contains the exact result R in the
 *    modal order, R ⊆ R~ (lo rounded down, hi rounded up, whatever the
 *    modality); MOD_INNER so that R~ ⊆ R (lo rounded up, hi rounded down).
 *    Every Kaucher operation is isotone in the modal order (A ⊆ A', B ⊆ B'
 *    gives A∘B ⊆ A'∘B'), so a computation made of outer-rounded operations is
 *    contained in (holds) the exact one, and one made of inner-rounded
 *    operations is contained in it: the first is what an outer claim
 *    f*(X) ⊆ R needs, the second what an inner claim R ⊆ f**(X) needs.
 *    Rounding uses expr/interval.h: iv_down / iv_up for + - * /, the
 *    rigorous point enclosures iv_sqrt, iv_exp ... for the functions.  Exact
 *    zeros stay exact (a product with a zero factor, a sum with a zero term),
 *    everything else is widened by the helpers, so an inner result of a
 *    computation on points is usually improper (nothing certified) even where
 *    the exact value is a representable double.
 *  - the FPU rounding mode is never changed; nothing prints, exits, or
 *    allocates except the tape functions (which return MOD_ENOMEM).
 */
#ifndef IVOCT_MODAL_H
#define IVOCT_MODAL_H

#include <stdbool.h>
#include <stdint.h>

#include "../expr/interval.h"
#include "../expr/tape.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mod {
    double lo, hi;
} mod_t;

typedef enum mod_round {
    MOD_OUTER = 0, /* result ⊇ exact result (modal order) */
    MOD_INNER = 1  /* result ⊆ exact result (modal order) */
} mod_round_t;

/* ---- construction, queries, lattice ------------------------------------------
 * All exact (no rounding).  NaN operands give NaN / false. */
static inline mod_t mod_make(double lo, double hi) { mod_t r = {lo, hi}; return r; }
static inline mod_t mod_point(double x) { mod_t r = {x, x}; return r; }
static inline mod_t mod_from_iv(iv_t a) { mod_t r = {a.lo, a.hi}; return r; }
/* true when undefined (a NaN bound) */
static inline bool mod_is_nan(mod_t a) { return (a.lo != a.lo) | (a.hi != a.hi); }
/* a.lo <= a.hi (points are proper) */
static inline bool mod_is_proper(mod_t a) { return a.lo <= a.hi; }
/* a.lo >= a.hi (points are improper) */
static inline bool mod_is_improper(mod_t a) { return a.lo >= a.hi; }
static inline bool mod_is_point(mod_t a) { return a.lo == a.hi; }
/* Dual [a, b] = [b, a]: the same set, the other quantifier. */
static inline mod_t mod_dual(mod_t a) { mod_t r = {a.hi, a.lo}; return r; }
/* prop: the proper interval of the same set; impr: the improper one. */
mod_t mod_prop(mod_t a);
mod_t mod_impr(mod_t a);
/* Set(a) as an ordinary interval [min, max]. */
iv_t mod_set(mod_t a);
/* Modal inclusion a ⊆ b: b.lo <= a.lo and a.hi <= b.hi.  For proper a, b it is
 * set inclusion; for improper ones the reverse inclusion of the sets; an
 * improper a is included in a proper b exactly when their sets intersect. */
bool mod_subset(mod_t a, mod_t b);
/* The lattice of the modal order: meet (greatest lower bound) is
 * [max(a.lo, b.lo), min(a.hi, b.hi)], join (least upper bound) is
 * [min(a.lo, b.lo), max(a.hi, b.hi)]; both are always defined (the meet of
 * two proper intervals with disjoint sets is improper). */
mod_t mod_meet(mod_t a, mod_t b);
mod_t mod_join(mod_t a, mod_t b);

/* ---- Kaucher arithmetic ---------------------------------------------------------
 * Each returns the Kaucher operation, rounded per r (see above); the exact
 * operation is the semantic extension of x∘y (each variable once, so
 * f* = f**: the result Z satisfies, for A, B proper, Z = {x∘y}; in general
 * Z = [min_{xp} max_{xi} x∘y, max_{xp} min_{xi} x∘y], xp ranging over the
 * sets of the proper operands, xi over those of the improper ones).
 *  add: [a1 + b1, a2 + b2]; sub: [a1 - b2, a2 - b1]; neg: [-a2, -a1] (exact);
 *  mul: Kaucher's table (modal/README.md) on the classes P (a1, a2 >= 0),
 *       -P (a1, a2 <= 0), Z (a1 < 0 < a2), Dual Z (a1 > 0 > a2);
 *  div: A * [1/b2, 1/b1], with the quotients a_i / b_j rounded once;
 *       NaN when 0 ∈ Set(B). */
mod_t mod_neg(mod_t a);
mod_t mod_add(mod_t a, mod_t b, mod_round_t r);
mod_t mod_sub(mod_t a, mod_t b, mod_round_t r);
mod_t mod_mul(mod_t a, mod_t b, mod_round_t r);
mod_t mod_div(mod_t a, mod_t b, mod_round_t r);

/* ---- continuous functions of one variable ----------------------------------------
 * The modal extension of a continuous phi on Set(A): [min phi, max phi] over
 * Set(A) for A proper, [max phi, min phi] for A improper (uni-incident, so
 * f* = f**), rounded per r.  NaN where phi is not defined and continuous on
 * the whole of Set(A), and (sin, cos, tan) where phi cannot be proved
 * monotone on Set(A) (their interior extrema are irrational points, so they
 * are only computed on monotone pieces).
 *  sqr, powi (any int n; n <= 0 needs 0 ∉ Set(A); n = 0 gives [1, 1]),
 *  powr (real r, not an integer: r > 0 needs Set(A) ⊆ [0, inf), r < 0 needs
 *  Set(A) ⊆ (0, inf)), sqrt ([0, inf)), exp, log ((0, inf)), atan,
 *  sin and cos (where monotone), tan (no pole in Set(A)). */
mod_t mod_sqr(mod_t a, mod_round_t r);
mod_t mod_powi(mod_t a, int n, mod_round_t r);
mod_t mod_powr(mod_t a, double e, mod_round_t r);
mod_t mod_sqrt(mod_t a, mod_round_t r);
mod_t mod_exp(mod_t a, mod_round_t r);
mod_t mod_log(mod_t a, mod_round_t r);
mod_t mod_atan(mod_t a, mod_round_t r);
mod_t mod_sin(mod_t a, mod_round_t r);
mod_t mod_cos(mod_t a, mod_round_t r);
mod_t mod_tan(mod_t a, mod_round_t r);

/* ---- the semantic extensions of a tape ------------------------------------------
 * For f the function of a tape and X = (X, Y, Z) a modal box (variables with
 * a proper component are existential, improper ones universal; X'p the sets
 * of the proper components, X'i those of the improper ones):
 *   f*(X)  = [min_{xp} max_{xi} f, max_{xp} min_{xi} f],
 *   f**(X) = [max_{xi} min_{xp} f, min_{xi} max_{xp} f],
 * and by the semantic theorems, for any modal interval R:
 *   f*(X) ⊆ R   <=>  ∀xp ∈ X'p  Q(z, R) z ∈ Set(R)  ∃xi ∈ X'i  z = f(xp, xi),
 *   R ⊆ f**(X)  <=>  ∀xi ∈ X'i  Q(z, Dual R) z ∈ Set(R)  ∃xp ∈ X'p  z = f(xp, xi),
 * Q(z, R) being ∃ for R proper and ∀ for R improper.  With all components
 * proper, f* = f** = the range of f over the box; R ⊆ f**(X) with R proper
 * says every value of R is attained by f in the box (an inner estimate).
 *
 * Status of the tape functions: MOD_OK when the documented claim holds; any
 * other status claims nothing (out is then {NaN, NaN}). */
typedef enum mod_status {
    MOD_OK = 0,
    MOD_NOT_INTERPRETABLE, /* a variable occurs more than once with the wrong
                            * modality, and f cannot be proved monotone in it */
    MOD_UNSUPPORTED,       /* the tape has an operation outside the supported set:
                            * min, max, abs (and any op unknown to this module) */
    MOD_DOMAIN,            /* f is not proved defined and continuous on the box,
                            * or sin/cos/tan not proved monotone where needed */
    MOD_OVERFLOW,          /* a non-finite bound appeared in the computation */
    MOD_NO_INNER,          /* mod_inner_range: the inner estimate is improper */
    MOD_EINVAL,            /* a non-finite box bound, or a NULL argument */
    MOD_ENOMEM
} mod_status_t;

/* A name for a status ("ok", "not interpretable", ...). */
const char *mod_status_name(mod_status_t s);

/* How the extension treated each variable. */
typedef enum mod_var_use {
    MOD_VAR_ABSENT = 0, /* f does not use it */
    MOD_VAR_ONCE,       /* used once along the DAG (uni-incident): optimal as given */
    MOD_VAR_POINT,      /* a degenerate component (a point): both modalities */
    MOD_VAR_MULTI,      /* multi-incident with the modality the claim allows */
    MOD_VAR_MONOTONE,   /* multi-incident, f monotone in it over the box: the
                         * lower bound is computed with it at one end, the upper
                         * with it at the other (the modal endpoint rule) */
    MOD_VAR_DUALISED,   /* mod_inner_range: multi-incident, not monotone, made
                         * universal (improper) so that the claim is interpretable */
    MOD_VAR_BLOCKING    /* multi-incident, wrong modality, not monotone: the cause
                         * of MOD_NOT_INTERPRETABLE */
} mod_var_use_t;

typedef struct mod_info {
    uint64_t incidence[3]; /* uses of x, y, z: the number of paths from the variable's
                            * leaf to the result in the DAG (saturates at UINT64_MAX) */
    int monotone[3];       /* +1 f nondecreasing in it over Set(X), -1 nonincreasing,
                            * 0 not proved (or not looked at) */
    mod_var_use_t use[3];
    int passes;            /* evaluations of the modal rational extension made (1 or 2) */
} mod_info_t;

/* Number of uses of x, y, z along the DAG of t (paths from each variable's leaf
 * to the result; a shared subexpression used twice counts twice).  A variable
 * used at most once is uni-incident.  An empty or NULL tape has none.  No allocation when t->n <= 1024,
 * otherwise a malloc (returns -1 when it fails, else 0). */
int mod_incidences(const tape_t *t, uint64_t inc[3]);

/* Does the module support every operation of t (see the functions above; not
 * min, max, abs)?  Whether they are defined over a given box is separate. */
bool mod_tape_supported(const tape_t *t);

/* The modal rational extension fR(X) of the tape: each operation replaced by
 * its modal extension (Kaucher arithmetic, the functions above), rounded per
 * r, with the tape's interval constants C taken as C for MOD_OUTER and as
 * Dual C for MOD_INNER (Dual C ⊆ [c, c] ⊆ C for every c in C, so the claim
 * holds for the exact constant).  Claims only the rounding: MOD_OUTER gives
 * out ⊇ fR(X) and MOD_INNER out ⊆ fR(X), fR computed exactly with the exact
 * constants; what fR(X) means about f is the business of mod_star and
 * mod_dstar.  Status MOD_OK, MOD_UNSUPPORTED, MOD_DOMAIN (an operation NaN on
 * its modal operands), MOD_OVERFLOW, MOD_EINVAL, MOD_ENOMEM. */
mod_status_t mod_tape_eval(const tape_t *t, const mod_t X[3], mod_round_t r, mod_t *out);

/* f*(X) ⊆ *out, an outer estimate of the semantic extension f*.
 * Conditions (checked; otherwise a status other than MOD_OK):
 *  - every operation supported, and f defined and continuous on the box
 *    Set(X) (checked on an ordinary interval evaluation of each clause);
 *  - *-interpretability: every variable used more than once is proper or a
 *    point in X, or f is proved monotone in it over Set(X) (the interval
 *    gradient of tape_eval_grad, used only when f is C^1 on the box: no
 *    sqrt/log/powr operand reaching 0), in which case it is fixed at the end
 *    of X_k that gives each bound (the modal endpoint rule: for f
 *    nondecreasing in x_k, f*(X).lo = f*(X | x_k = X_k.lo).lo and
 *    f*(X).hi = f*(X | x_k = X_k.hi).hi, for either modality of X_k).
 * Then, by the *-interpretability theorem, f*(X) ⊆ fR(X') for each of the
 * (at most two) substituted boxes X', and the outer-rounded fR holds it.
 * info may be NULL. */
mod_status_t mod_star(const tape_t *t, const mod_t X[3], mod_t *out, mod_info_t *info);

/* *out ⊆ f**(X), an inner estimate of the semantic extension f**.  The same
 * conditions as mod_star with "improper" for "proper": every variable used
 * more than once is improper or a point in X, or monotone (fixed at ends as
 * above, which holds for f** as well).  Then fR(X') ⊆ f**(X')
 * (**-interpretability) and the inner-rounded fR lies inside.  When *out is
 * proper and every component of X is proper this is an inner estimate of the
 * range; see mod_inner_range. */
mod_status_t mod_dstar(const tape_t *t, const mod_t X[3], mod_t *out, mod_info_t *info);

/* An inner estimate of the range of f over an ordinary box: on MOD_OK, *out
 * is proper (out->lo <= out->hi) and every value z in [out->lo, out->hi] is
 * f(p) for some point p of the box (and f is defined and continuous on the
 * whole box).  Computed as mod_dstar on the box with every variable proper,
 * except those used more than once in which f is not proved monotone, which
 * are made improper (MOD_VAR_DUALISED): then R ⊆ f**(X) reads "for every
 * value of the universal variables, every z in R is attained by the
 * existential ones", which implies the claim.  MOD_NO_INNER when the result is
 * improper (nothing is certified; typically a multi-incident variable in which
 * f is not monotone); the other statuses as mod_dstar.  The box bounds must be
 * finite with lo <= hi. */
mod_status_t mod_inner_range(const tape_t *t, const iv_box_t *box, iv_t *out, mod_info_t *info);

#ifdef __cplusplus
}
#endif
#endif
