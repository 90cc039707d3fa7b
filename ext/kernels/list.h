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
