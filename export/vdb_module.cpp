// ivoct export/ — the entry point of the OpenVDB module, libivoct_openvdb.so
// (module.h): vdb.cpp's writer, mesher and reader.
#include "internal.hpp"
#include "module_host.hpp"

namespace {

int write(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src, const char *path,
          char *msg, size_t msg_size)
{
    return ivexp::catching(msg, msg_size, [&] { ivexp::vdb_write(tree, tape, src, path); });
}

int mesh(const oct_tree_t *tree, const tape_t *tape, void *out, char *msg, size_t msg_size)
{
    return ivexp::catching(
        msg, msg_size, [&] { *static_cast<ivexp::Mesh *>(out) = ivexp::vdb_mesh(tree, tape); });
}

int info(const char *path, FILE *out, char *msg, size_t msg_size)
{
    return ivexp::catching(msg, msg_size, [&] { ivexp::vdb_info(path, out); });
}

const ivoct_vdb_api_t api = {write, mesh, info};

}  // namespace

extern "C" __attribute__((visibility("default"))) const void *
ivoct_module(const char *name, const ivoct_module_host_t *host, unsigned abi, size_t layout)
{
    return ivexp::module_attach(name, IVOCT_MODULE_OPENVDB, host, abi, layout) ? &api : nullptr;
}
