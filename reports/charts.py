"""The report's interactive charts: Vega-Lite specs made with Altair, drawn in the page by Vega-Embed.

The page carries the library once, in its head (:func:`library`), and each chart is its spec with the data inline,
so the file opens offline; why Vega-Lite, and why the dense diagnostics stay static (:mod:`.figures`), is
docs/results.md's. No chart computes a statistic: intervals, ranks and verdicts arrive in the frames."""

from __future__ import annotations

import contextlib
import contextvars
import functools
import json
import math
from collections.abc import Iterator
from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Any

import altair as alt
import pandas as pd

__all__ = [
    "USED",
    "FIGURES",
    "library",
    "embed",
    "collecting",
    "write_figures",
    "answer_chart",
    "hit_rate_chart",
    "speedup_hit_rate_chart",
    "forest_chart",
]

#: What every chart's script calls: a page that has it needs :func:`library` in its head.
USED = "vegaEmbed("

#: Pixels: a chart's plotting area is this wide (the page's column is 1180 px; the legend goes beside it).
WIDTH = 760
_RATIO_FORMAT = ".3~g"
#: How a legend says it filters the page's chart; a printed figure has no clicks, so it loses this.
_CLICK = " (click to show alone)"


#: The main charts' vector files in a run folder's ``figures/`` (:func:`write_figures`): chart id -> file
#: name, named by what the chart shows.
FIGURES = {
    "chart-answer": "fastest-kernels-per-band",
    "chart-forest": "speedups-over-baseline",
    "chart-hit-rate": "ns-per-test-by-hit-rate",
    "chart-speedup-hit-rate": "speedup-by-hit-rate",
    "chart-scaling": "ns-per-test-by-size",
}

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
        spec = {**json.loads(json.dumps(specs[chart_id]).replace(_CLICK, "")), "background": "white"}
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


def _records(frame: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    """The columns a chart needs, NaN as missing (JSON has no NaN), numbers as floats."""
    out = frame[columns].copy()
    return out.astype(object).where(out.notna(), None)


def _interval(value: Any, low: Any, high: Any, unit: str = "") -> str:
    """A record's value with its interval (records hold None for NaN); the value alone where it has none."""
    from ..harness.stats import format_estimate

    if value is None:
        return "–"
    if low is None:
        return f"{value:.3g}"
    return format_estimate(float(value), float(low), math.nan if high is None else float(high), unit)


def _kernel_colour(colours: dict[str, str]) -> alt.Color:
    """Kernels in the colours of the static figures; every layer the same (layers that disagree drop the legend)."""
    return alt.Color(
        "kernel:N",
        title="kernel" + _CLICK,
        scale=alt.Scale(domain=list(colours), range=list(colours.values())),
        legend=alt.Legend(symbolOpacity=1),
    )


def _intervals(frame: pd.DataFrame, column: str, unit: str) -> list[str]:
    """Each row's ``column`` with its interval (columns ``<column>_ci_low`` and ``_ci_high``) as text."""
    return [
        _interval(v, lo, hi, unit)
        for v, lo, hi in zip(frame[column], frame[f"{column}_ci_low"], frame[f"{column}_ci_high"], strict=True)
    ]


def _kernel_legend() -> alt.Parameter:
    return alt.selection_point(name="kernels", fields=["kernel"], bind="legend")


def _answer_data(bands: pd.DataFrame) -> pd.DataFrame:
    """The answer chart's records: ``bands`` with the menu's place of each row and its tooltips as text."""
    frame = bands.assign(
        where=bands["dtype"] + " · " + bands["band"],
        ns=_intervals(bands, "ns_per_test", " ns"),
        over_fastest=[
            "(the fastest)" if rank == 1 else text
            for rank, text in zip(bands["rank"], _intervals(bands, "vs_fastest", "×"), strict=True)
        ],
        over_baseline=[
            "(the baseline)" if kernel == baseline else text
            for kernel, baseline, text in zip(
                bands["kernel"], bands["baseline"], _intervals(bands, "speedup", "×"), strict=True
            )
        ],
        # the robustness axis: what the suite measured, never the promises (kept by design, so 0 for all)
        failures_per_million=bands["cracks_per_million"] + bands["sphere_misses_per_million"],
        watertight_text=bands["watertight"].map({True: "yes", False: "no"}).fillna("unknown"),
    )
    return _records(
        frame,
        [
            "where",
            "rank",
            "kernel",
            "ns_per_test",
            "ns_per_test_ci_low",
            "ns_per_test_ci_high",
            "failures_per_million",
            "bytes_per_triangle",
            "watertight_text",
            "ns",
            "over_fastest",
            "over_baseline",
            "cracks_per_million",
            "sphere_misses_per_million",
        ],
    )


def _answer_axes(bands: pd.DataFrame) -> tuple[alt.Scale, alt.X, alt.Y]:
    """x: ns/test, log when the intervals allow; y: failures per million rays, symlog (0 to tens of thousands)."""
    # a t interval over few processes may reach below 0, which a log axis cannot show
    log = bool((bands["ns_per_test_ci_low"].dropna() > 0).all())
    x_scale = alt.Scale(type="log") if log else alt.Scale(type="linear")
    x = alt.X("ns_per_test:Q", scale=x_scale, title="ns per ray–triangle test" + (" (log)" if log else ""))
    y = alt.Y(
        "failures_per_million:Q",
        title="cracks + far-sphere misses per million rays (symlog)",
        scale=alt.Scale(type="symlog", constant=1),
    )
    return x_scale, x, y


def _answer_points(base: alt.Chart, x: alt.X, y: alt.Y, shown: Any, colours: dict[str, str], baseline: str):
    """A point per kernel: sized by its bytes per triangle, shaped by its watertightness, every figure on hover."""
    return base.mark_point(filled=True, stroke="#333", strokeWidth=0.6).encode(
        x=x,
        y=y,
        color=_kernel_colour(colours),
        size=alt.Size("bytes_per_triangle:Q", title="bytes per triangle", scale=alt.Scale(range=[40, 400])),
        shape=alt.Shape("watertight_text:N", title="watertight by its paper"),
        opacity=shown,
        tooltip=[
            alt.Tooltip("kernel:N", title="kernel"),
            alt.Tooltip("rank:Q", title="rank in the band"),
            alt.Tooltip("ns:N", title="ns/test [95% CI]"),
            alt.Tooltip("over_fastest:N", title="time / fastest's"),
            alt.Tooltip("over_baseline:N", title=f"speedup over {baseline}"),
            alt.Tooltip("bytes_per_triangle:Q", title="bytes per triangle"),
            alt.Tooltip("watertight_text:N", title="watertight by its paper"),
            alt.Tooltip("cracks_per_million:Q", title="cracks at shared edges per million rays", format=",.0f"),
            alt.Tooltip("sphere_misses_per_million:Q", title="far-sphere misses per million rays", format=",.0f"),
        ],
    )


def answer_chart(bands: pd.DataFrame, colours: dict[str, str]) -> alt.LayerChart:
    """Speed against robustness against memory (``bands.csv``): one point per kernel in the band chosen in the menu."""
    data = _answer_data(bands)
    # the legend names only the kernels some band ranks (not one whose answers differ everywhere it ran),
    # each in the colour it has in every other figure
    colours = {k: c for k, c in colours.items() if k in set(bands["kernel"])}
    places = list(dict.fromkeys(data["where"]))
    place = alt.param(name="band", value=places[0], bind=alt.binding_select(options=places, name="precision · band: "))
    kernels = _kernel_legend()
    baseline = str(bands["baseline"].iloc[0]) if len(bands) else "the baseline"
    base = alt.Chart(data).transform_filter(alt.datum.where == place)
    x_scale, x, y = _answer_axes(bands)
    shown = alt.condition(kernels, alt.value(0.95), alt.value(0.08))
    rules = base.mark_rule(strokeWidth=2).encode(
        x=alt.X("ns_per_test_ci_low:Q", scale=x_scale),
        x2="ns_per_test_ci_high:Q",
        y=y,
        color=_kernel_colour(colours),
        opacity=shown,
    )
    points = _answer_points(base, x, y, shown, colours, baseline)
    return (
        alt.layer(rules, points.add_params(kernels))
        .add_params(place)
        .properties(width=WIDTH, height=260)
        .configure_axis(grid=True, gridColor="#eee")
    )


def _per_family(data: pd.DataFrame, panel: Any, marks: alt.Chart, legend: alt.Parameter) -> alt.VConcatChart:
    """One panel per workload family, stacked, each with its own y scale and the colours of all.

    ``panel(rows, marks)`` draws a family; the first panel's ``marks`` carry the ``legend`` selection,
    which the others' conditions read by name (a selection is defined in one view only)."""
    panels = [
        panel(rows, marks.add_params(legend) if i == 0 else marks).properties(
            title=alt.TitleParams(str(family), anchor="start", fontSize=12)
        )
        for i, (family, rows) in enumerate(data.groupby("family", sort=False))
    ]
    return alt.vconcat(*panels).resolve_scale(color="shared")


def _hit_rate_rows(frame: pd.DataFrame) -> pd.DataFrame:
    pairs = frame.loc[frame["kind"] == "pairs"]
    families = [f for f, g in pairs.groupby("family", sort=False) if g["test_hit_rate"].nunique() >= 2]
    return pairs.loc[pairs["family"].isin(families)]


def hit_rate_chart(est: pd.DataFrame, cross: pd.DataFrame, colours: dict[str, str]) -> alt.VConcatChart | None:
    """ns/test against the per-test hit rate, a line per kernel with its 95% CI band, a panel per family,
    crossovers (``crossovers.csv``) as dashed rules. None when no pair family has two or more hit rates."""
    rows = _hit_rate_rows(est)
    if rows.empty:
        return None
    frame = rows.assign(ns=_intervals(rows, "ns_per_test", " ns"))
    data = _records(
        frame,
        [
            "family",
            "label",
            "kernel",
            "test_hit_rate",
            "ns_per_test",
            "ns_per_test_ci_low",
            "ns_per_test_ci_high",
            "ns",
        ],
    )
    kernels = _kernel_legend()
    shown = alt.condition(kernels, alt.value(1.0), alt.value(0.08))
    x = alt.X("test_hit_rate:Q", axis=alt.Axis(format="%"), title="per-test hit rate (achieved)")
    band = (
        alt.Chart()
        .mark_area(opacity=0.18)
        .encode(
            x=x,
            y=alt.Y("ns_per_test_ci_low:Q", title="ns per ray–triangle test"),
            y2="ns_per_test_ci_high:Q",
            color=_kernel_colour(colours),
            opacity=alt.condition(kernels, alt.value(0.18), alt.value(0.02)),
        )
    )
    line = (
        alt.Chart()
        .mark_line(point=True)
        .encode(
            x=x,
            y="ns_per_test:Q",
            color=_kernel_colour(colours),
            opacity=shown,
            tooltip=[
                alt.Tooltip("kernel:N"),
                alt.Tooltip("label:N", title="workload"),
                alt.Tooltip("test_hit_rate:Q", title="per-test hit rate", format=".1%"),
                alt.Tooltip("ns:N", title="ns/test [95% CI]"),
            ],
        )
    )
    found = cross.loc[cross["hit_rate"].notna()] if not cross.empty else cross
    crossings = _records(
        found.assign(
            pair=found["kernel_a"] + " = " + found["kernel_b"],
            at=[
                f"{100 * h:.3g}% [{100 * lo:.3g}%, {100 * hi:.3g}%]"
                for h, lo, hi in zip(found["hit_rate"], found["ci_low"], found["ci_high"], strict=True)
            ],
        ),
        ["family", "hit_rate", "pair", "at"],
    )

    def panel(d: pd.DataFrame, marks: alt.Chart) -> Any:
        layers = [band, marks]
        here = crossings.loc[crossings["family"] == d["family"].iloc[0]]
        if len(here):
            layers.append(
                alt.Chart(here)
                .mark_rule(color="#7c3aed", strokeDash=[4, 3])
                .encode(
                    x="hit_rate:Q",
                    tooltip=[alt.Tooltip("pair:N", title="crossover"), alt.Tooltip("at:N", title="at [95% CI]")],
                )
            )
        return alt.layer(*layers, data=d).properties(width=WIDTH, height=220)

    return _per_family(data, panel, line, kernels)


def speedup_hit_rate_chart(
    spd: pd.DataFrame, baseline: str, margin: float, colours: dict[str, str]
) -> alt.VConcatChart | None:
    """Speedup over the baseline against the per-test hit rate, with CI bands and the margin (log axis)."""
    rows = _hit_rate_rows(spd)
    if rows.empty:
        return None
    frame = rows.assign(speedup=_intervals(rows, "ratio", "×"))
    data = _records(
        frame,
        ["family", "label", "kernel", "test_hit_rate", "ratio", "ratio_ci_low", "ratio_ci_high", "speedup", "verdict"],
    )
    kernels = _kernel_legend()
    x = alt.X("test_hit_rate:Q", axis=alt.Axis(format="%"), title="per-test hit rate (achieved)")
    y_scale = alt.Scale(type="log")
    band = (
        alt.Chart()
        .mark_area(opacity=0.18)
        .encode(
            x=x,
            y=alt.Y("ratio_ci_low:Q", scale=y_scale, title=f"speedup over {baseline} (log)"),
            y2="ratio_ci_high:Q",
            color=_kernel_colour(colours),
            opacity=alt.condition(kernels, alt.value(0.18), alt.value(0.02)),
        )
    )
    line = (
        alt.Chart()
        .mark_line(point=True)
        .encode(
            x=x,
            y=alt.Y("ratio:Q", scale=y_scale),
            color=_kernel_colour(colours),
            opacity=alt.condition(kernels, alt.value(1.0), alt.value(0.08)),
            tooltip=[
                alt.Tooltip("kernel:N"),
                alt.Tooltip("label:N", title="workload"),
                alt.Tooltip("speedup:N", title=f"speedup over {baseline} [simultaneous 95% CI]"),
                alt.Tooltip("verdict:N"),
            ],
        )
    )
    one = alt.Chart().mark_rule(color="#333").encode(y=alt.datum(1.0))
    equivalent = (
        alt.Chart()
        .mark_rect(color="#d0d7de", opacity=0.6)
        .encode(y=alt.datum(1 / (1 + margin)), y2=alt.datum(1 + margin))
    )
    return _per_family(
        data,
        lambda d, marks: alt.layer(equivalent, one, band, marks, data=d).properties(width=WIDTH, height=200),
        line,
        kernels,
    )


def forest_chart(spd: pd.DataFrame, baseline: str, verdict_colours: dict[str, str]) -> alt.VConcatChart | None:
    """Every speedup with its simultaneous 95% CI, a row per kernel and workload, by verdict; None without one."""
    if spd.empty:
        return None
    frame = spd.assign(
        row=spd["kernel"] + " · " + spd["label"],
        speedup=_intervals(spd, "ratio", "×"),
    )
    data = _records(
        frame,
        ["family", "row", "kernel", "label", "ratio", "ratio_ci_low", "ratio_ci_high", "speedup", "verdict", "p_holm"],
    )
    names = list(dict.fromkeys(data["kernel"]))
    pick = alt.param(
        name="kernel_shown",
        value="every kernel",
        bind=alt.binding_select(options=["every kernel", *names], name="kernel: "),
    )
    verdicts = alt.selection_point(name="verdicts", fields=["verdict"], bind="legend")
    kept = (pick == "every kernel") | (alt.datum.kernel == pick)
    x_scale = alt.Scale(type="log")
    colour = alt.Color(
        "verdict:N",
        scale=alt.Scale(domain=list(verdict_colours), range=list(verdict_colours.values())),
        title="verdict" + _CLICK,
    )
    y = alt.Y("row:N", title=None, sort=None)
    rule = (
        alt.Chart()
        .mark_rule(strokeWidth=2)
        .encode(
            x=alt.X("ratio_ci_low:Q", scale=x_scale, title=f"speedup over {baseline} (log; > 1: faster)"),
            x2="ratio_ci_high:Q",
            y=y,
            color=colour,
            opacity=alt.condition(verdicts, alt.value(1.0), alt.value(0.1)),
        )
    )
    dot = (
        alt.Chart()
        .mark_point(filled=True, size=60)
        .encode(
            x=alt.X("ratio:Q", scale=x_scale),
            y=y,
            color=colour,
            opacity=alt.condition(verdicts, alt.value(1.0), alt.value(0.1)),
            tooltip=[
                alt.Tooltip("kernel:N"),
                alt.Tooltip("label:N", title="workload"),
                alt.Tooltip("speedup:N", title=f"speedup over {baseline} [simultaneous 95% CI]"),
                alt.Tooltip("verdict:N"),
                alt.Tooltip("p_holm:Q", title="p (Holm)", format=".2~g"),
            ],
        )
    )
    one = alt.Chart().mark_rule(color="#333").encode(x=alt.datum(1.0))
    chart = _per_family(
        data,
        lambda d, marks: (
            alt.layer(one, rule, marks, data=d)
            .transform_filter(kept)
            .properties(width=WIDTH - 220, height=alt.Step(16))
        ),
        dot,
        verdicts,
    )
    return chart.add_params(pick)


def _axis_scale(*columns: pd.Series) -> tuple[alt.Scale, str]:
    """A log scale when every value is above 0, else linear."""
    values = pd.concat([c.dropna() for c in columns])
    return (alt.Scale(type="log"), " (log)") if bool((values > 0).all()) else (alt.Scale(type="linear"), "")


@dataclass(frozen=True)
class _CostLayers:
    """What both scaling panels draw against their x: each workload's 95% CI and a line per kernel and family."""

    y_scale: alt.Scale
    y_title: str
    colours: dict[str, str]
    kernels: alt.Parameter  # the legend's selection, carried by one panel only
    tooltip: list[alt.Tooltip]

    def layer(self, x: alt.X, rows: pd.DataFrame, with_legend: bool) -> Any:
        """The intervals and the lines of ``rows`` against ``x``; ``with_legend``: this layer defines the selection."""
        shown = alt.condition(self.kernels, alt.value(1.0), alt.value(0.08))
        y = alt.Y("ns_per_test:Q", scale=self.y_scale, title=self.y_title)
        interval = (
            alt.Chart(rows)
            .mark_rule()
            .encode(
                x=x,
                y=alt.Y("ns_per_test_ci_low:Q", scale=self.y_scale),
                y2="ns_per_test_ci_high:Q",
                color=_kernel_colour(self.colours),
                opacity=shown,
            )
        )
        line = (
            alt.Chart(rows)
            .mark_line(point=True)
            .encode(
                x=x,
                y=y,
                color=_kernel_colour(self.colours),
                strokeDash=alt.StrokeDash("family:N", legend=None),
                detail="family:N",
                opacity=shown,
                tooltip=self.tooltip,
            )
        )
        return alt.layer(interval, line.add_params(self.kernels) if with_legend else line)


def _panel_title(text: str) -> alt.TitleParams:
    return alt.TitleParams(text, anchor="start", fontSize=12)


def _triangle_count_panel(cost: _CostLayers, mesh: pd.DataFrame) -> Any:
    """Cost against the mesh's triangle count (log), the mesh workloads only; it carries the legend."""
    x = alt.X(
        "triangles:Q",
        scale=alt.Scale(type="log"),
        title="triangles in the mesh (log; brute force: every ray tests every triangle)",
    )
    return cost.layer(x, mesh, True).properties(
        width=WIDTH,
        height=240,
        title=_panel_title("cost against triangle count"),
    )


def _cache_marks(caches: dict[str, Any] | None) -> list[alt.Chart]:
    """The data caches as dashed rules named at their sizes (none when no size is known)."""
    from .figures import cache_bytes

    marks = pd.DataFrame(
        [
            {"cache": f"{name} {size}", "bytes": cache_bytes(size)}
            for name, size in (caches or {}).items()
            if not str(name).endswith("i")  # an instruction cache holds no data
        ]
    )
    marks = marks.loc[marks["bytes"].notna()] if len(marks) else marks
    if not len(marks):
        return []
    rule = alt.Chart(marks).mark_rule(color="#888", strokeDash=[4, 3]).encode(x="bytes:Q", tooltip=["cache:N"])
    text = rule.mark_text(angle=270, align="right", baseline="bottom", dy=-2, color="#555", fontSize=10).encode(
        y=alt.value(4), text="cache:N"
    )
    return [rule, text]


def _working_set_panel(cost: _CostLayers, sized: pd.DataFrame, caches: dict[str, Any] | None, with_legend: bool) -> Any:
    """Cost against the working set (log), with the data caches marked."""
    x = alt.X(
        "working_set_bytes:Q",
        scale=alt.Scale(type="log"),
        title="working set: prepared triangles + rays (bytes, log)",
    )
    layers: list[Any] = [cost.layer(x, sized, with_legend), *_cache_marks(caches)]
    return alt.layer(*layers).properties(
        width=WIDTH,
        height=240,
        title=_panel_title("cost against working-set size, data caches marked"),
    )


def scaling_chart(est: pd.DataFrame, caches: dict[str, Any], colours: dict[str, str]) -> alt.VConcatChart | None:
    """ns/test against the mesh's triangle count, and against the working set with the data caches marked.

    ``est``: :func:`.content.estimates_table`'s frame. None without an estimate."""
    if est.empty:
        return None
    frame = est.assign(ns=_intervals(est, "ns_per_test", " ns"))
    columns = ["family", "label", "kernel", "kind", "triangles", "working_set_bytes", "ns_per_test"]
    data = _records(frame, columns + ["ns_per_test_ci_low", "ns_per_test_ci_high", "ns"])
    y_scale, y_log = _axis_scale(est["ns_per_test_ci_low"], est["ns_per_test_ci_high"])
    tooltip = [
        alt.Tooltip("kernel:N"),
        alt.Tooltip("family:N"),
        alt.Tooltip("label:N", title="workload"),
        alt.Tooltip("ns:N", title="ns/test [95% CI]"),
        alt.Tooltip("working_set_bytes:Q", title="working set (bytes)", format=",.0f"),
    ]
    cost = _CostLayers(y_scale, f"ns per ray–triangle test{y_log}", colours, _kernel_legend(), tooltip)
    panels: list[Any] = []
    mesh = data.loc[(data["kind"] == "mesh") & data["triangles"].notna()]
    if len(mesh):
        panels.append(_triangle_count_panel(cost, mesh))
    sized = data.loc[data["working_set_bytes"].notna()]
    if len(sized):
        panels.append(_working_set_panel(cost, sized, caches, with_legend=not panels))
    if not panels:
        return None
    return alt.vconcat(*panels).resolve_scale(color="shared")
