# SPDX-License-Identifier: GPL-3.0-or-later
"""The video codecs a show is exported in, by name, what each is for, and which encoder writes it here.

    CODECS                 name -> VideoCodec (NAMES in the order the CLI and the panel list them)
    availability(ffmpeg=None)
                           {name: None where PyAV or a system FFmpeg has its encoder, else the one line why not}
    route(name, ffmpeg=None)
                           ("pyav", None) or ("ffmpeg", path): who writes it (PyAV first; the system FFmpeg through
                           a pipe for what PyAV lacks: HAP, with PyPI's `av` wheel)
    check_codec(name, ffmpeg=None)
                           the VideoCodec, or VideoExportError with one line
    av_problem(), av_version()
    encoded_depth(codec, bit_depth) -> (depth, note or "")
                           16-bit frames go in at the codec's deepest depth, with a note; never refused
    pixel_format(codec, depth), padded_size(codec, w, h) -> (w, h, note or ""), check_frame_size(codec, w, h)
    bytes_per_frame(...)   a conservative estimate of one encoded frame, for the disk check before writing

Nothing here imports `av` at module import (the torch-free Blender tier imports the export package).

Choices, and why (issue 52, checked with an independent FFmpeg and ffprobe):
- The defaults are what playback machines decode in hardware (media servers, BrightSign, NVDEC, Quick Sync):
  H.264 High profile 4:2:0 8-bit, and H.265 Main (8-bit) or Main 10, both 4:2:0, at the level the size and frame
  rate need (export/levels: 4.1 for 1080p30, 5.1 for 4K30) with that level's bitrate cap, a constant frame rate,
  a closed GOP with a keyframe at least every second (a media server's timeline scrubs to it).
- 'h264-444' and 'h265-444' keep every pixel's colour (thin coloured lines, text on colour): H.264 "High 4:4:4
  Predictive" and H.265 Rext 4:4:4 are decoded in software on nearly every playback machine.
- Quality: CRF 10 tuned for PSNR: a compensated projector image's fine grain is signal (it cancels the surface's
  texture), which x264's default psychovisual tuning smooths away. x264's preset 'superfast' (at 1080p on 2 cores
  60 % faster than 'faster', and closer to the source).
- Colour: BT.709 matrix, limited range (16-235), and the file says so: primaries, transfer and matrix BT.709,
  range limited, in the stream and the container. Readers that honour the tags (FFmpeg, VLC, mpv, QuickTime,
  media servers) decode it right. OpenCV's reader ignores the tags (it assumes BT.601): not a reader to judge
  these files by (tools/checks/video_read decodes with FFmpeg, honouring them).
- ProRes 422 HQ (yuv422p10le) and 4444 (yuv444p10le): what Watchout transcodes and editors take; 422 HQ is a
  third smaller. 8- and 16-bit frames go in at ProRes's 10 bits.
- 'lossless' is QuickTime Animation (qtrle, rgb24, .mov): the RGB bytes themselves, exact through any decoder;
  disguise plays it.
- HAP, HAP Alpha, HAP Q (.mov): GPU-decoded texture codecs that Resolume, Watchout, disguise, TouchDesigner and
  Millumin play best, every frame a keyframe, large files. FFmpeg's encoder needs snappy, which PyPI's `av`
  wheel lacks: then a system FFmpeg (Debian's has it) encodes them, fed raw RGB through a pipe.
"""
from __future__ import annotations

import functools
import os
import shutil
import subprocess
from dataclasses import dataclass, field

AV_PIN = "av==18.0.0"
FFMPEG_ENV = "LAPIG_FFMPEG"  # an explicit ffmpeg (the add-on's preference sets it)


class VideoExportError(ValueError):
    """A video export that cannot be done, with one line the user can act on."""


@dataclass(frozen=True)
class VideoCodec:
    name: str  # the choice the user makes
    label: str  # how people call it
    encoder: str  # FFmpeg's encoder
    containers: tuple[str, ...]  # file suffixes, the first the default
    pixel_formats: dict  # encoded bit depth -> the encoder's pixel format
    options: dict = field(default_factory=dict)  # the encoder's private options (the same through PyAV or the CLI)
    help: str = ""  # the trade-off: size, quality, which players take it (CLI help, panel, docs)
    profile: str = ""  # the profile a decoder sees (ffprobe's words), per 8-bit; profiles_10 for 10-bit
    profile_10: str = ""
    chroma: str = "4:2:0"  # "4:2:0", "4:2:2", "4:4:4" or "RGB"
    level_table: str = ""  # "h264" or "h265": the level comes from export/levels
    # a conservative size of one frame per pixel, in bytes, at 8 bits (twice at 10): the disk check. Measured at
    # 640x480 (8-bit, CRF 10): a textured frame with 8 % noise took 1.67 B/px in H.264 4:4:4, 1.39 to 1.48 in
    # H.265, 1.14 in ProRes 4444, 3.01 in QuickTime Animation; 4:2:0 is half the samples of 4:4:4
    bytes_per_pixel: float = 1.0
    intra: bool = False  # every frame a keyframe anyway
    missing: str = ""  # why an FFmpeg may lack it, and how to get one that has it
    # libx265 corrupts its heap on small frames: valgrind shows its lookahead (cuTree) writing out of bounds at 48
    # wide; with the export's own stream at 64x48 it hung in 2 of 3 runs of 1,500 encodes (a CI run that never
    # ended) and crashed in the video tests' loop; at 64x64 it still crashed once in 3 runs
    # (tools/research/x265_small_frames.py). Both sides at least this: a floor that refuses the hang, not yet one
    # shown safe
    min_side: int = 1
    block: int = 1  # width and height must be multiples of this (4:2:0: 2; HAP's DXT blocks: 4): padded

    @property
    def yuv(self) -> bool:
        return self.chroma != "RGB"


_X264 = {"crf": "10", "preset": "superfast", "tune": "psnr"}
_X265 = {"crf": "10", "preset": "faster", "tune": "psnr"}
_HAP_MISSING = ("HAP needs an FFmpeg built with snappy: install one (Debian/Ubuntu: apt-get install ffmpeg; macOS: "
                "brew install ffmpeg; Windows: a build from ffmpeg.org) and put it on PATH or set its path in "
                f"the add-on's preferences (or {FFMPEG_ENV})")
_CODEC_LIST = (
    VideoCodec("h264", "H.264", "libx264", (".mp4", ".mov", ".mkv"), {8: "yuv420p"},
               {**_X264, "profile": "high"}, profile="High", chroma="4:2:0", level_table="h264", block=2,
               bytes_per_pixel=0.9,
               help="H.264 High 4:2:0 8-bit (default): plays on every media server, signage player and PC, in "
                    "hardware; small files; colour at half resolution (thin coloured lines soften)"),
    VideoCodec("h265", "H.265", "libx265", (".mp4", ".mov", ".mkv"), {8: "yuv420p", 10: "yuv420p10le"},
               {**_X265, "profile": "main"}, profile="Main", profile_10="Main 10", chroma="4:2:0",
               level_table="h265", block=2, bytes_per_pixel=0.8, min_side=64,
               help="H.265 Main / Main 10 4:2:0: about half H.264's size at the same quality, 10-bit from 16-bit "
                    "frames; hardware decoding on recent players (NVDEC, Quick Sync, BrightSign 4K); slower to "
                    "encode"),
    VideoCodec("h264-444", "H.264 4:4:4", "libx264", (".mp4", ".mov", ".mkv"), {8: "yuv444p", 10: "yuv444p10le"},
               {**_X264, "profile": "high444"}, profile="High 4:4:4 Predictive", profile_10="High 4:4:4 Predictive",
               chroma="4:4:4", level_table="h264", bytes_per_pixel=1.8,
               help="H.264 High 4:4:4: full colour resolution (sharp coloured edges), twice the size; needs a "
                    "software decoder (most playback machines cannot play it in hardware)"),
    VideoCodec("h265-444", "H.265 4:4:4", "libx265", (".mp4", ".mov", ".mkv"), {8: "yuv444p", 10: "yuv444p10le"},
               {**_X265, "profile": "main444-8"}, profile="Rext", profile_10="Rext", chroma="4:4:4",
               level_table="h265", bytes_per_pixel=1.6, min_side=64,
               help="H.265 Rext 4:4:4: full colour resolution, 8 or 10 bit; needs a software decoder on most "
                    "playback machines (NVDEC takes it on recent GPUs)"),
    VideoCodec("prores422hq", "ProRes 422 HQ", "prores_ks", (".mov",), {10: "yuv422p10le"},
               {"profile": "hq", "vendor": "apl0"}, profile="HQ", profile_10="HQ", chroma="4:2:2",
               bytes_per_pixel=1.0, intra=True, block=2,
               help="ProRes 422 HQ 10-bit: an editing and playback master (Watchout, Resolume, editors), every "
                    "frame a keyframe; about 10 times H.264's size, a third smaller than 4444"),
    VideoCodec("prores4444", "ProRes 4444", "prores_ks", (".mov",), {10: "yuv444p10le"},
               {"profile": "4444", "vendor": "apl0"}, profile="4444", profile_10="4444", chroma="4:4:4",
               bytes_per_pixel=1.5, intra=True,
               help="ProRes 4444 10-bit: full colour resolution, every frame a keyframe; large files; Watchout "
                    "transcodes it, editors take it"),
    # worst case of run-length coding: every pixel a literal, plus a byte per run and the line headers
    VideoCodec("lossless", "QuickTime Animation (lossless)", "qtrle", (".mov",), {8: "rgb24"}, chroma="RGB",
               bytes_per_pixel=3.1,
               help="QuickTime Animation: exact 8-bit RGB, the largest files (about the raw pixels); disguise and "
                    "editors play it, slow to decode at 4K"),
    VideoCodec("hap", "HAP", "hap", (".mov",), {8: "rgba"}, {"format": "hap"}, chroma="RGB", bytes_per_pixel=0.6,
               intra=True, missing=_HAP_MISSING, block=4,
               help="HAP: decoded on the GPU by Resolume, Watchout, disguise, TouchDesigner, Millumin; plays many "
                    "layers at once; large files (DXT1, about 6:1), visible banding in gradients"),
    VideoCodec("hap-alpha", "HAP Alpha", "hap", (".mov",), {8: "rgba"}, {"format": "hap_alpha"}, chroma="RGB",
               bytes_per_pixel=1.1, intra=True, missing=_HAP_MISSING, block=4,
               help="HAP Alpha: HAP with an alpha channel (opaque here), for media servers that want it; twice "
                    "HAP's size"),
    VideoCodec("hap-q", "HAP Q", "hap", (".mov",), {8: "rgba"}, {"format": "hap_q"}, chroma="RGB",
               bytes_per_pixel=1.1, intra=True, missing=_HAP_MISSING, block=4,
               help="HAP Q: HAP's better quality (YCoCg DXT5), less banding; twice HAP's size, the same players"),
)
CODECS = {codec.name: codec for codec in _CODEC_LIST}
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


def _av_has_encoder(codec: VideoCodec) -> bool:
    import av

    try:
        av.codec.Codec(codec.encoder, "w")
    except Exception:  # UnknownCodecError, or a codec without an encoder
        return False
    return True


def find_ffmpeg(explicit: str | None = None) -> str | None:
    """The system FFmpeg to pipe into: `explicit`, else $LAPIG_FFMPEG, else `ffmpeg` on PATH; None where none."""
    for candidate in (explicit, os.environ.get(FFMPEG_ENV)):
        if candidate:
            found = shutil.which(candidate) or (candidate if os.path.isfile(candidate) else None)
            return found
    return shutil.which("ffmpeg")


@functools.lru_cache(maxsize=8)
def _ffmpeg_encoders(path: str, mtime: float) -> frozenset:
    """The encoders `ffmpeg -encoders` lists (mtime: a replaced binary is asked again)."""
    try:
        out = subprocess.run([path, "-hide_banner", "-encoders"], stdin=subprocess.DEVNULL, capture_output=True,
                             text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return frozenset()
    names = set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and len(parts[0]) == 6 and parts[0][0] in "VAS":
            names.add(parts[1])
    return frozenset(names)


def ffmpeg_has(path: str | None, encoder: str) -> bool:
    if not path:
        return False
    try:
        mtime = os.path.getmtime(path)
    except OSError:
        return False
    return encoder in _ffmpeg_encoders(path, mtime)


def route(name: str, ffmpeg: str | None = None) -> tuple[str, str | None] | None:
    """("pyav", None) where PyAV encodes `name`, else ("ffmpeg", path) where the system FFmpeg does, else None."""
    codec = CODECS[name]
    if av_problem() is None and _av_has_encoder(codec):
        return "pyav", None
    path = find_ffmpeg(ffmpeg)
    if ffmpeg_has(path, codec.encoder):
        return "ffmpeg", path
    return None


def availability(ffmpeg: str | None = None) -> dict:
    """{codec name: None where PyAV or the system FFmpeg encodes it, else the one line why not} (every name)."""
    problem = av_problem()
    if problem is not None:  # the line names the codec asked for: "hap: video export needs PyAV ..."
        return {name: f"{CODECS[name].label}: {problem}" for name in NAMES}
    routes = {name: route(name, ffmpeg) for name in NAMES}
    available = ", ".join(name for name in NAMES if routes[name]) or "none"
    path = find_ffmpeg(ffmpeg)
    asked = ffmpeg or os.environ.get(FFMPEG_ENV)
    system = (f"the system FFmpeg ({path}) has none either" if path else
              f"and the FFmpeg set ({asked}) is not there" if asked else "and no system FFmpeg was found on PATH")
    out = {}
    for name, codec in CODECS.items():
        if routes[name]:
            out[name] = None
        else:
            why = codec.missing or f"{codec.label} needs FFmpeg's {codec.encoder} encoder"
            out[name] = f"{why}. PyAV (av {av_version()}) has no {codec.encoder} encoder, {system}. " \
                        f"Available here: {available}"
    return out


def check_codec(name, ffmpeg: str | None = None) -> VideoCodec:
    """The codec of that name where PyAV or the system FFmpeg encodes it; VideoExportError with one line otherwise."""
    if name not in CODECS:
        raise VideoExportError(f"unknown video codec {name!r}; the choices are {', '.join(NAMES)}")
    problem = availability(ffmpeg)[name]
    if problem is not None:
        raise VideoExportError(problem)
    return CODECS[name]


def encoded_depth(codec: VideoCodec, bit_depth) -> tuple[int, str]:
    """The depth the frames are encoded at, and a note where it is not `bit_depth`: 16-bit frames (and 10 where
    the codec has no 10) go in at the codec's deepest depth below; 8 into a 10-bit-only codec is widened.
    A depth other than 8, 10 or 16 is refused."""
    if isinstance(bit_depth, bool) or bit_depth not in (8, 10, 16):
        depths = " or ".join(str(d) for d in sorted({8, 16, *codec.pixel_formats}))
        raise VideoExportError(f"{codec.label} takes frames of {depths} bits, got {bit_depth!r}")
    depths = sorted(codec.pixel_formats)
    if bit_depth in depths:
        return bit_depth, ""
    below = [d for d in depths if d <= bit_depth]
    if not below:  # 8-bit frames into ProRes's 10 bits: exact, nothing to say
        return depths[0], ""
    depth = below[-1]
    return depth, f"{bit_depth}-bit frames written at {codec.label}'s {depth} bits"


def pixel_format(codec: VideoCodec, depth) -> str:
    """The encoder's pixel format at an encoded depth (see encoded_depth)."""
    if depth not in codec.pixel_formats:
        return codec.pixel_formats[encoded_depth(codec, depth)[0]]
    return codec.pixel_formats[depth]


def profile_name(codec: VideoCodec, depth: int) -> str:
    """The profile ffprobe names for a file of this codec at this depth."""
    return codec.profile_10 if depth > 8 and codec.profile_10 else codec.profile


def encoder_options(codec: VideoCodec, depth: int) -> dict:
    """The encoder's private options at a depth (H.265's profile follows the depth)."""
    options = dict(codec.options)
    if codec.encoder == "libx265" and depth == 10:
        options["profile"] = {"main": "main10", "main444-8": "main444-10"}[options["profile"]]
    if codec.encoder == "libx264" and depth == 10:
        options["profile"] = "high444"  # High 4:4:4 Predictive carries 10 bits
    return options


def padded_size(codec: VideoCodec, width: int, height: int) -> tuple[int, int, str]:
    """The encoded size: width and height up to the codec's block (4:2:0 even, HAP a multiple of 4), the last
    column and row repeated; the note says so ('' where nothing was padded)."""
    b = codec.block
    bh = 1 if codec.chroma == "4:2:2" else b  # 4:2:2 halves the columns only
    pw, ph = -(-width // b) * b, -(-height // bh) * bh
    if (pw, ph) == (width, height):
        return width, height, ""
    why = "HAP's 4x4 texture blocks" if codec.encoder == "hap" else \
        f"{codec.chroma} needs an even width" if bh == 1 else f"{codec.chroma} needs even sizes"
    return pw, ph, (f"{width}x{height} padded to {pw}x{ph} ({why}; the last column and row repeated): crop "
                    f"{pw - width} column(s) right and {ph - height} row(s) at the bottom on the media server")


def check_frame_size(codec: VideoCodec, width: int, height: int) -> None:
    if min(width, height) < codec.min_side:
        raise VideoExportError(f"{codec.label} needs frames at least {codec.min_side}x{codec.min_side} pixels, got "
                               f"{width}x{height}: choose h264")


def bytes_per_frame(codec: VideoCodec, width: int, height: int, bit_depth: int = 8) -> int:
    """A conservative size of one encoded frame (a show of busy, noisy frames at high quality stays under it)."""
    depth_factor = 1.0 if bit_depth == 8 or codec.name == "lossless" or codec.encoder == "hap" else 2.0
    return int(width * height * codec.bytes_per_pixel * depth_factor) + 4096
