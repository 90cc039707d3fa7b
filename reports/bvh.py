"""The report's "In a BVH" section: every kernel as the leaf test of a tracer's BVH.

Every number is read from ``bvh.csv`` (:func:`tribench.reports.tables.bvh.bvh_table`)
and, for Embree, the peers' tables when they were timed with ``--accel bvh``."""

from __future__ import annotations

import math

import pandas as pd

from ..harness.jobs.peers import PEER_NAMES
from ..harness.stats import format_estimate
from . import page
from .charts import embed
from .results import PEER_RATE_COLUMNS
from .rundata import PeerTables
from .speed_charts import bvh_chart

__all__ = ["CLAIM", "CLAIMANTS", "bvh_figure", "bvh_rows", "bvh_section", "claim_answer", "claim_sentences"]

#: Baldwin & Weber (JCGT 5(3), 2016): their tests make a complete tracer (pbrt) this much faster
#: end to end than Moller-Trumbore, as a range of speedups.
CLAIM = (1.01, 1.06)
#: Their algorithms, and the one they compare with (``tribench.ext.kernel_info(k).algorithm``).
CLAIMANTS = ("baldwin_weber_12", "baldwin_weber_9")
CLAIM_BASELINE = "moller_trumbore"


def _percent(value: float, low: float, high: float) -> str:
    return format_estimate(100 * value, 100 * low, 100 * high, "%")


def claim_answer(low: float, high: float) -> str:
    """What a 95% interval of an end-to-end speedup says about the claim of 1-6% faster (:data:`CLAIM`).

    Written to follow "the claim":

    >>> claim_answer(1.02, 1.04), claim_answer(0.98, 1.005), claim_answer(0.90, 0.95)
    ('holds here', 'does not hold here (less than 1% faster)', 'does not hold here (slower)')
    >>> claim_answer(0.99, 1.03), claim_answer(1.07, 1.09)
    ('is not confirmed here (the interval includes no gain)', 'is exceeded here (more than 6% faster)')
    >>> claim_answer(math.nan, math.nan)
    'cannot be judged (one process, no interval)'
    """
    least, most = CLAIM
    if math.isnan(low) or math.isnan(high):
        return "cannot be judged (one process, no interval)"
    if high < 1:
        return "does not hold here (slower)"
    if high < least:
        return f"does not hold here (less than {100 * (least - 1):.0f}% faster)"
    if low > most:
        return f"is exceeded here (more than {100 * (most - 1):.0f}% faster)"
    if low > 1:
        return "holds here"
    return "is not confirmed here (the interval includes no gain)"


def claim_sentences(bvh: pd.DataFrame) -> list[str]:
    """The claim answered on every BVH workload of ``bvh.csv`` where a claimant ran against Moller-Trumbore."""
    out = []
    for _, g in bvh.groupby("workload_id", sort=False):
        base = g.loc[g["kernel"] == g["baseline"]]
        if base.empty or base["algorithm"].iloc[0] != CLAIM_BASELINE:
            continue
        for r in g.loc[g["algorithm"].isin(CLAIMANTS)].itertuples(index=False):
            share = (
                f"; the leaf tests are {_percent(r.leaf_share, r.leaf_share_ci_low, r.leaf_share_ci_high)} "
                "of its trace time"
                if not math.isnan(r.leaf_share)
                else ""
            )
            out.append(
                f"Baldwin & Weber's end-to-end claim (1–6% more rays/s in a complete tracer) on {r.family} · "
                f"{r.label}: {r.kernel} against {r.baseline}, "
                f"{format_estimate(r.speedup, r.speedup_ci_low, r.speedup_ci_high, '×')} the rays/s "
                f"(simultaneous 95% CI): the claim {claim_answer(r.speedup_ci_low, r.speedup_ci_high)}{share}."
            )
    return out


def bvh_rows(bvh: pd.DataFrame) -> pd.DataFrame:
    """One display row per workload and kernel of ``bvh.csv``.

    >>> row = {"family": "f", "label": "l", "dtype": "float32", "rays_kind": "camera", "kernel": "k",
    ...     "baseline": "k", "rays_per_s": 2e6, "rays_per_s_ci_low": 1.9e6, "rays_per_s_ci_high": 2.1e6,
    ...     "speedup": 1.0, "speedup_ci_low": 1.0, "speedup_ci_high": 1.0, "verdict": "baseline",
    ...     "brute_speedup": float("nan"), "brute_speedup_ci_low": float("nan"),
    ...     "brute_speedup_ci_high": float("nan"), "leaf_share": 0.4, "leaf_share_ci_low": 0.35,
    ...     "leaf_share_ci_high": 0.45, "nodes_per_ray": 30.5, "triangle_tests_per_ray": 40.0}
    >>> r = bvh_rows(pd.DataFrame([row])).iloc[0]
    >>> r["rate"], r["speedup"], r["brute"], r["share"]
    ('2e+06 [1.9e+06, 2.1e+06]', '(the baseline)', '–', '40% [35, 45]')
    """
    rows = []
    for r in bvh.itertuples(index=False):
        is_base = r.kernel == r.baseline
        rows.append(
            {
                "dtype": r.dtype,
                "workload": f"{r.family} · {r.label}",
                "kernel": r.kernel,
                "rate": format_estimate(r.rays_per_s, r.rays_per_s_ci_low, r.rays_per_s_ci_high),
                "speedup": "(the baseline)"
                if is_base
                else format_estimate(r.speedup, r.speedup_ci_low, r.speedup_ci_high, "×"),
                "verdict": "" if is_base else r.verdict,
                "brute": format_estimate(r.brute_speedup, r.brute_speedup_ci_low, r.brute_speedup_ci_high, "×")
                if not is_base
                else ("(the baseline)" if not math.isnan(r.brute_speedup) else "–"),
                "share": _percent(r.leaf_share, r.leaf_share_ci_low, r.leaf_share_ci_high),
                "nodes": r.nodes_per_ray,
                "tests": r.triangle_tests_per_ray,
            }
        )
    return pd.DataFrame(rows)


def bvh_figure(bvh: pd.DataFrame, colours: dict[str, str]) -> str:
    """Rays/s of every kernel in a BVH against the mesh's triangle count, with 95% CIs, as a page chart."""
    return embed(
        bvh_chart(bvh, colours),
        "chart-bvh",
        "rays per second of every kernel in a BVH by mesh size",
        "Rays/s end to end in the BVH (traversal and leaf tests, one core): geometric mean over processes, "
        "lines 95% CI (bvh.csv); dashes: the kind of rays, shapes: the precision. Hover for the figures; click a "
        "kernel in the legend to show it alone.",
    )


def _embree(peers: PeerTables | None) -> str:
    """tribench's BVH against Embree, when the run's peers were timed through the BVH."""
    if peers is None or not peers.in_bvh:
        return ""
    ours = peers.ratios.loc[peers.ratios["contender"] == "tribench"].set_index("over")
    said = [
        f"{format_estimate(r.ratio, r.ci_low, r.ci_high, '×')} {call}'s"
        for name, call in (("embree", "Embree's rtcIntersect1"), ("embree_16", "its rtcIntersect16"))
        if name in ours.index
        for r in [ours.loc[name]]
    ]
    text = (
        f"Against native Embree on {peers.workload} (tribench peers --accel bvh, one core, both timed in C): "
        f"tribench's BVH with {peers.kernel} runs at "
        + (" and ".join(said) + " rays/s (95% CIs)." if said else "(native Embree was not measured).")
    )
    packets = peers.ratios.loc[peers.ratios["contender"] == "tribench_packets"].set_index("over")
    if "embree_16" in packets.index:
        r = packets.loc["embree_16"]
        text += (
            f" Walked by packets of 16 rays (one box test per node for a packet sharing its origin), it runs at "
            f"{format_estimate(r.ratio, r.ci_low, r.ci_high, '×')} Embree's rtcIntersect16's."
        )
    ours_too = ["tribench", "tribench_packets"]
    shown = peers.rates.loc[peers.rates["contender"].isin([*ours_too, *(n for n in PEER_NAMES if n != "trimesh")])]
    return (
        "<h3>Against Embree</h3>"
        + page.p(text)
        + page.table(
            shown, [*(c for c in PEER_RATE_COLUMNS[:7] if c[0] != "rays"), ("setup_ms", "set-up ms (the build)")]
        )
    )


def bvh_section(bvh: pd.DataFrame, peers: PeerTables | None, colours: dict[str, str]) -> str:
    """The section's body: the claim, one table per precision, the figure, Embree; "" without a BVH workload."""
    if bvh.empty:
        return ""
    parts = [page.p(s) for s in claim_sentences(bvh)]
    shown = bvh_rows(bvh)
    cols = [
        ("workload", "workload"),
        ("kernel", "leaf test"),
        ("rate", "rays/s [95% CI]"),
        ("speedup", "speedup in the BVH [CI]"),
        ("verdict", "verdict"),
        ("brute", "same in brute force [CI]"),
        ("share", "leaf tests' share of trace time [95% CI]"),
        ("nodes", "nodes / ray"),
        ("tests", "triangle tests / ray"),
    ]
    for dtype, g in shown.groupby("dtype", sort=False):
        parts.append(f"<h3>{dtype}</h3>" + page.table(g, cols))
    parts.append(bvh_figure(bvh, colours))
    parts.append(_embree(peers))
    baselines = ", ".join(dict.fromkeys(bvh["baseline"]))
    parts.append(
        page.p(
            "Each kernel as the leaf test of tribench's BVH (ext/bvh.h: a binned SAH tree collapsed to nodes of "
            "8 children in float32, 4 in float64, each node's boxes tested at once), every batch a single-ray "
            "closest-hit traversal timed inside C. Speedups are of rays/s end to end against "
            f"{baselines} (the run's baseline's form that can be a leaf test, else Möller–Trumbore's), paired by "
            "process, with simultaneous 95% intervals (Bonferroni over the workload's kernels); beside them the "
            "same ratio in brute force on the same rays and mesh (ns per test), where the run has that workload: "
            "does the ranking carry into a tracer? The leaf tests' share is 1 − null / real: each batch is traced "
            "again with the leaf test replaced by nothing (each ray's t_max at the kernel's own hit, so it enters "
            "the nodes a ray that found its hit at once would enter), just before or after it at random; per "
            "process the median ratio, geometric mean over processes (traversals.csv). The null traversal enters "
            "no more nodes than the real one, so the share also counts the extra nodes a ray visits before it "
            "finds its hit. Every figure is in bvh.csv.",
            "note",
        )
    )
    return "".join(parts)
