"""Every ranking compares equal work: a kernel is ranked on a workload only where its answers are the reference's.

A back-face-culling kernel on randomly wound pairs rejects about half the
tests at its first comparison and returns about half the hits: its time is of
other work. On pairs wound to face their rays it does every test the others do.
"""

from __future__ import annotations

import re

import pandas as pd
import pytest
from conftest import analysed

from tribench.harness import plan, runfolder, runner
from tribench.harness.plan import Sweep
from tribench.reports import write_report
from tribench.reports.tables.workload_tables import agreeing
from tribench.workloads.spec import PairSpec, workload_id

CULL = "moller_trumbore_cull"
RANDOM, FACING = PairSpec(n=400, hit_rate=0.5, rng_seed=3), PairSpec(n=400, hit_rate=0.5, rng_seed=3, winding="facing")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    base = tmp_path_factory.mktemp("equal-work")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(base / "cache"))
        sweep = Sweep(("moller_seed", "moller_trumbore", CULL), (RANDOM, FACING), processes=3, rounds=2, target_ms=0.2)
        runner.start(sweep, base / "run", progress=False)
        analysed(base / "run", quick=True)
        write_report(base / "run")
        yield base / "run"


@pytest.mark.slow
def test_a_kernel_whose_answers_differ_is_measured_but_ranked_nowhere(run):
    correct = pd.read_csv(run / runfolder.CORRECTNESS).set_index(["workload_id", "kernel"])
    random_id, facing_id = workload_id(RANDOM), workload_id(FACING)
    assert not correct.loc[(random_id, CULL), "agrees"] and correct.loc[(facing_id, CULL), "agrees"]
    estimates = pd.read_csv(run / runfolder.ESTIMATES)
    assert {(random_id, CULL), (facing_id, CULL)} <= set(
        zip(estimates["workload_id"], estimates["kernel"], strict=True)
    )
    ranking = pd.read_csv(run / runfolder.RANKING)
    assert (random_id, CULL) not in set(zip(ranking["workload_id"], ranking["kernel"], strict=True))
    assert (facing_id, CULL) in set(
        zip(ranking["workload_id"], ranking["kernel"], strict=True)
    )  # the same work: ranked
    # both workloads make one band (pairs at 50%): a kernel that differs on one of them is not in it
    bands = pd.read_csv(run / runfolder.BANDS)
    assert list(bands["workloads"].unique()) == [2] and CULL not in set(bands["kernel"])


@pytest.mark.slow
def test_the_first_screen_names_it_only_to_say_it_is_left_out(run):
    page = (run / "report.html").read_text(encoding="utf-8")
    answer = re.search(r'<section id="answer">(.*?)</section>', page, re.S)
    assert answer and "pairs, hit rate 35–65%" in answer.group(1)  # the band's table and chart are there
    warnings = re.findall(r'<div class="warn">.*?</div>', answer.group(1), re.S)
    assert any(CULL in w for w in warnings)
    assert CULL not in re.sub(r'<div class="warn">.*?</div>', "", answer.group(1), flags=re.S)  # table, chart, legend


@pytest.mark.slow
def test_random_and_facing_pairs_are_two_families(run):
    families = pd.read_csv(run / runfolder.WORKLOADS).set_index("workload_id")["family"]
    assert families[workload_id(FACING)] == families[workload_id(RANDOM)].replace(" sphere ", " sphere facing ")
    assert families[workload_id(FACING)] != families[workload_id(RANDOM)]


@pytest.mark.slow
def test_the_report_says_which_kernel_it_left_out_and_why(run):
    page = (run / "report.html").read_text(encoding="utf-8")
    assert "Left out of every ranking, as doing other work than the reference asks: moller_trumbore_cull" in page
    assert "it culls back faces, so the tests it rejects at once are work it skipped, not speed" in page
    # the workload named so a reader tells it from its facing twin, which has the same hit rate
    assert f"Correctness: {CULL} on per-test hit rate 50% (pairs n=400 shuffled sphere float64) differs" in page
    # its own answer, as a share of the reference's hits: about half, the rays that meet a front face
    share = re.search(r"moller_trumbore_cull on [^:]*: [\d,]+ hits per pass of the reference&#x27;s 200, (\d+)%", page)
    assert share and 35 <= int(share.group(1)) <= 65


def test_agreeing_keeps_unknown_agreement_and_drops_only_the_differing_pairs():
    frame = pd.DataFrame({"workload_id": ["a", "a", "b", "c"], "kernel": ["k", "m", "k", "k"], "x": [1, 2, 3, 4]})
    correct = pd.DataFrame({"workload_id": ["a", "a", "b"], "kernel": ["k", "m", "k"], "agrees": [False, True, True]})
    assert list(agreeing(frame, correct)["x"]) == [2, 3, 4]  # c's agreement is unknown: kept


def test_the_main_job_times_every_pair_workload_facing_its_rays():
    for quick in (False, True):
        pairs = [w for w in plan.default_sweep(quick).workloads if isinstance(w, PairSpec)]
        assert pairs and all(w.winding == "facing" for w in pairs)
