/* The no-missed-cell check (see coverage.h); moved here from
 * tests/test_octree_coverage.c so that the stability suite runs the same one. */
#include "coverage.h"

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

#include "mpfi_tape.h"
#include "testutil.h"

#define LINE_POINTS 2000 /* random points per zero line */
#define MAX_REPORTS 5

size_t cov_gidx(const cov_grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    size_t s = (size_t)g->m + 1;
    return ((size_t)k * s + j) * s + i;
}

int cov_mpfi_sign(const tape_t *t, const double p[3])
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

int cov_sample_mpfi_sign(cov_grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    size_t q = cov_gidx(g, i, j, k);
    if (g->msign[q] == S_UNKNOWN) {
        double p[3] = {g->c[0][i], g->c[1][j], g->c[2][k]};
        g->msign[q] = (signed char)cov_mpfi_sign(g->tape, p);
        g->mpfi_calls++;
    }
    return g->msign[q];
}

static int sample_sign(cov_grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    size_t q = cov_gidx(g, i, j, k);
    if (g->sign[q] == S_UNKNOWN) {
        double v = g->f[q];
        if (isnan(v)) /* undefined, or nearly: skipped, which can only weaken the check */
            g->sign[q] = S_UNDEF;
        else if (fabs(v) > g->thr)
            g->sign[q] = v > 0 ? S_POS : S_NEG;
        else
            g->sign[q] = (signed char)cov_sample_mpfi_sign(g, i, j, k);
    }
    return g->sign[q];
}

void cov_grid_init_window(cov_grid_t *g, const tape_t *tape, const double box[6], int depth,
                          const uint32_t i0[3], uint32_t n)
{
    memset(g, 0, sizeof *g);
    g->depth = depth;
    g->n = n;
    g->m = 4 * n;
    g->tape = tape;
    memcpy(g->box, box, sizeof g->box);
    for (int a = 0; a < 3; a++) {
        g->i0[a] = i0[a];
        assert_true((uint64_t)i0[a] + n <= (1ull << depth));
    }
    size_t s1 = (size_t)g->m + 1, total = s1 * s1 * s1;
    for (int a = 0; a < 3; a++) {
        g->c[a] = malloc(s1 * sizeof *g->c[a]);
        g->cb[a] = malloc(((size_t)g->n + 1) * sizeof *g->cb[a]);
        assert_non_null(g->c[a]);
        assert_non_null(g->cb[a]);
        for (uint32_t i = 0; i <= g->m; i++)
            g->c[a][i] = oct_coord(box[2 * a], box[2 * a + 1], 4 * (uint64_t)i0[a] + i, depth + 2);
        for (uint32_t i = 0; i <= g->n; i++) {
            g->cb[a][i] = oct_coord(box[2 * a], box[2 * a + 1], (uint64_t)i0[a] + i, depth);
            /* the property the whole check relies on: same fraction, same double */
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

    tape_ws_t *ws = tape_ws_new(tape->n);
    assert_non_null(ws);
    double *y = malloc(s1 * sizeof *y), *z = malloc(s1 * sizeof *z);
    assert_non_null(y);
    assert_non_null(z);
    double scale = 0;
    for (uint32_t k = 0; k <= g->m; k++)
        for (uint32_t j = 0; j <= g->m; j++) {
            for (uint32_t i = 0; i <= g->m; i++)
                y[i] = g->c[1][j], z[i] = g->c[2][k];
            double *out = g->f + cov_gidx(g, 0, j, k);
            tape_eval_point(tape, ws, s1, g->c[0], y, z, out);
            for (uint32_t i = 0; i <= g->m; i++)
                if (isfinite(out[i]) && fabs(out[i]) > scale)
                    scale = fabs(out[i]);
        }
    g->thr = 1e-9 * scale;
    free(y);
    free(z);
    tape_ws_free(ws);
}

void cov_grid_init(cov_grid_t *g, const tape_t *tape, const double box[6], int depth)
{
    const uint32_t zero[3] = {0, 0, 0};
    cov_grid_init_window(g, tape, box, depth, zero, 1u << depth);
}

void cov_grid_free(cov_grid_t *g)
{
    for (int a = 0; a < 3; a++) {
        free(g->c[a]);
        free(g->cb[a]);
    }
    free(g->f);
    free(g->sign);
    free(g->msign);
}

/* ---- the surface leaves as sorted ranges of max-depth cells ------------------------- */

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

void cov_cover_init(cov_cover_t *cv, const oct_tree_t *t)
{
    cv->depth = t->depth;
    cv->n = t->n_leaves;
    /* pairs (lo, hi) sorted by lo: leaves are disjoint, so the his follow */
    uint64_t *pair = malloc((cv->n ? cv->n : 1) * 2 * sizeof *pair);
    assert_non_null(pair);
    for (uint32_t l = 0; l < t->n_leaves; l++) {
        const oct_leaf_t *lf = &t->leaves[l];
        assert_true(oct_leaf_depth(lf) <= t->depth);
        int sh = 3 * (t->depth - oct_leaf_depth(lf));
        pair[2 * l] = oct_leaf_code(lf) << sh;
        pair[2 * l + 1] = (oct_leaf_code(lf) + 1) << sh;
    }
    qsort(pair, cv->n, 2 * sizeof *pair, cmp_u64);
    cv->lo = malloc((cv->n ? cv->n : 1) * sizeof *cv->lo);
    cv->hi = malloc((cv->n ? cv->n : 1) * sizeof *cv->hi);
    assert_non_null(cv->lo);
    assert_non_null(cv->hi);
    for (size_t l = 0; l < cv->n; l++) {
        cv->lo[l] = pair[2 * l];
        cv->hi[l] = pair[2 * l + 1];
        assert_true(l == 0 || cv->lo[l] >= cv->hi[l - 1]); /* disjoint */
    }
    free(pair);
}

void cov_cover_free(cov_cover_t *cv)
{
    free(cv->lo);
    free(cv->hi);
}

int cov_covered(const cov_cover_t *cv, uint32_t x, uint32_t y, uint32_t z)
{
    uint64_t code = oct_morton(x, y, z, cv->depth);
    size_t lo = 0, hi = cv->n; /* first range with lo > code */
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (cv->lo[mid] <= code)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo > 0 && code < cv->hi[lo - 1];
}

/* Global cells (at most 2) whose closed extent along an axis holds sample index i of
 * the window starting at cell i0. */
static int cells_of_sample(const cov_grid_t *g, int a, uint32_t i, uint32_t out[2])
{
    int k = 0;
    uint64_t n_all = 1ull << g->depth, c = g->i0[a] + (uint64_t)(i / 4);
    if (i % 4 == 0) {
        if (c >= 1)
            out[k++] = (uint32_t)(c - 1);
        if (c < n_all)
            out[k++] = (uint32_t)c;
    } else {
        out[k++] = (uint32_t)c;
    }
    return k;
}

/* Is any closed cell of the product covered? */
static int any_covered(const cov_cover_t *cv, const uint32_t *cx, int nx, const uint32_t *cy,
                       int ny, const uint32_t *cz, int nz)
{
    for (int a = 0; a < nx; a++)
        for (int b = 0; b < ny; b++)
            for (int c = 0; c < nz; c++)
                if (cov_covered(cv, cx[a], cy[b], cz[c]))
                    return 1;
    return 0;
}

/* Global cell indices [*first, *last] whose closed extent along axis a meets [lo, hi]
 * (within the window); 0 when none does. */
static int cells_of_range(const cov_grid_t *g, int a, double lo, double hi, uint32_t *first,
                          uint32_t *last)
{
    const double *b = g->cb[a];
    if (!(hi >= b[0] && lo <= b[g->n]))
        return 0;
    uint32_t f = 0, l = g->n - 1;
    while (f + 1 < g->n && b[f + 1] < lo) /* cell f ends before lo */
        f++;
    while (l > f && b[l] > hi) /* cell l starts after hi */
        l--;
    *first = g->i0[a] + f, *last = g->i0[a] + l;
    return 1;
}

/* ---- the checks -------------------------------------------------------------------- */

void cov_report(cov_result_t *r, const char *fmt, ...)
{
    if (r->failures++ < MAX_REPORTS) {
        va_list ap;
        va_start(ap, fmt);
        vprintf(fmt, ap);
        va_end(ap);
        printf("\n");
    }
}

void cov_check_sign_changes(cov_grid_t *g, const cov_cover_t *cv, const char *what,
                            cov_result_t *r)
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
                        nc[a] = cells_of_sample(g, a, p[a], c[a]);
                    r->zeros++;
                    if (!any_covered(cv, c[0], nc[0], c[1], nc[1], c[2], nc[2]))
                        cov_report(r,
                                   "%s: possible zero at (%.17g, %.17g, %.17g) (f = %g) in no "
                                   "surface leaf",
                                   what, g->c[0][i], g->c[1][j], g->c[2][k],
                                   g->f[cov_gidx(g, i, j, k)]);
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
                        nc[b] = cells_of_sample(g, b, p[b], c[b]);
                    nc[a] = 1, c[a][0] = g->i0[a] + p[a] / 4;
                    if (!any_covered(cv, c[0], nc[0], c[1], nc[1], c[2], nc[2])) {
                        /* before blaming the octree, certify both signs in MPFI */
                        int ms = cov_sample_mpfi_sign(g, i, j, k);
                        int mt = cov_sample_mpfi_sign(g, q[0], q[1], q[2]);
                        if ((ms == S_POS && mt == S_NEG) || (ms == S_NEG && mt == S_POS))
                            cov_report(r,
                                       "%s: sign change along %c between (%.17g, %.17g, %.17g) "
                                       "f=%g and (%.17g, %.17g, %.17g) f=%g in no surface leaf",
                                       what, "xyz"[a], g->c[0][i], g->c[1][j], g->c[2][k],
                                       g->f[cov_gidx(g, i, j, k)], g->c[0][q[0]],
                                       g->c[1][q[1]], g->c[2][q[2]],
                                       g->f[cov_gidx(g, q[0], q[1], q[2])]);
                    }
                }
            }
}

void cov_check_box(const cov_grid_t *g, const cov_cover_t *cv, const double lo[3],
                   const double hi[3], const char *what, cov_result_t *r)
{
    uint32_t f[3], l[3];
    for (int a = 0; a < 3; a++)
        if (!cells_of_range(g, a, lo[a], hi[a], &f[a], &l[a]))
            fail_msg("%s: box [%.17g, %.17g] outside the grid's window along %c", what, lo[a],
                     hi[a], "xyz"[a]);
    r->point_boxes++;
    for (uint32_t z = f[2]; z <= l[2]; z++)
        for (uint32_t y = f[1]; y <= l[1]; y++)
            for (uint32_t x = f[0]; x <= l[0]; x++)
                if (cov_covered(cv, x, y, z))
                    return;
    cov_report(r, "%s: surface point in [%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g] in "
                  "no surface leaf",
               what, lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]);
}

void cov_check_zero_point(const cov_grid_t *g, const cov_cover_t *cv, const double p[3],
                          const char *what, cov_result_t *r)
{
    /* the point is exactly on the surface: make sure, in MPFI */
    assert_int_equal(cov_mpfi_sign(g->tape, p), S_ZERO);
    r->line_points++;
    long before = r->point_boxes;
    cov_check_box(g, cv, p, p, what, r);
    r->point_boxes = before;
}

void cov_check_zero_line(const cov_grid_t *g, const cov_cover_t *cv, int a, double t0,
                         double t1, const char *what, cov_result_t *r)
{
    uint64_t rng = tu_seed(0x5eedull + (uint64_t)a);
    double lo = fmax(t0, g->c[a][0]), hi = fmin(t1, g->c[a][g->m]);
    int npts = (int)(LINE_POINTS * tu_scale());
    for (int s = 0; s < npts; s++) {
        double p[3] = {0, 0, 0};
        p[a] = lo + (hi - lo) * tu_uniform(&rng);
        cov_check_zero_point(g, cv, p, what, r);
    }
    /* every cell bound and every sample on the line: the points shared by cells */
    for (uint32_t i = 0; i <= g->m; i++) {
        double p[3] = {0, 0, 0};
        p[a] = g->c[a][i];
        if (p[a] >= lo && p[a] <= hi)
            cov_check_zero_point(g, cv, p, what, r);
    }
}

typedef struct empty_cell {
    uint32_t ix, iy, iz, cls;
    int depth;
    size_t sample; /* grid index of its centre */
} empty_cell_t;

/* Walk the nodes from the root, checking the structure on the way, and list the
 * empty cells. */
static empty_cell_t *walk_tree(const cov_grid_t *g, const oct_tree_t *t, size_t *n_empty)
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
            assert_true(oct_leaf_depth(&t->leaves[val]) == d);
            assert_true(oct_leaf_code(&t->leaves[val]) == oct_morton(ix, iy, iz, d));
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
            list[n++] = (empty_cell_t){ix, iy, iz, val, d, cov_gidx(g, ci, cj, ck)};
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

void cov_check_empty_cells(cov_grid_t *g, const oct_tree_t *t, const char *what,
                           cov_result_t *r)
{
    assert_true(g->i0[0] == 0 && g->i0[1] == 0 && g->i0[2] == 0 &&
                g->n == 1u << g->depth); /* whole-box grids only */
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
        g->msign[q] = (signed char)cov_mpfi_sign(g->tape, p);
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
                cov_report(r,
                           "%s: cell depth %d (%u,%u,%u) is undefined but f is defined at its "
                           "centre",
                           what, e[i].depth, e[i].ix, e[i].iy, e[i].iz);
        } else if (s == S_ZERO || s == S_UNDEF) {
            r->empty_skipped++;
        } else {
            r->empty_checked++;
            uint32_t want = s == S_POS ? OCT_OUTSIDE : OCT_INSIDE;
            if (cls != want)
                cov_report(r,
                           "%s: cell depth %d (%u,%u,%u) classified %s but f %s 0 at its centre "
                           "(%.17g, %.17g, %.17g)",
                           what, e[i].depth, e[i].ix, e[i].iy, e[i].iz,
                           cls == OCT_INSIDE ? "inside" : "outside", s == S_POS ? ">" : "<", cx,
                           cy, cz);
        }
    }
    free(e);
}

void cov_check_all(const tape_t *tape, const double box[6], const char *name, int depth,
                   unsigned cfgs, const cov_line_t *lines, int n_lines, cov_summary_t *out)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    memset(out, 0, sizeof *out);
    out->min_segments = out->min_empty_checked = -1;
    cov_grid_t g;
    double t0 = omp_get_wtime();
    cov_grid_init(&g, tape, box, depth);
    double t_grid = omp_get_wtime() - t0, t_build = 0, t_sign = 0, t_empty = 0;

    /* the scenes' chains (interval; interval, lipschitz), then the whole
     * chain with ILIE, without and with early leaves (refine: 2% of the box's
     * largest edge) */
    static const unsigned configs[4] = {OCT_TEST_INTERVAL, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ,
                                        OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE,
                                        OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE};
    static const char *const names[4] = {"interval", "interval,lipschitz",
                                         "interval,lipschitz,ilie", "all, refine"};
    double edge = fmax(box[1] - box[0], fmax(box[3] - box[2], box[5] - box[4]));
    for (int c = 0; c < 4; c++) {
        if (!(cfgs & 1u << c))
            continue;
        char what[256];
        snprintf(what, sizeof what, "%s [%s]", name, names[c]);
        oct_params_t p = {.depth = depth, .tests = configs[c], .refine = c == 3 ? 0.02 * edge : 0,
                          .threads = 2};
        oct_tree_t *t;
        double t1 = omp_get_wtime();
        if (oct_build(tape, box, &p, &t, &err) != 0)
            fail_msg("%s: oct_build: %s", what, err.msg);
        t_build += omp_get_wtime() - t1;
        cov_cover_t cv;
        cov_cover_init(&cv, t);
        cov_result_t r = {0};

        t1 = omp_get_wtime();
        cov_check_sign_changes(&g, &cv, what, &r);
        for (int l = 0; l < n_lines; l++)
            cov_check_zero_line(&g, &cv, lines[l].axis, lines[l].t0, lines[l].t1, what, &r);
        t_sign += omp_get_wtime() - t1;
        t1 = omp_get_wtime();
        if (!(cfgs & COV_NO_EMPTY))
            cov_check_empty_cells(&g, t, what, &r);
        t_empty += omp_get_wtime() - t1;

        printf("%-44s D=%d leaves %6u  sign-change segments %7ld  zero samples %5ld  "
               "line points %5ld  empty cells checked %6ld (skipped %ld, undefined %ld)\n",
               what, depth, t->n_leaves, r.segments, r.zeros, r.line_points, r.empty_checked,
               r.empty_skipped, r.undefined_checked);
        fflush(stdout);
        out->segments += r.segments;
        out->zeros += r.zeros;
        out->line_points += r.line_points;
        out->empty_checked += r.empty_checked;
        out->undefined += r.undefined_checked;
        out->failures += r.failures;
        out->leaves = t->n_leaves;
        out->max_error_bound = fmax(out->max_error_bound, t->stats.max_error_bound);
        if (out->min_segments < 0 || r.segments < out->min_segments)
            out->min_segments = r.segments;
        if (out->min_empty_checked < 0 || r.empty_checked < out->min_empty_checked)
            out->min_empty_checked = r.empty_checked;
        oct_free(t);
        cov_cover_free(&cv);
        if (r.failures)
            fail_msg("%s: %ld failures (first ones above)", what, r.failures);
    }
    out->build_s = t_build;
    printf("%-44s %ld MPFI evaluations; time: sampling %.2f s, builds %.2f s, "
           "sign changes %.2f s, empty cells %.2f s\n",
           name, g.mpfi_calls, t_grid, t_build, t_sign, t_empty);
    cov_grid_free(&g);
}
