"""The receding-horizon loop on a height map (``planners.closed_loop`` in the plane): perceive the window ahead,
plan, fly the plan's first footholds, replan from the apex reached; until a foothold reaches the goal, a failure, no
plan, or the hop cap. Where a replan finds no sequence, the loop flies on along the last plan that found one (its
footholds not flown yet: the sequence the robot is on still reaches where it reached), then a plan's safe hops
(``Plan.to_fly``); "no plan" is left for an apex with neither.

On Drake the loop is one simulation of the ``SlipHopper3D``: its apex policy (``drakeslip.hybrid_hopper.ApexPolicy``)
plans when the footholds it was given run out and aims the leg at the next one with the spatial controller, so the
run is one continuous trajectory (a replay draws it whole). On the fast backend each hop is one compiled step. The
loop's settings are ``planners.replanning.ClosedLoopConfig``'s.

Under a noise profile (``drakeslip.noise``, drawn in three dimensions by ``drakeslip.spatial.noise``) the planner
and the controller are told a noisy apex and see a noisy perception window (filtered by the robot's ``map_filter``),
the controller aims from the apex told, the leg reaches the commanded angles plus their errors, and the hops run on
the executed hopper (the model with the case's spring, mass and friction errors) on the true map. As in the plane,
every draw comes from one generator per case (``case_seed``): first the executed hopper, then per planning call the
apex errors of its hops, their leg-angle errors and the sensed window. The robot aims GOAL_SIGMAS standard deviations
of x past the goal, believes it is there when a hop it aims passes within GOAL_RADIUS of that point (``passes_goal``,
the plan's search's test: the way from the foothold before it, or from the apex the plan was made from, to the
foothold aimed at), and succeeds when the hop between the last two footholds it reached passes the goal in the same
way.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from drakeslip.params import SlipParams
from drakeslip.spatial.controller import leg_angles_for
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.noise import angle_errors3d, apex_errors3d, perceived_map
from drakeslip.spatial.simulation import simulate3d
from drakeslip.spatial.stepmap import step3d
from drakeslip.terrain import WINDOW_AHEAD, WINDOW_BEHIND
from drakeslip.units import units_of

from planners.core.spatial_tree import reaches
from planners.replanning import GOAL_SIGMAS, ClosedLoopConfig, case_result, case_seed, drawn_hopper
from planners.search.spatial_problem import GOAL_RADIUS, WINDOW_ASIDE, goal_reach

# the template's backends (``run_map_case``) and the spatial robot (``planners.spatial_robot_loop``)
MAP_LOOP_BACKENDS = ("drake", "fast", "multibody")


@dataclass(frozen=True)
class MapCase:
    """A case on a height map: its id, the map, the start apex (x, y, z, xdot, ydot) and the goal (x, y)."""

    id: str
    terrain: HeightMap
    apex: tuple
    goal: tuple


def passes_goal(before, foothold, goal, radius: float) -> bool:
    """Whether the hop from ``before`` (x, y, ...: the foothold before it, or the body where a plan starts) to
    ``foothold`` reaches the goal: its way passes within ``radius`` of it (the test the plan's search made,
    ``planners.search.spatial_problem.goal_reach``): the case's success."""
    return reaches(float(before[0]), float(before[1]), float(foothold[0]), float(foothold[1]), goal_reach(goal, radius))


def past_goal(start, goal, margin: float) -> tuple:
    """The point ``margin`` [m] past ``goal`` on the way from ``start`` to it (the goal itself for no margin)."""
    if margin == 0:
        return goal
    hx, hy = goal[0] - start[0], goal[1] - start[1]
    norm = math.hypot(hx, hy) or 1.0
    return goal[0] + margin * hx / norm, goal[1] + margin * hy / norm


class MapLoop:
    """The loop's state for one case: the plans so far, the footholds left to fly, the outcome; under noise, the
    case's generator, the executed hopper and the errors drawn for the current plan's hops."""

    def __init__(self, planner, case: MapCase, params: SlipParams, config: ClosedLoopConfig,
                 checks_flying_on: bool = False, plans_for: SlipParams | None = None):
        if config.backend not in MAP_LOOP_BACKENDS:
            raise ValueError(f"backend {config.backend!r} does not run height maps; choose one of {MAP_LOOP_BACKENDS}")
        self.planner, self.case, self.params, self.config = planner, case, params, config
        # a robot's loop flies a queued foothold, or on along the last plan, only where the template's hop from the
        # apex told lands there (the robot is not where the template would be: its last plan may no longer fit)
        self.checks_flying_on = checks_flying_on
        self.plans_for = plans_for or params   # the template the planner plans for (a robot's: see its loop)
        self.radius = GOAL_RADIUS * units_of(params).length
        self.noise = config.noise.for_hopper(params)
        self.rng = np.random.default_rng(case_seed(config.seed, case.id))
        self.executed = drawn_hopper(self.noise, params, self.rng)   # the generator's first draw, as in the plane
        # a robot unsure of its x by sigma aims 5 sigma past the goal, so that believing it is past means being past
        self.aim = past_goal(case.apex, case.goal, GOAL_SIGMAS * self.noise.apex[0])
        self.plans, self.queue, self.failure, self.done = [], [], None, False
        self.window = None   # the map the last plan was made on, as sensed
        self.rest = []   # the footholds of the last sequence found after those queued
        self.before = case.apex[:2]   # where the next hop's way starts: the apex a plan starts from, then its footholds
        self.hops, self.flown = 0, 0   # hops in all, and of the current plan
        self.apex_errors = self.angle_errors = None   # the current plan's hops' (None without noise)

    def copy(self) -> "MapLoop":
        """A copy that changes apart from this loop: its own records, queue and generator (the planner, the case and
        the settings shared)."""
        twin = copy.copy(self)
        twin.plans = [dict(record, executed=list(record["executed"])) for record in self.plans]
        twin.queue, twin.rest = list(self.queue), list(self.rest)
        twin.rng = copy.deepcopy(self.rng)
        return twin

    def told(self, apex, hop: int) -> tuple:
        """The apex the robot is told at the current plan's ``hop``: the true one plus its drawn error."""
        if self.apex_errors is None:
            return tuple(apex)
        return tuple(float(v) for v in np.asarray(apex, dtype=np.float64) + self.apex_errors[hop])

    def next_foothold(self, apex):
        """The foothold the hop from ``apex`` aims at: the next of the queue, planned when it is empty. None ends the
        run (goal passed, no plan, hop cap). A robot's loop (``planners.spatial_robot_loop``) asks this at each
        apex and leaves the aiming to the robot's controller."""
        if self.done or self.failure is not None:
            return None
        if self.hops >= self.config.max_hops:
            self.failure = "HOP_CAP"
            return None
        if self.queue and self.checks_flying_on and not self.hop_lands(self.told(apex, self.flown), self.queue[0],
                                                                       self.window):
            self.queue = []   # the robot is not where the plan meant it to be: the next foothold no longer fits
        if not self.queue and not self.replan(apex):
            return None
        target = self.queue.pop(0)
        self.plans[-1]["executed"].append([float(v) for v in target])
        self.hops, self.flown = self.hops + 1, self.flown + 1
        if passes_goal(self.before, target, self.aim, self.radius):
            self.done = True   # this hop passes the goal: the run ends at the apex after it
        self.before = target
        return target

    def command(self, apex, hop: int):
        """The leg command at ``apex``: the leg angles that aim at ``next_foothold`` from the apex told; under noise,
        the angles the leg reaches. None ends the run (goal passed, no plan, hop cap)."""
        target = self.next_foothold(apex)
        if target is None:
            return None
        try:
            angles = leg_angles_for(self.told(apex, self.flown - 1), target, self.params)
        except ValueError:
            self.failure = "UNREACHABLE"
            return None
        if self.angle_errors is None:
            return angles
        return tuple(float(a + e) for a, e in zip(angles, self.angle_errors[self.flown - 1]))

    def hop_lands(self, apex, foothold, window: HeightMap) -> bool:
        """Whether the template's hop from ``apex`` aimed at ``foothold`` lands there (within 1 cm) on ``window``."""
        try:
            hop = step3d(tuple(apex), leg_angles_for(tuple(apex), foothold, self.plans_for), window, self.plans_for)
        except ValueError:   # out of the leg's reach
            return False
        miss = math.hypot(hop.foothold[0] - foothold[0], hop.foothold[1] - foothold[1])
        return bool(hop.ok) and miss < 0.01 * units_of(self.params).length

    def replan(self, apex) -> bool:
        """Plan from ``apex`` (told with this plan's first error) on the window the robot senses; False: no plan."""
        k, self.flown = self.config.executed_per_plan, 0
        if not self.noise.silent:   # the draws' order: the apex errors of the k hops, their angle errors, the map
            self.apex_errors = apex_errors3d(self.noise, self.rng, k)
            self.angle_errors = angle_errors3d(self.noise, self.rng, k)
        seen, goal = self.told(apex, 0), self.aim
        window = perception_window(self.case.terrain, seen, goal, self.params)
        if not self.noise.silent:
            window = perceived_map(self.noise, window, self.rng, self.config.map_filter)
        self.window = window
        try:
            plan = self.planner.plan(tuple(float(v) for v in seen), window, goal, self.plans_for)
            record = plan.summary()
        except ValueError as refusal:   # a noisy apex the planner cannot start from (below the ground it sees)
            if self.noise.silent:
                raise
            plan, record = None, {"success": False, "message": str(refusal), "ode_calls": 0, "t_plan_s": 0.0,
                                  "nodes_expanded": 0, "target_x": goal[0], "target_y": goal[1], "footholds": []}
        record.update(apex=[float(v) for v in apex], executed=[])
        if not self.noise.silent:
            record["seen_apex"] = list(seen)
        self.plans.append(record)
        if plan is not None and plan.success:
            footholds, self.before = [tuple(f) for f in plan.footholds], seen[:2]
        elif self.rest and (not self.checks_flying_on or self.hop_lands(seen, self.rest[0], window)):
            # on along the last sequence found, from its last foothold flown
            footholds = self.rest
            record["flies_on"] = len(footholds)
        else:   # a plan's safe hops where the planner was asked for them: at most k, so none is left after them
            footholds, self.before = ([] if plan is None else [tuple(f) for f in plan.to_fly(k)]), seen[:2]
        if not footholds:
            self.failure = "NO_PLAN"
            return False
        self.queue, self.rest = footholds[:k], footholds[k:]
        return True


def perception_window(height_map: HeightMap, at, goal, params: SlipParams) -> HeightMap:
    """The part of ``height_map`` a hopper at ``at`` (x, y, ...) senses looking toward ``goal`` (x, y): WINDOW_AHEAD
    ahead, WINDOW_BEHIND behind and WINDOW_ASIDE to either side, in the hopper's lengths."""
    length = units_of(params).length
    return height_map.perceived(at[0], at[1], (goal[0] - at[0], goal[1] - at[1]), WINDOW_AHEAD * length,
                                WINDOW_ASIDE * length, WINDOW_BEHIND * length)


def run_map_case(planner, case: MapCase, params: SlipParams, config: ClosedLoopConfig = ClosedLoopConfig()):
    """One case on a height map in the receding-horizon loop: (the case's result as ``case_result`` writes it, the
    Drake run (``SimulationResult3D``; None on the fast backend)). ``final_x`` is the last apex's x; "final" in the
    result holds its (x, y); under noise "executed_params" is the hopper that ran."""
    if config.backend == "multibody":
        raise ValueError("the multibody backend runs a map case on the robot: "
                         "planners.spatial_robot_loop.run_map_case_on_robot")
    loop = MapLoop(planner, case, params, config)
    sim, reached = None, []   # reached: the footholds the hopper touched down on
    if config.backend == "drake":
        sim = simulate3d(case.apex, loop.command, case.terrain, loop.executed, max_hops=config.max_hops + 1)
        failure = sim.failure.name if sim.failure is not None else loop.failure
        final = sim.apexes[-1] if sim.apexes else case.apex
        reached = list(sim.footholds)
    else:
        apex, failure = tuple(case.apex), None
        while True:
            command = loop.command(apex, loop.hops)
            if command is None:
                failure = loop.failure
                break
            hop = step3d(apex, command, case.terrain, loop.executed)
            if not hop.ok:
                failure = hop.failure.name
                break
            apex = tuple(hop.next_apex)
            reached.append(hop.foothold)
        final = apex
    return map_case_result(loop, case, failure, final, reached), sim


def map_case_result(loop: MapLoop, case: MapCase, failure: str | None, final, reached) -> dict:
    """The result of a run of ``loop`` on ``case`` (on any backend) that ended with ``failure`` (None: the loop's last
    hop was flown) at the apex ``final`` (x, y, ...), having touched down on the footholds ``reached``: as
    ``case_result`` writes it, with "final" (x, y). A run the loop did not end, or under noise one whose hop between
    the last two footholds it reached does not pass the goal, stopped short."""
    if failure is None and not loop.done:
        failure = "STOPPED_SHORT"
    noisy = not loop.noise.silent
    if failure is None and noisy and not (reached and passes_goal(([case.apex] + reached)[-2], reached[-1], case.goal,
                                                                  loop.radius)):
        failure = "STOPPED_SHORT"   # the robot believed its hop passed the goal; the hop between the footholds it
        # reached did not
    result = case_result(case.id, failure, float(final[0]), loop.plans, loop.executed if noisy else None)
    result["final"] = [float(final[0]), float(final[1])]
    return result
