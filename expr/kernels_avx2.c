/* ivoct — the evaluators' passes (kernels.h) for the avx2 SIMD path. */
#define KERNEL_TARGET avx2
#include "kernels.h"
