"""``report.html``: one self-contained page per run, put together from its sections.

The page kit (shell, CSS, tables, figures, escaping) is :mod:`.page`; the
sections are made by :mod:`.headline`, :mod:`.ranking`, :mod:`.results` (kernels, speedups, hit
rate, size and working set, peers, processes), :mod:`.bvh` (in a BVH), :mod:`.checks` (drift,
diagnostics, correctness, robustness) and :mod:`.about` (workloads, machine,
reproduce). Every number comes from the run folder's files.

Sections, by id, in page order:

>>> list(SECTIONS)  # doctest: +NORMALIZE_WHITESPACE
['headline', 'ranking', 'kernels', 'speedups', 'hit-rate', 'scaling', 'peers', 'processes', 'drift', 'diagnostics',
 'correctness', 'robustness', 'workloads', 'machine', 'reproduce']

and, only in a run that has one, after the section named:

>>> OPTIONAL_SECTIONS
{'bvh': ('In a BVH', 'scaling')}
"""

from __future__ import annotations

import pandas as pd

from tribench.harness import analysis, runfolder

from . import about, bvh, checks, content, figures, headline, page, ranking, results
from .about import sweep_toml
from .headline import headline_sentences
from .rundata import RunData, load_peers, load_validation

__all__ = ["OPTIONAL_SECTIONS", "SECTIONS", "render", "headline_sentences", "sweep_toml", "MAX_PICTURES"]

#: Section ids, in page order, with their titles.
SECTIONS = {
    "headline": "Headline",
    "ranking": "Ranking",
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

#: Sections a run has only sometimes: id -> (title, id of the section it follows).
OPTIONAL_SECTIONS = {"bvh": ("In a BVH", "scaling")}

#: At most this many workload pictures are drawn, at this resolution, by the analysis step
#: (:mod:`tribench.harness.analysis`; 60 dpi: 840 to 1080 px wide, 1.5 to 2 times the ~550 px shown).
MAX_PICTURES, PICTURE_DPI = analysis.MAX_PICTURES, analysis.PICTURE_DPI


def render(data: RunData, sweep_file: str = "sweep.toml") -> str:
    """The whole page for one run, as a string: every number from the run folder's files."""
    wl = content.workload_table(data)
    est = content.sweep_order(content.estimates_table(data, wl), data)
    spd = content.sweep_order(content.speedups_table(data, wl), data)
    pp = content.table(data, runfolder.PER_PROCESS)
    batches = content.table(data, runfolder.BATCH_LABELS)
    cross = content.table(data, runfolder.CROSSOVERS)
    slopes = content.table(data, runfolder.SLOPES)
    drift = content.table(data, runfolder.DRIFT)
    correct = content.table(data, runfolder.CORRECTNESS)
    kern = content.table(data, runfolder.KERNELS)
    val, val_note = load_validation(data)
    peers, peer_note = load_peers(data)
    colours = figures.kernel_colours(data.kernels)

    bodies = {
        "headline": headline.headline_section(data, spd, wl, headline.run_warnings(data, drift, correct), peers),
        "ranking": ranking.ranking_section(
            data,
            content.sweep_order(content.table(data, runfolder.RANKING), data),
            content.table(data, runfolder.ALGORITHMS),
        ),
        "kernels": results.kernels_section(data, kern),
        "speedups": results.speedups_section(data, spd, est),
        "hit-rate": results.hit_rate_section(data, est, spd, cross, colours),
        "scaling": results.scaling_section(data, est, slopes, colours),
        "peers": results.peers_section(peers, peer_note),
        "processes": results.processes_section(data, pp, est, wl, colours),
        "drift": checks.drift_section(data, batches, drift, colours),
        "diagnostics": checks.diagnostics_section(data, batches, wl),
        "correctness": checks.correctness_section(data, correct, wl),
        "robustness": checks.robustness_section(val, val_note),
        "workloads": about.pictures_section(data, wl),
        "machine": about.machine_section(data),
        "reproduce": about.reproduce_section(data, sweep_file),
    }
    # an analysis made before bvh.csv existed has none: no section, as for a run without a BVH workload
    in_bvh = data.tables.get(runfolder.BVH, pd.DataFrame())
    optional = {"bvh": bvh.bvh_section(in_bvh, peers, colours)}
    titles: dict[str, str] = {}
    for sid, title in SECTIONS.items():
        titles[sid] = title
        for extra, (extra_title, after) in OPTIONAL_SECTIONS.items():
            if after == sid and optional[extra]:
                titles[extra] = extra_title
    bodies.update(optional)
    # The headline opens the page with its own title, so its section has no heading.
    body = "".join(page.section(sid, None if sid == "headline" else titles[sid], bodies[sid]) for sid in titles)
    footer = page.p(
        f"Written by tribench report at {page.now()} from {data.run_dir}; tables made by the analysis "
        f"step at {data.record.get('created', '?')}. Statistics: tribench.stats.",
        "note",
    )
    return page.document(f"tribench report — {data.run.get('run_id', data.run_dir.name)}", body, titles, footer)


# tests/test_peers.py renders the peers section alone under its old name.
_peers = results.peers_section
