/* ivoct — the evaluators' passes (kernels.h) for the portable SIMD path. */
#define KERNEL_TARGET portable
#include "kernels.h"
