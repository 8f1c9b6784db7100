/* ivoct ray — the packet walk (packet_kernels.h) for the avx512 SIMD path. */
#define KERNEL_TARGET avx512
#include "packet_kernels.h"
