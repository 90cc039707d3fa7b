"""Whether a run's conclusions hold on another machine: ``tribench replicate``'s ``replication.csv``.

A conclusion is a verdict of the original run: a kernel against the baseline on a workload (``speedups.csv``), an
order of two kernels on a workload (tested as ``tribench compare`` tests it, paired within each run) and a kernel's
place in a band (``bands.csv``: the fastest, or behind the fastest). The replication gives the same verdict its own
intervals, and each pair of verdicts gets one word (:func:`word`). Nothing is pooled across the runs: each run's
interval is its own."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pandas as pd

from ...harness import runfolder
from ...workloads.labels import family_of, short_label
from .compare import RunTables, compare_many

__all__ = ["COLUMNS", "WORDS", "conclusions", "machine_differences", "word"]

#: The words; "still inconclusive" is no conclusion in either run.
WORDS = ("holds", "reversed", "now inconclusive", "now decided", "still inconclusive")
#: Verdicts that decide something (the rest, "inconclusive", decide nothing).
DECIDED = frozenset({"faster", "slower", "equivalent", "fastest", "behind the fastest"})

#: replication.csv's columns (documented in the run folder's schema).
COLUMNS = list(runfolder.FILES[runfolder.REPLICATION])


def word(original: str, replicated: str) -> str:
    """What became of the original verdict: ``holds`` (the same decided verdict), ``reversed`` (another
    decided verdict: faster against slower, or a difference against equivalence), ``now inconclusive``,
    ``now decided`` (the original decided nothing) or ``still inconclusive``.

    >>> word("faster", "faster"), word("faster", "slower"), word("equivalent", "inconclusive")
    ('holds', 'reversed', 'now inconclusive')
    """
    if original in DECIDED:
        if replicated == original:
            return "holds"
        return "reversed" if replicated in DECIDED else "now inconclusive"
    return "now decided" if replicated in DECIDED else "still inconclusive"


def conclusions(original: RunTables, replicated: RunTables) -> pd.DataFrame:
    """Every conclusion of ``original`` beside the same in ``replicated`` (same baseline), with a word."""
    rows = [*_verdicts(original, replicated), *_orders(original, replicated), *_bands(original, replicated)]
    out = pd.DataFrame(rows, columns=COLUMNS)
    out["word"] = [word(a, b) for a, b in zip(out["original_verdict"], out["replicated_verdict"], strict=True)]
    return out


def _row(kind: str, where: str, wid: str, kernel: str, other: str, a: tuple, b: tuple) -> dict[str, Any]:
    """One conclusion: ``a`` and ``b`` are (ratio, ci_low, ci_high, verdict) of the original and the replication."""
    keys = ("ratio", "ci_low", "ci_high", "verdict")
    return {
        "conclusion": kind,
        "where": where,
        "workload_id": wid,
        "kernel": kernel,
        "other_kernel": other,
        **{f"original_{k}": v for k, v in zip(keys, a, strict=True)},
        **{f"replicated_{k}": v for k, v in zip(keys, b, strict=True)},
    }


def _verdicts(original: RunTables, replicated: RunTables) -> list[dict[str, Any]]:
    """Each kernel against the baseline (ratio: its speedup), per workload and kernel both runs have."""
    fields = ["ratio", "ratio_ci_low", "ratio_ci_high", "verdict"]
    new = replicated.speedups.set_index(["workload_id", "kernel"])[fields]
    rows = []
    for r in original.speedups.itertuples(index=False):
        if (r.workload_id, r.kernel) in new.index:
            a = (r.ratio, r.ratio_ci_low, r.ratio_ci_high, r.verdict)
            b = tuple(new.loc[(r.workload_id, r.kernel)])
            spec = original.specs[r.workload_id]
            where = f"{family_of(spec)}: {short_label(spec)}"
            rows.append(_row("against the baseline", where, r.workload_id, r.kernel, original.baseline, a, b))
    return rows


def _orders(original: RunTables, replicated: RunTables) -> list[dict[str, Any]]:
    """Each order of two kernels per workload, oriented by the original (ratio: time_other / time_kernel)."""
    rows = []
    for r in compare_many([original, replicated]).orders.to_dict("records"):
        a, b = ((r[f"ratio_{t}"], r[f"ratio_{t}_ci_low"], r[f"ratio_{t}_ci_high"], r[f"verdict_{t}"]) for t in "AB")
        where = f"{r['family']}: {r['label']}"
        rows.append(_row("order of two", where, r["workload_id"], r["kernel"], r["other_kernel"], a, b))
    return rows


def _place(band: pd.DataFrame) -> dict[str, tuple]:
    """Each kernel's place in one band, as a verdict with its time over the fastest's: ``fastest`` (first, and
    nothing tied with it), ``behind the fastest`` (told apart from it) or ``inconclusive`` (tied with it)."""
    tied = band["tied_with_fastest"].astype(bool)
    alone = int(tied.sum()) == 1  # the fastest is tied with itself only
    out = {}
    for r, t in zip(band.itertuples(index=False), tied, strict=True):
        verdict = (
            ("fastest" if alone else "inconclusive") if r.rank == 1 else ("inconclusive" if t else "behind the fastest")
        )
        out[r.kernel] = (r.vs_fastest, r.vs_fastest_ci_low, r.vs_fastest_ci_high, verdict)
    return out


def _bands(original: RunTables, replicated: RunTables) -> list[dict[str, Any]]:
    """Each kernel's place in each precision's hit-rate band (ratio: its time over the band's fastest)."""
    a_bands, b_bands = (d.tables.get(runfolder.BANDS, pd.DataFrame()) for d in (original, replicated))
    if a_bands.empty or b_bands.empty:
        return []
    rows = []
    for (dtype, band), here in a_bands.groupby(["dtype", "band"], sort=False):
        there = b_bands.loc[(b_bands["dtype"] == dtype) & (b_bands["band"] == band)]
        a, b = _place(here), _place(there)
        fastest = str(here.loc[here["rank"] == 1, "kernel"].iloc[0])
        for kernel in (k for k in a if k in b):
            other = fastest if kernel != fastest else ""  # the fastest's own place is against the rest
            rows.append(_row("place in its band", f"{dtype}, {band}", "", kernel, other, a[kernel], b[kernel]))
    return rows


def machine_differences(a: Mapping[str, Any], b: Mapping[str, Any]) -> list[tuple[str, str, str]]:
    """(what, original, here) for each fact of two machine records (``run.json``'s ``machine``) that differs."""
    facts = {
        "CPU": lambda m: m.get("cpu_model"),
        "architecture": lambda m: m.get("machine"),
        "SIMD features": lambda m: m.get("simd_features"),
        "compiler": lambda m: m.get("build", {}).get("compiler"),
        "compile flags": lambda m: m.get("build", {}).get("flags"),
        "platform": lambda m: m.get("platform"),
        "tribench": lambda m: m.get("tribench"),
    }
    return [(what, str(get(a)), str(get(b))) for what, get in facts.items() if get(a) != get(b)]
