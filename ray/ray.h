/* ivoct — ray casting of implicit surfaces (prefix ray_).
 *
 * A pinhole camera shoots one primary ray per pixel (through the pixel
 * centre).  Each ray asks an interval source (ray_source_t) for the parameter
 * segments [t_in, t_out] that may hold surface, front to back, and runs a root
 * finder on g(t) = f(o + t·d) over each, up to the best hit so far, so the
 * first root wins.  With an octree (ray_octree_source) the segments are the
 * surface leaves the ray meets, front to back; without one, a single segment:
 * the ray clipped to the scene box (ray_box_source).  The hits are shaded
 * (Lambert + ambient from the normal ∇f/|∇f|) into an RGB image; the per-pixel
 * buffers of docs/DESIGN.md §4 (t, hit, point, normal, dir) can be written as a VTK
 * .vti, the image as PNG.
 *
 * Points along a ray.  The point evaluated at parameter t is the rounded
 * ray_point(o, d, t) = fl(o + fl(t·d)) per axis: the certified sign of g at t
 * is the sign of the interval enclosure of f at that exact point, and the hit
 * position reported is that point.  Exclusion tests (0 ∉ G(T)) are done on a
 * box that holds both the exact segment o + T·d and every rounded point of T,
 * so "no root" is certified for both; a reported root is certified to the
 * resolution of the rounded points (a few ulps).  See ray/README.md.
 *
 * Library code never prints, exits or aborts; functions that can fail return 0
 * on success and non-zero with a message in an ivoct_error_t.
 */
#ifndef IVOCT_RAY_H
#define IVOCT_RAY_H

#include <stdint.h>
#include <stdio.h>

#include "../expr/error.h"
#include "../expr/tape.h"
#include "../octree/octree.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- methods ------------------------------------------------------------------ */

typedef enum ray_method {
    RAY_MITCHELL,     /* "mitchell": interval bisection, monotonicity test on G'(T) */
    RAY_NEWTON,       /* "newton": interval Newton where 0 ∉ G'(T), bisection elsewhere */
    RAY_NEWTON_AH,    /* "newton-ah": interval Newton with Alefeld–Hansen extended division */
    RAY_MRFRO,        /* "mrfro": bisection with endpoint sign rules, no derivatives */
    RAY_MRFRO_NEWTON, /* "mrfro-newton": MRFro's rules, Newton steps where 0 ∉ G'(T) */
    RAY_LIPSCHITZ,    /* "lipschitz": Kalra–Barr G test |g(tm)| > G·h on ray segments */
    RAY_SAMPLING,     /* "sampling": fixed-step point sampling + bisection (NOT certified) */
    RAY_METHOD_COUNT
} ray_method_t;

/* The method's name as above; NULL for an invalid value. */
const char *ray_method_name(ray_method_t m);

/* Parse a method name (exactly one of the names above).  0 on success. */
int ray_method_parse(const char *name, ray_method_t *m);

/* Whether the method certifies its answers (all but sampling). */
int ray_method_certified(ray_method_t m);

/* The names for messages, "mitchell, newton, ..., lipschitz or sampling", into
 * buf (never more than n bytes with the terminating NUL); returns buf. */
char *ray_method_list(char *buf, size_t n);

/* ---- camera -------------------------------------------------------------------- */

#define RAY_MAX_SIZE 65536 /* largest width or height */

typedef struct ray_camera {
    double eye[3], target[3], up[3]; /* as given */
    double fov;                      /* vertical field of view, degrees, in (0, 180) */
    int width, height;               /* pixels */
    /* derived: an orthonormal frame and the half-height of the image plane at
     * distance 1 */
    double fwd[3], right[3], vup[3];
    double tan_half;
} ray_camera_t;

/* What ray_camera_init refused: its non-zero return values, in the order of
 * its checks. */
enum {
    RAY_CAMERA_BAD_FOV = 1, /* fov outside (0, 180) degrees */
    RAY_CAMERA_BAD_SIZE,    /* width or height outside [1, RAY_MAX_SIZE] */
    RAY_CAMERA_BAD_EYE,     /* eye or target not finite, or eye = target */
    RAY_CAMERA_BAD_UP,      /* up not finite, zero, or parallel to target - eye */
};

/* Set up a camera: the one place cameras are checked.  Returns 0, or one of
 * RAY_CAMERA_BAD_* with err saying what is wrong. */
int ray_camera_init(ray_camera_t *cam, const double eye[3], const double target[3],
                    const double up[3], double fov_deg, int width, int height,
                    ivoct_error_t *err);

/* The unit direction of the primary ray of pixel (col, row), row 0 at the top,
 * through the pixel centre.  Every ray starts at cam->eye. */
void ray_camera_dir(const ray_camera_t *cam, int col, int row, double d[3]);

/* The camera turned by `angle` radians about the axis through target along
 * up (a turntable); size, fov and up are kept. */
int ray_camera_orbit(const ray_camera_t *cam, double angle, ray_camera_t *out,
                     ivoct_error_t *err);

/* The rounded point of the ray at t: p[i] = o[i] + t*d[i] in double, without
 * fused multiply-add (the exact point the root finders evaluate at). */
void ray_point(const double o[3], const double d[3], double t, double p[3]);

/* Clip the ray o + t·d, t >= 0, to box {xmin xmax ymin ymax zmin zmax}.
 * Returns 1 with [*t0, *t1] (t0 <= t1), an enclosure of the exact parameter
 * range inside the box (widened outward by the rounding of the divisions),
 * or 0 when the ray misses the box. */
int ray_clip_box(const double box[6], const double o[3], const double d[3], double *t0,
                 double *t1);

/* ---- root finding on one segment ------------------------------------------------ */

typedef struct ray_opts {
    /* A segment T on which neither the value test nor the monotonicity test
     * decides is accepted as a hit (a double root: silhouette, whisker, singular
     * point, or unresolved) once w(T) <= tol_rel * max(|t0|, |t1|) of the
     * segment given (and never below 8 ulps).  Default 2^-44 ≈ 5.7e-14. */
    double tol_rel;
    /* sampling only: the step in t (distance along the unit direction).
     * <= 0: (t1 - t0) / 1000 for each segment. */
    double sample_step;
    /* Safety net: after this many segments of one search the first unresolved
     * one is reported as a hit (RAY_HIT_BUDGET).  Default 100000. */
    long max_nodes;
    /* An any-hit query (shadow rays): the search ends as soon as a segment is
     * proven to hold a root -- certified signs of opposite signs at its ends on
     * a segment where G' excludes 0 (or, for mrfro, on any segment), or an
     * interval Newton step inside the segment -- instead of refining the root
     * to a few ulps: RAY_HIT_ROOT with [t_lo, t_hi] that segment and t its
     * midpoint.  Other hits and misses are as without it.  Default 0. */
    int any_root;
} ray_opts_t;

void ray_opts_default(ray_opts_t *o);

typedef enum ray_hit_kind {
    RAY_MISS = 0,    /* no root in [t0, t1]: certified (sampling: none found) */
    RAY_HIT_ROOT,    /* a certified sign change, the root refined to a few ulps */
    RAY_HIT_ZERO,    /* the enclosure of f at the point contains 0 (a root within
                      * the evaluation's rounding; the sign cannot be decided) */
    RAY_HIT_TANGENT, /* an undecided segment reached the tolerance (double root) */
    RAY_HIT_BUDGET   /* max_nodes or the search stack ran out: t is the start of
                      * the first unresolved segment (conservative) */
} ray_hit_kind_t;

typedef struct ray_result {
    ray_hit_kind_t kind;
    double t;           /* the hit; NaN on a miss */
    double t_lo, t_hi;  /* the final bracket (or accepted segment); NaN on a miss */
    uint64_t evals;     /* tape passes: evaluator calls (gradient, interval or double),
                         * each of up to RAY_BATCH (8) boxes or points */
    uint64_t nodes;     /* segments examined */
} ray_result_t;

/* The first root of g(t) = f(o + t·d) in [t0, t1] (the smallest t) with method
 * m.  ws must fit tape (tape_ws_new(n >= tape->n)).  Returns res->kind:
 * non-zero on a hit.  d should be a unit vector for t to be a distance.  Rays
 * and segments with t0 > t1 or non-finite input are misses. */
ray_hit_kind_t ray_find_root(const tape_t *tape, tape_ws_t *ws, ray_method_t m,
                             const ray_opts_t *opts, const double o[3], const double d[3],
                             double t0, double t1, ray_result_t *res);

/* The first root over n <= RAY_MAX_SEGMENTS segments [t0[k], t1[k]] of the same
 * ray, given front to back: the answer of ray_find_root on each in turn until
 * one hits (the tolerance scale is that of all of them), but in one search
 * whose first evaluations take two segments per evaluator call (one call
 * holds both) — the octree's leaves come in runs.  *which (may be NULL): the
 * first segment that holds the start of the hit's bracket, -1 on a miss; the
 * segments after it were not searched beyond their first evaluation. */
#define RAY_MAX_SEGMENTS 8
ray_hit_kind_t ray_find_root_n(const tape_t *tape, tape_ws_t *ws, ray_method_t m,
                               const ray_opts_t *opts, const double o[3], const double d[3],
                               int n, const double *t0, const double *t1, ray_result_t *res,
                               int *which);

/* ---- interval sources: the seam between ray casting and space subdivision -------- */

typedef struct ray_segment {
    double t_in, t_out;    /* out: t_in <= t_out */
    const tape_t *tape;    /* out: the tape to search the segment with, equal to f on
                            * every point the search evaluates (the octree source
                            * with leaf tapes: the leaf's pruned tape), or NULL for
                            * the renderer's tape */
    double t_max;          /* in: the hit found so far on this ray (INFINITY before
                            * one); only roots before it are still wanted */
    int64_t leaf;          /* out, informative: the octree leaf (index in
                            * tree->leaves) of the octree source, -1 for the box
                            * source; other sources may leave it unset */
} ray_segment_t;

/* For each ray the renderer calls begin once, then next until it returns 0.
 * Before each call the renderer sets seg->t_max to the smallest hit found so
 * far (INFINITY before the first), runs the root finder on
 * [t_in, min(t_out, t_max)] when t_in < t_max, and keeps the smaller hit.
 * So the answer is the first root whatever the order of the segments, as long
 * as together they cover every t where the ray may meet the surface.  A
 * source should yield its segments front to back and return 0 as soon as
 * nothing left can start before t_max: then the loop ends at the first hit,
 * save for segments that overlap it by rounding (the octree source).  A
 * source of disjoint segments may ignore t_max: what follows a hit costs one
 * call each, no root finding.  state points to state_size bytes owned by the
 * renderer (one buffer per thread, reused for every ray; aligned for any
 * type); ctx is shared by all threads, read-only.  leaves (may be NULL)
 * counts what the source visited for the statistics. */
typedef struct ray_source {
    void *ctx;
    size_t state_size;
    void (*begin)(const void *ctx, void *state, const double o[3], const double d[3]);
    int (*next)(const void *ctx, void *state, ray_segment_t *seg, uint64_t *leaves);
} ray_source_t;

/* The source for --no-octree: one segment, the ray clipped to box (ray_clip_box).
 * bs holds the box and must outlive the source. */
typedef struct ray_box_source {
    double box[6];
} ray_box_source_t;

ray_source_t ray_box_source(ray_box_source_t *bs, const double box[6]);

/* The octree source: the surface leaves of tree that the ray meets, front to
 * back.  A parametric traversal (children in order of their entry parameter)
 * over the closed cells of the tree; empty cells are skipped without
 * evaluating anything.  A leaf's segment encloses every t where the exact ray
 * o + t·d (t >= 0) is inside the closed leaf box (plane crossings enclosed
 * with outward rounding), narrowed, when the leaf has an ILIE slab and
 * use_slabs is set, to an enclosure of the t where d_lo <= n·(o + t·d) <= d_hi
 * (a leaf whose slab the ray provably misses is skipped).  Subtrees that
 * cannot start before seg->t_max are pruned.  *leaves counts the surface
 * leaves yielded.  os holds the tree (borrowed: it must outlive the source,
 * and not change while rendering).  The state is sized from tree->depth.  See
 * ray/README.md, "Octree traversal", for why the first hit is the first root. */
typedef struct ray_octree_source {
    const oct_tree_t *tree;
    int use_slabs;
    /* NULL (the default): every segment is searched with the renderer's tape.
     * Else each leaf's segment with its pruned tape (octree.h,
     * oct_leaf_tapes_build with a margin of at least ray_tape_margin for the
     * cameras rendered): borrowed, built from the renderer's tape and tree. */
    const oct_leaf_tapes_t *tapes;
} ray_octree_source_t;

ray_source_t ray_octree_source(ray_octree_source_t *os, const oct_tree_t *tree);

/* The build of an octree for a render that casts `rays` rays (primary and
 * shadow): from RAY_SLAB_RAYS on, p's tests get ILIE added and its slabs are
 * kept, so that every leaf has a slab and the octree source narrows each
 * ray's segment of a leaf to it (most segments to nothing, for the rays that
 * pass by the surface); fewer, p is left as it is.  The slabs make the build
 * 1.3-3.6x slower and each ray 1.4-1.9x faster, so they pay from a few
 * 300 x 300 images on: ray/README.md, "Slabs for rendering". */
#define RAY_SLAB_RAYS 524288.0 /* 2^19: e.g. 1024 x 512, or 6 frames of 300 x 300 */
void ray_octree_params(oct_params_t *p, double rays);

/* A margin for oct_leaf_tapes_build that covers every point the root finders
 * evaluate for a leaf's segment, for the rays of cam and of every turntable
 * view of it (ray_camera_orbit): how far those points can lie outside the
 * closed leaf is bounded by the rounding of the segment's ends (a few ulps of
 * t) and of the points p~(t) (2^-52 (|o_i| + 2|t|), expr/tape.h), with t at
 * most the distance from the eye to the far side of box; the margin is 2^-40
 * times a bound on |o_i| + 2t, which exceeds them by far.  Rounded up. */
double ray_tape_margin(const ray_camera_t *cam, const double box[6]);

/* The same for the shadow rays of a point light (ray_render_opts_t.light):
 * they run from the light (or, for the piece searched first, from a point
 * just before q) to q in box, t in [0, 1] along q - light
 * (ray_shadow_origin), so the margin is 2^-40 times a bound on
 * |o_i| + 2|t·d_i| from the box and the light.  A render with a light needs
 * the larger of the two margins. */
double ray_light_tape_margin(const double light[3], const double box[6]);

/* ---- rendering -------------------------------------------------------------------- */

/* The buffers of docs/DESIGN.md §4, row-major with row 0 the top of the image:
 * pixel (col, row) at index row*width + col, 3-vectors at 3*index. */
/* What the shadow ray of a hit found (ray_image_t.shadow; see "Shadows" in
 * ray/README.md).  Misses, and every pixel of an image rendered without a
 * light, are RAY_LIT. */
typedef enum ray_shadow {
    RAY_LIT = 0,          /* certified: the segment to the light meets no surface */
    RAY_SHADOWED,         /* a certified root (sign change) on the segment */
    RAY_SHADOW_UNDECIDED  /* counted as shadow: a root the tests could not certify
                           * nor exclude (a tangency, a zero within the rounding
                           * of f, the budget), or no origin for the shadow ray
                           * could be placed before the first root */
} ray_shadow_t;

typedef struct ray_image {
    int width, height;
    int lit;              /* set by ray_render: rendered with a point light (below) */
    double light[3];      /* the light, when lit */
    double *t;            /* distance along dir to the first hit; NaN on a miss */
    unsigned char *hit;   /* 1 hit, 0 miss */
    unsigned char *kind;  /* ray_hit_kind_t */
    double *point;        /* the hit position ray_point(eye, dir, t); NaN on a miss */
    double *normal;       /* ∇f/|∇f| at the point (see ray/README.md for the
                           * fallback at singular points); NaN on a miss */
    double *dir;          /* the unit ray direction */
    unsigned char *rgb;   /* the shaded image, 8-bit sRGB */
    unsigned char *shadow; /* ray_shadow_t */
} ray_image_t;

int ray_image_alloc(ray_image_t *img, int width, int height, ivoct_error_t *err);
void ray_image_free(ray_image_t *img);

/* ---- parts of an image (the render over MPI: cli/, docs/cluster.md) ------------------
 * The image is cut into tiles of RAY_TILE x RAY_TILE pixels (the last row and
 * column of tiles may be smaller), tile (tx, ty) counted from the top left.
 * Part p of n (0 <= p < n) is the tiles with (tx + ty) mod n = p: diagonals
 * dealt round robin, so that every part has its share of each region of the
 * image (the cost of a ray varies strongly across an image: background rows
 * are cheap).  n <= 1: one part, the whole image.  ray_render renders one part
 * (ray_render_opts_t.part, .parts); a part travels packed, its tiles in
 * row-major order, each tile's pixels row by row: every buffer
 * (RAY_PACK_ALL, RAY_PIXEL_BYTES a pixel) or the shaded image alone
 * (RAY_PACK_RGB, 3 bytes a pixel). */
#define RAY_TILE 16
#define RAY_PIXEL_BYTES (10 * sizeof(double) + 6) /* t point normal dir, hit kind shadow rgb */
typedef enum ray_pack { RAY_PACK_ALL, RAY_PACK_RGB } ray_pack_t;

/* The bytes of one packed pixel. */
size_t ray_pack_bytes(ray_pack_t what);

/* The pixels of part `part` of `parts` of a width x height image. */
size_t ray_part_pixels(int width, int height, int part, int parts);

/* Copy the buffers `what` of part `part` of `parts` of img into buf
 * (ray_pack_bytes(what) x ray_part_pixels bytes), or back from it into img. */
void ray_image_pack(const ray_image_t *img, int part, int parts, ray_pack_t what,
                    unsigned char *buf);
void ray_image_unpack(ray_image_t *img, int part, int parts, ray_pack_t what,
                      const unsigned char *buf);

typedef struct ray_stats {
    uint64_t rays;         /* primary rays (pixels) */
    uint64_t hits;         /* rays with a hit */
    uint64_t tangent_hits; /* hits of kind RAY_HIT_TANGENT or RAY_HIT_BUDGET */
    uint64_t tape_evals;   /* tape passes (see ray_result_t.evals), shading included */
    uint64_t segments;     /* segments the root finder ran on */
    uint64_t leaves;       /* what the sources counted: the leaves yielded, every
                            * one searched but those a primary ray's walk yields
                            * (up to 4) while its hit's refinement is set aside,
                            * overlapping the hit's bracket by rounding (render.c) */
    /* with a light: shadow rays cast (one per hit), their outcomes (the rest
     * are lit), and the tape passes and source segments they took (part of
     * tape_evals, segments and leaves above) */
    uint64_t shadow_rays, shadowed, shadow_undecided, shadow_evals;
    /* beams (ray_render_opts_t.no_beams; ray/README.md, "Beams"): beam walks
     * done (a tile, then its quarters down to 4x4 pixels while they reach a
     * surface leaf), and primary rays decided as misses at beam level (no
     * walk, no search of their own) */
    uint64_t beams, rays_decided_by_beam;
    double time_s;         /* wall clock of ray_render */
    int threads;           /* threads used */
} ray_stats_t;

typedef struct ray_render_opts {
    ray_method_t method;
    ray_opts_t roots;
    int threads;   /* <= 0: OpenMP's default */
    /* Render only part `part` of `parts` (above; parts <= 1: the whole image,
     * the default); the rest of the buffers is left as it was. */
    int part, parts;
    /* A point light (light_on): every hit casts a shadow ray to it through the
     * same source, and is shaded by it; else a light fixed to the camera
     * lights the image and no shadow ray is cast. */
    int light_on;
    double light[3];
    /* With the octree source, the rays of a tile are first walked through the
     * tree together as beams (ray/README.md, "Beams"): a beam that reaches no
     * surface leaf decides its rays as misses; the other rays, and the shadow
     * rays, go down the tree in packets of 8 ("Packets").  On by default (0);
     * no_beams walks every ray alone.  The buffers and every counter but the
     * beams' are the same either way.  Other sources have no beams. */
    int no_beams;
    /* Called now and then with the fraction done, from one thread only; may be NULL. */
    void (*progress)(void *ctx, double fraction);
    void *progress_ctx;
} ray_render_opts_t;

void ray_render_opts_default(ray_render_opts_t *o);

/* Render img (allocated with the camera's size) with the given tape, camera
 * and source.  OpenMP over tiles of the image; the buffers and the counters in
 * stats do not depend on the number of threads.  Every counter is a sum over
 * the tiles: the parts' counters add up to the whole image's (rays: the
 * part's pixels).  Errors: size mismatch, an invalid part, out of memory. */
int ray_render(const tape_t *tape, const ray_camera_t *cam, const ray_source_t *src,
               const ray_render_opts_t *opts, ray_image_t *img, ray_stats_t *stats,
               ivoct_error_t *err);

/* The byte of a pixel's linear intensity c, gamma 2.2: exactly
 * (unsigned char)(255 pow(c', 1/2.2) + 0.5) with c' = c clamped to [0, 1],
 * for every c (NaN gives 0), at the cost of a table lookup but for c within
 * 2^-30 of a step, where it is that formula. */
unsigned char ray_srgb8(double c);

/* Lambert + ambient shading of one pixel: normal n at a hit seen along d,
 * the side of the surface facing the eye lit; background where !hit.  The
 * light: a point light at `light` seen from the hit point p when light is not
 * NULL (ambient only when shadowed), else a light fixed to the camera. */
void ray_shade(const ray_camera_t *cam, const double *light, const double p[3],
               const double d[3], const double n[3], int hit, int shadowed,
               unsigned char rgb[3]);

/* The shadow ray of a hit at distance t along the primary ray eye + s·d:
 * its end q = ray_point(eye, d, t_q) with t_q = t - 2^-20 t, a little in
 * front of the hit; returns t_q.  The renderer casts it only when the primary
 * search certified that no root lies before t_q (the hit's bracket starts
 * after it), so q is on the eye's side of the surface.  The shadow ray is
 * light + s·(q - light), s in [0, 1], q - light rounded per axis: the hit is
 * in shadow when f has a root on it.  See ray/README.md, "Shadows". */
double ray_shadow_origin(const double eye[3], const double d[3], double t, double q[3]);

/* ---- output -------------------------------------------------------------------------- */

/* 8-bit RGB PNG of img->rgb (libpng). */
int ray_write_png(FILE *f, const ray_image_t *img, ivoct_error_t *err);

/* VTK XML ImageData (.vti), one point per pixel, point arrays t, hit, point,
 * normal, dir and, when img->lit, shadow (1 shadowed or undecided, 0 lit)
 * (Float64, base64 "binary" format), with the camera (eye, target, up, fov),
 * the method and, when lit, the light as field data.  VTK's y axis points up: image row r
 * is VTK row height-1-r, so the data shows upright. */
int ray_write_vti(FILE *f, const ray_image_t *img, const ray_camera_t *cam,
                  const char *method, ivoct_error_t *err);

#ifdef __cplusplus
}
#endif
#endif
