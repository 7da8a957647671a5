"""The low-level step-length controller: a small MLP called once per apex (paper, section V-B).

Given the apex state and a desired foothold it returns the leg angle that lands the foot there. The leg is
held fixed from apex to touchdown and the body falls ballistically, so the touchdown point depends on the
apex only through the forward speed and the height of the body above the *landing* surface. The network
therefore reads

    (xdot, z - h(x_L), x_L - x)      speed, drop to the terrain at the desired foothold, foothold offset

which on flat ground are the paper's inputs (xdot, z, x_L) and also tell it the terrain height at the desired
foothold.

The touchdown depends on the hopper only through L0 and g, and in units of L0 and sqrt(g L0) it is the same function
for every hopper: x_L / L0 = sin(theta) + (xdot / sqrt(g L0)) sqrt(2 (drop / L0 - cos(theta))). So one network
serves every hopper: ``for_params(params)`` is the controller for another hopper, which feeds the network its
speed, drop and offset in the units of the hopper the network was trained for (speed over the speed factor, lengths
over the length factor) and polishes with the hopper's own L0 and g. For the trained hopper the factors are exactly
1.0 and the angles are the trained controller's to the bit.

Inference is compiled (``fast_controller.aim_rows``, from ``arrays()``: numpy's BLAS products and numpy's tanh, called
without a trip back into Python), not torch, whose dispatch costs more than a 3-64-64-64-1 MLP's arithmetic; torch is
needed only to read and write the weights file (training is controller_training.py). The planning core aims its
candidates with the same function.

``refine=True`` (the default) polishes the MLP's angle with Newton steps on the flight phase (compiled, in
``leg_aim.py``), which the fast step map integrates in closed form: the foot lands at
x_L(theta) = x + L0 sin(theta) + xdot sqrt(2 (z - h(x_L) - L0 cos(theta)) / g). That takes the foothold error
from about a millimetre to micrometres with no step-map call (examples/controller_accuracy.py). It matters
for plans made without the controller (Angle-space): a hop planned near the edge of its feasible set
survives only if the executed leg angle is the planned one.
"""
from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from drakeslip.jobs.files import atomic_write, first_line, load_weights, record_digest
from drakeslip.params import SlipParams
from drakeslip.state import ApexState
from drakeslip.terrain import Terrain

DEFAULT_WEIGHTS = Path(__file__).with_name("weights") / "controller.pt"
WEIGHTS_FORMAT = "drakeslip-controller/1"
N_FEATURES = 3


@dataclass(frozen=True)
class ControllerConfig:
    hidden: int = 64
    layers: int = 3           # hidden layers
    max_angle: float = 0.8    # [rad] outputs are clipped to the trained range of leg angles


class StepLengthController:
    """Maps (apex, desired foothold x_L, terrain) to the leg angle that lands the foot at x_L."""

    def __init__(self, weights: dict, config: ControllerConfig, feature_mean, feature_std, params: SlipParams,
                 refine: bool = True):
        """``weights``: the network's parameters by name, ``hidden.K.weight`` (out, in), ``hidden.K.bias`` for each
        hidden layer K and ``head.weight``, ``head.bias`` (a torch state dict, or arrays)."""
        self.config = config
        self.params = params          # the hopper the network was trained for (saved with the weights)
        self.refine = refine
        # the hopper it aims for: its leg length and gravity, and its speed and length over the trained hopper's
        self.leg_length, self.gravity = params.leg_length, params.gravity
        self.feature_scale = None     # None: the trained hopper (features as they are)
        self.views = {(params.leg_length, params.gravity): self}   # (leg length, gravity) -> its controller
        self.feature_mean = np.asarray(feature_mean, dtype=np.float64)
        self.feature_std = np.asarray(feature_std, dtype=np.float64)
        arrays = {k: np.asarray(v, dtype=np.float64) for k, v in weights.items()}
        sizes = [N_FEATURES] + [config.hidden] * config.layers
        expected = {f"hidden.{k}.{part}": shape for k, (a, b) in enumerate(zip(sizes[:-1], sizes[1:]))
                    for part, shape in (("weight", (b, a)), ("bias", (b,)))}
        expected.update({"head.weight": (1, config.hidden), "head.bias": (1,)})
        wrong = {k: s for k, s in expected.items() if k not in arrays or arrays[k].shape != s}
        if wrong or set(arrays) != set(expected):
            raise ValueError(f"controller weights do not fit a {config.layers} x {config.hidden} network: "
                             f"expected {expected}, got { {k: v.shape for k, v in arrays.items()} }")
        self._layers = [(arrays[f"hidden.{k}.weight"].T.copy(), arrays[f"hidden.{k}.bias"].copy())
                        for k in range(config.layers)]
        self._head = (arrays["head.weight"].T.copy(), arrays["head.bias"].copy())
        self._arrays = None           # the network for compiled code, made on first use

    def for_params(self, params: SlipParams) -> "StepLengthController":
        """The controller for the hopper ``params``: the same network, its inputs taken in the trained hopper's units
        (see the module doc) and its polish run with ``params``' leg length and gravity. Itself for a hopper with the
        trained leg length and gravity (the touchdown depends on nothing else); built once per hopper."""
        if not isinstance(params, SlipParams):
            raise TypeError(f"for_params takes SlipParams, got {type(params).__name__}")
        key = (params.leg_length, params.gravity)
        if key not in self.views:
            view = copy.copy(self)
            view.leg_length, view.gravity = key
            trained = self.params
            length = params.leg_length / trained.leg_length
            speed = math.sqrt((params.gravity * params.leg_length) / (trained.gravity * trained.leg_length))
            view.feature_scale = np.array([speed, length, length])
            view.views = self.views
            view._arrays = None
            self.views[key] = view
        return self.views[key]

    # ---- inference -----------------------------------------------------------------------------------
    def leg_angles(self, apex, footholds, terrain: Terrain, refine: bool | None = None) -> np.ndarray:
        """Leg angles for many desired footholds: from one apex (x, z, xdot), or one apex row per foothold."""
        footholds = np.ascontiguousarray(footholds, dtype=np.float64).reshape(-1)
        apex_arr = np.asarray(apex, dtype=np.float64)
        if apex_arr.ndim == 1:
            ApexState(*apex_arr).validate()
        elif apex_arr.shape != (footholds.size, 3):
            raise ValueError(f"apex must be one (x, z, xdot) or shape ({footholds.size}, 3), got {apex_arr.shape}")
        if not np.all(np.isfinite(footholds)) or not np.all(np.isfinite(apex_arr)):
            raise ValueError("leg_angles: footholds and apex must be finite")
        from drakeslip.fast_controller import aim_rows  # compiled on first use: --help and imports stay light

        net = self.arrays()
        if refine is not None and bool(refine) != self.refine:
            net = net._replace(refine=bool(refine))
        apexes = np.array(np.broadcast_to(apex_arr, (footholds.size, 3)))   # writable: one compiled aim_rows
        grounds = np.asarray(terrain.height_at(footholds), dtype=np.float64).reshape(-1)
        return aim_rows(apexes, footholds, grounds, net)

    def leg_angle(self, apex, foothold_x: float, terrain: Terrain, refine: bool | None = None) -> float:
        """The leg angle to command at ``apex`` so the foot lands at ``foothold_x``."""
        foothold_x = float(foothold_x)
        if not math.isfinite(foothold_x):
            raise ValueError(f"foothold_x must be finite, got {foothold_x!r}")
        return float(self.leg_angles(apex, [foothold_x], terrain, refine)[0])

    def arrays(self):
        """The network as ``drakeslip.fast_controller.ControllerArrays`` for compiled code (built once per view)."""
        if self._arrays is None:
            from drakeslip.fast_controller import controller_arrays

            (w_in, b_in), hidden = self._layers[0], self._layers[1:]
            size = self.config.hidden
            self._arrays = controller_arrays(
                w_in, b_in, np.array([w for w, _ in hidden]).reshape(len(hidden), size, size),
                np.array([b for _, b in hidden]).reshape(len(hidden), size), self._head[0][:, 0].copy(),
                float(self._head[1][0]), self.feature_mean, self.feature_std,
                np.ones(N_FEATURES) if self.feature_scale is None else self.feature_scale,
                float(self.config.max_angle), float(self.leg_length), float(self.gravity), bool(self.refine))
        return self._arrays

    # ---- persistence ---------------------------------------------------------------------------------
    def weights(self) -> dict:
        """The network's parameters by name (the inverse of the constructor's ``weights``)."""
        out = {}
        for k, (w, b) in enumerate(self._layers):
            out[f"hidden.{k}.weight"], out[f"hidden.{k}.bias"] = w.T, b
        out["head.weight"], out["head.bias"] = self._head[0].T, self._head[1]
        return out

    def save(self, path) -> None:
        """Write the weights atomically (a temporary file renamed over the target)."""
        import torch

        state = {k: torch.tensor(v, dtype=torch.float32) for k, v in self.weights().items()}
        blob = {"format": WEIGHTS_FORMAT, "config": asdict(self.config), "state_dict": state,
                "feature_mean": torch.tensor(self.feature_mean), "feature_std": torch.tensor(self.feature_std),
                "params": asdict(self.params)}
        with atomic_write(path) as f:
            torch.save(blob, f)
        record_digest(path)

    @classmethod
    def load(cls, path, refine: bool = True) -> "StepLengthController":
        """A controller from a weights file written by ``save``; a missing, damaged or mismatched file raises
        FileNotFoundError or ValueError naming it."""
        path = Path(path)
        blob = load_weights(path, "controller weights file")
        if not isinstance(blob, dict) or blob.get("format") != WEIGHTS_FORMAT:
            raise ValueError(f"controller weights file {path} is not in format {WEIGHTS_FORMAT!r}")
        try:
            config = ControllerConfig(**blob["config"])
            params = SlipParams(**blob["params"])
            mean, std = blob["feature_mean"].numpy(), blob["feature_std"].numpy()
            if mean.shape != (N_FEATURES,) or std.shape != (N_FEATURES,):
                raise ValueError("feature statistics of the wrong shape")
            return cls({k: v.numpy() for k, v in blob["state_dict"].items()}, config, mean, std, params, refine)
        except (KeyError, TypeError, AttributeError, RuntimeError, ValueError) as exc:
            raise ValueError(f"controller weights file {path} does not match the controller model: "
                             f"{first_line(exc)}") from exc

    @classmethod
    def load_default(cls, refine: bool = True) -> "StepLengthController":
        """The committed weights (drakeslip/weights/controller.pt), trained by examples/train_controller.py."""
        return cls.load(DEFAULT_WEIGHTS, refine=refine)
