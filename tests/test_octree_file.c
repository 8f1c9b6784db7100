/* The native octree file (.ivo): round trip, and robustness against truncated
 * and corrupt files (run under ASan/UBSan too, where a crash or an
 * out-of-bounds read is a failure).
 *
 *  - round trip: trees of several scenes (with 0, 1, 2 and 4 named
 *    subexpressions), a depth-0 tree, a tree whose root is empty and a tree
 *    saved without its source, saved and loaded back: every field equal
 *    (doubles bit for bit), the source texts equal, and saving the loaded tree
 *    again gives the same bytes;
 *  - truncated copies: every length from 0 to the full size minus 1 of a small
 *    tree, and a sample of lengths (with the section boundaries) of a larger
 *    one: oct_load must fail, saying "PATH: REASON" with the reason the bad
 *    magic (shorter than the 8 bytes of it) or the checksum mismatch; so must
 *    a copy with bytes appended (the checksum);
 *  - the checksum: a saved file is version 5 (6 with certain leaves) and ends
 *    with XXH3-64 of the rest, recomputed here with xxHash's one-shot call
 *    (the writer streams it); files of versions 3 and 4 (the same layouts
 *    with FNV-1a 64, written before) made from new ones by rewriting the
 *    version and re-signing with FNV-1a here, load as the same tree; a file
 *    whose version names one checksum and that carries the other is refused
 *    as corrupt;
 *  - corrupt copies: one random bit flipped in every byte of a small file, and
 *    random multi-byte corruptions of a larger one: oct_load must fail (the
 *    file ends with a 64-bit checksum of the rest, XXH3-64, whose every output
 *    bit depends on every input byte), for the bad magic where a byte of it
 *    changed, for an unsupported version where the version field changed to
 *    one no reader knows, else the checksum mismatch;
 *  - corrupt and re-signed: the same corruptions with the checksum recomputed
 *    (the format is documented in octree/file.c), so the structure checks are
 *    what stands between the bytes and the reader.  Targeted invalid headers,
 *    node words and leaves must be rejected, each for its reason (octree/file.c's
 *    message for that check); random ones must never crash, a rejection gives a
 *    structure reason (or the bad magic), never the checksum, and a tree that is
 *    accepted must be safe to walk (every index in range, leaves where their
 *    codes say);
 *  - a tree whose nodes are shared between parents (a DAG, not a tree) or
 *    that holds nodes no parent reaches must be rejected, for a bad child index
 *    and for unreached nodes: a builder never makes one, and walking a crafted
 *    DAG of depth 21 visits 8^21 nodes;
 *  - a missing file: "cannot open PATH"; saving into a missing folder:
 *    "cannot write PATH: " and the system's reason.
 * IVOCT_ASAN=1 scales the sample sizes down. */
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

#include <errno.h>

#include <cmocka.h>
#include <xxhash.h>

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/testutil.h"

static char g_dir[64];

static int setup(void **state)
{
    (void)state;
    strcpy(g_dir, "/tmp/ivoct-file-XXXXXX");
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

static void write_all(const char *path, const unsigned char *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(p, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

/* The two checksums of the format (octree/file.c), of every byte before the
 * last 8, stored little-endian in the last 8: XXH3-64 (seed 0) in versions 5
 * and 6, FNV-1a 64 in versions 2 to 4. */
static uint64_t fnv1a64(const unsigned char *p, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static uint64_t xxh3_64(const unsigned char *p, size_t n)
{
    return XXH3_64bits(p, n);
}

static void sign_with(unsigned char *p, size_t n, uint64_t (*sum)(const unsigned char *, size_t))
{
    if (n < 8)
        return;
    uint64_t h = sum(p, n - 8);
    for (int i = 0; i < 8; i++)
        p[n - 8 + i] = (unsigned char)(h >> (8 * i));
}

static uint32_t get_u32(const unsigned char *p);

/* Re-sign with the checksum the file's version names. */
static void resign(unsigned char *p, size_t n)
{
    uint32_t v = n >= 12 ? get_u32(p + 8) : 0;
    sign_with(p, n, v == 5 || v == 6 ? xxh3_64 : fnv1a64);
}

static uint64_t stored_sum(const unsigned char *p, size_t n)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | p[n - 8 + i];
    return v;
}

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static oct_tree_t *build_ex(const tape_t *tape, const double box[6], int depth, unsigned tests,
                            double refine)
{
    oct_params_t p = {.depth = depth, .tests = tests, .refine = refine, .threads = 2};
    oct_tree_t *t;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_build(tape, box, &p, &t, &err) != 0)
        fail_msg("oct_build: %s", err.msg);
    return t;
}

static oct_tree_t *build(const tape_t *tape, const double box[6], int depth)
{
    return build_ex(tape, box, depth, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ, 0);
}

#define ALL_TESTS (OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE)

/* Save a scene's tree at a depth (with ILIE slabs and refine when slabs);
 * returns the file's bytes. */
static unsigned char *saved_scene_ex(const char *name, int depth, int slabs, size_t *n)
{
    scene_t s;
    tu_load_scene(name, &s);
    oct_tree_t *t = slabs ? build_ex(s.tape, s.box, depth, ALL_TESTS, 0.05)
                          : build(s.tape, s.box, depth);
    assert_int_equal(t->slabs != NULL, slabs);
    const oct_source_t *src = &s.source;
    char path[128];
    tmp_path(path, sizeof path, "scene.ivo");
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(oct_save(t, src, path, &err), 0);
    unsigned char *p = tu_read_file(path, n);
    remove(path);
    oct_free(t);
    scene_free(&s);
    return p;
}

static unsigned char *saved_scene(const char *name, int depth, size_t *n)
{
    return saved_scene_ex(name, depth, 0, n);
}

/* The reasons oct_load gives for a file it opened and rejects (octree/file.c):
 * the message is "PATH: REASON". */
#define WHY_MAGIC "not an ivoct octree file (bad magic)"
#define WHY_CHECKSUM "checksum mismatch (truncated or corrupt file)"
static const char *const STRUCTURE_REASONS[] = {
    "unsupported version", "truncated scene", "bad header or truncated tree", "truncated tree",
    "bad node count", "bad child index", "leaves out of order",
    "leaf code does not match its place", "bad cell class", "bad node kind",
    "nodes not reached from the root", "leaves not reached from the root", "bad box",
};
#define N_STRUCTURE_REASONS (sizeof STRUCTURE_REASONS / sizeof *STRUCTURE_REASONS)

/* The reason of a message "PATH: REASON" for the file at path; fails when the
 * message does not have that form. */
static const char *reason_of(const char *msg, const char *path)
{
    size_t n = strlen(path);
    if (strncmp(msg, path, n) != 0 || strncmp(msg + n, ": ", 2) != 0)
        fail_msg("oct_load's message \"%s\" does not name the file %s", msg, path);
    return msg + n + 2;
}

/* oct_load on these bytes: 0 loaded, -1 rejected (the reason, after the path,
 * into why).  An accepted tree is walked with every index checked. */
static int try_load(const unsigned char *p, size_t n, char *why, size_t why_n)
{
    char path[128];
    tmp_path(path, sizeof path, "try.ivo");
    write_all(path, p, n);
    oct_tree_t *t = NULL;
    oct_source_t src;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int rc = oct_load(path, &t, &src, &err);
    remove(path);
    if (rc != 0) {
        assert_null(t);
        const char *r = reason_of(err.msg, path);
        assert_true(r[0] != '\0'); /* a reason */
        if (why)
            snprintf(why, why_n, "%s", r);
        return -1;
    }
    /* accepted: it must be safe to use */
    assert_non_null(t);
    assert_true(t->depth >= 0 && t->depth <= OCT_MAX_DEPTH);
    assert_true(t->n_nodes >= 1);
    for (int k = 0; k < 3; k++)
        assert_true(isfinite(t->box[2 * k]) && t->box[2 * k] <= t->box[2 * k + 1]);
    assert_non_null(src.name);
    assert_non_null(src.f);
    for (size_t i = 0; i < src.n_lets; i++) {
        assert_non_null(src.let_names[i]);
        assert_non_null(src.let_texts[i]);
    }
    /* a walk from the root, bounded: a tree has n_nodes nodes */
    struct {
        uint32_t node;
        uint64_t code;
        int depth;
    } stack[8 * (OCT_MAX_DEPTH + 2)];
    int sp = 0;
    uint64_t steps = 0;
    uint32_t next_leaf = 0;
    stack[sp].node = 0, stack[sp].code = 0, stack[sp].depth = 0, sp++;
    while (sp > 0) {
        if (++steps > t->n_nodes)
            fail_msg("accepted a file whose walk from the root visits more than its %u nodes",
                     t->n_nodes);
        sp--;
        uint32_t i = stack[sp].node;
        uint64_t code = stack[sp].code;
        int d = stack[sp].depth;
        assert_true(i < t->n_nodes);
        oct_node_t v = t->nodes[i];
        uint32_t val = OCT_NODE_VALUE(v);
        switch (OCT_NODE_KIND(v)) {
        case OCT_INTERIOR:
            assert_true(d < t->depth);
            assert_true((uint64_t)val + 8 <= t->n_nodes);
            for (int k = 7; k >= 0; k--) {
                stack[sp].node = val + (uint32_t)k;
                stack[sp].code = code << 3 | (uint64_t)k;
                stack[sp].depth = d + 1;
                sp++;
            }
            break;
        case OCT_LEAF:
            assert_true(val < t->n_leaves);
            assert_int_equal(val, next_leaf);
            next_leaf++;
            assert_int_equal(oct_leaf_depth(&t->leaves[val]), d);
            assert_true(oct_leaf_code(&t->leaves[val]) == code);
            break;
        case OCT_EMPTY:
            assert_true(val <= OCT_UNDEFINED);
            break;
        default:
            fail_msg("loaded a bad node kind");
        }
    }
    assert_int_equal(next_leaf, t->n_leaves);
    oct_free(t);
    oct_source_free(&src);
    return 0;
}

/* These bytes must be rejected for exactly this reason. */
static void expect_rejected(const unsigned char *p, size_t n, const char *reason, const char *what)
{
    char why[600];
    if (try_load(p, n, why, sizeof why) == 0)
        fail_msg("%s was accepted", what);
    if (strcmp(why, reason) != 0)
        fail_msg("%s was rejected for \"%s\", expected \"%s\"", what, why, reason);
}

/* A structure reason (a file whose checksum is right but whose content is not). */
static int is_structure_reason(const char *why)
{
    for (size_t k = 0; k < N_STRUCTURE_REASONS; k++)
        if (strcmp(why, STRUCTURE_REASONS[k]) == 0)
            return 1;
    return 0;
}


/* ---- the layout of a file (octree/file.c) ------------------------------------------ */

typedef struct layout {
    size_t depth, n_lets, f, param, patch, n_nodes, n_leaves, nodes, leaves, slabs, checksum;
    uint32_t nn, nl, has_slabs;
} layout_t;

#define FILE_VERSION 5 /* octree/file.c, a tree without certain leaves (XXH3-64) */
#define FILE_VERSION_CERTAIN 6 /* 5 with the certain leaves' codes */
#define FILE_VERSION_NEXT 7 /* the first version oct_load does not know (3 and 4 are 5
                               and 6 with FNV-1a 64, 2 is 3 without the parametrization) */
#define OFF_VERSION 8
#define OFF_DEPTH 12
#define OFF_REFINE 20
#define OFF_HAS_SLABS 28
#define OFF_BOX 32
#define OFF_NAME 80
#define LEAF_BYTES 25
#define SLAB_BYTES 48

static void layout_of(const unsigned char *p, size_t n, layout_t *L)
{
    size_t at = OFF_NAME;
    at += 4 + get_u32(p + at);
    L->depth = OFF_DEPTH;
    L->n_lets = at;
    uint32_t nl = get_u32(p + at);
    at += 4;
    for (uint32_t i = 0; i < 2 * nl; i++)
        at += 4 + get_u32(p + at);
    L->f = at;
    at += 4 + get_u32(p + at);
    L->param = at;
    for (int k = 0; k < 3; k++)
        at += 4 + get_u32(p + at);
    L->patch = at;
    at += 4 * 8;
    L->n_nodes = at;
    L->nn = get_u32(p + at);
    L->n_leaves = at + 4;
    L->nl = get_u32(p + at + 4);
    L->nodes = at + 8;
    L->leaves = L->nodes + 4 * (size_t)L->nn;
    L->has_slabs = get_u32(p + OFF_HAS_SLABS);
    L->slabs = L->leaves + LEAF_BYTES * (size_t)L->nl;
    L->checksum = L->slabs + (L->has_slabs ? SLAB_BYTES * (size_t)L->nl : 0);
    assert_int_equal(L->checksum + 8, n);
}

static void same_tree(const oct_tree_t *a, const oct_tree_t *b)
{
    assert_memory_equal(a->box, b->box, sizeof a->box);
    assert_int_equal(a->depth, b->depth);
    assert_int_equal(a->tests, b->tests);
    assert_memory_equal(&a->refine, &b->refine, sizeof a->refine);
    assert_int_equal(a->slabs != NULL, b->slabs != NULL);
    if (a->slabs && a->n_leaves)
        assert_memory_equal(a->slabs, b->slabs, a->n_leaves * sizeof *a->slabs);
    assert_int_equal(a->n_nodes, b->n_nodes);
    assert_memory_equal(a->nodes, b->nodes, a->n_nodes * sizeof *a->nodes);
    assert_int_equal(a->n_leaves, b->n_leaves);
    for (uint32_t i = 0; i < a->n_leaves; i++) {
        assert_true(a->leaves[i].key == b->leaves[i].key);
        assert_memory_equal(&a->leaves[i].f_lo, &b->leaves[i].f_lo, sizeof(float));
        assert_memory_equal(&a->leaves[i].f_hi, &b->leaves[i].f_hi, sizeof(float));
        assert_int_equal(oct_leaf_depth(&a->leaves[i]), oct_leaf_depth(&b->leaves[i]));
    }
}

static void same_source(const oct_source_t *a, const oct_source_t *b)
{
    assert_string_equal(a->name ? a->name : "", b->name);
    assert_int_equal(a->n_lets, b->n_lets);
    for (size_t i = 0; i < a->n_lets; i++) {
        assert_string_equal(a->let_names[i], b->let_names[i]);
        assert_string_equal(a->let_texts[i], b->let_texts[i]);
    }
    assert_string_equal(a->f ? a->f : "", b->f);
    for (int k = 0; k < 3; k++) {
        if (a->param[0])
            assert_string_equal(a->param[k], b->param[k]);
        else
            assert_null(b->param[k]);
    }
    for (int k = 0; k < 4; k++) {
        if (a->param[0] && !isnan(a->patch[k]))
            assert_memory_equal(&a->patch[k], &b->patch[k], sizeof(double));
        else
            assert_true(isnan(b->patch[k]));
    }
}

/* Save, load, compare; save the loaded tree again: same bytes. */
static void round_trip(const oct_tree_t *t, const oct_source_t *src)
{
    char p1[128], p2[128];
    tmp_path(p1, sizeof p1, "a.ivo");
    tmp_path(p2, sizeof p2, "b.ivo");
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(oct_save(t, src, p1, &err), 0);
    oct_tree_t *u;
    oct_source_t back;
    if (oct_load(p1, &u, &back, &err) != 0)
        fail_msg("oct_load of a file just saved: %s", err.msg);
    same_tree(t, u);
    oct_source_t none = {0};
    same_source(src ? src : &none, &back);
    assert_int_equal(oct_save(u, &back, p2, &err), 0);
    size_t n1, n2;
    unsigned char *b1 = tu_read_file(p1, &n1), *b2 = tu_read_file(p2, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(b1, b2, n1);
    /* src may be NULL when loading */
    oct_free(u);
    assert_int_equal(oct_load(p1, &u, NULL, &err), 0);
    same_tree(t, u);
    oct_free(u);
    oct_source_free(&back);
    free(b1);
    free(b2);
    remove(p1);
    remove(p2);
}

static void test_round_trip(void **state)
{
    (void)state;
    /* 0, 1, 2 and 4 named subexpressions */
    static const char *const names[] = {"sphere", "thin-shell", "barth-sextic", "csg-64-spheres",
                                        "whitney-umbrella"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        scene_t s;
        tu_load_scene(names[i], &s);
        oct_tree_t *t = build(s.tape, s.box, 4);
        const oct_source_t *src = &s.source;
        round_trip(t, src);
        round_trip(t, NULL); /* no source: empty texts */
        printf("%-18s %u nodes, %u leaves, %zu lets: round trip exact\n", names[i], t->n_nodes,
               t->n_leaves, s.source.n_lets);
        oct_free(t);
        /* with ILIE slabs, and leaves stopped early by refine */
        t = build_ex(s.tape, s.box, 4, ALL_TESTS, 0.1);
        assert_non_null(t->slabs);
        round_trip(t, src);
        oct_free(t);
        scene_free(&s);
    }
    /* a root that is a leaf (depth 0), and a root decided empty */
    tape_t *tape;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(tape_compile("x^2 + y^2 + z^2 - 1", &tape, &err), 0);
    double box[6] = {-2, 2, -2, 2, -2, 2}, far[6] = {3, 4, 3, 4, 3, 4};
    oct_source_t src = {"edge", 0, NULL, NULL, "x^2 + y^2 + z^2 - 1", {NULL}, {NAN, NAN, NAN, NAN}};
    oct_tree_t *t = build(tape, box, 0);
    assert_int_equal(t->n_leaves, 1);
    round_trip(t, &src);
    /* a parametric surface's source: the parametrization and its patch travel too */
    char px[] = "2*u/(1+u^2+v^2)", py[] = "2*v/(1+u^2+v^2)", pz[] = "(u^2+v^2-1)/(1+u^2+v^2)";
    oct_source_t par = {"stereo", 0, NULL, NULL, "x^2 + y^2 + z^2 - 1", {px, py, pz},
                        {-3, 3, -3, 3}};
    round_trip(t, &par);
    par.patch[2] = par.patch[3] = NAN; /* a patch of u only */
    round_trip(t, &par);
    oct_free(t);
    t = build(tape, far, 5);
    assert_int_equal(t->n_leaves, 0);
    round_trip(t, &src);
    oct_free(t);
    tape_free(tape);
}

/* A version 2 file (written before parametric scenes: no parametrization fields) loads,
 * with the same tree and no parametrization; one whose parametrization has an empty
 * coordinate is refused. */
static void test_version_2(void **state)
{
    (void)state;
    size_t n;
    unsigned char *p = saved_scene("gumdrop", 3, &n);
    layout_t L;
    layout_of(p, n, &L);
    size_t cut = L.n_nodes - L.param, m = n - cut;
    unsigned char *q = malloc(n);
    assert_non_null(q);
    memcpy(q, p, L.param);
    memcpy(q + L.param, p + L.n_nodes, n - L.n_nodes);
    put_u32(q + OFF_VERSION, 2);
    resign(q, m);
    char path[128];
    tmp_path(path, sizeof path, "v2.ivo");
    write_all(path, q, m);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    oct_tree_t *t2, *t3;
    oct_source_t s2, s3;
    if (oct_load(path, &t2, &s2, &err) != 0)
        fail_msg("a version 2 file: %s", err.msg);
    write_all(path, p, n);
    assert_int_equal(oct_load(path, &t3, &s3, &err), 0);
    same_tree(t3, t2);
    same_source(&s3, &s2);
    for (int k = 0; k < 3; k++)
        assert_null(s2.param[k]);
    oct_free(t2), oct_free(t3);
    oct_source_free(&s2), oct_source_free(&s3);
    remove(path);
    printf("version 2 file (%zu bytes): loads as the version 5 one, no parametrization\n", m);

    /* param_y given, param_x and param_z empty: refused */
    unsigned char *r = malloc(n + 1);
    assert_non_null(r);
    memcpy(r, p, L.param + 4);
    put_u32(r + L.param + 4, 1), r[L.param + 8] = 'u';
    memcpy(r + L.param + 9, p + L.param + 8, n - (L.param + 8));
    resign(r, n + 1);
    expect_rejected(r, n + 1, "bad header or truncated tree", "a parametrization of one coordinate");
    free(r);
    free(q);
    free(p);
}

/* The checksum of a saved file, recomputed here; the older versions (3 and 4, the same
 * layouts with FNV-1a 64) made from new files, loaded as the same tree; and the
 * checksum each version names, and no other. */
static void test_checksum_and_old_versions(void **state)
{
    (void)state;
    /* the library is XXH3-64 of the format: published test vectors (seed 0) */
    assert_true(XXH3_64bits("", 0) == 0x2d06800538d394c2ull);
    assert_true(XXH3_64bits("a", 1) == 0xe6c632b61e964e1full);
    assert_true(XXH3_64bits("abc", 3) == 0x78af5f94892f3950ull);
    assert_true(fnv1a64((const unsigned char *)"a", 1) == 0xaf63dc4c8601ec8cull);
    for (int certain = 0; certain <= 1; certain++) {
        scene_t s;
        tu_load_scene("gumdrop", &s);
        oct_tree_t *t = build_ex(s.tape, s.box, 5, ALL_TESTS, 0.05);
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (certain) {
            assert_int_equal(oct_certify(t, s.tape, 2, &err), 0);
            assert_non_null(t->certain);
            assert_true(t->stats.leaves_certain > 0);
        }
        char path[128], old[128], again[128];
        tmp_path(path, sizeof path, "new.ivo");
        tmp_path(old, sizeof old, "old.ivo");
        tmp_path(again, sizeof again, "again.ivo");
        assert_int_equal(oct_save(t, &s.source, path, &err), 0);
        size_t n;
        unsigned char *p = tu_read_file(path, &n);
        uint32_t v_new = certain ? FILE_VERSION_CERTAIN : FILE_VERSION, v_old = certain ? 4 : 3;
        assert_int_equal(get_u32(p + OFF_VERSION), v_new);
        assert_true(n > 8 + 4 + 8);
        assert_true(stored_sum(p, n) == xxh3_64(p, n - 8));
        assert_true(stored_sum(p, n) != fnv1a64(p, n - 8));
        oct_tree_t *a, *b;
        oct_source_t sa, sb;
        if (oct_load(path, &a, &sa, &err) != 0)
            fail_msg("version %u: %s", v_new, err.msg);
        same_tree(t, a);
        same_source(&s.source, &sa);

        /* the same tree as an older file: the version rewritten, signed with FNV-1a */
        unsigned char *q = malloc(n);
        assert_non_null(q);
        memcpy(q, p, n);
        put_u32(q + OFF_VERSION, v_old);
        sign_with(q, n, fnv1a64);
        write_all(old, q, n);
        if (oct_load(old, &b, &sb, &err) != 0)
            fail_msg("a version %u file: %s", v_old, err.msg);
        same_tree(a, b);
        same_source(&sa, &sb);
        assert_int_equal(a->certain != NULL, certain);
        assert_int_equal(b->certain != NULL, certain);
        if (certain) {
            assert_memory_equal(a->certain, b->certain, a->n_leaves);
            assert_int_equal(a->stats.leaves_certain, b->stats.leaves_certain);
        }
        /* saved again, it is the new file, byte for byte */
        assert_int_equal(oct_save(b, &sb, again, &err), 0);
        size_t m;
        unsigned char *r = tu_read_file(again, &m);
        assert_int_equal(m, n);
        assert_memory_equal(r, p, n);
        free(r);
        printf("%s certain leaves: version %u (%zu bytes, XXH3-64 %016llx) and version %u "
               "(FNV-1a 64 %016llx) load as the same tree\n",
               certain ? "with" : "without", v_new, n, (unsigned long long)stored_sum(p, n),
               v_old, (unsigned long long)stored_sum(q, n));

        /* each version with the other's checksum: corrupt */
        memcpy(q, p, n);
        sign_with(q, n, fnv1a64);
        char what[96];
        snprintf(what, sizeof what, "version %u signed with FNV-1a", v_new);
        expect_rejected(q, n, WHY_CHECKSUM, what);
        put_u32(q + OFF_VERSION, v_old);
        sign_with(q, n, xxh3_64);
        snprintf(what, sizeof what, "version %u signed with XXH3-64", v_old);
        expect_rejected(q, n, WHY_CHECKSUM, what);
        /* and a version 2 file signed with XXH3-64 (its own is FNV-1a) */
        put_u32(q + OFF_VERSION, 2);
        sign_with(q, n, xxh3_64);
        expect_rejected(q, n, WHY_CHECKSUM, "version 2 signed with XXH3-64");

        remove(path), remove(old), remove(again);
        free(q);
        free(p);
        oct_free(a), oct_free(b);
        oct_source_free(&sa), oct_source_free(&sb);
        oct_free(t);
        scene_free(&s);
    }
}

static void test_missing_and_unwritable(void **state)
{
    (void)state;
    oct_tree_t *t = (oct_tree_t *)&t; /* must be reset to NULL */
    oct_source_t src;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    char path[128], want[600];
    tmp_path(path, sizeof path, "does-not-exist.ivo");
    assert_int_not_equal(oct_load(path, &t, &src, &err), 0);
    assert_null(t);
    snprintf(want, sizeof want, "cannot open %s", path);
    assert_string_equal(err.msg, want);
    ivoct_error_clear(&err);
    assert_int_not_equal(oct_load(g_dir, &t, &src, &err), 0); /* a directory */
    assert_null(t);
    /* fopen of a directory fails on some systems; on Linux it opens and the
     * first read fails */
    snprintf(want, sizeof want, "cannot open %s", g_dir);
    if (strcmp(err.msg, want) != 0)
        assert_string_equal(reason_of(err.msg, g_dir), WHY_MAGIC);

    scene_t s;
    tu_load_scene("sphere", &s);
    oct_tree_t *u = build(s.tape, s.box, 3);
    tmp_path(path, sizeof path, "no-such-dir/x.ivo");
    ivoct_error_clear(&err);
    assert_int_not_equal(oct_save(u, NULL, path, &err), 0);
    snprintf(want, sizeof want, "cannot write %s: %s", path, strerror(ENOENT));
    assert_string_equal(err.msg, want);
    oct_free(u);
    scene_free(&s);
}

/* The first len of n bytes of a file: shorter than the magic, a bad magic;
 * else the last 8 bytes are not the checksum of the rest (FNV-1a 64 would have
 * to collide on these very bytes). */
static void expect_truncated(const unsigned char *p, size_t len, size_t n)
{
    char what[96];
    snprintf(what, sizeof what, "a copy truncated to %zu of %zu bytes", len, n);
    expect_rejected(p, len, len < 8 ? WHY_MAGIC : WHY_CHECKSUM, what);
}

static void test_truncated(void **state)
{
    (void)state;
    /* a small tree: every length */
    size_t n;
    unsigned char *p = saved_scene("sphere", 2, &n);
    printf("small file: %zu bytes, every truncation\n", n);
    for (size_t len = 0; len < n; len++)
        expect_truncated(p, len, n);
    assert_int_equal(try_load(p, n, NULL, 0), 0); /* the whole file is fine */
    free(p);

    /* a larger one: the section boundaries and a sample */
    p = saved_scene("gumdrop", tu_sanitizer_build() ? 4 : 5, &n);
    layout_t L;
    layout_of(p, n, &L);
    size_t marks[] = {8,      OFF_DEPTH, OFF_REFINE, OFF_HAS_SLABS, OFF_BOX, OFF_NAME,
                      L.n_lets, L.f,       L.param,    L.patch,       L.n_nodes,
                      L.nodes,  L.leaves,  L.slabs,
                      L.checksum, n - 1};
    for (size_t i = 0; i < sizeof marks / sizeof *marks; i++)
        for (int d = -1; d <= 1; d++) {
            size_t len = marks[i] + (size_t)d;
            if (len < n)
                expect_truncated(p, len, n);
        }
    uint64_t rng = tu_seed(0x7e57f11eull);
    int samples = tu_sanitizer_build() ? 60 : 400;
    for (int i = 0; i < samples; i++) {
        size_t len = (size_t)(tu_uniform(&rng) * (double)n);
        expect_truncated(p, len, n);
    }
    printf("larger file: %zu bytes, %d sampled truncations and the section boundaries\n", n,
           samples);

    /* bytes appended */
    unsigned char *q = malloc(n + 16);
    assert_non_null(q);
    memcpy(q, p, n);
    for (size_t extra = 1; extra <= 16; extra++) {
        memset(q + n, (int)extra, extra);
        char what[64];
        snprintf(what, sizeof what, "a copy with %zu bytes appended", extra);
        /* the last 8 bytes are no longer the checksum of the rest */
        expect_rejected(q, n + extra, WHY_CHECKSUM, what);
    }
    free(q);
    free(p);
}

/* Why a corrupt copy q of the file p must be refused: the magic is checked
 * first, then the version (which names the checksum), then the checksum. */
static const char *corrupt_reason(const unsigned char *p, const unsigned char *q)
{
    if (memcmp(p, q, 8) != 0)
        return WHY_MAGIC;
    uint32_t v = get_u32(q + OFF_VERSION);
    return v >= 2 && v <= 6 ? WHY_CHECKSUM : "unsupported version";
}

static void test_corrupt(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0xc0ffee11ull);
    size_t n;
    unsigned char *p = saved_scene("sphere", 2, &n);
    unsigned char *o = malloc(n);
    assert_non_null(o);
    memcpy(o, p, n);
    /* one bit flipped in every byte (the checksum's included) */
    for (size_t i = 0; i < n; i++) {
        unsigned char bit = (unsigned char)(1u << (tu_next(&rng) % 8));
        p[i] ^= bit;
        char what[96];
        snprintf(what, sizeof what, "byte %zu of %zu with bit 0x%02x flipped", i, n, bit);
        /* the magic and the version are checked first; any other byte breaks
           the checksum */
        expect_rejected(p, n, corrupt_reason(o, p), what);
        p[i] ^= bit;
    }
    /* and every bit of the version field (5 -> 4 is a version that reads FNV-1a) */
    for (int b = 0; b < 32; b++) {
        put_u32(p + OFF_VERSION, FILE_VERSION ^ (1u << b));
        char what[96];
        snprintf(what, sizeof what, "version %u", get_u32(p + OFF_VERSION));
        expect_rejected(p, n, corrupt_reason(o, p), what);
    }
    free(o);
    printf("small file: %zu single-bit corruptions rejected\n", n);
    free(p);

    p = saved_scene("crosscap", tu_sanitizer_build() ? 4 : 5, &n);
    unsigned char *q = malloc(n);
    assert_non_null(q);
    int tries = tu_sanitizer_build() ? 300 : 2000;
    for (int k = 0; k < tries; k++) {
        memcpy(q, p, n);
        int bytes = 1 + (int)(tu_next(&rng) % 8);
        for (int b = 0; b < bytes; b++) {
            size_t at = (size_t)(tu_next(&rng) % n);
            q[at] ^= (unsigned char)(1 + tu_next(&rng) % 255); /* a change, never a no-op */
        }
        if (memcmp(p, q, n) != 0) {
            char what[64];
            snprintf(what, sizeof what, "a copy with %d corrupt bytes", bytes);
            expect_rejected(q, n, corrupt_reason(p, q), what);
        }
    }
    printf("larger file: %zu bytes, %d multi-byte corruptions rejected\n", n, tries);
    free(q);
    free(p);
}

/* ---- corrupt, then re-signed: the structure checks alone ------------------------------- */

typedef void (*mutate_fn)(unsigned char *p, const layout_t *L);

static uint32_t node_at(const unsigned char *p, const layout_t *L, uint32_t i)
{
    return get_u32(p + L->nodes + 4 * (size_t)i);
}

static void set_node(unsigned char *p, const layout_t *L, uint32_t i, uint32_t v)
{
    put_u32(p + L->nodes + 4 * (size_t)i, v);
}

/* index of the first node of a kind after the root, or 0 */
static uint32_t find_node(const unsigned char *p, const layout_t *L, uint32_t kind)
{
    for (uint32_t i = 1; i < L->nn; i++)
        if (OCT_NODE_KIND(node_at(p, L, i)) == kind)
            return i;
    fail_msg("no node of kind %u", kind);
    return 0;
}

static void m_version(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_VERSION, FILE_VERSION_NEXT); }
/* a version 5 file read as version 6: one code byte per leaf is missing */
static void m_version_certain(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_VERSION, FILE_VERSION_CERTAIN); }
/* the same with FNV-1a: version 4 (re-signed with FNV-1a, the checksum it names) */
static void m_version_fnv_certain(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_VERSION, 4); }
static void m_version_zero(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_VERSION, 0); }
static void m_depth_big(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_DEPTH, OCT_MAX_DEPTH + 1); }
static void m_depth_neg(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_DEPTH, 0x80000000u); }
static void m_depth_less(unsigned char *p, const layout_t *L) { put_u32(p + OFF_DEPTH, get_u32(p + L->depth) - 1); }
static void m_refine_neg(unsigned char *p, const layout_t *L)
{
    (void)L;
    double v = -1;
    memcpy(p + OFF_REFINE, &v, 8);
}
static void m_refine_nan(unsigned char *p, const layout_t *L)
{
    (void)L;
    double v = NAN;
    memcpy(p + OFF_REFINE, &v, 8);
}
static void m_slabs_2(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_HAS_SLABS, 2); }
static void m_slabs_flip(unsigned char *p, const layout_t *L) { put_u32(p + OFF_HAS_SLABS, !L->has_slabs); }
static void m_name_len(unsigned char *p, const layout_t *L) { (void)L; put_u32(p + OFF_NAME, 0xffffffffu); }
static void m_lets_many(unsigned char *p, const layout_t *L) { put_u32(p + L->n_lets, 0xffffffffu); }
static void m_lets_more(unsigned char *p, const layout_t *L) { put_u32(p + L->n_lets, get_u32(p + L->n_lets) + 1); }
static void m_f_len(unsigned char *p, const layout_t *L) { put_u32(p + L->f, get_u32(p + L->f) + 1000); }
static void m_nodes_more(unsigned char *p, const layout_t *L) { put_u32(p + L->n_nodes, L->nn + 1); }
static void m_nodes_less(unsigned char *p, const layout_t *L) { put_u32(p + L->n_nodes, L->nn - 1); }
static void m_nodes_huge(unsigned char *p, const layout_t *L) { put_u32(p + L->n_nodes, 0xffffffffu); }
static void m_leaves_more(unsigned char *p, const layout_t *L) { put_u32(p + L->n_leaves, L->nl + 1); }
static void m_leaves_less(unsigned char *p, const layout_t *L) { put_u32(p + L->n_leaves, L->nl - 1); }
static void m_root_self(unsigned char *p, const layout_t *L) { set_node(p, L, 0, OCT_NODE(OCT_INTERIOR, 0)); }
static void m_root_empty(unsigned char *p, const layout_t *L) { set_node(p, L, 0, OCT_NODE(OCT_EMPTY, OCT_OUTSIDE)); }
static void m_child_out(unsigned char *p, const layout_t *L)
{
    set_node(p, L, find_node(p, L, OCT_INTERIOR), OCT_NODE(OCT_INTERIOR, L->nn - 7));
}
static void m_child_back(unsigned char *p, const layout_t *L)
{
    uint32_t i = find_node(p, L, OCT_INTERIOR);
    set_node(p, L, i, OCT_NODE(OCT_INTERIOR, i));
}
static void m_kind3(unsigned char *p, const layout_t *L) { set_node(p, L, find_node(p, L, OCT_EMPTY), 0xc0000000u); }
static void m_class3(unsigned char *p, const layout_t *L) { set_node(p, L, find_node(p, L, OCT_EMPTY), OCT_NODE(OCT_EMPTY, 3)); }
static void m_leaf_index(unsigned char *p, const layout_t *L)
{
    uint32_t i = find_node(p, L, OCT_LEAF);
    set_node(p, L, i, node_at(p, L, i) + 1);
}
static void m_leaf_index_big(unsigned char *p, const layout_t *L)
{
    set_node(p, L, find_node(p, L, OCT_LEAF), OCT_NODE(OCT_LEAF, 0x3fffffffu));
}
static void m_leaf_gone(unsigned char *p, const layout_t *L)
{
    set_node(p, L, find_node(p, L, OCT_LEAF), OCT_NODE(OCT_EMPTY, OCT_INSIDE));
}
static void m_leaf_code(unsigned char *p, const layout_t *L) { p[L->leaves] ^= 1; }
static void m_leaf_depth(unsigned char *p, const layout_t *L) { p[L->leaves + 24] -= 1; }
static void m_leaf_depth_big(unsigned char *p, const layout_t *L) { p[L->leaves + 24] = 200; }
static void m_box_nan(unsigned char *p, const layout_t *L)
{
    (void)L;
    double v = NAN;
    memcpy(p + OFF_BOX, &v, 8); /* the host is little-endian, like the format */
}
static void m_box_inf(unsigned char *p, const layout_t *L)
{
    (void)L;
    double v = INFINITY;
    memcpy(p + OFF_BOX + 8, &v, 8);
}
static void m_box_swap(unsigned char *p, const layout_t *L)
{
    (void)L;
    unsigned char tmp[8];
    memcpy(tmp, p + OFF_BOX + 16, 8);
    memcpy(p + OFF_BOX + 16, p + OFF_BOX + 24, 8);
    memcpy(p + OFF_BOX + 24, tmp, 8);
}

static void test_resigned_targeted(void **state)
{
    (void)state;
#define BAD_HEADER "bad header or truncated tree"
#define LEAF_CODE "leaf code does not match its place"
    static const struct {
        const char *what;
        mutate_fn fn;
        const char *why; /* what oct_load must say (octree/file.c) */
    } cases[] = {
        {"next version", m_version, "unsupported version"},
        {"version 0", m_version_zero, "unsupported version"},
        {"version 6 without the certain codes", m_version_certain, BAD_HEADER},
        {"version 4 without the certain codes", m_version_fnv_certain, BAD_HEADER},
        {"depth 22", m_depth_big, BAD_HEADER},
        {"depth 2^31", m_depth_neg, BAD_HEADER},
        {"depth one less than the tree's", m_depth_less, "bad child index"},
        {"refine -1", m_refine_neg, BAD_HEADER},
        {"refine NaN", m_refine_nan, BAD_HEADER},
        {"has_slabs 2", m_slabs_2, BAD_HEADER},
        {"has_slabs flipped", m_slabs_flip, BAD_HEADER},
        {"name length 2^32-1", m_name_len, "truncated scene"},
        {"2^32-1 lets", m_lets_many, "truncated scene"},
        {"one let more than there are", m_lets_more, BAD_HEADER},
        {"f longer than the file", m_f_len, BAD_HEADER},
        {"n_nodes + 1", m_nodes_more, BAD_HEADER},
        {"n_nodes - 1", m_nodes_less, BAD_HEADER},
        {"n_nodes 2^32-1", m_nodes_huge, BAD_HEADER},
        {"n_leaves + 1", m_leaves_more, BAD_HEADER},
        {"n_leaves - 1", m_leaves_less, BAD_HEADER},
        {"root's children at the root", m_root_self, "bad child index"},
        {"root empty: leaves unreached", m_root_empty, "nodes not reached from the root"},
        {"children block past the end", m_child_out, "bad child index"},
        {"children block at the parent", m_child_back, "bad child index"},
        {"node kind 3", m_kind3, "bad node kind"},
        {"empty class 3", m_class3, "bad cell class"},
        {"leaf index out of order", m_leaf_index, "leaves out of order"},
        {"leaf index past the leaves", m_leaf_index_big, "leaves out of order"},
        {"a leaf unreached", m_leaf_gone, "leaves out of order"},
        {"leaf code", m_leaf_code, LEAF_CODE},
        {"leaf depth", m_leaf_depth, LEAF_CODE},
        {"leaf depth 200", m_leaf_depth_big, LEAF_CODE},
        {"box NaN", m_box_nan, "bad box"},
        {"box infinite", m_box_inf, "bad box"},
        {"box y range inverted", m_box_swap, "bad box"},
    };
    for (int slabs = 0; slabs <= 1; slabs++) {
        size_t n;
        unsigned char *p = saved_scene_ex("thin-shell", 3, slabs, &n);
        layout_t L;
        layout_of(p, n, &L);
        assert_int_equal(get_u32(p + L.n_lets), 1);
        assert_int_equal(L.has_slabs, slabs);
        printf("%s ILIE slabs:\n", slabs ? "with" : "without");
        unsigned char *q = malloc(n);
        assert_non_null(q);
        for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
            memcpy(q, p, n);
            cases[c].fn(q, &L);
            assert_true(memcmp(p, q, n) != 0);
            resign(q, n);
            char what[128];
            snprintf(what, sizeof what, "re-signed file (%s slabs) with %s",
                     slabs ? "with" : "without", cases[c].what);
            expect_rejected(q, n, cases[c].why, what);
            printf("  %-34s rejected: %s\n", cases[c].what, cases[c].why);
        }
        free(q);
        free(p);
    }
}

static void test_resigned_random(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0xfa11ab1eull);
    for (int slabs = 0; slabs <= 1; slabs++) {
        size_t n;
        unsigned char *p = saved_scene_ex("steiner-roman", 3, slabs, &n);
        layout_t L;
        layout_of(p, n, &L);
        unsigned char *q = malloc(n);
        assert_non_null(q);
        int tries = tu_sanitizer_build() ? 300 : 2500, accepted = 0;
        for (int k = 0; k < tries; k++) {
            memcpy(q, p, n);
            int bytes = 1 + (int)(tu_next(&rng) % 4);
            for (int b = 0; b < bytes; b++) {
                /* half in the header and the nodes, where the structure is */
                size_t span = k % 2 ? L.leaves : L.checksum;
                size_t at = (size_t)(tu_next(&rng) % span);
                q[at] = (unsigned char)tu_next(&rng);
            }
            resign(q, n);
            char why[600];
            if (try_load(q, n, why, sizeof why) == 0) {
                accepted++;
                continue;
            }
            /* re-signed: the checksum holds, so the reason is the magic (when a
             * byte of it changed) or the structure */
            if (memcmp(p, q, 8) != 0 ? strcmp(why, WHY_MAGIC) != 0 : !is_structure_reason(why))
                fail_msg("re-signed random corruption %d (%s slabs) rejected for \"%s\": "
                         "expected %s",
                         k, slabs ? "with" : "without", why,
                         memcmp(p, q, 8) != 0 ? "a bad magic" : "a structure reason");
        }
        printf("%d re-signed random corruptions (%s slabs): %d accepted (and safe to walk), "
               "%d rejected\n",
               tries, slabs ? "with" : "without", accepted, tries - accepted);
        free(q);
        free(p);
    }
}

/* ---- shared and unreachable nodes ---------------------------------------------------- */

/* A file with the given nodes (no leaves), depth and a unit box. */
static unsigned char *craft(const uint32_t *nodes, uint32_t nn, int depth, size_t *n)
{
    size_t cap = 192 + 4 * (size_t)nn;
    unsigned char *p = calloc(cap, 1);
    assert_non_null(p);
    size_t at = 0;
    memcpy(p, "IVOCTREE", 8), at = 8;
    put_u32(p + at, FILE_VERSION), at += 4;
    put_u32(p + at, (uint32_t)depth), at += 4;
    put_u32(p + at, OCT_TEST_INTERVAL), at += 4;
    memset(p + at, 0, 8), at += 8; /* refine 0 */
    put_u32(p + at, 0), at += 4;   /* no slabs */
    for (int k = 0; k < 6; k++) {
        double v = k % 2;
        memcpy(p + at, &v, 8), at += 8;
    }
    put_u32(p + at, 3), memcpy(p + at + 4, "dag", 3), at += 7;
    put_u32(p + at, 0), at += 4;
    put_u32(p + at, 1), p[at + 4] = 'x', at += 5;
    for (int k = 0; k < 3; k++)
        put_u32(p + at, 0), at += 4; /* no parametrization */
    for (int k = 0; k < 4; k++) {
        double v = NAN;
        memcpy(p + at, &v, 8), at += 8;
    }
    put_u32(p + at, nn), at += 4;
    put_u32(p + at, 0), at += 4;
    for (uint32_t i = 0; i < nn; i++)
        put_u32(p + at, nodes[i]), at += 4;
    at += 8;
    resign(p, at);
    *n = at;
    return p;
}

/* A chain: root -> block 1 -> block 9 -> ... -> a block of empty cells.
 * shared: every node of a block points at the next block (8^levels paths to
 * the last one); else only the first node of each block does. */
static unsigned char *chain(int levels, int shared, uint32_t extra_blocks, size_t *n)
{
    uint32_t nn = 1 + 8 * (uint32_t)levels + 8 * extra_blocks;
    uint32_t *nodes = malloc(nn * sizeof *nodes);
    assert_non_null(nodes);
    nodes[0] = OCT_NODE(OCT_INTERIOR, 1);
    for (int l = 0; l < levels; l++)
        for (uint32_t k = 0; k < 8; k++) {
            uint32_t i = 1 + 8 * (uint32_t)l + k;
            int last = l == levels - 1;
            nodes[i] = !last && (shared || k == 0) ? OCT_NODE(OCT_INTERIOR, i - k + 8)
                                                   : OCT_NODE(OCT_EMPTY, OCT_OUTSIDE);
        }
    for (uint32_t i = 1 + 8 * (uint32_t)levels; i < nn; i++)
        nodes[i] = OCT_NODE(OCT_EMPTY, OCT_INSIDE);
    unsigned char *p = craft(nodes, nn, levels, n);
    free(nodes);
    return p;
}

static void test_crafted_tree_accepted(void **state)
{
    (void)state;
    /* the control: the crafted format is right */
    size_t n;
    unsigned char *p = chain(5, 0, 0, &n);
    char why[600] = "";
    if (try_load(p, n, why, sizeof why) != 0)
        fail_msg("a valid crafted tree was rejected: %s", why);
    free(p);
}

/* A DAG whose blocks are shared by several parents (no leaf reached twice):
 * a structure check that walks every path visits 8^levels nodes -- with
 * levels = 21, a 776-byte file kept `ivoct info` busy forever before
 * file.c checked that every block has exactly one parent.  Here levels = 5
 * (8^5 paths) so that the test ends even if that check regresses. */
static void test_shared_blocks_rejected(void **state)
{
    (void)state;
    size_t n;
    unsigned char *p = chain(5, 1, 0, &n);
    /* the second parent of a block finds it taken */
    expect_rejected(p, n, "bad child index",
                    "a file whose children blocks are shared by 8 parents each (41 nodes, 8^5 "
                    "paths to the last block)");
    free(p);
}

/* Nodes that no parent reaches are garbage a builder never writes. */
static void test_unreachable_nodes_rejected(void **state)
{
    (void)state;
    size_t n;
    unsigned char *p = chain(3, 0, 1, &n);
    expect_rejected(p, n, "nodes not reached from the root",
                    "a file with a block of 8 nodes that no parent reaches");
    free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_version_2),
        cmocka_unit_test(test_checksum_and_old_versions),
        cmocka_unit_test(test_missing_and_unwritable),
        cmocka_unit_test(test_truncated),
        cmocka_unit_test(test_corrupt),
        cmocka_unit_test(test_resigned_targeted),
        cmocka_unit_test(test_resigned_random),
        cmocka_unit_test(test_crafted_tree_accepted),
        cmocka_unit_test(test_shared_blocks_rejected),
        cmocka_unit_test(test_unreachable_nodes_rejected),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
