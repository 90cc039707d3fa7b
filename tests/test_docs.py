"""The README: its quick start and CI stay the same commands, it stays short, and its links and docs/'s
resolve; docs/run-folder.md is what the run folder's schema renders."""

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


# ------------------------------------------------------------ a README read in minutes

MAX_README_LINES = 200
MAX_README_WORDS = 2500


def test_the_readme_stays_short():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    lines, words = len(text.splitlines()), len(text.split())  # as `wc -l -w README.md` counts them
    assert lines <= MAX_README_LINES, f"README.md has {lines} lines, at most {MAX_README_LINES}: move detail to docs/"
    assert words <= MAX_README_WORDS, f"README.md has {words} words, at most {MAX_README_WORDS}: move detail to docs/"


def _anchor(heading: str) -> str:
    """GitHub's anchor of a markdown heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", path.read_text(encoding="utf-8"), flags=re.S)
    return {_anchor(m) for m in re.findall(r"^#+ (.+)$", text, flags=re.M)}


def _links(path: Path) -> list[tuple[str, str]]:
    """The relative links of a markdown file: (target file, anchor or '')."""
    text = re.sub(r"```.*?```", "", path.read_text(encoding="utf-8"), flags=re.S)
    found = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, anchor = target.partition("#")
        found.append((file, anchor))
    return found


def test_every_relative_link_of_the_readme_and_docs_resolves():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    checked = 0
    for page in pages:
        for file, anchor in _links(page):
            target = (page.parent / file).resolve() if file else page
            where = page.relative_to(ROOT)
            assert target.exists(), f"{where}: link to missing {file}"
            if anchor:
                assert anchor in _anchors(target), f"{where}: no heading #{anchor} in {file or page.name}"
            checked += 1
    assert checked >= 20


def test_the_readme_links_every_page_of_docs_and_shows_the_report():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    linked = {file for file, _ in _links(ROOT / "README.md")}
    pages = {f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md")}
    assert pages <= linked, f"README.md links no {sorted(pages - linked)}"
    assert "](docs/first-screen.png)" in readme and (ROOT / "docs" / "first-screen.png").stat().st_size < 300_000


# ------------------------------------------------------------ the run folder's page


def test_the_run_folder_page_is_what_its_schema_renders():
    from tribench.harness.runfolder import doc as runfolder_doc

    page = (ROOT / "docs" / "run-folder.md").read_text(encoding="utf-8")
    assert page == runfolder_doc.render(), (
        f"docs/run-folder.md differs from the run folder's schema (tribench/harness/runfolder.py): "
        f"regenerate it with `{runfolder_doc.COMMAND}` from the repository's root"
    )


def test_the_run_folder_page_names_every_file_and_column():
    from tribench.harness import runfolder
    from tribench.harness.runfolder import doc as runfolder_doc

    page = runfolder_doc.render()
    for schema in (runfolder.FILES, runfolder.SEED_FILES):
        for name, columns in schema.items():
            section = page.split(f"### `{name}`\n", 1)[1].split("\n### ", 1)[0]
            assert [line.split("`")[1] for line in section.splitlines() if line.startswith("| `")] == list(columns)
    for name in (runfolder.RUN, runfolder.STAGES, runfolder.ANALYSIS, runfolder.GOOGLE_BENCHMARK, runfolder.REPORT):
        assert f"| `{name}` |" in page, name


def test_the_regenerate_command_writes_the_page(tmp_path):
    from tribench.harness.runfolder import doc as runfolder_doc

    out = tmp_path / "run-folder.md"
    done = subprocess.run(
        [sys.executable, "-m", "tribench.harness.runfolder.doc", str(out)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert out.read_text(encoding="utf-8") == runfolder_doc.render()
