/* ivoct ray — the sampling baseline (not certified): step along the ray with
 * plain double evaluations, bisect the first sign change found.  Misses thin
 * features and double roots; kept to compare against. */
#include "roots_internal.h"

static void point_value(ctx_t *c, int n, const double *t, double *g)
{
    double x[RAY_BATCH], y[RAY_BATCH], z[RAY_BATCH];
    for (int k = 0; k < n; k++) {
        double p[3];
        ray_point(c->o, c->d, t[k], p);
        x[k] = p[0], y[k] = p[1], z[k] = p[2];
    }
    tape_eval_point(c->tape, c->ws, (size_t)n, x, y, z, g);
    c->evals++;
}

/* Bisection with plain double evaluations, seven interior points per call. */
static ray_hit_kind_t sample_bisect(ctx_t *c, double a, double b, double ga, ray_result_t *res)
{
    while (!tiny(a, b)) {
        double t[RAY_BATCH - 1], g[RAY_BATCH - 1];
        int n = 0;
        for (int j = 1; j < RAY_BATCH; j++) {
            double tj = a + (b - a) * ((double)j / RAY_BATCH);
            if (tj > a && tj < b && (n == 0 || tj > t[n - 1]))
                t[n++] = tj;
        }
        if (n == 0)
            break;
        point_value(c, n, t, g);
        double na = a, nb = b;
        int found = 0;
        for (int j = 0; j < n && !found; j++) {
            if (g[j] == 0)
                return hit(res, RAY_HIT_ROOT, t[j], t[j], t[j]);
            if (g[j] != g[j])
                continue;
            if ((g[j] < 0) != (ga < 0))
                nb = t[j], found = 1;
            else
                na = t[j];
        }
        a = na, b = nb;
    }
    return hit(res, RAY_HIT_ROOT, 0.5 * a + 0.5 * b, a, b);
}

ray_hit_kind_t sampling(ctx_t *c, const ray_opts_t *opts, double t0, double t1,
                               ray_result_t *res)
{
    double len = t1 - t0;
    double step = opts->sample_step > 0 ? opts->sample_step : len / 1000;
    double nd = step > 0 ? ceil(len / step) : 1;
    long n = nd < 1 ? 1 : nd > 1e8 ? 100000000L : (long)nd;
    double prev_t = NAN, prev_g = NAN;
    for (long base = 0; base <= n; base += RAY_BATCH) {
        double t[RAY_BATCH], g[RAY_BATCH];
        int cnt = 0;
        for (long k = base; k <= n && cnt < RAY_BATCH; k++)
            t[cnt++] = k == n ? t1 : t0 + len * ((double)k / (double)n);
        point_value(c, cnt, t, g);
        for (int j = 0; j < cnt; j++) {
            if (g[j] == 0)
                return hit(res, RAY_HIT_ROOT, t[j], t[j], t[j]);
            if (g[j] != g[j])
                continue;
            if (prev_g == prev_g && (prev_g < 0) != (g[j] < 0))
                return sample_bisect(c, prev_t, t[j], prev_g, res);
            prev_t = t[j], prev_g = g[j];
        }
    }
    return RAY_MISS;
}
