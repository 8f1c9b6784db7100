// The OpenVDB level-set baseline of bench/ray_error.c: see vdb_raycast.h.
#include "vdb_raycast.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include <omp.h>

#include <openvdb/openvdb.h>
#include <openvdb/math/Ray.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/RayIntersector.h>
#include <openvdb/tools/SignedFloodFill.h>

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::Vec3d;

struct vdb_rc {
    FloatGrid::Ptr grid;
};

namespace {

void set_msg(char *msg, size_t len, const std::string &s)
{
    if (msg && len)
        std::snprintf(msg, len, "%s", s.c_str());
}

// Index range [a, b] of the voxels (cells [lo + i h, lo + (i+1) h]) that meet
// [x0, x1], clipped to [0, n-1]; false when empty.  A bound that falls on a
// voxel face (up to rounding) does not pull in the neighbour beyond it.
bool voxel_range(double lo, double h, int32_t n, double x0, double x1, int32_t &a, int32_t &b)
{
    const double eps = 1e-9;
    double u0 = (x0 - lo) / h, u1 = (x1 - lo) / h;
    double fa = std::floor(u0 + eps), fb = std::ceil(u1 - eps) - 1;
    fb = std::max(fb, fa);  // a degenerate leaf still meets one voxel
    fa = std::max(fa, 0.0);
    fb = std::min(fb, (double)n - 1);
    if (!(fa <= fb))
        return false;
    a = (int32_t)fa;
    b = (int32_t)fb;
    return true;
}

}  // namespace

extern "C" int vdb_rc_build(const tape_t *tape, const oct_tree_t *tree, const vdb_rc_opts_t *opts,
                            vdb_rc_t **out, vdb_rc_build_stats_t *st, char *msg, size_t msg_len)
{
    *out = nullptr;
    *st = vdb_rc_build_stats_t{};
    try {
        openvdb::initialize();
        const int hw = opts && opts->half_width > 0 ? opts->half_width : 3;
        const int threads = opts && opts->threads > 0 ? opts->threads : omp_get_max_threads();
        double lo[3], edge[3];
        for (int a = 0; a < 3; a++) {
            lo[a] = tree->box[2 * a];
            edge[a] = tree->box[2 * a + 1] - tree->box[2 * a];
        }
        double h = opts && opts->voxel > 0
                       ? opts->voxel
                       : std::min(edge[0], std::min(edge[1], edge[2])) / std::ldexp(1.0, tree->depth);
        if (!(h > 0) || !std::isfinite(h)) {
            set_msg(msg, msg_len, "the box has no volume: no voxel grid can hold it");
            return 1;
        }
        int32_t n[3];
        for (int a = 0; a < 3; a++) {
            double c = std::ceil(edge[a] / h - 1e-9);
            if (c > 1 << 24) {
                set_msg(msg, msg_len, "too many voxels along an axis");
                return 1;
            }
            n[a] = std::max(1, (int32_t)c);
        }
        const float bg = (float)(hw * h);
        const double t_start = omp_get_wtime();

        FloatGrid::Ptr g = FloatGrid::create(bg);
        g->setName("level_set");
        g->setGridClass(openvdb::GRID_LEVEL_SET);
        openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(h);
        xf->postTranslate(Vec3d(lo[0] + 0.5 * h, lo[1] + 0.5 * h, lo[2] + 0.5 * h));
        g->setTransform(xf);

        // the seeds: voxels meeting a surface leaf
        {
            auto acc = g->getAccessor();
            for (uint32_t i = 0; i < tree->n_leaves; i++) {
                iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
                int32_t r[3][2];
                if (!voxel_range(lo[0], h, n[0], b.x.lo, b.x.hi, r[0][0], r[0][1]) ||
                    !voxel_range(lo[1], h, n[1], b.y.lo, b.y.hi, r[1][0], r[1][1]) ||
                    !voxel_range(lo[2], h, n[2], b.z.lo, b.z.hi, r[2][0], r[2][1]))
                    continue;
                for (int32_t x = r[0][0]; x <= r[0][1]; x++)
                    for (int32_t y = r[1][0]; y <= r[1][1]; y++)
                        for (int32_t z = r[2][0]; z <= r[2][1]; z++)
                            acc.setValueOn(Coord(x, y, z), 0.0f);
            }
        }
        st->seed_voxels = g->tree().activeVoxelCount();
        // the band
        openvdb::tools::dilateActiveValues(g->tree(), hw, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                           openvdb::tools::EXPAND_TILES);
        g->tree().clip(CoordBBox(Coord(0), Coord(n[0] - 1, n[1] - 1, n[2] - 1)));
        g->tree().voxelizeActiveTiles();

        // f / |grad f| at the band's voxel centres
        const double t_sample = omp_get_wtime();
        std::vector<Coord> coords;
        coords.reserve(g->tree().activeVoxelCount());
        for (auto it = g->tree().cbeginValueOn(); it; ++it)
            coords.push_back(it.getCoord());
        const size_t nv = coords.size();
        std::vector<float> value(nv);
        const size_t chunk = 512;
        const long nchunks = (long)((nv + chunk - 1) / chunk);
        int failed = 0;
#pragma omp parallel num_threads(threads)
        {
            tape_ws_t *ws = tape_ws_new(tape->n);
            std::vector<double> px(chunk), py(chunk), pz(chunk);
            std::vector<tape_point_grad_t> gr(chunk);
            if (!ws) {
#pragma omp atomic write
                failed = 1;
            }
#pragma omp for schedule(dynamic, 4)
            for (long c = 0; c < nchunks; c++) {
                if (!ws)
                    continue;
                size_t s = (size_t)c * chunk, m = std::min(chunk, nv - s);
                for (size_t k = 0; k < m; k++) {
                    const Coord &q = coords[s + k];
                    px[k] = lo[0] + ((double)q[0] + 0.5) * h;
                    py[k] = lo[1] + ((double)q[1] + 0.5) * h;
                    pz[k] = lo[2] + ((double)q[2] + 0.5) * h;
                }
                tape_eval_point_grad(tape, ws, m, px.data(), py.data(), pz.data(), gr.data());
                for (size_t k = 0; k < m; k++) {
                    const tape_point_grad_t &q = gr[k];
                    double f = q.v, gx = q.dx, gy = q.dy, gz = q.dz;
                    double gn = std::sqrt(gx * gx + gy * gy + gz * gz);
                    double d = gn > 0 && std::isfinite(gn) ? f / gn
                               : f > 0                      ? (double)bg
                               : f < 0                      ? -(double)bg
                                                            : 0.0;
                    if (std::isnan(d))  // f undefined here: call it outside
                        d = bg;
                    value[s + k] = (float)std::max(-(double)bg, std::min((double)bg, d));
                }
            }
            tape_ws_free(ws);
        }
        if (failed) {
            set_msg(msg, msg_len, "out of memory (tape workspace)");
            return 1;
        }
        size_t k = 0;
        for (auto it = g->tree().beginValueOn(); it; ++it)
            it.setValue(value[k++]);
        st->sample_s = omp_get_wtime() - t_sample;
        openvdb::tools::signedFloodFill(g->tree());
        st->time_s = omp_get_wtime() - t_start;

        st->voxel = h;
        st->background = bg;
        st->active_voxels = g->tree().activeVoxelCount();
        st->mem_bytes = (size_t)g->memUsage();
        st->threads = threads;
        if (st->active_voxels == 0) {
            set_msg(msg, msg_len, "the band is empty (no surface leaves): nothing to ray cast");
            return 1;
        }
        *out = new vdb_rc{g};
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_len, std::string("OpenVDB: ") + e.what());
    } catch (...) {
        set_msg(msg, msg_len, "OpenVDB: unknown exception");
    }
    return 1;
}

extern "C" int vdb_rc_cast(const vdb_rc_t *g, const ray_camera_t *cam, int threads, double *t,
                           double *time_s, uint64_t *hits, char *msg, size_t msg_len)
{
    using Intersector = openvdb::tools::LevelSetRayIntersector<FloatGrid>;
    using RayT = Intersector::RayType;
    try {
        const Intersector proto(*g->grid);
        const int W = cam->width, H = cam->height;
        const Vec3d eye(cam->eye[0], cam->eye[1], cam->eye[2]);
        uint64_t nhit = 0;
        const double t0 = omp_get_wtime();
        const int nt = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel num_threads(nt) reduction(+ : nhit)
        {
            Intersector isect(proto);  // each thread its own accessor
#pragma omp for schedule(dynamic, 1)
            for (int row = 0; row < H; row++)
                for (int col = 0; col < W; col++) {
                    double d[3];
                    ray_camera_dir(cam, col, row, d);
                    RayT ray(eye, Vec3d(d[0], d[1], d[2]));
                    Vec3d xyz;
                    double wt;
                    bool hit = isect.intersectsWS(ray, xyz, wt);
                    t[(size_t)row * W + col] = hit ? wt : NAN;
                    nhit += hit;
                }
        }
        *time_s = omp_get_wtime() - t0;
        *hits = nhit;
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_len, std::string("OpenVDB: ") + e.what());
    } catch (...) {
        set_msg(msg, msg_len, "OpenVDB: unknown exception");
    }
    return 1;
}

extern "C" void vdb_rc_free(vdb_rc_t *g)
{
    delete g;
}
