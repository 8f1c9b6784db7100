// ivoct export/ — the OpenVDB side: the surface and sdf grids, the mesh
// extracted from sdf, and reading .vdb files back for `ivoct info`.  The only
// file that includes OpenVDB (its headers are slow to compile).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <openvdb/tree/LeafManager.h>

#include "internal.hpp"

namespace ivexp {
namespace {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::Vec3d;

// A std::ostream onto the FILE* of an io_file_t: OpenVDB writes into the
// temporary file, io_commit checks, closes and renames it.
class FileBuf : public std::streambuf {
public:
    explicit FileBuf(FILE *f) : f_(f) {}

protected:
    int_type overflow(int_type c) override
    {
        if (traits_type::eq_int_type(c, traits_type::eof()))
            return traits_type::not_eof(c);
        return std::fputc(c, f_) == EOF ? traits_type::eof() : c;
    }
    std::streamsize xsputn(const char *s, std::streamsize n) override
    {
        return (std::streamsize)std::fwrite(s, 1, (size_t)n, f_);
    }
    int sync() override { return std::fflush(f_) == 0 ? 0 : -1; }

private:
    FILE *f_;
};


// A std::ostream onto a std::string: one chunk of leaf buffers, written by a
// worker and copied into the file in order.
class StringBuf : public std::streambuf {
public:
    std::string s;

protected:
    int_type overflow(int_type c) override
    {
        if (!traits_type::eq_int_type(c, traits_type::eof()))
            s.push_back(traits_type::to_char_type(c));
        return traits_type::not_eof(c);
    }
    std::streamsize xsputn(const char *p, std::streamsize n) override
    {
        s.append(p, (size_t)n);
        return n;
    }
};

// A FloatGrid (sharing the tree, metadata and transform of another) whose leaf
// buffers are written over threads.  Writing the buffers (Blosc/LZ4 of every
// leaf node, one node after another) was most of OpenVDB's write, on one
// thread.  Grid::writeBuffers writes LeafNode::writeBuffers of every leaf node
// in the tree's order (a FloatGrid has no multi-pass I/O) and each depends only
// on the node and the stream's compression flags and background: the same
// calls here, each chunk of nodes into a string by a worker, with the flags
// and background of the file's stream, then copied out in order, a window of
// chunks at a time (the memory of a window, not of a grid) — the same bytes.
class ThreadedWriteGrid final : public FloatGrid {
public:
    ThreadedWriteGrid(FloatGrid &g, int threads)
        : FloatGrid(g, openvdb::ShallowCopy()), threads_(threads)
    {
    }
    void writeBuffers(std::ostream &os) const override
    {
        using Leaf = openvdb::FloatTree::LeafNodeType;
        std::vector<const Leaf *> leaves;
        tree().getNodes(leaves);  // the order of Tree::writeBuffers: the tree's
        const uint32_t compression = openvdb::io::getDataCompression(os);
        const void *bg = openvdb::io::getGridBackgroundValuePtr(os);
        const bool half = saveFloatAsHalf();
        constexpr size_t chunk = 32, window = 32 * chunk;  // a window: at most ~2 MB
        std::vector<StringBuf> bufs(window / chunk);
        for (size_t w0 = 0; w0 < leaves.size() && os; w0 += window) {
            const size_t n = std::min(window, leaves.size() - w0);
            parallel_chunks(n, chunk, threads_, [&](size_t s, size_t e, int) {
                StringBuf &b = bufs[s / chunk];
                b.s.clear();
                std::ostream o(&b);
                openvdb::io::setDataCompression(o, compression);
                openvdb::io::setGridBackgroundValuePtr(o, bg);
                for (size_t i = s; i < e; i++)
                    leaves[w0 + i]->writeBuffers(o, half);
            });
            for (size_t c = 0; c * chunk < n; c++)
                os.write(bufs[c].s.data(), (std::streamsize)bufs[c].s.size());
        }
    }

private:
    int threads_;
};

void init()
{
    openvdb::initialize();  // registers grid and metadata types; idempotent
}

// The grids' geometry: voxels are the cells of the max depth D.
struct Frame {
    int D;
    uint32_t n;       // 2^D voxels per axis
    double lo[3], h[3];
    openvdb::math::Transform::Ptr xf;

    explicit Frame(const oct_tree_t *t) : D(t->depth), n(1u << t->depth)
    {
        for (int a = 0; a < 3; a++) {
            lo[a] = t->box[2 * a];
            h[a] = (t->box[2 * a + 1] - t->box[2 * a]) / (double)n;
            if (!(h[a] > 0) || !std::isfinite(h[a]))
                throw Error("the box has no volume: no voxel grid can hold it");
        }
        // index (i, j, k) -> the centre of depth-D cell (i, j, k)
        xf = openvdb::math::Transform::createLinearTransform(1.0);
        xf->preScale(Vec3d(h[0], h[1], h[2]));
        xf->postTranslate(Vec3d(lo[0] + 0.5 * h[0], lo[1] + 0.5 * h[1], lo[2] + 0.5 * h[2]));
    }
    double max_h() const { return std::max(h[0], std::max(h[1], h[2])); }
};

// The voxels of a cell of depth d: its region at depth D.
CoordBBox cell_voxels(int D, int d, uint32_t ix, uint32_t iy, uint32_t iz)
{
    int32_t s = (int32_t)1 << (D - d);
    Coord a((int32_t)ix * s, (int32_t)iy * s, (int32_t)iz * s);
    return CoordBBox(a, a.offsetBy(s - 1));
}

// The surface grid.  A leaf deeper than a grid leaf node (8^3 voxels, a cell
// of depth D - 3) is a block of voxels of one node; the surface leaves are in
// Morton order, so those of one node are contiguous: the nodes are made over
// threads (their memory is most of this grid's time), each by the thread
// whose chunk holds the node's first leaf, and added to the tree in order.
// The shallower leaves are tiles (or tile-aligned fills), few, added after.
FloatGrid::Ptr surface_grid(const oct_tree_t *t, const Frame &fr)
{
    using Leaf = openvdb::FloatTree::LeafNodeType;
    FloatGrid::Ptr g = FloatGrid::create(0.0f);
    g->setName("surface");
    g->setTransform(fr.xf->copy());
    auto &tree = g->tree();
    const int node_depth = fr.D - (int)Leaf::LOG2DIM;
    // the Morton code of a leaf's grid leaf node; a tile's: none
    constexpr uint64_t TILE = UINT64_MAX;
    auto node_of = [&](uint32_t i) {
        const oct_leaf_t &l = t->leaves[i];
        int d = oct_leaf_depth(&l);
        if (d <= node_depth)
            return TILE;
        return node_depth < 0 ? 0 : oct_leaf_code(&l) >> 3 * (d - node_depth);
    };
    const size_t n = t->n_leaves, chunk = 16384;
    std::vector<std::vector<std::unique_ptr<Leaf>>> made((n + chunk - 1) / chunk);
    parallel_chunks(n, chunk, writer_threads(t, made.size()), [&](size_t s, size_t e, int) {
        std::vector<std::unique_ptr<Leaf>> &out = made[s / chunk];
        size_t i = s;
        // a node begun in the chunk before is that chunk's
        const uint64_t before = s > 0 ? node_of((uint32_t)(s - 1)) : TILE;
        while (before != TILE && i < e && node_of((uint32_t)i) == before)
            i++;
        while (i < e) {
            const uint64_t key = node_of((uint32_t)i);
            if (key == TILE) {
                i++;
                continue;
            }
            Leaf *leaf = nullptr;
            for (; i < n && node_of((uint32_t)i) == key; i++) {
                const oct_leaf_t &l = t->leaves[i];
                uint32_t ix, iy, iz;
                int depth = oct_leaf_depth(&l);
                oct_unmorton(oct_leaf_code(&l), depth, &ix, &iy, &iz);
                CoordBBox b = cell_voxels(fr.D, depth, ix, iy, iz);
                if (!leaf) {
                    out.push_back(std::make_unique<Leaf>(b.min() & ~(Leaf::DIM - 1), 0.0f, false));
                    leaf = out.back().get();
                }
                for (int32_t x = b.min()[0]; x <= b.max()[0]; x++)
                    for (int32_t y = b.min()[1]; y <= b.max()[1]; y++)
                        for (int32_t z = b.min()[2]; z <= b.max()[2]; z++)
                            leaf->setValueOn(Leaf::coordToOffset(Coord(x, y, z)), (float)depth);
            }
        }
    });
    for (auto &v : made)
        for (auto &leaf : v)
            tree.addLeaf(leaf.release());
    for (uint32_t i = 0; i < n; i++) {
        if (node_of(i) != TILE)
            continue;
        const oct_leaf_t &l = t->leaves[i];
        uint32_t ix, iy, iz;
        int depth = oct_leaf_depth(&l);
        oct_unmorton(oct_leaf_code(&l), depth, &ix, &iy, &iz);
        tree.fill(cell_voxels(fr.D, depth, ix, iy, iz), (float)depth, true);
    }
    return g;
}

// Mark the empty cells of class inside with the inactive value -bg (the
// background, +bg, stands for outside).
void fill_inside(const oct_tree_t *t, const Frame &fr, FloatGrid &g, float bg, uint32_t node,
                 int d, uint32_t ix, uint32_t iy, uint32_t iz)
{
    oct_node_t w = t->nodes[node];
    if (OCT_NODE_KIND(w) == OCT_INTERIOR) {
        uint32_t first = OCT_NODE_VALUE(w);
        for (uint32_t c = 0; c < 8; c++)
            fill_inside(t, fr, g, bg, first + c, d + 1, 2 * ix + (c & 1), 2 * iy + (c >> 1 & 1),
                        2 * iz + (c >> 2 & 1));
    } else if (OCT_NODE_KIND(w) == OCT_EMPTY && OCT_NODE_VALUE(w) == OCT_INSIDE) {
        if (d == fr.D)
            g.tree().setValueOff(Coord((int32_t)ix, (int32_t)iy, (int32_t)iz), -bg);
        else
            g.tree().fill(cell_voxels(fr.D, d, ix, iy, iz), -bg, false);
    }
}

// The surface grid and the narrow-band level set (see export.h): surface set
// to the surface grid.
FloatGrid::Ptr sdf_grid(const oct_tree_t *t, const tape_t *tape, const Frame &fr,
                        FloatGrid::Ptr &surface_out)
{
    const float bg = (float)(EXP_SDF_HALF_WIDTH * fr.max_h());
    FloatGrid::Ptr g = FloatGrid::create(bg);
    g->setName("sdf");
    g->setGridClass(openvdb::GRID_LEVEL_SET);
    g->setTransform(fr.xf->copy());

    // The inside cells (a walk of the octree into the sdf tree) and the
    // surface grid with its dilated band (into their own trees) share nothing
    // until the union: one thread each when the build had two or more, the
    // walk and surface_grid being serial (the dilation is threaded by OpenVDB).
    std::exception_ptr inside_failed;
    auto inside_task = [&] {
        try {
            fill_inside(t, fr, *g, bg, 0, 0, 0, 0, 0);
        } catch (...) {
            inside_failed = std::current_exception();
        }
    };
    std::thread inside;
    if (writer_threads(t, 2) > 1) {
        try {
            inside = std::thread(inside_task);
        } catch (const std::system_error &) {  // no thread: in turn
        }
    }
    if (!inside.joinable())
        inside_task();
    struct Join {
        std::thread &th;
        ~Join()
        {
            if (th.joinable())
                th.join();
        }
    } join{inside};  // also when the code below throws

    surface_out = surface_grid(t, fr);
    const FloatGrid &surface = *surface_out;
    // the band: the surface leaves dilated by the half width, within the box
    openvdb::MaskTree band(surface.tree(), false, openvdb::TopologyCopy());
    openvdb::tools::dilateActiveValues(band, EXP_SDF_HALF_WIDTH, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::EXPAND_TILES);
    band.clip(CoordBBox(Coord(0), Coord((int32_t)fr.n - 1)));
    if (inside.joinable())
        inside.join();
    if (inside_failed)
        std::rethrow_exception(inside_failed);
    g->tree().topologyUnion(band);
    g->tree().voxelizeActiveTiles();

    // values at the voxel centres: f / |grad f|, clamped; outside the surface
    // leaves the sign is the octree's class (the value the voxel had: -bg or bg).
    // f and its gradient at every band voxel are the one evaluation the build
    // has not made (it knows f over cells, not at voxel centres): leaf node by
    // leaf node of the grid (up to 512 voxels, one evaluator pass), over
    // threads.  A distance estimate needs no enclosure: plain doubles
    // (tape_eval_point_grad), a fifth of the interval gradient's cost.
    openvdb::tree::LeafManager<openvdb::FloatTree> nodes(g->tree());
    const size_t n_nodes = nodes.leafCount(), chunk = 16;
    const int threads = writer_threads(t, (n_nodes + chunk - 1) / chunk);
    std::vector<std::unique_ptr<Workspace>> ws;
    for (int w = 0; w < threads; w++)
        ws.push_back(std::make_unique<Workspace>(tape));
    const openvdb::FloatTree &stree = surface.tree();
    parallel_chunks(n_nodes, chunk, threads, [&](size_t s, size_t e, int w) {
        using Leaf = openvdb::FloatTree::LeafNodeType;
        constexpr size_t N = Leaf::SIZE;
        std::vector<double> x(N), y(N), z(N);
        std::vector<tape_point_grad_t> out(N);
        std::vector<openvdb::Index> offset(N);
        std::vector<signed char> sign(N);  // 0: in a surface leaf
        double p[3][Leaf::DIM];            // voxel centres along each axis
        for (size_t i = s; i < e; i++) {
            Leaf &node = nodes.leaf(i);
            const Coord o = node.origin();
            // the surface grid's voxels here: its leaf node of the same origin
            // (both trees have the same nodes), else one tile covers the node
            const Leaf *sl = stree.probeConstLeaf(o);
            const bool s_tile_on = !sl && stree.isValueOn(o);
            for (int a = 0; a < 3; a++)
                for (openvdb::Index k = 0; k < Leaf::DIM; k++)
                    p[a][k] = fr.lo[a] + ((double)(o[a] + (int32_t)k) + 0.5) * fr.h[a];
            float *v = node.buffer().data();  // the node's values, written in place
            size_t m = 0;
            for (auto it = node.getValueMask().beginOn(); it; ++it, m++) {
                const openvdb::Index n = it.pos();  // (x << 6) | (y << 3) | z
                offset[m] = n;
                const bool in_surface = sl ? sl->isValueOn(n) : s_tile_on;
                sign[m] = in_surface ? 0 : v[n] < 0 ? -1 : 1;
                x[m] = p[0][n >> 2 * Leaf::LOG2DIM];
                y[m] = p[1][(n >> Leaf::LOG2DIM) & (Leaf::DIM - 1)];
                z[m] = p[2][n & (Leaf::DIM - 1)];
            }
            tape_eval_point_grad(tape, ws[(size_t)w]->ws, m, x.data(), y.data(), z.data(),
                                 out.data());
            for (size_t k = 0; k < m; k++) {
                const tape_point_grad_t &q = out[k];
                double f = q.v;
                double gn = std::sqrt(q.dx * q.dx + q.dy * q.dy + q.dz * q.dz);
                double d = gn > 0 && std::isfinite(gn) ? f / gn : f > 0 ? bg : f < 0 ? -bg : 0;
                if (std::isnan(d))  // f undefined here: outside
                    d = bg;
                d = std::max(-(double)bg, std::min((double)bg, d));
                int cls = sign[k];
                if (cls != 0 && !(d * cls > 0))  // the certified class wins; keep |d| if any
                    d = cls * std::max(std::fabs(d), 1e-3 * fr.max_h());
                v[offset[k]] = (float)d;
            }
        }
    });
    openvdb::tools::pruneLevelSet(g->tree());
    return g;
}

openvdb::MetaMap metadata(const oct_tree_t *t, const oct_source_t *src)
{
    openvdb::MetaMap m;
    for (const MetaItem &it : meta_strings(src))
        m.insertMeta(it.key, openvdb::StringMetadata(it.value));
    m.insertMeta("box_min", openvdb::Vec3DMetadata(Vec3d(t->box[0], t->box[2], t->box[4])));
    m.insertMeta("box_max", openvdb::Vec3DMetadata(Vec3d(t->box[1], t->box[3], t->box[5])));
    m.insertMeta("depth", openvdb::Int32Metadata(t->depth));
    return m;
}

}  // namespace

void vdb_write(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
               const char *path)
{
    init();
    Frame fr(tree);
    FloatGrid::Ptr surface;
    FloatGrid::Ptr sdf = sdf_grid(tree, tape, fr, surface);
    openvdb::MetaMap m = metadata(tree, src);
    const int threads = writer_threads(tree, (size_t)1 << 20);
    openvdb::GridPtrVec grids{std::make_shared<ThreadedWriteGrid>(*surface, threads),
                              std::make_shared<ThreadedWriteGrid>(*sdf, threads)};
    for (auto &g : grids) {
        for (auto it = m.beginMeta(); it != m.endMeta(); ++it)
            g->insertMeta(it->first, *it->second);
    }
    Output out(path);
    FileBuf buf(out.file());
    std::ostream os(&buf);
    openvdb::io::Stream(os).write(grids, m);
    os.flush();
    if (!os)
        throw Error(std::string("cannot write ") + path + ": " +
                    std::strerror(errno ? errno : EIO));
    out.commit();
}

Mesh vdb_mesh(const oct_tree_t *tree, const tape_t *tape)
{
    init();
    Frame fr(tree);
    FloatGrid::Ptr surface;
    FloatGrid::Ptr sdf = sdf_grid(tree, tape, fr, surface);
    surface.reset();
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*sdf, points, tris, quads, 0.0, 0.0);
    Mesh m;
    m.points.reserve(3 * points.size());
    for (const auto &p : points)
        m.points.insert(m.points.end(), {p[0], p[1], p[2]});
    // volumeToMesh winds its polygons clockwise seen from outside (inside is
    // negative): reversed here so that they face outwards
    m.tris.reserve(3 * (tris.size() + 2 * quads.size()));
    for (const auto &t : tris)
        m.tris.insert(m.tris.end(), {t[0], t[2], t[1]});
    for (const auto &q : quads) {
        m.tris.insert(m.tris.end(), {q[0], q[2], q[1]});
        m.tris.insert(m.tris.end(), {q[0], q[3], q[2]});
    }
    return m;
}

void vdb_info(const char *path, FILE *out)
{
    init();
    openvdb::io::File file(path);
    openvdb::GridPtrVecPtr grids;
    openvdb::MetaMap::Ptr meta;
    try {
        file.open(false);
        meta = file.getMetadata();
        grids = file.getGrids();
        file.close();
    } catch (const std::exception &e) {
        throw Error(std::string("cannot read ") + path + ": " + e.what());
    }
    if (!grids || !meta)
        throw Error(std::string("cannot read ") + path + ": no grids");
    std::fprintf(out, "file:     %s (OpenVDB, format version %u)\n", path, file.fileVersion());
    auto str = [&](const char *key) -> std::string {
        auto m = meta->getMetadata<openvdb::StringMetadata>(key);
        return m ? m->value() : std::string();
    };
    if (!str("scene").empty())
        std::fprintf(out, "scene:    %s\n", str("scene").c_str());
    for (auto it = meta->beginMeta(); it != meta->endMeta(); ++it)
        if (it->first.rfind("let.", 0) == 0)
            std::fprintf(out, "let:      %s = %s\n", it->first.c_str() + 4, it->second->str().c_str());
    if (!str("expression").empty())
        std::fprintf(out, "f:        %s\n", str("expression").c_str());
    auto lo = meta->getMetadata<openvdb::Vec3DMetadata>("box_min");
    auto hi = meta->getMetadata<openvdb::Vec3DMetadata>("box_max");
    if (lo && hi)
        std::fprintf(out, "box:      [%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g]\n",
                     lo->value()[0], hi->value()[0], lo->value()[1], hi->value()[1],
                     lo->value()[2], hi->value()[2]);
    if (auto d = meta->getMetadata<openvdb::Int32Metadata>("depth"))
        std::fprintf(out, "depth:    %d\n", d->value());
    std::fprintf(out, "grids:    %zu\n", grids->size());
    for (const auto &g : *grids) {
        Vec3d vs = g->voxelSize();
        CoordBBox bb = g->evalActiveVoxelBoundingBox();
        std::fprintf(out, "grid:     %s (%s, class %s): %llu active voxels", g->getName().c_str(),
                     g->valueType().c_str(),
                     openvdb::GridBase::gridClassToString(g->getGridClass()).c_str(),
                     (unsigned long long)g->activeVoxelCount());
        if (!bb.empty())
            std::fprintf(out, ", index bbox [%d %d %d]..[%d %d %d]", bb.min()[0], bb.min()[1],
                         bb.min()[2], bb.max()[0], bb.max()[1], bb.max()[2]);
        std::fprintf(out, ", voxel %.17g x %.17g x %.17g\n", vs[0], vs[1], vs[2]);
    }
}

}  // namespace ivexp
