// ivoct export/ — what each module of export/ (module.h) shares: attaching to the
// host's functions (module_host.cpp) and returning errors across the seam.
#ifndef IVOCT_EXPORT_MODULE_HOST_HPP
#define IVOCT_EXPORT_MODULE_HOST_HPP

#include <cstdio>
#include <exception>
#include <new>

#include "module.h"

namespace ivexp {

// Keep the host's table for the forwarding functions of module_host.cpp; false
// (and nothing kept) when the loader asked for another module (`asked`, this
// one being `self`), or abi or layout is not this module's.
bool module_attach(const char *asked, const char *self, const ivoct_module_host_t *host,
                   unsigned abi, size_t layout);

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

}  // namespace ivexp

#endif
