"""The scripts users run: every one answers --help with its defaults and without loading a heavy library, and
the README's main job works."""
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SCRIPTS = sorted(p.stem for p in (ROOT / "examples").glob("*.py"))
HEAVY = ("torch", "pydrake", "matplotlib", "ray", "numba")


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_script_answers_help_with_its_defaults(script, run_script):
    code, out, err = run_script(script, "--help")
    assert code == 0, err
    assert out.startswith("usage:") and "(default:" in out


def test_help_loads_no_heavy_library():
    """--help stays fast: no script imports torch, pydrake, matplotlib, ray or numba before it parses."""
    probe = f"""
import contextlib, importlib.util, io, sys
for name in {SCRIPTS!r}:
    spec = importlib.util.spec_from_file_location(name, {str(ROOT / "examples")!r} + "/" + name + ".py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            module.main(["--help"])
        except SystemExit:
            pass
    loaded = [m for m in {HEAVY!r} if m in sys.modules]
    assert not loaded, (name, loaded)
"""
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-1500:]


def readme_main_job() -> list[str]:
    """The script and arguments of README command 1's job (the first bash block's first command, after its
    install)."""
    block = README.read_text().split("```bash\n", 1)[1].split("```", 1)[0]
    command = next(line for line in block.splitlines() if line and not line.startswith("#"))
    return shlex.split(command.split(" && ", 1)[1])[1:]


def test_the_main_job_reaches_the_goal_and_writes_its_figure_and_replay(tmp_path, run_script):
    """README command 1, as written, its outputs in a scratch folder: plan, hop, write the figure and the replay."""
    script, *args = readme_main_job()
    assert script == "examples/plan_and_hop.py" and "--out" in args and "--html" in args
    outputs = {"--out": tmp_path / "figure.png", "--html": tmp_path / "replay.html"}
    args = [str(outputs[args[i - 1]]) if i and args[i - 1] in outputs else a for i, a in enumerate(args)]
    code, stdout, err = run_script("plan_and_hop", *args)
    assert code == 0, err
    assert "reached the goal" in stdout
    assert outputs["--out"].stat().st_size > 10_000 and outputs["--html"].stat().st_size > 10_000


@pytest.mark.parametrize("args, message", [
    (["--planner", "warp"], "unknown planner 'warp'"),
    (["--friction", "-1"], "--friction: must be a finite number >= 0.001 and <= 10.0, got '-1'"),
    (["--speed", "nan"], "--speed: must be a finite number > 0.0 and <= 50.0, got 'nan'"),
    (["--out", "x.xyz"], "--out: must end in .png or .pdf or .svg, got 'x.xyz'"),
])
def test_the_main_job_refuses_bad_input_in_one_line_before_any_work(run_script, args, message):
    code, stdout, err = run_script("plan_and_hop", *args)
    assert code == 2 and message in err and len(err.splitlines()) == 1 and not stdout
