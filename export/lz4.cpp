// ivoct export/ — the LZ4 blocks of the VTK XML writers (internal.hpp: lz4_blocks,
// lz4_stream), compressed over threads: the .vtu and .htg writers.  Only the LZ4
// library (Debian's liblz4, which VTK itself links for its LZ4 compressor), not VTK.
#include <cstring>

#include <lz4.h>

#include "internal.hpp"

namespace ivexp {

// ---- LZ4 blocks (internal.hpp) --------------------------------------------------------
namespace {
constexpr int LZ4_ACCELERATION = 5;   // vtkLZ4DataCompressor at the writer's level 5: 10 - 5
constexpr size_t PARALLEL_BLOCKS = 8; // fewer blocks than this: one thread
const size_t LZ4_BOUND = (size_t)LZ4_COMPRESSBOUND((int)LZ4_BLOCK);

// The header of an array of n bytes, but the blocks' compressed sizes.
Lz4Blocks header_of(size_t n)
{
    const size_t nblocks = n / LZ4_BLOCK + (n % LZ4_BLOCK ? 1 : 0);
    Lz4Blocks z;
    z.header.assign(3 + nblocks, 0);
    z.header[0] = nblocks;
    z.header[1] = LZ4_BLOCK;
    z.header[2] = n % LZ4_BLOCK;
    return z;
}

// Block b of the n bytes that bytes() gives, compressed into out (LZ4_BOUND
// bytes); its compressed size
size_t compress_block(size_t n, size_t b, const BlockBytes &bytes, unsigned char *scratch,
                      int worker, char *out, const char *path)
{
    const size_t at = b * LZ4_BLOCK, size = std::min(LZ4_BLOCK, n - at);
    const void *in = bytes(at, size, scratch, worker);
    const int cs = LZ4_compress_fast(static_cast<const char *>(in), out, (int)size,
                                     (int)LZ4_BOUND, LZ4_ACCELERATION);
    if (cs <= 0)
        throw Error(std::string("cannot write ") + path + ": LZ4 failed");
    return (size_t)cs;
}

}  // namespace

Lz4Blocks lz4_blocks(size_t n, int threads, const BlockBytes &bytes, const char *path,
                     std::vector<Lz4Spool> reuse)
{
    Lz4Blocks z = header_of(n);
    const size_t nblocks = z.header.size() - 3;
    if (nblocks < PARALLEL_BLOCKS)
        threads = 1;
    // each block compressed into the thread's scratch and appended to the thread's
    // spool, where the caller finds it (Lz4Blocks::each): only the compressed bytes
    // are ever touched, once (room for every block's bound, as large as the input,
    // would be mapped whole on huge pages; a copy end to end, as many fresh pages again)
    std::vector<std::unique_ptr<unsigned char[]>> scratch((size_t)threads);
    std::vector<std::unique_ptr<char[]>> packed((size_t)threads);
    for (int t = 0; t < threads; t++) {
        scratch[(size_t)t].reset(new unsigned char[LZ4_BLOCK]);
        packed[(size_t)t].reset(new char[LZ4_BOUND]);
    }
    // a new spool starts at half its share of the input's bound: large arrays'
    // spools are on huge pages from the start, and only the pages touched are mapped
    z.spools = std::move(reuse);
    if (z.spools.size() < (size_t)threads)
        z.spools.resize((size_t)threads);
    for (Lz4Spool &s : z.spools)
        s.size = 0;
    const size_t first = nblocks * LZ4_BOUND / (size_t)threads / 2 + 1;
    z.where.resize(nblocks);
    parallel_chunks(nblocks, 1, threads, [&](size_t b, size_t, int worker) {
        char *out = packed[(size_t)worker].get();
        const size_t cs =
            compress_block(n, b, bytes, scratch[(size_t)worker].get(), worker, out, path);
        z.header[3 + b] = (uint64_t)cs;
        z.where[b] = {worker, z.spools[(size_t)worker].append(out, cs, first)};
    });
    for (size_t b = 0; b < nblocks; b++)
        z.size += z.header[3 + b];
    return z;
}

Lz4Blocks lz4_stream(Output &file, size_t n, int threads, const BlockBytes &bytes)
{
    Lz4Blocks z = header_of(n);
    const size_t nblocks = z.header.size() - 3;
    if (nblocks < PARALLEL_BLOCKS)
        threads = 1;
    // the header's room, filled in once the blocks have given their sizes
    const uint64_t header_at = file.size();
    file.write(z.header.data(), z.header_bytes());
    // block b is compressed into slot b % SLOTS once the blocks SLOTS before it
    // are written; whichever thread finds the next block to write ready writes it
    // and those ready after it, in order
    constexpr size_t SLOTS = 64;
    std::vector<std::unique_ptr<unsigned char[]>> scratch((size_t)threads);
    for (int t = 0; t < threads; t++)
        scratch[(size_t)t].reset(new unsigned char[LZ4_BLOCK]);
    const std::unique_ptr<char[]> slots(new char[SLOTS * LZ4_BOUND]);
    size_t slot_size[SLOTS];
    bool ready[SLOTS] = {};
    Turns turns;
    size_t written = 0;  // blocks written
    parallel_chunks(nblocks, 1, threads, [&](size_t b, size_t, int worker) {
        turns.run([&] {
            {
                std::unique_lock<std::mutex> lk = turns.lock();
                if (!turns.wait(lk, [&] { return b < written + SLOTS; }))
                    return;
            }
            char *out = slots.get() + b % SLOTS * LZ4_BOUND;
            const size_t cs = compress_block(n, b, bytes, scratch[(size_t)worker].get(), worker,
                                             out, file.path());
            std::unique_lock<std::mutex> lk = turns.lock();
            z.header[3 + b] = (uint64_t)cs;
            slot_size[b % SLOTS] = cs;
            ready[b % SLOTS] = true;
            for (size_t k; written < nblocks && ready[k = written % SLOTS]; written++) {
                file.write(slots.get() + k * LZ4_BOUND, slot_size[k]);
                ready[k] = false;
            }
            turns.notify();
        });
    });
    for (size_t b = 0; b < nblocks; b++)
        z.size += z.header[3 + b];
    file.write_at(header_at, z.header.data(), z.header_bytes());
    return z;
}

Lz4Blocks lz4_blocks(const void *data, size_t n, int threads, const char *path,
                     std::vector<Lz4Spool> reuse)
{
    const unsigned char *p = static_cast<const unsigned char *>(data);
    return lz4_blocks(n, threads,
                      [p](size_t at, size_t, unsigned char *, int) -> const void * {
                          return p + at;
                      },
                      path, std::move(reuse));
}

Lz4Blocks lz4_stream(Output &file, const void *data, size_t n, int threads)
{
    const unsigned char *p = static_cast<const unsigned char *>(data);
    return lz4_stream(file, n, threads,
                      [p](size_t at, size_t, unsigned char *, int) -> const void * {
                          return p + at;
                      });
}

}  // namespace ivexp
