"""The uncompressed scanline EXR reader the capture studio reads its multilayer passes with."""
import struct

import numpy as np
import pytest

from lapig.lapig_core.common.exr import ExrError, pass_rgb, read_exr_channels


def _attribute(name, kind, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def _write_exr(path, channels: dict, compression=0, pixel_type=2, rows_reversed=False):
    """A scanline EXR as the format's spec lays it out (channels sorted by name, one line per chunk)."""
    names = sorted(channels)
    h, w = next(iter(channels.values())).shape
    dtype = {1: "<f2", 2: "<f4"}[pixel_type]
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", pixel_type, 0, 1, 1) for n in names) + b"\0"
    header = (struct.pack("<ii", 20000630, 2) + _attribute("channels", "chlist", chlist)
              + _attribute("compression", "compression", bytes([compression]))
              + _attribute("dataWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1))
              + _attribute("displayWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1))
              + _attribute("lineOrder", "lineOrder", b"\0") + b"\0")
    rows = [struct.pack("<ii", y, w * len(names) * np.dtype(dtype).itemsize)
            + b"".join(np.asarray(channels[n][y], dtype).tobytes() for n in names) for y in range(h)]
    order = list(range(h))[::-1] if rows_reversed else list(range(h))  # a writer may lay lines out as it likes
    offsets, pos = [0] * h, len(header) + 8 * h
    for y in order:
        offsets[y] = pos
        pos += len(rows[y])
    path.write_bytes(header + struct.pack(f"<{h}Q", *offsets) + b"".join(rows[y] for y in order))


def test_reads_every_channel_of_a_multilayer_file(tmp_path):
    rng = np.random.default_rng(0)
    planes = {f"ViewLayer.{p}.{c}": rng.random((5, 7)).astype(np.float32)
              for p in ("Combined", "DiffCol") for c in "RGB"}
    path = tmp_path / "passes.exr"
    _write_exr(path, planes)
    read = read_exr_channels(path)
    assert set(read) == set(planes)
    for name, plane in planes.items():
        assert np.array_equal(read[name], plane)
    albedo = pass_rgb(read, "Diffuse Color", "DiffCol")
    assert albedo.shape == (5, 7, 3)
    assert np.array_equal(albedo[..., 1], planes["ViewLayer.DiffCol.G"])


def test_scanlines_out_of_order_and_mixed_pixel_types_read_the_same(tmp_path):
    rng = np.random.default_rng(1)
    planes = {c: rng.random((6, 5)).astype(np.float32) for c in "RGB"}
    path = tmp_path / "reversed.exr"
    _write_exr(path, planes, rows_reversed=True)
    read = read_exr_channels(path)
    for name, plane in planes.items():
        assert np.array_equal(read[name], plane)


def test_half_floats_read_as_float32(tmp_path):
    plane = np.linspace(0, 1, 12, dtype=np.float32).reshape(3, 4)
    path = tmp_path / "half.exr"
    _write_exr(path, {"R": plane, "G": plane, "B": plane}, pixel_type=1)
    assert np.allclose(read_exr_channels(path)["G"], plane, atol=1e-3)


def test_what_it_cannot_read_gets_a_clear_error(tmp_path):
    path = tmp_path / "zip.exr"
    _write_exr(path, {"R": np.zeros((2, 2))}, compression=3)
    with pytest.raises(ExrError, match="compressed"):
        read_exr_channels(path)
    not_exr = tmp_path / "x.exr"
    not_exr.write_bytes(b"PNG....")
    with pytest.raises(ExrError, match="not an OpenEXR"):
        read_exr_channels(not_exr)
    plain = tmp_path / "plain.exr"
    _write_exr(plain, {c: np.zeros((2, 2)) for c in "RGB"})
    with pytest.raises(ExrError, match="no Diffuse Color or DiffCol pass"):
        pass_rgb(read_exr_channels(plain), "Diffuse Color", "DiffCol")
