"""The charts of what the kernels' speed is: the answer, speedups, hit rate, size, the BVH, the peers, the seed.

Each takes the frame its section shows and returns an Altair chart (None when there is nothing to draw);
the kit they share is :mod:`.charts`."""

from __future__ import annotations

from typing import Any

import altair as alt
import pandas as pd

from ..harness.machine import size_bytes
from .charts import (
    CLICK,
    VERDICT_COLOURS,
    WIDTH,
    intervals,
    kernel_colour,
    kernel_legend,
    margin_band,
    per_panel,
    rule_at_one,
    shown,
    title,
)

__all__ = [
    "answer_chart",
    "hit_rate_chart",
    "speedup_hit_rate_chart",
    "forest_chart",
    "scaling_chart",
    "bvh_chart",
    "peers_chart",
    "seed_chart",
]

_HIT_RATE = alt.X("test_hit_rate:Q", axis=alt.Axis(format="%"), title="per-test hit rate (achieved)")
_LOG = alt.Scale(type="log", nice=False, padding=14)  # the data's span, not powers of ten around it
_SI = alt.Axis(format="~s")  # 2M, not 2,000,000: a log axis of rates has room for no more


def _answer_data(bands: pd.DataFrame) -> pd.DataFrame:
    """The answer chart's records: ``bands`` with the menu's place of each row and its tooltips as text."""
    frame = bands.assign(
        where=bands["dtype"] + " · " + bands["band"],
        ns=intervals(bands, "ns_per_test", " ns"),
        over_fastest=[
            "(the fastest)" if rank == 1 else text
            for rank, text in zip(bands["rank"], intervals(bands, "vs_fastest", "×"), strict=True)
        ],
        over_baseline=[
            "(the baseline)" if kernel == baseline else text
            for kernel, baseline, text in zip(
                bands["kernel"], bands["baseline"], intervals(bands, "speedup", "×"), strict=True
            )
        ],
        # the robustness axis: what the suite measured, never the promises (kept by design, so 0 for all)
        failures_per_million=bands["cracks_per_million"] + bands["sphere_misses_per_million"],
        watertight_text=bands["watertight"].map({True: "yes", False: "no"}).fillna("unknown"),
    )
    columns = ["where", "rank", "kernel", "ns_per_test", "ns_per_test_ci_low", "ns_per_test_ci_high"]
    columns += ["failures_per_million", "bytes_per_triangle", "watertight_text", "ns", "over_fastest"]
    return frame[columns + ["over_baseline", "cracks_per_million", "sphere_misses_per_million"]]


def _answer_points(base: alt.Chart, x: alt.X, y: alt.Y, opacity: Any, colours: dict[str, str], baseline: str):
    """A point per kernel: sized by its bytes per triangle, shaped by its watertightness, every figure on hover."""
    return base.mark_point(filled=True, stroke="#333", strokeWidth=0.6).encode(
        x=x,
        y=y,
        color=kernel_colour(colours),
        size=alt.Size("bytes_per_triangle:Q", title="bytes per triangle", scale=alt.Scale(range=[40, 400])),
        shape=alt.Shape("watertight_text:N", title="watertight by its paper"),
        opacity=opacity,
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
    kernels = kernel_legend()
    baseline = str(bands["baseline"].iloc[0]) if len(bands) else "the baseline"
    base = alt.Chart(data).transform_filter(alt.datum.where == place)
    # x: ns/test, log when the intervals allow; y: failures per million rays, symlog (0 to tens of thousands)
    x_scale, log = _axis_scale(bands["ns_per_test_ci_low"])
    x = alt.X("ns_per_test:Q", scale=x_scale, title="ns per ray–triangle test" + log)
    y = alt.Y(
        "failures_per_million:Q",
        title="cracks + far-sphere misses per million rays (symlog)",
        scale=alt.Scale(type="symlog", constant=1),
    )
    opacity = shown(kernels, 0.95)
    rules = base.mark_rule(strokeWidth=2).encode(
        x=alt.X("ns_per_test_ci_low:Q", scale=x_scale),
        x2="ns_per_test_ci_high:Q",
        y=y,
        color=kernel_colour(colours),
        opacity=opacity,
    )
    points = _answer_points(base, x, y, opacity, colours, baseline)
    return (
        alt.layer(rules, points.add_params(kernels))
        .add_params(place)
        .properties(width=WIDTH, height=260)
        .configure_axis(grid=True, gridColor="#eee")
    )


def _hit_rate_rows(frame: pd.DataFrame) -> pd.DataFrame:
    pairs = frame.loc[frame["kind"] == "pairs"]
    families = [f for f, g in pairs.groupby("family", sort=False) if g["test_hit_rate"].nunique() >= 2]
    return pairs.loc[pairs["family"].isin(families)]


def _curve(value: str, y: alt.Y, colours: dict[str, str], kernels: alt.Parameter, tooltip: list) -> list[alt.Chart]:
    """A kernel's line of ``value`` (on the axis ``y``) against the per-test hit rate and its interval as a band
    (``<value>_ci_low`` to ``_ci_high``, on the same scale); the panel gives the data."""
    band = (
        alt.Chart()
        .mark_area()
        .encode(
            x=_HIT_RATE,
            y=alt.Y(f"{value}_ci_low:Q", scale=y["scale"]),
            y2=f"{value}_ci_high:Q",
            color=kernel_colour(colours),
            opacity=shown(kernels, 0.18, 0.02),
        )
    )
    line = (
        alt.Chart()
        .mark_line(point=True)
        .encode(x=_HIT_RATE, y=y, color=kernel_colour(colours), opacity=shown(kernels), tooltip=tooltip)
    )
    return [band, line]


def hit_rate_chart(est: pd.DataFrame, cross: pd.DataFrame, colours: dict[str, str]) -> alt.VConcatChart | None:
    """ns/test against the per-test hit rate, a line per kernel with its 95% CI band, a panel per family,
    crossovers (``crossovers.csv``) as dashed rules. None when no pair family has two or more hit rates."""
    rows = _hit_rate_rows(est)
    if rows.empty:
        return None
    columns = ["family", "label", "kernel", "test_hit_rate", "ns_per_test", "ns_per_test_ci_low"]
    data = rows.assign(ns=intervals(rows, "ns_per_test", " ns"))[columns + ["ns_per_test_ci_high", "ns"]]
    kernels = kernel_legend()
    tooltip = [
        alt.Tooltip("kernel:N"),
        alt.Tooltip("label:N", title="workload"),
        alt.Tooltip("test_hit_rate:Q", title="per-test hit rate", format=".1%"),
        alt.Tooltip("ns:N", title="ns/test [95% CI]"),
    ]
    band, line = _curve(
        "ns_per_test", alt.Y("ns_per_test:Q", title="ns per ray–triangle test"), colours, kernels, tooltip
    )
    found = cross.loc[cross["hit_rate"].notna()] if not cross.empty else cross
    crossings = (
        found.assign(
            pair=found["kernel_a"] + " = " + found["kernel_b"],
            at=[
                f"{100 * h:.3g}% [{100 * lo:.3g}%, {100 * hi:.3g}%]"
                for h, lo, hi in found[["hit_rate", "ci_low", "ci_high"]].clip(0, 1).to_numpy()  # rates there are
            ],
        )
    )[["family", "hit_rate", "pair", "at"]]

    def panel(d: pd.DataFrame, marks: alt.Chart) -> Any:
        layers = [band, marks]
        here = crossings.loc[crossings["family"] == d["family"].iloc[0]]
        if len(here):
            tip = [alt.Tooltip("pair:N", title="crossover"), alt.Tooltip("at:N", title="at [95% CI]")]
            layers.append(
                alt.Chart(here).mark_rule(color="#7c3aed", strokeDash=[4, 3]).encode(x="hit_rate:Q", tooltip=tip)
            )
        return alt.layer(*layers, data=d).properties(width=WIDTH, height=220)

    return per_panel(data, "family", panel, line, kernels)


def speedup_hit_rate_chart(
    spd: pd.DataFrame, baseline: str, margin: float, colours: dict[str, str]
) -> alt.VConcatChart | None:
    """Speedup over the baseline against the per-test hit rate, with CI bands and the margin (log axis)."""
    rows = _hit_rate_rows(spd)
    if rows.empty:
        return None
    frame = rows.assign(speedup=intervals(rows, "ratio", "×"))
    columns = ["family", "label", "kernel", "test_hit_rate", "ratio", "ratio_ci_low", "ratio_ci_high", "speedup"]
    data = frame[columns + ["verdict"]]
    kernels = kernel_legend()
    tooltip = [
        alt.Tooltip("kernel:N"),
        alt.Tooltip("label:N", title="workload"),
        alt.Tooltip("speedup:N", title=f"speedup over {baseline} [simultaneous 95% CI]"),
        alt.Tooltip("verdict:N"),
    ]
    y = alt.Y("ratio:Q", scale=_LOG, title=f"speedup over {baseline} (log)")
    band, line = _curve("ratio", y, colours, kernels, tooltip)
    guides = [margin_band(margin, "y"), rule_at_one("y")]
    return per_panel(
        data,
        "family",
        lambda d, marks: alt.layer(*guides, band, marks, data=d).properties(width=WIDTH, height=200),
        line,
        kernels,
    )


def forest_chart(
    spd: pd.DataFrame, margin: float, ratio: str, above_one: str, words: dict[str, str] | None = None
) -> alt.VConcatChart | None:
    """Every ratio with its simultaneous 95% CI, a row per kernel and workload, a panel per family, coloured by
    verdict, the margin a grey band around 1; None without a row. ``ratio`` names the ratio, ``above_one`` says what
    above 1 means, ``words`` how each verdict reads (the compare page's ratio of two runs reads them its own way)."""
    if spd.empty:
        return None
    words = words or {}
    frame = spd.assign(
        row=spd["kernel"] + " · " + spd["label"],
        text=intervals(spd, "ratio", "×"),
        verdict=[words.get(v, v) for v in spd["verdict"]],
    )
    extra = ["p_holm"] if "p_holm" in spd else []  # speedups.csv has it, a comparison of two runs not
    data = frame[
        ["family", "row", "kernel", "label", "ratio", "ratio_ci_low", "ratio_ci_high", "text", "verdict"] + extra
    ]
    names = list(dict.fromkeys(data["kernel"]))
    pick = alt.param(
        name="kernel_shown",
        value="every kernel",
        bind=alt.binding_select(options=["every kernel", *names], name="kernel: "),
    )
    verdicts = alt.selection_point(name="verdicts", fields=["verdict"], bind="legend")
    kept = (pick == "every kernel") | (alt.datum.kernel == pick)
    colour = alt.Color(
        "verdict:N",
        scale=alt.Scale(domain=[words.get(v, v) for v in VERDICT_COLOURS], range=list(VERDICT_COLOURS.values())),
        title="verdict" + CLICK,
    )
    y = alt.Y("row:N", title=None, sort=None)
    x = alt.X("ratio:Q", scale=_LOG, title=f"{ratio} (log; > 1: {above_one})")
    base = alt.Chart().transform_filter(kept).encode(y=y, color=colour, opacity=shown(verdicts, 1.0, 0.1))
    rule = base.mark_rule(strokeWidth=2).encode(x=alt.X("ratio_ci_low:Q", scale=_LOG), x2="ratio_ci_high:Q")
    tooltip = [
        alt.Tooltip("kernel:N"),
        alt.Tooltip("label:N", title="workload"),
        alt.Tooltip("text:N", title=f"{ratio} [simultaneous 95% CI]"),
        alt.Tooltip("verdict:N"),
    ]
    tooltip += [alt.Tooltip("p_holm:Q", title="p (Holm)", format=".2~g")] if extra else []
    dot = base.mark_point(filled=True, size=60).encode(x=x, tooltip=tooltip)
    guides = [margin_band(margin, "x"), rule_at_one("x")]
    chart = per_panel(
        data,
        "family",
        lambda d, marks: alt.layer(*guides, rule, marks, data=d).properties(width=WIDTH - 220, height=alt.Step(16)),
        dot,
        verdicts,
    )
    return chart.add_params(pick)


def _axis_scale(*columns: pd.Series) -> tuple[alt.Scale, str]:
    """A log scale when every value is above 0 (a t interval over few processes may reach below), else linear."""
    values = pd.concat([c.dropna() for c in columns])
    return (alt.Scale(type="log"), " (log)") if bool((values > 0).all()) else (alt.Scale(type="linear"), "")


def _cache_marks(caches: dict[str, Any] | None) -> list[alt.Chart]:
    """The data caches as dashed rules named at their sizes (none when no size is known)."""
    marks = pd.DataFrame(
        [
            {"cache": f"{name} {size}", "bytes": size_bytes(size)}
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


def scaling_chart(est: pd.DataFrame, caches: dict[str, Any], colours: dict[str, str]) -> alt.VConcatChart | None:
    """ns/test against the mesh's triangle count, and against the working set with the data caches marked.

    ``est``: :func:`.rundata.estimates_table`'s frame. None without an estimate."""
    if est.empty:
        return None
    frame = est.assign(ns=intervals(est, "ns_per_test", " ns"))
    columns = ["family", "label", "kernel", "kind", "triangles", "working_set_bytes", "ns_per_test"]
    data = frame[columns + ["ns_per_test_ci_low", "ns_per_test_ci_high", "ns"]]
    y_scale, y_log = _axis_scale(est["ns_per_test_ci_low"], est["ns_per_test_ci_high"])
    tooltip = [
        alt.Tooltip("kernel:N"),
        alt.Tooltip("family:N"),
        alt.Tooltip("label:N", title="workload"),
        alt.Tooltip("ns:N", title="ns/test [95% CI]"),
        alt.Tooltip("working_set_bytes:Q", title="working set (bytes)", format=",.0f"),
    ]
    kernels = kernel_legend()

    def cost(x: alt.X, rows: pd.DataFrame, with_legend: bool) -> Any:
        """Each workload's 95% CI and a line per kernel and family of ``rows`` against ``x``; ``with_legend``: this
        panel carries the legend's selection (one panel only)."""
        base = alt.Chart(rows).encode(x=x, color=kernel_colour(colours), opacity=shown(kernels))
        interval = base.mark_rule().encode(y=alt.Y("ns_per_test_ci_low:Q", scale=y_scale), y2="ns_per_test_ci_high:Q")
        line = base.mark_line(point=True).encode(
            y=alt.Y("ns_per_test:Q", scale=y_scale, title=f"ns per ray–triangle test{y_log}"),
            strokeDash=alt.StrokeDash("family:N", legend=None),
            detail="family:N",
            tooltip=tooltip,
        )
        return alt.layer(interval, line.add_params(kernels) if with_legend else line)

    panels: list[Any] = []
    mesh = data.loc[(data["kind"] == "mesh") & data["triangles"].notna()]
    if len(mesh):
        x = alt.X(
            "triangles:Q",
            scale=_LOG,
            axis=_SI,
            title="triangles in the mesh (log; brute force: every ray tests every triangle)",
        )
        panels.append(
            cost(x, mesh, True).properties(width=WIDTH, height=240, title=title("cost against triangle count"))
        )
    sized = data.loc[data["working_set_bytes"].notna()]
    if len(sized):
        x = alt.X(
            "working_set_bytes:Q", scale=_LOG, axis=_SI, title="working set: prepared triangles + rays (bytes, log)"
        )
        layers = [cost(x, sized, with_legend=not panels), *_cache_marks(caches)]
        panels.append(
            alt.layer(*layers).properties(
                width=WIDTH, height=240, title=title("cost against working-set size, data caches marked")
            )
        )
    return alt.vconcat(*panels).resolve_scale(color="shared") if panels else None


def bvh_chart(bvh: pd.DataFrame, colours: dict[str, str]) -> alt.TopLevelMixin:
    """Rays/s of every kernel in a BVH against the mesh's triangle count (log–log) with 95% CIs (``bvh.csv``);
    dashes tell the kinds of rays apart, shapes the precisions."""
    frame = bvh.assign(
        rate=intervals(bvh, "rays_per_s", " rays/s"),
        workload=bvh["family"] + " · " + bvh["label"],
        line=bvh["kernel"] + " " + bvh["rays_kind"] + " " + bvh["dtype"],
    )
    columns = ["kernel", "workload", "rays_kind", "dtype", "triangles", "rays_per_s", "rays_per_s_ci_low"]
    data = frame[columns + ["rays_per_s_ci_high", "rate", "line"]]
    kernels = kernel_legend()
    x = alt.X("triangles:Q", scale=_LOG, axis=_SI, title="triangles of the mesh (log)")
    base = alt.Chart(data).encode(x=x, color=kernel_colour(colours), opacity=shown(kernels), detail="line:N")
    rule = base.mark_rule().encode(y=alt.Y("rays_per_s_ci_low:Q", scale=_LOG), y2="rays_per_s_ci_high:Q")
    y = alt.Y("rays_per_s:Q", scale=_LOG, axis=_SI, title="rays per second (log)")
    line = base.mark_line().encode(y=y, strokeDash=alt.StrokeDash("rays_kind:N", title="rays"))
    tooltip = ["kernel:N", "workload:N", alt.Tooltip("rays_kind:N", title="rays")]
    tooltip += [alt.Tooltip("dtype:N", title="precision"), alt.Tooltip("rate:N", title="rays/s [95% CI]")]
    points = base.mark_point(filled=True).encode(y=y, shape=alt.Shape("dtype:N", title="precision"), tooltip=tooltip)
    return alt.layer(rule, line, points.add_params(kernels)).properties(width=WIDTH - 160, height=260)


def peers_chart(rates: pd.DataFrame) -> alt.TopLevelMixin:
    """Rays/s of every contender with its 95% CI (``peer_rates.csv``), a row each, on a log axis: dots, as a bar's
    length means nothing there."""
    frame = rates.assign(
        rate=intervals(rates, "rays_per_s", " rays/s", "ci_low", "ci_high"),
        side=["tribench" if c.startswith("tribench") else "peer" for c in rates["contender"]],
    )
    data = frame[["contender", "implementation", "rays_per_s", "ci_low", "ci_high", "rate", "side"]]
    y = alt.Y("contender:N", sort=None, title=None)
    colour = alt.Color("side:N", scale=alt.Scale(domain=["tribench", "peer"], range=["#1f77b4", "#d62728"]), title=None)
    x = alt.X("rays_per_s:Q", scale=_LOG, axis=_SI, title="rays per second on one core (log)")
    base = alt.Chart(data).encode(y=y, color=colour)
    rule = base.mark_rule(strokeWidth=2).encode(x=alt.X("ci_low:Q", scale=_LOG), x2="ci_high:Q")
    tooltip = ["contender:N", "implementation:N", alt.Tooltip("rate:N", title="rays/s [95% CI]")]
    dot = base.mark_point(filled=True, size=60).encode(x=x, tooltip=tooltip)
    return alt.layer(rule, dot).properties(width=WIDTH - 160, height=alt.Step(24))


def seed_chart(seed: pd.DataFrame, colours: dict[str, str]) -> alt.VConcatChart:
    """Each kernel's render time over its baseline's with its 95% CI (``seed.csv``), a panel per scene;
    the paper's ratios (real and user time) as diamonds."""
    value = "ratio_to_moller_seed"
    data = seed.assign(text=intervals(seed, value, "×"))[
        ["scene", "kernel", value, f"{value}_ci_low", f"{value}_ci_high", "text", "ratio_baseline"]
    ]
    compared = seed.loc[seed["kernel"] != seed["ratio_baseline"]]
    paper = compared.melt(["scene", "kernel"], ["paper_ratio_real", "paper_ratio_user"], "paper", "paper_ratio")
    paper = paper.assign(paper=paper["paper"].str.replace("paper_ratio_", "paper, "))
    y = alt.Y("kernel:N", sort=list(colours), title=None)
    colour = alt.Color("kernel:N", scale=alt.Scale(domain=list(colours), range=list(colours.values())), legend=None)
    x = alt.X(f"{value}:Q", scale=_LOG, title="time / its baseline's: moller_seed, or moller_seed_object (log)")
    base = alt.Chart().encode(y=y, color=colour)
    rule = base.mark_rule(strokeWidth=2).encode(x=alt.X(f"{value}_ci_low:Q", scale=_LOG), x2=f"{value}_ci_high:Q")
    tooltip = [
        "kernel:N",
        alt.Tooltip("text:N", title="time / baseline's [95% CI]"),
        alt.Tooltip("ratio_baseline:N", title="baseline"),
    ]
    dot = base.mark_point(filled=True, size=60).encode(x=x, tooltip=tooltip)
    fill = alt.Fill(
        "paper:N",
        scale=alt.Scale(domain=["paper, real", "paper, user"], range=["white", "#333"]),
        title="the paper's ratio",
    )
    tip = ["kernel:N", "paper:N", alt.Tooltip("paper_ratio:Q", format=".3g", title="ratio")]

    def panel(d: pd.DataFrame, marks: alt.Chart) -> Any:
        theirs = paper.loc[(paper["scene"] == d["scene"].iloc[0]) & paper["paper_ratio"].notna()]
        diamonds = alt.Chart(theirs).mark_point(shape="diamond", filled=True, stroke="#333", size=50)
        layers = [rule_at_one("x"), rule, marks]
        if len(theirs):  # a scene not in the paper has none, and a layer of no value leaves its scale no extent
            layers.append(diamonds.encode(x="paper_ratio:Q", y=y, fill=fill, tooltip=tip))
        return alt.layer(*layers, data=d).properties(width=WIDTH - 200, height=alt.Step(18))

    return per_panel(data, "scene", panel, dot, None)
