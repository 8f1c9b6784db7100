/* ivoct octree — leaves that surely hold surface (see octree.h, oct_certify).
 *
 * A post-pass over the finished leaves, one leaf at a time as far as the
 * result goes (so it does not depend on threads or batching): continuity
 * first (the whole tape when it is total, else tape_check_continuous over the
 * leaf), then the samples in three waves, each only for the leaves the waves
 * before left without a witness: two opposite corners, the other six
 * corners, the centre and the face centres.  The samples of a wave of up to
 * 32 leaves that share a tape go through the interval evaluator in one call
 * (64 lanes or more); each lane is computed on its own, so batching changes
 * no result.
 * Where the tape has min, max or abs and is total, each leaf's pruned tape
 * (oct_leaf_tapes_build, no margin: every sample lies in the leaf) is used:
 * it equals f on the leaf. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "octree.h"

enum {
    CODE_ZERO = 1,         /* 1 + k */
    CODE_SIGNS = 16,       /* 16 + 14 k0 + (k1 < k0 ? k1 : k1 - 1): 210 codes */
    BATCH_LEAVES = 32,     /* 32 leaves x 2 corners = TAPE_BATCH lanes in the first wave */
    CHUNK = 256,           /* leaves per scheduling unit */
};

static double mid(double lo, double hi)
{
    double m = lo + (hi - lo) * 0.5;
    return m < lo ? lo : m > hi ? hi : m;
}

void oct_leaf_sample(const iv_box_t *box, int k, double p[3])
{
    const iv_t s[3] = {box->x, box->y, box->z};
    /* per axis 0 lower, 1 middle, 2 upper */
    int t[3];
    if (k < 8) {
        for (int a = 0; a < 3; a++)
            t[a] = (k >> a & 1) ? 2 : 0;
    } else {
        t[0] = t[1] = t[2] = 1;
        if (k > 8 && k < OCT_SAMPLES) {
            int f = k - 9;
            t[f / 2] = (f & 1) ? 2 : 0;
        }
    }
    for (int a = 0; a < 3; a++)
        p[a] = t[a] == 0 ? s[a].lo : t[a] == 2 ? s[a].hi : mid(s[a].lo, s[a].hi);
}

oct_witness_t oct_witness_decode(uint8_t code)
{
    oct_witness_t w = {OCT_WITNESS_NONE, -1, -1};
    if (code >= CODE_ZERO && code < CODE_ZERO + OCT_SAMPLES) {
        w.kind = OCT_WITNESS_ZERO;
        w.k0 = code - CODE_ZERO;
    } else if (code >= CODE_SIGNS && code < CODE_SIGNS + OCT_SAMPLES * (OCT_SAMPLES - 1)) {
        int c = code - CODE_SIGNS;
        w.kind = OCT_WITNESS_SIGNS;
        w.k0 = c / (OCT_SAMPLES - 1);
        int r = c % (OCT_SAMPLES - 1);
        w.k1 = r < w.k0 ? r : r + 1;
    }
    return w;
}

uint8_t oct_witness_encode(oct_witness_t w)
{
    int ok0 = w.k0 >= 0 && w.k0 < OCT_SAMPLES, ok1 = w.k1 >= 0 && w.k1 < OCT_SAMPLES;
    switch (w.kind) {
    case OCT_WITNESS_ZERO: return ok0 ? (uint8_t)(CODE_ZERO + w.k0) : 0;
    case OCT_WITNESS_SIGNS:
        if (!ok0 || !ok1 || w.k0 == w.k1)
            return 0;
        return (uint8_t)(CODE_SIGNS + (OCT_SAMPLES - 1) * w.k0 + (w.k1 < w.k0 ? w.k1 : w.k1 - 1));
    default: return 0;
    }
}

int oct_leaf_certain(const oct_tree_t *tree, uint32_t i)
{
    return tree && tree->certain && i < tree->n_leaves && tree->certain[i] != 0;
}

/* -1, 0, +1 when the enclosure certifies the sign of f at its point, 2 when
 * it does not */
static int sign_of(iv_t v)
{
    if (v.lo > 0)
        return 1;
    if (v.hi < 0)
        return -1;
    if (v.lo == 0 && v.hi == 0)
        return 0;
    return 2;
}

/* the witness from the signs of the samples (2 where not evaluated or not
 * certain): a sign change (the first negative and the first positive sample
 * by index), else a zero, else none */
static uint8_t witness_of(const signed char *sg)
{
    int neg = -1, pos = -1, zero = -1;
    for (int k = 0; k < OCT_SAMPLES; k++) {
        if (sg[k] == -1 && neg < 0)
            neg = k;
        else if (sg[k] == 1 && pos < 0)
            pos = k;
        else if (sg[k] == 0 && zero < 0)
            zero = k;
    }
    if (neg >= 0 && pos >= 0)
        return oct_witness_encode((oct_witness_t){OCT_WITNESS_SIGNS, neg, pos});
    if (zero >= 0)
        return oct_witness_encode((oct_witness_t){OCT_WITNESS_ZERO, zero, -1});
    return 0;
}

typedef struct worker {
    tape_ws_t *ws;
    iv_t *slots;
    iv_box_t boxes[BATCH_LEAVES * OCT_SAMPLES];
    iv_t out[BATCH_LEAVES * OCT_SAMPLES];
} worker_t;

/* The waves of samples: two opposite corners, the other corners, the rest.
 * A leaf goes on to the next wave only while the samples so far give no
 * witness, and its witness is witness_of over the samples so far: a
 * function of the leaf alone. */
static const int WAVE[3][2] = {{0, 2}, {2, 8}, {8, OCT_SAMPLES}};
static const int ORDER[OCT_SAMPLES] = {0, 7, 1, 2, 3, 4, 5, 6, 8, 9, 10, 11, 12, 13, 14};

/* leaves [first, first + n) that share tape t (n <= BATCH_LEAVES) */
static void certify_batch(const oct_tree_t *tree, const tape_t *t, int total, uint32_t first,
                          int n, worker_t *w, uint8_t *code)
{
    iv_box_t leaf[BATCH_LEAVES];
    signed char sg[BATCH_LEAVES][OCT_SAMPLES];
    int open = 0, idx[BATCH_LEAVES];
    for (int i = 0; i < n; i++) {
        leaf[i] = oct_leaf_box(tree, &tree->leaves[first + i]);
        code[first + i] = 0;
        memset(sg[i], 2, sizeof sg[i]);
        if (total ||
            tape_check_continuous(t, &leaf[i], w->slots, NULL) == TAPE_DOMAIN_CONTINUOUS)
            idx[open++] = i;
    }
    for (int v = 0; v < 3 && open; v++) {
        const int a = WAVE[v][0], m = WAVE[v][1] - a;
        for (int j = 0; j < open; j++)
            for (int q = 0; q < m; q++) {
                double p[3];
                oct_leaf_sample(&leaf[idx[j]], ORDER[a + q], p);
                w->boxes[m * j + q] = (iv_box_t){{p[0], p[0]}, {p[1], p[1]}, {p[2], p[2]}};
            }
        tape_eval_interval(t, w->ws, (size_t)(m * open), w->boxes, w->out);
        int still = 0;
        for (int j = 0; j < open; j++) {
            const int i = idx[j];
            for (int q = 0; q < m; q++)
                sg[i][ORDER[a + q]] = (signed char)sign_of(w->out[m * j + q]);
            code[first + i] = witness_of(sg[i]);
            if (!code[first + i])
                idx[still++] = i;
        }
        open = still;
    }
}

int oct_certify(oct_tree_t *tree, const tape_t *t, int threads, ivoct_error_t *err)
{
    if (!tree || !t || t->n == 0 || (tree->n_leaves && !tree->leaves)) {
        ivoct_error_set(err, "oct_certify: no tree or no tape");
        return -1;
    }
    double t0 = omp_get_wtime();
    uint32_t nl = tree->n_leaves;
    uint8_t *code = malloc(nl ? nl : 1);
    if (!code) {
        ivoct_error_set(err, "out of memory (%u bytes for the certain leaves)", nl);
        return -1;
    }
    int total = tape_is_total(t);
    oct_leaf_tapes_t *lt = NULL;
    if (total && tape_has_choices(t) && nl &&
        oct_leaf_tapes_build(tree, t, 0.0, 1.0, &lt, err)) {
        free(code);
        return -1;
    }
    int nt = threads > 0 ? threads : omp_get_max_threads();
    size_t nchunks = ((size_t)nl + CHUNK - 1) / CHUNK;
    if (nt > 1 && (size_t)nt > nchunks)
        nt = nchunks > 0 ? (int)nchunks : 1;
    int failed = 0;
#pragma omp parallel num_threads(nt) reduction(| : failed)
    {
        worker_t w;
        w.ws = tape_ws_new(t->n);
        w.slots = malloc(t->n * sizeof *w.slots);
        if (!w.ws || !w.slots)
            failed = 1;
#pragma omp for schedule(dynamic, 1)
        for (size_t c = 0; c < nchunks; c++) {
            if (failed)
                continue;
            uint32_t end = (uint32_t)((c + 1) * CHUNK < nl ? (c + 1) * CHUNK : nl);
            uint32_t i = (uint32_t)(c * CHUNK);
            while (i < end) {
                const tape_t *ti = lt ? lt->of_leaf[i] : t;
                int n = 1;
                while (n < BATCH_LEAVES && i + (uint32_t)n < end &&
                       (lt ? lt->of_leaf[i + (uint32_t)n] : t) == ti)
                    n++;
                certify_batch(tree, ti, total, i, n, &w, code);
                i += (uint32_t)n;
            }
        }
        tape_ws_free(w.ws);
        free(w.slots);
    }
    oct_leaf_tapes_free(lt);
    if (failed) {
        free(code);
        ivoct_error_set(err, "out of memory (certain leaves)");
        return -1;
    }
    uint64_t count = 0;
    for (uint32_t i = 0; i < nl; i++)
        count += code[i] != 0;
    free(tree->certain);
    tree->certain = code;
    tree->stats.leaves_certain = count;
    tree->stats.certain_time_s = omp_get_wtime() - t0;
    return 0;
}
