# SPDX-License-Identifier: GPL-3.0-or-later
"""The H.264 and H.265 level a video is tagged with, chosen from its size and frame rate (the specs' tables).

    h264_level(width, height, rate) -> Level     H.264 (ITU-T H.264 Table A-1: MaxFS, MaxMBPS, MaxBR, MaxCPB)
    h265_level(width, height, rate) -> Level     H.265 Main tier (ITU-T H.265 Table A.8: MaxLumaPs, MaxLumaSr, ...)
    LevelError                                   no level takes that size at that rate: one line with the reason

A level is a promise to the decoder: a hardware decoder that takes 4.1 plays every 4.1 file. The encoder is told
the level and the bitrate caps that come with it (VBV), so the tag is true.

How the level is picked:
- the lowest whose frame size (and each side) and frame rate limits hold;
- of levels with the same frame limits, the highest (H.264 4 and 4.1 differ only in bitrate: 1080p30 is 4.1, the
  level every playback machine takes, with 2.5 times the bitrate of 4);
- never below 3 (3.0): every playback decoder takes it, and the bitrate caps of the levels under it starve the
  high-quality encode a projector image needs (level 1 allows 64 kbit/s).
So 1080p30 is H.264 4.1, 1080p60 4.2, 4K30 5.1, 4K60 5.2; H.265 1080p30 4, 4K30 5.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction


class LevelError(ValueError):
    """No level of the codec takes the frame size at the frame rate."""


@dataclass(frozen=True)
class Level:
    name: str  # as players show it: "4.1"
    idc: int  # the number in the stream: 41
    max_bitrate_kbps: int  # the VBV cap given to the encoder (for H.264 High: 1.25 times the table's MaxBR)
    max_buffer_kbit: int  # the VBV buffer (the same factor)


# (name, MaxMBPS macroblocks/s, MaxFS macroblocks, MaxBR kbit/s, MaxCPB kbit), Table A-1 (level 1b left out)
_H264 = (
    ("1", 1485, 99, 64, 175), ("1.1", 3000, 396, 192, 500), ("1.2", 6000, 396, 384, 1000),
    ("1.3", 11880, 396, 768, 2000), ("2", 11880, 396, 2000, 2000), ("2.1", 19800, 792, 4000, 4000),
    ("2.2", 20250, 1620, 4000, 4000), ("3", 40500, 1620, 10000, 10000), ("3.1", 108000, 3600, 14000, 14000),
    ("3.2", 216000, 5120, 20000, 20000), ("4", 245760, 8192, 20000, 25000), ("4.1", 245760, 8192, 50000, 62500),
    ("4.2", 522240, 8704, 50000, 62500), ("5", 589824, 22080, 135000, 135000),
    ("5.1", 983040, 36864, 240000, 240000), ("5.2", 2073600, 36864, 240000, 240000),
    ("6", 4177920, 139264, 240000, 240000), ("6.1", 8355840, 139264, 480000, 480000),
    ("6.2", 16711680, 139264, 800000, 800000),
)
_H264_HIGH_FACTOR = 1.25  # cpbBrVclFactor 1250 for High (and High 10: 3.0; not used here) against 1000
# (name, MaxLumaSr samples/s, MaxLumaPs samples, Main tier MaxBR kbit/s, Main tier MaxCPB kbit), Tables A.8 / A.9
_H265 = (
    ("1", 552960, 36864, 128, 350), ("2", 3686400, 122880, 1500, 1500), ("2.1", 7372800, 245760, 3000, 3000),
    ("3", 16588800, 552960, 6000, 6000), ("3.1", 33177600, 983040, 10000, 10000),
    ("4", 66846720, 2228224, 12000, 12000), ("4.1", 133693440, 2228224, 20000, 20000),
    ("5", 267386880, 8912896, 25000, 25000), ("5.1", 534773760, 8912896, 40000, 40000),
    ("5.2", 1069547520, 8912896, 60000, 60000), ("6", 1069547520, 35651584, 60000, 60000),
    ("6.1", 2139095040, 35651584, 120000, 120000), ("6.2", 4278190080, 35651584, 240000, 240000),
)
_FLOOR = "3"


def _idc(name: str) -> int:
    major, _, minor = name.partition(".")
    return int(major) * 10 + int(minor or 0)


def _pick(table, fits, what: str, width: int, height: int, rate: Fraction, factor: float, unit: str,
          demand: str) -> Level:
    names = [row[0] for row in table]
    start = names.index(_FLOOR)
    for i in range(start, len(table)):
        if fits(table[i]):
            j = i
            while j + 1 < len(table) and table[j + 1][1:3] == table[i][1:3]:
                j += 1  # the same frame limits, more bitrate
            name, _, _, br, cpb = table[j]
            return Level(name, _idc(name), int(br * factor), int(cpb * factor))
    top = table[-1]
    raise LevelError(f"{width}x{height} at {float(rate):g} fps is beyond {what}'s highest level {top[0]} "
                     f"({demand}, the level takes {top[1]:,} {unit}/s and frames of {top[2]:,} {unit}): "
                     f"lower the size or the frame rate, or choose prores422hq, prores4444 or hap")


def h264_level(width: int, height: int, rate) -> Level:
    """The H.264 level (High profile caps) for frames of width x height at `rate` frames a second."""
    rate = Fraction(rate)
    mbs_w, mbs_h = math.ceil(width / 16), math.ceil(height / 16)
    frame_mbs = mbs_w * mbs_h
    mbps = frame_mbs * rate

    def fits(row):  # A.3.1: each side at most sqrt(8 MaxFS) macroblocks
        _, max_mbps, max_fs, _, _ = row
        side = math.sqrt(8 * max_fs)
        return frame_mbs <= max_fs and mbs_w <= side and mbs_h <= side and mbps <= max_mbps

    return _pick(_H264, fits, "H.264", width, height, rate, _H264_HIGH_FACTOR, "macroblocks",
                 f"{frame_mbs:,} macroblocks a frame, {float(mbps):,.0f} a second")


def h265_level(width: int, height: int, rate) -> Level:
    """The H.265 level (Main tier caps) for frames of width x height at `rate` frames a second."""
    rate = Fraction(rate)
    samples = width * height
    per_second = samples * rate

    def fits(row):  # A.4.1: each side at most sqrt(8 MaxLumaPs)
        _, max_sr, max_ps, _, _ = row
        side = math.sqrt(8 * max_ps)
        return samples <= max_ps and width <= side and height <= side and per_second <= max_sr

    return _pick(_H265, fits, "H.265", width, height, rate, 1.0, "samples",
                 f"{samples:,} samples a frame, {float(per_second):,.0f} a second")
