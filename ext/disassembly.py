"""The built module's machine code read back (objdump), and what a kernel's block loop executes: the
instruction mix tests/test_ext_build.py holds each wide kernel's declared ``tb_<name>_mix`` to, and that
bench/compiled_mix.py counts per ISA (AVX2 has no mask registers, so its masks cost logic instructions)."""

from __future__ import annotations

import re
import subprocess

__all__ = ["CLASSES", "functions", "loop_arithmetic", "loop_mix"]

#: instruction classes of the port model (tribench.harness.peak), by mnemonic
CLASSES = {
    "fma": r"^vf\w*(madd|msub)\w*p[sd]$",
    "mul": r"^vmulp[sd]$",
    "add": r"^v(add|sub|min|max)p[sd]$",
    "cmp": r"^vcmp\w*p[sd]$",
    "div": r"^v(div|sqrt)p[sd]$",
    # bit operations, blends and selects: AVX2's and/or/xor/blendv; AVX-512's mask-register
    # operations, ternary logic, mask blends and masked register-to-register moves (a select)
    "logic": r"^(v(p?and|p?andn|p?or|p?xor|blendv|blendm|pblendm|pternlog)\w*|k(and|andn|or|xor|not)[bwdq])$",
}
_MASKED_MOVE = re.compile(r"^vmov(a|u)p[sd]$")
_ARITHMETIC = re.compile(r"^v(add|sub|mul|div|sqrt|cmp\w*|min|max|f\w*madd\w*|f\w*msub\w*)p[sd]$")


def functions(path: str) -> dict[str, str]:
    """Machine code of a shared object, by function name (needs objdump, from binutils)."""
    text = subprocess.run(["objdump", "-d", "--no-show-raw-insn", path], capture_output=True, text=True, check=True)
    out: dict[str, list[str]] = {}
    name = None
    for line in text.stdout.splitlines():
        head = re.match(r"^[0-9a-f]+ <([^>]+)>:$", line)
        if head:
            name = head.group(1)
            out[name] = []
        elif name:
            out[name].append(line)
    return {k: "\n".join(v) for k, v in out.items()}


def _loops(code: str) -> list[list[tuple[str, str]]]:
    """The (mnemonic, operands) of every backward jump's body in a function."""
    lines = [re.match(r"\s*([0-9a-f]+):\s+(\S+)\s*(.*)", line) for line in code.splitlines()]
    ins = [(int(m.group(1), 16), m.group(2), m.group(3)) for m in lines if m]
    bodies = []
    for address, op, operands in ins:
        target = operands.split()[0] if operands else ""
        if op.startswith("j") and re.fullmatch(r"[0-9a-f]+", target) and int(target, 16) < address:
            bodies.append([(o, r) for a, o, r in ins if int(target, 16) <= a <= address])
    return bodies


def loop_arithmetic(code: str) -> int:
    """Packed arithmetic instructions in a function's largest loop (a wide kernel's block loop), by kind."""
    return max((sum(1 for o, _ in body if _ARITHMETIC.match(o)) for body in _loops(code)), default=0)


def _class_of(op: str, operands: str) -> str | None:
    """The class of one instruction (None: bookkeeping, loads, branches)."""
    if _MASKED_MOVE.match(op) and "{%k" in operands and "(" not in operands:
        return "logic"  # a masked move between registers: a select
    return next((c for c, rx in CLASSES.items() if re.match(rx, op)), None)


def loop_mix(code: str) -> dict[str, int]:
    """Instructions per class in the largest loop (by arithmetic) of a function."""
    best = max(_loops(code), key=lambda body: sum(1 for o, _ in body if _ARITHMETIC.match(o)), default=[])
    classes = [_class_of(o, r) for o, r in best]
    return {c: classes.count(c) for c in CLASSES}
