# SPDX-License-Identifier: GPL-3.0-or-later
"""Projector images for training and testing compensation models.

A compensation network has to learn the projector-surface-camera response for
any content, so training images must span colours, brightness and spatial
frequencies the way natural images do. ``generate_patterns`` synthesises such
images procedurally (no bundled photographs); ``load_image_folder`` uses the
user's own pictures instead; ``reference_patterns`` gives the black, white and
gray frames projected to measure the surface.

All images are float32 RGB arrays of shape (height, width, 3) in [0, 1]: the working frame.
"""

from __future__ import annotations

import functools
import math
import string
from pathlib import Path

import cv2
import numpy as np

from ..common.imageio import ImageReadError, read_image

IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")

_SEED_MASK = (1 << 64) - 1


class PatternFolderError(ValueError):
    """A folder of user images cannot be turned into projector patterns."""


# --------------------------------------------------------------------------
# Synthetic patterns
# --------------------------------------------------------------------------


def generate_patterns(count: int, width: int = 256, height: int = 256, seed: int = 0) -> np.ndarray:
    """``count`` varied, natural-image-like patterns, float32 (count, height, width, 3).

    Image k depends only on (seed, k, width, height), so asking for more images keeps
    the first ones unchanged.
    """
    if count < 0:
        raise ValueError(f"count must be >= 0, got {count}")
    if min(width, height) < 8:
        raise ValueError(f"patterns must be at least 8x8, got {width}x{height}")
    out = np.empty((count, height, width, 3), np.float32)
    for index in range(count):
        out[index] = generate_pattern(index, width, height, seed)
    return out


def generate_pattern(index: int, width: int = 256, height: int = 256, seed: int = 0) -> np.ndarray:
    """Pattern number ``index`` of the set generated from ``seed``: drawn on a square of the long
    side (the generator is isotropic), then the frame's centre is kept."""
    square = _square_pattern(index, max(width, height), seed)
    top, left = (square.shape[0] - height) // 2, (square.shape[1] - width) // 2
    return np.ascontiguousarray(square[top:top + height, left:left + width])


def _square_pattern(index: int, size: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng([seed & _SEED_MASK, index])
    img = _background(rng, size)
    for _ in range(rng.integers(3, 11)):
        alpha = 1.0 if rng.random() < 0.75 else rng.uniform(0.35, 0.9)
        _composite(img, _shape_mask(rng, size), _fill(rng, size), alpha)
    for _ in range(rng.integers(0, 4) if rng.random() < 0.5 else 0):
        _add_blob(rng, img)
    if rng.random() < 0.2:
        _add_fine_detail(rng, img)
    if rng.random() < 0.4:  # uneven illumination, as in photographs
        img *= 0.55 + 0.5 * _unit_noise(rng, size, beta=3.0)[:, :, None]
    if rng.random() < 0.5:  # vary the tone distribution across the set
        np.clip(img, 0.0, 1.0, out=img)
        img **= np.float32(math.exp(rng.uniform(-0.6, 0.6)))
    return np.clip(img, 0.0, 1.0, out=img)


# -- colours ---------------------------------------------------------------


def _hue_colour(hue: float, sat: float, val: float) -> np.ndarray:
    rgb = np.clip(np.abs((hue * 6.0 + np.array([0.0, 4.0, 2.0])) % 6.0 - 3.0) - 1.0, 0.0, 1.0)
    return (val * (1.0 - sat + sat * rgb)).astype(np.float32)


def _colour(rng) -> np.ndarray:
    """A colour biased towards the corners of the RGB cube the projector must learn."""
    kind = rng.random()
    if kind < 0.35:
        return rng.random(3).astype(np.float32)
    if kind < 0.6:  # saturated
        return _hue_colour(rng.random(), rng.uniform(0.8, 1.0), rng.uniform(0.75, 1.0))
    if kind < 0.72:  # near black, possibly tinted
        return (rng.random(3) * rng.uniform(0.02, 0.1)).astype(np.float32)
    if kind < 0.84:  # near white
        return (1.0 - rng.random(3) * rng.uniform(0.02, 0.1)).astype(np.float32)
    return np.full(3, rng.random(), np.float32)  # neutral gray


def _ramp(t: np.ndarray, colours: list[np.ndarray]) -> np.ndarray:
    """Map scalar field t in [0, 1] through a piecewise-linear colour ramp.

    Done with a 256-entry cv2.LUT, several times faster than per-pixel
    interpolation; 256 steps match the 8-bit precision of the projector.
    """
    stops = np.linspace(0.0, 1.0, len(colours))
    levels = np.linspace(0.0, 1.0, 256)
    table = np.stack([np.interp(levels, stops, [c[i] for c in colours]) for i in range(3)], axis=-1)
    index = (np.clip(t, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    return cv2.LUT(cv2.merge([index, index, index]), table.astype(np.float32).reshape(1, 256, 3))


# -- scalar fields -----------------------------------------------------------


@functools.lru_cache(maxsize=4)
def _grid(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre coordinates in [0, 1], shaped for broadcasting."""
    axis = ((np.arange(size, dtype=np.float32) + 0.5) / size).astype(np.float32)
    axis.setflags(write=False)  # cached and shared: must never be modified in place
    return axis[:, None], axis[None, :]


@functools.lru_cache(maxsize=4)
def _frequencies(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """rfft2 frequency grid in cycles per image, and log of its radius (DC -> 0)."""
    fy = np.fft.fftfreq(size, 1.0 / size)[:, None].astype(np.float32)
    fx = np.fft.rfftfreq(size, 1.0 / size)[None, :].astype(np.float32)
    radius = np.hypot(fx, fy)
    radius[0, 0] = 1.0
    log_radius = np.log(radius)
    for cached in (fy, fx, log_radius):
        cached.setflags(write=False)  # shared between calls
    return fy, fx, log_radius


def _noise(rng, size: int, beta: float | None = None, band: float | None = None) -> np.ndarray:
    """Zero-mean, unit-variance 1/f^beta noise, optionally band-limited and anisotropic."""
    fy, fx, log_freq = _frequencies(size)
    if beta is None:
        beta = rng.uniform(1.0, 3.0)
    if rng.random() < 0.3:  # stretched along a random direction: grain, fibres
        angle, stretch = rng.uniform(0, math.pi), rng.uniform(2.0, 8.0)
        u = fx * math.cos(angle) + fy * math.sin(angle)
        v = (fy * math.cos(angle) - fx * math.sin(angle)) * stretch
        freq = np.hypot(u, v)
        freq[0, 0] = 1.0
        log_freq = np.log(freq)
    # Amplitude spectrum f^-(beta/2 + 1/2) in 2-D gives a 1/f^beta power falloff
    # along any line; the optional log-Gaussian keeps one band of scales.
    log_amplitude = log_freq * np.float32(-(beta / 2.0 + 0.5))
    if band is not None:
        log_amplitude -= np.float32(0.5 / 0.4**2) * (log_freq - np.float32(math.log(band))) ** 2
    amplitude = np.exp(log_amplitude)
    amplitude[0, 0] = 0.0
    shape = amplitude.shape
    spectrum = rng.standard_normal(shape, dtype=np.float32) * amplitude + 1j * (
        rng.standard_normal(shape, dtype=np.float32) * amplitude
    )
    field = np.fft.irfft2(spectrum, s=(size, size)).astype(np.float32)
    field -= field.mean()
    field /= field.std() + np.float32(1e-12)
    return field


def _unit_noise(rng, size: int, beta: float | None = None, band: float | None = None) -> np.ndarray:
    """Noise squashed into [0, 1]; a high gain gives hard-edged, blotchy regions."""
    gain = math.exp(rng.uniform(math.log(0.4), math.log(4.0)))
    return 0.5 + 0.5 * np.tanh(gain * _noise(rng, size, beta, band))


def _random_band(rng, size: int) -> float:
    return math.exp(rng.uniform(math.log(2.0), math.log(size / 4.0)))


def _linear_ramp(rng, size: int) -> np.ndarray:
    yy, xx = _grid(size)
    angle = rng.uniform(0, 2 * math.pi)
    t = (xx - 0.5) * math.cos(angle) + (yy - 0.5) * math.sin(angle)
    return np.clip(t * rng.uniform(0.7, 2.5) + 0.5 + rng.uniform(-0.3, 0.3), 0.0, 1.0)


def _radial_ramp(rng, size: int) -> np.ndarray:
    yy, xx = _grid(size)
    cy, cx = rng.uniform(-0.2, 1.2, 2)
    return np.clip(np.hypot(yy - cy, xx - cx) / rng.uniform(0.2, 1.2), 0.0, 1.0)


# -- layers --------------------------------------------------------------------


def _background(rng, size: int) -> np.ndarray:
    kind = rng.integers(4)
    if kind == 0:  # smooth colour field: a few colour nodes interpolated
        nodes = rng.integers(2, 6)
        grid = np.stack([_colour(rng) for _ in range(nodes * nodes)]).reshape(nodes, nodes, 3)
        img = cv2.resize(grid, (size, size), interpolation=cv2.INTER_CUBIC)
    elif kind == 1:
        img = _ramp(_linear_ramp(rng, size), [_colour(rng) for _ in range(rng.integers(2, 4))])
    elif kind == 2:
        img = _ramp(_radial_ramp(rng, size), [_colour(rng) for _ in range(rng.integers(2, 4))])
    else:
        img = _ramp(_unit_noise(rng, size), [_colour(rng) for _ in range(rng.integers(2, 5))])
    return np.ascontiguousarray(img, dtype=np.float32)


def _fill(rng, size: int) -> np.ndarray:
    """What a shape is painted with: flat colour, gradient, texture, stripes."""
    kind = rng.random()
    if kind < 0.3:
        return _colour(rng)[None, None, :]
    if kind < 0.45:
        return _ramp(_linear_ramp(rng, size), [_colour(rng), _colour(rng)])
    if kind < 0.52:
        return _ramp(_radial_ramp(rng, size), [_colour(rng), _colour(rng)])
    if kind < 0.7:  # texture at a random scale through a colour ramp
        band = _random_band(rng, size) if rng.random() < 0.5 else None
        return _ramp(_unit_noise(rng, size, band=band), [_colour(rng) for _ in range(rng.integers(2, 4))])
    if kind < 0.78:  # surface texture: a colour with brightness variation
        shade = 1.0 + rng.uniform(0.1, 0.5) * np.tanh(_noise(rng, size))
        return _colour(rng)[None, None, :] * shade[:, :, None]
    if kind < 0.84:  # independent colour noise per channel
        return np.stack([_unit_noise(rng, size) for _ in range(3)], axis=-1)
    return _stripes(rng, size)


def _stripes(rng, size: int) -> np.ndarray:
    """Square or sine gratings between two colours, any angle and frequency."""
    yy, xx = _grid(size)
    cycles = math.exp(rng.uniform(math.log(1.5), math.log(size / 3.0)))
    angle = rng.uniform(0, math.pi)
    phase = 2 * math.pi * cycles * (xx * math.cos(angle) + yy * math.sin(angle)) + rng.uniform(0, 2 * math.pi)
    wave = np.sin(phase)
    t = (wave > 0).astype(np.float32) if rng.random() < 0.6 else 0.5 + 0.5 * wave
    return _ramp(t, [_colour(rng), _colour(rng)])


def _point(xy) -> tuple[int, int]:
    """OpenCV drawing wants plain int tuples."""
    return int(xy[0]), int(xy[1])


def _shape_mask(rng, size: int) -> np.ndarray:
    """A float mask of one shape; sizes are log-uniform so edges occur at every scale."""
    mask = np.zeros((size, size), np.uint8)
    scale = size * math.exp(rng.uniform(math.log(0.03), math.log(0.7)))
    centre = rng.uniform(-0.1, 1.1, 2) * size
    line = cv2.LINE_AA if rng.random() < 0.5 else cv2.LINE_8
    kind = rng.integers(7)
    if kind == 0:  # axis-aligned rectangle
        half = rng.uniform(0.2, 1.0, 2) * scale
        corner0, corner1 = _point(centre - half), _point(centre + half)
        cv2.rectangle(mask, corner0, corner1, 255, -1, line)
    elif kind == 1:  # rotated rectangle
        sides = rng.uniform(0.2, 2.0, 2) * scale
        box = (tuple(map(float, centre)), tuple(map(float, sides)), rng.uniform(0, 180))
        cv2.fillPoly(mask, [cv2.boxPoints(box).astype(np.int32)], 255, line)
    elif kind == 2:  # star-shaped polygon
        vertices = rng.integers(3, 9)
        angles = np.sort(rng.uniform(0, 2 * math.pi, vertices))
        radii = scale * rng.uniform(0.3, 1.0, vertices)
        points = centre + np.stack([np.cos(angles), np.sin(angles)], axis=1) * radii[:, None]
        cv2.fillPoly(mask, [points.astype(np.int32)], 255, line)
    elif kind == 3:  # disc or ellipse
        axes = tuple(int(a) + 1 for a in rng.uniform(0.3, 1.0, 2) * scale)
        cv2.ellipse(mask, _point(centre), axes, rng.uniform(0, 180), 0, 360, 255, -1, line)
    elif kind == 4:  # thick or thin lines
        for _ in range(rng.integers(1, 4)):
            start, end = rng.uniform(0, size, (2, 2))
            thickness = max(1, int(math.exp(rng.uniform(0, math.log(max(2.0, size / 12))))))
            cv2.line(mask, _point(start), _point(end), 255, thickness, line)
    elif kind == 5:  # half plane: one long edge across the image
        return _half_plane(rng, size)
    else:  # irregular region from thresholded noise
        noise = _noise(rng, size, beta=rng.uniform(1.5, 3.0))
        return (noise > rng.uniform(-0.5, 1.0)).astype(np.float32)
    out = mask.astype(np.float32) / 255.0
    if rng.random() < 0.15:  # defocused edge
        out = cv2.GaussianBlur(out, (0, 0), rng.uniform(0.7, 3.0))
    return out


def _half_plane(rng, size: int) -> np.ndarray:
    yy, xx = _grid(size)
    angle = rng.uniform(0, 2 * math.pi)
    offset = rng.uniform(-0.4, 0.4)
    side = (xx - 0.5) * math.cos(angle) + (yy - 0.5) * math.sin(angle) > offset
    return side.astype(np.float32)


def _composite(img: np.ndarray, mask: np.ndarray, fill: np.ndarray, alpha: float) -> None:
    """Blend ``fill`` over ``img`` in place where ``mask`` > 0, only inside its bounding box."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return
    box = np.s_[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    weight = mask[box][:, :, None]
    if alpha != 1.0:
        weight = weight * np.float32(alpha)
    region = img[box]
    fill_region = fill[box] if fill.shape[0] > 1 else fill
    delta = fill_region - region
    delta *= weight
    region += delta


def _add_blob(rng, img: np.ndarray) -> None:
    """Soft Gaussian spot of colour, possibly elongated."""
    size = img.shape[0]
    yy, xx = _grid(size)
    cy, cx = rng.uniform(0, 1, 2)
    sy, sx = np.exp(rng.uniform(math.log(0.02), math.log(0.35), 2))
    weight = np.exp(-0.5 * (((yy - cy) / sy) ** 2 + ((xx - cx) / sx) ** 2)) * rng.uniform(0.5, 1.0)
    _composite(img, weight.astype(np.float32), _colour(rng)[None, None, :], 1.0)


def _add_fine_detail(rng, img: np.ndarray) -> None:
    """A patch of pixel-scale content: a fine checker or lines of text-like glyphs."""
    size = img.shape[0]
    mask = np.zeros((size, size), np.uint8)
    h, w = (rng.uniform(0.15, 0.5, 2) * size).astype(int) + 4
    y0, x0 = rng.integers(0, size - h + 1), rng.integers(0, size - w + 1)
    if rng.random() < 0.5:
        period = int(rng.integers(1, 5))
        yy, xx = np.mgrid[0:h, 0:w]
        mask[y0 : y0 + h, x0 : x0 + w] = ((yy // period + xx // period) % 2) * 255
    else:
        font_scale = rng.uniform(0.25, 0.6) * size / 256
        step = max(4, int(26 * font_scale))
        for row in range(y0 + step, y0 + h, step):
            text = "".join(rng.choice(list(string.ascii_letters + string.digits + "  .,"), 40))
            cv2.putText(mask, text, (int(x0), int(row)), cv2.FONT_HERSHEY_SIMPLEX, font_scale, 255, 1, cv2.LINE_AA)
        clip = np.zeros_like(mask)
        clip[y0 : y0 + h, x0 : x0 + w] = 1
        mask *= clip
    _composite(img, mask.astype(np.float32) / 255.0, _colour(rng)[None, None, :], 1.0)


# --------------------------------------------------------------------------
# User images and reference frames
# --------------------------------------------------------------------------


def _fill_resize(img: np.ndarray, width: int, height: int) -> np.ndarray:
    """Centre-crop to the frame's aspect ratio, then resize (area averaging when shrinking)."""
    h, w = img.shape[:2]
    crop_w, crop_h = min(w, round(h * width / height)), min(h, round(w * height / width))
    top, left = (h - crop_h) // 2, (w - crop_w) // 2
    crop = img[top : top + crop_h, left : left + crop_w]
    if (crop_h, crop_w) == (height, width):
        return np.ascontiguousarray(crop)
    interpolation = cv2.INTER_AREA if crop_w > width else cv2.INTER_CUBIC
    return np.clip(cv2.resize(crop, (width, height), interpolation=interpolation), 0.0, 1.0)


def load_image_folder(folder, width: int = 256, height: int = 256, count: int | None = None) -> np.ndarray:
    """Load the images in ``folder`` (sorted by file name) as float32 (N, height, width, 3), each
    cropped to the frame's aspect ratio about its centre.

    Reads PNG, JPEG, BMP, TIFF and WebP; 16-bit, grayscale and alpha are
    handled by read_image. ``count`` takes the first ``count`` images and is
    an error if the folder holds fewer.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise PatternFolderError(f"pattern folder not found: {folder}")
    files = sorted(
        (p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS),
        key=lambda p: p.name.lower(),
    )
    if not files:
        raise PatternFolderError(
            f"pattern folder {folder} contains no images (looked for {', '.join(IMAGE_EXTENSIONS)})"
        )
    if count is not None:
        if count < 1:
            raise ValueError(f"count must be >= 1, got {count}")
        if len(files) < count:
            raise PatternFolderError(f"pattern folder {folder} has {len(files)} images but {count} were requested")
        files = files[:count]
    out = np.empty((len(files), height, width, 3), np.float32)
    for i, path in enumerate(files):
        try:
            out[i] = _fill_resize(read_image(path), width, height)
        except ImageReadError as exc:
            raise PatternFolderError(f"{exc} (in pattern folder {folder})") from exc
    return out


def reference_patterns(width: int = 256, height: int = 256, gray_level: float = 0.5) -> dict[str, np.ndarray]:
    """Uniform 'black', 'white' and 'gray' frames used to measure the surface."""
    if not 0.0 <= gray_level <= 1.0:
        raise ValueError(f"gray_level must be in [0, 1], got {gray_level}")
    return {
        "black": np.zeros((height, width, 3), np.float32),
        "white": np.ones((height, width, 3), np.float32),
        "gray": np.full((height, width, 3), gray_level, np.float32),
    }
