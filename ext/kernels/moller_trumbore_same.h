/* moller_trumbore_same: moller_trumbore's own code under another name, for
 * the harness's check of its intervals on a ratio known to be exactly 1.
 *
 * Internal kernel (TB_INTERNAL_KERNEL_LIST). moller_trumbore_aa is the same
 * source compiled again: its code sits elsewhere in the module and, measured,
 * costs a percent or two more or less than the original (a layout effect no
 * process-level randomisation varies, docs/decisions.md "Coverage on a real
 * machine"). So its true ratio is not known, and it cannot tell a biased
 * harness from a layout effect. This kernel's entry points call
 * moller_trumbore's: one call per batch of milliseconds, the timed loop
 * itself the very same instructions, so its true cost ratio is 1 to within
 * 1e-6. A harness that times it apart from moller_trumbore, beyond its
 * interval more often than 5% of the time, is biased (bench/coverage.py).
 * Included by kernels.h after moller_trumbore's entry points exist. */

#define tb_moller_trumbore_same_stride tb_moller_trumbore_stride
#define tb_moller_trumbore_same_ops tb_moller_trumbore_ops
#define tb_moller_trumbore_same_flat tb_moller_trumbore_flat
#define tb_moller_trumbore_same_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_same_prepare_f64 tb_prepare_vertices_f64

#define TB_SAME_ENTRY(fn_mode)                                             \
    TB_HIDDEN void TB_FN(tb_moller_trumbore_same_##fn_mode)(tb_job *job)   \
    {                                                                      \
        TB_FN(tb_moller_trumbore_##fn_mode)(job);                          \
    }
#if TB_EMIT_SCALAR /* in the file that compiles moller_trumbore's (kernels.h) */
TB_SAME_ENTRY(run_pairs)
TB_SAME_ENTRY(run_any)
TB_SAME_ENTRY(run_closest)
TB_SAME_ENTRY(time_pairs)
TB_SAME_ENTRY(time_any)
TB_SAME_ENTRY(time_closest)
TB_SAME_ENTRY(time_closest_uv)
#endif
#undef TB_SAME_ENTRY

/* per class: moller_trumbore's */
#define tb_moller_trumbore_same_mix tb_moller_trumbore_mix
