"""The examples' exit-status contract: bad input is one line naming it and status 2 before any work (nothing
written), a run that fails its task is status 1, a run that does its task 0."""
from pathlib import Path

import pytest

SUITE = Path(__file__).resolve().parents[1] / "suites" / "step.json"


@pytest.fixture
def empty_file(tmp_path) -> Path:
    """A file that exists (so the argument types accept it) but holds no weights and no plan."""
    path = tmp_path / "empty"
    path.touch()
    return path


def refused(result, *names) -> bool:
    """Status 2, nothing on stdout and one line on stderr that names every one of ``names``."""
    code, out, err = result
    return code == 2 and not out and len(err.splitlines()) == 1 and all(name in err for name in names)


@pytest.mark.parametrize("args, names", [
    (["--planner", "expert", "--policy", "{empty}"], ["--policy", "{empty}"]),   # not weights: checked up front
    (["--explore", "0.5"], ["--explore", "angle"]),                              # only the expert explores
    (["--planner", "step", "--explore", "0.5"], ["--explore", "step"]),
])
def test_generate_dataset_refuses_before_writing_anything(run_script, tmp_path, empty_file, args, names):
    out = tmp_path / "data"
    args = [a.format(empty=empty_file) for a in args]
    result = run_script("generate_dataset", "--out", out, "--terrains", 1, "--jobs", 1, *args)
    assert refused(result, *(n.format(empty=empty_file) for n in names)), result
    assert not out.exists()


def test_hop_refuses_a_start_off_the_terrain(run_script, tmp_path):
    result = run_script("hop", "--x0", 500, "--hops", 2, "--out", tmp_path / "hop.png")
    assert refused(result, "--x0", "x=500", "not on solid ground"), result
    assert not (tmp_path / "hop.png").exists()


def test_hop_fails_when_it_stops_before_the_hops_asked_for(run_script, tmp_path):
    """0.1 m up is below the leg's length: no leg angle survives, the run stops at once."""
    code, out, _ = run_script("hop", "--hops", 2, "--z", 0.1, "--out", tmp_path / "hop.png")
    assert code == 1 and "FAILED, stopped after 0 of 2 hops" in out and "no leg angle survives" in out, out


def test_hop_completing_every_hop_succeeds(run_script, tmp_path):
    code, out, _ = run_script("hop", "--hops", 2, "--out", tmp_path / "hop.png")
    assert code == 0 and "outcome: ok, 2 hops" in out and (tmp_path / "hop.png").is_file(), out


@pytest.mark.parametrize("given", [["--speed", "2"], ["--height", "0.8"], ["--start-x", "0.5"], ["--goal", "5"],
                                   ["--speed", "2", "--goal", "5"]])
def test_make_plan_refuses_terrain_options_with_a_suite(run_script, tmp_path, given):
    out = tmp_path / "plan.json"
    result = run_script("make_plan", "--suite", SUITE, "--case", 0, "--planner", "step", "--out", out, *given)
    assert refused(result, "--suite", *given[::2]), result
    assert not out.exists()


def test_robustness_refuses_a_map_filter_without_noise(run_script, empty_file):
    result = run_script("robustness", "--plan", empty_file, "--map-filter", 3, "--noise", "none")
    assert refused(result, "--map-filter 3", "--noise"), result
