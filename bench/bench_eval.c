/* Benchmark: nanoseconds per tape clause and per box (or point) for the point,
 * interval, interval+gradient, point+gradient (plain doubles), affine (ILIE)
 * and ray (value, derivative along the ray and rounding bound:
 * tape_eval_ray) evaluators, with calls of TAPE_BATCH boxes (ray: segments of
 * one ray through the scene box), on scene files, for every SIMD path this
 * machine runs (side by side in one run).
 * Usage: ivoct_bench_eval [--seconds S] [--ray-lanes N] SCENE...
 * Prints one row per scene and path, and the ratios interval/point and
 * gradient/interval.  --ray-lanes N (1..TAPE_BATCH): the ray evaluator's calls
 * take N segments instead (a ray's search asks for 1 to 8 at a time); its
 * column is then still ns per clause per segment. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../ilie/ilie.h"
#include "../scene/scene.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

enum { NBOX = 1024 }; /* a working set that stays in cache, like the octree's */

typedef struct {
    const tape_t *t;
    tape_ws_t *ws;
    iv_box_t box[NBOX];
    double px[NBOX], py[NBOX], pz[NBOX];
    iv_t F[NBOX];
    iv_grad_t G[NBOX];
    double o[3], d[3];
    iv_t T[NBOX], dT[NBOX];
    double rnd[NBOX];
    double P[NBOX];
    tape_point_grad_t Q[NBOX];
    ilie_ws_t *iws;
    ilie_t A[NBOX];
} bench_t;

static void run_point(bench_t *b)
{
    for (int i = 0; i < NBOX; i += TAPE_BATCH)
        tape_eval_point(b->t, b->ws, TAPE_BATCH, b->px + i, b->py + i, b->pz + i, b->P + i);
}

static void run_interval(bench_t *b)
{
    for (int i = 0; i < NBOX; i += TAPE_BATCH)
        tape_eval_interval(b->t, b->ws, TAPE_BATCH, b->box + i, b->F + i);
}

static void run_grad(bench_t *b)
{
    for (int i = 0; i < NBOX; i += TAPE_BATCH)
        tape_eval_grad(b->t, b->ws, TAPE_BATCH, b->box + i, b->G + i);
}

static void run_point_grad(bench_t *b)
{
    for (int i = 0; i < NBOX; i += TAPE_BATCH)
        tape_eval_point_grad(b->t, b->ws, TAPE_BATCH, b->px + i, b->py + i, b->pz + i,
                             b->Q + i);
}

static int ray_lanes = TAPE_BATCH; /* segments per tape_eval_ray call */

static void run_ray(bench_t *b)
{
    for (int i = 0; i + ray_lanes <= NBOX; i += ray_lanes)
        tape_eval_ray(b->t, b->ws, b->o, b->d, (size_t)ray_lanes, b->T + i, b->F + i,
                      b->dT + i, b->rnd + i);
}

static void run_affine(bench_t *b)
{
    for (int i = 0; i < NBOX; i += TAPE_BATCH)
        ilie_eval(b->t, b->iws, TAPE_BATCH, b->box + i, b->A + i);
}

/* ns per clause per box: repeat for about `seconds`, best of 3 rounds */
static double measure(bench_t *b, void (*fn)(bench_t *), double seconds)
{
    double best = 1e300;
    for (int round = 0; round < 3; round++) {
        long reps = 0;
        double t0 = now(), t1;
        do {
            fn(b);
            reps++;
            t1 = now();
        } while (t1 - t0 < seconds / 3);
        /* (the ray calls cover the NBOX - NBOX % ray_lanes first segments) */
        int lanes = fn == run_ray ? NBOX - NBOX % ray_lanes : NBOX;
        double ns = (t1 - t0) * 1e9 / ((double)reps * lanes * b->t->n);
        if (ns < best)
            best = ns;
    }
    return best;
}

int main(int argc, char **argv)
{
    double seconds = 0.6;
    int first = 1;
    for (; first + 1 < argc; first += 2) {
        if (!strcmp(argv[first], "--seconds"))
            seconds = atof(argv[first + 1]);
        else if (!strcmp(argv[first], "--ray-lanes"))
            ray_lanes = atoi(argv[first + 1]);
        else
            break;
    }
    if (first >= argc || ray_lanes < 1 || ray_lanes > TAPE_BATCH) {
        fprintf(stderr, "usage: ivoct_bench_eval [--seconds S] [--ray-lanes 1..%d] SCENE...\n",
                TAPE_BATCH);
        return 2;
    }
    printf("%-26s %-9s %7s %9s %11s %9s %10s %9s %9s %7s %8s\n", "scene", "simd", "clauses",
           "point_ns", "interval_ns", "grad_ns", "ptgrad_ns", "ray_ns", "affine_ns", "iv/pt",
           "grad/iv");
    char paths[128];
    snprintf(paths, sizeof paths, "%s", tape_simd_paths());
    bench_t *b = malloc(sizeof *b);
    uint64_t seed = 12345;
    for (int a = first; a < argc; a++) {
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_load(argv[a], &s, &err)) {
            char buf[1024];
            fprintf(stderr, "%s\n", ivoct_error_format(&err, buf, sizeof buf));
            return 2;
        }
        b->t = s.tape;
        b->ws = tape_ws_new(s.tape->n);
        b->iws = ilie_ws_new(s.tape->n);
        /* cells of a depth-6 octree at random places, like the cells the
         * builder evaluates */
        for (int i = 0; i < NBOX; i++) {
            double c[3];
            for (int k = 0; k < 3; k++) {
                seed = seed * 6364136223846793005ull + 1442695040888963407ull;
                double u = (double)(seed >> 11) * 0x1p-53;
                double lo = s.box[2 * k], hi = s.box[2 * k + 1], w = (hi - lo) / 64;
                c[k] = lo + u * (hi - lo - w);
            }
            double w[3] = {(s.box[1] - s.box[0]) / 64, (s.box[3] - s.box[2]) / 64,
                           (s.box[5] - s.box[4]) / 64};
            b->box[i] = (iv_box_t){{c[0], c[0] + w[0]}, {c[1], c[1] + w[1]}, {c[2], c[2] + w[2]}};
            b->px[i] = c[0], b->py[i] = c[1], b->pz[i] = c[2];
        }
        /* a ray along the box's diagonal, in NBOX segments of 1/64 of it at
         * random places */
        for (int k = 0; k < 3; k++)
            b->o[k] = s.box[2 * k], b->d[k] = s.box[2 * k + 1] - s.box[2 * k];
        for (int i = 0; i < NBOX; i++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            double u = (double)(seed >> 11) * 0x1p-53 * (1 - 1.0 / 64);
            b->T[i] = iv_make(u, u + 1.0 / 64);
        }
        char list[128];
        memcpy(list, paths, sizeof list);
        for (char *save = NULL, *p = strtok_r(list, " ", &save); p; p = strtok_r(NULL, " ", &save)) {
            if (!tape_simd_available(p) || tape_simd_select(p, NULL))
                continue;
            double pt = measure(b, run_point, seconds);
            double iv = measure(b, run_interval, seconds);
            double gr = measure(b, run_grad, seconds);
            double pg = measure(b, run_point_grad, seconds);
            double ry = measure(b, run_ray, seconds);
            double af = measure(b, run_affine, seconds);
            printf("%-26s %-9s %7u %9.3f %11.3f %9.3f %10.3f %9.3f %9.3f %7.2f %8.2f\n",
                   s.source.name, p, s.tape->n, pt, iv, gr, pg, ry, af, iv / pt, gr / iv);
        }
        tape_simd_select(NULL, NULL);
        tape_ws_free(b->ws);
        ilie_ws_free(b->iws);
        scene_free(&s);
    }
    free(b);
    return 0;
}
