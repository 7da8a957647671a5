"""The committed suites and the terrain families: COMMITTED_SEEDS names exactly the committed suite files and
rebuilds them; every place that takes a family name refuses an unknown one with the same message."""
import json
from pathlib import Path

import numpy as np
import pytest

from drakeslip import SlipParams
from drakeslip.terrain import TERRAIN_FAMILIES, check_families, family
from planners.base import FootstepSequence, Plan
from planners.formats.plan import PlanRecord
from planners.formats.suite import COMMITTED_SEEDS, make_suite
from planners.learned.training.config import DatasetConfig
from verification.backend_agreement import draw_cases

ROOT = Path(__file__).resolve().parents[1]
UNKNOWN = r"unknown terrain families \['hills'\]; choose from \['ditch', 'mixed', 'step'\]"


def test_committed_seeds_name_exactly_the_committed_suites_and_rebuild_them():
    assert sorted(COMMITTED_SEEDS) == sorted(p.stem for p in (ROOT / "suites").glob("*.json"))
    for name, seed in COMMITTED_SEEDS.items():
        committed = json.loads((ROOT / "suites" / f"{name}.json").read_text())
        assert json.loads(json.dumps(make_suite(name, seed, name=name).to_dict())) == committed


def test_make_suites_writes_the_committed_suites_and_asks_a_seed_for_others(run_script, tmp_path):
    code, out, _ = run_script("make_suites", "--out", tmp_path)
    assert code == 0
    for name in COMMITTED_SEEDS:
        assert json.loads((tmp_path / f"{name}.json").read_text()) == json.loads((ROOT / "suites" / f"{name}.json")
                                                                                 .read_text())
    code, _, err = run_script("make_suites", "--families", "mixed", "--out", tmp_path / "mixed")
    assert code == 2 and "['mixed'] have no committed suite; give --seed" in err and len(err.splitlines()) == 1
    code, _, err = run_script("make_suites", "--families", "ditch,hills", "--seed", "5", "--out", tmp_path / "x")
    assert code == 2 and "--families: unknown terrain families ['hills']" in err and len(err.splitlines()) == 1


def test_a_family_is_its_generator_and_an_unknown_one_is_refused_everywhere_alike():
    plan = Plan("step", True, 1.0, sequences=[FootstepSequence(np.array([0.6]), np.array([0.1]), np.zeros((1, 3)))])
    assert all(family(name) is generate for name, generate in TERRAIN_FAMILIES.items())
    assert check_families(["step", "ditch"]) == ("step", "ditch")
    for refuse in (lambda: family("hills"), lambda: check_families(["step", "hills"]),
                   lambda: make_suite("hills", 0), lambda: draw_cases(1, 0, ("hills",)),
                   lambda: DatasetConfig(families=("hills",)),
                   lambda: PlanRecord.from_plan(plan, (0.0, 0.9, 2.0), {"family": "hills", "seed": 0}, 10.0,
                                                SlipParams())):
        with pytest.raises(ValueError, match=UNKNOWN):
            refuse()
    with pytest.raises(ValueError, match=r"unknown terrain families \[\]"):
        check_families([])
    with pytest.raises(ValueError, match=r"unknown terrain families \[\['step'\]\]"):
        family(["step"])
