"""The multibody hopper: its parameters and its MultibodyPlant, loaded from the packaged ``robot.sdf``.

The SLIP template is a point mass on a massless spring leg. The robot it stands for has a body with a pitch
inertia, a leg swung by a torque- and speed-limited hip motor, a telescoping lower leg on the template's spring
between a hard stop at the rest length and a bottom-out stop at the template's ``min_leg_length``, and an unsprung
foot that makes compliant, friction-limited contact. ``RobotParams`` holds the values a robot varies (defaults are
the SDF's); ``add_hopper`` writes them into the SDF before parsing it and adds the planar floating base (x, z,
pitch). ``model_geometry`` reads from the same SDF what the controller and the failure monitor know of the rest.

Coordinates: world x forward, z up; the hopper moves in the x-z plane. The pitch and the hip angle turn about
-y, so that a positive pitch lifts the nose and a positive absolute leg angle (pitch + hip) puts the foot ahead
of the hip, the SLIP's leg-angle convention (``drakeslip.state``).
"""
from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field, replace
from importlib import resources

import numpy as np

from drakeslip.params import SlipParams, check_number
from drakeslip.units import units_of

SDF_FILE = "robot.sdf"

# [m] how far the foot ball rolls in stance and is dragged at liftoff, at most, on the suites' hops; the paper's
# hopper's, in a hopper's own lengths
FOOT_TRAVEL = 0.05
# How each field of RobotParams scales with a hopper's units (drakeslip.units.HopperUnits): powers of (mass, length,
# time). Inertias M L^2; torques M L^2 / T^2; a motor's speed limit 1 / T; forces M L / T^2; damping [N s/m] M / T;
# contact stiffness [N/m] M / T^2; Hunt-Crossley dissipation [s/m] T / L.
SCALING = {"body_pitch_inertia": (1, 2, 0), "leg_mass": (1, 0, 0), "foot_mass": (1, 0, 0), "foot_radius": (0, 1, 0),
           "leg_damping": (1, 0, -1), "hip_torque_limit": (1, 2, -2), "hip_speed_limit": (0, 0, -1),
           "leg_force_limit": (1, 1, -2), "contact_stiffness": (1, 0, -2), "contact_dissipation": (0, -1, 1),
           "time_step": (0, 0, 1)}


def scaled_robot(cls, scaling: dict, slip: SlipParams, overrides: dict):
    """The robot ``cls`` of the hopper ``slip``: ``cls``'s defaults (the paper's hopper's robot) with each field of
    ``scaling`` in ``slip``'s units (for the paper's hopper each factor is exactly 1), then ``overrides`` by field
    name."""
    units = units_of(slip)
    base = cls()
    values = {name: getattr(base, name) * units.mass ** m * units.length ** length * units.time ** t
              for name, (m, length, t) in scaling.items()}
    values.update(overrides)
    return cls(slip=slip, **values)


@dataclass(frozen=True)
class RobotParams:
    """The multibody hopper's physical values, SI units.

    ``slip`` — the template the robot is built around: body mass, spring stiffness, rest length (hip to the
    foot's ground contact), bottom-out length, gravity and the foot-ground friction, the paper's hopper by
    default. ``body_pitch_inertia`` 0.25 kg m^2 — a 7 kg body about 0.6 m long with its battery and electronics
    at the ends (radius of gyration 0.19 m); it is about three times the leg's inertia about the hip, so the
    flight-phase leg swing pitches the body by a quarter of the swing angle, as in Raibert's planar hopper.
    ``leg_mass`` 0.35 kg (5 % of the body) — the upper leg with the leg actuator, swung by the hip motor;
    ``foot_mass`` 0.35 kg (5 %) — lower leg and foot below the spring, the unsprung mass whose velocity is lost
    at each touchdown. ``foot_radius`` 0.03 m — a rubber foot ball. ``leg_damping`` 2 N s/m — the telescope's
    friction, under 1 % of critical damping of the body on the spring. ``hip_torque_limit`` 30 N m and
    ``hip_speed_limit`` 25 rad/s — a small geared motor that swings the leg through 0.6 rad in well under the
    0.3 s of a flight. ``leg_force_limit`` 300 N — the leg actuator in series with the spring, about half the
    spring force at bottom-out, enough to return a hop's touchdown losses within one stance.
    ``contact_stiffness`` 2e5 N/m and ``contact_dissipation`` 1 s/m — a rubber foot on hard ground: a few mm
    of penetration at the peak stance force. ``time_step`` 1 ms — the plant's discrete step and the
    controller's period, a typical 1 kHz robot control loop.
    """

    slip: SlipParams = field(default_factory=SlipParams)
    body_pitch_inertia: float = 0.25
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
            raise TypeError(f"RobotParams.slip must be a SlipParams, got {type(self.slip).__name__}")
        for name in SCALING:
            check_number(getattr(self, name), f"RobotParams.{name}", positive=name != "leg_damping")
        if not self.foot_radius < self.slip.min_leg_length / 2:
            raise ValueError(f"RobotParams.foot_radius must be below half the bottom-out length "
                             f"{self.slip.min_leg_length}, got {self.foot_radius}")

    @classmethod
    def for_hopper(cls, slip: SlipParams, **overrides) -> "RobotParams":
        """The robot of the hopper ``slip``: the paper's robot with every value in ``slip``'s units (``SCALING``),
        then ``overrides`` by field name."""
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
    def face_keep_out(self) -> float:
        """How far before a step's face [m] the robot's planner places no foothold: the foot ball's radius plus
        FOOT_TRAVEL, the ball's rolling in stance and its drag at liftoff. Nearer, the ball catches the face as
        it leaves the ground and the body's angular momentum jumps."""
        return self.foot_radius + FOOT_TRAVEL * units_of(self.slip).length

    @property
    def total_mass(self) -> float:
        return self.slip.mass + self.leg_mass + self.foot_mass

    def with_slip(self, slip: SlipParams) -> "RobotParams":
        """These values on another template (a noise profile's drawn spring, mass and friction)."""
        return replace(self, slip=slip)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "RobotParams":
        d = dict(d)
        return cls(slip=SlipParams(**d.pop("slip")), **d)


def set_sdf_value(root, path: str, value) -> None:
    """Write ``value`` (a number, or a string as it is) into the element at ``path`` under ``root``."""
    node = root.find(path)
    node.text = repr(float(value)) if not isinstance(value, str) else value


def read_sdf_tree(package: str, name: str):
    """The SDF file ``name`` of ``package`` as an element tree, its ``drake:`` tags read as ``drake__`` (the prefix
    has no declared namespace); ``sdf_text`` writes it back."""
    text = resources.files(package).joinpath(name).read_text()
    return ET.fromstring(text.replace("drake:", "drake__"))


def sdf_text(root) -> str:
    """The SDF text of a tree ``read_sdf_tree`` read."""
    return ET.tostring(root, encoding="unicode").replace("drake__", "drake:")


def scale_link(link, mass: float, length: float) -> None:
    """Give ``link`` the ``mass`` and every length of it (poses, shapes) times ``length``, its inertia scaled with
    the mass and the length squared: the paper's robot's part, in another hopper's units."""
    inertial = link.find("inertial")
    paper_mass = float(inertial.find("mass").text)
    set_sdf_value(inertial, "mass", mass)
    for entry in inertial.find("inertia"):
        entry.text = repr(float(entry.text) * mass / paper_mass * length ** 2)
    for pose in link.iter("pose"):
        values = [float(v) for v in pose.text.split()]
        pose.text = " ".join(repr(v) for v in [*(c * length for c in values[:3]), *values[3:]])
    for tag in ("radius", "length"):
        for node in link.iter(tag):
            node.text = repr(float(node.text) * length)
    for node in link.iter("size"):
        node.text = " ".join(repr(float(v) * length) for v in node.text.split())


def _model_links(params: RobotParams):
    """The packaged SDF's tree with ``params`` written into it, and its links by name."""
    root = read_sdf_tree("drakeslip.multibody", SDF_FILE)
    model = root.find("model")
    links = {link.get("name"): link for link in model.findall("link")}
    joints = {joint.get("name"): joint for joint in model.findall("joint")}
    length = units_of(params.slip).length
    for name, mass in (("body", params.slip.mass), ("leg", params.leg_mass), ("foot", params.foot_mass)):
        scale_link(links[name], mass, length)
    set_sdf_value(links["body"], "inertial/inertia/iyy", params.body_pitch_inertia)
    set_sdf_value(links["foot"], "visual[@name='foot_visual']/geometry/sphere/radius", params.foot_radius)
    set_sdf_value(links["foot"], "collision/geometry/sphere/radius", params.foot_radius)
    props = links["foot"].find("collision/drake__proximity_properties")
    set_sdf_value(props, "drake__point_contact_stiffness", params.contact_stiffness)
    set_sdf_value(props, "drake__hunt_crossley_dissipation", params.contact_dissipation)
    for tag in ("drake__mu_dynamic", "drake__mu_static"):
        set_sdf_value(props, tag, params.slip.friction)
    set_sdf_value(joints["hip"], "axis/limit/effort", params.hip_torque_limit)
    set_sdf_value(joints["hip"], "axis/limit/velocity", params.hip_speed_limit)
    leg = joints["leg_spring"]
    set_sdf_value(leg, "axis/limit/lower", params.bottom_extension)
    set_sdf_value(leg, "axis/limit/upper", params.rest_extension)
    set_sdf_value(leg, "axis/limit/effort", params.leg_force_limit)
    set_sdf_value(leg, "axis/dynamics/damping", params.leg_damping)
    return root, links


def hopper_sdf(params: RobotParams) -> str:
    """The packaged SDF with ``params`` written into it."""
    root, _ = _model_links(params)
    return sdf_text(root)


@dataclass(frozen=True)
class ModelGeometry:
    """What the controller and the failure monitor know of the robot beyond ``RobotParams``, read from its model
    file (``hopper_sdf``): ``leg_com`` [m], the upper leg's centre of mass below the hip; ``leg_inertia``
    [kg m^2], the upper leg's pitch inertia about it; ``body_half`` [m], the half length and half height of the
    body box."""

    leg_com: float
    leg_inertia: float
    body_half: tuple


@functools.lru_cache(maxsize=16)
def model_geometry(params: RobotParams) -> ModelGeometry:
    """The ``ModelGeometry`` of the robot ``params`` builds."""
    _, links = _model_links(params)
    leg = links["leg"].find("inertial")
    size = [float(v) for v in links["body"].find("visual[@name='body_visual']/geometry/box/size").text.split()]
    return ModelGeometry(leg_com=-float(leg.find("pose").text.split()[2]),
                         leg_inertia=float(leg.find("inertia/iyy").text),
                         body_half=(size[0] / 2, size[2] / 2))   # x is the body's length, z its height


@dataclass(frozen=True)
class HopperParts:
    """The hopper's elements in its plant. After the plant is finalized, ``layout`` gives the indices of
    (x, z, pitch, hip, leg) in the plant's positions and velocities and the actuation order."""

    model: object
    body: object
    foot: object
    base: object
    hip: object
    leg: object

    def layout(self, plant) -> "StateLayout":
        q = (self.base.position_start(), self.base.position_start() + 1, self.base.position_start() + 2,
             self.hip.position_start(), self.leg.position_start())
        v = (self.base.velocity_start(), self.base.velocity_start() + 1, self.base.velocity_start() + 2,
             self.hip.velocity_start(), self.leg.velocity_start())
        hip_actuator = plant.GetJointActuatorByName("hip", self.model)
        leg_actuator = plant.GetJointActuatorByName("leg_spring", self.model)
        order = (int(hip_actuator.input_start()), int(leg_actuator.input_start()))
        return StateLayout(q, tuple(plant.num_positions() + i for i in v), order, plant.num_actuators())


@dataclass(frozen=True)
class StateLayout:
    """Indices of (x, z, pitch, hip, leg) in the plant state's positions ``q`` and velocities ``v`` (both
    into the full state vector) and of (hip, leg) in the actuation vector of ``n_actuators``."""

    q: tuple
    v: tuple
    actuation: tuple
    n_actuators: int

    def split(self, state) -> tuple:
        """(q, v): each (x, z, pitch, hip, leg) and its rates, from a plant state vector."""
        state = np.asarray(state)
        return state[list(self.q)], state[list(self.v)]


def add_hopper(plant, params: RobotParams) -> HopperParts:
    """Parse the hopper into ``plant`` (not yet finalized) and add its planar base and leg spring."""
    from pydrake.math import RigidTransform, RotationMatrix
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.tree import FixedOffsetFrame, PlanarJoint, PrismaticSpring

    (model,) = Parser(plant, "hopper").AddModelsFromString(hopper_sdf(params), "sdf")
    body = plant.GetBodyByName("body", model)
    # the joint's frame F has x along world x and y along world z, so it turns about -y (see the module doc)
    to_plane = RigidTransform(RotationMatrix.MakeXRotation(math.pi / 2))
    frame_w = plant.AddFrame(FixedOffsetFrame("plane_world", plant.world_frame(), to_plane))
    frame_b = plant.AddFrame(FixedOffsetFrame("plane_body", body.body_frame(), to_plane))
    base = plant.AddJoint(PlanarJoint("base", frame_w, frame_b, np.zeros(3)))
    leg = plant.GetJointByName("leg_spring", model)
    plant.AddForceElement(PrismaticSpring(leg, params.rest_extension, params.slip.stiffness))
    return HopperParts(model, body, plant.GetBodyByName("foot", model), base, plant.GetJointByName("hip", model),
                       leg)
