"""Planning for any hopper, measured: hoppers drawn at random (seeded) from the range the toolkit is for, suites
drawn for each (``planners.formats.suite_draw.draw_suite``), the planners evaluated on them in the receding-horizon
loop (``verification.evaluation``) and held to three bars:

* ``step`` crosses at least 95 % of the ditch cases without noise;
* ``step@robust`` at least 90 % of them under ``realistic`` noise, its sizes in the hopper's units (replanning at
  every apex, as its preset runs);
* ``lstm-guided`` crosses within 5 points of ``step`` without noise, with fewer step-map calls per plan.

The other families (step, mixed) are reported for ``step`` and ``lstm-guided`` without a bar. The hoppers: mass
3-30 kg, leg 0.3-1.2 m, dimensionless stiffness k L0 / (m g) 10-40 and friction 0.6-1.0, each drawn uniformly
(``random_hoppers``), after the range's two corners (``CORNERS``): the lightest, shortest, softest and most
slippery hopper, and the heaviest, longest, stiffest and grippiest.
"""
from __future__ import annotations

import numpy as np

from drakeslip import SlipParams
from drakeslip.hopper_file import NamedHopper
from drakeslip.noise import PROFILES

from planners.closed_loop import ClosedLoopConfig
from planners.formats.suite_draw import draw_suite
from planners.registry import hopper_specs, loop_settings
from verification.evaluation import evaluate

RANGE = {"mass": (3.0, 30.0), "leg_length": (0.3, 1.2), "stiffness": (10.0, 40.0), "friction": (0.6, 1.0)}
CORNERS = ((3.0, 0.3, 10.0, 0.6), (30.0, 1.2, 40.0, 1.0))   # (mass, leg, k L0 / (m g), friction)
GRAVITY = 9.81
# label -> (noise profile, bar on its ditch success rate [%], or None)
RUNS = {"step": ("none", 95.0), "step@robust": ("realistic", 90.0), "lstm-guided": ("none", None)}
GUIDED_GAP = 5.0   # points lstm-guided may fall behind step


def hopper(mass: float, leg_length: float, stiffness: float, friction: float, name: str) -> NamedHopper:
    """The hopper of ``mass`` [kg], ``leg_length`` [m], dimensionless ``stiffness`` k L0 / (m g) and ``friction``
    on the Earth; its stroke is SlipParams's default."""
    return NamedHopper(SlipParams(mass=mass, leg_length=leg_length, stiffness=stiffness * mass * GRAVITY / leg_length,
                             friction=friction), name)


def random_hoppers(seed: int, n: int, corners: bool = True) -> list[NamedHopper]:
    """``n`` hoppers drawn uniformly from RANGE with ``seed``, after the CORNERS when ``corners``; named
    ``corner-K`` and ``random-SEED-K``."""
    rng = np.random.default_rng(seed)
    out = [hopper(*c, name=f"corner-{k}") for k, c in enumerate(CORNERS)] if corners else []
    for k in range(n):
        mass, leg, kd, mu = (rng.uniform(*RANGE[name]) for name in ("mass", "leg_length", "stiffness", "friction"))
        out.append(hopper(float(mass), float(leg), float(kd), float(mu), f"random-{seed}-{k}"))
    return out


def describe(h: NamedHopper) -> str:
    """'3 kg, 0.3 m, kd 10, mu 0.6'."""
    p = h.params
    return f"{p.mass:.3g} kg, {p.leg_length:.3g} m, kd {h.units.stiffness:.3g}, mu {p.friction:.2g}"


# many parameters: the hopper, suite and labels, then ``evaluate``'s keyword options, each with its default
def evaluate_hopper(h: NamedHopper, family: str, seed: int, labels, every: int = 1, backend: str = "fast",
                    executor=None, cache_path=None, progress: bool = False) -> dict:
    """``labels`` (of RUNS) evaluated on the ``family`` suite drawn for ``h`` from terrain ``seed``, every
    ``every``-th case, each label with its RUNS noise and its preset's closed loop, executed on ``backend`` (on
    the multibody robot, ``h``'s robot planned for with its fitted template: ``drakeslip.multibody.fit.template_for``);
    the planners read the weights of ``h``'s hopper folder, if it has one (``planners.registry.hopper_options``)."""
    from drakeslip.multibody.fit import fitted_template

    suite = draw_suite(family, seed, h, name=f"{family}-{seed}-{h.name}")
    template = fitted_template() if backend == "multibody" else None
    configs = {label: ClosedLoopConfig(backend=backend, noise=PROFILES[RUNS[label][0]], template=template,
                                       **loop_settings(label)) for label in labels}
    return evaluate(suite, hopper_specs({label: None for label in labels}, h), executor=executor, cache_path=cache_path,
                    config=configs, progress=progress, every=every)


def checks(ditch: dict) -> list[tuple[str, float, str, bool]]:
    """(what, measured, bar, passed) for a hopper's ditch results (``evaluate_hopper`` with every RUNS label)."""
    rate = {label: 100.0 * r["success_rate"] for label, r in ditch["planners"].items()}
    calls = {label: r["ode_calls_mean"] for label, r in ditch["planners"].items()}
    out = [(f"{label} ({noise})", rate[label], f">= {bar:g} %", rate[label] >= bar)
           for label, (noise, bar) in RUNS.items() if bar is not None and label in rate]
    if "lstm-guided" in rate and "step" in rate:
        out.append(("lstm-guided - step", rate["lstm-guided"] - rate["step"], f">= -{GUIDED_GAP:g} points",
                    rate["lstm-guided"] >= rate["step"] - GUIDED_GAP))
        out.append(("lstm-guided / step ODE calls per plan", calls["lstm-guided"] / max(calls["step"], 1e-12),
                    "< 1", calls["lstm-guided"] < calls["step"]))
    return out
