/* ivoct — the evaluators' passes (kernels.h) for the avx2 SIMD path. */
#define KERNEL_TARGET avx2
#define KERNEL_SHORT_LANES 0 /* the short passes measured slower here (kernels.h) */
#define KERNEL_SHORT_HALF 0
#include "kernels.h"
