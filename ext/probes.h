/* Throughput probes: how many lane-operations per ns this core does of each
 * operation class the kernels use, at each vector width it has.
 *
 * One probe = one class on one ISA in one precision: TB_P_CHAINS independent
 * chains of that operation on the ISA's widest vector (AVX-512: 16 float / 8
 * double lanes; AVX2 with FMA: 8 / 4; NEON with FMA on aarch64 and the
 * baseline SSE2: 4 / 2), timed in C by the caller. The bodies are
 * probe_body.h, included once per ISA and precision, compiled for the ISA by
 * a target attribute and chosen at run time by CPU features, as the native
 * kernels are (kernels/list.h: TB_NATIVE_ISA_LIST).
 *
 * The classes (tribench.harness.peak explains the port model that uses them):
 *   fma      a fused multiply-add (SSE2 has none: a multiply then an add,
 *            counted as one operation, the cost of an FMA there)
 *   mul, add, div   one multiply, add or divide
 *   cmp      a compare (AVX-512: into a mask register, chained through the
 *            write mask, as `a & (x < y)` lowers; else into a vector)
 *   logic    a bitwise and, then a select (AVX-512: a masked blend; AVX2:
 *            blendv; SSE2: an or)
 *   load     a vector load from L1 (two per step, combined by one ternary
 *            logic op on AVX-512, an and and an or elsewhere)
 *   fma_add  an FMA then an add, both counted: a rate near fma's says adds
 *            share the FMA pipes, a rate above it says the core has adders
 *            of its own (AMD Zen's FADD pipes)
 *   fma_mul  an FMA then a multiply, both counted: the same question for
 *            multiplies (they share the FMA pipes on every current x86 core,
 *            so its rate is fma's; measured, not assumed) */

#include <string.h>

enum { TB_OP_FMA, TB_OP_MUL, TB_OP_ADD, TB_OP_CMP, TB_OP_LOGIC, TB_OP_DIV, TB_OP_LOAD, TB_OP_FMA_ADD, TB_OP_FMA_MUL, TB_N_OPS };
static const char *const tb_op_names[TB_N_OPS] = {"fma", "mul", "add", "cmp", "logic", "div", "load", "fma_add",
                                                    "fma_mul"};

#define TB_P_CHAINS 12
/* the constants (8 reals) then the load probe's buffer: 8 offsets x 2 N vectors
 * of 64 bytes, 12 KiB, resident in L1 */
#define TB_P_BUF_BYTES (8 * 2 * TB_P_CHAINS * 64)
static _Alignas(64) unsigned char tb_probe_data_f32[64 + TB_P_BUF_BYTES], tb_probe_data_f64[64 + TB_P_BUF_BYTES];

typedef double (*tb_probe_fn)(int op, uint64_t steps, const void *c, double *lane_ops);

/* ---- baseline: the build's ISA (SSE2 on x86-64), GCC vector extensions */
#define TB_P_TARGET
#define TB_P_CMP_CHAINS TB_P_CHAINS
#define TB_P_CMP_DECL
#define TB_P_CMP_STEP(k, a, b) (acc[k] = (TB_P_V)((a) < (b)))
#define TB_P_CMP_FOLD(n)
#define TB_P_FMA(a, b, c) ((a) * (b) + (c))
#define TB_P_MUL(a, b) ((a) * (b))
#define TB_P_ADD(a, b) ((a) + (b))
#define TB_P_DIV(a, b) ((a) / (b))
#define TB_P_LOAD(p) (*(const TB_P_V *)__builtin_assume_aligned((p), 16))
#define TB_P_BITS(x) ((TB_P_IV)(x))
#define TB_P_AND(a, b) ((TB_P_V)(TB_P_BITS(a) & TB_P_BITS(b)))
#define TB_P_SELECT(a, b) ((TB_P_V)(TB_P_BITS(a) | TB_P_BITS(b)))
#define TB_P_LOAD_COMBINE(a, x, y) ((TB_P_V)(TB_P_BITS(a) | (TB_P_BITS(x) & TB_P_BITS(y))))
typedef float tb_p_v4f __attribute__((vector_size(16)));
typedef int32_t tb_p_v4i32 __attribute__((vector_size(16)));
typedef double tb_p_v2d __attribute__((vector_size(16)));
typedef int64_t tb_p_v2i64 __attribute__((vector_size(16)));
#define TB_P_SET1(x) ((TB_P_V){0} + (x))
#define TB_P_FN tb_probe_baseline_f32
#define TB_P_REAL float
#define TB_P_V tb_p_v4f
#define TB_P_IV tb_p_v4i32
#include "probe_body.h"
#undef TB_P_FN
#undef TB_P_REAL
#undef TB_P_V
#undef TB_P_IV
#define TB_P_FN tb_probe_baseline_f64
#define TB_P_REAL double
#define TB_P_V tb_p_v2d
#define TB_P_IV tb_p_v2i64
#include "probe_body.h"
#undef TB_P_FN
#undef TB_P_REAL
#undef TB_P_V
#undef TB_P_IV
#undef TB_P_TARGET
#undef TB_P_FMA
#undef TB_P_SET1
#undef TB_P_LOAD

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>

/* ---- AVX2 with FMA: 256-bit vectors; everything but the FMA as above */
#define TB_P_TARGET __attribute__((target("avx2,fma")))
#define TB_P_SET1(x) ((TB_P_V){0} + (x))
#define TB_P_LOAD(p) (*(const TB_P_V *)__builtin_assume_aligned((p), 32))
typedef float tb_p_v8f __attribute__((vector_size(32)));
typedef int32_t tb_p_v8i32 __attribute__((vector_size(32)));
typedef double tb_p_v4d __attribute__((vector_size(32)));
typedef int64_t tb_p_v4i64 __attribute__((vector_size(32)));
#undef TB_P_SELECT
#define TB_P_FN tb_probe_avx2_f32
#define TB_P_REAL float
#define TB_P_V tb_p_v8f
#define TB_P_IV tb_p_v8i32
#define TB_P_FMA(a, b, c) ((TB_P_V)_mm256_fmadd_ps((__m256)(a), (__m256)(b), (__m256)(c)))
#define TB_P_SELECT(a, b) ((TB_P_V)_mm256_blendv_ps((__m256)(a), (__m256)(b), (__m256)one))
#include "probe_body.h"
#undef TB_P_FN
#undef TB_P_REAL
#undef TB_P_V
#undef TB_P_IV
#undef TB_P_FMA
#undef TB_P_SELECT
#define TB_P_FN tb_probe_avx2_f64
#define TB_P_REAL double
#define TB_P_V tb_p_v4d
#define TB_P_IV tb_p_v4i64
#define TB_P_FMA(a, b, c) ((TB_P_V)_mm256_fmadd_pd((__m256d)(a), (__m256d)(b), (__m256d)(c)))
#define TB_P_SELECT(a, b) ((TB_P_V)_mm256_blendv_pd((__m256d)(a), (__m256d)(b), (__m256d)one))
#include "probe_body.h"
#undef TB_P_FN
#undef TB_P_REAL
#undef TB_P_V
#undef TB_P_IV
#undef TB_P_FMA
#undef TB_P_SELECT
#undef TB_P_TARGET
#undef TB_P_SET1
#undef TB_P_LOAD

/* ---- AVX-512F: 512-bit vectors, compares into mask registers (7 usable, so
 * 6 compare chains), blends and the load probe's combine as single ops */
#define TB_P_TARGET __attribute__((target("avx512f")))
#define TB_P_SET1(x) ((TB_P_V){0} + (x))
#define TB_P_LOAD(p) (*(const TB_P_V *)__builtin_assume_aligned((p), 64))
#undef TB_P_CMP_CHAINS
#undef TB_P_CMP_DECL
#undef TB_P_CMP_STEP
#undef TB_P_CMP_FOLD
#undef TB_P_LOAD_COMBINE
#define TB_P_CMP_CHAINS 6
#define TB_P_LOAD_COMBINE(a, x, y)                                                                 \
    ((TB_P_V)_mm512_ternarylogic_epi32((__m512i)(a), (__m512i)(x), (__m512i)(y), 0xF8))
typedef float tb_p_v16f __attribute__((vector_size(64)));
typedef int32_t tb_p_v16i32 __attribute__((vector_size(64)));
typedef double tb_p_v8d __attribute__((vector_size(64)));
typedef int64_t tb_p_v8i64 __attribute__((vector_size(64)));
#define TB_P_FN tb_probe_avx512_f32
#define TB_P_REAL float
#define TB_P_V tb_p_v16f
#define TB_P_IV tb_p_v16i32
#define TB_P_FMA(a, b, c) ((TB_P_V)_mm512_fmadd_ps((__m512)(a), (__m512)(b), (__m512)(c)))
#define TB_P_SELECT(a, b) ((TB_P_V)_mm512_mask_blend_ps((__mmask16)0x5555, (__m512)(a), (__m512)(b)))
#define TB_P_CMP_DECL __mmask16 km[TB_P_CMP_CHAINS] = {0xffff, 0xffff, 0xffff, 0xffff, 0xffff, 0xffff}
#define TB_P_CMP_STEP(k, a, b) (km[k] = _mm512_mask_cmp_ps_mask(km[k], (__m512)(a), (__m512)(b), _CMP_LT_OQ))
#define TB_P_CMP_FOLD(n)                                                                           \
    for (int k = 0; k < (n); ++k)                                                                  \
        acc[k] = (TB_P_V)_mm512_mask_mov_ps((__m512)acc[k], km[k], (__m512)half)
#include "probe_body.h"
#undef TB_P_FN
#undef TB_P_REAL
#undef TB_P_V
#undef TB_P_IV
#undef TB_P_FMA
#undef TB_P_SELECT
#undef TB_P_CMP_DECL
#undef TB_P_CMP_STEP
#undef TB_P_CMP_FOLD
#define TB_P_FN tb_probe_avx512_f64
#define TB_P_REAL double
#define TB_P_V tb_p_v8d
#define TB_P_IV tb_p_v8i64
#define TB_P_FMA(a, b, c) ((TB_P_V)_mm512_fmadd_pd((__m512d)(a), (__m512d)(b), (__m512d)(c)))
#define TB_P_SELECT(a, b) ((TB_P_V)_mm512_mask_blend_pd((__mmask8)0x55, (__m512d)(a), (__m512d)(b)))
#define TB_P_CMP_DECL __mmask8 km[TB_P_CMP_CHAINS] = {0xff, 0xff, 0xff, 0xff, 0xff, 0xff}
#define TB_P_CMP_STEP(k, a, b) (km[k] = _mm512_mask_cmp_pd_mask(km[k], (__m512d)(a), (__m512d)(b), _CMP_LT_OQ))
#define TB_P_CMP_FOLD(n)                                                                           \
    for (int k = 0; k < (n); ++k)                                                                  \
        acc[k] = (TB_P_V)_mm512_mask_mov_pd((__m512d)acc[k], km[k], (__m512d)half)
#include "probe_body.h"

#define TB_PROBE_ISAS {"avx512", "avx2", "baseline"}
#define TB_PROBE_RUNNABLE                                                                          \
    {__builtin_cpu_supports("avx512f"), __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"), 1}
#define TB_PROBE_FNS                                                                               \
    {{(tb_probe_fn)tb_probe_avx512_f32, (tb_probe_fn)tb_probe_avx512_f64},                         \
     {(tb_probe_fn)tb_probe_avx2_f32, (tb_probe_fn)tb_probe_avx2_f64},                             \
     {(tb_probe_fn)tb_probe_baseline_f32, (tb_probe_fn)tb_probe_baseline_f64}}
#elif defined(__aarch64__)
#include <arm_neon.h>

/* ---- NEON: the baseline's 128-bit vectors with a fused multiply-add, as
 * the native kernels' NEON form has (native.h); every aarch64 CPU runs it */
#define TB_P_TARGET
#define TB_P_SET1(x) ((TB_P_V){0} + (x))
#define TB_P_LOAD(p) (*(const TB_P_V *)__builtin_assume_aligned((p), 16))
#define TB_P_FN tb_probe_neon_f32
#define TB_P_REAL float
#define TB_P_V tb_p_v4f
#define TB_P_IV tb_p_v4i32
#define TB_P_FMA(a, b, c) ((TB_P_V)vfmaq_f32((float32x4_t)(c), (float32x4_t)(a), (float32x4_t)(b)))
#include "probe_body.h"
#undef TB_P_FN
#undef TB_P_REAL
#undef TB_P_V
#undef TB_P_IV
#undef TB_P_FMA
#define TB_P_FN tb_probe_neon_f64
#define TB_P_REAL double
#define TB_P_V tb_p_v2d
#define TB_P_IV tb_p_v2i64
#define TB_P_FMA(a, b, c) ((TB_P_V)vfmaq_f64((float64x2_t)(c), (float64x2_t)(a), (float64x2_t)(b)))
#include "probe_body.h"

#define TB_PROBE_ISAS {"neon", "baseline"}
#define TB_PROBE_RUNNABLE {1, 1}
#define TB_PROBE_FNS                                                                               \
    {{(tb_probe_fn)tb_probe_neon_f32, (tb_probe_fn)tb_probe_neon_f64},                             \
     {(tb_probe_fn)tb_probe_baseline_f32, (tb_probe_fn)tb_probe_baseline_f64}}
#else
#define TB_PROBE_ISAS {"baseline"}
#define TB_PROBE_RUNNABLE {1}
#define TB_PROBE_FNS {{(tb_probe_fn)tb_probe_baseline_f32, (tb_probe_fn)tb_probe_baseline_f64}}
#endif

static const char *const tb_probe_isas[] = TB_PROBE_ISAS;
#define TB_N_PROBE_ISAS ((int)(sizeof tb_probe_isas / sizeof *tb_probe_isas))

/* Whether this CPU runs probe ISA i. */
static int tb_probe_runnable(int i)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_cpu_init();
#endif
    const int runnable[] = TB_PROBE_RUNNABLE;
    return runnable[i];
}

/* Fill the constants and the load buffer of one precision (once). */
static void *tb_probe_constants(int itemsize)
{
    static int filled[2];
    unsigned char *data = itemsize == 4 ? tb_probe_data_f32 : tb_probe_data_f64;
    if (!filled[itemsize == 8]) {
        const double c[8] = {2.0, 0.5, 1.0, -1.0, 0.999, 1e-3, 0, 0};
        for (size_t i = 0; i < sizeof tb_probe_data_f32 / (size_t)itemsize; ++i) {
            double x = i < 8 ? c[i] : 1.0;
            if (itemsize == 4) {
                float f = (float)x;
                memcpy(data + i * 4, &f, 4);
            } else
                memcpy(data + i * 8, &x, 8);
        }
        filled[itemsize == 8] = 1;
    }
    return data;
}
