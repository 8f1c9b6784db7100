/* ivoct ray — the packet walk (packet_kernels.h) for the portable SIMD path. */
#define KERNEL_TARGET portable
#include "packet_kernels.h"
