/* The affine pass of every SIMD path against the scalar affine arithmetic, bit
 * for bit; and expr/lanes.h against interval.h.
 *
 * ilie/affine_kernels.h computes neg, add, sub, mul, sqr and integer powers in
 * lane loops that must give every lane exactly what the scalar aa_ functions
 * of ilie/affine.c give, and hands the lanes that leave the common path to
 * those functions (ilie/README.md).  Here every expression of tu_op_exprs and
 * the tape of every scene runs through the pass of each path this machine has
 * (not only the one IVOCT_SIMD picks), on batches of every size from 1 to
 * ILIE_BATCH, with random forms for x, y and z: cells of every scale, and the
 * forms that take the other exits (empty, unbounded, huge coefficients, flat
 * sides, ranges across 0, NaN and infinite coefficients).  Every slot of every
 * lane must equal the scalar evaluation of the same tape on the same forms:
 * the same doubles bit for bit (a NaN matches any NaN).
 *
 * iv_powi_lanes, iv_pow_bound_lanes and iv_pow_bound_lanes_dir (expr/lanes.h)
 * must give the bounds of iv_powi and of the binary exponentiation it uses
 * (the last with a random direction per lane), for random intervals of every
 * sign and scale and every exponent 3..64.  ilie_excludes_boxes must
 * answer as ilie_excludes_box, and ilie_ws_bytes say what a workspace takes
 * from the heap. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <malloc.h>

#include "../expr/lanes.h"
#include "../ilie/affine.h"
#include "../ilie/ilie.h"
#include "../scene/scene.h"
#include "support/testutil.h"

/* ---- the passes of this build and machine ---------------------------------------- */

typedef struct {
    const char *name;
    ilie_pass_fn *pass;
} path_t;

static int machine_paths(path_t out[3])
{
    int n = 0;
    out[n++] = (path_t){"portable", ilie_lanes_portable.pass};
#ifdef IVOCT_SIMD_X86
    if (tape_simd_available("avx2"))
        out[n++] = (path_t){"avx2", ilie_lanes_avx2.pass};
    if (tape_simd_available("avx512"))
        out[n++] = (path_t){"avx512", ilie_lanes_avx512.pass};
#endif
    return n;
}

/* ---- random forms ------------------------------------------------------------------ */

/* A double of random sign and magnitude, with the special values now and then. */
static double random_value(uint64_t *rng)
{
    static const double special[] = {0.0, -0.0, 0x1p-1074, 0x1p-1022, 1.0, 0x1p1023, INFINITY,
                                     NAN};
    uint64_t r = tu_next(rng);
    if (r % 8 == 0)
        return (r & 8 ? -1.0 : 1.0) * special[(r >> 4) % 8];
    double mag = pow(10.0, -320.0 + 630.0 * tu_uniform(rng));
    return (r & 16 ? -1.0 : 1.0) * mag;
}

/* Scales of the cells: ordinary, small around 0, large, near overflow, tiny. */
static const double SCALES[] = {1.0, 1e-3, 1e3, 1e150, 1e300, 1e-300, 1e-160};

/* Variable d's form on a random cell side: as ilie.c frames it (centre, radius
 * pushed up), or a flat side. */
static aa_t cell_form(int d, uint64_t *rng)
{
    double s = SCALES[tu_next(rng) % (sizeof SCALES / sizeof *SCALES)];
    double lo = s * (2.0 * tu_uniform(rng) - 1.0);
    double hi = tu_next(rng) % 8 == 0 ? lo : lo + s * tu_uniform(rng) * pow(2.0, -30.0 * tu_uniform(rng));
    if (!(hi <= DBL_MAX))
        hi = DBL_MAX;
    double c = 0.5 * lo + 0.5 * hi;
    double w = c - lo > hi - c ? c - lo : hi - c;
    double r = w > 0.0 ? iv_up(w) : 0.0;
    aa_t f;
    aa_var(&f, d, c, r <= DBL_MAX ? r : 0.0, iv_make(lo, hi));
    return f;
}

static aa_t random_form(int d, uint64_t *rng)
{
    aa_t f;
    uint64_t kind = tu_next(rng) % 16;
    if (kind < 8)
        return cell_form(d, rng);
    switch (kind) {
    case 8: aa_from_iv(&f, iv_empty()); return f;
    case 9: aa_from_iv(&f, iv_entire()); return f;
    case 10: aa_from_iv(&f, iv_make(-INFINITY, random_value(rng))); return f;
    case 11: { /* an interval form of any scale */
        double a = random_value(rng), b = random_value(rng);
        aa_from_iv(&f, iv_make(a < b ? a : b, a < b ? b : a));
        return f;
    }
    default: /* any coefficients, any error term, any enclosure */
        for (int i = 0; i < 4; i++)
            f.x[i] = tu_next(rng) % 4 ? random_value(rng) : 0.0;
        f.e = fabs(random_value(rng));
        if (tu_next(rng) % 2)
            f.e = 0.0;
        double a = random_value(rng), b = random_value(rng);
        f.v = tu_next(rng) % 8 ? iv_make(a < b ? a : b, a < b ? b : a) : iv_empty();
        return f;
    }
}

/* ---- the scalar reference ------------------------------------------------------------ */

/* Clause i of t on lane forms: what affine.c computes (the pass's contract). */
static aa_t scalar_clause(const tape_t *t, uint32_t i, const aa_t *slot, const aa_t var[3])
{
    const tape_clause_t *cl = &t->clauses[i];
    const aa_t *a = &slot[cl->a], *b = &slot[cl->b];
    aa_t z;
    switch ((tape_op_t)cl->op) {
    case TAPE_CONST: aa_const(&z, cl->c); break;
    case TAPE_X: z = var[0]; break;
    case TAPE_Y: z = var[1]; break;
    case TAPE_Z: z = var[2]; break;
    case TAPE_NEG: aa_neg(&z, a); break;
    case TAPE_SQR: aa_sqr(&z, a); break;
    case TAPE_POWI: aa_powi(&z, a, cl->c.lo); break;
    case TAPE_POWR: aa_powr(&z, a, cl->c.lo); break;
    case TAPE_SQRT: aa_sqrt(&z, a); break;
    case TAPE_EXP: aa_exp(&z, a); break;
    case TAPE_LOG: aa_log(&z, a); break;
    case TAPE_SIN: aa_sin(&z, a); break;
    case TAPE_COS: aa_cos(&z, a); break;
    case TAPE_TAN: aa_tan(&z, a); break;
    case TAPE_ATAN: aa_atan(&z, a); break;
    case TAPE_ABS: aa_abs(&z, a); break;
    case TAPE_ADD: aa_add(&z, a, b); break;
    case TAPE_SUB: aa_sub(&z, a, b); break;
    case TAPE_MUL: aa_mul(&z, a, b); break;
    case TAPE_DIV: aa_div(&z, a, b); break;
    case TAPE_MIN: aa_min(&z, a, b); break;
    case TAPE_MAX: aa_max(&z, a, b); break;
    default: aa_from_iv(&z, iv_entire()); break;
    }
    return z;
}

static int same_double(double a, double b)
{
    return (a != a && b != b) || memcmp(&a, &b, sizeof a) == 0;
}

typedef struct {
    long batches, lanes, slots;
    char failure[512];
} tally_t;

/* One batch of nl lanes through every path's pass, against the reference. */
static void check_batch(const tape_t *t, const char *what, size_t nl, uint64_t *rng,
                        const path_t *paths, int npaths, double *S, aa_t *ref, tally_t *tl)
{
    aa_t var[3][ILIE_BATCH], f[ILIE_BATCH];
    for (size_t k = 0; k < nl; k++)
        for (int d = 0; d < 3; d++)
            var[d][k] = random_form(d, rng);
    for (int p = 0; p < npaths && !tl->failure[0]; p++) {
        paths[p].pass(t, S, nl, (const aa_t (*)[ILIE_BATCH])var, f);
        for (size_t k = 0; k < nl && !tl->failure[0]; k++) {
            const aa_t vk[3] = {var[0][k], var[1][k], var[2][k]};
            for (uint32_t i = 0; i < t->n; i++) {
                ref[i] = scalar_clause(t, i, ref, vk);
                const double want[A_ARRAYS] = {ref[i].x[0], ref[i].x[1], ref[i].x[2], ref[i].x[3],
                                               ref[i].e, ref[i].v.lo, ref[i].v.hi};
                for (int c = 0; c < A_ARRAYS; c++) {
                    double got = S[((size_t)i * A_ARRAYS + (size_t)c) * ILIE_BATCH + k];
                    if (!same_double(got, want[c])) {
                        snprintf(tl->failure, sizeof tl->failure,
                                 "%s, path %s, batch of %zu, lane %zu, clause %u (op %u), array %d: "
                                 "pass %a, scalar %a",
                                 what, paths[p].name, nl, k, i, t->clauses[i].op, c, got, want[c]);
                        break;
                    }
                }
                tl->slots++;
            }
            const aa_t *last = &ref[t->n - 1];
            if (memcmp(&f[k], last, sizeof *last) && !tl->failure[0]) {
                int same = 1;
                for (int i = 0; i < 4; i++)
                    same &= same_double(f[k].x[i], last->x[i]);
                same &= same_double(f[k].e, last->e) & same_double(f[k].v.lo, last->v.lo) &
                        same_double(f[k].v.hi, last->v.hi);
                if (!same)
                    snprintf(tl->failure, sizeof tl->failure,
                             "%s, path %s: the pass's result form of lane %zu is not its last slot",
                             what, paths[p].name, k);
            }
            tl->lanes++;
        }
    }
    tl->batches++;
}

static void check_tape(const tape_t *t, const char *what, int batches, uint64_t *rng,
                       tally_t *tl)
{
    path_t paths[3];
    int npaths = machine_paths(paths);
    double *S = malloc((size_t)t->n * A_ARRAYS * ILIE_BATCH * sizeof *S);
    aa_t *ref = malloc((size_t)t->n * sizeof *ref);
    assert_non_null(S);
    assert_non_null(ref);
    for (int b = 0; b < batches && !tl->failure[0]; b++) {
        size_t nl = 1 + (size_t)b % ILIE_BATCH; /* every size, the padded and the odd ones */
        check_batch(t, what, nl, rng, paths, npaths, S, ref, tl);
    }
    free(S);
    free(ref);
}

/* Every operation of the tape language, alone and composed, and integer
 * powers of every kind the pass has a lane loop for. */
static void test_pass_matches_scalar_ops(void **state)
{
    (void)state;
    static const char *const powers[] = {"x^3 + y", "(x - y)^4", "x^5 - z", "(x*y)^6 + z^3",
                                         "x^8 - y^9", "(x + y + z)^16", "x^63 + y^64",
                                         "-x^3 + (y^2 - z)^4"};
    uint64_t rng = tu_seed(0x11e1a5e5);
    int batches = (int)(ILIE_BATCH * 6 * tu_scale()) + ILIE_BATCH;
    tally_t tl = {0};
    for (size_t i = 0; i < tu_n_op_exprs && !tl.failure[0]; i++) {
        tape_t *t = tu_compile(tu_op_exprs[i]);
        check_tape(t, tu_op_exprs[i], batches, &rng, &tl);
        tape_free(t);
    }
    for (size_t i = 0; i < sizeof powers / sizeof *powers && !tl.failure[0]; i++) {
        tape_t *t = tu_compile(powers[i]);
        check_tape(t, powers[i], batches, &rng, &tl);
        tape_free(t);
    }
    printf("    %ld batches, %ld lanes, %ld slots compared on every path\n", tl.batches, tl.lanes,
           tl.slots);
    if (tl.failure[0])
        fail_msg("%s", tl.failure);
}

/* The tapes of every scene (the comparison surfaces, the stress surfaces, the
 * CSG union, the implicitized ones). */
static void test_pass_matches_scalar_scenes(void **state)
{
    (void)state;
    char **files;
    int n = tu_scene_files(&files);
    uint64_t rng = tu_seed(0x5ce9e5);
    int batches = (int)(ILIE_BATCH * 2 * tu_scale()) + ILIE_BATCH / 2;
    tally_t tl = {0};
    for (int i = 0; i < n && !tl.failure[0]; i++) {
        scene_t s;
        tu_load_scene(files[i], &s);
        check_tape(s.tape, files[i], batches, &rng, &tl);
        scene_free(&s);
    }
    tu_free_list(files, n);
    printf("    %ld batches, %ld lanes, %ld slots compared on every path\n", tl.batches, tl.lanes,
           tl.slots);
    if (tl.failure[0])
        fail_msg("%s", tl.failure);
}

/* ---- expr/lanes.h ------------------------------------------------------------------- */

static void test_powi_lanes(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x90e1);
    double lo[IV_LANES_MAX], hi[IV_LANES_MAX], ol[IV_LANES_MAX], oh[IV_LANES_MAX];
    double m[IV_LANES_MAX], dn[IV_LANES_MAX], up[IV_LANES_MAX];
    long checked = 0;
    for (unsigned e = 3; e <= 64; e++) {
        for (int round = 0; round < 40; round++) {
            size_t nl = 1 + tu_next(&rng) % IV_LANES_MAX;
            for (size_t k = 0; k < nl; k++) {
                double a = random_value(&rng), b = random_value(&rng);
                if (tu_next(&rng) % 4 == 0) /* ordinary ranges, across 0 or not */
                    a = 4.0 * tu_uniform(&rng) - 2.0, b = a + tu_uniform(&rng);
                if (tu_next(&rng) % 8 == 0)
                    b = a; /* a point */
                lo[k] = a < b || b != b ? a : b;
                hi[k] = a < b || b != b ? b : a;
                if (tu_next(&rng) % 16 == 0)
                    lo[k] = hi[k] = NAN; /* empty */
                m[k] = fabs(lo[k]);
            }
            iv_powi_lanes(lo, hi, nl, e, ol, oh);
            for (size_t k = 0; k < nl; k++) {
                iv_t want = iv_powi(iv_make(lo[k], hi[k]), (int)e);
                if (!same_double(ol[k], want.lo) || !same_double(oh[k], want.hi))
                    fail_msg("iv_powi_lanes([%a, %a], %u) = [%a, %a], iv_powi gives [%a, %a]",
                             lo[k], hi[k], e, ol[k], oh[k], want.lo, want.hi);
                checked++;
            }
            /* the bounds of |x|^e: iv_powi of the point |x| (m >= 0 and not NaN) */
            size_t nm = 0;
            for (size_t k = 0; k < nl; k++)
                if (m[k] == m[k])
                    m[nm++] = m[k];
            iv_pow_bound_lanes(m, nm, e, 0, dn);
            iv_pow_bound_lanes(m, nm, e, 1, up);
            /* and with the direction per lane: the same bits as the pass of
             * that direction */
            double dir[IV_LANES_MAX], mixed[IV_LANES_MAX];
            for (size_t k = 0; k < nm; k++)
                dir[k] = tu_next(&rng) % 2 ? 1.0 : -1.0;
            iv_pow_bound_lanes_dir(m, nm, e, dir, mixed);
            for (size_t k = 0; k < nm; k++) {
                iv_t want = iv_powi(iv_point(m[k]), (int)e);
                if (!same_double(dn[k], want.lo) || !same_double(up[k], want.hi))
                    fail_msg("iv_pow_bound_lanes(%a, %u) = %a, %a; iv_powi gives [%a, %a]", m[k],
                             e, dn[k], up[k], want.lo, want.hi);
                if (!same_double(mixed[k], dir[k] > 0 ? up[k] : dn[k]))
                    fail_msg("iv_pow_bound_lanes_dir(%a, %u, %g) = %a, not %a", m[k], e, dir[k],
                             mixed[k], dir[k] > 0 ? up[k] : dn[k]);
                checked++;
            }
        }
    }
    printf("    %ld lanes checked\n", checked);
}

/* ilie_excludes_boxes against ilie_excludes_box, ILIE by ILIE, on every path
 * (chosen with tape_simd_select): ILIEs of every expression over random cells
 * at every scale, and made-up ones (zero, NaN and infinite slopes, empty and
 * unbounded J); boxes that are the cell, a child of it, or have an infinite
 * or NaN side. */
static void test_excludes_boxes(void **state)
{
    (void)state;
    enum { N = 150 }; /* more than ILIE_BATCH: several chunks, a short last one */
    uint64_t rng = tu_seed(0xe8c1);
    const char *paths[] = {"portable", "avx2", "avx512"};
    ilie_t l[N];
    iv_box_t cell[N], box[N];
    bool ex[N];
    int sign[N];
    long checked = 0, excluded = 0;
    int rounds = (int)(20 * tu_scale()) + 2;
    for (size_t e = 0; e < tu_n_op_exprs; e++) {
        tape_t *t = tu_compile(tu_op_exprs[e]);
        ilie_ws_t *ws = ilie_ws_new(t->n);
        assert_non_null(ws);
        for (int round = 0; round < rounds; round++) {
            const double *b = tu_op_boxes[(size_t)round % TU_N_OP_BOXES];
            for (int j = 0; j < N; j++)
                cell[j] = tu_random_subbox(b, &rng);
            ilie_eval(t, ws, N, cell, l);
            for (int j = 0; j < N; j++) {
                box[j] = cell[j];
                uint64_t r = tu_next(&rng) % 16;
                iv_t *side = r < 12 ? NULL : &box[j].x + r % 3;
                if (r >= 4 && r < 8) /* a child */
                    box[j].x = iv_make(box[j].x.lo, iv_mid(box[j].x));
                if (side && r < 14)
                    side->hi = INFINITY;
                else if (side)
                    side->lo = NAN;
                if (tu_next(&rng) % 16 == 0) { /* made up */
                    for (int d = 0; d < 3; d++)
                        l[j].a[d] = tu_next(&rng) % 3 ? random_value(&rng) : 0.0;
                    double a = random_value(&rng), c = random_value(&rng);
                    l[j].J = tu_next(&rng) % 4 ? iv_make(a < c ? a : c, a < c ? c : a)
                                                : iv_empty();
                }
            }
            for (size_t p = 0; p < sizeof paths / sizeof *paths; p++) {
                if (!tape_simd_available(paths[p]))
                    continue;
                assert_int_equal(tape_simd_select(paths[p], NULL), 0);
                ilie_excludes_boxes(N, l, box, ex, sign);
                for (int j = 0; j < N; j++) {
                    int s1;
                    bool e1 = ilie_excludes_box(&l[j], &box[j], &s1);
                    if (e1 != ex[j] || s1 != sign[j])
                        fail_msg("%s, path %s, ILIE %d: ilie_excludes_boxes says %d (sign %d), "
                                 "ilie_excludes_box %d (sign %d)",
                                 tu_op_exprs[e], paths[p], j, ex[j], sign[j], e1, s1);
                    checked++;
                    excluded += e1;
                }
            }
        }
        ilie_ws_free(ws);
        tape_free(t);
    }
    tape_simd_select(NULL, NULL);
    printf("    %ld ILIEs compared, %ld of them excluded\n", checked, excluded);
}

/* ilie_ws_bytes: what the workspace takes from the heap (glibc's counters of
 * bytes in use, small blocks and mapped ones), up to the allocator's headers.
 * The sanitizers' allocator keeps no such counters: skipped there. */
static void test_ws_bytes(void **state)
{
    (void)state;
    if (tu_sanitizer_build())
        skip();
    const uint32_t sizes[] = {1, 19, 237, 4096};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; i++) {
        struct mallinfo2 before = mallinfo2();
        ilie_ws_t *ws = ilie_ws_new(sizes[i]);
        struct mallinfo2 after = mallinfo2();
        assert_non_null(ws);
        size_t used = (after.uordblks + after.hblkhd) - (before.uordblks + before.hblkhd);
        size_t said = ilie_ws_bytes(sizes[i]);
        if (used < said || used > said + 8192)
            fail_msg("ilie_ws_new(%u) took %zu bytes, ilie_ws_bytes says %zu", sizes[i], used, said);
        ilie_ws_free(ws);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pass_matches_scalar_ops),
        cmocka_unit_test(test_pass_matches_scalar_scenes),
        cmocka_unit_test(test_powi_lanes),
        cmocka_unit_test(test_excludes_boxes),
        cmocka_unit_test(test_ws_bytes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
