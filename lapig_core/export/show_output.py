# SPDX-License-Identifier: GPL-3.0-or-later
"""What a show's video and its image sequence check before they write anything, and the frames they take.

    frame_rate(fps)            -> Fraction: 30, 25, 24, 60, 29.97 (-> 30000/1001), "30000/1001", a Fraction;
                                  0, negative, not finite or not a number: ExportError, one line
    check_size(size)           -> (width, height)
    check_writable(folder)     an existing folder a file can be made in, else ExportError, one line
    check_disk_space(folder, frame_count, frame_bytes, what)
                               the estimate against shutil.disk_usage(folder).free, both figures in the line
    frame_pixels(frame, size, bit_depth, index)
                               a float [0, 1] / uint8 / uint16 (H, W, 3) or (H, W) frame -> uint8 or uint16 RGB
    Cancelled                  raised where the caller's threading.Event is set (checked before every frame)
    RepeatedFrame              a hold (the same array given again) recognised, so it is converted once

No `av` here: the image sequence uses it without PyAV.
"""
from __future__ import annotations

import math
import numbers
import os
import shutil
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np

from ..common.imageio import to_uint8, to_uint16
from .projector_image import ExportError, check_folder

# the NTSC rates: n * 1000 / 1001 frames a second, written as 23.976, 29.97, 59.94, ...
_NTSC = (24, 30, 48, 60, 120)
# room left on the disk beyond the estimate (the file system's own, the sidecar, anything else writing)
DISK_MARGIN_BYTES = 64 * 2**20


class Cancelled(Exception):
    """The export was cancelled: nothing was written under the final name."""


def frame_rate(fps) -> Fraction:
    """The frame rate as an exact fraction; NTSC rates given as decimals (29.97, 23.976, 59.94) become n*1000/1001."""
    if isinstance(fps, str):
        try:
            value = Fraction(fps.strip())
        except (ValueError, ZeroDivisionError):
            raise ExportError(f"frame rate must be a number of frames a second (30, 29.97, 30000/1001), "
                              f"got {fps!r}") from None
    elif isinstance(fps, bool) or not isinstance(fps, numbers.Real):
        raise ExportError(f"frame rate must be a number of frames a second, got {fps!r}")
    elif isinstance(fps, numbers.Rational):
        value = Fraction(fps)
    else:
        if not math.isfinite(float(fps)):
            raise ExportError(f"frame rate must be a finite number of frames a second, got {fps!r}")
        value = None
        for n in _NTSC:
            if abs(float(fps) - n * 1000 / 1001) < 0.0015 * n / 30:
                value = Fraction(n * 1000, 1001)
        if value is None:
            value = Fraction(float(fps)).limit_denominator(1001)
    if value <= 0:
        raise ExportError(f"frame rate must be above 0 frames a second, got {fps!r}")
    if value > 1000:
        raise ExportError(f"frame rate must be at most 1000 frames a second, got {fps!r}")
    return value


def check_size(size) -> tuple[int, int]:
    try:
        width, height = size
    except (TypeError, ValueError):
        raise ExportError(f"size must be (width, height) in pixels, got {size!r}") from None
    for label, value in (("width", width), ("height", height)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not 1 <= value <= 16384:
            raise ExportError(f"frame {label} must be a whole number of pixels from 1 to 16384, got {value!r}")
    return int(width), int(height)


def check_writable(folder: Path) -> None:
    """An existing folder that a file can be made in (tried, not guessed: permissions, read-only mounts)."""
    check_folder(folder)
    try:
        fd, probe = tempfile.mkstemp(prefix=".lapig_probe_", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ExportError(f"cannot write to folder {folder}: {exc.strerror or exc}") from None


def _size(n: float) -> str:
    for unit, scale in (("GB", 2**30), ("MB", 2**20), ("KB", 2**10)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{int(n)} bytes"


def check_disk_space(folder: Path, frame_count: int, frame_bytes: int, what: str) -> int:
    """Refuse, before anything is written, a show the disk cannot hold; returns the estimate in bytes."""
    need = int(frame_count) * int(frame_bytes)
    try:
        free = shutil.disk_usage(folder).free
    except OSError:  # a file system that does not say: the write itself will tell
        return need
    if need + DISK_MARGIN_BYTES > free:
        raise ExportError(f"the show needs up to {_size(need)} ({frame_count} frames of {what}) but {folder} has "
                          f"{_size(free)} free: free some space or choose another drive")
    return need


def frame_pixels(frame, size: tuple[int, int], bit_depth: int, index: int) -> np.ndarray:
    """One frame as the uint8 (bit_depth 8) or uint16 (more) RGB pixels of (height, width, 3)."""
    width, height = size
    try:
        img = np.asarray(frame)
    except Exception as exc:
        raise ExportError(f"frame {index + 1} is not an image array: {exc}") from None
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ExportError(f"frame {index + 1} must be an (H, W, 3) image, got shape {img.shape}")
    if img.shape[:2] != (height, width):
        raise ExportError(f"frame {index + 1} is {img.shape[1]}x{img.shape[0]}, the export is {width}x{height}")
    try:
        return to_uint8(img) if bit_depth == 8 else to_uint16(img)
    except TypeError as exc:
        raise ExportError(f"frame {index + 1}: {exc}") from None


class RepeatedFrame:
    """Whether a frame is the previous one again: the same array object, and the same values on a 32x32 grid of
    samples (a producer that fills one buffer with new frames is not taken for a hold)."""

    def __init__(self):
        self._source, self._sample = None, None

    @staticmethod
    def _grid(frame) -> np.ndarray:
        img = np.asarray(frame)
        return img[::max(1, img.shape[0] // 32), ::max(1, img.shape[1] // 32)] if img.ndim >= 2 else img

    def same(self, frame) -> bool:
        return frame is self._source and np.array_equal(self._grid(frame), self._sample)

    def remember(self, frame) -> None:
        self._source, self._sample = frame, np.array(self._grid(frame), copy=True)


def known_count(frames, frame_count) -> int | None:
    """The frame count the caller promises (frame_count, else len(frames) where it has one)."""
    if frame_count is None:
        try:
            return len(frames)
        except TypeError:
            return None
    if isinstance(frame_count, bool) or not isinstance(frame_count, (int, np.integer)) or frame_count < 1:
        raise ExportError(f"frame count must be a positive whole number, got {frame_count!r}")
    return int(frame_count)
