/* ivoct mesh/ — the certified mesh: subdivision, balance, construction.
 * The algorithm and its argument are in mesh/README.md; the comments here say
 * how the code maps onto it. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include "mesh.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- grid ------------------------------------------------------------------------
 * Cells and points live on the integer grid of the max depth D: a cell of level
 * l at (i, j, k) spans grid coordinates [i << (D - l), (i + 1) << (D - l)] per
 * axis.  A grid coordinate maps to a double by one function (coord), so every
 * cell that shares a face, an edge or a corner sees exactly the same doubles. */

enum kind { K_OPEN, K_INTERNAL, K_EMPTY, K_SURFACE, K_UNRESOLVED };

typedef struct cell {
    uint32_t pos[3]; /* position at its level */
    int32_t child;   /* K_INTERNAL: the first of its 8 children (octant x | y<<1 | z<<2) */
    uint8_t level, kind;
    uint8_t has_apex; /* 1: apex on the surface; 2: off it (at the max depth, none found) */
    double d[3];     /* K_SURFACE: a direction along which f increases strictly in the cell */
    double apex[3];  /* has_apex: a point of the surface strictly inside the cell */
} cell_t;

/* ---- hash map: 128-bit keys to uint32 values (open addressing) -------------------- */

typedef struct hkey {
    uint64_t a, b;
} hkey_t;

typedef struct hmap {
    hkey_t *keys;
    uint32_t *vals;
    size_t cap, n; /* cap a power of 2; a.a == UINT64_MAX marks a free slot */
} hmap_t;

static uint64_t hkey_hash(hkey_t k)
{
    uint64_t h = k.a * 0x9e3779b97f4a7c15u ^ (k.b + 0x632be59bd9b4e019u) * 0xbf58476d1ce4e5b9u;
    return h ^ (h >> 29);
}

/* The slot of k: where it is, or the free slot where it belongs. */
static size_t hmap_slot(const hmap_t *m, hkey_t k)
{
    size_t i = hkey_hash(k) & (m->cap - 1);
    while (m->keys[i].a != UINT64_MAX && (m->keys[i].a != k.a || m->keys[i].b != k.b))
        i = (i + 1) & (m->cap - 1);
    return i;
}

static int hmap_grow(hmap_t *m)
{
    size_t cap = m->cap ? 2 * m->cap : 1024;
    hkey_t *keys = malloc(cap * sizeof *keys);
    uint32_t *vals = malloc(cap * sizeof *vals);
    if (!keys || !vals) {
        free(keys);
        free(vals);
        return -1;
    }
    for (size_t i = 0; i < cap; i++)
        keys[i].a = UINT64_MAX;
    hmap_t g = {keys, vals, cap, 0};
    for (size_t i = 0; i < m->cap; i++)
        if (m->keys[i].a != UINT64_MAX) {
            size_t s = hmap_slot(&g, m->keys[i]);
            g.keys[s] = m->keys[i];
            g.vals[s] = m->vals[i];
            g.n++;
        }
    free(m->keys);
    free(m->vals);
    *m = g;
    return 0;
}

/* The value of k, or UINT32_MAX. */
static uint32_t hmap_get(const hmap_t *m, hkey_t k)
{
    if (!m->cap)
        return UINT32_MAX;
    size_t s = hmap_slot(m, k);
    return m->keys[s].a == UINT64_MAX ? UINT32_MAX : m->vals[s];
}

static int hmap_put(hmap_t *m, hkey_t k, uint32_t v)
{
    if ((m->n + 1) * 2 > m->cap && hmap_grow(m))
        return -1;
    size_t s = hmap_slot(m, k);
    if (m->keys[s].a == UINT64_MAX)
        m->n++;
    m->keys[s] = k;
    m->vals[s] = v;
    return 0;
}

static void hmap_free(hmap_t *m)
{
    free(m->keys);
    free(m->vals);
    memset(m, 0, sizeof *m);
}

/* ---- growable arrays -------------------------------------------------------------- */

/* Make room for n + extra elements of size sz in *p (capacity *cap). */
static int reserve(void *pp, size_t *cap, size_t n, size_t extra, size_t sz)
{
    void **p = pp;
    if (n + extra <= *cap)
        return 0;
    size_t c = *cap ? *cap : 64;
    while (c < n + extra)
        c *= 2;
    void *q = realloc(*p, c * sz);
    if (!q)
        return -1;
    *p = q;
    *cap = c;
    return 0;
}

/* ---- the context -------------------------------------------------------------------- */

/* Sign of f at a point: + (f > 0, or f exactly 0, which counts as positive: a
 * symbolic perturbation, mesh/README.md), - (f < 0), or not certified. */
enum { S_UNKNOWN = 2, S_POS = 1, S_NEG = -1, S_UNCERTAIN = 0 };

typedef struct vinfo {
    uint32_t g[3];
    int8_t sign;
    uint8_t corner; /* a corner of a leaf that may hold surface (this pass) */
} vinfo_t;

typedef struct crossing {
    double p[3];         /* placed: on the surface; else the lower end of its piece of side */
    double end[3];       /* the upper end, until placed */
    uint32_t mesh_index; /* its vertex in the mesh of pass `pass` */
    uint32_t pass;
    int8_t s_lo;         /* the sign at the lower end */
    uint8_t placed;
} crossing_t;

typedef struct ctx {
    const tape_t *t;
    tape_ws_t *ws;
    iv_t *slots; /* t->n, for tape_check_continuous */
    bool smooth; /* f is C^1 on the whole space: no per-cell check needed */
    int D;
    int min_depth;
    size_t max_memory;
    double lo[3], w[3]; /* the mesh box */

    cell_t *cells;
    size_t n_cells, cap_cells;

    hmap_t vmap; /* packed grid point -> index in verts */
    vinfo_t *verts;
    size_t n_verts, cap_verts;

    hmap_t xmap; /* sub-edge -> index in xs */
    crossing_t *xs;
    size_t n_xs, cap_xs;

    uint8_t *mark; /* per cell: split it in this pass's round of splits */
    size_t cap_mark;
    int32_t *queue;
    size_t n_queue, cap_queue;

    msh_mesh_t *out;
    size_t cap_points, cap_tris, cap_tri_cell, cap_cellout, cap_depth, cap_fail;
    int32_t *fail_cell; /* per failure of this pass: its cell */
    size_t cap_fail_cell;
    uint32_t pass;
    ivoct_error_t *err;
} ctx_t;

static double coord(const ctx_t *c, int axis, uint32_t g)
{
    return c->lo[axis] + c->w[axis] * ldexp((double)g, -c->D);
}

static iv_box_t cell_box(const ctx_t *c, const cell_t *cl)
{
    int s = c->D - cl->level;
    iv_t r[3];
    for (int a = 0; a < 3; a++)
        r[a] = iv_make(coord(c, a, cl->pos[a] << s), coord(c, a, (cl->pos[a] + 1) << s));
    iv_box_t b = {r[0], r[1], r[2]};
    return b;
}

static int nomem(ctx_t *c)
{
    ivoct_error_set(c->err, "certified mesh: out of memory");
    return -1;
}

/* The bytes held now, against max_memory. */
static int over_budget(ctx_t *c)
{
    if (!c->max_memory)
        return 0;
    size_t b = c->cap_cells * sizeof *c->cells + c->cap_mark + c->cap_queue * sizeof *c->queue +
               (c->vmap.cap + c->xmap.cap) * (sizeof(hkey_t) + 4) +
               c->cap_verts * sizeof *c->verts + c->cap_xs * sizeof *c->xs +
               c->cap_points * 3 * sizeof(double) + c->cap_tris * 4 * sizeof(uint32_t) +
               c->cap_cellout * (sizeof(iv_box_t) + sizeof(int));
    if (b <= c->max_memory)
        return 0;
    ivoct_error_set(c->err,
                    "certified mesh: memory budget of %zu bytes exceeded (raise --max-memory)",
                    c->max_memory);
    return -1;
}

static int32_t new_cell(ctx_t *c, int level, uint32_t i, uint32_t j, uint32_t k)
{
    if (reserve(&c->cells, &c->cap_cells, c->n_cells, 1, sizeof *c->cells))
        return -1;
    cell_t *cl = &c->cells[c->n_cells];
    memset(cl, 0, sizeof *cl);
    cl->pos[0] = i, cl->pos[1] = j, cl->pos[2] = k;
    cl->level = (uint8_t)level;
    cl->kind = K_OPEN;
    cl->child = -1;
    return (int32_t)c->n_cells++;
}

/* Give cell ci 8 K_OPEN children. */
static int split(ctx_t *c, int32_t ci)
{
    if (reserve(&c->cells, &c->cap_cells, c->n_cells, 8, sizeof *c->cells))
        return nomem(c);
    cell_t p = c->cells[ci];
    int32_t first = (int32_t)c->n_cells;
    for (int o = 0; o < 8; o++)
        new_cell(c, p.level + 1, 2 * p.pos[0] + (o & 1), 2 * p.pos[1] + (o >> 1 & 1),
                 2 * p.pos[2] + (o >> 2));
    c->cells[ci].kind = K_INTERNAL;
    c->cells[ci].child = first;
    return over_budget(c);
}

/* The leaf that holds the cell of level l at pos, or the internal node at
 * level l there. */
static int32_t find(const ctx_t *c, int l, const uint32_t pos[3])
{
    int32_t ci = 0;
    while (c->cells[ci].kind == K_INTERNAL && c->cells[ci].level < l) {
        int sh = l - c->cells[ci].level - 1;
        int o = (int)(pos[0] >> sh & 1) | (int)(pos[1] >> sh & 1) << 1 |
                (int)(pos[2] >> sh & 1) << 2;
        ci = c->cells[ci].child + o;
    }
    return ci;
}

static bool may_hold_surface(const cell_t *cl)
{
    return cl->kind == K_SURFACE || cl->kind == K_UNRESOLVED;
}

/* ---- classification ----------------------------------------------------------------- */

/* Does 0 lie outside F? (Also when f is defined nowhere on the box: empty.) */
static bool excludes_zero(iv_t f)
{
    return iv_is_empty(f) || f.lo > 0 || f.hi < 0;
}

/* The cell condition of Plantinga and Vegter: 0 not in <G, G>, where the product
 * takes its two factors independently (the set of <g1, g2> for g1, g2 in G), so
 * any two gradients in the cell make an acute angle; then <g, mid G> > 0 for every
 * g in G and f increases strictly along d = mid G.  The interval gradient bounds
 * every derivative only where f is C^1, which the caller has proved
 * (tape_check_continuous). */
static bool gradient_condition(const iv_grad_t *g, double d[3])
{
    iv_t s = iv_add(iv_add(iv_mul(g->dx, g->dx), iv_mul(g->dy, g->dy)), iv_mul(g->dz, g->dz));
    if (iv_is_empty(s) || !(s.lo > 0) || !isfinite(s.hi))
        return false;
    d[0] = iv_mid(g->dx), d[1] = iv_mid(g->dy), d[2] = iv_mid(g->dz);
    return true;
}

/* The mean value form f(m) + G . (X - m) over box X with centre m: an enclosure
 * of f where f is C^1, far tighter than F near a critical point of f, where the
 * direct evaluation of a polynomial with large terms overestimates most (and
 * the gradient condition fails, so only this can empty such a cell). */
static iv_t mean_value(const iv_grad_t *g, const iv_box_t *box, iv_t fm, const iv_box_t *m)
{
    iv_t r = fm;
    const iv_t *x = &box->x, *mm = &m->x, *gg = &g->dx;
    for (int a = 0; a < 3; a++)
        r = iv_add(r, iv_mul(gg[a], iv_sub(x[a], mm[a])));
    return r;
}

/* Classify the K_OPEN cells ids[0..n): empty, surface, unresolved (at the max
 * depth), or left K_OPEN to be split; coarse (above min_depth): empty or left
 * to be split.  Batches of TAPE_BATCH boxes. */
static void classify(ctx_t *c, const int32_t *ids, size_t n, bool coarse)
{
    iv_box_t box[TAPE_BATCH];
    iv_t f[TAPE_BATCH];
    iv_grad_t g[TAPE_BATCH];
    int32_t open[TAPE_BATCH];
    for (size_t b = 0; b < n; b += TAPE_BATCH) {
        size_t m = n - b < TAPE_BATCH ? n - b : TAPE_BATCH, k = 0;
        for (size_t i = 0; i < m; i++)
            box[i] = cell_box(c, &c->cells[ids[b + i]]);
        tape_eval_interval(c->t, c->ws, m, box, f);
        c->out->stats.cells_evaluated += m;
        for (size_t i = 0; i < m; i++) {
            if (excludes_zero(f[i]))
                c->cells[ids[b + i]].kind = K_EMPTY;
            else {
                open[k] = ids[b + i];
                box[k++] = box[i];
            }
        }
        if (!k || coarse)
            continue; /* above min_depth the cells that may hold surface are split */
        tape_eval_grad(c->t, c->ws, k, box, g);
        /* f at the centres, for the mean value form */
        iv_box_t ctr[TAPE_BATCH];
        iv_t fc[TAPE_BATCH];
        for (size_t i = 0; i < k; i++) {
            ctr[i].x = iv_point(iv_mid(box[i].x));
            ctr[i].y = iv_point(iv_mid(box[i].y));
            ctr[i].z = iv_point(iv_mid(box[i].z));
        }
        tape_eval_interval(c->t, c->ws, k, ctr, fc);
        for (size_t i = 0; i < k; i++) {
            cell_t *cl = &c->cells[open[i]];
            int smooth = 0;
            bool c1 = c->smooth || (tape_check_continuous(c->t, &box[i], c->slots, &smooth) ==
                                        TAPE_DOMAIN_CONTINUOUS && smooth);
            if (c1 && excludes_zero(mean_value(&g[i], &box[i], fc[i], &ctr[i])))
                cl->kind = K_EMPTY;
            else if (c1 && gradient_condition(&g[i], cl->d))
                cl->kind = K_SURFACE;
            else if (cl->level == c->D)
                cl->kind = K_UNRESOLVED;
        }
    }
}

/* Split surface cell ci after the subdivision: its children inherit the
 * gradient condition and the direction d (their gradients lie in the parent's
 * enclosure); those whose enclosure of f excludes 0 become empty. */
static int split_surface(ctx_t *c, int32_t ci)
{
    double d[3];
    memcpy(d, c->cells[ci].d, sizeof d);
    if (split(c, ci))
        return -1;
    int32_t first = c->cells[ci].child;
    iv_box_t box[8];
    iv_t f[8];
    for (int o = 0; o < 8; o++)
        box[o] = cell_box(c, &c->cells[first + o]);
    tape_eval_interval(c->t, c->ws, 8, box, f);
    c->out->stats.cells_evaluated += 8;
    for (int o = 0; o < 8; o++) {
        cell_t *ch = &c->cells[first + o];
        ch->kind = excludes_zero(f[o]) ? K_EMPTY : K_SURFACE;
        memcpy(ch->d, d, sizeof d);
    }
    return 0;
}

/* ---- subdivision ------------------------------------------------------------------- */

static int subdivide(ctx_t *c)
{
    if (new_cell(c, 0, 0, 0, 0) < 0)
        return nomem(c);
    size_t begin = 0, end = 1; /* the cells of the current level */
    for (int l = 0; l <= c->D && begin < end; l++) {
        int32_t *ids = malloc((end - begin) * sizeof *ids);
        if (!ids)
            return nomem(c);
        for (size_t i = begin; i < end; i++)
            ids[i - begin] = (int32_t)i;
        classify(c, ids, end - begin, l < c->min_depth);
        free(ids);
        size_t next = c->n_cells;
        for (size_t i = begin; i < end; i++)
            if (c->cells[i].kind == K_OPEN && split(c, (int32_t)i))
                return -1;
        begin = next;
        end = c->n_cells;
    }
    return 0;
}

/* ---- balance ------------------------------------------------------------------------
 * Leaves that may hold surface and touch (share a face, an edge or a corner)
 * differ by at most one level.  Empty leaves take no part: every point of an
 * empty cell has the sign of the cell, so nothing is built on its faces. */

static int push(ctx_t *c, int32_t ci)
{
    if (reserve(&c->queue, &c->cap_queue, c->n_queue, 1, sizeof *c->queue))
        return nomem(c);
    c->queue[c->n_queue++] = ci;
    return 0;
}

static int push_children(ctx_t *c, int32_t ci)
{
    for (int o = 0; o < 8; o++)
        if (may_hold_surface(&c->cells[c->cells[ci].child + o]) &&
            push(c, c->cells[ci].child + o))
            return -1;
    return 0;
}

static int balance(ctx_t *c)
{
    while (c->n_queue) {
        int32_t ci = c->queue[--c->n_queue];
        cell_t cl = c->cells[ci];
        /* every leaf is at min_depth or below, so one at min_depth + 1 or
         * above has no leaf two levels coarser next to it */
        if (cl.kind == K_INTERNAL || cl.level < 2 || cl.level <= c->min_depth + 1)
            continue;
        uint32_t side = 1u << cl.level;
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int64_t q[3] = {(int64_t)cl.pos[0] + dx, (int64_t)cl.pos[1] + dy,
                                    (int64_t)cl.pos[2] + dz};
                    if ((!dx && !dy && !dz) || q[0] < 0 || q[1] < 0 || q[2] < 0 ||
                        q[0] >= side || q[1] >= side || q[2] >= side)
                        continue;
                    uint32_t pos[3] = {(uint32_t)q[0], (uint32_t)q[1], (uint32_t)q[2]};
                    for (;;) {
                        int32_t n = find(c, cl.level, pos);
                        cell_t *nc = &c->cells[n];
                        if (nc->kind != K_SURFACE || nc->level + 1 >= cl.level)
                            break; /* unresolved leaves are at the max depth */
                        if (split_surface(c, n) || push_children(c, n))
                            return -1;
                        c->out->stats.split_balance++;
                    }
                }
    }
    return 0;
}

/* ---- certified signs, batched --------------------------------------------------------- */

static hkey_t point_key(const uint32_t g[3])
{
    hkey_t k = {(uint64_t)g[0] | (uint64_t)g[1] << 21 | (uint64_t)g[2] << 42, 0};
    return k;
}

static int sign_of(iv_t f)
{
    if (f.lo > 0 || (f.lo == 0 && f.hi == 0))
        return S_POS;
    if (f.hi < 0)
        return S_NEG;
    return S_UNCERTAIN; /* straddles 0, or f undefined there */
}

/* Certified signs of f at the n points p (x y z each) into s, and (v not
 * NULL) the midpoints of the enclosures, approximations of f there, into v:
 * TAPE_BATCH points per pass over the tape. */
static void point_values(ctx_t *c, size_t n, const double *p, int8_t *s, double *v)
{
    iv_box_t b[TAPE_BATCH];
    iv_t f[TAPE_BATCH];
    for (size_t i0 = 0; i0 < n; i0 += TAPE_BATCH) {
        size_t m = n - i0 < TAPE_BATCH ? n - i0 : TAPE_BATCH;
        for (size_t i = 0; i < m; i++) {
            const double *q = p + 3 * (i0 + i);
            b[i].x = iv_point(q[0]), b[i].y = iv_point(q[1]), b[i].z = iv_point(q[2]);
        }
        tape_eval_interval(c->t, c->ws, m, b, f);
        for (size_t i = 0; i < m; i++) {
            s[i0 + i] = (int8_t)sign_of(f[i]);
            if (v)
                v[i0 + i] = iv_mid(f[i]);
        }
    }
    c->out->stats.sign_evaluations += n;
}

static void point_signs(ctx_t *c, size_t n, const double *p, int8_t *s)
{
    point_values(c, n, p, s, NULL);
}

static int point_sign(ctx_t *c, const double p[3])
{
    int8_t s;
    point_signs(c, 1, p, &s);
    return s;
}

/* A bracket of a sign change: f has the certified sign s_lo at lo and the
 * other one at hi. */
typedef struct bracket {
    double lo[3], hi[3];
    int8_t s_lo;
    uint8_t lo_moved;
} bracket_t;

/* After this many steps a bracket is halved, no longer cut where the secant
 * through the ends' values meets 0: halving reaches adjacent doubles in at
 * most ~1100 more steps for any bracket, and in ~55 for the ones here. */
#define SECANT_STEPS 32

/* Shrink every bracket onto its sign change, all together (one batched
 * evaluation per step): each step cuts a bracket where the secant through the
 * approximate values of f at its ends meets 0 (the Illinois variant of
 * regula falsi: an end kept twice in a row has its value halved, so both ends
 * move), a point strictly between the ends, whose certified sign says which
 * end it replaces; until the enclosure of f there holds 0 (lo is then moved to
 * it: f is 0 there up to the evaluation's rounding) or the bracket's ends are
 * adjacent doubles.  Every point between the ends of a bracket stays between
 * them, coordinate by coordinate.  -1 when out of memory. */
static int bisect_all(ctx_t *c, bracket_t *br, size_t n)
{
    if (!n)
        return 0;
    size_t *act = malloc(n * sizeof *act);
    double *x = malloc(2 * n * 3 * sizeof *x), *v = malloc(2 * n * sizeof *v);
    double *f_lo = malloc(n * sizeof *f_lo), *f_hi = malloc(n * sizeof *f_hi);
    int8_t *sg = malloc(2 * n), *kept = calloc(n, 1);
    if (!act || !x || !v || !f_lo || !f_hi || !sg || !kept) {
        free(act), free(x), free(v), free(f_lo), free(f_hi), free(sg), free(kept);
        return nomem(c);
    }
    /* the values at the ends, for the secants (their signs are known) */
    for (size_t i = 0; i < n; i++) {
        memcpy(x + 6 * i, br[i].lo, sizeof br[i].lo);
        memcpy(x + 6 * i + 3, br[i].hi, sizeof br[i].hi);
    }
    point_values(c, 2 * n, x, sg, v);
    for (size_t i = 0; i < n; i++) {
        f_lo[i] = v[2 * i], f_hi[i] = v[2 * i + 1];
        act[i] = i;
    }
    size_t na = n;
    for (int step = 0; na; step++) {
        size_t k = 0;
        for (size_t j = 0; j < na; j++) {
            size_t i = act[j];
            bracket_t *b = &br[i];
            /* where the secant meets 0, if the values are of opposite signs
             * (they are approximations: near 0 they may not be) */
            double t = 0.5;
            if (step < SECANT_STEPS && f_lo[i] * f_hi[i] < 0)
                t = f_lo[i] / (f_lo[i] - f_hi[i]);
            int inside = 0, tries = 0;
            do {
                inside = 0;
                for (int a = 0; a < 3; a++) {
                    double p = b->lo[a] + t * (b->hi[a] - b->lo[a]);
                    /* between the ends even when rounded past one */
                    double lo = fmin(b->lo[a], b->hi[a]), hi = fmax(b->lo[a], b->hi[a]);
                    p = fmin(fmax(p, lo), hi);
                    inside |= p != b->lo[a] && p != b->hi[a];
                    x[3 * k + a] = p;
                }
                t = 0.5; /* the secant's point is an end: halve instead */
            } while (!inside && ++tries < 2);
            if (inside)
                act[k++] = i;
        }
        na = k;
        point_values(c, na, x, sg, v);
        k = 0;
        for (size_t j = 0; j < na; j++) {
            size_t i = act[j];
            bracket_t *b = &br[i];
            if (sg[j] == S_UNCERTAIN || sg[j] == b->s_lo) {
                memcpy(b->lo, x + 3 * j, sizeof b->lo);
                b->lo_moved = 1;
                f_lo[i] = v[j];
                if (kept[i] == 2) /* hi kept twice */
                    f_hi[i] *= 0.5;
                kept[i] = 2;
            } else {
                memcpy(b->hi, x + 3 * j, sizeof b->hi);
                f_hi[i] = v[j];
                if (kept[i] == 1) /* lo kept twice */
                    f_lo[i] *= 0.5;
                kept[i] = 1;
            }
            if (sg[j] != S_UNCERTAIN)
                act[k++] = i;
        }
        na = k;
    }
    free(act), free(x), free(v), free(f_lo), free(f_hi), free(sg), free(kept);
    return 0;
}

/* ---- grid points ---------------------------------------------------------------------- */

/* The record of grid point g, made if new; NULL when out of memory. */
static vinfo_t *vert(ctx_t *c, const uint32_t g[3])
{
    hkey_t k = point_key(g);
    uint32_t v = hmap_get(&c->vmap, k);
    if (v == UINT32_MAX) {
        if (reserve(&c->verts, &c->cap_verts, c->n_verts, 1, sizeof *c->verts) ||
            hmap_put(&c->vmap, k, (uint32_t)c->n_verts))
            return NULL;
        v = (uint32_t)c->n_verts++;
        c->verts[v].sign = S_UNKNOWN;
        c->verts[v].corner = 0;
        memcpy(c->verts[v].g, g, sizeof c->verts[v].g);
    }
    return &c->verts[v];
}

static void grid_point(const ctx_t *c, const uint32_t g[3], double p[3])
{
    for (int a = 0; a < 3; a++)
        p[a] = coord(c, a, g[a]);
}

/* The sign at grid point g (never S_UNKNOWN); 3 when out of memory.  The
 * corners of the leaves are evaluated beforehand in batches (signs_of_corners);
 * this evaluates the few others (corners of finer empty leaves). */
static int grid_sign(ctx_t *c, const uint32_t g[3])
{
    vinfo_t *v = vert(c, g);
    if (!v)
        return 3;
    if (v->sign == S_UNKNOWN) {
        double p[3];
        grid_point(c, g, p);
        v->sign = (int8_t)point_sign(c, p);
    }
    return v->sign;
}

/* Is grid point g a corner of a leaf that may hold surface? */
static bool is_corner(const ctx_t *c, const uint32_t g[3])
{
    uint32_t v = hmap_get(&c->vmap, point_key(g));
    return v != UINT32_MAX && c->verts[v].corner;
}

/* Flag the corners of this pass's leaves that may hold surface, and give them
 * their signs, batched. */
static int signs_of_corners(ctx_t *c)
{
    for (size_t v = 0; v < c->n_verts; v++)
        c->verts[v].corner = 0;
    for (size_t i = 0; i < c->n_cells; i++) {
        const cell_t *cl = &c->cells[i];
        if (!may_hold_surface(cl))
            continue;
        int sh = c->D - cl->level;
        for (int o8 = 0; o8 < 8; o8++) {
            uint32_t g[3] = {(cl->pos[0] + (o8 & 1)) << sh, (cl->pos[1] + (o8 >> 1 & 1)) << sh,
                             (cl->pos[2] + (o8 >> 2)) << sh};
            vinfo_t *v = vert(c, g);
            if (!v)
                return nomem(c);
            v->corner = 1;
        }
    }
    size_t n = 0;
    for (size_t v = 0; v < c->n_verts; v++)
        n += c->verts[v].sign == S_UNKNOWN;
    double *p = malloc((n ? n : 1) * 3 * sizeof *p);
    int8_t *s = malloc(n ? n : 1);
    if (!p || !s) {
        free(p), free(s);
        return nomem(c);
    }
    size_t k = 0;
    for (size_t v = 0; v < c->n_verts; v++)
        if (c->verts[v].sign == S_UNKNOWN)
            grid_point(c, c->verts[v].g, p + 3 * k++);
    point_signs(c, n, p, s);
    k = 0;
    for (size_t v = 0; v < c->n_verts; v++)
        if (c->verts[v].sign == S_UNKNOWN)
            c->verts[v].sign = s[k++];
    free(p), free(s);
    return 0;
}

/* ---- crossings: where f changes sign on a piece of a side ------------------------------ */

/* The crossing of the piece of side from grid point a to grid point b (one axis
 * apart, signs differ), made if new (and placed later, by place_crossings).
 * Its index, or -1 when out of memory. */
static int64_t crossing(ctx_t *c, const uint32_t a[3], const uint32_t b[3], int sa)
{
    int ax = a[0] != b[0] ? 0 : a[1] != b[1] ? 1 : 2;
    const uint32_t *lo = a[ax] < b[ax] ? a : b, *hi = lo == a ? b : a;
    hkey_t k = point_key(lo);
    k.b = (uint64_t)ax | (uint64_t)(hi[ax] - lo[ax]) << 2;
    uint32_t x = hmap_get(&c->xmap, k);
    if (x != UINT32_MAX)
        return x;
    if (reserve(&c->xs, &c->cap_xs, c->n_xs, 1, sizeof *c->xs) ||
        hmap_put(&c->xmap, k, (uint32_t)c->n_xs))
        return -1;
    crossing_t *cr = &c->xs[c->n_xs];
    memset(cr, 0, sizeof *cr);
    grid_point(c, lo, cr->p);
    grid_point(c, hi, cr->end);
    cr->s_lo = (int8_t)(lo == a ? sa : -sa);
    cr->mesh_index = UINT32_MAX;
    return (int64_t)c->n_xs++;
}

/* Put the new crossings on the surface: bisection with certified signs down
 * to two adjacent doubles (the end strictly inside the piece of side is kept)
 * or a point where the enclosure of f holds 0. */
static int place_crossings(ctx_t *c)
{
    size_t n = 0;
    for (size_t i = 0; i < c->n_xs; i++)
        n += !c->xs[i].placed;
    bracket_t *br = malloc((n ? n : 1) * sizeof *br);
    if (!br)
        return nomem(c);
    size_t k = 0;
    for (size_t i = 0; i < c->n_xs; i++)
        if (!c->xs[i].placed) {
            memcpy(br[k].lo, c->xs[i].p, sizeof br[k].lo);
            memcpy(br[k].hi, c->xs[i].end, sizeof br[k].hi);
            br[k].s_lo = c->xs[i].s_lo;
            br[k++].lo_moved = 0;
        }
    if (bisect_all(c, br, n)) {
        free(br);
        return -1;
    }
    k = 0;
    for (size_t i = 0; i < c->n_xs; i++)
        if (!c->xs[i].placed) {
            memcpy(c->xs[i].p, br[k].lo_moved ? br[k].lo : br[k].hi, sizeof c->xs[i].p);
            c->xs[i].placed = 1;
            k++;
        }
    free(br);
    return 0;
}

/* ---- one cell: its facets and its loop --------------------------------------------------- */

typedef struct seg {
    uint32_t from, to; /* crossings */
} seg_t;

enum cell_result { CELL_OK = 0, CELL_SPLIT_FACE, CELL_SPLIT_LOOPS, CELL_SPLIT_APEX, CELL_FAIL_SIGN,
                   CELL_ERROR };

/* Mark leaf ci (if it may hold surface) to be split in this round, for reason
 * why (the first one given is kept). */
static void mark(ctx_t *c, int32_t ci, enum cell_result why)
{
    if (may_hold_surface(&c->cells[ci]) && !c->mark[ci])
        c->mark[ci] = (uint8_t)why;
}

/* The leaf across a face, or the internal node there: the cell of the given level
 * on the far side (s = 1: above, 0: below along axis a) of the plane
 * plane[a], at plane's other coordinates.  -1 beyond the box. */
static int32_t across(const ctx_t *c, const uint32_t plane[3], int a, int s, int level)
{
    int sh = c->D - level;
    int64_t q[3];
    for (int k = 0; k < 3; k++)
        q[k] = plane[k] >> sh;
    q[a] = s ? (int64_t)(plane[a] >> sh) : (int64_t)(plane[a] >> sh) - 1;
    if (q[a] < 0 || q[a] >= (int64_t)1 << level)
        return -1;
    uint32_t pos[3] = {(uint32_t)q[0], (uint32_t)q[1], (uint32_t)q[2]};
    return find(c, level, pos);
}

/* The facet in the plane of axis a (its cell's outward side s: 1 high, 0 low)
 * with lower corner g0 (grid) and size h: its boundary walked counterclockwise
 * seen from +a (axes u = a+1, v = a+2), split at the side midpoints that are
 * corners of leaves; the crossings on it paired into at most one segment,
 * oriented so that f > 0 lies to its left seen from outside the cell.  Returns
 * 0, 1 when the facet crosses the surface ambiguously, 2 on an uncertain sign,
 * -1 when out of memory. */
static int facet(ctx_t *c, const uint32_t g0[3], int a, int s, uint32_t h, seg_t *segs, int *n_segs)
{
    int u = (a + 1) % 3, v = (a + 2) % 3;
    uint32_t pts[8][3];
    int side[8], n = 0;
    static const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
    for (int k = 0; k < 4; k++) {
        uint32_t p[3] = {g0[0], g0[1], g0[2]};
        p[u] += du[k] * h, p[v] += dv[k] * h;
        memcpy(pts[n], p, sizeof p);
        side[n++] = k;
        if (h >= 2) {
            uint32_t m[3] = {p[0], p[1], p[2]};
            m[u] = (uint32_t)((int64_t)m[u] + (du[(k + 1) % 4] - du[k]) * (int64_t)(h / 2));
            m[v] = (uint32_t)((int64_t)m[v] + (dv[(k + 1) % 4] - dv[k]) * (int64_t)(h / 2));
            if (is_corner(c, m)) {
                memcpy(pts[n], m, sizeof m);
                side[n++] = k;
            }
        }
    }
    int sg[8];
    for (int k = 0; k < n; k++) {
        sg[k] = grid_sign(c, pts[k]);
        if (sg[k] == 3)
            return -1;
        if (sg[k] == S_UNCERTAIN)
            return 2;
    }
    int64_t x[2];
    int xside[2], xdir[2], nx = 0;
    for (int k = 0; k < n; k++) {
        int k1 = (k + 1) % n;
        if (sg[k] == sg[k1])
            continue;
        if (nx == 2)
            return 1;
        x[nx] = crossing(c, pts[k], pts[k1], sg[k]);
        if (x[nx] < 0)
            return -1;
        xside[nx] = side[k];
        xdir[nx++] = sg[k1] > 0 ? +1 : -1; /* walking into f > 0, or out of it */
    }
    if (!nx)
        return 0;
    if (xside[0] == xside[1])
        return 1; /* both on one side: f crosses 0 twice along that side */
    /* Seen from outside a high face (s = 1) the walk is counterclockwise and f > 0
     * lies to the left of the segment from the crossing that leaves f > 0 to the
     * one that enters it; from outside a low face the walk is clockwise. */
    int from = (xdir[0] < 0) == (s == 1) ? 0 : 1;
    segs[*n_segs].from = (uint32_t)x[from];
    segs[(*n_segs)++].to = (uint32_t)x[1 - from];
    return 0;
}

/* The facets of surface leaf ci and their segments (at most 24: 6 faces of up
 * to 4 facets); marks the leaves to split when a facet is ambiguous or the
 * segments close into several loops. */
static enum cell_result analyse_cell(ctx_t *c, int32_t ci, seg_t *segs, int *n_segs)
{
    cell_t cl = c->cells[ci];
    int sh = c->D - cl.level;
    uint32_t h = 1u << sh, g[3] = {cl.pos[0] << sh, cl.pos[1] << sh, cl.pos[2] << sh};
    int ns = 0;
    enum cell_result res = CELL_OK;
    *n_segs = 0;
    for (int a = 0; a < 3; a++)
        for (int s = 0; s < 2; s++) {
            uint32_t f0[3] = {g[0], g[1], g[2]};
            f0[a] += s ? h : 0;
            int32_t nb = across(c, f0, a, s, cl.level);
            bool quarters = nb >= 0 && c->cells[nb].kind == K_INTERNAL;
            int nf = quarters ? 4 : 1;
            uint32_t fh = quarters ? h / 2 : h;
            int u = (a + 1) % 3, v = (a + 2) % 3;
            for (int q = 0; q < nf; q++) {
                uint32_t q0[3] = {f0[0], f0[1], f0[2]};
                q0[u] += (q & 1) * fh, q0[v] += (q >> 1) * fh;
                int r = facet(c, q0, a, s, fh, segs, &ns);
                if (r < 0)
                    return CELL_ERROR;
                if (r == 2)
                    return CELL_FAIL_SIGN;
                if (r == 1) {
                    /* split the leaves whose face this facet is */
                    mark(c, ci, CELL_SPLIT_FACE);
                    if (quarters) {
                        int32_t e = across(c, q0, a, s, cl.level + 1);
                        if (e >= 0)
                            mark(c, e, CELL_SPLIT_FACE);
                    } else if (nb >= 0 && c->cells[nb].level == cl.level)
                        mark(c, nb, CELL_SPLIT_FACE);
                    res = CELL_SPLIT_FACE;
                }
            }
        }
    if (res != CELL_OK)
        return res;
    /* each crossing is the end of one segment and the start of one other: the
     * segments close into loops */
    int used[24] = {0}, loops = 0;
    for (int k = 0; k < ns; k++) {
        if (used[k])
            continue;
        loops++;
        for (int j = k; !used[j];) {
            used[j] = 1;
            int nxt = -1;
            for (int m = 0; m < ns; m++)
                if (segs[m].from == segs[j].to)
                    nxt = m;
            if (nxt < 0) { /* cannot happen: every crossing is on two facets of the cell */
                mark(c, ci, CELL_SPLIT_LOOPS);
                return CELL_SPLIT_LOOPS;
            }
            j = nxt;
        }
    }
    if (loops > 1) {
        mark(c, ci, CELL_SPLIT_LOOPS);
        return CELL_SPLIT_LOOPS;
    }
    *n_segs = ns;
    return CELL_OK;
}

/* ---- the apex of a cell's fan ------------------------------------------------------------ */

/* Candidate m of the lines along d where the apex is looked for (f increases
 * strictly along d in the cell, so f changes sign at most once on such a
 * line): through the average of the loop's crossings (the surface is close to
 * it when the loop is small and flat), half way to the centre, the centre, and
 * the crossings pulled a little towards the centre (the line then meets the
 * surface close to them, inside the cell).  The line's two ends strictly
 * inside the box into e; 0, or 1 when it has none. */
#define APEX_PULLS 6
static int apex_line(const ctx_t *c, const iv_box_t *box, const double d[3], const seg_t *segs,
                     int ns, const double avg[3], int m, double e[2][3])
{
    static const double pull[APEX_PULLS] = {0.5, 0.05, 0.25, 1e-2, 1e-3, 1e-5};
    const iv_t *r = &box->x;
    double q[3], s0 = -INFINITY, s1 = INFINITY;
    for (int a = 0; a < 3; a++) {
        double ctr = iv_mid(r[a]);
        if (m == 0)
            q[a] = avg[a];
        else if (m == 1)
            q[a] = 0.5 * ctr + 0.5 * avg[a];
        else if (m == 2)
            q[a] = ctr;
        else {
            double x = c->xs[segs[(m - 3) % ns].from].p[a];
            q[a] = x + pull[(m - 3) / ns] * (ctr - x);
        }
        if (d[a] != 0) {
            double ta = (r[a].lo - q[a]) / d[a], tb = (r[a].hi - q[a]) / d[a];
            s0 = fmax(s0, fmin(ta, tb));
            s1 = fmin(s1, fmax(ta, tb));
        }
    }
    if (!(s0 < s1) || !isfinite(s0) || !isfinite(s1))
        return 1;
    double pad = 1e-6 * (s1 - s0);
    s0 += pad, s1 -= pad;
    int inside = 1;
    for (int k = 0; k < 2; k++)
        for (int a = 0; a < 3; a++) {
            e[k][a] = q[a] + (k ? s1 : s0) * d[a];
            inside &= e[k][a] > r[a].lo && e[k][a] < r[a].hi;
        }
    return !inside;
}

/* The average of a loop's crossings. */
static void loop_average(const ctx_t *c, const seg_t *segs, int ns, double avg[3])
{
    avg[0] = avg[1] = avg[2] = 0;
    for (int j = 0; j < ns; j++)
        for (int a = 0; a < 3; a++)
            avg[a] += c->xs[segs[j].from].p[a] / ns;
}

/* A cell of this pass with one loop: its segments are segs[off, off + ns). */
typedef struct loop_cell {
    int32_t cell;
    uint32_t off, ns;
} loop_cell_t;

/* The apexes of the cells of this pass that have none yet: the first line of
 * every cell bisected together; the cells where it fails try the other lines
 * one by one.  Any point of the surface strictly inside the cell serves
 * (mesh/README.md), so an apex found in an earlier pass is kept.  A cell with
 * no apex is marked to split, or at the max depth gets one off the surface. */
static int place_apexes(ctx_t *c, const loop_cell_t *lc, size_t n, const seg_t *segs)
{
    bracket_t *br = malloc((n ? n : 1) * sizeof *br);
    size_t *who = malloc((n ? n : 1) * sizeof *who);
    double *ends = malloc((n ? n : 1) * 6 * sizeof *ends);
    int8_t *sg = malloc(2 * (n ? n : 1));
    if (!br || !who || !ends || !sg) {
        free(br), free(who), free(ends), free(sg);
        return nomem(c);
    }
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        const cell_t *cl = &c->cells[lc[i].cell];
        if (cl->has_apex)
            continue;
        double avg[3], e[2][3];
        const seg_t *sg_i = segs + lc[i].off;
        loop_average(c, sg_i, (int)lc[i].ns, avg);
        iv_box_t box = cell_box(c, cl);
        if (apex_line(c, &box, cl->d, sg_i, (int)lc[i].ns, avg, 0, e))
            continue;
        memcpy(ends + 6 * k, e, sizeof e);
        who[k++] = i;
    }
    point_signs(c, 2 * k, ends, sg);
    size_t nb = 0;
    for (size_t j = 0; j < k; j++) {
        cell_t *cl = &c->cells[lc[who[j]].cell];
        for (int e = 0; e < 2; e++)
            if (sg[2 * j + e] == S_UNCERTAIN && !cl->has_apex) {
                memcpy(cl->apex, ends + 6 * j + 3 * e, sizeof cl->apex);
                cl->has_apex = 1;
            }
        if (cl->has_apex || sg[2 * j] == sg[2 * j + 1])
            continue;
        memcpy(br[nb].lo, ends + 6 * j, sizeof br[nb].lo);
        memcpy(br[nb].hi, ends + 6 * j + 3, sizeof br[nb].hi);
        br[nb].s_lo = sg[2 * j];
        who[nb++] = who[j];
    }
    int rc = bisect_all(c, br, nb);
    for (size_t j = 0; !rc && j < nb; j++) {
        cell_t *cl = &c->cells[lc[who[j]].cell];
        memcpy(cl->apex, br[j].lo, sizeof cl->apex);
        cl->has_apex = 1;
    }
    free(br), free(who), free(ends), free(sg);
    if (rc)
        return -1;
    /* the others, line by line */
    for (size_t i = 0; i < n; i++) {
        cell_t *cl = &c->cells[lc[i].cell];
        if (cl->has_apex)
            continue;
        const seg_t *sg_i = segs + lc[i].off;
        int ns = (int)lc[i].ns;
        double avg[3], e[2][3];
        loop_average(c, sg_i, ns, avg);
        iv_box_t box = cell_box(c, cl);
        for (int m = 1; m < 3 + APEX_PULLS * ns && !cl->has_apex; m++) {
            if (apex_line(c, &box, cl->d, sg_i, ns, avg, m, e))
                continue;
            int8_t s2[2];
            point_signs(c, 2, &e[0][0], s2);
            for (int q = 0; q < 2 && !cl->has_apex; q++)
                if (s2[q] == S_UNCERTAIN) {
                    memcpy(cl->apex, e[q], sizeof cl->apex);
                    cl->has_apex = 1;
                }
            if (cl->has_apex || s2[0] == s2[1])
                continue;
            bracket_t b;
            memcpy(b.lo, e[0], sizeof b.lo);
            memcpy(b.hi, e[1], sizeof b.hi);
            b.s_lo = s2[0];
            if (bisect_all(c, &b, 1))
                return -1;
            memcpy(cl->apex, b.lo, sizeof cl->apex);
            cl->has_apex = 1;
        }
        if (cl->has_apex)
            continue;
        if (cl->level < c->D) {
            mark(c, lc[i].cell, CELL_SPLIT_APEX);
            continue;
        }
        /* at the max depth: a fan from a point strictly inside is still an
         * embedded disc; only its apex is off the surface */
        const iv_t *r = &box.x;
        for (int a = 0; a < 3; a++)
            cl->apex[a] = 0.5 * iv_mid(r[a]) + 0.5 * avg[a];
        cl->has_apex = 2;
    }
    return 0;
}

/* ---- the mesh -------------------------------------------------------------------------- */

static uint32_t mesh_vertex(ctx_t *c, const double p[3])
{
    if (reserve(&c->out->points, &c->cap_points, c->out->n_points, 1, 3 * sizeof(double)))
        return UINT32_MAX;
    memcpy(c->out->points + 3 * c->out->n_points, p, 3 * sizeof(double));
    return (uint32_t)c->out->n_points++;
}

/* The fan of a cell: a triangle apex, from, to per segment. */
static int emit_fan(ctx_t *c, const cell_t *cl, const seg_t *segs, int ns)
{
    msh_mesh_t *o = c->out;
    if (reserve(&o->cells, &c->cap_cellout, o->n_cells, 1, sizeof *o->cells) ||
        reserve(&o->cell_depth, &c->cap_depth, o->n_cells, 1, sizeof(int)))
        return -1;
    o->cells[o->n_cells] = cell_box(c, cl);
    o->cell_depth[o->n_cells] = cl->level;
    o->stats.apex_off_surface += cl->has_apex == 2;
    uint32_t apex = mesh_vertex(c, cl->apex);
    if (apex == UINT32_MAX)
        return -1;
    for (int k = 0; k < ns; k++) {
        uint32_t ends[2] = {segs[k].from, segs[k].to}, idx[2];
        for (int e = 0; e < 2; e++) {
            crossing_t *x = &c->xs[ends[e]];
            if (x->pass != c->pass) {
                x->mesh_index = mesh_vertex(c, x->p);
                x->pass = c->pass;
                if (x->mesh_index == UINT32_MAX)
                    return -1;
            }
            idx[e] = x->mesh_index;
        }
        if (reserve(&o->tris, &c->cap_tris, o->n_tris, 1, 3 * sizeof(uint32_t)) ||
            reserve(&o->tri_cell, &c->cap_tri_cell, o->n_tris, 1, sizeof(uint32_t)))
            return -1;
        uint32_t *t = o->tris + 3 * o->n_tris;
        t[0] = apex, t[1] = idx[0], t[2] = idx[1];
        o->tri_cell[o->n_tris++] = (uint32_t)o->n_cells;
    }
    o->n_cells++;
    return 0;
}

/* ---- passes ------------------------------------------------------------------------ */

static int add_failure(ctx_t *c, const cell_t *cl, msh_reason_t why)
{
    msh_mesh_t *o = c->out;
    if (reserve(&o->failures, &c->cap_fail, o->n_failures, 1, sizeof *o->failures))
        return nomem(c);
    if (reserve(&c->fail_cell, &c->cap_fail_cell, o->n_failures, 1, sizeof *c->fail_cell))
        return nomem(c);
    c->fail_cell[o->n_failures] = (int32_t)(cl - c->cells);
    msh_failure_t *f = &o->failures[o->n_failures++];
    f->box = cell_box(c, cl);
    f->depth = cl->level;
    f->reason = why;
    return 0;
}

static size_t region_root(size_t *parent, size_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

/* Gather the failed cells into regions: union-find over each failed cell's 26
 * neighbours at its level (find gives the leaf there, or a finer internal node,
 * whose failed leaves reach this cell through their own neighbours). */
static int failure_regions(ctx_t *c)
{
    msh_mesh_t *o = c->out;
    size_t n = o->n_failures;
    int32_t *of_cell = malloc(c->n_cells * sizeof *of_cell); /* cell -> failure, -1 */
    size_t *parent = malloc((n ? n : 1) * sizeof *parent);
    if (!of_cell || !parent) {
        free(of_cell), free(parent);
        return nomem(c);
    }
    for (size_t i = 0; i < c->n_cells; i++)
        of_cell[i] = -1;
    for (size_t f = 0; f < n; f++) {
        of_cell[c->fail_cell[f]] = (int32_t)f;
        parent[f] = f;
    }
    for (size_t f = 0; f < n; f++) {
        const cell_t *cl = &c->cells[c->fail_cell[f]];
        int64_t side = (int64_t)1 << cl->level;
        for (int o27 = 0; o27 < 27; o27++) {
            int64_t q[3] = {(int64_t)cl->pos[0] + o27 % 3 - 1, (int64_t)cl->pos[1] + o27 / 3 % 3 - 1,
                            (int64_t)cl->pos[2] + o27 / 9 - 1};
            if (o27 == 13 || q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= side ||
                q[1] >= side || q[2] >= side)
                continue;
            uint32_t pos[3] = {(uint32_t)q[0], (uint32_t)q[1], (uint32_t)q[2]};
            int32_t g = of_cell[find(c, cl->level, pos)];
            if (g >= 0)
                parent[region_root(parent, f)] = region_root(parent, (size_t)g);
        }
    }
    /* number the regions in the order of their first failure */
    size_t *number = malloc((n ? n : 1) * sizeof *number);
    if (!number) {
        free(of_cell), free(parent);
        return nomem(c);
    }
    o->n_regions = 0;
    for (size_t f = 0; f < n; f++)
        number[f] = SIZE_MAX;
    for (size_t f = 0; f < n; f++) {
        size_t r = region_root(parent, f);
        if (number[r] == SIZE_MAX)
            number[r] = o->n_regions++;
        o->failures[f].region = (uint32_t)number[r];
    }
    free(of_cell), free(parent), free(number);
    return 0;
}

/* One construction pass over the leaves that may hold surface: the mesh of
 * this pass in c->out, the cells to split in c->mark, the failures of this
 * pass in c->out->failures.  In stages, so that the evaluations batch: the
 * corners' signs, every cell's facets and loop, the new crossings, the new
 * apexes, the fans. */
static int construct(ctx_t *c)
{
    msh_mesh_t *o = c->out;
    o->n_points = o->n_tris = o->n_cells = o->n_failures = 0;
    o->stats.apex_off_surface = 0;
    c->pass++;
    o->stats.passes++;
    if (reserve(&c->mark, &c->cap_mark, 0, c->n_cells, 1))
        return nomem(c);
    memset(c->mark, 0, c->n_cells);
    if (signs_of_corners(c) || over_budget(c))
        return -1;
    loop_cell_t *lc = NULL;
    seg_t *segs = NULL;
    size_t n_lc = 0, cap_lc = 0, n_segs = 0, cap_segs = 0;
    int rc = -1;
    for (size_t i = 0; i < c->n_cells; i++) {
        cell_t *cl = &c->cells[i];
        if (cl->kind == K_UNRESOLVED && add_failure(c, cl, MSH_FAIL_GRADIENT))
            goto done;
        if (cl->kind != K_SURFACE)
            continue;
        if (reserve(&segs, &cap_segs, n_segs, 24, sizeof *segs) ||
            reserve(&lc, &cap_lc, n_lc, 1, sizeof *lc)) {
            nomem(c);
            goto done;
        }
        int ns;
        enum cell_result r = analyse_cell(c, (int32_t)i, segs + n_segs, &ns);
        if (r == CELL_ERROR) {
            nomem(c);
            goto done;
        }
        if (r == CELL_FAIL_SIGN && add_failure(c, cl, MSH_FAIL_SIGN))
            goto done;
        if (r != CELL_OK || !ns)
            continue;
        lc[n_lc].cell = (int32_t)i;
        lc[n_lc].off = (uint32_t)n_segs;
        lc[n_lc++].ns = (uint32_t)ns;
        n_segs += (size_t)ns;
    }
    if (over_budget(c) || place_crossings(c) || place_apexes(c, lc, n_lc, segs))
        goto done;
    for (size_t i = 0; i < n_lc; i++)
        if (!c->mark[lc[i].cell] &&
            emit_fan(c, &c->cells[lc[i].cell], segs + lc[i].off, (int)lc[i].ns)) {
            nomem(c);
            goto done;
        }
    rc = over_budget(c);
done:
    free(lc);
    free(segs);
    return rc;
}

/* Split the marked cells; those at the max depth become failures.  Sets
 * *split when any cell was split. */
static int split_marked(ctx_t *c, int *split)
{
    size_t n = c->n_cells; /* cells made now are not marked */
    *split = 0;
    for (size_t i = 0; i < n; i++) {
        if (!c->mark[i])
            continue;
        cell_t *cl = &c->cells[i];
        if (cl->kind != K_SURFACE || cl->level == c->D) {
            msh_reason_t why = c->mark[i] == CELL_SPLIT_FACE ? MSH_FAIL_FACE : MSH_FAIL_LOOPS;
            if (cl->kind == K_SURFACE && add_failure(c, cl, why))
                return -1;
            continue;
        }
        msh_stats_t *st = &c->out->stats;
        if (c->mark[i] == CELL_SPLIT_FACE)
            st->split_face++;
        else if (c->mark[i] == CELL_SPLIT_LOOPS)
            st->split_loops++;
        else
            st->split_apex++;
        if (split_surface(c, (int32_t)i) || push_children(c, (int32_t)i))
            return -1;
        *split = 1;
    }
    return 0;
}

static void count_leaves(ctx_t *c)
{
    msh_stats_t *st = &c->out->stats;
    st->leaves_empty = st->leaves_surface = st->leaves_unresolved = 0;
    for (size_t i = 0; i < c->n_cells; i++) {
        int k = c->cells[i].kind;
        st->leaves_empty += k == K_EMPTY;
        st->leaves_surface += k == K_SURFACE;
        st->leaves_unresolved += k == K_UNRESOLVED;
    }
}

iv_box_t msh_mesh_box(const iv_box_t *box)
{
    iv_box_t b = *box;
    iv_t *r = &b.x;
    for (int a = 0; a < 3; a++) {
        double w = r[a].hi - r[a].lo;
        r[a].lo -= 0.00123 * w;
        r[a].hi += 0.00077 * w;
    }
    return b;
}

const char *msh_reason_name(msh_reason_t r)
{
    switch (r) {
    case MSH_FAIL_GRADIENT: return "gradient";
    case MSH_FAIL_SIGN: return "sign";
    case MSH_FAIL_FACE: return "face";
    case MSH_FAIL_LOOPS: return "loops";
    }
    return "?";
}

void msh_free(msh_mesh_t *m)
{
    if (!m)
        return;
    free(m->points);
    free(m->tris);
    free(m->tri_cell);
    free(m->cells);
    free(m->cell_depth);
    free(m->failures);
    memset(m, 0, sizeof *m);
}

int msh_build(const tape_t *t, const iv_box_t *box, const msh_params_t *p, msh_mesh_t *out,
              ivoct_error_t *err)
{
    memset(out, 0, sizeof *out);
    if (!t || !box || !p || p->max_depth < 1 || p->max_depth > MSH_MAX_DEPTH ||
        p->min_depth < 0 || p->min_depth > p->max_depth) {
        ivoct_error_set(err, "certified mesh: the depth must be 1..%d (min depth 0..max)",
                        MSH_MAX_DEPTH);
        return -1;
    }
    const iv_t *r = &box->x;
    for (int a = 0; a < 3; a++)
        if (!(r[a].lo < r[a].hi) || !isfinite(r[a].lo) || !isfinite(r[a].hi)) {
            ivoct_error_set(err, "certified mesh: the box must be finite and not flat");
            return -1;
        }
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    ctx_t c = {0};
    c.t = t;
    c.D = p->max_depth;
    c.min_depth = p->min_depth;
    c.max_memory = p->max_memory;
    c.out = out;
    c.err = err;
    out->box = msh_mesh_box(box);
    const iv_t *mb = &out->box.x;
    for (int a = 0; a < 3; a++) {
        c.lo[a] = mb[a].lo;
        c.w[a] = mb[a].hi - mb[a].lo;
    }
    int rc = -1;
    /* total (no division, sqrt, log ...) and no min, max or abs: polynomials and
     * the like, C^infinity everywhere */
    c.smooth = tape_is_total(t) && !tape_has_choices(t);
    c.ws = tape_ws_new(t->n);
    c.slots = malloc(t->n * sizeof *c.slots);
    if (!c.ws || !c.slots) {
        nomem(&c);
        goto done;
    }
    if (subdivide(&c))
        goto done;
    for (size_t i = 0; i < c.n_cells; i++)
        if (may_hold_surface(&c.cells[i]) && push(&c, (int32_t)i))
            goto done;
    if (balance(&c))
        goto done;
    for (;;) {
        int split;
        if (construct(&c) || split_marked(&c, &split))
            goto done;
        if (!split)
            break;
        if (balance(&c))
            goto done;
    }
    if (out->n_failures && failure_regions(&c))
        goto done;
    count_leaves(&c);
    rc = out->n_failures ? 1 : 0;
done:
    tape_ws_free(c.ws);
    free(c.slots);
    free(c.cells);
    hmap_free(&c.vmap);
    hmap_free(&c.xmap);
    free(c.verts);
    free(c.xs);
    free(c.mark);
    free(c.queue);
    free(c.fail_cell);
    if (rc < 0) {
        msh_free(out);
    } else {
        clock_gettime(CLOCK_MONOTONIC, &t1);
        out->stats.seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    }
    return rc;
}
