"""Multi-hop simulation of the SlipHopper3D in Drake's Simulator, and the Drake backend of the spatial step map."""
from __future__ import annotations

import math
from typing import Callable, Sequence

from drakeslip.params import SlipParams
from drakeslip.simulation import IntegratorConfig, SimulationResult, counted_policy, policy_from, run_hopper
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.slip_hopper import SlipHopper3D
from drakeslip.spatial.state import ApexState3D, StepResult3D, check_apex3d
from drakeslip.units import HOP_SECONDS, RUN_SECONDS, units_of


class SimulationResult3D(SimulationResult):
    """A logged multi-hop trajectory of the spatial hopper, as ``drakeslip.SimulationResult`` logs the planar one:
    ``states`` (N, 6) (x, y, z, xdot, ydot, zdot), ``hybrid`` (N, 11) (HybridState3D), and ``terrain`` the height map
    it ran on (also ``height_map``)."""

    @property
    def height_map(self) -> HeightMap:
        return self.terrain

    @property
    def apexes(self) -> list[ApexState3D]:
        """Every apex reached after the start."""
        return [ApexState3D(*e.state[:5]) for e in self.events if e.kind == "apex"]

    @property
    def footholds(self) -> list[tuple]:
        """(x, y, z) of every touchdown."""
        return [e.foot for e in self.events if e.kind == "touchdown"]


# many parameters: the options of a public entry point, each with a default, as ``drakeslip.simulate``'s
def simulate3d(apex, leg_angles: Sequence | Callable, height_map: HeightMap | None = None,
               params: SlipParams | None = None, max_hops: int | None = None, max_time: float | None = None,
               max_hop_time: float | None = None, integrator: IntegratorConfig | None = None,
               log: bool = True, add_to: Callable | None = None) -> SimulationResult3D:
    """``drakeslip.simulate`` for the spatial hopper: hops from ``apex`` (x, y, z, xdot, ydot) on ``height_map`` until
    the first failure, the commands run out, ``max_hops`` apexes or ``max_time``. ``leg_angles`` is a list of
    (pitch, roll), one per hop, or a callback ``f(apex: ApexState3D, hop_index) -> (pitch, roll) | None``."""
    params = params or SlipParams()
    height_map = height_map or HeightMap.flat()
    apex = check_apex3d(apex, height_map, params)
    units = units_of(params)
    max_time, max_hop_time = units.time_or(max_time, RUN_SECONDS), units.time_or(max_hop_time, HOP_SECONDS)
    if max_hops is not None and max_hops < 1:
        raise ValueError(f"max_hops must be at least 1, got {max_hops}")
    used: list = []
    pair = lambda c: (float(c[0]), float(c[1]))   # noqa: E731 - a command's (pitch, roll) as floats
    policy = counted_policy(policy_from(leg_angles, pair), max_hops, used, pair)
    hopper = SlipHopper3D(params, height_map)
    times, states, hybrid, events, failure_event, steps = run_hopper(
        hopper, lambda context: hopper.set_apex(context, apex), policy, max_time, max_hop_time,
        integrator or IntegratorConfig(), log, add_to)
    return SimulationResult3D(times=times, states=states, hybrid=hybrid, events=events,
                              failure=failure_event.failure if failure_event else None, failure_event=failure_event,
                              integrator_steps=steps, params=params, terrain=height_map, leg_angles=used)


def drake_step3d(apex, leg_angles, height_map: HeightMap, params: SlipParams,
                 integrator: IntegratorConfig | None = None) -> StepResult3D:
    """The spatial step map on the Drake hybrid simulator: one commanded hop, then halt at the next apex."""
    sim = simulate3d(apex, [tuple(leg_angles)], height_map, params, integrator=integrator, log=False)
    touchdown = next((e for e in sim.events if e.kind == "touchdown"), None)
    foothold = touchdown.foot if touchdown else (math.nan,) * 3
    if sim.failure is not None:
        e = sim.failure_event
        return StepResult3D(ok=False, failure=sim.failure, foothold=foothold, next_apex=None, time=e.time,
                            end_state=e.state, work=sim.integrator_steps)
    apex_event = next((e for e in sim.events if e.kind == "apex"), None)
    if apex_event is None:
        raise RuntimeError("Drake simulation ended without an apex or a failure")
    return StepResult3D(ok=True, failure=None, foothold=foothold, next_apex=ApexState3D(*apex_event.state[:5]),
                        time=apex_event.time, end_state=apex_event.state, work=sim.integrator_steps)
