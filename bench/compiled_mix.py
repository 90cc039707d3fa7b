"""Each native form's bound from the loop its ISA compiled, beside the declared one.

`tribench info --peak --isa avx2` holds every native kernel to AVX2 but bounds it by its
declared mix (``tb_<name>_mix``), counted in the AVX-512 loop. AVX2 has no mask
registers: a compare yields a vector, and combining or selecting by it costs logic
instructions on the vector pipes that AVX-512's mask registers do not. This reads
each ISA's compiled block loop back (objdump, tribench.ext.disassembly), counts its
instructions by class, scales them to one test (the FP arithmetic is the same source
on every ISA, so its count fixes how many tests a loop iteration covers), and prints
both bounds at that ISA's measured rates, with the time of this run on the in-cache
camera workload and the fraction of each bound (float32, one process: a quick look).
Both counts are the path that does everything: a form with an early exit (woop_fma,
plucker_fma, curless_fma, the _exit and _cull forms) does less on most vectors, so
its fraction can pass 100%.

    flock /tmp/tribench-timing.lock python bench/compiled_mix.py [--isa avx2] [--rounds 5]
"""

from __future__ import annotations

import argparse

from tribench import ext
from tribench.ext import _core
from tribench.ext.disassembly import functions, loop_mix
from tribench.harness.machine import machine_record
from tribench.harness.peak import bound_from_mix, camera_fractions

FP = ("fma", "mul", "add")


def per_test(compiled: dict[str, int], declared: dict[str, float]) -> dict[str, float]:
    """The compiled loop's counts per test, scaled so its FP arithmetic is the declared one's."""
    scale = sum(declared[c] for c in FP) / max(sum(compiled[c] for c in FP), 1)
    return {c: n * scale for c, n in compiled.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isa", default="avx2", choices=ext.probe_isas())
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    code = functions(_core.__file__)
    _, _, rate_isa, rates, table = camera_fractions(dtypes=("float32",), rounds=args.rounds, isa=args.isa)
    print(f"{machine_record()['cpu_model']}; forms and probes on {rate_isa}; float32, Suzanne 968, 64^2 camera")
    print("bounds in ns per test: 'declared' from tb_<name>_mix, 'compiled' from this ISA's loop; % = bound / ns")
    print(f"{'kernel':<26}{'logic ops':>10}{'declared':>9}{'ns':>7}{'%':>6}{'compiled':>9}{'%':>6}")
    for row in table.itertuples(index=False):
        info = ext.kernel_info(row.kernel)
        if info.lanes != 16:
            continue
        mix = per_test(loop_mix(code[f"tb_{row.kernel}_time_closest_{args.isa}_f32"]), info.mix)
        compiled = bound_from_mix({**mix, "load": info.mix.get("load", 0)}, rates["float32"])
        print(
            f"{row.kernel:<26}{mix['logic']:>10.1f}{row.bound_ns_per_test:>9.3f}{row.ns_per_test:>7.3f}"
            f"{100 * row.fraction:>5.0f}%{compiled:>9.3f}{100 * compiled / row.ns_per_test:>5.0f}%"
        )


if __name__ == "__main__":
    main()
