/* ivoct ray — the packet walk (packet_kernels.h) for the avx2 SIMD path, with
 * the lanes' tests as two compares and a movemask each: gcc gathers the
 * generic lane loop's results into bits one lane at a time. */
#include <immintrin.h>

#include "packet_internal.h"

#define KERNEL_TARGET avx2
#define PACKET_LANE_BITS
_Static_assert(PK == 8, "a packet is two AVX2 vectors");

static inline uint32_t bits_le(const double *a, const double *b)
{
    __m256d lo = _mm256_cmp_pd(_mm256_loadu_pd(a), _mm256_loadu_pd(b), _CMP_LE_OQ);
    __m256d hi = _mm256_cmp_pd(_mm256_loadu_pd(a + 4), _mm256_loadu_pd(b + 4), _CMP_LE_OQ);
    return (uint32_t)_mm256_movemask_pd(lo) | (uint32_t)_mm256_movemask_pd(hi) << 4;
}

static inline uint32_t bits_lt(const double *a, const double *b)
{
    __m256d lo = _mm256_cmp_pd(_mm256_loadu_pd(a), _mm256_loadu_pd(b), _CMP_LT_OQ);
    __m256d hi = _mm256_cmp_pd(_mm256_loadu_pd(a + 4), _mm256_loadu_pd(b + 4), _CMP_LT_OQ);
    return (uint32_t)_mm256_movemask_pd(lo) | (uint32_t)_mm256_movemask_pd(hi) << 4;
}

#include "packet_kernels.h"
