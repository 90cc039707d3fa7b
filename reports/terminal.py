"""Terminal tables of a run: per workload, estimates and speedups with CIs and verdicts, then the answer."""

from __future__ import annotations

from ..harness import runfolder
from ..harness.stats import format_interval
from ..workloads.labels import family_of
from .rundata import RunData, short_label
from .tables.frames import in_order

__all__ = ["format_answer", "format_run"]


def format_run(data: RunData, width: int = 24) -> str:
    """Per workload (sweep order): each kernel's ns/test with its 95% CI, then its speedup and verdict."""
    est, spd = data.estimates, data.speedups
    lines = [
        f"run {data.run.run_id}: {len(data.kernels)} kernels x "
        f"{len(data.workload_ids)} workloads, {data.n_processes} processes x {data.run.sweep.rounds} rounds"
        + (
            f"; build {data.build} ({len(data.builds)} builds: the report's Across builds compares them)"
            if len(data.builds) > 1
            else ""
        ),
        f"ns/test: mean over processes, 95% CI; speedup = time_{data.baseline} / time_kernel, "
        f"simultaneous 95% CI; margin ±{100 * data.margin:.2g}%",
    ]
    for wid in data.workload_ids:
        spec = data.specs[wid]
        rows = in_order(est.loc[est["workload_id"] == wid], kernel=data.kernels)
        if rows.empty:
            continue
        sp = spd.loc[spd["workload_id"] == wid].set_index("kernel")
        lines += [
            "",
            f"{family_of(spec)}: {short_label(spec)}  [{wid}]",
            f"  {'kernel':<{width}}{'ns/test':>9}  {'95% CI':<18}{'speedup':>8}  {'CI':<16}  verdict",
        ]
        for r in rows.itertuples(index=False):
            ci = format_interval(None, r.ns_per_test_ci_low, r.ns_per_test_ci_high, ".3f")
            left = f"  {r.kernel:<{width}}{r.ns_per_test:9.3f}  {ci:<18}"
            if r.kernel in sp.index:
                s = sp.loc[r.kernel]
                ci = format_interval(None, s["ratio_ci_low"], s["ratio_ci_high"], ".3f")
                left += f"{s['ratio']:7.3f}x  {ci:<16}  {s['verdict']}"
            elif r.kernel == data.baseline:
                left += "(baseline)"
            lines.append(left.rstrip())
    return "\n".join(lines + ["", format_answer(data)])


def format_answer(data: RunData) -> str:
    """The first screen in words: per precision and band the fastest kernel, its speedup and ties, then the answers."""
    from .ranking import answer_sentences, band_rows

    bands = data.tables.get(runfolder.BANDS)
    if bands is None or bands.empty:
        return "the answer: no ranking by band in these tables (run tribench stats on the folder)"
    lines = [f"the answer, per precision and band (speedup over {data.baseline}, 95% CI):"]
    for r in band_rows(bands).itertuples(index=False):
        lines.append(
            f"  {r.dtype} {r.band}: {r.fastest}, {r.ns} ns/test, {r.speedup}; tied with it: {r.tied}; "
            f"watertight: {r.watertight}"
        )
    lines += [f"  {sentence}" for sentence in answer_sentences(bands, data.tables.get(runfolder.ALGORITHMS))]
    return "\n".join(lines)
