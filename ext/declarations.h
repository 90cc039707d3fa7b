/* Every kernel's declarations (stride, ops, flat, mix, prepare) at both precisions, and no loop:
 * for the files that reach the kernels through their entry points without compiling any
 * (registry.c, bvh.c). No include guard: each of them includes it once. */

#define TB_EMIT_SCALAR 0
#define TB_EMIT_avx512 0
#define TB_EMIT_avx2 0
#define TB_EMIT_neon 0
#define TB_EMIT_baseline 0

#define TB_REAL float
#define TB_REAL_IS_DOUBLE 0
#define TB_SUFFIX _f32
#include "kernels.h"
#undef TB_REAL
#undef TB_REAL_IS_DOUBLE
#undef TB_SUFFIX

#define TB_REAL double
#define TB_REAL_IS_DOUBLE 1
#define TB_SUFFIX _f64
#include "kernels.h"
#undef TB_REAL
#undef TB_REAL_IS_DOUBLE
#undef TB_SUFFIX
