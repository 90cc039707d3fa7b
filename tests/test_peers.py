"""Peers (tribench.harness.jobs.peers): the statistics, a real tiny measurement, the report's section, the CLI."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import analysed
from test_report_run import run_fixture_dir

from tribench import reports
from tribench.ext import embree
from tribench.harness import runfolder, stats
from tribench.harness.jobs import peers
from tribench.reports import results
from tribench.reports import tables as analysis
from tribench.reports.rundata import load_peers, load_run
from tribench.reports.tables.peers import summarise

TINY = peers.PeerDesign(
    width=24, height=24, triangles=100, processes=2, reps=2, trimesh_rays=128, choice_rays=128, choice_rounds=1
)
INSTALLED = [p for p, v in peers.available().items() if v is not None]
#: The contenders the installed peers time (native Embree is four).
CONTENDERS = [c for p in INSTALLED for c in (peers.NATIVE_EMBREE if p == "embree" else (p,))]
needs_a_peer = pytest.mark.skipif(not INSTALLED, reason="no peer installed (pip install 'tribench[peers]')")


def _rows(rates: dict[str, list[float]], reps: int = 2) -> pd.DataFrame:
    """peers.csv rows with given rays/s per process (the same in every repetition)."""
    rows = []
    for contender, per_process in rates.items():
        for process, rate in enumerate(per_process):
            for rep in range(reps):
                rows.append(
                    {
                        "process": process,
                        "rep": rep,
                        "position": 0,
                        "contender": contender,
                        "implementation": contender,
                        "kernel": "k",
                        "workload_id": "w",
                        "workload": "camera",
                        "rays": 1000,
                        "elapsed_ns": int(1e12 / rate),
                        "wall_ns": int(1e12 / rate),
                        "cpu_ns": int(1e12 / rate),
                        "rays_per_s": rate,
                        "setup_ns": 5_000_000,
                        "differ": 0,
                        "differ_ambiguous": 0,
                        "cpu": 1,
                    }
                )
    return pd.DataFrame(rows, columns=list(peers.COLUMNS))


def test_summary_gives_geometric_means_and_ratios_paired_by_process():
    frame = _rows(
        {"tribench": [100.0, 200.0, 400.0], "trimesh": [10.0, 20.0, 40.0], "embree": [1000.0, 1000.0, 1000.0]}
    )
    rates, ratios = summarise(frame)
    assert list(rates["contender"]) == ["tribench", "embree", "trimesh"]
    tb = rates.set_index("contender").loc["tribench"]
    assert tb["rays_per_s"] == pytest.approx(200.0) and tb["ci_low"] < 200.0 < tb["ci_high"]
    assert tb["n_processes"] == 3 and tb["cpu_share"] == pytest.approx(1.0) and tb["setup_ms"] == pytest.approx(5.0)
    r = ratios.set_index(["contender", "over"])
    # exactly 10x faster than trimesh in every process: paired, the interval has no width
    assert r.loc[("tribench", "trimesh"), "ratio"] == pytest.approx(10.0)
    assert r.loc[("tribench", "trimesh"), "ci_low"] == pytest.approx(10.0)
    assert r.loc[("tribench", "embree"), "ratio"] == pytest.approx(0.2)  # slower: below 1
    assert ("tribench_call", "trimesh") not in r.index  # no such contender in these rows


def test_geometric_mean_is_the_mean_of_logs_and_refuses_non_positive_values():
    g = stats.geometric_mean([2.0, 8.0, 4.0])
    assert g.mean == pytest.approx(4.0) and g.n == 3 and g.ci_low < 4.0 < g.ci_high
    inverse = stats.geometric_mean([1 / 2, 1 / 8, 1 / 4])
    assert inverse.mean * g.mean == pytest.approx(1.0) and inverse.ci_low * g.ci_high == pytest.approx(1.0)
    assert np.isnan(stats.geometric_mean([3.0]).ci_low)
    with pytest.raises(ValueError, match="positive"):
        stats.geometric_mean([1.0, 0.0])


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    if not INSTALLED:
        pytest.skip("no peer installed (pip install 'tribench[peers]')")
    base = tmp_path_factory.mktemp("peers")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(base / "cache"))
        frame = peers.measure(base / "peers.csv", TINY, progress=False)
    return base / "peers.csv", frame


@pytest.mark.slow  # a real measurement of every contender (seconds)
def test_a_real_measurement_times_every_installed_contender_in_every_repetition(measured):
    path, frame = measured
    assert list(pd.read_csv(path, nrows=0).columns) == list(runfolder.FILES[runfolder.PEERS])
    expected = {"tribench", "tribench_call", *CONTENDERS}
    assert set(frame["contender"]) == expected
    counts = frame.groupby(["contender", "process"]).size()
    assert (counts == TINY.reps).all() and len(counts) == len(expected) * TINY.processes
    assert (frame["rays_per_s"] > 0).all() and (frame["elapsed_ns"] > 0).all()
    # the C-timed loops are inside the call timed around them
    in_c = frame.loc[frame["contender"].isin(["tribench", *peers.NATIVE_EMBREE])]
    assert (in_c["elapsed_ns"] <= in_c["wall_ns"]).all()
    # each process is pinned to one CPU: at most a little over one CPU-second per second
    assert (frame["cpu_ns"] <= 1.2 * frame["wall_ns"] + 2_000_000).all()
    rays = frame.groupby("contender")["rays"].first()
    assert rays["tribench"] == TINY.width * TINY.height
    if "trimesh" in INSTALLED:
        assert rays["trimesh"] == TINY.trimesh_rays  # its subset
    # the closest triangle agrees with the float64 reference but on ambiguous rays, for every contender
    assert (frame["differ"] == frame["differ_ambiguous"]).all()
    assert frame["kernel"].nunique() == 1 and frame["workload"].str.contains("suzanne").all()


def test_an_interrupted_measurement_keeps_the_finished_processes(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(peers, "available", lambda: {"trimesh": None, "embree": "fake"})
    done = []

    def worker(command, text, env, handlers, name):
        job = json.loads(text)
        if job["process"] == 1:
            raise KeyboardInterrupt
        done.append(job)
        for row in _rows({"tribench": [5.0], "embree": [50.0]}).assign(process=job["process"]).to_dict("records"):
            handlers["peer"](row)

    monkeypatch.setattr(peers.protocol, "run_worker", worker)
    with pytest.raises(KeyboardInterrupt):
        peers.measure(tmp_path / "peers.csv", TINY, kernel="moller_trumbore", progress=False)
    kept = pd.read_csv(tmp_path / "peers.csv")
    assert set(kept["process"]) == {0} and len(kept) == 4
    assert done[0]["kernel"] == "moller_trumbore" and done[0]["peers"] == ["embree"]


@needs_a_peer
def test_a_failing_worker_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    with pytest.raises(RuntimeError, match="^peers worker of process 0: .*no_such_kernel"):
        peers.measure(tmp_path / "peers.csv", TINY, kernel="no_such_kernel", progress=False)


def test_measure_without_any_peer_says_how_to_install(tmp_path, monkeypatch):
    monkeypatch.setattr(peers, "available", lambda: {"trimesh": None, "embree": None})
    with pytest.raises(RuntimeError, match=r"tribench\[peers\]"):
        peers.measure(tmp_path, TINY)


# --------------------------------------------------------------------- the report


@pytest.fixture()
def run_copy(tmp_path_factory, monkeypatch):
    run_dir, cache = run_fixture_dir(tmp_path_factory)
    copy = tmp_path_factory.mktemp("peers-report") / "run"
    shutil.copytree(run_dir, copy)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    return copy


def _section(page: str, sid: str) -> str:
    start = page.index(f'<section id="{sid}">')
    return page[start : page.index("</section>", start)]


@pytest.mark.slow
def test_report_shows_the_peers_with_their_ratios_and_a_headline_sentence(run_copy, measured):
    path, frame = measured
    shutil.copy(path, run_copy / peers.PEERS)
    analysed(run_copy)  # `tribench stats`: the report reads the peer tables it writes
    page = reports.write_report(run_copy).read_text(encoding="utf-8")
    section = _section(page, "peers")
    kernel = frame["kernel"].iloc[0]
    assert f"tribench&#x27;s {kernel}, brute force, runs at" in section
    assert 'id="chart-peers"' in section and "Ratios of rays/s" in section
    for name in ("tribench", "tribench_call", *INSTALLED):
        assert f"<td>{name}</td>" in section
    assert "brute force, runs at" in _section(page, "headline")


def _peers_section(run_dir) -> str:
    """The report's peers section for ``run_dir``, as render() makes it (without drawing the whole page)."""
    tables, note = load_peers(load_run(run_dir))
    return results.peers_section(tables, note)


def test_report_without_peers_says_how_to_add_them(run_copy):
    section = _peers_section(run_copy)
    assert "No peers were measured" in section and f"tribench peers --out {run_copy}" in section
    assert "vegaEmbed(" not in section


@pytest.mark.parametrize("content", ["not,a,peers,file\n1,2,3,4\n", "", "\x00\xff garbage"])
def test_a_corrupt_peers_file_does_not_stop_the_report(run_copy, content):
    (run_copy / peers.PEERS).write_bytes(content.encode("latin-1"))
    section = _peers_section(run_copy)
    assert "peers.csv" in section and "tribench peers --out" in section and "<table" not in section


def test_peers_rows_that_cannot_be_summarised_do_not_stop_the_report(run_copy):
    _rows({"tribench": [100.0], "trimesh": [10.0]}).assign(rays_per_s=-1.0).to_csv(run_copy / peers.PEERS, index=False)
    analysed(run_copy)  # the analysis cannot summarise them, and says why
    section = _peers_section(run_copy)
    assert "cannot be used" in section and "positive" in section


# ------------------------------------------------------------------------ the CLI


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--kernel", "frobnicate"], "not a kernel with a closest-hit mode"),
        (["--processes", "1"], "--processes: must be an integer from 2"),
        (["--camera", "64by64"], "--camera: must be WIDTHxHEIGHT"),
        (["--cpu", "4096"], "is not one of this process's CPUs"),
        (["--processes", "1000000000000"], "processes x reps must be at most 10,000"),
        (["--processes", "2", "--reps", "100000"], "processes x reps must be at most 10,000"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(tmp_path, flags, message, capsys):
    from tribench import cli  # in this process: the input is refused before anything runs

    try:
        code = cli.main(["peers", "--out", str(tmp_path), *flags])
    except SystemExit as stop:  # argparse's own refusals exit
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / peers.PEERS).exists()


def test_peers_refuse_a_mesh_the_sweep_refuses(tmp_path, capsys):
    from tribench import cli

    huge = tmp_path / "huge.obj"  # issue #29.4: peers once timed Embree on rays that all missed it
    huge.write_text("v 0 0 0\nv 1e300 0 0\nv 0 1e300 0\nf 1 2 3\n")
    assert cli.main(["peers", "--out", str(tmp_path), "--mesh", str(huge), "--quick"]) == 2
    err = capsys.readouterr().err
    assert "overflow" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / peers.PEERS).exists()


def test_tribench_run_goes_on_without_peers_or_when_they_fail(monkeypatch, capsys, tmp_path):
    from tribench.harness.jobs import main as main_job

    monkeypatch.setattr(peers, "available", lambda: {"trimesh": None, "embree": None})
    main_job._run_peers(str(tmp_path), quick=True, progress=False)
    assert "none installed (pip install 'tribench[peers]')" in capsys.readouterr().err

    def broken(*args, **kwargs):
        raise RuntimeError("peers worker of process 0 exited with code 1: boom")

    monkeypatch.setattr(peers, "available", lambda: {"trimesh": None, "embree": "fake"})
    monkeypatch.setattr(peers, "measure", broken)
    main_job._run_peers(str(tmp_path), quick=True, progress=False)
    assert "peers: not measured: peers worker of process 0 exited with code 1: boom" in capsys.readouterr().err
    assert not (tmp_path / peers.PEERS).exists()


@pytest.mark.slow
@needs_a_peer
def test_peers_into_an_analysed_run_folder_refresh_its_peer_tables(run_copy):
    import json

    analysed(run_copy, baseline="curless")  # a choice of `tribench stats` the refresh must keep
    assert load_peers(load_run(run_copy))[0] is None  # no peers yet
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "tribench.cli",
            "peers",
            "--out",
            str(run_copy),
            "--quick",
            "--camera",
            "16x16",
            "--processes",
            "2",
            "--reps",
            "1",
            "--no-progress",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert f"{runfolder.ANALYSIS} into {run_copy}" in done.stderr
    record = json.loads((run_copy / runfolder.ANALYSIS).read_text(encoding="utf-8"))
    assert record["peers_sha256"] == analysis.file_digest(run_copy / peers.PEERS) and record["peers"] == "summarised"
    assert record["baseline"] == "curless" and {runfolder.PEER_RATES, runfolder.PEER_RATIOS} <= set(record["tables"])
    tables, note = load_peers(load_run(run_copy, baseline="curless"))  # the report reads them, no `tribench stats`
    assert tables is not None, note
    assert set(tables.rates["contender"]) == set(pd.read_csv(run_copy / peers.PEERS)["contender"])


def test_peers_timed_through_the_bvh_are_reported_as_the_bvh_not_brute_force(run_copy):
    rows = _rows({"tribench": [100.0, 110.0, 105.0], "embree": [50.0, 52.0, 51.0]})
    rows.loc[rows.contender == "tribench", "implementation"] = "tribench 0.1.0 bvh woop_fma (16 lanes)"
    rows.to_csv(run_copy / peers.PEERS, index=False)
    analysed(run_copy)
    section = _peers_section(run_copy)
    assert "tribench&#x27;s BVH with k runs at" in section and "brute" not in section


@pytest.mark.parametrize("accel", ["brute", "bvh"])
def test_tribench_competes_with_two_sided_kernels_only(accel):
    from tribench import ext

    kernels = peers.candidate_kernels(accel)
    assert kernels and not any(ext.kernel_info(k).culls_back_faces for k in kernels)
    assert "moller_trumbore_fma" in kernels and "moller_trumbore_cull_fma" not in kernels


def test_embree_is_timed_at_the_isa_it_is_fastest_at_per_call():
    class Scene:  # a scene whose passes take fixed times per width
        def __init__(self, ns: dict[int, int]):
            self.ns, self.passes = ns, 0

        def trace(self, o, d, t_max, width, loops):
            self.passes += 1
            return embree.Trace(self.ns[width] + self.passes % 2, loops, len(o), 0, 0.0)

    native, held = Scene({1: 100, 16: 50}), Scene({1: 90, 16: 60})
    o = np.zeros((4, 3), np.float32)
    assert peers._fastest_isa({None: native, "avx2": held}, o, o, 1) == "avx2"
    assert peers._fastest_isa({None: native, "avx2": held}, o, o, 16) is None
    assert native.passes == held.passes == 6  # three alternating passes each, per call
