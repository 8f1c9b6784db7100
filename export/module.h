/* ivoct export/ — the seam between export/ and its two modules (internal).
 *
 * Why modules: loading a large C++ library costs every process that links it
 * before main, in the dynamic loader's symbol relocations: libopenvdb ~65 ms,
 * VTK's ~17 ms, of the 94 ms `ivoct --version` took (docs/BENCHMARKS.md,
 * "Start-up"), although few commands use them.  So the files that include
 * them are built as modules, opened (dlopen) by module_load.cpp the first
 * time they are needed:
 *   libivoct_openvdb.so  vdb.cpp: .vdb files, meshes, `ivoct info` of a .vdb;
 *   libivoct_vtk.so      vtk.cpp: .vtp meshes, `ivoct info` of VTK files.
 * (The .vtu and .htg writers and the LZ4 blocks of the XML files need no VTK
 * library.)
 *
 * A module reaches the rest of ivoct only through the host functions below,
 * which the loader fills with its own: the temporary-file registry of io/
 * (removed on a signal), the memory accounting of mem/ and the evaluator of
 * the SIMD path chosen at run time are the host's, never copies.  The
 * module's definitions of those C functions forward to this table
 * (module_host.cpp), so its sources are the same code as when they were
 * linked in.  No exception crosses the seam: one inside a module comes back
 * as a message.  Loader and modules are built together, by the same compiler,
 * from the same headers: a mesh crosses as the C++ object internal.hpp
 * defines (no copy of its arrays). */
#ifndef IVOCT_EXPORT_MODULE_H
#define IVOCT_EXPORT_MODULE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "expr/error.h"
#include "expr/tape.h"
#include "io/io.h"
#include "mem/mem.h"
#include "octree/octree.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Changed whenever a table below, or a type they pass, changes: the loader
 * refuses a module built with another value. */
#define IVOCT_MODULE_ABI 3u

/* The modules' file names, and the name of the one function each exports. */
#define IVOCT_MODULE_OPENVDB "libivoct_openvdb.so"
#define IVOCT_MODULE_VTK "libivoct_vtk.so"
#define IVOCT_MODULE_ENTRY "ivoct_module"

/* What a module calls in its host (the process that loaded it). */
typedef struct ivoct_module_host {
    int (*io_open)(io_file_t *f, const char *path, ivoct_error_t *err);
    int (*io_commit)(io_file_t *f, ivoct_error_t *err);
    void (*io_abort)(io_file_t *f);
    void (*ivoct_error_clear)(ivoct_error_t *err);
    void *(*mem_huge_alloc)(size_t bytes);
    void *(*mem_huge_realloc)(void *p, size_t bytes);
    tape_ws_t *(*tape_ws_new)(uint32_t max_clauses);
    void (*tape_ws_free)(tape_ws_t *ws);
    void (*tape_eval_point_grad)(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                                 const double *y, const double *z, tape_point_grad_t *out);
    void (*oct_unmorton)(uint64_t code, int depth, uint32_t *ix, uint32_t *iy, uint32_t *iz);
} ivoct_module_host_t;

/* What the modules offer.  Each function returns 0, or -1 with a message in
 * msg (msg_size bytes, NUL-terminated); -2 means out of memory.  `mesh` is an
 * ivexp::Mesh (internal.hpp). */
typedef struct ivoct_vdb_api {
    int (*write)(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
                 const char *path, char *msg, size_t msg_size);
    int (*mesh)(const oct_tree_t *tree, const tape_t *tape, void *mesh, char *msg,
                size_t msg_size); /* fills mesh */
    int (*info)(const char *path, FILE *out, char *msg, size_t msg_size);
} ivoct_vdb_api_t;

typedef struct ivoct_vtk_api {
    int (*write_vtp)(const void *mesh, const oct_source_t *src, const char *path, char *msg,
                     size_t msg_size);
    int (*info)(const char *path, FILE *out, char *msg, size_t msg_size);
} ivoct_vtk_api_t;

/* The sizes of the types that cross, folded into one number: a module built
 * from other headers (an older build tree's, beside a copied program) is
 * refused rather than misread. */
static inline size_t ivoct_module_layout(void)
{
    size_t s[] = {sizeof(ivoct_module_host_t), sizeof(ivoct_vdb_api_t), sizeof(ivoct_vtk_api_t),
                  sizeof(oct_tree_t),   sizeof(oct_source_t), sizeof(oct_stats_t),
                  sizeof(oct_leaf_t),   sizeof(tape_t),       sizeof(tape_point_grad_t),
                  sizeof(iv_box_t),     sizeof(io_file_t),    sizeof(ivoct_error_t)};
    size_t h = 0;
    for (size_t i = 0; i < sizeof s / sizeof s[0]; i++)
        h = h * 131 + s[i];
    return h;
}

/* The entry point of either module: its table (ivoct_vdb_api_t or
 * ivoct_vtk_api_t), or NULL when `name` is not the module's file name (one
 * module given for the other), abi not its IVOCT_MODULE_ABI or layout not its
 * ivoct_module_layout().  host must outlive every call. */
typedef const void *(*ivoct_module_fn)(const char *name, const ivoct_module_host_t *host,
                                       unsigned abi, size_t layout);

#ifdef __cplusplus
}
#endif

#endif
