"""Inputs whose size sets the work or the memory of a call have an upper bound: the map filter's window
(``MAX_FILTER_WINDOW``), a height map file's declared shape (``HEIGHT_MAP_CELLS``, read from each .npy header before
any array is loaded), a search budget (``MAX_NODES``, ``MAX_ODE_CALLS``) and a drawn suite's terrains and starts
(``MAX_TERRAINS``, ``MAX_STARTS`` of examples/make_suites.py). A value past one is refused in one line naming it: a
library function's ValueError, a script's exit status 2 before any work (no "reproduce with" line, no file or folder
written); a value at the bound is accepted."""
import zipfile
from pathlib import Path

import numpy as np
import pytest

from drakeslip.spatial.heightmap import HeightMap, load_height_map
from drakeslip.terrain import MAX_FILTER_WINDOW, Terrain, check_window
from planners.base import MAX_NODES, MAX_ODE_CALLS, Budget

ROOT = Path(__file__).resolve().parents[1]
SUITE = str(ROOT / "suites" / "step.json")


def refused(run_script, script: str, *args) -> str:
    """The one line of stderr with which ``script`` refused ``args`` (exit status 2, before it announced a run)."""
    code, out, err = run_script(script, *args)
    assert code == 2, (code, err[-800:])
    assert len(err.splitlines()) == 1 and "reproduce with" not in out + err, err[:800]
    return err


def npz_declaring(path: Path, key: str, shape=None, dtype=None) -> Path:
    """A height map file of a 2 x 2 map whose ``key`` member's .npy header declares ``shape`` and ``dtype`` (where
    given) while its data stays the few bytes of the real array."""
    arrays = {"heights": np.zeros((2, 2)), "cell": np.array(0.1), "origin": np.zeros(2)}
    with zipfile.ZipFile(path, "w") as archive:
        for name, array in arrays.items():
            header = np.lib.format.header_data_from_array_1_0(array)
            if name == key:
                header.update({k: v for k, v in (("shape", shape), ("descr", dtype)) if v is not None})
            with archive.open(f"{name}.npy", "w") as stream:
                np.lib.format.write_array_header_1_0(stream, header)
                stream.write(array.tobytes())
    return path


# ---- the map filter's window --------------------------------------------------------------------------------

def test_a_filter_window_is_odd_and_at_most_max_filter_window():
    assert [check_window(w, "w") for w in (1, 5, MAX_FILTER_WINDOW)] == [1, 5, MAX_FILTER_WINDOW]
    for window in (MAX_FILTER_WINDOW + 2, 1001, 10**400):
        with pytest.raises(ValueError, match=f"w must be odd .*from 1 to {MAX_FILTER_WINDOW}, got") as error:
            check_window(window, "w")
        assert "\n" not in str(error.value) and str(window)[:16] in str(error.value)
    with pytest.raises(ValueError, match="denoised window"):
        Terrain(np.zeros(50)).denoised(0.01, 1001)


def test_evaluate_refuses_a_map_filter_past_the_bound_before_any_work(run_script, tmp_path):
    err = refused(run_script, "evaluate", "--suite", SUITE, "--planners", "step", "--backend", "fast", "--noise",
                  "realistic", "--map-filter", "1001", "--out", tmp_path / "r.json")
    assert f"--map-filter: map_filter must be odd (a cell and as many on each side), from 1 to {MAX_FILTER_WINDOW}, " \
           "got 1001" in err
    assert not list(tmp_path.iterdir())


def test_robustness_refuses_a_map_filter_past_the_bound_before_any_work(run_script, tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text("{}")   # never read: the flags are checked first
    err = refused(run_script, "robustness", "--plan", plan, "--map-filter", "1001", "--out", tmp_path / "r.json")
    assert "--map-filter must be odd" in err and "got 1001" in err
    assert not (tmp_path / "r.json").exists()


# ---- a height map file's declared shape ---------------------------------------------------------------------

def test_a_huge_declared_heights_shape_is_refused_before_the_array_is_read(tmp_path):
    path = npz_declaring(tmp_path / "huge.npz", "heights", shape=(100_000, 100_000))   # 10^10 cells, 80 GB
    with pytest.raises(ValueError, match=r"huge\.npz: its heights declare 100000 x 100000 cells, more than the "
                                         r"4000000 cells") as error:
        load_height_map(path)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("key, shape, dtype, message", [
    ("cell", (100_000, 100_000), None, r"cell must be one number, got shape \(100000, 100000\)"),
    ("origin", (10**12,), None, r"origin must be \(x0, y0\), got shape \(1000000000000,\)"),
    ("heights", (2, 2, 2), None, r"heights must be a 2-D \(ny, nx\) array with at least one cell, got shape"),
    ("heights", None, "|O", "heights must be numbers, got dtype object"),
])
def test_every_member_is_checked_from_its_header(tmp_path, key, shape, dtype, message):
    with pytest.raises(ValueError, match=message) as error:
        load_height_map(npz_declaring(tmp_path / "m.npz", key, shape, dtype))
    assert "\n" not in str(error.value) and "m.npz" in str(error.value)


def test_a_member_zipfile_cannot_read_is_refused_in_one_line(tmp_path):
    """An encrypted member (flag bit 0 of its local and central headers) is no .npy to read: one line, no traceback."""
    data = bytearray(npz_declaring(tmp_path / "locked.npz", "heights").read_bytes())
    for signature, flags in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        start = data.find(signature)
        while start >= 0:
            data[start + flags] |= 1
            start = data.find(signature, start + 4)
    (tmp_path / "locked.npz").write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"locked\.npz is not a readable \.npz file \(File 'heights\.npy' is "
                                         "encrypted"):
        load_height_map(tmp_path / "locked.npz")


def test_a_map_file_within_the_bounds_still_loads(tmp_path):
    loaded = load_height_map(npz_declaring(tmp_path / "small.npz", "heights"))
    assert loaded.shape == (2, 2) and loaded.cell == 0.1 and loaded.origin == (0.0, 0.0)
    HeightMap(np.ones((3, 4)), 0.05, (-1.0, -1.0)).save(tmp_path / "saved.npz")
    assert load_height_map(tmp_path / "saved.npz").shape == (3, 4)


def test_plan_and_hop_refuses_a_huge_declared_map_before_any_work(run_script, tmp_path):
    path = npz_declaring(tmp_path / "huge.npz", "heights", shape=(100_000, 100_000))
    err = refused(run_script, "plan_and_hop", "--terrain", path, "--backend", "fast", "--out", tmp_path / "x.png")
    assert "huge.npz: its heights declare 100000 x 100000 cells" in err
    assert not (tmp_path / "x.png").exists()


# ---- a search budget ----------------------------------------------------------------------------------------

def test_a_budget_is_bounded():
    assert Budget(max_nodes=MAX_NODES, max_ode_calls=MAX_ODE_CALLS).max_nodes == MAX_NODES
    for kwargs, message in ((dict(max_nodes=10**12), f"max_nodes must be an integer from 1 to {MAX_NODES}, got "
                                                     "1000000000000"),
                            (dict(max_ode_calls=2**64), f"max_ode_calls must be an integer from 1 to {MAX_ODE_CALLS}, "
                                                        f"got {2**64}"),
                            (dict(max_nodes=0), "max_nodes must be an integer of at least 1, got 0")):
        with pytest.raises(ValueError, match=message):
            Budget(**kwargs)


def test_evaluate_refuses_a_huge_node_budget_before_any_work(run_script, tmp_path):
    err = refused(run_script, "evaluate", "--suite", SUITE, "--planners", "step", "--backend", "fast",
                  "--options", '{"step": {"max_nodes": 1000000000000}}', "--out", tmp_path / "r.json")
    assert "--options for step: max_nodes must be an integer from 1 to" in err and "got 1000000000000" in err


# ---- a drawn suite's terrains and starts ---------------------------------------------------------------------

@pytest.mark.parametrize("args, named", [
    (["--families", "gaps", "--seed", "1", "--terrains", "100000"],
     "--terrains: must be an integer in [1, 1000], got '100000'"),
    (["--families", "ditch", "--seed", "1", "--speeds", ",".join(f"{1 + i / 100:g}" for i in range(51))],
     "--speeds x --heights: 51 x 2 = 102 starts per terrain, more than the 100"),
    (["--families", "step", "--seed", "7000", "--heights", "6"], "its apex z=6 m is 6 m above the ground"),
])
def test_make_suites_refuses_too_many_cases_and_leaves_no_folder(run_script, tmp_path, args, named):
    err = refused(run_script, "make_suites", *args, "--out", tmp_path / "suites")
    assert named in err
    assert not (tmp_path / "suites").exists()


def test_make_suites_draws_up_to_its_bounds(example):
    make_suites = example("make_suites")
    assert make_suites.count_or_folder(str(make_suites.MAX_TERRAINS)) == make_suites.MAX_TERRAINS


def test_a_suite_case_that_starts_at_or_past_its_goal_is_refused(tmp_path, run_script):
    """A run from there would succeed with no hop and a plan would hold no foothold: the suite is refused naming the
    case's start and the goal (a make_plan.py of such a case crashed on the empty plan)."""
    import json

    document = json.loads(Path(SUITE).read_text())
    document["goal_x"] = -50.0
    (tmp_path / "s.json").write_text(json.dumps(document))
    err = refused(run_script, "make_plan", "--suite", tmp_path / "s.json", "--case", "0", "--planner", "step",
                  "--out", tmp_path / "p.json")
    assert "cases[0].apex.x=" in err and "is not before the suite's goal_x=-50" in err
    assert not (tmp_path / "p.json").exists()


def test_a_json_object_with_a_key_given_twice_is_refused(tmp_path, run_script):
    """The parser would keep the last value silently: a hopper file, a suite or --options that gives a key twice is
    refused naming the key."""
    from drakeslip.jobs.files import parse_json

    with pytest.raises(ValueError, match=r"^--options: the key 'mass' is given twice in one object$"):
        parse_json('{"a": {"mass": 7, "mass": 8}}', "--options")
    assert parse_json('{"a": {"mass": 7}, "b": {"mass": 8}}', "x") == {"a": {"mass": 7}, "b": {"mass": 8}}
    err = refused(run_script, "evaluate", "--suite", SUITE, "--cases", "1", "--planners", "step", "--options",
                  '{"step": {"max_nodes": 5, "max_nodes": 6}}', "--out", tmp_path / "r.json")
    assert "the key 'max_nodes' is given twice" in err


def test_a_suite_field_the_reader_does_not_know_is_refused(tmp_path, run_script):
    """A case's own goal_x (a suite has one goal), or any misspelt field, would be ignored without a word."""
    import json

    document = json.loads(Path(SUITE).read_text())
    document["cases"][0]["goal_x"] = 3.0
    (tmp_path / "s.json").write_text(json.dumps(document))
    err = refused(run_script, "evaluate", "--suite", tmp_path / "s.json", "--cases", "1", "--planners", "step",
                  "--out", tmp_path / "r.json")
    assert "cases[0]: unknown field 'goal_x' (the fields are id, terrain, apex)" in err
