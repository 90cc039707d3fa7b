/* Native-width wide kernels and their loop, for one precision and one ISA.
 *
 * No include guard: kernels.h includes this file once per ISA of
 * TB_NATIVE_ISA_LIST whose loops its includer compiles, for each precision
 * (and once, for the declarations alone, in a file that compiles none), with
 * TB_NISA set to the ISA's name and TB_NISA_ID to 2 (AVX-512), 1 (AVX2 + FMA),
 * 3 (NEON, aarch64) or 0 (the baseline: SSE2 on x86-64). Every symbol gets
 * the ISA and the precision as suffixes.
 *
 * The vector is the ISA's own register (__m512 / __m256 / float32x4_t /
 * __m128 and their double forms), not one generic vector type for every ISA (which would run
 * half an AVX-512 core's width, or lower wider comparisons to scalar compares
 * without AVX-512); comparisons give the ISA's own masks (__mmask16 or a
 * vector), and fused multiply-adds are explicit: 16 float / 8 double lanes
 * with AVX-512, 8 / 4 with AVX2, 4 / 2 with NEON and on the baseline (whose
 * "fused" operations are a multiply and an add, rounded twice).
 *
 * Records come in blocks of TB_NBLOCK = 16 triangles, structure of arrays
 * (field f of triangle l of a block at block[16 f + l]), whatever the ISA, so
 * one prepared layout serves every ISA: a block is one float vector with
 * AVX-512, two with AVX2, four with NEON and on the baseline (and twice as
 * many for double).
 *
 * A native kernel file kernels/<name>.h (wide column TB_NATIVE in list.h)
 * defines, like a scalar kernel, tb_<name>_stride, _ops, _flat, _prepare and
 * _ray (once per precision: in the first pass, #if TB_NFIRST), _algorithm (the
 * name of the clean scalar kernel it is a form of, as a string), and per ISA:
 *   nmask tb_<name>_test(const tb_nray *r, const real *lanes, nreal t_max, tb_nhit *h)
 *       the candidates among one vector's worth of triangles (lanes[16 f + l]):
 *       a lane is set where the hit passes every test that needs no division,
 *       with h->t, h->u, h->v scaled by h->den > 0 (t = h->t / h->den). The
 *       loop divides once per vector that has a candidate and checks
 *       0 < t < t_max on the divided t, so a kernel never divides. A kernel
 *       whose u and v have a denominator of their own (plucker_fma: the sum
 *       of its edge products) sets h->uv_den > 0 and h->uv_den_set; the loop
 *       then divides once more, only where u and v are asked for.
 *   tb_<name>_ops: operations per test and lane, counted as kernels.h says,
 *       the loop's division path included as if every vector took it. */

#define TB_NFN(name) TB_CAT(TB_CAT(name##_, TB_NISA), TB_SUFFIX)
#define nreal TB_NFN(tb_nreal)
#define nmask TB_NFN(tb_nmask)
#define nbits TB_NFN(tb_nbits)
#define tb_nray TB_NFN(tb_nray)
#define tb_nhit TB_NFN(tb_nhit)
#define TB_NBLOCK 16
/* helpers and kernels: inlined into the entries, compiled for this ISA */
#define TB_NWIDE static inline __attribute__((always_inline)) TB_NTARGET

/* The ISA's vector (nreal), mask (nmask), and the few operations that
 * differ between ISAs; everything else is written with vector-extension
 * operators (+ - * / and bit operations on nbits), which GCC lowers to the
 * ISA's own instructions. Comparisons are ordered: a NaN lane is false. */
#if TB_NISA_ID == 2 && !TB_REAL_IS_DOUBLE
typedef __m512 nreal;
typedef __mmask16 nmask;
#define TB_NL 16
#define nv_set1 _mm512_set1_ps
#define nv_fmadd _mm512_fmadd_ps
#define nv_fmsub _mm512_fmsub_ps
#define nv_fnmadd _mm512_fnmadd_ps
#define nv_cmp(a, b, op) _mm512_cmp_ps_mask(a, b, op)
#define nv_select(m, a, b) _mm512_mask_blend_ps(m, b, a)
#define nm_and(a, b) ((nmask)((a) & (b)))
#define nm_or(a, b) ((nmask)((a) | (b)))
#define nm_any(m) ((m) != 0)
#define nm_bits(m) ((unsigned)(m))
#define nv_min _mm512_min_ps
#define nv_max _mm512_max_ps
#elif TB_NISA_ID == 2
typedef __m512d nreal;
typedef __mmask8 nmask;
#define TB_NL 8
#define nv_set1 _mm512_set1_pd
#define nv_fmadd _mm512_fmadd_pd
#define nv_fmsub _mm512_fmsub_pd
#define nv_fnmadd _mm512_fnmadd_pd
#define nv_cmp(a, b, op) _mm512_cmp_pd_mask(a, b, op)
#define nv_select(m, a, b) _mm512_mask_blend_pd(m, b, a)
#define nm_and(a, b) ((nmask)((a) & (b)))
#define nm_or(a, b) ((nmask)((a) | (b)))
#define nm_any(m) ((m) != 0)
#define nm_bits(m) ((unsigned)(m))
#define nv_min _mm512_min_pd
#define nv_max _mm512_max_pd
#elif TB_NISA_ID == 1 && !TB_REAL_IS_DOUBLE
typedef __m256 nreal;
typedef __m256 nmask;
#define TB_NL 8
#define nv_set1 _mm256_set1_ps
#define nv_fmadd _mm256_fmadd_ps
#define nv_fmsub _mm256_fmsub_ps
#define nv_fnmadd _mm256_fnmadd_ps
#define nv_cmp(a, b, op) _mm256_cmp_ps(a, b, op)
#define nv_select(m, a, b) _mm256_blendv_ps(b, a, m)
#define nm_and _mm256_and_ps
#define nm_or _mm256_or_ps
#define nm_any(m) (_mm256_movemask_ps(m) != 0)
#define nm_bits(m) ((unsigned)_mm256_movemask_ps(m))
#define nv_min _mm256_min_ps
#define nv_max _mm256_max_ps
#elif TB_NISA_ID == 1
typedef __m256d nreal;
typedef __m256d nmask;
#define TB_NL 4
#define nv_set1 _mm256_set1_pd
#define nv_fmadd _mm256_fmadd_pd
#define nv_fmsub _mm256_fmsub_pd
#define nv_fnmadd _mm256_fnmadd_pd
#define nv_cmp(a, b, op) _mm256_cmp_pd(a, b, op)
#define nv_select(m, a, b) _mm256_blendv_pd(b, a, m)
#define nm_and _mm256_and_pd
#define nm_or _mm256_or_pd
#define nm_any(m) (_mm256_movemask_pd(m) != 0)
#define nm_bits(m) ((unsigned)_mm256_movemask_pd(m))
#define nv_min _mm256_min_pd
#define nv_max _mm256_max_pd
#elif TB_NISA_ID == 3 /* NEON (AdvSIMD, aarch64): 16 bytes, with fused multiply-adds */
#if TB_REAL_IS_DOUBLE
typedef float64x2_t nreal;
typedef uint64x2_t nmask;
#define TB_NL 2
#define TB_NV(op) op##_f64
#define TB_NM(op) op##_u64
/* no vmaxvq_u64: the largest 32-bit half of either lane */
#define nm_any(m) (vmaxvq_u32(vreinterpretq_u32_u64(m)) != 0)
#else
typedef float32x4_t nreal;
typedef uint32x4_t nmask;
#define TB_NL 4
#define TB_NV(op) op##_f32
#define TB_NM(op) op##_u32
#define nm_any(m) (vmaxvq_u32(m) != 0)
#endif
#define nv_set1 TB_NV(vdupq_n)
/* vfmaq(c, a, b) = c + a b and vfmsq(c, a, b) = c - a b, each rounded
 * once; a b - c is a b plus c negated (exact), so it is rounded once too */
#define nv_fmadd(a, b, c) TB_NV(vfmaq)(c, a, b)
#define nv_fmsub(a, b, c) TB_NV(vfmaq)(TB_NV(vnegq)(c), a, b)
#define nv_fnmadd(a, b, c) TB_NV(vfmsq)(c, a, b)
#define nv_cmp(a, b, op) TB_NCMP_##op(a, b)
#define TB_NCMP__CMP_GE_OQ TB_NV(vcgeq)
#define TB_NCMP__CMP_GT_OQ TB_NV(vcgtq)
#define TB_NCMP__CMP_LE_OQ TB_NV(vcleq)
#define TB_NCMP__CMP_LT_OQ TB_NV(vcltq)
#define TB_NCMP__CMP_EQ_OQ TB_NV(vceqq)
#define nv_select(m, a, b) TB_NV(vbslq)(m, a, b)
#define nm_and TB_NM(vandq)
#define nm_or TB_NM(vorrq)
#define nm_bits(m) TB_NFN(tb_nbits_of)(m)
/* the x86 forms' min and max (the second operand on a NaN or a tie), not
 * vminq's or vminnmq's, whose NaN rules differ */
#define nv_min(a, b) nv_select(nv_lt(a, b), a, b)
#define nv_max(a, b) nv_select(nv_gt(a, b), a, b)
/* no movemask on NEON: lane l keeps bit l alone, and an add across the
 * lanes gathers them */
TB_NWIDE unsigned TB_NFN(tb_nbits_of)(nmask m)
{
#if TB_REAL_IS_DOUBLE
    const uint64x2_t bit = {1, 2};
    return (unsigned)vaddvq_u64(vandq_u64(m, bit));
#else
    const uint32x4_t bit = {1, 2, 4, 8};
    return vaddvq_u32(vandq_u32(m, bit));
#endif
}
#else /* the baseline: plain vector extensions, 16 bytes (SSE2 on x86-64) */
typedef real nreal __attribute__((vector_size(16)));
typedef mask_elem nmask __attribute__((vector_size(16)));
#define TB_NL ((int)(16 / sizeof(real)))
#define nv_set1(x) ((x) - (nreal){0})
#define nv_fmadd(a, b, c) ((a) * (b) + (c))
#define nv_fmsub(a, b, c) ((a) * (b) - (c))
#define nv_fnmadd(a, b, c) ((c) - (a) * (b))
#define nv_cmp(a, b, op) TB_NCMP_##op(a, b)
#define TB_NCMP__CMP_GE_OQ(a, b) ((a) >= (b))
#define TB_NCMP__CMP_GT_OQ(a, b) ((a) > (b))
#define TB_NCMP__CMP_LE_OQ(a, b) ((a) <= (b))
#define TB_NCMP__CMP_LT_OQ(a, b) ((a) < (b))
#define TB_NCMP__CMP_EQ_OQ(a, b) ((a) == (b))
#define nv_select(m, a, b) ((nreal)(((m) & (nmask)(a)) | (~(m) & (nmask)(b))))
#define nm_and(a, b) ((a) & (b))
#define nm_or(a, b) ((a) | (b))
#define nm_any(m) TB_FN(tb_nany)(m)
#define nm_bits(m) TB_FN(tb_nbits_of)(m)
#define nv_min(a, b) nv_select(nv_lt(a, b), a, b)
#define nv_max(a, b) nv_select(nv_gt(a, b), a, b)
TB_NWIDE int TB_FN(tb_nany)(nmask m)
{
    uint64_t w[sizeof m / 8], any = 0;
    memcpy(w, &m, sizeof m);
    for (size_t k = 0; k < sizeof m / 8; ++k)
        any |= w[k];
    return any != 0;
}
/* n lanes of a vector mask as the low bits of an integer (bvh.h's box masks too) */
TB_NWIDE unsigned TB_FN(tb_lane_bits)(const mask_elem *lanes, int n)
{
    unsigned bits = 0;
    for (int l = 0; l < n; ++l)
        bits |= (unsigned)(lanes[l] != 0) << l;
    return bits;
}
TB_NWIDE unsigned TB_FN(tb_nbits_of)(nmask m)
{
    mask_elem lanes[TB_NL];
    memcpy(lanes, &m, sizeof lanes);
    return TB_FN(tb_lane_bits)(lanes, TB_NL);
}
#endif
/* the lanes' bits as integers, for sign and absolute-value masks */
typedef mask_elem nbits __attribute__((vector_size(sizeof(nreal))));
#define TB_NVPB (TB_NBLOCK / TB_NL) /* vectors per block */

/* the ray in every lane; kx, ky, kz and the shear sx, sy, sz are the per-ray
 * data of the kernels that have it (Woop's, see tb_ray); a kernel that does
 * not read them costs nothing for them (the loop's stores are dead code) */
typedef struct {
    nreal o[3], d[3];
    int kx, ky, kz;
    nreal sx, sy, sz;
} tb_nray;

/* a kernel's ray (its make_ray's tb_ray) in every lane */
TB_NWIDE tb_nray TB_NFN(tb_nray_of)(const tb_ray *s)
{
    tb_nray r;
    for (int k = 0; k < 3; ++k) {
        r.o[k] = nv_set1(s->o[k]);
        r.d[k] = nv_set1(s->d[k]);
    }
    r.kx = s->kx;
    r.ky = s->ky;
    r.kz = s->kz;
    r.sx = nv_set1(s->sx);
    r.sy = nv_set1(s->sy);
    r.sz = nv_set1(s->sz);
    return r;
}

typedef struct {
    nreal t, u, v, den;
    nreal uv_den;   /* u = h->u / uv_den where the kernel sets uv_den_set, else / den */
    int uv_den_set; /* 0 unless the kernel sets it (the loop clears it) */
} tb_nhit;

/* what scales a hit's u and v (inv = 1 / den, what scales its t) */
TB_NWIDE nreal TB_NFN(tb_nhit_uv_inv)(const tb_nhit *h, nreal inv)
{
    if (h->uv_den_set)
        return nv_set1((real)1) / h->uv_den;
    return inv;
}

/* one field of one vector's worth of triangles, any alignment */
TB_NWIDE nreal TB_NFN(nv_load)(const real *p)
{
    nreal v;
    memcpy(&v, p, sizeof v);
    return v;
}

#define nv_load TB_NFN(nv_load)
#define nv_ge(a, b) nv_cmp(a, b, _CMP_GE_OQ)
#define nv_gt(a, b) nv_cmp(a, b, _CMP_GT_OQ)
#define nv_le(a, b) nv_cmp(a, b, _CMP_LE_OQ)
#define nv_lt(a, b) nv_cmp(a, b, _CMP_LT_OQ)
#define nv_eq(a, b) nv_cmp(a, b, _CMP_EQ_OQ)

/* the ray in each lane's axis order k, k + 1, k + 2 (mod 3), with k (0, 1 or 2) read per lane from
 * a record field: the projection tests drop axis k; two selects per component */
TB_NWIDE void TB_NFN(tb_nray_by_axis)(const tb_nray *r, nreal axis, nreal o[3], nreal d[3])
{
    const nmask is1 = nv_eq(axis, nv_set1(1)), is2 = nv_eq(axis, nv_set1(2));
    for (int j = 0; j < 3; ++j) {
        o[j] = nv_select(is1, r->o[(j + 1) % 3], nv_select(is2, r->o[(j + 2) % 3], r->o[j]));
        d[j] = nv_select(is1, r->d[(j + 1) % 3], nv_select(is2, r->d[(j + 2) % 3], r->d[j]));
    }
}

#ifdef TB_KERNEL_FILE /* a build of a user's kernel file (kernels/list.h): its native part */
#define TB_NATIVE_PART 1
#include TB_KERNEL_FILE
#undef TB_NATIVE_PART
#else
#include "kernels/moller_trumbore_fma.h"
#include "kernels/moller_trumbore_fma_exit.h"
#include "kernels/baldwin_weber_12_fma.h"
#include "kernels/baldwin_weber_9_fma.h"
#include "kernels/moller_trumbore_yardstick.h"
#include "kernels/woop_fma.h"
#include "kernels/havel_herout_fma.h"
#include "kernels/plucker_fma.h"
#include "kernels/curless_fma.h"
#include "kernels/moller_trumbore_cull_fma.h"
#include "kernels/badouel_fma.h"
#include "kernels/wald_fma.h"
#include "kernels/segura_feito_fma.h"
#include "kernels/kensler_shirley_fma.h"
#include "kernels/shevtsov_fma.h"
#endif

typedef nmask (*TB_NFN(tb_native_fn))(const tb_nray *restrict, const real *restrict, nreal,
                                      tb_nhit *restrict);

/* One batch of a native kernel: each ray against blocks of 16 triangles, one
 * vector at a time. Each lane keeps its own closest hit (its t is that lane's
 * t_max for the next block), so lanes never talk to each other inside the
 * triangle loop; one reduction per ray picks the closest lane, ties to the
 * lowest index. Lanes past the last triangle are masked off. Pairs are not a
 * wide mode (one ray against one triangle has no triangles to spread over
 * lanes). The per-vector bookkeeping, behind one branch taken only
 * when a lane is a candidate: one division, 0 < t < t_max, and the selects
 * of t (u and v when asked) and of the block number (the lane gives the rest
 * of the index). */
TB_NWIDE void
TB_NFN(tb_native_loop)(TB_NFN(tb_native_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                       tb_job *job, const int mode, const int timed)
{
    const real *o = job->origins, *d = job->directions, *rec = job->records;
    const real *t_max = job->t_max;
    const size_t n_blocks = (job->n_records + TB_NBLOCK - 1) / TB_NBLOCK;
    const size_t last = job->n_records - (n_blocks - 1) * TB_NBLOCK; /* triangles in the last block */
    nmask tail[TB_NVPB];
    for (int v = 0; v < TB_NVPB; ++v) {
        real lane[TB_NL];
        for (int l = 0; l < TB_NL; ++l)
            lane[l] = (real)(v * TB_NL + l);
        tail[v] = nv_lt(nv_load(lane), nv_set1((real)last));
    }
    const nreal zero = nv_set1(0), one = nv_set1(1);
    uint64_t hits = 0, tests = 0, rays = 0, poll_at = 1;
    double t_sum = 0, uv_sum = 0;
    const uint64_t loops = timed ? job->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < job->n_rays; ++i) {
            if (++rays == poll_at && !(poll_at = tb_poll(job, rays)))
                goto stop;
            tb_ray scalar_ray;
            make_ray(o + 3 * i, d + 3 * i, &scalar_ray);
            const tb_nray r = TB_NFN(tb_nray_of)(&scalar_ray);
            nreal best_t[TB_NVPB], best_u[TB_NVPB], best_v[TB_NVPB], best_b[TB_NVPB];
            for (int v = 0; v < TB_NVPB; ++v) {
                best_t[v] = nv_set1(t_max[i]);
                best_u[v] = best_v[v] = nv_set1((real)NAN);
                best_b[v] = (nreal)((nbits)zero - 1); /* block -1: no hit */
            }
            size_t b = 0;
            for (; b < n_blocks; ++b) {
                int found = 0;
                for (int v = 0; v < TB_NVPB; ++v) {
                    tb_nhit h;
                    h.uv_den_set = 0;
                    nmask m = test(&r, rec + stride * TB_NBLOCK * b + v * TB_NL, best_t[v], &h);
                    if (b == n_blocks - 1)
                        m = nm_and(m, tail[v]);
                    if (!nm_any(m))
                        continue;
                    nreal inv = one / h.den, t = h.t * inv;
                    m = nm_and(m, nm_and(nv_gt(t, zero), nv_lt(t, best_t[v])));
                    best_t[v] = nv_select(m, t, best_t[v]);
                    if (mode == TB_CLOSEST_UV || !timed) {
                        const nreal inv_uv = TB_NFN(tb_nhit_uv_inv)(&h, inv);
                        best_u[v] = nv_select(m, h.u * inv_uv, best_u[v]);
                        best_v[v] = nv_select(m, h.v * inv_uv, best_v[v]);
                    }
                    best_b[v] = nv_select(m, (nreal)((nbits)zero + (mask_elem)b), best_b[v]);
                    found |= nm_any(m);
                }
                if (mode == TB_ANY && found) {
                    ++b;
                    break;
                }
            }
            tests += b < n_blocks ? TB_NBLOCK * b : job->n_records;
            /* the closest lane; ties to the lowest triangle index */
            real t_of[TB_NBLOCK], u_of[TB_NBLOCK], v_of[TB_NBLOCK];
            mask_elem block_of[TB_NBLOCK];
            memcpy(t_of, best_t, sizeof t_of);
            memcpy(u_of, best_u, sizeof u_of);
            memcpy(v_of, best_v, sizeof v_of);
            memcpy(block_of, best_b, sizeof block_of);
            int best = -1;
            int64_t index = -1;
            for (int l = 0; l < TB_NBLOCK; ++l) {
                int64_t at = (int64_t)block_of[l] * TB_NBLOCK + l;
                if (block_of[l] >= 0 &&
                    (best < 0 || t_of[l] < t_of[best] || (t_of[l] == t_of[best] && at < index))) {
                    best = l;
                    index = at;
                }
            }
            if (timed) {
                if (best >= 0) {
                    ++hits;
                    t_sum += t_of[best];
                    if (mode == TB_CLOSEST_UV)
                        uv_sum += (double)u_of[best] + v_of[best];
                }
            } else {
                real *t_out = job->t_out, *u_out = job->u_out, *v_out = job->v_out;
                job->index_out[i] = index;
                t_out[i] = best >= 0 ? t_of[best] : (real)NAN;
                u_out[i] = best >= 0 ? u_of[best] : (real)NAN;
                v_out[i] = best >= 0 ? v_of[best] : (real)NAN;
            }
        }
stop:
    job->hits = hits;
    job->tests = tests;
    job->t_sum = t_sum;
    job->uv_sum = uv_sum;
}

/* Entry points of one native kernel for this ISA: every mode but pairs; as
 * the scalar kernels', the timed ones with their mode compiled in, the
 * untimed ones through one loop that takes it. */
#define TB_NATIVE_ENTRY(name, fn_mode, mode, timed)                                           \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_##fn_mode)(tb_job *job)                      \
    {                                                                                         \
        TB_NFN(tb_native_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray),              \
                               tb_##name##_stride, job, mode, timed);                         \
    }
#define TB_NATIVE_RUN(name, fn_mode, mode)                                                    \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_##fn_mode)(tb_job *job)                      \
    {                                                                                         \
        TB_NFN(tb_##name##_run)(job, mode);                                                   \
    }
#define TB_NATIVE_ENTRIES(name)                                                               \
    static TB_SHARED_LOOP TB_NTARGET void TB_NFN(tb_##name##_run)(tb_job *job, int mode)      \
    {                                                                                         \
        TB_NFN(tb_native_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray),              \
                               tb_##name##_stride, job, mode, 0);                             \
    }                                                                                         \
    TB_NATIVE_RUN(name, run_any, TB_ANY)                                                      \
    TB_NATIVE_RUN(name, run_closest, TB_CLOSEST_UV)                                           \
    TB_NATIVE_ENTRY(name, time_any, TB_ANY, 1)                                                \
    TB_NATIVE_ENTRY(name, time_closest, TB_CLOSEST, 1)                                        \
    TB_NATIVE_ENTRY(name, time_closest_uv, TB_CLOSEST_UV, 1)
#define TB_NATIVE_INSTANTIATE(name, faces, watertight, promised_by, origin, wide) \
    TB_IF_NATIVE_ON(wide, TB_NISA_ID, TB_NATIVE_ENTRIES(name))
#if TB_CAT(TB_EMIT_, TB_NISA) /* not in the declarations-only pass (kernels.h) */
TB_KERNEL_LIST(TB_NATIVE_INSTANTIATE)
TB_INTERNAL_KERNEL_LIST(TB_NATIVE_INSTANTIATE)
#endif
#undef TB_NATIVE_INSTANTIATE
#undef TB_NATIVE_ENTRIES
#undef TB_NATIVE_ENTRY
#undef TB_NATIVE_RUN

#include "bvh.h"       /* the BVH build and check (first pass) */
#include "bvh_trace.h" /* its traversals, with these kernels' block tests at the leaves */

#undef nv_eq
#undef nv_lt
#undef nv_le
#undef nv_gt
#undef nv_ge
#undef nv_load
#undef TB_NVPB
#undef nv_max
#undef nv_min
#undef nm_any
#undef nm_bits
#undef nm_or
#undef nm_and
#undef nv_select
#undef nv_cmp
#undef nv_fnmadd
#undef nv_fmsub
#undef nv_fmadd
#undef nv_set1
#undef TB_NL
#undef TB_NV
#undef TB_NM
#undef TB_NCMP__CMP_GE_OQ
#undef TB_NCMP__CMP_GT_OQ
#undef TB_NCMP__CMP_LE_OQ
#undef TB_NCMP__CMP_LT_OQ
#undef TB_NCMP__CMP_EQ_OQ
#undef TB_NBLOCK
#undef TB_NWIDE
#undef tb_nhit
#undef tb_nray
#undef nbits
#undef nmask
#undef nreal
#undef TB_NFN
