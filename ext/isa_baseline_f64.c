/* The loops compiled for the build's own ISA (SSE2 on x86-64: no -march), in
 * float64: every scalar kernel's (kernels.h) and the baseline form of the wide
 * ones: the native kernels (native.h) and their BVH traversals
 * (bvh_trace.h). One file per ISA and precision: the largest files of the
 * build, of about one size, so a parallel build keeps every core busy. The
 * scalar loops are here rather than in a file of their own for GCC's
 * inliner: it stops inlining once a file has grown by --param
 * inline-unit-growth, and a file of scalar loops alone would call each
 * kernel's test out of line for every triangle (tests/test_ext_build.py
 * checks that no loop calls its test). */

#include "core.h"

#define TB_EMIT_SCALAR 1
#define TB_EMIT_avx512 0
#define TB_EMIT_avx2 0
#define TB_EMIT_neon 0
#if defined(__aarch64__) /* NEON replaces the baseline there (kernels/list.h) */
#define TB_EMIT_baseline 0
#else
#define TB_EMIT_baseline 1
#endif
#define TB_REAL double
#define TB_REAL_IS_DOUBLE 1
#define TB_SUFFIX _f64
#include "kernels.h"
