// ivoct export/ — the .vtu writer: VTK's UnstructuredGrid XML written straight
// from the octree (no vtkUnstructuredGrid, no VTK writer).
//
// The file is what VTK 9.1's vtkXMLUnstructuredGridWriter writes in appended
// mode, raw (EncodeAppendedDataOff), with UInt64 headers and its LZ4
// compressor, byte for byte:
//   - no XML declaration (VTK writes one only over base64 appended data);
//   - the attributes VTK fills in once it has written the data (the piece's
//     NumberOfPoints and NumberOfCells, every array's RangeMin, RangeMax and
//     offset) stand where it reserved room for them, ` name=""` and 20 spaces,
//     overwritten from the start: the value, then the spaces left over;
//     numbers as its ostream of precision 11 writes them (printf's %.11g);
//     the cells' arrays have their ranges reserved but never filled;
//   - the ranges are vtkDataArray::GetRange(-1)'s: NaN skipped, the range of
//     the tuples' Euclidean norms for 3 components;
//   - after "_", each array's compressed data (lz4_blocks: header, blocks) in
//     the order of the elements: field data, cell data, points, connectivity,
//     offsets, types.
// What differs is only how: every array is compressed over threads, the
// connectivity is held as 32-bit indices and widened to Int64 block by block,
// the cell data, offsets and types are made block by block and never held
// whole, and each array's data go to the file as soon as they are made, the
// XML written again over its first draft once the data gave their offsets.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "internal.hpp"

namespace ivexp {
namespace {

constexpr unsigned char VTK_VOXEL_TYPE = 11;  // vtkCellType.h's VTK_VOXEL
constexpr size_t RESERVED = 20;               // vtkXMLWriter::ReserveAttributeSpace's length

// ---- the points -----------------------------------------------------------------------
// The bits set in v (no popcnt instruction assumed: the build targets x86-64).
inline uint32_t popcount(uint64_t v)
{
    v = v - ((v >> 1) & 0x5555555555555555ull);
    v = (v & 0x3333333333333333ull) + ((v >> 2) & 0x3333333333333333ull);
    v = (v + (v >> 4)) & 0x0f0f0f0f0f0f0f0full;
    return (uint32_t)((v * 0x0101010101010101ull) >> 56);
}

// The lowest bit set in v (v != 0).
inline int ctz(uint64_t v) { return __builtin_ctzll(v); }

// Leaf i's lowest corner in integer coordinates of the max depth D, and its size.
inline void leaf_anchor(const oct_tree_t *tree, size_t i, uint32_t a[3], uint32_t &size)
{
    const oct_leaf_t &l = tree->leaves[i];
    const int depth = oct_leaf_depth(&l);
    const uint64_t code = oct_leaf_code(&l);
    size = 1u << (tree->depth - depth);
    oct_unmorton(code, depth, &a[0], &a[1], &a[2]);
    for (int k = 0; k < 3; k++)
        a[k] *= size;
}

struct Corner {
    uint32_t x, y, z;
    bool operator<(const Corner &o) const
    {
        return z != o.z ? z < o.z : y != o.y ? y < o.y : x < o.x;
    }
    bool operator==(const Corner &o) const { return x == o.x && y == o.y && z == o.z; }
};

// vtkDataArray::GetRange(-1) of 3 components: the range of the tuples' norms,
// the squares summed in component order from 0 (add_norm each tuple), the
// extremes' roots taken (finish_norm).
inline void add_norm(double x, double y, double z, Range &r)
{
    double s = 0.0;
    s += x * x;
    s += y * y;
    s += z * z;
    r.add(s);
}

void finish_norm(Range &r)
{
    if (r.any)
        r.lo = std::sqrt(r.lo), r.hi = std::sqrt(r.hi);
}

// Sort k 64-bit words on their bits [lo, hi) by an LSD radix sort (stable),
// between `a` (the words) and `b` (room for k): returns which holds the result.
// The counts of each digit are taken in four interleaved histograms (h: room
// for them): runs of equal digits (a point's corners meet often) do not wait
// on one counter.
const uint64_t *radix_sort(uint64_t *a, uint64_t *b, size_t k, int lo, int hi,
                           std::vector<uint32_t> &h)
{
    constexpr int DIGIT = 11;
    constexpr size_t BINS = (size_t)1 << DIGIT;
    const uint64_t mask = BINS - 1;
    h.resize(4 * BINS);
    uint64_t *from = a, *to = b;
    for (int shift = lo; shift < hi; shift += DIGIT) {
        std::fill(h.begin(), h.end(), 0);
        uint32_t *h0 = h.data(), *h1 = h0 + BINS, *h2 = h1 + BINS, *h3 = h2 + BINS;
        size_t j = 0;
        for (; j + 4 <= k; j += 4) {
            h0[(from[j] >> shift) & mask]++;
            h1[(from[j + 1] >> shift) & mask]++;
            h2[(from[j + 2] >> shift) & mask]++;
            h3[(from[j + 3] >> shift) & mask]++;
        }
        for (; j < k; j++)
            h0[(from[j] >> shift) & mask]++;
        uint32_t sum = 0;
        for (size_t d = 0; d < BINS; d++) {
            const uint32_t v = h0[d] + h1[d] + h2[d] + h3[d];
            h0[d] = sum;
            sum += v;
        }
        for (j = 0; j < k; j++)
            to[h0[(from[j] >> shift) & mask]++] = from[j];
        std::swap(from, to);
    }
    return from;
}

// A face of a leaf (its bottom, or with TOP its top) in one 64-bit word, up to
// depth 15: the leaf's lowest corner x, y (15 bits each), log2 of its size (4
// bits), 2 i + top (30 bits: at most 2^29 leaves).
struct Face {
    static constexpr uint64_t TOP = (uint64_t)1 << 34;
    static uint64_t make(size_t i, const uint32_t a[3], uint32_t size)
    {
        return (uint64_t)(2 * i) << 34 | (uint64_t)ctz(size) << 30 | (uint64_t)a[1] << 15 | a[0];
    }
    static uint64_t x(uint64_t f) { return f & 0x7fff; }
    static uint64_t y(uint64_t f) { return f >> 15 & 0x7fff; }
    static uint64_t size(uint64_t f) { return (uint64_t)1 << (f >> 30 & 15); }
    // the first of its 4 corners in the connectivity: 8 i, or 8 i + 4 for the top
    static size_t corner(uint64_t f) { return (size_t)(f >> 34) * 4; }
};

// The rectangle of a slice's corners, from its faces.
struct Rect {
    uint64_t x0 = UINT64_MAX, x1 = 0, y0 = UINT64_MAX, y1 = 0;
    void add(uint64_t x, uint64_t y, uint64_t s)
    {
        x0 = std::min(x0, x), x1 = std::max(x1, x + s);
        y0 = std::min(y0, y), y1 = std::max(y1, y + s);
    }
};

// The points of the .vtu: the distinct leaf corners in (z, y, x) order (corner c
// of a leaf in VTK_VOXEL order: x fastest, then y, then z), and the
// connectivity: for corner c of leaf i its point, value 8 i + c.  Both are read
// a block at a time while they are compressed (coords, connectivity): neither
// the coordinates nor the 64-bit connectivity are held whole.
//
// Up to depth 15 (and 2^32 corners) each leaf is listed under the two z slices
// of its corners (its bottom and top faces, a Face each: a counting sort, each
// thread a run of leaves with its own counts); then each slice, on its own and
// so over the threads, makes its corners in cache, numbers them from 0 in (y, x)
// order (number_dense by a bitmap, or number_sorted by a radix sort) and keeps
// its distinct (y, x) keys; a corner's point is its number in its slice plus
// the points of the slices below.  Deeper, a comparison sort of all the corners.
class SharedPoints {
public:
    SharedPoints(const oct_tree_t *tree, int threads)
        : tree_(tree), D_(tree->depth), bits_(tree->depth + 1)
    {
        const size_t m = 8 * tree->n_leaves;
        if (2 * bits_ + 32 > 64 || m > UINT32_MAX)
            sort_all();
        else
            by_slices(threads);
    }
    size_t size() const { return n_points_; }
    const Range &norm_range() const { return norm_; }

    // Values [first, first + k) of the points' coordinates (x y z per point).
    void coords(size_t first, size_t k, double *out) const
    {
        if (!corners_.empty()) {
            for (size_t v = first; v < first + k; v++) {
                const Corner &c = corners_[v / 3];
                const int axis = (int)(v % 3);
                *out++ = coord(axis, axis == 0 ? c.x : axis == 1 ? c.y : c.z);
            }
            return;
        }
        if (k == 0)
            return;
        // the slice of the first point, then on up
        size_t z = (size_t)(std::upper_bound(first_point_.begin(), first_point_.end(), first / 3) -
                            first_point_.begin()) - 1;
        const uint64_t lmask = ((uint64_t)1 << bits_) - 1;
        for (size_t v = first; v < first + k; v++) {
            const size_t p = v / 3;
            while (p >= first_point_[z + 1])
                z++;
            const uint32_t key = keys_[p];
            switch (v % 3) {
            case 0: *out++ = table_[0][key & lmask]; break;
            case 1: *out++ = table_[1][key >> bits_]; break;
            default: *out++ = table_[2][z]; break;
            }
        }
    }

    // Values [first, first + k) of the connectivity.
    void connectivity(size_t first, size_t k, int64_t *out) const
    {
        if (!corners_.empty()) {
            for (size_t v = first; v < first + k; v++)
                *out++ = (int64_t)global_[v];
            return;
        }
        size_t leaf = (size_t)-1;
        size_t below[2] = {0, 0};  // the points of the slices under the leaf's faces
        for (size_t v = first; v < first + k; v++) {
            if (v / 8 != leaf) {
                leaf = v / 8;
                uint32_t a[3], s;
                leaf_anchor(tree_, leaf, a, s);
                below[0] = first_point_[a[2]];
                below[1] = first_point_[(size_t)a[2] + s];
            }
            *out++ = (int64_t)(local_[v] + below[v >> 2 & 1]);
        }
    }

private:
    double coord(int axis, uint64_t i) const
    {
        return oct_coord(tree_->box[2 * axis], tree_->box[2 * axis + 1], i, D_);
    }

    void sort_all()
    {
        const size_t n = tree_->n_leaves, m = 8 * n;
        std::vector<Corner> corners(m);
        for (size_t i = 0; i < n; i++) {
            uint32_t a[3], s;
            leaf_anchor(tree_, i, a, s);
            for (uint32_t c = 0; c < 8; c++)
                corners[8 * i + c] = {a[0] + (c & 1) * s, a[1] + (c >> 1 & 1) * s,
                                      a[2] + (c >> 2 & 1) * s};
        }
        corners_ = corners;
        std::sort(corners_.begin(), corners_.end());
        corners_.erase(std::unique(corners_.begin(), corners_.end()), corners_.end());
        global_.resize(m);
        for (size_t k = 0; k < m; k++)
            global_[k] = (uint64_t)(std::lower_bound(corners_.begin(), corners_.end(), corners[k]) -
                                    corners_.begin());
        n_points_ = corners_.size();
        for (const Corner &c : corners_) {
            const double x = coord(0, c.x), y = coord(1, c.y), z = coord(2, c.z);
            add_norm(x, y, z, norm_);
        }
        finish_norm(norm_);
    }

    // A slice's corners e[0..k) (key << 32 | place), numbered in key order: ids[place],
    // the distinct keys appended to keys (their norms to norm).  By a radix sort
    // (tmp: room for k words).
    void number_sorted(uint64_t *e, uint64_t *tmp, size_t k, size_t z, std::vector<uint32_t> &ids,
                       std::vector<uint32_t> &histograms, std::vector<uint32_t> &keys,
                       Range &norm) const
    {
        const uint64_t *sorted = radix_sort(e, tmp, k, 32, 32 + 2 * bits_, histograms);
        uint32_t id = 0;
        for (size_t j = 0; j < k; j++) {
            const uint64_t key = sorted[j] >> 32;
            if (j == 0 || key != sorted[j - 1] >> 32) {
                id += j > 0;
                new_point((uint32_t)key, z, keys, norm);
            }
            ids[(uint32_t)sorted[j]] = id;
        }
    }

    // The same by a bitmap of the slice's (y, x) over the rectangle its corners
    // span, a bit set for each corner, the points numbered by counting the bits
    // before theirs: the corners are not moved at all.  Done only where the
    // rectangle's words are fewer than the corners (a dense slice: the common
    // case up to depth 10 or so); else false.
    struct Dense {
        std::vector<uint64_t> bits;
        std::vector<uint32_t> before;  // the bits set in the words before each
    };
    bool number_dense(const uint64_t *e, size_t k, const Rect &rect, size_t z,
                      std::vector<uint32_t> &ids, Dense &d, std::vector<uint32_t> &keys,
                      Range &norm) const
    {
        const uint64_t lmask = ((uint64_t)1 << bits_) - 1;
        const uint64_t x0 = rect.x0, x1 = rect.x1, y0 = rect.y0, y1 = rect.y1;
        const uint64_t w0 = x0 >> 6, row = (x1 >> 6) - w0 + 1, words = (y1 - y0 + 1) * row;
        if (words > k)
            return false;
        d.bits.assign(words, 0);
        d.before.resize(words);
        auto word_of = [&](uint64_t x, uint64_t y) { return (y - y0) * row + (x >> 6) - w0; };
        for (size_t j = 0; j < k; j++) {
            const uint64_t x = e[j] >> 32 & lmask, y = e[j] >> (32 + bits_);
            d.bits[word_of(x, y)] |= (uint64_t)1 << (x & 63);
        }
        uint32_t sum = 0;
        for (uint64_t y = y0, w = 0; y <= y1; y++)
            for (uint64_t c = w0; c < w0 + row; c++, w++) {
                d.before[w] = sum;
                uint64_t b = d.bits[w];
                sum += popcount(b);
                for (; b; b &= b - 1)  // the word's points, x up
                    new_point((uint32_t)(y << bits_ | (c << 6 | (uint64_t)ctz(b))), z, keys, norm);
            }
        for (size_t j = 0; j < k; j++) {
            const uint64_t x = e[j] >> 32 & lmask, y = e[j] >> (32 + bits_);
            const uint64_t w = word_of(x, y);
            ids[(uint32_t)e[j]] =
                d.before[w] + popcount(d.bits[w] & (((uint64_t)1 << (x & 63)) - 1));
        }
        return true;
    }

    void new_point(uint32_t key, size_t z, std::vector<uint32_t> &keys, Range &norm) const
    {
        const uint64_t lmask = ((uint64_t)1 << bits_) - 1;
        keys.push_back(key);
        add_norm(table_[0][key & lmask], table_[1][key >> bits_], table_[2][z], norm);
    }

    void by_slices(int threads)
    {
        const size_t n = tree_->n_leaves;
        const int bits = bits_;
        const size_t n_slices = ((size_t)1 << D_) + 1;
        for (int axis = 0; axis < 3; axis++) {
            table_[axis].resize(n_slices);
            for (size_t i = 0; i < n_slices; i++)
                table_[axis][i] = coord(axis, i);
        }
        // each leaf under its faces' slices, a face a word (Face): the leaf and which
        // face, and what its corners need, so that the slices do not go back to the
        // leaves
        const size_t runs = (size_t)std::max(1, std::min(threads, (int)std::min(n / 4096 + 1, (size_t)64)));
        auto run_start = [n, runs](size_t r) { return n / runs * r + std::min(r, n % runs); };
        std::vector<std::vector<size_t>> at(runs, std::vector<size_t>(n_slices, 0));
        parallel_chunks(runs, 1, (int)runs, [&](size_t r, size_t, int) {
            for (size_t i = run_start(r); i < run_start(r + 1); i++) {
                uint32_t a[3], s;
                leaf_anchor(tree_, i, a, s);
                at[r][a[2]]++;
                at[r][(size_t)a[2] + s]++;
            }
        });
        std::vector<size_t> start(n_slices + 1, 0);
        for (size_t z = 0, sum = 0; z < n_slices; z++) {
            start[z] = sum;
            for (size_t r = 0; r < runs; r++) {
                const size_t c = at[r][z];
                at[r][z] = sum;
                sum += c;
            }
            start[z + 1] = sum;
        }
        HugeArray<uint64_t> faces = huge_array<uint64_t>(2 * n);
        parallel_chunks(runs, 1, (int)runs, [&](size_t r, size_t, int) {
            for (size_t i = run_start(r); i < run_start(r + 1); i++) {
                uint32_t a[3], s;
                leaf_anchor(tree_, i, a, s);
                const uint64_t f = Face::make(i, a, s);
                faces[at[r][a[2]]++] = f;
                faces[at[r][(size_t)a[2] + s]++] = f | Face::TOP;
            }
        });
        std::vector<std::vector<size_t>>().swap(at);

        // each slice: its corners sorted and numbered, its distinct keys kept
        local_ = huge_array<uint32_t>(8 * n);
        const size_t chunk = (n_slices + 64 * (size_t)threads - 1) / (64 * (size_t)threads);
        const size_t n_chunks = (n_slices + chunk - 1) / chunk;
        std::vector<std::vector<uint32_t>> chunk_keys(n_chunks);
        std::vector<Range> chunk_norm(n_chunks);
        first_point_.assign(n_slices + 1, 0);
        parallel_chunks(n_slices, chunk, threads, [&](size_t z0, size_t z1, int) {
            std::vector<uint64_t> e, tmp;
            std::vector<uint32_t> ids, histograms;
            Dense dense;
            std::vector<uint32_t> &keys = chunk_keys[z0 / chunk];
            Range &norm = chunk_norm[z0 / chunk];
            size_t kept = keys.size();
            for (size_t z = z0; z < z1; z++) {
                // the corners of the slice's faces, in the faces' order: key << 32 | place;
                // the rectangle they span
                const uint64_t *face = faces.get() + start[z];
                const size_t nf = start[z + 1] - start[z], k = 4 * nf;
                if (nf == 0)
                    continue;
                e.resize(k);
                tmp.resize(k);
                ids.resize(k);
                Rect rect;
                for (size_t q = 0; q < nf; q++) {
                    const uint64_t f = face[q], x = Face::x(f), y = Face::y(f), s = Face::size(f);
                    rect.add(x, y, s);
                    for (uint32_t c = 0; c < 4; c++)  // the face's corners: x, then y
                        e[4 * q + c] = ((y + (c >> 1) * s) << bits | (x + (c & 1) * s)) << 32 |
                                       (4 * q + c);
                }
                if (!number_dense(e.data(), k, rect, z, ids, dense, keys, norm))
                    number_sorted(e.data(), tmp.data(), k, z, ids, histograms, keys, norm);
                first_point_[z + 1] = keys.size() - kept;
                kept = keys.size();
                // a face's 4 corners are 4 consecutive corners of its leaf: the writes
                // go up through local_ in the faces' (the leaves') order
                for (size_t q = 0; q < nf; q++)
                    std::memcpy(&local_[Face::corner(face[q])], &ids[4 * q], 4 * sizeof(uint32_t));
            }
        });
        faces.reset();
        for (size_t z = 0; z < n_slices; z++)
            first_point_[z + 1] += first_point_[z];
        n_points_ = first_point_[n_slices];
        keys_ = huge_array<uint32_t>(n_points_);
        for (size_t c = 0; c < n_chunks; c++) {
            std::copy(chunk_keys[c].begin(), chunk_keys[c].end(), keys_.get() + first_point_[c * chunk]);
            norm_.add(chunk_norm[c]);
        }
        finish_norm(norm_);
    }

    const oct_tree_t *tree_;
    int D_, bits_;
    size_t n_points_ = 0;
    Range norm_;
    // by slices: the bounds of depth D per axis, each slice's first point (and the
    // total last), the points' (y, x) keys, each corner's number in its slice
    std::vector<double> table_[3];
    std::vector<size_t> first_point_;
    HugeArray<uint32_t> keys_, local_;
    // sorted whole: the points, each corner's point
    std::vector<Corner> corners_;
    std::vector<uint64_t> global_;
};

// ---- the arrays -----------------------------------------------------------------------
// A double as vtkXMLWriter's stream writes it (precision 11, classic locale).
std::string num11(double v)
{
    char b[40];
    std::snprintf(b, sizeof b, "%.11g", v);
    return b;
}

// An attribute VTK reserved room for and filled in later.
std::string reserved(const char *name, const std::string &value)
{
    std::string s = std::string(" ") + name + "=\"" + value + "\"";
    const size_t room = std::strlen(name) + 4 + RESERVED;
    if (s.size() < room)
        s.append(room - s.size(), ' ');
    return s;
}

// One array of the file: its element, and how its compressed data are made.
struct Array {
    enum Ranges { NONE, EMPTY, FILLED };  // strings; the cells' arrays; data arrays
    std::string attributes;  // from type to format="appended"
    Ranges ranges;
    Range range;
    // the compressed data, written to the end of `stream` as they are made
    // (lz4_stream) or, without one, held (lz4_blocks); sets range where the
    // blocks give it
    std::function<Lz4Blocks(Array &, Output *stream)> make;
    uint64_t offset = 0;  // of the data in the appended data, once made
};

std::string attributes(const char *type, const std::string &name, int components, size_t tuples)
{
    std::string a = std::string(" type=\"") + type + "\" Name=\"" + name + "\"";
    if (components > 1)
        a += " NumberOfComponents=\"" + std::to_string(components) + "\"";
    if (tuples)
        a += " NumberOfTuples=\"" + std::to_string(tuples) + "\"";
    return a + " format=\"appended\"";
}

// An array of n bytes held at data (alive until it is made), on one thread.
Array held_array(std::string attributes, Array::Ranges ranges, Range range, const void *data,
                 size_t n, const char *path)
{
    return {std::move(attributes), ranges, range,
            [data, n, path](Array &, Output *stream) {
                return stream ? lz4_stream(*stream, data, n, 1) : lz4_blocks(data, n, 1, path);
            }};
}

// An array of `count` values of T made and compressed block by block:
// fill(first, k, out) writes values [first, first + k) to out.  With `ranges`
// FILLED, its range (one component) gathered from the blocks'.
template <class T, class F>
Array made_array(const char *type, const char *name, int components, size_t count,
                 Array::Ranges ranges, int threads, const char *path, F fill)
{
    auto make = [count, ranges, threads, path, fill](Array &a, Output *stream) {
        const size_t nblocks = (count * sizeof(T) + LZ4_BLOCK - 1) / LZ4_BLOCK;
        std::vector<Range> block_range(ranges == Array::FILLED ? nblocks : 0);
        const BlockBytes block = [&](size_t at, size_t bytes, unsigned char *scratch,
                                     int) -> const void * {
            T *out = reinterpret_cast<T *>(scratch);
            const size_t k = bytes / sizeof(T);
            fill(at / sizeof(T), k, out);
            if (!block_range.empty())
                block_range[at / LZ4_BLOCK] = range_of(out, k);
            return scratch;
        };
        const size_t n = count * sizeof(T);
        Lz4Blocks z = stream ? lz4_stream(*stream, n, threads, block)
                             : lz4_blocks(n, threads, block, path);
        if (ranges == Array::FILLED) {
            a.range = Range();
            for (const Range &r : block_range)
                a.range.add(r);
        }
        return z;
    };
    return {attributes(type, name, components, 0), ranges, {}, make};
}

// The fill of made_array for value(i), the i-th value.
template <class T, class V> auto each(V value)
{
    return [value](size_t first, size_t k, T *out) {
        for (size_t j = 0; j < k; j++)
            out[j] = value(first + j);
    };
}

// The element of one array.
void element(std::string &t, int indent, const Array &a)
{
    t.append((size_t)indent, ' ');
    t += a.ranges == Array::NONE ? "<Array" : "<DataArray";
    t += a.attributes;
    if (a.ranges != Array::NONE) {
        const bool filled = a.ranges == Array::FILLED;
        t += reserved("RangeMin", filled ? num11(a.range.lo) : "");
        t += reserved("RangeMax", filled ? num11(a.range.hi) : "");
    }
    t += reserved("offset", std::to_string(a.offset));
    t += "/>\n";
}

}  // namespace

// ---- .vtu -----------------------------------------------------------------------------
void vtk_write_vtu(const oct_tree_t *tree, const oct_source_t *src, const char *path)
{
    const size_t n = tree->n_leaves;
    const int threads = writer_threads(tree, (size_t)-1);
    std::vector<Array> field, cell, cells;

    // field data: the source's strings (each with its terminating 0), box, depth
    const std::vector<MetaItem> meta = meta_strings(src);
    for (const MetaItem &m : meta)
        field.push_back(held_array(attributes("String", m.key, 1, 1), Array::NONE, {},
                                   m.value.c_str(), m.value.size() + 1, path));
    field.push_back(held_array(attributes("Float64", "box", 1, 6), Array::FILLED,
                               range_of(tree->box, 6), tree->box, 6 * sizeof(double), path));
    const int32_t depth = tree->depth;
    field.push_back(held_array(attributes("Int32", "depth", 1, 1), Array::FILLED,
                               range_of(&depth, 1), &depth, sizeof depth, path));

    // cell data, in the order the VTK writer had them added
    const oct_leaf_t *leaves = tree->leaves;
    const auto F = Array::FILLED;
    cell.push_back(made_array<int32_t>("Int32", "depth", 1, n, F, threads, path,
                                       each<int32_t>([leaves](size_t i) {
                                           return (int32_t)oct_leaf_depth(&leaves[i]);
                                       })));
    cell.push_back(made_array<double>("Float64", "f_lo", 1, n, F, threads, path,
                                      each<double>([leaves](size_t i) {
                                          return (double)leaves[i].f_lo;
                                      })));
    cell.push_back(made_array<double>("Float64", "f_hi", 1, n, F, threads, path,
                                      each<double>([leaves](size_t i) {
                                          return (double)leaves[i].f_hi;
                                      })));
    cell.push_back(made_array<double>("Float64", "error_bound", 1, n, F, threads, path,
                                      each<double>([tree](size_t i) {
                                          return oct_leaf_error_bound(tree, (uint32_t)i);
                                      })));
    if (tree->certain) {
        // 1 where the leaf surely holds surface (oct_certify)
        const uint8_t *certain = tree->certain;
        cell.push_back(made_array<uint8_t>("UInt8", "certain", 1, n, F, threads, path,
                                           each<uint8_t>([certain](size_t i) {
                                               return (uint8_t)(certain[i] != 0);
                                           })));
    }
    if (tree->slabs) {
        // the range of 3 components is of the tuples, not of a block's values
        const oct_slab_t *slabs = tree->slabs;
        Array a = made_array<double>("Float64", "normal", 3, 3 * n, Array::NONE, threads, path,
                                     each<double>([slabs](size_t k) { return slabs[k / 3].n[k % 3]; }));
        a.ranges = F;
        for (size_t i = 0; i < n; i++)
            add_norm(slabs[i].n[0], slabs[i].n[1], slabs[i].n[2], a.range);
        finish_norm(a.range);
        cell.push_back(std::move(a));
    }

    // the points: the leaves' corners shared between neighbours, in (z, y, x) order
    const SharedPoints sp(tree, threads);
    Array points = made_array<double>("Float64", "Points", 3, 3 * sp.size(), Array::NONE, threads,
                                      path, [&sp](size_t first, size_t k, double *out) {
                                          sp.coords(first, k, out);
                                      });
    points.ranges = F;
    points.range = sp.norm_range();
    cells.push_back(made_array<int64_t>("Int64", "connectivity", 1, 8 * n, Array::EMPTY, threads,
                                        path, [&sp](size_t first, size_t k, int64_t *out) {
                                            sp.connectivity(first, k, out);
                                        }));
    // offsets: where each cell's points end; types: all voxels
    cells.push_back(made_array<int64_t>("Int64", "offsets", 1, n, Array::EMPTY, threads, path,
                                        each<int64_t>([](size_t i) { return (int64_t)(8 * (i + 1)); })));
    cells.push_back(made_array<uint8_t>("UInt8", "types", 1, n, Array::EMPTY, threads, path,
                                        each<uint8_t>([](size_t) { return VTK_VOXEL_TYPE; })));

    // in the order of the data
    std::vector<Array *> order;
    for (std::vector<Array> *v : {&field, &cell})
        for (Array &a : *v)
            order.push_back(&a);
    order.push_back(&points);
    for (Array &a : cells)
        order.push_back(&a);

    // the XML: what VTK fills in later stands in room of a fixed size
    auto xml = [&]() {
        std::string t = "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"";
        t += VTK_BYTE_ORDER;
        t += "\" header_type=\"UInt64\" compressor=\"vtkLZ4DataCompressor\">\n"
             "  <UnstructuredGrid>\n    <FieldData>\n";
        for (const Array &a : field)
            element(t, 6, a);
        t += "    </FieldData>\n    <Piece";
        t += reserved("NumberOfPoints", std::to_string(sp.size()));
        t += reserved("NumberOfCells", std::to_string(n));
        t += ">\n      <PointData>\n      </PointData>\n      <CellData Scalars=\"depth\">\n";
        for (const Array &a : cell)
            element(t, 8, a);
        t += "      </CellData>\n      <Points>\n";
        element(t, 8, points);
        t += "      </Points>\n      <Cells>\n";
        for (const Array &a : cells)
            element(t, 8, a);
        t += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n"
             "  <AppendedData encoding=\"raw\">\n   _";
        return t;
    };

    // Into a file, each array's data written as they are made (lz4_stream: its
    // header rewritten once its blocks are), and the XML written again over its
    // first draft once the data have given their offsets and ranges: its length
    // does not change (the values fit the room VTK reserves for them).  Into a
    // device or a pipe, which cannot be rewritten, the data are held until the
    // XML is known.
    Output out(path);
    const bool in_place = !out.seekable();
    std::string draft;
    if (!in_place) {
        draft = xml();
        out.write(draft.data(), draft.size());
    }
    std::vector<Lz4Blocks> held;
    uint64_t offset = 0;
    for (Array *a : order) {
        Lz4Blocks z = a->make(*a, in_place ? nullptr : &out);
        a->offset = offset;
        offset += z.bytes();
        if (in_place)
            held.push_back(std::move(z));
    }
    static const char end[] = "\n  </AppendedData>\n</VTKFile>\n";
    const std::string t = xml();
    if (in_place) {
        out.write(t.data(), t.size());
        for (const Lz4Blocks &z : held) {
            out.write(z.header.data(), z.header_bytes());
            z.each([&out](const char *p, size_t k) { out.write(p, k); });
        }
        out.write(end, sizeof end - 1);
    } else {
        if (t.size() != draft.size())
            throw Error(std::string("cannot write ") + path + ": the XML header changed length");
        out.write(end, sizeof end - 1);
        out.write_at(0, t.data(), t.size());
    }
    out.commit();
}

}  // namespace ivexp
