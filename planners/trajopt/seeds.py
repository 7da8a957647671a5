"""Seeds: the footholds a trajectory optimization starts from, which fix the segment of every hop.

A seed is a planner label: ``cold`` (a uniform gait at the neutral stride, no planner), or the label of a planner
that plans on the query's terrain (``heuristic``, ``step``, ``lstm``, ``lstm-guided``, or ``NAME@VARIANT`` of one,
such as the paper's ``lstm@paper`` and ``lstm-guided@paper``, with options for that planner). Plain ``lstm``
plans one step ahead, so as a seed it is asked again at the apex the fast step map predicts after each of its
footholds; a multi-step mode planner (``lstm@paper``) plans as many steps as the optimization takes. The cold
and LSTM-guided seeds have several starts (``MULTI_START``): other strides, other samples.
"""
from __future__ import annotations

import functools
import json
import math

import numpy as np

from drakeslip.rollout import rollout
from planners.base import Problem
from planners.registry import make_planners, options_for, planner_name
from planners.trajopt.config import COLD_OVERSHOOT, COLD_STRIDES, MULTI_START, SEEDS, TrajoptConfig, TrajoptError


def cold_footholds(problem: Problem, extra_hops: int = 0) -> np.ndarray:
    """A nominal uniform gait: the first foothold at the neutral point of the start apex on the ground under it,
    then equal steps (about the neutral gait's stride at the start speed) to COLD_OVERSHOOT (in the hopper's
    lengths) past the target, on whatever segments those land. ``extra_hops`` more (or fewer, down to two
    footholds) equal steps cover the same distance."""
    from planners.search.gait import interpolate, neutral_gait

    apex, terrain = problem.apex, problem.terrain
    offsets, advances = neutral_gait(problem.params.with_friction(1.0))
    drop = apex.z - terrain.height_at(apex.x)
    first = apex.x + interpolate(offsets, apex.xdot, drop)
    stride = interpolate(advances, apex.xdot, drop)
    last = max(problem.target_x + COLD_OVERSHOOT * problem.units.length, first)
    nominal = 1 + max(0, math.ceil((last - first) / stride - 1e-9))
    n = max(nominal + extra_hops, min(nominal, 2))  # fewer hops, but still from the first foothold to the last
    return first + (last - first) * np.arange(n) / max(n - 1, 1)


def seed_planner(label: str, options: dict | None, max_hops: int, seed_model, sample: int):
    """The seed's planner (``label`` with ``options`` over its preset's), built once per distinct arguments (so the
    one check_seed builds is the first start's): an lstm seed reads ``seed_model`` unless ``options`` name a
    checkpoint; a multi-step mode planner plans ``max_hops`` steps; the LSTM-guided search samples with seed
    ``sample``."""
    return _built_seed_planner(label, max_hops, str(seed_model) if seed_model else None, sample,
                               json.dumps(options or {}, sort_keys=True))


@functools.cache
def _built_seed_planner(label: str, max_hops: int, seed_model: str | None, sample: int, options_json: str):
    name, given = planner_name(label), json.loads(options_json)
    options = options_for(label, given)
    if name.startswith("lstm") and seed_model and "model" not in given:
        options["model"] = seed_model
    if name == "lstm" and options.get("max_steps", 1) > 1:  # a multi-step mode planner: as many as optimized
        options["max_steps"] = max_hops
    if name == "lstm-guided":  # footholds sampled from the model, each hop checked on the fast step map
        options["seed"] = sample
    try:
        return make_planners({label: options}, default_controller())[label]
    except ValueError as error:  # make_planners' message names the label; this one names the seed
        raise ValueError(f"options for the {label} seed: {error.__cause__ or error}") from error


@functools.cache
def default_controller():
    """The committed step-length controller, loaded once: it aims the seeds' footholds and the initial guess."""
    from drakeslip import StepLengthController

    return StepLengthController.load_default()


def check_seed_name(seed: str, options: dict | None) -> str:
    """The seed's name; a ValueError for an unknown one, or for options given to the cold gait."""
    name = planner_name(seed)
    if name not in SEEDS:
        raise ValueError(f"unknown seed {seed!r}; known seeds: {', '.join(SEEDS)} (each optionally NAME@VARIANT)")
    if name == "cold" and options:
        raise ValueError(f"the {seed} seed is a fixed gait and takes no options, got {options!r}")
    return name


def check_seed(seed: str, options: dict | None = None, config: TrajoptConfig | None = None) -> None:
    """A ValueError unless ``seed`` is a seed name, or ``NAME@VARIANT`` of one, and ``options`` (for the seed's
    planner) build it with ``config``'s max_hops and seed_model (the planner is kept for the first start);
    ``cold`` takes no options."""
    config = config or TrajoptConfig()
    if check_seed_name(seed, options) != "cold":
        seed_planner(seed, options, config.max_hops, config.seed_model, 0)


def seed_footholds(name: str, problem: Problem, max_hops: int = TrajoptConfig.max_hops,
                   seed_model: str | None = None, sample: int = 0,
                   options: dict | None = None) -> tuple[np.ndarray, int]:
    """Footholds from the named seed (planned on the problem's terrain), up to (and including) the first one
    past the target, and the step-map calls the seed's planner made (0 for ``cold``).
    ``name``: a seed, or ``NAME@VARIANT`` of one with ``options`` for its planner (e.g. ``lstm-guided@expert``
    with another model), so two settings of a seed can be compared; a preset label (``planners.registry.PRESETS``,
    e.g. ``lstm@paper``) runs with the preset's options, updated by ``options``.
    ``seed_model``: a checkpoint for the ``lstm`` and ``lstm-guided`` seeds (default: each label's own) unless
    ``options`` name one. ``sample``: which start of a MULTI_START seed (the cold gait with COLD_STRIDES[sample]
    more hops, the LSTM-guided search with sampling seed ``sample``). An ``lstm`` plan short of the target (the
    one-step mode planner: plain ``lstm``, whose learned re-ranker picks each foothold) is continued from the
    apexes the fast step map predicts."""
    kind = check_seed_name(name, options)
    if sample and kind not in MULTI_START:
        raise ValueError(f"the {name} seed has one start; sample {sample!r} asked for another")
    ode_calls = 0
    if kind == "cold":
        footholds = cold_footholds(problem, COLD_STRIDES[sample])
    else:
        planner = seed_planner(name, options, max_hops, seed_model, sample)
        plan = planner.plan(problem.apex, problem.terrain, problem.goal_x, problem.params)
        if not plan.success or plan.footholds.size == 0:
            raise TrajoptError(f"the {name} seed found no plan: {plan.message}")
        footholds, ode_calls = np.asarray(plan.footholds, dtype=np.float64), plan.ode_calls
        if kind == "lstm":
            footholds, ode_calls = _requeried(planner, problem, footholds, ode_calls, max_hops)
    passed = np.flatnonzero(footholds >= problem.target_x)
    return (footholds[:passed[0] + 1] if passed.size else footholds), ode_calls


def _requeried(planner, problem: Problem, footholds: np.ndarray, ode_calls: int, max_hops: int):
    """An LSTM plan that stops short of the target (the one-step mode planner's single foothold) continued: the
    controller aims each foothold, the fast step map predicts the apex after it, and the planner is asked again
    from there, until the footholds pass the target, number ``max_hops``, a hop fails or no plan is found. The
    footholds are still the model's; each prediction is one step-map call."""
    footholds = list(footholds)
    apex, done = problem.apex, 0
    while footholds[-1] < problem.target_x and len(footholds) < max_hops:
        hops = rollout(apex, problem.terrain, problem.params, footholds=footholds[done:],
                       controller=default_controller(), backend="fast")
        ode_calls += len(hops.apexes) + (hops.failure is not None)  # every hop tried, the failed one too
        if hops.failure is not None:
            return np.array(footholds), ode_calls
        apex, done = hops.apexes[-1], len(footholds)
        plan = planner.plan(apex, problem.terrain, problem.goal_x, problem.params)
        if not plan.success or plan.footholds.size == 0:
            break
        footholds += plan.footholds.tolist()
        ode_calls += plan.ode_calls
    return np.array(footholds), ode_calls

