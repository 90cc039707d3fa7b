/* The wide loops compiled for AVX2 with FMA (the yardstick's too), in
 * float32: the native kernels (native.h) and their BVH traversals
 * (bvh_trace.h). One file per ISA and precision: the largest files of the
 * build, of about one size, so a parallel build keeps every core busy. */

#include "core.h"

#if defined(__x86_64__) || defined(__i386__) /* x86 only (kernels/list.h) */
#define TB_EMIT_SCALAR 0
#define TB_EMIT_avx512 0
#define TB_EMIT_avx2 1
#define TB_EMIT_neon 0
#define TB_EMIT_baseline 0
#define TB_REAL float
#define TB_REAL_IS_DOUBLE 0
#define TB_SUFFIX _f32
#include "kernels.h"
#endif
