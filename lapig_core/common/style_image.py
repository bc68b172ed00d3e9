"""Reading a reference image for the arbitrary-style backend, with a clear message for bad input.

numpy + OpenCV only (no torch), so the add-on can check a chosen file before any model loads;
check_path needs neither (the panel calls it on every redraw), so OpenCV is imported where it is used.
A file that is missing, a folder, not an image or smaller than MIN_SIDE is refused with one line;
a grayscale, transparent or 16-bit image is converted and a huge one resized, each with a note
that says what was done.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MIN_SIDE = 32  # the predictor halves the image five times: less leaves no texture to read
MAX_SIDE = 1024  # longer side kept; the predictor reads a 256 px centre square, more only costs memory
MAX_FILE_MB = 256  # refused before decoding (a decoded 256 MB PNG can be gigabytes)


class StyleImageError(ValueError):
    """A style image cannot be used; the message names the file and why."""


@dataclass
class StyleImage:
    path: str
    image: np.ndarray  # (H, W, 3) float32 RGB in [0, 1]
    original_size: tuple[int, int]  # (width, height) of the file
    notes: list[str] = field(default_factory=list)

    def summary(self) -> dict:
        h, w = self.image.shape[:2]
        return {"path": self.path, "file_size": list(self.original_size), "used_size": [w, h],
                "notes": list(self.notes)}


def parse_style_image_spec(spec: str) -> tuple[str, float]:
    """'painting.png' -> ('painting.png', 1.0); 'painting.png:0.3' -> ('painting.png', 0.3).

    Only a trailing ':number' is a weight, so Windows drive letters ('C:\\\\a.png') stay paths."""
    spec = spec.strip()
    path, sep, tail = spec.rpartition(":")
    if sep and path and not path.endswith(("\\", "/")):
        try:
            weight = float(tail)
        except ValueError:
            return spec, 1.0
        if weight < 0:
            raise StyleImageError(f"style image weight must not be negative: '{spec}'")
        return path, weight
    return spec, 1.0


def check_path(path) -> Path:
    """The file as a Path; StyleImageError if it is not there or not a file (cheap, no decoding)."""
    if not str(path).strip():
        raise StyleImageError("no style image given")
    p = Path(os.path.expanduser(str(path)))
    if not p.exists():
        raise StyleImageError(f"style image not found: {p}")
    if p.is_dir():
        raise StyleImageError(f"style image {p} is a folder, not an image file")
    size_mb = p.stat().st_size / 2**20
    if size_mb > MAX_FILE_MB:
        raise StyleImageError(f"style image {p} is {size_mb:.0f} MB; use one under {MAX_FILE_MB} MB")
    if size_mb == 0:
        raise StyleImageError(f"style image {p} is empty")
    return p


def prepare_array(img: np.ndarray, name: str = "style image", max_side: int = MAX_SIDE,
                  bgr: bool = False) -> StyleImage:
    """An image array (gray, gray+alpha, colour, colour+alpha; uint8, uint16 or float in [0, 1]) ->
    StyleImage, with notes for what was converted. bgr: channels in OpenCV's order (as decoded).
    `name` is used in messages."""
    import cv2

    from .imageio import to_float

    notes = []
    img = np.asarray(img)
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (2, 3, 4)):
        raise StyleImageError(f"{name}: unsupported image layout {img.shape}")
    h, w = img.shape[:2]
    if min(h, w) < MIN_SIDE:
        raise StyleImageError(f"{name} is too small ({w}x{h} px); a style image needs at least "
                              f"{MIN_SIDE} px on each side")
    if img.dtype == np.uint16:
        notes.append("16-bit image: read at full depth")
    try:
        img = to_float(img)
    except TypeError as exc:
        raise StyleImageError(f"{name}: {exc}") from None
    if img.ndim == 2 or img.shape[2] == 2:
        gray, alpha = (img, None) if img.ndim == 2 else (img[:, :, 0], img[:, :, 1])
        img = np.repeat(gray[:, :, None], 3, axis=2)
        img = img if alpha is None else img * alpha[..., None] + (1 - alpha[..., None])
        notes.append("grayscale image: used as gray RGB (its texture and tone carry the style, not colour)")
        if alpha is not None:
            notes.append("transparent areas were filled with white")
    elif img.shape[2] == 4:
        alpha = img[:, :, 3:4]
        img = (img[:, :, 2::-1] if bgr else img[:, :, :3]) * alpha + (1 - alpha)
        if float(alpha.min()) < 1.0:
            notes.append("transparent areas were filled with white")
    elif bgr:
        img = img[:, :, ::-1]
    if max(h, w) > max_side:
        scale = max_side / max(h, w)
        size = (max(MIN_SIDE, round(w * scale)), max(MIN_SIDE, round(h * scale)))
        img = cv2.resize(np.ascontiguousarray(img), size, interpolation=cv2.INTER_AREA)
        notes.append(f"large image ({w}x{h}): resized to {size[0]}x{size[1]} (the style is read from a "
                     f"256 px centre square)")
    if float(np.ptp(img.reshape(-1, 3), axis=0).max()) < 1e-3:
        notes.append("the image is one flat colour: the style will be that colour's, with no texture")
    return StyleImage(name, np.ascontiguousarray(img, dtype=np.float32), (w, h), notes)


def load_style_image(path, max_side: int = MAX_SIDE) -> StyleImage:
    """Read a style image file; StyleImageError with a one-line reason when it cannot be used."""
    import cv2

    p = check_path(path)
    data = np.fromfile(p, dtype=np.uint8)  # np.fromfile + imdecode: non-ASCII paths work on Windows
    img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise StyleImageError(f"{p} is not an image OpenCV can read (use PNG, JPEG, BMP, TIFF or WebP)")
    out = prepare_array(img, name=f"style image {p.name}", max_side=max_side, bgr=True)
    out.path = str(p)
    return out
