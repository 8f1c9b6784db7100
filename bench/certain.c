/* ivoct_bench_certain — which surface leaves are proved to hold surface, by
 * point witnesses (oct_certify) and by modal intervals (mod_inner_range).
 *
 * Builds the octree of a scene at a depth on one thread (oct_build, as
 * `ivoct build` without outputs: slabs_unused), then two passes over its
 * surface leaves, each timed on its own, one thread:
 *   witness  oct_certify: f continuous on the leaf and two of its 15 sample
 *            points with certified opposite signs (or one certified zero);
 *   modal    per leaf mod_inner_range, the modal inner estimate [a, b] of the
 *            range of f over the leaf: on MOD_OK f is defined and continuous
 *            on the whole leaf and takes every value of [a, b] in it, so
 *            a <= 0 <= b proves a zero in the leaf.
 * Then the two sets compared: witness only, modal only, both, neither; and
 * hull_only — leaves neither proves where the hull of the two does: a modal
 * inner estimate of one sign (a > 0, say) and a sample point with a
 * certified value of the other (f < 0 there) give, f being continuous on
 * the connected leaf, a range that holds 0.  That is octree/README.md's
 * "hulled with the certified sample values", counted here rather than
 * assumed.  modal_status counts mod_inner_range's outcomes.
 *
 * Output: one JSON object on one line.
 *
 * usage: ivoct_bench_certain SCENE DEPTH [--tests LIST] */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../modal/modal.h"
#include "../octree/octree.h"
#include "../scene/scene.h"

static void usage(void)
{
    fputs("usage: ivoct_bench_certain SCENE DEPTH [--tests LIST]\n", stderr);
    exit(2);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Does a sample point of the leaf have a certified value of sign `sign`
 * (+1: f > 0, -1: f < 0)? */
static int sample_of_sign(const tape_t *t, tape_ws_t *ws, const iv_box_t *leaf, int sign)
{
    iv_box_t pts[OCT_SAMPLES];
    iv_t v[OCT_SAMPLES];
    for (int k = 0; k < OCT_SAMPLES; k++) {
        double p[3];
        oct_leaf_sample(leaf, k, p);
        pts[k] = (iv_box_t){iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
    }
    tape_eval_interval(t, ws, OCT_SAMPLES, pts, v);
    for (int k = 0; k < OCT_SAMPLES; k++)
        if (!iv_is_empty(v[k]) && (sign > 0 ? v[k].lo > 0 : v[k].hi < 0))
            return 1;
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 3)
        usage();
    const char *scene_path = argv[1];
    char *end;
    long depth = strtol(argv[2], &end, 10);
    if (*end || depth < 0 || depth > OCT_MAX_DEPTH)
        usage();
    const char *tests_text = NULL;
    for (int i = 3; i < argc; i++) {
        if (!strcmp(argv[i], "--tests") && i + 1 < argc)
            tests_text = argv[++i];
        else
            usage();
    }

    scene_t sc;
    ivoct_error_t err;
    char buf[512];
    if (scene_load(scene_path, &sc, &err)) {
        fprintf(stderr, "ivoct_bench_certain: %s\n", ivoct_error_format(&err, buf, sizeof buf));
        return 1;
    }
    oct_params_t p = sc.octree;
    p.depth = (int)depth;
    if (tests_text && oct_tests_parse(tests_text, &p.tests, &err)) {
        fprintf(stderr, "ivoct_bench_certain: --tests: %s\n", err.msg);
        return 2;
    }
    p.threads = 1;
    p.slabs_unused = 1;
    p.progress = NULL;

    oct_tree_t *tree = NULL;
    if (oct_build(sc.tape, sc.box, &p, &tree, &err)) {
        fprintf(stderr, "ivoct_bench_certain: oct_build: %s\n", err.msg);
        return 1;
    }
    if (oct_certify(tree, sc.tape, 1, &err)) {
        fprintf(stderr, "ivoct_bench_certain: oct_certify: %s\n", err.msg);
        return 1;
    }

    /* the modal pass, timed alone */
    uint32_t n = tree->n_leaves;
    uint8_t *modal = malloc(n ? n : 1);        /* 1: proved; 0: not */
    signed char *one_sign = malloc(n ? n : 1); /* MOD_OK without 0: the sign of [a, b] */
    if (!modal || !one_sign) {
        fputs("ivoct_bench_certain: out of memory\n", stderr);
        return 1;
    }
    uint64_t status[MOD_ENOMEM + 1] = {0};
    uint64_t ok_zero = 0, ok_nozero = 0;
    double t0 = now();
    for (uint32_t i = 0; i < n; i++) {
        iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
        iv_t r;
        mod_status_t st = mod_inner_range(sc.tape, &b, &r, NULL);
        modal[i] = 0;
        one_sign[i] = 0;
        if ((unsigned)st <= MOD_ENOMEM)
            status[st]++;
        if (st != MOD_OK)
            continue;
        if (r.lo <= 0 && 0 <= r.hi) {
            modal[i] = 1;
            ok_zero++;
        } else {
            one_sign[i] = r.lo > 0 ? 1 : -1;
            ok_nozero++;
        }
    }
    double modal_s = now() - t0;

    tape_ws_t *ws = tape_ws_new(sc.tape->n);
    if (!ws) {
        fputs("ivoct_bench_certain: out of memory\n", stderr);
        return 1;
    }
    uint64_t w_only = 0, m_only = 0, both = 0, neither = 0, hull_only = 0;
    for (uint32_t i = 0; i < n; i++) {
        int w = oct_leaf_certain(tree, i), m = modal[i];
        w_only += w && !m;
        m_only += m && !w;
        both += w && m;
        if (w || m)
            continue;
        neither++;
        if (one_sign[i]) {
            iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
            hull_only += sample_of_sign(sc.tape, ws, &b, -one_sign[i]);
        }
    }

    unsigned tests = p.tests;
    char tbuf[64];
    oct_tests_format(tests, tbuf, sizeof tbuf);
    printf("{\"scene\":\"%s\",\"tests\":\"%s\",\"depth\":%ld,\"leaves\":%u,"
           "\"witness\":%llu,\"modal\":%llu,\"witness_only\":%llu,\"modal_only\":%llu,"
           "\"both\":%llu,\"neither\":%llu,\"hull_only\":%llu,"
           "\"build_s\":%.4f,\"witness_s\":%.4f,\"modal_s\":%.4f,"
           "\"modal_status\":{\"ok_zero\":%llu,\"ok_one_sign\":%llu",
           sc.source.name, tbuf, depth, n, (unsigned long long)tree->stats.leaves_certain,
           (unsigned long long)(both + m_only), (unsigned long long)w_only,
           (unsigned long long)m_only, (unsigned long long)both, (unsigned long long)neither,
           (unsigned long long)hull_only, tree->stats.time_s, tree->stats.certain_time_s, modal_s,
           (unsigned long long)ok_zero, (unsigned long long)ok_nozero);
    for (int s = 1; s <= MOD_ENOMEM; s++)
        if (status[s])
            printf(",\"%s\":%llu", mod_status_name((mod_status_t)s), (unsigned long long)status[s]);
    printf("}}\n");

    tape_ws_free(ws);
    free(modal);
    free(one_sign);
    oct_free(tree);
    scene_free(&sc);
    return 0;
}
