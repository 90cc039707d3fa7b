"""The seed replay's tables, from its run folder alone: render times beside the paper's, per ray kind.

``tribench seed`` measures (:mod:`tribench.harness.jobs.seed`); these turn its
batches into ``seed.csv``, ``seed_kinds.csv`` and ``seed_workloads.csv``."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from ...common import UserError
from ...harness import runfolder, stats
from ...harness.jobs.seed import (
    BASELINE,
    COLUMNS,
    KINDS_CSV,
    MISS_STAGES,
    MODEL_ERROR,
    PAPER,
    PROGRAM,
    SEED_CSV,
    STREAM_FIGURES,
    WORKLOADS_CSV,
)
from .frames import in_order, paired_time_ratio, with_ci
from .pipeline import analyse, write_tables

__all__ = ["ratio_baseline", "read_seed_run", "render_per_process", "render_table", "seed_tables", "write_seed_tables"]


def write_seed_tables(run_dir: str | Path) -> dict[str, pd.DataFrame]:
    """Every table of a seed run: the sweep's (estimates, speedups, ...) and the seed's own three, written."""
    write_tables(run_dir, analyse(run_dir, baseline=BASELINE))
    tables = seed_tables(run_dir)
    for name in (SEED_CSV, KINDS_CSV, WORKLOADS_CSV):
        runfolder.write_csv(tables[name], Path(run_dir) / name)
    return tables


def render_per_process(pp: pd.DataFrame, workloads: Mapping[str, Mapping[str, Any]]) -> pd.DataFrame:
    """One render's time per scene, kernel and process: ``scene, kernel, process, render_s``.

    ``pp``: per-process ``ns_per_test`` and ``tests_per_pass``; ``workloads``: id -> ``scene``, ``stream_tests``,
    ``sample_tests``. A process lacking one of the scene's ray kinds is left out (its sum would be short).

    >>> pp = pd.DataFrame({"kernel": ["k"] * 2, "workload_id": ["a", "b"], "process": [0, 0],
    ...                    "ns_per_test": [2.0, 4.0], "tests_per_pass": [100, 50]})
    >>> w = {"a": {"scene": "s", "stream_tests": 1000, "sample_tests": 100},
    ...      "b": {"scene": "s", "stream_tests": 600, "sample_tests": 60}}
    >>> round(float(render_per_process(pp, w)["render_s"].iloc[0]) * 1e9, 6)  # 2*100*10 + 4*50*10
    4000.0
    """
    info = pd.DataFrame.from_dict(dict(workloads), orient="index")[["scene", "stream_tests", "sample_tests"]]
    d = pp.join(info, on="workload_id", how="inner")
    d = d.assign(render_s=d["ns_per_test"] * d["tests_per_pass"] * d["stream_tests"] / d["sample_tests"] * 1e-9)
    kinds = info.groupby("scene").size()
    g = (
        d.groupby(["scene", "kernel", "process"], sort=False)["render_s"]
        .agg(render_s="sum", kinds="size")
        .reset_index()
    )
    return g.loc[g["kinds"] == g["scene"].map(kinds)].drop(columns="kinds").reset_index(drop=True)


def ratio_baseline(kernel: str) -> str:
    """A render time's divisor: ``moller_seed_object`` for the object forms, else ``moller_seed``."""
    return PROGRAM[1] if kernel in PROGRAM else BASELINE


#: The paper's column an object form is set beside: the seed kernel whose program it replays.
PAPER_KERNEL = {"curless_seed_object": "curless_seed", "moller_seed_object": "moller_seed"}


def _paired_ratio(per: pd.DataFrame, scene: str, kernel: str) -> tuple[float, float, float]:
    """time_kernel / time of its ratio_baseline, paired by process (nan when the baseline is absent)."""
    base = ratio_baseline(kernel)
    if kernel == base:
        return 1.0, 1.0, 1.0
    sel = per.loc[per["scene"] == scene].pivot(index="process", columns="kernel", values="render_s")
    if base not in sel or kernel not in sel:
        return math.nan, math.nan, math.nan
    return paired_time_ratio(sel, kernel, base, stats.DEFAULTS.confidence)[:3]


def _widened(low: float, high: float, kernel: str) -> tuple[float, float]:
    """A 95% interval widened by the replay's model error (:data:`MODEL_ERROR`), for the object forms only:
    what the seed's own program is predicted to take on this machine."""
    if kernel not in PROGRAM:
        return math.nan, math.nan
    return low / (1 + MODEL_ERROR), high * (1 + MODEL_ERROR)


def render_table(per: pd.DataFrame, scenes: Mapping[str, Mapping[str, Any]]) -> pd.DataFrame:
    """The table beside the paper: one row per scene and kernel (``seed.csv``).

    ``scenes`` maps a scene to ``triangles``, ``render_tests``, ``paper`` (a key of :data:`PAPER` or None) and
    optionally ``paper_size`` (False: the image is not the paper's 512 x 512, so the paper's bound is left empty)."""
    rows = []
    for (scene, kernel), g in per.groupby(["scene", "kernel"], sort=False):
        e = stats.estimate(g["render_s"].to_numpy())
        ratio, low, high = _paired_ratio(per, scene, kernel)
        sc = scenes[scene]
        paper = PAPER.get(sc.get("paper") or "", {})
        mine, base = paper.get(PAPER_KERNEL.get(kernel, kernel), {}), paper.get(BASELINE, {})
        predicted = _widened(e.ci_low, e.ci_high, kernel)
        predicted_ratio = _widened(low, high, kernel) if kernel != ratio_baseline(kernel) else (1.0, 1.0)
        tests = sc["render_tests"]
        rows.append(
            {
                "scene": scene,
                "kernel": kernel,
                "triangles": sc["triangles"],
                "render_tests": tests,
                **with_ci("render_s", e.mean, e.ci_low, e.ci_high),
                "render_s_min": e.minimum,
                "replay_ns_per_test": e.mean / tests * 1e9,
                "ratio_baseline": ratio_baseline(kernel),
                **with_ci("ratio_to_moller_seed", ratio, low, high),
                "predicted_s_low": predicted[0],
                "predicted_s_high": predicted[1],
                "predicted_ratio_low": predicted_ratio[0] if kernel in PROGRAM else math.nan,
                "predicted_ratio_high": predicted_ratio[1] if kernel in PROGRAM else math.nan,
                "n_processes": e.n,
                "paper_real_s": mine.get("real", math.nan),
                "paper_user_s": mine.get("user", math.nan),
                "paper_ratio_real": mine["real"] / base["real"] if mine and base else math.nan,
                "paper_ratio_user": mine["user"] / base["user"] if mine and base else math.nan,
                "paper_user_ns_per_test": mine["user"] / tests * 1e9
                if mine and sc.get("paper_size", True)
                else math.nan,
            }
        )
    return pd.DataFrame(rows, columns=list(COLUMNS[SEED_CSV]))


def _workloads_table(info: Mapping[str, Mapping[str, Any]]) -> pd.DataFrame:
    rows = []
    for wid, w in info.items():
        rows.append(
            {
                "scene": w["scene"],
                "rays": w["rays"],
                "workload_id": wid,
                "mode": w["mode"],
                **{k: w[k] for k in STREAM_FIGURES},
                **{f"miss_{s}": w["miss_mix"].get(s, 0.0) for s in MISS_STAGES},
            }
        )
    table = pd.DataFrame(rows, columns=list(COLUMNS[WORKLOADS_CSV]))
    out = []
    for scene, g in table.groupby("scene", sort=False):
        # the render as a whole: hit rate weighted by tests, the mix by (estimated) misses
        tests = g["stream_tests"].astype(float)
        misses = tests * (1 - g["test_hit_rate"])
        total = {
            "scene": scene,
            "rays": "render",
            "workload_id": "",
            "mode": "",
            "triangles": g["triangles"].iloc[0],
            "stream_rays": g["stream_rays"].sum(),
            "stream_tests": g["stream_tests"].sum(),
            "sample_rays": g["sample_rays"].sum(),
            "sample_tests": g["sample_tests"].sum(),
            "test_hit_rate": float((g["test_hit_rate"] * tests).sum() / tests.sum()),
            "ray_hit_rate": float((g["ray_hit_rate"] * g["stream_rays"]).sum() / g["stream_rays"].sum()),
            "ambiguous_rays": g["ambiguous_rays"].sum(),
        }
        for s in MISS_STAGES:
            total[f"miss_{s}"] = float((g[f"miss_{s}"] * misses).sum() / misses.sum()) if misses.sum() else 0.0
        out += [g, pd.DataFrame([total], columns=table.columns)]
    return pd.concat(out, ignore_index=True)


def read_seed_run(run_dir: str | Path) -> tuple[runfolder.Run, Mapping[str, Any]]:
    """A seed replay's run record and its ``seed_replay`` part; a UserError for any other run folder."""
    run = runfolder.read_run(run_dir)
    if run.seed_replay is None:
        raise UserError(f"{run_dir} is not a run folder of the seed replay (tribench seed makes those)")
    return run, run.seed_replay


def seed_tables(run_dir: str | Path) -> dict[str, pd.DataFrame]:
    """``seed.csv``, ``seed_kinds.csv`` and ``seed_workloads.csv`` of a seed run, from its files alone."""
    from ...workloads.seed.workload import RAY_KINDS

    run, replay = read_seed_run(run_dir)
    scene_order = {s: i for i, s in enumerate(replay["scenes"])}
    info = dict(
        sorted(
            replay["workloads"].items(),  # scenes as given, kinds in ray order
            key=lambda kv: (scene_order.get(kv[1]["scene"], 0), RAY_KINDS.index(kv[1]["rays"])),
        )
    )
    kernels = run.sweep.kernels
    batches = runfolder.read_batches(run_dir, run)
    pp = stats.per_process(batches)
    timed = batches.loc[~batches["warmup"]]
    passes = (timed["tests"] / timed["loops"]).groupby([timed["kernel"], timed["workload_id"]]).median()
    pp = pp.join(passes.rename("tests_per_pass"), on=["kernel", "workload_id"])
    pp = in_order(pp, kernel=kernels)

    wl = _workloads_table(info)
    paper_size = (replay["width"], replay["height"]) == (512, 512)
    scenes = {
        r.scene: {
            "triangles": r.triangles,
            "render_tests": r.stream_tests,
            "paper_size": paper_size,
            "paper": next((w["paper"] for w in info.values() if w["scene"] == r.scene), None),
        }
        for r in wl.loc[wl["rays"] == "render"].itertuples()
    }
    per = render_per_process(pp, info)
    seed = in_order(render_table(per, scenes), scene=list(scenes), kernel=kernels)

    kinds = []
    d = pp.join(pd.DataFrame.from_dict(info, orient="index"), on="workload_id", how="inner")
    d["share_s"] = d["ns_per_test"] * d["tests_per_pass"] * d["stream_tests"] / d["sample_tests"] * 1e-9
    for (wid, kernel), g in d.groupby(["workload_id", "kernel"], sort=False):
        w = info[wid]
        e = stats.estimate(g["ns_per_test"].to_numpy())
        total = seed.loc[(seed["scene"] == w["scene"]) & (seed["kernel"] == kernel), "render_s"]
        share = float(g["share_s"].mean())
        kinds.append(
            {
                "scene": w["scene"],
                "rays": w["rays"],
                "kernel": kernel,
                "workload_id": wid,
                "mode": w["mode"],
                **with_ci("ns_per_test", e.mean, e.ci_low, e.ci_high),
                "tests_per_pass": float(g["tests_per_pass"].iloc[0]),
                "sample_tests": w["sample_tests"],
                "stream_tests": w["stream_tests"],
                "render_s": share,
                "render_share": share / float(total.iloc[0]) if len(total) else math.nan,
                "n_processes": e.n,
            }
        )
    kt = in_order(
        pd.DataFrame(kinds, columns=list(COLUMNS[KINDS_CSV])), scene=list(scenes), rays=RAY_KINDS, kernel=kernels
    )
    return {SEED_CSV: seed, KINDS_CSV: kt, WORKLOADS_CSV: wl}
