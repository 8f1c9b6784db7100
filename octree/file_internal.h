/* What the native file's two halves share: file.c (one tree) and pieces.c (a
 * tree in pieces, read through an index).  Not part of the interface. */
#ifndef IVOCT_OCTREE_FILE_INTERNAL_H
#define IVOCT_OCTREE_FILE_INTERNAL_H

#include <stdint.h>

#include "octree.h"

/* The first 8 bytes of an index of pieces (its first line is
 * "ivoct-pieces 1 pieces=N leaves=L"); a tree file begins with "IVOCTREE". */
#define PIECES_MAGIC "ivoct-pi"

/* oct_load of one tree file; *checksum (when not NULL) is the checksum that
 * ends the file (checked: XXH3-64 for versions 5 and 6, FNV-1a 64 for older). */
int file_load_tree(const char *path, oct_tree_t **out, oct_source_t *src, uint64_t *checksum,
                   ivoct_error_t *err);

/* oct_load of an index: its pieces loaded, checked and put together. */
int file_load_pieces(const char *path, oct_tree_t **out, oct_source_t *src, ivoct_error_t *err);

#endif
