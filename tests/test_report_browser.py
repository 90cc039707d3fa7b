"""The report in a real browser: headless Chromium loads it offline, no console error, not blank,
and with every detail collapsed it opens on the ranking and stays short."""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from test_report_run import run_fixture_dir

from tribench import reports

#: The longest the report may be with its details collapsed, at 1280 px wide (issue #20), and the first screen.
MAX_HEIGHT_PX, SCREEN = 10_000, (1280, 800)


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def report_page(tmp_path_factory) -> tuple[str, Path]:
    browser = _chromium()
    if browser is None:
        pytest.skip("no chromium or chromium-browser on PATH (.ci/run installs Debian's chromium package)")
    run_dir, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        page = reports.write_report(run_dir)
    return browser, page


def _chromium_run(browser: str, url: str, *flags: str) -> tuple[str, list[str]]:
    """Chromium's stdout, and every console message and failed load it logged (there must be none)."""
    proc = subprocess.run(
        [
            browser,
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-logging=stderr",
            "--v=0",
            "--no-first-run",
            "--disable-extensions",
            *flags,
            url,
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    console = [
        line
        for line in proc.stderr.splitlines()
        if re.search(r"Uncaught|ERROR:CONSOLE|CONSOLE[:(]\d+|Failed to load resource|net::ERR_", line)
    ]
    return proc.stdout, console


@pytest.mark.slow
def test_report_renders_in_headless_chromium_without_console_errors(report_page, tmp_path):
    browser, page = report_page
    shot = tmp_path / "report.png"
    _, console = _chromium_run(browser, page.resolve().as_uri(), f"--screenshot={shot}", "--window-size=1280,2000")
    assert console == [], "\n".join(console)

    import matplotlib.image as mpimg

    pixels = mpimg.imread(shot)
    assert pixels.shape[0] >= 1000 and pixels.shape[1] >= 1000
    rgb = pixels[..., :3]
    assert float(np.var(rgb)) > 1e-3, "the screenshot is blank"
    non_white = np.mean(np.any(rgb < 0.9, axis=-1))
    assert non_white > 0.02, f"only {non_white:.1%} of the screenshot is not white"


#: Appended to a copy of the page: once the charts have drawn, it writes what the test measures into the DOM.
_PROBE = """<script>addEventListener("load", () => setTimeout(() => {
  const row = document.querySelector("#answer table tbody tr").getBoundingClientRect();
  const m = document.createElement("div");
  m.id = "tb-measure";
  m.dataset.height = document.documentElement.scrollHeight;
  m.dataset.width = document.documentElement.scrollWidth;
  m.dataset.rowBottom = row.bottom + scrollY;
  m.dataset.charts = document.querySelectorAll("figure.chart svg.marks").length;
  m.dataset.open = document.querySelectorAll("details[open]").length;
  m.dataset.opened = [...document.querySelectorAll("section > details[open]")].map(d => d.parentElement.id).join(" ");
  document.body.appendChild(m);
}, 1000));</script>"""


class _Measure(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.found: dict[str, str] = {}

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if a.get("id") == "tb-measure":
            self.found = {k[5:]: v or "" for k, v in a.items() if k.startswith("data-")}


def _measure(browser: str, url: str) -> dict[str, str]:
    dom, console = _chromium_run(
        browser, url, "--dump-dom", f"--window-size={SCREEN[0]},{SCREEN[1]}", "--virtual-time-budget=20000"
    )
    assert console == [], "\n".join(console)
    parser = _Measure()
    parser.feed(dom)
    assert parser.found, "the probe did not run"
    return parser.found


@pytest.mark.slow
def test_collapsed_the_report_opens_on_the_ranking_and_is_at_most_10000_px_tall(report_page, tmp_path):
    browser, page = report_page
    probed = tmp_path / "report.html"
    text = page.read_text(encoding="utf-8")
    end = text.rindex("</body>")  # the last: the charts' library has the words in its strings
    probed.write_text(text[:end] + _PROBE + text[end:], encoding="utf-8")
    m = _measure(browser, probed.resolve().as_uri())
    assert int(m["charts"]) == 8  # every chart drew, the collapsed ones too
    assert int(m["open"]) == 0  # every detail collapsed
    assert int(m["width"]) <= SCREEN[0]  # nothing wider than the window
    assert int(m["height"]) <= MAX_HEIGHT_PX
    assert float(m["row-bottom"]) <= SCREEN[1]  # the ranking's first row is on the first screen
    # a link to a collapsed section (the bar at the top, or an address with its #id) opens it
    assert _measure(browser, probed.resolve().as_uri() + "#drift")["opened"] == "drift"


#: Hovers over a point of the answer chart and keeps its tooltip's text, then clicks the first kernel of the
#: legend and writes how many points faded before and after.
_CLICK = """<script>addEventListener("load", () => setTimeout(() => {
  const chart = document.querySelector("#chart-answer");
  const points = () => [...chart.querySelectorAll("g.mark-symbol.role-mark path")];
  const faded = () => points().filter(p => parseFloat(p.getAttribute("opacity") ?? "1") < 0.5).length;
  const r = points()[0].getBoundingClientRect();
  const at = {bubbles: true, clientX: r.x + r.width / 2, clientY: r.y + r.height / 2};
  for (const type of ["pointerover", "pointermove", "mouseover", "mousemove"]) {
    points()[0].dispatchEvent(new MouseEvent(type, at));
  }
  setTimeout(() => {
    const tip = document.querySelector("#vg-tooltip-element");
    const tooltip = tip ? tip.textContent : "";
    const before = faded();
    chart.querySelector("g.role-legend-symbol path").dispatchEvent(new MouseEvent("click", {bubbles: true}));
    setTimeout(() => {
      const m = document.createElement("div");
      m.id = "tb-measure";
      m.dataset.tooltip = tooltip;
      m.dataset.before = before;
      m.dataset.after = faded();
      m.dataset.points = points().length;
      document.body.appendChild(m);
    }, 500);
  }, 500);
}, 1000));</script>"""


@pytest.mark.slow
def test_the_answer_chart_shows_values_on_hover_and_a_kernel_alone_on_a_click(report_page, tmp_path):
    browser, page = report_page
    probed = tmp_path / "report.html"
    text = page.read_text(encoding="utf-8")
    end = text.rindex("</body>")
    probed.write_text(text[:end] + _CLICK + text[end:], encoding="utf-8")
    found = _measure(browser, probed.resolve().as_uri())
    tip = found.pop("tooltip")
    assert "ns/test [95% CI]" in tip and "speedup over moller_seed" in tip and "bytes per triangle" in tip
    assert re.search(r"kernel(moller_seed|moller_trumbore|curless)rank", tip), tip
    m = {k: int(v) for k, v in found.items()}
    # the first band of the fixture has its 3 kernels: one stays, the other two fade
    assert (m["points"], m["before"], m["after"]) == (3, 0, 2)


#: Appended to a page: once its charts have drawn, it writes how many did into the DOM.
_COUNT = """<script>addEventListener("load", () => setTimeout(() => {
  const m = document.createElement("div");
  m.id = "tb-measure";
  m.dataset.charts = document.querySelectorAll("figure.chart svg.marks").length;
  document.body.appendChild(m);
}, 1000));</script>"""


@pytest.mark.slow
def test_the_charts_the_fixture_has_no_data_for_draw_without_console_errors(tmp_path):
    """The BVH, peers, seed and compare charts, and rounds with outliers, from small frames in their tables' columns."""
    import pandas as pd

    from tribench.reports import charts, page, speed_charts
    from tribench.reports.compare import RATIO_WORDS
    from tribench.reports.tables.diagnostics import drift_bins, round_summary

    browser = _chromium()
    if browser is None:
        pytest.skip("no chromium or chromium-browser on PATH (.ci/run installs Debian's chromium package)")
    colours = charts.kernel_colours(["a", "b"])
    bvh = pd.DataFrame(
        {"family": "mesh", "label": ["s", "l"] * 2, "dtype": "float32", "rays_kind": "camera"}
        | {"kernel": ["a", "a", "b", "b"], "triangles": [1e3, 1e5] * 2, "rays_per_s": [4e6, 2e6, 3e6, 1.5e6]}
        | {"rays_per_s_ci_low": [3.9e6, 1.9e6, 2.9e6, 1.4e6], "rays_per_s_ci_high": [4.1e6, 2.1e6, 3.1e6, 1.6e6]}
    )
    rates = pd.DataFrame(
        {"contender": ["tribench", "embree", "trimesh"], "implementation": ["x", "y", "z"]}
        | {"rays_per_s": [2e6, 9e6, 5e4], "ci_low": [1.9e6, 8e6, float("nan")], "ci_high": [2.1e6, 1e7, float("nan")]}
    )
    seed = pd.DataFrame(
        {"scene": ["s1", "s1", "s2", "s2"], "kernel": ["a", "b"] * 2, "ratio_baseline": "a"}
        | {"ratio_to_moller_seed": [1.0, 1.4, 1.0, 1.2], "ratio_to_moller_seed_ci_low": [1.0, 1.3, 1.0, 1.1]}
        | {"ratio_to_moller_seed_ci_high": [1.0, 1.5, 1.0, 1.3], "paper_ratio_real": [1.0, 1.5, 1.0, float("nan")]}
        | {"paper_ratio_user": [1.0, 1.6, 1.0, float("nan")]}  # s2: a scene the paper did not render
    )
    spd = pd.DataFrame(
        {"family": "pairs", "label": ["20%", "80%"], "kernel": "b", "verdict": ["faster", "equivalent"]}
        | {"ratio": [1.25, 1.0], "ratio_ci_low": [1.2, 0.99], "ratio_ci_high": [1.3, 1.01]}
    )
    labels = pd.DataFrame(  # batches with a Tukey outlier and a far-out one, which the fixture may lack
        {"kernel": ["a"] * 4 + ["b"] * 4, "round": [-1, 0, 0, 1] * 2, "warmup": [True, False, False, False] * 2}
        | {"rel_to_median": [1.0, 1.1, 0.9, 1.0, 4.0, 1.0, 0.5, 1.0], "t_in_process_s": [0.0, 1.0, 2.0, 3.0] * 2}
        | {"outlier": [False] * 4 + [True, False, True, False], "far_out": [False] * 4 + [True] + [False] * 3}
    )
    drawn = [
        charts.rounds_chart(round_summary(labels), colours),
        charts.drift_chart(drift_bins(labels, bins=2), colours),
        speed_charts.bvh_chart(bvh, colours),
        speed_charts.peers_chart(rates),
        speed_charts.seed_chart(seed, colours),
        speed_charts.forest_chart(spd, 0.02, "speedup_B / speedup_A", "larger on B", RATIO_WORDS),
    ]
    body = "".join(charts.embed(c, f"chart-{i}", "a chart", "a chart") for i, c in enumerate(drawn))
    path = tmp_path / "charts.html"
    path.write_text(page.document("charts", body + _COUNT), encoding="utf-8")
    assert int(_measure(browser, path.resolve().as_uri())["charts"]) == 6
