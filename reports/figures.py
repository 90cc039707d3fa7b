"""The report's static figures (the dense diagnostics and the compare page's forest plot): tidy DataFrames in,
a matplotlib Figure out, embedded as a ``data:`` URI. matplotlib (Agg) is imported here only; dense scatters
are rasterised inside the SVG to keep the file small. No figure computes a statistic."""

from __future__ import annotations

import base64
import io
import math
import re
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg", force=False)
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.artist import Artist  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import FuncFormatter, MaxNLocator, NullFormatter  # noqa: E402

if TYPE_CHECKING:  # matplotlib.typing is new in 3.8
    from matplotlib.typing import RcKeyType

from ..harness.stats import format_interval  # noqa: E402

__all__ = [
    "VERDICT_COLOURS",
    "kernel_colours",
    "forest",
    "NO_HIT_RATE_CURVE",
    "process_dots",
    "drift_panel",
    "rounds_panel",
    "peers_rates",
    "svg_data_uri",
    "png_data_uri",
    "palette_png",
    "cache_bytes",
]

VERDICT_COLOURS = {"faster": "#1a7f37", "slower": "#c62828", "equivalent": "#5f6b7a", "inconclusive": "#d97706"}
_PALETTE = [
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
    # then the light shades of the same ten (matplotlib's tab20): the main job ranks about twenty kernels
    "#aec7e8",
    "#ffbb78",
    "#98df8a",
    "#ff9896",
    "#c5b0d5",
    "#c49c94",
    "#f7b6d2",
    "#c7c7c7",
    "#dbdb8d",
    "#9edae5",
]
_STYLE: dict[RcKeyType, Any] = {
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "svg.fonttype": "path",  # glyphs as paths: no font files, nothing external
    "svg.hashsalt": "tribench",  # stable ids: the same run gives the same bytes
}


def kernel_colours(kernels: Sequence[str]) -> dict[str, str]:
    """One colour per kernel, stable in the sweep's kernel order."""
    return {k: _PALETTE[i % len(_PALETTE)] for i, k in enumerate(kernels)}


def _figure(width: float, height: float) -> Figure:
    with plt.rc_context(_STYLE):
        return plt.figure(figsize=(width, height))


def svg_data_uri(fig: Figure) -> str:
    """The figure as a ``data:image/svg+xml;base64,...`` URI (and closes it)."""
    buf = io.StringIO()
    with plt.rc_context(_STYLE):
        fig.savefig(buf, format="svg", metadata={"Date": None, "Creator": None}, bbox_inches="tight", dpi=110)
    plt.close(fig)
    text = buf.getvalue()
    # The RDF metadata block and the DOCTYPE name schema URLs; nothing needs them.
    text = re.sub(r"<metadata>.*?</metadata>", "", text, flags=re.S)
    text = re.sub(r"<!DOCTYPE[^>]*>", "", text)
    # Indentation and line breaks are a tenth of the bytes; with text as paths no element holds text.
    text = re.sub(r"\s+", " ", re.sub(r">\s+<", "><", text))
    return "data:image/svg+xml;base64," + base64.b64encode(text.encode()).decode()


def png_data_uri(data: bytes) -> str:
    """PNG bytes as a ``data:image/png;base64,...`` URI."""
    return "data:image/png;base64," + base64.b64encode(data).decode()


def palette_png(data: bytes) -> bytes:
    """PNG bytes re-encoded with a 256-colour palette: a plot's flat colours look the same at a third of the bytes."""
    from PIL import Image  # a dependency of matplotlib

    out = io.BytesIO()
    with Image.open(io.BytesIO(data)) as im:
        im.convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE).save(out, format="PNG", optimize=True)
    return out.getvalue()


def cache_bytes(size: str) -> float:
    """A cache size as Linux prints it ('32K', '1M', '512') in bytes.

    >>> cache_bytes("32K"), cache_bytes("2M"), cache_bytes("512")
    (32768.0, 2097152.0, 512.0)
    """
    m = re.fullmatch(r"\s*([0-9.]+)\s*([KMG]?)i?B?\s*", str(size), flags=re.I)
    if not m:
        return math.nan
    return float(m.group(1)) * {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3}[m.group(2).upper()]


def _empty(message: str, width: float = 7.0, height: float = 1.2) -> Figure:
    fig = _figure(width, height)
    fig.text(0.5, 0.5, message, ha="center", va="center", color="#555")
    return fig


def _log_ratio_axis(ax, low: float, high: float) -> None:
    """A log x axis for ratios with plain-number ticks (0.8, 1, 1.25...)."""
    ax.set_xscale("log")
    lo, hi = min(low, 1 / 1.02), max(high, 1.02)
    pad = (hi / lo) ** 0.06
    ax.set_xlim(lo / pad, hi * pad)
    if hi / lo > 2.5:
        candidates = [0.1, 0.2, 0.25, 0.33, 0.5, 0.67, 1.0, 1.5, 2, 3, 4, 5, 10]
    else:
        candidates = [0.5, 0.67, 0.8, 0.9, 1.0, 1.1, 1.25, 1.5, 2]
    ticks = [t for t in candidates if lo / pad <= t <= hi * pad]
    if len(ticks) < 3:
        ticks = sorted(set(ticks) | {round(lo, 2), round(hi, 2)})
    ax.set_xticks(ticks)
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}×"))
    ax.xaxis.set_minor_formatter(NullFormatter())


# ------------------------------------------------------------------- forest


def _forest_family(ax, family: str, rows: pd.DataFrame, margin: float, words: dict[str, str]) -> None:
    """One family's panel: the equivalence band, 1, and a row per kernel and workload with its interval."""
    y = np.arange(len(rows))[::-1]
    ax.axvspan(
        1 / (1 + margin),
        1 + margin,
        color="#d0d7de",
        alpha=0.6,
        lw=0,
        label=f"equivalence margin ±{100 * margin:.2g}%",
    )
    ax.axvline(1.0, color="#333", lw=0.8)
    for yi, r in zip(y, rows.itertuples(index=False), strict=True):
        colour = VERDICT_COLOURS.get(r.verdict, "#333")
        if np.isfinite(r.ratio_ci_low) and np.isfinite(r.ratio_ci_high):
            ax.plot([r.ratio_ci_low, r.ratio_ci_high], [yi, yi], color=colour, lw=2.2, solid_capstyle="butt")
        ax.plot([r.ratio], [yi], "o", color=colour, ms=6, mec="white", mew=0.8)
        label = format_interval(r.ratio, r.ratio_ci_low, r.ratio_ci_high, unit="×")
        ax.text(
            1.01,
            yi,
            f"{label}  {words.get(r.verdict, r.verdict)}",
            transform=ax.get_yaxis_transform(),
            va="center",
            ha="left",
            color=colour,
            fontsize=8.5,
            clip_on=False,
        )
    ax.set_yticks(y)
    ax.set_yticklabels([f"{r.kernel}  ·  {r.label}" for r in rows.itertuples(index=False)])
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_title(family, loc="left", fontsize=9.5, color="#333")
    ax.grid(axis="x", color="#eee", lw=0.6)
    ax.tick_params(axis="y", length=0)


def _forest_xlabel(speedups: pd.DataFrame, baseline: str) -> str:
    """What the ratio is, and the level of each simultaneous interval when the table says."""
    level = speedups["confidence"].iloc[0] if "confidence" in speedups else math.nan
    return (
        f"speedup over {baseline} = time_{baseline} / time_kernel   "
        f"(log axis; > 1: faster; bars: simultaneous 95% CIs"
        + (f", {100 * level:.3g}% each)" if np.isfinite(level) else ")")
    )


def _forest_legend(ax, margin: float, words: dict[str, str]) -> None:
    """Every verdict's colour and the equivalence band, in a row above the first panel."""
    handles: list[Artist] = [
        plt.Line2D([], [], color=c, marker="o", lw=2, label=words.get(v, v)) for v, c in VERDICT_COLOURS.items()
    ]
    handles.append(plt.Rectangle((0, 0), 1, 1, color="#d0d7de", label=f"equivalence margin ±{100 * margin:.2g}%"))
    ax.legend(handles=handles, loc="lower left", bbox_to_anchor=(0, 1.12), ncol=5, frameon=False)


def forest(
    speedups: pd.DataFrame,
    baseline: str,
    margin: float,
    xlabel: str | None = None,
    verdict_words: dict[str, str] | None = None,
) -> Figure:
    """Forest plot: every kernel's speedup over the baseline, per workload family.

    ``speedups``: ``speedups.csv`` rows with ``family`` and ``label`` added; ``margin`` (relative) is drawn
    as a band around 1; ``verdict_words``: how to print each verdict (e.g. for a ratio of ratios)."""
    words = verdict_words or {}
    if speedups.empty:
        return _empty(f"no speedups: the run has no kernel other than the baseline {baseline}")
    families = list(dict.fromkeys(speedups["family"]))
    sizes = [int((speedups["family"] == f).sum()) for f in families]
    height = 0.9 + sum(0.27 * s + 0.55 for s in sizes)
    fig = _figure(9.5, height)
    axes = fig.subplots(
        len(families), 1, sharex=True, squeeze=False, gridspec_kw={"height_ratios": [s + 1.2 for s in sizes]}
    )[:, 0]
    low = float(np.nanmin(speedups[["ratio_ci_low", "ratio"]].to_numpy()))
    high = float(np.nanmax(speedups[["ratio_ci_high", "ratio"]].to_numpy()))
    korder = {k: i for i, k in enumerate(dict.fromkeys(speedups["kernel"]))}  # kernels in the table's order
    for ax, family in zip(axes, families, strict=True):
        rows = speedups.loc[speedups["family"] == family]
        rows = rows.sort_values("kernel", key=lambda s: s.map(korder), kind="stable").reset_index(drop=True)
        _forest_family(ax, family, rows, margin, words)
    _log_ratio_axis(axes[-1], low, high)
    axes[-1].set_xlabel(xlabel or _forest_xlabel(speedups, baseline))
    _forest_legend(axes[0], margin, words)
    fig.subplots_adjust(right=0.72, hspace=0.55)
    return fig


# ---------------------------------------------------------------- hit rate

#: Why a run has no hit-rate curve (the charts module draws them: :func:`tribench.reports.charts.hit_rate_chart`).
NO_HIT_RATE_CURVE = "no pair workload family with two or more per-test hit rates in this run"


# --------------------------------------------------------------- processes


def process_dots(
    pp: pd.DataFrame,
    est: pd.DataFrame,
    labels: dict[str, str],
    kernels: Sequence[str],
    colours: dict[str, str],
    ncols: int = 3,
) -> Figure:
    """Per-process medians (dots) under each kernel's estimate (mean and CI), per workload."""
    wids = list(dict.fromkeys(est["workload_id"]))
    if not wids:
        return _empty("no estimates")
    nrows = math.ceil(len(wids) / ncols)
    fig = _figure(3.4 * ncols, 0.5 + nrows * (0.45 * len(kernels) + 1.0))
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    order = [k for k in kernels if k in set(est["kernel"])]
    for ax, wid in zip(axes, wids, strict=False):  # the grid's last row may have spare panels, blanked below
        for i, kernel in enumerate(order[::-1]):
            dots = pp.loc[(pp["kernel"] == kernel) & (pp["workload_id"] == wid), "ns_per_test"].to_numpy()
            e = est.loc[(est["kernel"] == kernel) & (est["workload_id"] == wid)]
            c = colours.get(kernel, "#333")
            jitter = (np.arange(dots.size) % 5 - 2) * 0.05
            ax.plot(dots, i + 0.22 + jitter, "o", color=c, ms=3, alpha=0.75, mew=0)
            if not e.empty:
                r = e.iloc[0]
                if np.isfinite(r["ns_per_test_ci_low"]):
                    ax.plot([r["ns_per_test_ci_low"], r["ns_per_test_ci_high"]], [i - 0.1, i - 0.1], color=c, lw=2.2)
                ax.plot([r["ns_per_test"]], [i - 0.1], "D", color=c, ms=4.5, mec="white", mew=0.6)
        ax.set_yticks(range(len(order)))
        ax.set_yticklabels(order[::-1], fontsize=8)
        ax.set_ylim(-0.6, len(order) - 0.4)
        ax.set_title(labels.get(wid, wid), fontsize=8, loc="left")
        ax.set_xlabel("ns per test", fontsize=8)
        ax.grid(axis="x", color="#eee", lw=0.6)
        ax.tick_params(axis="y", length=0)
    for ax in axes[len(wids) :]:
        ax.axis("off")
    fig.tight_layout()
    return fig


# ------------------------------------------------------------- drift, rounds


def _robust_ylim(ax, values: np.ndarray) -> None:
    v = values[np.isfinite(values)]
    if v.size:
        lo, hi = np.quantile(v, [0.005, 0.995])
        pad = 0.15 * (hi - lo) + 1e-3
        ax.set_ylim(lo - pad, hi + pad)


def drift_panel(batches: pd.DataFrame, colours: dict[str, str]) -> Figure:
    """Each timed batch's ns/test over its process median, against time in the process; lines: binned medians."""
    timed = batches.loc[~batches["warmup"]]
    if timed.empty:
        return _empty("no timed batches")
    fig = _figure(9.5, 3.4)
    ax = fig.subplots()
    edges = np.linspace(timed["t_in_process_s"].min(), timed["t_in_process_s"].max() + 1e-9, 13)
    for kernel, g in timed.groupby("kernel", sort=False):
        c = colours.get(kernel, "#333")
        ax.scatter(g["t_in_process_s"], g["rel_to_median"], s=6, color=c, alpha=0.45, lw=0, rasterized=True)
        bins = pd.cut(g["t_in_process_s"], edges, include_lowest=True)
        med = g.groupby(bins, observed=True).agg(t=("t_in_process_s", "median"), y=("rel_to_median", "median"))
        ax.plot(med["t"], med["y"], "-", color=c, lw=1.6, label=kernel)
    ax.axhline(1.0, color="#333", lw=0.8)
    _robust_ylim(ax, timed["rel_to_median"].to_numpy())
    ax.set_xlabel("seconds since the worker process started")
    ax.set_ylabel("ns/test ÷ process median")
    ax.grid(color="#eee", lw=0.6)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), frameon=False)
    fig.subplots_adjust(right=0.8)
    return fig


def rounds_panel(batches: pd.DataFrame, colours: dict[str, str]) -> Figure:
    """Every batch (warm-ups shaded) against its round, over its process's timed median, Tukey outliers circled."""
    if batches.empty:
        return _empty("no batches")
    fig = _figure(9.5, 3.2)
    ax = fig.subplots()
    kernels = list(dict.fromkeys(batches["kernel"]))
    width = 0.7 / max(len(kernels), 1)
    for i, kernel in enumerate(kernels):
        g = batches.loc[batches["kernel"] == kernel]
        x = g["round"] + (i - (len(kernels) - 1) / 2) * width
        ax.scatter(
            x,
            g["rel_to_median"],
            s=7,
            color=colours.get(kernel, "#333"),
            alpha=0.55,
            lw=0,
            label=kernel,
            rasterized=True,
        )
    out = batches.loc[batches["outlier"] & ~batches["far_out"]]
    far = batches.loc[batches["far_out"]]
    ax.scatter(
        out["round"],
        out["rel_to_median"],
        s=40,
        facecolors="none",
        edgecolors="#c62828",
        lw=0.9,
        label="outlier (Tukey 1.5 IQR)",
    )
    ax.scatter(far["round"], far["rel_to_median"], s=40, marker="x", color="#c62828", lw=1.1, label="far out (3 IQR)")
    if (batches["round"] < 0).any():
        ax.axvspan(batches["round"].min() - 0.5, -0.5, color="#fde68a", alpha=0.35, lw=0, label="warm-up")
    ax.axhline(1.0, color="#333", lw=0.8)
    _robust_ylim(ax, batches["rel_to_median"].to_numpy())
    ax.set_xlabel("round inside the process (negative: warm-up)")
    ax.set_ylabel("ns/test ÷ process median")
    locator = ax.xaxis.get_major_locator()
    assert isinstance(locator, MaxNLocator)  # the default AutoLocator is one
    locator.set_params(integer=True)
    ax.grid(color="#eee", lw=0.6)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), frameon=False)
    fig.subplots_adjust(right=0.78)
    return fig


def peers_rates(rates: pd.DataFrame) -> Figure:
    """Rays/s of every contender on a log axis with 95% intervals: dots, as a bar's length means nothing there."""
    if rates.empty:
        return _empty("no peers measured")
    fig = _figure(7.0, 0.42 * len(rates) + 0.9)
    ax = fig.add_subplot(1, 1, 1)
    y = np.arange(len(rates))[::-1]
    for yi, r in zip(y, rates.itertuples(index=False), strict=True):
        colour = "#1f77b4" if r.contender.startswith("tribench") else "#d62728"
        if math.isfinite(r.ci_low) and math.isfinite(r.ci_high):
            ax.plot([r.ci_low, r.ci_high], [yi, yi], color=colour, lw=2, solid_capstyle="butt")
        ax.plot([r.rays_per_s], [yi], "o", color=colour, ms=6)
        ax.annotate(
            f"{r.rays_per_s:.3g}",
            (r.rays_per_s, yi),
            xytext=(0, 7),
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize=8,
        )
    ax.set_xscale("log")
    values = pd.concat([rates["rays_per_s"], rates["ci_low"], rates["ci_high"]]).dropna()
    ax.set_xlim(values.min() / 2, values.max() * 2)
    ax.set_ylim(-0.6, len(rates) - 0.2)
    ax.set_yticks(y, rates["contender"])
    ax.grid(axis="x", which="major", color="#e5e7eb", lw=0.8)
    ax.set_xlabel("rays per second on one core (log scale); dot: geometric mean over processes, line: 95% CI")
    return fig
