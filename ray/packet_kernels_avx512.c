/* ivoct ray — the packet walk (packet_kernels.h) for the avx512 SIMD path,
 * with the lanes' tests as one compare each into a mask register. */
#include <immintrin.h>

#include "packet_internal.h"

#define KERNEL_TARGET avx512
#define PACKET_LANE_BITS
_Static_assert(PK == 8, "a packet is one AVX-512 vector");

static inline uint32_t bits_le(const double *a, const double *b)
{
    return _mm512_cmp_pd_mask(_mm512_loadu_pd(a), _mm512_loadu_pd(b), _CMP_LE_OQ);
}

static inline uint32_t bits_lt(const double *a, const double *b)
{
    return _mm512_cmp_pd_mask(_mm512_loadu_pd(a), _mm512_loadu_pd(b), _CMP_LT_OQ);
}

#include "packet_kernels.h"
