"""The charts that check the measurement: every process's value, drift over time, batches by round.

The batches are thousands in a default run, so the drift and rounds charts draw the summaries
:mod:`.tables.diagnostics` makes of them (:func:`~.tables.diagnostics.drift_bins`,
:func:`~.tables.diagnostics.round_summary`); the per-process chart draws every process."""

from __future__ import annotations

import altair as alt
import pandas as pd

from .charts import WIDTH, intervals, kernel_colour, kernel_legend, rule_at_one, shown

__all__ = ["processes_chart", "drift_chart", "rounds_chart"]

_REL = "ns/test ÷ process median"


def processes_chart(
    pp: pd.DataFrame, est: pd.DataFrame, labels: dict[str, str], colours: dict[str, str]
) -> alt.TopLevelMixin | None:
    """Every worker process's median ns/test (dots) above each kernel's estimate (diamond) and 95% CI, on the
    workload the menu picks (``labels`` names each workload id). None without an estimate."""
    wids = list(dict.fromkeys(est["workload_id"]))
    if not wids:
        return None
    menu = alt.param(
        name="workload",
        value=wids[0],
        bind=alt.binding_select(options=wids, labels=[labels.get(w, w) for w in wids], name="workload: "),
    )
    kernels = kernel_legend()
    colours = {k: c for k, c in colours.items() if k in set(est["kernel"])}
    y = alt.Y("kernel:N", sort=list(colours), title=None)
    x = alt.X("ns_per_test:Q", scale=alt.Scale(zero=False), title="ns per ray–triangle test")
    dots = (
        alt.Chart(pp[["workload_id", "kernel", "process", "ns_per_test"]])
        .transform_filter(alt.datum.workload_id == menu)
        .mark_circle(size=22, yOffset=-4)
        .encode(
            x=x,
            y=y,
            color=kernel_colour(colours),
            opacity=shown(kernels, 0.65, 0.05),
            tooltip=["kernel:N", "process:Q", alt.Tooltip("ns_per_test:Q", title="ns/test", format=".4g")],
        )
    )
    frame = est.assign(ns=intervals(est, "ns_per_test", " ns"))
    columns = ["workload_id", "kernel", "ns_per_test", "ns_per_test_ci_low", "ns_per_test_ci_high", "ns"]
    base = (
        alt.Chart(frame[columns + ["n_processes"]])
        .transform_filter(alt.datum.workload_id == menu)
        .encode(y=y, color=kernel_colour(colours), opacity=shown(kernels))
    )
    ci = base.mark_rule(strokeWidth=2, yOffset=5).encode(x=alt.X("ns_per_test_ci_low:Q"), x2="ns_per_test_ci_high:Q")
    tooltip = [
        "kernel:N",
        alt.Tooltip("ns:N", title="mean ns/test [95% CI]"),
        alt.Tooltip("n_processes:Q", title="processes"),
    ]
    mean = base.mark_point(shape="diamond", filled=True, size=60, yOffset=5).encode(x=x, tooltip=tooltip)
    return alt.layer(dots.add_params(kernels), ci, mean).add_params(menu).properties(width=WIDTH, height=alt.Step(20))


def _quartiles(data: pd.DataFrame) -> list[str]:
    return [f"{m:.4g} [{a:.4g}, {b:.4g}]" for m, a, b in data[["rel_median", "rel_q1", "rel_q3"]].to_numpy()]


def drift_chart(bins: pd.DataFrame, colours: dict[str, str]) -> alt.TopLevelMixin | None:
    """Each kernel's timed batches over their process's median against time in the process (:func:`drift_bins`):
    a line through the spans' medians, and their quartiles as a band for the kernels clicked. None without one."""
    if bins.empty:
        return None
    data = bins.assign(text=_quartiles(bins))[["kernel", "t_s", "rel_q1", "rel_median", "rel_q3", "batches", "text"]]
    kernels = kernel_legend()
    x = alt.X("t_s:Q", title="seconds since the worker process started")
    band = (
        alt.Chart(data)
        .mark_area()
        .encode(
            x=x,
            y=alt.Y("rel_q1:Q", scale=alt.Scale(zero=False), title=_REL),
            y2="rel_q3:Q",
            color=kernel_colour(colours),
            opacity=shown(kernels, 0.2, 0.0, empty=False),
        )
    )
    tooltip = ["kernel:N", alt.Tooltip("t_s:Q", title="seconds (span's median)", format=".2f")]
    tooltip += [alt.Tooltip("text:N", title="median [quartiles]"), "batches:Q"]
    line = (
        alt.Chart(data)
        .mark_line(point=True)
        .encode(x=x, y="rel_median:Q", color=kernel_colour(colours), opacity=shown(kernels), tooltip=tooltip)
    )
    return alt.layer(band, rule_at_one("y"), line.add_params(kernels)).properties(width=WIDTH, height=260)


def rounds_chart(rounds: pd.DataFrame, colours: dict[str, str]) -> alt.TopLevelMixin | None:
    """Each kernel's batches by round over their process's median (:func:`round_summary`): median (dot), quartiles
    (thick), least to most (thin), the farthest Tukey outlier ringed (a cross when far out); warm-ups shaded."""
    if rounds.empty:
        return None
    frame = rounds.assign(
        text=_quartiles(rounds), range=[f"{a:.4g} to {b:.4g}" for a, b in rounds[["rel_min", "rel_max"]].to_numpy()]
    )
    columns = ["kernel", "round", "rel_min", "rel_q1", "rel_median", "rel_q3", "rel_max", "batches", "outliers"]
    data = frame[columns + ["far_out", "worst_outlier", "text", "range"]]
    kernels = kernel_legend()
    x = alt.X("round:O", title="round inside the process (negative: warm-up)")
    warm = pd.DataFrame({"round": sorted(set(rounds.loc[rounds["warmup"], "round"]))})
    shade = [alt.Chart(warm).mark_rect(color="#fde68a", opacity=0.35).encode(x=x)] if len(warm) else []
    base = alt.Chart(data).encode(
        x=x, xOffset=alt.XOffset("kernel:N", sort=list(colours)), color=kernel_colour(colours), opacity=shown(kernels)
    )
    whisker = base.mark_rule().encode(y=alt.Y("rel_min:Q", scale=alt.Scale(zero=False), title=_REL), y2="rel_max:Q")
    box = base.mark_rule(strokeWidth=4).encode(y="rel_q1:Q", y2="rel_q3:Q")
    tooltip = ["kernel:N", "round:O", alt.Tooltip("text:N", title="median [quartiles]")]
    tooltip += [
        alt.Tooltip("range:N", title="least to most"),
        "batches:Q",
        "outliers:Q",
        alt.Tooltip("far_out:Q", title="far out"),
    ]
    median = base.mark_point(filled=True, size=16, stroke="white", strokeWidth=0.5).encode(
        y="rel_median:Q", tooltip=tooltip
    )
    ring = (
        base.transform_filter("datum.outliers > 0")
        .mark_point(size=60, strokeWidth=1.2)
        .encode(
            y="worst_outlier:Q",
            color=alt.value("#c62828"),
            shape=alt.condition("datum.far_out > 0", alt.value("cross"), alt.value("circle")),
            tooltip=tooltip,
        )
    )
    layers = [*shade, rule_at_one("y"), whisker, box, median.add_params(kernels)]
    layers += [ring] if rounds["outliers"].any() else []  # a layer of no value would leave the y scale no extent
    return alt.layer(*layers).properties(width=WIDTH, height=260)
