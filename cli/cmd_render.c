/* ivoct render — ray cast a scene into a PNG and/or the .vti render buffers. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../io/io.h"
#include "../octree/octree.h"
#include "../ray/ray.h"
#include "../scene/scene.h"
#include "cli.h"

static const char SYNOPSIS[] =
    "usage: ivoct render SCENE [options]\n"
    "\n"
    "Ray cast the surface f = 0 of a scene: one primary ray per pixel from the\n"
    "scene's camera, through the pixel centre; the first root of f along each ray\n"
    "is found by a root finder on g(t) = f(eye + t*dir), shaded (Lambert + ambient\n"
    "from the normal grad f/|grad f|) and written out.  Every method but sampling\n"
    "is certified: a miss means no root on the ray inside the box; see\n"
    "ray/README.md for the methods and the tolerance for double roots.\n"
    "\n"
    "By default the scene's octree is built first (its [octree] depth, tests and\n"
    "refine, as ivoct build does) and each ray is searched only over the surface\n"
    "leaves it meets, front to back; the build time is reported apart.  From 2^19\n"
    "rays on (frames x pixels, twice that with a light) the build adds ilie to the\n"
    "tests: its slabs narrow each ray's segment of a leaf to where the surface can\n"
    "be, which costs 1.3-3.6x the build and saves 1.4-1.9x per ray.\n"
    "\n"
    "With a point light (--light, or the scene's [render] light) each hit also\n"
    "casts a shadow ray to the light through the same octree: any root of f on\n"
    "the way, or one the certified tests cannot exclude, puts the hit in shadow\n"
    "(ray/README.md, \"Shadows\"); without one, a light fixed to the camera.\n"
    "\n"
    "Under mpirun (docs/cluster.md) each rank loads or builds the octree; one\n"
    "image (fewer frames than ranks) is split into 16x16 tiles dealt out to the\n"
    "ranks and gathered on rank 0, else the frames are dealt out; the files are\n"
    "those of one process.\n"
    "\n";

/* Leaf tapes are used when they are at most this share of the scene's tape
 * on average: a tape shorter by a clause or two does not pay for leaving the
 * one tape that stays in cache (the thin shell's abs: 14 -> 13.9 clauses). */
#define LEAF_TAPES_MAX_RATIO 0.75

/* "WxH", both in 1..RAY_MAX_SIZE */
static int parse_size(const char *text, int *w, int *h)
{
    char *end;
    if (!isdigit((unsigned char)text[0]))
        return -1;
    long a = strtol(text, &end, 10);
    if (*end != 'x' && *end != 'X')
        return -1;
    const char *second = end + 1;
    if (!isdigit((unsigned char)second[0]))
        return -1;
    long b = strtol(second, &end, 10);
    if (*end != '\0' || a < 1 || b < 1 || a > RAY_MAX_SIZE || b > RAY_MAX_SIZE)
        return -1;
    *w = (int)a;
    *h = (int)b;
    return 0;
}

/* The file name of frame k: F itself for a single frame, else F with _NNN
 * before its extension (as many digits as the last frame needs, at least 3). */
static char *frame_path(const char *path, int k, int frames)
{
    size_t n = strlen(path);
    char *out = malloc(n + 24);
    if (!out)
        return NULL;
    if (frames <= 1) {
        memcpy(out, path, n + 1);
        return out;
    }
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    size_t stem = dot && (!slash || dot > slash + 1) ? (size_t)(dot - path) : n;
    int digits = 3;
    for (int m = frames - 1; m >= 1000; m /= 10)
        digits++;
    char num[24];
    int len = snprintf(num, sizeof num, "%d", k);
    memcpy(out, path, stem);
    char *q = out + stem;
    *q++ = '_';
    for (int z = len; z < digits; z++)
        *q++ = '0';
    memcpy(q, num, (size_t)len);
    memcpy(q + len, path + stem, n - stem + 1);
    return out;
}

typedef int (*writer_fn)(FILE *f, const ray_image_t *img, const ray_camera_t *cam,
                         const char *method, ivoct_error_t *err);

static int png_writer(FILE *f, const ray_image_t *img, const ray_camera_t *cam,
                      const char *method, ivoct_error_t *err)
{
    (void)cam;
    (void)method;
    return ray_write_png(f, img, err);
}

/* Write one output into the commit group (renamed into place with every
 * other output at the end); 0 on success. */
static int write_output(io_group_t *g, const char *path, int k, int frames, writer_fn fn,
                        const ray_image_t *img, const ray_camera_t *cam, const char *method,
                        ivoct_error_t *err)
{
    char *p = frame_path(path, k, frames);
    if (!p) {
        ivoct_error_set(err, "out of memory");
        return -1;
    }
    io_file_t f;
    int rc = io_open(&f, p, err);
    if (rc == 0) {
        errno = 0;
        if (fn(f.f, img, cam, method, err)) {
            /* a failed write: its reason (a full disk, a file too large)
             * rather than the writer's "write error" */
            int e = ferror(f.f) ? errno : 0;
            char why[512];
            snprintf(why, sizeof why, "%s", e ? strerror(e) : err->msg);
            ivoct_error_set(err, "cannot write %s: %s", p, why);
            io_abort(&f);
            rc = -1;
        } else {
            rc = io_group_add(g, &f, err);
        }
    }
    free(p);
    return rc;
}

/* Fail early, before the render, when an output cannot be created. */
static int probe_output(const char *path, int frames, ivoct_error_t *err)
{
    char *p = frame_path(path, 0, frames);
    if (!p) {
        ivoct_error_set(err, "out of memory");
        return -1;
    }
    io_file_t f;
    int rc = io_open(&f, p, err);
    if (rc == 0)
        io_abort(&f);
    free(p);
    return rc;
}

/* Where the segments came from. */
typedef struct octree_info {
    const oct_tree_t *tree; /* NULL: --no-octree */
    const char *file;       /* --octree F.ivo, else NULL (built here) */
    double build_time_s;    /* when built here */
    const oct_leaf_tapes_t *leaf_tapes; /* built (NULL: not even tried) */
    int leaf_tapes_used;    /* else every leaf is searched with the scene's tape */
    double leaf_tapes_time_s;
} octree_info_t;

static int write_stats(io_group_t *g, const char *path, const scene_t *s, ray_method_t method, int width,
                       int height, int frames, const ray_stats_t *st, const octree_info_t *oi,
                       const ray_render_opts_t *ro, const build_stats_extra_t *extra,
                       ivoct_error_t *err)
{
    io_file_t f;
    if (io_open(&f, path, err))
        return -1;
    FILE *o = f.f;
    fputs("{\n  \"scene\": ", o);
    cli_json_string(o, s->source.name);
    cli_json_implicitize(o, s);
    fputs(",\n  \"method\": ", o);
    cli_json_string(o, ray_method_name(method));
    fprintf(o,
            ",\n  \"certified\": %s,\n  \"octree\": %s,\n  \"width\": %d,\n  \"height\": %d,\n"
            "  \"frames\": %d,\n  \"rays\": %llu,\n  \"hits\": %llu,\n  \"tangent_hits\": %llu,\n"
            "  \"time_s\": ",
            ray_method_certified(method) ? "true" : "false", oi->tree ? "true" : "false", width,
            height, frames,
            (unsigned long long)st->rays, (unsigned long long)st->hits,
            (unsigned long long)st->tangent_hits);
    cli_json_double(o, st->time_s);
    fprintf(o,
            ",\n  \"tape_evals\": %llu,\n  \"simd\": \"%s\",\n  \"segments\": %llu,\n"
            "  \"leaves_visited\": %llu,\n  \"threads\": %d",
            (unsigned long long)st->tape_evals, tape_simd_name(), (unsigned long long)st->segments,
            (unsigned long long)st->leaves, st->threads);
    fprintf(o,
            ",\n  \"beams\": %llu,\n  \"rays_decided_by_beam\": %llu",
            (unsigned long long)st->beams, (unsigned long long)st->rays_decided_by_beam);
    fputs(",\n  \"light\": ", o);
    if (ro->light_on) {
        for (int a = 0; a < 3; a++) {
            fputs(a ? ", " : "[", o);
            cli_json_double(o, ro->light[a]);
        }
        fprintf(o,
                "],\n  \"shadow_rays\": %llu,\n  \"shadowed\": %llu,\n"
                "  \"shadow_undecided\": %llu,\n  \"shadow_tape_evals\": %llu",
                (unsigned long long)st->shadow_rays, (unsigned long long)st->shadowed,
                (unsigned long long)st->shadow_undecided, (unsigned long long)st->shadow_evals);
    } else {
        fputs("null", o);
    }
    if (oi->tree) {
        const oct_tree_t *t = oi->tree;
        fputs(",\n  \"octree_source\": ", o);
        if (oi->file)
            cli_json_string(o, oi->file);
        else
            fputs("\"built\"", o);
        fprintf(o, ",\n  \"octree_depth\": %d,\n  \"octree_leaves\": %u,\n"
                   "  \"octree_slabs\": %s",
                t->depth, t->n_leaves, t->slabs ? "true" : "false");
        if (!oi->file) {
            fputs(",\n  \"build_time_s\": ", o);
            cli_json_double(o, oi->build_time_s);
        }
        fprintf(o, ",\n  \"leaf_tapes\": %s", oi->leaf_tapes_used ? "true" : "false");
        if (oi->leaf_tapes) {
            fprintf(o, ",\n  \"leaf_tapes_stored\": %zu,\n  \"leaf_tapes_clauses\": %zu,\n"
                       "  \"leaf_tapes_mean_clauses\": ",
                    oi->leaf_tapes->n_tapes, oi->leaf_tapes->n_clauses);
            cli_json_double(o, oi->leaf_tapes->mean_clauses);
            fputs(",\n  \"leaf_tapes_time_s\": ", o);
            cli_json_double(o, oi->leaf_tapes_time_s);
        }
    }
    if (extra)
        extra->write(o, extra->user);
    fputs("\n}\n", o);
    return io_group_add(g, &f, err);
}

/* Whether a saved octree was built from this scene's surface: the same box
 * (bit for bit), the same f text and the same named subexpressions.  On a
 * mismatch, what differs goes into why. */
static int same_surface(const scene_t *s, const oct_tree_t *t, const oct_source_t *src,
                        char *why, size_t n)
{
    const oct_source_t *own = &s->source;
    for (int i = 0; i < 6; i++)
        if (!(s->box[i] == t->box[i])) {
            snprintf(why, n, "its box (%.17g %.17g %.17g %.17g %.17g %.17g) is not the scene's",
                     t->box[0], t->box[1], t->box[2], t->box[3], t->box[4], t->box[5]);
            return 0;
        }
    if (!src->f || strcmp(src->f, own->f)) {
        snprintf(why, n, "its f (%.200s) is not the scene's", src->f ? src->f : "none");
        return 0;
    }
    if (src->n_lets != own->n_lets) {
        snprintf(why, n, "it has %zu let definitions, the scene %zu", src->n_lets, own->n_lets);
        return 0;
    }
    for (size_t i = 0; i < own->n_lets; i++)
        if (strcmp(src->let_names[i], own->let_names[i]) ||
            strcmp(src->let_texts[i], own->let_texts[i])) {
            snprintf(why, n, "its let.%.100s is not the scene's", src->let_names[i]);
            return 0;
        }
    return 1;
}

/* ---- the memory budget (--max-memory) ------------------------------------------------
 * The image buffers (ray_image_t, known from the size) are taken off the
 * budget first; the octree is built within what is left (oct_params_t.
 * max_memory) or, when loaded, must fit in it.  Leaf tapes are an
 * optimisation: when the tree, the image and they do not fit together, they
 * are dropped and every leaf is searched with the scene's tape (the image is
 * the same).  PNG and .vti are written row by row, in constant memory. */
static double image_bytes(int width, int height)
{
    const double per_pixel = sizeof(double) * 10 /* t, point, normal, dir */ +
                             3 /* rgb */ + 3 /* hit, kind, shadow */;
    return per_pixel * width * height;
}

static double tree_bytes(const oct_tree_t *t)
{
    return (double)t->n_nodes * sizeof *t->nodes + (double)t->n_leaves * sizeof *t->leaves +
           (t->slabs ? (double)t->n_leaves * sizeof *t->slabs : 0.0);
}

static double leaf_tapes_bytes(const oct_leaf_tapes_t *lt)
{
    return (double)lt->n_leaves * sizeof *lt->of_leaf +
           (double)(lt->n_tapes + 1) * sizeof *lt->tapes +
           (double)lt->n_clauses * sizeof *lt->clauses;
}

/* ---- options ------------------------------------------------------------------------ */

static int parse_method(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    (void)opt;
    if (!ray_method_parse(value, target))
        return 0;
    char list[256];
    snprintf(msg, n, "unknown method '%s'; expected %s", value, ray_method_list(list, sizeof list));
    return -1;
}

static int parse_wxh(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    int *wh = target;
    if (!parse_size(value, &wh[0], &wh[1]))
        return 0;
    snprintf(msg, n, "%s expects WxH with W and H in 1..%d, got '%s'", opt, RAY_MAX_SIZE, value);
    return -1;
}

int cmd_render(int argc, char **argv)
{
    const char *scene_path = NULL, *png = NULL, *vti = NULL, *stats = NULL, *octree = NULL;
    ray_method_t method = RAY_NEWTON_AH;
    long threads = 0, frames = 1;
    int size[2] = {0, 0};
    size_t max_memory = 0;
    double light[3] = {0, 0, 0};
    bool quiet = false, no_octree = false, no_leaf_tapes = false, no_beams = false,
         method_given = false,
         size_given = false, light_given = false, no_light = false;

    const cli_option_t options[] = {
        {.name = "--help", .alias = "-h", .kind = CLI_HELP},
        {.name = "SCENE", .kind = CLI_OPERAND, .target = &scene_path},
        {.name = "--octree", .kind = CLI_STRING, .target = &octree, .arg = "F.ivo",
         .help = "use a saved octree (ivoct build --save: F.ivo, or F.pivo, the\n"
                 "index of the pieces saved under mpirun) instead of building\n"
                 "one: it must come from the same f (and let.*) and box as\n"
                 "SCENE, which still gives the camera and render settings;\n"
                 "built with ilie among its --tests, its slabs make the\n"
                 "render faster"},
        {.name = "--no-octree", .kind = CLI_FLAG, .target = &no_octree,
         .help = "search each ray over the whole scene box"},
        {.name = "--no-leaf-tapes", .kind = CLI_FLAG, .target = &no_leaf_tapes,
         .help = "search every leaf with the scene's tape, not with the tape\n"
                 "pruned to the leaf (which a scene with min, max or abs gets\n"
                 "by default when it shortens the tapes; the image is the same)"},
        {.name = "--no-beams", .kind = CLI_FLAG, .target = &no_beams,
         .help = "walk the octree ray by ray, not first a tile's rays together\n"
                 "as beams (which decide the rays that meet no surface leaf)\n"
                 "and the others in packets of 8; the image and the files are\n"
                 "the same"},
        {.name = "--method", .kind = CLI_CUSTOM, .target = &method, .parse = parse_method,
         .given = &method_given, .arg = "M",
         .help = "mitchell | newton | newton-ah | mrfro | mrfro-newton |\n"
                 "lipschitz | sampling (not certified)\n"
                 "(scene [render] method, default newton-ah)"},
        {.name = "--size", .kind = CLI_CUSTOM, .target = size, .parse = parse_wxh,
         .given = &size_given, .arg = "WxH",
         .help = "image size in pixels (scene [camera] size, default 300x300)"},
        {.name = "--light", .kind = CLI_DOUBLE, .target = light, .nargs = 3, .given = &light_given,
         .arg = "X Y Z",
         .help = "a point light at (X, Y, Z): every hit casts a certified\n"
                 "shadow ray to it; .vti gains the array shadow (scene\n"
                 "[render] light, default none: a light fixed to the camera)"},
        {.name = "--no-light", .kind = CLI_FLAG, .target = &no_light,
         .help = "ignore the scene's [render] light: no shadows"},
        {.name = "--threads", .kind = CLI_INT, .target = &threads, .lo = 1, .hi = 1024, .arg = "N",
         .help = "threads (default: all cores); the outputs are the same for any N"},
        {.name = "--max-memory", .kind = CLI_CUSTOM, .target = &max_memory,
         .parse = cli_parse_memory, .arg = "SIZE",
         .help = "stop with an error past SIZE bytes (suffixes K M G) for the\n"
                 "octree and the image buffers, default none"},
        {.name = "--png", .kind = CLI_STRING, .target = &png, .arg = "F",
         .help = "the shaded image, 8-bit RGB"},
        {.name = "--vti", .kind = CLI_STRING, .target = &vti, .arg = "F",
         .help = "the render buffers as VTK ImageData: per pixel t (NaN on a\n"
                 "miss), hit, point, normal, dir (and shadow with a light);\n"
                 "camera, method (and light) as field data"},
        {.name = "--frames", .kind = CLI_INT, .target = &frames, .lo = 1, .hi = 100000, .arg = "N",
         .help = "a turntable of N views about the camera's up axis through the\n"
                 "target, written as F_000.png, F_001.png, ... (default 1: F)"},
        {.name = "--stats", .kind = CLI_STRING, .target = &stats, .arg = "F.json",
         .help = "statistics: method, octree, width, height, rays, hits,\n"
                 "time_s (render only), tape_evals, leaves_visited, light,\n"
                 "shadow_rays, shadowed, shadow_undecided, build_time_s (when\n"
                 "built here), ... (totals over frames)"},
        {.name = "--quiet", .alias = "-q", .kind = CLI_FLAG, .target = &quiet,
         .help = "no summary on stdout, no progress bar"},
        {0},
    };
    const cli_command_t cmd = {"render", SYNOPSIS, 18, options};
    int rc = cli_parse(&cmd, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (!scene_path)
        return cli_usage_error("render", "missing the scene file");
    if (octree && no_octree)
        return cli_usage_error("render", "--octree and --no-octree exclude each other");
    if (light_given && no_light)
        return cli_usage_error("render", "--light and --no-light exclude each other");
    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int loaded = scene_load(scene_path, &s, &err);
    if (loaded) {
        cli_print_error(&err);
        return loaded == SCENE_ERUNTIME ? EXIT_RUNTIME : EXIT_USAGE;
    }
    rc = EXIT_OK;
    /* every output goes to a temporary name; all are renamed at the end, and
     * only when all were written (the commit group) */
    io_group_t group = IO_GROUP_INIT;
    ray_image_t img = {0};
    oct_tree_t *tree = NULL;
    oct_leaf_tapes_t *leaf_tapes = NULL;
    octree_info_t oi = {.file = octree};
#ifdef IVOCT_MPI
    cli_mpi_render_t mr = {0};
#endif
    if (!method_given)
        method = s.method;
    /* the scene's camera, at the size of --size */
    ray_camera_t cam0 = s.camera;
    if (size_given &&
        ray_camera_init(&cam0, s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, size[0],
                        size[1], &err)) {
        fprintf(stderr, "ivoct render: %s: %s\n", scene_path, err.msg);
        rc = EXIT_USAGE;
        goto out;
    }
    const int width = cam0.width, height = cam0.height;
    /* under mpirun (cli/mpi.c): with fewer frames than ranks each frame is cut
       into `parts` parts, one per rank, gathered on rank 0; else frame k is
       rendered by rank k mod N */
    int rank = 0, ranks = 1, parts = 1;
#ifdef IVOCT_MPI
    if (cli_mpi_ranks())
        ranks = cli_mpi_ranks(), rank = cli_mpi_rank();
    if (frames < ranks)
        parts = ranks;
#endif
    /* the image buffers, and the gather's buffer of one part: the shaded
       image alone when no .vti is written */
    double buffers = image_bytes(width, height);
#ifdef IVOCT_MPI
    const ray_pack_t gathered = vti ? RAY_PACK_ALL : RAY_PACK_RGB;
    if (parts > 1 && (png || vti))
        buffers += cli_mpi_render_buffer_bytes(width, height, parts, (int)gathered);
#endif
    if (max_memory && buffers > (double)max_memory) {
        fprintf(stderr, "ivoct render: the image buffers of %dx%d take %.1f MB: past the memory "
                        "budget of %.1f MB (raise --max-memory)\n",
                width, height, buffers / 1048576, (double)max_memory / 1048576);
        rc = EXIT_RUNTIME;
        goto out;
    }
    const char *outputs[3] = {png, vti, stats};
    for (int k = 0; k < 3; k++)
        if (outputs[k] && probe_output(outputs[k], k == 2 ? 1 : (int)frames, &err)) {
            fprintf(stderr, "ivoct render: %s\n", err.msg);
            rc = EXIT_RUNTIME;
            goto out;
        }
    if (octree) {
        oct_source_t os = {0};
        if (oct_load(octree, &tree, &os, &err)) {
            fprintf(stderr, "ivoct render: %s\n", err.msg);
            rc = EXIT_USAGE;
            goto out;
        }
        char why[512];
        int same = same_surface(&s, tree, &os, why, sizeof why);
        oct_source_free(&os);
        if (!same) {
            fprintf(stderr, "ivoct render: %s was not built from %s: %s\n", octree, scene_path,
                    why);
            rc = EXIT_USAGE;
            goto out;
        }
    } else if (!no_octree) {
        oct_params_t op = s.octree;
        /* slabs when they pay: the rays of every frame, and a shadow ray per
         * hit at most */
        const int lit = light_given || (s.has_light && !no_light);
        ray_octree_params(&op, (double)width * height * (double)frames * (lit ? 2 : 1));
        op.threads = (int)threads;
        /* at least 1 byte: 0 would mean no limit */
        if (max_memory)
            op.max_memory = (size_t)fmax(1.0, (double)max_memory - buffers);
        if (oct_params_check(&op, &err)) {
            fprintf(stderr, "ivoct render: %s: [octree] %s\n", scene_path, err.msg);
            rc = EXIT_USAGE;
            goto out;
        }
        cli_progress_t bp = {"building the octree", omp_get_wtime(), 0, 0, 1};
        if (!quiet && isatty(2)) {
            op.progress = cli_show_progress;
            op.progress_user = &bp;
        }
        double t0 = omp_get_wtime();
        if (oct_build(s.tape, s.box, &op, &tree, &err)) {
            if (max_memory)
                fprintf(stderr, "ivoct render: building the octree in the %.1f MB that the image "
                                "buffers leave of --max-memory: %s\n",
                        (double)op.max_memory / 1048576, err.msg);
            else
                fprintf(stderr, "ivoct render: building the octree: %s\n", err.msg);
            rc = EXIT_RUNTIME;
            goto out;
        }
        oi.build_time_s = omp_get_wtime() - t0;
    }
    oi.tree = tree;
    if (max_memory && tree && tree_bytes(tree) + buffers > (double)max_memory) {
        fprintf(stderr, "ivoct render: the octree (%.1f MB) and the image buffers (%.1f MB) are "
                        "past the memory budget of %.1f MB (raise --max-memory)\n",
                tree_bytes(tree) / 1048576, buffers / 1048576,
                (double)max_memory / 1048576);
        rc = EXIT_RUNTIME;
        goto out;
    }
    if (ray_image_alloc(&img, width, height, &err)) {
        fprintf(stderr, "ivoct render: %s\n", err.msg);
        rc = EXIT_RUNTIME;
        goto out;
    }

    ray_box_source_t bs;
    ray_octree_source_t trav;
    ray_source_t src = tree ? ray_octree_source(&trav, tree) : ray_box_source(&bs, s.box);
    ray_render_opts_t ro;
    ray_render_opts_default(&ro);
    ro.method = method;
    ro.threads = (int)threads;
    ro.no_beams = no_beams;
    if (light_given || (s.has_light && !no_light)) {
        ro.light_on = 1;
        memcpy(ro.light, light_given ? light : s.light, sizeof ro.light);
    }
    if (tree && !no_leaf_tapes && tape_has_choices(s.tape)) {
        /* the margin of the camera covers every turntable view of it; the
         * shadow rays need the light's */
        double margin = ray_tape_margin(&cam0, s.box);
        if (ro.light_on)
            margin = fmax(margin, ray_light_tape_margin(ro.light, s.box));
        double t0 = omp_get_wtime();
        if (oct_leaf_tapes_build(tree, s.tape, margin,
                                 LEAF_TAPES_MAX_RATIO, &leaf_tapes, &err)) {
            fprintf(stderr, "ivoct render: %s\n", err.msg);
            rc = EXIT_RUNTIME;
            goto out;
        }
        oi.leaf_tapes_time_s = omp_get_wtime() - t0;
        if (max_memory &&
            tree_bytes(tree) + buffers + leaf_tapes_bytes(leaf_tapes) > (double)max_memory) {
            oct_leaf_tapes_free(leaf_tapes); /* over the budget: the scene's tape */
            leaf_tapes = NULL;
        }
        oi.leaf_tapes = leaf_tapes;
        if (leaf_tapes && leaf_tapes->n_tapes > 0 &&
            leaf_tapes->mean_clauses <= LEAF_TAPES_MAX_RATIO * s.tape->n) {
            trav.tapes = leaf_tapes;
            oi.leaf_tapes_used = 1;
        }
    }
    {
        double dx = s.box[1] - s.box[0], dy = s.box[3] - s.box[2], dz = s.box[5] - s.box[4];
        double diag = sqrt(dx * dx + dy * dy + dz * dz);
        ro.roots.sample_step = diag > 0 ? diag / 1000 : 0;
    }
    cli_progress_t prog = {"rendering", omp_get_wtime(), 0, 0, (int)frames};
    if (!quiet && isatty(2)) {
        ro.progress = cli_show_progress;
        ro.progress_ctx = &prog;
    }
    ray_stats_t total = {0};
    build_stats_extra_t mpi_stats = {NULL, NULL};
#ifdef IVOCT_MPI
    if (ranks > 1) {
        int started = cli_mpi_render_start(&mr, width, height, (int)frames, png || vti,
                                           (int)gathered, &err)
                          ? EXIT_RUNTIME
                          : EXIT_OK;
        if (started != EXIT_OK)
            fprintf(stderr, "ivoct render: %s\n", err.msg);
        if ((rc = cli_mpi_agree(started)))
            goto out;
        mpi_stats = (build_stats_extra_t){cli_mpi_render_stats, &mr};
    }
#endif
    cli_test_pause("render");
    ro.part = rank;
    ro.parts = parts;
    for (int k = 0; k < frames; k++) {
        if (parts == 1 && k % ranks != rank)
            continue;
        ray_camera_t cam;
        const double two_pi = 6.283185307179586;
        if (ray_camera_orbit(&cam0, two_pi * k / (double)frames, &cam, &err)) {
            fprintf(stderr, "ivoct render: frame %d: %s\n", k, err.msg);
            rc = EXIT_USAGE;
            goto out;
        }
        prog.frame = k;
        ray_stats_t st;
        if (ray_render(s.tape, &cam, &src, &ro, &img, &st, &err)) {
            fprintf(stderr, "ivoct render: %s\n", err.msg);
            rc = EXIT_RUNTIME;
        }
#ifdef IVOCT_MPI
        if (parts > 1) {
            /* every part is rendered before the gather */
            if ((rc = cli_mpi_agree(rc)))
                goto out;
            if (mr.gather)
                cli_mpi_render_gather(&mr, &img);
        }
#endif
        if (rc)
            goto out;
        total.rays += st.rays;
        total.hits += st.hits;
        total.tangent_hits += st.tangent_hits;
        total.tape_evals += st.tape_evals;
        total.segments += st.segments;
        total.leaves += st.leaves;
        total.shadow_rays += st.shadow_rays;
        total.shadowed += st.shadowed;
        total.shadow_undecided += st.shadow_undecided;
        total.shadow_evals += st.shadow_evals;
        total.beams += st.beams;
        total.rays_decided_by_beam += st.rays_decided_by_beam;
        total.time_s += st.time_s;
        total.threads = st.threads;
        if (rank > 0 && parts > 1)
            continue; /* rank 0 writes the gathered frame */
        cli_test_pause("frame");
        if ((png && write_output(&group, png, k, (int)frames, png_writer, &img, &cam, NULL, &err)) ||
            (vti && write_output(&group, vti, k, (int)frames, ray_write_vti, &img, &cam,
                                 ray_method_name(method), &err))) {
            fprintf(stderr, "ivoct render: %s\n", err.msg);
            rc = EXIT_RUNTIME;
            goto out;
        }
    }
#ifdef IVOCT_MPI
    if (ranks > 1) {
        /* every rank rendered its frames or parts: the totals are over all of them */
        if ((rc = cli_mpi_agree(EXIT_OK)))
            goto out;
        cli_mpi_render_reduce(&mr, &total);
    }
#endif
    if (stats && rank == 0 &&
        write_stats(&group, stats, &s, method, width, height, (int)frames, &total, &oi, &ro,
                    mpi_stats.write ? &mpi_stats : NULL, &err)) {
        fprintf(stderr, "ivoct render: %s\n", err.msg);
        rc = EXIT_RUNTIME;
        goto out;
    }
#ifdef IVOCT_MPI
    /* renamed only once every rank has written all of its frames */
    if (ranks > 1 && (rc = cli_mpi_agree(EXIT_OK)))
        goto out;
#endif
    cli_test_pause("commit");
    if (io_group_commit(&group, &err)) {
        fprintf(stderr, "ivoct render: %s\n", err.msg);
        rc = EXIT_RUNTIME;
        goto out;
    }
    if (!quiet) {
        char how[128];
        if (!tree)
            snprintf(how, sizeof how, "no octree");
        else if (octree)
            snprintf(how, sizeof how, "octree depth %d (%u leaves, loaded)", tree->depth,
                     tree->n_leaves);
        else
            snprintf(how, sizeof how, "octree depth %d (%u leaves, built in %.3f s)",
                     tree->depth, tree->n_leaves, oi.build_time_s);
        char over[96] = "";
#ifdef IVOCT_MPI
        if (ranks > 1)
            snprintf(over, sizeof over, ", %d ranks (%s), balance %.2f", ranks,
                     parts > 1 ? "each frame in tiles" : "frames dealt out", mr.balance);
#endif
        char shadows[128] = "";
        if (ro.light_on)
            snprintf(shadows, sizeof shadows, ", %llu in shadow (%llu undecided)",
                     (unsigned long long)(total.shadowed + total.shadow_undecided),
                     (unsigned long long)total.shadow_undecided);
        printf("%s: %s, %dx%d%s, %s: %llu hits of %llu rays (%llu tangent)%s, %llu leaves "
               "searched, render %.3f s, %d thread%s%s\n",
               s.source.name, ray_method_name(method), width, height,
               frames > 1 ? " per frame" : "", how, (unsigned long long)total.hits,
               (unsigned long long)total.rays, (unsigned long long)total.tangent_hits, shadows,
               (unsigned long long)total.leaves, total.time_s, total.threads,
               total.threads > 1 ? "s" : "", over);
    }
out:
#ifdef IVOCT_MPI
    cli_mpi_render_end(&mr);
#endif
    io_group_abort(&group); /* empty after a commit */
    oct_leaf_tapes_free(leaf_tapes);
    oct_free(tree);
    ray_image_free(&img);
    scene_free(&s);
    return rc;
}
