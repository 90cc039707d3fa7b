/* moller_seed_aa: moller_seed compiled a second time under another name.
 *
 * Internal kernel (TB_INTERNAL_KERNEL_LIST): the A/A twin of the main job's
 * baseline. `tribench run` times it beside moller_seed on every workload
 * moller_seed runs, and the spread of the twin's speedups over those
 * workloads is the run's own equivalence margin (reports/tables/margin, docs/
 * methodology.md). Built as moller_trumbore_aa is (see there): the source is
 * included again with its test renamed, and TB_NO_ICF (core.h) keeps GCC
 * from folding the twin's loops back into moller_seed's. See
 * moller_seed.h for the algorithm. */

#define tb_moller_seed_test tb_moller_seed_aa_test
#include "moller_seed.h"
#undef tb_moller_seed_test

#define tb_moller_seed_aa_stride tb_moller_seed_stride
#define tb_moller_seed_aa_ops tb_moller_seed_ops
#define tb_moller_seed_aa_flat tb_moller_seed_flat
#define tb_moller_seed_aa_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_seed_aa_prepare_f64 tb_prepare_vertices_f64
#define tb_moller_seed_aa_ray_f32 tb_ray_plain_f32
#define tb_moller_seed_aa_ray_f64 tb_ray_plain_f64

#define tb_moller_seed_aa_mix tb_moller_seed_mix /* per class, as moller_seed */
