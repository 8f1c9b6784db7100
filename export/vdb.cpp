// ivoct export/ — the OpenVDB side: the surface and sdf grids, the mesh
// extracted from sdf, and reading .vdb files back for `ivoct info`.  The only
// file that includes OpenVDB (its headers are slow to compile).
#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Archive.h>
#include <openvdb/io/Compression.h>
#include <openvdb/io/DelayedLoadMetadata.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/VolumeToMesh.h>

#include "internal.hpp"

namespace ivexp {
namespace {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::Vec3d;
using Leaf = openvdb::FloatTree::LeafNodeType;
using Mask = Leaf::NodeMaskType;

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

// A grid leaf node's coordinates (origin / 8), packed 21 bits an axis, x
// first: the voxels of a tree of depth D <= 21 are in [0, 2^21).
uint64_t node_key(const Coord &origin)
{
    return (uint64_t)(uint32_t)(origin[0] >> Leaf::LOG2DIM) << 42 |
           (uint64_t)(uint32_t)(origin[1] >> Leaf::LOG2DIM) << 21 |
           (uint64_t)(uint32_t)(origin[2] >> Leaf::LOG2DIM);
}

Coord node_origin(uint64_t key)
{
    return Coord((int32_t)(key >> 42), (int32_t)(key >> 21 & 0x1fffff), (int32_t)(key & 0x1fffff))
           << Leaf::LOG2DIM;
}

// The bytes of leaf nodes made without their values.  A grid builder given
// one makes its leaf nodes with the value mask alone (LeafNode's PartialCreate:
// all that the topology, the statistics and the band's dilation read) and
// hands each node's values, made in a worker's scratch, to a Writer, which
// writes what LeafNode::writeBuffers would write for the node (OpenVDB's own
// NodeMask::save and io::writeCompressedValues, with the grid's compression
// flags and background) at the end of the worker's spool.
// VdbStream::write_grid writes those bytes in place of the node's.  So the
// grids' values, 2 KB a node and most of the writer's memory, are never held,
// and each node is compressed while in cache.
class LeafBytes {
    struct Piece {
        uint64_t key;  // node_key
        uint32_t worker;
        size_t at, size;
    };

public:
    LeafBytes(uint32_t flags, float background) : flags_(flags), background_(background) {}

    uint32_t flags() const { return flags_; }
    float background() const { return background_; }

    // room for the builder's workers, numbered from 0
    void workers(size_t n)
    {
        spools_.resize(n);
        pieces_.resize(n);
    }

    // What one worker encodes, a node at a time.
    class Writer {
    public:
        Writer(LeafBytes &b, size_t worker)
            : spool_(b.spools_.at(worker)), pieces_(b.pieces_.at(worker)),
              worker_((uint32_t)worker), o_(&node_)
        {
            openvdb::io::setDataCompression(o_, b.flags_);
            openvdb::io::setGridBackgroundValuePtr(o_, &b.background_);
        }
        // (values is only read: io::writeCompressedValues takes a non-const pointer)
        void add(const Coord &origin, const Mask &mask, float *values)
        {
            node_.s.clear();
            mask.save(o_);
            openvdb::io::writeCompressedValues(o_, values, Leaf::SIZE, mask, Mask(), false);
            if (!o_)
                throw Error("the .vdb writer: a leaf node could not be encoded");
            const size_t at = spool_.append(node_.s.data(), node_.s.size(), SPOOL_FIRST);
            pieces_.push_back({node_key(origin), worker_, at, node_.s.size()});
        }

    private:
        static constexpr size_t SPOOL_FIRST = (size_t)1 << 21;  // one huge page
        Lz4Spool &spool_;
        std::vector<Piece> &pieces_;
        uint32_t worker_;
        StringBuf node_;  // one node's bytes
        std::ostream o_;
    };

    // After the builder's workers: the nodes sorted by origin.
    void index()
    {
        index_.clear();
        for (const std::vector<Piece> &w : pieces_)
            index_.insert(index_.end(), w.begin(), w.end());
        std::vector<std::vector<Piece>>().swap(pieces_);
        std::sort(index_.begin(), index_.end(),
                  [](const Piece &a, const Piece &b) { return a.key < b.key; });
    }

    // The bytes of the node at origin; none (a null data()) if it was not
    // encoded here.
    std::string_view find(const Coord &origin) const
    {
        const uint64_t key = node_key(origin);
        auto it = std::lower_bound(index_.begin(), index_.end(), key,
                                   [](const Piece &p, uint64_t k) { return p.key < k; });
        if (it == index_.end() || it->key != key)
            return std::string_view();
        return std::string_view(spools_[it->worker].data.get() + it->at, it->size);
    }

private:
    uint32_t flags_;
    float background_;
    std::vector<Lz4Spool> spools_;  // a worker's nodes' bytes, end to end
    std::vector<std::vector<Piece>> pieces_;
    std::vector<Piece> index_;
};

// OpenVDB's Stream::write (io::Archive::write and writeGrid, OpenVDB 10) with
// each leaf node compressed once, over threads.  Archive::writeGrid compresses
// every leaf node (TBB) only to record its compressed size in the grid's
// delayed-load metadata, which comes before the topology, and then again, on
// one thread, as it writes the buffers.  Here each leaf node's bytes come
// first: encoded when it was made (LeafBytes), else written by workers
// (LeafNode::writeBuffers, each into a worker's string, with the grid's
// compression flags and background); the delayed-load metadata is read off
// those bytes, and the metadata, transform, topology and buffers then go out
// in Archive's order: the same file, byte for byte, but the UUID.  The test
// hook IVOCT_VDB_STREAM=openvdb writes with io::Stream itself instead, so that
// tests/test_export.sh compares the two.
class VdbStream : public openvdb::io::Archive {
public:
    explicit VdbStream(int threads) : threads_(threads) {}

    // Each grid is freed once written (the last reference: the caller's moved
    // in), so that the next one's buffers and the file's pages reuse its memory.
    // bytes[i], if any, holds the bytes of grids[i]'s leaf nodes made without
    // their values.
    void write_file(std::ostream &os, std::vector<FloatGrid::Ptr> grids,
                    std::vector<std::unique_ptr<LeafBytes>> bytes,
                    const openvdb::MetaMap &meta) const
    {
        namespace io = openvdb::io;
        bytes.resize(grids.size());
        io::StreamMetadata::Ptr file_meta(new io::StreamMetadata);
        io::setStreamMetadataPtr(os, file_meta, /*transfer=*/false);
        io::setDataCompression(os, compression());
        io::setWriteGridStatsMetadata(os, isGridStatsMetadataEnabled());
        writeHeader(os, /*seekable=*/false);
        meta.writeMeta(os);
        const int32_t count = (int32_t)grids.size();
        os.write(reinterpret_cast<const char *>(&count), sizeof count);
        for (size_t i = 0; i < grids.size(); i++) {
            write_grid(os, *grids[i], bytes[i].get());
            grids[i].reset();
            bytes[i].reset();
            // per-grid settings restored for the next, as Archive::write does
            io::setStreamMetadataPtr(os, file_meta, /*transfer=*/false);
            io::setDataCompression(os, compression());
        }
    }

    // The compression flags write_grid uses for a grid of class c
    // (Archive::setGridCompression's, written into a scratch stream).
    uint32_t grid_compression(openvdb::GridClass c) const
    {
        FloatGrid g;
        g.setGridClass(c);
        StringBuf scratch;
        std::ostream o(&scratch);
        setGridCompression(o, g);
        return openvdb::io::getDataCompression(o);
    }

private:
    // The per-leaf fields of the delayed-load metadata, from a leaf's bytes as
    // LeafNode<float>::writeBuffers writes them (io::writeCompressedValues):
    // the value mask (64 bytes), the mask-compression byte, the inactive values
    // it calls for, the selection mask it calls for, then the data with its
    // 8-byte size: what the metadata records is that last part's length.
    static int64_t compressed_size(const char *p, size_t n, int8_t &mask_meta)
    {
        namespace io = openvdb::io;
        constexpr size_t MASK = sizeof(Leaf::NodeMaskType);
        mask_meta = static_cast<int8_t>(p[MASK]);
        size_t head = MASK + 1;
        if (mask_meta == io::NO_MASK_AND_ONE_INACTIVE_VAL || mask_meta == io::MASK_AND_ONE_INACTIVE_VAL)
            head += sizeof(float);
        if (mask_meta == io::MASK_AND_TWO_INACTIVE_VALS)
            head += 2 * sizeof(float);
        if (mask_meta == io::MASK_AND_NO_INACTIVE_VALS || mask_meta == io::MASK_AND_ONE_INACTIVE_VAL ||
            mask_meta == io::MASK_AND_TWO_INACTIVE_VALS)
            head += MASK;
        if (n < head)
            throw Error("the .vdb writer: a leaf node's bytes are shorter than their header");
        return (int64_t)(n - head);
    }

    void write_grid(std::ostream &os, const FloatGrid &g, const LeafBytes *encoded) const
    {
        namespace io = openvdb::io;
        if (g.saveFloatAsHalf())
            throw Error("the .vdb writer: half floats are not written here");
        // stream metadata varies per grid: a copy of the file's
        io::StreamMetadata::Ptr grid_meta(new io::StreamMetadata(*io::getStreamMetadataPtr(os)));
        grid_meta->setHalfFloat(false);
        grid_meta->gridMetadata() = static_cast<const openvdb::MetaMap &>(g);
        io::setStreamMetadataPtr(os, grid_meta, /*transfer=*/false);

        if (g.getName().empty())  // Archive::write would number it
            throw Error("the .vdb writer: a grid without a name");
        io::GridDescriptor gd(g.getName(), g.type(), false);
        gd.writeHeader(os);
        gd.writeStreamPos(os);  // not seekable: no offsets
        setGridCompression(os, g);
        const uint32_t flags = io::getDataCompression(os);  // the grid's
        const float bg = g.tree().background();
        if (encoded && (encoded->flags() != flags || encoded->background() != bg))
            throw Error("the .vdb writer: leaf nodes encoded with another grid's settings");

        // each leaf node's bytes, in Tree::writeBuffers' order: those made
        // without values from `encoded`, the others written here by workers
        std::vector<const Leaf *> leaves;
        g.tree().getNodes(leaves);
        constexpr size_t chunk = 64;
        std::vector<StringBuf> bufs((leaves.size() + chunk - 1) / chunk);
        std::vector<std::string_view> bytes(leaves.size());
        std::vector<size_t> written(leaves.size());  // by a worker: its length there
        parallel_chunks(leaves.size(), chunk, threads_, [&](size_t s, size_t e, int) {
            StringBuf &b = bufs[s / chunk];
            std::ostream o(&b);
            io::setDataCompression(o, flags);
            io::setGridBackgroundValuePtr(o, &bg);
            for (size_t i = s; i < e; i++) {
                // a node is either made without values and encoded, or held
                // (a held node that is also encoded: its buffer was allocated
                // by some access after it was made, and holds no values)
                const std::string_view made = encoded ? encoded->find(leaves[i]->origin())
                                                      : std::string_view();
                if (leaves[i]->buffer().empty() != (made.data() != nullptr))
                    throw Error("the .vdb writer: a leaf node neither held nor encoded, or both");
                if (made.data()) {
                    bytes[i] = made;
                    continue;
                }
                const size_t before = b.s.size();
                leaves[i]->writeBuffers(o, false);
                written[i] = b.s.size() - before;
            }
        });
        size_t without_values = 0;
        for (size_t c = 0; c < bufs.size(); c++) {
            size_t at = 0;
            for (size_t i = c * chunk; i < std::min(leaves.size(), (c + 1) * chunk); i++) {
                if (bytes[i].data()) {
                    without_values++;
                    continue;
                }
                bytes[i] = std::string_view(bufs[c].s).substr(at, written[i]);
                at += written[i];
            }
        }
        std::vector<size_t>().swap(written);

        // the grid's metadata as Archive::writeGrid makes it: the delayed-load
        // metadata (Archive::compression()'s, as OpenVDB's populateDelayedLoadMetadata
        // computes it) and the statistics
        const openvdb::GridBase::Ptr copy = openvdb::ConstPtrCast<openvdb::GridBase>(g.copyGrid());
        io::DelayedLoadMetadata dl;  // a grid without leaf nodes has it empty
        if (!leaves.empty()) {
            if (!(compression() & io::COMPRESS_ACTIVE_MASK))
                throw Error("the .vdb writer: the mask compression byte is read off the leaves");
            dl.resizeMask(leaves.size());
            const bool sizes = compression() & (io::COMPRESS_BLOSC | io::COMPRESS_ZIP);
            if (sizes)
                dl.resizeCompressedSize(leaves.size());
            for (size_t i = 0; i < leaves.size(); i++) {
                int8_t mask_meta;
                const int64_t size = compressed_size(bytes[i].data(), bytes[i].size(), mask_meta);
                dl.setMask(i, mask_meta);
                if (sizes)
                    dl.setCompressedSize(i, size);
            }
        }
        copy->insertMeta(openvdb::GridBase::META_FILE_DELAYED_LOAD, dl);
        if (io::getWriteGridStatsMetadata(os)) {
            copy->addStatsMetadata();
            // the memory the grid would use with every node's values held
            const openvdb::Index64 values = without_values * Leaf::SIZE * sizeof(float);
            copy->insertMeta(openvdb::GridBase::META_FILE_MEM_BYTES,
                             openvdb::Int64Metadata((int64_t)(copy->memUsage() + values)));
            copy->insertMeta(openvdb::GridBase::META_FILE_COMPRESSION,
                             openvdb::StringMetadata(io::compressionToString(flags)));
        }
        copy->writeMeta(os);
        g.writeTransform(os);
        g.writeTopology(os);
        for (const std::string_view &b : bytes)
            os.write(b.data(), (std::streamsize)b.size());
    }

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
    // the sdf grid's: the band's half width in world units
    float sdf_background() const { return (float)(EXP_SDF_HALF_WIDTH * max_h()); }
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
// threads, each by the thread whose chunk holds the node's first leaf, and
// added to the tree in order.  The shallower leaves are tiles (or tile-aligned
// fills), few, added after.  Given `encoded`, the nodes are made without their
// values, which go there.
FloatGrid::Ptr surface_grid(const oct_tree_t *t, const Frame &fr, LeafBytes *encoded)
{
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
    const int threads = writer_threads(t, made.size());
    if (encoded)
        encoded->workers((size_t)threads);
    parallel_chunks(n, chunk, threads, [&](size_t s, size_t e, int w) {
        std::vector<std::unique_ptr<Leaf>> &out = made[s / chunk];
        std::unique_ptr<LeafBytes::Writer> bytes;
        if (encoded)
            bytes = std::make_unique<LeafBytes::Writer>(*encoded, (size_t)w);
        float v[Leaf::SIZE];  // a node's values: its leaves' depths, 0 elsewhere
        Mask mask;
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
            std::fill(v, v + Leaf::SIZE, 0.0f);
            mask.setOff();
            Coord origin;
            for (bool first = true; i < n && node_of((uint32_t)i) == key; i++, first = false) {
                const oct_leaf_t &l = t->leaves[i];
                uint32_t ix, iy, iz;
                int depth = oct_leaf_depth(&l);
                oct_unmorton(oct_leaf_code(&l), depth, &ix, &iy, &iz);
                CoordBBox b = cell_voxels(fr.D, depth, ix, iy, iz);
                if (first)
                    origin = b.min() & ~(Leaf::DIM - 1);
                for (int32_t x = b.min()[0]; x <= b.max()[0]; x++)
                    for (int32_t y = b.min()[1]; y <= b.max()[1]; y++)
                        for (int32_t z = b.min()[2]; z <= b.max()[2]; z++) {
                            const openvdb::Index k = Leaf::coordToOffset(Coord(x, y, z));
                            mask.setOn(k);
                            v[k] = (float)depth;
                        }
            }
            if (bytes) {
                out.push_back(std::make_unique<Leaf>(openvdb::PartialCreate(), origin, 0.0f));
                bytes->add(origin, mask, v);
            } else {
                out.push_back(std::make_unique<Leaf>(origin, 0.0f, false));
                std::copy(v, v + Leaf::SIZE, out.back()->buffer().data());
            }
            out.back()->setValueMask(mask);
        }
    });
    if (encoded)
        encoded->index();
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

// Is the cell's lowest voxel (the first of its grid leaf node) in an empty
// cell of class inside?
bool first_voxel_inside(const oct_tree_t *t, uint32_t node)
{
    oct_node_t w = t->nodes[node];
    while (OCT_NODE_KIND(w) == OCT_INTERIOR)
        w = t->nodes[OCT_NODE_VALUE(w)];  // child 0: the low corner
    return OCT_NODE_KIND(w) == OCT_EMPTY && OCT_NODE_VALUE(w) == OCT_INSIDE;
}

// Mark the empty cells of class inside with the inactive value -bg (the
// background, +bg, stands for outside).  A grid leaf node (a cell of depth
// D - 3) split in the octree gets no voxels here: if it holds a band voxel,
// the band's node made in sdf_grid replaces whatever is here; if not,
// pruneLevelSet would make it a tile of the sign of its first voxel, and that
// tile is what is made here.
void fill_inside(const oct_tree_t *t, const Frame &fr, FloatGrid &g, float bg, uint32_t node,
                 int d, uint32_t ix, uint32_t iy, uint32_t iz)
{
    oct_node_t w = t->nodes[node];
    if (OCT_NODE_KIND(w) == OCT_INTERIOR) {
        if (d == fr.D - (int)Leaf::LOG2DIM) {
            if (first_voxel_inside(t, node))
                g.tree().fill(cell_voxels(fr.D, d, ix, iy, iz), -bg, false);
            return;
        }
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

// The inactive values of the voxels of one grid leaf node (origin o): -bg in
// the empty cells of class inside, bg elsewhere.  The octree is walked down to
// the node's cell (depth D - 3), then below it.
void node_classes(const oct_tree_t *t, const Frame &fr, const Coord &o, float bg, float *v)
{
    std::fill(v, v + Leaf::SIZE, bg);
    const int nd = std::max(fr.D - (int)Leaf::LOG2DIM, 0);
    const uint32_t nx = (uint32_t)o[0] >> Leaf::LOG2DIM, ny = (uint32_t)o[1] >> Leaf::LOG2DIM,
                   nz = (uint32_t)o[2] >> Leaf::LOG2DIM;
    uint32_t node = 0;
    for (int d = 0; d < nd; d++) {
        const oct_node_t w = t->nodes[node];
        if (OCT_NODE_KIND(w) != OCT_INTERIOR) {  // the whole node in one cell
            if (OCT_NODE_KIND(w) == OCT_EMPTY && OCT_NODE_VALUE(w) == OCT_INSIDE)
                std::fill(v, v + Leaf::SIZE, -bg);
            return;
        }
        const int s = nd - d - 1;
        node = OCT_NODE_VALUE(w) + ((nx >> s & 1) | (ny >> s & 1) << 1 | (nz >> s & 1) << 2);
    }
    // below the node's cell: (ix, iy, iz) within it at depth d
    struct Walk {
        const oct_tree_t *t;
        int D;
        float inside;
        float *v;
        void operator()(uint32_t node, int d, uint32_t ix, uint32_t iy, uint32_t iz) const
        {
            const oct_node_t w = t->nodes[node];
            if (OCT_NODE_KIND(w) == OCT_INTERIOR) {
                const uint32_t first = OCT_NODE_VALUE(w);
                for (uint32_t c = 0; c < 8; c++)
                    (*this)(first + c, d + 1, 2 * ix + (c & 1), 2 * iy + (c >> 1 & 1),
                            2 * iz + (c >> 2 & 1));
            } else if (OCT_NODE_KIND(w) == OCT_EMPTY && OCT_NODE_VALUE(w) == OCT_INSIDE) {
                const uint32_t s = 1u << (D - d);
                for (uint32_t x = ix * s; x < (ix + 1) * s; x++)
                    for (uint32_t y = iy * s; y < (iy + 1) * s; y++)
                        for (uint32_t z = iz * s; z < (iz + 1) * s; z++)
                            v[x << 2 * Leaf::LOG2DIM | y << Leaf::LOG2DIM | z] = inside;
            }
        }
    };
    Walk{t, fr.D, -bg, v}(node, nd, 0, 0, 0);
}

// The band's voxels in the grid leaf node at o: the surface voxels within
// EXP_SDF_HALF_WIDTH voxels of it (Chebyshev distance, what OpenVDB's
// dilateActiveValues makes of NN_FACE_EDGE_VERTEX steps), within the box.
// The surface voxels of o and its 26 neighbour nodes go into rows of z bits,
// one per (x, y) of the node grown by the half width; the cube is the sum of
// three segments, so the dilation is one axis at a time.
constexpr int H = EXP_SDF_HALF_WIDTH;
static_assert(H >= 0 && H <= (int)Leaf::DIM, "the band reaches only the neighbour nodes");

template <class Accessor>
bool band_mask(Accessor &surface, const Frame &fr, const Coord &o, Mask &out)
{
    constexpr int DIM = (int)Leaf::DIM, W = DIM + 2 * H;
    uint32_t rows[W][W] = {};  // rows[x + H][y + H]: bit z + DIM for z in [-DIM, 2 DIM)
    bool any = false;
    for (int dx = -1; dx <= 1; dx++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dz = -1; dz <= 1; dz++) {
                const Coord no = o.offsetBy(dx * DIM, dy * DIM, dz * DIM);
                const Leaf *l = surface.probeConstLeaf(no);
                if (!l && !surface.isValueOn(no))  // no node, no active tile
                    continue;
                any = true;
                for (int lx = 0; lx < DIM; lx++) {
                    const int ax = dx * DIM + lx;
                    if (ax < -H || ax >= DIM + H)
                        continue;
                    const uint64_t word = l ? l->getValueMask().template getWord<uint64_t>(
                                                  (openvdb::Index)lx)
                                            : ~(uint64_t)0;
                    for (int ly = 0; ly < DIM; ly++) {
                        const int ay = dy * DIM + ly;
                        if (ay < -H || ay >= DIM + H)
                            continue;
                        rows[ax + H][ay + H] |= (uint32_t)(word >> DIM * ly & 0xff)
                                                << DIM * (dz + 1);
                    }
                }
            }
    if (!any)
        return false;
    for (auto &plane : rows)
        for (uint32_t &r : plane) {
            uint32_t d = r;
            for (int k = 0; k < H; k++)
                d |= d << 1 | d >> 1;
            r = d;
        }
    // the box: voxels [0, n) on each axis (a node reaches past it only when D < 3)
    uint32_t zmask = 0xffu;
    int xlim = DIM, ylim = DIM;
    if (fr.n < (uint32_t)DIM) {
        zmask = (1u << fr.n) - 1;
        xlim = ylim = (int)fr.n;
    }
    uint32_t cols[W][DIM];  // dilated along y
    for (int a = 0; a < W; a++)
        for (int y = 0; y < DIM; y++) {
            uint32_t r = 0;
            for (int b = y; b <= y + 2 * H; b++)
                r |= rows[a][b];
            cols[a][y] = r;
        }
    bool on = false;
    for (int x = 0; x < xlim; x++) {
        uint64_t word = 0;
        for (int y = 0; y < ylim; y++) {
            uint32_t r = 0;
            for (int a = x; a <= x + 2 * H; a++)
                r |= cols[a][y];
            word |= (uint64_t)(r >> DIM & zmask) << DIM * y;
        }
        out.template getWord<uint64_t>((openvdb::Index)x) = word;
        on = on || word;
    }
    for (int x = xlim; x < DIM; x++)
        out.template getWord<uint64_t>((openvdb::Index)x) = 0;
    return on;
}

// The grid leaf nodes the band may reach, as node coordinates (origin / 8)
// packed 21 bits an axis, x first, sorted: each node of the surface grid and
// those of its 26 neighbours (within the box) that its voxels come within the
// half width of; every node a tile of the surface grid covers, and theirs.
std::vector<uint64_t> band_candidates(const openvdb::FloatTree &surface, const Frame &fr)
{
    constexpr int DIM = (int)Leaf::DIM;
    const int32_t nn = (int32_t)std::max(fr.n / (uint32_t)DIM, 1u);  // nodes per axis
    // a bit per node of the grid, x slowest and z fastest as in a key, so that
    // the bits set come out sorted, while that is at most 16 MB (depth 12 and
    // less: a sort of the keys took 10 ms at depth 9); deeper, the keys sorted
    const uint64_t nodes = (uint64_t)nn * (uint64_t)nn * (uint64_t)nn;
    const bool bitmap = nodes <= (uint64_t)1 << 27;
    std::vector<uint64_t> bits(bitmap ? (nodes + 63) / 64 : 0);
    std::vector<uint64_t> keys;
    // lo[a], hi[a]: does the node reach its neighbour below / above on axis a?
    auto add = [&](const Coord &node, const bool lo[3], const bool hi[3]) {
        int32_t a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = std::max(node[k] - (int32_t)lo[k], 0);
            b[k] = std::min(node[k] + (int32_t)hi[k], nn - 1);
        }
        for (int32_t x = a[0]; x <= b[0]; x++)
            for (int32_t y = a[1]; y <= b[1]; y++)
                for (int32_t z = a[2]; z <= b[2]; z++) {
                    if (bitmap) {
                        const uint64_t i = ((uint64_t)x * (uint64_t)nn + (uint64_t)y) *
                                               (uint64_t)nn + (uint64_t)z;
                        bits[i >> 6] |= (uint64_t)1 << (i & 63);
                    } else {
                        keys.push_back(node_key(Coord(x, y, z) << Leaf::LOG2DIM));
                    }
                }
    };
    if (!bitmap)
        keys.reserve(8 * surface.leafCount());
    for (auto it = surface.cbeginLeaf(); it; ++it) {
        // the extent of the node's voxels: x from its words, y from the bytes
        // of their union, z from the union of those bytes
        const Mask &m = it->getValueMask();
        int x0 = DIM, x1 = -1;
        uint64_t all = 0;
        for (int x = 0; x < DIM; x++) {
            const uint64_t w = m.template getWord<uint64_t>((openvdb::Index)x);
            if (w) {
                x0 = std::min(x0, x);
                x1 = x;
                all |= w;
            }
        }
        if (!all)
            continue;
        int y0 = DIM, y1 = -1;
        unsigned zs = 0;
        for (int y = 0; y < DIM; y++) {
            const unsigned byte = (unsigned)(all >> DIM * y & 0xff);
            if (byte) {
                y0 = std::min(y0, y);
                y1 = y;
                zs |= byte;
            }
        }
        const int z0 = __builtin_ctz(zs), z1 = 31 - __builtin_clz(zs);
        const bool lo[3] = {x0 < H, y0 < H, z0 < H};
        const bool hi[3] = {x1 >= DIM - H, y1 >= DIM - H, z1 >= DIM - H};
        add(it->origin() >> Leaf::LOG2DIM, lo, hi);
    }
    // the active tiles (surface leaves of depth D - 3 or less)
    const bool every[3] = {true, true, true};
    auto tile = surface.cbeginValueOn();
    tile.setMaxDepth(openvdb::FloatTree::ValueOnCIter::LEAF_DEPTH - 1);
    for (; tile; ++tile) {
        CoordBBox b = tile.getBoundingBox();
        b.intersect(CoordBBox(Coord(0), Coord((int32_t)fr.n - 1)));
        for (int32_t x = b.min()[0]; x <= b.max()[0]; x += DIM)
            for (int32_t y = b.min()[1]; y <= b.max()[1]; y += DIM)
                for (int32_t z = b.min()[2]; z <= b.max()[2]; z += DIM)
                    add(Coord(x, y, z) >> Leaf::LOG2DIM, every, every);
    }
    if (!bitmap) {
        std::sort(keys.begin(), keys.end());
        keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
        return keys;
    }
    size_t count = 0;
    for (uint64_t w : bits)
        count += (size_t)__builtin_popcountll(w);
    keys.reserve(count);
    const uint64_t plane = (uint64_t)nn * (uint64_t)nn;
    for (size_t k = 0; k < bits.size(); k++)
        for (uint64_t w = bits[k]; w; w &= w - 1) {
            const uint64_t i = (uint64_t)k * 64 + (uint64_t)__builtin_ctzll(w);
            const Coord node((int32_t)(i / plane), (int32_t)(i / (uint64_t)nn % (uint64_t)nn),
                             (int32_t)(i % (uint64_t)nn));
            keys.push_back(node_key(node << Leaf::LOG2DIM));
        }
    return keys;
}

// The surface grid and the narrow-band level set (see export.h): surface set
// to the surface grid.  Given LeafBytes, a grid's leaf nodes are made without
// their values, which go there (surface_grid).
FloatGrid::Ptr sdf_grid(const oct_tree_t *t, const tape_t *tape, const Frame &fr,
                        FloatGrid::Ptr &surface_out, LeafBytes *surface_encoded = nullptr,
                        LeafBytes *sdf_encoded = nullptr)
{
    const float bg = fr.sdf_background();
    FloatGrid::Ptr g = FloatGrid::create(bg);
    g->setName("sdf");
    g->setGridClass(openvdb::GRID_LEVEL_SET);
    g->setTransform(fr.xf->copy());

    // The inside cells (a walk of the octree into the sdf tree) and the
    // surface grid with the band's nodes (their own trees and nodes) share
    // nothing until the band's nodes go into the tree: one thread each when
    // the build had two or more, the walk being serial.
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

    surface_out = surface_grid(t, fr, surface_encoded);
    const openvdb::FloatTree &stree = surface_out->tree();

    // The band's grid leaf nodes, made whole over threads: their voxels
    // (band_mask), their inactive values (node_classes: bg, or -bg inside)
    // and at the active ones f / |grad f|, clamped; outside the
    // surface leaves the sign is the octree's class.  f and its gradient at
    // every band voxel are the one evaluation the build has not made (it knows
    // f over cells, not at voxel centres): one evaluator pass a node (up to 512
    // voxels).  A distance estimate needs no enclosure: plain doubles
    // (tape_eval_point_grad), a fifth of the interval gradient's cost.
    const std::vector<uint64_t> keys = band_candidates(stree, fr);
    const size_t chunk = 64;
    std::vector<std::vector<std::unique_ptr<Leaf>>> made((keys.size() + chunk - 1) / chunk);
    const int threads = writer_threads(t, made.size());
    if (sdf_encoded)
        sdf_encoded->workers((size_t)threads);
    std::vector<std::unique_ptr<Workspace>> ws;
    for (int w = 0; w < threads; w++)
        ws.push_back(std::make_unique<Workspace>(tape));
    parallel_chunks(keys.size(), chunk, threads, [&](size_t s, size_t e, int w) {
        constexpr size_t N = Leaf::SIZE;
        // an accessor that caches no leaf node: ValueAccessor's leaf cache
        // allocates the node's buffer (LeafBuffer::data), which a node made
        // without its values (LeafBytes) must not have
        openvdb::tree::ValueAccessor2<const openvdb::FloatTree, true, 1, 2> acc(stree);
        std::vector<double> x(N), y(N), z(N);
        std::vector<tape_point_grad_t> out(N);
        std::vector<openvdb::Index> offset(N);
        std::vector<signed char> sign(N);  // 0: in a surface leaf
        std::vector<float> dist(N);
        double p[3][Leaf::DIM];            // voxel centres along each axis
        Mask mask;
        std::unique_ptr<LeafBytes::Writer> bytes;
        if (sdf_encoded)
            bytes = std::make_unique<LeafBytes::Writer>(*sdf_encoded, (size_t)w);
        float scratch[Leaf::SIZE];
        for (size_t i = s; i < e; i++) {
            const Coord o = node_origin(keys[i]);
            if (!band_mask(acc, fr, o, mask))  // else a voxel is on: pruneLevelSet keeps the node
                continue;
            // the node's values, written in place or, to be encoded, in the scratch
            auto node = bytes ? std::make_unique<Leaf>(openvdb::PartialCreate(), o, bg)
                              : std::make_unique<Leaf>(o, bg, false);
            float *v = bytes ? scratch : node->buffer().data();
            node_classes(t, fr, o, bg, v);
            node->setValueMask(mask);
            // the surface grid's voxels here: its leaf node of the same origin,
            // else one tile covers the node
            const Leaf *sl = acc.probeConstLeaf(o);
            const bool s_tile_on = !sl && acc.isValueOn(o);
            for (int a = 0; a < 3; a++)
                for (openvdb::Index j = 0; j < Leaf::DIM; j++)
                    p[a][j] = fr.lo[a] + ((double)(o[a] + (int32_t)j) + 0.5) * fr.h[a];
            // the band's voxels in the order of the mask's bits: a word of 64
            // (y << 3 | z) per x
            size_t m = 0;
            for (openvdb::Index ix = 0; ix < Leaf::DIM; ix++) {
                uint64_t word = mask.template getWord<uint64_t>(ix);
                const uint64_t surf = sl ? sl->getValueMask().template getWord<uint64_t>(ix)
                                         : s_tile_on ? ~(uint64_t)0 : 0;
                for (; word; word &= word - 1, m++) {
                    const unsigned b = (unsigned)__builtin_ctzll(word);
                    const openvdb::Index n = ix << 2 * Leaf::LOG2DIM | b;
                    offset[m] = n;
                    sign[m] = surf >> b & 1 ? 0 : v[n] < 0 ? -1 : 1;
                    x[m] = p[0][ix];
                    y[m] = p[1][b >> Leaf::LOG2DIM];
                    z[m] = p[2][b & (Leaf::DIM - 1)];
                }
            }
            tape_eval_point_grad(tape, ws[(size_t)w]->ws, m, x.data(), y.data(), z.data(),
                                 out.data());
            // without branches, so that the lanes vectorise: each quotient
            // and product is made, then the ones that apply selected
            const double bgd = bg, least = 1e-3 * fr.max_h();
            for (size_t j = 0; j < m; j++) {
                const tape_point_grad_t &q = out[j];
                const double f = q.v;
                const double gn = std::sqrt(q.dx * q.dx + q.dy * q.dy + q.dz * q.dz);
                const double ratio = f / gn;
                // a gradient of 0, inf or NaN: the sign of f
                double d = ((gn > 0) & (gn <= DBL_MAX)) ? ratio : f > 0 ? bgd : f < 0 ? -bgd : 0.0;
                d = d != d ? bgd : d;  // f undefined here: outside
                d = d < bgd ? d : bgd;
                d = -bgd < d ? d : -bgd;
                const double cls = sign[j];
                const double kept = cls * (std::fabs(d) < least ? least : std::fabs(d));
                d = ((cls != 0) & !(d * cls > 0)) ? kept : d;  // the certified class wins; keep |d| if any
                dist[j] = (float)d;
            }
            for (size_t j = 0; j < m; j++)
                v[offset[j]] = dist[j];
            if (bytes)
                bytes->add(o, mask, v);
            made[s / chunk].push_back(std::move(node));
        }
    });
    if (sdf_encoded)
        sdf_encoded->index();
    if (inside.joinable())
        inside.join();
    if (inside_failed)
        std::rethrow_exception(inside_failed);
    // each replaces what fill_inside left at its place (a tile or nothing; a
    // node of voxels when D < 3)
    for (auto &v : made)
        for (auto &node : v)
            g->tree().addLeaf(node.release());
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
    // the test hook: io::Stream itself, which needs every node's values held
    const char *hook = std::getenv("IVOCT_VDB_STREAM");
    const bool openvdb_stream = hook && !std::strcmp(hook, "openvdb");
    const VdbStream stream(writer_threads(tree, (size_t)1 << 20));
    std::vector<std::unique_ptr<LeafBytes>> bytes;
    if (!openvdb_stream) {
        bytes.push_back(std::make_unique<LeafBytes>(
            stream.grid_compression(openvdb::GRID_UNKNOWN), 0.0f));  // the surface grid's
        bytes.push_back(std::make_unique<LeafBytes>(
            stream.grid_compression(openvdb::GRID_LEVEL_SET), fr.sdf_background()));
    }
    FloatGrid::Ptr surface;
    FloatGrid::Ptr sdf = sdf_grid(tree, tape, fr, surface, bytes.empty() ? nullptr : bytes[0].get(),
                                  bytes.empty() ? nullptr : bytes[1].get());
    openvdb::MetaMap m = metadata(tree, src);
    std::vector<FloatGrid::Ptr> grids{std::move(surface), std::move(sdf)};
    for (auto &g : grids) {
        for (auto it = m.beginMeta(); it != m.endMeta(); ++it)
            g->insertMeta(it->first, *it->second);
    }
    Output out(path);
    FileBuf buf(out.file());
    std::ostream os(&buf);
    if (openvdb_stream)
        openvdb::io::Stream(os).write(openvdb::GridPtrVec(grids.begin(), grids.end()), m);
    else
        stream.write_file(os, std::move(grids), std::move(bytes), m);
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
