"""What the receding-horizon loop does, on either of its backends: ``planners.closed_loop`` runs it on the
template's rollouts (the fast step map or the Drake hybrid simulator), ``planners.drake_system`` on the multibody
robot in a Drake Diagram. Here: the loop's settings (``ClosedLoopConfig``), a case's noise generator and the hopper
a case runs (``case_seed``, ``drawn_hopper``), the planning call at an apex (``Replanner``: the apex the planner is
told, the map it sees, the goal it aims at, its refusal) and a case's result (``case_result``).
"""
from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, field

import numpy as np

from drakeslip import ApexState, SlipParams
from drakeslip.noise import NoiseProfile
from drakeslip.params import RobotTemplate, check_number
from drakeslip.rollout import ROLLOUT_BACKENDS
from drakeslip.terrain import Terrain, check_window
from drakeslip.units import units_of

from planners.base import footholds_to_fly

EXECUTED_PER_PLAN = 3   # footholds executed before replanning (the paper's protocol)
MAX_HOPS = 60           # a case that has not reached the goal after this many hops fails ("hop cap")
GOAL_SIGMAS = 5.0       # under state noise the planners aim this many standard deviations of x past the goal


@dataclass(frozen=True)
class ClosedLoopConfig:
    """``executed_per_plan`` footholds of each plan are executed before replanning; ``backend="drake"`` executes on
    the Drake hybrid simulator (the protocol), ``"fast"`` on the fast step map (quick diagnosis: is a failure the
    planner's or the model mismatch's?); ``refine`` switches the controller's Newton polish (False: the MLP alone,
    as in the paper, an ablation); ``noise`` the noise profile (its sizes the paper's hopper's, drawn in the case's
    hopper's units: ``NoiseProfile.for_hopper``) and ``seed`` the seed of its draws; ``map_filter``
    the cells of the median filter the robot runs on its sensed height map before the planner and the controller
    use it (``Terrain.denoised`` with the profile's height error; 1: the map as sensed). Without the filter a
    1 cm error per 10 cm cell makes one cell edge in six look like a step of more than 2 cm, which the planners
    keep their footholds clear of. ``robot``: on the multibody backend, the robot's ``RobotParams`` (None: the
    default robot with the case's friction), recorded with the results; ``template``: the SLIP the planners plan
    for there (None: the hopper's own parameters), e.g. the one fitted to the robot (``drakeslip.multibody.fit``),
    with the case's friction; ``pump_energy``: there, the robot raises its apex with its leg actuator where a
    plan skims the ground (``drakeslip.multibody.pump.EnergyPump``; False: an ablation)."""

    executed_per_plan: int = EXECUTED_PER_PLAN
    max_hops: int = MAX_HOPS
    backend: str = "drake"
    refine: bool = True
    noise: NoiseProfile = field(default_factory=NoiseProfile)
    seed: int = 0
    map_filter: int = 1
    robot: object = None
    template: SlipParams | None = None
    pump_energy: bool = True

    def to_dict(self) -> dict:
        record = {"executed_per_plan": self.executed_per_plan, "max_hops": self.max_hops, "backend": self.backend,
                  "refine": self.refine, "noise": self.noise.to_dict(), "seed": self.seed,
                  "map_filter": self.map_filter}
        if self.backend == "multibody":
            record["robot"] = robot_record(self.robot)
            record["template"] = None if self.template is None else asdict(self.template)
            record["pump_energy"] = self.pump_energy
        return record

    def __post_init__(self):
        if self.backend not in ROLLOUT_BACKENDS:
            raise ValueError(f"backend must be one of {ROLLOUT_BACKENDS}, got {self.backend!r}")
        for name in ("executed_per_plan", "max_hops"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        check_window(self.map_filter, "map_filter")


def robot_record(robot) -> dict:
    """The multibody robot a run executes on, as its results record it: the model file and every parameter (the
    planar robot's by default, the spatial robot's for a ``SpatialRobotParams``)."""
    from drakeslip.multibody.robot import SDF_FILE, RobotParams
    from drakeslip.spatial.multibody.robot import SDF_FILE as SPATIAL_SDF_FILE, SpatialRobotParams

    if isinstance(robot, SpatialRobotParams):
        return {"model": f"drakeslip/spatial/multibody/{SPATIAL_SDF_FILE}", "params": robot.to_dict()}
    return {"model": f"drakeslip/multibody/{SDF_FILE}", "params": (robot or RobotParams()).to_dict()}


def case_seed(seed: int, case_id: str) -> list:
    """The seed of a case's noise draws: the config's ``seed`` and the case's id, so that a case gives the same
    result in any process and any order."""
    return [seed, zlib.crc32(case_id.encode())]


def drawn_hopper(noise: NoiseProfile, model: SlipParams, rng: np.random.Generator) -> SlipParams:
    """The hopper a case runs: the ``model``, or under noise the model with the case's stiffness, mass and friction
    errors, the first draw of the case's generator ``rng`` (the planner and the controller keep the model's)."""
    return model if noise.silent else noise.executed_params(model, rng)


@dataclass(frozen=True)
class PlanningCall:
    """What a planning call at an apex saw and made: the ``plan`` (None where the planner refused the apex it was
    told), its ``record`` (``Plan.summary()`` with the true "apex", and the apex told, "seen_apex", under noise),
    the apex the planner was told (``seen``) and the map it sensed (``sensed``, filtered)."""

    plan: object
    record: dict
    seen: ApexState
    sensed: Terrain


@dataclass(frozen=True)
class Replanner:
    """The planner as the loop calls it at an apex, on either backend: told the true apex plus the error the caller
    drew (state estimation), shown the terrain window ahead of the apex told as sensed (``noise.perceived``: height
    and edge errors, then the robot's ``map_filter``), less the footholds within ``face_keep_out`` [m] before a
    step's face (``Terrain.without_footholds_before_rises``; 0: none left out), and aiming GOAL_SIGMAS standard
    deviations of x past ``goal_x`` so that believing it is past means being past.

    ``planner``: a planner object (``plan(apex, terrain, goal_x, params)``) or a label for ``planners.make``;
    ``terrain`` the world; ``params`` the template it plans for; ``noise`` the noise profile (in the template's
    units). ``raise_refusals``: a ValueError of the planner (an apex told below the ground it sees) is raised
    (True: the noiseless protocol, where the apex told is the true one and a refusal is a fault) or recorded as a
    failed plan."""

    planner: object
    terrain: Terrain
    goal_x: float
    params: SlipParams
    noise: NoiseProfile = field(default_factory=NoiseProfile)
    map_filter: int = 1
    face_keep_out: float = 0.0
    raise_refusals: bool = False

    def __post_init__(self):
        check_number(self.face_keep_out, "Replanner face_keep_out")
        if isinstance(self.planner, str):
            from planners.registry import make   # the registry imports every planner: only for a label

            object.__setattr__(self, "planner", make(self.planner))

    @property
    def aim_x(self) -> float:
        # a robot unsure of its x by sigma aims 5 sigma past the goal, so that believing it is past means being past
        return self.goal_x + GOAL_SIGMAS * self.noise.apex[0]

    def plan(self, apex: ApexState, apex_error, rng: np.random.Generator, before=None) -> PlanningCall:
        """Plan from the true ``apex`` told with ``apex_error`` ((x, z, xdot), None: told as it is), the map's
        errors drawn from ``rng`` (none without noise), reached by the hop ``before`` (``Planner.plan``)."""
        seen = apex if apex_error is None else ApexState(*(np.asarray(apex) + apex_error))
        window = self.terrain.perceived(seen.x, *units_of(self.params).window)   # the hopper's view
        sensed = window if self.noise.silent else self.noise.perceived(window, rng, self.map_filter)
        try:
            # the hop before matters only to a template with a learned correction; other planners are not told it
            told = {"before": before} if before is not None and isinstance(self.params, RobotTemplate) else {}
            plan = self.planner.plan(seen, sensed.without_footholds_before_rises(self.face_keep_out), self.aim_x,
                                     self.params, **told)
            record = plan.summary()
        except ValueError as refusal:  # a noisy apex the planner cannot start from (below the ground it sees)
            if self.raise_refusals:
                raise
            plan = None
            record = {"success": False, "message": str(refusal), "ode_calls": 0, "t_plan_s": 0.0,
                      "nodes_expanded": 0, "target_x": self.goal_x, "footholds": []}
        record["apex"] = list(apex)
        if not self.noise.silent:
            record["seen_apex"] = list(seen)
        return PlanningCall(plan, record, seen, sensed)


def flown_footholds(record: dict) -> list:
    """The footholds a planning call's ``record`` (``PlanningCall.record``) has the loop fly before it plans again:
    its plan's, or its safe hops' (``planners.base.footholds_to_fly``)."""
    return footholds_to_fly(record["success"], record["footholds"], record.get("safe_footholds"))


def case_result(case_id: str, failure: str | None, final_x: float, plans: list,
                executed: SlipParams | None = None) -> dict:
    """A case's result: {"id", "success", "failure", "final_x", "plans"} (one record per planning call), and
    "executed_params", the mismatched hopper that ran, under noise (``executed``)."""
    result = {"id": case_id, "success": failure is None, "failure": failure, "final_x": final_x, "plans": plans}
    if executed is not None:
        result["executed_params"] = asdict(executed)
    return result
