# SPDX-License-Identifier: GPL-3.0-or-later
"""Which frame shows what: a frame index -> a FrameKey, and the show's frame count.

    ('hold', i, 0.0)        look i, still (every frame of its hold has this key: made once)
    ('moving', i, t)        look i with its motion at t seconds, t taken modulo the motion's period
                            (a periodic motion's frames repeat, and are made once too)
    ('dissolve', i, j, w)   the linear-light crossfade of looks i and j at weight w in (0, 1)
    ('morph', i, j, w)      the in-between look of i and j at w in (0, 1)

Segment boundaries are the cumulative times rounded to frames, so the frame count is round(seconds x
fps) whatever the parts' lengths. A transition's weights are (n + 1) / (N + 1) for its N frames: never
0 or 1, which are the looks themselves. During a transition a moving look stands where its hold
leaves it (look i at the end of its hold, look j at its start), so the transition is one morph or
crossfade between two fixed looks.
"""
from __future__ import annotations

from dataclasses import dataclass

from .model import Show

DIGITS = 6  # keys' times and weights rounded, so the same frame gets an equal key


@dataclass(frozen=True)
class Segment:
    kind: str  # 'look' or a transition kind
    first: int  # first frame index
    frames: int
    looks: tuple  # (i,) or (i, j)


def _moving_t(show: Show, i: int, n: int) -> float:
    """Look i's motion time of the n-th frame of its hold."""
    motion = show.looks[i].motion
    t = round(n / float(show.fps), DIGITS)
    return round(t % float(motion.period_s), DIGITS)


class Schedule:
    def __init__(self, show: Show):
        self.show = show.validate()
        fps = float(show.fps)
        segments, t, edge = [], 0.0, 0
        for i, look in enumerate(show.looks):
            parts = [("look", float(look.hold_s), (i,))]
            if i < len(show.transitions):
                tr = show.transitions[i]
                parts.append((tr.kind, float(tr.seconds), (i, i + 1)))
            for kind, seconds, looks in parts:
                t += seconds
                end = round(t * fps)
                if end > edge:
                    segments.append(Segment(kind, edge, end - edge, looks))
                edge = max(edge, end)
        self.segments = segments
        self.total_frames = edge

    def segment_of(self, index: int) -> Segment:
        if not 0 <= index < self.total_frames:
            raise IndexError(f"frame {index} is outside the show's {self.total_frames} frames")
        for seg in self.segments:
            if index < seg.first + seg.frames:
                return seg
        raise AssertionError("unreachable: the segments cover every frame")

    def at(self, index: int) -> tuple:
        """The FrameKey of frame `index` (module docstring)."""
        seg = self.segment_of(index)
        n = index - seg.first
        if seg.kind == "look":
            i = seg.looks[0]
            if self.show.looks[i].motion is None:
                return ("hold", i, 0.0)
            return ("moving", i, _moving_t(self.show, i, n))
        i, j = seg.looks
        return (seg.kind, i, j, round((n + 1) / (seg.frames + 1), DIGITS))

    def keys(self):
        return [self.at(i) for i in range(self.total_frames)]

    def hold_end_t(self, i: int) -> float:
        """Look i's motion time where its hold ends (where a transition out of it stands)."""
        seg = next((s for s in self.segments if s.kind == "look" and s.looks == (i,)), None)
        if seg is None or self.show.looks[i].motion is None:
            return 0.0
        return _moving_t(self.show, i, seg.frames - 1)


def schedule_of(show: Show) -> Schedule:
    """The show's schedule; ShowError for a show that does not validate."""
    return Schedule(show)
