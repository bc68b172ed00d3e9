# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture device seam: a projector and a camera looking at the same surface.

The capture sequence (lapig_core.capture.sequence) only talks to this interface, so the same
sequence drives the Cycles studio, a real projector and webcam, or the numpy fake of the tests.

What crosses the seam is what crosses it on a real rig: the projector receives native 8-bit
frames, uint8 (Hp, Wp, 3) RGB, and applies its own light transfer (gamma, black level); the camera
returns what it saves, uint8 (Hc, Wc, 3) RGB or float32 in [0, 1], its response, exposure and
noise included.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class DeviceInfo:
    name: str
    projector_size: tuple[int, int]  # (width, height) of the frames show() takes
    camera_size: tuple[int, int]  # (width, height) of the images grab() returns
    details: dict = field(default_factory=dict)  # recorded in setup.json as they are


class CaptureDevice:
    """Implement describe(), show() and grab(); override capture() where batches are faster."""

    def describe(self) -> DeviceInfo:
        """What the device is; may change once the exposure is locked."""
        raise NotImplementedError

    def show(self, frame: np.ndarray) -> None:
        """Project one native 8-bit frame until the next show()."""
        raise NotImplementedError

    def grab(self) -> np.ndarray:
        """One camera image of what is projected now."""
        raise NotImplementedError

    def lock_exposure(self, white_frame: np.ndarray) -> None:
        """Fix the camera exposure for the brightest frame of the capture, before any image is
        kept (the camera must not adapt between patterns). By default the exposure is fixed."""

    def capture(self, frames) -> list[np.ndarray]:
        """Camera images of a sequence of frames, in order."""
        images = []
        for frame in frames:
            self.show(frame)
            images.append(self.grab())
        return images

    def close(self) -> None:
        """Release the device; called on success, error and cancel alike."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
