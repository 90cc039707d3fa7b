"""The report in a real browser: headless Chromium loads it offline, no console error, not blank."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest
from test_report_run import run_fixture_dir

from tribench import reports


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.mark.slow
def test_report_renders_in_headless_chromium_without_console_errors(tmp_path_factory):
    browser = _chromium()
    if browser is None:
        pytest.skip("no chromium or chromium-browser on PATH (.ci/run installs Debian's chromium package)")
    run_dir, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        page = reports.write_report(run_dir)
    shot = tmp_path_factory.mktemp("browser") / "report.png"
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
            f"--screenshot={shot}",
            "--window-size=1280,2000",
            page.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    console = [
        line
        for line in proc.stderr.splitlines()
        if re.search(r"Uncaught|ERROR:CONSOLE|CONSOLE\(\d+\)|Failed to load resource|net::ERR_", line)
    ]
    assert console == [], "\n".join(console)

    import matplotlib.image as mpimg

    pixels = mpimg.imread(shot)
    assert pixels.shape[0] >= 1000 and pixels.shape[1] >= 1000
    rgb = pixels[..., :3]
    assert float(np.var(rgb)) > 1e-3, "the screenshot is blank"
    non_white = np.mean(np.any(rgb < 0.9, axis=-1))
    assert non_white > 0.02, f"only {non_white:.1%} of the screenshot is not white"
