/* ivoct ray — the packet walk (packet_kernels.h) for the avx2 SIMD path. */
#define KERNEL_TARGET avx2
#include "packet_kernels.h"
