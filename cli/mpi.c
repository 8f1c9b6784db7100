/* ivoct build over MPI (docs/cluster.md): `mpirun -np N ivoct build SCENE ...`.
 *
 * Every rank loads the scene and computes the top of the tree (oct_plan_new:
 * cheap, and the same everywhere), whose frontier of >= 256 subtrees is the
 * unit of work.  A coarse pass (the subtrees built 3 levels deep, spread over
 * the ranks) weighs each subtree by its cells at that depth; the subtrees are
 * cut into N ranges of equal weight in Morton order.  Rank 0 hands them out
 * (a thread of its own answers requests): a rank takes chunks from the front
 * of its range, and once it is empty, from the back of the range with the
 * most weight left, so ranks that finish early take over the rest of a skewed
 * scene.  Each chunk is built by oct_plan_build on the rank's threads.
 *
 * The outputs that are one file (--save F.ivo, --cells F.csv, --vtu F.vtu,
 * --htg F.htg, --vdb, --mesh) are written by rank 0 from the subtrees gathered
 * there (the file of the single-process build, byte for byte); the partitioned
 * ones (--vtu F.pvtu, --cells F.pcsv, --htg F.phtg, --save F.pivo) by every
 * rank from its own subtrees, F_<rank> beside the index rank 0 writes.  --stats holds the
 * reduced counts and the per-rank figures.  Errors: every failure point is
 * agreed on by all ranks (cli_mpi_agree): the lowest failing rank's message
 * is printed once, by rank 0, and every rank exits with its status; outputs
 * are renamed into place only once every rank has written all of its own.
 *
 * The render over MPI (cmd_render.c) uses the end of this file: with fewer
 * frames than ranks each frame is cut into parts, one per rank (ray.h, "parts
 * of an image"), gathered on rank 0; else the frames are dealt out. */
#define _POSIX_C_SOURCE 200809L
#include <limits.h>
#include <mpi.h>
#include <omp.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "../export/export.h"
#include "../io/io.h"
#include "../octree/octree.h"
#include "../ray/ray.h"
#include "../scene/scene.h"
#include "cli.h"

static struct {
    int started, rank, size, threaded;
    int failed_agreed;  /* an agreement already ended in a failure */
    FILE *captured;     /* ranks > 0: stderr, read back when their failure is reported */
    long reported;      /* how much of it was dealt with */
} M;

enum { TAG_REQUEST = 1, TAG_GRANT, TAG_TEXT, TAG_SUBTREE, TAG_PART };

int cli_mpi_start(int *argc, char ***argv)
{
    /* only under a launcher: plain `ivoct build` stays a single process
       (MPI_Init outside mpirun would start a singleton runtime) */
    if (!getenv("OMPI_COMM_WORLD_SIZE") && !getenv("PMIX_RANK") && !getenv("PMI_RANK"))
        return EXIT_OK;
    int provided;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) {
        fputs("ivoct: cannot start MPI\n", stderr);
        return EXIT_RUNTIME;
    }
    M.started = 1;
    M.threaded = provided >= MPI_THREAD_SERIALIZED;
    MPI_Comm_rank(MPI_COMM_WORLD, &M.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &M.size);
    if (M.rank > 0) {
        /* one voice: rank 0 prints; the others' messages are kept and sent to
           it when their failure is the one reported (sanitizers write to the
           descriptor, not to stderr, so their reports still show) */
        FILE *cap = tmpfile();
        FILE *null = fopen("/dev/null", "w");
        if (cap)
            stderr = cap;
        if (null)
            stdout = null;
        M.captured = cap;
    }
    return EXIT_OK;
}

int cli_mpi_ranks(void) { return M.started ? M.size : 0; }

int cli_mpi_rank(void) { return M.rank; }

uint64_t cli_mpi_sum_u64(uint64_t v)
{
    uint64_t sum = v;
    if (M.started)
        MPI_Allreduce(&v, &sum, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    return sum;
}

/* What this rank wrote on its stderr since the last report. */
static char *captured_text(void)
{
    if (!M.captured)
        return NULL;
    fflush(M.captured);
    long end = ftell(M.captured);
    if (end < M.reported)
        return NULL;
    char *text = calloc((size_t)(end - M.reported) + 1, 1);
    if (text && fseek(M.captured, M.reported, SEEK_SET) == 0)
        text[fread(text, 1, (size_t)(end - M.reported), M.captured)] = '\0';
    fseek(M.captured, end, SEEK_SET);
    M.reported = end;
    return text;
}

int cli_mpi_agree(int rc)
{
    if (!M.started)
        return rc;
    int *all = malloc((size_t)M.size * sizeof *all);
    if (!all)
        MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME);
    MPI_Allgather(&rc, 1, MPI_INT, all, 1, MPI_INT, MPI_COMM_WORLD);
    int first = -1;
    for (int r = 0; r < M.size && first < 0; r++)
        if (all[r] != EXIT_OK)
            first = r;
    int agreed = first < 0 ? EXIT_OK : all[first];
    free(all);
    char *text = captured_text(); /* dealt with, whoever reports */
    if (first > 0) {
        /* rank 0 printed nothing for this: it prints the failing rank's words */
        if (M.rank == first) {
            const char *t = text ? text : "";
            MPI_Send(t, (int)strlen(t), MPI_CHAR, 0, TAG_TEXT, MPI_COMM_WORLD);
        } else if (M.rank == 0) {
            MPI_Status st;
            int n;
            MPI_Probe(first, TAG_TEXT, MPI_COMM_WORLD, &st);
            MPI_Get_count(&st, MPI_CHAR, &n);
            char *t = calloc((size_t)n + 1, 1);
            MPI_Recv(t, n, MPI_CHAR, first, TAG_TEXT, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            if (t)
                fputs(t, stderr);
            free(t);
        }
    }
    free(text);
    if (agreed != EXIT_OK) {
        /* from here every rank is on its way out: mpirun ends the slower ones
           with SIGTERM once one exits non-zero, which is not an interruption
           (the signal thread still removes the temporaries) */
        M.failed_agreed = 1;
        cli_signals_settled();
    }
    return agreed;
}

int cli_mpi_finish(int rc)
{
    if (!M.started)
        return rc;
    /* a rank that failed before the command's first agreement meets the
       others here (their first agreement); once a failure was agreed on, every
       rank is past its last collective */
    if (!M.failed_agreed)
        rc = cli_mpi_agree(rc);
    MPI_Finalize();
    return rc;
}

/* Is path an index of pieces (its name ends in ext)? */
static int is_index(const char *path, const char *ext)
{
    size_t n = path ? strlen(path) : 0, e = strlen(ext);
    return n > e && !strcmp(path + n - e, ext);
}

/* ---- the work: ranges by weight, handed out by rank 0 ------------------------------- */

typedef struct share {
    pthread_mutex_t lock;
    size_t *next, *end;     /* per rank: what is left of its range, [next, end) */
    const uint64_t *weight; /* per subtree */
    int aborted;            /* a rank failed: no more work for anyone */
    uint64_t *shared;       /* per rank: subtrees taken from another's range */
    uint64_t requests;
} share_t;

/* The next chunk for rank r with `threads` threads: [*a, *b), empty when the
 * work is done.  From r's own range while it lasts (a quarter of what is
 * left, at least one subtree per thread), then from the back of the range
 * with the most weight left (half of it, at most one per thread). */
static void share_next(share_t *s, int r, int threads, size_t *a, size_t *b)
{
    pthread_mutex_lock(&s->lock);
    s->requests++;
    *a = *b = 0;
    size_t t = threads > 0 ? (size_t)threads : 1;
    if (!s->aborted && s->next[r] < s->end[r]) {
        size_t left = s->end[r] - s->next[r], n = left / 4 > t ? left / 4 : t;
        *a = s->next[r];
        *b = *a + (n < left ? n : left);
        s->next[r] = *b;
    } else if (!s->aborted) {
        int victim = -1;
        uint64_t most = 0;
        for (int v = 0; v < M.size; v++) {
            uint64_t w = 0;
            for (size_t i = s->next[v]; i < s->end[v]; i++)
                w += s->weight[i];
            if (s->next[v] < s->end[v] && (victim < 0 || w > most))
                victim = v, most = w;
        }
        if (victim >= 0) {
            size_t left = s->end[victim] - s->next[victim];
            size_t n = (left + 1) / 2 < t ? (left + 1) / 2 : t;
            *b = s->end[victim];
            *a = *b - n;
            s->end[victim] = *a;
            s->shared[r] += n;
        }
    }
    pthread_mutex_unlock(&s->lock);
}

/* Rank 0's thread that answers the other ranks' requests until each has been
 * told there is no more work.  It polls (rather than blocking in MPI_Recv,
 * which spins a core in Open MPI) so the build keeps rank 0's cores. */
static void *share_serve(void *arg)
{
    share_t *s = arg;
    int left = M.size - 1;
    while (left > 0) {
        int flag;
        MPI_Status st;
        MPI_Iprobe(MPI_ANY_SOURCE, TAG_REQUEST, MPI_COMM_WORLD, &flag, &st);
        if (!flag) {
            nanosleep(&(struct timespec){0, 200000}, NULL);
            continue;
        }
        int req[2]; /* threads, failed */
        MPI_Recv(req, 2, MPI_INT, st.MPI_SOURCE, TAG_REQUEST, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (req[1]) {
            pthread_mutex_lock(&s->lock);
            s->aborted = 1;
            pthread_mutex_unlock(&s->lock);
        }
        size_t a, b;
        share_next(s, st.MPI_SOURCE, req[0], &a, &b);
        uint64_t grant[2] = {a, b};
        MPI_Send(grant, 2, MPI_UINT64_T, st.MPI_SOURCE, TAG_GRANT, MPI_COMM_WORLD);
        if (a == b)
            left--;
    }
    return NULL;
}

/* The next chunk for this rank: from rank 0's share, by message or directly. */
static void next_chunk(share_t *s, int threads, int failed, size_t *a, size_t *b)
{
    if (M.rank == 0 || !M.threaded) {
        if (failed && s) {
            pthread_mutex_lock(&s->lock);
            s->aborted = 1;
            pthread_mutex_unlock(&s->lock);
        }
        if (s) {
            share_next(s, 0, threads, a, b);
        } else {
            *a = *b = 0;
        }
        return;
    }
    int req[2] = {threads, failed};
    uint64_t grant[2];
    MPI_Send(req, 2, MPI_INT, 0, TAG_REQUEST, MPI_COMM_WORLD);
    MPI_Recv(grant, 2, MPI_UINT64_T, 0, TAG_GRANT, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    *a = (size_t)grant[0], *b = (size_t)grant[1];
}

/* Weights of the subtrees: each one's cells at 3 levels below the frontier
 * (a proxy for the surface it holds), from a coarse plan whose subtrees the
 * ranks build in turn (every N-th); 1 each when the build is that shallow. */
static int coarse_weights(const build_job_t *job, oct_plan_t *plan, uint64_t *w, int *coarse_depth,
                          ivoct_error_t *err)
{
    size_t n = oct_plan_subtrees(plan);
    int fd = oct_plan_subtree_depth(plan);
    for (size_t i = 0; i < n; i++)
        w[i] = 1;
    *coarse_depth = fd;
    if (job->params.depth <= fd + 3 || n == 0)
        return 0;
    oct_params_t cp = job->params;
    cp.depth = fd + 3;
    cp.slabs_unused = 1;
    cp.progress = NULL;
    oct_plan_t *coarse = NULL;
    size_t *mine = malloc(n * sizeof *mine), k = 0;
    uint64_t *local = calloc(n, sizeof *local);
    int rc = oct_plan_new(job->scene->tape, job->scene->box, &cp, &coarse, err);
    if (rc)
        goto done;
    if (!mine || !local || oct_plan_subtrees(coarse) != n) {
        /* the same frontier at any depth past it: else weights stay 1 */
        rc = !mine || !local ? (ivoct_error_set(err, "out of memory"), -1) : 0;
        goto done;
    }
    for (size_t i = (size_t)M.rank; i < n; i += (size_t)M.size)
        mine[k++] = i;
    if ((rc = oct_plan_build(coarse, mine, k, err)))
        goto done;
    for (size_t j = 0; j < k; j++) {
        oct_subtree_t st;
        if (!oct_plan_get(coarse, mine[j], &st))
            local[mine[j]] = st.stats.cells_by_depth[fd + 3] + 1;
    }
    *coarse_depth = fd + 3;
done:
    if (rc)
        fprintf(stderr, "ivoct build: %s\n", err->msg);
    rc = cli_mpi_agree(rc ? EXIT_RUNTIME : EXIT_OK) ? -1 : 0;
    if (!rc && *coarse_depth > fd)
        MPI_Allreduce(local, w, (int)n, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    free(mine);
    free(local);
    oct_plan_free(coarse);
    return rc;
}

/* ---- moving subtrees to rank 0 --------------------------------------------------------- */

typedef struct wire {
    uint64_t index;
    uint32_t base, n_nodes, n_leaves, slabs;
    double max_diagonal2;
    oct_stats_t stats;
} wire_t;

/* Send every subtree this rank holds to rank 0; the bytes sent. */
static uint64_t send_subtrees(const oct_plan_t *plan, MPI_Datatype leaf_t, MPI_Datatype slab_t)
{
    size_t n = oct_plan_subtrees(plan);
    uint64_t count = 0, bytes = 0;
    for (size_t i = 0; i < n; i++)
        count += (uint64_t)oct_plan_has(plan, i);
    MPI_Send(&count, 1, MPI_UINT64_T, 0, TAG_SUBTREE, MPI_COMM_WORLD);
    for (size_t i = 0; i < n; i++) {
        oct_subtree_t st;
        if (oct_plan_get(plan, i, &st))
            continue;
        wire_t h = {i, st.base, st.n_nodes, st.n_leaves, st.slabs != NULL, st.max_diagonal2,
                    st.stats};
        MPI_Send(&h, (int)sizeof h, MPI_BYTE, 0, TAG_SUBTREE, MPI_COMM_WORLD);
        MPI_Send(st.nodes, (int)st.n_nodes, MPI_UINT32_T, 0, TAG_SUBTREE, MPI_COMM_WORLD);
        MPI_Send(st.leaves, (int)st.n_leaves, leaf_t, 0, TAG_SUBTREE, MPI_COMM_WORLD);
        if (st.slabs)
            MPI_Send(st.slabs, (int)st.n_leaves, slab_t, 0, TAG_SUBTREE, MPI_COMM_WORLD);
        bytes += sizeof h + (uint64_t)st.n_nodes * sizeof *st.nodes +
                 (uint64_t)st.n_leaves * (sizeof *st.leaves + (st.slabs ? sizeof *st.slabs : 0));
    }
    return bytes;
}

/* Rank 0: the subtrees of rank `from` into plan; 0 or -1 with err set (the
 * messages are received all the same, so the sender is not left waiting). */
static int receive_subtrees(oct_plan_t *plan, int from, MPI_Datatype leaf_t, MPI_Datatype slab_t,
                            ivoct_error_t *err)
{
    uint64_t count;
    int rc = 0;
    MPI_Recv(&count, 1, MPI_UINT64_T, from, TAG_SUBTREE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    for (uint64_t k = 0; k < count; k++) {
        wire_t h;
        MPI_Recv(&h, (int)sizeof h, MPI_BYTE, from, TAG_SUBTREE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        oct_node_t *nodes = malloc(((size_t)h.n_nodes + 1) * sizeof *nodes);
        oct_leaf_t *leaves = malloc(((size_t)h.n_leaves + 1) * sizeof *leaves);
        oct_slab_t *slabs = h.slabs ? malloc(((size_t)h.n_leaves + 1) * sizeof *slabs) : NULL;
        if (!nodes || !leaves || (h.slabs && !slabs)) {
            /* cannot hold it: MPI has no way to drop a message unread */
            MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME);
        }
        MPI_Recv(nodes, (int)h.n_nodes, MPI_UINT32_T, from, TAG_SUBTREE, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        MPI_Recv(leaves, (int)h.n_leaves, leaf_t, from, TAG_SUBTREE, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        if (h.slabs)
            MPI_Recv(slabs, (int)h.n_leaves, slab_t, from, TAG_SUBTREE, MPI_COMM_WORLD,
                     MPI_STATUS_IGNORE);
        oct_subtree_t st = {h.base, h.n_nodes, h.n_leaves, nodes, leaves, slabs, h.stats,
                            h.max_diagonal2};
        if (!rc && oct_plan_put(plan, (size_t)h.index, &st, err))
            rc = -1;
        free(nodes), free(leaves), free(slabs);
    }
    return rc;
}

/* ---- the outputs ------------------------------------------------------------------------- */

/* The piece of rank r beside index path: PATH without its extension, _r, ext;
 * with the folder (for the file) or without (for the index's Source). */
static char *piece_name(const char *path, int r, const char *ext, int with_folder)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    const char *from = with_folder || !slash ? path : slash + 1;
    size_t n = (size_t)(dot - from) + strlen(ext) + 24;
    char *s = malloc(n);
    if (s)
        snprintf(s, n, "%.*s_%d%s", (int)(dot - from), from, r, ext);
    return s;
}

typedef struct mpi_figures {
    int ranks, subtrees, subtree_depth, coarse_depth, shared_on;
    double *time_s;
    uint64_t *cells, *count, *shared;
    double balance;
    uint64_t gather_bytes, requests;
} mpi_figures_t;

static void json_doubles(FILE *f, const double *v, int n)
{
    fputc('[', f);
    for (int i = 0; i < n; i++) {
        fputs(i ? ", " : "", f);
        cli_json_double(f, v[i]);
    }
    fputc(']', f);
}

static void json_u64s(FILE *f, const uint64_t *v, int n)
{
    fputc('[', f);
    for (int i = 0; i < n; i++)
        fprintf(f, "%s%llu", i ? ", " : "", (unsigned long long)v[i]);
    fputc(']', f);
}

/* ',\n    "key": [v...]' of the stats' mpi object. */
static void json_key_u64s(FILE *f, const char *key, const uint64_t *v, int n)
{
    fprintf(f, ",\n    \"%s\": ", key);
    json_u64s(f, v, n);
}

/* The balance of the ranks' times, max / mean (1 when all are 0); *max and
 * *sum (may be NULL) the slowest and the total. */
static double balance_of(const double *t, int n, double *max, double *sum)
{
    double tmax = 0, tsum = 0;
    for (int r = 0; r < n; r++) {
        tmax = t[r] > tmax ? t[r] : tmax;
        tsum += t[r];
    }
    if (max)
        *max = tmax;
    if (sum)
        *sum = tsum;
    return tsum > 0 ? tmax / (tsum / n) : 1.0;
}

static void write_mpi_stats(FILE *f, void *user)
{
    const mpi_figures_t *m = user;
    fprintf(f, ",\n  \"mpi\": {\"ranks\": %d, \"subtrees\": %d, \"subtree_depth\": %d, "
               "\"coarse_depth\": %d, \"work_sharing\": %s,\n    \"rank_time_s\": ",
            m->ranks, m->subtrees, m->subtree_depth, m->coarse_depth,
            m->shared_on ? "true" : "false");
    json_doubles(f, m->time_s, m->ranks);
    json_key_u64s(f, "rank_cells_visited", m->cells, m->ranks);
    json_key_u64s(f, "rank_subtrees", m->count, m->ranks);
    json_key_u64s(f, "rank_shared_subtrees", m->shared, m->ranks);
    fputs(",\n    \"balance\": ", f);
    cli_json_double(f, m->balance);
    fprintf(f, ", \"gather_bytes\": %llu, \"requests\": %llu}",
            (unsigned long long)m->gather_bytes, (unsigned long long)m->requests);
}

/* The counts of every rank's part added up on rank 0 (collective). */
static void reduce_stats(const oct_stats_t *mine, oct_stats_t *sum)
{
    enum { N = 7 + 4 * (OCT_MAX_DEPTH + 1) };
    uint64_t v[N], t[N];
    size_t k = 0;
    v[k++] = mine->cells_visited, v[k++] = mine->split, v[k++] = mine->decided_interval;
    v[k++] = mine->decided_lipschitz, v[k++] = mine->decided_ilie;
    v[k++] = mine->decided_refine, v[k++] = mine->decided_max_depth;
    for (int d = 0; d <= OCT_MAX_DEPTH; d++) {
        v[k++] = mine->leaves_by_depth[d], v[k++] = mine->cells_by_depth[d];
        v[k++] = mine->tape_length_sum_by_depth[d], v[k++] = mine->split_by_depth[d];
    }
    MPI_Reduce(v, t, N, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
    uint64_t u[2] = {mine->tape_clauses_evaluated, mine->leaves_certain}, tu[2] = {0, 0};
    MPI_Reduce(u, tu, 2, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
    /* the largest error bound; the slowest rank's certification */
    double e[2] = {mine->max_error_bound, mine->certain_time_s}, te[2] = {0, 0};
    MPI_Reduce(e, te, 2, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    k = 0;
    memset(sum, 0, sizeof *sum);
    sum->cells_visited = t[k++], sum->split = t[k++], sum->decided_interval = t[k++];
    sum->decided_lipschitz = t[k++], sum->decided_ilie = t[k++];
    sum->decided_refine = t[k++], sum->decided_max_depth = t[k++];
    for (int d = 0; d <= OCT_MAX_DEPTH; d++) {
        sum->leaves_by_depth[d] = t[k++], sum->cells_by_depth[d] = t[k++];
        sum->tape_length_sum_by_depth[d] = t[k++], sum->split_by_depth[d] = t[k++];
    }
    sum->tape_clauses_evaluated = tu[0];
    sum->leaves_certain = tu[1];
    sum->max_error_bound = te[0];
    sum->certain_time_s = te[1];
}

/* The frontier, for the .htg pieces: their trees are its cells (exp_htg_piece). */
typedef struct frontier {
    int depth;
    size_t n;
    uint64_t *code; /* Morton codes at depth, increasing */
} frontier_t;

/* This rank's pieces (--cells F.pcsv, --vtu F.pvtu, --htg F.phtg, --save
 * F.pivo) into g; rank 0 also the indexes, which name every rank's piece,
 * but the .pivo's, which needs every piece's checksum: *save_sum is this
 * rank's (write_save_index). */
static int write_pieces(const build_job_t *job, const oct_tree_t *part, const uint64_t *leaves,
                        const frontier_t *front, uint64_t *save_sum, io_group_t *g,
                        ivoct_error_t *err)
{
    const char *cells = is_index(job->cells, ".pcsv") ? job->cells : NULL;
    const char *vtu = is_index(job->ex.vtu, ".pvtu") ? job->ex.vtu : NULL;
    const char *htg = is_index(job->ex.htg, ".phtg") ? job->ex.htg : NULL;
    const char *save = is_index(job->save, ".pivo") ? job->save : NULL;
    /* the budget holds per rank: its part and what its pieces need beside it,
       as for one process's outputs */
    const exports_t piece_ex = {.vtu = vtu, .htg = htg};
    if (job->max_memory &&
        build_check_export_memory(part, cells, save, &piece_ex, job->max_memory, err))
        return -1;
    const int cells_threads =
        job->max_memory ? build_cells_threads(part, job->threads, job->max_memory) : job->threads;
    int rc = 0;
    char **sources = calloc((size_t)M.size, sizeof *sources);
    if (!sources) {
        ivoct_error_set(err, "out of memory");
        return -1;
    }
    const char *const index_of[] = {cells, vtu, htg, save};
    const char *const ext_of[] = {".csv", ".vtu", ".htg", ".ivo"};
    const char *const step_of[] = {"cells", "vtu", "htg", "save"}; /* cli_test_pause */
    const scene_t *s = job->scene;
    for (int pass = 0; pass < 4 && !rc; pass++) {
        const char *index = index_of[pass], *ext = ext_of[pass];
        if (!index)
            continue;
        char *mine = piece_name(index, M.rank, ext, 1);
        const char *tmp = NULL;
        cli_test_pause(step_of[pass]);
        rc = !mine || io_group_reserve(g, mine, &tmp, err);
        /* the .htg piece: the trees of the frontier cells this part holds, and
           on rank 0 (the part with the top's leaves) the top's cells there */
        if (!rc)
            rc = pass == 0   ? exp_cells(part, tmp, cells_threads, err)
                 : pass == 1 ? exp_vtu(part, &s->source, tmp, err)
                 : pass == 2 ? exp_htg_piece(part, s->tape, &s->source, front->depth, front->code,
                                             front->n, M.rank == 0, tmp, err)
                             : oct_save(part, &s->source, tmp, err) ||
                                   oct_file_checksum(tmp, save_sum, err);
        free(mine);
        if (!rc && M.rank == 0 && pass < 3) {
            for (int r = 0; r < M.size && !rc; r++)
                rc = !(sources[r] = piece_name(index, r, ext, 0));
            const char *itmp;
            if (!rc)
                rc = io_group_reserve(g, index, &itmp, err);
            if (!rc)
                rc = pass == 0   ? exp_cells_index(itmp, (const char *const *)sources, leaves,
                                                   M.size, err)
                     : pass == 1 ? exp_pvtu_index(itmp, tmp, (const char *const *)sources,
                                                  M.size, err)
                                 : exp_phtg_index(itmp, tmp, (const char *const *)sources,
                                                  M.size, err);
            for (int r = 0; r < M.size; r++)
                free(sources[r]), sources[r] = NULL;
        }
        if (rc && !err->msg[0])
            ivoct_error_set(err, "out of memory");
    }
    free(sources);
    if (rc)
        io_group_rename_error(g, err);
    return rc ? -1 : 0;
}

/* Rank 0: the index of the .ivo pieces (--save F.pivo), from every rank's
 * leaves and checksum, into g. */
static int write_save_index(const char *index, const uint64_t *leaves, const uint64_t *sums,
                            io_group_t *g, ivoct_error_t *err)
{
    char **sources = calloc((size_t)M.size, sizeof *sources);
    int rc = !sources;
    for (int r = 0; r < M.size && !rc; r++)
        rc = !(sources[r] = piece_name(index, r, ".ivo", 0));
    if (rc)
        ivoct_error_set(err, "out of memory");
    const char *itmp;
    if (!rc)
        rc = io_group_reserve(g, index, &itmp, err) ||
             oct_save_index(itmp, (const char *const *)sources, leaves, sums, M.size, err);
    for (int r = 0; sources && r < M.size; r++)
        free(sources[r]);
    free(sources);
    if (rc)
        io_group_rename_error(g, err);
    return rc ? -1 : 0;
}

/* ---- the command --------------------------------------------------------------------------- */

int cli_mpi_build(const build_job_t *job, bool quiet)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    /* the ranks that failed before this (the options, the scene) meet the
       others here */
    int agreed = cli_mpi_agree(EXIT_OK);
    if (agreed)
        return agreed;
    const scene_t *s = job->scene;
    const int N = M.size;
    double t0 = MPI_Wtime();
    oct_params_t p = job->params;
    if (M.rank > 0)
        p.progress = NULL;
    cli_test_pause("build");
    oct_plan_t *plan = NULL, *mine = NULL;
    oct_tree_t *tree = NULL, *part = NULL;
    uint64_t *weight = NULL;
    frontier_t front = {0, 0, NULL};
    share_t share = {PTHREAD_MUTEX_INITIALIZER, NULL, NULL, NULL, 0, NULL, 0};
    int rc = oct_plan_new(s->tape, s->box, &p, &plan, &err) ? EXIT_RUNTIME : EXIT_OK;
    if ((rc = cli_mpi_agree(rc ? (fprintf(stderr, "ivoct build: %s\n", err.msg), rc) : rc)))
        goto out;
    size_t n = oct_plan_subtrees(plan);
    int threads = p.threads > 0 ? p.threads : omp_get_num_procs();
    weight = malloc((n + 1) * sizeof *weight);
    if (is_index(job->ex.htg, ".phtg")) /* the same on every rank: the top is */
        front = (frontier_t){oct_plan_subtree_depth(plan), n, malloc((n + 1) * sizeof *front.code)};
    if (!weight || (is_index(job->ex.htg, ".phtg") && !front.code))
        MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME); /* the others are in a collective */
    for (size_t i = 0; front.code && i < n; i++)
        front.code[i] = oct_plan_subtree_code(plan, i);
    int coarse_depth = 0;
    if (coarse_weights(job, plan, weight, &coarse_depth, &err)) {
        rc = EXIT_RUNTIME;
        goto out;
    }

    /* N ranges of equal weight, in Morton order: subtree i goes to the rank
       whose share holds the weight before it */
    uint64_t total = 0, before = 0;
    for (size_t i = 0; i < n; i++)
        total += weight[i];
    share.next = calloc((size_t)N, sizeof *share.next);
    share.end = calloc((size_t)N, sizeof *share.end);
    share.shared = calloc((size_t)N, sizeof *share.shared);
    share.weight = weight;
    if (!share.next || !share.end || !share.shared)
        MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME);
    for (size_t i = 0, r = 0; i < n; i++) {
        while (r + 1 < (size_t)N && (double)before >= (double)total * (double)(r + 1) / N)
            share.end[r] = i, share.next[++r] = i;
        before += weight[i];
        share.end[r] = i + 1;
    }
    for (int r = 1; r < N; r++)
        if (share.next[r] < share.end[r - 1])
            share.next[r] = share.end[r] = share.end[r - 1]; /* empty ranges stay in order */
    /* without a thread for the requests, each rank builds its own range */
    int sharing = M.threaded && N > 1;
    pthread_t server;
    int serving = sharing && M.rank == 0 && pthread_create(&server, NULL, share_serve, &share) == 0;
    if (sharing && M.rank == 0 && !serving)
        MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME);
    if (!sharing) /* this rank's range alone */
        for (int r = 0; r < N; r++)
            if (r != M.rank)
                share.next[r] = share.end[r];
    int failed = 0;
    size_t *which = malloc((n + 1) * sizeof *which);
    if (!which)
        failed = 1, ivoct_error_set(&err, "out of memory");
    for (;;) {
        size_t a, b;
        if (!sharing) {
            share_next(&share, M.rank, threads, &a, &b);
            if (failed)
                a = b;
        } else {
            next_chunk(&share, threads, failed, &a, &b);
        }
        if (a == b)
            break;
        for (size_t i = a; i < b; i++)
            which[i - a] = i;
        if (!failed && oct_plan_build(plan, which, b - a, &err))
            failed = 1;
    }
    free(which);
    if (serving)
        pthread_join(server, NULL);
    double build_time = MPI_Wtime() - t0;
    if ((rc = cli_mpi_agree(failed ? (fprintf(stderr, "ivoct build: %s\n", err.msg), EXIT_RUNTIME)
                                   : EXIT_OK)))
        goto out;

    /* what this rank built, for the per-rank figures */
    oct_stats_t built;
    memset(&built, 0, sizeof built);
    uint64_t count = 0, sub_nodes = 0;
    for (size_t i = 0; i < n; i++) {
        oct_subtree_t st;
        if (!oct_plan_get(plan, i, &st)) {
            oct_stats_add(&built, &st.stats);
            count++, sub_nodes += st.n_nodes;
        }
    }

    /* gather: the outputs that are one file, written on rank 0 */
    const int save_pieces = is_index(job->save, ".pivo");
    int pieces = is_index(job->cells, ".pcsv") || is_index(job->ex.vtu, ".pvtu") ||
                 is_index(job->ex.htg, ".phtg") || save_pieces;
    build_job_t single = *job;
    if (is_index(job->cells, ".pcsv"))
        single.cells = NULL;
    if (is_index(job->ex.vtu, ".pvtu"))
        single.ex.vtu = NULL;
    if (is_index(job->ex.htg, ".phtg"))
        single.ex.htg = NULL;
    if (save_pieces)
        single.save = NULL;
    single.stats = NULL;
    int gather = single.cells || single.save || single.ex.vtu || single.ex.htg || single.ex.vdb ||
                 single.ex.mesh;
    uint64_t gather_bytes = 0;
    MPI_Datatype leaf_t, slab_t;
    MPI_Type_contiguous((int)sizeof(oct_leaf_t), MPI_BYTE, &leaf_t);
    MPI_Type_contiguous((int)sizeof(oct_slab_t), MPI_BYTE, &slab_t);
    MPI_Type_commit(&leaf_t);
    MPI_Type_commit(&slab_t);
    rc = EXIT_OK;
    if (gather && M.rank == 0 && pieces) {
        /* rank 0's own part, in a plan of its own: the gather takes the first */
        if (oct_plan_new(s->tape, s->box, &p, &mine, &err))
            rc = EXIT_RUNTIME;
        for (size_t i = 0; i < n && !rc; i++) {
            oct_subtree_t st;
            if (!oct_plan_get(plan, i, &st) && oct_plan_put(mine, i, &st, &err))
                rc = EXIT_RUNTIME;
        }
    }
    if (gather && M.rank > 0) {
        gather_bytes = send_subtrees(plan, leaf_t, slab_t);
    } else if (gather) {
        for (int r = 1; r < N; r++)
            if (receive_subtrees(plan, r, leaf_t, slab_t, &err) && !rc)
                rc = EXIT_RUNTIME;
        if (!rc && oct_plan_finish(plan, 0, &tree, &err))
            rc = EXIT_RUNTIME;
    }
    MPI_Type_free(&leaf_t);
    MPI_Type_free(&slab_t);
    /* this rank's part: for its pieces, or for the counts when nothing is gathered */
    if (!rc && (pieces || !gather)) {
        oct_plan_t *from = mine ? mine : plan;
        unsigned flags = OCT_PLAN_PART | (M.rank > 0 ? OCT_PLAN_NO_TOP : 0u);
        if (oct_plan_finish(from, flags, &part, &err))
            rc = EXIT_RUNTIME;
    }
    /* --certain: a leaf's witnesses depend on the leaf alone (its box and its
       pruned tape, octree/README.md), so each rank certifies its part, leaf
       for leaf as the single build would, and rank 0 the gathered tree */
    if (!rc && job->certain &&
        ((part && oct_certify(part, s->tape, threads, &err)) ||
         (tree && oct_certify(tree, s->tape, threads, &err))))
        rc = EXIT_RUNTIME;
    if ((rc = cli_mpi_agree(rc ? (fprintf(stderr, "ivoct build: %s\n", err.msg), rc) : rc)))
        goto out;

    /* the figures of every rank, on rank 0 */
    mpi_figures_t fig = {N, (int)n, oct_plan_subtree_depth(plan), coarse_depth, sharing,
                         NULL, NULL, NULL, NULL, 0, 0, share.requests};
    fig.time_s = calloc((size_t)N, sizeof *fig.time_s);
    fig.cells = calloc((size_t)N, sizeof *fig.cells);
    fig.count = calloc((size_t)N, sizeof *fig.count);
    fig.shared = calloc((size_t)N, sizeof *fig.shared);
    uint64_t *piece_leaves = calloc((size_t)N, sizeof *piece_leaves);
    if (!fig.time_s || !fig.cells || !fig.count || !fig.shared || !piece_leaves)
        MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME);
    uint64_t my_leaves = part ? part->n_leaves : 0;
    MPI_Gather(&build_time, 1, MPI_DOUBLE, fig.time_s, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    MPI_Gather(&built.cells_visited, 1, MPI_UINT64_T, fig.cells, 1, MPI_UINT64_T, 0,
               MPI_COMM_WORLD);
    MPI_Gather(&count, 1, MPI_UINT64_T, fig.count, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    MPI_Gather(&my_leaves, 1, MPI_UINT64_T, piece_leaves, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    MPI_Reduce(&gather_bytes, &fig.gather_bytes, 1, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
    if (M.rank == 0)
        memcpy(fig.shared, share.shared, (size_t)N * sizeof *fig.shared);
    /* the counts of the whole tree: the gathered one's, or every part's added up */
    oct_tree_t sum;
    memset(&sum, 0, sizeof sum);
    {
        oct_stats_t part_stats = built;
        uint64_t all_sub_nodes = 0, all_threads = 0, my_threads = (uint64_t)threads;
        size_t peak = part ? part->stats.peak_bytes : (tree ? tree->stats.peak_bytes : 0);
        unsigned long long peak_ull = peak, max_peak = 0;
        if (M.rank == 0 && part)
            part_stats = part->stats; /* built + the top's counts */
        if (part) /* --certain */
            part_stats.leaves_certain = part->stats.leaves_certain,
            part_stats.certain_time_s = part->stats.certain_time_s;
        reduce_stats(&part_stats, &sum.stats);
        MPI_Reduce(&sub_nodes, &all_sub_nodes, 1, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
        MPI_Reduce(&my_threads, &all_threads, 1, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
        MPI_Reduce(&peak_ull, &max_peak, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, 0, MPI_COMM_WORLD);
        if (M.rank == 0) {
            if (tree) {
                sum = *tree; /* exact: the single build's counts */
            } else {
                uint64_t top_nodes = part->n_nodes - sub_nodes;
                sum.n_nodes = (uint32_t)(top_nodes + all_sub_nodes);
                uint64_t l = 0;
                for (int r = 0; r < N; r++)
                    l += piece_leaves[r];
                sum.n_leaves = (uint32_t)l;
                sum.depth = p.depth;
                sum.tests = p.tests;
                memcpy(sum.box, s->box, sizeof sum.box);
            }
            double tmax;
            fig.balance = balance_of(fig.time_s, N, &tmax, NULL);
            sum.stats.time_s = tmax;
            sum.stats.threads = (int)all_threads;
            sum.stats.peak_bytes = (size_t)max_peak;
        }
    }

    /* every rank writes its files to temporary names; they are renamed only
       once every rank has all of its own */
    io_group_t g = IO_GROUP_INIT;
    rc = EXIT_OK;
    uint64_t save_sum = 0;
    if (pieces && write_pieces(job, part, piece_leaves, &front, &save_sum, &g, &err))
        rc = EXIT_RUNTIME;
    if (save_pieces) {
        /* every rank, written or not: the index names each piece's checksum */
        uint64_t *sums = calloc((size_t)N, sizeof *sums);
        if (!sums)
            MPI_Abort(MPI_COMM_WORLD, EXIT_RUNTIME);
        MPI_Gather(&save_sum, 1, MPI_UINT64_T, sums, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
        if (!rc && M.rank == 0 && write_save_index(job->save, piece_leaves, sums, &g, &err))
            rc = EXIT_RUNTIME;
        free(sums);
    }
    if (!rc && M.rank == 0) {
        build_stats_extra_t extra = {write_mpi_stats, &fig};
        build_job_t rest = single;
        rest.stats = job->stats;
        /* nothing of one file but the stats and the certified mesh, which need
         * no tree (the mesh builds its own subdivision from the tape) */
        if (!tree)
            rest.cells = rest.save = NULL,
            rest.ex = (exports_t){.mesh_certified = single.ex.mesh_certified,
                                  .mesh_min_depth = single.ex.mesh_min_depth};
        rc = build_write_outputs(&rest, &sum, &g, &extra, NULL, &err);
    }
    if ((rc = cli_mpi_agree(rc ? (fprintf(stderr, "ivoct build: %s\n", err.msg), rc) : rc))) {
        io_group_abort(&g);
    } else {
        cli_test_pause("commit");
        /* the destinations, to take back if another rank's rename fails */
        size_t nd = g.n;
        char **dest = calloc(nd + 1, sizeof *dest);
        for (size_t i = 0; dest && i < nd; i++)
            dest[i] = strdup(g.files[i].path);
        rc = io_group_commit(&g, &err) ? EXIT_RUNTIME : EXIT_OK;
        if (rc)
            fprintf(stderr, "ivoct build: %s\n", err.msg);
        rc = cli_mpi_agree(rc);
        if (rc && dest)
            for (size_t i = 0; i < nd; i++)
                if (dest[i])
                    unlink(dest[i]);
        for (size_t i = 0; dest && i < nd; i++)
            free(dest[i]);
        free(dest);
    }
    if (rc == EXIT_OK && M.rank == 0 && !quiet) {
        char names[64];
        printf("%s: depth %d, tests %s: %u surface leaves, %llu cells visited, %.3f s, %d "
               "ranks, %d threads, balance %.2f\n",
               s->source.name, p.depth, oct_tests_format(p.tests, names, sizeof names),
               sum.n_leaves, (unsigned long long)sum.stats.cells_visited, sum.stats.time_s, N,
               sum.stats.threads, fig.balance);
    }
    free(fig.time_s), free(fig.cells), free(fig.count), free(fig.shared), free(piece_leaves);
out:
    free(share.next), free(share.end), free(share.shared);
    free(weight);
    free(front.code);
    oct_free(tree);
    oct_free(part);
    oct_plan_free(plan);
    oct_plan_free(mine);
    return rc;
}

/* ---- the render over MPI (cmd_render.c) ----------------------------------------------- */

/* The pixels of the largest of `parts` parts. */
static size_t largest_part(int width, int height, int parts)
{
    size_t most = 0;
    for (int p = 0; p < parts; p++) {
        size_t n = ray_part_pixels(width, height, p, parts);
        most = n > most ? n : most;
    }
    return most;
}

double cli_mpi_render_buffer_bytes(int width, int height, int parts, int what)
{
    return (double)largest_part(width, height, parts) * (double)ray_pack_bytes((ray_pack_t)what);
}

int cli_mpi_render_start(cli_mpi_render_t *r, int width, int height, int frames, int gather,
                         int what, ivoct_error_t *err)
{
    memset(r, 0, sizeof *r);
    r->ranks = M.size;
    r->parts = frames < M.size ? M.size : 1;
    r->gather = gather && r->parts > 1;
    r->what = what;
    r->rank_time_s = calloc((size_t)M.size, sizeof *r->rank_time_s);
    r->rank_rays = calloc((size_t)M.size, sizeof *r->rank_rays);
    r->rank_tape_evals = calloc((size_t)M.size, sizeof *r->rank_tape_evals);
    size_t most = r->gather ? largest_part(width, height, r->parts) : 0;
    if (most > INT_MAX) {
        ivoct_error_set(err, "a part of the %dx%d image has %zu pixels: more than the %d "
                             "that one message carries (use more ranks)",
                        width, height, most, INT_MAX);
        return -1;
    }
    r->buf = most ? malloc(most * ray_pack_bytes((ray_pack_t)what)) : NULL;
    if (!r->rank_time_s || !r->rank_rays || !r->rank_tape_evals || (most && !r->buf)) {
        ivoct_error_set(err, "out of memory for the gather of the image");
        return -1;
    }
    return 0;
}

void cli_mpi_render_gather(cli_mpi_render_t *r, ray_image_t *img)
{
    double t0 = MPI_Wtime();
    const ray_pack_t what = (ray_pack_t)r->what;
    const size_t bytes = ray_pack_bytes(what);
    MPI_Datatype pixel;
    MPI_Type_contiguous((int)bytes, MPI_BYTE, &pixel);
    MPI_Type_commit(&pixel);
    if (M.rank > 0) {
        size_t n = ray_part_pixels(img->width, img->height, M.rank, r->parts);
        ray_image_pack(img, M.rank, r->parts, what, r->buf);
        MPI_Send(r->buf, (int)n, pixel, 0, TAG_PART, MPI_COMM_WORLD);
        r->gather_bytes += n * bytes;
    } else {
        /* one part at a time, in rank order: one buffer on rank 0 */
        for (int q = 1; q < r->parts; q++) {
            size_t n = ray_part_pixels(img->width, img->height, q, r->parts);
            MPI_Recv(r->buf, (int)n, pixel, q, TAG_PART, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            ray_image_unpack(img, q, r->parts, what, r->buf);
        }
    }
    MPI_Type_free(&pixel);
    r->gather_time_s += MPI_Wtime() - t0;
}

void cli_mpi_render_reduce(cli_mpi_render_t *r, ray_stats_t *total)
{
    double mine = total->time_s;
    MPI_Gather(&mine, 1, MPI_DOUBLE, r->rank_time_s, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    MPI_Gather(&total->rays, 1, MPI_UINT64_T, r->rank_rays, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    MPI_Gather(&total->tape_evals, 1, MPI_UINT64_T, r->rank_tape_evals, 1, MPI_UINT64_T, 0,
               MPI_COMM_WORLD);
    uint64_t sent = r->gather_bytes;
    MPI_Reduce(&sent, &r->gather_bytes, 1, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
    uint64_t *counts[] = {&total->rays, &total->hits, &total->tangent_hits, &total->tape_evals,
                          &total->segments, &total->leaves, &total->shadow_rays,
                          &total->shadowed, &total->shadow_undecided, &total->shadow_evals,
                          &total->beams, &total->rays_decided_by_beam};
    for (size_t i = 0; i < sizeof counts / sizeof *counts; i++)
        *counts[i] = cli_mpi_sum_u64(*counts[i]);
    total->threads = (int)cli_mpi_sum_u64((uint64_t)total->threads);
    if (M.rank == 0) {
        double tmax, tsum;
        r->balance = balance_of(r->rank_time_s, r->ranks, &tmax, &tsum);
        /* split: the slowest rank's render, as the build's time_s; frames
           dealt: the sum over the frames, as in one process */
        total->time_s = r->parts > 1 ? tmax : tsum;
    }
}

void cli_mpi_render_stats(FILE *f, void *user)
{
    const cli_mpi_render_t *r = user;
    fprintf(f,
            ",\n  \"mpi\": {\"ranks\": %d, \"split\": \"%s\", \"tile\": %d, \"gathered\": \"%s\","
            "\n    \"rank_time_s\": ",
            r->ranks, r->parts > 1 ? "tiles" : "whole_frames", RAY_TILE,
            !r->gather ? "none" : r->what == RAY_PACK_RGB ? "rgb" : "all");
    json_doubles(f, r->rank_time_s, r->ranks);
    json_key_u64s(f, "rank_rays", r->rank_rays, r->ranks);
    json_key_u64s(f, "rank_tape_evals", r->rank_tape_evals, r->ranks);
    fputs(",\n    \"balance\": ", f);
    cli_json_double(f, r->balance);
    fprintf(f, ", \"gather_bytes\": %llu, \"gather_time_s\": ",
            (unsigned long long)r->gather_bytes);
    cli_json_double(f, r->gather_time_s);
    fputc('}', f);
}

void cli_mpi_render_end(cli_mpi_render_t *r)
{
    free(r->buf);
    free(r->rank_time_s);
    free(r->rank_rays);
    free(r->rank_tape_evals);
    memset(r, 0, sizeof *r);
}
