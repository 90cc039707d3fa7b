"""``seed.html``: the page of a ``tribench seed`` run, one self-contained file.

Reads only the run folder: ``run.json``, the tables :mod:`tribench.harness.jobs.seed`
wrote, and the pictures, inlined as base64 PNG."""

from __future__ import annotations

import math
from collections.abc import Mapping
from html import escape
from pathlib import Path
from typing import Any

import pandas as pd

from ..common import write_text
from ..harness.jobs.seed import MISS_STAGES, PROGRAM
from ..harness.runfolder import Run
from ..harness.stats import format_interval
from . import charts, page
from .about import machine_tables
from .speed_charts import seed_chart
from .tables.seed import ratio_baseline, read_seed_run

__all__ = ["SEED_REPORT", "format_table", "render_seed", "write_seed_report"]

SEED_REPORT = "seed.html"

SECTIONS = {
    "paper": "The table beside the paper",
    "kinds": "Cost per test, by ray kind",
    "workload": "The seed's workload: hit rate and miss stages",
    "pictures": "Pictures",
    "machine": "Machine and build",
    "reproduce": "Reproduce",
}


def _v(x: float, fmt: str = ".4g") -> str:
    return "–" if x is None or not math.isfinite(float(x)) else f"{x:{fmt}}"


def _intervals(frame: pd.DataFrame, name: str, fmt: str) -> list[str]:
    """Each row's interval of ``name`` (its ``_ci_low`` and ``_ci_high`` columns) as text."""
    lows, highs = frame[f"{name}_ci_low"], frame[f"{name}_ci_high"]
    return [format_interval(None, a, b, fmt) for a, b in zip(lows, highs, strict=True)]


def _section(sid: str, body: str) -> str:
    return page.section(sid, SECTIONS[sid], body)


def _ratio_figure(seed: pd.DataFrame) -> str:
    """Each kernel's render time over its baseline's with its CI, per scene; the paper's ratios marked."""
    return charts.embed(
        seed_chart(seed, charts.kernel_colours(list(dict.fromkeys(seed["kernel"])))),
        "chart-seed",
        "ratios to moller_seed",
        "Render time of each kernel over its baseline's (moller_seed_object for the object forms, moller_seed "
        "for the others), 95% CIs, log axis; diamonds: the paper's Curless/Möller ratio (open: real, filled: "
        "user). Hover for the figures.",
    )


#: How the replay's table reads beside the paper's, first on the page.
_PAPER_INTRO = (
    "Paper: the seed's Unix time of the whole 512×512 render (2.3 GHz Core i9, one run per cell). "
    "What is replayed: the render's ray–triangle tests, and only them, by curless_seed_object and "
    "moller_seed_object as the seed's program runs them (its C++ objects, out-of-line vector calls, "
    "virtual dispatch and scene loop, so their seconds predict its user time on this machine, within "
    "the model error the widened interval adds), and by every other kernel as tribench's loop runs it. "
    "Each kind of ray (primary, reflected, shadow) is a workload sampled as runs of consecutive rays "
    "spread over the render; a pass over the sample is scaled by the render's tests of that kind over "
    "the sample's, and the kinds are added: one render time per worker process, mean with a 95% "
    "Student-t interval over processes. The ratio (to moller_seed_object for the object forms, to "
    "moller_seed for the others) is paired per process (log scale). The paper's times also cover "
    "spheres, the floor, shading, output and start-up, so its seconds are larger and its ratio is "
    "diluted where triangles are a small part of the work (scene02 has 12)."
)


def _scene_table(scene: str, g: pd.DataFrame, size: str) -> list[str]:
    """One scene's heading and its table: every kernel's replay beside the paper's times and ratios."""
    first = g.iloc[0]
    heading = (
        f"<h3>{escape(str(scene))}: {int(first['triangles'])} triangles, "
        f"{first['render_tests']:.4g} ray–triangle tests per {size} render</h3>"
    )
    rows = pd.DataFrame(
        {
            "kernel": g["kernel"],
            "paper real (s)": [_v(x, ".3f") for x in g["paper_real_s"]],
            "paper user (s)": [_v(x, ".3f") for x in g["paper_user_s"]],
            "replay (s)": [_v(x) for x in g["render_s"]],
            "95% CI (s)": _intervals(g, "render_s", ".4g"),
            "replay ns/test": [_v(x, ".3g") for x in g["replay_ns_per_test"]],
            "paper user ns/test (bound)": [_v(x, ".3g") for x in g["paper_user_ns_per_test"]],
            "paper ratio real / user": [
                f"{_v(a, '.3f')} / {_v(b, '.3f')}" if math.isfinite(a) else "–"
                for a, b in zip(g["paper_ratio_real"], g["paper_ratio_user"], strict=True)
            ],
            "replay ratio": [_v(x, ".3f") for x in g["ratio_to_moller_seed"]],
            "to": g["ratio_baseline"],
            "95% CI": _intervals(g, "ratio_to_moller_seed", ".3f"),
            "processes": g["n_processes"],
        }
    )
    return [heading, page.table(rows, [(c, c) for c in rows.columns])]


def _why_curless(r: pd.Series) -> str:
    """What in the scene's workload makes Curless faster or slower than Möller–Trumbore."""
    return (
        f" Its workload: per-test hit rate {100 * r['test_hit_rate']:.3g}%, and of the misses "
        f"{100 * r['miss_behind_origin']:.3g}% are behind the origin, which Curless rejects right "
        f"after its plane test and Möller–Trumbore only after u, v and t; "
        f"{100 * (1 - r['miss_behind_origin'] - r['miss_parallel']):.3g}% pass beside the triangle, "
        f"where Curless computes t, the point and one to three edge tests, and Möller–Trumbore "
        f"stops at u or v."
    )


def _replayed(c: pd.Series) -> tuple[str, str]:
    """A kernel's replayed ratio with its 95% CI, and the seed's program's predicted from it ("" if none)."""
    ratio = format_interval(
        c["ratio_to_moller_seed"], c["ratio_to_moller_seed_ci_low"], c["ratio_to_moller_seed_ci_high"], ".3f"
    )
    if not math.isfinite(c["predicted_ratio_low"]):
        return ratio, ""
    return ratio, format_interval(None, c["predicted_ratio_low"], c["predicted_ratio_high"], ".3f")


def _curless_over_moller(scene: str, g: pd.DataFrame, wl: pd.DataFrame) -> list[str]:
    """The paper's Curless/Möller ratio beside the replay's, the program's first, and why (none without Curless)."""
    rows = g.set_index("kernel")
    paper_row = next((rows.loc[k] for k in ("curless_seed_object", "curless_seed") if k in rows.index), None)
    if paper_row is None:
        return []
    paper = (
        f"the paper's {paper_row['paper_ratio_real']:.3f} (real) and {paper_row['paper_ratio_user']:.3f} (user), "
        if math.isfinite(paper_row["paper_ratio_real"])
        else ""
    )
    parts = []
    for kernel, what in (("curless_seed_object", "the seed's program"), ("curless_seed", "its arithmetic")):
        if kernel in rows.index and math.isfinite(rows.loc[kernel, "ratio_to_moller_seed"]):
            ratio, predicted = _replayed(rows.loc[kernel])
            so = f", so the program here {predicted} with the model's error" if predicted else ""
            parts.append(f"{what} replayed {ratio} (95% CI){so}")
    r = wl.loc[(wl["scene"] == scene) & (wl["rays"] == "render")]
    why = _why_curless(r.iloc[0]) if len(r) else ""
    return [page.p(f"Curless over Möller: {paper}{'; '.join(parts)}." + why)]


def _paper(seed: pd.DataFrame, wl: pd.DataFrame, replay: Mapping[str, Any]) -> str:
    """The table beside the paper: per scene, every kernel's replay and the paper's times, then Curless over Möller."""
    size = f"{replay['width']}×{replay['height']}"
    body = [page.p(_PAPER_INTRO)]
    if size != "512×512":
        body.append(
            page.warn(
                f"This replay renders {size}, not the paper's 512×512: compare its ratios with the "
                "paper's, not its seconds."
            )
        )
    for scene, g in seed.groupby("scene", sort=False):
        body += _scene_table(scene, g, size)
        body += _curless_over_moller(scene, g, wl)
    body.append(_ratio_figure(seed))
    return _section("paper", "".join(body))


def _kinds(kinds: pd.DataFrame) -> str:
    rows = pd.DataFrame(
        {
            "scene": kinds["scene"],
            "rays": kinds["rays"],
            "mode": kinds["mode"],
            "kernel": kinds["kernel"],
            "ns/test": [_v(x, ".4g") for x in kinds["ns_per_test"]],
            "95% CI": _intervals(kinds, "ns_per_test", ".4g"),
            "tests per pass": kinds["tests_per_pass"].astype(int),
            "render tests": kinds["stream_tests"],
            "share of render (s)": [_v(x) for x in kinds["render_s"]],
            "share of render": [_v(100 * x, ".3g") + "%" for x in kinds["render_share"]],
        }
    )
    return _section(
        "kinds",
        page.p(
            "Mean over processes of each process's median ns per test, with a 95% "
            "Student-t interval. Shadow rays (mode any) stop at their first occluder, so a "
            "pass runs fewer tests than rays × triangles; wide kernels count them in blocks "
            "of 8."
        )
        + page.table(rows, [(c, c) for c in rows.columns]),
    )


def _workload(wl: pd.DataFrame) -> str:
    stages = [c for c in wl.columns if c.startswith("miss_")]
    rows = pd.DataFrame(
        {
            "scene": wl["scene"],
            "rays": wl["rays"],
            "render rays": wl["stream_rays"],
            "render tests": wl["stream_tests"],
            "sampled rays": wl["sample_rays"],
            "per-test hit rate": [_v(100 * x, ".3g") + "%" for x in wl["test_hit_rate"]],
            "per-ray hit rate": [_v(100 * x, ".3g") + "%" for x in wl["ray_hit_rate"]],
            **{c.removeprefix("miss_").replace("_", " "): [_v(100 * x, ".3g") + "%" for x in wl[c]] for c in stages},
        }
    )
    text = page.p(
        "By the float64 reference on the sampled rays. Per-test hit rate: hits over the tests a kernel runs "
        "(the axis of Löfstedt & Akenine-Möller 2005); per-ray: rays that hit a triangle. Each miss is "
        "counted at the stage where Curless's test rejects it, in its order: parallel (no crossing), "
        "behind the origin (t ≤ 0), then outside edge v0v1, v1v2, v2v0 (the first edge test that fails). "
        "The 'render' row weighs the kinds by the render's tests (and misses)."
    )
    return _section("workload", text + page.table(rows, [(c, c) for c in rows.columns]))


def _pictures(run_dir: Path, pics: pd.DataFrame) -> str:
    body = [
        page.p(
            "Both seed kernels at float precision, as the seed renders (the seed's shading and depth-2 "
            "reflections). A differing pixel is explained when one of its rays passes within the tolerance "
            "of a triangle's edge (barycentric), where float rounding and the seeds' absolute epsilons decide "
            "differently, or when its colours differ by under 1e-5 (an 8-bit truncation flipped)."
        )
    ]
    for r in pics.itertuples(index=False):
        cards = []
        for col, caption in (
            ("curless_seed_png", "curless_seed"),
            ("moller_seed_png", "moller_seed"),
            ("difference_png", f"difference: {r.differing_pixels} pixels"),
        ):
            path = run_dir / str(getattr(r, col))
            uri = page.png_data_uri(path.read_bytes()) if path.is_file() else ""
            cards.append(page.figure(uri, caption, caption, img_class="pixels"))
        body.append(f"<h3>{escape(str(r.scene))} ({r.width}×{r.height}, {escape(str(r.dtype))})</h3>")
        body.append(f'<div class="pictures three">{"".join(cards)}</div>')
        body.append(
            page.p(
                f"{r.differing_pixels} differing pixels: {r.near_edge_pixels} within "
                f"{r.edge_tolerance:g} of a triangle edge, {r.last_bit_pixels} last-bit colour flips, "
                f"{r.other_pixels} other."
            )
        )
    return _section("pictures", "".join(body))


def _machine(run: Run) -> str:
    sweep = run.sweep
    design = [
        ("processes", sweep.processes),
        ("rounds (+ warm-up)", f"{sweep.rounds} (+{sweep.warmup})"),
        ("batch target (ms)", sweep.target_ms),
        ("sweep RNG seed", sweep.rng_seed),
        ("process seeds", list(run.process_seeds)),
        ("equivalence margin", {"value": run.margin.value, "source": run.margin.source}),
    ]
    return _section("machine", "".join(machine_tables(run)) + "<h3>Design</h3>" + page.kv_table(design))


def _reproduce(run: Run) -> str:
    from ..harness.jobs.seed import COLUMNS

    rev = run.machine.get("git_revision")
    steps = ([f"git checkout {rev}"] if rev else []) + ["pip install -e .", run.command or "tribench seed"]
    body = [
        "<h3>The command that made this run</h3>",
        page.code(run.command or "(not recorded)"),
        "<h3>To run it again</h3>",
        page.code("\n".join(steps)),
        page.p(
            "Every workload is a pure function of its spec (the sampled rays are drawn with a fixed RNG seed) and "
            "the plan a pure function of the sweep in run.json; times differ by the machine's noise. The run "
            "folder also holds the runner's batches.csv, processes.csv, checks.csv and the analysis's "
            "estimates.csv and speedups.csv.",
            "note",
        ),
        "<h3>Files of this page</h3>",
    ]
    for name, cols in COLUMNS.items():
        body.append(f"<details><summary>{escape(name)}</summary>{page.kv_table(cols.items())}</details>")
    return _section("reproduce", "".join(body))


def _kernels_timed(replay: Mapping[str, Any]) -> str:
    """Which kernels the run timed, in words (nothing for a run folder older than the choice)."""
    if "all_kernels" not in replay:
        return ""
    if replay["all_kernels"]:
        return "Kernels: every kernel (--all-kernels)."
    return (
        "Kernels: the seed's two, their clean scalar forms and the native form of every algorithm that "
        "tests both faces (tribench seed --all-kernels times every kernel)."
    )


def render_seed(run_dir: str | Path) -> str:
    """The whole page of a seed run, as a string."""
    from ..harness.jobs.seed import KINDS_CSV, PICTURES_CSV, SEED_CSV, WORKLOADS_CSV

    run_dir = Path(run_dir)
    run, replay = read_seed_run(run_dir)
    seed, kinds, wl, pics = (pd.read_csv(run_dir / n) for n in (SEED_CSV, KINDS_CSV, WORKLOADS_CSV, PICTURES_CSV))
    title = f"tribench seed — {run.run_id}"
    sections = [
        _paper(seed, wl, replay),
        _kinds(kinds),
        _workload(wl),
        _pictures(run_dir, pics),
        _machine(run),
        _reproduce(run),
    ]
    head = f"<h1>{escape(title)}</h1>" + page.p(
        f"The seed's renders (Vitse 2022: Curless vs Möller, Unix time) replayed through the harness: "
        f"{run.created}, {run.sweep.processes} processes. {_kernels_timed(replay)}",
        "sub",
    )
    return page.document(title, head + "".join(sections), SECTIONS, f"tribench seed at {page.now()} from {run_dir}")


def write_seed_report(run_dir: str | Path) -> Path:
    """Write ``RUN_DIR/seed.html`` (atomically) and return its path."""
    out = Path(run_dir) / SEED_REPORT
    write_text(out, render_seed(run_dir))
    return out


# ------------------------------------------------------------------ the terminal's table (``tribench seed``)


def _terminal_curless_over_moller(g: pd.DataFrame) -> list[str]:
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
    replay, predicted = _replayed(c)
    program = f"; the seed's program here: {predicted}" if predicted else ""
    return [f"  Curless / Moller: {paper}replay ({kernel}) {replay}{program}"]


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
            render_ci = format_interval(None, r.render_s_ci_low, r.render_s_ci_high, ".4g")
            ratio_ci = format_interval(None, r.ratio_to_moller_seed_ci_low, r.ratio_to_moller_seed_ci_high, ".3f")
            lines.append(
                f"  {r.kernel:<26}{paper}{r.render_s:11.4g}  {render_ci:<22}{r.ratio_to_moller_seed:7.3f}  {ratio_ci}"
            )
        lines += _terminal_curless_over_moller(g)
    return "\n".join(lines)
