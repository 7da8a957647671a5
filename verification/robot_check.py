"""A plan checked on the multibody robot: certified when the robot, aiming at the plan's footholds from its start
apex (``drakeslip.rollout``'s multibody backend), completes every hop with no failure, touches down within the
tolerance of every planned foothold, reaches every predicted apex within it (x and z in m, xdot in m/s) and the
plan's target; otherwise the first place the robot left the plan is the counterexample."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drakeslip.rollout import rollout


@dataclass
class RobotCheck:
    """``ok`` (certified) or the counterexample: ``kind`` (failure, foothold, apex, target), ``hop``, ``planned``
    and ``actual`` values, ``what`` happened on the robot; ``largest_error`` (foothold, apex) over the hops
    checked and ``max_pitch`` [rad]; ``log`` the robot's HopLog (its trajectory)."""

    ok: bool
    tolerance: float
    kind: str | None = None
    hop: int = -1
    planned: object = None
    actual: object = None
    what: str = ""
    largest_error: tuple = (0.0, 0.0)
    max_pitch: float = 0.0
    log: object = None

    def format(self) -> str:
        head = (f"CERTIFIED on the multibody robot (tolerance {self.tolerance:g})" if self.ok else
                f"COUNTEREXAMPLE on the multibody robot: hop {self.hop}, {self.kind}: planned {self.planned}, "
                f"actual {self.actual}{f' ({self.what})' if self.what else ''}")
        return (f"{head}\nlargest foothold error {self.largest_error[0]:.4f} m, apex error "
                f"{self.largest_error[1]:.4f}; largest body pitch {self.max_pitch:.3f} rad")

    def to_dict(self) -> dict:
        return {"backend": "multibody", "certified": self.ok, "tolerance": self.tolerance, "kind": self.kind,
                "hop": self.hop, "planned": self.planned, "actual": self.actual, "what": self.what,
                "largest_error": list(self.largest_error), "max_pitch": self.max_pitch}


def check_plan_on_robot(record, tolerance: float) -> RobotCheck:
    """Run ``record`` (a ``PlanRecord``) on the robot built around its hopper and certify it or not."""
    from drakeslip.controller import StepLengthController

    run = rollout(record.apex, record.terrain, record.params, footholds=[float(x) for x in record.footholds],
                  controller=StepLengthController.load_default(), backend="multibody", log=True)
    log = run.simulation
    worst_foot = worst_apex = 0.0
    base = {"tolerance": tolerance, "log": log, "max_pitch": log.max_pitch}

    def counterexample(kind, k, planned, actual, what=""):
        return RobotCheck(False, kind=kind, hop=k, planned=planned, actual=actual, what=what,
                          largest_error=(worst_foot, worst_apex), **base)

    for k in range(len(record.footholds)):
        if k < len(run.footholds):
            error = abs(run.footholds[k] - float(record.footholds[k]))
            worst_foot = max(worst_foot, error)
            if error > tolerance:
                return counterexample("foothold", k, float(record.footholds[k]), run.footholds[k])
        if run.failure is not None and k == run.failed_hop:
            return counterexample("failure", k, None, run.failure.name, log.failure.what)
        predicted = np.asarray(record.apexes[k], dtype=float)
        if k < len(run.apexes) and np.all(np.isfinite(predicted)):
            error = float(np.max(np.abs(np.subtract(run.apexes[k], predicted))))
            worst_apex = max(worst_apex, error)
            if error > tolerance:
                return counterexample("apex", k, tuple(map(float, predicted)), tuple(map(float, run.apexes[k])))
    if run.failure is not None:
        return counterexample("failure", run.failed_hop, None, run.failure.name, log.failure.what)
    if run.footholds[-1] < record.target_x - tolerance:
        return counterexample("target", len(run.footholds) - 1, record.target_x, run.footholds[-1])
    return RobotCheck(True, largest_error=(worst_foot, worst_apex), **base)
