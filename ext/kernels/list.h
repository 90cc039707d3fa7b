/* The kernel registry: the one place a kernel is named.
 *
 * Adding a kernel = one file kernels/<name>.h defining, for the current
 * precision, tb_<name>_stride, tb_<name>_prepare, tb_<name>_ray and
 * tb_<name>_test (see kernels.h), one include in kernels.h and one line
 * here. Its wide form is one file kernels/<name>_x8.h, one include and one
 * line in TB_WIDE_KERNEL_LIST. Python learns the names from these lists;
 * order is the order `tribench info` prints. */
#define TB_KERNEL_LIST(X)   \
    X(curless_seed)         \
    X(moller_seed)          \
    X(curless)              \
    X(moller_trumbore)      \
    X(moller_trumbore_cull) \
    X(baldwin_weber_12)     \
    X(baldwin_weber_9)      \
    X(havel_herout)         \
    X(woop)                 \
    X(plucker)

/* Kernels that also have a wide form, registered as <name>_x8: branchless,
 * one ray against blocks of 8 triangles stored structure of arrays. */
#define TB_WIDE_KERNEL_LIST(X) \
    X(curless)                 \
    X(moller_trumbore)         \
    X(moller_trumbore_cull)    \
    X(baldwin_weber_12)        \
    X(baldwin_weber_9)         \
    X(havel_herout)            \
    X(woop)                    \
    X(plucker)

/* Internal kernels: honesty checks of the harness, not algorithms to compare.
 * They are compiled and callable like any kernel but kept out of the user's
 * list (tribench.ext.kernel_names() leaves them out; kernel_names(internal=True)
 * includes them). moller_trumbore_aa is an A/A copy of moller_trumbore,
 * moller_trumbore_twice times every pass twice (a known 2x effect). Both are
 * instantiated by name in kernels.h. */
#define TB_INTERNAL_KERNEL_LIST(X) \
    X(moller_trumbore_aa)          \
    X(moller_trumbore_twice)

/* The instruction sets each wide kernel is compiled for, best first: name,
 * function attribute, and the run-time test that the CPU can run it. The
 * baseline is the build's own ISA (SSE2 on x86-64, no -march), always
 * runnable. On other architectures only the baseline exists. */
#if defined(__x86_64__) || defined(__i386__)
#define TB_ISA_LIST(X, name)                                                       \
    X(name, avx512, __attribute__((target("avx512f"))))                            \
    X(name, avx2, __attribute__((target("avx2"))))                                 \
    X(name, baseline, )
#define TB_ISA_NAMES {"avx512", "avx2", "baseline"}
#define TB_ISA_RUNNABLE {__builtin_cpu_supports("avx512f"), __builtin_cpu_supports("avx2"), 1}
#else
#define TB_ISA_LIST(X, name) X(name, baseline, )
#define TB_ISA_NAMES {"baseline"}
#define TB_ISA_RUNNABLE {1}
#endif
