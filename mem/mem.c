/* ivoct mem — large arrays on transparent huge pages (mem.h). */
#define _DEFAULT_SOURCE /* madvise */
#include "mem.h"

#include <stdint.h>
#include <stdlib.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

void mem_huge_advise(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    /* madvise wants a page-aligned start; the page holding p is ours too */
    uintptr_t a = (uintptr_t)p & ~(uintptr_t)4095;
    madvise((void *)a, bytes + ((uintptr_t)p - a), MADV_HUGEPAGE);
#else
    (void)p, (void)bytes;
#endif
}

void *mem_huge_alloc(size_t bytes)
{
    if (bytes < MEM_HUGE_BYTES)
        return malloc(bytes);
    /* whole huge pages: a malloc'd block starts and ends inside pages of 4 KiB,
       up to 2 x 511 of them faulted one by one */
    const size_t page = (size_t)2 << 20;
    if (bytes > SIZE_MAX - page)
        return NULL;
    const size_t size = (bytes + page - 1) / page * page;
    void *p = aligned_alloc(page, size);
    if (p) /* all of it: a huge page is granted only inside the advised range */
        mem_huge_advise(p, size);
    return p;
}

void *mem_huge_realloc(void *p, size_t bytes)
{
    if (!p)
        return mem_huge_alloc(bytes);
    void *q = realloc(p, bytes);
    if (q && bytes >= MEM_HUGE_BYTES)
        mem_huge_advise(q, bytes);
    return q;
}

void mem_release(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_DONTNEED)
    /* only what lies wholly inside: the ends may hold bytes of others (the
       allocator's own, or live data beside the range) */
    const uintptr_t page = (uintptr_t)2 << 20;
    uintptr_t a = ((uintptr_t)p + page - 1) & ~(page - 1);
    uintptr_t b = ((uintptr_t)p + bytes) & ~(page - 1);
    if (b > a)
        madvise((void *)a, b - a, MADV_DONTNEED);
#else
    (void)p, (void)bytes;
#endif
}
