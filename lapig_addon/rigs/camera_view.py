"""The real camera's live picture, for an installer aiming and focusing it.

A worker thread opens the scene's camera, grabs continuously and keeps the newest picture; Blender's side
(blender/live_devices) copies it into an image a few times per second, so the UI never waits for a grab.
The camera is opened, read and closed on that one thread (DirectShow and Media Foundation tie a camera to
the thread that opened it). A failure stops the view and stays as its ``error``, for the panel.

One view at a time (a camera serves one program at a time): the rig's factory stops it before it opens
the camera for a capture or a check (real_rig.release_devices).
"""
from __future__ import annotations

import threading
import time

from ..services.errors import one_line
from ..services.jobs import THREAD_PREFIX

MIN_PERIOD_S = 1 / 30  # a camera that answers at once (a video file, a simulated one) is read no faster


class CameraView:
    def __init__(self, spec, camera_factory=None, min_period_s: float = MIN_PERIOD_S):
        """camera_factory(spec) -> a Camera (lapig_core.rig): the real rig's (rigs/real_rig._camera) in Blender."""
        self.spec, self.min_period_s = spec, min_period_s
        self._factory = camera_factory
        self._lock = threading.Lock()
        self._image = None
        self.frames = 0  # pictures grabbed so far
        self.error = ""
        self.describe: dict = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"{THREAD_PREFIX}camera view", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        camera = None
        try:
            camera = self._factory(self.spec)
            self.describe = camera.describe()
            while not self._stop.is_set():
                started = time.perf_counter()
                image, _ = camera.grab()
                with self._lock:
                    self._image, self.frames = image, self.frames + 1
                rest = self.min_period_s - (time.perf_counter() - started)
                if rest > 0:
                    self._stop.wait(rest)
        except Exception as exc:  # the panel says it; the view is over
            self.error = one_line(exc)
        finally:
            if camera is not None:
                try:
                    camera.close()
                except Exception:  # closing a camera that failed: nothing more to say
                    pass

    def latest(self):
        """(the newest picture, uint8 (H, W, 3) RGB, or None before the first; how many were grabbed)."""
        with self._lock:
            return self._image, self.frames

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stop grabbing and close the camera (waits for the grab in progress, up to timeout_s)."""
        self._stop.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)


_STATE = {"view": None, "error": ""}  # the view of this Blender, and why the last one stopped


def start_view(spec, camera_factory=None) -> CameraView:
    """Start the camera view of ``spec`` (stopping one that runs); ValueError where the spec has no live camera."""
    problem = spec.problem(display=False)
    if problem:
        raise ValueError(problem)
    if spec.tethered_folder.strip():
        raise ValueError("The camera view needs a live camera: a tethered folder gives one picture per shot")
    if camera_factory is None:
        raise ValueError("the camera view was given no way to open the camera")
    stop_view()
    _STATE["view"], _STATE["error"] = CameraView(spec, camera_factory), ""
    return _STATE["view"]


def stop_view(error: str = "", timeout_s: float = 10.0) -> None:
    """Stop the view, if one runs, waiting up to timeout_s for its grab in progress (a camera that hangs
    is closed by its thread once the grab returns); ``error``: why (kept for the panel until the next start)."""
    view, _STATE["view"] = _STATE["view"], None
    if view is not None:
        view.stop(timeout_s)
    if error:
        _STATE["error"] = error


def current_view() -> CameraView | None:
    return _STATE["view"]


def last_error() -> str:
    return _STATE["error"]


def status() -> tuple[str, bool] | None:
    """The panel's line about the view: (text, ok), None while there is none and nothing to say."""
    view = current_view()
    if view is None:
        return (f"Camera view stopped: {last_error()}", False) if last_error() else None
    image, frames = view.latest()
    if image is None:
        return "Camera view: opening the camera", True
    return f"Camera view: {image.shape[1]}x{image.shape[0]}, {frames} pictures", True
