/* Property tests of ilie/ (affine arithmetic, ILIE) against an MPFI oracle.
 *
 * For small expressions exercising every operation of the tape language, and
 * for every scene file: random cells (sizes from the whole box down to 2^-30
 * of it, one in 16 a point cell) evaluated in batches with ilie_eval, random
 * points in each cell (corners, faces, interior) evaluated in MPFI at 256 bits,
 * alternately with each end of the interval constants.  Properties:
 *   1. the MPFI value at p lies in ilie_at(l, p)             (the enclosure)
 *   2. ilie_excludes_box(l, cell) with sign s => the MPFI value has sign s
 *      strictly; J empty => f is defined at no sampled point
 *   3. every p with 0 ∈ a·(p − c) + J (decided in MPFI) lies in the slab of
 *      ilie_slab (n·p computed in MPFI within [d_lo, d_hi])
 *   4. a batch gives the same ILIEs, bit for bit, as one cell at a time
 * And unit tests of the queries, the workspace growth, and a tightness
 * property: on the unit sphere, for cells of width 1e-3 on the surface, w(J)
 * is below a tenth of the width of the interval enclosure. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../ilie/ilie.h"
#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

#define BATCH 13 /* not a multiple of 8: the evaluators pad the batch */

typedef struct {
    long cells, checked, skipped, excluded, slab_checked, fallback;
    char failure[1536];
} stats_t;

/* ---- sampling ------------------------------------------------------------------- */

/* ---- the properties for one cell ------------------------------------------------ */

typedef struct {
    mpfi_t v, s, t;
} scratch_t;

static void scratch_init(scratch_t *w)
{
    mpfi_init2(w->v, ORACLE_PREC);
    mpfi_init2(w->s, ORACLE_PREC);
    mpfi_init2(w->t, ORACLE_PREC);
}

static void scratch_clear(scratch_t *w)
{
    mpfi_clear(w->v);
    mpfi_clear(w->s);
    mpfi_clear(w->t);
}

static const char *describe(char *buf, size_t n, const iv_box_t *b, const ilie_t *l)
{
    snprintf(buf, n,
             "cell [%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g], "
             "a = (%.17g, %.17g, %.17g), J = [%.17g, %.17g]",
             b->x.lo, b->x.hi, b->y.lo, b->y.hi, b->z.lo, b->z.hi, l->a[0], l->a[1], l->a[2],
             l->J.lo, l->J.hi);
    return buf;
}

/* Returns 0 when every property holds at the points sampled in the cell. */
static int check_cell(const tape_t *t, const iv_box_t *cell, const ilie_t *l, int npoints,
                      uint64_t *rng, scratch_t *w, stats_t *st)
{
    char where[512];
    int sign = 0;
    bool excluded = ilie_excludes_box(l, cell, &sign);
    double n[3], d_lo, d_hi;
    ilie_slab(l, n, &d_lo, &d_hi);
    iv_t slab = iv_make(d_lo, d_hi);
    st->cells++;
    st->excluded += excluded;
    st->fallback += l->a[0] == 0.0 && l->a[1] == 0.0 && l->a[2] == 0.0;
    for (int j = 0; j < npoints; j++) {
        double p[3] = {tu_pick(cell->x, rng), tu_pick(cell->y, rng), tu_pick(cell->z, rng)};
        oracle_const_t which = (j & 1) ? ORACLE_CONST_HI : ORACLE_CONST_LO;
        if (oracle_eval(t, p, which, w->v, NULL) != 0) {
            st->skipped++;
            continue;
        }
        st->checked++;
        iv_t at = ilie_at(l, p);
        if (!oracle_contained(w->v, at)) {
            mpfr_snprintf(st->failure, sizeof st->failure,
                          "f(%.17g, %.17g, %.17g) = %.20RNg not in ilie_at = [%.17g, %.17g]; %s",
                          p[0], p[1], p[2], &w->v->left, at.lo, at.hi,
                          describe(where, sizeof where, cell, l));
            return 1;
        }
        if (excluded && !(sign > 0 ? mpfi_is_strictly_pos(w->v) : sign < 0 ? mpfi_is_strictly_neg(w->v) : 0)) {
            mpfr_snprintf(st->failure, sizeof st->failure,
                          "cell excluded with sign %d but f(%.17g, %.17g, %.17g) = %.20RNg; %s",
                          sign, p[0], p[1], p[2], &w->v->left,
                          describe(where, sizeof where, cell, l));
            return 1;
        }
        /* 0 ∈ a·(p − c) + J, decided at 256 bits */
        if (iv_is_empty(l->J) || !(l->J.lo >= -DBL_MAX && l->J.hi <= DBL_MAX))
            continue;
        mpfi_interv_d(w->s, l->J.lo, l->J.hi);
        for (int k = 0; k < 3; k++) {
            mpfi_set_d(w->t, p[k]);
            mpfi_sub_d(w->t, w->t, l->c[k]);
            mpfi_mul_d(w->t, w->t, l->a[k]);
            mpfi_add(w->s, w->s, w->t);
        }
        if (!mpfi_has_zero(w->s))
            continue;
        st->slab_checked++;
        mpfi_set_ui(w->s, 0);
        for (int k = 0; k < 3; k++) {
            mpfi_set_d(w->t, p[k]);
            mpfi_mul_d(w->t, w->t, n[k]);
            mpfi_add(w->s, w->s, w->t);
        }
        if (!oracle_contained(w->s, slab)) {
            mpfr_snprintf(st->failure, sizeof st->failure,
                          "p = (%.17g, %.17g, %.17g) with 0 in a(p-c)+J: n.p = %.20RNg not in "
                          "slab [%.17g, %.17g], n = (%.17g, %.17g, %.17g); %s",
                          p[0], p[1], p[2], &w->s->left, d_lo, d_hi, n[0], n[1], n[2],
                          describe(where, sizeof where, cell, l));
            return 1;
        }
    }
    return 0;
}

static int same_ilie(const ilie_t *a, const ilie_t *b)
{
    return memcmp(a, b, sizeof *a) == 0;
}

/* ncells random cells of box, npoints points each.  Returns 0 on success. */
static int check_tape(const tape_t *t, const double box[6], long ncells, int npoints,
                      uint64_t *rng, stats_t *st)
{
    memset(st, 0, sizeof *st);
    ilie_ws_t *ws = ilie_ws_new(t->n);
    ilie_ws_t *ws1 = ilie_ws_new(t->n);
    scratch_t w;
    scratch_init(&w);
    int fail = ws == NULL || ws1 == NULL;
    if (fail)
        snprintf(st->failure, sizeof st->failure, "out of memory");
    for (long done = 0; done < ncells && !fail; done += BATCH) {
        iv_box_t cells[BATCH];
        ilie_t out[BATCH];
        for (int i = 0; i < BATCH; i++)
            cells[i] = tu_random_subbox(box, rng);
        ilie_eval(t, ws, BATCH, cells, out);
        for (int i = 0; i < BATCH && !fail; i++) {
            /* property 4, on every 8th batch */
            if ((done / BATCH) % 8 == 0) {
                ilie_t one;
                ilie_eval(t, ws1, 1, &cells[i], &one);
                if (!same_ilie(&one, &out[i])) {
                    snprintf(st->failure, sizeof st->failure,
                             "cell %d of a batch differs from its evaluation alone", i);
                    fail = 1;
                    break;
                }
            }
            fail = check_cell(t, &cells[i], &out[i], npoints, rng, &w, st);
        }
    }
    scratch_clear(&w);
    ilie_ws_free(ws);
    ilie_ws_free(ws1);
    return fail;
}

/* ---- every operation -------------------------------------------------------------- */


/* the boxes of tu_op_boxes, and one more: a box of edge ~20 that straddles 0 */
static const double op_box_extra[6] = {-12, 9, -10, 11, -7, 13};

#define OP_CELLS 800
#define OP_POINTS 3

static void test_every_operation(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(20261201);
    size_t nexpr = tu_n_op_exprs;
    size_t nbox = TU_N_OP_BOXES + 1;
    long ncells = (long)(OP_CELLS * tu_scale());
    long total = 0, checked = 0, slab = 0;
    for (size_t i = 0; i < nexpr; i++) {
        tape_t *t = NULL;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (tape_compile(tu_op_exprs[i], &t, &err) != 0)
            fail_msg("cannot compile \"%s\": %s", tu_op_exprs[i], err.msg);
        for (size_t b = 0; b < nbox; b++) {
            stats_t st;
            const double *box = b < TU_N_OP_BOXES ? tu_op_boxes[b] : op_box_extra;
            if (check_tape(t, box, ncells, OP_POINTS, &rng, &st) != 0)
                fail_msg("\"%s\" on box %zu: %s", tu_op_exprs[i], b, st.failure);
            total += st.cells;
            checked += st.checked;
            slab += st.slab_checked;
        }
        tape_free(t);
    }
    printf("operations: %zu expressions x %zu boxes, %ld cells, %ld points checked, "
           "%ld in a slab\n",
           nexpr, nbox, total, checked, slab);
    assert_true(checked >= total); /* most points are defined */
}

/* ---- every scene ---------------------------------------------------------------------- */

#define SCENE_CELLS 10000
/* MPFI evaluations per scene: points per cell shrink with the tape's length */
#define SCENE_CLAUSE_BUDGET 600000L

static void check_scene(const char *path, uint64_t *rng)
{
    scene_t s;
    tu_load_scene(path, &s);
    long ncells = (long)(SCENE_CELLS * tu_scale());
    long budget = (long)(SCENE_CLAUSE_BUDGET * tu_scale());
    int npoints = (int)(budget / ((long)s.tape->n * ncells));
    npoints = npoints < 1 ? 1 : npoints > 2 ? 2 : npoints;
    stats_t st;
    if (check_tape(s.tape, s.box, ncells, npoints, rng, &st) != 0)
        fail_msg("%s: %s", path, st.failure);
    printf("%-34s %4u clauses %6ld cells %6ld points %5ld skipped %5ld excluded %4ld "
           "in slab %5ld no-slope\n",
           path, s.tape->n, st.cells, st.checked, st.skipped, st.excluded, st.slab_checked,
           st.fallback);
    assert_true(st.cells >= ncells);
    assert_true(st.checked >= (long)(0.9 * (double)ncells)); /* not vacuous */
    scene_free(&s);
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    uint64_t rng = tu_seed(20261202);
    for (int i = 0; i < n; i++)
        check_scene(paths[i], &rng);
    tu_free_list(paths, n);
}

/* ---- tightness: affine arithmetic earns its keep ------------------------------------------ */

static void test_sphere_tightness(void **state)
{
    (void)state;
    tape_t *t = NULL;
    ivoct_error_t err;
    assert_int_equal(tape_compile("x^2 + y^2 + z^2 - 1", &t, &err), 0);
    ilie_ws_t *ws = ilie_ws_new(t->n);
    tape_ws_t *tws = tape_ws_new(t->n);
    assert_non_null(ws);
    assert_non_null(tws);
    uint64_t rng = tu_seed(20261203);
    enum { N = 4000 };
    const double w = 1e-3;
    double worst = 0.0, worst_thick = 0.0;
    for (int done = 0; done < N; done += BATCH) {
        iv_box_t cells[BATCH];
        ilie_t out[BATCH];
        iv_t F[BATCH];
        for (int i = 0; i < BATCH; i++) {
            double d[3], s2 = 0.0;
            do {
                s2 = 0.0;
                for (int k = 0; k < 3; k++) {
                    d[k] = 2.0 * tu_uniform(&rng) - 1.0;
                    s2 += d[k] * d[k];
                }
            } while (s2 > 1.0 || s2 < 1e-4);
            double rad = (1.0 + w * (tu_uniform(&rng) - 0.5)) / sqrt(s2);
            iv_t side[3];
            for (int k = 0; k < 3; k++)
                side[k] = iv_make(d[k] * rad - w / 2, d[k] * rad + w / 2);
            cells[i] = (iv_box_t){side[0], side[1], side[2]};
        }
        ilie_eval(t, ws, BATCH, cells, out);
        tape_eval_interval(t, tws, BATCH, cells, F);
        for (int i = 0; i < BATCH; i++) {
            double ratio = iv_width(out[i].J) / (F[i].hi - F[i].lo);
            worst = ratio > worst ? ratio : worst;
            double th = ilie_thickness(&out[i]);
            worst_thick = th > worst_thick ? th : worst_thick;
            /* the ILIE's slope is the gradient 2p, to the cell's scale */
            for (int k = 0; k < 3; k++) {
                const iv_t *side = &cells[i].x + k;
                assert_true(fabs(out[i].a[k] - (side->lo + side->hi)) <= 1e-9);
            }
            assert_true(ratio < 0.1);
            /* the slab is far thinner than the cell */
            assert_true(th < w / 100);
        }
    }
    printf("sphere, cells of width 1e-3 on the surface: max w(J)/w(F) = %.3g, "
           "max thickness %.3g\n",
           worst, worst_thick);
    ilie_ws_free(ws);
    tape_ws_free(tws);
    tape_free(t);
}

/* ---- the queries on hand-made ILIEs --------------------------------------------------------- */

static void test_queries(void **state)
{
    (void)state;
    /* f(p) ∈ 2(x − 1) + [−0.5, 0.5] on the cell [0, 2] x [-1, 1] x [-1, 1] */
    ilie_t l = {{1, 0, 0}, {1, 1, 1}, {2, 0, 0}, {-0.5, 0.5}};
    iv_box_t cell = {{0, 2}, {-1, 1}, {-1, 1}};
    int sign = 7;
    assert_false(ilie_excludes_box(&l, &cell, &sign));
    assert_int_equal(sign, 0);
    iv_box_t right = {{1.5, 2}, {-1, 1}, {-1, 1}}; /* f >= 0.5 there */
    assert_true(ilie_excludes_box(&l, &right, &sign));
    assert_int_equal(sign, 1);
    iv_box_t left = {{0, 0.7}, {-1, 1}, {-1, 1}};
    assert_true(ilie_excludes_box(&l, &left, &sign));
    assert_int_equal(sign, -1);
    double p[3] = {1.5, 0.3, -0.2};
    iv_t at = ilie_at(&l, p);
    assert_true(at.lo <= 0.5 && at.lo > 0.49 && at.hi >= 1.5 && at.hi < 1.51);
    /* thickness w(J)/|a| = 0.5; slab x ∈ [0.75, 1.25] */
    double th = ilie_thickness(&l);
    assert_true(th >= 0.5 && th < 0.5 + 1e-12);
    double n[3], dl, dh;
    ilie_slab(&l, n, &dl, &dh);
    assert_true(fabs(n[0] - 1) < 1e-15 && n[1] == 0 && n[2] == 0);
    assert_true(dl <= 0.75 && dl > 0.75 - 1e-12 && dh >= 1.25 && dh < 1.25 + 1e-12);

    /* an oblique normal: the slab contains the exact plane's points */
    ilie_t o = {{0.3, -0.2, 0.1}, {0.25, 0.25, 0.25}, {1, 2, 3}, {-1e-3, 2e-3}};
    ilie_slab(&o, n, &dl, &dh);
    assert_true(fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1) < 1e-15);
    double nc = n[0] * 0.3 + n[1] * -0.2 + n[2] * 0.1;
    assert_true(dl < nc - 1e-3 / sqrt(14.0) * 0.99 && dh > nc + 1e-3 / sqrt(14.0) * 0.99);
    assert_true(dh - dl < 3e-3 / sqrt(14.0) + 1e-12);

    /* no slope: no information when 0 ∈ J, the empty slab otherwise */
    ilie_t flat = {{0, 0, 0}, {1, 1, 1}, {0, 0, 0}, {-1, 1}};
    assert_true(isinf(ilie_thickness(&flat)));
    ilie_slab(&flat, n, &dl, &dh);
    assert_true(dl == -INFINITY && dh == INFINITY);
    flat.J = iv_make(0.5, 1);
    ilie_slab(&flat, n, &dl, &dh);
    assert_true(dl > dh);
    assert_true(ilie_excludes_box(&flat, &cell, &sign));
    assert_int_equal(sign, 1);

    /* undefined everywhere: excluded, no side, empty slab */
    ilie_t none = {{0, 0, 0}, {1, 1, 1}, {0, 0, 0}, {NAN, NAN}};
    assert_true(ilie_excludes_box(&none, &cell, &sign));
    assert_int_equal(sign, 0);
    assert_true(iv_is_empty(ilie_at(&none, p)));
    assert_true(ilie_thickness(&none) == 0.0);
    ilie_slab(&none, n, &dl, &dh);
    assert_true(dl > dh);
}

/* A few exact expectations of ilie_eval. */
static void test_eval_basics(void **state)
{
    (void)state;
    ivoct_error_t err;
    tape_t *t = NULL;
    ilie_ws_t *ws = ilie_ws_new(1); /* too small: must grow */
    assert_non_null(ws);

    /* linear f: a exact, J tiny */
    assert_int_equal(tape_compile("2*x - 3*y + z + 1", &t, &err), 0);
    iv_box_t cell = {{0, 1}, {2, 4}, {-1, 0}};
    ilie_t l;
    ilie_eval(t, ws, 1, &cell, &l);
    assert_true(l.c[0] == 0.5 && l.c[1] == 3 && l.c[2] == -0.5);
    assert_true(l.a[0] == 2 && l.a[1] == -3 && l.a[2] == 1);
    /* f(c) = 1 - 9 - 0.5 + 1 = -7.5 */
    assert_true(iv_contains(l.J, -7.5) && iv_width(l.J) < 1e-13);
    tape_free(t);

    /* undefined on the whole cell: J empty */
    assert_int_equal(tape_compile("sqrt(x) + y", &t, &err), 0);
    iv_box_t neg = {{-2, -1}, {0, 1}, {0, 1}};
    ilie_eval(t, ws, 1, &neg, &l);
    assert_true(iv_is_empty(l.J));
    /* point cell: r = 0, a = 0 */
    iv_box_t pt = {{4, 4}, {1, 1}, {0, 0}};
    ilie_eval(t, ws, 1, &pt, &l);
    assert_true(l.r[0] == 0 && l.a[0] == 0 && l.a[1] == 0 && iv_contains(l.J, 3));
    tape_free(t);

    /* division by a range holding 0: the interval fallback */
    assert_int_equal(tape_compile("1/x", &t, &err), 0);
    iv_box_t zero = {{-1, 1}, {0, 1}, {0, 1}};
    ilie_eval(t, ws, 1, &zero, &l);
    assert_true(l.a[0] == 0 && l.J.lo == -INFINITY && l.J.hi == INFINITY);
    tape_free(t);

    /* min with the branch decided by the affine difference */
    assert_int_equal(tape_compile("min(x + y, x + y + 1e-9)", &t, &err), 0);
    iv_box_t big = {{-1e3, 1e3}, {-1e3, 1e3}, {0, 1}};
    ilie_eval(t, ws, 1, &big, &l);
    assert_true(fabs(l.a[0] - 1) < 1e-12 && fabs(l.a[1] - 1) < 1e-12 && iv_width(l.J) < 1e-9);
    tape_free(t);

    /* no ws or unusable: no information, never a crash */
    assert_int_equal(tape_compile("x", &t, &err), 0);
    ilie_eval(t, NULL, 1, &cell, &l);
    assert_true(l.J.lo == -INFINITY && l.J.hi == INFINITY);
    tape_free(t);
    ilie_ws_free(ws);
    ilie_ws_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_queries),
        cmocka_unit_test(test_eval_basics),
        cmocka_unit_test(test_sphere_tightness),
        cmocka_unit_test(test_every_operation),
        cmocka_unit_test(test_every_scene),
    };
    /* IVOCT_TEST_FILTER=test_every_scene runs one test (a cmocka pattern) */
    const char *filter = getenv("IVOCT_TEST_FILTER");
    if (filter && *filter)
        cmocka_set_test_filter(filter);
    return cmocka_run_group_tests(tests, NULL, NULL);
}
