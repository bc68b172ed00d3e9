# SPDX-License-Identifier: GPL-3.0-or-later
"""K projectors and one camera in a few lines of numpy optics, for tests without Blender.

Each projector lights a textured surface; the camera sees its frame through its own homography
(projector pixels -> camera pixels, OpenCV convention), as capture.fake_device does for one. At a
camera pixel the projectors' light adds up:

    C = f_c( albedo * (sum_k gain_k * incidence_k * mix_k . warp_k(f_p,k(P_k) + black_k) + ambient) ) + noise

f_p,k(P) = P ** gamma_k, f_c(L) = L ** (1 / gamma_c); mix_k is the projector's channel crosstalk as the
camera sees it; incidence_k (a camera-space map, the cos of the angle the light meets the surface at)
dims the regions a projector only grazes; black_k = 1 / contrast_k is the light a projector leaks
showing black. The rig tells its ground truth (each projector's camera map, M_k, the offset, the
blacks) for tests.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

from ...lapig_core.capture.fake_device import default_albedo
from ...lapig_core.photometric.classical import _as_float_images
from ...lapig_core.multi.camera_map import CameraMap
from ...lapig_core.multi.capture import MultiDeviceInfo, MultiProjectorDevice
from ...lapig_core.multi.frames import smooth_frames  # noqa: F401 (the tests' frames, and the capture's)

_MIX = np.array([[0.90, 0.08, 0.02], [0.06, 0.88, 0.06], [0.02, 0.10, 0.88]])


@dataclass(eq=False)
class FakeProjector:
    """size: (width, height); homography: projector pixels -> camera pixels; incidence: camera-space
    (H,W) factor in (0,1], None for 1; mix: (3,3) rows = camera channels, None for a mild crosstalk."""

    size: tuple[int, int]
    homography: np.ndarray
    gamma: float = 2.2
    gain: float = 0.6
    contrast: float = 1000.0
    incidence: np.ndarray | None = None
    mix: np.ndarray | None = None


class FakeRig:
    """A camera (`camera_size` (width, height)) watching an object (`object_mask`, default an ellipse)
    that K FakeProjectors light. `capture(frames)` is the camera's uint8 image of one frame per projector."""

    def __init__(self, projectors: Sequence[FakeProjector], camera_size=(64, 48), camera_gamma=2.2,
                 albedo=None, ambient=0.02, object_mask=None, noise=0.0, seed=0):
        self.projectors = list(projectors)
        self.camera_size = tuple(camera_size)
        cw, ch = self.camera_size
        self.camera_gamma, self.ambient, self.noise = camera_gamma, ambient, noise
        self.object_mask = _ellipse(cw, ch) if object_mask is None else np.asarray(object_mask, bool)
        albedo = default_albedo(self.camera_size, seed) if albedo is None else np.asarray(albedo, np.float32)
        self.albedo = (albedo * self.object_mask[..., None]).astype(np.float32)  # nothing to see off the object
        self.rng = np.random.default_rng(seed)
        self._maps = [self._exact_map(p) for p in self.projectors]

    @property
    def count(self) -> int:
        return len(self.projectors)

    # ----------------------------------------------------------------- capture
    def capture(self, frames: Sequence[np.ndarray | None]) -> np.ndarray:
        """One frame per projector ((h,w,3) uint8 or float in [0,1]; None: black) -> (H,W,3) uint8."""
        if len(frames) != self.count:
            raise ValueError(f"one frame per projector: {self.count}, got {len(frames)}")
        light = np.full(self.albedo.shape, self.ambient, np.float32)
        for k, (proj, frame) in enumerate(zip(self.projectors, frames)):
            w, h = proj.size
            if frame is not None and np.shape(frame) != (h, w, 3):
                raise ValueError(f"projector {k}'s frame must be ({h}, {w}, 3), got {np.shape(frame)}")
            emitted = np.zeros((h, w, 3), np.float32) if frame is None else _as_float_images(frame, "frame")
            emitted = np.power(emitted, np.float32(proj.gamma)) + np.float32(1.0 / proj.contrast)
            seen = cv2.warpPerspective(emitted, proj.homography, self.camera_size, flags=cv2.INTER_LINEAR,
                                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
            light += self._scale(k)[..., None] * np.einsum("ij,hwj->hwi", self._mix(k), seen)
        radiance = self.albedo * light
        encoded = np.power(np.clip(radiance, 0.0, 1.0), np.float32(1.0 / self.camera_gamma))
        if self.noise > 0:
            encoded = encoded + self.noise * self.rng.standard_normal(encoded.shape).astype(np.float32)
        return np.round(np.clip(encoded, 0.0, 1.0) * 255).astype(np.uint8)

    def capture_alone(self, frames: Sequence[np.ndarray]) -> tuple[list, np.ndarray]:
        """frames[k]: (N_k,h,w,3) images for projector k -> (captures[k] (N_k,H,W,3) of each shown alone,
        the others black; the capture of all black), what JointModel.fit takes."""
        captures = []
        for k, images in enumerate(frames):
            shown = [None] * self.count
            captures.append(np.stack([self.capture(shown[:k] + [img] + shown[k + 1:]) for img in images]))
        return captures, self.capture([None] * self.count)

    # ------------------------------------------------------------ ground truth
    def camera_map(self, k: int) -> CameraMap:
        """Projector k's exact camera map: u_k(x) = H_k^-1 x, valid on the object where the bilinear
        footprint lies inside the frame (so the map samples exactly what the camera saw)."""
        return self._maps[k]

    def true_m(self, k: int) -> np.ndarray:
        """(H,W,3,3) M_k of the joint model, 0 where projector k does not reach."""
        s = self._scale(k) * self._maps[k].valid
        return (self.albedo[..., :, None] * s[..., None, None] * self._mix(k)).astype(np.float32)

    def true_black(self, k: int) -> np.ndarray:
        """(H,W,3) linear capture of projector k's black light alone (where its frame lands)."""
        proj = self.projectors[k]
        frame = cv2.warpPerspective(np.ones(proj.size[::-1], np.float32), proj.homography, self.camera_size,
                                    flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        white = self._mix(k).sum(axis=1) * (self._scale(k) * frame)[..., None]
        return (self.albedo * white / proj.contrast).astype(np.float32)

    def true_offset(self) -> np.ndarray:
        """(H,W,3) linear capture when every projector shows black: ambient plus their blacks."""
        return (self.albedo * self.ambient + sum(self.true_black(k) for k in range(self.count))).astype(np.float32)

    def true_model(self):
        """The JointModel of the rig's ground truth (exact maps, M_k, offset and gammas)."""
        from ...lapig_core.multi.joint_model import JointModel

        return JointModel(self.camera_gamma, tuple(p.gamma for p in self.projectors),
                          np.stack([self.true_m(k) for k in range(self.count)]), self.true_offset(),
                          [self.camera_map(k) for k in range(self.count)])

    def subset(self, indices: Sequence[int]) -> "FakeRig":
        """The same camera, object and albedo with only the projectors `indices` (the others taken away)."""
        rig = FakeRig([self.projectors[k] for k in indices], self.camera_size, self.camera_gamma, self.albedo,
                      self.ambient, self.object_mask, self.noise)
        return rig

    # --------------------------------------------------------------- helpers
    def _scale(self, k: int) -> np.ndarray:
        proj = self.projectors[k]
        inc = np.ones(self.camera_size[::-1], np.float32) if proj.incidence is None else proj.incidence
        return (proj.gain * np.asarray(inc, np.float32)).astype(np.float32)

    def _mix(self, k: int) -> np.ndarray:
        mix = self.projectors[k].mix
        return (_MIX if mix is None else np.asarray(mix)).astype(np.float32)

    def _exact_map(self, proj: FakeProjector) -> CameraMap:
        cw, ch = self.camera_size
        yy, xx = np.mgrid[0:ch, 0:cw].astype(np.float64)
        pts = np.stack([xx, yy], -1).reshape(-1, 1, 2)
        uv = cv2.perspectiveTransform(pts, np.linalg.inv(proj.homography)).reshape(ch, cw, 2)
        w, h = proj.size
        inside = (uv[..., 0] >= 0) & (uv[..., 0] <= w - 1) & (uv[..., 1] >= 0) & (uv[..., 1] <= h - 1)
        return CameraMap(uv[..., 0], uv[..., 1], inside & self.object_mask, proj.size)


def _ellipse(cw: int, ch: int) -> np.ndarray:
    yy, xx = np.mgrid[0:ch, 0:cw]
    return ((xx + 0.5 - cw / 2) / (0.49 * cw)) ** 2 + ((yy + 0.5 - ch / 2) / (0.47 * ch)) ** 2 <= 1.0


def homography_onto(projector_size, camera_size, quad) -> np.ndarray:
    """The homography taking the projector frame's corners onto `quad`: 4 (x, y) in camera-size units
    (0..1), clockwise from the top left."""
    pw, ph = projector_size
    cw, ch = camera_size
    corners = np.float32([[-0.5, -0.5], [pw - 0.5, -0.5], [pw - 0.5, ph - 0.5], [-0.5, ph - 0.5]])
    seen = np.float32([[x * cw, y * ch] for x, y in quad])
    return cv2.getPerspectiveTransform(corners, seen).astype(np.float64)


def incidence_from_angles(camera_size, start_deg: float, end_deg: float, axis: int = 1) -> np.ndarray:
    """A camera-space cos map whose angle grows linearly from start_deg to end_deg along x (axis 1)
    or y (axis 0): a projector that meets one side square on and grazes the other."""
    cw, ch = camera_size
    t = (np.arange(cw if axis == 1 else ch) + 0.5) / (cw if axis == 1 else ch)
    cos = np.cos(np.radians(start_deg + (end_deg - start_deg) * t)).astype(np.float32)
    return np.broadcast_to(cos[None, :] if axis == 1 else cos[:, None], (ch, cw)).copy()


def side_by_side_rig(camera_size=(64, 48), projector_size=(80, 60), noise=0.002, seed=0, **kw) -> FakeRig:
    """Two projectors, one lighting the left 60% of the view from the left, the other the right 60% from
    the right: a 24% overlap in the middle, each dimmer (more grazing) towards the other's side. Their
    frames overscan the object above and below (its outline there is no frame edge)."""
    left = FakeProjector(projector_size, homography_onto(projector_size, camera_size,
                                                         [(0.03, -0.02), (0.63, -0.05), (0.61, 1.04), (0.02, 1.01)]),
                         gamma=2.2, gain=0.6, contrast=800.0,
                         incidence=incidence_from_angles(camera_size, 15, 75))
    right = FakeProjector(projector_size, homography_onto(projector_size, camera_size,
                                                          [(0.37, -0.04), (0.97, -0.01), (0.98, 1.02), (0.39, 1.05)]),
                          gamma=1.9, gain=0.5, contrast=1200.0,
                          incidence=incidence_from_angles(camera_size, 75, 15),
                          mix=[[0.86, 0.10, 0.04], [0.05, 0.90, 0.05], [0.03, 0.07, 0.90]])
    return FakeRig([left, right], camera_size, noise=noise, seed=seed, **kw)


def three_projector_rig(camera_size=(64, 48), projector_size=(80, 60), noise=0.002, seed=0, **kw) -> FakeRig:
    """side_by_side_rig plus a third projector from below, over the middle of the lower two thirds."""
    rig = side_by_side_rig(camera_size, projector_size, noise, seed, **kw)
    below = FakeProjector(projector_size, homography_onto(projector_size, camera_size,
                                                          [(0.22, 0.35), (0.78, 0.38), (0.80, 0.97), (0.20, 0.95)]),
                          gamma=2.0, gain=0.45, contrast=1000.0,
                          incidence=incidence_from_angles(camera_size, 70, 20, axis=0),
                          mix=[[0.92, 0.06, 0.02], [0.08, 0.84, 0.08], [0.02, 0.08, 0.90]])
    return FakeRig(rig.projectors + [below], camera_size, noise=noise, seed=seed, **kw)


def stacked_rig(count: int = 2, camera_size=(64, 48), projector_size=(80, 60), albedo_scale: float = 0.3,
                noise=0.002, seed=0, **kw) -> FakeRig:
    """`count` projectors stacked: each frame overscans the whole object from a slightly different place, so
    every object pixel is lit by all of them. albedo_scale darkens the default texture (0.3: a dark textured
    surface, albedo about 0.1..0.29), where one projector's reach is narrow and a stack's is wider."""
    quads = [[(-0.04, -0.05), (1.03, -0.03), (1.05, 1.04), (-0.03, 1.06)],
             [(-0.05, -0.03), (1.04, -0.06), (1.03, 1.05), (-0.05, 1.03)],
             [(-0.03, -0.06), (1.05, -0.04), (1.04, 1.03), (-0.04, 1.05)],
             [(-0.06, -0.04), (1.03, -0.05), (1.06, 1.05), (-0.03, 1.04)]]
    gammas, gains = (2.2, 1.9, 2.0, 2.4), (0.6, 0.5, 0.55, 0.5)
    if not 1 <= count <= len(quads):
        raise ValueError(f"stacked_rig makes 1 to {len(quads)} projectors, got {count}")
    projectors = [FakeProjector(projector_size, homography_onto(projector_size, camera_size, quads[k]),
                                gamma=gammas[k], gain=gains[k], contrast=1000.0) for k in range(count)]
    albedo = default_albedo(camera_size, seed) * np.float32(albedo_scale)
    return FakeRig(projectors, camera_size, noise=noise, seed=seed, albedo=albedo, **kw)


class FakeRigDevice(MultiProjectorDevice):
    """A FakeRig as the capture's MultiProjectorDevice (lapig_core/multi/capture.py): it shows one frame per
    projector and grabs the camera's image; the object mask is the rig's own."""

    main_thread = False

    def __init__(self, rig: FakeRig):
        self.rig = rig
        self.captured = 0  # frame sets captured, for tests that count renders

    def describe(self) -> MultiDeviceInfo:
        return MultiDeviceInfo("numpy fake rig", tuple(p.size for p in self.rig.projectors), self.rig.camera_size,
                               {"projectors": [{"width": p.size[0], "height": p.size[1], "gamma": p.gamma,
                                                "black_level": 1.0 / p.contrast} for p in self.rig.projectors]})

    def capture(self, frame_sets) -> list[np.ndarray]:
        self.captured += len(frame_sets)
        return [self.rig.capture(list(frames)) for frames in frame_sets]

    def object_mask(self) -> np.ndarray:
        return self.rig.object_mask.copy()
