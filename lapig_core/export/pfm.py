# SPDX-License-Identifier: GPL-3.0-or-later
"""Portable Float Map (PFM) files: encode and decode, numpy in and out.

The netpbm format (netpbm.sourceforge.net/doc/pfm.html): a text header "PF" (3 channels) or "Pf"
(1 channel), the width and height, and a scale whose sign gives the byte order (negative: little
endian), then 32-bit IEEE floats row by row, the bottom row first. MPCDI stores its geometry warps
and distortion maps in it (VESA MPCDI 2.0 section 3.6.1).

In memory, arrays are in image order (row 0 at the top), as every other image in LAPIG; the row flip
to the file's bottom-to-top order happens here and only here. We write little-endian with scale -1;
we read either byte order. Values (NaN included) round-trip bit for bit for float32 input.
"""
from __future__ import annotations

import numpy as np

_MAGIC_CHANNELS = {b"PF": 3, b"Pf": 1}
_WHITESPACE = b" \t\r\n"


def encode_pfm(values, scale_text: str = "-1.0") -> bytes:
    """The PFM file of an (H, W, 3) array ("PF") or an (H, W) array ("Pf"), row 0 at the top.

    Values are stored as float32 (float64 input is rounded once, here). scale_text: the third header line
    (-1: little-endian); MPCDI 1.0's reference reader wants it as "-1.000000". Raises ValueError (one line)
    for any other shape or a non-numeric array.
    """
    array = np.asarray(values)
    if not np.issubdtype(array.dtype, np.number) or np.issubdtype(array.dtype, np.complexfloating):
        raise ValueError(f"a PFM holds real numbers, got an array of {array.dtype}")
    if array.ndim == 3 and array.shape[2] == 3:
        magic = b"PF"
    elif array.ndim == 2:
        magic = b"Pf"
    else:
        raise ValueError(f"a PFM holds an (H, W, 3) or (H, W) array, got shape {array.shape}")
    height, width = array.shape[:2]
    if height < 1 or width < 1:
        raise ValueError(f"a PFM needs at least one pixel, got shape {array.shape}")
    header = magic + b"\n" + f"{width} {height}\n{scale_text}\n".encode("ascii")
    rows_bottom_first = np.ascontiguousarray(array[::-1], dtype="<f4")
    return header + rows_bottom_first.tobytes()


def _header_fields(data: bytes, count: int) -> tuple[list[bytes], int]:
    """The first `count` whitespace-separated fields and the offset just past the single whitespace
    byte that ends the last one (netpbm: exactly one whitespace character after the scale)."""
    fields: list[bytes] = []
    pos = 0
    while len(fields) < count:
        while pos < len(data) and data[pos] in _WHITESPACE:
            pos += 1
        start = pos
        while pos < len(data) and data[pos] not in _WHITESPACE:
            pos += 1
        if start == pos or pos >= len(data) or pos - start > 32:
            raise ValueError("not a PFM file: its header is truncated or malformed")
        fields.append(data[start:pos])
        pos += 1  # the one whitespace byte after the field
    return fields, pos


def decode_pfm(data: bytes) -> np.ndarray:
    """The float32 array of a PFM file: (H, W, 3) for "PF", (H, W) for "Pf", row 0 at the top.

    Raises ValueError (one line) for a bad magic number, header, byte order or data length.
    """
    data = bytes(data)
    magic = data[:2]
    if magic not in _MAGIC_CHANNELS:
        raise ValueError(f"not a PFM file: it starts with {magic!r}, not b'PF' or b'Pf'")
    (width_text, height_text, scale_text), offset = _header_fields(data[2:], 3)
    try:
        width, height, scale = int(width_text), int(height_text), float(scale_text)
    except ValueError:
        raise ValueError("not a PFM file: its width, height or scale is not a number") from None
    if width < 1 or height < 1:
        raise ValueError(f"PFM size {width}x{height} has no pixels")
    if scale == 0.0 or not np.isfinite(scale):
        raise ValueError(f"PFM scale {scale_text.decode('ascii', 'replace')} gives no byte order")
    channels = _MAGIC_CHANNELS[magic]
    pixels = data[2 + offset:]
    expected = width * height * channels * 4
    if len(pixels) != expected:
        raise ValueError(f"PFM {width}x{height}x{channels} needs {expected} bytes of pixels, it has {len(pixels)}")
    dtype = "<f4" if scale < 0 else ">f4"
    rows = np.frombuffer(pixels, dtype=dtype).reshape((height, width, channels) if channels == 3 else (height, width))
    return rows[::-1].astype(np.float32)  # file rows are bottom first
