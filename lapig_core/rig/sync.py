# SPDX-License-Identifier: GPL-3.0-or-later
"""Showing a frame and grabbing the camera's picture of it, on a rig whose camera is late and unreliable.

``measure_latency`` times how long a change on the projector takes to reach a grabbed image (instead
of the public code's fixed 0.2 s pause and 13 dropped frames). ``FrameSync.shoot`` then shows a frame
stamped with its sequence number (lapig_core.rig.frame_code), waits that long, flushes what the camera
buffered, grabs, and reads the stamp back: a stale, torn or unreadable picture is grabbed again (and
the frame shown again when that does not help), and a camera that keeps failing stops the capture with
a message. Without a readable code (the camera does not see the frame's edges, or the code is turned
off) the sync is by time alone, and setup.json says so.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from . import RigError
from . import frame_code as fc


def _mean_level(image) -> float:
    x = np.asarray(image)
    return float(x.mean()) / (255.0 if x.dtype == np.uint8 else 1.0)


def measure_latency(output, camera, clock, switches: int = 4, timeout_s: float = 3.0) -> dict:
    """Seconds from show() to the first grabbed image of the new frame, over black/white switches:
    {"latency_s": the slowest switch, "samples_s": [...], "frame_interval_s": the camera's pace}."""
    w, h = output.size
    black = np.zeros((h, w, 3), np.uint8)
    white = np.full((h, w, 3), 255, np.uint8)
    samples, intervals = [], []
    dark = _steady_level(output, camera, clock, black, min)
    bright = _steady_level(output, camera, clock, white, max)
    if bright - dark < 0.02:
        raise RigError("the camera does not see the projector change from black to white: aim the camera "
                       "at the projection and uncover the lens; lock its exposure (an auto exposure evens "
                       "black and white out) and raise it if the picture is dark")
    middle = (dark + bright) / 2
    for k in range(switches):
        frame, want_bright = (black, False) if k % 2 == 0 else (white, True)
        shown = output.show(frame)
        last_read, first_new = None, None
        while True:
            image, read_at = camera.grab()
            if last_read is not None:
                intervals.append(read_at - last_read)
            last_read = read_at
            if (_mean_level(image) > middle) == want_bright:
                # two pictures in a row: one dropped (black) or torn picture is not the switch
                if first_new is not None:
                    samples.append(first_new - shown)
                    break
                first_new = read_at
            else:
                first_new = None
            if read_at - shown > timeout_s:
                raise RigError(f"the camera showed no change {timeout_s:.0f} s after the projector's: "
                               "is the camera live (not a file) and looking at the projection?")
    positive = [i for i in intervals if i > 1e-4]
    return {"latency_s": float(max(samples)), "samples_s": [round(s, 4) for s in samples],
            "frame_interval_s": float(np.median(positive)) if positive else 0.0}


def _steady_level(output, camera, clock, frame, pick, grabs: int = 5) -> float:
    """The camera's level of a still frame over several grabs: the darkest of black's (a repeated bright
    picture or a torn one is brighter) and the brightest of white's (a dropped picture is black)."""
    output.show(frame)
    clock.sleep(0.5)
    camera.flush()
    return pick(_mean_level(camera.grab()[0]) for _ in range(grabs))


@dataclass
class SyncStats:
    shots: int = 0
    rejected: Counter = field(default_factory=Counter)  # verdict -> grabs thrown away
    reshows: int = 0

    def as_dict(self) -> dict:
        return {"shots": self.shots, "rejected": dict(self.rejected), "reshows": self.reshows}


class FrameSync:
    """Shows frames and returns verified pictures of them."""

    def __init__(self, output, camera, clock, settle_s: float, cells: fc.CellMap | None,
                 layout: fc.CodeLayout | None, max_grabs: int = 8, max_settle_s: float = 2.0):
        self.output, self.camera, self.clock = output, camera, clock
        self.settle_s, self.max_settle_s = settle_s, max_settle_s
        self.cells, self.layout = cells, layout
        self.max_grabs = max_grabs
        self.number = 0
        self.stats = SyncStats()
        self.verdicts: list[str] = []  # every grab's verdict, in order (the bench compares it with the truth)

    @property
    def verifies(self) -> bool:
        return self.cells is not None and bool(self.cells.readable_bands())

    def shoot(self, frame: np.ndarray) -> np.ndarray:
        """The camera's picture of ``frame``, verified by its code where the camera reads it."""
        self.number += 1
        shown = self.output.show(fc.stamp(frame, self.layout, self.number) if self.verifies else frame)
        self.stats.shots += 1
        failures = []
        for attempt in range(self.max_grabs):
            self.clock.sleep_until(shown + self.settle_s)
            self.camera.flush()
            image, _ = self.camera.grab()
            if not self.verifies:
                return image
            verdict = fc.read_code(image, self.cells).verdict(self.number)
            self.verdicts.append(verdict)
            if verdict == "ok":
                return image
            failures.append(verdict)
            self.stats.rejected[verdict] += 1
            if verdict == "stale":  # the camera is later than measured: wait longer from now on
                self.settle_s = min(self.settle_s * 1.25 + 0.005, self.max_settle_s)
            if attempt % 3 == 2:  # a projector that missed the frame: show it again
                shown = self.output.show(fc.stamp(frame, self.layout, self.number))
                self.stats.reshows += 1
        said = ", ".join(f"{n} {v}" for v, n in Counter(failures).items())
        raise RigError(f"the camera gave no good picture of frame {self.stats.shots} in {self.max_grabs} "
                       f"tries ({said}): check that nothing covers the projection's top and bottom edges, "
                       "that the camera's exposure is locked, and its cable")
