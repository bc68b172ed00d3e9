# SPDX-License-Identifier: GPL-3.0-or-later
"""A show's frames written as a PNG image sequence (8 or 16 bit) with a JSON sidecar; no PyAV needed.

    write_image_sequence(frames, folder, fps, bit_depth=8, cancel_event=None, on_progress=None, metadata=None,
                         *, size=None, show=None, frame_count=None, lapig_version=None) -> dict

- frames: as video.write_video takes them (float [0, 1], uint8 or uint16 (H, W, 3)); a hold given as the same
  array object again is encoded once and its PNG bytes written again (show_output.RepeatedFrame).
- folder: the sequence's own folder: <folder>/frame_000001.png ... and <folder>/sequence.json (the sidecar:
  size, fps, frame count, duration, bit depth, the caller's metadata and `show`). Its parent must exist. A
  folder that exists must be empty or hold a previous sequence (frame_*.png and sequence.json only): another
  folder is refused, never emptied.
- size: (width, height), default the first frame's; fps, frame_count, cancel_event and on_progress as for a video.
Returns {"folder": Path, "sidecar": Path, "frames": n, "files": [Path, ...]}.

Frames go into a scratch folder beside the final one (common/scratch.ScratchFolder: a killed export's is removed by
the next). Only when every frame and the sidecar are written does it take the final name; a previous sequence
there is moved aside first and removed after, and put back should the rename fail. A cancel (show_output.Cancelled)
or an error removes the scratch folder and leaves the previous sequence as it was. The disk is checked before
the first frame where the frame count is known.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

from ..common.imageio import encode_png
from ..common.scratch import ScratchFolder
from .projector_image import ExportError, sidecar_bytes, software_info, utc_now, write_error
from .show_output import (Cancelled, RepeatedFrame, check_disk_space, check_size, check_writable, frame_pixels,
                          frame_rate, known_count)

__all__ = ["write_image_sequence", "frame_name", "SIDECAR_NAME", "Cancelled"]

SIDECAR_NAME = "sequence.json"
_FRAME = re.compile(r"^frame_\d{6,}\.png$")


def frame_name(index: int) -> str:
    """The file name of frame `index` (from 0): frame_000001.png, ..."""
    return f"frame_{index + 1:06d}.png"


def _is_previous_sequence(folder: Path) -> bool:
    """Empty, or only what write_image_sequence writes."""
    return all(_FRAME.match(entry.name) or entry.name == SIDECAR_NAME for entry in folder.iterdir())


def _scratch_prefix(folder: Path) -> str:
    return f".{folder.name}.partial_"


def write_image_sequence(frames, folder, fps, bit_depth: int = 8, cancel_event=None, on_progress=None,
                         metadata: dict | None = None, *, size=None, show: dict | None = None,
                         frame_count: int | None = None, lapig_version: str | None = None) -> dict:
    """Write `frames` as <folder>/frame_000001.png ... with <folder>/sequence.json (see the module docstring)."""
    if isinstance(bit_depth, bool) or bit_depth not in (8, 16):
        raise ExportError(f"an image sequence's bit depth must be 8 or 16, got {bit_depth!r}")
    rate = frame_rate(fps)
    count = known_count(frames, frame_count)
    if count == 0:
        raise ExportError("the show has no frames")
    try:
        folder = Path(os.fspath(folder))
    except TypeError:
        raise ExportError(f"output folder must be a path or string, got {type(folder).__name__}") from None
    if not folder.name:
        raise ExportError(f"output folder has no name: {folder}")
    check_writable(folder.parent)
    if folder.exists() and (not folder.is_dir() or not _is_previous_sequence(folder)):
        raise ExportError(f"{folder} holds other files than an image sequence: choose an empty or new folder")
    if metadata is not None and not isinstance(metadata, dict):
        raise ExportError(f"metadata must be a dict, got {type(metadata).__name__}")

    iterator = iter(frames)
    first = next(iterator, None)
    if first is None:
        raise ExportError("the show has no frames")
    if size is None:
        shape = getattr(first, "shape", None) or (len(first), len(first[0]))
        size = (int(shape[1]), int(shape[0]))
    width, height = check_size(size)
    if count is not None:
        # a PNG holds at most the raw pixels plus a little per line and chunk
        frame_bytes = int(width * height * 3 * bit_depth / 8 * 1.01) + height + 4096
        check_disk_space(folder.parent, count, frame_bytes, f"{width}x{height} {bit_depth}-bit PNG")

    scratch = ScratchFolder(folder.parent, _scratch_prefix(folder))
    files: list[Path] = []
    try:
        repeated, last_png = RepeatedFrame(), None
        step = max(1, (count or 100) // 100)

        def all_frames():
            yield first
            yield from iterator

        for index, frame in enumerate(all_frames()):
            if cancel_event is not None and cancel_event.is_set():
                raise Cancelled("image sequence export cancelled")
            if count is not None and index >= count:
                raise ExportError(f"the show has {count} frames, but more frames came")
            if not repeated.same(frame):  # a hold is encoded once
                pixels = frame_pixels(frame, (width, height), bit_depth, index)
                last_png = encode_png(pixels, bit_depth, frame_name(index))
                repeated.remember(frame)
            path = scratch.path / frame_name(index)
            try:
                path.write_bytes(last_png)
            except OSError as exc:
                raise write_error(exc, folder / path.name) from exc
            files.append(folder / path.name)
            if on_progress is not None and (len(files) % step == 0 or len(files) == count):
                on_progress(len(files) / count if count else None,
                            f"wrote frame {len(files)}" + (f"/{count}" if count else ""))
        if cancel_event is not None and cancel_event.is_set():
            raise Cancelled("image sequence export cancelled")
        if count is not None and len(files) != count:
            raise ExportError(f"the show has {count} frames, but {len(files)} came")
        own = {
            "software": software_info(lapig_version),
            "sequence": {
                "files": f"frame_000001.png .. {files[-1].name}",
                "first": files[0].name,
                "last": files[-1].name,
                "width": width,
                "height": height,
                "fps": float(rate),
                "fps_rational": f"{rate.numerator}/{rate.denominator}",
                "frame_count": len(files),
                "duration_s": float(len(files) / rate),
                "bit_depth": bit_depth,
                "channels": "RGB",
            },
            "show": show or {},
            "created": utc_now(),
        }
        try:
            (scratch.path / SIDECAR_NAME).write_bytes(sidecar_bytes(metadata, own))
            scratch.replace_folder(folder)
        except OSError as exc:
            raise write_error(exc, folder / SIDECAR_NAME) from exc
    except BaseException:
        scratch.remove()
        raise
    return {"folder": folder, "sidecar": folder / SIDECAR_NAME, "frames": len(files), "files": files}
