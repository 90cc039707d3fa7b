"""In a BVH: traversals.csv (counts and null-leaf times per batch), bvh.csv, the report's section,
and Baldwin & Weber's end-to-end claim as the report states it."""

from __future__ import annotations

import math
import shutil
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest
from conftest import analysed
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.common import UserError
from tribench.harness import runfolder, runner
from tribench.harness.plan import Sweep
from tribench.reports import bvh as report_bvh
from tribench.reports import html as report_html
from tribench.reports.rundata import load_run
from tribench.reports.tables import bvh as bvh_tables
from tribench.workloads import cache
from tribench.workloads.spec import MeshSpec, PairSpec, workload_id

pytestmark = pytest.mark.slow  # small runs with a BVH workload, measured and reported: CI runs it

SMALL = {"mesh": "suzanne", "triangles": 200, "width": 16, "height": 16, "dtype": "float32"}
KERNELS = ("moller_trumbore_fma", "baldwin_weber_12_fma")
BVH_SPEC = MeshSpec(**SMALL, accel="bvh")
BRUTE_SPEC = MeshSpec(**SMALL)


def _run(tmp_path_factory, name: str, sweep: Sweep):
    base = tmp_path_factory.mktemp(name)
    run_dir = base / "run"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(base / "cache"))
        runner.start(sweep, run_dir, progress=False)
        # an empty robustness table: the analysis does not run the suite (its own tests do)
        pd.DataFrame(columns=list(runfolder.FILES[runfolder.VALIDATE])).to_csv(run_dir / "validate.csv", index=False)
        analysed(run_dir)
    return run_dir, base / "cache"


@pytest.fixture(scope="module")
def bvh_run(tmp_path_factory):
    """Two native kernels on a BVH workload and on its brute-force twin: 3 processes x 3 rounds (+1 warm-up)
    (medians of 3: one batch the loaded machine stalled cannot move a process's value)."""
    sweep = Sweep(KERNELS, (BRUTE_SPEC, BVH_SPEC), processes=3, rounds=3, warmup=1, target_ms=0.2, rng_seed=3)
    run_dir, cache_dir = _run(tmp_path_factory, "bvh-run", sweep)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache_dir))
        yield run_dir


@pytest.fixture(scope="module")
def brute_run(tmp_path_factory):
    sweep = Sweep(("moller_trumbore",), (PairSpec(n=200, hit_rate=0.5),), processes=2, rounds=1, target_ms=0.2)
    run_dir, _ = _run(tmp_path_factory, "brute-run", sweep)
    return run_dir


def _per_pass_counts(kernel: str) -> np.ndarray:
    w = cache.make(BVH_SPEC)
    return ext.build_bvh(kernel, w.triangles).intersect(w.origins, w.directions).counts.sum(axis=0)


# ------------------------------------------------------------------ traversals.csv


def test_every_bvh_batch_has_its_traversal_with_its_counts_and_a_null_twin(bvh_run):
    batches = runfolder.read_batches(bvh_run)
    trav = runfolder.read_traversals(bvh_run)
    assert list(trav.columns) == list(runfolder.FILES[runfolder.TRAVERSALS])
    key = ["process", "workload_id", "round", "position", "kernel"]
    on_bvh = batches.loc[batches["workload_id"] == workload_id(BVH_SPEC)]
    assert sorted(map(tuple, trav[key].to_numpy())) == sorted(map(tuple, on_bvh[key].to_numpy()))
    joined = trav.merge(on_bvh, on=key, suffixes=("", "_batch"))
    rays = 16 * 16
    assert (joined["rays"] == joined["loops"] * rays).all()
    assert (joined["triangle_tests"] == joined["tests"]).all()  # batches.csv's tests are the traversal's
    for kernel, g in joined.groupby("kernel"):
        nodes, boxes, leaves, tris = _per_pass_counts(kernel)
        assert (g["nodes"] == g["loops"] * nodes).all() and (g["box_tests"] == g["loops"] * boxes).all()
        assert (g["leaves"] == g["loops"] * leaves).all() and (g["triangle_tests"] == g["loops"] * tris).all()
    # t_max at each ray's own hit: the null traversal enters no node the real one does not
    assert (joined["null_nodes"] <= joined["nodes"]).all() and (joined["null_nodes"] > 0).all()
    assert set(joined["null_first"]) == {True, False}  # the order is random, batch by batch


def test_a_run_without_a_bvh_workload_has_an_empty_traversals_file_and_bvh_table(brute_run):
    assert (brute_run / runfolder.TRAVERSALS).read_text() == ",".join(runfolder.FILES[runfolder.TRAVERSALS]) + "\n"
    assert runfolder.read_traversals(brute_run).empty
    bvh = pd.read_csv(brute_run / runfolder.BVH)
    assert bvh.empty and list(bvh.columns) == list(runfolder.FILES[runfolder.BVH])


def test_a_bad_traversal_row_is_refused_naming_its_line(bvh_run, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(bvh_run, copy)
    lines = (copy / runfolder.TRAVERSALS).read_text().splitlines()
    fields = lines[2].split(",")
    fields[list(runfolder.FILES[runfolder.TRAVERSALS]).index("null_elapsed_ns")] = "-5"
    lines[2] = ",".join(fields)
    (copy / runfolder.TRAVERSALS).write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match=r"traversals\.csv:3: null_elapsed_ns is -5; must be positive"):
        runfolder.read_traversals(copy)


# ------------------------------------------------------------------ bvh.csv


def test_bvh_table_has_rates_counts_a_leaf_share_in_0_1_and_both_speedups(bvh_run):
    bvh = pd.read_csv(bvh_run / runfolder.BVH)
    assert list(bvh.columns) == list(runfolder.FILES[runfolder.BVH])
    assert list(bvh["kernel"]) == list(KERNELS) and set(bvh["workload_id"]) == {workload_id(BVH_SPEC)}
    assert (bvh["n_processes"] == 3).all()
    assert (bvh["rays_per_s_ci_low"] < bvh["rays_per_s"]).all() and (
        bvh["rays_per_s"] < bvh["rays_per_s_ci_high"]
    ).all()
    assert ((0 < bvh["leaf_share"]) & (bvh["leaf_share"] < 1)).all()
    assert (bvh["leaf_share_ci_low"] <= bvh["leaf_share"]).all() and (
        bvh["leaf_share"] <= bvh["leaf_share_ci_high"]
    ).all()
    for r in bvh.itertuples():
        nodes, boxes, leaves, tris = _per_pass_counts(r.kernel) / (16 * 16)
        assert (r.nodes_per_ray, r.box_tests_per_ray, r.leaves_per_ray, r.triangle_tests_per_ray) == pytest.approx(
            (nodes, boxes, leaves, tris)
        )
        assert r.null_nodes_per_ray <= r.nodes_per_ray
    base, other = bvh.iloc[0], bvh.iloc[1]
    assert base["baseline"] == other["baseline"] == "moller_trumbore_fma" and base["verdict"] == "baseline"
    assert (base["speedup"], base["brute_speedup"]) == (1.0, 1.0)
    assert other["brute_workload_id"] == workload_id(BRUTE_SPEC)
    for name in ("speedup", "brute_speedup"):
        assert other[f"{name}_ci_low"] < other[name] < other[f"{name}_ci_high"]
    assert other["verdict"] in ("faster", "slower", "equivalent", "inconclusive")


def test_a_run_made_before_traversals_csv_gets_rates_and_speedups_without_counts_or_share(bvh_run, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(bvh_run, copy)
    (copy / runfolder.TRAVERSALS).unlink()
    analysed(copy)
    bvh = pd.read_csv(copy / runfolder.BVH)
    assert list(bvh["kernel"]) == list(KERNELS) and bvh["rays_per_s"].notna().all()
    assert bvh[["nodes_per_ray", "leaf_share", "leaf_share_ci_low"]].isna().all().all()
    assert "–" in report_bvh.bvh_section(bvh, None, {})  # the share shown as none, not as nan


def _frames(null_over_real: list[list[float]]):
    """batches and traversals of one BVH kernel: per process, batches whose null/real ratio is given."""
    spec = MeshSpec(**SMALL, accel="bvh")
    wid = workload_id(spec)
    rows, trav = [], []
    for p, ratios in enumerate(null_over_real):
        for rnd, ratio in enumerate(ratios):
            key = {"process": p, "workload_id": wid, "round": rnd, "position": 0, "kernel": KERNELS[0]}
            rows.append({**key, "warmup": False, "loops": 2, "tests": 1000, "elapsed_ns": 10_000})
            trav.append(
                {**key, "attempt": 0, "warmup": False, "rays": 512, "nodes": 5120, "box_tests": 9000, "leaves": 700}
                | {"triangle_tests": 1000, "null_elapsed_ns": round(10_000 * ratio), "null_nodes": 4000}
            )
    wl = pd.DataFrame(
        [{"workload_id": wid, "family": "f", "label": "l", "dtype": "float32", "triangles": 200, "rays": 256}]
    )
    batches = pd.DataFrame(rows)
    pp = (
        batches.assign(ns_per_test=batches["elapsed_ns"] / batches["tests"])
        .groupby(["kernel", "workload_id", "process"], as_index=False)["ns_per_test"]
        .median()
    )
    return batches, pd.DataFrame(trav), wl, {wid: spec.to_dict()}, pp


def test_the_leaf_share_is_one_minus_the_per_process_median_null_over_real_ratio():
    batches, trav, wl, specs, pp = _frames([[0.6, 0.6, 0.9], [0.6, 0.5, 0.6], [0.1, 0.6, 0.6]])  # medians 0.6
    row = bvh_tables.bvh_table(batches, trav, wl, specs, pp, KERNELS, "moller_seed", 0.01).iloc[0]
    assert row["leaf_share"] == pytest.approx(0.4)
    assert row["leaf_share_ci_low"] == pytest.approx(0.4) and row["leaf_share_ci_high"] == pytest.approx(0.4)
    assert row["rays_per_s"] == pytest.approx(512 / 10_000 * 1e9)  # loops x rays / elapsed
    assert (row["nodes_per_ray"], row["null_nodes_per_ray"]) == (10.0, 4000 / 512)
    assert row["baseline"] == KERNELS[0] and row["brute_workload_id"] == ""  # no twin in this run


@settings(max_examples=30, deadline=None)
@given(st.lists(st.lists(st.floats(0.05, 0.95), min_size=1, max_size=4), min_size=2, max_size=5))
def test_the_leaf_share_and_its_interval_lie_in_0_1_and_in_order(ratios):
    batches, trav, wl, specs, pp = _frames(ratios)
    row = bvh_tables.bvh_table(batches, trav, wl, specs, pp, KERNELS, "moller_seed", 0.01).iloc[0]
    medians = [float(np.median([round(10_000 * r) / 10_000 for r in p])) for p in ratios]
    assert row["leaf_share"] == pytest.approx(1 - math.exp(np.mean(np.log(medians))))
    assert 0 < row["leaf_share"] < 1
    assert row["leaf_share_ci_low"] <= row["leaf_share"] + 1e-12 <= row["leaf_share_ci_high"] + 2e-12


def test_the_bvh_baseline_is_the_runs_baseline_or_a_form_of_its_algorithm_or_moller_trumbores():
    assert bvh_tables.bvh_baseline(["woop_fma", "moller_trumbore_fma"], "woop_fma") == "woop_fma"
    assert bvh_tables.bvh_baseline(["woop_fma", "moller_trumbore_fma"], "woop") == "woop_fma"
    assert bvh_tables.bvh_baseline(["woop_fma", "moller_trumbore_fma"], "moller_seed") == "moller_trumbore_fma"
    assert bvh_tables.bvh_baseline(["woop_fma", "baldwin_weber_9_fma"], "moller_seed") == "woop_fma"


# ------------------------------------------------------------------ the report


class _Ids(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: list[str] = []
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.append(a["id"])
        if tag == "a" and str(a.get("href", "")).startswith("#"):
            self.links.append(a["href"][1:])


def _ids(text: str) -> _Ids:
    p = _Ids()
    p.feed(text)
    return p


def test_the_report_has_an_in_a_bvh_section_after_size_and_working_set(bvh_run):
    text = report_html.render(load_run(bvh_run))
    parsed = _ids(text)
    sections = [i for i in parsed.ids if i in report_html.SECTIONS or i == "bvh"]
    expected = list(report_html.SECTIONS)
    expected.insert(expected.index("scaling") + 1, "bvh")
    assert sections == expected and "bvh" in parsed.links
    body = text[text.index('<section id="bvh">') : text.index('<section id="peers">')]
    assert "<h2>In a BVH</h2>" in body and "baldwin_weber_12_fma" in body and "rays/s [95% CI]" in body
    assert body.count("vegaEmbed(") == 1 and 'id="chart-bvh"' in body  # one chart
    # the claim, answered on the run's BVH workload (moller_trumbore_fma is the baseline there)
    assert "Baldwin &amp; Weber&#x27;s end-to-end claim" in body and "the claim " in body


def test_the_report_has_no_bvh_section_without_a_bvh_workload(brute_run):
    parsed = _ids(report_html.render(load_run(brute_run)))
    assert "bvh" not in parsed.ids and "bvh" not in parsed.links
    assert [i for i in parsed.ids if i in report_html.SECTIONS] == list(report_html.SECTIONS)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.8, 1.2), st.floats(0.0, 0.2))
def test_the_claim_holds_exactly_when_the_interval_shows_a_gain_reaching_1_to_6_percent(low, width):
    high = low + width
    answer = report_bvh.claim_answer(low, high)
    least, most = report_bvh.CLAIM
    assert (answer == "holds here") == (1 < low <= most and high >= least)
    assert answer.startswith("does not hold") == (high < least)
    assert answer.startswith("is exceeded") == (low > most)


def test_against_embree_names_the_packet_walks_ratio_to_rtcintersect16():
    from tribench.reports.rundata import PeerTables

    frame = pd.DataFrame({"kernel": ["moller_trumbore_fma"], "workload": ["mesh-x (suzanne 250,000)"]})
    bvh = "tribench 0.1.0 bvh moller_trumbore_fma (x16 avx2)"
    contenders = [("tribench", bvh), ("tribench_packets", f"{bvh}, packets of 16 rays"), ("embree", "Embree 1")]
    contenders += [("embree_16", "Embree 16")]
    rates = pd.DataFrame(
        [
            {"contender": c, "implementation": i, "rays_per_s": 1e7, "ci_low": 9e6, "ci_high": 1.1e7}
            | {"n_processes": 5, "setup_ms": 1.0}
            for c, i in contenders
        ]
    )
    ratio = {"ratio": 1.14, "ci_low": 1.11, "ci_high": 1.18, "n_processes": 5}
    ratios = pd.DataFrame(
        [{"contender": "tribench", "over": o} | ratio for o in ("embree", "embree_16")]
        + [{"contender": "tribench_packets", "over": "embree_16"} | ratio]
    )
    html = report_bvh._embree(PeerTables(frame, rates, ratios))
    assert "Walked by packets of 16 rays" in html and "1.14× [1.11, 1.18] Embree" in html
    assert html.count("tribench_packets") == 1  # its row in the table
    html = report_bvh._embree(PeerTables(frame, rates, ratios[ratios["contender"] == "tribench"]))
    assert "Walked by packets" not in html  # a run made before the packet walk says nothing of it
