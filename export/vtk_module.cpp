// ivoct export/ — the entry point of the VTK module, libivoct_vtk.so (module.h):
// the .vtp writer and the readers of VTK files (vtk.cpp).
#include "internal.hpp"
#include "module_host.hpp"

namespace {

int write_vtp(const void *mesh, const oct_source_t *src, const char *path, char *msg,
              size_t msg_size)
{
    return ivexp::catching(msg, msg_size, [&] {
        ivexp::vtk_write_vtp(*static_cast<const ivexp::Mesh *>(mesh), src, path);
    });
}

int info(const char *path, FILE *out, char *msg, size_t msg_size)
{
    return ivexp::catching(msg, msg_size, [&] { ivexp::vtk_info(path, out); });
}

const ivoct_vtk_api_t api = {write_vtp, info};

}  // namespace

extern "C" __attribute__((visibility("default"))) const void *
ivoct_module(const char *name, const ivoct_module_host_t *host, unsigned abi, size_t layout)
{
    return ivexp::module_attach(name, IVOCT_MODULE_VTK, host, abi, layout) ? &api : nullptr;
}
