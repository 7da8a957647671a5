"""The spatial apex-to-apex step map f(a, pitch, roll) with two backends: ``"fast"`` (compiled) and ``"drake"``."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip.params import SlipParams
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.state import ApexState3D, StepResult3D, check_apex3d
from drakeslip.state import FailureMode

STEP_MAP_BACKENDS = ("fast", "drake")


def check_leg_angles(angles) -> np.ndarray:
    """``angles`` as an (n, 2) float array of (pitch, roll), each finite and inside (-pi/2, pi/2); else ValueError."""
    a = np.array(angles, dtype=np.float64)
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"leg angles must be (pitch, roll) pairs, got shape {np.shape(angles)}")
    bad = a[~(np.isfinite(a) & (np.abs(a) < math.pi / 2))]
    if bad.size:
        raise ValueError(f"leg angles must be finite and within (-pi/2, pi/2), got {float(bad[0])!r}")
    return a


@dataclass(frozen=True)
class BatchStepResult3D:
    """The compiled kernel's output, (n, N_OUT) rows (``drakeslip.spatial.fast_step``), as columns."""

    out: np.ndarray

    @property
    def failure(self) -> np.ndarray:
        return self.out[:, 0].astype(np.int64)

    @property
    def ok(self) -> np.ndarray:
        return self.failure == 0

    @property
    def foothold(self) -> np.ndarray:
        return self.out[:, 1:4]

    @property
    def end_state(self) -> np.ndarray:
        """(x, y, z, xdot, ydot, zdot): the next apex where ok, else the state at the failure."""
        return self.out[:, 4:10]

    def __len__(self):
        return self.out.shape[0]

    def result(self, i: int) -> StepResult3D:
        row = self.out[i]
        ok = bool(row[0] == 0)
        end = tuple(float(v) for v in row[4:10])
        return StepResult3D(ok=ok, failure=FailureMode.from_code(int(row[0])), foothold=tuple(map(float, row[1:4])),
                            next_apex=apex_of(end) if ok else None, time=float(row[10]), end_state=end,
                            work=int(row[11]))


def apex_of(end_state) -> ApexState3D:
    return ApexState3D(*end_state[:5])


def step3d(apex, leg_angles, height_map: HeightMap, params: SlipParams | None = None, backend: str = "fast",
           **backend_options) -> StepResult3D:
    """One hop from ``apex`` (x, y, z, xdot, ydot) with the leg at ``leg_angles`` (pitch, roll)."""
    params = params or SlipParams()
    apex = check_apex3d(apex, height_map, params)
    angles = check_leg_angles(leg_angles)
    if angles.shape[0] != 1:
        raise ValueError(f"step3d takes one (pitch, roll), got {angles.shape[0]}")
    if backend == "fast":
        return step_batch3d(apex, angles, height_map, params, **backend_options).result(0)
    if backend == "drake":
        from drakeslip.spatial.simulation import drake_step3d

        return drake_step3d(apex, angles[0], height_map, params, **backend_options)
    raise ValueError(f"unknown backend {backend!r}; choose one of {STEP_MAP_BACKENDS}")


def step_batch3d(apex, leg_angles, height_map: HeightMap, params: SlipParams | None = None,
                 stance_steps: int | None = None) -> BatchStepResult3D:
    """The compiled backend, batched: every (pitch, roll) of ``leg_angles`` from one apex, or, if ``apex`` is an
    (n, 5) array, one pair per apex row."""
    from drakeslip import fast_step
    from drakeslip.spatial import fast_step as fs3

    params = params or SlipParams()
    angles = check_leg_angles(leg_angles)
    apexes = np.array(apex, dtype=np.float64)
    if apexes.ndim == 1:
        check_apex3d(apexes, height_map, params)
        apexes = np.ascontiguousarray(np.broadcast_to(apexes, (angles.shape[0], 5)))
    elif apexes.shape != (angles.shape[0], 5) or not np.all(np.isfinite(apexes)):
        raise ValueError(f"apex must be one (x, y, z, xdot, ydot) or {angles.shape[0]} finite rows of them, got an "
                         f"array of shape {apexes.shape}")
    stance_steps = fast_step.STANCE_STEPS if stance_steps is None else stance_steps
    if int(stance_steps) < 4:
        raise ValueError(f"stance_steps must be at least 4, got {stance_steps}")
    return BatchStepResult3D(fs3.step_many(apexes, angles, params.as_array(), height_map.ground(),
                                           np.int64(stance_steps)))
