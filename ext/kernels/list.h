/* The kernel registry: the one place a kernel is named, and the one place its
 * properties are declared. Python reads them through tribench.ext.kernel_info;
 * nothing infers a property from a kernel's name.
 *
 * Adding a kernel = one file kernels/<name>.h (tb_<name>_stride, _ops, _flat,
 * _prepare, _ray and _test, see kernels.h; its #include in kernels.h), one
 * registration line below and one row in the README's Kernels table
 * (tests/test_registry.py checks all three). A native form is a kernel of
 * its own (native.h). Order is the order `tribench info` prints: the scalar
 * kernels, then the native ones.
 *
 * The columns of a registration line X(name, faces, watertight, promised_by,
 * origin, wide):
 *   faces        TB_BOTH_FACES, or TB_FRONT_FACES: back faces are culled (only
 *                det = e1 . (d x e2) > 0 counts, the vertices counter-clockwise
 *                seen from the ray's origin)
 *   watertight   TB_OPEN: no promise; or TB_WATERTIGHT: its paper promises no
 *                crack on shared edges and vertices (tribench validate holds it
 *                to 0 cracks there, and to Embree's threshold inside a sphere)
 *   promised_by  the paper that makes the watertight promise ("" for TB_OPEN)
 *   origin       TB_CLEAN, or TB_SEED_REPLAY: a faithful copy of the seed's
 *                code, flaws included, whose differences from the reference are
 *                measured and recorded, never judged
 *   wide         TB_SCALAR_ONLY, or TB_NATIVE: the kernel itself is wide, at
 *                the CPU's native width (native.h: blocks of 16 triangles, one
 *                vector per 16 float lanes), with no scalar form;
 *                TB_NATIVE_AVX2: the same, compiled for AVX2 only (the
 *                yardstick)
 * Every kernel is compiled for float32 and float64. Bytes per prepared
 * triangle (tb_<name>_stride), operations per test (tb_<name>_ops) and
 * what becomes of an exactly flat triangle
 * (tb_<name>_flat) sit beside the code they describe, in the kernel's file. */
#ifdef TB_KERNEL_FILE
/* A build of a user's kernel file (tribench.ext.load_kernels,
 * docs/own-kernel.md): its registration lines, TB_FILE_KERNELS, with the
 * columns below, are the whole list. Read here with neither TB_SCALAR_PART
 * nor TB_NATIVE_PART defined: the file's declarations alone; kernels.h and
 * native.h include it again for its code. */
#include TB_KERNEL_FILE
#ifndef TB_FILE_KERNELS
#error "a kernel file defines TB_FILE_KERNELS(X), its registration lines (docs/own-kernel.md)"
#endif
#define TB_KERNEL_LIST(X) TB_FILE_KERNELS(X)
#define TB_INTERNAL_KERNEL_LIST(X)
#else
#define TB_KERNEL_LIST(X)                                                                    \
    X(curless_seed,         TB_BOTH_FACES,  TB_OPEN,       "",                          TB_SEED_REPLAY, TB_SCALAR_ONLY) \
    X(moller_seed,          TB_BOTH_FACES,  TB_OPEN,       "",                          TB_SEED_REPLAY, TB_SCALAR_ONLY) \
    X(curless,              TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(moller_trumbore,      TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(moller_trumbore_cull, TB_FRONT_FACES, TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(baldwin_weber_12,     TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(baldwin_weber_9,      TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(havel_herout,         TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(woop,                 TB_BOTH_FACES,  TB_WATERTIGHT, "Woop, Benthin & Wald 2013", TB_CLEAN,       TB_SCALAR_ONLY) \
    X(plucker,              TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(badouel,              TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(wald,                 TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(segura_feito,         TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(kensler_shirley,      TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(shevtsov,             TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_SCALAR_ONLY) \
    X(moller_trumbore_fma,  TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(moller_trumbore_fma_exit, TB_BOTH_FACES, TB_OPEN,    "",                          TB_CLEAN,       TB_NATIVE)      \
    X(woop_fma,             TB_BOTH_FACES,  TB_WATERTIGHT, "Woop, Benthin & Wald 2013", TB_CLEAN,       TB_NATIVE)      \
    X(baldwin_weber_12_fma, TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(baldwin_weber_9_fma,  TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(havel_herout_fma,     TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(plucker_fma,          TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(curless_fma,          TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(moller_trumbore_cull_fma, TB_FRONT_FACES, TB_OPEN,   "",                          TB_CLEAN,       TB_NATIVE)      \
    X(badouel_fma,          TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(wald_fma,             TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(segura_feito_fma,     TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(kensler_shirley_fma,  TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)      \
    X(shevtsov_fma,         TB_BOTH_FACES,  TB_OPEN,       "",                          TB_CLEAN,       TB_NATIVE)

/* Internal kernels: honesty checks of the harness, not algorithms to compare,
 * with the same columns. They are compiled and callable like any kernel but
 * kept out of the user's list (tribench.ext.kernel_names() leaves them out;
 * kernel_names(internal=True) includes them).
 * moller_trumbore_aa is an A/A copy of moller_trumbore (tribench calibrate),
 * moller_seed_aa one of moller_seed (the main job's own A/A margin),
 * moller_trumbore_same calls moller_trumbore's own code (a ratio of exactly 1),
 * moller_trumbore_twice times every pass twice (a known 2x effect). The four
 * are instantiated by name in kernels.h. moller_seed_object and
 * curless_seed_object are the seed's tests as its program pays for them
 * (kernels/seed_objects.h: its objects, calls and scene loop; tribench seed). moller_trumbore_yardstick is the plain
 * AVX2 intrinsics form bench/yardstick.py times the kernels against. */
#define TB_INTERNAL_KERNEL_LIST(X)                                                           \
    X(moller_trumbore_aa,    TB_BOTH_FACES, TB_OPEN, "", TB_CLEAN, TB_SCALAR_ONLY)           \
    X(moller_seed_aa,        TB_BOTH_FACES, TB_OPEN, "", TB_SEED_REPLAY, TB_SCALAR_ONLY)     \
    X(moller_seed_object,    TB_BOTH_FACES, TB_OPEN, "", TB_SEED_REPLAY, TB_SCALAR_ONLY)     \
    X(curless_seed_object,   TB_BOTH_FACES, TB_OPEN, "", TB_SEED_REPLAY, TB_SCALAR_ONLY)     \
    X(moller_trumbore_same,  TB_BOTH_FACES, TB_OPEN, "", TB_CLEAN, TB_SCALAR_ONLY)           \
    X(moller_trumbore_twice, TB_BOTH_FACES, TB_OPEN, "", TB_CLEAN, TB_SCALAR_ONLY)           \
    X(moller_trumbore_yardstick, TB_BOTH_FACES, TB_OPEN, "", TB_CLEAN, TB_NATIVE_AVX2)
#endif /* TB_KERNEL_FILE */

/* The values of the columns. The wide column is pasted into macro names
 * (below), where an unknown value (a removed form's) would fail far from its
 * line; read once as a value here, it is an undeclared name at its line. */
enum { TB_BOTH_FACES, TB_FRONT_FACES };
enum { TB_OPEN, TB_WATERTIGHT };
enum { TB_CLEAN, TB_SEED_REPLAY };
enum { TB_SCALAR_ONLY, TB_NATIVE, TB_NATIVE_AVX2 };
#define TB_CHECK_WIDE(name, faces, watertight, promised_by, origin, wide) tb_##name##_wide_column = wide,
enum { TB_KERNEL_LIST(TB_CHECK_WIDE) TB_INTERNAL_KERNEL_LIST(TB_CHECK_WIDE) tb_wide_columns_checked };
#undef TB_CHECK_WIDE
/* TB_IF_SCALAR(wide, ...): the rest of the arguments for a scalar kernel,
 * nothing for a native one */
#define TB_IF_SCALAR(wide, ...) TB_IF_SCALAR_##wide(__VA_ARGS__)
#define TB_IF_SCALAR_TB_SCALAR_ONLY(...) __VA_ARGS__
#define TB_IF_SCALAR_TB_NATIVE(...)
#define TB_IF_SCALAR_TB_NATIVE_AVX2(...)
/* TB_IF_NATIVE_ON(wide, isa_id, ...): for a native kernel compiled for the
 * ISA of that id (TB_NATIVE_ISA_LIST) */
#define TB_IF_NATIVE_ON(wide, id, ...) TB_IF_NATIVE_ON_(wide, id, __VA_ARGS__)
#define TB_IF_NATIVE_ON_(wide, id, ...) TB_IF_NATIVE_##wide##_##id(__VA_ARGS__)
#define TB_IF_NATIVE_TB_SCALAR_ONLY_0(...)
#define TB_IF_NATIVE_TB_SCALAR_ONLY_1(...)
#define TB_IF_NATIVE_TB_SCALAR_ONLY_2(...)
#define TB_IF_NATIVE_TB_SCALAR_ONLY_3(...)
#define TB_IF_NATIVE_TB_NATIVE_0(...) __VA_ARGS__
#define TB_IF_NATIVE_TB_NATIVE_1(...) __VA_ARGS__
#define TB_IF_NATIVE_TB_NATIVE_2(...) __VA_ARGS__
#define TB_IF_NATIVE_TB_NATIVE_3(...) __VA_ARGS__
#define TB_IF_NATIVE_TB_NATIVE_AVX2_0(...)
#define TB_IF_NATIVE_TB_NATIVE_AVX2_1(...) __VA_ARGS__
#define TB_IF_NATIVE_TB_NATIVE_AVX2_2(...)
#define TB_IF_NATIVE_TB_NATIVE_AVX2_3(...)

/* The instruction sets the native kernels are compiled for (native.h, one
 * pass each, instantiated in kernels.h with these attributes), best first,
 * and the yardstick's. The baseline is the build's own ISA (SSE2 on x86-64,
 * no -march), always runnable; the AVX2 pass uses FMA too, so it runs where
 * the CPU has both (tb_isa_runnable). On aarch64 NEON (AdvSIMD, part of
 * its base ISA, so always runnable) replaces the baseline: the same 16
 * bytes, with fused multiply-adds. Elsewhere only the baseline exists. */
#if defined(__x86_64__) || defined(__i386__)
#define TB_TARGET_AVX512_FMA __attribute__((target("avx512f,fma")))
#define TB_TARGET_AVX2_FMA __attribute__((target("avx2,fma")))
#define TB_NATIVE_ISA_LIST(X, arg) X(arg, avx512) X(arg, avx2) X(arg, baseline)
#define TB_NATIVE_AVX2_ISA_LIST(X, arg) X(arg, avx2)
#elif defined(__aarch64__)
#define TB_NATIVE_ISA_LIST(X, arg) X(arg, neon)
#define TB_NATIVE_AVX2_ISA_LIST(X, arg) /* x86-64 only: the yardstick does not build here */
#else
#define TB_NATIVE_ISA_LIST(X, arg) X(arg, baseline)
#define TB_NATIVE_AVX2_ISA_LIST(X, arg) /* x86-64 only: the yardstick does not build here */
#endif
