# SPDX-License-Identifier: GPL-3.0-or-later
"""Time for the rig: the real clock, or a virtual one that simulated devices and the tests share, so a
capture at a 100 ms camera latency runs in milliseconds and the same way every time."""
from __future__ import annotations

import time


class RealClock:
    def now(self) -> float:
        return time.perf_counter()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)

    def sleep_until(self, moment: float) -> None:
        self.sleep(moment - self.now())


class VirtualClock(RealClock):
    """Time passes only when someone sleeps (and by ``cost_s`` for each call of ``charge``)."""

    def __init__(self, start: float = 0.0):
        self._now = start

    def now(self) -> float:
        return self._now

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self._now += seconds


REAL_CLOCK = RealClock()
