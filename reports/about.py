"""The report's closing sections: the workloads (pictures and achieved figures), machine and build, reproduce."""

from __future__ import annotations

import json
from html import escape
from pathlib import Path
from typing import Any

import pandas as pd

from ..harness.runfolder import FILES, Run
from . import page, rundata
from .rundata import RunData

__all__ = ["pictures_section", "machine_section", "reproduce_section", "sweep_toml"]


def pictures_section(data: RunData, wl: pd.DataFrame) -> str:
    """A card per workload: its picture (drawn by the analysis step) and its targets against the achieved."""
    body = [
        page.p(
            "What the kernels were timed on. Pair pictures map every pair's plane crossing into one "
            "reference triangle; mesh pictures show the mesh with its rays, hits and misses. Each title "
            "gives the targets against the achieved figures.",
            "note",
        )
    ]
    cards = []
    achieved = rundata.workload_figures(data)
    for r in wl.itertuples(index=False):
        rows = [("workload", f"{r.workload_id}: {r.summary}"), ("obtained from", r.source)]
        rows += [
            (f"{k}", f"target {page.plain(t)}, achieved {page.plain(a)}" if t is not None else page.plain(a))
            for k, t, a in achieved.get(r.workload_id, [])
        ]
        png, why = rundata.picture(data, r.workload_id)
        img = (
            page.figure(
                page.png_data_uri(page.palette_png(png)), f"picture of {r.workload_id}", f"{r.label} ({r.family})"
            )
            if png is not None
            else page.p(why, "note")
        )
        cards.append(
            f"<div><h3>{escape(r.label)} · {escape(r.family)}</h3>{img}"
            f"<details><summary>targets and achieved figures</summary>{page.kv_table(rows)}</details></div>"
        )
    body.append(f'<div class="pictures">{"".join(cards)}</div>')
    return "".join(body)


def pinning(run: Run) -> str:
    """Where the workers ran, in words: a CPU, or why they were not pinned."""
    if run.cpu is not None and run.cpu >= 0:
        return f"pinned to CPU {run.cpu}"
    if run.machine.get("can_pin") is False:
        return "not pinned: this system cannot pin a process to a CPU, so the OS may move a worker mid-batch"
    return "not pinned (the sweep asked for no pinning)"


def machine_tables(run: Run) -> list[str]:
    """The machine and software, the build of the C extension and each kernel's instruction set, as tables."""
    m = run.machine
    rows = [
        ("CPU", m.get("cpu_model")),
        ("logical CPUs", m.get("logical_cpus")),
        ("usable CPUs", m.get("usable_cpus")),
        ("workers", pinning(run)),
        ("SIMD features", m.get("simd_features")),
        ("caches", m.get("caches")),
        ("governor", m.get("governor")),
        ("CPU MHz (at start)", m.get("cpu_mhz")),
        ("load average (at start)", m.get("load_average")),
        ("platform", m.get("platform")),
        ("Python", m.get("python")),
        ("numpy", m.get("numpy")),
        ("tribench", m.get("tribench")),
        ("git revision", m.get("git_revision")),
    ]
    return [
        page.kv_table(rows),
        "<h3>Build of the C extension</h3>",
        page.kv_table(m.get("build", {}).items()),
        "<h3>Instruction set of each kernel</h3>",
        page.kv_table(run.isa.items()),
    ]


def machine_section(data: RunData) -> str:
    """The CPU, caches, software, build, each kernel's instruction set, RNG seeds and plan."""
    return (
        "".join(machine_tables(data.run))
        + "<h3>RNG seeds and plan</h3>"
        + page.kv_table(
            [
                ("sweep RNG seed", data.run.sweep.rng_seed),
                ("process seeds", list(data.run.process_seeds)),
                ("plan sha256", data.run.plan_sha256),
                ("batches planned / recorded", f"{data.run.n_batches} / {len(data.batches)}"),
            ]
        )
    )


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def sweep_toml(sweep: dict[str, Any]) -> str:
    """The run's sweep (run.json's) as a file ``tribench sweep --file`` reads back into the same plan;
    its kernel files are the run folder's copies, since the file sits in the run folder.

    >>> print(sweep_toml({"kernels": ["a"], "processes": 2, "rounds": 3, "warmup": 1,
    ...     "target_ms": 2.0, "rng_seed": 0, "workloads": [{"kind": "pairs", "n": 10}]}))
    # tribench sweep file, written by tribench report
    kernels = ["a"]
    processes = 2
    rounds = 3
    warmup = 1
    target_ms = 2.0
    rng_seed = 0
    <BLANKLINE>
    [[workloads]]
    kind = "pairs"
    n = 10
    <BLANKLINE>
    """
    from ..workloads.mesh_files import KERNELS_FOLDER

    lines = ["# tribench sweep file, written by tribench report"]
    for key in ("kernels", "processes", "rounds", "warmup", "target_ms", "rng_seed", "builds", "workload_kernels"):
        if key in sweep:
            lines.append(f"{key} = {_toml_value(sweep[key])}")
    if sweep.get("kernel_files"):
        copies = [f"{KERNELS_FOLDER}/{f['sha256']}{Path(f['path']).suffix.lower()}" for f in sweep["kernel_files"]]
        lines.append(f"kernel_files = {_toml_value(copies)}  # the run folder's copies")
    if sweep.get("sequential"):
        lines.append(f"sequential = {_toml_value(sweep['sequential'])}")
    for spec in sweep.get("workloads", []):
        lines += ["", "[[workloads]]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in spec.items() if v is not None]
    return "\n".join(lines) + "\n"


def reproduce_section(data: RunData, sweep_file: str) -> str:
    """How to run the sweep again and redraw the report, and what every file of the run folder holds."""
    rev = data.machine.get("git_revision")
    command = data.run.command
    steps = [f"git checkout {rev}"] if rev else []
    steps += [
        "pip install -e .",
        f"tribench sweep --file {sweep_file} --out NEW_RUN_DIR",
        "tribench report NEW_RUN_DIR",
    ]
    body = [
        page.p(
            "The plan (which batches run, in which order, with which layout seeds) is a pure function of the "
            "sweep below, and every workload a pure function of its spec: the same sweep on the same revision "
            "repeats the run. The times will differ by the machine's noise; compare two runs with "
            "`tribench compare RUN_A RUN_B`."
        ),
    ]
    if command:
        body += ["<h3>The command that made this run</h3>", page.code(page.plain(command))]
    body += [
        "<h3>To run it again</h3>",
        page.code("\n".join(steps)),
        f"<h3>{escape(sweep_file)} (written next to this report)</h3>",
        page.code(sweep_toml(data.run.sweep.to_dict())),
        "<h3>To redraw this report</h3>",
        page.code(f"tribench report {data.run_dir}"),
        "<h3>Files of the run folder</h3>",
        page.p("Tidy CSVs, one row per observation, raw units (nanoseconds, counts, fractions).", "note"),
    ]
    for name, cols in FILES.items():
        present = (data.run_dir / name).is_file()
        body.append(
            f"<details><summary>{escape(name)}{'' if present else ' (absent)'}</summary>"
            + page.kv_table(cols.items())
            + "</details>"
        )
    return "".join(body)
