"""Bad input to the scripts users run: every probe exits 2 with one line naming the bad value (and its bound,
``drakeslip.bounds``) before any planning or simulation starts. A damaged cache line is run again with one warning,
Ctrl-C ends a run in one line with no process left, and a planner's target on a one-cell terrain is the goal.
``python3 tests/test_probes.py`` runs every probe as a user would and prints the markdown table of
docs/verification.md (the command, what it must get, what it got), with the probes of tests/test_probes_sim.py."""
import copy
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SUITE = "suites/step.json"
NESTED = "[" * 50_000 + "]" * 50_000   # deeper than a JSON parser recurses; short enough for one argument
BIG = int("1" + "0" * 399)                # a 400-digit integer: no float holds it


def suite_with(path: tuple, value) -> str:
    """The first two cases of SUITE as a suite file's text, with the field at ``path`` set to ``value``."""
    doc = json.loads((ROOT / SUITE).read_text())
    doc["cases"] = doc["cases"][:2]
    return json.dumps(edited(doc, path, value))


def plan_with(path: tuple, value) -> str:
    """A valid plan file's text (one foothold on flat ground), with the field at ``path`` set to ``value``."""
    doc = {"format": "drakeslip-plan/2", "planner": "step", "apex": {"x": -1.0, "z": 0.9, "xdot": 2.0},
           "terrain": {"x0": -3.0, "cell": 0.1, "heights": [0.0] * 100, "ditch_height": -1.0},
           "params": {"mass": 7.0, "leg_length": 0.5, "stiffness": 3200.0, "gravity": 9.81, "friction": 0.8,
                      "min_leg_length": 0.3},
           "goal_x": 6.0, "target_x": -0.6, "footholds": [-0.6], "leg_angles": [None], "apexes": [[None] * 3]}
    return json.dumps(edited(doc, path, value))


def edited(doc, path: tuple, value):
    doc = copy.deepcopy(doc)
    *parents, last = path
    target = doc
    for key in parents:
        target = target[key]
    target[last] = value
    return doc


# the files probes read, made in the probe's folder TMP: name -> (what it holds, its text)
FILES = {
    "cell25.json": ("S with cases[0].terrain.cell = 25", lambda: suite_with(("cases", 0, "terrain", "cell"), 25)),
    "cell1e-9.json": ("S with cases[0].terrain.cell = 1e-9",
                      lambda: suite_with(("cases", 0, "terrain", "cell"), 1e-9)),
    "speed.json": ("S with cases[0].apex.xdot = 1e308", lambda: suite_with(("cases", 0, "apex", "xdot"), 1e308)),
    "position.json": ("S with cases[0].apex.x = 1e308", lambda: suite_with(("cases", 0, "apex", "x"), 1e308)),
    "height.json": ("S with cases[0].terrain.heights[5] = 1e308",
                    lambda: suite_with(("cases", 0, "terrain", "heights", 5), 1e308)),
    "big-friction.json": ("S with friction = a 400-digit integer", lambda: suite_with(("friction",), BIG)),
    "big-x.json": ("S with cases[0].apex.x = a 400-digit integer", lambda: suite_with(("cases", 0, "apex", "x"), BIG)),
    "nested.json": ("50,000 nested JSON arrays", lambda: NESTED),
    "big-mass-plan.json": ("a plan with params.mass = a 400-digit integer", lambda: plan_with(("params", "mass"), BIG)),
    "stiffness-plan.json": ("a plan with params.stiffness = 1e308",
                            lambda: plan_with(("params", "stiffness"), 1e308)),
    "gravity-plan.json": ("a plan with params.gravity = 1e308", lambda: plan_with(("params", "gravity"), 1e308)),
    "speed-plan.json": ("a plan with apex.xdot = 1e308", lambda: plan_with(("apex", "xdot"), 1e308)),
}

# (script, arguments, text the one line of stderr must contain); {dir} is a folder made for the probe, {bad} a
# file of 100 bytes that is not a weights file, {missing} a path that does not exist, {tmp} the probe's folder
# holding FILES
PROBES = [
    ("evaluate", ["--suite", SUITE, "--out", "{dir}"], "--out: '{dir}' is a folder"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--controller", "{missing}"], "--controller:"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--controller", "{bad}"], "bad.pt"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--planners", "lstm",
                  "--options", '{{"lstm": {{"model": "{bad}"}}}}'], "bad.pt"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--executed", "0"], "--executed: must be an integer in [1, inf], got"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--executed", "-1"], "--executed: must be an integer in [1, inf], got"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--planners", ","], "--planners: must name at least one"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--map-filter", "4"], "--map-filter: map_filter must be odd"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--noise", "loud"], "unknown noise profile 'loud'"),
    ("evaluate", ["--suite", "{tmp}/cell25.json", "--out", "{tmp}/r.json"],
     "cases[0].terrain.cell must be a positive finite number in [0.001, 10] m, got 25"),
    ("evaluate", ["--suite", "{tmp}/cell1e-9.json", "--out", "{tmp}/r.json"],
     "cases[0].terrain.cell must be a positive finite number in [0.001, 10] m, got 1e-09"),
    ("evaluate", ["--suite", "{tmp}/speed.json", "--out", "{tmp}/r.json"],
     "cases[0].apex.xdot must be a finite number in [-50, 50] m/s, got 1e+308"),
    ("evaluate", ["--suite", "{tmp}/position.json", "--out", "{tmp}/r.json"],
     "cases[0].apex.x must be a finite number in [-10000, 10000] m, got 1e+308"),
    ("evaluate", ["--suite", "{tmp}/height.json", "--out", "{tmp}/r.json"],
     "cases[0].terrain.heights[5] must be a finite number in [-10000, 10000] m, got 1e+308"),
    ("evaluate", ["--suite", "{tmp}/big-friction.json", "--out", "{tmp}/r.json"],
     "friction must be a positive finite number in [0.001, 10], got 1000000000000000... (400 characters)"),
    ("evaluate", ["--suite", "{tmp}/nested.json", "--out", "{tmp}/r.json"], "nested.json is nested too deeply"),
    ("evaluate", ["--suite", SUITE, "--out", "{tmp}/r.json", "--options", NESTED],
     "--options is nested too deeply to read as JSON"),
    ("plan_and_hop", ["--friction", "-1"], "--friction: must be a finite number >= 0.001 and <= 10.0, got '-1'"),
    ("plan_and_hop", ["--speed", "nan"], "--speed: must be a finite number > 0.0 and <= 50.0, got 'nan'"),
    ("plan_and_hop", ["--speed", "1e308"], "--speed: must be a finite number > 0.0 and <= 50.0, got '1e308'"),
    ("plan_and_hop", ["--out", "x.xyz"], "--out: must end in .png or .pdf or .svg, got 'x.xyz'"),
    ("plan_and_hop", ["--html", "replay.htm"], "--html: must end in .html, got 'replay.htm'"),
    ("plan_and_hop", ["--noise", "realistic*2x"], "--noise: noise scale in 'realistic*2x' must be a number"),
    ("verify_plan", ["--plan", "{missing}"], "--plan:"),
    ("verify_plan", ["--plan", "{bad}"], "bad.pt"),
    ("verify_plan", ["--plan", "{tmp}/big-mass-plan.json"],
     "params: SlipParams.mass must be a positive finite number in [0.001, 10000] kg, got 1000000000000000..."),
    ("verify_plan", ["--plan", "{tmp}/stiffness-plan.json"],
     "params: SlipParams.stiffness must be a positive finite number in [0.01, 1e+09] N/m, got 1e+308"),
    ("verify_plan", ["--plan", "{tmp}/gravity-plan.json"],
     "params: SlipParams.gravity must be a positive finite number in [0.1, 100] m/s^2, got 1e+308"),
    ("verify_plan", ["--plan", "{tmp}/speed-plan.json"],
     "apex.xdot must be a finite number in [-50, 50] m/s, got 1e+308"),
    ("verify_plan", ["--plan", "{tmp}/nested.json"], "nested.json is nested too deeply"),
    ("robustness", ["--plan", "{bad}"], "bad.pt"),
    ("robustness", ["--plan", "{bad}", "--noise", "realistic*-1"], "--noise"),
    ("robustness", ["--plan", "{bad}", "--map-filter", "2"], "--map-filter must be odd"),
    ("model_check", ["--suite", SUITE, "--out", "{dir}"], "--out: '{dir}' is a folder"),
    ("make_plan", ["--suite", SUITE, "--planner", "step", "--case", "999", "--out", "{dir}/../p.json"], "--case"),
    ("make_plan", ["--suite", "{tmp}/big-x.json", "--planner", "step", "--case", "0", "--out", "{tmp}/p.json"],
     "cases[0].apex.x must be a finite number in [-10000, 10000] m, got 1000000000000000..."),
]


def make_files(folder: Path) -> dict:
    """The probes' files in ``folder``; returns the placeholders' values."""
    (folder / "bad.pt").write_bytes(b"\x80not a weights file" + bytes(82))
    (folder / "out.json").mkdir(exist_ok=True)   # a folder where a results file would go
    for name, (_, text) in FILES.items():
        (folder / name).write_text(text())
    return {"dir": str(folder / "out.json"), "bad": str(folder / "bad.pt"), "missing": str(folder / "missing.pt"),
            "tmp": str(folder)}


@pytest.mark.parametrize("script, args, message", PROBES,
                         ids=[f"{s} {' '.join(a[-2:])[:60]}" for s, a, _ in PROBES])
def test_a_bad_argument_exits_2_in_one_line_before_any_work(tmp_path, run_script, script, args, message):
    fill = make_files(tmp_path)
    code, out, err = run_script(script, *(a.format(**fill) for a in args))   # in this process: no start-up cost
    assert code == 2, (code, err[-800:])
    assert len(err.splitlines()) == 1 and message.format(**fill) in err, err[:800]
    assert "reproduce with" not in out + err   # refused before the run was announced


# ---- a damaged cache line, Ctrl-C, a one-cell terrain -------------------------------------------------------

def damaged_cache_command(folder: Path) -> list[str]:
    """An evaluation of one case whose cache line has lost its ``success`` field (after a first run made it)."""
    doc = json.loads(suite_with(("name",), "one"))
    (folder / "one.json").write_text(json.dumps({**doc, "cases": doc["cases"][:1]}))
    return ["--suite", str(folder / "one.json"), "--planners", "heuristic", "--backend", "fast", "--quiet", "--out",
            str(folder / "r.json")]


def damage_cache(folder: Path) -> Path:
    """Remove ``success`` from the result of every line of the evaluation's cache; returns the cache's path."""
    cache = folder / "r.json.cases.jsonl"
    lines = [json.loads(line) for line in cache.read_text().splitlines()]
    for line in lines:
        del line["result"]["success"]
    cache.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return cache


def test_a_cached_case_lacking_success_is_run_again_with_one_warning(tmp_path, run_script):
    args = damaged_cache_command(tmp_path)
    assert run_script("evaluate", *args)[0] == 0
    first = json.loads((tmp_path / "r.json").read_text())
    cache = damage_cache(tmp_path)
    code, _, err = run_script("evaluate", *args)
    assert code == 0
    assert err.splitlines() == [f"warning: cache {cache}: 1 damaged line skipped (line 1: no field 'success'); its "
                                "result is computed again"]
    again = json.loads((tmp_path / "r.json").read_text())
    outcome = lambda results: [(c["id"], c["success"], c["failure"], c["final_x"], [p["footholds"] for p in c["plans"]])
                               for c in results["planners"]["heuristic"]["cases"]]
    assert outcome(again) == outcome(first)   # the case ran again, to the same result
    assert "success" in json.loads(cache.read_text().splitlines()[-1])["result"]


def session_processes(session: int) -> list[int]:
    """The live processes of a session (zombies, already dead, left out), from /proc."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z" and int(fields[3]) == session:
                found.append(int(entry.name))
    return found


def interrupt_evaluation(folder: Path) -> tuple:
    """Ctrl-C, as a terminal sends it (SIGINT to the process group), to a two-process evaluation once it saved a
    result. Returns (exit status, stderr, results in the cache, processes of the run left after 10 s). The hops run
    on Drake so that the run lasts tens of seconds after its first result: on the fast step map the whole suite can
    be done before the signal arrives."""
    out = folder / "ctrl-c.json"
    cache = Path(str(out) + ".cases.jsonl")
    job = subprocess.Popen([sys.executable, str(ROOT / "examples" / "evaluate.py"), "--suite", str(ROOT / SUITE),
                            "--planners", "heuristic", "--backend", "drake", "--jobs", "2", "--quiet", "--out",
                            str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                           start_new_session=True)
    try:
        deadline = time.monotonic() + 180
        while job.poll() is None and time.monotonic() < deadline and not (
                cache.exists() and cache.read_bytes().count(b"\n") >= 1):
            time.sleep(0.1)
        os.killpg(job.pid, signal.SIGINT)
        _, err = job.communicate(timeout=60)
    finally:
        if job.poll() is None:
            job.kill()
    deadline = time.monotonic() + 10
    while session_processes(job.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = session_processes(job.pid)
    for pid in left:   # do not leave them to the next test
        os.kill(pid, signal.SIGKILL)
    return job.returncode, err, len(cache.read_text().splitlines()), left


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc (Linux)")
def test_ctrl_c_ends_a_run_in_one_line_saying_what_was_saved(tmp_path):
    code, err, saved, left = interrupt_evaluation(tmp_path)
    assert code == -signal.SIGINT   # ended by SIGINT, as an interrupted program does (a shell shows 130)
    cache = tmp_path / "ctrl-c.json.cases.jsonl"
    assert err.splitlines() == [f"evaluate.py: interrupted: {saved} of 150 results saved in {cache}; rerun the same "
                                "command to resume"] and saved >= 1
    assert not left, f"processes of the run left after Ctrl-C: {left}"


ONE_CELL = "planners.make(NAME).plan(ApexState(-1, 0.9, 2), Terrain([0.0]), 6.0, SlipParams())"


def one_cell_targets() -> dict:
    """Each nominal planner's plan toward x = 6 on a terrain of one cell (flat forever): (target_x, success)."""
    import planners
    from drakeslip import ApexState, SlipParams, Terrain

    return {name: (plan.target_x, plan.success) for name in ("heuristic", "angle", "step", "lstm", "lstm-guided")
            for plan in [planners.make(name).plan(ApexState(-1, 0.9, 2), Terrain([0.0]), 6.0, SlipParams())]}


def test_a_planners_target_on_a_one_cell_terrain_is_the_goal():
    assert one_cell_targets() == {name: (6.0, True) for name in ("heuristic", "angle", "step", "lstm", "lstm-guided")}


def test_a_perception_window_ends_where_the_robot_sees():
    """The window of the receding-horizon loop is known only up to its last cell: a goal beyond it is aimed at
    1 m short of the window's edge."""
    import planners
    from drakeslip import ApexState, SlipParams, Terrain

    window = Terrain.flat().perceived(-1.0)
    assert window.known_end == window.x_end == 7.0 and Terrain.flat().known_end == float("inf")
    assert planners.make("step").plan(ApexState(-1, 0.9, 2), window, 10.0, SlipParams()).target_x == 6.0


def test_an_apex_too_fast_for_any_hopper_is_refused_by_the_planner_api():
    import planners
    from drakeslip import ApexState, SlipParams, Terrain

    with pytest.raises(ValueError, match=r"apex.xdot must be a finite number in \[-50, 50\] m/s, got 1000000000000.0"):
        planners.make("step").plan(ApexState(-1, 0.9, 1e12), Terrain([0.0]), 6.0, SlipParams())


# ---- the table of docs/verification.md ----------------------------------------------------------------------

def run_probe(script: str, args: list, fill: dict) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "examples" / f"{script}.py"), *(a.format(**fill) for a in args)],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)


def markdown() -> str:
    import tempfile

    def shown(text: str, folder: Path) -> str:
        text = text.replace(NESTED, "'[[[…]]]'").replace(str(folder), "TMP").replace("TMP/out.json/../", "TMP/")
        return text.replace(SUITE, "S").replace("|", "\\|")

    rows = ["| probe | expected | observed (exit status: stderr) |", "|---|---|---|"]
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        fill = make_files(folder)
        for script, args, _ in PROBES:
            run = run_probe(script, args, fill)
            command = shown(" ".join(a.format(**fill) for a in args), folder)
            rows.append(f"| `{script}.py {command}` | 2, one line | {run.returncode}: "
                        f"`{shown(run.stderr.strip(), folder)}` |")
        args = damaged_cache_command(folder)
        run_probe("evaluate", args, {})
        damage_cache(folder)
        run = run_probe("evaluate", args, {})
        rows.append(f"| `evaluate.py {shown(' '.join(args), folder)}`, its cache line's result lacking `success` | "
                    f"0, one warning line, the case run again | {run.returncode}: "
                    f"`{shown(run.stderr.strip(), folder)}` |")
        code, err, _, left = interrupt_evaluation(folder)
        rows.append(f"| Ctrl-C (SIGINT to the process group) of `evaluate.py --suite S --planners heuristic --backend "
                    f"drake --jobs 2 --quiet --out TMP/ctrl-c.json` once it saved a result | ended by SIGINT (a shell "
                    f"shows 130), one line, no process left | {code}: `{shown(err.strip(), folder)}`; processes left: "
                    f"{len(left)} |")
    targets = one_cell_targets()
    got = ", ".join(f"{name}: target {t:g}, {'a plan' if ok else 'no plan'}" for name, (t, ok) in targets.items())
    rows.append(f"| `{ONE_CELL}`, NAME each nominal planner | target 6, a plan | {got} |")
    from test_probes_sim import markdown_rows   # the edges of the simulation: tests/test_probes_sim.py

    sim_rows, sim_legend = markdown_rows()
    legend = "; ".join([*(f"TMP/{name}: {what}" for name, (what, _) in FILES.items()),
                        "TMP/one.json: the first case of S", sim_legend])
    return "\n".join(rows + sim_rows) + f"\n\nFiles: {legend}."


if __name__ == "__main__":
    print(markdown())
