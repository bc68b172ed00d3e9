# SPDX-License-Identifier: GPL-3.0-or-later
"""A projector and a camera in a few lines of numpy optics, for tests without Blender.

The projector lights a textured plane; the camera sees that plane through a known homography
(projector pixels -> camera pixels, OpenCV convention). Each camera pixel centre sees the light of
the one projector pixel it falls in, times the surface albedo, plus ambient light; the camera
adds sensor noise, applies a gamma and saves 8 bits.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..optics.projector_model import frame_sample_points
from .device import CaptureDevice, DeviceInfo


def default_homography(projector_size, camera_size) -> np.ndarray:
    """A slightly rotated, keystoned view of the whole projector frame inside the camera frame."""
    pw, ph = projector_size
    cw, ch = camera_size
    corners = np.float32([[-0.5, -0.5], [pw - 0.5, -0.5], [pw - 0.5, ph - 0.5], [-0.5, ph - 0.5]])
    seen = np.float32([[0.08 * cw, 0.10 * ch], [0.93 * cw, 0.05 * ch], [0.90 * cw, 0.93 * ch], [0.10 * cw, 0.88 * ch]])
    return cv2.getPerspectiveTransform(corners, seen).astype(np.float64)


def default_albedo(camera_size, seed=0) -> np.ndarray:
    """A smooth colour texture, albedo 0.35..0.95."""
    cw, ch = camera_size
    coarse = np.random.default_rng(seed).random((4, 5, 3)).astype(np.float32)
    return 0.35 + 0.6 * cv2.resize(coarse, (cw, ch), interpolation=cv2.INTER_CUBIC).clip(0, 1)


class FakeDevice(CaptureDevice):
    def __init__(self, projector_size=(64, 48), camera_size=(160, 120), homography=None, albedo=None,
                 ambient=0.05, projector_gamma=2.2, camera_gamma=2.2, gain=0.85, noise=0.003, seed=0):
        self.projector_size, self.camera_size = tuple(projector_size), tuple(camera_size)
        self.homography = default_homography(projector_size, camera_size) if homography is None \
            else np.asarray(homography, np.float64)
        self.albedo = default_albedo(camera_size, seed) if albedo is None else albedo
        self.ambient, self.projector_gamma, self.camera_gamma = ambient, projector_gamma, camera_gamma
        self.gain, self.noise = gain, noise
        self.rng = np.random.default_rng(seed)
        self._light = None

    def describe(self) -> DeviceInfo:
        pw, ph = self.projector_size
        cw, ch = self.camera_size
        return DeviceInfo("numpy fake (homography)", self.projector_size, self.camera_size,
                          {"projector": {"width": pw, "height": ph, "gamma": self.projector_gamma},
                           "camera": {"resolution": [cw, ch], "gamma": self.camera_gamma, "gain": self.gain},
                           "homography": self.homography.tolist()})

    def show(self, frame):
        pw, ph = self.projector_size
        if frame.dtype != np.uint8 or frame.shape != (ph, pw, 3):
            raise ValueError(f"a projector frame must be uint8 ({ph}, {pw}, 3), got {frame.dtype} {frame.shape}")
        self._light = np.power(frame.astype(np.float32) / 255, self.projector_gamma)

    def grab(self):
        lit = cv2.warpPerspective(self._light, self.homography, self.camera_size, flags=cv2.INTER_NEAREST,
                                  borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        radiance = self.gain * self.albedo * (lit + self.ambient)
        radiance += self.noise * self.rng.standard_normal(radiance.shape, dtype=np.float32)
        return np.round(np.power(radiance.clip(0, 1), 1 / self.camera_gamma) * 255).astype(np.uint8)

    # ground truth, for GeometryChecks
    def exact_projector_to_camera(self, points) -> np.ndarray:
        points = np.asarray(points, np.float64)
        cam = cv2.perspectiveTransform(points.reshape(-1, 1, 2), self.homography).reshape(points.shape)
        cw, ch = self.camera_size
        outside = (cam[..., 0] < -0.5) | (cam[..., 0] > cw - 0.5) | (cam[..., 1] < -0.5) | (cam[..., 1] > ch - 0.5)
        cam[outside] = np.nan
        return cam

    def coverage(self, grid=24) -> dict:
        """The plane is everywhere: the share of the projector frame the camera sees."""
        seen = np.isfinite(self.exact_projector_to_camera(frame_sample_points(*self.projector_size, grid))).all(-1)
        return {"projector_on_object": 1.0, "seen_by_camera": float(seen.mean())}
