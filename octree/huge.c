/* ivoct octree — large arrays on transparent huge pages (huge.h). */
#define _DEFAULT_SOURCE /* madvise */
#include "huge.h"

#include <stdint.h>
#include <stdlib.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

void huge_advise(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    /* madvise wants a page-aligned start; the page holding p is ours too */
    uintptr_t a = (uintptr_t)p & ~(uintptr_t)4095;
    madvise((void *)a, bytes + ((uintptr_t)p - a), MADV_HUGEPAGE);
#else
    (void)p, (void)bytes;
#endif
}

void *huge_realloc(void *p, size_t bytes)
{
    void *q = realloc(p, bytes);
    if (q && bytes >= HUGE_ARRAY_BYTES)
        huge_advise(q, bytes);
    return q;
}
