"""The show as the add-on holds it (issue 38): looks (results) in order, each held for a time, then a
transition to the next, and an optional motion; the frame rate is the scene's. Plain values, no bpy:
blender/scene_state reads scene.lapig.show_looks into a ShowPlan, and the timeline's markers, the baked
previz, the export and the live play all take their frames from it.

Time: look i is held from t_i for hold_s, then its transition to look i+1 lasts transition_s (the last
look's transition is not played); t_{i+1} = t_i + hold_s + transition_s. A time is frame round(t * fps)
after the show's first frame, so the segments tile the show's frames exactly.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

TRANSITIONS = ("dissolve", "morph")
MOTIONS = ("none", "drift", "rise", "pulse", "colour_cycle", "world")  # world: a world look's own time
MARKER_NAME_MAX = 63  # Blender keeps 63 characters of a marker's name


@dataclass(frozen=True)
class ShowLook:
    """One look of the show: a result folder (absolute; '' where it is gone), what the timeline calls it,
    how long it holds, its transition to the next look, and how it moves."""
    result_dir: str
    name: str = ""
    hold_s: float = 4.0
    transition: str = "dissolve"
    transition_s: float = 1.0
    motion: str = "none"
    motion_amount: float = 0.5
    motion_period_s: float = 4.0

    @property
    def label(self) -> str:
        return self.name.strip() or os.path.basename(os.path.normpath(self.result_dir)) or "look"

    def problem(self, index: int) -> str:
        """Why this look cannot play ('' when it can); index: its place in the show (0-based)."""
        where = f"Look {index + 1} '{self.label}'"
        if self.transition not in TRANSITIONS:
            return f"{where}: unknown transition '{self.transition}' (use {', '.join(TRANSITIONS)})"
        if self.motion not in MOTIONS:
            return f"{where}: unknown motion '{self.motion}' (use {', '.join(MOTIONS)})"
        if not (self.hold_s >= 0 and self.transition_s >= 0):
            return f"{where}: hold and transition times must not be negative"
        if self.motion != "none" and not self.motion_period_s > 0:
            return f"{where}: its {self.motion} needs a period above 0 s"
        return ""

    def to_dict(self) -> dict:
        return {"result": self.result_dir, "name": self.label, "hold_s": self.hold_s,
                "transition": {"kind": self.transition, "seconds": self.transition_s},
                "motion": {"kind": self.motion, "amount": self.motion_amount, "period_s": self.motion_period_s}}


@dataclass(frozen=True)
class Segment:
    """A run of the show's frames: a look held ('hold', look = b = its index) or a transition from look a
    to look b ('dissolve' or 'morph'); first: the frame it starts at, counted from the show's first frame."""
    kind: str
    a: int
    b: int
    first: int
    frames: int

    def weight(self, frame: int) -> float:
        """How far into a transition `frame` (counted from the show's first frame) is: (n + 1) / (N + 1) for its
        n-th of N frames, never 0 or 1, which are the looks themselves (lapig_core/show/schedule's weights)."""
        return (frame - self.first + 1) / (self.frames + 1) if self.kind != "hold" else 0.0


@dataclass(frozen=True)
class ShowPlan:
    looks: tuple = ()
    fps: float = 30.0
    frame_start: int = 1  # the scene's frame where the show begins
    meta: dict = field(default_factory=dict, compare=False)

    def problem(self) -> str:
        """Why the show cannot be baked, exported or played ('' when it can): one line."""
        if not self.looks:
            return "The show has no looks: add a result to it (Add Look)"
        if not self.fps > 0:
            return f"The show's frame rate is {self.fps:g}: set the scene's frame rate above 0"
        for i, look in enumerate(self.looks):
            problem = look.problem(i)
            if problem:
                return problem
            if not look.result_dir:
                return f"Look {i + 1} '{look.label}': its result folder is gone (choose the result again)"
        if self.frame_count() < 1:
            return "The show lasts no frame: give its looks hold times"
        return ""

    def frame_of(self, seconds: float) -> int:
        return int(round(seconds * self.fps))

    def segments(self) -> list:
        """The show's frames as holds and transitions, in order, none empty."""
        out, t = [], 0.0
        for i, look in enumerate(self.looks):
            last = i == len(self.looks) - 1
            spans = [("hold", i, i, look.hold_s)]
            if not last:
                spans.append((look.transition, i, i + 1, look.transition_s))
            for kind, a, b, seconds in spans:
                first, end = self.frame_of(t), self.frame_of(t + seconds)
                if end > first:
                    out.append(Segment(kind, a, b, first, end - first))
                t += seconds
        return out

    def frame_count(self) -> int:
        return sum(s.frames for s in self.segments()) if self.fps > 0 else 0

    def seconds(self) -> float:
        return self.frame_count() / self.fps if self.fps > 0 else 0.0

    def look_starts(self) -> list:
        """Each look's first frame (of its hold), counted from the show's first frame."""
        starts, t = [], 0.0
        for look in self.looks:
            starts.append(self.frame_of(t))
            t += look.hold_s + look.transition_s
        return starts

    def segment_at(self, frame: int) -> Segment:
        """The segment holding `frame` (from the show's first frame); the last one past the end."""
        segments = self.segments()
        for s in segments:
            if frame < s.first + s.frames:
                return s
        return segments[-1]

    def markers(self) -> list:
        """The timeline's markers as (scene frame, name): one at each look's start, named after the look, and
        one at each transition's start, saying which and how long."""
        out = []
        starts = self.look_starts()
        for i, look in enumerate(self.looks):
            out.append((self.frame_start + starts[i], _marker_name(look.label)))
        for s in self.segments():
            if s.kind != "hold":
                seconds = self.looks[s.a].transition_s
                name = f"{s.kind} {seconds:g}s to {self.looks[s.b].label}"
                out.append((self.frame_start + s.first, _marker_name(name)))
        return sorted(out)

    def frame_end(self) -> int:
        """The scene's last frame of the show."""
        return self.frame_start + max(self.frame_count(), 1) - 1

    def key(self) -> str:
        """A short hash of what the frames are made of (looks, times, transitions, motions, frame rate): a
        baked show of another key is out of date."""
        import hashlib
        import json

        data = {k: v for k, v in self.to_dict().items() if k != "frame_start"}
        return hashlib.sha1(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]

    def to_dict(self) -> dict:
        """What a sidecar says of the show: its looks, times, transitions, motions and frame rate."""
        return {"fps": self.fps, "frames": self.frame_count(), "seconds": round(self.seconds(), 4),
                "frame_start": self.frame_start, "looks": [look.to_dict() for look in self.looks],
                "segments": [{"kind": s.kind, "from": s.a, "to": s.b, "first_frame": s.first, "frames": s.frames}
                             for s in self.segments()]}


def _marker_name(text: str) -> str:
    return text if len(text) <= MARKER_NAME_MAX else text[:MARKER_NAME_MAX - 1] + "~"


# ------------------------------------------------------------------ the list's edits (the panel's buttons)

def look_name(result_dir: str, longest: int = 40) -> str:
    """A new look's name: its result's prompt (shortened), else the folder's name."""
    from ....lapig_core.export.result_files import read_summary

    try:
        prompt = " ".join(str(read_summary(result_dir).get("prompt") or "").split())
    except (OSError, ValueError):
        prompt = ""
    if not prompt:
        return os.path.basename(os.path.normpath(result_dir))
    return prompt if len(prompt) <= longest else prompt[:longest - 1].rstrip() + "~"


def moved(items: list, index: int, direction: int) -> tuple[list, int]:
    """The list with item `index` moved one place up (-1) or down (+1), and its new index (unchanged at an end)."""
    items = list(items)
    target = index + direction
    if not 0 <= index < len(items) or not 0 <= target < len(items):
        return items, index
    items[index], items[target] = items[target], items[index]
    return items, target


def index_after_removal(length_after: int, removed: int) -> int:
    """The active index once item `removed` is gone from a list now `length_after` long."""
    return max(0, min(removed, length_after - 1))


def with_look(plan: ShowPlan, index: int, **changes) -> ShowPlan:
    looks = list(plan.looks)
    looks[index] = replace(looks[index], **changes)
    return replace(plan, looks=tuple(looks))


# ------------------------------------------------------------------ stale looks

def look_made_from(summary: dict) -> tuple[str, str]:
    """(capture folder, capture fingerprint) a result's result.json names."""
    return str(summary.get("capture") or ""), str(summary.get("fingerprint") or "")


def _same_folder(a: str, b: str) -> bool:
    """The same capture folder, also after the .blend and its data folder moved together (the setups/<name>
    part and the data folder's name match)."""
    if not a or not b:
        return True  # unknown: not called stale for that
    tail = lambda p: os.path.normpath(p).replace("\\", "/").split("/")[-3:]  # noqa: E731
    return os.path.normpath(a) == os.path.normpath(b) or tail(a) == tail(b)


def look_staleness(index: int, look: ShowLook, summary: dict | None, result_time: float | None,
                   capture_dir: str, capture_fingerprint: str, capture_time: float | None) -> str:
    """Why look `index` is stale against the scene's capture ('' when it is current): its result is gone, made
    from another capture, or older than the scene's capture (captured again since)."""
    where = f"Look {index + 1} '{look.label}'"
    if summary is None:
        return f"{where}: its result is gone or unreadable ({look.result_dir or 'no folder'})"
    folder, fingerprint = look_made_from(summary)
    if fingerprint and capture_fingerprint and fingerprint != capture_fingerprint:
        return f"{where} was made from another capture than the scene's: generate it again"
    if not _same_folder(folder, capture_dir):
        return f"{where} was made from the capture {folder}, not the scene's: generate it again"
    if result_time is not None and capture_time is not None and result_time < capture_time:
        return f"{where} is older than the scene's capture (captured again since): generate it again"
    return ""


def stale_looks(plan: ShowPlan, capture_dir: str, capture_fingerprint: str) -> list:
    """Every look's staleness line, read from the result folders and the capture's setup.json (files, no bpy)."""
    from ....lapig_core.export.result_files import read_summary

    capture_time = _mtime(os.path.join(capture_dir, "setup.json")) if capture_dir else None
    lines = []
    for i, look in enumerate(plan.looks):
        try:
            summary = read_summary(look.result_dir) if look.result_dir else None
        except (OSError, ValueError):
            summary = None
        result_time = _mtime(os.path.join(look.result_dir, "result.json")) if summary is not None else None
        line = look_staleness(i, look, summary, result_time, capture_dir, capture_fingerprint, capture_time)
        if line:
            lines.append(line)
    return lines


def _mtime(path: str) -> float | None:
    try:
        return os.path.getmtime(path)
    except OSError:
        return None


def show_blocker(plan: ShowPlan, state) -> str:
    """Why the show cannot be baked, exported or played (services/state.SceneState): the plan's problem, the
    scene's capture, or the first stale look ('' when it can)."""
    from ..panel.panel_state import capture_blocker

    problem = plan.problem()
    if problem:
        return problem
    blocker = capture_blocker(state)
    if blocker:
        return f"The show's looks need the scene's capture: {blocker[0].lower()}{blocker[1:]}"
    stale = stale_looks(plan, state.capture_dir, state.capture_fingerprint)
    return stale[0] if stale else ""
