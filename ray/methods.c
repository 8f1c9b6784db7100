/* ivoct ray — the root-finding methods: names, and the table of the rules
 * each one applies (roots_internal.h, ray_method_info_t).  The search
 * (search.c) asks a method's row what to do; a new method is a new row. */
#include <stdio.h>
#include <string.h>

#include "../lipschitz/lipschitz.h"
#include "roots_internal.h"

/* Kalra–Barr (lipschitz/lipschitz.h): |g(m)| > G·h + R: no root.  Where the
 * test has nothing to work with — f undefined at m, or no finite bound G (f
 * not Lipschitz on T, e.g. sqrt at 0) — the interval test 0 ∉ F(T) stands in. */
static int lipschitz_excluded(const node_t *n)
{
    if (sgn(n->gm) == S_UNDEF || !isfinite(lip_derivative_bound(n->Gp)))
        return excluded(n);
    return lip_segment_excludes(n->a, n->b, n->m, n->gm, n->Gp, lip_magnitude(n->R));
}

/* A field left out is 0: no derivatives, points with the boxes, the end-sign
 * solution of a monotone segment, no extended division. */
static const ray_method_info_t METHODS[RAY_METHOD_COUNT] = {
    [RAY_MITCHELL] = {.name = "mitchell", .rules = RULES_INCLUSION, .deriv = 1, .skip = 1,
                      .excludes = excluded},
    [RAY_NEWTON] = {.name = "newton", .rules = RULES_INCLUSION, .deriv = 1, .skip = 1,
                    .excludes = excluded, .monotone = MONOTONE_NEWTON},
    [RAY_NEWTON_AH] = {.name = "newton-ah", .rules = RULES_INCLUSION, .deriv = 1, .skip = 1,
                       .excludes = excluded, .monotone = MONOTONE_NEWTON, .extended = 1},
    [RAY_MRFRO] = {.name = "mrfro", .rules = RULES_SIGNS, .excludes = excluded},
    [RAY_MRFRO_NEWTON] = {.name = "mrfro-newton", .rules = RULES_SIGNS, .deriv = 1,
                          .excludes = excluded, .monotone = MONOTONE_NEWTON},
    [RAY_LIPSCHITZ] = {.name = "lipschitz", .rules = RULES_INCLUSION, .deriv = 1,
                       .excludes = lipschitz_excluded},
    [RAY_SAMPLING] = {.name = "sampling", .rules = RULES_SAMPLING},
};

const ray_method_info_t *ray_method_info(ray_method_t m)
{
    return (unsigned)m < RAY_METHOD_COUNT ? &METHODS[m] : NULL;
}

const char *ray_method_name(ray_method_t m)
{
    return (unsigned)m < RAY_METHOD_COUNT ? METHODS[m].name : NULL;
}

int ray_method_parse(const char *name, ray_method_t *m)
{
    for (int i = 0; i < RAY_METHOD_COUNT; i++)
        if (name && !strcmp(name, METHODS[i].name)) {
            *m = (ray_method_t)i;
            return 0;
        }
    return 1;
}

char *ray_method_list(char *buf, size_t n)
{
    if (!buf || n == 0)
        return buf;
    buf[0] = '\0';
    size_t len = 0;
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        const char *sep = m == 0 ? "" : m == RAY_METHOD_COUNT - 1 ? " or " : ", ";
        int w = snprintf(buf + len, n - len, "%s%s", sep, METHODS[m].name);
        if (w < 0 || (size_t)w >= n - len)
            break;
        len += (size_t)w;
    }
    return buf;
}

int ray_method_certified(ray_method_t m)
{
    return (unsigned)m < RAY_METHOD_COUNT && METHODS[m].rules != RULES_SAMPLING;
}

void ray_opts_default(ray_opts_t *o)
{
    o->tol_rel = 0x1p-44;
    o->sample_step = 0;
    o->max_nodes = 100000;
    o->any_root = 0;
}
