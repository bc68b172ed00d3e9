# SPDX-License-Identifier: GPL-3.0-or-later
"""Export of finished projector images: native-resolution PNGs, JSON sidecars, crossfades.

The optimiser works on a small working frame (e.g. 256x192 for an 800x600 projector) that covers
the whole projector frame. What a user loads into a real projector is the full native frame:
this module writes the pixels of projector_model.quantised_frame, the same placement and rounding
the Blender light, Render Real Capture and the capture patterns use, so the file is exactly the
image that was rendered and checked. It writes 8- or 16-bit PNGs and records next to each image
how it was made (a JSON sidecar), so a result can be reproduced or traced later.

Every file is written to a temporary name in the target folder and renamed into place only
once complete: a full disk or a crash never leaves a truncated PNG, or a PNG without its
sidecar. Paths go through Python's file API and cv2.imencode (never cv2.imwrite), so
non-ASCII names work on every platform.

No bpy here: the Blender operators call this module, and the tests run it without Blender.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import json
import math
import os
import platform
import sys
from pathlib import Path

import cv2
import numpy as np

from ..common import atomic
from ..common.imageio import encode_png, to_bit_depth, to_float
from ..common.jsonable import jsonable
from ..common.resample import SAME_SIZE, resampling
from ..optics.projector_model import frame_from_working_image, quantised_frame
from ..optics.working_frame import WorkingFrameError, check_aspect

__all__ = [
    "ExportError",
    "export_projector_image",
    "crossfade_sequence",
    "EASES",
]

EASES = ("linear", "smooth")

_DISK_FULL_ERRNOS = {errno.ENOSPC} | ({errno.EDQUOT} if hasattr(errno, "EDQUOT") else set())


class ExportError(ValueError):
    """An export that cannot be done, with a message the user can act on."""


# ----------------------------------------------------------------------------- validation


def _check_size(width, height) -> tuple[int, int]:
    for label, value in (("width", width), ("height", height)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ExportError(f"projector {label} must be a positive whole number of pixels, got {value!r}")
    return int(width), int(height)


def _check_bit_depth(bit_depth) -> int:
    if isinstance(bit_depth, (bool, np.bool_)) or bit_depth not in (8, 16):
        raise ExportError(f"bit depth must be 8 or 16, got {bit_depth!r}")
    return int(bit_depth)


def _as_rgb_float(image, what: str) -> np.ndarray:
    """Any (H, W), (H, W, 1) or (H, W, 3) uint8/uint16/float array -> float32 RGB in [0, 1]."""
    try:
        img = np.asarray(image)
    except Exception as exc:  # ragged lists and the like
        raise ExportError(f"{what} is not an image array: {exc}") from exc
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)):
        raise ExportError(f"{what} must be an (H, W) or (H, W, 3) image array, got shape {img.shape}")
    if img.shape[0] < 1 or img.shape[1] < 1:
        raise ExportError(f"{what} is empty (shape {img.shape})")
    try:
        img = to_float(img)  # NaN -> 0, clipped to [0, 1]
    except TypeError as exc:
        raise ExportError(f"{what}: {exc}") from exc
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    return img


# ----------------------------------------------------------------------------- the frame


def _working(image, width: int, height: int, what: str) -> np.ndarray:
    """A working frame (or a native one) of the projector's aspect ratio, as float RGB."""
    img = _as_rgb_float(image, what)
    try:
        check_aspect((img.shape[1], img.shape[0]), (width, height), what)
    except WorkingFrameError as exc:
        raise ExportError(str(exc)) from None
    return img


def _native(image, width: int, height: int, what: str) -> tuple[np.ndarray, str]:
    """(frame, how it was resampled): a working frame resized to the native one (one at native
    size is used as is)."""
    img = _working(image, width, height, what)
    if img.shape[:2] == (height, width):
        return img, SAME_SIZE
    return frame_from_working_image(img, width, height), resampling(img.shape[:2], (height, width))


def _encode_png(pixels: np.ndarray, bit_depth: int, name: str) -> bytes:
    """RGB pixels -> the PNG bytes of a bit_depth file (imageio.encode_png)."""
    try:
        return encode_png(pixels, bit_depth, name)
    except OSError as exc:
        raise ExportError(str(exc)) from exc


# ----------------------------------------------------------------------------- JSON


def software_info(lapig_version) -> dict:
    """Versions of what made the image, so a result can be traced to its environment."""
    info = {
        "lapig": str(lapig_version) if lapig_version is not None else "unknown",
        "python": platform.python_version(),
        "numpy": np.__version__,
        "opencv": cv2.__version__,
    }
    torch = sys.modules.get("torch")
    if torch is not None and hasattr(torch, "__version__"):
        info["torch"] = str(torch.__version__)
    else:  # read the installed version without paying for `import torch`
        try:
            from importlib import metadata

            info["torch"] = metadata.version("torch")
        except Exception:
            pass
    return info


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds").replace("+00:00", "Z")


def sidecar_bytes(caller: dict | None, own: dict) -> bytes:
    """Caller's metadata plus this module's keys; dict values under the same key are merged."""
    if caller is not None and not isinstance(caller, dict):
        raise ExportError(f"metadata must be a dict, got {type(caller).__name__}")
    data = jsonable(dict(caller or {}))
    for key, value in own.items():
        value = jsonable(value)
        if isinstance(data.get(key), dict) and isinstance(value, dict):
            value = {**data[key], **value}
        data[key] = value
    return (json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n").encode("utf-8")


# ----------------------------------------------------------------------------- atomic files


def check_folder(folder: Path) -> None:
    if not folder.exists():
        raise ExportError(f"output folder does not exist: {folder}")
    if not folder.is_dir():
        raise ExportError(f"output folder is not a folder: {folder}")


def write_error(exc: OSError, target: Path) -> ExportError:
    if isinstance(exc, PermissionError):
        return ExportError(f"cannot write to folder {target.parent}: permission denied")
    if getattr(exc, "errno", None) in _DISK_FULL_ERRNOS:
        return ExportError(f"could not write {target.name} to {target.parent}: the disk may be full ({exc})")
    return ExportError(
        f"could not write {target.name} to {target.parent}: {exc} (the disk may be full or the drive gone)"
    )


def _commit(files: list[tuple[Path, bytes]]) -> list[Path]:
    """atomic.commit (nothing under a final name until every file is complete; put the image last), its
    failures as ExportErrors that say what to do."""
    return atomic.commit(files, write_error)


def _png_path(out_path) -> Path:
    try:
        path = Path(os.fspath(out_path))
    except TypeError as exc:
        raise ExportError(f"output path must be a path or string, got {type(out_path).__name__}") from exc
    if not path.name:
        raise ExportError(f"output path has no file name: {out_path!r}")
    if path.suffix.lower() != ".png" and not path.is_dir():  # a folder is refused, not written beside
        path = path.with_name(path.name + ".png")
    return path


# ----------------------------------------------------------------------------- public API


def export_projector_image(out_path, working_image, width: int, height: int, bit_depth: int = 8,
                           metadata: dict | None = None, *, lapig_version: str | None = None) -> dict:
    """Write the native-resolution projector PNG and its JSON sidecar `<name>.json`.

    ``.png`` is appended to a path that lacks it. The folder must exist (a missing one is
    more likely a typo or an unplugged drive than a wish to create it). The sidecar holds
    ``metadata`` (prompt, backend, seed, settings, metrics, projector/camera parameters...)
    plus ``software``, ``image`` and ``created``, which this function fills in itself.
    Both files are written to temp names first and renamed only when both are complete.
    Returns {"image": Path, "sidecar": Path}. Raises ExportError.
    """
    bit_depth = _check_bit_depth(bit_depth)
    width, height = _check_size(width, height)
    png_path = _png_path(out_path)
    json_path = png_path.with_suffix(".json")
    check_folder(png_path.parent)
    if png_path.is_dir():
        raise ExportError(f"output path is a folder, not a file name: {png_path} (e.g. "
                          f"{png_path / 'projector_image.png'})")

    working = _working(working_image, width, height, "working image")
    pixels = quantised_frame(working, width, height, bit_depth)
    own = {
        "software": software_info(lapig_version),
        "image": {
            "file": png_path.name,
            "width": width,
            "height": height,
            "bit_depth": bit_depth,
            "channels": "RGB",
            # the working frame covers the whole native frame
            "working_frame": [int(working.shape[1]), int(working.shape[0])],
            "resampling": resampling(working.shape[:2], (height, width)),
        },
        "created": utc_now(),
    }
    sidecar = sidecar_bytes(metadata, own)
    png = _encode_png(pixels, bit_depth, png_path.name)
    _commit([(json_path, sidecar), (png_path, png)])  # image last: its appearance means done
    return {"image": png_path, "sidecar": json_path}


def _ease(t: float, ease: str) -> float:
    # smoothstep: zero slope at both ends, so the fade starts and lands without a jolt
    return t if ease == "linear" else t * t * (3.0 - 2.0 * t)


def crossfade_sequence(out_dir, image_a, image_b, frames: int = 60, *, width: int, height: int,
                       bit_depth: int = 8, ease: str = "linear", name: str = "crossfade",
                       gamma: float = 2.2, metadata: dict | None = None,
                       source_labels: tuple[str, str] | None = None,
                       lapig_version: str | None = None, on_progress=None) -> list[Path]:
    """Write `name_0001.png` ... `name_NNNN.png` blending image_a into image_b, plus `name.json`.

    Each image is either a working frame (resized like export_projector_image does) or an
    already native (height, width) frame; the first and last frames are those images' exports.
    The blend is done in the projector's linear light: values are raised to ``gamma`` (the
    projector's transfer, ProjectorModel.gamma), mixed, and taken back with 1/gamma. Mixing the
    encoded values instead would not mix the light: halfway between red and green it would emit
    (0.5^2.2 ~ 0.22) of each, a visible dip in brightness mid-fade, whereas mixing light behaves
    like a real dissolve between two projectors with constant total output. (The projector's
    black level is an affine term and cancels out.)
    ``out_dir`` is created if its parent exists. Frames written before a failure are removed;
    the sidecar is written last. on_progress(fraction, message) hears about every 1% of the frames.
    Returns the frame paths in order. Raises ExportError.
    """
    bit_depth = _check_bit_depth(bit_depth)
    width, height = _check_size(width, height)
    if isinstance(frames, (bool, np.bool_)) or not isinstance(frames, (int, np.integer)) or frames < 2:
        raise ExportError(f"a crossfade needs at least 2 frames, got {frames!r}")
    frames = int(frames)
    if ease not in EASES:
        raise ExportError(f"ease must be one of {list(EASES)}, got {ease!r}")
    try:
        gamma = float(gamma)
    except (TypeError, ValueError) as exc:
        raise ExportError(f"gamma must be a number, got {gamma!r}") from exc
    if not (math.isfinite(gamma) and gamma > 0):
        raise ExportError(f"gamma must be a positive number, got {gamma}")
    if (not isinstance(name, str) or not name.strip() or name in (".", "..")
            or any(sep in name for sep in ("/", "\\", os.sep))):
        raise ExportError(f"sequence name must be a plain file name without folders, got {name!r}")

    folder = Path(os.fspath(out_dir))
    if not folder.exists():
        check_folder(folder.parent)
        try:
            folder.mkdir()
        except OSError as exc:
            raise ExportError(f"cannot create output folder {folder}: {exc}") from exc
    check_folder(folder)

    frame_a, resampled_a = _native(image_a, width, height, "image A")
    frame_b, resampled_b = _native(image_b, width, height, "image B")
    lin_a = np.power(frame_a, np.float32(gamma))
    lin_b = np.power(frame_b, np.float32(gamma))

    digits = max(4, len(str(frames)))
    paths = [folder / f"{name}_{i:0{digits}d}.png" for i in range(1, frames + 1)]
    weights = [_ease(i / (frames - 1), ease) for i in range(frames)]
    labels = list(source_labels) if source_labels is not None else ["A", "B"]
    if len(labels) != 2:
        raise ExportError(f"source_labels must name 2 sources, got {len(labels)}")
    own = {
        "software": software_info(lapig_version),
        "crossfade": {
            "frames": frames,
            "ease": ease,
            "gamma": gamma,
            "blend": "linear light: ((1-w)*a^gamma + w*b^gamma)^(1/gamma)",
            "weights": weights,
            "files": [p.name for p in paths],
        },
        "sources": [
            {"label": labels[0], "input_size": list(np.shape(image_a)[:2]), "resampling": resampled_a},
            {"label": labels[1], "input_size": list(np.shape(image_b)[:2]), "resampling": resampled_b},
        ],
        "image": {"width": width, "height": height, "bit_depth": bit_depth, "channels": "RGB"},
        "created": utc_now(),
    }
    sidecar = sidecar_bytes(metadata, own)

    written: list[Path] = []
    try:
        for path, w in zip(paths, weights):
            frame = blend_linear_light(frame_a, frame_b, lin_a, lin_b, w, gamma)
            written += _commit([(path, _encode_png(frame, bit_depth, path.name))])
            if on_progress and (len(written) % max(1, frames // 100) == 0 or len(written) == frames):
                on_progress(len(written) / frames, f"wrote crossfade frame {len(written)}/{frames}")
        _commit([(folder / f"{name}.json", sidecar)])
    except BaseException:
        for path in written:
            with contextlib.suppress(OSError):
                os.unlink(path)
        raise
    return written


def blend_linear_light(frame_a, frame_b, lin_a, lin_b, w: float, gamma: float) -> np.ndarray:
    """The crossfade at weight w, mixed in the projector's linear light (see crossfade_sequence)."""
    if w == 0.0:  # the end frames are the images themselves, not a gamma round trip
        return frame_a
    if w == 1.0:
        return frame_b
    return np.power(lin_a * np.float32(1.0 - w) + lin_b * np.float32(w), np.float32(1.0 / gamma))


def crossfade_frames(image_a, image_b, frames: int, *, width: int, height: int, bit_depth: int = 8,
                     ease: str = "smooth", gamma: float = 2.2):
    """The frames crossfade_sequence writes, as (height, width, 3) pixels at ``bit_depth``, one at a time
    (a live projector window plays them; nothing is written)."""
    bit_depth, (width, height) = _check_bit_depth(bit_depth), _check_size(width, height)
    if ease not in EASES or not isinstance(frames, (int, np.integer)) or frames < 2:
        raise ExportError(f"a crossfade needs at least 2 frames and an ease among {list(EASES)}")
    frame_a, _ = _native(image_a, width, height, "image A")
    frame_b, _ = _native(image_b, width, height, "image B")
    lin_a, lin_b = np.power(frame_a, np.float32(gamma)), np.power(frame_b, np.float32(gamma))
    for i in range(frames):
        w = _ease(i / (frames - 1), ease)
        yield to_bit_depth(blend_linear_light(frame_a, frame_b, lin_a, lin_b, w, gamma), bit_depth)
