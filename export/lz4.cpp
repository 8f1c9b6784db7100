// ivoct export/ — the LZ4 blocks of the VTK XML writers (internal.hpp: lz4_blocks),
// compressed over threads.  Built into export/ (the .vtu writer) and into its VTK
// module (the .htg writer): no state, only the LZ4 library (Debian's liblz4, which
// VTK itself links for its LZ4 compressor), not VTK.
#include <cstring>

#include <lz4.h>

#include "internal.hpp"

namespace ivexp {

// ---- LZ4 blocks (internal.hpp) --------------------------------------------------------
namespace {
constexpr int LZ4_ACCELERATION = 5;   // vtkLZ4DataCompressor at the writer's level 5: 10 - 5
constexpr size_t PARALLEL_BLOCKS = 8; // fewer blocks than this: one thread
}  // namespace

Lz4Blocks lz4_blocks(size_t n, int threads, const BlockBytes &bytes, const char *path,
                     std::vector<Lz4Spool> reuse)
{
    const size_t nblocks = n / LZ4_BLOCK + (n % LZ4_BLOCK ? 1 : 0);
    const size_t bound = (size_t)LZ4_COMPRESSBOUND((int)LZ4_BLOCK);
    Lz4Blocks z;
    z.header.resize(3 + nblocks);
    z.header[0] = nblocks;
    z.header[1] = LZ4_BLOCK;
    z.header[2] = n % LZ4_BLOCK;
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
        packed[(size_t)t].reset(new char[bound]);
    }
    // a new spool starts at half its share of the input's bound: large arrays'
    // spools are on huge pages from the start, and only the pages touched are mapped
    z.spools = std::move(reuse);
    if (z.spools.size() < (size_t)threads)
        z.spools.resize((size_t)threads);
    for (Lz4Spool &s : z.spools)
        s.size = 0;
    const size_t first = nblocks * bound / (size_t)threads / 2 + 1;
    z.where.resize(nblocks);
    parallel_chunks(nblocks, 1, threads, [&](size_t b, size_t, int worker) {
        const size_t at = b * LZ4_BLOCK, size = std::min(LZ4_BLOCK, n - at);
        const void *in = bytes(at, size, scratch[(size_t)worker].get(), worker);
        char *out = packed[(size_t)worker].get();
        const int cs = LZ4_compress_fast(static_cast<const char *>(in), out, (int)size,
                                         (int)bound, LZ4_ACCELERATION);
        if (cs <= 0)
            throw Error(std::string("cannot write ") + path + ": LZ4 failed");
        z.header[3 + b] = (uint64_t)cs;
        z.where[b] = {worker, z.spools[(size_t)worker].append(out, (size_t)cs, first)};
    });
    for (size_t b = 0; b < nblocks; b++)
        z.size += z.header[3 + b];
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

}  // namespace ivexp
