"""The robot's hops as the plans meant them, from closed-loop runs: what the template and its learned correction are
fitted to (``examples/fit_correction.py``; on height maps, the spatial robot's, ``examples/fit_template.py --robot
spatial``).

A hop counts when the robot flew it aiming at a foothold of a plan, with the energy the plan keeps: hops by Raibert's
placement (no plan), and hops whose stance pumped energy beyond the template's (``EnergyPump``), are the robot doing
something the template does not model. The hop's foothold is the commanded one, where the planner means the robot to
land, so that the fit learns what the robot does when told to land there, its foothold error included; its
``previous`` hop is the one the robot flew before it, whatever it was, at the foothold it touched down on.
"""
from __future__ import annotations

from drakeslip import ApexState
from drakeslip.multibody.fit import Hop
from drakeslip.params import SlipParams

from planners.replanning import flown_footholds


def planned_hops(result: dict, case) -> list[Hop]:
    """The hops of a robot run (``planners.drake_system.run_closed_loop``'s result with its "log") that flew a plan's
    foothold without pumping, in the order flown."""
    log, terrain = result["log"], case.terrain
    plans = {record["stamp"]: record for record in result["plans"]}
    apexes = [tuple(map(float, case.apex))] + [tuple(a) for a in log.apexes]
    hops, previous = [], None
    for k, (stamp, index) in enumerate(log.aimed[:len(apexes) - 1]):
        record = plans.get(stamp)
        footholds = flown_footholds(record) if record is not None and "pumped" not in record else ()
        if index < len(footholds):
            foothold = float(footholds[index])
            hops.append(Hop(apexes[k], foothold, float(terrain.height_at(foothold)), apexes[k + 1], previous))
        touchdown = float(log.footholds[k])
        previous = Hop(apexes[k], touchdown, float(terrain.height_at(touchdown)), apexes[k + 1])
    return hops


def robot_hops(label: str, case, goal_x: float, template: SlipParams, robot=None) -> list[Hop]:
    """The planned hops (``planned_hops``) of ``case`` run on the robot ``robot`` (``RobotParams``; None: the paper's
    hopper's) without noise, ``label`` planning for ``template``."""
    from dataclasses import replace

    from planners.drake_system import REPLAN_AT_EVERY_APEX, run_closed_loop

    ApexState(*map(float, case.apex)).validate()
    config = replace(REPLAN_AT_EVERY_APEX, robot=robot)
    return planned_hops(run_closed_loop(label, case, goal_x, template, config, trajectory=True), case)


def hop_record(hop: Hop) -> dict:
    """A hop as JSON keeps it (``hop_from_record`` reads it back)."""
    return {"apex": list(hop.apex), "foothold": hop.foothold, "height": hop.height, "next_apex": list(hop.next_apex),
            "previous": None if hop.previous is None else hop_record(hop.previous)}


def hop_from_record(record: dict) -> Hop:
    """The hop a ``hop_record`` holds."""
    previous = record["previous"]
    return Hop(tuple(record["apex"]), float(record["foothold"]), float(record["height"]), tuple(record["next_apex"]),
               None if previous is None else hop_from_record(previous))


def map_robot_hops(label: str, case, params: SlipParams) -> list[dict]:
    """The hops (``drakeslip.spatial.multibody.fit.SpatialHop`` as dicts) of the map ``case`` run on the spatial robot
    of the hopper ``params`` without noise, ``label`` replanning at every apex: each from an apex to the foothold
    commanded there, and the apex it reached."""
    from dataclasses import asdict

    from drakeslip.spatial.multibody.fit import hops_from_plans
    from planners.registry import make
    from planners.replanning import ClosedLoopConfig
    from planners.spatial_robot_loop import run_map_case_on_robot

    result = run_map_case_on_robot(make(label), case, params, ClosedLoopConfig(backend="multibody",
                                                                               executed_per_plan=1))
    return [asdict(h) for h in hops_from_plans(result["plans"])]
