/* mesh/: the certified mesh (msh_build) against independent checks.
 *
 *  - Regular surfaces of known topology (sphere, gumdrop = 2 spheres and a
 *    torus, McMullen K3, a torus, the genus-2 bretzel): msh_build certifies
 *    every cell; the mesh is a closed, consistently oriented, embedded
 *    2-manifold (tests/support/mesh_check.c: exact arithmetic, written apart
 *    from mesh/), with the Euler characteristic and the number of components
 *    of the surface — known from its equation, and recomputed here from a
 *    dense sampling of the solid f < 0 (2 chi(solid) = chi(boundary)), which
 *    is how McMullen K3's is known; its triangles face f > 0 (positive
 *    volume); every vertex lies in the cell that made it, and MPFI proves a
 *    root of f within 1e-12 of the box's size of every vertex (f has
 *    opposite certified signs at two points that close on either side).
 *  - Singular surfaces (chubs: 12 singular points) are not certified:
 *    msh_build returns 1, the failed cells all lie near the singular points,
 *    every singular point has failed cells next to it, and they make 12
 *    regions of touching cells.
 *  - Every scene file: msh_build certifies it or lists failures; a certified
 *    mesh is an embedded, consistently oriented manifold whose boundary edges
 *    (if any) lie on the faces of the mesh box, and when closed it has the
 *    Euler characteristic of the sampled solid (the tangle cube's genus 5 too).
 *  - The same mesh, bit for bit, on every SIMD path; cells never coarser
 *    than min_depth; bad parameters and a tiny memory budget are refused. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <mpfi.h>

#include "expr/tape.h"
#include "mesh/mesh.h"
#include "scene/scene.h"
#include "mesh_check.h"
#include "mpfi_tape.h"
#include "testutil.h"

typedef struct surface {
    const char *name;
    const char *f;
    double box[6];
    long euler;        /* of the surface, from its equation; UNKNOWN_EULER: from the sampling only */
    size_t components;
} surface_t;

#define UNKNOWN_EULER (-1000)

/* gumdrop: with r^2 = y^2 + z^2 it is 4x^4 + 4r^4 + 17x^2r^2 - 20(x^2+r^2) + 17,
 * symmetric in x and r and positive on the diagonal x = r (25s^4 - 40s^2 + 17 > 0):
 * in the half plane r >= 0 a closed curve around each of (+-1.5, 0) (crossing
 * the axis: two spheres of revolution about x) and one around (0, 1.5) (a torus). */
static const surface_t regular[] = {
    {"sphere", "x^2 + y^2 + z^2 - 1", {-2, 2, -2, 2, -2, 2}, 2, 1},
    {"gumdrop", "4*(x^4 + (y^2+z^2)^2) + 17*x^2*(y^2+z^2) - 20*(x^2+y^2+z^2) + 17",
     {-2, 2, -2, 2, -2, 2}, 4, 3},
    {"McMullen K3", "(1 + x^2)*(1 + y^2)*(1 + z^2) + 8*x*y*z - 2",
     {-1.8, 1.8, -1.8, 1.8, -1.8, 1.8}, UNKNOWN_EULER, 1},
    {"torus", "(x^2 + y^2 + z^2 + 1 - 0.16)^2 - 4*(x^2 + y^2)",
     {-1.6, 1.6, -1.6, 1.6, -0.6, 0.6}, 0, 1},
    {"bretzel", "(((1 - x^2)*x^2 - y^2)^2 + z^2/2)/(1 + x^2 + y^2 + z^2) - 0.02",
     {-1.15, 1.15, -0.7, 0.7, -0.35, 0.35}, -2, 1},
};

static tape_t *compile(const char *f)
{
    tape_t *t = NULL;
    ivoct_error_t err;
    if (tape_compile(f, &t, &err))
        fail_msg("%s: %s", f, err.msg);
    return t;
}

static iv_box_t to_box(const double b[6])
{
    iv_box_t r = {{b[0], b[1]}, {b[2], b[3]}, {b[4], b[5]}};
    return r;
}

static int max_depth(void) { return tu_sanitizer_build() ? 7 : 8; }

/* Euler characteristic of the solid f < 0 sampled on an n^3 grid of box: the
 * cubical complex of the grid's vertices, edges, squares and cubes whose
 * corners all have f < 0.  A dense, non-certified count, independent of the
 * mesher: for the smooth surfaces here a grid this fine sees every handle. */
static long solid_euler(const tape_t *t, const double box[6], int n)
{
    size_t m = (size_t)(n + 1);
    unsigned char *in = malloc(m * m * m);
    double *x = malloc(m * sizeof *x), *y = malloc(m * sizeof *y), *z = malloc(m * sizeof *z),
           *f = malloc(m * sizeof *f);
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(in);
    assert_non_null(ws);
    for (size_t k = 0; k < m; k++)
        for (size_t j = 0; j < m; j++) {
            for (size_t i = 0; i < m; i++) {
                x[i] = box[0] + (box[1] - box[0]) * (double)i / n;
                y[i] = box[2] + (box[3] - box[2]) * (double)j / n;
                z[i] = box[4] + (box[5] - box[4]) * (double)k / n;
            }
            tape_eval_point(t, ws, m, x, y, z, f);
            for (size_t i = 0; i < m; i++)
                in[(k * m + j) * m + i] = f[i] < 0;
        }
    long chi = 0;
    for (size_t k = 0; k < m; k++)
        for (size_t j = 0; j < m; j++)
            for (size_t i = 0; i < m; i++) {
                /* every cell with its lowest corner at (i, j, k): extents e in {0,1}^3 */
                for (int e = 0; e < 8; e++) {
                    size_t ex = e & 1, ey = e >> 1 & 1, ez = e >> 2;
                    if (i + ex >= m || j + ey >= m || k + ez >= m)
                        continue;
                    int all = 1;
                    for (int c = 0; c < 8 && all; c++) {
                        size_t cx = i + (ex & c), cy = j + (ey & (size_t)(c >> 1)),
                               cz = k + (ez & (size_t)(c >> 2));
                        all = in[(cz * m + cy) * m + cx];
                    }
                    if (all)
                        chi += (ex + ey + ez) % 2 ? -1 : 1;
                }
            }
    free(in);
    free(x);
    free(y);
    free(z);
    free(f);
    tape_ws_free(ws);
    return chi;
}

/* Does MPFI prove a root of f within eps of p?  Opposite certified signs at
 * p - eps u and p + eps u for one of the axis directions u (or f = 0 at p). */
static int root_near(const tape_t *t, const double p[3], double eps)
{
    mpfi_t v;
    mpfi_init2(v, ORACLE_PREC);
    int found = 0;
    if (!oracle_eval(t, p, ORACLE_CONST_LO, v, NULL) && mpfi_is_zero(v))
        found = 1;
    for (int a = 0; a < 3 && !found; a++) {
        int s[2] = {0, 0};
        for (int k = 0; k < 2; k++) {
            double q[3] = {p[0], p[1], p[2]};
            q[a] += k ? eps : -eps;
            /* both ends of every constant: the sign must hold for each */
            int sl = 0, sh = 0;
            if (!oracle_eval(t, q, ORACLE_CONST_LO, v, NULL))
                sl = mpfi_is_strictly_pos(v) ? 1 : mpfi_is_strictly_neg(v) ? -1 : 0;
            if (!oracle_eval(t, q, ORACLE_CONST_HI, v, NULL))
                sh = mpfi_is_strictly_pos(v) ? 1 : mpfi_is_strictly_neg(v) ? -1 : 0;
            s[k] = sl == sh ? sl : 0;
        }
        found = s[0] && s[1] && s[0] == -s[1];
    }
    mpfi_clear(v);
    return found;
}

static void check_regular(const surface_t *sf)
{
    tape_t *t = compile(sf->f);
    iv_box_t box = to_box(sf->box);
    msh_params_t p = {max_depth(), 4, 0};
    msh_mesh_t m;
    ivoct_error_t err;
    int rc = msh_build(t, &box, &p, &m, &err);
    if (rc)
        fail_msg("%s: msh_build %d, %zu failures (%s)", sf->name, rc, m.n_failures,
                 m.n_failures ? msh_reason_name(m.failures[0].reason) : err.msg);
    assert_true(m.n_tris > 100);

    mc_report_t r;
    assert_int_equal(mc_check(m.points, m.n_points, m.tris, m.n_tris, 1, &r), 0);
    if (!mc_is_closed_embedded(&r))
        fail_msg("%s: not a closed embedded manifold: boundary %zu, non-manifold %zu/%zu, "
                 "misoriented %zu, degenerate %zu, intersecting %zu (triangles %zu and %zu)",
                 sf->name, r.boundary_edges, r.nonmanifold_edges, r.nonmanifold_vertices,
                 r.misoriented_edges, r.degenerate_triangles, r.intersecting_pairs,
                 r.first_pair[0], r.first_pair[1]);
    assert_int_equal(r.vertices, m.n_points);
    assert_int_equal(r.components, sf->components);
    const iv_t *mb = &m.box.x;
    double mbox[6] = {mb[0].lo, mb[0].hi, mb[1].lo, mb[1].hi, mb[2].lo, mb[2].hi};
    long sampled = 2 * solid_euler(t, mbox, tu_sanitizer_build() ? 128 : 160);
    if (sf->euler != UNKNOWN_EULER)
        assert_int_equal(sf->euler, sampled);
    if (r.euler != sampled)
        fail_msg("%s: Euler characteristic %ld, the surface's %ld", sf->name, r.euler, sampled);
    assert_true(mc_signed_volume(m.points, m.tris, m.n_tris) > 0);

    /* every vertex in its cell (the closed box) and next to a root of f */
    double size = fmax(mb[0].hi - mb[0].lo, fmax(mb[1].hi - mb[1].lo, mb[2].hi - mb[2].lo));
    size_t far = 0;
    for (size_t i = 0; i < m.n_tris; i++) {
        const iv_t *c = &m.cells[m.tri_cell[i]].x;
        assert_true(m.cell_depth[m.tri_cell[i]] >= p.min_depth);
        for (int k = 0; k < 3; k++) {
            const double *v = m.points + 3 * m.tris[3 * i + k];
            for (int a = 0; a < 3; a++)
                if (!(v[a] >= c[a].lo && v[a] <= c[a].hi))
                    fail_msg("%s: vertex %u outside its cell", sf->name, m.tris[3 * i + k]);
        }
    }
    size_t step = tu_sanitizer_build() ? 37 : 7;
    for (size_t v = 0; v < m.n_points; v += step)
        far += !root_near(t, m.points + 3 * v, 1e-12 * size);
    if (far)
        fail_msg("%s: %zu vertices farther than 1e-12 * %g from f = 0", sf->name, far, size);
    assert_int_equal(m.stats.apex_off_surface, 0);
    msh_free(&m);
    tape_free(t);
}

static void test_regular_surfaces(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof regular / sizeof regular[0]; i++)
        check_regular(&regular[i]);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Is p on a face of box (a boundary edge of a mesh may only lie there)? */
static int on_box_face(const iv_box_t *box, const double *p)
{
    const iv_t *r = &box->x;
    for (int a = 0; a < 3; a++)
        if (p[a] == r[a].lo || p[a] == r[a].hi)
            return 1;
    return 0;
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths), certified = 0;
    int depth = tu_sanitizer_build() ? 6 : 7;
    for (int i = 0; i < n; i++) {
        scene_t s;
        tu_load_scene(paths[i], &s);
        iv_box_t box = {{s.box[0], s.box[1]}, {s.box[2], s.box[3]}, {s.box[4], s.box[5]}};
        msh_params_t p = {depth, depth - 2, 0};
        msh_mesh_t m;
        ivoct_error_t err;
        int rc = msh_build(s.tape, &box, &p, &m, &err);
        if (rc < 0)
            fail_msg("%s: %s", paths[i], err.msg);
        if (rc == 1) {
            assert_true(m.n_failures > 0);
        } else {
            certified++;
            mc_report_t r;
            assert_int_equal(mc_check(m.points, m.n_points, m.tris, m.n_tris, 1, &r), 0);
            if (r.nonmanifold_edges || r.nonmanifold_vertices || r.misoriented_edges ||
                r.degenerate_triangles || r.intersecting_pairs || r.coincident_vertices)
                fail_msg("%s: non-manifold %zu/%zu, misoriented %zu, degenerate %zu, "
                         "intersecting %zu, coincident %zu", paths[i], r.nonmanifold_edges,
                         r.nonmanifold_vertices, r.misoriented_edges, r.degenerate_triangles,
                         r.intersecting_pairs, r.coincident_vertices);
            /* an edge in one triangle only: both its ends on the box's faces */
            size_t stray = 0;
            if (r.boundary_edges) {
                size_t ne = 3 * m.n_tris;
                uint64_t *e = malloc(ne * sizeof *e);
                assert_non_null(e);
                for (size_t t = 0; t < m.n_tris; t++)
                    for (int k = 0; k < 3; k++) {
                        uint64_t a = m.tris[3 * t + k], b = m.tris[3 * t + (k + 1) % 3];
                        e[3 * t + k] = a < b ? a << 32 | b : b << 32 | a;
                    }
                qsort(e, ne, sizeof *e, cmp_u64);
                for (size_t j = 0; j < ne;) {
                    size_t k = j;
                    while (k < ne && e[k] == e[j])
                        k++;
                    if (k - j == 1 && !(on_box_face(&m.box, m.points + 3 * (e[j] >> 32)) &&
                                        on_box_face(&m.box, m.points + 3 * (e[j] & 0xffffffffu))))
                        stray++;
                    j = k;
                }
                free(e);
            } else {
                const iv_t *mb = &m.box.x;
                double mbox[6] = {mb[0].lo, mb[0].hi, mb[1].lo, mb[1].hi, mb[2].lo, mb[2].hi};
                long sampled = 2 * solid_euler(s.tape, mbox, tu_sanitizer_build() ? 128 : 160);
                if (r.euler != sampled)
                    fail_msg("%s: Euler characteristic %ld, the sampled solid's boundary %ld",
                             paths[i], r.euler, sampled);
                if (strstr(paths[i], "tangle-cube"))
                    assert_int_equal(r.euler, 2 - 2 * 5); /* genus 5 */
            }
            if (stray)
                fail_msg("%s: %zu boundary edges off the box's faces", paths[i], stray);
        }
        msh_free(&m);
        scene_free(&s);
    }
    tu_free_list(paths, n);
    /* sphere, offset sphere, tiny sphere, param-sphere, McMullen K3, tangle cube, blobs */
    assert_true(certified >= 7);
}

/* chubs: 12 singular points, (+-1/sqrt2, +-1/sqrt2, 0) and permutations */
static void test_singular_surface_reported(void **state)
{
    (void)state;
    tape_t *t = compile("x^4 + y^4 + z^4 - x^2 - y^2 - z^2 + 0.5");
    double b[6] = {-1.1, 1.1, -1.1, 1.1, -1.1, 1.1};
    iv_box_t box = to_box(b);
    msh_params_t p = {tu_sanitizer_build() ? 6 : 7, 3, 0};
    msh_mesh_t m;
    ivoct_error_t err;
    assert_int_equal(msh_build(t, &box, &p, &m, &err), 1);
    assert_true(m.n_failures > 0);
    assert_int_equal(m.n_regions, 12); /* one per singular point */
    double s = sqrt(0.5), sing[12][3];
    int n = 0;
    for (int zero = 0; zero < 3; zero++)
        for (int sg = 0; sg < 4; sg++) {
            double q[2] = {sg & 1 ? -s : s, sg & 2 ? -s : s};
            for (int a = 0, j = 0; a < 3; a++)
                sing[n][a] = a == zero ? 0.0 : q[j++];
            n++;
        }
    int seen[12] = {0};
    for (size_t i = 0; i < m.n_failures; i++) {
        const msh_failure_t *f = &m.failures[i];
        const iv_t *c = &f->box.x;
        double diag = 0;
        for (int a = 0; a < 3; a++)
            diag += (c[a].hi - c[a].lo) * (c[a].hi - c[a].lo);
        diag = sqrt(diag);
        int near = 0;
        for (int k = 0; k < 12; k++) {
            double d2 = 0;
            for (int a = 0; a < 3; a++) {
                double d = fmax(0, fmax(c[a].lo - sing[k][a], sing[k][a] - c[a].hi));
                d2 += d * d;
            }
            if (sqrt(d2) <= 4 * diag) {
                near = 1;
                seen[k] |= sqrt(d2) <= diag;
            }
        }
        if (!near)
            fail_msg("failed cell %zu (%s, depth %d) far from every singular point", i,
                     msh_reason_name(f->reason), f->depth);
    }
    for (int k = 0; k < 12; k++)
        if (!seen[k])
            fail_msg("singular point %d (%g %g %g) not reported", k, sing[k][0], sing[k][1],
                     sing[k][2]);
    msh_free(&m);
    tape_free(t);
}

/* Bit-identical meshes on every SIMD path. */
static void test_same_mesh_every_path(void **state)
{
    (void)state;
    tape_t *t = compile(regular[2].f);
    iv_box_t box = to_box(regular[2].box);
    msh_params_t p = {6, 3, 0};
    msh_mesh_t first = {0};
    ivoct_error_t err;
    char paths[256];
    snprintf(paths, sizeof paths, "%s", tape_simd_paths());
    int n = 0;
    for (char *name = strtok(paths, " "); name; name = strtok(NULL, " ")) {
        if (!tape_simd_available(name))
            continue;
        assert_int_equal(tape_simd_select(name, &err), 0);
        msh_mesh_t m;
        assert_int_equal(msh_build(t, &box, &p, &m, &err), 0);
        if (n++ == 0) {
            first = m;
            continue;
        }
        assert_int_equal(m.n_points, first.n_points);
        assert_int_equal(m.n_tris, first.n_tris);
        assert_memory_equal(m.points, first.points, 3 * m.n_points * sizeof(double));
        assert_memory_equal(m.tris, first.tris, 3 * m.n_tris * sizeof(uint32_t));
        msh_free(&m);
    }
    assert_int_equal(tape_simd_select(NULL, &err), 0);
    assert_true(n >= 1);
    msh_free(&first);
    tape_free(t);
}

static void test_parameters_refused(void **state)
{
    (void)state;
    tape_t *t = compile("x^2 + y^2 + z^2 - 1");
    iv_box_t box = {{-2, 2}, {-2, 2}, {-2, 2}}, flat = {{-2, 2}, {1, 1}, {-2, 2}};
    msh_mesh_t m;
    ivoct_error_t err;
    const msh_params_t bad[] = {{0, 0, 0}, {MSH_MAX_DEPTH + 1, 0, 0}, {5, 6, 0}, {5, -1, 0}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        ivoct_error_clear(&err);
        assert_int_equal(msh_build(t, &box, &bad[i], &m, &err), -1);
        assert_non_null(strstr(err.msg, "depth"));
        assert_int_equal(m.n_points, 0);
    }
    msh_params_t p = {5, 2, 0};
    assert_int_equal(msh_build(t, &flat, &p, &m, &err), -1);
    assert_non_null(strstr(err.msg, "box"));
    p.max_memory = 4096;
    assert_int_equal(msh_build(t, &box, &p, &m, &err), -1);
    assert_non_null(strstr(err.msg, "memory budget"));
    assert_null(m.points);
    msh_free(&m); /* safe on the emptied mesh */
    tape_free(t);
}

/* The mesh box is the box grown a little, and the mesh respects min_depth. */
static void test_mesh_box_and_min_depth(void **state)
{
    (void)state;
    tape_t *t = compile("x^2 + y^2 + z^2 - 1");
    iv_box_t box = {{-2, 2}, {-1.5, 1.5}, {-1.25, 2}};
    iv_box_t mb = msh_mesh_box(&box);
    const iv_t *a = &box.x, *b = &mb.x;
    for (int k = 0; k < 3; k++) {
        assert_true(b[k].lo < a[k].lo && b[k].hi > a[k].hi);
        assert_true(b[k].hi - b[k].lo < 1.01 * (a[k].hi - a[k].lo));
    }
    for (int min = 0; min <= 5; min += 5) {
        msh_params_t p = {6, min, 0};
        msh_mesh_t m;
        ivoct_error_t err;
        assert_int_equal(msh_build(t, &box, &p, &m, &err), 0);
        for (size_t i = 0; i < m.n_cells; i++)
            assert_true(m.cell_depth[i] >= min && m.cell_depth[i] <= 6);
        mc_report_t r;
        assert_int_equal(mc_check(m.points, m.n_points, m.tris, m.n_tris, 1, &r), 0);
        assert_true(mc_is_closed_embedded(&r));
        assert_int_equal(r.euler, 2);
        msh_free(&m);
    }
    tape_free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_regular_surfaces),
        cmocka_unit_test(test_singular_surface_reported),
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_same_mesh_every_path),
        cmocka_unit_test(test_parameters_refused),
        cmocka_unit_test(test_mesh_box_and_min_depth),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
