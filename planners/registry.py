"""Planner registry: ``make(name, **options)`` builds any registered planner by name."""
from __future__ import annotations

import json

_PLANNERS: dict = {}


def register(name: str):
    """Class decorator: ``@register("angle")`` makes the class available as ``make("angle")``."""
    def add(cls):
        if name in _PLANNERS:
            raise ValueError(f"a planner named {name!r} is already registered")
        cls.name = name
        _PLANNERS[name] = cls
        return cls
    return add


def planner_name(label: str) -> str:
    """The registered planner behind a label: ``NAME`` or ``NAME@VARIANT`` (a variant is the same planner with
    other options, so two settings can run side by side in one evaluation)."""
    return label.split("@", 1)[0]


def label_options(text: str, labels: list, kind: str = "planner") -> dict:
    """``--options`` JSON: an object mapping some of ``labels`` to option objects; a ValueError otherwise."""
    try:
        options = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"--options is not valid JSON ({error}): {text!r}") from None
    if not isinstance(options, dict) or any(k not in labels or not isinstance(v, dict) for k, v in options.items()):
        raise ValueError(f"--options must map {kind} labels among {labels} to option objects, got {text!r}")
    return options


def available() -> list[str]:
    return sorted(_PLANNERS)


def takes(name: str, option: str) -> bool:
    """Whether the planner registered as ``name`` accepts ``option`` (e.g. a shared ``controller``)."""
    import inspect

    return name in _PLANNERS and option in inspect.signature(_PLANNERS[name]).parameters


def make(name: str, **options):
    """A planner by name with its options, e.g. ``make("angle", branching=20, seed=0)``."""
    if name not in _PLANNERS:
        raise ValueError(f"unknown planner {name!r}; known planners: {', '.join(available())}")
    return _PLANNERS[name](**options)
