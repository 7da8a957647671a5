"""Every committed weights file's rebuild recipe, as docs/reproduction.md ("Regenerating the weights") writes it,
runs from a fresh clone: its commands, with the sizes cut down by flags the scripts have for real use, run in an
empty folder that holds only copies of the weights folders' SHA256SUMS manifests; the file they write loads through
the loader the planners use, its manifest entry was written by the command, and the model aims or plans."""
import math
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drakeslip.jobs.files import MANIFEST, manifest_entries, sha256

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "reproduction.md"
WEIGHTS_FOLDERS = ("drakeslip/weights", "planners/weights")
# per script: flags appended to the documented command (the last of a repeated flag wins) that shrink the job
SMALL = {
    "train_controller.py": ["--epochs", "2", "--angles", "5", "--quiet"],
    "generate_dataset.py": ["--terrains", "2", "--apexes", "2", "--jobs", "1", "--quiet"],
    "train_lstm.py": ["--epochs", "1", "--quiet"],
    "train_expert.py": ["--terrains", "1,1,1", "--apexes", "2", "--epochs", "1,1,1", "--jobs", "1", "--quiet"],
    "train_ranker.py": ["--rounds", "2", "--terrains", "1", "--families", "ditch", "--epochs", "2", "--jobs", "1",
                        "--quiet"],
    "train_spatial_model.py": ["--cases", "5", "--epochs", "1", "--jobs", "1", "--quiet"],
}
APEX, GOAL = (0.0, 0.8, 1.2), 10.0


def recipes() -> dict:
    """{weights file: its commands} from the doc's section: every ```bash block there that opens with a comment
    naming the file."""
    text = DOC.read_text()
    section = text.split("## Regenerating the weights", 1)[1].split("\n## ", 1)[0]
    found = {}
    for block in re.findall(r"```bash\n(.*?)```", section, re.S):
        lines = [line.strip() for line in block.strip().splitlines()]
        if lines and re.fullmatch(r"# \S+\.pt", lines[0]):
            found[lines[0][2:]] = [shlex.split(line) for line in lines[1:] if line.startswith("python3 examples/")]
    return found


RECIPES = recipes()


def aims(path: Path) -> None:
    from drakeslip import StepLengthController, Terrain

    controller = StepLengthController.load(path)
    theta = controller.leg_angle(APEX, 0.4, Terrain.flat(0.0, x0=-5.0, length=20.0))
    assert math.isfinite(theta) and abs(theta) < controller.config.max_angle


def plans(planner) -> None:
    from drakeslip import SlipParams, step_world

    plan = planner.plan(APEX, step_world(11), GOAL, SlipParams())
    assert plan.success, plan.message
    assert np.all(np.isfinite(plan.footholds)) and plan.footholds[0] > APEX[0] - 0.5


def lstm_plans(path: Path, **options) -> None:
    from planners.learned.lstm import LSTMPlanner, load_model

    assert load_model(path).config.n_cells == 110
    plans(LSTMPlanner(path, **options))   # the constructor's first parameter is the footstep model's checkpoint


def map_plans(path: Path) -> None:
    from drakeslip import SlipParams
    from drakeslip.spatial.heightmap import HeightMap
    from planners.learned.lstm_guided import LSTMGuidedPlanner

    plan = LSTMGuidedPlanner(map_model=path).plan((0.0, 0.0, 0.9, 1.5, 0.0), HeightMap.flat(), (5.0, 0.0),
                                                  SlipParams())
    assert plan.success, plan.message
    assert np.all(np.isfinite(plan.footholds)) and plan.footholds.shape[1] == 3


def checks() -> dict:
    """{weights file as the doc names it: (the committed file it rebuilds, a check of a file loaded with that file's
    loader: one call with it)}."""
    from drakeslip.controller import DEFAULT_WEIGHTS
    from planners.checkpoints import EXPERT_WEIGHTS, PAPER_WEIGHTS, RANKER_WEIGHTS, SPATIAL_WEIGHTS, SUBCELL_WEIGHTS
    from planners.learned.lstm_guided import LSTMGuidedPlanner

    return {"drakeslip/weights/controller.pt": (DEFAULT_WEIGHTS, aims),
            "planners/weights/lstm_paper.pt": (PAPER_WEIGHTS, lambda p: lstm_plans(p, max_steps=12, ranker=None)),
            "planners/weights/lstm_subcell.pt": (SUBCELL_WEIGHTS, lambda p: plans(LSTMGuidedPlanner(p))),
            "planners/weights/lstm_expert.pt": (EXPERT_WEIGHTS, lambda p: lstm_plans(p, max_steps=1, ranker=None)),
            "planners/weights/ranker.pt": (RANKER_WEIGHTS,
                                           lambda p: lstm_plans(EXPERT_WEIGHTS, max_steps=1, ranker=p)),
            "planners/weights/spatial_footstep.pt": (SPATIAL_WEIGHTS, map_plans)}


def test_the_doc_has_a_recipe_for_every_committed_weights_file():
    committed = {f"{folder}/{name}" for folder in WEIGHTS_FOLDERS for name in manifest_entries(ROOT / folder)}
    assert {str(file.relative_to(ROOT)) for file, _ in checks().values()} == committed
    assert sorted(RECIPES) == sorted(checks())
    for name, commands in RECIPES.items():
        assert commands and all(Path(c[1]).name in SMALL for c in commands), name


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(RECIPES))
def test_recipe_runs_from_a_fresh_clone_to_a_file_that_loads(name, tmp_path):
    for folder in WEIGHTS_FOLDERS:
        (tmp_path / folder).mkdir(parents=True)
        shutil.copy(ROOT / folder / MANIFEST, tmp_path / folder / MANIFEST)
    pythonpath = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    env = {**os.environ, "PYTHONPATH": pythonpath, "MPLBACKEND": "Agg"}
    for command in RECIPES[name]:
        script = Path(command[1]).name
        run = subprocess.run([sys.executable, str(ROOT / command[1]), *command[2:], *SMALL[script]], cwd=tmp_path,
                             env=env, capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, f"{shlex.join(command)}:\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
    path = tmp_path / name
    assert path.is_file(), f"the recipe wrote no {name}"
    before, after = manifest_entries(ROOT / path.parent.relative_to(tmp_path)), manifest_entries(path.parent)
    assert after[path.name] == sha256(path) != before.get(path.name)
    assert {k: v for k, v in after.items() if k != path.name} == {k: v for k, v in before.items() if k != path.name}
    checks()[name][1](path)


@pytest.mark.parametrize("script", ["train_controller", "train_lstm", "train_ranker", "train_expert",
                                    "train_spatial_model"])
@pytest.mark.parametrize("device", ["cuda:99", "tpu", "meta"])
def test_a_device_that_is_not_there_is_a_usage_error_before_any_work(script, device, run_script, tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "shard_00000.npz").touch()
    outputs = {"train_controller": ["--out", tmp_path / "out" / "c.pt"],
               "train_lstm": ["--data", tmp_path / "data", "--out", tmp_path / "out" / "m.pt",
                              "--checkpoint", tmp_path / "out" / "ck.pt"],
               "train_ranker": ["--data-dir", tmp_path / "out", "--out", tmp_path / "out" / "r.pt"],
               "train_expert": ["--work", tmp_path / "out", "--out", tmp_path / "out" / "e.pt"],
               "train_spatial_model": ["--data", tmp_path / "out", "--out", tmp_path / "out" / "s.pt"]}
    code, out, err = run_script(script, *outputs[script], "--device", device)
    assert code == 2 and err.count("\n") == 1 and "--device" in err and repr(device) in err, err
    assert not (tmp_path / "out").exists()


def test_the_expert_rounds_chain_their_commands(run_script, tmp_path):
    """Round r's rollouts follow round r-1's model with seed r, and its training fine-tunes that model on every
    round's data so far; each size is one entry of its list."""
    work = tmp_path / "work"
    code, out, _ = run_script("train_expert", "--work", work, "--terrains", "7,5", "--epochs", "3,2", "--dry-run",
                              "--device", "cpu")
    assert code == 0
    commands = [shlex.split(line) for line in out.splitlines()]
    assert [c[1] for c in commands] == ["examples/generate_dataset.py", "examples/train_lstm.py"] * 2
    flags = [dict(zip(c[2::2], c[3::2])) for c in commands]   # the commands' flags all take one value
    assert flags[0]["--terrains"] == "7" and flags[0]["--seed"] == "0" and "--policy" not in flags[0]
    assert flags[1]["--epochs"] == "3" and "--init" not in flags[1] and flags[1]["--hidden"] == "256"
    assert flags[2]["--terrains"] == "5" and flags[2]["--seed"] == "1" and flags[2]["--policy"] == f"{work}/round0.pt"
    assert flags[3]["--data"] == f"{work}/round0,{work}/round1" and flags[3]["--init"] == f"{work}/round0.pt"
    assert flags[3]["--epochs"] == "2" and flags[3]["--out"] == f"{work}/round1.pt"
    assert not work.exists()
    code, _, err = run_script("train_expert", "--work", work, "--terrains", "7,5", "--epochs", "3")
    assert code == 2 and "--epochs has 1 entries and --terrains 2" in err and not work.exists()


def test_the_expert_rounds_refuse_a_work_folder_made_with_other_settings(run_script, example, tmp_path):
    script = example("train_expert")
    args = script.parser().parse_args(["--work", str(tmp_path), "--terrains", "7,5", "--epochs", "3,2"])
    script.check_settings(tmp_path, {k: getattr(args, k) for k in script.SETTINGS})
    script.check_settings(tmp_path, {k: getattr(args, k) for k in script.SETTINGS})   # the same: resumes
    code, _, err = run_script("train_expert", "--work", tmp_path, "--terrains", "7,6", "--epochs", "3,2")
    assert code == 2 and err.count("\n") == 1 and "terrains differ" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["config.json"]
