/* ivoct_mesh_quality — how good a triangle mesh of a scene's surface is.
 *
 * For the meshes `ivoct build` writes (`--mesh`: OpenVDB's volumeToMesh,
 * `--mesh-certified`: mesh/), read back from their binary little-endian PLY
 * files (float or double vertices), one JSON line on stdout:
 *
 *  - the counts and the topology report of tests/support/mesh_check.c
 *    (mc_check: boundary, non-manifold and misoriented edges, non-manifold
 *    vertices, Euler characteristic, components, and with the exact
 *    intersection test the self-intersecting pairs): the same oracle the
 *    tests of mesh/ use, written apart from both meshers;
 *
 *  - mesh -> surface: sample points on every triangle (each used vertex, the
 *    midpoint of each edge, each centroid, and a barycentric grid on
 *    triangles whose longest edge is over twice the median edge) are
 *    projected onto f = 0 by Newton steps along the gradient, q <- q -
 *    f(q) grad f(q) / |grad f(q)|^2, first on the double evaluator
 *    (tape_eval_grad at the point, the midpoints of its enclosures) while
 *    the steps move q by more than 2^-30 of the box.  Then q is proved to be
 *    within delta (2^-40 of the box's diagonal, or 2^-44 of q's largest
 *    coordinate if more) of a zero of f: f has
 *    certified opposite signs at q -+ delta n (n the unit gradient) and is
 *    proved continuous on that segment (tape_check_continuous, or
 *    tape_is_total), so the intermediate value theorem gives the zero.  The
 *    signs come from the rigorous double interval evaluator where it decides
 *    them, else from MPFI at 256 bits (tests/support/mpfi_tape.c,
 *    oracle_eval), and where that fails too, Newton steps go on with f and
 *    grad f evaluated in MPFI (exact where doubles cancel, near singular
 *    points), at most 24.  With --mpfi-all every sign is MPFI's.  The
 *    farthest sample is proved again with MPFI in any case.  A sample's
 *    distance is |p - q|: an upper bound of its distance to the surface (up
 *    to delta), close to it when p is near the surface (the gradient's path
 *    curves little over such a distance).  Samples without a proof, or whose
 *    q strays more than a tenth of the box's diagonal from p, are left out of
 *    the distances and counted (to_surface_unconverged).  The decimal
 *    constants of the scene are taken at the lower end of their enclosures
 *    (ORACLE_CONST_LO) in MPFI: a zero of f to the precision the scene gives;
 *
 *  - surface -> mesh (--reference REF.ply): for every vertex of REF — a mesh
 *    whose vertices lie on the surface, e.g. the certified mesh of the same
 *    surface at a deeper depth (its vertices are on f = 0 to a double's
 *    precision) — the distance to the nearest triangle of the mesh (exact
 *    point-triangle distance in double, over a uniform grid of the
 *    triangles).  With --reference-project the reference's vertices are
 *    first projected onto the surface as above (for a surface the certified
 *    mesher refuses: a deeper OpenVDB mesh, projected);
 *
 *  - hausdorff: the larger of the two maxima, a sampled Hausdorff distance
 *    (what lies between the samples is not seen: the true one may be
 *    larger).
 *
 * Keys: mesh, point_type, triangles, vertices, the mc_report_t fields
 * (euler ... coincident_vertices), closed_embedded, signed_volume,
 * to_surface_samples, to_surface_max, to_surface_mean,
 * to_surface_unconverged, to_surface_mpfi (proved by MPFI signs),
 * to_surface_mpfi_newton (that needed MPFI steps), to_surface_max_mpfi_proved,
 * reference_points, reference_unconverged (with --reference-project),
 * to_mesh_max, to_mesh_mean, hausdorff (null where there is nothing to
 * measure), and the seconds of each part.  Distances in the scene's units.
 * Samples are spread over --threads (default: all cores).
 *
 * usage: ivoct_mesh_quality SCENE MESH.ply [--reference REF.ply] [--reference-project]
 *                           [--mpfi-all] [--no-intersections] [--threads N] */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <mpfi.h>

#include "../scene/scene.h"
#include "mesh_check.h"
#include "mpfi_tape.h"

static void usage(void)
{
    fputs("usage: ivoct_mesh_quality SCENE MESH.ply [--reference REF.ply] [--reference-project]\n"
          "                          [--mpfi-all] [--no-intersections] [--threads N]\n",
          stderr);
    exit(2);
}

static void die(const char *what, const char *path)
{
    fprintf(stderr, "ivoct_mesh_quality: %s: %s\n", path, what);
    exit(1);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p) {
        fputs("ivoct_mesh_quality: out of memory\n", stderr);
        exit(1);
    }
    return p;
}

/* ---- binary little-endian PLY ---------------------------------------------------
 * What exp_mesh and exp_mesh_write write (element vertex with x y z, element
 * face with a list of indices), read by the header rather than assumed, so
 * that any scalar types and extra properties are skipped correctly. */

typedef struct mesh {
    double *pts;
    size_t nv;
    uint32_t *tris;
    size_t nt;
    const char *point_type; /* "float" or "double": the type of x */
} mesh_t;

enum { MAX_PROPS = 16, MAX_ELEMS = 8 };

typedef struct prop {
    char name[32];
    int size; /* bytes of a scalar, or of an item of a list */
    int kind; /* 'i' signed, 'u' unsigned, 'f' float */
    int list; /* a list: count_size/count_kind give its count */
    int count_size, count_kind;
} prop_t;

typedef struct elem {
    char name[32];
    size_t count;
    prop_t props[MAX_PROPS];
    int n_props;
} elem_t;

static int ply_type(const char *s, int *size, int *kind)
{
    static const struct {
        const char *name;
        int size, kind;
    } types[] = {{"char", 1, 'i'},  {"int8", 1, 'i'},    {"uchar", 1, 'u'},  {"uint8", 1, 'u'},
                 {"short", 2, 'i'}, {"int16", 2, 'i'},   {"ushort", 2, 'u'}, {"uint16", 2, 'u'},
                 {"int", 4, 'i'},   {"int32", 4, 'i'},   {"uint", 4, 'u'},   {"uint32", 4, 'u'},
                 {"float", 4, 'f'}, {"float32", 4, 'f'}, {"double", 8, 'f'}, {"float64", 8, 'f'}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (!strcmp(s, types[i].name)) {
            *size = types[i].size;
            *kind = types[i].kind;
            return 0;
        }
    return -1;
}

/* The little-endian bytes at b as an integer of size bytes (two's complement
 * for 'i'), assembled byte by byte: the host's byte order does not matter. */
static uint64_t le_bits(const unsigned char *b, int size)
{
    uint64_t v = 0;
    for (int i = size - 1; i >= 0; i--)
        v = v << 8 | b[i];
    return v;
}

static double le_number(const unsigned char *b, int size, int kind)
{
    uint64_t v = le_bits(b, size);
    if (kind == 'f') {
        if (size == 4) {
            uint32_t w = (uint32_t)v;
            float f;
            memcpy(&f, &w, sizeof f);
            return f;
        }
        double d;
        memcpy(&d, &v, sizeof d);
        return d;
    }
    if (kind == 'i' && size < 8 && (v >> (8 * size - 1) & 1))
        return (double)(int64_t)(v | ~(uint64_t)0 << (8 * size));
    return (double)v;
}

static void ply_read(const char *path, mesh_t *m)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        die("cannot open", path);
    fseek(fp, 0, SEEK_END);
    long len = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    if (len <= 0)
        die("empty file", path);
    unsigned char *buf = xmalloc((size_t)len + 1);
    if (fread(buf, 1, (size_t)len, fp) != (size_t)len)
        die("read error", path);
    fclose(fp);
    buf[len] = 0;
    char *end = strstr((char *)buf, "end_header\n");
    if (strncmp((char *)buf, "ply\n", 4) || !end)
        die("not a PLY file with a header", path);
    size_t pos = (size_t)(end - (char *)buf) + strlen("end_header\n");
    *end = 0;

    elem_t el[MAX_ELEMS];
    int ne = 0;
    int little = 0;
    for (char *save = NULL, *line = strtok_r((char *)buf + 4, "\n", &save); line;
         line = strtok_r(NULL, "\n", &save)) {
        char a[32] = "", b[32] = "", c[32] = "", d[32] = "", e[32] = "";
        int n = sscanf(line, "%31s %31s %31s %31s %31s", a, b, c, d, e);
        if (n >= 2 && !strcmp(a, "format"))
            little = !strcmp(b, "binary_little_endian");
        else if (n == 3 && !strcmp(a, "element")) {
            if (ne == MAX_ELEMS)
                die("too many elements", path);
            memset(&el[ne], 0, sizeof el[ne]);
            snprintf(el[ne].name, sizeof el[ne].name, "%s", b);
            el[ne].count = strtoull(c, NULL, 10);
            ne++;
        } else if (n >= 3 && !strcmp(a, "property")) {
            if (!ne || el[ne - 1].n_props == MAX_PROPS)
                die("bad property line", path);
            prop_t *p = &el[ne - 1].props[el[ne - 1].n_props++];
            memset(p, 0, sizeof *p);
            if (!strcmp(b, "list")) {
                if (n != 5 || ply_type(c, &p->count_size, &p->count_kind) ||
                    ply_type(d, &p->size, &p->kind))
                    die("bad list property", path);
                p->list = 1;
                snprintf(p->name, sizeof p->name, "%s", e);
            } else {
                if (ply_type(b, &p->size, &p->kind))
                    die("unknown property type", path);
                snprintf(p->name, sizeof p->name, "%s", c);
            }
        }
    }
    if (!little)
        die("not binary_little_endian", path);

    memset(m, 0, sizeof *m);
    m->point_type = "?";
    size_t cap_tris = 0;
    for (int k = 0; k < ne; k++) {
        elem_t *E = &el[k];
        int is_vertex = !strcmp(E->name, "vertex"), is_face = !strcmp(E->name, "face");
        int ix[3] = {-1, -1, -1};
        if (is_vertex) {
            for (int j = 0; j < E->n_props; j++)
                for (int a = 0; a < 3; a++)
                    if (!E->props[j].list && E->props[j].name[0] == "xyz"[a] &&
                        !E->props[j].name[1])
                        ix[a] = j;
            if (ix[0] < 0 || ix[1] < 0 || ix[2] < 0)
                die("vertex without x y z", path);
            m->point_type = E->props[ix[0]].size == 8 ? "double" : "float";
            m->nv = E->count;
            m->pts = xmalloc(3 * E->count * sizeof *m->pts);
        }
        if (is_face) {
            cap_tris = E->count + 16;
            m->tris = xmalloc(3 * cap_tris * sizeof *m->tris);
        }
        for (size_t r = 0; r < E->count; r++)
            for (int j = 0; j < E->n_props; j++) {
                const prop_t *p = &E->props[j];
                if (!p->list) {
                    if (pos + (size_t)p->size > (size_t)len)
                        die("truncated", path);
                    if (is_vertex)
                        for (int a = 0; a < 3; a++)
                            if (ix[a] == j)
                                m->pts[3 * r + (size_t)a] = le_number(buf + pos, p->size, p->kind);
                    pos += (size_t)p->size;
                    continue;
                }
                if (pos + (size_t)p->count_size > (size_t)len)
                    die("truncated", path);
                size_t cnt = (size_t)le_number(buf + pos, p->count_size, p->count_kind);
                pos += (size_t)p->count_size;
                if (pos + cnt * (size_t)p->size > (size_t)len)
                    die("truncated", path);
                if (is_face &&
                    (!strcmp(p->name, "vertex_indices") || !strcmp(p->name, "vertex_index"))) {
                    if (cnt < 3)
                        die("a face with fewer than 3 vertices", path);
                    /* a polygon as a fan from its first vertex (ivoct writes triangles) */
                    uint32_t v0 = (uint32_t)le_number(buf + pos, p->size, p->kind);
                    for (size_t q = 1; q + 1 < cnt; q++) {
                        if (m->nt == cap_tris) {
                            cap_tris *= 2;
                            m->tris = realloc(m->tris, 3 * cap_tris * sizeof *m->tris);
                            if (!m->tris)
                                die("out of memory", path);
                        }
                        uint32_t *t = &m->tris[3 * m->nt++];
                        t[0] = v0;
                        t[1] =
                            (uint32_t)le_number(buf + pos + q * (size_t)p->size, p->size, p->kind);
                        t[2] = (uint32_t)le_number(buf + pos + (q + 1) * (size_t)p->size, p->size,
                                                   p->kind);
                    }
                }
                pos += cnt * (size_t)p->size;
            }
    }
    free(buf);
    if (!m->pts)
        die("no vertex element", path);
    for (size_t i = 0; i < 3 * m->nt; i++)
        if (m->tris[i] >= m->nv)
            die("a vertex index out of range", path);
}

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* ---- projection onto f = 0 ---------------------------------------------------------- */

typedef struct projector {
    const tape_t *t;
    double scale; /* the box's diagonal */
    double delta; /* the half-length of the proving segment (at least) */
    int total;    /* tape_is_total: f continuous everywhere, nothing to check */
    int mpfi_all; /* prove every point with MPFI, not only where doubles cannot */
} projector_t;

/* Per thread: the double evaluator's workspace and MPFI variables. */
typedef struct pws {
    tape_ws_t *ws;
    iv_t *slots;
    mpfi_t v, g[3];
} pws_t;

static void pws_init(pws_t *w, const tape_t *t)
{
    w->ws = tape_ws_new(t->n);
    w->slots = xmalloc(t->n * sizeof *w->slots);
    if (!w->ws)
        die("out of memory", "tape workspace");
    mpfi_init2(w->v, ORACLE_PREC);
    for (int k = 0; k < 3; k++)
        mpfi_init2(w->g[k], ORACLE_PREC);
}

static void pws_free(pws_t *w)
{
    tape_ws_free(w->ws);
    free(w->slots);
    mpfi_clear(w->v);
    for (int k = 0; k < 3; k++)
        mpfi_clear(w->g[k]);
}

/* The ends q -+ delta n of the proving segment, and whether f is proved
 * continuous on it (on the box that holds both ends). */
static int segment(const projector_t *P, pws_t *w, const double q[3], const double n[3],
                   double a[3], double b[3])
{
    /* delta, or 2^-44 of q's largest coordinate if more: far from the origin
     * (the offset sphere at x = 1e6) 2^-40 of the box is below a double's
     * spacing, and q -+ delta n would round to q */
    double m = fmax(fabs(q[0]), fmax(fabs(q[1]), fabs(q[2]))), d = fmax(P->delta, ldexp(m, -44));
    for (int k = 0; k < 3; k++) {
        a[k] = q[k] - d * n[k];
        b[k] = q[k] + d * n[k];
    }
    if (P->total)
        return 1;
    iv_box_t box = {{fmin(a[0], b[0]), fmax(a[0], b[0])},
                    {fmin(a[1], b[1]), fmax(a[1], b[1])},
                    {fmin(a[2], b[2]), fmax(a[2], b[2])}};
    return tape_check_continuous(P->t, &box, w->slots, NULL) == TAPE_DOMAIN_CONTINUOUS;
}

/* The certified sign of f at p (MPFI): +1, -1, or 0 when not decided. */
static int mpfi_sign(const projector_t *P, pws_t *w, const double p[3])
{
    if (oracle_eval(P->t, p, ORACLE_CONST_LO, w->v, NULL))
        return 0;
    return mpfi_is_strictly_pos(w->v) ? 1 : mpfi_is_strictly_neg(w->v) ? -1 : 0;
}

/* Is there a zero of f within delta of q, across the direction n (MPFI)? */
static int mpfi_prove(const projector_t *P, pws_t *w, const double q[3], const double n[3])
{
    double a[3], b[3];
    if (!segment(P, w, q, n, a, b))
        return 0;
    int sa = mpfi_sign(P, w, a);
    return sa != 0 && sa == -mpfi_sign(P, w, b);
}

/* One MPFI Newton step from q (f and grad f at 256 bits, the step rounded to
 * doubles once); the unit gradient in n.  0, or -1 where f or grad f is not
 * defined or the gradient vanishes. */
static int mpfi_step(const projector_t *P, pws_t *w, double q[3], double n[3])
{
    if (oracle_eval(P->t, q, ORACLE_CONST_LO, w->v, w->g))
        return -1;
    double f = mpfi_get_d(w->v), g[3], gg = 0;
    for (int k = 0; k < 3; k++) {
        g[k] = mpfi_get_d(w->g[k]);
        gg += g[k] * g[k];
    }
    if (!(gg > 0) || !isfinite(gg) || !isfinite(f))
        return -1;
    double s = sqrt(gg);
    for (int k = 0; k < 3; k++) {
        q[k] -= f / gg * g[k];
        n[k] = g[k] / s;
    }
    return 0;
}

/* How a point's projection was proved. */
enum { PROJ_FAILED = -1, PROJ_DOUBLE = 0, PROJ_MPFI = 1, PROJ_MPFI_NEWTON = 2 };

/* Project the n <= TAPE_BATCH points p (3 doubles each) onto f = 0: q (3
 * doubles each) and status[i] (PROJ_*). */
static void project_batch(const projector_t *P, pws_t *w, size_t n, const double *p, double *q,
                          int *status)
{
    iv_box_t box[2 * TAPE_BATCH];
    iv_grad_t gr[TAPE_BATCH];
    iv_t fv[2 * TAPE_BATCH];
    double nrm[TAPE_BATCH][3];
    int live[TAPE_BATCH], cont[TAPE_BATCH];
    const double settle = ldexp(P->scale, -30);
    memcpy(q, p, 3 * n * sizeof *q);
    for (size_t i = 0; i < n; i++) {
        live[i] = 1;
        nrm[i][0] = nrm[i][1] = nrm[i][2] = 0;
    }
    /* Newton steps on the double evaluator (the midpoints of its enclosures)
     * while they move the point by more than 2^-30 of the box */
    for (int it = 0; it < 16; it++) {
        int any = 0;
        for (size_t i = 0; i < n; i++) {
            box[i].x = iv_point(q[3 * i]);
            box[i].y = iv_point(q[3 * i + 1]);
            box[i].z = iv_point(q[3 * i + 2]);
        }
        tape_eval_grad(P->t, w->ws, n, box, gr);
        for (size_t i = 0; i < n; i++) {
            if (!live[i])
                continue;
            double f = iv_mid(gr[i].v),
                   g[3] = {iv_mid(gr[i].dx), iv_mid(gr[i].dy), iv_mid(gr[i].dz)};
            double gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            if (!(gg > 0) || !isfinite(gg) || !isfinite(f)) {
                live[i] = 0;
                continue;
            }
            double step = 0, s = sqrt(gg);
            for (int k = 0; k < 3; k++) {
                double d = f / gg * g[k];
                q[3 * i + (size_t)k] -= d;
                step += d * d;
                nrm[i][k] = g[k] / s;
            }
            if (sqrt(step) > settle)
                any = 1;
            else
                live[i] = 0;
        }
        if (!any)
            break;
    }
    /* The proof on the double interval evaluator first (rigorous, and enough
     * wherever |f| at delta from the zero is above its rounding) */
    for (size_t i = 0; i < n; i++) {
        double a[3], b[3], d2 = 0;
        const double *qi = &q[3 * i], *pi = &p[3 * i];
        for (int k = 0; k < 3; k++)
            d2 += (qi[k] - pi[k]) * (qi[k] - pi[k]);
        /* a point that strayed (or diverged) is not evaluated: the MPFI
         * loop below gives it up */
        if (!(sqrt(d2) <= 0.1 * P->scale)) {
            cont[i] = 0;
            memcpy(a, pi, sizeof a);
            memcpy(b, pi, sizeof b);
        } else {
            cont[i] = segment(P, w, qi, nrm[i], a, b);
        }
        box[2 * i] = (iv_box_t){iv_point(a[0]), iv_point(a[1]), iv_point(a[2])};
        box[2 * i + 1] = (iv_box_t){iv_point(b[0]), iv_point(b[1]), iv_point(b[2])};
    }
    if (!P->mpfi_all)
        tape_eval_interval(P->t, w->ws, 2 * n, box, fv);
    for (size_t i = 0; i < n; i++) {
        double *qi = &q[3 * i];
        const double *pi = &p[3 * i];
        status[i] = PROJ_FAILED;
        if (!P->mpfi_all && cont[i] && dot3(nrm[i], nrm[i]) > 0 &&
            ((fv[2 * i].hi < 0 && fv[2 * i + 1].lo > 0) ||
             (fv[2 * i].lo > 0 && fv[2 * i + 1].hi < 0))) {
            status[i] = PROJ_DOUBLE;
            continue;
        }
        /* MPFI: the proof where the doubles stopped, then Newton steps with f
         * and grad f at 256 bits where it fails */
        for (int steps = 0;; steps++) {
            double d2 = 0;
            for (int k = 0; k < 3; k++)
                d2 += (qi[k] - pi[k]) * (qi[k] - pi[k]);
            if (!isfinite(d2) || sqrt(d2) > 0.1 * P->scale)
                break;
            if (dot3(nrm[i], nrm[i]) > 0 && mpfi_prove(P, w, qi, nrm[i])) {
                status[i] = steps ? PROJ_MPFI_NEWTON : PROJ_MPFI;
                break;
            }
            if (steps == 24 || mpfi_step(P, w, qi, nrm[i]))
                break;
        }
    }
}

/* ---- nearest triangle: a uniform grid ---------------------------------------------- */

typedef struct grid {
    double lo[3], h;
    uint32_t dim[3];
    uint32_t *start; /* per cell + 1: offsets into items */
    uint32_t *items; /* triangle indices */
} grid_t;

static uint32_t cell_coord(const grid_t *g, int k, double x)
{
    double c = floor((x - g->lo[k]) / g->h);
    if (!(c > 0))
        return 0;
    if (c >= g->dim[k] - 1)
        return g->dim[k] - 1;
    return (uint32_t)c;
}

static size_t cell_index(const grid_t *g, uint32_t i, uint32_t j, uint32_t k)
{
    return ((size_t)k * g->dim[1] + j) * g->dim[0] + i;
}

static void tri_bounds(const mesh_t *m, size_t t, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
        for (int v = 0; v < 3; v++) {
            double x = m->pts[3 * (size_t)m->tris[3 * t + (size_t)v] + (size_t)k];
            lo[k] = fmin(lo[k], x);
            hi[k] = fmax(hi[k], x);
        }
    }
}

/* Cells about two mean edge lengths wide: a few triangles per occupied cell. */
static void grid_build(grid_t *g, const mesh_t *m, const double *qpts, size_t nq)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double edge = 0;
    for (size_t t = 0; t < m->nt; t++) {
        double a[3], b[3];
        tri_bounds(m, t, a, b);
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], a[k]);
            hi[k] = fmax(hi[k], b[k]);
        }
        edge += fmax(b[0] - a[0], fmax(b[1] - a[1], b[2] - a[2]));
    }
    for (size_t i = 0; i < nq; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], qpts[3 * i + (size_t)k]);
            hi[k] = fmax(hi[k], qpts[3 * i + (size_t)k]);
        }
    double span = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    g->h = fmax(2 * edge / (double)(m->nt ? m->nt : 1), span / 512);
    if (!(g->h > 0))
        g->h = 1;
    for (int k = 0; k < 3; k++) {
        g->lo[k] = lo[k];
        g->dim[k] = (uint32_t)fmin(512, floor((hi[k] - lo[k]) / g->h) + 1);
    }
    size_t cells = (size_t)g->dim[0] * g->dim[1] * g->dim[2];
    uint32_t *cnt = calloc(cells + 1, sizeof *cnt);
    if (!cnt)
        die("out of memory", "grid");
    for (int pass = 0; pass < 2; pass++) {
        for (size_t t = 0; t < m->nt; t++) {
            double a[3], b[3];
            tri_bounds(m, t, a, b);
            uint32_t c0[3], c1[3];
            for (int k = 0; k < 3; k++) {
                c0[k] = cell_coord(g, k, a[k]);
                c1[k] = cell_coord(g, k, b[k]);
            }
            for (uint32_t z = c0[2]; z <= c1[2]; z++)
                for (uint32_t y = c0[1]; y <= c1[1]; y++)
                    for (uint32_t x = c0[0]; x <= c1[0]; x++) {
                        size_t c = cell_index(g, x, y, z);
                        if (pass == 0)
                            cnt[c + 1]++;
                        else
                            g->items[g->start[c] + cnt[c]++] = (uint32_t)t;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < cells; c++)
                cnt[c + 1] += cnt[c];
            g->start = cnt;
            g->items = xmalloc((size_t)cnt[cells] * sizeof *g->items);
            cnt = calloc(cells, sizeof *cnt);
            if (!cnt)
                die("out of memory", "grid");
        }
    }
    free(cnt);
}

static double seg_dist2(const double *p, const double *a, const double *b)
{
    double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
           ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double l = dot3(ab, ab), s = l > 0 ? dot3(ap, ab) / l : 0;
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    double d[3] = {ap[0] - s * ab[0], ap[1] - s * ab[1], ap[2] - s * ab[2]};
    return dot3(d, d);
}

/* Squared distance from p to the triangle abc (closed).  If the foot of p in
 * the triangle's plane lies inside (barycentric coordinates >= 0) it is the
 * closest point; otherwise the closest point is on the boundary, the nearest
 * of the three sides (the triangle is convex).  Degenerate: the sides. */
static double tri_dist2(const double *p, const double *a, const double *b, const double *c)
{
    double e0[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
           e1[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double w[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double d00 = dot3(e0, e0), d01 = dot3(e0, e1), d11 = dot3(e1, e1);
    double d20 = dot3(w, e0), d21 = dot3(w, e1), den = d00 * d11 - d01 * d01;
    if (den > 1e-24 * d00 * d11) {
        double v = (d11 * d20 - d01 * d21) / den, u = (d00 * d21 - d01 * d20) / den;
        if (v >= 0 && u >= 0 && u + v <= 1) {
            double n[3] = {e0[1] * e1[2] - e0[2] * e1[1], e0[2] * e1[0] - e0[0] * e1[2],
                           e0[0] * e1[1] - e0[1] * e1[0]};
            double h = dot3(w, n);
            return h * h / dot3(n, n);
        }
    }
    return fmin(seg_dist2(p, a, b), fmin(seg_dist2(p, b, c), seg_dist2(p, c, a)));
}

/* The squared distance from p to the nearest triangle of one cell not seen
 * yet for this stamp (marking them seen). */
static double cell_nearest(const grid_t *g, const mesh_t *m, const double *p, size_t cell,
                           uint32_t *seen, uint32_t stamp)
{
    double best = INFINITY;
    for (uint32_t j = g->start[cell]; j < g->start[cell + 1]; j++) {
        uint32_t t = g->items[j];
        if (seen[t] == stamp)
            continue;
        seen[t] = stamp;
        const uint32_t *v = &m->tris[3 * (size_t)t];
        best = fmin(best, tri_dist2(p, &m->pts[3 * (size_t)v[0]], &m->pts[3 * (size_t)v[1]],
                                    &m->pts[3 * (size_t)v[2]]));
    }
    return best;
}

/* Distance from p to the nearest triangle: shells of cells around p's cell,
 * until every triangle not yet seen is provably farther (its bounding box
 * misses the block searched, so it lies beyond the block's faces). */
static double nearest(const grid_t *g, const mesh_t *m, const double *p, uint32_t *seen,
                      uint32_t stamp)
{
    uint32_t c[3];
    for (int k = 0; k < 3; k++)
        c[k] = cell_coord(g, k, p[k]);
    double best = INFINITY;
    for (long r = 0;; r++) {
        long lo[3], hi[3];
        int whole = 1;
        for (int k = 0; k < 3; k++) {
            lo[k] = (long)c[k] - r;
            hi[k] = (long)c[k] + r;
            whole &= lo[k] <= 0 && hi[k] >= (long)g->dim[k] - 1;
        }
        /* the shell only (the inside was searched), within the grid: whole
         * rows on its faces, the two ends of a row elsewhere */
        for (long z = lo[2] < 0 ? 0 : lo[2]; z <= hi[2] && z < (long)g->dim[2]; z++)
            for (long y = lo[1] < 0 ? 0 : lo[1]; y <= hi[1] && y < (long)g->dim[1]; y++) {
                int face = z == lo[2] || z == hi[2] || y == lo[1] || y == hi[1];
                long x0 = lo[0] < 0 ? 0 : lo[0],
                     x1 = hi[0] < (long)g->dim[0] ? hi[0] : (long)g->dim[0] - 1;
                for (long x = x0; x <= x1; x++) {
                    if (!face && x != lo[0] && x != hi[0]) {
                        if (hi[0] > x1)
                            break;
                        x = hi[0]; /* jump over the inside */
                    }
                    best = fmin(best,
                                cell_nearest(g, m, p,
                                             cell_index(g, (uint32_t)x, (uint32_t)y, (uint32_t)z),
                                             seen, stamp));
                }
            }
        if (whole)
            return sqrt(best);
        /* beyond the block: at least the distance from p to its nearest face
         * that has cells behind it */
        double out = INFINITY;
        for (int k = 0; k < 3; k++) {
            if (lo[k] > 0)
                out = fmin(out, p[k] - (g->lo[k] + (double)lo[k] * g->h));
            if (hi[k] < (long)g->dim[k] - 1)
                out = fmin(out, g->lo[k] + (double)(hi[k] + 1) * g->h - p[k]);
        }
        if (out > 0 && best <= out * out)
            return sqrt(best);
    }
}

/* ---- samples on the triangles --------------------------------------------------------- */

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static void push(double **s, size_t *n, size_t *cap, const double p[3])
{
    if (*n == *cap) {
        *cap = *cap ? 2 * *cap : 1024;
        *s = realloc(*s, 3 * *cap * sizeof **s);
        if (!*s)
            die("out of memory", "samples");
    }
    memcpy(*s + 3 * *n, p, 3 * sizeof **s);
    (*n)++;
}

/* Each used vertex, each edge's midpoint (once), each centroid; on a triangle
 * whose longest edge L exceeds twice the median edge s, the barycentric grid
 * of ceil(L / s) (at most 16) steps, less its corners. */
static double *mesh_samples(const mesh_t *m, size_t *count)
{
    double *s = NULL;
    size_t n = 0, cap = 0;
    unsigned char *used = calloc(m->nv ? m->nv : 1, 1);
    uint64_t *edges = xmalloc(3 * (m->nt ? m->nt : 1) * sizeof *edges);
    if (!used)
        die("out of memory", "samples");
    size_t ne = 0;
    for (size_t t = 0; t < m->nt; t++)
        for (int e = 0; e < 3; e++) {
            uint32_t a = m->tris[3 * t + (size_t)e], b = m->tris[3 * t + (size_t)(e + 1) % 3];
            used[a] = 1;
            if (a != b)
                edges[ne++] = (uint64_t)(a < b ? a : b) << 32 | (a < b ? b : a);
        }
    qsort(edges, ne, sizeof *edges, cmp_u64);
    size_t nu = 0;
    for (size_t i = 0; i < ne; i++)
        if (!nu || edges[i] != edges[nu - 1])
            edges[nu++] = edges[i];
    double *len = xmalloc((nu ? nu : 1) * sizeof *len);
    for (size_t v = 0; v < m->nv; v++)
        if (used[v])
            push(&s, &n, &cap, &m->pts[3 * v]);
    for (size_t i = 0; i < nu; i++) {
        const double *a = &m->pts[3 * (edges[i] >> 32)], *b = &m->pts[3 * (edges[i] & 0xffffffffu)];
        double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
        double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        len[i] = sqrt(dot3(d, d));
        push(&s, &n, &cap, mid);
    }
    qsort(len, nu, sizeof *len, cmp_double);
    double med = nu ? len[nu / 2] : 0;
    for (size_t t = 0; t < m->nt; t++) {
        const double *P[3];
        for (int v = 0; v < 3; v++)
            P[v] = &m->pts[3 * (size_t)m->tris[3 * t + (size_t)v]];
        double c[3];
        for (int k = 0; k < 3; k++)
            c[k] = (P[0][k] + P[1][k] + P[2][k]) / 3;
        push(&s, &n, &cap, c);
        double L = 0;
        for (int e = 0; e < 3; e++) {
            const double *a = P[e], *b = P[(e + 1) % 3];
            double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            L = fmax(L, sqrt(dot3(d, d)));
        }
        if (!(med > 0) || !(L > 2 * med))
            continue;
        int steps = (int)fmin(16, ceil(L / med));
        for (int i = 0; i <= steps; i++)
            for (int j = 0; i + j <= steps; j++) {
                int k = steps - i - j;
                if (i == steps || j == steps || k == steps)
                    continue; /* a corner: sampled as a vertex */
                double x[3];
                for (int a = 0; a < 3; a++)
                    x[a] =
                        ((double)i * P[0][a] + (double)j * P[1][a] + (double)k * P[2][a]) / steps;
                push(&s, &n, &cap, x);
            }
    }
    free(used);
    free(edges);
    free(len);
    *count = n;
    return s;
}

/* Project n points (in place when q == p is not wanted: q separate) over the
 * threads; per point its status (see project_batch). */
static void project_all(const projector_t *P, size_t n, const double *p, double *q, int *status)
{
#pragma omp parallel
    {
        pws_t w;
        pws_init(&w, P->t);
#pragma omp for schedule(dynamic, 4)
        for (size_t b = 0; b < (n + TAPE_BATCH - 1) / TAPE_BATCH; b++) {
            size_t i0 = b * TAPE_BATCH, k = n - i0 < TAPE_BATCH ? n - i0 : TAPE_BATCH;
            project_batch(P, &w, k, p + 3 * i0, q + 3 * i0, status + i0);
        }
        pws_free(&w);
    }
}

int main(int argc, char **argv)
{
    const char *scene_path = NULL, *mesh_path = NULL, *ref_path = NULL;
    int intersections = 1, ref_project = 0, threads = 0, mpfi_all = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--reference") && i + 1 < argc)
            ref_path = argv[++i];
        else if (!strcmp(argv[i], "--reference-project"))
            ref_project = 1;
        else if (!strcmp(argv[i], "--mpfi-all"))
            mpfi_all = 1;
        else if (!strcmp(argv[i], "--no-intersections"))
            intersections = 0;
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (argv[i][0] == '-')
            usage();
        else if (!scene_path)
            scene_path = argv[i];
        else if (!mesh_path)
            mesh_path = argv[i];
        else
            usage();
    }
    if (!scene_path || !mesh_path)
        usage();
    if (threads > 0)
        omp_set_num_threads(threads);

    scene_t sc;
    ivoct_error_t err;
    if (scene_load(scene_path, &sc, &err)) {
        char buf[512];
        fprintf(stderr, "ivoct_mesh_quality: %s\n", ivoct_error_format(&err, buf, sizeof buf));
        return 1;
    }
    mesh_t m;
    ply_read(mesh_path, &m);

    double t0 = now();
    mc_report_t r;
    if (mc_check(m.pts, m.nv, m.tris, m.nt, intersections, &r))
        die("mc_check refused the mesh", mesh_path);
    double t_topology = now() - t0;

    const double *B = sc.box;
    double diag = sqrt((B[1] - B[0]) * (B[1] - B[0]) + (B[3] - B[2]) * (B[3] - B[2]) +
                       (B[5] - B[4]) * (B[5] - B[4]));
    projector_t P = {sc.tape, diag, ldexp(diag, -40), tape_is_total(sc.tape), mpfi_all};

    t0 = now();
    size_t ns;
    double *s = mesh_samples(&m, &ns);
    double *q = xmalloc(3 * (ns ? ns : 1) * sizeof *q);
    int *st = xmalloc((ns ? ns : 1) * sizeof *st);
    project_all(&P, ns, s, q, st);
    double smax = 0, ssum = 0;
    size_t sn = 0, unconv = 0, by_mpfi = 0, mpfi_newton = 0, imax = 0;
    for (size_t i = 0; i < ns; i++) {
        if (st[i] < 0) {
            unconv++;
            continue;
        }
        by_mpfi += st[i] == PROJ_MPFI;
        mpfi_newton += st[i] == PROJ_MPFI_NEWTON;
        double d[3] = {q[3 * i] - s[3 * i], q[3 * i + 1] - s[3 * i + 1],
                       q[3 * i + 2] - s[3 * i + 2]};
        double dist = sqrt(dot3(d, d));
        if (dist > smax) {
            smax = dist;
            imax = i;
        }
        ssum += dist;
        sn++;
    }
    /* the farthest sample's surface point proved again with MPFI, whatever
     * proved it first: the maximum is the number quoted */
    int max_mpfi = 0;
    if (sn) {
        pws_t w;
        pws_init(&w, P.t);
        double n[3], qq[3];
        memcpy(qq, &q[3 * imax], sizeof qq);
        if (!oracle_eval(P.t, qq, ORACLE_CONST_LO, w.v, w.g)) {
            double gn = 0;
            for (int k = 0; k < 3; k++) {
                n[k] = mpfi_get_d(w.g[k]);
                gn += n[k] * n[k];
            }
            for (int k = 0; k < 3; k++)
                n[k] /= sqrt(gn);
            max_mpfi = gn > 0 && mpfi_prove(&P, &w, qq, n);
        }
        pws_free(&w);
    }
    double t_to_surface = now() - t0;

    double mmax = NAN, msum = 0, t_to_mesh = 0;
    size_t mn = 0, ref_unconv = 0;
    if (ref_path) {
        t0 = now();
        mesh_t ref;
        ply_read(ref_path, &ref);
        /* the reference's used vertices only */
        unsigned char *used = calloc(ref.nv ? ref.nv : 1, 1);
        if (!used)
            die("out of memory", ref_path);
        for (size_t i = 0; i < 3 * ref.nt; i++)
            used[ref.tris[i]] = 1;
        double *rp = xmalloc(3 * (ref.nv ? ref.nv : 1) * sizeof *rp);
        size_t nr = 0;
        for (size_t v = 0; v < ref.nv; v++)
            if (used[v])
                memcpy(&rp[3 * nr++], &ref.pts[3 * v], 3 * sizeof *rp);
        free(used);
        if (ref_project) {
            double *rq = xmalloc(3 * (nr ? nr : 1) * sizeof *rq);
            int *rs = xmalloc((nr ? nr : 1) * sizeof *rs);
            project_all(&P, nr, rp, rq, rs);
            size_t k = 0;
            for (size_t i = 0; i < nr; i++) {
                if (rs[i] < 0) {
                    ref_unconv++;
                    continue;
                }
                memcpy(&rp[3 * k++], &rq[3 * i], 3 * sizeof *rp);
            }
            nr = k;
            free(rq);
            free(rs);
        }
        grid_t g;
        grid_build(&g, &m, rp, nr);
        double *dist = xmalloc((nr ? nr : 1) * sizeof *dist);
#pragma omp parallel
        {
            uint32_t *seen = calloc(m.nt ? m.nt : 1, sizeof *seen);
            if (!seen)
                die("out of memory", "grid");
#pragma omp for schedule(dynamic, 256)
            for (size_t i = 0; i < nr; i++)
                dist[i] = m.nt ? nearest(&g, &m, &rp[3 * i], seen, (uint32_t)i + 1) : INFINITY;
            free(seen);
        }
        mmax = 0;
        for (size_t i = 0; i < nr; i++) {
            mmax = fmax(mmax, dist[i]);
            msum += dist[i];
        }
        mn = nr;
        free(dist);
        free(g.start);
        free(g.items);
        free(rp);
        free(ref.pts);
        free(ref.tris);
        t_to_mesh = now() - t0;
    }

    printf("{\"mesh\":\"%s\",\"point_type\":\"%s\",\"triangles\":%zu,\"vertices\":%zu,"
           "\"edges\":%zu,\"degenerate_triangles\":%zu,\"boundary_edges\":%zu,"
           "\"nonmanifold_edges\":%zu,\"nonmanifold_vertices\":%zu,\"misoriented_edges\":%zu,"
           "\"euler\":%ld,\"components\":%zu,\"intersections_checked\":%d,"
           "\"intersecting_pairs\":%zu,\"coincident_vertices\":%zu,\"closed_embedded\":%d,"
           "\"signed_volume\":%.9g,",
           mesh_path, m.point_type, r.triangles, r.vertices, r.edges, r.degenerate_triangles,
           r.boundary_edges, r.nonmanifold_edges, r.nonmanifold_vertices, r.misoriented_edges,
           r.euler, r.components, r.intersections_checked, r.intersecting_pairs,
           r.coincident_vertices, mc_is_closed_embedded(&r), mc_signed_volume(m.pts, m.tris, m.nt));
    /* JSON has no NaN: a distance over no points is null */
    char smax_s[32] = "null", smean_s[32] = "null", mmax_s[32] = "null", mmean_s[32] = "null",
         haus_s[32] = "null";
    if (sn) {
        snprintf(smax_s, sizeof smax_s, "%.6e", smax);
        snprintf(smean_s, sizeof smean_s, "%.6e", ssum / (double)sn);
    }
    if (mn && m.nt) {
        snprintf(mmax_s, sizeof mmax_s, "%.6e", mmax);
        snprintf(mmean_s, sizeof mmean_s, "%.6e", msum / (double)mn);
        if (sn)
            snprintf(haus_s, sizeof haus_s, "%.6e", fmax(smax, mmax));
    }
    printf("\"to_surface_samples\":%zu,\"to_surface_max\":%s,\"to_surface_mean\":%s,"
           "\"to_surface_unconverged\":%zu,\"to_surface_mpfi\":%zu,"
           "\"to_surface_mpfi_newton\":%zu,\"to_surface_max_mpfi_proved\":%d,",
           sn, smax_s, smean_s, unconv, by_mpfi, mpfi_newton, max_mpfi);
    if (ref_path)
        printf("\"reference_points\":%zu,\"reference_unconverged\":%zu,\"to_mesh_max\":%s,"
               "\"to_mesh_mean\":%s,\"hausdorff\":%s,",
               mn, ref_unconv, mmax_s, mmean_s, haus_s);
    else
        printf("\"reference_points\":0,\"to_mesh_max\":null,\"to_mesh_mean\":null,"
               "\"hausdorff\":null,");
    printf("\"topology_s\":%.3f,\"to_surface_s\":%.3f,\"to_mesh_s\":%.3f}\n", t_topology,
           t_to_surface, t_to_mesh);

    free(s);
    free(q);
    free(st);
    free(m.pts);
    free(m.tris);
    scene_free(&sc);
    return 0;
}
