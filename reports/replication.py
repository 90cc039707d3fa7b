"""The report's section on a replication (``tribench replicate``): did the original run's conclusions hold here?

It opens on the count of each word, names what differs between the two machines, then lists the conclusions that did
not hold, worst first. Every row is ``replication.csv``'s (:mod:`tribench.reports.tables.replication`)."""

from __future__ import annotations

from html import escape

import pandas as pd

from ..harness import runfolder
from ..harness.stats import format_estimate
from . import page
from .rundata import RunData
from .tables.replication import WORDS, machine_differences

__all__ = ["replication_section", "summary"]

#: At most this many conclusions that did not hold are listed; replication.csv has them all.
MAX_ROWS = 40


def summary(table: pd.DataFrame) -> str:
    """``"Of 52 conclusions of the original run: holds 40, reversed 1, ..."``: every word, in :data:`WORDS`' order."""
    counts = table["word"].value_counts()
    words = ", ".join(f"{w} {int(counts.get(w, 0))}" for w in WORDS)
    return f"Of {len(table)} conclusions of the original run: {words}."


def replication_section(data: RunData) -> str:
    """The section, or "" for a run that replicates nothing."""
    path = data.run_dir / runfolder.REPLICATION
    rep = data.run.replicates
    if rep is None or not path.is_file():
        return ""
    table = pd.read_csv(path, keep_default_na=False, na_values=[""])
    differ = machine_differences(rep.get("machine", {}), data.machine)
    parts = [
        page.p(
            f"This run measured again the plan of run {escape(str(rep.get('run_id')))} "
            f"({escape(str(rep.get('run_dir')))}) on this machine. {summary(table)} "
            "A conclusion holds when the replication gives the same verdict, each run with its own interval."
        ),
        page.kv_table([(what, f"{a} → {b}") for what, a, b in differ])
        if differ
        else page.p("The two runs' CPU, compiler, flags and tribench are the same.", "note"),
        *(page.warn(line) for line in rep.get("left_out", [])),
    ]
    rank = {w: i for i, w in enumerate(WORDS)}  # in WORDS' order: reversed first
    shown = table.loc[table["word"] != "holds"].sort_values("word", key=lambda s: s.map(rank), kind="stable")
    shown = shown.assign(
        original=[_figure(r, "original") for r in shown.itertuples()],
        replicated=[_figure(r, "replicated") for r in shown.itertuples()],
    )
    cols = [
        ("word", "what became of it"),
        ("conclusion", "conclusion"),
        ("where", "where"),
        ("kernel", "kernel"),
        ("other_kernel", "against"),
        ("original", "original: ratio [95% CI], verdict"),
        ("replicated", "here: ratio [95% CI], verdict"),
    ]
    parts.append(page.table(shown.head(MAX_ROWS), cols))
    if len(shown) > MAX_ROWS:
        parts.append(page.p(f"{len(shown) - MAX_ROWS} more in {runfolder.REPLICATION}.", "note"))
    return "".join(parts)


def _figure(r, run: str) -> str:
    ratio, low, high = (getattr(r, f"{run}_{k}") for k in ("ratio", "ci_low", "ci_high"))
    return f"{format_estimate(ratio, low, high, '×')}, {getattr(r, f'{run}_verdict')}"
