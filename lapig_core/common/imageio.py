# SPDX-License-Identifier: GPL-3.0-or-later
"""Reading and writing images as float32 RGB arrays in [0, 1].

OpenCV stores colour images as BGR; every function here speaks RGB so the
rest of the code never has to think about channel order. Files are read
through ``np.fromfile`` + ``cv2.imdecode`` (and written the mirror way) so
non-ASCII paths work on Windows, where ``cv2.imread`` cannot open them.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from .atomic import atomic_write_bytes

_JPEG_MAGIC = b"\xff\xd8\xff"


class ImageReadError(OSError):
    """An image file is missing, unreadable or not a decodable image."""


def to_float(img: np.ndarray) -> np.ndarray:
    """Scale uint8/uint16/float pixels to float32 in [0, 1] (NaN -> 0)."""
    img = np.asarray(img)
    if img.dtype == np.uint8:
        return img.astype(np.float32) / np.float32(255)
    if img.dtype == np.uint16:
        return img.astype(np.float32) / np.float32(65535)
    if img.dtype == np.bool_:
        return img.astype(np.float32)
    if np.issubdtype(img.dtype, np.floating):
        out = np.nan_to_num(img.astype(np.float32), nan=0.0, posinf=1.0, neginf=0.0)
        return np.clip(out, 0.0, 1.0)  # not in place: a 0-d input comes back as a scalar
    raise TypeError(f"unsupported pixel type {img.dtype}; expected uint8, uint16 or float")


def to_uint8(img: np.ndarray) -> np.ndarray:
    """Convert float [0, 1] (clipped), uint16 or uint8 pixels to uint8."""
    img = np.asarray(img)
    if img.dtype == np.uint8:
        return img
    if img.dtype == np.uint16:
        return ((img.astype(np.uint32) + 128) // 257).astype(np.uint8)
    return (to_float(img) * 255.0 + 0.5).astype(np.uint8)


def to_uint16(img: np.ndarray) -> np.ndarray:
    """Convert float [0, 1] (clipped), uint8 or uint16 pixels to uint16."""
    img = np.asarray(img)
    if img.dtype == np.uint16:
        return img
    if img.dtype == np.uint8:
        return img.astype(np.uint16) * np.uint16(257)
    return (to_float(img).astype(np.float64) * 65535.0 + 0.5).astype(np.uint16)


def to_bit_depth(img: np.ndarray, bit_depth: int) -> np.ndarray:
    """The pixels an 8- or 16-bit image file holds for ``img`` (to_uint8 or to_uint16)."""
    if bit_depth not in (8, 16):
        raise ValueError(f"bit_depth must be 8 or 16, got {bit_depth}")
    return to_uint8(img) if bit_depth == 8 else to_uint16(img)


def _to_rgb(img: np.ndarray, alpha_over_black: bool) -> np.ndarray:
    """Pixels in any channel layout OpenCV returns -> (H, W, 3) RGB; alpha over black (float pixels then)
    or dropped."""
    if img.ndim == 2:
        img = img[:, :, None]
    channels = img.shape[2]
    if channels in (2, 4) and alpha_over_black:  # transparent areas project as black
        img = to_float(img)
        img = img[:, :, :-1] * img[:, :, -1:]
    elif channels in (2, 4):
        img = img[:, :, :-1]
    channels = img.shape[2]
    if channels == 1:
        return np.repeat(img, 3, axis=2)
    if channels == 3:
        return np.ascontiguousarray(img[:, :, ::-1])
    raise ValueError(f"unsupported channel count {img.shape[2]}")


def decode_image(data, exif_turn: bool = True, alpha_over_black: bool = True) -> np.ndarray | None:
    """The RGB (H, W, 3) pixels of an image file's bytes, in the file's type (uint8, uint16, float32;
    float32 where alpha was laid over black); None when they do not decode.

    exif_turn: a JPEG is turned by its EXIF orientation (it holds no alpha); everything else is decoded
    unchanged, keeping 16-bit depth and alpha. A camera's frames keep the sensor's grid (exif_turn=False:
    every frame the same geometry) and drop alpha, which means nothing in a photograph.
    """
    data = np.frombuffer(data, np.uint8) if isinstance(data, (bytes, bytearray)) else data
    if not data.size:
        return None
    turn = exif_turn and data[:3].tobytes() == _JPEG_MAGIC
    img = cv2.imdecode(data, cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH if turn else cv2.IMREAD_UNCHANGED)
    if img is None or img.size == 0:
        return None
    return _to_rgb(img, alpha_over_black)


def read_image(path) -> np.ndarray:
    """Read an 8/16-bit PNG, JPEG, BMP, TIFF, ... as float32 RGB (H, W, 3) in [0, 1].

    Grayscale is replicated to three channels; alpha is composited over black.
    Raises ImageReadError naming the file when it is missing or undecodable.
    """
    path = Path(path)
    if not path.is_file():
        raise ImageReadError(f"image file not found: {path}")
    try:
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise ImageReadError(f"cannot read image file {path}: {exc}") from exc
    try:
        img = decode_image(data)
        if img is None:
            raise ImageReadError(
                f"cannot decode image file {path}: it is empty, truncated or not a supported image format"
            )
        return to_float(img)
    except (TypeError, ValueError) as exc:
        raise ImageReadError(f"cannot use image file {path}: {exc}") from exc


def encode_png(img: np.ndarray, bit_depth: int = 8, what: str = "an image") -> bytes:
    """The 8- or 16-bit PNG file of an RGB (H, W, 3) or grayscale (H, W) image.

    Accepts float [0, 1] (clipped), uint8 or uint16 pixels (to_bit_depth). Through cv2.imencode, never
    cv2.imwrite, so the caller writes the bytes to any path (non-ASCII ones on Windows too).
    """
    img = np.asarray(img)
    if not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] in (1, 3))):
        raise ValueError(f"expected an (H, W) or (H, W, 3) image, got shape {img.shape}")
    pixels = to_bit_depth(img, bit_depth)
    if pixels.ndim == 3 and pixels.shape[2] == 3:
        pixels = pixels[:, :, ::-1]  # RGB -> BGR
    ok, encoded = cv2.imencode(".png", np.ascontiguousarray(pixels))
    if not ok:
        raise OSError(f"OpenCV failed to encode PNG for {what}")
    return encoded.tobytes()


def write_png(path, img: np.ndarray, bit_depth: int = 8) -> Path:
    """Write an image as an 8- or 16-bit PNG (encode_png). Parent folders are created; the write is
    atomic (common/atomic)."""
    return atomic_write_bytes(path, encode_png(img, bit_depth, str(path)))
