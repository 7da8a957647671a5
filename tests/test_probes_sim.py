"""The edges of the simulation, probed as a user would: starts too high or too fast for the hopper (refused in one
line, exit 2, naming the bound in its units), a hopper of a tenth of the Moon's gravity (it plans on the fast step
map and its plan is certified on Drake: every time limit is in the hopper's time units), a hop that outlasts the
Drake simulator's limit (a TIMEOUT, exit 3: no verdict, not a counterexample), an integrator that raises and NaN
derivatives (exit 3 in one line naming what failed, within seconds; a fault injected, as no valid input reaches
them), and the replay of planners that predict no apexes. Each probe is a row of the table of docs/verification.md
(``python3 tests/test_probes.py`` prints it with test_probes.py's, ``markdown_rows``)."""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
LOW_GRAVITY = {"format": "drakeslip-hopper/1", "name": "tenth-moon", "mass": 7.0, "leg_length": 0.5,
               "stiffness": 3200.0, "gravity": 0.1}


def flat_plan(apex, heights, ditch_height=-1.0, footholds=(-0.6,), leg_angles=(None,)) -> dict:
    """A plan file's fields: the paper's hopper from ``apex`` over ``heights`` (10 cm cells from x = -3)."""
    return {"format": "drakeslip-plan/2", "planner": "step", "apex": dict(zip(("x", "z", "xdot"), apex)),
            "terrain": {"x0": -3.0, "cell": 0.1, "heights": list(heights), "ditch_height": ditch_height},
            "params": {"mass": 7.0, "leg_length": 0.5, "stiffness": 3200.0, "gravity": 9.81, "friction": 0.8,
                       "min_leg_length": 0.3},
            "goal_x": 6.0, "target_x": footholds[-1], "footholds": list(footholds), "leg_angles": list(leg_angles),
            "apexes": [[None] * 3 for _ in footholds]}


def pit_plan() -> dict:
    """One hop from the edge of a pit whose solid floor is 200 m down (x in [0, 20)): the fall lasts 6.4 s."""
    heights = [0.0] * 30 + [-200.0] * 200 + [0.0] * 50
    return flat_plan((-0.05, 0.9, 1.0), heights, ditch_height=-300.0, footholds=(6.4,), leg_angles=(0.1,))


def high_apex_suite() -> dict:
    doc = json.loads((ROOT / "suites" / "step.json").read_text())
    doc["cases"] = doc["cases"][:2]
    doc["cases"][0]["apex"]["z"] = 1000.0
    return doc


def low_gravity_plan(folder: Path) -> dict:
    """The Step-space planner's plan on the fast step map for the LOW_GRAVITY hopper over flat ground with a 10 cm
    step at x = 3, from plan_and_hop's default start made the hopper's."""
    import planners
    from drakeslip import StepLengthController, Terrain
    from drakeslip.hopper_file import load_hopper
    from planners.formats.plan import PlanRecord
    from planners.formats.suite_draw import one_case

    hopper = load_hopper(folder / "low-gravity.json")
    terrain = Terrain([0.0] * 50 + [0.1] * 100, 0.1, -2.0)
    suite = one_case(terrain, hopper=hopper)
    case = suite.cases[0]
    planner = planners.make("step", controller=StepLengthController.load_default())
    plan = planner.plan(case.apex, case.terrain.perceived(case.apex.x), suite.goal_x, hopper.params)
    assert plan.success, plan.message
    return PlanRecord.from_plan(plan, case.apex, terrain, suite.goal_x, hopper.params, hopper).to_dict()


# the files probes read, made in the probe's folder TMP: name -> (what it holds, its text given the folder)
FILES = {
    "low-gravity.json": ("a hopper file: the paper's hopper under g = 0.1 m/s^2", lambda _: LOW_GRAVITY),
    "low-gravity-plan.json": ("the step planner's plan (fast step map) for that hopper over flat ground with a "
                              "10 cm step", low_gravity_plan),
    "flat-plan.json": ("a plan of one foothold on flat ground", lambda _: flat_plan((-1.0, 0.9, 2.0), [0.0] * 100)),
    "pit-plan.json": ("a plan of one hop into a pit 200 m deep (a solid floor)", lambda _: pit_plan()),
    "high-apex-plan.json": ("a plan starting 1000 m above flat ground",
                            lambda _: flat_plan((-1.0, 1000.0, 2.0), [0.0] * 100)),
    "high-apex-suite.json": ("S with cases[0].apex.z = 1000", lambda _: high_apex_suite()),
}

# Faults no valid input reaches, injected into the Drake hopper before a script runs: its stance dynamics give NaN,
# or raise as a numba kernel does on a division by zero
FAULTS = {
    "nan": "dyn.stance_derivatives = lambda *args: (math.nan,) * 4",
    "raise": "dyn.stance_derivatives = lambda *args: 1 / 0",
}
FAULT_NAMES = {"nan": "the stance dynamics made to give NaN", "raise": "the stance dynamics made to raise "
               "ZeroDivisionError (as numba does on a division by zero)"}

# (script, arguments, fault or None, expected exit status(es), text stderr's one line or stdout must hold, what the
# table says is expected); {tmp} is the probe's folder holding FILES
PROBES = [
    ("plan_and_hop", ["--terrain", "ditch", "--noise", "none", "--height", "10000"], None, (2,),
     "the start apex z=10000 m is 10000 m above the ground at x=0: more than 10 leg lengths (5 m for this hopper",
     "2, one line"),
    ("plan_and_hop", ["--terrain", "ditch", "--noise", "none", "--height", "1000"], None, (2,),
     "more than 10 leg lengths (5 m for this hopper", "2, one line"),
    ("plan_and_hop", ["--hopper", "{tmp}/low-gravity.json", "--speed", "20"], None, (2,),
     "xdot=20 m/s is faster than 5 sqrt(g L0) (1.118 m/s for this hopper", "2, one line"),
    ("evaluate", ["--suite", "{tmp}/high-apex-suite.json", "--out", "{tmp}/r.json"], None, (2,),
     "cases[0].apex z=1000 m is 1000 m above the ground at x=-1: more than 10 leg lengths", "2, one line"),
    ("verify_plan", ["--plan", "{tmp}/high-apex-plan.json"], None, (2,),
     "apex z=1000 m is 1000 m above the ground at x=-1: more than 10 leg lengths", "2, one line"),
    ("make_suites", ["--families", "step", "--seed", "7000", "--heights", "6", "--out", "{tmp}/suites"], None, (2,),
     "the paper's start at 1 m/s: its apex z=6 m is 6 m above the ground at x=-1: more than 10 leg lengths",
     "2, one line"),
    ("make_suites", ["--families", "step", "--seed", "7000", "--heights", "1.5", "--hopper", "{tmp}/low-gravity.json",
                     "--out", "{tmp}/suites"], None, (2,),
     "no start of heights [1.5] m and speeds [1.0, 1.5, 2.0, 2.5, 3.0] m/s takes the paper's hopper two hops",
     "2, one line"),
    ("hop", ["--z", "8", "--out", "{tmp}/hop.png"], None, (2,),
     "the start apex z=8 m is 8 m above the ground at x=0: more than 10 leg lengths", "2, one line"),
    ("verify_plan", ["--plan", "{tmp}/low-gravity-plan.json"], None, (0,), "CERTIFIED: all", "0, CERTIFIED"),
    ("verify_plan", ["--plan", "{tmp}/pit-plan.json"], None, (3,),
     "simulation stopped: TIMEOUT at hop 0: the hop outlasted the simulator's 5 s limit", "3, one line: TIMEOUT"),
    ("verify_plan", ["--plan", "{tmp}/flat-plan.json"], "nan", (3,),
     "simulation stopped: non-finite derivatives (nan, nan, nan, nan) in STANCE", "3, one line, in seconds"),
    ("verify_plan", ["--plan", "{tmp}/flat-plan.json"], "raise", (3,),
     "simulation stopped: the integrator failed at t=", "3, one line"),
    ("plan_and_hop", ["--planner", "heuristic", "--terrain", "step", "--goal", "3", "--noise", "none", "--out",
                      "{tmp}/h.png", "--html", "{tmp}/heuristic.html"], None, (0, 1), "replay: {tmp}/heuristic.html",
     "0 or 1, the replay written"),
    ("plan_and_hop", ["--planner", "lstm", "--terrain", "step", "--goal", "3", "--noise", "none", "--out",
                      "{tmp}/l.png", "--html", "{tmp}/lstm.html"], None, (0, 1), "replay: {tmp}/lstm.html",
     "0 or 1, the replay written"),
]

DRIVER = """
import math, runpy, sys
import drakeslip.dynamics as dyn
{fault}
sys.argv = [{script!r}, *{args!r}]
runpy.run_path({script!r}, run_name="__main__")
"""


def make_files(folder: Path) -> dict:
    """The probes' files in ``folder`` (the hopper file first: the low-gravity plan reads it)."""
    for name, (_, make) in FILES.items():
        (folder / name).write_text(json.dumps(make(folder)))
    return {"tmp": str(folder)}


def run_probe(script: str, args: list, fault: str | None, fill: dict) -> subprocess.CompletedProcess:
    """The script run as a user would, in a process of its own; with a fault, through DRIVER."""
    path, args = str(ROOT / "examples" / f"{script}.py"), [a.format(**fill) for a in args]
    command = [sys.executable, path, *args] if fault is None else \
        [sys.executable, "-c", DRIVER.format(fault=FAULTS[fault], script=path, args=args)]
    return subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=300)


@pytest.fixture(scope="module")
def probe_folder():
    with tempfile.TemporaryDirectory() as name:
        yield make_files(Path(name))


@pytest.mark.parametrize("script, args, fault, codes, message, _", PROBES,
                         ids=[f"{s} {' '.join(a[-2:])[:50]}{' ' + f if f else ''}" for s, a, f, *_ in PROBES])
def test_a_probe_at_the_edges_of_the_simulation(probe_folder, run_script, script, args, fault, codes, message, _):
    """Refused before any work (2), certified (0), or stopped with no verdict (3), each in the one line it must
    give. A probe with a fault runs in a process of its own, so that a hang (NaN derivatives used to take minutes)
    fails at the time limit instead of stopping the tests."""
    if fault is None:   # in this process: no start-up cost
        code, out, err = run_script(script, *(a.format(**probe_folder) for a in args))
    else:
        run = run_probe(script, args, fault, probe_folder)
        code, out, err = run.returncode, run.stdout, run.stderr
    assert code in codes, (code, err[-800:])
    if code in (2, 3):
        assert len(err.splitlines()) == 1 and message.format(**probe_folder) in err, err[-800:]
        assert code == 3 or "reproduce with" not in out   # refused before the run was announced
    else:
        assert message.format(**probe_folder) in out, out[-800:]
    if "--html" in args:
        assert Path(args[args.index("--html") + 1].format(**probe_folder)).stat().st_size > 10_000


def test_the_planners_api_goes_on_past_the_bounds_without_the_energy_graph():
    """planner.plan takes any apex inside the absolute bounds (a start reached mid-run is not held to the start
    bounds): from 10 km up, the pruned stage is skipped, naming the graph it would need, instead of asking for
    298 GiB; the Drake hop from there is a TIMEOUT after the hopper's 5 s, not a STALL."""
    import planners
    from drakeslip import ApexState, FailureMode, SlipParams, ditch_world, simulate

    terrain = ditch_world(3).perceived(0.0)
    plan = planners.make("step").plan(ApexState(0.0, 1e4, 2.0), terrain, 10.0, SlipParams())
    assert not plan.success and "pruned search: skipped, the energy graph from x=0 to x=7 at energy height 1e+04 m " \
        "would have 200080 cells of 0.1 m, more than 10000" in plan.message
    run = simulate(ApexState(0.0, 1e4, 2.0), [0.1], terrain, log=False)
    assert run.failure is FailureMode.TIMEOUT and run.failure_event.time == pytest.approx(5.0, abs=0.01)


def test_the_energy_graphs_flight_limit_is_the_pairwise_formula():
    """``CellGraph.fly_limit`` (n log n) gives the same number, to the bit, as the pairwise definition of (5) it
    replaces, on random terrains of few and of many levels, ditches among them."""
    from drakeslip import SlipParams, Terrain
    from planners.search import energy_graph as eg

    def pairwise(g, a):
        k = np.flatnonzero((g.hi > a) & (g.lo < a + 2.0 * g.reach + g.far + 2.0 * g.H + 1.0))
        lo, hi, h = np.maximum(g.lo[k], a), g.hi[k], g.h[k]
        cap = lo[:, None] + 2.0 * (g.H - np.minimum(h[:, None], h[None, :])) + 2.0 * eg.GEOMETRY_SLACK
        fails = np.triu(cap < hi[None, :])
        return float(np.min(np.where(fails, np.maximum(g.lo[k][None, :], cap), np.inf), initial=np.inf))

    rng = np.random.default_rng(0)
    for digits in (1, 1, 6, 6) * 10:
        heights = np.round(rng.uniform(-0.6, 0.6, 120), digits)
        heights[rng.random(120) < 0.1] = -1.0
        graph = eg.CellGraph((rng.uniform(-1, 3), rng.uniform(1.0, 2.0), rng.uniform(0.5, 3.0)),
                             Terrain(heights, 0.1, -2.0), 8.0, SlipParams(friction=rng.uniform(0.3, 1.2)))
        for a in [*(graph.hi[graph.landable] + graph.reach), *rng.uniform(-2.0, 10.0, 10)]:
            assert graph.fly_limit(a) == pairwise(graph, a)


def markdown_rows() -> tuple[list[str], str]:
    """The table rows of PROBES (run as a user would) for test_probes.py's table, and the files' legend."""
    rows = []
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        fill = make_files(folder)
        for script, args, fault, codes, message, expected in PROBES:
            run = run_probe(script, args, fault, fill)
            command = " ".join(a.format(**fill) for a in args).replace(str(folder), "TMP")
            injected = f", {FAULT_NAMES[fault]}" if fault else ""
            said = run.stderr.strip() if run.returncode in (2, 3) else next(
                (line for line in run.stdout.splitlines() if message.format(**fill) in line), run.stdout.strip()[-200:])
            said = said.replace(str(folder), "TMP").replace("|", "\\|")
            rows.append(f"| `{script}.py {command}`{injected} | {expected} | {run.returncode}: `{said}` |")
    legend = "; ".join(f"TMP/{name}: {what}" for name, (what, _) in FILES.items())
    return rows, legend
