/* Benchmark: the interval product on AVX-512 with ivoct's outward widening
 * (iv_mul of expr/interval.h, vectorised by the compiler over structure-of-
 * arrays lanes, as in the evaluators' kernels) against AVX-512's per-instruction
 * rounding (_mm512_mul_round_pd toward -inf and +inf, the rounding mode left
 * alone).  Both keep iv_mul's meaning: 0 * inf is 0, an empty operand gives an
 * empty product, a factor [0,0] gives exactly 0.
 *
 * Why this is a benchmark and not a path: the two give different last bits
 * (the directed product is tighter by an ulp or two), and every SIMD path must
 * give the same tree (docs/BENCHMARKS.md, "AVX-512"); this measures what the
 * per-instruction rounding would be worth.
 *
 * Usage: ivoct_round_avx512 [SECONDS]: ns per product per lane of each, and the
 * share of bounds where the directed product is tighter (and a check that it
 * is never looser).  Exits 0 with a note where the CPU has no AVX-512. */
#define _POSIX_C_SOURCE 200809L
#include <immintrin.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "../expr/interval.h"

enum { N = 64, SETS = 64 }; /* a batch of lanes, as TAPE_BATCH; SETS batches in cache */

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct {
    double al[N], ah[N], bl[N], bh[N];
} operands_t;

/* iv_mul over the lanes: what the kernels do (kernels.h, K(interval)) */
__attribute__((noinline)) static void mul_widened(const operands_t *x, double *restrict ol,
                                                  double *restrict oh)
{
    for (int k = 0; k < N; k++) {
        iv_t r = iv_mul(iv_make(x->al[k], x->ah[k]), iv_make(x->bl[k], x->bh[k]));
        ol[k] = r.lo, oh[k] = r.hi;
    }
}

/* a product bound with 0 * inf = 0 */
static inline __m512d bound(__m512d p)
{
    return _mm512_mask_mov_pd(p, _mm512_cmp_pd_mask(p, p, _CMP_UNORD_Q), _mm512_setzero_pd());
}

#define RD (_MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC)
#define RU (_MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC)

__attribute__((noinline)) static void mul_directed(const operands_t *x, double *restrict ol,
                                                   double *restrict oh)
{
    const __m512d nan = _mm512_set1_pd(NAN);
    for (int k = 0; k < N; k += 8) {
        __m512d al = _mm512_loadu_pd(x->al + k), ah = _mm512_loadu_pd(x->ah + k);
        __m512d bl = _mm512_loadu_pd(x->bl + k), bh = _mm512_loadu_pd(x->bh + k);
        __m512d lo = _mm512_min_pd(
            _mm512_min_pd(bound(_mm512_mul_round_pd(al, bl, RD)),
                          bound(_mm512_mul_round_pd(al, bh, RD))),
            _mm512_min_pd(bound(_mm512_mul_round_pd(ah, bl, RD)),
                          bound(_mm512_mul_round_pd(ah, bh, RD))));
        __m512d hi = _mm512_max_pd(
            _mm512_max_pd(bound(_mm512_mul_round_pd(al, bl, RU)),
                          bound(_mm512_mul_round_pd(al, bh, RU))),
            _mm512_max_pd(bound(_mm512_mul_round_pd(ah, bl, RU)),
                          bound(_mm512_mul_round_pd(ah, bh, RU))));
        __mmask8 empty = _mm512_cmp_pd_mask(al, ah, _CMP_UNORD_Q) |
                         _mm512_cmp_pd_mask(bl, bh, _CMP_UNORD_Q);
        _mm512_storeu_pd(ol + k, _mm512_mask_mov_pd(lo, empty, nan));
        _mm512_storeu_pd(oh + k, _mm512_mask_mov_pd(hi, empty, nan));
    }
}

static uint64_t rng = 0x726f756e64ULL;
static double uniform(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) * 0x1p-53;
}

/* operands like a tape's on small cells: mostly small widths, every sign class */
static void fill(operands_t *x)
{
    for (int k = 0; k < N; k++) {
        double a = 4 * uniform() - 2, b = 4 * uniform() - 2;
        double wa = uniform() * 0.1, wb = uniform() * 0.1;
        x->al[k] = a, x->ah[k] = a + wa, x->bl[k] = b, x->bh[k] = b + wb;
    }
}

int main(int argc, char **argv)
{
    double seconds = argc > 1 ? atof(argv[1]) : 1.0;
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("avx512f")) {
        printf("ivoct_round_avx512: this CPU has no AVX-512; nothing measured\n");
        return 0;
    }
    static operands_t x[SETS];
    static double ol[SETS][N], oh[SETS][N], dl[SETS][N], dh[SETS][N];
    for (int s = 0; s < SETS; s++)
        fill(&x[s]);

    /* the directed product is never looser than the widened one, and tighter where */
    long tighter = 0, looser = 0, bounds = 0;
    for (int s = 0; s < SETS; s++) {
        mul_widened(&x[s], ol[s], oh[s]);
        mul_directed(&x[s], dl[s], dh[s]);
        for (int k = 0; k < N; k++) {
            tighter += (dl[s][k] > ol[s][k]) + (dh[s][k] < oh[s][k]);
            looser += (dl[s][k] < ol[s][k]) + (dh[s][k] > oh[s][k]);
            bounds += 2;
        }
    }

    double best[2] = {1e30, 1e30};
    for (int rep = 0; rep < 5; rep++)
        for (int v = 0; v < 2; v++) {
            long calls = 0;
            double t0 = now(), t;
            do {
                for (int s = 0; s < SETS; s++)
                    (v ? mul_directed : mul_widened)(&x[s], v ? dl[s] : ol[s], v ? dh[s] : oh[s]);
                calls += SETS;
            } while ((t = now() - t0) < seconds / 10);
            double ns = 1e9 * t / ((double)calls * N);
            best[v] = ns < best[v] ? ns : best[v];
        }
    printf("interval product, ns per lane (best of 5): widened %.3f  directed %.3f  "
           "widened/directed %.2f\n",
           best[0], best[1], best[0] / best[1]);
    printf("bounds tighter with directed rounding: %.1f%%; looser: %ld of %ld\n",
           100.0 * (double)tighter / (double)bounds, looser, bounds);
    return looser ? 1 : 0;
}
