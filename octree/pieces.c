/* ivoct — a tree in pieces: the index (.pivo) of the parts of a tree saved by
 * the processes of a build over MPI, and reading it back as the whole tree.
 *
 * Each process saves its part (oct_plan_finish with OCT_PLAN_PART) as a tree
 * file of its own.  A part is a whole tree's top with the subtrees of the
 * other parts left as empty cells of class OCT_OUTSIDE, so the parts agree
 * everywhere except where one holds a subtree (split, or a surface leaf above
 * the frontier) and the others an OUTSIDE cell: the tree is their union,
 * taken cell by cell from the root down.  Anything else (a leaf in two parts,
 * a cell split in one part and a leaf or an INSIDE cell in another) means the
 * files do not belong together and is an error. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../io/io.h"
#include "file_internal.h"
#include "octree.h"

#define INDEX_VERSION 1
#define MAX_INDEX ((size_t)1 << 26) /* bytes: ~10^6 pieces */

int oct_file_checksum(const char *path, uint64_t *sum, ivoct_error_t *err)
{
    FILE *f = fopen(path, "rb");
    unsigned char c[8];
    int ok = f && fseek(f, -8, SEEK_END) == 0 && fread(c, 1, 8, f) == 8;
    if (f)
        fclose(f);
    if (!ok) {
        ivoct_error_set(err, "cannot read %s", path);
        return -1;
    }
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | c[i];
    *sum = v;
    return 0;
}

int oct_save_index(const char *path, const char *const *sources, const uint64_t *leaves,
                   const uint64_t *checksums, int n, ivoct_error_t *err)
{
    uint64_t total = 0;
    for (int i = 0; i < n; i++)
        total += leaves[i];
    io_file_t f;
    if (io_open(&f, path, err))
        return -1;
    fprintf(f.f, "ivoct-pieces %d pieces=%d leaves=%" PRIu64 "\n", INDEX_VERSION, n, total);
    fprintf(f.f, "# the pieces of one octree: file,leaves,checksum (ivoct info and ivoct render "
                 "--octree read this index as the whole tree)\n");
    for (int i = 0; i < n; i++)
        fprintf(f.f, "%s,%" PRIu64 ",%016" PRIx64 "\n", sources[i], leaves[i], checksums[i]);
    return io_commit(&f, err);
}

/* ---- reading the index ------------------------------------------------------------- */

typedef struct piece {
    char *path;          /* as opened: relative names joined to the index's folder */
    uint64_t leaves, checksum;
    int line;            /* of the index */
    oct_tree_t *tree;
    oct_source_t src;
} piece_t;

/* The index's text, NUL-terminated; NULL with err set. */
static char *read_text(const char *path, ivoct_error_t *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        ivoct_error_set(err, "cannot open %s", path);
        return NULL;
    }
    char *text = NULL;
    size_t n = 0, cap = 0;
    const char *why = NULL;
    while (!why) {
        if (n == cap) {
            cap = cap ? 2 * cap : (size_t)1 << 16;
            char *t = cap <= MAX_INDEX ? realloc(text, cap + 1) : NULL;
            if (!t) {
                why = cap > MAX_INDEX ? "%s: index too large" : "%s: out of memory";
                break;
            }
            text = t;
        }
        size_t got = fread(text + n, 1, cap - n, f);
        n += got;
        if (got == 0)
            break;
    }
    if (!why && ferror(f))
        why = "cannot read %s";
    fclose(f);
    if (why) {
        free(text);
        ivoct_error_set(err, why, path);
        return NULL;
    }
    text[n] = '\0';
    return text;
}

/* name relative to the folder of index (unless absolute) */
static char *join(const char *index, const char *name)
{
    const char *slash = strrchr(index, '/');
    size_t dir = name[0] == '/' || !slash ? 0 : (size_t)(slash - index) + 1;
    char *s = malloc(dir + strlen(name) + 1);
    if (s) {
        memcpy(s, index, dir);
        strcpy(s + dir, name);
    }
    return s;
}

static int parse_u64(const char *s, const char *end, int base, uint64_t *v)
{
    if (s == end)
        return -1;
    uint64_t x = 0;
    for (; s < end; s++) {
        int d = *s >= '0' && *s <= '9'   ? *s - '0'
                : *s >= 'a' && *s <= 'f' ? *s - 'a' + 10
                                         : 99;
        if (d >= base || x > (UINT64_MAX - (uint64_t)d) / (uint64_t)base)
            return -1;
        x = x * (uint64_t)base + (uint64_t)d;
    }
    *v = x;
    return 0;
}

/* The header and the pieces' lines of the index text (modified in place). */
static int parse_index(const char *path, char *text, piece_t **out, int *count,
                       uint64_t *total, ivoct_error_t *err)
{
    *out = NULL, *count = 0;
    int version, n, used;
    char *eol = strchr(text, '\n');
    if (!eol || sscanf(text, "ivoct-pieces %d pieces=%d leaves=%" SCNu64 "%n", &version, &n,
                       total, &used) != 3 || text + used != eol) {
        ivoct_error_set(err, "%s:1: not an index of octree pieces (expected \"ivoct-pieces 1 "
                             "pieces=N leaves=L\")", path);
        return -1;
    }
    if (version != INDEX_VERSION || n < 1 || n > 1 << 20) {
        ivoct_error_set(err, "%s:1: %s", path,
                        version != INDEX_VERSION ? "unsupported version" : "bad piece count");
        return -1;
    }
    piece_t *p = calloc((size_t)n, sizeof *p);
    if (!p) {
        ivoct_error_set(err, "%s: out of memory", path);
        return -1;
    }
    int k = 0, line = 1;
    const char *why = NULL;
    for (char *s = eol + 1; *s && !why; s = eol + 1) {
        line++;
        eol = strchr(s, '\n');
        if (!eol) {
            why = "the last line is not ended";
            break;
        }
        *eol = '\0';
        if (s[0] == '#')
            continue;
        /* file,leaves,checksum: the file name may hold commas, the numbers not */
        char *c2 = strrchr(s, ','), *c1 = NULL;
        if (c2) {
            *c2 = '\0';
            c1 = strrchr(s, ',');
        }
        if (!c1 || c1 == s) {
            why = "expected file,leaves,checksum";
            break;
        }
        *c1 = '\0';
        if (k == n) {
            why = "more pieces than the header says";
            break;
        }
        p[k].line = line;
        if (parse_u64(c1 + 1, c2, 10, &p[k].leaves) ||
            parse_u64(c2 + 1, eol, 16, &p[k].checksum) || eol - (c2 + 1) != 16) {
            why = "expected file,leaves,checksum (a decimal count, 16 hex digits)";
            break;
        }
        if (!(p[k].path = join(path, s))) {
            why = "out of memory";
            break;
        }
        k++;
    }
    if (!why && k != n)
        why = "fewer pieces than the header says", line = 1;
    if (why) {
        for (int i = 0; i < n; i++)
            free(p[i].path);
        free(p);
        ivoct_error_set(err, "%s:%d: %s", path, line, why);
        return -1;
    }
    *out = p, *count = n;
    return 0;
}

int oct_index_pieces(const char *path)
{
    FILE *f = fopen(path, "rb");
    int version, n;
    int ok = f && fscanf(f, "ivoct-pieces %d pieces=%d", &version, &n) == 2;
    if (f)
        fclose(f);
    return ok && n > 0 ? n : 0;
}

/* ---- checking that the pieces belong together ---------------------------------------- */

static int same_text(const char *a, const char *b)
{
    return (!a && !b) || (a && b && strcmp(a, b) == 0);
}

static int same_double(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* What differs between two pieces' trees and scenes, or NULL. */
static const char *difference(const piece_t *a, const piece_t *b)
{
    const oct_tree_t *s = a->tree, *t = b->tree;
    if (s->depth != t->depth)
        return "depth";
    if (s->tests != t->tests)
        return "tests";
    if (!same_double(s->refine, t->refine))
        return "refine";
    for (int k = 0; k < 6; k++)
        if (!same_double(s->box[k], t->box[k]))
            return "box";
    if ((s->slabs != NULL) != (t->slabs != NULL))
        return "slabs";
    if ((s->certain != NULL) != (t->certain != NULL))
        return "certain leaves";
    const oct_source_t *x = &a->src, *y = &b->src;
    int lets = x->n_lets == y->n_lets;
    for (size_t i = 0; lets && i < x->n_lets; i++)
        lets = same_text(x->let_names[i], y->let_names[i]) &&
               same_text(x->let_texts[i], y->let_texts[i]);
    if (!same_text(x->name, y->name) || !same_text(x->f, y->f) || !lets)
        return "scene";
    for (int k = 0; k < 3; k++)
        if (!same_text(x->param[k], y->param[k]))
            return "scene";
    for (int k = 0; k < 4; k++)
        if (!same_double(x->patch[k], y->patch[k]))
            return "scene";
    return NULL;
}

/* ---- the union ------------------------------------------------------------------------ */

typedef struct at {
    uint32_t piece, node;
} at_t;

typedef struct merge {
    const piece_t *p;
    int n;
    oct_tree_t *out;
    at_t *lists;  /* (depth + 2) * n: the pieces that have a cell, at each level */
    const char *why;
    int why_depth, why_a, why_b;
    uint64_t why_code;
} merge_t;

static void fail_at(merge_t *m, const char *why, int depth, uint64_t code, int a, int b)
{
    if (m->why)
        return;
    m->why = why, m->why_depth = depth, m->why_code = code, m->why_a = a, m->why_b = b;
}

/* Cell `code` of `depth`, held as at[0..nat) (pieces where its parent is
 * split), into node `out` of the tree being made. */
static void merge_cell(merge_t *m, const at_t *at, int nat, uint32_t out, uint64_t code,
                       int depth)
{
    oct_tree_t *t = m->out;
    int split = -1, leaf = -1, other = -1;
    unsigned classes = 0;
    for (int i = 0; i < nat && !m->why; i++) {
        oct_node_t v = m->p[at[i].piece].tree->nodes[at[i].node];
        int k = (int)at[i].piece;
        switch (OCT_NODE_KIND(v)) {
        case OCT_INTERIOR:
            split = split < 0 ? k : split;
            break;
        case OCT_LEAF:
            if (leaf >= 0)
                fail_at(m, "both hold the surface leaf", depth, code, leaf, k);
            leaf = k;
            break;
        default:
            if (OCT_NODE_VALUE(v) != OCT_OUTSIDE)
                other = k;
            classes |= 1u << OCT_NODE_VALUE(v);
        }
    }
    if (m->why)
        return;
    if (split >= 0 && leaf >= 0)
        fail_at(m, "split the cell and hold it as a leaf", depth, code, split, leaf);
    else if ((split >= 0 || leaf >= 0) && other >= 0)
        fail_at(m, "disagree on the cell", depth, code, split >= 0 ? split : leaf, other);
    else if (split < 0 && leaf < 0 && (classes & (classes - 1)))
        fail_at(m, "disagree on the cell", depth, code, (int)at[0].piece, (int)at[nat - 1].piece);
    if (m->why)
        return;
    if (leaf >= 0) {
        const oct_tree_t *s = m->p[leaf].tree;
        uint32_t from = 0;
        for (int i = 0; i < nat; i++)
            if ((int)at[i].piece == leaf)
                from = OCT_NODE_VALUE(s->nodes[at[i].node]);
        uint32_t to = t->n_leaves++;
        t->leaves[to] = s->leaves[from];
        if (t->slabs)
            t->slabs[to] = s->slabs[from];
        if (t->certain) {
            t->certain[to] = s->certain[from];
            t->stats.leaves_certain += s->certain[from] != 0;
        }
        t->nodes[out] = OCT_NODE(OCT_LEAF, to);
        return;
    }
    if (split < 0) {
        uint32_t cls = 0;
        while (!(classes >> cls & 1u))
            cls++;
        t->nodes[out] = OCT_NODE(OCT_EMPTY, cls);
        return;
    }
    uint32_t block = t->n_nodes;
    t->n_nodes += 8;
    t->nodes[out] = OCT_NODE(OCT_INTERIOR, block);
    at_t *child = m->lists + (size_t)(depth + 1) * (size_t)m->n;
    for (uint32_t c = 0; c < 8 && !m->why; c++) {
        int k = 0;
        for (int i = 0; i < nat; i++) {
            oct_node_t v = m->p[at[i].piece].tree->nodes[at[i].node];
            if (OCT_NODE_KIND(v) == OCT_INTERIOR)
                child[k++] = (at_t){at[i].piece, OCT_NODE_VALUE(v) + c};
        }
        merge_cell(m, child, k, block + c, code << 3 | c, depth + 1);
    }
}

/* The union of the pieces' trees (all of one build: checked before). */
static int merge(const char *path, const piece_t *p, int n, oct_tree_t **out, ivoct_error_t *err)
{
    uint64_t nodes = 0, leaves = 0;
    for (int k = 0; k < n; k++)
        nodes += p[k].tree->n_nodes, leaves += p[k].tree->n_leaves;
    const oct_tree_t *first = p[0].tree;
    oct_tree_t *t = calloc(1, sizeof *t);
    merge_t m = {p, n, t, NULL, NULL, 0, 0, 0, 0};
    if (t && nodes <= 0x3fffffffu && leaves <= 0x3fffffffu) {
        t->nodes = malloc((size_t)nodes * sizeof *t->nodes);
        t->leaves = calloc((size_t)leaves + 1, sizeof *t->leaves);
        t->slabs = first->slabs ? malloc(((size_t)leaves + 1) * sizeof *t->slabs) : NULL;
        t->certain = first->certain ? malloc((size_t)leaves + 1) : NULL;
        m.lists = malloc((size_t)(first->depth + 2) * (size_t)n * sizeof *m.lists);
    }
    if (!t || !t->nodes || !t->leaves || (first->slabs && !t->slabs) ||
        (first->certain && !t->certain) || !m.lists) {
        free(m.lists);
        oct_free(t);
        ivoct_error_set(err, "%s: too large or out of memory", path);
        return -1;
    }
    memcpy(t->box, first->box, sizeof t->box);
    t->depth = first->depth;
    t->tests = first->tests;
    t->refine = first->refine;
    for (int k = 0; k < n; k++)
        m.lists[k] = (at_t){(uint32_t)k, 0};
    t->n_nodes = 1;
    merge_cell(&m, m.lists, n, 0, 0, 0);
    free(m.lists);
    if (m.why) {
        ivoct_error_set(err, "%s: pieces %s and %s %s of depth %d, Morton code %" PRIu64
                             " (they are not parts of one tree)",
                        path, p[m.why_a].path, p[m.why_b].path, m.why, m.why_depth, m.why_code);
        oct_free(t);
        return -1;
    }
    *out = t;
    return 0;
}

int file_load_pieces(const char *path, oct_tree_t **out, oct_source_t *src, ivoct_error_t *err)
{
    *out = NULL;
    if (src)
        memset(src, 0, sizeof *src);
    char *text = read_text(path, err);
    if (!text)
        return -1;
    piece_t *p;
    int n;
    uint64_t total, sum = 0;
    int rc = parse_index(path, text, &p, &n, &total, err);
    free(text);
    if (rc)
        return -1;
    for (int k = 0; k < n && !rc; k++) {
        uint64_t checksum;
        ivoct_error_t why;
        ivoct_error_clear(&why);
        if (file_load_tree(p[k].path, &p[k].tree, &p[k].src, &checksum, &why)) {
            ivoct_error_set(err, "%s:%d: %s", path, p[k].line, why.msg);
            rc = -1;
        } else if (checksum != p[k].checksum || p[k].tree->n_leaves != p[k].leaves) {
            ivoct_error_set(err, "%s:%d: %s is not the piece the index names (its %s differs)",
                            path, p[k].line, p[k].path,
                            checksum != p[k].checksum ? "checksum" : "leaf count");
            rc = -1;
        } else if (k > 0 && difference(&p[0], &p[k])) {
            ivoct_error_set(err, "%s:%d: %s is not from the build of %s (its %s differs)", path,
                            p[k].line, p[k].path, p[0].path, difference(&p[0], &p[k]));
            rc = -1;
        }
        sum += p[k].leaves;
    }
    if (!rc && sum != total) {
        ivoct_error_set(err, "%s:1: the pieces hold %" PRIu64 " leaves, the header says %" PRIu64,
                        path, sum, total);
        rc = -1;
    }
    if (!rc)
        rc = merge(path, p, n, out, err);
    if (!rc && src) {
        *src = p[0].src;
        memset(&p[0].src, 0, sizeof p[0].src);
    }
    for (int k = 0; k < n; k++) {
        free(p[k].path);
        oct_free(p[k].tree);
        oct_source_free(&p[k].src);
    }
    free(p);
    return rc;
}
