/* Test oracle: evaluate a tape at a point with MPFI (256 bits), value and gradient.
 * Independent of the double evaluators in expr/eval.c: only the tape format is shared. */
#ifndef IVOCT_TEST_MPFI_TAPE_H
#define IVOCT_TEST_MPFI_TAPE_H

#include <stdint.h>

#include <mpfi.h>

#include "../../expr/tape.h"

#define ORACLE_PREC 256

/* Which point of each interval constant to use: the tape's constants are
 * enclosures [lo, hi]; the double evaluator's result must hold f for every
 * constant value in them, so the oracle checks with each end. */
typedef enum { ORACLE_CONST_LO, ORACLE_CONST_HI } oracle_const_t;

/* Evaluate f at (x, y, z) exactly given as doubles.  value and grad (grad may
 * be NULL) must be initialised by the caller.  Returns 0 when f is defined at
 * the point and, if grad is requested, differentiable with every branch
 * (min/max/abs) decided; non-zero otherwise (the point is then skipped by
 * the tests: set-based semantics only speaks of points where f is defined). */
int oracle_eval(const tape_t *t, const double p[3], oracle_const_t which, mpfi_t value,
                mpfi_t grad[3]);

/* On the ray o + tt·d (the point computed in MPFI, exact or within 2^-256
 * relative, not rounded to doubles): value = f, grad = ∇f (required here)
 * and dvalue = ∇f·d.  Same return convention as oracle_eval, with the
 * gradient always requested. */
int oracle_eval_ray(const tape_t *t, const double o[3], const double d[3], double tt,
                    oracle_const_t which, mpfi_t value, mpfi_t dvalue, mpfi_t grad[3]);

/* Does the double interval [lo, hi] contain the MPFI interval v? */
int oracle_contained(mpfi_t v, iv_t d);

/* The evaluators against the oracle: nbox random sub-boxes of box (sizes from
 * the whole box down to 2^-30 of it, one in 16 a point box), evaluated in
 * batches of TAPE_BATCH + 13 (two passes, the second short and padded) with
 * tape_eval_interval and tape_eval_grad; points_per_box points in each (ends
 * and interior), alternately with each end of the interval constants.
 * Returns 0 when every value and gradient is enclosed, else 1 with a message
 * in stats->failure. */
typedef struct {
    long checked, checked_grad, skipped;
    char failure[1024];
} oracle_stats_t;

int oracle_check_tape(const tape_t *t, const double box[6], long nbox, int points_per_box,
                      uint64_t *rng, oracle_stats_t *stats);

/* The non-rigorous point + gradient evaluator against the oracle: npoints
 * random points of box in batches of TAPE_BATCH + 13, evaluated with
 * tape_eval_point_grad.  Its value must be tape_eval_point's bit for bit,
 * and its value and partials within 2w + 2^-50 |e| of the oracle's, where
 * [e.lo, e.hi] is tape_eval_grad's rigorous enclosure at the point box and
 * w its width (the rounding error of the same rules in doubles is of that
 * order; an enclosure that is not finite bounds nothing).  Points where the
 * oracle finds f undefined or not differentiable are skipped; checked counts
 * points, checked_grad partials with a finite enclosure. */
int oracle_check_point_grad(const tape_t *t, const double box[6], long npoints, uint64_t *rng,
                            oracle_stats_t *stats);

#endif
