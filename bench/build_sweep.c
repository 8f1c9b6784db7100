/* ivoct_build_sweep — octree build, run time against certified error.
 *
 * For one scene, builds the octree for each chain of tests (interval;
 * interval, lipschitz; interval, lipschitz, ilie; and interval, ilie) at each
 * depth of a range, and with refine EPS for each tolerance of a list, and
 * prints one CSV row per build:
 *
 *   scene,chain,depth,refine,threads,time_s,leaves,cells_visited,max_error_bound,
 *   sampled,proven_empty,proven_surface,undecided
 *
 * time_s is the build alone (oct_build's own clock, best of --reps).
 * max_error_bound is the certified bound: every point of the surface lies in
 * a leaf, within that distance of the leaf's slab mid-plane, or anywhere in
 * the leaf for the leaf's diagonal.
 *
 * Which leaves hold no surface, decided rigorously: up to --sample leaves
 * (evenly spaced in Morton order, so the sample covers the whole surface) are
 * each
 *   proven_empty    when a further octree on the leaf's box, --extra levels
 *                   deeper with the whole chain, keeps no leaf: then f has no
 *                   zero in the leaf (the chain's guarantee);
 *   proven_surface  when two of 27 points of the leaf (corners, edge and face
 *                   centres, centre) have certified opposite signs (interval
 *                   evaluation at the point): f is continuous on the box, so it
 *                   has a zero there;
 *   undecided       otherwise (surface tangent to the leaf, zero sets without a
 *                   sign change, or too close to call at that depth).
 * The share of leaves without surface lies between proven_empty / sampled and
 * (proven_empty + undecided) / sampled.
 *
 * usage: ivoct_build_sweep SCENE [--depths A-B] [--eps "E1 E2 ..."] [--refine-depth N]
 *                          [--chains LIST;LIST;...] [--threads N] [--reps N]
 *                          [--sample N] [--extra N] */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../octree/octree.h"
#include "../scene/scene.h"

static void usage(void)
{
    fputs("usage: ivoct_build_sweep SCENE [--depths A-B] [--eps \"E1 E2 ...\"] "
          "[--refine-depth N]\n"
          "                         [--chains \"LIST;LIST;...\"] [--threads N] [--reps N] "
          "[--sample N] [--extra N]\n",
          stderr);
    exit(2);
}

/* Certified sign of f at point p: +1, -1, or 0 when unknown (or undefined). */
static int certified_sign(const tape_t *t, tape_ws_t *ws, const double p[3])
{
    iv_box_t b = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
    iv_t v;
    tape_eval_interval(t, ws, 1, &b, &v);
    if (iv_is_empty(v))
        return 0;
    return v.lo > 0 ? 1 : v.hi < 0 ? -1 : 0;
}

typedef struct {
    long sampled, empty, surface, undecided;
} emptiness_t;

static void classify_leaves(const tape_t *t, tape_ws_t *ws, const oct_tree_t *tree, long sample,
                            int extra, emptiness_t *e)
{
    memset(e, 0, sizeof *e);
    if (tree->n_leaves == 0 || sample <= 0)
        return;
    long n = (long)tree->n_leaves < sample ? (long)tree->n_leaves : sample;
    for (long k = 0; k < n; k++) {
        uint32_t i = (uint32_t)((double)k * tree->n_leaves / n);
        iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
        const iv_t *r[3] = {&b.x, &b.y, &b.z};
        int pos = 0, neg = 0;
        for (int q = 0; q < 27 && !(pos && neg); q++) {
            double p[3];
            int c[3] = {q % 3, q / 3 % 3, q / 9};
            for (int a = 0; a < 3; a++)
                p[a] = c[a] == 0 ? r[a]->lo : c[a] == 2 ? r[a]->hi : 0.5 * r[a]->lo + 0.5 * r[a]->hi;
            int s = certified_sign(t, ws, p);
            pos |= s > 0, neg |= s < 0;
        }
        e->sampled++;
        if (pos && neg) {
            e->surface++;
            continue;
        }
        double box[6] = {b.x.lo, b.x.hi, b.y.lo, b.y.hi, b.z.lo, b.z.hi};
        oct_params_t p = {.depth = extra,
                          .tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE,
                          .slabs_unused = 1,
                          .threads = 1};
        oct_tree_t *sub;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (oct_build(t, box, &p, &sub, &err) == 0) {
            if (sub->n_leaves == 0)
                e->empty++;
            else
                e->undecided++;
            oct_free(sub);
        } else {
            e->undecided++;
        }
    }
}

/* The scene's key in the CSV: its file name without directory and .ini. */
static const char *scene_key(const char *path, char *buf, size_t n)
{
    const char *slash = strrchr(path, '/');
    snprintf(buf, n, "%s", slash ? slash + 1 : path);
    char *dot = strrchr(buf, '.');
    if (dot && !strcmp(dot, ".ini"))
        *dot = '\0';
    return buf;
}

static int run(const scene_t *s, const char *key, tape_ws_t *ws, unsigned tests, int depth, double refine,
               int threads, int reps, long sample, int extra)
{
    oct_tree_t *best = NULL;
    for (int r = 0; r < reps; r++) {
        oct_params_t p = {.depth = depth, .tests = tests, .refine = refine,
                          .slabs_unused = refine == 0, .threads = threads};
        oct_tree_t *t;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (oct_build(s->tape, s->box, &p, &t, &err)) {
            fprintf(stderr, "ivoct_build_sweep: %s: depth %d: %s\n", s->source.name, depth, err.msg);
            oct_free(best);
            return -1;
        }
        if (!best || t->stats.time_s < best->stats.time_s) {
            oct_free(best);
            best = t;
        } else {
            oct_free(t);
        }
    }
    emptiness_t e;
    classify_leaves(s->tape, ws, best, sample, extra, &e);
    /* the chain as interval+lipschitz+ilie: no commas inside a CSV field */
    char text[64], chain[64];
    oct_tests_format(tests, text, sizeof text);
    size_t o = 0;
    for (const char *c = text; *c && o + 1 < sizeof chain; c++)
        if (*c != ' ')
            chain[o++] = *c == ',' ? '+' : *c;
    chain[o] = '\0';
    printf("%s,%s,%d,%g,%d,%.6f,%u,%llu,%.6g,%ld,%ld,%ld,%ld\n", key, chain, depth, refine,
           best->stats.threads, best->stats.time_s, best->n_leaves,
           (unsigned long long)best->stats.cells_visited, best->stats.max_error_bound, e.sampled,
           e.empty, e.surface, e.undecided);
    fflush(stdout);
    oct_free(best);
    return 0;
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    int d0 = 5, d1 = 10, refine_depth = -1, threads = 2, reps = 1, extra = 3;
    long sample = 256;
    const char *eps_list = "1e-2 1e-3 1e-4 1e-5 1e-6";
    const char *chains = "interval;interval,lipschitz;interval,lipschitz,ilie;interval,ilie";
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (a[0] != '-') {
            path = a;
            continue;
        }
        if (!v)
            usage();
        i++;
        if (!strcmp(a, "--depths")) {
            if (sscanf(v, "%d-%d", &d0, &d1) != 2 || d0 < 0 || d1 > OCT_MAX_DEPTH || d0 > d1)
                usage();
        } else if (!strcmp(a, "--eps")) {
            eps_list = v;
        } else if (!strcmp(a, "--refine-depth")) {
            refine_depth = atoi(v);
        } else if (!strcmp(a, "--chains")) {
            chains = v;
        } else if (!strcmp(a, "--threads")) {
            threads = atoi(v);
        } else if (!strcmp(a, "--reps")) {
            reps = atoi(v) > 0 ? atoi(v) : 1;
        } else if (!strcmp(a, "--sample")) {
            sample = atol(v);
        } else if (!strcmp(a, "--extra")) {
            extra = atoi(v);
        } else {
            usage();
        }
    }
    if (!path)
        usage();
    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(path, &s, &err)) {
        fprintf(stderr, "ivoct_build_sweep: %s\n", err.msg);
        return 2;
    }
    tape_ws_t *ws = tape_ws_new(s.tape->n);
    if (!ws) {
        fputs("ivoct_build_sweep: out of memory\n", stderr);
        return 1;
    }
    char key[256];
    scene_key(path, key, sizeof key);
    int rc = 0;
    /* the chains at each depth */
    char *list = strdup(chains);
    for (char *save = NULL, *c = strtok_r(list, ";", &save); c && !rc;
         c = strtok_r(NULL, ";", &save)) {
        unsigned tests;
        if (oct_tests_parse(c, &tests, &err)) {
            fprintf(stderr, "ivoct_build_sweep: --chains: %s\n", err.msg);
            rc = 2;
            break;
        }
        for (int d = d0; d <= d1 && !rc; d++)
            rc = run(&s, key, ws, tests, d, 0.0, threads, reps, sample, extra);
    }
    free(list);
    /* refine: for each EPS, the depth at which a leaf's diagonal is <= EPS (so
     * every leaf's bound is <= EPS), at most OCT_MAX_DEPTH, or --refine-depth */
    double diag = sqrt(pow(s.box[1] - s.box[0], 2) + pow(s.box[3] - s.box[2], 2) +
                       pow(s.box[5] - s.box[4], 2));
    char *eps_copy = strdup(eps_list);
    for (char *save = NULL, *e = strtok_r(eps_copy, " ,", &save); e && !rc;
         e = strtok_r(NULL, " ,", &save)) {
        double eps = atof(e);
        if (!(eps > 0))
            continue;
        int depth = refine_depth >= 0 ? refine_depth : (int)ceil(log2(diag / eps));
        depth = depth < 0 ? 0 : depth > OCT_MAX_DEPTH ? OCT_MAX_DEPTH : depth;
        rc = run(&s, key, ws, OCT_TEST_INTERVAL | OCT_TEST_ILIE, depth, eps, threads, reps, sample,
                 extra);
    }
    free(eps_copy);
    tape_ws_free(ws);
    scene_free(&s);
    return rc ? 1 : 0;
}
