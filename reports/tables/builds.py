"""Across the builds of one run (``--builds``): does the ranking hold under every build?

Each build's processes are a run of their own to a comparison, so builds are compared by the code that compares
machines (:func:`tribench.reports.tables.compare.compare_many`); ``builds.csv`` has each order's test in long form,
a row per pair and build."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from ...harness import runfolder
from .margin import TWINS

__all__ = ["BuildView", "builds_table", "views"]


@dataclass(frozen=True)
class BuildView:
    """One build's part of a run, as a comparison reads a run (:class:`~tribench.reports.tables.compare.RunTables`)."""

    run_dir: Path
    build: str
    baseline: str
    margin: float
    kernels: list[str]
    workload_ids: list[str]
    specs: dict[str, Any]
    tables: dict[str, pd.DataFrame]
    estimates: pd.DataFrame
    speedups: pd.DataFrame


def views(run_dir: Path, specs: dict[str, Any], baseline: str, parts: dict[str, dict[str, Any]]) -> list[BuildView]:
    """A view per build: ``parts`` maps a build to its margin and its tables (without a ``build`` column)."""
    out = []
    for build, part in parts.items():
        tables = part["tables"]
        est = tables[runfolder.ESTIMATES]
        kernels = [k for k in dict.fromkeys(est["kernel"]) if k not in TWINS]
        wids = [w for w in specs if w in set(est["workload_id"])]
        out.append(
            BuildView(
                run_dir, build, baseline, part["margin"], kernels, wids, specs, tables, est, tables[runfolder.SPEEDUPS]
            )
        )
    return out


def builds_table(m: Any, parts: dict[str, Any], tables: dict[str, dict[str, pd.DataFrame]]) -> pd.DataFrame:
    """``builds.csv``: every order of two kernels per workload, tested under each build (none for one build)."""
    from .compare import compare_many

    columns = list(runfolder.FILES[runfolder.BUILDS])
    if len(parts) < 2:
        return pd.DataFrame(columns=columns)
    baseline = next(iter(parts.values())).baseline
    build_parts = {b: {"margin": a.margin.value, "tables": tables[b]} for b, a in parts.items()}
    many = compare_many(views(m.run_dir, m.specs, baseline, build_parts), same_run=True)
    return long_orders(many.orders, many.tags, list(parts))


def long_orders(orders: pd.DataFrame, tags: list[str], builds: list[str]) -> pd.DataFrame:
    """A comparison's orders (a column group per run tag) in long form: a row per pair and build."""
    from .compare import _ORDER_KEYS as keys  # the pair's columns, as the comparison has them

    rows = []
    for r in orders.to_dict("records"):
        for tag, build in zip(tags, builds, strict=True):
            rows.append(
                {
                    **{k: r[k] for k in keys},
                    "build": build,
                    "ratio": r[f"ratio_{tag}"],
                    "ratio_ci_low": r[f"ratio_{tag}_ci_low"],
                    "ratio_ci_high": r[f"ratio_{tag}_ci_high"],
                    "verdict": r[f"verdict_{tag}"],
                    "order": r["order"],
                    "confidence": r["confidence"],
                }
            )
    return pd.DataFrame(rows, columns=list(runfolder.FILES[runfolder.BUILDS]))
