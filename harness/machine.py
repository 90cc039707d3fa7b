"""What machine and build produced a measurement: read once, recorded with every run."""

from __future__ import annotations

import math
import os
import platform
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

# CPU features that decide which kernel variants can run, as /proc/cpuinfo names them.
SIMD_FLAGS = ("sse2", "sse4_1", "sse4_2", "avx", "avx2", "fma", "avx512f", "avx512vl", "asimd", "sve")


# /proc/cpuinfo's "CPU implementer" and "CPU part" numbers of aarch64 cores, the names their makers give
ARM_IMPLEMENTERS = {"0x41": "ARM", "0x46": "Fujitsu", "0x48": "HiSilicon", "0x4e": "NVIDIA", "0x51": "Qualcomm",
                    "0x61": "Apple", "0xc0": "Ampere"}  # fmt: skip
ARM_PARTS = {
    ("0x41", "0xd08"): "Cortex-A72", ("0x41", "0xd0b"): "Cortex-A76", ("0x41", "0xd0c"): "Neoverse-N1",
    ("0x41", "0xd40"): "Neoverse-V1", ("0x41", "0xd41"): "Cortex-A78", ("0x41", "0xd49"): "Neoverse-N2",
    ("0x41", "0xd4f"): "Neoverse-V2", ("0x41", "0xd84"): "Neoverse-V3", ("0x41", "0xd8e"): "Neoverse-N3",
    ("0x46", "0x001"): "A64FX", ("0xc0", "0xac3"): "Ampere-1", ("0xc0", "0xac4"): "Ampere-1a",
}  # fmt: skip
# macOS names its CPU features in `sysctl hw.optional`; these are the ones SIMD_FLAGS knows
_MACOS_FLAGS = {"hw.optional.neon": "asimd", "hw.optional.AdvSIMD": "asimd", "hw.optional.arm.FEAT_SVE": "sve",
                "hw.optional.sse2": "sse2", "hw.optional.sse4_1": "sse4_1", "hw.optional.sse4_2": "sse4_2",
                "hw.optional.avx1_0": "avx", "hw.optional.avx2_0": "avx2", "hw.optional.fma": "fma",
                "hw.optional.avx512f": "avx512f", "hw.optional.avx512vl": "avx512vl"}  # fmt: skip


def _cpuinfo() -> dict[str, str]:
    """The CPU's fields as /proc/cpuinfo names them: the first processor's, then those only later blocks
    give (a Raspberry Pi's "Model"). On macOS the same keys are made from sysctl; elsewhere empty."""
    if sys.platform == "darwin":
        return _macos_cpuinfo()
    fields: dict[str, str] = {}
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return fields
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip():
            fields.setdefault(key.strip(), value.strip())
    return fields


def _macos_cpuinfo() -> dict[str, str]:
    """The model name and flags from sysctl (empty where there is no sysctl)."""
    names = ["machdep.cpu.brand_string", "hw.optional"]
    try:
        out = subprocess.run(["sysctl", *names], capture_output=True, text=True, timeout=5).stdout
    except (OSError, subprocess.SubprocessError):
        out = ""
    values = {k.strip(): v.strip() for k, _, v in (line.partition(":") for line in out.splitlines()) if v}
    flags = {flag for key, flag in _MACOS_FLAGS.items() if values.get(key) == "1"}
    return {"model name": values.get("machdep.cpu.brand_string", ""), "flags": " ".join(sorted(flags))}


def _read(path: str) -> str | None:
    try:
        return Path(path).read_text().strip()
    except OSError:
        return None


def cpu_model() -> str:
    """The CPU's name, with its family and model numbers where /proc/cpuinfo gives them.

    A hypervisor may show only a brand ("AMD EPYC" for Zen 3, 4 and 5 alike), so
    a calibration's margin is applied only on the CPU it was measured on."""
    info = _cpuinfo()
    implementer, part = info.get("CPU implementer", "").lower(), info.get("CPU part", "").lower()
    if implementer and part and not info.get("model name"):  # aarch64 Linux: numbers, no name
        maker = ARM_IMPLEMENTERS.get(implementer, "CPU")
        name = f"{maker} {ARM_PARTS.get((implementer, part), 'part ' + part)}"
        return f"{name} (implementer {implementer}, part {part})"
    name = info.get("model name") or info.get("Model") or platform.processor() or platform.machine()
    family, model = info.get("cpu family"), info.get("model")
    return f"{name} (family {family}, model {model})" if family and model else name


def describe() -> str:
    """One line naming the CPU, its widest ISA, tribench's version and compiler, for bench/'s printouts."""
    from .. import ext

    simd = set(simd_features())
    widest = "AVX-512" if "avx512f" in simd else "AVX2" if "avx2" in simd else "NEON" if "asimd" in simd else "no AVX2"
    return f"machine: {cpu_model()}, {widest}; tribench {version()}, {ext.build_info()['compiler']}"


def simd_features() -> list[str]:
    """The SIMD-relevant CPU features this machine reports."""
    info = _cpuinfo()
    flags = set((info.get("flags") or info.get("Features") or "").split())
    return [f for f in SIMD_FLAGS if f in flags]


def cache_sizes() -> dict[str, str]:
    """Cache sizes of CPU 0 by level and type, e.g. {'L1d': '32K', 'L2': '512K'}."""
    sizes = {}
    for index in sorted(Path("/sys/devices/system/cpu/cpu0/cache").glob("index*")):
        level, kind, size = (_read(str(index / f)) for f in ("level", "type", "size"))
        if level and size:
            suffix = {"Data": "d", "Instruction": "i"}.get(kind or "", "")
            sizes[f"L{level}{suffix}"] = size
    return sizes


def size_bytes(size: str) -> float:
    """A size as Linux prints it in bytes, NaN when it is none (a run folder's caches are read with it too).

    >>> size_bytes("32K"), size_bytes("2M"), size_bytes("512"), size_bytes("?")
    (32768.0, 2097152.0, 512.0, nan)
    """
    m = re.fullmatch(r"\s*([0-9.]+)\s*([KMG]?)i?B?\s*", str(size), flags=re.I)
    if not m:
        return math.nan
    return float(m.group(1)) * {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30}[m.group(2).upper()]


def cache_bytes() -> dict[str, int]:
    """:func:`cache_sizes` in bytes ('32K' -> 32768)."""
    return {name: int(size_bytes(s)) for name, s in cache_sizes().items()}


def git_revision() -> str | None:
    """The source checkout's revision, if tribench runs from one."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def version() -> str:
    try:
        return metadata.version("tribench")
    except metadata.PackageNotFoundError:
        return "unknown"


def machine_record() -> dict:
    """Machine, build and versions, as one JSON-ready dict."""
    import numpy

    from .. import ext

    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {
        "tribench": version(),
        "git_revision": git_revision(),
        "cpu_model": cpu_model(),
        "simd_features": simd_features(),
        "logical_cpus": os.cpu_count(),
        "usable_cpus": sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "can_pin": hasattr(os, "sched_setaffinity"),  # macOS cannot pin a process to a CPU
        "caches": cache_sizes(),
        "governor": _read("/sys/devices/system/cpu/cpu0/cpufreq/scaling_governor"),
        "cpu_mhz": _cpuinfo().get("cpu MHz"),
        "load_average": list(load) if load else None,
        "platform": platform.platform(),
        "machine": platform.machine(),
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "build": ext.build_info(),
        "kernels": list(ext.kernel_names()),
    }
