/* ivoct mem — large arrays on transparent huge pages.
 *
 * A build, the load of a saved tree, or a writer fills hundreds of megabytes
 * of fresh memory, which the kernel maps page by page on first touch.  Where
 * a page fault is dear (a 2-vCPU virtual machine: ~5 us each, measured, so
 * 4 KiB pages fill at ~0.4 GB/s, however often the memory was used before)
 * transparent huge pages cut their number 512-fold; but a kernel set to
 * `madvise` (Debian's default) grants them only where asked, and before the
 * memory is touched.  The advice changes the mapping only: where it is
 * refused or unknown (not Linux), the arrays are ordinary memory.
 *
 * The functions never fail for the advice's sake and never print; memory from
 * them is freed with free(). */
#ifndef IVOCT_MEM_H
#define IVOCT_MEM_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Arrays from this size on ask for huge pages (mem_huge_realloc,
 * mem_huge_alloc); below it a huge page would be mostly unused. */
#define MEM_HUGE_BYTES ((size_t)4 << 20)

/* Ask for huge pages on [p, p + bytes), memory of ours not yet touched.  The
 * 2 MiB pages that lie wholly inside the range get them. */
void mem_huge_advise(void *p, size_t bytes);

/* realloc(p, bytes); when bytes >= MEM_HUGE_BYTES the block asks for huge
 * pages before its new part is touched (realloc of a large block moves its
 * pages rather than copying them, so what is added is still untouched).
 * NULL when out of memory (p is then unchanged), as realloc.  With p NULL,
 * mem_huge_alloc(bytes). */
void *mem_huge_realloc(void *p, size_t bytes);

/* malloc(bytes); from MEM_HUGE_BYTES on, a block of whole 2 MiB pages
 * (2 MiB-aligned, its size rounded up) with huge pages asked for. */
void *mem_huge_alloc(size_t bytes);

/* Give the 2 MiB-aligned stretches wholly inside [p, p + bytes) back to the
 * system, keeping the range allocated: memory of ours whose contents are no
 * longer needed, while the block it belongs to lives on (the ends, less than
 * 2 MiB each, are kept: a huge page is not split for them).  The range reads
 * as zeros or as its old contents afterwards; either way it stays valid
 * memory.  The pages freed are the next ones the kernel hands out: fresh
 * memory touched soon after (the tree filled while the pools it comes from are
 * released) reuses them, which on a virtual machine costs far less than pages
 * the host has to supply (measured: ~0.5 GB/s for those, ~10 GB/s reused). */
void mem_release(void *p, size_t bytes);

#ifdef __cplusplus
}
#endif

#endif
