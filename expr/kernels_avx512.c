/* ivoct — the evaluators' passes (kernels.h) for the avx512 SIMD path. */
#define KERNEL_TARGET avx512
#include "kernels.h"
