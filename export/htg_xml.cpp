// ivoct export/ — the .htg writer: VTK's HyperTreeGrid XML format written
// straight from the octree (no vtkHyperTreeGrid, no cursor walk, no VTK writer).
//
// The file is what VTK 9.1's vtkXMLHyperTreeGridWriter writes in binary mode
// with UInt64 headers and its LZ4 compressor, byte for byte: the same XML (its
// attributes, indentation and number formatting: vtk_number, the shortest
// digits that read back), the same arrays in the same order, each
// one's data compressed as VTK does (lz4_blocks, internal.hpp), the
// compressed-data header base64-encoded, then the compressed blocks
// base64-encoded as one stream.  What this writer does
// differently is only how: the blocks of an array are compressed by threads,
// the base64 is encoded by threads a window at a time into the text buffer,
// and the output goes to the file in a few large writes.
//
// Two layouts of the same trees (VTK's file format versions):
//   2.0 (exp_htg): the trees in tree-index order, each breadth first; one
//       bit array Descriptors (per tree, 1 for a split node, every depth but
//       the last), NumberOfVerticesPerDepth, TreeIds, DepthPerTree, and each
//       cell array over all the trees' nodes in that order;
//   0.0 (exp_htg_piece, VTK 9.1's parallel reader needs it: export/README.md):
//       one <Tree> element per tree (tree-index order) with its Index,
//       GlobalOffset and NumberOfVertices, its Descriptor (breadth first,
//       every depth) and its own cell arrays, the nodes in the order a
//       vtkHyperTree numbers them when built depth first: a split node's 8
//       children take the next 8 numbers when the walk reaches it.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "internal.hpp"

namespace ivexp {
namespace {

enum { CLASS_SURFACE = 3, CLASS_SPLIT = 4 };

struct HtgNode {
    uint32_t node;  // index in tree->nodes
    uint8_t depth;
    uint32_t ix, iy, iz;
};

inline HtgNode child_of(const HtgNode &n, uint32_t first, unsigned c)
{
    return {first + c, (uint8_t)(n.depth + 1), 2 * n.ix + (c & 1), 2 * n.iy + (c >> 1 & 1),
            2 * n.iz + (c >> 2 & 1)};
}

inline bool is_split(const oct_tree_t *tree, const HtgNode &n)
{
    return OCT_NODE_KIND(tree->nodes[n.node]) == OCT_INTERIOR;
}

// ---- base64 -------------------------------------------------------------------------
const char B64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

inline size_t b64_size(size_t n) { return (n + 2) / 3 * 4; }

// Two base64 digits for each 12-bit value.
struct B64Pairs {
    B64Pairs()
    {
        for (unsigned v = 0; v < 4096; v++) {
            pair[v][0] = B64[v >> 6];
            pair[v][1] = B64[v & 63];
        }
    }
    char pair[4096][2];
};
const B64Pairs b64_pairs;

// n bytes as base64 (padded with '=' as vtkBase64OutputStream ends a stream)
void b64_encode(const unsigned char *in, size_t n, char *out)
{
    size_t i = 0;
    for (; i + 3 <= n; i += 3, out += 4) {
        const uint32_t v = (uint32_t)in[i] << 16 | (uint32_t)in[i + 1] << 8 | in[i + 2];
        std::memcpy(out, b64_pairs.pair[v >> 12], 2);
        std::memcpy(out + 2, b64_pairs.pair[v & 4095], 2);
    }
    if (n - i == 1) {
        const uint32_t v = (uint32_t)in[i] << 16;
        out[0] = B64[v >> 18];
        out[1] = B64[v >> 12 & 63];
        out[2] = out[3] = '=';
    } else if (n - i == 2) {
        const uint32_t v = (uint32_t)in[i] << 16 | (uint32_t)in[i + 1] << 8;
        out[0] = B64[v >> 18];
        out[1] = B64[v >> 12 & 63];
        out[2] = B64[v >> 6 & 63];
        out[3] = '=';
    }
}

// ---- bits ---------------------------------------------------------------------------
// vtkBitArray's layout: bit i in byte i / 8, most significant bit first; the
// unused bits of the last byte 0.
struct Bits {
    std::vector<unsigned char> bytes;
    size_t n = 0;
    size_t ones = 0;
    void push(bool b)
    {
        if ((n & 7) == 0)
            bytes.push_back(0);
        if (b) {
            bytes.back() |= (unsigned char)(0x80u >> (n & 7));
            ones++;
        }
        n++;
    }
    void drop(size_t k)  // the last k bits, all 0
    {
        n -= k;
        bytes.resize((n + 7) / 8);
    }
    void append(const Bits &o)  // o's bits after these
    {
        const unsigned shift = (unsigned)(n & 7);
        if (!shift) {
            bytes.insert(bytes.end(), o.bytes.begin(), o.bytes.end());
        } else {
            for (unsigned char b : o.bytes) {
                bytes.back() |= (unsigned char)(b >> shift);
                bytes.push_back((unsigned char)(b << (8 - shift)));
            }
        }
        n += o.n;
        ones += o.ones;
        bytes.resize((n + 7) / 8);  // (the bits past n are o's unused ones: 0)
    }
    Range range() const
    {
        Range r;
        if (n) {
            r.lo = ones == n ? 1 : 0;
            r.hi = ones ? 1 : 0;
            r.any = true;
        }
        return r;
    }
};

// ---- the file -----------------------------------------------------------------------
class Writer {
public:
    Writer(const char *path, int threads) : out_(path), threads_(threads) {}

    std::string &text() { return text_; }

    int threads() const { return threads_; }
    const char *path() const { return out_.path(); }

    // <DataArray ...> (or <Array ...> for strings) with its inline binary data:
    // vtkXMLWriter::WriteArrayInline.  NumberOfTuples is written when tuples is
    // not 0 (VTK's writers pass the count as a flag); ranges for data arrays.
    void array(int indent, const char *type, const std::string &name, size_t tuples,
               Lz4Blocks &&z, const Range *range)
    {
        const std::string pad((size_t)indent, ' ');
        const char *tag = range ? "DataArray" : "Array";
        text_ += pad + "<" + tag + " type=\"" + type + "\" Name=\"" + name + "\"";
        if (tuples)
            text_ += " NumberOfTuples=\"" + std::to_string(tuples) + "\"";
        text_ += " format=\"binary\"";
        if (range)
            text_ += " RangeMin=\"" + vtk_number(range->lo) + "\" RangeMax=\"" +
                     vtk_number(range->hi) + "\"";
        text_ += ">\n" + pad + "  ";
        binary(z);
        text_ += "\n" + pad + "</" + tag + ">\n";
        if (text_.size() > FLUSH)
            flush();
        spools_ = std::move(z.spools);
    }
    // The same for `bytes` bytes held at data.
    void array(int indent, const char *type, const std::string &name, size_t tuples,
               const void *data, size_t bytes, const Range *range)
    {
        array(indent, type, name, tuples,
              lz4_blocks(data, bytes, threads_, out_.path(), std::move(spools_)), range);
    }

    // The n bytes that bytes() gives, compressed (lz4_blocks) into the memory of
    // the arrays before.
    Lz4Blocks compress(size_t n, const BlockBytes &bytes)
    {
        return lz4_blocks(n, threads_, bytes, out_.path(), std::move(spools_));
    }

    void commit()
    {
        flush();
        out_.commit();
    }

private:
    static constexpr size_t FLUSH = (size_t)1 << 20;         // the text written out past this
    static constexpr size_t WINDOW = 3 * ((size_t)1 << 18);  // compressed bytes encoded at once

    void flush()
    {
        out_.write(text_.data(), text_.size());
        text_.clear();
    }

    // n bytes as base64 at the end of the text
    void encode(const unsigned char *p, size_t n)
    {
        const size_t at = text_.size();
        text_.resize(at + b64_size(n));
        b64_encode(p, n, &text_[at]);
    }

    // The compressed data: base64 of the header, then of the blocks as one stream,
    // read where lz4_blocks left them, a window at a time (a multiple of 3 bytes, so
    // that only the stream's end is padded).  A stream of one window goes into the
    // text; a longer one straight to the file, the windows shared by the threads:
    // each gathers a window's bytes and encodes them into buffers of its own (the
    // same memory for every array), then writes them once the windows before are
    // written, so that one thread's write overlaps the others' encoding.
    void binary(const Lz4Blocks &z)
    {
        encode(reinterpret_cast<const unsigned char *>(z.header.data()), z.header_bytes());
        const size_t nblocks = z.where.size(), n = z.size;
        std::vector<size_t> start(nblocks + 1, 0);  // each block's place in the stream
        for (size_t b = 0; b < nblocks; b++)
            start[b + 1] = start[b] + (size_t)z.header[3 + b];
        // the stream's bytes [s, e) into out
        auto gather = [&](size_t s, size_t e, unsigned char *out) {
            size_t b =
                (size_t)(std::upper_bound(start.begin(), start.end(), s) - start.begin()) - 1;
            for (; s < e; b++) {
                const size_t k = std::min(e, start[b + 1]) - s;
                const Lz4Spool &spool = z.spools[(size_t)z.where[b].first];
                std::memcpy(out, spool.data.get() + z.where[b].second + (s - start[b]), k);
                out += k, s += k;
            }
        };
        const size_t windows = (n + WINDOW - 1) / WINDOW;
        const int threads = (int)std::min((size_t)threads_, windows);
        while (buffers_.size() < (size_t)std::max(threads, 1))
            buffers_.emplace_back(huge_array<unsigned char>(WINDOW),
                                  huge_array<char>(b64_size(WINDOW)));
        if (windows <= 1) {
            gather(0, n, buffers_[0].first.get());
            encode(buffers_[0].first.get(), n);
            return;
        }
        flush();
        Turns turns;
        size_t written = 0;  // windows written
        parallel_chunks(windows, 1, threads, [&](size_t w, size_t, int worker) {
            turns.run([&] {
                const size_t s = w * WINDOW, e = std::min(n, s + WINDOW);
                auto &buf = buffers_[(size_t)worker];
                gather(s, e, buf.first.get());
                b64_encode(buf.first.get(), e - s, buf.second.get());
                std::unique_lock<std::mutex> lk = turns.lock();
                if (!turns.wait(lk, [&] { return written == w; }))
                    return;
                out_.write(buf.second.get(), b64_size(e - s));
                written++;
                turns.notify();
            });
        });
    }

    Output out_;
    int threads_;
    std::string text_;
    // each thread's window: its bytes, their base64
    std::vector<std::pair<HugeArray<unsigned char>, HugeArray<char>>> buffers_;
    std::vector<Lz4Spool> spools_;  // the last array's, for the next
};

// ---- the trees ----------------------------------------------------------------------
// Is there a surface leaf at or below node i?  Into s[] for the whole subtree.
bool mark_surface(const oct_tree_t *tree, uint32_t i, HugeVector<uint8_t> &s)
{
    const oct_node_t w = tree->nodes[i];
    bool has = OCT_NODE_KIND(w) == OCT_LEAF;
    if (OCT_NODE_KIND(w) == OCT_INTERIOR)
        for (uint32_t c = 0; c < 8; c++)
            has = mark_surface(tree, OCT_NODE_VALUE(w) + c, s) || has;
    s[i] = has;
    return has;
}

// The trees' nodes in the output order, without a list of them: a tree is its
// root, then the 8 children of each of its split nodes in turn, in the order
// `split` lists those (breadth first for 2.0, whose arrays are breadth first; for
// 0.0 the order of a depth-first walk, vtkHyperTree's numbering of a tree built
// depth first: a split node's children take the next 8 numbers when the walk
// reaches it).  So node i > 0 of a tree is child (i - 1) % 8 of its split node
// (i - 1) / 8, and only the split nodes are held: an eighth of the nodes.
struct Tree {
    uint64_t index;                  // in the grid (x fastest)
    HtgNode root;
    size_t first = 0, count = 0;     // its nodes' positions in the output order
    HugeVector<HtgNode> split;       // its split nodes, in that order
    std::vector<int64_t> per_depth;  // nodes at each depth of the tree
    Bits desc;                       // its descriptor (2.0: every depth but the last)
};

struct Order {
    std::vector<Tree> trees;
    size_t total = 0;

    // The nodes at positions [s, e) into out.
    void nodes(const oct_tree_t *tree, size_t s, size_t e, HtgNode *out) const
    {
        size_t k = (size_t)(std::upper_bound(trees.begin(), trees.end(), s,
                                             [](size_t p, const Tree &t) { return p < t.first; }) -
                            trees.begin()) -
                   1;
        for (size_t p = s; p < e; p++) {
            while (p >= trees[k].first + trees[k].count)
                k++;
            const Tree &t = trees[k];
            const size_t i = p - t.first;
            if (i == 0) {
                *out++ = t.root;
            } else {
                const HtgNode &parent = t.split[(i - 1) / 8];
                *out++ = child_of(parent, OCT_NODE_VALUE(tree->nodes[parent.node]),
                                  (unsigned)((i - 1) & 7));
            }
        }
    }
};

// The split nodes below n (n's own first) as a depth-first walk reaches them.
void split_depth_first(const oct_tree_t *tree, const HtgNode &n, HugeVector<HtgNode> &out)
{
    if (!is_split(tree, n))
        return;
    out.push_back(n);
    const uint32_t child = OCT_NODE_VALUE(tree->nodes[n.node]);
    for (unsigned c = 0; c < 8; c++)
        split_depth_first(tree, child_of(n, child, c), out);
}

// The bounds of the cells, from a table of depth T = min(D, 16) per axis
// (oct_coord gives the same double for the same fraction at any depth); deeper
// cells from oct_coord itself.
class Coords {
public:
    explicit Coords(const oct_tree_t *tree) : box_(tree->box), t_(std::min(std::max(tree->depth, 0), 16))
    {
        const uint64_t n = ((uint64_t)1 << t_) + 1;
        for (int a = 0; a < 3; a++) {
            table_[a].resize(n);
            for (uint64_t i = 0; i < n; i++)
                table_[a][i] = oct_coord(box_[2 * a], box_[2 * a + 1], i, t_);
        }
    }
    double at(int axis, uint64_t i, int depth) const
    {
        return depth <= t_ ? table_[axis][i << (t_ - depth)]
                           : oct_coord(box_[2 * axis], box_[2 * axis + 1], i, depth);
    }
    iv_box_t box(const HtgNode &n) const
    {
        return {{at(0, n.ix, n.depth), at(0, (uint64_t)n.ix + 1, n.depth)},
                {at(1, n.iy, n.depth), at(1, (uint64_t)n.iy + 1, n.depth)},
                {at(2, n.iz, n.depth), at(2, (uint64_t)n.iz + 1, n.depth)}};
    }

private:
    const double *box_;
    int t_;
    std::vector<double> table_[3];
};

// The cell arrays, made a block at a time straight from the order and compressed
// (never held whole: 30 bytes a node would be as many fresh pages): each block's
// nodes found from their positions, f over the nodes that are not surface leaves
// (those keep the build's range) and at every centre evaluated for the block.  A
// box's result does not depend on its batch, and the ranges of the blocks are
// merged in order (range_of's result), so the file is the same for any thread count.
class CellArrays {
public:
    CellArrays(Writer &w, const oct_tree_t *tree, const tape_t *tape, const Order &order,
               const HugeVector<uint8_t> &surface)
        : w_(w), tree_(tree), tape_(tape), order_(order), surface_(surface), coords_(tree)
    {
        for (int k = 0; k < w.threads(); k++)
            scratch_.push_back(std::make_unique<Scratch>(tape));
    }

    // The arrays of the nodes at [first, first + n) (vtkXMLWriter's order: as the
    // cell data were added).
    void write(int indent, size_t first, size_t n)
    {
        const oct_tree_t *tree = tree_;
        // each array's values for a block's m nodes at v, into out
        array<int32_t>(indent, "Int32", "depth", first, n,
                       [](const HtgNode *v, size_t m, int32_t *out, Scratch &) {
                           for (size_t k = 0; k < m; k++)
                               out[k] = v[k].depth;
                       });
        array<double>(indent, "Float64", "f_center", first, n,
                      [this](const HtgNode *v, size_t m, double *out, Scratch &s) {
                          for (size_t k = 0; k < m; k++) {
                              const iv_box_t b = coords_.box(v[k]);
                              s.cx[k] = 0.5 * b.x.lo + 0.5 * b.x.hi;
                              s.cy[k] = 0.5 * b.y.lo + 0.5 * b.y.hi;
                              s.cz[k] = 0.5 * b.z.lo + 0.5 * b.z.hi;
                          }
                          tape_eval_point(tape_, s.ws.ws, m, s.cx.data(), s.cy.data(),
                                          s.cz.data(), out);
                      });
        // f over the cells evaluated for each bound: once more costs less than
        // the fresh pages that would keep the upper bounds from the first pass
        array<double>(indent, "Float64", "f_lo", first, n,
                      [this](const HtgNode *v, size_t m, double *out, Scratch &s) {
                          f_range(v, m, s);
                          for (size_t k = 0; k < m; k++)
                              out[k] = s.f[k].lo;
                      });
        array<double>(indent, "Float64", "f_hi", first, n,
                      [this](const HtgNode *v, size_t m, double *out, Scratch &s) {
                          f_range(v, m, s);
                          for (size_t k = 0; k < m; k++)
                              out[k] = s.f[k].hi;
                      });
        array<uint8_t>(indent, "UInt8", "surface", first, n,
                       [this](const HtgNode *v, size_t m, uint8_t *out, Scratch &) {
                           for (size_t k = 0; k < m; k++)
                               out[k] = surface_[v[k].node];
                       });
        array<int8_t>(indent, "Int8", "class", first, n,
                      [tree](const HtgNode *v, size_t m, int8_t *out, Scratch &) {
                          for (size_t k = 0; k < m; k++) {
                              const oct_node_t node = tree->nodes[v[k].node];
                              out[k] = OCT_NODE_KIND(node) == OCT_LEAF ? (int8_t)CLASS_SURFACE
                                       : OCT_NODE_KIND(node) == OCT_INTERIOR
                                           ? (int8_t)CLASS_SPLIT
                                           : (int8_t)OCT_NODE_VALUE(node);
                          }
                      });
        if (tree->certain)
            array<uint8_t>(indent, "UInt8", "certain", first, n,
                           [tree](const HtgNode *v, size_t m, uint8_t *out, Scratch &) {
                               for (size_t k = 0; k < m; k++) {
                                   const oct_node_t node = tree->nodes[v[k].node];
                                   out[k] = OCT_NODE_KIND(node) == OCT_LEAF
                                                ? (uint8_t)oct_leaf_certain(
                                                      tree, OCT_NODE_VALUE(node))
                                                : 0;
                               }
                           });
    }

private:
    static constexpr size_t MOST = LZ4_BLOCK;          // nodes in a block (of bytes)
    static constexpr size_t MOST_F = LZ4_BLOCK / 8;    // nodes in a block of doubles

    struct Scratch {
        explicit Scratch(const tape_t *tape)
            : ws(tape), nodes(MOST), boxes(MOST_F), f(MOST_F), fr(MOST_F), cx(MOST_F),
              cy(MOST_F), cz(MOST_F)
        {
        }
        Workspace ws;
        std::vector<HtgNode> nodes;
        std::vector<iv_box_t> boxes;
        std::vector<iv_t> f, fr;
        std::vector<double> cx, cy, cz;
    };

    // f over the m nodes at v into s.f: the leaves' from the build, the others'
    // evaluated
    void f_range(const HtgNode *v, size_t m, Scratch &s) const
    {
        size_t q = 0;
        for (size_t k = 0; k < m; k++)
            if (OCT_NODE_KIND(tree_->nodes[v[k].node]) != OCT_LEAF)
                s.boxes[q++] = coords_.box(v[k]);
        tape_eval_interval(tape_, s.ws.ws, q, s.boxes.data(), s.fr.data());
        q = 0;
        for (size_t k = 0; k < m; k++) {
            const oct_node_t node = tree_->nodes[v[k].node];
            if (OCT_NODE_KIND(node) == OCT_LEAF) {
                const oct_leaf_t &leaf = tree_->leaves[OCT_NODE_VALUE(node)];
                s.f[k] = {leaf.f_lo, leaf.f_hi};
            } else {
                s.f[k] = s.fr[q++];
            }
        }
    }

    // One array of T over the nodes [first, first + n): values(nodes, m, out,
    // scratch) for each block's m nodes.
    template <class T, class F>
    void array(int indent, const char *type, const char *name, size_t first, size_t n, F &&values)
    {
        constexpr size_t per = LZ4_BLOCK / sizeof(T);
        std::vector<Range> ranges((n + per - 1) / per);
        Lz4Blocks z = w_.compress(
            n * sizeof(T),
            [&](size_t at, size_t bytes, unsigned char *block, int worker) -> const void * {
                Scratch &s = *scratch_[(size_t)worker];
                const size_t i = at / sizeof(T), m = bytes / sizeof(T);
                order_.nodes(tree_, first + i, first + i + m, s.nodes.data());
                T *out = reinterpret_cast<T *>(block);  // new[]'s: aligned for any T
                values(s.nodes.data(), m, out, s);
                ranges[i / per] = range_of(out, m);
                return out;
            });
        Range r;
        for (const Range &b : ranges)
            r.add(b);
        w_.array(indent, type, name, n, std::move(z), &r);
    }

    Writer &w_;
    const oct_tree_t *tree_;
    const tape_t *tape_;
    const Order &order_;
    const HugeVector<uint8_t> &surface_;
    const Coords coords_;
    std::vector<std::unique_ptr<Scratch>> scratch_;
};

// The HyperTreeGrid of the subtrees of `tree` below `roots`, cells of depth g:
// a grid of 2^g x 2^g x 2^g trees (their bounds oct_coord at depth g), a tree at
// each root's cell; every node a cell, with the cell data and field data of
// exp_htg.  `piece`: a piece of a .phtg, in the file format VTK's parallel
// reader reads right (0.0); else 2.0.
void write_htg_trees(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src, int g,
                     std::vector<HtgNode> roots, bool piece, const char *path)
{
    const uint64_t cells = (uint64_t)1 << g;
    auto tree_index = [cells](const HtgNode &r) {
        return (uint64_t)r.ix + cells * ((uint64_t)r.iy + cells * (uint64_t)r.iz);
    };
    // VTK's tree iterator goes by tree index
    std::stable_sort(roots.begin(), roots.end(), [&](const HtgNode &a, const HtgNode &b) {
        return tree_index(a) < tree_index(b);
    });

    // each tree on its own, over threads: which nodes have surface below them;
    // the tree breadth first (its split nodes are the queue): its depths, its
    // descriptor; its split nodes in the output order
    HugeVector<uint8_t> surface(tree->n_nodes);
    Order order;
    order.trees.resize(roots.size());
    parallel_chunks(roots.size(), 1, writer_threads(tree, roots.size()),
                    [&](size_t k, size_t, int) {
        const HtgNode &r = roots[k];
        mark_surface(tree, r.node, surface);
        Tree &t = order.trees[k];
        t.index = tree_index(r);
        t.root = r;
        t.per_depth = {1};
        HugeVector<HtgNode> bfs;
        HugeVector<HtgNode> &queue = piece ? bfs : t.split;
        t.desc.push(is_split(tree, r));
        if (is_split(tree, r))
            queue.push_back(r);
        for (size_t i = 0; i < queue.size(); i++) {
            const HtgNode parent = queue[i];
            const size_t below = (size_t)(parent.depth - r.depth) + 1;
            if (t.per_depth.size() == below)
                t.per_depth.push_back(0);
            t.per_depth[below] += 8;
            const uint32_t first = OCT_NODE_VALUE(tree->nodes[parent.node]);
            for (unsigned c = 0; c < 8; c++) {
                const HtgNode ch = child_of(parent, first, c);
                t.desc.push(is_split(tree, ch));
                if (is_split(tree, ch))
                    queue.push_back(ch);
            }
        }
        t.count = 1 + 8 * queue.size();
        if (piece)
            split_depth_first(tree, r, t.split);
        else
            t.desc.drop((size_t)t.per_depth.back());  // the last depth's 0s are not written
    });
    Bits desc;  // 2.0: all trees' descriptors, one after the other
    for (Tree &t : order.trees) {
        t.first = order.total;
        order.total += t.count;
        if (!piece) {
            desc.append(t.desc);
            t.desc = Bits();
        }
    }
    const size_t total = order.total;
    const std::vector<Tree> &trees = order.trees;

    Writer w(path, writer_threads(tree, (size_t)-1));
    CellArrays arrays(w, tree, tape, order, surface);
    std::string &t = w.text();
    t += "<?xml version=\"1.0\"?>\n<VTKFile type=\"HyperTreeGrid\" version=\"";
    t += piece ? "0.0" : "2.0";
    t += "\" byte_order=\"";
    t += VTK_BYTE_ORDER;
    t += "\" header_type=\"UInt64\" compressor=\"vtkLZ4DataCompressor\">\n  <HyperTreeGrid";
    if (piece)
        t += " Dimension=\"3\" Orientation=\"-1\"";
    const std::string dim = std::to_string(cells + 1);
    t += " BranchFactor=\"2\" TransposedRootIndexing=\"0\" Dimensions=\"" + dim + " " + dim + " " +
         dim + "\"";
    if (piece)
        t += " NumberOfVertices=\"" + std::to_string(total) + "\"";
    t += ">\n    <Grid>\n";
    std::vector<double> coord(cells + 1);
    static const char *const axes[3] = {"XCoordinates", "YCoordinates", "ZCoordinates"};
    for (int axis = 0; axis < 3; axis++) {
        for (uint64_t i = 0; i <= cells; i++)
            coord[i] = oct_coord(tree->box[2 * axis], tree->box[2 * axis + 1], i, g);
        const Range r = range_of(coord.data(), coord.size());
        w.array(6, "Float64", axes[axis], coord.size(), coord.data(), 8 * coord.size(), &r);
    }
    t += "    </Grid>\n    <Trees>\n";
    if (piece) {
        int64_t offset = 0;
        for (size_t k = 0; k < trees.size(); k++) {
            const Tree &tr = trees[k];
            t += "      <Tree Index=\"" + std::to_string(tr.index) + "\" GlobalOffset=\"" +
                 std::to_string(offset) + "\" NumberOfVertices=\"" + std::to_string(tr.count) +
                 "\">\n";
            const Range r = tr.desc.range();
            w.array(8, "Bit", "Descriptor", tr.desc.n, tr.desc.bytes.data(), tr.desc.bytes.size(),
                    &r);
            t += "        <CellData>\n";
            arrays.write(10, tr.first, tr.count);
            t += "        </CellData>\n      </Tree>\n";
            offset += (int64_t)tr.count;
        }
        t += "    </Trees>\n";
    } else {
        std::vector<int64_t> per_depth, ids;
        std::vector<uint32_t> depths;
        for (const Tree &tr : trees) {
            per_depth.insert(per_depth.end(), tr.per_depth.begin(), tr.per_depth.end());
            ids.push_back((int64_t)tr.index);
            depths.push_back((uint32_t)tr.per_depth.size());
        }
        Range r = desc.range();
        w.array(8, "Bit", "Descriptors", desc.n, desc.bytes.data(), desc.bytes.size(), &r);
        r = range_of(per_depth.data(), per_depth.size());
        w.array(8, "Int64", "NumberOfVerticesPerDepth", per_depth.size(), per_depth.data(),
                8 * per_depth.size(), &r);
        r = range_of(ids.data(), ids.size());
        w.array(8, "Int64", "TreeIds", ids.size(), ids.data(), 8 * ids.size(), &r);
        r = range_of(depths.data(), depths.size());
        w.array(8, "UInt32", "DepthPerTree", depths.size(), depths.data(), 4 * depths.size(), &r);
        t += "    </Trees>\n    <CellData>\n";
        arrays.write(8, 0, total);
        t += "    </CellData>\n";
    }
    // field data: the source's strings (each with its terminating 0), box, depth
    t += "    <FieldData>\n";
    for (const MetaItem &m : meta_strings(src))
        w.array(6, "String", m.key, 1, m.value.c_str(), m.value.size() + 1, nullptr);
    const Range rb = range_of(tree->box, 6);
    w.array(6, "Float64", "box", 6, tree->box, 8 * 6, &rb);
    const int32_t depth = tree->depth;
    const Range rd = range_of(&depth, 1);
    w.array(6, "Int32", "depth", 1, &depth, 4, &rd);
    t += "    </FieldData>\n  </HyperTreeGrid>\n</VTKFile>\n";
    w.commit();
}

// The nodes of `tree` at depth g below node n (depth d, cell ix iy iz), in Morton
// order; a surface leaf above g is an error (no tree of the grid can hold it).
void nodes_at_depth(const oct_tree_t *tree, const HtgNode &n, int g, std::vector<HtgNode> &out,
                    const char *path)
{
    const oct_node_t w = tree->nodes[n.node];
    if (n.depth == g) {
        out.push_back(n);
    } else if (OCT_NODE_KIND(w) == OCT_INTERIOR) {
        for (uint32_t c = 0; c < 8; c++)
            nodes_at_depth(tree, child_of(n, OCT_NODE_VALUE(w), c), g, out, path);
    } else if (OCT_NODE_KIND(w) == OCT_LEAF) {
        throw Error(std::string("cannot write ") + path + ": a surface leaf of depth " +
                    std::to_string(n.depth) + " lies above depth " + std::to_string(g) +
                    ", where the pieces' trees start (the frontier): a .phtg cannot hold "
                    "it, a .htg can");
    }
}

}  // namespace

std::string vtk_number(double v)
{
    if (v != v)
        return "NaN";
    if (std::isinf(v))
        return v < 0 ? "-Infinity" : "Infinity";
    if (v == 0)
        return "0";  // -0 too
    // the shortest digits that read back as v, closest to it (to_chars), as
    // [-]d[.ddd]e(+|-)x
    char sci[32];
    const std::to_chars_result r =
        std::to_chars(sci, sci + sizeof sci - 1, v, std::chars_format::scientific);
    *r.ptr = 0;
    const char *e = std::strchr(sci, 'e');
    const bool negative = sci[0] == '-';
    std::string digits;
    for (const char *p = sci + negative; p < e; p++)
        if (*p != '.')
            digits += *p;
    const int exponent = std::atoi(e + 1);  // of the first digit
    const int k = (int)digits.size(), point = exponent + 1;  // digits before the point
    std::string s = negative ? "-" : "";
    if (exponent >= -6 && exponent < 21) {
        if (point <= 0)
            s += "0." + std::string((size_t)-point, '0') + digits;
        else if (point >= k)
            s += digits + std::string((size_t)(point - k), '0');
        else
            s += digits.substr(0, (size_t)point) + "." + digits.substr((size_t)point);
    } else {
        s += digits[0];
        if (k > 1)
            s += "." + digits.substr(1);
        s += exponent < 0 ? "e-" : "e+";
        s += std::to_string(std::abs(exponent));
    }
    return s;
}

void vtk_write_htg(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
                   const char *path)
{
    // the root's 8 children as a 2x2x2 grid of trees (HyperTreeGrid filters such as
    // Contour work on a grid of trees); a root that is not split is one tree
    const oct_node_t root = tree->nodes[0];
    std::vector<HtgNode> roots;
    if (OCT_NODE_KIND(root) == OCT_INTERIOR) {
        for (uint32_t c = 0; c < 8; c++)
            roots.push_back(child_of({0, 0, 0, 0, 0}, OCT_NODE_VALUE(root), c));
        write_htg_trees(tree, tape, src, 1, std::move(roots), false, path);
    } else {
        roots.push_back({0, 0, 0, 0, 0});
        write_htg_trees(tree, tape, src, 0, std::move(roots), false, path);
    }
}

void vtk_write_htg_piece(const oct_tree_t *part, const tape_t *tape, const oct_source_t *src,
                         int depth, const uint64_t *frontier, size_t n, int top, const char *path)
{
    // without a frontier the top is the whole tree: exp_htg's grid
    const oct_node_t root = part->nodes[0];
    const int g = n ? depth : OCT_NODE_KIND(root) == OCT_INTERIOR ? 1 : 0;
    if (g < 0 || g > part->depth)
        throw Error(std::string("cannot write ") + path + ": the frontier's depth " +
                    std::to_string(depth) + " is not within the tree's");
    for (size_t i = 1; i < n; i++)
        if (frontier[i] <= frontier[i - 1])
            throw Error(std::string("cannot write ") + path +
                        ": the frontier's codes are not increasing");
    std::vector<HtgNode> cells, roots;
    nodes_at_depth(part, {0, 0, 0, 0, 0}, g, cells, path);
    for (const HtgNode &c : cells) {
        const uint64_t code = oct_morton(c.ix, c.iy, c.iz, g);
        const bool in_frontier = std::binary_search(frontier, frontier + n, code);
        const oct_node_t w = part->nodes[c.node];
        // a frontier cell is split where its subtree is held, an empty cell where it
        // is not (oct_plan_finish); the top's cells at the frontier's depth are not
        // split (without a frontier, g = 1 holds the top's cells, split or not)
        if (in_frontier ? OCT_NODE_KIND(w) == OCT_LEAF : n && OCT_NODE_KIND(w) == OCT_INTERIOR)
            throw Error(std::string("cannot write ") + path + ": the cell " +
                        std::to_string(code) + " of depth " + std::to_string(g) +
                        (in_frontier ? " is a frontier cell but a leaf"
                                     : " is split but not a frontier cell"));
        if (in_frontier ? OCT_NODE_KIND(w) == OCT_INTERIOR : top != 0)
            roots.push_back(c);
    }
    write_htg_trees(part, tape, src, g, std::move(roots), true, path);
}

}  // namespace ivexp
