"""The planar robot's controller's gains and thresholds (``drakeslip.multibody.controller``), tuned for the paper's
hopper, and the same in another hopper's units (``control_constants``), which both robots' controllers take: for the
paper's hopper each factor is exactly 1."""
from __future__ import annotations

from typing import NamedTuple

from drakeslip.params import SlipParams
from drakeslip.units import units_of

CLEARANCE = 0.03          # [m] the foot's height above the ground before the leg swings forward after liftoff
RETRACT = 0.04            # [m] leg retraction in ascent: clears the ground the foot just left
TOUCHDOWN_COMPRESSION = 0.003   # [m] compression (leg moving in) that says the foot touched down
TOUCHDOWN_RATE = -0.2     # [m/s] ... and the leg's rate at that moment (extension in flight is positive)
LIFTOFF_MARGIN = 0.002    # [m] the leg within this of its stop after MIN_STANCE says the foot left the ground
MIN_STANCE = 0.03         # [s]
BIAS_GAIN = 0.5           # share of an apex's energy error learned into the bias
FLIGHT_GAINS = (150.0, 6.0)    # hip PD on the absolute leg angle in flight [N m/rad, N m s/rad]
STANCE_GAINS = (100.0, 60.0)   # hip PD in stance on the body pitch and on the angular momentum (as a rate)
LEG_GAINS = (3000.0, 40.0)     # leg PD on extension in flight [N/m, N s/m] (the spring is cancelled)
FRICTION_SHARE = 0.4      # in stance the hip torque asks for at most this share of the friction cone
# [s] the paper's hopper's stance, about half its body-on-spring period pi sqrt(m / k); a hopper's own is this in
# its time units (``stance_time``)
STANCE_TIME = 0.15
# Landing on a foothold: the leg swings back at this share of the body's forward speed (as the rate of its angle),
# the hip leading it by the swing still to come, at most LANDING_SWING_TIME's; the foot lands at 0.8 of the body's
# speed (tests/test_multibody.py). A foot landing at the body's speed slides before the leg's force holds it; the
# faster the leg swings back as it lands, the less a hop that lands far ahead brakes than the template's, and the
# robot reaches its next apex faster and farther than planned, where the planner may have no plan (docs/multibody.md)
LANDING_SWING_SHARE = 0.25
LANDING_SWING_TIME = 0.06   # [s]
LIFT_DAMPING = 6.0        # [N m s/rad] the hip's gain on the leg's rate while the foot rises where it stood
SPEED_GAIN = 0.08         # [m per m/s] Raibert's foot-placement gain on the speed error


def stance_time(params: SlipParams) -> float:
    """The stance of the hopper ``params`` [s]: STANCE_TIME in its time units (``drakeslip.units``)."""
    return STANCE_TIME * units_of(params).time


class ControlConstants(NamedTuple):
    """The constants above in a hopper's units: the PD gains (a torque M L^2 / T^2 per radian, a force M / T^2 per
    metre, their rates' gains times T), the lengths, rates and times, ``least_stroke`` (a centimetre: the leg's
    push divides by no less a stroke; the leg extends this past its stop in descent) and the stance."""

    flight_gains: tuple
    stance_gains: tuple
    leg_gains: tuple
    lift_damping: float
    retract: float
    clearance: float
    least_stroke: float
    touchdown_compression: float
    touchdown_rate: float
    liftoff_margin: float
    min_stance: float
    landing_swing_time: float
    speed_gain: float
    stance_time: float


def control_constants(slip: SlipParams) -> ControlConstants:
    """The controller's constants for the hopper ``slip`` (``ControlConstants``)."""
    u = units_of(slip)
    torque, force = u.mass * u.length ** 2 / u.time ** 2, u.mass / u.time ** 2
    return ControlConstants((FLIGHT_GAINS[0] * torque, FLIGHT_GAINS[1] * torque * u.time),
                            (STANCE_GAINS[0] * torque, STANCE_GAINS[1] * torque * u.time),
                            (LEG_GAINS[0] * force, LEG_GAINS[1] * force * u.time), LIFT_DAMPING * torque * u.time,
                            RETRACT * u.length, CLEARANCE * u.length, 0.01 * u.length,
                            TOUCHDOWN_COMPRESSION * u.length, TOUCHDOWN_RATE * u.speed, LIFTOFF_MARGIN * u.length,
                            MIN_STANCE * u.time, LANDING_SWING_TIME * u.time, SPEED_GAIN * u.time, stance_time(slip))
