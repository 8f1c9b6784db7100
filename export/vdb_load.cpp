// ivoct export/ — the OpenVDB module (vdb_module.h) opened on first use, and
// vdb_write, vdb_mesh and vdb_info (internal.hpp) through it.
#include <dlfcn.h>
#include <unistd.h>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <string>

#include "internal.hpp"
#include "vdb_module.h"

// Where the module is (export/CMakeLists.txt): BUILD/lib/ivoct in the build tree
// BUILD, and where `make install` puts it.
#ifndef IVOCT_BUILD_ROOT
#error "IVOCT_BUILD_ROOT is set by export/CMakeLists.txt"
#endif
#define IVOCT_MODULE_BUILD_DIR IVOCT_BUILD_ROOT "/lib/ivoct"
#ifndef IVOCT_MODULE_INSTALL_DIR
#error "IVOCT_MODULE_INSTALL_DIR is set by export/CMakeLists.txt"
#endif

namespace ivexp {
namespace {

const ivoct_vdb_host_t host_functions = {
    io_open,     io_commit,    io_abort,
    ivoct_error_clear,
    mem_huge_alloc,
    tape_ws_new, tape_ws_free, tape_eval_point_grad,
    oct_unmorton,
};

bool in_build_tree(const char *path)
{
    char real[PATH_MAX];
    const size_t n = std::strlen(IVOCT_BUILD_ROOT "/");
    return path && path[0] && realpath(path, real) &&
           std::strncmp(real, IVOCT_BUILD_ROOT "/", n) == 0;
}

// The files to try, in order: $IVOCT_OPENVDB_MODULE alone when it is set;
// else the build tree's first for a program run from it (the one it was built
// with: the tests, the benchmarks, a build not installed), the installed one
// first for any other.
std::vector<std::string> module_paths()
{
    const char *env = std::getenv("IVOCT_OPENVDB_MODULE");
    if (env && env[0])
        return {env};
    const std::string build = IVOCT_MODULE_BUILD_DIR "/" IVOCT_VDB_MODULE_FILE;
    const std::string installed = IVOCT_MODULE_INSTALL_DIR "/" IVOCT_VDB_MODULE_FILE;
    Dl_info self;
    bool here = in_build_tree("/proc/self/exe") ||
                (dladdr(reinterpret_cast<void *>(&in_build_tree), &self) &&
                 in_build_tree(self.dli_fname));
    if (here)
        return {build, installed};
    return {installed, build};
}

struct Module {
    const ivoct_vdb_api_t *api = nullptr;
    std::string why;  // when api is null: why it could not be loaded
};

Module open_module()
{
    Module m;
    std::string tried;
    for (const std::string &path : module_paths()) {
        tried += (tried.empty() ? "" : ", ") + path;
        // RTLD_LOCAL: OpenVDB's symbols stay the module's; RTLD_NOW: a missing one
        // is an error here, not a crash later.  Never closed: OpenVDB's statics
        // live until exit.
        void *h = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            const char *e = dlerror();
            // a file that is there but cannot be loaded is the answer; a missing
            // one sends us to the next folder
            if (access(path.c_str(), F_OK) == 0) {
                m.why = std::string("cannot load ") + (e ? e : path.c_str());
                return m;
            }
            continue;
        }
        auto entry = reinterpret_cast<ivoct_vdb_module_fn>(dlsym(h, IVOCT_VDB_MODULE_ENTRY));
        m.api = entry ? entry(&host_functions, IVOCT_VDB_MODULE_ABI, ivoct_vdb_layout())
                      : nullptr;
        if (!m.api)
            m.why = path + " is not the OpenVDB module of this ivoct (another version?)";
        return m;
    }
    m.why = "the OpenVDB module " IVOCT_VDB_MODULE_FILE " was not found (looked for " + tried +
            "; IVOCT_OPENVDB_MODULE may name the file)";
    return m;
}

const ivoct_vdb_api_t &api(const char *what)
{
    static const Module m = open_module();  // once, thread-safe (C++11 statics)
    if (!m.api)
        throw Error(std::string(what) + ": " + m.why);
    return *m.api;
}

void check(int rc, const char *msg)
{
    if (rc == -2)
        throw std::bad_alloc();
    if (rc)
        throw Error(msg);
}

}  // namespace

void vdb_load(const char *path)
{
    api((std::string("cannot read ") + path).c_str());
}

void vdb_write(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
               const char *path)
{
    const ivoct_vdb_api_t &m = api((std::string("cannot write ") + path).c_str());
    char msg[512] = "";
    check(m.write(tree, tape, src, path, msg, sizeof msg), msg);
}

Mesh vdb_mesh(const oct_tree_t *tree, const tape_t *tape)
{
    const ivoct_vdb_api_t &m = api("cannot extract the mesh");
    Mesh mesh;
    char msg[512] = "";
    check(m.mesh(tree, tape, &mesh, msg, sizeof msg), msg);
    return mesh;
}

void vdb_info(const char *path, FILE *out)
{
    const ivoct_vdb_api_t &m = api((std::string("cannot read ") + path).c_str());
    char msg[512] = "";
    check(m.info(path, out, msg, sizeof msg), msg);
}

}  // namespace ivexp
