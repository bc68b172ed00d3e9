"""Read the channels of an uncompressed, scanline OpenEXR file (what the capture studio writes).

OpenCV reads only an EXR's R, G, B and A channels; a multilayer render names its channels after the
view layer and the pass ('ViewLayer.DiffCol.R') and Blender writes it as a multi-part file, which
OpenCV cannot read. The capture studio writes
its multilayer renders uncompressed, so this small reader (the format's header, offset table and
scanline chunks, nothing more) is all it needs; anything else gets a clear error, not a guess.
"""
from __future__ import annotations

import struct

import numpy as np

MAGIC = 20000630
_PIXEL_TYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_TILED, _LONG_NAMES, _NON_IMAGE, _MULTIPART = 0x200, 0x400, 0x800, 0x1000


class ExrError(ValueError):
    pass


def _cstring(data: bytes, pos: int) -> tuple[str, int]:
    end = data.index(b"\0", pos)
    return data[pos:end].decode("latin-1"), end + 1


def _channels(value: bytes) -> list[tuple[str, np.dtype, int, int]]:
    out, pos = [], 0
    while value[pos:pos + 1] != b"\0":
        name, pos = _cstring(value, pos)
        pixel_type, _linear, xs, ys = struct.unpack_from("<iB3xii", value, pos)
        pos += 16
        if pixel_type not in _PIXEL_TYPES:
            raise ExrError(f"channel {name!r} has an unknown pixel type {pixel_type}")
        out.append((name, _PIXEL_TYPES[pixel_type], xs, ys))
    return out


def _header(data: bytes, pos: int) -> tuple[dict, int]:
    header = {}
    while data[pos:pos + 1] != b"\0":
        name, pos = _cstring(data, pos)
        _type, pos = _cstring(data, pos)
        size = struct.unpack_from("<i", data, pos)[0]
        pos += 4
        header[name] = data[pos:pos + size]
        pos += size
    return header, pos + 1


def _contiguous_rows(data, channels, width, height, ymin, offsets, row_bytes, prefix):
    """The common case at numpy speed: every scanline in order, back to back, with one pixel type.
    None when the file is laid out otherwise (the general loop reads it then)."""
    dtypes = {dtype for _, dtype, *_ in channels}
    chunk = prefix + 8 + row_bytes
    if len(dtypes) != 1 or height == 0:
        return None
    start = int(offsets[0])
    if not np.array_equal(offsets.astype(np.int64), start + chunk * np.arange(height, dtype=np.int64)):
        return None
    if start + chunk * height > len(data):
        raise ExrError("the file is cut short")
    rows = np.frombuffer(data, np.uint8, count=chunk * height, offset=start).reshape(height, chunk)
    ys = rows[:, prefix:prefix + 4].copy().view("<i4")[:, 0]
    if not np.array_equal(ys, ymin + np.arange(height)):
        return None
    dtype = dtypes.pop()
    pixels = rows[:, prefix + 8:].copy().view(dtype).reshape(height, len(channels), width)
    return {name: pixels[:, i].astype(np.float32) for i, (name, *_) in enumerate(channels)}


def read_exr_channels(path) -> dict[str, np.ndarray]:
    """{channel name: (H, W) float32} of an uncompressed scanline EXR, single- or multi-part
    (Blender writes its multilayer files as multi-part)."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 8 or struct.unpack_from("<i", data, 0)[0] != MAGIC:
        raise ExrError(f"{path} is not an OpenEXR file")
    flags = struct.unpack_from("<i", data, 4)[0]
    if flags & (_TILED | _NON_IMAGE):
        raise ExrError(f"{path}: tiled or deep EXR files are not supported")
    multipart = bool(flags & _MULTIPART)
    headers, pos = [], 8
    while True:
        header, pos = _header(data, pos)
        headers.append(header)
        if not multipart or data[pos:pos + 1] == b"\0":
            break
    pos += 1 if multipart else 0
    parts = []
    for header in headers:
        if header.get("compression", b"\0")[0] != 0:
            raise ExrError(f"{path} is compressed; the capture studio writes its passes uncompressed")
        if b"tile" in header.get("type", b"scanlineimage"):
            raise ExrError(f"{path}: tiled or deep EXR files are not supported")
        channels = _channels(header["channels"])
        if any(xs != 1 or ys != 1 for _, _, xs, ys in channels):
            raise ExrError(f"{path} has subsampled channels")
        xmin, ymin, xmax, ymax = struct.unpack("<iiii", header["dataWindow"])
        width, height = xmax - xmin + 1, ymax - ymin + 1
        # uncompressed: one scanline per chunk
        offsets = np.frombuffer(data, "<u8", count=height, offset=pos)
        pos += 8 * height
        parts.append((channels, width, height, ymin, offsets))
    out = {}
    for index, (channels, width, height, ymin, offsets) in enumerate(parts):
        row_bytes = sum(dtype.itemsize for _, dtype, *_ in channels) * width
        fast = _contiguous_rows(data, channels, width, height, ymin, offsets, row_bytes, 4 if multipart else 0)
        if fast is not None:
            out.update(fast)
            continue
        planes = {name: np.empty((height, width), np.float32) for name, *_ in channels}
        for offset in offsets:
            at = int(offset)
            if multipart:
                if struct.unpack_from("<i", data, at)[0] != index:
                    raise ExrError(f"{path}: a chunk of part {index} names another part")
                at += 4
            y, size = struct.unpack_from("<ii", data, at)
            if size != row_bytes:
                raise ExrError(f"{path}: a scanline holds {size} bytes, expected {row_bytes}")
            start = at + 8
            for name, dtype, *_ in channels:
                planes[name][y - ymin] = np.frombuffer(data, dtype, count=width, offset=start)
                start += dtype.itemsize * width
        out.update(planes)
    return out


def pass_rgb(channels: dict[str, np.ndarray], *names: str) -> np.ndarray:
    """The (H, W, 3) RGB (or XYZ, for a vector) of the pass whose channels end with '<name>.R/.G/.B', for
    the first of `names` found (a pass's spellings: Blender 5 writes 'Diffuse Color', 4.x 'DiffCol')."""
    for name in names:
        found = {}
        for channel in channels:
            stem, _, component = channel.rpartition(".")
            if stem == name or stem.endswith("." + name):
                found[component] = channel
        for components in ("RGB", "XYZ"):  # a colour, or a vector (the Normal pass)
            if all(c in found for c in components):
                return np.stack([channels[found[c]] for c in components], axis=-1)
    raise ExrError(f"no {' or '.join(names)} pass (channels: {', '.join(sorted(channels))})")

