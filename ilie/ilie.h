/* ivoct — affine arithmetic and implicit linear interval estimations (prefix ilie_).
 *
 * For a cell (a box) and a tape f, ilie_eval evaluates f in reduced affine
 * arithmetic over the cell's noise symbols and returns an ILIE (Bühler 2002):
 * a point vector a and an interval J such that
 *
 *     f(p) ∈ a·(p − c) + J     for every p in the cell where f is defined,
 *
 * as a statement about real numbers: every rounding error of the double
 * arithmetic, every approximation error of the nonlinear operations and the
 * rounding of a itself are inside J.  The surface f = 0 within the cell lies
 * in the slab {p : 0 ∈ a·(p − c) + J}.  See ilie/README.md for the
 * approximations and how rounding is accounted for.
 */
#ifndef IVOCT_ILIE_H
#define IVOCT_ILIE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../expr/interval.h"
#include "../expr/tape.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The ILIE of f on one cell.
 *
 * c   the cell's centre (c_k = 0.5·lo_k + 0.5·hi_k, a double inside [lo_k, hi_k]);
 * r   the noise radii: r_k >= max(c_k − lo_k, hi_k − c_k) exactly (the rounded
 *     difference pushed up by one ulp; 0 for a flat side lo_k = hi_k), so
 *     |p_k − c_k| <= r_k for every p in the cell;
 * a   the linear part (a_k = 0 where r_k = 0);
 * J   the constant part with every error folded in.
 *
 * Special values: J empty ({NaN, NaN}) and a = 0 when f is undefined on the
 * whole cell; a = 0 and J = an interval enclosure of f (possibly unbounded)
 * when the affine evaluation had to give up (an unbounded intermediate value).
 *
 * Every query below is rigorous only for points p inside the cell the ILIE
 * was computed for (|p_k − c_k| <= r_k). */
typedef struct ilie {
    double c[3];
    double r[3];
    double a[3];
    iv_t J;
} ilie_t;

/* ---- evaluation -----------------------------------------------------------------
 * A workspace holds the affine forms of the slots; one per thread.  It is sized
 * for tapes of max_clauses clauses and grows when given a longer tape (if that
 * allocation fails, ilie_eval returns the "no information" ILIE a = 0,
 * J = [-inf, +inf] for every cell, which is still a true statement). */
typedef struct ilie_ws ilie_ws_t;

ilie_ws_t *ilie_ws_new(uint32_t max_clauses); /* NULL when out of memory */
void ilie_ws_free(ilie_ws_t *ws);
/* The bytes ilie_ws_new(max_clauses) allocates (for memory budgets). */
size_t ilie_ws_bytes(uint32_t max_clauses);

/* The ILIE of f over each of the n cells box[0..n-1] into out[0..n-1].  Cells
 * are processed up to 64 at a time in a structure-of-arrays pass (lanes
 * innermost) compiled for each SIMD path; every path gives the same bits.  Cells should be
 * finite boxes with lo <= hi; a side that is not (infinite, NaN or reversed)
 * gets r_k = 0 and its variable becomes a plain interval (rigorous, no slope). */
void ilie_eval(const tape_t *t, ilie_ws_t *ws, size_t n, const iv_box_t *box, ilie_t *out);

/* ---- queries --------------------------------------------------------------------- */

/* The interval a·(p − c) + J at the point p, outward rounded.  Encloses f(p)
 * when p is in the cell and f is defined at p.  Empty when J is empty. */
iv_t ilie_at(const ilie_t *l, const double p[3]);

/* The range of a·(p − c) + J over p in box (outward rounded); box must lie in
 * the cell (a child of it, or the cell itself). */
iv_t ilie_range(const ilie_t *l, const iv_box_t *box);

/* Certified exclusion: true when 0 ∉ a·(p − c) + J for every p in box (box
 * inside the cell), i.e. f has no zero in box.  *sign (may be NULL) is then
 * +1 when f > 0 on box (outside), −1 when f < 0 (inside), and 0 when f is
 * undefined on the whole cell (J empty: no surface there, and neither side).
 * False (with *sign = 0) when a zero cannot be excluded. */
bool ilie_excludes_box(const ilie_t *l, const iv_box_t *box, int *sign);

/* ilie_excludes_box for n ILIEs at once: ex[j] and sign[j] (sign may be NULL)
 * are what ilie_excludes_box(&l[j], &box[j], &sign[j]) gives, bit for bit,
 * computed over lanes at the SIMD width of the path in use. */
void ilie_excludes_boxes(size_t n, const ilie_t *l, const iv_box_t *box, bool *ex, int *sign);

/* Thickness of the slab: w(J)/|a| rounded up.  +inf when a = 0 or J is
 * unbounded; 0 when J is empty (no surface in the cell). */
double ilie_thickness(const ilie_t *l);

/* The slab as n·p ∈ [d_lo, d_hi]: n the unit normal a/|a| (rounded to double;
 * |n| = 1 up to a few ulps) and offsets such that every p in the cell with
 * 0 ∈ a·(p − c) + J — in particular every point of the surface in the cell —
 * satisfies d_lo <= n·p <= d_hi exactly (the rounding of n is accounted for
 * with the cell radii r).  When a = 0: n = (0, 0, 0) and d_lo = −inf,
 * d_hi = +inf (no information) if 0 may be in J, else the empty slab
 * d_lo = +inf, d_hi = −inf; the empty slab also when J is empty. */
void ilie_slab(const ilie_t *l, double n[3], double *d_lo, double *d_hi);

#ifdef __cplusplus
}
#endif
#endif
