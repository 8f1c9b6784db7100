/* The octree misses no piece of surface: checked against dense sampling, an
 * independent method.
 *
 * For every scene file, built at a modest depth D with the tests "interval"
 * and "interval,lipschitz", and with "interval,lipschitz,ilie" and refine
 * (early leaves, 2% of the box's edge; coarser leaves are expanded):
 *
 *  1. Sign changes.  f is sampled on the grid of depth D+2 (4 samples per leaf
 *     edge), at exactly the cell-bound coordinates oct_coord(lo, hi, i, D+2), so
 *     a sample on a cell face is exactly on it.  The sign of a sample comes from
 *     tape_eval_point, except where |f| is tiny (below 1e-9 times the largest
 *     |f| sampled): there it comes from the MPFI oracle (256 bits), with both
 *     ends of the tape's interval constants (a NaN sample is taken as
 *     undefined and skipped, which can only weaken the check); a sample whose
 *     MPFI sign is not certified (the interval holds 0, or the two ends of the
 *     constants disagree) may be a zero itself.  Every scene's f is continuous
 *     in its box (polynomials; sqrt, abs, exp and min of continuous functions;
 *     the bretzel's denominator is >= 1), so a sign change is a zero.  Then:
 *       - wherever the sign changes between two neighbouring samples along x,
 *         y or z, the segment between them holds a zero, so it must lie in a
 *         surface leaf.  The segment lies in one closed max-depth cell along
 *         its own axis (samples are at multiples of 1/4 of a cell) and on up to
 *         2 cells along each other axis (when it lies on a face or an edge); at
 *         least one of them must be covered by a surface leaf;
 *       - a possible zero sample must lie in a surface leaf (one of the up to
 *         8 closed max-depth cells holding the point).
 *     Coverage is looked up in a bitmap of max-depth cells built from the
 *     leaves list (coarser leaves expanded), not through the tree's nodes.
 *
 *  2. Zero lines without sign change, which sampling cannot see: the z-axis of
 *     the crosscap, the three axes of the Steiner surface, the z-axis of the
 *     Whitney umbrella (whose handle z < 0 has no sign change).  Many points
 *     on them (random, and every cell bound) must lie in surface leaves.
 *
 *  3. Empty cells (found by walking the nodes from nodes[0]): an OCT_INSIDE /
 *     OCT_OUTSIDE cell must have that sign at its centre (MPFI-certified; the
 *     centre is skipped when MPFI cannot certify it); an OCT_UNDEFINED cell
 *     must have f undefined at its centre.
 *
 *  4. The same checks on three surfaces that end at the edge of f's domain
 *     (sqrt, log), where empty cells are also OCT_UNDEFINED.  Every function
 *     here is continuous where defined, so a sign change between two defined
 *     samples is a zero.
 *
 * IVOCT_ASAN=1 runs at depth 4 instead of 5; IVOCT_TEST_SCALE >= 4 at depth 6. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <omp.h>

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

#define LINE_POINTS 2000 /* random points per zero line */
#define MAX_REPORTS 5

enum { S_NEG = -1, S_ZERO = 0, S_POS = 1, S_UNDEF = 2, S_UNKNOWN = 3 };

typedef struct grid {
    int depth;           /* D: the tree's max depth */
    uint32_t n;          /* 2^D cells per axis */
    uint32_t m;          /* 4n sample intervals per axis, m + 1 samples */
    double box[6];
    double *c[3];        /* sample coordinates per axis: c[a][i] = oct_coord(.., i, D+2) */
    double *cb[3];       /* cell bounds per axis: cb[a][i] = oct_coord(.., i, D) */
    double *f;           /* point values, (m+1)^3 */
    signed char *sign;   /* certified (or point) sign per sample, S_UNKNOWN until computed */
    signed char *msign;  /* MPFI sign per sample, computed on demand */
    const tape_t *tape;
    double thr;          /* |f| below this: the sign comes from MPFI */
    long mpfi_calls;
} grid_t;

static int depth_for_run(void)
{
    const char *asan = getenv("IVOCT_ASAN");
    if (asan && *asan && strcmp(asan, "0") != 0)
        return 4;
    return tu_scale() >= 4 ? 6 : 5;
}

static size_t gidx(const grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    size_t s = (size_t)g->m + 1;
    return ((size_t)k * s + j) * s + i;
}

/* MPFI sign of f at p, with both ends of the interval constants. */
static int mpfi_sign(const tape_t *t, const double p[3])
{
    mpfi_t v;
    mpfi_init2(v, ORACLE_PREC);
    int s[2];
    int undef = 0;
    for (int w = 0; w < 2; w++) {
        if (oracle_eval(t, p, w ? ORACLE_CONST_HI : ORACLE_CONST_LO, v, NULL) != 0) {
            undef = 1;
            break;
        }
        s[w] = mpfi_is_strictly_pos(v) ? S_POS : mpfi_is_strictly_neg(v) ? S_NEG : S_ZERO;
    }
    mpfi_clear(v);
    if (undef)
        return S_UNDEF;
    return s[0] == s[1] ? s[0] : S_ZERO;
}

static int sample_mpfi_sign(grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    size_t q = gidx(g, i, j, k);
    if (g->msign[q] == S_UNKNOWN) {
        double p[3] = {g->c[0][i], g->c[1][j], g->c[2][k]};
        g->msign[q] = (signed char)mpfi_sign(g->tape, p);
        g->mpfi_calls++;
    }
    return g->msign[q];
}

static int sample_sign(grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    size_t q = gidx(g, i, j, k);
    if (g->sign[q] == S_UNKNOWN) {
        double v = g->f[q];
        if (isnan(v)) /* undefined, or nearly: skipped, which can only weaken the check */
            g->sign[q] = S_UNDEF;
        else if (fabs(v) > g->thr)
            g->sign[q] = v > 0 ? S_POS : S_NEG;
        else
            g->sign[q] = (signed char)sample_mpfi_sign(g, i, j, k);
    }
    return g->sign[q];
}

static void grid_init(grid_t *g, const scene_t *s, int depth)
{
    memset(g, 0, sizeof *g);
    g->depth = depth;
    g->n = 1u << depth;
    g->m = 4 * g->n;
    g->tape = s->tape;
    memcpy(g->box, s->box, sizeof g->box);
    size_t s1 = (size_t)g->m + 1, total = s1 * s1 * s1;
    for (int a = 0; a < 3; a++) {
        g->c[a] = malloc(s1 * sizeof *g->c[a]);
        g->cb[a] = malloc(((size_t)g->n + 1) * sizeof *g->cb[a]);
        assert_non_null(g->c[a]);
        assert_non_null(g->cb[a]);
        for (uint32_t i = 0; i <= g->m; i++)
            g->c[a][i] = oct_coord(s->box[2 * a], s->box[2 * a + 1], i, depth + 2);
        for (uint32_t i = 0; i <= g->n; i++) {
            g->cb[a][i] = oct_coord(s->box[2 * a], s->box[2 * a + 1], i, depth);
            /* the property the whole test relies on: same fraction, same double */
            assert_true(g->cb[a][i] == g->c[a][4 * i]);
        }
    }
    g->f = malloc(total * sizeof *g->f);
    g->sign = malloc(total);
    g->msign = malloc(total);
    assert_non_null(g->f);
    assert_non_null(g->sign);
    assert_non_null(g->msign);
    memset(g->sign, S_UNKNOWN, total);
    memset(g->msign, S_UNKNOWN, total);

    tape_ws_t *ws = tape_ws_new(s->tape->n);
    assert_non_null(ws);
    double *y = malloc(s1 * sizeof *y), *z = malloc(s1 * sizeof *z);
    assert_non_null(y);
    assert_non_null(z);
    double scale = 0;
    for (uint32_t k = 0; k <= g->m; k++)
        for (uint32_t j = 0; j <= g->m; j++) {
            for (uint32_t i = 0; i <= g->m; i++)
                y[i] = g->c[1][j], z[i] = g->c[2][k];
            double *out = g->f + gidx(g, 0, j, k);
            tape_eval_point(s->tape, ws, s1, g->c[0], y, z, out);
            for (uint32_t i = 0; i <= g->m; i++)
                if (isfinite(out[i]) && fabs(out[i]) > scale)
                    scale = fabs(out[i]);
        }
    g->thr = 1e-9 * scale;
    free(y);
    free(z);
    tape_ws_free(ws);
}

static void grid_free(grid_t *g)
{
    for (int a = 0; a < 3; a++) {
        free(g->c[a]);
        free(g->cb[a]);
    }
    free(g->f);
    free(g->sign);
    free(g->msign);
}

/* ---- the surface leaves as a bitmap of max-depth cells ---------------------------- */

typedef struct cover {
    uint32_t n;
    unsigned char *bit; /* n^3 bytes, index (iz * n + iy) * n + ix */
} cover_t;

static void cover_init(cover_t *cv, const oct_tree_t *t)
{
    cv->n = 1u << t->depth;
    size_t total = (size_t)cv->n * cv->n * cv->n;
    cv->bit = calloc(total, 1);
    assert_non_null(cv->bit);
    for (uint32_t l = 0; l < t->n_leaves; l++) {
        const oct_leaf_t *lf = &t->leaves[l];
        assert_true(lf->depth <= t->depth);
        uint32_t ix, iy, iz;
        oct_unmorton(lf->code, lf->depth, &ix, &iy, &iz);
        int sh = t->depth - lf->depth;
        for (uint32_t z = iz << sh; z < (iz + 1) << sh; z++)
            for (uint32_t y = iy << sh; y < (iy + 1) << sh; y++)
                for (uint32_t x = ix << sh; x < (ix + 1) << sh; x++)
                    cv->bit[((size_t)z * cv->n + y) * cv->n + x] = 1;
    }
}

static int covered(const cover_t *cv, uint32_t x, uint32_t y, uint32_t z)
{
    return cv->bit[((size_t)z * cv->n + y) * cv->n + x];
}

/* Cells (at most 2) whose closed extent along an axis holds sample index i. */
static int cells_of_sample(uint32_t i, uint32_t n, uint32_t out[2])
{
    int k = 0;
    if (i % 4 == 0) {
        if (i / 4 >= 1)
            out[k++] = i / 4 - 1;
        if (i / 4 < n)
            out[k++] = i / 4;
    } else {
        out[k++] = i / 4;
    }
    return k;
}

/* Is any closed cell of the product covered? */
static int any_covered(const cover_t *cv, const uint32_t *cx, int nx, const uint32_t *cy, int ny,
                       const uint32_t *cz, int nz)
{
    for (int a = 0; a < nx; a++)
        for (int b = 0; b < ny; b++)
            for (int c = 0; c < nz; c++)
                if (covered(cv, cx[a], cy[b], cz[c]))
                    return 1;
    return 0;
}

/* Cells (at most 2) whose closed extent along axis a holds coordinate v. */
static int cells_of_coord(const grid_t *g, int a, double v, uint32_t out[2])
{
    const double *b = g->cb[a];
    if (!(v >= b[0] && v <= b[g->n]))
        return 0;
    uint32_t lo = 0, hi = g->n; /* b[lo] <= v <= b[hi] */
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (b[mid] <= v)
            lo = mid;
        else
            hi = mid;
    }
    int k = 0;
    if (lo > 0 && b[lo] == v)
        out[k++] = lo - 1;
    out[k++] = lo;
    return k;
}

/* ---- the checks -------------------------------------------------------------------- */

typedef struct result {
    long segments, zeros, line_points, empty_checked, empty_skipped, undefined_checked;
    long failures;
} result_t;

static void report(result_t *r, const char *fmt, ...)
{
    if (r->failures++ < MAX_REPORTS) {
        va_list ap;
        va_start(ap, fmt);
        vprintf(fmt, ap);
        va_end(ap);
        printf("\n");
    }
}

static void check_sign_changes(grid_t *g, const cover_t *cv, const char *what, result_t *r)
{
    uint32_t m = g->m;
    for (uint32_t k = 0; k <= m; k++)
        for (uint32_t j = 0; j <= m; j++)
            for (uint32_t i = 0; i <= m; i++) {
                uint32_t p[3] = {i, j, k};
                int s = sample_sign(g, i, j, k);
                if (s == S_UNDEF)
                    continue;
                if (s == S_ZERO) {
                    uint32_t c[3][2];
                    int nc[3];
                    for (int a = 0; a < 3; a++)
                        nc[a] = cells_of_sample(p[a], g->n, c[a]);
                    r->zeros++;
                    if (!any_covered(cv, c[0], nc[0], c[1], nc[1], c[2], nc[2]))
                        report(r, "%s: possible zero at (%.17g, %.17g, %.17g) (f = %g) in no surface leaf",
                               what, g->c[0][i], g->c[1][j], g->c[2][k], g->f[gidx(g, i, j, k)]);
                    continue;
                }
                for (int a = 0; a < 3; a++) {
                    if (p[a] == m)
                        continue;
                    uint32_t q[3] = {i, j, k};
                    q[a]++;
                    int t = sample_sign(g, q[0], q[1], q[2]);
                    if (t == S_UNDEF || t == S_ZERO || t == s)
                        continue;
                    /* the segment p..q holds a zero strictly inside */
                    r->segments++;
                    uint32_t c[3][2];
                    int nc[3];
                    for (int b = 0; b < 3; b++)
                        nc[b] = cells_of_sample(p[b], g->n, c[b]);
                    nc[a] = 1, c[a][0] = p[a] / 4;
                    if (!any_covered(cv, c[0], nc[0], c[1], nc[1], c[2], nc[2])) {
                        /* before blaming the octree, certify both signs in MPFI */
                        int ms = sample_mpfi_sign(g, i, j, k);
                        int mt = sample_mpfi_sign(g, q[0], q[1], q[2]);
                        if ((ms == S_POS && mt == S_NEG) || (ms == S_NEG && mt == S_POS))
                            report(r,
                                   "%s: sign change along %c between (%.17g, %.17g, %.17g) "
                                   "f=%g and (%.17g, %.17g, %.17g) f=%g in no surface leaf",
                                   what, "xyz"[a], g->c[0][i], g->c[1][j], g->c[2][k],
                                   g->f[gidx(g, i, j, k)], g->c[0][q[0]], g->c[1][q[1]],
                                   g->c[2][q[2]], g->f[gidx(g, q[0], q[1], q[2])]);
                    }
                }
            }
}

/* A point where f = 0 must lie in a closed cell covered by a surface leaf. */
static void check_zero_point(const grid_t *g, const cover_t *cv, const double p[3],
                             const char *what, result_t *r)
{
    /* the line is exactly on the surface: make sure, in MPFI */
    assert_int_equal(mpfi_sign(g->tape, p), S_ZERO);
    uint32_t c[3][2];
    int nc[3];
    for (int a = 0; a < 3; a++) {
        nc[a] = cells_of_coord(g, a, p[a], c[a]);
        assert_true(nc[a] > 0);
    }
    r->line_points++;
    if (!any_covered(cv, c[0], nc[0], c[1], nc[1], c[2], nc[2]))
        report(r, "%s: zero-line point (%.17g, %.17g, %.17g) in no surface leaf", what, p[0],
               p[1], p[2]);
}

/* Zero lines without sign change: axis a (0, 1, 2) through the origin, t in [t0, t1]. */
static void check_zero_line(const grid_t *g, const cover_t *cv, int a, double t0, double t1,
                            const char *what, result_t *r)
{
    uint64_t rng = tu_seed(0x5eedull + (uint64_t)a);
    double lo = fmax(t0, g->box[2 * a]), hi = fmin(t1, g->box[2 * a + 1]);
    int npts = (int)(LINE_POINTS * tu_scale());
    for (int s = 0; s < npts; s++) {
        double p[3] = {0, 0, 0};
        p[a] = lo + (hi - lo) * tu_uniform(&rng);
        check_zero_point(g, cv, p, what, r);
    }
    /* every cell bound and every sample on the line: the points shared by cells */
    for (uint32_t i = 0; i <= g->m; i++) {
        double p[3] = {0, 0, 0};
        p[a] = g->c[a][i];
        if (p[a] >= lo && p[a] <= hi)
            check_zero_point(g, cv, p, what, r);
    }
}

typedef struct empty_cell {
    uint32_t ix, iy, iz, cls;
    int depth;
    size_t sample; /* grid index of its centre */
} empty_cell_t;

/* Walk the nodes from the root, checking the structure on the way, and list the
 * empty cells. */
static empty_cell_t *walk_tree(const grid_t *g, const oct_tree_t *t, size_t *n_empty)
{
    struct {
        uint32_t node, ix, iy, iz;
        int depth;
    } stack[8 * (OCT_MAX_DEPTH + 2)];
    size_t n = 0, cap = 1024;
    empty_cell_t *list = malloc(cap * sizeof *list);
    assert_non_null(list);
    int sp = 0;
    stack[sp].node = 0, stack[sp].ix = stack[sp].iy = stack[sp].iz = 0, stack[sp].depth = 0;
    sp++;
    long leaves_seen = 0;
    while (sp > 0) {
        sp--;
        uint32_t node = stack[sp].node, ix = stack[sp].ix, iy = stack[sp].iy, iz = stack[sp].iz;
        int d = stack[sp].depth;
        assert_true(node < t->n_nodes);
        oct_node_t v = t->nodes[node];
        uint32_t val = OCT_NODE_VALUE(v);
        switch (OCT_NODE_KIND(v)) {
        case OCT_INTERIOR:
            assert_true(d < t->depth);
            assert_true(val + 8 <= t->n_nodes);
            for (int k = 0; k < 8; k++) {
                stack[sp].node = val + (uint32_t)k;
                stack[sp].ix = 2 * ix + (k & 1u);
                stack[sp].iy = 2 * iy + (k >> 1 & 1u);
                stack[sp].iz = 2 * iz + (k >> 2 & 1u);
                stack[sp].depth = d + 1;
                sp++;
            }
            break;
        case OCT_LEAF:
            assert_true(val < t->n_leaves);
            assert_true(t->leaves[val].depth == d);
            assert_true(t->leaves[val].code == oct_morton(ix, iy, iz, d));
            leaves_seen++;
            break;
        case OCT_EMPTY: {
            assert_true(val <= OCT_UNDEFINED);
            /* the centre is a sample of the grid: index (2i+1) 2^(D+1-d) at depth D+2 */
            int sh = g->depth + 1 - d;
            uint32_t ci = (2 * ix + 1) << sh, cj = (2 * iy + 1) << sh, ck = (2 * iz + 1) << sh;
            iv_box_t b = oct_cell_box(t->box, d, ix, iy, iz);
            double cx = g->c[0][ci], cy = g->c[1][cj], cz = g->c[2][ck];
            assert_true(b.x.lo < cx && cx < b.x.hi && b.y.lo < cy && cy < b.y.hi &&
                        b.z.lo < cz && cz < b.z.hi);
            if (n == cap) {
                cap *= 2;
                list = realloc(list, cap * sizeof *list);
                assert_non_null(list);
            }
            list[n++] = (empty_cell_t){ix, iy, iz, val, d, gidx(g, ci, cj, ck)};
            break;
        }
        default:
            fail_msg("bad node kind");
        }
    }
    assert_int_equal(leaves_seen, t->n_leaves);
    *n_empty = n;
    return list;
}

/* The class of every empty cell against the MPFI sign of f at its centre. */
static void check_empty_cells(grid_t *g, const oct_tree_t *t, const char *what, result_t *r)
{
    size_t n;
    empty_cell_t *e = walk_tree(g, t, &n);
    /* the MPFI signs not known yet, each once, evaluated on every core */
    size_t *todo = malloc((n ? n : 1) * sizeof *todo), ntodo = 0;
    assert_non_null(todo);
    for (size_t i = 0; i < n; i++)
        if (g->msign[e[i].sample] == S_UNKNOWN) {
            g->msign[e[i].sample] = S_UNKNOWN + 1; /* queued */
            todo[ntodo++] = e[i].sample;
        }
    size_t s1 = (size_t)g->m + 1;
#pragma omp parallel for schedule(dynamic, 16)
    for (size_t i = 0; i < ntodo; i++) {
        size_t q = todo[i];
        double p[3] = {g->c[0][q % s1], g->c[1][q / s1 % s1], g->c[2][q / s1 / s1]};
        g->msign[q] = (signed char)mpfi_sign(g->tape, p);
    }
    g->mpfi_calls += (long)ntodo;
    free(todo);

    for (size_t i = 0; i < n; i++) {
        int s = g->msign[e[i].sample];
        uint32_t cls = e[i].cls;
        size_t q = e[i].sample;
        double cx = g->c[0][q % s1], cy = g->c[1][q / s1 % s1], cz = g->c[2][q / s1 / s1];
        if (cls == OCT_UNDEFINED) {
            r->undefined_checked++;
            if (s != S_UNDEF)
                report(r, "%s: cell depth %d (%u,%u,%u) is undefined but f is defined at its centre",
                       what, e[i].depth, e[i].ix, e[i].iy, e[i].iz);
        } else if (s == S_ZERO || s == S_UNDEF) {
            r->empty_skipped++;
        } else {
            r->empty_checked++;
            uint32_t want = s == S_POS ? OCT_OUTSIDE : OCT_INSIDE;
            if (cls != want)
                report(r, "%s: cell depth %d (%u,%u,%u) classified %s but f %s 0 at its centre "
                          "(%.17g, %.17g, %.17g)",
                       what, e[i].depth, e[i].ix, e[i].iy, e[i].iz,
                       cls == OCT_INSIDE ? "inside" : "outside", s == S_POS ? ">" : "<", cx, cy,
                       cz);
        }
    }
    free(e);
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Checks 1-3 on a scene, for both test lists; returns the empty cells found
 * undefined. */
static long check_loaded(const scene_t *sp, const char *name, int depth)
{
    scene_t s = *sp;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    long undefined = 0;
    grid_t g;
    double t0 = omp_get_wtime();
    grid_init(&g, &s, depth);
    double t_grid = omp_get_wtime() - t0, t_build = 0, t_sign = 0, t_empty = 0;

    /* the chain of the issue (interval; interval, lipschitz), then the whole
     * chain with ILIE, without and with early leaves (refine: 2% of the box's
     * largest edge) */
    static const unsigned configs[4] = {OCT_TEST_INTERVAL, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ,
                                        OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE,
                                        OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE};
    static const char *const names[4] = {"interval", "interval,lipschitz",
                                         "interval,lipschitz,ilie", "all, refine"};
    double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
    for (int c = 0; c < 4; c++) {
        char what[256];
        snprintf(what, sizeof what, "%s [%s]", name, names[c]);
        oct_params_t p = {.depth = depth, .tests = configs[c], .refine = c == 3 ? 0.02 * edge : 0,
                          .threads = 2};
        oct_tree_t *t;
        double t1 = omp_get_wtime();
        if (oct_build(s.tape, s.box, &p, &t, &err) != 0)
            fail_msg("%s: oct_build: %s", what, err.msg);
        t_build += omp_get_wtime() - t1;
        cover_t cv;
        cover_init(&cv, t);
        result_t r = {0};

        t1 = omp_get_wtime();
        check_sign_changes(&g, &cv, what, &r);
        if (!strcmp(name, "crosscap.ini")) {
            check_zero_line(&g, &cv, 2, -INFINITY, INFINITY, what, &r);
        } else if (!strcmp(name, "steiner-roman.ini")) {
            for (int a = 0; a < 3; a++)
                check_zero_line(&g, &cv, a, -INFINITY, INFINITY, what, &r);
        } else if (!strcmp(name, "whitney-umbrella.ini")) {
            check_zero_line(&g, &cv, 2, -INFINITY, 0.0, what, &r); /* the handle */
            check_zero_line(&g, &cv, 2, 0.0, INFINITY, what, &r);
        }
        t_sign += omp_get_wtime() - t1;
        t1 = omp_get_wtime();
        check_empty_cells(&g, t, what, &r);
        t_empty += omp_get_wtime() - t1;

        printf("%-44s D=%d leaves %6u  sign-change segments %7ld  zero samples %5ld  "
               "line points %5ld  empty cells checked %6ld (skipped %ld, undefined %ld)\n",
               what, depth, t->n_leaves, r.segments, r.zeros, r.line_points, r.empty_checked,
               r.empty_skipped, r.undefined_checked);
        fflush(stdout);
        if (r.failures)
            fail_msg("%s: %ld failures (first ones above)", what, r.failures);
        /* not vacuous: every scene's surface crosses its box, and most of the
         * box is decided empty with a certifiable sign */
        assert_true(r.segments > 0);
        assert_true(r.empty_checked > 0);
        undefined += r.undefined_checked;
        oct_free(t);
        free(cv.bit);
    }
    printf("%-44s %ld MPFI evaluations; time: sampling %.2f s, builds %.2f s, "
           "sign changes %.2f s, empty cells %.2f s\n",
           name, g.mpfi_calls, t_grid, t_build, t_sign, t_empty);
    grid_free(&g);
    return undefined;
}

static void check_scene(const char *path, int depth)
{
    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(path, &s, &err) != 0) {
        char buf[1024];
        fail_msg("cannot load %s: %s", path, ivoct_error_format(&err, buf, sizeof buf));
    }
    check_loaded(&s, base_name(path), depth);
    scene_free(&s);
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    assert_true(n >= 19);
    int depth = depth_for_run();
    int seen_lines = 0;
    for (int i = 0; i < n; i++) {
        const char *b = base_name(paths[i]);
        seen_lines += !strcmp(b, "crosscap.ini") || !strcmp(b, "steiner-roman.ini") ||
                      !strcmp(b, "whitney-umbrella.ini");
        check_scene(paths[i], depth);
    }
    assert_int_equal(seen_lines, 3);
    tu_free_list(paths, n);
}

/* Surfaces that end at the edge of f's domain: cells where f is defined
 * nowhere must be OCT_UNDEFINED (and f undefined at their centres), and the
 * surface must still be covered up to the domain's edge.  f is continuous
 * where defined, so a sign change between two defined samples is a zero. */
static void test_domain_edges(void **state)
{
    (void)state;
    static const struct {
        const char *f;
        double box[6];
    } cases[] = {
        {"sqrt(x) + y^2 + z^2 - 0.5", {-1, 1, -1, 1, -1, 1}},
        {"log(x) + y^2 + z^2", {-1, 2, -1, 1, -1, 1}},
        {"sqrt(1 - x^2 - y^2 - z^2) - 0.5", {-1.5, 1.5, -1.5, 1.5, -1.5, 1.5}},
    };
    int depth = depth_for_run();
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_from_expr(cases[i].f, cases[i].box, &s, &err) != 0)
            fail_msg("%s: %s", cases[i].f, err.msg);
        long undefined = check_loaded(&s, cases[i].f, depth);
        assert_true(undefined > 0); /* not vacuous */
        scene_free(&s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_domain_edges),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
