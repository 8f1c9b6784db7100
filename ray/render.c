/* ivoct ray — the render loop: tiles over OpenMP, one primary ray per pixel,
 * segments from an interval source, normals and shading. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <threads.h>

#include <omp.h>

#include "beam_internal.h"
#include "roots_internal.h"

#define TILE RAY_TILE

/* ---- the box source (--no-octree) ------------------------------------------------- */

typedef struct box_state {
    double t0, t1;
    int pending;
} box_state_t;

static void box_begin(const void *ctx, void *state, const double o[3], const double d[3])
{
    const ray_box_source_t *bs = ctx;
    box_state_t *st = state;
    st->pending = ray_clip_box(bs->box, o, d, &st->t0, &st->t1);
}

static int box_next(const void *ctx, void *state, ray_segment_t *seg, uint64_t *leaves)
{
    (void)ctx;
    (void)leaves;
    box_state_t *st = state;
    if (!st->pending)
        return 0;
    st->pending = 0;
    seg->t_in = st->t0;
    seg->t_out = st->t1;
    seg->tape = NULL;
    seg->leaf = -1;
    return 1;
}

ray_source_t ray_box_source(ray_box_source_t *bs, const double box[6])
{
    memcpy(bs->box, box, sizeof bs->box);
    ray_source_t s = {bs, sizeof(box_state_t), box_begin, box_next};
    return s;
}

/* ---- images ---------------------------------------------------------------------------- */

int ray_image_alloc(ray_image_t *img, int width, int height, ivoct_error_t *err)
{
    memset(img, 0, sizeof *img);
    if (width < 1 || height < 1 || width > RAY_MAX_SIZE || height > RAY_MAX_SIZE) {
        ivoct_error_set(err, "image size %dx%d out of range", width, height);
        return 1;
    }
    size_t n = (size_t)width * (size_t)height;
    img->width = width;
    img->height = height;
    img->t = malloc(n * sizeof *img->t);
    img->hit = malloc(n);
    img->kind = malloc(n);
    img->point = malloc(3 * n * sizeof *img->point);
    img->normal = malloc(3 * n * sizeof *img->normal);
    img->dir = malloc(3 * n * sizeof *img->dir);
    img->rgb = malloc(3 * n);
    img->shadow = calloc(n, 1);
    if (!img->t || !img->hit || !img->kind || !img->point || !img->normal || !img->dir ||
        !img->rgb || !img->shadow) {
        ray_image_free(img);
        ivoct_error_set(err, "out of memory for a %dx%d image", width, height);
        return 1;
    }
    return 0;
}

void ray_image_free(ray_image_t *img)
{
    free(img->t);
    free(img->hit);
    free(img->kind);
    free(img->point);
    free(img->normal);
    free(img->dir);
    free(img->rgb);
    free(img->shadow);
    memset(img, 0, sizeof *img);
}

/* ---- parts of an image ------------------------------------------------------------------- */

/* The pixels [c0, c1) x [r0, r1) of tile (tx, ty). */
static void tile_rect(int width, int height, int tx, int ty, int *c0, int *r0, int *c1, int *r1)
{
    *c0 = tx * TILE, *r0 = ty * TILE;
    *c1 = *c0 + TILE < width ? *c0 + TILE : width;
    *r1 = *r0 + TILE < height ? *r0 + TILE : height;
}

static int in_part(int tx, int ty, int part, int parts)
{
    return parts <= 1 || (tx + ty) % parts == part;
}

size_t ray_part_pixels(int width, int height, int part, int parts)
{
    size_t n = 0;
    for (int ty = 0; ty * TILE < height; ty++)
        for (int tx = 0; tx * TILE < width; tx++)
            if (in_part(tx, ty, part, parts)) {
                int c0, r0, c1, r1;
                tile_rect(width, height, tx, ty, &c0, &r0, &c1, &r1);
                n += (size_t)(c1 - c0) * (size_t)(r1 - r0);
            }
    return n;
}

size_t ray_pack_bytes(ray_pack_t what) { return what == RAY_PACK_RGB ? 3 : RAY_PIXEL_BYTES; }

/* One pixel's buffers to or from its packed bytes. */
static void pixel_pack(const ray_image_t *img, size_t i, ray_pack_t what, unsigned char *b)
{
    if (what == RAY_PACK_ALL) {
        memcpy(b, img->t + i, sizeof(double)), b += sizeof(double);
        memcpy(b, img->point + 3 * i, 3 * sizeof(double)), b += 3 * sizeof(double);
        memcpy(b, img->normal + 3 * i, 3 * sizeof(double)), b += 3 * sizeof(double);
        memcpy(b, img->dir + 3 * i, 3 * sizeof(double)), b += 3 * sizeof(double);
        *b++ = img->hit[i];
        *b++ = img->kind[i];
        *b++ = img->shadow[i];
    }
    memcpy(b, img->rgb + 3 * i, 3);
}

static void pixel_unpack(ray_image_t *img, size_t i, ray_pack_t what, const unsigned char *b)
{
    if (what == RAY_PACK_ALL) {
        memcpy(img->t + i, b, sizeof(double)), b += sizeof(double);
        memcpy(img->point + 3 * i, b, 3 * sizeof(double)), b += 3 * sizeof(double);
        memcpy(img->normal + 3 * i, b, 3 * sizeof(double)), b += 3 * sizeof(double);
        memcpy(img->dir + 3 * i, b, 3 * sizeof(double)), b += 3 * sizeof(double);
        img->hit[i] = *b++;
        img->kind[i] = *b++;
        img->shadow[i] = *b++;
    }
    memcpy(img->rgb + 3 * i, b, 3);
}

/* The pixels of a part in their order: packed from `from` into out, or
 * (from NULL) unpacked from in into `into`. */
static void part_copy(const ray_image_t *from, unsigned char *out, ray_image_t *into,
                      const unsigned char *in, int part, int parts, ray_pack_t what)
{
    const int W = from ? from->width : into->width, H = from ? from->height : into->height;
    const size_t step = ray_pack_bytes(what);
    for (int ty = 0; ty * TILE < H; ty++)
        for (int tx = 0; tx * TILE < W; tx++) {
            if (!in_part(tx, ty, part, parts))
                continue;
            int c0, r0, c1, r1;
            tile_rect(W, H, tx, ty, &c0, &r0, &c1, &r1);
            for (int row = r0; row < r1; row++)
                for (int col = c0; col < c1; col++) {
                    size_t i = (size_t)row * W + col;
                    if (from)
                        pixel_pack(from, i, what, out), out += step;
                    else
                        pixel_unpack(into, i, what, in), in += step;
                }
        }
}

void ray_image_pack(const ray_image_t *img, int part, int parts, ray_pack_t what,
                    unsigned char *buf)
{
    part_copy(img, buf, NULL, NULL, part, parts, what);
}

void ray_image_unpack(ray_image_t *img, int part, int parts, ray_pack_t what,
                      const unsigned char *buf)
{
    part_copy(NULL, NULL, img, buf, part, parts, what);
}

/* ---- shading ------------------------------------------------------------------------------ */

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The formula ray_srgb8 keeps to (ray.h). */
static unsigned char srgb8_pow(double c)
{
    c = c < 0 ? 0 : c > 1 ? 1 : c;
    return (unsigned char)(255.0 * pow(c, 1.0 / 2.2) + 0.5);
}

/* Where the formula steps: step[b] = ((b - 1/2) / 255)^2.2 for b = 1..255;
 * step[0] = -1 and step[256] = 2 bound the search (the formula clamps c to
 * [0, 1]).  A pixel's byte is the b with step[b] <= c < step[b + 1], found
 * in 8 comparisons; within 2^-30 (relative) of a step, far more than the
 * rounding of pow here and in the formula, the formula decides.  pow cost
 * more than the rest of a hit's shading. */
static double srgb_step[257];

/* The background's bytes, computed once: most pixels of an image are
 * misses. */
static const double background[3] = {0.012, 0.014, 0.02};
static unsigned char background_rgb[3];
static once_flag shade_once = ONCE_FLAG_INIT;

static void shade_init(void)
{
    srgb_step[0] = -1;
    for (int b = 1; b < 256; b++)
        srgb_step[b] = pow((b - 0.5) / 255.0, 2.2);
    srgb_step[256] = 2;
    for (int i = 0; i < 3; i++)
        background_rgb[i] = srgb8_pow(background[i]);
}

static int near_step(double c, double step) { return fabs(c - step) <= 0x1p-30 * step; }

/* ray_srgb8 once shade_init has run */
static unsigned char srgb8(double c)
{
    int b = 0;
    for (int h = 128; h > 0; h >>= 1)
        if (srgb_step[b + h] <= c)
            b += h;
    if (near_step(c, srgb_step[b]) || near_step(c, srgb_step[b + 1]))
        return srgb8_pow(c);
    return (unsigned char)b;
}

unsigned char ray_srgb8(double c)
{
    call_once(&shade_once, shade_init);
    return srgb8(c);
}

void ray_shade(const ray_camera_t *cam, const double *light, const double p[3],
               const double d[3], const double n[3], int hit, int shadowed,
               unsigned char rgb[3])
{
    /* the side ∇f points to (f increasing: "outside") warm, the other cool */
    static const double warm[3] = {0.92, 0.55, 0.22}, cool[3] = {0.25, 0.45, 0.85};
    call_once(&shade_once, shade_init);
    if (!hit) {
        memcpy(rgb, background_rgb, sizeof background_rgb);
        return;
    }
    /* the point light, else one above and to the left of the eye, fixed to
     * the camera */
    double L[3];
    for (int i = 0; i < 3; i++)
        L[i] = light ? light[i] - p[i] : -cam->fwd[i] + 0.7 * cam->vup[i] - 0.4 * cam->right[i];
    double ln = sqrt(dot3(L, L));
    double nd = dot3(n, d);
    const double *base = nd <= 0 ? warm : cool;
    /* two-sided: light the side facing the eye */
    double lambert = (nd <= 0 ? 1.0 : -1.0) * dot3(n, L) / ln;
    if (!(lambert > 0) || shadowed)
        lambert = 0;
    for (int i = 0; i < 3; i++)
        rgb[i] = srgb8(base[i] * (0.15 + 0.85 * lambert));
}

/* ∇f/|∇f| from a gradient enclosure at the hit point.  Where the enclosure
 * holds 0 in every component (a singular point, ∇f = 0, or an enclosure too
 * wide to tell) or the midpoint is not a usable direction, the normal faces
 * the eye: -d. */
static void normal_from(const iv_grad_t *g, const double d[3], double n[3])
{
    const iv_t c[3] = {g->dx, g->dy, g->dz};
    int all_zero = 1;
    for (int i = 0; i < 3; i++) {
        n[i] = iv_mid(c[i]);
        if (!iv_contains(c[i], 0.0))
            all_zero = 0;
    }
    double len = sqrt(dot3(n, n));
    if (all_zero || !(len > 0) || !isfinite(len)) {
        for (int i = 0; i < 3; i++)
            n[i] = -d[i];
        return;
    }
    for (int i = 0; i < 3; i++)
        n[i] /= len;
}

/* ---- the loop ------------------------------------------------------------------------------ */

void ray_render_opts_default(ray_render_opts_t *o)
{
    memset(o, 0, sizeof *o);
    o->method = RAY_NEWTON_AH;
    ray_opts_default(&o->roots);
}

typedef struct counters {
    uint64_t hits, tangent, evals, segments, leaves;
    uint64_t shadow_rays, shadowed, shadow_undecided, shadow_evals;
    uint64_t beams, rays_decided;
} counters_t;

double ray_shadow_origin(const double eye[3], const double d[3], double t, double q[3])
{
    double tq = t - 0x1p-20 * t;
    ray_point(eye, d, tq, q);
    return tq;
}

/* The first hit along one ray.  Every segment is searched up to the best hit
 * so far and the smaller hit kept, so the first root wins whatever order the
 * segments come in (see ray.h); front to back, t_max cuts off all but the
 * segments that overlap the hit by rounding.  A primary ray's segment is
 * searched as soon as it comes: while a segment waits for a second one to
 * share its first pass (ray_find_root_n), the walk goes on past the hit it
 * may hold, and with slabs the next segment may be far (measured: the
 * packet walk's own work 2.3x on the sphere).  A shadow ray's segments wait
 * in twos, the first one growing into a run (tracer_offer), unless the
 * octree's slabs narrow them (tracer_batch).  Those after the one with the
 * hit, if they start before it, are searched again up to it.
 *
 * A tracer is that search in progress, fed one segment at a time: trace()
 * pulls the segments from a source, a packet walk (traverse.c) pushes them,
 * and the searches are the same either way.
 *
 * A primary ray's tracer may set the refinement of its first hit aside
 * (job: see ray_find_root_defer) for trace_rays to run with those of the
 * other rays of the tile, side by side (refine_batch).  Until then the hit
 * is known to lie in [t_lo, t_hi] and t_max is t_hi, and the segments of
 * the search stay waiting: which of them are searched again depends on the
 * hit.  A segment offered meanwhile is dropped when it starts at or after
 * t_hi, as it would be after the hit; else (it overlaps the hit's segment by
 * rounding) it waits too, up to LATE_MAX of them, a further one has the
 * refinement run at once.  Once the hit is known (tracer_settle) the
 * segments waiting go on as they would have gone, and those offered
 * meanwhile are offered again.  So every search, hit and count but the
 * leaves the walk yields up to t_hi is what it would be with the refinement
 * run at once. */
#define BATCH 2 /* at most; tracer_batch says how many */
#define LATE_MAX 4
typedef struct tracer {
    const tape_t *tape;
    tape_ws_t *ws;
    const ray_render_opts_t *opts;
    const double *eye, *d;
    int any;             /* the first hit found ends the search */
    int batch;           /* the segments searched together (tracer_batch) */
    int stop;            /* it has */
    double t_max;        /* the best hit so far */
    int nq;              /* segments waiting */
    ray_segment_t q[BATCH];
    ray_result_t best;
    counters_t *cnt;
    int pending;         /* the refinement of the first hit is set aside, in job
                          * (a primary ray's only: not with `any`) */
    refine_job_t job;
    int ns;              /* the segments of its search, as searched */
    double s0[BATCH], s1[BATCH];
    int nlate;           /* segments offered meanwhile, offered again once settled */
    ray_segment_t late[LATE_MAX];
} tracer_t;

/* How many segments from src a tracer searches together: a primary ray's
 * one at a time; a shadow ray's two, the first grown into a run while it
 * waits, but one at a time where the octree's slabs narrow them: their gaps
 * keep runs short, and the walk goes on past a root while a segment waits
 * (callgrind, mitchell with a light, 300x300: one at a time 1-8 % fewer
 * instructions with slabs, 9-20 % more without). */
static int tracer_batch(const ray_source_t *src, int any)
{
    const ray_octree_source_t *os = ray_source_octree(src);
    int slabs = os && os->use_slabs && os->tree && os->tree->slabs;
    return any && !slabs ? BATCH : 1;
}

/* The roots wanted are those before t_end (INFINITY for a primary ray, 1 for
 * a shadow ray: the light); with `any` the first hit found ends the search
 * (a shadow ray asks whether there is a root, not where the first one is). */
static void tracer_init(tracer_t *tr, const tape_t *tape, tape_ws_t *ws,
                        const ray_render_opts_t *opts, const double eye[3], const double d[3],
                        double t_end, int any, int batch, counters_t *cnt)
{
    memset(tr, 0, sizeof *tr);
    tr->tape = tape;
    tr->ws = ws;
    tr->opts = opts;
    tr->eye = eye;
    tr->d = d;
    tr->any = any;
    tr->batch = batch;
    tr->t_max = t_end;
    tr->best = (ray_result_t){RAY_MISS, NAN, NAN, NAN, 0, 0};
    tr->cnt = cnt;
}

/* Keep the segments waiting from q[from] on that can still start before
 * the best hit. */
static void tracer_keep(tracer_t *tr, int from)
{
    int m = 0;
    for (int j = from; j < tr->nq; j++)
        if (tr->q[j].t_in < tr->t_max)
            tr->q[m++] = tr->q[j];
    tr->nq = m;
}

/* The refinement set aside has been run (job.out = &best): the hit is
 * known, and the segments after the one that holds it are searched again up
 * to it. */
static void tracer_offer(tracer_t *tr, const ray_segment_t *seg);

static void tracer_settle(tracer_t *tr)
{
    tr->pending = 0;
    tr->t_max = tr->best.t;
    tracer_keep(tr, ray_segment_of(tr->best.t_lo, tr->ns, tr->s0, tr->s1) + 1);
    int late = tr->nlate;
    tr->nlate = 0;
    for (int j = 0; j < late; j++)
        tracer_offer(tr, &tr->late[j]);
}

/* Run the refinement set aside now. */
static void tracer_resolve(tracer_t *tr)
{
    refine_job_t *job = &tr->job;
    job->out = &tr->best;
    tr->cnt->evals += refine_batch(&job, 1, tr->ws);
    tracer_settle(tr);
}

/* Search the leading segments waiting that share a tape (a batch shares one). */
static void tracer_search(tracer_t *tr)
{
    ray_segment_t *q = tr->q;
    int k = 1;
    while (k < tr->nq && q[k].tape == q[0].tape)
        k++;
    double t0[BATCH], t1[BATCH];
    for (int j = 0; j < k; j++) {
        t0[j] = q[j].t_in;
        t1[j] = q[j].t_out < tr->t_max ? q[j].t_out : tr->t_max;
    }
    ray_result_t r;
    int which, deferred;
    tr->cnt->segments += (uint64_t)k;
    /* (set aside only as the first hit: a second one is compared by its t) */
    ray_find_root_defer(q[0].tape ? q[0].tape : tr->tape, tr->ws, tr->opts->method,
                        &tr->opts->roots, tr->eye, tr->d, k, t0, t1, &r, &which,
                        !tr->any && tr->best.kind == RAY_MISS ? &tr->job : NULL, &deferred);
    tr->cnt->evals += r.evals;
    int done = k;
    if (r.kind != RAY_MISS && (tr->best.kind == RAY_MISS || r.t < tr->best.t)) {
        /* the first root is at or after the smaller bracket start */
        if (tr->best.kind != RAY_MISS && tr->best.t_lo < r.t_lo)
            r.t_lo = tr->best.t_lo;
        tr->best = r;
        tr->t_max = r.t;
        if (tr->any) {
            tr->stop = 1;
            return;
        }
        if (deferred) { /* the batch waits for the hit (tracer_settle) */
            tr->pending = 1;
            tr->ns = k;
            memcpy(tr->s0, t0, sizeof t0);
            memcpy(tr->s1, t1, sizeof t1);
            return;
        }
        done = which + 1; /* those after it: searched again, up to the hit */
    }
    /* keep what is left of the batch and was not searched */
    tracer_keep(tr, done);
}

/* The next segment of the ray, front to back: searched once batch wait.
 *
 * A ray that asks only whether there is a root (any: a shadow ray), and
 * whose segments wait in twos (tracer_batch: no slabs), searches a run of
 * segments as one: the search of [t_in, t_out] of the run proves a
 * root only where f has one, and misses none, whatever lies between its
 * leaves.  Most of a lit shadow ray's run hugs the surface near q, where f
 * along the ray is monotone: one pass over the run excludes it, where one
 * per leaf did.  A segment joins the run when it has the run's tape and
 * starts where the run ends or, with the scene's own tape (equal to f
 * everywhere), after a gap no longer than the run: longer gaps widen the
 * run's enclosures more than they save.  (A pruned leaf tape equals f on
 * its leaf only: its runs stay contiguous.)  Primary rays keep their
 * segments: their search must place the first root, and bisects a run again
 * (measured: 0–8 % more instructions on the sphere and McMullen's K3). */
static void tracer_offer(tracer_t *tr, const ray_segment_t *seg)
{
    if (tr->stop || !(seg->t_in < tr->t_max))
        return;
    if (tr->pending) {
        if (tr->nlate < LATE_MAX) {
            tr->late[tr->nlate++] = *seg;
            return;
        }
        tracer_resolve(tr);
        if (!(seg->t_in < tr->t_max))
            return;
    }
    ray_segment_t *run = tr->nq > 0 ? &tr->q[tr->nq - 1] : NULL;
    if (tr->any && run && seg->tape == run->tape &&
        (seg->t_in <= run->t_out ||
         (!seg->tape && seg->t_in - run->t_out <= run->t_out - run->t_in))) {
        if (seg->t_out > run->t_out)
            run->t_out = seg->t_out;
        return;
    }
    tr->q[tr->nq++] = *seg;
    while (tr->nq >= tr->batch && !tr->stop && !tr->pending)
        tracer_search(tr);
}

/* No segment is left: search those waiting (not while the refinement of
 * the hit is set aside: they wait for it). */
static void tracer_finish(tracer_t *tr)
{
    while (tr->nq > 0 && !tr->stop && !tr->pending)
        tracer_search(tr);
}

/* The hit of one ray into *best.  Without `any` the refinement of the hit
 * may be set aside: returns 1 when it was, the tracer in *hold (to be
 * settled and finished; hold may be NULL with `any`). */
static int trace(const tape_t *tape, tape_ws_t *ws, const ray_source_t *src, void *state,
                 const ray_render_opts_t *opts, const double eye[3], const double d[3],
                 double t_end, int any, ray_result_t *best, tracer_t *hold, counters_t *cnt)
{
    tracer_t tr;
    tracer_init(&tr, tape, ws, opts, eye, d, t_end, any, tracer_batch(src, any), cnt);
    ray_segment_t seg;
    src->begin(src->ctx, state, eye, d);
    while (!tr.stop) {
        seg.t_max = tr.t_max;
        if (!src->next(src->ctx, state, &seg, &cnt->leaves))
            break;
        tracer_offer(&tr, &seg);
    }
    tracer_finish(&tr);
    *best = tr.best;
    if (tr.pending)
        *hold = tr;
    return tr.pending;
}

/* The piece of a shadow ray just before q that render_tile searches first
 * (o = p0, t in [0, w]), for a root (opts->roots.any_root).  With the scene's
 * own tape on every leaf (the octree without leaf tapes), the piece goes
 * through the box source of the tree's box, one segment, instead of the walk
 * down to its leaf: the tape equals f everywhere, so the search proves a root
 * only where f has one, and the piece is so short (2^-16 t) that it nearly
 * always lies in q's leaf, whose segment the walk would have yielded.  Else
 * (leaf tapes, other sources) the walk finds the leaves and their tapes. */
static void attached_piece(const tape_t *tape, tape_ws_t *ws, const ray_source_t *src,
                           void *state, const ray_render_opts_t *opts, const double p0[3],
                           const double d[3], double w, ray_result_t *res, counters_t *cnt)
{
    const ray_octree_source_t *os = ray_source_octree(src);
    if (os && os->tree && !os->tapes) {
        ray_box_source_t bs;
        box_state_t bst;
        ray_source_t box = ray_box_source(&bs, os->tree->box);
        trace(tape, ws, &box, &bst, opts, p0, d, w, 1, res, NULL, cnt);
    } else {
        trace(tape, ws, src, state, opts, p0, d, w, 1, res, NULL, cnt);
    }
}

/* ---- packets --------------------------------------------------------------------------
 * Rays from one origin that the octree source would walk one by one go down
 * the tree in packets of one sign of direction (ray_packet_walk), each ray's
 * tracer fed the segments its own walk would have yielded; a ray that cannot
 * join one (ray_packet_ray) walks alone.  The hits are those of trace(). */
typedef struct packet {
    tracer_t tr[RAY_PACKET];
    double t_max[RAY_PACKET];
} packet_t;

static void packet_leaf(void *ctx, int r, const ray_segment_t *seg)
{
    packet_t *p = ctx;
    tracer_offer(&p->tr[r], seg);
    p->t_max[r] = p->tr[r].stop ? -INFINITY : p->tr[r].t_max;
}

/* The rays o + t·dir[j], t < t_end, j < n (at most TILE * TILE), each to
 * res[j]: with pw, packets of up to RAY_PACKET rays of one mask, taken in
 * the order of the list (a ray joins the first packet of its mask started
 * within the next 2 RAY_PACKET rays); without, trace() one by one.  Order
 * the list so that neighbours are near each other.  The refinements of the
 * first hits (not with `any`) are set aside and run side by side at the
 * end: the rays of a tile share the evaluator's passes. */
static void trace_rays(const tape_t *tape, tape_ws_t *ws, const ray_source_t *src, void *state,
                       const ray_octree_source_t *os, ray_packet_ws_t *pw,
                       const ray_render_opts_t *opts, const double o[3], int n,
                       const double **dir, double t_end, int any, ray_result_t **res,
                       counters_t *cnt)
{
    enum { DONE = 8 }; /* not a mask: the ray walked alone, or is in a packet */
    unsigned char mask[TILE * TILE];
    tracer_t held[TILE * TILE]; /* the rays whose refinement is set aside */
    int held_at[TILE * TILE], nh = 0;
    for (int j = 0; j < n; j++) {
        unsigned m;
        mask[j] = pw && ray_packet_ray(o, dir[j], &m) ? (unsigned char)m : DONE;
        if (mask[j] == DONE &&
            trace(tape, ws, src, state, opts, o, dir[j], t_end, any, res[j], &held[nh], cnt))
            held_at[nh++] = j;
    }
    for (int j = 0; j < n; j++) {
        if (mask[j] == DONE)
            continue;
        packet_t p;
        double d[RAY_PACKET][3];
        int at[RAY_PACKET], m = 0, batch = tracer_batch(src, any);
        const unsigned char mj = mask[j];
        for (int i = j; i < n && i < j + 2 * RAY_PACKET && m < RAY_PACKET; i++) {
            if (mask[i] != mj)
                continue;
            memcpy(d[m], dir[i], sizeof d[m]);
            tracer_init(&p.tr[m], tape, ws, opts, o, dir[i], t_end, any, batch, cnt);
            p.t_max[m] = t_end;
            at[m++] = i;
            mask[i] = DONE;
        }
        ray_packet_walk(os, pw, o, m, (const double(*)[3])d, p.t_max, packet_leaf, &p,
                        &cnt->leaves);
        for (int i = 0; i < m; i++) {
            tracer_finish(&p.tr[i]);
            *res[at[i]] = p.tr[i].best;
            if (p.tr[i].pending) {
                held[nh] = p.tr[i];
                held_at[nh++] = at[i];
            }
        }
    }
    refine_job_t *jobs[TILE * TILE];
    for (int h = 0; h < nh; h++) {
        jobs[h] = &held[h].job;
        jobs[h]->out = &held[h].best;
    }
    cnt->evals += refine_batch(jobs, nh, ws);
    for (int h = 0; h < nh; h++) {
        tracer_settle(&held[h]);
        tracer_finish(&held[h]);
        *res[held_at[h]] = held[h].best;
    }
}

/* Beams: the rays of the pixels [c0, c1) x [r0, r1) of the tile whose top
 * left pixel is (tc0, tr0), their directions already in img->dir, walked
 * through the tree as one beam (beam.c): the directions' hull per component
 * and the eye.  A beam that reaches no surface leaf decides its rays:
 * misses, marked in decided[] (by pixel within the tile).  Else its quarters
 * are tried, down to BEAM_MIN pixels a side: the walk of a beam that reaches
 * a leaf stops there, so a beam that decides nothing costs a few descents,
 * and the smaller beams catch more of the rays that pass by the surface.
 * Quarters of 4x4 caught a few % more of them, at a cost above what their
 * packet walks cost (ray/README.md, "Beams"). */
#define BEAM_MIN 8
static void beam_rect(const oct_tree_t *tree, ray_beam_ws_t *bw, const ray_camera_t *cam,
                      const ray_image_t *img, int tc0, int tr0, int c0, int r0, int c1, int r1,
                      unsigned char *decided, counters_t *cnt)
{
    double dlo[3] = {INFINITY, INFINITY, INFINITY}, dhi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int row = r0; row < r1; row++)
        for (int col = c0; col < c1; col++) {
            const double *d = img->dir + 3 * ((size_t)row * img->width + col);
            for (int a = 0; a < 3; a++) {
                dlo[a] = d[a] < dlo[a] ? d[a] : dlo[a];
                dhi[a] = d[a] > dhi[a] ? d[a] : dhi[a];
            }
        }
    cnt->beams++;
    if (!ray_beam_reaches(tree, bw, cam->eye, dlo, dhi)) {
        for (int row = r0; row < r1; row++)
            for (int col = c0; col < c1; col++)
                decided[(row - tr0) * TILE + (col - tc0)] = 1;
        cnt->rays_decided += (uint64_t)(r1 - r0) * (uint64_t)(c1 - c0);
        return;
    }
    if (c1 - c0 <= BEAM_MIN && r1 - r0 <= BEAM_MIN)
        return;
    int cm = c1 - c0 > BEAM_MIN ? c0 + (c1 - c0 + 1) / 2 : c1;
    int rm = r1 - r0 > BEAM_MIN ? r0 + (r1 - r0 + 1) / 2 : r1;
    const int cs[3] = {c0, cm, c1}, rs[3] = {r0, rm, r1};
    for (int v = 0; v < 2; v++)
        for (int u = 0; u < 2; u++)
            if (cs[u] < cs[u + 1] && rs[v] < rs[v + 1])
                beam_rect(tree, bw, cam, img, tc0, tr0, cs[u], rs[v], cs[u + 1], rs[v + 1],
                          decided, cnt);
}

/* The rays go to the packets by blocks of pixels, one packet each. */
#define PACKET_W 4
#define PACKET_H 2
_Static_assert(PACKET_W * PACKET_H == RAY_PACKET, "a block of pixels is a packet");

/* The pixels [c0, c1) x [r0, r1) of a tile whose top left pixel is (c0, r0),
 * block by block of PACKET_W x PACKET_H, as (row - r0) * TILE + (col - c0)
 * into px; returns their count. */
static int packet_order(int c0, int r0, int c1, int r1, int *px)
{
    int n = 0;
    for (int br = r0; br < r1; br += PACKET_H)
        for (int bc = c0; bc < c1; bc += PACKET_W)
            for (int row = br; row < br + PACKET_H && row < r1; row++)
                for (int col = bc; col < bc + PACKET_W && col < c1; col++)
                    px[n++] = (row - r0) * TILE + (col - c0);
    return n;
}

/* bw: the beams' workspace, NULL for no beams (tree is then not used); pw
 * the packets', with os the octree source, used with beams. */
static void render_tile(const tape_t *tape, tape_ws_t *ws, const ray_camera_t *cam,
                        const ray_source_t *src, void *state, const oct_tree_t *tree,
                        ray_beam_ws_t *bw, const ray_octree_source_t *os, ray_packet_ws_t *pw,
                        const ray_render_opts_t *opts, ray_image_t *img, int tx, int ty,
                        counters_t *cnt)
{
    const int W = img->width, H = img->height;
    int c0, r0, c1, r1;
    tile_rect(W, H, tx, ty, &c0, &r0, &c1, &r1);
    size_t hits[TILE * TILE];
    double t_lo[TILE * TILE]; /* the hits' bracket starts: no root before them */
    int nh = 0;
    unsigned char decided[TILE * TILE] = {0}; /* rays decided by a beam: misses */

    for (int row = r0; row < r1; row++)
        for (int col = c0; col < c1; col++)
            ray_camera_dir(cam, col, row, img->dir + 3 * ((size_t)row * W + col));
    /* a decided ray: the per-ray walk would yield no segment, and trace
     * would leave its result a miss without counting anything.  The others
     * in blocks of PACKET_W x PACKET_H pixels, a packet's worth. */
    if (bw)
        beam_rect(tree, bw, cam, img, c0, r0, c0, r0, c1, r1, decided, cnt);
    ray_result_t res[TILE * TILE], *to[TILE * TILE];
    const double *dirs[TILE * TILE];
    int px[TILE * TILE], npx = packet_order(c0, r0, c1, r1, px), nt = 0;
    for (int j = 0; j < npx; j++) {
        int k = px[j];
        res[k] = (ray_result_t){RAY_MISS, NAN, NAN, NAN, 0, 0};
        if (decided[k])
            continue;
        dirs[nt] = img->dir + 3 * ((size_t)(r0 + k / TILE) * W + (size_t)(c0 + k % TILE));
        to[nt++] = &res[k];
    }
    trace_rays(tape, ws, src, state, os, bw ? pw : NULL, opts, cam->eye, nt, dirs, INFINITY, 0,
               to, cnt);

    for (int row = r0; row < r1; row++)
        for (int col = c0; col < c1; col++) {
            size_t i = (size_t)row * W + col;
            double *d = img->dir + 3 * i;
            ray_result_t best = res[(row - r0) * TILE + (col - c0)];
            img->t[i] = best.t;
            img->kind[i] = (unsigned char)best.kind;
            img->hit[i] = best.kind != RAY_MISS;
            img->shadow[i] = RAY_LIT;
            if (best.kind != RAY_MISS) {
                ray_point(cam->eye, d, best.t, img->point + 3 * i);
                t_lo[nh] = best.t_lo;
                hits[nh++] = i;
                cnt->hits++;
                if (best.kind == RAY_HIT_TANGENT || best.kind == RAY_HIT_BUDGET)
                    cnt->tangent++;
            } else {
                for (int k = 0; k < 3; k++)
                    img->point[3 * i + k] = img->normal[3 * i + k] = NAN;
                ray_shade(cam, NULL, NULL, d, NULL, 0, 0, img->rgb + 3 * i);
            }
        }

    /* normals of the tile's hits, TAPE_BATCH per evaluator call */
    for (int b = 0; b < nh; b += TAPE_BATCH) {
        int m = nh - b < TAPE_BATCH ? nh - b : TAPE_BATCH;
        iv_box_t box[TAPE_BATCH];
        iv_grad_t g[TAPE_BATCH];
        for (int k = 0; k < m; k++) {
            const double *p = img->point + 3 * hits[b + k];
            box[k].x = iv_point(p[0]);
            box[k].y = iv_point(p[1]);
            box[k].z = iv_point(p[2]);
        }
        tape_eval_grad(tape, ws, (size_t)m, box, g);
        cnt->evals++;
        for (int k = 0; k < m; k++) {
            size_t i = hits[b + k];
            normal_from(&g[k], img->dir + 3 * i, img->normal + 3 * i);
        }
    }

    /* shadow rays: between the light and a point q a little in front of each
     * hit, where no root lies between the eye and q; any root on the way
     * casts the shadow.  The ray starts at the light and ends at q (s = 1):
     * near q, where a lit ray must exclude the surface it starts close to,
     * the parameter's ulps are as fine as the points' (near s = 0 they would
     * be far finer, and the searches there needlessly long) */
    ray_render_opts_t shadow_opts = *opts;
    shadow_opts.roots.any_root = 1; /* a root proven on the way is enough */
    if (opts->light_on) {
        counters_t sc = {0}; /* the shadow rays' counts */
        double ds[TILE * TILE][3];
        ray_result_t sr[TILE * TILE], *to[TILE * TILE];
        const double *dirs[TILE * TILE];
        unsigned char placed[TILE * TILE];
        int att[TILE * TILE], na = 0; /* the hits whose attached piece is tried */
        double p0[TILE * TILE][3], q[TILE * TILE][3], w[TILE * TILE];
        for (int k = 0; k < nh; k++) {
            size_t i = hits[k];
            placed[k] = ray_shadow_origin(cam->eye, img->dir + 3 * i, img->t[i], q[k]) < t_lo[k];
            if (!placed[k])
                continue;
            double len = 0;
            for (int a = 0; a < 3; a++) {
                ds[k][a] = q[k][a] - opts->light[a];
                len += ds[k][a] * ds[k][a];
            }
            len = sqrt(len);
            sr[k] = (ray_result_t){RAY_MISS, NAN, NAN, NAN, 0, 0};
            /* The light behind the surface as the eye sees it (by the
             * normal, an estimate that only picks the order): an attached
             * shadow, most likely.  First the piece of the shadow ray just
             * before q, 2^-16 t long, from p0 = ray_point(light, ds, 1 - w):
             * a root proven there settles the pixel without the walk from
             * the light.  Else (and for every other hit) the whole ray,
             * all of them from the light, in packets with beams. */
            const double *n = img->normal + 3 * i, *p = img->point + 3 * i;
            double to_light[3] = {opts->light[0] - p[0], opts->light[1] - p[1],
                                  opts->light[2] - p[2]};
            w[k] = 0x1p-16 * img->t[i] / len;
            if (dot3(n, to_light) * dot3(n, img->dir + 3 * i) > 0 && w[k] < 0.5) {
                ray_point(opts->light, ds[k], 1 - w[k], p0[k]);
                att[na++] = k;
            }
        }
        /* The attached pieces by the signs of f at their ends first: opposite
         * certified signs at p0 and q prove a root between them, as a
         * search's sign change does, for one interval pass per TAPE_BATCH / 2
         * pieces instead of a search each.  The others are searched. */
        for (int b = 0; b < na; b += TAPE_BATCH / 2) {
            int m = na - b < TAPE_BATCH / 2 ? na - b : TAPE_BATCH / 2;
            iv_box_t box[TAPE_BATCH];
            iv_t f[TAPE_BATCH];
            for (int j = 0; j < m; j++) {
                const double *e[2] = {p0[att[b + j]], q[att[b + j]]};
                for (int h = 0; h < 2; h++)
                    box[2 * j + h] = (iv_box_t){iv_point(e[h][0]), iv_point(e[h][1]),
                                                iv_point(e[h][2])};
            }
            tape_eval_interval(tape, ws, (size_t)(2 * m), box, f);
            sc.evals++;
            for (int j = 0; j < m; j++) {
                int s0 = sgn(f[2 * j]);
                if (is_sign(s0) && sgn(f[2 * j + 1]) == -s0)
                    sr[att[b + j]].kind = RAY_HIT_ROOT;
            }
        }
        for (int j = 0; j < na; j++) {
            int k = att[j];
            if (sr[k].kind == RAY_HIT_ROOT)
                continue;
            attached_piece(tape, ws, src, state, &shadow_opts, p0[k], ds[k], w[k], &sr[k], &sc);
            if (sr[k].kind != RAY_HIT_ROOT)
                sr[k].kind = RAY_MISS;
        }
        /* the hits whose whole shadow ray is searched, in the primary rays'
         * order (blocks of PACKET_W x PACKET_H pixels): a packet's rays then
         * end close together */
        int hit_at[TILE * TILE]; /* by pixel of the tile: its hit, or -1 */
        for (int k = 0; k < TILE * TILE; k++)
            hit_at[k] = -1;
        for (int k = 0; k < nh; k++)
            hit_at[(int)(hits[k] / (size_t)W - (size_t)r0) * TILE +
                   (int)(hits[k] % (size_t)W) - c0] = k;
        int nw = 0;
        for (int j = 0; j < npx; j++) {
            int k = hit_at[px[j]];
            if (k < 0 || !placed[k] || sr[k].kind == RAY_HIT_ROOT)
                continue;
            dirs[nw] = ds[k];
            to[nw++] = &sr[k];
        }
        trace_rays(tape, ws, src, state, os, bw ? pw : NULL, &shadow_opts, opts->light, nw, dirs,
                   1.0, 1, to, &sc);
        for (int k = 0; k < nh; k++) {
            size_t i = hits[k];
            unsigned char sh = !placed[k]                ? RAY_SHADOW_UNDECIDED
                               : sr[k].kind == RAY_MISS     ? RAY_LIT
                               : sr[k].kind == RAY_HIT_ROOT ? RAY_SHADOWED
                                                            : RAY_SHADOW_UNDECIDED;
            img->shadow[i] = sh;
            cnt->shadow_rays++;
            cnt->shadowed += sh == RAY_SHADOWED;
            cnt->shadow_undecided += sh == RAY_SHADOW_UNDECIDED;
        }
        cnt->evals += sc.evals;
        cnt->shadow_evals += sc.evals;
        cnt->segments += sc.segments;
        cnt->leaves += sc.leaves;
    }

    for (int k = 0; k < nh; k++) {
        size_t i = hits[k];
        ray_shade(cam, opts->light_on ? opts->light : NULL, img->point + 3 * i, img->dir + 3 * i,
                  img->normal + 3 * i, 1, img->shadow[i] != RAY_LIT, img->rgb + 3 * i);
    }
}

int ray_render(const tape_t *tape, const ray_camera_t *cam, const ray_source_t *src,
               const ray_render_opts_t *opts, ray_image_t *img, ray_stats_t *stats,
               ivoct_error_t *err)
{
    ray_render_opts_t def;
    if (!opts) {
        ray_render_opts_default(&def);
        opts = &def;
    }
    if (stats)
        memset(stats, 0, sizeof *stats);
    if (!tape || !cam || !src || !img) {
        ivoct_error_set(err, "ray_render: missing argument");
        return 1;
    }
    if (img->width != cam->width || img->height != cam->height) {
        ivoct_error_set(err, "ray_render: image %dx%d does not match the camera's %dx%d",
                        img->width, img->height, cam->width, cam->height);
        return 1;
    }
    if ((unsigned)opts->method >= RAY_METHOD_COUNT) {
        ivoct_error_set(err, "ray_render: invalid method %d", (int)opts->method);
        return 1;
    }
    const int parts = opts->parts > 1 ? opts->parts : 1, part = parts > 1 ? opts->part : 0;
    if (part < 0 || part >= parts) {
        ivoct_error_set(err, "ray_render: part %d of %d", opts->part, opts->parts);
        return 1;
    }
    if (opts->light_on &&
        !(isfinite(opts->light[0]) && isfinite(opts->light[1]) && isfinite(opts->light[2]))) {
        ivoct_error_set(err, "ray_render: the light (%g %g %g) is not a finite point",
                        opts->light[0], opts->light[1], opts->light[2]);
        return 1;
    }
    img->lit = opts->light_on != 0;
    for (int a = 0; a < 3; a++)
        img->light[a] = opts->light_on ? opts->light[a] : 0;
    const int tiles_x = (img->width + TILE - 1) / TILE, tiles_y = (img->height + TILE - 1) / TILE;
    const long ntiles = (long)tiles_x * tiles_y;
    long mine = 0; /* the tiles of the part */
    for (long tile = 0; tile < ntiles; tile++)
        mine += in_part((int)(tile % tiles_x), (int)(tile / tiles_x), part, parts);
    const int nthreads = opts->threads > 0 ? opts->threads : omp_get_max_threads();
    double start = omp_get_wtime();
    uint64_t hits = 0, tangent = 0, evals = 0, segments = 0, leaves = 0;
    uint64_t shadow_rays = 0, shadowed = 0, shadow_undecided = 0, shadow_evals = 0;
    uint64_t beams = 0, rays_decided = 0;
    const ray_octree_source_t *os = opts->no_beams ? NULL : ray_source_octree(src);
    const oct_tree_t *tree = os ? os->tree : NULL;
    int failed = 0, used = 1;
    long done = 0;

#pragma omp parallel num_threads(nthreads) reduction(+ : hits, tangent, evals, segments, leaves, \
                                                        shadow_rays, shadowed, shadow_undecided, \
                                                        shadow_evals, beams, rays_decided)
    {
        tape_ws_t *ws = tape_ws_new(tape->n);
        void *state = malloc(src->state_size ? src->state_size : 1);
        ray_beam_ws_t *bw = tree ? ray_beam_ws_new(tree) : NULL;
        ray_packet_ws_t *pw = tree ? ray_packet_ws_new(tree) : NULL;
        int ok = ws && state && ((bw && pw) || !tree);
        if (!ok) {
#pragma omp atomic write
            failed = 1;
        }
#pragma omp single
        used = omp_get_num_threads();
#pragma omp for schedule(dynamic, 1)
        for (long tile = 0; tile < ntiles; tile++) {
            const int tx = (int)(tile % tiles_x), ty = (int)(tile / tiles_x);
            if (!ok || !in_part(tx, ty, part, parts))
                continue;
            counters_t cnt = {0};
            render_tile(tape, ws, cam, src, state, tree, bw, os, pw, opts, img, tx, ty, &cnt);
            hits += cnt.hits;
            tangent += cnt.tangent;
            evals += cnt.evals;
            segments += cnt.segments;
            leaves += cnt.leaves;
            shadow_rays += cnt.shadow_rays;
            shadowed += cnt.shadowed;
            shadow_undecided += cnt.shadow_undecided;
            shadow_evals += cnt.shadow_evals;
            beams += cnt.beams;
            rays_decided += cnt.rays_decided;
            long now;
#pragma omp atomic capture
            now = ++done;
            if (opts->progress && omp_get_thread_num() == 0)
                opts->progress(opts->progress_ctx, (double)now / (double)mine);
        }
        ray_packet_ws_free(pw);
        ray_beam_ws_free(bw);
        free(state);
        tape_ws_free(ws);
    }
    if (failed) {
        ivoct_error_set(err, "out of memory for the render workspaces");
        return 1;
    }
    if (opts->progress)
        opts->progress(opts->progress_ctx, 1.0);
    if (stats) {
        stats->rays = ray_part_pixels(img->width, img->height, part, parts);
        stats->hits = hits;
        stats->tangent_hits = tangent;
        stats->tape_evals = evals;
        stats->segments = segments;
        stats->leaves = leaves;
        stats->shadow_rays = shadow_rays;
        stats->shadowed = shadowed;
        stats->shadow_undecided = shadow_undecided;
        stats->shadow_evals = shadow_evals;
        stats->beams = beams;
        stats->rays_decided_by_beam = rays_decided;
        stats->time_s = omp_get_wtime() - start;
        stats->threads = used;
    }
    return 0;
}
