// ivoct export/ — the cell list (`ivoct build --cells F.csv`): one row per
// surface leaf in Morton order.  Includes neither VTK nor OpenVDB.
//
// Numbers are written by fmt_g17 (fmt/fmt.h): byte for byte printf's %.17g,
// without its cost per value (ivoct_bench_fmt: glibc's snprintf ~0.2 us,
// std::to_chars with precision 17 ~60-70 ns, fmt_g17 ~27-30 ns).
// The bounds of the leaves are one of 2^D + 1 values per axis (oct_coord gives
// the same double for the same fraction at any depth), formatted once each.
//
// Leaves are formatted in blocks, by several threads, into buffers of a size
// known in advance (a row has at most ROW_MAX characters), and the blocks are
// written in order with one fwrite each.
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <mutex>
#include <thread>

#include "../fmt/fmt.h"
#include "internal.hpp"

namespace ivexp {
namespace {

const char HEADER[] = "x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound";
// appended when the tree has its certain leaves (oct_certify)
const char HEADER_CERTAIN[] = ",certain,wx0,wy0,wz0,wx1,wy1,wz1";

// a number's room: fmt_g17 writes at most FMT_G17_MAX characters, and
// scratch up to FMT_G17_ROOM
constexpr size_t NUM_MAX = FMT_G17_ROOM;
// 14 numbers, a depth of 2 digits, 14 commas and the newline
constexpr size_t ROW_MAX = 14 * NUM_MAX + 2 + 15;
// the certain columns: a flag, 6 numbers and 7 commas
constexpr size_t ROW_CERTAIN = 6 * NUM_MAX + 1 + 7;

inline size_t row_max(const oct_tree_t *t)
{
    return t->certain ? ROW_MAX + ROW_CERTAIN : ROW_MAX;
}
// leaves per block: ~1 MB of text per write, 2.4 MB of buffer per slot
constexpr size_t BLOCK = 4096;
// tables of the bounds up to this depth (3 x 2^16 numbers: ~10 ms)
constexpr int TABLE_DEPTH = 16;

inline char *put_double(char *p, double x) { return fmt_g17(p, x); }

inline char *put_int(char *p, int v)
{
    return std::to_chars(p, p + NUM_MAX, v).ptr;
}

// The formatted bounds of one axis at the max depth D: entry j is
// oct_coord(lo, hi, j, D) followed by a comma.
struct AxisTable {
    std::vector<char> text;
    std::vector<uint32_t> at;  // at[j] .. at[j + 1]: entry j

    AxisTable(double lo, double hi, int D)
    {
        const size_t n = ((size_t)1 << D) + 1;
        text.resize(n * (NUM_MAX + 1));
        at.resize(n + 1);
        char *p = text.data();
        for (size_t j = 0; j < n; j++) {
            at[j] = (uint32_t)(p - text.data());
            p = put_double(p, oct_coord(lo, hi, j, D));
            *p++ = ',';
        }
        at[n] = (uint32_t)(p - text.data());
    }
    char *put(char *p, size_t j) const
    {
        size_t n = at[j + 1] - at[j];
        std::memcpy(p, text.data() + at[j], n);
        return p + n;
    }
};

struct Formatter {
    const oct_tree_t *t;
    std::vector<AxisTable> axes;  // empty above TABLE_DEPTH

    // a table when it is cheaper than formatting 6 numbers a leaf
    static bool tabled(const oct_tree_t *t)
    {
        return t->depth <= TABLE_DEPTH && ((size_t)1 << t->depth) + 1 <= 2 * (size_t)t->n_leaves;
    }

    explicit Formatter(const oct_tree_t *tree) : t(tree)
    {
        if (tabled(t))
            for (int a = 0; a < 3; a++)
                axes.emplace_back(t->box[2 * a], t->box[2 * a + 1], t->depth);
    }

    // ",certain,wx0,wy0,wz0,wx1,wy1,wz1" of leaf i: 1 and the witness points
    // (the second empty for a zero), or 0 and six empty fields
    char *certain_columns(char *p, uint32_t i) const
    {
        const oct_witness_t w = oct_witness_decode(t->certain[i]);
        if (w.kind == OCT_WITNESS_NONE) {
            std::memcpy(p, ",0,,,,,,", 8);
            return p + 8;
        }
        std::memcpy(p, ",1", 2);
        p += 2;
        const iv_box_t b = oct_leaf_box(t, &t->leaves[i]);
        for (int k : {w.k0, w.k1}) {
            double q[3];
            if (k >= 0)
                oct_leaf_sample(&b, k, q);
            for (int a = 0; a < 3; a++) {
                *p++ = ',';
                if (k >= 0)
                    p = put_double(p, q[a]);
            }
        }
        return p;
    }

    // rows [first, last) into p (room for row_max a row); returns the end
    char *rows(char *p, uint32_t first, uint32_t last) const
    {
        const int D = t->depth;
        for (uint32_t i = first; i < last; i++) {
            const oct_leaf_t &l = t->leaves[i];
            const int depth = oct_leaf_depth(&l);
            uint32_t ix, iy, iz;
            oct_unmorton(oct_leaf_code(&l), depth, &ix, &iy, &iz);
            if (!axes.empty()) {
                const int s = D - depth;
                p = axes[0].put(p, (size_t)ix << s);
                p = axes[0].put(p, ((size_t)ix + 1) << s);
                p = axes[1].put(p, (size_t)iy << s);
                p = axes[1].put(p, ((size_t)iy + 1) << s);
                p = axes[2].put(p, (size_t)iz << s);
                p = axes[2].put(p, ((size_t)iz + 1) << s);
            } else {
                iv_box_t b = oct_cell_box(t->box, depth, ix, iy, iz);
                const double v[6] = {b.x.lo, b.x.hi, b.y.lo, b.y.hi, b.z.lo, b.z.hi};
                for (double x : v) {
                    p = put_double(p, x);
                    *p++ = ',';
                }
            }
            p = put_int(p, depth);
            *p++ = ',';
            p = put_double(p, l.f_lo);
            *p++ = ',';
            p = put_double(p, l.f_hi);
            *p++ = ',';
            if (oct_leaf_has_slab(t, i)) {
                const oct_slab_t &sl = t->slabs[i];
                const double v[5] = {sl.n[0], sl.n[1], sl.n[2], sl.d_lo, sl.d_hi};
                for (double x : v) {
                    p = put_double(p, x);
                    *p++ = ',';
                }
            } else {
                std::memcpy(p, ",,,,,", 5);
                p += 5;
            }
            p = put_double(p, oct_leaf_error_bound(t, i));
            if (t->certain)
                p = certain_columns(p, i);
            *p++ = '\n';
        }
        return p;
    }
};

int thread_count(int threads, size_t blocks)
{
    if (threads <= 0)
        threads = (int)std::max(1u, std::thread::hardware_concurrency());
    return (int)std::min<size_t>((size_t)threads, blocks);
}

// slots of the ring: two per worker, no more than there are blocks
size_t ring_slots(size_t n_blocks, int workers)
{
    return std::max<size_t>(1, std::min<size_t>(2 * (size_t)workers, n_blocks));
}

// Blocks formatted by `workers` threads into a ring of slots and written in
// order by the calling thread.  A worker formats block b into slot b % ring
// once block b - ring has been written.
class Pipeline {
public:
    Pipeline(const Formatter &fmt, Output &out, size_t n_blocks, int workers)
        : fmt_(fmt), out_(out), n_blocks_(n_blocks), ring_(ring_slots(n_blocks, workers)),
          slots_(ring_), ready_(ring_, SIZE_MAX), length_(ring_, 0)
    {
        for (auto &s : slots_)
            s.resize(BLOCK * row_max(fmt.t));
        for (int w = 0; w < workers; w++)
            threads_.emplace_back([this] { work(); });
    }
    ~Pipeline()
    {
        stop();
        for (auto &th : threads_)
            th.join();
    }
    Pipeline(const Pipeline &) = delete;
    Pipeline &operator=(const Pipeline &) = delete;

    void run()
    {
        try {
            for (size_t b = 0; b < n_blocks_; b++) {
                size_t slot = b % ring_, n;
                {
                    std::unique_lock<std::mutex> lk(m_);
                    cv_.wait(lk, [&] { return ready_[slot] == b || failure_; });
                    if (failure_)
                        std::rethrow_exception(failure_);
                    n = length_[slot];
                }
                out_.write(slots_[slot].data(), n);  // outside the lock
                {
                    std::lock_guard<std::mutex> lk(m_);
                    written_ = b + 1;
                }
                cv_.notify_all();
            }
        } catch (...) {
            stop();
            throw;
        }
    }

private:
    void stop()
    {
        {
            std::lock_guard<std::mutex> lk(m_);
            stopped_ = true;
        }
        cv_.notify_all();
    }

    void work()
    {
        for (;;) {
            size_t b = next_.fetch_add(1);
            if (b >= n_blocks_)
                return;
            size_t slot = b % ring_;
            {
                std::unique_lock<std::mutex> lk(m_);
                cv_.wait(lk, [&] { return written_ + ring_ > b || stopped_; });
                if (stopped_)
                    return;
            }
            try {
                uint32_t first = (uint32_t)(b * BLOCK);
                uint32_t last = (uint32_t)std::min<size_t>((size_t)first + BLOCK, fmt_.t->n_leaves);
                char *end = fmt_.rows(slots_[slot].data(), first, last);
                std::lock_guard<std::mutex> lk(m_);
                length_[slot] = (size_t)(end - slots_[slot].data());
                ready_[slot] = b;
            } catch (...) {
                std::lock_guard<std::mutex> lk(m_);
                if (!failure_)
                    failure_ = std::current_exception();
            }
            cv_.notify_all();
        }
    }

    const Formatter &fmt_;
    Output &out_;
    const size_t n_blocks_, ring_;
    std::vector<std::vector<char>> slots_;
    std::vector<size_t> ready_;   // the block each slot holds, once formatted
    std::vector<size_t> length_;  // its length in bytes
    std::atomic<size_t> next_{0};
    size_t written_ = 0;
    bool stopped_ = false;
    std::exception_ptr failure_;
    std::mutex m_;
    std::condition_variable cv_;
    std::vector<std::thread> threads_;
};

}  // namespace

size_t cells_memory(const oct_tree_t *tree, int threads)
{
    const size_t n = tree->n_leaves, n_blocks = (n + BLOCK - 1) / BLOCK;
    const int workers = thread_count(threads, n_blocks);
    const size_t entries = ((size_t)1 << std::min(tree->depth, TABLE_DEPTH)) + 1;
    size_t tables = Formatter::tabled(tree) ? 3 * (entries * (NUM_MAX + 1) + (entries + 1) * 4) : 0;
    if (workers <= 1)
        return tables + std::min<size_t>(n, BLOCK) * row_max(tree);
    return tables + ring_slots(n_blocks, workers) * BLOCK * row_max(tree);
}

void write_cells(const oct_tree_t *tree, const char *path, int threads)
{
    Output out(path);
    out.write(HEADER, sizeof HEADER - 1);
    if (tree->certain)
        out.write(HEADER_CERTAIN, sizeof HEADER_CERTAIN - 1);
    out.write("\n", 1);
    const size_t n = tree->n_leaves, n_blocks = (n + BLOCK - 1) / BLOCK;
    Formatter fmt(tree);
    const int workers = thread_count(threads, n_blocks);
    if (workers <= 1) {
        std::vector<char> buf(std::min<size_t>(n, BLOCK) * row_max(tree));
        for (size_t first = 0; first < n; first += BLOCK) {
            size_t last = std::min(n, first + BLOCK);
            char *end = fmt.rows(buf.data(), (uint32_t)first, (uint32_t)last);
            out.write(buf.data(), (size_t)(end - buf.data()));
        }
    } else {
        Pipeline(fmt, out, n_blocks, workers).run();
    }
    out.commit();
}

}  // namespace ivexp
