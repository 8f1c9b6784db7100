// ivoct export/ — the entry point of the OpenVDB module (libivoct_openvdb.so),
// and its way to the host's functions.  vdb_module.h says why the module
// exists and what crosses the seam.
//
// The C functions of ivoct that vdb.cpp and output.cpp call are defined here,
// forwarding to the host's table: the module links no other part of ivoct, so
// the temporary-file registry, the memory accounting and the evaluator it
// uses are the host's own.  The module exports nothing else (hidden
// visibility), so these definitions never stand in for the host's.
#include <cstdio>
#include <new>

#include "internal.hpp"
#include "vdb_module.h"

namespace {
const ivoct_vdb_host_t *host;

// body() with any exception turned into msg: -2 out of memory, -1 otherwise.
template <class F> int catching(char *msg, size_t msg_size, F &&body) noexcept
{
    try {
        body();
        return 0;
    } catch (const std::bad_alloc &) {
        std::snprintf(msg, msg_size, "out of memory");
        return -2;
    } catch (const std::exception &e) {
        std::snprintf(msg, msg_size, "%s", e.what());
    } catch (...) {
        std::snprintf(msg, msg_size, "unexpected error");
    }
    return -1;
}

int write(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src, const char *path,
          char *msg, size_t msg_size)
{
    return catching(msg, msg_size, [&] { ivexp::vdb_write(tree, tape, src, path); });
}

int mesh(const oct_tree_t *tree, const tape_t *tape, void *out, char *msg, size_t msg_size)
{
    return catching(msg, msg_size,
                    [&] { *static_cast<ivexp::Mesh *>(out) = ivexp::vdb_mesh(tree, tape); });
}

int info(const char *path, FILE *out, char *msg, size_t msg_size)
{
    return catching(msg, msg_size, [&] { ivexp::vdb_info(path, out); });
}

const ivoct_vdb_api_t api = {write, mesh, info};
}  // namespace

extern "C" {

__attribute__((visibility("default"))) const ivoct_vdb_api_t *
ivoct_vdb_module(const ivoct_vdb_host_t *h, unsigned abi, size_t layout)
{
    if (abi != IVOCT_VDB_MODULE_ABI || layout != ivoct_vdb_layout() || !h)
        return nullptr;
    host = h;
    return &api;
}

// ---- the host's functions (vdb_module.h) ---------------------------------------------
int io_open(io_file_t *f, const char *path, ivoct_error_t *err)
{
    return host->io_open(f, path, err);
}
int io_commit(io_file_t *f, ivoct_error_t *err) { return host->io_commit(f, err); }
void io_abort(io_file_t *f) { host->io_abort(f); }
void ivoct_error_clear(ivoct_error_t *err) { host->ivoct_error_clear(err); }
void *mem_huge_alloc(size_t bytes) { return host->mem_huge_alloc(bytes); }
tape_ws_t *tape_ws_new(uint32_t max_clauses) { return host->tape_ws_new(max_clauses); }
void tape_ws_free(tape_ws_t *ws) { host->tape_ws_free(ws); }
void tape_eval_point_grad(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                          const double *y, const double *z, tape_point_grad_t *out)
{
    host->tape_eval_point_grad(t, ws, n, x, y, z, out);
}
void oct_unmorton(uint64_t code, int depth, uint32_t *ix, uint32_t *iy, uint32_t *iz)
{
    host->oct_unmorton(code, depth, ix, iy, iz);
}

}  // extern "C"
