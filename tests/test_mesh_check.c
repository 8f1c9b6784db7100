/* The mesh checker of tests/support/mesh_check.c, on meshes whose answers are
 * known by construction, and its intersection predicate against an
 * independent exact oracle.
 *
 *  - closed meshes: a tetrahedron, an octahedron (two pyramids), a torus from a
 *    parametric grid, two disjoint tetrahedra; their counts, Euler
 *    characteristic, components and the sign of the volume;
 *  - broken ones: a face flipped (misoriented edges), a face removed (boundary),
 *    two interpenetrating tetrahedra, two tetrahedra sharing a vertex (a
 *    non-manifold vertex), a fin (a non-manifold edge), a bowtie (two open
 *    fans at a vertex), degenerate triangles
 *    and coincident vertices, bad input;
 *  - a flat grid in a tilted plane (exactly coplanar neighbours everywhere), then
 *    folded within the plane, then bent by one ulp; the octahedron at scales
 *    from 2^-1070 to 2^1023 (products under- and overflowing in double);
 *  - every degenerate way two triangles can touch, sharing 0, 1 or 2 vertices,
 *    each with its "intersecting" and its "fine" variant, under every
 *    permutation of both triangles' vertices and of the pair;
 *  - the exact fallback: points one ulp off a plane, and coplanar points one
 *    ulp off a line, where the plain double determinant is wrong or cannot
 *    tell;
 *  - the predicate against an oracle with nothing in common with it: the
 *    intersection of the two triangles computed as a polygon by exact
 *    rational clipping (Sutherland-Hodgman), then compared with the hull of
 *    the shared vertices; on random pairs from a small lattice (under an exact
 *    skewing map, so that coplanar and collinear cases abound off the axis
 *    planes) and from random doubles;
 *  - the grid of candidate pairs against all pairs, on random soups;
 *  - a subdivided icosahedron (20480 triangles; up to 327680 in the release
 *    build, timed) closed and embedded, then one vertex pushed through the
 *    opposite side. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <gmp.h>

#include "support/mesh_check.h"
#include "support/testutil.h"

#define PI 3.14159265358979323846

static mc_report_t check(const double *pts, size_t nv, const uint32_t *tris, size_t nt)
{
    mc_report_t r;
    assert_int_equal(mc_check(pts, nv, tris, nt, 1, &r), 0);
    assert_int_equal(r.intersections_checked, 1);
    assert_int_equal(r.triangles, nt);
    assert_int_equal(r.euler, (long)r.vertices - (long)r.edges + (long)r.triangles);
    return r;
}

/* ---- closed meshes ---------------------------------------------------------------------- */

/* the unit corner tetrahedron, faces outward */
static const double tet_pts[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const uint32_t tet_tris[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

static void test_tetrahedron(void **state)
{
    (void)state;
    mc_report_t r = check(tet_pts, 4, tet_tris, 4);
    assert_true(mc_is_closed_embedded(&r));
    assert_int_equal(r.vertices, 4);
    assert_int_equal(r.edges, 6);
    assert_int_equal(r.euler, 2);
    assert_int_equal(r.components, 1);
    assert_int_equal(r.boundary_edges + r.nonmanifold_edges + r.misoriented_edges, 0);
    assert_int_equal(r.nonmanifold_vertices + r.degenerate_triangles + r.coincident_vertices, 0);
    assert_int_equal(r.intersecting_pairs, 0);
    /* faces containing the origin add nothing: the volume is face 1 2 3's, 1/6 */
    assert_true(fabs(mc_signed_volume(tet_pts, tet_tris, 4) - 1.0 / 6) < 1e-15);

    /* without the intersection test, nothing is claimed embedded */
    mc_report_t q;
    assert_int_equal(mc_check(tet_pts, 4, tet_tris, 4, 0, &q), 0);
    assert_int_equal(q.intersections_checked, 0);
    assert_false(mc_is_closed_embedded(&q));
    assert_int_equal(q.euler, 2);
}

static void test_tetrahedron_flipped(void **state)
{
    (void)state;
    uint32_t t[12];
    memcpy(t, tet_tris, sizeof t);
    t[10] = 3; /* face 1 2 3 -> 1 3 2: its three edges now run as their neighbours do */
    t[11] = 2;
    mc_report_t r = check(tet_pts, 4, t, 4);
    assert_false(mc_is_closed_embedded(&r));
    assert_int_equal(r.misoriented_edges, 3);
    assert_int_equal(r.boundary_edges + r.nonmanifold_edges + r.nonmanifold_vertices, 0);
    assert_int_equal(r.euler, 2);
    assert_int_equal(r.intersecting_pairs, 0);
    assert_true(fabs(mc_signed_volume(tet_pts, t, 4) + 1.0 / 6) < 1e-15);
}

static void test_tetrahedron_open(void **state)
{
    (void)state;
    mc_report_t r = check(tet_pts, 4, tet_tris, 3); /* without face 1 2 3 */
    assert_false(mc_is_closed_embedded(&r));
    assert_int_equal(r.boundary_edges, 3);
    assert_int_equal(r.edges, 6);
    assert_int_equal(r.euler, 1); /* a disc */
    assert_int_equal(r.components, 1);
    assert_int_equal(r.misoriented_edges + r.nonmanifold_edges + r.nonmanifold_vertices, 0);
    assert_true(mc_signed_volume(tet_pts, tet_tris, 3) == 0);
}

static void test_octahedron(void **state)
{
    (void)state;
    /* +x -x +y -y +z -z */
    const double p[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    /* the top pyramid (apex +z) and the bottom one (apex -z), counter-clockwise from outside */
    const uint32_t t[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    mc_report_t r = check(p, 6, t, 8);
    assert_true(mc_is_closed_embedded(&r));
    assert_int_equal(r.vertices, 6);
    assert_int_equal(r.edges, 12);
    assert_int_equal(r.euler, 2);
    assert_int_equal(r.components, 1);
    assert_true(fabs(mc_signed_volume(p, t, 8) - 4.0 / 3) < 1e-14);
}

/* A torus of radii 2 and 0.7 from an nu x nv grid of (u, v), two triangles per quad,
 * facing outward (d/du x d/dv points out). */
static void torus(int nu, int nv, double **pts, uint32_t **tris)
{
    double *p = malloc(3 * (size_t)nu * nv * sizeof *p);
    uint32_t *t = malloc(6 * (size_t)nu * nv * sizeof *t);
    assert_non_null(p);
    assert_non_null(t);
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            double u = 2 * PI * i / nu, v = 2 * PI * j / nv;
            double *q = p + 3 * (i * nv + j);
            q[0] = (2 + 0.7 * cos(v)) * cos(u);
            q[1] = (2 + 0.7 * cos(v)) * sin(u);
            q[2] = 0.7 * sin(v);
            uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j),
                     c = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv),
                     d = (uint32_t)(i * nv + (j + 1) % nv);
            uint32_t *x = t + 6 * (i * nv + j);
            x[0] = a, x[1] = b, x[2] = c, x[3] = a, x[4] = c, x[5] = d;
        }
    *pts = p;
    *tris = t;
}

static void test_torus(void **state)
{
    (void)state;
    double *p;
    uint32_t *t;
    torus(24, 12, &p, &t);
    mc_report_t r = check(p, 24 * 12, t, 2 * 24 * 12);
    assert_true(mc_is_closed_embedded(&r));
    assert_int_equal(r.vertices, 288);
    assert_int_equal(r.edges, 864);
    assert_int_equal(r.euler, 0);
    assert_int_equal(r.components, 1);
    /* the polyhedron is inscribed: a little less than 2 pi^2 R r^2 */
    double vol = mc_signed_volume(p, t, 576), exact = 2 * PI * PI * 2 * 0.49;
    assert_true(vol > 0.9 * exact && vol < exact);
    free(p);
    free(t);
}

/* two copies of the tetrahedron, the second moved by (dx, dy, dz) */
static void two_tets(double dx, double dy, double dz, double p[24], uint32_t t[24])
{
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++) {
            p[3 * i + k] = tet_pts[3 * i + k];
            p[12 + 3 * i + k] = tet_pts[3 * i + k] + (k == 0 ? dx : k == 1 ? dy : dz);
        }
    for (int i = 0; i < 12; i++) {
        t[i] = tet_tris[i];
        t[12 + i] = tet_tris[i] + 4;
    }
}

static void test_two_tetrahedra(void **state)
{
    (void)state;
    double p[24];
    uint32_t t[24];
    two_tets(3, 0, 0, p, t);
    mc_report_t r = check(p, 8, t, 8);
    assert_true(mc_is_closed_embedded(&r));
    assert_int_equal(r.components, 2);
    assert_int_equal(r.euler, 4);

    /* interpenetrating: the corner (0.2, 0.2, 0.2) of the second is inside the first */
    two_tets(0.2, 0.2, 0.2, p, t);
    r = check(p, 8, t, 8);
    assert_false(mc_is_closed_embedded(&r));
    assert_true(r.intersecting_pairs > 0);
    assert_true(r.first_pair[0] < 4 && r.first_pair[1] >= 4); /* one face of each */
    assert_int_equal(r.euler, 4);
    assert_int_equal(r.components, 2);
    assert_int_equal(r.boundary_edges + r.misoriented_edges + r.nonmanifold_edges, 0);

    /* moved by exactly 1 in x: the first's vertex 1 (1, 0, 0) is the second's vertex 4's
     * point (distinct indices), where the two touch */
    two_tets(1, 0, 0, p, t);
    r = check(p, 8, t, 8);
    assert_int_equal(r.coincident_vertices, 1);
    assert_true(r.intersecting_pairs > 0);
    assert_false(mc_is_closed_embedded(&r));
}

static void test_tets_sharing_vertex(void **state)
{
    (void)state;
    /* the tetrahedron and its mirror image through the origin, sharing vertex 0: the
     * mirror reverses orientation, so its faces are listed reversed to face outward */
    const double p[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, -1, 0, 0, 0, -1, 0, 0, 0, -1};
    uint32_t t[24];
    for (int f = 0; f < 4; f++)
        for (int k = 0; k < 3; k++) {
            t[3 * f + k] = tet_tris[3 * f + k];
            uint32_t v = tet_tris[3 * f + 2 - k];
            t[12 + 3 * f + k] = v ? v + 3 : 0;
        }
    mc_report_t r = check(p, 7, t, 8);
    assert_int_equal(r.vertices, 7);
    assert_int_equal(r.edges, 12);
    assert_int_equal(r.euler, 3);
    assert_int_equal(r.components, 2); /* components are joined through edges only */
    assert_int_equal(r.nonmanifold_vertices, 1);
    assert_int_equal(r.boundary_edges + r.misoriented_edges + r.nonmanifold_edges, 0);
    assert_int_equal(r.intersecting_pairs, 0); /* they meet in the shared vertex only */
    assert_false(mc_is_closed_embedded(&r));
    assert_true(fabs(mc_signed_volume(p, t, 8) - 2.0 / 6) < 1e-15);
}

static void test_fin(void **state)
{
    (void)state;
    /* edge 0-1 on the z axis, three triangles around it at 0, 120 and 240 degrees */
    const double p[] = {0, 0, 0, 0, 0, 1, 1, 0, 0.5, -0.5, 0.8660254037844386, 0.5,
                        -0.5, -0.8660254037844386, 0.5};
    const uint32_t t[] = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    mc_report_t r = check(p, 5, t, 3);
    assert_int_equal(r.nonmanifold_edges, 1);
    assert_int_equal(r.boundary_edges, 6);
    assert_int_equal(r.misoriented_edges, 0);
    assert_int_equal(r.nonmanifold_vertices, 2); /* the ends of the fin's edge */
    assert_int_equal(r.edges, 7);
    assert_int_equal(r.euler, 1);
    assert_int_equal(r.components, 1);
    assert_int_equal(r.intersecting_pairs, 0);

    /* a bowtie: two triangles meeting at vertex 0 only, two open fans there */
    const uint32_t b[] = {0, 2, 3, 0, 4, 1};
    const double q[] = {0, 0, 0, -1, 0.5, 0, 1, -0.5, 0, 1, 0.5, 0, -1, -0.5, 0};
    r = check(q, 5, b, 2);
    assert_int_equal(r.nonmanifold_vertices, 1);
    assert_int_equal(r.nonmanifold_edges, 0);
    assert_int_equal(r.boundary_edges, 6);
    assert_int_equal(r.components, 2);
    assert_int_equal(r.euler, 1);
    assert_int_equal(r.intersecting_pairs, 0);
}

static void test_degenerate(void **state)
{
    (void)state;
    const double p[] = {0, 0, 0, 2, 2, 2, 1, 1, 1, 5, 0, 0, 0.5, 0.5, 0x1.0000000000001p-1,
                        0, 0, 0};
    /* exactly collinear (vertex 2 the midpoint of 0 1); a repeated index; one ulp off the line:
     * not degenerate */
    const uint32_t t[] = {0, 1, 2, 3, 3, 1, 0, 1, 4};
    mc_report_t r = check(p, 6, t, 3);
    assert_int_equal(r.degenerate_triangles, 2);
    assert_int_equal(r.coincident_vertices, 0);
    /* the vertices of the triangle with a repeated index are no manifold points */
    assert_int_equal(r.nonmanifold_vertices, 2);
    assert_int_equal(r.intersecting_pairs, 0); /* degenerate triangles are not tested */
    assert_false(mc_is_closed_embedded(&r));

    /* vertex 5 is vertex 0's point: a triangle on it is degenerate, and the pair counts */
    const uint32_t t2[] = {0, 1, 3, 5, 1, 3};
    r = check(p, 6, t2, 2);
    assert_int_equal(r.coincident_vertices, 1);
    assert_int_equal(r.degenerate_triangles, 0);
    assert_int_equal(r.intersecting_pairs, 1); /* they share edge 1 3 by index, and more */
    const uint32_t t3[] = {5, 1, 0};
    r = check(p, 6, t3, 1);
    assert_int_equal(r.degenerate_triangles, 1);
    assert_int_equal(r.coincident_vertices, 1);

    /* three coincident points: three pairs; an unused vertex does not count */
    const double q[] = {1, 2, 3, 1, 2, 3, 1, 2, 3, 1, 2, 3, 0, 0, 0, -0.0, 0, 0};
    const uint32_t t4[] = {0, 1, 4, 2, 4, 5};
    r = check(q, 6, t4, 2);
    assert_int_equal(r.coincident_vertices, 3 + 1); /* 0 1 2, and 4 5 (-0.0 == 0.0) */
}

static void test_bad_input(void **state)
{
    (void)state;
    mc_report_t r;
    const uint32_t t[] = {0, 1, 4};
    assert_int_equal(mc_check(tet_pts, 4, t, 1, 1, &r), -1);
    assert_int_equal(r.triangles, 0);
    double p[12];
    memcpy(p, tet_pts, sizeof p);
    p[4] = NAN;
    assert_int_equal(mc_check(p, 4, tet_tris, 4, 1, &r), -1);
    p[4] = INFINITY;
    assert_int_equal(mc_check(p, 4, tet_tris, 4, 1, &r), -1);
    /* an unused vertex may be anything */
    assert_int_equal(mc_check(p, 4, t, 0, 1, &r), 0);
    assert_int_equal(r.vertices, 0);
    assert_false(mc_is_closed_embedded(&r));
    /* the empty mesh */
    assert_int_equal(mc_check(NULL, 0, NULL, 0, 1, &r), 0);
    assert_int_equal(r.triangles + r.edges + r.components, 0);
}

/* A flat n x n grid of squares, two triangles each, in the plane z = x/2 + y/4 (the
 * coordinates are multiples of 1/256: exact, so the grid is exactly flat off the axis planes;
 * every neighbouring pair is coplanar and needs the exact stage). */
static void tilted_grid(int n, double **pts, uint32_t **tris)
{
    double *p = malloc(3 * (size_t)(n + 1) * (n + 1) * sizeof *p);
    uint32_t *t = malloc(6 * (size_t)n * n * sizeof *t);
    assert_non_null(p);
    assert_non_null(t);
    for (int i = 0; i <= n; i++)
        for (int j = 0; j <= n; j++) {
            double *q = p + 3 * (i * (n + 1) + j);
            q[0] = i / 64.0;
            q[1] = j / 64.0;
            q[2] = q[0] / 2 + q[1] / 4;
        }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            uint32_t a = (uint32_t)(i * (n + 1) + j), b = a + (uint32_t)(n + 1);
            const uint32_t q[6] = {a, b, b + 1, a, b + 1, a + 1};
            memcpy(t + 6 * (i * n + j), q, sizeof q);
        }
    *pts = p;
    *tris = t;
}

static void test_flat(void **state)
{
    (void)state;
    const int n = 20;
    double *p;
    uint32_t *t;
    tilted_grid(n, &p, &t);
    size_t nv = (size_t)(n + 1) * (n + 1), nt = 2 * (size_t)n * n;
    mc_report_t r = check(p, nv, t, nt);
    assert_int_equal(r.intersecting_pairs, 0);
    assert_int_equal(r.boundary_edges, 4 * n);
    assert_int_equal(r.euler, 1);
    assert_int_equal(r.misoriented_edges + r.nonmanifold_edges + r.nonmanifold_vertices, 0);
    assert_true(r.exact_fallbacks > 0);

    /* a middle vertex moved within the plane past its neighbour: the triangles around it fold
     * over their neighbours, still exactly flat */
    size_t v = (size_t)(n / 2) * (n + 1) + n / 2;
    p[3 * v] += 1.5 / 64;
    p[3 * v + 2] = p[3 * v] / 2 + p[3 * v + 1] / 4;
    r = check(p, nv, t, nt);
    assert_true(r.intersecting_pairs > 0);
    assert_int_equal(r.euler, 1);

    /* lifted off the plane by a hair instead: no fold, every neighbour pair just bent */
    p[3 * v] -= 1.5 / 64;
    p[3 * v + 2] = nextafter(p[3 * v] / 2 + p[3 * v + 1] / 4, INFINITY);
    r = check(p, nv, t, nt);
    assert_int_equal(r.intersecting_pairs, 0);
    free(p);
    free(t);
}

static void test_extreme_scales(void **state)
{
    (void)state;
    /* the octahedron at scales where products in double would overflow or underflow (the
     * filter steps aside: everything exact), and one where even differences overflow */
    const double o[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    const uint32_t t[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    const double scales[] = {0x1p-1070, 1e-200, 1e-100, 1e100, 1e200, 0x1p1023};
    for (size_t s = 0; s < sizeof scales / sizeof *scales; s++) {
        double p[18];
        for (int i = 0; i < 18; i++)
            p[i] = o[i] * scales[s];
        mc_report_t r = check(p, 6, t, 8);
        if (!mc_is_closed_embedded(&r))
            fail_msg("octahedron at scale %g: not closed and embedded (%zu degenerate, %zu "
                     "intersecting)",
                     scales[s], r.degenerate_triangles, r.intersecting_pairs);
        assert_true(r.exact_fallbacks > 0);
        /* and with a copy moved by (1/2, 1/4, 1/8) of its size: the two cross */
        double q[36];
        uint32_t u[48];
        for (int i = 0; i < 18; i++) {
            q[i] = p[i];
            q[18 + i] = p[i] + scales[s] * (i % 3 == 0 ? 0.5 : i % 3 == 1 ? 0.25 : 0.125);
        }
        for (int i = 0; i < 24; i++) {
            u[i] = t[i];
            u[24 + i] = t[i] + 6;
        }
        r = check(q, 12, u, 16);
        assert_true(r.intersecting_pairs > 0);
        assert_true(r.first_pair[0] < 8 && r.first_pair[1] >= 8);
        assert_int_equal(r.components, 2);
    }
}

/* ---- the degenerate contacts, one at a time ------------------------------------------- */

/* Triangles a and b of the points p (ncoord coordinates): mc_triangles_intersect must answer want for every
 * rotation and reversal of both and for both orders, and mc_check on the two gives the
 * same. */
static void pair_case(const char *name, const double *p, size_t ncoord, const uint32_t a[3],
                      const uint32_t b[3], int want)
{
    size_t np = ncoord / 3;
    assert_int_equal(ncoord % 3, 0); /* a coordinate left out of a point list */
    for (int k = 0; k < 3; k++)
        assert_true(a[k] < np && b[k] < np);
    static const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 6; j++) {
            uint32_t x[3], y[3];
            for (int k = 0; k < 3; k++) {
                x[k] = a[perm[i][k]];
                y[k] = b[perm[j][k]];
            }
            int got = mc_triangles_intersect(p, x, y), back = mc_triangles_intersect(p, y, x);
            if (got != want || back != want)
                fail_msg("%s: permutation %d %d: %d and %d, expected %d", name, i, j, got, back,
                         want);
        }
    uint32_t t[6] = {a[0], a[1], a[2], b[0], b[1], b[2]};
    mc_report_t r = check(p, np, t, 2);
    if (r.intersecting_pairs != (size_t)want)
        fail_msg("%s: mc_check counts %zu intersecting pairs, expected %d", name,
                 r.intersecting_pairs, want);
    if (want)
        assert_true(r.first_pair[0] == 0 && r.first_pair[1] == 1);
}

#define PAIR_CASE(name, p, a, b, want) pair_case(name, p, sizeof p / sizeof *p, a, b, want)

static const uint32_t A[3] = {0, 1, 2}, B[3] = {3, 4, 5};

/* no shared vertex */
static void test_contacts_disjoint(void **state)
{
    (void)state;
    const double tiny = 0x1p-60;
    /* A in z = 0: (0,0,0) (1,0,0) (0,1,0) */
#define TRI_A 0, 0, 0, 1, 0, 0, 0, 1, 0
    {
        const double p[] = {TRI_A, 0.2, 0.2, 0, 1.2, 0.2, 0, 0.2, 1.2, 0}; /* coplanar overlap */
        PAIR_CASE("coplanar overlapping", p, A, B, 1);
    }
    {
        const double p[] = {TRI_A, 0.1, 0.1, 0, 0.3, 0.1, 0, 0.1, 0.3, 0}; /* B inside A */
        PAIR_CASE("coplanar nested", p, A, B, 1);
    }
    {
        const double p[] = {TRI_A, 0.6, 0.6, 0, 1.6, 0.6, 0, 0.6, 1.6, 0}; /* beyond the edge */
        PAIR_CASE("coplanar apart", p, A, B, 0);
    }
    {
        /* B's vertex on A's edge y = 0, B below it */
        const double p[] = {TRI_A, 0.5, 0, 0, 0.2, -1, 0, 0.8, -1, 0};
        PAIR_CASE("coplanar vertex on edge", p, A, B, 1);
        const double q[] = {TRI_A, 0.5, -tiny, 0, 0.2, -1, 0, 0.8, -1, 0};
        PAIR_CASE("coplanar vertex just off the edge", q, A, B, 0);
    }
    {
        /* B shares A's edge 0-1 as points (vertices 3, 4 at A's 0, 1), on the other side */
        const double p[] = {TRI_A, 0, 0, 0, 1, 0, 0, 0.5, -1, 0};
        PAIR_CASE("coplanar edge by coordinates", p, A, B, 1);
        const double q[] = {TRI_A, 0, -tiny, 0, 1, -tiny, 0, 0.5, -1, 0};
        PAIR_CASE("coplanar edge just apart", q, A, B, 0);
    }
    {
        /* B's vertex at a point of A's interior, B above */
        const double p[] = {TRI_A, 0.25, 0.25, 0, 0.25, 0.25, 1, 0.5, 0, 1};
        PAIR_CASE("vertex on interior", p, A, B, 1);
        const double q[] = {TRI_A, 0.25, 0.25, tiny, 0.25, 0.25, 1, 0.5, 0, 1};
        PAIR_CASE("vertex just above interior", q, A, B, 0);
        const double s[] = {TRI_A, 0.25, 0.25, -tiny, 0.25, 0.25, 1, 0.5, 0, 1};
        PAIR_CASE("vertex just below interior (piercing)", s, A, B, 1);
    }
    {
        /* B's vertex on A's edge x + y = 1, B above */
        const double p[] = {TRI_A, 0.5, 0.5, 0, 0.5, 0.5, 1, 1, 1, 1};
        PAIR_CASE("vertex on edge", p, A, B, 1);
        const double q[] = {TRI_A, 0.5, 0.5 + 0x1p-53, 0, 0.5, 0.5, 1, 1, 1, 1};
        PAIR_CASE("vertex just beyond edge", q, A, B, 0);
    }
    {
        /* B's vertex at A's vertex (1,0,0), distinct indices */
        const double p[] = {TRI_A, 1, 0, 0, 2, 0, 1, 2, 1, 1};
        PAIR_CASE("vertex on vertex", p, A, B, 1);
    }
    {
        /* skew edges: B's edge from (0.5,-1,1) to (0.5,1,-1) crosses A's edge y = 0 at
         * (0.5, 0, 0); B's third vertex away below */
        const double p[] = {TRI_A, 0.5, -1, 1, 0.5, 1, -1, 3, -1, -1};
        PAIR_CASE("edge crosses edge", p, A, B, 1);
        const double q[] = {TRI_A, 0.5, -1 - 0x1p-52, 1, 0.5, 1 - 0x1p-52, -1, 3, -1, -1};
        PAIR_CASE("edge passes by edge", q, A, B, 0);
    }
    {
        /* B's edge through A's interior, ends far above and below */
        const double p[] = {TRI_A, 0.2, 0.2, -1, 0.2, 0.2, 1, 2, 2, 0};
        PAIR_CASE("edge pierces interior", p, A, B, 1);
    }
    {
        /* B perpendicular, its edge lying in A's plane across A */
        const double p[] = {TRI_A, -1, 0.3, 0, 2, 0.3, 0, 0.5, 0.3, 1};
        PAIR_CASE("edge lies across", p, A, B, 1);
    }
#undef TRI_A
}

/* one shared vertex, index 0 (at the origin) */
static void test_contacts_vertex(void **state)
{
    (void)state;
    const uint32_t b[3] = {0, 3, 4};
    const double tiny = 0x1p-60;
#define TRI_A 0, 0, 0, 1, 0, 0, 0, 1, 0
    {
        /* coplanar fans folded over each other: B's wedge inside A's quadrant */
        const double p[] = {TRI_A, 2, 1, 0, 1, 2, 0};
        PAIR_CASE("fans folded over", p, A, b, 1);
        /* B's wedge straddling A's edge along x */
        const double q[] = {TRI_A, 1, -1, 0, 1, 1, 0};
        PAIR_CASE("fans overlapping", q, A, b, 1);
        /* the opposite quadrant */
        const double s[] = {TRI_A, -1, 0, 0, 0, -1, 0};
        PAIR_CASE("fans opposite", s, A, b, 0);
        /* B's edge along A's edge 0-2 (x = 0), B on the other side: they share a segment */
        const double u[] = {TRI_A, 0, 2, 0, -1, 1, 0};
        PAIR_CASE("fans along a common edge", u, A, b, 1);
        /* B's edge along -y, opposite A's edge along +y: they meet at the origin only */
        const double v[] = {TRI_A, 0, -2, 0, -1, 1, 0};
        PAIR_CASE("fans with opposite edges", v, A, b, 0);
        /* B's edge just off A's edge 0-1 direction, below */
        const double w[] = {TRI_A, 1, -tiny, 0, 1, -1, 0};
        PAIR_CASE("fans with edges one angle apart", w, A, b, 0);
    }
    {
        /* B's far vertex on A's opposite edge (0.5, 0.5, 0), B above: B's edge to it lies in
         * A; lifted by a hair, B leaves A's plane at once */
        const double p[] = {TRI_A, 0.5, 0.5, 0, 0, 0, 1};
        PAIR_CASE("far vertex on opposite edge", p, A, b, 1);
        const double q[] = {TRI_A, 0.5, 0.5, tiny, 0, 0, 1};
        PAIR_CASE("far vertex above opposite edge", q, A, b, 0);
        /* B's far vertex touching A's interior */
        const double s[] = {TRI_A, 0.2, 0.2, 0, 0, 0, 1};
        PAIR_CASE("far vertex on interior", s, A, b, 1);
    }
    {
        /* B's opposite edge through A's interior */
        const double p[] = {TRI_A, 0.3, 0.3, -1, 0.3, 0.3, 1};
        PAIR_CASE("opposite edge pierces", p, A, b, 1);
    }
    {
        /* B crosses A's plane along the ray (t, t, 0), which enters A: a segment in common */
        const double p[] = {TRI_A, 1, 1, -1, 1, 1, 1};
        PAIR_CASE("planes cross inside", p, A, b, 1);
        /* along (-t, -t, 0): outside A */
        const double q[] = {TRI_A, -1, -1, -1, -1, -1, 1};
        PAIR_CASE("planes cross outside", q, A, b, 0);
        /* a non-coplanar neighbour touching only at the vertex */
        const double s[] = {TRI_A, -1, 0, 1, 0, -1, 1};
        PAIR_CASE("vertex only", s, A, b, 0);
    }
    {
        /* B's other vertex at A's vertex 1's point (distinct index) */
        const double p[] = {TRI_A, 1, 0, 0, 0, 0, 1};
        PAIR_CASE("shared vertex and a coincident one", p, A, b, 1);
    }
#undef TRI_A
}

/* a shared edge, indices 0 1 */
static void test_contacts_edge(void **state)
{
    (void)state;
    const uint32_t b[3] = {1, 0, 3};
#define TRI_A 0, 0, 0, 1, 0, 0, 0.3, 1, 0
    {
        const double p[] = {TRI_A, 0.7, 2, 0};
        PAIR_CASE("folded flat, same side", p, A, b, 1);
        const double q[] = {TRI_A, 0.7, 0.1, 0};
        PAIR_CASE("folded flat, inside", q, A, b, 1);
        const double s[] = {TRI_A, -5, 1e-3, 0};
        PAIR_CASE("folded flat, far to the side", s, A, b, 1);
        const double u[] = {TRI_A, 0.7, -2, 0};
        PAIR_CASE("flat, opposite sides", u, A, b, 0);
        const double v[] = {TRI_A, 0.7, 2, 0x1p-70};
        PAIR_CASE("folded almost flat", v, A, b, 0);
        const double w[] = {TRI_A, 0.7, 2, 1};
        PAIR_CASE("bent", w, A, b, 0);
        const double x[] = {TRI_A, 0.3, 1, 0}; /* vertex 3 at vertex 2's point */
        PAIR_CASE("folded flat onto itself", x, A, b, 1);
    }
#undef TRI_A
    {
        /* the same triangle twice shares three vertices: fine by the definition */
        const double p[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        const uint32_t c[3] = {2, 1, 0};
        assert_int_equal(mc_triangles_intersect(p, A, A), 0);
        assert_int_equal(mc_triangles_intersect(p, A, c), 0);
        /* a degenerate one is refused */
        const uint32_t d[3] = {0, 0, 1};
        assert_int_equal(mc_triangles_intersect(p, A, d), -1);
    }
}

/* ---- the exact fallback ----------------------------------------------------------------- */

/* sign of det[a - d; b - d; c - d] in rationals: the test's own, for expected answers */
static int orient_q(const double *a, const double *b, const double *c, const double *d)
{
    mpq_t m[9], t, u, det;
    const double *r[3] = {a, b, c};
    for (int i = 0; i < 9; i++) {
        mpq_init(m[i]);
        mpq_set_d(m[i], r[i / 3][i % 3]);
        mpq_init(t);
        mpq_set_d(t, d[i % 3]);
        mpq_sub(m[i], m[i], t);
        mpq_clear(t);
    }
    mpq_inits(t, u, det, NULL);
    /* det by the rule of Sarrus */
    static const int pl[3][3] = {{0, 4, 8}, {1, 5, 6}, {2, 3, 7}}, mi[3][3] = {{2, 4, 6}, {0, 5, 7}, {1, 3, 8}};
    for (int k = 0; k < 3; k++) {
        mpq_mul(t, m[pl[k][0]], m[pl[k][1]]);
        mpq_mul(t, t, m[pl[k][2]]);
        mpq_add(det, det, t);
        mpq_mul(u, m[mi[k][0]], m[mi[k][1]]);
        mpq_mul(u, u, m[mi[k][2]]);
        mpq_sub(det, det, u);
    }
    int s = mpq_sgn(det);
    for (int i = 0; i < 9; i++)
        mpq_clear(m[i]);
    mpq_clears(t, u, det, NULL);
    return s;
}

/* the same determinant in plain doubles, as a naive mesher would */
static int orient_naive(const double *a, const double *b, const double *c, const double *d)
{
    double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
    double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
    double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
    double det = adx * (bdy * cdz - bdz * cdy) + bdx * (cdy * adz - cdz * ady) +
                 cdx * (ady * bdz - adz * bdy);
    return (det > 0) - (det < 0);
}

static void test_exact_fallback(void **state)
{
    (void)state;
    /* A in the plane x + y + z = 1 (all coordinates dyadic); B's vertex d at a point of A's
     * interior, and one ulp above and below it; B's other vertices above the plane.  The
     * determinants are within rounding of 0: the filter must hand them to GMP. */
    double p[] = {0.75, 0.125, 0.125, 0.125, 0.75, 0.125, 0.125, 0.125, 0.75,
                  0.25, 0.25, 0.5, 0.5, 0.5, 1, 0.25, 0.75, 1};
    PAIR_CASE("on the skew plane", p, A, B, 1);
    mc_report_t r = check(p, 6, (const uint32_t[]){0, 1, 2, 3, 4, 5}, 2);
    assert_true(r.exact_fallbacks > 0);
    p[11] = nextafter(0.5, 1);
    PAIR_CASE("an ulp above the skew plane", p, A, B, 0);
    p[11] = nextafter(0.5, 0);
    PAIR_CASE("an ulp below the skew plane", p, A, B, 1);

    /* Random triangles, a point near the centroid stepped by k ulps in z for k = -3..3, and
     * two more points well above: B touches or crosses A iff the point is on or below A's
     * plane (exactly).  Keep going until the naive double determinant has given the
     * opposite of the exact sign several times (not only 0 for a nonzero or the reverse). */
    uint64_t rng = tu_seed(0x6d65736863686b31ull);
    int naive_wrong = 0, naive_flip = 0, cases = 0, crossing = 0;
    for (int trial = 0; trial < 20000 && naive_flip < 25; trial++) {
        double q[18];
        double off = trial % 2 ? 1000 : 0; /* far from the origin the rounding is coarser */
        for (int i = 0; i < 9; i++)
            q[i] = off + tu_uniform(&rng);
        double u[3], v[3], n[3], len = 0, tl = 0;
        for (int k = 0; k < 3; k++) {
            u[k] = q[3 + k] - q[k];
            v[k] = q[6 + k] - q[k];
        }
        n[0] = u[1] * v[2] - u[2] * v[1];
        n[1] = u[2] * v[0] - u[0] * v[2];
        n[2] = u[0] * v[1] - u[1] * v[0];
        for (int k = 0; k < 3; k++) {
            len += n[k] * n[k];
            tl += u[k] * u[k];
        }
        len = sqrt(len);
        tl = sqrt(tl);
        if (len < 0.05 || fabs(n[2]) < 0.2 * len) /* no slivers; z steps must move off the plane */
            continue;
        double d[3];
        for (int k = 0; k < 3; k++)
            d[k] = (q[k] + q[3 + k] + q[6 + k]) / 3;
        for (int k = 0; k < 3; k++) {
            q[12 + k] = d[k] + 0.25 * n[k] / len + 0.1 * u[k] / tl;
            q[15 + k] = d[k] + 0.25 * n[k] / len - 0.1 * u[k] / tl;
        }
        int above = orient_q(q, q + 3, q + 6, q + 12);
        assert_true(above != 0 && orient_q(q, q + 3, q + 6, q + 15) == above);
        for (int step = -3; step <= 3; step++) {
            q[9] = d[0];
            q[10] = d[1];
            q[11] = d[2];
            for (int s = 0; s < abs(step); s++)
                q[11] = nextafter(q[11], step > 0 ? INFINITY : -INFINITY);
            int exact = orient_q(q, q + 3, q + 6, q + 9);
            int naive = orient_naive(q, q + 3, q + 6, q + 9);
            naive_wrong += naive != exact;
            naive_flip += naive && naive != exact;
            int want = exact != above;
            crossing += want;
            cases++;
            int got = mc_triangles_intersect(q, A, B);
            if (got != want)
                fail_msg("trial %d step %d: mc_triangles_intersect %d, exact orientation %d "
                         "(B above: %d), expected %d",
                         trial, step, got, exact, above, want);
        }
    }
    printf("exact fallback: %d near-plane cases (%d touching or crossing), the naive double "
           "determinant wrong in %d (the opposite sign in %d)\n",
           cases, crossing, naive_wrong, naive_flip);
    assert_true(naive_flip >= 1);
    assert_true(crossing > 0 && crossing < cases);
}

/* sign of (a - c) x (b - c) in the xy plane, in rationals and in doubles */
static int orient2_q(const double *a, const double *b, const double *c)
{
    mpq_t x[6], l, r;
    const double v[6] = {a[0], a[1], b[0], b[1], c[0], c[1]};
    for (int i = 0; i < 6; i++) {
        mpq_init(x[i]);
        mpq_set_d(x[i], v[i]);
    }
    mpq_inits(l, r, NULL);
    for (int i = 0; i < 4; i++)
        mpq_sub(x[i], x[i], x[4 + i % 2]);
    mpq_mul(l, x[0], x[3]);
    mpq_mul(r, x[1], x[2]);
    int s = mpq_cmp(l, r);
    for (int i = 0; i < 6; i++)
        mpq_clear(x[i]);
    mpq_clears(l, r, NULL);
    return (s > 0) - (s < 0);
}

static int orient2_naive(const double *a, const double *b, const double *c)
{
    double det = (a[0] - c[0]) * (b[1] - c[1]) - (a[1] - c[1]) * (b[0] - c[0]);
    return (det > 0) - (det < 0);
}

static void test_exact_fallback_planar(void **state)
{
    (void)state;
    /* Coplanar triangles in z = 0, where everything is decided by planar orientations:
     * random A, a point d near the middle of A's edge 0 1 stepped by k ulps in y for
     * k = -3..3, and B = d and two points well outside that edge.  B meets A iff d is on the
     * edge or inside (exactly).  And the triangle 0 1 d is degenerate iff d is exactly on the
     * line. */
    uint64_t rng = tu_seed(0x706c616e61723131ull);
    int naive_wrong = 0, naive_flip = 0, cases = 0, inside = 0, collinear = 0;
    for (int trial = 0; trial < 20000 && naive_flip < 25; trial++) {
        double q[18] = {0};
        /* small coordinates; far from the origin; a long edge, whose ends and middle differ
         * in magnitude so that the differences round (where the naive sign flips) */
        int kind = trial % 3;
        double off = kind == 1 ? 1000 : 0;
        for (int i = 0; i < 3; i++) {
            q[3 * i] = off + tu_uniform(&rng);
            q[3 * i + 1] = off + tu_uniform(&rng);
        }
        if (kind == 2) {
            q[3] += 16 + 16 * tu_uniform(&rng);
            q[4] += 16 * tu_uniform(&rng);
            double h = 0.3 + 0.4 * tu_uniform(&rng);
            q[6] = (q[0] + q[3]) / 2 - h * (q[4] - q[1]);
            q[7] = (q[1] + q[4]) / 2 + h * (q[3] - q[0]);
        }
        double ex = q[3] - q[0], ey = q[4] - q[1], el = sqrt(ex * ex + ey * ey);
        int sa = orient2_q(q, q + 3, q + 6);
        if (el < 0.1 || fabs(ex) < 0.2 * el || sa == 0)
            continue;
        double area = fabs((q[3] - q[0]) * (q[7] - q[1]) - (q[4] - q[1]) * (q[6] - q[0]));
        if (area < 0.05 * el * el)
            continue; /* no slivers: d must be far from the other two edges */
        /* the outer normal of edge 0 1 (away from vertex 2) */
        double nx = ey / el, ny = -ex / el;
        if ((q[6] - q[0]) * nx + (q[7] - q[1]) * ny > 0)
            nx = -nx, ny = -ny;
        double d[2] = {(q[0] + q[3]) / 2, (q[1] + q[4]) / 2};
        q[12] = d[0] + 0.3 * nx + 0.1 * ex / el;
        q[13] = d[1] + 0.3 * ny + 0.1 * ey / el;
        q[15] = d[0] + 0.3 * nx - 0.1 * ex / el;
        q[16] = d[1] + 0.3 * ny - 0.1 * ey / el;
        assert_true(orient2_q(q, q + 3, q + 12) == -sa && orient2_q(q, q + 3, q + 15) == -sa);
        for (int step = -3; step <= 3; step++) {
            q[9] = d[0];
            q[10] = d[1];
            for (int s = 0; s < abs(step); s++)
                q[10] = nextafter(q[10], step > 0 ? INFINITY : -INFINITY);
            int exact = orient2_q(q, q + 3, q + 9), naive = orient2_naive(q, q + 3, q + 9);
            naive_wrong += naive != exact;
            naive_flip += naive && naive != exact;
            int want = exact != -sa;
            inside += want;
            collinear += exact == 0;
            cases++;
            int got = mc_triangles_intersect(q, A, B);
            if (got != want)
                fail_msg("planar trial %d step %d: mc_triangles_intersect %d, exact side %d (A's "
                         "side %d), expected %d",
                         trial, step, got, exact, sa, want);
            const uint32_t t[3] = {0, 1, 3};
            mc_report_t r = check(q, 4, t, 1);
            if (r.degenerate_triangles != (exact == 0))
                fail_msg("planar trial %d step %d: %zu degenerate, exact side %d", trial, step,
                         r.degenerate_triangles, exact);
        }
    }
    printf("exact fallback, planar: %d near-edge cases (%d on or inside, %d exactly on the "
           "line), the naive double determinant wrong in %d (the opposite sign in %d)\n",
           cases, inside, collinear, naive_wrong, naive_flip);
    assert_true(naive_flip >= 1);
    assert_true(inside > 0 && inside < cases);
}

/* ---- the clipping oracle ---------------------------------------------------------------- */

#define OR_MAX 64

typedef struct oracle {
    mpq_t poly[2][OR_MAX][3];
    mpq_t a[3][3], b[3][3], n[3], w[3], e[3], t, s, c, l0, l1;
    mpq_t f[OR_MAX];
} oracle_t;

static void oracle_init(oracle_t *o)
{
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < OR_MAX; j++)
            for (int k = 0; k < 3; k++)
                mpq_init(o->poly[i][j][k]);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            mpq_init(o->a[i][k]);
            mpq_init(o->b[i][k]);
        }
    for (int k = 0; k < 3; k++) {
        mpq_init(o->n[k]);
        mpq_init(o->w[k]);
        mpq_init(o->e[k]);
    }
    for (int j = 0; j < OR_MAX; j++)
        mpq_init(o->f[j]);
    mpq_inits(o->t, o->s, o->c, o->l0, o->l1, NULL);
}

static void oracle_clear(oracle_t *o)
{
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < OR_MAX; j++)
            for (int k = 0; k < 3; k++)
                mpq_clear(o->poly[i][j][k]);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            mpq_clear(o->a[i][k]);
            mpq_clear(o->b[i][k]);
        }
    for (int k = 0; k < 3; k++) {
        mpq_clear(o->n[k]);
        mpq_clear(o->w[k]);
        mpq_clear(o->e[k]);
    }
    for (int j = 0; j < OR_MAX; j++)
        mpq_clear(o->f[j]);
    mpq_clears(o->t, o->s, o->c, o->l0, o->l1, NULL);
}

/* r = x cross y */
static void cross_q(mpq_t r[3], mpq_t x[3], mpq_t y[3], mpq_t tmp)
{
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        mpq_mul(r[k], x[i], y[j]);
        mpq_mul(tmp, x[j], y[i]);
        mpq_sub(r[k], r[k], tmp);
    }
}

static void dot_q(mpq_t r, mpq_t x[3], mpq_t y[3], mpq_t tmp)
{
    mpq_set_ui(r, 0, 1);
    for (int k = 0; k < 3; k++) {
        mpq_mul(tmp, x[k], y[k]);
        mpq_add(r, r, tmp);
    }
}

/* Sutherland-Hodgman step: keep the part of poly[src] (n points) where w . x - c >= 0, into
 * poly[1 - src]; the new count.  A convex polygon (possibly flat: a segment or a point,
 * traversed forth and back) stays one, with exactly its part in the closed half-space as
 * hull. */
static int clip_q(oracle_t *o, int src, int n)
{
    mpq_t(*in)[3] = o->poly[src], (*out)[3] = o->poly[1 - src];
    for (int i = 0; i < n; i++) {
        dot_q(o->f[i], o->w, in[i], o->t);
        mpq_sub(o->f[i], o->f[i], o->c);
    }
    int m = 0;
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n, si = mpq_sgn(o->f[i]), sj = mpq_sgn(o->f[j]);
        if (si >= 0) {
            assert_true(m < OR_MAX);
            for (int k = 0; k < 3; k++)
                mpq_set(out[m][k], in[i][k]);
            m++;
        }
        if ((si > 0 && sj < 0) || (si < 0 && sj > 0)) {
            assert_true(m < OR_MAX);
            /* x = in[i] + (in[j] - in[i]) f_i / (f_i - f_j) */
            mpq_sub(o->s, o->f[i], o->f[j]);
            mpq_div(o->s, o->f[i], o->s);
            for (int k = 0; k < 3; k++) {
                mpq_sub(o->t, in[j][k], in[i][k]);
                mpq_mul(o->t, o->t, o->s);
                mpq_add(out[m][k], in[i][k], o->t);
            }
            m++;
        }
    }
    return m;
}

/* -1 when triangle ia is degenerate, else whether A and B meet other than in the hull of
 * their shared vertices: A ∩ B computed as a polygon by clipping B by A's plane (both
 * half-spaces) and by A's three inward edge half-spaces. */
static int oracle_intersects(oracle_t *o, const double *p, const uint32_t ia[3],
                             const uint32_t ib[3])
{
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            mpq_set_d(o->a[i][k], p[3 * (size_t)ia[i] + k]);
            mpq_set_d(o->b[i][k], p[3 * (size_t)ib[i] + k]);
        }
    mpq_t u[3], v[3];
    for (int k = 0; k < 3; k++) {
        mpq_init(u[k]);
        mpq_init(v[k]);
        mpq_sub(u[k], o->a[1][k], o->a[0][k]);
        mpq_sub(v[k], o->a[2][k], o->a[0][k]);
    }
    cross_q(o->n, u, v, o->t);
    for (int k = 0; k < 3; k++) {
        mpq_clear(u[k]);
        mpq_clear(v[k]);
    }
    if (!mpq_sgn(o->n[0]) && !mpq_sgn(o->n[1]) && !mpq_sgn(o->n[2]))
        return -1;
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            mpq_set(o->poly[0][i][k], o->b[i][k]);
    int n = 3, src = 0;
    /* n . x >= n . a0, then -n . x >= -n . a0 */
    for (int side = 0; side < 2; side++) {
        for (int k = 0; k < 3; k++) {
            if (side)
                mpq_neg(o->w[k], o->n[k]);
            else
                mpq_set(o->w[k], o->n[k]);
        }
        dot_q(o->c, o->w, o->a[0], o->t);
        n = clip_q(o, src, n);
        src = 1 - src;
    }
    /* (n x (a[i+1] - a[i])) . (x - a[i]) >= 0: the side of edge i towards the triangle */
    for (int i = 0; i < 3 && n; i++) {
        for (int k = 0; k < 3; k++)
            mpq_sub(o->e[k], o->a[(i + 1) % 3][k], o->a[i][k]);
        cross_q(o->w, o->n, o->e, o->t);
        dot_q(o->c, o->w, o->a[i], o->t);
        n = clip_q(o, src, n);
        src = 1 - src;
    }
    /* shared vertices, by index */
    int sh[3], ns = 0;
    for (int i = 0; i < 3; i++)
        if (ia[i] == ib[0] || ia[i] == ib[1] || ia[i] == ib[2])
            sh[ns++] = i;
    if (ns == 3)
        return 0;
    mpq_t(*k)[3] = o->poly[src];
    for (int j = 0; j < n; j++) {
        if (ns == 0)
            return 1;
        if (ns == 1) {
            for (int c = 0; c < 3; c++)
                if (!mpq_equal(k[j][c], o->a[sh[0]][c]))
                    return 1;
            continue;
        }
        /* on the segment a[sh0] a[sh1]: (x - u) x (w - u) = 0 and 0 <= (x - u).(w - u) <= |w - u|^2 */
        mpq_t d[3], e[3], x[3];
        for (int c = 0; c < 3; c++) {
            mpq_inits(d[c], e[c], x[c], NULL);
            mpq_sub(d[c], k[j][c], o->a[sh[0]][c]);
            mpq_sub(e[c], o->a[sh[1]][c], o->a[sh[0]][c]);
        }
        cross_q(x, d, e, o->t);
        int on = !mpq_sgn(x[0]) && !mpq_sgn(x[1]) && !mpq_sgn(x[2]);
        dot_q(o->l0, d, e, o->t);
        dot_q(o->l1, e, e, o->t);
        on = on && mpq_sgn(o->l0) >= 0 && mpq_cmp(o->l0, o->l1) <= 0;
        for (int c = 0; c < 3; c++)
            mpq_clears(d[c], e[c], x[c], NULL);
        if (!on)
            return 1;
    }
    return 0;
}

/* Random pairs from a pool of 7 points: each triangle three distinct pool indices, so pairs
 * share 0 to 3 indices; with lattice points, repeated coordinates give coincident vertices
 * too.  Checks mc_triangles_intersect against the oracle and counts the outcomes. */
static void oracle_run(const char *name, int lattice, int pairs, uint64_t *rng)
{
    /* an exact skewing map for lattice points: dyadic entries, small integers in: every
     * coordinate exact, so coplanarity and collinearity survive, off the axis planes */
    static const double M[3][3] = {{0.75, 0.5, -0.25}, {0.125, 1.0, 0.375}, {-0.5, 0.25, 1.0}};
    oracle_t o;
    oracle_init(&o);
    size_t seen[3][2] = {{0}};
    double p[21];
    int bad = 0;
    for (int it = 0; it < pairs; it++) {
        if (it % 50 == 0) {
            int skew = lattice && (it / 50) % 2, far = lattice && (it / 50) % 4 == 3;
            for (int i = 0; i < 7; i++) {
                double x[3];
                for (int k = 0; k < 3; k++)
                    x[k] = lattice ? (double)(tu_next(rng) % 3) : tu_uniform(rng);
                for (int k = 0; k < 3; k++)
                    p[3 * i + k] = skew ? M[k][0] * x[0] + M[k][1] * x[1] + M[k][2] * x[2] : x[k];
                if (far) /* exact still: 2^40 + small dyadics */
                    for (int k = 0; k < 3; k++)
                        p[3 * i + k] += 0x1p40;
            }
        }
        uint32_t t[2][3];
        for (int j = 0; j < 2; j++) {
            t[j][0] = (uint32_t)(tu_next(rng) % 7);
            do
                t[j][1] = (uint32_t)(tu_next(rng) % 7);
            while (t[j][1] == t[j][0]);
            do
                t[j][2] = (uint32_t)(tu_next(rng) % 7);
            while (t[j][2] == t[j][0] || t[j][2] == t[j][1]);
        }
        int da = oracle_intersects(&o, p, t[1], t[0]) < 0; /* degeneracy of t[1] */
        int want = oracle_intersects(&o, p, t[0], t[1]);
        int got = mc_triangles_intersect(p, t[0], t[1]);
        if (want < 0 || da) {
            if (got != -1)
                fail_msg("%s: a degenerate triangle gives %d", name, got);
            continue;
        }
        /* the oracle is not symmetric in its arguments: the other order must agree */
        int want2 = oracle_intersects(&o, p, t[1], t[0]);
        if (want != want2 || got != want) {
            if (bad++ < 5)
                fprintf(stderr,
                        "%s: %u %u %u / %u %u %u: checker %d, oracle %d (reversed %d); points:",
                        name, t[0][0], t[0][1], t[0][2], t[1][0], t[1][1], t[1][2], got, want,
                        want2);
            if (bad <= 5) {
                for (int i = 0; i < 21; i++)
                    fprintf(stderr, " %.17g", p[i]);
                fprintf(stderr, "\n");
            }
            continue;
        }
        int s = 0;
        for (int i = 0; i < 3; i++)
            s += t[0][i] == t[1][0] || t[0][i] == t[1][1] || t[0][i] == t[1][2];
        if (s < 3)
            seen[s][want]++;
    }
    oracle_clear(&o);
    printf("%s: shared 0: %zu fine, %zu intersecting; 1: %zu, %zu; 2: %zu, %zu\n", name,
           seen[0][0], seen[0][1], seen[1][0], seen[1][1], seen[2][0], seen[2][1]);
    assert_int_equal(bad, 0);
    if (lattice) /* every kind of pair, both ways */
        for (int s = 0; s < 3; s++)
            assert_true(seen[s][0] > 0 && seen[s][1] > 0);
}

static void test_against_oracle(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x6f7261636c653231ull);
    int n = (int)(40000 * tu_scale());
    oracle_run("lattice pairs", 1, n, &rng);
    oracle_run("random pairs", 0, n / 4, &rng);
}

/* ---- the grid against all pairs --------------------------------------------------------- */

static void brute_force(const double *p, const uint32_t *t, size_t nt, size_t *count,
                        size_t first[2])
{
    *count = 0;
    first[0] = first[1] = 0;
    for (size_t i = 0; i < nt; i++)
        for (size_t j = i + 1; j < nt; j++) {
            int x = mc_triangles_intersect(p, t + 3 * i, t + 3 * j);
            if (x == 1 && !(*count)++) {
                first[0] = i;
                first[1] = j;
            }
        }
}

static void test_grid_vs_all_pairs(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x67726964706169ull);
    int rounds = tu_sanitizer_build() ? 2 : 6;
    for (int round = 0; round < rounds; round++) {
        /* small triangles in a unit cube, a third of them on a vertex of an earlier one, some
         * big; or triangles of a 5^3 lattice (contacts of every degenerate kind) */
        int lattice = round % 2;
        size_t nt = 300, nv = 0;
        double *p = malloc(9 * nt * sizeof *p);
        uint32_t *t = malloc(3 * nt * sizeof *t);
        assert_non_null(p);
        assert_non_null(t);
        if (lattice) {
            nv = 60;
            for (size_t i = 0; i < 3 * nv; i++)
                p[i] = (double)(tu_next(&rng) % 5) * 0.25;
            for (size_t i = 0; i < nt; i++) {
                uint32_t a = (uint32_t)(tu_next(&rng) % nv), b, c;
                do
                    b = (uint32_t)(tu_next(&rng) % nv);
                while (b == a);
                do
                    c = (uint32_t)(tu_next(&rng) % nv);
                while (c == a || c == b);
                t[3 * i] = a, t[3 * i + 1] = b, t[3 * i + 2] = c;
            }
        } else {
            for (size_t i = 0; i < nt; i++) {
                double size = tu_next(&rng) % 20 == 0 ? 0.5 : 0.08;
                uint32_t base;
                if (i > 0 && tu_next(&rng) % 3 == 0) {
                    base = t[3 * (tu_next(&rng) % i)];
                } else {
                    base = (uint32_t)nv++;
                    for (int k = 0; k < 3; k++)
                        p[3 * base + k] = tu_uniform(&rng);
                }
                t[3 * i] = base;
                for (int j = 1; j < 3; j++) {
                    uint32_t v = (uint32_t)nv++;
                    for (int k = 0; k < 3; k++)
                        p[3 * v + k] = p[3 * base + k] + size * (tu_uniform(&rng) - 0.5);
                    t[3 * i + j] = v;
                }
            }
        }
        mc_report_t r = check(p, nv, t, nt);
        size_t count, first[2];
        brute_force(p, t, nt, &count, first);
        printf("soup %d (%s): %zu triangles, %zu intersecting pairs, %zu degenerate\n", round,
               lattice ? "lattice" : "random", nt, count, r.degenerate_triangles);
        assert_true(count > 0);
        assert_int_equal(r.intersecting_pairs, count);
        assert_int_equal(r.first_pair[0], first[0]);
        assert_int_equal(r.first_pair[1], first[1]);
        free(p);
        free(t);
    }
}

/* ---- the sphere ------------------------------------------------------------------------- */

typedef struct mesh {
    double *p;
    uint32_t *t;
    size_t nv, nt, cap_v;
} mesh_t;

static uint32_t add_vertex(mesh_t *m, double x, double y, double z)
{
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? 2 * m->cap_v : 64;
        m->p = realloc(m->p, 3 * m->cap_v * sizeof *m->p);
        assert_non_null(m->p);
    }
    double l = sqrt(x * x + y * y + z * z);
    m->p[3 * m->nv] = x / l;
    m->p[3 * m->nv + 1] = y / l;
    m->p[3 * m->nv + 2] = z / l;
    return (uint32_t)m->nv++;
}

/* The midpoint of edge a b on the sphere, made once: an open-addressing table of edges. */
typedef struct edge_map {
    uint64_t *key;
    uint32_t *val;
    size_t mask;
} edge_map_t;

static uint32_t midpoint(mesh_t *m, edge_map_t *em, uint32_t a, uint32_t b)
{
    uint64_t k = a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
    size_t at = (size_t)((k * 0x9e3779b97f4a7c15ull) >> 20) & em->mask;
    for (;; at = (at + 1) & em->mask) {
        if (em->key[at] == k + 1)
            return em->val[at];
        if (!em->key[at])
            break;
    }
    em->key[at] = k + 1;
    const double *pa = m->p + 3 * (size_t)a, *pb = m->p + 3 * (size_t)b;
    em->val[at] = add_vertex(m, pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]);
    return em->val[at];
}

/* The icosahedron subdivided `level` times (20 4^level triangles), on the unit sphere, turned
 * by a random rotation so that no coordinate is special; faces outward. */
static mesh_t icosphere(int level, uint64_t *rng)
{
    mesh_t m = {0};
    const double g = (1 + sqrt(5.0)) / 2;
    const double iv[12][3] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0},
                              {0, -1, g}, {0, 1, g}, {0, -1, -g}, {0, 1, -g},
                              {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    const uint32_t it[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int i = 0; i < 12; i++)
        add_vertex(&m, iv[i][0], iv[i][1], iv[i][2]);
    m.nt = 20;
    m.t = malloc(3 * 20 * sizeof *m.t);
    assert_non_null(m.t);
    memcpy(m.t, it, sizeof it);
    for (int l = 0; l < level; l++) {
        edge_map_t em;
        size_t cap = 1;
        while (cap < 4 * m.nt)
            cap <<= 1;
        em.key = calloc(cap, sizeof *em.key);
        em.val = malloc(cap * sizeof *em.val);
        em.mask = cap - 1;
        uint32_t *nt = malloc(12 * m.nt * sizeof *nt);
        assert_non_null(em.key);
        assert_non_null(em.val);
        assert_non_null(nt);
        for (size_t f = 0; f < m.nt; f++) {
            uint32_t a = m.t[3 * f], b = m.t[3 * f + 1], c = m.t[3 * f + 2];
            uint32_t ab = midpoint(&m, &em, a, b), bc = midpoint(&m, &em, b, c),
                     ca = midpoint(&m, &em, c, a);
            const uint32_t q[12] = {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca};
            memcpy(nt + 12 * f, q, sizeof q);
        }
        free(em.key);
        free(em.val);
        free(m.t);
        m.t = nt;
        m.nt *= 4;
    }
    /* a random rotation: a random unit quaternion */
    double q[4], l = 0;
    for (int k = 0; k < 4; k++) {
        q[k] = tu_uniform(rng) - 0.5;
        l += q[k] * q[k];
    }
    l = sqrt(l);
    double w = q[0] / l, x = q[1] / l, y = q[2] / l, z = q[3] / l;
    const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                            {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                            {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    for (size_t v = 0; v < m.nv; v++) {
        double *p = m.p + 3 * v, r[3];
        for (int k = 0; k < 3; k++)
            r[k] = R[k][0] * p[0] + R[k][1] * p[1] + R[k][2] * p[2];
        memcpy(p, r, sizeof r);
    }
    return m;
}

static void sphere_case(int level, uint64_t *rng)
{
    mesh_t m = icosphere(level, rng);
    double t0 = tu_now();
    mc_report_t r = check(m.p, m.nv, m.t, m.nt);
    double t1 = tu_now();
    printf("icosphere level %d: %zu triangles, %zu vertices: checked in %.3f s (%zu exact "
           "fallbacks)\n",
           level, m.nt, m.nv, t1 - t0, r.exact_fallbacks);
    assert_true(mc_is_closed_embedded(&r));
    assert_int_equal(r.euler, 2);
    assert_int_equal(r.components, 1);
    double vol = mc_signed_volume(m.p, m.t, m.nt);
    assert_true(vol > 0.95 * 4 * PI / 3 && vol < 4 * PI / 3);

    /* vertex 0 through the sphere to beyond the opposite side: its fan crosses the far faces */
    for (int k = 0; k < 3; k++)
        m.p[k] *= -1.3;
    t0 = tu_now();
    r = check(m.p, m.nv, m.t, m.nt);
    t1 = tu_now();
    printf("icosphere level %d, a vertex pushed through: %zu intersecting pairs (first %zu %zu), "
           "checked in %.3f s\n",
           level, r.intersecting_pairs, r.first_pair[0], r.first_pair[1], t1 - t0);
    assert_false(mc_is_closed_embedded(&r));
    assert_true(r.intersecting_pairs > 0);
    assert_int_equal(r.euler, 2); /* the topology is untouched */
    assert_int_equal(r.boundary_edges + r.misoriented_edges + r.nonmanifold_vertices, 0);
    free(m.p);
    free(m.t);
}

static void test_sphere(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x737068657265ull);
    sphere_case(5, &rng); /* 20480 triangles */
    if (!tu_sanitizer_build()) {
        sphere_case(6, &rng); /* 81920 */
        sphere_case(7, &rng); /* 327680 */
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tetrahedron),
        cmocka_unit_test(test_tetrahedron_flipped),
        cmocka_unit_test(test_tetrahedron_open),
        cmocka_unit_test(test_octahedron),
        cmocka_unit_test(test_torus),
        cmocka_unit_test(test_two_tetrahedra),
        cmocka_unit_test(test_tets_sharing_vertex),
        cmocka_unit_test(test_fin),
        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_flat),
        cmocka_unit_test(test_extreme_scales),
        cmocka_unit_test(test_contacts_disjoint),
        cmocka_unit_test(test_contacts_vertex),
        cmocka_unit_test(test_contacts_edge),
        cmocka_unit_test(test_exact_fallback),
        cmocka_unit_test(test_exact_fallback_planar),
        cmocka_unit_test(test_against_oracle),
        cmocka_unit_test(test_grid_vs_all_pairs),
        cmocka_unit_test(test_sphere),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
