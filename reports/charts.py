"""The report's chart kit: Vega-Lite specs made with Altair, drawn in the page by Vega-Embed; and the charts that
check the measurement (every process's value, drift over time, batches by round).

The page carries the library once, in its head (:func:`library`), and each chart is its spec with the data inline,
so the file opens offline (why Vega-Lite: docs/results.md). The charts of the kernels' speed are :mod:`.speed_charts`.
No chart computes a statistic: intervals, ranks, verdicts and binned medians arrive in the frames; the batches are
thousands in a default run, so the drift and rounds charts draw the summaries :mod:`.tables.diagnostics` makes of
them (:func:`~.tables.diagnostics.drift_bins`, :func:`~.tables.diagnostics.round_summary`)."""

from __future__ import annotations

import contextlib
import contextvars
import functools
import json
import math
from collections.abc import Callable, Iterator
from html import escape
from pathlib import Path
from typing import Any

import altair as alt
import pandas as pd

__all__ = [
    "USED",
    "FIGURES",
    "VERDICT_COLOURS",
    "library",
    "embed",
    "collecting",
    "write_figures",
    "kernel_colours",
    "processes_chart",
    "drift_chart",
    "rounds_chart",
]

#: What every chart's script calls: a page that has it needs :func:`library` in its head.
USED = "vegaEmbed("

#: Pixels: a chart's plotting area is this wide (the page's column is 1180 px; the legend goes beside it).
WIDTH = 760
#: How a legend says it filters the page's chart; a printed figure has no clicks, so it loses this.
CLICK = " (click to show alone)"

#: The main charts' vector files in a run folder's ``figures/`` (:func:`write_figures`): chart id -> file
#: name, named by what the chart shows.
FIGURES = {
    "chart-answer": "fastest-kernels-per-band",
    "chart-forest": "speedups-over-baseline",
    "chart-hit-rate": "ns-per-test-by-hit-rate",
    "chart-speedup-hit-rate": "speedup-by-hit-rate",
    "chart-scaling": "ns-per-test-by-size",
}

VERDICT_COLOURS = {"faster": "#1a7f37", "slower": "#c62828", "equivalent": "#5f6b7a", "inconclusive": "#d97706"}
# Vega's tableau10, then its light shades (tableau20's): the main job ranks about thirty kernels.
_PALETTE = (
    "#1f77b4 #ff7f0e #2ca02c #d62728 #9467bd #8c564b #e377c2 #7f7f7f #bcbd22 #17becf "
    "#aec7e8 #ffbb78 #98df8a #ff9896 #c5b0d5 #c49c94 #f7b6d2 #c7c7c7 #dbdb8d #9edae5"
).split()

# The specs embedded while a report is rendered, for its vector figures (:func:`collecting`).
_collected: contextvars.ContextVar[dict[str, dict[str, Any]] | None] = contextvars.ContextVar("collected", default=None)


@functools.cache
def _vl_version() -> str | None:
    """vl-convert's Vega-Lite version: the one Altair writes, where vl-convert has it (None: its default)."""
    import vl_convert

    version = alt.SCHEMA_VERSION.lstrip("v").rsplit(".", 1)[0]
    return version if version in vl_convert.get_vegalite_versions() else None


@functools.cache
def library() -> str:
    """Vega, Vega-Lite (the version Altair writes) and Vega-Embed as one script, made once per process."""
    import vl_convert

    version = _vl_version()
    return vl_convert.javascript_bundle(**({"vl_version": version} if version else {}))


@contextlib.contextmanager
def collecting() -> Iterator[dict[str, dict[str, Any]]]:
    """Within it, every :func:`embed`-ed chart's spec lands in the dict it yields, by chart id."""
    specs: dict[str, dict[str, Any]] = {}
    token = _collected.set(specs)
    try:
        yield specs
    finally:
        _collected.reset(token)


def write_figures(specs: dict[str, dict[str, Any]], folder: Path) -> list[Path]:
    """Each main chart of ``specs`` as SVG and PDF in ``folder`` (:data:`FIGURES` names them), for a paper.

    Drawn by vl-convert from the same spec as the page's chart, so the two cannot disagree;
    the files of charts this report no longer has are removed, so the folder matches the page."""
    import vl_convert

    from ..common import write_bytes, write_text

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for chart_id, stem in FIGURES.items():
        svg, pdf = folder / f"{stem}.svg", folder / f"{stem}.pdf"
        if chart_id not in specs:
            svg.unlink(missing_ok=True)
            pdf.unlink(missing_ok=True)
            continue
        spec = {**json.loads(json.dumps(specs[chart_id]).replace(CLICK, "")), "background": "white"}
        drawn = vl_convert.vegalite_to_svg(spec, vl_version=_vl_version())
        write_text(svg, drawn)
        write_bytes(pdf, vl_convert.svg_to_pdf(drawn))  # the same drawing: a fifth of drawing the spec again
        written += [svg, pdf]
    return written


def embed(chart: alt.TopLevelMixin, chart_id: str, description: str, caption: str) -> str:
    """A figure that draws ``chart`` when the page loads (the page's head must carry :func:`library`)."""
    spec = chart.to_dict()  # validated against Vega-Lite's schema
    spec.pop("$schema", None)  # a URL nothing needs: the library in the page is that version
    sink = _collected.get()
    if sink is not None:
        sink[chart_id] = spec
    data = json.dumps(spec, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    return (
        f'<figure class="chart"><div id="{escape(chart_id)}" role="img" aria-label="{escape(description)}"></div>'
        f'<script>vegaEmbed("#{escape(chart_id)}",{data},{{actions:false,renderer:"svg"}})'
        f".catch(e=>console.error(e))</script><figcaption>{escape(caption)}</figcaption></figure>"
    )


def kernel_colours(kernels: list[str]) -> dict[str, str]:
    """One colour per kernel, stable in the sweep's kernel order."""
    return {k: _PALETTE[i % len(_PALETTE)] for i, k in enumerate(kernels)}


def _interval(value: Any, low: Any, high: Any, unit: str = "") -> str:
    """A value with its interval (NaN or None: missing); the value alone where it has none."""
    from ..harness.stats import format_interval

    if pd.isna(value):
        return "–"
    if pd.isna(low):
        return f"{value:.3g}"
    return format_interval(float(value), float(low), math.nan if pd.isna(high) else float(high), unit=unit)


def intervals(frame: pd.DataFrame, column: str, unit: str, low: str = "", high: str = "") -> list[str]:
    """Each row's ``column`` with its interval (columns ``low`` and ``high``, by default
    ``<column>_ci_low`` and ``<column>_ci_high``) as text, for a tooltip."""
    lows, highs = frame[low or f"{column}_ci_low"], frame[high or f"{column}_ci_high"]
    return [_interval(v, lo, hi, unit) for v, lo, hi in zip(frame[column], lows, highs, strict=True)]


def kernel_colour(colours: dict[str, str]) -> alt.Color:
    """Kernels in their colours; every layer the same (layers that disagree drop the legend)."""
    return alt.Color(
        "kernel:N",
        title="kernel" + CLICK,
        scale=alt.Scale(domain=list(colours), range=list(colours.values())),
        legend=alt.Legend(symbolOpacity=1),
    )


def kernel_legend() -> alt.Parameter:
    """The legend's selection: a click shows a kernel alone, a shift-click adds one."""
    return alt.selection_point(name="kernels", fields=["kernel"], bind="legend")


def shown(selection: alt.Parameter, on: float = 1.0, off: float = 0.08, empty: bool = True) -> Any:
    """Opacity ``on`` for what ``selection`` holds (everything while it is ``empty``, unless told), else ``off``."""
    return alt.condition(selection, alt.value(on), alt.value(off), empty=empty)


def title(text: str) -> alt.TitleParams:
    """A panel's title, left-aligned."""
    return alt.TitleParams(text, anchor="start", fontSize=12)


def per_panel(
    data: pd.DataFrame, by: str, panel: Callable[[pd.DataFrame, alt.Chart], Any], marks: alt.Chart, legend: Any
) -> alt.VConcatChart:
    """One panel per value of ``by`` (a workload family, a scene), stacked, each with its own y scale.

    ``panel(rows, marks)`` draws one; the first panel's ``marks`` carry the ``legend`` selection,
    which the others' conditions read by name (a selection is defined in one view only)."""
    panels = [
        panel(rows, marks.add_params(legend) if i == 0 and legend is not None else marks).properties(
            title=title(str(name))
        )
        for i, (name, rows) in enumerate(data.groupby(by, sort=False))
    ]
    return alt.vconcat(*panels).resolve_scale(color="shared")


def rule_at_one(channel: str) -> alt.Chart:
    """A rule at 1 on the ``channel`` (x or y) axis, drawn once (its own data, not a rule per row of a panel)."""
    return alt.Chart(alt.Data(values=[{}])).mark_rule(color="#333").encode(**{channel: alt.datum(1.0)})


def margin_band(margin: float, channel: str) -> alt.Chart:
    """The equivalence margin around 1 on the ``channel`` (x or y) axis: a grey band, drawn once (its own data)."""
    row = alt.Data(values=[{"margin": f"±{100 * margin:.2g}%"}])
    return (
        alt.Chart(row)
        .mark_rect(color="#d0d7de", opacity=0.6)
        .encode(
            **{channel: alt.datum(1 / (1 + margin)), f"{channel}2": alt.datum(1 + margin)},
            tooltip=[alt.Tooltip("margin:N", title="equivalence margin")],
        )
    )


# ------------------------------------------------------------ the charts that check the measurement

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
