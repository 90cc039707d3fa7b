/* moller_trumbore_aa: moller_trumbore compiled a second time under another name.
 *
 * Internal kernel (TB_INTERNAL_KERNEL_LIST), for the A/A calibration of
 * `tribench calibrate`: the same source compiled twice is the same algorithm
 * as a separate function with its own code layout, so any difference the
 * harness measures between the two is noise (layout, alignment, drift) and
 * sets the equivalence margin. The source is included again with its test
 * renamed, which defines a new function; TB_NO_ICF (core.h) keeps GCC from
 * folding it back into moller_trumbore's (before it did, the twin's entry
 * points were jumps into the original's code). See moller_trumbore.h for the
 * algorithm. */

#define tb_moller_trumbore_test tb_moller_trumbore_aa_test
#include "moller_trumbore.h"
#undef tb_moller_trumbore_test

#define tb_moller_trumbore_aa_stride tb_moller_trumbore_stride
#define tb_moller_trumbore_aa_ops tb_moller_trumbore_ops
#define tb_moller_trumbore_aa_flat tb_moller_trumbore_flat
#define tb_moller_trumbore_aa_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_aa_prepare_f64 tb_prepare_vertices_f64
#define tb_moller_trumbore_aa_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_aa_ray_f64 tb_ray_plain_f64

#define tb_moller_trumbore_aa_mix tb_moller_trumbore_mix /* per class, as moller_trumbore */
