"""The robot's use of its leg actuator beyond the template's (``EnergyPump``): where and by how much it raises its
apex above the one a plan keeps."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip.multibody.controller import neutral_angle
from drakeslip.multibody.gains import CLEARANCE, control_constants
from drakeslip.multibody.robot import RobotParams
from drakeslip.params import SlipParams
from drakeslip.state import ApexState
from drakeslip.terrain import Terrain
from drakeslip.units import units_of

PUMP_RISE = 0.15    # [m] apex height a pumping hop adds, in the paper's hopper's lengths
PUMPS_WITHOUT_PLAN = 3   # pumping hops in a row from apexes with no plan before the robot gives up
LEVEL = 0.02        # [m] ground this close to the height under the hip is level for a hop in place, in the paper's
                    # hopper's lengths (its terrains' steps are 5 cm or more)


@dataclass(frozen=True)
class EnergyPump:
    """The robot's use of its leg actuator beyond the template's: the template has none, so every apex of a plan
    keeps the energy of the apex it starts from, and from a low start before a high step its only plans skim over
    the step with the body less than a leg length above it. A robot's leg, swung through under the hip in flight,
    meets the ground there. When a plan passes an apex from which the foot, held at the neutral angle through the
    apex (``neutral_angle``), is less than the controller's ``CLEARANCE`` above the ground under it or the ground
    under the hip, the robot flies the plan's first hop and aims its stance at an apex ``rise`` [m] higher than
    the one it left; the next apex's plan starts from there. From an apex with no plan (a start too low for the
    template to climb anything ahead, say) it hops on the spot's level ground instead, at its speed by Raibert's
    placement, where the ground is ``level`` [m] for the hop (``room``), up to PUMPS_WITHOUT_PLAN times in a row.
    ``reach`` [m]: hip to the foot's contact at the leg's rest length; ``stance`` [s]: the robot's stance time
    (``drakeslip.multibody.gains.stance_time``); ``clearance`` [m]: the controller's ``CLEARANCE`` in the robot's
    lengths (both from ``control_constants``)."""

    reach: float
    rise: float
    level: float
    stance: float
    clearance: float = CLEARANCE

    @classmethod
    def for_robot(cls, robot: RobotParams, params: SlipParams) -> "EnergyPump":
        """``robot``'s pump when it plans for the template ``params``: its leg's reach and stance time, PUMP_RISE
        and LEVEL in the template's lengths."""
        length, scaled = units_of(params).length, control_constants(robot.slip)
        return cls(robot.slip.leg_length, PUMP_RISE * length, LEVEL * length, scaled.stance_time, scaled.clearance)

    def wanted(self, planned_apexes, seen: ApexState, sensed: Terrain, gravity: float, pumps_in_a_row: int,
               safe_hop: bool = False) -> bool:
        """Whether the robot pumps from the apex ``seen`` on the map ``sensed``: with a plan (its
        ``planned_apexes``), where its leg cannot swing through one of them (``needed``); with none (None), unless
        the last ``pumps_in_a_row`` hops pumped without a plan PUMPS_WITHOUT_PLAN times, while it flies a safe hop
        (``safe_hop``: to regain the energy from which a plan exists) or where the ground has ``room`` for a hop in
        place."""
        if planned_apexes is not None:
            return self.needed(planned_apexes, sensed)
        return pumps_in_a_row < PUMPS_WITHOUT_PLAN and (safe_hop or self.room(seen, sensed, gravity))

    def energy(self, seen: ApexState, gravity: float) -> float:
        """The energy per kg of body [J/kg] the stance after the apex ``seen`` aims at: an apex ``rise`` higher."""
        return gravity * (seen.z + self.rise) + 0.5 * seen.xdot ** 2

    def needed(self, apexes, terrain: Terrain) -> bool:
        """Whether any of the planned ``apexes`` ((x, z, xdot) rows) is one the leg cannot swing through."""
        for x, z, xdot in apexes:
            angle = neutral_angle(xdot, self.reach, self.stance)
            foot_x = x + self.reach * math.sin(angle)
            ground = max(float(terrain.height_at(x)), float(terrain.height_at(foot_x)))
            if z - self.reach * math.cos(angle) - ground < self.clearance:
                return True
        return False

    def room(self, apex: ApexState, terrain: Terrain, gravity: float) -> bool:
        """Whether a hop from ``apex`` at its speed to an apex ``rise`` higher lands and lifts off on level ground:
        the ground from a leg behind the hip to a leg past that apex within ``level`` of the ground under the hip."""
        ground = float(terrain.height_at(apex.x))
        fall = max(apex.z - ground - self.reach, 0.0)
        hop = apex.xdot * (math.sqrt(2 * fall / gravity) + self.stance + math.sqrt(2 * (fall + self.rise) / gravity))
        xs = np.arange(apex.x - self.reach, apex.x + hop + self.reach, 0.5 * terrain.cell)
        return bool(np.all(np.abs(terrain.height_at(xs) - ground) <= self.level))
