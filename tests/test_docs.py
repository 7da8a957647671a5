"""The pages users read: every example script is documented on a page with a command that runs it, every flag of
a command on a page is one its script takes, every relative link of README.md and docs/*.md leads to a file that
exists (and to a heading of it, when it names one), and the probe table of docs/verification.md lists exactly the
probes of tests/test_probes.py."""
import json
import re
import subprocess
import sys
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
    documented = f"python3 examples/{script}" in text_of_pages()
    assert documented, (
        f"examples/{script} is not run by any command in README.md or docs/*.md")


def help_texts(scripts) -> dict:
    """Each script's --help, from one interpreter (--help loads no heavy library, tests/test_examples.py)."""
    probe = f"""
import contextlib, importlib.util, io, json, sys
sys.path.insert(0, {str(ROOT)!r})
texts = {{}}
for name in {sorted(scripts)!r}:
    spec = importlib.util.spec_from_file_location(name[:-3], {str(ROOT / "examples")!r} + "/" + name)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            module.main(["--help"])
        except SystemExit:
            pass
    texts[name] = out.getvalue()
print(json.dumps(texts))
"""
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 0, run.stderr[-1500:]
    return json.loads(run.stdout)


def test_every_flag_of_a_command_on_a_page_is_one_its_script_takes():
    commands = re.findall(r"python3 examples/(\w+\.py)([^`|\n]*)", text_of_pages())
    helps = help_texts({script for script, _ in commands})
    unknown = {(script, flag) for script, rest in commands
               for flag in re.findall(r"(?<![\w-])(--[a-z][\w-]*)", rest) if flag not in helps[script]}
    assert not unknown, f"flags on the pages that their scripts do not take: {sorted(unknown)}"


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
    """One row per probe of tests/test_probes.py (its PROBES and the three probes after them), in its order, then
    one per probe of tests/test_probes_sim.py."""
    import test_probes
    import test_probes_sim

    text = (ROOT / "docs" / "verification.md").read_text()
    table = text[text.index("| probe | expected | observed (exit status: stderr) |"):]
    lines = table.splitlines()[2:]
    rows = lines[:next((i for i, line in enumerate(lines) if not line.startswith("|")), len(lines))]
    probes = rows[:len(test_probes.PROBES)]
    assert len(rows) == len(test_probes.PROBES) + 3 + len(test_probes_sim.PROBES)
    for row, (script, _, _) in zip(probes, test_probes.PROBES):
        assert row.startswith(f"| `{script}.py "), row
    for row, (script, *_) in zip(rows[len(test_probes.PROBES) + 3:], test_probes_sim.PROBES):
        assert row.startswith(f"| `{script}.py "), row
