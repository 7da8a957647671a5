"""The pages users read: every example script is documented on a page with a command that runs it, every
relative link of README.md and docs/*.md leads to a file that exists (and to a heading of it, when it names one),
and the probe table of docs/verification.md lists exactly the probes of tests/test_probes.py."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SCRIPTS = sorted(p.name for p in (ROOT / "examples").glob("*.py"))
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def text_of_pages() -> str:
    return "\n".join(page.read_text() for page in PAGES)


def anchor(heading: str) -> str:
    """GitHub's anchor of a markdown heading: lower case, punctuation dropped, spaces as hyphens."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page: Path) -> set:
    return {anchor(line.lstrip("#")) for line in page.read_text().splitlines() if line.startswith("#")}


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_example_script_is_run_by_a_command_on_a_page(script):
    """Each script appears on README.md or a docs page in a command line (``python3 examples/NAME.py ...``)."""
    assert f"python3 examples/{script}" in text_of_pages(), (
        f"examples/{script} is not run by any command in README.md or docs/*.md")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_relative_link_leads_to_a_file_and_heading_that_exist(page):
    broken = []
    for target in LINK.findall(page.read_text()):
        if re.match(r"[a-z]+:", target):
            continue   # a web address
        path, _, fragment = target.partition("#")
        linked = (page.parent / path).resolve() if path else page
        if not linked.exists():
            broken.append(target)
        elif fragment and linked.suffix == ".md" and fragment not in anchors(linked):
            broken.append(target)
    assert not broken, f"{page.name}: links to missing files or headings: {broken}"


def test_the_probe_table_lists_every_probe():
    """One row per probe of tests/test_probes.py (its PROBES and the three probes after them), in its order."""
    import test_probes

    text = (ROOT / "docs" / "verification.md").read_text()
    table = text[text.index("| probe | expected | observed (exit status: stderr) |"):]
    lines = table.splitlines()[2:]
    rows = lines[:next((i for i, line in enumerate(lines) if not line.startswith("|")), len(lines))]
    probes = rows[:len(test_probes.PROBES)]
    assert len(rows) == len(test_probes.PROBES) + 3
    for row, (script, _, _) in zip(probes, test_probes.PROBES):
        assert row.startswith(f"| `{script}.py "), row
