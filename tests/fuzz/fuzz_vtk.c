/* ivoct info on VTK XML files (.vtu, .htg, .vtp: export/vtk.cpp's readers and VTK's):
 * any file is summarised or refused with an error, never a crash.  exp_info
 * recognises files by content, so the name's suffix does not matter; the
 * summary goes to /dev/null. */
#define _DEFAULT_SOURCE
#include <limits.h>

#include "fuzz_input.h"

#include "export/export.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static FILE *out;
    if (!out && !(out = fopen("/dev/null", "w")))
        abort();
    char path[PATH_MAX];
    fuzz_file(data, size, ".vtu", path, sizeof path);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (exp_info(path, out, &err) < 0 && !err.msg[0])
        abort();
    unlink(path);
    return 0;
}
