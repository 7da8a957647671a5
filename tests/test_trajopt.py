"""The multi-hop trajectory optimization (planners/trajopt/): its equations agree with the simulators, it
converges and verifies on flat ground, and bad seeds are rejected clearly."""
import math

import numpy as np
import pytest

from drakeslip import SlipParams, Terrain, step_batch
from drakeslip import dynamics as dyn
from drakeslip.terrain import DITCH_HEIGHT
from drakeslip.units import units_of
from planners.learned.lstm import load_model
from planners.trajopt import autodiff as G
from planners.trajopt import solve
from planners.trajopt.config import COLD_STRIDES, COLLOCATIONS, TrajoptConfig, TrajoptError
from planners.trajopt.guess import build_guess
from planners.trajopt.planner import TrajoptPlanner, make_problem
from planners.trajopt.program import SlipTrajopt
from planners.trajopt.seeds import check_seed, cold_footholds, seed_footholds, seed_planner
from planners.trajopt.segments import assign_segments, segment_of, segments
from planners.trajopt.solve import optimize

PARAMS = SlipParams()
APEX = (0.0, 1.0, 2.0)


def executed_footholds(apex, angles, terrain, params=PARAMS):
    """Footholds and apexes the fast step map reaches with these leg angles (all hops must succeed)."""
    footholds, apexes = [], [tuple(apex)]
    for theta in angles:
        r = step_batch(apexes[-1], [theta], terrain, params).result(0)
        assert r.ok, r.failure
        footholds.append(r.touchdown_x)
        apexes.append(tuple(r.next_apex))
    return np.array(footholds), np.array(apexes)


@pytest.fixture(scope="module")
def flat_problem():
    terrain = Terrain.flat()
    return make_problem(APEX, terrain, 3.0, PARAMS)


def test_generic_equations_are_the_compiled_ones():
    """The optimizer evaluates the very source numba compiled: same numbers, on floats and on Duals."""
    p = PARAMS.as_array()
    state = (0.12, 0.43, 1.7, -0.9, 0.02, 0.0)
    assert G.generic(dyn.stance_derivatives)(*state, p) == pytest.approx(dyn.stance_derivatives(*state, p), rel=1e-15)
    assert G.generic(dyn.foot_position)(0.3, 1.0, 0.25, p) == pytest.approx(dyn.foot_position(0.3, 1.0, 0.25, p))
    v = G.Dual.variables(np.array(state))
    out = G.generic(dyn.stance_derivatives)(*v, p)
    assert [float(o.val) for o in out] == pytest.approx(list(dyn.stance_derivatives(*state, p)), rel=1e-15)
    # forward-mode derivatives against central differences
    h = 1e-6
    for j in range(6):
        up, down = list(state), list(state)
        up[j] += h
        down[j] -= h
        fd = (np.array(dyn.stance_derivatives(*up, p)) - np.array(dyn.stance_derivatives(*down, p))) / (2 * h)
        assert np.array([o.der[j] for o in out]) == pytest.approx(fd, rel=1e-6, abs=1e-6)


def test_constraints_agree_with_the_fast_step_map_on_a_simulated_seed():
    """Footholds the fast step map reaches, executed by the controller into an initial guess: every equality
    of the program holds (dynamics defects ~0), the guess reproduces the step map's apexes, and a perturbed
    stance breaks the dynamics defect."""
    terrain = Terrain.flat()
    footholds, apexes = executed_footholds(APEX, [0.25, 0.27, 0.27], terrain)
    problem = make_problem(APEX, terrain, apexes[-1][0] - 0.1, PARAMS)
    config = TrajoptConfig().for_hopper(problem.units)
    segs = assign_segments(terrain, footholds, config.edge_margin, problem.window_end)
    guess = build_guess(APEX, footholds, segs, terrain, PARAMS, config.node_times())
    assert guess.fast_ok, guess.fast_failure
    assert guess.footholds == pytest.approx(footholds, abs=1e-6)  # the controller lands where the seed says
    assert guess.apexes == pytest.approx(apexes, abs=1e-9)
    program = SlipTrajopt(APEX, terrain, segs, PARAMS, problem.target_x, config)
    x = program.guess_vector(guess)
    v = program.violations(x)
    assert v["dynamics"] < 1e-6, v          # Chebyshev collocation on the integrated stance
    assert v["touchdown"] < 1e-12 and v["foot_on_terrain"] < 1e-12 and v["liftoff"] < 1e-9, v
    assert v["apex"] < 1e-6, v              # liftoff -> apex in closed form vs the step map's apex
    assert v["clearance"] == 0 and v["friction"] == 0 and v["leg_length"] == 0, v
    # the defect really measures the dynamics: move one mid-stance knot by 1 mm
    i = program.prog.FindDecisionVariableIndices([program.S[1][10, 1]])[0]
    x[i] += 1e-3
    assert program.violations(x)["dynamics"] > 1e-3


@pytest.mark.parametrize("collocation", COLLOCATIONS)
def test_collocation_jacobian_matches_its_declared_sparsity_and_finite_differences(collocation):
    from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff

    terrain = Terrain.flat()
    footholds, _ = executed_footholds(APEX, [0.25, 0.27], terrain)
    config = TrajoptConfig(collocation=collocation, knots=8).for_hopper(units_of(PARAMS))
    segs = assign_segments(terrain, footholds, config.edge_margin)
    guess = build_guess(APEX, footholds, segs, terrain, PARAMS, config.node_times())
    program = SlipTrajopt(APEX, terrain, segs, PARAMS, config=config)
    x = program.guess_vector(guess)
    binding = program.groups["dynamics"][1]
    idx = np.array(program.prog.FindDecisionVariableIndices(binding.variables()))
    c = binding.evaluator()
    jac = ExtractGradient(c.Eval(InitializeAutoDiff(x[idx])))
    allowed = np.zeros_like(jac, dtype=bool)
    for r, col in c.gradient_sparsity_pattern():
        allowed[r, col] = True
    assert np.all(jac[~allowed] == 0)
    h = 1e-7
    fd = np.stack([(c.Eval(x[idx] + h * e) - c.Eval(x[idx] - h * e)) / (2 * h) for e in np.eye(idx.size)], axis=1)
    assert jac == pytest.approx(fd, abs=1e-5 * max(1.0, np.abs(fd).max()))


def test_flat_ground_cold_start_converges_and_verifies_on_drake(flat_problem):
    record = optimize(flat_problem, "cold")
    assert record["error"] is None
    assert record["converged"], record["status"]
    assert record["verified"], record["verification"]
    assert record["iterations"] is not None and record["iterations"] > 0
    assert record["solve_time_s"] > 0
    # no seed planner; each guess built executes every foothold once on the fast step map
    assert record["ode_calls"] == record["hops"] * sum(a["guess"] != "polish" for a in record["attempts"]) > 0
    # Drake lands where the optimizer planned (open loop, 3 hops: the transcription is accurate)
    assert np.array(record["verification"]["footholds"]) == pytest.approx(record["footholds"], abs=1e-5)
    assert record["apexes"][-1][0] >= flat_problem.target_x


def test_a_foothold_on_a_ditch_segment_is_rejected_clearly():
    heights = np.zeros(230)
    heights[40:45] = DITCH_HEIGHT            # a ditch over [1.0, 1.5)
    terrain = Terrain(heights)
    with pytest.raises(TrajoptError, match=r"foothold 1 \(x=1\.200 m\) lies on a ditch segment \[1\.00, 1\.50\)"):
        assign_segments(terrain, [0.5, 1.2, 2.0], 0.03)
    problem = make_problem(APEX, terrain, 3.0, PARAMS)
    record = optimize(problem, np.array([0.5, 1.2, 2.0]))
    assert not record["converged"] and "ditch" in record["error"]
    ditch = segment_of(terrain, 1.2)
    with pytest.raises(TrajoptError, match="ditch"):
        SlipTrajopt(APEX, terrain, [segment_of(terrain, 0.5), ditch], PARAMS)


def test_a_segment_too_short_for_the_edge_margin_is_rejected():
    heights = np.zeros(230)
    heights[40] = 0.1                        # one 10 cm cell
    with pytest.raises(TrajoptError, match="too short"):
        assign_segments(Terrain(heights), [1.05], 0.06)


def test_unknown_seed_errors_clearly(flat_problem):
    with pytest.raises(ValueError, match="unknown seed 'astar'; known seeds: cold, heuristic, step, lstm"):
        seed_footholds("astar", flat_problem)
    with pytest.raises(ValueError, match="unknown seed 'astar'"):
        optimize(flat_problem, "astar")
    with pytest.raises(ValueError, match="unknown seed"):
        TrajoptPlanner(seed="astar")


def test_the_seed_model_is_the_checkpoint_an_lstm_seed_reads_unless_its_options_name_one():
    """``TrajoptConfig.seed_model`` (``trajopt_warmstart.py --seed-model``) replaces an LSTM seed's ``model``; a
    seed's own ``model`` option wins; other seeds read no model."""
    from planners.checkpoints import EXPERT_WEIGHTS, PAPER_WEIGHTS, RANKER_WEIGHTS, SPATIAL_WEIGHTS
    from planners.registry import files_read

    config = {"seed_model": str(PAPER_WEIGHTS)}
    maps = {"seed.map_model": str(SPATIAL_WEIGHTS)}   # the learned seeds' height-map model, read on maps only
    assert files_read("trajopt", {"seed": "lstm-guided", "config": config}) == {"seed.model": str(PAPER_WEIGHTS),
                                                                              **maps}
    assert files_read("trajopt", {"seed": "lstm", "config": config}) == {"seed.model": str(PAPER_WEIGHTS),
                                                                       "seed.ranker": str(RANKER_WEIGHTS), **maps}
    own = {"seed": "lstm-guided", "seed_options": {"model": str(EXPERT_WEIGHTS)}, "config": config}
    assert files_read("trajopt", own) == {"seed.model": str(EXPERT_WEIGHTS), **maps}
    assert files_read("trajopt", {"seed": "step", "config": config}) == {}
    assert seed_planner("lstm-guided", None, 24, str(PAPER_WEIGHTS), 0).net.model.config == load_model().config


def test_a_seed_variant_plans_with_its_options(flat_problem):
    """NAME@VARIANT is the named seed's planner built with the given options; options it does not take, a
    missing model file and options for the cold gait are errors naming the seed."""
    from planners.checkpoints import EXPERT_WEIGHTS

    options = {"model": str(EXPERT_WEIGHTS), "lazy": True, "conditioning": "apex"}
    planner = seed_planner("lstm-guided@expert", options, TrajoptConfig.max_hops, None, 0)
    assert planner.lazy and planner.conditioning == "apex"
    preset = seed_planner("lstm-guided@expert", None, TrajoptConfig.max_hops, None, 0)  # planners.registry.PRESETS
    assert preset.lazy and preset.conditioning == "apex" and preset.net.model.config == planner.net.model.config
    assert planner.net.model.config == load_model(EXPERT_WEIGHTS).config != load_model().config
    footholds, calls = seed_footholds("lstm-guided@expert", flat_problem, options=options)
    assert calls > 0 and np.all(np.diff(footholds) > 0) and footholds[-1] >= flat_problem.target_x
    with pytest.raises(ValueError, match="options for the lstm-guided@x seed: .*'bogus'"):
        check_seed("lstm-guided@x", {"bogus": 1})
    with pytest.raises(ValueError, match="options for the lstm@x seed: .*nope.pt"):
        check_seed("lstm@x", {"model": "nope.pt"})
    with pytest.raises(ValueError, match="the cold@x seed is a fixed gait and takes no options"):
        check_seed("cold@x", {"extra_hops": 1})
    with pytest.raises(ValueError, match="unknown seed 'astar@x'"):
        TrajoptPlanner(seed="astar@x")


def test_segments_and_cold_seed_cover_the_problem(flat_problem):
    terrain = Terrain(np.r_[np.zeros(40), np.full(10, 0.2), np.zeros(180)])
    segs = segments(terrain)
    assert [(s.lo, s.hi, s.height) for s in segs] == [(-math.inf, pytest.approx(1.0), 0.0),
                                                      (pytest.approx(1.0), pytest.approx(2.0), 0.2),
                                                      (pytest.approx(2.0), math.inf, 0.0)]
    cold = cold_footholds(flat_problem)
    steps = np.diff(cold)
    assert np.all(steps > 0) and steps == pytest.approx(np.full(steps.size, steps[0]))
    assert cold[-1] >= flat_problem.target_x
    # the cold seed's other starts: the same span in more or fewer equal steps
    for sample, extra in enumerate(COLD_STRIDES):
        other, calls = seed_footholds("cold", flat_problem, sample=sample)
        assert calls == 0
        assert other.size == max(cold.size + extra, 2)
        assert (other[0], other[-1]) == pytest.approx((cold[0], cold[-1]))
    with pytest.raises(ValueError, match="the step seed has one start; sample 1"):
        seed_footholds("step", flat_problem, sample=1)


def test_a_start_that_is_not_verified_is_followed_by_the_next(flat_problem, monkeypatch):
    """starts > 1: optimize tries the seed's next start until one is verified; the record is that start's,
    its costs add up every start, and a seed with one start is not repeated."""
    calls = []

    def fake_start(problem, seed, sample, config, true_terrain, verify_on_drake, seed_options):
        calls.append((seed, sample))
        ok = sample == 1
        return {"seed": seed, "converged": ok, "verified": ok, "error": None, "status": f"start {sample}",
                "seed_time_s": 0.5, "solve_time_s": 2.0, "iterations": 10}

    monkeypatch.setattr(solve, "optimize_start", fake_start)
    record = optimize(flat_problem, "lstm-guided", TrajoptConfig(starts=3))
    assert calls == [("lstm-guided", 0), ("lstm-guided", 1)]
    assert record["verified"] and record["status"] == "start 1"
    assert [s["verified"] for s in record["starts"]] == [False, True]
    assert (record["seed_time_s"], record["solve_time_s"], record["iterations"]) == (1.0, 4.0, 20)
    calls.clear()
    record = optimize(flat_problem, "step", TrajoptConfig(starts=3))
    assert calls == [("step", 0)] and "starts" not in record
    calls.clear()  # a variant of a seed with several starts has them too
    optimize(flat_problem, "lstm-guided@lazy", TrajoptConfig(starts=3), seed_options={"lazy": True})
    assert calls == [("lstm-guided@lazy", 0), ("lstm-guided@lazy", 1)]


def test_an_unconverged_point_near_feasible_is_polished_to_convergence(flat_problem):
    """A solve cut short (here by a 3-iteration limit) ends near feasible; solving again from its own point
    (what optimize does for SNOPT's numerical difficulties) reaches the same optimum as an uncut solve."""
    footholds = cold_footholds(flat_problem)
    segs = assign_segments(flat_problem.terrain, footholds, 0.03, flat_problem.window_end)
    guess = build_guess(flat_problem.apex, footholds, segs, flat_problem.terrain, PARAMS,
                          TrajoptConfig().node_times())
    short = SlipTrajopt(flat_problem.apex, flat_problem.terrain, segs, PARAMS, flat_problem.target_x,
                          TrajoptConfig(major_iterations=3)).solve(guess)
    assert not short.converged and short.x.shape == (short.x.size,)
    full = SlipTrajopt(flat_problem.apex, flat_problem.terrain, segs, PARAMS, flat_problem.target_x)
    polished, direct = full.solve(short.x), full.solve(guess)
    assert polished.converged and direct.converged
    assert polished.cost == pytest.approx(direct.cost, rel=1e-3, abs=1e-4)


@pytest.mark.parametrize("seed", ["lstm@paper", "lstm-guided"])
def test_learned_seeds_give_increasing_footholds_to_the_target(seed):
    from drakeslip import ditch_world

    problem = make_problem(APEX, ditch_world(1003), 4.0, PARAMS)
    footholds, calls = seed_footholds(seed, problem)
    assert calls > 0 if seed == "lstm-guided" else calls == 0   # the mode planner simulates nothing
    assert footholds.size >= 2 and np.all(np.diff(footholds) > 0)
    assert footholds[-1] >= problem.target_x and np.all(footholds[:-1] < problem.target_x)


def test_the_one_step_lstm_seed_is_asked_again_at_each_predicted_apex():
    """The mode planner with the ranker plans one foothold; as a seed it is re-queried at the apex the fast step
    map predicts after each, so its footholds are the closed-loop rollout's, to the target."""
    from drakeslip import ditch_world
    from drakeslip.controller import StepLengthController
    from planners import make
    from planners.checkpoints import EXPERT_WEIGHTS, RANKER_WEIGHTS

    options = {"model": str(EXPERT_WEIGHTS), "max_steps": 1, "ranker": str(RANKER_WEIGHTS)}
    terrain = ditch_world(1003)
    problem = make_problem(APEX, terrain, 4.0, PARAMS)
    footholds, calls = seed_footholds("lstm@ranked", problem, options=options)
    assert footholds.size >= 3 and calls == footholds.size - 1  # one prediction per foothold before the last
    assert footholds[-1] >= problem.target_x and np.all(footholds[:-1] < problem.target_x)
    planner, controller = make("lstm", **options), StepLengthController.load_default()
    apex = problem.apex
    for x in footholds:  # each foothold is the planner's answer at the apex the previous ones lead to
        assert planner.plan(apex, terrain, problem.goal_x, PARAMS).footholds[0] == x
        apex = step_batch(apex, [controller.leg_angle(apex, x, terrain)], terrain, PARAMS).result(0).next_apex
    short, _ = seed_footholds("lstm@ranked", problem, max_hops=2, options=options)
    assert np.array_equal(short, footholds[:2])


def test_config_checks():
    with pytest.raises(ValueError, match="collocation"):
        TrajoptConfig(collocation="trapezoid")
    with pytest.raises(ValueError, match="solver"):
        TrajoptConfig(solver="gurobi")
    with pytest.raises(ValueError, match="starts must be an integer in 1..5, got 0"):
        TrajoptConfig(starts=0)
    with pytest.raises(ValueError, match="polish_violation must be non-negative"):
        TrajoptConfig(polish_violation=-1.0)


def test_as_a_planner_it_returns_the_optimized_plan():
    import planners

    plan = planners.make("trajopt", seed="cold").plan(APEX, Terrain.flat(), 3.0, PARAMS)
    assert plan.success, plan.message
    assert len(plan.footholds) == len(plan.leg_angles) == len(plan.apexes) >= 2
    assert np.all(np.isfinite(plan.leg_angles)) and plan.apexes[-1][0] >= plan.target_x
    assert plan.ode_calls in (len(plan.footholds), 2 * len(plan.footholds))   # one or two guesses, no seed search
    step_seeded = planners.make("trajopt", seed="step").plan(APEX, Terrain.flat(), 3.0, PARAMS)
    seed_calls = planners.make("step").plan(APEX, Terrain.flat(), 3.0, PARAMS).ode_calls
    assert step_seeded.success and step_seeded.ode_calls >= seed_calls + len(step_seeded.footholds)


@pytest.mark.slow  # two trajectory optimizations and their Drake checks, twice
def test_warmstart_example_writes_the_documented_format_and_resumes(tmp_path):
    """examples/trajopt_warmstart.py on a one-case suite: the documented JSON format, a verified cold start, a
    rerun of the same code served from the case cache, and a bad --starts refused with the bad value named."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    from drakeslip import ApexState
    from planners.formats.suite import Case, Suite, save_suite

    root = Path(__file__).resolve().parents[1]
    suite_path, out = tmp_path / "flat.json", tmp_path / "out.json"
    save_suite(Suite("flat", 1.5, 0.8, (Case("flat-v2", Terrain.flat(), ApexState(-1.0, 1.0, 2.0)),)), suite_path)
    cmd = [sys.executable, str(root / "examples" / "trajopt_warmstart.py"), "--suite", str(suite_path),
           "--seeds", "cold", "--starts", "2", "--out", str(out), "--quiet"]
    runs = [subprocess.run(cmd, capture_output=True, text=True, cwd=root, timeout=300) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr
    block = json.loads(out.read_text())["seeds"]["cold"]
    assert {"converged_rate", "verified_rate", "first_start_verified_rate", "solve_time_median_s",
            "iterations_median", "cases"} <= set(block)
    assert block["verified_rate"] == block["first_start_verified_rate"] == 1.0
    assert len(block["cases"]) == 1 and block["cases"][0]["id"] == "flat-v2"
    assert len(Path(str(out) + ".cases.jsonl").read_text().splitlines()) == 1   # the rerun solved nothing
    assert "1 of 1 results reused" in runs[1].stdout
    from verification.provenance import code_version

    assert json.loads(out.read_text())["provenance"]["code_version"] == code_version()   # the solves' code
    bad = subprocess.run(cmd[:-5] + ["--starts", "9", "--out", str(out)], capture_output=True, text=True,
                         cwd=root, timeout=120)
    assert bad.returncode == 2 and "starts must be an integer in 1..5, got 9" in bad.stderr


@pytest.mark.slow
def test_warmstart_example_in_two_processes_gives_the_serial_records(tmp_path):
    """--jobs 2 solves the (seed, case) pairs in spawned processes: every record (iterations, verdict, leg
    angles) is the one the serial run gives, and the cache holds each pair once."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    from drakeslip import ApexState
    from planners.formats.suite import Case, Suite, save_suite

    root = Path(__file__).resolve().parents[1]
    suite_path = tmp_path / "flat.json"
    cases = (Case("flat-v2", Terrain.flat(), ApexState(-1.0, 1.0, 2.0)),
             Case("flat-v1.5", Terrain.flat(), ApexState(-1.0, 0.9, 1.5)))
    save_suite(Suite("flat", 1.5, 0.8, cases), suite_path)
    blocks = {}
    for jobs in (1, 2):
        out = tmp_path / f"out{jobs}.json"
        run = subprocess.run([sys.executable, str(root / "examples" / "trajopt_warmstart.py"), "--suite",
                              str(suite_path), "--seeds", "cold,heuristic", "--jobs", str(jobs), "--out", str(out),
                              "--quiet"], capture_output=True, text=True, cwd=root, timeout=300)
        assert run.returncode == 0, run.stderr
        blocks[jobs] = json.loads(out.read_text())["seeds"]
        assert len(Path(str(out) + ".cases.jsonl").read_text().splitlines()) == 4
    for seed in ("cold", "heuristic"):
        for serial, parallel in zip(blocks[1][seed]["cases"], blocks[2][seed]["cases"]):
            assert serial["id"] == parallel["id"]
            for field in ("converged", "verified", "iterations", "leg_angles", "seed_footholds"):
                assert serial[field] == parallel[field], (seed, serial["id"], field)
