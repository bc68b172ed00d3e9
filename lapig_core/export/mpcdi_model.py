# SPDX-License-Identifier: GPL-3.0-or-later
"""What an MPCDI package describes, as plain objects, and the checks that make it one the spec allows.

Section numbers are those of VESA MPCDI 2.0 (19 May 2015). A buffer is one projector's frame buffer and
a region the part of it one image-rendering path fills (2.1, 3.5.1): two blending projectors are two
buffers, usually one full-size region each (x = y = 0, xsize = ysize = 1). Region ids are unique in
the whole file, since each fileset names only its region (3.5.2).

Every check raises ValueError with one line that names the buffer or region.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

PROFILES = ("2d", "sl")  # what this writer writes; the spec also has 3d and a3 (table 3-2)
GEOMETRIC_UNITS = ("mm", "cm", "dm", "m", "in", "ft", "yd", "unknown")  # 3.5.2, geometryWarpFile
ORIGINS_OF_3D_DATA = ("centerOfMass", "idealEyePoint", "floorCenter", "unknown")
INTERPOLATIONS = ("linear", "keystone", "smooth", "unknown")  # 2.7
BIT_DEPTHS = (8, 16)  # PNG blend maps (3.7); 16 keeps a blend ramp free of visible steps
LEVEL_1_WARP_GRID = 32  # a 2d warp grid of at most 32x32 is geometry level 1 (table 3-2)
_UNIT_TOLERANCE = 1e-4  # coordinate frame axes: orthonormal unit vectors (2.2.2)


@dataclass(frozen=True)
class MpcdiFrustum:
    """A region's view frustum in degrees (2.2.1, table 2-1): yaw, then pitch, then roll; the field of
    view by its four edge angles (left < right, down < up)."""
    yaw: float
    pitch: float
    roll: float
    right_angle: float
    left_angle: float
    up_angle: float
    down_angle: float

    @classmethod
    def from_pinhole(cls, fx: float, fy: float, cx: float, cy: float, size: tuple[int, int],
                     yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0) -> MpcdiFrustum:
        """The edge angles of a pinhole projector: focal lengths and principal point in pixels, the
        image's (width, height), image y down (the principal point's row cy counts from the top)."""
        width, height = size
        if not (fx > 0 and fy > 0):
            raise ValueError(f"a pinhole's focal lengths must be positive, got fx={fx}, fy={fy}")
        deg = math.degrees
        return cls(yaw=yaw, pitch=pitch, roll=roll,
                   right_angle=deg(math.atan((width - cx) / fx)), left_angle=-deg(math.atan(cx / fx)),
                   up_angle=deg(math.atan(cy / fy)), down_angle=-deg(math.atan((height - cy) / fy)))


@dataclass(frozen=True)
class MpcdiCoordinateFrame:
    """A shader-lamp projector's pose (2.2.2): its position and the orthonormal unit vectors of its yaw,
    pitch and roll axes, in the 3D data's coordinates and unit."""
    position: tuple[float, float, float]
    yaw_axis: tuple[float, float, float]
    pitch_axis: tuple[float, float, float]
    roll_axis: tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class MpcdiRegion:
    """One projector's (or image path's) part of a buffer, and the maps the projector applies.

    resolution: (width, height) in pixels; x, y, xsize, ysize: the region in the buffer's normalised
    frame. warp: (h', w', 2 or 3) float32 on a uniform grid that fills the region (3.6): for '2d' each
    texel's normalised (u, v) source coordinate (a third channel: its estimated error, 3.6.2; NaN where
    unknown), for 'sl' each texel's 3D surface point (3.6.3; NaN where unknown). alpha: (height, width)
    linear blend weight in [0, 1]; beta: (height, width) black-level offset in [0, 1] or None. gamma: the
    gamma embedded in the alpha map's file (1.0: stored linear). signal_gamma: the decode and encode gamma
    of the region's color tag (2.5.1). frustum, coordinate_frame, distortion: 'sl' only; distortion a
    2D map like a '2d' warp (2.6, 3.9).
    """
    id: str
    resolution: tuple[int, int]
    x: float
    y: float
    xsize: float
    ysize: float
    warp: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray | None = None
    gamma: float = 1.0
    frustum: MpcdiFrustum | None = None
    coordinate_frame: MpcdiCoordinateFrame | None = None
    distortion: np.ndarray | None = None
    signal_gamma: float = 2.2


@dataclass(frozen=True, eq=False)
class MpcdiBuffer:
    """One projector's frame buffer: its id, (width, height) and the regions that fill it."""
    id: str
    resolution: tuple[int, int]
    regions: Sequence[MpcdiRegion] = field(default_factory=tuple)


def check_id(value, what: str) -> str:
    """An id the XML and a file name can hold: a non-empty string without control characters or
    surrounding blanks."""
    if not isinstance(value, str) or not value:
        raise ValueError(f"{what} id must be a non-empty string, got {value!r}")
    if value != value.strip() or any(ord(ch) < 32 or 0xD800 <= ord(ch) <= 0xDFFF or ord(ch) in (0xFFFE, 0xFFFF)
                                     for ch in value):
        raise ValueError(f"{what} id {value!r} has surrounding blanks or characters XML cannot hold")
    return value


def check_resolution(value, what: str) -> tuple[int, int]:
    """(width, height): two integers of at least 2 (a 1-pixel map is not allowed, 3.6 and 3.7)."""
    try:
        width, height = value
    except (TypeError, ValueError):
        raise ValueError(f"{what} resolution must be (width, height), got {value!r}") from None
    for n in (width, height):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"{what} resolution must be two integers of at least 2, got {value!r}")
    return int(width), int(height)


def check_number(value, what: str, low: float | None = None, high: float | None = None,
                 low_open: bool = False) -> float:
    """A finite float within [low, high] (or (low, high] with low_open)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, got {number}")
    too_low = low is not None and (number <= low if low_open else number < low)
    if too_low or (high is not None and number > high):
        if high is None:
            bound = f"{'above' if low_open else 'at least'} {low}"
        else:
            bound = f"in {'(' if low_open else '['}{low}, {high}]"
        raise ValueError(f"{what} must be {bound}, got {number}")
    return number


def check_float_array(value, what: str, shape_text: str, ndim: int) -> np.ndarray:
    """A real-valued numpy array of `ndim` dimensions (no conversion of lists of strings)."""
    if not isinstance(value, np.ndarray):
        raise ValueError(f"{what} must be a numpy array {shape_text}, got {type(value).__name__}")
    if value.ndim != ndim or not (np.issubdtype(value.dtype, np.floating) or np.issubdtype(value.dtype, np.integer)):
        raise ValueError(f"{what} must be a real array {shape_text}, got {value.dtype} of shape {value.shape}")
    return value


def check_weight_map(value, what: str, size: tuple[int, int]) -> np.ndarray:
    """An alpha or beta map: (height, width) of the region, finite values in [0, 1]."""
    width, height = size
    array = check_float_array(value, what, f"({height}, {width})", 2)
    if array.shape != (height, width):
        raise ValueError(f"{what} has shape {array.shape}, the region's resolution {width}x{height} "
                         f"needs ({height}, {width})")
    values = array.astype(np.float64)
    if not np.isfinite(values).all():
        raise ValueError(f"{what} holds NaN or infinite values")
    if values.min() < 0.0 or values.max() > 1.0:
        raise ValueError(f"{what} must lie in [0, 1], got [{values.min():.6g}, {values.max():.6g}]")
    return values


def _check_grid(array: np.ndarray, what: str, size: tuple[int, int]) -> None:
    """A uniform grid of at least 2x2 (3.6) and at most one texel per pixel (table 3-2, level 2)."""
    width, height = size
    grid_h, grid_w = array.shape[:2]
    if grid_w < 2 or grid_h < 2:
        raise ValueError(f"{what} grid is {grid_w}x{grid_h}: it must be at least 2x2")
    if grid_w > width or grid_h > height:
        raise ValueError(f"{what} grid is {grid_w}x{grid_h}, finer than the region's {width}x{height} pixels")


def check_2d_map(value, what: str, size: tuple[int, int]) -> np.ndarray:
    """A 2D warp or distortion map (3.6.2, 3.9) as the 3-channel float32 grid the file stores.

    (h', w', 2): (u, v) given, the error channel is filled in: NaN (not calculated), 1.0 where (u, v)
    is unknown (NaN). (h', w', 3): stored as given. u and v lie in [0, 1] or are NaN together; the error
    lies in [0, 1] or is NaN.
    """
    array = check_float_array(value, what, "(h, w, 2 or 3)", 3)
    if array.shape[2] not in (2, 3):
        raise ValueError(f"{what} must be (h, w, 2 or 3), got shape {array.shape}")
    _check_grid(array, what, size)
    grid = array.astype(np.float32)
    uv = grid[..., :2]
    unknown = np.isnan(uv)
    if (unknown[..., 0] != unknown[..., 1]).any():
        raise ValueError(f"{what} has texels where only one of u and v is NaN")
    known = uv[~unknown]
    if np.isinf(known).any() or (known.size and (known.min() < 0.0 or known.max() > 1.0)):
        raise ValueError(f"{what} coordinates must be normalised to [0, 1] (or NaN where unknown), "
                         f"got [{known.min():.6g}, {known.max():.6g}]")
    if grid.shape[2] == 2:
        error = np.where(unknown[..., 0], np.float32(1.0), np.float32(np.nan))
        return np.concatenate([grid, error[..., None]], axis=2)
    error = grid[..., 2]
    error_known = error[~np.isnan(error)]
    if error_known.size and (not np.isfinite(error_known).all() or error_known.min() < 0.0 or error_known.max() > 1.0):
        raise ValueError(f"{what} error channel must lie in [0, 1] or be NaN")
    return grid


def check_3d_map(value, what: str, size: tuple[int, int]) -> np.ndarray:
    """A shader lamp's 3D geometry (3.6.3): (h', w', 3) surface points, finite or NaN all three."""
    array = check_float_array(value, what, "(h, w, 3)", 3)
    if array.shape[2] != 3:
        raise ValueError(f"{what} must hold 3D points, shape (h, w, 3), got shape {array.shape}")
    _check_grid(array, what, size)
    grid = array.astype(np.float32)
    unknown = np.isnan(grid)
    if (unknown.any(axis=2) != unknown.all(axis=2)).any():
        raise ValueError(f"{what} has points with some but not all of x, y, z NaN")
    if np.isinf(grid).any():
        raise ValueError(f"{what} holds infinite coordinates")
    if unknown.all():
        raise ValueError(f"{what} holds no known point")
    return grid


def check_frustum(frustum, what: str) -> MpcdiFrustum:
    """Finite angles, left < right and down < up (2.2.1), each edge within (-90, 90) degrees."""
    if not isinstance(frustum, MpcdiFrustum):
        raise ValueError(f"{what} frustum must be an MpcdiFrustum, got {type(frustum).__name__}")
    for name in ("yaw", "pitch", "roll"):
        check_number(getattr(frustum, name), f"{what} frustum {name}")
    for name in ("right_angle", "left_angle", "up_angle", "down_angle"):
        check_number(getattr(frustum, name), f"{what} frustum {name}", -90.0, 90.0)
    if not frustum.left_angle < frustum.right_angle:
        raise ValueError(f"{what} frustum left angle {frustum.left_angle} must be less than right angle "
                         f"{frustum.right_angle}")
    if not frustum.down_angle < frustum.up_angle:
        raise ValueError(f"{what} frustum down angle {frustum.down_angle} must be less than up angle "
                         f"{frustum.up_angle}")
    return frustum


def check_coordinate_frame(frame, what: str) -> MpcdiCoordinateFrame:
    """A finite position and three orthonormal unit axes (2.2.2)."""
    if not isinstance(frame, MpcdiCoordinateFrame):
        raise ValueError(f"{what} coordinate frame must be an MpcdiCoordinateFrame, got {type(frame).__name__}")
    vectors = {}
    for name in ("position", "yaw_axis", "pitch_axis", "roll_axis"):
        try:
            vector = np.asarray(getattr(frame, name), dtype=np.float64)
        except (TypeError, ValueError):
            vector = None
        if vector is None or vector.shape != (3,) or not np.isfinite(vector).all():
            raise ValueError(f"{what} coordinate frame {name} must be three finite numbers")
        vectors[name] = vector
    axes = np.stack([vectors["yaw_axis"], vectors["pitch_axis"], vectors["roll_axis"]])
    if np.abs(axes @ axes.T - np.eye(3)).max() > _UNIT_TOLERANCE:
        raise ValueError(f"{what} coordinate frame yaw, pitch and roll axes must be orthonormal unit vectors")
    return frame
