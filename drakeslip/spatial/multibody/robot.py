"""The spatial multibody hopper: its parameters and its MultibodyPlant, loaded from the packaged ``robot.sdf``.

The 3D SLIP (``drakeslip.spatial``) is a point mass on a massless spring leg aimed by two gimbal angles. The robot
it stands for has a free-floating body with roll, pitch and yaw inertia, a two-axis hip (a pitch joint from the
body to a small gimbal, a roll joint from the gimbal to the leg: the SLIP's gimbal, in the same order and signs),
each axis on a torque- and speed-limited motor, a telescoping lower leg on the template's spring between a hard
stop at the rest length and a bottom-out stop at ``min_leg_length``, and an unsprung foot ball in compliant,
friction-limited contact. ``SpatialRobotParams`` holds what a robot varies; ``for_hopper`` builds the robot of
any hopper file by scaling the paper's robot's masses, lengths, inertias, motors and contact to the hopper's
units (``drakeslip.units``), so no value is the paper's hopper's unless the hopper is.

Coordinates: world x forward, y to the left, z up. The base is a ``QuaternionFloatingJoint`` (positions: the
body's quaternion w, x, y, z and its origin; velocities: its angular velocity and its origin's velocity, both
in the world frame). At zero hip angles the leg points along the body's -z from the hip at the body's origin.
"""
from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from drakeslip.multibody.robot import SCALING as PLANAR_SCALING, read_sdf_tree, scale_link, scaled_robot, sdf_text, \
    set_sdf_value
from drakeslip.params import SlipParams, check_number
from drakeslip.units import units_of

SDF_PACKAGE, SDF_FILE = "drakeslip.spatial.multibody", "robot.sdf"

# How each field of SpatialRobotParams scales with a hopper's units: the planar robot's fields as there
# (``drakeslip.multibody.robot.SCALING``), the roll and yaw inertias M L^2 and the gimbal's mass M.
SCALING = {**PLANAR_SCALING, "body_roll_inertia": (1, 2, 0), "body_yaw_inertia": (1, 2, 0), "gimbal_mass": (1, 0, 0)}


@dataclass(frozen=True)
class SpatialRobotParams:
    """The spatial multibody hopper's physical values, SI units; the defaults are the paper's hopper's robot.

    ``slip`` — the template: body mass, spring stiffness, rest length (hip to the foot's ground contact),
    bottom-out length, gravity, friction. ``body_roll_inertia``, ``body_pitch_inertia`` 0.25 kg m^2 and
    ``body_yaw_inertia`` 0.4 kg m^2 — a 7 kg body about 0.4 m across with its battery and electronics at the rim
    (radius of gyration 0.19 m about a horizontal axis), about three times the leg's inertia about the hip in both
    directions, so a leg swing in flight turns the body by a quarter of the swing. ``gimbal_mass`` 0.05 kg — the
    hip's cross. ``leg_mass`` 0.35 kg and ``foot_mass`` 0.35 kg (5 % of the body each) — the upper leg with the
    leg actuator, and the lower leg and foot below the spring, whose velocity is lost at each touchdown.
    ``foot_radius`` 0.03 m — a rubber ball. ``leg_damping`` 2 N s/m — the telescope's friction.
    ``hip_torque_limit`` 30 N m and ``hip_speed_limit`` 25 rad/s — each hip axis's geared motor.
    ``leg_force_limit`` 300 N — the leg actuator in series with the spring. ``contact_stiffness`` 2e5 N/m and
    ``contact_dissipation`` 1 s/m — rubber on hard ground. ``time_step`` 1 ms — the plant's step and the
    controller's period.
    """

    slip: SlipParams = field(default_factory=SlipParams)
    body_roll_inertia: float = 0.25
    body_pitch_inertia: float = 0.25
    body_yaw_inertia: float = 0.4
    gimbal_mass: float = 0.05
    leg_mass: float = 0.35
    foot_mass: float = 0.35
    foot_radius: float = 0.03
    leg_damping: float = 2.0
    hip_torque_limit: float = 30.0
    hip_speed_limit: float = 25.0
    leg_force_limit: float = 300.0
    contact_stiffness: float = 2e5
    contact_dissipation: float = 1.0
    time_step: float = 1e-3

    def __post_init__(self):
        if not isinstance(self.slip, SlipParams):
            raise TypeError(f"SpatialRobotParams.slip must be a SlipParams, got {type(self.slip).__name__}")
        for name in SCALING:
            check_number(getattr(self, name), f"SpatialRobotParams.{name}", positive=name != "leg_damping")
        if not self.foot_radius < self.slip.min_leg_length / 2:
            raise ValueError(f"SpatialRobotParams.foot_radius must be below half the bottom-out length "
                             f"{self.slip.min_leg_length}, got {self.foot_radius}")

    @classmethod
    def for_hopper(cls, slip: SlipParams, **overrides) -> "SpatialRobotParams":
        """The robot of the hopper ``slip``: the paper's robot with every value in ``slip``'s units (``SCALING``;
        for the paper's hopper each factor is exactly 1), then ``overrides`` by field name."""
        return scaled_robot(cls, SCALING, slip, overrides)

    @property
    def rest_extension(self) -> float:
        """The leg joint's position at the spring's rest length (the hard stop): foot centre below the hip."""
        return self.slip.leg_length - self.foot_radius

    @property
    def bottom_extension(self) -> float:
        """The leg joint's position at bottom-out."""
        return self.slip.min_leg_length - self.foot_radius

    @property
    def total_mass(self) -> float:
        return self.slip.mass + self.gimbal_mass + self.leg_mass + self.foot_mass

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "SpatialRobotParams":
        d = dict(d)
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ValueError(f"unknown SpatialRobotParams fields: {', '.join(unknown)}")
        return cls(slip=SlipParams(**d.pop("slip")), **d)

    def with_slip(self, slip: SlipParams) -> "SpatialRobotParams":
        """These values on another template (a noise profile's drawn spring, mass and friction)."""
        return replace(self, slip=slip)


def _model(params: SpatialRobotParams):
    """The packaged SDF's tree with ``params`` written into it, and its links by name."""
    root = read_sdf_tree(SDF_PACKAGE, SDF_FILE)
    model = root.find("model")
    links = {link.get("name"): link for link in model.findall("link")}
    joints = {joint.get("name"): joint for joint in model.findall("joint")}
    length = units_of(params.slip).length
    for name, mass in (("body", params.slip.mass), ("gimbal", params.gimbal_mass), ("leg", params.leg_mass),
                       ("foot", params.foot_mass)):
        scale_link(links[name], mass, length)
    for axis, value in zip(("ixx", "iyy", "izz"),
                           (params.body_roll_inertia, params.body_pitch_inertia, params.body_yaw_inertia)):
        set_sdf_value(links["body"], f"inertial/inertia/{axis}", value)
    set_sdf_value(links["foot"], "visual[@name='foot_visual']/geometry/sphere/radius", params.foot_radius)
    set_sdf_value(links["foot"], "collision/geometry/sphere/radius", params.foot_radius)
    props = links["foot"].find("collision/drake__proximity_properties")
    set_sdf_value(props, "drake__point_contact_stiffness", params.contact_stiffness)
    set_sdf_value(props, "drake__hunt_crossley_dissipation", params.contact_dissipation)
    for tag in ("drake__mu_dynamic", "drake__mu_static"):
        set_sdf_value(props, tag, params.slip.friction)
    for name in ("hip_pitch", "hip_roll"):
        set_sdf_value(joints[name], "axis/limit/effort", params.hip_torque_limit)
        set_sdf_value(joints[name], "axis/limit/velocity", params.hip_speed_limit)
    leg = joints["leg_spring"]
    set_sdf_value(leg, "axis/limit/lower", params.bottom_extension)
    set_sdf_value(leg, "axis/limit/upper", params.rest_extension)
    set_sdf_value(leg, "axis/limit/effort", params.leg_force_limit)
    set_sdf_value(leg, "axis/dynamics/damping", params.leg_damping)
    return root, links


def spatial_hopper_sdf(params: SpatialRobotParams) -> str:
    """The packaged SDF with ``params`` written into it."""
    return sdf_text(_model(params)[0])


@dataclass(frozen=True)
class SpatialGeometry:
    """What the controller and the monitor know of the robot beyond ``SpatialRobotParams``, read from its model file:
    ``leg_com`` [m], the upper leg's centre of mass below the hip; ``leg_inertia`` [kg m^2], the upper leg's and the
    foot's inertias about their centres of mass together, (across the leg, along it); ``body_half`` [m], half the body
    box's sides (x, y, z)."""

    leg_com: float
    leg_inertia: tuple
    body_half: tuple


@functools.lru_cache(maxsize=16)
def spatial_geometry(params: SpatialRobotParams) -> SpatialGeometry:
    """The ``SpatialGeometry`` of the robot ``params`` builds."""
    _, links = _model(params)
    leg, foot = links["leg"].find("inertial"), links["foot"].find("inertial")
    size = links["body"].find("visual[@name='body_visual']/geometry/box/size").text.split()
    return SpatialGeometry(
        leg_com=-float(leg.find("pose").text.split()[2]),
        leg_inertia=tuple(float(leg.find(f"inertia/{axis}").text) + float(foot.find(f"inertia/{axis}").text)
                          for axis in ("ixx", "izz")),
        body_half=tuple(float(v) / 2 for v in size))


@dataclass(frozen=True)
class SpatialLayout:
    """Where the robot's values live in the plant's state vector (positions then velocities) and actuation:
    ``quaternion`` (w, x, y, z) and ``position`` of the body, ``hip`` (pitch, roll) and ``leg`` positions;
    ``angular`` and ``linear`` velocity of the body (world frame), ``hip_rates`` and ``leg_rate``; ``actuation``
    the indices of (hip pitch, hip roll, leg) in the actuation vector of ``n_actuators``; ``size`` the state's."""

    quaternion: tuple
    position: tuple
    hip: tuple
    leg: int
    angular: tuple
    linear: tuple
    hip_rates: tuple
    leg_rate: int
    actuation: tuple
    n_actuators: int
    size: int


@dataclass(frozen=True)
class SpatialHopperParts:
    """The hopper's elements in its plant: model instance, bodies, the base and the joints."""

    model: object
    body: object
    foot: object
    base: object
    hip_pitch: object
    hip_roll: object
    leg: object

    def layout(self, plant) -> SpatialLayout:
        """The robot's ``SpatialLayout`` in the finalized ``plant``."""
        nq = plant.num_positions()
        q0, v0 = self.base.position_start(), nq + self.base.velocity_start()
        order = tuple(int(plant.GetJointActuatorByName(name, self.model).input_start())
                      for name in ("hip_pitch", "hip_roll", "leg_spring"))
        return SpatialLayout(
            quaternion=tuple(range(q0, q0 + 4)), position=tuple(range(q0 + 4, q0 + 7)),
            hip=(self.hip_pitch.position_start(), self.hip_roll.position_start()), leg=self.leg.position_start(),
            angular=tuple(range(v0, v0 + 3)), linear=tuple(range(v0 + 3, v0 + 6)),
            hip_rates=(nq + self.hip_pitch.velocity_start(), nq + self.hip_roll.velocity_start()),
            leg_rate=nq + self.leg.velocity_start(), actuation=order, n_actuators=plant.num_actuators(),
            size=nq + plant.num_velocities())


def add_spatial_hopper(plant, params: SpatialRobotParams) -> SpatialHopperParts:
    """Parse the hopper into ``plant`` (not yet finalized) and add its floating base and leg spring."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.tree import PrismaticSpring, QuaternionFloatingJoint

    (model,) = Parser(plant, "spatial_hopper").AddModelsFromString(spatial_hopper_sdf(params), "sdf")
    body = plant.GetBodyByName("body", model)
    base = plant.AddJoint(QuaternionFloatingJoint("base", plant.world_frame(), body.body_frame()))
    leg = plant.GetJointByName("leg_spring", model)
    plant.AddForceElement(PrismaticSpring(leg, params.rest_extension, params.slip.stiffness))
    return SpatialHopperParts(model, body, plant.GetBodyByName("foot", model), base,
                              plant.GetJointByName("hip_pitch", model), plant.GetJointByName("hip_roll", model), leg)


def leg_direction(pitch: float, roll: float) -> np.ndarray:
    """The unit vector from the hip to the foot in the body frame at hip angles (pitch, roll): the SLIP's gimbal,
    (sin p cos r, sin r, -cos p cos r)."""
    return np.array([math.sin(pitch) * math.cos(roll), math.sin(roll), -math.cos(pitch) * math.cos(roll)])
