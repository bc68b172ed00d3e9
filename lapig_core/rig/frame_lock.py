# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projector windows presenting together (issue 36's live output: frame-locked within one frame).

Each window is its own helper process (rig/projector_window). A frame set is shown in two phases: every
window LOADS its frame into its surface (the pixels cross the pipe, the slow part, all windows at once on
one thread each), then, once every load has returned, a barrier releases one thread per window that asks
its helper to PRESENT (SDL_UpdateWindowSurface: milliseconds). Each helper answers with time.monotonic()
after its update, a clock every process of the machine shares, so the skew between the windows is measured
where it happens, not where it was asked for. An output without load/present (a simulated screen) is shown
in the present phase.

``play_locked`` plays frame sets at a frame rate and reports the lock: the largest and the typical skew
between the windows of one frame set, in frames of the rate (goal: at most one), and the frames presented
more than half a period after their time.
"""
from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Sequence

import numpy as np

from . import RigError


class LockedWindows:
    """K outputs (ProjectorWindow, tools/fakes' SimulatedWindow, ...) whose frames go up together."""

    def __init__(self, windows: Sequence, names: Sequence[str] | None = None):
        if not windows:
            raise RigError("no projector window to show on")
        self.windows = list(windows)
        self.names = list(names) if names else [f"projector {k + 1}" for k in range(len(self.windows))]
        self._pool = ThreadPoolExecutor(max_workers=len(self.windows), thread_name_prefix="LAPIG window")
        self.skews_s: list[float] = []  # every frame set's spread of present times

    @property
    def size(self):
        return tuple(self.windows[0].size)

    @property
    def is_open(self) -> bool:
        return all(getattr(w, "is_open", True) for w in self.windows)

    def show(self, frames: Sequence, at: float | None = None) -> list[float]:
        """Every window's frame, presented together (not before time.monotonic() reaches ``at``, where given:
        the frames load first); each window's present time (time.monotonic where the window says it; an output
        without present: its show()'s own time)."""
        if len(frames) != len(self.windows):
            raise RigError(f"one frame per projector window: {len(self.windows)}, got {len(frames)}")
        self._each(lambda k: self._load(k, frames[k]))
        if at is not None and at > time.monotonic():
            time.sleep(at - time.monotonic())
        barrier = threading.Barrier(len(self.windows))
        times = self._each(lambda k: self._present(k, frames[k], barrier))
        self.skews_s.append(max(times) - min(times))
        return times

    def _load(self, k: int, frame) -> None:
        load = getattr(self.windows[k], "load", None)
        if load is not None:
            load(frame)

    def _present(self, k: int, frame, barrier: threading.Barrier) -> float:
        window = self.windows[k]
        barrier.wait(timeout=30.0)
        present = getattr(window, "present", None)
        return float(present() if present is not None and hasattr(window, "load") else window.show(frame))

    def _each(self, work) -> list:
        futures = [self._pool.submit(work, k) for k in range(len(self.windows))]
        out, first = [], None
        for k, future in enumerate(futures):
            try:
                out.append(future.result())
            except threading.BrokenBarrierError:
                out.append(None)
            except RigError as exc:
                first = first or RigError(f"{self.names[k]}: {exc}")
                out.append(None)
        if first is not None:
            raise first
        return out

    def describe(self) -> dict:
        first = self.windows[0].describe() if hasattr(self.windows[0], "describe") else {}
        return {**first, "windows": [w.describe() if hasattr(w, "describe") else {} for w in self.windows]}

    def close(self) -> None:
        errors = []
        for window in self.windows:
            try:
                window.close()
            except Exception as exc:  # close every one
                errors.append(exc)
        self._pool.shutdown(wait=False)
        if errors:
            raise errors[0]


def play_locked(windows: LockedWindows, frame_sets, fps: float = 30.0, on_frame=None) -> dict:
    """Show each frame set (one frame per window) at 1/fps; the lock's figures: frames, late_frames,
    late_frame_pct (presented more than half a period after their time), max_skew_frames, mean_skew_frames,
    p95_skew_ms, max_skew_ms (the spread of one set's present times across the windows)."""
    period = 1.0 / float(fps)
    skews, late, start = [], 0, None
    for i, frames in enumerate(frame_sets):
        if start is None:
            start = time.monotonic()
        due = start + i * period
        times = windows.show(list(frames), at=due)  # loaded ahead, presented at its time
        late += max(times) - due > period / 2
        skews.append(max(times) - min(times))
        if on_frame is not None:
            on_frame(i, times)
    return lock_figures(skews, late, fps)


def lock_figures(skews, late: int, fps: float) -> dict:
    count = len(skews)
    arr = np.asarray(skews, np.float64) if count else np.zeros(1)
    return {"frames": count, "late_frames": int(late),
            "late_frame_pct": round(100.0 * late / count, 3) if count else 0.0,
            "max_skew_frames": round(float(arr.max()) * fps, 4), "mean_skew_frames": round(float(arr.mean()) * fps, 4),
            "max_skew_ms": round(float(arr.max()) * 1000, 3),
            "p95_skew_ms": round(float(np.percentile(arr, 95)) * 1000, 3)}
