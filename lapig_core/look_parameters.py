# SPDX-License-Identifier: GPL-3.0-or-later
"""A world look's few main parameters, the sliders of the Stylize panel (issue 50, item 4), in Blender's node words
where they fit (Noise: Scale, Detail, Roughness, Distortion; Hue/Saturation; Seed) and speed on the show's timeline.

The prompt plan gives their start values (lgst/world/compose.py: "fine" and "huge" the scale, "dense" and "sparse"
the density; the seed Generate's); an artist then moves them and the look is drawn again from them, with no new
prompt. They are not PSA's theta: PSA moves how the look is lit and coloured, these say what it is (where its stones
are, how big).
Plain Python, no torch (outside lgst/, whose package loads torch): services/limits.py reads the ranges from here
and the panel's properties take them from there, in the torch-free tier too.

    params = LookParameters.from_plan(comp, seed=3)     # the plan's choice
    params = params.edited({"scale": 2.0})              # ValueError: one line naming the slider and its range
    params.to_dict() / LookParameters.from_dict(d)      # result.json's lgst.look_parameters

Adding a parameter: a Parameter in PARAMETERS (its range and what it does, in one line), its field in
LookParameters, and where lgst/world/stage.render reads it."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace


@dataclass(frozen=True)
class Parameter:
    name: str      # LookParameters' field, the scene property's (look_<name>) and result.json's key
    label: str     # the slider's name
    low: float
    high: float
    step: float    # the slider's step (Blender's UI: hundredths)
    tip: str       # the slider's tooltip: what it does
    integer: bool = False


PARAMETERS = (
    Parameter("scale", "Scale", 0.2, 5.0, 0.05, "Features per frame: higher draws more, smaller stones, cells, leaves"),
    Parameter("density", "Density", -0.6, 0.6, 0.05, "How much of the overlays and scattered shapes there is"),
    Parameter("detail", "Detail", 0.0, 3.0, 0.05, "The material's own fine detail: pores, fibres, grains"),
    Parameter("roughness", "Roughness", 0.0, 3.0, 0.05, "The fine grain's strength: each grain of its own shade"),
    Parameter("distortion", "Distortion", 0.0, 2.0, 0.05, "Warps the pattern by noise (veined, melted, blown)"),
    Parameter("hue", "Hue", -180.0, 180.0, 1.0, "Turns the look's colours round the colour wheel (degrees)"),
    Parameter("saturation", "Saturation", 0.0, 2.0, 0.05, "0 grey, 1 the look's own colours, 2 twice as vivid"),
    Parameter("seed", "Seed", 0, 9999, 1, "Another draw of the same look: the stones and leaves elsewhere", True),
    Parameter("speed", "Speed", 0.0, 5.0, 0.05, "How fast it moves on the show's timeline (0: still)"),
)
BY_NAME = {p.name: p for p in PARAMETERS}


def problem(name: str, value) -> str:
    """Why `value` cannot be the parameter `name` ('' when it can): one line naming the slider and its range."""
    p = BY_NAME.get(name)
    if p is None:
        return f"a world look has no parameter '{name}': it has {', '.join(BY_NAME)}"
    try:
        x = float(value)
    except (TypeError, ValueError):
        return f"{p.label} must be a number, got {value!r}"
    if isinstance(value, bool) or not math.isfinite(x):
        return f"{p.label} must be a number, got {value!r}"
    if p.integer and x != int(x):
        return f"{p.label} must be a whole number, got {value!r}"
    if not p.low <= x <= p.high:
        return f"{p.label} must be between {p.low:g} and {p.high:g}, got {value!r}"
    return ""


@dataclass(frozen=True)
class LookParameters:
    scale: float = 1.0
    density: float = 0.0
    detail: float = 1.0
    roughness: float = 1.0
    distortion: float = 0.0
    hue: float = 0.0
    saturation: float = 1.0
    seed: int = 0
    speed: float = 1.0

    @classmethod
    def from_plan(cls, comp, seed: int = 0) -> "LookParameters":
        """The prompt plan's choice: the composition's scale and density (its modifier words), the seed."""
        return cls(scale=float(comp.scale), density=float(comp.density), seed=int(seed))

    def edited(self, changes: dict) -> "LookParameters":
        """These parameters with `changes` ({name: value}); ValueError with the first bad one's line."""
        for name, value in changes.items():
            why = problem(name, value)
            if why:
                raise ValueError(why)
        typed = {k: (int(v) if BY_NAME[k].integer else float(v)) for k, v in changes.items()}
        return replace(self, **typed)

    def to_dict(self) -> dict:
        return {k: (int(v) if BY_NAME[k].integer else round(float(v), 4)) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict | None, defaults: "LookParameters | None" = None) -> "LookParameters":
        """result.json's record over `defaults` (keys it lacks keep theirs; unknown keys are refused)."""
        base = defaults or cls()
        if not d:
            return base
        if not isinstance(d, dict):
            raise ValueError(f"the look's parameters must be a table of numbers, got {type(d).__name__}")
        return base.edited(d)

    def changed(self, other: "LookParameters") -> list[str]:
        """The names whose values differ from `other`'s (what an edit changed)."""
        return [f.name for f in fields(self) if getattr(self, f.name) != getattr(other, f.name)]
