/* The cases of the numerical stability suite, shared by its octree half
 * (tests/test_stab_octree.c) and its ray half (tests/test_stab_rays.c) so that
 * both run the same ones:
 *  - translated: the sphere and the gumdrop written in u, v, w with
 *    u = x - off (and v = y - off, w = z - off along the diagonal), off from
 *    1e3 to 1e8;
 *  - scaled: the same with u = x * inverse (v, w alike), scale 1e-8 to 1e8;
 *  - thin shells |sqrt(x^2 + y^2 + z^2) - 1| - h, h from 1e-3 to 1e-12;
 *  - the high-degree scenes. */
#ifndef IVOCT_TEST_STAB_CASES_H
#define IVOCT_TEST_STAB_CASES_H

#include <stddef.h>

#define STAB_SPHERE "u^2 + v^2 + w^2 - 1"
#define STAB_GUMDROP "4*(u^4 + (v^2 + w^2)^2) + 17*u^2*(v^2 + w^2) - 20*(u^2 + v^2 + w^2) + 17"

/* the offsets of the translated cases and the scales of the scaled ones, as
 * decimal texts (exact powers of ten in the expressions) */
#define STAB_N_OFFSETS 6
extern const char *const stab_offsets[STAB_N_OFFSETS];
#define STAB_N_SCALES 8
extern const char *const stab_scales[STAB_N_SCALES];

/* the widths h of the thin shells */
#define STAB_N_SHELLS 4
extern const char *const stab_shell_widths[STAB_N_SHELLS];

/* scenes/NAME.ini of degree 6 and more, or with many singular points */
#define STAB_N_HIGH_DEGREE 3
extern const char *const stab_high_degree_scenes[STAB_N_HIGH_DEGREE];

/* One translated or scaled case: f in u, v, w with u, v, w in x, y, z (for
 * tu_compile_uvw), its name, and the cube box around the surface (half-edge 1.05
 * for the sphere, 2 for the gumdrop, times the scale) with its centre. */
typedef struct stab_case {
    const char *f;
    char u[32], v[32], w[32];
    char name[96];
    double centre[3];
    double half; /* the box's half-edge */
    double box[6];
    double scale; /* the length scale: 1 when translated */
} stab_case_t;

/* surf: 0 sphere, 1 gumdrop; k < STAB_N_OFFSETS; diag: along (1,1,1), else x */
void stab_translated(int surf, size_t k, int diag, stab_case_t *c);

/* surf: 0 sphere, 1 gumdrop; k < STAB_N_SCALES */
void stab_scaled(int surf, size_t k, stab_case_t *c);

#endif
