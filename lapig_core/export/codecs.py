# SPDX-License-Identifier: GPL-3.0-or-later
"""The video codecs a show is exported in, by name, and which of them the installed FFmpeg (PyAV) has.

    CODECS                 name -> VideoCodec: 'h264', 'h265', 'prores4444', 'lossless', 'hap'
    availability()         {name: None where PyAV has its encoder, else the one line that says why not}
    check_codec(name)      the VideoCodec, or VideoExportError with one line naming the available ones
    av_problem()           None where `av` imports, else the one line that says what to install
    av_version()           the installed PyAV's version (for a sidecar)
    available_codecs()     the names availability() has no line for
    pixel_format(codec, bit_depth), check_frame_size(codec, w, h)
                           the encoder's pixel format for a bit depth, and the frame sizes it takes (one line each)
    bytes_per_frame(...)   a conservative estimate of one encoded frame, for the disk check before writing

Nothing here imports `av` at module import (the torch-free Blender tier imports the export package); it is
imported when availability is asked.

Choices, and why:
- H.264 and H.265 are 4:4:4 (yuv444p: no chroma subsampling, so a projector image's sharp colour edges and odd
  sizes survive), at CRF 10 tuned for PSNR: a compensated projector image's fine grain is signal (it cancels
  the surface's texture), which x264's default psychovisual tuning smooths away (on a textured test frame:
  35 dB at CRF 12 default, 42 dB at CRF 10 tune=psnr). x264's preset 'superfast': at 1080p on 2 cores 60 %
  faster than 'faster', and closer to the source (42.3 against 40.3 dB on a noisy frame), in larger files. `intra_only` makes every frame a keyframe (disguise and
  other media servers seek and loop faster). 10-bit (yuv444p10le) where bit_depth is 10.
- ProRes 4444 (prores_ks, profile 4444, yuv444p10le): what Watchout transcodes and editors take.
- 'lossless' is QuickTime Animation (qtrle, rgb24, in .mov). It stores the RGB bytes themselves (run-length
  coded), and FFmpeg's decoder gives rgb24 back, which OpenCV's reader turns into BGR by a plain channel swap:
  8-bit RGB round-trips exactly through cv2.VideoCapture (and PyAV), checked by the tests. disguise plays it.
  FFV1 (bgr0 in .mkv) is exact too and three times smaller, but no media server plays it; PNG in .mov is exact
  and smaller but slow to decode on playback.
- YUV codecs use the BT.601 matrix, limited range, and say so in the file (colorspace smpte170m, primaries
  bt709). FFmpeg-based readers that ignore the tag (OpenCV) assume BT.601 too, and readers that honour it
  (FFmpeg, VLC, mpv, QuickTime) decode it right: the same colours everywhere. A BT.709 matrix, the HD habit,
  came back 12 dB worse through OpenCV, which ignores the tag.
- HAP needs an FFmpeg built with snappy; PyPI's `av` wheel has none, so it is available only where the user's
  PyAV was built against such an FFmpeg.
"""
from __future__ import annotations

from dataclasses import dataclass, field

AV_PIN = "av==18.0.0"


class VideoExportError(ValueError):
    """A video export that cannot be done, with one line the user can act on."""


@dataclass(frozen=True)
class VideoCodec:
    name: str  # the choice the user makes
    label: str  # how people call it
    encoder: str  # FFmpeg's encoder
    containers: tuple[str, ...]  # file suffixes, the first the default
    pixel_formats: dict  # bit depth of the source frames -> the encoder's pixel format
    options: dict = field(default_factory=dict)  # encoder options
    # a conservative size of one frame per pixel, in bytes, at 8 bits (twice at 10 or 16): the disk check.
    # Measured at 640x480 (8-bit): a textured frame with 8 % per-pixel noise, the worst seen, took 1.67 B/px in
    # H.264 and 1.39 to 1.48 in H.265 (CRF 10, with or without every frame a keyframe; a smooth compensated
    # 1080p frame 0.07), 1.14 in ProRes 4444, 3.01 in QuickTime Animation (the raw RGB bytes)
    bytes_per_pixel: float = 1.0
    intra: bool = False  # every frame a keyframe anyway
    missing: str = ""  # why an FFmpeg may lack it
    min_width: int = 1  # libx265 corrupts its heap (the process aborts) on frames under about 48 pixels wide

    @property
    def yuv(self) -> bool:
        return any(fmt.startswith("yuv") for fmt in self.pixel_formats.values())


_X264 = {"crf": "10", "preset": "superfast", "tune": "psnr"}
CODECS = {
    "h264": VideoCodec("h264", "H.264", "libx264", (".mp4", ".mov", ".mkv"),
                       {8: "yuv444p", 10: "yuv444p10le"}, _X264, bytes_per_pixel=1.8),
    "h265": VideoCodec("h265", "H.265", "libx265", (".mp4", ".mov", ".mkv"),
                       {8: "yuv444p", 10: "yuv444p10le"},
                       {"crf": "10", "preset": "faster", "tune": "psnr", "x265-params": "log-level=error"},
                       bytes_per_pixel=1.6, min_width=64),
    "prores4444": VideoCodec("prores4444", "ProRes 4444", "prores_ks", (".mov",),
                             {8: "yuv444p10le", 10: "yuv444p10le"}, {"profile": "4444", "vendor": "apl0"},
                             bytes_per_pixel=1.5, intra=True),
    # worst case of run-length coding: every pixel a literal, plus a byte per run and the line headers
    "lossless": VideoCodec("lossless", "QuickTime Animation (lossless)", "qtrle", (".mov",), {8: "rgb24"},
                           bytes_per_pixel=3.1),
    "hap": VideoCodec("hap", "HAP", "hap", (".mov",), {8: "rgba"}, {"format": "hap"}, bytes_per_pixel=1.0,
                      intra=True, missing="HAP needs an FFmpeg built with snappy"),
}
NAMES = tuple(CODECS)


def av_problem() -> str | None:
    """None where PyAV imports, else one line: what to install (image sequences work without it)."""
    try:
        import av  # noqa: F401
    except Exception as exc:  # ImportError, or a wheel for another platform (OSError)
        why = "" if isinstance(exc, ModuleNotFoundError) else f" (importing it failed: {type(exc).__name__}: {exc})"
        return (f"video export needs PyAV: install it with 'pip install {AV_PIN}' into Blender's Python, or use "
                f"the add-on zip that bundles it{why}; PNG image sequences work without it")
    return None


def av_version() -> str:
    """The installed PyAV's version (call where av_problem() is None)."""
    import av

    return getattr(av, "__version__", "unknown")


def _has_encoder(codec: VideoCodec) -> bool:
    import av

    try:
        av.codec.Codec(codec.encoder, "w")
    except Exception:  # UnknownCodecError, or a codec without an encoder
        return False
    return True


def availability() -> dict:
    """{codec name: None where the installed PyAV encodes it, else the one line why not} (every name is
    there; where `av` itself is missing, every line is av_problem())."""
    problem = av_problem()
    if problem is not None:  # the line names the codec asked for: "hap: video export needs PyAV ..."
        return {name: f"{CODECS[name].label}: {problem}" for name in NAMES}
    have = {name: _has_encoder(codec) for name, codec in CODECS.items()}
    available = ", ".join(name for name in NAMES if have[name]) or "none"
    out = {}
    for name, codec in CODECS.items():
        if have[name]:
            out[name] = None
        else:
            why = codec.missing or f"{codec.label} needs FFmpeg's {codec.encoder} encoder"
            out[name] = (f"{why}; the installed PyAV (av {av_version()}) has none. Available here: {available}")
    return out


def available_codecs() -> list[str]:
    return [name for name, problem in availability().items() if problem is None]


def check_codec(name) -> VideoCodec:
    """The codec of that name where the installed PyAV encodes it; VideoExportError with one line otherwise."""
    if name not in CODECS:
        raise VideoExportError(f"unknown video codec {name!r}; the choices are {', '.join(NAMES)}")
    problem = availability()[name]
    if problem is not None:
        raise VideoExportError(problem)
    return CODECS[name]


def pixel_format(codec: VideoCodec, bit_depth) -> str:
    """The encoder's pixel format for frames of `bit_depth`; VideoExportError naming the depths it takes."""
    if isinstance(bit_depth, bool) or bit_depth not in codec.pixel_formats:
        depths = " or ".join(str(d) for d in codec.pixel_formats)
        raise VideoExportError(f"{codec.label} takes a bit depth of {depths}, got {bit_depth!r}")
    return codec.pixel_formats[bit_depth]


def check_frame_size(codec: VideoCodec, width: int, height: int) -> None:
    if width < codec.min_width:
        raise VideoExportError(f"{codec.label} needs frames at least {codec.min_width} pixels wide, got {width}: "
                               f"choose h264")


def bytes_per_frame(codec: VideoCodec, width: int, height: int, bit_depth: int = 8) -> int:
    """A conservative size of one encoded frame (a show of busy, noisy frames at high quality stays under it)."""
    depth_factor = 1.0 if bit_depth == 8 else 2.0
    if codec.name == "lossless":
        depth_factor = 1.0
    return int(width * height * codec.bytes_per_pixel * depth_factor) + 4096
