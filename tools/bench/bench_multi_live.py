"""`python -m lapig_addon bench multi-live --json`: the lock of several projector windows (issue 36's "Live: show
and the panel open every projector's window at once, on its display, frame-locked within one frame").

Two projector windows (rig/projector_window: each its own helper process), full screen on the two monitors of a
virtual X server (tools/virtual_screens: Xvnc, 1280x720 each), play 150 frame sets at 30 fps through
lapig_core/rig/frame_lock.play_locked: each window loads its frame, then one barrier releases every present; each
helper says when its window was updated (time.monotonic, shared by the processes). Where Xvnc, xwd, xdotool or
PySDL2 are missing, on simulated windows (tools/fakes/simulated_window), and `window` says so. A screenshot of both
monitors after the last frame set is written beside the figures (screenshot) and checked against the frames.

Keys: max_skew_frames (the largest spread of one frame set's present times across the windows, in frames; goal
<= 1), mean_skew_frames, p95_skew_ms, max_skew_ms, late_frame_pct (frame sets presented more than half a period
after their time), late_frames, frames, fps, resolution, window, screenshot, screenshot_matches.
"""
from __future__ import annotations

import os
import shutil

import numpy as np

SIZE = (1280, 720)
FPS = 30.0
FRAMES = 150
DISTINCT = 30  # frames made before the play (the lock is measured, not the making of frames)


def _frames(k: int) -> list:
    """Projector k's moving bands, its number written large, DISTINCT frames of them."""
    import cv2

    w, h = SIZE
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    out = []
    for i in range(DISTINCT):
        t = i / DISTINCT * 2 * np.pi
        base = np.stack([0.5 + 0.45 * np.sin(x / 90.0 + t + 2 * k), 0.5 + 0.45 * np.sin(y / 70.0 - t),
                         0.5 + 0.45 * np.sin((x + y) / 120.0 + 3 * k)], -1)
        frame = np.round(base * 255).astype(np.uint8)
        cv2.putText(frame, f"projector {k + 1}  frame {i}", (60, h // 2), cv2.FONT_HERSHEY_SIMPLEX, 2.5,
                    (255, 255, 255), 8, cv2.LINE_AA)
        out.append(frame)
    return out


def run(args) -> dict:
    from ...lapig_core.rig.frame_lock import LockedWindows, play_locked
    from ..fakes.simulated_window import SimulatedWindow
    from .. import virtual_screens as vs

    out = os.path.abspath(args.out)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    frames = [_frames(k) for k in range(2)]
    sets = ([frames[0][i % DISTINCT], frames[1][i % DISTINCT]] for i in range(FRAMES))
    figures = {"fps": FPS, "resolution": f"2 x {SIZE[0]}x{SIZE[1]}", "frames_asked": FRAMES}
    missing = vs.missing_tools()
    if missing:
        windows = LockedWindows([SimulatedWindow(SIZE), SimulatedWindow(SIZE)])
        try:
            played = play_locked(windows, sets, FPS)
        finally:
            windows.close()
        figures["window"] = "simulated (no virtual screen here: " + "; ".join(missing) + ")"
    else:
        import cv2

        from ...lapig_core.rig.projector_window import ProjectorWindow

        monitors = [(0, 0, *SIZE), (SIZE[0], 0, *SIZE)]
        with vs.two_monitors(monitors, (2 * SIZE[0], SIZE[1])) as env:
            windows = LockedWindows([ProjectorWindow(k, env=env) for k in range(2)])
            try:
                played = play_locked(windows, sets, FPS)
                image = vs.screenshot(env, (2 * SIZE[0], SIZE[1]))
            finally:
                windows.close()
        last = (FRAMES - 1) % DISTINCT
        figures["screenshot_matches"] = all(np.array_equal(vs.region(image, k, monitors), frames[k][last])
                                            for k in range(2))
        path = os.path.join(out, "multi_live_screens.png")
        cv2.imwrite(path, image[..., ::-1])
        figures["screenshot"] = path
        figures["window"] = "virtual screen (Xvnc), two monitors 1280x720, one projector window on each"
    figures.update(frames=played["frames"], late_frames=played["late_frames"], late_frame_pct=played["late_frame_pct"],
                   max_skew_frames=played["max_skew_frames"], mean_skew_frames=played["mean_skew_frames"],
                   p95_skew_ms=played["p95_skew_ms"], max_skew_ms=played["max_skew_ms"])
    return figures
