/* ivoct_ray_error — render time against hit error: ivoct's ray
 * methods with and without the octree, and the OpenVDB level-set ray caster,
 * against the high-precision reference of tests/support/ray_reference.c.
 *
 * For each surface (scenes/NAME.ini, its camera, at --size):
 *   reference  the first root in the box of every pixel's ray (MPFR, the
 *              same rays: ray_camera_dir), threads over pixels;
 *   octree     built once with the scene's [octree] settings (--depth
 *              overrides); its build time is reported apart;
 *   ivoct      for each method, ray_render with the octree source (--threads
 *              and 1 thread) and with the box source (--no-octree, --threads);
 *              the octree ones timed --reps times (their best), the other once;
 *              one-thread runs also give the CPU time of the thread, which a
 *              loaded machine does not inflate (cpu_1t_s);
 *   openvdb    the level set of bench/vdb_raycast.h (band from the octree's
 *              surface leaves), built once (time apart), cast with 1 thread
 *              and with --threads, best of --reps each.
 * Each row: time, and against the reference over the pixels where both hit,
 * max and mean |t - t_ref| (and the max over the pixels the reference does
 * not call ambiguous); pixels that disagree on hit/miss, and how many of
 * those the reference calls ambiguous (the ray within ~1e-9 of touching the
 * surface, or the surface within ~1e-9 of the box; see ray_reference.h) and
 * how many are within a voxel of that (graze <= voxel edge); and the pixel of
 * the max error with its graze (how close its ray comes to touching the
 * surface, relative: see ray_reference.h).
 *
 * Output: CSV (--csv, default bench/results/ray_error.csv) and a table on
 * stdout.
 *
 * usage: ivoct_ray_error [--scenes DIR] [--surfaces "a b"] [--methods "m n"]
 *                        [--size WxH] [--threads N] [--reps N] [--depth N]
 *                        [--voxel H] [--half-width N] [--csv F] [--quick]
 *                        [--dump DIR] */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <math.h>
#include <omp.h>
#include <time.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../octree/octree.h"
#include "../ray/ray.h"
#include "../scene/scene.h"
#include "../tests/support/ray_reference.h"
#include "vdb_raycast.h"

#define MAX_LIST 32

static void usage(void)
{
    fputs("usage: ivoct_ray_error [--scenes DIR] [--surfaces \"a b\"] [--methods \"m n\"]\n"
          "                       [--size WxH] [--threads N] [--reps N] [--depth N]\n"
          "                       [--voxel H] [--half-width N] [--csv F] [--quick] [--dump DIR]\n",
          stderr);
    exit(2);
}

static int split(char *s, char **out)
{
    int n = 0;
    for (char *tok = strtok(s, " ,"); tok && n < MAX_LIST; tok = strtok(NULL, " ,"))
        out[n++] = tok;
    return n;
}

/* The reference of one image. */
typedef struct ref_image {
    size_t npix;
    unsigned char *inbox, *hit, *amb;
    double *r, *graze;
    size_t n_in, n_hit, n_amb;
    double time_s;
} ref_image_t;

static int reference(const scene_t *s, const ray_camera_t *cam, int threads, ref_image_t *R)
{
    const size_t npix = (size_t)cam->width * cam->height;
    R->npix = npix;
    R->inbox = calloc(npix, 1);
    R->hit = calloc(npix, 1);
    R->amb = calloc(npix, 1);
    R->r = malloc(npix * sizeof *R->r);
    R->graze = malloc(npix * sizeof *R->graze);
    if (!R->inbox || !R->hit || !R->amb || !R->r || !R->graze)
        return 1;
    int failed = 0;
    double t0 = omp_get_wtime();
#pragma omp parallel num_threads(threads)
    {
        rref_t *ref = rref_new(s->tape);
        if (!ref) {
#pragma omp atomic write
            failed = 1;
        }
#pragma omp for schedule(dynamic, 1)
        for (int row = 0; row < cam->height; row++) {
            for (int col = 0; col < cam->width && ref; col++) {
                size_t i = (size_t)row * cam->width + col;
                double d[3];
                rref_result_t q;
                ray_camera_dir(cam, col, row, d);
                R->inbox[i] = (unsigned char)rref_ray_box(ref, s->box, cam->eye, d, &q);
                R->hit[i] = (unsigned char)q.hit;
                R->amb[i] = (unsigned char)q.ambiguous;
                R->r[i] = q.r;
                R->graze[i] = q.graze;
            }
        }
        rref_free(ref);
        rref_thread_cleanup();
    }
    R->time_s = omp_get_wtime() - t0;
    R->n_in = R->n_hit = R->n_amb = 0;
    for (size_t i = 0; i < npix; i++) {
        R->n_in += R->inbox[i];
        R->n_hit += R->hit[i];
        R->n_amb += R->amb[i];
    }
    return failed;
}

static void ref_free(ref_image_t *R)
{
    free(R->inbox);
    free(R->hit);
    free(R->amb);
    free(R->r);
    free(R->graze);
}

typedef struct errs {
    size_t hits, both;
    double max_err, mean_err;
    double max_err_unamb; /* over the pixels the reference does not call ambiguous */
    size_t disagree, disagree_amb, disagree_voxel;
    long worst;   /* the pixel of max_err, -1 when none */
} errs_t;

/* t: NaN on a miss */
static errs_t compare(const ref_image_t *R, const double *t, double voxel)
{
    errs_t e = {0};
    e.worst = -1;
    double sum = 0;
    for (size_t i = 0; i < R->npix; i++) {
        int h = !isnan(t[i]);
        e.hits += h;
        if (h != R->hit[i]) {
            e.disagree++;
            e.disagree_amb += R->amb[i];
            e.disagree_voxel += R->amb[i] || R->graze[i] <= voxel;
            continue;
        }
        if (!h)
            continue;
        double d = fabs(t[i] - R->r[i]);
        e.both++;
        sum += d;
        if (!R->amb[i] && d > e.max_err_unamb)
            e.max_err_unamb = d;
        if (d > e.max_err) {
            e.max_err = d;
            e.worst = (long)i;
        }
    }
    e.mean_err = e.both ? sum / (double)e.both : NAN;
    return e;
}

/* CPU time of the calling thread: on a loaded machine the wall clock of a
 * one-thread run counts the time other processes held the core; this does not. */
static double thread_cpu(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts))
        return NAN;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static FILE *csv;
static const char *cur_surface;

static int cur_width;

/* cpu_s: the thread CPU time of a one-thread run, NaN otherwise */
static void row(const char *variant, const char *method, int threads, double time_s,
                double cpu_s, double build_s, const errs_t *e, const ref_image_t *R)
{
    long w = e->worst;
    fprintf(csv,
            "%s,%s,%s,%d,%.6f,%.6f,%zu,%zu,%zu,%.6e,%.6e,%zu,%zu,%zu,%zu,%zu,%ld,%ld,%.3e,%.6e,"
            "%.6f\n",
            cur_surface, variant, method, threads, time_s, build_s, R->n_hit, e->hits, e->both,
            e->max_err, e->mean_err, e->disagree, e->disagree_amb, e->disagree_voxel, R->n_amb,
            R->npix, w < 0 ? -1 : w % cur_width, w < 0 ? -1 : w / cur_width,
            w < 0 ? NAN : R->graze[w], e->max_err_unamb, threads == 1 ? cpu_s : NAN);
    fflush(csv);
    printf("%-15s %-9s %-13s %3d %9.4f %9.3f %7zu %10.3e %10.3e %6zu %5zu %6zu\n", cur_surface,
           variant, method, threads, time_s, build_s, e->both, e->max_err, e->mean_err,
           e->disagree, e->disagree_amb, e->disagree_voxel);
    fflush(stdout);
}

int main(int argc, char **argv)
{
    const char *scenes = "scenes", *csv_path = "bench/results/ray_error.csv", *dump = NULL;
    char surf_buf[1024] =
        "sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt";
    char meth_buf[1024] = "mitchell newton newton-ah mrfro mrfro-newton lipschitz sampling";
    int width = 0, height = 0, threads = 0, reps = 2, depth = -1, half_width = 3, quick = 0;
    double voxel = 0;
    int surf_given = 0, meth_given = 0, size_given = 0, reps_given = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--quick")) {
            quick = 1;
            continue;
        }
        if (!v)
            usage();
        i++;
        if (!strcmp(a, "--scenes"))
            scenes = v;
        else if (!strcmp(a, "--surfaces"))
            snprintf(surf_buf, sizeof surf_buf, "%s", v), surf_given = 1;
        else if (!strcmp(a, "--methods"))
            snprintf(meth_buf, sizeof meth_buf, "%s", v), meth_given = 1;
        else if (!strcmp(a, "--size")) {
            if (sscanf(v, "%dx%d", &width, &height) != 2 || width < 1 || height < 1)
                usage();
            size_given = 1;
        } else if (!strcmp(a, "--threads"))
            threads = atoi(v);
        else if (!strcmp(a, "--reps"))
            reps = atoi(v), reps_given = 1;
        else if (!strcmp(a, "--depth"))
            depth = atoi(v);
        else if (!strcmp(a, "--voxel"))
            voxel = atof(v);
        else if (!strcmp(a, "--half-width"))
            half_width = atoi(v);
        else if (!strcmp(a, "--csv"))
            csv_path = v;
        else if (!strcmp(a, "--dump"))
            dump = v;
        else
            usage();
    }
    if (quick) {
        if (!surf_given)
            snprintf(surf_buf, sizeof surf_buf, "sphere gumdrop");
        if (!meth_given)
            snprintf(meth_buf, sizeof meth_buf, "mitchell lipschitz");
        if (!size_given)
            width = height = 100;
        if (!reps_given)
            reps = 1;
    }
    if (threads <= 0)
        threads = omp_get_max_threads();
    if (reps < 1 || depth > OCT_MAX_DEPTH || half_width < 1)
        usage();
    char *surfaces[MAX_LIST], *methods_s[MAX_LIST];
    int n_surf = split(surf_buf, surfaces), n_meth = split(meth_buf, methods_s);
    ray_method_t methods[MAX_LIST];
    for (int k = 0; k < n_meth; k++)
        if (ray_method_parse(methods_s[k], &methods[k])) {
            fprintf(stderr, "ivoct_ray_error: unknown method %s\n", methods_s[k]);
            return 2;
        }

    csv = fopen(csv_path, "w");
    if (!csv) {
        perror(csv_path);
        return 1;
    }
    fprintf(csv, "surface,variant,method,threads,time_s,build_s,ref_hits,hits,both_hit,"
                 "max_abs_err,mean_abs_err,disagree,disagree_ambiguous,disagree_within_voxel,"
                 "ref_ambiguous,pixels,worst_col,worst_row,worst_graze,"
                 "max_abs_err_unambiguous,cpu_1t_s\n");
    printf("%-15s %-9s %-13s %3s %9s %9s %7s %10s %10s %6s %5s %6s\n", "surface", "variant",
           "method", "thr", "time s", "build s", "both", "max |dt|", "mean |dt|", "differ",
           "amb", "voxel");

    int status = 0;
    for (int si = 0; si < n_surf; si++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.ini", scenes, surfaces[si]);
        cur_surface = surfaces[si];
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_load(path, &s, &err)) {
            fprintf(stderr, "ivoct_ray_error: %s: %s\n", path, err.msg);
            status = 1;
            continue;
        }
        if (!rref_supported(s.tape)) {
            fprintf(stderr, "ivoct_ray_error: %s: not a polynomial with double constants: no "
                            "reference\n", path);
            scene_free(&s);
            status = 1;
            continue;
        }
        int W = size_given || quick ? width : s.camera.width,
            H = size_given || quick ? height : s.camera.height;
        ray_camera_t cam;
        if (ray_camera_init(&cam, s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, W, H, &err)) {
            fprintf(stderr, "ivoct_ray_error: %s: camera: %s\n", path, err.msg);
            scene_free(&s);
            status = 1;
            continue;
        }
        cur_width = W;
        ref_image_t R = {0};
        if (reference(&s, &cam, threads, &R)) {
            fprintf(stderr, "ivoct_ray_error: %s: reference: out of memory\n", path);
            ref_free(&R);
            scene_free(&s);
            status = 1;
            continue;
        }
        fprintf(stderr, "%s: %dx%d, reference in %.1f s (%zu rays in the box, %zu hits, %zu "
                        "ambiguous)\n",
                cur_surface, W, H, R.time_s, R.n_in, R.n_hit, R.n_amb);

        oct_params_t op = s.octree;
        /* every render of the run reuses it, as a saved octree would be
         * reused: with slabs, as ivoct render builds it for many rays */
        ray_octree_params(&op, INFINITY);
        if (depth >= 0)
            op.depth = depth;
        op.threads = threads;
        oct_tree_t *tree = NULL;
        double tb = omp_get_wtime();
        if (oct_build(s.tape, s.box, &op, &tree, &err)) {
            fprintf(stderr, "ivoct_ray_error: %s: octree: %s\n", path, err.msg);
            ref_free(&R);
            scene_free(&s);
            status = 1;
            continue;
        }
        double build_s = omp_get_wtime() - tb;

        /* the OpenVDB grid first: its voxel edge is the "within a voxel" scale */
        char msg[512];
        vdb_rc_opts_t vo = {voxel, half_width, threads};
        vdb_rc_t *grid = NULL;
        vdb_rc_build_stats_t vst;
        if (vdb_rc_build(s.tape, tree, &vo, &grid, &vst, msg, sizeof msg)) {
            fprintf(stderr, "ivoct_ray_error: %s: %s\n", path, msg);
            status = 1;
        }
        const double h = grid ? vst.voxel : 0;

        ray_image_t img;
        if (ray_image_alloc(&img, W, H, &err)) {
            fprintf(stderr, "ivoct_ray_error: %s\n", err.msg);
            return 1;
        }
        ray_render_opts_t ro;
        ray_render_opts_default(&ro);
        ro.threads = threads;
        {   /* as ivoct render does */
            double dx = s.box[1] - s.box[0], dy = s.box[3] - s.box[2], dz = s.box[5] - s.box[4];
            double diag = sqrt(dx * dx + dy * dy + dz * dz);
            ro.roots.sample_step = diag > 0 ? diag / 1000 : 0;
        }
        ray_octree_source_t os;
        ray_box_source_t bs;
        ray_source_t srcs[3] = {ray_octree_source(&os, tree), ray_octree_source(&os, tree),
                                ray_box_source(&bs, s.box)};
        double *tbuf = malloc(R.npix * sizeof *tbuf);
        double *t_best = malloc(R.npix * sizeof *t_best);
        double best_time = INFINITY;
        for (size_t i = 0; i < R.npix; i++)
            t_best[i] = NAN;
        for (int k = 0; k < n_meth; k++) {
            /* v: 0 the octree, 1 the same on one thread, 2 no octree */
            for (int v = 0; v < 3; v++) {
                if (v == 1 && threads == 1)
                    continue;
                ro.method = methods[k];
                ro.threads = v == 1 ? 1 : threads;
                double tmin = INFINITY, cmin = INFINITY;
                ray_stats_t st;
                /* the goal's variants are timed --reps times, the other once */
                for (int r = 0; r < (v < 2 ? reps : 1); r++) {
                    double c0 = thread_cpu();
                    if (ray_render(s.tape, &cam, &srcs[v], &ro, &img, &st, &err)) {
                        fprintf(stderr, "ivoct_ray_error: render: %s\n", err.msg);
                        return 1;
                    }
                    double c = thread_cpu() - c0;
                    if (st.time_s < tmin)
                        tmin = st.time_s;
                    if (c < cmin)
                        cmin = c;
                }
                for (size_t i = 0; i < R.npix; i++)
                    tbuf[i] = img.hit[i] ? img.t[i] : NAN;
                errs_t e = compare(&R, tbuf, h);
                row(v < 2 ? "octree" : "no-octree", ray_method_name(methods[k]), st.threads, tmin,
                    cmin, v < 2 ? build_s : 0, &e, &R);
                if (v == 0 && ray_method_certified(methods[k]) && tmin < best_time) {
                    best_time = tmin;
                    memcpy(t_best, tbuf, R.npix * sizeof *tbuf);
                }
            }
        }
        double *t_vdb = malloc(R.npix * sizeof *t_vdb);
        if (grid) {
            fprintf(stderr, "%s: OpenVDB level set: voxel %.4g, %llu band voxels (%llu seeds), "
                            "%.1f MB, built in %.3f s (sampling %.3f s) + octree %.3f s\n",
                    cur_surface, vst.voxel, (unsigned long long)vst.active_voxels,
                    (unsigned long long)vst.seed_voxels, vst.mem_bytes / 1e6, vst.time_s,
                    vst.sample_s, build_s);
            int thr[2] = {1, threads};
            for (int v = 0; v < (threads > 1 ? 2 : 1); v++) {
                double tmin = INFINITY, cmin = INFINITY, ts;
                uint64_t hits;
                for (int r = 0; r < reps; r++) {
                    double c0 = thread_cpu();
                    if (vdb_rc_cast(grid, &cam, thr[v], t_vdb, &ts, &hits, msg, sizeof msg)) {
                        fprintf(stderr, "ivoct_ray_error: %s: %s\n", path, msg);
                        return 1;
                    }
                    double c = thread_cpu() - c0;
                    if (ts < tmin)
                        tmin = ts;
                    if (c < cmin)
                        cmin = c;
                }
                errs_t e = compare(&R, t_vdb, h);
                row("openvdb", "level-set", thr[v], tmin, cmin, vst.time_s, &e, &R);
            }
        }
        if (dump) {
            char dp[4096];
            snprintf(dp, sizeof dp, "%s/%s-t.csv", dump, cur_surface);
            FILE *f = fopen(dp, "w");
            if (!f) {
                perror(dp);
            } else {
                fprintf(f, "col,row,t_ref,ambiguous,t_ivoct_best_octree,t_openvdb\n");
                for (size_t i = 0; i < R.npix; i++)
                    fprintf(f, "%zu,%zu,%.17g,%d,%.17g,%.17g\n", i % W, i / W, R.r[i], R.amb[i],
                            t_best[i], grid ? t_vdb[i] : NAN);
                fclose(f);
            }
        }
        free(t_vdb);
        free(tbuf);
        free(t_best);
        ray_image_free(&img);
        vdb_rc_free(grid);
        oct_free(tree);
        ref_free(&R);
        scene_free(&s);
    }
    fclose(csv);
    return status;
}
