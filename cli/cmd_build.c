/* ivoct build — the octree of a scene, and its outputs. */
#define _POSIX_C_SOURCE 200809L
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

_Static_assert((unsigned)OCT_TEST_INTERVAL == (unsigned)SCENE_TEST_INTERVAL &&
                   (unsigned)OCT_TEST_LIPSCHITZ == (unsigned)SCENE_TEST_LIPSCHITZ &&
                   (unsigned)OCT_TEST_ILIE == (unsigned)SCENE_TEST_ILIE,
               "scene and octree test bits agree");

static const char HELP[] =
    "usage: ivoct build SCENE [options]\n"
    "\n"
    "Subdivide the scene's box into the octree of cells that may hold the surface\n"
    "f = 0.  Every cell that holds part of the surface is kept (certified by\n"
    "rigorous interval arithmetic); cells proven empty are classified inside\n"
    "(f < 0) or outside (f > 0).\n"
    "\n"
    "  --depth N         max depth, 0..21 (scene [octree] depth, default 8)\n"
    "  --tests LIST      tests of the chain, cheapest first: interval, lipschitz, ilie\n"
    "                    (scene [octree] tests, default interval,lipschitz)\n"
    "  --refine EPS      with ilie: stop early where the surface is within a slab\n"
    "                    thinner than EPS and has no fold (certified error bound EPS;\n"
    "                    scene [octree] refine, default 0 = off)\n"
    "  --threads N       threads (default: all cores); the result is the same for any N\n"
    "  --max-memory SIZE stop with an error past SIZE bytes (suffixes K M G), default none\n"
    "  --cells F.csv     surface leaves, one per line in Morton order:\n"
    "                    x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound\n"
    "                    (the slab n.p in [d_lo, d_hi] is empty where a leaf has none)\n"
    "  --save F.ivo      the octree with its scene, for ivoct info and ivoct render\n"
    "  --stats F.json    build statistics (keys in octree/README.md)\n"
    "  --vtu F.vtu       surface leaves as VTK voxels (depth, f_lo, f_hi, error_bound)\n"
    "  --htg F.htg       the whole octree as a VTK HyperTreeGrid (see docs/paraview.md)\n"
    "  --vdb F.vdb       OpenVDB grids: surface (the leaves) and sdf (a level set)\n"
    "  --mesh F          a triangle mesh of the surface (OpenVDB volumeToMesh of sdf);\n"
    "                    the format follows the name: .vtp, .ply or .obj\n"
    "  --quiet           no summary on stdout, no progress bar\n";

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

static int write_cells(const oct_tree_t *t, const char *path, ivoct_error_t *err)
{
    io_file_t f;
    if (io_open(&f, path, err))
        return -1;
    fputs("x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound\n", f.f);
    for (uint32_t i = 0; i < t->n_leaves; i++) {
        const oct_leaf_t *l = &t->leaves[i];
        iv_box_t b = oct_leaf_box(t, l);
        fprintf(f.f, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d,%.17g,%.17g,", b.x.lo, b.x.hi,
                b.y.lo, b.y.hi, b.z.lo, b.z.hi, l->depth, l->f_lo, l->f_hi);
        if (oct_leaf_has_slab(t, i)) {
            const oct_slab_t *sl = &t->slabs[i];
            fprintf(f.f, "%.17g,%.17g,%.17g,%.17g,%.17g,", sl->n[0], sl->n[1], sl->n[2],
                    sl->d_lo, sl->d_hi);
        } else {
            fputs(",,,,,", f.f);
        }
        fprintf(f.f, "%.17g\n", oct_leaf_error_bound(t, i));
    }
    return io_commit(&f, err);
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
    cli_json_string(o, s->name);
    fputs(",\n  \"tests\": ", o);
    cli_json_string(o, scene_tests_string(t->tests, tests, sizeof tests));
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

/* The slot of an export option, NULL when opt is not one. */
static const char **export_option(exports_t *ex, const char *opt)
{
    return !strcmp(opt, "--vtu")  ? &ex->vtu
           : !strcmp(opt, "--htg") ? &ex->htg
           : !strcmp(opt, "--vdb") ? &ex->vdb
           : !strcmp(opt, "--mesh") ? &ex->mesh
                                    : NULL;
}

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
    exp_meta_t meta = {s->name, s->f_text, s->n_lets, s->let_names, s->let_texts};
    if (ex->vtu && exp_vtu(t, &meta, ex->vtu, err))
        return -1;
    if (ex->htg && exp_htg(t, s->tape, &meta, ex->htg, err))
        return -1;
    if (ex->vdb && exp_vdb(t, s->tape, &meta, ex->vdb, err))
        return -1;
    if (ex->mesh && exp_mesh(t, s->tape, &meta, ex->mesh, err))
        return -1;
    return 0;
}

int cmd_build(int argc, char **argv)
{
    exports_t ex = {0};
    const char *scene_path = NULL, *cells = NULL, *save = NULL, *stats = NULL;
    const char *tests_text = NULL;
    long depth = -1, threads = 0;
    double refine = -1;
    size_t max_memory = 0;
    bool quiet = false;

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEED_VALUE()                                                                        \
    do {                                                                                    \
        if (!v)                                                                             \
            return cli_usage_error("build", "%s needs a value", a);                         \
        i++;                                                                                \
    } while (0)
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(HELP, stdout);
            return EXIT_OK;
        } else if (!strcmp(a, "--depth")) {
            NEED_VALUE();
            if (!cli_parse_int("build", a, v, 0, OCT_MAX_DEPTH, &depth))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--threads")) {
            NEED_VALUE();
            if (!cli_parse_int("build", a, v, 1, 1024, &threads))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--tests")) {
            NEED_VALUE();
            tests_text = v;
        } else if (!strcmp(a, "--refine")) {
            NEED_VALUE();
            if (!cli_parse_double("build", a, v, &refine) || refine < 0)
                return cli_usage_error("build", "--refine expects a number >= 0");
        } else if (!strcmp(a, "--max-memory")) {
            NEED_VALUE();
            if (parse_size(v, &max_memory))
                return cli_usage_error("build", "--max-memory expects a size like 512M or 2G, got '%s'", v);
        } else if (!strcmp(a, "--cells")) {
            NEED_VALUE();
            cells = v;
        } else if (!strcmp(a, "--save")) {
            NEED_VALUE();
            save = v;
        } else if (!strcmp(a, "--stats")) {
            NEED_VALUE();
            stats = v;
        } else if (export_option(&ex, a)) {
            NEED_VALUE();
            *export_option(&ex, a) = v;
        } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
            quiet = true;
        } else if (a[0] == '-' && a[1] != '\0') {
            return cli_usage_error("build", "unknown option '%s'", a);
        } else if (!scene_path) {
            scene_path = a;
        } else {
            return cli_usage_error("build", "unexpected argument '%s'", a);
        }
#undef NEED_VALUE
    }
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
    int rc = EXIT_OK;
    if (depth >= 0)
        s.depth = (int)depth;
    if (refine >= 0)
        s.refine = refine;
    if (tests_text && scene_parse_tests(tests_text, &s.tests, &err)) {
        rc = cli_usage_error("build", "--tests: %s", err.msg);
        goto out;
    }
    if (s.refine > 0 && !(s.tests & SCENE_TEST_ILIE)) {
        rc = cli_usage_error("build", "refine %g needs the ilie test (--tests interval,lipschitz,ilie)",
                             s.refine);
        goto out;
    }
    if (s.depth > OCT_MAX_DEPTH) {
        rc = cli_usage_error("build", "depth %d is more than %d", s.depth, OCT_MAX_DEPTH);
        goto out;
    }

    cli_progress_t prog = {"building", omp_get_wtime(), 0, 0, 1};
    oct_params_t p = {
        .depth = s.depth,
        .tests = s.tests,
        .refine = s.refine,
        /* slabs are read by the CSV, the .vtu (normals, error bounds) and
         * renders from the .ivo; without those, ILIE runs only as a test */
        .slabs_unused = !cells && !save && !ex.vtu,
        .threads = (int)threads,
        .max_memory = max_memory,
        .progress = !quiet && isatty(2) ? cli_show_progress : NULL,
        .progress_user = &prog,
    };
    oct_tree_t *tree;
    if (oct_build(s.tape, s.box, &p, &tree, &err)) {
        fprintf(stderr, "ivoct build: %s\n", err.msg);
        rc = EXIT_RUNTIME;
        goto out;
    }
    if (cells && write_cells(tree, cells, &err))
        rc = EXIT_RUNTIME;
    if (rc == EXIT_OK && save) {
        oct_source_t src = {s.name, s.n_lets, s.let_names, s.let_texts, s.f_text};
        if (oct_save(tree, &src, save, &err))
            rc = EXIT_RUNTIME;
    }
    if (rc == EXIT_OK && stats && write_stats(&s, tree, stats, &err))
        rc = EXIT_RUNTIME;
    if (rc == EXIT_OK && write_exports(&s, tree, &ex, &err))
        rc = EXIT_RUNTIME;
    if (rc != EXIT_OK) {
        fprintf(stderr, "ivoct build: %s\n", err.msg);
    } else if (!quiet) {
        char tests[64];
        printf("%s: depth %d, tests %s: %u surface leaves, %llu cells visited, %.3f s, %d "
               "thread%s\n",
               s.name, tree->depth, scene_tests_string(tree->tests, tests, sizeof tests),
               tree->n_leaves, (unsigned long long)tree->stats.cells_visited,
               tree->stats.time_s, tree->stats.threads, tree->stats.threads > 1 ? "s" : "");
    }
    oct_free(tree);
out:
    scene_free(&s);
    return rc;
}
