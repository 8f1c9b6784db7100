/* ivoct ray — the beam walk: does a beam of rays (one origin, an interval box
 * of directions) reach any surface leaf of the octree?  beam_internal.h says
 * what it proves; ray/README.md, "Beams", why.
 *
 * The walk mirrors the per-ray walk of traverse.c (the same cells, the same
 * plane coordinates oct_coord, the same rules for corrupt trees), with each
 * per-axis [entry, exit] an enclosure over every direction of the beam: the
 * crossing (c - o) / d of the plane x_a = c is enclosed by interval division
 * over [dlo_a, dhi_a], then widened by 2^-44 of itself (and 2^-1000), far more
 * than the few ulps by which the per-ray walk's own outward rounding (a
 * rounded difference, reciprocal and product, each widened by iv_down/iv_up:
 * under 2^-49 relative, plus a few subnormals) can put a ray's computed
 * crossing outside the exact one.  So the beam's range of
 * a cell holds every range the per-ray walk computes for a ray of the beam,
 * and a leaf the per-ray walk yields is always reached here.  An axis where D
 * holds 0 (or a component below 2^-500, where the crossings of some rays are
 * huge) gives no bound: [-inf, inf] for every cell. */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "beam_internal.h"

typedef struct bcell {
    double r[3][2]; /* per axis, [entry, exit] over every ray of the beam */
    uint32_t i[3];  /* cell coordinates at depth */
    oct_node_t word;
    int depth;
} bcell_t;

struct ray_beam_ws {
    int cap;
    bcell_t stack[];
};

/* As traverse.c: popping a cell pushes at most 8, so at depth k at most 7 per
 * level above plus 8 wait. */
static int beam_cap(int depth) { return 7 * (depth > 0 ? depth : 0) + 8; }

ray_beam_ws_t *ray_beam_ws_new(const oct_tree_t *tree)
{
    int depth = tree && tree->depth > 0 && tree->depth <= OCT_MAX_DEPTH ? tree->depth : 0;
    ray_beam_ws_t *ws = malloc(sizeof *ws + (size_t)beam_cap(depth) * sizeof(bcell_t));
    if (ws)
        ws->cap = beam_cap(depth);
    return ws;
}

void ray_beam_ws_free(ray_beam_ws_t *ws) { free(ws); }

/* One axis of the beam. */
typedef struct baxis {
    double o;
    iv_t d;   /* [dlo, dhi] */
    int free; /* no bound from this axis */
    int neg;  /* d < 0 on the whole beam: the near half is the upper one */
} baxis_t;

/* Widened past the per-ray walk's rounding (see the top of the file).  An
 * overflowed crossing stays as the per-ray walk would see it: a lower bound
 * +inf is DBL_MAX there (iv_down), an upper bound -inf is -DBL_MAX. */
static double widen_down(double x)
{
    return x == INFINITY ? DBL_MAX : x - (fabs(x) * 0x1p-44 + 0x1p-1000);
}

static double widen_up(double x)
{
    return x == -INFINITY ? -DBL_MAX : x + (fabs(x) * 0x1p-44 + 0x1p-1000);
}

/* An enclosure of the parameters where the rays of the beam cross x_a = c. */
static void beam_cross(const baxis_t *x, double c, double *lo, double *hi)
{
    iv_t s = iv_make(iv_add_down(c, -x->o), iv_add_up(c, -x->o));
    iv_t t = iv_div(s, x->d);
    *lo = widen_down(t.lo);
    *hi = widen_up(t.hi);
}

int ray_beam_reaches(const oct_tree_t *tree, ray_beam_ws_t *ws, const double o[3],
                     const double dlo[3], const double dhi[3])
{
    if (!tree || !tree->n_nodes || tree->depth < 0 || tree->depth > OCT_MAX_DEPTH)
        return 0; /* the per-ray walk yields nothing either */
    baxis_t ax[3];
    unsigned mask = 0;
    bcell_t *e = &ws->stack[0];
    for (int a = 0; a < 3; a++) {
        baxis_t *x = &ax[a];
        /* not finite: say nothing (the per-ray walk yields nothing for such a
         * ray, but claiming it is not worth a special case) */
        if (!isfinite(o[a]) || !isfinite(dlo[a]) || !isfinite(dhi[a]) || !(dlo[a] <= dhi[a]))
            return 1;
        x->o = o[a];
        x->d = iv_make(dlo[a], dhi[a]);
        x->free = !(dlo[a] > 0x1p-500) && !(dhi[a] < -0x1p-500);
        x->neg = !x->free && dhi[a] < 0;
        mask |= (unsigned)x->neg << a;
        e->i[a] = 0;
        if (x->free) {
            e->r[a][0] = -INFINITY;
            e->r[a][1] = INFINITY;
            continue;
        }
        double lo = tree->box[2 * a], hi = tree->box[2 * a + 1], dummy;
        beam_cross(x, x->neg ? hi : lo, &e->r[a][0], &dummy);
        beam_cross(x, x->neg ? lo : hi, &dummy, &e->r[a][1]);
    }
    e->word = tree->nodes[0];
    e->depth = 0;
    int sp = 1;
    static const unsigned half_mask[3][2] = {{0x55u, 0xaau}, {0x33u, 0xccu}, {0x0fu, 0xf0u}};
    while (sp > 0) {
        bcell_t p = ws->stack[--sp];
        double lo = 0.0, hi = INFINITY;
        for (int a = 0; a < 3; a++) {
            lo = p.r[a][0] > lo ? p.r[a][0] : lo;
            hi = p.r[a][1] < hi ? p.r[a][1] : hi;
        }
        if (!(lo <= hi))
            continue;
        switch (OCT_NODE_KIND(p.word)) {
        case OCT_LEAF:
            if (OCT_NODE_VALUE(p.word) < tree->n_leaves)
                return 1;
            break;
        case OCT_INTERIOR: {
            uint32_t first = OCT_NODE_VALUE(p.word);
            int depth = p.depth + 1;
            /* a corrupt tree: as traverse.c, children must exist and depth
             * stay within the tree */
            if ((uint64_t)first + 8 > tree->n_nodes || depth > tree->depth)
                break;
            const oct_node_t *kids = tree->nodes + first;
            double r[3][2][2];
            unsigned feasible = 0xffu;
            for (int a = 0; a < 3; a++) {
                if (ax[a].free) {
                    r[a][0][0] = r[a][1][0] = -INFINITY;
                    r[a][0][1] = r[a][1][1] = INFINITY;
                    continue;
                }
                double blo = tree->box[2 * a], bhi = tree->box[2 * a + 1];
                double mid = oct_coord(blo, bhi, 2 * (uint64_t)p.i[a] + 1, depth), mlo, mhi;
                beam_cross(&ax[a], mid, &mlo, &mhi);
                int near = ax[a].neg;
                r[a][near][0] = p.r[a][0];
                r[a][near][1] = mhi;
                r[a][!near][0] = mlo;
                r[a][!near][1] = p.r[a][1];
                unsigned m = 0;
                for (int h = 0; h < 2; h++)
                    if (r[a][h][0] <= hi && r[a][h][1] >= lo)
                        m |= half_mask[a][h];
                feasible &= m;
            }
            /* back to front on the stack: the front child is looked at first,
             * and a leaf near the front ends the walk soonest */
            for (int j = 7; j >= 0; j--) {
                unsigned k = (unsigned)j ^ mask;
                if (!(feasible >> k & 1u) || OCT_NODE_KIND(kids[k]) == OCT_EMPTY)
                    continue;
                if (sp >= ws->cap)
                    return 1; /* cannot happen (beam_cap); were it to, claim nothing */
                unsigned h[3] = {k & 1u, k >> 1 & 1u, k >> 2 & 1u};
                bcell_t *c = &ws->stack[sp++];
                for (int a = 0; a < 3; a++) {
                    c->r[a][0] = r[a][h[a]][0];
                    c->r[a][1] = r[a][h[a]][1];
                    c->i[a] = 2 * p.i[a] + h[a];
                }
                c->word = kids[k];
                c->depth = depth;
            }
            break;
        }
        default: /* OCT_EMPTY, or invalid: the per-ray walk yields nothing there */
            break;
        }
    }
    return 0;
}
