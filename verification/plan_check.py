"""Check a plan on the Drake hybrid simulator: a certificate with the run's safety margins, or a counterexample.

``check_plan(record, mode)`` executes a stored plan (``planners.formats.plan.PlanRecord``) from its initial apex on
the whole terrain with ``drakeslip.simulation``:

* ``"angles"`` commands the plan's leg angles open-loop (what the planner predicted on the fast backend);
* ``"footholds"`` aims at the plan's footholds through the step-length controller from the apex actually
  reached at each flight (how the receding-horizon evaluation executes plans);
* ``"auto"`` uses the angles when the plan has all of them, else the footholds (``lstm`` plans have only the
  first angle).

A run that reaches the apex after the last foothold with no failure gives a ``Certificate``; its margins are
taken from the simulator's log: the body state at every integrator step (at most ``max_step`` = 2 ms apart)
plus the exact states of the localized touchdown, liftoff and apex events. Between samples an extreme can be
slightly tighter than reported, by at most about half a step's travel (a few mm at 3 m/s) for the clearances
and far less for the others (the touchdown and liftoff states, where the leg leans most, are exact). The
guards themselves come from ``drakeslip.dynamics``, the one definition both backends use.

Otherwise the first failure gives a ``Counterexample``: the hop, the ``FailureMode``, when, where, the full
hybrid state there, and the trace of apexes, commands and footholds up to it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from drakeslip import FailureMode, StepLengthController
from drakeslip import dynamics as dyn
from drakeslip.hopper import HybridState, Mode
from drakeslip.rollout import rollout
from drakeslip.simulation import IntegratorConfig, SimulationResult
from drakeslip.terrain import Terrain

from planners.formats.plan import PlanRecord

MODES = ("angles", "footholds", "auto")
_MODE, _DEPLOYED, _ANGLE, _FOOT_X, _FOOT_Z = (HybridState._fields.index(f)
                                               for f in ("mode", "leg_deployed", "leg_angle", "foot_x", "foot_z"))


class Margin(NamedTuple):
    """The tightest value of one margin over the run (positive = safe), the hop, and the x where it was (the
    body's; for ``edge_distance`` the foothold's)."""

    value: float
    hop: int
    x: float


@dataclass
class Certificate:
    """The plan ran to its end on Drake. Margins (each positive, else the run would have failed):

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

    ``deviation``: the largest |actual - planned| foothold [m].
    """

    mode: str
    planned_footholds: list
    footholds: list
    leg_angles: list
    apexes: list            # the start apex, then the apex after each hop
    friction: Margin
    body_clearance: Margin
    foot_clearance: Margin
    stroke: Margin
    max_compression: float
    stroke_length: float
    edge_distance: Margin
    edge_distances: list
    goal_x: float
    target_x: float

    ok = True

    @property
    def deviation(self) -> float:
        return float(np.max(np.abs(np.subtract(self.footholds, self.planned_footholds))))

    def margins(self) -> dict:
        return {"friction": self.friction, "body_clearance": self.body_clearance,
                "foot_clearance": self.foot_clearance, "stroke": self.stroke, "edge_distance": self.edge_distance}

    def to_dict(self) -> dict:
        return _finite({"verdict": "certified", "mode": self.mode, "hops": len(self.footholds),
                        "margins": {k: m._asdict() for k, m in self.margins().items()},
                        "max_compression": self.max_compression, "stroke_length": self.stroke_length,
                        "deviation": self.deviation, "planned_footholds": self.planned_footholds,
                        "footholds": self.footholds, "edge_distances": self.edge_distances,
                        "leg_angles": self.leg_angles, "apexes": self.apexes, "goal_x": self.goal_x,
                        "target_x": self.target_x})

    def format(self) -> str:
        final = self.apexes[-1]
        lines = [f"CERTIFIED: {len(self.footholds)} hops on Drake ({_MODE_WORDS[self.mode]}), final apex "
                 f"x={final[0]:.3f} z={final[1]:.3f} xdot={final[2]:.3f} (plan target x={self.target_x:g}, "
                 f"goal x={self.goal_x:g})"]
        notes = {"friction": "mu - |F_t|/F_n, min over stance",
                 "body_clearance": "m, body to terrain",
                 "foot_clearance": "m, falling foot to a terrain face",
                 "stroke": f"m of spring travel left; max compression {self.max_compression:.4f} of "
                           f"{self.stroke_length:.4f} m",
                 "edge_distance": "m, foothold to the nearest terrain edge"}
        for name, m in self.margins().items():
            where = f"hop {m.hop}, x={m.x:.3f}" if math.isfinite(m.value) else "no terrain edge"
            lines.append(f"  {name:<15} {m.value:9.4f}  ({notes[name]}; {where})")
        lines.append(f"  {'deviation':<15} {self.deviation:9.2e}  (m, max |actual - planned| foothold)")
        lines.append("  hop  planned x  actual x   edge dist  leg angle")
        for k, (p, a, e, th) in enumerate(zip(self.planned_footholds, self.footholds, self.edge_distances,
                                              self.leg_angles)):
            lines.append(f"  {k:3d}  {p:9.4f}  {a:9.4f}  {e:9.4f}  {th:+9.4f}")
        return "\n".join(lines)


@dataclass
class Counterexample:
    """The first failure: ``hop`` (0 = the hop from the start apex), ``failure``, ``time`` [s], ``state``
    (x, z, xdot, zdot), ``foot`` (where the foot was: pinned in stance, extended in flight; None when
    retracted), ``hybrid`` (the HybridState after the failure), and ``trace``: one entry per hop up to the
    failure with its start apex, commanded leg angle, planned and actual foothold."""

    mode: str
    hop: int
    failure: FailureMode
    time: float
    state: tuple
    foot: tuple | None
    hybrid: dict
    trace: list

    ok = False

    @property
    def x(self) -> float:
        return self.state[0]

    def to_dict(self) -> dict:
        return _finite({"verdict": "counterexample", "mode": self.mode, "hop": self.hop,
                        "failure": self.failure.name, "time": self.time, "x": self.x, "state": list(self.state),
                        "foot": None if self.foot is None else list(self.foot), "hybrid": self.hybrid,
                        "trace": self.trace})

    def format(self) -> str:
        s = self.state
        foot = "retracted" if self.foot is None else f"({self.foot[0]:.4f}, {self.foot[1]:.4f})"
        lines = [f"COUNTEREXAMPLE: {self.failure.name} at hop {self.hop}, t={self.time:.4f} s, x={self.x:.4f} "
                 f"({_MODE_WORDS[self.mode]} on Drake)",
                 f"  state x={s[0]:.4f} z={s[1]:.4f} xdot={s[2]:.4f} zdot={s[3]:.4f}, foot {foot}",
                 "  hybrid " + ", ".join(f"{k}={v}" for k, v in self.hybrid.items()),
                 "  hop  apex x    apex z   apex xdot  leg angle  planned x  actual x"]
        for t in self.trace:
            cells = [t["apex"][0], t["apex"][1], t["apex"][2], t["leg_angle"], t["planned_foothold"], t["foothold"]]
            lines.append(f"  {t['hop']:3d}" + "".join("  " + ("        -" if v is None else f"{v:9.4f}")
                                                      for v in cells))
        return "\n".join(lines)


_MODE_WORDS = {"angles": "leg angles open-loop", "footholds": "footholds through the controller"}


def check_plan(record: PlanRecord, mode: str = "auto", controller: StepLengthController | None = None,
               integrator: IntegratorConfig | None = None) -> Certificate | Counterexample:
    """Simulate ``record`` on Drake (see the module doc for the modes) and certify it or return its first
    failure."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if mode == "auto":
        mode = "angles" if np.all(np.isfinite(record.leg_angles)) else "footholds"
    n = len(record.footholds)
    terrain, params = record.terrain, record.params
    if mode == "angles":
        bad = np.flatnonzero(~(np.abs(record.leg_angles) < math.pi / 2))
        if bad.size:
            raise ValueError(f"mode 'angles' needs every leg angle finite and within (-pi/2, pi/2): "
                             f"leg_angles[{bad[0]}] = {record.leg_angles[bad[0]]}; use mode 'footholds'")
        commands = {"leg_angles": [float(a) for a in record.leg_angles]}
    else:
        commands = {"footholds": [float(x) for x in record.footholds],
                    "controller": controller or StepLengthController.load_default()}
    sim = rollout(record.apex, terrain, params, **commands, backend="drake", log=True,
                  integrator=integrator).simulation
    if sim.failure is not None:
        return _counterexample(sim, record, mode)
    if len(sim.apexes) != n:
        raise RuntimeError(f"the Drake run stopped after {len(sim.apexes)} of {n} hops with no failure")
    return _certificate(sim, record, mode)


def _counterexample(sim: SimulationResult, record: PlanRecord, mode: str) -> Counterexample:
    e = sim.failure_event
    hop = sim.failed_hop
    h = HybridState(sim.hybrid[-1])  # logged after the failure's reset: mode FAILED and the failure code
    hybrid = {k: float(v) for k, v in zip(HybridState._fields, h[:])}
    hybrid.update(mode=Mode(int(h.mode)).name, leg_deployed=int(h.leg_deployed), hops=int(h.hops),
                  failure=FailureMode(int(h.failure)).name if h.failure else None)
    foot = e.foot
    if foot is None and h.leg_deployed:
        foot = dyn.foot_position(e.state[0], e.state[1], e.leg_angle, sim.params.as_array())
    apexes = [tuple(record.apex)] + [tuple(a) for a in sim.apexes]
    trace = [{"hop": k, "apex": list(apexes[k]),
              "leg_angle": sim.leg_angles[k] if k < len(sim.leg_angles) else None,
              "planned_foothold": float(record.footholds[k]) if k < len(record.footholds) else None,
              "foothold": sim.footholds[k] if k < len(sim.footholds) else None} for k in range(hop + 1)]
    return Counterexample(mode, hop, sim.failure, e.time, tuple(e.state),
                          None if foot is None else tuple(map(float, foot)), hybrid, trace)


def _certificate(sim: SimulationResult, record: PlanRecord, mode: str) -> Certificate:
    p, terrain = sim.params.as_array(), sim.terrain
    events = [e for e in sim.events if e.kind in ("touchdown", "liftoff", "apex")]
    apex_times = np.array([e.time for e in sim.events if e.kind == "apex"])
    # Every integrator step's sample, then the exact event states (the foot pinned at touchdown and liftoff).
    t = np.r_[sim.times, [e.time for e in events]]
    s = np.vstack([sim.states] + [np.array([e.state for e in events])])
    h = np.vstack([sim.hybrid] + [_event_hybrid(e, sim.hybrid.shape[1]) for e in events])
    hop = np.searchsorted(apex_times, t, side="right")
    x, z = s[:, 0], s[:, 1]

    def tightest(values, mask):
        i = np.flatnonzero(mask)[np.argmin(values[mask])] if mask.any() else None
        return Margin(math.inf, -1, math.nan) if i is None else Margin(float(values[i]), int(hop[i]), float(x[i]))

    stance = h[:, _MODE] == int(Mode.STANCE)
    fx, fz = h[:, _FOOT_X], h[:, _FOOT_Z]
    friction = np.array([dyn.friction_margin(x[i], z[i], fx[i], fz[i], p) / (z[i] - fz[i]) if stance[i] else 0.0
                         for i in range(t.size)])
    stroke = np.array([dyn.stroke_left(x[i], z[i], fx[i], fz[i], p) if stance[i] else 0.0 for i in range(t.size)])
    falling = (h[:, _MODE] == int(Mode.FLIGHT)) & (h[:, _DEPLOYED] == 1)
    foot = np.array([dyn.foot_position(x[i], z[i], h[i, _ANGLE], p) for i in range(t.size)])
    tops, faces = _profile(terrain)
    body = np.minimum(_distance_to_tops(x, z, tops), _distance_to_faces(x, z, faces))
    foot_gap = _distance_to_faces(foot[:, 0], foot[:, 1], faces)
    stroke_margin = tightest(stroke, stance)
    edges = faces[0]
    edge_distances = [float(np.min(np.abs(edges - f))) if edges.size else math.inf for f in sim.footholds]
    edge_i = int(np.argmin(edge_distances))
    return Certificate(mode, [float(f) for f in record.footholds], [float(f) for f in sim.footholds],
                       list(sim.leg_angles), [list(record.apex)] + [list(a) for a in sim.apexes],
                       friction=tightest(friction, stance), body_clearance=tightest(body, np.ones_like(stance)),
                       foot_clearance=tightest(foot_gap, falling), stroke=stroke_margin,
                       max_compression=float(sim.params.leg_length - sim.params.min_leg_length - stroke_margin.value),
                       stroke_length=sim.params.leg_length - sim.params.min_leg_length,
                       edge_distance=Margin(edge_distances[edge_i], edge_i, float(sim.footholds[edge_i])),
                       edge_distances=edge_distances, goal_x=record.goal_x, target_x=record.target_x)


def _event_hybrid(event, width: int) -> np.ndarray:
    """The hybrid row that holds at an event's exact state: stance with the foot pinned at touchdown and
    liftoff, flight with the leg retracted at an apex (its foot is placed by the apex's reset)."""
    row = np.zeros((1, width))
    row[0, _MODE] = int(Mode.STANCE) if event.kind in ("touchdown", "liftoff") else int(Mode.FLIGHT)
    row[0, _ANGLE] = event.leg_angle
    if event.foot is not None:
        row[0, _FOOT_X], row[0, _FOOT_Z] = event.foot
    return row


def _profile(terrain: Terrain):
    """The terrain as segments: tops (x_from, x_to, height), the first and last extended flat to infinity,
    and vertical faces (x, low, high) wherever the height changes."""
    hs = terrain.heights
    change = np.flatnonzero(np.diff(hs) != 0) + 1
    xe = terrain.x0 + terrain.cell * change
    tops = (np.r_[-math.inf, xe], np.r_[xe, math.inf], hs[np.r_[0, change]])
    faces = (xe, np.minimum(hs[change - 1], hs[change]), np.maximum(hs[change - 1], hs[change]))
    return tops, faces


def _distance_to_tops(px, pz, tops) -> np.ndarray:
    a, b, height = (v[None, :] for v in tops)
    dx = np.maximum(np.maximum(a - px[:, None], 0.0), px[:, None] - b)
    return np.min(np.hypot(dx, pz[:, None] - height), axis=1)


def _distance_to_faces(px, pz, faces) -> np.ndarray:
    if faces[0].size == 0:
        return np.full(px.shape, math.inf)
    xe, low, high = (v[None, :] for v in faces)
    dz = np.maximum(np.maximum(low - pz[:, None], 0.0), pz[:, None] - high)
    return np.min(np.hypot(px[:, None] - xe, dz), axis=1)


def _finite(value):
    """JSON has no inf or NaN: an absent margin (no terrain edge) is written as null."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
