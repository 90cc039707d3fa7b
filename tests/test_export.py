"""google_benchmark.json: the run's estimates and speedups in Google Benchmark's JSON format.

Checked three ways: against a JSON Schema of the format (written from Google
Benchmark's JSONReporter, tests/google_benchmark.schema.json), against what
Google Benchmark's own reader, tools/compare.py (tools/gbench/util.py and
report.py), needs of a file, and against the run's tables it comes from.
"""

from __future__ import annotations

import copy
import json
import math
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import jsonschema
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_report_run import run_fixture_dir

from tribench.harness import runfolder
from tribench.reports.tables import export

SCHEMA = json.loads((Path(__file__).parent / "google_benchmark.schema.json").read_text(encoding="utf-8"))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    run, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        yield run


@pytest.fixture(scope="module")
def document(run_dir):
    return json.loads((run_dir / runfolder.GOOGLE_BENCHMARK).read_text(encoding="utf-8"))


def _tribench(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tribench.cli", *args], capture_output=True, text=True, timeout=120)


# ----------------------------------------------------------------- the format


def test_the_schema_is_a_valid_json_schema():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)


def test_the_analysis_step_writes_a_file_the_schema_accepts(run_dir, document):
    errors = sorted(VALIDATOR.iter_errors(document), key=str)
    assert not errors, "\n".join(f"{list(e.path)}: {e.message}" for e in errors[:5])
    record = json.loads((run_dir / runfolder.ANALYSIS).read_text())
    assert record["exports"] == [runfolder.GOOGLE_BENCHMARK]
    text = (run_dir / runfolder.GOOGLE_BENCHMARK).read_text()
    assert "NaN" not in text and "Infinity" not in text  # strict JSON: any reader parses it


def _field_paths(document: dict) -> list[tuple[str, ...]]:
    paths = [("context", k) for k in SCHEMA["properties"]["context"]["required"]]
    return paths + [("benchmarks", str(i), k) for i in range(3) for k in SCHEMA["$defs"]["run"]["required"]]


@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_the_schema_refuses_a_file_with_a_field_missing_or_of_another_type(document, data):
    # a schema that accepted anything would pass the test above
    broken = copy.deepcopy(document)
    path = data.draw(st.sampled_from(_field_paths(document)))
    parent = broken
    for key in path[:-1]:
        parent = parent[int(key)] if isinstance(parent, list) else parent[key]
    if data.draw(st.booleans()):
        del parent[path[-1]]
    else:
        parent[path[-1]] = {"not": "a value of this field"}
    assert not VALIDATOR.is_valid(broken), path


def test_the_schema_refuses_what_the_reporter_never_writes(document):
    aggregate = next(b for b in document["benchmarks"] if b["run_type"] == "aggregate")
    iteration = next(b for b in document["benchmarks"] if b["run_type"] == "iteration")
    for bad in (
        {**aggregate, "repetition_index": 0},  # an aggregate has no repetition
        {**iteration, "aggregate_name": "mean"},
        {**iteration, "time_unit": "cycles"},
        {**iteration, "ci_low": "1.5"},  # a counter is a number
    ):
        assert not VALIDATOR.is_valid({**document, "benchmarks": [bad]})
    assert not VALIDATOR.is_valid({**document, "context": {**document["context"], "json_schema_version": 2}})
    assert not VALIDATOR.is_valid({**document, "context": {**document["context"], "machine.x": 3}})


# ------------------------------------------------------- what compare.py reads


def test_google_benchmarks_compare_py_can_read_it(document):
    """What tools/gbench (util.py, report.py) needs of a file, field by field."""
    # util.load_benchmark_results: a json_schema_version in context must be 1
    assert document["context"]["json_schema_version"] == 1
    by_name = defaultdict(list)
    for b in document["benchmarks"]:
        by_name[b["name"]].append(b)
        # report.is_potentially_comparable_benchmark, and get_timedelta_field_as_seconds's unit table
        assert {"time_unit", "real_time", "cpu_time"} <= set(b) and b["time_unit"] in {"s", "ms", "us", "ns"}
        assert all(isinstance(b[k], float) for k in ("real_time", "cpu_time"))
        # util.sort_benchmark_results sorts on these; report.print_difference_report on run_type
        assert isinstance(b["family_index"], int) and isinstance(b["per_family_instance_index"], int)
        assert b["run_type"] in {"iteration", "aggregate"} and isinstance(b.get("label", ""), str)
        assert (b["run_type"] == "aggregate") == ("aggregate_name" in b)
        # the benchmark filter matches run_name, else name
        assert b["run_name"] == b["name"].removesuffix(f"_{b.get('aggregate_name', '')}")
    for name, group in by_name.items():
        # report.partition_benchmarks pairs entries of one name; all must share the first one's time unit
        assert len({b["time_unit"] for b in group}) == 1
        kinds = {b["run_type"] for b in group}
        assert len(kinds) == 1, f"{name}: repetitions and an aggregate under one name would be compared as one"
        if kinds == {"iteration"}:  # the repetitions the U test reads (report.calc_utest)
            assert [b["repetition_index"] for b in group] == list(range(group[0]["repetitions"]))
    assert len(by_name) > 1


# ------------------------------------------------------- the run's own figures


def test_every_estimate_and_speedup_is_there_with_its_interval(run_dir, document):
    est = pd.read_csv(run_dir / runfolder.ESTIMATES)
    spd = pd.read_csv(run_dir / runfolder.SPEEDUPS)
    pp = pd.read_csv(run_dir / runfolder.PER_PROCESS)
    entries = {b["name"]: b for b in document["benchmarks"] if b["run_type"] == "aggregate"}
    for r in est.itertuples(index=False):
        mean = entries[f"{r.kernel}/{r.workload_id}_mean"]
        assert mean["real_time"] == r.ns_per_test and mean["aggregate_unit"] == "time"
        assert (mean["ci_low"], mean["ci_high"], mean["confidence"]) == (
            r.ns_per_test_ci_low,
            r.ns_per_test_ci_high,
            r.confidence,
        )
        assert entries[f"{r.kernel}/{r.workload_id}_stddev"]["real_time"] == r.ns_per_test_sd
        assert mean["label"] == r.workload
    for r in spd.itertuples(index=False):
        s = entries[f"{r.kernel}/{r.workload_id}_speedup"]
        assert (s["real_time"], s["ci_low"], s["ci_high"]) == (r.ratio, r.ratio_ci_low, r.ratio_ci_high)
        assert s["aggregate_unit"] == "percentage" and s["label"].endswith(f"; {r.verdict} against {r.baseline}")
    assert len([n for n in entries if n.endswith("_speedup")]) == len(spd)
    reps = [b for b in document["benchmarks"] if b["run_type"] == "iteration"]
    assert sorted((b["name"], b["process"], b["real_time"]) for b in reps) == sorted(
        (f"{r.kernel}/{r.workload_id}", r.process, r.ns_per_test) for r in pp.itertuples(index=False)
    )


def test_the_context_carries_the_machine_record(run_dir, document):
    run = json.loads((run_dir / runfolder.RUN).read_text())
    context, machine = document["context"], run["machine"]
    assert context["machine.cpu_model"] == machine["cpu_model"]
    assert json.loads(context["machine.build"]) == machine["build"]
    assert set(context) >= {f"machine.{k}" for k in machine}
    assert context["num_cpus"] == machine["logical_cpus"] and context["run_id"] == run["run_id"]
    assert context["baseline"] == "moller_seed"
    levels = {c["level"] for c in context["caches"]}
    assert levels == {int(k[1]) for k in machine["caches"]}


def test_an_undefined_interval_is_left_out_not_written_as_nan(run_dir):
    from tribench.reports.rundata import load_run

    data = load_run(run_dir)
    tables = dict(data.tables)
    est = tables[runfolder.ESTIMATES].copy()
    est.loc[0, ["ns_per_test_ci_low", "ns_per_test_ci_high", "ns_per_test_sd"]] = math.nan
    tables[runfolder.ESTIMATES] = est
    doc = export.google_benchmark(data.run, tables, data.baseline, {"value": 0.01, "source": "test"})
    name = f"{est.loc[0, 'kernel']}/{est.loc[0, 'workload_id']}"
    mean = next(b for b in doc["benchmarks"] if b["name"] == f"{name}_mean")
    assert "ci_low" not in mean and "ci_high" not in mean and "bootstrap_low" in mean
    assert not any(b["name"] == f"{name}_stddev" for b in doc["benchmarks"])
    assert VALIDATOR.is_valid(json.loads(export.dumps(doc)))


# ------------------------------------------------------------------ the command


@pytest.mark.slow
def test_tribench_export_prints_what_the_analysis_wrote(run_dir, tmp_path):
    proc = _tribench("export", str(run_dir))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == (run_dir / runfolder.GOOGLE_BENCHMARK).read_text()
    out = tmp_path / "sub" / "gbench.json"
    proc = _tribench("export", str(run_dir), "--out", str(out))
    assert proc.returncode == 0 and proc.stdout == "" and f"wrote {out}" in proc.stderr
    assert VALIDATOR.is_valid(json.loads(out.read_text()))


@pytest.mark.slow
def test_tribench_export_refuses_stale_tables_in_one_line(run_dir, tmp_path):
    stale = tmp_path / "stale"
    shutil.copytree(run_dir, stale)
    record = json.loads((stale / runfolder.ANALYSIS).read_text())
    record["batches_sha256"] = "0" * 64  # the tables were made from another batches.csv
    (stale / runfolder.ANALYSIS).write_text(json.dumps(record))
    proc = _tribench("export", str(stale))
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and f"tribench stats {stale}" in proc.stderr
