"""The measured robustness beside the speed: ranking.csv and bands.csv from a synthetic validate.csv.

The first screen once showed broken promises, 0 for every kernel by design; these tests hold its
tables and chart to what the suite measured, joined on kernel and precision, and keep the promises
in the robustness section.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from tribench.reports import checks, page, speed_charts
from tribench.reports import ranking as report_ranking
from tribench.reports.tables import ranking

KERNELS = ("moller_trumbore", "baldwin_weber_12", "woop")
DTYPES = ("float32", "float64")
# failures per test, kernel and dtype; every figure different, so a join on the kernel alone, on the
# dtype alone or on the wrong test shows
FAILURES = {
    ("shared_edges", "moller_trumbore", "float32"): 632,
    ("shared_edges", "baldwin_weber_12", "float32"): 1765,
    ("shared_edges", "woop", "float32"): 0,
    ("shared_edges", "moller_trumbore", "float64"): 3,
    ("shared_edges", "baldwin_weber_12", "float64"): 411,
    ("shared_edges", "woop", "float64"): 0,
    ("inside_sphere", "moller_trumbore", "float32"): 0,
    ("inside_sphere", "baldwin_weber_12", "float32"): 2300,
    ("inside_sphere", "woop", "float32"): 2,
    ("inside_sphere", "moller_trumbore", "float64"): 7,
    ("inside_sphere", "baldwin_weber_12", "float64"): 0,
    ("inside_sphere", "woop", "float64"): 0,
}
RAYS = {"shared_edges": 20_000, "inside_sphere": 50_000, "parallel_rays": 1000}


def _validate() -> pd.DataFrame:
    """validate.csv's rows for KERNELS at DTYPES; one promise judged per row set, none broken but woop's
    float32 sphere (2 in 50,000 is above Embree's 0.002%)."""
    rows = []
    for (test, kernel, dtype), failures in FAILURES.items():
        verdict = "measured"
        if kernel == "woop":
            verdict = "fail" if failures / RAYS[test] > 2e-5 else "pass"
        rows.append((kernel, dtype, test, RAYS[test], failures, verdict))
    for kernel in KERNELS:
        for dtype in DTYPES:
            rows.append((kernel, dtype, "parallel_rays", RAYS["parallel_rays"], 0, "pass"))
    frame = pd.DataFrame(rows, columns=["kernel", "dtype", "test", "rays", "failures", "verdict"])
    return frame.assign(isa="scalar", rate=frame["failures"] / frame["rays"], expected="-", detail="-")


def _timings() -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(est, spd, pp): one pair workload per dtype, 4 processes, the kernels 1, 2 and 3 ns apart."""
    est, spd, pp = [], [], []
    rng = np.random.default_rng(3)
    for dtype in DTYPES:
        wid = f"pairs-{dtype}"
        for i, kernel in enumerate(KERNELS):
            ns = 1.0 + i + 0.01 * rng.standard_normal(4)
            pp += [(wid, p, kernel, v) for p, v in enumerate(ns)]
            est.append((wid, kernel, ns.mean(), ns.mean() * 0.99, ns.mean() * 1.01, dtype))
            spd.append((wid, kernel, 1.0 / (1 + i), 0.9 / (1 + i), 1.1 / (1 + i), "moller_trumbore"))
    workload = {"family": "pairs", "label": "hit rate 0.5", "kind": "pairs", "test_hit_rate": 0.5}
    est_f = pd.DataFrame(
        est, columns=["workload_id", "kernel", "ns_per_test", "ns_per_test_ci_low", "ns_per_test_ci_high", "dtype"]
    ).assign(**workload)
    spd_f = pd.DataFrame(spd, columns=["workload_id", "kernel", "ratio", "ratio_ci_low", "ratio_ci_high", "baseline"])
    spd_f = spd_f.loc[spd_f["kernel"] != "moller_trumbore"]  # the baseline has no speedup over itself
    return est_f, spd_f, pd.DataFrame(pp, columns=["workload_id", "process", "kernel", "ns_per_test"])


def _want(test: str, kernel: str, dtype: str) -> float:
    return 1e6 * FAILURES[(test, kernel, dtype)] / RAYS[test]


@pytest.fixture(scope="module")
def tables():
    est, spd, pp = _timings()
    val = _validate()
    rank = ranking.ranking_table(est, spd, pp, 0.01, val)
    bands = ranking.band_table(est, pp, {}, "moller_trumbore", 0.01, val)
    return rank, bands, val


@pytest.mark.parametrize("which", [0, 1])
def test_the_tables_carry_the_measured_rates_of_each_kernel_at_its_precision(tables, which):
    frame = tables[which]  # ranking.csv, then bands.csv
    assert len(frame) == len(KERNELS) * len(DTYPES)
    for r in frame.itertuples(index=False):
        assert r.cracks_per_million == pytest.approx(_want("shared_edges", r.kernel, r.dtype))
        assert r.sphere_misses_per_million == pytest.approx(_want("inside_sphere", r.kernel, r.dtype))
        assert (r.shared_edge_rays, r.sphere_rays) == (RAYS["shared_edges"], RAYS["inside_sphere"])
    # differing figures stay different: one value per (kernel, dtype), as validate measured them
    cracks = frame.set_index(["kernel", "dtype"])["cracks_per_million"]
    assert cracks[("baldwin_weber_12", "float32")] == pytest.approx(88_250)
    assert cracks[("moller_trumbore", "float32")] == pytest.approx(31_600)
    assert cracks[("moller_trumbore", "float64")] == pytest.approx(150)
    assert cracks.nunique() == 5  # woop has 0 at both precisions


def test_the_promises_stay_in_bands_csv_and_out_of_ranking_csv(tables):
    rank, bands, _ = tables
    assert "broken_promises" not in rank and "promises_checked" not in rank
    woop = bands.set_index(["kernel", "dtype"]).loc["woop"]
    assert list(woop["promises_checked"]) == [3, 3] and list(woop["broken_promises"]) == [1, 0]


def test_without_validate_the_rates_are_missing_not_zero():
    est, spd, pp = _timings()
    rank = ranking.ranking_table(est, spd, pp, 0.01)
    assert rank["cracks_per_million"].isna().all() and rank["sphere_rays"].isna().all()
    partial = _validate().query("dtype == 'float32'")  # validated at one precision only
    bands = ranking.band_table(est, pp, {}, "moller_trumbore", 0.01, partial)
    by_dtype = bands.groupby("dtype")["cracks_per_million"]
    assert by_dtype.apply(lambda s: s.notna().all())["float32"]
    assert by_dtype.apply(lambda s: s.isna().all())["float64"]
    assert report_ranking.band_rows(bands).set_index("dtype").loc["float64", "cracks"] == "not validated"


def test_the_first_table_shows_the_fastest_kernels_measured_rates(tables):
    _, bands, _ = tables
    shown = report_ranking.band_rows(bands).set_index("dtype")
    # moller_trumbore is the fastest in both bands: its figures, which differ between precisions
    assert shown.loc["float32", "cracks"] == "31,600 (20,000 rays)"
    assert shown.loc["float64", "cracks"] == "150 (20,000 rays)"
    assert shown.loc["float64", "sphere"] == "140 (50,000 rays)"
    slow = bands.assign(ns_per_test=bands["ns_per_test"].where(bands["kernel"] != "moller_trumbore", 99.0))
    again = report_ranking.band_rows(slow.assign(rank=slow.groupby("dtype")["ns_per_test"].rank()))
    assert again.set_index("dtype").loc["float32", "cracks"] == "88,250 (20,000 rays)"  # baldwin_weber_12


def test_the_chart_height_is_the_measured_rate(tables):
    _, bands, _ = tables
    spec = speed_charts.answer_chart(bands, dict.fromkeys(KERNELS, "#000")).to_dict()
    values = spec["datasets"][spec["data"]["name"]] if "datasets" in spec else spec["data"]["values"]
    got = {(d["where"].split(" · ")[0], d["kernel"]): d["failures_per_million"] for d in values}
    want = {
        (dtype, k): _want("shared_edges", k, dtype) + _want("inside_sphere", k, dtype)
        for k in KERNELS
        for dtype in DTYPES
    }
    assert got == pytest.approx(want)
    y = spec["layer"][1]["encoding"]["y"]
    assert (y["field"], y["scale"]["type"]) == ("failures_per_million", "symlog")
    assert "per million rays" in y["title"] and "symlog" in y["title"]


def test_the_promises_column_is_in_the_robustness_section(tables):
    *_, val = tables
    text = checks.robustness_section(val, "synthetic")
    header = re.findall(r"<th[^>]*>(.*?)</th>", text)
    assert "promises (validate)" in header
    kept = checks.promises_kept(val)
    rows = {(k, d): cell for k, d, cell in kept[["kernel", "dtype", "promises"]].itertuples(index=False)}
    assert rows[("woop", "float32")] == "1 of 3 broken" and rows[("woop", "float64")] == "0 of 3 broken"
    assert rows[("moller_trumbore", "float32")] == "0 of 1 broken"
    assert "1 of 3 broken" in text


def test_the_headers_say_what_the_rates_count(tables):
    _, bands, _ = tables
    html = report_ranking.band_rows(bands)
    assert set(report_ranking.ROBUSTNESS_TIPS) <= set(html.columns)
    tips = report_ranking.ROBUSTNESS_TIPS
    assert "shared_edges" in tips["cracks"] and "inside_sphere" in tips["sphere"]
    table = page.table(html, [("cracks", "cracks"), ("sphere", "sphere")], titles=tips)
    assert re.findall(r'<th title="([^"]*)">', table)[0].startswith("tribench validate&#x27;s shared_edges")


def test_on_a_workload_the_baseline_did_not_run_no_kernel_is_the_baseline():
    """A BVH workload runs no moller_seed: ranking.csv once named each kernel its own baseline at 1.00x there,
    and the report's ranking per workload called the fastest '(the baseline)'."""
    est, spd, pp = _timings()
    gone = "pairs-float64"  # as a BVH workload: the baseline did not run it, so it has no speedups
    est = est.loc[~((est["workload_id"] == gone) & (est["kernel"] == "moller_trumbore"))]
    pp = pp.loc[~((pp["workload_id"] == gone) & (pp["kernel"] == "moller_trumbore"))]
    spd = spd.loc[spd["workload_id"] != gone]
    rank = ranking.ranking_table(est, spd, pp, 0.01, baseline="moller_trumbore")
    there = rank.loc[rank["workload_id"] == gone]
    assert set(rank["baseline"]) == {"moller_trumbore"}
    assert there["speedup"].isna().all()
    fastest = report_ranking.ranking_rows(rank).set_index("dtype").loc["float64"]
    assert fastest["fastest"] == "baldwin_weber_12" and fastest["speedup"] == "–"
