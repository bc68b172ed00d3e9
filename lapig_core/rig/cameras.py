# SPDX-License-Identifier: GPL-3.0-or-later
"""Cameras of a real rig (the Camera interface of lapig_core.rig).

- ``OpenCVCamera``: cv2.VideoCapture of a camera index, a stream URL (rtsp/http) or a video file,
  its automatic controls locked where the backend allows and every value read back
  (camera_controls); the source, the backend and the frames' conversion in camera_sources.
- ``TetheredFolderCamera`` (tethered.py) and ``GphotoTrigger`` (gphoto.py): each new image file in
  a watched folder is the next frame (DSLR tethering programs, gphoto2).
- ``list_cameras()``: the indices that open.
"""
from __future__ import annotations

import threading
import time

import cv2
import numpy as np

from ..common.closing import Closing
from . import RigError
from .camera_controls import lock_controls, not_locked, quiet_opencv, reread, set_control
from .camera_sources import (BACKENDS, backend_label, native_backend, parse_source, redacted, resolve_backend,
                             to_rgb)
from .gphoto import GphotoTrigger
from .tethered import TetheredFolderCamera

__all__ = ["OpenCVCamera", "TetheredFolderCamera", "GphotoTrigger", "list_cameras", "BACKENDS",
           "native_backend", "resolve_backend", "to_rgb"]

READ_TRIES = 3  # of a live camera, before it is said to have stopped
READ_RETRY_S = 0.1
FLUSH_MAX_FRAMES = 30
FLUSH_MIN_S = 0.2


def _open_capture(source, api: int, params: list[int]):
    """cv2.VideoCapture opened quietly (the caller says what went wrong); tests replace it."""
    with quiet_opencv():
        return cv2.VideoCapture(source, api, params) if params else cv2.VideoCapture(source, api)


class OpenCVCamera(Closing):
    """A camera through cv2.VideoCapture: an index, a stream URL or a video file.

    Every automatic control is turned off (exposure, focus, white balance), then the values asked
    are set (None: keep what the camera has), the resolution first and CAP_PROP_BUFFERSIZE last;
    each is read back and ``describe()["settings"]`` records it as asked and as read. A control that
    did not take is listed in ``describe()["not_locked"]``, never an error. Exposure, gain, focus and
    white balance are in the backend's units (see camera_controls).

    ``open_timeout_s`` bounds opening and reading a URL or a file (FFMPEG's timeouts); a local camera
    opens on the calling thread, since DirectShow and Media Foundation tie it to that thread.
    """

    def __init__(self, source, backend: str = "auto", width: int | None = None, height: int | None = None,
                 exposure: float | None = None, gain: float | None = None, focus: float | None = None,
                 white_balance: float | None = None, buffer_size: int | None = 1,
                 open_timeout_s: float = 10.0):
        self._kind, self._source = parse_source(source)
        self._backend_asked = backend
        self._api = resolve_backend(backend, self._kind)
        self._lock = threading.Lock()
        self._frames = 0
        self._flush_record: dict = {}
        if self._kind == "file" and not self._source.is_file():
            raise RigError(f"no video file at {self._source}: check the path")
        self._cap = self._open(open_timeout_s)
        try:
            self._backend_name = self._cap.getBackendName()
        except cv2.error:
            self._backend_name = str(backend)
        asked = {"width": width, "height": height, "exposure": exposure, "gain": gain, "focus": focus,
                 "white_balance": white_balance, "buffer_size": buffer_size}
        try:  # a file takes none of them: the same record says so, and the tests read it
            self._settings = lock_controls(self._cap, self._api, asked)
            self._size = self._read_size()
        except BaseException:
            self.close()
            raise

    # -- opening --------------------------------------------------------------------------------
    def label(self) -> str:
        if self._kind == "index":
            return f"camera {self._source}"
        if self._kind == "url":
            return f"stream {redacted(self._source)}"
        return f"video file {self._source}"

    def _open(self, timeout_s: float):
        params = []
        if self._api == cv2.CAP_FFMPEG and timeout_s:
            ms = int(max(timeout_s, 0.001) * 1000)
            params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms]
        source = str(self._source) if self._kind == "file" else self._source
        try:
            cap = _open_capture(source, self._api, params)
        except cv2.error as exc:
            raise RigError(f"OpenCV could not open {self.label()}: {exc.err or exc}") from exc
        if cap is not None and cap.isOpened():
            return cap
        if cap is not None:
            cap.release()
        backend = backend_label(self._api)
        if self._kind == "index":
            raise RigError(f"no camera answers at index {self._source} ({backend}): check that it is plugged "
                           f"in and no other program uses it; list_cameras() shows the indices that open")
        if self._kind == "url":
            raise RigError(f"cannot open {self.label()} within {timeout_s:g} s: check the address, the network "
                           f"and that the camera streams at that path")
        hint = "" if self._api == cv2.CAP_FFMPEG else " (backend='auto' opens files with FFMPEG)"
        raise RigError(f"cannot open {self.label()} with {backend}: is it a video OpenCV can decode?{hint}")

    def _read_size(self) -> tuple[int, int]:
        width = self._settings["width"]["read_back"] or 0
        height = self._settings["height"]["read_back"] or 0
        if width > 0 and height > 0:
            return int(round(width)), int(round(height))
        if self._kind == "file":
            return 0, 0  # known from the first frame
        image, _ = self.grab()  # a live camera that does not say: one frame tells
        return image.shape[1], image.shape[0]

    # -- the Camera interface -------------------------------------------------------------------
    @property
    def size(self) -> tuple[int, int]:
        return self._size

    @property
    def live(self) -> bool:
        return self._kind != "file"

    def grab(self) -> tuple[np.ndarray, float]:
        """The next frame, uint8 (H, W, 3) RGB, and time.perf_counter() when it was read."""
        tries = READ_TRIES if self.live else 1
        with self._lock:
            if self._cap is None:
                raise RigError(f"{self.label()} is closed")
            for attempt in range(tries):
                try:
                    ok, frame = self._cap.read()
                except cv2.error:
                    ok, frame = False, None
                read_at = time.perf_counter()
                if ok and frame is not None and frame.size:
                    break
                if attempt + 1 < tries:
                    time.sleep(READ_RETRY_S)
            else:
                raise self._stopped(tries)
            self._frames += 1
        image = to_rgb(frame)
        self._size = (image.shape[1], image.shape[0])
        return image, read_at

    def _stopped(self, tries: int) -> RigError:
        if not self.live:
            return RigError(f"the camera stopped answering: {self.label()} has no frame after the "
                            f"{self._frames} it gave (it has ended); use a longer video or a live camera")
        return RigError(f"the camera stopped answering (unplugged?): {self.label()} gave no frame in {tries} "
                        f"tries; check its cable and that no other program took it, then open it again")

    def flush(self) -> None:
        """Drop the frames a live camera buffered: grab and drop until a grab has to wait for a new
        frame (half a frame period or more), so the next grab() is of now. A file is not live: no-op."""
        if not self.live:
            return
        dropped, failed, waited = 0, 0, 0.0
        with self._lock:
            if self._cap is None:
                raise RigError(f"{self.label()} is closed")
            fps = self._cap.get(cv2.CAP_PROP_FPS)
            period = 1.0 / fps if 1.0 <= fps <= 1000.0 else 1.0 / 30.0
            deadline = time.perf_counter() + max(FLUSH_MIN_S, 4 * period)
            while dropped < FLUSH_MAX_FRAMES:
                start = time.perf_counter()
                try:
                    ok = self._cap.grab()
                except cv2.error:
                    ok = False
                waited = time.perf_counter() - start
                if not ok:
                    failed += 1
                    if failed >= READ_TRIES:
                        raise self._stopped(failed)
                    time.sleep(READ_RETRY_S)
                    continue
                dropped, failed = dropped + 1, 0
                if waited >= 0.5 * period or time.perf_counter() > deadline:
                    break
        self._flush_record = {"frames_dropped": dropped, "last_wait_s": round(waited, 4),
                              "frame_period_s": round(period, 4), "drained": waited >= 0.5 * period}

    def set_control(self, name: str, value) -> dict:
        """Change one control after opening (e.g. the exposure a rig settles on); its record as set."""
        with self._lock:
            if self._cap is None:
                raise RigError(f"{self.label()} is closed")
            self._settings[name] = set_control(self._cap, self._api, name, value)
            reread(self._cap, self._settings)
        return dict(self._settings[name])

    def describe(self) -> dict:
        source = redacted(self._source) if self._kind == "url" else str(self._source)
        info = {"kind": "opencv", "source": source, "source_kind": self._kind, "backend": self._backend_name,
                "backend_asked": self._backend_asked, "size": list(self._size), "opencv": cv2.__version__,
                "settings": {name: dict(entry) for name, entry in self._settings.items()},
                "not_locked": not_locked(self._settings), "frames_read": self._frames,
                "flush": "none (a file is not live)" if not self.live else
                         {"method": "grab and drop until a grab waits for a new frame", **self._flush_record}}
        if self._cap is not None:
            info["fps"] = float(self._cap.get(cv2.CAP_PROP_FPS))
        return info

    def close(self) -> None:
        with self._lock:
            if self._cap is not None:
                self._cap.release()
                self._cap = None

    @staticmethod
    def list_cameras(max_index: int = 8, backend: str = "auto") -> list[dict]:
        """The camera indices that open (the module's list_cameras)."""
        return list_cameras(max_index, backend)


def list_cameras(max_index: int = 8, backend: str = "auto") -> list[dict]:
    """The camera indices 0..max_index-1 that open, quietly: [{index, backend, width, height}]."""
    api = resolve_backend(backend, "index")
    found = []
    for index in range(max_index):
        try:
            cap = _open_capture(index, api, [])
        except cv2.error:
            continue
        try:
            if cap is not None and cap.isOpened():
                found.append({"index": index, "backend": cap.getBackendName(),
                              "width": int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
                              "height": int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))})
        finally:
            if cap is not None:
                cap.release()
    return found
