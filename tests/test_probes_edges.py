"""The edges of the input, tried as a careless or hostile user would: the multibody backend given another hopper,
hopper folders missing what their manifest lists, an output over an input, damaged cache lines, terrain files at
the limits of what the code can do, a full disk, Ctrl-C while a script loads its libraries, and a huge name full of
control characters. Each gets one clear line and the right exit status before any work, or the right answer.
``python3 tests/test_probes_edges.py`` runs every probe as a user would and prints the markdown table of
docs/verification.md ("The edges of the input")."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from test_probes import plan_with, suite_with   # the bad-input probes' file makers

ROOT = Path(__file__).resolve().parents[1]

MINE = {"name": "mine", "mass": 3.0, "leg_length": 0.3, "stiffness": 1000.0, "friction": 0.6}
LONG_NAME = "\x1b[2J" + "x" * 50_000_000   # a terminal's clear-screen sequence, then 50 MB


def make_files(tmp: Path) -> None:
    """The probes' files in ``tmp`` (listed under the table)."""
    from drakeslip.hopper_file import load_hopper, make_hopper_folder
    from drakeslip.jobs.files import record_digest
    from planners.formats.suite import save_suite
    from planners.formats.suite_draw import draw_suite

    (tmp / "mine.json").write_text(json.dumps(MINE))
    mine = load_hopper(tmp / "mine.json")
    save_suite(draw_suite("ditch", 7000, mine, n_terrains=1), tmp / "mine-suite.json")
    for name in ("missing-weights", "unlisted", "untrained"):
        make_hopper_folder(mine, tmp / name)
    (tmp / "missing-weights" / "lstm_expert.pt").write_bytes(b"weights")
    record_digest(tmp / "missing-weights" / "lstm_expert.pt")
    (tmp / "missing-weights" / "lstm_expert.pt").unlink()
    (tmp / "unlisted" / "ranker.pt").write_bytes(b"weights")
    (tmp / "no-manifest").mkdir()
    (tmp / "no-manifest" / "hopper.json").write_text(json.dumps(MINE))
    (tmp / "s.json").write_text(suite_with(("name",), "two"))
    (tmp / "c.json.cases.jsonl").write_text(suite_with(("name",), "two"))
    (tmp / "p.json").write_text(plan_with(("planner",), "step"))
    os.symlink(tmp / "s.json", tmp / "link.json")
    os.link(tmp / "s.json", tmp / "hard.json")
    (tmp / "t.json").write_text("x,height\n0,0\n0.1,0\n20,0\n")
    (tmp / "ditch.json").write_text(json.dumps(MINE))
    (tmp / "hf").mkdir()
    (tmp / "hf" / "hopper.json").write_text(json.dumps(MINE))
    (tmp / "x1e308.csv").write_text("x,height\n0,0\n1e308,0\n")
    (tmp / "nano.csv").write_text("x,height\n" + "".join(f"{k * 1e-9:.9f},0\n" for k in range(3)) + "1,0\n")
    (tmp / "far.csv").write_text("x,height\n" + "".join(f"{9980 + k * 0.001:.3f},{0.02 if (k // 500) % 4 == 0 else 0}\n"
                                                       for k in range(12001)))
    (tmp / "rows.csv").write_text("".join(f"{k},0\n" for k in range(200_001)))
    with open(tmp / "big.csv", "wb") as f:   # a 17 MiB file, sparse: nothing is written but its size
        f.truncate(17 * 2**20)
    (tmp / "long-name.json").write_text(json.dumps({**MINE, "name": LONG_NAME}))
    (tmp / "bad\nname.json").write_text("{")


# (script, arguments, exit status, text the one line of stderr holds); {tmp} is the folder holding the files
PROBES = [
    # 1. the multibody robot is built for any hopper; a learned correction of its template is one robot's
    ("evaluate", ["--suite", "{tmp}/mine-suite.json", "--backend", "multibody", "--planners", "heuristic",
                  "--template", "drakeslip/multibody/template_corrected.json", "--out", "{tmp}/r.json"], 2,
     "the template's learned correction was trained on another hopper's robot than the robot of this 3 kg, 0.3 m "
     "hopper (examples/fit_correction.py --hopper trains one for it)"),
    # 2. a hopper folder holds what its manifest lists, and nothing unlisted
    ("plan_and_hop", ["--hopper", "{tmp}/missing-weights"], 2,
     "hopper folder {tmp}/missing-weights: lstm_expert.pt, listed in its SHA256SUMS, is missing"),
    ("plan_and_hop", ["--hopper", "{tmp}/no-manifest"], 2, "hopper folder {tmp}/no-manifest has no SHA256SUMS"),
    ("plan_and_hop", ["--hopper", "{tmp}/unlisted"], 2,
     "hopper folder {tmp}/unlisted: ranker.pt is not listed in its SHA256SUMS"),
    # 3. no output lands on an input
    ("evaluate", ["--suite", "{tmp}/s.json", "--out", "{tmp}/s.json"], 2,
     "--out would write '{tmp}/s.json', which is the --suite file '{tmp}/s.json'"),
    ("verify_plan", ["--plan", "{tmp}/p.json", "--out", "{tmp}/p.json"], 2,
     "--out would write '{tmp}/p.json', which is the --plan file"),
    ("evaluate", ["--suite", "{tmp}/s.json", "--out", "{tmp}/./hf/../s.json"], 2, "which is the --suite file"),
    ("evaluate", ["--suite", "{tmp}/s.json", "--out", "{tmp}/link.json"], 2, "which is the --suite file"),
    ("evaluate", ["--suite", "{tmp}/s.json", "--out", "{tmp}/hard.json"], 2, "which is the --suite file"),
    ("evaluate", ["--suite", "{tmp}/c.json.cases.jsonl", "--out", "{tmp}/c.json"], 2,
     "--out would write '{tmp}/c.json.cases.jsonl', which is the --suite file"),
    ("make_plan", ["--terrain", "{tmp}/t.json", "--planner", "step", "--out", "{tmp}/t.json"], 2,
     "which is the --terrain file"),
    ("evaluate", ["--suite", "{tmp}/mine-suite.json", "--hopper", "{tmp}/untrained", "--out",
                  "{tmp}/untrained/hopper.json"], 2, "which is the --hopper file '{tmp}/untrained/hopper.json'"),
    ("make_suites", ["--hopper", "{tmp}/ditch.json", "--families", "ditch", "--terrains", "1", "--out", "{tmp}"], 2,
     "--out would write '{tmp}/ditch.json', which is the --hopper file"),
    ("train_hopper", ["--hopper", "{tmp}/hf/hopper.json", "--out", "{tmp}/hf", "--dry-run"], 2,
     "--out would write '{tmp}/hf/hopper.json', which is the --hopper file"),
    # 5. terrain files: bounds the code can keep, checked before the work
    ("plan_and_hop", ["--terrain", "{tmp}/x1e308.csv"], 2,
     "{tmp}/x1e308.csv, line 3: x must be a number in [-10000, 10000] m, got '1e308'"),
    ("plan_and_hop", ["--terrain", "{tmp}/nano.csv"], 2,
     "{tmp}/nano.csv, lines 2 and 3: rows 1e-09 m apart, closer than the smallest cell, 0.001 m"),
    ("plan_and_hop", ["--terrain", "{tmp}/rows.csv"], 2,
     "{tmp}/rows.csv, line 200001: the rows up to here hold more than 400000 numbers"),
    ("plan_and_hop", ["--terrain", "{tmp}/big.csv"], 2,
     "{tmp}/big.csv is 17 MiB, more than a terrain file's 16 MiB"),
    ("make_plan", ["--terrain", "{tmp}/far.csv", "--planner", "step", "--out", "{tmp}/far-plan.json"], 0,
     None),
    # 8. names and paths echoed shortened, their control characters escaped
    ("plan_and_hop", ["--hopper", "{tmp}/long-name.json"], 2,
     "name must be a string of 1 to 100 printable characters, no / or \\, got '\\x1b[2Jxxxxxxxx... (50000004 "
     "characters)"),
    ("evaluate", ["--suite", "{tmp}/bad\nname.json", "--out", "{tmp}/r.json"], 2,
     "suite file {tmp}/bad\\nname.json is not valid JSON"),
]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("edges")
    make_files(tmp)
    return tmp


@pytest.mark.parametrize("script, args, status, message", PROBES,
                         ids=[f"{s} {' '.join(a)[-60:]}" for s, a, _, _ in PROBES])
def test_an_edge_of_the_input_gets_one_line_and_its_status(files, run_script, script, args, status, message):
    code, out, err = run_script(script, *(a.format(tmp=files) for a in args))
    assert code == status, (code, err[-800:])
    if message is not None:
        assert len(err.splitlines()) == 1 and message.format(tmp=files) in err, err[:800]
        assert len(err) < 2000 and "reproduce with" not in out + err   # refused before the run was announced


def test_the_library_refuses_another_robots_correction(files):
    from drakeslip.hopper_file import load_hopper
    from planners.closed_loop import ClosedLoopConfig
    from planners.formats.suite import load_suite
    from verification.evaluation import evaluate

    corrected = load_hopper(ROOT / "drakeslip" / "multibody" / "template_corrected.json").params
    with pytest.raises(ValueError, match="learned correction was trained on another hopper's robot"):
        evaluate(load_suite(files / "mine-suite.json"), {"heuristic": None}, progress=False,
                 config=ClosedLoopConfig(backend="multibody", template=corrected))


# ---- 4. damaged cache lines ---------------------------------------------------------------------------------

DAMAGE = {   # what is done to the result of the cache's one line -> the warning's reason
    '"success": "maybe"': (lambda r: {**r, "success": "maybe"}, "success must be true or false, got 'maybe'"),
    "the result null": (lambda r: None, "the result must be an object, got None"),
    "plans[0] lacking footholds": (lambda r: {**r, "plans": [{k: v for k, v in r["plans"][0].items()
                                                              if k != "footholds"}]},
                                   "no field 'plans[0].footholds'"),
    'plans[0].footholds ["a"]': (lambda r: {**r, "plans": [{**r["plans"][0], "footholds": ["a"]}]},
                                 "plans[0].footholds must be a list of numbers, got ['a']"),
    "plans[0].ode_calls 1.5": (lambda r: {**r, "plans": [{**r["plans"][0], "ode_calls": 1.5}]},
                               "plans[0].ode_calls must be a count, got 1.5"),
}


def cache_command(tmp: Path) -> list[str]:
    """An evaluation of the first case of S on the fast backend, caching in TMP/one.json's folder."""
    doc = json.loads(suite_with(("name",), "one"))
    (tmp / "one.json").write_text(json.dumps({**doc, "cases": doc["cases"][:1]}))
    return ["--suite", str(tmp / "one.json"), "--planners", "heuristic", "--backend", "fast", "--quiet", "--out",
            str(tmp / "one-results.json")]


def damage(tmp: Path, how: str) -> None:
    cache = tmp / "one-results.json.cases.jsonl"
    entry = json.loads(cache.read_text().splitlines()[-1])   # the last good line
    cache.write_text(json.dumps({**entry, "result": DAMAGE[how][0](entry["result"])}) + "\n")


def outcome(path: Path) -> list:
    return [(c["id"], c["success"], c["failure"], c["final_x"], [p["footholds"] for p in c["plans"]])
            for c in json.loads(path.read_text())["planners"]["heuristic"]["cases"]]


@pytest.mark.parametrize("how", DAMAGE)
def test_a_damaged_cache_line_is_run_again_with_one_warning(tmp_path, run_script, how):
    args = cache_command(tmp_path)
    assert run_script("evaluate", *args)[0] == 0
    first = outcome(tmp_path / "one-results.json")
    damage(tmp_path, how)
    code, _, err = run_script("evaluate", *args)
    cache = tmp_path / "one-results.json.cases.jsonl"
    assert code == 0, err
    assert err.splitlines() == [f"warning: cache {cache}: 1 damaged line skipped (line 1: {DAMAGE[how][1]}); its "
                                "result is computed again"]
    assert outcome(tmp_path / "one-results.json") == first


# ---- 6. a full disk; 7. Ctrl-C while a script loads -------------------------------------------------------

# Runs examples/evaluate.py as __main__ with one write of the run failing as on a full disk: FAIL is "cache" (making
# a cache line durable) or "results" (the results file, its temporary file opened on /dev/full).
FULL_DISK = """
import errno, os, runpy, sys, tempfile
fail, sys.argv = sys.argv[1], sys.argv[2:]
if fail == "cache":
    def fsync(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    os.fsync = fsync
else:
    mkstemp = tempfile.mkstemp
    def on_full_device(*args, **kwargs):
        fd, name = mkstemp(*args, **kwargs)
        if os.path.basename(name).startswith("r.json."):
            os.close(fd)
            fd = os.open("/dev/full", os.O_WRONLY)
        return fd, name
    tempfile.mkstemp = on_full_device
runpy.run_path(sys.argv[0], run_name="__main__")
"""
FULL_ARGS = ["--suite", "{suite}", "--planners", "heuristic", "--backend", "fast", "--cases", "1", "--quiet",
             "--out", "{tmp}/r.json"]


def run_full(tmp: Path, fail: str | None, stdout=subprocess.PIPE) -> subprocess.CompletedProcess:
    """evaluate.py on one case with ``fail`` ("cache", "results"; None: stdout as given, e.g. /dev/full)."""
    args = [a.format(tmp=tmp, suite=ROOT / "suites" / "step.json") for a in FULL_ARGS]
    script = str(ROOT / "examples" / "evaluate.py")
    command = [sys.executable, "-c", FULL_DISK, fail, script, *args] if fail else [sys.executable, script, *args]
    return subprocess.run(command, stdout=stdout, stderr=subprocess.PIPE, text=True, cwd=ROOT, timeout=300)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux) to fill a device")
def test_a_full_disk_is_one_line_with_status_1_and_leaves_the_files_whole(tmp_path):
    with open("/dev/full", "w") as full:
        run = run_full(tmp_path, None, stdout=full)
    assert run.returncode == 1
    assert run.stderr.splitlines() == ["evaluate.py: error: No space left on device (ENOSPC)"]
    (tmp_path / "r.json").write_text("earlier results\n")
    run = run_full(tmp_path, "cache")
    cache = tmp_path / "r.json.cases.jsonl"
    assert run.returncode == 1 and len(run.stderr.splitlines()) == 1, run.stderr
    assert run.stderr.startswith(f"evaluate.py: error: {cache}: No space left on device (ENOSPC); ")
    run = run_full(tmp_path, "results")
    assert run.returncode == 1
    assert run.stderr.splitlines() == [f"evaluate.py: error: {tmp_path / 'r.json'}: No space left on device "
                                       f"(ENOSPC); 1 of 1 results saved in {cache}; rerun the same command to resume"]
    assert (tmp_path / "r.json").read_text() == "earlier results\n"   # untouched, and no temporary file left
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.json.cases.jsonl"]


# Runs examples/SCRIPT.py as __main__ with its import of numpy held up (a slow disk, a cold cache): it says so on
# stdout and waits, so that Ctrl-C lands while the script is loading its libraries, every time.
SLOW_NUMPY = """
import importlib.abc, runpy, sys, time
class SlowNumpy(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            sys.meta_path.remove(self)
            print("loading numpy", flush=True)
            time.sleep(60)
        return None
sys.meta_path.insert(0, SlowNumpy())
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
"""


def interrupt_while_loading(script: str, tmp: Path) -> subprocess.CompletedProcess:
    """Ctrl-C to examples/SCRIPT.py while it imports numpy."""
    job = subprocess.Popen([sys.executable, "-c", SLOW_NUMPY, str(ROOT / "examples" / f"{script}.py"), "--out",
                            str(tmp / "x.json")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        loading = job.stdout.readline()
        job.send_signal(signal.SIGINT)
        out, err = job.communicate(timeout=60)
    finally:
        if job.poll() is None:
            job.kill()
    return subprocess.CompletedProcess(job.args, job.returncode, loading + out, err)


LOADING = ("evaluate", "plan_and_hop", "hop", "train_controller")


@pytest.mark.parametrize("script", LOADING)
def test_ctrl_c_while_a_script_loads_its_libraries_is_one_line(tmp_path, script):
    run = interrupt_while_loading(script, tmp_path)
    assert run.stdout.startswith("loading numpy") and run.returncode == -signal.SIGINT
    assert run.stderr.splitlines() == [f"{script}.py: interrupted: no results were cached"], run.stderr[-800:]


def test_every_script_makes_ctrl_c_one_line_before_it_loads_a_library():
    """Each script imports drakeslip.jobs.cli (which installs the one-line report) before anything but the
    standard library, and that import, and drakeslip.cli_physics's after it, load nothing heavy, not even numpy."""
    import ast

    late = []
    for path in sorted((ROOT / "examples").glob("*.py")):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                module = node.module if isinstance(node, ast.ImportFrom) else node.names[0].name
                if module == "drakeslip.jobs" and [a.name for a in node.names] == ["cli"]:
                    break
                if module != "__future__" and module.split(".")[0] not in sys.stdlib_module_names:
                    late.append(f"{path.name}: {module} before drakeslip.jobs.cli")
                    break
        else:
            late.append(f"{path.name}: no top-level import of drakeslip.jobs.cli")
    assert not late, late
    probe = ("import sys; import drakeslip.jobs.cli, drakeslip.cli_physics; "
             "print(sorted(m for m in ('numpy', 'torch') if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert run.stdout.strip() == "[]", run.stderr


# ---- the table of docs/verification.md ------------------------------------------------------------------------

def test_the_page_lists_every_edge_probe_in_order():
    text = (ROOT / "docs" / "verification.md").read_text()
    section = text[text.index("### The edges of the input"):]
    lines = section[section.index("| probe |"):].splitlines()[2:]
    rows = lines[:next(i for i, line in enumerate(lines) if not line.startswith("|"))]
    scripts = [script for script, _, _, _ in PROBES] + ["evaluate"] * (len(DAMAGE) + 3) + list(LOADING)
    assert len(rows) == len(scripts)
    for row, script in zip(rows, scripts):
        assert row.startswith(f"| `{script}.py "), row


def markdown() -> str:
    import tempfile

    def shown(text: str, tmp: Path) -> str:
        text = text.replace(str(tmp), "TMP").replace(str(ROOT / "suites" / "step.json"), "S")
        return text.replace("\n", "\\n").replace("|", "\\|")

    def row(command: str, expected: str, code: int, err: str, tmp: Path, note: str = "") -> str:
        return f"| `{shown(command, tmp)}` | {expected} | {code}: `{shown(err.strip(), tmp)}`{note} |"

    rows = ["| probe | expected | observed (exit status: stderr) |", "|---|---|---|"]
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        make_files(tmp)
        for script, args, status, _ in PROBES:
            args = [a.format(tmp=tmp) for a in args]
            t0 = time.perf_counter()
            run = subprocess.run([sys.executable, str(ROOT / "examples" / f"{script}.py"), *args],
                                 capture_output=True, text=True, cwd=ROOT, timeout=600)
            took = f" ({time.perf_counter() - t0:.1f} s)"
            err = run.stderr if status == 2 else run.stdout.strip().splitlines()[-1] + run.stderr
            rows.append(row(f"{script}.py {' '.join(args)}", f"{status}" + (", one line" if status == 2 else ""),
                            run.returncode, err, tmp, took))
        args = cache_command(tmp)
        subprocess.run([sys.executable, str(ROOT / "examples" / "evaluate.py"), *args], capture_output=True, cwd=ROOT)
        for how in DAMAGE:
            damage(tmp, how)
            run = subprocess.run([sys.executable, str(ROOT / "examples" / "evaluate.py"), *args], capture_output=True,
                                 text=True, cwd=ROOT)
            rows.append(row(f"evaluate.py {' '.join(args)}", f"its cache line with {how}: 0, one warning, the case "
                            "run again", run.returncode, run.stderr, tmp))
        with open("/dev/full", "w") as full:
            run = run_full(tmp, None, stdout=full)
        command = "evaluate.py " + " ".join(a.format(tmp=tmp, suite=ROOT / "suites" / "step.json") for a in FULL_ARGS)
        rows.append(row(f"{command} > /dev/full", "1, one line", run.returncode, run.stderr, tmp))
        (tmp / "r.json").write_text("earlier results\n")
        for fail, what in (("cache", "making its cache line durable"), ("results", "writing the results file")):
            run = run_full(tmp, fail)
            rows.append(row(command, f"no space left on the device when {what} (FULL_DISK): 1, one line, the files "
                            "whole", run.returncode, run.stderr, tmp,
                            f"; TMP/r.json holds {(tmp / 'r.json').read_text().strip()!r}"))
        for script in LOADING:
            run = interrupt_while_loading(script, tmp)
            rows.append(row(f"{script}.py --out TMP/x.json", "Ctrl-C while it imports numpy (held up, SLOW_NUMPY): "
                            "ended by SIGINT, one line",
                            run.returncode, run.stderr, tmp))
    legend = ("TMP/mine.json: a 3 kg, 0.3 m hopper (1000 N/m, friction 0.6); TMP/mine-suite.json: a ditch suite drawn "
              "for it; TMP/missing-weights, TMP/unlisted, TMP/untrained: its "
              "hopper folders, the first with lstm_expert.pt listed in SHA256SUMS and deleted, the second with an "
              "unlisted ranker.pt, the third only hopper.json; TMP/no-manifest: hopper.json alone; TMP/s.json: two "
              "cases of S, also as TMP/c.json.cases.jsonl, TMP/link.json (a symbolic link) and TMP/hard.json (a hard "
              "link); TMP/p.json: a plan; TMP/t.json, TMP/ditch.json, TMP/hf/hopper.json: a terrain and two hopper "
              "files; TMP/x1e308.csv: a profile with a row at x = 1e308; TMP/nano.csv: rows 1e-9 m apart; "
              "TMP/far.csv: 12,001 rows 1 mm apart from x = 9980 (2 cm steps); TMP/rows.csv: 200,001 rows; "
              "TMP/big.csv: 17 MiB; TMP/long-name.json: a hopper named ESC [2J and 50,000,000 x; TMP/bad\\nname.json: "
              "'{' in a file whose name holds a newline; TMP/one.json: the first case of S")
    return "\n".join(rows) + f"\n\nFiles: {legend}."


if __name__ == "__main__":
    print(markdown())
