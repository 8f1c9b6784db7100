/* The scene loader (scene/, and through it the expression compiler, octree/'s
 * and ray/'s value checks): any file is loaded or refused with an error
 * naming what was expected, never a crash.  The input is written to a
 * temporary file (scene_load takes a path; scene files include nothing).
 * Parametric scenes are implicitized too (implicit/). */
#define _DEFAULT_SOURCE
#include <limits.h>

#include "fuzz_input.h"

#include "scene/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[PATH_MAX];
    fuzz_file(data, size, ".ini", path, sizeof path);
    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    /* a small budget, so that a fuzzed parametrization of high degree is refused
     * in a moment rather than computed; and resultants only, whose steps are
     * short: one S-polynomial reduction of the Groebner basis is a single call of
     * Calcium's that can last seconds past any budget (implicit/README.md), longer
     * than libFuzzer's timeout */
    const scene_options_t opt = {.implicitize = IMP_RESULTANT,
                                 .budget = {.seconds = 0.5, .bytes = 64 << 20}};
    if (scene_load_with(path, &opt, &s, &err) == 0) {
        if (!s.tape || !s.source.f)
            abort();
        scene_free(&s);
    } else if (!err.msg[0]) {
        abort();
    }
    unlink(path);
    return 0;
}
