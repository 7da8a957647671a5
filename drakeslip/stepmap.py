"""The apex-to-apex step map f(a, t, theta) with two backends: ``"fast"`` (compiled) and ``"drake"``."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip.params import SlipParams
from drakeslip.state import ApexState, FailureMode, StepResult, check_apex, check_leg_angle
from drakeslip.terrain import Terrain

STEP_MAP_BACKENDS = ("fast", "drake")


def step(apex, leg_angle: float, terrain: Terrain, params: SlipParams | None = None, backend: str = "fast",
         **backend_options) -> StepResult:
    """One hop from ``apex`` with the leg commanded to ``leg_angle``: flight, touchdown, stance, liftoff and
    flight to the next apex, stopping at the first failure."""
    params = params or SlipParams()
    apex = check_apex(apex, terrain, params)
    leg_angle = check_leg_angle(leg_angle)
    if backend == "fast":
        return step_batch(apex, [leg_angle], terrain, params, **backend_options).result(0)
    if backend == "drake":
        from drakeslip.simulation import drake_step

        return drake_step(apex, leg_angle, terrain, params, **backend_options)
    raise ValueError(f"unknown backend {backend!r}; choose one of {STEP_MAP_BACKENDS}")


@dataclass(frozen=True)
class BatchStepResult:
    """Column arrays for a batch of steps (see StepResult): ``failure`` holds FailureMode codes, 0 = ok;
    ``next_x/next_z/next_xdot`` are the next apex where ok, else the state at the failure."""

    failure: np.ndarray
    touchdown_x: np.ndarray
    next_x: np.ndarray
    next_z: np.ndarray
    next_xdot: np.ndarray
    end_zdot: np.ndarray
    time: np.ndarray
    work: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        return self.failure == 0

    def __len__(self):
        return self.failure.size

    def result(self, i: int) -> StepResult:
        ok = bool(self.failure[i] == 0)
        end = (float(self.next_x[i]), float(self.next_z[i]), float(self.next_xdot[i]), float(self.end_zdot[i]))
        return StepResult(ok=ok, failure=FailureMode.from_code(int(self.failure[i])),
                          touchdown_x=float(self.touchdown_x[i]),
                          next_apex=ApexState(*end[:3]) if ok else None,
                          time=float(self.time[i]), end_state=end, work=int(self.work[i]))


def step_batch(apex, leg_angles, terrain: Terrain, params: SlipParams | None = None,
               stance_steps: int | None = None, parallel: bool = False) -> BatchStepResult:
    """Fast backend, batched: all ``leg_angles`` from one apex, or, if ``apex`` is an (N, 3) array, one
    leg angle per apex row. This is the planners' inner loop. ``stance_steps``: RK4 steps per half natural
    period of stance (default ``fast_step.STANCE_STEPS``)."""
    from drakeslip import fast_step as fs  # compiled on first use, so importing the step map stays light

    params = params or SlipParams()
    angles = leg_angle_array(leg_angles)
    apexes = np.asarray(apex, dtype=np.float64)
    if apexes.ndim == 1:
        check_apex(apexes, terrain, params)
        apexes = np.broadcast_to(apexes, (angles.size, 3))
    else:
        apexes = apex_rows(apexes, angles.size)
    stance_steps = fs.STANCE_STEPS if stance_steps is None else stance_steps
    if int(stance_steps) < 4:
        raise ValueError(f"stance_steps must be at least 4, got {stance_steps}")
    kernel = fs.step_many_parallel if parallel else fs.step_many
    # fresh writable columns whatever the caller passed (a read-only or broadcast apex would compile the kernel again)
    return batch_result(kernel(np.array(apexes[:, 0]), np.array(apexes[:, 1]), np.array(apexes[:, 2]), angles,
                               params.as_array(), terrain.ground(), int(stance_steps)))


def leg_angle_array(leg_angles) -> np.ndarray:
    """``leg_angles`` as a contiguous float array, if every one is finite and inside (-pi/2, pi/2); else ValueError
    naming the first that is not."""
    angles = np.array(leg_angles, dtype=np.float64).reshape(-1)   # a writable copy: see step_batch
    bad = angles[~(np.isfinite(angles) & (np.abs(angles) < math.pi / 2))]
    if bad.size:
        raise ValueError(f"leg angles must be finite and within (-pi/2, pi/2), got {float(bad[0])!r}")
    return angles


def apex_rows(apexes: np.ndarray, n: int) -> np.ndarray:
    """``apexes`` if it holds ``n`` finite (x, z, xdot) rows; else ValueError naming its shape."""
    if apexes.shape != (n, 3):
        raise ValueError(f"apex must be one (x, z, xdot) or an array of shape ({n}, 3), got shape {apexes.shape}")
    if not np.all(np.isfinite(apexes)):
        raise ValueError("apex array contains non-finite values")
    return apexes


def batch_result(out: np.ndarray) -> BatchStepResult:
    """The compiled kernels' (N, N_OUT) output as columns."""
    from drakeslip import fast_step as fs

    return BatchStepResult(failure=out[:, fs.OUT_CODE].astype(np.int64), touchdown_x=out[:, fs.OUT_TD_X],
                           next_x=out[:, fs.OUT_X], next_z=out[:, fs.OUT_Z], next_xdot=out[:, fs.OUT_XDOT],
                           end_zdot=out[:, fs.OUT_ZDOT], time=out[:, fs.OUT_TIME],
                           work=out[:, fs.OUT_WORK].astype(np.int64))
