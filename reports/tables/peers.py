"""The peers' figures: rays/s per contender and tribench's ratios over each peer, from ``peers.csv``."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ...common import UserError
from ...harness import runfolder, stats
from ...harness.jobs.peers import CONTENDERS, NATIVE_EMBREE, PEER_NAMES

__all__ = ["format_summary", "summarise"]


def summarise(peers: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(rates, ratios)`` of a ``peers.csv`` (``peer_rates.csv``, ``peer_ratios.csv``: docs/run-folder.md).

    Rates are geometric means over processes of each process's geometric mean,
    with t intervals; ratios are paired by process, tribench over each peer (and
    its C loop over its call, Embree robust over plain: what watertightness costs)."""
    rates_ok = np.isfinite(peers["rays_per_s"]) & (peers["rays_per_s"] > 0)
    if peers.empty or not rates_ok.all():
        raise UserError(
            f"{runfolder.PEERS} needs rows with positive, finite rays_per_s ({int((~rates_ok).sum())} are not)"
        )
    per_process = (
        peers.assign(log_rate=np.log(peers["rays_per_s"]), share=peers["cpu_ns"] / peers["wall_ns"])
        .groupby(["contender", "process"], sort=False)
        .agg(
            log_rate=("log_rate", "mean"),
            share=("share", "median"),
            setup_ns=("setup_ns", "median"),
            rays=("rays", "first"),
            differ=("differ", "max"),
            differ_ambiguous=("differ_ambiguous", "max"),
            implementation=("implementation", "first"),
        )
        .reset_index()
    )
    per_process["rays_per_s"] = np.exp(per_process["log_rate"])
    order = [c for c in CONTENDERS if c in set(per_process["contender"])]
    rates = []
    for name in order:
        g = per_process.loc[per_process["contender"] == name]
        gm = stats.geometric_mean(g["rays_per_s"])
        rates.append(
            {
                "contender": name,
                "implementation": g["implementation"].iloc[0],
                "rays": int(g["rays"].iloc[0]),
                "rays_per_s": gm.mean,
                "ci_low": gm.ci_low,
                "ci_high": gm.ci_high,
                "n_processes": gm.n,
                "cpu_share": float(g["share"].median()),
                "setup_ms": float(g["setup_ns"].median()) / 1e6,
                "differ": int(g["differ"].max()),
                "differ_ambiguous": int(g["differ_ambiguous"].max()),
            }
        )
    wide = per_process.pivot(index="process", columns="contender", values="rays_per_s")
    ratios = []
    for a, b in (
        [("tribench", p) for p in PEER_NAMES]
        + [("tribench_call", p) for p in PEER_NAMES]
        + [("tribench_packets", p) for p in NATIVE_EMBREE]
        + [("tribench", "tribench_call"), ("tribench_packets", "tribench")]
        + [("embree_robust", "embree"), ("embree_robust_16", "embree_16")]
    ):
        if a in wide and b in wide:
            pair = wide[[a, b]].dropna()
            # rays/s a over b = time per ray of b over a's: a speedup with b as the baseline
            s = stats.speedup(1 / pair[b], 1 / pair[a])
            ratios.append(
                {
                    "contender": a,
                    "over": b,
                    "ratio": s.ratio,
                    "ci_low": s.ci_low,
                    "ci_high": s.ci_high,
                    "n_processes": s.n,
                }
            )
    return pd.DataFrame(rates), pd.DataFrame(ratios)


def format_summary(rates: pd.DataFrame, ratios: pd.DataFrame) -> str:
    """The two tables of :func:`summarise` as text."""
    lines = [f"{'contender':<18}{'rays':>8}{'rays/s':>12}   {'95% CI':<24}{'CPU':>5}{'setup ms':>10}   implementation"]
    for r in rates.itertuples(index=False):
        ci = f"[{r.ci_low:.4g}, {r.ci_high:.4g}]"
        lines.append(
            f"{r.contender:<18}{r.rays:>8}{r.rays_per_s:>12.4g}   {ci:<24}{r.cpu_share:>5.0%}"
            f"{r.setup_ms:>10.1f}   {r.implementation}"
        )
    lines.append("\nrays/s ratios, paired by process (>1: the first is faster)")
    for r in ratios.itertuples(index=False):
        lines.append(f"  {r.contender:<17} / {r.over:<17}{r.ratio:>10.4g}   [{r.ci_low:.4g}, {r.ci_high:.4g}]")
    return "\n".join(lines)
