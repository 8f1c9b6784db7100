/* ivoct — the affine pass (affine_kernels.h) for the portable SIMD path. */
#define KERNEL_TARGET portable
#include "affine_kernels.h"
