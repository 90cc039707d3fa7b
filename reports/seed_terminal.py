"""``tribench seed``'s table for the terminal: every kernel's replay beside the paper's times and ratios."""

from __future__ import annotations

import math

import pandas as pd

from ..harness import stats
from ..harness.jobs.seed import MISS_STAGES, PROGRAM
from .tables.seed import ratio_baseline

__all__ = ["format_table"]


def _curless_over_moller(g: pd.DataFrame) -> list[str]:
    """The paper's ratio beside the replay's: the program's (object forms), predicted with the model's error."""
    rows = g.set_index("kernel")
    kernel = PROGRAM[0] if PROGRAM[0] in rows.index else "curless_seed"
    if kernel not in rows.index or ratio_baseline(kernel) not in rows.index:
        return []
    c = rows.loc[kernel]
    paper = (
        f"paper {c.paper_ratio_real:.3f} (real), {c.paper_ratio_user:.3f} (user); "
        if math.isfinite(c.paper_ratio_real)
        else ""
    )
    replay = stats.format_interval(
        c.ratio_to_moller_seed, c.ratio_to_moller_seed_ci_low, c.ratio_to_moller_seed_ci_high, ".3f"
    )
    line = f"  Curless / Moller: {paper}replay ({kernel}) {replay}"
    if math.isfinite(c.predicted_ratio_low):
        predicted = stats.format_interval(None, c.predicted_ratio_low, c.predicted_ratio_high, ".3f")
        line += f"; the seed's program here: {predicted}"
    return [line]


def format_table(seed: pd.DataFrame, workloads: pd.DataFrame | None = None) -> str:
    """The table beside the paper, for the terminal."""
    lines = [
        "The seed's renders replayed, triangle tests only, mean over processes with 95% CIs: the _object forms",
        "as the seed's program runs them (its objects, calls and scene loop), the others as tribench's loop does.",
        "ratio = time_kernel / time of moller_seed_object for the _object forms, of moller_seed for the others",
        "(paired per process). Paper: Unix time of the whole render.",
    ]
    for scene, g in seed.groupby("scene", sort=False):
        first = g.iloc[0]
        lines += [
            "",
            f"{scene}: {first['triangles']} triangles, {first['render_tests']:.3g} ray-triangle tests "
            f"per render, {first['n_processes']} processes",
        ]
        if workloads is not None:
            r = workloads.loc[(workloads["scene"] == scene) & (workloads["rays"] == "render")]
            if len(r):
                r = r.iloc[0]
                mix = ", ".join(f"{s.replace('outside_', '')} {100 * r[f'miss_{s}']:.1f}%" for s in MISS_STAGES)
                lines.append(f"  per-test hit rate {100 * r['test_hit_rate']:.3f}%; misses: {mix}")
        lines.append(f"  {'kernel':<26}{'paper real s':>13}{'replay s':>11}  {'95% CI':<22}{'ratio':>7}  95% CI")
        for r in g.itertuples(index=False):
            paper = f"{r.paper_real_s:13.3f}" if math.isfinite(r.paper_real_s) else f"{'':13}"
            render_ci = stats.format_interval(None, r.render_s_ci_low, r.render_s_ci_high, ".4g")
            ratio_ci = stats.format_interval(None, r.ratio_to_moller_seed_ci_low, r.ratio_to_moller_seed_ci_high, ".3f")
            lines.append(
                f"  {r.kernel:<26}{paper}{r.render_s:11.4g}  {render_ci:<22}{r.ratio_to_moller_seed:7.3f}  {ratio_ci}"
            )
        lines += _curless_over_moller(g)
    return "\n".join(lines)
