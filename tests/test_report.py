"""The HTML report: structure from a small real run, offline-ness, the headline, bad input."""

from __future__ import annotations

import base64
import html
import json
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from html.parser import HTMLParser

import pandas as pd
import pytest
from conftest import analysed
from test_report_run import run_fixture_dir

from tribench import reports
from tribench.harness import runfolder
from tribench.harness.plan import plan
from tribench.reports import charts, checks, headline, speed_charts
from tribench.reports import html as report_html
from tribench.reports.rundata import RunError

pytestmark = pytest.mark.slow  # the report of a small run, rendered (10 s) and read section by section: CI runs it


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    run_dir, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        path = reports.write_report(run_dir)
        yield run_dir, path, path.read_text(encoding="utf-8")


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids, self.imgs, self.scripts, self.links, self.tags = [], [], [], [], []
        self.head_scripts = 0  # scripts before <body>
        self._in_script = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if "id" in a:
            self.ids.append(a["id"])
        if tag == "img":
            self.imgs.append(a.get("src", ""))
        if tag == "script":
            assert "src" not in a  # every script is inline
            self.scripts.append("")
            self.head_scripts += "body" not in self.tags
            self._in_script = True
        if tag in ("link", "iframe", "object", "embed"):
            self.links.append(a)

    def handle_endtag(self, tag):
        if tag == "script":
            self._in_script = False

    def handle_data(self, data):
        if self._in_script:
            self.scripts[-1] += data


def _without_library(text):
    """The page less the charts' library (Vega's code holds URLs in strings it never fetches here)."""
    from tribench.reports import charts

    assert text.count(charts.library()) == 1  # inlined once, not per chart
    return text.replace(charts.library(), "")


def _parse(text):
    p = _Page()
    p.feed(text)
    return p


def test_report_has_every_section_in_order(rendered):
    _, path, text = rendered
    assert path.name == "report.html"
    ids = _parse(text).ids
    sections = [i for i in ids if i in report_html.SECTIONS]
    assert sections == list(report_html.SECTIONS)


def test_the_only_images_are_the_workloads_inline_pictures(rendered):
    _, _, text = rendered
    imgs = _parse(text).imgs
    pngs = [s for s in imgs if s.startswith("data:image/png;base64,")]
    assert len(pngs) == len(imgs) == 4  # one picture per workload; every plot is a chart
    for uri in pngs:
        assert base64.b64decode(uri.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
        assert len(uri) < 120_000  # low-dpi palette pictures: the report stays a few MB


def test_report_opens_offline_no_external_references(rendered):
    _, _, full = rendered
    page = _parse(full)
    assert page.links == []
    text = _without_library(full)
    assert "http://" not in text and "https://" not in text
    assert 'src="//' not in text and 'href="//' not in text
    hrefs = re.findall(r'href="([^"]*)"', text)
    assert hrefs and all(h.startswith("#") for h in hrefs)
    srcs = re.findall(r'src="([^"]*)"', text)
    assert all(s.startswith("data:") for s in srcs)


def test_headline_states_verdicts_and_hit_rate_meaning(rendered):
    run_dir, _, text = rendered
    head = text[text.index('id="headline"') : text.index('id="kernels"')]
    spd = pd.read_csv(run_dir / "speedups.csv")
    for kernel in spd["kernel"].unique():
        assert f"{kernel} " in head
    assert "moller_seed" in head  # the baseline is named
    assert "per-test hit rate" in head and "per-ray hit rate" in head
    assert "95% CI" in head and "3 processes" in head
    assert "AMD" in head or "cpu" in head.lower() or "on " in head
    # every verdict word in the headline is one stats.verdict can give (or "mixed")
    words = re.findall(r'<span class="(\w+)">', head)
    assert words and set(words) <= {"faster", "slower", "equivalent", "inconclusive", "mixed"}


def test_tables_carry_units_and_escaped_text(rendered):
    _, _, text = rendered
    assert "ns/test (mean)" in text and "speedup (×)" in text
    # the only scripts: the charts' library and the opener of collapsed sections in the head, and one
    # vegaEmbed call per chart (no text of the run became a script)
    from tribench.reports import charts

    page = _parse(text)
    assert page.head_scripts == 2 and page.scripts[0] == charts.library() and "tbOpen" in page.scripts[1]
    assert all(s.startswith('vegaEmbed("#chart-') for s in page.scripts[2:]) and len(page.scripts) == 2 + 8


def test_reproduce_section_gives_a_sweep_file_that_reads_back(rendered, tmp_path):
    from tribench.harness.plan import Sweep
    from tribench.harness.sweep_file import load_sweep_file

    run_dir, _, text = rendered
    assert "tribench sweep --file sweep.toml" in text
    sweep = load_sweep_file(run_dir / "sweep.toml")
    recorded = Sweep.from_dict(json.loads((run_dir / "run.json").read_text())["sweep"])
    assert sweep.workload_ids == recorded.workload_ids
    assert (sweep.kernels, sweep.processes, sweep.rounds, sweep.rng_seed) == (
        recorded.kernels,
        recorded.processes,
        recorded.rounds,
        recorded.rng_seed,
    )
    assert plan(sweep) == plan(recorded)  # the same batches, in the same order


def test_a_main_jobs_sweep_file_reproduces_its_design_and_who_runs_what(tmp_path):
    """The sequential rule and the per-workload kernels of the main job survive the round trip, so a
    rerun plans the same batches (2,574 of them, not 8,856 on 36 processes as without them)."""
    from tribench.harness.plan import Sweep, default_sweep
    from tribench.harness.sweep_file import load_sweep_file
    from tribench.reports.about import sweep_toml

    job = default_sweep(quick=True)
    assert job.sequential is not None and job.workload_kernels  # what the round trip must keep
    (tmp_path / "sweep.toml").write_text(sweep_toml(job.to_dict()))
    again = load_sweep_file(tmp_path / "sweep.toml")
    assert again == job and plan(again) == plan(job)
    assert Sweep.from_dict(again.to_dict()) == job


def test_machine_section_shows_caches_and_build(rendered):
    run_dir, _, text = rendered
    run = json.loads((run_dir / "run.json").read_text())
    machine = text[text.index('id="machine"') : text.index('id="reproduce"')]
    assert run["machine"]["build"]["compiler"] in machine
    for level in run["machine"]["caches"]:
        assert level in machine


def test_correctness_table_agrees_on_a_clean_run(rendered):
    _, _, text = rendered
    corr = text[text.index('id="correctness"') : text.index('id="robustness"')]
    assert corr.count("<td>yes</td>") == 3 * 4  # every kernel on every workload agrees
    assert "<td>no</td>" not in corr
    assert '<a href="#robustness">' in corr  # the watertightness figures are there


def _section_rows(text, sid):
    """The cells of every table row of one section, tags stripped."""
    part = text[text.index(f'id="{sid}"') :]
    part = part[: part.index("</section>")]
    return [
        [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", row)]
        for row in re.findall(r"<tr>(.*?)</tr>", part)
    ]


def test_every_table_names_its_workload_by_family_and_label(rendered):
    """The speedups, estimates, drift and diagnostics tables named a workload by its label alone
    ("suzanne, 968 triangles"): at two precisions, two rows per kernel said the same. Each names its family too."""
    run_dir, _, text = rendered
    wl = pd.read_csv(run_dir / "workloads.csv")
    names = {f"{f} · {lab}" for f, lab in zip(wl["family"], wl["label"], strict=True)}
    tables = 0
    for sid in ("speedups", "drift", "diagnostics"):
        part = text[text.index(f'id="{sid}"') :]
        for table in re.findall(r"<table.*?</table>", part[: part.index("</section>")], flags=re.S):
            rows = [
                [html.unescape(re.sub(r"<[^>]+>", "", c)) for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", row)]
                for row in re.findall(r"<tr>(.*?)</tr>", table, flags=re.S)
            ]
            if rows and rows[0][:2] == ["kernel", "workload"]:
                tables += 1
                assert {r[1] for r in rows[1:]} <= names, (sid, {r[1] for r in rows[1:]} - names)
    assert tables == 6  # speedups, estimates, drift, warm-up, outliers, variance


def test_kernels_section_gives_bytes_per_triangle_beside_speed(rendered):
    from test_report_run import KERNELS

    from tribench import ext

    _, _, text = rendered
    rows = _section_rows(text, "kernels")
    head = rows[0]
    assert {"form", "ISA", "bytes per triangle", "ns/test (median)", "speedup (median, ×)"} <= set(head)
    col = {h: i for i, h in enumerate(head)}
    for kernel in KERNELS:
        mine = [r for r in rows[1:] if r[col["kernel"]] == kernel]
        assert len(mine) == 2  # the pair family and the mesh family, both float64
        for r in mine:
            assert r[col["form"]] == "scalar" and r[col["precision"]] == "float64"
            assert r[col["bytes per triangle"]] == str(ext.bytes_per_triangle(kernel, "float64"))
            assert float(r[col["ns/test (median)"]]) > 0
            assert (r[col["verdicts"]] == "baseline") == (kernel == "moller_seed")


def test_robustness_section_shows_the_validate_table_per_kernel_and_dtype(rendered):
    from test_report_run import KERNELS

    from tribench.harness.jobs import validate

    run_dir, _, text = rendered
    part = text[text.index('id="robustness"') : text.index('id="workloads"')]
    assert "Read from validate.csv" in part
    rows = _section_rows(text, "robustness")
    head = rows[0]
    assert head[:4] == ["kernel", "precision", "ISA", "promises (validate)"]
    assert head[4:] == list(validate.SHORT_NAMES.values())
    table = [r for r in rows if len(r) == len(head)][1 : len(KERNELS) + 1]
    assert [(r[0], r[1]) for r in table] == [(k, "float64") for k in KERNELS]
    # the promises, moved here from the first screen: each kernel's judged tests and how many broke
    val = pd.read_csv(run_dir / "validate.csv")
    for r in table:
        mine = val.loc[(val["kernel"] == r[0]) & (val["dtype"] == r[1])]
        checked, broken = (mine["verdict"] != "measured").sum(), (mine["verdict"] == "fail").sum()
        assert r[3] == (f"{broken} of {checked} broken" if checked else "none promised")
    # the rays per test, and one sentence on what each measures
    tests = [r for r in rows if len(r) > 1 and r[1] in validate.TESTS]
    assert [r[1] for r in tests] == list(validate.TESTS)
    assert all(int(r[-1].replace(",", "")) > 0 and len(r[2]) > 40 for r in tests)
    # a broken promise is marked in its cell, and only there
    fails = pd.read_csv(run_dir / "validate.csv").query("verdict == 'fail'")
    marked = re.findall(r'<td class="num broken">[^<]*!</td>', part)
    assert len(marked) == 2 * len(fails)  # in the table and in the list of broken promises
    assert part.count("!</td>") == len(marked)


def test_a_broken_promise_is_marked_red_in_the_robustness_table(rendered):
    run_dir, _, _ = rendered
    val = pd.read_csv(run_dir / "validate.csv")
    row = (val["kernel"] == "curless") & (val["test"] == "parallel_rays")
    val.loc[row, ["failures", "rate", "verdict"]] = [3, 3 / 32, "fail"]
    part = checks.robustness_section(val, "a note")
    assert "1 broken" in part and "Broken promises" in part
    assert part.count('<td class="num broken">9.38%!</td>') == 2  # the table and the list
    assert part.count("!</td>") == 2


def test_the_page_uses_the_one_stylesheet_of_the_page_kit(rendered):
    from tribench.reports import page

    _, _, text = rendered
    assert re.findall(r"<style>(.*?)</style>", text, re.S) == [page.CSS]
    assert text.count("<nav>") == 1 and text.endswith("</main></body></html>\n")


# a run analysed and reported again (seconds)
def test_the_calibration_note_shows_run_json_and_reads_no_file_outside_the_run(rendered, tmp_path):
    run_dir, _, _ = rendered
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("report.html", "sweep.toml", ".lock"))
    outside = tmp_path / "elsewhere" / "calibration.json"
    outside.parent.mkdir()
    outside.write_text(json.dumps({"kernel": "OUTSIDE_KERNEL", "copy": "x", "margin": 0.5}))
    source = f"calibration {outside} (2026-01-01T00:00:00+00:00, run r)"
    for name in ("run.json", "analysis.json"):
        record = json.loads((copy / name).read_text())
        record["margin"] = {"value": 0.02, "source": source}
        (copy / name).write_text(json.dumps(record))
    text = reports.write_report(copy).read_text(encoding="utf-8")
    part = text[text.index("<h3>A/A calibration</h3>") : text.index("<h3>Interference</h3>")]
    assert re.sub(r"<[^>]+>", "", part).replace("&#x27;", "'") == (
        f"A/A calibrationEquivalence margin of the verdicts: ±2% — {source}.That A/A calibration's record is not "
        "part of this run folder; its margin and source are the ones run.json recorded when the sweep started."
    )
    assert "OUTSIDE_KERNEL" not in text


# a run analysed and reported again (seconds)
def test_a_calibration_run_shows_its_own_record(rendered, tmp_path):
    run_dir, _, _ = rendered
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("report.html", "sweep.toml", ".lock"))
    (copy / "calibration.json").write_text(
        json.dumps({"kernel": "moller_trumbore", "copy": "moller_trumbore_aa", "noise_floor": 0.0123, "margin": 0.015})
    )
    text = reports.write_report(copy).read_text(encoding="utf-8")
    part = text[text.index("<h3>A/A calibration</h3>") : text.index("<h3>Interference</h3>")]
    assert "This run folder is an A/A calibration" in part
    assert "<td>moller_trumbore vs moller_trumbore_aa</td>" in part and "<td>0.0123</td>" in part


# a run analysed and reported again (seconds)
def test_the_analysis_rebuilds_a_workload_missing_from_the_cache(tmp_path_factory, monkeypatch):

    run_dir, cache = run_fixture_dir(tmp_path_factory)
    copy = tmp_path_factory.mktemp("rebuild") / "run"
    shutil.copytree(run_dir, copy)
    monkeypatch.setenv("TRIBENCH_CACHE", str(copy.parent / "empty-cache"))
    analysed(copy)  # `tribench stats` on another machine: the workloads are made from their specs
    text = reports.write_report(copy).read_text()
    assert "rebuilt from the spec recorded in run.json" in text
    rebuilt, cached = pd.read_csv(copy / "workloads.csv"), pd.read_csv(run_dir / "workloads.csv")
    assert set(cached["source"]) == {"cache"} and rebuilt["source"].str.startswith("not in the cache: rebuilt").all()
    assert rebuilt.drop(columns="source").equals(cached.drop(columns="source"))  # the same achieved figures


def test_headline_sentence_for_one_workload():
    spd = pd.DataFrame(
        {
            "family": ["pairs n=10"],
            "label": ["per-test hit rate 50%"],
            "kernel": ["mt"],
            "baseline": ["seed"],
            "ratio": [0.8],
            "ratio_ci_low": [0.7],
            "ratio_ci_high": [0.9],
            "n_processes": [10],
            "verdict": ["slower"],
            "confidence": [0.975],
        }
    )
    ((verdict, sentence),) = headline.headline_sentences(spd)["pairs n=10"]
    assert verdict == "slower"
    assert sentence == (
        "mt is slower than seed: 0.8× [0.7, 0.9] (95% CI, 10 processes) on pairs n=10 at per-test hit rate 50%."
    )


def test_format_tables_lists_estimates_and_speedups(rendered):
    run_dir, _, _ = rendered
    text = reports.format_tables(run_dir)
    assert "per-test hit rate 20%" in text and "suzanne, 300 triangles" in text
    assert "(baseline)" in text and "ns/test" in text
    assert re.search(r"moller_trumbore\s+[\d.]+\s+\[[\d.]+, [\d.]+\]\s+[\d.]+x\s+\[[\d.]+, [\d.]+\]", text)
    # every block names its workload in words (its family, then what varies), not by its id alone
    headings = [line for line in text.splitlines() if line.endswith("]") and "  [" in line]
    assert headings and all(line.startswith(("pairs n=", "mesh ")) for line in headings)
    # and the text ends on the report's answer: per band the fastest kernel, then the questions
    answer = text[text.index("the answer, per precision and band") :].splitlines()
    assert answer[1].startswith("  float") and "ns/test" in answer[1] and "tied with it" in answer[1]
    assert any(line.startswith("  Fastest: ") for line in answer) and text.endswith(answer[-1])


def test_a_run_that_ranks_no_kernel_says_why(rendered):
    """Every kernel an A/A copy (``sweep --kernels moller_trumbore_aa``): the tables hold no ranking, and the
    terminal said to run the stats it had just run, the page that the run had no estimate."""
    import dataclasses

    from tribench.reports import ranking
    from tribench.reports.rundata import load_run

    data = load_run(rendered[0])
    empty = {name: df.iloc[:0] for name, df in data.tables.items() if name in (runfolder.BANDS, runfolder.RANKING)}
    data = dataclasses.replace(data, tables={**data.tables, **empty})
    assert ranking.format_answer(data) == f"the answer: {ranking.NOTHING_RANKED}"
    for section in (
        ranking.ranking_section(data, empty[runfolder.RANKING]),
        ranking.answer_section(data, empty[runfolder.BANDS], None, {}),
    ):
        assert ranking.NOTHING_RANKED in section


def test_a_workload_the_baseline_did_not_run_says_why_it_has_no_speedups(rendered):
    """A BVH workload runs no moller_seed (no leaf test): its terminal block had blank speedup columns."""
    import dataclasses

    from tribench.reports import ranking
    from tribench.reports.rundata import load_run

    data = load_run(rendered[0])
    gone = data.workload_ids[0]
    est, spd = data.estimates, data.speedups
    data = dataclasses.replace(
        data,
        estimates=est.loc[~((est["workload_id"] == gone) & (est["kernel"] == data.baseline))],
        speedups=spd.loc[spd["workload_id"] != gone],
    )
    blocks = ranking.format_run(data).split("\n\n")
    said = f"  no speedups: {data.baseline} did not run on this workload"
    assert [said in b for b in blocks[1 : 1 + len(data.workload_ids)]] == [True] + [False] * (
        len(data.workload_ids) - 1
    )


def test_a_crossovers_interval_is_shown_within_the_hit_rates_there_are(rendered):
    """Fieller's interval of a line's root can run past 0-100% (-294% to 388% was shown): the report cuts it there."""
    from tribench.reports import results, rundata

    data = rundata.load_run(rendered[0])
    wl = data.tables[runfolder.WORKLOADS]
    cross = data.tables[runfolder.CROSSOVERS].iloc[:1].assign(hit_rate=0.4, ci_low=-2.941, ci_high=3.884)
    est, spd = rundata.estimates_table(data, wl), rundata.speedups_table(data, wl)
    html = results.hit_rate_section(data, est, spd, cross, charts.kernel_colours(data.kernels))
    table = html[html.index("<h3>Crossovers</h3>") :]
    assert "294" not in table and "388" not in table and "cut to 0–100%" in table
    cells = re.findall(r"<td[^>]*>([^<]*)</td>", table)
    assert cells[3:6] == ["40", "0", "100"], cells


# ----------------------------------------------------------------- bad input


def test_missing_run_dir_is_a_clear_error(tmp_path):
    with pytest.raises(RunError, match="no run directory"):
        reports.write_report(tmp_path / "nope")


def test_run_dir_without_batches_is_a_clear_error(tmp_path_factory):
    run_dir, _ = run_fixture_dir(tmp_path_factory)
    bare = tmp_path_factory.mktemp("bare")
    shutil.copy(run_dir / "run.json", bare / "run.json")
    with pytest.raises(RunError, match="batches.csv"):
        reports.write_report(bare)


def test_corrupt_run_json_is_a_clear_error(tmp_path):
    (tmp_path / "run.json").write_text("{not json")
    with pytest.raises(RunError, match="not valid JSON"):
        reports.write_report(tmp_path)


@pytest.mark.parametrize(
    "setup, message",
    [
        ("missing", "no run directory"),
        ("corrupt", "not valid JSON"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(tmp_path, setup, message):
    target = tmp_path / "run"
    if setup == "corrupt":
        target.mkdir()
        (target / "run.json").write_text("[")
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "report", str(target)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tribench report: error:") and message in lines[0]


def test_the_ranking_section_names_each_workloads_fastest_kernel_from_ranking_csv(rendered):
    run_dir, _, text = rendered
    assert text.index('id="ranking"') < text.index('id="kernels"')
    rank = pd.read_csv(run_dir / "ranking.csv")
    fastest = rank.loc[rank["rank"] == 1]
    rows = _section_rows(text, "ranking")
    head = rows[0]
    assert head[:3] == ["workload", "fastest kernel", "its ns/test [95% CI]"]
    shown = {r[0]: r[1] for r in rows if r and r[0] != "workload" and len(r) == len(head)}
    assert len(shown) == len(fastest)
    for r in fastest.itertuples(index=False):
        assert shown[f"{r.family} · {r.label}"] == r.kernel
    # three algorithms: their order, and the head-to-head questions this run can answer (it has no curless_seed)
    assert "The algorithms in order" in text and "curless vs moller_trumbore" in text
    assert "curless_seed vs moller_seed" not in text


def _specs(text):
    """Every chart's Vega-Lite spec on the page, by its element id."""
    return {m[0]: json.loads(m[1]) for m in re.findall(r'vegaEmbed\("#([\w-]+)",(\{.*?\}),\{actions', text)}


def test_the_page_opens_on_the_answer_and_collapses_every_other_section(rendered):
    run_dir, _, text = rendered
    body = text[text.index("<main>") :]
    assert body.startswith('<main><section id="answer"><h1>')
    for sid in report_html.SECTIONS:
        if sid not in report_html.OPEN:
            assert f'<section id="{sid}"><details><summary><h2>{report_html.SECTIONS[sid]}</h2></summary>' in text
    nav = text[text.index("<nav>") : text.index("</nav>")]
    assert re.findall(r'href="#([\w-]+)"', nav) == list(report_html.SECTIONS)  # the table of contents
    # the answer's tables: per precision, one row per band, the fastest kernel of bands.csv first
    answer = text[text.index('id="answer"') : text.index('id="ranking"')]
    bands = pd.read_csv(run_dir / "bands.csv")
    rows = _section_rows(text, "answer")
    assert rows[0][:4] == ["band", "fastest kernel", "ns/test [95% CI]", "speedup over moller_seed [95% CI]"]
    shown = [r for r in rows if r[0] != "band"]
    best = bands.loc[bands["rank"] == 1]
    assert [r[1] for r in shown] == list(best["kernel"])
    assert [r[0].split(" (")[0] for r in shown] == list(best["band"])
    assert [int(r[-1]) for r in shown] == list(best["bytes_per_triangle"])
    # robustness as measured, never as promises kept (0 for every kernel by design): those are in Robustness
    assert [html.unescape(h) for h in rows[0][-3:-1]] == [
        "shared-edge cracks per 10⁶ rays",
        "far-sphere misses per 10⁶ rays",
    ]
    assert [r[-3] for r in shown] == [
        f"{c:,.0f} ({int(n):,} rays)" for c, n in zip(best["cracks_per_million"], best["shared_edge_rays"], strict=True)
    ]
    assert "promises (validate)" not in answer
    # the headers' tooltips say which of validate's tests each column counts
    tips = [html.unescape(t) for t in re.findall(r'<th title="([^"]*)">', answer)]
    assert len(tips) == 2 * answer.count("<table>")
    assert "shared_edges test" in tips[0] and "inside_sphere test" in tips[1]
    assert answer.index("<table>") < answer.index("vegaEmbed(")  # the table before the chart
    # one sentence per question: the fastest, against the baseline, watertightness, curless or moller_trumbore
    items = re.findall(r"<li>(.*?)</li>", answer)
    assert [i.split(" ")[0] for i in items] == ["Fastest:", "Against", "Watertight:", "curless"]
    assert "curless or moller_trumbore? Of 4 workloads" in items[3]


def test_the_charts_show_values_on_hover_and_toggle_kernels(rendered):
    run_dir, _, text = rendered
    specs = _specs(text)
    assert sorted(specs) == [
        "chart-answer",
        "chart-drift",
        "chart-forest",
        "chart-hit-rate",
        "chart-processes",
        "chart-rounds",
        "chart-scaling",
        "chart-speedup-hit-rate",
    ]
    for name, spec in specs.items():
        flat = json.dumps(spec)
        assert '"tooltip"' in flat, name  # values on hover
        legends = [p for p in re.findall(r'\{"name": "(\w+)", "select": \{[^}]*\}, "bind": "legend"', flat)]
        assert legends == (["verdicts"] if name == "chart-forest" else ["kernels"]), name  # toggles
        assert "$schema" not in spec and "http" not in flat
    # the answer chart holds every kernel of every band, at bands.csv's values
    answer = specs["chart-answer"]
    data = answer["datasets"][answer["data"]["name"]] if "datasets" in answer else answer["data"]["values"]
    bands = pd.read_csv(run_dir / "bands.csv")
    got = {(d["where"], d["kernel"]): d["ns_per_test"] for d in data}
    want = {(f"{r.dtype} · {r.band}", r.kernel): r.ns_per_test for r in bands.itertuples()}
    assert got == pytest.approx(want, rel=1e-12)
    # its robustness axis is what validate measured: cracks plus far-sphere misses per million rays
    got = {(d["where"], d["kernel"]): d["failures_per_million"] for d in data}
    want = {
        (f"{r.dtype} · {r.band}", r.kernel): r.cracks_per_million + r.sphere_misses_per_million
        for r in bands.itertuples()
    }
    assert got == pytest.approx(want)
    assert '"field": "failures_per_million"' in json.dumps(answer)
    # where the suite's figures differ between kernels, so do their heights
    cracked = bands.assign(cracks_per_million=[88_250.0 * (r.kernel == "curless") for r in bands.itertuples()])
    spec = speed_charts.answer_chart(cracked, dict.fromkeys(bands["kernel"], "#000")).to_dict()
    values = spec["datasets"][spec["data"]["name"]] if "datasets" in spec else spec["data"]["values"]
    heights = {d["kernel"]: d["failures_per_million"] for d in values}
    assert heights["curless"] == 88_250.0 and heights["moller_trumbore"] == 0.0
    menu = next(p for p in answer["params"] if p["name"] == "band")
    assert menu["bind"]["options"] == list(dict.fromkeys(w for w, _ in want))


def test_each_chart_of_the_page_is_also_a_vector_figure_named_by_what_it_shows(rendered, tmp_path):
    run_dir, _, text = rendered
    folder = run_dir / "figures"
    shown = {c: spec for c, spec in _specs(text).items() if c in charts.FIGURES}  # the diagnostics are no paper's
    assert len(shown) == 5 and sorted(p.name for p in folder.iterdir()) == sorted(
        f"{charts.FIGURES[c]}.{ext}" for c in shown for ext in ("svg", "pdf")
    )
    kernels = {k for spec in shown.values() for k in re.findall(r"\"kernel\": \"(\w+)\"", json.dumps(spec))}
    for chart_id in shown:
        svg = (folder / f"{charts.FIGURES[chart_id]}.svg").read_text(encoding="utf-8")
        assert ET.fromstring(svg).tag.endswith("svg") and "click" not in svg  # a printed legend has no clicks
        assert (folder / f"{charts.FIGURES[chart_id]}.pdf").read_bytes().startswith(b"%PDF-")
    legend = (folder / f"{charts.FIGURES['chart-hit-rate']}.svg").read_text(encoding="utf-8")
    assert kernels and all(k in legend for k in kernels)
    # a chart the page no longer draws loses its files, so the folder matches the page
    charts.write_figures({"chart-answer": shown["chart-answer"]}, tmp_path)
    stem = charts.FIGURES["chart-answer"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"{stem}.pdf", f"{stem}.svg"]
    (tmp_path / "speedup-by-hit-rate.svg").write_text("stale")
    charts.write_figures({}, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_the_answer_chart_draws_an_interval_below_zero_on_a_linear_axis(rendered):
    """A t interval over 3 processes may reach below 0 ns (tribench run --quick on a busy machine): no log axis then."""
    run_dir, _, _ = rendered
    bands = pd.read_csv(run_dir / "bands.csv")
    colours = dict.fromkeys(bands["kernel"], "#000")

    def x_scales(frame):
        spec = json.dumps(speed_charts.answer_chart(frame, colours).to_dict())
        return set(re.findall(r'"x": \{[^{}]*"scale": \{"type": "(\w+)"\}', spec))

    # the fixture's own intervals may reach below 0 on a busy machine: set them
    narrow = bands.assign(ns_per_test_ci_low=0.9 * bands["ns_per_test"], ns_per_test_ci_high=1.1 * bands["ns_per_test"])
    assert x_scales(narrow) == {"log"}
    wide = narrow.assign(ns_per_test_ci_low=narrow["ns_per_test_ci_low"] - 2 * narrow["ns_per_test"])
    assert x_scales(wide) == {"linear"}


def _values(spec, field):
    """Every record of ``spec``'s inline datasets that has ``field``."""
    return [r for values in spec.get("datasets", {}).values() for r in values if field in r]


def test_the_per_process_chart_holds_every_process_of_every_workload_behind_a_menu(rendered):
    run_dir, _, text = rendered
    spec = _specs(text)["chart-processes"]
    pp = pd.read_csv(run_dir / "per_process.csv")
    dots = _values(spec, "process")
    assert sorted((d["workload_id"], d["kernel"], d["process"], d["ns_per_test"]) for d in dots) == sorted(
        zip(pp["workload_id"], pp["kernel"], pp["process"], pp["ns_per_test"], strict=True)
    )
    est = pd.read_csv(run_dir / "estimates.csv")
    means = {(d["workload_id"], d["kernel"]): d["ns_per_test"] for d in _values(spec, "n_processes")}
    keys = zip(est["workload_id"], est["kernel"], strict=True)
    assert means == pytest.approx(dict(zip(keys, est["ns_per_test"], strict=True)))
    menu = next(p for p in spec["params"] if p["name"] == "workload")
    swept = json.loads((run_dir / "run.json").read_text())["sweep"]["workload_ids"]
    assert menu["bind"]["options"] == [w for w in swept if w in set(est["workload_id"])]  # in the sweep's order
    assert len(menu["bind"]["labels"]) == 4 and all(" · " in label for label in menu["bind"]["labels"])


def test_the_drift_and_rounds_charts_draw_the_batches_summaries_not_every_batch(rendered):
    from tribench.reports.tables.diagnostics import drift_bins, round_summary

    run_dir, _, text = rendered
    specs = _specs(text)
    labels = pd.read_csv(run_dir / "batch_labels.csv")
    drift = drift_bins(labels)
    points = _values(specs["chart-drift"], "rel_median")
    assert len(points) == len(drift) <= 3 * 12  # a point per kernel and span of time, whatever the batches
    assert sorted(p["rel_median"] for p in points) == pytest.approx(sorted(drift["rel_median"]))
    rounds = round_summary(labels)
    boxes = _values(specs["chart-rounds"], "rel_q1")
    assert len(boxes) == len(rounds) == 3 * 4  # 3 kernels, 3 rounds and the warm-up
    assert {(b["kernel"], b["round"]): b["batches"] for b in boxes} == {
        (r.kernel, r.round): r.batches for r in rounds.itertuples()
    }
    assert sum(b["batches"] for b in boxes) == len(labels)


def test_drift_bins_and_round_summary_count_and_place_every_batch():
    from tribench.reports.tables.diagnostics import drift_bins, round_summary

    rel = [1.0, 1.1, 0.9, 1.0, 4.0, 1.0, 0.5, 1.0]
    labels = pd.DataFrame(
        {
            "kernel": ["a"] * 4 + ["b"] * 4,
            "round": [-1, 0, 0, 1] * 2,
            "warmup": [True, False, False, False] * 2,
            "rel_to_median": rel,
            "t_in_process_s": [0.0, 1.0, 2.0, 3.0] * 2,
            "outlier": [False] * 4 + [True, False, True, False],
            "far_out": [False] * 4 + [True, False, False, False],
        }
    )
    bins = drift_bins(labels, bins=2)  # spans [1, 2] and (2, 3] of the timed batches
    assert bins.set_index("kernel")["batches"].groupby(level=0).sum().to_dict() == {"a": 3, "b": 3}
    a = bins.loc[bins["kernel"] == "a"].sort_values("t_s")
    assert a[["t_s", "rel_q1", "rel_median"]].to_numpy().ravel() == pytest.approx([1.5, 0.95, 1.0, 3.0, 1.0, 1.0])
    rounds = round_summary(labels).set_index(["kernel", "round"])
    assert rounds.loc[("a", 0), ["rel_min", "rel_median", "rel_max", "batches"]].tolist() == pytest.approx(
        [0.9, 1, 1.1, 2]
    )
    # b's warm-up batch is far out (4.0); in round 0 the outlier is 0.5; a has none
    assert rounds.loc[("b", -1), ["outliers", "far_out", "worst_outlier"]].tolist() == [1, 1, 4.0]
    assert rounds.loc[("b", 0), ["outliers", "far_out", "worst_outlier"]].tolist() == [1, 0, 0.5]
    assert rounds.loc["a", "worst_outlier"].isna().all() and bool(rounds.loc[("a", -1), "warmup"])
    assert drift_bins(labels.loc[labels["warmup"]]).empty  # no timed batch, no point
