"""The report's ranking: per workload, the fastest kernel, what ties with it, and what robustness costs.

Part of ``report.html`` (:mod:`.html` puts the sections together); every number
is read from ``ranking.csv``, which the analysis step wrote
(:func:`tribench.harness.tables.ranking_table`).
"""

from __future__ import annotations

import math

import pandas as pd

from tribench.stats import format_interval

from . import page
from .rundata import RunData

__all__ = ["QUESTIONS", "algorithm_order", "question_rows", "ranking_rows", "ranking_section"]

#: The head-to-head questions the report answers when a run has both algorithms (algorithm names:
#: tribench.ext.kernel_info(k).algorithm): Baldwin & Weber's claim, and the seed's question.
QUESTIONS: tuple[tuple[str, str], ...] = (
    ("baldwin_weber_12", "moller_trumbore"),
    ("baldwin_weber_9", "moller_trumbore"),
    ("curless", "moller_trumbore"),
    ("curless_seed", "moller_seed"),
)


def _interval(value: float, low: float, high: float, unit: str = "") -> str:
    return format_interval(value, low, high, unit=unit) if not math.isnan(value) else "–"


def _named(kernel: str, rows: pd.DataFrame) -> str:
    """The kernel's name, marked when it culls back faces (it answers another question: front faces only)."""
    if "culls_back_faces" not in rows:
        return kernel
    culls = rows.loc[rows["kernel"] == kernel, "culls_back_faces"]
    return f"{kernel} (front faces only)" if len(culls) and str(culls.iloc[0]) == "True" else kernel


def ranking_rows(rank: pd.DataFrame) -> pd.DataFrame:
    """One display row per workload of ``ranking.csv`` (its rows in file order).

    Examples
    --------
    >>> rank = pd.DataFrame({"workload_id": ["w", "w"], "family": ["f", "f"], "label": ["l", "l"],
    ...     "dtype": ["float32"] * 2, "rank": [1, 2], "kernel": ["a", "b"], "ns_per_test": [1.0, 2.0],
    ...     "ns_per_test_ci_low": [0.9, 1.9], "ns_per_test_ci_high": [1.1, 2.1], "vs_fastest": [1.0, 2.0],
    ...     "vs_fastest_ci_low": [1.0, 1.8], "vs_fastest_ci_high": [1.0, 2.2], "tied_with_fastest": [True, False],
    ...     "speedup": [2.0, 1.0], "speedup_ci_low": [1.8, float("nan")], "speedup_ci_high": [2.2, float("nan")],
    ...     "baseline": ["b", "b"], "watertight": [False, True], "bytes_per_triangle": [36, 48]})
    >>> r = ranking_rows(rank).iloc[0]
    >>> r["fastest"], r["ns"], r["next"], r["watertight_best"]
    ('a', '1 [0.9, 1.1]', 'b: 2× [1.8, 2.2] slower', 'b: 2× [1.8, 2.2] slower')
    >>> ranking_rows(rank.assign(culls_back_faces=[True, False])).iloc[0]["fastest"]
    'a (front faces only)'
    """
    rows = []
    for _, g in rank.groupby("workload_id", sort=False):
        g = g.sort_values("rank")
        best = g.iloc[0]
        tied = [_named(k, g) for k in g.loc[g["tied_with_fastest"].astype(bool), "kernel"] if k != best["kernel"]]
        rest = g.iloc[1:]

        def slower(r: pd.Series, g: pd.DataFrame = g) -> str:
            ratio = _interval(r["vs_fastest"], r["vs_fastest_ci_low"], r["vs_fastest_ci_high"], "×")
            return f"{_named(r['kernel'], g)}: {ratio} slower"

        tight = g.loc[g["watertight"].astype(str) == "True"]
        if tight.empty:
            watertight = "none in this run"
        elif tight.iloc[0]["rank"] == 1:
            watertight = f"{tight.iloc[0]['kernel']} (the fastest)"
        else:
            watertight = slower(tight.iloc[0])
        rows.append(
            {
                "dtype": best["dtype"],
                "workload": f"{best['family']} · {best['label']}",
                "fastest": _named(best["kernel"], g),
                "ns": _interval(best["ns_per_test"], best["ns_per_test_ci_low"], best["ns_per_test_ci_high"]),
                "speedup": (
                    "(the baseline)"
                    if best["kernel"] == best["baseline"]
                    else _interval(best["speedup"], best["speedup_ci_low"], best["speedup_ci_high"], "×")
                ),
                "tied": ", ".join(tied) or "none",
                "next": slower(rest.iloc[0]) if len(rest) else "–",
                "watertight_best": watertight,
                "bytes": best["bytes_per_triangle"],
            }
        )
    return pd.DataFrame(rows)


def algorithm_order(rank: pd.DataFrame) -> pd.DataFrame:
    """Per workload, the algorithms from the fastest down, each by its fastest form, in one line.

    Examples
    --------
    >>> rank = pd.DataFrame({"workload_id": ["w"] * 3, "family": ["f"] * 3, "label": ["l"] * 3,
    ...     "dtype": ["float32"] * 3, "rank": [1, 2, 3], "kernel": ["a_fast", "b", "a"],
    ...     "algorithm": ["a", "b", "a"], "vs_fastest": [1.0, 1.5, 2.0], "vs_fastest_ci_low": [1.0, 1.4, 1.9],
    ...     "vs_fastest_ci_high": [1.0, 1.6, 2.1]})
    >>> algorithm_order(rank)["order"].iloc[0]
    'a (a_fast) · b 1.5× [1.4, 1.6]'
    """
    rows = []
    for _, g in rank.groupby("workload_id", sort=False):
        best = g.sort_values("rank").drop_duplicates("algorithm")
        parts = []
        for r in best.itertuples(index=False):
            if r.rank == 1:
                form = f" ({r.kernel})" if r.kernel != r.algorithm else ""
                parts.append(f"{r.algorithm}{form}")
            else:
                form = f" ({r.kernel})" if r.kernel != r.algorithm else ""
                ratio = _interval(r.vs_fastest, r.vs_fastest_ci_low, r.vs_fastest_ci_high, "×")
                parts.append(f"{r.algorithm}{form} {ratio}")
        first = g.iloc[0]
        rows.append(
            {"dtype": first["dtype"], "workload": f"{first['family']} · {first['label']}", "order": " · ".join(parts)}
        )
    return pd.DataFrame(rows)


def question_rows(alg: pd.DataFrame) -> pd.DataFrame:
    """Per workload, the answer to each of :data:`QUESTIONS` the run can answer (``algorithms.csv``).

    Examples
    --------
    >>> alg = pd.DataFrame({"workload_id": ["w"], "family": ["f"], "label": ["l"], "dtype": ["float64"],
    ...     "algorithm": ["moller_trumbore"], "kernel": ["mt"], "other_algorithm": ["curless"],
    ...     "other_kernel": ["c"], "ratio": [1.5], "ratio_ci_low": [1.4], "ratio_ci_high": [1.6],
    ...     "verdict": ["faster"]})
    >>> question_rows(alg).iloc[0]["curless vs moller_trumbore"]
    'moller_trumbore faster: 1.5× [1.4, 1.6]'
    """
    rows = []
    for _, g in alg.groupby("workload_id", sort=False):
        first = g.iloc[0]
        row = {"dtype": first["dtype"], "workload": f"{first['family']} · {first['label']}"}
        for a, b in QUESTIONS:
            hit = g.loc[
                ((g["algorithm"] == a) & (g["other_algorithm"] == b))
                | ((g["algorithm"] == b) & (g["other_algorithm"] == a))
            ]
            if hit.empty:
                continue
            r = hit.iloc[0]
            ratio = _interval(r["ratio"], r["ratio_ci_low"], r["ratio_ci_high"], "×")
            said = {"faster": f"{r['algorithm']} faster", "equivalent": "equivalent"}.get(
                r["verdict"], "not told apart"
            )
            row[f"{a} vs {b}"] = f"{said}: {ratio}"
        if len(row) > 2:
            rows.append(row)
    return pd.DataFrame(rows)


def ranking_section(data: RunData, rank: pd.DataFrame, alg: pd.DataFrame | None = None) -> str:
    """The ranking table per precision, the order of the algorithms, the head-to-head questions."""
    if rank.empty:
        return page.p("No ranking: this run has no estimate.")
    shown = ranking_rows(rank)
    cols = [
        ("workload", "workload"),
        ("fastest", "fastest kernel"),
        ("ns", "its ns/test [95% CI]"),
        ("speedup", f"its speedup over {data.baseline}"),
        ("tied", "not told apart from it"),
        ("next", "next kernel, time / fastest's"),
        ("watertight_best", "fastest watertight kernel"),
        ("bytes", "bytes per triangle (fastest)"),
    ]
    parts = []
    for dtype, g in shown.groupby("dtype", sort=False):
        parts.append(f"<h3>{dtype}</h3>" + page.table(g, cols))
    if rank["algorithm"].nunique() > 1:
        order = algorithm_order(rank)
        parts.append("<h3>The algorithms in order</h3>")
        parts.append(
            page.p(
                "Each algorithm by its fastest form on the workload, and that form's time over the fastest's "
                "[simultaneous 95% CI].",
                "note",
            )
        )
        for dtype, g in order.groupby("dtype", sort=False):
            parts.append(page.table(g, [("workload", f"workload ({dtype})"), ("order", "fastest first")]))
    answers = question_rows(alg) if alg is not None and not alg.empty else pd.DataFrame()
    if not answers.empty:
        asked = [c for c in answers.columns if c not in ("dtype", "workload")]
        parts.append("<h3>Head to head</h3>")
        parts.append(
            page.p(
                "Baldwin & Weber's claim (faster than Möller–Trumbore at every hit rate) and the seed's question "
                "(Curless against Möller), each algorithm in its fastest form here: the faster one's speedup "
                "[simultaneous 95% CI, Bonferroni over the workload's pairs of algorithms] (algorithms.csv).",
                "note",
            )
        )
        for dtype, g in answers.groupby("dtype", sort=False):
            parts.append(page.table(g, [("workload", f"workload ({dtype})")] + [(c, c) for c in asked]))
    parts.append(
        page.p(
            "Per workload, the kernel with the lowest mean ns per test, and every other kernel's time over "
            "its time, paired by process, with simultaneous 95% intervals (Bonferroni over the workload's kernels). "
            f"“Not told apart” lists the kernels whose interval reaches down to 1 + the equivalence margin "
            f"({100 * data.margin:.2g}%): the point estimate alone picked the fastest among them. Every kernel's "
            "rank is in ranking.csv.",
            "note",
        )
    )
    return "".join(parts)
