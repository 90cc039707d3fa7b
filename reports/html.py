"""``report.html``: one self-contained page per run, put together from its sections.

What each section shows is docs/results.md's; the page kit is :mod:`.page`, and :func:`render` names each body's module.

Sections, by id, in page order (a new section: its title here and its body in :func:`render`):

>>> list(SECTIONS)  # doctest: +NORMALIZE_WHITESPACE
['answer', 'ranking', 'headline', 'kernels', 'speedups', 'hit-rate', 'scaling', 'peers', 'processes', 'drift',
 'diagnostics', 'correctness', 'robustness', 'workloads', 'machine', 'reproduce']

and, only in a run that has one, after the section named:

>>> OPTIONAL_SECTIONS  # doctest: +NORMALIZE_WHITESPACE
{'replication': ('Replication', 'answer'), 'builds': ('Across builds', 'ranking'),
 'bvh': ('In a BVH', 'scaling')}
"""

from __future__ import annotations

import pandas as pd

from ..harness import runfolder
from . import about, bvh, charts, checks, compare, headline, page, ranking, replication, results, rundata
from .rundata import RunData, load_peers, load_validation

__all__ = ["OPTIONAL_SECTIONS", "SECTIONS", "OPEN", "render"]

#: Section ids, in page order, with their titles.
SECTIONS = {
    "answer": "The answer",
    "ranking": "Ranking per workload",
    "headline": "Every kernel against the baseline",
    "kernels": "Kernels",
    "speedups": "Speedups",
    "hit-rate": "Hit rate",
    "scaling": "Size and working set",
    "peers": "Against peers",
    "processes": "Per-process values",
    "drift": "Drift",
    "diagnostics": "Diagnostics",
    "correctness": "Correctness",
    "robustness": "Robustness",
    "workloads": "Workloads",
    "machine": "Machine and build",
    "reproduce": "Reproduce",
}

#: Sections shown open; every other one is collapsed under its title.
OPEN = frozenset({"answer", "replication"})  # a replication is why its report is read

#: Sections a run has only sometimes: id -> (title, id of the section it follows).
OPTIONAL_SECTIONS = {
    "replication": ("Replication", "answer"),
    "builds": ("Across builds", "ranking"),
    "bvh": ("In a BVH", "scaling"),
}


def render(data: RunData, sweep_file: str = "sweep.toml") -> str:
    """The whole page for one run, as a string: every number from the run folder's files."""
    wl = data.tables[runfolder.WORKLOADS]
    est = rundata.sweep_order(rundata.estimates_table(data, wl), data)
    spd = rundata.sweep_order(rundata.speedups_table(data, wl), data)
    batches = data.tables[runfolder.BATCH_LABELS]
    drift = rundata.named(data.tables[runfolder.DRIFT], data)
    correct = data.tables[runfolder.CORRECTNESS]
    val, val_note = load_validation(data)
    peers, peer_note = load_peers(data)
    colours = charts.kernel_colours(data.kernels)

    alg = data.tables[runfolder.ALGORITHMS]
    bands = data.tables.get(runfolder.BANDS)  # None: tables of an older tribench
    bodies = {
        "answer": headline.title(data, wl)
        + _build_shown(data)
        + ranking.answer_section(data, bands, alg, colours)
        + "".join(page.warn(w) for w in headline.run_warnings(data, drift, correct)),
        "headline": headline.headline_section(data, spd, wl, peers),
        "ranking": ranking.ranking_section(data, data.tables[runfolder.RANKING], alg),
        "kernels": results.kernels_section(data, data.tables[runfolder.KERNELS]),
        "speedups": results.speedups_section(data, spd, est),
        "hit-rate": results.hit_rate_section(data, est, spd, data.tables[runfolder.CROSSOVERS], colours),
        "scaling": results.scaling_section(data, est, data.tables[runfolder.SLOPES], colours),
        "peers": results.peers_section(peers, peer_note),
        "processes": results.processes_section(data.tables[runfolder.PER_PROCESS], est, colours),
        "drift": checks.drift_section(batches, drift, colours),
        "diagnostics": checks.diagnostics_section(data, batches, colours),
        "correctness": checks.correctness_section(correct, wl),
        "robustness": checks.robustness_section(val, val_note),
        "workloads": about.pictures_section(data, wl),
        "machine": about.machine_section(data),
        "reproduce": about.reproduce_section(data, sweep_file),
    }
    # an analysis made before bvh.csv existed has none: no section, as for a run without a BVH workload
    in_bvh = data.tables.get(runfolder.BVH, pd.DataFrame())
    optional = {
        "replication": replication.replication_section(data),
        "builds": compare.builds_section(data),
        "bvh": bvh.bvh_section(in_bvh, peers, colours),
    }
    titles: dict[str, str] = {}
    for sid, title in SECTIONS.items():
        titles[sid] = title
        for extra, (extra_title, after) in OPTIONAL_SECTIONS.items():
            if after == sid and optional[extra]:
                titles[extra] = extra_title
    bodies.update(optional)
    # The answer opens the page with the page's title, so its section has no heading of its own.
    body = "".join(
        page.section(sid, None if sid == "answer" else titles[sid], bodies[sid], collapsed=sid not in OPEN)
        for sid in titles
    )
    written = (
        f"tribench report at {page.now()} from {data.run_dir}; tables made by the analysis step at "
        f"{data.record.get('created', '?')}"
    )
    return page.document(f"tribench report — {data.run.run_id}", body, titles, written)


def _build_shown(data: RunData) -> str:
    if len(data.builds) < 2:
        return ""
    return page.p(
        f"This page shows build {data.build} ({data.builds.index(data.build) + 1} of {len(data.builds)}: "
        f"{'; '.join(data.builds)}); Across builds compares them.",
        "note",
    )
