"""A plan on a height map checked as written: on the spatial SLIP on Drake, or on the spatial robot.

``check_map_plan(record, mode, tolerance, backend)`` executes a stored map plan (``planners.formats.map_plan``) from
its start apex on the whole map, with no replanning:

* ``backend="drake"``, ``mode="angles"``: the plan's leg angles (pitch, roll) open loop on ``SlipHopper3D``;
* ``backend="drake"``, ``mode="footholds"``: each hop aimed at the plan's next foothold by the spatial controller
  (``drakeslip.spatial.controller.leg_angles_for``) from the apex reached, as the map loop flies a plan;
* ``backend="multibody"``: the spatial robot (``drakeslip.spatial.multibody``, built for the plan's hopper) touching
  down on the plan's footholds with the template's energy (``gait.execute``).

The plan is certified when the run completed every hop with no failure, touched down within ``tolerance`` of every
planned foothold and reached every predicted apex within it (each coordinate, m and m/s), and its last hop reached
the plan's target as the planner's goal test asks (``MapPlanRecord.reach``). Otherwise the counterexample is the
first place, in hop order, where the run left the plan: a failure (its name, and what happened on the robot), a hop
the controller cannot aim (out of the leg's reach), a missed foothold, a missed apex, or the target not reached.

On Drake a certificate carries the run's margins from its log (every integrator step and the exact events): the
friction to spare in stance (mu - |F_t| / F_n), the spring travel left before bottoming out, the body's height above
the map under it, and each foothold's distance to the nearest cell of another height or a hole on the map (an
edge). On the robot it carries the largest body roll and pitch.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from drakeslip.hybrid_hopper import Mode
from drakeslip.jobs.runner import finite
from drakeslip.spatial import dynamics as dyn
from drakeslip.spatial.controller import leg_angles_for
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.simulation import simulate3d
from drakeslip.spatial.slip_hopper import HybridState3D
from drakeslip.units import units_of

from planners.core.spatial_tree import reaches
from planners.formats.map_plan import MapPlanRecord

MODE, FOOT = HybridState3D._fields.index("mode"), HybridState3D._fields.index("foot_x")
EDGE_SEARCH = 1.0   # [m] how far around a foothold an edge is looked for (paper's lengths); farther reads as inf


@dataclass
class MapPlanCheck:
    """The verdict (module doc): ``ok``, or the counterexample's ``kind`` (failure, unreachable, foothold, apex,
    target) at ``hop``, ``planned`` against ``actual``, and ``what`` happened. ``footholds`` and ``apexes``: the run's
    touchdowns and apexes (the start first); ``deviation``: the largest foothold and apex error over the hops
    checked. ``margins`` (Drake; {name: (value, hop)}) or ``attitude`` (robot; largest |roll|, |pitch| [rad]);
    ``run`` the Drake result or the robot's ``GaitLog``."""

    backend: str
    mode: str
    tolerance: float
    ok: bool
    kind: str | None = None
    hop: int = -1
    planned: object = None
    actual: object = None
    what: str = ""
    footholds: list = field(default_factory=list)
    apexes: list = field(default_factory=list)
    deviation: tuple = (0.0, 0.0)
    margins: dict | None = None
    attitude: tuple | None = None
    run: object = field(default=None, repr=False, compare=False)

    def where(self) -> str:
        return ("the spatial SLIP on Drake" if self.backend == "drake" else "the spatial robot") + \
            f" ({'leg angles open loop' if self.mode == 'angles' else 'footholds through the controller'})"

    def reason(self) -> str:
        """The counterexample in one line (empty for a certificate)."""
        if self.ok:
            return ""
        return (f"hop {self.hop}, {self.kind}: planned {as_text(self.planned)}, actual {as_text(self.actual)}"
                f"{f' ({self.what})' if self.what else ''}")

    def format(self) -> str:
        head = (f"CERTIFIED on {self.where()}: all {len(self.footholds)} hops, every foothold and predicted apex "
                f"within {self.tolerance:g}, the target reached" if self.ok else
                f"COUNTEREXAMPLE on {self.where()}: {self.reason()}")
        lines = [head, f"  largest foothold error {self.deviation[0]:.4f} m, apex error {self.deviation[1]:.4f} "
                       f"(m, m/s) over the hops checked"]
        for name, (value, hop) in (self.margins or {}).items():
            lines.append(f"  {name:<15} {value:9.4f}  ({MARGIN_WORDS[name]}; hop {hop})")
        if self.attitude is not None:
            lines.append(f"  largest body roll {self.attitude[0]:.3f} rad, pitch {self.attitude[1]:.3f} rad")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return finite({"verdict": "certified" if self.ok else "counterexample", "backend": self.backend,
                       "mode": self.mode, "tolerance": self.tolerance, "kind": self.kind, "hop": self.hop,
                       "planned": self.planned, "actual": self.actual, "what": self.what, "footholds": self.footholds,
                       "apexes": self.apexes, "deviation": self.deviation,
                       "margins": None if self.margins is None else {k: {"value": v, "hop": h}
                                                                     for k, (v, h) in self.margins.items()},
                       "attitude": self.attitude})


MARGIN_WORDS = {"friction": "mu - |F_t|/F_n, min over stance", "stroke": "m of spring travel left, min over stance",
                "body_clearance": "m, body above the map under it", "edge_distance": "m, foothold to the nearest edge"}


def check_map_plan(record: MapPlanRecord, mode: str, tolerance: float, backend: str = "drake") -> MapPlanCheck:
    """Run ``record`` on ``backend`` ("drake" with ``mode`` "angles" or "footholds"; "multibody" flies footholds) and
    certify it or give the counterexample (module doc)."""
    if backend == "multibody":
        return robot_check(record, tolerance)
    footholds = [tuple(f) for f in record.footholds]
    if mode == "angles":
        commands = [tuple(a) for a in record.leg_angles]
    else:
        unreachable = []

        def commands(apex, k):
            if k >= len(footholds):
                return None
            try:
                return leg_angles_for(tuple(apex), footholds[k], record.params)
            except ValueError as error:
                unreachable.append((k, str(error)))
                return None
    sim = simulate3d(record.apex, commands, record.height_map, record.params, max_hops=len(footholds) + 1)
    failed = None
    if sim.failure is not None:
        failed = (len(sim.apexes), sim.failure.name, "")
    elif mode != "angles" and unreachable:
        failed = (unreachable[0][0], "unreachable", unreachable[0][1])
    verdict = compare(record, mode, tolerance, "drake", sim.footholds, [tuple(a) for a in sim.apexes], failed)
    verdict.run = sim
    if verdict.ok:
        verdict.margins = map_margins(sim)
    return verdict


def robot_check(record: MapPlanRecord, tolerance: float) -> MapPlanCheck:
    """The plan's footholds flown by the spatial robot built for its hopper."""
    from drakeslip.spatial.multibody.gait import execute
    from drakeslip.spatial.multibody.robot import SpatialRobotParams

    log = execute(record.apex, record.height_map, record.footholds, SpatialRobotParams.for_hopper(record.params),
                  trajectory=True)
    f = log.failure
    failed = None if f is None else (len(log.apexes), f.mode.name, f.what)   # the run stops at its failure
    verdict = compare(record, "footholds", tolerance, "multibody", [t[1:4] for t in log.touchdowns],
                      [tuple(a[1:6]) for a in log.apexes], failed)
    verdict.run, verdict.attitude = log, log.max_attitude()
    return verdict


# many parameters: the plan, how it ran and what the run did, the inputs of one comparison
def compare(record: MapPlanRecord, mode: str, tolerance: float, backend: str, touchdowns, apexes,
            failed) -> MapPlanCheck:
    """The verdict on a run that touched down at ``touchdowns`` and reached ``apexes`` (after the start), ending at
    ``failed`` (hop, kind, what) or None: the first place it left the plan, hop by hop."""
    touchdowns = [tuple(map(float, t)) for t in touchdowns]
    apexes = [tuple(map(float, a)) for a in apexes]
    worst = [0.0, 0.0]
    base = dict(backend=backend, mode=mode, tolerance=tolerance, footholds=touchdowns,
                apexes=[tuple(record.apex)] + apexes)

    def counterexample(kind, k, planned, actual, what=""):
        return MapPlanCheck(ok=False, kind=kind, hop=k, planned=planned, actual=actual, what=what,
                            deviation=tuple(worst), **base)

    for k, planned in enumerate(record.footholds):
        if failed is not None and failed[0] == k and (failed[1] == "unreachable" or k >= len(touchdowns)):
            return counterexample(failed[1], k, None, None, failed[2])
        if k < len(touchdowns):
            error = float(np.max(np.abs(np.subtract(touchdowns[k], planned))))
            worst[0] = max(worst[0], error)
            if error > tolerance:
                return counterexample("foothold", k, tuple(map(float, planned)), touchdowns[k])
        if failed is not None and failed[0] == k:
            return counterexample(failed[1], k, None, None, failed[2])
        predicted = record.apexes[k]
        if k < len(apexes) and np.all(np.isfinite(predicted)):
            error = float(np.max(np.abs(np.subtract(apexes[k], predicted))))
            worst[1] = max(worst[1], error)
            if error > tolerance:
                return counterexample("apex", k, tuple(map(float, predicted)), apexes[k])
    if failed is not None:
        return counterexample(failed[1], failed[0], None, None, failed[2])
    last = len(record.footholds) - 1
    if len(touchdowns) <= last:
        return counterexample("failure", len(touchdowns), None, None, "the run ended before the plan's last hop")
    before = touchdowns[last - 1][:2] if last else record.apex[:2]   # the way starts where the planner's does
    if not reaches(before[0], before[1], touchdowns[last][0], touchdowns[last][1], record.reach):
        return counterexample("target", last, tuple(record.target), touchdowns[last][:2])
    return MapPlanCheck(ok=True, deviation=tuple(worst), **base)


def map_margins(sim) -> dict:
    """{name: (value, hop)} of a logged Drake run without a failure (module doc): the tightest value of each margin
    over the logged steps and the exact events, and the hop (apexes passed) where it was."""
    p, ground = sim.params.as_array(), sim.height_map.ground()
    events = [e for e in sim.events if e.kind in ("touchdown", "liftoff")]
    states = np.vstack([sim.states] + [np.array([e.state for e in events]).reshape(-1, 6)])
    feet = np.vstack([sim.hybrid[:, FOOT:FOOT + 3]] + [np.array([e.foot for e in events]).reshape(-1, 3)])
    stance = np.r_[sim.hybrid[:, MODE] == int(Mode.STANCE), np.ones(len(events), dtype=bool)]
    times = np.r_[sim.times, [e.time for e in events]]
    hop = np.searchsorted(np.array([e.time for e in sim.events if e.kind == "apex"]), times, side="right")

    def tightest(values, mask):
        if not mask.any():
            return math.inf, -1
        i = np.flatnonzero(mask)[np.argmin(values[mask])]
        return float(values[i]), int(hop[i])

    x, y, z = states[:, 0], states[:, 1], states[:, 2]
    friction = np.array([dyn.friction_margin(x[i], y[i], z[i], *feet[i], p) / (z[i] - feet[i, 2]) if stance[i]
                         else 0.0 for i in range(len(x))])
    stroke = np.array([dyn.stroke_left(x[i], y[i], z[i], *feet[i], p) if stance[i] else 0.0 for i in range(len(x))])
    body = np.array([dyn.body_clearance(x[i], y[i], z[i], ground) for i in range(len(x))])
    edges = [edge_distance(sim.height_map, f[0], f[1], EDGE_SEARCH * units_of(sim.params).length)
             for f in sim.footholds]
    edge = (min(edges), int(np.argmin(edges))) if edges else (math.inf, -1)
    return {"friction": tightest(friction, stance), "stroke": tightest(stroke, stance),
            "body_clearance": tightest(body, np.isfinite(body)), "edge_distance": edge}


def edge_distance(height_map: HeightMap, x: float, y: float, within: float) -> float:
    """The distance from (x, y) to the nearest cell within ``within`` whose height differs from the cell under it
    (a hole counts), inf where there is none."""
    h = height_map.heights
    c, (x0, y0) = height_map.cell, height_map.origin
    j, i = height_map.index(x, y)
    n = int(math.ceil(within / c))
    j0, j1, i0, i1 = max(j - n, 0), min(j + n + 1, h.shape[0]), max(i - n, 0), min(i + n + 1, h.shape[1])
    patch = h[j0:j1, i0:i1]
    other = np.isnan(patch) | (np.abs(patch - h[j, i]) > 1e-9)
    if not other.any():
        return math.inf
    rows, cols = np.nonzero(other)
    left, bottom = x0 + (cols + i0) * c, y0 + (rows + j0) * c
    dx = np.maximum(np.maximum(left - x, 0.0), x - (left + c))
    dy = np.maximum(np.maximum(bottom - y, 0.0), y - (bottom + c))
    return float(np.min(np.hypot(dx, dy)))


def as_text(value) -> str:
    """A planned or actual value of a counterexample as its line shows it."""
    if value is None:
        return "-"
    if isinstance(value, tuple):
        return "(" + ", ".join(f"{v:.3f}" for v in value) + ")"
    return str(value)
