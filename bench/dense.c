/* ivoct_dense — the dense-sampling baseline of the octree benchmark.
 *
 * What a marching-cubes pre-pass does: evaluate f with point arithmetic at all
 * (2^d + 1)^3 corners of the depth-d grid of the scene's box (the same cell
 * bounds as the octree's, from oct_coord) and keep the cells whose 8 corners
 * do not all have the same strict sign (a sign change, or a corner where f is
 * exactly 0; a NaN corner counts for nothing).  Rows of 2^d + 1 points go
 * through tape_eval_point in one call; slabs of planes of z are spread over
 * the threads, each holding one plane of signs and two planes of square
 * summaries.
 *
 * With --octree F.ivo (saved by `ivoct build --save` at the same depth) the
 * two cell sets are compared:
 *   octree_only  cells the octree keeps (certified as possibly holding
 *                surface) that sampling drops.  Not all are misses: a leaf
 *                may hold no surface.  On thin features (the horned cube's
 *                horns, zero lines without a sign change) they are real misses
 *                of sampling.
 *   octree_only_surface  those of them where a finer sampling (5^3 points per
 *                cell, corners included) finds a sign change: certainly
 *                surface that corner sampling drops, a lower bound of its real
 *                misses (a zero line without a sign change, like the
 *                crosscap's z-axis, is missed by any sampling and not counted).
 *   dense_only   cells with a sign change at their corners that the octree
 *                does not keep.  A sign change proves a zero in the closed
 *                cell, so this must be 0 (up to point-evaluation rounding at
 *                corners where |f| is at the rounding level).
 *
 * Output: one JSON object on stdout.
 *
 * usage: ivoct_dense SCENE [--depth N] [--threads N] [--octree F.ivo] */
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../octree/octree.h"
#include "../scene/scene.h"

static void usage(void)
{
    fputs("usage: ivoct_dense SCENE [--depth N] [--threads N] [--octree F.ivo]\n", stderr);
    exit(2);
}

/* quad bits of a 2x2 square of corners: which signs occur */
enum { Q_POS = 1, Q_NEG = 2, Q_ZERO = 4 };

static unsigned char sign_bits(double v)
{
    return v > 0 ? Q_POS : v < 0 ? Q_NEG : v == 0 ? Q_ZERO : 0; /* NaN: nothing */
}

static int kept(unsigned char q)
{
    return (q & Q_ZERO) || (q & (Q_POS | Q_NEG)) == (Q_POS | Q_NEG);
}

int main(int argc, char **argv)
{
    const char *scene_path = NULL, *compare = NULL;
    int depth = -1, threads = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--depth") && i + 1 < argc)
            depth = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--octree") && i + 1 < argc)
            compare = argv[++i];
        else if (argv[i][0] == '-')
            usage();
        else if (!scene_path)
            scene_path = argv[i];
        else
            usage();
    }
    if (!scene_path)
        usage();
    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(scene_path, &s, &err)) {
        char buf[1024];
        fprintf(stderr, "ivoct_dense: %s\n", ivoct_error_format(&err, buf, sizeof buf));
        return 2;
    }
    if (depth < 0)
        depth = s.octree.depth;
    if (depth < 1 || depth > 11) {
        fprintf(stderr, "ivoct_dense: depth %d out of 1..11\n", depth);
        return 2;
    }
    if (threads <= 0)
        threads = omp_get_num_procs();

    const uint32_t n = 1u << depth, m = n + 1;
    double *c[3];
    for (int a = 0; a < 3; a++) {
        c[a] = malloc(m * sizeof *c[a]);
        for (uint32_t i = 0; i < m; i++)
            c[a][i] = oct_coord(s.box[2 * a], s.box[2 * a + 1], i, depth);
    }
    uint64_t *bits = NULL;
    size_t nwords = ((size_t)n * n * n + 63) / 64;
    if (compare && !(bits = calloc(nwords, sizeof *bits))) {
        fprintf(stderr, "ivoct_dense: out of memory\n");
        return 1;
    }

    /* Slabs of SLAB cell layers go to whichever thread is free (no barrier
     * per plane: on a busy machine a descheduled thread would stall the
     * others); a slab evaluates its SLAB + 1 planes, so the planes between
     * slabs are evaluated twice, 1/SLAB of the work. */
    enum { SLAB = 16 };
    uint32_t nslabs = (n + SLAB - 1) / SLAB;
    uint64_t nkept = 0;
    int oom = 0;
    double t0 = omp_get_wtime();
#pragma omp parallel num_threads(threads) reduction(+ : nkept)
    {
        /* per thread: the signs of one plane of samples, (n+1)^2; the quads
         * (which signs occur at the 4 corners of each square) of the previous
         * and the current plane, n^2 each */
        tape_ws_t *ws = tape_ws_new(s.tape->n);
        double *y = malloc(m * sizeof *y), *z = malloc(m * sizeof *z);
        double *row = malloc(m * sizeof *row);
        unsigned char *plane = malloc((size_t)m * m);
        unsigned char *qprev = malloc((size_t)n * n), *qcur = malloc((size_t)n * n);
        int ok = ws && y && z && row && plane && qprev && qcur;
        if (!ok) {
#pragma omp atomic write
            oom = 1;
        }
#pragma omp for schedule(dynamic, 1)
        for (uint32_t sl = 0; sl < nslabs; sl++) {
            if (!ok)
                continue;
            uint32_t k0 = sl * SLAB, k1 = k0 + SLAB < n ? k0 + SLAB : n;
            for (uint32_t k = k0; k <= k1; k++) {
                for (uint32_t i = 0; i < m; i++)
                    z[i] = c[2][k];
                for (uint32_t j = 0; j < m; j++) {
                    for (uint32_t i = 0; i < m; i++)
                        y[i] = c[1][j];
                    tape_eval_point(s.tape, ws, m, c[0], y, z, row);
                    unsigned char *out = plane + (size_t)j * m;
                    for (uint32_t i = 0; i < m; i++)
                        out[i] = sign_bits(row[i]);
                }
                for (uint32_t j = 0; j < n; j++) {
                    const unsigned char *a = plane + (size_t)j * m, *b = a + m;
                    unsigned char *q = qcur + (size_t)j * n;
                    for (uint32_t i = 0; i < n; i++)
                        q[i] = a[i] | a[i + 1] | b[i] | b[i + 1];
                }
                if (k > k0)
                    for (uint32_t j = 0; j < n; j++) {
                        const unsigned char *a = qprev + (size_t)j * n, *b = qcur + (size_t)j * n;
                        for (uint32_t i = 0; i < n; i++)
                            if (kept(a[i] | b[i])) {
                                nkept++;
                                if (bits) {
                                    size_t at = ((size_t)(k - 1) * n + j) * n + i;
#pragma omp atomic update
                                    bits[at / 64] |= (uint64_t)1 << (at % 64);
                                }
                            }
                    }
                unsigned char *tmp = qprev;
                qprev = qcur;
                qcur = tmp;
            }
        }
        tape_ws_free(ws);
        free(y);
        free(z);
        free(row);
        free(plane);
        free(qprev);
        free(qcur);
    }
    if (oom) {
        fprintf(stderr, "ivoct_dense: out of memory\n");
        return 1;
    }
    double dense_time = omp_get_wtime() - t0;
    /* the points of the grid; the planes between slabs are evaluated twice */
    double points = (double)m * (double)m * (double)m;

    printf("{\"scene\": \"%s\", \"depth\": %d, \"threads\": %d, \"tape_clauses\": %u, "
           "\"points\": %.0f, \"dense_time_s\": %.6f, \"dense_cells\": %llu",
           s.source.name, depth, threads, s.tape->n, points, dense_time, (unsigned long long)nkept);

    if (compare) {
        oct_tree_t *t;
        if (oct_load(compare, &t, NULL, &err)) {
            fprintf(stderr, "ivoct_dense: %s\n", err.msg);
            return 1;
        }
        if (t->depth != depth || memcmp(t->box, s.box, sizeof s.box) != 0) {
            fprintf(stderr, "ivoct_dense: %s: not built at depth %d in the scene's box\n",
                    compare, depth);
            return 1;
        }
        uint64_t *leaf = calloc(nwords, sizeof *leaf);
        if (!leaf) {
            fprintf(stderr, "ivoct_dense: out of memory\n");
            return 1;
        }
        uint64_t octree_cells = 0;
        for (uint32_t l = 0; l < t->n_leaves; l++) {
            uint32_t ix, iy, iz;
            oct_unmorton(oct_leaf_code(&t->leaves[l]), oct_leaf_depth(&t->leaves[l]), &ix, &iy,
                         &iz);
            int sh = depth - oct_leaf_depth(&t->leaves[l]);
            for (uint32_t zz = iz << sh; zz < (iz + 1) << sh; zz++)
                for (uint32_t yy = iy << sh; yy < (iy + 1) << sh; yy++)
                    for (uint32_t xx = ix << sh; xx < (ix + 1) << sh; xx++) {
                        size_t at = ((size_t)zz * n + yy) * n + xx;
                        leaf[at / 64] |= (uint64_t)1 << (at % 64);
                        octree_cells++;
                    }
        }
        uint64_t both = 0, octree_only = 0, dense_only = 0, octree_only_surface = 0;
        for (size_t w = 0; w < nwords; w++) {
            both += (uint64_t)__builtin_popcountll(bits[w] & leaf[w]);
            octree_only += (uint64_t)__builtin_popcountll(leaf[w] & ~bits[w]);
            dense_only += (uint64_t)__builtin_popcountll(bits[w] & ~leaf[w]);
        }
        /* Of the cells only the octree keeps, those that certainly hold
         * surface: a sign change (or an exact zero) among 5^3 points of the
         * cell (its corners and 3 more per edge).  A lower bound of the
         * surface cells corner sampling misses. */
#pragma omp parallel num_threads(threads) reduction(+ : octree_only_surface)
        {
            enum { K = 5, KP = K * K * K };
            tape_ws_t *ws = tape_ws_new(s.tape->n);
            double px[KP], py[KP], pz[KP], v[KP];
#pragma omp for schedule(dynamic, 64)
            for (size_t w = 0; w < nwords; w++) {
                uint64_t only = leaf[w] & ~bits[w];
                while (only && ws) {
                    int b = __builtin_ctzll(only);
                    only &= only - 1;
                    size_t at = w * 64 + (size_t)b;
                    uint32_t ix = (uint32_t)(at % n), iy = (uint32_t)(at / n % n),
                             iz = (uint32_t)(at / n / n);
                    /* the sub-grid of depth d + 2 inside the cell */
                    int q = 0;
                    for (int c2 = 0; c2 < K; c2++)
                        for (int c1 = 0; c1 < K; c1++)
                            for (int c0 = 0; c0 < K; c0++, q++) {
                                px[q] = oct_coord(s.box[0], s.box[1], 4 * (uint64_t)ix + (uint64_t)c0, depth + 2);
                                py[q] = oct_coord(s.box[2], s.box[3], 4 * (uint64_t)iy + (uint64_t)c1, depth + 2);
                                pz[q] = oct_coord(s.box[4], s.box[5], 4 * (uint64_t)iz + (uint64_t)c2, depth + 2);
                            }
                    tape_eval_point(s.tape, ws, KP, px, py, pz, v);
                    unsigned char seen = 0;
                    for (int k = 0; k < KP; k++)
                        seen |= sign_bits(v[k]);
                    octree_only_surface += kept(seen);
                }
            }
            tape_ws_free(ws);
        }
        char tbuf[64];
        printf(", \"octree_tests\": \"%s\", \"octree_cells\": %llu, "
               "\"both\": %llu, \"octree_only\": %llu, \"octree_only_surface\": %llu, "
               "\"dense_only\": %llu",
               oct_tests_format(t->tests, tbuf, sizeof tbuf),
               (unsigned long long)octree_cells, (unsigned long long)both,
               (unsigned long long)octree_only, (unsigned long long)octree_only_surface,
               (unsigned long long)dense_only);
        free(leaf);
        oct_free(t);
    }
    printf("}\n");
    free(bits);
    for (int a = 0; a < 3; a++)
        free(c[a]);
    scene_free(&s);
    return 0;
}
