/* The .ivo loader (oct_load, octree/file.c): any file is loaded or refused,
 * never a crash.  A mutated file almost never keeps a valid checksum, which
 * oct_load checks before the structure, so the target writes the checksum of
 * the input's first size - 8 bytes in place of its last 8, the one the file's
 * version names (XXH3-64 for versions 5 and 6, else FNV-1a 64): the structure
 * checks behind it are what gets fuzzed.  (The checksum test itself is
 * tests/test_octree_file.c's.) */
#define _DEFAULT_SOURCE
#include <limits.h>

#include <xxhash.h>

#include "fuzz_input.h"

#include "octree/octree.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *buf = malloc(size ? size : 1);
    if (!buf)
        abort();
    if (size)
        memcpy(buf, data, size);
    if (size >= 8) {
        uint32_t version = size >= 12 ? (uint32_t)buf[8] | (uint32_t)buf[9] << 8 |
                                            (uint32_t)buf[10] << 16 | (uint32_t)buf[11] << 24
                                      : 0;
        uint64_t h = 0xcbf29ce484222325u;
        if (version == 5 || version == 6) {
            h = XXH3_64bits(buf, size - 8);
        } else {
            for (size_t i = 0; i < size - 8; i++)
                h = (h ^ buf[i]) * 0x100000001b3u;
        }
        for (int k = 0; k < 8; k++)
            buf[size - 8 + k] = (uint8_t)(h >> (8 * k));
    }
    char path[PATH_MAX];
    fuzz_file(buf, size, ".ivo", path, sizeof path);
    free(buf);
    oct_tree_t *tree = NULL;
    oct_source_t src;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_load(path, &tree, &src, &err) == 0) {
        if (!tree || !src.f || !src.name)
            abort();
        oct_free(tree);
        oct_source_free(&src);
    } else if (!err.msg[0]) {
        abort();
    }
    unlink(path);
    return 0;
}
