"""Bounded model checking: can the terrain from a case's start be crossed at all?

For one case (initial apex, whole terrain, goal, friction) the oracle explores the apex states reachable by
leg-angle sequences drawn from a grid inside the friction cone, with the fast batched step map, until a hop
ends with its apex at or past the goal (the evaluation's success test). It sees the whole terrain (no
perception window) and chooses every hop: it asks whether *any* plan exists, not whether a planner finds one.

The state, and why merging is sound enough
  The SLIP is conservative, so an apex's height is ``z = E/(m g) - xdot^2/(2 g)``: its state is (x, xdot). Apexes
  in one merge cell (``merge_x`` by ``merge_xdot``) are represented by one arrival. Away from event boundaries the
  step map is continuous, so a cell's states have children within about a cell of each other (1 cm of x shifts
  later footholds by 1 cm, 1 cm/s of speed ~3 mm per 0.3 s of flight), the order of the grid's foothold spacing
  (0.5 deg: 4-8 mm). A knife edge narrower than a cell can be lost.

The verdicts (``verdict``, with a one-line ``statement`` of what it rests on)
  ``traversable``             a sequence of grid leg angles reaches the goal with no failure when commanded
                              open-loop on the Drake simulator (``drakeslip.simulation``): the ``witness``.
  ``proved-not-traversable``  the energy argument (``verification.energy_bound``) shows that no run of the model
                              reaches the goal, for any leg angles at all (``proof``); no search is run.
  ``not-traversable``         a pass of ``LEVELS`` exhausted its reachable set: no plan over its leg-angle grid
                              with its merge cells and apexes no slower than ``MIN_SPEED``, on the fast step map.
                              ``holds_at`` is the finest such pass (0.25 deg, 5 mm x 1 cm/s, confirming the
                              ``coarser`` 0.5 deg, 1 cm x 1 cm/s); ``unconfirmed`` names a finer pass that ran out
                              of budget first, with no witness (none with ``confirm``: then the case is unknown).
  ``unknown``                 ``why``: "time" or "nodes" (a budget ran out), "witnesses" (Drake rejected
                              ``max_witnesses``) or "pruned" (exhausted only after rejected witnesses pruned it).

The search
  x grows on every successful hop (the forward speed stays positive), so the graph is acyclic and finite at a given
  resolution. Apexes slower than ``MIN_SPEED`` are dropped (0.1 m/s; the planners drop those under 0.3 m/s), and so
  are those from which the energy argument shows the goal unreachable (``Coreach``: sound, no plan is lost). There is
  no hop cap (a witness's length is in ``hops``). Each iteration expands a batch of nodes with every grid angle in one
  ``step_batch`` call; each merge cell is expanded once, from its first arrival with the least risk. A hop landing
  within ``EDGE_MARGIN`` of an edge, or whose foot clears the terrain at the apex by less than ``TRIP_MARGIN``, is
  risky: there the two simulators can part (Drake checks guards at its 2 ms step ends), and it adds ``EDGE_RISK``; a
  hop to an apex slower than ``CAREFUL_SPEED`` (the planners' floor) adds 1. The queue pops the node farthest ahead,
  less ``RISK_COST`` m per unit of risk on its path: low-energy starts often need slow hops to climb a step, which a
  queue of the safe apexes first reaches only after far more nodes. The order prunes nothing, so the verdicts keep
  their meaning. Speeds, lengths and merge cells are the paper's hopper's, used in the checked hopper's units
  (``drakeslip.units``; ``min_speed`` given is in m/s).

The Drake check
  A witness is executed on Drake in one continuous simulation, replanned on the fast map from Drake's apex
  wherever that drifted more than ``REPLAN_TOLERANCE`` from the prediction (``verification.drake_witness``): the
  backends differ by ~1e-8 m a hop and a slow gait amplifies that 4-10x a hop. The grid angles it ran replay
  open-loop.
"""
from __future__ import annotations

import heapq
import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain, step_batch
from drakeslip.units import units_of
from planners.base import Budget
from planners.search.tree import clear_of_edges
from planners.search.energy_graph import Coreach, cell_graph
from verification.drake_witness import execute_on_drake
from verification.energy_bound import prove_unreachable

TRAVERSABLE, NOT_TRAVERSABLE, UNKNOWN = "traversable", "not-traversable", "unknown"
PROVED_NOT_TRAVERSABLE = "proved-not-traversable"
MIN_SPEED = 0.1        # m/s: slower apexes are dropped (the planners' floor is 0.3 m/s)
BATCH_NODES = 32       # nodes expanded per step_batch call
MAX_WITNESSES = 5      # Drake executions tried before a case is called unknown
REPLAN_NODES = 50_000  # node budget of one replan during a Drake execution
EDGE_MARGIN = 0.02     # m: a hop landing this close to an edge is risky (the planners drop them) ...
TRIP_MARGIN = 0.01     # m: ... and so is one whose foot clears the terrain at the apex by less than this;
CAREFUL_SPEED = 0.3    # m/s: a hop to an apex slower than this (the planners' floor) is slow
RISK_COST = 0.3        # m of progress the queue takes off per unit of risk on a node's path: a slow hop is 1,
EDGE_RISK = 2         # an edge or trip hop this many (Drake rejects those: a foot near an edge can miss it)
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
                 min_speed: float, alive=None, parallel: bool = False):
        self.start, self.terrain, self.goal_x, self.params = apex, terrain, goal_x, params
        self.res, self.min_speed = res, min_speed
        u = units_of(params)   # merge cells, margins and the risk cost in the hopper's units
        self.merge_x, self.risk_cost, self.edge_margin, self.trip_margin = (
            c * u.length for c in (res.merge_x, RISK_COST, EDGE_MARGIN, TRIP_MARGIN))
        self.merge_xdot, self.careful = res.merge_xdot * u.speed, CAREFUL_SPEED * u.speed
        self.alive, self.parallel = alive, parallel   # rows of apexes -> mask, or None; all cores per batch
        self.grid = res.angles(params)
        self.parent, self.angle, self.foothold, self.risk = [-1], [math.nan], [math.nan], [0]
        self.apex = [tuple(apex)]
        self.seen = {self._key(apex[0], apex[2]): 0}   # merge cell -> the node that represents it
        self.queue = [(-apex[0], 0)]   # smallest first: farthest ahead, less the risk cost of the path
        self.goals: list = []       # goal nodes found, not yet handed out
        self.banned: set = set()    # nodes whose hop Drake rejected (and so their subtrees)
        self.expanded, self.nodes, self.pruned = bytearray(1), 0, 0   # expanded[node] = 1 once expanded

    def _key(self, x, xdot):
        return (round(x / self.merge_x), round(xdot / self.merge_xdot))

    def _alive(self, node: int) -> bool:
        while node > 0 and self.banned:
            if node in self.banned:
                return False
            node = self.parent[node]
        return True

    def _add(self, parent, angle, foothold, apex, risk) -> int:
        for column, value in ((self.parent, parent), (self.angle, angle), (self.foothold, foothold),
                              (self.apex, apex), (self.risk, risk), (self.expanded, 0)):
            column.append(value)
        return len(self.parent) - 1

    def _pop_batch(self, size: int) -> list:
        batch = []
        while self.queue and len(batch) < size:
            node = heapq.heappop(self.queue)[1]
            if self.seen.get(self._key(self.apex[node][0], self.apex[node][2])) == node and self._alive(node):
                batch.append(node)   # else superseded by a safer arrival in its cell, or banned
                self.expanded[node] = 1
        return batch

    def _pop_goal(self, safest_only: bool):
        """The pending goal first in the queue order, if it is alive and (``safest_only``) no node still in the
        queue comes before it."""
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
            if batch:
                self.nodes += len(batch)
                self._expand(batch, n)

    def _expand(self, batch: list, n: int) -> None:
        """Every grid angle from every node of ``batch``: goals are kept, other children merged into cells."""
        starts = np.array([self.apex[i] for i in batch])
        r = step_batch(np.repeat(starts, n, axis=0), np.tile(self.grid, len(batch)), self.terrain, self.params,
                       parallel=self.parallel)
        goal = r.ok & (r.next_x >= self.goal_x)
        keep = r.ok & ~goal & (r.next_xdot >= self.min_speed)
        if self.alive is not None and keep.any():
            k = np.flatnonzero(keep)
            dead = ~self.alive(np.column_stack([r.next_x[k], r.next_z[k], r.next_xdot[k]]))
            keep[k[dead]] = False
            self.pruned += int(dead.sum())
        idx = np.flatnonzero(goal | keep)
        if idx.size == 0:
            return
        top, angle, L0 = starts[idx // n], self.grid[idx % n], self.params.leg_length   # foot clearance at apex:
        foot = top[:, 1] - L0 * np.cos(angle) - self.terrain.height_at(top[:, 0] + L0 * np.sin(angle))
        risky = (EDGE_RISK * (~clear_of_edges(self.terrain, r.touchdown_x[idx], self.edge_margin)
                              | (foot < self.trip_margin)) + (r.next_xdot[idx] < self.careful))
        risk = np.array([self.risk[b] for b in batch])[idx // n] + risky
        kx = np.round(r.next_x[idx] / self.merge_x).astype(np.int64)
        kv = np.round(r.next_xdot[idx] / self.merge_xdot).astype(np.int64)
        # one child per merge cell: the first with the least risk (goals are all kept)
        order = np.lexsort((np.arange(idx.size), risk, kv, kx, goal[idx]))
        ks, vs, gs = kx[order], kv[order], goal[idx][order]
        first = np.r_[True, (ks[1:] != ks[:-1]) | (vs[1:] != vs[:-1]) | gs[1:]]
        chosen = np.sort(order[first])
        i = idx[chosen]
        rows = zip((i // n).tolist(), self.grid[i % n].tolist(), r.touchdown_x[i].tolist(), r.next_x[i].tolist(),
                   r.next_z[i].tolist(), r.next_xdot[i].tolist(), risk[chosen].tolist(), goal[i].tolist(),
                   kx[chosen].tolist(), kv[chosen].tolist())
        for b, angle, foothold, x, z, xdot, rk, is_goal, key_x, key_v in rows:
            if is_goal:
                node = self._add(batch[b], angle, foothold, (x, z, xdot), rk)
                heapq.heappush(self.goals, (self.risk_cost * rk - x, node))
                continue
            held = self.seen.get((key_x, key_v))
            if held is not None and (self.risk[held] <= rk or self.expanded[held]):
                continue
            node = self._add(batch[b], angle, foothold, (x, z, xdot), rk)
            self.seen[(key_x, key_v)] = node
            heapq.heappush(self.queue, (self.risk_cost * rk - x, node))

    def path(self, node: int) -> list[int]:
        """Nodes from the first hop's child to ``node``."""
        out = []
        while node > 0:
            out, node = [node, *out], self.parent[node]
        return out

    def witness(self, node: int) -> dict:
        p = self.path(node)
        return {"leg_angles": [self.angle[i] for i in p], "footholds": [self.foothold[i] for i in p],
                "apexes": [list(self.apex[i]) for i in p]}

    def ban(self, node: int) -> None:   # drop the node and its subtree (Drake rejected its hop)
        self.banned.add(node)

    def replan(self, apex: ApexState, deadline: float) -> dict | None:
        """A fresh witness on the fast map from ``apex`` (a Drake execution's drifted apex) at this pass's
        resolution, or None."""
        search = _Pass(apex, self.terrain, self.goal_x, self.params, self.res, self.min_speed, self.alive)
        node, _ = search.next_goal(REPLAN_NODES, deadline)
        return None if node is None else search.witness(node)


# many parameters: a public entry point's keyword options (grid, budget, floor speed, checks), each with a default
def model_check(apex, terrain: Terrain, goal_x: float, params: SlipParams | None = None, levels=LEVELS,
                budget: Budget = DEFAULT_BUDGET, min_speed: float | None = None, drake_check: bool = True,
                max_witnesses: int = MAX_WITNESSES, energy: bool = True, confirm: bool = False,
                parallel: bool = False) -> dict:
    """The verdict for one start: {"verdict", "statement", "holds_at", "proof", "why", "witness", "nodes",
    "pruned", "time_s", "hops", "passes", "drake"} (module docstring).

    ``energy``: settle the case by the energy argument first where it can, and drop the apexes it shows dead.
    ``levels`` are tried in order, each later one only if the one before exhausted its graph. The case is not
    traversable at the finest level that exhausted if the next ran out of budget without a witness (or, with
    ``confirm``, only if every level exhausted; ``holds_at`` says which). ``budget`` bounds the node expansions and
    the seconds of all passes together (Drake executions use up the seconds too, but one is never cut short;
    replans inside them do not count as nodes). ``drake_check=False`` accepts the first witness on the fast
    step map alone (diagnosis only). ``parallel`` spreads each batch of hops over all cores (the same results)."""
    params = params or SlipParams()
    min_speed = units_of(params).speed_or(min_speed, MIN_SPEED)
    apex = ApexState(*map(float, apex)).validate()
    _check_question(apex, goal_x, levels, budget, min_speed)
    step_batch(apex, [0.0], terrain, params)  # checks the apex is above the terrain; compiles the kernel once
    t0 = time.perf_counter()
    deadline = t0 + budget.max_time_s
    result = {"verdict": UNKNOWN, "statement": "", "holds_at": None, "proof": None, "why": None,
              "witness": None, "nodes": 0, "pruned": 0, "time_s": 0.0, "hops": 0, "passes": [], "drake": []}
    if apex.x >= goal_x:
        result.update(verdict=TRAVERSABLE, witness={"leg_angles": [], "footholds": [], "apexes": []},
                      statement="the start is at or past the goal")
        return result
    alive, graph = None, cell_graph(apex, terrain, goal_x, params) if energy else None   # None: too large
    if graph is not None:
        proof = prove_unreachable(apex, terrain, goal_x, params, graph=graph)
        if proof is not None:
            result.update(verdict=PROVED_NOT_TRAVERSABLE, proof=proof, statement="proved: " + proof["statement"],
                          time_s=time.perf_counter() - t0)
            return result
        alive = Coreach(graph).alive
    for res in levels:
        t_pass, tried = time.perf_counter(), len(result["drake"])
        search = _Pass(apex, terrain, goal_x, params, res, min_speed, alive, parallel)
        stop = _search_pass(search, result, budget.max_nodes, deadline, drake_check, max_witnesses)
        if stop == "exhausted" and search.banned:
            stop = "pruned"   # a graph pruned by rejected witnesses proves nothing when it exhausts
        result["nodes"] += search.nodes
        result["pruned"] += search.pruned
        result["passes"].append({**asdict(res), "stop": "goal" if result["verdict"] == TRAVERSABLE else stop,
                                 "nodes": search.nodes, "states": len(search.seen),
                                 "witnesses": len(result["drake"]) - tried, "time_s": time.perf_counter() - t_pass})
        if result["verdict"] == TRAVERSABLE or stop != "exhausted":
            break
    _conclude(result, min_speed, confirm, drake_check)
    result["time_s"] = time.perf_counter() - t0
    return result


def _check_question(apex: ApexState, goal_x: float, levels, budget: Budget, min_speed: float) -> None:
    """ValueError (TypeError for the budget) naming the first bad argument of ``model_check``."""
    if not isinstance(budget, Budget):
        raise TypeError(f"budget must be a planners.base.Budget, got {type(budget).__name__}")
    if not levels or not all(isinstance(r, Resolution) for r in levels):
        raise ValueError(f"levels must be a non-empty sequence of Resolution, got {levels!r}")
    if not (math.isfinite(goal_x) and math.isfinite(min_speed) and min_speed > 0):
        raise ValueError(f"goal_x must be finite and min_speed positive, got {goal_x!r}, {min_speed!r}")
    if apex.xdot <= 0:
        raise ValueError(f"apex xdot={apex.xdot} must be positive: the hopper moves forward")


def _search_pass(search: _Pass, result: dict, max_nodes: int, deadline: float, drake_check: bool,
                 max_witnesses: int) -> str | None:
    """Run ``search`` until one of its witnesses is accepted (``result``'s verdict and witness set; returns None)
    or it stops (returns why); each witness executed on Drake is logged in ``result["drake"]``, and one Drake
    rejects is banned with the subtree where it went wrong."""
    while True:
        node, stop = search.next_goal(max_nodes - result["nodes"], deadline)
        if node is None:
            return stop
        witness = search.witness(node)
        if not drake_check:
            result.update(verdict=TRAVERSABLE, witness=witness)
            return stop
        run = execute_on_drake(search.start, witness, lambda a: search.replan(a, deadline), search.goal_x,
                               search.terrain, search.params)
        result["drake"].append({k: run[k] for k in ("ok", "replans", "hops_done", "failure", "final_x",
                                                    "drift_hop")})
        if run["ok"]:
            result.update(verdict=TRAVERSABLE, witness={k: run[k] for k in ("leg_angles", "footholds", "apexes")})
            return stop
        # Drake disagrees (a near-tie the two integrators resolve differently, or a drift with no way on):
        # drop the witness's apex where it drifted, or else its hop that failed, with the subtree.
        path = search.path(node)
        bad = run["drift_hop"] - 1 if run["drift_hop"] else min(run["hops_done"], len(path) - 1)
        search.ban(path[bad])
        if len(result["drake"]) >= max_witnesses:
            return "witnesses"


def _conclude(result: dict, min_speed: float, confirm: bool, drake_check: bool) -> None:
    """The verdict of ``result`` from its passes (not traversable at the finest exhausted grid, or why unknown),
    its witness's hops and its statement, set in place."""
    last, done = result["passes"][-1], [p for p in result["passes"] if p["stop"] == "exhausted"]
    if result["verdict"] == UNKNOWN and done and (last["stop"] == "exhausted" or (
            not confirm and last["stop"] in ("time", "nodes") and not last["witnesses"])):
        holds = [{k: p[k] for k in ("angle_deg", "merge_x", "merge_xdot")} for p in done]
        result.update(verdict=NOT_TRAVERSABLE, holds_at={**holds[-1], "min_speed": min_speed, "coarser": holds[:-1]})
        if last["stop"] != "exhausted":   # a finer pass ran out before it could confirm
            result["holds_at"]["unconfirmed"] = {k: last[k] for k in ("angle_deg", "stop", "nodes")}
    if result["witness"] is not None:
        result["hops"] = len(result["witness"]["leg_angles"])
    if result["verdict"] == UNKNOWN:
        result["why"] = last["stop"]
    result["statement"] = _statement(result, drake_check)


def resolution_text(holds_at: dict) -> str:
    """'0.5 deg / 1 cm x 1 cm/s, then 0.25 deg / 0.5 cm x 1 cm/s (apexes >= 0.1 m/s)' for a ``holds_at``."""
    passes = [*holds_at.get("coarser", []), holds_at]
    return ", then ".join(f"{r['angle_deg']:g} deg / {100 * r['merge_x']:g} cm x {100 * r['merge_xdot']:g} cm/s"
                          for r in passes) + f" (apexes >= {holds_at['min_speed']:g} m/s)"


def _statement(r: dict, drake_check: bool) -> str:
    """One line: what the verdict rests on."""
    passes = r["passes"]
    if r["verdict"] == TRAVERSABLE:
        where = "executed on Drake" if drake_check else "on the fast step map only (not checked on Drake)"
        return f"a {r['hops']}-hop witness on the {passes[-1]['angle_deg']:g} deg grid, {where}"
    if r["verdict"] == NOT_TRAVERSABLE:
        late = r["holds_at"].get("unconfirmed")
        return (f"no plan over the leg-angle grid(s) {resolution_text(r['holds_at'])}: the reachable apexes were "
                f"exhausted on the fast step map" + (f"; the {late['angle_deg']:g} deg pass ran out of {late['stop']}"
                                                     f" after {late['nodes']} nodes" if late else ""))
    last, done = passes[-1], ", ".join(f"{p['angle_deg']:g} deg" for p in passes if p["stop"] == "exhausted")
    why = {"witnesses": f"Drake rejected {len(r['drake'])} of its witnesses",
           "pruned": "exhausted only after Drake-rejected witnesses pruned it"}.get(r["why"], f"ran out of {r['why']}")
    return (f"the {last['angle_deg']:g} deg pass {why} after {last['nodes']} nodes"
            + (f"; no plan at {done} (exhausted)" if done else ""))
