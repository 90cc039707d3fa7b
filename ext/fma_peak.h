/* The FMA peak probe: how many flops per second this core does right now.
 *
 * A short loop of independent multiply-adds on 8 float lanes. With AVX2 and
 * FMA (checked at run time with __builtin_cpu_supports, compiled for them with
 * a target attribute, so the rest of the build keeps its baseline ISA) one
 * _mm256_fmadd_ps is 16 flops; TB_PEAK_CHAINS independent accumulators cover
 * the FMA latency (4-5 cycles) times the FMA ports (2) of current x86 cores,
 * so the loop is bound by throughput, not latency. On aarch64 NEON's
 * vfmaq_f32 (8 flops, always there) runs 16 chains: Neoverse V1/V2
 * (Graviton 3/4) have 4 FMA pipes of latency 4. Elsewhere a portable
 * scalar loop of separate multiplies and adds (no contraction: the build has
 * -ffp-contract=off) gives the scalar peak, and says so.
 *
 * Each accumulator follows acc = acc * m + c with 0 < m < 1: it converges to
 * c / (1 - m), so no value overflows or becomes subnormal (subnormals would
 * slow some cores down); NEON's chains add m c each pass instead (fmla's
 * accumulator is its addend), growing by at most 2^28 x 1e-3, far from
 * overflow. The sum of the accumulators is returned so the
 * compiler cannot delete the loop.
 *
 * The harness's worker runs the probe at the start and end of each process,
 * so each estimate can be stated as a fraction of the peak of that moment. */

#include <stdint.h>

#define TB_PEAK_CHAINS 12

typedef struct {
    double flops;    /* floating-point operations done (an FMA counts 2) */
    int64_t elapsed_ns;
    double sink;     /* sum of the accumulators (keeps the work alive) */
    const char *isa; /* "avx2+fma", "neon+fma" or "scalar" */
} tb_peak;

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define TB_PEAK_X86 1

__attribute__((target("avx2,fma"))) static double tb_peak_avx2(uint64_t iterations)
{
    __m256 acc[TB_PEAK_CHAINS];
    const __m256 m = _mm256_set1_ps(0.999f), c = _mm256_set1_ps(1e-3f);
    for (int k = 0; k < TB_PEAK_CHAINS; ++k)
        acc[k] = _mm256_set1_ps((float)k);
    for (uint64_t i = 0; i < iterations; ++i)
        for (int k = 0; k < TB_PEAK_CHAINS; ++k) /* unrolled by the compiler: independent chains */
            acc[k] = _mm256_fmadd_ps(acc[k], m, c);
    __m256 total = acc[0];
    for (int k = 1; k < TB_PEAK_CHAINS; ++k)
        total = _mm256_add_ps(total, acc[k]);
    float lanes[8];
    _mm256_storeu_ps(lanes, total);
    double sum = 0;
    for (int j = 0; j < 8; ++j)
        sum += lanes[j];
    return sum;
}
#endif

#if defined(__aarch64__)
#include <arm_neon.h>
#define TB_PEAK_NEON 1
/* 4 pipes x latency 4: 16 chains in flight, named, not an array, which GCC
 * keeps in memory at this size (a store per chain and pass) */
#define TB_PEAK_NEON_CHAINS 16
#define TB_PEAK_NEON_EACH(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7) X(8) X(9) X(10) X(11) X(12) X(13) X(14) X(15)

static double tb_peak_neon(uint64_t iterations)
{
    const float32x4_t m = vdupq_n_f32(0.999f), c = vdupq_n_f32(1e-3f);
#define TB_PEAK_NEON_INIT(k) float32x4_t acc##k = vdupq_n_f32((float)k);
#define TB_PEAK_NEON_STEP(k) acc##k = vfmaq_f32(acc##k, m, c); /* fmla adds into its destination: acc as the addend */
#define TB_PEAK_NEON_SUM(k) total = vaddq_f32(total, acc##k);
    TB_PEAK_NEON_EACH(TB_PEAK_NEON_INIT)
    for (uint64_t i = 0; i < iterations; ++i) {
        TB_PEAK_NEON_EACH(TB_PEAK_NEON_STEP)
    }
    float32x4_t total = vdupq_n_f32(0);
    TB_PEAK_NEON_EACH(TB_PEAK_NEON_SUM)
#undef TB_PEAK_NEON_SUM
#undef TB_PEAK_NEON_STEP
#undef TB_PEAK_NEON_INIT
    return vaddvq_f32(total);
}
#endif

static double tb_peak_scalar(uint64_t iterations)
{
    float acc[TB_PEAK_CHAINS];
    const float m = 0.999f, c = 1e-3f;
    for (int k = 0; k < TB_PEAK_CHAINS; ++k)
        acc[k] = (float)k;
    for (uint64_t i = 0; i < iterations; ++i)
        for (int k = 0; k < TB_PEAK_CHAINS; ++k)
            acc[k] = acc[k] * m + c;
    double sum = 0;
    for (int k = 0; k < TB_PEAK_CHAINS; ++k)
        sum += acc[k];
    return sum;
}

/* Runs `iterations` passes over the chains with the best ISA available (or
 * the scalar loop if `force_scalar`); timed with tb_now_ns, defined by the
 * includer. */
static tb_peak tb_fma_peak(uint64_t iterations, int force_scalar)
{
    tb_peak r;
    int64_t start, stop;
#ifdef TB_PEAK_X86
    if (!force_scalar && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
        start = tb_now_ns();
        r.sink = tb_peak_avx2(iterations);
        stop = tb_now_ns();
        r.flops = 2.0 * 8 * TB_PEAK_CHAINS * (double)iterations;
        r.elapsed_ns = stop - start;
        r.isa = "avx2+fma";
        return r;
    }
#endif
#ifdef TB_PEAK_NEON
    if (!force_scalar) {
        start = tb_now_ns();
        r.sink = tb_peak_neon(iterations);
        stop = tb_now_ns();
        r.flops = 2.0 * 4 * TB_PEAK_NEON_CHAINS * (double)iterations;
        r.elapsed_ns = stop - start;
        r.isa = "neon+fma";
        return r;
    }
#endif
    (void)force_scalar;
    start = tb_now_ns();
    r.sink = tb_peak_scalar(iterations);
    stop = tb_now_ns();
    r.flops = 2.0 * TB_PEAK_CHAINS * (double)iterations;
    r.elapsed_ns = stop - start;
    r.isa = "scalar";
    return r;
}
