"""The README's quick start and CI stay the same commands."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def quick_start_commands():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```sh\n(.+?)\n```", section)


def test_quick_start_is_two_commands():
    commands = quick_start_commands()
    assert len(commands) == 2
    assert all("\n" not in c for c in commands)


def test_ci_runs_the_readme_test_command():
    test_command = quick_start_commands()[1]
    assert "pytest" in test_command
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert test_command in ci


# ------------------------------------------------------------ the run folder's page


def test_the_run_folder_page_is_what_its_schema_renders():
    from tribench.harness import runfolder_doc

    page = (ROOT / "docs" / "run-folder.md").read_text(encoding="utf-8")
    assert page == runfolder_doc.render(), (
        f"docs/run-folder.md differs from the run folder's schema (tribench/harness/runfolder.py): "
        f"regenerate it with `{runfolder_doc.COMMAND}` from the repository's root"
    )


def test_the_run_folder_page_names_every_file_and_column():
    from tribench.harness import runfolder, runfolder_doc

    page = runfolder_doc.render()
    for schema in (runfolder.FILES, runfolder.SEED_FILES):
        for name, columns in schema.items():
            section = page.split(f"### `{name}`\n", 1)[1].split("\n### ", 1)[0]
            assert [line.split("`")[1] for line in section.splitlines() if line.startswith("| `")] == list(columns)
    for name in (runfolder.RUN, runfolder.STAGES, runfolder.ANALYSIS, runfolder.GOOGLE_BENCHMARK, runfolder.REPORT):
        assert f"| `{name}` |" in page, name


def test_the_regenerate_command_writes_the_page(tmp_path):
    from tribench.harness import runfolder_doc

    out = tmp_path / "run-folder.md"
    done = subprocess.run(
        [sys.executable, "-m", "tribench.harness.runfolder_doc", str(out)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert out.read_text(encoding="utf-8") == runfolder_doc.render()
