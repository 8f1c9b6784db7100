/* ivoct — the affine pass (affine_kernels.h) for the avx512 SIMD path. */
#define KERNEL_TARGET avx512
#include "affine_kernels.h"
