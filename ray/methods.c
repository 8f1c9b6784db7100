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

static const ray_method_info_t METHODS[RAY_METHOD_COUNT] = {
    [RAY_MITCHELL] = {"mitchell", 1, RULES_INCLUSION, 1, 1, excluded, MONOTONE_END_SIGNS, 0},
    [RAY_NEWTON] = {"newton", 1, RULES_INCLUSION, 1, 1, excluded, MONOTONE_NEWTON, 0},
    [RAY_NEWTON_AH] = {"newton-ah", 1, RULES_INCLUSION, 1, 1, excluded, MONOTONE_NEWTON, 1},
    [RAY_MRFRO] = {"mrfro", 1, RULES_SIGNS, 0, 0, excluded, MONOTONE_END_SIGNS, 0},
    [RAY_MRFRO_NEWTON] = {"mrfro-newton", 1, RULES_SIGNS, 1, 0, excluded, MONOTONE_NEWTON, 0},
    [RAY_LIPSCHITZ] = {"lipschitz", 1, RULES_INCLUSION, 1, 0, lipschitz_excluded,
                       MONOTONE_END_SIGNS, 0},
    [RAY_SAMPLING] = {"sampling", 0, RULES_SAMPLING, 0, 0, NULL, MONOTONE_END_SIGNS, 0},
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
    return (unsigned)m < RAY_METHOD_COUNT && METHODS[m].certified;
}

void ray_opts_default(ray_opts_t *o)
{
    o->tol_rel = 0x1p-44;
    o->sample_step = 0;
    o->max_nodes = 100000;
}
