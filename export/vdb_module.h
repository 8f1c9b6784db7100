/* ivoct export/ — the seam between export/ and its OpenVDB module (internal).
 *
 * Why a module: loading libopenvdb costs every process that links it about
 * 60 ms before main (its tens of thousands of symbol relocations, resolved
 * by the dynamic loader at start-up: measured in export/README.md, "The
 * OpenVDB module"), although only `--vdb`, `--mesh` and `ivoct info` of a
 * .vdb use it.  So vdb.cpp, the one file that includes OpenVDB, is built as
 * the module libivoct_openvdb.so, and vdb_load.cpp opens it (dlopen) the
 * first time one of them is called.
 *
 * The module reaches the rest of ivoct only through the host functions below,
 * which the loader fills with its own: the temporary-file registry of io/
 * (removed on a signal), the memory accounting of mem/ and the evaluator
 * chosen at run time are the host's, never copies.  The module's definitions
 * of those C functions forward to this table (vdb_module.cpp), so vdb.cpp is
 * the same code as when it was linked in.  No exception crosses the seam:
 * one inside the module comes back as a message.  Loader and module are built
 * together, by the same compiler, from the same headers: the mesh crosses as
 * the C++ object internal.hpp defines (no copy of its arrays). */
#ifndef IVOCT_EXPORT_VDB_MODULE_H
#define IVOCT_EXPORT_VDB_MODULE_H

#include <stddef.h>
#include <stdio.h>

#include "expr/error.h"
#include "expr/tape.h"
#include "io/io.h"
#include "mem/mem.h"
#include "octree/octree.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Changed whenever either table below, or a type they pass, changes: the
 * loader refuses a module built with another value. */
#define IVOCT_VDB_MODULE_ABI 1u

/* The module's file name, and the name of its one exported function. */
#define IVOCT_VDB_MODULE_FILE "libivoct_openvdb.so"
#define IVOCT_VDB_MODULE_ENTRY "ivoct_vdb_module"

/* What the module calls in its host (the process that loaded it). */
typedef struct ivoct_vdb_host {
    int (*io_open)(io_file_t *f, const char *path, ivoct_error_t *err);
    int (*io_commit)(io_file_t *f, ivoct_error_t *err);
    void (*io_abort)(io_file_t *f);
    void (*ivoct_error_clear)(ivoct_error_t *err);
    void *(*mem_huge_alloc)(size_t bytes);
    tape_ws_t *(*tape_ws_new)(uint32_t max_clauses);
    void (*tape_ws_free)(tape_ws_t *ws);
    void (*tape_eval_point_grad)(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                                 const double *y, const double *z, tape_point_grad_t *out);
    void (*oct_unmorton)(uint64_t code, int depth, uint32_t *ix, uint32_t *iy, uint32_t *iz);
} ivoct_vdb_host_t;

/* What the module offers.  Each returns 0, or -1 with a message in msg
 * (msg_size bytes, NUL-terminated); -2 means out of memory. */
typedef struct ivoct_vdb_api {
    int (*write)(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
                 const char *path, char *msg, size_t msg_size);
    int (*mesh)(const oct_tree_t *tree, const tape_t *tape, void *mesh, char *msg,
                size_t msg_size); /* mesh: an ivexp::Mesh (internal.hpp), filled */
    int (*info)(const char *path, FILE *out, char *msg, size_t msg_size);
} ivoct_vdb_api_t;

/* The sizes of the types that cross, folded into one number: a module built
 * from other headers (an older build tree's, beside a copied program) is
 * refused rather than misread. */
static inline size_t ivoct_vdb_layout(void)
{
    size_t s[] = {sizeof(ivoct_vdb_host_t), sizeof(ivoct_vdb_api_t), sizeof(oct_tree_t),
                  sizeof(oct_source_t),     sizeof(oct_stats_t),     sizeof(oct_leaf_t),
                  sizeof(tape_t),           sizeof(tape_point_grad_t), sizeof(io_file_t),
                  sizeof(ivoct_error_t)};
    size_t h = 0;
    for (size_t i = 0; i < sizeof s / sizeof s[0]; i++)
        h = h * 131 + s[i];
    return h;
}

/* The entry point: the module's table, or NULL when abi is not the module's
 * IVOCT_VDB_MODULE_ABI or layout not its ivoct_vdb_layout().  host must
 * outlive every call. */
typedef const ivoct_vdb_api_t *(*ivoct_vdb_module_fn)(const ivoct_vdb_host_t *host,
                                                      unsigned abi, size_t layout);

#ifdef __cplusplus
}
#endif

#endif
