"""The report's section on a run of several builds (``--builds``): do the answers hold under every build?

Each build is read as a run of its own (``load_run(build=)``) and compared as :mod:`.tables.builds` says."""

from __future__ import annotations

import pandas as pd

from . import page
from .compare import _many_parts
from .rundata import RunData, load_run
from .tables.compare import compare_many

__all__ = ["builds_section", "build_views"]


def build_views(data: RunData) -> list[RunData]:
    """The run as each of its builds measured it, the build ``data`` shows first."""
    return [data] + [load_run(data.run_dir, build=b) for b in data.builds if b != data.build]


def builds_section(data: RunData) -> str:
    """The section, or "" for a run of one build."""
    if len(data.builds) < 2:
        return ""
    views = build_views(data)
    many = compare_many(views, same_run=True)
    records = {b.get("spec"): b for b in data.run.builds}
    rows = []
    for tag, view in zip(many.tags, views, strict=True):
        b = records.get(view.build, {})
        rows.append(
            {
                "tag": tag,
                "build": view.build,
                "compiler": b.get("compiler", "?"),
                "flags": b.get("flags", "?"),
                "processes": view.n_processes,
                "check": _check_text(b.get("check")),
            }
        )
    cols = [
        ("tag", ""),
        ("build", "build"),
        ("compiler", "compiler"),
        ("flags", "exact flags"),
        ("processes", "processes"),
        ("check", "checked against the reference again, before timing"),
    ]
    intro = page.p(
        f"The processes took the {len(views)} builds in turn, so each build's figures come from its own "
        f"processes; the rest of this page shows build {data.build}. Each build below is a run of its own: its "
        "speedups, and every order of two kernels tested under each build (builds.csv). A build that breaks "
        "a promise of a kernel (a flag such as -ffast-math or -ffp-contract=fast changes results) still ran: "
        "the last column says what its kernels got wrong."
    )
    broken = [r for r in rows if r["check"] not in ("every kernel right", "not checked (pip's build)")]
    warnings = "".join(page.warn(f"build {r['build']}: {r['check']}") for r in broken)
    return (
        intro
        + warnings
        + page.table(pd.DataFrame(rows), cols)
        + "".join(_many_parts(many, unit="build", ids=("build-speedups", "build-orders")))
    )


def _check_text(check: dict | None) -> str:
    if check is None:
        return "not checked (pip's build)"
    wrong = {k: v for k, v in check.items() if v}
    if not wrong:
        return "every kernel right"
    return "; ".join(f"{k}: {', '.join(v[:2])}{' ...' if len(v) > 2 else ''}" for k, v in wrong.items())
