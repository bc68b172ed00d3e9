# SPDX-License-Identifier: GPL-3.0-or-later
"""A show's frames written as one video file for a media server, with a JSON sidecar (issue 38).

    write_video(frames, path, fps, size, codec, bit_depth=8, cancel_event=None, on_progress=None,
                metadata=None, *, show=None, frame_count=None, intra_only=False, lapig_version=None,
                ffmpeg=None) -> dict

- frames: an iterable of (H, W, 3) frames, float32 in [0, 1] or uint8 / uint16 (a generator is fine: one frame
  is held at a time). A hold is best given as the same array object again: it is converted once
  (show_output.RepeatedFrame; one buffer refilled with new frames is still seen to change).
- path: the video file; a name without a suffix gets the codec's (.mp4 for H.264 / H.265, .mov for the others).
- fps: 30, 25, 24, 60, 29.97 (stored as 30000/1001), "30000/1001" or a Fraction (show_output.frame_rate).
- size: (width, height); every frame must have it. codec: a name of codecs.CODECS ('h264' (High 4:2:0, the
  default), 'h265', 'h264-444', 'h265-444', 'prores422hq', 'prores4444', 'lossless', 'hap', 'hap-alpha', 'hap-q').
  bit_depth: 8, 10 or 16; a depth the codec lacks goes in at its deepest below, with a note (16-bit frames into
  H.264: 8 bits; into H.265 and ProRes: 10).
- Sizes 4:2:0 (and HAP) cannot take are padded (even; HAP a multiple of 4), the last column and row repeated, with
  a note. The level (H.264 / H.265) comes from the size and rate (export/levels); beyond the highest: refused.
- audio: a sound file (the show's range mixed down from its first frame) muxed beside the video: AAC in .mp4 and
  .mkv, 16-bit PCM in .mov, 48 kHz stereo, cut or padded to the video's duration (export/audio_mux); None: no
  audio track.
- ffmpeg: the system FFmpeg for codecs PyAV lacks (default $LAPIG_FFMPEG, then PATH): fed raw RGB through a pipe
  (export/ffmpeg_pipe), with the same progress, cancel and temporary file.
- frame_count: the frames promised (default len(frames) where it has one): the disk check needs it, and an
  export that gets another number of frames fails (frame-locked: the file has exactly the show's frames).
- cancel_event: a threading.Event, checked before every frame: set, the export stops with show_output.Cancelled.
- on_progress(fraction or None, message) about every 1 % of the frames. intra_only: every frame a keyframe.
- metadata: the caller's dict for the sidecar; show: the show's description (looks, times, transitions,
  motions), embedded as the sidecar's "show".
Returns {"video": Path, "sidecar": Path, "frames": n, "bytes": size of the video, "notes": [one line each],
"profile", "level", "pixel_format"}.

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
import math
import os
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from ..common import atomic
from . import codecs as codec_table
from . import chroma, ffmpeg_pipe, levels
from .codecs import VideoExportError
from .projector_image import ExportError, sidecar_bytes, software_info, utc_now, write_error
from .show_output import (Cancelled, RepeatedFrame, check_disk_space, check_size, check_writable, frame_pixels,
                          frame_rate, known_count)

__all__ = ["write_video", "video_path", "VideoExportError", "ExportError", "Cancelled"]

_FORMATS = {".mp4": "mp4", ".mov": "mov", ".mkv": "matroska"}
# FFmpeg's numbers: BT.709 matrix, primaries and transfer, limited range (codecs' module docstring says why)
_BT709, _RANGE_MPEG = 1, 1
_LUMA_CORRECTED = ("yuv420p", "yuv420p10le")


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


@dataclass(frozen=True)
class Plan:
    """How one video is encoded, decided before anything is written."""
    codec: codec_table.VideoCodec
    depth: int  # the encoded bit depth
    pix_fmt: str
    size: tuple  # the encoded (padded) width, height
    source_size: tuple  # the frames' width, height
    rate: Fraction
    gop: int  # frames between keyframes (1: every frame one)
    options: dict  # the encoder's private options
    level: object  # levels.Level, or None
    notes: tuple  # one line each: a depth conversion, a padding

    @property
    def source_depth(self) -> int:  # the depth of the RGB frames given to the encoder
        return 8 if self.depth == 8 else 16


def _chromaloc(spec: codec_table.VideoCodec) -> str:
    """4:2:0 chroma is the 2x2 mean, sited at the centre of the four pixels: the stream says so (type 1)."""
    return ":chromaloc=1" if spec.chroma == "4:2:0" else ""


def plan_video(spec: codec_table.VideoCodec, bit_depth, size, rate: Fraction, intra_only: bool) -> Plan:
    """The encoding of frames of `size` at `rate`: depth, padding, level, GOP and options (VideoExportError where
    the size is beyond the codec's levels)."""
    depth, depth_note = codec_table.encoded_depth(spec, bit_depth)
    width, height, pad_note = codec_table.padded_size(spec, *size)
    options = codec_table.encoder_options(spec, depth)
    # a keyframe at least every second: the whole frames in a second (29.97 fps: 29), or every frame one
    gop = 1 if intra_only or spec.intra else max(1, math.floor(rate))
    level = None
    if spec.level_table:
        pick = levels.h264_level if spec.level_table == "h264" else levels.h265_level
        try:
            level = pick(width, height, rate)
        except levels.LevelError as exc:
            raise VideoExportError(str(exc)) from None
    vbv = f"vbv-maxrate={level.max_bitrate_kbps}:vbv-bufsize={level.max_buffer_kbit}" if level else ""
    if spec.encoder == "libx264":
        key = f"keyint={gop}:min-keyint=1:scenecut=0" if gop == 1 else f"keyint={gop}"
        # closed GOP, constant frame rate, the level and its bitrate cap (so the level tag is true)
        options["x264-params"] = f"{key}:open-gop=0:force-cfr=1:level={level.name}:{vbv}" + _chromaloc(spec)
    elif spec.encoder == "libx265":
        key = f"keyint={gop}:min-keyint=1:scenecut=0" if gop == 1 else f"keyint={gop}:min-keyint={gop}"
        # no B-frames: with them, a short show in an .mp4 or .mov failed at the end with 'Not yet implemented in
        # FFmpeg' (av 18.0.0); a media server decodes and scrubs I/P frames more easily
        options["x265-params"] = (f"log-level=error:{key}:open-gop=0:bframes=0:level-idc={level.idc}:{vbv}:"
                                  f"colorprim=bt709:transfer=bt709:colormatrix=bt709:range=limited" + _chromaloc(spec))
    notes = tuple(n for n in (depth_note, pad_note) if n)
    return Plan(spec, depth, codec_table.pixel_format(spec, depth), (width, height), tuple(size), rate, gop,
                options, level, notes)


def _open_stream(container, plan: Plan):
    spec = plan.codec
    stream = container.add_stream(spec.encoder, rate=plan.rate)
    stream.width, stream.height = plan.size
    stream.pix_fmt = plan.pix_fmt
    ctx = stream.codec_context
    ctx.time_base = 1 / plan.rate
    ctx.gop_size = plan.gop
    if spec.encoder == "libx265":
        ctx.codec_tag = "hvc1"  # Apple's players need it
    if spec.yuv:
        ctx.colorspace, ctx.color_primaries, ctx.color_trc, ctx.color_range = _BT709, _BT709, _BT709, _RANGE_MPEG
    stream.options = dict(plan.options)
    ctx.thread_count = 0  # FFmpeg's choice: every core
    return stream


def _video_frame(av, pixels, plan: Plan):
    if plan.pix_fmt in _LUMA_CORRECTED:  # 4:2:0: the 2x2 mean chroma and corrected luma (export/chroma)
        frame = av.VideoFrame.from_ndarray(chroma.to_yuv420(pixels, plan.depth), format=plan.pix_fmt)
        frame.colorspace, frame.color_range = _BT709, _RANGE_MPEG
        return frame
    src = "rgb24" if pixels.dtype.itemsize == 1 else "rgb48le"
    frame = av.VideoFrame.from_ndarray(pixels, format=src)
    if plan.pix_fmt == src:
        return frame
    if plan.codec.yuv:  # the BT.709 matrix into limited range: what the tags say
        from av.video.reformatter import ColorRange, Colorspace, Interpolation

        return frame.reformat(format=plan.pix_fmt, src_colorspace=Colorspace.ITU709, dst_colorspace=Colorspace.ITU709,
                              src_color_range=ColorRange.JPEG, dst_color_range=ColorRange.MPEG,
                              dst_color_trc=_BT709, dst_color_primaries=_BT709,
                              interpolation=Interpolation.BILINEAR | Interpolation.ACCURATE_RND)
    return frame.reformat(format=plan.pix_fmt)


def _padded(pixels: np.ndarray, size) -> np.ndarray:
    """The frame padded to the encoded size, its last column and row repeated."""
    width, height = size
    h, w = pixels.shape[:2]
    if (w, h) == (width, height):
        return pixels
    return np.pad(pixels, ((0, height - h), (0, width - w), (0, 0)), mode="edge")


def _mux(container, packet) -> None:  # a seam: the tests' full disk raises here
    container.mux(packet)


class _PyAVEncoder:
    def __init__(self, av, tmp: Path, fmt: str, plan: Plan):
        self._av = av
        self._container = av.open(str(tmp), mode="w", format=fmt)
        try:
            self._stream = _open_stream(self._container, plan)
        except BaseException:
            self._container.close()
            raise
        self._plan, self._index = plan, 0

    def convert(self, pixels):
        return _video_frame(self._av, pixels, self._plan)

    def write(self, frame) -> None:
        frame.pts = self._index
        self._index += 1
        for packet in self._stream.encode(frame):
            _mux(self._container, packet)

    def finish(self) -> None:
        for packet in self._stream.encode():
            _mux(self._container, packet)
        self._container.close()

    def abort(self) -> None:
        with contextlib.suppress(Exception):
            self._container.close()


class _PipeEncoder:
    def __init__(self, ffmpeg: str, tmp: Path, fmt: str, plan: Plan, target: Path):
        args = ffmpeg_pipe.command(ffmpeg, str(tmp), fmt, plan.codec.encoder, plan.pix_fmt, plan.size, plan.rate,
                                   plan.gop, plan.options, plan.source_depth, plan.codec.yuv)
        self._pipe = ffmpeg_pipe.FFmpegPipe(args, plan.codec.label, target.name)

    @staticmethod
    def convert(pixels):
        return np.ascontiguousarray(pixels)

    def write(self, frame) -> None:
        self._pipe.write(frame)

    def finish(self) -> None:
        self._pipe.finish()

    def abort(self) -> None:
        self._pipe.abort()


def _encode(encoder, frames, plan: Plan, count, cancel_event, on_progress) -> int:
    """Every frame through `encoder`; returns how many were written."""
    written = 0
    step = max(1, (count or 100) // 100)
    repeated, last_frame = RepeatedFrame(), None
    for index, frame in enumerate(frames):
        if cancel_event is not None and cancel_event.is_set():
            raise Cancelled("video export cancelled")
        if count is not None and index >= count:
            raise ExportError(f"the show has {count} frames, but more frames came")
        if repeated.same(frame):  # a hold: the same frame again, converted once
            video_frame = last_frame
        else:
            pixels = _padded(frame_pixels(frame, plan.source_size, plan.source_depth, index), plan.size)
            last_frame = video_frame = encoder.convert(pixels)
            repeated.remember(frame)
        encoder.write(video_frame)
        written += 1
        if on_progress is not None and (written % step == 0 or written == count):
            on_progress(written / count if count else None,
                        f"encoded frame {written}" + (f"/{count}" if count else ""))
    if cancel_event is not None and cancel_event.is_set():
        raise Cancelled("video export cancelled")
    return written


def _with_audio(tmp: Path, target: Path, fmt: str, audio, duration_s: float) -> dict:
    """The show's sound muxed beside the encoded video (export/audio_mux), the temporary file replaced."""
    from .audio_mux import add_audio

    with_sound = atomic.temporary_beside(target, write_error)
    try:
        sound = add_audio(tmp, audio, with_sound, fmt, duration_s)
        os.replace(with_sound, tmp)
    except BaseException:
        with contextlib.suppress(OSError):
            with_sound.unlink()
        raise
    return {**sound, "source": Path(os.fspath(audio)).name}


def write_video(frames, path, fps, size, codec, bit_depth: int = 8, cancel_event=None, on_progress=None,
                metadata: dict | None = None, *, show: dict | None = None, frame_count: int | None = None,
                intra_only: bool = False, lapig_version: str | None = None, ffmpeg: str | None = None,
                audio=None) -> dict:
    """Encode `frames` into the video at `path` with its sidecar `<name>.json` (see the module docstring)."""
    spec = codec_table.check_codec(codec, ffmpeg)
    rate = frame_rate(fps)
    width, height = check_size(size)
    codec_table.check_frame_size(spec, width, height)
    plan = plan_video(spec, bit_depth, (width, height), rate, intra_only)
    count = known_count(frames, frame_count)
    if count == 0:
        raise ExportError("the show has no frames")
    target = video_path(path, spec)
    sidecar_path = target.with_suffix(".json")
    folder = target.parent
    check_writable(folder)
    if count is not None:
        check_disk_space(folder, count, codec_table.bytes_per_frame(spec, *plan.size, plan.depth),
                         f"{width}x{height} {spec.label}")
    if metadata is not None and not isinstance(metadata, dict):
        raise ExportError(f"metadata must be a dict, got {type(metadata).__name__}")
    if show is not None and not isinstance(show, dict):
        raise ExportError(f"show must be a dict, got {type(show).__name__}")

    import av

    how, ffmpeg_path = codec_table.route(spec.name, ffmpeg)
    fmt = _FORMATS[target.suffix.lower()]
    atomic.remove_partial_writes(target)  # what a killed export left
    tmp = atomic.temporary_beside(target, write_error)
    encoder = None
    try:
        try:
            encoder = (_PyAVEncoder(av, tmp, fmt, plan) if how == "pyav"
                       else _PipeEncoder(ffmpeg_path, tmp, fmt, plan, target))
            written = _encode(encoder, frames, plan, count, cancel_event, on_progress)
            encoder.finish()
            encoder = None
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
        try:
            sound = None if audio is None else _with_audio(tmp, target, fmt, audio, float(written / rate))
        except OSError as exc:
            raise write_error(exc, target) from exc
        except av.FFmpegError as exc:
            raise ExportError(f"could not add the show's sound to {target.name}: {exc}") from exc
        software = {**software_info(lapig_version), "av": codec_table.av_version()}
        if how == "ffmpeg":
            software["ffmpeg"] = ffmpeg_path
        own = {
            "software": software,
            "video": {
                "file": target.name,
                "codec": spec.name,
                "codec_label": spec.label,
                "encoder": spec.encoder,
                "encoded_by": "PyAV" if how == "pyav" else "system FFmpeg through a pipe",
                "profile": codec_table.profile_name(spec, plan.depth),
                "level": plan.level.name if plan.level else None,
                "pixel_format": plan.pix_fmt,
                "chroma": spec.chroma,
                "width": plan.size[0],
                "height": plan.size[1],
                "picture": [width, height],  # the show's frame, top left, where the video was padded
                "fps": float(rate),
                "fps_rational": f"{rate.numerator}/{rate.denominator}",
                "constant_frame_rate": True,
                "frame_count": written,
                "duration_s": float(written / rate),
                "bit_depth": plan.depth,
                "keyframe_interval_frames": plan.gop,
                "closed_gop": True,
                "every_frame_keyframe": plan.gop == 1,
                "colour": "BT.709 primaries, transfer and matrix, limited range (tagged)" if spec.yuv else "RGB",
                "notes": list(plan.notes),
                "audio": sound,
            },
            "show": show or {},
            "created": utc_now(),
        }
        atomic.commit([(sidecar_path, sidecar_bytes(metadata, own))], write_error, written=[(target, tmp)])
    except BaseException:
        if encoder is not None:
            encoder.abort()
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return {"video": target, "sidecar": sidecar_path, "frames": written, "bytes": target.stat().st_size,
            "notes": list(plan.notes), "profile": codec_table.profile_name(spec, plan.depth),
            "level": plan.level.name if plan.level else None, "pixel_format": plan.pix_fmt}
