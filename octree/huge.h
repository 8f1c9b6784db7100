/* ivoct octree — large arrays on transparent huge pages (internal to octree/).
 *
 * A build, or the load of a saved tree, fills hundreds of megabytes of fresh
 * memory, which the kernel maps page by page on first touch.  Where a page
 * fault is dear (a 2-vCPU virtual machine: ~5 us each, measured; the faults
 * of 4 KiB pages were a quarter of a one-thread build and most of a load)
 * transparent huge pages cut their number 512-fold, but a kernel set to
 * `madvise` grants them only where asked, and before the memory is touched.
 * The advice changes the mapping only; where it is refused or unknown (not
 * Linux) the arrays are ordinary memory. */
#ifndef IVOCT_OCTREE_HUGE_H
#define IVOCT_OCTREE_HUGE_H

#include <stddef.h>

/* Arrays from this size on ask for huge pages. */
#define HUGE_ARRAY_BYTES ((size_t)4 << 20)

/* Ask for huge pages on [p, p + bytes), memory of ours not yet touched. */
void huge_advise(void *p, size_t bytes);

/* realloc(p, bytes); when bytes >= HUGE_ARRAY_BYTES the block asks for huge
 * pages before its new part is touched (realloc of a large block moves its
 * pages rather than copying them, so what is added is still untouched). */
void *huge_realloc(void *p, size_t bytes);

#endif
