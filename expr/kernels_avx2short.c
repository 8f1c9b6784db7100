/* ivoct — the short passes of the avx2 SIMD path (kernels.h, "short batches"),
 * compiled apart from kernels_avx2.c with their own flags (expr/CMakeLists.txt). */
#define KERNEL_TARGET avx2
#define KERNEL_SHORT_LANES KERNEL_ALIGN
#define KERNEL_SHORT_HALF 4
#define KERNEL_SHORT_APART 1
#define KERNEL_SHORT_UNIT 1
/* the other passes' helpers, static in kernels.h, are not used here */
#pragma GCC diagnostic ignored "-Wunused-function"
#include "kernels.h"
