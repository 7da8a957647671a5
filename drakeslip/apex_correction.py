"""The learned correction of a template's apex-to-apex map toward the robot it stands for (``ApexCorrection``).

The template fitted to the multibody robot (``drakeslip.multibody.fit``) predicts the robot's next apex from its
apex and foothold alone. The robot carries its last hop into the next one (its body's pitch and its leg's swing are
not in the apex state), so its next apex depends on that hop too: from the hop alone a network predicts the robot no
better than the template; with the hop before it as well, it halves the template's error (docs/multibody.md). The
correction is a small network that adds to the template's next apex what the robot does differently, from

  the hop: its apex height above the foothold, its speed and the foothold's distance ahead of the body;
  the hop before it: the same three, and whether there was one (0 at the start of a run: the three are then the
  hop's own),

in the template's leg lengths and speed unit sqrt(g L0), to the robot's next apex minus the template's (x, z, xdot)
in the same units. Inputs are held inside the range it was trained on, so a hop unlike any the robot flew gets the
correction of the nearest ones it did, not an extrapolation. Two tanh layers; trained by
``drakeslip/multibody/correction_training.py`` (``examples/fit_correction.py``), with some hops shown without the hop
before them, so that it also predicts a hop whose previous hop is not known (a plan's first).

A correction is a weights file (``.npz``: ``ARRAYS``, matrices stored (inputs, outputs), and "held_out": the errors
it still makes on held-out hops, ``HELD_OUT_FIELDS``) read by ``load_correction`` against its SHA-256. A template that
carries one is a ``drakeslip.params.RobotTemplate``, whose parameter array carries the network packed after the
parameters (``ApexCorrection.packed``); ``drakeslip.fast_correction`` is its forward pass in compiled code, which the
planners' compiled searches and robust checks add to each hop of the step map (planners/core/grid.py, particles.py).
A hop's previous hop reaches it as ``before``: (apex height above its foothold, speed, foothold ahead, 1), or zeros
where it is not known.
"""
from __future__ import annotations

import functools
import hashlib
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


N_PARAMS = 6            # a SlipParams array's own length: a correction is packed after it
N_IN, N_OUT = 7, 3
ARRAYS = ("w1", "b1", "w2", "b2", "w3", "b3", "input_low", "input_high", "input_mean", "input_scale",
          "output_scale")
HELD_OUT_FIELDS = ("median_x", "p90_x", "median_z", "p90_z", "median_xdot", "p90_xdot")


def hop_inputs(hops, leg_length: float, gravity: float) -> np.ndarray:
    """(n, N_IN) the correction's inputs, before scaling, for ``hops`` (``fit.Hop``, each with its ``previous``)."""
    def geometry(hop):
        return hop.apex[1] - hop.height, hop.apex[2], hop.foothold - hop.apex[0]

    rows = []
    for hop in hops:
        own = geometry(hop)
        rows.append((*own, *(own if hop.previous is None else geometry(hop.previous)), float(hop.previous is not None)))
    units = np.array([leg_length, math.sqrt(gravity * leg_length), leg_length] * 2 + [1.0])
    return np.array(rows, dtype=np.float64).reshape(-1, N_IN) / units


def output_units(leg_length: float, gravity: float) -> np.ndarray:
    """The outputs' units: (x, z, xdot) of the next apex in metres and m/s per network unit."""
    return np.array([leg_length, leg_length, math.sqrt(gravity * leg_length)])


def correction_of(arrays: dict, inputs: np.ndarray) -> np.ndarray:
    """(n, N_OUT) the correction in output units of the network ``arrays`` (``ARRAYS``) for (n, N_IN) ``inputs``
    (``hop_inputs``)."""
    a = arrays
    u = (np.clip(inputs, a["input_low"], a["input_high"]) - a["input_mean"]) / a["input_scale"]
    h = np.tanh(np.tanh(u @ a["w1"] + a["b1"]) @ a["w2"] + a["b2"])
    return (h @ a["w3"] + a["b3"]) * a["output_scale"]


@dataclass(frozen=True)
class ApexCorrection:
    """The correction in the weights file ``path``, whose bytes have the SHA-256 ``sha256`` (checked when it is
    read, here). Two corrections are the same when their files are; a record of one (``dataclasses.asdict`` of a
    ``RobotTemplate``) is the digest and the path. ``arrays``: the network's (``ARRAYS`` and "held_out")."""

    sha256: str
    path: str = field(compare=False)

    def __post_init__(self):
        object.__setattr__(self, "arrays", read_arrays(str(self.path), self.sha256))

    def packed(self) -> np.ndarray:
        """The network as ``drakeslip.fast_correction`` reads it after a hopper's parameters: the hidden units,
        then every array of ``ARRAYS`` flattened in order."""
        a = self.arrays
        return np.concatenate([[float(a["b1"].shape[0])], *(np.ravel(a[name]) for name in ARRAYS)])


def save_correction(path, arrays: dict) -> str:
    """Write a correction's network ``arrays`` (``ARRAYS`` and "held_out") to ``path`` (.npz) atomically; returns
    the file's SHA-256."""
    from drakeslip.jobs.files import atomic_write

    buffer = io.BytesIO()
    np.savez(buffer, **{name: np.asarray(value, dtype=np.float64) for name, value in arrays.items()})
    data = buffer.getvalue()
    with atomic_write(path) as f:
        f.write(data)
    return hashlib.sha256(data).hexdigest()


def load_correction(path) -> ApexCorrection:
    """The correction in the weights file ``path`` (its digest taken from its bytes)."""
    try:
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as error:
        raise ValueError(f"correction weights {path}: {error.strerror or error}") from None
    return ApexCorrection(digest, str(path))


@functools.lru_cache(maxsize=8)
def read_arrays(path: str, sha256: str) -> dict:
    """The network in the weights file ``path``, its bytes checked against ``sha256``; a missing, altered or
    malformed file raises ValueError naming it."""
    try:
        data = Path(path).read_bytes()
    except OSError as error:
        raise ValueError(f"correction weights {path}: {error.strerror or error}") from None
    digest = hashlib.sha256(data).hexdigest()
    if digest != sha256:
        raise ValueError(f"correction weights {path} are not the file named (sha256 {str(sha256)[:12]}..., the "
                         f"file's {digest[:12]}...): regenerate them with examples/fit_correction.py")
    try:
        with np.load(io.BytesIO(data)) as npz:
            arrays = {name: np.asarray(npz[name], dtype=np.float64) for name in (*ARRAYS, "held_out")}
    except (KeyError, ValueError, OSError) as error:
        raise ValueError(f"correction weights {path}: {error}") from None
    hidden = arrays["b1"].shape[0] if arrays["b1"].ndim == 1 else -1
    shapes = {"w1": (N_IN, hidden), "w2": (hidden, hidden), "b2": (hidden,), "w3": (hidden, N_OUT), "b3": (N_OUT,),
              **{name: (N_IN,) for name in ("input_low", "input_high", "input_mean", "input_scale")},
              "output_scale": (N_OUT,), "held_out": (len(HELD_OUT_FIELDS),)}
    for name, shape in shapes.items():
        if arrays[name].shape != shape or not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"correction weights {path}: {name} must be finite of shape {shape}, "
                             f"got {arrays[name].shape}")
    for array in arrays.values():
        array.setflags(write=False)
    return arrays
