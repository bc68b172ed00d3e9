"""A projector window without a screen, for the tests and the benchmarks where no display is."""
from __future__ import annotations

import time

import numpy as np


class SimulatedWindow:
    """A window without a screen, for tests and the bench where no display is: load copies the frame,
    present takes present_s and returns time.monotonic()."""

    def __init__(self, size, present_s: float = 0.001):
        self.size, self.present_s = tuple(size), present_s
        self.is_open = True
        self.frames = 0
        self._loaded = self.shown = None

    def load(self, frame) -> None:
        self._loaded = np.array(frame, copy=True)

    def present(self) -> float:
        time.sleep(self.present_s)
        self.shown, self.frames = self._loaded, self.frames + 1
        return time.monotonic()

    def show(self, frame) -> float:
        self.load(frame)
        return self.present()

    def describe(self) -> dict:
        return {"kind": "simulated window", "size": list(self.size), "frames_shown": self.frames}

    def close(self) -> None:
        self.is_open = False
