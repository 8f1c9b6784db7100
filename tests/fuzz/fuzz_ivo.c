/* The .ivo loader (oct_load, octree/file.c): any file is loaded or refused,
 * never a crash.  A mutated file almost never keeps a valid FNV-1a checksum,
 * which oct_load checks before the structure, so the target writes the
 * checksum of the input's first size - 8 bytes in place of its last 8: the
 * structure checks behind it are what gets fuzzed.  (The checksum test itself
 * is tests/test_octree_file.c's.) */
#define _DEFAULT_SOURCE
#include <limits.h>

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
        uint64_t h = 0xcbf29ce484222325u;
        for (size_t i = 0; i < size - 8; i++)
            h = (h ^ buf[i]) * 0x100000001b3u;
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
