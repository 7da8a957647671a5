"""The spatial SLIP fitted to the spatial robot (drakeslip/spatial/multibody/fit.py): the template predicts its own
hops exactly, the fit finds the leg length and stiffness that made a set of hops, the fit file is read back as the
factors of any hopper's SLIP and a file that is not a fit is refused naming it; the hops of a loop's records."""
import json
from dataclasses import replace

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.spatial.controller import leg_angles_for
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.multibody.fit import SpatialHop, errors, fit_factors, fitted, fitted_template, \
    hops_from_plans, save_fit, summary
from drakeslip.spatial.stepmap import step3d


def hops_of(params, n: int = 24, seed: int = 3) -> list:
    """Hops of ``params``'s SLIP on level ground at random heights, from random apexes to random footholds."""
    rng = np.random.default_rng(seed)
    hops = []
    while len(hops) < n:
        level = float(rng.uniform(-0.1, 0.2))
        ground = HeightMap.flat(level, 0.05, (-5.0, -5.0), (10.0, 10.0))
        v = rng.uniform(0.5, 2.0)
        heading = rng.uniform(-0.5, 0.5)
        apex = (0.0, 0.0, level + rng.uniform(0.75, 0.95), v * np.cos(heading), v * np.sin(heading))
        foothold = (0.16 * v + rng.uniform(-0.08, 0.08), rng.uniform(-0.08, 0.08), level)
        hop = step3d(apex, leg_angles_for(apex, foothold, params), ground, params)
        if hop.ok and np.hypot(*np.subtract(hop.foothold[:2], foothold[:2])) < 1e-4:   # the foothold in reach
            hops.append(SpatialHop(apex, foothold, tuple(hop.next_apex)))
    return hops


def test_the_template_predicts_its_own_hops():
    params = ds.SlipParams()
    err = errors(hops_of(params), params)
    assert np.all(np.isfinite(err)) and err.max() < 1e-6
    s = summary(err)
    assert s["hops"] == 24 and s["template_failed"] == 0 and s["median_position"] < 1e-6


def test_the_fit_finds_the_leg_and_spring_that_made_the_hops():
    hopper = ds.SlipParams()
    robot = fitted(hopper, {"leg_length": 0.95, "stiffness": 1.2})
    hops = hops_of(robot)
    assert summary(errors(hops, hopper))["median_position"] > 0.005   # the hopper's own SLIP is off ...
    factors = fit_factors(hops, hopper)
    assert factors["leg_length"] == pytest.approx(0.95, abs=0.005)
    assert factors["stiffness"] == pytest.approx(1.2, rel=0.03)
    assert summary(errors(hops, fitted(hopper, factors)))["median_position"] < 0.002   # ... the fitted one is not


def test_the_fit_file_holds_factors_for_any_hopper(tmp_path):
    save_fit(tmp_path / "fit.json", {"leg_length": 0.9, "stiffness": 1.5}, {"note": "a report"})
    big = replace(ds.SlipParams(), mass=12.0, leg_length=0.7, stiffness=5000.0)
    template = fitted_template(big, tmp_path / "fit.json")
    assert template.leg_length == pytest.approx(0.63) and template.stiffness == pytest.approx(7500.0)
    assert template.mass == 12.0
    (tmp_path / "bad.json").write_text(json.dumps({"format": "drakeslip-spatial-template/1",
                                                   "factors": {"leg_length": 0.0, "stiffness": 1.0}}))
    for bad in ("bad.json", "missing.json"):
        with pytest.raises(ValueError, match=f"{bad} is not a spatial template fit"):
            fitted_template(big, tmp_path / bad)


def test_the_hops_of_a_loops_records_pair_each_foothold_with_the_apex_it_reached():
    plans = [{"apex": [0, 0, 0.9, 1, 0], "executed": [[0.3, 0, 0]]},
             {"apex": [0.7, 0, 0.9, 1, 0], "executed": []},             # a hop in place: no foothold
             {"apex": [0.7, 0, 0.9, 0, 0], "executed": [[0.8, 0, 0]]},
             {"apex": [1.1, 0, 0.9, 1, 0], "executed": [[1.4, 0, 0]]}]  # the last: no apex after it
    hops = hops_from_plans(plans)
    assert [(h.apex[0], h.foothold[0], h.next_apex[0]) for h in hops] == [(0, 0.3, 0.7), (0.7, 0.8, 1.1)]


@pytest.fixture
def small_map_suite(tmp_path):
    """A map suite of two cases over a flat map with a 0.3 m gap."""
    from planners.formats.map_suite import MAP_SUITE_FORMAT, map_digest

    heights = np.zeros((40, 140))
    heights[:, 35:41] = np.nan
    ground = HeightMap(heights, 0.05, (-0.25, -1.0))
    ground.save(tmp_path / "gap.npz")
    record = {"file": "gap.npz", "sha256": map_digest(ground)}
    cases = [{"id": f"gap-{v}", "map": record, "apex": {"x": 0.0, "y": 0.0, "z": 0.7, "xdot": v, "ydot": 0.0}}
             for v in (1.2, 1.5)]
    (tmp_path / "s.json").write_text(json.dumps({"format": MAP_SUITE_FORMAT, "name": "gap", "goal": {"x": 4.0, "y": 0.0},
                                                 "friction": 0.8, "cases": cases}))
    return tmp_path / "s.json"


def test_the_script_fits_the_spatial_robots_hops_and_writes_the_factors(run_script, tmp_path, small_map_suite):
    code, out, err = run_script("fit_template", "--robot", "spatial", "--suites", small_map_suite, "--cases", 1,
                                "--held-out", 1, "--every", 1, "--out", tmp_path / "fit.json")
    assert code == 0, err
    report = json.loads(out[out.index("{"):out.rindex("}") + 1])
    assert report["hops"]["fit"] >= 4 and report["hops"]["held_out"] >= 4
    assert report["own"]["held_out"]["median_position"] < 0.1
    template = fitted_template(ds.SlipParams(), tmp_path / "fit.json")
    assert template.leg_length == pytest.approx(0.5 * report["factors"]["leg_length"])


@pytest.fixture
def other_hoppers_suite(tmp_path):
    """A one-map stones suite drawn for a 12 kg hopper with a 0.7 m leg."""
    from drakeslip.hopper_file import NamedHopper
    from planners.formats.map_suite import make_map_suite, save_map_suite

    big = NamedHopper(replace(ds.SlipParams(), mass=12.0, leg_length=0.7, stiffness=5000.0), "big")
    save_map_suite(make_map_suite("stones", 5, n_maps=1, hopper=big), tmp_path / "big.json")
    return tmp_path / "big.json"


@pytest.mark.parametrize("args, named", [
    (["--robot", "spatial", "--suites", "{tmp}/missing.json"], "missing.json"),
    (["--robot", "spatial", "--suites", "{small},{big}"], "stones-5 was drawn for another hopper than gap"),
    (["--robot", "spatial", "--suites", "suites/ditch.json"], "suites/ditch.json"),
    (["--jobs", "2"], "--jobs, --executor and --seed are for --robot spatial"),
])
def test_the_script_refuses_bad_input_in_one_line(run_script, tmp_path, small_map_suite, other_hoppers_suite, args,
                                                  named):
    fill = {"{tmp}": tmp_path, "{small}": small_map_suite, "{big}": other_hoppers_suite}
    for key, value in fill.items():
        args = [a.replace(key, str(value)) for a in args]
    code, out, err = run_script("fit_template", *args, "--out", tmp_path / "fit.json")
    assert code == 2 and not out and len(err.splitlines()) == 1 and named in err, err
    assert not (tmp_path / "fit.json").exists()
