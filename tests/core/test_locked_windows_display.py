"""Two projector windows, one per monitor of the virtual two-monitor X screen (tools/virtual_screens), presenting
together through lapig_core/rig/frame_lock: each monitor shows its own frame pixel for pixel, and the helpers'
present times lie within one frame of each other."""
import os

import numpy as np
import pytest

from lapig.tools import virtual_screens
from lapig.tools.virtual_screens import missing_tools, region, screenshot
from lapig.lapig_core.rig.frame_lock import LockedWindows, play_locked
from lapig.lapig_core.rig.projector_window import ProjectorWindow

pytestmark = pytest.mark.display


@pytest.fixture(scope="module")
def two_monitors():
    if missing_tools():
        pytest.skip("needs " + "; ".join(missing_tools()))
    with virtual_screens.two_monitors() as env:
        yield env


def test_two_windows_present_their_own_frames_within_one_frame(two_monitors):
    sizes = [(640, 480), (800, 600)]
    rng = np.random.default_rng(3)
    windows = LockedWindows([ProjectorWindow(k, env=two_monitors) for k in range(2)], names=["Left", "Right"])
    try:
        assert [w.size for w in windows.windows] == sizes
        base = [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for w, h in sizes]

        def frame_sets(count):
            for i in range(count):
                yield [np.roll(b, 7 * i, axis=1) for b in base]

        figures = play_locked(windows, frame_sets(30), fps=30)
        image = screenshot(two_monitors)
        last = [np.roll(b, 7 * 29, axis=1) for b in base]
    finally:
        windows.close()
    for k in range(2):  # each monitor shows its own window's last frame, 1:1
        assert np.array_equal(region(image, k), last[k])
    assert figures["frames"] == 30 and figures["max_skew_frames"] <= 1.0, figures
    import cv2

    cv2.imwrite(os.path.join("/tmp", "lapig_two_live_windows.png"), image[..., ::-1])
