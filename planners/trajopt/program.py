"""The N-hop program in Drake's ``MathematicalProgram`` (``SlipTrajopt``): its variables, constraints and cost,
and a solve of it by SNOPT (IPOPT when SNOPT is unavailable, or asked for) from a guess.

Transcription (hop i = 0..N-1; apex 0 is the given start):

* decision variables: the leg angle theta_i, the fall time tf_i from apex i to touchdown, the foothold f_i, the
  stance duration T_i, the stance states S_i[k] = (x, z, xdot, zdot) on K+1 knots, and apex i+1 = (x, z, xdot);
* flight is analytic: touchdown S_i[0] = (x_a + v tf, z_a - g tf^2 / 2, v, -g tf) from apex a_i = (x_a, z_a, v);
  the foot of the leg held at theta_i (``dynamics.foot_position``) is then at (f_i, h_i), h_i the segment's
  height; apex i+1 is the top of the parabola from the liftoff state S_i[K];
* stance is direct collocation of ``dynamics.stance_derivatives`` with the foot pinned at (f_i, h_i)
  (``collocation.py``). Liftoff is the leg back at rest length (``dynamics.stance_leg_length``); at touchdown the leg
  must be compressing (``dynamics.leg_rate`` < 0);
* along stance, at the knots: the leg stays ``stroke_margin`` above ``min_leg_length`` (no bottom-out) and no
  longer than rest length before liftoff, inside ``friction_fraction`` of the friction cone, and the body moves
  forward; liftoff is upward;
* clearance (a Python constraint, since which cells lie under a point depends on where it is): the body on the
  stance knots and on the flight parabolas, sampled at ``flight_samples`` intervals per ascent and per descent,
  stays ``clearance`` above the highest cell under each interval (the terrain is piecewise constant, and a
  parabola's lowest point over an interval is an end); the extended foot, falling with the body from its apex
  position, stays ``clearance`` above every cell before its segment (checked where it enters the segment,
  where it is lowest over them) and above the cell under it at apex (no trip);
* footholds stay ``edge_margin`` inside their segment; apex speeds lie in [min_speed, max_speed]; the last apex
  lies ``target_margin`` past the plan's target (the hopper gets past it, with room for the open-loop drift);
* with positive margin weights, the margin variables and their bounds at every knot (``margins.py``).

The collocation defects and the clearance are Python constraints evaluated on dual numbers (``autodiff.py``);
the simple algebraic constraints are symbolic expressions that Drake evaluates in C++. The cost is the one
``config.py`` documents. Major iterations are read from the solver's print file.
"""
from __future__ import annotations

import gc
import math
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass

import numpy as np

from drakeslip import SlipParams, Terrain
from drakeslip import dynamics as dyn
from drakeslip.state import as_apex
from drakeslip.units import units_of
from planners.trajopt.autodiff import Dual, dual_constraint, generic
from planners.trajopt.collocation import defect_sparsity, interior_leg_lengths, stance_defects
from planners.trajopt.config import ANGLE_SCALE, EDGE_SCALE, SPEED_SCALE, TrajoptConfig, TrajoptError
from planners.trajopt.guess import Guess
from planners.trajopt.margins import add_margins, knot_margins
from planners.trajopt.segments import Segment, max_height, max_heights


@dataclass
class TrajoptResult:
    """One solve: the solver's verdict and cost, the optimized leg angles, footholds, apexes and stance
    durations, and the largest violation of each constraint group at the solver's last point."""

    converged: bool
    solver: str
    status: str
    iterations: int | None
    solve_time_s: float
    build_time_s: float
    cost: float
    leg_angles: np.ndarray
    footholds: np.ndarray
    apexes: np.ndarray
    durations: np.ndarray
    max_violation: float
    violations: dict
    x: np.ndarray | None = None   # the solver's last point, every decision variable

    def summary(self) -> dict:
        return {"converged": self.converged, "solver": self.solver, "status": self.status,
                "iterations": self.iterations, "solve_time_s": self.solve_time_s,
                "build_time_s": self.build_time_s, "cost": self.cost, "max_violation": self.max_violation,
                "violations": self.violations,
                "leg_angles": self.leg_angles.tolist(), "footholds": self.footholds.tolist(),
                "apexes": self.apexes.tolist()}


def _add_expressions(prog, exprs, lb, ub):
    """lb <= exprs <= ub for a vector of symbolic expressions, as one ExpressionConstraint (Drake evaluates it
    and its symbolic gradient in C++)."""
    from pydrake.solvers import ExpressionConstraint
    from pydrake.symbolic import Expression

    exprs = np.array([e if isinstance(e, Expression) else Expression(e) for e in np.ravel(np.array(exprs, object))])
    m = exprs.size
    c = ExpressionConstraint(exprs, np.broadcast_to(np.asarray(lb, float), (m,)).copy(),
                             np.broadcast_to(np.asarray(ub, float), (m,)).copy())
    return prog.AddConstraint(c, c.vars())


class SlipTrajopt:
    """The N-hop program for a start apex, the segments the N footholds must land on, and a target the last
    one must pass. ``prog`` is the MathematicalProgram; ``groups`` maps constraint names to their bindings."""

    def __init__(self, apex, terrain: Terrain, segs: list[Segment], params: SlipParams | None = None,
                 target_x: float = -math.inf, config: TrajoptConfig | None = None):
        from pydrake.solvers import MathematicalProgram

        t0 = time.perf_counter()
        self.apex0 = as_apex(apex)
        self.terrain = terrain
        self.segs = list(segs)
        self.params = params = params or SlipParams()
        self.units = units = units_of(params)
        self.config = cfg = (config or TrajoptConfig()).for_hopper(units)
        self.target_x = float(target_x)
        if not self.segs:
            raise TrajoptError("no footholds to optimize")
        for i, s in enumerate(self.segs):
            if s.ditch:
                raise TrajoptError(f"foothold {i} is assigned to a ditch segment [{s.lo:.2f}, {s.hi:.2f})")
        N, K = len(self.segs), cfg.knots
        self.N, self.K = N, K
        prog = self.prog = MathematicalProgram()
        self.theta = prog.NewContinuousVariables(N, "theta")
        self.tf = prog.NewContinuousVariables(N, "tf")
        self.foot = prog.NewContinuousVariables(N, "f")
        self.dur = prog.NewContinuousVariables(N, "T")
        self.S = [prog.NewContinuousVariables(K + 1, 4, f"s{i}") for i in range(N)]
        self.A = prog.NewContinuousVariables(N, 3, "apex")  # the apex after hop i
        self.groups: dict = {}
        for i, seg in enumerate(self.segs):
            self._add_touchdown(i, seg)
            self._add_stance(i, seg)
            self._add_liftoff(i, seg)
        if math.isfinite(self.target_x):  # the hopper passes the target: the last apex lies beyond it
            self._add("target", prog.AddBoundingBoxConstraint(self.target_x + cfg.target_margin, np.inf,
                                                              self.A[N - 1, 0]))
        for k in range(N + 1):
            variables, fn, m = self._clearance(k)
            self._add("clearance", prog.AddConstraint(fn, np.full(m, cfg.clearance), np.full(m, np.inf), variables))
        self._add_costs()
        self.margins = add_margins(self)
        self.build_time_s = time.perf_counter() - t0

    def _add(self, group: str, binding) -> None:
        self.groups.setdefault(group, []).append(binding)

    # -- hop i: flight to touchdown, stance, liftoff and flight to the next apex ----------------------------------
    def _add_touchdown(self, i: int, seg: Segment) -> None:
        """Hop i's bounds, and its touchdown: the body falls from apex i for tf; the foot of the leg held at theta
        reaches (f, h) on its segment, its leg compressing."""
        prog, cfg, params, units = self.prog, self.config, self.params, self.units
        g, h = params.gravity, seg.height
        limit = 0.97 * math.atan(params.friction)
        half = math.pi / params.natural_frequency
        ax, az, av = self.apex_before(i)
        S, th, tf, f, T = self.S[i], self.theta[i], self.tf[i], self.foot[i], self.dur[i]
        prog.AddBoundingBoxConstraint(-limit, limit, th)
        prog.AddBoundingBoxConstraint(0.01 * units.time, 2.0 * units.time, tf)
        prog.AddBoundingBoxConstraint(0.3 * half, 3.0 * half, T)
        self._add("foothold_segment", prog.AddBoundingBoxConstraint(seg.lo + cfg.edge_margin,
                                                                    seg.hi - cfg.edge_margin, f))
        td = [ax + av * tf, az - 0.5 * g * tf * tf, av, -g * tf]
        self._add("touchdown", _add_expressions(prog, [S[0, j] - td[j] for j in range(4)], 0, 0))
        fx, fz = generic(dyn.foot_position)(S[0, 0], S[0, 1], th, params.as_array())
        self._add("foot_on_terrain", _add_expressions(prog, [fx - f, fz - h], 0, 0))
        leg_rate = generic(dyn.leg_rate)
        self._add("leg_loads", _add_expressions(prog, leg_rate(S[0, 0], S[0, 1], S[0, 2], S[0, 3], f, h), -np.inf,
                                                -1e-3 * units.speed))

    def _add_stance(self, i: int, seg: Segment) -> None:
        """Hop i's stance: collocation of the shared stance equations; along it no bottom-out, no longer than rest
        length before liftoff (interior knots), inside the friction cone, and moving forward (a STALL otherwise)."""
        prog, cfg, params, K = self.prog, self.config, self.params, self.K
        S, f, T, h = self.S[i], self.foot[i], self.dur[i], seg.height
        variables = np.concatenate([S.reshape(-1), [f, T]])
        defects = dual_constraint(stance_defects(cfg.collocation, K, params, h), 4 * K)
        binding = prog.AddConstraint(defects, np.zeros(4 * K), np.zeros(4 * K), variables)
        binding.evaluator().SetGradientSparsityPattern(defect_sparsity(cfg.collocation, K))
        self._add("dynamics", binding)
        inner = np.concatenate([S[1:K, :2].reshape(-1), [f]])
        binding = prog.AddConstraint(dual_constraint(interior_leg_lengths(K, h), K - 1),
                                     np.full(K - 1, params.min_leg_length + cfg.stroke_margin),
                                     np.full(K - 1, params.leg_length), inner)
        binding.evaluator().SetGradientSparsityPattern(
            [(k, c) for k in range(K - 1) for c in (2 * k, 2 * k + 1, 2 * (K - 1))])
        self._add("leg_length", binding)
        # the friction cone, mu' (z - h) >= |x - f| (linear: the foot height is known)
        mu_c = cfg.friction_fraction * params.friction
        rows = np.zeros((2 * (K + 1), 2 * (K + 1) + 1))
        for k in range(K + 1):
            for r, sign in ((2 * k, 1.0), (2 * k + 1, -1.0)):
                rows[r, k], rows[r, K + 1 + k], rows[r, -1] = -sign, mu_c, sign
        self._add("friction", prog.AddLinearConstraint(rows, np.full(2 * (K + 1), mu_c * h),
                                                       np.full(2 * (K + 1), np.inf),
                                                       np.concatenate([S[:, 0], S[:, 1], [f]])))
        prog.AddBoundingBoxConstraint(cfg.min_stance_speed, np.inf, S[:, 2])

    def _add_liftoff(self, i: int, seg: Segment) -> None:
        """Hop i's liftoff, the leg back at rest length and leaving the ground upward, and its flight to the next
        apex, in closed form."""
        prog, cfg, params = self.prog, self.config, self.params
        L0, g, f, h = params.leg_length, params.gravity, self.foot[i], seg.height
        x, z, xd, zd = self.S[i][self.K]
        self._add("liftoff", _add_expressions(prog, generic(dyn.stance_leg_length)(x, z, f, h), L0, L0))
        prog.AddBoundingBoxConstraint(0.05 * self.units.speed, np.inf, zd)  # upward: an apex follows
        A = self.A[i]
        self._add("apex", _add_expressions(prog, [A[0] - (x + xd * zd / g), A[1] - (z + zd * zd / (2 * g)),
                                                  A[2] - xd], 0, 0))
        prog.AddBoundingBoxConstraint(cfg.min_speed, cfg.max_speed, A[2])

    def apex_before(self, i: int):
        """Apex i (the start for i = 0): constants or decision variables."""
        return tuple(self.apex0) if i == 0 else tuple(self.A[i - 1])

    # -- clearance: a Python constraint, since the terrain under a sample depends on where the sample is --------
    def _clearance(self, k: int):
        """Body clearance over flight k (the ascent after stance k-1, the descent to stance k) and stance k, and
        the extended foot's clearance over the cells before segment k: (variables, function, outputs)."""
        params, terrain = self.params, self.terrain
        g = params.gravity
        N, K, M = self.N, self.K, self.config.flight_samples
        p = params.as_array()
        foot_pos = generic(dyn.foot_position)
        parts = []
        if k > 0:
            parts.append(self.S[k - 1][K])                 # liftoff state of the previous stance
        if 0 < k < N:
            parts.append(self.A[k - 1])                    # apex k
        if k < N:
            parts.append([self.theta[k], self.tf[k]])
            parts.append(self.S[k][:, :2].reshape(-1))     # body (x, z) on the stance knots
        variables = np.concatenate([np.ravel(v) for v in parts])
        seg = self.segs[k] if k < N else None
        n_points = (M + 1 if k > 0 else 0) + (M + 1 + K + 1 if k < N else 0)
        n_out = 2 * (n_points - 1) + (1 if k < N else 0)
        u = np.linspace(0.0, 1.0, M + 1)
        apex0 = tuple(self.apex0)

        def clearance(v):
            xs, zs, at = [], [], 0
            if k > 0:
                x, z, xd, zd = v[0], v[1], v[2], v[3]
                t = zd * (u / g)
                xs.append(x + xd * t)
                zs.append(z + zd * t - 0.5 * g * t * t)
                at = 4
            if k < N:
                if k > 0:
                    ax, az, av = v[at], v[at + 1], v[at + 2]
                    at += 3
                else:
                    ax, az, av = apex0
                theta, tf = v[at], v[at + 1]
                t = tf * u
                xs.append(ax + av * t)
                zs.append(az - 0.5 * g * t * t)
                body = v[at + 2:at + 2 + 2 * (K + 1)]
                xs.append(body[0::2])
                zs.append(body[1::2])
            X, Z = Dual.concat(xs), Dual.concat(zs)
            top = max_heights(terrain, X.val[:-1], X.val[1:])
            out = [Z[:-1] - top, Z[1:] - top]
            if k < N:
                # the extended foot falls with the body from its apex position; over the cells before its
                # segment it must stay above them, and it is lowest over them where it enters the segment
                fx, fz = foot_pos(ax, az, theta, p)
                reach = (seg.lo - fx) / av if math.isfinite(seg.lo) else None
                if reach is not None and reach.val > 0:
                    out.append(fz - 0.5 * g * reach * reach - max_height(terrain, float(fx.val), seg.lo - 1e-9))
                else:
                    out.append(fz - terrain.height_at(float(fx.val)))
            return Dual.concat(out)

        return variables, dual_constraint(clearance, n_out), n_out

    def _add_costs(self):
        w, N, units = self.config.objective, self.N, self.units
        edge_scale, speed_scale = EDGE_SCALE * units.length, SPEED_SCALE * units.speed
        if w.edge:
            for i, seg in enumerate(self.segs):
                for edge in (seg.lo, seg.hi):
                    if math.isfinite(edge):
                        self.prog.AddCost(w.edge * edge_scale ** 2 / ((self.foot[i] - edge) ** 2))
        # (sums built term by term: numpy arithmetic on arrays of symbolic variables trips spurious FP warnings)
        if w.angle and N > 1:
            self.prog.AddQuadraticCost(sum((w.angle / ANGLE_SCALE ** 2) * (self.theta[i + 1] - self.theta[i]) ** 2
                                           for i in range(N - 1)), is_convex=True)
        if w.speed:
            v = [self.apex0.xdot] + list(self.A[:, 2])
            self.prog.AddQuadraticCost(sum((w.speed / speed_scale ** 2) * (v[i + 1] - v[i]) ** 2 for i in range(N)),
                                       is_convex=True)
        if w.progress:
            unit = 1.0 * units.length   # a metre of progress for the paper's hopper
            span = max(self.target_x - self.apex0.x, unit) if math.isfinite(self.target_x) else unit
            self.prog.AddLinearCost(-w.progress * (self.A[N - 1, 0] - self.apex0.x) / span)

    # -- values ----------------------------------------------------------------------------------------------
    def guess_vector(self, guess: Guess) -> np.ndarray:
        """The decision-variable vector holding a Guess."""
        if guess.leg_angles.size != self.N or guess.stance.shape[1] != self.K + 1:
            raise ValueError(f"guess has {guess.leg_angles.size} hops and {guess.stance.shape[1]} knots; the "
                             f"program has {self.N} and {self.K + 1}")
        x = np.zeros(self.prog.num_vars())
        put = lambda var, val: x.__setitem__(self.prog.FindDecisionVariableIndices(np.ravel(var)), np.ravel(val))
        put(self.theta, guess.leg_angles)
        put(self.tf, guess.fall_times)
        put(self.foot, guess.footholds)
        put(self.dur, guess.durations)
        for i in range(self.N):
            put(self.S[i], guess.stance[i])
        put(self.A, guess.apexes[1:])
        for name, var in self.margins.items():  # the guess's own margins (at least 0, their lower bound)
            put(var, max(knot_margins(self, x)[name], 0.0))
        return x

    def violations(self, x: np.ndarray) -> dict:
        """Largest violation of each constraint group at the decision vector x (0 = satisfied)."""
        out = {}
        for name, bindings in self.groups.items():
            worst = 0.0
            for b in bindings:
                val = np.atleast_1d(self.prog.EvalBinding(b, x))
                c = b.evaluator()
                worst = max(worst, float(np.max(np.maximum(c.lower_bound() - val, val - c.upper_bound()))))
            out[name] = max(worst, 0.0)
        return out

    def solve(self, guess: Guess | np.ndarray, print_file=None) -> TrajoptResult:
        """Solve from ``guess`` (or a decision-variable vector, such as a previous result's ``x``);
        ``print_file``: keep the solver's log there."""
        from pydrake.solvers import IpoptSolver, SnoptSolver

        cfg = self.config
        x0 = np.asarray(guess, dtype=np.float64) if isinstance(guess, np.ndarray) else self.guess_vector(guess)
        use_snopt = cfg.solver == "snopt" and SnoptSolver().available() and SnoptSolver().enabled()
        solver = SnoptSolver() if use_snopt else IpoptSolver()
        fd, log = tempfile.mkstemp(prefix="trajopt-", suffix=".log")
        os.close(fd)
        try:
            options = _solver_options(cfg, solver, use_snopt, log)
            collecting = gc.isenabled()
            gc.disable()  # the callbacks make many short-lived arrays; cyclic GC passes only cost time here
            t0 = time.perf_counter()
            try:
                result = solver.Solve(self.prog, x0, options)
            finally:
                solve_time = time.perf_counter() - t0
                if collecting:
                    gc.enable()
            with open(log, errors="replace") as f:
                text = f.read()
        finally:
            if print_file is not None:
                shutil.copy(log, print_file)
            os.unlink(log)
        pattern = r"No\. of major iterations\s+(\d+)" if use_snopt else r"Number of Iterations\.+:\s*(\d+)"
        found = re.findall(pattern, text)
        iterations = int(found[-1]) if found else None
        if use_snopt:
            status = f"SNOPT info {result.get_solver_details().info}"
        else:
            status = f"IPOPT status {result.get_solver_details().status}"
        x = result.GetSolution()
        viol = self.violations(x)
        val = lambda v: result.GetSolution(v)
        apexes = np.vstack([np.array(self.apex0)[None], val(self.A)])
        return TrajoptResult(converged=bool(result.is_success()), solver="snopt" if use_snopt else "ipopt",
                             status=status, iterations=iterations, solve_time_s=solve_time,
                             build_time_s=self.build_time_s, cost=float(result.get_optimal_cost()),
                             leg_angles=val(self.theta), footholds=val(self.foot), apexes=apexes,
                             durations=val(self.dur), max_violation=max(viol.values()), violations=viol, x=x)


def _solver_options(cfg: TrajoptConfig, solver, use_snopt: bool, log: str):
    """The SolverOptions of a solve by ``solver`` (SNOPT when ``use_snopt``, else IPOPT): its log written to
    ``log``, the iteration limit and tolerances of ``cfg``, then ``cfg.solver_options`` as given."""
    from pydrake.solvers import CommonSolverOption, SolverOptions

    options = SolverOptions()
    sid = solver.solver_id()
    if use_snopt:
        options.SetOption(CommonSolverOption.kPrintFileName, log)
        options.SetOption(sid, "Major iterations limit", cfg.major_iterations)
        options.SetOption(sid, "Iterations limit", 100000)
        options.SetOption(sid, "Major optimality tolerance", cfg.optimality_tolerance)
        options.SetOption(sid, "Major feasibility tolerance", cfg.feasibility_tolerance)
    else:
        options.SetOption(sid, "output_file", log)
        options.SetOption(sid, "file_print_level", 3)
        options.SetOption(sid, "print_level", 0)
        options.SetOption(sid, "max_iter", cfg.major_iterations)
        options.SetOption(sid, "tol", cfg.optimality_tolerance)
        options.SetOption(sid, "constr_viol_tol", cfg.feasibility_tolerance)
    for name, value in cfg.solver_options:
        options.SetOption(sid, name, value)
    return options
