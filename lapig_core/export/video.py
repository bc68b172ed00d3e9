# SPDX-License-Identifier: GPL-3.0-or-later
"""A show's frames written as one video file for a media server, with a JSON sidecar (issue 38).

    write_video(frames, path, fps, size, codec, bit_depth=8, cancel_event=None, on_progress=None,
                metadata=None, *, show=None, frame_count=None, intra_only=False, lapig_version=None) -> dict

- frames: an iterable of (H, W, 3) frames, float32 in [0, 1] or uint8 / uint16 (a generator is fine: one frame
  is held at a time). A hold is best given as the same array object again: it is converted once
  (show_output.RepeatedFrame; one buffer refilled with new frames is still seen to change).
- path: the video file; a name without a suffix gets the codec's (.mp4 for H.264 / H.265, .mov for the others).
- fps: 30, 25, 24, 60, 29.97 (stored as 30000/1001), "30000/1001" or a Fraction (show_output.frame_rate).
- size: (width, height); every frame must have it. codec: a name of codecs.CODECS ('h264', 'h265',
  'prores4444', 'lossless', 'hap'). bit_depth: 8, or 10 for H.264 / H.265 / ProRes.
- frame_count: the frames promised (default len(frames) where it has one): the disk check needs it, and an
  export that gets another number of frames fails (frame-locked: the file has exactly the show's frames).
- cancel_event: a threading.Event, checked before every frame: set, the export stops with show_output.Cancelled.
- on_progress(fraction or None, message) about every 1 % of the frames. intra_only: every frame a keyframe.
- metadata: the caller's dict for the sidecar; show: the show's description (looks, times, transitions,
  motions), embedded as the sidecar's "show".
Returns {"video": Path, "sidecar": Path, "frames": n, "bytes": size of the video}.

Before anything is written: the codec (one line naming the available ones where PyAV lacks it), the frame rate,
the size, the folder (exists, writable) and the disk (the frame count times codecs.bytes_per_frame against
shutil.disk_usage; both figures in the line). Then the video goes into a hidden temporary file beside the final
one (common/atomic.temporary_beside) and is renamed into place with its sidecar (common/atomic.commit) only
once every frame is encoded: a cancel or any error removes the temporary file, and a previous video and
sidecar under the final names stay as they were. Errors are ExportError (VideoExportError for the codec),
one line each.

`av` is imported inside write_video only: the torch-free Blender tier imports this module without PyAV.
"""
from __future__ import annotations

import contextlib
import os
from fractions import Fraction
from pathlib import Path

from ..common import atomic
from . import codecs as codec_table
from .codecs import VideoExportError
from .projector_image import ExportError, sidecar_bytes, software_info, utc_now, write_error
from .show_output import (Cancelled, RepeatedFrame, check_disk_space, check_size, check_writable, frame_pixels,
                          frame_rate, known_count)

__all__ = ["write_video", "video_path", "VideoExportError", "ExportError", "Cancelled"]

_FORMATS = {".mp4": "mp4", ".mov": "mov", ".mkv": "matroska"}
# BT.601 matrix, limited range, BT.709 primaries (codecs' module docstring says why); FFmpeg's numbers
_COLORSPACE_SMPTE170M, _RANGE_MPEG, _PRIMARIES_BT709 = 6, 1, 1


def video_path(path, codec: codec_table.VideoCodec) -> Path:
    """The file to write: the codec's suffix added to a name without one; a suffix it cannot go in is refused."""
    try:
        path = Path(os.fspath(path))
    except TypeError:
        raise ExportError(f"output path must be a path or string, got {type(path).__name__}") from None
    if not path.name or path.is_dir():
        raise ExportError(f"output path is a folder, not a video file name: {path}")
    if not path.suffix:
        return path.with_name(path.name + codec.containers[0])
    if path.suffix.lower() not in codec.containers:
        raise ExportError(f"{codec.label} goes into {' or '.join(codec.containers)} files, not {path.suffix}")
    return path


def _open_stream(container, codec: codec_table.VideoCodec, pix_fmt: str, size, rate: Fraction, intra_only: bool):
    stream = container.add_stream(codec.encoder, rate=rate)
    stream.width, stream.height = size
    stream.pix_fmt = pix_fmt
    options = dict(codec.options)
    ctx = stream.codec_context
    ctx.time_base = 1 / rate
    # a keyframe a second (seeking and looping stay quick), or every frame one
    keyint = 1 if intra_only or codec.intra else max(1, round(float(rate)))
    if codec.encoder == "libx265":
        # no B-frames: with them, a short show (2 frames at 1080p) in an .mp4 or .mov failed at the end with
        # 'Not yet implemented in FFmpeg' (av 18.0.0); a media server decodes and scrubs I/P frames more easily
        options["x265-params"] = options.get("x265-params", "") + f":keyint={keyint}:open-gop=0:bframes=0" + \
            (":min-keyint=1:scenecut=0" if keyint == 1 else "")
    else:
        ctx.gop_size = keyint
        if keyint == 1 and codec.encoder == "libx264":
            options["x264-params"] = "keyint=1:min-keyint=1:scenecut=0"
    if codec.encoder == "libx265":
        ctx.codec_tag = "hvc1"  # Apple's players need it
    if codec.yuv:
        ctx.colorspace, ctx.color_range, ctx.color_primaries = _COLORSPACE_SMPTE170M, _RANGE_MPEG, _PRIMARIES_BT709
    stream.options = options
    ctx.thread_count = 0  # FFmpeg's choice: every core
    return stream


def _video_frame(av, pixels, pix_fmt: str, codec: codec_table.VideoCodec):
    src = "rgb24" if pixels.dtype.itemsize == 1 else "rgb48le"
    frame = av.VideoFrame.from_ndarray(pixels, format=src)
    if pix_fmt == src:
        return frame
    if codec.yuv:
        return frame.reformat(format=pix_fmt, dst_colorspace="itu601")
    return frame.reformat(format=pix_fmt)


def _encode(av, tmp: Path, fmt: str, frames, codec, pix_fmt, size, rate, bit_depth, intra_only, count,
            cancel_event, on_progress) -> int:
    """Every frame into the file at tmp; returns how many were written."""
    written = 0
    step = max(1, (count or 100) // 100)
    with av.open(str(tmp), mode="w", format=fmt) as container:
        stream = _open_stream(container, codec, pix_fmt, size, rate, intra_only)
        repeated, last_frame = RepeatedFrame(), None
        for index, frame in enumerate(frames):
            if cancel_event is not None and cancel_event.is_set():
                raise Cancelled("video export cancelled")
            if count is not None and index >= count:
                raise ExportError(f"the show has {count} frames, but more frames came")
            if repeated.same(frame):  # a hold: the same frame again, converted once
                video_frame = last_frame
            else:
                pixels = frame_pixels(frame, size, 8 if bit_depth == 8 else 16, index)
                last_frame = video_frame = _video_frame(av, pixels, pix_fmt, codec)
                repeated.remember(frame)
            video_frame.pts = index
            for packet in stream.encode(video_frame):
                container.mux(packet)
            written += 1
            if on_progress is not None and (written % step == 0 or written == count):
                on_progress(written / count if count else None,
                            f"encoded frame {written}" + (f"/{count}" if count else ""))
        if cancel_event is not None and cancel_event.is_set():
            raise Cancelled("video export cancelled")
        for packet in stream.encode():
            container.mux(packet)
    return written


def write_video(frames, path, fps, size, codec, bit_depth: int = 8, cancel_event=None, on_progress=None,
                metadata: dict | None = None, *, show: dict | None = None, frame_count: int | None = None,
                intra_only: bool = False, lapig_version: str | None = None) -> dict:
    """Encode `frames` into the video at `path` with its sidecar `<name>.json` (see the module docstring)."""
    spec = codec_table.check_codec(codec)
    pix_fmt = codec_table.pixel_format(spec, bit_depth)
    rate = frame_rate(fps)
    width, height = check_size(size)
    codec_table.check_frame_size(spec, width, height)
    count = known_count(frames, frame_count)
    if count == 0:
        raise ExportError("the show has no frames")
    target = video_path(path, spec)
    sidecar_path = target.with_suffix(".json")
    folder = target.parent
    check_writable(folder)
    if count is not None:
        check_disk_space(folder, count, codec_table.bytes_per_frame(spec, width, height, bit_depth),
                         f"{width}x{height} {spec.label}")
    if metadata is not None and not isinstance(metadata, dict):
        raise ExportError(f"metadata must be a dict, got {type(metadata).__name__}")
    if show is not None and not isinstance(show, dict):
        raise ExportError(f"show must be a dict, got {type(show).__name__}")

    import av

    atomic.remove_partial_writes(target)  # what a killed export left
    tmp = atomic.temporary_beside(target, write_error)
    try:
        try:
            written = _encode(av, tmp, _FORMATS[target.suffix.lower()], frames, spec, pix_fmt, (width, height),
                              rate, bit_depth, intra_only, count, cancel_event, on_progress)
        except (Cancelled, ExportError):
            raise
        except OSError as exc:
            raise write_error(exc, target) from exc
        except av.FFmpegError as exc:
            raise ExportError(f"{spec.label} could not encode {target.name}: {exc}") from exc
        if count is not None and written != count:
            raise ExportError(f"the show has {count} frames, but {written} came")
        if written == 0:
            raise ExportError("the show has no frames")
        own = {
            "software": {**software_info(lapig_version), "av": codec_table.av_version()},
            "video": {
                "file": target.name,
                "codec": spec.name,
                "codec_label": spec.label,
                "encoder": spec.encoder,
                "pixel_format": pix_fmt,
                "width": width,
                "height": height,
                "fps": float(rate),
                "fps_rational": f"{rate.numerator}/{rate.denominator}",
                "frame_count": written,
                "duration_s": float(written / rate),
                "bit_depth": bit_depth,
                "every_frame_keyframe": bool(intra_only or spec.intra),
                "colour": "BT.601 matrix, limited range, BT.709 primaries" if spec.yuv else "RGB",
            },
            "show": show or {},
            "created": utc_now(),
        }
        atomic.commit([(sidecar_path, sidecar_bytes(metadata, own))], write_error, written=[(target, tmp)])
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return {"video": target, "sidecar": sidecar_path, "frames": written, "bytes": target.stat().st_size}
