# SPDX-License-Identifier: GPL-3.0-or-later
"""Read an exported video back as a media server's decoder would see it, with a decoder other than the writer.

    decode_with_ffmpeg(path, ffmpeg=None) -> (frames, fps)  the system FFmpeg (honours the colour tags: BT.709,
                                                            limited range), strict (-xerror); RGB uint8 frames
    probe(path, ffprobe=None) -> dict                        ffprobe's stream: codec, profile, pix_fmt, level,
                                                            colour tags, frame count, rate, duration, keyframes
    decode_with_opencv(path) -> (frames, fps)                OpenCV's FFmpeg reader: it ignores the colour tags
                                                            (assumes BT.601), so only RGB codecs read right
    system_tool(name) -> path or None                        ffmpeg / ffprobe on PATH ($LAPIG_FFMPEG's folder first)

The round-trip checks of the show's export (its tests, `bench video`) compare these frames with the source; the
writer is PyAV (or the system FFmpeg through a pipe, for HAP), so a frame it mislabels shows up."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from fractions import Fraction

import cv2
import numpy as np


def system_tool(name: str) -> str | None:
    """`ffmpeg` or `ffprobe`: beside $LAPIG_FFMPEG where that is set, else on PATH."""
    explicit = os.environ.get("LAPIG_FFMPEG")
    if explicit:
        beside = os.path.join(os.path.dirname(shutil.which(explicit) or explicit), name)
        if os.path.isfile(beside):
            return beside
    return shutil.which(name)


def probe(path, ffprobe: str | None = None) -> dict:
    """The first video stream as ffprobe sees it, with every frame's key flag counted from the packets."""
    tool = ffprobe or system_tool("ffprobe")
    if tool is None:
        raise FileNotFoundError("ffprobe is not installed")
    out = subprocess.run([tool, "-v", "error", "-select_streams", "v:0", "-show_streams",
                          "-show_format", "-show_entries", "packet=pts_time,flags", "-of", "json", str(path)],
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    if out.returncode != 0:
        raise ValueError(f"ffprobe refused {path}: {out.stderr.strip()}")
    info = json.loads(out.stdout)
    stream = info["streams"][0]
    packets = info.get("packets", [])
    keys = [i for i, p in enumerate(packets) if "K" in p.get("flags", "")]
    rate = Fraction(stream["r_frame_rate"])
    return {**stream, "frames": len(packets), "rate": rate, "avg_rate": Fraction(stream["avg_frame_rate"]),
            "keyframes": keys, "duration_s": float(info["format"].get("duration", "nan")),
            "stderr": out.stderr.strip()}


def decode_with_ffmpeg(path, ffmpeg: str | None = None, size=None) -> tuple[list[np.ndarray], float]:
    """Every frame as (H, W, 3) uint8 RGB, decoded strictly (-xerror: any decode error fails) by the system FFmpeg,
    which converts with the matrix and range the file is tagged with; and the stream's frame rate."""
    tool = ffmpeg or system_tool("ffmpeg")
    if tool is None:
        raise FileNotFoundError("ffmpeg is not installed")
    info = probe(path, system_tool("ffprobe"))
    width, height = size or (int(info["width"]), int(info["height"]))
    out = subprocess.run([tool, "-v", "error", "-xerror", "-i", str(path), "-map", "0:v:0",
                          "-sws_flags", "bilinear+accurate_rnd+full_chroma_int", "-f", "rawvideo", "-pix_fmt", "rgb24",
                          "pipe:1"], stdin=subprocess.DEVNULL, capture_output=True, timeout=300)
    if out.returncode != 0 or out.stderr.strip():
        raise ValueError(f"ffmpeg could not decode {path} cleanly: {out.stderr.decode('utf-8', 'replace').strip()}")
    frames = np.frombuffer(out.stdout, np.uint8).reshape(-1, height, width, 3)
    return list(frames), float(info["rate"])


def decode_with_opencv(path) -> tuple[list[np.ndarray], float]:
    """Every frame of the video at path, (H, W, 3) uint8 RGB in order, and the frame rate its header gives."""
    cap = cv2.VideoCapture(str(path))
    frames = []
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            frames.append(frame[:, :, ::-1])
        fps = cap.get(cv2.CAP_PROP_FPS)
    finally:
        cap.release()
    return frames, fps
