/* ivoct — the native octree file (.ivo).
 *
 * Layout, all integers little-endian, doubles as their IEEE bits:
 *   "IVOCTREE"  u32 version (6 with certain leaves, else 5; oct_load also reads
 *               4 and 3, the same layouts with the older checksum, and 2,
 *               without the parametrization)
 *   u32 depth  u32 tests  f64 refine  u32 has_slabs  f64 box[6]
 *   str name  u32 n_lets  (str let_name  str let_text) * n_lets  str f
 *   str param_x  str param_y  str param_z  f64 patch[4]   (versions 3 to 6; ""
 *                                                         for an implicit scene)
 *   u32 n_nodes  u32 n_leaves
 *   u32 node * n_nodes
 *   (u64 code  f64 f_lo  f64 f_hi  u8 depth) * n_leaves
 *   when has_slabs: (f64 n[3]  f64 d_lo  f64 d_hi  f64 thickness) * n_leaves
 *   versions 6 and 4: u8 certain * n_leaves   (oct_witness_decode codes)
 *   u64 checksum of every byte before it: XXH3-64 (xxHash, seed 0) in
 *       versions 5 and 6, FNV-1a 64 in versions 2, 3 and 4
 * where str = u32 length + bytes.  Versions 5 and 6 are 3 and 4 byte for byte
 * but for the version field and the checksum: FNV-1a is byte-serial (~4 cycles
 * a byte, most of a large save's time), XXH3 (libxxhash) runs at memory speed.
 * The reader checks every length against the file size before using it, the
 * checksum (the one the version names: an unknown version is refused), and
 * the tree's structure, so a truncated or corrupt file is an error and never a
 * crash. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <xxhash.h>

#include "../io/io.h"
#include "../mem/mem.h"
#include "file_internal.h"
#include "octree.h"

#define MAGIC "IVOCTREE"
#define VERSION 5u         /* without certain leaves: version 3's layout, XXH3-64 */
#define VERSION_CERTAIN 6u /* version 5 followed by the certain codes */
/* read only: the same layouts with FNV-1a 64 (files written before XXH3) */
#define VERSION_FNV 3u
#define VERSION_FNV_CERTAIN 4u
#define MAX_FILE ((size_t)1 << 36)

/* ---- writing through a buffer ----------------------------------------------------
 * The file goes out in large writes as it is made: a 1 MB staging buffer for
 * the small fields and the repacked leaves, and on a little-endian host the
 * node words and the slabs (the file's own byte order) straight from the tree's
 * arrays, one fwrite each.  The checksum (XXH3-64, streaming) is carried along
 * over every byte. */

#define WBUF_SIZE ((size_t)1 << 20)

#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) && \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HOST_LITTLE_ENDIAN 1
#else
#define HOST_LITTLE_ENDIAN 0
#endif

typedef struct wbuf {
    FILE *f;
    unsigned char *p;
    size_t n;
    XXH3_state_t *hash; /* XXH3-64 of every byte put so far */
} wbuf_t;

static void emit(wbuf_t *b, const void *src, size_t n)
{
    if (n)
        XXH3_64bits_update(b->hash, src, n);
    /* a failed write sets the stream's error flag, which io_commit reports */
    if (n && !ferror(b->f))
        fwrite(src, 1, n, b->f);
}

static void flush(wbuf_t *b)
{
    emit(b, b->p, b->n);
    b->n = 0;
}

static void put(wbuf_t *b, const void *src, size_t n)
{
    if (b->n + n > WBUF_SIZE)
        flush(b);
    if (n > WBUF_SIZE) {
        emit(b, src, n);
        return;
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
}

static void put_u64(wbuf_t *b, uint64_t v)
{
    unsigned char c[8];
    for (int i = 0; i < 8; i++)
        c[i] = (unsigned char)(v >> (8 * i));
    put(b, c, 8);
}

static void put_u32(wbuf_t *b, uint32_t v)
{
    unsigned char c[4];
    for (int i = 0; i < 4; i++)
        c[i] = (unsigned char)(v >> (8 * i));
    put(b, c, 4);
}

static void put_f64(wbuf_t *b, double x)
{
    uint64_t v;
    memcpy(&v, &x, 8);
    put_u64(b, v);
}

static void put_str(wbuf_t *b, const char *s)
{
    size_t n = s ? strlen(s) : 0;
    put_u32(b, (uint32_t)n);
    put(b, s ? s : "", n);
}

/* The checksum of files of versions 2 to 4, read only. */
static uint64_t fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

int oct_save(const oct_tree_t *tree, const oct_source_t *src, const char *path,
             ivoct_error_t *err)
{
    wbuf_t b = {NULL, malloc(WBUF_SIZE), 0, XXH3_createState()};
    if (!b.p || !b.hash || XXH3_64bits_reset(b.hash) != XXH_OK) {
        free(b.p);
        XXH3_freeState(b.hash);
        ivoct_error_set(err, "cannot write %s: out of memory", path);
        return -1;
    }
    io_file_t f;
    if (io_open(&f, path, err)) {
        free(b.p);
        XXH3_freeState(b.hash);
        return -1;
    }
    b.f = f.f;
    put(&b, MAGIC, 8);
    put_u32(&b, tree->certain ? VERSION_CERTAIN : VERSION);
    put_u32(&b, (uint32_t)tree->depth);
    put_u32(&b, tree->tests);
    put_f64(&b, tree->refine);
    put_u32(&b, tree->slabs != NULL);
    for (int k = 0; k < 6; k++)
        put_f64(&b, tree->box[k]);
    put_str(&b, src ? src->name : "");
    put_u32(&b, src ? (uint32_t)src->n_lets : 0);
    for (size_t i = 0; src && i < src->n_lets; i++) {
        put_str(&b, src->let_names[i]);
        put_str(&b, src->let_texts[i]);
    }
    put_str(&b, src ? src->f : "");
    for (int k = 0; k < 3; k++)
        put_str(&b, src && src->param[k] ? src->param[k] : "");
    for (int k = 0; k < 4; k++)
        put_f64(&b, src && src->param[0] ? src->patch[k] : NAN);
    put_u32(&b, tree->n_nodes);
    put_u32(&b, tree->n_leaves);
    if (HOST_LITTLE_ENDIAN) {
        put(&b, tree->nodes, (size_t)tree->n_nodes * sizeof *tree->nodes);
    } else {
        for (uint32_t i = 0; i < tree->n_nodes; i++)
            put_u32(&b, tree->nodes[i]);
    }
    /* 25 bytes a leaf in the file, 32 in memory (alignment): repacked */
    for (uint32_t i = 0; i < tree->n_leaves; i++) {
        const oct_leaf_t *l = &tree->leaves[i];
        unsigned char depth = (unsigned char)oct_leaf_depth(l);
        uint64_t code = oct_leaf_code(l);
        double f_lo = l->f_lo, f_hi = l->f_hi;
        if (HOST_LITTLE_ENDIAN && b.n + 25 <= WBUF_SIZE) {
            unsigned char *q = b.p + b.n;
            memcpy(q, &code, 8);
            memcpy(q + 8, &f_lo, 8);
            memcpy(q + 16, &f_hi, 8);
            q[24] = depth;
            b.n += 25;
            continue;
        }
        put_u64(&b, code);
        put_f64(&b, f_lo);
        put_f64(&b, f_hi);
        put(&b, &depth, 1);
    }
    if (tree->slabs && HOST_LITTLE_ENDIAN && sizeof(oct_slab_t) == 48) {
        put(&b, tree->slabs, (size_t)tree->n_leaves * sizeof *tree->slabs);
    } else {
        for (uint32_t i = 0; tree->slabs && i < tree->n_leaves; i++) {
            const oct_slab_t *sl = &tree->slabs[i];
            for (int k = 0; k < 3; k++)
                put_f64(&b, sl->n[k]);
            put_f64(&b, sl->d_lo);
            put_f64(&b, sl->d_hi);
            put_f64(&b, sl->thickness);
        }
    }
    if (tree->certain)
        put(&b, tree->certain, tree->n_leaves);
    flush(&b);
    uint64_t sum = XXH3_64bits_digest(b.hash);
    put_u64(&b, sum);
    flush(&b);
    free(b.p);
    XXH3_freeState(b.hash);
    return io_commit(&f, err);
}

/* ---- reading with bounds checks ---------------------------------------------------- */

typedef struct reader {
    const unsigned char *p;
    size_t n, at;
    int bad;
} reader_t;

static inline const unsigned char *take(reader_t *r, size_t n)
{
    if (r->bad || n > r->n - r->at) {
        r->bad = 1;
        return NULL;
    }
    const unsigned char *q = r->p + r->at;
    r->at += n;
    return q;
}

/* Little-endian values, their bytes shifted into place in one expression,
 * which the compiler makes one load (and a byte swap on a big-endian host);
 * a loop over the bytes stays a load, a shift and an or each, and was most
 * of a large file's decoding.  0 past the end (r->bad is set). */
static inline uint64_t get_u64(reader_t *r)
{
    const unsigned char *c = take(r, 8);
    if (!c)
        return 0;
    return (uint64_t)c[0] | (uint64_t)c[1] << 8 | (uint64_t)c[2] << 16 | (uint64_t)c[3] << 24 |
           (uint64_t)c[4] << 32 | (uint64_t)c[5] << 40 | (uint64_t)c[6] << 48 |
           (uint64_t)c[7] << 56;
}

static inline uint32_t get_u32(reader_t *r)
{
    const unsigned char *c = take(r, 4);
    if (!c)
        return 0;
    return (uint32_t)c[0] | (uint32_t)c[1] << 8 | (uint32_t)c[2] << 16 | (uint32_t)c[3] << 24;
}

static inline double get_f64(reader_t *r)
{
    uint64_t v = get_u64(r);
    double x;
    memcpy(&x, &v, 8);
    return x;
}

static char *get_str(reader_t *r)
{
    uint32_t n = get_u32(r);
    const unsigned char *c = take(r, n);
    if (!c)
        return NULL;
    char *s = malloc((size_t)n + 1);
    if (!s) {
        r->bad = 1;
        return NULL;
    }
    memcpy(s, c, n);
    s[n] = '\0';
    return s;
}

void oct_source_free(oct_source_t *src)
{
    if (!src)
        return;
    free(src->name);
    for (size_t i = 0; i < src->n_lets; i++) {
        if (src->let_names)
            free(src->let_names[i]);
        if (src->let_texts)
            free(src->let_texts[i]);
    }
    free(src->let_names);
    free(src->let_texts);
    free(src->f);
    for (int k = 0; k < 3; k++)
        free(src->param[k]);
    memset(src, 0, sizeof *src);
}

/* The structure a builder makes: the root at 0, then blocks of 8 children at
 * 1, 9, 17, ..., each block the children of exactly one interior node that
 * comes before it, every block reached, every leaf reached once at the place
 * its Morton code names.  (A block shared by several parents would make the
 * walk exponential; an unreached one would be garbage.)  Returns a reason or
 * NULL. */
static const char *check_structure(const oct_tree_t *t)
{
    if (t->n_nodes == 0 || (t->n_nodes - 1) % 8 != 0)
        return "bad node count";
    uint32_t nblocks = (t->n_nodes - 1) / 8;
    unsigned char *seen = calloc(nblocks ? nblocks : 1, 1);
    if (!seen)
        return "out of memory";
    struct {
        uint32_t node;
        uint64_t code;
        int depth;
    } stack[8 * (OCT_MAX_DEPTH + 2)];
    int sp = 0;
    uint32_t next_leaf = 0, interior = 0;
    const char *why = NULL;
    stack[sp].node = 0, stack[sp].code = 0, stack[sp].depth = 0, sp++;
    while (sp > 0 && !why) {
        sp--;
        uint32_t i = stack[sp].node;
        uint64_t code = stack[sp].code;
        int depth = stack[sp].depth;
        oct_node_t v = t->nodes[i];
        uint32_t val = OCT_NODE_VALUE(v);
        switch (OCT_NODE_KIND(v)) {
        case OCT_INTERIOR:
            if (nblocks == 0 || depth >= t->depth || val <= i || val > t->n_nodes - 8 ||
                (val - 1) % 8 != 0 || seen[(val - 1) / 8]) {
                why = "bad child index";
                break;
            }
            seen[(val - 1) / 8] = 1;
            interior++;
            for (int k = 7; k >= 0; k--) {
                stack[sp].node = val + (uint32_t)k;
                stack[sp].code = code << 3 | (uint64_t)k;
                stack[sp].depth = depth + 1;
                sp++;
            }
            break;
        case OCT_LEAF:
            if (val != next_leaf || val >= t->n_leaves)
                why = "leaves out of order";
            else if (t->leaves[val].key != ((uint64_t)1 << (3 * depth) | code))
                why = "leaf code does not match its place";
            next_leaf++;
            break;
        case OCT_EMPTY:
            if (val > OCT_UNDEFINED)
                why = "bad cell class";
            break;
        default:
            why = "bad node kind";
        }
    }
    free(seen);
    if (!why && interior != nblocks)
        why = "nodes not reached from the root";
    if (!why && next_leaf != t->n_leaves)
        why = "leaves not reached from the root";
    return why;
}

int oct_load(const char *path, oct_tree_t **out, oct_source_t *src, ivoct_error_t *err)
{
    /* an index of pieces begins with its own magic; anything else is read as
       one tree, whose loader says what is wrong with it */
    char magic8[8];
    FILE *f = fopen(path, "rb");
    int pieces = f && fread(magic8, 1, 8, f) == 8 && memcmp(magic8, PIECES_MAGIC, 8) == 0;
    if (f)
        fclose(f);
    return pieces ? file_load_pieces(path, out, src, err)
                  : file_load_tree(path, out, src, NULL, err);
}

int file_load_tree(const char *path, oct_tree_t **out, oct_source_t *src, uint64_t *checksum,
                   ivoct_error_t *err)
{
    *out = NULL;
    if (src)
        memset(src, 0, sizeof *src);
    FILE *f = fopen(path, "rb");
    if (!f) {
        ivoct_error_set(err, "cannot open %s", path);
        return -1;
    }
    char magic8[8];
    if (fread(magic8, 1, 8, f) != 8 || memcmp(magic8, MAGIC, 8) != 0) {
        fclose(f);
        ivoct_error_set(err, "%s: not an ivoct octree file (bad magic)", path);
        return -1;
    }
    /* the whole file in one buffer, of its size when the file says (one
       more byte, so that the read ends at EOF), else grown by doubling */
    long size = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    rewind(f);
    unsigned char *data = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n == cap) {
            cap = cap ? 2 * cap : size > 0 && (size_t)size < MAX_FILE ? (size_t)size + 1 : 1 << 16;
            unsigned char *q = cap <= MAX_FILE ? mem_huge_realloc(data, cap) : NULL;
            if (!q) {
                free(data);
                fclose(f);
                ivoct_error_set(err, "%s: too large or out of memory", path);
                return -1;
            }
            data = q;
        }
        size_t got = fread(data + n, 1, cap - n, f);
        n += got;
        if (got == 0)
            break;
    }
    int rd_err = ferror(f);
    fclose(f);
    if (rd_err) {
        free(data);
        ivoct_error_set(err, "cannot read %s", path);
        return -1;
    }

    const char *why = NULL;
    reader_t r = {data, n, 0, 0};
    oct_tree_t *t = calloc(1, sizeof *t);
    oct_source_t s = {0};
    const unsigned char *magic = take(&r, 8);
    if (!t) {
        why = "out of memory";
        goto fail;
    }
    if (!magic || memcmp(magic, MAGIC, 8) != 0) {
        why = "not an ivoct octree file (bad magic)";
        goto fail;
    }
    /* the version names the checksum: read it first, then check the checksum
     * before anything else */
    if (n < 8 + 4 + 8) {
        why = "checksum mismatch (truncated or corrupt file)";
        goto fail;
    }
    uint32_t version = get_u32(&r);
    int xxh3 = version == VERSION || version == VERSION_CERTAIN;
    if (!xxh3 && version != VERSION_FNV && version != VERSION_FNV_CERTAIN && version != 2) {
        why = "unsupported version";
        goto fail;
    }
    r.at = n - 8;
    uint64_t stored = get_u64(&r);
    if ((xxh3 ? XXH3_64bits(data, n - 8) : fnv1a(data, n - 8)) != stored) {
        why = "checksum mismatch (truncated or corrupt file)";
        goto fail;
    }
    r.n = n - 8; /* the checksum is not payload */
    r.at = 8 + 4;
    /* the certain leaves' codes follow the slabs */
    int has_certain = version == VERSION_CERTAIN || version == VERSION_FNV_CERTAIN;
    t->depth = (int)get_u32(&r);
    t->tests = get_u32(&r);
    t->refine = get_f64(&r);
    uint32_t has_slabs = get_u32(&r);
    for (int k = 0; k < 6; k++)
        t->box[k] = get_f64(&r);
    s.name = get_str(&r);
    uint32_t nl = get_u32(&r);
    if (r.bad || nl > (r.n - r.at) / 8) {
        why = "truncated scene";
        goto fail;
    }
    s.let_names = calloc(nl ? nl : 1, sizeof *s.let_names);
    s.let_texts = calloc(nl ? nl : 1, sizeof *s.let_texts);
    if (!s.let_names || !s.let_texts) {
        why = "out of memory";
        goto fail;
    }
    s.n_lets = nl;
    for (uint32_t i = 0; i < nl && !r.bad; i++) {
        s.let_names[i] = get_str(&r);
        s.let_texts[i] = get_str(&r);
    }
    s.f = get_str(&r);
    for (int k = 0; k < 4; k++)
        s.patch[k] = NAN;
    if (version >= 3) {
        for (int k = 0; k < 3; k++)
            s.param[k] = get_str(&r);
        for (int k = 0; k < 4; k++)
            s.patch[k] = get_f64(&r);
        int given = 0;
        for (int k = 0; k < 3; k++)
            given += s.param[k] && s.param[k][0];
        if (given != 0 && given != 3)
            r.bad = 1; /* a parametrization has its three coordinates */
        for (int k = 0; k < 3 && !given; k++) {
            free(s.param[k]);
            s.param[k] = NULL;
        }
    }
    t->n_nodes = get_u32(&r);
    t->n_leaves = get_u32(&r);
    if (r.bad || t->depth < 0 || t->depth > OCT_MAX_DEPTH ||
        has_slabs > 1 || !(t->refine >= 0) ||
        (uint64_t)t->n_nodes * 4 +
                (uint64_t)t->n_leaves * (25 + 48 * has_slabs + (uint64_t)has_certain) !=
            r.n - r.at) {
        why = "bad header or truncated tree";
        goto fail;
    }
    t->nodes = mem_huge_alloc(((size_t)t->n_nodes + 1) * sizeof *t->nodes);
    t->leaves = mem_huge_alloc(((size_t)t->n_leaves + 1) * sizeof *t->leaves);
    if (!t->nodes || !t->leaves) {
        why = "out of memory";
        goto fail;
    }
    memset(&t->leaves[t->n_leaves], 0, sizeof *t->leaves);
    for (uint32_t i = 0; i < t->n_nodes; i++)
        t->nodes[i] = get_u32(&r);
    for (uint32_t i = 0; i < t->n_leaves; i++) {
        uint64_t code = get_u64(&r);
        double f_lo = get_f64(&r), f_hi = get_f64(&r);
        const unsigned char *d = take(&r, 1);
        int fits = d && *d <= OCT_MAX_DEPTH && !(code >> (3 * *d));
        t->leaves[i] = oct_leaf_make(fits ? code : 0, fits ? *d : 0, f_lo, f_hi);
        /* a depth or code no leaf can have: key 0 matches no place, so the
         * structure check below refuses the file */
        if (!fits)
            t->leaves[i].key = 0;
    }
    if (has_slabs) {
        t->slabs = mem_huge_alloc(((size_t)t->n_leaves + 1) * sizeof *t->slabs);
        if (!t->slabs) {
            why = "out of memory";
            goto fail;
        }
        for (uint32_t i = 0; i < t->n_leaves; i++) {
            oct_slab_t *sl = &t->slabs[i];
            for (int k = 0; k < 3; k++)
                sl->n[k] = get_f64(&r);
            sl->d_lo = get_f64(&r);
            sl->d_hi = get_f64(&r);
            sl->thickness = get_f64(&r);
        }
    }
    if (has_certain) {
        t->certain = malloc((size_t)t->n_leaves + 1);
        const unsigned char *c = take(&r, t->n_leaves);
        if (!t->certain) {
            why = "out of memory";
            goto fail;
        }
        for (uint32_t i = 0; c && i < t->n_leaves; i++) {
            oct_witness_t w = oct_witness_decode(c[i]);
            if (c[i] && w.kind == OCT_WITNESS_NONE) {
                why = "bad certain leaf code";
                goto fail;
            }
            t->certain[i] = c[i];
            t->stats.leaves_certain += c[i] != 0;
        }
    }
    if (r.bad) {
        why = "truncated tree";
        goto fail;
    }
    if ((why = check_structure(t)) != NULL)
        goto fail;
    for (int k = 0; k < 3; k++)
        if (!(t->box[2 * k] <= t->box[2 * k + 1]) || !isfinite(t->box[2 * k]) ||
            !isfinite(t->box[2 * k + 1])) {
            why = "bad box";
            goto fail;
        }
    free(data);
    *out = t;
    if (checksum)
        *checksum = stored;
    if (src)
        *src = s;
    else
        oct_source_free(&s);
    return 0;
fail:
    free(data);
    oct_free(t);
    oct_source_free(&s);
    ivoct_error_set(err, "%s: %s", path, why);
    return -1;
}
