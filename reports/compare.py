"""``tribench compare RUN...``: the comparison of N runs as text and as an HTML page, and the report's section on a
run of several builds (``--builds``), whose builds are compared as runs.

:mod:`tribench.reports.tables.compare` computes the tables; this module only words and renders them."""

from __future__ import annotations

from html import escape

import pandas as pd

from ..harness import stats
from . import page
from .charts import embed
from .rundata import RunData, load_run
from .speed_charts import forest_chart
from .tables.compare import (
    Comparison,
    MultiComparison,
    compare,
    compare_many,
    compare_runs,
    order_summary,
)

__all__ = [
    "build_views",
    "builds_section",
    "Comparison",
    "MultiComparison",
    "compare",
    "compare_many",
    "compare_runs",
    "format_compare_text",
    "format_comparison",
    "format_many",
    "order_summary",
    "render_compare",
    "RATIO_WORDS",
]

#: The page's sections, by id, in page order.
SECTIONS = {
    "speedup-ratios": "Ratio of speedups (B / A)",
    "time-ratios": "Time ratio (B / A)",
    "machines": "Machines and builds",
}

#: How verdicts read for a ratio of run B to run A.
RATIO_WORDS = {
    "faster": "larger on B",
    "slower": "smaller on B",
    "equivalent": "same on both",
    "inconclusive": "inconclusive",
}
TIME_WORDS = {"faster": "B slower", "slower": "B faster", "equivalent": "same on both", "inconclusive": "inconclusive"}


def _run_line(tag: str, d: RunData) -> str:
    m = d.machine
    rev = (m.get("git_revision") or "?")[:12]
    return (
        f"{tag}: {d.run_dir}  run {d.run.run_id}, {m.get('cpu_model', '?')}, "
        f"{m.get('build', {}).get('compiler', '?')}, git {rev}, {d.n_processes} processes"
    )


def format_comparison(a: RunData, b: RunData, c: Comparison) -> str:
    """Terminal table: per workload, each kernel's speedup on A and B and their ratio."""
    lines = [
        _run_line("A", a),
        _run_line("B", b),
        f"ratio of speedups = speedup_B / speedup_A (speedup = time_{c.baseline} / time_kernel); "
        f"Welch 95% CIs, simultaneous per workload; margin ±{100 * c.margin:.2g}%",
    ]
    for wid, g in c.speedups.groupby("workload_id", sort=False):
        lines += [
            "",
            f"{g['label'].iloc[0]}  ({g['family'].iloc[0]})  [{wid}]",
            f"  {'kernel':<22}{'on A':>8}{'on B':>8}{'B/A':>8}  {'CI':<18}verdict",
        ]
        for r in g.itertuples(index=False):
            ci = stats.format_interval(None, r.ratio_ci_low, r.ratio_ci_high, ".3f")
            lines.append(
                f"  {r.kernel:<22}{r.speedup_a:8.3f}{r.speedup_b:8.3f}{r.ratio:8.3f}  "
                f"{ci:<18}{RATIO_WORDS.get(r.verdict, r.verdict)}"
            )
    if c.speedups.empty:
        lines += ["", "no kernel besides the baseline in both runs: time ratios only"]
    lines += ["", "time ratio time_B / time_A (above 1: B is slower):"]
    for r in c.times.itertuples(index=False):
        ci = stats.format_interval(None, r.ratio_ci_low, r.ratio_ci_high, ".3f")
        lines.append(f"  {r.kernel:<22}{r.label:<30}{r.ratio:8.3f}  {ci:<18}{TIME_WORDS.get(r.verdict, r.verdict)}")
    if c.only_a or c.only_b:
        lines.append(f"\nnot compared: {len(c.only_a)} workloads only in A, {len(c.only_b)} only in B")
    return "\n".join(lines)


def _pair_parts(c: Comparison) -> list[str]:
    """The two-run sections: the ratio of speedups (B / A) and the time ratios, with the forest plot."""
    spd = c.speedups
    parts = []
    chart = forest_chart(spd, c.margin, "speedup_B / speedup_A", "the kernel's advantage is larger on B", RATIO_WORDS)
    if chart is not None:
        parts.append(
            embed(
                chart,
                "chart-forest",
                "ratio of speedups",
                f"Ratio of speedups (speedup = time_{c.baseline} / time_kernel) per workload family, with Welch 95% "
                f"CIs simultaneous per workload; grey: the equivalence margin ±{100 * c.margin:.2g}% (the larger of "
                "the two runs'). Log axis. Hover for the figures; the menu picks a kernel, the legend a verdict.",
            )
        )
    parts.append(
        page.section(
            "speedup-ratios",
            SECTIONS["speedup-ratios"],
            page.table(
                _named(spd.assign(verdict=spd["verdict"].map(RATIO_WORDS))),
                [
                    ("kernel", "kernel"),
                    ("label", "workload"),
                    ("speedup_a", "speedup on A (×)"),
                    ("speedup_b", "speedup on B (×)"),
                    ("ratio", "B / A"),
                    ("ratio_ci_low", "CI low"),
                    ("ratio_ci_high", "CI high"),
                    ("df", "Welch df"),
                    ("n_a", "processes A"),
                    ("n_b", "processes B"),
                    ("verdict", "verdict"),
                ],
            ),
        )
    )
    parts.append(
        page.section(
            "time-ratios",
            SECTIONS["time-ratios"],
            page.p(
                "Absolute ns/test across machines moves with clock speed and load; the ratio of speedups above "
                "is the steadier figure."
            )
            + page.table(
                _named(c.times.assign(verdict=c.times["verdict"].map(TIME_WORDS))),
                [
                    ("kernel", "kernel"),
                    ("label", "workload"),
                    ("ns_per_test_a", "ns/test on A (geo. mean)"),
                    ("ns_per_test_b", "ns/test on B (geo. mean)"),
                    ("ratio", "B / A"),
                    ("ratio_ci_low", "CI low"),
                    ("ratio_ci_high", "CI high"),
                    ("verdict", "verdict"),
                ],
            ),
        )
    )
    if c.only_a or c.only_b:
        parts.append(
            page.p(
                f"Not compared: {', '.join(c.only_a) or 'none'} only in A; {', '.join(c.only_b) or 'none'} only in B."
            )
        )
    return parts


def _machines_part(runs: list[RunData], tags: list[str]) -> str:
    machines = []
    for tag, d in zip(tags, runs, strict=True):
        m = d.machine
        machines += [
            f"<h3>{tag}: {escape(str(d.run_dir))}</h3>",
            page.kv_table(
                [
                    ("CPU", m.get("cpu_model")),
                    ("caches", m.get("caches")),
                    ("compiler", m.get("build", {}).get("compiler")),
                    ("flags", m.get("build", {}).get("flags")),
                    ("git", m.get("git_revision")),
                    ("margin", f"{100 * d.margin:.3g}% ({d.margin_source})"),
                ]
            ),
        ]
    return page.section("machines", SECTIONS["machines"], "".join(machines))


def render_compare(runs: list[RunData], m: MultiComparison, pair: Comparison | None = None) -> str:
    """The comparison as one self-contained HTML page; ``pair`` (:func:`compare_runs`) adds the two-run sections."""
    ids = [escape(d.run.run_id) for d in runs]
    parts = [f"<h1>{' vs '.join(ids)}</h1>", f"<p>{'<br>'.join(escape(x) for x in _run_lines(runs, m.tags))}</p>"]
    parts += _many_parts(m)
    nav = dict(MANY_SECTIONS)
    if pair is not None:
        parts += _pair_parts(pair)
        nav |= SECTIONS
    else:
        nav["machines"] = SECTIONS["machines"]
    parts.append(_machines_part(runs, m.tags))
    return page.document("tribench compare", "".join(parts), nav, f"tribench compare at {page.now()}")


def format_compare_text(runs: list[RunData], m: MultiComparison, pair: Comparison | None = None) -> str:
    """The terminal form of :func:`render_compare`."""
    text = format_many(runs, m)
    return text if pair is None else format_comparison(runs[0], runs[1], pair) + "\n\n" + text


# ------------------------------------------------------------------ N runs

#: The N-run page's sections, by id, in page order (the two-run sections follow them for two runs).
MANY_SECTIONS = {
    "speedups": "Speedups on every machine",
    "orders": "Rankings that hold on every machine",
}


#: The verdict colours the page gives an order of two kernels.
ORDER_CLASSES = {"holds": "faster", "differs": "slower"}


def _run_lines(runs: list[RunData], tags: list[str]) -> list[str]:
    return [_run_line(t, d) for t, d in zip(tags, runs, strict=True)]


def _speedup_grid(m: MultiComparison, wid: str) -> pd.DataFrame:
    """One workload's speedups as kernel rows and one column of text per run."""
    g = m.speedups.loc[m.speedups["workload_id"] == wid]
    if g.empty:  # the baseline ran on no run's copy of this workload (a BVH workload, say)
        return pd.DataFrame(columns=["kernel", *m.tags])
    cells = g.assign(
        text=[
            stats.format_interval(r.ratio, r.ratio_ci_low, r.ratio_ci_high, ".3g", "×")
            if r.kernel != m.baseline
            else "1 (baseline)"
            for r in g.itertuples(index=False)
        ]
    )
    grid = cells.pivot(index="kernel", columns="run", values="text").reindex(columns=m.tags).fillna("–")
    return grid.reindex([k for k in m.kernels if k in grid.index]).reset_index()


def _order_text(r: pd.Series, tags: list[str]) -> str:
    ratios = ", ".join(f"{t} {r[f'ratio_{t}']:.3g}×" for t in tags)
    return f"{r['kernel']} faster than {r['other_kernel']} ({ratios})"


def format_many(runs: list[RunData], m: MultiComparison) -> str:
    """Terminal tables: per workload, each kernel's speedup on every run, then the orders that hold."""
    lines = [
        *_run_lines(runs, m.tags),
        f"speedup = time_{m.baseline} / time_kernel, 95% CIs simultaneous per workload (each run's speedups.csv)",
    ]
    for wid in m.workload_ids:
        grid = _speedup_grid(m, wid)
        label, family = m.labels[wid]
        lines += ["", f"{label}  ({family})  [{wid}]"]
        if grid.empty:
            lines.append(f"  no speedups: {m.baseline} did not run on this workload in every run")
        else:
            width = max(24, *(len(str(v)) + 2 for v in grid[m.tags].to_numpy().ravel()))
            lines.append((f"  {'kernel':<26}" + "".join(f"{t:<{width}}" for t in m.tags)).rstrip())
            lines += [
                (f"  {r['kernel']:<26}" + "".join(f"{r[t]:<{width}}" for t in m.tags)).rstrip()
                for _, r in grid.iterrows()
            ]
        o = m.orders.loc[m.orders["workload_id"] == wid]
        held = [_order_text(r, m.tags) for _, r in o.loc[o["order"] == "holds"].iterrows()]
        differ = [_order_text(r, m.tags) for _, r in o.loc[o["order"] == "differs"].iterrows()]
        lines.append(f"  holds on every machine: {'; '.join(held) if held else 'no order of two kernels'}")
        if differ:
            lines.append(f"  differs between machines: {'; '.join(differ)}")
    lines += ["", f"per pair of kernels, over the {len(m.workload_ids)} workloads:"]
    for r in order_summary(m).itertuples(index=False):
        lines.append(
            f"  {r.kernel} vs {r.other_kernel}: {r.kernel} faster on every machine on {r.kernel_faster}, "
            f"{r.other_kernel} on {r.other_faster}; machines differ on {r.differs}, undecided on {r.undecided}"
        )
    counts = m.orders["order"].value_counts()
    lines += [
        "",
        f"orders of two kernels on one workload: {int(counts.get('holds', 0))} hold on every machine, "
        f"{int(counts.get('differs', 0))} differ between machines, {int(counts.get('undecided', 0))} undecided "
        f"on some machine (of {len(m.orders)}; each run's intervals simultaneous over the workload's pairs)",
    ]
    if m.not_shared:
        lines.append(f"not compared: {len(m.not_shared)} workloads not in every run")
    return "\n".join(lines)


def _named(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with its ``label`` the workload in words, family and label: a label alone ("per-test hit rate
    50%") is two workloads' when the runs have a hit rate at both precisions."""
    return frame.assign(label=frame["family"] + " · " + frame["label"])


def _many_parts(m: MultiComparison, unit: str = "machine", ids: tuple[str, str] = ("speedups", "orders")) -> list[str]:
    """The N-run sections: machine x kernel speedup tables per workload, and the orders that hold.
    ``unit`` names what the runs are (``build`` for :func:`builds_section`); ``ids`` the sections'."""
    speed = []
    for wid in m.workload_ids:
        label, family = m.labels[wid]
        speed += [
            f"<h3>{escape(label)} <small>({escape(family)}, {escape(wid)})</small></h3>",
            page.table(_speedup_grid(m, wid), [("kernel", "kernel"), *((t, f"speedup on {t} (×)") for t in m.tags)]),
        ]
    o = m.orders
    order_cols = [
        ("label", "workload"),
        ("kernel", f"kernel (the faster on {m.tags[0]})"),
        ("other_kernel", "other kernel"),
        *((f"ratio_{t}", f"{t}: time other / kernel (×)") for t in m.tags),
        ("order", "order"),
    ]
    shown = o.loc[o["order"] != "undecided"]
    summary = order_summary(m)
    orders = [
        page.p(f"Per pair of kernels, over the {len(m.workload_ids)} workloads in every run:"),
        page.table(
            summary,
            [
                ("kernel", "kernel"),
                ("other_kernel", "other kernel"),
                ("kernel_faster", f"workloads: kernel faster on every {unit}"),
                ("other_faster", f"workloads: other faster on every {unit}"),
                ("differs", f"workloads: {unit}s differ"),
                ("undecided", f"workloads: undecided on some {unit}"),
            ],
        ),
        page.p(
            "A pair of kernels on one workload: its time ratio (the other kernel's time over the kernel's, paired "
            "by process) in each run, with intervals simultaneous over the workload's pairs. It holds when every "
            "run finds the same kernel faster beyond its equivalence margin; it differs when one run finds "
            "each faster. Pairs undecided on some run are left out of this table "
            f"({int((o['order'] == 'undecided').sum())} of {len(o)})."
        ),
        page.table(_named(shown), order_cols, classes={"order": lambda v: ORDER_CLASSES.get(v, "")}),
    ]
    return [
        page.section(
            ids[0],
            MANY_SECTIONS["speedups"].replace("machine", unit),
            page.p(
                f"Speedup = time_{m.baseline} / time_kernel, with each run's 95% interval (simultaneous over "
                "the workload's kernels), as in its speedups.csv."
            )
            + "".join(speed),
        ),
        page.section(ids[1], MANY_SECTIONS["orders"].replace("machine", unit), "".join(orders)),
    ]


# ------------------------------------------------------------------ the builds of one run


def build_views(data: RunData) -> list[RunData]:
    """The run as each of its builds measured it, the build ``data`` shows first."""
    return [data] + [load_run(data.run_dir, build=b) for b in data.builds if b != data.build]


def builds_section(data: RunData) -> str:
    """The section, or "" for a run of one build."""
    if len(data.builds) < 2:
        return ""
    views = build_views(data)
    many = compare_many(views, same_run=True)
    records = {b.get("spec"): b for b in data.run.builds}
    rows = []
    for tag, view in zip(many.tags, views, strict=True):
        b = records.get(view.build, {})
        rows.append(
            {
                "tag": tag,
                "build": view.build,
                "compiler": b.get("compiler", "?"),
                "flags": b.get("flags", "?"),
                "processes": view.n_processes,
                "check": _check_text(b.get("check")),
            }
        )
    cols = [
        ("tag", ""),
        ("build", "build"),
        ("compiler", "compiler"),
        ("flags", "exact flags"),
        ("processes", "processes"),
        ("check", "checked against the reference again, before timing"),
    ]
    intro = page.p(
        f"The processes took the {len(views)} builds in turn, so each build's figures come from its own "
        f"processes; the rest of this page shows build {data.build}. Each build below is a run of its own: its "
        "speedups, and every order of two kernels tested under each build (builds.csv). A build that breaks "
        "a promise of a kernel (a flag such as -ffast-math or -ffp-contract=fast changes results) still ran: "
        "the last column says what its kernels got wrong."
    )
    broken = [r for r in rows if r["check"] not in ("every kernel right", "not checked (pip's build)")]
    warnings = "".join(page.warn(f"build {r['build']}: {r['check']}") for r in broken)
    return (
        intro
        + warnings
        + page.table(pd.DataFrame(rows), cols)
        + "".join(_many_parts(many, unit="build", ids=("build-speedups", "build-orders")))
    )


def _check_text(check: dict | None) -> str:
    if check is None:
        return "not checked (pip's build)"
    wrong = {k: v for k, v in check.items() if v}
    if not wrong:
        return "every kernel right"
    return "; ".join(f"{k}: {', '.join(v[:2])}{' ...' if len(v) > 2 else ''}" for k, v in wrong.items())
