/* One throughput probe function for one ISA and precision: included by
 * probes.h once per pair, with these defined (no include guard, as kernels.h):
 *   TB_P_FN       the function's name
 *   TB_P_TARGET   its target attribute (empty for the baseline)
 *   TB_P_REAL     float or double;  TB_P_V  the ISA's widest vector of it
 *   TB_P_SET1(x), TB_P_LOAD(p), TB_P_FMA(a, b, c), TB_P_MUL, TB_P_ADD, TB_P_DIV
 *   TB_P_AND(a, b), TB_P_SELECT(a, b) (a blend under a fixed mask; SSE2: an or)
 *   TB_P_LOAD_COMBINE(acc, x, y)  acc | (x & y) (AVX-512: one ternary logic op)
 *   TB_P_CMP_CHAINS, TB_P_CMP_DECL, TB_P_CMP_STEP(k, a, b), TB_P_CMP_FOLD(k)
 *                 a compare chained through its result (AVX-512: a mask register
 *                 fed back as the write mask; else the compare's own vector)
 * Every loop runs TB_P_CHAINS independent chains, enough to cover an
 * operation's latency (4-14 cycles) times its pipes on current x86 cores, so
 * throughput binds, not latency. The values stay normal (no subnormal slows
 * a core): multiply by 2 then 0.5, add 1 then -1, divide 1 by the value
 * (oscillates between x and 1/x), x * 0.999 + 0.001 (converges to 1).
 * Constants come from `c` at run time so the compiler folds nothing. */

TB_P_TARGET static double TB_P_FN(int op, uint64_t steps, const TB_P_REAL *c, double *lane_ops)
{
    enum { N = TB_P_CHAINS, LANES = (int)(sizeof(TB_P_V) / sizeof(TB_P_REAL)) };
    TB_P_V acc[N];
    const TB_P_V two = TB_P_SET1(c[0]), half = TB_P_SET1(c[1]), one = TB_P_SET1(c[2]);
    const TB_P_V minus_one = TB_P_SET1(c[3]), m = TB_P_SET1(c[4]), add = TB_P_SET1(c[5]);
    for (int k = 0; k < N; ++k)
        acc[k] = TB_P_SET1((TB_P_REAL)(k + 1));
    double per_step = 1; /* operations per chain and step */
    switch (op) {
    case TB_OP_FMA:
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_FMA(acc[k], m, add);
        break;
    case TB_OP_MUL:
        per_step = 2;
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_MUL(TB_P_MUL(acc[k], two), half);
        break;
    case TB_OP_ADD:
        per_step = 2;
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_ADD(TB_P_ADD(acc[k], one), minus_one);
        break;
    case TB_OP_CMP: {
        TB_P_CMP_DECL;
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < TB_P_CMP_CHAINS; ++k)
                TB_P_CMP_STEP(k, acc[k], two);
        TB_P_CMP_FOLD(TB_P_CMP_CHAINS);
        *lane_ops = (double)steps * TB_P_CMP_CHAINS * LANES;
        goto fold;
    }
    case TB_OP_LOGIC:
        per_step = 2;
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_SELECT(TB_P_AND(acc[k], two), half);
        break;
    case TB_OP_DIV:
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_DIV(one, acc[k]);
        break;
    case TB_OP_LOAD: {
        /* two loads per chain and step from an L1-resident buffer, its offset
         * moving with the step so no load is hoisted out of the loop */
        per_step = 2;
        const TB_P_REAL *buf = c + 64 / sizeof(TB_P_REAL); /* past the constants, 64-byte aligned */
        for (uint64_t i = 0; i < steps; ++i) {
            const TB_P_REAL *p = buf + (i & 7) * (2 * N * LANES);
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_LOAD_COMBINE(acc[k], TB_P_LOAD(p + 2 * k * LANES), TB_P_LOAD(p + (2 * k + 1) * LANES));
        }
        break;
    }
    case TB_OP_FMA_MUL: /* one FMA then one multiply by 1: do multiplies share the FMA pipes? */
        per_step = 2;
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_MUL(TB_P_FMA(acc[k], m, add), one);
        break;
    default: /* TB_OP_FMA_ADD: one FMA then one add, to learn whether adds share the FMA pipes */
        per_step = 2;
        for (uint64_t i = 0; i < steps; ++i)
            for (int k = 0; k < N; ++k)
                acc[k] = TB_P_ADD(TB_P_FMA(acc[k], m, add), add);
        break;
    }
    *lane_ops = (double)steps * N * per_step * LANES;
fold:;
    TB_P_REAL lanes[LANES];
    double sum = 0;
    for (int k = 0; k < N; ++k) {
        memcpy(lanes, &acc[k], sizeof lanes);
        for (int j = 0; j < LANES; ++j)
            sum += (double)lanes[j];
    }
    return sum;
}
