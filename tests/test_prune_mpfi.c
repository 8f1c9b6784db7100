/* Property tests of tape pruning (expr/tape.h: tape_eval_interval_choices and
 * tape_prune) against an MPFI oracle.
 *
 * tape.h promises that the tape pruned with the choices of a box "equals t at
 * every point of the box where t is defined".  For every scene whose tape has
 * choices (min, max, abs) and for expressions that exercise them in many ways
 * (CSG unions, intersections and differences of spheres and boxes, abs of
 * signed expressions, nested and shared min/max, a min or max with an operand
 * that is undefined on part of the box or has a pole): random boxes of many
 * sizes (the whole box down to 2^-30 of it, one in 16 a point), their choices
 * from batches of 13 boxes (not a multiple of 8: the evaluators pad the
 * batch), each box's pruned tape, and at points of the box (corners, centre,
 * faces, inside), with each end of the interval constants, in MPFI at 256 bits:
 *   1. where the original tape is defined the pruned one is too, and their two
 *      enclosures intersect (at a point they denote the same real);
 *   2. tape_eval_interval of the pruned tape over the box holds both values
 *      (the pruned tape is a valid tape of f over the box);
 *   3. the pruned tape is a tape: 1 <= n <= t->n, operands before their clause;
 *   4. every choice is what tape.h documents, recomputed from the operands'
 *      enclosures (the prefix of the tape that ends at an operand is a tape
 *      whose value is that operand), and does not depend on the batch.
 * And pruning earns its keep: on the 64-sphere union, boxes of 1/16 of the
 * scene box keep less than half of the clauses on average; every CSG
 * expression keeps fewer than all.  Hand-made boxes check the documented
 * choices exactly. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

enum { BATCH = 13 }; /* not a multiple of 8: the evaluators pad the batch */

/* MPFI clause evaluations per tape (times tu_scale()): the original and the
 * pruned tape at each point, with both ends of the constants.  The number of
 * boxes follows, between a floor and a cap. */
#define PRUNE_BUDGET 400000L
#define PRUNE_POINTS 12 /* corners, centre, 3 on faces or inside */
#define PRUNE_MAX_BOXES 520
#define PRUNE_MIN_BOXES (2 * BATCH)

/* A failure message with MPFR values (%Rg): cmocka's fail_msg knows only printf's formats. */
#define FAIL_MP(...)                                                                       \
    do {                                                                                   \
        char msg_[2048];                                                                   \
        mpfr_snprintf(msg_, sizeof msg_, __VA_ARGS__);                                     \
        fail_msg("%s", msg_);                                                              \
    } while (0)

/* ---- sampling ------------------------------------------------------------------------------- */

/* frac > 0: a box of that fraction of the scene box per axis; else a random
 * fraction 2^-30..1, one box in 16 a point.  Placed uniformly inside. */
static iv_box_t random_box(const double box[6], double frac, uint64_t *rng)
{
    iv_t r[3];
    int point = 0;
    if (!(frac > 0)) {
        frac = exp2(-30.0 * tu_uniform(rng));
        point = tu_next(rng) % 16 == 0;
    }
    for (int k = 0; k < 3; k++) {
        double lo = box[2 * k], hi = box[2 * k + 1], w = (hi - lo) * frac;
        double a = tu_lerp(lo, hi - w, tu_uniform(rng));
        double e = point ? a : fmin(a + w, hi);
        r[k] = iv_make(a, e < a ? a : e);
    }
    return (iv_box_t){r[0], r[1], r[2]};
}

static const char *box_str(char *buf, size_t n, const iv_box_t *b)
{
    snprintf(buf, n, "[%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g]", b->x.lo, b->x.hi,
             b->y.lo, b->y.hi, b->z.lo, b->z.hi);
    return buf;
}

static int same_iv(iv_t a, iv_t b)
{
    return (iv_is_empty(a) && iv_is_empty(b)) || (a.lo == b.lo && a.hi == b.hi);
}

/* ---- the documented choices ----------------------------------------------------------------- */

/* The choice tape.h documents for clause c given its operands' enclosures. */
static uint8_t documented_choice(const tape_clause_t *c, iv_t A, iv_t B)
{
    /* comparisons with NaN are false: an empty operand decides nothing */
    switch ((tape_op_t)c->op) {
    case TAPE_MIN:
        return A.hi <= B.lo ? TAPE_CHOICE_A : B.hi <= A.lo ? TAPE_CHOICE_B : TAPE_CHOICE_BOTH;
    case TAPE_MAX:
        return A.lo >= B.hi ? TAPE_CHOICE_A : B.lo >= A.hi ? TAPE_CHOICE_B : TAPE_CHOICE_BOTH;
    case TAPE_ABS:
        return A.lo >= 0 ? TAPE_CHOICE_A : A.hi <= 0 ? TAPE_CHOICE_NEG_A : TAPE_CHOICE_BOTH;
    default:
        return TAPE_CHOICE_BOTH; /* not a choice */
    }
}

/* The enclosure of slot i over n boxes: the prefix of the tape ending at
 * clause i is a tape whose value is slot i. */
static void slot_enclosure(const tape_t *t, tape_ws_t *ws, uint32_t i, size_t n,
                           const iv_box_t *boxes, iv_t *out)
{
    tape_t prefix = {t->clauses, i + 1};
    tape_eval_interval(&prefix, ws, n, boxes, out);
}

/* Property 4 on a batch: the choices of every box are the documented ones. */
static void check_documented_choices(const tape_t *t, tape_ws_t *ws, size_t n,
                                     const iv_box_t *boxes, const uint8_t *choices,
                                     const char *what)
{
    iv_t A[BATCH], B[BATCH];
    char b1[256];
    assert_true(n <= BATCH);
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        int choice = c->op == TAPE_MIN || c->op == TAPE_MAX || c->op == TAPE_ABS;
        if (choice) {
            slot_enclosure(t, ws, c->a, n, boxes, A);
            if (c->op != TAPE_ABS)
                slot_enclosure(t, ws, c->b, n, boxes, B);
        }
        for (size_t k = 0; k < n; k++) {
            uint8_t want = choice ? documented_choice(c, A[k], c->op == TAPE_ABS ? A[k] : B[k])
                                  : TAPE_CHOICE_BOTH;
            uint8_t got = choices[k * t->n + i];
            if (got != want)
                fail_msg("%s: box %s, clause %u (%s): choice %u, documented %u (A = [%.17g, "
                         "%.17g], B = [%.17g, %.17g])",
                         what, box_str(b1, sizeof b1, &boxes[k]), i,
                         tape_op_name((tape_op_t)c->op), got, want, choice ? A[k].lo : 0,
                         choice ? A[k].hi : 0, choice && c->op != TAPE_ABS ? B[k].lo : 0,
                         choice && c->op != TAPE_ABS ? B[k].hi : 0);
        }
    }
}

/* Property 3: out is a tape of at most t->n clauses. */
static void check_is_tape(const tape_t *t, const tape_t *out, const char *what)
{
    assert_true(out->n >= 1);
    assert_true(out->n <= t->n);
    for (uint32_t i = 0; i < out->n; i++) {
        const tape_clause_t *c = &out->clauses[i];
        if (c->op >= TAPE_OP_COUNT)
            fail_msg("%s: pruned clause %u has op %u", what, i, c->op);
        int arity = tape_op_arity((tape_op_t)c->op);
        if ((arity >= 1 && c->a >= i) || (arity == 2 && c->b >= i))
            fail_msg("%s: pruned clause %u (%s) reads slots %u, %u", what, i,
                     tape_op_name((tape_op_t)c->op), c->a, c->b);
    }
}

/* ---- the MPFI checks ------------------------------------------------------------------------ */

typedef struct {
    long boxes, points, skipped, decided;
    double before, after; /* clause counts summed over the boxes */
} counts_t;

typedef struct {
    mpfi_t v0, v1, s;
} mp_t;

/* Properties 1 and 2 at npts points of box; F the pruned tape's enclosure. */
static void check_points(const tape_t *t, const tape_t *out, const iv_box_t *box, iv_t F,
                         long npts, uint64_t *rng, mp_t *m, counts_t *c, const char *what)
{
    char b1[256];
    for (long j = 0; j < npts; j++) {
        double p[3];
        tu_box_point(box, (int)j, rng, p);
        for (int w = 0; w < 2; w++) {
            oracle_const_t which = w ? ORACLE_CONST_HI : ORACLE_CONST_LO;
            if (oracle_eval(t, p, which, m->v0, NULL) != 0) {
                c->skipped++;
                continue;
            }
            c->points++;
            if (oracle_eval(out, p, which, m->v1, NULL) != 0)
                FAIL_MP("%s: box %s: f(%.17g, %.17g, %.17g) = %.17Rg (constants at their %s "
                        "ends) but the pruned tape (%u of %u clauses) is undefined there",
                        what, box_str(b1, sizeof b1, box), p[0], p[1], p[2], &m->v0->left,
                        w ? "upper" : "lower", out->n, t->n);
            mpfi_intersect(m->s, m->v0, m->v1);
            if (mpfi_is_empty(m->s))
                FAIL_MP("%s: box %s: at (%.17g, %.17g, %.17g) (constants at their %s ends) "
                        "f = [%.17Rg, %.17Rg] but the pruned tape (%u of %u clauses) gives "
                        "[%.17Rg, %.17Rg]",
                        what, box_str(b1, sizeof b1, box), p[0], p[1], p[2],
                        w ? "upper" : "lower", &m->v0->left, &m->v0->right, out->n, t->n,
                        &m->v1->left, &m->v1->right);
            if (!oracle_contained(m->v0, F) || !oracle_contained(m->v1, F))
                FAIL_MP("%s: box %s: f(%.17g, %.17g, %.17g) = %.17Rg (pruned %.17Rg) not in "
                        "the pruned tape's enclosure [%.17g, %.17g]",
                        what, box_str(b1, sizeof b1, box), p[0], p[1], p[2], &m->v0->left,
                        &m->v1->left, F.lo, F.hi);
        }
    }
}

/* nbox boxes of box (frac as random_box), in batches; every property. */
static void check_tape(const tape_t *t, const double box[6], double frac, long nbox,
                       long npts, uint64_t *rng, counts_t *c, const char *what)
{
    tape_ws_t *ws = tape_ws_new(t->n);
    uint8_t *choices = malloc((size_t)BATCH * t->n);
    uint8_t *one = malloc(t->n);
    uint32_t *scratch = malloc(3 * sizeof *scratch * t->n);
    tape_t out = {malloc(t->n * sizeof(tape_clause_t)), 0};
    assert_true(ws && choices && one && scratch && out.clauses);
    mp_t m;
    mpfi_init2(m.v0, ORACLE_PREC);
    mpfi_init2(m.v1, ORACLE_PREC);
    mpfi_init2(m.s, ORACLE_PREC);
    char b1[256];
    for (long done = 0; done < nbox; done += BATCH) {
        iv_box_t boxes[BATCH];
        iv_t F[BATCH], F2[BATCH];
        for (int k = 0; k < BATCH; k++)
            boxes[k] = random_box(box, frac, rng);
        /* every entry is written: no byte may keep this filler */
        memset(choices, 0xA5, (size_t)BATCH * t->n);
        tape_eval_interval_choices(t, ws, BATCH, boxes, F, choices);
        /* the same enclosures as tape_eval_interval */
        tape_eval_interval(t, ws, BATCH, boxes, F2);
        for (int k = 0; k < BATCH; k++)
            if (!same_iv(F[k], F2[k]))
                fail_msg("%s: box %s: with choices [%.17g, %.17g], without [%.17g, %.17g]",
                         what, box_str(b1, sizeof b1, &boxes[k]), F[k].lo, F[k].hi, F2[k].lo,
                         F2[k].hi);
        check_documented_choices(t, ws, BATCH, boxes, choices, what);
        for (int k = 0; k < BATCH; k++) {
            const uint8_t *ch = choices + (size_t)k * t->n;
            /* a box's choices do not depend on its batch (every 4th batch) */
            if ((done / BATCH) % 4 == 0) {
                iv_t F1;
                tape_eval_interval_choices(t, ws, 1, &boxes[k], &F1, one);
                if (memcmp(one, ch, t->n) != 0 || !same_iv(F1, F[k]))
                    fail_msg("%s: box %s: choices differ alone and as box %d of a batch", what,
                             box_str(b1, sizeof b1, &boxes[k]), k);
            }
            for (uint32_t i = 0; i < t->n; i++)
                c->decided += ch[i] != TAPE_CHOICE_BOTH;
            tape_prune(t, ch, scratch, &out);
            check_is_tape(t, &out, what);
            c->boxes++;
            c->before += t->n;
            c->after += out.n;
            iv_t Fp;
            tape_eval_interval(&out, ws, 1, &boxes[k], &Fp);
            check_points(t, &out, &boxes[k], Fp, npts, rng, &m, c, what);
        }
    }
    mpfi_clear(m.v0);
    mpfi_clear(m.v1);
    mpfi_clear(m.s);
    free(out.clauses);
    free(scratch);
    free(one);
    free(choices);
    tape_ws_free(ws);
}

static long boxes_for(uint32_t nclauses, long npts)
{
    /* ~1.5 tapes' worth of clauses per point and constant end (the pruned one is shorter) */
    double n = (double)PRUNE_BUDGET * tu_scale() / (3.0 * nclauses * npts);
    long m = n > PRUNE_MAX_BOXES ? PRUNE_MAX_BOXES : (long)n;
    m = (m + BATCH - 1) / BATCH * BATCH;
    return m < PRUNE_MIN_BOXES ? PRUNE_MIN_BOXES : m;
}

static void print_counts(const char *what, const tape_t *t, const counts_t *c)
{
    printf("%-44.44s %4u clauses %5ld boxes %6ld points %5ld skipped %6ld decided, "
           "mean pruned length %.1f\n",
           what, t->n, c->boxes, c->points, c->skipped, c->decided,
           c->boxes ? c->after / (double)c->boxes : 0.0);
}

/* ---- every scene with choices --------------------------------------------------------------- */

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    assert_true(n >= 19);
    uint64_t rng = tu_seed(20261401);
    int visited = 0, with_choices = 0;
    long total_points = 0;
    for (int i = 0; i < n; i++) {
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_load(paths[i], &s, &err) != 0) {
            char buf[1024];
            fail_msg("cannot load %s: %s", paths[i], ivoct_error_format(&err, buf, sizeof buf));
        }
        visited++;
        const char *base = strrchr(paths[i], '/');
        base = base ? base + 1 : paths[i];
        if (!tape_has_choices(s.tape)) {
            /* nothing to prune: the choices are all BOTH, and the pruned
             * tape is a tape of f (checked at a few points) */
            counts_t c = {0};
            check_tape(s.tape, s.box, 0, BATCH, 2, &rng, &c, base);
            assert_true(c.decided == 0);
            scene_free(&s);
            continue;
        }
        with_choices++;
        long nbox = boxes_for(s.tape->n, PRUNE_POINTS);
        counts_t c = {0};
        check_tape(s.tape, s.box, 0, nbox, PRUNE_POINTS, &rng, &c, base);
        print_counts(base, s.tape, &c);
        assert_true(c.points > c.boxes); /* the scenes are defined on most of their box */
        assert_true(c.decided > 0);
        total_points += c.points;
        scene_free(&s);
    }
    printf("%d scenes, %d with choices, %ld points checked\n", visited, with_choices,
           total_points);
    assert_int_equal(visited, n);
    assert_true(with_choices >= 2); /* csg-64-spheres, thin-shell */
    tu_free_list(paths, n);
}

/* ---- expressions exercising min, max and abs ------------------------------------------------ */

typedef struct {
    const char *text;
    int csg; /* pruning must shorten the tape on average over boxes 1/16 of the box */
} prune_expr_t;

static const prune_expr_t exprs[] = {
    /* CSG: unions, intersections, differences of spheres, boxes, a cylinder */
    {"min(min(x^2 + y^2 + z^2 - 1, (x - 1.5)^2 + y^2 + z^2 - 0.5), "
     "(x + 1)^2 + (y - 1)^2 + z^2 - 0.3)", 1},
    {"max(max(abs(x) - 1, abs(y) - 0.5), abs(z) - 0.7)", 1},
    {"max(x^2 + y^2 + z^2 - 1, -max(max(abs(x - 0.5) - 0.4, abs(y) - 0.4), abs(z) - 0.4))", 1},
    {"max((x - 0.3)^2 + y^2 + z^2 - 1, (x + 0.3)^2 + y^2 + z^2 - 1)", 1},
    {"min(max(max(abs(x) - 0.5, abs(y) - 0.5), abs(z) - 0.5), "
     "max(sqrt((x - 1)^2 + y^2) - 0.3, abs(z) - 1))", 1},
    {"max(min(x - 0.1, 0.3 - x), min(y + 0.2, 0.1 - y))", 1},
    {"min(min(min((x-1)^2 + y^2 + z^2 - 0.2, (x+1)^2 + y^2 + z^2 - 0.2), "
     "min(x^2 + (y-1)^2 + z^2 - 0.2, x^2 + (y+1)^2 + z^2 - 0.2)), "
     "max(x^2 + y^2 + z^2 - 0.5, -(x^2 + y^2 + z^2 - 0.3)))", 1},
    /* abs of signed expressions */
    {"abs(x*y - z) - 0.1", 0},
    {"abs(abs(x) - abs(y)) - z + 0.1*abs(sin(3*x))", 0},
    {"abs(x^3 - 3*x*y^2 + 0.1) - abs(z) + 0.2", 0},
    /* nested and shared min/max */
    {"min(max(x, y), max(min(y, z), x - z))", 1},
    {"max(min(x, min(y, z)), -max(x, max(y, z)) + 0.5)", 1},
    {"min(x*y, z) + max(x*y, z) - abs(x*y)", 0},
    {"min(x, y) - max(x, y) + abs(min(x, y))", 0},
    {"max(min(x^2 - y, z), min(max(y - z^2, x), abs(x + y + z) - 1))", 1},
    /* an operand undefined on part of the box, or with a pole */
    {"min(sqrt(x), y)", 0},
    {"max(log(y), x - 1) + z", 0},
    {"min(sqrt(x^2 - 0.25), abs(z) - 0.5) - y", 0},
    {"min(1/x, y) + z", 0},
    {"abs(sqrt(x) - y) - 0.2", 0},
    {"max(log(x + y), min(sqrt(z), x*y)) - 0.5", 0},
    {"min(x^2 + y^2 - 1, z) + 0.1*abs(sin(3*x + y))", 0},
};

static const double expr_box[6] = {-2, 2, -2, 2, -2, 2};

static void test_expressions(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(20261402);
    long skipped = 0;
    for (size_t e = 0; e < sizeof exprs / sizeof *exprs; e++) {
        tape_t *t = tu_compile(exprs[e].text);
        assert_true(tape_has_choices(t));
        counts_t c = {0};
        check_tape(t, expr_box, 0, boxes_for(t->n, PRUNE_POINTS), PRUNE_POINTS, &rng, &c,
                   exprs[e].text);
        print_counts(exprs[e].text, t, &c);
        assert_true(c.points > 0);
        assert_true(c.decided > 0);
        skipped += c.skipped;
        /* the boxes of 1/16 of the box: sizes where a CSG branch is decided */
        counts_t s = {0};
        check_tape(t, expr_box, 1.0 / 16, 2 * BATCH, 4, &rng, &s, exprs[e].text);
        printf("%-44.44s   boxes 1/16: mean pruned length %.2f of %u\n", exprs[e].text,
               s.after / (double)s.boxes, t->n);
        if (exprs[e].csg)
            assert_true(s.after < s.before);
        tape_free(t);
    }
    assert_true(skipped > 0); /* the undefined parts are reached */
}

/* ---- pruning earns its keep on the 64-sphere union ------------------------------------------ */

static void test_csg_64_spheres(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("csg-64-spheres", &s);
    uint64_t rng = tu_seed(20261403);
    long nbox = tu_sanitizer_build() ? 2 * BATCH : 16 * BATCH;
    counts_t c = {0};
    check_tape(s.tape, s.box, 1.0 / 16, nbox, 3, &rng, &c, "csg-64-spheres, boxes 1/16");
    double mean = c.after / (double)c.boxes;
    printf("csg-64-spheres: %u clauses; boxes of 1/16 of the box: mean pruned length %.1f "
           "(%.1f%%), %ld points checked\n",
           s.tape->n, mean, 100.0 * mean / s.tape->n, c.points);
    /* in a box an eighth of the sphere spacing wide, only the nearest spheres
     * can be the minimum: most of the 63 min clauses and their spheres go */
    assert_true(mean < 0.5 * s.tape->n);
    scene_free(&s);
}

/* ---- the documented choices on hand-made boxes ---------------------------------------------- */

/* The index of the only clause of op op in t. */
static uint32_t clause_of(const tape_t *t, tape_op_t op)
{
    uint32_t found = UINT32_MAX;
    for (uint32_t i = 0; i < t->n; i++)
        if (t->clauses[i].op == (uint32_t)op) {
            assert_true(found == UINT32_MAX);
            found = i;
        }
    assert_true(found != UINT32_MAX);
    return found;
}

/* The choice of the clause of op op of text over box, evaluated alone and
 * as the last box (in the short chunk) of a batch of 13. */
static uint8_t choice_over(const tape_t *t, tape_op_t op, iv_box_t box)
{
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    uint8_t *ch = malloc((size_t)BATCH * t->n);
    assert_non_null(ch);
    iv_box_t boxes[BATCH];
    iv_t F[BATCH];
    for (int k = 0; k < BATCH; k++)
        boxes[k] = (iv_box_t){iv_make(-k, k), iv_make(k, 2 * k + 1), iv_make(0, 1)};
    boxes[BATCH - 1] = box;
    memset(ch, 0xA5, (size_t)BATCH * t->n);
    tape_eval_interval_choices(t, ws, BATCH, boxes, F, ch);
    uint32_t i = clause_of(t, op);
    uint8_t batched = ch[(size_t)(BATCH - 1) * t->n + i];
    memset(ch, 0xA5, t->n);
    tape_eval_interval_choices(t, ws, 1, &box, F, ch);
    assert_int_equal(ch[i], batched);
    for (uint32_t j = 0; j < t->n; j++)
        if (j != i)
            assert_int_equal(ch[j], TAPE_CHOICE_BOTH); /* not choices */
    uint8_t r = ch[i];
    free(ch);
    tape_ws_free(ws);
    return r;
}

/* For min/max: the operand of the clause whose op is winner is the value, or
 * BOTH when winner is TAPE_OP_COUNT.  (The compiler may order the operands
 * either way: min(x, y) and min(y, x) are one clause.) */
static void expect_min_max(const char *text, tape_op_t op, iv_box_t box, tape_op_t winner)
{
    tape_t *t = tu_compile(text);
    uint8_t got = choice_over(t, op, box);
    const tape_clause_t *c = &t->clauses[clause_of(t, op)];
    uint8_t want = TAPE_CHOICE_BOTH;
    if (winner != TAPE_OP_COUNT) {
        assert_true(t->clauses[c->a].op == (uint32_t)winner ||
                    t->clauses[c->b].op == (uint32_t)winner);
        want = t->clauses[c->a].op == (uint32_t)winner ? TAPE_CHOICE_A : TAPE_CHOICE_B;
    }
    if (got != want)
        fail_msg("%s over [%g, %g] x [%g, %g] x [%g, %g]: choice %u, want %u", text, box.x.lo,
                 box.x.hi, box.y.lo, box.y.hi, box.z.lo, box.z.hi, got, want);
    tape_free(t);
}

static void expect_abs(const char *text, iv_box_t box, uint8_t want)
{
    tape_t *t = tu_compile(text);
    uint8_t got = choice_over(t, TAPE_ABS, box);
    if (got != want)
        fail_msg("%s over [%g, %g] x [%g, %g] x [%g, %g]: choice %u, want %u", text, box.x.lo,
                 box.x.hi, box.y.lo, box.y.hi, box.z.lo, box.z.hi, got, want);
    tape_free(t);
}

static iv_box_t B3(double x0, double x1, double y0, double y1)
{
    return (iv_box_t){iv_make(x0, x1), iv_make(y0, y1), iv_make(0, 1)};
}

static tape_t prune_over(const tape_t *t, iv_box_t box)
{
    tape_ws_t *ws = tape_ws_new(t->n);
    uint8_t *ch = malloc(t->n);
    uint32_t *scratch = malloc(3 * sizeof *scratch * t->n);
    tape_t out = {malloc(t->n * sizeof(tape_clause_t)), 0};
    assert_true(ws && ch && scratch && out.clauses);
    iv_t F;
    tape_eval_interval_choices(t, ws, 1, &box, &F, ch);
    tape_prune(t, ch, scratch, &out);
    free(scratch);
    free(ch);
    tape_ws_free(ws);
    return out;
}

static void test_hand_choices(void **state)
{
    (void)state;
    /* min(a, b) takes a where A.hi <= B.lo, b where B.hi <= A.lo */
    expect_min_max("min(x, y)", TAPE_MIN, B3(0, 1, 2, 3), TAPE_X);
    expect_min_max("min(x, y)", TAPE_MIN, B3(2, 3, 0, 1), TAPE_Y);
    expect_min_max("min(y, x)", TAPE_MIN, B3(0, 1, 2, 3), TAPE_X);
    /* overlapping ranges: either can be the minimum somewhere, BOTH */
    expect_min_max("min(x, y)", TAPE_MIN, B3(0, 2, 1, 3), TAPE_OP_COUNT);
    expect_min_max("min(x, y)", TAPE_MIN, B3(0, 1, 0, 1), TAPE_OP_COUNT);
    /* touching ranges (the branches tie at x = y = 1 only): A.hi <= B.lo
     * holds, so tape.h's rule decides x, which is the minimum everywhere */
    expect_min_max("min(x, y)", TAPE_MIN, B3(0, 1, 1, 2), TAPE_X);
    /* max likewise */
    expect_min_max("max(x, y)", TAPE_MAX, B3(2, 3, 0, 1), TAPE_X);
    expect_min_max("max(x, y)", TAPE_MAX, B3(0, 1, 2, 3), TAPE_Y);
    expect_min_max("max(x, y)", TAPE_MAX, B3(0, 2, 1, 3), TAPE_OP_COUNT);
    expect_min_max("max(x, y)", TAPE_MAX, B3(1, 2, 0, 1), TAPE_X);
    /* abs(a): a where A.lo >= 0, -a where A.hi <= 0 */
    expect_abs("abs(x)", B3(-2, -1, 0, 1), TAPE_CHOICE_NEG_A);
    expect_abs("abs(x)", B3(1, 2, 0, 1), TAPE_CHOICE_A);
    expect_abs("abs(x)", B3(0, 1, 0, 1), TAPE_CHOICE_A);
    expect_abs("abs(x)", B3(-1, 0, 0, 1), TAPE_CHOICE_NEG_A);
    expect_abs("abs(x)", B3(-1, 1, 0, 1), TAPE_CHOICE_BOTH);
    /* an empty operand (sqrt, log of negatives: f defined nowhere) decides nothing */
    expect_min_max("min(sqrt(x), y)", TAPE_MIN, B3(-2, -1, 0, 1), TAPE_OP_COUNT);
    expect_min_max("max(y, log(x))", TAPE_MAX, B3(-2, -1, 0, 1), TAPE_OP_COUNT);
    expect_abs("abs(log(x))", B3(-2, -1, 0, 1), TAPE_CHOICE_BOTH);
    expect_abs("abs(sqrt(x) - 3)", B3(-2, -1, 0, 1), TAPE_CHOICE_BOTH);
    /* a defined operand next to one defined on part of the box: decided on the part */
    expect_min_max("min(sqrt(x), y)", TAPE_MIN, B3(-1, 1, 2, 3), TAPE_SQRT);

    /* the pruned tapes of the documented rewrites */
    tape_t *t = tu_compile("min(x, y)");
    tape_t out = prune_over(t, B3(0, 1, 2, 3)); /* min(x, y) becomes x */
    assert_int_equal(out.n, 1);
    assert_int_equal(out.clauses[0].op, TAPE_X);
    free(out.clauses);
    out = prune_over(t, B3(0, 2, 1, 3)); /* undecided: unchanged */
    assert_int_equal(out.n, t->n);
    free(out.clauses);
    tape_free(t);
    t = tu_compile("abs(x)");
    out = prune_over(t, B3(-2, -1, 0, 1)); /* abs(x) becomes -x */
    assert_int_equal(out.n, 2);
    assert_int_equal(out.clauses[0].op, TAPE_X);
    assert_int_equal(out.clauses[1].op, TAPE_NEG);
    assert_int_equal(out.clauses[1].a, 0);
    free(out.clauses);
    out = prune_over(t, B3(1, 2, 0, 1)); /* abs(x) becomes x */
    assert_int_equal(out.n, 1);
    assert_int_equal(out.clauses[0].op, TAPE_X);
    free(out.clauses);
    tape_free(t);
    /* a chain: min(min(x, y), z) with x the least becomes x; y and z go */
    t = tu_compile("min(min(x, y), z)");
    out = prune_over(t, (iv_box_t){iv_make(0, 1), iv_make(2, 3), iv_make(4, 5)});
    assert_int_equal(out.n, 1);
    assert_int_equal(out.clauses[0].op, TAPE_X);
    free(out.clauses);
    tape_free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hand_choices),
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_expressions),
        cmocka_unit_test(test_csg_64_spheres),
    };
    /* IVOCT_TEST_FILTER=test_expressions runs one test (a cmocka pattern) */
    const char *filter = getenv("IVOCT_TEST_FILTER");
    if (filter && *filter)
        cmocka_set_test_filter(filter);
    return cmocka_run_group_tests(tests, NULL, NULL);
}
