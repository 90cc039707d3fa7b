"""A kernel file's kernels, checked before anything times them.

Each kernel must give the float64 reference's answers, in both precisions and on every ISA, where rounding cannot
decide them (crossings at least :data:`MARGIN` from every edge; rays into a closed mesh), and keep the promises of
the robustness suite (:func:`tribench.harness.jobs.validate.promise`). The check runs in a worker of its own, with
a silence limit on each of its parts, so a kernel that crashes, exits or hangs is refused in one line."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence

import numpy as np

from ... import ext
from ...common import UserError, UserTypeError
from ...workloads import reference
from ..protocol import emit, run_apart, serve_apart
from . import validate

__all__ = ["MARGIN", "KernelRefused", "check_builds", "check_kernel", "load_checked", "PRINTS", "refuse_crashing"]

#: How far (barycentric) from every edge a checked crossing lies, and how far along the ray.
MARGIN = 1e-3
_T_RTOL = {"float32": 1e-4, "float64": 1e-9}
_PAIRS, _MESH_RAYS, _ICOSPHERE = 4000, 400, 2  # the pairs checked; the rays into the icosphere, its subdivisions
_UV_ATOL = {"float32": 1e-3, "float64": 1e-9}


_PASSED: set[tuple[str, ext.KernelFile | None]] = set()  # checked in this process, and right


class KernelRefused(UserError):
    """A kernel file's kernel that gives answers other than the reference's."""


def load_checked(paths: Sequence[str | os.PathLike]) -> tuple[str, ...]:
    """Load every kernel file of ``paths`` and check each kernel they declare; the names, in order.

    Raises :class:`~tribench.ext.KernelFileError` (no compile) or :class:`KernelRefused` (wrong answers)."""
    if isinstance(paths, (str, bytes, os.PathLike)) or not isinstance(paths, Sequence):
        raise UserTypeError(f"kernel files must be a list of paths, got {type(paths).__name__}: give [path, ...]")
    if not all(isinstance(p, (str, os.PathLike)) for p in paths):
        raise UserTypeError(f"kernel files must be a list of paths, got {[type(p).__name__ for p in paths]}")
    names: list[str] = []
    for path in paths:
        declared = ext.load_kernels(path)  # compiles; none of the file's code runs yet
        names += declared
        if all((k, ext.kernel_file_of(k)) in _PASSED for k in declared):
            continue
        for kernel, problems in _checked_elsewhere(path).items():
            printed = [p for p in problems if p.startswith(PRINTS)]
            wrong = [p for p in problems if not p.startswith(PRINTS)]
            if problems:
                raise KernelRefused(
                    f"{kernel} (from {path}) is refused: "
                    + "; ".join(printed + ["its answers differ from the float64 reference's:"] * bool(wrong))
                    + "".join(f"\n  {p}" for p in wrong)
                )
            _PASSED.add((kernel, ext.kernel_file_of(kernel)))
    return tuple(names)


def refuse_crashing(path: str | os.PathLike) -> None:
    """Refuse a kernel file (:class:`KernelRefused`) only if its kernels crash a process of their own or print:
    what ``tribench validate`` needs before running them in its process, where wrong answers are the measurement
    (and a kernel's output would run into its table)."""
    for kernel, problems in _checked_elsewhere(path).items():
        for printed in (p for p in problems if p.startswith(PRINTS)):
            raise KernelRefused(f"{kernel} (from {path}) is refused: {printed}")


def _checked_elsewhere(path: str | os.PathLike) -> dict[str, list[str]]:
    """:func:`check_kernel` of each kernel of the file, in a process of its own: a kernel that crashes
    (a stray pointer is likely in code being written) is refused in one line, and takes nothing down."""
    return _in_a_process([str(path)], list(ext.load_kernels(path)), None, f"the reference check of {path}")


def _in_a_process(kernel_files: list[str], kernels: list[str], build: str | None, what: str) -> dict[str, list[str]]:
    """kernel -> problems, of ``kernels`` checked in a worker under ``build``, ``kernel_files`` loaded there."""
    checked: dict[str, list[str]] = {}
    try:
        run_apart(
            "tribench.harness.jobs.kernel_check",
            kernels,
            kernel_files,
            {"checked": checked.update},
            what,
            None,  # "the reference check of F was killed by SIGSEGV" says it
            build,
        )
    except UserError as exc:  # its own message (a kernel file that does not compile under a build), or its end
        raise KernelRefused(str(exc)) from None
    return checked


def check_builds(sweep) -> dict[str, dict[str, list[str]]]:
    """Every kernel of ``sweep`` checked again under each build but the installed one: build -> kernel -> problems.

    A build may change results (``-ffast-math``), so nothing is refused: ``run.json``
    and the report show it. Every worker still holds a build's answers to the reference."""
    checked = {}
    for build in sweep.build_names:
        if build == ext.INSTALLED:
            continue
        t0 = time.monotonic()
        ext.load_build(build)  # compiled here, so a compile error is one message (and the check's process imports it)
        what = f"the reference check of build {build!r}"
        checked[build] = _in_a_process(list(sweep.kernel_files), list(sweep.kernels), build, what)
        wrong = sum(1 for problems in checked[build].values() if problems)
        verdict = f"{wrong} broke a promise (shown in the report)" if wrong else "all right"
        print(
            f"build {build}: compiled (or cached) and its {len(checked[build])} kernels checked again in "
            f"{time.monotonic() - t0:.0f} s: {verdict}",
            file=sys.stderr,
        )
    return checked


def check_kernel(kernel: str, rng_seed: int = 0, before: Callable[[str, int], None] | None = None) -> list[str]:
    """What ``kernel`` gets wrong, one line per case; empty if nothing. ``before(part, tests)`` is told of each
    part of the check before it runs, with the most triangle tests it runs (a worker's silence limit)."""
    info = ext.kernel_info(kernel)
    tell = before or (lambda part, tests: None)
    problems = []
    for dtype in info.precisions:
        for isa in (i for i, runnable in info.isas.items() if runnable):
            where = f"{dtype}, {isa}"
            if "pairs" in info.modes:
                tell(f"{where}: pairs", _PAIRS)
                problems += [f"{where}: {p}" for p in _check_pairs(kernel, isa, dtype, rng_seed, info.culls_back_faces)]
            tell(f"{where}: a closed mesh", 2 * _MESH_RAYS * 20 * 4**_ICOSPHERE)  # closest and any, on every face
            problems += [f"{where}: {p}" for p in _check_mesh(kernel, isa, dtype, rng_seed, info.culls_back_faces)]
        sets = validate.build(dtype, quick=True, rng_seed=rng_seed)
        tell(f"{dtype}: the quick robustness suite", validate.triangle_tests(sets))
        for row in validate.measure(kernel, sets):
            if row["verdict"] == "fail":
                problems.append(
                    f"{dtype}: robustness test {row['test']}: {row['failures']} of {row['rays']} rays "
                    f"broke the promise {row['expected']}"
                )
    return problems


def _safe_pairs(n: int, rng_seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random pairs, about half hits, wound at random, each crossing at least MARGIN from every edge."""
    rng = np.random.default_rng(rng_seed)
    tris = rng.normal(size=(n, 3, 3))
    b = rng.dirichlet([1, 1, 1], n) * 2 - 0.5  # barycentrics of the aim point: inside about half the time
    b /= b.sum(axis=1, keepdims=True)
    target = np.einsum("nk,nkj->nj", b, tris)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = target - rng.uniform(0.5, 4, (n, 1)) * d
    ref = reference.intersect_pairs(o, d, tris)
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    cos = np.abs(np.einsum("nj,nj->n", normal, d)) / np.linalg.norm(normal, axis=1)
    safe = (np.abs(ref.edge_margin) >= MARGIN) & (cos >= 0.05) & (np.linalg.norm(normal, axis=1) > 0.1)
    return o[safe], d[safe], tris[safe]


def _check_pairs(kernel: str, isa: str, dtype: str, rng_seed: int, front_only: bool) -> list[str]:
    o, d, tris = (a.astype(dtype) for a in _safe_pairs(_PAIRS, rng_seed))
    f64 = [a.astype(np.float64) for a in (o, d, tris)]
    ref = reference.intersect_pairs(f64[0], f64[1], f64[2], front_only=front_only)
    index, t, _, _ = ext.intersect(kernel, o, d, tris, "pairs", isa=isa)
    hit = index >= 0
    wrong = hit != ref.hit
    far = hit & ref.hit & ~np.isclose(t, ref.t, rtol=_T_RTOL[dtype], atol=0)
    out = []
    if wrong.any():
        out.append(
            f"pairs: {int(wrong.sum())} of {len(o)} hit or miss against the reference "
            f"({int((hit & ~ref.hit).sum())} extra hits, {int((~hit & ref.hit).sum())} missed)"
        )
    if far.any():
        out.append(f"pairs: t off by more than {_T_RTOL[dtype]:g} (relative) on {int(far.sum())} hits")
    return out


def _safe_mesh_rays(rng_seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A closed mesh (an icosphere) and rays from around it whose every plane crossing is safe."""
    import trimesh

    tris = np.ascontiguousarray(trimesh.creation.icosphere(subdivisions=_ICOSPHERE).triangles)
    rng = np.random.default_rng(rng_seed)
    o = rng.normal(size=(_MESH_RAYS, 3))
    o = 3 * o / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.normal(size=(_MESH_RAYS, 3)) * 0.7 - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    m, k = len(o), len(tris)
    every = reference.intersect_pairs(np.repeat(o, k, 0), np.repeat(d, k, 0), np.tile(tris, (m, 1, 1)))
    near = (np.abs(every.edge_margin) < MARGIN) | (np.abs(every.t) < MARGIN)
    safe = ~near.reshape(m, k).any(axis=1)
    return o[safe], d[safe], tris


def _check_mesh(kernel: str, isa: str, dtype: str, rng_seed: int, front_only: bool) -> list[str]:
    o, d, tris = (a.astype(dtype) for a in _safe_mesh_rays(rng_seed))
    f64 = [a.astype(np.float64) for a in (o, d, tris)]
    ref_index, ref_t = reference.intersect_closest(f64[0], f64[1], f64[2], front_only=front_only)
    index, t, u, v = ext.intersect(kernel, o, d, tris, "closest_uv", isa=isa)
    out = []
    wrong = index != ref_index
    if wrong.any():
        out.append(f"closest hit on a mesh: {int(wrong.sum())} of {len(o)} rays name another triangle or miss")
        return out
    hit = index >= 0
    if (~np.isclose(t[hit], ref_t[hit], rtol=_T_RTOL[dtype], atol=0)).any():
        out.append(f"closest hit on a mesh: t off by more than {_T_RTOL[dtype]:g} (relative)")
    ref = reference.intersect_pairs(f64[0][hit], f64[1][hit], f64[2][index[hit]])
    if not (np.allclose(u[hit], ref.u, atol=_UV_ATOL[dtype]) and np.allclose(v[hit], ref.v, atol=_UV_ATOL[dtype])):
        out.append("closest hit on a mesh: u or v (the barycentrics of v1 and v2) differ from the reference's")
    any_hit = ext.intersect(kernel, o, d, tris, "any", isa=isa)
    if not np.array_equal(any_hit.index >= 0, hit):
        out.append("any hit on a mesh: another set of rays hits than the closest hit's")
    return out


def _work(kernels: list[str]) -> None:
    """The check's worker (the kernel files loaded): one ``checked`` line of kernel -> problems, and a silence
    limit before each part of each check."""
    from ..worker import unmeasured_limit_s

    def check(kernel: str) -> list[str]:
        def before(part: str, tests: int) -> None:
            emit("silence", {"seconds": unmeasured_limit_s(tests), "during": f"checking {kernel}, {part}"})

        return _quiet_check(kernel, before)

    emit("checked", {k: check(k) for k in kernels})


#: How a kernel that writes to standard output is refused (its output would be timed with it, and would run into
#: the tables of a command that runs it in its own process: ``tribench validate``, the sweep's robustness step).
PRINTS = "it writes to standard output"


def _quiet_check(kernel: str, before: Callable[[str, int], None] | None = None) -> list[str]:
    """:func:`check_kernel`, with what the kernel writes to standard output (fd 1) caught: if anything, the first
    problem says so."""
    import ctypes
    import tempfile

    with tempfile.TemporaryFile() as caught:
        kept = os.dup(1)
        os.dup2(caught.fileno(), 1)
        try:
            problems = check_kernel(kernel, before=before)
        finally:
            ctypes.CDLL(None).fflush(None)  # C's stdio buffers what goes to a file
            os.dup2(kept, 1)
            os.close(kept)
        size = os.fstat(caught.fileno()).st_size
        caught.seek(0)
        first = caught.readline(80).decode(errors="replace").strip()
    if size:
        problems.insert(0, f"{PRINTS} ({size:,} bytes in its check, the first {first!r}): a kernel must print nothing")
    return problems


if __name__ == "__main__":
    sys.exit(serve_apart(_work))
