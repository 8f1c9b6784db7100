// ivoct export/ — a module's way to its host's functions (module.h).
//
// The C functions of ivoct that a module's sources call are defined here,
// forwarding to the host's table: a module links no other part of ivoct, so
// the temporary-file registry, the memory accounting and the evaluator it uses
// are the host's own.  A module exports nothing but its entry point
// (module.map), so these definitions never stand in for the host's.
#include <cstring>

#include "module_host.hpp"

namespace {
const ivoct_module_host_t *host;
}  // namespace

bool ivexp::module_attach(const char *asked, const char *self, const ivoct_module_host_t *h,
                          unsigned abi, size_t layout)
{
    if (!asked || std::strcmp(asked, self) || abi != IVOCT_MODULE_ABI ||
        layout != ivoct_module_layout() || !h)
        return false;
    host = h;
    return true;
}

extern "C" {

int io_open(io_file_t *f, const char *path, ivoct_error_t *err)
{
    return host->io_open(f, path, err);
}
int io_commit(io_file_t *f, ivoct_error_t *err) { return host->io_commit(f, err); }
void io_abort(io_file_t *f) { host->io_abort(f); }
void ivoct_error_clear(ivoct_error_t *err) { host->ivoct_error_clear(err); }
void *mem_huge_alloc(size_t bytes) { return host->mem_huge_alloc(bytes); }
void *mem_huge_realloc(void *p, size_t bytes) { return host->mem_huge_realloc(p, bytes); }
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
