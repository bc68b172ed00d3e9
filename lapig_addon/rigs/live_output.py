"""Live output: the current look on the real projector's window (services/ports.ResultSink), and a
crossfade between two looks played at a set frame rate.

The window (lapig_core.rig.projector_window) stays open between looks: every Generate that has this
sink among its seams replaces the picture, so an artist types a new prompt and sees it on the object.
Esc in the window closes it; the next show() then says so.
"""
from __future__ import annotations

import time

import numpy as np

from ...lapig_core.rig import RigError
from ..services.ports import ProjectorFrame


def window_pixels(frame: ProjectorFrame, size) -> np.ndarray:
    """The 8-bit pixels the window shows of a frame: the quantised_frame that Export writes (a 16-bit
    export shows its top 8 bits); RigError where the look was made for another resolution."""
    if (frame.width, frame.height) != tuple(size):
        raise RigError(f"the look is {frame.width}x{frame.height} but the projector's display is "
                       f"{size[0]}x{size[1]}: set the projector's resolution to the display's, then Generate")
    pixels = frame.pixels
    if pixels.dtype == np.uint16:
        pixels = ((pixels.astype(np.uint32) + 128) // 257).astype(np.uint8)
    return pixels


class ProjectorWindowSink:
    """Shows each generated frame on an open projector window; `shown_at` is when the last one was on screen.

    A look that cannot be shown (the window was closed, or it is another resolution) does not undo the
    Generate that made it: `problem` says why, for the panel and the command line."""

    def __init__(self, window):
        self.window = window
        self.shown_at: float | None = None
        self.problem = ""

    def show(self, frame: ProjectorFrame) -> None:
        try:
            self.shown_at = self.window.show(window_pixels(frame, self.window.size))
            self.problem = ""
        except RigError as exc:
            self.problem = str(exc)


_LIVE: list = []  # the live windows open in this Blender (or command), newest last


def open_live(display, window_factory=None) -> ProjectorWindowSink:
    """Open the projector window on ``display`` (closing a live one first) and make it a sink of every job."""
    close_live()
    if window_factory is None:
        from ...lapig_core.rig.projector_window import ProjectorWindow as window_factory
    sink = ProjectorWindowSink(window_factory(int(display) if str(display).strip().isdigit() else display))
    _LIVE.append(sink)
    return sink


def close_live() -> None:
    while _LIVE:
        _LIVE.pop().window.close()


def open_sinks() -> tuple:
    """The live windows still open (one closed with Esc is forgotten)."""
    _LIVE[:] = [sink for sink in _LIVE if getattr(sink.window, "is_open", True)]
    return tuple(_LIVE)


def play(window, frames, fps: float = 30.0, clock=time, on_frame=None) -> dict:
    """Show ``frames`` (8- or 16-bit (H, W, 3) pixels) one per 1/fps seconds; {"frames", "seconds",
    "late_frames"}: a frame shown more than half a period after its time was late (a slow machine or a
    large frame)."""
    period = 1.0 / float(fps)
    late = shown = 0
    ahead = _ahead(frames)  # the next frames are made while this one is on screen
    start = clock.perf_counter()
    for i, pixels in enumerate(ahead):
        due = start + i * period
        wait = due - clock.perf_counter()
        if wait > 0:
            clock.sleep(wait)
        if pixels.dtype == np.uint16:
            pixels = ((pixels.astype(np.uint32) + 128) // 257).astype(np.uint8)
        on_screen = window.show(pixels)
        late += on_screen - due > period / 2
        shown += 1
        if on_frame is not None:
            on_frame(i, on_screen)
    return {"frames": shown, "seconds": round(clock.perf_counter() - start, 3), "late_frames": int(late)}


def _ahead(frames, depth: int = 4):
    """``frames`` made on a worker thread, up to ``depth`` ahead of the one being shown."""
    import queue
    import threading

    made: queue.Queue = queue.Queue(maxsize=depth)
    done, failed = object(), []
    stop = threading.Event()

    def put(item) -> bool:
        while not stop.is_set():  # a player that stopped early takes nothing more
            try:
                made.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def produce():
        try:
            for frame in frames:
                if not put(frame):
                    return
        except Exception as exc:  # handed to the player
            failed.append(exc)
        put(done)

    worker = threading.Thread(target=produce, name="LAPIG: crossfade frames", daemon=True)
    worker.start()
    try:
        while True:
            frame = made.get()
            if frame is done:
                if failed:
                    raise failed[0]
                return
            yield frame
    finally:
        stop.set()
