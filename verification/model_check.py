"""Bounded model checking: can the terrain from a case's start be crossed at all?

For one case (initial apex, whole terrain, goal, friction) the oracle explores the apex states reachable by
leg-angle sequences drawn from a grid inside the friction cone, with the fast batched step map, until a hop
ends with its apex at or past the goal (the evaluation's success test). It sees the whole terrain (no
perception window) and chooses every hop: it asks whether *any* plan exists, not whether a planner finds one.

The state, and why merging is sound enough
  The SLIP is conservative (lossless spring, massless leg, no impacts), so every apex of a run has the start's
  energy E and its height is ``z = E/(m g) - xdot^2/(2 g)``: the apex state is (x, xdot). Apexes in the same
  merge cell (``merge_x`` by ``merge_xdot``: 1 cm by 1 cm/s) are treated as one, represented by one arrival.
  Away from event boundaries the step map is continuous, so the states of a cell have children within about
  a cell of each other for every leg angle: 1 cm of x shifts every later foothold by 1 cm, and 1 cm/s of
  speed moves a foothold by ~3 mm per 0.3 s of flight. That is the order of the angle grid's own foothold
  spacing (0.5 deg moves a foothold by 4-8 mm), so merging costs little beyond the discretization itself.
  It is still an approximation: a sequence whose feasible footholds form bands narrower than a cell (a knife
  edge) can be lost. Hence the precise verdicts:

  ``traversable``      a sequence of grid leg angles, commanded open-loop on the Drake simulator
                       (``drakeslip.simulation``), reaches the goal with no failure: the ``witness``.
  ``not-traversable``  every pass exhausted its reachable set without reaching the goal: no plan exists over
                       this leg-angle grid with these merge tolerances (on the fast step map). A coarse pass
                       (0.5 deg, 1 cm, 1 cm/s) is confirmed by a finer one (0.25 deg, 0.5 cm) before this is
                       said (``LEVELS``).
  ``unknown``          the node or time budget ran out, or Drake rejected every witness tried (or a rejected
                       witness pruned the graph before it was exhausted).

The search
  x grows on every successful hop (the forward speed stays positive), so the graph is acyclic and finite at a
  given resolution. Hops to apexes slower than ``MIN_SPEED`` are dropped (0.1 m/s; the planners drop those
  under 0.3 m/s, so no apex a planner's plan can pass through is excluded). There is no hop cap; a witness
  longer than the evaluation's 60 hops would still count (its length is in ``hops``). Each iteration takes
  a batch of nodes and expands them with every grid angle in one ``step_batch`` call. The queue pops first the
  apexes reached with the fewest risky hops, among those the one farthest ahead (a goal is usually found in a
  few hundred nodes when one exists), and a cell is represented by its arrival with the fewest risky hops. A hop
  is risky when its foothold lies within ``EDGE_MARGIN`` of an edge, its next apex is slower than
  ``CAREFUL_SPEED`` (the planners avoid both) or its foot clears the terrain at the apex by less than
  ``TRIP_MARGIN``: there the two simulators can part (Drake checks the touchdown guard at its 2 ms step ends,
  so a foot landing within a step's travel of a ditch edge can miss the ground; see
  ``drakeslip.simulation.IntegratorConfig``). This orders the search and prunes nothing, so the verdicts keep
  their meaning, but witnesses stay off knife edges where they can.

The Drake check
  A witness is executed on Drake one continuous simulation long, and replanned on the fast map from Drake's
  apex wherever that has drifted more than ``REPLAN_TOLERANCE`` from the prediction (``execute_on_drake``):
  the backends differ by ~1e-8 m a hop and a slow gait amplifies that 4-10x a hop, as any open-loop SLIP gait
  does. The simulation is deterministic, so the grid angles it commanded replay open-loop to the same run.
"""
from __future__ import annotations

import heapq
import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain, step_batch
from drakeslip.rollout import HOP_SECONDS, rollout

from planners.base import Budget
from planners.search.tree import clear_of_edges

TRAVERSABLE, NOT_TRAVERSABLE, UNKNOWN = "traversable", "not-traversable", "unknown"
MIN_SPEED = 0.1        # m/s: slower apexes are dropped (the planners' floor is 0.3 m/s)
BATCH_NODES = 32       # nodes expanded per step_batch call
MAX_WITNESSES = 5      # Drake executions tried before a case is called unknown
REPLAN_TOLERANCE = 1e-3  # m, m/s: Drake's apex this far from the predicted one is replanned from
REPLAN_NODES = 50_000  # node budget of one replan during a Drake execution
EDGE_MARGIN = 0.02     # m: hops landing this close to an edge are searched last (the planners drop them) ...
CAREFUL_SPEED = 0.3    # m/s: ... and so are hops to apexes slower than this (the planners' floor) ...
TRIP_MARGIN = 0.01     # m: ... and hops whose foot clears the terrain at the apex by less than this
DEFAULT_BUDGET = Budget(max_nodes=600_000, max_time_s=600.0)   # per case, all passes together


@dataclass(frozen=True)
class Resolution:
    """One pass: leg angles ``k * angle_deg`` inside the friction cone; apexes merged on (x, xdot) cells of
    ``merge_x`` m by ``merge_xdot`` m/s."""

    angle_deg: float
    merge_x: float
    merge_xdot: float

    def __post_init__(self):
        for name in ("angle_deg", "merge_x", "merge_xdot"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"Resolution.{name} must be a positive finite number, got {v!r}")

    def angles(self, params: SlipParams) -> np.ndarray:
        """The grid: 0 and multiples of the step with |theta| < atan(mu) (the touchdown friction cone)."""
        step = math.radians(self.angle_deg)
        k = math.ceil(params.max_leg_angle / step) - 1
        return np.arange(-k, k + 1) * step


COARSE = Resolution(0.5, 0.01, 0.01)
FINE = Resolution(0.25, 0.005, 0.01)   # 1 cm/s of speed moves a foothold by ~3 mm: x and angle matter more
LEVELS = (COARSE, FINE)


class _Pass:
    """Best-first search at one resolution. Nodes live in flat lists; node 0 is the start apex."""

    def __init__(self, apex: ApexState, terrain: Terrain, goal_x: float, params: SlipParams, res: Resolution,
                 min_speed: float):
        self.terrain, self.goal_x, self.params, self.res, self.min_speed = terrain, goal_x, params, res, min_speed
        self.grid = res.angles(params)
        self.parent, self.angle, self.foothold, self.risk = [-1], [math.nan], [math.nan], [0]
        self.apex = [tuple(apex)]
        self.seen = {self._key(apex[0], apex[2]): 0}   # merge cell -> the node that represents it
        self.queue = [(0, -apex[0], 0)]                # (risky hops, -x, node)
        self.goals: list = []       # goal nodes found, not yet handed out
        self.banned: set = set()    # nodes whose hop Drake rejected (and so their subtrees)
        self.nodes = 0

    def _key(self, x, xdot):
        return (round(x / self.res.merge_x), round(xdot / self.res.merge_xdot))

    def _alive(self, node: int) -> bool:
        while node > 0 and self.banned:
            if node in self.banned:
                return False
            node = self.parent[node]
        return True

    def _add(self, parent, angle, foothold, apex, risk) -> int:
        self.parent.append(parent)
        self.angle.append(angle)
        self.foothold.append(foothold)
        self.apex.append(apex)
        self.risk.append(risk)
        return len(self.parent) - 1

    def _pop_batch(self, size: int) -> list:
        batch = []
        while self.queue and len(batch) < size:
            node = heapq.heappop(self.queue)[2]
            if self.seen.get(self._key(self.apex[node][0], self.apex[node][2])) == node and self._alive(node):
                batch.append(node)   # else superseded by a safer arrival in its cell, or banned
        return batch

    def _foot_clearance(self, apex: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Height of the commanded foot above the terrain at each apex (rows of (x, z, xdot))."""
        L0 = self.params.leg_length
        return apex[:, 1] - L0 * np.cos(angles) - self.terrain.height_at(apex[:, 0] + L0 * np.sin(angles))

    def _pop_goal(self, safest_only: bool):
        """The pending goal with the fewest risky hops, if it is alive and (``safest_only``) no node still in
        the queue could lead to a goal with fewer."""
        while self.goals and not (safest_only and self.queue and self.queue[0][0] < self.goals[0][0]):
            g = heapq.heappop(self.goals)[1]
            if self._alive(g):
                return g
        return None

    def next_goal(self, max_nodes: int, deadline: float):
        """Search on until a goal node is found (returns ``(node, None)``) or the search stops (returns
        ``(None, "exhausted" | "nodes" | "time")``). Call again after ``ban`` for another witness."""
        n = self.grid.size
        while True:
            g = self._pop_goal(safest_only=True)
            if g is not None:
                return g, None
            stop = ("exhausted" if not self.queue else "nodes" if self.nodes >= max_nodes
                    else "time" if time.perf_counter() >= deadline else None)
            if stop:
                g = self._pop_goal(safest_only=False)
                return (g, None) if g is not None else (None, stop)
            batch = self._pop_batch(min(BATCH_NODES, max_nodes - self.nodes))
            if not batch:
                continue
            self.nodes += len(batch)
            starts = np.array([self.apex[i] for i in batch])
            r = step_batch(np.repeat(starts, n, axis=0), np.tile(self.grid, len(batch)), self.terrain, self.params)
            goal = r.ok & (r.next_x >= self.goal_x)
            keep = r.ok & ~goal & (r.next_xdot >= self.min_speed)
            idx = np.flatnonzero(goal | keep)
            risky = (~clear_of_edges(self.terrain, r.touchdown_x[idx], EDGE_MARGIN)
                     | (r.next_xdot[idx] < CAREFUL_SPEED)
                     | (self._foot_clearance(starts[idx // n], self.grid[idx % n]) < TRIP_MARGIN))
            for i, bad in zip(idx.tolist(), risky.tolist()):
                parent = batch[i // n]
                apex = (float(r.next_x[i]), float(r.next_z[i]), float(r.next_xdot[i]))
                risk = self.risk[parent] + bad
                if goal[i]:
                    node = self._add(parent, float(self.grid[i % n]), float(r.touchdown_x[i]), apex, risk)
                    heapq.heappush(self.goals, (risk, node))
                    continue
                key = self._key(apex[0], apex[2])
                held = self.seen.get(key)
                if held is not None and self.risk[held] <= risk:
                    continue
                node = self._add(parent, float(self.grid[i % n]), float(r.touchdown_x[i]), apex, risk)
                self.seen[key] = node
                heapq.heappush(self.queue, (risk, -apex[0], node))

    def path(self, node: int) -> list[int]:
        """Nodes from the first hop's child to ``node``."""
        out = []
        while node > 0:
            out.append(node)
            node = self.parent[node]
        return out[::-1]

    def witness(self, node: int) -> dict:
        p = self.path(node)
        return {"leg_angles": [self.angle[i] for i in p], "footholds": [self.foothold[i] for i in p],
                "apexes": [list(self.apex[i]) for i in p]}

    def ban(self, node: int) -> None:
        self.banned.add(node)


def execute_on_drake(apex: ApexState, witness: dict, search_from, goal_x: float, terrain: Terrain,
                     params: SlipParams) -> dict:
    """Execute a witness on the Drake simulator, with its leg angles commanded at each apex, and replan when
    Drake's apex has drifted more than ``REPLAN_TOLERANCE`` from the fast map's prediction:
    ``search_from(apex)`` must return a new witness from there, or None. Pure open-loop replay is not enough
    in general: the backends differ by ~1e-8 m a hop and a slow gait amplifies that up to 4-10x a hop, as
    any open-loop SLIP gait does (the evaluation replans every 3 hops for the same reason). It is one
    continuous, deterministic simulation, so the leg angles it ran re-check open-loop on Drake exactly.
    Returns {"ok", "replans", "hops_done", "failure", "final_x", "drift_hop", "leg_angles", "footholds",
    "apexes"}: ok when every hop succeeds and the last apex is at or past ``goal_x``; ``drift_hop`` is the first
    hop at whose start Drake had drifted (None if never)."""
    plan = {"start": 0, "from": tuple(apex), **witness}
    log = {"replans": 0, "drift_hop": None, "stuck": False}

    def policy(a, hop):
        j = hop - plan["start"]
        if j >= len(plan["leg_angles"]):
            return None   # the plan is done: its last apex is past the goal
        expected = plan["apexes"][j - 1] if j > 0 else plan["from"]
        if max(abs(u - v) for u, v in zip(a, expected)) > REPLAN_TOLERANCE:
            log["drift_hop"] = hop if log["drift_hop"] is None else log["drift_hop"]
            new = search_from(ApexState(*a))
            if new is None:
                log["stuck"] = True
                return None
            plan.update(start=hop, **{"from": tuple(a)}, **new)
            log["replans"] += 1
            j = 0
        return plan["leg_angles"][j]

    run = rollout(apex, terrain, params, leg_angles=policy, backend="drake",
                  max_time=HOP_SECONDS * (len(witness["leg_angles"]) + 20))
    final_x = run.apexes[-1].x if run.apexes else apex.x
    return {"ok": run.ok and not log["stuck"] and final_x >= goal_x, "replans": log["replans"],
            "hops_done": len(run.apexes), "failure": run.failure.name if run.failure else None,
            "final_x": float(final_x), "drift_hop": log["drift_hop"],
            "leg_angles": [float(v) for v in run.leg_angles], "footholds": [float(v) for v in run.footholds],
            "apexes": [[float(v) for v in e] for e in run.apexes]}


def model_check(apex, terrain: Terrain, goal_x: float, params: SlipParams | None = None, levels=LEVELS,
                budget: Budget = DEFAULT_BUDGET, min_speed: float = MIN_SPEED, drake_check: bool = True,
                max_witnesses: int = MAX_WITNESSES) -> dict:
    """The verdict for one start: {"verdict", "witness", "nodes", "time_s", "hops", "passes", "drake"}.

    ``levels`` are tried in order; each later one runs only if the one before exhausted its graph, and the
    case is not traversable only if the last one exhausts too. ``budget`` bounds the node expansions and the
    seconds of all passes together (Drake executions use up the seconds too, but one is never cut short;
    replans inside them do not count as nodes). ``drake_check=False`` accepts the first witness on the fast
    step map alone (diagnosis only)."""
    params = params or SlipParams()
    apex = ApexState(*map(float, apex)).validate()
    if not isinstance(budget, Budget):
        raise TypeError(f"budget must be a planners.base.Budget, got {type(budget).__name__}")
    if not levels or not all(isinstance(r, Resolution) for r in levels):
        raise ValueError(f"levels must be a non-empty sequence of Resolution, got {levels!r}")
    if not (math.isfinite(goal_x) and math.isfinite(min_speed) and min_speed > 0):
        raise ValueError(f"goal_x must be finite and min_speed positive, got {goal_x!r}, {min_speed!r}")
    if apex.xdot <= 0:
        raise ValueError(f"apex xdot={apex.xdot} must be positive: the hopper moves forward")
    step_batch(apex, [0.0], terrain, params)  # checks the apex is above the terrain; compiles the kernel once
    t0 = time.perf_counter()
    deadline = t0 + budget.max_time_s
    result = {"verdict": UNKNOWN, "witness": None, "nodes": 0, "time_s": 0.0, "hops": 0, "passes": [],
              "drake": []}
    if apex.x >= goal_x:
        result.update(verdict=TRAVERSABLE, witness={"leg_angles": [], "footholds": [], "apexes": []})
        return result
    for res in levels:
        t_pass = time.perf_counter()
        search = _Pass(apex, terrain, goal_x, params, res, min_speed)
        stop = None
        while True:
            node, stop = search.next_goal(budget.max_nodes - result["nodes"], deadline)
            if node is None:
                break
            witness = search.witness(node)
            if not drake_check:
                result.update(verdict=TRAVERSABLE, witness=witness)
                break
            run = execute_on_drake(apex, witness, lambda a, res=res: _replan(a, terrain, goal_x, params, res,
                                                                             min_speed, deadline),
                                   goal_x, terrain, params)
            result["drake"].append({k: run[k] for k in ("ok", "replans", "hops_done", "failure", "final_x",
                                                        "drift_hop")})
            if run["ok"]:
                result.update(verdict=TRAVERSABLE, witness={k: run[k] for k in ("leg_angles", "footholds", "apexes")})
                break
            # Drake disagrees (a near-tie the two integrators resolve differently, or a drift with no way on):
            # drop the witness's apex where it drifted, or else its hop that failed, with the subtree.
            path = search.path(node)
            bad = run["drift_hop"] - 1 if run["drift_hop"] else min(run["hops_done"], len(path) - 1)
            search.ban(path[bad])
            if len(result["drake"]) >= max_witnesses:
                stop = "witnesses"
                break
        result["nodes"] += search.nodes
        result["passes"].append({**asdict(res), "stop": "goal" if result["verdict"] == TRAVERSABLE else stop,
                                 "nodes": search.nodes, "states": len(search.seen),
                                 "time_s": time.perf_counter() - t_pass})
        if result["verdict"] == TRAVERSABLE or stop != "exhausted" or search.banned:
            break  # found; out of budget; or a pruned graph, whose exhaustion proves nothing
    else:
        result["verdict"] = NOT_TRAVERSABLE
    if result["witness"] is not None:
        result["hops"] = len(result["witness"]["leg_angles"])
    result["time_s"] = time.perf_counter() - t0
    return result


def _replan(apex, terrain, goal_x, params, res, min_speed, deadline) -> dict | None:
    """A fresh fast-map witness from ``apex`` (a Drake execution's drifted apex), or None."""
    search = _Pass(apex, terrain, goal_x, params, res, min_speed)
    node, _ = search.next_goal(REPLAN_NODES, deadline)
    return None if node is None else search.witness(node)
