"""tribench seed: the seed's ray stream as workloads, the per-render arithmetic, the command end to end."""

from __future__ import annotations

import json
import math
import re
import shutil
from html import escape

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from tribench import ext
from tribench.cli.command import main
from tribench.harness import runfolder
from tribench.harness.jobs import seed as hs
from tribench.reports import charts
from tribench.reports.tables import seed as seed_tables
from tribench.workloads import cache, reference
from tribench.workloads.kinds import spec_from_dict
from tribench.workloads.seed import workload as sw
from tribench.workloads.seed.scene import Scene, builtin_scene, builtin_scene_path
from tribench.workloads.seed.workload import ORIGIN_SHIFT, EmptyStream, SeedSpec
from tribench.workloads.spec import workload_id

# A tiny scene with every kind of ray: a reflective floor, a sphere, and a
# reflective tetrahedron-ish pair of triangles in front of the camera.
TINY = """\
fond 1 1 1
source -2 3 1  1 1 1
source 2 3 0  1 1 1
materiau 0.2 0.2 0.9  0.2 0.5 0.5 10
plan 0 1 0 1
materiau 0.9 0.2 0.2  0.2 0.5 0.3 50
sphere 0.6 0 -3 0.4
materiau 0.8 0.7 0.2  0.1 0.5 0.4 20
tri -1 -1 -2  0 1 -2.5  0 -1 -3
tri 0 -1 -3  0 1 -2.5  1 -1 -2
"""


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_spec_is_deterministic_round_trips_and_is_cached(cache_dir, tmp_path):
    spec = SeedSpec("scene02", "reflected", sample=40, width=16, height=16, rng_seed=3)
    assert spec_from_dict(spec.to_dict()) == spec and spec.mode == "closest"
    first = cache.generate(spec)
    sw._trace.cache_clear()  # trace the scene again: the same bytes
    assert cache.generate(spec).checksum() == first.checksum()
    made = cache.make(spec)
    assert (cache_dir / f"{workload_id(spec)}.npz").is_file()
    assert made.checksum() == first.checksum() == cache.make(spec).checksum()
    assert cache.load(workload_id(spec)).checksum() == first.checksum()
    assert any(c.workload_id == workload_id(spec) and c.problem is None for c in cache.list_cached())
    other = cache.generate(SeedSpec("scene02", "reflected", sample=40, width=16, height=16, rng_seed=4))
    assert other.checksum() != first.checksum()
    # a scene file is named by its content, not its path
    a, b = tmp_path / "a" / "mine.txt", tmp_path / "b" / "other.txt"
    for p in (a, b):
        p.parent.mkdir()
        shutil.copy(builtin_scene_path("scene02"), p)
    ids = {workload_id(SeedSpec(str(p), sample=10, width=8, height=8)) for p in (a, b)}
    assert len(ids) == 1
    b.write_text(b.read_text() + "sphere 0 0 -9 0.1\n")
    assert workload_id(SeedSpec(str(b), sample=10, width=8, height=8)) not in ids
    with pytest.raises(ValueError, match="unknown scene"):
        SeedSpec("scene99")
    with pytest.raises(ValueError, match="sample must be"):
        SeedSpec(sample=0)


def test_sample_sizes_seed_order_and_shifted_secondary_rays(cache_dir):
    # 10 x 10 primary rays: a sample larger than the stream takes all of them, in the seed's order
    w = cache.make(SeedSpec("scene02", "primary", sample=500, width=10, height=10))
    assert w.achieved["sample_rays"] == w.achieved["stream_rays"] == 100 == len(w.origins)
    tr = sw.stream_trace(SeedSpec("scene02", "primary", width=10, height=10))
    rows = sw.stream_indices(tr, "primary")
    assert np.array_equal(w.directions, tr.primary.directions[rows].astype(np.float32))
    assert (w.origins == np.float32(2.0) * np.array([0, 0, 1], np.float32)).all()  # the eye, not shifted
    assert w.achieved["stream_tests"] == w.achieved["tests"] == 100 * 12  # closest: rays x triangles

    small = cache.make(SeedSpec("scene02", "primary", sample=30, width=10, height=10))
    assert len(small.origins) == small.achieved["sample_rays"] == 30
    assert small.achieved["sample_tests"] == 30 * 12

    # reflected rays start 1e-4 along their direction from the hit point
    spec = SeedSpec("scene02", "reflected", sample=25, width=12, height=12, dtype="float64")
    w = cache.make(spec)
    tr = sw.stream_trace(spec)
    rs, rows = tr.reflected, sw.stream_indices(tr, "reflected")
    p, d = rs.origins[rows], rs.directions[rows]
    for o_i, d_i in zip(w.origins, w.directions, strict=True):
        j = np.argmin(np.abs(d - d_i).sum(axis=1))  # the stream ray this one was drawn from
        assert np.array_equal(d[j], d_i) and np.allclose(o_i, p[j] + ORIGIN_SHIFT * d_i, rtol=0, atol=1e-15)


def test_the_sample_is_runs_of_consecutive_rays_one_in_each_share_of_the_render():
    n, size, run = 100_000, 4096, sw.RUN_LENGTH
    rows = sw.sample_runs(n, size, np.random.default_rng(7))
    assert len(rows) == size and (np.diff(rows) > 0).all() and 0 <= rows[0] and rows[-1] < n
    shares = np.arange(size // run + 1) * n // (size // run)  # the render cut into one share per run
    run_of_row = np.arange(size) // run
    assert (np.searchsorted(shares, rows, side="right") - 1 == run_of_row).all()
    assert (np.diff(rows)[np.diff(run_of_row) == 0] == 1).all()  # consecutive within a run
    assert not np.array_equal(rows, sw.sample_runs(n, size, np.random.default_rng(8)))
    for n, size in [(200, 65), (1000, 999), (64, 10), (130, 130), (5, 9)]:  # short runs, tight fits, all rows
        rows = sw.sample_runs(n, size, np.random.default_rng(0))
        assert len(rows) == min(n, size) == len(np.unique(rows)) and 0 <= rows.min() and rows.max() < n


def test_shadow_rays_any_hit_no_t_max_and_exact_test_counts(cache_dir):
    spec = SeedSpec("scene02", "shadow", sample=60, width=14, height=14, dtype="float64")
    w = cache.make(spec)
    assert w.mode == "any" and w.t_max is None  # the seed's shadow rays have no upper bound on t
    tr = sw.stream_trace(spec)
    sh = tr.shadow
    rows = sw.stream_indices(tr, "shadow")
    # rays a sphere stops first never test the triangles
    assert w.achieved["stream_rays"] == int((sh.hit_kind != Scene.SPHERE).sum()) == len(rows) < len(sh)
    # the light is at t = 1 from the hit point, so at t = 1 - shift from the shifted origin
    lights = np.array([lt.position for lt in builtin_scene("scene02").lights])
    ends = w.origins + (1 - ORIGIN_SHIFT) * w.directions
    assert np.abs(ends[:, None, :] - lights[None]).max(axis=2).min(axis=1).max() < 1e-9
    # the stream's tests, counted by hand: every triangle up to the first hit, in file order
    tri = tr.scene.triangles
    o, d = sh.origins[rows] + ORIGIN_SHIFT * sh.directions[rows], sh.directions[rows]
    k = len(tri)
    hit = reference.intersect_pairs(np.repeat(o, k, 0), np.repeat(d, k, 0), np.tile(tri, (len(o), 1, 1))).hit
    hit = hit.reshape(len(o), k)
    by_hand = np.where(hit.any(axis=1), np.argmax(hit, axis=1) + 1, k).sum()
    assert w.achieved["stream_tests"] == by_hand < len(rows) * k
    mix = w.achieved["miss_mix"]
    assert math.isclose(sum(mix.values()), 1.0) and mix["beyond_t_max"] == 0.0
    assert sum(w.achieved["miss_counts"].values()) + w.achieved["test_hits"] == w.achieved["tests"]


def test_a_scene_without_reflections_has_no_reflected_stream(cache_dir, tmp_path):
    path = tmp_path / "matte.txt"
    path.write_text(
        TINY.replace("0.5 0.5 10", "0.5 0 10").replace("0.5 0.3 50", "0.5 0 50").replace("0.5 0.4 20", "0.5 0 20")
    )
    with pytest.raises(EmptyStream, match="no reflected rays"):
        cache.make(SeedSpec(str(path), "reflected", width=8, height=8))


def test_per_render_arithmetic_by_hand():
    # Two processes; kernel A costs 2 ns/test on primary and 4 on shadow in
    # process 0, 3 and 5 in process 1; B is 1 and 2, then 1 and 3.
    pp = pd.DataFrame(
        {
            "kernel": ["A"] * 4 + ["moller_seed"] * 4,
            "workload_id": ["p", "s"] * 4,
            "process": [0, 0, 1, 1] * 2,
            "ns_per_test": [2.0, 4.0, 3.0, 5.0, 1.0, 2.0, 1.0, 3.0],
            "tests_per_pass": [100, 40, 100, 40, 100, 40, 100, 40],
        }
    )
    workloads = {
        "p": {"scene": "s1", "stream_tests": 10_000, "sample_tests": 100},  # x100
        "s": {"scene": "s1", "stream_tests": 2_000, "sample_tests": 40},
    }  # x50
    per = seed_tables.render_per_process(pp, workloads)
    got = {(r.kernel, r.process): r.render_s * 1e9 for r in per.itertuples()}
    # A, process 0: 2*100*100 + 4*40*50 = 28000 ns; process 1: 3*100*100 + 5*40*50 = 40000
    assert got == pytest.approx(
        {("A", 0): 28_000, ("A", 1): 40_000, ("moller_seed", 0): 14_000, ("moller_seed", 1): 16_000}
    )
    table = seed_tables.render_table(per, {"s1": {"triangles": 12, "render_tests": 12_000, "paper": "scene03"}})
    a = table.set_index("kernel").loc["A"]
    mean, half = 34_000e-9, sps.t.ppf(0.975, 1) * np.std([28_000e-9, 40_000e-9], ddof=1) / math.sqrt(2)
    assert a["render_s"] == pytest.approx(mean)
    relative = half / mean  # a time's interval is on the log scale
    assert (a["render_s_ci_low"], a["render_s_ci_high"]) == pytest.approx(
        (mean * math.exp(-relative), mean * math.exp(relative))
    )
    d = np.log([28_000 / 14_000, 40_000 / 16_000])  # paired per process
    half = sps.t.ppf(0.975, 1) * d.std(ddof=1) / math.sqrt(2)
    assert a["ratio_to_moller_seed"] == pytest.approx(math.exp(d.mean()))
    assert a["ratio_to_moller_seed_ci_low"] == pytest.approx(math.exp(d.mean() - half))
    assert a["replay_ns_per_test"] == pytest.approx(mean / 12_000 * 1e9)
    m = table.set_index("kernel").loc["moller_seed"]
    assert m["ratio_to_moller_seed"] == 1.0 and m["paper_real_s"] == 57.970
    assert m["paper_user_ns_per_test"] == pytest.approx(55.691 / 12_000 * 1e9)
    assert math.isnan(a["paper_real_s"])
    # a process missing one ray kind is left out, not summed short
    assert len(seed_tables.render_per_process(pp.drop(index=[0]), workloads).query("kernel == 'A'")) == 1


def test_the_object_forms_are_set_beside_the_seeds_program_with_the_models_error():
    # the program's two forms over each other, and the paper's columns of the seed kernel each replays
    pp = pd.DataFrame(
        {
            "kernel": ["curless_seed_object"] * 3 + ["moller_seed_object"] * 3 + ["moller_seed"] * 3,
            "workload_id": ["p"] * 9,
            "process": [0, 1, 2] * 3,
            "ns_per_test": [50.0, 52.0, 51.0, 36.0, 37.0, 38.0, 12.0, 12.5, 12.2],
            "tests_per_pass": [100] * 9,
        }
    )
    per = seed_tables.render_per_process(pp, {"p": {"scene": "s1", "stream_tests": 1000, "sample_tests": 100}})
    table = seed_tables.render_table(
        per, {"s1": {"triangles": 968, "render_tests": 1000, "paper": "scene03"}}
    ).set_index("kernel")
    c, m, base = table.loc["curless_seed_object"], table.loc["moller_seed_object"], table.loc["moller_seed"]
    d = np.log(np.array([50.0, 52.0, 51.0]) / [36.0, 37.0, 38.0])
    assert c["ratio_baseline"] == "moller_seed_object" and base["ratio_baseline"] == "moller_seed"
    assert c["ratio_to_moller_seed"] == pytest.approx(math.exp(d.mean())) and m["ratio_to_moller_seed"] == 1.0
    assert c["paper_user_s"] == hs.PAPER["scene03"]["curless_seed"]["user"]  # the program's own figure
    assert c["paper_ratio_user"] == pytest.approx(94.305 / 55.691)
    e = hs.MODEL_ERROR
    assert c["predicted_s_low"] == pytest.approx(c["render_s_ci_low"] / (1 + e))
    assert c["predicted_s_high"] == pytest.approx(c["render_s_ci_high"] * (1 + e))
    assert c["predicted_ratio_low"] == pytest.approx(c["ratio_to_moller_seed_ci_low"] / (1 + e))
    assert c["predicted_ratio_high"] == pytest.approx(c["ratio_to_moller_seed_ci_high"] * (1 + e))
    assert math.isnan(base["predicted_s_low"]) and math.isnan(base["predicted_ratio_high"])  # arithmetic only


@pytest.mark.slow
def test_tribench_seed_quick_end_to_end_on_a_tiny_scene(cache_dir, tmp_path, capsys):
    scene = tmp_path / "tiny.txt"
    scene.write_text(TINY)
    out = tmp_path / "run"
    rc = main(
        ["seed", "--quick", "--scene", str(scene), "--out", str(out), "--size", "16", "--sample", "24", "--no-progress"]
    )
    assert rc == 0
    captured = capsys.readouterr()
    printed = captured.out
    assert "expected: about " in captured.err  # the seed states its duration before it starts
    assert captured.err.index("tracing tiny: expected about ") < captured.err.index("workload: ")
    assert " in all; for the sweep: about " in captured.err and "then the pictures and tables about" in captured.err
    assert f"report: {out / 'seed.html'}" in printed and "Curless / Moller: replay (curless_seed_object)" in printed
    for name in (
        "seed.csv",
        "seed_kinds.csv",
        "seed_workloads.csv",
        "seed_pictures.csv",
        "seed.html",
        "batches.csv",
        "estimates.csv",
        "tiny_curless_seed.png",
        "tiny_difference.png",
    ):
        assert (out / name).is_file(), name
    seed = pd.read_csv(out / "seed.csv")
    assert list(seed.columns) == list(hs.COLUMNS["seed.csv"])
    assert list(seed["kernel"]) == list(hs.seed_kernels()) and set(seed["scene"]) == {"tiny"}
    assert (seed["render_s"] > 0).all() and seed["paper_real_s"].isna().all()
    assert seed.set_index("kernel").loc["moller_seed", "ratio_to_moller_seed"] == 1.0
    kinds = pd.read_csv(out / "seed_kinds.csv")
    assert set(kinds["rays"]) == {"primary", "reflected", "shadow"}
    assert kinds.groupby("kernel")["render_share"].sum().round(9).eq(1.0).all()
    wl = pd.read_csv(out / "seed_workloads.csv")
    assert list(wl["rays"]) == ["primary", "reflected", "shadow", "render"]
    page = (out / "seed.html").read_text()
    assert "data:image/png;base64," in page and 'src="http' not in page and "<script src" not in page
    # the ratios chart: every kernel's ratio of seed.csv, the charts' library once in the page's head
    assert page.count(charts.library()) == 1 and page.index(charts.library()) < page.index("<body>")
    spec = json.loads(re.search(r'vegaEmbed\("#chart-seed",(\{.*?\}),\{actions', page).group(1))
    drawn = {r["kernel"]: r["ratio_to_moller_seed"] for v in spec["datasets"].values() for r in v if "text" in r}
    assert drawn == pytest.approx(dict(zip(seed["kernel"], seed["ratio_to_moller_seed"], strict=True)))
    for words in (
        "The table beside the paper",
        "per-test hit rate",
        "behind origin",
        "Machine and build",
        "tribench seed --scene",
        "Kernels: the seed's two, their clean scalar forms",
    ):
        assert escape(words) in page, words


def test_a_scene_past_the_triangle_bound_is_refused_before_it_is_parsed(cache_dir, tmp_path, capsys):
    from tribench.workloads.seed import scene as seed_scene

    scene = tmp_path / "huge.txt"
    # one more triangle line than the bound; only the last is malformed, so parsing would say so instead
    line = "tri -1 -1 -2  0 1 -2.5  0 -1 -3\n"
    scene.write_text("source 0 3 1 1 1 1\n" + line * seed_scene.MAX_TRIANGLES + "tri 1 2\n")
    assert main(["seed", "--quick", "--scene", str(scene), "--out", str(tmp_path / "run")]) == 2  # a usage error
    err = capsys.readouterr().err.strip()
    assert f"{seed_scene.MAX_TRIANGLES + 1:,} triangles, more than the {seed_scene.MAX_TRIANGLES:,}" in err
    assert len(err.splitlines()) == 1 and "Traceback" not in err and not (tmp_path / "run").exists()


def test_a_trace_forecast_past_the_bound_is_refused_before_the_trace(cache_dir, tmp_path, capsys, monkeypatch):
    scene = tmp_path / "tiny.txt"
    scene.write_text(TINY)
    monkeypatch.setattr(sw, "MAX_TRACE_S", 1e-9)  # every trace is then too long
    rc = main(["seed", "--quick", "--scene", str(scene), "--out", str(tmp_path / "run"), "--size", "16"])
    err = capsys.readouterr().err
    assert rc == 2 and "scene tiny: tracing its 16x16 render should take about" in err and "Traceback" not in err
    assert "workload: " not in err and not list(cache_dir.glob("**/*.npz"))  # nothing traced, nothing cached


def test_the_default_kernels_are_the_seeds_and_the_widest_form_of_every_two_sided_algorithm():
    names = ext.kernel_names()
    info = {k: ext.kernel_info(k) for k in ext.kernel_names(internal=True)}
    chosen = hs.seed_kernels()
    assert chosen[:6] == hs.FIRST_KERNELS and len(set(chosen)) == len(chosen)
    assert chosen[:2] == hs.PROGRAM and all(info[k].internal and info[k].seed_replay for k in hs.PROGRAM)
    assert not any(info[k].culls_back_faces for k in chosen)  # the seed's renders test both faces
    for k in names:
        kin = [c for c in names if info[c].algorithm == info[k].algorithm and not info[c].culls_back_faces]
        widest = max(info[c].lanes for c in kin) if kin else 0
        if k not in hs.FIRST_KERNELS and not info[k].culls_back_faces:
            assert (k in chosen) == (info[k].lanes == widest > 1), k
    public = [k for k in chosen if k not in hs.PROGRAM]
    assert {info[k].algorithm for k in public} == {info[k].algorithm for k in names if not info[k].culls_back_faces}
    every = hs.seed_kernels(all_kernels=True)
    assert every[:6] == hs.FIRST_KERNELS and sorted(every) == sorted([*names, *hs.PROGRAM])


@pytest.mark.slow
def test_all_kernels_times_every_kernel(cache_dir, tmp_path):
    scene = tmp_path / "tiny.txt"
    scene.write_text(TINY)
    out = tmp_path / "run"
    flags = ["--quick", "--all-kernels", "--scene", str(scene), "--size", "8", "--sample", "8", "--no-progress"]
    assert main(["seed", *flags, "--out", str(out)]) == 0
    assert list(pd.read_csv(out / "seed.csv")["kernel"].drop_duplicates()) == list(hs.seed_kernels(all_kernels=True))
    run = runfolder.read_run(out)
    assert run.seed_replay and run.seed_replay["all_kernels"] is True and "--all-kernels" in (run.command or "")
    assert "Kernels: every kernel" in (out / "seed.html").read_text()


def test_both_algorithms_images_differ_only_near_shared_edges(tmp_path):
    # tests/test_seed_trace.py checks this at full size on scene02; here the numbers tribench seed reports
    row = hs.make_pictures("scene02", "scene02", 512, tmp_path)
    assert row["differing_pixels"] == row["near_edge_pixels"] + row["last_bit_pixels"] + row["other_pixels"]
    assert 0 < row["differing_pixels"] < 1e-3 * 512 * 512 and row["other_pixels"] == 0
    for col in ("curless_seed_png", "moller_seed_png", "difference_png"):
        assert (tmp_path / row[col]).stat().st_size > 500
