# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture device seam: a projector and a camera looking at the same surface.

The capture sequence (lapig_core.capture.sequence) only talks to this interface, so the same
sequence drives the Cycles studio, a real projector and webcam, or the numpy fake of the tests.

What crosses the seam is what crosses it on a real rig: the projector receives native frames,
(Hp, Wp, 3) RGB whose dtype states their bit depth (uint8: 8 bits, uint16: 16 bits; a device says
which depths it takes in DeviceInfo.frame_bit_depths), and applies its own light transfer (gamma,
black level); the camera returns what it saves, uint8 (Hc, Wc, 3) RGB or float32 in [0, 1], its
response, exposure and noise included.

A device also says whether it must run on Blender's main thread (Cycles renders through bpy; a real
camera must not, or its blocking grab() freezes the UI), how long the projection takes to settle
and how late the camera's frames are: the jobs and the capture sequence plan with them.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..common.closing import Closing

FRAME_DTYPES = {8: np.uint8, 16: np.uint16}


def frame_bit_depth(frame: np.ndarray) -> int:
    """8 or 16: what a projector frame's dtype states; ValueError for any other dtype."""
    for depth, dtype in FRAME_DTYPES.items():
        if frame.dtype == dtype:
            return depth
    raise ValueError(f"a projector frame is uint8 or uint16, got {frame.dtype}")


@dataclass(frozen=True)
class DeviceInfo:
    name: str
    projector_size: tuple[int, int]  # (width, height) of the frames show() takes
    camera_size: tuple[int, int]  # (width, height) of the images grab() returns
    details: dict = field(default_factory=dict)  # recorded in setup.json as they are
    frame_bit_depths: tuple[int, ...] = (8,)  # the frame depths show() takes
    settle_s: float = 0.0  # after show(), before the camera sees the new frame steadily
    latency_s: float = 0.0  # how late a grabbed image is behind the moment it is asked for

    def timing(self) -> dict:
        """What setup.json records of the device's pace and frames."""
        return {"frame_bit_depths": list(self.frame_bit_depths), "settle_s": self.settle_s,
                "latency_s": self.latency_s}


@dataclass(frozen=True)
class GeometryChecks:
    """Ground truth that only a simulated rig knows; a real rig passes none.

    coverage() -> {"projector_on_object": f, "seen_by_camera": f}, shares of the projector's
    frame; exact_projector_to_camera(points (..., 2) native projector pixels) -> camera
    pixels (..., 2), NaN where not seen. Coordinates follow OpenCV.
    """

    surface: str = "the surface"
    aim_hint: str = "aim the projector and the camera at the object"
    coverage: Callable[[], dict] | None = None
    exact_projector_to_camera: Callable[[np.ndarray], np.ndarray] | None = None


class CaptureDevice(Closing):
    """Implement describe(), show() and grab(); override capture() where batches are faster."""

    main_thread = False  # True: every call must come from Blender's main thread (bpy work)

    def geometry_checks(self) -> GeometryChecks:
        """The ground truth this device knows of its rig's geometry: none for a real rig."""
        return GeometryChecks()

    def reserved_rows(self) -> tuple[int, int]:
        """(top, bottom) rows of the projector frame the device uses for itself during a capture (a real
        rig's frame code): the capture marks them invalid."""
        return 0, 0

    def check_frame(self, frame: np.ndarray) -> int:
        """The frame's bit depth; ValueError when this device does not take frames of it."""
        depth = frame_bit_depth(frame)
        accepted = self.describe().frame_bit_depths
        if depth not in accepted:
            raise ValueError(f"{self.describe().name} takes {' or '.join(f'{d}-bit' for d in accepted)} "
                             f"frames, not {depth}-bit ones")
        return depth

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
        """Camera images of a sequence of frames, in order: each shown, left to settle, then grabbed."""
        settle = self.describe().settle_s
        images = []
        for frame in frames:
            self.show(frame)
            if settle > 0:
                time.sleep(settle)
            images.append(self.grab())
        return images

    def vary_noise(self, draw: int) -> None:
        """Make the next captures a new noise draw (draw: a count). A real camera's noise is new with every
        grab; a renderer's sampling noise repeats with its seed, which a simulated device changes here, so
        that repeated captures of one image (closed-loop refinement) differ as a real camera's would."""
