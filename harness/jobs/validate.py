"""``tribench validate``: the robustness suite, every kernel at both precisions.

The cases are :mod:`tribench.workloads.robustness`'s (re-exported here; docs/methodology.md, "The robustness
suite"); this module asks every kernel, wide ones at their default ISA, and judges the answers into rows of
:data:`COLUMNS` against :func:`promise`, the papers' promise; the rest is ``measured``, never judged.
:data:`FULL` takes about 0.3 s per kernel and precision."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pandas as pd

from ... import ext
from ...common import UserError
from ...workloads.geometry import dot, triangle_normals
from ...workloads.robustness import *  # noqa: F403
from ...workloads.robustness import DTYPES, EMBREE_MAX_MISS_RATE, TESTS, MeshRays, PairRays, RaySets, build
from ...workloads.robustness import __all__ as _cases
from .. import runfolder

__all__ = [
    *_cases,
    "COLUMNS",
    "SHORT_NAMES",
    "WATERTIGHT",
    "culls",
    "format_rate",
    "format_table",
    "measure",
    "promise",
    "run",
    "table",
]

#: The columns of ``validate.csv``, in file order (defined in :mod:`~tribench.harness.runfolder`).
COLUMNS: dict[str, str] = runfolder.FILES[runfolder.VALIDATE]

#: Kernels that promise no crack on shared edges and vertices, and the paper
#: that promises it: read from the registry (``ext.kernel_info(k).watertight``).
WATERTIGHT: dict[str, str] = {
    k: ext.kernel_info(k).watertight_source
    for k in ext.kernel_names(internal=True)
    if ext.kernel_info(k).watertight == "edges_and_vertices"
}


# ----------------------------------------------------------------- measuring


def promise(kernel: str, test: str) -> tuple[str, float | None]:
    """What the papers promise ``kernel`` on ``test``: (text, largest rate allowed), or ('measured', None).

    >>> promise("woop_fma", "shared_edges")
    ('0 (watertight: Woop, Benthin & Wald 2013)', 0.0)
    >>> promise("curless", "parallel_rays")
    ('0 (must miss)', 0.0)
    >>> promise("moller_seed", "nonfinite"), promise("curless_seed", "parallel_rays")
    (('measured', None), ('measured', None))
    """
    info = ext.kernel_info(kernel)
    watertight = info.watertight == "edges_and_vertices"
    if watertight and test in ("shared_edges", "shared_vertices"):
        return f"0 (watertight: {info.watertight_source})", 0.0
    if watertight and test == "inside_sphere":
        return "<= 0.002% (Embree's threshold)", EMBREE_MAX_MISS_RATE
    # a seed replay's flaws are the seed's: measured and recorded, never judged (its registration)
    if test in ("parallel_rays", "degenerate_triangles", "nonfinite") and not info.seed_replay:
        return "0 (must miss)", 0.0
    return "measured", None


def culls(kernel: str) -> bool:
    """Whether ``kernel`` culls back faces: it is then asked about front faces only, so its rates measure robustness."""
    return ext.kernel_info(kernel).culls_back_faces


def _closest(kernel: str, isa: str, rays: MeshRays, triangles: np.ndarray | None = None) -> np.ndarray:
    """Closest hit of each ray on ``triangles`` (default the mesh's), wound to face the ray for a culling kernel."""
    tris = rays.triangles if triangles is None else triangles
    back = rays.back if culls(kernel) else np.zeros(len(rays.origins), bool)
    index = np.full(len(rays.origins), -1)
    for side in (False, True):
        rows = back == side
        if rows.any():
            facing = np.ascontiguousarray(tris[:, [0, 2, 1]] if side else tris)  # v1, v2 swapped: turned round
            index[rows] = ext.intersect(
                kernel, rays.origins[rows], rays.directions[rows], facing, "closest", isa=isa
            ).index
    return index


def _own_hits(kernel: str, isa: str, p: PairRays, allow_nonfinite: bool = False) -> np.ndarray:
    """Whether ray i hits ``triangles[owner[i]]``: in pairs mode, or by one closest call per triangle and side."""
    options: dict[str, Any] = {"isa": isa, "allow_nonfinite": allow_nonfinite}
    tris = p.triangles[p.owner]
    back = np.zeros(len(p.owner), bool)
    if culls(kernel):
        with np.errstate(invalid="ignore", over="ignore"):
            back = dot(p.directions.astype(np.float64), triangle_normals(tris.astype(np.float64))) > 0
        tris = np.where(back[:, None, None], tris[:, [0, 2, 1]], tris)
    if "pairs" in ext.kernel_info(kernel).modes:
        return ext.intersect(kernel, p.origins, p.directions, np.ascontiguousarray(tris), "pairs", **options).hit
    hit = np.zeros(len(p.owner), bool)
    for key in np.unique(2 * p.owner + back):
        rows = np.flatnonzero(2 * p.owner + back == key)
        hit[rows] = ext.intersect(kernel, p.origins[rows], p.directions[rows], tris[rows[:1]], "closest", **options).hit
    return hit


def _breakdown(failed: np.ndarray, label: np.ndarray, what: str) -> str:
    """``what`` per label where some failed, e.g. 'cracks: x+y+z=c 3/512'."""
    parts = [
        f"{g} {int(failed[label == g].sum())}/{int((label == g).sum())}"
        for g in dict.fromkeys(label.tolist())
        if failed[label == g].any()
    ]
    return f"{what}: {', '.join(parts)}" if parts else f"no {what}"


def _mesh_result(kernel: str, isa: str, test: str, sets: RaySets) -> tuple[int, int, str]:
    groups = sets.meshes["shared_edges" if test == "shared_edges_double" else test]
    if test == "shared_edges_double":  # the lower and the upper triangle of its edge, each asked alone
        assert all(g.incident is not None for g in groups)  # the shared-edge rays know their triangles
        failed = np.concatenate(
            [
                (_closest(kernel, isa, g, g.triangles[0::2]) == g.incident[:, 0] // 2)
                & (_closest(kernel, isa, g, g.triangles[1::2]) == g.incident[:, 1] // 2)
                for g in groups
                if g.incident is not None  # all of them (asserted): the `if` is for mypy
            ]
        )
    else:
        failed = np.concatenate([_closest(kernel, isa, g) < 0 for g in groups])
    if test == "inside_sphere":
        embree = "pass" if failed.mean() <= EMBREE_MAX_MISS_RATE else "fail"
        detail = f"{failed.sum()} of {len(failed)} rays missed; Embree's 0.002% threshold: {embree}"
    else:
        label = np.concatenate([np.full(len(g.origins), g.label) for g in groups])
        detail = _breakdown(failed, label, "both triangles hit" if test == "shared_edges_double" else "cracks")
    return len(failed), int(failed.sum()), detail


_PAIR_WORDS = {
    "scales": "disagreements by scale",
    "tiny_triangles": "misses by size",
    "needle_triangles": "misses by aspect ratio",
    "grazing_rays": "misses by slope",
    "parallel_rays": "hits",
    "in_plane_rays": "hits",
    "degenerate_triangles": "hits",
    "nonfinite": "hits",
}


def _pair_result(kernel: str, isa: str, test: str, p: PairRays) -> tuple[int, int, str]:
    hit = _own_hits(kernel, isa, p, allow_nonfinite=test == "nonfinite")
    failed = hit != p.expect_hit
    detail = _breakdown(failed, p.label, _PAIR_WORDS[test])
    if p.dropped:
        detail += f"; {p.dropped} ambiguous after rounding, dropped"
    return len(failed), int(failed.sum()), detail


def measure(kernel: str, sets: RaySets) -> list[dict]:
    """One row per test of ``kernel`` on ``sets`` (columns of :data:`COLUMNS`)."""
    isa = ext.kernel_info(kernel).isa
    rows = []
    for test in sets.tests:
        if test in sets.pairs:
            rays, failures, detail = _pair_result(kernel, isa, test, sets.pairs[test])
        else:
            rays, failures, detail = _mesh_result(kernel, isa, test, sets)
        expected, allowed = promise(kernel, test)
        rate = failures / rays if rays else float("nan")
        verdict = "measured" if allowed is None else ("pass" if rate <= allowed else "fail")
        values = (kernel, sets.dtype, isa, test, rays, failures, rate, expected, verdict, detail)
        rows.append(dict(zip(COLUMNS, values, strict=True)))
    return rows


def run(kernels=None, dtypes=DTYPES, quick: bool = False, rng_seed: int = 0, tests=TESTS, progress: bool | None = None):
    """The whole suite as a tidy DataFrame (:data:`COLUMNS`), ordered by kernel, dtype and test.

    ``kernels`` default to ``ext.kernel_names()``; ``quick``: the ``QUICK`` sizes; ``progress`` False for none.
    With a kernel file's kernel among them, the suite runs in a worker of the protocol: the kernel's check ran the
    quick suite only, and one that crashes or never returns on the full one ends the worker, not this process
    (UserError). The frame's ``attrs`` record the RNG seed (``rng_seed``), size and seconds."""
    from ..runner import progress_ticks

    kernels = list(kernels or ext.kernel_names())
    for k in kernels:
        ext.kernel_info(k)  # an unknown name fails here, before any work
    for what, names in (("kernels", kernels), ("dtypes", list(dtypes))):
        twice = sorted({str(n) for n in names if names.count(n) > 1})
        if twice:  # each would be measured twice, and the table's rows would clash
            raise UserError(f"{what} name {', '.join(twice)} more than once: give each once")
    start = time.perf_counter()
    rows: list[dict] = []
    files = sorted({f.path for k in kernels if (f := ext.kernel_file_of(k)) is not None})
    with progress_ticks(progress, len(kernels), unit="kernels", label="validate") as advance:

        def got(kernel_rows: list[dict]) -> None:
            rows.extend(kernel_rows)
            advance()

        suite = {"kernels": kernels, "dtypes": list(dtypes), "quick": quick, "rng_seed": rng_seed, "tests": list(tests)}
        if files:
            _in_a_worker(files, suite, got)
        else:
            _measure_each(**suite, got=got)
    df = pd.DataFrame(rows, columns=list(COLUMNS))
    df.attrs.update(rng_seed=rng_seed, size="quick" if quick else "full", seconds=time.perf_counter() - start)
    return df


def _measure_each(kernels, dtypes, quick, rng_seed, tests, got, emit=None) -> None:
    """``got(rows)`` of each kernel in turn; in a worker, ``emit`` says how long each kernel may take (protocol)."""
    from ..worker import unmeasured_limit_s

    sets = [build(dtype, quick, rng_seed, tests) for dtype in dtypes]
    limit_s = unmeasured_limit_s(sum(map(triangle_tests, sets))) if emit else None
    for k in kernels:
        if emit:
            emit("silence", {"seconds": limit_s, "during": f"validating {k}"})
        got([r for s in sets for r in measure(k, s)])


def triangle_tests(sets: RaySets) -> int:
    """The most triangle tests :func:`measure` runs on ``sets`` (a mesh's rays serve two tests)."""
    rays = sum(len(m.origins) * len(m.triangles) for ms in sets.meshes.values() for m in ms)
    return 2 * (rays + sum(len(p.origins) for p in sets.pairs.values()))


def _in_a_worker(files: list[str], suite: dict[str, Any], got) -> None:
    from ..protocol import run_apart

    run_apart(
        "tribench.harness.jobs.validate",
        suite,
        files,
        {"rows": lambda m: got(m["rows"])},
        "the robustness suite's worker",
        "a kernel file's kernel failed on the robustness suite; nothing was measured",
    )


def _work(suite: dict[str, Any]) -> None:
    """The worker of :func:`_in_a_worker`: a ``rows`` line per kernel."""
    from ..protocol import emit

    _measure_each(**suite, got=lambda rows: emit("rows", {"rows": rows}), emit=emit)


# ---------------------------------------------------------------- displaying

#: Column headers of the display table.
SHORT_NAMES = {
    "shared_edges": "edges",
    "shared_edges_double": "edges2x",
    "shared_vertices": "vertices",
    "inside_sphere": "sphere",
    "scales": "scales",
    "tiny_triangles": "tiny",
    "needle_triangles": "needle",
    "grazing_rays": "grazing",
    "parallel_rays": "parallel",
    "in_plane_rays": "in plane",
    "degenerate_triangles": "degenerate",
    "nonfinite": "nonfinite",
}


def format_rate(failures: int, rate: float, verdict: str = "measured") -> str:
    """A table cell: ``0``, or the rate in percent; ``!`` marks a broken promise.

    >>> format_rate(0, 0.0), format_rate(3, 0.125), format_rate(1, 2e-5, "fail")
    ('0', '12.5%', '0.002%!')
    """
    cell = "0" if failures == 0 else f"{100 * rate:.3g}%"
    return cell + ("!" if verdict == "fail" else "")


def table(df):
    """The display table: one row per kernel and dtype, one column per test, cells from :func:`format_rate`."""
    cells = df.assign(cell=[format_rate(f, r, v) for f, r, v in zip(df.failures, df.rate, df.verdict, strict=True)])
    wide = cells.pivot(index=["kernel", "dtype", "isa"], columns="test", values="cell")
    wide = wide.reindex(
        index=list(dict.fromkeys(zip(df.kernel, df.dtype, df.isa, strict=True))),
        columns=[t for t in TESTS if t in set(df.test)],
    )
    return wide.rename(columns=SHORT_NAMES).reset_index()


def format_table(df) -> str:
    """The terminal table of :func:`run`'s frame, with the rays per test and a legend."""
    wide = table(df)
    cells = [list(wide.columns), *wide.astype(str).values.tolist()]
    widths = [max(len(row[i]) for row in cells) for i in range(len(cells[0]))]
    # names left-aligned, rates right-aligned
    lines = [
        "  ".join(
            v.ljust(w) if i < 3 else v.rjust(w) for i, (v, w) in enumerate(zip(row, widths, strict=True))
        ).rstrip()
        for row in cells
    ]
    first = df[df.kernel == df.kernel.iloc[0]]
    for dtype, rows in first.groupby("dtype", sort=False):
        counts = ", ".join(f"{SHORT_NAMES[t]} {n}" for t, n in zip(rows.test, rows.rays, strict=True))
        lines.append(f"rays ({dtype}): {counts}")
    lines += [
        "cells: failure rate, 0 = none; edges, vertices: cracks; edges2x: both triangles of an edge hit",
        "  (by design for closed triangles); sphere: misses; scales: answers other than the float64 reference's;",
        "  tiny, needle, grazing: misses; parallel, in plane, degenerate, nonfinite: hits",
        f"promises (the CSV's expected column): {int((df.verdict != 'measured').sum())} checked, "
        f"{int((df.verdict == 'fail').sum())} broken, marked !",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    import sys

    from ..protocol import serve_apart

    sys.exit(serve_apart(_work))
