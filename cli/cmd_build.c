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
#include "../mesh/mesh.h"
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

/* Each writer writes into the commit group g: its file is renamed into place
 * with the others by io_group_commit, once every output is complete. */

static void json_u64_array(FILE *f, const uint64_t *v, int n)
{
    fputc('[', f);
    for (int i = 0; i < n; i++)
        fprintf(f, "%s%llu", i ? ", " : "", (unsigned long long)v[i]);
    fputc(']', f);
}

/* certain: the leaves were certified (--certain): t->certain, or, for the
 * counts of a build over MPI that holds no tree, the ranks' parts */
static void write_mesh_stats(FILE *o, const msh_mesh_t *m, const msh_params_t *p)
{
    const msh_stats_t *st = &m->stats;
    fprintf(o,
            ",\n  \"mesh_certified\": {\"certified\": %s, \"vertices\": %zu, \"triangles\": %zu, "
            "\"cells_meshed\": %zu, \"max_depth\": %d, \"min_depth\": %d,\n"
            "    \"cells_evaluated\": %llu, \"leaves_empty\": %llu, \"leaves_surface\": %llu, "
            "\"leaves_unresolved\": %llu, \"failures\": %zu,\n"
            "    \"split_balance\": %llu, \"split_face\": %llu, \"split_loops\": %llu, "
            "\"split_apex\": %llu, \"passes\": %llu,\n"
            "    \"sign_evaluations\": %llu, \"apex_off_surface\": %llu, \"time_s\": ",
            m->n_failures ? "false" : "true", m->n_points, m->n_tris, m->n_cells, p->max_depth,
            p->min_depth, (unsigned long long)st->cells_evaluated,
            (unsigned long long)st->leaves_empty, (unsigned long long)st->leaves_surface,
            (unsigned long long)st->leaves_unresolved, m->n_failures,
            (unsigned long long)st->split_balance, (unsigned long long)st->split_face,
            (unsigned long long)st->split_loops, (unsigned long long)st->split_apex,
            (unsigned long long)st->passes, (unsigned long long)st->sign_evaluations,
            (unsigned long long)st->apex_off_surface);
    cli_json_double(o, st->seconds);
    fputc('}', o);
}

/* mesh, mesh_params: the certified mesh (--mesh-certified), or NULL */
static int write_stats(const scene_t *s, const oct_tree_t *t, bool certain, io_group_t *g,
                       const char *path, const msh_mesh_t *mesh, const msh_params_t *mesh_params,
                       const build_stats_extra_t *extra, ivoct_error_t *err)
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
    cli_json_implicitize(o, s);
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
    if (certain)
        storage += (size_t)t->n_leaves * sizeof *t->certain;
    fprintf(o, ",\n  \"peak_bytes\": %zu,\n  \"nodes\": %u,\n  \"storage_bytes\": %zu,\n"
               "  \"bytes_per_leaf\": ",
            st->peak_bytes, t->n_nodes, storage);
    cli_json_double(o, t->n_leaves ? (double)storage / t->n_leaves : 0.0);
    fprintf(o, ",\n  \"leaf_record_bytes\": %zu,\n  \"threads\": %d,\n  \"simd\": \"%s\"",
            sizeof(oct_leaf_t), st->threads, tape_simd_name());
    if (certain) {
        fprintf(o, ",\n  \"leaves_certain\": %llu,\n  \"leaves_certain_share\": ",
                (unsigned long long)st->leaves_certain);
        cli_json_double(o, t->n_leaves ? (double)st->leaves_certain / t->n_leaves : 0.0);
        fputs(",\n  \"certain_time_s\": ", o);
        cli_json_double(o, st->certain_time_s);
        fprintf(o, ",\n  \"certain_bytes_per_leaf\": %zu", sizeof *t->certain);
    }
    if (mesh)
        write_mesh_stats(o, mesh, mesh_params);
    if (extra)
        extra->write(o, extra->user);
    fputs("\n}\n", o);
    return io_group_add(g, &f, err);
}

/* ---- exports (export/): --vtu --htg --vdb --mesh --mesh-certified ------------------ */

/* Usage errors found before the build: exit 2, nothing built. */
static int check_exports(const exports_t *ex, int depth)
{
    if (ex->mesh && !exp_mesh_supported(ex->mesh))
        return cli_usage_error("build", "--mesh '%s': the name must end in .vtp, .ply or .obj",
                               ex->mesh);
    if (ex->mesh_certified && !exp_mesh_supported(ex->mesh_certified))
        return cli_usage_error("build",
                               "--mesh-certified '%s': the name must end in .vtp, .ply or .obj",
                               ex->mesh_certified);
    if (ex->mesh_certified && (depth < 1 || depth > MSH_MAX_DEPTH))
        return cli_usage_error("build", "--mesh-certified needs a depth of 1..%d, not %d",
                               MSH_MAX_DEPTH, depth);
    if (ex->mesh_min_depth > depth)
        return cli_usage_error("build", "--mesh-min-depth %d is deeper than the depth %d",
                               ex->mesh_min_depth, depth);
    if (ex->mesh_min_depth >= 0 && !ex->mesh_certified)
        return cli_usage_error("build", "--mesh-min-depth goes with --mesh-certified");
    return EXIT_OK;
}

static msh_params_t mesh_params(const build_job_t *job)
{
    int depth = job->params.depth, min = job->ex.mesh_min_depth;
    msh_params_t p = {depth, min >= 0 ? min : depth > 2 ? depth - 2 : 0, 0};
    return p;
}

/* The cells where the certified mesh failed, on stderr, by region of touching
 * cells (msh_failure_t.region: a singular point makes one). */
static void report_failures(const msh_mesh_t *m, int max_depth)
{
    size_t n = m->n_failures, regions = m->n_regions, shown = regions < 20 ? regions : 20;
    fprintf(stderr,
            "ivoct build: --mesh-certified: the topology is not certified in %zu cell%s "
            "(max depth %d), in %zu region%s:\n",
            n, n > 1 ? "s" : "", max_depth, regions, regions > 1 ? "s" : "");
    /* the first regions' cell counts, hulls and reasons, in one pass */
    size_t cells[20] = {0}, by[20][MSH_FAIL_LOOPS + 1] = {{0}};
    iv_box_t hull[20];
    for (size_t i = 0; i < n; i++) {
        const msh_failure_t *f = &m->failures[i];
        if (f->region >= shown)
            continue;
        iv_t *h = &hull[f->region].x;
        const iv_t *b = &f->box.x;
        for (int k = 0; k < 3; k++)
            h[k] = cells[f->region] ? iv_hull(h[k], b[k]) : b[k];
        cells[f->region]++;
        by[f->region][f->reason]++;
    }
    for (size_t r = 0; r < shown; r++) {
        const iv_t *h = &hull[r].x;
        fprintf(stderr, "  %zu cell%s in [%.9g, %.9g] x [%.9g, %.9g] x [%.9g, %.9g]:", cells[r],
                cells[r] > 1 ? "s" : "", h[0].lo, h[0].hi, h[1].lo, h[1].hi, h[2].lo, h[2].hi);
        for (int k = 0; k <= MSH_FAIL_LOOPS; k++)
            if (by[r][k])
                fprintf(stderr, " %s %zu", msh_reason_name((msh_reason_t)k), by[r][k]);
        fputc('\n', stderr);
    }
    if (regions > shown)
        fprintf(stderr, "  ... and %zu more regions\n", regions - shown);
    fprintf(stderr,
            "  gradient: grad f may vanish or turn by 90 degrees or more in the cell (a singular\n"
            "  point of the surface, or an enclosure too wide: a larger --depth may certify it);\n"
            "  sign: f's sign at a corner is not certified; face, loops: the surface crosses a\n"
            "  face twice, or meets the cell in several pieces, at the max depth (mesh/README.md)\n");
}

/* The certified mesh, built before the outputs are written (its figures go into
 * the stats): EXIT_OK, EXIT_UNCERTIFIED after listing the cells where the
 * guarantee fails on stderr, or EXIT_RUNTIME. */
static int certified_mesh(const build_job_t *job, double tree_bytes, msh_mesh_t *m,
                          ivoct_error_t *err)
{
    const scene_t *s = job->scene;
    msh_params_t p = mesh_params(job);
    /* the budget left beside the octree, which stays allocated */
    if (job->max_memory)
        p.max_memory = tree_bytes < (double)job->max_memory
                           ? job->max_memory - (size_t)tree_bytes : 1;
    iv_box_t box = {{s->box[0], s->box[1]}, {s->box[2], s->box[3]}, {s->box[4], s->box[5]}};
    cli_test_pause("mesh-certified");
    int rc = msh_build(s->tape, &box, &p, m, err);
    if (rc < 0)
        return EXIT_RUNTIME;
    if (rc == 0)
        return EXIT_OK;
    report_failures(m, p.max_depth);
    ivoct_error_set(err, "--mesh-certified: not certified (regions listed above); nothing written");
    return EXIT_UNCERTIFIED;
}

/* The .ivo and the exports write their files themselves (through io_open and
 * io_commit): each is given a temporary name reserved in the group, renamed
 * into place by io_group_commit; errors name the destination. */
static int reserve(io_group_t *g, const char *step, const char *path, const char **tmp,
                   ivoct_error_t *err)
{
    cli_test_pause(step);
    return io_group_reserve(g, path, tmp, err);
}

/* The certified mesh, with the depth of each triangle's cell (a .vtp cell array). */
static int write_certified_mesh(const scene_t *s, const msh_mesh_t *m, const char *path,
                                ivoct_error_t *err)
{
    int *depth = malloc((m->n_tris ? m->n_tris : 1) * sizeof *depth);
    if (!depth) {
        ivoct_error_set(err, "cannot write %s: out of memory", path);
        return -1;
    }
    for (size_t i = 0; i < m->n_tris; i++)
        depth[i] = m->cell_depth[m->tri_cell[i]];
    int rc = exp_mesh_write(m->points, m->n_points, m->tris, depth, m->n_tris, &s->source, path,
                            err);
    free(depth);
    return rc;
}

static int write_exports(const scene_t *s, const oct_tree_t *t, const exports_t *ex,
                         const msh_mesh_t *mesh, io_group_t *g, ivoct_error_t *err)
{
    const char *tmp;
    int rc = 0;
    if (!rc && ex->vtu && !(rc = reserve(g, "vtu", ex->vtu, &tmp, err)))
        rc = exp_vtu(t, &s->source, tmp, err);
    if (!rc && ex->htg && !(rc = reserve(g, "htg", ex->htg, &tmp, err)))
        rc = exp_htg(t, s->tape, &s->source, tmp, err);
    if (!rc && ex->vdb && !(rc = reserve(g, "vdb", ex->vdb, &tmp, err)))
        rc = exp_vdb(t, s->tape, &s->source, tmp, err);
    if (!rc && ex->mesh && !(rc = reserve(g, "mesh", ex->mesh, &tmp, err)))
        rc = exp_mesh(t, s->tape, &s->source, tmp, err);
    if (!rc && mesh && !(rc = reserve(g, "mesh-certified-write", ex->mesh_certified, &tmp, err)))
        rc = write_certified_mesh(s, mesh, tmp, err);
    if (rc)
        io_group_rename_error(g, err);
    return rc ? -1 : 0;
}

/* --cells: the CSV of the surface leaves (export/cells.cpp, threads formatting blocks) */
static int write_cells(const oct_tree_t *t, io_group_t *g, const char *path, int threads,
                       ivoct_error_t *err)
{
    const char *tmp;
    if (io_group_reserve(g, path, &tmp, err))
        return -1;
    if (exp_cells(t, tmp, threads, err)) {
        io_group_rename_error(g, err);
        return -1;
    }
    return 0;
}

static int write_save(const scene_t *s, const oct_tree_t *t, io_group_t *g, const char *path,
                      ivoct_error_t *err)
{
    const char *tmp;
    if (reserve(g, "save", path, &tmp, err))
        return -1;
    if (oct_save(t, &s->source, tmp, err)) {
        io_group_rename_error(g, err);
        return -1;
    }
    return 0;
}

/* ---- the memory budget of the outputs (--max-memory) -------------------------------
 * The build keeps within the budget by itself (oct_params_t.max_memory); the
 * outputs are checked before the first is written: the tree's storage, which
 * stays allocated, plus what the most demanding output needs on top must fit.
 * VTK and OpenVDB allocate inside, so their needs are estimates: the growth of
 * the peak resident size measured per unit (ivoct build on gumdrop and sphere
 * at depths 7 and 8; cli/README.md) with a margin of about 1.5. */
#define MEM_VTU_PER_LEAF 500.0    /* measured 61 .. 133 bytes, 125 .. 216 with slabs (vtu_xml.cpp) */
#define MEM_HTG_PER_NODE 40.0     /* measured 13 .. 17 bytes per node at depth 9 (htg_xml.cpp) */
#define MEM_HTG_FIXED (8.0 * 1024 * 1024) /* its text and windows: 1.6 MB at depth 2 */
#define MEM_VDB_PER_VOXEL 40.0    /* measured 26 bytes per voxel of the max depth (vdb.cpp) */
#define MEM_MESH_PER_VOXEL 220.0  /* measured 148: the sdf grid's values held, and the mesh */
#define MEM_VDB_FIXED (48.0 * 1024 * 1024) /* OpenVDB's libraries and more: measured 34 MB */


static double tree_bytes(const oct_tree_t *t)
{
    return (double)t->n_nodes * sizeof *t->nodes + (double)t->n_leaves * sizeof *t->leaves +
           (t->slabs ? (double)t->n_leaves * sizeof *t->slabs : 0.0) +
           (t->certain ? (double)t->n_leaves * sizeof *t->certain : 0.0);
}

/* What --vdb and --mesh fill: every surface leaf's voxels of the max depth. */
static double surface_voxels(const oct_tree_t *t)
{
    double v = 0;
    for (uint32_t i = 0; i < t->n_leaves; i++)
        v += ldexp(1.0, 3 * (t->depth - oct_leaf_depth(&t->leaves[i])));
    return v;
}

/* The threads that format --cells: the build's, or fewer when their buffers
 * would not fit the budget beside the tree (one thread's are the CSV's
 * minimum, which build_check_export_memory checks). */
int build_cells_threads(const oct_tree_t *t, int threads, size_t budget)
{
    int n = threads > 0 ? threads : t->stats.threads;
    while (budget && n > 1 && tree_bytes(t) + (double)exp_cells_memory(t, n) > (double)budget)
        n--;
    return n;
}

int build_check_export_memory(const oct_tree_t *t, const char *cells, const char *save,
                              const exports_t *ex, size_t budget, ivoct_error_t *err)
{
    double voxels = ex->vdb || ex->mesh ? surface_voxels(t) : 0;
    struct {
        const char *opt, *path;
        double bytes;
    } need[] = {
        /* oct_save builds the file in a buffer that doubles as it grows */
        {"--save", save, 2.0 * tree_bytes(t) + 65536.0},
        {"--cells", cells, (double)exp_cells_memory(t, 1)},
        {"--vtu", ex->vtu, MEM_VTU_PER_LEAF * t->n_leaves},
        {"--htg", ex->htg, MEM_HTG_PER_NODE * t->n_nodes + MEM_HTG_FIXED},
        {"--vdb", ex->vdb, MEM_VDB_PER_VOXEL * voxels + MEM_VDB_FIXED},
        {"--mesh", ex->mesh, MEM_MESH_PER_VOXEL * voxels + MEM_VDB_FIXED},
    };
    double base = tree_bytes(t);
    for (size_t k = 0; k < sizeof need / sizeof need[0]; k++)
        if (need[k].path && base + need[k].bytes > (double)budget) {
            ivoct_error_set(err,
                            "%s needs about %.1f MB beside the octree's %.1f MB (%u leaves): "
                            "past the memory budget of %.1f MB (raise --max-memory)",
                            need[k].opt, need[k].bytes / 1048576, base / 1048576, t->n_leaves,
                            (double)budget / 1048576);
            return -1;
        }
    return 0;
}

/* Every output of the job but the commit: written into g (cmd_build, and
 * rank 0 of the build over MPI with the outputs that are one file). */
int build_write_outputs(const build_job_t *job, const oct_tree_t *tree, io_group_t *g,
                        const build_stats_extra_t *extra, mesh_summary_t *summary,
                        ivoct_error_t *err)
{
    const scene_t *s = job->scene;
    const char *cells = job->cells, *save = job->save, *stats = job->stats;
    const exports_t *ex = &job->ex;
    size_t max_memory = job->max_memory;
    if (max_memory && build_check_export_memory(tree, cells, save, ex, max_memory, err))
        return EXIT_RUNTIME;
    msh_mesh_t mesh = {0};
    msh_params_t mp = mesh_params(job);
    int rc = ex->mesh_certified ? certified_mesh(job, tree_bytes(tree), &mesh, err) : EXIT_OK;
    const msh_mesh_t *m = ex->mesh_certified ? &mesh : NULL;
    if (rc)
        goto done;
    rc = EXIT_RUNTIME;
    if (cells)
        cli_test_pause("cells");
    if (cells &&
        write_cells(tree, g, cells, build_cells_threads(tree, job->threads, max_memory), err))
        goto done;
    if (save && write_save(s, tree, g, save, err))
        goto done;
    if (stats)
        cli_test_pause("stats");
    if (stats && write_stats(s, tree, job->certain, g, stats, m, &mp, extra, err))
        goto done;
    if (write_exports(s, tree, ex, m, g, err))
        goto done;
    rc = EXIT_OK;
    if (summary && m) {
        *summary = (mesh_summary_t){true, m->n_points, m->n_tris, m->n_cells, MSH_MAX_DEPTH, 0,
                                    m->stats.seconds};
        for (size_t i = 0; i < m->n_cells; i++) {
            summary->min_depth = m->cell_depth[i] < summary->min_depth ? m->cell_depth[i]
                                                                       : summary->min_depth;
            summary->max_depth = m->cell_depth[i] > summary->max_depth ? m->cell_depth[i]
                                                                       : summary->max_depth;
        }
    }
done:
    msh_free(&mesh);
    return rc;
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

int cmd_build(int argc, char **argv)
{
    exports_t ex = {.mesh_min_depth = -1};
    const char *scene_path = NULL, *cells = NULL, *save = NULL, *stats = NULL;
    unsigned tests = 0;
    long depth = -1, threads = 0, mesh_min_depth = -1;
    double refine = -1;
    size_t max_memory = 0;
    bool quiet = false, tests_given = false, certain = false;

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
        {.name = "--max-memory", .kind = CLI_CUSTOM, .target = &max_memory, .parse = cli_parse_memory,
         .arg = "SIZE", .help = "stop with an error past SIZE bytes (suffixes K M G), default none"},
        {.name = "--cells", .kind = CLI_STRING, .target = &cells, .arg = "F.csv",
         .help = "surface leaves, one per line in Morton order:\n"
                 "x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound\n"
                 "(the slab n.p in [d_lo, d_hi] is empty where a leaf has none);\n"
                 "under mpirun F.pcsv writes one piece per rank, F_<rank>.csv"},
        {.name = "--save", .kind = CLI_STRING, .target = &save, .arg = "F.ivo",
         .help = "the octree with its scene, for ivoct info and ivoct render;\n"
                 "under mpirun F.pivo writes one piece per rank, F_<rank>.ivo,\n"
                 "and an index that info and render read as the whole tree"},
        {.name = "--stats", .kind = CLI_STRING, .target = &stats, .arg = "F.json",
         .help = "build statistics (keys in octree/README.md)"},
        {.name = "--vtu", .kind = CLI_STRING, .target = &ex.vtu, .arg = "F.vtu",
         .help = "surface leaves as VTK voxels (depth, f_lo, f_hi, error_bound);\n"
                 "under mpirun F.pvtu writes one piece per rank, F_<rank>.vtu"},
        {.name = "--htg", .kind = CLI_STRING, .target = &ex.htg, .arg = "F.htg",
         .help = "the whole octree as a VTK HyperTreeGrid (see docs/paraview.md);\n"
                 "under mpirun F.phtg writes one piece per rank, F_<rank>.htg\n"
                 "(the tree from the frontier down: docs/cluster.md)"},
        {.name = "--vdb", .kind = CLI_STRING, .target = &ex.vdb, .arg = "F.vdb",
         .help = "OpenVDB grids: surface (the leaves) and sdf (a level set)"},
        {.name = "--mesh", .kind = CLI_STRING, .target = &ex.mesh, .arg = "F",
         .help = "a triangle mesh of the surface (OpenVDB volumeToMesh of sdf);\n"
                 "the format follows the name: .vtp, .ply or .obj"},
        {.name = "--mesh-certified", .kind = CLI_STRING, .target = &ex.mesh_certified,
         .arg = "F",
         .help = "a triangle mesh with certified topology (Plantinga-Vegter):\n"
                 "embedded, and isotopic to the surface in the box where f is\n"
                 "C^1 and the surface regular; vertices on the surface to a\n"
                 "double's precision.  Cells down to --depth (at most "
                 CLI_STR(MSH_MAX_DEPTH) "); where\n"
                 "the guarantee fails there the cells are listed, nothing is\n"
                 "written and the exit status is 3 (mesh/README.md).\n"
                 ".vtp, .ply or .obj, with double-precision points"},
        {.name = "--mesh-min-depth", .kind = CLI_INT, .target = &mesh_min_depth, .lo = 0,
         .hi = MSH_MAX_DEPTH, .arg = "N",
         .help = "the certified mesh's cells are split at least to depth N\n"
                 "(a finer mesh; default: --depth - 2)"},
        {.name = "--certain", .kind = CLI_FLAG, .target = &certain,
         .help = "after the build, prove which surface leaves surely hold\n"
                 "surface (f continuous on the leaf, and a certified sign\n"
                 "change or zero at its sample points) and keep a witness:\n"
                 "adds the columns\n"
                 "certain,wx0,wy0,wz0,wx1,wy1,wz1 to --cells, the cell array\n"
                 "certain to --vtu and --htg, the flags to --save and\n"
                 "leaves_certain to --stats (octree/README.md)"},
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

    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int loaded = scene_load(scene_path, &s, &err);
    if (loaded) {
        cli_print_error(&err);
        return loaded == SCENE_ERUNTIME ? EXIT_RUNTIME : EXIT_USAGE;
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

    ex.mesh_min_depth = (int)mesh_min_depth;
    if ((rc = check_exports(&ex, p.depth)))
        goto out;

    cli_progress_t prog = {"building", omp_get_wtime(), 0, 0, 1};
    /* slabs are read by the CSV, the .vtu (normals, error bounds) and
     * renders from the .ivo; without those, ILIE runs only as a test */
    p.slabs_unused = !cells && !save && !ex.vtu;
    p.threads = (int)threads;
    p.max_memory = max_memory;
    p.progress = !quiet && isatty(2) ? cli_show_progress : NULL;
    p.progress_user = &prog;
    const build_job_t job = {&s, p, cells, save, stats, ex, (int)threads, max_memory, certain};
#ifdef IVOCT_MPI
    if (cli_mpi_ranks()) {
        /* started by mpirun: the build and the outputs spread over the ranks */
        rc = cli_mpi_build(&job, quiet);
        goto out;
    }
#endif
    oct_tree_t *tree;
    cli_test_pause("build");
    if (oct_build(s.tape, s.box, &p, &tree, &err)) {
        fprintf(stderr, "ivoct build: %s\n", err.msg);
        rc = EXIT_RUNTIME;
        goto out;
    }
    if (certain) {
        if (oct_certify(tree, s.tape, (int)threads, &err)) {
            fprintf(stderr, "ivoct build: %s\n", err.msg);
            oct_free(tree);
            rc = EXIT_RUNTIME;
            goto out;
        }
    }
    /* every output goes to a temporary name; all are renamed at the end, and
     * only when all were written (the commit group) */
    io_group_t g = IO_GROUP_INIT;
    mesh_summary_t mesh = {0};
    rc = build_write_outputs(&job, tree, &g, NULL, &mesh, &err);
    if (rc == EXIT_OK) {
        cli_test_pause("commit");
        if (io_group_commit(&g, &err))
            rc = EXIT_RUNTIME;
    } else {
        io_group_abort(&g);
    }
    if (rc != EXIT_OK) {
        fprintf(stderr, "ivoct build: %s\n", err.msg);
    } else if (!quiet) {
        char names[64];
        printf("%s: depth %d, tests %s: %u surface leaves, %llu cells visited, %.3f s, %d "
               "thread%s\n",
               s.source.name, tree->depth, oct_tests_format(tree->tests, names, sizeof names),
               tree->n_leaves, (unsigned long long)tree->stats.cells_visited,
               tree->stats.time_s, tree->stats.threads, tree->stats.threads > 1 ? "s" : "");
        if (tree->certain)
            printf("certain: %llu of %u surface leaves (%.1f%%), %.3f s\n",
                   (unsigned long long)tree->stats.leaves_certain, tree->n_leaves,
                   tree->n_leaves ? 100.0 * (double)tree->stats.leaves_certain / tree->n_leaves : 0.0,
                   tree->stats.certain_time_s);
        if (mesh.made)
            printf("certified mesh: %zu vertices, %zu triangles in %zu cells of depth %d to %d, "
                   "%.3f s\n",
                   mesh.vertices, mesh.triangles, mesh.cells, mesh.min_depth, mesh.max_depth,
                   mesh.seconds);
    }
    oct_free(tree);
out:
    scene_free(&s);
    return rc;
}
