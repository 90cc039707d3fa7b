/* The wide loops compiled for NEON (AdvSIMD, with fused multiply-adds) on
 * aarch64, in float32: the native kernels (native.h) and their BVH traversals
 * (bvh_trace.h). Empty elsewhere. On aarch64 the scalar loops stay in
 * isa_baseline_f32.c, whose native pass NEON replaces (kernels/list.h). */

#include "core.h"

#if defined(__aarch64__) /* elsewhere no NEON pass exists (kernels/list.h) */
#define TB_EMIT_SCALAR 0
#define TB_EMIT_avx512 0
#define TB_EMIT_avx2 0
#define TB_EMIT_neon 1
#define TB_EMIT_baseline 0
#define TB_REAL float
#define TB_REAL_IS_DOUBLE 0
#define TB_SUFFIX _f32
#include "kernels.h"
#endif
