// ivoct export/ — what the translation units share (internal to export/).
//
// vtk.cpp holds everything that includes VTK, vdb.cpp everything
// that includes OpenVDB (slow to compile: one file); each library's files are a
// module of their own, loaded on first use (module.h).  The other files need
// neither.  They meet here through plain types.
#ifndef IVOCT_EXPORT_INTERNAL_HPP
#define IVOCT_EXPORT_INTERNAL_HPP

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "export.h"
#include "io/io.h"
#include "mem/mem.h"

namespace ivexp {

// A failure with its message: thrown inside export/, caught at the C boundary.
struct Error : std::runtime_error {
    explicit Error(const std::string &m) : std::runtime_error(m) {}
};

// Run body; turn any exception into err and -1.  Every exp_* function is one
// call of this, so no exception crosses into C.
template <class F> int guard(ivoct_error_t *err, F &&body) noexcept
{
    try {
        body();
        return 0;
    } catch (const std::bad_alloc &) {
        ivoct_error_set(err, "out of memory");
    } catch (const std::exception &e) {
        ivoct_error_set(err, "%s", e.what());
    } catch (...) {
        ivoct_error_set(err, "unexpected error");
    }
    return -1;
}

// ---- large arrays on huge pages (mem/mem.h) ------------------------------------------
// The writers fill hundreds of megabytes of fresh memory (sort keys, cell values,
// compressed and encoded arrays); in 4 KiB pages every page is a fault (~5 us each
// on a 2-vCPU virtual machine, most of a writer's time there).  Large arrays come
// from mem_huge_alloc instead: whole 2 MiB pages, asked for before they are touched.
struct FreeMemory {
    void operator()(void *p) const noexcept { std::free(p); }
};
template <class T> using HugeArray = std::unique_ptr<T[], FreeMemory>;

// std::vector's allocator over mem_huge_alloc (HugeVector<T>); bad_alloc when out of
// memory.
template <class T> struct HugeAllocator {
    using value_type = T;
    HugeAllocator() = default;
    template <class U> HugeAllocator(const HugeAllocator<U> &) noexcept {}
    T *allocate(size_t n)
    {
        if (n > SIZE_MAX / sizeof(T))
            throw std::bad_alloc();
        void *p = mem_huge_alloc(n * sizeof(T));
        if (!p)
            throw std::bad_alloc();
        return static_cast<T *>(p);
    }
    void deallocate(T *p, size_t) noexcept { std::free(p); }
};
template <class T, class U> bool operator==(const HugeAllocator<T> &, const HugeAllocator<U> &)
{
    return true;
}
template <class T, class U> bool operator!=(const HugeAllocator<T> &, const HugeAllocator<U> &)
{
    return false;
}
template <class T> using HugeVector = std::vector<T, HugeAllocator<T>>;

// n elements of T, not initialised (as new T[n] for these types).
template <class T> HugeArray<T> huge_array(size_t n)
{
    static_assert(std::is_trivially_copyable<T>::value && std::is_trivially_destructible<T>::value,
                  "huge_array holds plain data");
    return HugeArray<T>(HugeAllocator<T>().allocate(n ? n : 1));
}

// An output file opened with io_open; aborted (temporary removed) unless
// committed.
class Output {
public:
    explicit Output(const char *path);
    ~Output();
    Output(const Output &) = delete;
    Output &operator=(const Output &) = delete;
    FILE *file() { return f_.f; }
    const char *path() const { return path_.c_str(); }
    void write(const void *data, size_t n);
    // The bytes write() has written so far: the end of the file for a writer
    // that writes through write() only (write_at checks against it).
    uint64_t size() const { return size_; }
    // A temporary file, which write_at may rewrite (not a device or a pipe,
    // written in place).
    bool seekable() const { return f_.tmp != nullptr; }
    // data[0, n) over the bytes at offset written already; later writes go on
    // at the end.
    void write_at(uint64_t offset, const void *data, size_t n);
    void commit();  // throws Error naming the path and the reason
private:
    io_file_t f_;
    bool open_ = false;
    std::string path_;
    uint64_t size_ = 0;
};

// A triangle mesh in world coordinates, triangles facing outwards.
struct Mesh {
    std::vector<double> points;    // x y z per vertex
    std::vector<uint32_t> tris;    // 3 vertex indices per triangle
    std::vector<int> tri_depth;    // empty, or per triangle the depth of its cell (.vtp cell data)
    bool doubles = false;          // write the points as doubles (else as floats: exact for
                                   // OpenVDB's float points)
};

// The key=value pairs of the metadata, in a fixed order.
struct MetaItem {
    std::string key, value;
};
std::vector<MetaItem> meta_strings(const oct_source_t *src);

// cells.cpp
void write_cells(const oct_tree_t *tree, const char *path, int threads);
size_t cells_memory(const oct_tree_t *tree, int threads);

// vdb.cpp, in the OpenVDB module (module.h), reached through module_load.cpp;
// vdb_load opens the module now (before a fork: `ivoct info` reads in a child),
// or throws Error("cannot read PATH: why").
void vdb_load(const char *path);
void vdb_write(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
               const char *path);
Mesh vdb_mesh(const oct_tree_t *tree, const tape_t *tape);
void vdb_info(const char *path, FILE *out);

// vtu_xml.cpp (.vtu) and htg_xml.cpp (.htg): VTK's XML formats written without VTK;
// vtk.cpp (the rest) in the VTK module (module.h), reached through
// module_load.cpp; vtk_load as vdb_load.
void vtk_load(const char *path);
void vtk_write_vtu(const oct_tree_t *tree, const oct_source_t *src, const char *path);
void vtk_write_htg(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
                   const char *path);
void vtk_write_htg_piece(const oct_tree_t *part, const tape_t *tape, const oct_source_t *src,
                         int depth, const uint64_t *frontier, size_t n, int top, const char *path);
// A double as VTK 9.1's vtkNumberToString writes it (double-conversion's
// EcmaScriptConverter, ToShortest): the shortest digits that read back as v, in
// decimal notation for decimal exponents -6 to 20 (0.000001, 123, no trailing
// point), else as d.ddde+x or d.ddde-x; -0 as "0", "NaN", "Infinity",
// "-Infinity".  The .htg's attributes (htg_xml.cpp).
std::string vtk_number(double v);
void vtk_write_vtp(const Mesh &mesh, const oct_source_t *src, const char *path);
void vtk_info(const char *path, FILE *out);

// A tape workspace that frees itself.
struct Workspace {
    explicit Workspace(const tape_t *t) : ws(tape_ws_new(t->n))
    {
        if (!ws)
            throw std::bad_alloc();
    }
    ~Workspace() { tape_ws_free(ws); }
    Workspace(const Workspace &) = delete;
    Workspace &operator=(const Workspace &) = delete;
    tape_ws_t *ws;
};

// Threads for a writer of this tree: the build's count (--threads), all cores
// when it is not known (a tree read from a file), never more than `jobs`.
inline int writer_threads(const oct_tree_t *tree, size_t jobs)
{
    int n = tree->stats.threads > 0 ? tree->stats.threads
                                    : (int)std::thread::hardware_concurrency();
    if (n < 1)
        n = 1;
    return (int)((size_t)n < jobs ? (size_t)n : (jobs ? jobs : 1));
}

// body(first, last, worker) over [0, n) in chunks of `chunk`, by `threads`
// threads (worker in 0..threads-1, for per-thread workspaces); the chunks are
// independent, so the result does not depend on the count.  The first
// exception of any thread is rethrown here once all have stopped.
template <class F> void parallel_chunks(size_t n, size_t chunk, int threads, F &&body)
{
    const size_t n_chunks = (n + chunk - 1) / chunk;
    if (threads <= 1 || n_chunks <= 1) {
        for (size_t s = 0; s < n; s += chunk)
            body(s, s + chunk < n ? s + chunk : n, 0);
        return;
    }
    std::atomic<size_t> next{0};
    std::exception_ptr failure;
    std::mutex m;
    auto run = [&](int worker) {
        try {
            for (size_t c; (c = next.fetch_add(1)) < n_chunks;) {
                size_t s = c * chunk;
                body(s, s + chunk < n ? s + chunk : n, worker);
            }
        } catch (...) {
            std::lock_guard<std::mutex> lk(m);
            if (!failure)
                failure = std::current_exception();
            next = n_chunks;
        }
    };
    std::vector<std::thread> pool;
    try {
        for (int w = 1; w < threads; w++)
            pool.emplace_back(run, w);
    } catch (...) {  // no thread: the work is done by those there are
    }
    run(0);
    for (auto &t : pool)
        t.join();
    if (failure)
        std::rethrow_exception(failure);
}

// The threads of one parallel_chunks that wait on each other, e.g. to write their
// chunks' output in order: a thread waits with the lock held (lock(), wait) until
// the others have done what it needs, and a thread that throws wakes them all
// (run), so that none waits forever for the one that failed.
class Turns {
public:
    std::unique_lock<std::mutex> lock() { return std::unique_lock<std::mutex>(m_); }
    // Wait (lk held) until ready(); false if a thread failed meanwhile (the caller
    // returns: parallel_chunks rethrows the first failure).
    template <class P> bool wait(std::unique_lock<std::mutex> &lk, P ready)
    {
        cv_.wait(lk, [&] { return failed_ || ready(); });
        return !failed_;
    }
    void notify() { cv_.notify_all(); }  // lk held
    // body() for a chunk; on an exception the waiting threads are woken, and it
    // is rethrown
    template <class F> void run(F &&body)
    {
        try {
            body();
        } catch (...) {
            {
                std::lock_guard<std::mutex> lk(m_);
                failed_ = true;
            }
            cv_.notify_all();
            throw;
        }
    }

private:
    std::mutex m_;
    std::condition_variable cv_;
    bool failed_ = false;
};

// ---- the binary data of VTK's XML files (htg_xml.cpp, vtu_xml.cpp) -------------------
// What vtkXMLWriter (VTK 9.1) writes for an array of n bytes with UInt64 headers
// and vtkLZ4DataCompressor: the bytes cut into blocks of LZ4_BLOCK, each
// compressed on its own (LZ4_compress_fast at the acceleration vtkLZ4DataCompressor
// uses for the writer's default level 5), behind the compressed-data header
//   block count, block size, size of the last block (0 when it is full), and the
//   compressed size of each block.
// The writers here compress the blocks of an array over threads; a block's
// bytes do not depend on the others', so the data are the same for any count.
constexpr size_t LZ4_BLOCK = 32768;  // vtkXMLWriter's default BlockSize

// The byte order of the numbers in the VTK XML files written here: the host's,
// as VTK's own writers do (its readers swap where the reader's host differs).
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
constexpr const char *VTK_BYTE_ORDER = "LittleEndian";
#elif defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
constexpr const char *VTK_BYTE_ORDER = "BigEndian";
#else
#error "the VTK XML writers need the host's byte order (__BYTE_ORDER__)"
#endif

// A thread's compressed blocks, end to end, in the order it made them; grown by
// mem_huge_realloc (a large block moves its pages, no copy).  Also the .vdb
// writer's encoded leaf nodes (vdb.cpp, LeafBytes): no LZ4 here.
struct Lz4Spool {
    HugeArray<char> data;
    size_t size = 0, cap = 0;
    // p[0, n) appended, at least `first` bytes of room taken when there is none;
    // returns where they start
    size_t append(const char *p, size_t n, size_t first)
    {
        if (size + n > cap) {
            const size_t cap2 = std::max(std::max(2 * cap, first), size + n);
            char *q = static_cast<char *>(mem_huge_realloc(data.get(), cap2));
            if (!q)
                throw std::bad_alloc();
            data.release();
            data.reset(q);
            cap = cap2;
        }
        std::memcpy(data.get() + size, p, n);
        size += n;
        return size - n;
    }
};

// An array's compressed data: the header, and the blocks where the threads that
// compressed them left them (each thread's blocks end to end in its own spool),
// never copied together: each() gives them in order.
struct Lz4Blocks {
    std::vector<uint64_t> header;  // the compressed-data header (host order)
    size_t size = 0;               // the blocks' bytes
    std::vector<Lz4Spool> spools;
    std::vector<std::pair<int, size_t>> where;  // a block's spool and offset in it
    size_t header_bytes() const { return header.size() * sizeof(uint64_t); }
    size_t bytes() const { return header_bytes() + size; }
    // f(p, n) for each block in order
    template <class F> void each(F &&f) const
    {
        for (size_t b = 0; b < where.size(); b++)
            f(spools[(size_t)where[b].first].data.get() + where[b].second, (size_t)header[3 + b]);
    }
};

// The bytes [at, at + n) of an array (n <= LZ4_BLOCK, one block): a pointer into
// the array, or into `scratch` (LZ4_BLOCK bytes, the calling thread's own) after
// writing them there, for an array made block by block and never held whole.
// worker: the calling thread's number, 0 to threads - 1 (for its own workspaces).
using BlockBytes =
    std::function<const void *(size_t at, size_t n, unsigned char *scratch, int worker)>;

// The n bytes that bytes() gives, compressed by `threads` threads (one below
// 8 blocks).  path: for the error message.  reuse: the spools of an array
// written already, whose memory the blocks then fill (pages mapped once for a
// writer's arrays, not once for each).
Lz4Blocks lz4_blocks(size_t n, int threads, const BlockBytes &bytes, const char *path,
                     std::vector<Lz4Spool> reuse = {});
// The same for n bytes held at data.
Lz4Blocks lz4_blocks(const void *data, size_t n, int threads, const char *path,
                     std::vector<Lz4Spool> reuse = {});
// The same compressed data written to the end of `file` (seekable) as they are
// made, never held: room for the header, the blocks in order as the threads
// compress them (a few dozen blocks ahead of the one written next, at most),
// then the header written into its room.  Returns the header and size (no
// blocks: `where` and `spools` are empty).
Lz4Blocks lz4_stream(Output &file, size_t n, int threads, const BlockBytes &bytes);
Lz4Blocks lz4_stream(Output &file, const void *data, size_t n, int threads);

// vtkDataArray::GetRange of one component: the least and greatest value, NaN
// skipped; without any value VTK_DOUBLE_MAX, VTK_DOUBLE_MIN.  Integers compare
// as doubles: the conversion is monotone, so the extremes are the same.
struct Range {
    double lo = 1.0e+299, hi = -1.0e+299;
    bool any = false;
    void add(double v)
    {
        if (v != v)  // NaN
            return;
        if (!any) {
            lo = hi = v, any = true;
            return;
        }
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
    }
    void add(const Range &r)
    {
        if (r.any) {
            add(r.lo);
            add(r.hi);
        }
    }
};

template <class T> Range range_of(const T *v, size_t n)
{
    Range r;
    for (size_t i = 0; i < n; i++)
        r.add((double)v[i]);
    return r;
}

}  // namespace ivexp

#endif
