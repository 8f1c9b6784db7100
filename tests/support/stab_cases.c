/* The cases of the numerical stability suite: see stab_cases.h. */
#include "stab_cases.h"

#include <stdio.h>
#include <stdlib.h>

const char *const stab_offsets[STAB_N_OFFSETS] = {"1e3", "1e4", "1e5", "1e6", "1e7", "1e8"};

const char *const stab_scales[STAB_N_SCALES] = {"1e-8", "1e-6", "1e-4", "1e-2",
                                                "1e2",  "1e4",  "1e6",  "1e8"};

/* 1 / stab_scales[k], as texts: u = x * 1e8 is exact where u = x / 1e-8 is not */
static const char *const inverse_scales[STAB_N_SCALES] = {"1e8",  "1e6",  "1e4",  "1e2",
                                                          "1e-2", "1e-4", "1e-6", "1e-8"};

const char *const stab_shell_widths[STAB_N_SHELLS] = {"1e-3", "1e-6", "1e-9", "1e-12"};

const char *const stab_high_degree_scenes[STAB_N_HIGH_DEGREE] = {"barth-sextic", "tangle-cube",
                                                                 "clebsch-cubic"};

static void cube(stab_case_t *c, double r)
{
    c->half = r;
    for (int a = 0; a < 3; a++) {
        c->box[2 * a] = c->centre[a] - r;
        c->box[2 * a + 1] = c->centre[a] + r;
    }
}

void stab_translated(int surf, size_t k, int diag, stab_case_t *c)
{
    const char *off = stab_offsets[k];
    double v = strtod(off, NULL);
    c->f = surf ? STAB_GUMDROP : STAB_SPHERE;
    snprintf(c->u, sizeof c->u, "x - %s", off);
    snprintf(c->v, sizeof c->v, diag ? "y - %s" : "y", off);
    snprintf(c->w, sizeof c->w, diag ? "z - %s" : "z", off);
    snprintf(c->name, sizeof c->name, "translated %s +%s%s", surf ? "gumdrop" : "sphere", off,
             diag ? "(1,1,1)" : "x");
    c->centre[0] = v;
    c->centre[1] = c->centre[2] = diag ? v : 0;
    c->scale = 1;
    cube(c, surf ? 2 : 1.05);
}

void stab_scaled(int surf, size_t k, stab_case_t *c)
{
    double s = strtod(stab_scales[k], NULL);
    c->f = surf ? STAB_GUMDROP : STAB_SPHERE;
    snprintf(c->u, sizeof c->u, "x*%s", inverse_scales[k]);
    snprintf(c->v, sizeof c->v, "y*%s", inverse_scales[k]);
    snprintf(c->w, sizeof c->w, "z*%s", inverse_scales[k]);
    snprintf(c->name, sizeof c->name, "scaled %s x%s", surf ? "gumdrop" : "sphere",
             stab_scales[k]);
    c->centre[0] = c->centre[1] = c->centre[2] = 0;
    c->scale = s;
    cube(c, (surf ? 2 : 1.05) * s);
}
