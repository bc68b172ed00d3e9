# SPDX-License-Identifier: GPL-3.0-or-later
"""The show as data: an ordered list of looks, the transitions between them, the frame rate.

Plain values only: to_dict() is JSON (the export sidecar lists it), from_dict() reads it back and
validates; a data file never runs code. Every problem is one ShowError line that names the look.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

MOTION_PRESETS = ("drift", "rise", "pulse", "colour_cycle", "world")  # world: a world look's own time
TRANSITION_KINDS = ("dissolve", "morph")


class ShowError(ValueError):
    """A show that cannot play; the message is one line a person can act on."""


def _number(value, what: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ShowError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ShowError(f"{what} must be a finite number, got {value!r}")
    return x


@dataclass
class Motion:
    """A look that moves: a preset with its strength (0..1 of the preset's largest move) and period."""

    preset: str
    amount: float = 0.5
    period_s: float = 4.0

    def validate(self, where: str) -> None:
        if self.preset not in MOTION_PRESETS:
            raise ShowError(f"{where}: unknown motion '{self.preset}'; the presets are {', '.join(MOTION_PRESETS)}")
        if not 0.0 <= _number(self.amount, f"{where}: the motion's amount") <= 1.0:
            raise ShowError(f"{where}: the motion's amount must be between 0 and 1, got {self.amount}")
        if _number(self.period_s, f"{where}: the motion's period") <= 0:
            raise ShowError(f"{where}: the motion's period must be more than 0 seconds, got {self.period_s}")

    def to_dict(self) -> dict:
        return {"preset": self.preset, "amount": float(self.amount), "period_s": float(self.period_s)}


@dataclass
class Look:
    """One result on the show: its folder, what made it (as result.json records it), how long it holds."""

    result: str  # the result folder (absolute, or relative to where the show file is)
    prompt: str = ""
    backend: str = "styletransfer"
    seed: int = 0
    hold_s: float = 2.0
    motion: Motion | None = None

    def to_dict(self) -> dict:
        return {"result": str(self.result), "prompt": self.prompt, "backend": self.backend, "seed": int(self.seed),
                "hold_s": float(self.hold_s), "motion": self.motion.to_dict() if self.motion else None}


@dataclass
class Transition:
    """Between look i and look i + 1: a dissolve (linear-light crossfade) or a morph."""

    kind: str = "dissolve"
    seconds: float = 1.0

    def to_dict(self) -> dict:
        return {"kind": self.kind, "seconds": float(self.seconds)}


@dataclass
class Show:
    looks: list = field(default_factory=list)
    transitions: list = field(default_factory=list)  # len(looks) - 1
    fps: float = 30.0

    def validate(self) -> "Show":
        """self, or ShowError with the first problem found."""
        fps = _number(self.fps, "the frame rate")
        if fps <= 0:
            raise ShowError(f"the frame rate must be more than 0 frames per second, got {self.fps}")
        if not self.looks:
            raise ShowError("the show has no looks: add a result to it")
        if len(self.transitions) != len(self.looks) - 1:
            raise ShowError(f"a show of {len(self.looks)} looks needs {len(self.looks) - 1} transitions, "
                            f"got {len(self.transitions)}")
        for n, look in enumerate(self.looks, 1):
            where = f"look {n}"
            if not str(look.result or "").strip():
                raise ShowError(f"{where} names no result folder")
            if _number(look.hold_s, f"{where}: the hold") < 0:
                raise ShowError(f"{where}: the hold must not be negative, got {look.hold_s} s")
            if look.motion is not None:
                look.motion.validate(where)
        for n, tr in enumerate(self.transitions, 1):
            where = f"transition {n} (look {n} to {n + 1})"
            if tr.kind not in TRANSITION_KINDS:
                raise ShowError(f"{where}: unknown transition '{tr.kind}'; use one of {', '.join(TRANSITION_KINDS)}")
            if _number(tr.seconds, f"{where}: its time") < 0:
                raise ShowError(f"{where}: its time must not be negative, got {tr.seconds} s")
        if self.seconds() * fps < 1:
            raise ShowError(f"the show lasts {self.seconds():.3f} s, less than one frame at {fps:g} fps")
        return self

    def seconds(self) -> float:
        return float(sum(lk.hold_s for lk in self.looks) + sum(tr.seconds for tr in self.transitions))

    def to_dict(self) -> dict:
        return {"fps": float(self.fps), "looks": [lk.to_dict() for lk in self.looks],
                "transitions": [tr.to_dict() for tr in self.transitions], "seconds": self.seconds()}

    @classmethod
    def from_dict(cls, d: dict) -> "Show":
        """The show a to_dict() (or a sidecar's "show") describes, validated; ShowError for a malformed one."""
        if not isinstance(d, dict):
            raise ShowError(f"a show is a JSON object, got {type(d).__name__}")
        try:
            looks = []
            for entry in d.get("looks") or []:
                m = entry.get("motion")
                motion = Motion(str(m["preset"]), m.get("amount", 0.5), m.get("period_s", 4.0)) if m else None
                looks.append(Look(str(entry["result"]), str(entry.get("prompt", "")),
                                  str(entry.get("backend", "styletransfer")), int(entry.get("seed", 0)),
                                  entry.get("hold_s", 2.0), motion))
            transitions = [Transition(str(t.get("kind", "dissolve")), t.get("seconds", 1.0))
                           for t in d.get("transitions") or []]
        except (KeyError, TypeError, AttributeError, ValueError) as exc:
            raise ShowError(f"the show's data is malformed ({type(exc).__name__}: {exc})") from None
        return cls(looks, transitions, d.get("fps", 30.0)).validate()
