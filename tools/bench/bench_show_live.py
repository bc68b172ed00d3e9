"""`python -m lapig_addon bench show-live --json`: `show --timeline`'s pace (issue 38's live_late_frame_pct).

A show of three looks at 1920x1080, 30 fps (each held 1 s, dissolves of 1 s: 5 s, 150 frames), played by Play
Show's job (rigs/live_output.ShowPlayJob: the frames made ahead on a worker thread, each shown at its time) on the
projector window, full screen on the second monitor of a virtual two-monitor X server (tools/virtual_screens:
Xvnc). Where Xvnc, xwd, xdotool or PySDL2 are missing, on a simulated window (lapig_core/rig/simulated's screen on
the real clock), and `window` says so. The looks are stored results (the frames are holds and linear-light
dissolves of their images: what lapig_core/show makes of holds and dissolves too); no capture is needed.

Keys: live_late_frame_pct (goal <= 1 %), late_frames, frames, seconds, window, frame_make_ms (median time to make a
dissolve frame, alone), show_fps.
"""
from __future__ import annotations

import os
import shutil
import time

import numpy as np

SIZE = (1920, 1080)
FPS = 30.0


def _looks(out) -> list:
    """Three smooth coloured results, stored at the projector's native size."""
    from ...lapig_core.export.result_files import write_result

    h, w = SIZE[1], SIZE[0]
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    folders = []
    for i in range(3):
        phase = i * 2.1
        image = np.stack([0.5 + 0.45 * np.sin(x / 170.0 + phase), 0.5 + 0.45 * np.sin(y / 130.0 + 2 * phase),
                          0.5 + 0.45 * np.sin((x + y) / 210.0 + 3 * phase)], -1).astype(np.float32)
        folders.append(str(write_result(os.path.join(out, f"look{i}"), {"projector": image}, {"prompt": f"look {i}"})))
    return folders


def _source(folders):
    from ...lapig_addon.services.show.show_plan import ShowLook, ShowPlan
    from ...lapig_addon.services.show.show_source import ShowSource
    from ...lapig_core.optics.projector_model import ProjectorModel

    plan = ShowPlan(tuple(ShowLook(f, name=f"look {i}", hold_s=1.0, transition_s=1.0) for i, f in enumerate(folders)),
                    fps=FPS)
    return ShowSource(plan, projectors=(ProjectorModel(width=SIZE[0], height=SIZE[1]),), bit_depth=8,
                      use_producer=False, compensated_dissolves=False)


def _frame_make_ms(source) -> float:
    """The median time to make one dissolve frame, the worker thread alone."""
    from ...lapig_addon.services.show import show_source

    dissolve = next(s for s in source.plan.segments() if s.kind == "dissolve")
    times = []
    frames = show_source.frames(source, start=dissolve.first, stop=dissolve.first + 6)
    t = time.perf_counter()
    for _ in frames:
        now = time.perf_counter()
        times.append(now - t)
        t = now
    return round(1000 * float(np.median(times[1:])), 1)


def _play(source, window) -> dict:
    from ...lapig_addon.rigs.live_output import ProjectorWindowSink, ShowPlayJob

    return ShowPlayJob(ProjectorWindowSink(window), source).run_to_completion()


def run(args) -> dict:
    out = os.path.abspath(args.out)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    source = _source(_looks(out))
    figures = {"frames_in_show": source.frame_count, "fps": FPS, "resolution": f"{SIZE[0]}x{SIZE[1]}",
               "frame_make_ms": _frame_make_ms(source)}
    from .. import virtual_screens as vs

    missing = vs.missing_tools()
    if missing:
        from ...lapig_core.rig.simulated import SimulatedScreen

        played = _play(source, SimulatedScreen(SIZE))
        figures["window"] = "simulated (no virtual screen here: " + "; ".join(missing) + ")"
    else:
        from ...lapig_core.rig.projector_window import ProjectorWindow

        monitors, root = [(0, 0, 640, 480), (640, 0, SIZE[0], SIZE[1])], (640 + SIZE[0], SIZE[1])
        with vs.two_monitors(monitors, root) as env:
            window = ProjectorWindow(1, env=env)
            try:
                played = _play(source, window)
            finally:
                window.close()
        figures["window"] = "virtual screen (Xvnc), second monitor 1920x1080"
    figures.update(frames=played["frames"], seconds=played["seconds"], late_frames=played["late_frames"],
                   live_late_frame_pct=played["late_frame_pct"],
                   show_fps=round(played["frames"] / played["seconds"], 2) if played["seconds"] else None)
    return figures
