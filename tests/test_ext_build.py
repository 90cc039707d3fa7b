"""The built module is what it claims: wide kernels really run on their ISA's registers.

The native kernels are compiled once per ISA by a target attribute; this
reads the machine code back (objdump) and checks that each ISA's timed loop
uses that ISA's vector registers, and the baseline's does not, so "avx2" in a
result means 256-bit instructions ran.
"""

from __future__ import annotations

import platform
import re
import shutil

import pytest

from tribench import ext
from tribench.ext import _core
from tribench.ext.disassembly import CLASSES, functions, loop_arithmetic, loop_mix

WIDE = [k for k in ext.kernel_names() if ext.kernel_info(k).lanes > 1]

pytestmark = [
    pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86-64 ISAs only"),
    pytest.mark.skipif(shutil.which("objdump") is None, reason="needs objdump (binutils)"),
]


@pytest.fixture(scope="module")
def disassembly() -> dict[str, str]:
    """Machine code of the module, by function name."""
    return functions(_core.__file__)


@pytest.mark.parametrize("kernel", WIDE)
@pytest.mark.parametrize("suffix", ["f32", "f64"])
def test_each_isa_uses_its_registers(disassembly, kernel, suffix):
    base = f"tb_{kernel}_time_closest"
    code = {isa: disassembly.get(f"{base}_{isa}_{suffix}") for isa in ext.kernel_info(kernel).isas}
    assert all(code.values()), f"missing symbols for {base}: {[i for i, c in code.items() if not c]}"
    assert "ymm" not in code["baseline"] and "zmm" not in code["baseline"]
    assert len(re.findall(r"\bv\w+ps\b|\bv\w+pd\b", code["avx2"])) > 20  # packed AVX arithmetic
    assert "ymm" in code["avx2"] and "zmm" not in code["avx2"]
    # no lane lowered to scalar compares (GCC does that to vector comparisons
    # wider than the ISA's registers; the per-ray reduction has a few)
    assert len(re.findall(r"\bv?u?comis[sd]\b", code["avx2"])) < 30


LOOPS = re.compile(
    r"^tb_\w+_((run|time)_(pairs|any|closest|closest_uv|null)|run|bvh_wide|bvh_binary|bvh_packet)(_(avx512|avx2|baseline))?_f(32|64)$"
)
# the calls a loop makes by design: moller_trumbore_twice's and moller_trumbore_same's loops
# are moller_trumbore's, called twice over or once; woop_fma's exact fallback for a 0 edge
# function is out of line (cold); the seed's object path (seed_objects.h) is calls by its nature;
# the wide BVH entry points trace packets out of line (bvh_trace.h: one tb_<kernel>_bvh_packet each);
# the untimed entry points jump to their kernel's shared loop (core.h's TB_SHARED_LOOP), which is a loop here
CALLED_BY_DESIGN = re.compile(
    r"^tb_(moller_trumbore_(run|time)_\w+|woop_fma_exact_f(32|64)|so_\w+_f(32|64)|\w+_bvh_packet_(avx512|avx2|baseline)_f(32|64)(\.\w+)*)$"
)


def test_loops_inline_their_kernel(disassembly):
    """Every loop is one function: its kernel's test, ray set-up and signal poll are
    inlined, so a timed test costs no call. (GCC stops inlining a file's functions
    once the file has grown past --param inline-unit-growth, which is why the scalar
    loops share a file with the baseline ones, ext/isa_baseline_<p>.c.)"""
    loops = [name for name in disassembly if LOOPS.match(name)]
    assert len(loops) > 500, f"found only {len(loops)} loops in the disassembly"
    called = {
        name: sorted(set(calls) - {c for c in calls if c.endswith("@plt") or CALLED_BY_DESIGN.match(c)})
        for name in loops
        if (calls := re.findall(r"\bcall\s+[0-9a-f]+ <([^>+]+)", disassembly[name]))
    }
    offenders = {name: c for name, c in called.items() if c}
    assert not offenders, f"{len(offenders)} loops call functions of the module: {dict(list(offenders.items())[:5])}"


@pytest.mark.parametrize("kernel", WIDE)
def test_documented_ops_are_the_compiled_arithmetic(disassembly, kernel):
    """A wide kernel's documented operation count (the bound of `tribench info
    --peak`) is the arithmetic its compiled block loop does: one float vector
    per block of 16 with AVX-512, so the count per lane. A kernel edited without
    its count, or arithmetic the compiler fused or dropped, fails here."""
    code = disassembly[f"tb_{kernel}_time_closest_avx512_f32"]
    assert loop_arithmetic(code) == ext.kernel_info(kernel).ops


@pytest.mark.parametrize("kernel", WIDE)
def test_declared_mix_is_the_compiled_loop(disassembly, kernel):
    """A wide kernel's per-class counts (the port model's input, ext.kernel_info(k).mix)
    are its compiled block loop's instructions of each class."""
    mix = ext.kernel_info(kernel).mix
    compiled = loop_mix(disassembly[f"tb_{kernel}_time_closest_avx512_f32"])  # as for the total, above
    assert compiled == {c: mix[c] for c in CLASSES}
