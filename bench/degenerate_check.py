"""What a per-test check for flat (zero-area) triangles would cost, against none.

tribench decides flatness once per triangle when it prepares the records (exact
arithmetic, ``tribench.ext.flat``) and gives a flat triangle NaN records, which
every clean test already rejects: no cost per test. The alternatives put a check
in the test itself. This script compiles, with the extension's flags
(``-O3 -ffp-contract=off``), three forms of Moller-Trumbore's late-division test
(``ext/kernels/moller_trumbore.h``) in one small C program:

* ``none``: the test as tribench runs it (flat triangles already poisoned);
* ``flag``: a per-triangle flag stored in the record (10 reals, not 9), read and
  tested first: the cheapest check a test can make;
* ``normal``: the test computes ``n = e1 x e2`` and rejects ``n == 0`` (9 more
  operations; and not even exact: rounding makes a flat triangle's n nonzero);

and times each on a closest-hit workload (rays against 1024 random triangles,
float32 and float64), 21 interleaved repetitions of each, printing the median
ns per test and each check's ratio to ``none`` measured side by side in one run.
About 5 s. Run: ``python bench/degenerate_check.py``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

from tribench.harness.machine import cpu_model

SOURCE = r"""#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define FORMS(real)                                                                       \
static inline int mt_##real(const real *o, const real *d, const real *tri, int check,     \
                            real t_max, real *t_out)                                       \
{                                                                                          \
    real e1[3], e2[3], p[3], s[3], q[3];                                                   \
    if (check == 1 && tri[9] != 0)                                                         \
        return 0;                                                                          \
    for (int k = 0; k < 3; ++k) {                                                          \
        e1[k] = tri[3 + k] - tri[k];                                                       \
        e2[k] = tri[6 + k] - tri[k];                                                       \
        s[k] = o[k] - tri[k];                                                              \
    }                                                                                      \
    if (check == 2) {                                                                      \
        real n0 = e1[1] * e2[2] - e1[2] * e2[1], n1 = e1[2] * e2[0] - e1[0] * e2[2],      \
             n2 = e1[0] * e2[1] - e1[1] * e2[0];                                           \
        if (n0 == 0 && n1 == 0 && n2 == 0)                                                 \
            return 0;                                                                      \
    }                                                                                      \
    p[0] = d[1] * e2[2] - d[2] * e2[1];                                                    \
    p[1] = d[2] * e2[0] - d[0] * e2[2];                                                    \
    p[2] = d[0] * e2[1] - d[1] * e2[0];                                                    \
    real det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];                                 \
    if (det == 0)                                                                          \
        return 0;                                                                          \
    real sign = det < 0 ? -1 : 1, abs_det = sign * det;                                    \
    real u = sign * (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]);                             \
    if (!(u >= 0 && u <= abs_det))                                                         \
        return 0;                                                                          \
    q[0] = s[1] * e1[2] - s[2] * e1[1];                                                    \
    q[1] = s[2] * e1[0] - s[0] * e1[2];                                                    \
    q[2] = s[0] * e1[1] - s[1] * e1[0];                                                    \
    real v = sign * (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]);                             \
    if (!(v >= 0 && u + v <= abs_det))                                                     \
        return 0;                                                                          \
    real scaled_t = sign * (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]);                   \
    if (!(scaled_t > 0 && scaled_t < t_max * abs_det))                                     \
        return 0;                                                                          \
    real t = scaled_t / abs_det;                                                           \
    if (!(t > 0 && t < t_max))                                                             \
        return 0;                                                                          \
    *t_out = t;                                                                            \
    return 1;                                                                              \
}
/* one function per check: the check is a constant, as in a compiled kernel */
#define RUN(real, check)                                                                   \
__attribute__((noinline)) static double run_##real##_##check(const real *o, const real *d, \
                                                          int n_rays, const real *rec,     \
                                                          int stride, int n_tris)          \
{                                                                                          \
    double sum = 0;                                                                        \
    for (int i = 0; i < n_rays; ++i) {                                                     \
        real best = (real)1e30, t;                                                         \
        for (int j = 0; j < n_tris; ++j)                                                   \
            if (mt_##real(o + 3 * i, d + 3 * i, rec + stride * j, check, best, &t))        \
                best = t;                                                                  \
        sum += best;                                                                       \
    }                                                                                      \
    return sum;                                                                            \
}
FORMS(float)
FORMS(double)
RUN(float, 0)
RUN(float, 1)
RUN(float, 2)
RUN(double, 0)
RUN(double, 1)
RUN(double, 2)

static double run(int precision, int check, const void *o, const void *d, int n_rays, const void *rec,
                  int stride, int n_tris)
{
    if (precision == 0)
        return check == 0 ? run_float_0(o, d, n_rays, rec, stride, n_tris)
             : check == 1 ? run_float_1(o, d, n_rays, rec, stride, n_tris)
                          : run_float_2(o, d, n_rays, rec, stride, n_tris);
    return check == 0 ? run_double_0(o, d, n_rays, rec, stride, n_tris)
         : check == 1 ? run_double_1(o, d, n_rays, rec, stride, n_tris)
                      : run_double_2(o, d, n_rays, rec, stride, n_tris);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double uniform(void) { return rand() / (double)RAND_MAX * 2 - 1; }

int main(void)
{
    enum { RAYS = 1024, TRIS = 1024, REPS = 21 };
    static float of[3 * RAYS], df[3 * RAYS], rf[10 * TRIS];
    static double od[3 * RAYS], dd[3 * RAYS], rd[10 * TRIS];
    srand(1);
    for (int i = 0; i < 3 * RAYS; ++i) {
        od[i] = of[i] = (float)(3 * uniform());
        dd[i] = df[i] = (float)uniform();
    }
    for (int j = 0; j < TRIS; ++j) {
        for (int k = 0; k < 9; ++k)
            rd[10 * j + k] = rf[10 * j + k] = (float)uniform();
        rd[10 * j + 9] = rf[10 * j + 9] = 0;
    }
    const char *names[3] = {"none", "flag", "normal"};
    for (int precision = 0; precision < 2; ++precision) {
        double ns[3][REPS], sink = 0;
        for (int rep = 0; rep < REPS; ++rep)
            for (int c = 0; c < 3; ++c) {
                int check = (rep + c) % 3; /* rotate the order */
                int stride = check == 1 ? 10 : 9;
                /* the 9-real forms read the same data packed at stride 9 */
                static float pf[10 * TRIS];
                static double pd[10 * TRIS];
                for (int j = 0; j < TRIS; ++j)
                    for (int k = 0; k < stride; ++k) {
                        pf[stride * j + k] = rf[10 * j + k];
                        pd[stride * j + k] = rd[10 * j + k];
                    }
                double start = now();
                sink += precision == 0 ? run(0, check, of, df, RAYS, pf, stride, TRIS)
                                       : run(1, check, od, dd, RAYS, pd, stride, TRIS);
                ns[check][rep] = (now() - start) * 1e9 / ((double)RAYS * TRIS);
            }
        for (int c = 0; c < 3; ++c) { /* median by insertion sort */
            for (int i = 1; i < REPS; ++i)
                for (int k = i; k > 0 && ns[c][k] < ns[c][k - 1]; --k) {
                    double x = ns[c][k]; ns[c][k] = ns[c][k - 1]; ns[c][k - 1] = x;
                }
        }
        for (int c = 0; c < 3; ++c)
            printf("%s %s %.3f %.3f\n", precision ? "float64" : "float32", names[c], ns[c][REPS / 2],
                   ns[c][REPS / 2] / ns[0][REPS / 2]);
        if (sink == 42)
            puts("");
    }
    return 0;
}
"""


def main() -> int:
    import argparse

    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC").split()[0] or "cc"
    with tempfile.TemporaryDirectory() as tmp:
        src, exe = Path(tmp, "check.c"), Path(tmp, "check")
        src.write_text(SOURCE)
        subprocess.run(
            [cc, "-std=c11", "-O3", "-ffp-contract=off", "-fno-math-errno", str(src), "-o", str(exe)], check=True
        )
        out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    print(f"CPU: {cpu_model()}; Moller-Trumbore, closest hit, 1024 rays x 1024 triangles, median of 21")
    print(f"{'precision':9}  {'check':7}  {'ns/test':>8}  {'vs none':>7}")
    for line in out.split("\n"):
        if line.strip():
            precision, check, ns, ratio = line.split()
            print(f"{precision:9}  {check:7}  {float(ns):8.3f}  {float(ratio):7.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
