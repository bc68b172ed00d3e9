# SPDX-License-Identifier: GPL-3.0-or-later
"""A video encoded by a system FFmpeg fed raw RGB frames through a pipe: the route for a codec the installed
PyAV lacks (HAP, with PyPI's `av` wheel), with the same progress, cancel and temporary file as PyAV's route.

    FFmpegPipe(path, out_file, container_format, codec, pix_fmt, size, rate, gop, options, source_depth)
        .write(pixels)  one (H, W, 3) uint8 / uint16 frame (already padded to `size`)
        .finish()       closes the pipe and waits; ExportError with FFmpeg's last line where it failed
        .abort()        kills it (a cancel or an error); the caller removes the file

FFmpeg's messages go into a temporary file, not a pipe: a full stderr pipe would block the encoder while this
process blocks on its stdin.
"""
from __future__ import annotations

import contextlib
import errno
import subprocess
import tempfile
from fractions import Fraction

from .projector_image import ExportError

_COLOUR_ARGS = ["-colorspace", "bt709", "-color_primaries", "bt709", "-color_trc", "bt709", "-color_range", "tv"]


def command(path: str, out_file: str, container_format: str, encoder: str, pix_fmt: str, size, rate: Fraction,
            gop: int, options: dict, source_depth: int, yuv: bool) -> list[str]:
    """The ffmpeg command line: raw RGB on stdin, the codec's pixel format out (BT.709, limited range for YUV)."""
    width, height = size
    src = "rgb24" if source_depth == 8 else "rgb48le"
    args = [path, "-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", src,
            "-s", f"{width}x{height}", "-framerate", f"{rate.numerator}/{rate.denominator}", "-i", "pipe:0",
            "-an", "-map_metadata", "-1"]
    if yuv:  # swscale's conversion with the BT.709 matrix into limited range, so the tags are true; 4:2:0
        # chroma sited at the centre of its four pixels, as the stream says (video.plan_video's chromaloc=1)
        siting = ":out_h_chr_pos=128:out_v_chr_pos=128" if pix_fmt.startswith("yuv420") else ""
        args += ["-vf", f"scale=out_color_matrix=bt709:out_range=tv:flags=bilinear+accurate_rnd+full_chroma_int"
                        f"{siting},format={pix_fmt}"]
    else:
        args += ["-pix_fmt", pix_fmt]
    args += ["-c:v", encoder, "-g", str(gop)]
    for key, value in options.items():
        args += [f"-{key}", str(value)]
    if yuv:
        args += _COLOUR_ARGS
    args += ["-vsync", "cfr", "-r", f"{rate.numerator}/{rate.denominator}", "-f", container_format, out_file]
    return args


class FFmpegPipe:
    def __init__(self, args: list[str], label: str, target_name: str):
        self._label, self._target = label, target_name
        self._log = tempfile.TemporaryFile()
        try:
            self._proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._log)
        except OSError as exc:
            self._log.close()
            raise ExportError(f"could not start FFmpeg ({args[0]}) for {label}: {exc.strerror or exc}") from None

    def _last_line(self) -> str:
        self._log.seek(0)
        lines = [ln.strip() for ln in self._log.read().decode("utf-8", "replace").splitlines() if ln.strip()]
        return lines[-1] if lines else f"it exited with status {self._proc.returncode}"

    def _failed(self) -> ExportError:
        line = self._last_line()
        if "No space left" in line:
            return ExportError(f"could not write {self._target}: the disk may be full (FFmpeg: {line})")
        return ExportError(f"FFmpeg could not encode {self._target} as {self._label}: {line}")

    def write(self, pixels) -> None:
        try:
            self._proc.stdin.write(memoryview(pixels).cast("B") if pixels.flags.c_contiguous else pixels.tobytes())
        except BrokenPipeError:  # FFmpeg stopped: its own line says why
            self._proc.wait()
            raise self._failed() from None
        except OSError as exc:
            if exc.errno == errno.EPIPE:
                self._proc.wait()
                raise self._failed() from None
            raise

    def finish(self) -> None:
        with contextlib.suppress(BrokenPipeError):
            self._proc.stdin.close()
        status = self._proc.wait()
        try:
            if status != 0:
                raise self._failed()
        finally:
            self._log.close()

    def abort(self) -> None:
        with contextlib.suppress(OSError):
            self._proc.kill()
        with contextlib.suppress(OSError, ValueError):
            self._proc.stdin.close()
        self._proc.wait()
        with contextlib.suppress(OSError):
            self._log.close()
