"""The evaluation harness: planners evaluated on a suite in the receding-horizon loop (paper, section VII).

Each (planner label, case) is one task of the job runner (``drakeslip.jobs``): run in this process, in local
worker processes or on a Ray cluster, saved to a JSON-lines store as it finishes, and reused by a later run of
the same setup with the same code, so a killed evaluation resumes where it stopped. A task's key is a
fingerprint of everything its result depends on: the code version (``verification.provenance.code_version``:
the commit and a digest of uncommitted changes), the case, the hopper, the planner and its options after presets,
the closed-loop settings, and the digests of the controller and every weights file the planner reads. Every case is
planned for and executed with the suite's hopper (``Suite.hopper``, the paper's when the suite records none) with
the suite's friction, and the results record that hopper (``NamedHopper.to_record``). Cached results
of other code are never reused: the run says how many cached results it reused and how many of other code it
ignored, and computes the rest. The results record the same (each planner's "options", "config" and "weights":
SHA-256 by file) with the code version the keys hold, the libraries, machine and date ("provenance").

A height-map suite (``planners.formats.map_suite.MapSuite``) runs the same way, each case in the loop on its map
(``planners.spatial_loop.run_map_case``; on the multibody backend on the spatial robot,
``planners.spatial_robot_loop.run_map_case_on_robot``): its key holds the map's digest, its start and its goal instead
of a terrain, and a task carries a drawn map's record rather than its cells (``task_map``). A planner that plans on
profiles only is refused before any case (``check_map_run``).
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from dataclasses import asdict

from drakeslip.controller import DEFAULT_WEIGHTS, StepLengthController
from drakeslip.hopper_file import NamedHopper, params_from_fields
from drakeslip.jobs.executors import prepare
from drakeslip.jobs.files import sha256
from drakeslip.jobs.runner import JsonLinesStore, run

from planners.base import Planner
from planners.closed_loop import ClosedLoopConfig, robot_config, run_case
from planners.formats.case_record import check_case_record
from planners.formats.map_case_record import check_map_case_record
from planners.formats.map_suite import MapSuite, map_of_task, task_map
from planners.formats.suite import Suite, suite_from_dict, terrain_record
from planners.formats.suite_draw import suite_hopper
from planners.registry import files_read, make_planners, options_for, planner_class, planner_name
from planners.spatial_loop import MAP_LOOP_BACKENDS, MapCase, run_map_case
from verification.provenance import code_version, provenance, weights_digests
from verification.report import summarize

_WORKER: dict = {}


def controller_weights(path=None) -> str:
    """The controller weights file a run uses: ``path``, or the committed one."""
    return str(path or DEFAULT_WEIGHTS)


def digest(path) -> str:
    """The first 16 hex digits of the SHA-256 of a file (its path when it does not exist)."""
    path = Path(path)
    return sha256(path)[:16] if path.is_file() else str(path)


def fingerprint(suite: Suite | MapSuite, label: str, options: dict, config: ClosedLoopConfig, controller_path,
                code: str | None = None) -> str:
    """Identifies a (code, suite and its hopper, planner, options, closed loop, weights) setup, so cached cases are
    reused only for the same setup: changing the code (``code``, default ``code_version()``), the hopper,
    retraining the controller or any weights file the planner reads invalidates them."""
    files = {name: digest(path) for name, path in files_read(label, options).items()}
    loop = config.to_dict()
    if config.noise.silent:  # a noiseless run does not depend on the noise's seed: its cached cases stay valid
        del loop["noise"], loop["seed"]
    goal = list(suite.goal) if isinstance(suite, MapSuite) else suite.goal_x
    blob = json.dumps([code_version() if code is None else code, goal, suite.friction,
                       asdict(suite_hopper(suite).params), label, options, loop,
                       digest(controller_weights(controller_path)), files], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def case_key(setup: str, case, ground=None) -> str:
    """The store key of one case under one setup (a ``fingerprint``, which holds the code version): the setup
    and the case's own content; ``ground``: what identifies a map case's map and goal (default: the case's
    terrain record)."""
    blob = json.dumps([setup, case.id, terrain_record(case.terrain) if ground is None else ground, list(case.apex)],
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def worker_setup(specs: dict, controller_path=None, refine: bool = True) -> tuple:
    """The setup every process of a run does once (``drakeslip.jobs.executors.prepare``): the run's controller and
    planners, ``specs`` mapping labels to options (presets applied)."""
    return prepare_worker, ({label: options_for(label, options) for label, options in specs.items()},
                            controller_path, refine)


def prepare_worker(specs: dict, controller_path, refine: bool) -> None:
    """Build the run's controller and planners in this process (a worker's setup)."""
    controller = StepLengthController.load(controller_weights(controller_path), refine=refine)
    _WORKER["controller"] = controller
    _WORKER["planners"] = make_planners(specs, controller)


def run_task(label: str, case: dict, goal_x: float, friction: float, config: ClosedLoopConfig,
             hopper: dict) -> dict:
    """One case (a suite's case entry) for one planner label, with the planners ``prepare_worker`` built, for the
    hopper whose parameters are ``hopper`` (``SlipParams`` fields) on ground of ``friction``."""
    suite = suite_from_dict({"format": "drakeslip-suite/1", "name": "task", "goal_x": goal_x, "friction": friction,
                             "cases": [case]})
    params = params_from_fields(hopper, "the task's hopper").with_friction(friction)
    return run_case(_WORKER["planners"][label], _WORKER["controller"], suite.cases[0], goal_x, params, config)


def run_map_task(label: str, case: dict, friction: float, config: ClosedLoopConfig, hopper: dict) -> dict:
    """One case of a map suite (its id, the map as ``task_map`` carries it, its apex and goal) for one planner
    label, with the planners ``prepare_worker`` built, for the hopper of ``hopper`` (``SlipParams`` fields)."""
    params = params_from_fields(hopper, "the task's hopper").with_friction(friction)
    map_case = MapCase(case["id"], map_of_task(case["map"]), tuple(case["apex"]), tuple(case["goal"]))
    if config.backend == "multibody":
        from planners.spatial_robot_loop import run_map_case_on_robot

        return run_map_case_on_robot(_WORKER["planners"][label], map_case, params, config)
    return run_map_case(_WORKER["planners"][label], map_case, params, config)[0]


def check_map_run(configs: dict) -> None:
    """ValueError in one line unless every planner label of ``configs`` (label -> ClosedLoopConfig) plans on height
    maps and runs in a loop the map loop runs: a backend of MAP_LOOP_BACKENDS."""
    profile_only = [label for label in configs
                    if planner_class(planner_name(label)).plan_on_map is Planner.plan_on_map]
    if profile_only:
        raise ValueError(f"planners {', '.join(profile_only)} plan on profiles only, not on height maps")
    for label, config in configs.items():
        if config.backend not in MAP_LOOP_BACKENDS:
            raise ValueError(f"{label}: backend {config.backend!r} does not run height maps; choose one of "
                             f"{MAP_LOOP_BACKENDS}")


def check_map_planners(planners: dict | None = None) -> None:
    """ValueError in one line unless every planner of ``planners`` (by label; None: those ``prepare_worker`` built)
    plans on a height map with its options (a plan to where the hopper already is costs nothing, and one that refuses
    maps, or its preset's options there, says so here rather than at its first case)."""
    from drakeslip.spatial.heightmap import HeightMap

    for label, planner in (_WORKER["planners"] if planners is None else planners).items():
        try:
            planner.plan((0.0, 0.0, 1.0, 1.0, 0.0), HeightMap.flat(), (0.0, 0.0))
        except ValueError as error:
            raise ValueError(f"{label}: {error}") from None


def tasks_for(suite: Suite | MapSuite, cases: list, setups: dict, configs: dict) -> tuple:
    """(the task function, {key: (label, case)}, the tasks) of ``cases`` for every label of ``setups``."""
    hopper = asdict(suite_hopper(suite).params)
    if isinstance(suite, MapSuite):
        source = dict(zip((c.id for c in suite.cases), suite.sources))
        owner = {case_key(setups[label], c, [source[c.id]["sha256"], list(c.goal)]): (label, c)
                 for label in setups for c in cases}
        return run_map_task, owner, [
            (key, (label, {"id": c.id, "map": task_map(source[c.id], c.terrain), "apex": list(c.apex),
                           "goal": list(c.goal)}, suite.friction, configs[label], hopper))
            for key, (label, c) in owner.items()]
    owner = {case_key(setups[label], c): (label, c) for label in setups for c in cases}
    return run_task, owner, [
        (key, (label, {"id": c.id, "terrain": terrain_record(c.terrain), "apex": c.apex._asdict()},
               suite.goal_x, suite.friction, configs[label], hopper))
        for key, (label, c) in owner.items()]


def select(suite: Suite | MapSuite, n_cases: int | None = None, every: int = 1) -> list:
    """Every ``every``-th case of the suite, the first ``n_cases`` of those (all if None)."""
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if n_cases is not None and (isinstance(n_cases, bool) or not isinstance(n_cases, int) or n_cases < 1):
        raise ValueError(f"the number of cases must be a positive integer, got {n_cases!r}")
    return list(suite.cases[::every])[:n_cases]


# many parameters: the suite and planners, then keyword options of a public entry point, each with its default
def evaluate(suite: Suite | MapSuite, specs: dict, n_cases: int | None = None, executor=None, cache_path=None,
             controller_path=None, config: ClosedLoopConfig | dict = ClosedLoopConfig(), progress: bool = True,
             every: int = 1) -> dict:
    """Run every planner label of ``specs`` (label -> options, or None) on ``select(suite, n_cases, every)``, in
    the closed loop ``config`` describes (one for all, or a dict by label, e.g. for each preset's replanning
    period). Finished cases go to ``cache_path`` (JSON lines) as they complete and are reused when the run is
    started again with the same code; a damaged cached case (a line cut short, a result that is not a case
    record: a field missing or of the wrong type, ``check_case_record``) is skipped with a warning and run
    again. ``executor``: where the cases run (``drakeslip.jobs.executors``; default this process)."""
    from tqdm import tqdm

    cases = select(suite, n_cases, every)
    configs = config if isinstance(config, dict) else {label: config for label in specs}
    if isinstance(suite, MapSuite):
        check_map_run({label: configs[label] for label in specs})
    else:   # the robot of the suite's hopper and its template, as the results record them (refused: a learned
        # correction of the paper's robot's template on another hopper)
        configs = {label: robot_config(configs[label], suite_hopper(suite).params) for label in specs}
    if {c.refine for c in configs.values()} != {next(iter(configs.values())).refine}:
        raise ValueError("every planner of a run shares the controller: give them all the same refine")
    setup = worker_setup(specs, controller_path, next(iter(configs.values())).refine)
    specs = setup[1][0]
    prepare(setup)  # in this process first: a bad option or weights file fails before any case runs
    origin = provenance()   # the code version the keys hold is the one the results file names
    setups = {label: fingerprint(suite, label, options, configs[label], controller_path, origin["code_version"])
              for label, options in specs.items()}
    task, owner, tasks = tasks_for(suite, cases, setups, configs)
    hopper: NamedHopper = suite_hopper(suite)
    check = check_map_case_record if isinstance(suite, MapSuite) else check_case_record
    store = JsonLinesStore(cache_path, check, origin["code_version"]) if cache_path else None
    done = {label: {} for label in specs}
    with tqdm(total=len(tasks), desc=suite.name, disable=not progress, unit="case") as bar:
        for key, result in run(task, tasks, store, executor, setup):
            label, case = owner[key]
            done[label][case.id] = result
            bar.update(1)
            bar.set_postfix({n: f"{sum(r['success'] for r in d.values())}/{len(d)}" for n, d in done.items()})
    return {"suite": suite.name, "hopper": hopper.to_record(), "options": specs, "provenance": origin,
            "planners": {label: {"config": configs[label].to_dict(),
                                 "weights": weights_files(label, specs[label], controller_path),
                                 **summarize([done[label][c.id] for c in cases])}
                         for label in specs}}


def weights_files(label: str, options: dict | None, controller_path=None) -> dict:
    """{file: SHA-256} of the controller and every weights file the planner ``label`` reads with ``options``."""
    return weights_digests([controller_weights(controller_path), *files_read(label, options).values()])
