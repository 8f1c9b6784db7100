// ivoct export/ — the modules (module.h) opened on first use, and the functions
// of internal.hpp that they hold (vdb_*, vtk_write_vtp, vtk_info) called through
// them.
#include <dlfcn.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <cstring>
#include <string>

#include "internal.hpp"
#include "module.h"

// Where the modules are (export/CMakeLists.txt): BUILD/lib/ivoct in the build
// tree BUILD, and where `make install` puts them.
#ifndef IVOCT_BUILD_ROOT
#error "IVOCT_BUILD_ROOT is set by export/CMakeLists.txt"
#endif
#ifndef IVOCT_MODULE_INSTALL_DIR
#error "IVOCT_MODULE_INSTALL_DIR is set by export/CMakeLists.txt"
#endif
#define IVOCT_MODULE_BUILD_DIR IVOCT_BUILD_ROOT "/lib/ivoct"

namespace ivexp {
namespace {

const ivoct_module_host_t host_functions = {
    io_open,     io_commit,    io_abort,
    ivoct_error_clear,
    mem_huge_alloc, mem_huge_realloc,
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

// The files to try for module `file`, in order: $env alone when it is set;
// else the build tree's first for a program run from it (the one it was built
// with: the tests, the benchmarks, a build not installed), the installed one
// first for any other.
std::vector<std::string> module_paths(const char *file, const char *env)
{
    const char *given = std::getenv(env);
    if (given && given[0])
        return {given};
    const std::string build = std::string(IVOCT_MODULE_BUILD_DIR "/") + file;
    const std::string installed = std::string(IVOCT_MODULE_INSTALL_DIR "/") + file;
    Dl_info self;
    bool here = in_build_tree("/proc/self/exe") ||
                (dladdr(reinterpret_cast<void *>(&in_build_tree), &self) &&
                 in_build_tree(self.dli_fname));
    if (here)
        return {build, installed};
    return {installed, build};
}

struct Module {
    const void *api = nullptr;
    std::string why;  // when api is null: why it could not be loaded
};

Module open_module(const char *file, const char *env)
{
    Module m;
    std::string tried;
    for (const std::string &path : module_paths(file, env)) {
        tried += (tried.empty() ? "" : ", ") + path;
        // RTLD_LOCAL: the library's symbols stay the module's; RTLD_NOW: a missing
        // one is an error here, not a crash later.  Never closed: the libraries'
        // statics live until exit.
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
        auto entry = reinterpret_cast<ivoct_module_fn>(dlsym(h, IVOCT_MODULE_ENTRY));
        m.api = entry ? entry(file, &host_functions, IVOCT_MODULE_ABI, ivoct_module_layout())
                      : nullptr;
        if (!m.api)
            m.why = path + " is not the " + file + " of this ivoct (another module, or another "
                    "version?)";
        return m;
    }
    m.why = std::string("the module ") + file + " was not found (looked for " + tried + "; " +
            env + " may name the file)";
    return m;
}

// The module's table, opened once (thread-safe: C++11 statics); else Error
// "what: why".
const ivoct_vdb_api_t &vdb(const std::string &what)
{
    static const Module m = open_module(IVOCT_MODULE_OPENVDB, "IVOCT_OPENVDB_MODULE");
    if (!m.api)
        throw Error(what + ": " + m.why);
    return *static_cast<const ivoct_vdb_api_t *>(m.api);
}

const ivoct_vtk_api_t &vtk(const std::string &what)
{
    static const Module m = open_module(IVOCT_MODULE_VTK, "IVOCT_VTK_MODULE");
    if (!m.api)
        throw Error(what + ": " + m.why);
    return *static_cast<const ivoct_vtk_api_t *>(m.api);
}

// A module function's status as an exception.
void check(int rc, const char *msg)
{
    if (rc == -2)
        throw std::bad_alloc();
    if (rc)
        throw Error(msg);
}

std::string writing(const char *path) { return std::string("cannot write ") + path; }
std::string reading(const char *path) { return std::string("cannot read ") + path; }

}  // namespace

void vdb_load(const char *path) { vdb(reading(path)); }
void vtk_load(const char *path) { vtk(reading(path)); }

void vdb_write(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
               const char *path)
{
    const ivoct_vdb_api_t &m = vdb(writing(path));
    char msg[512] = "";
    check(m.write(tree, tape, src, path, msg, sizeof msg), msg);
}

Mesh vdb_mesh(const oct_tree_t *tree, const tape_t *tape)
{
    const ivoct_vdb_api_t &m = vdb("cannot extract the mesh");
    Mesh mesh;
    char msg[512] = "";
    check(m.mesh(tree, tape, &mesh, msg, sizeof msg), msg);
    return mesh;
}

void vdb_info(const char *path, FILE *out)
{
    const ivoct_vdb_api_t &m = vdb(reading(path));
    char msg[512] = "";
    check(m.info(path, out, msg, sizeof msg), msg);
}

void vtk_write_vtp(const Mesh &mesh, const oct_source_t *src, const char *path)
{
    const ivoct_vtk_api_t &m = vtk(writing(path));
    char msg[512] = "";
    check(m.write_vtp(&mesh, src, path, msg, sizeof msg), msg);
}

void vtk_info(const char *path, FILE *out)
{
    const ivoct_vtk_api_t &m = vtk(reading(path));
    char msg[512] = "";
    check(m.info(path, out, msg, sizeof msg), msg);
}

}  // namespace ivexp
