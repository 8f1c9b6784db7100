/* ivoct — the evaluators' passes (kernels.h) for the avx2 SIMD path. */
#define KERNEL_TARGET avx2
#define KERNEL_SHORT_LANES KERNEL_ALIGN /* a short batch: two vectors per lane loop */
#define KERNEL_SHORT_HALF 4             /* half of it: one vector */
#define KERNEL_SHORT_APART 1            /* in kernels_avx2short.c (kernels.h) */
#include "kernels.h"
