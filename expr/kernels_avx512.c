/* ivoct — the evaluators' passes (kernels.h) for the avx512 SIMD path. */
#define KERNEL_TARGET avx512
#define KERNEL_SHORT_LANES KERNEL_ALIGN /* a short batch: one vector per lane loop */
#define KERNEL_SHORT_HALF 4 /* half a vector: half the cost on Zen 4 (kernels.h) */
#include "kernels.h"
