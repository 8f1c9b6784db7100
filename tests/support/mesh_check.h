/* An independent checker of triangle meshes, for the tests of the mesher:
 * topology (edges, boundary, non-manifold edges and vertices, orientation,
 * Euler characteristic, components) and self-intersection decided exactly on
 * the double coordinates.  It shares no code with mesh/: it is the oracle the
 * mesher's output is judged against.
 *
 * The mesh: points holds x y z (doubles) per vertex, tris three vertex indices
 * per triangle.  Vertices are identified by index: two indices with identical
 * coordinates are two vertices (and are counted in coincident_vertices).
 *
 * Self-intersection: two distinct triangles T1, T2, as closed point sets, are
 * fine iff T1 ∩ T2 is the convex hull of the vertices whose indices they share
 * (empty when they share none, that vertex when one, that edge when two; a
 * triangle listed twice shares three and is fine here, its edges are then
 * non-manifold).  Every orientation is decided exactly: a double-precision
 * determinant with a rigorous error bound, and GMP rationals when the bound
 * cannot decide.  Degenerate triangles (a repeated index or three collinear
 * points) are a segment or a point, not a 2-cell: they are counted in
 * degenerate_triangles and take no part in the intersection test. */
#ifndef IVOCT_TEST_MESH_CHECK_H
#define IVOCT_TEST_MESH_CHECK_H

#include <stddef.h>
#include <stdint.h>

typedef struct mc_report {
    size_t vertices;             /* vertices used by at least one triangle */
    size_t edges;                /* distinct undirected edges (two distinct indices) */
    size_t triangles;
    size_t degenerate_triangles; /* a repeated index, or three collinear points (exact) */
    size_t boundary_edges;       /* edges in exactly one triangle */
    size_t nonmanifold_edges;    /* edges in three or more triangles */
    size_t misoriented_edges;    /* edges in two triangles that traverse them the same way */
    size_t nonmanifold_vertices; /* vertices whose star is not one disc: the triangles around
                                    the vertex, linked by shared edges, do not form a single fan
                                    (closed cycle, or one open fan at a boundary).  So both ends
                                    of a non-manifold edge, and every vertex of a triangle with a
                                    repeated index, are non-manifold */
    long euler;                  /* V - E + F over the used vertices */
    size_t components;           /* connected components (triangles linked by shared edges) */
    int intersections_checked;   /* mc_check ran the intersection test (the three fields below) */
    size_t intersecting_pairs;   /* pairs of non-degenerate triangles meeting other than exactly
                                    in the convex hull of their shared vertices (exact) */
    size_t first_pair[2];        /* the lexicographically first such pair (i < j), for
                                    messages; 0 0 when there is none */
    size_t exact_fallbacks;      /* orientation tests the double filter left to GMP */
    size_t coincident_vertices;  /* pairs of distinct used vertex indices with identical
                                    coordinates (-0.0 == 0.0) */
} mc_report_t;

/* Check the mesh.  check_intersections: 0 skips the (costlier) intersection
 * test (then intersections_checked is 0 and its counts are 0).
 * Returns 0, or -1 when out of memory (GMP aborts on its own), an index is out
 * of range, a used vertex has a coordinate that is not finite, or nt >= 2^31;
 * *r is then zeroed. */
int mc_check(const double *points, size_t nv, const uint32_t *tris, size_t nt,
             int check_intersections, mc_report_t *r);

/* A closed orientable 2-manifold without self-intersections: at least one
 * triangle; no boundary, non-manifold (edge or vertex), misoriented or
 * degenerate elements; no coincident vertices; the intersection test run and
 * no intersecting pairs. */
int mc_is_closed_embedded(const mc_report_t *r);

/* Signed volume enclosed by the mesh (sum of signed tetrahedra with the
 * origin, in double): positive when the triangles face outwards.  The indices
 * are not checked (run mc_check first). */
double mc_signed_volume(const double *points, const uint32_t *tris, size_t nt);

/* The intersection predicate of mc_check on one pair: do triangles a and b
 * (three indices each into points, not checked) meet other than exactly in the
 * convex hull of their shared vertices?  1 yes, 0 no, -1 when either is
 * degenerate.  For tests of the predicate itself (e.g. against a brute force). */
int mc_triangles_intersect(const double *points, const uint32_t a[3], const uint32_t b[3]);

#endif
