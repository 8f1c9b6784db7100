/* ivoct — the affine pass (affine_kernels.h) for the avx2 SIMD path. */
#define KERNEL_TARGET avx2
#include "affine_kernels.h"
