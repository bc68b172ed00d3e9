# SPDX-License-Identifier: GPL-3.0-or-later
"""One projector's registration in camera space: the projector pixel each camera pixel sees.

Several projectors share no projector frame, but they share the camera's, so the joint model, the
compensation and the blend all work per camera pixel and a CameraMap carries each projector's part
in and out of it: `sample` pulls a projector image into camera space (u_k(x), bilinear, the map Gray
code gives), `to_projector` sends per-camera-pixel values back into the projector's frame (the inverse
of u_k: camera pixels splatted onto the projector pixels around them, averaged where several land on
one, holes filled by push-pull) and `density` says how many projector pixels one camera pixel spans.
Coordinates follow OpenCV: pixel (i, j) has its centre at (i, j).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..capture.structured_light import DecodeResult
from .masked_filter import masked_gaussian
from .push_pull import push_pull


# A projector's image carries its edge values this share of its frame's larger side past its footprint.
# At the object's outline the camera sees the surface edge-on: one camera pixel gathers a long strip of it,
# lit by projector pixels that no camera pixel centre lands on. Black there, the outline captured dark
# (the bust of `bench multi`: 0.16 RMS on the reached outline against 0.02 inside; bleeds of 3, 8 and 20
# of 800 pixels left 0.110, 0.051 and 0.029). The light past the footprint falls where the camera sees no
# part of the object, the same light a white frame sends there.
BLEED_SHARE = 0.02


@dataclass(eq=False)
class CameraMap:
    """map_x, map_y: (H,W) float32 projector coordinates of each camera pixel centre; valid: (H,W) bool,
    where the projector's light reaches the object the camera sees; projector_size: (width, height).
    Camera pixels whose coordinates fall off the projector frame are made invalid."""

    map_x: np.ndarray
    map_y: np.ndarray
    valid: np.ndarray
    projector_size: tuple[int, int]

    def __post_init__(self):
        self.map_x = np.asarray(self.map_x, np.float32)
        self.map_y = np.asarray(self.map_y, np.float32)
        self.valid = np.asarray(self.valid, bool)
        self.projector_size = tuple(int(v) for v in self.projector_size)
        if not (self.map_x.shape == self.map_y.shape == self.valid.shape) or self.valid.ndim != 2:
            raise ValueError(f"map_x, map_y and valid must be equal (H,W) arrays, got {self.map_x.shape}, "
                             f"{self.map_y.shape}, {self.valid.shape}")
        w, h = self.projector_size
        if min(w, h) < 2:
            raise ValueError(f"a projector frame must be at least 2x2, got {w}x{h}")
        with np.errstate(invalid="ignore"):
            on_frame = (self.map_x >= -0.5) & (self.map_x <= w - 0.5) & (self.map_y >= -0.5) & (self.map_y <= h - 0.5)
        self.valid = self.valid & on_frame  # NaN compares False: off the frame too
        self.map_x = np.where(self.valid, self.map_x, -1.0).astype(np.float32)
        self.map_y = np.where(self.valid, self.map_y, -1.0).astype(np.float32)

    @property
    def camera_shape(self) -> tuple[int, int]:
        return self.valid.shape

    @classmethod
    def from_decoded(cls, decoded: DecodeResult, projector_size, sigma: float = 1.0) -> "CameraMap":
        """Decoded Gray code (integer projector pixels per camera pixel) -> sub-pixel maps, smoothed by a
        Gaussian of `sigma` camera pixels within the decoded pixels (the integer staircase averaged out)."""
        ok = decoded.valid & (decoded.proj_x >= 0) & (decoded.proj_y >= 0)
        mx = masked_gaussian(decoded.proj_x.astype(np.float32), ok, sigma, fill=-1.0)
        my = masked_gaussian(decoded.proj_y.astype(np.float32), ok, sigma, fill=-1.0)
        return cls(mx, my, ok, projector_size)

    # -------------------------------------------------------------- projector -> camera
    def sample(self, image: np.ndarray) -> np.ndarray:
        """A projector-frame image (h,w[,C]) -> camera space (H,W[,C]) float32: bilinear at u(x), 0 where
        invalid. The frame's outer half pixel takes the edge pixel (its light reaches that far)."""
        img = np.asarray(image, np.float32)
        w, h = self.projector_size
        if img.shape[:2] != (h, w):
            raise ValueError(f"a projector image must be ({h},{w}[,C]), got {img.shape}")
        out = cv2.remap(img, self.map_x, self.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        out = out.reshape(self.camera_shape + img.shape[2:])
        inside = self.valid if out.ndim == 2 else self.valid[..., None]
        return np.where(inside, out, 0.0).astype(np.float32)

    def density(self) -> np.ndarray:
        """(H,W) float32: projector pixels per camera pixel, |det du/dx|, 0 where invalid. Derivatives are
        taken between valid neighbours only; a pixel with none takes its valid neighbourhood's value."""
        dxx, ok1 = _derivative(self.map_x, self.valid, axis=1)
        dxy, ok2 = _derivative(self.map_x, self.valid, axis=0)
        dyx, ok3 = _derivative(self.map_y, self.valid, axis=1)
        dyy, ok4 = _derivative(self.map_y, self.valid, axis=0)
        det = np.abs(dxx * dyy - dxy * dyx)
        known = ok1 & ok2 & ok3 & ok4
        if (self.valid & ~known).any():
            det = np.where(known, det, masked_gaussian(det, known, 2.0))
        return np.where(self.valid, det, 0.0).astype(np.float32)

    # -------------------------------------------------------------- camera -> projector
    def splat(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-camera-pixel values (H,W[,C]) onto the projector frame: (weighted sums (h,w[,C]), weights
        (h,w)), each valid camera pixel shared among the 4 projector pixels around u(x) bilinearly."""
        v = np.asarray(values, np.float32)
        if v.shape[:2] != self.camera_shape:
            raise ValueError(f"values must be {self.camera_shape}[+C], got {v.shape}")
        flat = v.ndim == 2
        v = v[self.valid].reshape(-1, 1 if flat else v.shape[-1]).astype(np.float64)
        w, h = self.projector_size
        ux, uy = self.map_x[self.valid].astype(np.float64), self.map_y[self.valid].astype(np.float64)
        x0, y0 = np.floor(ux).astype(np.intp), np.floor(uy).astype(np.intp)
        fx, fy = ux - x0, uy - y0
        sums = np.zeros((h * w, v.shape[1]), np.float64)
        weight = np.zeros(h * w, np.float64)
        for dx, dy, wt in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                           (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
            xi, yi = x0 + dx, y0 + dy
            on = (xi >= 0) & (xi < w) & (yi >= 0) & (yi < h)
            cell = (yi * w + xi)[on]
            weight += np.bincount(cell, wt[on], minlength=h * w)
            for c in range(v.shape[1]):
                sums[:, c] += np.bincount(cell, wt[on] * v[on, c], minlength=h * w)
        sums = sums.reshape(h, w, -1)
        return (sums[..., 0] if flat else sums).astype(np.float32), weight.reshape(h, w).astype(np.float32)

    def footprint(self, weight: np.ndarray | None = None) -> np.ndarray:
        """(h,w) bool: the projector pixels whose light the camera sees on the object: those the valid
        camera pixels land on, their gaps closed (a projector finer than the camera leaves some unhit)."""
        if weight is None:
            weight = self.splat(np.zeros(self.camera_shape, np.float32))[1]
        hit = (weight > 0).astype(np.uint8)
        density = self.density()[self.valid]
        spacing = np.sqrt(np.percentile(density, 95)) if density.size else 1.0  # projector px between samples
        k = 2 * int(np.ceil(spacing)) + 1
        return cv2.morphologyEx(hit, cv2.MORPH_CLOSE, np.ones((k, k), np.uint8)).astype(bool)

    def bleed_pixels(self) -> int:
        """How far past its footprint a projector's image carries its edge values (BLEED_SHARE of the frame)."""
        return int(np.ceil(BLEED_SHARE * max(self.projector_size)))

    def to_projector(self, values: np.ndarray, outside: float | None = 0.0, bleed: int = 0) -> np.ndarray:
        """Per-camera-pixel values (H,W[,C]) -> the projector frame (h,w[,C]) float32: the weighted mean of
        the camera pixels landing around each projector pixel, holes filled by push-pull. Projector
        pixels more than `bleed` pixels off the footprint get `outside`, or with None the nearest values,
        extended (push-pull); within `bleed` of it, the extended values."""
        sums, weight = self.splat(values)
        wt = weight if sums.ndim == 2 else weight[..., None]
        mean = np.where(wt > 0, sums / np.maximum(wt, 1e-12), 0.0)
        filled = push_pull(mean, np.clip(weight, 0.0, 1.0))
        if outside is None:
            return filled
        on = self.footprint(weight)
        if bleed > 0:
            on = cv2.dilate(on.astype(np.uint8), np.ones((2 * bleed + 1, 2 * bleed + 1), np.uint8)).astype(bool)
        return np.where(on if filled.ndim == 2 else on[..., None], filled, np.float32(outside)).astype(np.float32)


def maps_to_arrays(maps) -> dict:
    """The arrays an .npz keeps of several projectors' maps (maps_from_arrays reads them back)."""
    return {"map_xy": np.stack([np.stack([m.map_x, m.map_y]) for m in maps]),
            "valid": np.stack([m.valid for m in maps]),
            "projector_sizes": np.array([m.projector_size for m in maps])}


def maps_from_arrays(z) -> list:
    return [CameraMap(xy[0], xy[1], v, tuple(int(s) for s in size))
            for xy, v, size in zip(z["map_xy"], z["valid"], z["projector_sizes"])]


def _derivative(m: np.ndarray, ok: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """d m / d(axis) from the valid neighbours only: the mean of the forward and backward differences
    that exist (the central difference inside, one-sided at an edge); and where one existed."""
    m = np.moveaxis(m.astype(np.float64), axis, 0)
    ok = np.moveaxis(ok, axis, 0)
    step = m[1:] - m[:-1]
    both = ok[1:] & ok[:-1]
    step = np.where(both, step, 0.0)
    total, count = np.zeros_like(m), np.zeros(m.shape, np.int8)
    total[:-1] += step
    total[1:] += step
    count[:-1] += both
    count[1:] += both
    d = np.where(count > 0, total / np.maximum(count, 1), 0.0)
    return np.moveaxis(d, 0, axis), np.moveaxis(count > 0, 0, axis)
