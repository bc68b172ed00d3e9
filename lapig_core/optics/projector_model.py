"""Pinhole model of a video projector: pixel <-> ray geometry and its light transfer.

The same formulas drive the Blender light's node tree (lapig_addon.projector_nodes) and the exact
ray-cast check of the registration, so they live here once, free of bpy.

Conventions: the projector looks down its local -Z axis with +X right and +Y up, like a Blender
camera. Normalised image coordinates (u, v) run 0..1 from the left and from the *bottom* edge (the
convention of Blender's image textures); pixel coordinates follow OpenCV: pixel (col i, row j) has
its centre at (i, j), rows counted from the top.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..common.imageio import to_bit_depth, to_float
from ..common.resample import resize_image


@dataclass(frozen=True)
class ProjectorModel:
    width: int = 800
    height: int = 600
    throw_ratio: float = 1.5  # distance / image width
    shift_x: float = 0.0  # lens shift, in image widths
    shift_y: float = 0.0  # lens shift, in image heights
    gamma: float = 2.2  # input value -> relative light output
    black_level: float = 0.002  # light leaked by a black input, relative to white

    def __post_init__(self):
        if self.width < 2 or self.height < 2:
            raise ValueError(f"projector resolution must be at least 2x2, got {self.width}x{self.height}")
        if not self.throw_ratio > 0:
            raise ValueError(f"throw ratio must be positive, got {self.throw_ratio}")
        if not 0 <= self.black_level < 1:
            raise ValueError(f"black level must be in [0, 1), got {self.black_level}")
        if not self.gamma > 0:
            raise ValueError(f"projector gamma must be positive, got {self.gamma}")

    @property
    def aspect(self) -> float:
        return self.width / self.height

    # u = 0.5 + shift_x + throw * x / d ; v = 0.5 + shift_y + throw * aspect * y / d, d = -z
    def uv_scale(self) -> tuple[float, float]:
        return self.throw_ratio, self.throw_ratio * self.aspect

    def directions_to_uv(self, directions: np.ndarray) -> np.ndarray:
        """Local-space directions (..., 3) -> normalised (u, v); NaN behind the projector."""
        d = np.asarray(directions, dtype=np.float64)
        depth = -d[..., 2]
        sx, sy = self.uv_scale()
        with np.errstate(divide="ignore", invalid="ignore"):
            u = 0.5 + self.shift_x + sx * d[..., 0] / depth
            v = 0.5 + self.shift_y + sy * d[..., 1] / depth
        behind = depth <= 0
        u = np.where(behind, np.nan, u)
        v = np.where(behind, np.nan, v)
        return np.stack([u, v], axis=-1)

    def uv_to_pixel(self, uv: np.ndarray) -> np.ndarray:
        """Normalised (u, v) -> continuous pixel coordinates (x, y) in OpenCV convention."""
        uv = np.asarray(uv, dtype=np.float64)
        x = uv[..., 0] * self.width - 0.5
        y = (1.0 - uv[..., 1]) * self.height - 0.5
        return np.stack([x, y], axis=-1)

    def pixel_to_uv(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=np.float64)
        u = (xy[..., 0] + 0.5) / self.width
        v = 1.0 - (xy[..., 1] + 0.5) / self.height
        return np.stack([u, v], axis=-1)

    def pixel_to_direction(self, xy: np.ndarray) -> np.ndarray:
        """Continuous pixel coordinates -> unit local-space ray directions (..., 3)."""
        uv = self.pixel_to_uv(xy)
        sx, sy = self.uv_scale()
        x = (uv[..., 0] - 0.5 - self.shift_x) / sx
        y = (uv[..., 1] - 0.5 - self.shift_y) / sy
        d = np.stack([x, y, -np.ones_like(x)], axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def emitted(self, image: np.ndarray) -> np.ndarray:
        """Input values (float in [0,1], or uint8/uint16 file pixels) -> relative emitted light
        (gamma, then black-level leak)."""
        x = to_float(image)
        return self.black_level + (1.0 - self.black_level) * np.power(x, self.gamma)

    def emitted_8bit(self, image) -> np.ndarray:
        """emitted() of the 8-bit frame a real projector receives, by lookup (fast for captures)."""
        img = to_bit_depth(image, 8)
        if img.ndim == 2:
            img = np.repeat(img[..., None], 3, axis=-1)
        return self.emitted(np.arange(256, dtype=np.uint8))[img]

    def frame_light(self, working_image: np.ndarray, bit_depth: int) -> np.ndarray:
        """The light emitted for a working image sent to the projector as a bit_depth file."""
        return self.emitted(quantised_frame(working_image, self.width, self.height, bit_depth))

    def to_dict(self) -> dict:
        return asdict(self)


def frame_sample_points(width: int, height: int, grid: int = 24) -> np.ndarray:
    """(grid, grid, 2) native pixel coordinates spread evenly over a width x height frame, for
    coverage checks (cell centres, OpenCV convention)."""
    t = (np.arange(grid) + 0.5) / grid
    xs, ys = np.meshgrid(t * width - 0.5, t * height - 0.5)
    return np.stack([xs, ys], -1)


def frame_from_working_image(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """The native width x height frame of a working image: the working frame covers the whole
    projector frame, so this is a plain resize (an image already at native size is kept as is).

    The one placement of every frame the projector shows: capture patterns, the Blender light,
    Render Real Capture and the exported file (resampling: lapig_core.common.resample). Values are
    clipped to [0, 1] (NaN -> 0) and stay there.
    """
    img = to_float(image)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=-1)
    return resize_image(np.ascontiguousarray(img, dtype=np.float32), width, height)


def quantised_frame(image: np.ndarray, width: int, height: int, bit_depth: int) -> np.ndarray:
    """The native frame as the projector receives it: placed, then rounded to a uint8/uint16 file's
    levels. The exported PNG holds exactly these pixels and the Blender light emits their light."""
    return to_bit_depth(frame_from_working_image(image, width, height), bit_depth)
