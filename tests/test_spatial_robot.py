"""The spatial multibody hopper: its model for any hopper, a height map as boxes, the controller's geometry (hip
angles, aiming, attitude, angular momentum against Drake's), and its gait on flat ground: in place, at speed in
any heading, a foothold reached, a turn and a push (the full acceptance runs: examples/multibody_gait.py --robot
spatial, in the slow tests)."""
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.multibody.aiming import aim_direction, cross, hip_angles, roll_pitch_yaw, rotation
from drakeslip.spatial.multibody.robot import SpatialRobotParams, leg_direction, spatial_hopper_sdf
from drakeslip.spatial.multibody.terrain import height_map_boxes

ROOT = Path(__file__).resolve().parents[1]


def test_the_robot_of_any_hopper_is_the_papers_robot_in_its_units():
    assert SpatialRobotParams.for_hopper(ds.SlipParams()) == SpatialRobotParams()
    big = ds.SlipParams(mass=28.0, leg_length=1.0, stiffness=3200 * 4 * 2 / 2)   # the paper's dimensionless spring
    robot = SpatialRobotParams.for_hopper(big)
    assert robot.leg_mass == pytest.approx(0.35 * 4) and robot.foot_radius == pytest.approx(0.06)
    assert robot.body_pitch_inertia == pytest.approx(0.25 * 4 * 4)
    assert robot.time_step == pytest.approx(1e-3 * math.sqrt(2))
    text = spatial_hopper_sdf(robot)
    assert "<mass>28.0</mass>" in text and "<lower>0.54</lower>" in text   # bottom-out: 0.6 m less the ball
    assert SpatialRobotParams.from_dict(robot.to_dict()) == robot
    with pytest.raises(ValueError, match="leg_mass"):
        SpatialRobotParams(leg_mass=-1.0)
    with pytest.raises(ValueError, match="unknown SpatialRobotParams fields: wings"):
        SpatialRobotParams.from_dict({**robot.to_dict(), "wings": 2})


def test_the_plant_has_the_parameters_masses_and_a_floating_base():
    from drakeslip.spatial.multibody.diagram import build_spatial_diagram
    from drakeslip.spatial.multibody.robot import spatial_geometry

    params = SpatialRobotParams.for_hopper(ds.SlipParams(mass=10.0, stiffness=3200 * 10 / 7))
    sd = build_spatial_diagram(HeightMap.flat(), params)
    plant = sd.plant
    assert plant.num_positions() == 10 and plant.num_velocities() == 9 and plant.num_actuators() == 3
    total = sum(plant.get_body(i).default_mass() for i in plant.GetBodyIndices(sd.parts.model))
    assert total == pytest.approx(params.total_mass, rel=1e-12)
    leg = plant.GetBodyByName("leg", sd.parts.model)
    com = leg.default_com()
    inertia = leg.default_spatial_inertia().Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
    geometry = spatial_geometry(params)
    foot = plant.GetBodyByName("foot", sd.parts.model).default_rotational_inertia().CopyToFullMatrix3()
    assert geometry.leg_com == pytest.approx(-com[2], rel=1e-12)
    assert geometry.leg_inertia == pytest.approx((inertia[0, 0] + foot[0, 0], inertia[2, 2] + foot[2, 2]), rel=1e-12)


def test_a_height_map_becomes_boxes_with_its_heights_and_its_holes():
    heights = np.array([[0.0, 0.0, 0.2, 0.2],
                        [0.0, np.nan, 0.2, 0.2],
                        [0.0, 0.0, 0.2, 0.3]])
    hm = HeightMap(heights, 0.5, (1.0, -1.0))
    boxes = height_map_boxes(hm)
    # every cell centre lies in exactly one box of its height, a hole in none
    for j in range(3):
        for i in range(4):
            x, y = 1.0 + 0.5 * i + 0.25, -1.0 + 0.5 * j + 0.25
            inside = [b for b in boxes if b[0] <= x < b[1] and b[2] <= y < b[3]]
            assert [b[4] for b in inside] == ([] if np.isnan(heights[j, i]) else [heights[j, i]])
    # rows with the same runs merge: the 0.2 tread of two rows is one box
    assert sum(1 for b in boxes if b[4] == 0.2) == 2 and len(boxes) == 6
    # the map extends flat past its edges, a window does not
    assert min(b[0] for b in boxes) < -10 and max(b[3] for b in boxes) > 10
    window = HeightMap(heights, 0.5, (1.0, -1.0), extends_flat=False)
    assert min(b[0] for b in height_map_boxes(window)) == 1.0
    assert len(height_map_boxes(HeightMap.flat())) == 1


def test_hip_angles_point_the_leg_and_attitude_reads_drakes_conventions():
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RollPitchYaw, RotationMatrix

    rng = np.random.default_rng(0)
    for _ in range(20):
        pitch, roll = rng.uniform(-1.0, 1.0, 2)
        assert hip_angles(leg_direction(pitch, roll)) == pytest.approx((pitch, roll), abs=1e-12)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        drake = RotationMatrix(Quaternion(q)).matrix()
        assert rotation(*q) == pytest.approx(drake, abs=1e-12)
        angles = rng.uniform(-1.0, 1.0, 3)
        assert roll_pitch_yaw(RollPitchYaw(angles).ToRotationMatrix().matrix()) == pytest.approx(angles, abs=1e-12)
        a, b = rng.normal(size=3), rng.normal(size=3)
        assert cross(a, b) == pytest.approx(np.cross(a, b), abs=1e-12)


def test_the_aimed_leg_lands_the_foot_on_the_target():
    """A leg held along a direction within reach lands the foot, falling with the body, on a point; aimed at that
    point, the leg takes that direction and the fall that time."""
    from drakeslip.spatial.multibody.aiming import fall_time

    g, reach = 9.81, 0.47
    rng = np.random.default_rng(1)
    for _ in range(20):
        position = np.array([0.0, 0.0, rng.uniform(0.55, 0.8)])
        velocity = np.array([*rng.uniform(-2.0, 2.0, 2), rng.uniform(-1.0, 0.5)])
        offset = rng.uniform(-0.25, 0.25, 2)
        held = np.array([*offset, -math.sqrt(reach ** 2 - offset @ offset)]) / reach
        ground = rng.uniform(-0.05, 0.05)
        t = fall_time(position[2], velocity[2], position[2] + reach * held[2] - ground, g)
        target = position + velocity * t + (0.0, 0.0, -0.5 * g * t * t) + reach * held
        assert target[2] == pytest.approx(ground, abs=1e-12)
        d, fall = aim_direction(position, velocity, target, reach, g)
        assert d == pytest.approx(held, abs=1e-9) and fall == pytest.approx(t, abs=1e-9)


def test_the_controllers_angular_momentum_is_drakes():
    """About the robot's centre of mass, at a random state: the controller's sum over its parts against
    ``MultibodyPlant.CalcSpatialMomentumInWorldAboutPoint``."""
    from drakeslip.spatial.multibody.controller import Sensed
    from drakeslip.spatial.multibody.diagram import build_spatial_diagram

    sd = build_spatial_diagram(HeightMap.flat())
    plant, lay = sd.plant, sd.layout
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(2)
    for _ in range(5):
        x = np.zeros(lay.size)
        q = rng.normal(size=4)
        x[list(lay.quaternion)] = q / np.linalg.norm(q)
        x[list(lay.position)] = (0.3, -0.2, 0.7)
        x[list(lay.hip)] = rng.uniform(-0.6, 0.6, 2)
        x[lay.leg] = rng.uniform(0.3, 0.45)
        for index in (*lay.angular, *lay.linear, *lay.hip_rates, lay.leg_rate):
            x[index] = rng.uniform(-2.0, 2.0)
        plant.SetPositionsAndVelocities(context, x)
        com = plant.CalcCenterOfMassPositionInWorld(context)
        drake = plant.CalcSpatialMomentumInWorldAboutPoint(context, com).rotational()
        m = Sensed(x[list(lay.position)], x[list(lay.linear)], x[list(lay.angular)], rotation(*x[list(lay.quaternion)]),
                   x[list(lay.hip)], x[list(lay.hip_rates)], x[lay.leg], x[lay.leg_rate])
        ours = sd.controller.angular_momentum(m.velocity, m.omega, m.rotation, m.hip, m.hip_rates, m.leg, m.leg_rate)
        # the gimbal's own inertia (2e-5 kg m^2) is the only part the controller leaves out
        assert ours == pytest.approx(drake, abs=1e-4)


def test_the_robot_hops_in_place_and_at_speed_in_any_heading():
    from drakeslip.spatial.multibody.gait import hop_flat

    still = hop_flat(lambda k: (0.0, 0.0), 8)
    assert still.failure is None and len(still.apexes) == 8
    assert [a[3] for a in still.apexes[2:]] == pytest.approx([0.62] * 6, abs=0.01)
    assert max(math.hypot(a[1], a[2]) for a in still.apexes) < 0.01
    for heading in (0.0, 45.0, 90.0):
        wanted = 2.0 * math.cos(math.radians(heading)), 2.0 * math.sin(math.radians(heading))
        log = hop_flat(lambda k: wanted, 14)
        assert log.failure is None and len(log.apexes) == 14
        assert log.apexes[-1][4:6] == pytest.approx(wanted, abs=0.05)
        assert max(log.max_attitude(5)) < 0.15


def test_the_foot_lands_on_commanded_footholds_in_both_directions():
    """The next two footholds of the robot's own diagonal gait, commanded from one of its apexes: each touchdown within
    5 mm (a longer sequence, unplanned again, drifts off the robot's dynamics: the closed loop replans at each apex)."""
    from drakeslip.spatial.multibody.gait import execute, hop_flat

    gait = hop_flat(lambda k: (1.2, 0.9), 9)
    start = gait.apexes[6]
    footholds = [t[1:] for t in gait.touchdowns if t[0] > start[0]][:2]
    log = execute(start[1:6], HeightMap(np.zeros((40, 40)), 0.25, (-5.0, -5.0)), footholds)
    assert log.failure is None and len(log.touchdowns) >= 2   # the last by Raibert's placement, to the apex after
    errors = [math.hypot(f[0] - t[1], f[1] - t[2]) for f, t in zip(footholds, log.touchdowns)]
    assert max(errors) < 0.005


def test_a_turn_and_a_push_are_undone_in_a_few_hops():
    from drakeslip.spatial.multibody.gait import push, turn

    log, hops = turn(2.0, hops_before=4, hops_after=8)
    assert log.failure is None and hops is not None and hops < 10
    log, hops = push(1.0, math.radians(45), 20.0, hops_before=4, hops_after=7)
    assert log.failure is None and hops is not None and hops <= 5
    assert log.apexes[5][4:6] != pytest.approx(log.apexes[3][4:6], abs=0.5)   # the push did move it


def test_the_gait_script_refuses_bad_input_before_any_work():
    for bad in (["--headings", "north"], ["--push", "-3"], ["--robot", "hexapod"]):
        run = subprocess.run([sys.executable, str(ROOT / "examples" / "multibody_gait.py"), *bad],
                             capture_output=True, text=True, timeout=60)
        assert run.returncode == 2 and run.stderr.count("\n") <= 2, run.stderr


@pytest.mark.slow
def test_the_spatial_gait_script_passes_its_checks():
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "multibody_gait.py"), "--robot", "spatial",
                          "--speeds", "0,3", "--headings", "45", "--hops", "30"],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "turn of 90 deg at 3.0 m/s: ok; done in" in run.stdout
    assert "push of 20 N s to the left at 0.0 m/s: ok; undone in" in run.stdout


def test_every_hop_keeps_room_to_swing_the_leg():
    """Asked for apexes lower than a standing leg plus APEX_CLEARANCE, the robot hops to that floor instead."""
    from drakeslip.spatial.multibody.controller import APEX_CLEARANCE
    from drakeslip.spatial.multibody.gait import hop_flat

    log = hop_flat(lambda k: (1.0, 0.0), 10, apex_height=0.53)
    assert log.failure is None and len(log.apexes) == 10
    floor = ds.SlipParams().leg_length + APEX_CLEARANCE
    assert [a[3] for a in log.apexes[4:]] == pytest.approx([floor] * 6, abs=0.015)
