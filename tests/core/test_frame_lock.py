"""Several projector windows presenting together (lapig_core/rig/frame_lock): loaded first, then released by one
barrier; the skew between them measured per frame set, in frames of the rate."""
import time

import numpy as np
import pytest

from lapig.lapig_core.rig import RigError
from lapig.lapig_core.rig.frame_lock import LockedWindows, play_locked
from lapig.tools.fakes.simulated_window import SimulatedWindow


def _sets(count, sizes):
    return ([np.full((h, w, 3), i % 256, np.uint8) for w, h in sizes] for i in range(count))


def test_windows_that_load_slowly_still_present_within_a_frame():
    class SlowLoad(SimulatedWindow):  # the pixels take 20 ms to cross one window's pipe, 1 ms the other's
        def __init__(self, size, load_s):
            super().__init__(size)
            self.load_s = load_s

        def load(self, frame):
            time.sleep(self.load_s)
            super().load(frame)

    windows = LockedWindows([SlowLoad((64, 48), 0.02), SlowLoad((80, 60), 0.001)])
    figures = play_locked(windows, _sets(20, [(64, 48), (80, 60)]), fps=30)
    assert figures["frames"] == 20 and figures["max_skew_frames"] <= 1.0, figures
    assert figures["p95_skew_ms"] < 10, figures
    assert [w.shown[0, 0, 0] for w in windows.windows] == [19, 19]  # the last set, on both
    windows.close()


def test_the_lock_is_measured_not_assumed():
    """A window that presents 50 ms after the other is 1.5 frames late at 30 fps: the figures say so."""
    windows = LockedWindows([SimulatedWindow((8, 8), 0.001), SimulatedWindow((8, 8), 0.05)])
    figures = play_locked(windows, _sets(5, [(8, 8), (8, 8)]), fps=30)
    assert figures["max_skew_frames"] > 1.2 and figures["max_skew_ms"] >= 45, figures


def test_a_window_that_closes_names_its_projector():
    class Closed(SimulatedWindow):
        def present(self):
            raise RigError("the projector window was closed (Esc or the window's close button)")

    windows = LockedWindows([SimulatedWindow((8, 8)), Closed((8, 8))], names=["Left", "Right"])
    with pytest.raises(RigError, match="^Right: the projector window was closed"):
        windows.show([np.zeros((8, 8, 3), np.uint8)] * 2)
