/* ivoct — expressions compiled to tapes, and the evaluators over a tape (prefix tape_).
 *
 * An expression (grammar in docs/scene-format.md) is parsed into a DAG with
 * common-subexpression elimination and constant folding, then flattened into a
 * tape: an array of SSA clauses, clause i writing slot i, each reading only
 * slots before it.  The value of the expression is the last clause.
 *
 * Constants are intervals: a decimal literal that is not a double (0.1) and
 * the constants pi and e are enclosed, so folding and evaluation stay rigorous.
 */
#ifndef IVOCT_TAPE_H
#define IVOCT_TAPE_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "interval.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum tape_op {
    /* leaves */
    TAPE_CONST, /* c */
    TAPE_X,
    TAPE_Y,
    TAPE_Z,
    /* unary: slot a */
    TAPE_NEG,
    TAPE_SQR,
    TAPE_POWI, /* a ^ n, n = (int)c.lo, |n| >= 3 or n = -1, -2 */
    TAPE_POWR, /* a ^ r, r = c.lo a double that is not an integer */
    TAPE_SQRT,
    TAPE_EXP,
    TAPE_LOG,
    TAPE_SIN,
    TAPE_COS,
    TAPE_TAN,
    TAPE_ATAN,
    TAPE_ABS,
    /* binary: slots a, b */
    TAPE_ADD,
    TAPE_SUB,
    TAPE_MUL,
    TAPE_DIV,
    TAPE_MIN,
    TAPE_MAX,
    TAPE_OP_COUNT
} tape_op_t;

typedef struct tape_clause {
    uint32_t op; /* tape_op_t */
    uint32_t a, b;
    iv_t c;      /* TAPE_CONST: the value; TAPE_POWI / TAPE_POWR: the exponent in c.lo */
} tape_clause_t;

typedef struct tape {
    tape_clause_t *clauses;
    uint32_t n; /* number of clauses, >= 1; the result is clause n-1 */
} tape_t;

/* Name of an op ("add", "sqr", ...), for dumps and stats. */
const char *tape_op_name(tape_op_t op);

/* ---- compiling ----------------------------------------------------------------
 * A compiler holds the named subexpressions (let.NAME) defined so far.
 * Errors name line and column inside the text given (1-based; text may hold
 * newlines); the scene loader maps them to file positions.  Limits, reported as
 * errors rather than crashes: nesting deeper than TAPE_MAX_NESTING, texts
 * longer than TAPE_MAX_TEXT bytes. */
#define TAPE_MAX_NESTING 1000
#define TAPE_MAX_TEXT (1u << 20)

typedef struct tape_compiler tape_compiler_t;

tape_compiler_t *tape_compiler_new(void); /* NULL when out of memory */
void tape_compiler_free(tape_compiler_t *tc);

/* Define NAME as the expression text; later texts may use NAME.  Names follow
 * [A-Za-z_][A-Za-z0-9_]* and may not shadow x y z pi e or a function.  An
 * error about NAME itself (syntax, reserved, already defined) has line 0: it
 * has no position in text.  A message may quote a second position, always
 * as "opened at LINE:COL" in text positions (the scene loader maps it too). */
int tape_compiler_define(tape_compiler_t *tc, const char *name, const char *text,
                         ivoct_error_t *err);

/* Compile text (which may use the names defined so far) into a new tape. */
int tape_compiler_compile(tape_compiler_t *tc, const char *text, tape_t **out,
                          ivoct_error_t *err);

/* Shorthand: compile a text that uses no names. */
int tape_compile(const char *text, tape_t **out, ivoct_error_t *err);

void tape_free(tape_t *t);
tape_t *tape_clone(const tape_t *t);

/* ---- evaluating ---------------------------------------------------------------
 * Each evaluator takes n points or boxes and runs one pass over the tape per
 * batch of up to TAPE_BATCH of them, structure of arrays: every slot is an
 * array of lower bounds and one of upper bounds (and the partials' for the
 * gradient) with the lanes innermost, so the per-clause loops run in SIMD
 * registers.  Give the evaluators many boxes per call: a call with few boxes
 * pays a whole pass for them.  A workspace holds the slots; one per thread,
 * sized for tapes of at most max_clauses clauses and any n. */
#define TAPE_BATCH 64

typedef struct tape_ws tape_ws_t;

tape_ws_t *tape_ws_new(uint32_t max_clauses); /* NULL when out of memory */
void tape_ws_free(tape_ws_t *ws);
/* The bytes tape_ws_new(max_clauses) allocates (for memory budgets). */
size_t tape_ws_bytes(uint32_t max_clauses);

/* ---- SIMD paths ------------------------------------------------------------------
 * The evaluators run on one of the SIMD paths: "portable" (what the compiler
 * vectorises for the baseline CPU) everywhere, "avx2" and "avx512" on x86-64
 * CPUs that have them.  Every path computes the same bits (the same IEEE
 * operations in the same order, at different vector widths), so results never
 * depend on the path.  By default the widest path the CPU runs is used, or
 * the one the environment variable IVOCT_SIMD names when the CPU runs it. */
const char *tape_simd_name(void);            /* the path in use */
const char *tape_simd_paths(void);           /* this build's paths, space-separated */
int tape_simd_available(const char *name);   /* does this build and CPU run it? */
/* Use path name from now on (NULL: the default above).  0, or -1 with err set
 * when the name is unknown or the CPU cannot run it.  Call before evaluating
 * (not while other threads evaluate). */
int tape_simd_select(const char *name, ivoct_error_t *err);
/* Short batches on the path in use: a call of tape_eval_point,
 * tape_eval_interval or tape_eval_ray with at most this many boxes costs at
 * most one pass of exactly this many (the path pads them; avx2 and avx512 run
 * 1 to 4 boxes as a pass of 4, cheaper); 0 when the cost of a call grows
 * with its boxes down to one.  A caller that asks for a few boxes at a time
 * can fill the rest for free. */
size_t tape_short_lanes(void);

/* Plain double evaluation (not rigorous: for sampling and baselines). */
void tape_eval_point(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                     const double *y, const double *z, double *out);

/* Rigorous enclosure of f over each box. */
void tape_eval_interval(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                        iv_t *out);

/* The branch of a choice (min, max, abs) that an interval evaluation proved is
 * the one taken everywhere over a box, for tape_prune. */
typedef enum tape_choice {
    TAPE_CHOICE_BOTH = 0, /* not decided (or not a choice): the clause stays */
    TAPE_CHOICE_A,        /* min/max: operand a is the value (abs: a >= 0, the value is a) */
    TAPE_CHOICE_B,        /* min/max: operand b is the value */
    TAPE_CHOICE_NEG_A,    /* abs: a <= 0, the value is -a */
} tape_choice_t;

/* tape_eval_interval, and the choices decided over each box: choices[k *
 * t->n + i] (n * t->n bytes, every entry written) for box k and clause i,
 * from the same enclosures as out: min(a, b) takes a where A.hi <= B.lo over
 * the box, b where B.hi <= A.lo; max likewise; abs(a) is a where A.lo >= 0,
 * -a where A.hi <= 0; anything else (an empty operand included) is BOTH. */
void tape_eval_interval_choices(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                                iv_t *out, uint8_t *choices);

/* Rigorous enclosure of f and of its gradient over each box. */
void tape_eval_grad(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                    iv_grad_t *out);

/* Plain double evaluation of f and of its gradient at points (forward mode;
 * not rigorous: for distance estimates and normals, where the cost of
 * tape_eval_grad buys nothing).  out[k].v is tape_eval_point's value, bit
 * for bit.  The partials are those of the same rules as tape_eval_grad's,
 * rounded to nearest, so they lie close to the midpoints of tape_eval_grad's
 * enclosures at the point box (test_eval and test_eval_mpfi check value and
 * partials against MPFI within twice the width of those enclosures, plus
 * 2^-50 relative).  Where abs, min or max is at its kink (abs at 0, min/max at
 * a tie) the partials are the mean of the two one-sided ones; IEEE NaN or
 * ±inf where f or a partial is undefined, as tape_eval_point. */
typedef struct tape_point_grad {
    double v, dx, dy, dz;
} tape_point_grad_t;

void tape_eval_point_grad(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                          const double *y, const double *z, tape_point_grad_t *out);

/* ---- along a ray ----------------------------------------------------------------
 * g(t) = f(o + t·d) on a ray with finite o and d.  The rounded point of
 * parameter t is p~(t) = fl(o + fl(t·d)) per axis (two roundings; the build
 * has -ffp-contract=off): what a caller that evaluates "at t" really gets. */
static inline void tape_ray_point(const double o[3], const double d[3], double t, double p[3])
{
    for (int i = 0; i < 3; i++) {
        double s = t * d[i];
        p[i] = o[i] + s;
    }
}

/* Rigorous enclosures along a ray, for n parameter intervals T[k] (finite,
 * T.lo <= T.hi).  Lane k is evaluated over the box X_k:
 *   - T = [t, t]: X = {p~(t)}, the rounded point;
 *   - T.lo < T.hi: X = an outward-rounded enclosure of the exact segment
 *     o + T·d, hulled with p~(T.lo) and p~(T.hi), so X holds every exact
 *     point o + t·d and every rounded point p~(t), t ∈ T (p~ is monotone in t).
 * Then:
 *   g[k]   ⊇ { f(p) : p ∈ X_k, f defined at p }  (so g[k] ⊇ g(T) for a segment;
 *            the same set as tape_eval_interval on X_k);
 *   dg[k]  ⊇ { ∇f(p)·d : p ∈ X_k, f differentiable at p }, with one forward
 *            tangent (not three partials); where abs, min or max is not
 *            differentiable it holds every one-sided derivative along d, as
 *            tape_eval_grad does; so dg[k] ⊇ g'(T);
 *   rnd[k] >= sup { |∇f(p)·e| : p ∈ X_k, |e_i| <= rho_i(T_k) }, where
 *            rho_i(T) = 2^-51 (|o_i| + 2 max(|T.lo|, |T.hi|) |d_i|) rounded up
 *            is at least twice the displacement |p~_i(t) - (o_i + t d_i)| of any
 *            rounded point of T; +inf where no finite bound is known (f not
 *            Lipschitz on X_k, e.g. sqrt at 0).  By the mean value theorem,
 *            for t, m ∈ T: f(p~(t)) and g(t) lie in f(p~(m)) + dg·(t - m) ±
 *            rnd (the Newton and Kalra–Barr steps of ray/ need this).
 * Same outward rounding and set-based conventions as the interval evaluator:
 * empty where f is defined nowhere on X_k, never NaN from a defined value.
 * dg = NULL: values only (an interval pass; rnd ignored).  rnd may be NULL. */
void tape_eval_ray(const tape_t *t, tape_ws_t *ws, const double o[3], const double d[3],
                   size_t n, const iv_t *T, iv_t *g, iv_t *dg, double *rnd);

/* ---- pruning per region --------------------------------------------------------
 * Over a region where the branch of a choice is known, the choice can go:
 * min(a, b) with a <= b over the region becomes a, max likewise, abs(a) with a
 * of known sign becomes a or -a; clauses no longer needed are dropped.  The
 * pruned tape equals f at every point of the region where f is defined. */

/* Does the tape hold any min, max or abs (anything tape_prune could remove)? */
int tape_has_choices(const tape_t *t);

/* Is every clause that depends on x, y or z used at most once?  Then the tape is
 * a single-use expression: its interval evaluation is the exact range of f
 * over a box (up to the outward rounding), since no variable can take two
 * values at once.  No other range test (Lipschitz, affine) can then decide a
 * box the interval test leaves open, so the octree skips them.  scratch: 2 *
 * t->n words. */
int tape_is_single_use(const tape_t *t, uint32_t *scratch);

/* ---- continuity over a box ----------------------------------------------------
 * What an argument that needs f continuous on a box (the intermediate value
 * theorem, the semantic extensions of modal/) checks first. */
typedef enum tape_domain {
    TAPE_DOMAIN_CONTINUOUS = 0, /* f is defined and continuous on the whole box */
    TAPE_DOMAIN_NOT_PROVED,     /* an operand may leave its operation's domain of
                                 * continuity, or an unknown op (nothing claimed) */
    TAPE_DOMAIN_OVERFLOW        /* an enclosure had a non-finite bound (nothing claimed) */
} tape_domain_t;

/* Is the function of t defined and continuous at every point of the closed
 * box?  An ordinary interval evaluation of each clause over the box, checked
 * against the domain where its operation is continuous: division by an
 * enclosure that excludes 0, sqrt and powr (r > 0) of one >= 0, log and powr
 * (r < 0) of one > 0, negative integer powers of one that excludes 0, tan
 * without a pole; +, -, *, neg, sqr, nonnegative powers, exp, sin, cos,
 * atan, abs, min and max are continuous everywhere.  TAPE_DOMAIN_CONTINUOUS
 * is a proof (the enclosures are rigorous); the other results claim nothing.
 * slots: t->n intervals, left holding each clause's enclosure over the box
 * when the result is TAPE_DOMAIN_CONTINUOUS.  smooth (may be NULL): on
 * TAPE_DOMAIN_CONTINUOUS, 1 when f is moreover C^1 on a neighbourhood of the
 * box (sqrt and powr operands bounded away from 0, abs operands and min/max
 * branches of one sign or order over the box), so that the interval gradient
 * of tape_eval_grad bounds every derivative.  No allocation. */
tape_domain_t tape_check_continuous(const tape_t *t, const iv_box_t *box, iv_t *slots,
                                    int *smooth);

/* Is every operation of t defined and continuous on the whole of R^3 (no
 * division, sqrt, log, powr, negative power or tan; finite constants)?  Then
 * f is continuous on every box, and so is any tape pruned from t over a box
 * (it equals f there). */
int tape_is_total(const tape_t *t);

/* Number of operands of an op (0, 1 or 2). */
int tape_op_arity(tape_op_t op);

/* Prune t with the choices of one box (t->n entries, as written by
 * tape_eval_interval_choices for that box or any box that holds it) into out,
 * whose clauses array must hold t->n clauses: a decided choice becomes its
 * branch, and clauses the result no longer needs are dropped.  out->n <= t->n,
 * and out equals t at every point of the box where t is defined.  scratch: 3 *
 * t->n words.  No allocation. */
void tape_prune(const tape_t *t, const uint8_t *choices, uint32_t *scratch, tape_t *out);

#ifdef __cplusplus
}
#endif
#endif
