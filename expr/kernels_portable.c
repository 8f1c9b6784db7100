/* ivoct — the evaluators' passes (kernels.h) for the portable SIMD path. */
#define KERNEL_TARGET portable
#define KERNEL_SHORT_LANES 0 /* two lanes a vector: padding a short batch costs more */
#define KERNEL_SHORT_HALF 0
#include "kernels.h"
