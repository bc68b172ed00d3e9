"""The allowed range of every numeric setting: one table behind the panel's properties (their min and
max), the command line's options and the checks of the plain settings objects.

A value outside its range is refused with the setting's name, never clamped in silence.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Limit:
    label: str  # what the user calls the setting
    low: float
    high: float | None = None  # None: no upper bound

    def problem(self, value) -> str:
        """Why `value` is out of range ('' when it is in)."""
        if self.high is None:
            return "" if value >= self.low else f"{self.label} must be at least {self.low}, got {value}"
        if self.low <= value <= self.high:
            return ""
        return f"{self.label} must be between {self.low} and {self.high}, got {value}"

    def describe(self) -> str:
        return f"at least {self.low}" if self.high is None else f"{self.low} to {self.high}"

    def bounds(self) -> dict:
        """The min and max of the Blender property."""
        return {"min": self.low} if self.high is None else {"min": self.low, "max": self.high}


LIMITS = {  # keyed by the scene property's name (blender/properties.py) where there is one
    "train_count": Limit("Training images", 1, 2000),  # no training pairs: a set nothing can be trained on
    "test_count": Limit("Test images", 0, 2000),
    "working_size": Limit("Working size", 32, 1024),  # every capture image is working size squared
    "samples": Limit("Samples", 1, 64),
    "seed": Limit("Pattern seed", 0),
    "finetune_iterations": Limit("Fine-tuning iterations", 0, 100000),  # 0: the standard recipe
    "psa_adaptation": Limit("Adaptation", 0.0, 1.0),  # 0: keep my look, 1: whatever the surface can show
    "style_seed": Limit("Style seed", 0),
    "style_prompt_weight": Limit("Prompt share of the style image's look", 0.0, 1.0),
    "output_size": Limit("Output size", 0, 8192),  # 0: the projector's native frame
    "refine_iterations": Limit("Refinement steps", 0, 50),  # 0: no refinement on the rig
    "crossfade_frames": Limit("Crossfade frames", 2, 10000),
    "crossfade_fps": Limit("Crossfade frame rate", 1, 240),  # played live on the projector window
    # developer commands only
    "psa_iterations": Limit("PSA iterations", 1, 1000),
    "pretrain_iterations": Limit("Pretraining iterations", 1, 1000000),
    "crop": Limit("Crop size", 16, 1024),
}


def _look_sliders() -> dict:
    """A world look's sliders (lapig_core/look_parameters: plain Python, no torch), as scene properties look_<name>."""
    from ...lapig_core.look_parameters import PARAMETERS

    return {f"look_{p.name}": Limit(p.label, p.low, p.high) for p in PARAMETERS}


LIMITS.update(_look_sliders())


def first_problem(values: dict) -> str:
    """The first setting (LIMITS name -> value) out of its range, said ('' when all are in)."""
    for name, value in values.items():
        problem = LIMITS[name].problem(value)
        if problem:
            return problem
    return ""
