/* ivoct cli/ — the allocator of the `ivoct` program.
 *
 * The release build links jemalloc (Debian's libjemalloc2, which replaces
 * malloc for the whole process: ivoct, OpenVDB, VTK, TBB), as OpenVDB
 * recommends for its own tools.  What it buys here is memory on huge pages:
 * the .vdb writer makes ~100 MB of OpenVDB nodes of 2 KiB each, and glibc's
 * malloc takes them from its heap in 4 KiB pages, a page fault each (~5 us on
 * the 2-vCPU virtual machines this is measured on: about a fifth of that
 * writer's time, docs/BENCHMARKS.md "The allocator").  The settings are
 * compiled in, read by jemalloc at its first allocation (MALLOC_CONF in the
 * environment still adds to them, for experiments):
 *   thp:always  jemalloc's memory on transparent huge pages (MADV_HUGEPAGE);
 *   narenas:1   one arena for all threads (each keeps its own cache): the
 *               threads share huge pages instead of filling one each.
 * The sanitizer build keeps the C library's malloc (ASan replaces it), and
 * libivoct, a library, never chooses its users' allocator. */
#include <stdio.h>

#include "cli.h"

#ifdef IVOCT_JEMALLOC
#include <jemalloc/jemalloc.h>

const char *malloc_conf = "thp:always,narenas:1";

const char *cli_allocator(void)
{
    static char text[96];
    const char *version = NULL;
    size_t n = sizeof version;
    if (mallctl("version", (void *)&version, &n, NULL, 0) != 0 || !version)
        return "jemalloc";
    const char *thp = NULL;
    unsigned arenas = 0;
    size_t nt = sizeof thp, na = sizeof arenas;
    if (mallctl("opt.thp", (void *)&thp, &nt, NULL, 0) != 0 || !thp)
        thp = "?";
    if (mallctl("opt.narenas", &arenas, &na, NULL, 0) != 0)
        arenas = 0;
    /* "5.3.0-0-g<commit>": the release, up to the '-' */
    int len = 0;
    while (len < 40 && version[len] && version[len] != '-')
        len++;
    snprintf(text, sizeof text, "jemalloc %.*s (thp: %.12s, arenas: %u)", len, version, thp,
             arenas);
    return text;
}
#else
const char *cli_allocator(void) { return "the C library's malloc"; }
#endif
