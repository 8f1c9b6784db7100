/* ivoct — the evaluators over a tape: point, interval, interval + gradient,
 * point + gradient and along a ray, and the choice of SIMD path.
 *
 * The point, interval and gradient evaluators run structure-of-arrays passes
 * (kernels.h, compiled per SIMD target): up to TAPE_BATCH boxes per pass over
 * the tape, every slot an array per bound with the lanes innermost, so the
 * switch on the op is paid once per clause and batch and the lane loops are
 * vectorised.  This file moves the caller's boxes into the workspace's input
 * arrays (a short batch padded with copies of its first box to a multiple of
 * KERNEL_ALIGN lanes) and the results out. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "eval_internal.h"

#define B TAPE_BATCH

struct tape_ws {
    uint32_t max_clauses;
    double *point;      /* max_clauses * B */
    double *lo, *hi;    /* max_clauses * B each */
    double *grad;       /* (max_clauses + 2) * G_ARRAYS * B (also the ray pass's R_ARRAYS) */
    uint32_t *gsrc;     /* 3 * max_clauses: where the gradient pass's partials live */
    double *in;         /* 12 * B: the inputs of a pass (the ray pass's directions and
                           rounding radii in the second half) */
    uint8_t *deps;      /* max_clauses: tape_deps of the gradient pass */
};

tape_ws_t *tape_ws_new(uint32_t max_clauses)
{
    tape_ws_t *ws = calloc(1, sizeof *ws);
    if (!ws)
        return NULL;
    if (max_clauses == 0)
        max_clauses = 1;
    size_t n = max_clauses;
    ws->max_clauses = max_clauses;
    ws->point = malloc(n * B * sizeof *ws->point);
    ws->lo = malloc(n * B * sizeof *ws->lo);
    ws->hi = malloc(n * B * sizeof *ws->hi);
    ws->grad = malloc((n + 2) * G_ARRAYS * B * sizeof *ws->grad);
    ws->gsrc = malloc(3 * n * sizeof *ws->gsrc);
    ws->in = malloc(12 * B * sizeof *ws->in);
    ws->deps = malloc(n);
    if (!ws->point || !ws->lo || !ws->hi || !ws->grad || !ws->gsrc || !ws->in ||
        !ws->deps) {
        tape_ws_free(ws);
        return NULL;
    }
    return ws;
}

size_t tape_ws_bytes(uint32_t max_clauses)
{
    size_t n = max_clauses ? max_clauses : 1;
    return sizeof(struct tape_ws) + n * B * sizeof(double) * (3 + G_ARRAYS) +
           2 * G_ARRAYS * B * sizeof(double) + 3 * n * sizeof(uint32_t) +
           12 * B * sizeof(double) + n;
}

void tape_ws_free(tape_ws_t *ws)
{
    if (!ws)
        return;
    free(ws->point);
    free(ws->lo);
    free(ws->hi);
    free(ws->grad);
    free(ws->gsrc);
    free(ws->in);
    free(ws->deps);
    free(ws);
}

/* ---- the SIMD path ------------------------------------------------------------ */

static const tape_kernels_t *const PATHS[] = {
#ifdef IVOCT_SIMD_X86
    &tape_kernels_avx512,
    &tape_kernels_avx2,
#endif
    &tape_kernels_portable,
};
enum { NPATHS = sizeof PATHS / sizeof PATHS[0] };

/* Can this CPU (and its OS, which must save the wide registers: the
 * compiler's cpu check reads XGETBV for that) run the path? */
static int cpu_runs(const tape_kernels_t *k)
{
#ifdef IVOCT_SIMD_X86
    if (k == &tape_kernels_avx2)
        return __builtin_cpu_supports("avx2");
    if (k == &tape_kernels_avx512)
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
               __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
#endif
    return k == &tape_kernels_portable;
}

static const tape_kernels_t *path_named(const char *name)
{
    for (int i = 0; i < NPATHS; i++)
        if (!strcmp(PATHS[i]->name, name))
            return PATHS[i];
    return NULL;
}

static _Atomic(const tape_kernels_t *) active_path;

/* The first path of PATHS the CPU runs, unless IVOCT_SIMD names one it runs. */
static const tape_kernels_t *default_path(void)
{
    const char *env = getenv("IVOCT_SIMD");
    const tape_kernels_t *k = env ? path_named(env) : NULL;
    if (k && cpu_runs(k))
        return k;
    for (int i = 0; i < NPATHS; i++)
        if (cpu_runs(PATHS[i]))
            return PATHS[i];
    return &tape_kernels_portable;
}

static const tape_kernels_t *kernels(void)
{
    const tape_kernels_t *k = atomic_load_explicit(&active_path, memory_order_acquire);
    if (!k) {
        k = default_path();
        atomic_store_explicit(&active_path, k, memory_order_release);
    }
    return k;
}

const char *tape_simd_name(void) { return kernels()->name; }
size_t tape_short_lanes(void) { return kernels()->short_lanes; }

const char *tape_simd_paths(void)
{
#ifdef IVOCT_SIMD_X86
    return "portable avx2 avx512";
#else
    return "portable";
#endif
}

int tape_simd_available(const char *name)
{
    const tape_kernels_t *k = name ? path_named(name) : NULL;
    return k && cpu_runs(k);
}

int tape_simd_select(const char *name, ivoct_error_t *err)
{
    if (!name) {
        atomic_store(&active_path, default_path());
        return 0;
    }
    const tape_kernels_t *k = path_named(name);
    if (!k) {
        ivoct_error_set(err, "unknown SIMD path '%s' (this build has: %s)", name,
                        tape_simd_paths());
        return -1;
    }
    if (!cpu_runs(k)) {
        ivoct_error_set(err, "SIMD path '%s' needs CPU features this machine lacks", name);
        return -1;
    }
    atomic_store(&active_path, k);
    return 0;
}

/* ---- moving batches in and out ---------------------------------------------------- */

/* The lanes a pass over m boxes runs: m rounded up to KERNEL_ALIGN, so that
 * the lane loops have no scalar remainder; but a batch shorter than that (a
 * ray's search asks for one or two segments at a time) runs its m lanes
 * alone: padding it would multiply its cost. */
static size_t padded(size_t m)
{
    return m < KERNEL_ALIGN ? m : (m + KERNEL_ALIGN - 1) / KERNEL_ALIGN * KERNEL_ALIGN;
}

/* The lanes of a point, interval or ray pass over m boxes: a short batch
 * padded to the path's short_lanes, which those passes run as a whole
 * (kernels.h, "Short batches"). */
static size_t padded_short(const tape_kernels_t *kern, size_t m)
{
    if (m <= kern->short_half)
        return kern->short_half;
    return m < kern->short_lanes ? kern->short_lanes : padded(m);
}

/* The input arrays of a pass over m boxes, np >= m lanes. */
static void load_boxes(tape_ws_t *ws, const iv_box_t *box, size_t m, size_t np)
{
    double *in = ws->in;
    for (size_t k = 0; k < np; k++) {
        const iv_box_t *b = &box[k < m ? k : 0];
        in[0 * B + k] = b->x.lo, in[1 * B + k] = b->x.hi;
        in[2 * B + k] = b->y.lo, in[3 * B + k] = b->y.hi;
        in[4 * B + k] = b->z.lo, in[5 * B + k] = b->z.hi;
    }
}

/* The input arrays of a pass over m points, np >= m lanes (x, y, z in the
 * first three). */
static void load_points(tape_ws_t *ws, const double *x, const double *y, const double *z,
                        size_t m, size_t np)
{
    double *in = ws->in;
    for (size_t k = 0; k < np; k++) {
        size_t j = k < m ? k : 0;
        in[k] = x[j], in[B + k] = y[j], in[2 * B + k] = z[j];
    }
}

#define PASS_IN(ws)                                                                          \
    {                                                                                        \
        (ws)->in, (ws)->in + B, (ws)->in + 2 * B, (ws)->in + 3 * B, (ws)->in + 4 * B,        \
            (ws)->in + 5 * B                                                                 \
    }

/* ---- point ------------------------------------------------------------------------ */

void tape_eval_point(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                     const double *y, const double *z, double *out)
{
    const tape_kernels_t *kern = kernels();
    const double *in[6] = PASS_IN(ws);
    for (size_t base = 0; base < n; base += B) {
        size_t m = n - base < B ? n - base : B, np = padded_short(kern, m);
        load_points(ws, x + base, y + base, z + base, m, np);
        kern->point(t, ws->point, np, in);
        memcpy(out + base, ws->point + (size_t)(t->n - 1) * B, m * sizeof *out);
    }
}

/* ---- interval --------------------------------------------------------------------- */

/* The choices of the m boxes of the pass just run (see
 * tape_eval_interval_choices); comparisons with an empty (NaN) operand are
 * false, so nothing is decided there. */
static void pass_choices(const tape_t *t, const tape_ws_t *ws, size_t m, uint8_t *choices)
{
    memset(choices, TAPE_CHOICE_BOTH, m * t->n);
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        const double *al = ws->lo + (size_t)c->a * B, *ah = ws->hi + (size_t)c->a * B;
        const double *bl = ws->lo + (size_t)c->b * B, *bh = ws->hi + (size_t)c->b * B;
        uint8_t *out = choices + i;
        switch ((tape_op_t)c->op) {
        case TAPE_MIN:
        case TAPE_MAX:
            /* the branch certainly selected: the gradient rules' fm_pick_* */
            for (size_t k = 0; k < m; k++) {
                iv_t A = iv_make(al[k], ah[k]), Bv = iv_make(bl[k], bh[k]);
                int pick = c->op == TAPE_MIN ? fm_pick_min(A, Bv) : fm_pick_max(A, Bv);
                out[k * t->n] = pick < 0   ? TAPE_CHOICE_A
                                : pick > 0 ? TAPE_CHOICE_B
                                           : TAPE_CHOICE_BOTH;
            }
            break;
        case TAPE_ABS:
            for (size_t k = 0; k < m; k++)
                out[k * t->n] = al[k] >= 0   ? TAPE_CHOICE_A
                                : ah[k] <= 0 ? TAPE_CHOICE_NEG_A
                                             : TAPE_CHOICE_BOTH;
            break;
        default:
            break;
        }
    }
}

void tape_eval_interval_choices(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                                iv_t *out, uint8_t *choices)
{
    const tape_kernels_t *kern = kernels();
    const double *in[6] = PASS_IN(ws);
    const size_t last = (size_t)(t->n - 1) * B;
    for (size_t base = 0; base < n; base += B) {
        size_t m = n - base < B ? n - base : B, np = padded_short(kern, m);
        load_boxes(ws, box + base, m, np);
        kern->interval(t, ws->lo, ws->hi, np, in);
        for (size_t k = 0; k < m; k++)
            out[base + k] = iv_make(ws->lo[last + k], ws->hi[last + k]);
        if (choices)
            pass_choices(t, ws, m, choices + base * t->n);
    }
}

void tape_eval_interval(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                        iv_t *out)
{
    tape_eval_interval_choices(t, ws, n, box, out, NULL);
}

/* ---- interval + gradient ------------------------------------------------------------ */

void tape_deps(const tape_t *t, uint8_t *deps)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        switch (tape_op_arity((tape_op_t)c->op)) {
        case 0:
            deps[i] = c->op == TAPE_X ? 1 : c->op == TAPE_Y ? 2 : c->op == TAPE_Z ? 4 : 0;
            break;
        case 1: deps[i] = deps[c->a]; break;
        default: deps[i] = deps[c->a] | deps[c->b]; break;
        }
    }
}

void tape_eval_grad(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                    iv_grad_t *out)
{
    const tape_kernels_t *kern = kernels();
    const double *in[6] = PASS_IN(ws);
    const double *r = ws->grad + (size_t)(t->n - 1) * G_ARRAYS * B;
    const uint32_t *rs = ws->gsrc + 3 * (size_t)(t->n - 1);
    tape_deps(t, ws->deps);
    for (size_t base = 0; base < n; base += B) {
        size_t m = n - base < B ? n - base : B, np = padded(m);
        load_boxes(ws, box + base, m, np);
        kern->grad(t, ws->deps, ws->grad, ws->gsrc, np, in);
        /* the partials where they live (the slots rs names: kernels.h) */
        const double *dx = ws->grad + ((size_t)rs[0] * G_ARRAYS + G_XLO) * B;
        const double *dy = ws->grad + ((size_t)rs[1] * G_ARRAYS + G_YLO) * B;
        const double *dz = ws->grad + ((size_t)rs[2] * G_ARRAYS + G_ZLO) * B;
        for (size_t k = 0; k < m; k++)
            out[base + k] = (iv_grad_t){{r[G_VLO * B + k], r[G_VHI * B + k]},
                                        {dx[k], dx[k + B]},
                                        {dy[k], dy[k + B]},
                                        {dz[k], dz[k + B]}};
    }
}

/* ---- point + gradient ----------------------------------------------------------------- */

void tape_eval_point_grad(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                          const double *y, const double *z, tape_point_grad_t *out)
{
    const tape_kernels_t *kern = kernels();
    const double *in[6] = PASS_IN(ws);
    const double *r = ws->grad + (size_t)(t->n - 1) * P_ARRAYS * B;
    tape_deps(t, ws->deps);
    for (size_t base = 0; base < n; base += B) {
        size_t m = n - base < B ? n - base : B, np = padded(m);
        load_points(ws, x + base, y + base, z + base, m, np);
        kern->point_grad(t, ws->deps, ws->grad, np, in);
        for (size_t k = 0; k < m; k++)
            out[base + k] = (tape_point_grad_t){r[P_V * B + k], r[P_X * B + k],
                                                r[P_Y * B + k], r[P_Z * B + k]};
    }
}

/* ---- along a ray -----------------------------------------------------------------
 * Forward mode with one tangent, the direction d of the ray: a slot carries
 * its value, its derivative along d and a magnitude bounding |∇u(p)·e| over
 * every e with |e_i| <= rho_i (the R_* arrays of the kernels' ray pass, a
 * structure of arrays over TAPE_BATCH lanes like the other passes).  The set of
 * those e is a box symmetric about 0, so every set ∇u(X)·e is symmetric too
 * and one non-negative bound per slot carries it, propagated in doubles
 * rounded up — the price of the rounding term is a few double operations per
 * clause instead of the three partials a full gradient would need. */

void tape_eval_ray(const tape_t *t, tape_ws_t *ws, const double o[3], const double d[3],
                   size_t n, const iv_t *T, iv_t *g, iv_t *dg, double *rnd)
{
    const tape_kernels_t *kern = kernels();
    const double *in[6] = PASS_IN(ws);
    const double *dir_rho[6] = {ws->in + 6 * B,  ws->in + 7 * B,  ws->in + 8 * B,
                                ws->in + 9 * B,  ws->in + 10 * B, ws->in + 11 * B};
    double tl[B], th[B];
    for (size_t base = 0; base < n; base += B) {
        size_t m = n - base < B ? n - base : B, np = padded_short(kern, m);
        for (size_t k = 0; k < np; k++) {
            iv_t Tk = T[base + (k < m ? k : 0)];
            tl[k] = Tk.lo, th[k] = Tk.hi;
        }
        kern->ray_inputs(np, o, d, tl, th, ws->in);
        if (!dg) { /* values only: the interval pass over the lanes' boxes */
            const size_t last = (size_t)(t->n - 1) * B;
            kern->interval(t, ws->lo, ws->hi, np, in);
            for (size_t k = 0; k < m; k++)
                g[base + k] = iv_make(ws->lo[last + k], ws->hi[last + k]);
            continue;
        }
        const double *r = ws->grad + (size_t)(t->n - 1) * R_ARRAYS * B;
        kern->ray(t, ws->grad, np, in, dir_rho);
        for (size_t k = 0; k < m; k++) {
            g[base + k] = iv_make(r[R_VLO * B + k], r[R_VHI * B + k]);
            dg[base + k] = iv_make(r[R_DLO * B + k], r[R_DHI * B + k]);
            if (rnd)
                rnd[base + k] = r[R_MAG * B + k];
        }
    }
}
