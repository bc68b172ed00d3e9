# SPDX-License-Identifier: GPL-3.0-or-later
"""A tethered camera: each new image file in a watched folder is the next frame.

DSLR tethering programs (and ``gphoto2 --capture-tethered``) save every shot into a folder; this
camera watches it. Files present when it starts are not frames. New files are frames in the order
they arrive (those that arrive between two looks at the folder: in name order), each read once its
size has stopped changing for ``settle_s`` and, for a PNG or a JPEG, once its end marker is there,
so a file still being written is never read half-written. JPEG, PNG and TIFF are read (a RAW file
beside its JPEG is ignored); the sensor's pixel grid is kept (EXIF rotation is not applied, so
every frame has the same geometry even when the camera's orientation sensor flips).

Bit depth: the Camera interface returns uint8, so a 16-bit file (a TIFF or PNG from a raw
converter) is rounded to 8 bits (v / 257); ``keep_16_bit=True`` returns every frame as float32 in
[0, 1] instead, which the capture device seam also takes, to keep the file's precision.

A ``trigger`` (gphoto.GphotoTrigger, or any callable) is called at the start of each grab(): a shot
on demand before the wait for its file.
"""
from __future__ import annotations

import os
import threading
import time
from collections import deque
from pathlib import Path

import numpy as np

from ..common.closing import Closing
from ..common.imageio import decode_image, to_float, to_uint8

from . import RigError

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".tif", ".tiff")
POLL_S = 0.05
_PNG = b"\x89PNG\r\n\x1a\n"
_JPEG = b"\xff\xd8\xff"
NO_END_MARKER_GRACE_S = 2.0  # a JPEG without its end marker, unchanged this long and decodable, is read


def _is_image_name(name: str) -> bool:
    return not name.startswith((".", "~")) and name.lower().endswith(IMAGE_SUFFIXES)


def ends_complete(data: bytes) -> bool | None:
    """Whether a PNG or JPEG file's bytes end with its end marker (None: a format without one)."""
    if data.startswith(_PNG):
        return data[-12:-8] == b"\x00\x00\x00\x00" and data[-8:-4] == b"IEND"
    if data.startswith(_JPEG):
        return data[-4096:].rstrip(b"\x00").endswith(b"\xff\xd9")
    return None


def decode_frame(data: bytes, keep_16_bit: bool = False) -> tuple[np.ndarray, int] | None:
    """(RGB image, the file's bit depth) of an image file's bytes; None when they do not decode."""
    rgb = decode_image(data, exif_turn=False, alpha_over_black=False)
    if rgb is None:
        return None
    depth = {np.dtype(np.uint8): 8, np.dtype(np.uint16): 16}.get(rgb.dtype, 32)
    return (to_float(rgb) if keep_16_bit else to_uint8(rgb)), depth


class TetheredFolderCamera(Closing):
    """The Camera interface over a folder a tethering program saves into (see the module doc).

    grab() waits up to ``timeout_s`` for the next new file and returns it with the
    time.perf_counter() at which it was first seen in the folder (its arrival)."""

    def __init__(self, folder, timeout_s: float = 30.0, settle_s: float = 0.5, trigger=None,
                 keep_16_bit: bool = False):
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise RigError(f"the tethered folder {self.folder} does not exist: create it and set the "
                           f"tethering program to save there")
        self.timeout_s = float(timeout_s)
        self.settle_s = float(settle_s)
        self.trigger = trigger
        self.keep_16_bit = keep_16_bit
        self._at_start = self._listing()
        self._seen = set(self._at_start)
        self._queue: deque[tuple[str, float]] = deque()
        self._size: tuple[int, int] | None = None
        self._depths: dict[str, int] = {}
        self._frames = 0
        self._closed = threading.Event()

    # -- the folder -----------------------------------------------------------------------------
    def _gone(self) -> RigError:
        return RigError(f"the tethered folder {self.folder} is gone: it was deleted, renamed or its drive "
                        f"unmounted; restore it (or choose another folder) and start the capture again")

    def _listing(self) -> list[str]:
        try:
            with os.scandir(self.folder) as entries:
                return [entry.name for entry in entries if _is_image_name(entry.name) and entry.is_file()]
        except (FileNotFoundError, NotADirectoryError):
            raise self._gone() from None
        except OSError as exc:
            raise RigError(f"cannot read the tethered folder {self.folder}: {exc}") from exc

    def _poll(self) -> None:
        now = time.perf_counter()
        for name in sorted(name for name in self._listing() if name not in self._seen):
            self._seen.add(name)
            self._queue.append((name, now))

    def _check_open(self) -> None:
        if self._closed.is_set():
            raise RigError(f"the tethered camera on {self.folder} is closed")

    # -- reading one file -----------------------------------------------------------------------
    def _read_when_written(self, path: Path):
        """The decoded file once it is whole; None when it vanished (a temporary name renamed)."""
        give_up = time.perf_counter() + self.timeout_s
        last, steady_since, retry_at, problem = None, 0.0, 0.0, "it is still being written"
        while True:
            self._check_open()
            if not self.folder.is_dir():
                raise self._gone()
            try:
                stat = path.stat()
            except FileNotFoundError:
                return None
            except OSError as exc:  # Windows: locked by the program writing it
                stat, problem = None, f"it cannot be read: {exc}"
            now = time.perf_counter()
            signature = (stat.st_size, stat.st_mtime_ns) if stat else None
            if stat is None or signature != last:
                last, steady_since = signature, now
            elif now - steady_since >= self.settle_s and stat.st_size > 0 and now >= retry_at:
                try:
                    data = path.read_bytes()
                except FileNotFoundError:
                    return None
                except OSError as exc:
                    data, problem = None, f"it cannot be read: {exc}"
                if data is not None and len(data) == stat.st_size:
                    decoded, problem = self._decode_whole(data, now - steady_since)
                    if decoded is not None:
                        return decoded
                retry_at = now + self.settle_s  # read it again after a change or another settle time
            if now > give_up:
                raise RigError(f"{path} stayed unreadable for {self.timeout_s:g} s ({problem}): check that the "
                               f"tethering program saves JPEG, PNG or TIFF there; remove the file and shoot again")
            time.sleep(min(POLL_S, max(self.settle_s / 4, 0.005)))

    def _decode_whole(self, data: bytes, steady_s: float):
        """(the decoded frame, None), or (None, why not yet) for a file's settled bytes."""
        if ends_complete(data) is False and steady_s < NO_END_MARKER_GRACE_S:
            return None, "it ends before its end marker (truncated)"
        decoded = decode_frame(data, self.keep_16_bit)
        return (decoded, None) if decoded is not None else (None, "it does not decode as an image")

    # -- the Camera interface -------------------------------------------------------------------
    @property
    def size(self) -> tuple[int, int]:
        """The last frame's (width, height); before the first, the newest image the folder held at
        start; RigError when there is neither."""
        if self._size is None:
            for name in sorted(self._at_start, key=self._mtime, reverse=True):
                decoded = decode_frame(self._bytes(name))
                if decoded is not None:
                    self._size = (decoded[0].shape[1], decoded[0].shape[0])
                    break
            else:
                raise RigError(f"the size of the tethered camera on {self.folder} is known once it saved an "
                               f"image: take one shot (or grab() once) first")
        return self._size

    def _mtime(self, name: str) -> int:
        try:
            return (self.folder / name).stat().st_mtime_ns
        except OSError:
            return 0

    def _bytes(self, name: str) -> bytes:
        try:
            return (self.folder / name).read_bytes()
        except OSError:
            return b""

    def grab(self) -> tuple[np.ndarray, float]:
        """The next new image (uint8 (H, W, 3) RGB; float32 with keep_16_bit) and when it arrived."""
        self._check_open()
        if self.trigger is not None:
            self.trigger()
        deadline = time.perf_counter() + self.timeout_s
        while True:
            self._check_open()
            self._poll()
            while self._queue:
                name, arrived = self._queue.popleft()
                decoded = self._read_when_written(self.folder / name)
                if decoded is not None:
                    image, depth = decoded
                    self._frames += 1
                    self._depths[str(depth)] = self._depths.get(str(depth), 0) + 1
                    self._size = (image.shape[1], image.shape[0])
                    return image, arrived
            if time.perf_counter() > deadline:
                raise RigError(f"no new image in {self.folder} for {self.timeout_s:g} s: is the tethering "
                               f"program saving there (and the camera taking pictures)?")
            time.sleep(POLL_S)

    def flush(self) -> None:
        """Forget the files that arrived before now: the next grab() waits for a newer one."""
        self._check_open()
        self._poll()
        self._queue.clear()

    def describe(self) -> dict:
        return {"kind": "tethered_folder", "folder": str(self.folder), "timeout_s": self.timeout_s,
                "settle_s": self.settle_s, "size": list(self._size) if self._size else None,
                "frames_read": self._frames, "file_bit_depths": dict(self._depths),
                "output": "float32 in [0, 1]" if self.keep_16_bit else "uint8 (16-bit files rounded to 8 bits)",
                "exif_rotation": "not applied (the sensor's pixel grid)",
                "trigger": self.trigger.describe() if hasattr(self.trigger, "describe") else
                           (None if self.trigger is None else repr(self.trigger))}

    def close(self) -> None:
        self._closed.set()
