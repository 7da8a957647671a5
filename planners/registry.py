"""Planner registry: ``make(label, **options)`` builds any planner by its label.

A label is a planner's name (``step``) or ``NAME@VARIANT``: the same planner with other options, so two settings
run side by side in one evaluation. A variant can be a preset, a named setting kept here (``lstm@paper``, the
paper's literal LSTM planner); options given for a label update its preset. A name alone runs the planner's
defaults, which are the best settings this project ships.

The planners are imported when first made, so listing them, or a script's ``--help``, starts no torch or pydrake.
"""
from __future__ import annotations

import importlib
import inspect
from pathlib import Path

from drakeslip.jobs.files import parse_json

from planners.checkpoints import EXPERT_WEIGHTS, PAPER_WEIGHTS, WEIGHTS_DIR

_PLANNERS = {
    "heuristic": "planners.search.heuristic:HeuristicPlanner",
    "angle": "planners.search.angle_space:AngleSpacePlanner",
    "step": "planners.search.step_space:StepSpacePlanner",
    "lstm": "planners.learned.lstm:LSTMPlanner",
    "lstm-guided": "planners.learned.lstm_guided:LSTMGuidedPlanner",
    "trajopt": "planners.trajopt.planner:TrajoptPlanner",
}

PRESETS = {
    # the paper's LSTM planner: its model (Table I data), the mode fed back for up to 12 steps
    "lstm@paper": {"model": str(PAPER_WEIGHTS), "max_steps": 12, "ranker": None},
    # the default without its learned re-ranker: the expert model's mode, one step ahead
    "lstm@no-ranker": {"ranker": None},
    # the paper's LSTM-guided search: its model, path-conditioned, every sampled child simulated at once
    # (and no pruned last stage, which the paper's planners do not have)
    "lstm-guided@paper": {"model": str(PAPER_WEIGHTS), "lazy": False, "conditioning": "path", "pruned_nodes": 0},
    # the default search sampling the expert model instead (the trajectory optimizer's best seed)
    "lstm-guided@expert": {"model": str(EXPERT_WEIGHTS)},
    # children that survive realistic noise and leave the hopper where it can go on (planners/search/robust.py),
    # replanning at every apex; the sampled search falls back on the whole grid before giving up
    "step@robust": {"robustness": {}},
    "lstm-guided@robust": {"robustness": {}, "grid_fallback": True},
    # trajectory optimization that also maximizes the plan's least spring travel and friction to spare
    # (planners/trajopt/margins.py; planners/trajopt/config.py says why these weights)
    "trajopt@robust": {"config": {"objective": {"stroke": 10.0, "friction": 1.0}}},
}


# The closed loop a preset is meant to run in, where it is not the protocol's (planners.closed_loop.ClosedLoopConfig):
# footholds executed per plan (replanning at every apex) and the robot's map filter (5 cells).
ROBUST_LOOP = {"executed_per_plan": 1, "map_filter": 5}
LOOP_SETTINGS = {"step@robust": ROBUST_LOOP, "lstm-guided@robust": ROBUST_LOOP}


def loop_settings(label: str) -> dict:
    """The ``ClosedLoopConfig`` fields ``label`` is meant to run with, {} for the evaluation's own."""
    return dict(LOOP_SETTINGS.get(label, {}))


def planner_name(label: str) -> str:
    """The registered planner behind a label: ``NAME`` or ``NAME@VARIANT``."""
    return label.split("@", 1)[0]


def available() -> list[str]:
    """The registered planner names."""
    return sorted(_PLANNERS)


def labels() -> list[str]:
    """Every name and preset label."""
    return sorted([*_PLANNERS, *PRESETS])


def register(name: str, cls) -> None:
    """Add a planner class (or ``"module:Class"``) under ``name``, so ``make(name)`` builds it."""
    if name in _PLANNERS:
        raise ValueError(f"a planner named {name!r} is already registered")
    if "@" in name:
        raise ValueError(f"a planner name cannot contain '@' (that marks a variant), got {name!r}")
    _PLANNERS[name] = cls


def planner_class(name: str):
    """The class registered as ``name`` (imported now if needed)."""
    if name not in _PLANNERS:
        raise ValueError(f"unknown planner {name!r}; known planners: {', '.join(available())}")
    target = _PLANNERS[name]
    if isinstance(target, str):
        module, _, attr = target.partition(":")
        target = _PLANNERS[name] = getattr(importlib.import_module(module), attr)
    return target


def check_label(label: str) -> str:
    """``label`` if its planner is registered; else ValueError naming the known planners and presets."""
    if not isinstance(label, str) or planner_name(label) not in _PLANNERS:
        raise ValueError(f"unknown planner {label!r}; known planners: {', '.join(available())}; "
                         f"presets: {', '.join(PRESETS)} (any NAME@VARIANT takes its options from --options)")
    return label


def options_for(label: str, options: dict | None = None) -> dict:
    """The options ``label`` runs with: its preset's (none for a plain name), updated by ``options``."""
    return {**PRESETS.get(label, {}), **(options or {})}


def takes(name: str, option: str) -> bool:
    """Whether the planner registered as ``name`` accepts ``option`` (e.g. a shared ``controller``)."""
    return name in _PLANNERS and option in inspect.signature(planner_class(name)).parameters


def check_variant(label: str, options: dict | None) -> None:
    """ValueError in one line for a ``NAME@VARIANT`` that is no preset and is given no options: it would run as the
    plain planner under another name (most likely a preset's name mistyped)."""
    if "@" in label and label not in PRESETS and not options:
        raise ValueError(f"{label!r} is no preset ({', '.join(PRESETS)}) and has no options: a NAME@VARIANT other "
                         f"than a preset takes its options from --options")


def make(label: str, **options):
    """A planner by label with its options, e.g. ``make("angle", branching=20, seed=0)`` or ``make("lstm@paper")``."""
    check_variant(check_label(label), options)
    cls = planner_class(planner_name(label))
    return cls(**options_for(label, options))


def files_read(label: str, options: dict | None = None) -> dict:
    """The files (models, rankers) the planner ``label`` reads when built with ``options``, by option name."""
    return planner_class(planner_name(check_label(label))).files_read(options_for(label, options))


def hopper_options(label: str, options: dict | None, hopper) -> dict | None:
    """``options`` for ``label`` on ``hopper`` (a ``drakeslip.hopper_file.NamedHopper``): every committed weights file
    the planner reads (``files_read``, from planners/weights/) that the hopper's folder also holds, by name, is
    read from the folder instead (examples/train_hopper.py writes them; loading checks the folder's manifest).
    ``options`` itself for a hopper without a folder, the paper's included, or when the folder holds none."""
    if hopper is None or hopper.folder is None:
        return options
    swapped = dict(options or {})
    for option, path in files_read(label, options).items():
        own = hopper.weights(Path(path).name) if Path(path).resolve().parent == WEIGHTS_DIR.resolve() else None
        if own is None:
            continue
        if option.startswith("seed."):   # a trajectory optimizer's seed planner's file (TrajoptPlanner.files_read)
            swapped["seed_options"] = {**swapped.get("seed_options", {}), option[len("seed."):]: str(own)}
        else:
            swapped[option] = str(own)
    return swapped if swapped != dict(options or {}) else options


def hopper_specs(specs: dict, hopper) -> dict:
    """``specs`` (label -> options) with each label's options for ``hopper`` (``hopper_options``)."""
    return {label: hopper_options(label, options, hopper) for label, options in specs.items()}


def make_planners(specs: dict, controller=None) -> dict:
    """The planners of a run by label, ``specs`` mapping labels to options (or None), sharing ``controller`` with
    those that take one. An unknown label, an option a planner does not take, or a bad value is a ValueError
    naming the label."""
    planners = {}
    for label, options in specs.items():
        name = planner_name(check_label(label))
        check_variant(label, options)
        shared = {"controller": controller} if controller is not None and takes(name, "controller") else {}
        try:
            planners[label] = make(label, **shared, **(options or {}))
        # TypeError: an unknown keyword; OSError: a missing file; OverflowError: an integer too large for a float
        except (TypeError, ValueError, OSError, OverflowError) as error:
            raise ValueError(f"options for {label}: {error}") from error
    return planners


def label_options(text: str, labels: list, kind: str = "planner") -> dict:
    """``--options`` JSON: an object mapping some of ``labels`` to option objects; a ValueError otherwise."""
    options = parse_json(text, "--options")
    if not isinstance(options, dict) or any(k not in labels or not isinstance(v, dict) for k, v in options.items()):
        raise ValueError(f"--options must map {kind} labels among {labels} to option objects, got {text!r}")
    return options
