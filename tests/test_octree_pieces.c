/* A tree in pieces (octree/pieces.c: oct_save_index, oct_file_checksum, and
 * oct_load of an index).
 *
 * For several scenes (the CSG union and the thin shell among them), both
 * chains (the scene's tests; the whole chain with slabs and early leaves) and
 * with and without certain leaves, the frontier's subtrees are dealt to 1, 2
 * and 3 plans as the build over MPI deals them (Morton ranges, and a deal
 * where one part took subtrees from the back of another's range), each part
 * is finished (OCT_PLAN_PART, the top's leaves in the first only) and saved,
 * and the index is written.  oct_load of the index must give oct_build's
 * tree: the same cells (kind, class) at the same places, the same leaves in
 * the same order, slabs and certain codes, and the index's scene.
 *
 * Then the index that must be refused, each with the reason and where: a
 * piece listed twice (the leaves of two pieces overlap), a piece left out
 * (the header's count), a wrong leaf total, a checksum or leaf count that is
 * not the file's, a piece of another scene or depth, a missing or truncated
 * piece, and malformed lines (with their line number). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/testutil.h"

static const char *const SCENES[] = {"sphere", "gumdrop", "csg-64-spheres", "thin-shell",
                                     "crosscap"};

static char g_dir[64];

static int setup(void **state)
{
    (void)state;
    strcpy(g_dir, "/tmp/ivoct-pieces-XXXXXX");
    return mkdtemp(g_dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    return rmdir(g_dir);
}

static void tmp_path(char *out, size_t n, const char *name)
{
    snprintf(out, n, "%s/%s", g_dir, name);
}

/* Are the trees the same cells at the same places (whatever the layout of
 * their node arrays)?  Leaves are compared by index: both in Morton order. */
static void same_cells(const oct_tree_t *a, uint32_t i, const oct_tree_t *b, uint32_t j)
{
    oct_node_t u = a->nodes[i], v = b->nodes[j];
    assert_int_equal(OCT_NODE_KIND(u), OCT_NODE_KIND(v));
    if (OCT_NODE_KIND(u) == OCT_INTERIOR) {
        for (uint32_t c = 0; c < 8; c++)
            same_cells(a, OCT_NODE_VALUE(u) + c, b, OCT_NODE_VALUE(v) + c);
        return;
    }
    assert_int_equal(OCT_NODE_VALUE(u), OCT_NODE_VALUE(v));
}

static void same_tree(const oct_tree_t *a, const oct_tree_t *b)
{
    assert_int_equal(a->n_nodes, b->n_nodes);
    assert_int_equal(a->n_leaves, b->n_leaves);
    assert_int_equal(a->depth, b->depth);
    assert_int_equal(a->tests, b->tests);
    assert_memory_equal(a->box, b->box, sizeof a->box);
    assert_true(a->refine == b->refine);
    same_cells(a, 0, b, 0);
    if (a->n_leaves)
        assert_memory_equal(a->leaves, b->leaves, a->n_leaves * sizeof *a->leaves);
    assert_int_equal(a->slabs != NULL, b->slabs != NULL);
    if (a->slabs && a->n_leaves)
        assert_memory_equal(a->slabs, b->slabs, a->n_leaves * sizeof *a->slabs);
    assert_int_equal(a->certain != NULL, b->certain != NULL);
    if (a->certain && a->n_leaves) {
        assert_memory_equal(a->certain, b->certain, a->n_leaves);
        assert_int_equal(a->stats.leaves_certain, b->stats.leaves_certain);
    }
}

typedef struct pieces {
    int n;
    char path[3][256], name[3][32];
    const char *names[3];
    uint64_t leaves[3], sums[3];
} pieces_t;

/* The parts of a build dealt to n plans, saved as PREFIX_k.ivo. */
static void save_parts(const scene_t *s, const oct_params_t *p, int n, int deal, int certain,
                       const char *prefix, pieces_t *out)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    out->n = n;
    oct_plan_t *plan;
    for (int k = 0; k < n; k++) {
        if (oct_plan_new(s->tape, s->box, p, &plan, &err))
            fail_msg("oct_plan_new: %s", err.msg);
        size_t m = oct_plan_subtrees(plan), count = 0;
        size_t *which = malloc((m + 1) * sizeof *which);
        for (size_t i = 0; i < m; i++) {
            /* deal 0: Morton ranges; deal 1: ranges, then the last quarter of
               each range taken by the next part (work sharing) */
            size_t lo = m * (size_t)k / (size_t)n, hi = m * (size_t)(k + 1) / (size_t)n;
            size_t prev_hi = m * (size_t)(k ? k : n) / (size_t)n;
            size_t prev_lo = m * (size_t)(k ? k - 1 : n - 1) / (size_t)n;
            int mine = i >= lo && i < hi;
            if (deal == 1 && n > 1) {
                size_t cut = hi - (hi - lo) / 4, prev_cut = prev_hi - (prev_hi - prev_lo) / 4;
                mine = (i >= lo && i < cut) || (i >= prev_cut && i < prev_hi);
            }
            if (mine)
                which[count++] = i;
        }
        if (oct_plan_build(plan, which, count, &err))
            fail_msg("oct_plan_build: %s", err.msg);
        free(which);
        oct_tree_t *part;
        if (oct_plan_finish(plan, OCT_PLAN_PART | (k ? OCT_PLAN_NO_TOP : 0u), &part, &err))
            fail_msg("oct_plan_finish: %s", err.msg);
        oct_plan_free(plan);
        if (certain && oct_certify(part, s->tape, 2, &err))
            fail_msg("oct_certify: %s", err.msg);
        snprintf(out->name[k], sizeof out->name[k], "%s_%d.ivo", prefix, k);
        tmp_path(out->path[k], sizeof out->path[k], out->name[k]);
        out->names[k] = out->name[k];
        if (oct_save(part, &s->source, out->path[k], &err))
            fail_msg("oct_save: %s", err.msg);
        out->leaves[k] = part->n_leaves;
        assert_int_equal(oct_file_checksum(out->path[k], &out->sums[k], &err), 0);
        oct_free(part);
    }
}

static void remove_parts(const pieces_t *ps)
{
    for (int k = 0; k < ps->n; k++)
        unlink(ps->path[k]);
}

static void check_scene(const char *name, int chain, int certain)
{
    scene_t s;
    tu_load_scene(name, &s);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
    oct_params_t p = {.depth = tu_sanitizer_build() ? 5 : 6, .tests = s.octree.tests, .threads = 2};
    if (chain)
        p.tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE, p.refine = 0.02 * edge;
    oct_tree_t *whole;
    if (oct_build(s.tape, s.box, &p, &whole, &err))
        fail_msg("%s: oct_build: %s", name, err.msg);
    if (certain && oct_certify(whole, s.tape, 2, &err))
        fail_msg("%s: oct_certify: %s", name, err.msg);

    char index[256];
    tmp_path(index, sizeof index, "p.pivo");
    for (int n = 1; n <= 3; n++)
        for (int deal = 0; deal < (n > 1 ? 2 : 1); deal++) {
            pieces_t ps;
            save_parts(&s, &p, n, deal, certain, "p", &ps);
            assert_int_equal(
                oct_save_index(index, ps.names, ps.leaves, ps.sums, ps.n, &err), 0);
            oct_tree_t *back;
            oct_source_t src;
            if (oct_load(index, &back, &src, &err))
                fail_msg("%s: %d pieces: %s", name, n, err.msg);
            same_tree(whole, back);
            assert_string_equal(src.f, s.source.f);
            assert_string_equal(src.name, s.source.name);
            oct_free(back);
            oct_source_free(&src);
            remove_parts(&ps);
        }
    unlink(index);
    oct_free(whole);
    scene_free(&s);
}

static void test_union(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof SCENES / sizeof *SCENES; i++)
        for (int chain = 0; chain < 2; chain++)
            check_scene(SCENES[i], chain, chain == 0 && i < 2);
}

/* ---- indexes that must be refused ------------------------------------------------------ */

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

/* oct_load(index) must fail with a message holding every one of the words. */
static void refused(const char *index, const char *what, const char *w1, const char *w2)
{
    oct_tree_t *t = (oct_tree_t *)1;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_load(index, &t, NULL, &err) == 0)
        fail_msg("%s: loaded", what);
    assert_null(t);
    if (!strstr(err.msg, w1) || (w2 && !strstr(err.msg, w2)))
        fail_msg("%s: the message \"%s\" does not say \"%s\"%s%s", what, err.msg, w1,
                 w2 ? " and " : "", w2 ? w2 : "");
}

static void test_refused(void **state)
{
    (void)state;
    scene_t s, other;
    tu_load_scene("gumdrop", &s);
    tu_load_scene("sphere", &other);
    oct_params_t p = {.depth = 5, .tests = s.octree.tests, .threads = 2};
    pieces_t ps;
    save_parts(&s, &p, 3, 0, 0, "p", &ps);
    char index[256], text[4096], line[3][128];
    tmp_path(index, sizeof index, "bad.pivo");
    for (int k = 0; k < 3; k++)
        snprintf(line[k], sizeof line[k], "%s,%llu,%016llx\n", ps.name[k],
                 (unsigned long long)ps.leaves[k], (unsigned long long)ps.sums[k]);
    unsigned long long total = ps.leaves[0] + ps.leaves[1] + ps.leaves[2];
    ivoct_error_t err;
    ivoct_error_clear(&err);

    /* the good one, written by hand: loads */
    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n# c\n%s%s%s", total,
             line[0], line[1], line[2]);
    write_text(index, text);
    oct_tree_t *t;
    assert_int_equal(oct_load(index, &t, NULL, &err), 0);
    oct_free(t);

    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%s%s",
             total - ps.leaves[2] + ps.leaves[1], line[0], line[1], line[1]);
    write_text(index, text);
    refused(index, "a piece twice", "p_1.ivo", "both hold");

    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%s", total, line[0],
             line[2]);
    write_text(index, text);
    refused(index, "a piece left out", "bad.pivo:1:", "fewer pieces");

    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%s%s", total + 1,
             line[0], line[1], line[2]);
    write_text(index, text);
    refused(index, "a wrong total", "bad.pivo:1:", "header says");

    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%s%s,%llu,%016llx\n",
             total, line[0], line[1], ps.name[2], (unsigned long long)ps.leaves[2],
             (unsigned long long)(ps.sums[2] ^ 1));
    write_text(index, text);
    refused(index, "a wrong checksum", "bad.pivo:4:", "checksum");

    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%s,%llu,%016llx\n%s",
             total + 1, line[0], ps.name[1], (unsigned long long)ps.leaves[1] + 1,
             (unsigned long long)ps.sums[1], line[2]);
    write_text(index, text);
    refused(index, "a wrong leaf count", "bad.pivo:3:", "leaf count");

    /* a piece of another scene, and of another depth */
    for (int kind = 0; kind < 2; kind++) {
        pieces_t alien;
        oct_params_t q = p;
        q.depth = kind ? 4 : 5;
        save_parts(kind ? &s : &other, &q, 1, 0, 0, "alien", &alien);
        snprintf(text, sizeof text,
                 "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%salien_0.ivo,%llu,%016llx\n",
                 (unsigned long long)(ps.leaves[0] + ps.leaves[1] + alien.leaves[0]), line[0],
                 line[1], (unsigned long long)alien.leaves[0],
                 (unsigned long long)alien.sums[0]);
        write_text(index, text);
        refused(index, kind ? "another depth" : "another scene", "bad.pivo:4:",
                kind ? "its depth differs" : "not from the build");
        remove_parts(&alien);
    }

    /* a missing piece, a truncated one */
    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%snone.ivo,%llu,%016llx\n",
             total, line[0], line[1], (unsigned long long)ps.leaves[2],
             (unsigned long long)ps.sums[2]);
    write_text(index, text);
    refused(index, "a missing piece", "bad.pivo:4:", "cannot open");
    size_t n;
    unsigned char *bytes = tu_read_file(ps.path[2], &n);
    FILE *f = fopen(ps.path[2], "wb");
    assert_int_equal(fwrite(bytes, 1, n / 2, f), n / 2);
    fclose(f);
    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=3 leaves=%llu\n%s%s%s", total, line[0],
             line[1], line[2]);
    write_text(index, text);
    refused(index, "a truncated piece", "bad.pivo:4:", "p_2.ivo");
    free(bytes);

    /* malformed */
    write_text(index, "ivoct-pieces 2 pieces=1 leaves=0\nx,0,0000000000000000\n");
    refused(index, "version 2", "bad.pivo:1:", "version");
    write_text(index, "ivoct-pieces 1 pieces=1 leaves=0 extra\n");
    refused(index, "a bad header", "bad.pivo:1:", "ivoct-pieces 1");
    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=1 leaves=0\n# c\np_0.ivo,12x,%016llx\n",
             (unsigned long long)ps.sums[0]);
    write_text(index, text);
    refused(index, "a bad count", "bad.pivo:3:", "expected file,leaves,checksum");
    write_text(index, "ivoct-pieces 1 pieces=1 leaves=0\np_0.ivo,0,abc\n");
    refused(index, "a short checksum", "bad.pivo:2:", "16 hex digits");
    write_text(index, "ivoct-pieces 1 pieces=1 leaves=0\np_0.ivo\n");
    refused(index, "no fields", "bad.pivo:2:", "expected");
    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=1 leaves=%llu\n%s%s",
             (unsigned long long)ps.leaves[0], line[0], line[1]);
    write_text(index, text);
    refused(index, "too many lines", "bad.pivo:3:", "more pieces");
    snprintf(text, sizeof text, "ivoct-pieces 1 pieces=1 leaves=%llu\n%.*s",
             (unsigned long long)ps.leaves[0], (int)strlen(line[0]) - 1, line[0]);
    write_text(index, text);
    refused(index, "an unended line", "bad.pivo:2:", "not ended");

    unlink(index);
    remove_parts(&ps);
    scene_free(&s);
    scene_free(&other);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_union),
                                       cmocka_unit_test(test_refused)};
    return cmocka_run_group_tests(tests, setup, teardown);
}
