/* ivoct — reduced affine arithmetic over the three noise symbols of a cell
 * (internal to ilie/; the public interface is ilie.h).
 *
 * A form  x̂ = x[0] + x[1]·εx + x[2]·εy + x[3]·εz + e·η,  εk, η ∈ [−1, 1],
 * stands for a quantity q(p) over the cell: for every p in the cell where q
 * is defined there is an η with q(p) = x̂ at εk = (p_k − c_k)/r_k.  All
 * coefficients are doubles and the statement is about the real numbers they
 * denote: every rounding error is inside e.
 *
 * Each form also carries v, an interval enclosure of q over the cell, kept
 * inside the range of the form.  v decides branches (abs, min, max), gives
 * the argument range of the nonlinear approximations and the domain tests,
 * and is the value of the interval fallback.
 *
 * Special forms: v empty (and x = 0, e = 0) when q is undefined on the whole
 * cell; e = +inf (and x = 0) when no finite form is known (v then holds what
 * is known, possibly unbounded).
 */
#ifndef IVOCT_ILIE_AFFINE_H
#define IVOCT_ILIE_AFFINE_H

#include "../expr/interval.h"
#include "../expr/tape.h"
#include "ilie.h"

typedef struct aa {
    double x[4];
    double e;
    iv_t v;
} aa_t;

/* Leaves: an interval constant, and variable k (0, 1, 2) of a cell side b
 * with centre c and radius r (r = 0: the variable is the interval b). */
void aa_const(aa_t *z, iv_t c);
void aa_var(aa_t *z, int k, double c, double r, iv_t b);

/* The interval fallback: the pure interval form of v (x[1..3] = 0). */
void aa_from_iv(aa_t *z, iv_t v);

/* Operations of the tape language.  z must not alias an operand. */
void aa_neg(aa_t *z, const aa_t *a);
void aa_add(aa_t *z, const aa_t *a, const aa_t *b);
void aa_sub(aa_t *z, const aa_t *a, const aa_t *b);
void aa_mul(aa_t *z, const aa_t *a, const aa_t *b);
void aa_div(aa_t *z, const aa_t *a, const aa_t *b);
void aa_sqr(aa_t *z, const aa_t *a);
void aa_powi(aa_t *z, const aa_t *a, double n);
void aa_powr(aa_t *z, const aa_t *a, double r);
void aa_sqrt(aa_t *z, const aa_t *a);
void aa_exp(aa_t *z, const aa_t *a);
void aa_log(aa_t *z, const aa_t *a);
void aa_sin(aa_t *z, const aa_t *a);
void aa_cos(aa_t *z, const aa_t *a);
void aa_tan(aa_t *z, const aa_t *a);
void aa_atan(aa_t *z, const aa_t *a);
void aa_abs(aa_t *z, const aa_t *a);
void aa_min(aa_t *z, const aa_t *a, const aa_t *b);
void aa_max(aa_t *z, const aa_t *a, const aa_t *b);

/* An upper bound of the exact value of a bound expression evaluated in
 * round-to-nearest: see affine.c. */
static inline double aa_fin_up(double s)
{
    return s * (1.0 + 0x1p-44) + 0x1p-1040;
}

/* ---- the structure-of-arrays pass (affine_kernels.h) -----------------------------
 * The forms of a batch of up to ILIE_BATCH cells, lanes innermost: slot i of the
 * tape holds A_ARRAYS arrays of ILIE_BATCH doubles, array c at
 * S + (i * A_ARRAYS + c) * ILIE_BATCH, lane k at index k.  The pass is
 * compiled once per SIMD path, like the tape evaluators of expr/; every path
 * gives every lane the bits the scalar aa_ functions give. */
#define ILIE_BATCH 64 /* at most IV_LANES_MAX (expr/lanes.h) */
enum { A_X0, A_X1, A_X2, A_X3, A_E, A_VLO, A_VHI, A_ARRAYS };

/* The forms of every clause of t for lanes 0..nl-1 (nl <= ILIE_BATCH, a
 * multiple of 8 when it is larger than 8), from the variables' forms
 * var[d][k] (d = 0, 1, 2 for x, y, z), into S (t->n slots); the last clause's
 * forms into f[0..nl-1]. */
typedef void ilie_pass_fn(const tape_t *t, double *S, size_t nl,
                          const aa_t (*var)[ILIE_BATCH], aa_t *f);

/* ilie_excludes_box for nl <= ILIE_BATCH lanes (ilie.h, ilie_excludes_boxes):
 * code[j] = 1 or -1 (excluded, the sign), 2 (excluded: J empty, no sign), 0
 * (not excluded), or 3: not decided here (an empty side), ask ilie_excludes_box. */
typedef void ilie_excludes_fn(size_t nl, const ilie_t *l, const iv_box_t *box, int64_t *code);

/* A SIMD path's lane functions. */
typedef struct {
    const char *name; /* tape_simd_name()'s */
    ilie_pass_fn *pass;
    ilie_excludes_fn *excludes;
} ilie_lanes_t;
extern const ilie_lanes_t ilie_lanes_portable;
#ifdef IVOCT_SIMD_X86
extern const ilie_lanes_t ilie_lanes_avx2, ilie_lanes_avx512;
#endif

#endif
