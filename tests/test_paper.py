"""`tribench export --format latex|methods|bmf`: a run in the forms a paper and Bencher take."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import jsonschema
import pandas as pd
import pytest
from test_report_run import copy_run_inputs, run_fixture_dir

from tribench.harness import runfolder
from tribench.reports import paper
from tribench.reports.rundata import load_run

BMF_SCHEMA = json.loads((Path(__file__).parent / "bencher_metric_format.schema.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    run, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        yield run


def _export(run_dir: Path, fmt: str) -> str:
    argv = [sys.executable, "-m", "tribench.cli", "export", str(run_dir), "--format", fmt]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_bmf_validates_and_carries_every_estimate_with_its_interval(run_dir):
    doc = json.loads(_export(run_dir, "bmf"))
    jsonschema.Draft202012Validator(BMF_SCHEMA).validate(doc)
    est = pd.read_csv(run_dir / runfolder.ESTIMATES)
    assert len(doc) == len(est)
    for r in est.itertuples(index=False):
        m = doc[f"{r.kernel}/{r.workload}"]["ns-per-test"]
        assert (m["value"], m["lower_value"], m["upper_value"]) == pytest.approx(
            (r.ns_per_test, r.ns_per_test_ci_low, r.ns_per_test_ci_high)
        )
    spd = pd.read_csv(run_dir / runfolder.SPEEDUPS)
    slug = f"speedup-over-{spd['baseline'].iloc[0]}"
    assert sum(slug in measures for measures in doc.values()) == len(spd)


def test_the_schema_refuses_a_metric_without_a_value():
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"k/w": {"ns-per-test": {"lower_value": 1.0}}}, BMF_SCHEMA)


def _rows(table: str) -> list[str]:
    return [line for line in table.splitlines() if line.endswith(r"\\") and not line.startswith("Rank")]


def test_latex_has_one_booktabs_table_per_band_with_every_ranked_kernel(run_dir):
    text = _export(run_dir, "latex")
    bands = pd.read_csv(run_dir / runfolder.BANDS)
    tables = text.split(r"\begin{table}")[1:]
    assert len(tables) == bands.groupby(["build", "dtype", "band"]).ngroups
    rows = [row for t in tables for row in _rows(t)]
    assert all(row.count("&") == 5 for row in rows)
    # a kernel's row, then its intervals under its estimates, in small type
    kernels, intervals = rows[::2], rows[1::2]
    assert len(kernels) == len(intervals) == len(bands)
    assert all(row.startswith(" & & {\\footnotesize [") for row in intervals)
    for t in tables:
        assert t.index(r"\toprule") < t.index(r"\midrule") < t.index(r"\bottomrule") < t.index(r"\end{table}")
    # nothing LaTeX would read as markup: every _ and % escaped
    assert not re.search(r"(?<!\\)[_%]", text.replace(r"\_", "").replace(r"\%", ""))
    assert r"moller\_seed & " in text and "baseline" in text


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no TeX installation (Debian: texlive-latex-recommended)")
def test_latex_compiles(run_dir, tmp_path):
    body = _export(run_dir, "latex")
    doc = "\\documentclass{article}\n\\usepackage{booktabs}\n\\begin{document}\n" + body + "\\end{document}\n"
    (tmp_path / "t.tex").write_text(doc, encoding="utf-8")
    done = subprocess.run(
        ["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "t.tex"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout[-2000:]
    assert (tmp_path / "t.pdf").stat().st_size > 1000
    # every table and the methods paragraph within an article's text width (they ran 107-122 pt past it)
    assert "Overfull \\hbox" not in (tmp_path / "t.log").read_text(errors="replace")


def test_methods_quote_the_run_not_fixed_text(run_dir, tmp_path):
    data = load_run(run_dir)
    text = paper.methods(data)
    machine, sweep = data.run.machine, data.run.sweep
    for fact in (machine["cpu_model"], machine["build"]["compiler"], data.baseline, f"{data.margin:.1%}"):
        assert fact in text
    assert f"{sweep.warmup} warm-up and {sweep.rounds} timed rounds" in text
    assert all(w in text for w in pd.read_csv(run_dir / runfolder.ESTIMATES)["workload"])
    # another machine and compiler in run.json: the paragraph follows them
    other = tmp_path / "other"
    copy_run_inputs(run_dir, other, [p.name for p in run_dir.iterdir() if p.is_file() and p.name != "run.json"])
    run = json.loads((run_dir / "run.json").read_text())
    run["machine"]["cpu_model"], run["machine"]["build"]["compiler"] = "ARM Neoverse-V1 (implementer 0x41)", "clang 19"
    (other / "run.json").write_text(json.dumps(run))
    moved = paper.methods(load_run(other))
    assert "ARM Neoverse-V1" in moved and "by clang 19" in moved and machine["cpu_model"] not in moved


def test_methods_of_a_run_with_no_compared_estimate_say_so(run_dir):
    """Every kernel an A/A copy (sweep --kernels moller_trumbore_aa) or disagreeing with the reference: the
    paragraph took the spread of no process counts, and export --format methods|latex raised a traceback."""
    import dataclasses

    data = load_run(run_dir)
    none = data.estimates.iloc[:0]
    text = paper.methods(dataclasses.replace(data, estimates=none, every_build={runfolder.ESTIMATES: none}))
    assert "no kernel's estimate is reported (each was an A/A copy or disagreed with the reference)" in text
    assert all(w.summary() in text for w in data.run.sweep.workloads)


def _two_builds(data):
    """``data`` as a run of two builds would read: the installed one's rows again as clang's."""
    import dataclasses

    from tribench.ext import INSTALLED

    clang = {"spec": "clang -O2", "compiler": "Debian clang version 14.0.6", "flags": "-std=c11 -DNDEBUG -fPIC -O2"}
    sweep = dataclasses.replace(data.run.sweep, builds=(INSTALLED, clang["spec"]), processes=4)
    run = dataclasses.replace(data.run, sweep=sweep, builds=(*data.run.builds, clang))
    every = {name: pd.concat([t, t.assign(build=clang["spec"])]) for name, t in data.every_build.items()}
    return dataclasses.replace(data, run=run, every_build=every)


def test_every_export_of_a_run_of_two_builds_has_both_builds_and_names_their_compilers(run_dir):
    """export --format bmf|latex|methods of a --builds run wrote the first build's figures alone, named no build,
    and the methods paragraph named the installed build's compiler and flags, not the builds'."""
    data = load_run(run_dir)
    both = _two_builds(data)
    doc = paper.bencher(both)
    assert len(doc) == 2 * len(data.estimates)
    assert {name.rsplit("/", 1)[1] for name in doc} == {"installed", "clang -O2"}
    tables = paper.latex_tables(both).split(r"\begin{table}")[1:]
    assert len(tables) == 2 * data.tables[runfolder.BANDS].groupby(["dtype", "band"]).ngroups
    assert sum("build clang -O2" in t for t in tables) == len(tables) // 2
    text = paper.methods(both)
    assert "clang -O2: Debian clang version 14.0.6 (flags -std=c11 -DNDEBUG -fPIC -O2)" in text
    assert f"installed: {data.run.machine['build']['compiler']}" in text
