/* ivoct build — the octree of a scene, and its outputs. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "../export/export.h"
#include "../io/io.h"
#include "../octree/octree.h"
#include "../scene/scene.h"
#include "cli.h"

static const char SYNOPSIS[] =
    "usage: ivoct build SCENE [options]\n"
    "\n"
    "Subdivide the scene's box into the octree of cells that may hold the surface\n"
    "f = 0.  Every cell that holds part of the surface is kept (certified by\n"
    "rigorous interval arithmetic); cells proven empty are classified inside\n"
    "(f < 0) or outside (f > 0).\n"
    "\n";

static int parse_size(const char *text, size_t *out)
{
    char *end;
    double v = strtod(text, &end);
    double mult = 1;
    if (end == text || v < 0)
        return -1;
    switch (*end) {
    case 'k': case 'K': mult = 1024.0, end++; break;
    case 'm': case 'M': mult = 1024.0 * 1024, end++; break;
    case 'g': case 'G': mult = 1024.0 * 1024 * 1024, end++; break;
    default: break;
    }
    if (*end == 'B' || *end == 'b')
        end++;
    if (*end != '\0' || v * mult > 1e18)
        return -1;
    *out = (size_t)(v * mult);
    return 0;
}

static void json_u64_array(FILE *f, const uint64_t *v, int n)
{
    fputc('[', f);
    for (int i = 0; i < n; i++)
        fprintf(f, "%s%llu", i ? ", " : "", (unsigned long long)v[i]);
    fputc(']', f);
}

static int write_stats(const scene_t *s, const oct_tree_t *t, const char *path,
                       ivoct_error_t *err)
{
    const oct_stats_t *st = &t->stats;
    io_file_t f;
    if (io_open(&f, path, err))
        return -1;
    FILE *o = f.f;
    char tests[64];
    int n = t->depth + 1;
    fputs("{\n  \"scene\": ", o);
    cli_json_string(o, s->source.name);
    fputs(",\n  \"tests\": ", o);
    cli_json_string(o, oct_tests_format(t->tests, tests, sizeof tests));
    fputs(",\n", o);
    fprintf(o, "  \"depth\": %d,\n  \"leaves\": %u,\n  \"leaves_by_depth\": ", t->depth,
            t->n_leaves);
    json_u64_array(o, st->leaves_by_depth, n);
    fprintf(o, ",\n  \"cells_visited\": %llu,\n  \"cells_by_depth\": ",
            (unsigned long long)st->cells_visited);
    json_u64_array(o, st->cells_by_depth, n);
    fprintf(o, ",\n  \"split\": %llu,\n", (unsigned long long)st->split);
    fprintf(o,
            "  \"decided_by\": {\"interval\": %llu, \"lipschitz\": %llu, \"ilie\": %llu, "
            "\"refine\": %llu, \"max_depth\": %llu},\n",
            (unsigned long long)st->decided_interval, (unsigned long long)st->decided_lipschitz,
            (unsigned long long)st->decided_ilie, (unsigned long long)st->decided_refine,
            (unsigned long long)st->decided_max_depth);
    fputs("  \"mean_tape_length_by_depth\": [", o);
    for (int d = 0; d < n; d++) {
        fputs(d ? ", " : "", o);
        if (st->split_by_depth[d])
            cli_json_double(o, (double)st->tape_length_sum_by_depth[d] / (double)st->split_by_depth[d]);
        else
            fputs("null", o);
    }
    fputs("],\n  \"max_error_bound\": ", o);
    cli_json_double(o, st->max_error_bound);
    fprintf(o, ",\n  \"tape_clauses\": %u,\n  \"tape_clauses_evaluated\": %llu,\n  \"time_s\": ",
            s->tape->n, (unsigned long long)st->tape_clauses_evaluated);
    cli_json_double(o, st->time_s);
    size_t storage = (size_t)t->n_nodes * sizeof *t->nodes + (size_t)t->n_leaves * sizeof *t->leaves;
    fprintf(o, ",\n  \"peak_bytes\": %zu,\n  \"nodes\": %u,\n  \"storage_bytes\": %zu,\n"
               "  \"bytes_per_leaf\": ",
            st->peak_bytes, t->n_nodes, storage);
    cli_json_double(o, t->n_leaves ? (double)storage / t->n_leaves : 0.0);
    fprintf(o, ",\n  \"leaf_record_bytes\": %zu,\n  \"threads\": %d\n}\n", sizeof(oct_leaf_t),
            st->threads);
    return io_commit(&f, err);
}

/* ---- exports (export/): --vtu --htg --vdb --mesh ---------------------------------- */
typedef struct exports {
    const char *vtu, *htg, *vdb, *mesh;
} exports_t;

/* Usage errors found before the build: exit 2, nothing built. */
static int check_exports(const exports_t *ex)
{
    if (ex->mesh && !exp_mesh_supported(ex->mesh))
        return cli_usage_error("build", "--mesh '%s': the name must end in .vtp, .ply or .obj",
                               ex->mesh);
    return EXIT_OK;
}

static int write_exports(const scene_t *s, const oct_tree_t *t, const exports_t *ex,
                         ivoct_error_t *err)
{
    if (ex->vtu && exp_vtu(t, &s->source, ex->vtu, err))
        return -1;
    if (ex->htg && exp_htg(t, s->tape, &s->source, ex->htg, err))
        return -1;
    if (ex->vdb && exp_vdb(t, s->tape, &s->source, ex->vdb, err))
        return -1;
    if (ex->mesh && exp_mesh(t, s->tape, &s->source, ex->mesh, err))
        return -1;
    return 0;
}

/* ---- options ------------------------------------------------------------------------ */

static int parse_tests(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (!oct_tests_parse(value, target, &err))
        return 0;
    snprintf(msg, n, "%s: %s", opt, err.msg);
    return -1;
}

static int parse_refine(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    char *end;
    double v = strtod(value, &end);
    if (end == value || *end != '\0' || !isfinite(v) || v < 0) {
        snprintf(msg, n, "%s expects a number >= 0, got '%s'", opt, value);
        return -1;
    }
    *(double *)target = v;
    return 0;
}

static int parse_memory(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    if (!parse_size(value, target))
        return 0;
    snprintf(msg, n, "%s expects a size like 512M or 2G, got '%s'", opt, value);
    return -1;
}

int cmd_build(int argc, char **argv)
{
    exports_t ex = {0};
    const char *scene_path = NULL, *cells = NULL, *save = NULL, *stats = NULL;
    unsigned tests = 0;
    long depth = -1, threads = 0;
    double refine = -1;
    size_t max_memory = 0;
    bool quiet = false, tests_given = false;

    const cli_option_t options[] = {
        {.name = "--help", .alias = "-h", .kind = CLI_HELP},
        {.name = "SCENE", .kind = CLI_OPERAND, .target = &scene_path},
        {.name = "--depth", .kind = CLI_INT, .target = &depth, .lo = 0, .hi = OCT_MAX_DEPTH,
         .arg = "N", .help = "max depth, 0.." CLI_STR(OCT_MAX_DEPTH) " (scene [octree] depth, default "
                             CLI_STR(OCT_DEFAULT_DEPTH) ")"},
        {.name = "--tests", .kind = CLI_CUSTOM, .target = &tests, .parse = parse_tests,
         .given = &tests_given, .arg = "LIST",
         .help = "tests of the chain, cheapest first: interval, lipschitz, ilie\n"
                 "(scene [octree] tests, default interval,lipschitz)"},
        {.name = "--refine", .kind = CLI_CUSTOM, .target = &refine, .parse = parse_refine,
         .arg = "EPS",
         .help = "with ilie: stop early where the surface is within a slab\n"
                 "thinner than EPS and has no fold (certified error bound EPS;\n"
                 "scene [octree] refine, default 0 = off)"},
        {.name = "--threads", .kind = CLI_INT, .target = &threads, .lo = 1, .hi = 1024, .arg = "N",
         .help = "threads (default: all cores); the result is the same for any N"},
        {.name = "--max-memory", .kind = CLI_CUSTOM, .target = &max_memory, .parse = parse_memory,
         .arg = "SIZE", .help = "stop with an error past SIZE bytes (suffixes K M G), default none"},
        {.name = "--cells", .kind = CLI_STRING, .target = &cells, .arg = "F.csv",
         .help = "surface leaves, one per line in Morton order:\n"
                 "x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound\n"
                 "(the slab n.p in [d_lo, d_hi] is empty where a leaf has none)"},
        {.name = "--save", .kind = CLI_STRING, .target = &save, .arg = "F.ivo",
         .help = "the octree with its scene, for ivoct info and ivoct render"},
        {.name = "--stats", .kind = CLI_STRING, .target = &stats, .arg = "F.json",
         .help = "build statistics (keys in octree/README.md)"},
        {.name = "--vtu", .kind = CLI_STRING, .target = &ex.vtu, .arg = "F.vtu",
         .help = "surface leaves as VTK voxels (depth, f_lo, f_hi, error_bound)"},
        {.name = "--htg", .kind = CLI_STRING, .target = &ex.htg, .arg = "F.htg",
         .help = "the whole octree as a VTK HyperTreeGrid (see docs/paraview.md)"},
        {.name = "--vdb", .kind = CLI_STRING, .target = &ex.vdb, .arg = "F.vdb",
         .help = "OpenVDB grids: surface (the leaves) and sdf (a level set)"},
        {.name = "--mesh", .kind = CLI_STRING, .target = &ex.mesh, .arg = "F",
         .help = "a triangle mesh of the surface (OpenVDB volumeToMesh of sdf);\n"
                 "the format follows the name: .vtp, .ply or .obj"},
        {.name = "--quiet", .alias = "-q", .kind = CLI_FLAG, .target = &quiet,
         .help = "no summary on stdout, no progress bar"},
        {0},
    };
    const cli_command_t cmd = {"build", SYNOPSIS, 18, options};
    int rc = cli_parse(&cmd, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (!scene_path)
        return cli_usage_error("build", "missing the scene file");
    if (check_exports(&ex))
        return EXIT_USAGE;

    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(scene_path, &s, &err)) {
        cli_print_error(&err);
        return EXIT_USAGE;
    }
    rc = EXIT_OK;
    /* the scene's settings, overridden by the options */
    oct_params_t p = s.octree;
    if (depth >= 0)
        p.depth = (int)depth;
    if (refine >= 0)
        p.refine = refine;
    if (tests_given)
        p.tests = tests;
    if (oct_params_check(&p, &err)) {
        bool ilie = p.refine > 0 && !(p.tests & OCT_TEST_ILIE);
        rc = cli_usage_error("build", "%s%s", err.msg, ilie ? " (--tests interval,lipschitz,ilie)" : "");
        goto out;
    }

    cli_progress_t prog = {"building", omp_get_wtime(), 0, 0, 1};
    /* slabs are read by the CSV, the .vtu (normals, error bounds) and
     * renders from the .ivo; without those, ILIE runs only as a test */
    p.slabs_unused = !cells && !save && !ex.vtu;
    p.threads = (int)threads;
    p.max_memory = max_memory;
    p.progress = !quiet && isatty(2) ? cli_show_progress : NULL;
    p.progress_user = &prog;
    oct_tree_t *tree;
    if (oct_build(s.tape, s.box, &p, &tree, &err)) {
        fprintf(stderr, "ivoct build: %s\n", err.msg);
        rc = EXIT_RUNTIME;
        goto out;
    }
    if (cells && exp_cells(tree, cells, (int)threads, &err))
        rc = EXIT_RUNTIME;
    if (rc == EXIT_OK && save && oct_save(tree, &s.source, save, &err))
        rc = EXIT_RUNTIME;
    if (rc == EXIT_OK && stats && write_stats(&s, tree, stats, &err))
        rc = EXIT_RUNTIME;
    if (rc == EXIT_OK && write_exports(&s, tree, &ex, &err))
        rc = EXIT_RUNTIME;
    if (rc != EXIT_OK) {
        fprintf(stderr, "ivoct build: %s\n", err.msg);
    } else if (!quiet) {
        char names[64];
        printf("%s: depth %d, tests %s: %u surface leaves, %llu cells visited, %.3f s, %d "
               "thread%s\n",
               s.source.name, tree->depth, oct_tests_format(tree->tests, names, sizeof names),
               tree->n_leaves, (unsigned long long)tree->stats.cells_visited,
               tree->stats.time_s, tree->stats.threads, tree->stats.threads > 1 ? "s" : "");
    }
    oct_free(tree);
out:
    scene_free(&s);
    return rc;
}
