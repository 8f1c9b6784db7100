/* The no-missed-cell check, shared by tests/test_octree_coverage.c and the
 * stability suite (tests/test_stab_octree.c): an octree misses no piece of
 * surface, checked against dense sampling with MPFI-certified signs.
 *
 * f is sampled on the grid of depth D+2 (4 samples per max-depth cell edge) at
 * exactly the cell-bound coordinates oct_coord(lo, hi, i, D+2), so a sample on
 * a cell face is exactly on it.  The grid covers a window of the tree: a cube
 * of n max-depth cells per axis starting at cell i0 (the whole box when n =
 * 2^D), so a deep tree can be checked where its surface is.  The sign of a
 * sample comes from tape_eval_point, except where |f| is tiny (below 1e-9
 * times the largest |f| sampled): there it comes from the MPFI oracle (256
 * bits) with both ends of the tape's interval constants; a sample whose MPFI
 * sign is not certified may be a zero itself.  A NaN sample is taken as
 * undefined and skipped (that can only weaken the check).  f must be
 * continuous where defined, so that a sign change between two defined samples
 * is a zero.
 *
 * Coverage is looked up in the tree's leaves list (coarser leaves expanded to
 * ranges of max-depth Morton codes, sorted, binary search), not through the
 * tree's nodes.  Every check fails with cmocka (fail_msg) on a broken
 * structure and counts property failures in cov_result_t (the first few are
 * printed). */
#ifndef IVOCT_TEST_COVERAGE_H
#define IVOCT_TEST_COVERAGE_H

#include <stddef.h>
#include <stdint.h>

#include "../../expr/tape.h"
#include "../../octree/octree.h"

enum { S_NEG = -1, S_ZERO = 0, S_POS = 1, S_UNDEF = 2, S_UNKNOWN = 3 };

typedef struct cov_grid {
    int depth;          /* D: the tree's max depth */
    uint32_t n;         /* max-depth cells per axis in the window */
    uint32_t i0[3];     /* the window's first cell per axis (0 for the whole box) */
    uint32_t m;         /* 4n sample intervals per axis, m + 1 samples */
    double box[6];
    double *c[3];       /* sample coordinates: c[a][i] = oct_coord(.., 4 i0[a] + i, D+2) */
    double *cb[3];      /* cell bounds: cb[a][i] = oct_coord(.., i0[a] + i, D) */
    double *f;          /* point values, (m+1)^3 */
    signed char *sign;  /* certified (or point) sign per sample, S_UNKNOWN until computed */
    signed char *msign; /* MPFI sign per sample, computed on demand */
    const tape_t *tape;
    double thr;         /* |f| below this: the sign comes from MPFI */
    long mpfi_calls;
} cov_grid_t;

/* MPFI sign of f at p (S_NEG, S_ZERO when not certified, S_POS, S_UNDEF), with
 * both ends of the interval constants. */
int cov_mpfi_sign(const tape_t *t, const double p[3]);

/* The grid over the whole box (i0 = 0, n = 2^depth) or over a window. */
void cov_grid_init(cov_grid_t *g, const tape_t *tape, const double box[6], int depth);
void cov_grid_init_window(cov_grid_t *g, const tape_t *tape, const double box[6], int depth,
                          const uint32_t i0[3], uint32_t n);
void cov_grid_free(cov_grid_t *g);
size_t cov_gidx(const cov_grid_t *g, uint32_t i, uint32_t j, uint32_t k);
int cov_sample_mpfi_sign(cov_grid_t *g, uint32_t i, uint32_t j, uint32_t k);

/* The surface leaves as sorted ranges of max-depth Morton codes. */
typedef struct cov_cover {
    int depth;
    size_t n;
    uint64_t *lo, *hi; /* [lo, hi) */
} cov_cover_t;

void cov_cover_init(cov_cover_t *cv, const oct_tree_t *t);
void cov_cover_free(cov_cover_t *cv);
/* Is the max-depth cell (global indices) inside a surface leaf? */
int cov_covered(const cov_cover_t *cv, uint32_t x, uint32_t y, uint32_t z);

typedef struct cov_result {
    long segments, zeros, line_points, point_boxes, empty_checked, empty_skipped,
        undefined_checked;
    long failures;
} cov_result_t;

void cov_report(cov_result_t *r, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Every sign change between neighbouring samples (along x, y, z) must lie in
 * a surface leaf, and so must every sample whose sign MPFI cannot certify. */
void cov_check_sign_changes(cov_grid_t *g, const cov_cover_t *cv, const char *what,
                            cov_result_t *r);

/* A point where f = 0 (asserted in MPFI) must lie in a covered closed cell. */
void cov_check_zero_point(const cov_grid_t *g, const cov_cover_t *cv, const double p[3],
                          const char *what, cov_result_t *r);

/* A zero line without sign change along axis a through the origin, for t in
 * [t0, t1] clipped to the box: random points and every sample coordinate. */
void cov_check_zero_line(const cov_grid_t *g, const cov_cover_t *cv, int a, double t0,
                         double t1, const char *what, cov_result_t *r);

/* A point of the surface certainly lies in the closed box [lo, hi] (e.g. an
 * irrational singular point enclosed by doubles, or a segment whose ends have
 * opposite MPFI-certified signs): at least one max-depth cell meeting the box
 * must be covered.  The box must be small (it is expanded cell by cell). */
void cov_check_box(const cov_grid_t *g, const cov_cover_t *cv, const double lo[3],
                   const double hi[3], const char *what, cov_result_t *r);

/* The class of every empty cell (walked from nodes[0], with a check of the
 * tree's structure) against the MPFI sign of f at its centre: OCT_INSIDE needs
 * f < 0 there, OCT_OUTSIDE f > 0, OCT_UNDEFINED f undefined (a centre MPFI
 * cannot certify is skipped).  Whole-box grids only. */
void cov_check_empty_cells(cov_grid_t *g, const oct_tree_t *t, const char *what,
                           cov_result_t *r);

/* A zero line for cov_check_all: axis a (0, 1, 2), t in [t0, t1]. */
typedef struct cov_line {
    int axis;
    double t0, t1;
} cov_line_t;

/* The test configurations of cov_check_all. */
enum {
    COV_CFG_INTERVAL = 1u << 0,   /* tests = interval */
    COV_CFG_LIPSCHITZ = 1u << 1,  /* tests = interval, lipschitz */
    COV_CFG_ILIE = 1u << 2,       /* tests = interval, lipschitz, ilie */
    COV_CFG_REFINE = 1u << 3,     /* all three, refine = 2% of the box's largest edge */
    COV_CFG_ALL = 15u,
    COV_NO_EMPTY = 1u << 4,       /* skip the empty-cell check (it costs an MPFI
                                     evaluation per empty cell) */
};

typedef struct cov_summary {
    long segments, zeros, line_points, empty_checked, undefined; /* summed */
    long min_segments, min_empty_checked; /* the least over the configurations */
    long failures;   /* property failures over all configurations */
    uint32_t leaves; /* of the last configuration */
    double max_error_bound; /* the largest certified leaf error bound, over the builds */
    double build_s;  /* builds, summed */
} cov_summary_t;

/* Build the tree of the tape in box at depth for each configuration in cfgs
 * and run the sign-change, zero-line and empty-cell checks on it (whole box).
 * Fails the test (fail_msg) when a check fails; whether it was vacuous is the
 * caller's to assert (out->min_segments, out->min_empty_checked). */
void cov_check_all(const tape_t *tape, const double box[6], const char *name, int depth,
                   unsigned cfgs, const cov_line_t *lines, int n_lines, cov_summary_t *out);

#endif
