"""Every example script answers --help (argparse), without running its job."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.name for p in (ROOT / "examples").glob("*.py"))


@pytest.mark.parametrize("script", SCRIPTS)
def test_example_answers_help(script):
    run = subprocess.run([sys.executable, str(ROOT / "examples" / script), "--help"], capture_output=True,
                         text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("usage:")


def test_the_main_job_reaches_the_goal_and_writes_its_figure(tmp_path):
    """README command 1: plan with Step-space, hop on Drake, write the figure."""
    out = tmp_path / "plan_and_hop.png"
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "plan_and_hop.py"), "--terrain", "mixed",
                          "--seed", "3", "--out", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "reached the goal" in run.stdout and out.stat().st_size > 10_000
    bad = subprocess.run([sys.executable, str(ROOT / "examples" / "plan_and_hop.py"), "--planner", "warp"],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert bad.returncode == 2 and "unknown planner 'warp'" in bad.stderr and "Traceback" not in bad.stderr
