/* The kernel registry: the one place a kernel is named.
 *
 * Adding a kernel = one file kernels/<name>.h defining, for the current
 * precision, tb_<name>_stride, tb_<name>_prepare and tb_<name>_test (see
 * kernels.h), plus one include in kernels.h and one line here. Python learns
 * the names from this list; order is the order `tribench info` prints. */
#define TB_KERNEL_LIST(X) \
    X(curless_seed)       \
    X(moller_seed)        \
    X(curless)            \
    X(moller_trumbore)

/* Internal kernels: honesty checks of the harness, not algorithms to compare.
 * They are compiled and callable like any kernel but kept out of the user's
 * list (tribench.ext.kernel_names() leaves them out; kernel_names(internal=True)
 * includes them). moller_trumbore_aa is an A/A copy of moller_trumbore,
 * moller_trumbore_twice does each of its tests twice (a known 2x effect). */
#define TB_INTERNAL_KERNEL_LIST(X) \
    X(moller_trumbore_aa)          \
    X(moller_trumbore_twice)
