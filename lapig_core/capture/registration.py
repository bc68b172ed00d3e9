# SPDX-License-Identifier: GPL-3.0-or-later
"""Registering camera captures into the projector's working frame.

The compensation models work on a width x height image covering the whole projector frame
(lapig_core.optics.working_frame). ``working_map`` samples the dense projector -> camera map of
``structured_light.projector_to_camera_map`` at that grid's pixel centres; ``warp_to_projector``
pulls a capture through it. The dense map is kept too, so the same captures can be registered
again at any other size up to native (``Registration.resized``). Coordinates follow OpenCV
(pixel (i, j) has its centre at (i, j)).

Plain Python + numpy + OpenCV; never imports bpy.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .structured_light import DecodeResult, projector_to_camera_map


def frame_grid(proj_width: int, proj_height: int, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Native projector x (length ``width``) and y (length ``height``), float64, of the pixel
    centres of a width x height frame covering the whole native frame.

    The grid is separable: pixel (row r, col c) sits at (xs[c], ys[r]). Its outer edges are the
    native frame's edges: xs[c] = (c + 0.5) * Wp / width - 0.5.
    """
    if min(proj_width, proj_height, width, height) < 1:
        raise ValueError(f"sizes must be positive, got projector {proj_width}x{proj_height}, frame {width}x{height}")
    return ((np.arange(width) + 0.5) * proj_width / width - 0.5,
            (np.arange(height) + 0.5) * proj_height / height - 0.5)


def _check_dense(cam_xy, valid, proj_width, proj_height):
    if cam_xy.shape != (proj_height, proj_width, 2):
        raise ValueError(f"cam_xy has shape {cam_xy.shape}, expected ({proj_height}, {proj_width}, 2)")
    if valid.shape != (proj_height, proj_width):
        raise ValueError(f"valid has shape {valid.shape}, expected ({proj_height}, {proj_width})")


def working_map(
    cam_xy: np.ndarray, valid: np.ndarray, proj_width: int, proj_height: int, width: int, height: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Camera coordinates of the working pixel centres: (map_x, map_y) float32 for cv2.remap, and
    valid_w. Bilinear on the dense map; invalid (maps -1) where any of the 4 neighbours is invalid.
    A grid point in the frame's outermost half pixel uses the edge pixels (clamped)."""
    cam_xy = np.asarray(cam_xy)
    valid = np.asarray(valid, bool)
    _check_dense(cam_xy, valid, proj_width, proj_height)
    xs, ys = frame_grid(proj_width, proj_height, width, height)

    def axis(t, n):  # left neighbour index and weight, clamped to the frame
        t = np.clip(t, 0.0, n - 1.0)
        i0 = np.minimum(np.floor(t).astype(np.intp), n - 2)
        return i0, t - i0

    i0, fx = axis(xs, proj_width)
    j0, fy = axis(ys, proj_height)
    J, I = j0[:, None], i0[None, :]
    fx, fy = fx[None, :, None], fy[:, None, None]
    m = cam_xy.astype(np.float64)
    top = m[J, I] * (1 - fx) + m[J, I + 1] * fx
    bot = m[J + 1, I] * (1 - fx) + m[J + 1, I + 1] * fx
    xy = top * (1 - fy) + bot * fy
    ok = valid[J, I] & valid[J, I + 1] & valid[J + 1, I] & valid[J + 1, I + 1]
    map_x = np.where(ok, xy[..., 0], -1.0).astype(np.float32)
    map_y = np.where(ok, xy[..., 1], -1.0).astype(np.float32)
    return map_x, map_y, ok


def supersampled_map(
    cam_xy: np.ndarray, valid: np.ndarray, proj_width: int, proj_height: int, width: int, height: int,
    supersample: int = 2
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The working map at ``supersample`` times the frame: what ``warp_to_projector`` wants for it."""
    ss = int(supersample)
    return working_map(cam_xy, valid, proj_width, proj_height, width * ss, height * ss)


def _as_float_image(capture) -> np.ndarray:
    img = np.asarray(capture)
    if img.dtype == np.uint8:
        img = img.astype(np.float32) / 255.0
    elif np.issubdtype(img.dtype, np.floating):
        img = img.astype(np.float32, copy=False)
    else:
        raise ValueError(f"capture dtype {img.dtype} not supported (use uint8 or float in [0, 1])")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] in (3, 4))):
        raise ValueError(f"capture shape {img.shape} is neither HxW nor HxWx(1|3|4)")
    return img


def warp_to_projector(
    capture: np.ndarray,
    map_x: np.ndarray,
    map_y: np.ndarray,
    valid_w: np.ndarray | None = None,
    supersample: int = 2,
    return_valid: bool = False,
):
    """Register a camera capture into projector space.

    ``map_x``/``map_y`` (and ``valid_w``) must be the map at ``supersample`` times the output size
    (``supersampled_map``): the capture is remapped
    bilinearly at that resolution, then area-averaged (cv2.INTER_AREA) by ``supersample`` so a
    camera finer than the working grid does not alias. With ``supersample=1`` pass the plain
    working map. Output: float32 in [0, 1] (uint8 input is divided by 255), HxW or HxWxC like the
    capture, of the map's size // supersample; 0 where any sub-sample is invalid or falls outside
    the capture. ``return_valid=True`` also returns that output validity mask.
    """
    img = _as_float_image(capture)
    map_x = np.asarray(map_x, np.float32)
    map_y = np.asarray(map_y, np.float32)
    ss = int(supersample)
    if ss < 1 or ss != supersample:
        raise ValueError(f"supersample must be a positive integer, got {supersample}")
    if map_x.ndim != 2 or map_x.shape != map_y.shape:
        raise ValueError(f"map_x {map_x.shape} and map_y {map_y.shape} must be equal 2-D shapes")
    if map_x.shape[0] % ss or map_x.shape[1] % ss:
        raise ValueError(f"map shape {map_x.shape} is not a multiple of supersample={ss}")
    H, W = img.shape[:2]
    ok = (map_x >= 0) & (map_x <= W - 1) & (map_y >= 0) & (map_y <= H - 1)  # no blending with border
    if valid_w is not None:
        valid_w = np.asarray(valid_w, bool)
        if valid_w.shape != map_x.shape:
            raise ValueError(f"valid_w has shape {valid_w.shape}, maps have {map_x.shape}")
        ok &= valid_w
    out = cv2.remap(img, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    out[~ok] = 0.0
    if ss > 1:
        h, w = map_x.shape[0] // ss, map_x.shape[1] // ss
        out = cv2.resize(out, (w, h), interpolation=cv2.INTER_AREA)  # exact block mean for integer ss
        ok = ok.reshape(h, ss, w, ss).all(axis=(1, 3))
        out[~ok] = 0.0
    return (out, ok) if return_valid else out


class RegistrationError(ValueError):
    """A registration file that cannot serve this version (made for a central square)."""


@dataclass
class Registration:
    """Projector <-> camera registration of one capture set, reusable for many captures.

    ``map_x``/``map_y``/``valid``: camera coordinates of the width x height working pixel centres
    (``working_map``). ``fine_*``: the same at ``supersample`` times the frame, cached for ``warp``;
    built by ``from_map`` (exact, from the dense map). Without them ``warp`` remaps the working map
    directly (no supersampling). ``dense_xy``/``dense_valid``: the native projector -> camera map
    itself, kept for registering at other sizes (``resized``). ``camera_shape`` (H, W), when known,
    is checked against captures.
    """

    proj_width: int
    proj_height: int
    width: int
    height: int
    map_x: np.ndarray
    map_y: np.ndarray
    valid: np.ndarray
    supersample: int = 2
    camera_shape: tuple[int, int] | None = None
    fine_x: np.ndarray | None = field(default=None, repr=False)
    fine_y: np.ndarray | None = field(default=None, repr=False)
    fine_valid: np.ndarray | None = field(default=None, repr=False)
    dense_xy: np.ndarray | None = field(default=None, repr=False)
    dense_valid: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        shape = (self.height, self.width)
        for name in ("map_x", "map_y", "valid"):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"{name} has shape {np.shape(getattr(self, name))}, expected {shape}")
        fine = [self.fine_x, self.fine_y, self.fine_valid]
        if any(f is not None for f in fine):
            ss = self.supersample
            if any(np.shape(f) != (shape[0] * ss, shape[1] * ss) for f in fine):
                raise ValueError(f"fine maps must all be {shape[0] * ss}x{shape[1] * ss} for a "
                                 f"{self.width}x{self.height} frame x supersample {ss}")
        if self.dense_xy is not None:
            _check_dense(self.dense_xy, self.dense_valid, self.proj_width, self.proj_height)
        if self.camera_shape is not None:
            self.camera_shape = tuple(int(v) for v in self.camera_shape)

    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) of the registered images."""
        return self.width, self.height

    @property
    def frame_valid(self) -> np.ndarray:
        """(height, width) bool: the working pixels ``warp`` fills from the camera, i.e. where the
        projector frame lands on something the camera sees."""
        if self.fine_valid is None:
            return self.valid.copy()
        ss = self.supersample
        return self.fine_valid.reshape(self.height, ss, self.width, ss).all(axis=(1, 3))

    @classmethod
    def from_map(cls, cam_xy, valid, proj_width, proj_height, width, height, supersample=2, camera_shape=None):
        """Build from ``projector_to_camera_map`` output; caches the supersampled maps and keeps
        the dense map."""
        mx, my, ok = working_map(cam_xy, valid, proj_width, proj_height, width, height)
        fx, fy, fok = supersampled_map(cam_xy, valid, proj_width, proj_height, width, height, supersample)
        return cls(proj_width, proj_height, width, height, mx, my, ok, supersample, camera_shape, fx, fy, fok,
                   np.asarray(cam_xy, np.float32), np.asarray(valid, bool))

    @classmethod
    def from_decoded(cls, decoded: DecodeResult, proj_width, proj_height, width, height, supersample=2,
                     sigma=None):
        """Decoded Gray code -> dense map -> registration, remembering the camera shape."""
        cam_xy, valid = projector_to_camera_map(decoded, proj_width, proj_height, sigma=sigma)
        return cls.from_map(cam_xy, valid, proj_width, proj_height, width, height, supersample,
                            decoded.valid.shape)

    def resized(self, width: int, height: int, supersample: int | None = None) -> "Registration":
        """The same registration for a width x height frame (up to native), from the dense map.

        supersample None: 2 where the camera has more pixels than the frame (so it does not alias),
        else 1 (a finer grid would only interpolate the same camera pixels)."""
        if self.dense_xy is None:
            raise RegistrationError("this registration has no dense map: capture again to register at other sizes")
        if width > self.proj_width or height > self.proj_height:
            raise ValueError(f"a {width}x{height} frame is finer than the projector's "
                             f"{self.proj_width}x{self.proj_height}")
        if supersample is None:
            camera_pixels = np.prod(self.camera_shape) if self.camera_shape else 0
            supersample = 2 if camera_pixels > width * height else 1
        return Registration.from_map(self.dense_xy, self.dense_valid, self.proj_width, self.proj_height, width,
                                     height, supersample, self.camera_shape)

    def warp(self, capture, return_valid: bool = False):
        """Capture (HxW[xC], uint8 or float) -> float32 height x width[xC] projector-space image."""
        shape = np.shape(capture)[:2]
        if self.camera_shape is not None and shape != self.camera_shape:
            raise ValueError(f"capture is {shape[1]}x{shape[0]}, registration was made for "
                             f"{self.camera_shape[1]}x{self.camera_shape[0]} captures")
        if self.fine_x is not None:
            return warp_to_projector(capture, self.fine_x, self.fine_y, self.fine_valid, self.supersample, return_valid)
        return warp_to_projector(capture, self.map_x, self.map_y, self.valid, 1, return_valid)

    def save(self, path) -> None:
        """Write everything (fine and dense maps included) to ``path`` as .npz, exactly at that name."""
        arrays = dict(
            proj_size=np.array([self.proj_width, self.proj_height]),
            frame_size=np.array([self.width, self.height]),
            supersample=np.array(self.supersample),
            camera_shape=np.array(self.camera_shape if self.camera_shape else [], dtype=np.int64),
            map_x=self.map_x, map_y=self.map_y, valid=self.valid,
        )
        if self.fine_x is not None:
            arrays.update(fine_x=self.fine_x, fine_y=self.fine_y, fine_valid=self.fine_valid)
        if self.dense_xy is not None:
            arrays.update(dense_xy=self.dense_xy, dense_valid=self.dense_valid)
        with open(Path(path), "wb") as f:  # a file object: np.savez must not append ".npz"
            np.savez(f, **arrays)

    @classmethod
    def load(cls, path) -> "Registration":
        """Read a file written by ``save``."""
        with np.load(Path(path), allow_pickle=False) as z:
            if "frame_size" not in z.files:
                raise RegistrationError(f"{Path(path).name} registers a central square of the projector frame "
                                        "(made by an older version): capture again for the whole frame")
            cam = tuple(int(v) for v in z["camera_shape"]) or None
            optional = [z[k] if k in z.files else None
                        for k in ("fine_x", "fine_y", "fine_valid", "dense_xy", "dense_valid")]
            if optional[4] is not None:
                optional[4] = optional[4].astype(bool)
            (pw, ph), (w, h) = z["proj_size"], z["frame_size"]
            return cls(int(pw), int(ph), int(w), int(h), z["map_x"], z["map_y"], z["valid"].astype(bool),
                       int(z["supersample"]), cam, *optional)
