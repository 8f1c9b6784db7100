// ivoct export/ — the entry point of the VTK module, libivoct_vtk.so (module.h):
// the .htg writer (htg_xml.cpp: VTK's number formatting), the .vtp writer and
// the readers of VTK files (vtk.cpp).
#include "internal.hpp"
#include "module_host.hpp"

namespace {

int write_htg(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
              const char *path, char *msg, size_t msg_size)
{
    return ivexp::catching(msg, msg_size, [&] { ivexp::vtk_write_htg(tree, tape, src, path); });
}

int write_htg_piece(const oct_tree_t *part, const tape_t *tape, const oct_source_t *src,
                    int depth, const uint64_t *frontier, size_t n, int top, const char *path,
                    char *msg, size_t msg_size)
{
    return ivexp::catching(msg, msg_size, [&] {
        ivexp::vtk_write_htg_piece(part, tape, src, depth, frontier, n, top, path);
    });
}

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

const ivoct_vtk_api_t api = {write_htg, write_htg_piece, write_vtp, info};

}  // namespace

extern "C" __attribute__((visibility("default"))) const void *
ivoct_module(const char *name, const ivoct_module_host_t *host, unsigned abi, size_t layout)
{
    return ivexp::module_attach(name, IVOCT_MODULE_VTK, host, abi, layout) ? &api : nullptr;
}
