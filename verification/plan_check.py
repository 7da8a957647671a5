"""Check a plan on the Drake hybrid simulator: certify the plan as written, or give a counterexample.

``check_plan(record, mode, tolerance)`` executes a stored plan (``planners.formats.plan.PlanRecord``) from its
start apex on the whole terrain, on Drake:

* ``"angles"`` commands the plan's leg angles open loop (what the planner predicted on the fast backend);
* ``"footholds"`` aims at the plan's footholds through the step-length controller from the apex actually
  reached at each flight (how the receding-horizon evaluation executes plans);
* ``"auto"`` uses the angles when the plan has all of them, else the footholds (a one-step ``lstm`` plan has
  only the first angle).

A ``Certificate`` means the run did what the plan says: every hop of the plan completed with no failure, every
touchdown within ``tolerance`` of its planned foothold, every apex the plan predicts reached within ``tolerance``
(in x and z [m] and xdot [m/s]), and the plan's target reached (the last touchdown at or past ``target_x`` less
the tolerance). Its margins (``verification.margins``) say how far the run stayed from each failure.

Otherwise a ``Counterexample`` names the first place, in hop order, where the run left the plan: a failure (a
``FailureMode``), a missed foothold, a missed apex, or a target not reached, with the hop, planned against actual,
the time, the state and full hybrid state there, and the trace of hops up to it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from drakeslip import FailureMode, StepLengthController
from drakeslip import dynamics as dyn
from drakeslip.slip_hopper import HybridState, Mode
from drakeslip.hopper_file import NamedHopper, check_same_hopper
from drakeslip.jobs.runner import finite
from drakeslip.rollout import rollout
from drakeslip.simulation import IntegratorConfig, SimulationResult
from drakeslip.state import SimulationCrash
from drakeslip.units import HOP_SECONDS, units_of

from planners.formats.plan import PlanRecord
from verification.margins import Margin, margins
from verification.plan_check_options import MODES, TOLERANCE
_MODE_WORDS = {"angles": "leg angles open loop", "footholds": "footholds through the controller"}


@dataclass
class Certificate:
    """The plan ran as written on Drake (see the module doc). Margins (each positive, else the run would have
    failed):

    * ``friction``: min over stance of mu - |F_t| / F_n = mu - |x - x_f| / (z - z_f) (the leg force is axial):
      the plan survives any friction coefficient above mu - friction;
    * ``body_clearance``: min distance [m] from the body to the terrain profile (tops and vertical faces),
      over the whole run; a distance, not a height, so a near miss of a wall counts;
    * ``foot_clearance``: min distance [m] from the extended foot to a vertical face of the terrain while it
      falls to touchdown (inf if the terrain has none): how near the foot came to striking a wall or a corner;
    * ``stroke``: min over stance of l - min_leg_length [m], the spring travel left before bottoming out
      (``max_compression`` = L0 - min l, out of the stroke L0 - min_leg_length);
    * ``edge_distance``: min distance [m] of an actual foothold to the nearest terrain edge (a height change,
      ditch edges included; inf on terrain without edges), and ``edge_distances`` per foothold.

    ``deviation`` and ``apex_deviation``: the largest |actual - planned| foothold [m] and predicted apex component.
    """

    mode: str
    tolerance: float
    planned_footholds: list
    footholds: list
    leg_angles: list
    apexes: list            # the start apex, then the apex after each hop
    deviation: float
    apex_deviation: float
    safety: object          # verification.margins.Margins of the run
    goal_x: float
    target_x: float
    simulation: SimulationResult | None = field(default=None, repr=False, compare=False)  # the logged Drake run

    ok = True

    @property
    def max_compression(self) -> float:
        return self.safety.max_compression

    @property
    def stroke_length(self) -> float:
        return self.safety.stroke_length

    @property
    def edge_distances(self) -> list:
        return self.safety.edge_distances

    def margins(self) -> dict:
        m = self.safety
        return {"friction": m.friction, "body_clearance": m.body_clearance, "foot_clearance": m.foot_clearance,
                "stroke": m.stroke, "edge_distance": m.edge_distance}

    def to_dict(self) -> dict:
        return finite({"verdict": "certified", "mode": self.mode, "tolerance": self.tolerance,
                       "hops": len(self.footholds),
                       "margins": {k: m._asdict() for k, m in self.margins().items()},
                       "max_compression": self.safety.max_compression, "stroke_length": self.safety.stroke_length,
                       "deviation": self.deviation, "apex_deviation": self.apex_deviation,
                       "planned_footholds": self.planned_footholds, "footholds": self.footholds,
                       "edge_distances": self.safety.edge_distances, "leg_angles": self.leg_angles,
                       "apexes": self.apexes, "goal_x": self.goal_x, "target_x": self.target_x})

    def format(self) -> str:
        final, m = self.apexes[-1], self.safety
        lines = [f"CERTIFIED: all {len(self.footholds)} hops of the plan on Drake ({_MODE_WORDS[self.mode]}), every "
                 f"foothold and predicted apex within {self.tolerance:g}, target x={self.target_x:g} reached; final "
                 f"apex x={final[0]:.3f} z={final[1]:.3f} xdot={final[2]:.3f} (goal x={self.goal_x:g})"]
        notes = {"friction": "mu - |F_t|/F_n, min over stance",
                 "body_clearance": "m, body to terrain",
                 "foot_clearance": "m, falling foot to a terrain face",
                 "stroke": f"m of spring travel left; max compression {m.max_compression:.4f} of "
                           f"{m.stroke_length:.4f} m",
                 "edge_distance": "m, foothold to the nearest terrain edge"}
        for name, margin in self.margins().items():
            where = f"hop {margin.hop}, x={margin.x:.3f}" if math.isfinite(margin.value) else "no terrain edge"
            lines.append(f"  {name:<15} {margin.value:9.4f}  ({notes[name]}; {where})")
        lines.append(f"  {'deviation':<15} {self.deviation:9.2e}  (m, max |actual - planned| foothold)")
        if math.isfinite(self.apex_deviation):
            lines.append(f"  {'apex deviation':<15} {self.apex_deviation:9.2e}  (max |actual - predicted| apex "
                         "x, z [m], xdot [m/s])")
        lines.append("  hop  planned x  actual x   edge dist  leg angle")
        for k, (p, a, e, th) in enumerate(zip(self.planned_footholds, self.footholds, m.edge_distances,
                                              self.leg_angles)):
            lines.append(f"  {k:3d}  {p:9.4f}  {a:9.4f}  {e:9.4f}  {th:+9.4f}")
        return "\n".join(lines)


@dataclass
class Counterexample:
    """The first place the run left the plan. ``kind``: ``"failure"`` (``failure`` says which), ``"foothold"``
    (a touchdown off its planned foothold), ``"apex"`` (an apex off the predicted one) or ``"target"`` (the
    run ended short of the plan's target). ``hop`` (0 = the hop from the start apex), ``planned`` and ``actual``
    (the foothold x, the apex (x, z, xdot), or the target x and the last touchdown), ``time`` [s], ``state``
    (x, z, xdot, zdot) there, ``foot`` (pinned in stance, extended in flight; None when retracted), ``hybrid``
    (the HybridState there), and ``trace``: one entry per hop up to it with its start apex, commanded leg angle,
    planned and actual foothold."""

    mode: str
    kind: str
    hop: int
    failure: FailureMode | None
    planned: object
    actual: object
    tolerance: float
    time: float
    state: tuple
    foot: tuple | None
    hybrid: dict
    trace: list
    simulation: SimulationResult | None = field(default=None, repr=False, compare=False)  # the logged Drake run

    ok = False

    @property
    def x(self) -> float:
        return self.state[0]

    def reason(self) -> str:
        """One line: what went differently from the plan."""
        if self.kind == "failure":
            return f"{self.failure.name} at hop {self.hop}"
        if self.kind == "foothold":
            return (f"FOOTHOLD MISSED at hop {self.hop}: planned x={self.planned:.4f}, touched down at "
                    f"x={self.actual:.4f} ({abs(self.actual - self.planned):.4f} m off, tolerance {self.tolerance:g})")
        if self.kind == "apex":
            off = max(abs(a - p) for a, p in zip(self.actual, self.planned))
            return (f"APEX MISSED after hop {self.hop}: predicted ({', '.join(f'{v:.4f}' for v in self.planned)}), "
                    f"reached ({', '.join(f'{v:.4f}' for v in self.actual)}) ({off:.4f} off, tolerance "
                    f"{self.tolerance:g})")
        return (f"SHORT OF TARGET after its {self.hop + 1} hops: the plan claims target x={self.planned:g}, "
                f"its last touchdown is at x={self.actual:.4f}")

    def to_dict(self) -> dict:
        return finite({"verdict": "counterexample", "mode": self.mode, "kind": self.kind, "hop": self.hop,
                       "failure": self.failure.name if self.failure is not None else None,
                       "planned": _plain(self.planned), "actual": _plain(self.actual), "tolerance": self.tolerance,
                       "reason": self.reason(), "time": self.time, "x": self.x, "state": list(self.state),
                       "foot": None if self.foot is None else list(self.foot), "hybrid": self.hybrid,
                       "trace": self.trace})

    def format(self) -> str:
        s = self.state
        foot = "retracted" if self.foot is None else f"({self.foot[0]:.4f}, {self.foot[1]:.4f})"
        lines = [f"COUNTEREXAMPLE: {self.reason()}; t={self.time:.4f} s, x={self.x:.4f} "
                 f"({_MODE_WORDS[self.mode]} on Drake)",
                 f"  state x={s[0]:.4f} z={s[1]:.4f} xdot={s[2]:.4f} zdot={s[3]:.4f}, foot {foot}",
                 "  hybrid " + ", ".join(f"{k}={v}" for k, v in self.hybrid.items()),
                 "  hop  apex x    apex z   apex xdot  leg angle  planned x  actual x"]
        for t in self.trace:
            cells = [t["apex"][0], t["apex"][1], t["apex"][2], t["leg_angle"], t["planned_foothold"], t["foothold"]]
            lines.append(f"  {t['hop']:3d}" + "".join("  " + ("        -" if v is None else f"{v:9.4f}")
                                                      for v in cells))
        return "\n".join(lines)


def check_plan(record: PlanRecord, mode: str = "auto", tolerance: float = TOLERANCE,
               controller: StepLengthController | None = None,
               integrator: IntegratorConfig | None = None,
               hopper: NamedHopper | None = None) -> Certificate | Counterexample:
    """Simulate ``record`` on Drake (see the module doc for the modes and what a certificate means) and certify it,
    or return the first place the run left it. With ``hopper``, a plan made for another hopper (its params' body
    differs) is refused: ValueError in one line, before any simulation. A run that stops before it says what the
    plan does (the integrator raised, NaN derivatives, a hop that timed out before the plan was left) raises
    ``SimulationCrash``."""
    if hopper is not None:
        check_same_hopper(hopper, record.params, "the plan")
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be a positive number of metres, got {tolerance!r}")
    if mode == "auto":
        mode = "angles" if np.all(np.isfinite(record.leg_angles)) else "footholds"
    n = len(record.footholds)
    if mode == "angles":
        bad = np.flatnonzero(~(np.abs(record.leg_angles) < math.pi / 2))
        if bad.size:
            raise ValueError(f"mode 'angles' needs every leg angle finite and within (-pi/2, pi/2): "
                             f"leg_angles[{bad[0]}] = {record.leg_angles[bad[0]]}; use mode 'footholds'")
        commands = {"leg_angles": [float(a) for a in record.leg_angles]}
    else:
        commands = {"footholds": [float(x) for x in record.footholds],
                    "controller": controller or StepLengthController.load_default()}
    sim = rollout(record.apex, record.terrain, record.params, **commands, backend="drake", log=True,
                  integrator=integrator).simulation
    touchdowns = [e for e in sim.events if e.kind == "touchdown"]
    apex_events = [e for e in sim.events if e.kind == "apex"]
    for k in range(n):  # in the order things happened: hop k's touchdown, then its failure or its apex
        if k < len(sim.footholds):
            planned, actual = float(record.footholds[k]), float(sim.footholds[k])
            if abs(actual - planned) > tolerance:
                return _counterexample(sim, record, mode, tolerance,
                                       _Departure("foothold", k, planned, actual, touchdowns[k]))
        if sim.failure is FailureMode.TIMEOUT and k == sim.failed_hop:
            raise SimulationCrash(timed_out(sim, k))
        if sim.failure is not None and k == sim.failed_hop:
            return _counterexample(sim, record, mode, tolerance,
                                   _Departure("failure", k, None, None, sim.failure_event))
        predicted = record.apexes[k]
        if np.all(np.isfinite(predicted)) and np.max(np.abs(np.subtract(sim.apexes[k], predicted))) > tolerance:
            return _counterexample(sim, record, mode, tolerance, _Departure(
                "apex", k, tuple(map(float, predicted)), tuple(map(float, sim.apexes[k])), apex_events[k]))
    if len(sim.apexes) != n:
        raise SimulationCrash(f"the Drake run stopped after {len(sim.apexes)} of {n} hops with no failure")
    if sim.footholds[-1] < record.target_x - tolerance:
        return _counterexample(sim, record, mode, tolerance,
                               _Departure("target", n - 1, record.target_x, float(sim.footholds[-1]), apex_events[-1]))
    predicted = np.isfinite(record.apexes).all(axis=1)
    apex_deviation = (float(np.max(np.abs(np.array(sim.apexes)[predicted] - record.apexes[predicted])))
                      if predicted.any() else math.nan)
    return Certificate(mode, tolerance, [float(f) for f in record.footholds], [float(f) for f in sim.footholds],
                       list(sim.leg_angles), [list(record.apex)] + [list(a) for a in sim.apexes],
                       deviation=float(np.max(np.abs(np.subtract(sim.footholds, record.footholds)))),
                       apex_deviation=apex_deviation, safety=margins(sim), goal_x=record.goal_x,
                       target_x=record.target_x, simulation=sim)


def timed_out(sim: SimulationResult, hop: int) -> str:
    """One line: the TIMEOUT of ``sim`` in ``hop``, where the hopper was when the simulator's limit cut the run."""
    e, mode = sim.failure_event, Mode(int(sim.hybrid[-1][0])).name if len(sim.hybrid) else "its hop"
    limit = units_of(sim.params).hop_seconds
    return (f"TIMEOUT at hop {hop}: the hop outlasted the simulator's {limit:.4g} s limit (HOP_SECONDS, "
            f"{HOP_SECONDS:g} s in this hopper's time units) before any guard fired, the hopper still in {mode} at "
            f"t={e.time:.4g} s, x={e.state[0]:.4g} z={e.state[1]:.4g} zdot={e.state[3]:.4g}: no verdict on the plan")


class _Departure(NamedTuple):
    """Where a run left its plan: the ``kind`` ("failure", "foothold", "apex" or "target"), the ``hop``, the
    ``planned`` value against the ``actual`` one (None for a failure), and the simulator's ``event`` there (the
    failure, or the touchdown or apex)."""

    kind: str
    hop: int
    planned: object
    actual: object
    event: object


def _counterexample(sim: SimulationResult, record: PlanRecord, mode: str, tolerance: float,
                    departure: _Departure) -> Counterexample:
    """The counterexample at ``departure``, of a check in ``mode`` with ``tolerance``."""
    kind, hop, planned, actual, event = departure
    row = _hybrid_at(sim, event.time, after=kind != "failure")
    h = HybridState(row)
    hybrid = {k: float(v) for k, v in zip(HybridState._fields, h[:])}
    hybrid.update(mode=Mode(int(h.mode)).name, leg_deployed=int(h.leg_deployed), hops=int(h.hops),
                  failure=FailureMode(int(h.failure)).name if h.failure else None)
    foot = event.foot
    if foot is None and h.leg_deployed and kind == "failure":
        foot = dyn.foot_position(event.state[0], event.state[1], event.leg_angle, sim.params.as_array())
    apexes = [tuple(record.apex)] + [tuple(a) for a in sim.apexes]
    trace = [{"hop": k, "apex": list(apexes[k]),
              "leg_angle": sim.leg_angles[k] if k < len(sim.leg_angles) else None,
              "planned_foothold": float(record.footholds[k]) if k < len(record.footholds) else None,
              "foothold": sim.footholds[k] if k < len(sim.footholds) else None} for k in range(hop + 1)]
    return Counterexample(mode, kind, hop, sim.failure if kind == "failure" else None, planned, actual, tolerance,
                          event.time, tuple(event.state), None if foot is None else tuple(map(float, foot)), hybrid,
                          trace, simulation=sim)


def _hybrid_at(sim: SimulationResult, time: float, after: bool) -> np.ndarray:
    """The logged hybrid state at ``time``: the last row of the run for a failure (logged after its reset: mode
    FAILED and the failure code), else the first row logged at or after the event (its reset applied)."""
    if not after:
        return sim.hybrid[-1]
    i = min(int(np.searchsorted(sim.times, time, side="left")), len(sim.times) - 1)
    return sim.hybrid[i]


def _plain(value):
    return list(value) if isinstance(value, tuple) else value


__all__ = ["MODES", "TOLERANCE", "Certificate", "Counterexample", "Margin", "check_plan"]
