/* ivoct ray — the packet walk (packet_kernels.h) for the avx512 SIMD path. */
#define KERNEL_TARGET avx512
#define PACKET_MASK_AVX512 /* the lanes' tests as one compare each */
#include "packet_kernels.h"
